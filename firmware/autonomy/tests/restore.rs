//! Honest accounting across a warm reset (issue 15): a commanded task that was running at the
//! last checkpoint is reported interrupted, never completed; planner-only timelines declared
//! to revert after a reset do; the executive's retry state and the planner's failure ledger
//! come back with the checkpoint; state updates of the wrong type are counted and named; a
//! payload that does not decode leaves an empty core, reset in place.
mod common;
use autonomy::*;
use common::*;

const MODE_KEY: StateKey = StateKey(7);
const OP: Opcode = Opcode(0x0300);
const TL_MODE: u8 = 0;
const TL_HEATER: u8 = 1;
const OFF: i64 = 0;
const ON: i64 = 1;

/// Mode (measured, 2 values) and Heater (planner-only, OFF/ON, reverting to `heater_reset`).
fn network(tasks: &[TaskSpec], heater_reset: Option<i64>) -> TaskNetwork {
    let mut n = NetworkSpec::new(1, PlannerConfig::DEFAULT);
    for (name, state_key, after_reset) in [
        ("Mode", Some(MODE_KEY), None),
        ("Heater", None, heater_reset),
    ] {
        n.timelines
            .push(TimelineSpec {
                name: Name::try_from(name).unwrap(),
                kind: TimelineKind::State {
                    value_count: 2,
                    initial: 0,
                },
                state_key,
                after_reset,
                stale_after_us: None,
                background_rate: 0,
                external: false,
                thresholds: heapless::Vec::new(),
            })
            .unwrap();
    }
    for t in tasks {
        n.tasks.push(t.clone()).unwrap();
    }
    TaskNetwork::from_spec(n).expect("valid")
}

fn task(id: u16, start_s: u64, duration_s: u64) -> TaskSpec {
    TaskSpec {
        id,
        name: Name::try_from("t").unwrap(),
        priority: 0,
        role: TaskRole::Requested,
        command: Some(CommandSpec {
            opcode: OP,
            args: CommandArgs::new(),
            from_instance: heapless::Vec::new(),
        }),
        duration_us: duration_s * SEC,
        min_duration_us: duration_s * SEC,
        earliest_start: MissionTimeUs(start_s * SEC),
        latest_start: MissionTimeUs(start_s * SEC),
        latest_end: MissionTimeUs::MAX,
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: ControlSpec {
            pre_wait_timeout_us: 5 * SEC,
            response_timeout_us: 1000 * SEC,
            ..ControlSpec::NONE
        },
        contingencies: heapless::Vec::new(),
        permissions: Permissions {
            may_move: false,
            may_delete: false,
            may_add: heapless::Vec::new(),
        },
    }
}

fn step(a: &mut Autonomy, out: &mut Recorder, t: u64) {
    out.now = MissionTimeUs(t * SEC);
    a.step(MissionTimeUs(t * SEC), StepBudget::UNLIMITED, out);
}

/// Checkpoints `a` and brings up a fresh core from the checkpoint, as after a warm reset.
fn warm_reset(a: &Autonomy) -> Box<Autonomy> {
    let mut bytes = vec![0u8; WARM_AREA_LEN];
    let mut area = WarmRestartArea::new(&mut bytes);
    a.checkpoint_to(&mut area).expect("fits");
    let mut restored = Box::new(Autonomy::new());
    restored.restore_from(&area).expect("whole checkpoint");
    restored
}

fn transitions_of(out: &Recorder, instance: u16) -> Vec<(TaskState, TaskState, u64)> {
    out.decisions
        .iter()
        .filter_map(|d| match *d {
            Decision::Transition { task, from, to, at } if task == instance => {
                Some((from, to, at.0 / SEC))
            }
            _ => None,
        })
        .collect()
}

