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

/// Added to a Mandatory product's value in the knapsack: more than the largest possible sum of
/// Residual values ([`MAX_DATA_PRODUCTS`] x [`MAX_PRODUCT_VALUE`]).
pub const MANDATORY_BONUS: u64 = (MAX_DATA_PRODUCTS as u64) * MAX_PRODUCT_VALUE + 1;

const _: () = assert!(
    (MAX_DATA_PRODUCTS as u128) * (MANDATORY_BONUS as u128 + MAX_PRODUCT_VALUE as u128)
        < u64::MAX as u128
);
const _: () = assert!(MAX_DOWNLINKS <= 16 && MAX_DATA_PRODUCTS < u8::MAX as usize);

/// One item of a multiple knapsack problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct KnapsackItem {
    pub size: u64,
    pub value: u64,
    /// Bit `j` set: the item may go in knapsack `j` (equation 13, `U_ij = 0`).
    pub allowed: u16,
}

/// Why a problem was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DownlinkError {
    TooManyProducts,
    TooManyOpportunities,
    TooManySols,
    /// Product `index` is larger than [`MAX_BYTES`] or worth more than [`MAX_PRODUCT_VALUE`].
    ProductOutOfRange {
        index: usize,
    },
    /// Opportunity `index` starts before the one before it, ends before it starts, or has a
    /// capacity above [`MAX_BYTES`].
    OpportunityOutOfOrder {
        index: usize,
    },
    /// Opportunity `index` names a sol with no allocation.
    NoAllocation {
        index: usize,
    },
}

/// What one [`MultipleKnapsack::step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KnapsackStep {
    /// Nodes visited.
    pub used: u32,
    /// True once the best assignment is proven optimal.
    pub done: bool,
}

/// Nodes one exact surrogate check ([`MultipleKnapsack`]'s second bound) may visit; past that
/// the node is explored as if the check had not been made.
pub const SURROGATE_NODE_LIMIT: u32 = 4_096;

/// No choice made yet at this depth.
const NOT_STARTED: u8 = u8::MAX;
/// "Not in any knapsack" (equation 12 allows it).
pub const UNASSIGNED: u8 = u8::MAX - 1;

/// Exact, anytime branch and bound for the multiple knapsack problem with availability.
#[derive(Clone, Debug)]
pub struct MultipleKnapsack {
    items: Vec<KnapsackItem, MAX_DATA_PRODUCTS>,
    capacities: Vec<u64, MAX_DOWNLINKS>,
    /// Item indices in the solver's order.
    order: Vec<u8, MAX_DATA_PRODUCTS>,
    /// Per depth: the option being tried (a knapsack, [`UNASSIGNED`] or [`NOT_STARTED`]).
    choice: Vec<u8, MAX_DATA_PRODUCTS>,
    residual: Vec<u64, MAX_DOWNLINKS>,
    depth: usize,
    value: u64,
    best: Vec<u8, MAX_DATA_PRODUCTS>,
    best_value: u64,
    root_bound: u64,
    done: bool,
    nodes: u64,
    /// Nodes of the exact surrogate checks since the problem was loaded.
    bound_nodes: u64,
    /// Nodes of the exact surrogate checks in the current step.
    step_bound_nodes: u32,
}

impl Default for MultipleKnapsack {
    fn default() -> Self {
        Self::new()
    }
}

/// `a` before `b` in the solver's order: value per byte decreasing, then value decreasing, then
/// index.
fn solver_order(a: (usize, &KnapsackItem), b: (usize, &KnapsackItem)) -> Ordering {
    let (ia, x) = a;
    let (ib, y) = b;
    // x.value / x.size vs y.value / y.size, sizes possibly zero (infinite density first).
    let left = u128::from(x.value) * u128::from(y.size);
    let right = u128::from(y.value) * u128::from(x.size);
    let density = match (x.size == 0, y.size == 0) {
        (true, false) => Ordering::Less,
        (false, true) => Ordering::Greater,
        _ => right.cmp(&left),
    };
    density
        .then_with(|| y.value.cmp(&x.value))
        .then_with(|| ia.cmp(&ib))
}

