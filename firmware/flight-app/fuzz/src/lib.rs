//! Fuzz target logic for the flight application, in plain functions shared by the libFuzzer
//! wrappers (`fuzz_targets/`) and the bounded run on stable
//! (`firmware/flight-app/tests/fuzz_bounded.rs`).
//!
//! Both targets drive a [`Harness`]: a [`FlightApp`] with a warm-restart area, non-volatile
//! checkpoint areas and a security area provisioned with [`KEY`], fed [`Op`]s (a decoded host
//! message, an uplink or ground command the harness secures itself, a warm reset, a power
//! cycle, security-area writes failing or not), checking after each one:
//! * a time grant is answered by exactly one `FrameDone`, for that frame, last;
//! * every uplink chunk gets the answers of [`UplinkModel`] (the transfer protocol written
//!   out as a specification); a completed transfer is judged by [`SecurityModel`] (the
//!   documented order of the security checks and the anti-replay rule, written out again):
//!   refused with its security reason, counted, and nothing changed (plan, counter, holds);
//!   or, authentic and fresh, its sequence number stored in non-volatile memory first and
//!   then the image loaded exactly as it validates, or refused with the validator's code, or
//!   as busy (the number stays spent either way);
//! * every ground command gets [`SecurityModel`]'s answer, and sets or releases exactly the
//!   hold it names, never touching the plan;
//! * every checkpoint written restores, and restores to the same bytes;
//! * a boot restores the newest record of either memory (every record is one the application
//!   wrote, so every one validates), or comes up cold when there is none; it reads back the
//!   anti-replay counter and the holds the model expects.
//!
//! * [`messages`]: any sequence of [`Op`]s (postcard-encoded back to back): time going
//!   backwards, grants repeated or out of order, arbitrary command responses, state updates of
//!   any key and type, raw uplink chunks and ground commands (forged, replayed, truncated),
//!   properly secured ones with any sequence number, resets at any point.
//! * [`uplink_chunks`]: an uplink image, secured by the harness or sent as it is, cut into
//!   chunks and delivered with a script of defects (duplicates, losses, reordering, wrong
//!   totals, flipped bits, resets and grants in between).
//!
//! * [`rover_checkpoint`]: the rover mission's checkpoint memory (and the task buffer it names)
//!   as a reset leaves it, any bytes: taking the mission up again never panics, and a mission
//!   taken up saves and takes up again to the same records (`restore(save(m))` is `m`).
//!
//! Seeds are in `seeds/<target>/`: the message sequences of the shipped scenarios flown on the
//! native target (`hil` signs with the key the harness provisions), and the shipped networks
//! as chunked uplinks (regenerate them with
//! `cargo run --manifest-path host-harness/fuzz/Cargo.toml --example seeds`).
use autonomy::checkpoint::records;
use autonomy::partitioned::{ExecutivePartition, PlannerPartition};
use autonomy::{TaskNetwork, TaskRole};
use flight_app::{
    metric, uplink_reason, BootOutcome, FlightApp, Memories, NoClock, SecurityStore, StoreError,
    MAX_UPLINK_BYTES,
};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::security::{MAC_LEN, MAX_GROUND_HOLDS};
use fsw_bridge::{
    CommandRefusal, GroundCommand, HostToTarget, MissionTimeUs, SecurityHeader, SecurityRefusal,
    TargetToHost, TelemetryEvent,
};
use sdls::nv::SECURITY_AREA_BYTES;
use serde::{Deserialize, Serialize};

#[path = "../../../../fsw-bridge/fuzz/src/bounded.rs"]
pub mod bounded;

/// The targets of this crate, by name.
pub const TARGETS: &[bounded::Target] = &[
    ("messages", messages),
    ("uplink_chunks", uplink_chunks),
    ("rover_checkpoint", rover_checkpoint),
];

/// Bytes of the warm-restart area in the harness: the executive's and the planner's shares
/// (`flight_app::executive_share`: half each; a checkpoint slot is half a share), small enough
/// that a large fuzzed network overflows a share now and then (a failed checkpoint write)
/// while non-volatile memory still takes it.
pub const WARM_BYTES: usize = 32 * 1024;
/// Bytes of non-volatile checkpoint memory in the harness (the security area is apart).
pub const NV_BYTES: usize = 128 * 1024;

/// The executive's share of a memory.
fn executive_part(memory: &[u8]) -> &[u8] {
    &memory[..flight_app::executive_share(memory.len())]
}

/// The planner's share of a memory.
fn planner_part(memory: &[u8]) -> &[u8] {
    &memory[flight_app::executive_share(memory.len())..]
}
/// Most operations one input is cut to (keeps one input's run time bounded).
pub const MAX_OPS: usize = 1_000;

/// The key the harness provisions and secures its uplinks and commands with: `hil`'s built-in
/// test key (`hil::mission::auth::TEST_KEY`, repeated here because the flight application
/// cannot depend on `hil`; the seed generator checks that they are equal), so that the
/// missions `hil` flew and recorded as seeds verify in the harness too.
pub const KEY: sdls::Key = sdls::Key {
    spi: 1,
    bytes: *b"hil test key - not a secret (v1)",
};

/// One thing that happens to the flight application.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Op {
    /// A message from the host, as the link decoded it.
    Message(HostToTarget),
    /// A warm reset: RAM is lost, both memories are kept; the application boots.
    WarmReset,
    /// A power cycle: RAM and the warm-restart area are lost; the application boots.
    PowerCycle,
    /// The ground uplinks `image`: the harness secures it with [`KEY`] and sequence number
    /// `step` after the last one the application accepted (wrapping: 1 is what the ground
    /// sends, 0 or below a replay, more a gap), cuts it into chunks of `1 + chunk % 128`
    /// bytes and sends them in order.
    SecuredUplink {
        image: Vec<u8>,
        chunk: u8,
        step: i32,
    },
    /// The ground sends `command` signed with [`KEY`], its sequence number chosen as for
    /// [`Op::SecuredUplink`].
    SecuredCommand { command: GroundCommand, step: i32 },
    /// From now on writes to the security area fail (true) or succeed (false): the
    /// non-volatile memory that keeps the anti-replay counter is faulty.
    SecurityWritesFail(bool),
}

