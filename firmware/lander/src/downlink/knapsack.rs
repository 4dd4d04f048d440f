//! The multiple knapsack solver behind the downlink manager: an anytime branch and bound in the
//! manner of Martello and Toth's MTM (see the parent module for the method and its scale).

use super::*;

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
pub(super) fn solver_order(a: (usize, &KnapsackItem), b: (usize, &KnapsackItem)) -> Ordering {
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
pub(super) fn dantzig_bound(items: &[(u64, u64)], capacity: u64) -> u64 {
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
pub(super) fn surrogate_exceeds(
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
        crate::small_sort::sort_small(&mut self.order, |&a, &b| {
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
    pub(super) fn greedy(&mut self) {
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
    pub(super) fn surrogate(&self, depth: usize) -> (u64, Vec<(u64, u64), MAX_DATA_PRODUCTS>) {
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
    pub(super) fn bound_from(&self, depth: usize) -> u64 {
        let (capacity, items) = self.surrogate(depth);
        dantzig_bound(&items, capacity)
    }

    /// Whether a subtree with this upper bound can still change the result: only a strictly
    /// better leaf replaces the best, since an equal one comes later in the tie order.
    pub(super) fn worth_exploring(&self, bound: u64) -> bool {
        bound > self.best_value
    }

    pub(super) fn apply(&mut self, item: u8, option: u8, sign_add: bool) {
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
    pub(super) fn next_option(&self, depth: usize, after: u8) -> Option<u8> {
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
    pub(super) fn surrogate_allows(&mut self, depth: usize) -> bool {
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
    pub(super) fn undo_at(&mut self, depth: usize) {
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
