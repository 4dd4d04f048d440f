//! The flight application's side of the lockstep protocol, independent of where it runs.
//!
//! [`FlightApp`] takes the host's messages (state-buffer updates, command responses, uplink
//! chunks, time grants), drives the [`autonomy::Autonomy`] core, and sends back what the core
//! decided (command dispatches, telemetry) followed by `FrameDone`. After every granted frame it
//! checkpoints the whole plan into the warm-restart area (RAM kept across a warm reset) and, when
//! there is one, into non-volatile memory (kept across a power cycle), both under the same
//! sequence number. On boot it restores the newest whole checkpoint of the two memories whose
//! contents validate, comparing sequence numbers with wrap-around, and falls back to the next
//! newest when one is refused.
//!
//! Task-network uplinks and ground commands are authenticated ([`sdls`], in the manner of CCSDS
//! SDLS): a reassembled uplink is verified (key, MAC, anti-replay sequence number) before it is
//! validated and loaded, a ground command before it is carried out, and in both cases the new
//! anti-replay counter is written to non-volatile memory before anything takes effect. A
//! refused one is answered with its typed reason ([`fsw_bridge::SecurityRefusal`]: as the
//! `UplinkNak` reason code, or in `GroundCommandNak`), counted in a metric
//! ([`metric::SECURITY_REFUSALS_FIRST`]), and changes nothing: the running plan, the counter and
//! the holds stay as they were.
//!
//! The firmware runs it inside its partitions; `hil`'s native target runs the very same code in
//! the host process, which is what makes the native-versus-emulated comparison meaningful.
#![no_std]
#![forbid(unsafe_code)]

use autonomy::checkpoint::{self, Record, RECORD_HEADER_LEN};
pub use autonomy::partitioned::{ExecutiveInput, PlannerInput, PlannerStatus as Status, Wire};
use autonomy::partitioned::{ExecutivePartition, PartitionSide, PlannerPartition, PlannerStatus};
use autonomy::{Outputs, RestoreInfo, WarmRestartArea};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::security::{MAC_LEN, MAX_GROUND_HOLDS};
use fsw_bridge::{
    CommandArgs, CommandRefusal, GroundCommand, HostToTarget, MissionTimeUs, Opcode,
    SecurityHeader, SecurityRefusal, TargetToHost, TelemetryEvent,
};
pub use sdls::{SecurityAssociation, SecurityStore, StoreError};

/// Largest secured task-network uplink the application accepts, in bytes: the image plus its
/// security header and trailer (`sdls::uplink::OVERHEAD`, 42 bytes). 32 KiB since the lander
/// capacities (issue 14): a network of 256 light tasks (two constraints, three impacts each) is
/// about 25 KiB; at 16 KiB the largest such network was 162 tasks. What a checkpoint slot
/// holds is the tighter bound now (see the README's "Capacities and RAM").
pub const MAX_UPLINK_BYTES: usize = 32 * 1024;

/// `UplinkNak` reasons of the transfer itself (validation failures use the autonomy core's
/// `ValidationCode::code()`, which stay below 0xff00).
pub mod uplink_reason {
    /// A chunk arrived out of order (or a continuation without a first chunk).
    pub const OUT_OF_SEQUENCE: u16 = 0xff01;
    /// The announced or accumulated size exceeds [`super::MAX_UPLINK_BYTES`].
    pub const TOO_LARGE: u16 = 0xff02;
    /// The executive still owns tasks of the running plan; uplink again when it is idle.
    pub const BUSY: u16 = 0xff03;
    /// `total` was zero, or changed in the middle of a transfer.
    pub const BAD_TOTAL: u16 = 0xff04;
    // 0xff10 and up: the security refusals, `fsw_bridge::SecurityRefusal::code()`.
}

/// Ids of the `TelemetryEvent::Metric` records this application emits: the telemetry
/// dictionary's application table (`fsw_bridge::dictionary::app`, ids 0x1000-0x1fff), where
/// each id's name, unit, kind (measured cost or value) and channel are declared; the kernel's
/// are below 0x1000 (kernel-config's `abi::metric`, the dictionary's platform table).
pub mod metric {
    pub use fsw_bridge::dictionary::app::*;
    use fsw_bridge::dictionary::restored_from;

    /// `RESTORED_FROM`: the warm-restart area.
    pub const RESTORED_FROM_WARM: u64 = restored_from::WARM;
    /// `RESTORED_FROM`: non-volatile memory.
    pub const RESTORED_FROM_NV: u64 = restored_from::NV;
}

/// Validity checks the planner may spend in one window (see `autonomy::planner`); a cycle
/// that needs more goes on in the next frame's window.
pub const DEFAULT_PLANNER_BUDGET: u32 = 20_000;

/// Where the application's messages go.
pub trait Downlink {
    fn send(&mut self, msg: TargetToHost);
}

impl<F: FnMut(TargetToHost)> Downlink for F {
    fn send(&mut self, msg: TargetToHost) {
        self(msg)
    }
}

/// A CPU clock for cost accounting (the timebase on the target, 0 natively).
pub trait CpuClock {
    fn ticks(&mut self) -> u64;
}

/// A clock that always reads 0: the native target counts no cycles.
pub struct NoClock;

impl CpuClock for NoClock {
    fn ticks(&mut self) -> u64 {
        0
    }
}

/// The memories the application checkpoints into, and where it keeps its key and counters.
pub struct Memories<'a> {
    /// Warm-restart area: survives a warm reset.
    pub warm: &'a mut [u8],
    /// Non-volatile memory's checkpoint areas: survive a power cycle (None where there is none).
    pub nv: Option<&'a mut [u8]>,
    /// Non-volatile memory's security area (`sdls::nv`: the key slot and the anti-replay
    /// counter records). None where there is none: then every authenticated uplink and
    /// ground command is refused with `NoKey`.
    pub security: Option<&'a mut dyn SecurityStore>,
}

/// Which of the two checkpoint memories. The warm one sorts first: of two records with the
/// same sequence number (the same checkpoint), the warm one is tried first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum MemoryKind {
    /// The warm-restart area ([`Memories::warm`]).
    Warm,
    /// Non-volatile memory's checkpoint areas ([`Memories::nv`]).
    Nv,
}

/// A target whose memories sit behind an interface (the firmware: system calls into the
/// kernel) gives the application copies that start out empty, and this to fill them: the
/// application asks for the bytes it needs, at the offset they have in the copy, instead of the
/// target copying both 64 KiB areas in at every boot. At boot it reads the two record headers
/// of each memory, then the records they claim, newest claim of either memory first, until one
/// is whole and its payload validates (usually the first: the warm area's newest). The records
/// of a memory that the choice did not need are read before its first checkpoint write (which
/// must know the slot holding its newest whole record). A target that passes none hands over
/// complete copies.
pub trait MemoryFetch {
    /// Fill `bytes` from `memory` at `offset`.
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError>;
}

/// What the application's copy of one memory holds, when a [`MemoryFetch`] fills it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct CopyState {
    /// The slots whose payloads have been read in (bit `i` for slot `i`).
    payloads_read: u8,
    /// The copy holds the memory's newest whole record, or the memory has none: a checkpoint
    /// write into the copy picks the slot it would pick in the memory.
    newest_known: bool,
}

impl CopyState {
    /// A complete copy.
    const COMPLETE: Self = Self {
        payloads_read: 0b11,
        newest_known: true,
    };
}

/// Reads the payload that slot `index`'s header claims into `copy`, unless it is there already.
/// False if the header claims none or the read failed. Without `fetch` the copy is complete.
fn fetch_payload(
    copy: &mut [u8],
    memory: MemoryKind,
    index: u8,
    fetch: Option<&mut (dyn MemoryFetch + '_)>,
    state: &mut CopyState,
) -> bool {
    let Some(fetch) = fetch else {
        return true;
    };
    let bit = 1u8 << index;
    if state.payloads_read & bit != 0 {
        return true;
    }
    let area = WarmRestartArea::new(copy);
    let Some((_, len)) = area.claimed(index) else {
        return false;
    };
    let start = area.slot_offset(index) + RECORD_HEADER_LEN;
    let Some(payload) = copy.get_mut(start..start + len) else {
        return false;
    };
    if fetch.fetch(memory, start, payload).is_err() {
        return false;
    }
    state.payloads_read |= bit;
    true
}

/// Makes `copy` hold its memory's newest whole record, before a checkpoint write into it:
/// reads the payloads of the slots whose headers claim a record, newest claim first, until one
/// is whole (what [`WarmRestartArea::latest`] will look at). The headers must be in `copy`
/// already.
fn fetch_latest(
    copy: &mut [u8],
    memory: MemoryKind,
    mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
    state: &mut CopyState,
) {
    if state.newest_known {
        return;
    }
    let candidates = WarmRestartArea::new(copy).candidates();
    for index in candidates.into_iter().flatten() {
        if fetch_payload(copy, memory, index, fetch.as_deref_mut(), state)
            && WarmRestartArea::new(copy).record(index).is_some()
        {
            break;
        }
    }
    state.newest_known = true;
}

/// Read the two record headers of an A/B area into its copy (a failed read leaves that
/// header's bytes as they were: zero in a fresh copy, which claims nothing).
fn fetch_headers(copy: &mut [u8], memory: MemoryKind, fetch: &mut (dyn MemoryFetch + '_)) {
    for index in 0..2 {
        let start = WarmRestartArea::new(copy).slot_offset(index);
        if let Some(header) = copy.get_mut(start..start + RECORD_HEADER_LEN) {
            let _ = fetch.fetch(memory, start, header);
        }
    }
}

/// A record a header claims: its memory, slot and sequence number.
type Claim = (MemoryKind, u8, u32);

/// The records the headers of both memories claim, newest first by sequence number with
/// wrap-around ([`checkpoint::is_newer`]); of two with the same number the warm one, then
/// slot A. Reads the headers only (no CRC).
fn claims(memories: &mut Memories<'_>) -> heapless::Vec<Claim, 4> {
    let mut claims: heapless::Vec<Claim, 4> = heapless::Vec::new();
    let warm = Some(&mut *memories.warm);
    let nv = memories.nv.as_deref_mut();
    for (memory, copy) in [(MemoryKind::Warm, warm), (MemoryKind::Nv, nv)] {
        let Some(copy) = copy else { continue };
        let area = WarmRestartArea::new(copy);
        for index in 0..2 {
            if let Some((sequence, _)) = area.claimed(index) {
                let _ = claims.push((memory, index, sequence));
            }
        }
    }
    // Sequence numbers relative to one of them are a linear order as long as they span less
    // than half the number space (they are a few frames apart).
    let reference = claims.first().map_or(0, |&(_, _, sequence)| sequence);
    let key =
        |&(memory, slot, sequence): &Claim| (reference.wrapping_sub(sequence) as i32, memory, slot);
    // At most four claims, with distinct keys (memory and slot): an insertion sort, which
    // orders them as any sort does, without the library's general sort in the image (its
    // code is read by the reset stub's image check at every warm boot).
    for i in 1..claims.len() {
        let mut j = i;
        while j > 0 {
            let (Some(a), Some(b)) = (claims.get(j - 1).copied(), claims.get(j).copied()) else {
                break;
            };
            if key(&a) <= key(&b) {
                break;
            }
            claims.swap(j - 1, j);
            j -= 1;
        }
    }
    claims
}

/// The newer of two sequence numbers (wrap-around).
fn newer(a: Option<u32>, b: u32) -> u32 {
    match a {
        Some(a) if checkpoint::is_newer(a, b) => a,
        _ => b,
    }
}

/// How the application came up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BootOutcome {
    /// No whole checkpoint anywhere: waiting for an uplink.
    Cold,
    /// Restored from the warm-restart area.
    RestoredWarm(RestoreInfo),
    /// Restored from non-volatile memory.
    RestoredNv(RestoreInfo),
}

/// Sends the core's decisions down the link.
struct Decisions<'d, D: Downlink> {
    downlink: &'d mut D,
}

impl<D: Downlink> Outputs for Decisions<'_, D> {
    fn dispatch(&mut self, id: u32, opcode: Opcode, args: &CommandArgs) {
        self.downlink.send(TargetToHost::CommandDispatch {
            id,
            opcode,
            args: args.clone(),
        });
    }

    fn telemetry(&mut self, event: TelemetryEvent) {
        self.downlink.send(TargetToHost::Telemetry(event));
    }
}

/// Where one partition's checkpoints stand in its two memories: what its copies hold, the
/// newest sequence number, and the byte ranges the last checkpoint wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Persistence {
    /// What the copies of the warm-restart area and of non-volatile memory hold, when a
    /// [`MemoryFetch`] fills them.
    copies: [CopyState; 2],
    /// The slot of each memory (warm, non-volatile) that holds the newest whole record, once
    /// this side has written one there since its boot: the next write goes to the other
    /// without reading or checking the old records.
    newest_slot: [Option<u8>; 2],
    /// The newest sequence number of a whole record in either memory (found at boot, then the
    /// last one written): both memories' next checkpoints are numbered after it.
    newest_sequence: Option<u32>,
    /// Byte ranges of the warm memory the checkpoints since the last take wrote, in order (a
    /// target whose warm-restart area sits behind a system call copies just these bytes).
    last_warm_write: Writes,
    /// The same for non-volatile memory.
    last_nv_write: Writes,
}

