//! `hil lander run FILE --emulated`: the lander simulation with the executor's decisions made
//! on the emulated RAD750, in the planner partition (`flight_app::LanderApp`, issues 11 and
//! 12).
//!
//! The simulation (`lander_sim::sim::run_watched`) keeps a native shadow executor for its own
//! queries (the pending primitive, the counters) and tells [`EmulatedLander`] of every
//! executor it builds and every step. Each build is uplinked to the target as a setup (chunks,
//! CRC-32; the target decodes, validates and builds its executor), each step goes up as a
//! `LanderStep`, and the host grants frames in lockstep until the target's answer: the
//! decisions logged since the last answer, then the directive. Both are compared with the
//! shadow's at every step; the first difference ends the run with a verdict naming the step
//! (`DIVERGED at step N ...`), and a target that does not answer (within
//! [`MAX_FRAMES_PER_STEP`] frames, or a lost link) ends it too (`NO ANSWER at step N ...`):
//! never a hang. So a run that ends is one whose every decision was made, identically, by the
//! target.
//!
//! Costs are guest CPU (the planner partition's timebase ticks, and the guest instructions
//! they are under `-icount shift=2`), never host time; the run's wall time is reported beside
//! them for the speed-up over mission time.
use std::time::{Duration, Instant};

use ::lander::comms::CommsModel;
use ::lander::downlink::DataProduct;
use ::lander::executor::{Decision, Directive, ExecConfig, Learned, Observation};
use ::lander::htn::{FlatNetwork, HtnModel};
use ::lander::placement::TimelinePlacement;
use ::lander::setup::LanderSetup;
use ::lander::wire::{
    comms_to_wire, decision_from_wire, directive_from_wire, observation_to_wire, product_to_wire,
};
use fsw_bridge::lander::{
    LanderInput, LanderRefusal, LanderReport, LANDER_CHUNK_MAX, LANDER_PRODUCTS_PER_MESSAGE,
};
use fsw_bridge::{HostToTarget, MissionTimeUs, TargetToHost};
use lander_sim::scenario::Scenario;
use lander_sim::sim::{self, Autonomy, RunConfig, RunResult, StepWatch};

use crate::firmware::FirmwareImage;
use crate::mission::link::{Exchanged, LinkSession};
use crate::mission::target::{EmulatedTarget, MissionTarget};
use crate::plan_emulated::{boot_linked, frame_grant, FRAME_US, INSTRUCTIONS_PER_TICK};

/// Frames a step may take before the run ends with no answer (a full RSM-1 replan takes a few
/// hundred planner windows).
pub const MAX_FRAMES_PER_STEP: u32 = 20_000;
/// Chunks sent before the link is given a chance to settle (as a temporal task's).
const CHUNKS_PER_BATCH: usize = 32;
/// The host's buffer for an encoded setup (the target takes at most
/// `flight_app::MAX_LANDER_SETUP_BYTES`; a larger one is sent and refused).
const SETUP_BUFFER_BYTES: usize = 1 << 20;

/// Every decision of a run, per executor built (the native run's, or the target's).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Transcript {
    /// One log per executor (the start, then each model uplink).
    pub logs: Vec<Vec<Decision>>,
    /// Every step's directive, in order.
    pub directives: Vec<Directive>,
}

/// A watch that keeps the native executor's decisions and directives.
#[derive(Debug, Default)]
pub struct Recorder {
    pub transcript: Transcript,
    seen: usize,
}

impl StepWatch for Recorder {
    fn built(
        &mut self,
        _: ExecConfig,
        _: &HtnModel,
        _: &FlatNetwork,
        _: &TimelinePlacement,
        _: &::lander::assessor::ScienceContext,
        _: &Learned,
    ) -> Result<(), String> {
        self.transcript.logs.push(Vec::new());
        self.seen = 0;
        Ok(())
    }

    fn stepped(
        &mut self,
        _: &Observation,
        directive: &Directive,
        exec: &Autonomy,
    ) -> Result<(), String> {
        let new = exec.log().get(self.seen..).unwrap_or(&[]);
        if let Some(log) = self.transcript.logs.last_mut() {
            log.extend_from_slice(new);
        }
        self.seen = exec.log().len();
        self.transcript.directives.push(*directive);
        Ok(())
    }
}

