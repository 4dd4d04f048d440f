//! Campaigns: many seeded variants of one mission scenario, each with one warm reset at a
//! random point, run in parallel and merged into one report (`hil campaign`).
//!
//! Run `i` of a campaign with base seed `S` uses seed `S + i` for everything random in that run
//! (the scenario's own noise and link faults as well as the variant): from it the campaign
//! draws, deterministically, a warm-reset time uniformly within the reset window (default: the
//! mission span minus its last 20 %), a recovery duration (default 3 min, or uniform within a
//! range), and whether the reset lands at a frame boundary or in the middle of a frame (half
//! and half). A mid-frame reset on the native target is a torn checkpoint: the reset lands
//! while the last frame's checkpoint is being written (see
//! [`crate::mission::target::CheckpointDamage`]). On the emulated target it is a real warm
//! reset at a seeded point of the executive's work in the frame at the reset time, carried out
//! by the target's kernel (see [`MissionTarget::arm_mid_frame_reset`]); the run's `mid_frame`
//! lines say where it landed (in the step, in the checkpoint write and how much of it was
//! copied, or after the frame's work) and which checkpoint the restart restored. A variant is
//! fully described by
//! (scenario, run index, seed, reset time, recovery, reset point), and
//! `hil campaign <scenario> --seed S --only I` runs exactly that variant again.
//!
//! Every run is checked against the scenario's own expectations (which a campaign scenario
//! writes to hold for a reset at any time, e.g. `scenarios/flyby-campaign.toml`) and against
//! the campaign's own checks:
//! - the run ends without a driver error;
//! - every reset is followed, before the next one, by "plan restored from checkpoint" (no
//!   lost checkpoint);
//! - the variant's reset happened.
//!
//! `--shard k/n` (1-based) runs the indices `i` with `i % n == k - 1`; the shard reports
//! (`--report`) merge with `--merge` into the report the unsharded campaign would have written
//! (wall times aside). Results are always in run-index order, whatever order the worker threads
//! finish in. The workers are [`run_pool`]'s (why it is written with the standard library only
//! is said there): a run that panics, or whose QEMU dies, is one failed run with its reason,
//! and the campaign goes on.
use std::collections::BTreeMap;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use fsw_bridge::MissionTimeUs;
use serde::{Deserialize, Serialize};

use crate::mission::metrics;
use crate::mission::report::MissionReport;
use crate::mission::rng::Rng;
use crate::mission::runner::{make_target, prepare, run};
use crate::mission::target::{CheckpointDamage, MissionTarget, NativeTarget};
use crate::options::RunOptions;
use crate::scenario::TargetKind;
use crate::time::{fmt_time, parse_duration, parse_time, Epoch, TimeText};

/// Default recovery (fault protection running before the flight software restarts).
pub const DEFAULT_RECOVERY_US: u64 = 180_000_000;
/// The label that proves a restart restored the plan.
pub const RESTORED_LABEL: &str = "plan restored from checkpoint";

const SEC: u64 = 1_000_000;

/// `--shard k/n`: this machine runs the indices `i` with `i % n == k - 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub k: u32,
    pub n: u32,
}

impl Shard {
    pub fn parse(text: &str) -> Result<Self, String> {
        let bad = || format!("bad shard {text:?}: expected k/n with 1 <= k <= n, e.g. 2/4");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (k, n): (u32, u32) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if n == 0 || k == 0 || k > n {
            return Err(bad());
        }
        Ok(Self { k, n })
    }

    pub fn contains(&self, run: u32) -> bool {
        run % self.n == self.k - 1
    }

    /// The run indices of this shard among `runs`.
    pub fn runs(&self, runs: u32) -> Vec<u32> {
        (0..runs).filter(|i| self.contains(*i)).collect()
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

/// A time window `A..B` (mission times, B excluded).
pub fn parse_window(text: &str) -> Result<(MissionTimeUs, MissionTimeUs), String> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| format!("bad window {text:?}: expected A..B, e.g. 10:00..11:05"))?;
    let t = |x: &str| parse_time(&TimeText::from(x), Epoch::default());
    let (a, b) = (t(a)?, t(b)?);
    if b <= a {
        return Err(format!(
            "bad window {text:?}: the end must be after the start"
        ));
    }
    Ok((a, b))
}

/// A recovery: one duration (`3min`) or a range drawn from uniformly (`1min..5min`).
pub fn parse_recovery(text: &str) -> Result<(u64, u64), String> {
    match text.split_once("..") {
        Some((a, b)) => {
            let (a, b) = (parse_duration(&a.into())?, parse_duration(&b.into())?);
            if b < a {
                return Err(format!(
                    "bad recovery range {text:?}: the end is before the start"
                ));
            }
            Ok((a, b))
        }
        None => {
            let d = parse_duration(&text.into())?;
            Ok((d, d))
        }
    }
}

fn fmt_duration(us: u64) -> String {
    if us.is_multiple_of(SEC) {
        format!("{}s", us / SEC)
    } else {
        format!("{}ms", us / 1000)
    }
}

fn fmt_recovery((a, b): (u64, u64)) -> String {
    if a == b {
        fmt_duration(a)
    } else {
        format!("{}..{}", fmt_duration(a), fmt_duration(b))
    }
}

/// Where the reset of a variant lands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ResetPoint {
    /// Between two frames.
    FrameBoundary,
    /// Inside a frame: a torn checkpoint natively, a reset at a point of the executive's work
    /// on the emulated target.
    MidFrame,
}

impl ResetPoint {
    pub fn name(self) -> &'static str {
        match self {
            ResetPoint::FrameBoundary => "frame-boundary",
            ResetPoint::MidFrame => "mid-frame",
        }
    }
}

