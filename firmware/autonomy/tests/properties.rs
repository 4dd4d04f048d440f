//! Property tests: valid intervals agree with a brute-force placement check; the planner never
//! holds a placed schedule that violates a constraint, whatever its budget; checkpoints
//! round-trip (with the executive's retry state and the planner's failure ledger of a
//! misbehaving GNC too), and a truncated or bit-flipped record is never used.
mod common;
use autonomy::planner::Planner;
use autonomy::*;
use common::*;
use proptest::prelude::*;

const TL_STATE: u8 = 0;
const TL_CLAIM: u8 = 1;
const TL_CUMUL: u8 = 2;

#[derive(Clone, Debug)]
struct RandomTask {
    duration: u64,
    earliest: u64,
    slack: u64,
    constraint: Option<(bool, u8, u8)>, // (maintain?, timeline choice, value)
    impacts: Vec<(u8, u8, i8)>,         // (when 0 pre/1 maintain/2 post, timeline choice, value)
}

fn task_strategy() -> impl Strategy<Value = RandomTask> {
    (
        1u64..25,
        0u64..60,
        0u64..60,
        proptest::option::of((any::<bool>(), 0u8..2, 0u8..3)),
        proptest::collection::vec((0u8..3, 0u8..3, -1i8..3), 0..3),
    )
        .prop_map(
            |(duration, earliest, slack, constraint, impacts)| RandomTask {
                duration,
                earliest,
                slack,
                constraint,
                impacts,
            },
        )
}

/// A small network over a 3-value state timeline, a claim and a cumulative timeline in [0, 2].
fn network(tasks: &[RandomTask]) -> Option<TaskNetwork> {
    let config = PlannerConfig {
        commit_window_us: 1,
        scheduling_window_us: 1_000,
        plan_horizon_us: 1_000,
        plan_process_interval_us: 1_000,
    };
    let mut n = NetworkSpec::new(9, config);
    for (name, kind) in [
        (
            "S",
            TimelineKind::State {
                value_count: 3,
                initial: 0,
            },
        ),
        ("C", TimelineKind::Claimable),
        (
            "R",
            TimelineKind::Cumulative {
                initial: 1,
                min: 0,
                max: 2,
            },
        ),
    ] {
        n.timelines
            .push(TimelineSpec {
                name: Name::try_from(name).unwrap(),
                kind,
                state_key: None,
                after_reset: None,
                stale_after_us: None,
                background_rate: 0,
                external: false,
                thresholds: heapless::Vec::new(),
            })
            .unwrap();
    }
    for (i, t) in tasks.iter().enumerate() {
        let mut spec = TaskSpec {
            id: i as u16 + 1,
            name: Name::try_from("t").unwrap(),
            priority: 0,
            role: TaskRole::Requested,
            command: None,
            duration_us: t.duration,
            min_duration_us: t.duration,
            earliest_start: MissionTimeUs(t.earliest),
            latest_start: MissionTimeUs(t.earliest + t.slack),
            latest_end: MissionTimeUs::MAX,
            constraints: heapless::Vec::new(),
            impacts: heapless::Vec::new(),
            control: ControlSpec::NONE,
            contingencies: heapless::Vec::new(),
            permissions: Permissions {
                may_move: false,
                may_delete: false,
                may_add: heapless::Vec::new(),
            },
        };
        if let Some((maintain, tl, v)) = t.constraint {
            let (timeline, require) = if tl == 0 {
                (TL_STATE, Requirement::OneOf { mask: 1 << v })
            } else {
                (
                    TL_CUMUL,
                    Requirement::Range {
                        min: i64::from(v.min(1)),
                        max: 2,
                    },
                )
            };
            let when = if maintain {
                ConstraintWhen::Maintain
            } else {
                ConstraintWhen::Pre
            };
            spec.constraints
                .push(ConstraintSpec {
                    when,
                    timeline,
                    require,
                    start_offset_us: 0,
                    end_offset_us: 0,
                })
                .unwrap();
        }
        for &(when, tl, v) in &t.impacts {
            let when = [ImpactWhen::Pre, ImpactWhen::Maintain, ImpactWhen::Post][when as usize];
            // Keep to what the validator accepts: state changes at PRE/POST, claims at MAINTAIN.
            let (timeline, effect, when) = match tl {
                0 => {
                    let when = if when == ImpactWhen::Maintain {
                        ImpactWhen::Post
                    } else {
                        when
                    };
                    (TL_STATE, Effect::Assign(i64::from(v.rem_euclid(3))), when)
                }
                1 => (TL_CLAIM, Effect::Claim, ImpactWhen::Maintain),
                _ => (TL_CUMUL, Effect::Add(i64::from(v)), when),
            };
            spec.impacts
                .push(ImpactSpec {
                    when,
                    timeline,
                    effect,
                    start_offset_us: 0,
                    end_offset_us: 0,
                })
                .ok()?;
        }
        n.tasks.push(spec).ok()?;
    }
    TaskNetwork::from_spec(n).ok()
}

