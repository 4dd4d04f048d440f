//! Model expressiveness (issue 11 item 8): external availability timelines fed as timed
//! values, background rates on cumulative timelines, state values derived from integer
//! measurements by thresholds, and more than 4 constraints and impacts per task. Each is
//! checked through the uplink (encode, validate, decode) and through the core's behaviour.
mod common;
use autonomy::timeline::{Measurement, PlanView, TimelineAnchor};
use autonomy::uplink::{decode_into, validate_uplink, ErrorSite, TaskField, ValidationCode};
use autonomy::*;
use common::*;

const OP: Opcode = Opcode(0x0400);
const THERMAL_KEY: StateKey = StateKey(9);

// Timeline indices of `network`.
const TL_VIEW: u8 = 0;
const TL_BATTERY: u8 = 1;
const TL_THERMAL: u8 = 2;

fn timeline(name: &str, kind: TimelineKind) -> TimelineSpec {
    TimelineSpec::internal(Name::try_from(name).unwrap(), kind)
}

/// EarthInView (external: NO, YES from 200 s, NO from 400 s), Battery (1000, draining 1 a
/// second in the background), TransmitterTemp (COLD below 250, WARM from 250, measured).
fn network(tasks: &[TaskSpec]) -> NetworkSpec {
    let mut n = NetworkSpec::new(8, PlannerConfig::DEFAULT);
    let mut view = timeline(
        "EarthInView",
        TimelineKind::State {
            value_count: 2,
            initial: 0,
        },
    );
    view.external = true;
    n.timelines.push(view).unwrap();
    let mut battery = timeline(
        "Battery",
        TimelineKind::Cumulative {
            initial: 1000,
            min: 0,
            max: 1000,
        },
    );
    battery.background_rate = -1;
    n.timelines.push(battery).unwrap();
    let mut thermal = timeline(
        "TransmitterTemp",
        TimelineKind::State {
            value_count: 2,
            initial: 0,
        },
    );
    thermal.state_key = Some(THERMAL_KEY);
    thermal.thresholds.push(250).unwrap();
    n.timelines.push(thermal).unwrap();
    for (at, value) in [(0, 0), (200, 1), (400, 0)] {
        n.timed
            .push(TimedValue {
                timeline: TL_VIEW,
                at: MissionTimeUs(at * SEC),
                value,
            })
            .unwrap();
    }
    for t in tasks {
        n.tasks.push(t.clone()).unwrap();
    }
    n
}

