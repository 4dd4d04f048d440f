//! The Heathrow interrupt controller of the PowerMac G3 "Beige" (OldWorld mac-io), as QEMU 7.2
//! emulates it (`hw/intc/heathrow_pic.c`, wired up in `hw/misc/macio/macio.c`), observed in
//! QEMU's sources:
//!
//! - The controller's registers are at mac-io + 0x0 (`macio_oldworld_realize` maps the PIC's
//!   region at offset 0 of the mac-io BAR): little-endian 32-bit words.
//! - Two banks of 32 lines. Bank 1 (lines 0..31) is at +0x20, bank 2 (lines 32..63) at +0x10
//!   (`pics[1 - (line >> 5)]`, bank n at `0x10 + 0x10 * n`). In each bank: +0x0 events
//!   (latched, read-only), +0x4 mask (read/write), +0x8 clear (write 1s to clear latched
//!   events), +0xc levels (the lines' current state, read-only).
//! - A line is latched into `events` every time its source raises it (edge lines), and the CPU's
//!   external interrupt input is `(events | levels & level_triggered) & mask`, over both banks.
//!   Only lines 20..28 of bank 1 are level-triggered (`level_triggered = 0x1ff00000`); for them
//!   a write to `clear` does nothing.
//! - A device reset (QMP `system_reset`) does NOT clear `mask` or `events` (QEMU 7.2's reset
//!   handler only sets `level_triggered`): boot code must mask everything and clear the latched
//!   events itself before it enables external interrupts.
//! - OldWorld line numbers (`include/hw/misc/macio/macio.h`): ESCC channel A (QEMU's first
//!   `-serial`) is line 0x0f, channel B 0x10, CUDA 0x12, IDE0 0x0d, IDE1 0x0e.
//!
//! [`Heathrow`] is the driver: the kernel uses one line, ESCC channel A's (the link's receive
//! interrupt), enabled only while the schedule is stopped waiting for input, so that a
//! partition's CPU time, counted with the decrementer, never includes an interrupt handler.
use crate::Bus;

/// Offset of the controller in mac-io.
pub const PIC_OFFSET: usize = 0x0;
/// ESCC channel A: the link's serial port.
pub const ESCC_A_LINE: u8 = 0x0f;
/// ESCC channel B.
pub const ESCC_B_LINE: u8 = 0x10;
/// Lines the controller has.
pub const LINES: u8 = 64;
/// Bank 1's level-triggered lines (QEMU's reset value; bank 2 has none).
pub const BANK1_LEVEL_TRIGGERED: u32 = 0x1ff0_0000;

/// Where one interrupt line lives: register offsets from the start of mac-io, and its bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PicLine {
    /// Latched events of the line's bank (read).
    pub events: usize,
    /// Mask of the line's bank (1 = enabled).
    pub mask: usize,
    /// Write the bit here to clear the latched event.
    pub clear: usize,
    /// Current line states of the bank (read).
    pub levels: usize,
    /// The line's bit in each of those registers.
    pub bit: u32,
}

impl PicLine {
    /// The registers and bit of `line` (None past the last line).
    pub const fn of(line: u8) -> Option<PicLine> {
        if line >= LINES {
            return None;
        }
        let bank_base = PIC_OFFSET + if line < 32 { 0x20 } else { 0x10 };
        Some(PicLine {
            events: bank_base,
            mask: bank_base + 0x4,
            clear: bank_base + 0x8,
            levels: bank_base + 0xc,
            bit: 1 << (line % 32),
        })
    }

    /// True if the controller latches this line on each rise (a write to `clear` then clears
    /// it); false for the level-triggered lines.
    pub const fn is_edge_triggered(line: u8) -> bool {
        line >= 32 || BANK1_LEVEL_TRIGGERED & (1 << line) == 0
    }
}

/// Register offsets (from mac-io) of both banks' mask and clear registers, for boot code that
/// masks everything and clears whatever a previous boot left latched.
pub const ALL_MASKS: [usize; 2] = [PIC_OFFSET + 0x14, PIC_OFFSET + 0x24];
pub const ALL_CLEARS: [usize; 2] = [PIC_OFFSET + 0x18, PIC_OFFSET + 0x28];

/// The controller, in mac-io at `base` (the mac-io BAR), over register access `B`.
pub struct Heathrow<B: Bus> {
    bus: B,
    /// mac-io's base: [`PicLine`]'s offsets are from there.
    base: usize,
}

impl<B: Bus> Heathrow<B> {
    /// The controller of the mac-io mapped at `mac_io_base` (no register access).
    #[inline]
    pub const fn new(bus: B, mac_io_base: usize) -> Self {
        Self {
            bus,
            base: mac_io_base,
        }
    }