/// One step's cost on the target.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct StepCost {
    /// The step's number over the run.
    pub step: u64,
    pub at_us: u64,
    /// The planner partition's CPU for the step, timebase ticks.
    pub ticks: u32,
    pub guest_instructions: u64,
    /// Planner windows it ran in, and frames granted until its answer.
    pub windows: u16,
    pub frames: u32,
    /// The shadow's search explorations in the step (0: it did not plan).
    pub explored: u32,
    /// The step made a plan (a replan, or the first plan), and why.
    pub planned: Option<String>,
}

/// What the emulated target added to a run.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct EmulatedCosts {
    pub steps: u64,
    pub setups: u32,
    /// Setup sizes in bytes, and the target's CPU to decode, validate and build (ticks).
    pub setup_bytes: Vec<u32>,
    pub build_ticks: Vec<u32>,
    /// Every step that planned, with its cost.
    pub plans: Vec<StepCost>,
    /// Planner CPU of every step (ticks), summed, and per sol of mission time.
    pub total_ticks: u64,
    pub ticks_per_sol: Vec<u64>,
    pub frames: u64,
    /// The most planner windows and frames a step took.
    pub worst_windows: u16,
    pub worst_frames: u32,
    /// Host wall time of the run (booting QEMU excluded).
    #[serde(skip)]
    pub wall: Duration,
}

/// The emulated target running the lander's executor, compared with the shadow at each step.
pub struct EmulatedLander {
    target: EmulatedTarget,
    link: LinkSession,
    frame: u32,
    now: MissionTimeUs,
    setup: u16,
    seq: u32,
    step_no: u64,
    /// Decisions of the shadow's log compared so far.
    seen: usize,
    /// The link model and product list the target's executor has (as a new one: none).
    sent_comms: Option<CommsModel>,
    sent_onboard: Vec<DataProduct>,
    /// Input messages sent (link model changes and product list parts).
    pub inputs_sent: u64,
    /// The target's decisions and directives.
    pub transcript: Transcript,
    pub costs: EmulatedCosts,
    /// Health-monitor events seen.
    pub health_events: Vec<String>,
    /// Applied to every setup before it goes up (tests make the target decide differently
    /// from the shadow with it; None in use).
    pub perturb_setup: Option<fn(&mut LanderSetup)>,
}

/// What the planner partition said about a setup or a step.
#[derive(Debug, Default)]
struct Collected {
    accepted: Option<LanderReport>,
    refused: Option<LanderRefusal>,
    decisions: Vec<(u16, Decision)>,
    answer: Option<LanderReport>,
    health: Vec<String>,
    errors: Vec<String>,
}

impl Collected {
    fn take(&mut self, setup: u16, msg: &TargetToHost) {
        match msg {
            TargetToHost::Lander(r) if r.setup() == setup => match *r {
                LanderReport::Accepted { .. } => self.accepted = Some(*r),
                LanderReport::Refused { reason, .. } => self.refused = Some(reason),
                LanderReport::Decision {
                    index, decision, ..
                } => self.decisions.push((index, decision_from_wire(&decision))),
                LanderReport::Answer { .. } => self.answer = Some(*r),
                // Taken by `solve_downlink` itself.
                LanderReport::DownlinkSolved { .. } => {}
            },
            TargetToHost::Telemetry(fsw_bridge::TelemetryEvent::HealthMonitor {
                partition,
                kind,
                action,
                ..
            }) => self.health.push(format!(
                "partition {partition}: error kind {kind}, action {action}"
            )),
            TargetToHost::Panic { file, line } => self.errors.push(format!(
                "the target panicked at {}:{line}",
                String::from_utf8_lossy(file)
            )),
            _ => {}
        }
    }
}

impl EmulatedLander {
    /// Boot `firmware` under QEMU (the shipped `rad750-proxy` profile). QEMU is ended by its
    /// PID when this is dropped.
    pub fn boot(firmware: &FirmwareImage) -> Result<Self, String> {
        let (target, link) = boot_linked(firmware, None)?;
        Ok(Self {
            target,
            link,
            frame: 0,
            now: MissionTimeUs::ZERO,
            setup: 0,
            seq: 0,
            step_no: 0,
            seen: 0,
            sent_comms: None,
            sent_onboard: Vec::new(),
            inputs_sent: 0,
            transcript: Transcript::default(),
            costs: EmulatedCosts::default(),
            health_events: Vec::new(),
            perturb_setup: None,
        })
    }

