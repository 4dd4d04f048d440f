//! Warm-restart area: double-buffered (A/B) checkpoint records with sequence numbers and
//! CRC-32s over a caller-provided byte region that survives a warm reset, and the validation of
//! a restored checkpoint's contents.
//!
//! The region is split into two equal slots. A record is a 20-byte big-endian header
//! (`magic, format, reserved, sequence, length, crc`) followed by the payload; the CRC covers
//! the first 16 header bytes and the payload. A write always goes to the slot that does not
//! hold the newest whole record, and the header is written last, so a reset at any instant
//! leaves at least one whole record. Sequence numbers compare with wrap-around
//! ([`is_newer`]); a truncated or corrupted record is ignored. Only the CRCs needed are
//! computed: the slot whose header claims the newer sequence number is checked first, and the
//! other only if it is not whole (or, at a restore, if its payload is refused).
//!
//! A whole record only proves that its bytes are the ones written. What they say is checked
//! like an uplink before the core runs on it ([`check_restored`]): a payload that does not
//! decode, or that holds an index, a time, a state, a count or a value the core cannot have
//! produced, is refused with a [`PayloadError`] naming the defect and where it is, and the
//! restore falls back to the older record (then to a cold start).

mod crc;
mod payload;

use crc::Crc32;
pub(crate) use payload::{
    check_executive_restored, check_planner_restored, check_restored, RestoredState,
};
pub use payload::{PayloadDefect, PayloadError, PayloadSite, MAX_RESTORED_TIME_US};

const MAGIC: u32 = 0x4D58_4350; // "MXCP"
/// Version of the checkpoint payload layout; a record of another version is ignored. Version 2:
/// uplink format 2 inside, the executive's retry state, the planner's failure ledger. Version
/// 3: uplink format 3 inside (staleness bounds), and each state-table entry's stale mark (its
/// measurement time was there already). Version 4: uplink format 5 inside, and each executive
/// entry's served definition and temporal window. Version 5: the channel's dispatch messages
/// (issue 13 item 3), the executive's dispatch part (`partitioned::ExecutiveDispatch`) and the
/// planner's dispatch notes.
pub const CHECKPOINT_FORMAT: u16 = 5;
/// Bytes of each record header.
pub const RECORD_HEADER_LEN: usize = 20;

/// Why a checkpoint could not be written or restored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CheckpointError {
    /// The payload does not fit in one slot (half the area minus the header).
    AreaTooSmall,
    /// Neither slot holds a whole record of this format.
    NoValidRecord,
    /// Whole records were found but none has a payload that decodes and validates (a firmware
    /// whose layout changed without bumping [`CHECKPOINT_FORMAT`], or contents the core could
    /// not have written). The error is the newest record's.
    BadPayload(PayloadError),
}

/// Whether sequence number `a` is newer than `b`: serial-number arithmetic (RFC 1982), so
/// that `0` is newer than `u32::MAX`. Of two numbers exactly `2^31` apart neither is newer.
pub const fn is_newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// One whole record of an area.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record<'a> {
    /// 0 for slot A, 1 for slot B.
    pub slot: u8,
    pub sequence: u32,
    pub payload: &'a [u8],
}

/// The whole records of the A/B area `bytes` (the layout [`WarmRestartArea`] writes), newest
/// first. Reads only, so it works on memory the caller may not write. Checks both records'
/// CRCs: a restore that needs only the newest uses [`WarmRestartArea::candidates`] and
/// [`WarmRestartArea::record`].
pub fn records(bytes: &[u8]) -> [Option<Record<'_>>; 2] {
    let mut whole = candidates_in(bytes)
        .into_iter()
        .flatten()
        .filter_map(|slot| {
            record_in(bytes, slot).map(|(sequence, payload)| Record {
                slot,
                sequence,
                payload,
            })
        });
    [whole.next(), whole.next()]
}

/// Slot `index` (0 = A, 1 = B) of the A/B area `bytes`.
fn slot_in(bytes: &[u8], index: u8) -> &[u8] {
    let n = bytes.len() / 2;
    let start = usize::from(index) * n;
    bytes.get(start..start + n).unwrap_or(&[])
}

