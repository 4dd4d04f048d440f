//! The task network model (seed 000 IV.A.1, seed 003 "Constraints and Impacts"): timelines,
//! tasks with constraints, impacts, control conditions, timeouts, contingencies and
//! permissions, templates, temporal constraints between tasks, and the bounds on how often the
//! core answers a task's failures ([`ResponsePolicy`]: executive retries and planner repairs
//! per cause, backed off in mission time).
//!
//! [`NetworkSpec`] is the plain, unchecked form (what the ground builds and the uplink carries).
//! [`TaskNetwork`] is the validated form: it can only be made by [`TaskNetwork::from_spec`] or
//! the uplink decoder, both of which run [`crate::uplink`]'s validator, so every index it holds
//! refers to something that exists and every value fits its timeline.
use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

use crate::capacity::*;
use crate::telemetry::FailureKind;
use fsw_bridge::{CommandArgs, MissionTimeUs, Opcode, StateKey, StateValue};

/// A short name (task, timeline) kept for reports and for the ground tools.
pub type Name = String<MAX_NAME_LEN>;

/// Value a timeline holds when its owner cannot vouch for it ([`fsw_bridge::StateValue::Unknown`]).
/// No requirement is satisfied by it.
pub const VALUE_UNKNOWN: i64 = i64::MIN;

/// Version of the binary task-network format; the decoder refuses any other. Version 2 added
/// the response bounds ([`ResponsePolicy`], [`ControlSpec::max_retries`] and the fields after
/// it) and [`TimelineSpec::after_reset`]; version 3 [`TimelineSpec::stale_after_us`];
/// version 4 [`TimelineSpec::background_rate`], [`TimelineSpec::external`],
/// [`TimelineSpec::thresholds`] and the timed values ([`NetworkSpec::timed`]); version 5
/// [`CommandSpec::from_instance`], temporal constraints that bind a template's instances
/// to a requested task ([`TemporalConstraint`]) and the model parameters
/// ([`NetworkSpec::params`]).
pub const UPLINK_FORMAT_VERSION: u16 = 5;

/// The windows of the planner cycle (seed 000 IV.A.3), all durations in µs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlannerConfig {
    /// Scheduled tasks starting before `now + commit_window_us` are committed to the executive.
    pub commit_window_us: u64,
    /// Unscheduled tasks whose earliest start is before `now + scheduling_window_us` are scheduled.
    pub scheduling_window_us: u64,
    /// Tasks are placed to start before `now + plan_horizon_us`.
    pub plan_horizon_us: u64,
    /// A planner cycle runs at least this often even when nothing changed.
    pub plan_process_interval_us: u64,
}

impl PlannerConfig {
    /// Windows that suit the flyby scenario: commit 60 s ahead, schedule 6 h ahead, plan 12 h
    /// ahead, cycle at least every 5 min.
    pub const DEFAULT: Self = Self {
        commit_window_us: 60_000_000,
        scheduling_window_us: 6 * 3_600_000_000,
        plan_horizon_us: 12 * 3_600_000_000,
        plan_process_interval_us: 300_000_000,
    };
}

/// One small count or bound per failure cause, indexed by [`FailureKind`] code.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PerCause(pub [u8; FailureKind::COUNT]);

impl PerCause {
    pub const ZERO: Self = Self([0; FailureKind::COUNT]);

    /// `value` for every cause in `causes` (a mask of [`FailureKind::bit`]s), 0 for the others.
    pub const fn uniform(value: u8, causes: u8) -> Self {
        const fn pick(value: u8, causes: u8, code: u8) -> u8 {
            if causes & (1 << code) != 0 {
                value
            } else {
                0
            }
        }
        Self([
            pick(value, causes, 0),
            pick(value, causes, 1),
            pick(value, causes, 2),
            pick(value, causes, 3),
            pick(value, causes, 4),
            pick(value, causes, 5),
            pick(value, causes, 6),
            pick(value, causes, 7),
        ])
    }

    pub fn get(&self, cause: FailureKind) -> u8 {
        self.0.get(cause as usize).copied().unwrap_or(0)
    }

    pub fn set(&mut self, cause: FailureKind, value: u8) {
        if let Some(slot) = self.0.get_mut(cause as usize) {
            *slot = value;
        }
    }

