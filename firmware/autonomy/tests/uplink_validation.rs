//! The uplink validator: each rejection has its precise code and site, and a rejected uplink
//! leaves the running plan untouched.
mod common;
use autonomy::uplink::{validate_uplink, ErrorSite, ResponseField, TaskField, ValidationCode};
use autonomy::*;
use common::*;

fn encode(spec: &NetworkSpec) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 16];
    let len = autonomy::uplink::encode_spec(spec, &mut buf).unwrap();
    buf.truncate(len);
    buf
}

fn rejected(spec: &NetworkSpec) -> (ValidationCode, ErrorSite) {
    // The in-memory and the streaming validators agree.
    let a = TaskNetwork::from_spec(spec.clone()).unwrap_err();
    let b = validate_uplink(&encode(spec)).unwrap_err();
    assert_eq!(a, b);
    (a.code, a.site)
}

fn task(i: u8, field: TaskField) -> ErrorSite {
    ErrorSite::Task {
        task: i.into(),
        field,
    }
}

#[test]
fn flyby_uplink_is_accepted() {
    assert!(validate_uplink(&encode(&flyby_spec())).is_ok());
}

#[test]
fn each_defect_has_its_code_and_site() {
    let mut s = flyby_spec();
    s.tasks[2].constraints[0].timeline = 9;
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::DanglingTimeline,
            task(2, TaskField::Constraint(0))
        )
    );

    let mut s = flyby_spec();
    s.tasks[2].impacts[0].effect = Effect::Claim; // a claim on the cumulative request timeline
    assert_eq!(
        rejected(&s),
        (ValidationCode::TypeMismatch, task(2, TaskField::Impact(0)))
    );

    let mut s = flyby_spec();
    s.tasks[0].impacts[1].effect = Effect::Assign(7); // attitude has 5 values
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::ValueOutOfRange,
            task(0, TaskField::Impact(1))
        )
    );

    let mut s = flyby_spec();
    s.tasks[2].permissions.may_add[0] = ID_FLYBY; // not a template
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::DanglingTemplate,
            task(2, TaskField::Permission(0))
        )
    );

    let mut s = flyby_spec();
    s.tasks[3].id = ID_GNC_NADIR;
    assert_eq!(
        rejected(&s),
        (ValidationCode::DuplicateTaskId, task(3, TaskField::Id))
    );

    let mut s = flyby_spec();
    s.tasks[1].latest_start = hm(10, 0);
    assert_eq!(
        rejected(&s),
        (ValidationCode::BadTimeWindow, task(1, TaskField::Window))
    );

    let mut s = flyby_spec();
    s.tasks[2].min_duration_us = s.tasks[2].duration_us + 1;
    assert_eq!(
        rejected(&s),
        (ValidationCode::BadDuration, task(2, TaskField::Duration))
    );

    let mut s = flyby_spec();
    s.tasks[2].control.start_condition = Some(0);
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::DanglingCondition,
            task(2, TaskField::Control)
        )
    );

    let mut s = flyby_spec();
    s.header.config.commit_window_us = 0;
    assert_eq!(
        rejected(&s),
        (ValidationCode::BadPlannerConfig, ErrorSite::Network)
    );

    let mut s = flyby_spec();
    s.timelines[1].state_key = Some(ATTITUDE_KEY);
    assert_eq!(
        rejected(&s),
        (ValidationCode::DuplicateStateKey, ErrorSite::Timeline(1))
    );
}

fn term() -> CondNode {
    CondNode::Term {
        operand: Operand::Timeline(TL_ATTITUDE),
        op: RelOp::Eq,
        value: i64::from(NADIR),
    }
}

#[test]
fn conditions_are_checked_for_shape_depth_and_operands() {
    let with = |nodes: &[CondNode]| {
        let mut s = flyby_spec();
        s.conditions
            .push(ConditionSpec {
                nodes: heapless::Vec::from_slice(nodes).unwrap(),
            })
            .unwrap();
        s
    };
    let site = |node| ErrorSite::Condition { condition: 0, node };
    assert!(TaskNetwork::from_spec(with(&[term(), term(), CondNode::And, CondNode::Not])).is_ok());
    assert_eq!(
        rejected(&with(&[term(), CondNode::And])),
        (ValidationCode::MalformedCondition, site(1))
    );
    assert_eq!(
        rejected(&with(&[term(), term()])),
        (ValidationCode::MalformedCondition, site(1))
    );
    assert_eq!(
        rejected(&with(&[
            term(),
            CondNode::Not,
            CondNode::Not,
            CondNode::Not,
            CondNode::Not
        ])),
        (ValidationCode::ConditionTooDeep, site(4))
    );
    let internal = CondNode::Term {
        operand: Operand::Timeline(TL_REQUEST),
        op: RelOp::Ge,
        value: 1,
    };
    assert_eq!(
        rejected(&with(&[internal])),
        (ValidationCode::TermNotMeasured, site(0))
    );
}

