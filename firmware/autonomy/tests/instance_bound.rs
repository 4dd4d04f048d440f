//! Model expressiveness (issue 11 item 8 e, g): temporal constraints between a template's
//! instances and a requested task, honoured by the planner's placement and by the executive
//! at dispatch, and command arguments the executive takes from the instance it dispatches
//! (the served task's site and target, the end as executed). Each through the uplink (encode,
//! validate, decode) and the core's behaviour, with the target's refusals of what the format
//! forbids.
mod common;
use autonomy::uplink::{validate_uplink, ErrorSite, TaskField, ValidationCode};
use autonomy::*;
use common::*;

const OP_HEAT: Opcode = Opcode(0x0501);
const OP_PASS: Opcode = Opcode(0x0401);
const OP_POINT: Opcode = Opcode(0x0101);

const TL_ANTENNA: u8 = 0;
const EARTH: Requirement = Requirement::OneOf { mask: 0b10 };

const HEAT: u16 = 1;
const PASS: u16 = 2;
const POINT: u16 = 10;

fn task(
    id: u16,
    role: TaskRole,
    opcode: Opcode,
    args: &[i32],
    window: (u64, u64),
    duration: u64,
) -> TaskSpec {
    TaskSpec {
        id,
        name: Name::try_from(format!("t{id}").as_str()).unwrap(),
        priority: 0,
        role,
        command: Some(CommandSpec::fixed(
            opcode,
            CommandArgs::from_slice(args).unwrap(),
        )),
        duration_us: duration * SEC,
        min_duration_us: duration * SEC,
        earliest_start: MissionTimeUs(window.0 * SEC),
        latest_start: if window.1 == u64::MAX {
            MissionTimeUs::MAX
        } else {
            MissionTimeUs(window.1 * SEC)
        },
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
            may_move: true,
            may_delete: false,
            may_add: heapless::Vec::new(),
        },
    }
}

