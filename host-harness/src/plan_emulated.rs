//! `hil plan --emulated`: the temporal planner on the emulated RAD750, in the planner
//! partition (issue 13). The compiled task goes up in chunks on the reliable link
//! (`TemporalBegin`, `TemporalChunk`), the planner partition checks and accepts it, and the
//! host then grants frames in lockstep (one major frame of mission time each) until the plan
//! comes back: the planner searches in each granted frame's window, within its CPU share, and
//! resumes in the next (anytime across windows).
//!
//! Uplinks are authenticated (`sdls::temporal`): `hil` provisions its built-in test key
//! ([`crate::mission::auth::TEST_KEY`]) into the target's non-volatile memory before boot (the
//! executive's security area and the planner's), and signs every job with the next sequence
//! number of its own counter ([`EmulatedPlanner::signed_job_messages`]).
//!
//! Costs are guest CPU: the planner partition's timebase ticks spent setting up and searching
//! (its decrementer-counted CPU time, the same run to run), and the guest instructions that
//! makes under `-icount shift=2` (4 ns each, 15.06 per 16.6 MHz tick). Never host time.
use fsw_bridge::temporal::{
    RoverReport, TemporalConfig, TemporalDuplicates, TemporalOutcome, TemporalReport,
    TEMPORAL_CHUNK_MAX,
};
use fsw_bridge::{HostToTarget, MissionTimeUs, ResetKind, TargetToHost};

use crate::firmware::FirmwareImage;
use crate::mission::auth::{Signer, TEST_KEY};
use crate::mission::link::{Exchanged, LinkSession};
use crate::mission::plan::LinkFaults;
use crate::mission::target::{hello_message, EmulatedTarget, MissionTarget};
use crate::plan::{PlanOptions, PlanReport, PlanStep};
use crate::qemu::QemuProfile;
use sdls::Key;

/// One major frame of mission time per grant while planning is pending.
pub const FRAME_US: u64 = autonomy::partitioned::MAJOR_FRAME_US;
/// Guest instructions per timebase tick under `-icount shift=2` (4 ns per instruction, a
/// 16.6 MHz timebase): 60.24 ns / 4 ns.
pub const INSTRUCTIONS_PER_TICK: f64 = 1e9 / 16.6e6 / 4.0;
/// Chunks sent before the link is given a chance to settle (the send window is 16 frames a
/// virtual channel; the queue takes more).
const CHUNKS_PER_BATCH: usize = 32;

/// What the emulated target adds to a plan report.
#[derive(Clone, Debug, Default, serde::Serialize, PartialEq)]
pub struct EmulatedCosts {
    /// The planner partition's CPU spent setting up and searching until the search's plan,
    /// timebase ticks (before the action elimination that improves it).
    pub planning_ticks: u64,
    /// The same in guest instructions (ticks x 15.06, `-icount shift=2`): "instructions to a
    /// plan", the measure of issue 13's goal and of `budgets.toml`'s `plan:` sources.
    pub guest_instructions: u64,
    /// The action elimination after the search (`temporal`'s eliminate.rs): its CPU in
    /// ticks and guest instructions, the instructions to the improved plan (search and
    /// elimination), and its costliest unit (timebase ticks).
    pub elimination_ticks: u64,
    pub elimination_instructions: u64,
    pub improved_plan_instructions: u64,
    pub worst_elimination_ticks: u32,
    /// Planner windows in which the search ran.
    pub planner_windows: u32,
    /// The costliest expansion, timebase ticks (a planner window is 33,200; its planning
    /// share 24,900).
    pub worst_expansion_ticks: u32,
    /// The costliest piece of the search's set-up, timebase ticks.
    pub worst_set_up_ticks: u32,
    /// Frames granted from the task's acceptance to the plan's end (mission time:
    /// `frames` x 10 ms).
    pub frames: u32,
    /// Lockstep rounds of the link for the whole job (uplink included).
    pub link_rounds: u64,
    /// The planner partition's CPU spent receiving and checking the task (chunks copied and
    /// absorbed into the MAC, CRC-32, security checks and counter write, validation),
    /// timebase ticks; not part of `planning_ticks`.
    pub receive_ticks: u32,
    /// The same in guest instructions.
    pub receive_instructions: u64,
    /// The part of `receive_ticks` spent authenticating the task, timebase ticks.
    pub auth_ticks: u32,
    /// The same in guest instructions.
    pub auth_instructions: u64,
    /// The kernel's health-monitor events during the job, uplink included (an overrun of the
    /// planner partition's window is "partition 2: error kind 8, action 0").
    pub health_events: Vec<String>,
    /// Warm resets injected during the search ([`MidSearchReset`]).
    pub resets: u32,
    /// The planner partition said it resumed the job after a reset.
    pub resumed: bool,
    /// The CPU it spent checking the stored task again before the search restarted, timebase
    /// ticks (part of `planning_ticks`).
    pub verify_ticks: u32,
}

