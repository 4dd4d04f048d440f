//! Frame codec: `0x00, COBS(postcard(message) ++ CRC-32/ISO-HDLC little-endian), 0x00`.
//!
//! The leading delimiter ends whatever garbage came before, so garbage between frames never
//! costs a valid frame. [`FrameDecoder`] is a byte-at-a-time state machine with a fixed buffer:
//! it never allocates, never panics, resynchronises on the next delimiter after any error, and
//! counts every rejected frame by reason in [`LinkCounters`].
use crc::{Crc, CRC_32_ISO_HDLC};
use serde::{de::DeserializeOwned, Serialize};

use crate::messages::{HostToTarget, LinkCounters, TargetToHost};

/// Most bytes one frame occupies on the wire, both delimiters included.
pub const MAX_FRAME_LEN: usize = 256;
/// Most bytes of postcard payload in one frame.
pub const MAX_PAYLOAD_LEN: usize = 240;
const CRC_LEN: usize = 4;
/// Bytes between the two delimiters at most: COBS adds one byte per 254 plus one.
const MAX_STUFFED_LEN: usize = MAX_FRAME_LEN - 2;

const _: () = assert!(MAX_PAYLOAD_LEN + CRC_LEN + (MAX_PAYLOAD_LEN + CRC_LEN) / 254 + 1 <= MAX_STUFFED_LEN);

/// The CRC used on the link (CRC-32, as in Ethernet and zlib).
pub const LINK_CRC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// A message type that travels in frames: knows how many variants it has, so that a frame with
/// an intact CRC but an unknown type is reported as such rather than as malformed.
pub trait WireMessage: Serialize + DeserializeOwned {
    /// Number of variants; a leading tag at or above this is an unknown type.
    const VARIANT_COUNT: u8;
}

impl WireMessage for HostToTarget {
    const VARIANT_COUNT: u8 = 6;
}

impl WireMessage for TargetToHost {
    const VARIANT_COUNT: u8 = 9;
}

/// Why a message could not be put in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The message does not fit in [`MAX_PAYLOAD_LEN`].
    PayloadTooLarge,
    /// The output buffer is smaller than the frame.
    OutputTooSmall,
}

/// Why a received frame was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The CRC-32 did not match the payload.
    BadCrc,
    /// More than [`MAX_FRAME_LEN`] bytes arrived without a delimiter.
    Oversize,
    /// The CRC matched but the message type tag is not one this side knows.
    UnknownType(u8),
    /// Too short for a CRC, invalid COBS, or the payload ended inside a field.
    Truncated,
    /// A field held a value its type does not allow, or bytes were left over.
    Malformed,
}

