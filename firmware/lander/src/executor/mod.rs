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
//!   the same site: at once in the remaining plan's predictions, and in every later replan;
//!   and in the executor that replaces this one at a model uplink ([`Executor::learned`],
//!   [`Executor::set_learned`], with the volume factors and the sol's radio energy spent; the
//!   ground may set such a parameter too, [`Learned::set_parameter`]).
//! - **Strategies** (III.D), [`Strategy`]: Static abandons the rest of the plan at the first
//!   failure; Ground halts and waits for ground input at every failure; FE pushes and retries,
//!   and halts for ground when that does not resolve the failure; Replan pushes and retries,
//!   then replans (also after a negative biosignature, to exploit what was discovered), and
//!   halts for ground only for a fault, or when the replan fails. Replan also replans, at the
//!   next chain boundary, after a negative biosignature (utility discovery: the subway map
//!   moves on) and when measured overruns leave the remaining plan more energy than the charge.
//!
//! - **Data volume** ([`crate::comms`]): with a link model ([`Executor::set_comms`]) and the
//!   products onboard ([`Executor::set_onboard_data`]) as inputs, each plan sizes the chains'
//!   downlinks to their data at the measured volumes and checks every chain with the downlink
//!   manager; a dispatched downlink carries the manager's assignment
//!   ([`Executor::downlink_payload`]) and lasts long enough for it. Under Replan a new link or a
//!   product measured larger or smaller than modelled replans at the next chain boundary
//!   ([`Reason::DataVolume`]).
//!
//! States in a replan: targets collected, biosignatures and excavated sites are in the
//! Assessor's context; an excavation of a site already excavated costs nothing and is not
//! dispatched ([`already_done`]).
//!
//! Limits: a replan drops the interrupted chain's remaining primitives (its task counts as
//! failed); ground holds are not carried into a replan (the replan's placement starts with
//! none in force), so replanning is meant for the fully-autonomous flag; plans hold at most
//! [`MAX_EXEC_STEPS`] primitives.
//!
//! The module is split by responsibility: `types` holds the public value types (configuration,
//! observation, directive, decisions, statistics, errors), re-exported here; this file holds the
//! [`Executor`] and its stepping (dispatch, push, retry, the strategies' answers to failures);
//! `plan` holds model updates, the science context, replanning, plan installation and the
//! prediction helpers ([`predicted`], [`already_done`], [`reparameterize`]); `learned` what is
//! carried across a rebuild.
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use crate::assessor::ScienceContext;
use crate::assessor::{chain_science, Assessor, ChainScience};
use crate::capacity::*;
use crate::comms::{CommsError, CommsModel, DataStats, DownlinkSizes, VolumeFactors};
use crate::downlink::DataProduct;
use crate::htn::{FlatNetwork, HtnModel, PrimitiveKind, PrimitiveSpec};
use crate::placement::{PlanIndexCache, TimelinePlacement, ViewTimeline};
use crate::search::{PlacedChain, Search, SearchConfig, SearchStats};
use crate::utility::RankedUtility;

mod in_place;
mod learned;
mod plan;
mod sizing;
mod types;