    /// Heathrow's registers are little-endian: the 750 stores big-endian words.
    #[inline]
    fn write(&self, offset: usize, value: u32) {
        self.bus.write32(self.base + offset, value.swap_bytes())
    }

    #[inline]
    fn read(&self, offset: usize) -> u32 {
        self.bus.read32(self.base + offset).swap_bytes()
    }

    /// Mask every line and clear whatever is latched. Boot only (before anything is enabled): a
    /// warm reset in QEMU keeps the mask and the latched events of the previous boot.
    pub fn init(&self) {
        for (mask, clear) in ALL_MASKS.iter().zip(ALL_CLEARS.iter()) {
            self.write(*mask, 0);
            self.write(*clear, u32::MAX);
        }
    }

    /// Let `line` alone of its bank reach the CPU (true) or hold the bank back (false). An
    /// event latched while it was held back raises the interrupt as soon as it is let through.
    #[inline]
    pub fn enable_only(&self, line: PicLine, enabled: bool) {
        self.write(line.mask, if enabled { line.bit } else { 0 });
    }

    /// Clear `line`'s latched event; true if it was set.
    #[inline]
    pub fn take_event(&self, line: PicLine) -> bool {
        let pending = self.read(line.events) & line.bit != 0;
        if pending {
            self.write(line.clear, line.bit);
        }
        pending
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    use crate::mock::{Access, MockBus};

    const BASE: usize = crate::pci::MAC_IO_BASE;

    fn escc_a() -> PicLine {
        PicLine::of(ESCC_A_LINE).unwrap()
    }

    #[test]
    fn init_masks_both_banks_and_clears_every_latched_event_little_endian() {
        let bus = MockBus::new();
        Heathrow::new(&bus, BASE).init();
        assert_eq!(
            bus.take_log(),
            std::vec![
                Access::W32(BASE + 0x14, 0),
                Access::W32(BASE + 0x18, u32::MAX),
                Access::W32(BASE + 0x24, 0),
                Access::W32(BASE + 0x28, u32::MAX),
            ]
        );
    }

    #[test]
    fn enabling_the_link_line_writes_its_bit_byte_swapped_to_bank_1_mask() {
        let bus = MockBus::new();
        let pic = Heathrow::new(&bus, BASE);
        pic.enable_only(escc_a(), true);
        pic.enable_only(escc_a(), false);
        // Bit 15 is 0x0000_8000; little-endian on the bus: 0x0080_0000.
        assert_eq!(
            bus.take_log(),
            std::vec![
                Access::W32(BASE + 0x24, 0x0080_0000),
                Access::W32(BASE + 0x24, 0),
            ]
        );
    }

    #[test]
    fn take_event_acks_only_a_latched_line_and_only_its_bit() {
        let bus = MockBus::new();
        // Line 15 and line 0 latched; then only line 0.
        bus.script(BASE + 0x20, &[(0x8001u32).swap_bytes(), 1u32.swap_bytes()]);
        let pic = Heathrow::new(&bus, BASE);
        assert!(pic.take_event(escc_a()));
        assert_eq!(
            bus.writes(),
            std::vec![Access::W32(BASE + 0x28, 0x0080_0000)]
        );
        let _ = bus.take_log();
        assert!(!pic.take_event(escc_a()));
        assert!(bus.writes().is_empty());
    }

    #[test]
    fn the_escc_a_line_is_bit_15_of_bank_1_at_0x20() {
        let line = PicLine::of(ESCC_A_LINE).unwrap();
        assert_eq!(
            line,
            PicLine {
                events: 0x20,
                mask: 0x24,
                clear: 0x28,
                levels: 0x2c,
                bit: 1 << 15,
            }
        );
        assert!(PicLine::is_edge_triggered(ESCC_A_LINE));
    }

    #[test]
    fn lines_32_and_up_are_in_bank_2_at_0x10() {
        let line = PicLine::of(40).unwrap();
        assert_eq!(
            (line.events, line.mask, line.clear, line.levels),
            (0x10, 0x14, 0x18, 0x1c)
        );
        assert_eq!(line.bit, 1 << 8);
        assert_eq!(PicLine::of(63).unwrap().bit, 1 << 31);
        assert_eq!(PicLine::of(64), None);
    }

    #[test]
    fn only_lines_20_to_28_are_level_triggered() {
        let level: std::vec::Vec<u8> = (0..LINES)
            .filter(|&l| !PicLine::is_edge_triggered(l))
            .collect();
        assert_eq!(level, (20..=28).collect::<std::vec::Vec<u8>>());
    }

    #[test]
    fn the_boot_clearing_covers_both_banks() {
        for line in [0u8, ESCC_A_LINE, ESCC_B_LINE, 31, 32, 63] {
            let l = PicLine::of(line).unwrap();
            assert!(ALL_MASKS.contains(&l.mask));
            assert!(ALL_CLEARS.contains(&l.clear));
        }
    }
}
