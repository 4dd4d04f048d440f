//! Binary task-network uplink: format, validation and decoding (seed 000 IV.A.3: "performs
//! input validation before storing the information").
//!
//! Format (postcard throughout, [`crate::UPLINK_FORMAT_VERSION`]):
//! `NetworkHeader, u16 n, n x TimelineSpec, u16 n, n x ConditionSpec, u16 n, n x TaskSpec,
//! u16 n, n x TemporalConstraint, u16 n, n x TimedValue, u16 n, n x ParamSpec`, and nothing
//! after.
//!
//! [`validate_uplink`] walks the bytes one element at a time (no temporary larger than one
//! [`TaskSpec`]), so a rejected uplink never touches the running network; only then does
//! [`decode_into`] rebuild the network in place. Elements are read field by field
//! ([`take_task`] and its siblings), so a list over its capacity is refused with its own code
//! (`TooManyConstraints`, ...) at the first item that does not fit, and bytes that do not
//! decode are named with the field they are in. Every rejection is a [`ValidationError`]: a
//! [`ValidationCode`] (its `u16` goes to the host in `UplinkNak.reason`) and an [`ErrorSite`]
//! naming the element, which the ground compiler maps back to `file:line:column`.
use heapless::Vec;
use serde::{de::DeserializeOwned, Serialize};

use crate::capacity::*;
use crate::model::*;
use crate::telemetry::FailureKind;
use fsw_bridge::MissionTimeUs;

mod encode;
mod reader;
mod validate;

pub use encode::{encode_spec, BufferTooSmall};
use reader::Reader;
pub use reader::{take_condition, take_task, take_timeline};
use validate::push_id;
use validate::{note_durations, validate_param, validate_param_uses, validate_params_found};
pub use validate::{
    stale_bound_in_range, validate_condition, validate_header, validate_spec, validate_task,
    validate_temporal, validate_temporal_cycles, validate_timed_value, validate_timeline,
    TaskContext, TaskDurations,
};

