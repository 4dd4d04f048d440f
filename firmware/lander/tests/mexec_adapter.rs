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
use lander::comms::{CommsModel, DataPlacement, DataView};
use lander::downlink::Tier;
use lander::htn::*;
use lander::mexec::{MexecEarth, MexecPlacement};
use lander::placement::{EarthView, TimelinePlacement, ViewTimeline, ViewWindow};
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
            earth: None,
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
            earth: None,
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
        earth: None,
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
        earth: None,
    };
    assert_eq!(mexec.place(&net, &[], 0), None);
    assert!(mexec.plan_full > 0);
    // With one held entry fewer it fits, before the held ones.
    mexec.held = &entries[1..];
    assert_eq!(mexec.place(&net, &[], 0), Some(MissionTimeUs::ZERO));
}

/// A random small instance with Earth and data: primitives of whole hours (some downlinks,
/// some creating a product), chains of one to three of them built directly, Earth in view in
/// one to three windows of whole hours.
struct EarthCase {
    primitives: Vec<Primitive>,
    specs: Vec<PrimitiveSpec>,
    net: FlatNetwork,
    view: EarthView,
    battery_mj: u64,
    horizon_h: u64,
}

fn earth_case(rng: &mut Rng) -> EarthCase {
    let count = rng.range(2, 5) as usize;
    let mut primitives = Vec::new();
    let mut specs = Vec::new();
    for _ in 0..count {
        let p = Primitive {
            duration_us: rng.range(1, 3) * HOUR,
            energy_mj: rng.range(1, 6),
        };
        let mut spec = primitive_spec(p, RankedUtility::ZERO);
        if rng.chance(35) {
            spec.kind = PrimitiveKind::Downlink;
        } else if rng.chance(60) {
            spec.product = Some(ProductSpec {
                size_bytes: rng.range(1, 40) * 1_000,
                tier: [Tier::Decisional, Tier::Mandatory, Tier::Residual][rng.range(0, 2) as usize],
                value: rng.range(1, 9),
            });
        }
        primitives.push(p);
        specs.push(spec);
    }
    let mut net = FlatNetwork::default();
    for c in 0..rng.range(2, 5) {
        let mut chain = Chain::bare(c as u16, c as u8, small_utility(rng), 0);
        for _ in 0..rng.range(1, 3) {
            let i = rng.range(0, count as u64 - 1) as usize;
            chain.primitives.push(i as u8).expect("room");
            chain.energy_mj += primitives[i].energy_mj;
            chain.duration_us += primitives[i].duration_us;
            if let Some(spec) = specs[i].product {
                chain
                    .products
                    .push(ChainProduct {
                        offset_us: chain.duration_us,
                        spec,
                    })
                    .expect("room");
            }
        }
        net.chains.push(chain).expect("room");
    }
    let mut windows = Vec::new();
    let mut at = rng.range(0, 4);
    for _ in 0..rng.range(1, 3) {
        let len = rng.range(1, 5);
        windows.push(ViewWindow {
            start: hours(at),
            end: hours(at + len),
        });
        at += len + rng.range(1, 6);
    }
    let windows = ViewTimeline::new(&windows).expect("sorted");
    let view = EarthView::new(windows, &specs, &net);
    EarthCase {
        primitives,
        specs,
        net,
        view,
        battery_mj: rng.range(3, 25),
        horizon_h: rng.range(6, 24),
    }
}

