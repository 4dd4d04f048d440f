//! The downlink manager's exact multiple-knapsack branch and bound (seed 000 Appendix A)
//! against brute force on small random instances (value and the tie rule: the first optimum in
//! the documented order, which sends data down at the earliest opportunity), against a dynamic
//! programme over capacities on larger ones, anytime resumption, and the tier rules.
mod common;

use common::Rng;
use fsw_bridge::MissionTimeUs;
use lander::downlink::*;

const CASES: u64 = 400;

fn random_items(
    rng: &mut Rng,
    n: usize,
    bins: usize,
    max_size: u64,
    max_value: u64,
) -> Vec<KnapsackItem> {
    (0..n)
        .map(|_| KnapsackItem {
            size: rng.range(0, max_size),
            value: rng.range(0, max_value),
            allowed: (rng.next() as u16) & ((1u16 << bins) - 1),
        })
        .collect()
}

/// The solver's item order as documented, written independently: value per byte decreasing
/// (zero sizes first), then value decreasing, then index.
fn documented_order(items: &[KnapsackItem]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (&items[a], &items[b]);
        let key = |i: &KnapsackItem| {
            if i.size == 0 {
                (1u8, 0u128, 0u128)
            } else {
                (0, i.value as u128, i.size as u128)
            }
        };
        let (kx, ky) = (key(x), key(y));
        let density = if kx.0 != ky.0 {
            ky.0.cmp(&kx.0)
        } else {
            (ky.1 * kx.2).cmp(&(kx.1 * ky.2))
        };
        density.then(y.value.cmp(&x.value)).then(a.cmp(&b))
    });
    order
}

/// Every assignment, items in the documented order, each item's choice running through the
/// knapsacks in index order and then "not downlinked"; the first of the best is kept.
fn brute(items: &[KnapsackItem], capacities: &[u64]) -> (u64, Vec<u8>) {
    let order = documented_order(items);
    let m = capacities.len();
    let n = items.len();
    let mut digits = vec![0usize; n]; // 0..m: knapsack, m: not downlinked
    let mut best: Option<(u64, Vec<u8>)> = None;
    loop {
        let mut load = vec![0u64; m];
        let mut value = 0;
        let mut ok = true;
        for (d, &i) in order.iter().enumerate() {
            let j = digits[d];
            if j < m {
                ok &= items[i].allowed & (1 << j) != 0;
                load[j] += items[i].size;
                value += items[i].value;
            }
        }
        ok &= load.iter().zip(capacities).all(|(l, c)| l <= c);
        if ok && best.as_ref().is_none_or(|(b, _)| value > *b) {
            let mut assignment = vec![UNASSIGNED; n];
            for (d, &i) in order.iter().enumerate() {
                if digits[d] < m {
                    assignment[i] = digits[d] as u8;
                }
            }
            best = Some((value, assignment));
        }
        // Next assignment, the last item's digit fastest.
        let mut d = n;
        loop {
            if d == 0 {
                return best.expect("leaving everything out is feasible");
            }
            d -= 1;
            digits[d] += 1;
            if digits[d] <= m {
                break;
            }
            digits[d] = 0;
        }
    }
}

#[test]
fn branch_and_bound_matches_brute_force_value_and_tie_order() {
    for seed in 0..CASES {
        let mut rng = Rng::new(10_000 + seed);
        let bins = rng.range(1, 3) as usize;
        let n = rng.range(0, 7) as usize;
        let items = random_items(&mut rng, n, bins, 12, 6);
        let capacities: Vec<u64> = (0..bins).map(|_| rng.range(0, 20)).collect();
        let mut solver = MultipleKnapsack::new();
        solver.load(&items, &capacities).expect("loads");
        solver.solve();
        let (value, assignment) = brute(&items, &capacities);
        assert!(solver.proven_optimal());
        assert_eq!(
            solver.best_value(),
            value,
            "seed {seed}: {items:?} {capacities:?}"
        );
        assert_eq!(
            solver.assignment(),
            &assignment[..],
            "seed {seed}: {items:?} {capacities:?}"
        );
        assert!(solver.upper_bound() >= value);
        let documented: Vec<u8> = documented_order(&items).iter().map(|&i| i as u8).collect();
        assert_eq!(solver.order(), &documented[..]);
    }
}