/// Byte ranges (start, end) written into a memory's copy, in order.
pub type Writes = heapless::Vec<(usize, usize), 4>;

/// Adds `range` to `writes`; with no room left, the last range grows to cover it (more
/// bytes copied out, none missed).
fn record_write(writes: &mut Writes, range: (usize, usize)) {
    if let Err(range) = writes.push(range) {
        if let Some(last) = writes.last_mut() {
            *last = (last.0.min(range.0), last.1.max(range.1));
        }
    }
}

impl Persistence {
    const NEW: Self = Self {
        copies: [CopyState::COMPLETE; 2],
        newest_slot: [None; 2],
        newest_sequence: None,
        last_warm_write: heapless::Vec::new(),
        last_nv_write: heapless::Vec::new(),
    };

    /// Checkpoint `side` into the warm memory and, if there is one, non-volatile memory, both
    /// under the sequence number after the newest of either; returns how many of the writes
    /// failed. When one write succeeded the side is told it is checkpointed.
    fn checkpoint_all(
        &mut self,
        side: &mut impl PartitionSide,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
    ) -> u64 {
        let newest = self.newest_sequence;
        let sequence = newest.map_or(1, |n| n.wrapping_add(1));
        let mut failures = 0;
        // A write goes to the slot that does not hold the newest whole record. Once this side
        // has written a memory it knows that slot; before (after a boot), the copy must hold
        // the records to find it (see `MemoryFetch`).
        let [warm_copy, nv_copy] = &mut self.copies;
        let warm = match self.newest_slot[0] {
            Some(slot) => {
                WarmRestartArea::new(memories.warm)
                    .write_slot(1 - slot, sequence, |buf| side.encode_state(buf))
            }
            None => {
                fetch_latest(
                    memories.warm,
                    MemoryKind::Warm,
                    fetch.as_deref_mut(),
                    warm_copy,
                );
                WarmRestartArea::new(memories.warm)
                    .write_after(newest, |buf| side.encode_state(buf))
            }
        };
        let warm = match warm {
            Ok(written) => {
                record_write(&mut self.last_warm_write, written.bytes);
                self.newest_sequence = Some(newer(self.newest_sequence, written.sequence));
                self.newest_slot[0] = Some(written.slot);
                Some(written)
            }
            Err(_) => {
                failures += 1;
                None
            }
        };
        let mut writes = 1;
        if let Some(nv) = memories.nv.as_deref_mut() {
            writes += 1;
            // The same record: copied from the warm memory's when both are numbered alike
            // (no second encoding, no second CRC), else written afresh.
            let record = warm
                .filter(|w| w.sequence == sequence)
                .and_then(|w| memories.warm.get(w.bytes.0..w.bytes.1));
            let written = match (self.newest_slot[1], record) {
                (Some(slot), Some(record)) => {
                    WarmRestartArea::new(nv).copy_record(1 - slot, record)
                }
                (Some(slot), None) => {
                    WarmRestartArea::new(nv)
                        .write_slot(1 - slot, sequence, |buf| side.encode_state(buf))
                }
                (None, _) => {
                    fetch_latest(nv, MemoryKind::Nv, fetch, nv_copy);
                    WarmRestartArea::new(nv).write_after(newest, |buf| side.encode_state(buf))
                }
            };
            match written {
                Ok(written) => {
                    record_write(&mut self.last_nv_write, written.bytes);
                    self.newest_sequence = Some(newer(self.newest_sequence, written.sequence));
                    self.newest_slot[1] = Some(written.slot);
                }
                Err(_) => failures += 1,
            }
        }
        // A state that fits no slot (a network over what a checkpoint holds) is flown on
        // unprotected, as a single core was: the side goes on as if checkpointed, so the ports
        // keep moving, and every failed write is counted (CHECKPOINT_WRITE_FAILURES). A reset
        // then restores the side's older checkpoint, or none, and the ports' resume brings the
        // other side up to date.
        let _ = writes;
        side.checkpointed();
        failures
    }

    /// Read the record headers of both memories (a target whose memories sit behind `fetch`);
    /// the copies start out knowing nothing else.
    fn start(&mut self, memories: &mut Memories<'_>, fetch: Option<&mut (dyn MemoryFetch + '_)>) {
        self.copies = [CopyState::COMPLETE; 2];
        self.newest_slot = [None; 2];
        if let Some(fetch) = fetch {
            self.copies = [CopyState::default(); 2];
            fetch_headers(memories.warm, MemoryKind::Warm, fetch);
            if let Some(nv) = memories.nv.as_deref_mut() {
                fetch_headers(nv, MemoryKind::Nv, fetch);
            }
        }
    }

    /// The restore choice: the records of both memories (two slots each), newest first by
    /// sequence number with wrap-around ([`checkpoint::is_newer`]; of two with the same number,
    /// the warm one, which holds the same checkpoint); the first that is whole and whose payload
    /// decodes and validates is restored. Cold when there is none. Only the records tried are
    /// read in and CRC-checked: usually one. Also finds the newest sequence number of a whole
    /// record, after which the next checkpoints are numbered. Returns the outcome and the ticks
    /// spent decoding and validating payloads.
    fn restore_newest(
        &mut self,
        side: &mut impl PartitionSide,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
    ) -> (BootOutcome, u64) {
        let mut decode_ticks = 0u64;
        let mut newest = None;
        let mut outcome = BootOutcome::Cold;
        for (memory, slot, _) in claims(memories) {
            let (copy, state) = match memory {
                MemoryKind::Warm => (&mut *memories.warm, &mut self.copies[0]),
                MemoryKind::Nv => match memories.nv.as_deref_mut() {
                    Some(nv) => (nv, &mut self.copies[1]),
                    None => continue,
                },
            };
            if !fetch_payload(copy, memory, slot, fetch.as_deref_mut(), state) {
                continue;
            }
            let area = WarmRestartArea::new(copy);
            let Some((sequence, payload)) = area.record(slot) else {
                continue;
            };
            // The first whole record is the newest.
            newest.get_or_insert(sequence);
            // This memory's newest whole record is in its copy when the slots before this one
            // in its own order have been read (they were not whole, or were refused).
            let read_before = area
                .candidates()
                .into_iter()
                .flatten()
                .take_while(|&s| s != slot)
                .all(|s| state.payloads_read & (1 << s) != 0);
            state.newest_known |= read_before;
            let t = clock.ticks();
            let restored = side.restore_record(Record {
                slot,
                sequence,
                payload,
            });
            decode_ticks = decode_ticks.wrapping_add(clock.ticks().wrapping_sub(t));
            if let Ok(info) = restored {
                // The slot restored holds a whole, valid record: the next write in this memory
                // goes to the other without checking the old records again.
                let index = match memory {
                    MemoryKind::Warm => 0,
                    MemoryKind::Nv => 1,
                };
                self.newest_slot[index] = Some(slot);
                outcome = match memory {
                    MemoryKind::Warm => BootOutcome::RestoredWarm(info),
                    MemoryKind::Nv => BootOutcome::RestoredNv(info),
                };
                break;
            }
        }
        self.newest_sequence = newest;
        (outcome, decode_ticks)
    }
}

/// The frame whose first window ran and whose planner answer is awaited.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Awaiting {
    frame: u32,
    /// Ticks of the first window's executive pass and of its checkpoint.
    pass_ticks: u64,
    checkpoint_ticks: u64,
}

/// The executive partition's application: the control loop (`autonomy::partitioned`'s
/// executive side) plus the lockstep, uplink and security protocol around it. A granted
/// frame runs in two windows: [`ExecutiveApp::first_window`] at the grant, and
/// [`ExecutiveApp::second_window`] once the planner partition has answered the frame (its
/// commits, decisions and status come through [`ExecutiveApp::receive`]), which ends with
/// `FrameDone`. Between them [`ExecutiveApp::transmit`] hands the planner what the first
/// window checkpointed.
pub struct ExecutiveApp {
    executive: ExecutivePartition,
    uplink: [u8; MAX_UPLINK_BYTES],
    uplink_len: usize,
    /// (next expected sequence number, announced total) of the transfer in progress.
    uplink_progress: Option<(u16, u16)>,
    /// Set after a restore until the repaired plan is committed: the CPU spent on recovery so
    /// far (see [`metric::RECOVERY_TICKS`]).
    recovering: Option<u64>,
    /// The last frame finished and what its FrameDone said: a grant for that frame again (the
    /// host lost our FrameDone, or its grant reached us twice) is answered without stepping.
    last_done: Option<(u32, Option<MissionTimeUs>)>,
    /// The frame between its two windows.
    awaiting: Option<Awaiting>,
    persist: Persistence,
    /// The state type mismatch count last reported ([`metric::STATE_TYPE_MISMATCHES`]).
    reported_state_type_mismatches: u32,
    /// The stale-commit count last reported ([`metric::STALE_COMMITS`]).
    reported_stale_commits: u32,
    /// Frames whose planner cycle stopped on its budget, since boot
    /// ([`metric::PLANNER_PENDING_FRAMES`]).
    pending_frames: u32,
    /// The key, the anti-replay counter and the ground holds, read from non-volatile memory at
    /// boot.
    security: SecurityAssociation,
    /// Refusals by the security checks since boot, per reason.
    security_refusals: [u32; SecurityRefusal::COUNT],
    /// Authentic ground commands not carried out since boot.
    commands_not_carried_out: u32,
}

impl Default for ExecutiveApp {
    fn default() -> Self {
        Self::new()
    }
}

impl ExecutiveApp {
    /// `const` so it can be placed in a partition's static memory.
    pub const fn new() -> Self {
        Self {
            executive: ExecutivePartition::new(),
            uplink: [0; MAX_UPLINK_BYTES],
            uplink_len: 0,
            uplink_progress: None,
            recovering: None,
            last_done: None,
            awaiting: None,
            persist: Persistence::NEW,
            reported_state_type_mismatches: 0,
            reported_stale_commits: 0,
            pending_frames: 0,
            security: SecurityAssociation::none(),
            security_refusals: [0; SecurityRefusal::COUNT],
            commands_not_carried_out: 0,
        }
    }

    /// Makes this application what [`ExecutiveApp::new`] makes, in place, but for the bytes of
    /// the uplink buffer (only its first `uplink_len` bytes are ever read, and that is now 0):
    /// writing a constant image of it into a static would copy tens of KiB that sit in the
    /// firmware image and that the reset stub's image check reads at every boot.
    pub fn reset(&mut self) {
        self.executive.reset();
        self.uplink_len = 0;
        self.uplink_progress = None;
        self.recovering = None;
        self.last_done = None;
        self.awaiting = None;
        self.persist = Persistence::NEW;
        self.reported_state_type_mismatches = 0;
        self.reported_stale_commits = 0;
        self.pending_frames = 0;
        self.security = SecurityAssociation::none();
        self.security_refusals = [0; SecurityRefusal::COUNT];
        self.commands_not_carried_out = 0;
    }

    /// The security association read at boot and updated by every accepted message.
    pub fn security(&self) -> &SecurityAssociation {
        &self.security
    }

    /// Refusals by the security checks since boot for `reason`.
    pub fn security_refusals(&self, reason: SecurityRefusal) -> u32 {
        self.security_refusals[reason.index()]
    }

    /// The control loop's side of the core.
    pub fn executive(&self) -> &ExecutivePartition {
        &self.executive
    }

    /// The ranges of warm memory written by the checkpoints since the last call, in order.
    pub fn take_warm_writes(&mut self) -> Writes {
        core::mem::take(&mut self.persist.last_warm_write)
    }

    /// The same for non-volatile memory.
    pub fn take_nv_writes(&mut self) -> Writes {
        core::mem::take(&mut self.persist.last_nv_write)
    }

    /// Whether a frame waits for the planner's answer.
    pub fn awaiting_planner(&self) -> bool {
        self.awaiting.is_some()
    }

    /// Come up after a (re)boot: restore the newest whole checkpoint of the two memories whose
    /// payload validates (complete copies of both; see [`ExecutiveApp::boot_fetching`]).
    pub fn boot(
        &mut self,
        memories: &mut Memories<'_>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        self.boot_fetching(memories, None, clock, downlink)
    }

