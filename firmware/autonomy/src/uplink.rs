//! Binary task-network uplink: format, validation and decoding (seed 000 IV.A.3: "performs
//! input validation before storing the information").
//!
//! Format (postcard throughout, [`crate::UPLINK_FORMAT_VERSION`]):
//! `NetworkHeader, u16 n, n x TimelineSpec, u16 n, n x ConditionSpec, u16 n, n x TaskSpec,
//! u16 n, n x TemporalConstraint`, and nothing after.
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
    /// A temporal constraint naming a task that does not exist or is a template.
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

/// Checks the planner windows and the format version.
pub fn validate_header(header: &NetworkHeader) -> VResult {
    use ValidationCode::*;
    if header.format_version != UPLINK_FORMAT_VERSION {
        return err(FormatVersion, ErrorSite::Network);
    }
    let c = &header.config;
    let ok = c.commit_window_us > 0
        && c.plan_process_interval_us > 0
        && c.commit_window_us <= c.scheduling_window_us
        && c.scheduling_window_us <= c.plan_horizon_us
        && c.plan_horizon_us <= MAX_MISSION_TIME_US
        && c.plan_process_interval_us <= MAX_DURATION_US;
    if !ok {
        return err(BadPlannerConfig, ErrorSite::Network);
    }
    validate_responses(
        Some(&header.responses.max_retries),
        Some(&header.responses.max_repairs),
        Some(&header.responses.backoff),
        true,
        ErrorSite::NetworkResponses,
    )
}

/// Checks the parts of a response policy that are given. `has_command`: whether retries can
/// apply (a network-wide default applies to tasks with commands).
fn validate_responses(
    max_retries: Option<&PerCause>,
    max_repairs: Option<&PerCause>,
    backoff: Option<&Backoff>,
    has_command: bool,
    site: impl Fn(ResponseField) -> ErrorSite,
) -> VResult {
    use ValidationCode::*;
    let over_bound = |p: &PerCause| p.0.iter().any(|&v| v > MAX_RESPONSE_BOUND);
    if let Some(retries) = max_retries {
        let s = site(ResponseField::MaxRetries);
        if over_bound(retries) {
            return err(BadResponseBound, s);
        }
        let allowed = if has_command {
            FailureKind::RETRYABLE
        } else {
            0
        };
        if retries.nonzero_causes() & !allowed != 0 {
            return err(BoundNotApplicable, s);
        }
    }
    if let Some(repairs) = max_repairs {
        let s = site(ResponseField::MaxRepairs);
        if over_bound(repairs) {
            return err(BadResponseBound, s);
        }
        if repairs.nonzero_causes() & !FailureKind::REPAIRABLE != 0 {
            return err(BoundNotApplicable, s);
        }
    }
    if let Some(b) = backoff {
        let ok = b.initial_us <= b.max_us
            && b.max_us <= MAX_DURATION_US
            && (b.initial_us > 0 || b.max_us == 0);
        if !ok {
            return err(BadBackoff, site(ResponseField::Backoff));
        }
    }
    Ok(())
}

/// Whether `bound_us` may be a staleness bound ([`TimelineSpec::stale_after_us`]): positive
/// and at most [`MAX_STALE_AFTER_US`]. The ground compiler checks a network-wide default with
/// it too.
pub fn stale_bound_in_range(bound_us: u64) -> bool {
    (1..=MAX_STALE_AFTER_US).contains(&bound_us)
}

/// Checks timeline `index` against the ones before it.
pub fn validate_timeline(
    index: usize,
    timeline: &TimelineSpec,
    earlier: &[TimelineSpec],
) -> VResult {
    use ValidationCode::*;
    let site = ErrorSite::Timeline(u8_index(index));
    if earlier.iter().any(|t| t.name == timeline.name) {
        return err(DuplicateTimelineName, site);
    }
    if timeline.state_key.is_some() && earlier.iter().any(|t| t.state_key == timeline.state_key) {
        return err(DuplicateStateKey, site);
    }
    if let Some(bound) = timeline.stale_after_us {
        let s = ErrorSite::TimelineStaleAfter(u8_index(index));
        if timeline.state_key.is_none() {
            return err(StaleNotMeasured, s);
        }
        if !stale_bound_in_range(bound) {
            return err(BadStaleBound, s);
        }
    }
    match timeline.kind {
        TimelineKind::State {
            value_count,
            initial,
        } => {
            if value_count == 0 || usize::from(value_count) > MAX_STATE_VALUES {
                return err(TooManyStateValues, site);
            }
            if initial >= u16::from(value_count) {
                return err(ValueOutOfRange, site);
            }
            if let Some(v) = timeline.after_reset {
                let s = ErrorSite::TimelineAfterReset(u8_index(index));
                if timeline.state_key.is_some() {
                    return err(RevertMeasuredTimeline, s);
                }
                if v < 0 || v >= i64::from(value_count) {
                    return err(ValueOutOfRange, s);
                }
            }
        }
        TimelineKind::Claimable | TimelineKind::Cumulative { .. }
            if timeline.after_reset.is_some() =>
        {
            return err(
                RevertNotState,
                ErrorSite::TimelineAfterReset(u8_index(index)),
            );
        }
        TimelineKind::Claimable => {}
        TimelineKind::Cumulative { initial, min, max } => {
            let in_magnitude = |v: i64| (-MAX_MAGNITUDE..=MAX_MAGNITUDE).contains(&v);
            if !(in_magnitude(initial) && in_magnitude(min) && in_magnitude(max)) {
                return err(ValueOutOfRange, site);
            }
            if min > max {
                return err(EmptyRequirement, site);
            }
            if initial < min || initial > max {
                return err(ValueOutOfRange, site);
            }
        }
    }
    Ok(())
}