struct Sink;
impl Outputs for Sink {
    fn dispatch(&mut self, _: u32, _: Opcode, _: &CommandArgs) {}
    fn telemetry(&mut self, _: TelemetryEvent) {}
}

fn planned(net: &TaskNetwork, budget: u32, steps: u32) -> Planner {
    let mut p = Planner::new();
    p.load(net);
    for _ in 0..steps {
        p.step(net, MissionTimeUs(0), budget, &mut |_| {}, &mut Sink);
    }
    p
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    #[test]
    fn valid_intervals_agree_with_brute_force_placement(tasks in proptest::collection::vec(task_strategy(), 1..5), pick in 0usize..5) {
        let net = network(&tasks).expect("generated networks validate");
        let mut p = planned(&net, u32::MAX, 1);
        let instance = (pick % tasks.len()) as u16 + 1;
        let intervals = p.valid_intervals(&net, MissionTimeUs(0), instance);
        for s in 0..=130u64 {
            let brute = p.is_valid_placement(&net, MissionTimeUs(0), instance, MissionTimeUs(s));
            let listed = intervals.iter().any(|iv| iv.start.0 <= s && s <= iv.end.0);
            prop_assert_eq!(brute, listed, "start {} intervals {:?}", s, intervals);
        }
    }

    #[test]
    fn planner_never_holds_a_placed_schedule_that_violates_a_constraint(
        tasks in proptest::collection::vec(task_strategy(), 1..7),
        budget in prop_oneof![Just(u32::MAX), 1u32..8],
    ) {
        let net = network(&tasks).expect("generated networks validate");
        let mut p = Planner::new();
        p.load(&net);
        for _ in 0..20 {
            p.step(&net, MissionTimeUs(0), budget, &mut |_| {}, &mut Sink);
            let conflicts = p.conflicts(&net, MissionTimeUs(0));
            prop_assert!(conflicts.is_empty(), "conflicts {:?} in {:#?}", conflicts, p.entries());
        }
    }
}

