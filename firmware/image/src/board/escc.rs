//! ESCC (Zilog 8530) channel A: the link's serial port (driver: `drv_g3beige::escc`).
//!
//! The channel belongs to the kernel (`kernel::link`), which moves the link's bytes for the I/O
//! partition: transmit polled, an interrupt (Heathrow line 0x0f) for every received character.
use drv_g3beige::bus::Mmio;
use drv_g3beige::escc::Escc;

/// Channel A of the ESCC over the kernel's MMIO. Zero-sized.
pub type EsccChannelA = Escc<Mmio>;

/// Reset and configure the channel. Boot only, after `pci::init_mac_io`.
pub fn init() -> EsccChannelA {
    Escc::init(super::kernel_mmio())
}

/// Kernel only (MMU off): the channel [`init`] set up at boot.
#[inline]
pub fn kernel_channel() -> EsccChannelA {
    Escc::attach(super::kernel_mmio())
}