fn task(id: u16, earliest: u64, latest: u64, duration: u64) -> TaskSpec {
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
        duration_us: duration * SEC,
        min_duration_us: duration * SEC,
        earliest_start: MissionTimeUs(earliest * SEC),
        latest_start: MissionTimeUs(latest * SEC),
        latest_end: MissionTimeUs::MAX,
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: ControlSpec {
            pre_wait_timeout_us: 5 * SEC,
            response_timeout_us: 2 * duration * SEC,
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

fn pre(timeline: u8, require: Requirement) -> ConstraintSpec {
    ConstraintSpec {
        when: ConstraintWhen::Pre,
        timeline,
        require,
        start_offset_us: 0,
        end_offset_us: 0,
    }
}

fn maintain(timeline: u8, require: Requirement) -> ConstraintSpec {
    ConstraintSpec {
        when: ConstraintWhen::Maintain,
        ..pre(timeline, require)
    }
}

const IN_VIEW: Requirement = Requirement::OneOf { mask: 0b10 };
const WARM: Requirement = Requirement::OneOf { mask: 0b10 };

/// Runs the core over `seconds`, one step a second, answering every command Ok at once;
/// returns the mission seconds at which commands were dispatched.
fn dispatch_times(
    network: TaskNetwork,
    seconds: u64,
    measure: &[(u64, StateValue)],
) -> (Vec<u64>, Box<Autonomy>) {
    let mut a = Box::new(Autonomy::new());
    a.load_network(network).unwrap();
    let mut out = Recorder::default();
    let mut answered = 0;
    for t in 0..=seconds {
        for &(at, v) in measure {
            if at == t {
                a.on_state_update(THERMAL_KEY, v, MissionTimeUs(t * SEC));
            }
        }
        out.now = MissionTimeUs(t * SEC);
        a.step(MissionTimeUs(t * SEC), StepBudget::UNLIMITED, &mut out);
        while answered < out.dispatches.len() {
            a.on_command_response(out.dispatches[answered].0, CommandStatus::Ok);
            answered += 1;
        }
    }
    let times = out
        .decisions
        .iter()
        .filter_map(|d| match d {
            Decision::Dispatch { at, .. } => Some(at.0 / SEC),
            _ => None,
        })
        .collect();
    (times, a)
}

#[test]
fn external_timeline_holds_its_timed_values_in_the_plan_view() {
    let n = uplinked(network(&[]));
    let anchors: Vec<TimelineAnchor> = n.timelines().iter().map(TimelineAnchor::initial).collect();
    let view = PlanView::new(&n, &[], &anchors);
    let at = |s: u64| view.value_at(TL_VIEW, MissionTimeUs(s * SEC));
    assert_eq!(
        [at(0), at(199), at(200), at(399), at(400), at(900)],
        [0, 0, 1, 1, 0, 0]
    );
    assert!(view.holds_over(
        TL_VIEW,
        &IN_VIEW,
        MissionTimeUs(200 * SEC),
        MissionTimeUs(400 * SEC)
    ));
    assert!(!view.holds_over(
        TL_VIEW,
        &IN_VIEW,
        MissionTimeUs(300 * SEC),
        MissionTimeUs(401 * SEC)
    ));
}

#[test]
fn a_downlink_waits_for_the_window_and_one_longer_than_the_window_never_runs() {
    // Needs the window for its whole 100 s: placed at the window's opening, 200 s.
    let mut fits = task(1, 0, 1000, 100);
    fits.constraints.push(pre(TL_VIEW, IN_VIEW)).unwrap();
    fits.constraints.push(maintain(TL_VIEW, IN_VIEW)).unwrap();
    let (times, _) = dispatch_times(uplinked(network(&[fits.clone()])), 600, &[]);
    assert_eq!(times, vec![200]);
    // 250 s does not fit the 200 s window: never dispatched.
    let mut too_long = fits;
    too_long.duration_us = 250 * SEC;
    too_long.min_duration_us = 250 * SEC;
    too_long.control.response_timeout_us = 500 * SEC;
    let (times, _) = dispatch_times(uplinked(network(&[too_long])), 600, &[]);
    assert!(times.is_empty(), "{times:?}");
}

#[test]
fn background_rate_drains_a_cumulative_timeline_from_its_anchor_and_from_a_measurement() {
    let n = uplinked(network(&[]));
    let mut anchors: Vec<TimelineAnchor> =
        n.timelines().iter().map(TimelineAnchor::initial).collect();
    assert_eq!(anchors[usize::from(TL_BATTERY)].rate, -1);
    let v = |anchors: &[TimelineAnchor], s: u64| {
        PlanView::new(&n, &[], anchors).value_at(TL_BATTERY, MissionTimeUs(s * SEC))
    };
    assert_eq!(v(&anchors, 0), 1000);
    assert_eq!(v(&anchors, 200), 800);
    // A measurement re-anchors the value; the background rate keeps integrating from it.
    anchors[usize::from(TL_BATTERY)].measured = Some(Measurement {
        value: 500,
        at: MissionTimeUs(100 * SEC),
    });
    assert_eq!(v(&anchors, 300), 300);
}

#[test]
fn background_rate_keeps_a_task_that_needs_charge_from_starting_late() {
    // PRE battery >= 900: at 50 s the battery holds 950, at 200 s 800.
    let early = {
        let mut t = task(1, 50, 50, 10);
        t.constraints
            .push(pre(
                TL_BATTERY,
                Requirement::Range {
                    min: 900,
                    max: 1000,
                },
            ))
            .unwrap();
        t
    };
    let late = TaskSpec {
        id: 2,
        earliest_start: MissionTimeUs(200 * SEC),
        latest_start: MissionTimeUs(200 * SEC),
        ..early.clone()
    };
    let (times, _) = dispatch_times(uplinked(network(&[early, late])), 300, &[]);
    assert_eq!(times, vec![50]);
}

#[test]
fn thresholds_derive_a_state_from_an_integer_measurement() {
    let mut t = task(1, 20, 20, 10);
    t.constraints.push(pre(TL_THERMAL, WARM)).unwrap();
    let n = uplinked(network(&[t]));
    assert_eq!(
        n.timelines()[2].measured_value_type(),
        Some(MeasuredValueType::Int)
    );
    // Warm (260 >= 250): the task starts at 20 s, and the integer is no type mismatch.
    let (times, a) = dispatch_times(n.clone(), 40, &[(0, StateValue::Int(260))]);
    assert_eq!(times, vec![20]);
    assert_eq!(a.state_type_mismatches(), 0);
    // Cold (249): it never starts.
    let (times, a) = dispatch_times(n.clone(), 40, &[(0, StateValue::Int(249))]);
    assert!(times.is_empty(), "{times:?}");
    assert_eq!(a.state_type_mismatches(), 0);
    // Cold, then warm at 10 s: the planner sees the derived WARM and it starts at 20 s.
    let (times, _) = dispatch_times(
        n,
        40,
        &[(0, StateValue::Int(100)), (10, StateValue::Int(300))],
    );
    assert_eq!(times, vec![20]);
}

#[test]
fn a_condition_reads_the_derived_state() {
    let mut spec = network(&[]);
    spec.conditions
        .push(ConditionSpec {
            nodes: heapless::Vec::from_slice(&[CondNode::Term {
                operand: Operand::Timeline(TL_THERMAL),
                op: RelOp::Eq,
                value: 1,
            }])
            .unwrap(),
        })
        .unwrap();
    let mut t = task(1, 20, 20, 10);
    t.control.start_condition = Some(0);
    spec.tasks.push(t).unwrap();
    let n = uplinked(spec);
    let (times, _) = dispatch_times(n.clone(), 40, &[(0, StateValue::Int(400))]);
    assert_eq!(times, vec![20]);
    let (times, _) = dispatch_times(n, 40, &[(0, StateValue::Int(-40))]);
    assert!(times.is_empty());
}

#[test]
fn sixteen_constraints_and_impacts_per_task_pass_the_uplink_and_seventeen_are_refused() {
    let mut spec = network(&[]);
    for i in 0..4u8 {
        let mut tl = timeline(
            &format!("Count{i}"),
            TimelineKind::Cumulative {
                initial: 0,
                min: 0,
                max: 100,
            },
        );
        tl.background_rate = 0;
        spec.timelines.push(tl).unwrap();
    }
    let mut t = task(1, 0, 100, 10);
    for i in 0..16u8 {
        t.constraints
            .push(maintain(3 + i % 4, Requirement::Range { min: 0, max: 100 }))
            .unwrap();
        t.impacts
            .push(ImpactSpec {
                when: ImpactWhen::Maintain,
                timeline: 3 + i % 4,
                effect: Effect::Add(1),
                start_offset_us: 0,
                end_offset_us: 0,
            })
            .unwrap();
    }
    spec.tasks.push(t).unwrap();
    let n = uplinked(spec.clone());
    assert_eq!(n.tasks()[0].constraints.len(), 16);
    assert_eq!(n.tasks()[0].impacts.len(), 16);
    // While it runs each Count timeline holds 4 (four impacts each, all in effect).
    let (times, _) = dispatch_times(n, 20, &[]);
    assert_eq!(times, vec![0]);
    // A 17th of either is refused with its capacity code.
    let bytes = encode(&spec);
    let raw = raise_last_list_count(&bytes, &spec);
    assert!(matches!(
        validate_uplink(&raw).unwrap_err().code,
        ValidationCode::TooManyConstraints
            | ValidationCode::TooManyImpacts
            | ValidationCode::Decode
    ));
}

fn encode(spec: &NetworkSpec) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 16];
    let len = autonomy::uplink::encode_spec(spec, &mut buf).unwrap();
    buf.truncate(len);
    buf
}