/// Exact optimum by dynamic programming over the residual capacities (up to three knapsacks of
/// small capacity): a different exact method from the branch and bound.
fn dp_optimum(items: &[KnapsackItem], capacities: &[u64]) -> u64 {
    let caps: Vec<usize> = (0..3)
        .map(|j| capacities.get(j).copied().unwrap_or(0) as usize)
        .collect();
    let (a, b, c) = (caps[0] + 1, caps[1] + 1, caps[2] + 1);
    let idx = |x: usize, y: usize, z: usize| (x * b + y) * c + z;
    // best[x][y][z]: the most value with loads at most (x, y, z).
    let mut best = vec![0u64; a * b * c];
    for item in items {
        let s = item.size as usize;
        let mut next = best.clone();
        for x in 0..a {
            for y in 0..b {
                for z in 0..c {
                    let mut v = best[idx(x, y, z)];
                    if item.allowed & 1 != 0 && x >= s && !capacities.is_empty() {
                        v = v.max(best[idx(x - s, y, z)] + item.value);
                    }
                    if item.allowed & 2 != 0 && y >= s && capacities.len() > 1 {
                        v = v.max(best[idx(x, y - s, z)] + item.value);
                    }
                    if item.allowed & 4 != 0 && z >= s && capacities.len() > 2 {
                        v = v.max(best[idx(x, y, z - s)] + item.value);
                    }
                    next[idx(x, y, z)] = v;
                }
            }
        }
        best = next;
    }
    best[idx(caps[0], caps[1], caps[2])]
}

#[test]
fn branch_and_bound_matches_a_dynamic_programme_on_larger_instances() {
    for seed in 0..120 {
        let mut rng = Rng::new(20_000 + seed);
        let bins = rng.range(1, 3) as usize;
        let n = rng.range(8, 24) as usize;
        let items = random_items(&mut rng, n, bins, 15, 60);
        let capacities: Vec<u64> = (0..bins).map(|_| rng.range(5, 30)).collect();
        let mut solver = MultipleKnapsack::new();
        solver.load(&items, &capacities).expect("loads");
        solver.solve();
        assert_eq!(
            solver.best_value(),
            dp_optimum(&items, &capacities),
            "seed {seed}: {items:?} {capacities:?}"
        );
        // The assignment is feasible and worth what it says.
        let mut load = vec![0u64; bins];
        let mut value = 0;
        for (item, &j) in items.iter().zip(solver.assignment()) {
            if j != UNASSIGNED {
                assert!(item.allowed & (1 << j) != 0);
                load[usize::from(j)] += item.size;
                value += item.value;
            }
        }
        assert!(load.iter().zip(&capacities).all(|(l, c)| l <= c));
        assert_eq!(value, solver.best_value());
    }
}

#[test]
fn anytime_steps_resume_to_the_one_call_result_and_never_get_worse() {
    for seed in 0..150 {
        let mut rng = Rng::new(30_000 + seed);
        let bins = rng.range(1, 4) as usize;
        let n = rng.range(5, 20) as usize;
        let items = random_items(&mut rng, n, bins, 30, 100);
        let capacities: Vec<u64> = (0..bins).map(|_| rng.range(10, 60)).collect();
        let mut whole = MultipleKnapsack::new();
        whole.load(&items, &capacities).expect("loads");
        whole.solve();
        let mut pieces = MultipleKnapsack::new();
        pieces.load(&items, &capacities).expect("loads");
        let mut last = pieces.best_value();
        loop {
            let step = pieces.step(rng.range(1, 7) as u32);
            assert!(pieces.best_value() >= last, "seed {seed}");
            assert!(pieces.best_value() <= whole.best_value());
            last = pieces.best_value();
            if step.done {
                break;
            }
            assert!(!pieces.proven_optimal());
        }
        assert_eq!(pieces.assignment(), whole.assignment(), "seed {seed}");
        assert_eq!(pieces.nodes(), whole.nodes(), "seed {seed}");
    }
}

