//! The lander's executor (seed 000 III.B-D, IV.C.3): executes a plan of chains primitive by
//! primitive, with flexible execution (task push and automated retry), replanning from the
//! current state, model parameter updates, and the four strategies of III.D.
//!
//! It is a value-in, value-out state machine with no global state: every call of
//! [`Executor::step`] takes an [`Observation`] (the time, the battery charge, whether the
//! pending primitive's preconditions hold, and at most one [`Event`]: a primitive finished, or
//! ground input arrived) and a budget of search explorations, and returns one [`Directive`]
//! (dispatch this primitive, wait until, push, replanning, halted for ground, abandoned, done).
//! The caller (the lander simulation on the host; later the planner and executive partitions)
//! owns time and the world. Every decision is also appended to a log ([`Decision`]), the
//! transcript the tests compare.
//!
//! - **Task push** (III.B): when a primitive is due and its preconditions do not hold, the
//!   executor waits for them up to [`ExecConfig::push_timeout_us`]; past the timeout the
//!   primitive has failed.
//! - **Automated retry** (III.B): a primitive that completes with a failure code
//!   ([`TaskResult::Failed`]) while its preconditions still hold is dispatched again at once,
//!   at most [`ExecConfig::max_retries`] times; the plan's later primitives move to start no
//!   earlier than the retry's predicted end, and the plan's predicted end and energy
//!   ([`Executor::prediction`]) include the retry.
//! - **Replanning** (III.C): the search ([`crate::search::Search`], through the Assessor's
//!   placement) runs again from the current state: the time and charge observed now (the
//!   placement's horizon starts now, and its battery and the search's M are the charge now,
//!   so every under- or overrun is accounted for), the tasks executed (held fixed: left out of
//!   the search, their data in the Assessor's context) and failed (left out, and their targets
//!   marked failed), the durations and energies updated by measurement, and the utilities the
//!   Assessor predicts in the updated context. The search is stepped within the budget of each
//!   call, so a replan spreads over as many calls as it needs.
//! - **Model parameter updates** (IV.C.3): when a primitive with a site completes, its
//!   measured duration and energy replace the priors of every primitive of the same kind at
//!   the same site: at once in the remaining plan's predictions, and in every later replan.
//! - **Strategies** (III.D), [`Strategy`]: Static abandons the rest of the plan at the first
//!   failure; Ground halts and waits for ground input at every failure; FE pushes and retries,
//!   and halts for ground when that does not resolve the failure; Replan pushes and retries,
//!   then replans (also after a negative biosignature, to exploit what was discovered), and
//!   halts for ground only for a fault, or when the replan fails. Replan also replans, at the
//!   next chain boundary, after a negative biosignature (utility discovery: the subway map
//!   moves on) and when measured overruns leave the remaining plan more energy than the charge.
//!
//! States in a replan: targets collected, biosignatures and excavated sites are in the
//! Assessor's context; an excavation of a site already excavated costs nothing and is not
//! dispatched ([`already_done`]).
//!
//! Limits: a replan drops the interrupted chain's remaining primitives (its task counts as
//! failed); ground holds are not carried into a replan (the replan's placement starts with
//! none in force), so replanning is meant for the fully-autonomous flag; plans hold at most
//! [`MAX_EXEC_STEPS`] primitives.
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use crate::assessor::{chain_science, AssessedPlacement, Assessor, Biosignature, ChainScience};
use crate::assessor::{SampleRef, ScienceContext};
use crate::capacity::*;
use crate::htn::{FlatNetwork, HtnModel, PrimitiveKind, PrimitiveSpec};
use crate::placement::TimelinePlacement;
use crate::search::{PlacedChain, Search, SearchConfig, SearchStats};
use crate::utility::RankedUtility;

/// Primitives in the executor's plan.
pub const MAX_EXEC_STEPS: usize = 256;
/// Decisions kept in the log (later ones are counted in [`ExecStats::log_overflows`]).
pub const MAX_DECISIONS: usize = 512;
/// The search's exploration bound per batch unless configured otherwise
/// ([`ExecConfig::exploration_bound`]).
pub const DEFAULT_EXPLORATION_BOUND: u32 = 1_000;
/// Measured (kind, site) parameters kept.
pub const MAX_PARAMETER_UPDATES: usize = 64;