    /// Adds one to the count of `cause` (saturating) and returns the new count.
    pub fn bump(&mut self, cause: FailureKind) -> u8 {
        let next = self.get(cause).saturating_add(1);
        self.set(cause, next);
        next
    }

    /// The sum over all causes.
    pub fn total(&self) -> u32 {
        self.total_over(FailureKind::ANY)
    }

    /// The sum over the causes in `causes` (a mask of [`FailureKind::bit`]s).
    pub fn total_over(&self, causes: u8) -> u32 {
        self.0
            .iter()
            .enumerate()
            .filter(|(code, _)| causes & (1u8 << code) != 0)
            .map(|(_, &v)| u32::from(v))
            .sum()
    }

    /// The mask of causes with a non-zero value.
    pub fn nonzero_causes(&self) -> u8 {
        self.0
            .iter()
            .enumerate()
            .filter(|(_, &v)| v != 0)
            .fold(0, |m, (code, _)| m | (1u8 << code))
    }
}

/// Back-off of repeated responses in mission time: the response to the first failure of a run
/// of consecutive failures is immediate (seed 000 III.B: flexible execution retries at once),
/// the one to the `n`-th (n >= 2) waits `initial_us * 2^(n-2)`, at most `max_us`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Backoff {
    pub initial_us: u64,
    pub max_us: u64,
}

impl Backoff {
    /// How long the response to the `consecutive`-th failure in a row waits.
    pub fn delay_us(&self, consecutive: u32) -> u64 {
        if consecutive <= 1 {
            return 0;
        }
        let doublings = consecutive - 2;
        let delay = if doublings >= 63 {
            u64::MAX
        } else {
            self.initial_us.saturating_mul(1u64 << doublings)
        };
        delay.min(self.max_us)
    }
}

/// How the core answers a task's failures, network-wide (each task may override any part in
/// its [`ControlSpec`]). Bounds count per cause, so a subsystem that keeps misbehaving the
/// same way exhausts its bound, and responses back off, so it can never make the core run
/// again at the same mission time without end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResponsePolicy {
    /// Executive re-dispatches of one task instance's command, per cause (only the causes in
    /// [`FailureKind::RETRYABLE`]; counted per instance).
    pub max_retries: PerCause,
    /// Planner responses that put a new instance of a task definition in the plan (restart,
    /// move and add-template contingencies; a template added again to enable or repair a
    /// task), per cause of the failure answered (only [`FailureKind::REPAIRABLE`]), counted
    /// over consecutive failures of the definition: an instance that completes clears them.
    /// Past the bound the planner gives up on the definition ([`crate::telemetry::gave_up_code`]).
    pub max_repairs: PerCause,
    /// Delays between consecutive retries of one instance and between consecutive repairs
    /// of one definition.
    pub backoff: Backoff,
}

impl ResponsePolicy {
    /// No automatic retries (as before bounds existed), two repairs per cause, back-off from
    /// 10 s doubling up to 10 min.
    pub const DEFAULT: Self = Self {
        max_retries: PerCause::ZERO,
        max_repairs: PerCause::uniform(2, FailureKind::REPAIRABLE),
        backoff: Backoff {
            initial_us: 10_000_000,
            max_us: 600_000_000,
        },
    };
}

/// What type of state-buffer value a measured timeline takes. A value of another type is
/// taken as unknown and counted as a state type mismatch (`Autonomy::state_type_mismatches`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeasuredValueType {
    /// `StateValue::Enum(v)` with `v < values` (a state timeline); `Bool` too when `values >= 2`
    /// (false is value 0, true value 1).
    Enum { values: u8 },
    /// `StateValue::Int` or `Bool` (a cumulative or claimable timeline).
    Int,
}

impl MeasuredValueType {
    /// Whether `value` is of this type. `Unknown` always is.
    pub fn accepts(&self, value: StateValue) -> bool {
        match (*self, value) {
            (_, StateValue::Unknown) => true,
            (Self::Enum { values }, StateValue::Enum(v)) => v < u16::from(values),
            (Self::Enum { values }, StateValue::Bool(_)) => values >= 2,
            (Self::Int, StateValue::Int(_) | StateValue::Bool(_)) => true,
            _ => false,
        }
    }
}