pub use learned::Learned;
pub use plan::{already_done, predicted, reparameterize};
pub use sizing::SIZING_NODES_PER_EXPLORATION;
pub use types::*;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Ready,
    Pushing {
        since: MissionTimeUs,
    },
    Running,
    Planning {
        reason: Reason,
    },
    /// The pending downlink is being sized before its dispatch ([`sizing`]).
    Sizing,
    Halted {
        reason: Reason,
    },
    Abandoned {
        reason: Reason,
    },
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
    /// The placement's horizon end, phases, hotel load and Earth-in-view windows (its start
    /// and charge are set at each plan, its chains' downlink spans computed).
    timeline: TimelinePlacement,
    /// The search's plan index kept between placements and planning calls (cleared whenever
    /// a search starts: the network's chains may have changed).
    index_cache: PlanIndexCache,
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
    /// The link, when data volume is modelled ([`Executor::set_comms`]).
    comms: Option<CommsModel>,
    /// The products onboard, as last reported ([`Executor::set_onboard_data`]).
    onboard: Vec<DataProduct, MAX_DATA_PRODUCTS>,
    /// Measured product volumes against the model's.
    volumes: VolumeFactors,
    /// Per chain, its downlink sized at the last plan (duration, energy).
    downlink_sizes: DownlinkSizes,
    /// What the downlink being dispatched carries ([`Executor::downlink_payload`]).
    payload: Vec<DataProduct, MAX_DATA_PRODUCTS>,
    /// Radio energy the dispatched downlinks planned to spend: (sol, mJ) for the latest sol.
    comm_spent: (u16, u64),
    data_stats: DataStats,
    /// The downlink being dispatched, while it is sized over several calls.
    sizing: sizing::Sizing,
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
            index_cache: PlanIndexCache::new(),
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
            comms: None,
            onboard: Vec::new(),
            volumes: VolumeFactors::default(),
            downlink_sizes: DownlinkSizes::new(),
            payload: Vec::new(),
            comm_spent: (0, 0),
            data_stats: DataStats::default(),
            sizing: sizing::Sizing::new(),
        };
        match plan {
            Some(plan) => e.install(plan)?,
            None => e.begin_planning(Reason::Initial),
        }
        Ok(e)
    }

    /// Replaces the Earth-in-view windows the placement allows downlinks in (an external
    /// availability timeline, e.g. a new DSN schedule); they apply from the next plan or
    /// replan. The chains' downlink offsets are recomputed at every plan, so the
    /// `timeline.earth.downlinks` given to [`Executor::new`] need not be filled.
    pub fn set_view_windows(&mut self, windows: &ViewTimeline) {
        self.timeline.earth.windows = windows.clone();
    }

    /// Sets the link the planning sizes downlinks and checks data volume with (`None`, the
    /// default: data volume is not modelled, downlinks keep their model durations). A model
    /// that differs from the one in force (e.g. the ground lowered the rate) applies from the
    /// next plan; under Replan it makes one at the next chain boundary, and a search under way
    /// starts again with it. A zero rate or sol length is refused and changes nothing.
    pub fn set_comms(&mut self, comms: Option<CommsModel>) -> Result<(), CommsError> {
        if let Some(c) = &comms {
            c.validate()?;
        }
        if comms == self.comms {
            return Ok(());
        }
        self.comms = comms;
        match self.mode {
            Mode::Planning { reason } => self.restart_planning(reason),
            Mode::Done => {}
            _ if self.config.strategy == Strategy::Replan && !self.remaining().is_empty() => {
                self.replan_pending.get_or_insert(Reason::DataVolume);
            }
            _ => {}
        }
        Ok(())
    }

    /// The link in force.
    pub fn comms(&self) -> Option<&CommsModel> {
        self.comms.as_ref()
    }

    /// Reports the data products onboard (their measured sizes), for the planning and the
    /// downlinks: call it before a step whenever they changed. More than
    /// [`MAX_DATA_PRODUCTS`], or a product out of range, is refused and keeps the last list.
    pub fn set_onboard_data(&mut self, products: &[DataProduct]) -> Result<(), CommsError> {
        if products
            .iter()
            .any(|p| p.size_bytes > MAX_BYTES || p.value > MAX_PRODUCT_VALUE)
        {
            return Err(CommsError::ProductOutOfRange);
        }
        self.onboard = Vec::from_slice(products).map_err(|_| CommsError::TooManyProducts)?;
        Ok(())
    }

    /// The products onboard as last reported ([`Executor::set_onboard_data`]).
    pub fn onboard(&self) -> &[DataProduct] {
        &self.onboard
    }

    /// The measured product volumes in force.
    pub fn volumes(&self) -> &VolumeFactors {
        &self.volumes
    }

    /// What the downlink just dispatched should carry, in order: the onboard products the
    /// downlink manager assigns to it (empty when data volume is not modelled, or the last
    /// dispatch was not a downlink).
    pub fn downlink_payload(&self) -> &[DataProduct] {
        &self.payload
    }

    /// The downlink manager's counters over every plan made (placement checks).
    pub fn data_stats(&self) -> &DataStats {
        &self.data_stats
    }

    /// The Earth-in-view windows the placement allows downlinks in (empty: not modelled).
    pub fn view_windows(&self) -> &ViewTimeline {
        &self.timeline.earth.windows
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
                Mode::Sizing => {
                    if !self.continue_sizing(budget) {
                        return Directive::Planning {
                            reason: Reason::DataVolume,
                        };
                    }
                    return self.finish_dispatch();
                }
                Mode::Ready | Mode::Pushing { .. } => {
                    let met = observation.preconditions_met && self.pending() == observed;
                    if let Some(d) = self.advance(met, self.pending() == observed, budget) {
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
    fn advance(&mut self, met: bool, observed: bool, budget: u32) -> Option<Directive> {
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
            return Some(self.dispatch(budget));
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

    fn dispatch(&mut self, budget: u32) -> Directive {
        let now = self.now;
        let Some(step) = self.steps.get_mut(self.cursor) else {
            self.mode = Mode::Done;
            return Directive::Done;
        };
        step.start = now;
        self.payload.clear();
        // A downlink is sized first (what it carries, how long it lasts), over as many calls
        // as its knapsack needs at `budget`.
        if self.begin_sizing() {
            self.mode = Mode::Sizing;
            if !self.continue_sizing(budget) {
                return Directive::Planning {
                    reason: Reason::DataVolume,
                };
            }
        }
        self.finish_dispatch()
    }

    /// Dispatches the pending primitive (sized, if a downlink).
    fn finish_dispatch(&mut self) -> Directive {
        let now = self.now;
        let Some(step) = self.steps.get(self.cursor).copied() else {
            self.mode = Mode::Done;
            return Directive::Done;
        };
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
                    self.learn_volume(spec);
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
                    if self.replan_pending.is_none() && self.stranded_new_data() {
                        self.replan_pending = Some(Reason::DataVolume);
                    }
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
}
