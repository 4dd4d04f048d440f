//! The lander capacities (issue 14 item 6) at their limits: a network with exactly
//! [`MAX_TASKS`] tasks validates, loads from its uplink and is planned; one task more is refused
//! with `TooManyTasks` at the site of task 256; a network at every capacity at once (64
//! timelines, 256 tasks of 16 constraints and 16 impacts) validates and loads.
use autonomy::scenarios::{synthetic_into, SyntheticShape, SYNTHETIC_TASK};
use autonomy::uplink::{validate_uplink, ErrorSite, TaskField, ValidationCode};
use autonomy::*;

struct Sink(u32);
impl Outputs for Sink {
    fn dispatch(&mut self, _: u32, _: Opcode, _: &CommandArgs) {
        self.0 += 1;
    }
    fn telemetry(&mut self, _: TelemetryEvent) {}
}

fn spec(shape: SyntheticShape) -> Box<NetworkSpec> {
    let mut spec = Box::new(NetworkSpec::new(0, PlannerConfig::DEFAULT));
    synthetic_into(&mut spec, shape).unwrap();
    spec
}

fn encode(spec: &NetworkSpec) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 21];
    let len = uplink::encode_spec(spec, &mut buf).unwrap();
    buf.truncate(len);
    buf
}

fn postcard_bytes<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 14];
    let len = postcard::to_slice(value, &mut buf).unwrap().len();
    buf.truncate(len);
    buf
}

#[test]
fn a_network_of_exactly_max_tasks_validates_loads_and_is_planned() {
    let spec = spec(SyntheticShape::bench(MAX_TASKS));
    assert_eq!(spec.tasks.len(), MAX_TASKS);
    let bytes = encode(&spec);
    validate_uplink(&bytes).unwrap();
    let mut core = Box::new(Autonomy::new());
    core.load_uplink(&bytes).unwrap();
    assert_eq!(core.network().tasks().len(), MAX_TASKS);
    // Every definition index fits the `u8` the plan uses, the last one included.
    assert_eq!(
        core.network().def_of_id(MAX_TASKS as u16),
        Some((MAX_TASKS - 1) as u8)
    );
    let mut sink = Sink(0);
    let report = core.step(MissionTimeUs::ZERO, StepBudget::UNLIMITED, &mut sink);
    assert!(!report.planner_pending);
    let plan = core.plan();
    assert_eq!(plan.len(), MAX_TASKS, "one instance per requested task");
    let placed = plan
        .iter()
        .filter(|e| matches!(e.state, TaskState::Scheduled | TaskState::Committed))
        .count();
    assert_eq!(
        placed, MAX_TASKS,
        "every task placed in its day-long window"
    );
    let stats = core.planner().stats;
    assert_eq!((stats.plan_full, stats.dropped_reports), (0, 0));
    // Two tasks on one resource never overlap (the claim holds).
    for (i, a) in plan.iter().enumerate() {
        for b in &plan[i + 1..] {
            if usize::from(a.def) % 8 == usize::from(b.def) % 8 {
                assert!(a.end <= b.start || b.end <= a.start, "{a:?} overlaps {b:?}");
            }
        }
    }
    // The executive takes what starts in the commit window and dispatches it as time passes.
    let later = MissionTimeUs(3 * 3_600_000_000);
    core.step(later, StepBudget::UNLIMITED, &mut sink);
    assert!(sink.0 > 0, "tasks dispatched by {later:?}");
}

