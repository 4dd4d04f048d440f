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
//! [`Frame::planning_latency_us`] says how much later.
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
use crate::interface::{Commit, Outputs, ToPlanner};
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
pub const MAX_TO_PLANNER_IN_FLIGHT: usize = 64;
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
/// Largest network image the two partitions exchange (the uplink's limit).
pub const MAX_NETWORK_IMAGE: usize = 16 * 1024;
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

/// What crosses a port between the two partitions.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wire<T> {
    /// Message number `seq` (from 1, in order).
    Message { seq: u32, message: T },
    /// The sender of this has checkpointed every message up to `upto` it received.
    Ack { upto: u32 },
    /// The sender of this (re)started, restored or cold, and has applied every message up to
    /// `received`: send again what came after.
    Resume { received: u32 },
    /// The messages before `next` are void: the receiver lost what they built on (its
    /// checkpoint, or the sender's, is gone). The receiver takes `next` as the next message.
    Rebase { next: u32 },
}

/// The sending end of one direction: every message numbered and kept until acknowledged.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Outbox<T, const N: usize> {
    /// The number the next message gets.
    next_seq: u32,
    /// Messages up to this number have gone to the port (or were acknowledged). Not saved:
    /// after a restore every message kept goes again.
    #[serde(skip)]
    sent: u32,
    /// Messages up to this number were in this side's last checkpoint: only they may go. Not
    /// saved: a restored state is a checkpointed one.
    #[serde(skip)]
    sendable: u32,
    /// Messages not acknowledged yet, oldest first.
    log: Vec<(u32, T), N>,
    /// Messages refused because the log was full (the sender's count of what it lost).
    pub refused: u32,
    /// Messages sent again after the receiver was restored.
    pub resent: u32,
    /// The receiver cannot be caught up by sending again (see [`Wire::Rebase`]): the next
    /// transmission starts with a `Rebase` to this number (the first message kept after it).
    /// Not saved: the receiver's next `Resume` asks again.
    #[serde(skip)]
    rebase: Option<u32>,
    /// Times the channel was rebased.
    pub rebases: u32,
}

impl<T: Clone, const N: usize> Default for Outbox<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Clone, const N: usize> Outbox<T, N> {
    pub const fn new() -> Self {
        Self {
            next_seq: 1,
            sent: 0,
            sendable: 0,
            log: Vec::new(),
            refused: 0,
            resent: 0,
            rebase: None,
            rebases: 0,
        }
    }

    /// Keeps `message` for sending; false (and counted) when the log is full.
    pub fn push(&mut self, message: T) -> bool {
        if self.log.push((self.next_seq, message)).is_err() {
            self.refused = self.refused.saturating_add(1);
            return false;
        }
        self.next_seq = self.next_seq.wrapping_add(1);
        true
    }

    /// Room for this many more messages.
    pub fn room(&self) -> usize {
        N - self.log.len()
    }

    /// Messages not acknowledged yet.
    pub fn unacknowledged(&self) -> usize {
        self.log.len()
    }

    /// Messages kept but not sent yet.
    pub fn unsent(&self) -> usize {
        self.log.iter().filter(|(seq, _)| *seq > self.sent).count()
    }

    /// The receiver has checkpointed every message up to `upto` (an acknowledgement of
    /// messages this side never sent, from before a rebase, is void).
    pub fn on_ack(&mut self, upto: u32) {
        if upto >= self.next_seq {
            return;
        }
        self.log.retain(|(seq, _)| *seq > upto);
        self.sent = self.sent.max(upto);
    }

    /// The receiver (re)started with every message up to `received` applied: what came after
    /// goes again. When that cannot be (it has applied messages this side never sent, or lacks
    /// ones this side no longer keeps), the messages kept are dropped, the next transmission
    /// starts with a [`Wire::Rebase`], and this returns true: the sender must bring the
    /// receiver up to date another way.
    pub fn on_resume(&mut self, received: u32) -> bool {
        let last = self.next_seq.wrapping_sub(1);
        let oldest_kept = self.log.first().map_or(self.next_seq, |(seq, _)| *seq);
        if received > last || received.wrapping_add(1) < oldest_kept {
            self.log.clear();
            self.sent = last;
            self.rebase = Some(self.next_seq);
            self.rebases = self.rebases.saturating_add(1);
            return true;
        }
        self.log.retain(|(seq, _)| *seq > received);
        let again = self.log.iter().filter(|(seq, _)| *seq <= self.sent).count();
        self.resent = self
            .resent
            .saturating_add(u32::try_from(again).unwrap_or(u32::MAX));
        self.sent = received;
        false
    }

    /// Whether messages were kept since this side's last checkpoint (they cannot go before
    /// the next one).
    pub fn awaits_checkpoint(&self) -> bool {
        self.log.iter().any(|(seq, _)| *seq > self.sendable)
    }

    /// This side was restored: whatever was in the ports is gone, so every message kept goes
    /// again (the receiver drops those it has).
    pub fn after_restore(&mut self) {
        let again = self.log.iter().filter(|(seq, _)| *seq <= self.sent).count();
        self.resent = self
            .resent
            .saturating_add(u32::try_from(again).unwrap_or(u32::MAX));
        self.sent = self
            .log
            .first()
            .map_or(self.sent, |(seq, _)| seq.wrapping_sub(1));
        self.checkpointed();
    }

    /// This side's checkpoint now holds every message kept: they may go.
    pub fn checkpointed(&mut self) {
        self.sendable = self.next_seq.wrapping_sub(1);
    }