/// Checks condition `index`: well-formed postfix, depth, operands.
pub fn validate_condition(
    index: usize,
    condition: &ConditionSpec,
    timelines: &[TimelineSpec],
) -> VResult {
    use ValidationCode::*;
    let condition_index = u8_index(index);
    let site = |node: usize| ErrorSite::Condition {
        condition: condition_index,
        node: u8_index(node),
    };
    if condition.nodes.is_empty() {
        return err(EmptyCondition, site(0));
    }
    // Simulate the evaluation stack, tracking the depth of each subtree.
    let mut depths: Vec<u8, MAX_CONDITION_TERMS> = Vec::new();
    for (n, node) in condition.nodes.iter().enumerate() {
        let depth = match *node {
            CondNode::Term { operand, .. } => {
                if let Operand::Timeline(t) = operand {
                    match timelines.get(usize::from(t)) {
                        None => return err(DanglingTimeline, site(n)),
                        Some(tl) if tl.state_key.is_none() => return err(TermNotMeasured, site(n)),
                        Some(_) => {}
                    }
                }
                1
            }
            CondNode::Not => match depths.pop() {
                Some(d) => d.saturating_add(1),
                None => return err(MalformedCondition, site(n)),
            },
            CondNode::And | CondNode::Or => match (depths.pop(), depths.pop()) {
                (Some(a), Some(b)) => a.max(b).saturating_add(1),
                _ => return err(MalformedCondition, site(n)),
            },
        };
        if usize::from(depth) > MAX_CONDITION_DEPTH {
            return err(ConditionTooDeep, site(n));
        }
        if depths.push(depth).is_err() {
            return err(MalformedCondition, site(n));
        }
    }
    if depths.len() != 1 {
        return err(
            MalformedCondition,
            site(condition.nodes.len().saturating_sub(1)),
        );
    }
    Ok(())
}

/// What a task is checked against.
pub struct TaskContext<'a> {
    pub timelines: &'a [TimelineSpec],
    pub condition_count: usize,
    /// `(id, role)` of every task of the network, in order.
    pub ids: &'a [(u16, TaskRole)],
}

fn check_time(t: u64) -> bool {
    t <= MAX_MISSION_TIME_US
}

fn check_offset(o: i64) -> bool {
    (-MAX_OFFSET_US..=MAX_OFFSET_US).contains(&o)
}

fn check_magnitude(v: i64) -> bool {
    (-MAX_MAGNITUDE..=MAX_MAGNITUDE).contains(&v)
}