/// The planning and execution strategy (III.D), chosen per run by uplinked configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Execute the plan unchanged; the first failure abandons the rest.
    Static,
    /// Every failure halts execution until ground input resolves it.
    Ground,
    /// Flexible execution (push, retry); what it cannot resolve goes to ground.
    FlexibleExecution,
    /// Flexible execution, then replanning, then ground as the last resort.
    Replan,
}

/// The executor's configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExecConfig {
    pub strategy: Strategy,
    /// Task push: how long a due primitive waits for its preconditions.
    pub push_timeout_us: u64,
    /// Automated retries of one primitive.
    pub max_retries: u8,
    /// The search's exploration bound per batch, for the initial plan and every replan.
    pub exploration_bound: Option<u32>,
    /// Energy held back by the search (see [`SearchConfig::reserve_mj`]).
    pub reserve_mj: u64,
}

impl ExecConfig {
    pub const fn new(strategy: Strategy) -> Self {
        Self {
            strategy,
            push_timeout_us: 3_600_000_000,
            max_retries: 2,
            exploration_bound: Some(DEFAULT_EXPLORATION_BOUND),
            reserve_mj: 0,
        }
    }

    fn flexible(&self) -> bool {
        matches!(
            self.strategy,
            Strategy::FlexibleExecution | Strategy::Replan
        )
    }
}

/// How a primitive ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskResult {
    Succeeded,
    /// Completed with a failure code (a retry may succeed if the preconditions still hold).
    Failed,
    /// A fault only ground can resolve.
    Faulted,
}

/// A finished primitive, as measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outcome {
    pub result: TaskResult,
    pub duration_us: u64,
    pub energy_mj: u64,
    /// The biosignature result, when the primitive is a sample's analysis.
    pub biosignature: Option<Biosignature>,
}

/// Something that happened since the last step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// The dispatched primitive finished.
    Finished(Outcome),
    /// Ground resolved the problem the executor halted for: execution resumes with the
    /// primitive it halted at.
    GroundResume,
}

/// The input of one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Observation {
    pub now: MissionTimeUs,
    pub battery_mj: u64,
    /// Whether the preconditions of the pending primitive (the first of
    /// [`Executor::remaining`] before this step) hold now: the executive's check on the
    /// world. When the step makes another primitive pending (the previous one finished, or a
    /// new plan), it does not dispatch it on this answer but returns a [`Directive::Wait`]
    /// (until now, if it is due), so that the next observation answers for it.
    pub preconditions_met: bool,
    pub event: Option<Event>,
}

/// Why execution stopped or replanned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// The first plan.
    Initial,
    /// A primitive completed with a failure code that was not resolved by a retry.
    Failed,
    /// A primitive's preconditions did not hold (after the push timeout, when pushing).
    PreconditionsUnmet,
    /// A fault only ground can resolve.
    Fault,
    /// A negative biosignature: the map moves on (utility discovery).
    Discovery,
    /// The remaining plan's predicted energy exceeds the charge (measured overruns).
    Overrun,
    /// The search could not start.
    ReplanFailed,
}

/// The output of one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Directive {
    /// Start this primitive now.
    Dispatch {
        chain: u16,
        primitive: u8,
        kind: PrimitiveKind,
        site: Option<u8>,
        target: Option<u8>,
        expected_end: MissionTimeUs,
        expected_energy_mj: u64,
    },
    /// The dispatched primitive is running.
    Running { expected_end: MissionTimeUs },
    /// Nothing is due before `until`.
    Wait { until: MissionTimeUs },
    /// Task push: the due primitive waits for its preconditions until `deadline`.
    Pushing { deadline: MissionTimeUs },
    /// The search is running; call again with more budget.
    Planning { reason: Reason },
    /// Halted: waiting for ground input.
    HaltedForGround { reason: Reason },
    /// The rest of the plan is abandoned (Static).
    Abandoned { reason: Reason },
    /// The plan is executed.
    Done,
}

/// One entry of the executor's transcript.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecisionKind {
    Dispatched,
    Completed,
    /// Completed with a failure code or a fault.
    Failed,
    Retried,
    PushStarted,
    PushTimedOut,
    ParameterUpdated,
    ReplanStarted(Reason),
    /// A plan was installed; the number of chains in it.
    Planned {
        chains: u8,
    },
    HaltedForGround(Reason),
    GroundResumed,
    Abandoned(Reason),
    Finished,
}

/// A decision, when and about which primitive (`u16::MAX`/`u8::MAX` when none).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decision {
    pub at: MissionTimeUs,
    pub chain: u16,
    pub primitive: u8,
    pub kind: DecisionKind,
}

