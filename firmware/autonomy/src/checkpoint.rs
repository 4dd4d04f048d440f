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
use crate::capacity::*;
use crate::condition::StateTable;
use crate::executive::Executive;
use crate::model::{TaskNetwork, TaskRole, TimelineKind, VALUE_UNKNOWN};
use crate::plan::Origin;
use crate::planner::{Planner, MAX_SCHEDULE_PASSES};
use crate::telemetry::{FailureKind, TaskState};
use crate::uplink::ValidationError;
use fsw_bridge::MissionTimeUs;

const MAGIC: u32 = 0x4D58_4350; // "MXCP"
/// Version of the checkpoint payload layout; a record of another version is ignored. Version 2:
/// uplink format 2 inside, the executive's retry state, the planner's failure ledger. Version
/// 3: uplink format 3 inside (staleness bounds), and each state-table entry's stale mark (its
/// measurement time was there already).
pub const CHECKPOINT_FORMAT: u16 = 3;
/// Bytes of each record header.
pub const RECORD_HEADER_LEN: usize = 20;

/// The records' CRC-32 (ISO-HDLC, the `crc` crate's `CRC_32_ISO_HDLC`: reflected polynomial
/// 0xEDB88320, initial value and final XOR all ones), four bytes per step with four 256-entry
/// tables (slice-by-4, 4 KiB of tables): about 4 instructions per byte on the 750 where the
/// byte-at-a-time table takes about 9. A warm boot checks the record it restores (about a
/// kilobyte) and every frame writes two; the values are the same (see the tests).
struct Crc32 {
    value: u32,
}

/// `CRC32_TABLES[k][b]`: the CRC register after byte `b` followed by `k` zero bytes.
static CRC32_TABLES: [[u32; 256]; 4] = crc32_tables();

// Evaluated at compile time only (the static's initialiser): an index out of range would be a
// compile error, never a panic at run time.
#[allow(clippy::indexing_slicing)]
const fn crc32_tables() -> [[u32; 256]; 4] {
    let mut tables = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 256 {
        let mut crc = b as u32;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
            bit += 1;
        }
        tables[0][b] = crc;
        b += 1;
    }
    let mut k = 1;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            let previous = tables[k - 1][b];
            tables[k][b] = (previous >> 8) ^ tables[0][(previous & 0xFF) as usize];
            b += 1;
        }
        k += 1;
    }
    tables
}

impl Crc32 {
    const fn new() -> Self {
        Self { value: u32::MAX }
    }

    fn update(&mut self, bytes: &[u8]) {
        // `i & 0xFF` is always in range: the compiler drops the check and `get` never fails.
        let at = |table: &[u32; 256], i: u32| table.get((i & 0xFF) as usize).copied().unwrap_or(0);
        let [t0, t1, t2, t3] = &CRC32_TABLES;
        let mut crc = self.value;
        let mut words = bytes.chunks_exact(4);
        for w in &mut words {
            let (Some(&a), Some(&b), Some(&c), Some(&d)) =
                (w.first(), w.get(1), w.get(2), w.get(3))
            else {
                break;
            };
            crc ^= u32::from_le_bytes([a, b, c, d]);
            crc = at(t3, crc) ^ at(t2, crc >> 8) ^ at(t1, crc >> 16) ^ at(t0, crc >> 24);
        }
        for &byte in words.remainder() {
            crc = at(t0, crc ^ u32::from(byte)) ^ (crc >> 8);
        }
        self.value = crc;
    }

    const fn finalize(self) -> u32 {
        !self.value
    }
}

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
        let slot = newest_here.map_or(0, |(s, _)| 1 - s);
        let newest = match (newest_here.map(|(_, seq)| seq), newest_elsewhere) {
            (Some(a), Some(b)) => Some(if is_newer(b, a) { b } else { a }),
            (a, b) => a.or(b),
        };
        let sequence = newest.map_or(1, |n| n.wrapping_add(1));
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

    /// Erases both records (cold start).
    pub fn invalidate(&mut self) {
        for s in 0..2 {
            if let Some(m) = self.slot_mut(s).get_mut(..4) {
                m.copy_from_slice(&[0; 4]);
            }
        }
    }
}

/// Latest finite mission time a checkpoint may hold. The core takes no input time later than
/// [`MAX_MISSION_TIME_US`] (later grants are clamped to it, later state updates ignored), and
/// what it computes from one adds at most a plan horizon (itself at most
/// [`MAX_MISSION_TIME_US`]) and durations, offsets and back-offs of at most
/// [`MAX_DURATION_US`] each: every time it stores stays below this. [`MissionTimeUs::MAX`]
/// is "never", where a time may be unbounded.
pub const MAX_RESTORED_TIME_US: u64 = 4 * MAX_MISSION_TIME_US;