/// `data` as operations: postcard-encoded [`Op`]s back to back, up to the first that does not
/// decode (at most [`MAX_OPS`]).
pub fn decode_ops(data: &[u8]) -> Vec<Op> {
    let mut ops = Vec::new();
    let mut rest = data;
    while ops.len() < MAX_OPS {
        match postcard::take_from_bytes::<Op>(rest) {
            Ok((op, more)) => {
                ops.push(op);
                rest = more;
            }
            Err(_) => break,
        }
    }
    ops
}

/// The input [`decode_ops`] reads back as `ops`.
pub fn encode_ops(ops: &[Op]) -> Vec<u8> {
    let mut out = Vec::new();
    for op in ops {
        out.extend(postcard::to_allocvec(op).expect("an op encodes"));
    }
    out
}

/// Any sequence of host messages and resets.
pub fn messages(data: &[u8]) {
    with_harness(|harness| {
        for op in decode_ops(data) {
            harness.apply(&op);
        }
    });
}

thread_local! {
    /// The harness the targets reuse from input to input, put back to a power-on state
    /// ([`Harness::power_on`]) before each: a fresh one would allocate and page in the
    /// application, a checkpoint core and the memories anew for every input.
    static HARNESS: std::cell::RefCell<Option<Harness>> = const { std::cell::RefCell::new(None) };
}

/// Runs `f` on a harness in the state [`Harness::new`] gives, reusing this thread's.
fn with_harness(f: impl FnOnce(&mut Harness)) {
    HARNESS.with(|cell| {
        let mut slot = cell.borrow_mut();
        match slot.as_mut() {
            Some(harness) => harness.power_on(),
            None => *slot = Some(Harness::new()),
        }
        if let Some(harness) = slot.as_mut() {
            f(harness);
        }
    });
}

/// An uplink image cut into chunks and delivered with a script of defects. Layout: image
/// length (2 bytes, big-endian), a control byte (low 7 bits: chunk size - 1; high bit clear:
/// the harness secures the image with [`KEY`] and the next sequence number first, set: the
/// image is sent as it is), the image, then the script, two bytes per defect (see
/// [`chunk_ops`]). A grant follows the last chunk, so a network that loads is flown for a
/// frame and checkpointed.
pub fn uplink_chunks(data: &[u8]) {
    with_harness(|harness| {
        for op in chunk_ops(data) {
            harness.apply(&op);
        }
    });
}

/// The control byte's bit that sends an [`uplink_chunks`] image without securing it.
pub const RAW_IMAGE: u8 = 0x80;
// Chunk sizes up to 128 (the control byte's low 7 bits) all fit a chunk.
const _: () = assert!(UPLINK_CHUNK_MAX >= 128);

/// The operations [`uplink_chunks`] performs for `data`. The image is secured with sequence
/// number 1: the harness starts with a freshly provisioned key, so that is the next one.
pub fn chunk_ops(data: &[u8]) -> Vec<Op> {
    let [hi, lo, control, rest @ ..] = data else {
        return Vec::new();
    };
    let image_len = usize::from(u16::from_be_bytes([*hi, *lo])).min(rest.len());
    let chunk = 1 + usize::from(*control & 0x7f);
    let (image, script) = rest.split_at(image_len);
    let secured;
    let sent = if control & RAW_IMAGE != 0 {
        image
    } else {
        secured = secure_uplink(1, image);
        &secured[..]
    };
    let pieces: Vec<&[u8]> = if sent.is_empty() {
        vec![&[]]
    } else {
        sent.chunks(chunk).collect()
    };
    let total = u16::try_from(pieces.len()).unwrap_or(u16::MAX);
    let mut ops: Vec<Op> = pieces
        .iter()
        .enumerate()
        .map(|(seq, bytes)| {
            Op::Message(HostToTarget::UplinkChunk {
                seq: u16::try_from(seq).unwrap_or(u16::MAX),
                total,
                bytes: heapless::Vec::from_slice(bytes).expect("a chunk fits"),
            })
        })
        .collect();
    for (n, defect) in script.chunks(2).take(64).enumerate() {
        let [kind, arg] = defect else { break };
        let i = usize::from(*arg) % ops.len();
        match kind % 9 {
            0 => {
                let again = ops[i].clone();
                ops.insert(i, again);
            }
            1 if ops.len() > 1 => {
                ops.remove(i);
            }
            2 if i + 1 < ops.len() => ops.swap(i, i + 1),
            3 => {
                if let Op::Message(HostToTarget::UplinkChunk { total, .. }) = &mut ops[i] {
                    *total = total.wrapping_add(1);
                }
            }
            4 => ops.insert(i, grant(n as u32, 0)),
            5 => ops.insert(i, Op::WarmReset),
            6 => {
                if let Op::Message(HostToTarget::UplinkChunk { seq, .. }) = &mut ops[i] {
                    *seq = u16::from(*arg);
                }
            }
            7 => {
                if let Op::Message(HostToTarget::UplinkChunk { bytes, .. }) = &mut ops[i] {
                    bytes.clear();
                }
            }
            _ => {
                // A bit flipped on the way (the link's CRC would catch it; a forger would not).
                if let Op::Message(HostToTarget::UplinkChunk { bytes, .. }) = &mut ops[i] {
                    if !bytes.is_empty() {
                        let at = usize::from(*arg) % bytes.len();
                        bytes[at] ^= 1 << (arg % 8);
                    }
                }
            }
        }
    }
    ops.push(grant(u32::MAX, 1));
    ops
}