    fn exchange(
        &mut self,
        got: &mut Collected,
        until: Option<&mut dyn FnMut(&TargetToHost) -> bool>,
    ) -> Result<(), String> {
        let (end, delivered) = self
            .link
            .exchange(&mut self.target, until)
            .map_err(|e| format!("the link: {e}"))?;
        for msg in &delivered {
            self.target.observe(msg);
            got.take(self.setup, msg);
        }
        if let Some(e) = got.errors.first() {
            return Err(e.clone());
        }
        match end {
            Exchanged::Settled => Ok(()),
            Exchanged::TargetReset(hello) => Err(format!("the target reset ({hello:?})")),
        }
    }

    /// One frame granted, until its FrameDone.
    fn grant(&mut self, got: &mut Collected) -> Result<(), String> {
        let (grant, until, mut done) = frame_grant(self.frame, self.now);
        self.link.send(grant).map_err(|e| e.to_string())?;
        self.exchange(got, Some(&mut done))?;
        self.frame = self.frame.wrapping_add(1);
        self.now = until;
        Ok(())
    }

    /// The messages that uplink `bytes` as setup `setup`.
    pub fn setup_messages(setup: u16, bytes: &[u8]) -> Vec<HostToTarget> {
        let mut msgs = vec![HostToTarget::LanderBegin {
            setup,
            len: bytes.len() as u32,
            crc32: flight_app::lander_crc32(bytes),
        }];
        for (i, chunk) in bytes.chunks(LANDER_CHUNK_MAX).enumerate() {
            msgs.push(HostToTarget::LanderChunk {
                setup,
                offset: (i * LANDER_CHUNK_MAX) as u32,
                bytes: heapless::Vec::from_slice(chunk).expect("a chunk fits its message"),
            });
        }
        msgs
    }

    /// Encodes `setup`.
    pub fn encode(setup: &LanderSetup) -> Result<Vec<u8>, String> {
        let mut buf = vec![0u8; SETUP_BUFFER_BYTES];
        let n = ::lander::setup::encode(setup, &mut buf)
            .map_err(|e| format!("the setup does not encode: {e:?}"))?;
        buf.truncate(n);
        Ok(buf)
    }

    /// Sends raw setup messages (tests send damaged ones) as setup `setup` and waits for its
    /// acceptance (Ok) or refusal (Err, the reason).
    pub fn uplink(
        &mut self,
        setup: u16,
        msgs: Vec<HostToTarget>,
    ) -> Result<Result<LanderReport, LanderRefusal>, String> {
        self.setup = setup;
        let mut got = Collected::default();
        for batch in msgs.chunks(CHUNKS_PER_BATCH) {
            for m in batch {
                self.link.send(m.clone()).map_err(|e| e.to_string())?;
            }
            self.exchange(&mut got, None)?;
        }
        let mut frames = 0;
        while got.accepted.is_none() && got.refused.is_none() {
            if frames >= MAX_FRAMES_PER_STEP {
                return Err(format!("setup {setup}: no answer after {frames} frames"));
            }
            self.grant(&mut got)?;
            frames += 1;
        }
        self.health_events.append(&mut got.health);
        Ok(match (got.refused, got.accepted) {
            (Some(r), _) => Err(r),
            (None, Some(a)) => Ok(a),
            (None, None) => unreachable!("the loop waits for one"),
        })
    }

    /// Uplinks `setup` as the next setup; its acceptance.
    pub fn load(&mut self, setup: &LanderSetup) -> Result<LanderReport, String> {
        let bytes = Self::encode(setup)?;
        let id = self.setup.wrapping_add(1).max(1);
        let accepted = self
            .uplink(id, Self::setup_messages(id, &bytes))?
            .map_err(|r| format!("the target refused setup {id}: {r:?}"))?;
        self.seq = 0;
        self.seen = 0;
        self.sent_comms = None;
        self.sent_onboard.clear();
        self.transcript.logs.push(Vec::new());
        self.costs.setups += 1;
        self.costs.setup_bytes.push(bytes.len() as u32);
        if let LanderReport::Accepted { build_ticks, .. } = accepted {
            self.costs.build_ticks.push(build_ticks);
        }
        Ok(accepted)
    }