    /// Hands the messages not sent yet that a checkpoint holds to `send`, in order, until it
    /// refuses one (a full port: the rest go at the next call).
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<T>) -> bool) {
        if let Some(next) = self.rebase {
            if !send(Wire::Rebase { next }) {
                return;
            }
            self.rebase = None;
        }
        for (seq, message) in &self.log {
            let seq = *seq;
            if seq <= self.sent {
                continue;
            }
            if seq > self.sendable {
                return;
            }
            if !send(Wire::Message {
                seq,
                message: message.clone(),
            }) {
                return;
            }
            self.sent = seq;
        }
    }
}

/// The receiving end of one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Inbox {
    /// Every message up to this number has been applied.
    pub received: u32,
    /// The last number acknowledged. Not saved: a restored side acknowledges again.
    #[serde(skip)]
    acknowledged: u32,
    /// Every message up to this number was applied when this side's last checkpoint was
    /// taken: the most that may be acknowledged. Not saved: a restored state is a
    /// checkpointed one.
    #[serde(skip)]
    checkpointed: u32,
    /// Messages dropped as already applied (sent again after a restore).
    pub duplicates: u32,
    /// Messages dropped because one before them is missing (they come again in order).
    pub out_of_order: u32,
}

impl Inbox {
    /// Whether message `seq` is the next one (apply it); counts the others.
    pub fn accept(&mut self, seq: u32) -> bool {
        if seq == self.received.wrapping_add(1) {
            self.received = seq;
            true
        } else {
            if seq <= self.received {
                self.duplicates = self.duplicates.saturating_add(1);
            } else {
                self.out_of_order = self.out_of_order.saturating_add(1);
            }
            false
        }
    }

    /// This side's checkpoint now holds every message applied.
    pub fn checkpointed(&mut self) {
        self.checkpointed = self.received;
    }

    /// The sender declared the messages before `next` void ([`Wire::Rebase`]).
    pub fn rebase(&mut self, next: u32) {
        self.received = next.wrapping_sub(1);
        // Nothing before `next` is to be acknowledged any more.
        self.checkpointed = self.received;
        self.acknowledged = self.received;
    }

    /// The acknowledgement to send, if there is a new one: up to what the last checkpoint
    /// holds.
    pub fn ack(&mut self) -> Option<u32> {
        (self.checkpointed != self.acknowledged).then(|| {
            self.acknowledged = self.checkpointed;
            self.checkpointed
        })
    }
}

/// Why a side could not be restored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SideRestoreError {
    /// No whole record in the area.
    NoRecord,
    /// The newest whole record did not decode or validate.
    BadPayload,
}

/// A network image on its way from the executive to the planner.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
struct Transfer {
    len: u32,
    /// Bytes put in the channel so far.
    pushed: u32,
    crc: u32,
    begun: bool,
}

/// Everything in the executive partition: the control loop, its copy of the network, and its
/// ends of the two ports.
#[derive(Clone, Debug)]
pub struct ExecutivePartition {
    network: TaskNetwork,
    control: ControlLoop,
    now: MissionTimeUs,
    frame: u32,
    loaded: bool,
    restored: Option<u32>,
    /// Generation of the loaded network (0: none).
    generation: u32,
    /// The network image being streamed to the planner.
    transfer: Option<Transfer>,
    to_planner: Outbox<PlannerInput, MAX_TO_PLANNER_IN_FLIGHT>,
    from_planner: Inbox,
    /// Tell the planner what we have applied (after a restore).
    resume: bool,
    /// The planner's last status.
    status: Option<PlannerStatus>,
    /// Planner telemetry received, for the host at the next second window.
    telemetry: Vec<TelemetryEvent, MAX_FORWARDED_TELEMETRY>,
    /// The loaded network's image (not saved: encoded again from the network after a restore).
    image: [u8; MAX_NETWORK_IMAGE],
    image_len: usize,
    pub stats: ExecutivePartitionStats,
}

/// Counts of what the executive partition dropped or refused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExecutivePartitionStats {
    /// Commits planned for a network that is no longer loaded.
    pub stale_commits: u32,
    /// Planner telemetry lost because the forwarding buffer was full.
    pub telemetry_dropped: u32,
    /// Times the planner came up without the checkpoint matching ours and was sent the
    /// network again.
    pub resyncs: u32,
}

#[derive(Serialize, Deserialize)]
struct ExecutiveMeta {
    loaded: bool,
    now: MissionTimeUs,
    frame: u32,
    generation: u32,
    transfer: Option<Transfer>,
    state_type_mismatches: u32,
    last_state_type_mismatch: Option<StateKey>,
    stats: ExecutivePartitionStats,
}

impl Default for ExecutivePartition {
    fn default() -> Self {
        Self::new()
    }
}

const EMPTY_INBOX: Inbox = Inbox {
    received: 0,
    acknowledged: 0,
    checkpointed: 0,
    duplicates: 0,
    out_of_order: 0,
};

impl ExecutivePartition {
    pub const fn new() -> Self {
        Self {
            network: TaskNetwork::EMPTY,
            control: ControlLoop::new(),
            now: MissionTimeUs::ZERO,
            frame: 0,
            loaded: false,
            restored: None,
            generation: 0,
            transfer: None,
            to_planner: Outbox::new(),
            from_planner: EMPTY_INBOX,
            // A side that starts says where it stands, restored or not.
            resume: true,
            status: None,
            telemetry: Vec::new(),
            image: [0; MAX_NETWORK_IMAGE],
            image_len: 0,
            stats: ExecutivePartitionStats {
                stale_commits: 0,
                telemetry_dropped: 0,
                resyncs: 0,
            },
        }
    }

