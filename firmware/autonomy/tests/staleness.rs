//! State knowledge that heals (issue 10): a measured value older than its timeline's staleness
//! bound reads UNKNOWN to every reader in the core (the state table, conditions, the
//! executive's constraints, the planner's projections) from exactly one microsecond past the
//! bound, is reported once, and is a state change the executive and the planner react to; a
//! newer measurement makes it known again.
mod common;
use autonomy::condition::{evaluate, measured_value};
use autonomy::*;
use common::*;

/// Measured by timeline "Mode" (two values, OFF 0 / ON 1).
const MODE_KEY: StateKey = StateKey(7);
/// A state-buffer entry no timeline measures (conditions may still read it).
const PLAIN_KEY: StateKey = StateKey(8);
const TL_MODE: u8 = 0;
const ON: u16 = 1;
const BOUND_US: u64 = 10 * SEC;

/// "Mode == ON" read through the state key, and through the timeline.
fn mode_on_conditions() -> [ConditionSpec; 3] {
    let term = |operand| ConditionSpec {
        nodes: heapless::Vec::from_slice(&[CondNode::Term {
            operand,
            op: RelOp::Eq,
            value: i64::from(ON),
        }])
        .unwrap(),
    };
    [
        term(Operand::State(MODE_KEY)),
        term(Operand::Timeline(TL_MODE)),
        term(Operand::State(PLAIN_KEY)),
    ]
}