/// The flyby is running (10:15-11:05) when the flight software resets at 11:04; the core is
/// back at 11:07, after the flyby's end. It used to report the flyby completed at 11:07: the
/// executive saw a Running task past its end. The instrument stopped at the reset, so it is
/// reported interrupted, and the host can end it at the reset.
#[test]
fn a_flyby_running_at_a_reset_is_reported_interrupted_not_completed() {
    let mut sim = Sim::flyby();
    sim.run(
        hm(11, 30),
        &[Reset {
            at: hm(11, 4),
            recovery_us: 3 * MIN,
        }],
    );
    let flyby: Vec<Executed> = sim
        .as_executed()
        .into_iter()
        .filter(|r| r.instance == ID_FLYBY)
        .collect();
    assert_eq!(flyby.len(), 1);
    assert_eq!(
        (flyby[0].end, flyby[0].outcome),
        (Some(hm(11, 7)), TaskState::Failed(FailureKind::Interrupted)),
        "{:#?}",
        timeline_lines(&sim.as_executed())
    );
    assert!(!sim.out.decisions.iter().any(|d| matches!(
        d,
        Decision::Transition {
            task: ID_FLYBY,
            to: TaskState::Completed,
            ..
        }
    )));
    // Its restart contingency applies (on any failure), but its window has closed.
    assert!(sim.out.decisions.iter().any(|d| matches!(
        d,
        Decision::Modification { kind, template: ID_FLYBY, .. }
            if *kind == PlanModificationKind::Restart as u8
    )));
}

/// The same at the level of one task: dispatched (no response yet) or running when the
/// checkpoint was taken, it ends interrupted at the first step after the restore, whatever
/// its end time; a no-op task carries on (nothing ran on a subsystem); and the response to a
/// command sent before the reset is not taken for anything.
#[test]
fn commanded_tasks_out_at_the_checkpoint_end_interrupted_and_no_op_tasks_carry_on() {
    let awaiting = task(1, 100, 50);
    let running = task(2, 100, 500);
    let mut no_op = task(3, 100, 500);
    no_op.command = None;
    let mut a = Box::new(Autonomy::new());
    a.load_network(network(&[awaiting, running, no_op], None))
        .unwrap();
    let mut out = Recorder::default();
    step(&mut a, &mut out, 100);
    let (first_id, _, _) = out.dispatches[0].clone();
    let (second_id, _, _) = out.dispatches[1].clone();
    a.on_command_response(second_id, CommandStatus::Ok);
    step(&mut a, &mut out, 101);
    assert_eq!(
        transitions_of(&out, 2).last().map(|t| t.1),
        Some(TaskState::Running)
    );
    // Reset at 120; back at 300, after task 1's nominal end (150), before task 2's (600).
    let mut a = warm_reset(&a);
    a.on_command_response(first_id, CommandStatus::Ok); // from before the reset
    let mut out = Recorder::default();
    step(&mut a, &mut out, 300);
    assert_eq!(
        transitions_of(&out, 1),
        [(
            TaskState::Dispatched,
            TaskState::Failed(FailureKind::Interrupted),
            300
        )]
    );
    assert_eq!(
        transitions_of(&out, 2),
        [(
            TaskState::Running,
            TaskState::Failed(FailureKind::Interrupted),
            300
        )]
    );
    assert!(
        transitions_of(&out, 3).is_empty(),
        "the no-op task carries on"
    );
    assert_eq!(a.executive().stats.unmatched_responses, 1);
    step(&mut a, &mut out, 600);
    assert_eq!(
        transitions_of(&out, 3),
        [(TaskState::Running, TaskState::Completed, 600)]
    );
    // The planner has them failed (their impacts ended at the restart), not completed.
    let plan_state = |id: u16| a.plan().iter().find(|e| e.instance == id).map(|e| e.state);
    for id in [1, 2] {
        assert!(matches!(
            plan_state(id),
            None | Some(TaskState::Failed(FailureKind::Interrupted))
        ));
    }
}

