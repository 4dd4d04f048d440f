//! Binary task-network uplink: format, validation and decoding (seed 000 IV.A.3: "performs
//! input validation before storing the information").
//!
//! Format (postcard throughout, [`crate::UPLINK_FORMAT_VERSION`]):
//! `NetworkHeader, u16 n, n x TimelineSpec, u16 n, n x ConditionSpec, u16 n, n x TaskSpec,
//! u16 n, n x TemporalConstraint`, and nothing after.
//!
//! [`validate_uplink`] walks the bytes one element at a time (no temporary larger than one
//! [`TaskSpec`]), so a rejected uplink never touches the running network; only then does
//! [`decode_into`] rebuild the network in place. Every rejection is a [`ValidationError`]: a
//! [`ValidationCode`] (its `u16` goes to the host in `UplinkNak.reason`) and an [`ErrorSite`]
//! naming the element, which the ground compiler maps back to `file:line:column`.
use heapless::Vec;
use serde::{de::DeserializeOwned, Serialize};

use crate::capacity::*;
use crate::model::*;
use crate::telemetry::FailureKind;

/// Why an uplink was refused. `code as u16` is what reaches the host.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum ValidationCode {
    /// Bytes do not decode (bad varint, enum tag, string, or a nested list over capacity).
    Decode = 1,
    /// Bytes remain after the last element.
    TrailingBytes = 2,
    /// `format_version` is not [`UPLINK_FORMAT_VERSION`].
    FormatVersion = 3,
    TooManyTimelines = 10,
    TooManyTasks = 11,
    TooManyConstraints = 12,
    TooManyImpacts = 13,
    TooManyConditions = 14,
    TooManyConditionTerms = 15,
    TooManyContingencies = 16,
    TooManyPermissions = 17,
    TooManyTemporalConstraints = 18,
    TooManyStateValues = 19,
    NameTooLong = 20,
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
        task: u8,
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
    let task_index = u8_index(index);
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
        task: u8_index(index),
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

    fn count(&mut self, max: usize, too_many: ValidationCode) -> Result<usize, ValidationError> {
        let n: u16 = self.take(ErrorSite::Network)?;
        let n = usize::from(n);
        if n > max {
            return Err(ValidationError::new(too_many, ErrorSite::Network));
        }
        Ok(n)
    }
}

/// Validates a binary uplink without storing anything. Stack use stays around one [`TaskSpec`]
/// plus the timeline table.
pub fn validate_uplink(bytes: &[u8]) -> VResult {
    use ValidationCode::*;
    let mut r = Reader { rest: bytes };
    let header: NetworkHeader = r.take(ErrorSite::Network)?;
    validate_header(&header)?;
    let mut timelines: Vec<TimelineSpec, MAX_TIMELINES> = Vec::new();
    for i in 0..r.count(MAX_TIMELINES, TooManyTimelines)? {
        let t: TimelineSpec = r.take(ErrorSite::Timeline(u8_index(i)))?;
        validate_timeline(i, &t, &timelines)?;
        timelines
            .push(t)
            .map_err(|_| ValidationError::new(TooManyTimelines, ErrorSite::Network))?;
    }
    let condition_count = r.count(MAX_CONDITIONS, TooManyConditions)?;
    for i in 0..condition_count {
        let site = ErrorSite::Condition {
            condition: u8_index(i),
            node: 0,
        };
        let c: ConditionSpec = r.take(site)?;
        validate_condition(i, &c, &timelines)?;
    }
    let task_count = r.count(MAX_TASKS, TooManyTasks)?;
    let tasks_start = r.rest;
    let mut ids: Vec<(u16, TaskRole), MAX_TASKS> = Vec::new();
    for i in 0..task_count {
        let site = ErrorSite::Task {
            task: u8_index(i),
            field: TaskField::Whole,
        };
        let t: TaskSpec = r.take(site)?;
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
        let site = ErrorSite::Task {
            task: u8_index(i),
            field: TaskField::Whole,
        };
        let t: TaskSpec = r.take(site)?;
        validate_task(i, &t, &ctx)?;
    }
    r.rest = after_tasks;
    for i in 0..r.count(MAX_TEMPORAL_CONSTRAINTS, TooManyTemporalConstraints)? {
        let tc: TemporalConstraint = r.take(ErrorSite::Temporal(u8_index(i)))?;
        validate_temporal(i, &tc, &ids)?;
    }
    if !r.rest.is_empty() {
        return err(TrailingBytes, ErrorSite::Network);
    }
    Ok(())
}

fn decode_list<T: DeserializeOwned, const N: usize>(
    r: &mut Reader<'_>,
    list: &mut Vec<T, N>,
    too_many: ValidationCode,
) -> VResult {
    list.clear();
    for _ in 0..r.count(N, too_many)? {
        let item: T = r.take(ErrorSite::Network)?;
        list.push(item)
            .map_err(|_| ValidationError::new(too_many, ErrorSite::Network))?;
    }
    Ok(())
}

/// Validates `bytes` and, only if they pass, rebuilds `network` from them in place. On error
/// `network` is unchanged.
pub fn decode_into(network: &mut TaskNetwork, bytes: &[u8]) -> VResult {
    validate_uplink(bytes)?;
    let mut r = Reader { rest: bytes };
    let spec = &mut network.spec;
    spec.header = r.take(ErrorSite::Network)?;
    decode_list(
        &mut r,
        &mut spec.timelines,
        ValidationCode::TooManyTimelines,
    )?;
    decode_list(
        &mut r,
        &mut spec.conditions,
        ValidationCode::TooManyConditions,
    )?;
    decode_list(&mut r, &mut spec.tasks, ValidationCode::TooManyTasks)?;
    decode_list(
        &mut r,
        &mut spec.temporal,
        ValidationCode::TooManyTemporalConstraints,
    )?;
    Ok(())
}

/// Decodes `bytes` into `network` and then checks what it decoded with [`validate_spec`]: the
/// checks [`validate_uplink`] makes on the same values, so it accepts exactly what
/// [`decode_into`] accepts, but decodes the network once where `decode_into` decodes its tasks
/// three times (twice to validate the bytes, once to store them). The checkpoint restore's
/// path. On error `network` holds whatever was decoded: for callers that discard it.
pub fn decode_then_validate(network: &mut TaskNetwork, bytes: &[u8]) -> VResult {
    let mut r = Reader { rest: bytes };
    let spec = &mut network.spec;
    spec.header = r.take(ErrorSite::Network)?;
    decode_list(
        &mut r,
        &mut spec.timelines,
        ValidationCode::TooManyTimelines,
    )?;
    decode_list(
        &mut r,
        &mut spec.conditions,
        ValidationCode::TooManyConditions,
    )?;
    decode_list(&mut r, &mut spec.tasks, ValidationCode::TooManyTasks)?;
    decode_list(
        &mut r,
        &mut spec.temporal,
        ValidationCode::TooManyTemporalConstraints,
    )?;
    if !r.rest.is_empty() {
        return err(ValidationCode::TrailingBytes, ErrorSite::Network);
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
