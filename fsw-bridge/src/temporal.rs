//! Temporal planning on the target (issue 13): a compiled temporal task (the `temporal`
//! crate's binary format, written by `hil`'s PDDL front end) is uplinked to the planner
//! partition in chunks, planned there anytime across the partition's windows, and the plan
//! comes back step by step.
//!
//! Host to target: [`HostToTarget::TemporalBegin`](crate::HostToTarget::TemporalBegin)
//! announces a job (its length, its CRC-32 and how to search), then
//! [`HostToTarget::TemporalChunk`](crate::HostToTarget::TemporalChunk)s carry the bytes in
//! order. Target to host: [`TemporalReport`]s inside
//! [`TargetToHost::Temporal`](crate::TargetToHost::Temporal): `Accepted` once the whole task
//! arrived, matched its CRC and validated (or `Refused`, naming why), then after the search
//! one `Step` per planned action, `Stats` and `Done`.
//!
//! The bytes the chunks carry are a secured task (`sdls::temporal`: a security header, the
//! compiled task, an HMAC-SHA-256 trailer that also covers the job and its configuration);
//! `len` and `crc32` are the secured string's. The planner partition authenticates it with the
//! key and the anti-replay counter of its own security area before it validates it.
//!
//! Times are integers with their unit in the name: a plan's times are in the task's ticks
//! (`ticks_per_unit` of them make one PDDL time unit), the planning's CPU cost in timebase
//! ticks. Every report fits the planner partition's outbound port (64 bytes, checked by this
//! crate's tests for the largest instance of each).
use heapless::Vec;
use serde::{Deserialize, Serialize};

/// Bytes of task carried by one TemporalChunk (the same as a task-network uplink chunk).
pub const TEMPORAL_CHUNK_MAX: usize = 128;

/// Which repeated states the search prunes (`temporal::Duplicates`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalDuplicates {
    Keep,
    PruneQuiescent,
    PruneAll,
}

/// How to search (`temporal::PlannerConfig`, plus the limits of the job on the target).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct TemporalConfig {
    /// Longest plan in snap actions.
    pub max_steps: u16,
    /// Apply compression-safe actions' ends with their starts.
    pub compression: bool,
    /// The second open list (preferred operators).
    pub preferred_operators: bool,
    /// A full open list sheds its worse half instead of ending the search.
    pub shed_when_full: bool,
    pub duplicates: TemporalDuplicates,
    /// Heuristic supporters by duration instead of by action count.
    pub duration_costs: bool,
    /// Goal facts left out (bit i: the task's i-th goal fact).
    pub dropped_goals: u64,
    /// Stop after this many expansions (0: no limit).
    pub max_expansions: u32,
    /// Stop after this many planner windows of search (0: no limit).
    pub max_windows: u32,
}

impl TemporalConfig {
    /// `temporal::PlannerConfig::default()`, no limits.
    pub const DEFAULT: Self = Self {
        max_steps: 2048,
        compression: true,
        preferred_operators: true,
        shed_when_full: true,
        duplicates: TemporalDuplicates::PruneQuiescent,
        duration_costs: false,
        dropped_goals: 0,
        max_expansions: 0,
        max_windows: 0,
    };
}

impl Default for TemporalConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The arena region that ran out (`temporal::Region`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalRegion {
    /// The arena cannot hold the task's tables and scratch.
    Tables,
    Nodes,
    RegularOpen,
    PreferredOpen,
    PlanLength,
}

/// Why a job was refused before planning.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalRefusal {
    /// A chunk for no job, for another job, or not at the next offset.
    OutOfSequence { expected_offset: u32 },
    /// The announced length is zero or over the target's task buffer (`capacity` bytes).
    TooLarge { capacity: u32 },
    /// The bytes received do not have the announced CRC-32.
    BadCrc { computed: u32 },
    /// The task does not validate (`temporal::TaskError`): `kind` is the index of its
    /// `TaskErrorKind`, `offset` the byte where reading stopped.
    BadTask { kind: u8, offset: u32 },
    /// The secured task failed the security checks (`sdls::temporal`: no key, truncated, bad
    /// length, unknown key, bad MAC, replayed sequence number, or the counter could not be
    /// stored): nothing was planned and no counter moved (but for `CounterNotStored`, none
    /// moved either). Appended: the variants before it keep their index.
    Security(crate::security::SecurityRefusal),
    /// A Begin while job `job` is planning or reporting: that job goes on (a Begin abandons
    /// only a job still being received, so that no message from outside, authentic or not,
    /// can end an accepted job before it is authenticated). Appended.
    Busy { job: u16 },
}

