//! The Heathrow interrupt controller in mac-io (see `kernel_logic::heathrow` for its registers
//! and the QEMU behaviour they were taken from). The kernel uses one line: ESCC channel A's,
//! the link's receive interrupt. It is enabled only while the schedule is stopped waiting for
//! input, so a partition's CPU time, counted with the decrementer, never includes an interrupt
//! handler.
use kernel_logic::heathrow::{PicLine, ALL_CLEARS, ALL_MASKS, ESCC_A_LINE};

use super::{mmio_read32, mmio_write32, pci::MAC_IO_BASE};

const ESCC_A: PicLine = match PicLine::of(ESCC_A_LINE) {
    Some(line) => line,
    None => panic!("the ESCC line is a Heathrow line"),
};

/// Heathrow's registers are little-endian: the 750 stores big-endian words.
fn write(offset: usize, value: u32) {
    // SAFETY:
    // 1. mac-io is mapped at MAC_IO_BASE (`pci::init_mac_io` ran at boot; the kernel runs with
    //    the MMU off, where the physical address is the device).
    // 2. `offset` is one of the controller's 4-byte aligned registers (from `PicLine`).
    unsafe { mmio_write32(MAC_IO_BASE + offset, value.swap_bytes()) }
}

fn read(offset: usize) -> u32 {
    // SAFETY: as in `write`.
    unsafe { mmio_read32(MAC_IO_BASE + offset).swap_bytes() }
}

/// Mask every line and clear whatever is latched. Boot only (before anything is enabled): a
/// warm reset in QEMU keeps the mask and the latched events of the previous boot.
pub fn init() {
    for (mask, clear) in ALL_MASKS.iter().zip(ALL_CLEARS.iter()) {
        write(*mask, 0);
        write(*clear, u32::MAX);
    }
}

/// Let the link's receive interrupt reach the CPU (true) or hold it back (false). A receive
/// event latched while it was held back raises the interrupt as soon as it is let through.
pub fn enable_link_interrupt(enabled: bool) {
    write(ESCC_A.mask, if enabled { ESCC_A.bit } else { 0 });
}

/// Clear the link's latched receive event; true if it was set. Done before the UART is drained,
/// so that a byte arriving after the drain latches a new event.
pub fn take_link_event() -> bool {
    let pending = read(ESCC_A.events) & ESCC_A.bit != 0;
    if pending {
        write(ESCC_A.clear, ESCC_A.bit);
    }
    pending
}
