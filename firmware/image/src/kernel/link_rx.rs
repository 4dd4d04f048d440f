//! The link's receive path in the kernel: the UART's bytes go into a ring in kernel RAM, on the
//! receive interrupt (taken only while the schedule is stopped waiting for input) and whenever
//! the I/O partition reads (`SYS_LINK_READ`), which moves them out of the ring. The kernel owns the receiver so that it
//! can wait for the host with the schedule stopped (`SYS_WAIT_FOR_INPUT`) and wake on the first
//! byte.
//!
//! While the schedule is stopped, the kernel keeps draining the UART on each receive interrupt
//! and restarts the schedule only when the ring holds a whole frame (the link's COBS framing
//! ends every frame with a 0 byte) or is full: QEMU hands the guest one byte per turn of its
//! main loop, and waking the partitions for each would cost a schedule restart per byte.
//!
//! Nothing is lost silently: when the ring is full the kernel stops draining and leaves the
//! bytes in the UART until the I/O partition has read (QEMU's ESCC then holds the host's bytes
//! back in the pty; the occasions are counted), and bytes the UART itself lost (a real 8530's
//! overrun) are counted; both go to the host in every kernel report.
use kernel_logic::byte_ring::ByteRing;

use crate::board::escc;

/// Bytes received from the host and not yet read by the I/O partition.
pub const RX_RING_CAPACITY: usize = 2048;

/// The link's frame delimiter (COBS: no other byte of a frame is 0).
const FRAME_DELIMITER: u8 = 0;

pub struct LinkRx {
    ring: ByteRing<RX_RING_CAPACITY>,
    /// Frame delimiters in the ring.
    delimiters: usize,
    /// Bytes received since boot.
    pub received: u32,
    /// Bytes the UART lost since boot (overruns).
    pub lost: u32,
    /// Times the ring was full with bytes still waiting in the UART.
    pub ring_full: u32,
}

impl LinkRx {
    pub const fn new() -> Self {
        Self {
            ring: ByteRing::new(),
            delimiters: 0,
            received: 0,
            lost: 0,
            ring_full: 0,
        }
    }

    /// Move what the UART holds into the ring, while there is room. Kernel only.
    pub fn drain_uart(&mut self) {
        let mut uart = escc::kernel_receiver();
        let mut took = false;
        while !self.ring.is_full() {
            match uart.try_read_byte() {
                Some(byte) => {
                    self.ring.push(byte);
                    if byte == FRAME_DELIMITER {
                        self.delimiters += 1;
                    }
                    self.received = self.received.wrapping_add(1);
                    took = true;
                }
                None => break,
            }
        }
        if took && uart.take_overrun() {
            // The 8530 does not say how many; at least one character is gone.
            self.lost = self.lost.saturating_add(1);
        }
        if self.ring.is_full() && uart.try_peek_available() {
            self.ring_full = self.ring_full.saturating_add(1);
        }
    }

    /// True if bytes wait in the ring or in the UART.
    pub fn pending(&self) -> bool {
        !self.ring.is_empty() || escc::kernel_receiver().try_peek_available()
    }

    /// True if the ring holds the end of a frame, or is full: worth waking the I/O partition.
    pub fn holds_frame_end(&self) -> bool {
        self.delimiters > 0 || self.ring.is_full()
    }

    /// Move received bytes into `out` (the UART drained first); returns how many.
    pub fn read(&mut self, out: &mut [u8]) -> usize {
        self.drain_uart();
        let n = self.ring.pop_into(out);
        let taken = out[..n].iter().filter(|&&b| b == FRAME_DELIMITER).count();
        self.delimiters = self.delimiters.saturating_sub(taken);
        n
    }
}