    pub fn control(&self) -> &ControlLoop {
        &self.control
    }

    pub fn network(&self) -> &TaskNetwork {
        &self.network
    }

    pub fn to_planner(&self) -> &Outbox<PlannerInput, MAX_TO_PLANNER_IN_FLIGHT> {
        &self.to_planner
    }

    pub fn from_planner(&self) -> &Inbox {
        &self.from_planner
    }

    /// Mission time of the last first window.
    pub fn now(&self) -> MissionTimeUs {
        self.now
    }

    /// The frame of the last first window.
    pub fn frame(&self) -> u32 {
        self.frame
    }

    /// Whether a network is loaded.
    pub fn loaded(&self) -> bool {
        self.loaded
    }

    /// The planner's last status.
    pub fn planner_status(&self) -> Option<PlannerStatus> {
        self.status
    }

    /// Whether the network image is still on its way to the planner.
    pub fn transferring(&self) -> bool {
        self.transfer.is_some()
    }

    /// Validates and loads an uplinked network (as [`crate::Autonomy::load_uplink`]) and
    /// starts streaming it to the planner. Refused while the executive owns tasks, and while
    /// the previous network is still on its way.
    pub fn load_uplink(&mut self, bytes: &[u8]) -> Result<(), LoadError> {
        uplink::validate_uplink(bytes).map_err(LoadError::Invalid)?;
        if !self.control.executive.entries().is_empty() || self.transfer.is_some() {
            return Err(LoadError::Busy);
        }
        let image = self
            .image
            .get_mut(..bytes.len())
            .ok_or(LoadError::TooLarge)?;
        uplink::decode_into(&mut self.network, bytes).map_err(LoadError::Invalid)?;
        image.copy_from_slice(bytes);
        self.image_len = bytes.len();
        self.after_load();
        Ok(())
    }

    /// Loads a network (see [`ExecutivePartition::load_uplink`]).
    pub fn load_network(&mut self, network: &TaskNetwork) -> Result<(), LoadError> {
        if !self.control.executive.entries().is_empty() || self.transfer.is_some() {
            return Err(LoadError::Busy);
        }
        let len = network
            .encode(&mut self.image)
            .map_err(|_| LoadError::TooLarge)?;
        self.network = network.clone();
        self.image_len = len;
        self.after_load();
        Ok(())
    }

    fn after_load(&mut self) {
        self.loaded = true;
        self.generation = self.generation.wrapping_add(1).max(1);
        let image = self.image.get(..self.image_len).unwrap_or(&[]);
        self.transfer = Some(Transfer {
            len: u32::try_from(image.len()).unwrap_or(u32::MAX),
            pushed: 0,
            crc: CRC32.checksum(image),
            begun: false,
        });
        self.pump();
    }

    /// Puts the next part of the network image in the channel; after its end, what the state
    /// buffer already told us.
    fn pump(&mut self) {
        let Some(mut t) = self.transfer else {
            return;
        };
        if !t.begun {
            if !self.to_planner.push(PlannerInput::NetworkBegin {
                generation: self.generation,
                len: t.len,
            }) {
                return;
            }
            t.begun = true;
        }
        let mut chunks = 0;
        while t.pushed < t.len && chunks < MAX_CHUNKS_PER_FRAME && self.to_planner.room() > 16 {
            let start = t.pushed as usize;
            let end = (start + NETWORK_CHUNK_BYTES).min(t.len as usize);
            let bytes = self
                .image
                .get(start..end)
                .and_then(|b| Vec::from_slice(b).ok())
                .unwrap_or_default();
            self.to_planner.push(PlannerInput::NetworkChunk {
                offset: t.pushed,
                bytes,
            });
            t.pushed = end as u32;
            chunks += 1;
        }
        if t.pushed >= t.len
            && self.to_planner.push(PlannerInput::NetworkEnd {
                generation: self.generation,
                crc: t.crc,
            })
        {
            self.transfer = None;
            let Self {
                network,
                control,
                to_planner,
                ..
            } = self;
            control.after_load(network, &mut |m| {
                to_planner.push(PlannerInput::Core(m));
            });
            return;
        }
        self.transfer = Some(t);
    }