fn flyby_sim_until(t: MissionTimeUs) -> Sim {
    let mut sim = Sim::flyby();
    sim.run(t, &[]);
    sim
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn checkpoint_round_trips(minute in 0u64..90) {
        let sim = flyby_sim_until(hm(9, 50).saturating_add(minute * MIN));
        let mut first = vec![0u8; WARM_AREA_LEN];
        let len = sim.autonomy.encode_state(&mut first).unwrap();
        let mut restored = Box::new(Autonomy::new());
        restored.decode_state(&first[..len]).unwrap();
        let mut second = vec![0u8; WARM_AREA_LEN];
        let len2 = restored.encode_state(&mut second).unwrap();
        prop_assert_eq!(&first[..len], &second[..len2]);
        prop_assert_eq!(restored.plan(), sim.autonomy.plan());
        prop_assert_eq!(restored.states(), sim.autonomy.states());
        // And through the warm-restart area.
        let mut bytes = vec![0u8; WARM_AREA_LEN];
        let mut area = WarmRestartArea::new(&mut bytes);
        let seq = sim.autonomy.checkpoint_to(&mut area).unwrap();
        let mut again = Box::new(Autonomy::new());
        let info = again.restore_from(&area).unwrap();
        prop_assert_eq!(info.sequence, seq);
        prop_assert_eq!(again.plan(), sim.autonomy.plan());
    }

    /// The same against a misbehaving GNC, with retries allowed: the checkpoint holds the
    /// executive's retry counts and back-off times and the planner's failure ledger, and a
    /// core restored from it has exactly the same state.
    #[test]
    fn checkpoint_round_trips_retry_state_and_failure_ledger(
        minute in 0u64..90,
        fates in proptest::collection::vec(
            prop_oneof![
                Just(GncFate::Reject),
                Just(GncFate::Fail),
                Just(GncFate::AcceptNoSlew),
                Just(GncFate::WrongEndState),
                Just(GncFate::Nominal),
            ],
            1..4,
        ),
    ) {
        let mut spec = flyby_spec();
        spec.header.responses.max_retries = PerCause::uniform(1, FailureKind::RETRYABLE);
        let mut sim = Sim::new(TaskNetwork::from_spec(spec).unwrap(), hm(9, 50));
        sim.sc.gnc_fates = fates;
        sim.run(hm(9, 50).saturating_add(minute * MIN), &[]);
        let mut first = vec![0u8; WARM_AREA_LEN];
        let len = sim.autonomy.encode_state(&mut first).unwrap();
        let mut restored = Box::new(Autonomy::new());
        restored.decode_state(&first[..len]).unwrap();
        let mut second = vec![0u8; WARM_AREA_LEN];
        let len2 = restored.encode_state(&mut second).unwrap();
        prop_assert_eq!(&first[..len], &second[..len2]);
        prop_assert_eq!(restored.executive().entries(), sim.autonomy.executive().entries());
        prop_assert_eq!(restored.planner().ledger(), sim.autonomy.planner().ledger());
        prop_assert_eq!(restored.plan(), sim.autonomy.plan());
    }

    /// With a staleness bound on the attitude and republications lost at random: the
    /// checkpoint holds every state-table entry with its measurement time and stale mark and
    /// the planner's view of the attitude, and a core restored from it reads the attitude,
    /// and next goes stale, exactly as the original.
    #[test]
    fn checkpoint_round_trips_ages_and_stale_marks(
        minute in 0u64..90,
        bound_min in 1u64..20,
        lost_from_min in 0u64..90,
        lost_for_min in 0u64..40,
    ) {
        let mut spec = flyby_spec();
        spec.timelines[TL_ATTITUDE as usize].stale_after_us = Some(bound_min * MIN);
        let mut sim = Sim::new(TaskNetwork::from_spec(spec).unwrap(), hm(9, 50));
        let lost_from = hm(9, 50).saturating_add(lost_from_min * MIN);
        sim.sc.republish = Some(Republish {
            lost_from,
            lost_until: lost_from.saturating_add(lost_for_min * MIN),
            ..Republish::every(5 * MIN, hm(9, 50))
        });
        sim.run(hm(9, 50).saturating_add(minute * MIN), &[]);
        let mut bytes = vec![0u8; WARM_AREA_LEN];
        let mut area = WarmRestartArea::new(&mut bytes);
        sim.autonomy.checkpoint_to(&mut area).unwrap();
        let mut restored = Box::new(Autonomy::new());
        restored.restore_from(&area).unwrap();
        prop_assert_eq!(restored.states(), sim.autonomy.states());
        prop_assert_eq!(restored.planner().anchors(), sim.autonomy.planner().anchors());
        let now = sim.autonomy.now();
        prop_assert_eq!(
            condition::measured_value(restored.network(), TL_ATTITUDE, restored.states()),
            condition::measured_value(sim.autonomy.network(), TL_ATTITUDE, sim.autonomy.states())
        );
        prop_assert_eq!(
            restored.planner().view(restored.network()).value_at(TL_ATTITUDE, now),
            sim.autonomy.planner().view(sim.autonomy.network()).value_at(TL_ATTITUDE, now)
        );
        // Stepping both at the original's next wake-up gives the same decisions.
        if let Some(next) = sim.autonomy.next_wakeup() {
            let mut original = Recorder::default();
            let mut again = Recorder::default();
            sim.autonomy.step(next, StepBudget::UNLIMITED, &mut original);
            restored.step(next, StepBudget::UNLIMITED, &mut again);
            // The restored core first reports its restore, then decides the same.
            let decisions = &again.decisions;
            let restore_reported = matches!(
                decisions.first(),
                Some(Decision::Modification { kind, .. })
                    if *kind == PlanModificationKind::Restored as u8
            );
            prop_assert!(restore_reported);
            let stale = |d: &[Decision]| d.iter().filter(|d| matches!(d, Decision::Stale { .. })).cloned().collect::<Vec<_>>();
            prop_assert_eq!(stale(&decisions[1..]), stale(&original.decisions));
        }
    }

    #[test]
    fn damaged_newest_record_falls_back_to_the_other_slot(minute in 0u64..90, bit in 0usize..(8 * 4096), truncate in any::<bool>()) {
        let sim = flyby_sim_until(hm(9, 50).saturating_add(minute * MIN));
        let mut bytes = vec![0u8; WARM_AREA_LEN];
        let (old_seq, new_slot, new_len) = {
            let mut area = WarmRestartArea::new(&mut bytes);
            let old = sim.autonomy.checkpoint_to(&mut area).unwrap();
            sim.autonomy.checkpoint_to(&mut area).unwrap();
            let (slot, _, payload) = area.latest().unwrap();
            (old, slot, payload.len())
        };
        let slot_start = usize::from(new_slot) * (WARM_AREA_LEN / 2);
        let record_len = checkpoint::RECORD_HEADER_LEN + new_len;
        if truncate {
            // A write torn at some byte: everything after it is stale (here: zero).
            let cut = bit % record_len;
            for b in &mut bytes[slot_start + cut..slot_start + record_len] {
                *b = !*b;
            }
        } else {
            let bit = bit % (8 * record_len);
            bytes[slot_start + bit / 8] ^= 1 << (bit % 8);
        }
        let area = WarmRestartArea::new(&mut bytes);
        let (slot, seq, _) = area.latest().expect("the other record is whole");
        prop_assert_eq!(seq, old_seq);
        prop_assert_ne!(slot, new_slot);
        let mut restored = Box::new(Autonomy::new());
        prop_assert!(restored.restore_from(&area).is_ok());
    }
}