/// A warm reset injected in the middle of the search (`hil plan --emulated
/// --warm-reset-after-frames N`): before granted frame `after_frames` (counted from the job's
/// acceptance, from 0) the host arms a reset that lands once the planner partition has run
/// `planner_ticks` ticks of CPU in that frame (`ResetKind::PlannerAfterTicks`, as `hil run`'s
/// mid-frame resets), then goes on granting frames; the target resumes the job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MidSearchReset {
    pub after_frames: u32,
    pub planner_ticks: u32,
}

/// The job's configuration on the wire, from `hil plan`'s options.
pub fn wire_config(options: &PlanOptions) -> Result<TemporalConfig, String> {
    let c = &options.config;
    Ok(TemporalConfig {
        max_steps: u16::try_from(c.max_steps).map_err(|_| "max steps over 65535".to_string())?,
        compression: c.compression,
        preferred_operators: c.preferred_operators,
        shed_when_full: c.shed_when_full,
        duplicates: match c.duplicates {
            temporal::Duplicates::Keep => TemporalDuplicates::Keep,
            temporal::Duplicates::PruneQuiescent => TemporalDuplicates::PruneQuiescent,
            temporal::Duplicates::PruneAll => TemporalDuplicates::PruneAll,
        },
        duration_costs: c.relaxed_cost == temporal::heuristic::RelaxedCost::Duration,
        dropped_goals: c.dropped_goals,
        max_expansions: u32::try_from(options.max_expansions).unwrap_or(u32::MAX),
        max_windows: 0,
    })
}

/// What the planner partition said about the job.
#[derive(Debug, Default)]
struct Collected {
    accepted: bool,
    receive_ticks: u32,
    auth_ticks: u32,
    /// The Resumed report's verify ticks.
    resumed: Option<u32>,
    /// Every temporal report, of any job.
    all: Vec<TemporalReport>,
    refused: Option<String>,
    steps: Vec<TemporalReport>,
    stats: Option<TemporalReport>,
    improved: Option<TemporalReport>,
    done: Option<TemporalReport>,
    health: Vec<String>,
}

impl Collected {
    fn take(&mut self, job: u16, msg: &TargetToHost) {
        if let TargetToHost::Temporal(r) = msg {
            self.all.push(r.clone());
        }
        match msg {
            TargetToHost::Temporal(r) if r.job() == job => match r {
                TemporalReport::Accepted {
                    receive_ticks,
                    auth_ticks,
                    ..
                } => {
                    self.accepted = true;
                    self.receive_ticks = *receive_ticks;
                    self.auth_ticks = *auth_ticks;
                }
                // The first refusal says why: after a refused `TemporalBegin` (a task too
                // large, say) every chunk is refused as out of sequence too.
                TemporalReport::Refused { reason, .. } => {
                    if self.refused.is_none() {
                        self.refused = Some(format!("{reason:?}"));
                    }
                }
                TemporalReport::Step { .. } => self.steps.push(r.clone()),
                TemporalReport::Stats { .. } => self.stats = Some(r.clone()),
                TemporalReport::Improved { .. } => self.improved = Some(r.clone()),
                TemporalReport::Done { .. } => self.done = Some(r.clone()),
                // The rover mission's reports are taken by `rover_frames` from `all`.
                TemporalReport::Rover { .. } => {}
                TemporalReport::Resumed { verify_ticks, .. } => {
                    // What came of the job before the reset is void: it comes again.
                    self.resumed = Some(*verify_ticks);
                    self.steps.clear();
                    self.stats = None;
                    self.improved = None;
                    self.done = None;
                }
            },
            TargetToHost::Telemetry(fsw_bridge::TelemetryEvent::HealthMonitor {
                partition,
                kind,
                action,
                ..
            }) => self.health.push(format!(
                "partition {partition}: error kind {kind}, action {action}"
            )),
            _ => {}
        }
    }
}