    /// A state-buffer value from the host (see [`crate::Autonomy::on_state_update`]).
    pub fn on_state_update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        if at.0 > MAX_MISSION_TIME_US || self.transfer.is_some() {
            // During a transfer the table still takes it; the planner hears it after the end.
            if at.0 <= MAX_MISSION_TIME_US {
                let _ = self.control.states.update(key, value, at);
            }
            return;
        }
        let Self {
            network,
            control,
            to_planner,
            ..
        } = self;
        control.on_state_update(network, key, value, at, &mut |m| {
            to_planner.push(PlannerInput::Core(m));
        });
    }

    pub fn on_command_response(&mut self, id: u32, status: CommandStatus) {
        self.control.executive.on_command_response(id, status);
    }

    /// Takes what the planner partition sent.
    pub fn receive(&mut self, wire: Wire<ExecutiveInput>) {
        match wire {
            Wire::Message { seq, message } => {
                if self.from_planner.accept(seq) {
                    self.apply(message);
                }
            }
            Wire::Ack { upto } => self.to_planner.on_ack(upto),
            Wire::Resume { received } => {
                if self.to_planner.on_resume(received) {
                    self.resynchronise();
                }
            }
            Wire::Rebase { next } => self.from_planner.rebase(next),
        }
    }

    /// The planner lost what the channel built on (it came up without the checkpoint that
    /// matches ours): it gets the network again, under a new generation (so nothing it
    /// committed before counts), then what the state buffer says, then the frame in
    /// progress. The tasks the executive holds run on; the planner, planning afresh from
    /// the network's requested tasks, may plan one of them again.
    fn resynchronise(&mut self) {
        self.stats.resyncs = self.stats.resyncs.saturating_add(1);
        if !self.loaded {
            return;
        }
        self.status = None;
        self.generation = self.generation.wrapping_add(1).max(1);
        let image = self.image.get(..self.image_len).unwrap_or(&[]);
        self.transfer = Some(Transfer {
            len: u32::try_from(image.len()).unwrap_or(u32::MAX),
            pushed: 0,
            crc: CRC32.checksum(image),
            begun: false,
        });
        self.pump();
        if self.frame != 0 {
            self.to_planner.push(PlannerInput::Frame {
                frame: self.frame,
                now: self.now,
            });
        }
    }

    /// Whether messages wait for a checkpoint before they can go to the planner.
    pub fn awaits_checkpoint(&self) -> bool {
        self.to_planner.awaits_checkpoint()
    }

    fn apply(&mut self, message: ExecutiveInput) {
        match message {
            ExecutiveInput::Commit { generation, commit } => {
                if generation != self.generation {
                    self.stats.stale_commits = self.stats.stale_commits.saturating_add(1);
                    return;
                }
                self.accept(commit);
            }
            ExecutiveInput::Telemetry(event) => {
                if self.telemetry.push(event).is_err() {
                    self.stats.telemetry_dropped = self.stats.telemetry_dropped.saturating_add(1);
                }
            }
            ExecutiveInput::Status(status) => self.status = Some(status),
        }
    }

    fn accept(&mut self, commit: Commit) {
        let Self {
            control,
            to_planner,
            ..
        } = self;
        control.accept(commit, &mut |m| {
            to_planner.push(PlannerInput::Core(m));
        });
    }

    /// The executive's first window of frame `frame` at `now`: the restart adjustments after a
    /// restore, the ages of measured values, the first executive pass, the next part of a
    /// network transfer, and the frame for the planner.
    pub fn first_window(&mut self, frame: u32, now: MissionTimeUs, out: &mut impl Outputs) {
        let now = MissionTimeUs(now.0.min(MAX_MISSION_TIME_US));
        self.now = now;
        self.frame = frame;
        self.pump();
        let transferring = self.transfer.is_some();
        let Self {
            network,
            control,
            to_planner,
            ..
        } = self;
        let mut to_planner = |m| {
            if !transferring {
                to_planner.push(PlannerInput::Core(m));
            }
        };
        if let Some(seq) = self.restored.take() {
            out.telemetry(crate::autonomy::restored_event(seq, now));
            control.after_reset_values(network, now, &mut to_planner);
        }
        if self.loaded {
            control.judge_ages(network, now, out, &mut to_planner);
            control.step(network, now, out, &mut to_planner);
        }
        self.to_planner.push(PlannerInput::Frame { frame, now });
    }

    /// The executive's second window: the planner's telemetry for the host, then the second
    /// executive pass (the commits were taken as they arrived).
    pub fn second_window(&mut self, out: &mut impl Outputs) {
        for event in core::mem::take(&mut self.telemetry) {
            out.telemetry(event);
        }
        if !self.loaded {
            return;
        }
        let Self {
            network,
            control,
            to_planner,
            now,
            ..
        } = self;
        control.step(network, *now, out, &mut |m| {
            to_planner.push(PlannerInput::Core(m));
        });
    }

    /// Whether the planner has answered this frame.
    pub fn planner_answered(&self) -> bool {
        self.status.is_some_and(|s| s.frame == self.frame)
    }

    /// After this side's checkpoint: what goes to the planner's port, in order (a `Resume`
    /// after a restore, the acknowledgement, then the messages not sent yet), until `send`
    /// refuses one.
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<PlannerInput>) -> bool) {
        transmit(
            &mut self.resume,
            &mut self.from_planner,
            &mut self.to_planner,
            send,
        );
    }

    /// When the host must grant next, after this frame's second window: one major frame on
    /// while the planner has work pending or the network is on its way, else the earliest
    /// need of either side.
    pub fn next_wakeup(&self) -> Option<MissionTimeUs> {
        if !self.loaded {
            return None;
        }
        let status = self.status.filter(|s| s.frame == self.frame);
        if status.is_none_or(|s| s.pending) || self.transfer.is_some() {
            return Some(MissionTimeUs(self.now.0.saturating_add(MAJOR_FRAME_US)));
        }
        if self.control.executive.work_pending() || self.restored.is_some() {
            return Some(self.now);
        }
        let own = self.control.next_wakeup(&self.network, self.now);
        [own, status.and_then(|s| s.next_wakeup)]
            .into_iter()
            .flatten()
            .min()
    }

    /// Encodes this side's whole state (the checkpoint payload).
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let meta = ExecutiveMeta {
            loaded: self.loaded,
            now: self.now,
            frame: self.frame,
            generation: self.generation,
            transfer: self.transfer,
            state_type_mismatches: self.control.state_type_mismatches,
            last_state_type_mismatch: self.control.last_state_type_mismatch,
            stats: self.stats,
        };
        let mut len = postcard::to_slice(&meta, buf).ok()?.len();
        len += encode_network(&self.network, buf.get_mut(len..)?)?;
        len += postcard::to_slice(&self.control.executive, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.control.states, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.to_planner, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.from_planner, buf.get_mut(len..)?)
            .ok()?
            .len();
        Some(len)
    }

    /// This side's checkpoint now holds its whole state (a caller that writes the checkpoint
    /// itself, from [`ExecutivePartition::encode_state`], says so): the messages kept may go,
    /// the messages applied may be acknowledged.
    pub fn checkpointed(&mut self) {
        self.to_planner.checkpointed();
        self.from_planner.checkpointed();
    }

    /// Restores this side from one record the caller found whole (its CRC is not checked
    /// again), then prepares the restart: tasks whose command was out are interrupted, command
    /// ids skip ahead, the `Restored` event and the after-reset values come at the next first
    /// window, every message not acknowledged goes again, and the planner hears what we have
    /// applied. On error this side is a cold, empty one. (From an area:
    /// [`PartitionSide::restore_from`].)
    pub fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, SideRestoreError> {
        let Record {
            slot,
            sequence,
            payload,
        } = record;
        if self.decode_state(payload).is_none() {
            self.reset();
            return Err(SideRestoreError::BadPayload);
        }
        self.control.executive.after_restore();
        self.to_planner.after_restore();
        self.from_planner.checkpointed();
        self.restored = Some(sequence);
        self.resume = true;
        Ok(RestoreInfo {
            slot,
            sequence,
            payload_len: u32::try_from(payload.len()).unwrap_or(u32::MAX),
        })
    }

    /// Makes this side what [`ExecutivePartition::new`] is, in place.
    pub fn reset(&mut self) {
        self.network.clear();
        self.control.reset();
        self.now = MissionTimeUs::ZERO;
        self.frame = 0;
        self.loaded = false;
        self.restored = None;
        self.generation = 0;
        self.transfer = None;
        self.to_planner = Outbox::new();
        self.from_planner = EMPTY_INBOX;
        self.resume = true;
        self.status = None;
        self.telemetry.clear();
        self.image_len = 0;
        self.stats = ExecutivePartitionStats::default();
    }

    /// Replaces the state with one [`ExecutivePartition::encode_state`] wrote, checked as a
    /// restored checkpoint is (no restart adjustments: [`ExecutivePartition::restore_record`]
    /// adds them). None when refused; the state may then be partly overwritten.
    pub fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        let (meta, rest): (ExecutiveMeta, _) = postcard::take_from_bytes(payload).ok()?;
        let rest = decode_network(&mut self.network, rest)?;
        let rest = in_place::take_in_place(rest, ExecutiveInPlace(&mut self.control.executive))?;
        let rest = in_place::take_in_place(rest, StateTableInPlace(&mut self.control.states))?;
        let (to_planner, rest) = postcard::take_from_bytes(rest).ok()?;
        let (from_planner, rest) = postcard::take_from_bytes(rest).ok()?;
        if !rest.is_empty() {
            return None;
        }
        checkpoint::check_executive_restored(
            meta.loaded,
            meta.now,
            &self.network,
            &self.control.executive,
            &self.control.states,
        )
        .ok()?;
        // The image streamed to the planner, again from the network.
        self.image_len = self.network.encode(&mut self.image).ok()?;
        self.control.state_type_mismatches = meta.state_type_mismatches;
        self.control.last_state_type_mismatch = meta.last_state_type_mismatch;
        self.to_planner = to_planner;
        self.from_planner = from_planner;
        self.loaded = meta.loaded;
        self.now = meta.now;
        self.frame = meta.frame;
        self.generation = meta.generation;
        self.transfer = meta.transfer;
        self.stats = meta.stats;
        Some(())
    }
}