/// The fuzz target's property on mutations of a real uplink (a fuzz smoke test that runs in
/// `cargo test`): refused bytes leave the network untouched; accepted bytes re-validate,
/// round-trip and can be planned. The checkpoint restore's decoder (decode once, then
/// validate) accepts exactly the same bytes and builds the same network.
fn check_uplink(data: &[u8]) -> Result<(), TestCaseError> {
    let mut network = TaskNetwork::EMPTY;
    let verdict = autonomy::uplink::decode_into(&mut network, data);
    let mut restored = TaskNetwork::EMPTY;
    let restore_verdict = autonomy::uplink::decode_then_validate(&mut restored, data);
    prop_assert_eq!(verdict.is_ok(), restore_verdict.is_ok());
    if verdict.is_ok() {
        prop_assert_eq!(&restored, &network);
    }
    match verdict {
        Err(_) => prop_assert_eq!(&network, &TaskNetwork::EMPTY),
        Ok(()) => {
            prop_assert!(TaskNetwork::from_spec(network.spec().clone()).is_ok());
            let mut buf = vec![0u8; data.len() + 64];
            let len = network.encode(&mut buf).unwrap();
            let mut again = TaskNetwork::EMPTY;
            autonomy::uplink::decode_into(&mut again, &buf[..len]).unwrap();
            prop_assert_eq!(&again, &network);
            let mut core = Box::new(Autonomy::new());
            core.load_network(network).unwrap();
            core.step(
                MissionTimeUs(hm(9, 0).0),
                StepBudget {
                    planner_checks: 2_000,
                },
                &mut Sink,
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn mutated_uplinks_are_refused_cleanly_or_accepted_whole(
        flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..4),
        cut in proptest::option::of(any::<usize>()),
    ) {
        let mut bytes = vec![0u8; 1 << 16];
        let len = flyby_network().encode(&mut bytes).unwrap();
        bytes.truncate(len);
        for (at, value) in flips {
            let at = at % bytes.len();
            bytes[at] = value;
        }
        if let Some(cut) = cut {
            bytes.truncate(cut % (bytes.len() + 1));
        }
        check_uplink(&bytes)?;
    }
}