/// Dantzig's bound of a 0-1 knapsack of `capacity` over `items` (size, value) in decreasing
/// value per byte: whole items while they fit, then the fraction of the first that does not,
/// rounded down (values are integers).
fn dantzig_bound(items: &[(u64, u64)], capacity: u64) -> u64 {
    let mut room = capacity;
    let mut bound = 0u64;
    for &(size, value) in items {
        if size <= room {
            room -= size;
            bound = bound.saturating_add(value);
        } else {
            let part = u128::from(value) * u128::from(room) / u128::from(size);
            return bound.saturating_add(u64::try_from(part).unwrap_or(u64::MAX));
        }
    }
    bound
}

/// Whether some subset of `items` (size, value; in decreasing value per byte) of total size at
/// most `capacity` is worth more than `threshold`: the surrogate relaxation solved exactly
/// (as MTM bounds its nodes), as the decision the pruning needs, by a depth-first branch and
/// bound with Dantzig's bound (Horowitz and Sahni). Gives up and answers `true` (the safe
/// answer: nothing is pruned) after `limit` nodes; `nodes` counts the nodes visited.
fn surrogate_exceeds(
    items: &[(u64, u64)],
    capacity: u64,
    threshold: u64,
    limit: u32,
    nodes: &mut u32,
) -> bool {
    // Items taken on the current path (indices into `items`, increasing).
    let mut taken: Vec<u8, MAX_DATA_PRODUCTS> = Vec::new();
    let (mut room, mut value, mut next) = (capacity, 0u64, 0usize);
    loop {
        *nodes += 1;
        if value > threshold || *nodes > limit {
            return true;
        }
        let rest = items.get(next..).unwrap_or(&[]);
        if next < items.len() && value.saturating_add(dantzig_bound(rest, room)) > threshold {
            // Forward: take the next item if it fits, else leave it out.
            if let Some(&(size, v)) = items.get(next) {
                if size <= room && taken.push(next as u8).is_ok() {
                    room -= size;
                    value += v;
                }
            }
            next += 1;
            continue;
        }
        // Back: the last item taken is left out instead.
        let Some(last) = taken.pop() else {
            return false;
        };
        if let Some(&(size, v)) = items.get(usize::from(last)) {
            room += size;
            value -= v;
        }
        next = usize::from(last) + 1;
    }
}

impl MultipleKnapsack {
    pub const fn new() -> Self {
        Self {
            items: Vec::new(),
            capacities: Vec::new(),
            order: Vec::new(),
            choice: Vec::new(),
            residual: Vec::new(),
            depth: 0,
            value: 0,
            best: Vec::new(),
            best_value: 0,
            root_bound: 0,
            done: true,
            nodes: 0,
            bound_nodes: 0,
            step_bound_nodes: 0,
        }
    }

    /// Loads a problem and makes the greedy first solution. Items above [`MAX_BYTES`] or
    /// [`MANDATORY_BONUS`] + [`MAX_PRODUCT_VALUE`] in value, and capacities above
    /// [`MAX_BYTES`], are refused.
    pub fn load(
        &mut self,
        items: &[KnapsackItem],
        capacities: &[u64],
    ) -> Result<(), DownlinkError> {
        if items.len() > MAX_DATA_PRODUCTS {
            return Err(DownlinkError::TooManyProducts);
        }
        if capacities.len() > MAX_DOWNLINKS {
            return Err(DownlinkError::TooManyOpportunities);
        }
        for (index, item) in items.iter().enumerate() {
            if item.size > MAX_BYTES || item.value > MANDATORY_BONUS + MAX_PRODUCT_VALUE {
                return Err(DownlinkError::ProductOutOfRange { index });
            }
        }
        if let Some(index) = capacities.iter().position(|&c| c > MAX_BYTES) {
            return Err(DownlinkError::OpportunityOutOfOrder { index });
        }
        self.items.clear();
        self.capacities.clear();
        self.order.clear();
        self.choice.clear();
        self.residual.clear();
        self.best.clear();
        let bins_mask = if capacities.len() >= 16 {
            u16::MAX
        } else {
            (1u16 << capacities.len()) - 1
        };
        for item in items {
            let _ = self.items.push(KnapsackItem {
                allowed: item.allowed & bins_mask,
                ..*item
            });
        }
        for &c in capacities {
            let _ = self.capacities.push(c);
            let _ = self.residual.push(c);
        }
        for i in 0..self.items.len() {
            let _ = self.order.push(i as u8);
        }
        let items_ref = &self.items;
        self.order.sort_unstable_by(|&a, &b| {
            match (items_ref.get(usize::from(a)), items_ref.get(usize::from(b))) {
                (Some(x), Some(y)) => solver_order((usize::from(a), x), (usize::from(b), y)),
                _ => a.cmp(&b),
            }
        });
        for _ in 0..self.items.len() {
            let _ = self.choice.push(NOT_STARTED);
            let _ = self.best.push(UNASSIGNED);
        }
        self.depth = 0;
        self.value = 0;
        self.nodes = 0;
        self.bound_nodes = 0;
        self.greedy();
        self.root_bound = self.bound_from(0);
        self.step_bound_nodes = 0;
        // The greedy solution is the search's first leaf; if it meets a bound it is final.
        self.done = self.best_value >= self.root_bound || !self.surrogate_allows(0);
        Ok(())
    }

