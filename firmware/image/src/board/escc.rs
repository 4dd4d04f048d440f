//! ESCC (Zilog 8530) channel A, QEMU's first `-serial`: the link to the host. mac-io + 0x13000,
//! register stride 0x10: channel A control at +0x20, data at +0x30.
//!
//! The channel belongs to the kernel (`kernel::link`), which moves the link's bytes for the I/O
//! partition. Transmit is polled, behind the `embedded-io` write traits; the channel raises its
//! interrupt (Heathrow line 0x0f) for every received character, and the kernel drains it with
//! [`EsccChannelA::try_read_byte`].
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

use embedded_io::{ErrorType, Write, WriteReady};

use super::{mmio_read8, mmio_write8, pci::MAC_IO_BASE};

const ESCC_BASE: usize = MAC_IO_BASE + 0x13000;
const CHANNEL_A_CONTROL: usize = ESCC_BASE + 0x20;
const CHANNEL_A_DATA: usize = ESCC_BASE + 0x30;

/// RR0: a received character is available.
const RR0_RX_AVAILABLE: u8 = 0x01;
/// RR0: the transmit buffer is empty.
const RR0_TX_EMPTY: u8 = 0x04;
/// RR1: a received character was lost (receiver overrun).
const RR1_RX_OVERRUN: u8 = 0x20;
/// WR0 command: reset the error latches (RR1).
const WR0_ERROR_RESET: u8 = 0x30;

/// Register set-up, in order: WR9 reset channel A; WR4 x16 clock, 1 stop bit, no parity; WR3
/// receiver on, 8 bits; WR5 transmitter on, 8 bits, DTR/RTS; WR1 receive interrupt on every
/// character (no transmit or external/status interrupts); WR15 no external/status sources (no
/// break interrupt); WR9 master interrupt enable.
const INIT_SEQUENCE: [(u8, u8); 7] = [
    (9, 0x80),
    (4, 0x44),
    (3, 0xc1),
    (5, 0xea),
    (1, 0x10),
    (15, 0x00),
    (9, 0x08),
];

/// Channel A of the ESCC. Zero-sized: the registers are global; there is one of these.
pub struct EsccChannelA(());

impl EsccChannelA {
    /// Reset and configure channel A: 8 data bits, 1 stop bit, no parity, x16 clock; RX and TX
    /// on; an interrupt for every received character.
    ///
    /// # Safety
    /// 1. mac-io has been mapped at [`MAC_IO_BASE`] (see `pci::init_mac_io`).
    /// 2. Only the kernel uses the channel (through [`kernel_channel`]), with the MMU off.
    pub unsafe fn init() -> Self {
        for (reg, value) in INIT_SEQUENCE {
            mmio_write8(CHANNEL_A_CONTROL, reg);
            mmio_write8(CHANNEL_A_CONTROL, value);
        }
        // QEMU stops polling the host side of the serial port while RX is disabled (as it is
        // after every reset) and only starts again when the guest reads the data register.
        // Enabling RX through WR3 does not wake it, so without this read the first byte from the
        // host waits for an unrelated QEMU timer (about 1 s at power-on, indefinitely after a
        // system_reset). Nothing can be pending yet: the host sends only after our Hello.
        if mmio_read8(CHANNEL_A_CONTROL) & RR0_RX_AVAILABLE == 0 {
            let _ = mmio_read8(CHANNEL_A_DATA);
        }
        Self(())
    }

    fn status(&self) -> u8 {
        // SAFETY: the instance exists only after `init` mapped the device.
        unsafe { mmio_read8(CHANNEL_A_CONTROL) }
    }

    /// Take one received byte if there is one.
    pub fn try_read_byte(&mut self) -> Option<u8> {
        if self.status() & RR0_RX_AVAILABLE != 0 {
            // SAFETY: as in `status`.
            Some(unsafe { mmio_read8(CHANNEL_A_DATA) })
        } else {
            None
        }
    }

    /// True if a received character waits (it stays there).
    pub fn try_peek_available(&self) -> bool {
        self.status() & RR0_RX_AVAILABLE != 0
    }

    /// True if the receiver lost a character since the last call (RR1 overrun, reset here).
    /// QEMU never overruns (it holds bytes back); a real 8530 does when it is not drained in
    /// time.
    pub fn take_overrun(&mut self) -> bool {
        // SAFETY: as in `status`; WR0 selects RR1 for the next control read, which then returns
        // the pointer to 0, and the error reset command touches only RR1's latches.
        unsafe {
            mmio_write8(CHANNEL_A_CONTROL, 1);
            let rr1 = mmio_read8(CHANNEL_A_CONTROL);
            if rr1 & RR1_RX_OVERRUN != 0 {
                mmio_write8(CHANNEL_A_CONTROL, WR0_ERROR_RESET);
                true
            } else {
                false
            }
        }
    }

    /// Send one byte, waiting for the transmitter.
    pub fn write_byte(&mut self, byte: u8) {
        while self.status() & RR0_TX_EMPTY == 0 {}
        // SAFETY: as in `status`.
        unsafe { mmio_write8(CHANNEL_A_DATA, byte) }
    }
}

impl ErrorType for EsccChannelA {
    type Error = Infallible;
}

impl Write for EsccChannelA {
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

impl WriteReady for EsccChannelA {
    fn write_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(self.status() & RR0_TX_EMPTY != 0)
    }
}

/// Kernel only (MMU off): the channel [`EsccChannelA::init`] set up at boot.
pub fn kernel_channel() -> EsccChannelA {
    EsccChannelA(())
}