/// Why an emulated job failed (the target keeps running after each but the last two).
#[derive(Debug, thiserror::Error)]
pub enum EmulatedError {
    #[error("the planner partition refused the task: {0}")]
    Refused(String),
    #[error("the target: {0}")]
    Target(String),
    #[error("the target reset during the job ({0})")]
    Reset(String),
    #[error("no answer from the planner partition after {0} frames")]
    NoAnswer(u32),
}

/// A booted emulated target with its link, for one or more jobs.
pub struct EmulatedPlanner {
    target: EmulatedTarget,
    link: LinkSession,
    frame: u32,
    now: MissionTimeUs,
    next_job: u16,
    /// The host's key and anti-replay counter for temporal uplinks.
    signer: Signer,
    /// A mid-frame warm reset is armed: the next Hello is its landing, not a failure.
    armed_reset: bool,
    /// Warm resets that landed.
    resets: u32,
    /// Health-monitor events seen (for tests: a planner that overran its window).
    pub health_events: Vec<String>,
    /// The rover mission's reports delivered and not yet taken (any exchange may bring them:
    /// the mission's Ready comes with its task's acceptance).
    rover_reports: Vec<fsw_bridge::temporal::RoverReport>,
}

/// Boot `firmware` under QEMU (the shipped `rad750-proxy` profile), with `key` provisioned in
/// its non-volatile memory first if given, and open the link session on its Hello. QEMU is
/// ended by its PID when the target is dropped. Shared by the temporal planner's and the
/// lander's emulated drivers.
pub(crate) fn boot_linked(
    firmware: &FirmwareImage,
    key: Option<&Key>,
) -> Result<(EmulatedTarget, LinkSession), String> {
    let profile = QemuProfile::load("rad750-proxy").map_err(|e| e.to_string())?;
    let mut target = EmulatedTarget::with_temporary_nv(profile, firmware.clone(), false, false)
        .map_err(|e| format!("cannot create the non-volatile memory file: {e}"))?;
    if let Some(key) = key {
        target
            .provision_key(key)
            .map_err(|e| format!("cannot provision the key: {e}"))?;
    }
    let hello = target.boot().map_err(|e| e.to_string())?;
    let mut link = LinkSession::new(0, &LinkFaults::default());
    link.hello(&hello_message(&hello));
    Ok((target, link))
}

/// The time grant of one frame (`frame` from `now`), the end of the frame, and the test that
/// the frame is done (its `FrameDone`).
pub(crate) fn frame_grant(
    frame: u32,
    now: MissionTimeUs,
) -> (
    HostToTarget,
    MissionTimeUs,
    impl FnMut(&TargetToHost) -> bool,
) {
    let until = now.saturating_add(FRAME_US);
    (
        HostToTarget::TimeGrant { frame, now, until },
        until,
        move |m: &TargetToHost| matches!(m, TargetToHost::FrameDone { frame: f, .. } if *f == frame),
    )
}

impl EmulatedPlanner {
    /// Boot `firmware` under QEMU (the shipped `rad750-proxy` profile).
    pub fn boot(firmware: &FirmwareImage) -> Result<Self, String> {
        let (target, link) = boot_linked(firmware, Some(&TEST_KEY))?;
        Ok(Self {
            target,
            link,
            frame: 0,
            now: MissionTimeUs::ZERO,
            next_job: 1,
            signer: Signer::new(TEST_KEY),
            armed_reset: false,
            resets: 0,
            health_events: Vec::new(),
            rover_reports: Vec::new(),
        })
    }

    fn exchange(
        &mut self,
        job: u16,
        got: &mut Collected,
        until: Option<&mut dyn FnMut(&TargetToHost) -> bool>,
    ) -> Result<(), EmulatedError> {
        let (end, delivered) = self
            .link
            .exchange(&mut self.target, until)
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        for msg in &delivered {
            self.target.observe(msg);
            got.take(job, msg);
            if let TargetToHost::Temporal(TemporalReport::Rover { report, .. }) = msg {
                self.rover_reports.push(*report);
            }
        }
        match end {
            Exchanged::Settled if self.armed_reset => Err(EmulatedError::Target(
                "the armed warm reset did not land in its frame".into(),
            )),
            Exchanged::Settled => Ok(()),
            Exchanged::TargetReset(hello) if self.armed_reset => {
                self.armed_reset = false;
                self.resets += 1;
                self.link.reset();
                self.link.hello(&hello);
                Ok(())
            }
            Exchanged::TargetReset(hello) => Err(EmulatedError::Reset(format!("{hello:?}"))),
        }
    }

