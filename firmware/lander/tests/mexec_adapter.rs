//! The MEXEC adapter ([`lander::mexec::MexecPlacement`]): the autonomy crate's exact validity
//! check as the search's "can be added". On a task network that says what the simple timeline
//! says (every primitive claims the one arm and draws its energy from a battery that is never
//! recharged) the search decides exactly as with [`TimelinePlacement`], on many seeded random
//! HTNs; instances the MEXEC planner already holds are respected, whatever ids it gave them;
//! a plan that needs more entries than the MEXEC plan holds is refused and counted.
mod common;

use autonomy::plan::{Origin, PlanEntry};
use autonomy::timeline::TimelineAnchor;
use autonomy::{
    ControlSpec, Effect, ImpactSpec, ImpactWhen, Name, NetworkSpec, Permissions, PlannerConfig,
    TaskNetwork, TaskRole, TaskSpec, TaskState, TimelineKind, TimelineSpec, FIRST_INSTANCE_ID,
    MAX_PLAN_ENTRIES,
};
use common::*;
use fsw_bridge::MissionTimeUs;
use heapless::Vec as HVec;
use lander::capacity::MAX_PLAN_CHAINS;
use lander::htn::*;
use lander::mexec::MexecPlacement;
use lander::placement::TimelinePlacement;
use lander::search::{ChainPlacement, PlacedChain, Search, SearchConfig};
use lander::utility::RankedUtility;

const TL_ARM: u8 = 0;
const TL_BATTERY: u8 = 1;

/// A primitive of the test models: duration and energy.
#[derive(Clone, Copy)]
struct Primitive {
    duration_us: u64,
    energy_mj: u64,
}

fn name(s: &str) -> Name {
    Name::try_from(s).expect("short name")
}

