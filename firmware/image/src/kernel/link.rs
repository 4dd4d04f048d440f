//! The link to the host in the kernel: the kernel is the link's byte pipe (the I/O partition
//! frames and routes what goes through it with `SYS_LINK_READ` and `SYS_LINK_WRITE`), over one of
//! two transports, chosen at boot by what the board has:
//!
//! - **Serial** (every board): the ESCC's channel A. Received bytes go into a ring in kernel RAM,
//!   on the receive interrupt (taken only while the schedule is stopped waiting for input) and
//!   whenever the I/O partition reads; transmitted bytes go to the UART as the I/O partition
//!   writes them.
//! - **Shared memory** (the emulated target, when `hil` attaches a second `ivshmem-plain` device
//!   carrying the link header, see `kernel_logic::shm_link`): the same byte stream through two
//!   rings in that device, with the serial line as the doorbell: the host sends one byte after
//!   writing into its ring (the receive interrupt wakes a parked schedule), and the kernel sends
//!   one byte when the I/O partition gives up the CPU after writing into the other. QEMU hands
//!   the guest one received byte per turn of its main loop; a doorbell per batch is one turn.
//!
//! While the schedule is stopped, the kernel restarts it only once a whole frame has arrived
//! (the link's COBS framing ends every frame with a 0 byte; the host rings the doorbell after
//! whole frames), so the partitions are not woken byte by byte.
//!
//! Nothing is lost silently: a full serial receive ring leaves bytes in the UART until the I/O
//! partition has read (QEMU's ESCC then holds the host's bytes back; the occasions are counted),
//! bytes the UART itself lost (a real 8530's overrun) are counted, and a shared ring whose
//! counts make no sense is dropped and counted; all of it goes to the host in every kernel
//! report.
use core::ptr::{read_volatile, write_volatile};

use embedded_io::Write;
use kernel_logic::byte_ring::ByteRing;
use kernel_logic::shm_link::{self, SharedMemory, HOST_TO_TARGET, TARGET_TO_HOST};

use crate::board::escc;

/// Bytes received over the serial line and not yet read by the I/O partition.
pub const RX_RING_CAPACITY: usize = 2048;

/// The link's frame delimiter (COBS: no other byte of a frame is 0).
const FRAME_DELIMITER: u8 = 0;
/// What the kernel sends as a doorbell (the value means nothing).
const DOORBELL: u8 = 0;

/// The shared-memory device, mapped at `base` (the kernel runs with the MMU off).
#[derive(Clone, Copy)]
pub struct SharedMemoryDevice {
    base: usize,
}

impl SharedMemoryDevice {
    /// # Safety
    /// 1. `base..base + shm_link::DEVICE_BYTES` is the link's ivshmem device, mapped by the
    ///    boot code, and nothing but the kernel (and the host on its side) touches it.
    pub unsafe fn at(base: usize) -> Self {
        Self { base }
    }

    fn sync() {
        // SAFETY: `sync` only orders this CPU's memory accesses.
        unsafe { core::arch::asm!("sync", options(nostack)) }
    }
}

impl SharedMemory for SharedMemoryDevice {
    fn load_word(&self, offset: usize) -> u32 {
        // SAFETY: `offset` is one of `shm_link`'s header words, inside the device (`at`'s
        // contract); the target is big-endian like the layout.
        let value = unsafe { read_volatile((self.base + offset) as *const u32) };
        Self::sync();
        value
    }

    fn store_word(&mut self, offset: usize, value: u32) {
        Self::sync();
        // SAFETY: as in `load_word`.
        unsafe { write_volatile((self.base + offset) as *mut u32, value) }
    }

    fn read_bytes(&self, offset: usize, out: &mut [u8]) {
        for (i, byte) in out.iter_mut().enumerate() {
            // SAFETY: `shm_link` keeps `offset..offset + out.len()` inside a ring's data.
            *byte = unsafe { read_volatile((self.base + offset + i) as *const u8) };
        }
    }

    fn write_bytes(&mut self, offset: usize, data: &[u8]) {
        for (i, &byte) in data.iter().enumerate() {
            // SAFETY: as in `read_bytes`.
            unsafe { write_volatile((self.base + offset + i) as *mut u8, byte) }
        }
    }
}

#[derive(Clone, Copy)]
enum Transport {
    Serial,
    SharedMemory(SharedMemoryDevice),
}

pub struct KernelLink {
    transport: Transport,
    /// Serial: bytes received, not yet read.
    ring: ByteRing<RX_RING_CAPACITY>,
    /// Frame delimiters in `ring`.
    delimiters: usize,
    /// Shared memory: bytes were written since the last doorbell.
    doorbell_due: bool,
    /// Bytes received since boot.
    pub received: u32,
    /// Bytes the UART lost since boot (overruns).
    pub lost: u32,
    /// Times the serial receive ring was full with bytes still waiting in the UART.
    pub ring_full: u32,
    /// Shared memory: rings whose counts made no sense (what they held, or what was to be
    /// written into them, dropped).
    pub ring_errors: u32,
}