    /// Power the target off and on (QEMU ends and starts again: RAM gone, the non-volatile
    /// memory kept) and take its Hello.
    pub fn power_cycle(&mut self) -> Result<(), EmulatedError> {
        self.target
            .power_cycle()
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        let hello = self
            .target
            .boot()
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        self.link.reset();
        self.link.hello(&hello_message(&hello));
        Ok(())
    }

    /// Grant `n` frames and return the temporal reports that came, of any job (tests: after a
    /// cold boot, nothing of a job accepted before it).
    pub fn grant_frames(&mut self, n: u32) -> Result<Vec<TemporalReport>, EmulatedError> {
        let mut reports = Vec::new();
        for _ in 0..n {
            let mut got = Collected::default();
            self.grant_one(0, &mut got, None)?;
            reports.append(&mut got.all);
            self.health_events.append(&mut got.health);
        }
        Ok(reports)
    }

    /// Grant one frame (after arming `reset` if any) and exchange until its FrameDone, or the
    /// armed reset's Hello.
    fn grant_one(
        &mut self,
        job: u16,
        got: &mut Collected,
        reset: Option<u32>,
    ) -> Result<(), EmulatedError> {
        if let Some(ticks) = reset {
            self.target
                .arm_mid_frame_reset_exactly(ResetKind::PlannerAfterTicks { ticks });
            self.target
                .warm_reset(self.now)
                .map_err(|e| EmulatedError::Target(e.to_string()))?;
            self.armed_reset = true;
        }
        let (grant, until, mut done) = frame_grant(self.frame, self.now);
        self.link
            .send(grant)
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        self.exchange(job, got, Some(&mut done))?;
        self.frame = self.frame.wrapping_add(1);
        self.now = until;
        Ok(())
    }

    /// Send raw job messages (tests send damaged ones) and wait for the acceptance or the
    /// refusal of `job`.
    pub fn uplink(&mut self, job: u16, msgs: Vec<HostToTarget>) -> Result<(), EmulatedError> {
        self.uplink_costs(job, msgs).map(|_| ())
    }

    /// [`Self::uplink`], and the receive and authentication ticks the acceptance reported.
    fn uplink_costs(
        &mut self,
        job: u16,
        msgs: Vec<HostToTarget>,
    ) -> Result<(u32, u32), EmulatedError> {
        let mut got = Collected::default();
        for batch in msgs.chunks(CHUNKS_PER_BATCH) {
            for m in batch {
                self.link
                    .send(m.clone())
                    .map_err(|e| EmulatedError::Target(e.to_string()))?;
            }
            self.exchange(job, &mut got, None)?;
        }
        if !got.accepted && got.refused.is_none() {
            let mut answered = |m: &TargetToHost| matches!(m, TargetToHost::Temporal(TemporalReport::Accepted { job: j, .. } | TemporalReport::Refused { job: j, .. }) if *j == job);
            self.exchange(job, &mut got, Some(&mut answered))?;
        }
        self.health_events.append(&mut got.health);
        match got.refused {
            Some(reason) => Err(EmulatedError::Refused(reason)),
            None => Ok((got.receive_ticks, got.auth_ticks)),
        }
    }

    /// The messages that uplink `task` as job `job`, signed with the host's key and its next
    /// sequence number.
    pub fn signed_job_messages(
        &mut self,
        job: u16,
        task: &[u8],
        config: TemporalConfig,
    ) -> Vec<HostToTarget> {
        let (_, secured) = self.signer.sign_temporal(job, &config, task);
        Self::job_messages(job, &secured, config)
    }

    /// The host's signer (tests sign with it, or burn a sequence number).
    pub fn signer(&mut self) -> &mut Signer {
        &mut self.signer
    }