/// Counters of one executor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExecStats {
    pub dispatched: u32,
    pub retries: u32,
    pub pushes: u32,
    pub push_timeouts: u32,
    pub replans: u32,
    pub ground_halts: u32,
    pub parameter_updates: u32,
    /// Search explorations over every plan made.
    pub explored: u32,
    /// Search nodes over every plan made.
    pub nodes: u32,
    pub log_overflows: u32,
}

/// A primitive of the plan, with its predictions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExecStep {
    pub chain: u16,
    /// Index into the model's primitives.
    pub primitive: u8,
    /// The start the plan gave it (it never starts earlier).
    pub planned_start: MissionTimeUs,
    /// The predicted start: no earlier than the plan's, nor than the previous primitive's
    /// predicted end; the actual start once dispatched.
    pub start: MissionTimeUs,
    pub duration_us: u64,
    pub energy_mj: u64,
    pub retries: u8,
    pub last_in_chain: bool,
}

/// A measured parameter replacing the priors of (kind, site).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParameterUpdate {
    pub kind: PrimitiveKind,
    pub site: u8,
    pub duration_us: u64,
    pub energy_mj: u64,
}

/// The plan's predicted end and total energy (spent so far and still to spend).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prediction {
    pub end: MissionTimeUs,
    pub energy_mj: u64,
}

/// Why an executor could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExecError {
    /// The plan names a chain the network does not have, or a primitive the model does not.
    UnknownChain,
    /// The plan has more than [`MAX_EXEC_STEPS`] primitives or [`MAX_PLAN_CHAINS`] chains.
    PlanTooLong,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Ready,
    Pushing { since: MissionTimeUs },
    Running,
    Planning { reason: Reason },
    Halted { reason: Reason },
    Abandoned { reason: Reason },
    Done,
}

const NONE_CHAIN: u16 = u16::MAX;
const NONE_PRIMITIVE: u8 = u8::MAX;

/// The executor. `NODES` and `QUEUE` size its search (see [`Search`]).
pub struct Executor<const NODES: usize = MAX_SEARCH_NODES, const QUEUE: usize = MAX_EXPLORE_QUEUE> {
    config: ExecConfig,
    primitives: Vec<PrimitiveSpec, MAX_PRIMITIVES>,
    /// The flattened network with the current parameters.
    network: FlatNetwork,
    science: Vec<ChainScience, MAX_CHAINS>,
    context: ScienceContext,
    assessor: Assessor,
    /// The placement's horizon end, phases and hotel load (its start and charge are set at
    /// each plan).
    timeline: TimelinePlacement,
    params: Vec<ParameterUpdate, MAX_PARAMETER_UPDATES>,
    steps: Vec<ExecStep, MAX_EXEC_STEPS>,
    cursor: usize,
    mode: Mode,
    /// Chains executed to the end, with their actual starts.
    executed: Vec<PlacedChain, MAX_PLAN_CHAINS>,
    /// Task slots executed or failed: left out of replans.
    closed_tasks: Vec<u8, MAX_SEARCH_TASKS>,
    /// Replan at the next chain boundary (Replan only): a negative biosignature was seen, or
    /// the remaining plan no longer fits the charge.
    replan_pending: Option<Reason>,
    search: Search<NODES, QUEUE>,
    planning_from: (MissionTimeUs, u64),
    /// Plans installed so far (tells a pending primitive of a new plan from the old one's).
    plans: u32,
    log: Vec<Decision, MAX_DECISIONS>,
    stats: ExecStats,
    last_search: SearchStats,
    last_plan_value: (RankedUtility, u64),
    initial_battery_mj: u64,
    now: MissionTimeUs,
    battery_mj: u64,
}