/// What slot `index`'s header claims (see [`WarmRestartArea::claimed`]).
fn claimed_in(bytes: &[u8], index: u8) -> Option<(u32, usize)> {
    let slot = slot_in(bytes, index);
    if be_u32(slot, 0)? != MAGIC || be_u16(slot, 4)? != CHECKPOINT_FORMAT {
        return None;
    }
    let sequence = be_u32(slot, 8)?;
    let len = usize::try_from(be_u32(slot, 12)?).ok()?;
    (len <= slot.len().saturating_sub(RECORD_HEADER_LEN)).then_some((sequence, len))
}

/// The slots whose headers claim a record, newest claim first (see
/// [`WarmRestartArea::candidates`]).
fn candidates_in(bytes: &[u8]) -> [Option<u8>; 2] {
    match (claimed_in(bytes, 0), claimed_in(bytes, 1)) {
        (Some((sa, _)), Some((sb, _))) if is_newer(sb, sa) => [Some(1), Some(0)],
        (Some(_), b) => [Some(0), b.map(|_| 1)],
        (None, b) => [b.map(|_| 1), None],
    }
}

/// Where the next record of an area goes and its number: the slot after the area's newest
/// whole record `newest_here` (slot, sequence; slot A when there is none), numbered after both
/// it and `newest_elsewhere` (another area holding the same checkpoints).
pub fn following(newest_here: Option<(u8, u32)>, newest_elsewhere: Option<u32>) -> (u8, u32) {
    let slot = newest_here.map_or(0, |(s, _)| 1 - (s & 1));
    let newest = match (newest_here.map(|(_, seq)| seq), newest_elsewhere) {
        (Some(a), Some(b)) => Some(if is_newer(b, a) { b } else { a }),
        (a, b) => a.or(b),
    };
    (slot, newest.map_or(1, |n| n.wrapping_add(1)))
}

/// The whole record in slot `index`, as (sequence, payload): header and payload pass the CRC.
fn record_in(bytes: &[u8], index: u8) -> Option<(u32, &[u8])> {
    let slot = slot_in(bytes, index);
    let (sequence, len) = claimed_in(bytes, index)?;
    let crc = be_u32(slot, 16)?;
    let payload = slot.get(RECORD_HEADER_LEN..RECORD_HEADER_LEN.checked_add(len)?)?;
    let mut digest = Crc32::new();
    digest.update(slot.get(..16)?);
    digest.update(payload);
    (digest.finalize() == crc).then_some((sequence, payload))
}

/// What a restore found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RestoreInfo {
    /// 0 for slot A, 1 for slot B.
    pub slot: u8,
    pub sequence: u32,
    pub payload_len: u32,
}

/// A record [`WarmRestartArea::write_record`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WrittenRecord {
    /// 0 for slot A, 1 for slot B.
    pub slot: u8,
    pub sequence: u32,
    /// The byte range of the region written (header and payload): what a target whose region
    /// sits behind a copy must copy out.
    pub bytes: (usize, usize),
}

/// The warm-restart region, split into slots A and B.
pub struct WarmRestartArea<'a> {
    bytes: &'a mut [u8],
}

fn be_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at + 4)?;
    Some(u32::from_be_bytes([
        *s.first()?,
        *s.get(1)?,
        *s.get(2)?,
        *s.get(3)?,
    ]))
}

fn be_u16(b: &[u8], at: usize) -> Option<u16> {
    let s = b.get(at..at + 2)?;
    Some(u16::from_be_bytes([*s.first()?, *s.get(1)?]))
}

impl<'a> WarmRestartArea<'a> {
    /// Wraps the region. Its contents are kept: that is the point.
    pub fn new(bytes: &'a mut [u8]) -> Self {
        Self { bytes }
    }

    fn slot_len(&self) -> usize {
        self.bytes.len() / 2
    }

    /// Largest payload one record can hold.
    pub fn payload_capacity(&self) -> usize {
        self.slot_len().saturating_sub(RECORD_HEADER_LEN)
    }

