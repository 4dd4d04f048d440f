//! The framed link to the host (used by the I/O partition, in its own region): encoded frames
//! out through the kernel (`SYS_LINK_WRITE`), gathered into batches so that a burst (a lockstep
//! round's answer) costs one system call, and frames in from the kernel (`SYS_LINK_READ`)
//! through the streaming decoder, whose counters the target reports in every Pong. The kernel
//! moves the bytes over the board's transport (the serial line, or shared memory on the
//! emulated target); the frames are the same either way. What the frames mean (the reliable
//! link's data frames, reports and round ends) is `fsw_bridge::link`'s business.
use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::link::{FrameSink, LinkFrame};
use fsw_bridge::{HostToTarget, LinkCounters, TargetToHost};

use userlib::sys;

/// Bytes taken from the kernel's receive ring at a time.
pub const RX_CHUNK_BYTES: usize = 256;
/// Bytes of encoded frames gathered before they go to the kernel in one call.
pub const TX_BATCH_BYTES: usize = 1024;

pub struct Link {
    /// Encoded frames not yet handed to the kernel: `tx_batch[..tx_len]`.
    tx_batch: [u8; TX_BATCH_BYTES],
    tx_len: usize,
    /// Bytes read from the kernel and not yet decoded: `rx_chunk[rx_next..rx_len]`.
    rx_chunk: [u8; RX_CHUNK_BYTES],
    rx_next: usize,
    rx_len: usize,
    decoder: FrameDecoder,
    /// Frames that could not be encoded (a message larger than a frame: a firmware bug).
    tx_encode_errors: u32,
}

impl Link {
    pub fn new() -> Self {
        Self {
            tx_batch: [0; TX_BATCH_BYTES],
            tx_len: 0,
            rx_chunk: [0; RX_CHUNK_BYTES],
            rx_next: 0,
            rx_len: 0,
            decoder: FrameDecoder::new(),
            tx_encode_errors: 0,
        }
    }

    /// Encode one message for the host as an expedited (Type-BD) frame: the Hello, a Pong.
    /// It leaves with the batch: at the next [`Link::flush`], or now if the batch has no room.
    pub fn send_expedited(&mut self, msg: &TargetToHost) {
        if TX_BATCH_BYTES - self.tx_len < MAX_FRAME_LEN {
            self.flush();
        }
        // The batch's free part (none, so an encode error, should `tx_len` ever be past it).
        let free = self.tx_batch.get_mut(self.tx_len..).unwrap_or_default();
        match encode(&LinkFrame::Bd(msg), free) {
            Ok(len) => self.tx_len += len,
            Err(_) => self.tx_encode_errors = self.tx_encode_errors.saturating_add(1),
        }
    }

    /// Hand the batch to the kernel. Waits (a window at a time) while the transport has no room:
    /// the host has not read what went before.
    pub fn flush(&mut self) {
        let mut sent = 0;
        while let Some(rest) = self
            .tx_batch
            .get(sent..self.tx_len)
            .filter(|r| !r.is_empty())
        {
            let n = sys::link_write(rest);
            if n == 0 {
                sys::wait_next_window();
            }
            sent += n;
        }
        self.tx_len = 0;
    }

    /// The next complete frame, if the bytes received so far finish one.
    pub fn poll(&mut self) -> Option<Result<LinkFrame<HostToTarget>, DecodeError>> {
        loop {
            if self.rx_next == self.rx_len {
                let n = sys::link_read(&mut self.rx_chunk);
                self.rx_next = 0;
                self.rx_len = n;
                if n == 0 {
                    return None;
                }
            }
            let Some(&byte) = self.rx_chunk.get(self.rx_next) else {
                // Past what the chunk holds: read a new one.
                self.rx_len = self.rx_next;
                continue;
            };
            self.rx_next += 1;
            if let Some(result) = self.decoder.push::<LinkFrame<HostToTarget>>(byte) {
                return Some(result);
            }
        }
    }

    pub fn counters(&self) -> LinkCounters {
        self.decoder.counters()
    }
}

/// The reliable link's bursts go out with the batch, frame by frame.
impl FrameSink for Link {
    fn send_frame(&mut self, frame: &[u8]) {
        if TX_BATCH_BYTES - self.tx_len < frame.len() {
            self.flush();
        }
        match self
            .tx_batch
            .get_mut(self.tx_len..self.tx_len + frame.len())
        {
            Some(slot) => {
                slot.copy_from_slice(frame);
                self.tx_len += frame.len();
            }
            None => self.tx_encode_errors = self.tx_encode_errors.saturating_add(1),
        }
    }
}