impl KernelLink {
    pub const fn new() -> Self {
        Self {
            transport: Transport::Serial,
            ring: ByteRing::new(),
            delimiters: 0,
            doorbell_due: false,
            received: 0,
            lost: 0,
            ring_full: 0,
            ring_errors: 0,
        }
    }

    /// Carry the link over `device` from now on (boot, when the board has one).
    pub fn use_shared_memory(&mut self, device: SharedMemoryDevice) {
        self.transport = Transport::SharedMemory(device);
    }

    /// True when the link runs over shared memory.
    pub fn over_shared_memory(&self) -> bool {
        matches!(self.transport, Transport::SharedMemory(_))
    }

    /// Take what the UART holds: received bytes (serial; into the ring while there is room) or
    /// doorbells (shared memory; their value means nothing).
    pub fn drain_uart(&mut self) {
        let mut uart = escc::kernel_channel();
        let serial = !self.over_shared_memory();
        let mut took = false;
        while !(serial && self.ring.is_full()) {
            let Some(byte) = uart.try_read_byte() else {
                break;
            };
            took = true;
            if serial {
                self.ring.push(byte);
                self.received = self.received.wrapping_add(1);
                if byte == FRAME_DELIMITER {
                    self.delimiters += 1;
                }
            }
        }
        if took && serial && uart.take_overrun() {
            // The 8530 does not say how many; at least one character is gone.
            self.lost = self.lost.saturating_add(1);
        }
        if serial && self.ring.is_full() && uart.try_peek_available() {
            self.ring_full = self.ring_full.saturating_add(1);
        }
    }

    /// True if received bytes wait to be read.
    pub fn pending(&self) -> bool {
        match self.transport {
            Transport::Serial => {
                !self.ring.is_empty() || escc::kernel_channel().try_peek_available()
            }
            Transport::SharedMemory(device) => {
                // A ring in disorder is "pending" too: the read that finds it drops and counts it.
                shm_link::readable(&device, &HOST_TO_TARGET).map_or(true, |n| n > 0)
            }
        }
    }

    /// True if a whole frame (or a full ring's worth) has arrived: worth restarting a stopped
    /// schedule for.
    pub fn holds_frame_end(&self) -> bool {
        match self.transport {
            Transport::Serial => self.delimiters > 0 || self.ring.is_full(),
            // The host rings the doorbell after whole frames.
            Transport::SharedMemory(_) => self.pending(),
        }
    }

    /// Move received bytes into `out`; returns how many.
    pub fn read(&mut self, out: &mut [u8]) -> usize {
        self.drain_uart();
        match &mut self.transport {
            // Counted as received when they left the UART.
            Transport::Serial => {
                let n = self.ring.pop_into(out);
                let taken = out
                    .iter()
                    .take(n)
                    .filter(|&&b| b == FRAME_DELIMITER)
                    .count();
                self.delimiters = self.delimiters.saturating_sub(taken);
                n
            }
            Transport::SharedMemory(device) => {
                match shm_link::consume(device, &HOST_TO_TARGET, out) {
                    Ok(n) => {
                        self.received = self.received.wrapping_add(n as u32);
                        n
                    }
                    Err(_) => {
                        shm_link::discard(device, &HOST_TO_TARGET);
                        self.ring_errors = self.ring_errors.saturating_add(1);
                        0
                    }
                }
            }
        }
    }

    /// Send bytes; returns how many were taken (serial: all, waiting for the UART; shared
    /// memory: what fits in the ring, 0 while the host has not read).
    pub fn write(&mut self, data: &[u8]) -> usize {
        match &mut self.transport {
            Transport::Serial => {
                let _ = escc::kernel_channel().write_all(data);
                data.len()
            }
            Transport::SharedMemory(device) => {
                match shm_link::produce(device, &TARGET_TO_HOST, data) {
                    Ok(n) => {
                        self.doorbell_due |= n > 0;
                        n
                    }
                    // The host's read count is garbage (only the host writes it): the bytes are
                    // dropped and counted rather than waiting for a host that will never read.
                    Err(_) => {
                        self.ring_errors = self.ring_errors.saturating_add(1);
                        data.len()
                    }
                }
            }
        }
    }

    /// Shared memory: tell the host that bytes are in its ring, if any were written since the
    /// last doorbell. Called when the I/O partition gives up the CPU, and after the kernel's own
    /// reports.
    pub fn ring_doorbell(&mut self) {
        if core::mem::take(&mut self.doorbell_due) {
            escc::kernel_channel().write_byte(DOORBELL);
        }
    }

    /// The kernel's own report (a fault, a reset): all of `bytes`, now. Over shared memory, what
    /// does not fit because the host has not read is dropped (nothing may wait here).
    pub fn write_direct(&mut self, bytes: &[u8]) {
        self.write(bytes);
        self.ring_doorbell();
    }
}