impl<const NODES: usize, const QUEUE: usize> Executor<NODES, QUEUE> {
    /// An executor for the chains of `network` (flattened from `model`), the placement
    /// `timeline` (its horizon start and battery are the mission's start and charge), the
    /// science `context`. With `plan` it executes that plan (made before execution); without,
    /// its first steps make the plan with the search.
    pub fn new(
        config: ExecConfig,
        model: &HtnModel,
        network: &FlatNetwork,
        timeline: &TimelinePlacement,
        context: &ScienceContext,
        plan: Option<&[PlacedChain]>,
    ) -> Result<Self, ExecError> {
        let mut e = Self {
            config,
            primitives: model.primitives.clone(),
            network: network.clone(),
            science: chain_science(&model.primitives, network),
            context: context.clone(),
            assessor: Assessor::default(),
            timeline: timeline.clone(),
            params: Vec::new(),
            steps: Vec::new(),
            cursor: 0,
            mode: Mode::Ready,
            executed: Vec::new(),
            closed_tasks: Vec::new(),
            replan_pending: None,
            search: Search::new(SearchConfig::exhaustive(0)),
            planning_from: (timeline.horizon_start, timeline.battery_mj),
            plans: 0,
            log: Vec::new(),
            stats: ExecStats::default(),
            last_search: SearchStats::default(),
            last_plan_value: (RankedUtility::ZERO, 0),
            initial_battery_mj: timeline.battery_mj,
            now: timeline.horizon_start,
            battery_mj: timeline.battery_mj,
        };
        match plan {
            Some(plan) => e.install(plan)?,
            None => e.begin_planning(Reason::Initial),
        }
        Ok(e)
    }

    pub fn config(&self) -> &ExecConfig {
        &self.config
    }

    pub fn stats(&self) -> &ExecStats {
        &self.stats
    }

    /// The statistics of the last search (initial plan or replan).
    pub fn last_search(&self) -> &SearchStats {
        &self.last_search
    }

    /// The utility (as the Assessor predicted it) and energy of the last plan the search made.
    pub fn last_plan_value(&self) -> (RankedUtility, u64) {
        self.last_plan_value
    }

    pub fn log(&self) -> &[Decision] {
        &self.log
    }

    pub fn context(&self) -> &ScienceContext {
        &self.context
    }

    pub fn network(&self) -> &FlatNetwork {
        &self.network
    }

    /// The plan's primitives not yet finished, the first being the pending or running one.
    pub fn remaining(&self) -> &[ExecStep] {
        self.steps.get(self.cursor..).unwrap_or(&[])
    }

    /// The chains executed to the end.
    pub fn executed(&self) -> &[PlacedChain] {
        &self.executed
    }

    /// The measured parameters in force.
    pub fn parameters(&self) -> &[ParameterUpdate] {
        &self.params
    }

    /// The predicted duration and energy of primitive `index`: the measured parameters of its
    /// kind at its site if there are any, else the model's priors.
    pub fn predicted(&self, index: u8) -> Option<(u64, u64)> {
        predicted(&self.primitives, &self.params, index)
    }

    /// The plan's predicted end and total energy: what was spent since the start, and the
    /// predicted energy of every primitive not yet finished.
    pub fn prediction(&self) -> Prediction {
        let remaining = self.remaining();
        let end = remaining.last().map_or(self.now, |s| {
            MissionTimeUs(s.start.0.saturating_add(s.duration_us))
        });
        let spent = self.initial_battery_mj.saturating_sub(self.battery_mj);
        let energy = remaining
            .iter()
            .fold(spent, |e, s| e.saturating_add(s.energy_mj));
        Prediction {
            end,
            energy_mj: energy,
        }
    }

    /// The realised utility of the chains executed to the end (their flattened utility with
    /// the parameters of the time).
    pub fn executed_utility(&self) -> RankedUtility {
        self.executed.iter().fold(RankedUtility::ZERO, |u, p| {
            self.network
                .chains
                .get(usize::from(p.chain))
                .map_or(u, |c| u.saturating_add(&c.utility))
        })
    }

    fn record(&mut self, chain: u16, primitive: u8, kind: DecisionKind) {
        let d = Decision {
            at: self.now,
            chain,
            primitive,
            kind,
        };
        if self.log.push(d).is_err() {
            self.stats.log_overflows += 1;
        }
    }

    fn record_step(&mut self, kind: DecisionKind) {
        let (chain, primitive) = self
            .steps
            .get(self.cursor)
            .map_or((NONE_CHAIN, NONE_PRIMITIVE), |s| (s.chain, s.primitive));
        self.record(chain, primitive, kind);
    }