    /// The messages that carry a product list (parts of at most
    /// [`LANDER_PRODUCTS_PER_MESSAGE`], in order; an empty list is one empty part).
    pub fn product_messages(setup: u16, products: &[DataProduct]) -> Vec<HostToTarget> {
        let total = products.len().min(usize::from(u8::MAX)) as u8;
        let mut out = Vec::new();
        let mut first = 0usize;
        loop {
            let part = products
                .get(first..(first + LANDER_PRODUCTS_PER_MESSAGE).min(products.len()))
                .unwrap_or(&[]);
            out.push(HostToTarget::LanderInput {
                setup,
                input: LanderInput::Products {
                    first: first.min(usize::from(u8::MAX)) as u8,
                    total,
                    products: part.iter().map(product_to_wire).collect(),
                },
            });
            first += LANDER_PRODUCTS_PER_MESSAGE;
            if first >= products.len() {
                return out;
            }
        }
    }

    /// Sends the shadow's link model and product list where the target's differ (before the
    /// step that sees them; a refusal ends that step's exchange).
    fn send_inputs(&mut self, exec: &Autonomy) -> Result<(), String> {
        let comms = exec.comms().copied();
        let mut msgs = Vec::new();
        if comms != self.sent_comms {
            msgs.push(HostToTarget::LanderInput {
                setup: self.setup,
                input: LanderInput::Comms(comms.as_ref().map(comms_to_wire)),
            });
            self.sent_comms = comms;
        }
        if exec.onboard() != self.sent_onboard.as_slice() {
            msgs.extend(Self::product_messages(self.setup, exec.onboard()));
            self.sent_onboard = exec.onboard().to_vec();
        }
        for m in msgs {
            self.inputs_sent += 1;
            self.link.send(m).map_err(|e| e.to_string())?;
        }
        Ok(())
    }

    /// Sends `msgs` (link or data inputs) and grants `frames` frames: the target's refusal,
    /// if it made one (an accepted input is not answered).
    pub fn input_raw(
        &mut self,
        msgs: Vec<HostToTarget>,
        frames: u32,
    ) -> Result<Option<LanderRefusal>, String> {
        for m in msgs {
            self.link.send(m).map_err(|e| e.to_string())?;
        }
        let mut got = Collected::default();
        for _ in 0..frames {
            self.grant(&mut got)?;
            if got.refused.is_some() {
                break;
            }
        }
        Ok(got.refused)
    }

    /// Sends step `seq` of the current setup and grants frames until its answer (or a
    /// refusal): the target's decisions, its directive, and the answer.
    pub fn step_raw(
        &mut self,
        seq: u32,
        observation: &Observation,
    ) -> Result<Result<StepAnswer, LanderRefusal>, String> {
        self.link
            .send(HostToTarget::LanderStep {
                setup: self.setup,
                seq,
                observation: observation_to_wire(observation),
            })
            .map_err(|e| e.to_string())?;
        let mut got = Collected::default();
        let mut frames = 0u32;
        while got.answer.is_none() && got.refused.is_none() {
            if frames >= MAX_FRAMES_PER_STEP {
                return Err(format!("no answer from the target after {frames} frames"));
            }
            self.grant(&mut got)?;
            frames += 1;
        }
        // Named by the step it came in, so an overrun can be traced to its call.
        let setup = self.setup;
        self.health_events.extend(got.health.drain(..).map(|h| {
            format!(
                "{h} (setup {setup}, step {seq}: {:?}, frame {frames} of the step)",
                observation.event
            )
        }));
        if let Some(r) = got.refused {
            return Ok(Err(r));
        }
        let answer = got.answer.expect("the loop waits for it");
        let LanderReport::Answer { directive, .. } = answer else {
            unreachable!("an answer")
        };
        let directive = directive_from_wire(&directive)
            .map_err(|k| format!("the target answered an unknown primitive kind {}", k.0))?;
        let decisions = got.decisions.into_iter().map(|(_, d)| d).collect();
        Ok(Ok((decisions, directive, answer, frames)))
    }
}

