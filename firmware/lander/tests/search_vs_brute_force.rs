//! Algorithm 1 (seed 000 III.A) against brute force on small random flat networks: with an
//! unlimited bound the search finds the optimum over every order the placement accepts, the
//! energy pruning never removes it, the phased outer loop holds each batch's best fixed, and
//! the anytime search split over many small steps gives exactly the one-call result.
mod common;

use common::*;
use fsw_bridge::MissionTimeUs;
use heapless::Vec as HVec;
use lander::capacity::MAX_PLAN_CHAINS;
use lander::htn::{FlatNetwork, PhaseTimeline};
use lander::placement::TimelinePlacement;
use lander::search::{ChainPlacement, PlacedChain, Search, SearchConfig};
use lander::utility::RankedUtility;

const CASES: u64 = 300;

/// Room for every order of up to four tasks of three alternatives (Algorithm 1 explores orders).
type Big = Search<6_000, 6_000>;

/// A placement that leaves energy to the search (a battery it never reaches), over a horizon
/// short enough that some plans do not fit.
fn placement(rng: &mut Rng) -> TimelinePlacement {
    TimelinePlacement {
        horizon_start: MissionTimeUs::ZERO,
        horizon_end: hours(rng.range(3, 12)),
        phases: PhaseTimeline::default(),
        battery_mj: u64::MAX / 4,
        hotel_load_mw: 0,
        earth: Default::default(),
    }
}

fn better(a: (RankedUtility, u64), b: (RankedUtility, u64)) -> bool {
    a.0 > b.0 || (a.0 == b.0 && a.1 < b.1)
}

fn value_of(net: &FlatNetwork, plan: &[PlacedChain]) -> (RankedUtility, u64) {
    plan.iter().fold((RankedUtility::ZERO, 0), |(u, c), p| {
        let chain = &net.chains[usize::from(p.chain)];
        (
            u.checked_add(&chain.utility).expect("no overflow"),
            c + chain.energy_mj,
        )
    })
}

/// The best (utility, cost) over every sequence of chains of `batch` (distinct tasks) that the
/// placement accepts one after the other from `plan`, keeping only plans within `battery`.
fn brute(
    net: &FlatNetwork,
    placement: &mut TimelinePlacement,
    plan: &mut Vec<PlacedChain>,
    batch: u8,
    battery: u64,
) -> (RankedUtility, u64) {
    let here = value_of(net, plan);
    let mut best = if here.1 <= battery {
        here
    } else {
        (RankedUtility::ZERO, u64::MAX)
    };
    for (i, chain) in net.chains.iter().enumerate() {
        if chain.batch != batch
            || plan
                .iter()
                .any(|p| net.chains[usize::from(p.chain)].task == chain.task)
        {
            continue;
        }
        if let Some(start) = placement.place(net, plan, i as u16) {
            plan.push(PlacedChain {
                chain: i as u16,
                start,
            });
            let sub = brute(net, placement, plan, batch, battery);
            plan.pop();
            if better(sub, best) {
                best = sub;
            }
        }
    }
    best
}

fn plan_of(search: &Big) -> Vec<PlacedChain> {
    let mut out: HVec<PlacedChain, MAX_PLAN_CHAINS> = HVec::new();
    search.best_plan(&mut out);
    out.to_vec()
}

/// Every chain of `plan` is where the placement puts it after the chains before it.
fn assert_replays(net: &FlatNetwork, placement: &mut TimelinePlacement, plan: &[PlacedChain]) {
    for k in 0..plan.len() {
        assert_eq!(
            placement.place(net, &plan[..k], plan[k].chain),
            Some(plan[k].start),
            "chain {k} of {plan:?}"
        );
    }
}

#[test]
fn unlimited_search_finds_the_brute_force_optimum() {
    let mut pruned_somewhere = 0;
    for seed in 0..CASES {
        let mut rng = Rng::new(seed);
        let tasks = rng.range(1, 4) as u8;
        let net = random_network(&mut rng, tasks, 1);
        let mut place = placement(&mut rng);
        let battery = rng.range(0, 25);
        let mut search: Big = Search::new(SearchConfig::exhaustive(battery));
        search.start(&net, &[]).expect("starts");
        search.run(&net, &mut place);
        let expected = brute(&net, &mut place, &mut Vec::new(), 1, battery);
        let plan = plan_of(&search);
        assert_eq!(search.best_value(), expected, "seed {seed}: plan {plan:?}");
        assert_eq!(value_of(&net, &plan), expected, "seed {seed}");
        assert!(
            search.stats().exhaustive(),
            "seed {seed}: {:?}",
            search.stats()
        );
        assert_replays(&net, &mut place, &plan);
        pruned_somewhere += search.stats().pruned_by_energy;
    }
    assert!(
        pruned_somewhere > 0,
        "the cases must exercise the energy pruning"
    );
}

#[test]
fn energy_pruning_never_removes_the_optimum() {
    for seed in 0..CASES {
        let mut rng = Rng::new(1_000 + seed);
        let tasks = rng.range(1, 4) as u8;
        let net = random_network(&mut rng, tasks, 1);
        let mut place = placement(&mut rng);
        let battery = rng.range(0, 20);
        let mut pruned: Big = Search::new(SearchConfig::exhaustive(battery));
        pruned.start(&net, &[]).expect("starts");
        pruned.run(&net, &mut place);
        let mut unpruned: Big = Search::new(SearchConfig {
            energy_pruning: false,
            ..SearchConfig::exhaustive(battery)
        });
        unpruned.start(&net, &[]).expect("starts");
        unpruned.run(&net, &mut place);
        assert_eq!(pruned.best_value(), unpruned.best_value(), "seed {seed}");
        assert!(
            pruned.stats().explored <= unpruned.stats().explored,
            "seed {seed}"
        );
        assert!(
            unpruned.best_value().1 <= battery,
            "seed {seed}: selection keeps the battery"
        );
    }
}

