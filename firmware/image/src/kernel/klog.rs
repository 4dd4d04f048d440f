//! The kernel's side of logging and reporting: a ring of whole defmt frames (from the kernel's
//! own log calls and from partitions' SYS_LOG) that the I/O partition drains into Log frames,
//! and a direct path to the link for when the kernel must speak itself (a fault in the kernel,
//! a module reset): it flushes what is pending, then its own message.
use fsw_bridge::codec::{encode, MAX_FRAME_LEN};
use fsw_bridge::messages::LOG_CHUNK_MAX;
use fsw_bridge::TargetToHost;
use heapless::Deque;

use super::link::KernelLink;

/// Bytes of defmt stream the kernel holds for the I/O partition.
pub const LOG_RING_BYTES: usize = 2048;

pub struct LogRing {
    bytes: Deque<u8, LOG_RING_BYTES>,
    /// Bytes dropped because the ring could not take a whole frame.
    pub dropped: u32,
}

impl LogRing {
    pub const fn new() -> Self {
        Self {
            bytes: Deque::new(),
            dropped: 0,
        }
    }

    /// Append one whole defmt frame, or drop it whole: frames never interleave.
    pub fn push_frame(&mut self, frame: &[u8]) {
        if self.bytes.capacity() - self.bytes.len() < frame.len() {
            self.dropped = self.dropped.saturating_add(frame.len() as u32);
            return;
        }
        for &b in frame {
            let _ = self.bytes.push_back(b);
        }
    }

    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Move up to `out.len()` bytes out; returns how many.
    pub fn drain(&mut self, out: &mut [u8]) -> usize {
        let mut n = 0;
        for slot in out.iter_mut() {
            match self.bytes.pop_front() {
                Some(b) => {
                    *slot = b;
                    n += 1;
                }
                None => break,
            }
        }
        n
    }
}

struct RingCell(core::cell::UnsafeCell<LogRing>);

// SAFETY: used only in kernel context with interrupts off, on the single core, through
// `with_ring`, whose closures never log (so never re-enter).
unsafe impl Sync for RingCell {}

static RING: RingCell = RingCell(core::cell::UnsafeCell::new(LogRing::new()));

/// Kernel only: run `f` with the kernel's log ring. `f` must not log.
pub fn with_ring<R>(f: impl FnOnce(&mut LogRing) -> R) -> R {
    // SAFETY: kernel context, interrupts off; closures given here do not log, so there is no
    // second reference while this one lives.
    f(unsafe { &mut *RING.0.get() })
}

/// Send a message straight to the link (kernel only, MMU off). A leading frame delimiter ends
/// any frame the I/O partition was in the middle of, so this one arrives whole.
pub fn send_direct(link: &mut KernelLink, msg: &TargetToHost) {
    let mut frame = [0u8; MAX_FRAME_LEN + 1];
    // The kernel's last words before a reset it makes: an expedited frame (the reliable link's
    // sequence numbers die with the I/O partition; the host takes these like the Hello after
    // them).
    let Some((_delimiter, body)) = frame.split_first_mut() else {
        return;
    };
    if let Ok(len) = encode(&fsw_bridge::link::LinkFrame::Bd(msg), body) {
        link.write_direct(frame.get(..=len).unwrap_or_default());
    }
}

/// Send everything in the ring as Log frames, straight to the link.
pub fn flush_direct(link: &mut KernelLink, ring: &mut LogRing) {
    loop {
        let mut chunk = [0u8; LOG_CHUNK_MAX];
        let n = ring.drain(&mut chunk);
        if n == 0 {
            return;
        }
        send_direct(
            link,
            &TargetToHost::Log {
                bytes: heapless::Vec::from_slice(chunk.get(..n).unwrap_or_default())
                    .unwrap_or_default(),
            },
        );
    }
}