/// A grant for `frame` at 9:50 plus `minutes` (the shipped networks' morning).
fn grant(frame: u32, minutes: u64) -> Op {
    let now = MissionTimeUs::from_mins(590 + minutes);
    Op::Message(HostToTarget::TimeGrant {
        frame,
        now,
        until: now.saturating_add(60_000_000),
    })
}

/// `image` secured with [`KEY`] and `sequence` (`sdls::uplink`'s layout), as the ground sends
/// it.
pub fn secure_uplink(sequence: u32, image: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; image.len() + sdls::uplink::OVERHEAD];
    let len = sdls::uplink::sign_into(&KEY, sequence, image, &mut out)
        .expect("the output has room for the image and its header and trailer");
    out.truncate(len);
    out
}

/// `command` signed with [`KEY`] and `sequence`, as the ground sends it.
pub fn secure_command(sequence: u32, command: GroundCommand) -> HostToTarget {
    let header = SecurityHeader {
        spi: KEY.spi,
        sequence,
    };
    HostToTarget::GroundCommand {
        header,
        command,
        mac: heapless::Vec::from_slice(&sdls::command_mac(&KEY, &header, &command))
            .expect("a MAC fits"),
    }
}

/// The uplink transfer protocol written out as a specification: what the application must
/// answer to each chunk.
#[derive(Debug, Default)]
pub struct UplinkModel {
    transfer: Option<Transfer>,
}

#[derive(Debug)]
struct Transfer {
    next: u16,
    total: u16,
    image: Vec<u8>,
}

/// What one chunk must bring.
#[derive(Debug, PartialEq, Eq)]
pub enum ChunkAnswer {
    /// `UplinkNak { seq, reason }` and nothing else.
    Nak(u16),
    /// `UplinkAck { seq }` and nothing else.
    Ack,
    /// `UplinkAck { seq }`, then the whole transfer (a secured uplink) is judged.
    Complete(Vec<u8>),
}

impl UplinkModel {
    /// The answer to chunk `seq` of `total` carrying `bytes`. A chunk 0 starts a new transfer;
    /// any other chunk must be the next one of the transfer in progress, with its total; the
    /// transfer may not grow past [`MAX_UPLINK_BYTES`]; a refused chunk ends the transfer.
    pub fn answer(&mut self, seq: u16, total: u16, bytes: &[u8]) -> ChunkAnswer {
        if seq == 0 {
            self.transfer = Some(Transfer {
                next: 0,
                total,
                image: Vec::new(),
            });
        }
        let Some(t) = self.transfer.as_mut() else {
            return ChunkAnswer::Nak(uplink_reason::OUT_OF_SEQUENCE);
        };
        let refusal = if total == 0 || total != t.total {
            Some(uplink_reason::BAD_TOTAL)
        } else if seq != t.next {
            Some(uplink_reason::OUT_OF_SEQUENCE)
        } else if t.image.len() + bytes.len() > MAX_UPLINK_BYTES {
            Some(uplink_reason::TOO_LARGE)
        } else {
            None
        };
        if let Some(reason) = refusal {
            self.transfer = None;
            return ChunkAnswer::Nak(reason);
        }
        t.image.extend_from_slice(bytes);
        if u32::from(seq) + 1 < u32::from(total) {
            t.next = seq + 1;
            return ChunkAnswer::Ack;
        }
        let image = std::mem::take(&mut t.image);
        self.transfer = None;
        ChunkAnswer::Complete(image)
    }
}

/// The security rules of `sdls` (its crate documentation) written out as a specification,
/// for a target provisioned with [`KEY`]: the order of the checks, the anti-replay rule
/// (fresh iff greater than the last number accepted; the last one accepted lives in
/// non-volatile memory and survives every reset; stored before the message takes effect, and
/// refused with `CounterNotStored` when it cannot be), and the ground holds. Only the MAC is
/// computed with `sdls::mac` (the oracle for "authentic").
#[derive(Debug, Default)]
pub struct SecurityModel {
    /// The last sequence number accepted (0: none yet).
    pub last_sequence: u32,
    /// Ground holds set (bit h: hold h).
    pub holds: u32,
    /// Writes to the security area fail.
    pub writes_fail: bool,
    /// Refusals per reason since the last boot.
    refusals: [u64; SecurityRefusal::COUNT],
    /// Authentic commands not carried out since the last boot.
    not_carried_out: u64,
    /// Refusals per reason over the harness's life.
    total_refusals: [u64; SecurityRefusal::COUNT],
}

/// A secured uplink's parts, as `sdls::uplink` documents its layout.
struct SecuredParts<'a> {
    spi: u16,
    sequence: u32,
    /// Header and image: what the MAC covers after the service byte.
    covered: &'a [u8],
    image: &'a [u8],
    mac: &'a [u8],
}

/// Header: SPI (2 bytes), sequence number (4), image length L (4), big-endian; then the image,
/// then a 32-byte MAC. Shorter than that: truncated; longer: a bad length.
fn split_secured(bytes: &[u8]) -> Result<SecuredParts<'_>, SecurityRefusal> {
    const HEADER: usize = 10;
    if bytes.len() < HEADER {
        return Err(SecurityRefusal::Truncated);
    }
    let word =
        |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let length = u64::from(word(6));
    let whole = HEADER as u64 + length + MAC_LEN as u64;
    let len = bytes.len() as u64;
    if len < whole {
        return Err(SecurityRefusal::Truncated);
    }
    if len > whole {
        return Err(SecurityRefusal::BadLength);
    }
    let image_end = bytes.len() - MAC_LEN;
    Ok(SecuredParts {
        spi: u16::from_be_bytes([bytes[0], bytes[1]]),
        sequence: word(2),
        covered: &bytes[..image_end],
        image: &bytes[HEADER..image_end],
        mac: &bytes[image_end..],
    })
}