/// Why a campaign run failed.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Failure {
    /// The run did not reach its end: the target or the link failed, or `hil` panicked.
    RunError { error: String },
    /// One of the scenario's expectations did not hold.
    Expectation {
        index: usize,
        what: String,
        detail: String,
    },
    /// The variant's warm reset never happened.
    ResetMissing { at: String },
    /// A restart came up without the plan from a checkpoint.
    LostCheckpoint {
        reset: String,
        at: String,
        restart: String,
    },
    /// A task definition sent more commands than its responses allow.
    BoundExceeded {
        task: String,
        commands: u32,
        allowed: u32,
    },
    /// The mission failed but the report names no cause (no task failed with a reason, the
    /// autonomy gave up on nothing).
    NoNamedCause,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::RunError { error } => write!(f, "run error: {error}"),
            Failure::Expectation { index, what, detail } => {
                write!(f, "expect[{index}] {what}: {detail}")
            }
            Failure::ResetMissing { at } => {
                write!(f, "campaign: the warm reset at {at} did not happen")
            }
            Failure::LostCheckpoint {
                reset,
                at,
                restart,
            } => write!(
                f,
                "campaign: lost checkpoint: no \"{RESTORED_LABEL}\" after the {reset} at {at} (restart {restart})"
            ),
            Failure::BoundExceeded {
                task,
                commands,
                allowed,
            } => write!(
                f,
                "campaign: {task} sent {commands} commands, more than its bound allows ({allowed})"
            ),
            Failure::NoNamedCause => write!(
                f,
                "campaign: the mission failed and the report names no cause"
            ),
        }
    }
}

/// How a misbehaving subsystem treats a command (campaigns with `--misbehave`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MisbehaviourMode {
    /// Refuses it.
    Reject,
    /// Tries and fails.
    Fail,
    /// Never answers.
    Silent,
    /// Answers Ok and does nothing ("accepted but never completed").
    NoEffect,
    /// Answers Ok but ends in another state than commanded.
    WrongState,
}

impl MisbehaviourMode {
    pub const ALL: [MisbehaviourMode; 5] = [
        MisbehaviourMode::Reject,
        MisbehaviourMode::Fail,
        MisbehaviourMode::Silent,
        MisbehaviourMode::NoEffect,
        MisbehaviourMode::WrongState,
    ];
}

/// A subsystem that misbehaves from `from` to the end of the mission: every dispatch of
/// `opcode` meets `mode` (for `WrongState`, the attitude ends at value `value`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Misbehaviour {
    pub opcode: u16,
    pub mode: MisbehaviourMode,
    pub from: String,
    pub from_us: u64,
    /// The attitude value a `WrongState` command ends at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<u16>,
}

impl Misbehaviour {
    /// Drawn from `seed`: one of `opcodes` (the network's commands), a mode, a start in
    /// `window`. `attitude_values` is the GNC's attitude value count when `gnc_opcode` is its
    /// attain opcode (a wrong state needs a value to end at; other subsystems get `NoEffect`).
    pub fn derive(
        seed: u64,
        opcodes: &[u16],
        window: (MissionTimeUs, MissionTimeUs),
        gnc: Option<(u16, u16)>,
    ) -> Option<Self> {
        let mut rng = Rng::new(seed).fork(0x3b);
        let opcode = *opcodes.get(rng.below(opcodes.len() as u64) as usize)?;
        let mut mode = MisbehaviourMode::ALL[rng.below(5) as usize];
        let span_s = (window.1 .0 - window.0 .0).div_ceil(SEC).max(1);
        let from = MissionTimeUs(window.0 .0 + rng.below(span_s) * SEC);
        let value = match (mode, gnc) {
            (MisbehaviourMode::WrongState, Some((attain, values)))
                if attain == opcode && values > 0 =>
            {
                Some(rng.below(u64::from(values)) as u16)
            }
            (MisbehaviourMode::WrongState, _) => {
                mode = MisbehaviourMode::NoEffect;
                None
            }
            _ => None,
        };
        Some(Self {
            opcode,
            mode,
            from: fmt_time(from),
            from_us: from.0,
            value,
        })
    }

    pub fn describe(&self) -> String {
        let mode = match self.mode {
            MisbehaviourMode::Reject => "rejects",
            MisbehaviourMode::Fail => "fails",
            MisbehaviourMode::Silent => "never answers",
            MisbehaviourMode::NoEffect => "accepts and ignores",
            MisbehaviourMode::WrongState => "completes in the wrong state",
        };
        format!(
            "from {} the subsystem {mode} every command {:#06x}{}",
            self.from,
            self.opcode,
            self.value
                .map(|v| format!(" (ends at value {v})"))
                .unwrap_or_default()
        )
    }

    /// The command fault that plays it.
    fn fault(&self) -> crate::mission::plan::CommandFault {
        use crate::mission::sim::CommandFate;
        use fsw_bridge::{CommandStatus, StateValue};
        crate::mission::plan::CommandFault {
            opcode: fsw_bridge::Opcode(self.opcode),
            skip: None,
            probability: 1.0,
            fate: match self.mode {
                MisbehaviourMode::Reject => CommandFate::Answer(CommandStatus::Rejected),
                MisbehaviourMode::Fail => CommandFate::Answer(CommandStatus::Failed(1)),
                MisbehaviourMode::Silent => CommandFate::Silent,
                MisbehaviourMode::NoEffect => CommandFate::NoEffect,
                MisbehaviourMode::WrongState => {
                    CommandFate::WrongState(StateValue::Enum(self.value.unwrap_or(0)))
                }
            },
            spent: false,
        }
    }
}

/// One variant of a campaign: everything needed to run it again.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Variant {
    pub run: u32,
    pub seed: u64,
    pub reset_at: String,
    pub reset_at_us: u64,
    pub recovery: String,
    pub recovery_us: u64,
    pub reset_point: ResetPoint,
    /// Seed of the mid-frame instant (what the target tears, and where).
    pub mid_frame_seed: u64,
    /// Test knob: every checkpoint destroyed at the reset (recovery must fail).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub destroy_checkpoints: bool,
    /// With `--misbehave`: the subsystem that misbehaves in this run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub misbehaviour: Option<Misbehaviour>,
}