/// What kind of value a timeline holds and how impacts combine on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TimelineKind {
    /// Enumerated state (attitude NADIR, TURNING, ...): values `0..value_count`; changed only by
    /// `Assign` impacts at PRE or POST.
    State { value_count: u8, initial: u16 },
    /// Binary semaphore: MAINTAIN `Claim` impacts may not overlap.
    Claimable,
    /// Cumulative or depletable quantity (energy, data volume, coverage): `Assign`, `Add` and
    /// `Rate` (change per second) impacts; the value must stay in `[min, max]`.
    Cumulative { initial: i64, min: i64, max: i64 },
}

/// One timeline of the network.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TimelineSpec {
    pub name: Name,
    pub kind: TimelineKind,
    /// State-buffer entry that measures this timeline; `None` for internal timelines that only
    /// the planner projects (requests, claims).
    pub state_key: Option<StateKey>,
    /// Value an unmeasured state timeline takes after a reset (a heater is off after a reset):
    /// applied at the first step after a restore, as if measured then. `None`: a reset leaves
    /// the timeline as projected. Only for state timelines without a state key.
    pub after_reset: Option<i64>,
    /// Staleness bound of a measured timeline, in µs: a state-buffer value measured at `at`
    /// reads [`VALUE_UNKNOWN`] to the whole core (conditions, constraints, the planner) at
    /// every step `now` with `now - at > stale_after_us`, until a newer measurement arrives.
    /// `None`: a measurement never goes stale. Only for timelines with a state key; positive
    /// and at most [`MAX_STALE_AFTER_US`].
    pub stale_after_us: Option<u64>,
    /// Background rate of a cumulative timeline, in value units per second, from mission time
    /// 0 (a hotel load draining the battery while no task runs): the timeline's initial
    /// anchor carries it, tasks' `Rate` impacts add to it, and a measurement restarts the
    /// integration from the measured value. 0 on other kinds; magnitude at most
    /// [`MAX_MAGNITUDE`].
    pub background_rate: i64,
    /// An external availability timeline (Earth in view, a ground-station pass): its values
    /// come from the network's timed values ([`NetworkSpec::timed`]) and, if it has a state
    /// key, from measurements; no task may impact it. State and cumulative kinds only.
    pub external: bool,
    /// Thresholds that derive a state timeline's value from an integer measurement: the
    /// value is the number of thresholds at or below the measured integer (with thresholds
    /// `[10]`, a measured 9 is value 0, COLD, and 10 is value 1, WARM). Empty: the state
    /// buffer gives the value itself. Non-empty only on a measured state timeline, strictly
    /// increasing, exactly `value_count - 1` of them, at most [`MAX_THRESHOLDS`].
    pub thresholds: Vec<i64, MAX_THRESHOLDS>,
}

impl TimelineSpec {
    /// A timeline with no state key, no revert, no staleness bound, no background rate, not
    /// external, no thresholds.
    pub fn internal(name: Name, kind: TimelineKind) -> Self {
        Self {
            name,
            kind,
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: Vec::new(),
        }
    }

    /// The type of state-buffer value this timeline takes, or None when no state key
    /// measures it. The host can check what it will publish against this before boot.
    pub fn measured_value_type(&self) -> Option<MeasuredValueType> {
        self.state_key?;
        Some(match self.kind {
            TimelineKind::State { .. } if !self.thresholds.is_empty() => MeasuredValueType::Int,
            TimelineKind::State { value_count, .. } => MeasuredValueType::Enum {
                values: value_count,
            },
            TimelineKind::Claimable | TimelineKind::Cumulative { .. } => MeasuredValueType::Int,
        })
    }

    /// A state-buffer value as this timeline's integer value: through the thresholds when it
    /// has some, else as is. [`VALUE_UNKNOWN`] stays unknown.
    pub fn derived_value(&self, measured: i64) -> i64 {
        if self.thresholds.is_empty() || measured == VALUE_UNKNOWN {
            return measured;
        }
        self.thresholds.iter().filter(|&&t| t <= measured).count() as i64
    }
}

/// One timed value of an external timeline: from `at` on (until the next one), `timeline`
/// holds `value` (a state index or a cumulative value), as an assignment the plan cannot
/// change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TimedValue {
    pub timeline: u8,
    pub at: MissionTimeUs,
    pub value: i64,
}

/// When a constraint must hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ConstraintWhen {
    /// Just before the task starts (at `start + start_offset_us`, before the task's own impacts).
    Pre,
    /// From `start + start_offset_us` (inclusive) to `end + end_offset_us` (exclusive).
    Maintain,
}

