//! The downlink manager (seed 000 Appendix A, equations 6-14): which data product goes down in
//! which downlink opportunity.
//!
//! Opportunities ([`DownlinkOpportunity`]) have an Earth-in-view window, a rate, a radio power
//! drawn from their sol's energy allocation and a thermal limit on how long the radio may
//! transmit; their byte capacities come from those ([`capacities`]). A product may go down in an
//! opportunity that starts at or after its creation (equation 13).
//!
//! Tiers: Critical and Decisional products have no choice (Appendix A): each is placed first,
//! in the first opportunity that starts at or after its creation (Critical before Decisional,
//! each in creation order), or reported unplaced when that opportunity is full. Mandatory and
//! Residual products are then assigned by [`MultipleKnapsack`], an exact branch and bound for
//! the multiple knapsack problem (equations 10-14) over the capacity left; a Mandatory product
//! carries [`MANDATORY_BONUS`] on top of its value, more than every Residual product's value
//! together, so the optimum downlinks as many Mandatory products as can go and only then
//! maximises value.
//!
//! The branch and bound follows Martello and Toth's MTM in its essentials: items in decreasing
//! value per byte; a depth-first search that assigns each item in turn to each opportunity
//! (earliest first) and then tries leaving it out; the upper bound at every node is the
//! surrogate relaxation (all residual capacities summed into one knapsack) solved as a linear
//! programme (Dantzig's bound), counting only the items that still fit some residual capacity
//! they may use; where that bound cannot prune, the same surrogate problem solved exactly as a
//! 0-1 knapsack (MTM's bound), as a decision ("can it add more than the best needs?") by a
//! small depth-first branch and bound capped at [`SURROGATE_NODE_LIMIT`] nodes; and a greedy
//! first solution (the search's own first leaf). It is anytime: [`MultipleKnapsack::step`] visits
//! at most `budget` nodes and resumes where it stopped; the best assignment so far and whether
//! it is proven optimal can be read at any time. No heap, no recursion: the search state is an
//! array of choices, one per item.
//!
//! Scale (host measurements, `examples/lander_measure.rs`): the downlink problems of the
//! reference RSM-1 search take at most about a thousand nodes each; random uncorrelated
//! problems up to 24 products over 4 opportunities are proven within 2 million nodes; from 32
//! products over 8 opportunities (about 4 products per opportunity, the hard ratio for
//! multiple knapsacks) no proof comes within 5 million, where MTM's full scheme (a heuristic
//! lower bound at every node, bin-by-bin branching) is much faster. There the anytime answer
//! is the best assignment found, not proven optimal.
//!
//! Ties: among the optimal assignments the solver returns the first in its search order, that
//! is, taking items in the solver's order (value per byte decreasing, then value decreasing,
//! then index), the one whose items go down earliest: the lexicographically smallest vector of
//! opportunity indices, "not downlinked" counting as after every opportunity. So, all else
//! being equal, data goes down at the earliest opportunity (Appendix A's second preference).
use core::cmp::Ordering;

use heapless::Vec;
use serde::{Deserialize, Serialize};

use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
pub use crate::htn::Tier;

mod knapsack;

pub use knapsack::{
    DownlinkError, KnapsackItem, KnapsackStep, MultipleKnapsack, MANDATORY_BONUS,
    SURROGATE_NODE_LIMIT, UNASSIGNED,
};

/// A data product onboard or predicted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DataProduct {
    pub size_bytes: u64,
    pub value: u64,
    pub created_at: MissionTimeUs,
    pub tier: Tier,
}

/// One downlink opportunity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DownlinkOpportunity {
    /// Earth in view (and the downlink scheduled) from `start` to `end`.
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
    /// Window time not available for data (radio preparation, the uplink).
    pub overhead_us: u64,
    /// The sol whose energy allocation pays for it.
    pub sol: u16,
    pub rate_bps: u64,
    pub radio_power_mw: u64,
    /// Longest transmission before the radio reaches its temperature limit.
    pub thermal_limit_us: u64,
}

/// Energy a sol may spend on downlinks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SolAllocation {
    pub sol: u16,
    pub energy_mj: u64,
}