#[test]
fn byte_level_defects_are_refused() {
    let bytes = encode(&flyby_spec());
    let mut trailing = bytes.clone();
    trailing.push(0);
    assert_eq!(
        validate_uplink(&trailing).unwrap_err().code,
        ValidationCode::TrailingBytes
    );
    assert_eq!(
        validate_uplink(&bytes[..bytes.len() - 4]).unwrap_err().code,
        ValidationCode::Decode
    );
    let mut version = bytes.clone();
    version[0] = 9;
    assert_eq!(
        validate_uplink(&version).unwrap_err().code,
        ValidationCode::FormatVersion
    );
    // A task count over the capacity is named as such before anything is decoded.
    let mut spec = flyby_spec();
    spec.tasks.clear();
    spec.temporal.clear();
    let mut short = encode(&spec);
    short.truncate(short.len() - 4); // drop "0 tasks, 0 temporal, 0 timed values, 0 parameters"
    let mut count = [0u8; 3];
    let count = postcard::to_slice(&((MAX_TASKS + 1) as u16), &mut count).unwrap();
    short.extend_from_slice(count);
    assert_eq!(
        validate_uplink(&short).unwrap_err().code,
        ValidationCode::TooManyTasks
    );
}

#[test]
fn a_rejected_uplink_leaves_the_running_plan_untouched() {
    let mut sim = Sim::flyby();
    sim.run(hm(10, 20), &[]);
    let plan_before = sim.autonomy.plan().to_vec();
    let network_before = sim.autonomy.network().clone();
    let mut bad = flyby_spec();
    bad.tasks[2].constraints[0].timeline = 9;
    let err = sim.autonomy.load_uplink(&encode(&bad)).unwrap_err();
    assert_eq!(
        err,
        LoadError::Invalid(ValidationError::new(
            ValidationCode::DanglingTimeline,
            task(2, TaskField::Constraint(0))
        ))
    );
    assert_eq!(err_code(err), 33);
    assert_eq!(sim.autonomy.plan(), &plan_before[..]);
    assert_eq!(sim.autonomy.network(), &network_before);
    // And the flyby carries on as nominal.
    sim.run(hm(11, 30), &[]);
    assert_eq!(sim.as_executed().len(), 4);
}

fn err_code(e: LoadError) -> u16 {
    match e {
        LoadError::Invalid(v) => v.code.code(),
        LoadError::Busy | LoadError::TooLarge => 0,
    }
}

#[test]
fn a_good_uplink_loads_through_the_bytes() {
    let mut core = Box::new(Autonomy::new());
    core.load_uplink(&encode(&flyby_spec())).unwrap();
    assert_eq!(core.network(), &flyby_network());
    assert_eq!(core.plan().len(), 4, "the four requested tasks");
}

#[test]
fn state_values_of_the_wrong_type_count_as_unknown() {
    let mut core = Box::new(Autonomy::new());
    core.load_network(flyby_network()).unwrap();
    core.on_state_update(ATTITUDE_KEY, StateValue::Int(5), hm(9, 0));
    assert_eq!(core.state_type_mismatches(), 1);
    core.on_state_update(ATTITUDE_KEY, StateValue::Enum(9), hm(9, 0));
    assert_eq!(core.state_type_mismatches(), 2);
    let view = core.planner().view(core.network());
    assert_eq!(view.value_at(TL_ATTITUDE, hm(9, 1)), VALUE_UNKNOWN);
}

