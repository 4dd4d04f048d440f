//! Ordering properties of ranked utility (seed 000 IV.C.1) and of the ranked ratio
//! T.utility / T.cost the search orders by ([`UtilityRate`], [`Priority`]), over the whole range
//! the capacities allow: monotone in the utility, anti-monotone in the cost, the same order as
//! the utilities at equal cost, a total order, and exact (no overflow, no rounding) up to a
//! full plan's sums and the largest energy, checked against a comparison of rationals that
//! never multiplies (Euclid's algorithm on quotients and remainders).
use core::cmp::Ordering;

use lander::capacity::{MAX_CHAIN_PRIMITIVES, MAX_ENERGY_MJ, MAX_PLAN_CHAINS};
use lander::utility::{
    Priority, Rank, RankedUtility, Score, UtilityRate, MAX_SCORE_TERMS, RANK_COUNT, SCORE_ONE,
};
use proptest::prelude::*;

/// The largest sum one rank of a plan can reach.
const MAX_SUM: u32 = (MAX_SCORE_TERMS * SCORE_ONE as u64) as u32;

/// A utility with these rank sums, built only through the public API: adding items whose
/// scores are at most 1.0, as chains and plans add primitives.
fn utility(sums: [u32; RANK_COUNT]) -> RankedUtility {
    let mut left = sums;
    let mut out = RankedUtility::ZERO;
    while left.iter().any(|&s| s > 0) {
        let mut scores = [Score::ZERO; RANK_COUNT];
        for (score, rest) in scores.iter_mut().zip(left.iter_mut()) {
            let take = (*rest).min(u32::from(SCORE_ONE));
            *score = Score::new(take).expect("at most 1.0");
            *rest -= take;
        }
        out = out
            .checked_add(&RankedUtility::from_scores(scores))
            .expect("inside the capacities");
    }
    assert_eq!(out.sums(), sums);
    out
}

/// a / b against c / d (b, d > 0) without multiplying: compare the integer parts, then the
/// reciprocals of the remainders.
fn cmp_fraction(a: u128, b: u128, c: u128, d: u128) -> Ordering {
    let (qa, ra, qc, rc) = (a / b, a % b, c / d, c % d);
    if qa != qc {
        return qa.cmp(&qc);
    }
    match (ra == 0, rc == 0) {
        (true, true) => Ordering::Equal,
        (true, false) => Ordering::Less,
        (false, true) => Ordering::Greater,
        // ra / b vs rc / d  <=>  d / rc vs b / ra.
        (false, false) => cmp_fraction(d, rc, b, ra),
    }
}

/// The reference order of h(P, T) = P + T / cost: rank by rank (P·cost + T) / cost.
fn reference_priority(
    plan_a: [u32; RANK_COUNT],
    chain_a: [u32; RANK_COUNT],
    cost_a: u64,
    plan_b: [u32; RANK_COUNT],
    chain_b: [u32; RANK_COUNT],
    cost_b: u64,
) -> Ordering {
    let (ca, cb) = (u128::from(cost_a.max(1)), u128::from(cost_b.max(1)));
    for k in 0..RANK_COUNT {
        let a = u128::from(plan_a[k]) * ca + u128::from(chain_a[k]);
        let b = u128::from(plan_b[k]) * cb + u128::from(chain_b[k]);
        match cmp_fraction(a, ca, b, cb) {
            Ordering::Equal => continue,
            unequal => return unequal,
        }
    }
    Ordering::Equal
}

/// Rank sums: often small (so that ties and equal ranks happen), sometimes anywhere up to a
/// full plan's sum.
fn sums() -> impl Strategy<Value = [u32; RANK_COUNT]> {
    let one = prop_oneof![
        3 => 0u32..4,
        2 => 0u32..=u32::from(SCORE_ONE),
        2 => 0u32..=MAX_SUM,
        1 => Just(MAX_SUM),
    ];
    proptest::array::uniform7(one)
}