impl Variant {
    /// Derive run `run` of a campaign with base seed `base_seed`.
    pub fn derive(
        run: u32,
        base_seed: u64,
        window: (MissionTimeUs, MissionTimeUs),
        recovery: (u64, u64),
    ) -> Self {
        let seed = base_seed.wrapping_add(u64::from(run));
        let mut rng = Rng::new(seed).fork(0xca);
        let span_s = (window.1 .0 - window.0 .0).div_ceil(SEC).max(1);
        let reset_at = MissionTimeUs(window.0 .0 + rng.below(span_s) * SEC);
        let recovery_us = if recovery.1 > recovery.0 {
            let choices = (recovery.1 - recovery.0) / SEC + 1;
            recovery.0 + rng.below(choices) * SEC
        } else {
            recovery.0
        };
        let mid_frame = rng.chance(0.5);
        let mid_frame_seed = rng.next_u64();
        Self {
            run,
            seed,
            reset_at: fmt_time(reset_at),
            reset_at_us: reset_at.0,
            recovery: fmt_duration(recovery_us),
            recovery_us,
            reset_point: if mid_frame {
                ResetPoint::MidFrame
            } else {
                ResetPoint::FrameBoundary
            },
            mid_frame_seed,
            destroy_checkpoints: false,
            misbehaviour: None,
        }
    }

    /// "run 7 (seed 8): warm reset at 10:31:12, mid-frame, recovery 180s".
    pub fn describe(&self) -> String {
        format!(
            "run {} (seed {}): warm reset at {}, {}, recovery {}{}{}",
            self.run,
            self.seed,
            self.reset_at,
            self.reset_point.name(),
            self.recovery,
            if self.destroy_checkpoints {
                ", every checkpoint destroyed (test knob)"
            } else {
                ""
            },
            self.misbehaviour
                .as_ref()
                .map(|m| format!("; {}", m.describe()))
                .unwrap_or_default()
        )
    }
}

/// The outcome of one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    pub variant: Variant,
    pub passed: bool,
    /// Why it failed: a run error, failed expectations, the campaign's own checks.
    pub failures: Vec<Failure>,
    /// What the mid-frame reset did (empty for a frame-boundary reset).
    pub mid_frame: Vec<String>,
    /// The run's metrics, plus `frames` and `wall_time_ms`.
    pub metrics: BTreeMap<String, u64>,
    pub transcript_sha256: String,
    /// The as-executed timeline ("10:33:00 Instrument Flyby aborted"), for failed runs.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub timeline: Vec<String>,
}

/// min, median, 95th percentile and max of one metric over the runs that report it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Distribution {
    pub runs: usize,
    pub min: u64,
    pub median: u64,
    pub p95: u64,
    pub max: u64,
}

/// Nearest-rank percentile of sorted values (`p` in 1..=100).
pub fn percentile(sorted: &[u64], p: u32) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    let rank = (u64::from(p) * sorted.len() as u64).div_ceil(100).max(1) as usize;
    sorted[rank.min(sorted.len()) - 1]
}

pub fn distribution(values: &[u64]) -> Option<Distribution> {
    let mut v = values.to_vec();
    v.sort_unstable();
    Some(Distribution {
        runs: v.len(),
        min: *v.first()?,
        median: percentile(&v, 50),
        p95: percentile(&v, 95),
        max: *v.last()?,
    })
}

/// The merged statistics of a report.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CampaignStats {
    pub runs_present: usize,
    pub passed: usize,
    pub failed: usize,
    pub pass_rate: f64,
    pub metrics: BTreeMap<String, Distribution>,
    /// Run indices of the campaign with no result in this report (other shards).
    pub missing_runs: Vec<u32>,
}

/// The JSON report of a campaign (or of one shard of it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CampaignReport {
    pub scenario: String,
    /// The scenario file as given on the command line.
    pub scenario_file: String,
    pub target: TargetKind,
    /// Base seed: run i uses seed + i.
    pub seed: u64,
    /// Runs in the whole campaign.
    pub runs: u32,
    pub reset_window: String,
    pub recovery: String,
    /// Shards whose results this report holds ("1/2"); empty: the whole campaign.
    pub shards: Vec<String>,
    /// Set when the report holds one reproduced run (`--only`).
    pub only: Option<u32>,
    /// Every run had a misbehaving subsystem (`--misbehave`).
    #[serde(default)]
    pub misbehave: bool,
    pub results: Vec<RunResult>,
    #[serde(default)]
    pub stats: CampaignStats,
}

impl CampaignReport {
    fn compute_stats(&mut self) {
        let mut values: BTreeMap<String, Vec<u64>> = BTreeMap::new();
        for r in &self.results {
            for (k, v) in &r.metrics {
                values.entry(k.clone()).or_default().push(*v);
            }
        }
        let passed = self.results.iter().filter(|r| r.passed).count();
        let present: std::collections::BTreeSet<u32> =
            self.results.iter().map(|r| r.variant.run).collect();
        self.stats = CampaignStats {
            runs_present: self.results.len(),
            passed,
            failed: self.results.len() - passed,
            pass_rate: if self.results.is_empty() {
                0.0
            } else {
                passed as f64 / self.results.len() as f64
            },
            metrics: values
                .iter()
                .filter_map(|(k, v)| Some((k.clone(), distribution(v)?)))
                .collect(),
            missing_runs: if self.only.is_some() {
                Vec::new()
            } else {
                (0..self.runs).filter(|i| !present.contains(i)).collect()
            },
        };
    }

    pub fn passed(&self) -> bool {
        !self.results.is_empty() && self.results.iter().all(|r| r.passed)
    }

    /// The command line that runs `variant` again, exactly.
    pub fn reproduce(&self, variant: &Variant) -> String {
        format!(
            "hil campaign {} --seed {} --only {} --reset-window {} --recovery {}{}",
            self.scenario_file,
            self.seed,
            variant.run,
            self.reset_window,
            self.recovery,
            if self.target == TargetKind::Native {
                " --native"
            } else {
                ""
            }
        ) + if self.misbehave { " --misbehave" } else { "" }
    }

    /// Results without wall-clock-dependent numbers (for comparing campaigns).
    pub fn deterministic_results(&self) -> Vec<RunResult> {
        self.results
            .iter()
            .cloned()
            .map(|mut r| {
                r.metrics.remove("wall_time_ms");
                r
            })
            .collect()
    }
}

