//! `hil rover run FILE [--emulated] [--json]`: the planetary rover mission of seed 001
//! (section 3.3) flown with flexible dispatch and replanning (section 5).
//!
//! The scenario file names a PDDL domain and problem (`scenarios/rover/`), the waypoints'
//! positions for the path-estimate module that gives traverse durations (section 4.5), a
//! seeded simulation of the rover, and opportunistic science goals that arrive during the run.
//! The run:
//!
//! - the onboard side of the mission decides: `flight_app::rover_mission` inside the temporal
//!   plug-in, in the planner partition of the emulated RAD750 with `--emulated` (one QEMU for
//!   the whole run; [`onboard::Place::Emulated`]), or the same plug-in code in this process
//!   natively ([`onboard::Place::Native`]). It plans (every plan and replan a search of the
//!   plug-in, across windows), turns each plan into a dispatch network
//!   ([`temporal::replan::network_from_plan`]) and executes it with [`temporal::Dispatcher`]
//!   (start at lb if ready early, at once within (lb, ub], replan past ub; it names its next
//!   wake, just past the earliest ub of a step not yet executed, so an overrun is noticed
//!   when it happens); replans when a step is past its ub or an opportunistic goal arrives
//!   (nothing new dispatched, pausable running actions back to their inactive state, the
//!   others carried, the replan task built from the state now by
//!   [`temporal::replan::write_replan_task`]); drops the newest opportunistic goal when an
//!   attempt fails and tries again (5.3);
//! - the host plays the rover and the world ([`sim`]: how long each started action really
//!   takes, obstacles, when opportunistic goals arrive) and keeps the time: it sends events
//!   (`RoverEvent`: goal arrived, action ended, the rover's estimate of an end, poll at time
//!   t) and renders the mission's answers (`RoverReport`) as the transcript; it decides
//!   nothing, and has no dispatcher;
//! - prints the transcript and checks the file's expectations.
//!
//! Mission time does not advance while the planner runs (its cost is modelled from its
//! expansions, and measured on the emulated target in guest instructions), so the native and
//! the emulated run make the same decisions, which the transcript's decision lines (and their
//! hash) show.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use fsw_bridge::temporal::{
    RoverEvent, RoverReplanWhy, RoverReport, RoverStartKind, TemporalOutcome,
};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use temporal::Task;

pub mod exec_shadow;
mod onboard;
mod sim;

pub use onboard::{Backend, Damage, NativeOnboard, Place, ResetAt, Resume};
use sim::{Rng, RoverSim};

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
    /// Starts the mission decided and the host received (one per dispatch line), and the
    /// mission's reports received in all.
    pub dispatches_received: usize,
    pub reports_received: usize,
    /// What the onboard side cost on the target (emulated only).
    pub onboard: OnboardCosts,
    /// The target's health-monitor events (an overrun of the planner's window; emulated).
    pub health_events: Vec<String>,
    /// Resets of the planner partition injected during the run, and how the mission was taken
    /// up again from its checkpoint ([`onboard::ResetAt`]).
    pub resumes: Vec<onboard::Resume>,
}

/// An expectation and whether it held.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    pub ok: bool,
    pub what: String,
    pub got: String,
}

/// One planning attempt, as the mission reported it.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Attempt {
    pub outcome: String,
    pub expanded: u64,
    pub peak_arena_bytes: u64,
    /// Guest instructions the planner partition spent searching (emulated only).
    pub guest_instructions: Option<u64>,
    /// Guest instructions the mission spent building the attempt's replan task (the state, the
    /// pauses, the carried completions, `write_replan_task`; emulated only).
    pub build_instructions: Option<u64>,
}

/// What the onboard side cost on the target (emulated only), guest instructions.
#[derive(Clone, Debug, Default, Serialize)]
pub struct OnboardCosts {
    /// Polls of the dispatcher answered with a start or a wait, and their instructions (the
    /// dispatcher's STN windows, the start's conditions and effects).
    pub polls: u64,
    pub poll_instructions_max: u64,
    pub poll_instructions_total: u64,
    /// Replan tasks built (one per attempt).
    pub builds: u64,
    pub build_instructions_max: u64,
    pub build_instructions_total: u64,
    /// Networks built from plans (`network_from_plan` and the dispatcher's first windows).
    pub networks: u64,
    pub network_instructions_max: u64,
    pub network_instructions_total: u64,
}