fn network(stale_after_us: Option<u64>, tasks: &[TaskSpec]) -> TaskNetwork {
    let mut n = NetworkSpec::new(1, PlannerConfig::DEFAULT);
    n.timelines
        .push(TimelineSpec {
            name: Name::try_from("Mode").unwrap(),
            kind: TimelineKind::State {
                value_count: 2,
                initial: 0,
            },
            state_key: Some(MODE_KEY),
            after_reset: None,
            stale_after_us,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .unwrap();
    for c in mode_on_conditions() {
        n.conditions.push(c).unwrap();
    }
    for t in tasks {
        n.tasks.push(t.clone()).unwrap();
    }
    TaskNetwork::from_spec(n).expect("valid")
}

/// A no-op task over `[start_us, start_us + duration_us)` with a MAINTAIN constraint Mode == ON.
fn maintain_on_task(start_us: u64, duration_us: u64) -> TaskSpec {
    let mut constraints = heapless::Vec::new();
    constraints
        .push(ConstraintSpec {
            when: ConstraintWhen::Maintain,
            timeline: TL_MODE,
            require: Requirement::OneOf { mask: 1 << ON },
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    TaskSpec {
        id: 1,
        name: Name::try_from("Observe").unwrap(),
        priority: 0,
        role: TaskRole::Requested,
        command: None,
        duration_us,
        min_duration_us: duration_us,
        earliest_start: MissionTimeUs(start_us),
        latest_start: MissionTimeUs(start_us),
        latest_end: MissionTimeUs::MAX,
        constraints,
        impacts: heapless::Vec::new(),
        control: ControlSpec::NONE,
        contingencies: heapless::Vec::new(),
        permissions: Permissions {
            may_move: false,
            may_delete: false,
            may_add: heapless::Vec::new(),
        },
    }
}

fn core(network: TaskNetwork) -> Box<Autonomy> {
    let mut a = Box::new(Autonomy::new());
    a.load_network(network).expect("loads");
    a
}

fn step(a: &mut Autonomy, out: &mut Recorder, now: MissionTimeUs) {
    out.now = now;
    a.step(now, StepBudget::UNLIMITED, out);
}

/// What each reader of the core sees of Mode at the last step.
#[derive(Debug, PartialEq, Eq)]
struct Readings {
    /// The executive's reading of the timeline (constraints, POST checks).
    measured: Option<i64>,
    /// The state table's reading of the key.
    table: i64,
    /// The planner's projection of the timeline at the step's time.
    planner: i64,
    /// Conditions reading the key, and the timeline.
    condition_on_key: bool,
    condition_on_timeline: bool,
}

fn readings(a: &Autonomy) -> Readings {
    let network = a.network();
    let condition = |i: u8| evaluate(network, network.condition(i).unwrap(), a.states());
    Readings {
        measured: measured_value(network, TL_MODE, a.states()),
        table: a.states().value(MODE_KEY),
        planner: a.planner().view(network).value_at(TL_MODE, a.now()),
        condition_on_key: condition(0),
        condition_on_timeline: condition(1),
    }
}

const KNOWN_ON: Readings = Readings {
    measured: Some(ON as i64),
    table: ON as i64,
    planner: ON as i64,
    condition_on_key: true,
    condition_on_timeline: true,
};

const UNKNOWN_TO_ALL: Readings = Readings {
    measured: Some(VALUE_UNKNOWN),
    table: VALUE_UNKNOWN,
    planner: VALUE_UNKNOWN,
    condition_on_key: false,
    condition_on_timeline: false,
};

fn stale_reports(out: &Recorder) -> Vec<(StateKey, MissionTimeUs, MissionTimeUs)> {
    out.decisions
        .iter()
        .filter_map(|d| match *d {
            Decision::Stale {
                key,
                measured_at,
                at,
            } => Some((key, measured_at, at)),
            _ => None,
        })
        .collect()
}

#[test]
fn a_value_reads_unknown_exactly_one_microsecond_past_its_bound_and_not_before() {
    let mut a = core(network(Some(BOUND_US), &[]));
    let mut out = Recorder::default();
    let measured_at = MissionTimeUs(100 * SEC);
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), measured_at);
    a.on_state_update(PLAIN_KEY, StateValue::Enum(ON), measured_at);
    step(&mut a, &mut out, measured_at);
    assert_eq!(readings(&a), KNOWN_ON);
    // The instant it goes stale is when the core must run next.
    let stale_at = measured_at.saturating_add(BOUND_US + 1);
    assert_eq!(a.next_wakeup(), Some(stale_at));

    // At the bound itself: still known, nothing reported.
    step(&mut a, &mut out, measured_at.saturating_add(BOUND_US));
    assert_eq!(readings(&a), KNOWN_ON);
    assert!(stale_reports(&out).is_empty());
    assert_eq!(a.next_wakeup(), Some(stale_at));

    // One microsecond past it: unknown to every reader, reported once with its age.
    step(&mut a, &mut out, stale_at);
    assert_eq!(readings(&a), UNKNOWN_TO_ALL);
    assert_eq!(stale_reports(&out), [(MODE_KEY, measured_at, stale_at)]);
    // The value as reported is kept (with its measurement time); only its reading changed.
    let entry = *a.states().get(MODE_KEY).unwrap();
    assert_eq!(
        (entry.value, entry.at, entry.stale),
        (StateValue::Enum(ON), measured_at, true)
    );
    // A key no timeline measures has no bound: it never goes stale.
    assert!(evaluate(
        a.network(),
        a.network().condition(2).unwrap(),
        a.states()
    ));

    // Later steps: still unknown, not reported again, no more wake-ups for it.
    step(&mut a, &mut out, MissionTimeUs(3600 * SEC));
    assert_eq!(readings(&a), UNKNOWN_TO_ALL);
    assert_eq!(stale_reports(&out).len(), 1);
    assert_eq!(a.next_wakeup(), None);
}

#[test]
fn without_a_bound_a_value_never_goes_stale_and_a_never_measured_one_reads_as_before() {
    let mut a = core(network(None, &[]));
    let mut out = Recorder::default();
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), MissionTimeUs(100 * SEC));
    step(&mut a, &mut out, MissionTimeUs(100 * SEC));
    assert_eq!(a.next_wakeup(), None);
    step(&mut a, &mut out, MissionTimeUs(30 * 86_400 * SEC));
    assert_eq!(readings(&a), KNOWN_ON);

    // Never measured: the timeline's initial value, however long it has been.
    let mut a = core(network(Some(BOUND_US), &[]));
    step(&mut a, &mut out, MissionTimeUs(3600 * SEC));
    assert_eq!(measured_value(a.network(), TL_MODE, a.states()), Some(0));
    assert_eq!(a.planner().view(a.network()).value_at(TL_MODE, a.now()), 0);
    assert_eq!(a.next_wakeup(), None);
    assert!(stale_reports(&out).is_empty());
}