/// What to run.
#[derive(Clone, Debug)]
pub struct CampaignOptions {
    pub scenario: PathBuf,
    pub runs: u32,
    pub seed: u64,
    /// Force the native target (default: the scenario's target kind).
    pub native: bool,
    /// Worker threads (0: available parallelism).
    pub jobs: usize,
    pub shard: Option<Shard>,
    /// Reset window (default: the mission span minus its last 20 %).
    pub reset_window: Option<(MissionTimeUs, MissionTimeUs)>,
    /// Recovery range in microseconds (equal ends: fixed).
    pub recovery: (u64, u64),
    /// Run only this index (reproduce one variant).
    pub only: Option<u32>,
    /// Firmware ELF for the emulated target (default: build it once).
    pub firmware: Option<PathBuf>,
    /// Test knob: runs whose checkpoints are all destroyed at the reset (warm slots and NV);
    /// native only. Proves the campaign's checks notice a lost checkpoint.
    pub destroy_checkpoints_in: Vec<u32>,
    /// Every run also has a subsystem that misbehaves from a random time on (rejects, fails,
    /// never answers, ignores, or completes in the wrong state every command of one opcode).
    /// Such a run passes the campaign when it ends cleanly, no task sends more commands than
    /// its bounds allow, and a failed mission names its cause.
    pub misbehave: bool,
}

impl CampaignOptions {
    pub fn new(scenario: impl Into<PathBuf>, runs: u32, seed: u64) -> Self {
        Self {
            scenario: scenario.into(),
            runs,
            seed,
            native: false,
            jobs: 0,
            shard: None,
            reset_window: None,
            recovery: (DEFAULT_RECOVERY_US, DEFAULT_RECOVERY_US),
            only: None,
            firmware: None,
            destroy_checkpoints_in: Vec::new(),
            misbehave: false,
        }
    }
}

/// Everything a worker needs, resolved once.
struct Plan {
    scenario_file: PathBuf,
    native: bool,
    firmware: Option<PathBuf>,
}

/// The variants a campaign (or shard) runs, in run-index order.
pub fn variants(
    opts: &CampaignOptions,
    window: (MissionTimeUs, MissionTimeUs),
    misbehaving: &MisbehaviourChoices,
) -> Result<Vec<Variant>, String> {
    let indices: Vec<u32> = match (opts.only, opts.shard) {
        (Some(_), Some(_)) => return Err("--only and --shard do not go together".into()),
        (Some(i), None) => vec![i],
        (None, Some(s)) => s.runs(opts.runs),
        (None, None) => (0..opts.runs).collect(),
    };
    Ok(indices
        .into_iter()
        .map(|i| {
            let mut v = Variant::derive(i, opts.seed, window, opts.recovery);
            v.destroy_checkpoints = opts.destroy_checkpoints_in.contains(&i);
            if opts.misbehave {
                v.misbehaviour =
                    Misbehaviour::derive(v.seed, &misbehaving.opcodes, window, misbehaving.gnc);
            }
            v
        })
        .collect())
}

/// What a misbehaving subsystem can be drawn from: the opcodes the task network commands, and
/// the GNC's attain opcode with its attitude value count (for wrong-state attitudes).
#[derive(Clone, Debug, Default)]
pub struct MisbehaviourChoices {
    pub opcodes: Vec<u16>,
    pub gnc: Option<(u16, u16)>,
}

impl MisbehaviourChoices {
    fn of(plan: &crate::mission::plan::MissionPlan) -> Self {
        let mut opcodes: Vec<u16> = plan
            .network
            .network
            .tasks()
            .iter()
            .filter_map(|t| t.command.as_ref().map(|c| c.opcode.0))
            .collect();
        opcodes.sort_unstable();
        opcodes.dedup();
        let gnc = plan.scenario.spacecraft.gnc.as_ref().and_then(|g| {
            let values = plan.network.timeline(&g.attitude)?.values.len();
            Some((g.attain_opcode, values as u16))
        });
        Self { opcodes, gnc }
    }
}

/// Run a campaign (or one shard of it, or one variant). `progress` is called on the calling
/// thread once per finished run, in completion order; the report is in run-index order.
pub fn run_campaign(
    opts: &CampaignOptions,
    progress: &mut dyn FnMut(&RunResult),
) -> Result<CampaignReport, String> {
    let scenario = crate::scenario::load(&opts.scenario).map_err(|e| e.render())?;
    if scenario.mission.is_none() {
        return Err(format!(
            "{}: a campaign needs a mission scenario (with [mission])",
            opts.scenario.display()
        ));
    }
    let native = opts.native || scenario.target.kind == TargetKind::Native;
    let prepared = crate::mission::plan::MissionPlan::build(scenario).map_err(|e| e.render())?;
    let (start, end) = (prepared.start, prepared.end);
    let window = match opts.reset_window {
        Some(w) => w,
        None => (
            start,
            MissionTimeUs(start.0 + (end.0 - start.0) * 4 / 5 / SEC * SEC),
        ),
    };
    if window.0 < start || window.1 > end || window.1 <= window.0 {
        return Err(format!(
            "reset window {}..{} is not inside the mission ({} to {})",
            fmt_time(window.0),
            fmt_time(window.1),
            fmt_time(start),
            fmt_time(end)
        ));
    }
    if !native && !opts.destroy_checkpoints_in.is_empty() {
        return Err("destroying checkpoints is a native-target test knob".into());
    }
    let variants = variants(opts, window, &MisbehaviourChoices::of(&prepared))?;
    let firmware = match (&opts.firmware, native) {
        (_, true) => None,
        (Some(f), false) => Some(f.clone()),
        (None, false) => Some(crate::firmware::build().map_err(|e| e.to_string())?.elf),
    };
    let plan = Plan {
        scenario_file: opts.scenario.clone(),
        native,
        firmware,
    };
    let jobs = match opts.jobs {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        j => j,
    }
    .min(variants.len())
    .max(1);

    let results = run_pool(
        &variants,
        jobs,
        |v| run_variant(&plan, v),
        |v, panic| failed(v.clone(), format!("panicked: {panic}")),
        progress,
    )?;
    let mut report = CampaignReport {
        scenario: prepared.name().to_string(),
        scenario_file: opts.scenario.display().to_string(),
        target: if native {
            TargetKind::Native
        } else {
            TargetKind::Qemu
        },
        seed: opts.seed,
        runs: opts.runs,
        reset_window: format!("{}..{}", fmt_time(window.0), fmt_time(window.1)),
        recovery: fmt_recovery(opts.recovery),
        shards: opts.shard.iter().map(|s| s.to_string()).collect(),
        only: opts.only,
        misbehave: opts.misbehave,
        results,
        stats: CampaignStats::default(),
    };
    report.compute_stats();
    Ok(report)
}