impl OnboardCosts {
    fn add(n: &mut u64, max: &mut u64, total: &mut u64, ticks: u64) {
        let g = instructions(ticks);
        *n += 1;
        *max = (*max).max(g);
        *total += g;
    }
}

/// Guest instructions of `ticks` planner-partition timebase ticks.
fn instructions(ticks: u64) -> u64 {
    (ticks as f64 * crate::plan_emulated::INSTRUCTIONS_PER_TICK).round() as u64
}

fn secs(ticks: u32) -> f64 {
    f64::from(ticks) / 1000.0
}

/// A running action on the simulated rover.
#[derive(Clone, Debug)]
struct Active {
    action: u16,
    started: u32,
    ends: u32,
}

/// The host's side of a run: the rover and the world, the time, the transcript of what the
/// onboard mission decided.
struct World<'a> {
    base: &'a pddl::Compiled,
    task: Task<'a>,
    backend: &'a mut Backend,
    job: u16,
    sim: RoverSim,
    active: Vec<Active>,
    run: RoverRun,
    /// The carried actions of the current plan, in order (their completions' names).
    carried: Vec<u16>,
}

impl World<'_> {
    fn say(&mut self, t: u32, line: String) {
        let l = format!("{:>9.3}  {line}", secs(t));
        self.run.decisions.push(l.clone());
        self.run.transcript.push(l);
    }
    fn cost(&mut self, line: String) {
        self.run.transcript.push(format!("{:>9}  {line}", ""));
    }
    fn fact(&self, f: u16) -> String {
        self.base
            .fact_names
            .get(usize::from(f))
            .cloned()
            .unwrap_or_else(|| format!("(fact {f})"))
    }
    /// An action's name: the task's, or the completion of a carried action of the current plan.
    fn name(&self, a: u16) -> String {
        let base = self.task.action_count();
        match self.base.action_names.get(usize::from(a)) {
            Some(n) if usize::from(a) < base => n.clone(),
            _ => self
                .carried
                .get(usize::from(a).wrapping_sub(base))
                .and_then(|&c| self.base.action_names.get(usize::from(c)))
                .map_or_else(|| format!("(action {a})"), |n| format!("(finish {n})")),
        }
    }

    fn event(&mut self, event: RoverEvent) -> Result<Vec<RoverReport>, String> {
        let reports = self.backend.event(self.job, event)?;
        if let Some(RoverReport::Refused { reason }) = reports.last() {
            return Err(format!("the mission refused {event:?}: {reason:?}"));
        }
        self.run.reports_received += reports.len();
        Ok(reports)
    }

    /// The answer of a replan (after its `Replan`): the transcript, the planning; the mission
    /// time planning takes, or None when no plan came.
    fn replan(&mut self, reports: Vec<RoverReport>) -> Result<Option<u32>, String> {
        let mut it = reports.into_iter().peekable();
        let Some(RoverReport::Replan { at_ms: t, why }) = it.next() else {
            return Err("the mission's answer is not a replan".into());
        };
        let what = |w: &World<'_>, action: u16, end: bool| {
            if action == flight_app::rover_mission::NO_ACTION {
                String::new()
            } else {
                format!(
                    "{} of {}",
                    if end { "end" } else { "start" },
                    w.name(action)
                )
            }
        };
        let reason = match why {
            RoverReplanWhy::Initial => "initial plan".to_string(),
            RoverReplanWhy::Goal { fact } => {
                format!("opportunistic goal {} arrived", self.fact(fact))
            }
            RoverReplanWhy::PastUb {
                step,
                action,
                end,
                ub_ms,
            } => {
                self.run.overrun_replans += 1;
                format!(
                    "overrun: step {step} ({}) past its ub {:.3}",
                    what(self, action, end),
                    secs(ub_ms)
                )
            }
            RoverReplanWhy::NoLongerFits { step, action, end } => {
                self.run.overrun_replans += 1;
                format!(
                    "overrun: what followed step {step} ({}) no longer fits the plan's windows",
                    what(self, action, end)
                )
            }
        };
        self.say(t, format!("replan: {reason}"));
        let mut planning = Planning {
            at_s: secs(t),
            reason,
            attempts: Vec::new(),
            carried: Vec::new(),
            paused: Vec::new(),
            dropped: Vec::new(),
            solved: false,
            actions: 0,
            makespan_s: 0.0,
            guest_instructions: None,
        };
        let emulated = self.backend.emulated();
        let goal_count = self.task.goal_facts().len();
        let mut carried = Vec::new();
        let mut extra: Vec<u16> = Vec::new();
        let mut plan_lines = Vec::new();
        let mut new_plan: Option<(u16, u32)> = None;
        let mut takes = None;
        for r in it.by_ref() {
            match r {
                RoverReport::Paused { action } => {
                    let n = self.name(action);
                    self.say(
                        t,
                        format!("  pause {n}: back to its inactive state, not done"),
                    );
                    planning.paused.push(n);
                    self.run.paused += 1;
                    // The rover stops it: it will not end.
                    self.active.retain(|a| a.action != action);
                }
                RoverReport::Carried {
                    action,
                    since_ms,
                    left_ms,
                } => {
                    let n = self.name(action);
                    self.say(
                        t,
                        format!(
                            "  carry {n} (running since {:.3}, {:.3} s left)",
                            secs(since_ms),
                            secs(left_ms)
                        ),
                    );
                    planning.carried.push(n);
                    carried.push(action);
                }
                RoverReport::AttemptGoal { fact } => extra.push(fact),
                RoverReport::Attempt {
                    index,
                    outcome,
                    actions,
                    expanded,
                    peak_arena_bytes,
                    build_ticks,
                    planning_ticks,
                    hard_goals,
                } => {
                    let goals: Vec<String> = extra.drain(..).map(|g| self.fact(g)).collect();
                    let outcome = outcome_name(outcome);
                    debug_assert_eq!(usize::from(hard_goals), goal_count);
                    self.say(
                        t,
                        format!(
                            "  attempt {index}: {hard_goals} hard goals{}{}: {outcome}, {actions} actions, {expanded} expanded",
                            if goals.is_empty() { "" } else { " + opportunistic " },
                            goals.join(" "),
                        ),
                    );
                    let attempt = Attempt {
                        outcome,
                        expanded: expanded.into(),
                        peak_arena_bytes: peak_arena_bytes.into(),
                        guest_instructions: emulated.then(|| instructions(planning_ticks)),
                        build_instructions: emulated.then(|| instructions(build_ticks.into())),
                    };
                    if let Some(g) = attempt.guest_instructions {
                        self.cost(format!(
                            "  planner partition: {g} guest instructions, peak arena {peak_arena_bytes} bytes; the replan task built in {} guest instructions",
                            attempt.build_instructions.unwrap_or(0)
                        ));
                        let c = &mut self.run.onboard;
                        OnboardCosts::add(
                            &mut c.builds,
                            &mut c.build_instructions_max,
                            &mut c.build_instructions_total,
                            build_ticks.into(),
                        );
                    } else {
                        self.cost(format!("  native: peak arena {peak_arena_bytes} bytes"));
                    }
                    planning.attempts.push(attempt);
                }
                RoverReport::Dropped { fact } => {
                    let n = self.fact(fact);
                    self.say(t, format!("  drop opportunistic goal {n}"));
                    planning.dropped.push(n.clone());
                    self.run.dropped.push(n);
                }
                RoverReport::NoPlan => {
                    self.say(t, "  no plan: the mission stops here".into());
                    planning.guest_instructions = sum_guest(&planning.attempts);
                    self.run.plannings.push(planning);
                    return Ok(None);
                }
                RoverReport::NewPlan {
                    actions,
                    makespan_ms,
                    network_ticks,
                } => {
                    self.carried = carried.clone();
                    new_plan = Some((actions, makespan_ms));
                    self.say(
                        t,
                        format!(
                            "  new plan: {actions} actions, makespan {:.3} s (ends at {:.3})",
                            secs(makespan_ms),
                            secs(t + makespan_ms)
                        ),
                    );
                    if emulated {
                        let c = &mut self.run.onboard;
                        OnboardCosts::add(
                            &mut c.networks,
                            &mut c.network_instructions_max,
                            &mut c.network_instructions_total,
                            network_ticks.into(),
                        );
                    }
                }
                RoverReport::PlanStep {
                    action,
                    start_ms,
                    duration_ms,
                    lb_ms,
                    ub_ms,
                    ..
                } => {
                    let line = format!(
                        "    {:>9.3} {} [{:.3}] start window [{:.3}, {:.3}]",
                        secs(start_ms),
                        self.name(action),
                        secs(duration_ms),
                        secs(lb_ms),
                        secs(ub_ms)
                    );
                    plan_lines.push(line.clone());
                    self.say(t, line);
                }
                RoverReport::PlanningTakes {
                    expansions,
                    until_ms,
                } => {
                    takes = Some(until_ms - t);
                    self.say(
                        t,
                        format!(
                            "  planning takes {:.3} s ({expansions} expansions): nothing new dispatched until {:.3}",
                            secs(until_ms - t),
                            secs(until_ms)
                        ),
                    );
                }
                other => return Err(format!("unexpected in a replan: {other:?}")),
            }
        }
        let (Some((actions, makespan)), Some(takes)) = (new_plan, takes) else {
            return Err("the replan's answer ended before its plan".into());
        };
        planning.solved = true;
        planning.actions = usize::from(actions);
        planning.makespan_s = secs(makespan);
        planning.guest_instructions = sum_guest(&planning.attempts);
        self.run.plannings.push(planning);
        Ok(Some(takes))
    }

    /// The rover's actions that end by `t`, in time order: each reported to the mission.
    fn end_actions(&mut self, t: u32) -> Result<(), String> {
        loop {
            let Some(i) = (0..self.active.len())
                .filter(|&i| self.active[i].ends <= t)
                .min_by_key(|&i| (self.active[i].ends, self.active[i].action))
            else {
                return Ok(());
            };
            let a = self.active.remove(i);
            let estimate = self.task.action(usize::from(a.action)).duration_lb;
            let took = a.ends - a.started;
            let name = self.name(a.action);
            let diff = if took == estimate {
                String::new()
            } else {
                format!(
                    " ({:+.3} s on the estimate {:.3})",
                    (f64::from(took) - f64::from(estimate)) / 1000.0,
                    secs(estimate)
                )
            };
            self.say(
                a.ends,
                format!("end {name} after {:.3} s{diff}", secs(took)),
            );
            let answer = self.event(RoverEvent::Ended {
                action: a.action,
                at_ms: a.ends,
            })?;
            if !matches!(answer.last(), Some(RoverReport::EndTaken { action }) if *action == a.action)
            {
                return Err(format!("the mission answered an end with {answer:?}"));
            }
        }
    }
}