    /// One step: takes in the observation, decides, and says what to do.
    pub fn step(&mut self, observation: &Observation, budget: u32) -> Directive {
        self.now = observation.now;
        self.battery_mj = observation.battery_mj;
        let observed = self.pending();
        match observation.event {
            Some(Event::Finished(outcome)) => self.on_finished(outcome, observation),
            Some(Event::GroundResume) => {
                if let Mode::Halted { .. } = self.mode {
                    self.record_step(DecisionKind::GroundResumed);
                    if let Some(s) = self.steps.get_mut(self.cursor) {
                        s.retries = 0;
                    }
                    self.mode = Mode::Ready;
                }
            }
            None => {}
        }
        // Each pass either returns or changes the mode towards a return; a few passes suffice
        // (finish a plan, replan, dispatch).
        for _ in 0..8 {
            match self.mode {
                Mode::Done => return Directive::Done,
                Mode::Halted { reason } => return Directive::HaltedForGround { reason },
                Mode::Abandoned { reason } => return Directive::Abandoned { reason },
                Mode::Running => {
                    return Directive::Running {
                        expected_end: self.steps.get(self.cursor).map_or(self.now, |s| {
                            MissionTimeUs(s.start.0.saturating_add(s.duration_us))
                        }),
                    }
                }
                Mode::Planning { reason } => {
                    if !self.continue_planning(budget) {
                        return Directive::Planning { reason };
                    }
                }
                Mode::Ready | Mode::Pushing { .. } => {
                    let met = observation.preconditions_met && self.pending() == observed;
                    if let Some(d) = self.advance(met, self.pending() == observed) {
                        return d;
                    }
                }
            }
        }
        // Not reached with the modes above; asking again is always safe.
        Directive::Wait { until: self.now }
    }

    /// The pending primitive: (plan number, chain, primitive), if any.
    fn pending(&self) -> Option<(u32, u16, u8)> {
        self.steps
            .get(self.cursor)
            .map(|s| (self.plans, s.chain, s.primitive))
    }

    /// Ready or pushing: dispatch the next primitive, wait, push, or fail it. `observed`: the
    /// observation's preconditions are about this primitive (`met` says whether they hold).
    fn advance(&mut self, met: bool, observed: bool) -> Option<Directive> {
        let Some(step) = self.steps.get(self.cursor).copied() else {
            if let Some(reason) = self.replan_pending.take() {
                self.begin_planning(reason);
                return None;
            }
            self.mode = Mode::Done;
            self.record(NONE_CHAIN, NONE_PRIMITIVE, DecisionKind::Finished);
            return Some(Directive::Done);
        };
        if self.now < step.start || !observed {
            self.mode = Mode::Ready;
            return Some(Directive::Wait {
                until: step.start.max(self.now),
            });
        }
        if met {
            return Some(self.dispatch());
        }
        if !self.config.flexible() {
            self.fail(Reason::PreconditionsUnmet, false);
            return None;
        }
        let since = match self.mode {
            Mode::Pushing { since } => since,
            _ => {
                self.stats.pushes += 1;
                self.record_step(DecisionKind::PushStarted);
                self.mode = Mode::Pushing { since: self.now };
                self.now
            }
        };
        let deadline = MissionTimeUs(since.0.saturating_add(self.config.push_timeout_us));
        if self.now >= deadline {
            self.stats.push_timeouts += 1;
            self.record_step(DecisionKind::PushTimedOut);
            self.fail(Reason::PreconditionsUnmet, false);
            return None;
        }
        Some(Directive::Pushing { deadline })
    }

    fn dispatch(&mut self) -> Directive {
        let now = self.now;
        let Some(step) = self.steps.get_mut(self.cursor) else {
            self.mode = Mode::Done;
            return Directive::Done;
        };
        step.start = now;
        let step = *step;
        self.reshift();
        self.mode = Mode::Running;
        self.stats.dispatched += 1;
        self.record_step(DecisionKind::Dispatched);
        let spec = self.primitives.get(usize::from(step.primitive));
        Directive::Dispatch {
            chain: step.chain,
            primitive: step.primitive,
            kind: spec.map_or(PrimitiveKind::HotelLoad, |s| s.kind),
            site: spec.and_then(|s| s.site),
            target: spec.and_then(|s| s.target),
            expected_end: MissionTimeUs(now.0.saturating_add(step.duration_us)),
            expected_energy_mj: step.energy_mj,
        }
    }

    /// Moves every primitive after the cursor to start no earlier than its plan's start and
    /// the previous primitive's predicted end.
    fn reshift(&mut self) {
        let mut end = match self.steps.get(self.cursor) {
            Some(s) => s.start.0.saturating_add(s.duration_us),
            None => return,
        };
        for s in self.steps.iter_mut().skip(self.cursor + 1) {
            s.start = MissionTimeUs(s.planned_start.0.max(end));
            end = s.start.0.saturating_add(s.duration_us);
        }
    }