/// One task definition per primitive: MAINTAIN claim on the arm, PRE draw of its energy from
/// the battery (a cumulative timeline from `battery_mj` that may not go below zero).
fn network(primitives: &[Primitive], battery_mj: u64) -> TaskNetwork {
    let mut spec = NetworkSpec::new(11, PlannerConfig::DEFAULT);
    spec.timelines
        .push(TimelineSpec {
            name: name("Arm"),
            kind: TimelineKind::Claimable,
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .expect("room");
    let battery = i64::try_from(battery_mj).expect("fits i64");
    spec.timelines
        .push(TimelineSpec {
            name: name("Battery"),
            kind: TimelineKind::Cumulative {
                initial: battery,
                min: 0,
                max: battery,
            },
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .expect("room");
    for (i, p) in primitives.iter().enumerate() {
        let mut task = TaskSpec {
            id: 1 + i as u16,
            name: name(&format!("p{i}")),
            priority: 0,
            role: TaskRole::Template,
            command: None,
            duration_us: p.duration_us,
            min_duration_us: p.duration_us,
            earliest_start: MissionTimeUs::ZERO,
            latest_start: MissionTimeUs::MAX,
            latest_end: MissionTimeUs::MAX,
            constraints: HVec::new(),
            impacts: HVec::new(),
            control: ControlSpec::NONE,
            contingencies: HVec::new(),
            permissions: Permissions {
                may_move: false,
                may_delete: false,
                may_add: HVec::new(),
            },
        };
        let impact = |when, timeline, effect| ImpactSpec {
            when,
            timeline,
            effect,
            start_offset_us: 0,
            end_offset_us: 0,
        };
        task.impacts
            .push(impact(ImpactWhen::Maintain, TL_ARM, Effect::Claim))
            .expect("room");
        let draw = -i64::try_from(p.energy_mj).expect("fits i64");
        task.impacts
            .push(impact(ImpactWhen::Pre, TL_BATTERY, Effect::Add(draw)))
            .expect("room");
        spec.tasks.push(task).expect("room");
    }
    TaskNetwork::from_spec(spec).expect("valid network")
}

fn anchors(network: &TaskNetwork) -> Vec<TimelineAnchor> {
    network
        .timelines()
        .iter()
        .map(TimelineAnchor::initial)
        .collect()
}

fn primitive_spec(p: Primitive, utility: RankedUtility) -> PrimitiveSpec {
    PrimitiveSpec {
        kind: PrimitiveKind::CollectSample,
        site: None,
        target: None,
        duration_us: p.duration_us,
        energy_mj: p.energy_mj,
        utility,
        product: None,
    }
}

fn decomposition(steps: &[Step]) -> Decomposition {
    Decomposition {
        steps: HVec::from_slice(steps).expect("room"),
        phases: PhaseMask::ANY,
        mode: ModeUse::Always,
        waits_for_ground_release: false,
    }
}

/// A random HTN: a few primitives (1-3 hours, 1-9 mJ), one nested parent with two
/// alternatives, and 1-4 top-level tasks with one or two decompositions of one to three steps.
fn random_model(rng: &mut Rng) -> (Vec<Primitive>, HtnModel) {
    let count = rng.range(3, 6) as usize;
    let primitives: Vec<Primitive> = (0..count)
        .map(|_| Primitive {
            duration_us: rng.range(1, 3) * HOUR,
            energy_mj: rng.range(1, 9),
        })
        .collect();
    let mut model = HtnModel::default();
    for &p in &primitives {
        model
            .primitives
            .push(primitive_spec(p, small_utility(rng)))
            .expect("room");
    }
    let pick = |rng: &mut Rng| Step::Primitive(rng.range(0, count as u64 - 1) as u8);
    let nested = ParentSpec {
        id: 900,
        name: name("nested"),
        top_level: false,
        batch: 1,
        fixed_start: None,
        decompositions: HVec::from_slice(&[
            decomposition(&[pick(rng)]),
            decomposition(&[pick(rng)]),
        ])
        .expect("room"),
    };
    model.parents.push(nested).expect("room");
    for task in 0..rng.range(1, 4) {
        let mut decompositions = HVec::new();
        for _ in 0..rng.range(1, 2) {
            let steps: Vec<Step> = (0..rng.range(1, 3))
                .map(|_| {
                    if rng.chance(25) {
                        Step::Parent(0)
                    } else {
                        pick(rng)
                    }
                })
                .collect();
            decompositions.push(decomposition(&steps)).expect("room");
        }
        model
            .parents
            .push(ParentSpec {
                id: 10 + task as u16,
                name: name("task"),
                top_level: true,
                batch: 1,
                fixed_start: None,
                decompositions,
            })
            .expect("room");
    }
    (primitives, model)
}

fn plan_of<const N: usize, const Q: usize>(search: &Search<N, Q>) -> Vec<PlacedChain> {
    let mut out: HVec<PlacedChain, MAX_PLAN_CHAINS> = HVec::new();
    search.best_plan(&mut out);
    out.to_vec()
}

fn run(net: &FlatNetwork, placement: &mut impl ChainPlacement) -> Vec<PlacedChain> {
    // The search's own battery never binds: the placements decide on energy.
    let mut search: Search<4_000, 4_000> = Search::new(SearchConfig::exhaustive(u64::MAX / 4));
    search.start(net, &[]).expect("starts");
    search.run(net, placement);
    assert!(search.stats().exhaustive(), "{:?}", search.stats());
    plan_of(&search)
}

#[test]
fn the_mexec_timelines_decide_as_the_simple_timeline_on_random_htns() {
    let mut battery_refused = 0;
    for seed in 0..120 {
        let mut rng = Rng::new(seed);
        let (primitives, model) = random_model(&mut rng);
        let net = flatten(
            &model,
            FlattenOptions {
                fully_autonomous: true,
            },
        )
        .expect("flattens");
        let battery_mj = rng.range(2, 30);
        let tasks = network(&primitives, battery_mj);
        let anchors = anchors(&tasks);
        let definition_of: Vec<u8> = (0..primitives.len() as u8).collect();
        let mut mexec = MexecPlacement {
            network: &tasks,
            anchors: &anchors,
            held: &[],
            definition_of: &definition_of,
            now: MissionTimeUs::ZERO,
            plan_full: 0,
        };
        let mut simple = TimelinePlacement {
            horizon_start: MissionTimeUs::ZERO,
            horizon_end: MissionTimeUs::MAX,
            phases: PhaseTimeline::default(),
            battery_mj,
            hotel_load_mw: 0,
            earth: Default::default(),
        };
        let with_mexec = run(&net, &mut mexec);
        let with_simple = run(&net, &mut simple);
        assert_eq!(with_mexec, with_simple, "seed {seed}");
        assert_eq!(mexec.plan_full, 0);
        // Whether the battery refused something the plan could have had.
        let planned: u64 = with_simple
            .iter()
            .map(|p| net.chains[usize::from(p.chain)].energy_mj)
            .sum();
        let left_out = net.chains.iter().any(|c| {
            with_simple
                .iter()
                .all(|p| net.chains[usize::from(p.chain)].task != c.task)
                && planned + c.energy_mj > battery_mj
        });
        battery_refused += usize::from(left_out);
    }
    assert!(
        battery_refused > 10,
        "the battery must bind in some cases: {battery_refused}"
    );
}

fn held(instance: u16, def: u8, start_h: u64, end_h: u64) -> PlanEntry {
    PlanEntry {
        instance,
        def,
        state: TaskState::Committed,
        start: hours(start_h),
        end: hours(end_h),
        earliest_start: hours(start_h),
        latest_start: hours(start_h),
        started: false,
        persistent: false,
        origin: Origin::Added {
            for_instance: FIRST_INSTANCE_ID,
        },
    }
}

/// One top-level task with one chain: the primitives given, in order.
fn single_chain(primitives: &[Primitive], steps: &[u8]) -> FlatNetwork {
    let mut model = HtnModel::default();
    for &p in primitives {
        model
            .primitives
            .push(primitive_spec(p, RankedUtility::ZERO))
            .expect("room");
    }
    let steps: Vec<Step> = steps.iter().map(|&i| Step::Primitive(i)).collect();
    model
        .parents
        .push(ParentSpec {
            id: 1,
            name: name("task"),
            top_level: true,
            batch: 1,
            fixed_start: None,
            decompositions: HVec::from_slice(&[decomposition(&steps)]).expect("room"),
        })
        .expect("room");
    flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flattens")
}

#[test]
fn held_instances_are_respected_whatever_ids_the_planner_gave_them() {
    let primitives = [
        Primitive {
            duration_us: HOUR,
            energy_mj: 1,
        },
        Primitive {
            duration_us: 2 * HOUR,
            energy_mj: 1,
        },
    ];
    let tasks = network(&primitives, 100);
    let anchors = anchors(&tasks);
    let definition_of = [0u8, 1];
    let one_hour = single_chain(&primitives, &[0]);
    let two_hours = single_chain(&primitives, &[1]);
    let three_hours = single_chain(&primitives, &[0, 1]);
    // Planner-given ids that are not dense from FIRST_INSTANCE_ID: the adapter's own entries
    // must not take one of them (numbering them from FIRST_INSTANCE_ID by count would give
    // the candidate the id of the second held instance in the middle two cases).
    for ids in [
        [FIRST_INSTANCE_ID, FIRST_INSTANCE_ID + 1],
        [FIRST_INSTANCE_ID + 1, FIRST_INSTANCE_ID + 2],
        [FIRST_INSTANCE_ID + 3, FIRST_INSTANCE_ID + 2],
        [7, FIRST_INSTANCE_ID + 5],
    ] {
        // The arm is claimed over [0, 1 h) and [2 h, 4 h).
        let entries = [held(ids[0], 0, 0, 1), held(ids[1], 1, 2, 4)];
        let mut mexec = MexecPlacement {
            network: &tasks,
            anchors: &anchors,
            held: &entries,
            definition_of: &definition_of,
            now: MissionTimeUs::ZERO,
            plan_full: 0,
        };
        // One hour fits between the held instances; two and three do not.
        assert_eq!(mexec.place(&one_hour, &[], 0), Some(hours(1)), "{ids:?}");
        assert_eq!(mexec.place(&two_hours, &[], 0), Some(hours(4)), "{ids:?}");
        assert_eq!(mexec.place(&three_hours, &[], 0), Some(hours(4)), "{ids:?}");
        // The plan's chains are laid out too: with the gap taken, the next copy goes last.
        let plan = [PlacedChain {
            chain: 0,
            start: hours(1),
        }];
        assert_eq!(mexec.place(&one_hour, &plan, 0), Some(hours(4)), "{ids:?}");
    }
}

#[test]
fn nothing_starts_before_now_and_the_battery_is_never_overdrawn() {
    let primitives = [Primitive {
        duration_us: HOUR,
        energy_mj: 4,
    }];
    let tasks = network(&primitives, 10);
    let anchors = anchors(&tasks);
    let net = single_chain(&primitives, &[0]);
    let mut mexec = MexecPlacement {
        network: &tasks,
        anchors: &anchors,
        held: &[],
        definition_of: &[0],
        now: hours(5),
        plan_full: 0,
    };
    assert_eq!(mexec.place(&net, &[], 0), Some(hours(5)));
    let one = [PlacedChain {
        chain: 0,
        start: hours(5),
    }];
    assert_eq!(mexec.place(&net, &one, 0), Some(hours(6)));
    // 3 x 4 mJ > 10 mJ.
    let two = [
        one[0],
        PlacedChain {
            chain: 0,
            start: hours(6),
        },
    ];
    assert_eq!(mexec.place(&net, &two, 0), None);
    assert_eq!(mexec.plan_full, 0);
}

#[test]
fn a_plan_longer_than_the_mexec_plan_is_refused_and_counted() {
    let primitives = [Primitive {
        duration_us: HOUR,
        energy_mj: 0,
    }];
    let tasks = network(&primitives, 1);
    let anchors = anchors(&tasks);
    let net = single_chain(&primitives, &[0, 0]);
    // Room for one more entry, and the chain has two primitives.
    let entries: Vec<PlanEntry> = (0..MAX_PLAN_ENTRIES as u64 - 1)
        .map(|k| held(FIRST_INSTANCE_ID + k as u16, 0, 100 + k, 101 + k))
        .collect();
    let mut mexec = MexecPlacement {
        network: &tasks,
        anchors: &anchors,
        held: &entries,
        definition_of: &[0],
        now: MissionTimeUs::ZERO,
        plan_full: 0,
    };
    assert_eq!(mexec.place(&net, &[], 0), None);
    assert!(mexec.plan_full > 0);
    // With one held entry fewer it fits, before the held ones.
    mexec.held = &entries[1..];
    assert_eq!(mexec.place(&net, &[], 0), Some(MissionTimeUs::ZERO));
}