/// Why a whole record's payload was refused: what is wrong, and where.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PayloadError {
    pub defect: PayloadDefect,
    pub site: PayloadSite,
}

impl PayloadError {
    pub const fn new(defect: PayloadDefect, site: PayloadSite) -> Self {
        Self { defect, site }
    }
}

/// What is wrong with a restored payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PayloadDefect {
    /// The bytes do not decode (a bad varint or tag, a list over its capacity, the payload
    /// ends inside a part).
    Decode,
    /// Bytes remain after the last part.
    TrailingBytes,
    /// The task network inside fails the uplink validation.
    InvalidNetwork(ValidationError),
    /// A list whose length is fixed by the network has another one (timeline anchors, one per
    /// timeline; failure ledgers, one per task definition).
    CountMismatch,
    /// A plan or executive entry names a task definition the network does not have.
    DanglingDefinition,
    /// An entry names a definition that cannot be its own: a requested instance whose
    /// definition is a template or has another ground id, a second requested instance of one
    /// definition, an added instance of a definition that is not a template.
    WrongDefinition,
    /// An executive entry that is not a committed or running instance of the plan with the
    /// same definition.
    NotInPlan,
    /// An index that does not exist (a constraint of a task).
    IndexOutOfRange,
    /// An instance or command id from the wrong range: a planner-given instance id below
    /// [`FIRST_INSTANCE_ID`], a command id of 0 for the next command.
    IdOutOfRange,
    /// A time after [`MAX_RESTORED_TIME_US`] that is not "never", or a task that does not end
    /// within its definition's duration of its start.
    TimeOutOfRange,
    /// A life-cycle state the core never puts there: an executive state in the plan, a
    /// finished task in the executive, a started flag on an instance that never started, a
    /// dispatched task without a command or command id, an interrupted task that was not
    /// dispatched, a plan without a loaded network, a cause given up on that is never counted.
    ImpossibleState,
    /// A count over its bound: scheduling passes, the retries of an instance over its
    /// definition's `max_retries`, consecutive failures of a cause the planner does not count.
    CountOutOfRange,
    /// A timeline value its timeline cannot hold: a state timeline outside its values, a rate
    /// on a timeline that is not cumulative.
    ValueOutOfRange,
    /// Two state-buffer entries with the same key.
    DuplicateKey,
    /// Two plan entries with the same instance id, or the id the planner gives next already
    /// in the plan (the planner gives each instance its own; reports and commands find their
    /// instance by it).
    DuplicateInstance,
}

/// Where in a restored payload a defect is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PayloadSite {
    /// The header part (loaded flag, mission time, state type mismatch count).
    Meta,
    /// The task network, or the length before it.
    Network,
    /// The planner as a whole (its cursor, counters and the lists below).
    Planner,
    /// Plan entry `i`.
    PlanEntry(u16),
    /// The anchor of timeline `i`.
    Anchor(u16),
    /// The failure ledger of task definition `i`.
    Ledger(u16),
    /// Queued execution report `i`.
    Report(u16),
    /// Conflict `i` already tried in the current planner cycle.
    Tried(u16),
    /// The executive as a whole.
    Executive,
    /// Executive entry `i`.
    ExecEntry(u16),
    /// The state buffer copy as a whole.
    States,
    /// State-buffer entry `i`.
    StateEntry(u16),
    /// After the last part.
    End,
}

/// Everything a checkpoint payload restores, decoded and not yet trusted.
pub(crate) struct RestoredState<'a> {
    pub loaded: bool,
    pub now: MissionTimeUs,
    pub network: &'a TaskNetwork,
    pub planner: &'a Planner,
    pub executive: &'a Executive,
    pub states: &'a StateTable,
}

/// A list index as a [`PayloadSite`] names it (every list's capacity is below `u16::MAX`).
fn index(i: usize) -> u16 {
    u16::try_from(i).unwrap_or(u16::MAX)
}

fn time_ok(t: MissionTimeUs) -> bool {
    t.0 <= MAX_RESTORED_TIME_US || t == MissionTimeUs::MAX
}

fn check(ok: bool, defect: PayloadDefect, site: PayloadSite) -> Result<(), PayloadError> {
    if ok {
        Ok(())
    } else {
        Err(PayloadError::new(defect, site))
    }
}

