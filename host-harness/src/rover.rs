//! `hil rover run FILE [--emulated] [--json]`: the planetary rover mission of seed 001
//! (section 3.3) flown with flexible dispatch and replanning (section 5).
//!
//! The scenario file names a PDDL domain and problem (`scenarios/rover/`), the waypoints'
//! positions for the path-estimate module that gives traverse durations (section 4.5), a
//! seeded simulation of the rover, and opportunistic science goals that arrive during the run.
//! The run:
//!
//! - plans (natively, or in the planner partition of the emulated RAD750 with `--emulated`:
//!   one QEMU for the whole run, each plan and replan a job on it);
//! - turns the plan into a dispatch network ([`temporal::replan::network_from_plan`]) and
//!   executes it with [`temporal::Dispatcher`] (start at lb if ready early, at once within
//!   (lb, ub], replan past ub), against the simulated rover, which takes longer than the
//!   estimate on some traverses (seeded, and on the traverses the file names as obstacles);
//! - wakes at the earliest ub of a step not yet executed, so an overrun is noticed when it
//!   happens, not when the late action ends;
//! - replans when a step is past its ub or an opportunistic goal arrives: nothing new is
//!   dispatched, pausable running actions go to their inactive state (the `inactive-`
//!   convention, [`temporal::replan`]), the others are carried; the task from now is built by
//!   [`temporal::replan::write_replan_task`] and planned; a plan that fails drops the newest
//!   opportunistic goal and tries again (5.3);
//! - prints a transcript and checks the file's expectations.
//!
//! Mission time does not advance while the planner runs (its cost is counted in expansions,
//! and on the emulated target in guest instructions), so the native and the emulated run make
//! the same decisions, which the transcript's decision lines (and their hash) show. The
//! dispatcher and the simulation run on the host; only planning runs on the target.
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use temporal::dispatch::{Decision, Dispatcher, PlanNetwork};
use temporal::replan::{self, Carried, ReplanInput};
use temporal::{PlannedAction, Planner, Status, Task};