    /// As [`ExecutiveApp::boot`], with copies of the memories that `fetch` fills on demand (see
    /// [`MemoryFetch`]). The choice is the same (see `Persistence::restore_newest`).
    pub fn boot_fetching(
        &mut self,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        let t0 = clock.ticks();
        self.security = SecurityAssociation::load(memories.security.as_deref_mut());
        if self.security.holds() != 0 {
            downlink.send(metric_event(
                metric::GROUND_HOLDS,
                u64::from(self.security.holds()),
            ));
        }
        let t_security = clock.ticks();
        self.persist.start(memories, fetch.as_deref_mut());
        let (outcome, decode_ticks) =
            self.persist
                .restore_newest(&mut self.executive, memories, fetch, clock);
        let t_end = clock.ticks();
        if t_end != t0 {
            downlink.send(metric_event(
                metric::BOOT_SECURITY_TICKS,
                t_security.wrapping_sub(t0),
            ));
            downlink.send(metric_event(
                metric::RESTORE_CHECK_TICKS,
                t_end.wrapping_sub(t_security).wrapping_sub(decode_ticks),
            ));
            downlink.send(metric_event(metric::RESTORE_DECODE_TICKS, decode_ticks));
        }
        if let BootOutcome::RestoredWarm(info) | BootOutcome::RestoredNv(info) = outcome {
            self.recovering = Some(0);
            let from = match outcome {
                BootOutcome::RestoredNv(_) => metric::RESTORED_FROM_NV,
                _ => metric::RESTORED_FROM_WARM,
            };
            downlink.send(metric_event(metric::RESTORE_TICKS, t_end.wrapping_sub(t0)));
            downlink.send(metric_event(
                metric::RESTORED_SEQUENCE,
                u64::from(info.sequence),
            ));
            downlink.send(metric_event(metric::RESTORED_FROM, from));
            downlink.send(metric_event(metric::RESTORED_SLOT, u64::from(info.slot)));
        }
        outcome
    }

    /// Handle one message from the host. Returns false for messages that are not the
    /// application's (Ping, ResetRequest: the I/O layer answers those).
    pub fn handle(
        &mut self,
        msg: &HostToTarget,
        memories: &mut Memories<'_>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        self.handle_fetching(msg, memories, None, clock, downlink)
    }

    /// As [`ExecutiveApp::handle`], for copies of the memories filled on demand by `fetch`
    /// (the same as at [`ExecutiveApp::boot_fetching`]). A time grant runs the frame's first
    /// window.
    pub fn handle_fetching(
        &mut self,
        msg: &HostToTarget,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        let t0 = self.recovering.map(|_| clock.ticks());
        match msg {
            HostToTarget::StateUpdate {
                key,
                value,
                timestamp,
            } => self.executive.on_state_update(*key, *value, *timestamp),
            HostToTarget::CommandResponse { id, status, .. } => {
                self.executive.on_command_response(*id, *status)
            }
            HostToTarget::UplinkChunk { seq, total, bytes } => {
                self.uplink_chunk((*seq, *total, bytes), memories, fetch, clock, downlink)
            }
            HostToTarget::GroundCommand {
                header,
                command,
                mac,
            } => self.ground_command(header, command, mac, memories, downlink),
            HostToTarget::TimeGrant { frame, now, .. } => {
                // Accounts its own recovery time.
                self.first_window(*frame, *now, memories, fetch, clock, downlink);
                return true;
            }
            HostToTarget::Ping { .. } | HostToTarget::ResetRequest { .. } => return false,
        }
        if let (Some(t0), Some(spent)) = (t0, self.recovering.as_mut()) {
            *spent = spent.wrapping_add(clock.ticks().wrapping_sub(t0));
        }
        true
    }

    /// Takes one message from the planner partition.
    pub fn receive(&mut self, wire: Wire<ExecutiveInput>) {
        self.executive.receive(wire);
    }

    /// Checkpoints now if messages for the planner wait for a checkpoint (they were made
    /// outside a window's work: the planner came up without its checkpoint and is sent the
    /// network again). Returns whether it wrote one.
    pub fn checkpoint_if_needed(
        &mut self,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        downlink: &mut impl Downlink,
    ) -> bool {
        if !self.executive.awaits_checkpoint() {
            return false;
        }
        let failures = self
            .persist
            .checkpoint_all(&mut self.executive, memories, fetch);
        if failures > 0 {
            downlink.send(metric_event(metric::CHECKPOINT_WRITE_FAILURES, failures));
        }
        true
    }

    /// Hands the planner partition what the last checkpoint holds (see
    /// `autonomy::partitioned`), until `send` refuses one (a full port).
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<PlannerInput>) -> bool) {
        self.executive.transmit(send);
    }

    /// The first window of granted frame `frame` at `now`: the first executive pass, the
    /// checkpoint, then the frame waits for the planner (a grant for a frame already done is
    /// answered with its FrameDone again; one for the frame in progress is ignored).
    fn first_window(
        &mut self,
        frame: u32,
        now: MissionTimeUs,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) {
        if let Some((done, next_wakeup)) = self.last_done {
            if done == frame {
                downlink.send(TargetToHost::FrameDone { frame, next_wakeup });
                return;
            }
        }
        if self.awaiting.is_some_and(|a| a.frame == frame) {
            return;
        }
        let t0 = clock.ticks();
        self.executive.first_window(
            frame,
            now,
            &mut Decisions {
                downlink: &mut *downlink,
            },
        );
        let t1 = clock.ticks();
        let failures = self
            .persist
            .checkpoint_all(&mut self.executive, memories, fetch);
        let t2 = clock.ticks();
        if failures > 0 {
            downlink.send(metric_event(metric::CHECKPOINT_WRITE_FAILURES, failures));
        }
        if let Some(spent) = self.recovering.as_mut() {
            *spent = spent.wrapping_add(t2.wrapping_sub(t0));
        }
        self.awaiting = Some(Awaiting {
            frame,
            pass_ticks: t1.wrapping_sub(t0),
            checkpoint_ticks: t2.wrapping_sub(t1),
        });
    }

    /// The second window of the frame in progress, once the planner has answered it: the
    /// planner's decisions for the host, the second executive pass, the checkpoint, the
    /// frame's metrics and `FrameDone`. False (nothing done) while the planner has not
    /// answered.
    pub fn second_window(
        &mut self,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        let Some(awaiting) = self.awaiting else {
            return false;
        };
        if !self.executive.planner_answered() {
            return false;
        }
        let t0 = clock.ticks();
        self.executive.second_window(&mut Decisions {
            downlink: &mut *downlink,
        });
        let t1 = clock.ticks();
        let status = self.executive.planner_status().unwrap_or_default();
        let repaired = !status.pending;
        if let Some(spent) = self.recovering.as_mut() {
            *spent = spent.wrapping_add(t1.wrapping_sub(t0));
            if repaired {
                // The repaired plan is committed.
                downlink.send(metric_event(metric::RECOVERY_TICKS, *spent));
                self.recovering = None;
            }
        }
        let failures = self
            .persist
            .checkpoint_all(&mut self.executive, memories, fetch);
        let t2 = clock.ticks();
        if let Some(spent) = self.recovering.as_mut() {
            // Still repairing: this frame's checkpoint is on the way to the committed plan.
            *spent = spent.wrapping_add(t2.wrapping_sub(t1));
        }
        if failures > 0 {
            downlink.send(metric_event(metric::CHECKPOINT_WRITE_FAILURES, failures));
        }
        let mismatches = self.executive.control().state_type_mismatches();
        if mismatches != self.reported_state_type_mismatches {
            downlink.send(metric_event(
                metric::STATE_TYPE_MISMATCHES,
                u64::from(mismatches),
            ));
            if let Some(key) = self.executive.control().last_state_type_mismatch() {
                downlink.send(metric_event(
                    metric::STATE_TYPE_MISMATCH_KEY,
                    u64::from(key.0),
                ));
            }
            self.reported_state_type_mismatches = mismatches;
        }
        let stale = self.executive.stats.stale_commits;
        if stale != self.reported_stale_commits {
            downlink.send(metric_event(metric::STALE_COMMITS, u64::from(stale)));
            self.reported_stale_commits = stale;
        }
        if status.pending {
            self.pending_frames = self.pending_frames.saturating_add(1);
            downlink.send(metric_event(
                metric::PLANNER_PENDING_FRAMES,
                u64::from(self.pending_frames),
            ));
        }
        if let Some(latency) = status.cycle_latency_us.filter(|&l| l > 0) {
            downlink.send(metric_event(metric::PLANNING_LATENCY_US, latency));
        }
        if t2 != t0 {
            let pass = awaiting.pass_ticks.wrapping_add(t1.wrapping_sub(t0));
            let checkpoint = awaiting.checkpoint_ticks.wrapping_add(t2.wrapping_sub(t1));
            downlink.send(metric_event(metric::STEP_TICKS, pass));
            downlink.send(metric_event(metric::EXECUTIVE_TICKS, pass));
            downlink.send(metric_event(metric::CHECKPOINT_TICKS, checkpoint));
            downlink.send(metric_event(
                metric::FRAME_BUSY_TICKS,
                pass.wrapping_add(checkpoint),
            ));
        }
        let next_wakeup = self.executive.next_wakeup();
        let frame = awaiting.frame;
        self.awaiting = None;
        self.last_done = Some((frame, next_wakeup));
        downlink.send(TargetToHost::FrameDone { frame, next_wakeup });
        true
    }

    /// One chunk of an uplink: (its sequence number, the announced total, its bytes).
    fn uplink_chunk(
        &mut self,
        (seq, total, bytes): (u16, u16, &heapless::Vec<u8, UPLINK_CHUNK_MAX>),
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) {
        let mut nak = |reason| {
            downlink.send(TargetToHost::UplinkNak { seq, reason });
        };
        if seq == 0 {
            self.uplink_len = 0;
            self.uplink_progress = Some((0, total));
        }
        let Some((expected, announced)) = self.uplink_progress else {
            return nak(uplink_reason::OUT_OF_SEQUENCE);
        };
        if total == 0 || total != announced {
            self.uplink_progress = None;
            return nak(uplink_reason::BAD_TOTAL);
        }
        if seq != expected {
            self.uplink_progress = None;
            return nak(uplink_reason::OUT_OF_SEQUENCE);
        }
        let end = self.uplink_len + bytes.len();
        let Some(slot) = self.uplink.get_mut(self.uplink_len..end) else {
            self.uplink_progress = None;
            return nak(uplink_reason::TOO_LARGE);
        };
        slot.copy_from_slice(bytes);
        self.uplink_len = end;
        downlink.send(TargetToHost::UplinkAck { seq });
        if u32::from(seq) + 1 < u32::from(total) {
            self.uplink_progress = Some((seq + 1, total));
            return;
        }
        self.uplink_progress = None;
        let secured = self.uplink.get(..self.uplink_len).unwrap_or(&[]);
        // Authentic and fresh first; the counter is stored before the network is even
        // validated, so a reset at any point cannot make this uplink acceptable again.
        let t0 = clock.ticks();
        let checked = self.security.check_uplink(secured);
        let t1 = clock.ticks();
        if t1 != t0 {
            downlink.send(metric_event(
                metric::UPLINK_VERIFY_TICKS,
                t1.wrapping_sub(t0),
            ));
        }
        let accepted = checked.and_then(|(header, image)| {
            self.security
                .accept(
                    header.sequence,
                    self.security.holds(),
                    memories.security.as_deref_mut(),
                )
                .map(|()| image)
        });
        let image = match accepted {
            Ok(image) => image,
            Err(reason) => {
                let count = count_refusal(&mut self.security_refusals, reason);
                downlink.send(metric_event(metric::security_refusals(reason), count));
                return downlink.send(TargetToHost::UplinkNak {
                    seq: total,
                    reason: reason.code(),
                });
            }
        };
        match self.executive.load_uplink(image) {
            // The whole network was accepted. It is checkpointed before the acknowledgement
            // (seq == total) goes out, so a network the ground saw acknowledged survives a
            // reset even before the first frame has run.
            Ok(()) => {
                let failures = self
                    .persist
                    .checkpoint_all(&mut self.executive, memories, fetch);
                if failures > 0 {
                    downlink.send(metric_event(metric::CHECKPOINT_WRITE_FAILURES, failures));
                }
                downlink.send(TargetToHost::UplinkAck { seq: total })
            }
            Err(autonomy::LoadError::Invalid(e)) => downlink.send(TargetToHost::UplinkNak {
                seq: total,
                reason: e.code.code(),
            }),
            Err(autonomy::LoadError::Busy) => downlink.send(TargetToHost::UplinkNak {
                seq: total,
                reason: uplink_reason::BUSY,
            }),
            Err(autonomy::LoadError::TooLarge) => downlink.send(TargetToHost::UplinkNak {
                seq: total,
                reason: uplink_reason::TOO_LARGE,
            }),
        }
    }

    /// An authenticated ground command: checked, its counter stored, then carried out.
    fn ground_command(
        &mut self,
        header: &SecurityHeader,
        command: &GroundCommand,
        mac: &heapless::Vec<u8, MAC_LEN>,
        memories: &mut Memories<'_>,
        downlink: &mut impl Downlink,
    ) {
        let sequence = header.sequence;
        let holds = self.security.holds();
        let bit = |hold: u8| (hold < MAX_GROUND_HOLDS).then(|| 1u32 << hold);
        let holds_after = match *command {
            GroundCommand::NoOp => Some(holds),
            GroundCommand::SetHold(hold) => bit(hold).map(|b| holds | b),
            GroundCommand::ReleaseHold(hold) => bit(hold).map(|b| holds & !b),
        };
        // An authentic, fresh command spends its sequence number even if it cannot be carried
        // out; the holds it sets are written in the same record as the counter.
        let stored = self
            .security
            .check_command(header, command, mac)
            .and_then(|()| {
                self.security.accept(
                    sequence,
                    holds_after.unwrap_or(holds),
                    memories.security.as_deref_mut(),
                )
            });
        if let Err(reason) = stored {
            let count = count_refusal(&mut self.security_refusals, reason);
            downlink.send(metric_event(metric::security_refusals(reason), count));
            return downlink.send(TargetToHost::GroundCommandNak {
                sequence,
                reason: CommandRefusal::Security(reason),
            });
        }
        let Some(holds_after) = holds_after else {
            self.commands_not_carried_out = self.commands_not_carried_out.saturating_add(1);
            downlink.send(metric_event(
                metric::GROUND_COMMANDS_NOT_CARRIED_OUT,
                u64::from(self.commands_not_carried_out),
            ));
            return downlink.send(TargetToHost::GroundCommandNak {
                sequence,
                reason: CommandRefusal::HoldOutOfRange,
            });
        };
        if holds_after != holds {
            downlink.send(metric_event(metric::GROUND_HOLDS, u64::from(holds_after)));
        }
        downlink.send(TargetToHost::GroundCommandAck { sequence });
    }
}