/// Byte capacity of each opportunity (in the order given, which must be by start time): the
/// transmit time is the window less its overhead, at most the thermal limit, and at most what
/// the sol's energy allocation still pays for; the opportunities of one sol draw on its
/// allocation earliest first. Capacity = rate x transmit time / 8.
pub fn capacities(
    opportunities: &[DownlinkOpportunity],
    allocations: &[SolAllocation],
) -> Result<Vec<u64, MAX_DOWNLINKS>, DownlinkError> {
    if opportunities.len() > MAX_DOWNLINKS {
        return Err(DownlinkError::TooManyOpportunities);
    }
    if allocations.len() > MAX_SOLS {
        return Err(DownlinkError::TooManySols);
    }
    let mut left: Vec<(u16, u64), MAX_SOLS> = Vec::new();
    for a in allocations {
        let _ = left.push((a.sol, a.energy_mj));
    }
    let mut out = Vec::new();
    let mut previous: Option<MissionTimeUs> = None;
    for (index, o) in opportunities.iter().enumerate() {
        if previous.is_some_and(|p| o.start < p) || o.end < o.start {
            return Err(DownlinkError::OpportunityOutOfOrder { index });
        }
        previous = Some(o.start);
        let energy = left
            .iter_mut()
            .find(|(sol, _)| *sol == o.sol)
            .map(|(_, e)| e)
            .ok_or(DownlinkError::NoAllocation { index })?;
        let window_us = (o.end.0 - o.start.0).saturating_sub(o.overhead_us);
        let paid_us = if o.radio_power_mw == 0 {
            u64::MAX
        } else {
            u64::try_from(u128::from(*energy) * 1_000_000 / u128::from(o.radio_power_mw))
                .unwrap_or(u64::MAX)
        };
        let transmit_us = window_us.min(o.thermal_limit_us).min(paid_us);
        let spent = u128::from(transmit_us) * u128::from(o.radio_power_mw) / 1_000_000;
        *energy = energy.saturating_sub(u64::try_from(spent).unwrap_or(u64::MAX));
        let bytes = u128::from(o.rate_bps) * u128::from(transmit_us) / 8 / 1_000_000;
        let bytes = u64::try_from(bytes).unwrap_or(u64::MAX);
        if bytes > MAX_BYTES {
            return Err(DownlinkError::OpportunityOutOfOrder { index });
        }
        let _ = out.push(bytes);
    }
    Ok(out)
}

/// Where a product goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Placement {
    /// In opportunity `n`.
    Downlink(u8),
    NotDownlinked,
}

/// The downlink manager: tiers first, then the exact knapsack; anytime.
#[derive(Clone, Debug, Default)]
pub struct DownlinkManager {
    products: Vec<DataProduct, MAX_DATA_PRODUCTS>,
    starts: Vec<MissionTimeUs, MAX_DOWNLINKS>,
    capacities: Vec<u64, MAX_DOWNLINKS>,
    /// Per product: its fixed opportunity (Critical, Decisional), or its knapsack item index.
    fixed: Vec<Option<Placement>, MAX_DATA_PRODUCTS>,
    item_of: Vec<u8, MAX_DATA_PRODUCTS>,
    knapsack: MultipleKnapsack,
}

impl DownlinkManager {
    pub const fn new() -> Self {
        Self {
            products: Vec::new(),
            starts: Vec::new(),
            capacities: Vec::new(),
            fixed: Vec::new(),
            item_of: Vec::new(),
            knapsack: MultipleKnapsack::new(),
        }
    }

    /// Loads a problem: places the Critical and Decisional products and sets up the knapsack
    /// for the others. Opportunities must be in start order.
    pub fn load(
        &mut self,
        products: &[DataProduct],
        opportunities: &[DownlinkOpportunity],
        allocations: &[SolAllocation],
    ) -> Result<(), DownlinkError> {
        let capacities = capacities(opportunities, allocations)?;
        let starts: Vec<MissionTimeUs, MAX_DOWNLINKS> =
            opportunities.iter().map(|o| o.start).collect();
        self.load_capacities(products, &starts, &capacities)
    }

