//! The utility-maximising search (seed 000 III.A, Algorithm 1) over flattened chains, with the
//! phased outer loop of RSM-1, as an anytime computation.
//!
//! Nodes are partial plans; edges are chains ([`crate::htn::Chain`]). The exploration queue
//! holds (plan, chain) pairs ordered by h(P, T) = P.utility + T.utility / T.cost
//! ([`crate::utility::Priority`]; ties: the pair queued first). Each exploration pops the best
//! pair and asks the [`ChainPlacement`] whether the chain can be added to the plan; if it can,
//! the new plan becomes a node and is paired with every chain of the current batch whose task
//! is not in it yet and whose cost still fits the battery: P.cost + T.cost + reserve <= M.
//! Because costs are never negative, a pair pruned that way only leads to plans over the
//! battery, so the pruning never removes the optimum; with an unlimited exploration bound (and
//! no capacity overflow, reported in [`SearchStats`]) the result is the optimum over every
//! order in which the placement accepts chains. The best plan is the node with the highest
//! utility, ties to lower cost, then to the node found first.
//!
//! The phased outer loop: the chains of batch 0 (exogenous uplinks at fixed times) are placed
//! first, in the order of their fixed start; then each batch in increasing number is searched
//! with the plan so far as the single root node, and its best plan is held fixed as the root
//! of the next batch.
//!
//! Anytime: all state is in [`Search`] (fixed-capacity arrays, no recursion, no heap).
//! [`Search::step`] explores at most `budget` pairs and returns; the next call resumes where it
//! stopped, and the best plan so far can be read at any time. Splitting the work over many
//! calls gives exactly the result of one call with the whole budget.
use core::cmp::Ordering;

use heapless::Vec;
use serde::{Deserialize, Serialize};

use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
use crate::htn::FlatNetwork;
use crate::utility::{Priority, RankedUtility, MIN_RATIO_COST_MJ};

/// A chain in a plan, with the start the placement gave it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlacedChain {
    /// Index into [`FlatNetwork::chains`].
    pub chain: u16,
    pub start: MissionTimeUs,
}

/// "Can the decomposition's tasks be added to the plan?" (Algorithm 1): where the chain can
/// start given the plan's chains, or `None`. Implementations: [`crate::placement`]'s simple
/// timeline, the downlink gate ([`crate::gate`]), and the MEXEC timelines
/// ([`crate::mexec`]).
pub trait ChainPlacement {
    /// Where chain `candidate` starts if added to `plan` (the plan's chains in the order they
    /// were added), or `None` if it cannot be added. Must depend only on its arguments (and on
    /// configuration fixed for the search), so that the search is deterministic.
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs>;

    /// The utility chain `candidate` adds to `plan`, asked after [`Self::place`] accepted it.
    /// The default is the chain's own (flattened) utility; a placement that knows the mission
    /// rules overrides it with a prediction in the plan's context (the Assessor,
    /// [`crate::assessor::AssessedPlacement`]). Must depend only on its arguments.
    fn utility(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> RankedUtility {
        let _ = plan;
        network
            .chains
            .get(usize::from(candidate))
            .map_or(RankedUtility::ZERO, |c| c.utility)
    }

    /// [`Self::place`], then (if placed) [`Self::utility`]: what the search asks for each
    /// chain. A placement that computes both from the same context (the Assessor) overrides it
    /// to do that work once; the answer must equal the two calls'.
    fn place_valued(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<(MissionTimeUs, RankedUtility)> {
        let start = self.place(network, plan, candidate)?;
        Some((start, self.utility(network, plan, candidate)))
    }
}

/// The configuration of one search.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SearchConfig {
    /// M: the battery charge the plan's chains may use, in mJ.
    pub battery_mj: u64,
    /// Energy held back beyond each pair's cost when pruning (Algorithm 1's
    /// `compute_heuristic`); 0 is the paper's bound.
    pub reserve_mj: u64,
    /// Explorations (queue pops) per batch; `None` explores until the queue is empty.
    pub exploration_bound: Option<u32>,
    /// Prune pairs over the battery when they are queued (the paper's pruning). When off, they
    /// are queued and explored, and only the plan selection leaves plans over the battery out:
    /// the reference the tests compare the pruning against.
    pub energy_pruning: bool,
}

impl SearchConfig {
    /// An exhaustive search with the paper's pruning for a battery of `battery_mj`.
    pub const fn exhaustive(battery_mj: u64) -> Self {
        Self {
            battery_mj,
            reserve_mj: 0,
            exploration_bound: None,
            energy_pruning: true,
        }
    }
}

/// Counters of one search, over all its batches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SearchStats {
    /// Pairs popped from the exploration queue.
    pub explored: u32,
    /// Calls to the placement (exploration and exogenous chains).
    pub placement_calls: u32,
    /// Plans added to the node collection by exploration (roots not counted).
    pub nodes: u32,
    /// Pairs not queued because they would exceed the battery.
    pub pruned_by_energy: u32,
    /// Pairs not queued because the exploration queue was full: the search is no longer
    /// exhaustive.
    pub queue_overflows: u32,
    /// Plans lost because the node collection was full: the search is no longer exhaustive.
    pub node_overflows: u32,
    /// Batches stopped by the exploration bound with pairs still queued.
    pub bounded_batches: u32,
    /// Longest the exploration queue grew.
    pub max_queue_len: u32,
}