/// Everything in the planner partition: the planner, its copy of the network, and its ends of
/// the two ports.
#[derive(Clone, Debug)]
pub struct PlannerPartition {
    network: TaskNetwork,
    planner: Planner,
    now: MissionTimeUs,
    loaded: bool,
    /// Generation of the loaded network.
    generation: u32,
    /// The frame to plan for (received, not planned yet).
    frame: Option<(u32, MissionTimeUs)>,
    /// A network image being received: (generation, length, bytes so far); the bytes are in
    /// `image`.
    assembly: Option<(u32, u32, u32)>,
    image: [u8; MAX_NETWORK_IMAGE],
    to_executive: Outbox<ExecutiveInput, MAX_TO_EXECUTIVE_IN_FLIGHT>,
    from_executive: Inbox,
    resume: bool,
    /// Network images refused (bad CRC, bad length, failed validation).
    pub refused_networks: u32,
}

#[derive(Serialize, Deserialize)]
struct PlannerMeta {
    loaded: bool,
    now: MissionTimeUs,
    generation: u32,
    frame: Option<(u32, MissionTimeUs)>,
    assembly: Option<(u32, u32, u32)>,
    refused_networks: u32,
}

impl Default for PlannerPartition {
    fn default() -> Self {
        Self::new()
    }
}

/// Sends the planner's decisions to the executive through the channel.
struct Forward<'a> {
    outbox: &'a mut Outbox<ExecutiveInput, MAX_TO_EXECUTIVE_IN_FLIGHT>,
}

