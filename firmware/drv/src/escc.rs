//! ESCC (Zilog 8530) channel A, QEMU's first `-serial`: the link to the host. mac-io + 0x13000,
//! register stride 0x10: channel A control at +0x20, data at +0x30.
//!
//! The channel belongs to the kernel, which moves the link's bytes for the I/O partition.
//! Transmit is polled; the channel raises its interrupt (Heathrow line 0x0f) for every received
//! character, and the kernel drains it with [`Escc::try_read_byte`].
//!
//! Traits: `embedded-io`'s [`Write`] / [`WriteReady`] (blocking byte writes, waiting for the
//! transmit buffer) and [`Read`] / [`ReadReady`] (a read waits for the first byte, then takes
//! what is there); `embedded-hal-nb`'s `serial::Read` / `serial::Write` (one byte, or
//! `WouldBlock`).
//!
//! What QEMU 7.2's `hw/char/escc.c` does, observed in its source:
//! - It ignores the baud rate and holds back the next received byte until the guest has read the
//!   previous one (`serial_can_receive` is 0 while RR0's "character available" is set), so a
//!   receiver that drains when it can loses nothing: the host's bytes wait in the pty.
//! - The channel's interrupt line is high while a received character waits and WR1 enables
//!   receive interrupts ("on first" or "on all characters"); reading the data register lowers it
//!   and asks the chardev for the next byte (`qemu_chr_fe_accept_input`), which arrives after a
//!   turn of QEMU's main loop and raises the line again.
//! - The master interrupt enable (WR9 MIE) is not modelled (writes of WR9 without reset bits are
//!   dropped), but a break condition would hold the line high for good unless WR15 disables break
//!   interrupts, which after a channel reset it enables: WR15 is cleared here.
use core::convert::Infallible;

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};

use crate::pci::MAC_IO_BASE;
use crate::Bus;

pub const ESCC_BASE: usize = MAC_IO_BASE + 0x13000;
pub const CHANNEL_A_CONTROL: usize = ESCC_BASE + 0x20;
pub const CHANNEL_A_DATA: usize = ESCC_BASE + 0x30;

/// RR0: a received character is available.
pub const RR0_RX_AVAILABLE: u8 = 0x01;
/// RR0: the transmit buffer is empty.
pub const RR0_TX_EMPTY: u8 = 0x04;
/// RR1: a received character was lost (receiver overrun).
pub const RR1_RX_OVERRUN: u8 = 0x20;
/// WR0 command: reset the error latches (RR1).
pub const WR0_ERROR_RESET: u8 = 0x30;

/// Register set-up, in order: WR9 reset channel A; WR4 x16 clock, 1 stop bit, no parity; WR3
/// receiver on, 8 bits; WR5 transmitter on, 8 bits, DTR/RTS; WR1 receive interrupt on every
/// character (no transmit or external/status interrupts); WR15 no external/status sources (no
/// break interrupt); WR9 master interrupt enable.
pub const INIT_SEQUENCE: [(u8, u8); 7] = [
    (9, 0x80),
    (4, 0x44),
    (3, 0xc1),
    (5, 0xea),
    (1, 0x10),
    (15, 0x00),
    (9, 0x08),
];

/// Channel A of the ESCC over register access `B`.
pub struct Escc<B: Bus> {
    bus: B,
}

impl<B: Bus> Escc<B> {
    /// Reset and configure channel A: 8 data bits, 1 stop bit, no parity, x16 clock; RX and TX
    /// on; an interrupt for every received character. mac-io must be mapped.
    pub fn init(bus: B) -> Self {
        for (reg, value) in INIT_SEQUENCE {
            bus.write8(CHANNEL_A_CONTROL, reg);
            bus.write8(CHANNEL_A_CONTROL, value);
        }
        // QEMU stops polling the host side of the serial port while RX is disabled (as it is
        // after every reset) and only starts again when the guest reads the data register.
        // Enabling RX through WR3 does not wake it, so without this read the first byte from the
        // host waits for an unrelated QEMU timer (about 1 s at power-on, indefinitely after a
        // system_reset). Nothing can be pending yet: the host sends only after our Hello.
        if bus.read8(CHANNEL_A_CONTROL) & RR0_RX_AVAILABLE == 0 {
            let _ = bus.read8(CHANNEL_A_DATA);
        }
        Self { bus }
    }

    /// The channel [`Escc::init`] set up earlier (no register access).
    #[inline]
    pub const fn attach(bus: B) -> Self {
        Self { bus }
    }

    #[inline]
    fn status(&self) -> u8 {
        self.bus.read8(CHANNEL_A_CONTROL)
    }

    /// Take one received byte if there is one.
    #[inline]
    pub fn try_read_byte(&mut self) -> Option<u8> {
        if self.status() & RR0_RX_AVAILABLE != 0 {
            Some(self.bus.read8(CHANNEL_A_DATA))
        } else {
            None
        }
    }

