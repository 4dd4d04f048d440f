//! Ranked utility (seed 000 IV.C.1): a utility is seven science scores, one per rank (Mission,
//! Analysis, Post-collection, Pre-collection, Post-excavation, Pre-excavation, Default), each a
//! fixed-point value in [0, 1]. Utilities add rank by rank and compare lexicographically from
//! the Mission rank down, so a higher score at a higher rank beats any score at a lower one.
//!
//! The search needs T.utility / T.cost, which the paper leaves undefined for ranked utility.
//! Here it is [`UtilityRate`], the vector of exact rationals `score_k / cost`, compared
//! lexicographically rank by rank:
//! - it is what "utility per unit energy" means for each independent measure, and it keeps
//!   the dominance the ranks exist for: a chain that buys more Mission score per joule is
//!   preferred whatever its lower-rank rates are;
//! - at equal cost it orders exactly as the utilities do (the cost cancels in every rank);
//! - it rises when any score rises and falls when the cost rises (strictly, unless the
//!   utility is zero);
//! - it is exact: rationals are compared by cross-multiplication in `u128`, never divided, so
//!   rounding can neither merge two different rates nor reorder them, and host and target
//!   agree bit for bit.
//!
//! The alternatives were worse: one weighted scalar (the weights must outgrow every lower-rank
//! sum, which overflows any integer at mission size and breaks the dominance when scores are
//! summed), or dividing each rank with integer division (two different rates can round equal
//! and let a lower rank reverse the order, breaking consistency at equal cost).
//!
//! h(P, T) = P.utility + T.utility / T.cost is [`Priority`]: per rank the exact rational
//! `P_k + T_k / cost`, compared the same way.
use core::cmp::Ordering;

use serde::{Deserialize, Serialize};

use crate::capacity::{MAX_CHAIN_PRIMITIVES, MAX_ENERGY_MJ, MAX_PLAN_CHAINS};

/// The ranks, highest first (seed 000 IV.C.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[repr(u8)]
pub enum Rank {
    /// Mission rules (the science subway map); dominates every other rank.
    Mission = 0,
    /// The final onboard analysis of a sample (biosignature).
    Analysis = 1,
    PostCollection = 2,
    PreCollection = 3,
    PostExcavation = 4,
    PreExcavation = 5,
    /// Some value just for existing.
    Default = 6,
}

/// Number of ranks.
pub const RANK_COUNT: usize = 7;

impl Rank {
    /// Every rank, highest first.
    pub const ALL: [Rank; RANK_COUNT] = [
        Rank::Mission,
        Rank::Analysis,
        Rank::PostCollection,
        Rank::PreCollection,
        Rank::PostExcavation,
        Rank::PreExcavation,
        Rank::Default,
    ];
}

/// Fixed-point score that stands for 1.0: scores are in units of 1/10 000.
pub const SCORE_ONE: u16 = 10_000;

/// The most scores one rank of a plan's utility can add up: every primitive of every chain of a
/// full plan scoring 1.0.
pub const MAX_SCORE_TERMS: u64 = (MAX_PLAN_CHAINS * MAX_CHAIN_PRIMITIVES) as u64;

// A full plan's sums stay far inside u32, so [`RankedUtility::checked_add`] cannot fail at the
// configured capacities; the cross-multiplications below stay inside u128.
const _: () = assert!(MAX_SCORE_TERMS * SCORE_ONE as u64 <= u32::MAX as u64);
const _: () = assert!(
    (u32::MAX as u128 + 1) * (MAX_ENERGY_MJ as u128 + 1) * (MAX_ENERGY_MJ as u128) < u128::MAX / 2
);

/// One score in [0, 1] as a multiple of 1/[`SCORE_ONE`].
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Score(u16);

/// A score above 1.0 was asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScoreOutOfRange(pub u32);

impl Score {
    pub const ZERO: Self = Self(0);
    pub const ONE: Self = Self(SCORE_ONE);

    /// A score of `ten_thousandths` / 10 000; an error above 1.0.
    pub const fn new(ten_thousandths: u32) -> Result<Self, ScoreOutOfRange> {
        if ten_thousandths > SCORE_ONE as u32 {
            Err(ScoreOutOfRange(ten_thousandths))
        } else {
            Ok(Self(ten_thousandths as u16))
        }
    }

    /// The fixed-point value (1.0 is [`SCORE_ONE`]).
    pub const fn ten_thousandths(self) -> u16 {
        self.0
    }
}

