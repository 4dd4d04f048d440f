//! The host end of the framed link: a serial device (a real board's `/dev/tty*`), the Unix
//! socket QEMU connects the emulated target's serial port to, or the emulated target's
//! shared-memory link with that socket as its doorbell; a reader thread that cuts the byte
//! stream into frames as they arrive, and a transcript of every frame in both directions, in
//! order. The frames are the same on every transport. What a frame means is the reliable link
//! layer's business (`fsw_bridge::link`): missions run it in [`crate::mission::link`]; link
//! checks read the target's expedited messages with [`HostLink::recv`].
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use fsw_bridge::codec::{encode, DecodeError, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::link::LinkFrame;
use fsw_bridge::{HostToTarget, LinkCounters, TargetToHost};

/// Baud rate asked of a real serial port (QEMU's pty ignores it).
pub const DEFAULT_BAUD: u32 = 115_200;

#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    #[error("cannot open serial device {path}: {source}")]
    Open {
        path: String,
        source: serialport::Error,
    },
    #[error("cannot connect to the target's serial socket {path}: {source}")]
    Connect {
        path: String,
        source: std::io::Error,
    },
    #[error("serial write failed: {0}")]
    Write(std::io::Error),
    #[error("the serial device closed: {0}")]
    Closed(String),
    #[error("timed out after {} waiting for the target", crate::time::fmt_wall(*.0))]
    Timeout(Duration),
}

/// One entry of the transcript.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TranscriptEntry {
    /// Frame bytes the host sent (exactly as written).
    Sent(Vec<u8>),
    /// A frame the host received (bytes between two delimiters, delimiters included).
    Received(Vec<u8>),
}

/// What the reader thread hands over.
#[derive(Debug)]
enum Rx {
    Frame(Vec<u8>),
    Closed(String),
}

/// How long the reader thread blocks in one read before it looks at its stop flag.
const READ_POLL: Duration = Duration::from_millis(50);

/// A framed link to one target.
pub struct HostLink {
    writer: Box<dyn Write + Send>,
    rx: Receiver<Rx>,
    reader: Option<JoinHandle<()>>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    transcript: Arc<Mutex<Vec<TranscriptEntry>>>,
    host_counters: Arc<Mutex<LinkCounters>>,
    bytes_received: Arc<std::sync::atomic::AtomicU64>,
    closed: Option<String>,
}

impl HostLink {
    /// Open a serial device (a real port, or a pty standing in for one) in raw mode.
    pub fn open(path: &str, baud: u32) -> Result<Self, LinkError> {
        let port = serialport::new(path, baud)
            .timeout(READ_POLL)
            .open()
            .map_err(|source| LinkError::Open {
                path: path.to_string(),
                source,
            })?;
        let reader_port = port.try_clone().map_err(|source| LinkError::Open {
            path: path.to_string(),
            source,
        })?;
        Ok(Self::start(Box::new(reader_port), Box::new(port), false))
    }

    /// Connect to the Unix socket QEMU serves the emulated target's serial port on.
    pub fn connect_unix(path: &Path) -> Result<Self, LinkError> {
        let error = |source| LinkError::Connect {
            path: path.display().to_string(),
            source,
        };
        let stream = UnixStream::connect(path).map_err(error)?;
        let reader = stream.try_clone().map_err(error)?;
        reader.set_read_timeout(Some(READ_POLL)).map_err(error)?;
        Ok(Self::start(Box::new(reader), Box::new(stream), true))
    }

    /// Connect to the emulated target's serial socket and use it as the doorbell of the
    /// shared-memory link in `link_file` (see [`crate::shm`]): frames go through the rings.
    pub fn connect_shm(socket: &Path, link_file: &Path) -> Result<Self, LinkError> {
        let error = |source| LinkError::Connect {
            path: socket.display().to_string(),
            source,
        };
        let stream = UnixStream::connect(socket).map_err(error)?;
        stream.set_read_timeout(Some(READ_POLL)).map_err(error)?;
        let (reader, writer) = crate::shm::open(link_file, stream).map_err(error)?;
        Ok(Self::start(Box::new(reader), Box::new(writer), true))
    }