    /// The messages that uplink `bytes` (a secured task, or whatever a test sends) as job
    /// `job`, with `bytes`' length and CRC-32 in the Begin.
    pub fn job_messages(job: u16, bytes: &[u8], config: TemporalConfig) -> Vec<HostToTarget> {
        let mut msgs = vec![HostToTarget::TemporalBegin {
            job,
            len: bytes.len() as u32,
            crc32: flight_app::temporal_crc32(bytes),
            config,
        }];
        for (i, chunk) in bytes.chunks(TEMPORAL_CHUNK_MAX).enumerate() {
            msgs.push(HostToTarget::TemporalChunk {
                job,
                offset: (i * TEMPORAL_CHUNK_MAX) as u32,
                bytes: heapless::Vec::from_slice(chunk).expect("a chunk fits its message"),
            });
        }
        msgs
    }

    /// A new job id.
    pub fn new_job(&mut self) -> u16 {
        let job = self.next_job;
        self.next_job = self.next_job.wrapping_add(1).max(1);
        job
    }

    /// Grant frames until `job`'s Done, at most `max_frames`.
    fn plan_frames(
        &mut self,
        job: u16,
        max_frames: u32,
        reset: Option<MidSearchReset>,
    ) -> Result<(Collected, u32), EmulatedError> {
        let mut got = Collected::default();
        let mut frames = 0;
        while got.done.is_none() {
            if frames >= max_frames {
                return Err(EmulatedError::NoAnswer(frames));
            }
            let arm = reset
                .filter(|r| r.after_frames == frames)
                .map(|r| r.planner_ticks);
            self.grant_one(job, &mut got, arm)?;
            frames += 1;
        }
        self.health_events.append(&mut got.health);
        Ok((got, frames))
    }

    /// The onboard rover mission (`flight_app::rover_mission`): `start` for a new job, then
    /// `task` uplinked (signed) as that job, then frames until the mission is ready (or refused).
    pub fn rover_start(
        &mut self,
        task: &[u8],
        start: fsw_bridge::temporal::RoverEvent,
        max_frames: u32,
    ) -> Result<(u16, Vec<fsw_bridge::temporal::RoverReport>), EmulatedError> {
        let job = self.new_job();
        self.link
            .send(HostToTarget::Rover { job, event: start })
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        let msgs = self.signed_job_messages(job, task, TemporalConfig::DEFAULT);
        self.uplink_costs(job, msgs)?;
        let ready = self
            .rover_frames(job, max_frames)
            .map_err(|e| EmulatedError::Target(format!("the mission's task: {e}")))?;
        Ok((job, ready))
    }

    /// One event of the rover mission flying job `job`, and frames until its last answer.
    pub fn rover_event(
        &mut self,
        job: u16,
        event: fsw_bridge::temporal::RoverEvent,
        max_frames: u32,
    ) -> Result<Vec<fsw_bridge::temporal::RoverReport>, EmulatedError> {
        self.link
            .send(HostToTarget::Rover { job, event })
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        self.rover_frames(job, max_frames)
    }

    /// [`Self::rover_event`] with a warm reset armed in granted frame `after` of its answer,
    /// landing once the planner partition has run `ticks` ticks of CPU in it
    /// (`ResetKind::PlannerAfterTicks`): None when it landed (what came of the answer before
    /// it is void).
    pub fn rover_event_with_reset(
        &mut self,
        job: u16,
        event: fsw_bridge::temporal::RoverEvent,
        reset: Option<(u32, u32)>,
        max_frames: u32,
    ) -> Result<Option<Vec<fsw_bridge::temporal::RoverReport>>, EmulatedError> {
        self.link
            .send(HostToTarget::Rover { job, event })
            .map_err(|e| EmulatedError::Target(e.to_string()))?;
        let resets = self.resets;
        let answer = self.rover_frames_resetting(job, max_frames, reset)?;
        if self.resets != resets {
            self.rover_reports.clear();
            return Ok(None);
        }
        Ok(Some(answer))
    }

    /// Frames until the rover mission's next last answer (after a reset: its `Resumed`).
    pub fn rover_answer(
        &mut self,
        job: u16,
        max_frames: u32,
    ) -> Result<Vec<fsw_bridge::temporal::RoverReport>, EmulatedError> {
        self.rover_frames(job, max_frames)
    }