    fn on_finished(&mut self, outcome: Outcome, observation: &Observation) {
        if self.mode != Mode::Running {
            return;
        }
        let Some(step) = self.steps.get(self.cursor).copied() else {
            return;
        };
        let spec = self.primitives.get(usize::from(step.primitive)).cloned();
        match outcome.result {
            TaskResult::Succeeded => {
                self.record_step(DecisionKind::Completed);
                // The rest of the plan moves after the measured end.
                if let Some(s) = self.steps.get_mut(self.cursor) {
                    s.duration_us = outcome.duration_us;
                    s.energy_mj = outcome.energy_mj;
                }
                self.reshift();
                if let Some(spec) = &spec {
                    self.learn(spec, outcome);
                    self.note_science(spec, &step, outcome);
                }
                self.cursor += 1;
                self.mode = Mode::Ready;
                let to_spend = self
                    .remaining()
                    .iter()
                    .fold(0u64, |e, s| e.saturating_add(s.energy_mj));
                if to_spend > self.battery_mj && self.replan_pending.is_none() {
                    self.replan_pending = Some(Reason::Overrun);
                }
                if self.config.strategy != Strategy::Replan {
                    self.replan_pending = None;
                }
                if step.last_in_chain {
                    self.close_chain(step.chain, true);
                    if let Some(reason) = self.replan_pending.take() {
                        self.begin_planning(reason);
                    }
                }
            }
            TaskResult::Failed => {
                self.record_step(DecisionKind::Failed);
                let retryable = self.config.flexible()
                    && observation.preconditions_met
                    && step.retries < self.config.max_retries;
                if retryable {
                    self.retry();
                } else {
                    self.fail(Reason::Failed, false);
                }
            }
            TaskResult::Faulted => {
                self.record_step(DecisionKind::Failed);
                self.fail(Reason::Fault, true);
            }
        }
    }

    /// Automated retry: the same primitive again, now, with its current prediction; the rest
    /// of the plan moves after it.
    fn retry(&mut self) {
        let now = self.now;
        let Some(s) = self.steps.get_mut(self.cursor) else {
            return;
        };
        s.retries = s.retries.saturating_add(1);
        s.start = now;
        self.reshift();
        self.stats.retries += 1;
        self.record_step(DecisionKind::Retried);
        self.mode = Mode::Ready;
    }

    /// The strategy's answer to a failure flexible execution did not resolve.
    fn fail(&mut self, reason: Reason, fault: bool) {
        match self.config.strategy {
            Strategy::Static => {
                self.record_step(DecisionKind::Abandoned(reason));
                self.mode = Mode::Abandoned { reason };
            }
            Strategy::Replan if !fault => {
                if let Some(s) = self.steps.get(self.cursor).copied() {
                    self.close_chain(s.chain, false);
                }
                self.begin_planning(reason);
            }
            Strategy::Ground | Strategy::FlexibleExecution | Strategy::Replan => {
                self.halt(reason);
            }
        }
    }

    fn halt(&mut self, reason: Reason) {
        self.stats.ground_halts += 1;
        self.record_step(DecisionKind::HaltedForGround(reason));
        self.mode = Mode::Halted { reason };
    }

    /// Model parameter update (IV.C.3).
    fn learn(&mut self, spec: &PrimitiveSpec, outcome: Outcome) {
        let Some(site) = spec.site else {
            return;
        };
        let update = ParameterUpdate {
            kind: spec.kind,
            site,
            duration_us: outcome.duration_us,
            energy_mj: outcome.energy_mj.min(MAX_ENERGY_MJ),
        };
        match self
            .params
            .iter_mut()
            .find(|p| p.kind == spec.kind && p.site == site)
        {
            Some(p) => *p = update,
            None => {
                if self.params.push(update).is_err() {
                    return;
                }
            }
        }
        self.stats.parameter_updates += 1;
        self.record_step(DecisionKind::ParameterUpdated);
        for i in self.cursor + 1..self.steps.len() {
            let Some(primitive) = self.steps.get(i).map(|s| s.primitive) else {
                continue;
            };
            let same = self
                .primitives
                .get(usize::from(primitive))
                .is_some_and(|p| p.kind == spec.kind && p.site == Some(site));
            if let (true, Some(s)) = (same, self.steps.get_mut(i)) {
                s.duration_us = update.duration_us;
                s.energy_mj = update.energy_mj;
            }
        }
    }

