//! Property test: a plan view that reads the entries' events from a [`PlanEvents`] table (what
//! the planner's placement searches use) answers every timeline question exactly as the view
//! that generates the events from the entries for each query (the original computation, kept
//! as the oracle), on random plans: values, constraint checks over intervals, first violations,
//! bounds, the events themselves in order, and whole placement checks. The same for a view
//! that reads its hypothetical placement's events from a [`CandidateEvents`] list (generated
//! once per placement check) instead of generating them for every query. And the value's
//! 64-bit path answers as the 128-bit computation, near the ends of the range too.
use autonomy::plan::{Origin, PlanEntry};
use autonomy::planner::{placement_valid, placement_valid_with_events};
use autonomy::timeline::{
    Candidate, CandidateEvents, Event, Measurement, PlanEvents, PlanView, TimelineAnchor,
};
use autonomy::*;
use proptest::prelude::*;

/// Timelines: a 3-value state, a claim, a cumulative with additions and rates in [0, 50].
fn network() -> TaskNetwork {
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
                initial: 10,
                min: 0,
                max: 50,
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
    // Task shapes: every kind of impact and constraint, with offsets.
    let shapes: [(&[ImpactSpec], &[ConstraintSpec]); 6] = [
        (
            &[impact(ImpactWhen::Pre, 0, Effect::Assign(1), 0, 0)],
            &[constraint(
                ConstraintWhen::Pre,
                0,
                Requirement::OneOf { mask: 0b001 },
            )],
        ),
        (
            &[
                impact(ImpactWhen::Post, 0, Effect::Assign(2), 0, 3),
                impact(ImpactWhen::Maintain, 1, Effect::Claim, 1, -1),
            ],
            &[constraint(
                ConstraintWhen::Maintain,
                0,
                Requirement::OneOf { mask: 0b011 },
            )],
        ),
        (
            &[impact(
                ImpactWhen::Maintain,
                2,
                Effect::Rate(2_000_000),
                0,
                0,
            )],
            &[constraint(
                ConstraintWhen::Maintain,
                2,
                Requirement::Range { min: 5, max: 40 },
            )],
        ),
        (
            &[
                impact(ImpactWhen::Pre, 2, Effect::Add(-7), 2, 0),
                impact(ImpactWhen::Post, 2, Effect::Add(4), 0, 0),
            ],
            &[],
        ),
        (
            &[
                impact(ImpactWhen::Maintain, 2, Effect::Rate(-3_000_000), 0, -2),
                impact(ImpactWhen::Pre, 0, Effect::Assign(0), 0, 0),
            ],
            &[constraint(
                ConstraintWhen::Pre,
                2,
                Requirement::Range { min: 1, max: 50 },
            )],
        ),
        (
            &[impact(ImpactWhen::Post, 2, Effect::Assign(20), 0, 0)],
            &[constraint(
                ConstraintWhen::Maintain,
                1,
                Requirement::Range { min: 0, max: 0 },
            )],
        ),
    ];
    for (i, (impacts, constraints)) in shapes.iter().enumerate() {
        n.tasks
            .push(TaskSpec {
                id: i as u16 + 1,
                name: Name::try_from("t").unwrap(),
                priority: 0,
                role: TaskRole::Requested,
                command: None,
                duration_us: 10,
                min_duration_us: 10,
                earliest_start: MissionTimeUs(0),
                latest_start: MissionTimeUs(100),
                latest_end: MissionTimeUs::MAX,
                constraints: heapless::Vec::from_slice(constraints).unwrap(),
                impacts: heapless::Vec::from_slice(impacts).unwrap(),
                control: ControlSpec::NONE,
                contingencies: heapless::Vec::new(),
                permissions: Permissions {
                    may_move: false,
                    may_delete: false,
                    may_add: heapless::Vec::new(),
                },
            })
            .unwrap();
    }
    TaskNetwork::from_spec(n).expect("the test network validates")
}

fn impact(when: ImpactWhen, timeline: u8, effect: Effect, start: i64, end: i64) -> ImpactSpec {
    ImpactSpec {
        when,
        timeline,
        effect,
        start_offset_us: start,
        end_offset_us: end,
    }
}

