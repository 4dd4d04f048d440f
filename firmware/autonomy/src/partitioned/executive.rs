//! The executive partition's side: the control loop, its network, its ends of the ports.
use super::*;

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
    /// The second window reported a failure (or a skip) that the planner has not seen: the
    /// next frame comes at once, so that the planner's response (a contingency, a repair)
    /// does not wait for the next need. The first window's reports reach the planner in the
    /// same frame.
    replan_now: bool,
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
    /// `image` holds the network's image (false after a restore, until a transfer needs it:
    /// encoding it again costs a restore as much as decoding the network).
    image_valid: bool,
    pub stats: ExecutivePartitionStats,
    /// The temporal plan this side dispatches (its network from the planner in chunks).
    dispatch: ExecutiveDispatch,
    /// The frame's message found no room (the planner has not acknowledged what it holds): it
    /// goes once an acknowledgement makes room, late rather than lost. Not saved: a restore
    /// sends the frame again ([`ExecutivePartition::resynchronise`]).
    frame_unsent: bool,
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

impl ExecutivePartition {
    pub const fn new() -> Self {
        Self {
            network: TaskNetwork::EMPTY,
            control: ControlLoop::new(),
            now: MissionTimeUs::ZERO,
            frame: 0,
            loaded: false,
            restored: None,
            replan_now: false,
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
            image_valid: false,
            stats: ExecutivePartitionStats {
                stale_commits: 0,
                telemetry_dropped: 0,
                resyncs: 0,
            },
            dispatch: ExecutiveDispatch::new(),
            frame_unsent: false,
        }
    }

    /// The temporal plan's dispatch state.
    pub fn dispatch(&self) -> &ExecutiveDispatch {
        &self.dispatch
    }

    /// The dispatcher of the plan held whole, to poll.
    pub fn dispatcher_mut(&mut self) -> Option<&mut temporal::Dispatcher> {
        self.dispatch.dispatcher_mut()
    }

    /// Step `step` of the plan held was executed at `at` (ticks since the plan's epoch): the
    /// dispatcher marks it and the planner is told ([`DispatchNote::Executed`]), through the
    /// checkpointed channel. Refused with its reason, nothing changed.
    pub fn dispatch_executed(&mut self, step: u16, at: u32) -> Result<(), ExecutedRefusal> {
        let note = self.dispatch.executed(step, at)?;
        self.to_planner
            .push_leaving(1, PlannerInput::Dispatch(note));
        Ok(())
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
        self.image_valid = true;
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
        self.image_valid = true;
        self.after_load();
        Ok(())
    }

    /// A new generation of the network, streamed to the planner from its start.
    fn start_transfer(&mut self) {
        self.generation = self.generation.wrapping_add(1).max(1);
        self.ensure_image();
        let image = self.image.get(..self.image_len).unwrap_or(&[]);
        self.transfer = Some(Transfer {
            len: u32::try_from(image.len()).unwrap_or(u32::MAX),
            pushed: 0,
            crc: CRC32.checksum(image),
            begun: false,
        });
        self.pump();
    }

    fn after_load(&mut self) {
        self.loaded = true;
        self.start_transfer();
    }

    /// The network's image in `image`, encoded again from the network after a restore.
    fn ensure_image(&mut self) {
        if !self.image_valid {
            self.image_len = self.network.encode(&mut self.image).unwrap_or(0);
            self.image_valid = true;
        }
    }