/// The response bounds (issue 15): each bad value is refused with its own code, at the field
/// (network-wide defaults or one task's override) that holds it.
#[test]
fn response_bounds_and_back_off_are_checked_with_their_codes() {
    let net = |f: ResponseField| ErrorSite::NetworkResponses(f);
    let own = |i: u8, f: ResponseField| task(i, TaskField::Responses(f));
    let flyby = 2; // Instrument Flyby (has a command)
    let request = 1; // Instrument Flyby Request (no command)

    // Accepted: the defaults, generous bounds, no back-off at all, a task's own override.
    let mut s = flyby_spec();
    s.header.responses.max_retries = PerCause::uniform(MAX_RESPONSE_BOUND, FailureKind::RETRYABLE);
    s.header.responses.backoff = Backoff {
        initial_us: 0,
        max_us: 0,
    };
    s.tasks[flyby].control.max_repairs = Some(PerCause::uniform(0, FailureKind::REPAIRABLE));
    assert!(validate_uplink(&encode(&s)).is_ok());
    assert!(TaskNetwork::from_spec(s).is_ok());

    // Over MAX_RESPONSE_BOUND (70).
    let mut s = flyby_spec();
    s.header
        .responses
        .max_repairs
        .set(FailureKind::CommandFailed, MAX_RESPONSE_BOUND + 1);
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::BadResponseBound,
            net(ResponseField::MaxRepairs)
        )
    );
    let mut s = flyby_spec();
    let mut retries = PerCause::ZERO;
    retries.set(FailureKind::ResponseTimeout, 200);
    s.tasks[flyby].control.max_retries = Some(retries);
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::BadResponseBound,
            own(2, ResponseField::MaxRetries)
        )
    );

    // A bound where it means nothing (71): the executive cannot retry a MAINTAIN abort; a
    // task without a command has nothing to retry; nothing answers "unschedulable".
    let mut s = flyby_spec();
    s.header
        .responses
        .max_retries
        .set(FailureKind::MaintainViolation, 1);
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::BoundNotApplicable,
            net(ResponseField::MaxRetries)
        )
    );
    let mut s = flyby_spec();
    s.tasks[request].control.max_retries = Some(PerCause::uniform(1, FailureKind::RETRYABLE));
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::BoundNotApplicable,
            own(1, ResponseField::MaxRetries)
        )
    );
    let mut s = flyby_spec();
    let mut repairs = PerCause::ZERO;
    repairs.set(FailureKind::Unschedulable, 1);
    s.tasks[flyby].control.max_repairs = Some(repairs);
    assert_eq!(
        rejected(&s),
        (
            ValidationCode::BoundNotApplicable,
            own(2, ResponseField::MaxRepairs)
        )
    );

    // Back-off (72): initial over the cap, a zero initial delay with a cap (zero doubles to
    // zero), a cap over 30 days.
    for (initial_us, max_us) in [
        (20 * SEC, 10 * SEC),
        (0, 10 * SEC),
        (SEC, MAX_DURATION_US + 1),
    ] {
        let mut s = flyby_spec();
        s.header.responses.backoff = Backoff { initial_us, max_us };
        assert_eq!(
            rejected(&s),
            (ValidationCode::BadBackoff, net(ResponseField::Backoff)),
            "{initial_us} {max_us}"
        );
        let mut s = flyby_spec();
        s.tasks[flyby].control.backoff = Some(Backoff { initial_us, max_us });
        assert_eq!(
            rejected(&s),
            (ValidationCode::BadBackoff, own(2, ResponseField::Backoff))
        );
    }
}

/// `after_reset` (issue 15): only on a state timeline without a state key, with one of its
/// values.
#[test]
fn after_reset_values_are_checked_with_their_codes() {
    let at = ErrorSite::TimelineAfterReset;
    let mut s = flyby_spec();
    s.timelines[TL_ATTITUDE as usize].state_key = None;
    s.timelines[TL_ATTITUDE as usize].after_reset = Some(i64::from(UNKNOWN));
    assert!(TaskNetwork::from_spec(s.clone()).is_ok());
    assert!(validate_uplink(&encode(&s)).is_ok());

    let mut s = flyby_spec();
    s.timelines[TL_ATTITUDE as usize].after_reset = Some(i64::from(UNKNOWN));
    assert_eq!(
        rejected(&s),
        (ValidationCode::RevertMeasuredTimeline, at(TL_ATTITUDE))
    );
    for bad in [5, -1] {
        let mut s = flyby_spec();
        s.timelines[TL_ATTITUDE as usize].state_key = None;
        s.timelines[TL_ATTITUDE as usize].after_reset = Some(bad);
        assert_eq!(
            rejected(&s),
            (ValidationCode::ValueOutOfRange, at(TL_ATTITUDE))
        );
    }
    for timeline in [TL_REQUEST, TL_GNC_SLEW] {
        let mut s = flyby_spec();
        s.timelines[timeline as usize].after_reset = Some(0);
        assert_eq!(rejected(&s), (ValidationCode::RevertNotState, at(timeline)));
    }
}