    /// Updates the science context from a finished primitive of a sampling chain.
    fn note_science(&mut self, spec: &PrimitiveSpec, step: &ExecStep, outcome: Outcome) {
        let sample: Option<SampleRef> = self
            .science
            .get(usize::from(step.chain))
            .and_then(|s| s.sample);
        match spec.kind {
            PrimitiveKind::ExcavateSite => {
                let prior = self.assessor.post_excavation_prior;
                if let Some(site) = spec
                    .site
                    .and_then(|s| self.context.sites.get_mut(usize::from(s)))
                {
                    site.post_excavation.get_or_insert(prior);
                }
            }
            PrimitiveKind::CollectSample => {
                if let Some(t) = sample.and_then(|s| self.context.target_mut(s)) {
                    t.collected = true;
                }
            }
            PrimitiveKind::ScienceAnalyze => {
                if let (Some(bio), Some(t)) = (
                    outcome.biosignature,
                    sample.and_then(|s| self.context.target_mut(s)),
                ) {
                    t.biosignature = Some(bio);
                    if bio == Biosignature::Negative {
                        self.replan_pending = Some(Reason::Discovery);
                    }
                }
            }
            _ => {}
        }
    }

    /// A chain ends: executed to the end (`done`), or abandoned after a failure (its task is
    /// then failed, and its target too).
    fn close_chain(&mut self, chain: u16, done: bool) {
        let Some(c) = self.network.chains.get(usize::from(chain)) else {
            return;
        };
        if !self.closed_tasks.contains(&c.task_slot) {
            let _ = self.closed_tasks.push(c.task_slot);
        }
        if done {
            let start = self
                .steps
                .iter()
                .find(|s| s.chain == chain)
                .map_or(self.now, |s| s.start);
            let _ = self.executed.push(PlacedChain { chain, start });
        } else if let Some(sample) = self.science.get(usize::from(chain)).and_then(|s| s.sample) {
            if let Some(t) = self.context.target_mut(sample) {
                if !t.collected {
                    t.failed = true;
                }
            }
        }
    }

    /// Starts the search from the current state.
    fn begin_planning(&mut self, reason: Reason) {
        self.record_step(DecisionKind::ReplanStarted(reason));
        if reason != Reason::Initial {
            self.stats.replans += 1;
        }
        reparameterize(
            &self.primitives,
            &self.params,
            &self.context,
            &mut self.network,
        );
        self.planning_from = (self.now, self.battery_mj);
        let config = SearchConfig {
            battery_mj: self.battery_mj,
            reserve_mj: self.config.reserve_mj,
            exploration_bound: self.config.exploration_bound,
            energy_pruning: true,
        };
        self.search = Search::new(config);
        match self
            .search
            .start_excluding(&self.network, &[], &self.closed_tasks)
        {
            Ok(()) => self.mode = Mode::Planning { reason },
            Err(_) => self.halt(Reason::ReplanFailed),
        }
    }

    /// Runs the search within `budget`; true when the plan is installed (or planning failed).
    fn continue_planning(&mut self, budget: u32) -> bool {
        let mut timeline = self.timeline.clone();
        timeline.horizon_start = self.planning_from.0;
        timeline.battery_mj = self.planning_from.1;
        let mut placement = AssessedPlacement {
            inner: timeline,
            assessor: self.assessor,
            context: &self.context,
            science: &self.science,
            refused: 0,
        };
        let step = self
            .search
            .step(&self.network, &mut placement, budget.max(1));
        if !step.done {
            return false;
        }
        let s = *self.search.stats();
        self.last_search = s;
        self.last_plan_value = self.search.best_value();
        self.stats.explored = self.stats.explored.saturating_add(s.explored);
        self.stats.nodes = self.stats.nodes.saturating_add(s.nodes);
        let mut plan: Vec<PlacedChain, MAX_PLAN_CHAINS> = Vec::new();
        self.search.best_plan(&mut plan);
        if self.install(&plan).is_err() {
            self.halt(Reason::ReplanFailed);
        }
        true
    }