/// The values a constraint accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Requirement {
    /// State timelines: bit `v` set accepts value `v`.
    OneOf { mask: u32 },
    /// Cumulative and claimable timelines: `min <= value <= max`.
    Range { min: i64, max: i64 },
}

impl Requirement {
    /// Whether `value` satisfies this requirement ([`VALUE_UNKNOWN`] never does).
    pub fn accepts(&self, value: i64) -> bool {
        if value == VALUE_UNKNOWN {
            return false;
        }
        match *self {
            Requirement::OneOf { mask } => {
                (0..32).contains(&value) && (mask >> (value as u32)) & 1 == 1
            }
            Requirement::Range { min, max } => min <= value && value <= max,
        }
    }
}

/// A PRE or MAINTAIN constraint on one timeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ConstraintSpec {
    pub when: ConstraintWhen,
    /// Index into [`NetworkSpec::timelines`].
    pub timeline: u8,
    pub require: Requirement,
    pub start_offset_us: i64,
    /// MAINTAIN only.
    pub end_offset_us: i64,
}

/// When an impact happens.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ImpactWhen {
    /// At `start + start_offset_us`.
    Pre,
    /// From `start + start_offset_us` to `end + end_offset_us` (undone at the end).
    Maintain,
    /// At `end + end_offset_us` (only if the task completes).
    Post,
}

/// What an impact does to its timeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Effect {
    /// Set the value (state index, or cumulative value). PRE or POST only.
    Assign(i64),
    /// Add a change (MAINTAIN: added at the start, removed at the end).
    Add(i64),
    /// Change the rate, in value units per second (MAINTAIN: for the interval).
    Rate(i64),
    /// Hold the semaphore (claimable timelines, MAINTAIN only).
    Claim,
}

/// A PRE, MAINTAIN or POST impact on one timeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ImpactSpec {
    pub when: ImpactWhen,
    pub timeline: u8,
    pub effect: Effect,
    pub start_offset_us: i64,
    pub end_offset_us: i64,
}

/// A command argument the executive takes from the instance it dispatches, at dispatch.
/// Times are whole seconds of mission time (an `i32` argument holds 68 years of them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum InstanceArg {
    /// The instance's id (the ground id of a requested task, a planner-given id otherwise).
    Instance,
    /// Its end as executed: the dispatch time plus its duration, which a restart shortens to
    /// end by the task's `latest_end` (whole seconds, rounded down).
    EndS,
    /// Its duration as executed (whole seconds, rounded down).
    DurationS,
    /// Argument `k` (of the fixed `args`) of the command of the task this instance was added
    /// for (a template instance that enables or repairs a task; a restarted instance: the
    /// failed one): the site and target indices a helper takes from the task it serves. -1
    /// when the instance serves no other task or that task's command has no argument `k`.
    Served(u8),
}

/// The command a task dispatches: `args`, then one argument per [`CommandSpec::from_instance`]
/// entry, taken from the instance at dispatch (at most [`fsw_bridge::MAX_COMMAND_ARGS`] in
/// all).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CommandSpec {
    pub opcode: Opcode,
    pub args: CommandArgs,
    pub from_instance: heapless::Vec<InstanceArg, { fsw_bridge::MAX_COMMAND_ARGS }>,
}

impl CommandSpec {
    /// A command with fixed arguments only.
    pub fn fixed(opcode: Opcode, args: CommandArgs) -> Self {
        Self {
            opcode,
            args,
            from_instance: heapless::Vec::new(),
        }
    }
}

/// Executive-side control of one task (seed 000 IV.A.4, seed 003 "controller").
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ControlSpec {
    /// Extra condition that must hold (with the PRE constraints) before dispatch.
    pub start_condition: Option<u8>,
    /// Extra condition monitored (with the MAINTAIN constraints) while the task runs.
    pub maintain_condition: Option<u8>,
    /// When true at the start time, the task is skipped (no command, no impacts).
    pub skip_condition: Option<u8>,
    /// How long after its start time the task may wait for its PRE constraints ("task push").
    pub pre_wait_timeout_us: u64,
    /// How long after dispatch the command response may take.
    pub response_timeout_us: u64,
    /// Fire-and-forget command the executive sends when the task fails or is aborted.
    pub on_failure_command: Option<CommandSpec>,
    /// This task's [`ResponsePolicy::max_retries`]; `None`: the network's.
    pub max_retries: Option<PerCause>,
    /// This task's [`ResponsePolicy::max_repairs`]; `None`: the network's.
    pub max_repairs: Option<PerCause>,
    /// This task's [`ResponsePolicy::backoff`]; `None`: the network's.
    pub backoff: Option<Backoff>,
}

