//! The autonomy core as two partitions: the control loop in the executive partition, the
//! planning loop in the planner partition, a port each way, each side checkpointing its own
//! state. This is the model the firmware's partition split follows, runnable on the host:
//! [`ExecutivePartition`] and [`PlannerPartition`] hold everything each partition holds, and
//! [`Wire`] is everything that crosses a port.
//!
//! # A major frame
//! One time grant is one major frame of mission time ([`MAJOR_FRAME_US`]), with three windows
//! in this order:
//! 1. the executive's first window ([`ExecutivePartition::first_window`]): what the planner
//!    sent, the host's input of the frame (already taken in), the ages of measured values, the
//!    first executive pass (responses, start, maintain and end checks, timeouts);
//! 2. the planner's window ([`PlannerPartition::window`]): what the executive sent, then
//!    planning within the window's budget (validity checks), then commits. A cycle that does
//!    not finish resumes in the next frame's window: the planner is anytime;
//! 3. the executive's second window ([`ExecutivePartition::second_window`]): the commits, and
//!    the second executive pass, so that a task committed for now starts now.
//!
//! The executive runs both of its windows every frame whatever the planner does: no amount of
//! planning changes when the control loop runs. When the planner's cycle finishes within its
//! window, the decisions are exactly those of [`crate::Autonomy`], which runs the same loops
//! in the same order with the planner run to completion: the unthrottled reference (a test
//! holds the two to the same outputs). When it does not, the frame ends with the planner's
//! work pending, and the next grant comes one major frame later in mission time
//! ([`Frame::next_wakeup`]): a planner that needs more CPU commits later in mission time, and
//! [`PlannerStatus::cycle_latency_us`] says how much later.
//!
//! # Consistent restore
//! Each side checkpoints its own state in its own warm-restart area, and a reset can come at
//! any instruction of either. What keeps the pair consistent is a rule for the ports, checked
//! by the reset tests:
//! - **checkpoint, then send**: a message leaves only once the state that produced it is in a
//!   checkpoint ([`Outbox`] keeps it, numbered, until the receiver has checkpointed it);
//! - **acknowledge after checkpointing**: the receiver applies messages in order, once each
//!   (by number), and acknowledges them ([`Wire::Ack`]) only after its own checkpoint holds
//!   them;
//! - **resume after a restore**: a restored side tells the other what it has applied
//!   ([`Wire::Resume`]); the other sends again what came after. A message in a port at the
//!   reset, or sent after the receiver's last checkpoint, is sent again; none is applied twice.
//!
//! So after any reset each side restores its own newest whole checkpoint, the two exchange
//! `Resume`, and the planner's view of what the executive holds (commits, reports) is again
//! what the executive holds.
//!
//! # What else crosses the ports
//! - **The network.** The executive validates and loads an uplinked network, then streams its
//!   image to the planner through the same numbered channel ([`PlannerInput::NetworkBegin`],
//!   chunks of [`NETWORK_CHUNK_BYTES`], [`PlannerInput::NetworkEnd`] with the image's CRC), a
//!   few dozen chunks per frame so the channel's log stays small. The planner checks the CRC,
//!   validates and loads it. Every network has a generation number: the planner tags its
//!   commits with the generation it planned for, and the executive drops (and counts) a commit
//!   for another one, so nothing planned for a replaced network is ever executed. The state
//!   the executive already knows goes to the planner after the network's end.
//! - **The frame.** The executive's first window ends with [`PlannerInput::Frame`]: the
//!   planner plans once per frame of mission time, in its window after that message.
//! - **The planner's telemetry and status.** The planner's decisions (transitions, plan
//!   modifications) travel to the executive in the channel and leave for the host at the start
//!   of the executive's second window, so the host sees the frame's decisions in the order the
//!   windows ran, on any target. [`PlannerInput::Frame`] is answered by a
//!   [`ExecutiveInput::Status`]: whether planning is pending, the planner's next wake-up, and
//!   a finished cycle's latency.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crc::{Crc, CRC_32_ISO_HDLC};

use crate::capacity::{MAX_COMMITTED, MAX_MISSION_TIME_US};
use crate::checkpoint::{
    self, CheckpointError, Record, RestoreInfo, WarmRestartArea, WrittenRecord,
};
use crate::condition::StateTableInPlace;
use crate::control::ControlLoop;
use crate::executive::ExecutiveInPlace;
use crate::in_place;
use crate::interface::{Commit, Outputs, ReportKind, TaskReport, ToPlanner};
use crate::model::TaskNetwork;
use crate::planner::{Planner, PlannerInPlace};
use crate::uplink;
use crate::LoadError;
use fsw_bridge::{
    CommandArgs, CommandStatus, MissionTimeUs, Opcode, StateKey, StateValue, TelemetryEvent,
};