    /// The rover mission's reports, frame after frame, up to the last answer to an event.
    fn rover_frames(
        &mut self,
        job: u16,
        max_frames: u32,
    ) -> Result<Vec<fsw_bridge::temporal::RoverReport>, EmulatedError> {
        self.rover_frames_resetting(job, max_frames, None)
    }

    /// [`Self::rover_frames`], with a warm reset armed before frame `reset.0` (it ends the
    /// wait when it lands).
    fn rover_frames_resetting(
        &mut self,
        job: u16,
        max_frames: u32,
        reset: Option<(u32, u32)>,
    ) -> Result<Vec<fsw_bridge::temporal::RoverReport>, EmulatedError> {
        let resets = self.resets;
        let mut frames = 0;
        loop {
            if self.resets != resets {
                return Ok(Vec::new());
            }
            if let Some(last) = self
                .rover_reports
                .iter()
                .position(fsw_bridge::temporal::RoverReport::is_last)
            {
                return Ok(self.rover_reports.drain(..=last).collect());
            }
            if frames >= max_frames {
                return Err(EmulatedError::Target(format!(
                    "no answer from the rover mission after {frames} frames (reports so far: {:?})",
                    self.rover_reports
                )));
            }
            let mut got = Collected::default();
            let arm = reset.filter(|r| r.0 == frames).map(|r| r.1);
            let searching_before = self.rover_reports.last().is_some_and(|r| {
                matches!(
                    r,
                    RoverReport::Replan { .. }
                        | RoverReport::Paused { .. }
                        | RoverReport::Carried { .. }
                        | RoverReport::AttemptGoal { .. }
                        | RoverReport::Dropped { .. }
                )
            });
            self.grant_one(job, &mut got, arm)?;
            // A health event in a frame of a planning attempt's search (after its replan task
            // was built, before a frame that brings its Attempt) is the search's (an expansion
            // or a set-up piece that did not fit the window), not the mission's.
            let searching = searching_before
                && !got.all.iter().any(|r| {
                    matches!(
                        r,
                        TemporalReport::Rover {
                            report: RoverReport::Attempt { .. },
                            ..
                        }
                    )
                });
            for h in got.health.drain(..) {
                self.health_events.push(if searching {
                    format!("{h} (in a planning attempt's search)")
                } else {
                    h
                });
            }
            frames += 1;
        }
    }

    /// Plan `compiled` on the target: uplink, frames until the plan, the report.
    pub fn plan(
        &mut self,
        compiled: &pddl::Compiled,
        options: &PlanOptions,
        max_frames: u32,
    ) -> Result<PlanReport, EmulatedError> {
        let job = self.new_job();
        let config = wire_config(options).map_err(EmulatedError::Target)?;
        let msgs = self.signed_job_messages(job, &compiled.task, config);
        self.plan_job(job, msgs, compiled, max_frames, None)
    }

    /// [`Self::plan`] with a warm reset injected in the middle of the search.
    pub fn plan_with_reset(
        &mut self,
        compiled: &pddl::Compiled,
        options: &PlanOptions,
        max_frames: u32,
        reset: Option<MidSearchReset>,
    ) -> Result<PlanReport, EmulatedError> {
        let job = self.new_job();
        let config = wire_config(options).map_err(EmulatedError::Target)?;
        let msgs = self.signed_job_messages(job, &compiled.task, config);
        self.plan_job(job, msgs, compiled, max_frames, reset)
    }