impl ControlSpec {
    /// No conditions, no timeouts, no failure command, the network's response policy.
    pub const NONE: Self = Self {
        start_condition: None,
        maintain_condition: None,
        skip_condition: None,
        pre_wait_timeout_us: 0,
        response_timeout_us: 0,
        on_failure_command: None,
        max_retries: None,
        max_repairs: None,
        backoff: None,
    };
}

/// Whether the ground asked for this task or only allows the planner to add it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TaskRole {
    /// In the plan from the start.
    Requested,
    /// Added by the planner only, when a permission and a conflict call for it.
    Template,
}

/// What the planner does when a task fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ContingencyAction {
    /// Schedule a new instance of the task from now on, keeping its latest end (it is shortened
    /// if need be, down to its minimum duration); add permitted templates to enable it.
    Restart,
    /// Schedule a new instance with its full duration at the earliest valid time.
    Move,
    /// Add an instance of the template with this task id, as early as valid.
    AddTemplate(u16),
    /// Give the task up (the plan is repaired without it).
    Delete,
}

/// A contingency: on one of the failure kinds in `on` (bit `FailureKind as u8`), do `action`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Contingency {
    pub on: u8,
    pub action: ContingencyAction,
}

/// What the planner may do to this task and on its behalf.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Permissions {
    /// May be moved within its window while not committed.
    pub may_move: bool,
    /// May be deleted when it cannot be scheduled or repaired.
    pub may_delete: bool,
    /// Templates (task ids) the planner may add: to enable this task when its constraints
    /// cannot be met, to repair a conflict on one of its constraints, and to repair a conflict
    /// on any timeline this task definition impacts (so the flyby's permission covers the
    /// request it serves).
    pub may_add: Vec<u16, MAX_ADD_PERMISSIONS_PER_TASK>,
}

/// One task definition: a requested task or a template.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TaskSpec {
    /// Ground id, unique, below [`FIRST_INSTANCE_ID`]; the requested instance carries it too.
    pub id: u16,
    pub name: Name,
    /// Higher schedules first among tasks with the same earliest start.
    pub priority: u8,
    pub role: TaskRole,
    /// `None`: a no-op task (it runs for its duration without dispatching).
    pub command: Option<CommandSpec>,
    pub duration_us: u64,
    /// Shortest useful duration when the task must end by `latest_end`.
    pub min_duration_us: u64,
    pub earliest_start: MissionTimeUs,
    pub latest_start: MissionTimeUs,
    /// The task ends at `min(start + duration_us, latest_end)`.
    pub latest_end: MissionTimeUs,
    pub constraints: Vec<ConstraintSpec, MAX_CONSTRAINTS_PER_TASK>,
    pub impacts: Vec<ImpactSpec, MAX_IMPACTS_PER_TASK>,
    pub control: ControlSpec,
    pub contingencies: Vec<Contingency, MAX_CONTINGENCIES_PER_TASK>,
    pub permissions: Permissions,
}

impl TaskSpec {
    /// Duration of an instance that starts at `start` (shortened to end by `latest_end`), or
    /// `None` when less than `min_duration_us` would remain.
    pub fn duration_from(&self, start: MissionTimeUs) -> Option<u64> {
        let room = self.latest_end.0.checked_sub(start.0)?;
        let duration = self.duration_us.min(room);
        (duration >= self.min_duration_us).then_some(duration)
    }

    /// The contingency action for a failure of `kind`, if any.
    pub fn contingency_for(
        &self,
        kind: crate::telemetry::FailureKind,
    ) -> Option<ContingencyAction> {
        let bit = 1u8 << (kind as u8);
        self.contingencies
            .iter()
            .find(|c| c.on & bit != 0)
            .map(|c| c.action)
    }
}

/// Relational operator of a condition term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum RelOp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