impl SearchStats {
    /// Whether every batch was explored to the end with nothing lost to a capacity: the plan is
    /// then the optimum of the phased search.
    pub fn exhaustive(&self) -> bool {
        self.queue_overflows == 0 && self.node_overflows == 0 && self.bounded_batches == 0
    }
}

/// Why a search could not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SearchError {
    /// The initial plan names a chain that does not exist.
    UnknownChain { index: usize },
    /// The initial plan is longer than [`MAX_PLAN_CHAINS`].
    PlanTooLong,
    /// The network has more chains than a `u16` index.
    TooManyChains,
}

/// What one [`Search::step`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SearchStep {
    /// Explorations and exogenous placements spent from the budget.
    pub used: u32,
    /// True once every batch is done: the plan is final.
    pub done: bool,
}

const NO_PARENT: u16 = u16::MAX;

/// A set of top-level tasks (by [`crate::htn::Chain::task_slot`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
struct TaskSet([u64; MAX_SEARCH_TASKS / 64]);

impl TaskSet {
    fn contains(&self, slot: u8) -> bool {
        let (word, bit) = (usize::from(slot) / 64, u32::from(slot) % 64);
        self.0.get(word).is_some_and(|w| w & (1u64 << bit) != 0)
    }

    fn insert(&mut self, slot: u8) {
        let (word, bit) = (usize::from(slot) / 64, u32::from(slot) % 64);
        if let Some(w) = self.0.get_mut(word) {
            *w |= 1u64 << bit;
        }
    }
}

/// A partial plan: its last chain and its parent node (the root has none).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Node {
    parent: u16,
    chain: u16,
    start: MissionTimeUs,
    utility: RankedUtility,
    cost_mj: u64,
    tasks: TaskSet,
}

/// A queued (plan, chain) pair; `seq` orders equal priorities first-queued first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pair {
    node: u16,
    chain: u16,
    seq: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Nothing loaded.
    Idle,
    /// Placing the exogenous chains (batch 0); `next` indexes `order`.
    Exogenous {
        next: usize,
    },
    /// Searching one batch.
    Batch {
        batch: u8,
        explored: u32,
    },
    Done,
}

/// Algorithm 1 with the phased outer loop, anytime. `NODES` and `QUEUE` are the node
/// collection and exploration queue capacities (defaults [`MAX_SEARCH_NODES`],
/// [`MAX_EXPLORE_QUEUE`]); their RAM is about `NODES * 64 + QUEUE * 8` bytes.
pub struct Search<const NODES: usize = MAX_SEARCH_NODES, const QUEUE: usize = MAX_EXPLORE_QUEUE> {
    config: SearchConfig,
    stage: Stage,
    /// The plan held fixed: the initial plan, the exogenous chains, and each finished batch's
    /// best plan.
    fixed: Vec<PlacedChain, MAX_PLAN_CHAINS>,
    /// Exogenous chains in placement order.
    order: Vec<u16, MAX_CHAINS>,
    nodes: Vec<Node, NODES>,
    queue: Vec<Pair, QUEUE>,
    next_seq: u32,
    /// The best node of the current batch.
    best: u16,
    stats: SearchStats,
    scratch: Vec<PlacedChain, MAX_PLAN_CHAINS>,
    /// Tasks left out of the search ([`Self::start_excluding`]).
    excluded: TaskSet,
    /// Utility and cost of the fixed plan (each chain's utility as it was when it was added).
    fixed_value: (RankedUtility, u64),
    /// The chains of the batch being searched, in index order (each new node is paired with
    /// them, not with every chain of the network).
    batch_chains: Vec<u16, MAX_CHAINS>,
}