    /// Greedy first solution: each item in the solver's order into the earliest knapsack it
    /// fits. It is exactly the first leaf of the depth-first search (which tries the earliest
    /// knapsack first), so starting from it keeps the tie rule: a later leaf replaces it only
    /// when strictly better.
    fn greedy(&mut self) {
        let mut residual = self.residual.clone();
        let mut value = 0u64;
        for &i in &self.order {
            let Some(item) = self.items.get(usize::from(i)) else {
                continue;
            };
            let bin = (0..residual.len()).find(|&j| {
                item.allowed & (1 << j) != 0 && residual.get(j).is_some_and(|&r| r >= item.size)
            });
            if let (Some(j), Some(slot)) = (bin, self.best.get_mut(usize::from(i))) {
                *slot = j as u8;
                if let Some(r) = residual.get_mut(j) {
                    *r -= item.size;
                }
                value += item.value;
            }
        }
        self.best_value = value;
    }

    /// The surrogate relaxation of the items from `depth` on: every residual capacity that some
    /// remaining item may use and fits, summed into one knapsack, and the items (size, value),
    /// in the solver's order, that still fit a residual capacity they may use.
    fn surrogate(&self, depth: usize) -> (u64, Vec<(u64, u64), MAX_DATA_PRODUCTS>) {
        let fits = |item: &KnapsackItem| -> u16 {
            let mut bins = 0u16;
            for (j, &r) in self.residual.iter().enumerate() {
                if item.allowed & (1 << j) != 0 && r >= item.size {
                    bins |= 1 << j;
                }
            }
            bins
        };
        let mut eligible_bins = 0u16;
        let mut items = Vec::new();
        for &i in self.order.iter().skip(depth) {
            if let Some(item) = self.items.get(usize::from(i)) {
                let bins = fits(item);
                if bins != 0 {
                    eligible_bins |= bins;
                    let _ = items.push((item.size, item.value));
                }
            }
        }
        let capacity: u64 = self
            .residual
            .iter()
            .enumerate()
            .filter(|(j, _)| eligible_bins & (1 << j) != 0)
            .map(|(_, &r)| r)
            .sum();
        (capacity, items)
    }

    /// Upper bound on the value the items from `depth` on can add, given the residual
    /// capacities: Dantzig's bound of the surrogate relaxation ([`Self::surrogate`]).
    fn bound_from(&self, depth: usize) -> u64 {
        let (capacity, items) = self.surrogate(depth);
        dantzig_bound(&items, capacity)
    }

    /// Whether a subtree with this upper bound can still change the result: only a strictly
    /// better leaf replaces the best, since an equal one comes later in the tie order.
    fn worth_exploring(&self, bound: u64) -> bool {
        bound > self.best_value
    }

    fn apply(&mut self, item: u8, option: u8, sign_add: bool) {
        let Some(it) = self.items.get(usize::from(item)).copied() else {
            return;
        };
        if option == UNASSIGNED || option == NOT_STARTED {
            return;
        }
        if let Some(r) = self.residual.get_mut(usize::from(option)) {
            if sign_add {
                *r -= it.size;
                self.value += it.value;
            } else {
                *r += it.size;
                self.value -= it.value;
            }
        }
    }