fn sum_guest(attempts: &[Attempt]) -> Option<u64> {
    attempts.iter().map(|a| a.guest_instructions).sum()
}

fn outcome_name(o: TemporalOutcome) -> String {
    match o {
        TemporalOutcome::Solved => "solved".into(),
        TemporalOutcome::Unsolvable => "unsolvable".into(),
        TemporalOutcome::OutOfMemory(r) => format!("out of memory ({r:?})"),
        TemporalOutcome::ExpansionLimit => "expansion limit".into(),
        TemporalOutcome::WindowLimit => "window limit".into(),
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
    // Opportunistic goals arrive after compiling: keep the actions that reach them.
    let mut options = crate::plan::PlanOptions::default();
    options.pddl.prune_irrelevant = false;
    let (_, _, compiled, _) = crate::plan::compile_files(
        &dir.join(&scenario.rover.domain),
        &dir.join(&scenario.rover.problem),
        &modules,
        &options,
    )
    .map_err(|e| e.render())?;
    Ok(compiled)
}

/// Run the scenario with `backend`: the host plays the rover, the world and the time; the
/// onboard mission (in the planner partition with `--emulated`) decides.
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
    let target = if backend.emulated() {
        "emulated"
    } else {
        "native"
    };
    let start = RoverEvent::Start {
        horizon_slack_ms: (scenario.dispatch.horizon_slack_s * 1000.0).round() as u32,
        max_expansions: scenario.dispatch.max_expansions,
        us_per_expansion: (scenario.dispatch.planning_ms_per_expansion * 1000.0).round() as u32,
    };
    let (job, ready) = backend.start(&base.task, start)?;
    if !matches!(ready.last(), Some(RoverReport::Ready { .. })) {
        return Err(format!("the mission did not take the task: {ready:?}"));
    }
    let mut w = World {
        base: &base,
        task,
        backend,
        job,
        sim: RoverSim {
            rng: Rng::new(seed),
            sim: scenario.simulation.clone(),
            blocked: scenario
                .simulation
                .obstacles
                .iter()
                .map(|o| o.traverse.clone())
                .collect(),
        },
        active: Vec::new(),
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
            dispatches_received: 0,
            reports_received: ready.len(),
            onboard: OnboardCosts::default(),
            health_events: Vec::new(),
            resumes: Vec::new(),
        },
        carried: Vec::new(),
    };
    // The components' inactive states (5.1): metadata outside the PDDL, uplinked with the
    // mission (the `inactive-` naming convention of this domain).
    for (f, name) in base.fact_names.iter().enumerate() {
        if name.starts_with("(inactive-") {
            w.event(RoverEvent::Inactive { fact: f as u16 })?;
        }
    }
    let mut t = 0u32;
    let mut alive = false;
    // Opportunistic goals known from the start (`at_s = 0`) are in the first plan's goals.
    while arrivals.first().is_some_and(|a| a.0 == 0) {
        let (_, id, name) = arrivals.remove(0);
        let answer = w.event(RoverEvent::Goal { fact: id, at_ms: 0 })?;
        if !matches!(answer.last(), Some(RoverReport::Optional { fact }) if *fact == id) {
            return Err(format!("the mission answered a goal with {answer:?}"));
        }
        w.say(0, format!("optional goal {name} from the start"));
    }
    let first = w.event(RoverEvent::Poll { now_ms: 0 })?;
    if let Some(p) = w.replan(first)? {
        alive = true;
        t = p;
    }
    let mut guard = 0u32;
    while alive {
        guard += 1;
        if guard > 100_000 {
            return Err("the run did not end (more than 100,000 decisions)".into());
        }
        // Opportunities arriving now.
        if arrivals.first().is_some_and(|a| a.0 <= t) {
            let (_, id, _) = arrivals.remove(0);
            let answer = w.event(RoverEvent::Goal { fact: id, at_ms: t })?;
            let planned = w.replan(answer)?;
            alive = planned.is_some();
            // While the planner runs, what is running goes on (and may end).
            t += planned.unwrap_or(0);
            w.end_actions(t)?;
            continue;
        }
        let answer = w.event(RoverEvent::Poll { now_ms: t })?;
        match answer.last().copied() {
            Some(RoverReport::Dispatch {
                action,
                at_ms,
                lb_ms,
                ub_ms,
                kind,
                poll_ticks,
                ..
            }) => {
                w.run.dispatches_received += 1;
                if w.backend.emulated() {
                    let c = &mut w.run.onboard;
                    OnboardCosts::add(
                        &mut c.polls,
                        &mut c.poll_instructions_max,
                        &mut c.poll_instructions_total,
                        poll_ticks.into(),
                    );
                }
                let name = w.name(action);
                let when = match kind {
                    RoverStartKind::Early { by_ms } => {
                        w.run.started_early += 1;
                        format!(
                            "{:.3} s before its planned lb (what it follows ended early)",
                            secs(by_ms)
                        )
                    }
                    RoverStartKind::AtLb => {
                        w.run.started_at_lb += 1;
                        "at lb".to_string()
                    }
                    RoverStartKind::HeldToLb { waited_ms } => {
                        w.run.started_at_lb += 1;
                        w.run.held_to_lb += 1;
                        format!("at lb (ready {:.3} s early, held to lb)", secs(waited_ms))
                    }
                    RoverStartKind::Late { by_ms } => {
                        w.run.started_late += 1;
                        format!("{:.3} s after lb, within (lb, ub]", secs(by_ms))
                    }
                };
                w.say(
                    at_ms,
                    format!(
                        "dispatch {name} window [{:.3}, {:.3}] {when}",
                        secs(lb_ms),
                        secs(ub_ms)
                    ),
                );
                // The rover starts it; how long it takes is the world's.
                let estimate = w.task.action(usize::from(action)).duration_lb;
                let (actual, why) = w.sim.duration(&name, estimate);
                if let Some(why) = why {
                    w.say(
                        at_ms,
                        format!(
                            "  ({why}: will take {:.3} s, estimate {:.3} s)",
                            secs(actual),
                            secs(estimate)
                        ),
                    );
                }
                w.active.push(Active {
                    action,
                    started: at_ms,
                    ends: at_ms + actual,
                });
                // The rover's own estimate of its end (its navigation's).
                w.event(RoverEvent::Expected {
                    action,
                    ends_ms: at_ms + actual,
                })?;
            }
            Some(RoverReport::PlanningTakes { .. } | RoverReport::NoPlan) => {
                let planned = w.replan(answer)?;
                alive = planned.is_some();
                t += planned.unwrap_or(0);
                w.end_actions(t)?;
            }
            Some(RoverReport::Wait {
                wake_ms,
                poll_ticks,
            }) => {
                if w.backend.emulated() {
                    let c = &mut w.run.onboard;
                    OnboardCosts::add(
                        &mut c.polls,
                        &mut c.poll_instructions_max,
                        &mut c.poll_instructions_total,
                        poll_ticks.into(),
                    );
                }
                // Wake at what the mission asked, the next end on the rover, or the next
                // arrival.
                let next = [
                    wake_ms,
                    w.active.iter().map(|a| a.ends).min(),
                    arrivals.first().map(|a| a.0),
                ]
                .into_iter()
                .flatten()
                .filter(|&x| x > t)
                .min();
                let Some(next) = next else {
                    w.say(t, "stuck: nothing to wait for".into());
                    break;
                };
                t = next;
                w.end_actions(t)?;
            }
            Some(RoverReport::Finished) => {
                if let Some(&(at, _, _)) = arrivals.first() {
                    t = t.max(at);
                    continue;
                }
                w.run.finished = true;
                w.say(t, "finished: every step of the plan executed".into());
                break;
            }
            other => return Err(format!("the mission answered a poll with {other:?}")),
        }
    }
    // The goals, as the mission's state has them.
    let answer = w.event(RoverEvent::Close { now_ms: t })?;
    for r in &answer {
        match *r {
            RoverReport::Achieved { fact } => {
                let n = w.fact(fact);
                w.run.achieved.push(n);
            }
            RoverReport::Kept { fact } => {
                let n = w.fact(fact);
                w.run.accepted.push(n);
            }
            _ => {}
        }
    }
    let achieved = w.run.achieved.join(" ");
    w.say(t, format!("goals achieved: {achieved}"));
    let dropped = w.run.dropped.join(" ");
    if !dropped.is_empty() {
        w.say(t, format!("opportunistic goals dropped: {dropped}"));
    }
    w.run.end_s = secs(t);
    w.run.health_events = w.backend.health_events();
    w.run.resumes = w.backend.resumes.clone();
    for h in w.backend.health_during.clone() {
        w.cost(format!("health monitor: {h}"));
    }
    for r in w.run.resumes.clone() {
        w.cost(format!(
            "planner partition reset during event {}: the mission resumed from its checkpoint after event {} ({} guest instructions), {} event(s) sent again and answered the same",
            r.during_event,
            r.resumed_after,
            instructions(u64::from(r.restore_ticks)),
            r.replayed
        ));
    }
    let mut h = Sha256::new();
    for l in &w.run.decisions {
        h.update(l.as_bytes());
        h.update(b"\n");
    }
    w.run.decisions_sha256 = format!("{:x}", h.finalize())[..16].to_string();
    Ok(w.run)
}