/// Checks a decoded checkpoint the way an uplink is checked: every index refers to something
/// that exists, every time is in range, every state and count is one the core can reach, and
/// the plan, the executive and the network belong together. The network itself was validated
/// as it was decoded. Only true invariants of the core are checked: a checkpoint the core
/// wrote, whatever its inputs were, always passes (the fuzz targets check that).
pub(crate) fn check_restored(s: &RestoredState<'_>) -> Result<(), PayloadError> {
    check_planner_restored(s.loaded, s.now, s.network, s.planner)?;
    check_executive_restored(s.loaded, s.now, s.network, s.executive, s.states)?;
    // Every task the executive holds is one the planner committed.
    for (i, e) in s.executive.entries().iter().enumerate() {
        let in_plan = s.planner.entries().iter().any(|p| {
            p.instance == e.instance
                && p.def == e.def
                && matches!(p.state, TaskState::Committed | TaskState::Running)
        });
        check(
            in_plan,
            PayloadDefect::NotInPlan,
            PayloadSite::ExecEntry(index(i)),
        )?;
    }
    Ok(())
}

/// The planner's half of [`check_restored`]: what a planner partition's checkpoint holds.
pub(crate) fn check_planner_restored(
    loaded: bool,
    now: MissionTimeUs,
    network: &TaskNetwork,
    planner: &Planner,
) -> Result<(), PayloadError> {
    use PayloadDefect::*;
    use PayloadSite as At;
    let tasks = network.tasks();
    check(time_ok(now), TimeOutOfRange, At::Meta)?;
    let empty_network = tasks.is_empty() && network.timelines().is_empty();
    check(
        loaded || (empty_network && planner.entries().is_empty()),
        ImpossibleState,
        At::Meta,
    )?;

    // The planner's own cursor and counters.
    check(
        planner.next_instance_id() >= FIRST_INSTANCE_ID,
        IdOutOfRange,
        At::Planner,
    )?;
    // The id the next added instance gets is one no instance has.
    let next_in_use = planner
        .entries()
        .iter()
        .any(|e| e.instance == planner.next_instance_id());
    check(!next_in_use, DuplicateInstance, At::Planner)?;
    check(
        planner.schedule_passes() < MAX_SCHEDULE_PASSES,
        CountOutOfRange,
        At::Planner,
    )?;
    check(
        planner.last_cycle_at().is_none_or(time_ok),
        TimeOutOfRange,
        At::Planner,
    )?;
    check(
        planner.anchors().len() == network.timelines().len(),
        CountMismatch,
        At::Planner,
    )?;
    check(
        planner.ledger().len() == tasks.len(),
        CountMismatch,
        At::Planner,
    )?;

    for (i, e) in planner.entries().iter().enumerate() {
        let at = At::PlanEntry(index(i));
        let spec = network
            .task(e.def)
            .ok_or(PayloadError::new(DanglingDefinition, at))?;
        match e.origin {
            Origin::Requested => {
                check(
                    spec.role == TaskRole::Requested && e.instance == spec.id,
                    WrongDefinition,
                    at,
                )?;
                let requested_before = planner
                    .entries()
                    .iter()
                    .take(i)
                    .any(|x| x.origin == Origin::Requested && x.def == e.def);
                check(!requested_before, WrongDefinition, at)?;
            }
            Origin::Added { .. } => {
                check(spec.role == TaskRole::Template, WrongDefinition, at)?;
                check(e.instance >= FIRST_INSTANCE_ID, IdOutOfRange, at)?;
            }
            Origin::Restarted { .. } => check(e.instance >= FIRST_INSTANCE_ID, IdOutOfRange, at)?,
        }
        let times = [e.start, e.end, e.earliest_start, e.latest_start];
        check(times.into_iter().all(time_ok), TimeOutOfRange, at)?;
        // Until it ends, an instance spans at most its definition's duration (a start report
        // keeps the span, so a longer one would push its end out of range).
        let span_ok =
            e.state.is_terminal() || (e.start <= e.end && e.end.0 - e.start.0 <= spec.duration_us);
        check(span_ok, TimeOutOfRange, at)?;
        let executive_state = matches!(e.state, TaskState::WaitingPre | TaskState::Dispatched);
        let unstarted = matches!(
            e.state,
            TaskState::Unscheduled | TaskState::Scheduled | TaskState::Committed
        );
        let started_unstarted = e.started && unstarted;
        check(!executive_state && !started_unstarted, ImpossibleState, at)?;
        let seen_before = planner
            .entries()
            .iter()
            .take(i)
            .any(|x| x.instance == e.instance);
        check(!seen_before, DuplicateInstance, at)?;
    }

    for (i, a) in planner.anchors().iter().enumerate() {
        let at = At::Anchor(index(i));
        let times_ok = time_ok(a.at) && a.measured.is_none_or(|m| time_ok(m.at));
        check(times_ok, TimeOutOfRange, at)?;
        let spec = network
            .timelines()
            .get(i)
            .ok_or(PayloadError::new(CountMismatch, at))?;
        match spec.kind {
            TimelineKind::State { value_count, .. } => {
                let fits = |v: i64| v == VALUE_UNKNOWN || (0..i64::from(value_count)).contains(&v);
                let values_ok = fits(a.value) && a.measured.is_none_or(|m| fits(m.value));
                check(values_ok && a.rate == 0, ValueOutOfRange, at)?;
            }
            TimelineKind::Claimable => check(a.rate == 0, ValueOutOfRange, at)?,
            TimelineKind::Cumulative { .. } => {}
        }
    }

    for (i, l) in planner.ledger().iter().enumerate() {
        let at = At::Ledger(index(i));
        check(time_ok(l.not_before), TimeOutOfRange, at)?;
        check(
            l.gave_up & !FailureKind::REPAIRABLE == 0,
            ImpossibleState,
            at,
        )?;
        check(
            l.consecutive.nonzero_causes() & !FailureKind::REPAIRABLE == 0,
            CountOutOfRange,
            at,
        )?;
    }

    for (i, r) in planner.queued_reports().iter().enumerate() {
        check(time_ok(r.at), TimeOutOfRange, At::Report(index(i)))?;
    }
    for (i, &(_, constraint)) in planner.tried_conflicts().iter().enumerate() {
        check(
            usize::from(constraint) < MAX_CONSTRAINTS_PER_TASK,
            IndexOutOfRange,
            At::Tried(index(i)),
        )?;
    }

    Ok(())
}