/// The uplink of `spec` with its one task's constraint count byte (16, one varint byte)
/// raised to 17: found as the only 16 that, raised, gives `TooManyConstraints`.
fn raise_last_list_count(bytes: &[u8], _spec: &NetworkSpec) -> Vec<u8> {
    for i in 0..bytes.len() {
        if bytes[i] == 16 {
            let mut b = bytes.to_vec();
            b[i] = 17;
            if let Err(e) = validate_uplink(&b) {
                if e.code == ValidationCode::TooManyConstraints {
                    assert_eq!(
                        e.site,
                        ErrorSite::Task {
                            task: 0,
                            field: TaskField::Constraint(16)
                        }
                    );
                    return b;
                }
            }
        }
    }
    panic!("no constraint count found");
}

fn refused(spec: NetworkSpec) -> (ValidationCode, ErrorSite) {
    let e = TaskNetwork::from_spec(spec.clone()).unwrap_err();
    // The binary path refuses the same bytes with the same code and site.
    let b = encode(&spec);
    assert_eq!(validate_uplink(&b).unwrap_err(), e);
    (e.code, e.site)
}

#[test]
fn validation_refuses_misuse_of_the_new_fields_with_a_reason() {
    use ValidationCode::*;
    // A task may not impact an external timeline.
    let mut t = task(1, 0, 100, 10);
    t.impacts
        .push(ImpactSpec {
            when: ImpactWhen::Post,
            timeline: TL_VIEW,
            effect: Effect::Assign(1),
            start_offset_us: 0,
            end_offset_us: 0,
        })
        .unwrap();
    assert_eq!(
        refused(network(&[t])),
        (
            ExternalTimeline,
            ErrorSite::Task {
                task: 0,
                field: TaskField::Impact(0)
            }
        )
    );
    // Timed values out of order, on a timeline that is not external, or out of its values.
    let mut s = network(&[]);
    s.timed[2].at = MissionTimeUs(100 * SEC);
    assert_eq!(refused(s), (BadTimedValue, ErrorSite::TimedValue(2)));
    let mut s = network(&[]);
    s.timed[1].timeline = TL_BATTERY;
    assert_eq!(refused(s), (BadTimedValue, ErrorSite::TimedValue(1)));
    let mut s = network(&[]);
    s.timed[1].value = 2;
    assert_eq!(refused(s), (ValueOutOfRange, ErrorSite::TimedValue(1)));
    let mut s = network(&[]);
    s.timed[1].timeline = 40;
    assert_eq!(refused(s), (DanglingTimeline, ErrorSite::TimedValue(1)));
    // A claimable external timeline.
    let mut s = network(&[]);
    let mut c = timeline("Station", TimelineKind::Claimable);
    c.external = true;
    s.timelines.push(c).unwrap();
    assert_eq!(refused(s), (ExternalTimeline, ErrorSite::Timeline(3)));
    // A background rate on a state timeline, or over the magnitude bound.
    let mut s = network(&[]);
    s.timelines[0].background_rate = 1;
    assert_eq!(refused(s), (BadBackgroundRate, ErrorSite::Timeline(0)));
    let mut s = network(&[]);
    s.timelines[1].background_rate = MAX_MAGNITUDE + 1;
    assert_eq!(refused(s), (BadBackgroundRate, ErrorSite::Timeline(1)));
    // Thresholds: not increasing, wrong count, unmeasured, on a cumulative timeline.
    let site = ErrorSite::TimelineThresholds(2);
    let mut s = network(&[]);
    s.timelines[2].thresholds.push(250).unwrap();
    assert_eq!(refused(s), (BadThresholds, site));
    let mut s = network(&[]);
    s.timelines[2].thresholds.push(300).unwrap();
    assert_eq!(refused(s), (BadThresholds, site));
    let mut s = network(&[]);
    s.timelines[2].state_key = None;
    assert_eq!(refused(s), (BadThresholds, site));
    let mut s = network(&[]);
    s.timelines[1].thresholds.push(5).unwrap();
    assert_eq!(
        refused(s),
        (BadThresholds, ErrorSite::TimelineThresholds(1))
    );
}