/// The planner's budget in one window: validity checks, and CPU up to a clock reading.
struct WindowBudget<'c, C: CpuClock> {
    checks: u32,
    until: Option<u64>,
    clock: &'c mut C,
}

impl<C: CpuClock> autonomy::planner::Budget for WindowBudget<'_, C> {
    fn exhausted(&mut self, checks_spent: u32) -> bool {
        checks_spent >= self.checks || self.until.is_some_and(|t| self.clock.ticks() >= t)
    }
}

/// The planner partition's application: the planning loop (`autonomy::partitioned`'s planner
/// side) with its own checkpoints in its own slices of the two memories. It plans once per
/// frame, in its window after the executive's first window ([`PlannerApp::window`]), within a
/// budget of validity checks, and sends the executive its commits, decisions and status.
pub struct PlannerApp {
    partition: PlannerPartition,
    persist: Persistence,
    /// Validity checks per window.
    budget: u32,
    /// CPU ticks the planning may take per window (None: no limit): the planner stops before
    /// the next job once its window's share is spent, so that it yields at its window's end
    /// instead of being preempted there, and its cycle goes on in the next frame's window.
    cpu_budget: Option<u64>,
    /// Set at a restore until the first window with no planning pending: the CPU spent so
    /// far, the restore included ([`metric::PLANNER_RECOVERY_TICKS`]).
    recovering: Option<u64>,
}

impl Default for PlannerApp {
    fn default() -> Self {
        Self::new()
    }
}

impl PlannerApp {
    pub const fn new() -> Self {
        Self {
            partition: PlannerPartition::new(),
            persist: Persistence::NEW,
            budget: DEFAULT_PLANNER_BUDGET,
            cpu_budget: None,
            recovering: None,
        }
    }

    /// Makes this application what [`PlannerApp::new`] makes, in place.
    pub fn reset(&mut self) {
        self.partition.reset();
        self.persist = Persistence::NEW;
        self.budget = DEFAULT_PLANNER_BUDGET;
        self.cpu_budget = None;
        self.recovering = None;
    }

    /// The planning loop's side of the core.
    pub fn partition(&self) -> &PlannerPartition {
        &self.partition
    }

    /// Validity checks per window (see [`DEFAULT_PLANNER_BUDGET`]).
    pub fn set_budget(&mut self, checks: u32) {
        self.budget = checks;
    }

    /// CPU ticks the planning may take per window (None: no limit; see the field).
    pub fn set_cpu_budget(&mut self, ticks: Option<u64>) {
        self.cpu_budget = ticks;
    }

    /// The ranges of warm memory written by the checkpoints since the last call, in order.
    pub fn take_warm_writes(&mut self) -> Writes {
        core::mem::take(&mut self.persist.last_warm_write)
    }

    /// The same for non-volatile memory.
    pub fn take_nv_writes(&mut self) -> Writes {
        core::mem::take(&mut self.persist.last_nv_write)
    }

    /// Come up after a (re)boot: restore the newest whole checkpoint of this partition's two
    /// memories (copies filled by `fetch` on demand, or complete ones).
    pub fn boot_fetching(
        &mut self,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        let t0 = clock.ticks();
        self.persist.start(memories, fetch.as_deref_mut());
        let (outcome, _) = self
            .persist
            .restore_newest(&mut self.partition, memories, fetch, clock);
        let t1 = clock.ticks();
        // Restored or not, the planner's CPU counts towards the repaired plan until its first
        // window with nothing pending: a planner that lost its checkpoint plans afresh.
        self.recovering = Some(t1.wrapping_sub(t0));
        if let BootOutcome::RestoredWarm(_) | BootOutcome::RestoredNv(_) = outcome {
            if t1 != t0 {
                downlink.send(metric_event(
                    metric::PLANNER_RESTORE_TICKS,
                    t1.wrapping_sub(t0),
                ));
            }
        }
        outcome
    }

    /// Takes one message from the executive partition.
    pub fn receive(&mut self, wire: Wire<PlannerInput>) {
        self.partition.receive(wire);
    }

    /// Whether the executive's frame has come and the window has not run for it.
    pub fn frame_pending(&self) -> bool {
        self.partition.frame_pending()
    }

    /// Messages for the executive not sent yet (the port was full).
    pub fn unsent(&self) -> usize {
        self.partition.unsent()
    }

    /// The window for the frame the executive announced, if one came: planning within the
    /// budget, then the checkpoint (after which [`PlannerApp::transmit`] may send the
    /// commits, decisions and status). Its costs go to `downlink` as metrics.
    pub fn window(
        &mut self,
        memories: &mut Memories<'_>,
        fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> Option<PlannerStatus> {
        let t0 = clock.ticks();
        let budget = WindowBudget {
            checks: self.budget,
            until: self.cpu_budget.map(|ticks| t0.saturating_add(ticks)),
            clock: &mut *clock,
        };
        let status = self.partition.window(budget)?;
        let t1 = clock.ticks();
        let failures = self
            .persist
            .checkpoint_all(&mut self.partition, memories, fetch);
        let t2 = clock.ticks();
        if failures > 0 {
            downlink.send(metric_event(
                metric::PLANNER_CHECKPOINT_WRITE_FAILURES,
                failures,
            ));
        }
        if let Some(spent) = self.recovering.as_mut() {
            *spent = spent.wrapping_add(t2.wrapping_sub(t0));
            if !status.pending {
                if t2 != t0 {
                    downlink.send(metric_event(metric::PLANNER_RECOVERY_TICKS, *spent));
                }
                self.recovering = None;
            }
        }
        if t2 != t0 {
            downlink.send(metric_event(metric::PLANNER_TICKS, t1.wrapping_sub(t0)));
            downlink.send(metric_event(
                metric::PLANNER_CHECKPOINT_TICKS,
                t2.wrapping_sub(t1),
            ));
        }
        Some(status)
    }

    /// Hands the executive partition what the last checkpoint holds, until `send` refuses one.
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<ExecutiveInput>) -> bool) {
        self.partition.transmit(send);
    }
}

/// Rounds of the planner's and the executive's windows one grant may take in [`FlightApp`]: one,
/// and one more when the planner must be brought up to date first.
const MAX_ROUNDS_PER_FRAME: usize = 2;

/// Bytes of the warm memory and of non-volatile memory's checkpoint part that
/// [`FlightApp`] gives the executive's side (the rest is the planner's), as the kernel
/// gives each partition its slice.
pub const fn executive_share(len: usize) -> usize {
    len / 2
}

/// Offsets a [`MemoryFetch`] by the start of one side's share of the memories.
struct ShareFetch<'f, 'g> {
    fetch: &'f mut (dyn MemoryFetch + 'g),
    warm_offset: usize,
    nv_offset: usize,
}

impl MemoryFetch for ShareFetch<'_, '_> {
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError> {
        let base = match memory {
            MemoryKind::Warm => self.warm_offset,
            MemoryKind::Nv => self.nv_offset,
        };
        self.fetch.fetch(memory, base + offset, bytes)
    }
}

/// The whole flight software in one place, for a target without partitions (`hil`'s native
/// target, tests): the executive's and the planner's applications with the ports between them
/// as direct calls, each with its share of the memories ([`executive_share`]). A time grant
/// runs the executive's first window, the planner's window and the executive's second window,
/// as the partitions' windows run in one major frame of the target.
pub struct FlightApp {
    executive: ExecutiveApp,
    planner: PlannerApp,
    /// Bytes of each memory's checkpoint part that are the executive's (the rest is the
    /// planner's); None: half of each ([`executive_share`]).
    executive_bytes: Option<usize>,
    /// The lengths of the warm memory and of non-volatile memory's checkpoint part last seen.
    lens: (usize, usize),
}

impl Default for FlightApp {
    fn default() -> Self {
        Self::new()
    }
}

impl FlightApp {
    pub const fn new() -> Self {
        let mut planner = PlannerApp::new();
        // The unthrottled reference: the planner's cycle runs to its end in every frame.
        planner.budget = u32::MAX;
        Self {
            executive: ExecutiveApp::new(),
            planner,
            executive_bytes: None,
            lens: (0, 0),
        }
    }

    /// As [`FlightApp::new`], with the memories split as the kernel splits them: the first
    /// `executive_bytes` of each memory's checkpoint part are the executive partition's slice,
    /// the rest the planner's (`kernel_config::system::EXECUTIVE_WARM`).
    pub const fn with_executive_share(executive_bytes: usize) -> Self {
        let mut app = Self::new();
        app.executive_bytes = Some(executive_bytes);
        app
    }

    /// Makes this application what [`FlightApp::new`] makes, in place (the memories' split
    /// and the planner's budget are kept).
    pub fn reset(&mut self) {
        let budget = self.planner.budget;
        self.executive.reset();
        self.planner.reset();
        self.planner.budget = budget;
    }

    /// The executive's bytes of a memory part of `len` bytes.
    fn share(&self, len: usize) -> usize {
        self.executive_bytes
            .map_or(executive_share(len), |b| b.min(len))
    }

    /// Where the planner's shares of `memories` start (warm, non-volatile), remembered for
    /// [`FlightApp::take_warm_write`].
    fn shares(&mut self, memories: &Memories<'_>) -> (usize, usize) {
        self.lens = (
            memories.warm.len(),
            memories.nv.as_deref().map_or(0, <[u8]>::len),
        );
        (self.share(self.lens.0), self.share(self.lens.1))
    }

    pub fn executive(&self) -> &ExecutiveApp {
        &self.executive
    }

    pub fn planner(&self) -> &PlannerApp {
        &self.planner
    }