/// Checks task `index` (its id uniqueness is checked when `ids` is built).
pub fn validate_task(index: usize, task: &TaskSpec, ctx: &TaskContext<'_>) -> VResult {
    use ValidationCode::*;
    let task_index = u16_index(index);
    let site = |field| ErrorSite::Task {
        task: task_index,
        field,
    };
    if task.id >= FIRST_INSTANCE_ID {
        return err(TaskIdReserved, site(TaskField::Id));
    }
    if task.duration_us == 0
        || task.min_duration_us == 0
        || task.min_duration_us > task.duration_us
        || task.duration_us > MAX_DURATION_US
    {
        return err(BadDuration, site(TaskField::Duration));
    }
    if !(check_time(task.earliest_start.0)
        && (check_time(task.latest_start.0) || task.latest_start.0 == u64::MAX)
        && (check_time(task.latest_end.0) || task.latest_end.0 == u64::MAX))
    {
        return err(TimeOutOfRange, site(TaskField::Window));
    }
    if task.earliest_start > task.latest_start {
        return err(BadTimeWindow, site(TaskField::Window));
    }
    if task.role == TaskRole::Requested
        && task.earliest_start.0.saturating_add(task.min_duration_us) > task.latest_end.0
    {
        return err(WindowTooShort, site(TaskField::Window));
    }
    for (c, constraint) in task.constraints.iter().enumerate() {
        let s = site(TaskField::Constraint(u8_index(c)));
        let Some(timeline) = ctx.timelines.get(usize::from(constraint.timeline)) else {
            return err(DanglingTimeline, s);
        };
        if !check_offset(constraint.start_offset_us) || !check_offset(constraint.end_offset_us) {
            return err(BadOffset, s);
        }
        if constraint.when == ConstraintWhen::Maintain
            && i128::from(task.min_duration_us) + i128::from(constraint.end_offset_us)
                <= i128::from(constraint.start_offset_us)
        {
            return err(BadOffset, s);
        }
        match (timeline.kind, constraint.require) {
            (TimelineKind::State { value_count, .. }, Requirement::OneOf { mask }) => {
                if mask == 0 {
                    return err(EmptyRequirement, s);
                }
                let allowed = if value_count >= 32 {
                    u32::MAX
                } else {
                    (1u32 << value_count) - 1
                };
                if mask & !allowed != 0 {
                    return err(ValueOutOfRange, s);
                }
            }
            (
                TimelineKind::Cumulative { .. } | TimelineKind::Claimable,
                Requirement::Range { min, max },
            ) => {
                if min > max {
                    return err(EmptyRequirement, s);
                }
                if !check_magnitude(min) || !check_magnitude(max) {
                    return err(ValueOutOfRange, s);
                }
            }
            _ => return err(TypeMismatch, s),
        }
    }
    for (i, impact) in task.impacts.iter().enumerate() {
        let s = site(TaskField::Impact(u8_index(i)));
        let Some(timeline) = ctx.timelines.get(usize::from(impact.timeline)) else {
            return err(DanglingTimeline, s);
        };
        if !check_offset(impact.start_offset_us) || !check_offset(impact.end_offset_us) {
            return err(BadOffset, s);
        }
        if impact.when == ImpactWhen::Maintain
            && i128::from(task.min_duration_us) + i128::from(impact.end_offset_us)
                <= i128::from(impact.start_offset_us)
        {
            return err(BadOffset, s);
        }
        match (timeline.kind, impact.effect) {
            (_, Effect::Assign(_)) if impact.when == ImpactWhen::Maintain => {
                return err(MaintainAssign, s)
            }
            (TimelineKind::State { value_count, .. }, Effect::Assign(v)) => {
                if v < 0 || v >= i64::from(value_count) {
                    return err(ValueOutOfRange, s);
                }
            }
            (TimelineKind::Claimable, Effect::Claim) => {
                if impact.when != ImpactWhen::Maintain {
                    return err(ClaimNotMaintain, s);
                }
            }
            (
                TimelineKind::Cumulative { .. },
                Effect::Assign(v) | Effect::Add(v) | Effect::Rate(v),
            ) => {
                if !check_magnitude(v) {
                    return err(ValueOutOfRange, s);
                }
            }
            _ => return err(TypeMismatch, s),
        }
    }
    let control = &task.control;
    for condition in [
        control.start_condition,
        control.maintain_condition,
        control.skip_condition,
    ]
    .into_iter()
    .flatten()
    {
        if usize::from(condition) >= ctx.condition_count {
            return err(DanglingCondition, site(TaskField::Control));
        }
    }
    if control.pre_wait_timeout_us > MAX_DURATION_US
        || control.response_timeout_us > MAX_DURATION_US
        || (task.command.is_some() && control.response_timeout_us == 0)
    {
        return err(BadTimeout, site(TaskField::Control));
    }
    validate_responses(
        control.max_retries.as_ref(),
        control.max_repairs.as_ref(),
        control.backoff.as_ref(),
        task.command.is_some(),
        |f| site(TaskField::Responses(f)),
    )?;
    let is_template = |id: u16| {
        ctx.ids
            .iter()
            .any(|&(i, r)| i == id && r == TaskRole::Template)
    };
    for (c, contingency) in task.contingencies.iter().enumerate() {
        let s = site(TaskField::Contingency(u8_index(c)));
        if contingency.on == 0 {
            return err(BadContingency, s);
        }
        if let ContingencyAction::AddTemplate(id) = contingency.action {
            if !is_template(id) {
                return err(DanglingTemplate, s);
            }
        }
    }
    for (p, &id) in task.permissions.may_add.iter().enumerate() {
        if !is_template(id) {
            return err(DanglingTemplate, site(TaskField::Permission(u8_index(p))));
        }
    }
    Ok(())
}