/// Why an uplink was refused. `code as u16` is what reaches the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum ValidationCode {
    /// Bytes do not decode (bad varint, enum tag, option tag, UTF-8, or the bytes end inside an
    /// element). A list over its capacity has its own `TooMany...` code, a name over
    /// [`MAX_NAME_LEN`] [`ValidationCode::NameTooLong`].
    Decode = 1,
    /// Bytes remain after the last element.
    TrailingBytes = 2,
    /// `format_version` is not [`UPLINK_FORMAT_VERSION`].
    FormatVersion = 3,
    // 10-21: a list or name over its capacity, refused at the first item that does not fit.
    /// More than [`MAX_TIMELINES`] timelines.
    TooManyTimelines = 10,
    /// More than [`MAX_TASKS`] tasks.
    TooManyTasks = 11,
    /// More than [`MAX_CONSTRAINTS_PER_TASK`] constraints in a task.
    TooManyConstraints = 12,
    /// More than [`MAX_IMPACTS_PER_TASK`] impacts in a task.
    TooManyImpacts = 13,
    /// More than [`MAX_CONDITIONS`] conditions.
    TooManyConditions = 14,
    /// More than [`MAX_CONDITION_TERMS`] nodes in a condition.
    TooManyConditionTerms = 15,
    /// More than [`MAX_CONTINGENCIES_PER_TASK`] contingencies in a task.
    TooManyContingencies = 16,
    /// More than [`MAX_ADD_PERMISSIONS_PER_TASK`] templates a task may add.
    TooManyPermissions = 17,
    /// More than [`MAX_TEMPORAL_CONSTRAINTS`] temporal constraints.
    TooManyTemporalConstraints = 18,
    /// A state timeline with no values or more than [`MAX_STATE_VALUES`].
    TooManyStateValues = 19,
    /// A name over [`MAX_NAME_LEN`] bytes.
    NameTooLong = 20,
    /// A command (a task's, or its `on_failure_command`) with more than
    /// [`fsw_bridge::MAX_COMMAND_ARGS`] arguments.
    TooManyCommandArgs = 21,
    /// More than [`MAX_TIMED_VALUES`] timed values.
    TooManyTimedValues = 22,
    /// More than [`MAX_THRESHOLDS`] thresholds on a timeline.
    TooManyThresholds = 23,
    /// More than [`MAX_PARAMS`] model parameters.
    TooManyParams = 24,
    /// Two tasks share an id.
    DuplicateTaskId = 30,
    /// A ground task id at or above [`FIRST_INSTANCE_ID`].
    TaskIdReserved = 31,
    /// Two timelines share a name.
    DuplicateTimelineName = 32,
    /// A timeline index that does not exist.
    DanglingTimeline = 33,
    /// A condition index that does not exist.
    DanglingCondition = 34,
    /// A template id that does not exist or is not a template.
    DanglingTemplate = 35,
    /// A temporal constraint naming a task that does not exist, or the same task twice.
    DanglingTemporalTask = 36,
    /// Two timelines measured by the same state key.
    DuplicateStateKey = 37,
    /// An effect or requirement that does not fit the timeline kind (Add on a state timeline,
    /// Claim on a cumulative one, OneOf on a cumulative one, ...).
    TypeMismatch = 40,
    /// A value outside its timeline (state index >= value count, initial outside bounds, mask
    /// bits beyond the value count, magnitude over [`MAX_MAGNITUDE`]).
    ValueOutOfRange = 41,
    /// A requirement nothing can satisfy (empty mask, min > max).
    EmptyRequirement = 42,
    /// A claim that is not a MAINTAIN impact.
    ClaimNotMaintain = 43,
    /// An Assign at MAINTAIN (only PRE/POST assignments are defined).
    MaintainAssign = 44,
    /// A condition term on a timeline that has no state key.
    TermNotMeasured = 45,
    /// A contingency with an empty failure mask (every bit names a [`FailureKind`]).
    BadContingency = 46,
    /// earliest_start > latest_start.
    BadTimeWindow = 50,
    /// Zero duration, min_duration > duration, or over [`MAX_DURATION_US`].
    BadDuration = 51,
    /// A requested task cannot fit: earliest_start + min_duration > latest_end.
    WindowTooShort = 52,
    /// A mission time over [`MAX_MISSION_TIME_US`].
    TimeOutOfRange = 53,
    /// An offset over [`MAX_OFFSET_US`], or a MAINTAIN interval that is empty at full duration.
    BadOffset = 54,
    /// A planner window of zero, or commit window > scheduling window > horizon.
    BadPlannerConfig = 55,
    /// A temporal constraint with min > max or bounds over [`MAX_OFFSET_US`].
    BadTemporalBounds = 56,
    /// A timeout of zero (when it applies) or over [`MAX_DURATION_US`].
    BadTimeout = 57,
    /// A condition that is not one well-formed postfix expression.
    MalformedCondition = 60,
    /// A condition deeper than [`MAX_CONDITION_DEPTH`].
    ConditionTooDeep = 61,
    /// A condition with no nodes.
    EmptyCondition = 62,
    /// A `max_retries` or `max_repairs` bound over [`MAX_RESPONSE_BOUND`].
    BadResponseBound = 70,
    /// A non-zero bound where it means nothing: `max_retries` for a cause the executive
    /// cannot retry (outside [`FailureKind::RETRYABLE`]) or on a task without a command,
    /// `max_repairs` for a cause the planner never answers (outside
    /// [`FailureKind::REPAIRABLE`]).
    BoundNotApplicable = 71,
    /// A back-off whose initial delay exceeds its cap, whose initial delay is zero while its
    /// cap is not (zero doubles to zero), or whose cap is over [`MAX_DURATION_US`].
    BadBackoff = 72,
    /// `after_reset` on a timeline a state key measures (the state buffer says what it is
    /// after a reset).
    RevertMeasuredTimeline = 73,
    /// `after_reset` on a claimable or cumulative timeline (only state timelines revert).
    RevertNotState = 74,
    /// A `stale_after_us` bound of zero or over [`MAX_STALE_AFTER_US`].
    BadStaleBound = 75,
    /// `stale_after_us` on a timeline no state key measures (only measurements age).
    StaleNotMeasured = 76,
    /// A background rate on a timeline that is not cumulative, or over [`MAX_MAGNITUDE`].
    BadBackgroundRate = 80,
    /// An external timeline that is claimable, or a task impact on an external timeline
    /// (only its timed values and measurements set it).
    ExternalTimeline = 81,
    /// A timed value on a timeline that is not external, at a time over
    /// [`MAX_MISSION_TIME_US`], or earlier than the one before it on the same timeline.
    BadTimedValue = 82,
    /// Thresholds on a timeline that is not a measured state timeline, not strictly
    /// increasing, over [`MAX_MAGNITUDE`], or not exactly one fewer than its values.
    BadThresholds = 83,
    /// A temporal constraint between two templates (a template's instances are bound only to
    /// a requested task's requested instance).
    TemporalTemplatePair = 84,
    /// Temporal constraints that form a cycle no schedule can meet, with the tasks' durations
    /// (a negative cycle of the simple temporal network; refused at the constraint that
    /// closes it).
    TemporalCycle = 85,
    /// A command argument taken from the instance that names no argument
    /// ([`InstanceArg::Served`] at or past [`fsw_bridge::MAX_COMMAND_ARGS`]), or a command
    /// with more than [`fsw_bridge::MAX_COMMAND_ARGS`] fixed and instance arguments together.
    BadInstanceArg = 86,
    /// A model parameter whose bounds do not hold its prior and value, that a timeline
    /// measures which is not a measured cumulative one, or with a use that names no task, a
    /// duration its bounds do not fit (at least the task's minimum duration, at most 30
    /// days), an impact without a magnitude, a magnitude over [`MAX_MAGNITUDE`], or a number
    /// that is not the parameter's value.
    BadParam = 87,
}