/// A MAINTAIN constraint that no longer holds after the restore is still the clean abort of
/// seed 003 (the early-reset flyby), not "interrupted".
#[test]
fn a_violated_maintain_constraint_at_the_restore_is_reported_as_the_abort() {
    let mut t = task(1, 100, 500);
    t.constraints
        .push(ConstraintSpec {
            when: ConstraintWhen::Maintain,
            timeline: TL_MODE,
            require: Requirement::OneOf { mask: 0b10 },
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    let mut a = Box::new(Autonomy::new());
    a.load_network(network(&[t], None)).unwrap();
    a.on_state_update(MODE_KEY, StateValue::Enum(1), MissionTimeUs(0));
    let mut out = Recorder::default();
    step(&mut a, &mut out, 100);
    let (id, _, _) = out.dispatches[0].clone();
    a.on_command_response(id, CommandStatus::Ok);
    step(&mut a, &mut out, 101);
    let mut a = warm_reset(&a);
    a.on_state_update(MODE_KEY, StateValue::Unknown, MissionTimeUs(200 * SEC));
    let mut out = Recorder::default();
    step(&mut a, &mut out, 203);
    assert_eq!(
        transitions_of(&out, 1),
        [(
            TaskState::Running,
            TaskState::Failed(FailureKind::MaintainViolation),
            203
        )]
    );
}

/// `network` with a staleness bound on Mode.
fn with_mode_bound(network: TaskNetwork, stale_after_us: u64) -> TaskNetwork {
    let mut spec = network.spec().clone();
    spec.timelines[usize::from(TL_MODE)].stale_after_us = Some(stale_after_us);
    TaskNetwork::from_spec(spec).expect("valid")
}

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

/// Issue 10: a value comes back from the checkpoint with the time it was measured, so one not
/// published again after the restart goes stale when its bound says (measured at 100 s, bound
/// 10 min: unknown from 700 s + 1 µs), not a bound after the restart; and one already stale at
/// the checkpoint stays stale and is not reported again.
#[test]
fn a_restored_value_keeps_its_measurement_time_and_goes_stale_on_time() {
    let bound = 600 * SEC;
    let mut a = Box::new(Autonomy::new());
    a.load_network(with_mode_bound(network(&[], None), bound))
        .unwrap();
    let measured_at = MissionTimeUs(100 * SEC);
    a.on_state_update(MODE_KEY, StateValue::Enum(1), measured_at);
    let mut out = Recorder::default();
    step(&mut a, &mut out, 100);
    // Reset at 200 s, back at 400 s; the value is not published again.
    let mut a = warm_reset(&a);
    assert_eq!(a.states().get(MODE_KEY).map(|e| e.at), Some(measured_at));
    let mut out = Recorder::default();
    step(&mut a, &mut out, 400);
    let mode = |a: &Autonomy| condition::measured_value(a.network(), TL_MODE, a.states());
    assert_eq!(mode(&a), Some(1));
    let stale_at = measured_at.saturating_add(bound + 1);
    assert_eq!(a.next_wakeup(), Some(stale_at));
    out.now = MissionTimeUs(700 * SEC);
    a.step(MissionTimeUs(700 * SEC), StepBudget::UNLIMITED, &mut out);
    assert_eq!(mode(&a), Some(1));
    out.now = stale_at;
    a.step(stale_at, StepBudget::UNLIMITED, &mut out);
    assert_eq!(mode(&a), Some(VALUE_UNKNOWN));
    assert_eq!(stale_reports(&out), [(MODE_KEY, measured_at, stale_at)]);
    // Stale at the checkpoint: still stale after the next reset, and reported only once.
    let mut a = warm_reset(&a);
    let mut out = Recorder::default();
    step(&mut a, &mut out, 900);
    assert_eq!(mode(&a), Some(VALUE_UNKNOWN));
    assert_eq!(
        a.planner().view(a.network()).value_at(TL_MODE, a.now()),
        VALUE_UNKNOWN
    );
    assert!(stale_reports(&out).is_empty());
}

/// A task running with a MAINTAIN constraint on Mode (measured ON at 190 s) is cut short by a
/// reset; fault protection takes 30 minutes and Mode is not published again. With a 10-minute
/// bound the restored measurement is stale at the restart: the clean abort of seed 003, after
/// the stale report. Without a bound the core would go on trusting the 30-minute-old value:
/// the task is merely interrupted.
#[test]
fn after_a_long_recovery_a_restored_value_past_its_bound_aborts_what_it_held() {
    let run = |bound: Option<u64>| {
        let mut t = task(1, 200, 3600);
        t.constraints
            .push(ConstraintSpec {
                when: ConstraintWhen::Maintain,
                timeline: TL_MODE,
                require: Requirement::OneOf { mask: 0b10 },
                start_offset_us: 0,
                end_offset_us: 0,
            })
            .unwrap();
        let plain = network(&[t], None);
        let net = bound.map_or(plain.clone(), |b| with_mode_bound(plain, b));
        let mut a = Box::new(Autonomy::new());
        a.load_network(net).unwrap();
        a.on_state_update(MODE_KEY, StateValue::Enum(1), MissionTimeUs(190 * SEC));
        let mut out = Recorder::default();
        step(&mut a, &mut out, 190);
        step(&mut a, &mut out, 200);
        let (id, _, _) = out.dispatches[0].clone();
        a.on_command_response(id, CommandStatus::Ok);
        step(&mut a, &mut out, 201);
        // Reset at 300 s; back 30 minutes later.
        let mut a = warm_reset(&a);
        let mut out = Recorder::default();
        step(&mut a, &mut out, 300 + 1800);
        (transitions_of(&out, 1), stale_reports(&out), out.decisions)
    };
    let (transitions, stale, decisions) = run(Some(600 * SEC));
    assert_eq!(
        transitions,
        [(
            TaskState::Running,
            TaskState::Failed(FailureKind::MaintainViolation),
            2100
        )]
    );
    assert_eq!(
        stale,
        [(
            MODE_KEY,
            MissionTimeUs(190 * SEC),
            MissionTimeUs(2100 * SEC)
        )]
    );
    let first_stale = decisions
        .iter()
        .position(|d| matches!(d, Decision::Stale { .. }));
    let abort = decisions.iter().position(|d| {
        matches!(
            d,
            Decision::Transition {
                task: 1,
                to: TaskState::Failed(_),
                ..
            }
        )
    });
    assert!(first_stale < abort);
    let (transitions, stale, _) = run(None);
    assert_eq!(
        transitions,
        [(
            TaskState::Running,
            TaskState::Failed(FailureKind::Interrupted),
            2100
        )]
    );
    assert!(stale.is_empty());
}

/// A heater task turns the planner-only Heater timeline ON (POST impact); an observation
/// later needs it ON (PRE) and may add another heater task. A reset turns heaters off: with
/// `after_reset = OFF` the timeline reads OFF from the restart and the planner adds a heater
/// task before the observation; without it the planner goes on believing the heater is on.
#[test]
fn a_planner_only_timeline_reverts_after_a_reset_when_declared() {
    let run = |after_reset: Option<i64>| {
        let heat = |id: u16, role: TaskRole, start_s: u64| {
            let mut t = task(id, start_s, 60);
            t.role = role;
            if role == TaskRole::Template {
                t.earliest_start = MissionTimeUs::ZERO;
                t.latest_start = MissionTimeUs::MAX;
            }
            t.impacts
                .push(ImpactSpec {
                    when: ImpactWhen::Post,
                    timeline: TL_HEATER,
                    effect: Effect::Assign(ON),
                    start_offset_us: 0,
                    end_offset_us: 0,
                })
                .unwrap();
            t
        };
        let mut observe = task(3, 1000, 60);
        observe
            .constraints
            .push(ConstraintSpec {
                when: ConstraintWhen::Pre,
                timeline: TL_HEATER,
                require: Requirement::OneOf { mask: 1 << ON },
                start_offset_us: 0,
                end_offset_us: 0,
            })
            .unwrap();
        observe.permissions.may_add.push(11).unwrap();
        let net = network(
            &[
                heat(1, TaskRole::Requested, 100),
                observe,
                heat(11, TaskRole::Template, 0),
            ],
            after_reset,
        );
        let mut a = Box::new(Autonomy::new());
        a.load_network(net).unwrap();
        let mut out = Recorder::default();
        step(&mut a, &mut out, 100);
        for (id, _, _) in out.dispatches.clone() {
            a.on_command_response(id, CommandStatus::Ok);
        }
        step(&mut a, &mut out, 101);
        step(&mut a, &mut out, 160); // the heater task completes: Heater ON
        let mut a = warm_reset(&a);
        let mut out = Recorder::default();
        step(&mut a, &mut out, 500);
        let heater_at_restart = a
            .planner()
            .view(a.network())
            .value_at(TL_HEATER, MissionTimeUs(500 * SEC));
        let added = out.decisions.iter().any(|d| {
            matches!(d, Decision::Modification { kind, template: 11, .. }
                if *kind == PlanModificationKind::Add as u8)
        });
        (heater_at_restart, added)
    };
    assert_eq!(run(Some(OFF)), (OFF, true));
    assert_eq!(run(None), (ON, false));
}

/// Resets in the middle of back-offs: the executive's retry (its count and its time) and the
/// planner's failure counts come back with the checkpoint, so the flyby against a GNC that
/// rejects everything sends exactly the commands it sends without the resets, at the same
/// times (lost counts would allow more).
#[test]
fn retry_counts_back_off_times_and_failure_counts_survive_a_warm_reset() {
    let mut spec = flyby_spec();
    spec.header.responses.max_retries = PerCause::uniform(2, FailureKind::RETRYABLE);
    let network = TaskNetwork::from_spec(spec).unwrap();
    let fly = |end: MissionTimeUs, resets: &[Reset]| {
        let mut sim = Sim::new(network.clone(), hm(9, 50));
        sim.sc.gnc_fates = vec![GncFate::Reject];
        sim.run(end, resets);
        sim
    };
    let after = |s: u64| hm(10, 0).saturating_add(s * SEC);
    // 10:00:05: the first turn waits until 10:00:10 for its second retry.
    let first = Reset {
        at: after(5),
        recovery_us: SEC,
    };
    // 10:00:35: two added turns have failed; the third waits for the back-off (10:00:40).
    let second = Reset {
        at: after(35),
        recovery_us: SEC,
    };
    let before_first = fly(MissionTimeUs(first.at.0 - 1), &[]);
    let waiting = before_first
        .autonomy
        .executive()
        .entries()
        .iter()
        .find(|e| e.instance == ID_GNC_NADIR)
        .copied()
        .expect("the first turn waits for its retry");
    assert_eq!(waiting.state, TaskState::WaitingPre);
    assert_eq!(waiting.retry_at, after(10));
    assert_eq!(waiting.retries.get(FailureKind::CommandRejected), 2);
    let restored = warm_reset(&before_first.autonomy);
    assert_eq!(
        restored.executive().entries(),
        before_first.autonomy.executive().entries()
    );

    let before_second = fly(MissionTimeUs(second.at.0 - 1), &[]);
    let template = network.def_of_id(ID_GNC_NADIR_TEMPLATE).unwrap();
    let ledger = *before_second
        .autonomy
        .planner()
        .ledger_of(template)
        .unwrap();
    assert_eq!(ledger.consecutive.get(FailureKind::CommandRejected), 2);
    assert_eq!(ledger.not_before, after(40));
    let restored = warm_reset(&before_second.autonomy);
    assert_eq!(
        restored.planner().ledger(),
        before_second.autonomy.planner().ledger()
    );

    let sent = |sim: &Sim| -> Vec<(MissionTimeUs, u16)> {
        sim.task_dispatches()
            .into_iter()
            .map(|(at, id, _)| (at, id))
            .collect()
    };
    let plain = fly(hm(11, 30), &[]);
    let with_resets = fly(hm(11, 30), &[first, second]);
    assert_eq!(sent(&with_resets), sent(&plain));
    assert_eq!(
        plain.dispatches_per_definition()[&ID_GNC_NADIR_TEMPLATE],
        9,
        "three turns of three attempts"
    );
}

/// An integer published for the attitude (a state timeline) is not taken as an attitude: it
/// reads unknown to the planner and the executive alike, and it is counted with its key.
#[test]
fn state_updates_of_the_wrong_type_are_counted_with_their_key() {
    let mut a = Box::new(Autonomy::new());
    a.load_network(flyby_network()).unwrap();
    assert_eq!(a.state_type_mismatches(), 0);
    a.on_state_update(ATTITUDE_KEY, StateValue::Int(1), hm(9, 0));
    a.on_state_update(ATTITUDE_KEY, StateValue::Enum(NADIR), hm(9, 1));
    a.on_state_update(ATTITUDE_KEY, StateValue::Enum(9), hm(9, 2)); // beyond the 5 values
    assert_eq!(a.state_type_mismatches(), 2);
    assert_eq!(a.last_state_type_mismatch(), Some(ATTITUDE_KEY));
    assert_eq!(
        condition::measured_value(a.network(), TL_ATTITUDE, a.states()),
        Some(VALUE_UNKNOWN)
    );
    // The host can check its state buffer against this before boot.
    let measured: Vec<(u8, StateKey, MeasuredValueType)> =
        a.network().measured_timelines().collect();
    assert_eq!(
        measured,
        [(
            TL_ATTITUDE,
            ATTITUDE_KEY,
            MeasuredValueType::Enum { values: 5 }
        )]
    );
    assert!(!measured[0].2.accepts(StateValue::Int(1)));
    assert!(measured[0].2.accepts(StateValue::Enum(EARTH)));
    // The count survives a warm reset.
    let restored = warm_reset(&a);
    assert_eq!(restored.state_type_mismatches(), 2);
    assert_eq!(restored.last_state_type_mismatch(), Some(ATTITUDE_KEY));
}

/// What a core holds, as its checkpoint encodes it (meta, network, plan, executive, states).
fn encoded(a: &Autonomy) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 16];
    let len = a.encode_state(&mut buf).expect("the state fits");
    buf.truncate(len);
    buf
}

