//! The lockstep time driver. The host grants mission time frame by frame: before each grant it
//! sends what the spacecraft published and answered since the last one; the target consumes
//! input only at frame boundaries, runs one frame, reports its decisions and FrameDone with the
//! earliest time it next needs to run. The next grant is at the earliest of that, the next
//! spacecraft event, the next scenario event, the next republication of the state buffer and
//! `max_frame`: idle stretches cost nothing.
//!
//! Everything travels on the reliable link ([`super::link::LinkSession`]): a frame's inputs and
//! grant, and the target's decisions and FrameDone, are delivered exactly once and in order
//! whatever faults the scenario injects, in as many lockstep rounds as the faults cost; mission
//! time does not move until they are. So link faults cost rounds, never decisions: the same
//! seed gives the same decisions on a clean and on a faulty link. A link that cannot deliver
//! ends the run with a "link lost" verdict.
//!
//! Uplinks and ground commands are authenticated ([`super::auth`]): the plan's key is
//! provisioned into the target's non-volatile memory before the first boot, the task network
//! goes up secured (security header, image, MAC) with the host's next anti-replay sequence
//! number, and so does every `ground_command` event. `attack` events send deliberately bad ones;
//! every answer is recorded ([`MissionRecord::authenticated`]) and counted in the `refused_*`
//! and `authenticated_accepted` metrics, and an attack the target does not refuse with the
//! reason it owed fails the run.
//!
//! Once the mission has started (the target booted and took its task network), whatever goes
//! wrong ends the run with a FAIL verdict that names it ([`MissionRun::ended_early`]) and the
//! record of everything up to then; only a target that cannot start is an error.
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::{
    CommandRefusal, GroundCommand, HostToTarget, MissionTimeUs, Opcode, ResetCause, TargetToHost,
};

use super::auth::{uplink_reason_name, Attack, Signer};
use super::link::{Exchanged, LinkFailure, LinkSession, LinkSummary};
use super::plan::{Action, AttackOn, CommandFault, MissionPlan};
use super::record::{AuthenticatedRecord, MissionRecord};
use super::rng::Rng;
use super::sim::{CommandFate, Spacecraft};
use super::target::{hello_message, hello_of, Hello, MissionTarget, ResetLanding, TargetError};
use crate::scenario::cause_name;
use crate::time::fmt_time;

/// Consecutive frames at the same mission time after which the run is declared stuck (the
/// autonomy bounds its responses and backs off in mission time, so this is a safety net).
pub const MAX_ZERO_ADVANCE_FRAMES: u32 = 10_000;
/// Bytes of task network per uplink chunk (the protocol allows up to
/// `fsw_bridge::messages::UPLINK_CHUNK_MAX`): small frames get through a noisy link far more
/// often (a 48-byte frame crosses a link that corrupts 5 % of the bytes one time in twelve, a
/// 150-byte one one time in 2,000), and a lost one costs less to send again.
pub const UPLINK_CHUNK_BYTES: usize = 32;
/// Uplink chunks queued on the link at once: well inside the 255 frames its send window holds
/// a channel, with room for the frame's other messages.
pub const UPLINK_CHUNKS_PER_BATCH: usize = 128;