impl ValidationCode {
    pub const fn code(self) -> u16 {
        self as u16
    }
}

/// Which field of a task an error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskField {
    Whole,
    Id,
    Name,
    Command,
    Duration,
    Window,
    Constraint(u8),
    Impact(u8),
    Control,
    Contingency(u8),
    Permission(u8),
    /// A response-policy field (the task's own override).
    Responses(ResponseField),
}

/// Which field of a response policy an error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResponseField {
    MaxRetries,
    MaxRepairs,
    Backoff,
}

/// Where in the network an error is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorSite {
    Network,
    /// A field of the network-wide response policy.
    NetworkResponses(ResponseField),
    Timeline(u8),
    /// The `after_reset` value of a timeline.
    TimelineAfterReset(u8),
    /// The `stale_after_us` bound of a timeline.
    TimelineStaleAfter(u8),
    Condition {
        condition: u8,
        node: u8,
    },
    Task {
        /// `u16`: a network holds up to [`MAX_TASKS`] (256) tasks, and the site of a refused
        /// 257th task is task 256.
        task: u16,
        field: TaskField,
    },
    Temporal(u8),
    /// The thresholds of a timeline.
    TimelineThresholds(u8),
    TimedValue(u8),
    /// A model parameter.
    Param(u8),
}

/// A rejected uplink: what and where.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ValidationError {
    pub code: ValidationCode,
    pub site: ErrorSite,
}

impl ValidationError {
    pub const fn new(code: ValidationCode, site: ErrorSite) -> Self {
        Self { code, site }
    }
}

impl core::fmt::Display for ValidationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{:?} (code {}) at {:?}",
            self.code,
            self.code.code(),
            self.site
        )
    }
}

type VResult = Result<(), ValidationError>;

fn err(code: ValidationCode, site: ErrorSite) -> VResult {
    Err(ValidationError::new(code, site))
}

fn u8_index(i: usize) -> u8 {
    u8::try_from(i).unwrap_or(u8::MAX)
}

fn u16_index(i: usize) -> u16 {
    u16::try_from(i).unwrap_or(u16::MAX)
}