/// How a search ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalOutcome {
    Solved,
    /// The open lists emptied: no plan (within the pruning used).
    Unsolvable,
    /// The arena is exhausted.
    OutOfMemory(TemporalRegion),
    /// The job's expansion limit was reached.
    ExpansionLimit,
    /// The job's window limit was reached.
    WindowLimit,
}

/// What the planner partition says about a temporal job.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TemporalReport {
    /// The whole task arrived, matched its CRC and validated; planning starts in the next
    /// granted frame's window.
    Accepted {
        job: u16,
        facts: u32,
        actions: u32,
        task_bytes: u32,
        ticks_per_unit: u32,
        /// The planner partition's CPU spent receiving and checking the job (copying the
        /// chunks, absorbing them into the MAC, the CRC-32, the security checks and the
        /// counter write, the task's validation), timebase ticks (0 without a clock).
        receive_ticks: u32,
        /// The part of `receive_ticks` spent authenticating it (the security association
        /// read at the first job, the MAC absorbed chunk by chunk, the checks, the counter
        /// written to non-volatile memory).
        auth_ticks: u32,
    },
    /// The job was refused; nothing is planned for it.
    Refused { job: u16, reason: TemporalRefusal },
    /// Action `index` (in order of starts) of the plan. Times in task ticks.
    Step {
        job: u16,
        index: u16,
        action: u16,
        start: u32,
        duration: u32,
        /// The start window the plan's STN allows with the makespan kept.
        start_lb: u32,
        start_ub: u32,
    },
    /// Search statistics (saturated at u32::MAX).
    Stats {
        job: u16,
        expanded: u32,
        generated: u32,
        evaluated: u32,
        inconsistent: u32,
        duplicates: u32,
        dead_ends: u32,
        nodes: u32,
        too_long: u32,
        shed: u32,
        best_h: u32,
    },
    /// The job is over; after the steps and the statistics.
    Done {
        job: u16,
        outcome: TemporalOutcome,
        /// Steps sent (the plan's actions; 0 without a plan).
        steps: u16,
        /// The plan's makespan in task ticks (0 without a plan).
        makespan: u32,
        ticks_per_unit: u32,
        peak_arena_bytes: u32,
        arena_bytes: u32,
        /// The planner partition's CPU spent setting up and searching, in timebase ticks
        /// (0 natively).
        planning_ticks: u64,
        /// Planner windows in which the search ran.
        windows: u32,
        /// The costliest expansion's CPU (with a clock reading), timebase ticks (0 natively).
        worst_expansion_ticks: u32,
        /// The costliest piece of the search's set-up (`temporal::Planner::set_up_step`,
        /// with a clock reading), timebase ticks (0 natively).
        worst_set_up_ticks: u32,
    },
    /// After a warm reset (or a restart of the planner partition) the job accepted before it
    /// was found in memory the reset keeps, its task checked again (CRC-32 and validation)
    /// and its search restarted from the beginning: the same search, so the same plan. Steps,
    /// statistics or Done of the job sent before the reset are void; they come again.
    /// Appended.
    Resumed {
        job: u16,
        task_bytes: u32,
        /// The planner partition's CPU spent checking the stored task again, timebase ticks.
        verify_ticks: u32,
    },
    /// What the onboard rover mission decided (job `job` is the mission's task; see
    /// [`RoverReport`]). Appended.
    Rover { job: u16, report: RoverReport },
    /// The search's plan and the action elimination that improved it
    /// (`temporal::Planner::improving`), after `Stats` and before `Done` (a report of its
    /// own: `Done` has no room left in the planner's outbound port). Appended.
    Improved {
        job: u16,
        /// Of `Done`'s `planning_ticks`, those until the search found its plan (all of them
        /// without an elimination after it): "instructions to a plan"; the rest is the
        /// elimination's.
        first_plan_ticks: u64,
        /// The search's plan's actions and makespan (task ticks), before the elimination
        /// (`Done`'s `steps` and `makespan` without one; 0 without a plan).
        first_plan_steps: u16,
        first_makespan: u32,
        /// Removals the elimination tried, and its costliest unit's CPU (timebase ticks).
        elimination_checks: u32,
        worst_elimination_ticks: u32,
    },
}

impl TemporalReport {
    /// The job the report is about.
    pub fn job(&self) -> u16 {
        match *self {
            TemporalReport::Accepted { job, .. }
            | TemporalReport::Refused { job, .. }
            | TemporalReport::Step { job, .. }
            | TemporalReport::Stats { job, .. }
            | TemporalReport::Done { job, .. }
            | TemporalReport::Resumed { job, .. }
            | TemporalReport::Rover { job, .. }
            | TemporalReport::Improved { job, .. } => job,
        }
    }
}

/// The bytes of a TemporalChunk.
pub type TemporalChunkBytes = Vec<u8, TEMPORAL_CHUNK_MAX>;