/// The earliest start on the hour grid at which `candidate` may be added to `plan`, by the
/// rules written out directly: after now (0), ending by the horizon, overlapping no chain of
/// the plan, the plan's energy and the candidate's within the battery, the candidate's
/// downlinks inside one window, and, when it creates data its downlinks do not carry, a free
/// in-view hour after its end. Every time in the instance is whole hours, so the earliest
/// valid start is too.
fn earliest_by_hand(case: &EarthCase, plan: &[PlacedChain], candidate: u16) -> Option<u64> {
    let chain = &case.net.chains[usize::from(candidate)];
    let busy: Vec<(u64, u64)> = plan
        .iter()
        .map(|p| {
            let c = &case.net.chains[usize::from(p.chain)];
            (p.start.0, p.start.0 + c.duration_us)
        })
        .collect();
    let energy: u64 = plan
        .iter()
        .map(|p| case.net.chains[usize::from(p.chain)].energy_mj)
        .sum::<u64>()
        + chain.energy_mj;
    if energy > case.battery_mj {
        return None;
    }
    let in_view = |a: u64, b: u64| {
        case.view
            .windows
            .windows()
            .iter()
            .any(|w| w.start.0 <= a && b <= w.end.0)
    };
    // The downlink span, from the primitives themselves.
    let mut span: Option<(u64, u64)> = None;
    let mut t = 0;
    for &i in &chain.primitives {
        let d = case.primitives[usize::from(i)].duration_us;
        if case.specs[usize::from(i)].kind == PrimitiveKind::Downlink {
            span = Some(span.map_or((t, t + d), |(a, _)| (a, t + d)));
        }
        t += d;
    }
    let uncarried = chain
        .products
        .iter()
        .any(|p| span.is_none_or(|(a, _)| p.offset_us > a));
    (0..case.horizon_h).map(|h| h * HOUR).find(|&s| {
        let end = s + chain.duration_us;
        let overlaps = busy.iter().any(|&(a, b)| s < b && a < end);
        let downlink_ok = span.is_none_or(|(a, b)| in_view(s + a, s + b));
        let room = !uncarried
            || (end / HOUR..case.horizon_h).any(|h| {
                let (a, b) = (h * HOUR, (h + 1) * HOUR);
                in_view(a, b) && !busy.iter().any(|&(x, y)| x < b && a < y)
            });
        end <= case.horizon_h * HOUR && !overlaps && downlink_ok && room
    })
}

/// Issue 11 item 2's "can be added" with Earth in view: the MEXEC placement given the windows
/// places every chain where the rules written out directly say (the earliest valid start, or
/// none), and so does the simple timeline; with the downlink manager's data check around
/// each ([`DataPlacement`]) the two decide the same too. Without the windows the MEXEC
/// placement would put downlinks where Earth is not in view (counted: it happens).
#[test]
fn the_mexec_placement_keeps_downlinks_in_view_and_data_reachable_as_the_rules_say() {
    let (mut compared, mut placed, mut refused, mut blind_wrong) = (0, 0, 0, 0);
    let mut data_vetoes = 0;
    for seed in 0..400 {
        let mut rng = Rng::new(1_000 + seed);
        let case = earth_case(&mut rng);
        let tasks = network(&case.primitives, case.battery_mj);
        let anchors = anchors(&tasks);
        let definition_of: Vec<u8> = (0..case.primitives.len() as u8).collect();
        let horizon_end = hours(case.horizon_h);
        let mut mexec = MexecPlacement {
            network: &tasks,
            anchors: &anchors,
            held: &[],
            definition_of: &definition_of,
            now: MissionTimeUs::ZERO,
            plan_full: 0,
            earth: Some(MexecEarth {
                view: &case.view,
                horizon_end,
            }),
        };
        let mut simple = TimelinePlacement {
            horizon_start: MissionTimeUs::ZERO,
            horizon_end,
            phases: PhaseTimeline::default(),
            battery_mj: case.battery_mj,
            hotel_load_mw: 0,
            earth: case.view.clone(),
        };
        // Plans built chain by chain as the rules allow, every chain tried at each step.
        let mut plan: Vec<PlacedChain> = Vec::new();
        for _ in 0..3 {
            let mut next = None;
            for c in 0..case.net.chains.len() as u16 {
                let want = earliest_by_hand(&case, &plan, c).map(MissionTimeUs);
                assert_eq!(
                    mexec.place(&case.net, &plan, c),
                    want,
                    "seed {seed} {plan:?} {c}"
                );
                assert_eq!(
                    simple.place(&case.net, &plan, c),
                    want,
                    "seed {seed} {plan:?} {c}"
                );
                compared += 1;
                match want {
                    Some(start) => {
                        placed += 1;
                        next.get_or_insert(PlacedChain { chain: c, start });
                    }
                    None => refused += 1,
                }
                let mut blind = MexecPlacement {
                    earth: None,
                    ..mexec
                };
                let got = blind.place(&case.net, &plan, c);
                blind_wrong += usize::from(got.is_some() && got != want);
            }
            // The data check around each: the same decisions.
            let comms = CommsModel {
                rate_bps: 8 * rng.range(2, 12),
                overhead_us: 0,
                thermal_limit_us: 10 * HOUR,
                radio_power_mw: 0,
                per_downlink_mj: 1 << 30,
                per_sol_mj: 1 << 30,
                sol_us: 100 * HOUR,
            };
            let view = DataView {
                comms: &comms,
                onboard: &[],
                spans: &case.view.downlinks,
                spent: (0, 0),
            };
            let mut data_mexec = DataPlacement::new(
                MexecPlacement {
                    plan_full: 0,
                    ..mexec
                },
                view,
            );
            let mut data_simple = DataPlacement::new(simple.clone(), view);
            for c in 0..case.net.chains.len() as u16 {
                assert_eq!(
                    data_mexec.place(&case.net, &plan, c),
                    data_simple.place(&case.net, &plan, c),
                    "seed {seed}: data check, {plan:?} {c}"
                );
            }
            assert_eq!(data_mexec.stats, data_simple.stats, "seed {seed}");
            data_vetoes += data_mexec.stats.vetoes;
            match next {
                Some(p) => plan.push(p),
                None => break,
            }
        }
        assert_eq!(mexec.plan_full, 0);
    }
    println!("{compared} placements compared: {placed} placed, {refused} refused; {blind_wrong} wrong without the windows; {data_vetoes} data vetoes");
    assert!(
        placed > 200 && refused > 200,
        "{placed} placed, {refused} refused"
    );
    assert!(
        blind_wrong > 20,
        "windows change placements: {blind_wrong} of {compared}"
    );
    assert!(
        data_vetoes > 20,
        "the data check binds: {data_vetoes} vetoes"
    );
}