    /// Start the reader thread on `reader`; `end_of_file_closes`: a read of 0 bytes means the
    /// other side is gone (a socket), rather than nothing yet (a serial port's timeout).
    fn start(
        reader_port: Box<dyn Read + Send>,
        writer: Box<dyn Write + Send>,
        end_of_file_closes: bool,
    ) -> Self {
        let (tx, rx) = mpsc::channel();
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let transcript = Arc::new(Mutex::new(Vec::new()));
        let host_counters = Arc::new(Mutex::new(LinkCounters::default()));
        let bytes_received = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let reader = {
            let (stop, transcript, bytes) =
                (stop.clone(), transcript.clone(), bytes_received.clone());
            std::thread::Builder::new()
                .name("hil-link-rx".into())
                .spawn(move || {
                    read_loop(reader_port, end_of_file_closes, tx, stop, transcript, bytes)
                })
                .expect("spawn link reader thread")
        };
        Self {
            writer,
            rx,
            reader: Some(reader),
            stop,
            transcript,
            host_counters,
            bytes_received,
            closed: None,
        }
    }

    /// Send one message as an expedited (Type-BD) frame: link checks and resets, outside the
    /// lockstep rounds.
    pub fn send(&mut self, msg: &HostToTarget) -> Result<(), LinkError> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len =
            encode(&LinkFrame::Bd(msg), &mut frame).expect("every HostToTarget fits in a frame");
        self.send_raw(&frame[..len])
    }

    /// Send bytes as they are (used to inject corrupted frames).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.transcript
            .lock()
            .unwrap()
            .push(TranscriptEntry::Sent(bytes.to_vec()));
        self.writer.write_all(bytes).map_err(LinkError::Write)?;
        self.writer.flush().map_err(LinkError::Write)
    }

    /// The next frame from the target (its bytes, delimiters included), waiting up to
    /// `timeout`.
    pub fn recv_frame(&mut self, timeout: Duration) -> Result<Vec<u8>, LinkError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(why) = &self.closed {
                return Err(LinkError::Closed(why.clone()));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(Rx::Frame(frame)) => return Ok(frame),
                Ok(Rx::Closed(why)) => self.closed = Some(why),
                Err(RecvTimeoutError::Timeout) => return Err(LinkError::Timeout(timeout)),
                Err(RecvTimeoutError::Disconnected) => {
                    self.closed = Some("reader thread ended".into())
                }
            }
        }
    }

    /// The next message the target sent outside a lockstep round (an expedited frame: Hello,
    /// Pong, a panic report, the kernel's last words before a reset), waiting up to
    /// `timeout`. Frames the host rejects are counted ([`HostLink::host_counters`]) and
    /// skipped, and so are the frames of lockstep rounds.
    pub fn recv(&mut self, timeout: Duration) -> Result<TargetToHost, LinkError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let frame = self.recv_frame(left).map_err(|e| match e {
                LinkError::Timeout(_) => LinkError::Timeout(timeout),
                e => e,
            })?;
            match self.decode(&frame) {
                Ok(LinkFrame::Bd(msg)) | Ok(LinkFrame::Ad { msg, .. }) => return Ok(msg),
                Ok(_) => continue,
                // A target from before the reliable link (protocol v1) says Hello as a bare
                // message: taken so that the session can refuse it by name.
                Err(_) => {
                    if let Some(hello @ TargetToHost::Hello { .. }) = legacy_message(&frame) {
                        return Ok(hello);
                    }
                }
            }
        }
    }

    /// Decode one received frame, counting it in the host's counters.
    pub fn decode(&mut self, frame: &[u8]) -> Result<LinkFrame<TargetToHost>, DecodeError> {
        let mut decoder = FrameDecoder::new();
        let mut result = Err(DecodeError::Truncated);
        for &b in frame {
            if let Some(r) = decoder.push::<LinkFrame<TargetToHost>>(b) {
                result = r;
            }
        }
        let mut counters = self.host_counters.lock().unwrap();
        match &result {
            Ok(_) => counters.frames_ok += 1,
            Err(DecodeError::BadCrc) => counters.crc_errors += 1,
            Err(DecodeError::Oversize) => counters.oversize += 1,
            Err(DecodeError::UnknownType(_)) => counters.unknown_type += 1,
            Err(DecodeError::Truncated) => counters.truncated += 1,
            Err(DecodeError::Malformed) => counters.malformed += 1,
        }
        result
    }

    /// Counters of the host's own decoder (frames from the target it accepted and rejected).
    pub fn host_counters(&self) -> LinkCounters {
        *self.host_counters.lock().unwrap()
    }

    /// Raw bytes received from the target so far.
    pub fn bytes_received(&self) -> u64 {
        self.bytes_received
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// A copy of the transcript so far.
    pub fn transcript(&self) -> Vec<TranscriptEntry> {
        self.transcript.lock().unwrap().clone()
    }
}