#[test]
fn too_many_timed_values_and_thresholds_are_refused_never_a_panic() {
    // 65 timed values: the count is refused at the first that does not fit.
    let spec = network(&[]);
    let mut b = encode(&spec);
    // The timed-value count (postcard: a one-byte varint 3), found as the byte that, raised
    // to 65, is refused as too many timed values.
    let pos = (0..b.len())
        .rev()
        .find(|&i| {
            b[i] == 3 && {
                let mut c = b.clone();
                c[i] = 65;
                validate_uplink(&c).is_err_and(|e| e.code == ValidationCode::TooManyTimedValues)
            }
        })
        .expect("timed-value count");
    b[pos] = 65;
    assert_eq!(
        validate_uplink(&b).unwrap_err().site,
        ErrorSite::TimedValue(MAX_TIMED_VALUES as u8)
    );
    // Every prefix and every one-byte change of the uplink is refused or accepted, never a
    // panic, and what is accepted decodes to a network that validates.
    let good = encode(&network(&[task(1, 0, 100, 10)]));
    for len in 0..good.len() {
        assert!(validate_uplink(&good[..len]).is_err());
    }
    for i in 0..good.len() {
        for v in [0u8, 1, 2, 0x7f, 0x80, 0xff] {
            let mut c = good.clone();
            c[i] = v;
            let mut n = TaskNetwork::EMPTY;
            if decode_into(&mut n, &c).is_ok() {
                TaskNetwork::from_spec(n.spec().clone()).unwrap();
            }
        }
    }
}

#[test]
fn a_checkpoint_with_the_new_fields_round_trips() {
    let mut t = task(1, 0, 1000, 100);
    t.constraints.push(pre(TL_VIEW, IN_VIEW)).unwrap();
    t.constraints.push(pre(TL_THERMAL, WARM)).unwrap();
    let n = uplinked(network(&[t]));
    let (_, a) = dispatch_times(n.clone(), 150, &[(0, StateValue::Int(300))]);
    let mut buf = vec![0u8; 1 << 20];
    let len = a.encode_state(&mut buf).unwrap();
    let mut b = Box::new(Autonomy::new());
    b.decode_state(&buf[..len]).unwrap();
    assert_eq!(b.network(), &n);
    let mut again = vec![0u8; 1 << 20];
    let len2 = b.encode_state(&mut again).unwrap();
    assert_eq!(&buf[..len], &again[..len2]);
}