impl StepWatch for EmulatedLander {
    fn built(
        &mut self,
        config: ExecConfig,
        model: &HtnModel,
        network: &FlatNetwork,
        timeline: &TimelinePlacement,
        context: &::lander::assessor::ScienceContext,
        learned: &Learned,
    ) -> Result<(), String> {
        let mut setup = LanderSetup {
            config,
            primitives: model.primitives.clone(),
            network: network.clone(),
            timeline: timeline.clone(),
            context: context.clone(),
            learned: learned.clone(),
        };
        if let Some(perturb) = self.perturb_setup {
            perturb(&mut setup);
        }
        self.load(&setup).map(|_| ())
    }

    fn stepped(
        &mut self,
        observation: &Observation,
        directive: &Directive,
        exec: &Autonomy,
    ) -> Result<(), String> {
        let step = self.step_no;
        self.step_no += 1;
        let at = observation.now.0;
        let (setup, seq_now) = (self.setup, self.seq);
        let verdict = move |what: &str, why: String| {
            format!(
                "{what} at step {step} (setup {setup}, step {seq_now} of it, mission time {:.3} h): {why}",
                at as f64 / 3.6e9
            )
        };
        let diverged = move |why: String| verdict("DIVERGED", why);
        let seq = self.seq;
        if let Err(e) = self.send_inputs(exec) {
            return Err(verdict("NO ANSWER", e));
        }
        let (decisions, got, answer, frames) = match self.step_raw(seq, observation) {
            Ok(Ok(a)) => a,
            Ok(Err(r)) => {
                return Err(diverged(format!(
                    "the target refused the step or its inputs: {r:?}"
                )))
            }
            // The link or the target failed: no answer to compare.
            Err(e) => return Err(verdict("NO ANSWER", e)),
        };
        self.seq += 1;
        let shadow = exec.log().get(self.seen..).unwrap_or(&[]);
        if let Some(log) = self.transcript.logs.last_mut() {
            log.extend_from_slice(&decisions);
        }
        self.transcript.directives.push(got);
        if decisions != shadow {
            return Err(diverged(format!(
                "decisions: target {decisions:?}, native {shadow:?}"
            )));
        }
        if got != *directive {
            return Err(diverged(format!(
                "directive: target {got:?}, native {directive:?}"
            )));
        }
        let LanderReport::Answer {
            log_len,
            ticks,
            windows,
            ..
        } = answer
        else {
            unreachable!("an answer")
        };
        if usize::from(log_len) != exec.log().len() {
            return Err(diverged(format!(
                "log length: target {log_len}, native {}",
                exec.log().len()
            )));
        }
        self.seen = exec.log().len();
        // Costs.
        let c = &mut self.costs;
        c.steps += 1;
        c.frames += u64::from(frames);
        c.total_ticks += u64::from(ticks);
        c.worst_windows = c.worst_windows.max(windows);
        c.worst_frames = c.worst_frames.max(frames);
        let sol = (at / sim::SOL_US) as usize;
        if c.ticks_per_sol.len() <= sol {
            c.ticks_per_sol.resize(sol + 1, 0);
        }
        c.ticks_per_sol[sol] += u64::from(ticks);
        let planned = decisions.iter().find_map(|d| match d.kind {
            ::lander::executor::DecisionKind::ReplanStarted(r) => Some(format!("{r:?}")),
            _ => None,
        });
        if planned.is_some() {
            c.plans.push(StepCost {
                step,
                at_us: at,
                ticks,
                guest_instructions: (f64::from(ticks) * INSTRUCTIONS_PER_TICK).round() as u64,
                windows,
                frames,
                explored: exec.last_search().explored,
                planned,
            });
        }
        Ok(())
    }
}

/// A step's answer: the decisions logged since the last answer, the directive, the answer as
/// it came, and the frames granted until it came.
pub type StepAnswer = (Vec<Decision>, Directive, LanderReport, u32);

/// An emulated run: the simulation's result, and what the target cost.
#[derive(Debug)]
pub struct EmulatedRun {
    pub result: RunResult,
    pub costs: EmulatedCosts,
    pub transcript: Transcript,
    pub health_events: Vec<String>,
}

