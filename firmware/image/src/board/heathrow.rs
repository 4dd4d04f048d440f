//! The Heathrow interrupt controller in mac-io (driver and register map:
//! `drv_g3beige::heathrow`). The kernel uses one line: ESCC channel A's, the link's receive
//! interrupt. It is enabled only while the schedule is stopped waiting for input, so a
//! partition's CPU time, counted with the decrementer, never includes an interrupt handler.
use drv_g3beige::bus::Mmio;
use drv_g3beige::heathrow::{Heathrow, PicLine, ESCC_A_LINE};
use drv_g3beige::pci::MAC_IO_BASE;

const ESCC_A: PicLine = match PicLine::of(ESCC_A_LINE) {
    Some(line) => line,
    None => panic!("the ESCC line is a Heathrow line"),
};

#[inline]
fn pic() -> Heathrow<Mmio> {
    Heathrow::new(super::kernel_mmio(), MAC_IO_BASE)
}

/// Mask every line and clear whatever is latched. Boot only (before anything is enabled): a
/// warm reset in QEMU keeps the mask and the latched events of the previous boot.
pub fn init() {
    pic().init();
}

/// Let the link's receive interrupt reach the CPU (true) or hold it back (false). A receive
/// event latched while it was held back raises the interrupt as soon as it is let through.
pub fn enable_link_interrupt(enabled: bool) {
    pic().enable_only(ESCC_A, enabled);
}

/// Clear the link's latched receive event; true if it was set. Done before the UART is drained,
/// so that a byte arriving after the drain latches a new event.
pub fn take_link_event() -> bool {
    pic().take_event(ESCC_A)
}