/// What a condition term reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Operand {
    /// A state-buffer entry (Bool as 0/1, Enum as its code, Int as is).
    State(StateKey),
    /// The measured value of a timeline (the timeline must have a state key).
    Timeline(u8),
}

/// One node of a condition in postfix order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CondNode {
    /// `operand op value`; false when the operand is unknown.
    Term {
        operand: Operand,
        op: RelOp,
        value: i64,
    },
    /// Pops two, pushes their conjunction.
    And,
    /// Pops two, pushes their disjunction.
    Or,
    /// Pops one, pushes its negation.
    Not,
}

/// A boolean expression tree in postfix order, at most [`MAX_CONDITION_TERMS`] nodes and
/// [`MAX_CONDITION_DEPTH`] deep.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ConditionSpec {
    pub nodes: Vec<CondNode, MAX_CONDITION_TERMS>,
}

/// Which point of a task a temporal constraint names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TaskPoint {
    Start,
    End,
}

/// `to_point(to) - from_point(from)` must lie in `[min_us, max_us]` (seed 003: "{start,end} of A
/// must occur {before,after} the {start,end} of B by [min,max]"). Between two requested tasks
/// it applies to their requested instances. Between a template and a requested task (format
/// 5; never two templates) it binds every instance of the template the planner adds to the
/// requested task's requested instance ("this instance starts at least 60 s after the end of
/// task X"); it does not move the requested task, which is placed on its own terms.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TemporalConstraint {
    pub from_task: u16,
    pub from_point: TaskPoint,
    pub to_task: u16,
    pub to_point: TaskPoint,
    pub min_us: i64,
    pub max_us: i64,
}

/// What a model parameter sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ParamUse {
    /// The duration (µs) of the task with this ground id.
    Duration { task: u16 },
    /// The magnitude of impact `impact` of the task with this ground id (an `Add`, `Rate` or
    /// `Assign` on a cumulative timeline: an energy, a power).
    Impact { task: u16, impact: u8 },
}

/// A model parameter (seed 000 IV.C.3): a value several task durations or impact magnitudes
/// share, with its prior, that measurements update at run time. Every use holds `value`
/// (the network's tasks carry it, so the planner and executive read it where they read any
/// duration or magnitude, and a checkpoint of the network keeps it across a warm reset).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ParamSpec {
    /// The value the ground uplinked.
    pub prior: i64,
    /// The value in force: the prior, or the last accepted measurement.
    pub value: i64,
    /// Measurements outside `[min, max]` are not taken (counted instead).
    pub min: i64,
    pub max: i64,
    /// The measured cumulative timeline whose measurements set the parameter (a subsystem
    /// reports the measured duration or energy of what it executed, or the ground uplinks a
    /// new value as a state update); `None`: fixed at its prior.
    pub measured_by: Option<u8>,
    pub uses: Vec<ParamUse, MAX_PARAM_USES>,
}

/// The fixed part at the head of an uplink.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetworkHeader {
    pub format_version: u16,
    /// Ground-assigned identifier of this network (echoed in reports).
    pub network_id: u32,
    pub config: PlannerConfig,
    /// Network-wide response bounds and back-off (tasks may override them).
    pub responses: ResponsePolicy,
}

/// A task network as the ground builds it, not yet validated.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetworkSpec {
    pub header: NetworkHeader,
    pub timelines: Vec<TimelineSpec, MAX_TIMELINES>,
    pub conditions: Vec<ConditionSpec, MAX_CONDITIONS>,
    pub tasks: Vec<TaskSpec, MAX_TASKS>,
    pub temporal: Vec<TemporalConstraint, MAX_TEMPORAL_CONSTRAINTS>,
    /// Timed values of the external timelines, in time order per timeline.
    pub timed: Vec<TimedValue, MAX_TIMED_VALUES>,
    /// Model parameters (format 5).
    pub params: Vec<ParamSpec, MAX_PARAMS>,
}

impl NetworkSpec {
    /// An empty network with the given id and planner windows.
    pub const fn new(network_id: u32, config: PlannerConfig) -> Self {
        Self {
            header: NetworkHeader {
                format_version: UPLINK_FORMAT_VERSION,
                network_id,
                config,
                responses: ResponsePolicy::DEFAULT,
            },
            timelines: Vec::new(),
            conditions: Vec::new(),
            tasks: Vec::new(),
            temporal: Vec::new(),
            timed: Vec::new(),
            params: Vec::new(),
        }
    }
}