/// Costs in mJ: zero (divided as one), small, anywhere, or the largest allowed.
fn cost() -> impl Strategy<Value = u64> {
    prop_oneof![
        1 => Just(0u64),
        3 => 1u64..20,
        3 => 1u64..=MAX_ENERGY_MJ,
        1 => Just(MAX_ENERGY_MJ),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn the_rate_rises_when_any_score_rises(
        base in sums(),
        rank in 0usize..RANK_COUNT,
        raise in 1u32..=u32::from(SCORE_ONE),
        c in cost(),
    ) {
        prop_assume!(base[rank] <= MAX_SUM - raise);
        let mut higher = base;
        higher[rank] += raise;
        prop_assert!(utility(higher) > utility(base));
        prop_assert!(utility(higher).per_cost(c) > utility(base).per_cost(c));
        // And h(P, T) rises with either the plan's or the chain's utility.
        let other = utility(base).per_cost(c);
        prop_assert_eq!(
            Priority::new(utility(higher), other).cmp(&Priority::new(utility(base), other)),
            Ordering::Greater
        );
        prop_assert_eq!(
            Priority::new(utility(base), utility(higher).per_cost(c))
                .cmp(&Priority::new(utility(base), other)),
            Ordering::Greater
        );
    }

    #[test]
    fn the_rate_falls_when_the_cost_rises(
        u in sums(),
        c in 1u64..MAX_ENERGY_MJ,
        more in 1u64..=MAX_ENERGY_MJ,
    ) {
        let dearer = c.saturating_add(more).min(MAX_ENERGY_MJ);
        let (cheap, expensive) = (utility(u).per_cost(c), utility(u).per_cost(dearer));
        if u.iter().all(|&s| s == 0) {
            prop_assert_eq!(cheap, expensive);
        } else {
            prop_assert!(cheap > expensive, "{:?} / {} vs / {}", u, c, dearer);
        }
    }

    #[test]
    fn at_equal_cost_rates_order_as_the_utilities(a in sums(), b in sums(), c in cost()) {
        let (ua, ub) = (utility(a), utility(b));
        prop_assert_eq!(ua.per_cost(c).cmp(&ub.per_cost(c)), ua.cmp(&ub));
        prop_assert_eq!(ua.per_cost(c) == ub.per_cost(c), ua == ub);
        // Lexicographic from the Mission rank down: the first differing rank decides.
        prop_assert_eq!(ua.cmp(&ub), a.cmp(&b));
    }

    #[test]
    fn rates_and_priorities_are_exact_at_capacity(
        plan_a in sums(), chain_a in sums(), cost_a in cost(),
        plan_b in sums(), chain_b in sums(), cost_b in cost(),
    ) {
        let (ra, rb) = (utility(chain_a).per_cost(cost_a), utility(chain_b).per_cost(cost_b));
        let zero = [0; RANK_COUNT];
        prop_assert_eq!(ra.cmp(&rb), reference_priority(zero, chain_a, cost_a, zero, chain_b, cost_b));
        prop_assert_eq!(
            Priority::new(utility(plan_a), ra).cmp(&Priority::new(utility(plan_b), rb)),
            reference_priority(plan_a, chain_a, cost_a, plan_b, chain_b, cost_b)
        );
    }

    #[test]
    fn the_orders_are_total(
        a in sums(), b in sums(), c in sums(),
        ca in cost(), cb in cost(), cc in cost(),
    ) {
        let (x, y, z) = (utility(a).per_cost(ca), utility(b).per_cost(cb), utility(c).per_cost(cc));
        prop_assert_eq!(x.cmp(&y), y.cmp(&x).reverse());
        prop_assert_eq!(x == y, x.cmp(&y) == Ordering::Equal);
        if x <= y && y <= z {
            prop_assert!(x <= z);
        }
        let (p, q, r) = (
            Priority::new(utility(a), y),
            Priority::new(utility(b), z),
            Priority::new(utility(c), x),
        );
        prop_assert_eq!(p.cmp(&q), q.cmp(&p).reverse());
        if p <= q && q <= r {
            prop_assert!(p <= r);
        }
    }

    #[test]
    fn a_higher_rank_outweighs_every_lower_rank(
        a in sums(), b in sums(), rank in 0usize..RANK_COUNT - 1, ca in cost(), cb in cost(),
    ) {
        // Equal above `rank`, a ahead at `rank`: a wins whatever the lower ranks are, at equal
        // cost and as a plan utility in h(P, T) with the same chain.
        let mut a = a;
        let mut b = b;
        b[..rank].copy_from_slice(&a[..rank]);
        prop_assume!(a[rank] != b[rank]);
        if a[rank] < b[rank] {
            core::mem::swap(&mut a, &mut b);
        }
        for k in rank + 1..RANK_COUNT {
            a[k] = 0;
            b[k] = MAX_SUM;
        }
        prop_assert!(utility(a) > utility(b));
        prop_assert!(utility(a).per_cost(ca) > utility(b).per_cost(ca));
        let chain = utility(b).per_cost(cb);
        prop_assert!(Priority::new(utility(a), chain) > Priority::new(utility(b), chain));
    }
}

#[test]
fn a_full_plan_of_perfect_scores_adds_without_overflow() {
    let perfect = RankedUtility::from_scores([Score::ONE; RANK_COUNT]);
    let mut plan = RankedUtility::ZERO;
    for _ in 0..MAX_PLAN_CHAINS * MAX_CHAIN_PRIMITIVES {
        plan = plan.checked_add(&perfect).expect("no overflow at capacity");
    }
    assert_eq!(plan.at(Rank::Mission), MAX_SUM);
    assert_eq!(plan.at(Rank::Default), MAX_SUM);
    // The exact comparison still tells apart rates that differ by one part in the largest
    // products it forms.
    let a = plan.per_cost(MAX_ENERGY_MJ);
    let b = plan.per_cost(MAX_ENERGY_MJ - 1);
    assert!(a < b);
    let almost = utility([MAX_SUM - 1; RANK_COUNT]).per_cost(MAX_ENERGY_MJ - 1);
    assert_eq!(
        a.cmp(&almost),
        cmp_fraction(
            u128::from(MAX_SUM),
            u128::from(MAX_ENERGY_MJ),
            u128::from(MAX_SUM - 1),
            u128::from(MAX_ENERGY_MJ - 1)
        )
    );
}

#[test]
fn rates_equal_as_rationals_are_equal() {
    let one = RankedUtility::single(Rank::Analysis, Score::new(1).expect("valid"));
    let two = one.checked_add(&one).expect("fits");
    assert_eq!(two.per_cost(2), one.per_cost(1));
    assert_eq!(UtilityRate::default(), RankedUtility::ZERO.per_cost(7));
    assert!(UtilityRate::default() < one.per_cost(MAX_ENERGY_MJ));
}