impl EmulatedLander {
    /// Runs `s` under `config` with the executor on this target (a new setup at the start:
    /// runs can follow each other on one booted target). A divergence from the native shadow,
    /// or a target that stops answering, is an error naming the step.
    pub fn run(&mut self, s: &Scenario, config: &RunConfig) -> Result<EmulatedRun, String> {
        self.transcript = Transcript::default();
        self.costs = EmulatedCosts::default();
        self.health_events.clear();
        self.step_no = 0;
        let started = Instant::now();
        let result = sim::run_watched(s, config, self)?;
        self.costs.wall = started.elapsed();
        Ok(EmulatedRun {
            result,
            costs: std::mem::take(&mut self.costs),
            transcript: std::mem::take(&mut self.transcript),
            health_events: std::mem::take(&mut self.health_events),
        })
    }

    /// The setup in force and the number its next step must have (tests send raw steps).
    pub fn position(&self) -> (u16, u32) {
        (self.setup, self.seq)
    }
}

/// Runs `s` under `config` with the executor on the emulated target `firmware` (booted for the
/// run, QEMU ended by its PID after it).
pub fn run_emulated(
    s: &Scenario,
    config: &RunConfig,
    firmware: &FirmwareImage,
) -> Result<EmulatedRun, String> {
    EmulatedLander::boot(firmware)?.run(s, config)
}

/// `hil lander run FILE --emulated`: the checked run (Ok(Ok)), a run that diverged or whose
/// target stopped answering (Ok(Err(verdict))), or bad input (Err).
pub fn cli_run(
    s: &Scenario,
    args: &crate::lander::LanderRunArgs,
) -> Result<Result<crate::lander::LanderOutcome, String>, String> {
    let fw = firmware_for(args.firmware.as_deref())?;
    let seed = args.seed.unwrap_or(s.run.seed);
    let strategy = args.strategy.unwrap_or(s.run.strategy);
    let run = match run_emulated(s, &RunConfig::new(strategy.strategy(), seed), &fw) {
        Ok(r) => r,
        Err(verdict) => return Ok(Err(verdict)),
    };
    let verdicts = lander_sim::expect::check_all(s, &run.result);
    print!("{}", costs_summary(&run));
    Ok(Ok(crate::lander::LanderOutcome {
        scenario: s.name.clone(),
        seed,
        strategy,
        result: run.result,
        verdicts,
        wall: run.costs.wall,
    }))
}

/// The firmware `--firmware` names, or the one built now.
pub fn firmware_for(elf: Option<&std::path::Path>) -> Result<FirmwareImage, String> {
    match elf {
        Some(elf) => {
            if !elf.exists() {
                return Err(format!(
                    "--firmware {}: no such file (give the firmware ELF, or leave --firmware out to build it)",
                    elf.display()
                ));
            }
            FirmwareImage::open(elf).map_err(|e| e.to_string())
        }
        None => {
            eprintln!("building firmware (cargo, powerpc-unknown-linux-gnu) ...");
            crate::firmware::build().map_err(|e| e.to_string())
        }
    }
}

/// The emulated costs, readable.
pub fn costs_summary(run: &EmulatedRun) -> String {
    let c = &run.costs;
    let mission_s = run.result.end_us as f64 / 1e6;
    let wall_s = c.wall.as_secs_f64();
    let mut out = format!(
        "  emulated: every decision identical to the native shadow ({} steps, {} setup(s) of {:?} bytes, built in {:?} ticks); {} frames granted\n",
        c.steps, c.setups, c.setup_bytes, c.build_ticks, c.frames
    );
    out += &format!(
        "  emulated wall time {wall_s:.1} s for {:.2} sols of mission time: {:.0}x real time\n",
        mission_s / (sim::SOL_US as f64 / 1e6),
        mission_s / wall_s.max(1e-9)
    );
    out += &format!(
        "  planner CPU: {} ticks in all ({} guest instructions); per sol: {:?} ticks (of {} ticks of planner windows a sol)\n",
        c.total_ticks,
        (c.total_ticks as f64 * INSTRUCTIONS_PER_TICK).round() as u64,
        c.ticks_per_sol,
        windows_ticks_per_sol()
    );
    for p in &c.plans {
        out += &format!(
            "  plan at step {} ({:.2} h, {}): {} explorations, {} guest instructions, {} planner windows, latency {:.0} ms of target time ({} frames)\n",
            p.step,
            p.at_us as f64 / 3.6e9,
            p.planned.as_deref().unwrap_or("?"),
            p.explored,
            p.guest_instructions,
            p.windows,
            p.frames as f64 * FRAME_US as f64 / 1e3,
            p.frames
        );
    }
    if !run.health_events.is_empty() {
        out += &format!("  health events: {:?}\n", run.health_events);
    }
    out
}