fn failed(variant: Variant, error: String) -> RunResult {
    RunResult {
        variant,
        passed: false,
        failures: vec![Failure::RunError { error }],
        mid_frame: Vec::new(),
        metrics: BTreeMap::new(),
        transcript_sha256: String::new(),
        timeline: Vec::new(),
    }
}

/// Run one variant on a fresh target (a panic is caught by [`run_pool`]: a failed run).
fn run_variant(plan: &Plan, variant: &Variant) -> RunResult {
    let started = Instant::now();
    let outcome = run_variant_inner(plan, variant);
    let wall_ms = started.elapsed().as_millis() as u64;
    let mut result = match outcome {
        Ok((report, mid_frame)) => judge(variant, &report, mid_frame),
        Err(e) => failed(variant.clone(), e),
    };
    result.metrics.insert("wall_time_ms".into(), wall_ms);
    result
}

/// The campaign's worker pool: `work` on every item with `jobs` threads, the results in item
/// order. `progress` sees each result on the calling thread as it finishes. A panic in `work`
/// does not take the campaign down: it becomes `on_panic(item, message)`, that item's result.
///
/// Why by hand, with the standard library only: `std::thread::scope` lets the workers borrow
/// the items and the plan, an atomic index hands out the next item (no queue to fill), and an
/// `mpsc` channel brings results back as they finish so `progress` runs on the caller's
/// thread. That is the whole pool; rayon would bring a global thread pool and work stealing
/// that runs of seconds each do not need, and would still need `catch_unwind` to turn a panic
/// into one failed run rather than a panic of the whole campaign. No run can hang the pool:
/// every wait on a target is bounded (a round, a Hello, a QMP answer, a full shared-memory
/// ring), and a QEMU that ends closes the link at once, so its run fails naming that.
pub fn run_pool<T: Sync, R: Send>(
    items: &[T],
    jobs: usize,
    work: impl Fn(&T) -> R + Sync,
    on_panic: impl Fn(&T, String) -> R + Sync,
    progress: &mut dyn FnMut(&R),
) -> Result<Vec<R>, String> {
    let next = AtomicUsize::new(0);
    let (tx, rx) = std::sync::mpsc::channel::<(usize, R)>();
    let mut slots: Vec<Option<R>> = std::iter::repeat_with(|| None).take(items.len()).collect();
    std::thread::scope(|s| -> Result<(), String> {
        for _ in 0..jobs.clamp(1, items.len().max(1)) {
            let tx = tx.clone();
            let (next, work, on_panic) = (&next, &work, &on_panic);
            std::thread::Builder::new()
                .name("campaign-worker".into())
                .stack_size(64 << 20)
                .spawn_scoped(s, move || loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(item) = items.get(k) else { break };
                    let result = std::panic::catch_unwind(AssertUnwindSafe(|| work(item)))
                        .unwrap_or_else(|panic| on_panic(item, panic_message(panic.as_ref())));
                    if tx.send((k, result)).is_err() {
                        break;
                    }
                })
                .map_err(|e| format!("cannot start a worker thread: {e}"))?;
        }
        drop(tx);
        for (k, result) in rx {
            progress(&result);
            slots[k] = Some(result);
        }
        Ok(())
    })?;
    // A worker only stops early when the receiver is gone, or if `on_panic` itself panicked.
    Ok(slots
        .into_iter()
        .zip(items)
        .map(|(r, item)| r.unwrap_or_else(|| on_panic(item, "the worker running it died".into())))
        .collect())
}

/// The message a panic was raised with.
fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "a panic without a message".into())
}

fn run_variant_inner(
    plan: &Plan,
    variant: &Variant,
) -> Result<(MissionReport, Vec<String>), String> {
    let mut prepared = prepare(&plan.scenario_file).map_err(|e| e.to_string())?;
    prepared.set_seed(variant.seed);
    prepared.add_warm_reset(MissionTimeUs(variant.reset_at_us), variant.recovery_us);
    if let Some(m) = &variant.misbehaviour {
        prepared.add_command_fault(MissionTimeUs(m.from_us), m.fault());
    }
    let (mut target, firmware): (Box<dyn MissionTarget>, _) = if plan.native {
        let mut t = NativeTarget::new();
        if variant.destroy_checkpoints {
            t.damage_on_next_warm_reset(CheckpointDamage::DestroyAll);
        }
        (Box::new(t), None)
    } else {
        let options = RunOptions {
            firmware: plan.firmware.clone(),
            ..RunOptions::default()
        };
        make_target(&prepared, &options, &mut |_| {})?
    };
    let mut notes = Vec::new();
    if variant.reset_point == ResetPoint::MidFrame && !variant.destroy_checkpoints {
        target.arm_mid_frame_reset(variant.mid_frame_seed);
    }
    let report = run(
        &prepared,
        target.as_mut(),
        firmware.as_ref(),
        &mut |_, _, _| {},
    )
    .map_err(|e| e.to_string())?;
    notes.extend(target.reset_notes());
    let mut report = report;
    if !target.counts_cycles() {
        // The native target counts no guest cycles: its tick metrics are all 0, not data.
        report.metrics.retain(|k, _| !metrics::is_guest_cost(k));
    }
    Ok((report, notes))
}

