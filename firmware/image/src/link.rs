//! The framed serial link to the host (used by the I/O partition, in its own region): frames out
//! (blocking on the UART), and frames in from the kernel's receive ring (`SYS_LINK_READ`)
//! through the streaming decoder, whose counters the target reports in every Pong.
use embedded_io::Write;
use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::{HostToTarget, LinkCounters, TargetToHost};

use crate::sys;

/// Bytes taken from the kernel's receive ring at a time.
pub const RX_CHUNK_BYTES: usize = 256;

pub struct Link<U> {
    uart: U,
    /// Where frames are encoded (kept, so a message does not clear a frame's worth of stack).
    tx_frame: [u8; MAX_FRAME_LEN],
    /// Bytes read from the kernel and not yet decoded: `rx_chunk[rx_next..rx_len]`.
    rx_chunk: [u8; RX_CHUNK_BYTES],
    rx_next: usize,
    rx_len: usize,
    decoder: FrameDecoder,
    /// Frames that could not be encoded (a message larger than a frame: a firmware bug).
    tx_encode_errors: u32,
    /// Bytes the kernel's receiver lost, as last reported.
    pub rx_lost: u32,
}

impl<U: Write> Link<U> {
    pub fn new(uart: U) -> Self {
        Self {
            uart,
            tx_frame: [0; MAX_FRAME_LEN],
            rx_chunk: [0; RX_CHUNK_BYTES],
            rx_next: 0,
            rx_len: 0,
            decoder: FrameDecoder::new(),
            tx_encode_errors: 0,
            rx_lost: 0,
        }
    }

    /// Encode and send one message; waits for the UART.
    pub fn send(&mut self, msg: &TargetToHost) {
        match encode(msg, &mut self.tx_frame) {
            Ok(len) => {
                let _ = self.uart.write_all(&self.tx_frame[..len]);
            }
            Err(_) => self.tx_encode_errors = self.tx_encode_errors.saturating_add(1),
        }
    }

    /// The next complete frame, if the bytes received so far finish one.
    pub fn poll(&mut self) -> Option<Result<HostToTarget, DecodeError>> {
        loop {
            if self.rx_next == self.rx_len {
                let (n, lost) = sys::link_read(&mut self.rx_chunk);
                self.rx_lost = lost;
                self.rx_next = 0;
                self.rx_len = n;
                if n == 0 {
                    return None;
                }
            }
            let byte = self.rx_chunk[self.rx_next];
            self.rx_next += 1;
            if let Some(result) = self.decoder.push::<HostToTarget>(byte) {
                return Some(result);
            }
        }
    }

    pub fn counters(&self) -> LinkCounters {
        self.decoder.counters()
    }
}