/// The planner partition's window ticks in one sol of target time (its CPU capacity: the
/// window of every 10 ms major frame).
pub fn windows_ticks_per_sol() -> u64 {
    let frames_per_sol = sim::SOL_US / FRAME_US;
    frames_per_sol * u64::from(kernel_config::system::PLANNER_WINDOW_TICKS)
}

/// The metrics of a lander mission (`scenario`, relative to the repository) with its executor
/// on the emulated target, for `budgets.toml`'s `lander:` sources: guest instructions of the
/// first plan (`first_plan_instructions`: at the mission's start, the full plan) and of the
/// costliest plan or replan (`worst_plan_instructions`), the most frames a step took to be
/// answered (`worst_step_frames`: the planning latency, 10 ms of target time each), the
/// planner CPU of the busiest sol (`worst_sol_planner_ticks`), and the CPU to decode, validate
/// and build the first setup (`setup_build_ticks`), and the guest instructions of the downlink
/// manager's solve of the run's products over its downlinks (`downlink_solve_instructions`,
/// [`mission_downlink_problem`]). The run must decide as natively.
pub fn lander_metrics(
    scenario: &str,
    firmware: &FirmwareImage,
) -> Result<std::collections::BTreeMap<String, u64>, String> {
    let path = crate::repo_root().join(scenario);
    let s = crate::study::load_scenario(&path).map_err(|d| d.render())?;
    let mut target = EmulatedLander::boot(firmware)?;
    let run = target.run(&s, &RunConfig::new(s.run.strategy.strategy(), s.run.seed))?;
    let solve = target.solve_downlink(&mission_downlink_problem(&run.result, &s))?;
    let c = &run.costs;
    let mut m = std::collections::BTreeMap::new();
    let plan = |p: &StepCost| p.guest_instructions;
    m.insert(
        "first_plan_instructions".into(),
        c.plans.first().map_or(0, plan),
    );
    m.insert(
        "worst_plan_instructions".into(),
        c.plans.iter().map(plan).max().unwrap_or(0),
    );
    m.insert("worst_step_frames".into(), u64::from(c.worst_frames));
    m.insert(
        "worst_sol_planner_ticks".into(),
        c.ticks_per_sol.iter().copied().max().unwrap_or(0),
    );
    m.insert(
        "downlink_solve_instructions".into(),
        solve.guest_instructions,
    );
    m.insert(
        "setup_build_ticks".into(),
        c.build_ticks.first().copied().map_or(0, u64::from),
    );
    Ok(m)
}

/// A downlink problem solved on the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct DownlinkSolve {
    pub value: u64,
    pub proven: bool,
    /// Knapsack nodes (the exact surrogate checks' included).
    pub nodes: u32,
    /// The planner partition's CPU to load and solve it, and the guest instructions that is.
    pub ticks: u32,
    pub guest_instructions: u64,
    pub windows: u16,
}

