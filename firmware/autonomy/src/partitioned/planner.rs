//! The planner partition's side: the planning loop, its network, its ends of the ports.
use super::*;

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
    /// `image[..image_len]` is the loaded network's image (no assembly in progress).
    image_len: usize,
    to_executive: Outbox<ExecutiveInput, MAX_TO_EXECUTIVE_IN_FLIGHT>,
    from_executive: Inbox,
    resume: bool,
    /// Network images refused (bad CRC, bad length, failed validation).
    pub refused_networks: u32,
    /// What the executive said of the temporal plan it dispatches, for this side's owner
    /// ([`PlannerPartition::take_dispatch_notes`]); checkpointed (applied messages are).
    dispatch_notes: Vec<DispatchNote, MAX_DISPATCH_NOTES>,
    /// Notes lost because `dispatch_notes` was full.
    pub dispatch_notes_dropped: u32,
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
        // The last place is the window's status's: without it the executive would wait for an
        // answer that never comes. Telemetry that finds no other room is refused and counted
        // (`Outbox::refused`, which the planner partition's application reports).
        self.outbox
            .push_leaving(1, ExecutiveInput::Telemetry(event));
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
            image_len: 0,
            to_executive: Outbox::new(),
            from_executive: EMPTY_INBOX,
            resume: true,
            refused_networks: 0,
            dispatch_notes: Vec::new(),
            dispatch_notes_dropped: 0,
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
        self.image_len = 0;
        self.to_executive.reset();
        self.from_executive = EMPTY_INBOX;
        self.resume = true;
        self.refused_networks = 0;
        self.dispatch_notes.clear();
        self.dispatch_notes_dropped = 0;
    }

    /// Puts a chunk of a temporal plan's dispatch network in the channel to the executive
    /// (see [`DispatchSender::pump`]); false when the outbox has no room for it beside a
    /// window's status.
    pub fn send_dispatch_chunk(
        &mut self,
        chunk: &temporal::dispatch_wire::NetworkChunk,
        horizon: u32,
    ) -> bool {
        self.to_executive.room() > 2
            && self.to_executive.push(ExecutiveInput::DispatchChunk {
                horizon,
                chunk: DispatchChunk::from(*chunk),
            })
    }

    /// What the executive said of the plan it dispatches since the last call, in order (the
    /// network held, chunks refused, steps executed). A caller that checkpoints what it took
    /// does so before this side's next checkpoint.
    pub fn take_dispatch_notes(&mut self) -> Vec<DispatchNote, MAX_DISPATCH_NOTES> {
        core::mem::take(&mut self.dispatch_notes)
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

    /// A measurement of a timeline that measures model parameters: the executive's copy took
    /// it too. The image this side checkpoints is encoded again so that a restore keeps the
    /// new values (only when a parameter changed). Not inlined: its encode stays off the
    /// frame of the partition's main loop (the planner's stack is 64 KiB).
    #[inline(never)]
    fn measure_params(&mut self, timeline: u8, value: i64) {
        if self.network.params().is_empty() || value == crate::model::VALUE_UNKNOWN {
            return;
        }
        if self.network.measure_params(timeline, value).0 > 0 {
            if let Ok(len) = self.network.encode(&mut self.image) {
                self.image_len = len;
            }
        }
    }

    fn apply(&mut self, message: PlannerInput) {
        match message {
            PlannerInput::Core(m) => {
                if self.loaded {
                    if let ToPlanner::Measured {
                        timeline, value, ..
                    } = m
                    {
                        self.measure_params(timeline, value);
                    }
                    self.planner.receive(m);
                }
            }
            PlannerInput::Frame { frame, now } => self.frame = Some((frame, now)),
            PlannerInput::Dispatch(note) => {
                if self.dispatch_notes.push(note).is_err() {
                    self.dispatch_notes_dropped = self.dispatch_notes_dropped.saturating_add(1);
                }
            }
            PlannerInput::NetworkBegin { generation, len } => {
                // The plan of the old network is void from here.
                self.loaded = false;
                self.planner.reset();
                self.network.clear();
                self.image_len = 0;
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
                    self.image_len = len as usize;
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
    pub fn window(&mut self, budget: impl crate::planner::Budget) -> Option<PlannerStatus> {
        // No room for the status: the executive has not acknowledged what this side sent. The
        // frame waits for a window after its acknowledgement (late, not lost).
        if self.to_executive.room() == 0 {
            return None;
        }
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
        // Every push above left this place free.
        let _ = self.to_executive.push(ExecutiveInput::Status(status));
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
        // The loaded network's image as it came (no encoding again), or the empty network.
        len += match self
            .image
            .get(..self.image_len)
            .filter(|_| self.assembly.is_none())
        {
            Some(image) if self.image_len > 0 => put_network_image(image, buf.get_mut(len..)?)?,
            _ => encode_network(&self.network, buf.get_mut(len..)?)?,
        };
        put(&self.planner, buf, &mut len)?;
        put(&self.to_executive, buf, &mut len)?;
        put(&self.from_executive, buf, &mut len)?;
        put(
            &(self.dispatch_notes_dropped, &self.dispatch_notes),
            buf,
            &mut len,
        )?;
        Some(len)
    }

    /// This side's checkpoint now holds its whole state: see
    /// [`ExecutivePartition::checkpointed`].
    pub fn checkpointed(&mut self) {
        self.to_executive.checkpointed();
        self.from_executive.checkpointed();
    }

    /// The restart adjustments after a decoded checkpoint: every message not acknowledged goes
    /// again, the executive hears what we have applied, and a new cycle starts (the state may
    /// have changed while the target was down). (A whole restore:
    /// [`PartitionSide::restore_record`], [`PartitionSide::restore_from`].)
    pub(super) fn prepare_restart(&mut self, _sequence: u32) {
        self.planner.after_restore();
        self.to_executive.after_restore();
        self.from_executive.checkpointed();
        self.resume = true;
    }

    /// Replaces the state with one [`PlannerPartition::encode_state`] wrote, checked as a
    /// restored checkpoint is (no restart adjustments). None when refused; the state may then
    /// be partly overwritten ([`PartitionSide::restore_record`] resets it).
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
        let (image, rest) = decode_network(&mut self.network, rest)?;
        let rest = in_place::take_in_place(rest, PlannerInPlace(&mut self.planner))?;
        let rest = in_place::take_in_place(rest, OutboxInPlace(&mut self.to_executive))?;
        let (from_executive, rest) = postcard::take_from_bytes(rest).ok()?;
        let ((dropped, notes), rest): ((u32, Vec<DispatchNote, MAX_DISPATCH_NOTES>), _) =
            postcard::take_from_bytes(rest).ok()?;
        if !rest.is_empty() {
            return None;
        }
        checkpoint::check_planner_restored(meta.loaded, meta.now, &self.network, &self.planner)
            .ok()?;
        self.from_executive = from_executive;
        self.loaded = meta.loaded;
        self.now = meta.now;
        self.generation = meta.generation;
        self.frame = meta.frame;
        self.assembly = meta.assembly;
        self.refused_networks = meta.refused_networks;
        self.dispatch_notes = notes;
        self.dispatch_notes_dropped = dropped;
        self.image_len = 0;
        if meta.assembly.is_none() && meta.loaded {
            self.image.get_mut(..image.len())?.copy_from_slice(image);
            self.image_len = image.len();
        }
        Some(())
    }
}