#[test]
fn one_task_over_max_tasks_is_refused_with_too_many_tasks_at_its_site() {
    // The spec itself cannot hold a 257th task.
    let mut over = Box::new(NetworkSpec::new(0, PlannerConfig::DEFAULT));
    assert!(synthetic_into(&mut over, SyntheticShape::bench(MAX_TASKS + 1)).is_err());
    // An uplink that announces 257 tasks and carries them: a ground tool with larger lists.
    let spec = spec(SyntheticShape::bench(MAX_TASKS));
    let mut head = spec.clone();
    head.tasks.clear();
    head.temporal.clear();
    let mut bytes = encode(&head);
    bytes.truncate(bytes.len() - 4); // "0 tasks, 0 temporal, 0 timed values, 0 parameters"
    bytes.extend(postcard_bytes(&((MAX_TASKS + 1) as u16)));
    for t in &spec.tasks {
        bytes.extend(postcard_bytes(t));
    }
    let mut extra = spec.tasks[0].clone();
    extra.id = (MAX_TASKS + 1) as u16;
    bytes.extend(postcard_bytes(&extra));
    bytes.extend(postcard_bytes(&0u16));
    bytes.extend(postcard_bytes(&0u16));
    bytes.extend(postcard_bytes(&0u16));
    let e = validate_uplink(&bytes).unwrap_err();
    assert_eq!(e.code, ValidationCode::TooManyTasks);
    assert_eq!(
        e.site,
        ErrorSite::Task {
            task: MAX_TASKS as u16,
            field: TaskField::Whole
        }
    );
    // The code reaches the host as the UplinkNak reason, and nothing changes.
    let mut core = Box::new(Autonomy::new());
    match core.load_uplink(&bytes) {
        Err(LoadError::Invalid(e)) => assert_eq!(e.code.code(), 11),
        other => panic!("{other:?}"),
    }
    assert!(core.network().tasks().is_empty());
}

#[test]
fn a_network_at_every_capacity_at_once_validates_and_loads() {
    let spec = spec(SyntheticShape::at_capacity());
    assert_eq!(spec.timelines.len(), MAX_TIMELINES);
    assert!(spec
        .tasks
        .iter()
        .all(|t| t.constraints.len() == MAX_CONSTRAINTS_PER_TASK
            && t.impacts.len() == MAX_IMPACTS_PER_TASK));
    let bytes = encode(&spec);
    validate_uplink(&bytes).unwrap();
    let mut core = Box::new(Autonomy::new());
    core.load_uplink(&bytes).unwrap();
    assert_eq!(core.network().spec(), &*spec);
    // The last timeline and the last impact of the last task are where they should be.
    let last = core.network().tasks().last().unwrap();
    assert_eq!(last.command.as_ref().unwrap().opcode, SYNTHETIC_TASK);
    assert!(last
        .impacts
        .iter()
        .all(|m| usize::from(m.timeline) < MAX_TIMELINES));
    // A 17th constraint or impact does not fit a task.
    let mut t = spec.tasks[0].clone();
    assert!(t.constraints.push(t.constraints[0]).is_err());
    assert!(t.impacts.push(t.impacts[0]).is_err());
}

/// Impacts 8 to 15 of a task take part in the timelines' tie-break order (an event key keeps 4
/// bits of impact index since tasks hold 16 impacts): the events of one instance at one
/// instant are keyed in impact order, each impact with its own key, and carry the instance.
#[test]
fn events_of_sixteen_impacts_keep_their_order_and_instance() {
    let spec = spec(SyntheticShape::at_capacity());
    let task = &spec.tasks[0];
    let instance = FIRST_INSTANCE_ID + 7;
    let span = plan::Contribution {
        start: MissionTimeUs(1_000_000),
        end: MissionTimeUs(2_000_000),
        post: true,
    };
    let mut first_key = Vec::new();
    for (j, m) in task.impacts.iter().enumerate() {
        let mut seen = Vec::new();
        timeline::impact_events(task, instance, span, m.timeline, &mut |ev| seen.push(ev));
        assert!(
            seen.iter().all(|ev| ev.instance() == instance),
            "impact {j}"
        );
        let own = seen
            .iter()
            .filter(|ev| ev.at == span.start || ev.at == span.end)
            .map(|ev| ev.seq)
            .min()
            .unwrap();
        first_key.push(own);
    }
    assert_eq!(first_key.len(), MAX_IMPACTS_PER_TASK);
    assert!(
        first_key.windows(2).all(|w| w[0] < w[1]),
        "keys in impact order, all distinct: {first_key:?}"
    );
}