/// Validates a binary uplink without storing anything. Stack use stays around one [`TaskSpec`]
/// plus the timeline table.
pub fn validate_uplink(bytes: &[u8]) -> VResult {
    use ValidationCode::*;
    let mut r = Reader { rest: bytes };
    let header: NetworkHeader = r.take(ErrorSite::Network)?;
    validate_header(&header)?;
    let mut timelines: Vec<TimelineSpec, MAX_TIMELINES> = Vec::new();
    let timeline_count = r.count(
        MAX_TIMELINES,
        TooManyTimelines,
        ErrorSite::Timeline(u8_index(MAX_TIMELINES)),
    )?;
    for i in 0..timeline_count {
        let t = r.timeline(i)?;
        validate_timeline(i, &t, &timelines)?;
        timelines.push(t).map_err(|_| {
            ValidationError::new(TooManyTimelines, ErrorSite::Timeline(u8_index(i)))
        })?;
    }
    let condition_count = r.count(
        MAX_CONDITIONS,
        TooManyConditions,
        ErrorSite::Condition {
            condition: u8_index(MAX_CONDITIONS),
            node: 0,
        },
    )?;
    for i in 0..condition_count {
        let c = r.condition(i)?;
        validate_condition(i, &c, &timelines)?;
    }
    let task_count = r.count(
        MAX_TASKS,
        TooManyTasks,
        ErrorSite::Task {
            task: u16_index(MAX_TASKS),
            field: TaskField::Whole,
        },
    )?;
    let tasks_start = r.rest;
    let mut ids: Vec<(u16, TaskRole), MAX_TASKS> = Vec::new();
    for i in 0..task_count {
        let t = r.task(i)?;
        push_id(&mut ids, i, &t)?;
    }
    let after_tasks = r.rest;
    r.rest = tasks_start;
    let ctx = TaskContext {
        timelines: &timelines,
        condition_count,
        ids: &ids,
    };
    for i in 0..task_count {
        let t = r.task(i)?;
        validate_task(i, &t, &ctx)?;
    }
    r.rest = after_tasks;
    let temporal_count = r.count(
        MAX_TEMPORAL_CONSTRAINTS,
        TooManyTemporalConstraints,
        ErrorSite::Temporal(u8_index(MAX_TEMPORAL_CONSTRAINTS)),
    )?;
    let mut temporal: Vec<TemporalConstraint, MAX_TEMPORAL_CONSTRAINTS> = Vec::new();
    for i in 0..temporal_count {
        let tc: TemporalConstraint = r.take(ErrorSite::Temporal(u8_index(i)))?;
        validate_temporal(i, &tc, &ids)?;
        let _ = temporal.push(tc);
    }
    if !temporal.is_empty() {
        // The durations of the tasks the constraints name, from a third walk over the tasks
        // (only networks with temporal constraints pay for it).
        let after_temporal = r.rest;
        r.rest = tasks_start;
        let mut durations: Vec<TaskDurations, { 2 * MAX_TEMPORAL_CONSTRAINTS }> = Vec::new();
        for i in 0..task_count {
            let t = r.task(i)?;
            note_durations(&mut durations, &temporal, &t);
        }
        r.rest = after_temporal;
        validate_temporal_cycles(&temporal, &durations)?;
    }
    let timed_count = r.count(
        MAX_TIMED_VALUES,
        TooManyTimedValues,
        ErrorSite::TimedValue(u8_index(MAX_TIMED_VALUES)),
    )?;
    let mut last_at = [MissionTimeUs::ZERO; MAX_TIMELINES];
    for i in 0..timed_count {
        let tv: TimedValue = r.take(ErrorSite::TimedValue(u8_index(i)))?;
        validate_timed_value(i, &tv, &timelines, &mut last_at)?;
    }
    let param_count = r.count(
        MAX_PARAMS,
        TooManyParams,
        ErrorSite::Param(u8_index(MAX_PARAMS)),
    )?;
    if param_count > 0 {
        let mut params: Vec<ParamSpec, MAX_PARAMS> = Vec::new();
        for i in 0..param_count {
            let p: ParamSpec = r.take(ErrorSite::Param(u8_index(i)))?;
            validate_param(i, &p, &timelines)?;
            let _ = params.push(p);
        }
        // Each use against its task, from one more walk over the tasks (only networks with
        // parameters pay for it).
        let after_params = r.rest;
        r.rest = tasks_start;
        for i in 0..task_count {
            let t = r.task(i)?;
            validate_param_uses(&params, &t, &timelines)?;
        }
        r.rest = after_params;
        for (i, p) in params.iter().enumerate() {
            validate_params_found(i, p, &ids)?;
        }
    }
    if !r.rest.is_empty() {
        return err(TrailingBytes, ErrorSite::Network);
    }
    Ok(())
}

/// Validates `bytes` and, only if they pass, rebuilds `network` from them in place. On error
/// `network` is unchanged.
pub fn decode_into(network: &mut TaskNetwork, bytes: &[u8]) -> VResult {
    use ValidationCode::*;
    validate_uplink(bytes)?;
    // Validated: every element below decodes and fits, so no error can occur part-way.
    let mut r = Reader { rest: bytes };
    let spec = &mut network.spec;
    spec.header = r.take(ErrorSite::Network)?;
    r.refill(&mut spec.timelines, TooManyTimelines, Reader::timeline)?;
    r.refill(&mut spec.conditions, TooManyConditions, Reader::condition)?;
    r.refill(&mut spec.tasks, TooManyTasks, Reader::task)?;
    r.refill(
        &mut spec.temporal,
        TooManyTemporalConstraints,
        |r: &mut Reader<'_>, i| r.take(ErrorSite::Temporal(u8_index(i))),
    )?;
    r.refill(
        &mut spec.timed,
        TooManyTimedValues,
        |r: &mut Reader<'_>, i| r.take(ErrorSite::TimedValue(u8_index(i))),
    )?;
    r.refill(&mut spec.params, TooManyParams, |r: &mut Reader<'_>, i| {
        r.take(ErrorSite::Param(u8_index(i)))
    })?;
    Ok(())
}