/// Encode `msg` as one frame into `out`; returns the number of bytes written.
pub fn encode<M: Serialize>(msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
    let mut raw = [0u8; MAX_PAYLOAD_LEN + CRC_LEN];
    let payload_len = postcard::to_slice(msg, &mut raw[..MAX_PAYLOAD_LEN])
        .map_err(|_| EncodeError::PayloadTooLarge)?
        .len();
    let crc = LINK_CRC.checksum(&raw[..payload_len]);
    raw[payload_len..payload_len + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    let raw = &raw[..payload_len + CRC_LEN];

    let needed = raw.len() + raw.len() / 254 + 1 + 2;
    if out.len() < needed {
        return Err(EncodeError::OutputTooSmall);
    }
    out[0] = 0;
    let stuffed = cobs_encode(raw, &mut out[1..needed - 1]);
    out[1 + stuffed] = 0;
    Ok(stuffed + 2)
}

/// COBS-encode `src` into `dst` (which must hold `src.len() + src.len() / 254 + 1` bytes);
/// returns the bytes written.
fn cobs_encode(src: &[u8], dst: &mut [u8]) -> usize {
    let mut code_at = 0;
    let mut write = 1;
    let mut code: u8 = 1;
    for &byte in src {
        if byte == 0 {
            dst[code_at] = code;
            code_at = write;
            write += 1;
            code = 1;
        } else {
            dst[write] = byte;
            write += 1;
            code += 1;
            if code == 0xff {
                dst[code_at] = code;
                code_at = write;
                write += 1;
                code = 1;
            }
        }
    }
    dst[code_at] = code;
    write
}

/// COBS-decode `buf[..len]` in place; returns the decoded length, or None if the stuffing is
/// invalid (a code byte pointing past the end, or a zero inside the frame).
fn cobs_decode_in_place(buf: &mut [u8], len: usize) -> Option<usize> {
    let mut read = 0;
    let mut write = 0;
    while read < len {
        let code = buf[read] as usize;
        if code == 0 || read + code > len {
            return None;
        }
        read += 1;
        for _ in 1..code {
            let byte = buf[read];
            if byte == 0 {
                return None;
            }
            buf[write] = byte;
            write += 1;
            read += 1;
        }
        if code != 0xff && read < len {
            buf[write] = 0;
            write += 1;
        }
    }
    Some(write)
}

/// Streaming frame decoder with a fixed buffer.
pub struct FrameDecoder {
    buf: [u8; MAX_STUFFED_LEN],
    len: usize,
    overflowed: bool,
    counters: LinkCounters,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_STUFFED_LEN],
            len: 0,
            overflowed: false,
            counters: LinkCounters {
                frames_ok: 0,
                crc_errors: 0,
                oversize: 0,
                unknown_type: 0,
                truncated: 0,
                malformed: 0,
            },
        }
    }

    /// Counters since this decoder was created.
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// Feed one received byte. Returns a result when the byte completed a frame: the message,
    /// or why the frame was rejected (already counted). Empty frames (two delimiters in a row)
    /// are not frames and return None.
    pub fn push<M: WireMessage>(&mut self, byte: u8) -> Option<Result<M, DecodeError>> {
        if byte != 0 {
            if self.overflowed {
                return None;
            }
            if self.len == self.buf.len() {
                self.overflowed = true;
                self.len = 0;
                self.counters.oversize = self.counters.oversize.saturating_add(1);
                return Some(Err(DecodeError::Oversize));
            }
            self.buf[self.len] = byte;
            self.len += 1;
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflowed, false) || len == 0 {
            return None;
        }
        let result = self.decode_frame::<M>(len);
        let counter = match result {
            Ok(_) => &mut self.counters.frames_ok,
            Err(DecodeError::BadCrc) => &mut self.counters.crc_errors,
            Err(DecodeError::Oversize) => &mut self.counters.oversize,
            Err(DecodeError::UnknownType(_)) => &mut self.counters.unknown_type,
            Err(DecodeError::Truncated) => &mut self.counters.truncated,
            Err(DecodeError::Malformed) => &mut self.counters.malformed,
        };
        *counter = counter.saturating_add(1);
        Some(result)
    }

    fn decode_frame<M: WireMessage>(&mut self, stuffed_len: usize) -> Result<M, DecodeError> {
        let len = cobs_decode_in_place(&mut self.buf, stuffed_len).ok_or(DecodeError::Truncated)?;
        if len <= CRC_LEN {
            return Err(DecodeError::Truncated);
        }
        let (payload, crc) = self.buf[..len].split_at(len - CRC_LEN);
        let mut crc_bytes = [0u8; CRC_LEN];
        crc_bytes.copy_from_slice(crc);
        if LINK_CRC.checksum(payload) != u32::from_le_bytes(crc_bytes) {
            return Err(DecodeError::BadCrc);
        }
        // The tag is a varint; every tag we know fits in its first byte.
        let tag = payload[0];
        if tag >= M::VARIANT_COUNT {
            return Err(DecodeError::UnknownType(tag));
        }
        match postcard::take_from_bytes::<M>(payload) {
            Ok((msg, [])) => Ok(msg),
            Ok(_) => Err(DecodeError::Malformed),
            Err(postcard::Error::DeserializeUnexpectedEnd) => Err(DecodeError::Truncated),
            Err(_) => Err(DecodeError::Malformed),
        }
    }
}