/// The campaign's own checks on top of the scenario's expectations.
pub fn campaign_checks(variant: &Variant, report: &MissionReport) -> Vec<Failure> {
    let mut failures = Vec::new();
    if !report
        .resets
        .iter()
        .any(|r| r.at == variant.reset_at_us && r.kind == "warm reset")
    {
        failures.push(Failure::ResetMissing {
            at: variant.reset_at.clone(),
        });
    }
    let labels = &report.record.labels;
    for (n, reset) in report.resets.iter().enumerate() {
        let until = report.resets.get(n + 1).map_or(u64::MAX, |r| r.at);
        let restored = labels
            .iter()
            .any(|(t, l)| *t >= reset.restart_at && *t < until && l == RESTORED_LABEL);
        if !restored {
            failures.push(Failure::LostCheckpoint {
                reset: reset.kind.clone(),
                at: fmt_time(MissionTimeUs(reset.at)),
                restart: fmt_time(MissionTimeUs(reset.restart_at)),
            });
        }
    }
    failures
}

fn judge(variant: &Variant, report: &MissionReport, mid_frame: Vec<String>) -> RunResult {
    let mut failures: Vec<Failure> = report
        .expectations
        .iter()
        .filter(|v| !v.passed)
        .map(|v| Failure::Expectation {
            index: v.index,
            what: v.what.clone(),
            detail: v.detail.clone(),
        })
        .collect();
    failures.extend(campaign_checks(variant, report));
    if variant.misbehaviour.is_some() {
        // A broken subsystem may well fail the mission: the campaign asks that the run ended
        // cleanly, within its response bounds, with its cause named.
        let mission_failed = failures
            .iter()
            .any(|f| matches!(f, Failure::Expectation { .. }));
        failures
            .retain(|f| !matches!(f, Failure::Expectation { .. }) || report.ended_early.is_some());
        if mission_failed && !names_a_cause(report) {
            failures.push(Failure::NoNamedCause);
        }
    }
    failures.extend(bound_checks(report));
    let mut metrics = report.metrics.clone();
    if let Some(most) = report.commands_per_task.iter().max_by_key(|c| c.commands) {
        // The task that sent the most commands, and the most its bounds allow it in one run.
        metrics.insert("max_commands_per_task".into(), u64::from(most.commands));
        metrics.insert(
            "bound_of_the_busiest_task".into(),
            u64::from(most.bound_per_run),
        );
    }
    metrics.insert("frames".into(), report.frames);
    let passed = failures.is_empty();
    RunResult {
        variant: variant.clone(),
        passed,
        failures,
        mid_frame,
        metrics,
        transcript_sha256: report.transcript_sha256.clone(),
        timeline: if passed {
            Vec::new()
        } else {
            report.record.timeline_lines()
        },
    }
}

/// True if the report says why the mission failed: a task failed with a reason, or the autonomy
/// gave up on one.
fn names_a_cause(report: &MissionReport) -> bool {
    !report.gave_up.is_empty()
        || report
            .record
            .instances
            .iter()
            .any(|i| i.failure_cause().is_some())
        || report.ended_early.is_some()
}

/// No task definition sent more commands than its bound per run allows, counting one run per
/// completed instance plus the one still open.
pub fn bound_checks(report: &MissionReport) -> Vec<Failure> {
    report
        .commands_per_task
        .iter()
        .filter_map(|c| {
            let runs = 1 + report
                .record
                .instances
                .iter()
                .filter(|i| i.name == c.task && i.outcome_name() == "completed")
                .count() as u32;
            let allowed = c.bound_per_run.saturating_mul(runs);
            (c.commands > allowed).then(|| Failure::BoundExceeded {
                task: c.task.clone(),
                commands: c.commands,
                allowed,
            })
        })
        .collect()
}

/// Merge shard reports into one. Refuses reports of different campaigns and overlapping runs.
pub fn merge(reports: Vec<CampaignReport>) -> Result<CampaignReport, String> {
    let mut it = reports.into_iter();
    let mut merged = it.next().ok_or("nothing to merge")?;
    if merged.only.is_some() {
        return Err("a report of one reproduced run (--only) does not merge".into());
    }
    let mut owner: BTreeMap<u32, String> = BTreeMap::new();
    let label = |r: &CampaignReport| {
        if r.shards.is_empty() {
            "the unsharded report".to_string()
        } else {
            format!("shard {}", r.shards.join("+"))
        }
    };
    for r in &merged.results {
        owner.insert(r.variant.run, label(&merged));
    }
    for other in it {
        let mut differences = Vec::new();
        if other.scenario != merged.scenario {
            differences.push(format!(
                "scenario {} vs {}",
                merged.scenario, other.scenario
            ));
        }
        if other.seed != merged.seed {
            differences.push(format!("seed {} vs {}", merged.seed, other.seed));
        }
        if other.runs != merged.runs {
            differences.push(format!("runs {} vs {}", merged.runs, other.runs));
        }
        if other.target != merged.target {
            differences.push(format!("target {:?} vs {:?}", merged.target, other.target));
        }
        if other.reset_window != merged.reset_window {
            differences.push(format!(
                "reset window {} vs {}",
                merged.reset_window, other.reset_window
            ));
        }
        if other.recovery != merged.recovery {
            differences.push(format!(
                "recovery {} vs {}",
                merged.recovery, other.recovery
            ));
        }
        if other.only.is_some() {
            differences.push("one is a reproduced single run (--only)".into());
        }
        if other.misbehave != merged.misbehave {
            differences.push("one has misbehaving subsystems (--misbehave), the other not".into());
        }
        if !differences.is_empty() {
            return Err(format!(
                "cannot merge reports of different campaigns: {}",
                differences.join(", ")
            ));
        }
        let this = label(&other);
        for r in &other.results {
            if let Some(prev) = owner.get(&r.variant.run) {
                return Err(format!(
                    "cannot merge: run {} is in both {prev} and {this} (overlapping shards)",
                    r.variant.run
                ));
            }
            owner.insert(r.variant.run, this.clone());
        }
        merged.shards.extend(other.shards);
        merged.results.extend(other.results);
    }
    merged.results.sort_by_key(|r| r.variant.run);
    merged.shards.sort();
    merged.compute_stats();
    if merged.stats.missing_runs.is_empty() {
        merged.shards.clear();
    }
    Ok(merged)
}