impl SecurityModel {
    /// The number `step` after the last one accepted.
    pub fn sequence_after(&self, step: i32) -> u32 {
        self.last_sequence.wrapping_add(step as u32)
    }

    fn fresh(&self, sequence: u32) -> Result<(), SecurityRefusal> {
        if sequence > self.last_sequence {
            Ok(())
        } else {
            Err(SecurityRefusal::Replay)
        }
    }

    /// A whole transfer: its sequence number and image if authentic and fresh.
    fn check_uplink<'a>(&self, bytes: &'a [u8]) -> Result<(u32, &'a [u8]), SecurityRefusal> {
        let parts = split_secured(bytes)?;
        if parts.spi != KEY.spi {
            return Err(SecurityRefusal::UnknownKey);
        }
        let expected = sdls::mac::tag(&KEY.bytes, &[&[sdls::Service::Uplink as u8], parts.covered]);
        if parts.mac != expected {
            return Err(SecurityRefusal::BadMac);
        }
        self.fresh(parts.sequence)?;
        Ok((parts.sequence, parts.image))
    }

    /// A ground command: Ok if authentic and fresh.
    fn check_command(
        &self,
        header: &SecurityHeader,
        command: &GroundCommand,
        mac: &[u8],
    ) -> Result<(), SecurityRefusal> {
        if mac.len() < MAC_LEN {
            return Err(SecurityRefusal::Truncated);
        }
        if header.spi != KEY.spi {
            return Err(SecurityRefusal::UnknownKey);
        }
        if mac != sdls::command_mac(&KEY, header, command) {
            return Err(SecurityRefusal::BadMac);
        }
        self.fresh(header.sequence)
    }

    /// Store `sequence` and `holds` (non-volatile memory first).
    fn accept(&mut self, sequence: u32, holds: u32) -> Result<(), SecurityRefusal> {
        if self.writes_fail {
            return Err(SecurityRefusal::CounterNotStored);
        }
        self.last_sequence = sequence;
        self.holds = holds;
        Ok(())
    }

    /// Count a refusal; the count since boot.
    fn refuse(&mut self, reason: SecurityRefusal) -> u64 {
        self.total_refusals[reason.index()] += 1;
        self.refusals[reason.index()] += 1;
        self.refusals[reason.index()]
    }

    /// A reboot: the counter and the holds are in non-volatile memory, the counts are not.
    fn boot(&mut self) {
        self.refusals = [0; SecurityRefusal::COUNT];
        self.not_carried_out = 0;
    }
}

/// The security area of the harness's non-volatile memory, with writes that can be made to
/// fail.
struct SecurityNv {
    area: [u8; SECURITY_AREA_BYTES],
    writes_fail: bool,
}

impl SecurityNv {
    /// An area with [`KEY`] provisioned and nothing else, writes succeeding.
    fn provisioned() -> Self {
        static AREA: std::sync::OnceLock<[u8; SECURITY_AREA_BYTES]> = std::sync::OnceLock::new();
        let area = *AREA.get_or_init(|| {
            let mut area = [0u8; SECURITY_AREA_BYTES];
            sdls::nv::provision(&mut area, &KEY).expect("a whole security area");
            area
        });
        Self {
            area,
            writes_fail: false,
        }
    }
}

impl SecurityStore for SecurityNv {
    fn read(&mut self, area: &mut [u8; SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(&self.area);
        Ok(())
    }

    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        if self.writes_fail {
            return Err(StoreError);
        }
        let end = offset.checked_add(bytes.len()).ok_or(StoreError)?;
        self.area
            .get_mut(offset..end)
            .ok_or(StoreError)?
            .copy_from_slice(bytes);
        Ok(())
    }
}

/// What the verdicts on whole uplinks and ground commands were, over a harness's life (the
/// bounded run's tests check that the seeds reach each).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Verdicts {
    /// Uplinks and ground commands refused by the security checks, per reason.
    pub security_refusals: [u64; SecurityRefusal::COUNT],
    /// Authentic, fresh uplinks refused by the validator.
    pub invalid: u64,
    /// Authentic, fresh, valid uplinks refused because the executive was busy.
    pub busy: u64,
    /// Uplinks loaded.
    pub loaded: u64,
    /// Ground commands carried out.
    pub commands: u64,
    /// Authentic ground commands not carried out (hold out of range).
    pub commands_not_carried_out: u64,
}

/// A flight application with its memories, checked after every operation.
pub struct Harness {
    app: Box<FlightApp>,
    warm: Vec<u8>,
    nv: Vec<u8>,
    security_nv: SecurityNv,
    model: UplinkModel,
    security: SecurityModel,
    verdicts: Verdicts,
    /// The sides a written checkpoint is restored into (reset before each restore).
    restored_executive: Box<ExecutivePartition>,
    restored_planner: Box<PlannerPartition>,
    /// Room for an encoded state (the state images and the re-encoded checkpoints).
    state_buf: Vec<u8>,
}

/// Bytes of [`Harness`]'s buffer for an encoded state: far more than any state needs.
const STATE_BUF_BYTES: usize = 4 * MAX_UPLINK_BYTES + 64 * 1024;

impl Default for Harness {
    fn default() -> Self {
        Self::new()
    }
}

