//! Unit tests of the parts the flyby does not exercise: executive retries, timeouts and skips,
//! control conditions, temporal constraints (shortest paths), rate impacts, the warm-restart
//! area's slot alternation.
mod common;
use autonomy::planner::Planner;
use autonomy::*;
use common::*;

const MODE_KEY: StateKey = StateKey(7);
const OP: Opcode = Opcode(0x0300);

fn base(tasks: &[TaskSpec]) -> NetworkSpec {
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
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .unwrap();
    n.timelines
        .push(TimelineSpec {
            name: Name::try_from("Energy").unwrap(),
            kind: TimelineKind::Cumulative {
                initial: 100,
                min: 0,
                max: 1000,
            },
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .unwrap();
    for t in tasks {
        n.tasks.push(t.clone()).unwrap();
    }
    n
}

fn task(id: u16, start: MissionTimeUs) -> TaskSpec {
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
        duration_us: 10 * SEC,
        min_duration_us: 10 * SEC,
        earliest_start: start,
        latest_start: start,
        latest_end: MissionTimeUs::MAX,
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: ControlSpec {
            pre_wait_timeout_us: 5 * SEC,
            response_timeout_us: 20 * SEC,
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

fn core(spec: NetworkSpec) -> Box<Autonomy> {
    let mut a = Box::new(Autonomy::new());
    a.load_network(TaskNetwork::from_spec(spec).unwrap())
        .unwrap();
    a.on_state_update(MODE_KEY, StateValue::Enum(0), MissionTimeUs(0));
    a
}

fn step(a: &mut Autonomy, out: &mut Recorder, t: u64) {
    out.now = MissionTimeUs(t * SEC);
    a.step(MissionTimeUs(t * SEC), StepBudget::UNLIMITED, out);
}

fn transitions(out: &Recorder) -> Vec<(u16, TaskState, u64)> {
    out.decisions
        .iter()
        .filter_map(|d| match d {
            Decision::Transition { task, to, at, .. } => Some((*task, *to, at.0 / SEC)),
            _ => None,
        })
        .collect()
}

#[test]
fn failed_command_is_retried_then_the_task_completes() {
    let mut t = task(1, MissionTimeUs(100 * SEC));
    t.control.max_retries = Some(PerCause::uniform(1, FailureKind::RETRYABLE));
    let mut a = core(base(&[t]));
    let mut out = Recorder::default();
    step(&mut a, &mut out, 100);
    let (id, _, _) = out.dispatches[0].clone();
    a.on_command_response(id, CommandStatus::Failed(3));
    step(&mut a, &mut out, 101);
    assert_eq!(out.dispatches.len(), 2, "re-dispatched");
    let (id2, _, _) = out.dispatches[1].clone();
    assert_ne!(id, id2);
    a.on_command_response(id2, CommandStatus::Ok);
    step(&mut a, &mut out, 102);
    step(&mut a, &mut out, 111);
    let tr = transitions(&out);
    assert!(tr.contains(&(1, TaskState::WaitingPre, 101)));
    assert!(tr.contains(&(1, TaskState::Completed, 111)), "{tr:?}");
}

#[test]
fn response_timeout_and_rejection_fail_the_task() {
    let mut a = core(base(&[
        task(1, MissionTimeUs(100 * SEC)),
        task(2, MissionTimeUs(200 * SEC)),
    ]));
    let mut out = Recorder::default();
    step(&mut a, &mut out, 100);
    assert_eq!(
        a.next_wakeup(),
        Some(MissionTimeUs(100 * SEC)),
        "the planner has a report to take in"
    );
    step(&mut a, &mut out, 100);
    assert_eq!(
        a.next_wakeup(),
        Some(MissionTimeUs(110 * SEC)),
        "the end of the duration"
    );
    step(&mut a, &mut out, 120);
    step(&mut a, &mut out, 200);
    let (id, _, _) = out.dispatches[1].clone();
    a.on_command_response(id, CommandStatus::Rejected);
    step(&mut a, &mut out, 201);
    let tr = transitions(&out);
    assert!(
        tr.contains(&(1, TaskState::Failed(FailureKind::ResponseTimeout), 120)),
        "{tr:?}"
    );
    assert!(
        tr.contains(&(2, TaskState::Failed(FailureKind::CommandRejected), 201)),
        "{tr:?}"
    );
}

#[test]
fn task_push_waits_for_pre_constraints_up_to_the_timeout() {
    let on = Requirement::OneOf { mask: 0b10 };
    let mut t1 = task(1, MissionTimeUs(100 * SEC));
    t1.constraints
        .push(ConstraintSpec {
            when: ConstraintWhen::Pre,
            timeline: 0,
            require: on,
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    let mut t2 = t1.clone();
    t2.id = 2;
    t2.earliest_start = MissionTimeUs(200 * SEC);
    t2.latest_start = t2.earliest_start;
    // The planner would refuse PRE constraints it cannot see met; the executive is what is
    // tested here, so the constraint is on a measured timeline the projection keeps at ON.
    let mut a = core(base(&[t1, t2]));
    a.on_state_update(MODE_KEY, StateValue::Enum(1), MissionTimeUs(0));
    let mut out = Recorder::default();
    step(&mut a, &mut out, 1);
    a.on_state_update(MODE_KEY, StateValue::Enum(0), MissionTimeUs(50 * SEC));
    step(&mut a, &mut out, 100);
    a.on_state_update(MODE_KEY, StateValue::Enum(1), MissionTimeUs(103 * SEC));
    step(&mut a, &mut out, 103);
    a.on_state_update(MODE_KEY, StateValue::Enum(0), MissionTimeUs(150 * SEC));
    step(&mut a, &mut out, 200);
    step(&mut a, &mut out, 205);
    let tr = transitions(&out);
    assert!(tr.contains(&(1, TaskState::WaitingPre, 100)), "{tr:?}");
    assert!(
        tr.contains(&(1, TaskState::Dispatched, 103)),
        "pushed by 3 s: {tr:?}"
    );
    assert!(
        tr.contains(&(2, TaskState::Failed(FailureKind::PreTimeout), 205)),
        "{tr:?}"
    );
}

#[test]
fn skip_and_start_conditions_are_boolean_expressions() {
    let mut spec = base(&[]);
    // skip when Mode == 1 OR NOT(key 8 >= 5)
    spec.conditions
        .push(ConditionSpec {
            nodes: heapless::Vec::from_slice(&[
                CondNode::Term {
                    operand: Operand::Timeline(0),
                    op: RelOp::Eq,
                    value: 1,
                },
                CondNode::Term {
                    operand: Operand::State(StateKey(8)),
                    op: RelOp::Ge,
                    value: 5,
                },
                CondNode::Not,
                CondNode::Or,
            ])
            .unwrap(),
        })
        .unwrap();
    let mut t = task(1, MissionTimeUs(100 * SEC));
    t.control.skip_condition = Some(0);
    let mut t2 = task(2, MissionTimeUs(200 * SEC));
    t2.control.skip_condition = Some(0);
    spec.tasks.push(t).unwrap();
    spec.tasks.push(t2).unwrap();
    let mut a = core(spec);
    let mut out = Recorder::default();
    a.on_state_update(StateKey(8), StateValue::Int(7), MissionTimeUs(0));
    step(&mut a, &mut out, 100); // Mode 0, key8 7: not skipped
    a.on_state_update(StateKey(8), StateValue::Int(2), MissionTimeUs(150 * SEC));
    step(&mut a, &mut out, 200); // key8 2: NOT(false) = true: skipped
    let tr = transitions(&out);
    assert!(tr.contains(&(1, TaskState::Dispatched, 100)), "{tr:?}");
    assert!(tr.contains(&(2, TaskState::Skipped, 200)), "{tr:?}");
}

#[test]
fn temporal_constraints_bound_the_start_through_shortest_paths() {
    // B must start 30..60 s after A ends; C must start exactly 10 s after B starts.
    let mut a = task(1, MissionTimeUs(100 * SEC));
    a.command = None;
    let mut b = task(2, MissionTimeUs(0));
    b.command = None;
    b.latest_start = MissionTimeUs(10_000 * SEC);
    let mut c = task(3, MissionTimeUs(0));
    c.command = None;
    c.latest_start = MissionTimeUs(10_000 * SEC);
    let mut spec = base(&[a, b, c]);
    spec.temporal
        .push(TemporalConstraint {
            from_task: 1,
            from_point: TaskPoint::End,
            to_task: 2,
            to_point: TaskPoint::Start,
            min_us: 30_000_000,
            max_us: 60_000_000,
        })
        .unwrap();
    spec.temporal
        .push(TemporalConstraint {
            from_task: 2,
            from_point: TaskPoint::Start,
            to_task: 3,
            to_point: TaskPoint::Start,
            min_us: 10_000_000,
            max_us: 10_000_000,
        })
        .unwrap();
    let net = TaskNetwork::from_spec(spec).unwrap();
    let mut p = Planner::new();
    p.load(&net);
    p.step(
        &net,
        MissionTimeUs(0),
        u32::MAX,
        &mut |_| {},
        &mut Recorder::default(),
    );
    let start = |id: u16| {
        p.entries()
            .iter()
            .find(|e| e.instance == id)
            .unwrap()
            .start
            .0
            / SEC
    };
    assert_eq!((start(1), start(2), start(3)), (100, 140, 150));
}

#[test]
fn rates_integrate_and_bounds_refuse_overdraw() {
    // A task draining 2 units/s for 10 s from 100 units; a second one would overdraw.
    let mut drain = task(1, MissionTimeUs(10 * SEC));
    drain.command = None;
    drain
        .impacts
        .push(ImpactSpec {
            when: ImpactWhen::Maintain,
            timeline: 1,
            effect: Effect::Rate(-6),
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    let mut second = drain.clone();
    second.id = 2;
    second.earliest_start = MissionTimeUs(20 * SEC);
    second.latest_start = MissionTimeUs(20 * SEC);
    let net = TaskNetwork::from_spec(base(&[drain, second])).unwrap();
    let mut p = Planner::new();
    p.load(&net);
    p.step(
        &net,
        MissionTimeUs(0),
        u32::MAX,
        &mut |_| {},
        &mut Recorder::default(),
    );
    let view = p.view(&net);
    assert_eq!(view.value_at(1, MissionTimeUs(15 * SEC)), 70);
    assert_eq!(view.value_at(1, MissionTimeUs(20 * SEC)), 40);
    // 40 left: the second drain of 60 would go below 0, so it stays unscheduled.
    let second = p.entries().iter().find(|e| e.instance == 2).unwrap();
    assert_eq!(second.state, TaskState::Unscheduled);
}

#[test]
fn warm_restart_slots_alternate_with_rising_sequence_numbers() {
    let mut bytes = vec![0u8; 4096];
    let mut area = WarmRestartArea::new(&mut bytes);
    assert!(area.latest().is_none());
    let mut seen = Vec::new();
    for i in 0..4u8 {
        let (slot, seq) = area
            .write(|buf| {
                buf[..3].copy_from_slice(&[i, i, i]);
                Some(3)
            })
            .unwrap();
        seen.push((slot, seq));
        assert_eq!(area.latest().unwrap(), (slot, seq, &[i, i, i][..]));
    }
    assert_eq!(seen, [(0, 1), (1, 2), (0, 3), (1, 4)]);
    assert_eq!(
        area.write(|_| Some(5000)),
        Err(CheckpointError::AreaTooSmall)
    );
    assert_eq!(
        area.latest().unwrap().1,
        4,
        "a failed write leaves the newest record"
    );
    area.invalidate();
    assert!(area.latest().is_none());
}
