//! The executor's public value types: configuration, observation, directive, decisions,
//! statistics, errors (re-exported by [`crate::executor`]).
use fsw_bridge::MissionTimeUs;

use crate::assessor::Biosignature;
use crate::htn::PrimitiveKind;

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
    /// Energy held back by the search (see [`crate::search::SearchConfig::reserve_mj`]).
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

    pub(super) fn flexible(&self) -> bool {
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
    /// [`Executor::remaining`](super::Executor::remaining) before this step) hold now: the
    /// executive's check on the world. When the step makes another primitive pending (the
    /// previous one finished, or a new plan), it does not dispatch it on this answer but
    /// returns a [`Directive::Wait`] (until now, if it is due), so that the next observation
    /// answers for it.
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
    /// Data volume or the link changed: a product measured larger or smaller than modelled,
    /// or a new rate or allowance ([`Executor::set_comms`](super::Executor::set_comms)).
    DataVolume,
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
    /// The search is running, or (with [`Reason::DataVolume`]) the downlink due now is being
    /// sized before its dispatch; call again with more budget.
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
    /// The plan has more than [`MAX_EXEC_STEPS`] primitives or
    /// [`MAX_PLAN_CHAINS`](crate::capacity::MAX_PLAN_CHAINS) chains.
    PlanTooLong,
}