/// A utility: the summed scores of each rank, highest rank first. One data product or primitive
/// has scores in [0, 1]; chains and plans add them rank by rank.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct RankedUtility {
    /// Sum of scores per rank, in units of 1/[`SCORE_ONE`], indexed by [`Rank`].
    sums: [u32; RANK_COUNT],
}

/// A rank sum would leave `u32` (more terms than any plan at the configured capacities has).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UtilityOverflow;

impl RankedUtility {
    pub const ZERO: Self = Self {
        sums: [0; RANK_COUNT],
    };

    /// The utility of one item with these scores.
    pub fn from_scores(scores: [Score; RANK_COUNT]) -> Self {
        let mut sums = [0u32; RANK_COUNT];
        for (sum, score) in sums.iter_mut().zip(scores) {
            *sum = u32::from(score.0);
        }
        Self { sums }
    }

    /// The utility of one item scoring `score` at `rank` only.
    pub fn single(rank: Rank, score: Score) -> Self {
        let mut u = Self::ZERO;
        if let Some(sum) = u.sums.get_mut(rank as usize) {
            *sum = u32::from(score.0);
        }
        u
    }

    /// The summed score at `rank`.
    pub fn at(&self, rank: Rank) -> u32 {
        self.sums.get(rank as usize).copied().unwrap_or(0)
    }

    /// Every rank's sum, highest rank first.
    pub fn sums(&self) -> [u32; RANK_COUNT] {
        self.sums
    }

    /// Rank-by-rank sum; an error if any rank leaves `u32`.
    pub fn checked_add(&self, other: &Self) -> Result<Self, UtilityOverflow> {
        let mut sums = [0u32; RANK_COUNT];
        for ((out, a), b) in sums.iter_mut().zip(self.sums).zip(other.sums) {
            *out = a.checked_add(b).ok_or(UtilityOverflow)?;
        }
        Ok(Self { sums })
    }

    /// Rank-by-rank sum, each rank saturating at `u32::MAX`. Used where the capacities already
    /// guarantee no saturation (see [`MAX_SCORE_TERMS`]).
    pub fn saturating_add(&self, other: &Self) -> Self {
        let mut sums = [0u32; RANK_COUNT];
        for ((out, a), b) in sums.iter_mut().zip(self.sums).zip(other.sums) {
            *out = a.saturating_add(b);
        }
        Self { sums }
    }

    /// Whether every rank is zero.
    pub fn is_zero(&self) -> bool {
        self.sums.iter().all(|&s| s == 0)
    }

    /// This utility per unit of `cost_mj` (T.utility / T.cost).
    pub fn per_cost(&self, cost_mj: u64) -> UtilityRate {
        UtilityRate::new(*self, cost_mj)
    }
}

impl Ord for RankedUtility {
    /// Lexicographic from the Mission rank down.
    fn cmp(&self, other: &Self) -> Ordering {
        self.sums.cmp(&other.sums)
    }
}

impl PartialOrd for RankedUtility {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The smallest cost a ratio divides by: energy is counted in whole millijoules and a chain
/// that names zero is taken to cost one (it still uses the hotel load while it runs).
pub const MIN_RATIO_COST_MJ: u64 = 1;

/// T.utility / T.cost for ranked utility: per rank the exact rational `sum_k / cost_mj`,
/// compared lexicographically from the Mission rank down (see the module docs for why).
/// Equality is equality of the rationals (2/2 equals 1/1), as the order needs.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct UtilityRate {
    utility: RankedUtility,
    cost_mj: u64,
}

impl Default for UtilityRate {
    /// Zero utility per [`MIN_RATIO_COST_MJ`].
    fn default() -> Self {
        Self::new(RankedUtility::ZERO, MIN_RATIO_COST_MJ)
    }
}

impl PartialEq for UtilityRate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for UtilityRate {}

impl UtilityRate {
    /// `utility / cost_mj`; the cost is clamped into `[MIN_RATIO_COST_MJ, MAX_ENERGY_MJ]`.
    pub fn new(utility: RankedUtility, cost_mj: u64) -> Self {
        Self {
            utility,
            cost_mj: cost_mj.clamp(MIN_RATIO_COST_MJ, MAX_ENERGY_MJ),
        }
    }

    pub fn utility(&self) -> RankedUtility {
        self.utility
    }

    /// The (clamped) cost divided by.
    pub fn cost_mj(&self) -> u64 {
        self.cost_mj
    }
}

