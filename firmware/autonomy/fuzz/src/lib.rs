//! Fuzz target logic for the autonomy core, in plain functions shared by the libFuzzer
//! wrappers (`fuzz_targets/`) and the bounded run on stable
//! (`firmware/autonomy/tests/fuzz_bounded.rs`).
//!
//! * [`uplink`]: any bytes as a task-network uplink. The element decoders agree with postcard;
//!   a refused uplink leaves the network untouched; an accepted one re-validates, round-trips,
//!   and is flown for a few frames, every checkpoint of which must restore.
//! * [`checkpoint`]: any bytes as the payload of a whole (CRC-valid) checkpoint record. The
//!   restore either refuses it and leaves a cold core, or restores a core that re-encodes to a
//!   payload that restores again, and that can be flown for a few frames with every checkpoint
//!   restoring (what the restore validation accepts, the core can run on; what the core
//!   writes, the validation accepts).
//! * [`executive_checkpoint`], [`planner_checkpoint`]: any bytes as the payload of a whole
//!   checkpoint record of the executive partition's or the planner partition's side (the
//!   checkpoints the flight software writes since the planner has its own partition). The
//!   restore either refuses it and leaves the side as a new one, or restores a side whose
//!   checkpoint a new side accepts and encodes back to the same bytes.
//!
//! Seeds are in `seeds/<target>/`: the shipped task networks and variants over capacity, and
//! checkpoints of flyby runs with resets and misbehaving subsystems (regenerate them with
//! `cargo run --manifest-path host-harness/fuzz/Cargo.toml --example seeds`).
use std::sync::Mutex;

use autonomy::checkpoint::{WarmRestartArea, RECORD_HEADER_LEN};
use autonomy::partitioned::{
    ExecutivePartition, PartitionSide, PlannerPartition, SideRestoreError,
};
use autonomy::uplink::{self, take_condition, take_task, take_timeline};
use autonomy::{
    Autonomy, CommandArgs, CommandStatus, ConditionSpec, MeasuredValueType, MissionTimeUs, Opcode,
    StateValue, StepBudget, TaskNetwork, TaskSpec, TelemetryEvent, TimelineSpec,
};

#[path = "../../../../fsw-bridge/fuzz/src/bounded.rs"]
pub mod bounded;

/// The targets of this crate, by name.
pub const TARGETS: &[bounded::Target] = &[
    ("uplink", uplink),
    ("checkpoint", checkpoint),
    ("executive_checkpoint", executive_checkpoint),
    ("planner_checkpoint", planner_checkpoint),
];

/// Planner work per frame when flying a fuzzed network: enough for the shipped networks,
/// small enough that a pathological one cannot make one input take seconds.
const FUZZ_BUDGET: StepBudget = StepBudget {
    planner_checks: 2_000,
};

/// Frames flown after a network is loaded or a checkpoint restored.
const FRAMES: usize = 6;

/// Bytes for a checkpoint payload: far more than the largest network and plan need.
const CHECKPOINT_BUF: usize = 64 * 1024;

/// Any bytes as a task-network uplink.
pub fn uplink(data: &[u8]) {
    element_decoders_agree_with_postcard(data);
    let mut network = TaskNetwork::EMPTY;
    match uplink::decode_into(&mut network, data) {
        Err(e) => {
            assert_eq!(
                network,
                TaskNetwork::EMPTY,
                "a refused uplink changed the network"
            );
            assert_eq!(
                uplink::validate_uplink(data),
                Err(e),
                "decode and validate differ"
            );
        }
        Ok(()) => {
            assert!(uplink::validate_uplink(data).is_ok());
            assert!(TaskNetwork::from_spec(network.spec().clone()).is_ok());
            let mut buf = vec![0u8; data.len() + 64];
            let len = network
                .encode(&mut buf)
                .expect("a decoded network re-encodes");
            let mut again = TaskNetwork::EMPTY;
            uplink::decode_into(&mut again, &buf[..len]).expect("re-encoded network decodes");
            assert_eq!(again, network, "encode/decode does not round-trip");
            with_scratch(|Scratch { core, checker }| {
                let core = fresh(core);
                core.load_network(network).expect("an idle core loads");
                let start = core
                    .network()
                    .tasks()
                    .iter()
                    .map(|t| t.earliest_start)
                    .min()
                    .unwrap_or(MissionTimeUs::ZERO);
                fly(core, checker, start, seed_of(data));
            });
        }
    }
}

/// The cores and buffers an input needs, kept from input to input: a fresh core and a
/// zeroed 64 KiB buffer per use would allocate and page in memory many times per input.
/// Every use starts from [`fresh`] or overwrites what it reads.
struct Scratch {
    /// The core an input loads its network into or restores its checkpoint into.
    core: Box<Autonomy>,
    /// Checks that checkpoints restore ([`Checker::restores`]).
    checker: Checker,
}

/// A second core and two buffers, to restore a checkpoint and encode it again.
struct Checker {
    core: Box<Autonomy>,
    buf: Vec<u8>,
    again: Vec<u8>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Option<Scratch>> = const { std::cell::RefCell::new(None) };
}