    /// Plan job `job` uplinked by `msgs` (a signed job of `compiled`'s task: tests keep the
    /// messages to send them again): uplink, frames until the plan, the report.
    pub fn plan_job(
        &mut self,
        job: u16,
        msgs: Vec<HostToTarget>,
        compiled: &pddl::Compiled,
        max_frames: u32,
        reset: Option<MidSearchReset>,
    ) -> Result<PlanReport, EmulatedError> {
        let rounds_before = self.link.summary().rounds;
        let resets_before = self.resets;
        let health_before = self.health_events.len();
        let (receive_ticks, auth_ticks) = self.uplink_costs(job, msgs)?;
        let (got, frames) = self.plan_frames(job, max_frames, reset)?;
        let mut report = crate::plan::empty_report(compiled);
        let Some(TemporalReport::Done {
            outcome,
            makespan,
            ticks_per_unit,
            peak_arena_bytes,
            arena_bytes,
            planning_ticks,
            windows,
            worst_expansion_ticks,
            worst_set_up_ticks,
            ..
        }) = got.done
        else {
            return Err(EmulatedError::NoAnswer(frames));
        };
        // Without an elimination report (a firmware before it), all of it the search's.
        let (
            first_plan_ticks,
            first_plan_steps,
            first_makespan,
            elimination_checks,
            worst_elimination_ticks,
        ) = match got.improved {
            Some(TemporalReport::Improved {
                first_plan_ticks,
                first_plan_steps,
                first_makespan,
                elimination_checks,
                worst_elimination_ticks,
                ..
            }) => (
                first_plan_ticks,
                first_plan_steps,
                first_makespan,
                elimination_checks,
                worst_elimination_ticks,
            ),
            _ => (planning_ticks, got.steps.len() as u16, makespan, 0, 0),
        };
        let tpu = f64::from(ticks_per_unit.max(1));
        report.solved = outcome == TemporalOutcome::Solved;
        report.outcome = match outcome {
            TemporalOutcome::Solved => "solved".into(),
            TemporalOutcome::Unsolvable => "unsolvable".into(),
            TemporalOutcome::OutOfMemory(r) => format!("out of memory ({r:?})"),
            TemporalOutcome::ExpansionLimit => "expansion limit".into(),
            TemporalOutcome::WindowLimit => "window limit".into(),
        };
        if report.solved {
            report.makespan = Some(f64::from(makespan) / tpu);
            report.first_plan_makespan = Some(f64::from(first_makespan) / tpu);
            report.first_plan_actions = first_plan_steps.into();
            report.eliminated = u64::from(first_plan_steps).saturating_sub(got.steps.len() as u64);
        }
        report.elimination_checks = elimination_checks.into();
        for s in &got.steps {
            if let TemporalReport::Step {
                action,
                start,
                duration,
                start_lb,
                start_ub,
                ..
            } = *s
            {
                report.plan.push(PlanStep {
                    start: f64::from(start) / tpu,
                    action: compiled
                        .action_names
                        .get(usize::from(action))
                        .cloned()
                        .unwrap_or_else(|| format!("(action {action})")),
                    duration: f64::from(duration) / tpu,
                    start_window: [f64::from(start_lb) / tpu, f64::from(start_ub) / tpu],
                });
            }
        }
        if let Some(TemporalReport::Stats {
            expanded,
            generated,
            evaluated,
            inconsistent,
            duplicates,
            dead_ends,
            nodes,
            too_long,
            shed,
            best_h,
            ..
        }) = got.stats
        {
            report.expanded = expanded.into();
            report.generated = generated.into();
            report.evaluated = evaluated.into();
            report.inconsistent = inconsistent.into();
            report.duplicates = duplicates.into();
            report.dead_ends = dead_ends.into();
            report.nodes = nodes.into();
            report.too_long = too_long.into();
            report.shed = shed.into();
            report.best_h = best_h;
        }
        report.peak_arena_bytes = peak_arena_bytes.into();
        report.arena_bytes = arena_bytes.into();
        report.target = "emulated".into();
        report.emulated = Some(EmulatedCosts {
            planning_ticks: first_plan_ticks,
            guest_instructions: (first_plan_ticks as f64 * INSTRUCTIONS_PER_TICK).round() as u64,
            elimination_ticks: planning_ticks.saturating_sub(first_plan_ticks),
            elimination_instructions: (planning_ticks.saturating_sub(first_plan_ticks) as f64
                * INSTRUCTIONS_PER_TICK)
                .round() as u64,
            improved_plan_instructions: (planning_ticks as f64 * INSTRUCTIONS_PER_TICK).round()
                as u64,
            worst_elimination_ticks,
            planner_windows: windows,
            worst_expansion_ticks,
            worst_set_up_ticks,
            frames,
            link_rounds: self.link.summary().rounds - rounds_before,
            receive_ticks,
            receive_instructions: (f64::from(receive_ticks) * INSTRUCTIONS_PER_TICK).round() as u64,
            auth_ticks,
            auth_instructions: (f64::from(auth_ticks) * INSTRUCTIONS_PER_TICK).round() as u64,
            health_events: self.health_events[health_before..].to_vec(),
            resets: self.resets - resets_before,
            resumed: got.resumed.is_some(),
            verify_ticks: got.resumed.unwrap_or(0),
        });
        Ok(report)
    }
}