fn constraint(when: ConstraintWhen, timeline: u8, require: Requirement) -> ConstraintSpec {
    ConstraintSpec {
        when,
        timeline,
        require,
        start_offset_us: 0,
        end_offset_us: 0,
    }
}

const STATES: [TaskState; 8] = [
    TaskState::Unscheduled,
    TaskState::Scheduled,
    TaskState::Committed,
    TaskState::Running,
    TaskState::Completed,
    TaskState::Deleted,
    TaskState::Failed(FailureKind::CommandFailed),
    TaskState::Skipped,
];

/// (definition, state index, start, duration, started)
type RandomEntry = (u8, usize, u64, u64, bool);

fn entries(random: &[RandomEntry]) -> Vec<PlanEntry> {
    random
        .iter()
        .enumerate()
        .map(|(i, &(def, state, start, duration, started))| PlanEntry {
            instance: i as u16 + 1,
            def: def % 6,
            state: STATES[state % STATES.len()],
            start: MissionTimeUs(start),
            end: MissionTimeUs(start + duration),
            earliest_start: MissionTimeUs(0),
            latest_start: MissionTimeUs(100),
            started,
            persistent: true,
            origin: Origin::Requested,
        })
        .collect()
}

fn anchors(net: &TaskNetwork, measured: &[Option<(i64, u64)>], rate: i64) -> Vec<TimelineAnchor> {
    net.timelines()
        .iter()
        .enumerate()
        .map(|(t, spec)| {
            let mut a = TimelineAnchor::initial(spec);
            a.at = MissionTimeUs(5);
            if t == 2 {
                a.rate = rate;
            }
            a.measured = measured
                .get(t)
                .copied()
                .flatten()
                .map(|(value, at)| Measurement {
                    value,
                    at: MissionTimeUs(at),
                });
            a
        })
        .collect()
}