/// Write a campaign report (JSON), as `--report` does.
pub fn save_report(report: &CampaignReport, path: &Path) -> Result<(), String> {
    let json = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
    std::fs::write(path, json).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Read a campaign report written with `--report`.
pub fn load_report(path: &Path) -> Result<CampaignReport, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut r: CampaignReport = serde_json::from_str(&text)
        .map_err(|e| format!("{}: not a campaign report: {e}", path.display()))?;
    r.compute_stats();
    Ok(r)
}

/// The terminal summary: pass rate, metric distributions, failures with their reproducers.
pub fn summary(r: &CampaignReport) -> String {
    let mut out = format!(
        "campaign {} ({}): {} runs, seeds {}..{}, {} target, reset window {}, recovery {}{}\n",
        r.scenario,
        r.scenario_file,
        r.runs,
        r.seed,
        r.seed + u64::from(r.runs.max(1)) - 1,
        match r.target {
            TargetKind::Native => "native",
            TargetKind::Qemu => "qemu",
        },
        r.reset_window,
        r.recovery,
        if r.shards.is_empty() {
            String::new()
        } else {
            format!(", shard(s) {}", r.shards.join(", "))
        }
    );
    let s = &r.stats;
    out.push_str(&format!(
        "  passed {}/{} ({:.1} %)",
        s.passed,
        s.runs_present,
        s.pass_rate * 100.0
    ));
    if !s.missing_runs.is_empty() {
        out.push_str(&format!(
            "; {} of {} runs not in this report (other shards)",
            s.missing_runs.len(),
            r.runs
        ));
    }
    let mid = r
        .results
        .iter()
        .filter(|x| x.variant.reset_point == ResetPoint::MidFrame)
        .count();
    out.push_str(&format!(
        "; {} mid-frame, {} frame-boundary resets\n",
        mid,
        r.results.len() - mid
    ));
    if !s.metrics.is_empty() {
        out.push_str(&format!(
            "  {:<28} {:>10} {:>10} {:>10} {:>10} {:>5}\n",
            "metric", "min", "median", "p95", "max", "runs"
        ));
        for (name, d) in &s.metrics {
            out.push_str(&format!(
                "  {:<28} {:>10} {:>10} {:>10} {:>10} {:>5}\n",
                name, d.min, d.median, d.p95, d.max, d.runs
            ));
        }
    }
    let failures: Vec<&RunResult> = r.results.iter().filter(|x| !x.passed).collect();
    if !failures.is_empty() {
        out.push_str("  failures:\n");
        for f in failures {
            out.push_str(&format!("    {}\n", f.variant.describe()));
            for line in &f.failures {
                out.push_str(&format!("      {line}\n"));
            }
            for line in &f.mid_frame {
                out.push_str(&format!("      ({line})\n"));
            }
            out.push_str(&format!("      reproduce: {}\n", r.reproduce(&f.variant)));
        }
    }
    out.push_str(&format!(
        "{} {}",
        if r.passed() { "PASS" } else { "FAIL" },
        r.scenario
    ));
    out
}

/// `hil campaign`.
#[derive(Clone, Debug, clap::Args)]
pub struct CampaignArgs {
    /// Mission scenario (TOML), e.g. scenarios/flyby-campaign.toml (not with --merge).
    #[arg(required_unless_present = "merge")]
    pub scenario: Option<PathBuf>,
    /// Number of variants (run indices 0..N).
    #[arg(long, default_value_t = 20)]
    pub runs: u32,
    /// Base seed: run i uses seed S + i.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run on the native target (default: the scenario's target kind).
    #[arg(long)]
    pub native: bool,
    /// Worker threads (default: available parallelism).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Run only the indices i with i % n == k - 1 (1-based k), e.g. 2/4.
    #[arg(long, value_name = "k/n")]
    pub shard: Option<String>,
    /// Write the campaign report (JSON) here.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Merge these shard reports into one (with --report) instead of running.
    #[arg(long, value_name = "FILES", num_args = 1.., conflicts_with = "scenario")]
    pub merge: Vec<PathBuf>,
    /// Reset times are drawn from A..B (default: the mission span minus its last 20 %).
    #[arg(long, value_name = "A..B")]
    pub reset_window: Option<String>,
    /// Recovery before the software restarts: a duration or a range A..B drawn from.
    #[arg(long, value_name = "DUR", default_value = "3min")]
    pub recovery: String,
    /// Run only this run index (reproduce one variant exactly).
    #[arg(long, value_name = "I")]
    pub only: Option<u32>,
    /// Firmware ELF for the emulated target (default: build firmware/image once).
    #[arg(long, value_name = "ELF")]
    pub firmware: Option<PathBuf>,
    /// Every run also gets a misbehaving subsystem (rejects, fails, never answers, ignores or
    /// completes in the wrong state every command of one opcode, from a random time on); a
    /// run passes when it ends cleanly within its response bounds and names why it failed.
    #[arg(long)]
    pub misbehave: bool,
}

fn write_report(report: &CampaignReport, path: &Option<PathBuf>) -> Result<(), String> {
    if let Some(path) = path {
        save_report(report, path)?;
        println!("  report: {}", path.display());
    }
    Ok(())
}