/// The security refusal metrics among `out`: (reason, count).
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

/// The values of metric `id` among `out`.
fn metric_values(out: &[TargetToHost], id: u16) -> Vec<u64> {
    out.iter()
        .filter_map(|m| match m {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if *i == id => {
                Some(*value)
            }
            _ => None,
        })
        .collect()
}

impl Harness {
    /// A power-on with both checkpoint memories empty and [`KEY`] provisioned: cold.
    pub fn new() -> Self {
        let mut h = Self {
            app: Box::new(FlightApp::new()),
            warm: vec![0; WARM_BYTES],
            nv: vec![0; NV_BYTES],
            security_nv: SecurityNv::provisioned(),
            model: UplinkModel::default(),
            security: SecurityModel::default(),
            verdicts: Verdicts::default(),
            restored_executive: Box::new(ExecutivePartition::new()),
            restored_planner: Box::new(PlannerPartition::new()),
            state_buf: vec![0; STATE_BUF_BYTES],
        };
        assert_eq!(h.boot(), BootOutcome::Cold);
        h
    }

    /// Puts this harness back to the state [`Harness::new`] gives (both memories empty,
    /// [`KEY`] freshly provisioned, the models at their start, booted cold), in the memory it
    /// already has. Every field is named, so a field added later cannot be forgotten here.
    pub fn power_on(&mut self) {
        let Self {
            app: _,
            warm,
            nv,
            security_nv,
            model,
            security,
            verdicts,
            restored_executive: _,
            restored_planner: _,
            state_buf: _,
        } = self;
        warm.fill(0);
        nv.fill(0);
        *security_nv = SecurityNv::provisioned();
        *model = UplinkModel::default();
        *security = SecurityModel::default();
        *verdicts = Verdicts::default();
        // The application and the restore core are rebuilt from `new()` where they are used.
        assert_eq!(self.boot(), BootOutcome::Cold);
    }

    /// The application.
    pub fn app(&self) -> &FlightApp {
        &self.app
    }

    /// The security model (what the application must have accepted so far).
    pub fn security(&self) -> &SecurityModel {
        &self.security
    }

    /// The verdicts so far.
    pub fn verdicts(&self) -> &Verdicts {
        &self.verdicts
    }

    /// The payload of the executive's newest checkpoint in the warm-restart area.
    pub fn warm_checkpoint(&self) -> Option<&[u8]> {
        records(executive_part(&self.warm))[0].map(|r| r.payload)
    }

    /// The payload of the planner's newest checkpoint in the warm-restart area.
    pub fn planner_checkpoint(&self) -> Option<&[u8]> {
        records(planner_part(&self.warm))[0].map(|r| r.payload)
    }

    /// Performs `op` and checks what the application did.
    pub fn apply(&mut self, op: &Op) {
        match op {
            Op::WarmReset => {
                self.boot();
            }
            Op::PowerCycle => {
                self.warm.fill(0);
                self.boot();
            }
            Op::Message(msg) => self.message(msg),
            Op::SecuredUplink { image, chunk, step } => {
                let secured = secure_uplink(self.security.sequence_after(*step), image);
                let size = 1 + usize::from(*chunk) % UPLINK_CHUNK_MAX;
                let pieces: Vec<&[u8]> = secured.chunks(size).collect();
                let total = u16::try_from(pieces.len()).unwrap_or(u16::MAX);
                for (seq, bytes) in pieces.iter().enumerate() {
                    let Ok(seq) = u16::try_from(seq) else { break };
                    self.message(&HostToTarget::UplinkChunk {
                        seq,
                        total,
                        bytes: heapless::Vec::from_slice(bytes).expect("a chunk fits"),
                    });
                }
            }
            Op::SecuredCommand { command, step } => {
                let sequence = self.security.sequence_after(*step);
                self.message(&secure_command(sequence, *command));
            }
            Op::SecurityWritesFail(fail) => {
                self.security.writes_fail = *fail;
                self.security_nv.writes_fail = *fail;
            }
        }
    }

    /// Boots a fresh application on the memories; it must restore the newest record of
    /// either (all were written by the application and checked to restore), and read back
    /// the anti-replay counter and the holds.
    fn boot(&mut self) -> BootOutcome {
        let newest = [&self.warm, &self.nv]
            .into_iter()
            .filter_map(|m| records(executive_part(m))[0].map(|r| r.sequence))
            .reduce(|a, b| {
                if autonomy::checkpoint::is_newer(b, a) {
                    b
                } else {
                    a
                }
            });
        *self.app = FlightApp::new();
        self.model = UplinkModel::default();
        self.security.boot();
        let mut memories = Memories {
            warm: &mut self.warm,
            nv: Some(&mut self.nv),
            security: Some(&mut self.security_nv),
        };
        let mut out = Vec::new();
        let outcome = self
            .app
            .boot(&mut memories, &mut NoClock, &mut |m| out.push(m));
        match (newest, outcome) {
            (None, BootOutcome::Cold) => {}
            (Some(seq), BootOutcome::RestoredWarm(info) | BootOutcome::RestoredNv(info)) => {
                assert_eq!(info.sequence, seq, "boot did not restore the newest record");
            }
            (newest, outcome) => panic!("newest record {newest:?}, boot {outcome:?}"),
        }
        let sa = self.app.security();
        assert!(sa.has_key(), "the provisioned key was not read");
        assert_eq!(
            (sa.last_sequence(), sa.holds()),
            (self.security.last_sequence, self.security.holds),
            "boot read another counter or other holds than were stored"
        );
        let holds = metric_values(&out, metric::GROUND_HOLDS);
        let expected: &[u64] = match self.security.holds {
            0 => &[],
            h => &[u64::from(h)],
        };
        assert_eq!(holds, expected, "holds announced at boot");
        outcome
    }