    /// Replaces the remaining plan by `plan` (chains, in any order), primitives back to back
    /// from each chain's start with the current predictions.
    fn install(&mut self, plan: &[PlacedChain]) -> Result<(), ExecError> {
        let mut sorted: Vec<PlacedChain, MAX_PLAN_CHAINS> =
            Vec::from_slice(plan).map_err(|_| ExecError::PlanTooLong)?;
        sorted.sort_unstable_by_key(|p| (p.start, p.chain));
        self.steps.clear();
        self.cursor = 0;
        for p in &sorted {
            let chain = self
                .network
                .chains
                .get(usize::from(p.chain))
                .ok_or(ExecError::UnknownChain)?;
            let mut at = p.start.0;
            let first = self.steps.len();
            for &primitive in chain.primitives.iter() {
                let (duration_us, energy_mj) = predicted(&self.primitives, &self.params, primitive)
                    .ok_or(ExecError::UnknownChain)?;
                if already_done(&self.primitives, &self.context, primitive) {
                    continue;
                }
                self.steps
                    .push(ExecStep {
                        chain: p.chain,
                        primitive,
                        planned_start: MissionTimeUs(at),
                        start: MissionTimeUs(at),
                        duration_us,
                        energy_mj,
                        retries: 0,
                        last_in_chain: false,
                    })
                    .map_err(|_| ExecError::PlanTooLong)?;
                at = at.saturating_add(duration_us);
            }
            match self.steps.get_mut(first..).and_then(|s| s.last_mut()) {
                Some(last) => last.last_in_chain = true,
                // Nothing left to do in it: executed as it stands.
                None => {
                    let task = chain.task_slot;
                    if !self.closed_tasks.contains(&task) {
                        let _ = self.closed_tasks.push(task);
                    }
                    let _ = self.executed.push(*p);
                }
            }
        }
        self.mode = Mode::Ready;
        self.plans = self.plans.wrapping_add(1);
        self.record(
            NONE_CHAIN,
            NONE_PRIMITIVE,
            DecisionKind::Planned {
                chains: u8::try_from(sorted.len()).unwrap_or(u8::MAX),
            },
        );
        Ok(())
    }
}

/// The predicted (duration, energy) of primitive `index` under the measured `params`.
pub fn predicted(
    primitives: &[PrimitiveSpec],
    params: &[ParameterUpdate],
    index: u8,
) -> Option<(u64, u64)> {
    let spec = primitives.get(usize::from(index))?;
    let measured = spec.site.and_then(|site| {
        params
            .iter()
            .find(|p| p.kind == spec.kind && p.site == site)
    });
    Some(measured.map_or((spec.duration_us, spec.energy_mj), |p| {
        (p.duration_us, p.energy_mj)
    }))
}

/// Whether primitive `index` has nothing left to do in the state `context` describes: the
/// excavation of a site already excavated (the reference model folds an excavation into every
/// sampling chain; the trench is dug once). Such a primitive costs nothing in a replan and is
/// not dispatched.
pub fn already_done(primitives: &[PrimitiveSpec], context: &ScienceContext, index: u8) -> bool {
    primitives.get(usize::from(index)).is_some_and(|spec| {
        spec.kind == PrimitiveKind::ExcavateSite
            && spec
                .site
                .and_then(|site| context.sites.get(usize::from(site)))
                .is_some_and(|site| site.post_excavation.is_some())
    })
}

/// Recomputes every chain's duration, energy and product offsets from its primitives under the
/// measured `params` (IV.C.3) in the state `context` describes (primitives
/// [`already_done`] cost nothing). Utilities are left as flattened: the Assessor predicts them
/// in context during the search.
pub fn reparameterize(
    primitives: &[PrimitiveSpec],
    params: &[ParameterUpdate],
    context: &ScienceContext,
    network: &mut FlatNetwork,
) {
    for chain in network.chains.iter_mut() {
        let (mut duration, mut energy) = (0u64, 0u64);
        let mut product = 0usize;
        for &p in &chain.primitives {
            let Some((d, e)) = predicted(primitives, params, p) else {
                continue;
            };
            let (d, e) = if already_done(primitives, context, p) {
                (0, 0)
            } else {
                (d, e)
            };
            duration = duration.saturating_add(d);
            energy = energy.saturating_add(e).min(MAX_ENERGY_MJ);
            if primitives
                .get(usize::from(p))
                .is_some_and(|s| s.product.is_some())
            {
                if let Some(cp) = chain.products.get_mut(product) {
                    cp.offset_us = duration;
                }
                product += 1;
            }
        }
        chain.duration_us = duration;
        chain.energy_mj = energy;
    }
}