impl Outputs for Forward<'_> {
    fn dispatch(&mut self, _id: u32, _opcode: Opcode, _args: &CommandArgs) {
        // The planner dispatches nothing; only the executive commands subsystems.
    }

    fn telemetry(&mut self, event: TelemetryEvent) {
        self.outbox.push(ExecutiveInput::Telemetry(event));
    }
}

impl PlannerPartition {
    pub const fn new() -> Self {
        Self {
            network: TaskNetwork::EMPTY,
            planner: Planner::new(),
            now: MissionTimeUs::ZERO,
            loaded: false,
            generation: 0,
            frame: None,
            assembly: None,
            image: [0; MAX_NETWORK_IMAGE],
            to_executive: Outbox::new(),
            from_executive: EMPTY_INBOX,
            resume: true,
            refused_networks: 0,
        }
    }

    /// Makes this side what [`PlannerPartition::new`] is, in place.
    pub fn reset(&mut self) {
        self.network.clear();
        self.planner.reset();
        self.now = MissionTimeUs::ZERO;
        self.loaded = false;
        self.generation = 0;
        self.frame = None;
        self.assembly = None;
        self.to_executive = Outbox::new();
        self.from_executive = EMPTY_INBOX;
        self.resume = true;
        self.refused_networks = 0;
    }

    pub fn planner(&self) -> &Planner {
        &self.planner
    }

    /// Whether a network is loaded.
    pub fn loaded(&self) -> bool {
        self.loaded
    }

    /// Whether the executive's frame has come and the window has not run yet.
    pub fn frame_pending(&self) -> bool {
        self.frame.is_some()
    }

    /// Whether the channel holds messages for the executive not sent yet.
    pub fn unsent(&self) -> usize {
        self.to_executive.unsent()
    }

    pub fn network(&self) -> &TaskNetwork {
        &self.network
    }

    pub fn to_executive(&self) -> &Outbox<ExecutiveInput, MAX_TO_EXECUTIVE_IN_FLIGHT> {
        &self.to_executive
    }

    pub fn from_executive(&self) -> &Inbox {
        &self.from_executive
    }

    /// Takes what the executive partition sent.
    pub fn receive(&mut self, wire: Wire<PlannerInput>) {
        match wire {
            Wire::Message { seq, message } => {
                if self.from_executive.accept(seq) {
                    self.apply(message);
                }
            }
            Wire::Ack { upto } => self.to_executive.on_ack(upto),
            Wire::Resume { received } => {
                // What the planner sent before is void for an executive that lost it; the
                // executive brings the planner up to date (see
                // `ExecutivePartition::resynchronise`).
                let _ = self.to_executive.on_resume(received);
            }
            Wire::Rebase { next } => {
                self.from_executive.rebase(next);
                // What comes next is a new network: the old plan is void.
                self.loaded = false;
                self.planner.reset();
            }
        }
    }

    fn apply(&mut self, message: PlannerInput) {
        match message {
            PlannerInput::Core(m) => {
                if self.loaded {
                    self.planner.receive(m);
                }
            }
            PlannerInput::Frame { frame, now } => self.frame = Some((frame, now)),
            PlannerInput::NetworkBegin { generation, len } => {
                // The plan of the old network is void from here.
                self.loaded = false;
                self.planner.reset();
                self.network.clear();
                self.assembly = (len as usize <= MAX_NETWORK_IMAGE).then_some((generation, len, 0));
                if self.assembly.is_none() {
                    self.refused_networks = self.refused_networks.saturating_add(1);
                }
            }
            PlannerInput::NetworkChunk { offset, bytes } => {
                let Some((generation, len, got)) = self.assembly else {
                    return;
                };
                let end = offset as usize + bytes.len();
                match self.image.get_mut(offset as usize..end) {
                    Some(dst) if offset == got && end <= len as usize => {
                        dst.copy_from_slice(&bytes);
                        self.assembly = Some((generation, len, end as u32));
                    }
                    _ => {
                        self.assembly = None;
                        self.refused_networks = self.refused_networks.saturating_add(1);
                    }
                }
            }
            PlannerInput::NetworkEnd { generation, crc } => {
                let Some((g, len, got)) = self.assembly.take() else {
                    return;
                };
                let image = self.image.get(..len as usize).unwrap_or(&[]);
                let whole = g == generation && got == len && CRC32.checksum(image) == crc;
                if whole && uplink::decode_then_validate(&mut self.network, image).is_ok() {
                    self.planner.load(&self.network);
                    self.generation = generation;
                    self.loaded = true;
                } else {
                    self.network.clear();
                    self.refused_networks = self.refused_networks.saturating_add(1);
                }
            }
        }
    }