impl EmulatedLander {
    /// Uplinks `problem` (as a setup-like blob: it ends the executor in force) and grants
    /// frames until the downlink manager's answer.
    pub fn solve_downlink(
        &mut self,
        problem: &::lander::setup::DownlinkProblem,
    ) -> Result<DownlinkSolve, String> {
        let mut buf = vec![0u8; SETUP_BUFFER_BYTES];
        let n = ::lander::setup::encode_downlink_problem(problem, &mut buf)
            .map_err(|e| format!("the problem does not encode: {e:?}"))?;
        buf.truncate(n);
        let id = self.setup.wrapping_add(1).max(1);
        self.setup = id;
        let mut got = Collected::default();
        for batch in Self::setup_messages(id, &buf).chunks(CHUNKS_PER_BATCH) {
            for m in batch {
                self.link.send(m.clone()).map_err(|e| e.to_string())?;
            }
            self.exchange(&mut got, None)?;
        }
        let mut solved = None;
        let mut frames = 0;
        while solved.is_none() {
            if let Some(r) = got.refused {
                return Err(format!("the target refused the downlink problem: {r:?}"));
            }
            if frames >= MAX_FRAMES_PER_STEP {
                return Err(format!("no downlink answer after {frames} frames"));
            }
            let setup = self.setup;
            let (end, delivered) = {
                self.link
                    .send(HostToTarget::TimeGrant {
                        frame: self.frame,
                        now: self.now,
                        until: self.now.saturating_add(FRAME_US),
                    })
                    .map_err(|e| e.to_string())?;
                let frame = self.frame;
                let mut done = |m: &TargetToHost| matches!(m, TargetToHost::FrameDone { frame: f, .. } if *f == frame);
                self.link
                    .exchange(&mut self.target, Some(&mut done))
                    .map_err(|e| format!("the link: {e}"))?
            };
            self.frame = self.frame.wrapping_add(1);
            self.now = self.now.saturating_add(FRAME_US);
            frames += 1;
            for msg in &delivered {
                self.target.observe(msg);
                got.take(setup, msg);
                if let TargetToHost::Lander(LanderReport::DownlinkSolved {
                    setup: s,
                    value,
                    proven,
                    nodes,
                    ticks,
                    windows,
                }) = *msg
                {
                    if s == setup {
                        solved = Some(DownlinkSolve {
                            value,
                            proven,
                            nodes,
                            ticks,
                            guest_instructions: (f64::from(ticks) * INSTRUCTIONS_PER_TICK).round()
                                as u64,
                            windows,
                        });
                    }
                }
            }
            if let Exchanged::TargetReset(hello) = end {
                return Err(format!("the target reset ({hello:?})"));
            }
        }
        Ok(solved.expect("the loop waits for it"))
    }
}

/// A downlink manager's problem at mission size: every data product a native run of `s` made
/// (its sizes, values, tiers and creation times) over the downlinks that run made (each from its
/// dispatch to its planned end, with the scenario's rate, radio power, overhead and thermal
/// limit; at most 16), each Earth-in-view period's downlinks paying from its `per_sol_wh`
/// allocation (the scenario's).
pub fn mission_downlink_problem(
    result: &RunResult,
    s: &Scenario,
) -> ::lander::setup::DownlinkProblem {
    use ::lander::downlink::{DataProduct, DownlinkOpportunity, SolAllocation};
    let mut p = ::lander::setup::DownlinkProblem::default();
    for x in result
        .products
        .iter()
        .take(::lander::capacity::MAX_DATA_PRODUCTS)
    {
        let _ = p.products.push(DataProduct {
            size_bytes: x.bytes,
            value: x.value_milli,
            created_at: MissionTimeUs(x.created_us),
            tier: x.tier,
        });
    }
    let period = s.comms.period_h * sim::HOUR_US;
    for d in result
        .downlinks
        .iter()
        .take(::lander::capacity::MAX_DOWNLINKS)
    {
        let _ = p.opportunities.push(DownlinkOpportunity {
            start: MissionTimeUs(d.dispatched_us),
            end: MissionTimeUs(d.end_us.max(d.dispatched_us)),
            overhead_us: s.comms.overhead_min * sim::MIN_US,
            sol: (d.dispatched_us / period) as u16,
            rate_bps: s.comms.rate_bps,
            radio_power_mw: s.comms.radio_w * 1_000,
            thermal_limit_us: s.comms.thermal_limit_h * sim::HOUR_US,
        });
    }
    let periods = p.opportunities.last().map_or(0, |o| o.sol + 1);
    for sol in 0..periods {
        let _ = p.allocations.push(SolAllocation {
            sol,
            energy_mj: s.comms.per_sol_wh * sim::WH_MJ,
        });
    }
    p
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_missing_firmware_is_a_clear_error() {
        let Err(e) =
            super::firmware_for(Some(std::path::Path::new("/nonexistent/rad750-firmware")))
        else {
            panic!("no firmware, yet an image");
        };
        assert!(
            e.contains("--firmware /nonexistent/rad750-firmware: no such file"),
            "{e}"
        );
    }
}