    /// True if a received character waits (it stays there).
    #[inline]
    pub fn try_peek_available(&self) -> bool {
        self.status() & RR0_RX_AVAILABLE != 0
    }

    /// True if the receiver lost a character since the last call (RR1 overrun, reset here).
    /// QEMU never overruns (it holds bytes back); a real 8530 does when it is not drained in
    /// time.
    pub fn take_overrun(&mut self) -> bool {
        // WR0 selects RR1 for the next control read, which then returns the pointer to 0, and
        // the error reset command touches only RR1's latches.
        self.bus.write8(CHANNEL_A_CONTROL, 1);
        let rr1 = self.bus.read8(CHANNEL_A_CONTROL);
        if rr1 & RR1_RX_OVERRUN != 0 {
            self.bus.write8(CHANNEL_A_CONTROL, WR0_ERROR_RESET);
            true
        } else {
            false
        }
    }

    /// Send one byte, waiting for the transmitter.
    #[inline]
    pub fn write_byte(&mut self, byte: u8) {
        while self.status() & RR0_TX_EMPTY == 0 {}
        self.bus.write8(CHANNEL_A_DATA, byte)
    }
}

impl<B: Bus> ErrorType for Escc<B> {
    type Error = Infallible;
}

impl<B: Bus> Write for Escc<B> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        for &b in buf {
            self.write_byte(b);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        while self.status() & RR0_TX_EMPTY == 0 {}
        Ok(())
    }
}

impl<B: Bus> WriteReady for Escc<B> {
    fn write_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(self.status() & RR0_TX_EMPTY != 0)
    }
}

impl<B: Bus> Read for Escc<B> {
    /// Waits for the first byte (unless `buf` is empty), then takes the bytes that are there
    /// without waiting for more.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let Some((first, rest)) = buf.split_first_mut() else {
            return Ok(0);
        };
        *first = loop {
            if let Some(b) = self.try_read_byte() {
                break b;
            }
        };
        let mut n = 1;
        for slot in rest {
            match self.try_read_byte() {
                Some(b) => *slot = b,
                None => break,
            }
            n += 1;
        }
        Ok(n)
    }
}

impl<B: Bus> ReadReady for Escc<B> {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(self.try_peek_available())
    }
}

impl<B: Bus> embedded_hal_nb::serial::ErrorType for Escc<B> {
    type Error = Infallible;
}

impl<B: Bus> embedded_hal_nb::serial::Read<u8> for Escc<B> {
    fn read(&mut self) -> embedded_hal_nb::nb::Result<u8, Infallible> {
        self.try_read_byte()
            .ok_or(embedded_hal_nb::nb::Error::WouldBlock)
    }
}

impl<B: Bus> embedded_hal_nb::serial::Write<u8> for Escc<B> {
    fn write(&mut self, word: u8) -> embedded_hal_nb::nb::Result<(), Infallible> {
        if self.status() & RR0_TX_EMPTY == 0 {
            return Err(embedded_hal_nb::nb::Error::WouldBlock);
        }
        self.bus.write8(CHANNEL_A_DATA, word);
        Ok(())
    }