fn events_of(view: &PlanView<'_>, timeline: u8) -> Vec<Event> {
    let mut out = Vec::new();
    view.for_each_event(timeline, |e| out.push(e));
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn plan_events_table_answers_as_the_per_query_computation(
        random in proptest::collection::vec((0u8..6, 0usize..8, 0u64..80, 0u64..30, any::<bool>()), 0..MAX_PLAN_ENTRIES),
        measured in proptest::collection::vec(proptest::option::of((-5i64..60, 0u64..60)), 3),
        rate in prop_oneof![Just(0i64), -1_000_000i64..1_000_000],
        exclude in proptest::collection::vec(0u16..50, 0..3),
        extra in proptest::option::of((0u8..6, 0u64..90, 1u64..30, 0u16..50)),
        probes in proptest::collection::vec((0u8..4, 0u64..130, 1u64..40), 1..12),
        check in proptest::option::of((0usize..MAX_PLAN_ENTRIES, 0u64..90)),
    ) {
        let net = network();
        let entries = entries(&random);
        let anchors = anchors(&net, &measured, rate);
        let mut table = PlanEvents::new();
        table.build(&net, &entries);

        let mut oracle = PlanView::new(&net, &entries, &anchors);
        for &x in &exclude {
            oracle = oracle.without(x);
        }
        if let Some((def, start, duration, instance)) = extra {
            oracle = oracle.with(Candidate {
                instance,
                def,
                start: MissionTimeUs(start),
                end: MissionTimeUs(start + duration),
            });
        }
        let tabled = oracle.with_events(&table);
        // The candidate's events listed once; and a list made for another candidate, which a
        // view must not use.
        let mut listed = CandidateEvents::none();
        let mut stale = CandidateEvents::none();
        let mut precomputed = tabled;
        let mut with_stale = tabled;
        if let Some(x) = oracle.extra {
            listed.fill(&net, x);
            precomputed = tabled.with_candidate(&listed);
            stale.fill(&net, Candidate { start: MissionTimeUs(x.start.0 + 7), ..x });
            with_stale = tabled.with_candidate(&stale).with(x);
        }
        for timeline in 0..4u8 {
            prop_assert_eq!(events_of(&oracle, timeline), events_of(&tabled, timeline));
            prop_assert_eq!(events_of(&oracle, timeline), events_of(&precomputed, timeline));
            prop_assert_eq!(events_of(&oracle, timeline), events_of(&with_stale, timeline));
        }
        for &(timeline, t, length) in &probes {
            let (a, b) = (MissionTimeUs(t), MissionTimeUs(t + length));
            prop_assert_eq!(oracle.value_at(timeline, a), tabled.value_at(timeline, a));
            prop_assert_eq!(oracle.value_at(timeline, a), precomputed.value_at(timeline, a));
            prop_assert_eq!(
                oracle.within_bounds_at(timeline, a),
                tabled.within_bounds_at(timeline, a)
            );
            prop_assert_eq!(
                oracle.within_bounds_at(timeline, a),
                precomputed.within_bounds_at(timeline, a)
            );
            for require in [
                Requirement::OneOf { mask: 0b010 },
                Requirement::Range { min: 8, max: 30 },
                Requirement::Range { min: 0, max: 0 },
            ] {
                prop_assert_eq!(
                    oracle.holds_over(timeline, &require, a, b),
                    tabled.holds_over(timeline, &require, a, b)
                );
                prop_assert_eq!(
                    oracle.holds_over(timeline, &require, a, b),
                    precomputed.holds_over(timeline, &require, a, b)
                );
                prop_assert_eq!(
                    oracle.first_violation(timeline, &require, a, b),
                    tabled.first_violation(timeline, &require, a, b)
                );
                prop_assert_eq!(
                    oracle.first_violation(timeline, &require, a, b),
                    precomputed.first_violation(timeline, &require, a, b)
                );
            }
        }
        if let Some((index, start)) = check.filter(|_| !entries.is_empty()) {
            let entry = entries[index % entries.len()];
            let (start, now) = (MissionTimeUs(start), MissionTimeUs(3));
            let end = MissionTimeUs(start.0 + 10);
            prop_assert_eq!(
                placement_valid(&net, &entries, &anchors, &entry, start, end, now),
                placement_valid_with_events(&net, &entries, &anchors, Some(&table), &entry, start, end, now)
            );
        }
    }

    #[test]
    fn the_64_bit_value_is_the_exact_value(
        random in proptest::collection::vec((0u8..6, 0usize..8, 0u64..80, 0u64..30, any::<bool>()), 0..MAX_PLAN_ENTRIES),
        measured in proptest::collection::vec(proptest::option::of((prop_oneof![
            -5i64..60,
            Just(VALUE_UNKNOWN),
            Just(VALUE_UNKNOWN + 1),
            (i64::MAX - 10)..=i64::MAX,
            (VALUE_UNKNOWN + 1)..(VALUE_UNKNOWN + 10),
        ], 0u64..60)), 3),
        rate in prop_oneof![Just(0i64), -1_000_000i64..1_000_000],
        exclude in proptest::collection::vec(0u16..50, 0..3),
        probes in proptest::collection::vec((0u8..4, 0u64..130), 1..20),
    ) {
        let net = network();
        let entries = entries(&random);
        let anchors = anchors(&net, &measured, rate);
        let mut view = PlanView::new(&net, &entries, &anchors);
        for &x in &exclude {
            view = view.without(x);
        }
        for &(timeline, t) in &probes {
            let t = MissionTimeUs(t);
            prop_assert_eq!(view.value_at(timeline, t), view.value_at_exact(timeline, t));
        }
    }

    #[test]
    fn a_table_built_from_other_entries_is_not_used(
        random in proptest::collection::vec((0u8..6, 0usize..8, 0u64..80, 0u64..30, any::<bool>()), 1..20),
        t in 0u64..120,
    ) {
        let net = network();
        let entries = entries(&random);
        let anchors = anchors(&net, &[], 0);
        let mut table = PlanEvents::new();
        table.build(&net, &entries[1..]);
        let oracle = PlanView::new(&net, &entries, &anchors);
        let tabled = oracle.with_events(&table);
        for timeline in 0..3u8 {
            prop_assert_eq!(events_of(&oracle, timeline), events_of(&tabled, timeline));
            prop_assert_eq!(oracle.value_at(timeline, MissionTimeUs(t)), tabled.value_at(timeline, MissionTimeUs(t)));
        }
    }
}