/// Checks temporal constraint `index`.
pub fn validate_temporal(
    index: usize,
    tc: &TemporalConstraint,
    ids: &[(u16, TaskRole)],
) -> VResult {
    use ValidationCode::*;
    let site = ErrorSite::Temporal(u8_index(index));
    let requested = |id: u16| {
        ids.iter()
            .any(|&(i, r)| i == id && r == TaskRole::Requested)
    };
    if !requested(tc.from_task) || !requested(tc.to_task) || tc.from_task == tc.to_task {
        return err(DanglingTemporalTask, site);
    }
    if tc.min_us > tc.max_us || !check_offset(tc.min_us) || !check_offset(tc.max_us) {
        return err(BadTemporalBounds, site);
    }
    Ok(())
}

fn push_id(ids: &mut Vec<(u16, TaskRole), MAX_TASKS>, index: usize, task: &TaskSpec) -> VResult {
    let site = ErrorSite::Task {
        task: u16_index(index),
        field: TaskField::Id,
    };
    if ids.iter().any(|&(id, _)| id == task.id) {
        return err(ValidationCode::DuplicateTaskId, site);
    }
    ids.push((task.id, task.role))
        .map_err(|_| ValidationError::new(ValidationCode::TooManyTasks, ErrorSite::Network))
}

/// Validates an in-memory network (the same element checks as [`validate_uplink`]).
pub fn validate_spec(spec: &NetworkSpec) -> VResult {
    validate_header(&spec.header)?;
    for (i, t) in spec.timelines.iter().enumerate() {
        validate_timeline(i, t, spec.timelines.get(..i).unwrap_or(&[]))?;
    }
    for (i, c) in spec.conditions.iter().enumerate() {
        validate_condition(i, c, &spec.timelines)?;
    }
    let mut ids: Vec<(u16, TaskRole), MAX_TASKS> = Vec::new();
    for (i, t) in spec.tasks.iter().enumerate() {
        push_id(&mut ids, i, t)?;
    }
    let ctx = TaskContext {
        timelines: &spec.timelines,
        condition_count: spec.conditions.len(),
        ids: &ids,
    };
    for (i, t) in spec.tasks.iter().enumerate() {
        validate_task(i, t, &ctx)?;
    }
    for (i, tc) in spec.temporal.iter().enumerate() {
        validate_temporal(i, tc, &ids)?;
    }
    Ok(())
}