    fn slot_mut(&mut self, index: u8) -> &mut [u8] {
        let n = self.slot_len();
        let start = usize::from(index) * n;
        self.bytes.get_mut(start..start + n).unwrap_or(&mut [])
    }

    /// The whole records, newest first (see [`records`]; checks both CRCs).
    pub fn records(&self) -> [Option<Record<'_>>; 2] {
        records(self.bytes)
    }

    /// Byte offset of slot `index` (0 = A, 1 = B) in the region.
    pub fn slot_offset(&self, index: u8) -> usize {
        usize::from(index) * self.slot_len()
    }

    /// What slot `index`'s header claims, before any check of its CRC: (sequence, payload
    /// length), if the header has this format's magic and version and the length fits the
    /// slot. A target that copies the region in from slow memory reads the two headers first
    /// and then only the payloads it needs (see [`WarmRestartArea::candidates`]).
    pub fn claimed(&self, index: u8) -> Option<(u32, usize)> {
        claimed_in(self.bytes, index)
    }

    /// The slots whose headers claim a record, newest claim first (sequence numbers compare
    /// with wrap-around, [`is_newer`]; on a tie A comes first): the order in which
    /// [`WarmRestartArea::latest`] checks them. The first whole one is the newest whole
    /// record, so the other slot's payload is read and checked only when the first is torn or
    /// corrupted (or, at a restore, refused).
    pub fn candidates(&self) -> [Option<u8>; 2] {
        candidates_in(self.bytes)
    }

    /// The whole record in slot `index`, as (sequence, payload): header and payload pass the
    /// CRC.
    pub fn record(&self, index: u8) -> Option<(u32, &[u8])> {
        record_in(self.bytes, index)
    }

    /// The newest whole record: (slot, sequence, payload). Of two whole records the one with
    /// the newer sequence number (with wrap-around); only the CRCs needed to know it are
    /// computed (usually one: see [`WarmRestartArea::candidates`]).
    pub fn latest(&self) -> Option<(u8, u32, &[u8])> {
        self.candidates().into_iter().flatten().find_map(|index| {
            self.record(index)
                .map(|(seq, payload)| (index, seq, payload))
        })
    }