    /// The planner's window: if the executive's frame has come, planning within `budget`
    /// validity checks at the frame's time, then the commits (no more than the channel's log
    /// has room for), then the status. The planner's decisions go to the executive.
    pub fn window(&mut self, budget: u32) -> Option<PlannerStatus> {
        let (frame, now) = self.frame.take()?;
        let now = MissionTimeUs(now.0.min(MAX_MISSION_TIME_US));
        self.now = now;
        let mut status = PlannerStatus {
            frame,
            ..PlannerStatus::default()
        };
        if self.loaded {
            let Self {
                network,
                planner,
                to_executive,
                generation,
                ..
            } = self;
            let mut commits: Vec<Commit, MAX_COMMITTED> = Vec::new();
            let mut refused: Vec<u16, MAX_COMMITTED> = Vec::new();
            let report = planner.step(
                network,
                now,
                budget,
                &mut |c| {
                    if commits.push(c).is_err() {
                        let _ = refused.push(c.instance);
                    }
                },
                &mut Forward {
                    outbox: to_executive,
                },
            );
            // Room for the status is kept.
            for c in commits {
                if to_executive.room() > 1
                    && to_executive.push(ExecutiveInput::Commit {
                        generation: *generation,
                        commit: c,
                    })
                {
                    status.commits += 1;
                } else {
                    let _ = refused.push(c.instance);
                }
            }
            for instance in refused {
                planner.on_returned(instance);
            }
            status.pending = report.work_pending;
            status.cycle_latency_us = report.cycle_latency_us;
            status.checks = report.checks;
            status.next_wakeup = planner.next_wakeup(network, now);
        }
        self.to_executive.push(ExecutiveInput::Status(status));
        Some(status)
    }

    /// After this side's checkpoint: a `Resume` after a restore, the acknowledgement, then
    /// what was not sent yet, until `send` refuses one.
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<ExecutiveInput>) -> bool) {
        transmit(
            &mut self.resume,
            &mut self.from_executive,
            &mut self.to_executive,
            send,
        );
    }

    /// Encodes this side's whole state (the checkpoint payload): with a network image in
    /// progress, the part received so far.
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let meta = PlannerMeta {
            loaded: self.loaded,
            now: self.now,
            generation: self.generation,
            frame: self.frame,
            assembly: self.assembly,
            refused_networks: self.refused_networks,
        };
        let mut len = postcard::to_slice(&meta, buf).ok()?.len();
        if let Some((_, _, got)) = self.assembly {
            let part = self.image.get(..got as usize)?;
            buf.get_mut(len..len + part.len())?.copy_from_slice(part);
            len += part.len();
        }
        len += encode_network(&self.network, buf.get_mut(len..)?)?;
        len += postcard::to_slice(&self.planner, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.to_executive, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.from_executive, buf.get_mut(len..)?)
            .ok()?
            .len();
        Some(len)
    }

    /// This side's checkpoint now holds its whole state: see
    /// [`ExecutivePartition::checkpointed`].
    pub fn checkpointed(&mut self) {
        self.to_executive.checkpointed();
        self.from_executive.checkpointed();
    }

    /// Restores this side from one record the caller found whole (its CRC is not checked
    /// again): every message not acknowledged goes again, the executive hears what we have
    /// applied, and a new cycle starts (the state may have changed while the target was down).
    /// On error this side is a cold, empty one. (From an area:
    /// [`PartitionSide::restore_from`].)
    pub fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, SideRestoreError> {
        let Record {
            slot,
            sequence,
            payload,
        } = record;
        if self.decode_state(payload).is_none() {
            self.reset();
            return Err(SideRestoreError::BadPayload);
        }
        self.planner.after_restore();
        self.to_executive.after_restore();
        self.from_executive.checkpointed();
        self.resume = true;
        Ok(RestoreInfo {
            slot,
            sequence,
            payload_len: u32::try_from(payload.len()).unwrap_or(u32::MAX),
        })
    }

    /// Replaces the state with one [`PlannerPartition::encode_state`] wrote, checked as a
    /// restored checkpoint is (no restart adjustments). None when refused.
    pub fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        let (meta, mut rest): (PlannerMeta, _) = postcard::take_from_bytes(payload).ok()?;
        if let Some((_, len, got)) = meta.assembly {
            if got > len || len as usize > MAX_NETWORK_IMAGE {
                return None;
            }
            let part = rest.get(..got as usize)?;
            self.image.get_mut(..part.len())?.copy_from_slice(part);
            rest = rest.get(got as usize..)?;
        }
        let rest = decode_network(&mut self.network, rest)?;
        let rest = in_place::take_in_place(rest, PlannerInPlace(&mut self.planner))?;
        let (to_executive, rest) = postcard::take_from_bytes(rest).ok()?;
        let (from_executive, rest) = postcard::take_from_bytes(rest).ok()?;
        if !rest.is_empty() {
            return None;
        }
        checkpoint::check_planner_restored(meta.loaded, meta.now, &self.network, &self.planner)
            .ok()?;
        self.to_executive = to_executive;
        self.from_executive = from_executive;
        self.loaded = meta.loaded;
        self.now = meta.now;
        self.generation = meta.generation;
        self.frame = meta.frame;
        self.assembly = meta.assembly;
        self.refused_networks = meta.refused_networks;
        Some(())
    }
}

/// What both sides do with their checkpoints.
pub trait PartitionSide {
    /// The whole state as a checkpoint payload.
    fn encode_state(&self, buf: &mut [u8]) -> Option<usize>;
    /// The checkpoint now holds the whole state: what it kept may go, what it applied may be
    /// acknowledged.
    fn checkpointed(&mut self);
    /// Restores from one whole record (see each side's `restore_record`).
    fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, SideRestoreError>;

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
    fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, SideRestoreError> {
        ExecutivePartition::restore_record(self, record)
    }
}