/// Reads elements off an uplink, one at a time.
struct Reader<'a> {
    rest: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take<T: DeserializeOwned>(&mut self, site: ErrorSite) -> Result<T, ValidationError> {
        match postcard::take_from_bytes::<T>(self.rest) {
            Ok((value, rest)) => {
                self.rest = rest;
                Ok(value)
            }
            Err(_) => Err(ValidationError::new(ValidationCode::Decode, site)),
        }
    }

    /// A `u64` as postcard writes it (a varint of at most 10 bytes, the last at most 1), read
    /// here rather than through `take` (a deserializer built and finished for every number):
    /// the same numbers, and `Decode` where postcard fails (a short or over-long varint).
    ///
    /// A one-byte varint is read without a loop; in a longer one the seven-bit groups are
    /// gathered four at a time into a 32-bit word, which is shifted into place once (a 64-bit
    /// shift by a variable amount takes about a dozen instructions on the 32-bit target): a
    /// checkpoint's network is hundreds of varints.
    fn u64(&mut self, site: ErrorSite) -> Result<u64, ValidationError> {
        // One byte (lengths, counts, small numbers): no loop.
        match self.rest.split_first() {
            Some((&byte, rest)) if byte & 0x80 == 0 => {
                self.rest = rest;
                Ok(u64::from(byte))
            }
            _ => self.u64_long(site),
        }
    }

    /// [`Reader::u64`] of a varint of more than one byte (or none). Bytes 1 to 3 are taken
    /// one by one with constant shifts into the low 28 bits (the times and durations of a
    /// network are mostly five bytes long), the rest a group of four at a time.
    #[inline(never)]
    fn u64_long(&mut self, site: ErrorSite) -> Result<u64, ValidationError> {
        const MAX_BYTES: usize = 10;
        let error = ValidationError::new(ValidationCode::Decode, site);
        let rest = self.rest;
        let byte = |i: usize| rest.get(i).copied().ok_or(error);
        let done = |reader: &mut Self, used: usize, value: u64| {
            reader.rest = rest.get(used..).unwrap_or(&[]);
            Ok(value)
        };
        // The first byte has its continuation bit set (or is absent).
        let b = byte(0)?;
        let mut low = u32::from(b & 0x7F);
        if b & 0x80 == 0 {
            return done(self, 1, u64::from(low));
        }
        let b = byte(1)?;
        low |= u32::from(b & 0x7F) << 7;
        if b & 0x80 == 0 {
            return done(self, 2, u64::from(low));
        }
        let b = byte(2)?;
        low |= u32::from(b & 0x7F) << 14;
        if b & 0x80 == 0 {
            return done(self, 3, u64::from(low));
        }
        let b = byte(3)?;
        low |= u32::from(b & 0x7F) << 21;
        if b & 0x80 == 0 {
            return done(self, 4, u64::from(low));
        }
        // Bytes 4 to 9: groups of four from bit 28.
        let mut value = u64::from(low);
        let mut i = 4usize;
        for group in 1..3u32 {
            let mut word = 0u32;
            for k in 0..4u32 {
                if i == MAX_BYTES {
                    return Err(error);
                }
                let b = byte(i)?;
                word |= u32::from(b & 0x7F) << (7 * k);
                i += 1;
                if b & 0x80 == 0 {
                    if i == MAX_BYTES && b > 0x01 {
                        return Err(error);
                    }
                    return done(self, i, value | (u64::from(word) << (28 * group)));
                }
            }
            value |= u64::from(word) << (28 * group);
        }
        Err(error)
    }

    /// A mission time (a `u64` newtype: postcard writes the number alone).
    fn time(&mut self, site: ErrorSite) -> Result<MissionTimeUs, ValidationError> {
        self.u64(site).map(MissionTimeUs)
    }

    /// The length postcard puts before a list or a string (a varint). Read as a `u64` on
    /// every platform, so a length says the same on the 32-bit target as on the host.
    fn length(&mut self, site: ErrorSite) -> Result<usize, ValidationError> {
        let n = self.u64(site)?;
        Ok(usize::try_from(n).unwrap_or(usize::MAX))
    }

    /// A top-level element count (`u16`), at most `max`. Over it: `too_many` at the site of
    /// the first element that does not fit.
    /// Clears `list` and reads a count (at most the list's capacity, else `too_many`) and that
    /// many elements into it with `item` (given the element's index).
    fn refill<T, const N: usize>(
        &mut self,
        list: &mut Vec<T, N>,
        too_many: ValidationCode,
        mut item: impl FnMut(&mut Self, usize) -> Result<T, ValidationError>,
    ) -> VResult {
        list.clear();
        for i in 0..self.count(N, too_many, ErrorSite::Network)? {
            let element = item(self, i)?;
            list.push(element)
                .map_err(|_| ValidationError::new(too_many, ErrorSite::Network))?;
        }
        Ok(())
    }

    fn count(
        &mut self,
        max: usize,
        too_many: ValidationCode,
        first_over: ErrorSite,
    ) -> Result<usize, ValidationError> {
        let n: u16 = self.take(ErrorSite::Network)?;
        let n = usize::from(n);
        if n > max {
            return Err(ValidationError::new(too_many, first_over));
        }
        Ok(n)
    }

    /// A list nested in an element, of at most `N` items; item `i` is at `site(i)`. A longer
    /// list is refused with `too_many` at the site of the first item that does not fit,
    /// before any item is decoded.
    fn list<T: DeserializeOwned, const N: usize>(
        &mut self,
        too_many: ValidationCode,
        site: impl Fn(usize) -> ErrorSite,
    ) -> Result<Vec<T, N>, ValidationError> {
        let n = self.length(site(0))?;
        if n > N {
            return Err(ValidationError::new(too_many, site(N)));
        }
        let mut items = Vec::new();
        for i in 0..n {
            let item = self.take(site(i))?;
            items
                .push(item)
                .map_err(|_| ValidationError::new(too_many, site(i)))?;
        }
        Ok(items)
    }

    /// [`Reader::list`] into `items` in place (cleared first): the items are not built in a
    /// temporary list that is then moved, twice, into the element that holds it.
    fn list_into<T: DeserializeOwned, const N: usize>(
        &mut self,
        items: &mut Vec<T, N>,
        too_many: ValidationCode,
        site: impl Fn(usize) -> ErrorSite,
    ) -> Result<(), ValidationError> {
        items.clear();
        let n = self.length(site(0))?;
        if n > N {
            return Err(ValidationError::new(too_many, site(N)));
        }
        for i in 0..n {
            let item = self.take(site(i))?;
            items
                .push(item)
                .map_err(|_| ValidationError::new(too_many, site(i)))?;
        }
        Ok(())
    }

    /// A name: over [`MAX_NAME_LEN`] bytes is [`ValidationCode::NameTooLong`].
    /// Read here as postcard reads a string (length, then UTF-8 bytes) but straight into the
    /// [`Name`], without postcard's string visitor and the moves of its result.
    fn name(&mut self, site: ErrorSite) -> Result<Name, ValidationError> {
        let len = self.length(site)?;
        if len > MAX_NAME_LEN {
            return Err(ValidationError::new(ValidationCode::NameTooLong, site));
        }
        let decode_error = ValidationError::new(ValidationCode::Decode, site);
        let (bytes, rest) = self.rest.split_at_checked(len).ok_or(decode_error)?;
        let text = core::str::from_utf8(bytes).map_err(|_| decode_error)?;
        let mut name = Name::new();
        name.push_str(text).map_err(|_| decode_error)?;
        self.rest = rest;
        Ok(name)
    }

    /// An `Option` (postcard: a tag byte 0 or 1, then the value) whose value `read` decodes.
    fn option<T>(
        &mut self,
        site: ErrorSite,
        read: impl FnOnce(&mut Self) -> Result<T, ValidationError>,
    ) -> Result<Option<T>, ValidationError> {
        match self.take::<u8>(site)? {
            0 => Ok(None),
            1 => read(self).map(Some),
            _ => Err(ValidationError::new(ValidationCode::Decode, site)),
        }
    }

    fn command(&mut self, site: ErrorSite) -> Result<CommandSpec, ValidationError> {
        let opcode = self.take(site)?;
        let args = self.list(ValidationCode::TooManyCommandArgs, |_| site)?;
        Ok(CommandSpec { opcode, args })
    }

    /// Timeline `index`, pushed onto `timelines` as it is read (not returned and moved).
    fn timeline_into<const N: usize>(
        &mut self,
        index: usize,
        timelines: &mut Vec<TimelineSpec, N>,
    ) -> Result<(), ValidationError> {
        let site = ErrorSite::Timeline(u8_index(index));
        let name = self.name(site)?;
        let kind = self.take(site)?;
        let state_key = self.take(site)?;
        let after_reset = self.take(ErrorSite::TimelineAfterReset(u8_index(index)))?;
        let stale_after_us = self.take(ErrorSite::TimelineStaleAfter(u8_index(index)))?;
        timelines
            .push(TimelineSpec {
                name,
                kind,
                state_key,
                after_reset,
                stale_after_us,
            })
            .map_err(|_| ValidationError::new(ValidationCode::TooManyTimelines, site))
    }

    /// Timeline `index` as a value ([`Reader::timeline_into`] into a list of one).
    fn timeline(&mut self, index: usize) -> Result<TimelineSpec, ValidationError> {
        let mut one: Vec<TimelineSpec, 1> = Vec::new();
        self.timeline_into(index, &mut one)?;
        one.pop().ok_or(ValidationError::new(
            ValidationCode::Decode,
            ErrorSite::Timeline(u8_index(index)),
        ))
    }

    fn condition(&mut self, index: usize) -> Result<ConditionSpec, ValidationError> {
        let condition = u8_index(index);
        let nodes = self.list(ValidationCode::TooManyConditionTerms, |node| {
            ErrorSite::Condition {
                condition,
                node: u8_index(node),
            }
        })?;
        Ok(ConditionSpec { nodes })
    }

    /// Task `index`, decoded into `tasks` (pushed at its end): the fields before the first
    /// list are read into the pushed element, and the lists and the control part that follow
    /// are decoded straight into it, so the element is copied once (by the push) instead of
    /// being built in temporaries and moved through each reader's result. On error `tasks`
    /// may hold a partly decoded last element (the caller discards the network).
    fn task_into<const N: usize>(
        &mut self,
        index: usize,
        tasks: &mut Vec<TaskSpec, N>,
    ) -> Result<(), ValidationError> {
        use ValidationCode::*;
        let task = u16_index(index);
        let site = |field| ErrorSite::Task { task, field };
        let id = self.take(site(TaskField::Id))?;
        let name = self.name(site(TaskField::Name))?;
        let priority = self.take(site(TaskField::Whole))?;
        let role = self.take(site(TaskField::Whole))?;
        let command = self.option(site(TaskField::Command), |r| {
            r.command(site(TaskField::Command))
        })?;
        let duration_us = self.u64(site(TaskField::Duration))?;
        let min_duration_us = self.u64(site(TaskField::Duration))?;
        let earliest_start = self.time(site(TaskField::Window))?;
        let latest_start = self.time(site(TaskField::Window))?;
        let latest_end = self.time(site(TaskField::Window))?;
        tasks
            .push(TaskSpec {
                id,
                name,
                priority,
                role,
                command,
                duration_us,
                min_duration_us,
                earliest_start,
                latest_start,
                latest_end,
                constraints: Vec::new(),
                impacts: Vec::new(),
                control: ControlSpec::NONE,
                contingencies: Vec::new(),
                permissions: Permissions {
                    may_move: false,
                    may_delete: false,
                    may_add: Vec::new(),
                },
            })
            .map_err(|_| ValidationError::new(TooManyTasks, site(TaskField::Whole)))?;
        let Some(t) = tasks.last_mut() else {
            return Err(ValidationError::new(TooManyTasks, site(TaskField::Whole)));
        };
        self.list_into(&mut t.constraints, TooManyConstraints, |k| {
            site(TaskField::Constraint(u8_index(k)))
        })?;
        self.list_into(&mut t.impacts, TooManyImpacts, |k| {
            site(TaskField::Impact(u8_index(k)))
        })?;
        self.control_into(|field| ErrorSite::Task { task, field }, &mut t.control)?;
        self.list_into(&mut t.contingencies, TooManyContingencies, |k| {
            site(TaskField::Contingency(u8_index(k)))
        })?;
        t.permissions.may_move = self.take(site(TaskField::Whole))?;
        t.permissions.may_delete = self.take(site(TaskField::Whole))?;
        self.list_into(&mut t.permissions.may_add, TooManyPermissions, |k| {
            site(TaskField::Permission(u8_index(k)))
        })?;
        Ok(())
    }

    /// Task `index` as a value ([`Reader::task_into`] into a list of one).
    fn task(&mut self, index: usize) -> Result<TaskSpec, ValidationError> {
        let mut one: Vec<TaskSpec, 1> = Vec::new();
        self.task_into(index, &mut one)?;
        one.pop().ok_or(ValidationError::new(
            ValidationCode::Decode,
            ErrorSite::Task {
                task: u16_index(index),
                field: TaskField::Whole,
            },
        ))
    }

    /// [`Reader::control`] into `c` in place, field by field.
    fn control_into(
        &mut self,
        site: impl Fn(TaskField) -> ErrorSite,
        c: &mut ControlSpec,
    ) -> Result<(), ValidationError> {
        let control = site(TaskField::Control);
        let responses = |f| site(TaskField::Responses(f));
        c.start_condition = self.take(control)?;
        c.maintain_condition = self.take(control)?;
        c.skip_condition = self.take(control)?;
        c.pre_wait_timeout_us = self.u64(control)?;
        c.response_timeout_us = self.u64(control)?;
        c.on_failure_command = self.option(control, |r| r.command(control))?;
        c.max_retries = self.take(responses(ResponseField::MaxRetries))?;
        c.max_repairs = self.take(responses(ResponseField::MaxRepairs))?;
        c.backoff = self.take(responses(ResponseField::Backoff))?;
        Ok(())
    }
}