/// Runs `f` on this thread's [`Scratch`].
fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    SCRATCH.with(|cell| {
        let mut slot = cell.borrow_mut();
        let scratch = slot.get_or_insert_with(|| Scratch {
            core: Box::new(Autonomy::new()),
            checker: Checker {
                core: Box::new(Autonomy::new()),
                buf: vec![0; CHECKPOINT_BUF],
                again: vec![0; CHECKPOINT_BUF],
            },
        });
        f(scratch)
    })
}

/// `core` reset to a newly constructed one, in place.
fn fresh(core: &mut Autonomy) -> &mut Autonomy {
    *core = Autonomy::new();
    core
}

/// The field-by-field element decoders of the uplink accept exactly what postcard's derived
/// decoders accept, with the same value and the same rest.
fn element_decoders_agree_with_postcard(data: &[u8]) {
    let derived_timeline = postcard::take_from_bytes::<TimelineSpec>(data).ok();
    let ours = take_timeline(data, 0).ok();
    assert_eq!(ours, derived_timeline, "timeline decoders differ");
    let derived_condition = postcard::take_from_bytes::<ConditionSpec>(data).ok();
    let ours = take_condition(data, 0).ok();
    assert_eq!(ours, derived_condition, "condition decoders differ");
    let derived_task = postcard::take_from_bytes::<TaskSpec>(data).ok();
    let ours = take_task(data, 0).ok();
    assert_eq!(ours, derived_task, "task decoders differ");
}

/// A warm-restart area of two slots whose first holds `data` as a whole record (number 1).
fn area_bytes(data: &[u8]) -> Vec<u8> {
    let mut bytes = vec![0u8; 2 * (RECORD_HEADER_LEN + data.len())];
    WarmRestartArea::new(&mut bytes)
        .write(|buf| {
            buf.get_mut(..data.len())?.copy_from_slice(data);
            Some(data.len())
        })
        .expect("the area holds the payload");
    bytes
}

/// Any bytes as the payload of a whole checkpoint record.
pub fn checkpoint(data: &[u8]) {
    let mut bytes = area_bytes(data);
    let area = WarmRestartArea::new(&mut bytes);
    with_scratch(|Scratch { core, checker }| {
        let core = fresh(core);
        match core.restore_from(&area) {
            Err(_) => assert_cold(core),
            Ok(info) => {
                assert_eq!((info.slot, info.sequence), (0, 1));
                // What was accepted re-encodes to a payload that is accepted again, unchanged.
                let again = checker.restores(core).expect("a restored core checkpoints");
                let twice = fresh(&mut checker.core);
                twice
                    .decode_state(&again)
                    .expect("the re-encoded payload restores");
                let buf = &mut checker.buf;
                let len = twice.encode_state(buf).expect("fits");
                assert_eq!(
                    &buf[..len],
                    &again[..],
                    "checkpoint encoding is not a fixed point"
                );
                let now = core.now();
                fly(core, checker, now, seed_of(data));
            }
        }
    });
}

/// A core that restored nothing: empty, cold, waiting for an uplink.
fn assert_cold(core: &Autonomy) {
    assert!(core.plan().is_empty(), "refused restore left a plan");
    assert!(core.executive().entries().is_empty());
    assert!(core.network().tasks().is_empty() && core.network().timelines().is_empty());
    assert!(core.states().entries().is_empty());
    assert_eq!(core.now(), MissionTimeUs::ZERO);
    assert_eq!(core.next_wakeup(), None);
}

impl Checker {
    /// The checkpoint payload of `core`, after checking that a fresh core accepts it and
    /// encodes it back to the same bytes. None when it does not fit (the core reports that as
    /// a failed checkpoint write).
    fn restores(&mut self, core: &Autonomy) -> Option<Vec<u8>> {
        let len = core.encode_state(&mut self.buf)?;
        let buf = &self.buf[..len];
        let restored = fresh(&mut self.core);
        if let Err(e) = restored.decode_state(buf) {
            panic!("a checkpoint the core wrote is refused: {e:?}");
        }
        let again = &mut self.again;
        let len = restored.encode_state(again).expect("fits as before");
        assert_eq!(&again[..len], buf, "restore changed the state");
        Some(buf.to_vec())
    }
}