    /// The next option after `after` for the item at `depth`: a knapsack it may use and fits,
    /// then [`UNASSIGNED`], then none. Two dominance rules skip knapsacks whose subtrees cannot
    /// hold the first optimum in the tie order:
    /// - an item left out earlier that may use the knapsack, is no larger and worth at least as
    ///   much could take this item's place: a solution at least as good that comes earlier;
    /// - a knapsack with the same residual capacity as an earlier one, which every item still
    ///   to decide may use exactly when it may use the earlier one, is a mirror of it.
    fn next_option(&self, depth: usize, after: u8) -> Option<u8> {
        let item = *self.order.get(depth)?;
        let it = self.items.get(usize::from(item))?;
        let from = if after == NOT_STARTED {
            0
        } else if after == UNASSIGNED {
            return None;
        } else {
            usize::from(after) + 1
        };
        for j in from..self.residual.len() {
            let bit = 1u16 << j;
            let Some(&r) = self.residual.get(j) else {
                break;
            };
            if it.allowed & bit == 0 || r < it.size {
                continue;
            }
            let dominated =
                self.order
                    .iter()
                    .zip(self.choice.iter())
                    .take(depth)
                    .any(|(&i, &c)| {
                        c == UNASSIGNED
                            && self.items.get(usize::from(i)).is_some_and(|left_out| {
                                left_out.allowed & bit != 0
                                    && left_out.size <= it.size
                                    && left_out.value >= it.value
                            })
                    });
            if dominated {
                continue;
            }
            let mirrored = (0..j).any(|earlier| {
                let earlier_bit = 1u16 << earlier;
                self.residual.get(earlier) == Some(&r)
                    && self.order.iter().skip(depth).all(|&k| {
                        self.items.get(usize::from(k)).is_some_and(|x| {
                            (x.allowed & bit == 0) == (x.allowed & earlier_bit == 0)
                        })
                    })
            });
            if mirrored {
                continue;
            }
            return Some(j as u8);
        }
        Some(UNASSIGNED)
    }

    /// Visits at most `budget` nodes of the branch and bound, counting the nodes of the exact
    /// surrogate checks: a check is never split, so a step may use up to
    /// [`SURROGATE_NODE_LIMIT`] beyond its budget.
    pub fn step(&mut self, budget: u32) -> KnapsackStep {
        let mut used = 0u32;
        let n = self.order.len();
        while used < budget && !self.done {
            used = used.saturating_add(1);
            self.nodes += 1;
            if self.depth == n {
                // A complete assignment.
                if self.value > self.best_value {
                    for (d, &i) in self.order.iter().enumerate() {
                        if let (Some(slot), Some(&c)) =
                            (self.best.get_mut(usize::from(i)), self.choice.get(d))
                        {
                            *slot = c;
                        }
                    }
                    self.best_value = self.value;
                    if self.best_value >= self.root_bound {
                        self.done = true; // nothing later in the order can beat it
                        break;
                    }
                }
                if n == 0 {
                    self.done = true;
                    break;
                }
                self.depth -= 1;
                self.undo_at(self.depth);
                continue;
            }
            let Some(&item) = self.order.get(self.depth) else {
                self.done = true;
                break;
            };
            let after = self.choice.get(self.depth).copied().unwrap_or(NOT_STARTED);
            match self.next_option(self.depth, after) {
                None => {
                    if let Some(c) = self.choice.get_mut(self.depth) {
                        *c = NOT_STARTED;
                    }
                    if self.depth == 0 {
                        self.done = true; // the whole tree is explored
                        break;
                    }
                    self.depth -= 1;
                    self.undo_at(self.depth);
                }
                Some(option) => {
                    if let Some(c) = self.choice.get_mut(self.depth) {
                        *c = option;
                    }
                    self.apply(item, option, true);
                    let bound = self.value.saturating_add(self.bound_from(self.depth + 1));
                    if self.worth_exploring(bound) && self.surrogate_allows(self.depth + 1) {
                        self.depth += 1;
                        if let Some(c) = self.choice.get_mut(self.depth) {
                            *c = NOT_STARTED;
                        }
                    } else {
                        self.apply(item, option, false);
                    }
                    used = used.saturating_add(core::mem::take(&mut self.step_bound_nodes));
                }
            }
        }
        KnapsackStep {
            used,
            done: self.done,
        }
    }