    /// Puts the next part of the network image in the channel; after its end, what the state
    /// buffer already told us.
    fn pump(&mut self) {
        let Some(mut t) = self.transfer else {
            return;
        };
        self.ensure_image();
        if !t.begun {
            if self.to_planner.room() < 2
                || !self.to_planner.push(PlannerInput::NetworkBegin {
                    generation: self.generation,
                    len: t.len,
                })
            {
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
            && self.to_planner.room() > 1
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
                to_planner.push_leaving(1, PlannerInput::Core(m));
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
        let params_changed = control.on_state_update(network, key, value, at, &mut |m| {
            to_planner.push_leaving(1, PlannerInput::Core(m));
        });
        if params_changed {
            // The image streamed to a planner that starts over must hold the new values.
            self.image_valid = false;
        }
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
            Wire::Ack { upto } => {
                self.to_planner.on_ack(upto);
                if self.frame_unsent {
                    self.push_frame();
                }
            }
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
        self.start_transfer();
        if self.frame != 0 {
            self.push_frame();
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
            ExecutiveInput::DispatchChunk { horizon, chunk } => {
                if let Some(note) = self.dispatch.take(&chunk, horizon) {
                    self.to_planner
                        .push_leaving(1, PlannerInput::Dispatch(note));
                }
            }
        }
    }

    fn accept(&mut self, commit: Commit) {
        let Self {
            control,
            to_planner,
            ..
        } = self;
        control.accept(commit, &mut |m| {
            to_planner.push_leaving(1, PlannerInput::Core(m));
        });
    }

    /// The executive's first window of frame `frame` at `now`: the restart adjustments after a
    /// restore, the ages of measured values, the first executive pass, the next part of a
    /// network transfer, and the frame for the planner.
    pub fn first_window(&mut self, frame: u32, now: MissionTimeUs, out: &mut impl Outputs) {
        let now = MissionTimeUs(now.0.min(MAX_MISSION_TIME_US));
        self.now = now;
        self.frame = frame;
        self.replan_now = false;
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
                to_planner.push_leaving(1, PlannerInput::Core(m));
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
        self.push_frame();
    }

    /// The frame in progress for the planner; when the outbox is full, again after the next
    /// acknowledgement (see `frame_unsent`).
    fn push_frame(&mut self) {
        self.frame_unsent = !self.to_planner.push(PlannerInput::Frame {
            frame: self.frame,
            now: self.now,
        });
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
            replan_now,
            ..
        } = self;
        control.step(network, *now, out, &mut |m| {
            if let ToPlanner::Report(TaskReport {
                kind: ReportKind::Failed { .. } | ReportKind::Skipped,
                ..
            }) = m
            {
                *replan_now = true;
            }
            to_planner.push_leaving(1, PlannerInput::Core(m));
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
        if self.control.executive.work_pending() || self.restored.is_some() || self.replan_now {
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
        // The image in hand, or the network encoded again (`load_network` before any transfer).
        len += match self
            .image
            .get(..self.image_len)
            .filter(|_| self.image_valid)
        {
            Some(image) => put_network_image(image, buf.get_mut(len..)?)?,
            None => encode_network(&self.network, buf.get_mut(len..)?)?,
        };
        put(&self.control.executive, buf, &mut len)?;
        put(&self.control.states, buf, &mut len)?;
        put(&self.to_planner, buf, &mut len)?;
        put(&self.from_planner, buf, &mut len)?;
        self.dispatch.encode(buf, &mut len)?;
        Some(len)
    }

    /// This side's checkpoint now holds its whole state (a caller that writes the checkpoint
    /// itself, from [`ExecutivePartition::encode_state`], says so): the messages kept may go,
    /// the messages applied may be acknowledged.
    pub fn checkpointed(&mut self) {
        self.to_planner.checkpointed();
        self.from_planner.checkpointed();
    }

    /// The restart adjustments after a decoded checkpoint numbered `sequence`: tasks whose
    /// command was out are interrupted, command ids skip ahead, the `Restored` event and the
    /// after-reset values come at the next first window, every message not acknowledged goes
    /// again, and the planner hears what we have applied. (A whole restore:
    /// [`PartitionSide::restore_record`], [`PartitionSide::restore_from`].)
    pub(super) fn prepare_restart(&mut self, sequence: u32) {
        self.control.executive.after_restore();
        self.to_planner.after_restore();
        self.from_planner.checkpointed();
        self.restored = Some(sequence);
        self.resume = true;
    }

    /// Makes this side what [`ExecutivePartition::new`] is, in place.
    pub fn reset(&mut self) {
        self.network.clear();
        self.control.reset();
        self.now = MissionTimeUs::ZERO;
        self.frame = 0;
        self.loaded = false;
        self.restored = None;
        self.replan_now = false;
        self.generation = 0;
        self.transfer = None;
        self.to_planner.reset();
        self.from_planner = EMPTY_INBOX;
        self.resume = true;
        self.status = None;
        self.telemetry.clear();
        self.image_len = 0;
        self.image_valid = false;
        self.stats = ExecutivePartitionStats::default();
        self.dispatch.reset();
        self.frame_unsent = false;
    }

    /// Replaces the state with one [`ExecutivePartition::encode_state`] wrote, checked as a
    /// restored checkpoint is (no restart adjustments: [`PartitionSide::restore_record`]
    /// adds them). None when refused; the state may then be partly overwritten.
    pub fn decode_state(&mut self, payload: &[u8]) -> Option<()> {
        let (meta, rest): (ExecutiveMeta, _) = postcard::take_from_bytes(payload).ok()?;
        let (image, rest) = decode_network(&mut self.network, rest)?;
        let rest = in_place::take_in_place(rest, ExecutiveInPlace(&mut self.control.executive))?;
        let rest = in_place::take_in_place(rest, StateTableInPlace(&mut self.control.states))?;
        let rest = in_place::take_in_place(rest, OutboxInPlace(&mut self.to_planner))?;
        let (from_planner, rest) = postcard::take_from_bytes(rest).ok()?;
        let rest = self.dispatch.decode(rest).ok()?;
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
        // The image streamed to the planner: the checkpoint's bytes (a transfer in progress
        // goes on with the bytes its CRC covers).
        self.image.get_mut(..image.len())?.copy_from_slice(image);
        self.image_len = image.len();
        self.image_valid = true;
        self.control.state_type_mismatches = meta.state_type_mismatches;
        self.control.last_state_type_mismatch = meta.last_state_type_mismatch;
        self.from_planner = from_planner;
        self.loaded = meta.loaded;
        self.now = meta.now;
        self.frame = meta.frame;
        self.generation = meta.generation;
        self.transfer = meta.transfer;
        self.stats = meta.stats;
        self.frame_unsent = false;
        Some(())
    }
}