    /// The whole plan and execution state (both partitions'), to show that something left it
    /// untouched.
    fn state_image(&mut self) -> Vec<u8> {
        let len = self
            .app
            .encode_state(&mut self.state_buf)
            .expect("the state fits");
        self.state_buf[..len].to_vec()
    }

    fn message(&mut self, msg: &HostToTarget) {
        // Busy while the executive owns tasks, or the last network is still on its way to the
        // planner.
        let executive = self.app.executive().executive();
        let busy =
            !executive.control().executive().entries().is_empty() || executive.transferring();
        let expected = match msg {
            HostToTarget::UplinkChunk { seq, total, bytes } => {
                Some(self.model.answer(*seq, *total, bytes))
            }
            _ => None,
        };
        let judged = matches!(expected, Some(ChunkAnswer::Complete(_)))
            || matches!(msg, HostToTarget::GroundCommand { .. });
        let before = judged.then(|| (self.state_image(), self.security_nv.area));
        let mut out = Vec::new();
        let handled = {
            let mut memories = Memories {
                warm: &mut self.warm,
                nv: Some(&mut self.nv),
                security: Some(&mut self.security_nv),
            };
            self.app
                .handle(msg, &mut memories, &mut NoClock, &mut |m| out.push(m))
        };
        match msg {
            HostToTarget::Ping { .. } | HostToTarget::ResetRequest { .. } => {
                assert!(!handled && out.is_empty(), "{msg:?} is the I/O layer's");
            }
            HostToTarget::TemporalBegin { .. }
            | HostToTarget::TemporalChunk { .. }
            | HostToTarget::LanderBegin { .. }
            | HostToTarget::LanderChunk { .. }
            | HostToTarget::LanderStep { .. }
            | HostToTarget::LanderInput { .. }
            | HostToTarget::Rover { .. } => {
                assert!(
                    !handled && out.is_empty(),
                    "{msg:?} is the planner partition's"
                );
            }
            HostToTarget::StateUpdate { .. } | HostToTarget::CommandResponse { .. } => {
                assert!(handled && out.is_empty(), "{msg:?} answered with {out:?}");
            }
            HostToTarget::TimeGrant { frame, .. } => {
                let done: Vec<_> = out
                    .iter()
                    .filter(|m| matches!(m, TargetToHost::FrameDone { .. }))
                    .collect();
                assert_eq!(done.len(), 1, "one FrameDone per grant: {out:?}");
                assert!(
                    matches!(out.last(), Some(TargetToHost::FrameDone { frame: f, .. }) if f == frame),
                    "the grant's FrameDone comes last: {out:?}"
                );
            }
            HostToTarget::UplinkChunk { seq, total, .. } => {
                let expected = expected.expect("computed for chunks");
                self.check_chunk(*seq, *total, expected, busy, before, &out);
            }
            HostToTarget::GroundCommand {
                header,
                command,
                mac,
            } => {
                let before = before.expect("taken for commands");
                self.check_command(header, command, mac, before, &out);
            }
        }
        self.verdicts.security_refusals = self.security.total_refusals;
        self.check_security_state();
        self.check_checkpoints(&out);
    }

    fn check_chunk(
        &mut self,
        seq: u16,
        total: u16,
        expected: ChunkAnswer,
        busy: bool,
        before: Option<(Vec<u8>, [u8; SECURITY_AREA_BYTES])>,
        out: &[TargetToHost],
    ) {
        // Checkpoint write failures and refusal counts may be reported between the answers.
        let answers: Vec<&TargetToHost> = out
            .iter()
            .filter(|m| !matches!(m, TargetToHost::Telemetry(_)))
            .collect();
        let secured = match expected {
            ChunkAnswer::Nak(reason) => {
                assert_eq!(answers, [&TargetToHost::UplinkNak { seq, reason }]);
                return;
            }
            ChunkAnswer::Ack => {
                assert_eq!(answers, [&TargetToHost::UplinkAck { seq }]);
                return;
            }
            ChunkAnswer::Complete(secured) => secured,
        };
        let (state_before, area_before) = before.expect("taken for a whole transfer");
        // Authentic and fresh first; the number is stored before the image is validated.
        let accepted = self
            .security
            .check_uplink(&secured)
            .and_then(|(sequence, image)| {
                let holds = self.security.holds;
                self.security.accept(sequence, holds).map(|()| image)
            });
        let image = match accepted {
            Err(reason) => {
                let count = self.security.refuse(reason);
                let nak = TargetToHost::UplinkNak {
                    seq: total,
                    reason: reason.code(),
                };
                assert_eq!(answers, [&TargetToHost::UplinkAck { seq }, &nak]);
                assert_eq!(
                    refusal_metrics(out),
                    [(reason, count)],
                    "{reason:?} counted"
                );
                assert_eq!(
                    self.state_image(),
                    state_before,
                    "an uplink refused as {reason:?} changed the plan"
                );
                assert_eq!(
                    self.security_nv.area, area_before,
                    "an uplink refused as {reason:?} wrote the security area"
                );
                return;
            }
            Ok(image) => image,
        };
        assert!(refusal_metrics(out).is_empty(), "accepted, yet {out:?}");
        let stored = sdls::nv::current_counter(&self.security_nv.area)
            .map(|(_, record)| record.last_sequence);
        assert_eq!(
            stored,
            Some(self.security.last_sequence),
            "the accepted number is not in non-volatile memory"
        );
        let last = match TaskNetwork::validate_uplink(image) {
            Err(e) => {
                self.verdicts.invalid += 1;
                TargetToHost::UplinkNak {
                    seq: total,
                    reason: e.code.code(),
                }
            }
            Ok(()) if busy => {
                self.verdicts.busy += 1;
                TargetToHost::UplinkNak {
                    seq: total,
                    reason: uplink_reason::BUSY,
                }
            }
            Ok(()) => {
                self.verdicts.loaded += 1;
                let mut network = TaskNetwork::EMPTY;
                autonomy::uplink::decode_into(&mut network, image).expect("validated");
                assert_eq!(
                    self.app.executive().executive().network(),
                    &network,
                    "loaded network"
                );
                // The planner loads it in the next frame, from the executive's stream.
                let _ = TaskRole::Requested;
                TargetToHost::UplinkAck { seq: total }
            }
        };
        if matches!(last, TargetToHost::UplinkNak { .. }) {
            assert_eq!(
                self.state_image(),
                state_before,
                "a refused network changed the plan"
            );
        }
        assert_eq!(answers, [&TargetToHost::UplinkAck { seq }, &last]);
    }