#[test]
fn a_newer_measurement_makes_a_stale_value_known_again() {
    let mut a = core(network(Some(BOUND_US), &[]));
    let mut out = Recorder::default();
    let first = MissionTimeUs(100 * SEC);
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), first);
    step(&mut a, &mut out, first);
    let stale_at = first.saturating_add(BOUND_US + 1);
    step(&mut a, &mut out, stale_at);
    assert_eq!(readings(&a), UNKNOWN_TO_ALL);

    // Neither the same measurement again nor an older one refreshes it.
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), first);
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), MissionTimeUs(50 * SEC));
    step(&mut a, &mut out, MissionTimeUs(115 * SEC));
    assert_eq!(readings(&a), UNKNOWN_TO_ALL);
    assert_eq!(stale_reports(&out).len(), 1);

    // A newer one does, to every reader, and ages from its own time: here a delayed one,
    // measured before the step that found the first one stale (110 s + 1 µs) but still
    // within its bound when it arrives.
    let second = MissionTimeUs(108 * SEC);
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), second);
    step(&mut a, &mut out, MissionTimeUs(116 * SEC));
    assert_eq!(readings(&a), KNOWN_ON);
    assert_eq!(a.next_wakeup(), Some(second.saturating_add(BOUND_US + 1)));
    step(&mut a, &mut out, second.saturating_add(BOUND_US));
    assert_eq!(readings(&a), KNOWN_ON);
    step(&mut a, &mut out, second.saturating_add(BOUND_US + 1));
    assert_eq!(readings(&a), UNKNOWN_TO_ALL);
    assert_eq!(
        stale_reports(&out),
        [
            (MODE_KEY, first, stale_at),
            (MODE_KEY, second, second.saturating_add(BOUND_US + 1))
        ]
    );

    // A measurement newer than the stored one but already past its bound when the core runs
    // is unknown at once, and reported with its own time.
    let late = MissionTimeUs(200 * SEC);
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), late);
    let now = late.saturating_add(BOUND_US + 5);
    step(&mut a, &mut out, now);
    assert_eq!(readings(&a), UNKNOWN_TO_ALL);
    assert_eq!(stale_reports(&out).last(), Some(&(MODE_KEY, late, now)));
}

/// A value going stale is a state change: the executive aborts a task whose MAINTAIN
/// constraint it was holding, at the very instant, after the stale report.
#[test]
fn a_maintain_constraint_is_violated_when_its_value_goes_stale() {
    let start = 100 * SEC;
    let mut a = core(network(
        Some(BOUND_US),
        &[maintain_on_task(start, 60 * SEC)],
    ));
    let mut out = Recorder::default();
    let measured_at = MissionTimeUs(start - 5 * SEC);
    a.on_state_update(MODE_KEY, StateValue::Enum(ON), measured_at);
    // Step the way the time driver does: at every wake-up the core asks for.
    let mut now = MissionTimeUs(90 * SEC);
    while now <= MissionTimeUs(start + 60 * SEC) {
        step(&mut a, &mut out, now);
        match a.next_wakeup() {
            Some(next) if next > now => now = next,
            _ => break,
        }
    }
    let stale_at = measured_at.saturating_add(BOUND_US + 1);
    let tail: Vec<&Decision> = out
        .decisions
        .iter()
        .filter(|d| {
            matches!(
                d,
                Decision::Stale { .. } | Decision::Transition { task: 1, .. }
            )
        })
        .collect();
    assert_eq!(
        tail,
        [
            &Decision::Transition {
                task: 1,
                from: TaskState::Unscheduled,
                to: TaskState::Scheduled,
                at: MissionTimeUs(90 * SEC)
            },
            &Decision::Transition {
                task: 1,
                from: TaskState::Scheduled,
                to: TaskState::Committed,
                at: MissionTimeUs(90 * SEC)
            },
            &Decision::Transition {
                task: 1,
                from: TaskState::Committed,
                to: TaskState::Running,
                at: MissionTimeUs(start)
            },
            &Decision::Stale {
                key: MODE_KEY,
                measured_at,
                at: stale_at
            },
            &Decision::Transition {
                task: 1,
                from: TaskState::Running,
                to: TaskState::Failed(FailureKind::MaintainViolation),
                at: stale_at
            },
        ],
        "{:#?}",
        out.decisions
    );

    // The same task with the value published again within the bound completes.
    let mut a = core(network(
        Some(BOUND_US),
        &[maintain_on_task(start, 60 * SEC)],
    ));
    let mut out = Recorder::default();
    // Republished every 5 s (the task's start and end are on that grid).
    for s in (90..=160).step_by(5) {
        let now = MissionTimeUs(s * SEC);
        a.on_state_update(MODE_KEY, StateValue::Enum(ON), now);
        step(&mut a, &mut out, now);
    }
    assert!(stale_reports(&out).is_empty());
    assert!(out.decisions.contains(&Decision::Transition {
        task: 1,
        from: TaskState::Running,
        to: TaskState::Completed,
        at: MissionTimeUs(start + 60 * SEC)
    }));
}