    /// Writes a new record whose payload `fill` produces into the given buffer (returning its
    /// length). Returns the slot and sequence number written.
    pub fn write(
        &mut self,
        fill: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Result<(u8, u32), CheckpointError> {
        self.write_record(fill)
            .map(|written| (written.slot, written.sequence))
    }

    /// As [`WarmRestartArea::write`], and says which bytes of the region it wrote.
    pub fn write_record(
        &mut self,
        fill: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Result<WrittenRecord, CheckpointError> {
        self.write_after(None, fill)
    }

    /// [`WarmRestartArea::write_record`], numbered after both this area's newest record and
    /// `newest_elsewhere` (the newest sequence number of another area holding the same
    /// checkpoints): two memories written with the same state carry the same number, so
    /// comparing their numbers says which is newer even after one of them was lost.
    pub fn write_after(
        &mut self,
        newest_elsewhere: Option<u32>,
        fill: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Result<WrittenRecord, CheckpointError> {
        let newest_here = self.latest().map(|(s, seq, _)| (s, seq));
        self.write_following(newest_here, newest_elsewhere, fill)
    }

    /// [`WarmRestartArea::write_after`] for a writer that already knows this area's newest
    /// whole record (slot, sequence), e.g. from having checked it while reading it in: no CRC
    /// is computed again. `newest_here` must be what [`WarmRestartArea::latest`] says.
    pub fn write_following(
        &mut self,
        newest_here: Option<(u8, u32)>,
        newest_elsewhere: Option<u32>,
        fill: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Result<WrittenRecord, CheckpointError> {
        let (slot, sequence) = following(newest_here, newest_elsewhere);
        self.write_slot(slot, sequence, fill)
    }

    /// Writes a record numbered `sequence` into `slot`, its payload written by `fill`: for a
    /// writer that knows the other slot holds the newest whole record (it wrote it), so that
    /// no CRC of the old records is computed to find it. Breaks the slot's old record first
    /// and writes the header last, so a torn write is never taken as whole.
    pub fn write_slot(
        &mut self,
        slot: u8,
        sequence: u32,
        fill: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Result<WrittenRecord, CheckpointError> {
        let slot = slot & 1;
        let capacity = self.payload_capacity();
        let target = self.slot_mut(slot);
        // Break the old record in this slot first, so a torn write is never taken as whole.
        if let Some(m) = target.get_mut(..4) {
            m.copy_from_slice(&[0; 4]);
        }
        let payload_area = target
            .get_mut(RECORD_HEADER_LEN..RECORD_HEADER_LEN + capacity)
            .ok_or(CheckpointError::AreaTooSmall)?;
        let len = fill(payload_area).ok_or(CheckpointError::AreaTooSmall)?;
        if len > capacity {
            return Err(CheckpointError::AreaTooSmall);
        }
        let len32 = u32::try_from(len).map_err(|_| CheckpointError::AreaTooSmall)?;
        let mut header = [0u8; RECORD_HEADER_LEN];
        header[0..4].copy_from_slice(&MAGIC.to_be_bytes());
        header[4..6].copy_from_slice(&CHECKPOINT_FORMAT.to_be_bytes());
        header[8..12].copy_from_slice(&sequence.to_be_bytes());
        header[12..16].copy_from_slice(&len32.to_be_bytes());
        let mut digest = Crc32::new();
        digest.update(&header[..16]);
        digest.update(
            target
                .get(RECORD_HEADER_LEN..RECORD_HEADER_LEN + len)
                .unwrap_or(&[]),
        );
        header[16..20].copy_from_slice(&digest.finalize().to_be_bytes());
        // Header last: until it is complete the record does not count.
        target
            .get_mut(4..RECORD_HEADER_LEN)
            .ok_or(CheckpointError::AreaTooSmall)?
            .copy_from_slice(header.get(4..).unwrap_or(&[]));
        target
            .get_mut(..4)
            .ok_or(CheckpointError::AreaTooSmall)?
            .copy_from_slice(&MAGIC.to_be_bytes());
        let start = self.slot_offset(slot);
        Ok(WrittenRecord {
            slot,
            sequence,
            bytes: (start, start + RECORD_HEADER_LEN + len),
        })
    }

    /// Copies a whole record (its header and payload, as [`WarmRestartArea::write_slot`] made
    /// it in another area: the bytes do not depend on the slot) into `slot`, in the same
    /// order (old record broken first, magic last): the same checkpoint in a second memory
    /// without encoding it or computing its CRC again.
    pub fn copy_record(
        &mut self,
        slot: u8,
        record: &[u8],
    ) -> Result<WrittenRecord, CheckpointError> {
        let slot = slot & 1;
        if be_u32(record, 0) != Some(MAGIC) {
            return Err(CheckpointError::AreaTooSmall);
        }
        let sequence = be_u32(record, 8).ok_or(CheckpointError::AreaTooSmall)?;
        let target = self.slot_mut(slot);
        let dst = target
            .get_mut(..record.len())
            .filter(|d| d.len() >= 4)
            .ok_or(CheckpointError::AreaTooSmall)?;
        dst.get_mut(..4)
            .ok_or(CheckpointError::AreaTooSmall)?
            .copy_from_slice(&[0; 4]);
        dst.get_mut(4..)
            .ok_or(CheckpointError::AreaTooSmall)?
            .copy_from_slice(record.get(4..).unwrap_or(&[]));
        dst.get_mut(..4)
            .ok_or(CheckpointError::AreaTooSmall)?
            .copy_from_slice(record.get(..4).unwrap_or(&[0; 4]));
        let start = self.slot_offset(slot);
        Ok(WrittenRecord {
            slot,
            sequence,
            bytes: (start, start + record.len()),
        })
    }

    /// Erases both records (cold start).
    pub fn invalidate(&mut self) {
        for s in 0..2 {
            if let Some(m) = self.slot_mut(s).get_mut(..4) {
                m.copy_from_slice(&[0; 4]);
            }
        }
    }
}