/// Antenna (STOWED, EARTH; only the planner knows it); Heat (requested at 10 s, 100 s);
/// Pass (requested from 0 s to 1000 s, 100 s, needs the antenna at EARTH, may add Point,
/// site 7 and target 3 in its arguments); Point (template, 50 s, points the antenna at
/// EARTH, arguments: 1, then the served task's two, then its end in seconds).
fn network(temporal: &[TemporalConstraint]) -> NetworkSpec {
    let mut n = NetworkSpec::new(12, PlannerConfig::DEFAULT);
    n.timelines
        .push(TimelineSpec::internal(
            Name::try_from("Antenna").unwrap(),
            TimelineKind::State {
                value_count: 2,
                initial: 0,
            },
        ))
        .unwrap();
    let heat = task(HEAT, TaskRole::Requested, OP_HEAT, &[], (10, 10), 100);
    let mut pass = task(PASS, TaskRole::Requested, OP_PASS, &[7, 3], (0, 1000), 100);
    pass.constraints
        .push(ConstraintSpec {
            when: ConstraintWhen::Pre,
            timeline: TL_ANTENNA,
            require: EARTH,
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    pass.permissions.may_add.push(POINT).unwrap();
    let mut point = task(POINT, TaskRole::Template, OP_POINT, &[1], (0, u64::MAX), 50);
    point
        .impacts
        .push(ImpactSpec {
            when: ImpactWhen::Post,
            timeline: TL_ANTENNA,
            effect: Effect::Assign(1),
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    let command = point.command.as_mut().unwrap();
    for a in [
        InstanceArg::Served(0),
        InstanceArg::Served(1),
        InstanceArg::EndS,
    ] {
        command.from_instance.push(a).unwrap();
    }
    for t in [heat, pass, point] {
        n.tasks.push(t).unwrap();
    }
    for tc in temporal {
        n.temporal.push(*tc).unwrap();
    }
    n
}

/// Point starts at least 60 s (at most 1000 s) after Heat ends.
const AFTER_HEAT: TemporalConstraint = TemporalConstraint {
    from_task: HEAT,
    from_point: TaskPoint::End,
    to_task: POINT,
    to_point: TaskPoint::Start,
    min_us: 60 * SEC as i64,
    max_us: 1000 * SEC as i64,
};

/// Runs the core one step a second for `seconds`, answering each command Ok when `answer_at`
/// says (by opcode; default at once). Returns every dispatch: (second, opcode, args).
fn run(
    network: TaskNetwork,
    seconds: u64,
    answer_at: &dyn Fn(Opcode, u64) -> u64,
) -> Vec<(u64, u16, Vec<i32>)> {
    let mut a = Box::new(Autonomy::new());
    a.load_network(network).unwrap();
    let mut out = Recorder::default();
    let mut pending: Vec<(u64, u32)> = Vec::new();
    let mut seen = 0;
    for t in 0..=seconds {
        pending.retain(|&(at, id)| {
            if at <= t {
                a.on_command_response(id, CommandStatus::Ok);
                false
            } else {
                true
            }
        });
        out.now = MissionTimeUs(t * SEC);
        a.step(MissionTimeUs(t * SEC), StepBudget::UNLIMITED, &mut out);
        while seen < out.dispatches.len() {
            let (id, opcode, _) = out.dispatches[seen];
            let at = answer_at(opcode, t);
            if at <= t {
                a.on_command_response(id, CommandStatus::Ok);
            } else {
                pending.push((at, id));
            }
            seen += 1;
        }
    }
    out.decisions
        .iter()
        .filter_map(|d| match d {
            Decision::Dispatch {
                at, opcode, args, ..
            } => Some((at.0 / SEC, opcode.0, args.to_vec())),
            _ => None,
        })
        .collect()
}

fn at_once(_: Opcode, t: u64) -> u64 {
    t
}

fn starts(dispatches: &[(u64, u16, Vec<i32>)], opcode: Opcode) -> Vec<u64> {
    dispatches
        .iter()
        .filter(|d| d.1 == opcode.0)
        .map(|d| d.0)
        .collect()
}

#[test]
fn without_the_constraint_the_helper_is_placed_as_early_as_it_is_valid() {
    // The reference the next test differs from: Point at once (0 s), Pass when it ends.
    let d = run(uplinked(network(&[])), 400, &at_once);
    assert_eq!(starts(&d, OP_POINT), vec![0]);
    assert_eq!(starts(&d, OP_PASS), vec![50]);
}

#[test]
fn a_template_instance_starts_at_least_60_s_after_the_end_of_a_requested_task() {
    // Heat 10-110 s; Point from 170 s (110 + 60), to 220 s; Pass when the antenna is there.
    let d = run(uplinked(network(&[AFTER_HEAT])), 400, &at_once);
    assert_eq!(starts(&d, OP_HEAT), vec![10]);
    assert_eq!(starts(&d, OP_POINT), vec![170]);
    assert_eq!(starts(&d, OP_PASS), vec![220]);
}

#[test]
fn a_template_instance_starts_within_bounds_of_the_start_of_a_request() {
    // "Within [20 s, 40 s] of the start of Heat" (10 s): from 30 s.
    let within = TemporalConstraint {
        from_task: HEAT,
        from_point: TaskPoint::Start,
        to_task: POINT,
        to_point: TaskPoint::Start,
        min_us: 20 * SEC as i64,
        max_us: 40 * SEC as i64,
    };
    let d = run(uplinked(network(&[within])), 400, &at_once);
    assert_eq!(starts(&d, OP_POINT), vec![30]);
    assert_eq!(starts(&d, OP_PASS), vec![80]);
    // The same written from the template's side (Heat start - Point start in [-40 s, -20 s]).
    let reversed = TemporalConstraint {
        from_task: POINT,
        from_point: TaskPoint::Start,
        to_task: HEAT,
        to_point: TaskPoint::Start,
        min_us: -40 * SEC as i64,
        max_us: -20 * SEC as i64,
    };
    let d = run(uplinked(network(&[reversed])), 400, &at_once);
    assert_eq!(starts(&d, OP_POINT), vec![30]);
}

#[test]
fn the_executive_holds_the_helper_until_60_s_after_a_late_end() {
    // Heat's command is answered only at 200 s, so it ends at 200 s instead of 110 s; Point,
    // committed for 170 s, waits for Heat's end and then 60 s: 260 s.
    let late_heat = |op: Opcode, t: u64| if op == OP_HEAT { 200 } else { t };
    let d = run(uplinked(network(&[AFTER_HEAT])), 500, &late_heat);
    assert_eq!(starts(&d, OP_HEAT), vec![10]);
    assert_eq!(starts(&d, OP_POINT), vec![260]);
}

#[test]
fn the_helper_command_carries_the_served_task_arguments_and_its_end() {
    let d = run(uplinked(network(&[AFTER_HEAT])), 400, &at_once);
    let point: Vec<&Vec<i32>> = d
        .iter()
        .filter(|x| x.1 == OP_POINT.0)
        .map(|x| &x.2)
        .collect();
    // Its fixed 1, the Pass's site 7 and target 3, its end (170 + 50 s).
    assert_eq!(point, vec![&vec![1, 7, 3, 220]]);
    // The requested tasks' commands are as written.
    let pass: Vec<&Vec<i32>> = d
        .iter()
        .filter(|x| x.1 == OP_PASS.0)
        .map(|x| &x.2)
        .collect();
    assert_eq!(pass, vec![&vec![7, 3]]);
}

#[test]
fn a_restart_shortens_the_end_its_command_carries() {
    // A requested 100 s task that must end by 150 s (at least 50 s long), whose command
    // carries its end and duration. Its first command is rejected only at 70 s; the restart
    // at 70 s has 80 s left: its command says so.
    let mut n = network(&[]);
    n.tasks.clear();
    n.timelines.clear();
    let mut t = task(5, TaskRole::Requested, OP_HEAT, &[9], (10, 100), 100);
    t.min_duration_us = 50 * SEC;
    t.latest_end = MissionTimeUs(150 * SEC);
    t.contingencies
        .push(Contingency {
            on: FailureKind::CommandRejected.bit(),
            action: ContingencyAction::Restart,
        })
        .unwrap();
    let command = t.command.as_mut().unwrap();
    for a in [
        InstanceArg::EndS,
        InstanceArg::DurationS,
        InstanceArg::Served(0),
    ] {
        command.from_instance.push(a).unwrap();
    }
    n.tasks.push(t).unwrap();
    let network = uplinked(n);
    let mut a = Box::new(Autonomy::new());
    a.load_network(network).unwrap();
    let mut out = Recorder::default();
    let mut seen = 0;
    for s in 0..=300u64 {
        if s == 70 {
            a.on_command_response(out.dispatches[0].0, CommandStatus::Rejected);
        }
        out.now = MissionTimeUs(s * SEC);
        a.step(MissionTimeUs(s * SEC), StepBudget::UNLIMITED, &mut out);
        while seen < out.dispatches.len() {
            if seen > 0 {
                a.on_command_response(out.dispatches[seen].0, CommandStatus::Ok);
            }
            seen += 1;
        }
    }
    let d: Vec<(u64, Vec<i32>)> = out
        .decisions
        .iter()
        .filter_map(|d| match d {
            Decision::Dispatch { at, args, .. } => Some((at.0 / SEC, args.to_vec())),
            _ => None,
        })
        .collect();
    // First attempt: 10 s to 110 s, 100 s; it serves no other task (-1).
    // The restart serves the failed instance (the same definition: its argument 9); its end
    // is the latest end, 150 s, which shortened it to 80 s.
    assert_eq!(
        d,
        vec![(10, vec![9, 110, 100, -1]), (70, vec![9, 150, 80, 9])],
        "{:?}",
        out.decisions
    );
}

fn rejected(spec: &NetworkSpec) -> (ValidationCode, ErrorSite) {
    let mut buf = vec![0u8; 1 << 16];
    let len = autonomy::uplink::encode_spec(spec, &mut buf).unwrap();
    let e = validate_uplink(&buf[..len]).unwrap_err();
    let f = TaskNetwork::from_spec(spec.clone()).unwrap_err();
    assert_eq!(e, f, "the uplink and the in-memory validation agree");
    (e.code, e.site)
}

#[test]
fn temporal_constraints_the_format_forbids_are_refused_with_their_reason() {
    // A task that does not exist.
    let unknown = TemporalConstraint {
        to_task: 99,
        ..AFTER_HEAT
    };
    assert_eq!(
        rejected(&network(&[unknown])),
        (ValidationCode::DanglingTemporalTask, ErrorSite::Temporal(0))
    );
    // The same task on both sides.
    let same = TemporalConstraint {
        from_task: POINT,
        ..AFTER_HEAT
    };
    assert_eq!(
        rejected(&network(&[same])),
        (ValidationCode::DanglingTemporalTask, ErrorSite::Temporal(0))
    );
    // Two templates.
    let mut n = network(&[]);
    let mut other = n.tasks[2].clone();
    other.id = 11;
    other.name = Name::try_from("t11").unwrap();
    n.tasks.push(other).unwrap();
    n.temporal
        .push(TemporalConstraint {
            from_task: 11,
            ..AFTER_HEAT
        })
        .unwrap();
    assert_eq!(
        rejected(&n),
        (ValidationCode::TemporalTemplatePair, ErrorSite::Temporal(0))
    );
    // Bad bounds.
    let bad = TemporalConstraint {
        min_us: 10 * SEC as i64,
        max_us: 5 * SEC as i64,
        ..AFTER_HEAT
    };
    assert_eq!(
        rejected(&network(&[bad])),
        (ValidationCode::BadTemporalBounds, ErrorSite::Temporal(0))
    );
    // A cycle no schedule meets: Point after Heat's end by 60 s, and Heat's start after
    // Point's end: refused at the constraint that closes it.
    let back = TemporalConstraint {
        from_task: POINT,
        from_point: TaskPoint::End,
        to_task: HEAT,
        to_point: TaskPoint::Start,
        min_us: 0,
        max_us: 1000 * SEC as i64,
    };
    assert_eq!(
        rejected(&network(&[AFTER_HEAT, back])),
        (ValidationCode::TemporalCycle, ErrorSite::Temporal(1))
    );
    // A consistent cycle is fine (Point exactly 60 s after Heat, said both ways).
    let both_ways = TemporalConstraint {
        from_task: POINT,
        from_point: TaskPoint::Start,
        to_task: HEAT,
        to_point: TaskPoint::End,
        min_us: -60 * SEC as i64,
        max_us: -60 * SEC as i64,
    };
    assert!(TaskNetwork::from_spec(network(&[AFTER_HEAT, both_ways])).is_ok());
}

#[test]
fn instance_arguments_that_cannot_exist_are_refused() {
    // Served(4): there is no fifth argument.
    let mut n = network(&[]);
    let command = n.tasks[2].command.as_mut().unwrap();
    command.from_instance.clear();
    command.from_instance.push(InstanceArg::Served(4)).unwrap();
    let site = ErrorSite::Task {
        task: 2,
        field: TaskField::Command,
    };
    assert_eq!(rejected(&n), (ValidationCode::BadInstanceArg, site));
    // Five in all (two fixed, three from the instance).
    let mut n = network(&[]);
    let command = n.tasks[2].command.as_mut().unwrap();
    command.args.push(2).unwrap();
    assert_eq!(rejected(&n), (ValidationCode::BadInstanceArg, site));
    // On the failure command too.
    let mut n = network(&[]);
    let mut on_failure = CommandSpec::fixed(OP_POINT, CommandArgs::new());
    on_failure
        .from_instance
        .push(InstanceArg::Served(7))
        .unwrap();
    n.tasks[0].control.on_failure_command = Some(on_failure);
    assert_eq!(
        rejected(&n),
        (
            ValidationCode::BadInstanceArg,
            ErrorSite::Task {
                task: 0,
                field: TaskField::Control,
            }
        )
    );
}

#[test]
fn the_format_version_is_5_and_4_is_refused() {
    assert_eq!(UPLINK_FORMAT_VERSION, 5);
    let mut n = network(&[AFTER_HEAT]);
    n.header.format_version = 4;
    assert_eq!(
        rejected(&n),
        (ValidationCode::FormatVersion, ErrorSite::Network)
    );
}