/// Why a mission could not start.
#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    #[error(transparent)]
    Target(#[from] TargetError),
    #[error(transparent)]
    Link(#[from] LinkFailure),
    #[error("the target refused the task-network uplink: {name} (reason code {reason:#06x})")]
    UplinkRefused { reason: u16, name: String },
    #[error("the target reset itself during the uplink: {0}")]
    ResetDuringUplink(String),
    #[error("the target never gave its verdict on the task-network uplink")]
    UplinkUnanswered,
    #[error("the task network is too large to uplink ({chunks} chunks, at most 65535)")]
    UplinkTooLarge { chunks: usize },
}

/// Why a mission that had started ended before its end time.
#[derive(Debug, thiserror::Error)]
enum EndedEarly {
    #[error(transparent)]
    Target(#[from] TargetError),
    #[error(transparent)]
    Link(#[from] LinkFailure),
    #[error("the target kept asking to run at {at} ({frames} frames without time advancing)")]
    Stuck { at: String, frames: u32 },
    #[error("expected reset cause {expected} after the {what} at {at}, got {got}")]
    WrongResetCause {
        what: String,
        at: String,
        expected: String,
        got: String,
    },
    #[error("the warm reset armed inside the frame at {at} did not happen: the frame finished")]
    ArmedResetMissed { at: String },
    #[error("the simulated spacecraft refused an event at {at}: {why}")]
    Simulation { at: String, why: String },
    #[error(transparent)]
    Uplink(#[from] MissionError),
    #[error("the target reset itself (or never answered) during the {what} at {at}")]
    ResetDuringExchange { what: String, at: String },
    #[error("the {what} at {at} has nothing to replay: no {kind} was accepted before it")]
    NothingToReplay {
        what: String,
        at: String,
        kind: &'static str,
    },
}

/// The target's verdict on a whole uplink.
enum UplinkVerdict {
    /// UplinkAck with seq == total: authentic, fresh, valid and loaded.
    Accepted,
    /// UplinkNak: the reason code.
    Refused(u16),
    /// The target said Hello before it answered.
    TargetReset(TargetToHost),
    /// The exchange settled without a verdict (the link's exchange waits for one, so this
    /// means the target answered something else).
    Unanswered,
}

/// What a mission run produced.
pub struct MissionRun {
    pub record: MissionRecord,
    pub transcript_sha256: String,
    pub transcript_frames: u64,
    /// One line per frame both ways, in transcript order.
    pub transcript: Vec<String>,
    pub injected_link_faults: u64,
    /// Rounds, retransmissions per message class, faults injected.
    pub link: LinkSummary,
    /// Set when the run ended before the mission's end: what went wrong, and when.
    pub ended_early: Option<String>,
    /// Wall time from the start of the drive to the target's first Hello (QEMU start and
    /// boot, for an emulated target).
    pub first_boot_wall: std::time::Duration,
}

/// Progress callback: (mission time now, mission start, mission end).
pub type Progress<'a> = &'a mut dyn FnMut(MissionTimeUs, MissionTimeUs, MissionTimeUs);

/// The host's side of a running mission.
struct Flight<'p, 't> {
    plan: &'p MissionPlan,
    target: &'t mut dyn MissionTarget,
    sim: Spacecraft,
    link: LinkSession,
    fault_rng: Rng,
    armed: Vec<CommandFault>,
    rec: MissionRecord,
    now: MissionTimeUs,
    frame: u32,
    /// Messages for the next grant.
    inputs: Vec<HostToTarget>,
    /// When the whole state buffer is published again (None: only after resets).
    next_republish: Option<MissionTimeUs>,
    /// A warm reset the target armed inside the next frame: (time due, recovery).
    armed_reset: Option<(MissionTimeUs, u64)>,
    /// The key and the host's anti-replay counter.
    signer: Signer,
    /// The bytes of the last secured uplink the target accepted (replay attacks resend them).
    last_uplink: Option<Vec<u8>>,
    /// The last ground command the target accepted.
    last_command: Option<HostToTarget>,
}

/// Most rounds run after the mission to bring in what the target still has queued on the
/// Instrument channel.
const INSTRUMENT_DRAIN_ROUNDS: u32 = 2_000;

/// Fly `plan` on `target`.
pub fn drive(
    plan: &MissionPlan,
    target: &mut dyn MissionTarget,
    progress: Progress<'_>,
) -> Result<MissionRun, MissionError> {
    let sim = Spacecraft::new(
        &plan.scenario.spacecraft,
        &plan.network,
        plan.start,
        plan.seed,
    )
    .map_err(|e| TargetError::Other(format!("{}: {}", e.field, e.message)))?;
    let mut f = Flight {
        plan,
        target,
        sim,
        link: LinkSession::new(plan.seed, &plan.link),
        fault_rng: Rng::new(plan.seed).fork(0xfa),
        armed: Vec::new(),
        rec: MissionRecord::default(),
        now: plan.start,
        frame: 0,
        inputs: Vec::new(),
        next_republish: plan.republish_us.map(|p| plan.start.saturating_add(p)),
        armed_reset: None,
        signer: Signer::new(plan.key.clone()),
        last_uplink: None,
        last_command: None,
    };
    f.rec.start_security_counts();
    let drive_started = std::time::Instant::now();
    f.target.provision_key(&plan.key)?;
    let hello = f.target.boot()?;
    let first_boot_wall = drive_started.elapsed();
    f.link.reset();
    f.link.hello(&hello_message(&hello));
    f.rec.boot(plan.start, hello.reset_cause);
    f.rec.label(
        plan.start,
        format!("boot ({})", cause_name(hello.reset_cause)),
    );
    // A refused or oversized network is the inputs' fault: the mission cannot start. From
    // here on, whatever else goes wrong (a link or a target failing during the first uplink
    // included) ends the run with a FAIL verdict that names it, and what was received so far
    // is reported.
    let flown = match f.uplink() {
        Err(e @ (MissionError::UplinkRefused { .. } | MissionError::UplinkTooLarge { .. })) => {
            return Err(e)
        }
        Err(e) => Err(EndedEarly::from(e)),
        Ok(()) => {
            f.inputs = f.sim.publish_all(f.now);
            f.inputs.extend(f.planner_budget());
            f.fly(progress)
        }
    };
    if flown.is_err() {
        // What the failed exchange received: the target's last telemetry and logs.
        for msg in f.link.take_stranded() {
            f.take(msg);
        }
    }
    let ended_early = flown.err().map(|e| {
        let at = fmt_time(f.now);
        f.rec.label(f.now, format!("run ended early: {e}"));
        format!("at {at}: {e}")
    });
    f.rec.frames_metric();
    let injected = f.link.injected_faults();
    f.rec
        .metrics
        .insert("link_faults_injected".into(), injected);
    let mut link = f.link.summary();
    let (transcript_frames, transcript_sha256, transcript) = f.link.finish_transcript();
    if ended_early.is_none() {
        // What the target still has queued on the Instrument channel (costs, logs) comes in
        // before the report is made; a channel that does not empty is reported, not waited on.
        match f
            .link
            .drain_instrument(&mut *f.target, INSTRUMENT_DRAIN_ROUNDS)
        {
            Ok((rounds, drained, delivered)) => {
                link.instrument_drain_rounds = u64::from(rounds);
                link.instrument_drained = drained;
                for msg in delivered {
                    f.take(msg);
                }
            }
            Err(e) => f
                .rec
                .label(f.now, format!("draining the Instrument channel: {e}")),
        }
    }
    Ok(MissionRun {
        record: f.rec,
        transcript_sha256,
        transcript_frames,
        transcript,
        injected_link_faults: injected,
        link,
        ended_early,
        first_boot_wall,
    })
}

impl Flight<'_, '_> {
    /// Send the task network, secured with the next sequence number, and have it accepted
    /// (UplinkAck with seq == total). Telemetry that arrives meanwhile (the boot's metrics) is
    /// recorded.
    fn uplink(&mut self) -> Result<(), MissionError> {
        let (sequence, secured) = self.signer.sign_uplink(&self.plan.network.uplink);
        let verdict = self.transfer_uplink(&secured)?;
        let refused = match &verdict {
            UplinkVerdict::Accepted => None,
            UplinkVerdict::Refused(reason) => Some(uplink_reason_name(*reason)),
            UplinkVerdict::TargetReset(_) | UplinkVerdict::Unanswered => None,
        };
        if matches!(verdict, UplinkVerdict::Accepted | UplinkVerdict::Refused(_)) {
            self.rec.authenticated(AuthenticatedRecord {
                at: self.now.0,
                what: "task-network uplink".into(),
                sequence,
                refused: refused.clone(),
                expected_refusal: None,
            });
        }
        match verdict {
            UplinkVerdict::Accepted => {
                self.last_uplink = Some(secured);
                Ok(())
            }
            UplinkVerdict::Refused(reason) => Err(MissionError::UplinkRefused {
                reason,
                name: refused.unwrap_or_default(),
            }),
            UplinkVerdict::TargetReset(hello) => {
                Err(MissionError::ResetDuringUplink(format!("{hello:?}")))
            }
            UplinkVerdict::Unanswered => Err(MissionError::UplinkUnanswered),
        }
    }

    /// Send `secured` (a secured uplink) in chunks and exchange until the target's verdict on
    /// the whole of it.
    fn transfer_uplink(&mut self, secured: &[u8]) -> Result<UplinkVerdict, MissionError> {
        let chunks: Vec<&[u8]> = secured
            .chunks(UPLINK_CHUNK_BYTES.min(UPLINK_CHUNK_MAX))
            .collect();
        let total = u16::try_from(chunks.len()).map_err(|_| MissionError::UplinkTooLarge {
            chunks: chunks.len(),
        })?;
        // In batches the link's send window holds (it queues at most 255 frames a channel),
        // each exchanged until the target acknowledged its last chunk, refused the uplink, or
        // came back from a reset.
        let mut verdict = None;
        let mut end = Exchanged::Settled;
        for (batch, part) in chunks.chunks(UPLINK_CHUNKS_PER_BATCH).enumerate() {
            let first = batch * UPLINK_CHUNKS_PER_BATCH;
            for (i, chunk) in part.iter().enumerate() {
                self.link.send(HostToTarget::UplinkChunk {
                    seq: (first + i) as u16,
                    total,
                    bytes: heapless::Vec::from_slice(chunk).expect("a chunk fits its message"),
                })?;
            }
            // The whole uplink's acknowledgement is `total`; a batch's, its last chunk's.
            let last = (first + part.len()) as u16;
            let awaited = if last == total { total } else { last - 1 };
            let (ended, delivered) = self.link.exchange(
                &mut *self.target,
                Some(&mut |m: &TargetToHost| match m {
                    TargetToHost::UplinkNak { .. } => true,
                    TargetToHost::UplinkAck { seq } => *seq == awaited,
                    _ => false,
                }),
            )?;
            end = ended;
            for msg in delivered {
                match &msg {
                    TargetToHost::UplinkNak { reason, .. } => {
                        verdict.get_or_insert(UplinkVerdict::Refused(*reason));
                    }
                    TargetToHost::UplinkAck { seq } if *seq == total => {
                        verdict.get_or_insert(UplinkVerdict::Accepted);
                    }
                    other => self.take(other.clone()),
                }
            }
            if verdict.is_some() || matches!(end, Exchanged::TargetReset(_)) {
                break;
            }
        }
        Ok(match (end, verdict) {
            (Exchanged::TargetReset(hello), _) => UplinkVerdict::TargetReset(hello),
            (Exchanged::Settled, Some(verdict)) => verdict,
            (Exchanged::Settled, None) => UplinkVerdict::Unanswered,
        })
    }

    /// Send an authenticated ground command and exchange until the target's Ack or Nak for
    /// `sequence`; None if acknowledged, else the refusal.
    fn transfer_command(
        &mut self,
        msg: HostToTarget,
        sequence: u32,
        what: &str,
    ) -> Result<Option<CommandRefusal>, EndedEarly> {
        self.link.send(msg)?;
        let (end, delivered) = self.link.exchange(
            &mut *self.target,
            Some(&mut |m: &TargetToHost| match m {
                TargetToHost::GroundCommandAck { sequence: s }
                | TargetToHost::GroundCommandNak { sequence: s, .. } => *s == sequence,
                _ => false,
            }),
        )?;
        let mut verdict = None;
        for msg in delivered {
            match msg {
                TargetToHost::GroundCommandAck { sequence: s } if s == sequence => {
                    verdict.get_or_insert(None);
                }
                TargetToHost::GroundCommandNak {
                    sequence: s,
                    reason,
                } if s == sequence => {
                    verdict.get_or_insert(Some(reason));
                }
                other => self.take(other),
            }
        }
        match (end, verdict) {
            (Exchanged::Settled, Some(verdict)) => Ok(verdict),
            _ => Err(EndedEarly::ResetDuringExchange {
                what: what.into(),
                at: fmt_time(self.now),
            }),
        }
    }

    /// A `ground_command` event: signed with the next sequence number, sent, its answer
    /// recorded.
    fn ground_command(&mut self, command: GroundCommand) -> Result<(), EndedEarly> {
        let (sequence, msg) = self.signer.sign_command(command);
        let what = format!("ground command {command:?}");
        let refused = self.transfer_command(msg.clone(), sequence, &what)?;
        if refused.is_none() {
            self.last_command = Some(msg);
        }
        self.rec.authenticated(AuthenticatedRecord {
            at: self.now.0,
            what,
            sequence,
            refused: refused.map(|r| r.name().to_string()),
            expected_refusal: None,
        });
        Ok(())
    }

    /// An `attack` event: a deliberately bad uplink or ground command (with a sequence number
    /// of its own, so that one the target wrongly accepted never collides with the next good
    /// one), sent, its answer recorded next to the refusal it was owed.
    fn attack(&mut self, attack: Attack, on: AttackOn) -> Result<(), EndedEarly> {
        let what = format!("{} {}", attack.name(), on.name());
        let at = fmt_time(self.now);
        let nothing_to_replay = |kind| EndedEarly::NothingToReplay {
            what: what.clone(),
            at: at.clone(),
            kind,
        };
        let sequence = self.signer.burn_sequence();
        let key = self.signer.key().clone();
        let (sequence, refused) = match on {
            AttackOn::Uplink => {
                let last = self.last_uplink.clone().unwrap_or_default();
                if attack == Attack::Replayed && last.is_empty() {
                    return Err(nothing_to_replay("uplink"));
                }
                let bytes = attack.uplink(&key, sequence, &self.plan.network.uplink, &last);
                // The sequence number the bytes carry (the replayed one for a replay).
                let carried = sdls::uplink::parse(&bytes)
                    .map(|u| u.header.sequence)
                    .unwrap_or(sequence);
                let refused = match self.transfer_uplink(&bytes)? {
                    UplinkVerdict::Accepted => None,
                    UplinkVerdict::Refused(reason) => Some(uplink_reason_name(reason)),
                    UplinkVerdict::TargetReset(_) | UplinkVerdict::Unanswered => {
                        return Err(EndedEarly::ResetDuringExchange { what, at })
                    }
                };
                (carried, refused)
            }
            AttackOn::Command => {
                let last = self.last_command.clone();
                if attack == Attack::Replayed && last.is_none() {
                    return Err(nothing_to_replay("ground command"));
                }
                let last = last.unwrap_or(HostToTarget::Ping { seq: 0 });
                let msg = attack.command(&key, sequence, GroundCommand::SetHold(0), &last);
                let carried = match &msg {
                    HostToTarget::GroundCommand { header, .. } => header.sequence,
                    _ => sequence,
                };
                let refused = self.transfer_command(msg, carried, &what)?;
                (carried, refused.map(|r| r.name().to_string()))
            }
        };
        self.rec.authenticated(AuthenticatedRecord {
            at: self.now.0,
            what,
            sequence,
            refused,
            expected_refusal: Some(attack.expected().name().to_string()),
        });
        Ok(())
    }

    /// The mission, frame by frame, to its end.
    fn fly(&mut self, progress: Progress<'_>) -> Result<(), EndedEarly> {
        let plan = self.plan;
        let wall_start = std::time::Instant::now();
        let mut events = plan.events.iter().peekable();
        let mut zero_advance = 0u32;
        loop {
            // Scenario events due now happen before the grant.
            while let Some(ev) = events.next_if(|e| e.at <= self.now) {
                self.event(ev.at, &ev.action)?;
            }
            if plan.realtime {
                // Real time: the grant for `now` goes out when the wall clock says so.
                let due = wall_start + std::time::Duration::from_micros(self.now.0 - plan.start.0);
                if let Some(wait) = due.checked_duration_since(std::time::Instant::now()) {
                    std::thread::sleep(wait);
                }
            }
            let next_event = events.peek().map(|e| e.at);
            let next_wakeup = self.frame(next_event)?;
            progress(self.now, plan.start, plan.end);
            if self.now >= plan.end {
                return Ok(());
            }
            let next = self.next_stop(next_wakeup, events.peek().map(|e| e.at));
            if next <= self.now {
                zero_advance += 1;
                if zero_advance > MAX_ZERO_ADVANCE_FRAMES {
                    return Err(EndedEarly::Stuck {
                        at: fmt_time(self.now),
                        frames: zero_advance,
                    });
                }
            } else {
                zero_advance = 0;
            }
            self.now = next.max(self.now);
        }
    }

    /// One granted frame: the inputs due now and the grant, delivered; the target's decisions
    /// taken. Returns the target's next wake-up. A frame the target resets in (an armed
    /// mid-frame reset, or its health monitor) ends with the reset handled and the restart's
    /// wake-up at once.
    fn frame(
        &mut self,
        next_event: Option<MissionTimeUs>,
    ) -> Result<Option<MissionTimeUs>, EndedEarly> {
        let now = self.now;
        self.inputs.extend(self.sim.due(now));
        if self.next_republish.is_some_and(|t| t <= now) {
            // The whole state buffer again, so that a value the target missed heals.
            self.inputs.extend(self.sim.republish_all(now));
            self.next_republish = self.plan.republish_us.map(|p| now.saturating_add(p.max(1)));
        }
        for msg in std::mem::take(&mut self.inputs) {
            if let HostToTarget::StateUpdate {
                key,
                value,
                timestamp,
            } = msg
            {
                self.rec.state(key, value, timestamp);
            }
            self.link.send(msg)?;
        }
        let frame = self.frame;
        let until = self.next_stop(None, next_event);
        self.link
            .send(HostToTarget::TimeGrant { frame, now, until })?;
        self.frame = self.frame.wrapping_add(1);
        self.rec.frames += 1;
        let (end, delivered) = self.link.exchange(
            &mut *self.target,
            Some(&mut |m: &TargetToHost| {
                matches!(m, TargetToHost::FrameDone { frame: f, .. } if *f == frame)
            }),
        )?;
        let mut wakeup = None;
        for msg in delivered {
            if let TargetToHost::FrameDone {
                frame: f,
                next_wakeup,
            } = msg
            {
                if f == frame {
                    wakeup = next_wakeup;
                }
                continue;
            }
            self.take(msg);
        }
        match end {
            Exchanged::Settled => {
                if let Some((at, _)) = self.armed_reset.take() {
                    return Err(EndedEarly::ArmedResetMissed { at: fmt_time(at) });
                }
                Ok(wakeup)
            }
            Exchanged::TargetReset(hello) => {
                let hello = hello_of(&hello).expect("TargetReset carries a Hello");
                match self.armed_reset.take() {
                    Some((at, recovery_us)) => {
                        self.restarted("warm reset", at, recovery_us, ResetCause::Warm, hello)?
                    }
                    // The target reset itself (health monitor, watchdog): no fault protection
                    // delay is modelled; it restarts at once.
                    None => {
                        self.restarted("target-initiated reset", now, 0, hello.reset_cause, hello)?
                    }
                }
                Ok(Some(self.now))
            }
        }
    }

    /// One message the target sent, delivered by the link.
    fn take(&mut self, msg: TargetToHost) {
        self.target.observe(&msg);
        let now = self.now;
        match &msg {
            TargetToHost::CommandDispatch { id, opcode, args } => {
                self.rec.dispatch(now, *id, *opcode, args);
                let fate = fate_of(&mut self.armed, *opcode, &mut self.fault_rng);
                if fate != CommandFate::Nominal {
                    self.rec.faults.push((
                        now.0,
                        format!("command {id} (opcode {:#06x}): {fate:?}", opcode.0),
                    ));
                }
                self.sim.on_dispatch(now, *id, *opcode, args, fate);
            }
            TargetToHost::Telemetry(ev) => self.rec.telemetry(ev, &self.plan.network.network),
            _ => {}
        }
    }

    /// A scenario event due at `at` (now).
    fn event(&mut self, at: MissionTimeUs, action: &Action) -> Result<(), EndedEarly> {
        let now = self.now;
        match action {
            Action::WarmReset { recovery_us } => match self.target.warm_reset(at)? {
                ResetLanding::Now => {
                    let hello = self.target.boot()?;
                    self.restarted("warm reset", at, *recovery_us, ResetCause::Warm, hello)?;
                }
                ResetLanding::InsideNextFrame => self.armed_reset = Some((at, *recovery_us)),
            },
            Action::PowerCycle { recovery_us } => {
                self.target.power_cycle()?;
                let hello = self.target.boot()?;
                self.restarted("power cycle", at, *recovery_us, ResetCause::PowerOn, hello)?;
            }
            Action::CommandFault(f) => {
                self.rec.faults.push((
                    now.0,
                    format!("armed {:?} for opcode {:#06x}", f.fate, f.opcode.0),
                ));
                self.armed.push(f.clone());
            }
            Action::Override { key, value, name } => {
                self.sim.override_state(*key, *value, now);
                self.rec
                    .faults
                    .push((now.0, format!("{name} forced to {value:?}")));
            }
            Action::GroundCommand(command) => self.ground_command(*command)?,
            Action::Attack { attack, on } => self.attack(*attack, *on)?,
            Action::Change { key, by, name } => {
                self.sim
                    .add_to(*key, *by, now)
                    .map_err(|why| EndedEarly::Simulation {
                        at: fmt_time(now),
                        why: format!("state_change of {name}: {why}"),
                    })?;
                self.rec
                    .faults
                    .push((now.0, format!("{name} changed by {by}")));
            }
        }
        Ok(())
    }

    /// The target went down at `at` (`what`) and said `hello` when it came back: fault
    /// protection ran for `recovery_us` meanwhile (the spacecraft's commands in flight were
    /// lost and its attitude unknown), the link restarted, and the whole state buffer goes out
    /// again.
    fn restarted(
        &mut self,
        what: &str,
        at: MissionTimeUs,
        recovery_us: u64,
        expected: ResetCause,
        hello: Hello,
    ) -> Result<(), EndedEarly> {
        self.sim.reset(at);
        self.link.reset();
        self.link.hello(&hello_message(&hello));
        self.now = at.saturating_add(recovery_us);
        // What the spacecraft did while the software was down is not delivered: it restarts
        // with the whole state buffer instead.
        let _ = self.sim.due(self.now);
        if hello.reset_cause != expected && what != "target-initiated reset" {
            return Err(EndedEarly::WrongResetCause {
                what: what.into(),
                at: fmt_time(at),
                expected: cause_name(expected).into(),
                got: cause_name(hello.reset_cause).into(),
            });
        }
        self.rec.reset(at, what, recovery_us, hello.reset_cause);
        self.rec.label(
            self.now,
            format!(
                "flight software restarted ({})",
                cause_name(hello.reset_cause)
            ),
        );
        self.inputs = self.sim.publish_all(self.now);
        self.inputs.extend(self.planner_budget());
        Ok(())
    }

    /// The scenario's planner budget for the target's planner partition (after every boot:
    /// the target forgets it at a reset), if it sets one.
    fn planner_budget(&self) -> Option<HostToTarget> {
        let checks = self.plan.planner_checks_per_window?;
        Some(HostToTarget::StateUpdate {
            key: fsw_bridge::StateKey(kernel_config::abi::control::PLANNER_BUDGET),
            value: fsw_bridge::StateValue::Int(i64::from(checks)),
            timestamp: self.now,
        })
    }

    /// The next time anything needs to happen, never past the mission's end.
    fn next_stop(
        &self,
        wakeup: Option<MissionTimeUs>,
        next_event: Option<MissionTimeUs>,
    ) -> MissionTimeUs {
        let now = self.now;
        let mut next = self.plan.end;
        for t in [
            wakeup,
            self.sim.next_event(),
            next_event,
            self.next_republish,
        ]
        .into_iter()
        .flatten()
        {
            next = next.min(t.max(now));
        }
        if let Some(max) = self.plan.max_frame_us {
            next = next.min(now.saturating_add(max));
        }
        next
    }
}

fn fate_of(armed: &mut [CommandFault], opcode: Opcode, rng: &mut Rng) -> CommandFate {
    for f in armed.iter_mut().filter(|f| f.opcode == opcode && !f.spent) {
        match &mut f.skip {
            Some(0) => {
                f.spent = true;
                return f.fate;
            }
            Some(n) => *n -= 1,
            None => {
                if rng.chance(f.probability) {
                    return f.fate;
                }
            }
        }
    }
    CommandFate::Nominal
}