/// Decodes one timeline (element `index` of the uplink) off the front of `bytes`; returns it
/// and the bytes after it. The uplink decoder's own element reader: a name over
/// [`MAX_NAME_LEN`] is [`ValidationCode::NameTooLong`], anything else that does not decode
/// [`ValidationCode::Decode`], at the timeline's site. Decodes exactly what postcard decodes
/// into a [`TimelineSpec`] (the fuzz targets check that).
pub fn take_timeline(bytes: &[u8], index: usize) -> Result<(TimelineSpec, &[u8]), ValidationError> {
    let mut r = Reader { rest: bytes };
    let t = r.timeline(index)?;
    Ok((t, r.rest))
}

/// Decodes one condition (element `index`); more than [`MAX_CONDITION_TERMS`] nodes is
/// [`ValidationCode::TooManyConditionTerms`] at the first node that does not fit.
pub fn take_condition(
    bytes: &[u8],
    index: usize,
) -> Result<(ConditionSpec, &[u8]), ValidationError> {
    let mut r = Reader { rest: bytes };
    let c = r.condition(index)?;
    Ok((c, r.rest))
}

/// Decodes one task (element `index`). A list over its capacity is refused with its own code
/// (`TooManyConstraints`, `TooManyImpacts`, `TooManyContingencies`, `TooManyPermissions`,
/// `TooManyCommandArgs`) at the site of the first item that does not fit, a name over
/// [`MAX_NAME_LEN`] with `NameTooLong`; any other defect is `Decode` at the field it is in.
pub fn take_task(bytes: &[u8], index: usize) -> Result<(TaskSpec, &[u8]), ValidationError> {
    let mut r = Reader { rest: bytes };
    let t = r.task(index)?;
    Ok((t, r.rest))
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
    for i in 0..temporal_count {
        let tc: TemporalConstraint = r.take(ErrorSite::Temporal(u8_index(i)))?;
        validate_temporal(i, &tc, &ids)?;
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
    if !r.rest.is_empty() {
        return err(TrailingBytes, ErrorSite::Network);
    }
    validate_spec(spec)
}

/// The uplink did not fit in the output buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferTooSmall;

struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Writer<'_> {
    fn put<T: Serialize>(&mut self, value: &T) -> Result<(), BufferTooSmall> {
        let rest = self.buf.get_mut(self.len..).ok_or(BufferTooSmall)?;
        let used = postcard::to_slice(value, rest)
            .map_err(|_| BufferTooSmall)?
            .len();
        self.len += used;
        Ok(())
    }

    fn list<T: Serialize>(&mut self, items: &[T]) -> Result<(), BufferTooSmall> {
        let n = u16::try_from(items.len()).map_err(|_| BufferTooSmall)?;
        self.put(&n)?;
        items.iter().try_for_each(|i| self.put(i))
    }
}

