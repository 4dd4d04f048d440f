//! ESCC (Zilog 8530) channel A, QEMU's first `-serial`, as a polled UART behind the
//! `embedded-io` traits. mac-io + 0x13000, register stride 0x10: channel A control at +0x20,
//! data at +0x30. QEMU ignores the baud rate and holds back the next received byte until the
//! guest has read the previous one, so polling loses nothing.
use core::convert::Infallible;

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};

use super::{mmio_read8, mmio_write8, pci::MAC_IO_BASE};

const ESCC_BASE: usize = MAC_IO_BASE + 0x13000;
const CHANNEL_A_CONTROL: usize = ESCC_BASE + 0x20;
const CHANNEL_A_DATA: usize = ESCC_BASE + 0x30;

/// RR0: a received character is available.
const RR0_RX_AVAILABLE: u8 = 0x01;
/// RR0: the transmit buffer is empty.
const RR0_TX_EMPTY: u8 = 0x04;

/// Channel A of the ESCC. Zero-sized: the registers are global; there is one of these.
pub struct EsccChannelA(());

impl EsccChannelA {
    /// Reset and configure channel A: 8 data bits, 1 stop bit, no parity, x16 clock; RX and TX on.
    ///
    /// # Safety
    /// 1. mac-io has been mapped at [`MAC_IO_BASE`] (see `pci::init_mac_io`).
    /// 2. No other `EsccChannelA` exists.
    pub unsafe fn init() -> Self {
        for (reg, value) in [(9u8, 0x80u8), (4, 0x44), (3, 0xc1), (5, 0xea)] {
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

    /// The channel the kernel initialised at boot, for the I/O partition (which has mac-io
    /// mapped at the same address).
    ///
    /// # Safety
    /// 1. [`EsccChannelA::init`] ran in this boot.
    /// 2. The caller is the only user of the channel (the I/O partition), apart from the
    ///    kernel's [`kernel_write`], which only runs while the partition is stopped.
    pub unsafe fn attach() -> Self {
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

impl Read for EsccChannelA {
    /// Blocks until at least one byte is available, then returns what is there.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if buf.is_empty() {
            return Ok(0);
        }
        let mut n = 0;
        loop {
            while n < buf.len() {
                match self.try_read_byte() {
                    Some(b) => {
                        buf[n] = b;
                        n += 1;
                    }
                    None => break,
                }
            }
            if n > 0 {
                return Ok(n);
            }
        }
    }
}

impl ReadReady for EsccChannelA {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(self.status() & RR0_RX_AVAILABLE != 0)
    }
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

/// Kernel only (MMU off, partition stopped): write bytes to channel A, waiting for the
/// transmitter. For reports the kernel sends itself (faults, module reset).
pub fn kernel_write(bytes: &[u8]) {
    let mut channel = EsccChannelA(());
    for &b in bytes {
        channel.write_byte(b);
    }
}