    /// Both sides' whole states, the executive's then the planner's, as their checkpoints
    /// hold them (tests compare them to show that something left the state untouched).
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let n = self.executive.executive().encode_state(buf)?;
        let m = self.planner.partition().encode_state(buf.get_mut(n..)?)?;
        Some(n + m)
    }

    /// The executive's network (the one loaded last).
    pub fn network(&self) -> &autonomy::TaskNetwork {
        self.executive.executive().network()
    }

    /// Validity checks per planner window.
    pub fn set_planner_budget(&mut self, checks: u32) {
        self.planner.set_budget(checks);
    }

    /// The security association read at boot and updated by every accepted message.
    pub fn security(&self) -> &SecurityAssociation {
        self.executive.security()
    }

    /// Refusals by the security checks since boot for `reason`.
    pub fn security_refusals(&self, reason: SecurityRefusal) -> u32 {
        self.executive.security_refusals(reason)
    }

    /// The ranges the checkpoints since the last call wrote into the warm memory, in the whole
    /// memory's offsets: the executive's, then the planner's.
    pub fn take_warm_writes(&mut self) -> heapless::Vec<(usize, usize), 8> {
        let base = self.share(self.lens.0);
        both_writes(
            self.executive.take_warm_writes(),
            self.planner.take_warm_writes(),
            base,
        )
    }

    /// The same for non-volatile memory's checkpoint part.
    pub fn take_nv_writes(&mut self) -> heapless::Vec<(usize, usize), 8> {
        let base = self.share(self.lens.1);
        both_writes(
            self.executive.take_nv_writes(),
            self.planner.take_nv_writes(),
            base,
        )
    }

    /// The range the last checkpoint since the last call wrote into the warm memory, in the
    /// whole memory's offsets: the executive's last one if it wrote any (after a frame, its
    /// second window's), else the planner's. What a reset right after could have torn. The
    /// others are forgotten.
    pub fn take_warm_write(&mut self) -> Option<(usize, usize)> {
        let base = self.share(self.lens.0);
        let planner = self.planner.take_warm_writes();
        let executive = self.executive.take_warm_writes();
        executive
            .last()
            .copied()
            .or_else(|| planner.last().map(|&(s, e)| (s + base, e + base)))
    }

    /// The same for non-volatile memory's checkpoint part.
    pub fn take_nv_write(&mut self) -> Option<(usize, usize)> {
        let base = self.share(self.lens.1);
        let planner = self.planner.take_nv_writes();
        let executive = self.executive.take_nv_writes();
        executive
            .last()
            .copied()
            .or_else(|| planner.last().map(|&(s, e)| (s + base, e + base)))
    }

    /// Come up after a (re)boot: each side restores its newest whole checkpoint from its share
    /// of the memories. The executive's outcome is the application's.
    pub fn boot(
        &mut self,
        memories: &mut Memories<'_>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        self.boot_fetching(memories, None, clock, downlink)
    }

    /// As [`FlightApp::boot`], with copies filled by `fetch` on demand.
    pub fn boot_fetching(
        &mut self,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> BootOutcome {
        let at = self.shares(memories);
        let outcome = {
            let (mut mem, _) = split(memories, at);
            let mut fetch = fetch.as_deref_mut().map(|f| ShareFetch {
                fetch: f,
                warm_offset: 0,
                nv_offset: 0,
            });
            self.executive.boot_fetching(
                &mut mem,
                fetch.as_mut().map(|f| f as &mut dyn MemoryFetch),
                clock,
                downlink,
            )
        };
        let (_, mut mem) = split(memories, at);
        let mut fetch = fetch.map(|f| ShareFetch {
            fetch: f,
            warm_offset: at.0,
            nv_offset: at.1,
        });
        self.planner.boot_fetching(
            &mut mem,
            fetch.as_mut().map(|f| f as &mut dyn MemoryFetch),
            clock,
            downlink,
        );
        outcome
    }

    /// Handle one message from the host (see [`ExecutiveApp::handle`]); a time grant runs the
    /// whole frame, both partitions.
    pub fn handle(
        &mut self,
        msg: &HostToTarget,
        memories: &mut Memories<'_>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        self.handle_fetching(msg, memories, None, clock, downlink)
    }

    /// As [`FlightApp::handle`], for copies filled by `fetch` on demand.
    pub fn handle_fetching(
        &mut self,
        msg: &HostToTarget,
        memories: &mut Memories<'_>,
        mut fetch: Option<&mut (dyn MemoryFetch + '_)>,
        clock: &mut impl CpuClock,
        downlink: &mut impl Downlink,
    ) -> bool {
        let at = self.shares(memories);
        let share = |planner: bool| if planner { at } else { (0, 0) };
        let handled = {
            let (mut mem, _) = split(memories, at);
            let mut f = share_fetch(fetch.as_deref_mut(), share(false));
            self.executive.handle_fetching(
                msg,
                &mut mem,
                f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                clock,
                downlink,
            )
        };
        // The rest of the frame: the planner's window, then the executive's second. A second
        // round (a major frame more on the target) when the planner had to be brought up to
        // date first; never more.
        if !self.executive.awaiting_planner() {
            return handled;
        }
        let Self {
            executive, planner, ..
        } = self;
        for _ in 0..MAX_ROUNDS_PER_FRAME {
            if !executive.awaiting_planner() {
                break;
            }
            {
                let (mut mem, _) = split(memories, at);
                let mut f = share_fetch(fetch.as_deref_mut(), share(false));
                executive.checkpoint_if_needed(
                    &mut mem,
                    f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                    downlink,
                );
            }
            executive.transmit(&mut |w| {
                planner.receive(w);
                true
            });
            {
                let (_, mut mem) = split(memories, at);
                let mut f = share_fetch(fetch.as_deref_mut(), share(true));
                planner.window(
                    &mut mem,
                    f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                    clock,
                    downlink,
                );
            }
            planner.transmit(&mut |w| {
                executive.receive(w);
                true
            });
            let (mut mem, _) = split(memories, at);
            let mut f = share_fetch(fetch.as_deref_mut(), share(false));
            executive.second_window(
                &mut mem,
                f.as_mut().map(|f| f as &mut dyn MemoryFetch),
                clock,
                downlink,
            );
        }
        executive.transmit(&mut |w| {
            planner.receive(w);
            true
        });
        handled
    }
}

/// Both sides' write ranges in the whole memory's offsets: the executive's, then the
/// planner's (whose share starts at `base`).
fn both_writes(
    executive: Writes,
    planner: Writes,
    base: usize,
) -> heapless::Vec<(usize, usize), 8> {
    executive
        .into_iter()
        .chain(planner.into_iter().map(|(s, e)| (s + base, e + base)))
        .collect()
}

/// `fetch` for one side's share, which starts at `(warm, nv)` offsets.
fn share_fetch<'f, 'g>(
    fetch: Option<&'f mut (dyn MemoryFetch + 'g)>,
    (warm_offset, nv_offset): (usize, usize),
) -> Option<ShareFetch<'f, 'g>> {
    fetch.map(|fetch| ShareFetch {
        fetch,
        warm_offset,
        nv_offset,
    })
}

/// The executive's and the planner's shares of `memories` (the security area is the
/// executive's).
fn split<'m, 'a: 'm>(
    memories: &'m mut Memories<'a>,
    (warm_at, nv_at): (usize, usize),
) -> (Memories<'m>, Memories<'m>) {
    let (exec_warm, planner_warm) = memories.warm.split_at_mut(warm_at);
    let (exec_nv, planner_nv) = match memories.nv.as_deref_mut() {
        Some(nv) => {
            let (a, b) = nv.split_at_mut(nv_at);
            (Some(a), Some(b))
        }
        None => (None, None),
    };
    (
        Memories {
            warm: exec_warm,
            nv: exec_nv,
            security: match memories.security.as_mut() {
                Some(s) => Some(&mut **s),
                None => None,
            },
        },
        Memories {
            warm: planner_warm,
            nv: planner_nv,
            security: None,
        },
    )
}

/// Count a refusal for `reason`; the new count.
fn count_refusal(counts: &mut [u32; SecurityRefusal::COUNT], reason: SecurityRefusal) -> u64 {
    let count = &mut counts[reason.index()];
    *count = count.saturating_add(1);
    u64::from(*count)
}