/// FNV-1a of the input: the deterministic choices of [`fly`] (values published, responses).
fn seed_of(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// Records dispatches.
#[derive(Default)]
struct Sink {
    dispatched: Vec<u32>,
}

impl autonomy::Outputs for Sink {
    fn dispatch(&mut self, id: u32, _: Opcode, _: &CommandArgs) {
        self.dispatched.push(id);
    }
    fn telemetry(&mut self, _: TelemetryEvent) {}
}

/// Flies `core` for [`FRAMES`] frames from `start`: every measured timeline is published
/// (a value of its type, now and then one of the wrong type or unknown), every command is
/// answered (Ok, Failed, Rejected, or not at all), the core steps at its next wakeup (or a
/// minute later), and every frame's checkpoint must restore.
fn fly(core: &mut Autonomy, checker: &mut Checker, start: MissionTimeUs, seed: u64) {
    let mut rng = bounded::Mutator::new(seed);
    let mut now = start;
    let mut pending: Vec<u32> = Vec::new();
    for _ in 0..FRAMES {
        let measured: Vec<_> = core.network().measured_timelines().collect();
        for (_, key, kind) in measured {
            let value = match (rng.below(8), kind) {
                (0, _) => StateValue::Unknown,
                (1, _) => StateValue::Int(rng.next_u64() as i64),
                (_, MeasuredValueType::Enum { values }) => {
                    StateValue::Enum(rng.below(usize::from(values)) as u16)
                }
                (_, MeasuredValueType::Int) => StateValue::Int(rng.below(20) as i64 - 5),
            };
            core.on_state_update(key, value, now);
        }
        for id in pending.drain(..) {
            let status = match rng.below(4) {
                0 => continue,
                1 => CommandStatus::Failed(7),
                2 => CommandStatus::Rejected,
                _ => CommandStatus::Ok,
            };
            core.on_command_response(id, status);
        }
        let mut sink = Sink::default();
        core.step(now, FUZZ_BUDGET, &mut sink);
        pending = sink.dispatched;
        let _ = checker.restores(core);
        let next = core.next_wakeup().unwrap_or(now.saturating_add(60_000_000));
        now = next.max(now.saturating_add(1));
    }
}

/// Bytes for a partition side's checkpoint payload: the executive's carries the network image
/// besides its tables, far below this.
const SIDE_CHECKPOINT_BUF: usize = 4 << 20;

/// A side to restore into and a second one to check its checkpoint, kept from input to input
/// (both are hundreds of KB: built once, at compile time, and reset in place).
struct SidePair<S> {
    side: S,
    again: S,
}

static EXECUTIVE_SIDES: Mutex<SidePair<ExecutivePartition>> = Mutex::new(SidePair {
    side: ExecutivePartition::new(),
    again: ExecutivePartition::new(),
});

static PLANNER_SIDES: Mutex<SidePair<PlannerPartition>> = Mutex::new(SidePair {
    side: PlannerPartition::new(),
    again: PlannerPartition::new(),
});

thread_local! {
    /// Three payload buffers: a new side's encoding, a restored side's, and the check's.
    static SIDE_BUFS: std::cell::RefCell<[Vec<u8>; 3]> =
        std::cell::RefCell::new(std::array::from_fn(|_| vec![0; SIDE_CHECKPOINT_BUF]));
}

/// Any bytes as the payload of a whole checkpoint record of the executive partition.
pub fn executive_checkpoint(data: &[u8]) {
    executive_checkpoint_restores(data);
}

/// [`executive_checkpoint`], telling whether the payload was restored.
pub fn executive_checkpoint_restores(data: &[u8]) -> bool {
    side_checkpoint(&EXECUTIVE_SIDES, data)
}

/// Any bytes as the payload of a whole checkpoint record of the planner partition.
pub fn planner_checkpoint(data: &[u8]) {
    planner_checkpoint_restores(data);
}

/// [`planner_checkpoint`], telling whether the payload was restored.
pub fn planner_checkpoint_restores(data: &[u8]) -> bool {
    side_checkpoint(&PLANNER_SIDES, data)
}

/// Restores one side from a whole record holding `data`: refused, the side is a new one
/// again (it encodes as one); accepted, its checkpoint is accepted by a new side, which
/// encodes it back unchanged (what the restore accepts, the side can checkpoint; what it
/// writes, the restore accepts). True when it was restored.
fn side_checkpoint<S: PartitionSide>(pair: &Mutex<SidePair<S>>, data: &[u8]) -> bool {
    // A panic under the lock (a finding) must not hide the next input's result.
    let mut pair = pair.lock().unwrap_or_else(|e| e.into_inner());
    let SidePair { side, again } = &mut *pair;
    SIDE_BUFS.with(|bufs| {
        let [new_bytes, restored_bytes, again_bytes] = &mut *bufs.borrow_mut();
        side.reset();
        let new_len = side.encode_state(new_bytes).expect("a new side encodes");
        let mut bytes = area_bytes(data);
        let area = WarmRestartArea::new(&mut bytes);
        match side.restore_from(&area) {
            Err(SideRestoreError::NoRecord) => panic!("the record written is not found"),
            Err(SideRestoreError::BadPayload) => {
                let len = side
                    .encode_state(restored_bytes)
                    .expect("a reset side encodes");
                assert_eq!(
                    &restored_bytes[..len],
                    &new_bytes[..new_len],
                    "a refused restore left state behind"
                );
                false
            }
            Ok(sequence) => {
                assert_eq!(sequence, 1);
                let len = side
                    .encode_state(restored_bytes)
                    .expect("a restored side checkpoints");
                again.reset();
                again
                    .decode_state(&restored_bytes[..len])
                    .expect("a restored side's checkpoint restores");
                let again_len = again.encode_state(again_bytes).expect("fits as before");
                assert_eq!(
                    &again_bytes[..again_len],
                    &restored_bytes[..len],
                    "a side's checkpoint encoding is not a fixed point"
                );
                true
            }
        }
    })
}
