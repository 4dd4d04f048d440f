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
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::capacity::{MAX_COMMITTED, MAX_MISSION_TIME_US};
use crate::checkpoint::{CheckpointError, WarmRestartArea, WrittenRecord};
use crate::control::ControlLoop;
use crate::interface::{Commit, Outputs, ToExecutive, ToPlanner};
use crate::model::TaskNetwork;
use crate::planner::Planner;
use crate::telemetry::PlanModificationKind;
use crate::uplink;
use fsw_bridge::{CommandStatus, MissionTimeUs, StateKey, StateValue, TelemetryEvent};

/// One major frame of the partition schedule in mission time (10 ms): how far mission time
/// advances per grant while the planner has work pending.
pub const MAJOR_FRAME_US: u64 = 10_000;
/// Messages the executive keeps for the planner until they are acknowledged (about two
/// frames' worth: a frame's state updates, reports and returned commits).
pub const MAX_TO_PLANNER_IN_FLIGHT: usize = 64;
/// Messages the planner keeps for the executive until they are acknowledged: one commit per
/// task the executive can hold.
pub const MAX_TO_EXECUTIVE_IN_FLIGHT: usize = MAX_COMMITTED;

/// What crosses a port between the two partitions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wire<T> {
    /// Message number `seq` (from 1, in order).
    Message { seq: u32, message: T },
    /// The sender of this has checkpointed every message up to `upto` it received.
    Ack { upto: u32 },
    /// The sender of this was restored and has applied every message up to `received`: send
    /// again what came after.
    Resume { received: u32 },
}

/// The sending end of one direction: every message numbered and kept until acknowledged.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Outbox<T, const N: usize> {
    /// The number the next message gets.
    next_seq: u32,
    /// Messages up to this number have gone to the port (or were acknowledged).
    sent: u32,
    /// Messages not acknowledged yet, oldest first.
    log: Vec<(u32, T), N>,
    /// Messages refused because the log was full (the sender's count of what it lost).
    pub refused: u32,
    /// Messages sent again after the receiver was restored.
    pub resent: u32,
}