impl Drop for HostLink {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
    }
}

/// `frame` as protocol v1 framed its messages (no link envelope), if it decodes so.
fn legacy_message(frame: &[u8]) -> Option<TargetToHost> {
    let mut decoder = FrameDecoder::new();
    frame
        .iter()
        .filter_map(|&b| decoder.push::<TargetToHost>(b))
        .last()?
        .ok()
}

fn read_loop(
    mut port: Box<dyn Read + Send>,
    end_of_file_closes: bool,
    tx: mpsc::Sender<Rx>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    transcript: Arc<Mutex<Vec<TranscriptEntry>>>,
    bytes_received: Arc<std::sync::atomic::AtomicU64>,
) {
    // Bytes since the last delimiter; a frame is a non-empty run between two.
    let mut current: Vec<u8> = Vec::with_capacity(MAX_FRAME_LEN);
    let mut buf = [0u8; 4096];
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        let n = match port.read(&mut buf) {
            Ok(0) if end_of_file_closes => {
                let _ = tx.send(Rx::Closed("the target's end closed".into()));
                return;
            }
            Ok(0) => continue,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => {
                let _ = tx.send(Rx::Closed(e.to_string()));
                return;
            }
        };
        bytes_received.fetch_add(n as u64, std::sync::atomic::Ordering::Relaxed);
        for &byte in &buf[..n] {
            if byte != 0 {
                // A run longer than any frame is garbage: keep its tail only (the decoder
                // downstream reports it as oversize when it sees the delimiter).
                if current.len() > 2 * MAX_FRAME_LEN {
                    current.clear();
                }
                current.push(byte);
                continue;
            }
            if current.is_empty() {
                continue;
            }
            let mut frame = Vec::with_capacity(current.len() + 2);
            frame.push(0);
            frame.append(&mut current);
            frame.push(0);
            transcript
                .lock()
                .unwrap()
                .push(TranscriptEntry::Received(frame.clone()));
            if tx.send(Rx::Frame(frame)).is_err() {
                return;
            }
        }
    }
}

/// An expedited frame that carries `msg` with bit `bit` of its payload flipped (taken modulo
/// the payload's bits), properly COBS-stuffed and delimited: the receiver must reject it as a
/// CRC error.
pub fn corrupted_frame(msg: &HostToTarget, bit: usize) -> Vec<u8> {
    let mut raw = postcard::to_stdvec(&LinkFrame::Bd(msg)).expect("HostToTarget serializes");
    let crc = fsw_bridge::codec::LINK_CRC.checksum(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let payload_bits = (raw.len() - 4) * 8;
    let bit = bit % payload_bits;
    raw[bit / 8] ^= 1 << (bit % 8);
    let mut frame = vec![0u8; cobs::max_encoding_length(raw.len()) + 2];
    let n = cobs::encode(&raw, &mut frame[1..]);
    frame.truncate(n + 1);
    frame.push(0);
    frame
}