fn product(size: u64, value: u64, at_h: u64, tier: Tier) -> DataProduct {
    DataProduct {
        size_bytes: size,
        value,
        created_at: MissionTimeUs(at_h * 3_600_000_000),
        tier,
    }
}

fn starts(hours: &[u64]) -> Vec<MissionTimeUs> {
    hours
        .iter()
        .map(|h| MissionTimeUs(h * 3_600_000_000))
        .collect()
}

#[test]
fn critical_and_decisional_products_take_the_first_opportunity_after_their_creation() {
    let mut m = DownlinkManager::new();
    let products = [
        product(10, 1, 5, Tier::Decisional),
        product(10, 1, 0, Tier::Critical),
        product(10, 1, 11, Tier::Critical),
        product(50, 1, 0, Tier::Decisional), // does not fit what is left of opportunity 0
    ];
    m.load_capacities(&products, &starts(&[1, 10, 20]), &[40, 40, 40])
        .expect("loads");
    m.solve();
    assert_eq!(m.placement(0), Placement::Downlink(1));
    assert_eq!(m.placement(1), Placement::Downlink(0));
    assert_eq!(m.placement(2), Placement::Downlink(2));
    assert_eq!(m.placement(3), Placement::NotDownlinked);
    assert_eq!(m.required_unplaced(), 1);
}

#[test]
fn mandatory_products_go_down_before_any_residual_value() {
    let mut m = DownlinkManager::new();
    // One opportunity of 10 bytes: the mandatory product (value 1) beats residual value 1000.
    let products = [
        product(10, 1_000, 0, Tier::Residual),
        product(10, 1, 0, Tier::Mandatory),
    ];
    m.load_capacities(&products, &starts(&[1]), &[10])
        .expect("loads");
    m.solve();
    assert_eq!(m.placement(1), Placement::Downlink(0));
    assert_eq!(m.placement(0), Placement::NotDownlinked);
    assert_eq!(m.required_unplaced(), 0);
    assert_eq!(m.downlinked_value(), 1);
    assert!(m.proven_optimal());
}

#[test]
fn a_product_goes_down_only_after_it_is_created_and_earliest_on_ties() {
    let mut m = DownlinkManager::new();
    let products = [
        product(5, 3, 15, Tier::Mandatory),
        product(5, 3, 0, Tier::Residual),
    ];
    m.load_capacities(&products, &starts(&[1, 10, 20, 30]), &[100, 100, 100, 100])
        .expect("loads");
    m.solve();
    assert_eq!(
        m.placement(0),
        Placement::Downlink(2),
        "created at 15 h: the 20 h opportunity"
    );
    assert_eq!(
        m.placement(1),
        Placement::Downlink(0),
        "ties go to the earliest opportunity"
    );
}

#[test]
fn capacities_follow_the_window_the_thermal_limit_and_the_sol_energy() {
    let hour = 3_600_000_000;
    let opp = |start_h: u64, sol: u16| DownlinkOpportunity {
        start: MissionTimeUs(start_h * hour),
        end: MissionTimeUs(start_h * hour + 2 * hour),
        overhead_us: 600_000_000, // 10 min
        sol,
        rate_bps: 8_000,        // 1000 bytes per second
        radio_power_mw: 10_000, // 10 J per second
        thermal_limit_us: hour,
    };
    let opportunities = [opp(0, 0), opp(10, 0), opp(20, 1), opp(30, 2)];
    let allocations = [
        SolAllocation {
            sol: 0,
            energy_mj: 50_000_000,
        }, // 5000 s of radio
        SolAllocation {
            sol: 1,
            energy_mj: 10_000_000,
        }, // 1000 s
        SolAllocation {
            sol: 2,
            energy_mj: 1_000_000_000,
        },
    ];
    let caps = capacities(&opportunities, &allocations).expect("computes");
    // Window 110 min, thermal 60 min: 3600 s; sol 0 pays 5000 s: 3600 then 1400.
    assert_eq!(
        caps.as_slice(),
        &[3_600_000, 1_400_000, 1_000_000, 3_600_000]
    );
    let missing = [SolAllocation {
        sol: 0,
        energy_mj: 1,
    }];
    assert_eq!(
        capacities(&opportunities, &missing),
        Err(DownlinkError::NoAllocation { index: 2 })
    );
}