/// One major frame of the partition schedule in mission time (10 ms): how far mission time
/// advances per grant while the planner has work pending.
pub const MAJOR_FRAME_US: u64 = 10_000;
/// Messages the executive keeps for the planner until they are acknowledged: a frame's state
/// updates, reports and returned commits, and up to [`MAX_CHUNKS_PER_FRAME`] network chunks.
/// Twice [`crate::capacity::MAX_COMMITTED`], so that a report for every task the executive
/// holds fits beside the frame's other messages (64 failed at once filled the log, and the
/// frame's own message was refused before its last place was kept for it). The last place
/// is always the frame's; anything else refused is counted (`Outbox::refused`, reported as
/// `channel_refused_to_planner`).
pub const MAX_TO_PLANNER_IN_FLIGHT: usize = 2 * crate::capacity::MAX_COMMITTED;
/// Network chunks the executive puts in the channel per frame (the rest of the log is kept for
/// the frame's other messages, and a port holds a frame's messages): 16 chunks of 96 bytes,
/// 1.5 KiB of image per frame, so the flyby's image (about 1 KiB) goes in one frame and the
/// largest (16 KiB) in 11.
pub const MAX_CHUNKS_PER_FRAME: usize = 16;
/// Messages the planner keeps for the executive until they are acknowledged: a window's
/// commits (at most one per task the executive can hold), its telemetry and its status.
pub const MAX_TO_EXECUTIVE_IN_FLIGHT: usize = 128;
/// Bytes of network image per chunk.
pub const NETWORK_CHUNK_BYTES: usize = 96;
/// Largest network image the two partitions exchange: the flight application's uplink
/// buffer (32 KiB, a 256-task network of the lander capacities is about 25 KiB).
pub const MAX_NETWORK_IMAGE: usize = 32 * 1024;
/// Planner telemetry the executive holds between its receipt and the second window.
pub const MAX_FORWARDED_TELEMETRY: usize = 128;

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// From the executive partition to the planner partition.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PlannerInput {
    /// A core message (measurements, reports, returned commits).
    Core(ToPlanner),
    /// A new network of `len` bytes (uplink format) follows: forget the plan.
    NetworkBegin { generation: u32, len: u32 },
    /// `bytes` of the image at `offset`.
    NetworkChunk {
        offset: u32,
        bytes: Vec<u8, NETWORK_CHUNK_BYTES>,
    },
    /// The image is complete; its CRC-32.
    NetworkEnd { generation: u32, crc: u32 },
    /// The executive's first window of frame `frame` at mission time `now` is done: plan.
    Frame { frame: u32, now: MissionTimeUs },
    /// About the temporal plan the executive dispatches (appended: the variants above keep
    /// their encoding).
    Dispatch(DispatchNote),
}

/// From the planner partition to the executive partition.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ExecutiveInput {
    /// A task for the executive, planned for network `generation`.
    Commit { generation: u32, commit: Commit },
    /// A planner decision for the host.
    Telemetry(TelemetryEvent),
    /// The answer to [`PlannerInput::Frame`].
    Status(PlannerStatus),
    /// A chunk of a temporal plan's dispatch network, every step by `horizon` (appended: the
    /// variants above keep their encoding).
    DispatchChunk { horizon: u32, chunk: DispatchChunk },
}

/// What the planner's window for one frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlannerStatus {
    pub frame: u32,
    /// The cycle stopped on the window's budget: it resumes in the next frame's window.
    pub pending: bool,
    /// When the planner needs to run next (its own needs).
    pub next_wakeup: Option<MissionTimeUs>,
    /// A cycle ended in this window this long after the window that started it (mission
    /// time, µs).
    pub cycle_latency_us: Option<u64>,
    /// Validity checks spent.
    pub checks: u32,
    /// Commits sent.
    pub commits: u32,
}

mod channel;
mod dispatch;
mod executive;
mod frame;
mod planner;

pub use channel::{Inbox, Outbox, Wire};
use channel::{OutboxInPlace, EMPTY_INBOX};
pub use dispatch::dispatch_part_max_bytes;
pub use dispatch::{
    ChunkRefusal, DispatchChunk, DispatchNote, DispatchRestoreError, DispatchSender,
    ExecutedRefusal, ExecutiveDispatch, DISPATCH_PART_FORMAT, MAX_CHECKPOINTED_DISPATCH_CHUNKS,
    MAX_DISPATCH_CHUNKS_PER_WINDOW, MAX_DISPATCH_NOTES,
};
pub use executive::{ExecutivePartition, ExecutivePartitionStats};
pub use frame::{run_frame, Frame, FrameEnv, Interrupted, Point, Side};
pub use planner::PlannerPartition;

/// Why a side could not be restored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SideRestoreError {
    /// No whole record in the area.
    NoRecord,
    /// The newest whole record did not decode or validate.
    BadPayload,
}

/// What both sides do with their checkpoints.
pub trait PartitionSide {
    /// The whole state as a checkpoint payload.
    fn encode_state(&self, buf: &mut [u8]) -> Option<usize>;
    /// The checkpoint now holds the whole state: what it kept may go, what it applied may be
    /// acknowledged.
    fn checkpointed(&mut self);
    /// Replaces the state with a checkpoint's (checked as a restored checkpoint is); None when
    /// refused.
    fn decode_state(&mut self, payload: &[u8]) -> Option<()>;
    /// Makes this side a cold, empty one.
    fn reset(&mut self);
    /// The restart adjustments after a decoded checkpoint numbered `sequence` (see each
    /// side's `prepare_restart`).
    fn prepare_restart(&mut self, sequence: u32);

