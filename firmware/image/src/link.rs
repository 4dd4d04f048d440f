//! The framed serial link to the host (used by the I/O partition, in its own region): frames out (blocking on the UART), and frames in through
//! an RX ring buffer and the streaming decoder, whose counters the target reports in every Pong.
use embedded_io::{Read, ReadReady, Write};
use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::{HostToTarget, LinkCounters, TargetToHost};
use heapless::Deque;

/// Bytes the RX ring holds between polls.
pub const RX_RING_CAPACITY: usize = 512;

pub struct Link<U> {
    uart: U,
    rx_ring: Deque<u8, RX_RING_CAPACITY>,
    decoder: FrameDecoder,
    /// Frames that could not be encoded (a message larger than a frame: a firmware bug).
    tx_encode_errors: u32,
}

impl<U: Read + ReadReady + Write> Link<U> {
    pub fn new(uart: U) -> Self {
        Self {
            uart,
            rx_ring: Deque::new(),
            decoder: FrameDecoder::new(),
            tx_encode_errors: 0,
        }
    }

    /// Encode and send one message; waits for the UART.
    pub fn send(&mut self, msg: &TargetToHost) {
        let mut frame = [0u8; MAX_FRAME_LEN];
        match encode(msg, &mut frame) {
            Ok(len) => {
                let _ = self.uart.write_all(&frame[..len]);
            }
            Err(_) => self.tx_encode_errors = self.tx_encode_errors.saturating_add(1),
        }
    }

    /// Move whatever the UART holds into the RX ring (up to its capacity).
    fn fill_ring(&mut self) {
        let mut chunk = [0u8; 32];
        while !self.rx_ring.is_full() && matches!(self.uart.read_ready(), Ok(true)) {
            let room = (RX_RING_CAPACITY - self.rx_ring.len()).min(chunk.len());
            let Ok(n) = self.uart.read(&mut chunk[..room]) else {
                break;
            };
            for &b in &chunk[..n] {
                let _ = self.rx_ring.push_back(b);
            }
        }
    }

    /// The next complete frame, if the bytes received so far finish one.
    pub fn poll(&mut self) -> Option<Result<HostToTarget, DecodeError>> {
        loop {
            if self.rx_ring.is_empty() {
                self.fill_ring();
            }
            let byte = self.rx_ring.pop_front()?;
            if let Some(result) = self.decoder.push::<HostToTarget>(byte) {
                return Some(result);
            }
        }
    }

    pub fn counters(&self) -> LinkCounters {
        self.decoder.counters()
    }
}