/// Encodes `spec` into `buf` in the uplink format; returns the length used.
pub fn encode_spec(spec: &NetworkSpec, buf: &mut [u8]) -> Result<usize, BufferTooSmall> {
    let mut w = Writer { buf, len: 0 };
    w.put(&spec.header)?;
    w.list(&spec.timelines)?;
    w.list(&spec.conditions)?;
    w.list(&spec.tasks)?;
    w.list(&spec.temporal)?;
    Ok(w.len)
}

impl TaskNetwork {
    /// Validates a binary uplink without storing it.
    pub fn validate_uplink(bytes: &[u8]) -> VResult {
        validate_uplink(bytes)
    }

    /// Encodes this network in the uplink format; returns the length used.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, BufferTooSmall> {
        encode_spec(&self.spec, buf)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    /// What `Reader::u64` reads off `bytes`: the value and the bytes left, or None.
    fn ours(bytes: &[u8]) -> Option<(u64, usize)> {
        let mut r = Reader { rest: bytes };
        r.u64(ErrorSite::Network).ok().map(|v| (v, r.rest.len()))
    }

    /// What postcard reads off `bytes` as a `u64`.
    fn postcards(bytes: &[u8]) -> Option<(u64, usize)> {
        postcard::take_from_bytes::<u64>(bytes)
            .ok()
            .map(|(v, rest)| (v, rest.len()))
    }