    /// Whether the exact surrogate relaxation of the items from `depth` on can still add more
    /// than the best assignment needs (`best_value - value`); only asked when Dantzig's bound
    /// could not prune. Its nodes count in [`Self::bound_nodes`].
    fn surrogate_allows(&mut self, depth: usize) -> bool {
        let Some(threshold) = self.best_value.checked_sub(self.value) else {
            return true;
        };
        let (capacity, items) = self.surrogate(depth);
        let mut nodes = 0u32;
        let allows = surrogate_exceeds(
            &items,
            capacity,
            threshold,
            SURROGATE_NODE_LIMIT,
            &mut nodes,
        );
        self.bound_nodes += u64::from(nodes);
        self.step_bound_nodes += nodes;
        allows
    }

    /// Undoes the option applied at `depth` (it stays recorded so the next one follows it).
    fn undo_at(&mut self, depth: usize) {
        if let (Some(&item), Some(&option)) = (self.order.get(depth), self.choice.get(depth)) {
            self.apply(item, option, false);
        }
    }

    /// Runs to the proof of optimality.
    pub fn solve(&mut self) {
        while !self.step(u32::MAX).done {}
    }

    /// The best assignment so far: per item (in the caller's order) the knapsack index, or
    /// [`UNASSIGNED`].
    pub fn assignment(&self) -> &[u8] {
        &self.best
    }

    pub fn best_value(&self) -> u64 {
        self.best_value
    }

    /// An upper bound on the optimum (the root's surrogate bound).
    pub fn upper_bound(&self) -> u64 {
        self.root_bound.max(self.best_value)
    }

    /// True once the best assignment is proven optimal (and first in the tie order).
    pub fn proven_optimal(&self) -> bool {
        self.done
    }

    /// Nodes visited since the problem was loaded.
    pub fn nodes(&self) -> u64 {
        self.nodes
    }

    /// Nodes of the exact surrogate checks since the problem was loaded (they count in each
    /// step's budget too).
    pub fn bound_nodes(&self) -> u64 {
        self.bound_nodes
    }

    /// The solver's item order (item indices), for tools and tests.
    pub fn order(&self) -> &[u8] {
        &self.order
    }
}

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
            picked.sort_unstable_by_key(|&i| {
                (products_ref.get(usize::from(i)).map(|p| p.created_at), i)
            });
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

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;

    /// The best subset value by enumeration.
    fn best_subset(items: &[(u64, u64)], capacity: u64) -> u64 {
        (0u32..1 << items.len())
            .filter_map(|mask| {
                let picked = items.iter().enumerate().filter(|(i, _)| mask >> i & 1 == 1);
                let size: u64 = picked.clone().map(|(_, it)| it.0).sum();
                (size <= capacity).then(|| picked.map(|(_, it)| it.1).sum())
            })
            .max()
            .unwrap_or(0)
    }

    #[test]
    fn the_surrogate_decision_matches_enumeration() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = |hi: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % (hi + 1)
        };
        for case in 0..400 {
            let n = next(11) as usize;
            let mut items: std::vec::Vec<(u64, u64)> =
                (0..n).map(|_| (next(30), next(50))).collect();
            // Decreasing value per byte, as the solver passes them (zero sizes first).
            items.sort_by(|a, b| {
                (b.0 == 0).cmp(&(a.0 == 0)).then_with(|| {
                    (u128::from(b.1) * u128::from(a.0)).cmp(&(u128::from(a.1) * u128::from(b.0)))
                })
            });
            let capacity = next(80);
            let best = best_subset(&items, capacity);
            for threshold in [best.saturating_sub(1), best, best + 1, next(200)] {
                let mut nodes = 0;
                let exceeds = surrogate_exceeds(&items, capacity, threshold, u32::MAX, &mut nodes);
                assert_eq!(
                    exceeds,
                    best > threshold,
                    "case {case}: {items:?} in {capacity}"
                );
                assert!(dantzig_bound(&items, capacity) >= best, "case {case}");
            }
            // Out of nodes, the answer is the safe one.
            let mut nodes = 0;
            assert!(surrogate_exceeds(
                &items,
                capacity,
                u64::MAX - 1,
                0,
                &mut nodes
            ));
        }
    }
}