impl PartitionSide for PlannerPartition {
    fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        PlannerPartition::encode_state(self, buf)
    }
    fn checkpointed(&mut self) {
        PlannerPartition::checkpointed(self)
    }
    fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, SideRestoreError> {
        PlannerPartition::restore_record(self, record)
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

/// The network in uplink format behind a 4-byte length.
fn encode_network(network: &TaskNetwork, buf: &mut [u8]) -> Option<usize> {
    let body = buf.get_mut(4..)?;
    let n = network.encode(body).ok()?;
    buf.get_mut(..4)?
        .copy_from_slice(&u32::try_from(n).ok()?.to_be_bytes());
    Some(4 + n)
}

/// Decodes and validates what [`encode_network`] wrote into `network`; the bytes after it.
fn decode_network<'a>(network: &mut TaskNetwork, bytes: &'a [u8]) -> Option<&'a [u8]> {
    let n = usize::try_from(u32::from_be_bytes(bytes.get(..4)?.try_into().ok()?)).ok()?;
    let body = bytes.get(4..)?.get(..n)?;
    uplink::decode_then_validate(network, body).ok()?;
    bytes.get(4 + n..)
}

/// What one frame of the two partitions did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Frame {
    /// When the host must grant next (if no input arrives first): see
    /// [`ExecutivePartition::next_wakeup`].
    pub next_wakeup: Option<MissionTimeUs>,
    /// The planner's window.
    pub planner: PlannerStatus,
}

/// Which partition a checkpoint belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Executive,
    Planner,
}

/// The points of a frame at which [`FrameEnv::proceed`] is asked whether to go on (a test
/// resets there): after each window's work, after each checkpoint, after each transmission.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Point {
    ExecutiveFirstWindow,
    ExecutiveFirstCheckpoint,
    ExecutiveFirstSent,
    PlannerWindow,
    PlannerCheckpoint,
    PlannerSent,
    ExecutiveSecondWindow,
    ExecutiveSecondCheckpoint,
    ExecutiveSecondSent,
}

impl Point {
    pub const ALL: [Point; 9] = [
        Point::ExecutiveFirstWindow,
        Point::ExecutiveFirstCheckpoint,
        Point::ExecutiveFirstSent,
        Point::PlannerWindow,
        Point::PlannerCheckpoint,
        Point::PlannerSent,
        Point::ExecutiveSecondWindow,
        Point::ExecutiveSecondCheckpoint,
        Point::ExecutiveSecondSent,
    ];
}

/// Where a frame's checkpoints go, and whether it goes on at each [`Point`].
pub trait FrameEnv {
    /// Write `side`'s checkpoint (`executive` or `planner`, whichever `side` names: its
    /// `encode_state`). False: the write did not complete (a reset tore it); the frame stops
    /// there. True: [`run_frame`] marks the side checkpointed.
    fn checkpoint(
        &mut self,
        side: Side,
        executive: &ExecutivePartition,
        planner: &PlannerPartition,
    ) -> bool;
    /// Whether the frame goes on after `point` (false: a reset came).
    fn proceed(&mut self, point: Point) -> bool {
        let _ = point;
        true
    }
}

/// The frame stopped at a reset, after this point (or in the checkpoint after it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Interrupted(pub Point);

/// Runs frame `frame` of both partitions at `now` with `planner_budget` validity checks for
/// the planner's window, handing the ports' messages over as the kernel does (what a window
/// sends is in the port at the start of the other side's next window; a port never refuses
/// here: the outboxes are the bound). The decisions go to `out` in the order the windows run
/// (the planner's at the start of the executive's second window). Each window ends with its
/// side's checkpoint, then its transmission.
pub fn run_frame(
    executive: &mut ExecutivePartition,
    planner: &mut PlannerPartition,
    frame: u32,
    now: MissionTimeUs,
    planner_budget: u32,
    out: &mut impl Outputs,
    env: &mut impl FrameEnv,
) -> Result<Frame, Interrupted> {
    let go = |env: &mut dyn FnMut(Point) -> bool, point| {
        if env(point) {
            Ok(())
        } else {
            Err(Interrupted(point))
        }
    };
    executive.first_window(frame, now, out);
    go(&mut |p| env.proceed(p), Point::ExecutiveFirstWindow)?;
    if !env.checkpoint(Side::Executive, executive, planner) {
        return Err(Interrupted(Point::ExecutiveFirstWindow));
    }
    executive.checkpointed();
    go(&mut |p| env.proceed(p), Point::ExecutiveFirstCheckpoint)?;
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    go(&mut |p| env.proceed(p), Point::ExecutiveFirstSent)?;
    let status = planner.window(planner_budget).unwrap_or_default();
    go(&mut |p| env.proceed(p), Point::PlannerWindow)?;
    if !env.checkpoint(Side::Planner, executive, planner) {
        return Err(Interrupted(Point::PlannerWindow));
    }
    planner.checkpointed();
    go(&mut |p| env.proceed(p), Point::PlannerCheckpoint)?;
    planner.transmit(&mut |w| {
        executive.receive(w);
        true
    });
    go(&mut |p| env.proceed(p), Point::PlannerSent)?;
    executive.second_window(out);
    go(&mut |p| env.proceed(p), Point::ExecutiveSecondWindow)?;
    if !env.checkpoint(Side::Executive, executive, planner) {
        return Err(Interrupted(Point::ExecutiveSecondWindow));
    }
    executive.checkpointed();
    go(&mut |p| env.proceed(p), Point::ExecutiveSecondCheckpoint)?;
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    go(&mut |p| env.proceed(p), Point::ExecutiveSecondSent)?;
    Ok(Frame {
        next_wakeup: executive.next_wakeup(),
        planner: status,
    })
}