/// `stale_after_us` (issue 10): only on a measured timeline, positive, at most 30 days.
#[test]
fn staleness_bounds_are_checked_with_their_codes() {
    let at = ErrorSite::TimelineStaleAfter;
    for fine in [1, 10 * MIN, MAX_STALE_AFTER_US] {
        let mut s = flyby_spec();
        s.timelines[TL_ATTITUDE as usize].stale_after_us = Some(fine);
        let network = TaskNetwork::from_spec(s.clone()).expect("accepted");
        let bytes = encode(&s);
        assert!(validate_uplink(&bytes).is_ok());
        // The bound survives the uplink.
        let mut decoded = TaskNetwork::EMPTY;
        autonomy::uplink::decode_into(&mut decoded, &bytes).unwrap();
        assert_eq!(decoded, network);
        assert_eq!(
            decoded.timelines()[TL_ATTITUDE as usize].stale_after_us,
            Some(fine)
        );
    }
    for bad in [0, MAX_STALE_AFTER_US + 1, u64::MAX] {
        let mut s = flyby_spec();
        s.timelines[TL_ATTITUDE as usize].stale_after_us = Some(bad);
        assert_eq!(
            rejected(&s),
            (ValidationCode::BadStaleBound, at(TL_ATTITUDE)),
            "{bad}"
        );
    }
    // Timelines no state key measures: nothing ages there.
    for timeline in [TL_REQUEST, TL_GNC_SLEW, TL_INSTRUMENT] {
        let mut s = flyby_spec();
        s.timelines[timeline as usize].stale_after_us = Some(10 * MIN);
        assert_eq!(
            rejected(&s),
            (ValidationCode::StaleNotMeasured, at(timeline))
        );
    }
    // Both wrong: the missing state key is named first.
    let mut s = flyby_spec();
    s.timelines[TL_REQUEST as usize].stale_after_us = Some(0);
    assert_eq!(
        rejected(&s),
        (ValidationCode::StaleNotMeasured, at(TL_REQUEST))
    );
}

/// Every code keeps its number: they reach the host in `UplinkNak.reason`.
#[test]
fn new_validation_codes_have_their_numbers() {
    assert_eq!(ValidationCode::BadResponseBound.code(), 70);
    assert_eq!(ValidationCode::BoundNotApplicable.code(), 71);
    assert_eq!(ValidationCode::BadBackoff.code(), 72);
    assert_eq!(ValidationCode::RevertMeasuredTimeline.code(), 73);
    assert_eq!(ValidationCode::RevertNotState.code(), 74);
    assert_eq!(ValidationCode::BadStaleBound.code(), 75);
    assert_eq!(ValidationCode::StaleNotMeasured.code(), 76);
    assert_eq!(ValidationCode::TooManyTimedValues.code(), 22);
    assert_eq!(ValidationCode::TooManyThresholds.code(), 23);
    assert_eq!(ValidationCode::BadBackgroundRate.code(), 80);
    assert_eq!(ValidationCode::ExternalTimeline.code(), 81);
    assert_eq!(ValidationCode::BadTimedValue.code(), 82);
    assert_eq!(ValidationCode::BadThresholds.code(), 83);
    assert_eq!(ValidationCode::TemporalTemplatePair.code(), 84);
    assert_eq!(ValidationCode::TemporalCycle.code(), 85);
    assert_eq!(ValidationCode::BadInstanceArg.code(), 86);
    // And an uplink of a previous format is refused as such.
    assert_eq!(UPLINK_FORMAT_VERSION, 5);
    for previous in [1, 2, 3, 4] {
        let mut bytes = encode(&flyby_spec());
        bytes[0] = previous;
        assert_eq!(
            validate_uplink(&bytes).unwrap_err().code,
            ValidationCode::FormatVersion
        );
    }
}