    fn check_command(
        &mut self,
        header: &SecurityHeader,
        command: &GroundCommand,
        mac: &[u8],
        (state_before, area_before): (Vec<u8>, [u8; SECURITY_AREA_BYTES]),
        out: &[TargetToHost],
    ) {
        let sequence = header.sequence;
        let holds = self.security.holds;
        let bit = |hold: u8| (hold < MAX_GROUND_HOLDS).then(|| 1u32 << hold);
        let holds_after = match *command {
            GroundCommand::NoOp => Some(holds),
            GroundCommand::SetHold(h) => bit(h).map(|b| holds | b),
            GroundCommand::ReleaseHold(h) => bit(h).map(|b| holds & !b),
        };
        // An authentic, fresh command spends its number even when it cannot be carried out.
        let verdict = self
            .security
            .check_command(header, command, mac)
            .and_then(|()| self.security.accept(sequence, holds_after.unwrap_or(holds)));
        let answers: Vec<&TargetToHost> = out
            .iter()
            .filter(|m| !matches!(m, TargetToHost::Telemetry(_)))
            .collect();
        assert_eq!(
            self.state_image(),
            state_before,
            "a ground command changed the plan"
        );
        match (verdict, holds_after) {
            (Err(reason), _) => {
                let count = self.security.refuse(reason);
                let nak = TargetToHost::GroundCommandNak {
                    sequence,
                    reason: CommandRefusal::Security(reason),
                };
                assert_eq!(answers, [&nak]);
                assert_eq!(
                    refusal_metrics(out),
                    [(reason, count)],
                    "{reason:?} counted"
                );
                assert_eq!(
                    self.security_nv.area, area_before,
                    "a command refused as {reason:?} wrote the security area"
                );
            }
            (Ok(()), None) => {
                self.security.not_carried_out += 1;
                self.verdicts.commands_not_carried_out += 1;
                let nak = TargetToHost::GroundCommandNak {
                    sequence,
                    reason: CommandRefusal::HoldOutOfRange,
                };
                assert_eq!(answers, [&nak]);
                assert_eq!(
                    metric_values(out, metric::GROUND_COMMANDS_NOT_CARRIED_OUT),
                    [self.security.not_carried_out]
                );
            }
            (Ok(()), Some(after)) => {
                self.verdicts.commands += 1;
                assert_eq!(answers, [&TargetToHost::GroundCommandAck { sequence }]);
                let expected: &[u64] = if after == holds {
                    &[]
                } else {
                    &[u64::from(after)]
                };
                assert_eq!(metric_values(out, metric::GROUND_HOLDS), expected);
            }
        }
    }

    /// The application holds the counter and the holds the model expects, and non-volatile
    /// memory holds them too (once anything was stored).
    fn check_security_state(&self) {
        let sa = self.app.security();
        assert_eq!(
            (sa.last_sequence(), sa.holds()),
            (self.security.last_sequence, self.security.holds),
            "the application's counter and holds differ from the model's"
        );
        if let Some((_, record)) = sdls::nv::current_counter(&self.security_nv.area) {
            assert_eq!(
                (record.last_sequence, record.holds, record.key_check),
                (
                    self.security.last_sequence,
                    self.security.holds,
                    KEY.check()
                ),
                "non-volatile memory's counter record"
            );
        } else {
            assert_eq!((self.security.last_sequence, self.security.holds), (0, 0));
        }
    }

    /// Every record the last message wrote restores, to the same bytes. Both memories are
    /// written with the same state under the same number; the non-volatile copy is checked
    /// against the warm one, or on its own when the warm write failed. A message can make
    /// several checkpoints (a grant's two windows): when the warm memory's newest record is
    /// older than non-volatile memory's, a later warm write failed (the warm share is the
    /// smaller: a state it cannot hold) and `out` must count the failure.
    fn check_checkpoints(&mut self, out: &[TargetToHost]) {
        let share = flight_app::executive_share(self.warm.len());
        let nv_share = flight_app::executive_share(self.nv.len());
        let warm_writes: Vec<_> = self.app.take_warm_writes().into_iter().collect();
        let nv_writes: Vec<_> = self.app.take_nv_writes().into_iter().collect();
        self.check_planner_checkpoints(
            warm_writes.iter().any(|w| w.0 >= share),
            nv_writes.iter().any(|w| w.0 >= nv_share),
        );
        let warm = warm_writes.iter().any(|w| w.0 < share);
        let nv = nv_writes.iter().any(|w| w.0 < nv_share);
        if warm && nv {
            let (w, n) = (
                records(executive_part(&self.warm))[0],
                records(executive_part(&self.nv))[0],
            );
            let (w, n) = (w.expect("written"), n.expect("written"));
            if w.sequence == n.sequence {
                assert_eq!(
                    w.payload, n.payload,
                    "both memories hold the same checkpoint"
                );
            } else {
                assert!(
                    autonomy::checkpoint::is_newer(n.sequence, w.sequence),
                    "the warm memory's newest record ({}) is newer than non-volatile memory's ({})",
                    w.sequence,
                    n.sequence
                );
                assert!(
                    metric_values(out, metric::CHECKPOINT_WRITE_FAILURES)
                        .iter()
                        .sum::<u64>()
                        > 0,
                    "the memories' newest records differ ({} warm, {} non-volatile) and no \
                     failed checkpoint write was counted",
                    w.sequence,
                    n.sequence
                );
            }
        }
        for (written, memory) in [(warm, &self.warm), (nv && !warm, &self.nv)] {
            if !written {
                continue;
            }
            let record = records(executive_part(memory))[0].expect("a record was written");
            // A fresh side, in the memory of the last one (no allocation per check).
            let side = &mut *self.restored_executive;
            side.reset();
            if side.decode_state(record.payload).is_none() {
                panic!("an executive checkpoint the application wrote is refused");
            }
            let again = &mut self.state_buf[..record.payload.len()];
            let len = side.encode_state(again).expect("fits as before");
            assert_eq!(&again[..len], record.payload, "restore changed the state");
        }
    }