/// A validated task network. Every index it holds is in range and every value fits its
/// timeline; see [`crate::uplink`] for the checks. Only the uplink module builds one from a
/// spec ([`TaskNetwork::from_spec`], [`TaskNetwork::validate_uplink`]): it depends on this
/// module, never the other way.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TaskNetwork {
    pub(crate) spec: NetworkSpec,
}

impl TaskNetwork {
    /// The empty network (no timelines, no tasks) the core holds before the first uplink.
    pub const EMPTY: Self = Self {
        spec: NetworkSpec::new(0, PlannerConfig::DEFAULT),
    };

    /// Makes this network [`TaskNetwork::EMPTY`], in place (assigning `EMPTY` copies a
    /// constant image of a whole network, which sits in the firmware image).
    pub fn clear(&mut self) {
        self.spec.header = NetworkHeader {
            format_version: UPLINK_FORMAT_VERSION,
            network_id: 0,
            config: PlannerConfig::DEFAULT,
            responses: ResponsePolicy::DEFAULT,
        };
        self.spec.timelines.clear();
        self.spec.conditions.clear();
        self.spec.tasks.clear();
        self.spec.temporal.clear();
        self.spec.timed.clear();
        self.spec.params.clear();
    }

    /// The longest duration an instance of `def` can have been planned with: its duration,
    /// or the largest its duration parameter allows (a measurement may have shortened it
    /// since).
    pub fn max_duration_us(&self, def: u8) -> u64 {
        let Some(t) = self.task(def) else {
            return 0;
        };
        let mut longest = t.duration_us;
        for p in &self.spec.params {
            if p.uses.contains(&ParamUse::Duration { task: t.id }) {
                longest = longest.max(u64::try_from(p.max).unwrap_or(0));
            }
        }
        longest
    }

    /// The model parameters.
    pub fn params(&self) -> &[ParamSpec] {
        &self.spec.params
    }

    /// Takes a measurement of `timeline` for the parameters it measures: each whose value it
    /// changes and that accepts it (within its `[min, max]`) takes it, in itself and in every
    /// use. Returns (parameters changed, parameters that refused it). Costs nothing for a
    /// network without parameters.
    pub fn measure_params(&mut self, timeline: u8, value: i64) -> (u8, u8) {
        let (mut changed, mut refused) = (0u8, 0u8);
        for p in self.spec.params.iter_mut() {
            if p.measured_by != Some(timeline) || p.value == value {
                continue;
            }
            if value < p.min || value > p.max {
                refused = refused.saturating_add(1);
                continue;
            }
            p.value = value;
            changed = changed.saturating_add(1);
            for u in p.uses.iter() {
                set_use(&mut self.spec.tasks, *u, value);
            }
        }
        (changed, refused)
    }

    /// The validated contents.
    pub fn spec(&self) -> &NetworkSpec {
        &self.spec
    }

    pub fn config(&self) -> &PlannerConfig {
        &self.spec.header.config
    }

    pub fn network_id(&self) -> u32 {
        self.spec.header.network_id
    }

    pub fn timelines(&self) -> &[TimelineSpec] {
        &self.spec.timelines
    }

    pub fn tasks(&self) -> &[TaskSpec] {
        &self.spec.tasks
    }

    pub fn task(&self, def: u8) -> Option<&TaskSpec> {
        self.spec.tasks.get(usize::from(def))
    }

    pub fn timeline(&self, index: u8) -> Option<&TimelineSpec> {
        self.spec.timelines.get(usize::from(index))
    }

    pub fn condition(&self, index: u8) -> Option<&ConditionSpec> {
        self.spec.conditions.get(usize::from(index))
    }

    pub fn temporal(&self) -> &[TemporalConstraint] {
        &self.spec.temporal
    }

    /// The timed values of the external timelines.
    pub fn timed(&self) -> &[TimedValue] {
        &self.spec.timed
    }

    /// Index of the task definition with ground id `id`.
    pub fn def_of_id(&self, id: u16) -> Option<u8> {
        self.spec
            .tasks
            .iter()
            .position(|t| t.id == id)
            .and_then(|i| u8::try_from(i).ok())
    }

    /// The network-wide response policy.
    pub fn responses(&self) -> &ResponsePolicy {
        &self.spec.header.responses
    }