    /// [`Self::load`] with the capacities already computed (`starts[j]`, `capacities[j]` per
    /// opportunity, in start order).
    pub fn load_capacities(
        &mut self,
        products: &[DataProduct],
        starts: &[MissionTimeUs],
        capacities: &[u64],
    ) -> Result<(), DownlinkError> {
        if products.len() > MAX_DATA_PRODUCTS {
            return Err(DownlinkError::TooManyProducts);
        }
        if starts.len() > MAX_DOWNLINKS || capacities.len() != starts.len() {
            return Err(DownlinkError::TooManyOpportunities);
        }
        if let Some(index) = starts.windows(2).position(|w| matches!(w, [a, b] if b < a)) {
            return Err(DownlinkError::OpportunityOutOfOrder { index: index + 1 });
        }
        for (index, p) in products.iter().enumerate() {
            if p.size_bytes > MAX_BYTES || p.value > MAX_PRODUCT_VALUE {
                return Err(DownlinkError::ProductOutOfRange { index });
            }
        }
        self.products.clear();
        self.starts.clear();
        self.capacities.clear();
        self.fixed.clear();
        self.item_of.clear();
        for p in products {
            let _ = self.products.push(*p);
            let _ = self.fixed.push(None);
            let _ = self.item_of.push(UNASSIGNED);
        }
        for (&s, &c) in starts.iter().zip(capacities) {
            let _ = self.starts.push(s);
            let _ = self.capacities.push(c);
        }
        let mut residual = self.capacities.clone();
        // Critical, then Decisional, each in creation order (then index).
        for tier in [Tier::Critical, Tier::Decisional] {
            let mut picked: Vec<u8, MAX_DATA_PRODUCTS> = Vec::new();
            for (i, p) in self.products.iter().enumerate() {
                if p.tier == tier {
                    let _ = picked.push(i as u8);
                }
            }
            let products_ref = &self.products;
            let key = |i: u8| (products_ref.get(usize::from(i)).map(|p| p.created_at), i);
            crate::small_sort::sort_small(&mut picked, |&a, &b| key(a).cmp(&key(b)));
            for &i in &picked {
                let Some(p) = self.products.get(usize::from(i)).copied() else {
                    continue;
                };
                let first = self.starts.iter().position(|&s| s >= p.created_at);
                let placed = match first.and_then(|j| residual.get_mut(j).map(|r| (j, r))) {
                    Some((j, r)) if *r >= p.size_bytes => {
                        *r -= p.size_bytes;
                        Placement::Downlink(j as u8)
                    }
                    _ => Placement::NotDownlinked,
                };
                if let Some(slot) = self.fixed.get_mut(usize::from(i)) {
                    *slot = Some(placed);
                }
            }
        }
        // Mandatory and Residual: the knapsack.
        let mut items: Vec<KnapsackItem, MAX_DATA_PRODUCTS> = Vec::new();
        for (i, p) in self.products.iter().enumerate() {
            if matches!(p.tier, Tier::Critical | Tier::Decisional) {
                continue;
            }
            let mut allowed = 0u16;
            for (j, &s) in self.starts.iter().enumerate() {
                if s >= p.created_at {
                    allowed |= 1 << j;
                }
            }
            let bonus = if p.tier == Tier::Mandatory {
                MANDATORY_BONUS
            } else {
                0
            };
            if let Some(slot) = self.item_of.get_mut(i) {
                *slot = items.len() as u8;
            }
            let _ = items.push(KnapsackItem {
                size: p.size_bytes,
                value: p.value + bonus,
                allowed,
            });
        }
        self.knapsack.load(&items, &residual)
    }

    /// Visits at most `budget` knapsack nodes.
    pub fn step(&mut self, budget: u32) -> KnapsackStep {
        self.knapsack.step(budget)
    }

    /// Runs the knapsack to the proof of optimality.
    pub fn solve(&mut self) {
        self.knapsack.solve();
    }

    /// Where product `index` goes in the best assignment so far.
    pub fn placement(&self, index: usize) -> Placement {
        if let Some(Some(p)) = self.fixed.get(index) {
            return *p;
        }
        let item = self.item_of.get(index).copied().unwrap_or(UNASSIGNED);
        match self.knapsack.assignment().get(usize::from(item)) {
            Some(&bin) if bin != UNASSIGNED => Placement::Downlink(bin),
            _ => Placement::NotDownlinked,
        }
    }

    /// Products of tiers Critical, Decisional and Mandatory that the best assignment so far
    /// does not downlink.
    pub fn required_unplaced(&self) -> usize {
        (0..self.products.len())
            .filter(|&i| {
                self.products
                    .get(i)
                    .is_some_and(|p| p.tier != Tier::Residual)
                    && self.placement(i) == Placement::NotDownlinked
            })
            .count()
    }

    /// Total value (without bonuses) of the products the best assignment so far downlinks.
    pub fn downlinked_value(&self) -> u64 {
        (0..self.products.len())
            .filter(|&i| self.placement(i) != Placement::NotDownlinked)
            .filter_map(|i| self.products.get(i).map(|p| p.value))
            .sum()
    }

    /// True once the knapsack's assignment is proven optimal.
    pub fn proven_optimal(&self) -> bool {
        self.knapsack.proven_optimal()
    }

    pub fn knapsack(&self) -> &MultipleKnapsack {
        &self.knapsack
    }

    pub fn products(&self) -> &[DataProduct] {
        &self.products
    }

    /// The byte capacity of each opportunity before any product is placed.
    pub fn opportunity_capacities(&self) -> &[u64] {
        &self.capacities
    }
}