/// The executive's half of [`check_restored`]: what an executive partition's checkpoint holds
/// (its tasks are checked against the network; against the plan only where both are in one
/// checkpoint).
pub(crate) fn check_executive_restored(
    loaded: bool,
    now: MissionTimeUs,
    network: &TaskNetwork,
    executive: &Executive,
    states: &StateTable,
) -> Result<(), PayloadError> {
    use PayloadDefect::*;
    use PayloadSite as At;
    check(time_ok(now), TimeOutOfRange, At::Meta)?;
    let empty_network = network.tasks().is_empty() && network.timelines().is_empty();
    check(
        loaded || (empty_network && executive.entries().is_empty()),
        ImpossibleState,
        At::Meta,
    )?;
    check(
        executive.next_command_id() != 0,
        IdOutOfRange,
        At::Executive,
    )?;
    for (i, e) in executive.entries().iter().enumerate() {
        let at = At::ExecEntry(index(i));
        let spec = network
            .task(e.def)
            .ok_or(PayloadError::new(DanglingDefinition, at))?;
        let times = [
            e.planned_start,
            e.started_at,
            e.end_at,
            e.dispatched_at,
            e.retry_at,
        ];
        check(times.into_iter().all(time_ok), TimeOutOfRange, at)?;
        check(e.duration_us <= spec.duration_us, TimeOutOfRange, at)?;
        let has_command = spec.command.is_some();
        let state_ok = match e.state {
            TaskState::Committed | TaskState::WaitingPre => true,
            TaskState::Dispatched => has_command && e.command_id != 0,
            TaskState::Running => has_command == (e.command_id != 0),
            _ => false,
        };
        let interrupted_ok =
            !e.interrupted || matches!(e.state, TaskState::Dispatched | TaskState::Running);
        check(state_ok && interrupted_ok, ImpossibleState, at)?;
        let bound = network.max_retries(e.def);
        let retries_ok = FailureKind::ALL
            .iter()
            .all(|&k| e.retries.get(k) <= bound.get(k));
        check(retries_ok, CountOutOfRange, at)?;
    }

    for (i, e) in states.entries().iter().enumerate() {
        let at = At::StateEntry(index(i));
        check(time_ok(e.at), TimeOutOfRange, at)?;
        let seen_before = states.entries().iter().take(i).any(|x| x.key == e.key);
        check(!seen_before, DuplicateKey, at)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::Crc32;
    use crc::{Crc, CRC_32_ISO_HDLC};

    /// The `crc` crate's byte-at-a-time CRC-32 (ISO-HDLC) that the records used before.
    const REFERENCE: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

    #[test]
    fn the_slice_by_4_crc_is_the_iso_hdlc_crc_for_every_length_alignment_and_split() {
        // "123456789" is the catalogue's check value.
        let mut d = Crc32::new();
        d.update(b"123456789");
        assert_eq!(d.finalize(), 0xCBF4_3926);
        let mut x = 0x1234_5678u32;
        let bytes: [u8; 300] = core::array::from_fn(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        });
        for start in 0..4 {
            for len in 0..bytes.len() - start {
                let data = bytes.get(start..start + len).unwrap_or(&[]);
                for split in [0, 1, 3, 16, len / 2, len] {
                    let (a, b) = data.split_at(split.min(len));
                    let mut d = Crc32::new();
                    d.update(a);
                    d.update(b);
                    assert_eq!(
                        d.finalize(),
                        REFERENCE.checksum(data),
                        "{start} {len} {split}"
                    );
                }
            }
        }
    }
}