impl<const NODES: usize, const QUEUE: usize> Default for Search<NODES, QUEUE> {
    fn default() -> Self {
        Self::new(SearchConfig::exhaustive(0))
    }
}

impl<const NODES: usize, const QUEUE: usize> Search<NODES, QUEUE> {
    const INDEXABLE: () = assert!(NODES >= 1 && NODES < NO_PARENT as usize);

    pub fn new(config: SearchConfig) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::INDEXABLE;
        Self {
            config,
            stage: Stage::Idle,
            fixed: Vec::new(),
            order: Vec::new(),
            nodes: Vec::new(),
            queue: Vec::new(),
            next_seq: 0,
            best: 0,
            stats: SearchStats::default(),
            scratch: Vec::new(),
            excluded: TaskSet::default(),
            fixed_value: (RankedUtility::ZERO, 0),
            batch_chains: Vec::new(),
        }
    }

    /// [`Self::new`] in place: the same search as `*self = Search::new(config)`, without a
    /// temporary of the whole search (tens of KiB of nodes and queue) on the stack, which the
    /// planner partition's stack cannot hold.
    pub fn reconfigure(&mut self, config: SearchConfig) {
        self.config = config;
        self.stage = Stage::Idle;
        self.fixed.clear();
        self.order.clear();
        self.nodes.clear();
        self.queue.clear();
        self.next_seq = 0;
        self.best = 0;
        self.stats = SearchStats::default();
        self.scratch.clear();
        self.excluded = TaskSet::default();
        self.fixed_value = (RankedUtility::ZERO, 0);
        self.batch_chains.clear();
    }

    pub fn config(&self) -> &SearchConfig {
        &self.config
    }

    pub fn stats(&self) -> &SearchStats {
        &self.stats
    }

    /// Whether every batch is done.
    pub fn is_done(&self) -> bool {
        self.stage == Stage::Done
    }

    /// Starts a search of `network` from `initial` (chains already in the plan: executed or
    /// committed ones, held fixed). Resets the statistics.
    pub fn start(
        &mut self,
        network: &FlatNetwork,
        initial: &[PlacedChain],
    ) -> Result<(), SearchError> {
        self.start_excluding(network, initial, &[])
    }

    /// [`Self::start`], with the top-level tasks of `excluded` (task slots) left out of the
    /// search as if they were in the plan: tasks already executed, or failed, when replanning
    /// from the current state (their time and energy are in the placement's horizon and
    /// charge, not in the plan).
    pub fn start_excluding(
        &mut self,
        network: &FlatNetwork,
        initial: &[PlacedChain],
        excluded: &[u8],
    ) -> Result<(), SearchError> {
        if network.chains.len() >= usize::from(NO_PARENT) {
            return Err(SearchError::TooManyChains);
        }
        self.excluded = TaskSet::default();
        for &slot in excluded {
            self.excluded.insert(slot);
        }
        self.fixed.clear();
        for (index, placed) in initial.iter().enumerate() {
            if usize::from(placed.chain) >= network.chains.len() {
                return Err(SearchError::UnknownChain { index });
            }
            self.fixed
                .push(*placed)
                .map_err(|_| SearchError::PlanTooLong)?;
        }
        // Exogenous chains by fixed start, then index.
        self.order.clear();
        for (i, chain) in network.chains.iter().enumerate() {
            if chain.batch == 0 {
                let _ = self.order.push(i as u16);
            }
        }
        let key = |i: &u16| {
            let start = network
                .chains
                .get(usize::from(*i))
                .and_then(|c| c.fixed_start)
                .unwrap_or(MissionTimeUs::MAX);
            (start, *i)
        };
        self.order.sort_unstable_by_key(key);
        self.stats = SearchStats::default();
        self.next_seq = 0;
        self.stage = Stage::Exogenous { next: 0 };
        self.fixed_value = self
            .fixed
            .iter()
            .fold((RankedUtility::ZERO, 0), |(u, e), p| {
                network
                    .chains
                    .get(usize::from(p.chain))
                    .map_or((u, e), |c| {
                        (u.saturating_add(&c.utility), e.saturating_add(c.energy_mj))
                    })
            });
        self.reset_root(network);
        Ok(())
    }

    /// Runs until `budget` explorations are spent or the search is done.
    pub fn step(
        &mut self,
        network: &FlatNetwork,
        placement: &mut impl ChainPlacement,
        budget: u32,
    ) -> SearchStep {
        let mut used = 0u32;
        while used < budget {
            match self.stage {
                Stage::Idle | Stage::Done => break,
                Stage::Exogenous { next } => {
                    let Some(&chain) = self.order.get(next) else {
                        self.stage = self.next_batch_stage(network, 0);
                        if let Stage::Batch { batch, .. } = self.stage {
                            self.seed_batch(network, batch);
                        }
                        continue;
                    };
                    used += 1;
                    self.place_exogenous(network, placement, chain);
                    self.stage = Stage::Exogenous { next: next + 1 };
                }
                Stage::Batch { batch, explored } => {
                    let bounded = self.config.exploration_bound.is_some_and(|b| explored >= b);
                    if bounded || self.queue.is_empty() {
                        if bounded && !self.queue.is_empty() {
                            self.stats.bounded_batches += 1;
                        }
                        self.fix_best(network);
                        self.stage = self.next_batch_stage(network, batch.saturating_add(1));
                        if let Stage::Batch { batch, .. } = self.stage {
                            self.seed_batch(network, batch);
                        }
                        continue;
                    }
                    used += 1;
                    self.explore_one(network, placement, batch);
                    self.stage = Stage::Batch {
                        batch,
                        explored: explored + 1,
                    };
                }
            }
        }
        SearchStep {
            used,
            done: self.stage == Stage::Done,
        }
    }

    /// Runs to the end (however long that takes).
    pub fn run(&mut self, network: &FlatNetwork, placement: &mut impl ChainPlacement) {
        while !self.step(network, placement, u32::MAX).done {}
    }

    /// The best plan so far: the fixed chains, then the best plan of the batch being searched.
    pub fn best_plan(&self, out: &mut Vec<PlacedChain, MAX_PLAN_CHAINS>) {
        out.clear();
        for p in &self.fixed {
            let _ = out.push(*p);
        }
        if matches!(self.stage, Stage::Batch { .. }) {
            let mut path: Vec<PlacedChain, MAX_PLAN_CHAINS> = Vec::new();
            self.path_of(self.best, &mut path);
            for p in path.iter().skip(self.fixed.len()) {
                let _ = out.push(*p);
            }
        }
    }

    /// Utility and cost of the best plan so far.
    pub fn best_value(&self) -> (RankedUtility, u64) {
        match self.nodes.get(usize::from(self.best)) {
            Some(n) if matches!(self.stage, Stage::Batch { .. }) => (n.utility, n.cost_mj),
            _ => self.nodes.first().map_or((RankedUtility::ZERO, 0), |root| {
                (root.utility, root.cost_mj)
            }),
        }
    }

    fn fits_battery(&self, cost_mj: u64) -> bool {
        cost_mj.saturating_add(self.config.reserve_mj) <= self.config.battery_mj
    }

    /// The node collection holds only the root: the fixed plan.
    fn reset_root(&mut self, network: &FlatNetwork) {
        let mut root = Node {
            parent: NO_PARENT,
            chain: NO_PARENT,
            start: MissionTimeUs::ZERO,
            utility: self.fixed_value.0,
            cost_mj: self.fixed_value.1,
            tasks: self.excluded,
        };
        for p in &self.fixed {
            if let Some(c) = network.chains.get(usize::from(p.chain)) {
                root.tasks.insert(c.task_slot);
            }
        }
        self.nodes.clear();
        self.queue.clear();
        let _ = self.nodes.push(root);
        self.best = 0;
    }

    /// The stage for the lowest batch at or above `from` that has chains (batch 0 excluded).
    fn next_batch_stage(&self, network: &FlatNetwork, from: u8) -> Stage {
        network
            .chains
            .iter()
            .map(|c| c.batch)
            .filter(|&b| b >= from.max(1))
            .min()
            .map_or(Stage::Done, |batch| Stage::Batch { batch, explored: 0 })
    }

    fn place_exogenous(
        &mut self,
        network: &FlatNetwork,
        placement: &mut impl ChainPlacement,
        chain: u16,
    ) {
        let Some(c) = network.chains.get(usize::from(chain)) else {
            return;
        };
        let root = self.nodes.first().copied();
        let Some(root) = root else {
            return;
        };
        if root.tasks.contains(c.task_slot)
            || !self.fits_battery(root.cost_mj.saturating_add(c.energy_mj))
        {
            return;
        }
        self.stats.placement_calls += 1;
        if let Some((start, utility)) = placement.place_valued(network, &self.fixed, chain) {
            if self.fixed.push(PlacedChain { chain, start }).is_ok() {
                self.fixed_value = (
                    self.fixed_value.0.saturating_add(&utility),
                    self.fixed_value.1.saturating_add(c.energy_mj),
                );
                self.reset_root(network);
            }
        }
    }

    /// Queues the root with every chain of `batch`.
    fn seed_batch(&mut self, network: &FlatNetwork, batch: u8) {
        self.batch_chains.clear();
        for (i, c) in network.chains.iter().enumerate() {
            if c.batch == batch {
                // Never fails: at most MAX_CHAINS chains (a network's capacity).
                let _ = self.batch_chains.push(i as u16);
            }
        }
        self.reset_root(network);
        self.pair_with_batch(network, 0, batch);
    }

    /// Queues (node, chain) for every chain of `batch` whose task is not in the node's plan and
    /// whose cost fits.
    fn pair_with_batch(&mut self, network: &FlatNetwork, node: u16, batch: u8) {
        let Some(n) = self.nodes.get(usize::from(node)).copied() else {
            return;
        };
        for k in 0..self.batch_chains.len() {
            let Some(&i) = self.batch_chains.get(k) else {
                break;
            };
            let Some(c) = network.chains.get(usize::from(i)) else {
                continue;
            };
            if c.batch != batch || n.tasks.contains(c.task_slot) {
                continue;
            }
            if self.config.energy_pruning
                && !self.fits_battery(n.cost_mj.saturating_add(c.energy_mj))
            {
                self.stats.pruned_by_energy += 1;
                continue;
            }
            self.push(
                network,
                Pair {
                    node,
                    chain: i,
                    seq: self.next_seq,
                },
            );
            self.next_seq = self.next_seq.wrapping_add(1);
        }
    }

    fn explore_one(
        &mut self,
        network: &FlatNetwork,
        placement: &mut impl ChainPlacement,
        batch: u8,
    ) {
        self.stats.explored += 1;
        let Some(pair) = self.pop(network) else {
            return;
        };
        let (Some(parent), Some(chain)) = (
            self.nodes.get(usize::from(pair.node)).copied(),
            network.chains.get(usize::from(pair.chain)),
        ) else {
            return;
        };
        // The plan is built in `scratch` in place (moving a plan-sized vector out and back
        // copies it twice).
        path_into(&self.fixed, &self.nodes, pair.node, &mut self.scratch);
        if self.scratch.len() >= MAX_PLAN_CHAINS {
            self.stats.node_overflows += 1;
            return;
        }
        self.stats.placement_calls += 1;
        let Some((start, utility)) = placement.place_valued(network, &self.scratch, pair.chain)
        else {
            return;
        };
        let mut tasks = parent.tasks;
        tasks.insert(chain.task_slot);
        let node = Node {
            parent: pair.node,
            chain: pair.chain,
            start,
            utility: parent.utility.saturating_add(&utility),
            cost_mj: parent.cost_mj.saturating_add(chain.energy_mj),
            tasks,
        };
        let index = self.nodes.len() as u16;
        if self.nodes.push(node).is_err() {
            self.stats.node_overflows += 1;
            return;
        }
        self.stats.nodes += 1;
        if self.is_better(&node) {
            self.best = index;
        }
        self.pair_with_batch(network, index, batch);
    }

    /// Whether `node` beats the best so far: higher utility, ties to lower cost; plans over the
    /// battery never do.
    fn is_better(&self, node: &Node) -> bool {
        if !self.fits_battery(node.cost_mj) {
            return false;
        }
        let Some(best) = self.nodes.get(usize::from(self.best)) else {
            return true;
        };
        match node.utility.cmp(&best.utility) {
            Ordering::Greater => true,
            Ordering::Equal => node.cost_mj < best.cost_mj,
            Ordering::Less => false,
        }
    }

    /// Holds the best plan of the finished batch fixed.
    fn fix_best(&mut self, network: &FlatNetwork) {
        if let Some(best) = self.nodes.get(usize::from(self.best)) {
            self.fixed_value = (best.utility, best.cost_mj);
        }
        let mut path = core::mem::take(&mut self.scratch);
        self.path_of(self.best, &mut path);
        self.fixed.clear();
        for p in &path {
            let _ = self.fixed.push(*p);
        }
        self.scratch = path;
        self.reset_root(network);
    }

    /// The plan of `node`: the fixed chains, then its chains from the root down.
    fn path_of(&self, node: u16, out: &mut Vec<PlacedChain, MAX_PLAN_CHAINS>) {
        path_into(&self.fixed, &self.nodes, node, out);
    }

    // --- the exploration queue: a binary max-heap on h(P, T), then first queued ---

    /// A chain's (T.utility, T.cost) for h, by reference (an unknown chain: zero utility).
    fn chain_value(network: &FlatNetwork, chain: u16) -> (&RankedUtility, u64) {
        network
            .chains
            .get(usize::from(chain))
            .map_or((&RankedUtility::ZERO, MIN_RATIO_COST_MJ), |c| {
                (&c.utility, c.energy_mj)
            })
    }

    fn compare(&self, network: &FlatNetwork, a: &Pair, b: &Pair) -> Ordering {
        let utility = |p: &Pair| {
            self.nodes
                .get(usize::from(p.node))
                .map_or(&RankedUtility::ZERO, |n| &n.utility)
        };
        Priority::compare_parts(
            utility(a),
            Self::chain_value(network, a.chain),
            utility(b),
            Self::chain_value(network, b.chain),
        )
        .then_with(|| b.seq.cmp(&a.seq))
    }

    fn push(&mut self, network: &FlatNetwork, pair: Pair) {
        if self.queue.push(pair).is_err() {
            self.stats.queue_overflows += 1;
            return;
        }
        self.stats.max_queue_len = self.stats.max_queue_len.max(self.queue.len() as u32);
        let mut i = self.queue.len() - 1;
        while i > 0 {
            let up = (i - 1) / 2;
            let (Some(child), Some(parent)) =
                (self.queue.get(i).copied(), self.queue.get(up).copied())
            else {
                break;
            };
            if self.compare(network, &child, &parent) != Ordering::Greater {
                break;
            }
            self.queue.swap(i, up);
            i = up;
        }
    }

    fn pop(&mut self, network: &FlatNetwork) -> Option<Pair> {
        let last = self.queue.len().checked_sub(1)?;
        self.queue.swap(0, last);
        let top = self.queue.pop();
        let len = self.queue.len();
        let mut i = 0;
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut largest = i;
            for c in [l, r] {
                if c < len {
                    let (Some(x), Some(y)) =
                        (self.queue.get(c).copied(), self.queue.get(largest).copied())
                    else {
                        continue;
                    };
                    if self.compare(network, &x, &y) == Ordering::Greater {
                        largest = c;
                    }
                }
            }
            if largest == i {
                break;
            }
            self.queue.swap(i, largest);
            i = largest;
        }
        top
    }
}

/// [`Search::path_of`] over the search's fields, so that it can write into the search's own
/// scratch vector.
fn path_into(
    fixed: &[PlacedChain],
    nodes: &[Node],
    node: u16,
    out: &mut Vec<PlacedChain, MAX_PLAN_CHAINS>,
) {
    out.clear();
    for p in fixed {
        let _ = out.push(*p);
    }
    let base = out.len();
    let mut at = node;
    while let Some(n) = nodes.get(usize::from(at)) {
        if n.parent == NO_PARENT {
            break;
        }
        if out
            .push(PlacedChain {
                chain: n.chain,
                start: n.start,
            })
            .is_err()
        {
            break;
        }
        at = n.parent;
    }
    if let Some(tail) = out.get_mut(base..) {
        tail.reverse();
    }
}
