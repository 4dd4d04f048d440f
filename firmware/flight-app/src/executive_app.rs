//! The executive partition's application: the control loop plus the lockstep, uplink and
//! security protocol around it.
use super::*;

/// The frame whose first window ran and whose planner answer is awaited.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Awaiting {
    pub(crate) frame: u32,
    /// Ticks of the first window's executive pass and of its checkpoint.
    pub(crate) pass_ticks: u64,
    pub(crate) checkpoint_ticks: u64,
}

/// The executive partition's application: the control loop (`autonomy::partitioned`'s
/// executive side) plus the lockstep, uplink and security protocol around it. A granted
/// frame runs in two windows: [`ExecutiveApp::first_window`] at the grant, and
/// [`ExecutiveApp::second_window`] once the planner partition has answered the frame (its
/// commits, decisions and status come through [`ExecutiveApp::receive`]), which ends with
/// `FrameDone`. Between them [`ExecutiveApp::transmit`] hands the planner what the first
/// window checkpointed.
pub struct ExecutiveApp {
    pub(crate) executive: ExecutivePartition,
    pub(crate) uplink: [u8; MAX_UPLINK_BYTES],
    pub(crate) uplink_len: usize,
    /// (next expected sequence number, announced total) of the transfer in progress.
    pub(crate) uplink_progress: Option<(u16, u16)>,
    /// Set after a restore until the repaired plan is committed: the CPU spent on recovery so
    /// far (see [`metric::RECOVERY_TICKS`]).
    pub(crate) recovering: Option<u64>,
    /// The last frame finished and what its FrameDone said: a grant for that frame again (the
    /// host lost our FrameDone, or its grant reached us twice) is answered without stepping.
    pub(crate) last_done: Option<(u32, Option<MissionTimeUs>)>,
    /// The frame between its two windows.
    pub(crate) awaiting: Option<Awaiting>,
    pub(crate) persist: Persistence,
    /// The state type mismatch count last reported ([`metric::STATE_TYPE_MISMATCHES`]).
    pub(crate) reported_state_type_mismatches: u32,
    /// The stale-commit count last reported ([`metric::STALE_COMMITS`]).
    pub(crate) reported_stale_commits: u32,
    /// The channel counts last reported ([`metric::CHANNEL_REFUSED_TO_PLANNER`],
    /// [`metric::PLANNER_TELEMETRY_DROPPED`]).
    pub(crate) reported_channel_losses: (u32, u32),
    /// Frames whose planner cycle stopped on its budget, since boot
    /// ([`metric::PLANNER_PENDING_FRAMES`]).
    pub(crate) pending_frames: u32,
    /// The key, the anti-replay counter and the ground holds, read from non-volatile memory at
    /// boot.
    pub(crate) security: SecurityAssociation,
    /// Refusals by the security checks since boot, per reason.
    pub(crate) security_refusals: [u32; SecurityRefusal::COUNT],
    /// Authentic ground commands not carried out since boot.
    pub(crate) commands_not_carried_out: u32,
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
            reported_channel_losses: (0, 0),
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
        self.reported_channel_losses = (0, 0);
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
            // Temporal planning jobs are the planner partition's (`TemporalApp`).
            HostToTarget::Ping { .. }
            | HostToTarget::ResetRequest { .. }
            | HostToTarget::TemporalBegin { .. }
            | HostToTarget::TemporalChunk { .. }
            // So are the lander executor's setups and steps (`LanderApp`).
            | HostToTarget::LanderBegin { .. }
            | HostToTarget::LanderChunk { .. }
            | HostToTarget::LanderStep { .. }
            | HostToTarget::LanderInput { .. }
            // And the onboard rover mission's events (`TemporalApp`).
            | HostToTarget::Rover { .. } => return false,
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
        let losses = (
            self.executive.to_planner().refused,
            self.executive.stats.telemetry_dropped,
        );
        if losses != self.reported_channel_losses {
            downlink.send(metric_event(
                metric::CHANNEL_REFUSED_TO_PLANNER,
                u64::from(losses.0),
            ));
            downlink.send(metric_event(
                metric::PLANNER_TELEMETRY_DROPPED,
                u64::from(losses.1),
            ));
            self.reported_channel_losses = losses;
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