// ----- the scenario file ----------------------------------------------------------------------

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoverScenario {
    pub rover: RoverSection,
    pub path_estimate: PathEstimateSection,
    #[serde(default)]
    pub dispatch: DispatchSection,
    #[serde(default)]
    pub simulation: SimulationSection,
    #[serde(default, rename = "opportunity")]
    pub opportunities: Vec<Opportunity>,
    #[serde(default)]
    pub expect: Expectations,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoverSection {
    pub name: String,
    /// PDDL files, relative to the scenario file.
    pub domain: String,
    pub problem: String,
    #[serde(default)]
    pub seed: u64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathEstimateSection {
    /// The module and function names the domain declares.
    pub module: String,
    pub function: String,
    /// Metres per PDDL time unit (seconds).
    pub speed: f64,
    /// Waypoint positions in metres.
    pub waypoints: BTreeMap<String, [f64; 2]>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DispatchSection {
    /// Latest time for any step: the plan's makespan plus this (seconds).
    #[serde(default)]
    pub horizon_slack_s: f64,
    /// Expansions a planning attempt may make (the same limit natively and on the target).
    #[serde(default = "default_expansions")]
    pub max_expansions: u32,
    /// Mission time planning takes, per expansion, milliseconds: a model of the planner's CPU
    /// that is the same natively and on the target (the target's measured cost is reported
    /// in guest instructions beside it; about 135,000 instructions, 0.54 ms at 250 MIPS, per
    /// expansion on the rover's replans).
    #[serde(default = "default_ms_per_expansion")]
    pub planning_ms_per_expansion: f64,
}

fn default_ms_per_expansion() -> f64 {
    0.5
}

fn default_expansions() -> u32 {
    20_000
}

impl Default for DispatchSection {
    fn default() -> Self {
        Self {
            horizon_slack_s: 0.0,
            max_expansions: default_expansions(),
            planning_ms_per_expansion: default_ms_per_expansion(),
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationSection {
    /// Percent chance that a traverse is slowed by terrain.
    #[serde(default)]
    pub slow_percent: u64,
    /// A slowed traverse takes the estimate times a factor in this range.
    #[serde(default = "default_slow")]
    pub slow_factor: [f64; 2],
    /// Any other traverse takes the estimate times a factor in this range.
    #[serde(default = "default_nominal")]
    pub nominal_factor: [f64; 2],
    /// Traverses blocked by obstacles the estimate did not know of: their first run takes the
    /// estimate times `factor`.
    #[serde(default, rename = "obstacle")]
    pub obstacles: Vec<Obstacle>,
}

fn default_slow() -> [f64; 2] {
    [1.3, 1.8]
}
fn default_nominal() -> [f64; 2] {
    [1.0, 1.0]
}

impl Default for SimulationSection {
    fn default() -> Self {
        Self {
            slow_percent: 0,
            slow_factor: default_slow(),
            nominal_factor: default_nominal(),
            obstacles: Vec::new(),
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Obstacle {
    pub traverse: String,
    pub factor: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Opportunity {
    /// Mission time it arrives, seconds.
    pub at_s: f64,
    /// The goal fact, as the front end names it: `(image-sent o3)`.
    pub goal: String,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expectations {
    /// Facts true at the end.
    #[serde(default)]
    pub achieved: Vec<String>,
    /// Opportunistic goals kept (and achieved).
    #[serde(default)]
    pub accepted: Vec<String>,
    /// Opportunistic goals dropped.
    #[serde(default)]
    pub dropped: Vec<String>,
    /// At least this many replans because a step was past its ub.
    #[serde(default)]
    pub min_overrun_replans: usize,
    /// At least this many running actions paused into their inactive state.
    #[serde(default)]
    pub min_paused: usize,
    /// At least this many starts that waited for their lb, and that started late within
    /// (lb, ub].
    #[serde(default)]
    pub min_started_at_lb: usize,
    #[serde(default)]
    pub min_started_late: usize,
    /// At least this many starts ready early and held to their lb.
    #[serde(default)]
    pub min_held_to_lb: usize,
    /// Every step of the last plan executed.
    #[serde(default)]
    pub finished: bool,
}

impl RoverScenario {
    pub fn load(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
    }
}

// ----- planning, natively or on the target ------------------------------------------------------

/// One planning attempt's result, times in ticks.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Attempt {
    pub outcome: String,
    #[serde(skip)]
    pub plan: Vec<PlannedAction>,
    pub expanded: u64,
    pub peak_arena_bytes: u64,
    /// Guest instructions the planner partition spent (emulated only).
    pub guest_instructions: Option<u64>,
}

/// Where plans are made.
pub enum Backend {
    Native { arena: Vec<u32> },
    Emulated(Box<crate::plan_emulated::EmulatedPlanner>),
}

impl Backend {
    pub fn native() -> Self {
        Backend::Native {
            arena: vec![0u32; flight_app::TEMPORAL_ARENA_BYTES / 4],
        }
    }

    fn options(max_expansions: u32, dropped: u64) -> crate::plan::PlanOptions {
        crate::plan::PlanOptions {
            max_expansions: u64::from(max_expansions),
            config: temporal::PlannerConfig {
                dropped_goals: dropped,
                relaxed_cost: temporal::heuristic::RelaxedCost::Duration,
                ..temporal::PlannerConfig::default()
            },
            ..crate::plan::PlanOptions::default()
        }
    }

    /// Plan `compiled` with the goals `dropped` names left out.
    pub fn plan(
        &mut self,
        compiled: &pddl::Compiled,
        max_expansions: u32,
        dropped: u64,
    ) -> Result<Attempt, String> {
        let options = Self::options(max_expansions, dropped);
        match self {
            Backend::Native { arena } => {
                // The configuration the planner partition derives from the wire, and its
                // loop: one expansion at a time up to the limit.
                let wire = crate::plan_emulated::wire_config(&options)?;
                let config =
                    flight_app::planner_config(&wire, flight_app::MAX_TEMPORAL_PLAN_ACTIONS);
                let task = Task::parse(&compiled.task).map_err(|e| e.to_string())?;
                let mut planner = match Planner::new(task, arena, config) {
                    Ok(p) => p,
                    Err(r) => {
                        return Ok(Attempt {
                            outcome: format!("out of memory ({r:?})"),
                            ..Attempt::default()
                        })
                    }
                };
                let mut status = planner.status();
                while status == Status::Searching {
                    status = planner.step(1);
                    if status == Status::Searching
                        && planner.stats().expanded >= u64::from(max_expansions)
                    {
                        break;
                    }
                }
                let stats = planner.stats();
                let mut attempt = Attempt {
                    outcome: match status {
                        Status::Solved => "solved".into(),
                        Status::Unsolvable => "unsolvable".into(),
                        Status::OutOfMemory(r) => format!("out of memory ({r:?})"),
                        Status::Searching => "expansion limit".into(),
                    },
                    expanded: stats.expanded,
                    peak_arena_bytes: stats.peak_words * 4,
                    ..Attempt::default()
                };
                if status == Status::Solved {
                    let mut out =
                        vec![PlannedAction::default(); flight_app::MAX_TEMPORAL_PLAN_ACTIONS];
                    let (n, _) = planner
                        .plan(&mut out)
                        .ok_or("the planner reported a plan but could not write it")?;
                    out.truncate(n);
                    attempt.plan = out;
                }
                Ok(attempt)
            }
            Backend::Emulated(target) => {
                let report = target
                    .plan(compiled, &options, 2_000_000)
                    .map_err(|e| e.to_string())?;
                let ids: HashMap<&str, u16> = compiled
                    .action_names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| (n.as_str(), i as u16))
                    .collect();
                let tpu = f64::from(compiled.ticks_per_unit);
                let ticks = |x: f64| (x * tpu).round() as u32;
                let mut plan = Vec::new();
                for s in &report.plan {
                    let action = *ids.get(s.action.as_str()).ok_or_else(|| {
                        format!("the target planned an unknown action {}", s.action)
                    })?;
                    plan.push(PlannedAction {
                        action,
                        start: ticks(s.start),
                        duration: ticks(s.duration),
                        start_lb: ticks(s.start_window[0]),
                        start_ub: ticks(s.start_window[1]),
                    });
                }
                Ok(Attempt {
                    outcome: report.outcome.clone(),
                    plan,
                    expanded: report.expanded,
                    peak_arena_bytes: report.peak_arena_bytes,
                    guest_instructions: report.emulated.as_ref().map(|e| e.guest_instructions),
                })
            }
        }
    }
}

// ----- the simulated rover ----------------------------------------------------------------------

/// xorshift64*: the same numbers on every machine.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(seed ^ 0x9e37_79b9_7f4a_7c15 | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [lo, hi], in thousandths.
    fn factor(&mut self, [lo, hi]: [f64; 2]) -> f64 {
        lo + (hi - lo) * (self.next() % 1001) as f64 / 1000.0
    }
}

/// How long the simulated rover takes for each action it is commanded.
struct RoverSim {
    rng: Rng,
    sim: SimulationSection,
    blocked: Vec<String>,
}

impl RoverSim {
    /// The actual duration of `name` whose estimate is `estimate` ticks.
    fn duration(&mut self, name: &str, estimate: u32) -> (u32, Option<&'static str>) {
        if !name.starts_with("(traverse") {
            return (estimate, None);
        }
        if let Some(i) = self.blocked.iter().position(|b| b == name) {
            self.blocked.remove(i);
            let f = self
                .sim
                .obstacles
                .iter()
                .find(|o| o.traverse == name)
                .map_or(1.0, |o| o.factor);
            return ((f64::from(estimate) * f).round() as u32, Some("obstacle"));
        }
        let slow = self.rng.next() % 100 < self.sim.slow_percent;
        let f = if slow {
            self.rng.factor(self.sim.slow_factor)
        } else {
            self.rng.factor(self.sim.nominal_factor)
        };
        (
            (f64::from(estimate) * f).round() as u32,
            slow.then_some("terrain"),
        )
    }
}

// ----- the run ----------------------------------------------------------------------------------

/// One planning (a plan or a replan, with its attempts).
#[derive(Clone, Debug, Serialize)]
pub struct Planning {
    pub at_s: f64,
    pub reason: String,
    pub attempts: Vec<Attempt>,
    pub carried: Vec<String>,
    pub paused: Vec<String>,
    pub dropped: Vec<String>,
    pub solved: bool,
    pub actions: usize,
    pub makespan_s: f64,
    /// Guest instructions of all the attempts (emulated only).
    pub guest_instructions: Option<u64>,
}

/// What a run did.
#[derive(Clone, Debug, Serialize)]
pub struct RoverRun {
    pub scenario: String,
    pub seed: u64,
    pub target: String,
    /// Decision lines: dispatches, ends, overruns, pauses, replans and their outcomes, goals.
    pub decisions: Vec<String>,
    /// The same with the planning costs added (what is printed).
    pub transcript: Vec<String>,
    pub plannings: Vec<Planning>,
    pub achieved: Vec<String>,
    pub accepted: Vec<String>,
    pub dropped: Vec<String>,
    pub overrun_replans: usize,
    pub paused: usize,
    pub started_at_lb: usize,
    pub started_late: usize,
    /// Starts before their planned lb (what they follow ended early).
    pub started_early: usize,
    /// Starts at lb of a step ready more than a second before it (held to lb).
    pub held_to_lb: usize,
    pub finished: bool,
    pub end_s: f64,
    /// sha256 of the decision lines (hex, 16 digits).
    pub decisions_sha256: String,
}

/// An expectation and whether it held.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    pub ok: bool,
    pub what: String,
    pub got: String,
}

/// A running action on the simulated rover.
#[derive(Clone, Debug)]
struct Active {
    action: u16,
    started: u32,
    ends: u32,
    /// The end step in the current network.
    end_step: Option<usize>,
}

fn secs(ticks: u32) -> f64 {
    f64::from(ticks) / 1000.0
}

struct Mission<'a> {
    base: &'a pddl::Compiled,
    task: Task<'a>,
    backend: &'a mut Backend,
    max_expansions: u32,
    slack: u32,
    ms_per_expansion: f64,
    facts: Vec<u32>,
    values: Vec<i64>,
    active: Vec<Active>,
    /// Opportunistic goals kept so far (fact ids, arrival order).
    opportunistic: Vec<u16>,
    run: RoverRun,
    /// The current network, its dispatcher, its epoch, and its compiled task.
    dispatcher: Option<Dispatcher>,
    epoch: u32,
    current: Option<pddl::Compiled>,
    /// Each step's window [lb, ub] when the plan was made (epoch ticks).
    planned: Vec<(u32, u32)>,
}

impl Mission<'_> {
    fn say(&mut self, t: u32, line: String) {
        let l = format!("{:>9.3}  {line}", secs(t));
        self.run.decisions.push(l.clone());
        self.run.transcript.push(l);
    }
    fn cost(&mut self, line: String) {
        self.run.transcript.push(format!("{:>9}  {line}", ""));
    }
    fn name(&self, a: u16) -> String {
        self.current
            .as_ref()
            .and_then(|c| c.action_names.get(usize::from(a)))
            .or_else(|| self.base.action_names.get(usize::from(a)))
            .cloned()
            .unwrap_or_else(|| format!("(action {a})"))
    }

    /// Plan from time `t`: pause what is pausable, carry the rest, drop opportunistic goals
    /// newest first until a plan comes. The mission time planning takes (ticks), or None when
    /// no plan came. Nothing new is dispatched until that time has passed.
    fn replan(&mut self, t: u32, reason: String) -> Result<Option<u32>, String> {
        self.say(t, format!("replan: {reason}"));
        let task = self.task;
        let inactive = |f: usize| {
            self.base
                .fact_names
                .get(f)
                .is_some_and(|n| n.starts_with("(inactive-"))
        };
        let mut carried = Vec::new();
        let mut paused = Vec::new();
        let mut keep = Vec::new();
        for a in std::mem::take(&mut self.active) {
            if replan::is_pausable(&task, usize::from(a.action), &inactive) {
                replan::pause(&task, usize::from(a.action), &mut self.facts)
                    .map_err(|e| format!("pause: {e:?}"))?;
                paused.push(self.base.action_names[usize::from(a.action)].clone());
            } else {
                let left = a.ends.saturating_sub(t);
                carried.push(Carried {
                    action: a.action,
                    remaining_lb: left,
                    remaining_ub: left,
                });
                keep.push(a);
            }
        }
        self.active = keep;
        for p in &paused {
            self.say(
                t,
                format!("  pause {p}: back to its inactive state, not done"),
            );
        }
        let lines: Vec<String> = carried
            .iter()
            .zip(&self.active)
            .map(|(c, a)| {
                format!(
                    "  carry {} (running since {:.3}, {:.3} s left)",
                    self.base.action_names[usize::from(c.action)],
                    secs(a.started),
                    secs(c.remaining_lb)
                )
            })
            .collect();
        for line in lines {
            self.say(t, line);
        }
        self.run.paused += paused.len();
        let goal_count = task.goal_facts().len();
        let mut dropped_names = Vec::new();
        let mut attempts = Vec::new();
        let mut dropped_now: Vec<u16> = Vec::new();
        let (plan, compiled) = loop {
            let extra: Vec<u16> = self
                .opportunistic
                .iter()
                .copied()
                .filter(|g| !dropped_now.contains(g))
                .collect();
            let mut buf = vec![0u8; self.base.task.len() * 2 + (64 << 10)];
            let len = replan::write_replan_task(
                &ReplanInput {
                    task,
                    now: t,
                    facts: &self.facts,
                    values: &self.values,
                    carried: &carried,
                    extra_goals: &extra,
                },
                &mut buf,
            )
            .map_err(|e| format!("the replan task: {e:?}"))?;
            buf.truncate(len);
            let mut action_names = self.base.action_names.clone();
            let mut fact_names = self.base.fact_names.clone();
            for (k, c) in carried.iter().enumerate() {
                action_names.push(format!(
                    "(finish {})",
                    self.base.action_names[usize::from(c.action)]
                ));
                fact_names.push(format!("(finished {k})"));
            }
            let compiled = pddl::Compiled {
                task: buf,
                action_names,
                fact_names,
                numeric_names: self.base.numeric_names.clone(),
                til_windows: self.base.til_windows,
                ticks_per_unit: self.base.ticks_per_unit,
                epsilon_ticks: self.base.epsilon_ticks,
            };
            let attempt = self.backend.plan(&compiled, self.max_expansions, 0)?;
            let goals: Vec<String> = extra
                .iter()
                .map(|&g| self.base.fact_names[usize::from(g)].clone())
                .collect();
            let line = format!(
                "  attempt {}: {} hard goals{}{}: {}, {} actions, {} expanded",
                attempts.len() + 1,
                goal_count,
                if goals.is_empty() {
                    ""
                } else {
                    " + opportunistic "
                },
                goals.join(" "),
                attempt.outcome,
                attempt.plan.len(),
                attempt.expanded
            );
            self.say(t, line);
            if let Some(g) = attempt.guest_instructions {
                self.cost(format!(
                    "  planner partition: {g} guest instructions, peak arena {} bytes",
                    attempt.peak_arena_bytes
                ));
            } else {
                self.cost(format!(
                    "  native: peak arena {} bytes",
                    attempt.peak_arena_bytes
                ));
            }
            let solved = attempt.outcome == "solved";
            let plan = attempt.plan.clone();
            attempts.push(attempt);
            if solved {
                break (Some(plan), compiled);
            }
            // Drop the newest opportunistic goal still in, and try again.
            match extra.last() {
                Some(&g) => {
                    dropped_now.push(g);
                    let n = self.base.fact_names[usize::from(g)].clone();
                    self.say(t, format!("  drop opportunistic goal {n}"));
                    dropped_names.push(n);
                }
                None => break (None, compiled),
            }
        };
        self.opportunistic.retain(|g| !dropped_now.contains(g));
        self.run.dropped.extend(dropped_names.iter().cloned());
        let guest: Option<u64> = attempts
            .iter()
            .map(|a| a.guest_instructions)
            .sum::<Option<u64>>();
        let mut planning = Planning {
            at_s: secs(t),
            reason,
            attempts,
            carried: carried
                .iter()
                .map(|c| self.base.action_names[usize::from(c.action)].clone())
                .collect(),
            paused,
            dropped: dropped_names,
            solved: plan.is_some(),
            actions: 0,
            makespan_s: 0.0,
            guest_instructions: guest,
        };
        let Some(plan) = plan else {
            self.say(t, "  no plan: the mission stops here".into());
            self.run.plannings.push(planning);
            self.dispatcher = None;
            return Ok(None);
        };
        let new_task = Task::parse(&compiled.task).map_err(|e| e.to_string())?;
        let mut net = PlanNetwork::new();
        let mut scratch = vec![0u32; new_task.fact_count() + new_task.numeric_count()];
        replan::network_from_plan(&new_task, &plan, true, &mut scratch, &mut net)
            .map_err(|e| format!("the plan's network: {e:?}"))?;
        let makespan = net.makespan;
        let expanded: u64 = planning.attempts.iter().map(|a| a.expanded).sum();
        let planning_ticks = (expanded as f64 * self.ms_per_expansion).round() as u32;
        planning.actions = plan.len();
        planning.makespan_s = secs(makespan);
        self.run.plannings.push(planning);
        let mut d = Dispatcher::new(net, makespan.saturating_add(self.slack))
            .map_err(|e| format!("the plan's network: {e:?}"))?;
        self.planned = (0..=d.network().step_count())
            .map(|k| d.window(k).unwrap_or((0, 0)))
            .collect();
        self.say(
            t,
            format!(
                "  new plan: {} actions, makespan {:.3} s (ends at {:.3})",
                plan.len(),
                secs(makespan),
                secs(t + makespan)
            ),
        );
        for p in &plan {
            let line = format!(
                "    {:>9.3} {} [{:.3}] start window [{:.3}, {:.3}]",
                secs(t + p.start),
                compiled
                    .action_names
                    .get(usize::from(p.action))
                    .map_or("?", String::as_str),
                secs(p.duration),
                secs(t + p.start_lb),
                secs(t + p.start_ub)
            );
            self.say(t, line);
        }
        // The completions start at the epoch: they are the carried actions going on.
        let base_actions = self.task.action_count();
        let steps = d.network().step_count();
        for k in 1..=steps {
            let Some(s) = d.network().step(k) else {
                continue;
            };
            if s.end || usize::from(s.action) < base_actions {
                continue;
            }
            let i = usize::from(s.action) - base_actions;
            d.executed(k, 0)
                .map_err(|e| format!("completion start: {e:?}"))?;
            let end = d.network().end_of(k);
            if let Some(a) = self.active.get_mut(i) {
                a.end_step = end;
            }
        }
        self.dispatcher = Some(d);
        self.epoch = t;
        self.current = Some(compiled);
        self.say(
            t,
            format!(
                "  planning takes {:.3} s ({expanded} expansions): nothing new dispatched until {:.3}",
                secs(planning_ticks),
                secs(t + planning_ticks)
            ),
        );
        Ok(Some(planning_ticks))
    }
}

/// Compile the scenario's PDDL with its path estimate.
pub fn compile(scenario: &RoverScenario, dir: &Path) -> Result<pddl::Compiled, String> {
    let mut modules = pddl::ModuleRegistry::new();
    let positions: Vec<(&str, f64, f64)> = scenario
        .path_estimate
        .waypoints
        .iter()
        .map(|(n, p)| (n.as_str(), p[0], p[1]))
        .collect();
    modules.register(Box::new(pddl::PathEstimate::new(
        &scenario.path_estimate.module,
        &scenario.path_estimate.function,
        &positions,
        scenario.path_estimate.speed,
    )));
    let (_, _, compiled, _) = crate::plan::compile_files(
        &dir.join(&scenario.rover.domain),
        &dir.join(&scenario.rover.problem),
        &modules,
        &crate::plan::PlanOptions::default(),
    )
    .map_err(|e| e.render())?;
    Ok(compiled)
}

/// Run the scenario with `backend`.
pub fn run(
    scenario: &RoverScenario,
    dir: &Path,
    seed: u64,
    backend: &mut Backend,
) -> Result<RoverRun, String> {
    let base = compile(scenario, dir)?;
    let task = Task::parse(&base.task).map_err(|e| e.to_string())?;
    let fact_id = |name: &str| -> Result<u16, String> {
        base.fact_names
            .iter()
            .position(|f| f == name)
            .map(|i| i as u16)
            .ok_or_else(|| format!("the task has no fact {name} (check the goal's spelling)"))
    };
    let mut arrivals: Vec<(u32, u16, String)> = Vec::new();
    for o in &scenario.opportunities {
        let id = fact_id(&o.goal)?;
        if task.goal_facts().contains(usize::from(id)) {
            return Err(format!("opportunity {}: it is already a goal", o.goal));
        }
        if o.at_s.is_nan() || o.at_s < 0.0 {
            return Err(format!("opportunity {}: at_s must be 0 or more", o.goal));
        }
        arrivals.push(((o.at_s * 1000.0).round() as u32, id, o.goal.clone()));
    }
    arrivals.sort();
    let mut facts = vec![0u32; replan::fact_words(&task)];
    let mut values = vec![0i64; task.numeric_count()];
    replan::initial_state(&task, &mut facts, &mut values).map_err(|e| format!("{e:?}"))?;
    let target = match backend {
        Backend::Native { .. } => "native",
        Backend::Emulated(_) => "emulated",
    };
    let mut sim = RoverSim {
        rng: Rng::new(seed),
        sim: scenario.simulation.clone(),
        blocked: scenario
            .simulation
            .obstacles
            .iter()
            .map(|o| o.traverse.clone())
            .collect(),
    };
    let mut m = Mission {
        base: &base,
        task,
        backend,
        max_expansions: scenario.dispatch.max_expansions,
        slack: (scenario.dispatch.horizon_slack_s * 1000.0).round() as u32,
        ms_per_expansion: scenario.dispatch.planning_ms_per_expansion,
        facts,
        values,
        active: Vec::new(),
        opportunistic: Vec::new(),
        run: RoverRun {
            scenario: scenario.rover.name.clone(),
            seed,
            target: target.into(),
            decisions: Vec::new(),
            transcript: Vec::new(),
            plannings: Vec::new(),
            achieved: Vec::new(),
            accepted: Vec::new(),
            dropped: Vec::new(),
            overrun_replans: 0,
            paused: 0,
            started_at_lb: 0,
            started_late: 0,
            started_early: 0,
            held_to_lb: 0,
            finished: false,
            end_s: 0.0,
            decisions_sha256: String::new(),
        },
        dispatcher: None,
        epoch: 0,
        current: None,
        planned: Vec::new(),
    };
    let mut t = 0u32;
    let mut alive = false;
    // Opportunistic goals known from the start (`at_s = 0`) are in the first plan's goals.
    while arrivals.first().is_some_and(|a| a.0 == 0) {
        let (_, id, name) = arrivals.remove(0);
        m.say(0, format!("optional goal {name} from the start"));
        m.opportunistic.push(id);
    }
    if let Some(p) = m.replan(0, "initial plan".into())? {
        alive = true;
        t = p;
    }
    let base_actions = task.action_count();
    let mut guard = 0u32;
    let mut held: Option<(u32, u32)> = None;
    while alive {
        guard += 1;
        if guard > 100_000 {
            return Err("the run did not end (more than 100,000 decisions)".into());
        }
        // Opportunities arriving now.
        if arrivals.first().is_some_and(|a| a.0 <= t) {
            let (_, id, name) = arrivals.remove(0);
            m.opportunistic.push(id);
            let planned = m.replan(t, format!("opportunistic goal {name} arrived"))?;
            alive = planned.is_some();
            // While the planner runs, what is running goes on (and may end).
            t += planned.unwrap_or(0);
            end_actions(&mut m, t, &task)?;
            continue;
        }
        let epoch = m.epoch;
        let Some(d) = m.dispatcher.as_mut() else {
            break;
        };
        let facts = &m.facts;
        let values = &m.values;
        let ready = |a: u16| {
            usize::from(a) >= base_actions
                || replan::start_holds(&task, usize::from(a), facts, values)
        };
        let decision = d.poll(t - epoch, &ready);
        match decision {
            Decision::Start { step, action } => {
                // The window as planned (the current one has moved up to now).
                let (lb, ub) = m.planned.get(step).copied().unwrap_or((0, 0));
                let d = m.dispatcher.as_mut().ok_or("no plan")?;
                d.executed(step, t - epoch)
                    .map_err(|e| format!("dispatch: {e:?}"))?;
                let end_step = d.network().end_of(step);
                let a = task.action(usize::from(action));
                let estimate = a.duration_lb;
                let name = m.name(action);
                let (actual, why) = sim.duration(&name, estimate);
                let waited = held.filter(|h| h.0 == t).map_or(0, |h| h.0 - h.1);
                let when = if t - epoch < lb {
                    m.run.started_early += 1;
                    format!(
                        "{:.3} s before its planned lb (what it follows ended early)",
                        secs(lb - (t - epoch))
                    )
                } else if t - epoch == lb {
                    m.run.started_at_lb += 1;
                    if waited > 1000 {
                        m.run.held_to_lb += 1;
                        format!("at lb (ready {:.3} s early, held to lb)", secs(waited))
                    } else {
                        "at lb".to_string()
                    }
                } else {
                    m.run.started_late += 1;
                    format!("{:.3} s after lb, within (lb, ub]", secs(t - epoch - lb))
                };
                m.say(
                    t,
                    format!(
                        "dispatch {name} window [{:.3}, {:.3}] {when}",
                        secs(lb + epoch),
                        secs(ub.saturating_add(epoch))
                    ),
                );
                if let Some(why) = why {
                    m.say(
                        t,
                        format!(
                            "  ({why}: will take {:.3} s, estimate {:.3} s)",
                            secs(actual),
                            secs(estimate)
                        ),
                    );
                }
                replan::apply(
                    &task,
                    usize::from(action),
                    false,
                    &mut m.facts,
                    &mut m.values,
                )
                .map_err(|e| format!("{e:?}"))?;
                m.active.push(Active {
                    action,
                    started: t,
                    ends: t + actual,
                    end_step,
                });
            }
            Decision::Replan { step, ub } => {
                let executed = d.executed_at(step).is_some();
                let what = d
                    .network()
                    .step(step)
                    .map(|s| {
                        format!(
                            "{} of {}",
                            if s.end { "end" } else { "start" },
                            m.name(s.action)
                        )
                    })
                    .unwrap_or_default();
                let reason = if executed {
                    format!("overrun: what followed step {step} ({what}) no longer fits the plan's windows")
                } else {
                    format!(
                        "overrun: step {step} ({what}) past its ub {:.3}",
                        secs(ub.saturating_add(epoch))
                    )
                };
                m.run.overrun_replans += 1;
                let planned = m.replan(t, reason)?;
                alive = planned.is_some();
                t += planned.unwrap_or(0);
                end_actions(&mut m, t, &task)?;
            }
            Decision::Wait { until } => {
                // Wake at: a ready step's lb, the next end on the rover, the next arrival, or
                // just past the earliest ub of a step not yet executed (an overrun).
                let steps = d.network().step_count();
                let earliest_ub = (1..=steps)
                    .filter(|&k| d.executed_at(k).is_none())
                    .filter_map(|k| d.window(k).map(|w| w.1))
                    .filter(|&ub| ub != temporal::task::UNBOUNDED)
                    .min()
                    .map(|ub| ub.saturating_add(epoch).saturating_add(1));
                let next = [
                    until.map(|u| u + epoch),
                    m.active.iter().map(|a| a.ends).min(),
                    arrivals.first().map(|a| a.0),
                    earliest_ub,
                ]
                .into_iter()
                .flatten()
                .filter(|&x| x > t)
                .min();
                let Some(next) = next else {
                    m.say(t, "stuck: nothing to wait for".into());
                    break;
                };
                // A ready step waits for its lb (and nothing else happens before it).
                held = until
                    .map(|u| u + epoch)
                    .filter(|&u| u == next)
                    .map(|u| (u, t));
                t = next;
                end_actions(&mut m, t, &task)?;
            }
            Decision::Finished => {
                if let Some(&(at, _, _)) = arrivals.first() {
                    t = t.max(at);
                    continue;
                }
                m.run.finished = true;
                m.say(t, "finished: every step of the plan executed".into());
                break;
            }
        }
    }
    // The goals.
    let goals: Vec<String> = task
        .goal_facts()
        .iter()
        .map(|g| base.fact_names[g].clone())
        .collect();
    for (f, name) in base.fact_names.iter().enumerate() {
        let is_goal =
            goals.contains(name) || scenario.opportunities.iter().any(|o| &o.goal == name);
        if is_goal && replan::fact(&m.facts, f) {
            m.run.achieved.push(name.clone());
        }
    }
    m.run.accepted = m
        .opportunistic
        .iter()
        .map(|&g| base.fact_names[usize::from(g)].clone())
        .collect();
    let achieved = m.run.achieved.join(" ");
    m.say(t, format!("goals achieved: {achieved}"));
    let dropped = m.run.dropped.join(" ");
    if !dropped.is_empty() {
        m.say(t, format!("opportunistic goals dropped: {dropped}"));
    }
    m.run.end_s = secs(t);
    let mut h = Sha256::new();
    for l in &m.run.decisions {
        h.update(l.as_bytes());
        h.update(b"\n");
    }
    m.run.decisions_sha256 = format!("{:x}", h.finalize())[..16].to_string();
    Ok(m.run)
}

/// The rover's actions that end by `t`, in time order: their end effects, the dispatcher told.
fn end_actions(m: &mut Mission<'_>, t: u32, task: &Task<'_>) -> Result<(), String> {
    loop {
        let Some(i) = (0..m.active.len())
            .filter(|&i| m.active[i].ends <= t)
            .min_by_key(|&i| (m.active[i].ends, m.active[i].action))
        else {
            return Ok(());
        };
        let a = m.active.remove(i);
        replan::apply(
            task,
            usize::from(a.action),
            true,
            &mut m.facts,
            &mut m.values,
        )
        .map_err(|e| format!("{e:?}"))?;
        let estimate = task.action(usize::from(a.action)).duration_lb;
        let took = a.ends - a.started;
        let name = m.base.action_names[usize::from(a.action)].clone();
        let diff = if took == estimate {
            String::new()
        } else {
            format!(
                " ({:+.3} s on the estimate {:.3})",
                (f64::from(took) - f64::from(estimate)) / 1000.0,
                secs(estimate)
            )
        };
        m.say(
            a.ends,
            format!("end {name} after {:.3} s{diff}", secs(took)),
        );
        let epoch = m.epoch;
        if let (Some(k), Some(d)) = (a.end_step, m.dispatcher.as_mut()) {
            d.executed(k, a.ends.saturating_sub(epoch))
                .map_err(|e| format!("end: {e:?}"))?;
        }
    }
}

/// The file's expectations against the run.
pub fn check(scenario: &RoverScenario, run: &RoverRun) -> Vec<Verdict> {
    let e = &scenario.expect;
    let mut v = Vec::new();
    for g in &e.achieved {
        v.push(Verdict {
            ok: run.achieved.contains(g),
            what: format!("{g} achieved"),
            got: if run.achieved.contains(g) {
                "achieved".into()
            } else {
                "not achieved".into()
            },
        });
    }
    for g in &e.accepted {
        let ok = run.accepted.contains(g) && run.achieved.contains(g);
        v.push(Verdict {
            ok,
            what: format!("opportunistic {g} accepted and achieved"),
            got: format!(
                "{}, {}",
                if run.accepted.contains(g) {
                    "kept"
                } else {
                    "not kept"
                },
                if run.achieved.contains(g) {
                    "achieved"
                } else {
                    "not achieved"
                }
            ),
        });
    }
    for g in &e.dropped {
        v.push(Verdict {
            ok: run.dropped.contains(g),
            what: format!("opportunistic {g} dropped"),
            got: if run.dropped.contains(g) {
                "dropped".into()
            } else {
                "not dropped".into()
            },
        });
    }
    let mut at_least = |what: &str, want: usize, got: usize| {
        if want > 0 {
            v.push(Verdict {
                ok: got >= want,
                what: format!("{what} >= {want}"),
                got: got.to_string(),
            });
        }
    };
    at_least(
        "replans for a step past its ub",
        e.min_overrun_replans,
        run.overrun_replans,
    );
    at_least("running actions paused", e.min_paused, run.paused);
    at_least("starts at lb", e.min_started_at_lb, run.started_at_lb);
    at_least(
        "starts within (lb, ub]",
        e.min_started_late,
        run.started_late,
    );
    at_least(
        "starts ready early, held to lb",
        e.min_held_to_lb,
        run.held_to_lb,
    );
    if e.finished {
        v.push(Verdict {
            ok: run.finished,
            what: "every step of the last plan executed".into(),
            got: run.finished.to_string(),
        });
    }
    v
}

/// The transcript and verdict for people.
pub fn render(run: &RoverRun, verdicts: &[Verdict]) -> String {
    let mut s = format!(
        "hil rover run {} (seed {}, planning {})\n",
        run.scenario, run.seed, run.target
    );
    for l in &run.transcript {
        s.push_str("  ");
        s.push_str(l);
        s.push('\n');
    }
    s.push_str("  plannings:\n");
    for (i, p) in run.plannings.iter().enumerate() {
        let cost = match p.guest_instructions {
            Some(g) => format!("{g} guest instructions"),
            None => "native".into(),
        };
        let expanded: u64 = p.attempts.iter().map(|a| a.expanded).sum();
        s.push_str(&format!(
            "    #{i} at {:>8.3}: {} attempt(s), {expanded} expanded, {cost}; {}\n",
            p.at_s,
            p.attempts.len(),
            p.reason
        ));
    }
    s.push_str("  expectations:\n");
    for v in verdicts {
        s.push_str(&format!(
            "    [{}] {}: {}\n",
            if v.ok { "ok  " } else { "FAIL" },
            v.what,
            v.got
        ));
    }
    let met = verdicts.iter().filter(|v| v.ok).count();
    s.push_str(&format!(
        "{} {}: {met}/{} expectations met; mission ended at {:.3} s; decisions sha256 {}\n",
        if met == verdicts.len() {
            "PASS"
        } else {
            "FAIL"
        },
        run.scenario,
        verdicts.len(),
        run.end_s,
        run.decisions_sha256
    ));
    s
}

#[derive(clap::Subcommand, Debug)]
pub enum RoverCommand {
    /// Run a rover scenario (plan, dispatch, replan) and check its expectations.
    Run(RoverRunArgs),
}

#[derive(clap::Args, Debug)]
pub struct RoverRunArgs {
    /// Rover scenario (TOML), e.g. scenarios/rover/sahara-day.toml
    pub scenario: PathBuf,
    /// Plan in the planner partition of the emulated RAD750 (one QEMU for the whole run).
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: the firmware ELF to boot (default: build it).
    #[arg(long, requires = "emulated")]
    pub firmware: Option<PathBuf>,
    /// Seed of the simulation (default: the scenario's `rover.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Print JSON (the run and the verdicts) instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Load, run and check a scenario file.
pub fn run_file(
    path: &Path,
    seed: Option<u64>,
    backend: &mut Backend,
) -> Result<(RoverRun, Vec<Verdict>), String> {
    let scenario = RoverScenario::load(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let seed = seed.unwrap_or(scenario.rover.seed);
    let run = run(&scenario, dir, seed, backend)?;
    let verdicts = check(&scenario, &run);
    Ok((run, verdicts))
}

/// `hil rover`: exit 0 when every expectation holds, 1 when one fails, 2 on bad input.
pub fn cli(command: RoverCommand) -> Result<ExitCode, String> {
    let RoverCommand::Run(args) = command;
    // A bad file is refused before anything boots.
    RoverScenario::load(&args.scenario)?;
    let mut backend = if args.emulated {
        let fw = match &args.firmware {
            Some(elf) => crate::firmware::FirmwareImage::open(elf).map_err(|e| e.to_string())?,
            None => {
                eprintln!("building firmware (cargo, powerpc-unknown-linux-gnu) ...");
                crate::firmware::build().map_err(|e| e.to_string())?
            }
        };
        Backend::Emulated(Box::new(crate::plan_emulated::EmulatedPlanner::boot(&fw)?))
    } else {
        Backend::native()
    };
    let (run, verdicts) = run_file(&args.scenario, args.seed, &mut backend)?;
    if args.json {
        #[derive(Serialize)]
        struct Out<'a> {
            run: &'a RoverRun,
            verdicts: &'a [Verdict],
        }
        println!(
            "{}",
            serde_json::to_string_pretty(&Out {
                run: &run,
                verdicts: &verdicts,
            })
            .map_err(|e| e.to_string())?
        );
    } else {
        print!("{}", render(&run, &verdicts));
    }
    Ok(if verdicts.iter().all(|v| v.ok) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