#[test]
fn anytime_steps_resume_to_the_one_call_result() {
    for seed in 0..CASES {
        let mut rng = Rng::new(2_000 + seed);
        let tasks = rng.range(1, 4) as u8;
        let net = random_network(&mut rng, tasks, 3);
        let mut place = placement(&mut rng);
        let battery = rng.range(5, 30);
        let bound = if rng.chance(50) {
            None
        } else {
            Some(rng.range(1, 40) as u32)
        };
        let config = SearchConfig {
            exploration_bound: bound,
            ..SearchConfig::exhaustive(battery)
        };
        let mut whole: Big = Search::new(config);
        whole.start(&net, &[]).expect("starts");
        whole.run(&net, &mut place);

        let mut pieces: Big = Search::new(config);
        pieces.start(&net, &[]).expect("starts");
        let mut calls = 0;
        loop {
            let step = pieces.step(&net, &mut place, rng.range(1, 4) as u32);
            calls += 1;
            // The best so far is always a valid plan.
            let so_far = plan_of(&pieces);
            assert_replays(&net, &mut place, &so_far);
            assert_eq!(value_of(&net, &so_far), pieces.best_value(), "seed {seed}");
            if step.done {
                break;
            }
        }
        assert!(calls >= 1);
        assert_eq!(plan_of(&pieces), plan_of(&whole), "seed {seed}");
        assert_eq!(pieces.stats(), whole.stats(), "seed {seed}");
    }
}

#[test]
fn the_exploration_bound_limits_each_batch() {
    for seed in 0..CASES {
        let mut rng = Rng::new(3_000 + seed);
        let tasks = rng.range(2, 4) as u8;
        let net = random_network(&mut rng, tasks, 2);
        let mut place = placement(&mut rng);
        let battery = rng.range(5, 30);
        let bound = rng.range(1, 6) as u32;
        let mut search: Big = Search::new(SearchConfig {
            exploration_bound: Some(bound),
            ..SearchConfig::exhaustive(battery)
        });
        search.start(&net, &[]).expect("starts");
        search.run(&net, &mut place);
        assert!(
            search.stats().explored <= 2 * bound,
            "seed {seed}: {:?}",
            search.stats()
        );
        let plan = plan_of(&search);
        assert_replays(&net, &mut place, &plan);
        assert!(value_of(&net, &plan).1 <= battery);
    }
}

#[test]
fn each_batch_is_searched_from_the_previous_batch_best_held_fixed() {
    for seed in 0..CASES {
        let mut rng = Rng::new(4_000 + seed);
        let tasks = rng.range(2, 4) as u8;
        let net = random_network(&mut rng, tasks, 2);
        let mut place = placement(&mut rng);
        let battery = rng.range(5, 30);
        let mut search: Big = Search::new(SearchConfig::exhaustive(battery));
        search.start(&net, &[]).expect("starts");
        search.run(&net, &mut place);
        let plan = plan_of(&search);
        // Batch 1's chains come first and are batch 1's optimum from the empty plan.
        let split = plan
            .iter()
            .take_while(|p| net.chains[usize::from(p.chain)].batch == 1)
            .count();
        assert!(
            plan[split..]
                .iter()
                .all(|p| net.chains[usize::from(p.chain)].batch == 2),
            "seed {seed}"
        );
        let first = brute(&net, &mut place, &mut Vec::new(), 1, battery);
        assert_eq!(value_of(&net, &plan[..split]), first, "seed {seed}");
        // Batch 2's part is its optimum from that plan.
        let total = brute(&net, &mut place, &mut plan[..split].to_vec(), 2, battery);
        assert_eq!(value_of(&net, &plan), total, "seed {seed}");
    }
}

#[test]
fn exogenous_chains_are_placed_first_at_their_fixed_start() {
    let mut rng = Rng::new(7);
    let mut net = random_network(&mut rng, 4, 1);
    for (k, at) in [(0u8, 5u64), (1, 1)] {
        let mut uplink =
            lander::htn::Chain::bare(50 + u16::from(k), 10 + k, RankedUtility::ZERO, 1);
        uplink.batch = 0;
        uplink.duration_us = HOUR;
        uplink.fixed_start = Some(hours(at));
        uplink.is_uplink = true;
        net.chains.push(uplink).expect("capacity");
    }
    let mut place = TimelinePlacement {
        horizon_start: MissionTimeUs::ZERO,
        horizon_end: hours(30),
        phases: PhaseTimeline::default(),
        battery_mj: u64::MAX / 4,
        hotel_load_mw: 0,
        earth: Default::default(),
    };
    let mut search: Big = Search::new(SearchConfig::exhaustive(1_000));
    search.start(&net, &[]).expect("starts");
    search.run(&net, &mut place);
    let plan = plan_of(&search);
    let n = net.chains.len() as u16;
    assert_eq!(
        plan[0],
        PlacedChain {
            chain: n - 1,
            start: hours(1)
        }
    );
    assert_eq!(
        plan[1],
        PlacedChain {
            chain: n - 2,
            start: hours(5)
        }
    );
    assert!(plan
        .iter()
        .skip(2)
        .all(|p| p.start != hours(1) && p.start != hours(5)));
}
