//! Validation of decoded elements: the header, each timeline, condition, task and temporal
//! constraint, and a whole network spec.

use super::*;
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
pub(super) fn validate_responses(
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
    if timeline.background_rate != 0
        && (!matches!(timeline.kind, TimelineKind::Cumulative { .. })
            || !check_magnitude(timeline.background_rate))
    {
        return err(BadBackgroundRate, site);
    }
    if timeline.external && matches!(timeline.kind, TimelineKind::Claimable) {
        return err(ExternalTimeline, site);
    }
    if !timeline.thresholds.is_empty() {
        let s = ErrorSite::TimelineThresholds(u8_index(index));
        let TimelineKind::State { value_count, .. } = timeline.kind else {
            return err(BadThresholds, s);
        };
        let increasing = timeline
            .thresholds
            .iter()
            .zip(timeline.thresholds.iter().skip(1))
            .all(|(a, b)| a < b);
        if timeline.state_key.is_none()
            || !increasing
            || !timeline.thresholds.iter().all(|&t| check_magnitude(t))
            || timeline.thresholds.len() + 1 != usize::from(value_count)
        {
            return err(BadThresholds, s);
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

pub(super) fn check_time(t: u64) -> bool {
    t <= MAX_MISSION_TIME_US
}

pub(super) fn check_offset(o: i64) -> bool {
    (-MAX_OFFSET_US..=MAX_OFFSET_US).contains(&o)
}

pub(super) fn check_magnitude(v: i64) -> bool {
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
        if timeline.external {
            return err(ExternalTimeline, s);
        }
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
    if let Some(command) = &task.command {
        validate_command(command, site(TaskField::Command))?;
    }
    if let Some(command) = &task.control.on_failure_command {
        validate_command(command, site(TaskField::Control))?;
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
    let role = |id: u16| ids.iter().find(|&&(i, _)| i == id).map(|&(_, r)| r);
    let (Some(from), Some(to)) = (role(tc.from_task), role(tc.to_task)) else {
        return err(DanglingTemporalTask, site);
    };
    if tc.from_task == tc.to_task {
        return err(DanglingTemporalTask, site);
    }
    if from == TaskRole::Template && to == TaskRole::Template {
        return err(TemporalTemplatePair, site);
    }
    if tc.min_us > tc.max_us || !check_offset(tc.min_us) || !check_offset(tc.max_us) {
        return err(BadTemporalBounds, site);
    }
    Ok(())
}

pub(super) fn push_id(
    ids: &mut Vec<(u16, TaskRole), MAX_TASKS>,
    index: usize,
    task: &TaskSpec,
) -> VResult {
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
    if !spec.temporal.is_empty() {
        let mut durations: Vec<TaskDurations, { 2 * MAX_TEMPORAL_CONSTRAINTS }> = Vec::new();
        for t in spec.tasks.iter() {
            note_durations(&mut durations, &spec.temporal, t);
        }
        validate_temporal_cycles(&spec.temporal, &durations)?;
    }
    let mut last_at = [MissionTimeUs::ZERO; MAX_TIMELINES];
    for (i, tv) in spec.timed.iter().enumerate() {
        validate_timed_value(i, tv, &spec.timelines, &mut last_at)?;
    }
    for (i, p) in spec.params.iter().enumerate() {
        validate_param(i, p, &spec.timelines)?;
    }
    if !spec.params.is_empty() {
        for t in spec.tasks.iter() {
            validate_param_uses(&spec.params, t, &spec.timelines)?;
        }
        for (i, p) in spec.params.iter().enumerate() {
            validate_params_found(i, p, &ids)?;
        }
    }
    Ok(())
}

/// Checks model parameter `index` on its own: its bounds hold its prior and value (within
/// [`MAX_MAGNITUDE`]), and a timeline that measures it is a measured cumulative one.
pub fn validate_param(index: usize, p: &ParamSpec, timelines: &[TimelineSpec]) -> VResult {
    use ValidationCode::*;
    let site = ErrorSite::Param(u8_index(index));
    let bounded = p.min <= p.max
        && check_magnitude(p.min)
        && check_magnitude(p.max)
        && (p.min..=p.max).contains(&p.prior)
        && (p.min..=p.max).contains(&p.value);
    if !bounded {
        return err(BadParam, site);
    }
    if let Some(tl) = p.measured_by {
        let Some(t) = timelines.get(usize::from(tl)) else {
            return err(DanglingTimeline, site);
        };
        if t.state_key.is_none() || !matches!(t.kind, TimelineKind::Cumulative { .. }) {
            return err(BadParam, site);
        }
    }
    Ok(())
}

/// Checks every use of `params` that names `task`: a duration its parameter's bounds fit, an
/// impact with a magnitude, and the number it holds is the parameter's value.
pub fn validate_param_uses(
    params: &[ParamSpec],
    task: &TaskSpec,
    timelines: &[TimelineSpec],
) -> VResult {
    for (i, p) in params.iter().enumerate() {
        let site = ErrorSite::Param(u8_index(i));
        for &u in p.uses.iter() {
            let fits = match u {
                ParamUse::Duration { task: id } if id == task.id => {
                    i128::from(p.min) >= i128::from(task.min_duration_us.max(1))
                        && i128::from(p.max) <= i128::from(MAX_DURATION_US)
                }
                ParamUse::Impact { task: id, impact } if id == task.id => task
                    .impacts
                    .get(usize::from(impact))
                    .and_then(|i| timelines.get(usize::from(i.timeline)))
                    .is_some_and(|t| matches!(t.kind, TimelineKind::Cumulative { .. })),
                _ => continue,
            };
            let holds = use_value(core::slice::from_ref(task), u) == Some(p.value);
            if !fits || !holds {
                return err(ValidationCode::BadParam, site);
            }
        }
    }
    Ok(())
}

/// Checks that every use of parameter `index` names a task of the network.
pub fn validate_params_found(index: usize, p: &ParamSpec, ids: &[(u16, TaskRole)]) -> VResult {
    let named = |id: u16| ids.iter().any(|&(i, _)| i == id);
    let all = p.uses.iter().all(|u| match *u {
        ParamUse::Duration { task } | ParamUse::Impact { task, .. } => named(task),
    });
    if !all {
        return err(ValidationCode::BadParam, ErrorSite::Param(u8_index(index)));
    }
    Ok(())
}

/// Checks timed value `index`: on an external timeline, in time, a value that fits the
/// timeline, and not earlier than the previous one on the same timeline (`last_at`: per
/// timeline, the time of the last timed value checked, updated here).
pub fn validate_timed_value(
    index: usize,
    tv: &TimedValue,
    timelines: &[TimelineSpec],
    last_at: &mut [MissionTimeUs; MAX_TIMELINES],
) -> VResult {
    use ValidationCode::*;
    let site = ErrorSite::TimedValue(u8_index(index));
    let Some(timeline) = timelines.get(usize::from(tv.timeline)) else {
        return err(DanglingTimeline, site);
    };
    if !timeline.external || !check_time(tv.at.0) {
        return err(BadTimedValue, site);
    }
    let Some(last) = last_at.get_mut(usize::from(tv.timeline)) else {
        return err(DanglingTimeline, site);
    };
    if tv.at < *last {
        return err(BadTimedValue, site);
    }
    *last = tv.at;
    let fits = match timeline.kind {
        TimelineKind::State { value_count, .. } => (0..i64::from(value_count)).contains(&tv.value),
        TimelineKind::Cumulative { min, max, .. } => (min..=max).contains(&tv.value),
        TimelineKind::Claimable => false,
    };
    if !fits {
        return err(ValueOutOfRange, site);
    }
    Ok(())
}

/// A task named by a temporal constraint: its id, duration and minimum duration (the bounds
/// of `end - start` in the simple temporal network).
pub type TaskDurations = (u16, u64, u64);

/// Adds `task`'s durations to `durations` if a constraint of `temporal` names it.
pub fn note_durations<const N: usize>(
    durations: &mut Vec<TaskDurations, N>,
    temporal: &[TemporalConstraint],
    task: &TaskSpec,
) {
    let named = temporal
        .iter()
        .any(|tc| tc.from_task == task.id || tc.to_task == task.id);
    if named && !durations.iter().any(|&(id, _, _)| id == task.id) {
        let _ = durations.push((task.id, task.duration_us, task.min_duration_us));
    }
}

/// Refuses the first temporal constraint that closes a cycle no schedule can meet
/// ([`ValidationCode::TemporalCycle`]): constraints `0..=i` and the durations of the tasks
/// they name (`durations`, from [`note_durations`]) have a negative cycle, constraints `0..i`
/// do not. Only the named tasks' start and end are nodes (at most 64), so it costs nothing
/// when the network has no temporal constraints.
pub fn validate_temporal_cycles(
    temporal: &[TemporalConstraint],
    durations: &[TaskDurations],
) -> VResult {
    for i in 0..temporal.len() {
        if !temporal_consistent(temporal.get(..=i).unwrap_or(temporal), durations) {
            return err(
                ValidationCode::TemporalCycle,
                ErrorSite::Temporal(u8_index(i)),
            );
        }
    }
    Ok(())
}

/// Whether the simple temporal network of `temporal` (`to - from` in `[min, max]`) and the
/// tasks' `end - start` in `[min_duration, duration]` has a solution: Bellman-Ford from a
/// virtual source finds no negative cycle.
fn temporal_consistent(temporal: &[TemporalConstraint], durations: &[TaskDurations]) -> bool {
    const NODES: usize = 4 * MAX_TEMPORAL_CONSTRAINTS;
    let node = |id: u16, point: TaskPoint| {
        durations
            .iter()
            .position(|&(i, _, _)| i == id)
            .map(|d| 2 * d + usize::from(point == TaskPoint::End))
    };
    let clamp = |v: u64| v.min(MAX_DURATION_US) as i64;
    let mut dist = [0i64; NODES];
    let n = (2 * durations.len()).min(NODES);
    for _ in 0..=n {
        let mut changed = false;
        let mut relax = |u: usize, v: usize, w: i64| {
            let cand = dist.get(u).copied().unwrap_or(0).saturating_add(w);
            if let Some(dv) = dist.get_mut(v) {
                if cand < *dv {
                    *dv = cand;
                    changed = true;
                }
            }
        };
        for (d, &(_, duration, min_duration)) in durations.iter().enumerate() {
            relax(2 * d, 2 * d + 1, clamp(duration));
            relax(2 * d + 1, 2 * d, clamp(min_duration).saturating_neg());
        }
        for tc in temporal {
            let (Some(u), Some(v)) = (
                node(tc.from_task, tc.from_point),
                node(tc.to_task, tc.to_point),
            ) else {
                continue;
            };
            relax(u, v, tc.max_us);
            relax(v, u, tc.min_us.saturating_neg());
        }
        if !changed {
            return true;
        }
    }
    false
}

/// Checks a command's instance arguments: each names an argument that can exist, and the
/// fixed and instance arguments together fit in one command.
fn validate_command(command: &CommandSpec, site: ErrorSite) -> VResult {
    let total = command.args.len() + command.from_instance.len();
    let named_ok = command.from_instance.iter().all(|a| match *a {
        InstanceArg::Served(k) => usize::from(k) < fsw_bridge::MAX_COMMAND_ARGS,
        InstanceArg::Instance | InstanceArg::EndS | InstanceArg::DurationS => true,
    });
    if total > fsw_bridge::MAX_COMMAND_ARGS || !named_ok {
        return err(ValidationCode::BadInstanceArg, site);
    }
    Ok(())
}