/// The flyby with a 10-minute staleness bound on the attitude.
fn flyby_with_bound(stale_after_us: u64) -> TaskNetwork {
    let mut spec = flyby_spec();
    spec.timelines[TL_ATTITUDE as usize].stale_after_us = Some(stale_after_us);
    TaskNetwork::from_spec(spec).expect("valid")
}

/// The attitude published every 5 minutes (from 09:50) and a 10-minute bound: the flyby flies
/// exactly as without a bound, and nothing goes stale.
#[test]
fn a_flyby_whose_attitude_is_republished_within_its_bound_flies_as_without_one() {
    let mut plain = Sim::flyby();
    plain.run(hm(11, 30), &[]);
    let mut bounded = Sim::new(flyby_with_bound(10 * MIN), hm(9, 50));
    bounded.sc.republish = Some(Republish::every(5 * MIN, hm(9, 50)));
    bounded.run(hm(11, 30), &[]);
    assert!(stale_reports(&bounded.out).is_empty());
    assert_eq!(
        decision_lines(&bounded),
        decision_lines(&plain),
        "same decisions at the same times"
    );
}

/// The republished attitude is lost at 10:20 and 10:25: NADIR, measured at 10:15, goes stale
/// at 10:25 plus one microsecond. The flyby's MAINTAIN constraint no longer holds, so it is
/// aborted then, and the planner answers as after a reset (seed 003): the flyby restarted, the
/// turn back to NADIR added before it, the degraded flyby added to cover the request meanwhile,
/// and the next maneuver still at 11:05.
#[test]
fn a_lost_republish_aborts_the_flyby_when_the_attitude_goes_stale_and_the_plan_is_repaired() {
    let mut sim = Sim::new(flyby_with_bound(10 * MIN), hm(9, 50));
    sim.sc.republish = Some(Republish {
        lost_from: hm(10, 20),
        lost_until: hm(10, 30),
        ..Republish::every(5 * MIN, hm(9, 50))
    });
    sim.run(hm(11, 30), &[]);
    let stale_at = hm(10, 25).saturating_add(1);
    assert_eq!(
        stale_reports(&sim.out),
        [(ATTITUDE_KEY, hm(10, 15), stale_at)],
        "{:#?}",
        decision_lines(&sim)
    );
    let rows = sim.as_executed();
    let lines = timeline_lines(&rows);
    let first_flyby = rows.iter().find(|r| r.instance == ID_FLYBY).unwrap();
    assert_eq!(
        (first_flyby.end, first_flyby.outcome),
        (
            Some(stale_at),
            TaskState::Failed(FailureKind::MaintainViolation)
        ),
        "{lines:#?}"
    );
    // The stale report comes before the abort it causes.
    let index_of = |pred: &dyn Fn(&Decision) -> bool| {
        sim.out.decisions.iter().position(pred).expect("present")
    };
    let stale = index_of(&|d| matches!(d, Decision::Stale { .. }));
    let abort = index_of(&|d| {
        matches!(
            d,
            Decision::Transition {
                task: ID_FLYBY,
                to: TaskState::Failed(FailureKind::MaintainViolation),
                ..
            }
        )
    });
    assert!(stale < abort);
    // The planner's answers to the state change, all at the instant it went stale.
    let modifications_at_stale: Vec<(u8, u16)> = sim
        .out
        .decisions
        .iter()
        .filter_map(|d| match *d {
            Decision::Modification {
                kind, template, at, ..
            } if at == stale_at => Some((kind, template)),
            _ => None,
        })
        .collect();
    for expected in [
        (PlanModificationKind::Restart as u8, ID_FLYBY),
        (PlanModificationKind::Add as u8, ID_GNC_NADIR_TEMPLATE),
        (PlanModificationKind::Add as u8, ID_DEGRADED_TEMPLATE),
    ] {
        assert!(
            modifications_at_stale.contains(&expected),
            "{expected:?} not in {modifications_at_stale:?}: {lines:#?}"
        );
    }
    // As executed: seed 003's Fig. 7, with the staleness where the reset was.
    assert_eq!(
        lines,
        [
            "10:00:00-10:15:00 GncAttain NADIR Completed",
            "10:15:00-11:05:00 Instrument Flyby Request Completed",
            "10:15:00-10:25:00.000001 Instrument Flyby Failed(MaintainViolation)",
            "10:25:00.000001-10:40:00.000002 Instrument Degraded Flyby Completed",
            "10:25:00.000002-10:40:00.000002 GncAttain NADIR (template) Completed",
            "10:40:00.000002-11:05:00 Instrument Flyby Completed",
            "11:05:00-11:20:00 GncAttain EARTH Completed",
        ]
    );
}
