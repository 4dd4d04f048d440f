//! The g3beige board's drivers as the kernel uses them: the register logic is in `drv-g3beige`
//! (`firmware/drv`, tested on the host against mocks); here it is bound to memory-mapped I/O
//! and the timebase register, and to the board's addresses.
pub mod escc;
pub mod heathrow;
pub mod pci;
pub mod timebase;

use drv_g3beige::bus::Mmio;

/// The board's registers, for the kernel.
///
/// Contract (kernel only): the kernel runs with the MMU off, where a device's physical address
/// is the device; mac-io's devices (the ESCC, the PIC) are used only after `pci::init_mac_io`
/// mapped mac-io at `drv_g3beige::pci::MAC_IO_BASE` at boot.
#[inline]
pub fn kernel_mmio() -> Mmio {
    // SAFETY: see the contract above; every caller is kernel code.
    unsafe { Mmio::new() }
}