/// Instances the MEXEC planner already holds take in-view time too: a chain whose data needs a
/// later downlink is refused when held instances fill the rest of the only window, and placed
/// when they leave an hour of it.
#[test]
fn held_instances_take_in_view_time_from_data_waiting_for_a_downlink() {
    let primitives = [Primitive {
        duration_us: HOUR,
        energy_mj: 1,
    }];
    let tasks = network(&primitives, 100);
    let anchors = anchors(&tasks);
    let mut spec = primitive_spec(primitives[0], RankedUtility::ZERO);
    spec.product = Some(ProductSpec {
        size_bytes: 1_000,
        tier: Tier::Mandatory,
        value: 1,
    });
    let mut net = FlatNetwork::default();
    let mut chain = Chain::bare(1, 0, RankedUtility::ZERO, 1);
    chain.primitives.push(0).unwrap();
    chain.duration_us = HOUR;
    chain
        .products
        .push(ChainProduct {
            offset_us: HOUR,
            spec: spec.product.unwrap(),
        })
        .unwrap();
    net.chains.push(chain).unwrap();
    let windows = ViewTimeline::new(&[ViewWindow {
        start: hours(2),
        end: hours(4),
    }])
    .unwrap();
    let view = EarthView::new(windows, &[spec], &net);
    for (held_until, want) in [(4, None), (3, Some(hours(0)))] {
        let entries = [held(FIRST_INSTANCE_ID + 7, 0, 2, held_until)];
        let mut mexec = MexecPlacement {
            network: &tasks,
            anchors: &anchors,
            held: &entries,
            definition_of: &[0],
            now: MissionTimeUs::ZERO,
            plan_full: 0,
            earth: Some(MexecEarth {
                view: &view,
                horizon_end: hours(10),
            }),
        };
        assert_eq!(mexec.place(&net, &[], 0), want, "held until {held_until} h");
        // Without Earth the data is not followed: placed at once either way.
        mexec.earth = None;
        assert_eq!(mexec.place(&net, &[], 0), Some(hours(0)));
    }
}