// ----- the onboard rover mission (issue 13 item 3) ------------------------------------------------
//
// The host plays the rover and the world and keeps the time; the planner partition decides.
// Before uplinking the mission's task as an ordinary (signed) job, the host sends
// `RoverEvent::Start` naming the job: once accepted, that task is not planned as a job but
// flown: every plan and replan is made from it on the target. Then, in lockstep, the host sends
// one event and grants frames until the event's last answer: `Poll` (time is now: decide)
// answers one `Dispatch`, one `Wait`, `Finished`, or a replan (`Replan`, its pauses and carries,
// its attempts, `NewPlan` and its `PlanStep`s, and `PlanningTakes`, or `NoPlan`); `Goal` (an
// opportunistic goal arrived) answers `Optional` before the first plan and a replan after;
// `Ended` (an action the rover was told to start ended) answers `EndTaken`; `Close` answers
// the goals `Achieved`, the opportunistic goals `Kept`, and `Closed`. An event the mission
// cannot take is answered `Refused` with the reason, and changes nothing. Times are mission
// milliseconds (the rover task's ticks), absolute. After a reset of the planner partition the
// mission says on its own, in the first granted window, `Resumed` (from its checkpoint: the
// host sends again the events after it) or `NotResumed` with the reason.

/// An event of the onboard rover mission, host to target
/// ([`HostToTarget::Rover`](crate::HostToTarget::Rover)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RoverEvent {
    /// Fly the task the job this event names will carry (sent before its `TemporalBegin`):
    /// any step at most
    /// `horizon_slack_ms` after the plan's makespan; each attempt at most `max_expansions`
    /// expansions; planning takes `us_per_expansion` microseconds of mission time per
    /// expansion (a model, the same natively and on the target).
    Start {
        horizon_slack_ms: u32,
        max_expansions: u32,
        us_per_expansion: u32,
    },
    /// An opportunistic goal (a fact of the task) arrived.
    Goal { fact: u16, at_ms: u32 },
    /// The rover says an action it was told to start ended.
    Ended { action: u16, at_ms: u32 },
    /// The time is `now_ms`: decide.
    Poll { now_ms: u32 },
    /// The run is over: report the goals.
    Close { now_ms: u32 },
    /// Fact `fact` is a component's inactive state (seed 001 5.1: metadata outside the PDDL;
    /// the `inactive-` convention of `temporal::replan`), sent before the first plan.
    Inactive { fact: u16 },
    /// The rover's own estimate of when running action `action` ends (its navigation's, once it
    /// met an obstacle): what a replan carries of it.
    Expected { action: u16, ends_ms: u32 },
}

/// How a dispatched start stands against its window as planned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RoverStartKind {
    /// Before its planned lb (what it follows ended early), by `by_ms`.
    Early { by_ms: u32 },
    /// At lb.
    AtLb,
    /// At lb, ready `waited_ms` (over a second) before it: held to lb.
    HeldToLb { waited_ms: u32 },
    /// `by_ms` after lb, within (lb, ub].
    Late { by_ms: u32 },
}

/// Why the onboard mission (re)plans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RoverReplanWhy {
    Initial,
    /// An opportunistic goal arrived.
    Goal {
        fact: u16,
    },
    /// Step `step` (the start or the end of `action`) is not executed and past its ub.
    PastUb {
        step: u16,
        action: u16,
        end: bool,
        ub_ms: u32,
    },
    /// Step `step` was executed, but what follows it no longer fits the plan's windows.
    NoLongerFits {
        step: u16,
        action: u16,
        end: bool,
    },
}

/// Why the onboard mission refused an event (nothing changed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RoverRefusal {
    /// No mission is flying (no Start, its task not accepted yet, or it ended).
    NoMission,
    /// The mission is planning, or still answering the last event.
    Busy,
    /// The event's time is before the last event's (`last_ms`).
    OutOfOrder { last_ms: u32 },
    /// An end of an action the mission did not start (or that ended already).
    NotRunning { action: u16 },
    /// A goal that is no fact of the task, already a goal, or arrived already.
    UnknownGoal { fact: u16 },
    /// More than the mission holds (opportunistic goals, running actions, the task's size).
    Capacity,
    /// The task cannot be flown (its state or a replan task could not be built).
    BadTask,
}