impl Ord for UtilityRate {
    fn cmp(&self, other: &Self) -> Ordering {
        for (a, b) in self.utility.sums.iter().zip(other.utility.sums.iter()) {
            // a / ca vs b / cb  <=>  a * cb vs b * ca (costs are positive).
            let left = u128::from(*a) * u128::from(other.cost_mj);
            let right = u128::from(*b) * u128::from(self.cost_mj);
            match left.cmp(&right) {
                Ordering::Equal => continue,
                unequal => return unequal,
            }
        }
        Ordering::Equal
    }
}

impl PartialOrd for UtilityRate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The search's priority h(P, T) = P.utility + T.utility / T.cost: per rank the exact rational
/// `P_k + T_k / cost`, compared lexicographically from the Mission rank down.
#[derive(Clone, Copy, Debug, Default)]
pub struct Priority {
    plan: RankedUtility,
    chain: UtilityRate,
}

impl PartialEq for Priority {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Priority {}

impl Priority {
    pub fn new(plan: RankedUtility, chain: UtilityRate) -> Self {
        Self { plan, chain }
    }

    /// Compares h(P1, T1) with h(P2, T2) without building either.
    pub fn compare(
        plan_a: &RankedUtility,
        chain_a: &UtilityRate,
        plan_b: &RankedUtility,
        chain_b: &UtilityRate,
    ) -> Ordering {
        Self::compare_parts(
            plan_a,
            (&chain_a.utility, chain_a.cost_mj),
            plan_b,
            (&chain_b.utility, chain_b.cost_mj),
        )
    }

    /// [`Self::compare`] with each chain given as (utility, cost in mJ), by reference: the
    /// same order (the costs clamped as [`UtilityRate::new`] does) without copying utilities
    /// into rates, which the search's queue does for every comparison.
    pub fn compare_parts(
        plan_a: &RankedUtility,
        chain_a: (&RankedUtility, u64),
        plan_b: &RankedUtility,
        chain_b: (&RankedUtility, u64),
    ) -> Ordering {
        let clamp = |c: u64| c.clamp(MIN_RATIO_COST_MJ, MAX_ENERGY_MJ);
        let (ca, cb) = (clamp(chain_a.1), clamp(chain_b.1));
        for ((&pa, &ta), (&pb, &tb)) in plan_a
            .sums
            .iter()
            .zip(&chain_a.0.sums)
            .zip(plan_b.sums.iter().zip(&chain_b.0.sums))
        {
            // (pa + ta/ca) vs (pb + tb/cb), exactly, without 128-bit products where the
            // answer is plain (a 128-bit multiplication is a library call on the 32-bit target):
            // - a ratio below 1 (t < c) adds less than one to its plan's sum, so integer sums
            //   that differ decide when the smaller side's ratio is below 1;
            // - equal sums compare the ratios, ta*cb vs tb*ca, in u64 when both fit;
            // - otherwise (pa*ca + ta)*cb vs (pb*cb + tb)*ca in u128.
            let order = if pa > pb && u64::from(tb) < cb {
                Ordering::Greater
            } else if pb > pa && u64::from(ta) < ca {
                Ordering::Less
            } else if pa == pb {
                match (u64::from(ta).checked_mul(cb), u64::from(tb).checked_mul(ca)) {
                    (Some(left), Some(right)) => left.cmp(&right),
                    _ => (u128::from(ta) * u128::from(cb)).cmp(&(u128::from(tb) * u128::from(ca))),
                }
            } else {
                let (ca, cb) = (u128::from(ca), u128::from(cb));
                let left = (u128::from(pa) * ca + u128::from(ta)) * cb;
                let right = (u128::from(pb) * cb + u128::from(tb)) * ca;
                left.cmp(&right)
            };
            if order != Ordering::Equal {
                return order;
            }
        }
        Ordering::Equal
    }
}

impl Ord for Priority {
    fn cmp(&self, other: &Self) -> Ordering {
        Self::compare(&self.plan, &self.chain, &other.plan, &other.chain)
    }
}

impl PartialOrd for Priority {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(sums: [u32; RANK_COUNT]) -> RankedUtility {
        RankedUtility { sums }
    }

    #[test]
    fn a_higher_rank_dominates_any_lower_rank_sum() {
        let mission = RankedUtility::single(Rank::Mission, Score::new(1).unwrap_or_default());
        let everything_else = u([
            0,
            u32::MAX,
            u32::MAX,
            u32::MAX,
            u32::MAX,
            u32::MAX,
            u32::MAX,
        ]);
        assert!(mission > everything_else);
    }