impl<T: Copy, const N: usize> Default for Outbox<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy, const N: usize> Outbox<T, N> {
    pub const fn new() -> Self {
        Self {
            next_seq: 1,
            sent: 0,
            log: Vec::new(),
            refused: 0,
            resent: 0,
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

    /// The receiver has checkpointed every message up to `upto`.
    pub fn on_ack(&mut self, upto: u32) {
        self.log.retain(|(seq, _)| *seq > upto);
        self.sent = self.sent.max(upto);
    }

    /// The receiver was restored with every message up to `received` applied: what came after
    /// goes again.
    pub fn on_resume(&mut self, received: u32) {
        self.log.retain(|(seq, _)| *seq > received);
        let again = self.log.iter().filter(|(seq, _)| *seq <= self.sent).count();
        self.resent = self
            .resent
            .saturating_add(u32::try_from(again).unwrap_or(u32::MAX));
        self.sent = received;
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
    }

    /// Hands the messages not sent yet to `send`, in order, until it refuses one (a full
    /// port: the rest go at the next call).
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<T>) -> bool) {
        for &(seq, message) in &self.log {
            if seq <= self.sent {
                continue;
            }
            if !send(Wire::Message { seq, message }) {
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
    /// The last number acknowledged.
    acknowledged: u32,
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

    /// After this side's checkpoint: the acknowledgement to send, if there is a new one.
    pub fn ack(&mut self) -> Option<u32> {
        (self.received != self.acknowledged).then(|| {
            self.acknowledged = self.received;
            self.received
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

/// Everything in the executive partition: the control loop, its copy of the network, and its
/// ends of the two ports.
#[derive(Clone, Debug)]
pub struct ExecutivePartition {
    network: TaskNetwork,
    control: ControlLoop,
    now: MissionTimeUs,
    loaded: bool,
    restored: Option<u32>,
    to_planner: Outbox<ToPlanner, MAX_TO_PLANNER_IN_FLIGHT>,
    from_planner: Inbox,
    /// Tell the planner what we have applied (after a restore).
    resume: bool,
}

#[derive(Serialize, Deserialize)]
struct ExecutiveMeta {
    loaded: bool,
    now: MissionTimeUs,
    state_type_mismatches: u32,
    last_state_type_mismatch: Option<StateKey>,
}

impl Default for ExecutivePartition {
    fn default() -> Self {
        Self::new()
    }
}

impl ExecutivePartition {
    pub const fn new() -> Self {
        Self {
            network: TaskNetwork::EMPTY,
            control: ControlLoop::new(),
            now: MissionTimeUs::ZERO,
            loaded: false,
            restored: None,
            to_planner: Outbox::new(),
            from_planner: Inbox {
                received: 0,
                acknowledged: 0,
                duplicates: 0,
                out_of_order: 0,
            },
            resume: false,
        }
    }

    pub fn control(&self) -> &ControlLoop {
        &self.control
    }

    pub fn network(&self) -> &TaskNetwork {
        &self.network
    }

    pub fn to_planner(&self) -> &Outbox<ToPlanner, MAX_TO_PLANNER_IN_FLIGHT> {
        &self.to_planner
    }

    pub fn from_planner(&self) -> &Inbox {
        &self.from_planner
    }

    /// Loads a network the planner partition loads too (refused while the executive owns
    /// tasks, as [`crate::Autonomy::load_network`]).
    pub fn load_network(&mut self, network: &TaskNetwork) -> Result<(), crate::LoadError> {
        if !self.control.executive.entries().is_empty() {
            return Err(crate::LoadError::Busy);
        }
        self.network = network.clone();
        self.loaded = true;
        let Self {
            network,
            control,
            to_planner,
            ..
        } = self;
        control.after_load(network, &mut |m| {
            to_planner.push(m);
        });
        Ok(())
    }

    /// A state-buffer value from the host (see [`crate::Autonomy::on_state_update`]).
    pub fn on_state_update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        if at.0 > MAX_MISSION_TIME_US {
            return;
        }
        let Self {
            network,
            control,
            to_planner,
            ..
        } = self;
        control.on_state_update(network, key, value, at, &mut |m| {
            to_planner.push(m);
        });
    }

    pub fn on_command_response(&mut self, id: u32, status: CommandStatus) {
        self.control.executive.on_command_response(id, status);
    }

    /// Takes what the planner partition sent.
    pub fn receive(&mut self, wire: Wire<ToExecutive>) {
        match wire {
            Wire::Message { seq, message } => {
                if self.from_planner.accept(seq) {
                    let ToExecutive::Commit(commit) = message;
                    self.accept(commit);
                }
            }
            Wire::Ack { upto } => self.to_planner.on_ack(upto),
            Wire::Resume { received } => self.to_planner.on_resume(received),
        }
    }

    fn accept(&mut self, commit: Commit) {
        let Self {
            control,
            to_planner,
            ..
        } = self;
        control.accept(commit, &mut |m| {
            to_planner.push(m);
        });
    }

    /// The executive's first window of the frame at `now`: the restart adjustments after a
    /// restore, the ages of measured values, the first executive pass.
    pub fn first_window(&mut self, now: MissionTimeUs, out: &mut impl Outputs) {
        let now = MissionTimeUs(now.0.min(MAX_MISSION_TIME_US));
        self.now = now;
        let Self {
            network,
            control,
            to_planner,
            ..
        } = self;
        let mut to_planner = |m| {
            to_planner.push(m);
        };
        if let Some(seq) = self.restored.take() {
            out.telemetry(TelemetryEvent::PlanModification {
                kind: PlanModificationKind::Restored as u8,
                task: 0,
                template: seq as u16,
                at: now,
            });
            control.after_reset_values(network, now, &mut to_planner);
        }
        if !self.loaded {
            return;
        }
        control.judge_ages(network, now, out, &mut to_planner);
        control.step(network, now, out, &mut to_planner);
    }

    /// The executive's second window: the commits the planner sent (already received), and
    /// the second executive pass.
    pub fn second_window(&mut self, out: &mut impl Outputs) {
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
            to_planner.push(m);
        });
    }

    /// After this side's checkpoint: what goes to the planner's port, in order (a `Resume`
    /// after a restore, the acknowledgement, then the messages not sent yet), until `send`
    /// refuses one.
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<ToPlanner>) -> bool) {
        if self.resume {
            if !send(Wire::Resume {
                received: self.from_planner.received,
            }) {
                return;
            }
            self.resume = false;
        }
        if let Some(upto) = self.from_planner.ack() {
            let _ = send(Wire::Ack { upto });
        }
        self.to_planner.transmit(send);
    }

    /// When the control loop needs to run next (its own needs; the frame adds the planner's).
    pub fn next_wakeup(&self) -> Option<MissionTimeUs> {
        if !self.loaded {
            return None;
        }
        if self.control.executive.work_pending() || self.restored.is_some() {
            return Some(self.now);
        }
        self.control.next_wakeup(&self.network, self.now)
    }

    /// Encodes this side's whole state (the checkpoint payload).
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let meta = ExecutiveMeta {
            loaded: self.loaded,
            now: self.now,
            state_type_mismatches: self.control.state_type_mismatches,
            last_state_type_mismatch: self.control.last_state_type_mismatch,
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

    /// Writes this side's checkpoint into its own area.
    pub fn checkpoint_to(
        &self,
        area: &mut WarmRestartArea<'_>,
    ) -> Result<WrittenRecord, CheckpointError> {
        area.write_record(|buf| self.encode_state(buf))
    }

    /// Restores this side from the newest whole record of its area, then prepares the
    /// restart: tasks whose command was out are interrupted, command ids skip ahead, the
    /// `Restored` event and the after-reset values come at the next first window, every
    /// message not acknowledged goes again, and the planner hears what we have applied.
    pub fn restore_from(&mut self, area: &WarmRestartArea<'_>) -> Result<u32, SideRestoreError> {
        let (_, sequence, payload) = area.latest().ok_or(SideRestoreError::NoRecord)?;
        if self.decode_state(payload).is_none() {
            *self = Self::new();
            return Err(SideRestoreError::BadPayload);
        }
        self.control.executive.after_restore();
        self.to_planner.after_restore();
        self.restored = Some(sequence);
        self.resume = true;
        Ok(sequence)
    }

    fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        let (meta, rest): (ExecutiveMeta, _) = postcard::take_from_bytes(payload).ok()?;
        let rest = decode_network(&mut self.network, rest)?;
        let (executive, rest) = postcard::take_from_bytes(rest).ok()?;
        let (states, rest) = postcard::take_from_bytes(rest).ok()?;
        let (to_planner, rest) = postcard::take_from_bytes(rest).ok()?;
        let (from_planner, rest) = postcard::take_from_bytes(rest).ok()?;
        if !rest.is_empty() {
            return None;
        }
        self.control.executive = executive;
        self.control.states = states;
        self.control.state_type_mismatches = meta.state_type_mismatches;
        self.control.last_state_type_mismatch = meta.last_state_type_mismatch;
        self.to_planner = to_planner;
        self.from_planner = from_planner;
        self.loaded = meta.loaded;
        self.now = meta.now;
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
    to_executive: Outbox<ToExecutive, MAX_TO_EXECUTIVE_IN_FLIGHT>,
    from_executive: Inbox,
    resume: bool,
}

#[derive(Serialize, Deserialize)]
struct PlannerMeta {
    loaded: bool,
    now: MissionTimeUs,
}

/// What one planner window did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlannerWindow {
    /// Validity checks spent.
    pub checks: u32,
    /// The cycle stopped on the window's budget: it resumes in the next window.
    pub pending: bool,
    /// A cycle ended in this window this long after the window that started it (mission
    /// time, µs).
    pub cycle_latency_us: Option<u64>,
    /// Commits sent in this window.
    pub commits: u32,
}

impl Default for PlannerPartition {
    fn default() -> Self {
        Self::new()
    }
}

impl PlannerPartition {
    pub const fn new() -> Self {
        Self {
            network: TaskNetwork::EMPTY,
            planner: Planner::new(),
            now: MissionTimeUs::ZERO,
            loaded: false,
            to_executive: Outbox::new(),
            from_executive: Inbox {
                received: 0,
                acknowledged: 0,
                duplicates: 0,
                out_of_order: 0,
            },
            resume: false,
        }
    }

    pub fn planner(&self) -> &Planner {
        &self.planner
    }

    pub fn to_executive(&self) -> &Outbox<ToExecutive, MAX_TO_EXECUTIVE_IN_FLIGHT> {
        &self.to_executive
    }

    pub fn from_executive(&self) -> &Inbox {
        &self.from_executive
    }

    /// Loads the network (the executive partition loads the same one).
    pub fn load_network(&mut self, network: &TaskNetwork) {
        self.network = network.clone();
        self.planner.load(&self.network);
        self.loaded = true;
    }

    /// Takes what the executive partition sent.
    pub fn receive(&mut self, wire: Wire<ToPlanner>) {
        match wire {
            Wire::Message { seq, message } => {
                if self.from_executive.accept(seq) {
                    self.planner.receive(message);
                }
            }
            Wire::Ack { upto } => self.to_executive.on_ack(upto),
            Wire::Resume { received } => self.to_executive.on_resume(received),
        }
    }

    /// The planner's window at `now`: planning within `budget` validity checks, then commits
    /// (no more than the port's log has room for).
    pub fn window(
        &mut self,
        now: MissionTimeUs,
        budget: u32,
        out: &mut impl Outputs,
    ) -> PlannerWindow {
        let now = MissionTimeUs(now.0.min(MAX_MISSION_TIME_US));
        self.now = now;
        if !self.loaded {
            return PlannerWindow::default();
        }
        let Self {
            network,
            planner,
            to_executive,
            ..
        } = self;
        let mut commits = 0u32;
        let mut refused: Vec<u16, MAX_COMMITTED> = Vec::new();
        let report = planner.step(
            network,
            now,
            budget,
            &mut |c| {
                if to_executive.push(ToExecutive::Commit(c)) {
                    commits += 1;
                } else {
                    let _ = refused.push(c.instance);
                }
            },
            out,
        );
        for instance in refused {
            planner.on_returned(instance);
        }
        PlannerWindow {
            checks: report.checks,
            pending: report.work_pending,
            cycle_latency_us: report.cycle_latency_us,
            commits,
        }
    }

    /// After this side's checkpoint: a `Resume` after a restore, the acknowledgement, then
    /// the commits not sent yet, until `send` refuses one.
    pub fn transmit(&mut self, send: &mut impl FnMut(Wire<ToExecutive>) -> bool) {
        if self.resume {
            if !send(Wire::Resume {
                received: self.from_executive.received,
            }) {
                return;
            }
            self.resume = false;
        }
        if let Some(upto) = self.from_executive.ack() {
            let _ = send(Wire::Ack { upto });
        }
        self.to_executive.transmit(send);
    }

    /// Whether a cycle is in progress or inputs wait.
    pub fn work_pending(&self) -> bool {
        self.loaded && self.planner.work_pending()
    }

    /// When the planner needs to run next.
    pub fn next_wakeup(&self) -> Option<MissionTimeUs> {
        if !self.loaded {
            return None;
        }
        self.planner.next_wakeup(&self.network, self.now)
    }

    /// Encodes this side's whole state (the checkpoint payload).
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let meta = PlannerMeta {
            loaded: self.loaded,
            now: self.now,
        };
        let mut len = postcard::to_slice(&meta, buf).ok()?.len();
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

    /// Writes this side's checkpoint into its own area.
    pub fn checkpoint_to(
        &self,
        area: &mut WarmRestartArea<'_>,
    ) -> Result<WrittenRecord, CheckpointError> {
        area.write_record(|buf| self.encode_state(buf))
    }

    /// Restores this side from the newest whole record of its area; every commit not
    /// acknowledged goes again, the executive hears what we have applied, and a new cycle
    /// starts (the state may have changed while the target was down).
    pub fn restore_from(&mut self, area: &WarmRestartArea<'_>) -> Result<u32, SideRestoreError> {
        let (_, sequence, payload) = area.latest().ok_or(SideRestoreError::NoRecord)?;
        if self.decode_state(payload).is_none() {
            *self = Self::new();
            return Err(SideRestoreError::BadPayload);
        }
        self.planner.after_restore();
        self.to_executive.after_restore();
        self.resume = true;
        Ok(sequence)
    }

    fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        let (meta, rest): (PlannerMeta, _) = postcard::take_from_bytes(payload).ok()?;
        let rest = decode_network(&mut self.network, rest)?;
        let (planner, rest) = postcard::take_from_bytes(rest).ok()?;
        let (to_executive, rest) = postcard::take_from_bytes(rest).ok()?;
        let (from_executive, rest) = postcard::take_from_bytes(rest).ok()?;
        if !rest.is_empty() {
            return None;
        }
        self.planner = planner;
        self.to_executive = to_executive;
        self.from_executive = from_executive;
        self.loaded = meta.loaded;
        self.now = meta.now;
        Some(())
    }
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
    /// When the host must grant next (if no input arrives first): one major frame on while
    /// the planner has work pending or a message waits to be sent, else the earliest need of
    /// either side.
    pub next_wakeup: Option<MissionTimeUs>,
    /// The planner's window.
    pub planner: PlannerWindow,
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
    /// Write `side`'s checkpoint (`executive` or `planner`, whichever `side` names). False:
    /// the write did not complete (a reset tore it); the frame stops there.
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

/// Runs one major frame of both partitions at `now` with `planner_budget` validity checks for
/// the planner's window, handing the ports' messages over as the kernel does (what a window
/// sends is in the port at the start of the other side's next window; a port never refuses
/// here: the outboxes are the bound). The decisions go to `out` in the order the windows run.
/// Each window ends with its side's checkpoint, then its transmission.
pub fn run_frame(
    executive: &mut ExecutivePartition,
    planner: &mut PlannerPartition,
    now: MissionTimeUs,
    planner_budget: u32,
    out: &mut impl Outputs,
    env: &mut impl FrameEnv,
) -> Result<Frame, Interrupted> {
    let step = |env: &mut dyn FnMut(Point) -> bool, point| {
        if env(point) {
            Ok(())
        } else {
            Err(Interrupted(point))
        }
    };
    executive.first_window(now, out);
    step(&mut |p| env.proceed(p), Point::ExecutiveFirstWindow)?;
    if !env.checkpoint(Side::Executive, executive, planner) {
        return Err(Interrupted(Point::ExecutiveFirstWindow));
    }
    step(&mut |p| env.proceed(p), Point::ExecutiveFirstCheckpoint)?;
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    step(&mut |p| env.proceed(p), Point::ExecutiveFirstSent)?;
    let window = planner.window(now, planner_budget, out);
    step(&mut |p| env.proceed(p), Point::PlannerWindow)?;
    if !env.checkpoint(Side::Planner, executive, planner) {
        return Err(Interrupted(Point::PlannerWindow));
    }
    step(&mut |p| env.proceed(p), Point::PlannerCheckpoint)?;
    planner.transmit(&mut |w| {
        executive.receive(w);
        true
    });
    step(&mut |p| env.proceed(p), Point::PlannerSent)?;
    executive.second_window(out);
    step(&mut |p| env.proceed(p), Point::ExecutiveSecondWindow)?;
    if !env.checkpoint(Side::Executive, executive, planner) {
        return Err(Interrupted(Point::ExecutiveSecondWindow));
    }
    step(&mut |p| env.proceed(p), Point::ExecutiveSecondCheckpoint)?;
    executive.transmit(&mut |w| {
        planner.receive(w);
        true
    });
    step(&mut |p| env.proceed(p), Point::ExecutiveSecondSent)?;
    let waiting = executive.to_planner.unsent() > 0 || planner.to_executive.unsent() > 0;
    let next_wakeup = if window.pending || waiting {
        Some(MissionTimeUs(now.0.saturating_add(MAJOR_FRAME_US)))
    } else {
        [executive.next_wakeup(), planner.next_wakeup()]
            .into_iter()
            .flatten()
            .min()
    };
    Ok(Frame {
        next_wakeup,
        planner: window,
    })
}