/// Decodes `bytes` into `network` and then checks what it decoded with [`validate_spec`]: the
/// checks [`validate_uplink`] makes on the same values, so it accepts exactly what
/// [`decode_into`] accepts, but decodes the network once where `decode_into` decodes its tasks
/// three times (twice to validate the bytes, once to store them). The checkpoint restore's
/// path. On error `network` holds whatever was decoded: for callers that discard it.
pub fn decode_then_validate(network: &mut TaskNetwork, bytes: &[u8]) -> VResult {
    use ValidationCode::*;
    let mut r = Reader { rest: bytes };
    let spec = &mut network.spec;
    spec.header = r.take(ErrorSite::Network)?;
    // Element counts are refused at the same sites as in `validate_uplink`.
    spec.timelines.clear();
    let timeline_count = r.count(
        MAX_TIMELINES,
        TooManyTimelines,
        ErrorSite::Timeline(u8_index(MAX_TIMELINES)),
    )?;
    for i in 0..timeline_count {
        r.timeline_into(i, &mut spec.timelines)?;
    }
    spec.conditions.clear();
    let condition_count = r.count(
        MAX_CONDITIONS,
        TooManyConditions,
        ErrorSite::Condition {
            condition: u8_index(MAX_CONDITIONS),
            node: 0,
        },
    )?;
    for i in 0..condition_count {
        let c = r.condition(i)?;
        spec.conditions.push(c).map_err(|_| {
            ValidationError::new(
                TooManyConditions,
                ErrorSite::Condition {
                    condition: u8_index(i),
                    node: 0,
                },
            )
        })?;
    }
    spec.tasks.clear();
    let task_count = r.count(
        MAX_TASKS,
        TooManyTasks,
        ErrorSite::Task {
            task: u16_index(MAX_TASKS),
            field: TaskField::Whole,
        },
    )?;
    for i in 0..task_count {
        r.task_into(i, &mut spec.tasks)?;
    }
    spec.temporal.clear();
    let temporal_count = r.count(
        MAX_TEMPORAL_CONSTRAINTS,
        TooManyTemporalConstraints,
        ErrorSite::Temporal(u8_index(MAX_TEMPORAL_CONSTRAINTS)),
    )?;
    for i in 0..temporal_count {
        let tc = r.take(ErrorSite::Temporal(u8_index(i)))?;
        spec.temporal.push(tc).map_err(|_| {
            ValidationError::new(TooManyTemporalConstraints, ErrorSite::Temporal(u8_index(i)))
        })?;
    }
    spec.timed.clear();
    let timed_count = r.count(
        MAX_TIMED_VALUES,
        TooManyTimedValues,
        ErrorSite::TimedValue(u8_index(MAX_TIMED_VALUES)),
    )?;
    for i in 0..timed_count {
        let tv = r.take(ErrorSite::TimedValue(u8_index(i)))?;
        spec.timed.push(tv).map_err(|_| {
            ValidationError::new(TooManyTimedValues, ErrorSite::TimedValue(u8_index(i)))
        })?;
    }
    spec.params.clear();
    let param_count = r.count(
        MAX_PARAMS,
        TooManyParams,
        ErrorSite::Param(u8_index(MAX_PARAMS)),
    )?;
    for i in 0..param_count {
        let p = r.take(ErrorSite::Param(u8_index(i)))?;
        spec.params
            .push(p)
            .map_err(|_| ValidationError::new(TooManyParams, ErrorSite::Param(u8_index(i))))?;
    }
    if !r.rest.is_empty() {
        return err(TrailingBytes, ErrorSite::Network);
    }
    validate_spec(spec)
}

impl TaskNetwork {
    /// Validate `spec` and wrap it. The same checks run on the target for binary uplinks.
    pub fn from_spec(spec: NetworkSpec) -> Result<Self, ValidationError> {
        validate_spec(&spec)?;
        Ok(Self { spec })
    }

    /// Validates a binary uplink without storing it.
    pub fn validate_uplink(bytes: &[u8]) -> VResult {
        validate_uplink(bytes)
    }

    /// Encodes this network in the uplink format; returns the length used.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, BufferTooSmall> {
        encode_spec(&self.spec, buf)
    }
}