    #[test]
    fn scores_above_one_are_refused() {
        assert_eq!(Score::new(10_001), Err(ScoreOutOfRange(10_001)));
        assert_eq!(Score::new(10_000), Ok(Score::ONE));
    }

    #[test]
    fn integer_division_would_have_merged_rates_that_the_exact_rate_keeps_apart() {
        // 7/3 and 6/3 both round to 2; the lower rank would then have reversed the order.
        let a = UtilityRate::new(u([7, 0, 0, 0, 0, 0, 0]), 3);
        let b = UtilityRate::new(u([6, 9, 0, 0, 0, 0, 0]), 3);
        assert!(a > b);
    }

    #[test]
    fn zero_cost_is_divided_as_the_smallest_cost() {
        let a = UtilityRate::new(u([1, 0, 0, 0, 0, 0, 0]), 0);
        assert_eq!(a.cost_mj(), MIN_RATIO_COST_MJ);
        assert_eq!(a, UtilityRate::new(u([1, 0, 0, 0, 0, 0, 0]), 1));
    }

    #[test]
    fn priority_adds_the_plan_utility_to_the_chain_rate() {
        // P = 1 at Analysis, T = 4 at Analysis for cost 2: h = 3 at Analysis.
        let plan = u([0, 1, 0, 0, 0, 0, 0]);
        let chain = UtilityRate::new(u([0, 4, 0, 0, 0, 0, 0]), 2);
        let same = Priority::new(
            u([0, 3, 0, 0, 0, 0, 0]),
            UtilityRate::new(RankedUtility::ZERO, 1),
        );
        assert_eq!(Priority::new(plan, chain).cmp(&same), Ordering::Equal);
        let more = Priority::new(
            u([0, 3, 0, 0, 0, 0, 1]),
            UtilityRate::new(RankedUtility::ZERO, 1),
        );
        assert!(Priority::new(plan, chain) < more);
    }

    /// `compare_parts`'s shortcuts decide as the 128-bit cross-multiplication they avoid, on
    /// every combination of boundary values (ratios just below, at and above 1, sums equal and
    /// one apart, costs clamped at both ends, products over u64).
    #[test]
    fn compare_parts_is_the_cross_multiplication() {
        let reference = |pa: u32, ta: u32, ca: u64, pb: u32, tb: u32, cb: u64| {
            let clamp = |c: u64| u128::from(c.clamp(MIN_RATIO_COST_MJ, MAX_ENERGY_MJ));
            let (ca, cb) = (clamp(ca), clamp(cb));
            ((u128::from(pa) * ca + u128::from(ta)) * cb)
                .cmp(&((u128::from(pb) * cb + u128::from(tb)) * ca))
        };
        let sums = [
            0u32,
            1,
            2,
            9_999,
            10_000,
            10_001,
            123_456,
            u32::MAX - 1,
            u32::MAX,
        ];
        let costs = [
            0u64,
            1,
            2,
            9_999,
            10_000,
            10_001,
            1 << 32,
            MAX_ENERGY_MJ,
            u64::MAX,
        ];
        let mut checked = 0u64;
        let mut shortcuts = 0u64;
        for &pa in &sums {
            for &ta in &sums {
                for &ca in &costs {
                    for &pb in &[pa.saturating_sub(1), pa, pa.saturating_add(1), 0, u32::MAX] {
                        for &tb in &[ta.saturating_sub(1), ta, ta.saturating_add(1), 0, 10_000] {
                            for &cb in &costs {
                                // In the third rank, the first two equal.
                                let plan = |v: u32| u([7, 7, v, 0, 0, 0, 0]);
                                let chain = |v: u32| u([0, 0, v, 0, 0, 0, 0]);
                                let got = Priority::compare_parts(
                                    &plan(pa),
                                    (&chain(ta), ca),
                                    &plan(pb),
                                    (&chain(tb), cb),
                                );
                                assert_eq!(
                                    got,
                                    reference(pa, ta, ca, pb, tb, cb),
                                    "{pa} {ta} {ca} / {pb} {tb} {cb}"
                                );
                                checked += 1;
                                shortcuts += u64::from(pa != pb && (ta < 10_000 || tb < 10_000));
                            }
                        }
                    }
                }
            }
        }
        assert!(
            checked > 100_000 && shortcuts > 1_000,
            "{checked} {shortcuts}"
        );
    }
}