    fn flush(&mut self) -> embedded_hal_nb::nb::Result<(), Infallible> {
        if self.status() & RR0_TX_EMPTY == 0 {
            Err(embedded_hal_nb::nb::Error::WouldBlock)
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec;

    use embedded_hal_nb::nb;

    use super::*;
    use crate::mock::{Access, MockBus};

    const C: usize = CHANNEL_A_CONTROL;
    const D: usize = CHANNEL_A_DATA;

    #[test]
    fn registers_are_at_mac_io_0x13020_and_0x13030() {
        assert_eq!(C, 0xf301_3020);
        assert_eq!(D, 0xf301_3030);
    }

    #[test]
    fn init_writes_the_sequence_then_reads_data_to_wake_qemu_rx() {
        let bus = MockBus::new();
        bus.script(C, &[0]);
        bus.fix(D, 0xaa);
        let _ = Escc::init(&bus);
        let mut expected = vec![];
        for (reg, value) in INIT_SEQUENCE {
            expected.push(Access::W8(C, reg));
            expected.push(Access::W8(C, value));
        }
        expected.push(Access::R8(C, 0));
        expected.push(Access::R8(D, 0xaa));
        assert_eq!(bus.take_log(), expected);
    }

    #[test]
    fn init_leaves_a_waiting_byte_alone() {
        let bus = MockBus::new();
        bus.script(C, &[u32::from(RR0_RX_AVAILABLE)]);
        let _ = Escc::init(&bus);
        let log = bus.take_log();
        assert_eq!(log.last(), Some(&Access::R8(C, RR0_RX_AVAILABLE)));
        assert!(!log.iter().any(|a| matches!(a, Access::R8(D, _))));
    }

    #[test]
    fn write_waits_for_tx_empty_before_each_data_write() {
        let bus = MockBus::new();
        // Busy twice before the first byte, ready at once for the second.
        bus.script(C, &[0, 0, u32::from(RR0_TX_EMPTY), u32::from(RR0_TX_EMPTY)]);
        let mut uart = Escc::attach(&bus);
        assert_eq!(Write::write(&mut uart, &[0x12, 0x34]), Ok(2));
        assert!(bus.script_done());
        assert_eq!(
            bus.take_log(),
            vec![
                Access::R8(C, 0),
                Access::R8(C, 0),
                Access::R8(C, RR0_TX_EMPTY),
                Access::W8(D, 0x12),
                Access::R8(C, RR0_TX_EMPTY),
                Access::W8(D, 0x34),
            ]
        );
    }

    #[test]
    fn flush_and_write_ready_follow_rr0_tx_empty() {
        let bus = MockBus::new();
        bus.script(C, &[0, u32::from(RR0_TX_EMPTY), 0, 0x05]);
        let mut uart = Escc::attach(&bus);
        assert_eq!(Write::flush(&mut uart), Ok(()));
        assert_eq!(bus.take_log().len(), 2, "flush polled until TX empty");
        assert_eq!(uart.write_ready(), Ok(false));
        assert_eq!(uart.write_ready(), Ok(true));
        assert!(bus.writes().is_empty());
    }

    #[test]
    fn nb_read_is_would_block_without_a_byte_and_the_byte_with_one() {
        let bus = MockBus::new();
        bus.script(C, &[0, u32::from(RR0_RX_AVAILABLE | RR0_TX_EMPTY)]);
        bus.script(D, &[0x5a]);
        let mut uart = Escc::attach(&bus);
        assert_eq!(
            embedded_hal_nb::serial::Read::read(&mut uart),
            Err(nb::Error::WouldBlock)
        );
        assert_eq!(embedded_hal_nb::serial::Read::read(&mut uart), Ok(0x5a));
        assert_eq!(
            bus.take_log(),
            vec![
                Access::R8(C, 0),
                Access::R8(C, RR0_RX_AVAILABLE | RR0_TX_EMPTY),
                Access::R8(D, 0x5a),
            ]
        );
    }

    #[test]
    fn nb_write_is_would_block_while_tx_is_busy_and_writes_nothing() {
        let bus = MockBus::new();
        bus.script(C, &[0, u32::from(RR0_TX_EMPTY)]);
        let mut uart = Escc::attach(&bus);
        assert_eq!(
            embedded_hal_nb::serial::Write::write(&mut uart, 7),
            Err(nb::Error::WouldBlock)
        );
        assert!(bus.writes().is_empty());
        assert_eq!(embedded_hal_nb::serial::Write::write(&mut uart, 7), Ok(()));
        assert_eq!(bus.writes(), vec![Access::W8(D, 7)]);
    }

    #[test]
    fn io_read_waits_for_the_first_byte_then_takes_what_is_there() {
        let bus = MockBus::new();
        let rx = u32::from(RR0_RX_AVAILABLE);
        // Nothing, nothing, then two bytes, then empty.
        bus.script(C, &[0, 0, rx, rx, 0]);
        bus.script(D, &[1, 2]);
        let mut uart = Escc::attach(&bus);
        let mut buf = [0u8; 8];
        assert_eq!(Read::read(&mut uart, &mut buf), Ok(2));
        assert_eq!(&buf[..2], &[1, 2]);
        assert!(bus.script_done());
        // An empty buffer touches nothing.
        let _ = bus.take_log();
        assert_eq!(Read::read(&mut uart, &mut []), Ok(0));
        assert!(bus.take_log().is_empty());
    }

    #[test]
    fn read_ready_peeks_without_reading_data() {
        let bus = MockBus::new();
        bus.script(C, &[u32::from(RR0_RX_AVAILABLE), 0]);
        let mut uart = Escc::attach(&bus);
        assert_eq!(uart.read_ready(), Ok(true));
        assert_eq!(uart.read_ready(), Ok(false));
        assert!(!bus.take_log().iter().any(|a| matches!(a, Access::R8(D, _))));
    }

    #[test]
    fn take_overrun_selects_rr1_and_resets_errors_only_when_set() {
        let bus = MockBus::new();
        bus.script(C, &[u32::from(RR1_RX_OVERRUN), 0]);
        let mut uart = Escc::attach(&bus);
        assert!(uart.take_overrun());
        assert_eq!(
            bus.take_log(),
            vec![
                Access::W8(C, 1),
                Access::R8(C, RR1_RX_OVERRUN),
                Access::W8(C, WR0_ERROR_RESET),
            ]
        );
        assert!(!uart.take_overrun());
        assert_eq!(bus.take_log(), vec![Access::W8(C, 1), Access::R8(C, 0)]);
    }
}