/// What the onboard rover mission says, target to host (inside [`TemporalReport::Rover`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RoverReport {
    /// The mission's task was accepted: the mission waits for events.
    Ready {
        facts: u32,
        actions: u32,
    },
    Refused {
        reason: RoverRefusal,
    },
    /// An opportunistic goal known before the first plan: it is in the first plan's goals.
    Optional {
        fact: u16,
    },
    /// Planning starts at `at_ms`: nothing new is dispatched until `PlanningTakes`.
    Replan {
        at_ms: u32,
        why: RoverReplanWhy,
    },
    /// A running pausable action went back to its inactive state (not done).
    Paused {
        action: u16,
    },
    /// A running action carried into the new plan as a completion.
    Carried {
        action: u16,
        since_ms: u32,
        left_ms: u32,
    },
    /// An opportunistic goal in the next attempt (one per goal, before its `Attempt`).
    AttemptGoal {
        fact: u16,
    },
    /// A planning attempt ended. `build_ticks`: the CPU building its replan task (the replay's
    /// state, the pauses, `write_replan_task`), `planning_ticks` its search's, timebase ticks.
    Attempt {
        index: u16,
        hard_goals: u16,
        outcome: TemporalOutcome,
        actions: u16,
        expanded: u32,
        peak_arena_bytes: u32,
        build_ticks: u32,
        planning_ticks: u64,
    },
    /// The newest opportunistic goal still in is dropped; the next attempt is without it.
    Dropped {
        fact: u16,
    },
    /// No plan (no opportunistic goal left to drop): the mission stops.
    NoPlan,
    /// The plan and its dispatch network: `network_ticks` the CPU of `network_from_plan` and
    /// the dispatcher's first windows.
    NewPlan {
        actions: u16,
        makespan_ms: u32,
        network_ticks: u32,
    },
    /// The plan's action `index` (completions of carried actions after the task's actions).
    PlanStep {
        index: u16,
        action: u16,
        start_ms: u32,
        duration_ms: u32,
        lb_ms: u32,
        ub_ms: u32,
    },
    /// Planning took `expansions` expansions: nothing new is dispatched until `until_ms`.
    PlanningTakes {
        expansions: u32,
        until_ms: u32,
    },
    /// Start action `action` (step `step`) now, at `at_ms`; its window as planned.
    Dispatch {
        step: u16,
        action: u16,
        at_ms: u32,
        lb_ms: u32,
        ub_ms: u32,
        kind: RoverStartKind,
        /// The CPU of this decision (the dispatcher's poll), timebase ticks.
        poll_ticks: u32,
    },
    /// Nothing to start now: ask again at `wake_ms` (a ready step's lb, or just past the
    /// earliest ub of a step not executed) or when something happens.
    Wait {
        wake_ms: Option<u32>,
        poll_ticks: u32,
    },
    /// Every step of the plan is executed.
    Finished,
    /// The end was taken (its effects applied, its step executed).
    EndTaken {
        action: u16,
    },
    /// An `Inactive` was taken.
    InactiveTaken {
        fact: u16,
    },
    /// An `Expected` was taken.
    ExpectedTaken {
        action: u16,
    },
    /// A goal (of the task, or opportunistic) holds at the end.
    Achieved {
        fact: u16,
    },
    /// An opportunistic goal kept to the end.
    Kept {
        fact: u16,
    },
    /// The answer to Close is complete.
    Closed,
    /// After a reset of the planner partition, the mission was taken up again from its
    /// checkpoint: the state after the first `events` events it took (the host sends the
    /// others again), the last of them at `last_ms`. Appended.
    Resumed {
        events: u32,
        last_ms: u32,
        /// The planner partition's CPU taking it up (records checked, task checked, network
        /// rebuilt), timebase ticks.
        restore_ticks: u32,
    },
    /// After a reset, a checkpoint of a mission was found but refused (nothing flies). Appended.
    NotResumed {
        reason: RoverResumeRefusal,
    },
}

/// Why the checkpoint of a rover mission was not taken up after a reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RoverResumeRefusal {
    /// A record of another format version (`found`).
    Version { found: u32 },
    /// A record's length is beyond its slot.
    BadLength,
    /// A record's CRC-32 does not match its words.
    BadCrc,
    /// The mission's task in the task buffer is not the one the record was made with (its
    /// CRC-32, or it no longer validates).
    TaskChanged,
    /// The plan record the state names is not whole.
    PlanMissing,
    /// A field beyond a capacity or the task (a phase, a count, an action, a step).
    OutOfRange,
}

impl RoverReport {
    /// Whether the report is the last answer to an event (or to the acceptance of the
    /// mission's task).
    pub fn is_last(&self) -> bool {
        matches!(
            self,
            RoverReport::Ready { .. }
                | RoverReport::Refused { .. }
                | RoverReport::Optional { .. }
                | RoverReport::NoPlan
                | RoverReport::PlanningTakes { .. }
                | RoverReport::Dispatch { .. }
                | RoverReport::Wait { .. }
                | RoverReport::Finished
                | RoverReport::EndTaken { .. }
                | RoverReport::InactiveTaken { .. }
                | RoverReport::ExpectedTaken { .. }
                | RoverReport::Closed
                | RoverReport::Resumed { .. }
                | RoverReport::NotResumed { .. }
        )
    }
}