    /// The same for the planner's records.
    fn check_planner_checkpoints(&mut self, warm: bool, nv: bool) {
        for (written, memory) in [(warm, &self.warm), (nv && !warm, &self.nv)] {
            if !written {
                continue;
            }
            let record = records(planner_part(memory))[0].expect("a record was written");
            let side = &mut *self.restored_planner;
            side.reset();
            if side.decode_state(record.payload).is_none() {
                panic!("a planner checkpoint the application wrote is refused");
            }
            let again = &mut self.state_buf[..record.payload.len()];
            let len = side.encode_state(again).expect("fits as before");
            assert_eq!(&again[..len], record.payload, "restore changed the state");
        }
    }
}

// ----- the rover mission's checkpoint ---------------------------------------------------------

use flight_app::rover_mission::checkpoint::{
    restore as rover_restore, save_all as rover_save_all, RoverCheckpoint,
};
use flight_app::rover_mission::RoverMission;

/// The input of [`rover_checkpoint`]: the task buffer's first bytes (their length a big-endian
/// u32, then the bytes), then each of the four slots (state 0 and 1, plan 0 and 1) as a
/// big-endian u32 count of words and the words (big-endian); what is missing is zeros, what
/// is beyond a slot is cut.
pub fn encode_rover_checkpoint(task_buffer: &[u8], cp: &RoverCheckpoint) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&(task_buffer.len() as u32).to_be_bytes());
    out.extend_from_slice(task_buffer);
    let slots: [&[u32]; 4] = [&cp.state[0], &cp.state[1], &cp.plan[0], &cp.plan[1]];
    for slot in slots {
        // Up to the record's end (its length word and CRC), or its magic only when empty.
        let n = slot[3] as usize + 5;
        let used = if slot[0] == 0 { 1 } else { n.min(slot.len()) };
        out.extend_from_slice(&(used as u32).to_be_bytes());
        for w in &slot[..used] {
            out.extend_from_slice(&w.to_be_bytes());
        }
    }
    out
}

fn decode_rover_checkpoint(data: &[u8]) -> (Vec<u8>, Box<RoverCheckpoint>) {
    let mut at = 0usize;
    let word = |at: &mut usize| {
        let w = data
            .get(*at..*at + 4)
            .map_or(0, |b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]));
        *at += 4;
        w
    };
    // The task buffer: at most the half of the buffer the mission's task lives in.
    let len = (word(&mut at) as usize).min(flight_app::rover_mission::ROVER_REPLAN_AT);
    let task = data.get(at..).unwrap_or_default();
    let task = task[..len.min(task.len())].to_vec();
    at += len;
    let mut cp = Box::new(RoverCheckpoint::new());
    for i in 0..4 {
        let n = word(&mut at) as usize;
        let slot: &mut [u32] = match i {
            0 | 1 => &mut cp.state[i][..],
            _ => &mut cp.plan[i - 2][..],
        };
        for k in 0..n.min(slot.len()) {
            slot[k] = word(&mut at);
        }
        at += 4 * n.saturating_sub(slot.len());
    }
    (task, cp)
}

/// See [`rover_checkpoint_restores`].
pub fn rover_checkpoint(data: &[u8]) {
    rover_checkpoint_restores(data);
}

/// Takes the mission up from the checkpoint in `data` ([`encode_rover_checkpoint`]'s layout);
/// whether it was. A mission taken up is saved into fresh memory and taken up again from it:
/// the same events count, and saved again, the same records word for word.
pub fn rover_checkpoint_restores(data: &[u8]) -> bool {
    let (task, cp) = decode_rover_checkpoint(data);
    let mut m = Box::new(RoverMission::new().expect("an idle mission"));
    let Ok(Some(events)) = rover_restore(&mut m, &cp, &task) else {
        return false;
    };
    let mut once = Box::new(RoverCheckpoint::new());
    rover_save_all(&mut m, &mut once);
    let mut again = Box::new(RoverMission::new().expect("an idle mission"));
    assert_eq!(
        rover_restore(&mut again, &once, &task),
        Ok(Some(events)),
        "a mission taken up did not take up again from its own checkpoint"
    );
    let mut twice = Box::new(RoverCheckpoint::new());
    rover_save_all(&mut again, &mut twice);
    assert!(
        once.state == twice.state && once.plan == twice.plan,
        "restore(save(m)) saved other records than m"
    );
    true
}