    #[test]
    fn the_varint_reader_reads_what_postcard_reads() {
        let mut cases: std::vec::Vec<std::vec::Vec<u8>> = std::vec::Vec::new();
        // Every power of two and its neighbours, each followed by a byte that must be left.
        for shift in 0..64 {
            for v in [
                1u64 << shift,
                (1u64 << shift) - 1,
                (1u64 << shift) + 1,
                u64::MAX,
            ] {
                let mut buf = [0u8; 16];
                let used = postcard::to_slice(&v, &mut buf).map_or(0, |b| b.len());
                assert!(used > 0, "{v} encodes");
                let mut bytes = buf.get(..used).unwrap_or(&[]).to_vec();
                bytes.push(0x55);
                cases.push(bytes.clone());
                // Every truncation of it.
                for cut in 0..used {
                    cases.push(bytes.get(..cut).unwrap_or(&[]).to_vec());
                }
            }
        }
        // Ten bytes whose last carries more than the one bit left, and eleven-byte varints.
        for last in 0..=0xFFu8 {
            let mut bytes = [0xFFu8; 9].to_vec();
            bytes.push(last);
            cases.push(bytes.clone());
            bytes.push(0x00);
            cases.push(bytes);
        }
        // Over-long encodings of small numbers (a zero continuation), which postcard takes.
        cases.push(std::vec![0x80, 0x00]);
        cases.push(std::vec![0x81, 0x80, 0x00, 0x07]);
        for bytes in &cases {
            assert_eq!(ours(bytes), postcards(bytes), "{bytes:02x?}");
        }
        assert_eq!(ours(&[0xFF; 9]), None);
        assert_eq!(ours(&[0x80, 0x00]), Some((0, 0)));
        assert_eq!(ours(&[0xFF, 0x01, 0x55]), Some((255, 1)));
    }
}
