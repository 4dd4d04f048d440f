//! Model expressiveness (issue 11 item 8 f): durations and energies that come from model
//! parameters updated at run time. A parameter has a prior and bounds; the network's tasks
//! name it for a duration or an impact's magnitude; a measurement of the timeline that
//! measures it (a subsystem's report of what it measured, or a new value from the ground as a
//! state update) changes it; the next plan uses the new value, and a checkpoint keeps it
//! across a warm reset. With the target's refusals of parameters that cannot be.
mod common;
use autonomy::uplink::{encode_spec, validate_uplink, ErrorSite, ValidationCode};
use autonomy::*;
use common::*;

const OP_PASS: Opcode = Opcode(0x0401);
const LENGTH_KEY: StateKey = StateKey(30);
const BATTERY_KEY: StateKey = StateKey(20);

const TL_LENGTH: u8 = 0;
const TL_BATTERY: u8 = 1;

fn pass(id: u16, at: u64) -> TaskSpec {
    TaskSpec {
        id,
        name: Name::try_from(format!("pass{id}").as_str()).unwrap(),
        priority: 0,
        role: TaskRole::Requested,
        command: Some(CommandSpec::fixed(OP_PASS, CommandArgs::new())),
        duration_us: 100 * SEC,
        min_duration_us: 20 * SEC,
        earliest_start: MissionTimeUs(at * SEC),
        latest_start: MissionTimeUs(at * SEC),
        latest_end: MissionTimeUs::MAX,
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::from_slice(&[ImpactSpec {
            when: ImpactWhen::Maintain,
            timeline: TL_BATTERY,
            effect: Effect::Rate(-3),
            start_offset_us: 0,
            end_offset_us: 0,
        }])
        .unwrap(),
        control: ControlSpec {
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

fn cumulative(name: &str, key: StateKey, initial: i64, max: i64) -> TimelineSpec {
    let mut t = TimelineSpec::internal(
        Name::try_from(name).unwrap(),
        TimelineKind::Cumulative {
            initial,
            min: 0,
            max,
        },
    );
    t.state_key = Some(key);
    t
}

/// PassLength (measured, µs), Battery (measured); two passes at 10 s and 500 s whose duration
/// is parameter 0 (prior 100 s, 20 s to 200 s, measured by PassLength) and whose drain rate
/// is parameter 1 (prior -3 a second, fixed).
fn network() -> NetworkSpec {
    let mut n = NetworkSpec::new(14, PlannerConfig::DEFAULT);
    n.timelines
        .push(cumulative("PassLength", LENGTH_KEY, 0, 1 << 40))
        .unwrap();
    n.timelines
        .push(cumulative("Battery", BATTERY_KEY, 10_000, 10_000))
        .unwrap();
    n.tasks.push(pass(1, 10)).unwrap();
    n.tasks.push(pass(2, 500)).unwrap();
    n.params
        .push(ParamSpec {
            prior: 100 * SEC as i64,
            value: 100 * SEC as i64,
            min: 20 * SEC as i64,
            max: 200 * SEC as i64,
            measured_by: Some(TL_LENGTH),
            uses: heapless::Vec::from_slice(&[
                ParamUse::Duration { task: 1 },
                ParamUse::Duration { task: 2 },
            ])
            .unwrap(),
        })
        .unwrap();
    n.params
        .push(ParamSpec {
            prior: -3,
            value: -3,
            min: -10,
            max: 0,
            measured_by: None,
            uses: heapless::Vec::from_slice(&[
                ParamUse::Impact { task: 1, impact: 0 },
                ParamUse::Impact { task: 2, impact: 0 },
            ])
            .unwrap(),
        })
        .unwrap();
    n
}

/// Steps the core one second at a time over `from..=to`, answering commands Ok at once and
/// delivering `measure` (second, key, value) first; returns (dispatch second, completion
/// second) of every instance that completed, by instance.
fn fly(a: &mut Autonomy, from: u64, to: u64, measure: &[(u64, StateKey, i64)], out: &mut Recorder) {
    let mut seen = out.dispatches.len();
    for t in from..=to {
        for &(at, key, v) in measure {
            if at == t {
                a.on_state_update(key, StateValue::Int(v), MissionTimeUs(t * SEC));
            }
        }
        out.now = MissionTimeUs(t * SEC);
        a.step(MissionTimeUs(t * SEC), StepBudget::UNLIMITED, out);
        while seen < out.dispatches.len() {
            a.on_command_response(out.dispatches[seen].0, CommandStatus::Ok);
            seen += 1;
        }
    }
}

fn completions(out: &Recorder, task: u16) -> Vec<u64> {
    out.decisions
        .iter()
        .filter_map(|d| match d {
            Decision::Transition {
                task: t,
                to: TaskState::Completed,
                at,
                ..
            } if *t == task => Some(at.0 / SEC),
            _ => None,
        })
        .collect()
}

#[test]
fn tasks_take_the_prior_until_a_measurement_changes_it_and_the_next_plan_uses_the_new_value() {
    let network = uplinked(network());
    let mut a = Box::new(Autonomy::new());
    a.load_network(network).unwrap();
    let mut out = Recorder::default();
    // Pass 1 runs its prior, 100 s; at 200 s the subsystem reports 60 s for a pass.
    fly(
        &mut a,
        0,
        700,
        &[(200, LENGTH_KEY, 60 * SEC as i64)],
        &mut out,
    );
    assert_eq!(completions(&out, 1), vec![110]);
    // Pass 2 was planned with 100 s; the plan after the measurement gives it 60 s.
    assert_eq!(completions(&out, 2), vec![560]);
    assert_eq!(a.network().params()[0].value, 60 * SEC as i64);
    assert_eq!(a.network().params()[0].prior, 100 * SEC as i64);
    assert_eq!(a.network().tasks()[1].duration_us, 60 * SEC);
}

#[test]
fn without_a_measurement_both_passes_run_their_prior() {
    let mut a = Box::new(Autonomy::new());
    a.load_network(uplinked(network())).unwrap();
    let mut out = Recorder::default();
    fly(&mut a, 0, 700, &[], &mut out);
    assert_eq!(completions(&out, 1), vec![110]);
    assert_eq!(completions(&out, 2), vec![600]);
}

#[test]
fn a_measurement_outside_the_bounds_is_not_taken() {
    let mut a = Box::new(Autonomy::new());
    a.load_network(uplinked(network())).unwrap();
    let mut out = Recorder::default();
    // 500 s is over the 200 s bound: pass 2 keeps its 100 s.
    fly(
        &mut a,
        0,
        700,
        &[(200, LENGTH_KEY, 500 * SEC as i64)],
        &mut out,
    );
    assert_eq!(completions(&out, 2), vec![600]);
    assert_eq!(a.network().params()[0].value, 100 * SEC as i64);
}

#[test]
fn an_energy_parameter_sets_the_drain_the_plan_projects() {
    let mut spec = network();
    // Battery's drain made a measured parameter too: -3 a second, measured by the battery
    // timeline would be odd; here the ground changes the prior instead, and the plan's
    // projection of pass 1 follows it.
    spec.params[1].prior = -7;
    spec.params[1].value = -7;
    spec.tasks[0].impacts[0].effect = Effect::Rate(-7);
    spec.tasks[1].impacts[0].effect = Effect::Rate(-7);
    let network = uplinked(spec);
    let mut a = Box::new(Autonomy::new());
    a.load_network(network).unwrap();
    let mut out = Recorder::default();
    fly(&mut a, 0, 5, &[], &mut out);
    let view = a.planner().view(a.network());
    // Pass 1 from 10 s: 10,000 - 7 * 50 at 60 s.
    assert_eq!(
        view.value_at(TL_BATTERY, MissionTimeUs(60 * SEC)),
        10_000 - 350
    );
}

#[test]
fn an_updated_parameter_survives_a_warm_reset() {
    let mut a = Box::new(Autonomy::new());
    a.load_network(uplinked(network())).unwrap();
    let mut out = Recorder::default();
    fly(
        &mut a,
        0,
        300,
        &[(200, LENGTH_KEY, 60 * SEC as i64)],
        &mut out,
    );
    let mut bytes = vec![0u8; WARM_AREA_LEN];
    let mut area = WarmRestartArea::new(&mut bytes);
    a.checkpoint_record_to(&mut area).unwrap();
    let mut restored = Box::new(Autonomy::new());
    restored.restore_from(&area).unwrap();
    assert_eq!(restored.network().params()[0].value, 60 * SEC as i64);
    assert_eq!(restored.network().tasks()[1].duration_us, 60 * SEC);
    // And flies pass 2 with it.
    let mut out = Recorder::default();
    fly(&mut restored, 301, 700, &[], &mut out);
    assert_eq!(completions(&out, 2), vec![560]);
}

fn rejected(spec: &NetworkSpec) -> (ValidationCode, ErrorSite) {
    let mut buf = vec![0u8; 1 << 16];
    let len = encode_spec(spec, &mut buf).unwrap();
    let e = validate_uplink(&buf[..len]).unwrap_err();
    let f = TaskNetwork::from_spec(spec.clone()).unwrap_err();
    assert_eq!(e, f, "the uplink and the in-memory validation agree");
    (e.code, e.site)
}

#[test]
fn parameters_that_cannot_be_are_refused() {
    use ValidationCode::*;
    let at0 = ErrorSite::Param(0);
    let refused = |edit: &dyn Fn(&mut NetworkSpec)| {
        let mut n = network();
        edit(&mut n);
        rejected(&n)
    };
    // The prior outside its bounds.
    assert_eq!(
        refused(&|n| n.params[0].min = 150 * SEC as i64),
        (BadParam, at0)
    );
    // Measured by a timeline that is not measured, or not cumulative.
    assert_eq!(
        refused(&|n| n.timelines[0].state_key = None),
        (BadParam, at0)
    );
    assert_eq!(
        refused(&|n| n.params[0].measured_by = Some(9)),
        (DanglingTimeline, at0)
    );
    // A duration below the task's minimum duration is allowed by the bounds.
    assert_eq!(
        refused(&|n| n.params[0].min = 10 * SEC as i64),
        (BadParam, at0)
    );
    // A task whose duration is not the parameter's value.
    assert_eq!(
        refused(&|n| n.tasks[1].duration_us = 90 * SEC),
        (BadParam, at0)
    );
    // A use naming no task.
    assert_eq!(
        refused(&|n| n.params[0].uses[1] = ParamUse::Duration { task: 7 }),
        (BadParam, at0)
    );
    // An impact that has no magnitude (a claim), or that does not exist.
    assert_eq!(
        refused(&|n| n.params[1].uses[1] = ParamUse::Impact { task: 2, impact: 3 }),
        (BadParam, ErrorSite::Param(1))
    );
    // More than MAX_PARAMS: eight copies of parameter 1 are fine, a ninth is refused.
    let mut n = network();
    let p = n.params[1].clone();
    n.params.clear();
    while n.params.len() < MAX_PARAMS {
        n.params.push(p.clone()).unwrap();
    }
    assert!(TaskNetwork::from_spec(n.clone()).is_ok());
    let mut buf = vec![0u8; 1 << 16];
    let len = encode_spec(&n, &mut buf).unwrap();
    let mut one = [0u8; 256];
    let one = postcard::to_slice(&p, &mut one).unwrap().to_vec();
    let params_at = len - 1 - one.len() * MAX_PARAMS;
    let mut bytes = buf[..params_at].to_vec();
    bytes.push(MAX_PARAMS as u8 + 1);
    for _ in 0..=MAX_PARAMS {
        bytes.extend_from_slice(&one);
    }
    assert_eq!(
        validate_uplink(&bytes).unwrap_err(),
        autonomy::ValidationError::new(TooManyParams, ErrorSite::Param(MAX_PARAMS as u8))
    );
    assert_eq!(TooManyParams.code(), 24);
    assert_eq!(BadParam.code(), 87);
}