#[test]
fn a_payload_that_does_not_decode_leaves_the_core_as_a_new_one() {
    let mut sim = Sim::flyby();
    sim.run(hm(10, 29), &[]);
    let fresh = Box::new(Autonomy::new());
    assert_ne!(
        encoded(&sim.autonomy),
        encoded(&fresh),
        "the flyby core holds a plan"
    );
    let mut payload = encoded(&sim.autonomy);
    let last = payload.len() - 1;
    payload[last] ^= 0xff;
    payload.push(0);
    let record = autonomy::checkpoint::Record {
        slot: 0,
        sequence: 7,
        payload: &payload,
    };
    assert!(sim.autonomy.restore_record(record).is_err());
    assert_eq!(encoded(&sim.autonomy), encoded(&fresh));
    assert_eq!(sim.autonomy.network(), fresh.network());
    assert_eq!(
        format!("{:?}", sim.autonomy.planner().entries()),
        format!("{:?}", fresh.planner().entries())
    );
}

#[test]
fn a_reset_core_flies_the_flyby_as_a_new_one() {
    let mut used = Sim::flyby();
    used.run(hm(10, 29), &[]);
    let mut core = std::mem::replace(&mut used.autonomy, Box::new(Autonomy::new()));
    core.reset();
    assert_eq!(encoded(&core), encoded(&Autonomy::new()));
    core.load_network(flyby_network()).expect("loads");
    let mut again = Sim::flyby();
    again.autonomy = core;
    again.run(hm(11, 30), &[]);
    let mut fresh = Sim::flyby();
    fresh.run(hm(11, 30), &[]);
    assert!(!fresh.out.decisions.is_empty());
    assert_eq!(again.out.decisions, fresh.out.decisions);
    assert_eq!(encoded(&again.autonomy), encoded(&fresh.autonomy));
}