/// One onboard cost of `scenario` (relative to the repository) flown by the emulated target
/// booted from `firmware`, guest instructions (`budgets.toml`'s `rover:` sources): the most
/// costly dispatcher poll (`max_poll_instructions`), replan task built
/// (`max_build_instructions`) or network built (`max_network_instructions`). A run whose
/// expectations fail is an error (its costs are not representative).
pub fn onboard_metric(
    scenario: &str,
    metric: &str,
    firmware: &crate::firmware::FirmwareImage,
) -> Result<u64, String> {
    let target = crate::plan_emulated::EmulatedPlanner::boot(firmware)?;
    let mut backend = Backend::on_target(target);
    let (run, verdicts) = run_file(&crate::repo_root().join(scenario), None, &mut backend)?;
    if let Some(v) = verdicts.iter().find(|v| !v.ok) {
        return Err(format!("{scenario}: {}: {}", v.what, v.got));
    }
    let c = &run.onboard;
    match metric {
        "max_poll_instructions" => Ok(c.poll_instructions_max),
        "max_build_instructions" => Ok(c.build_instructions_max),
        "max_network_instructions" => Ok(c.network_instructions_max),
        _ => Err(format!(
            "no rover metric {metric:?} (max_poll_instructions, max_build_instructions, max_network_instructions)"
        )),
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
    let c = &run.onboard;
    if c.polls > 0 {
        s.push_str(&format!(
            "  onboard (planner partition, guest instructions): {} dispatcher polls, at most {}, {} in all; {} replan tasks built, at most {}, {} in all; {} networks, at most {}, {} in all\n",
            c.polls,
            c.poll_instructions_max,
            c.poll_instructions_total,
            c.builds,
            c.build_instructions_max,
            c.build_instructions_total,
            c.networks,
            c.network_instructions_max,
            c.network_instructions_total
        ));
    }
    for h in &run.health_events {
        s.push_str(&format!("  health monitor: {h}\n"));
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
        Backend::on_target(crate::plan_emulated::EmulatedPlanner::boot(&fw)?)
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