fn metric_event(id: u16, value: u64) -> TargetToHost {
    TargetToHost::Telemetry(TelemetryEvent::Metric { id, value })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    /// Every metric id the application sends is in the telemetry dictionary under its own
    /// constant's name; the costs travel on the Instrument channel, the rest on the Mission
    /// channel (the native target's stream is the emulated one's).
    #[test]
    fn every_application_metric_is_in_the_dictionary() {
        use fsw_bridge::dictionary;
        use fsw_bridge::link::VirtualChannel::{Instrument, Mission};
        let ids = [
            (metric::STEP_TICKS, "STEP_TICKS", Instrument),
            (metric::CHECKPOINT_TICKS, "CHECKPOINT_TICKS", Instrument),
            (metric::RESTORE_TICKS, "RESTORE_TICKS", Instrument),
            (metric::RECOVERY_TICKS, "RECOVERY_TICKS", Instrument),
            (metric::RESTORED_SEQUENCE, "RESTORED_SEQUENCE", Mission),
            (
                metric::CHECKPOINT_WRITE_FAILURES,
                "CHECKPOINT_WRITE_FAILURES",
                Mission,
            ),
            (metric::PLANNER_TICKS, "PLANNER_TICKS", Instrument),
            (metric::EXECUTIVE_TICKS, "EXECUTIVE_TICKS", Instrument),
            (metric::RESTORED_FROM, "RESTORED_FROM", Mission),
            (metric::RESTORED_SLOT, "RESTORED_SLOT", Mission),
            (
                metric::STATE_TYPE_MISMATCHES,
                "STATE_TYPE_MISMATCHES",
                Mission,
            ),
            (
                metric::STATE_TYPE_MISMATCH_KEY,
                "STATE_TYPE_MISMATCH_KEY",
                Mission,
            ),
            (metric::FRAME_BUSY_TICKS, "FRAME_BUSY_TICKS", Instrument),
            (metric::GROUND_HOLDS, "GROUND_HOLDS", Mission),
            (
                metric::UPLINK_VERIFY_TICKS,
                "UPLINK_VERIFY_TICKS",
                Instrument,
            ),
            (
                metric::GROUND_COMMANDS_NOT_CARRIED_OUT,
                "GROUND_COMMANDS_NOT_CARRIED_OUT",
                Mission,
            ),
            (
                metric::SECURITY_REFUSALS_FIRST,
                "SECURITY_REFUSALS_FIRST",
                Mission,
            ),
            (
                metric::BOOT_SECURITY_TICKS,
                "BOOT_SECURITY_TICKS",
                Instrument,
            ),
            (
                metric::RESTORE_CHECK_TICKS,
                "RESTORE_CHECK_TICKS",
                Instrument,
            ),
            (
                metric::RESTORE_DECODE_TICKS,
                "RESTORE_DECODE_TICKS",
                Instrument,
            ),
            (
                metric::PLANNER_RESTORE_TICKS,
                "PLANNER_RESTORE_TICKS",
                Instrument,
            ),
            (
                metric::PLANNER_RECOVERY_TICKS,
                "PLANNER_RECOVERY_TICKS",
                Instrument,
            ),
            (
                metric::PLANNER_CHECKPOINT_TICKS,
                "PLANNER_CHECKPOINT_TICKS",
                Instrument,
            ),
            (
                metric::PLANNER_CHECKPOINT_WRITE_FAILURES,
                "PLANNER_CHECKPOINT_WRITE_FAILURES",
                Mission,
            ),
            (metric::PLANNING_LATENCY_US, "PLANNING_LATENCY_US", Mission),
            (metric::STALE_COMMITS, "STALE_COMMITS", Mission),
            (
                metric::PLANNER_PENDING_FRAMES,
                "PLANNER_PENDING_FRAMES",
                Mission,
            ),
        ];
        assert_eq!(
            ids.len(),
            metric::APP_METRICS.len(),
            "a constant is missing here"
        );
        // The wire ids are fixed (transcripts and budgets depend on them): spot checks.
        assert_eq!(metric::STEP_TICKS, 0x1000);
        assert_eq!(metric::SECURITY_REFUSALS_FIRST, 0x1010);
        assert_eq!(metric::RESTORE_DECODE_TICKS, 0x1022);
        for (id, constant, channel) in ids {
            let m =
                dictionary::metric(id).unwrap_or_else(|| panic!("{constant} not in dictionary"));
            assert_eq!((m.id, m.constant, m.channel), (id, constant, channel));
        }
        for reason in SecurityRefusal::ALL {
            let m = dictionary::metric(metric::security_refusals(reason)).unwrap();
            assert_eq!(m.constant, "SECURITY_REFUSALS_FIRST");
        }
        let from = dictionary::metric(metric::RESTORED_FROM).unwrap();
        assert!(from.value_name(metric::RESTORED_FROM_WARM).is_some());
        assert!(from.value_name(metric::RESTORED_FROM_NV).is_some());
    }

    fn grant(frame: u32, secs: u64) -> HostToTarget {
        HostToTarget::TimeGrant {
            frame,
            now: MissionTimeUs::from_secs(secs),
            until: MissionTimeUs::from_secs(secs + 1),
        }
    }

    #[test]
    fn a_repeated_grant_gets_the_same_frame_done_without_stepping_again() {
        let mut app = std::boxed::Box::new(FlightApp::new());
        let (mut warm, mut nv) = (std::vec![0u8; 8192], std::vec![0u8; 8192]);
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: None,
        };
        let mut out: Vec<TargetToHost> = Vec::new();
        app.handle(&grant(7, 10), &mut mem, &mut NoClock, &mut |m| out.push(m));
        app.handle(&grant(7, 10), &mut mem, &mut NoClock, &mut |m| out.push(m));
        let done: Vec<&TargetToHost> = out
            .iter()
            .filter(|m| matches!(m, TargetToHost::FrameDone { .. }))
            .collect();
        assert_eq!(done.len(), 2);
        assert_eq!(done[0], done[1]);
        app.handle(&grant(8, 20), &mut mem, &mut NoClock, &mut |m| out.push(m));
        assert!(matches!(
            out.last(),
            Some(TargetToHost::FrameDone { frame: 8, .. })
        ));
    }

    /// A clock that advances by 10 ticks per read.
    struct Counting(u64);

    impl CpuClock for Counting {
        fn ticks(&mut self) -> u64 {
            self.0 += 10;
            self.0
        }
    }

    fn metrics(out: &[TargetToHost], id: u16) -> Vec<u64> {
        out.iter()
            .filter_map(|m| match m {
                TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if *i == id => {
                    Some(*value)
                }
                _ => None,
            })
            .collect()
    }

    /// The key the tests provision.
    const TEST_KEY: sdls::Key = sdls::Key {
        spi: 1,
        bytes: [0x11; 32],
    };

    /// A security area in memory; `fail_writes` makes every write fail.
    #[derive(Clone)]
    struct TestNv {
        area: [u8; sdls::nv::SECURITY_AREA_BYTES],
        fail_writes: bool,
    }

    impl TestNv {
        fn provisioned(key: &sdls::Key) -> Self {
            let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
            sdls::nv::provision(&mut area, key).unwrap();
            Self {
                area,
                fail_writes: false,
            }
        }
    }

    impl SecurityStore for TestNv {
        fn read(
            &mut self,
            area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES],
        ) -> Result<(), StoreError> {
            area.copy_from_slice(&self.area);
            Ok(())
        }
        fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
            if self.fail_writes {
                return Err(StoreError);
            }
            self.area
                .get_mut(offset..offset + bytes.len())
                .ok_or(StoreError)?
                .copy_from_slice(bytes);
            Ok(())
        }
    }

    fn flyby_image() -> Vec<u8> {
        let network = autonomy::scenarios::flyby_network().unwrap();
        let mut image = std::vec![0u8; MAX_UPLINK_BYTES];
        let len = network.encode(&mut image).unwrap();
        image.truncate(len);
        image
    }

    /// The flyby network secured with `key` and sequence number `sequence`.
    fn signed_flyby(key: &sdls::Key, sequence: u32) -> Vec<u8> {
        let image = flyby_image();
        let mut out = std::vec![0u8; image.len() + sdls::uplink::OVERHEAD];
        let n = sdls::uplink::sign_into(key, sequence, &image, &mut out).unwrap();
        out.truncate(n);
        out
    }

    /// Send `secured` in chunks; everything the application answered.
    fn send_uplink(
        app: &mut FlightApp,
        mem: &mut Memories<'_>,
        secured: &[u8],
    ) -> Vec<TargetToHost> {
        let chunks: Vec<&[u8]> = secured.chunks(UPLINK_CHUNK_MAX).collect();
        let mut out: Vec<TargetToHost> = Vec::new();
        for (seq, c) in chunks.iter().enumerate() {
            let msg = HostToTarget::UplinkChunk {
                seq: seq as u16,
                total: chunks.len() as u16,
                bytes: heapless::Vec::from_slice(c).unwrap(),
            };
            app.handle(&msg, mem, &mut NoClock, &mut |m| out.push(m));
        }
        out
    }

    /// The verdict on a whole uplink: the reply with `seq == total`.
    fn verdict(out: &[TargetToHost]) -> Option<&TargetToHost> {
        out.iter().rev().find(|m| {
            matches!(m, TargetToHost::UplinkNak { .. })
                || matches!(m, TargetToHost::UplinkAck { .. })
        })
    }

    /// Boot `app` (which reads the key) and uplink the flyby with sequence number 1.
    fn boot_and_uplink_flyby(app: &mut FlightApp, mem: &mut Memories<'_>) {
        app.boot(mem, &mut NoClock, &mut |_| {});
        let secured = signed_flyby(&TEST_KEY, 1);
        let total = secured.len().div_ceil(UPLINK_CHUNK_MAX) as u16;
        let out = send_uplink(app, mem, &secured);
        assert_eq!(out.last(), Some(&TargetToHost::UplinkAck { seq: total }));
    }

    /// Boot, uplink the flyby and fly ten frames with fresh memories; everything answered.
    fn fly_ten_frames(app: &mut FlightApp) -> Vec<TargetToHost> {
        let (mut warm, mut nv) = (std::vec![0u8; 60 * 1024], std::vec![0u8; 60 * 1024]);
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: Some(&mut security),
        };
        boot_and_uplink_flyby(app, &mut mem);
        let mut out: Vec<TargetToHost> = Vec::new();
        for frame in 0..10u32 {
            let g = grant(frame, 9 * 3600 + 50 * 60 + 60 * u64::from(frame));
            app.handle(&g, &mut mem, &mut Counting(0), &mut |m| out.push(m));
        }
        out
    }

    /// Both sides' whole states, as their checkpoints hold them.
    fn encoded_core(app: &FlightApp) -> Vec<u8> {
        let mut buf = std::vec![0u8; 1 << 16];
        let len = app.executive.executive.encode_state(&mut buf).unwrap();
        buf.truncate(len);
        let mut planner = std::vec![0u8; 1 << 16];
        let len = app.planner.partition.encode_state(&mut planner).unwrap();
        buf.extend_from_slice(&planner[..len]);
        buf
    }

    #[test]
    fn a_reset_application_is_the_new_one_and_flies_as_it() {
        let mut used = std::boxed::Box::new(FlightApp::new());
        let first = fly_ten_frames(&mut used);
        let fresh = std::boxed::Box::new(FlightApp::new());
        assert_ne!(encoded_core(&used), encoded_core(&fresh));
        assert_ne!(used.security(), fresh.security());
        used.reset();
        assert_eq!(encoded_core(&used), encoded_core(&fresh));
        let (u, f) = (&used.executive, &fresh.executive);
        assert_eq!(u.uplink_len, f.uplink_len);
        assert_eq!(u.uplink_progress, f.uplink_progress);
        assert_eq!(u.recovering, f.recovering);
        assert_eq!(u.last_done, f.last_done);
        assert_eq!(u.awaiting, f.awaiting);
        assert_eq!(u.persist, f.persist);
        assert_eq!(
            u.reported_state_type_mismatches,
            f.reported_state_type_mismatches
        );
        assert_eq!(u.reported_stale_commits, f.reported_stale_commits);
        assert_eq!(u.security, f.security);
        assert_eq!(u.security_refusals, f.security_refusals);
        assert_eq!(u.commands_not_carried_out, f.commands_not_carried_out);
        let (u, f) = (&used.planner, &fresh.planner);
        assert_eq!(u.persist, f.persist);
        assert_eq!(u.budget, f.budget);
        assert_eq!(u.recovering, f.recovering);
        assert_eq!(fly_ten_frames(&mut used), first);
    }

    #[test]
    fn each_frame_reports_its_planner_and_executive_parts_and_a_restore_its_recovery() {
        let mut app = std::boxed::Box::new(FlightApp::new());
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        boot_and_uplink_flyby(&mut app, &mut mem);
        let mut out: Vec<TargetToHost> = Vec::new();
        let mut clock = Counting(0);
        app.handle(&grant(0, 9 * 3600), &mut mem, &mut clock, &mut |m| {
            out.push(m)
        });
        // Each window reads the clock before its work, between the work and its checkpoint,
        // and after: the executive's two passes (10 each), the planner's (10), each checkpoint
        // 10.
        assert_eq!(metrics(&out, metric::STEP_TICKS), [20]);
        assert_eq!(metrics(&out, metric::EXECUTIVE_TICKS), [20]);
        assert_eq!(metrics(&out, metric::CHECKPOINT_TICKS), [20]);
        assert_eq!(metrics(&out, metric::FRAME_BUSY_TICKS), [40]);
        assert_eq!(metrics(&out, metric::PLANNER_TICKS), [10]);
        assert_eq!(metrics(&out, metric::PLANNER_CHECKPOINT_TICKS), [10]);
        assert!(metrics(&out, metric::RECOVERY_TICKS).is_empty());
        // The planner counts its way to its first plan after any boot, a cold one too (the
        // host counts it only after a reset).
        assert_eq!(metrics(&out, metric::PLANNER_RECOVERY_TICKS).len(), 1);

        // Warm reset: a fresh application restores, hears two state updates, then a grant.
        let mut app = std::boxed::Box::new(FlightApp::new());
        let mut out: Vec<TargetToHost> = Vec::new();
        let outcome = app.boot(&mut mem, &mut clock, &mut |m| out.push(m));
        assert!(matches!(outcome, BootOutcome::RestoredWarm(_)));
        for _ in 0..2 {
            let update = HostToTarget::StateUpdate {
                key: autonomy::scenarios::ATTITUDE_KEY,
                value: fsw_bridge::StateValue::Enum(autonomy::scenarios::UNKNOWN),
                timestamp: MissionTimeUs::from_secs(9 * 3600 + 60),
            };
            app.handle(&update, &mut mem, &mut clock, &mut |m| out.push(m));
        }
        app.handle(&grant(1, 9 * 3600 + 60), &mut mem, &mut clock, &mut |m| {
            out.push(m)
        });
        // The executive: 10 ticks per state update, 20 for the first window and its
        // checkpoint, 10 for the second window's pass (the plan is repaired: its checkpoint is
        // not counted). The planner partition counts its own, from its restore on.
        assert_eq!(metrics(&out, metric::RECOVERY_TICKS), [50]);
        assert_eq!(metrics(&out, metric::PLANNER_RECOVERY_TICKS).len(), 1);
        assert!(metrics(&out, metric::PLANNER_RECOVERY_TICKS)[0] >= 20);
        // Once per restore.
        app.handle(&grant(2, 9 * 3600 + 120), &mut mem, &mut clock, &mut |m| {
            out.push(m)
        });
        assert_eq!(metrics(&out, metric::RECOVERY_TICKS), [50]);
        assert_eq!(metrics(&out, metric::PLANNER_RECOVERY_TICKS).len(), 1);
        assert_eq!(metrics(&out, metric::STEP_TICKS).len(), 2);
    }

    #[test]
    fn state_updates_of_the_wrong_type_are_reported_the_first_time_and_when_the_count_changes() {
        let mut app = std::boxed::Box::new(FlightApp::new());
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        boot_and_uplink_flyby(&mut app, &mut mem);
        let key = autonomy::scenarios::ATTITUDE_KEY;
        let update = |value| HostToTarget::StateUpdate {
            key,
            value,
            timestamp: MissionTimeUs::from_secs(9 * 3600),
        };
        let mut out: Vec<TargetToHost> = Vec::new();
        let frame = |app: &mut FlightApp, mem: &mut Memories<'_>, n: u32| {
            let mut out: Vec<TargetToHost> = Vec::new();
            app.handle(
                &grant(n, 9 * 3600 + u64::from(n)),
                mem,
                &mut NoClock,
                &mut |m| out.push(m),
            );
            (
                metrics(&out, metric::STATE_TYPE_MISMATCHES),
                metrics(&out, metric::STATE_TYPE_MISMATCH_KEY),
            )
        };
        assert_eq!(frame(&mut app, &mut mem, 0), (std::vec![], std::vec![]));
        // An integer for the attitude (a state timeline): counted, reported with its key.
        app.handle(
            &update(fsw_bridge::StateValue::Int(1)),
            &mut mem,
            &mut NoClock,
            &mut |m| out.push(m),
        );
        assert_eq!(
            frame(&mut app, &mut mem, 1),
            (std::vec![1], std::vec![u64::from(key.0)])
        );
        // Unchanged: not reported again.
        assert_eq!(frame(&mut app, &mut mem, 2), (std::vec![], std::vec![]));
        for _ in 0..2 {
            app.handle(
                &update(fsw_bridge::StateValue::Enum(77)),
                &mut mem,
                &mut NoClock,
                &mut |m| out.push(m),
            );
        }
        assert_eq!(
            frame(&mut app, &mut mem, 3),
            (std::vec![3], std::vec![u64::from(key.0)])
        );
        // After a warm reset the restored count is reported in the first frame.
        let mut app = std::boxed::Box::new(FlightApp::new());
        app.boot(&mut mem, &mut NoClock, &mut |m| out.push(m));
        assert_eq!(
            frame(&mut app, &mut mem, 4),
            (std::vec![3], std::vec![u64::from(key.0)])
        );
        // Updates of the right type do not count.
        app.handle(
            &update(fsw_bridge::StateValue::Enum(1)),
            &mut mem,
            &mut NoClock,
            &mut |m| out.push(m),
        );
        assert_eq!(frame(&mut app, &mut mem, 5), (std::vec![], std::vec![]));
    }

    #[test]
    fn uplink_chunks_out_of_order_are_refused_and_nothing_is_loaded() {
        let mut app = std::boxed::Box::new(FlightApp::new());
        let (mut warm, mut nv) = (std::vec![0u8; 8192], std::vec![0u8; 8192]);
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: None,
        };
        let mut out: Vec<TargetToHost> = Vec::new();
        let chunk = |seq, total| HostToTarget::UplinkChunk {
            seq,
            total,
            bytes: heapless::Vec::from_slice(&[1, 2, 3]).unwrap(),
        };
        app.handle(&chunk(1, 3), &mut mem, &mut NoClock, &mut |m| out.push(m));
        assert_eq!(
            out.pop(),
            Some(TargetToHost::UplinkNak {
                seq: 1,
                reason: uplink_reason::OUT_OF_SEQUENCE
            })
        );
        app.handle(&chunk(0, 2), &mut mem, &mut NoClock, &mut |m| out.push(m));
        assert_eq!(out.pop(), Some(TargetToHost::UplinkAck { seq: 0 }));
        app.handle(&chunk(1, 3), &mut mem, &mut NoClock, &mut |m| out.push(m));
        assert_eq!(
            out.pop(),
            Some(TargetToHost::UplinkNak {
                seq: 1,
                reason: uplink_reason::BAD_TOTAL
            })
        );
        // Garbage that completes a transfer is refused by the validator, not loaded.
        app.handle(&chunk(0, 1), &mut mem, &mut NoClock, &mut |m| out.push(m));
        assert!(matches!(
            out.pop(),
            Some(TargetToHost::UplinkNak { seq: 1, .. })
        ));
        assert!(app.executive().executive().network().tasks().is_empty());
    }

    /// The whole plan and execution state, to show that a refusal left it untouched.
    fn state_image(app: &FlightApp) -> Vec<u8> {
        let mut buf = std::vec![0u8; 64 * 1024];
        let n = app.executive().executive().encode_state(&mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// Security refusal metrics in `out`: (reason, count so far).
    fn refusal_metrics(out: &[TargetToHost]) -> Vec<(SecurityRefusal, u64)> {
        out.iter()
            .filter_map(|m| match m {
                TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }) => {
                    metric::security_refusal_of(*id).map(|r| (r, *value))
                }
                _ => None,
            })
            .collect()
    }

    fn nak_reason(out: &[TargetToHost]) -> Option<SecurityRefusal> {
        match verdict(out) {
            Some(TargetToHost::UplinkNak { reason, .. }) => SecurityRefusal::from_code(*reason),
            _ => None,
        }
    }

    /// An application with the flyby loaded (sequence 1) and one frame run, so its state is
    /// not that of a freshly loaded network, with nothing owned by the executive yet (so a
    /// second uplink, if accepted, would load).
    fn flying(mem: &mut Memories<'_>) -> std::boxed::Box<FlightApp> {
        let mut app = std::boxed::Box::new(FlightApp::new());
        boot_and_uplink_flyby(&mut app, mem);
        app.handle(&grant(0, 9 * 3600), mem, &mut NoClock, &mut |_| {});
        assert!(app
            .executive()
            .executive()
            .control()
            .executive()
            .entries()
            .is_empty());
        app
    }

    #[test]
    fn forged_replayed_wrong_key_unknown_key_and_truncated_uplinks_are_refused_counted_and_change_nothing(
    ) {
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        let mut app = flying(&mut mem);
        let before = state_image(&app);

        let mut forged = signed_flyby(&TEST_KEY, 2);
        forged[sdls::uplink::HEADER_LEN + 7] ^= 0x01;
        let wrong_key = signed_flyby(
            &sdls::Key {
                spi: TEST_KEY.spi,
                bytes: [0x22; 32],
            },
            2,
        );
        let unknown_key = signed_flyby(
            &sdls::Key {
                spi: 9,
                bytes: TEST_KEY.bytes,
            },
            2,
        );
        let good = signed_flyby(&TEST_KEY, 2);
        let truncated = good[..good.len() - 1].to_vec();
        let mut long = good.clone();
        long.push(0);
        let replayed = signed_flyby(&TEST_KEY, 1);
        let cases = [
            (forged, SecurityRefusal::BadMac),
            (wrong_key, SecurityRefusal::BadMac),
            (unknown_key, SecurityRefusal::UnknownKey),
            (truncated, SecurityRefusal::Truncated),
            (long, SecurityRefusal::BadLength),
            (replayed, SecurityRefusal::Replay),
        ];
        for (bytes, reason) in &cases {
            let out = send_uplink(&mut app, &mut mem, bytes);
            assert_eq!(nak_reason(&out), Some(*reason), "{out:?}");
            let count = cases
                .iter()
                .take_while(|(b, _)| !core::ptr::eq(b, bytes))
                .filter(|(_, r)| r == reason)
                .count() as u64
                + 1;
            assert_eq!(refusal_metrics(&out), [(*reason, count)]);
            assert_eq!(state_image(&app), before, "{reason:?} changed the plan");
            assert_eq!(app.security().last_sequence(), 1);
        }
        assert_eq!(app.security_refusals(SecurityRefusal::BadMac), 2);
        // The same network, signed properly with a fresh number, is loaded: the checks above
        // were what kept the others out.
        let out = send_uplink(&mut app, &mut mem, &good);
        assert!(matches!(
            verdict(&out),
            Some(TargetToHost::UplinkAck { .. })
        ));
        assert_ne!(state_image(&app), before);
        assert_eq!(app.security().last_sequence(), 2);
    }

    #[test]
    fn without_a_key_or_without_non_volatile_memory_every_uplink_is_refused_with_no_key() {
        fn refused_with_no_key<'a>(warm: &'a mut [u8], store: Option<&'a mut dyn SecurityStore>) {
            let mut mem = Memories {
                warm,
                nv: None,
                security: store,
            };
            let mut app = std::boxed::Box::new(FlightApp::new());
            app.boot(&mut mem, &mut NoClock, &mut |_| {});
            let out = send_uplink(&mut app, &mut mem, &signed_flyby(&TEST_KEY, 1));
            assert_eq!(nak_reason(&out), Some(SecurityRefusal::NoKey));
            assert!(app.executive().executive().network().tasks().is_empty());
        }
        let mut blank = TestNv::provisioned(&TEST_KEY);
        blank.area = [0; sdls::nv::SECURITY_AREA_BYTES];
        refused_with_no_key(&mut std::vec![0u8; 60 * 1024], Some(&mut blank));
        refused_with_no_key(&mut std::vec![0u8; 60 * 1024], None);
    }

    #[test]
    fn an_uplink_whose_counter_cannot_be_stored_is_refused_and_not_loaded() {
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        security.fail_writes = true;
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        let mut app = std::boxed::Box::new(FlightApp::new());
        app.boot(&mut mem, &mut NoClock, &mut |_| {});
        let out = send_uplink(&mut app, &mut mem, &signed_flyby(&TEST_KEY, 1));
        assert_eq!(nak_reason(&out), Some(SecurityRefusal::CounterNotStored));
        assert!(app.executive().executive().network().tasks().is_empty());
        assert_eq!(app.security().last_sequence(), 0);
    }

    #[test]
    fn the_counter_survives_a_warm_reset_and_a_power_cycle_so_the_last_uplink_cannot_be_replayed() {
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        let _ = flying(&mut mem);
        let last = signed_flyby(&TEST_KEY, 1);
        // Warm reset: RAM is a fresh application, the warm area and the NV stay.
        let mut app = std::boxed::Box::new(FlightApp::new());
        assert!(matches!(
            app.boot(&mut mem, &mut NoClock, &mut |_| {}),
            BootOutcome::RestoredWarm(_)
        ));
        let before = state_image(&app);
        let out = send_uplink(&mut app, &mut mem, &last);
        assert_eq!(nak_reason(&out), Some(SecurityRefusal::Replay));
        assert_eq!(state_image(&app), before);
        // Power cycle: the warm area is gone too (no plan to restore), the NV stays.
        mem.warm.fill(0);
        let mut app = std::boxed::Box::new(FlightApp::new());
        assert_eq!(
            app.boot(&mut mem, &mut NoClock, &mut |_| {}),
            BootOutcome::Cold
        );
        let out = send_uplink(&mut app, &mut mem, &last);
        assert_eq!(nak_reason(&out), Some(SecurityRefusal::Replay));
        assert!(app.executive().executive().network().tasks().is_empty());
        let out = send_uplink(&mut app, &mut mem, &signed_flyby(&TEST_KEY, 2));
        assert!(matches!(
            verdict(&out),
            Some(TargetToHost::UplinkAck { .. })
        ));
    }

    fn command(key: &sdls::Key, sequence: u32, command: GroundCommand) -> HostToTarget {
        let header = SecurityHeader {
            spi: key.spi,
            sequence,
        };
        HostToTarget::GroundCommand {
            header,
            command,
            mac: heapless::Vec::from_slice(&sdls::command_mac(key, &header, &command)).unwrap(),
        }
    }

    fn send(app: &mut FlightApp, mem: &mut Memories<'_>, msg: &HostToTarget) -> Vec<TargetToHost> {
        let mut out = Vec::new();
        app.handle(msg, mem, &mut NoClock, &mut |m| out.push(m));
        out
    }

    fn security_nak(reason: SecurityRefusal, sequence: u32) -> TargetToHost {
        TargetToHost::GroundCommandNak {
            sequence,
            reason: CommandRefusal::Security(reason),
        }
    }

    #[test]
    fn ground_commands_are_acknowledged_or_refused_with_their_reason_and_holds_survive_resets() {
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        let mut app = flying(&mut mem);
        let before = state_image(&app);
        let out = send(
            &mut app,
            &mut mem,
            &command(&TEST_KEY, 2, GroundCommand::NoOp),
        );
        assert_eq!(out, [TargetToHost::GroundCommandAck { sequence: 2 }]);
        let out = send(
            &mut app,
            &mut mem,
            &command(&TEST_KEY, 5, GroundCommand::SetHold(3)),
        );
        assert_eq!(
            out,
            [
                metric_event(metric::GROUND_HOLDS, 1 << 3),
                TargetToHost::GroundCommandAck { sequence: 5 }
            ]
        );
        // Refusals: each with its reason and count, holds and counter unchanged.
        let mut forged = command(&TEST_KEY, 6, GroundCommand::SetHold(4));
        if let HostToTarget::GroundCommand { mac, .. } = &mut forged {
            mac[0] ^= 0x80;
        }
        let mut truncated = command(&TEST_KEY, 6, GroundCommand::ReleaseHold(3));
        if let HostToTarget::GroundCommand { mac, .. } = &mut truncated {
            mac.truncate(MAC_LEN - 4);
        }
        let wrong_key = sdls::Key {
            spi: TEST_KEY.spi,
            bytes: [0x33; 32],
        };
        let unknown_key = sdls::Key {
            spi: 2,
            bytes: TEST_KEY.bytes,
        };
        let cases = [
            (forged, SecurityRefusal::BadMac, 6),
            (truncated, SecurityRefusal::Truncated, 6),
            (
                command(&wrong_key, 6, GroundCommand::ReleaseHold(3)),
                SecurityRefusal::BadMac,
                6,
            ),
            (
                command(&unknown_key, 6, GroundCommand::ReleaseHold(3)),
                SecurityRefusal::UnknownKey,
                6,
            ),
            (
                command(&TEST_KEY, 5, GroundCommand::SetHold(3)),
                SecurityRefusal::Replay,
                5,
            ),
            (
                command(&TEST_KEY, 4, GroundCommand::ReleaseHold(3)),
                SecurityRefusal::Replay,
                4,
            ),
        ];
        for (msg, reason, sequence) in &cases {
            let out = send(&mut app, &mut mem, msg);
            assert_eq!(
                out.last(),
                Some(&security_nak(*reason, *sequence)),
                "{msg:?}"
            );
            assert_eq!(refusal_metrics(&out).len(), 1);
            assert_eq!(refusal_metrics(&out)[0].0, *reason);
            assert_eq!(app.security().holds(), 1 << 3);
            assert_eq!(app.security().last_sequence(), 5);
        }
        assert_eq!(app.security_refusals(SecurityRefusal::BadMac), 2);
        assert_eq!(app.security_refusals(SecurityRefusal::Replay), 2);
        // Authentic but out of range: refused, its number spent, nothing else changed.
        let out = send(
            &mut app,
            &mut mem,
            &command(&TEST_KEY, 7, GroundCommand::SetHold(40)),
        );
        assert_eq!(
            out.last(),
            Some(&TargetToHost::GroundCommandNak {
                sequence: 7,
                reason: CommandRefusal::HoldOutOfRange
            })
        );
        assert_eq!(app.security().last_sequence(), 7);
        assert_eq!(app.security().holds(), 1 << 3);
        // None of it touched the plan.
        assert_eq!(state_image(&app), before);

        // Warm reset and power cycle: the hold and the counter come back from NV.
        for power_cycle in [false, true] {
            if power_cycle {
                mem.warm.fill(0);
            }
            let mut app = std::boxed::Box::new(FlightApp::new());
            let mut out = Vec::new();
            app.boot(&mut mem, &mut NoClock, &mut |m| out.push(m));
            assert_eq!(
                out.first(),
                Some(&metric_event(metric::GROUND_HOLDS, 1 << 3))
            );
            assert_eq!(app.security().holds(), 1 << 3);
            let out = send(
                &mut app,
                &mut mem,
                &command(&TEST_KEY, 5, GroundCommand::ReleaseHold(3)),
            );
            assert_eq!(out.last(), Some(&security_nak(SecurityRefusal::Replay, 5)));
        }
        let mut app = std::boxed::Box::new(FlightApp::new());
        app.boot(&mut mem, &mut NoClock, &mut |_| {});
        let out = send(
            &mut app,
            &mut mem,
            &command(&TEST_KEY, 8, GroundCommand::ReleaseHold(3)),
        );
        assert_eq!(
            out,
            [
                metric_event(metric::GROUND_HOLDS, 0),
                TargetToHost::GroundCommandAck { sequence: 8 }
            ]
        );
    }

    #[test]
    fn an_uplink_signature_is_not_a_command_signature() {
        // The same key, header and bytes under the other service: never accepted.
        let mut warm = std::vec![0u8; 60 * 1024];
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: None,
            security: Some(&mut security),
        };
        let mut app = std::boxed::Box::new(FlightApp::new());
        app.boot(&mut mem, &mut NoClock, &mut |_| {});
        let header = SecurityHeader {
            spi: TEST_KEY.spi,
            sequence: 3,
        };
        let (bytes, len) = sdls::command_bytes(&GroundCommand::NoOp);
        let uplink_tag = sdls::mac::tag(
            &TEST_KEY.bytes,
            &[
                &[sdls::Service::Uplink as u8],
                &sdls::mac::header_bytes(&header),
                &bytes[..len],
            ],
        );
        let msg = HostToTarget::GroundCommand {
            header,
            command: GroundCommand::NoOp,
            mac: heapless::Vec::from_slice(&uplink_tag).unwrap(),
        };
        let out = send(&mut app, &mut mem, &msg);
        assert_eq!(out.last(), Some(&security_nak(SecurityRefusal::BadMac, 3)));
    }

    /// The real memories behind a target's copies (as the firmware's are behind the kernel):
    /// serves the application's reads and logs them.
    struct Backing {
        warm: Vec<u8>,
        nv: Vec<u8>,
        reads: Reads,
    }

    impl MemoryFetch for Backing {
        fn fetch(
            &mut self,
            memory: MemoryKind,
            offset: usize,
            bytes: &mut [u8],
        ) -> Result<(), StoreError> {
            self.reads.push((memory, offset, bytes.len()));
            let source = match memory {
                MemoryKind::Warm => &self.warm,
                MemoryKind::Nv => &self.nv,
            };
            bytes.copy_from_slice(source.get(offset..offset + bytes.len()).ok_or(StoreError)?);
            Ok(())
        }
    }

    const AREA: usize = 60 * 1024;

    /// Reads logged by [`Backing`]: (memory, offset, length).
    type Reads = Vec<(MemoryKind, usize, usize)>;

    /// The executive's shares of warm and non-volatile memory (`AREA` bytes each) after the
    /// flyby uplink and `frames` granted frames, and the security area.
    fn flown(frames: u32) -> (Vec<u8>, Vec<u8>, TestNv) {
        let mut app = std::boxed::Box::new(FlightApp::new());
        let (mut warm, mut nv) = (std::vec![0u8; 2 * AREA], std::vec![0u8; 2 * AREA]);
        let mut security = TestNv::provisioned(&TEST_KEY);
        let mut mem = Memories {
            warm: &mut warm,
            nv: Some(&mut nv),
            security: Some(&mut security),
        };
        boot_and_uplink_flyby(&mut app, &mut mem);
        for frame in 0..frames {
            let at = 9 * 3600 + 600 * u64::from(frame);
            app.handle(&grant(frame, at), &mut mem, &mut NoClock, &mut |_| {});
        }
        assert_eq!(executive_share(2 * AREA), AREA);
        warm.truncate(AREA);
        nv.truncate(AREA);
        (warm, nv, security)
    }

    /// Byte `at` of slot `slot`'s payload flipped (the record no longer whole).
    fn torn(mut area: Vec<u8>, slot: usize, at: usize) -> Vec<u8> {
        area[slot * (AREA / 2) + autonomy::checkpoint::RECORD_HEADER_LEN + at] ^= 0x40;
        area
    }

    /// The slot of the newest whole record of an area.
    fn newest_slot(area: &mut [u8]) -> usize {
        usize::from(WarmRestartArea::new(area).latest().unwrap().0)
    }

    /// Boot the executive's application and run the first window of a frame twice: with
    /// complete copies of the memories (`boot`, `handle`), and with empty copies filled on
    /// demand from `Backing` (`boot_fetching`, `handle_fetching`, each checkpoint's bytes
    /// copied out as the firmware does). Both must decide the same, say the same, and leave
    /// the memories byte for byte the same. Returns the outcome and the reads of the fetching
    /// boot (before the frame) and of the frame.
    fn boot_both_ways(warm: &[u8], nv: &[u8], security: &TestNv) -> (BootOutcome, Reads, Reads) {
        let frame = grant(40, 10 * 3600);
        // Complete copies.
        let (mut full_warm, mut full_nv) = (warm.to_vec(), nv.to_vec());
        let mut full_security = security.clone();
        let mut full_app = std::boxed::Box::new(ExecutiveApp::new());
        let mut full_out: Vec<TargetToHost> = Vec::new();
        let mut mem = Memories {
            warm: &mut full_warm,
            nv: Some(&mut full_nv),
            security: Some(&mut full_security),
        };
        let full_outcome = full_app.boot(&mut mem, &mut NoClock, &mut |m| full_out.push(m));
        full_app.handle(&frame, &mut mem, &mut NoClock, &mut |m| full_out.push(m));
        // Copies filled on demand.
        let mut backing = Backing {
            warm: warm.to_vec(),
            nv: nv.to_vec(),
            reads: Vec::new(),
        };
        let (mut copy_warm, mut copy_nv) = (std::vec![0u8; AREA], std::vec![0u8; AREA]);
        let mut copy_security = security.clone();
        let mut app = std::boxed::Box::new(ExecutiveApp::new());
        let mut out: Vec<TargetToHost> = Vec::new();
        let mut mem = Memories {
            warm: &mut copy_warm,
            nv: Some(&mut copy_nv),
            security: Some(&mut copy_security),
        };
        let outcome = app.boot_fetching(&mut mem, Some(&mut backing), &mut NoClock, &mut |m| {
            out.push(m)
        });
        let boot_reads = core::mem::take(&mut backing.reads);
        app.handle_fetching(
            &frame,
            &mut mem,
            Some(&mut backing),
            &mut NoClock,
            &mut |m| out.push(m),
        );
        for (start, end) in app.take_warm_writes() {
            backing.warm[start..end].copy_from_slice(&mem.warm[start..end]);
        }
        for (start, end) in app.take_nv_writes() {
            let nv = mem.nv.as_deref().unwrap();
            backing.nv[start..end].copy_from_slice(&nv[start..end]);
        }
        assert_eq!(outcome, full_outcome);
        assert_eq!(out, full_out);
        if backing.warm != full_warm {
            let diff: Vec<usize> = (0..full_warm.len())
                .filter(|&i| backing.warm[i] != full_warm[i])
                .collect();
            panic!(
                "warm memories differ at {} bytes, first {:?} last {:?}",
                diff.len(),
                diff.first(),
                diff.last()
            );
        }
        assert!(backing.nv == full_nv, "non-volatile memories differ");
        (outcome, boot_reads, backing.reads)
    }

    fn payload_reads(reads: &Reads, memory: MemoryKind) -> usize {
        reads
            .iter()
            .filter(|&&(m, _, len)| m == memory && len != autonomy::checkpoint::RECORD_HEADER_LEN)
            .count()
    }

    #[test]
    fn a_boot_that_reads_what_it_needs_decides_and_writes_as_one_given_both_whole_memories() {
        let (warm, nv, security) = flown(3);
        let (mut later_warm, later_nv, _) = flown(4);

        // Both memories as written (the same sequence numbers): the warm area's newest record
        // and the headers; non-volatile memory's records only before its first write.
        let (outcome, boot, frame) = boot_both_ways(&warm, &nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredWarm(_)));
        assert_eq!(payload_reads(&boot, MemoryKind::Warm), 1);
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);
        assert_eq!(boot.len(), 5, "four headers and one record: {boot:?}");
        assert_eq!(payload_reads(&frame, MemoryKind::Nv), 1);

        // The warm area's newest record torn: its other record, as new as non-volatile
        // memory's newest (sequence numbers equal): the warm one, from the other slot.
        let slot = newest_slot(&mut later_warm.clone());
        let (outcome, boot, _) = boot_both_ways(&torn(later_warm.clone(), slot, 7), &nv, &security);
        assert!(
            matches!(outcome, BootOutcome::RestoredWarm(info) if usize::from(info.slot) != slot)
        );
        assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);

        // Torn, and non-volatile memory a frame newer: non-volatile memory's.
        let (outcome, _, _) =
            boot_both_ways(&torn(later_warm.clone(), slot, 7), &later_nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredNv(_)));

        // Non-volatile memory newer than the warm area (a reset after its write only).
        let (outcome, boot, _) = boot_both_ways(&warm, &later_nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredNv(_)));
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);

        // ... with its newest record torn: its other one (the checkpoint of the same frame's
        // first window) is still newer than the warm area's: non-volatile memory's other
        // slot, and the warm area's records are read only before its first write.
        let nv_slot = newest_slot(&mut later_nv.clone());
        let (outcome, boot, frame) =
            boot_both_ways(&warm, &torn(later_nv.clone(), nv_slot, 3), &security);
        assert!(
            matches!(outcome, BootOutcome::RestoredNv(info) if usize::from(info.slot) != nv_slot)
        );
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 2);
        assert_eq!(payload_reads(&boot, MemoryKind::Warm), 0);
        assert_eq!(payload_reads(&frame, MemoryKind::Warm), 1);

        // A power cycle: the warm area is gone.
        let (outcome, _, _) = boot_both_ways(&std::vec![0u8; AREA], &nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredNv(_)));

        // Nothing anywhere: cold, and the first frame writes the first records.
        let blank = std::vec![0u8; AREA];
        let (outcome, _, _) = boot_both_ways(&blank, &blank, &security);
        assert_eq!(outcome, BootOutcome::Cold);

        // The warm area's newest record whole but not a plan (a firmware whose layout changed
        // without a new format version): the next newest whole record of either memory, here
        // the warm area's other one (a frame newer than non-volatile memory's; the uplink's
        // checkpoint is number 1, and each frame writes two, one per executive window).
        let not_a_plan = |buf: &mut [u8]| {
            buf[..4].copy_from_slice(&[0xff; 4]);
            Some(4)
        };
        WarmRestartArea::new(&mut later_warm)
            .write(not_a_plan)
            .unwrap();
        let (outcome, boot, _) = boot_both_ways(&later_warm, &nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if info.sequence == 9));
        assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);

        // Neither of the warm area's records a plan: non-volatile memory's newest, whose
        // records the choice had not needed until then.
        WarmRestartArea::new(&mut later_warm)
            .write(not_a_plan)
            .unwrap();
        let (outcome, boot, _) = boot_both_ways(&later_warm, &nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredNv(info) if info.sequence == 7));
        assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);
    }

    /// An area holding one record, numbered `sequence`, of `payload`.
    fn area_with(sequence: u32, payload: &[u8]) -> Vec<u8> {
        let mut area = std::vec![0u8; AREA];
        WarmRestartArea::new(&mut area)
            .write_after(Some(sequence.wrapping_sub(1)), |buf| {
                buf[..payload.len()].copy_from_slice(payload);
                Some(payload.len())
            })
            .unwrap();
        area
    }

    #[test]
    fn a_boot_that_reads_what_it_needs_compares_sequence_numbers_across_the_wrap() {
        let (mut older, _, security) = flown(3);
        let (mut newer, _, _) = flown(4);
        let older = WarmRestartArea::new(&mut older)
            .latest()
            .unwrap()
            .2
            .to_vec();
        let newer = WarmRestartArea::new(&mut newer)
            .latest()
            .unwrap()
            .2
            .to_vec();
        let newest = |area: &mut [u8]| WarmRestartArea::new(area).latest().map(|r| r.1);

        // Non-volatile memory's checkpoint numbered 0, after the warm area's u32::MAX: newer,
        // tried first, and the only payload read at boot; the warm area's is read before its
        // first write, and both memories go on at 1.
        let (warm, nv) = (area_with(u32::MAX, &older), area_with(0, &newer));
        let (outcome, boot, frame) = boot_both_ways(&warm, &nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredNv(info) if info.sequence == 0));
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);
        assert_eq!(payload_reads(&boot, MemoryKind::Warm), 0);
        assert_eq!(payload_reads(&frame, MemoryKind::Warm), 1);
        let mut full_warm = warm.clone();
        let mut full_nv = nv.clone();
        let mut app = std::boxed::Box::new(ExecutiveApp::new());
        let mut security_copy = security.clone();
        let mut mem = Memories {
            warm: &mut full_warm,
            nv: Some(&mut full_nv),
            security: Some(&mut security_copy),
        };
        app.boot(&mut mem, &mut NoClock, &mut |_| {});
        app.handle(&grant(40, 10 * 3600), &mut mem, &mut NoClock, &mut |_| {});
        assert_eq!(newest(&mut full_warm), Some(1));
        assert_eq!(newest(&mut full_nv), Some(1));

        // The other way round: the warm area's, without reading non-volatile memory's.
        let (warm, nv) = (area_with(0, &newer), area_with(u32::MAX, &older));
        let (outcome, boot, _) = boot_both_ways(&warm, &nv, &security);
        assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if info.sequence == 0));
        assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);
    }
}