    /// The executive retry bounds of task definition `def` (its own, or the network's).
    pub fn max_retries(&self, def: u8) -> PerCause {
        self.task(def)
            .and_then(|t| t.control.max_retries)
            .unwrap_or(self.spec.header.responses.max_retries)
    }

    /// The planner repair bounds of task definition `def` (its own, or the network's).
    pub fn max_repairs(&self, def: u8) -> PerCause {
        self.task(def)
            .and_then(|t| t.control.max_repairs)
            .unwrap_or(self.spec.header.responses.max_repairs)
    }

    /// The back-off of task definition `def` (its own, or the network's).
    pub fn backoff(&self, def: u8) -> Backoff {
        self.task(def)
            .and_then(|t| t.control.backoff)
            .unwrap_or(self.spec.header.responses.backoff)
    }

    /// The most instances of definition `def` one run can have: the first and one per
    /// permitted repair (`1 + sum of max_repairs`). A run ends when an instance of `def`
    /// completes.
    pub fn max_instances_per_run(&self, def: u8) -> u32 {
        1 + self.max_repairs(def).total_over(FailureKind::REPAIRABLE)
    }

    /// The most commands one run of definition `def` can send: each instance dispatched once,
    /// and once more per permitted retry (`max_instances_per_run * (1 + sum of
    /// max_retries)`).
    pub fn max_dispatches_per_run(&self, def: u8) -> u32 {
        let retries = self.max_retries(def).total_over(FailureKind::RETRYABLE);
        self.max_instances_per_run(def) * (1 + retries)
    }

    /// Every measured timeline: (timeline index, its state key, the value type it takes).
    pub fn measured_timelines(
        &self,
    ) -> impl Iterator<Item = (u8, StateKey, MeasuredValueType)> + '_ {
        self.spec.timelines.iter().enumerate().filter_map(|(i, t)| {
            Some((
                u8::try_from(i).ok()?,
                t.state_key?,
                t.measured_value_type()?,
            ))
        })
    }

    /// Index of the timeline measured by state-buffer entry `key`.
    pub fn timeline_of_key(&self, key: StateKey) -> Option<u8> {
        self.spec
            .timelines
            .iter()
            .position(|t| t.state_key == Some(key))
            .and_then(|i| u8::try_from(i).ok())
    }

    /// Index of the timeline called `name`.
    pub fn timeline_by_name(&self, name: &str) -> Option<u8> {
        self.spec
            .timelines
            .iter()
            .position(|t| t.name.as_str() == name)
            .and_then(|i| u8::try_from(i).ok())
    }

    /// Index of the task definition called `name`.
    pub fn def_by_name(&self, name: &str) -> Option<u8> {
        self.spec
            .tasks
            .iter()
            .position(|t| t.name.as_str() == name)
            .and_then(|i| u8::try_from(i).ok())
    }
}

/// The number a parameter use holds in `tasks` (`None` when it names nothing it can hold).
pub fn use_value(tasks: &[TaskSpec], u: ParamUse) -> Option<i64> {
    match u {
        ParamUse::Duration { task } => {
            let t = tasks.iter().find(|t| t.id == task)?;
            i64::try_from(t.duration_us).ok()
        }
        ParamUse::Impact { task, impact } => {
            let t = tasks.iter().find(|t| t.id == task)?;
            match t.impacts.get(usize::from(impact))?.effect {
                Effect::Add(v) | Effect::Rate(v) | Effect::Assign(v) => Some(v),
                Effect::Claim => None,
            }
        }
    }
}

/// Sets the number use `u` names in `tasks` to `value` (validated to fit it).
fn set_use(tasks: &mut [TaskSpec], u: ParamUse, value: i64) {
    match u {
        ParamUse::Duration { task } => {
            if let Some(t) = tasks.iter_mut().find(|t| t.id == task) {
                t.duration_us = u64::try_from(value).unwrap_or(t.duration_us);
            }
        }
        ParamUse::Impact { task, impact } => {
            let effect = tasks
                .iter_mut()
                .find(|t| t.id == task)
                .and_then(|t| t.impacts.get_mut(usize::from(impact)))
                .map(|i| &mut i.effect);
            if let Some(Effect::Add(v) | Effect::Rate(v) | Effect::Assign(v)) = effect {
                *v = value;
            }
        }
    }
}