    /// Restores this side from one record the caller found whole (its CRC is not checked
    /// again) and prepares the restart. On error this side is a cold, empty one.
    fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, SideRestoreError> {
        let Record {
            slot,
            sequence,
            payload,
        } = record;
        if self.decode_state(payload).is_none() {
            self.reset();
            return Err(SideRestoreError::BadPayload);
        }
        self.prepare_restart(sequence);
        Ok(RestoreInfo {
            slot,
            sequence,
            payload_len: u32::try_from(payload.len()).unwrap_or(u32::MAX),
        })
    }

    /// Writes this side's checkpoint into its own area and, written, marks what it holds.
    fn checkpoint_to(
        &mut self,
        area: &mut WarmRestartArea<'_>,
    ) -> Result<WrittenRecord, CheckpointError> {
        let written = area.write_record(|buf| self.encode_state(buf))?;
        self.checkpointed();
        Ok(written)
    }

    /// Restores this side from the newest whole record of its area; its sequence number.
    fn restore_from(&mut self, area: &WarmRestartArea<'_>) -> Result<u32, SideRestoreError> {
        let (slot, sequence, payload) = area.latest().ok_or(SideRestoreError::NoRecord)?;
        self.restore_record(Record {
            slot,
            sequence,
            payload,
        })
        .map(|info| info.sequence)
    }
}

impl PartitionSide for ExecutivePartition {
    fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        ExecutivePartition::encode_state(self, buf)
    }
    fn checkpointed(&mut self) {
        ExecutivePartition::checkpointed(self)
    }
    fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        ExecutivePartition::decode_state(self, payload)
    }
    fn reset(&mut self) {
        ExecutivePartition::reset(self)
    }
    fn prepare_restart(&mut self, sequence: u32) {
        ExecutivePartition::prepare_restart(self, sequence)
    }
}

impl PartitionSide for PlannerPartition {
    fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        PlannerPartition::encode_state(self, buf)
    }
    fn checkpointed(&mut self) {
        PlannerPartition::checkpointed(self)
    }
    fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        PlannerPartition::decode_state(self, payload)
    }
    fn reset(&mut self) {
        PlannerPartition::reset(self)
    }
    fn prepare_restart(&mut self, sequence: u32) {
        PlannerPartition::prepare_restart(self, sequence)
    }
}

/// One side's transmission: a `Resume` when it (re)started, the acknowledgement of what its
/// checkpoint holds, then what its outbox may send, until `send` refuses one.
fn transmit<T: Clone, const N: usize>(
    resume: &mut bool,
    inbox: &mut Inbox,
    outbox: &mut Outbox<T, N>,
    send: &mut impl FnMut(Wire<T>) -> bool,
) {
    if *resume {
        if !send(Wire::Resume {
            received: inbox.received,
        }) {
            return;
        }
        *resume = false;
    }
    if let Some(upto) = inbox.ack() {
        let _ = send(Wire::Ack { upto });
    }
    outbox.transmit(send);
}

/// Appends `value`'s postcard encoding to the `len` bytes of `buf` already used.
fn put<T: Serialize>(value: &T, buf: &mut [u8], len: &mut usize) -> Option<()> {
    *len += postcard::to_slice(value, buf.get_mut(*len..)?).ok()?.len();
    Some(())
}

/// The network in uplink format behind a 4-byte length.
fn encode_network(network: &TaskNetwork, buf: &mut [u8]) -> Option<usize> {
    let body = buf.get_mut(4..)?;
    let n = network.encode(body).ok()?;
    buf.get_mut(..4)?
        .copy_from_slice(&u32::try_from(n).ok()?.to_be_bytes());
    Some(4 + n)
}

/// The network's image (uplink format, as a side holds it) behind a 4-byte length: what
/// [`encode_network`] writes, without encoding the network again.
fn put_network_image(image: &[u8], buf: &mut [u8]) -> Option<usize> {
    buf.get_mut(4..4 + image.len())?.copy_from_slice(image);
    buf.get_mut(..4)?
        .copy_from_slice(&u32::try_from(image.len()).ok()?.to_be_bytes());
    Some(4 + image.len())
}

/// Decodes and validates what [`encode_network`] (or [`put_network_image`]) wrote into
/// `network`; the image itself and the bytes after it.
fn decode_network<'a>(network: &mut TaskNetwork, bytes: &'a [u8]) -> Option<(&'a [u8], &'a [u8])> {
    let n = usize::try_from(u32::from_be_bytes(bytes.get(..4)?.try_into().ok()?)).ok()?;
    let body = bytes.get(4..)?.get(..n)?;
    uplink::decode_then_validate(network, body).ok()?;
    Some((body, bytes.get(4 + n..)?))
}