/// The `hil campaign` command.
pub fn cli(args: CampaignArgs) -> Result<ExitCode, String> {
    let report = if !args.merge.is_empty() {
        let reports = args
            .merge
            .iter()
            .map(|p| load_report(p))
            .collect::<Result<Vec<_>, _>>()?;
        merge(reports)?
    } else {
        let scenario = args.scenario.clone().ok_or("give a scenario or --merge")?;
        let mut opts = CampaignOptions::new(scenario, args.runs, args.seed);
        opts.native = args.native;
        opts.jobs = args.jobs.unwrap_or(0);
        opts.shard = if args.only.is_some() {
            args.shard.as_deref().map(Shard::parse).transpose()?
        } else {
            crate::shard_env::resolve(args.shard.as_deref(), &crate::shard_env::process_vars())?
        };
        opts.reset_window = args.reset_window.as_deref().map(parse_window).transpose()?;
        opts.recovery = parse_recovery(&args.recovery)?;
        opts.only = args.only;
        opts.firmware = args.firmware.clone();
        opts.misbehave = args.misbehave;
        let count = match (opts.only, opts.shard) {
            (Some(_), _) => 1,
            (None, Some(s)) => s.runs(opts.runs).len() as u64,
            (None, None) => u64::from(opts.runs),
        };
        println!(
            "hil campaign {} — {} run(s), base seed {}",
            opts.scenario.display(),
            count,
            opts.seed
        );
        let bar = indicatif::ProgressBar::new(count);
        bar.set_style(
            indicatif::ProgressStyle::with_template("  {bar:40} {pos}/{len} runs {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let mut failed = 0;
        let report = run_campaign(&opts, &mut |r| {
            if !r.passed {
                failed += 1;
                bar.println(format!("  FAIL {}", r.variant.describe()));
            }
            bar.set_message(format!("({failed} failed)"));
            bar.inc(1);
        });
        bar.finish_and_clear();
        report?
    };
    println!("{}", summary(&report));
    write_report(&report, &args.report)?;
    Ok(if report.passed() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> (MissionTimeUs, MissionTimeUs) {
        parse_window("09:50..11:10").unwrap()
    }

    #[test]
    fn a_panicking_run_is_a_failed_result_in_its_place_and_the_others_still_run() {
        let items: Vec<u32> = (0..9).collect();
        let mut seen = Vec::new();
        let results = run_pool(
            &items,
            3,
            |&i| {
                if i % 4 == 1 {
                    panic!("run {i} misbehaved");
                }
                Ok(i * 10)
            },
            |&i, why| Err(format!("{i}: {why}")),
            &mut |r: &Result<u32, String>| seen.push(r.clone()),
        )
        .unwrap();
        assert_eq!(seen.len(), 9, "progress sees every result once");
        for (i, r) in (0u32..).zip(&results) {
            if i % 4 == 1 {
                assert_eq!(r, &Err(format!("{i}: run {i} misbehaved")));
            } else {
                assert_eq!(r, &Ok(i * 10));
            }
        }
    }

    #[test]
    fn a_pool_with_more_jobs_than_items_or_no_items_finishes() {
        let none: Vec<u32> = Vec::new();
        let results = run_pool(&none, 4, |&i| i, |&i, _| i, &mut |_| {}).unwrap();
        assert!(results.is_empty());
        let results = run_pool(&[7u32], 0, |&i| i + 1, |&i, _| i, &mut |_| {}).unwrap();
        assert_eq!(results, [8]);
    }

    #[test]
    fn shards_partition_the_runs() {
        let s = Shard::parse("2/3").unwrap();
        assert_eq!(s.runs(10), [1, 4, 7]);
        let mut all: Vec<u32> = (1..=3).flat_map(|k| Shard { k, n: 3 }.runs(10)).collect();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(Shard::parse("1/1").unwrap().runs(3), [0, 1, 2]);
        for bad in ["0/2", "3/2", "1/0", "1", "a/b", "1/2/3"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn variants_derive_deterministically_from_the_seed() {
        let r = (DEFAULT_RECOVERY_US, DEFAULT_RECOVERY_US);
        let a: Vec<Variant> = (0..50)
            .map(|i| Variant::derive(i, 7, window(), r))
            .collect();
        let b: Vec<Variant> = (0..50)
            .map(|i| Variant::derive(i, 7, window(), r))
            .collect();
        assert_eq!(a, b);
        // Run i of base seed S is run i-1 of base seed S+1: only the seed matters.
        assert_eq!(
            Variant::derive(3, 7, window(), r).reset_at_us,
            Variant::derive(2, 8, window(), r).reset_at_us
        );
        let (lo, hi) = window();
        for v in &a {
            assert_eq!(v.seed, 7 + u64::from(v.run));
            assert!(v.reset_at_us >= lo.0 && v.reset_at_us < hi.0, "{v:?}");
            assert_eq!(v.reset_at_us % SEC, 0);
            assert_eq!(v.recovery_us, DEFAULT_RECOVERY_US);
            assert_eq!(
                parse_time(&v.reset_at.as_str().into(), Epoch::default())
                    .unwrap()
                    .0,
                v.reset_at_us
            );
        }
        let mid = a
            .iter()
            .filter(|v| v.reset_point == ResetPoint::MidFrame)
            .count();
        assert!((10..=40).contains(&mid), "{mid} of 50 mid-frame");
        let distinct: std::collections::BTreeSet<u64> = a.iter().map(|v| v.reset_at_us).collect();
        assert!(distinct.len() > 40);
        // A recovery range is drawn from, in whole seconds, ends included.
        let range = parse_recovery("1min..5min").unwrap();
        for i in 0..50 {
            let v = Variant::derive(i, 1, window(), range);
            assert!((60 * SEC..=300 * SEC).contains(&v.recovery_us));
            assert_eq!(v.recovery_us % SEC, 0);
        }
    }

    #[test]
    fn statistics_use_nearest_rank() {
        let d = distribution(&[5, 1, 4, 2, 3]).unwrap();
        assert_eq!((d.runs, d.min, d.median, d.p95, d.max), (5, 1, 3, 5, 5));
        let v: Vec<u64> = (1..=100).collect();
        let d = distribution(&v).unwrap();
        assert_eq!((d.min, d.median, d.p95, d.max), (1, 50, 95, 100));
        let d = distribution(&[9]).unwrap();
        assert_eq!((d.min, d.median, d.p95, d.max), (9, 9, 9, 9));
        assert!(distribution(&[]).is_none());
        assert_eq!(percentile(&[1, 2], 50), 1);
    }

    #[test]
    fn windows_and_recoveries_parse() {
        let (a, b) = parse_window("10:00..11:05").unwrap();
        assert_eq!((b.0 - a.0) / SEC, 65 * 60);
        assert!(parse_window("11:05..10:00").is_err());
        assert!(parse_window("10:00").is_err());
        assert_eq!(parse_recovery("3min").unwrap(), (180 * SEC, 180 * SEC));
        assert!(parse_recovery("5min..1min").is_err());
        assert_eq!(fmt_recovery((180 * SEC, 180 * SEC)), "180s");
        assert_eq!(
            parse_recovery(&fmt_recovery((60 * SEC, 300 * SEC))).unwrap(),
            (60 * SEC, 300 * SEC)
        );
    }
}
