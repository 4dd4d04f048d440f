//! The search: lazy greedy best-first search over snap actions (seed 001, section 4.1) with
//! two open lists (all successors, and those the relaxed plan prefers), all of it in one fixed
//! arena of 32-bit words handed in by the caller.
//!
//! A search node is a record in the arena: its parent, the snap action that reached it, its h,
//! its bit-packed state (facts one bit each, numeric values, the running actions) and the
//! serialised temporal constraints its own step added ([`crate::constraints`]). Nothing else is
//! stored per state: when a node is taken from an open list, the plan to its parent is walked
//! back, the ordering annotations are recreated from the steps' conditions and effects, the
//! constraints are unpacked and the STN is checked ([`crate::stn`]).
//!
//! A ground action runs at most once at a time (no self-overlap): its start is applicable
//! only while it is not running.
//!
//! The three temporal rules of 4.1: an end is applicable only while its action runs; the goal
//! needs every action ended; after every snap action the invariants of the running actions
//! (and of an action just started) still hold. Compression safety: an action whose end can be
//! applied straight after its start without losing plans ([`Planner::compression_safe`]) is
//! applied as one step, start and end together.
//!
//! [`Planner::step`] runs a bounded number of expansions and returns; the search state stays in
//! the arena, so the next call resumes where this one stopped (anytime across windows).
use crate::constraints::{self, Constraint, MAX_STEPS};
use crate::heuristic::{self, Relaxation, RelaxedCost, DEAD_END};
use crate::stn;
use crate::task::{FactList, NumericList, Task, UNBOUNDED};

/// Snap kinds in a snap id (`action << 2 | kind`).
const START: u32 = 0;
const END: u32 = 1;
const COMPRESSED: u32 = 2;
const NONE: u32 = u32::MAX;
/// Most actions a plan can hold (two steps each).
pub const MAX_PLAN_ACTIONS: usize = MAX_STEPS / 2;
/// Most actions running at once.
pub const MAX_RUNNING: usize = 64;
/// Largest serialised constraint list one node may add, in bytes.
pub const MAX_NODE_CONSTRAINT_BYTES: usize = 2048;
/// Words of a node record before its state.
const NODE_HEADER: usize = 5;
/// Most preferred-queue pops granted after progress (a new best h), as in Fast Downward.
const BOOST: u32 = 1000;

/// How the planner searches.
#[derive(Clone, Copy, Debug)]
pub struct PlannerConfig {
    /// Longest plan in steps (snap actions) the search may build; at most [`MAX_STEPS`] - 1.
    pub max_steps: usize,
    /// Apply the ends of compression-safe actions with their starts.
    pub compression: bool,
    /// Which repeated states (facts, values, running actions reached before) are not expanded.
    pub duplicates: Duplicates,
    /// Use the second open list of successors the relaxed plan prefers.
    pub preferred_operators: bool,
    /// When an open list is full, drop its worse half (by key) and go on, instead of ending
    /// the search: anytime in fixed memory, at the price of completeness (counted in
    /// [`Stats::shed`]; an open list emptied after shedding is out of memory, not unsolvable).
    pub shed_when_full: bool,
    /// Snap-action costs in the heuristic's cost propagation.
    pub relaxed_cost: RelaxedCost,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            max_steps: 2048,
            compression: true,
            duplicates: Duplicates::PruneQuiescent,
            preferred_operators: true,
            shed_when_full: true,
            relaxed_cost: RelaxedCost::Unit,
        }
    }
}

/// Which repeated states the search prunes.
///
/// A state is its facts, numeric values and running actions; it says nothing of when things
/// happened. Two paths to a state with actions running can differ in how long each has left
/// to run, and only one of them may be able to finish (a brute-force test found such tasks:
/// pruning every repeat loses their plans). With nothing running, every later step is ordered
/// only after earlier ones (lower bounds), so the past's timing cannot make the future
/// impossible, unless windows (timed initial literals) put deadlines on later steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Duplicates {
    /// Expand every state, however often it is reached (complete, slow).
    Keep,
    /// Prune a repeated state only when no action is running in it.
    PruneQuiescent,
    /// Prune every repeated state (fastest; may lose plans that need concurrency).
    PruneAll,
}

/// Where the arena ran out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// The arena is too small for the task's tables and scratch.
    Tables,
    Nodes,
    RegularOpen,
    PreferredOpen,
    /// A plan would exceed `max_steps` or a step too many constraints (during the search this
    /// drops the branch and is counted in [`Stats::too_long`]).
    PlanLength,
}

/// What a call to [`Planner::step`] ended with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Budget used up; call again.
    Searching,
    /// A plan was found: read it with [`Planner::plan`].
    Solved,
    /// The open lists are empty: no plan (within the pruning used).
    Unsolvable,
    /// The arena is full.
    OutOfMemory(Region),
}

/// Search statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Open-list entries taken (successor states materialised).
    pub expanded: u64,
    /// Open-list entries added.
    pub generated: u64,
    /// Heuristic evaluations.
    pub evaluated: u64,
    /// Successors refused by the STN check.
    pub inconsistent: u64,
    /// Successors that repeated a state reached before.
    pub duplicates: u64,
    /// Successors from which the goal is unreachable even relaxed.
    pub dead_ends: u64,
    /// Nodes stored.
    pub nodes: u64,
    /// Successors dropped because their plan would exceed `max_steps` (or a step's constraint
    /// capacity).
    pub too_long: u64,
    /// Open-list entries dropped because a list was full (see [`PlannerConfig::shed_when_full`]).
    pub shed: u64,
    /// The best h seen.
    pub best_h: u32,
    /// Arena words in use at most: tables, scratch, nodes, buckets and open lists.
    pub peak_words: u64,
    /// Arena words handed in.
    pub arena_words: u64,
}

/// One action of the plan, times in ticks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlannedAction {
    pub action: u16,
    pub start: u32,
    pub duration: u32,
    /// The window of start times the STN allows with the makespan kept (section 5.2).
    pub start_lb: u32,
    pub start_ub: u32,
}

/// A binary min-heap of three-word entries (key, node, snap) in an arena slice.
struct Heap<'m> {
    words: &'m mut [u32],
    len: usize,
    peak: usize,
}

impl<'m> Heap<'m> {
    fn push(&mut self, key: u32, node: u32, snap: u32) -> bool {
        if 3 * (self.len + 1) > self.words.len() {
            return false;
        }
        let mut i = self.len;
        self.len += 1;
        self.peak = self.peak.max(self.len);
        self.words[3 * i..3 * i + 3].copy_from_slice(&[key, node, snap]);
        while i > 0 {
            let p = (i - 1) / 2;
            if self.words[3 * p] <= self.words[3 * i] {
                break;
            }
            for k in 0..3 {
                self.words.swap(3 * p + k, 3 * i + k);
            }
            i = p;
        }
        true
    }
    /// Drop the worse half of the entries (the highest keys); returns how many went. The
    /// entries left are sorted, which is a valid heap.
    fn shed_worse_half(&mut self) -> usize {
        let (records, _) = self.words[..3 * self.len].as_chunks_mut::<3>();
        records.sort_unstable_by_key(|r| r[0]);
        let dropped = self.len - self.len / 2;
        self.len /= 2;
        dropped
    }
    fn pop(&mut self) -> Option<(u32, u32, u32)> {
        if self.len == 0 {
            return None;
        }
        let top = (self.words[0], self.words[1], self.words[2]);
        self.len -= 1;
        let last = self.len;
        for k in 0..3 {
            self.words[k] = self.words[3 * last + k];
        }
        let mut i = 0;
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut m = i;
            if l < last && self.words[3 * l] < self.words[3 * m] {
                m = l;
            }
            if r < last && self.words[3 * r] < self.words[3 * m] {
                m = r;
            }
            if m == i {
                break;
            }
            for k in 0..3 {
                self.words.swap(3 * m + k, 3 * i + k);
            }
            i = m;
        }
        Some(top)
    }
}

/// Take `n` words off the front of `rest`.
fn carve<'m>(rest: &mut &'m mut [u32], n: usize, used: &mut usize) -> Option<&'m mut [u32]> {
    if n > rest.len() {
        return None;
    }
    let (head, tail) = core::mem::take(rest).split_at_mut(n);
    *rest = tail;
    *used += n;
    Some(head)
}

/// The planner: a task, its arena, and the search in progress.
pub struct Planner<'t, 'm> {
    task: Task<'t>,
    config: PlannerConfig,
    relax: Relaxation<'m>,
    /// Bit per action: compression safe.
    safe: &'m mut [u32],
    /// Per fact: how many running actions protect it as an invariant (for the current state).
    protect: &'m mut [u32],
    /// Per fact and numeric variable: the last step of the loaded path that wrote it (0: none).
    last_writer: &'m mut [u32],
    /// The loaded path: per step its snap (`action << 1 | is_end`), node ids root..parent.
    path_snap: &'m mut [u32],
    path_nodes: &'m mut [u32],
    /// Earliest times of the loaded path and of a candidate child.
    est_parent: &'m mut [u32],
    est_child: &'m mut [u32],
    /// Decoded constraints of the loaded path (three words each) and their count.
    path_constraints: &'m mut [u32],
    loaded_constraints: usize,
    loaded_steps: usize,
    /// Nodes on the loaded path (`path_nodes[..loaded_depth]`, root first).
    loaded_depth: usize,
    loaded_node: u32,
    /// The running actions' start steps on the loaded path, parallel to its running list.
    running_start: [u32; MAX_RUNNING],
    /// The parent's and the child's states, and a temporary for the successor checks.
    parent_state: &'m mut [u32],
    child_state: &'m mut [u32],
    probe_state: &'m mut [u32],
    /// The child's serialised constraints.
    child_bytes: [u8; MAX_NODE_CONSTRAINT_BYTES],
    /// The node store and the duplicate buckets (head node of each chain).
    nodes: &'m mut [u32],
    nodes_used: usize,
    buckets: &'m mut [u32],
    regular: Heap<'m>,
    preferred: Heap<'m>,
    fixed_words: usize,
    seq: u32,
    boost: u32,
    turn: bool,
    goal_node: u32,
    status: Status,
    stats: Stats,
    fact_words: usize,
}

/// Words of a packed state: facts, numeric values (two words each), running count and ids.
fn state_words(task: &Task<'_>) -> usize {
    task.fact_count().div_ceil(32) + 2 * task.numeric_count() + 1 + MAX_RUNNING
}

impl<'t, 'm> Planner<'t, 'm> {
    /// Set up a search for `task` in `arena`. Errors if the arena cannot hold the task's
    /// tables, the scratch for `config.max_steps` steps and a root node.
    pub fn new(
        task: Task<'t>,
        arena: &'m mut [u32],
        mut config: PlannerConfig,
    ) -> Result<Self, Region> {
        config.max_steps = config.max_steps.clamp(2, MAX_STEPS - 2);
        let arena_words = arena.len();
        let facts = task.fact_count();
        let actions = task.action_count();
        let ids = facts + task.numeric_count();
        let all = facts + actions;
        let relaxed = 2 * actions;
        let (offsets_n, entries_n, _) = heuristic::index_words(&task);
        let (add_offsets_n, add_entries_n) = heuristic::add_words(&task);
        let mut adds = 0;
        for a in 0..actions {
            let act = task.action(a);
            adds += act.facts(FactList::AddStart).len() + act.facts(FactList::AddEnd).len() + 1;
        }
        let steps = config.max_steps + 3;
        let max_constraints = 8 * steps;
        let sw = state_words(&task);
        let mut rest: &'m mut [u32] = arena;
        let mut used = 0usize;
        let mut take = |n: usize| carve(&mut rest, n, &mut used).ok_or(Region::Tables);
        let relax = Relaxation {
            pre_offsets: take(offsets_n)?,
            pre_index: take(entries_n)?,
            pre_count: take(relaxed)?,
            cost: take(all.max(offsets_n))?,
            supporter: take(all)?,
            waiting: take(relaxed)?,
            action_cost: take(relaxed)?,
            heap: take(2 * (all + adds + 1))?,
            marked: take(relaxed.div_ceil(32))?,
            stack: take(entries_n + task.goal_facts().len() + 1)?,
            goal: take(facts.div_ceil(32))?,
            add_offsets: take(add_offsets_n)?,
            add_index: take(add_entries_n)?,
            own_cost: take(relaxed)?,
        };
        let safe = take(actions.div_ceil(32))?;
        let protect = take(facts)?;
        let last_writer = take(ids)?;
        let path_snap = take(steps)?;
        let path_nodes = take(steps)?;
        let est_parent = take(steps)?;
        let est_child = take(steps)?;
        let path_constraints = take(3 * max_constraints)?;
        let parent_state = take(sw)?;
        let child_state = take(sw)?;
        let probe_state = take(sw)?;
        let fixed = used;
        let remaining = rest.len();
        let bucket_count = (remaining / 64).clamp(1024, 1 << 16).next_power_of_two();
        let buckets = carve(&mut rest, bucket_count, &mut used).ok_or(Region::Tables)?;
        let remaining = rest.len();
        let regular = carve(&mut rest, remaining / 4 / 3 * 3, &mut used).ok_or(Region::Tables)?;
        let preferred = carve(&mut rest, remaining / 8 / 3 * 3, &mut used).ok_or(Region::Tables)?;
        let nodes = rest;
        let mut planner = Self {
            task,
            config,
            relax,
            safe,
            protect,
            last_writer,
            path_snap,
            path_nodes,
            est_parent,
            est_child,
            path_constraints,
            loaded_constraints: 0,
            loaded_steps: 0,
            loaded_depth: 0,
            loaded_node: NONE,
            running_start: [0; MAX_RUNNING],
            parent_state,
            child_state,
            probe_state,
            child_bytes: [0; MAX_NODE_CONSTRAINT_BYTES],
            nodes,
            nodes_used: 0,
            buckets,
            regular: Heap {
                words: regular,
                len: 0,
                peak: 0,
            },
            preferred: Heap {
                words: preferred,
                len: 0,
                peak: 0,
            },
            fixed_words: fixed + bucket_count,
            seq: 0,
            boost: 0,
            turn: false,
            goal_node: NONE,
            status: Status::Searching,
            stats: Stats {
                arena_words: arena_words as u64,
                best_h: u32::MAX,
                ..Stats::default()
            },
            fact_words: facts.div_ceil(32),
        };
        planner.buckets.iter_mut().for_each(|b| *b = NONE);
        planner
            .relax
            .build_index(&planner.task, config.relaxed_cost);
        planner.mark_compression_safe();
        planner.start();
        Ok(planner)
    }

    pub fn task(&self) -> &Task<'t> {
        &self.task
    }
    pub fn status(&self) -> Status {
        self.status
    }
    pub fn stats(&self) -> Stats {
        let mut s = self.stats;
        let used =
            self.fixed_words + self.nodes_used + 3 * self.regular.peak + 3 * self.preferred.peak;
        s.peak_words = s.peak_words.max(used as u64);
        s
    }
    /// Whether the end of `action` may be applied straight after its start without losing plans.
    pub fn compression_safe(&self, action: usize) -> bool {
        self.safe[action / 32] & (1 << (action % 32)) != 0
    }

    // ----- compression safety -------------------------------------------------------------

    /// An action is compression safe (a sufficient condition, checked against brute force in
    /// the tests) when its end has no numeric conditions or effects and no numeric invariants,
    /// every end precondition is one of its invariants or a start precondition no action
    /// deletes, and every fact its end adds or deletes is touched by no other action (no
    /// other action's condition, invariant or effect names it) and is not a window fact.
    /// Then applying the end at once changes no other step's support, threatens nothing, and
    /// adds no ordering the original plan did not have.
    fn mark_compression_safe(&mut self) {
        let task = self.task;
        // protect[f] as scratch: bit 0 = deleted by some action; bits 1.. = count of actions
        // touching f (saturating at 3). last_writer[f] = 1 + the last action counted for f.
        self.protect.iter_mut().for_each(|x| *x = 0);
        self.last_writer.iter_mut().for_each(|x| *x = 0);
        for a in 0..task.action_count() {
            let act = task.action(a);
            for list in [FactList::DelStart, FactList::DelEnd] {
                for f in act.facts(list).iter() {
                    self.protect[f] |= 1;
                }
            }
            for list in [
                FactList::PreStart,
                FactList::Invariant,
                FactList::PreEnd,
                FactList::AddStart,
                FactList::DelStart,
                FactList::AddEnd,
                FactList::DelEnd,
            ] {
                for f in act.facts(list).iter() {
                    if self.last_writer[f] != a as u32 + 1 {
                        self.last_writer[f] = a as u32 + 1;
                        if self.protect[f] >> 1 < 3 {
                            self.protect[f] += 2;
                        }
                    }
                }
            }
        }
        self.safe.iter_mut().for_each(|x| *x = 0);
        for a in 0..task.action_count() {
            let act = task.action(a);
            if act.has_numeric(NumericList::CondEnd)
                || act.has_numeric(NumericList::EffEnd)
                || act.has_numeric(NumericList::CondInvariant)
                || act.end_window != (0, UNBOUNDED)
            {
                continue;
            }
            let inv = act.facts(FactList::Invariant);
            let pre_start = act.facts(FactList::PreStart);
            let pre_ok = act
                .facts(FactList::PreEnd)
                .iter()
                .all(|p| inv.contains(p) || (pre_start.contains(p) && self.protect[p] & 1 == 0));
            let private = |f: usize| self.protect[f] >> 1 == 1;
            let effects_private = act.facts(FactList::AddEnd).iter().all(private)
                && act.facts(FactList::DelEnd).iter().all(private);
            if pre_ok && effects_private {
                self.safe[a / 32] |= 1 << (a % 32);
            }
        }
        self.protect.iter_mut().for_each(|x| *x = 0);
        self.last_writer.iter_mut().for_each(|x| *x = 0);
    }

    // ----- states -----------------------------------------------------------------------------

    fn fact(state: &[u32], f: usize) -> bool {
        state[f / 32] & (1 << (f % 32)) != 0
    }
    fn set_fact(state: &mut [u32], f: usize, on: bool) {
        if on {
            state[f / 32] |= 1 << (f % 32);
        } else {
            state[f / 32] &= !(1 << (f % 32));
        }
    }
    fn value(&self, state: &[u32], v: usize) -> i64 {
        let at = self.fact_words + 2 * v;
        (u64::from(state[at]) | u64::from(state[at + 1]) << 32) as i64
    }
    fn set_value(&self, state: &mut [u32], v: usize, x: i64) {
        let at = self.fact_words + 2 * v;
        state[at] = x as u64 as u32;
        state[at + 1] = (x as u64 >> 32) as u32;
    }
    fn running_at(&self) -> usize {
        self.fact_words + 2 * self.task.numeric_count()
    }
    fn running<'s>(&self, state: &'s [u32]) -> &'s [u32] {
        let at = self.running_at();
        let n = state[at] as usize;
        &state[at + 1..at + 1 + n]
    }
    /// Words of the state that are in use (the running list is variable).
    fn used_state_words(&self, state: &[u32]) -> usize {
        self.running_at() + 1 + state[self.running_at()] as usize
    }
    fn is_running(&self, state: &[u32], a: usize) -> bool {
        self.running(state).binary_search(&(a as u32)).is_ok()
    }

    fn initial_state(&self, state: &mut [u32]) {
        state.iter_mut().for_each(|x| *x = 0);
        for f in 0..self.task.fact_count() {
            Self::set_fact(state, f, self.task.initially_true(f));
        }
        for v in 0..self.task.numeric_count() {
            self.set_value(state, v, self.task.initial_value(v));
        }
    }

    /// Recompute the invariant protection counts for the running actions of `state`.
    fn load_protection(&mut self, running: &[u32], add: bool) {
        for &a in running {
            let act = self.task.action(a as usize);
            for f in act.facts(FactList::Invariant).iter() {
                if add {
                    self.protect[f] += 1;
                } else {
                    self.protect[f] -= 1;
                }
            }
        }
    }

    fn numeric_ok(&self, state: &[u32], list: NumericList, a: usize) -> bool {
        let act = self.task.action(a);
        act.numeric(list)
            .all(|c| c.holds(&|v| self.value(state, v)))
    }

    /// Apply the start (`end == false`) or end of `a` to `state` in place. Returns false if it
    /// is not applicable or breaks an invariant (the protection counts must describe the
    /// running actions of `state` before this snap, without `a`'s own entry for an end).
    fn apply_snap(&self, state: &mut [u32], a: usize, end: bool, own_protected: bool) -> bool {
        let task = self.task;
        let act = task.action(a);
        let (pre, add, del, conds, effs) = if end {
            (
                FactList::PreEnd,
                FactList::AddEnd,
                FactList::DelEnd,
                NumericList::CondEnd,
                NumericList::EffEnd,
            )
        } else {
            (
                FactList::PreStart,
                FactList::AddStart,
                FactList::DelStart,
                NumericList::CondStart,
                NumericList::EffStart,
            )
        };
        if self.is_running(state, a) != end {
            return false;
        }
        if !act.facts(pre).iter().all(|f| Self::fact(state, f)) {
            return false;
        }
        if !self.numeric_ok(state, conds, a) {
            return false;
        }
        // Numeric effects read the values before the snap.
        let mut new_values = [(0usize, 0i64); 16];
        let mut n_values = 0;
        for e in act.numeric(effs) {
            let Some(x) = e.apply(&|v| self.value(state, v)) else {
                return false;
            };
            if n_values == new_values.len() {
                return false;
            }
            new_values[n_values] = (e.target, x);
            n_values += 1;
        }
        let inv = act.facts(FactList::Invariant);
        for f in act.facts(del).iter() {
            let own = u32::from(own_protected && inv.contains(f));
            if self.protect[f] > own && !act.facts(add).contains(f) {
                return false;
            }
            Self::set_fact(state, f, false);
        }
        for f in act.facts(add).iter() {
            Self::set_fact(state, f, true);
        }
        for &(v, x) in &new_values[..n_values] {
            self.set_value(state, v, x);
        }
        // The running list, kept sorted.
        let at = self.running_at();
        let n = state[at] as usize;
        let list = &mut state[at + 1..at + 1 + MAX_RUNNING];
        if end {
            let Ok(i) = list[..n].binary_search(&(a as u32)) else {
                return false;
            };
            list.copy_within(i + 1..n, i);
            state[at] -= 1;
        } else {
            if n == MAX_RUNNING {
                return false;
            }
            // A start that would deadlock with a running action is a dead end: neither end
            // could ever be applied while the other runs.
            if list[..n]
                .iter()
                .any(|&r| self.ends_block_each_other(a, r as usize))
            {
                return false;
            }
            let i = list[..n].partition_point(|&x| x < a as u32);
            list.copy_within(i..n, i + 1);
            list[i] = a as u32;
            state[at] += 1;
            // The new action's own invariants must hold once it has started.
            if !inv.iter().all(|f| Self::fact(state, f))
                || !self.numeric_ok(state, NumericList::CondInvariant, a)
            {
                return false;
            }
        }
        // Numeric invariants of the running actions.
        if n_values > 0 {
            for &r in self.running(state) {
                if !self.numeric_ok(state, NumericList::CondInvariant, r as usize) {
                    return false;
                }
            }
        }
        true
    }

    /// Whether the end of `x` deletes (without adding back) an invariant of `y`.
    fn end_breaks_invariant(&self, x: usize, y: usize) -> bool {
        let (ax, ay) = (self.task.action(x), self.task.action(y));
        let inv = ay.facts(FactList::Invariant);
        let add = ax.facts(FactList::AddEnd);
        ax.facts(FactList::DelEnd)
            .iter()
            .any(|f| inv.contains(f) && !add.contains(f))
    }

    /// Whether `x` and `y`, running together, could never both end: each one's end deletes an
    /// invariant of the other (two images with one camera, each needing it calibrated
    /// throughout and uncalibrating it at its end). The delete-free heuristic cannot see this
    /// dead end, so the search refuses the start that would create it.
    fn ends_block_each_other(&self, x: usize, y: usize) -> bool {
        x != y && self.end_breaks_invariant(x, y) && self.end_breaks_invariant(y, x)
    }

    /// Apply snap id `snap` (start, end or compressed) to `state` in place.
    fn apply(&self, state: &mut [u32], snap: u32) -> bool {
        let a = (snap >> 2) as usize;
        match snap & 3 {
            START => self.apply_snap(state, a, false, false),
            END => self.apply_snap(state, a, true, true),
            _ => {
                // The protection counts do not include the action itself here.
                self.apply_snap(state, a, false, false) && self.apply_snap(state, a, true, false)
            }
        }
    }

    fn is_goal(&self, state: &[u32]) -> bool {
        state[self.running_at()] == 0
            && self.task.goal_facts().iter().all(|g| Self::fact(state, g))
            && self
                .task
                .goal_conditions()
                .all(|c| c.holds(&|v| self.value(state, v)))
    }

    // ----- nodes --------------------------------------------------------------------------------

    fn node_state(&self, node: u32) -> &[u32] {
        let at = node as usize + NODE_HEADER;
        &self.nodes[at..]
    }
    fn node_parent(&self, node: u32) -> u32 {
        self.nodes[node as usize]
    }
    fn node_snap(&self, node: u32) -> u32 {
        self.nodes[node as usize + 1]
    }
    fn node_constraint_bytes(&self, node: u32) -> (usize, usize) {
        let n = node as usize;
        let bytes = (self.nodes[n + 2] & 0xffff) as usize;
        let state_len = self.nodes[n + 3] as usize;
        (n + NODE_HEADER + state_len, bytes)
    }
    fn state_hash(&self, state: &[u32]) -> u32 {
        let n = self.used_state_words(state);
        let mut h: u32 = 0x811c_9dc5;
        for &w in &state[..n] {
            h = (h ^ w).wrapping_mul(0x0100_0193);
            h ^= h >> 15;
        }
        h
    }
    fn find_duplicate(&self, state: &[u32], hash: u32) -> bool {
        let n = self.used_state_words(state);
        let mut node = self.buckets[hash as usize & (self.buckets.len() - 1)];
        while node != NONE {
            let s = self.node_state(node);
            if s[..n] == state[..n] {
                return true;
            }
            node = self.nodes[node as usize + 4];
        }
        false
    }

    /// Store the child state with the constraint bytes in `self.child_bytes[..bytes]`.
    fn store_node(
        &mut self,
        parent: u32,
        snap: u32,
        h: u32,
        bytes: usize,
        hash: u32,
    ) -> Option<u32> {
        let state_len = self.used_state_words(self.child_state);
        let words = NODE_HEADER + state_len + bytes.div_ceil(4);
        if self.nodes_used + words > self.nodes.len() {
            return None;
        }
        let id = self.nodes_used as u32;
        let at = self.nodes_used;
        let bucket = hash as usize & (self.buckets.len() - 1);
        self.nodes[at] = parent;
        self.nodes[at + 1] = snap;
        self.nodes[at + 2] = h.min(0xffff) << 16 | bytes as u32;
        self.nodes[at + 3] = state_len as u32;
        self.nodes[at + 4] = self.buckets[bucket];
        self.buckets[bucket] = id;
        self.nodes[at + NODE_HEADER..at + NODE_HEADER + state_len]
            .copy_from_slice(&self.child_state[..state_len]);
        let cat = at + NODE_HEADER + state_len;
        for (i, chunk) in self.child_bytes[..bytes].chunks(4).enumerate() {
            let mut w = [0u8; 4];
            w[..chunk.len()].copy_from_slice(chunk);
            self.nodes[cat + i] = u32::from_le_bytes(w);
        }
        self.nodes_used += words;
        self.stats.nodes += 1;
        Some(id)
    }

    fn constraint_byte(&self, node: u32, i: usize) -> u8 {
        let (at, _) = self.node_constraint_bytes(node);
        self.nodes[at + i / 4].to_le_bytes()[i % 4]
    }

    // ----- the loaded path ----------------------------------------------------------------------

    /// Make `node` the loaded path: its steps, decoded constraints, earliest times, last
    /// writers and its running actions' start steps. False if the plan is too long.
    fn load_path(&mut self, node: u32) -> Result<(), Region> {
        if self.loaded_node == node {
            return Ok(());
        }
        self.loaded_node = NONE;
        let mut depth = 0usize;
        let mut n = node;
        while n != NONE {
            if depth >= self.path_nodes.len() {
                return Err(Region::PlanLength);
            }
            self.path_nodes[depth] = n;
            depth += 1;
            n = self.node_parent(n);
        }
        self.path_nodes[..depth].reverse();
        self.loaded_depth = depth;
        let eps = self.task.epsilon();
        let ids = self.last_writer.len();
        self.last_writer[..ids].iter_mut().for_each(|x| *x = 0);
        let mut steps = 0usize;
        let mut constraints = 0usize;
        let mut bytes = [0u8; MAX_NODE_CONSTRAINT_BYTES];
        for d in 0..depth {
            let n = self.path_nodes[d];
            let snap = self.node_snap(n);
            if snap != NONE {
                let a = snap >> 2;
                let kinds: &[u32] = match snap & 3 {
                    START => &[0],
                    END => &[1],
                    _ => &[0, 1],
                };
                for &k in kinds {
                    steps += 1;
                    if steps + 2 >= self.path_snap.len() {
                        return Err(Region::PlanLength);
                    }
                    self.path_snap[steps] = a << 1 | k;
                    self.record_writes(steps, a as usize, k == 1);
                }
            }
            let (_, len) = self.node_constraint_bytes(n);
            for (i, b) in bytes[..len].iter_mut().enumerate() {
                *b = self.constraint_byte(n, i);
            }
            let mut at = 0;
            while at < len {
                let Ok(c) = constraints::decode(&bytes[..len], eps, &mut at) else {
                    break;
                };
                if 3 * (constraints + 1) > self.path_constraints.len() {
                    return Err(Region::PlanLength);
                }
                self.path_constraints[3 * constraints] =
                    u32::from(c.before) | u32::from(c.after) << 16;
                self.path_constraints[3 * constraints + 1] = c.lb;
                self.path_constraints[3 * constraints + 2] = c.ub;
                constraints += 1;
            }
        }
        self.loaded_steps = steps;
        self.loaded_constraints = constraints;
        // Start steps of the running actions: the last start of each.
        let state_len = self.used_state_words(self.node_state(node));
        let (ps, ns) = (
            &mut *self.parent_state,
            &self.nodes[node as usize + NODE_HEADER..],
        );
        ps[..state_len].copy_from_slice(&ns[..state_len]);
        let at = self.running_at();
        let running_n = self.parent_state[at] as usize;
        for i in 0..running_n {
            let a = self.parent_state[at + 1 + i];
            let mut s = steps;
            while s > 0 && self.path_snap[s] != a << 1 {
                s -= 1;
            }
            self.running_start[i] = s as u32;
        }
        // Earliest times of the path (consistent: it was checked when the node was stored).
        self.est_parent[..=steps].iter_mut().for_each(|x| *x = 0);
        let task = self.task;
        let snaps = &self.path_snap;
        let window = |k: usize| step_window(&task, snaps[k]);
        earliest_words(
            steps,
            &self.path_constraints[..3 * constraints],
            &window,
            self.est_parent,
        )
        .map_err(|_| Region::PlanLength)?;
        self.loaded_node = node;
        Ok(())
    }

    fn record_writes(&mut self, step: usize, a: usize, end: bool) {
        let act = self.task.action(a);
        let facts = self.task.fact_count();
        let (add, del, effs) = if end {
            (FactList::AddEnd, FactList::DelEnd, NumericList::EffEnd)
        } else {
            (
                FactList::AddStart,
                FactList::DelStart,
                NumericList::EffStart,
            )
        };
        for f in act.facts(add).iter().chain(act.facts(del).iter()) {
            self.last_writer[f] = step as u32;
        }
        for e in act.numeric(effs) {
            self.last_writer[facts + e.target] = step as u32;
        }
    }

    /// Whether step `s` of the loaded path reads id `id` (a fact, or `facts + variable`).
    /// An end's invariants count as reads only against deletes (`for_delete`).
    fn step_reads(&self, s: usize, id: usize, for_delete: bool) -> bool {
        let snap = self.path_snap[s];
        snap_reads(&self.task, snap >> 1, snap & 1 == 1, id, for_delete)
    }

    /// The constraints of a new step `j` (snap of `a`) on the loaded path plus `extra` steps
    /// already appended, appended to `out` (deduplicated by earlier step).
    fn step_constraints(
        &self,
        j: usize,
        a: usize,
        end: bool,
        start_step: usize,
        out: &mut [Constraint; 64],
        n: &mut usize,
    ) -> Result<(), Region> {
        let task = self.task;
        let eps = task.epsilon();
        let facts = task.fact_count();
        let mut add = |before: usize, lb: u32, ub: u32, n: &mut usize| -> Result<(), Region> {
            if before == 0 && lb == 0 {
                return Ok(());
            }
            for c in out[..*n].iter_mut() {
                if c.before as usize == before && c.after as usize == j {
                    c.lb = c.lb.max(lb);
                    c.ub = c.ub.min(ub);
                    return Ok(());
                }
            }
            if *n == out.len() {
                return Err(Region::PlanLength);
            }
            out[*n] = Constraint {
                before: before as u16,
                after: j as u16,
                lb,
                ub,
            };
            *n += 1;
            Ok(())
        };
        // Reads: after the last writer.
        let mut reads_err = Ok(());
        for_each_read(&task, a, end, &mut |id| {
            let w = self.last_writer[id] as usize;
            if w > 0 && reads_err.is_ok() {
                reads_err = add(w, eps, UNBOUNDED, n);
            }
        });
        reads_err?;
        // Writes: after the last writer and every reader since.
        let mut writes_err = Ok(());
        for_each_write(&task, a, end, &mut |id, is_delete| {
            if writes_err.is_err() {
                return;
            }
            let w = self.last_writer[id] as usize;
            if w > 0 {
                writes_err = add(w, eps, UNBOUNDED, n);
            }
            for s in w + 1..j {
                if self.step_reads(s, id, is_delete || id >= facts) {
                    writes_err = add(s, eps, UNBOUNDED, n);
                    if writes_err.is_err() {
                        return;
                    }
                }
            }
        });
        writes_err?;
        if end {
            let act = task.action(a);
            add(start_step, act.duration_lb, act.duration_ub, n)?;
        }
        Ok(())
    }

    // ----- search -------------------------------------------------------------------------------

    fn start(&mut self) {
        let task = self.task;
        let cs = core::mem::take(&mut self.child_state);
        self.initial_state(cs);
        self.child_state = cs;
        let h = {
            let cs = &*self.child_state;
            self.relax.evaluate(&task, &|f| Self::fact(cs, f), &[])
        };
        self.stats.evaluated += 1;
        if h == DEAD_END {
            self.status = Status::Unsolvable;
            return;
        }
        self.stats.best_h = h;
        let hash = self.state_hash(self.child_state);
        let Some(root) = self.store_node(NONE, NONE, h, 0, hash) else {
            self.status = Status::OutOfMemory(Region::Nodes);
            return;
        };
        if self.is_goal(self.child_state) {
            self.goal_node = root;
            self.status = Status::Solved;
            return;
        }
        if let Err(r) = self.push_successors(root, h) {
            self.status = Status::OutOfMemory(r);
        }
    }

    /// Push every applicable snap of the state in `child_state` (stored as `node`) into the
    /// open lists with key `h`; those in the relaxed plan also into the preferred list.
    fn push_successors(&mut self, node: u32, h: u32) -> Result<(), Region> {
        let task = self.task;
        let running_n = self.child_state[self.running_at()] as usize;
        let mut running = [0u32; MAX_RUNNING];
        running[..running_n].copy_from_slice(self.running(self.child_state));
        self.load_protection(&running[..running_n], true);
        let sw = self.probe_state.len();
        let mut result = Ok(());
        for a in 0..task.action_count() {
            let is_running = running[..running_n].binary_search(&(a as u32)).is_ok();
            let snap = if is_running {
                (a as u32) << 2 | END
            } else if self.config.compression && self.compression_safe(a) {
                (a as u32) << 2 | COMPRESSED
            } else {
                (a as u32) << 2 | START
            };
            // Cheap precondition test before the full application.
            let act = task.action(a);
            let pre = if is_running {
                FactList::PreEnd
            } else {
                FactList::PreStart
            };
            if !act
                .facts(pre)
                .iter()
                .all(|f| Self::fact(self.child_state, f))
            {
                continue;
            }
            let (probe, child) = (&mut *self.probe_state, &*self.child_state);
            probe[..sw].copy_from_slice(&child[..sw]);
            let probe = core::mem::take(&mut self.probe_state);
            let ok = self.apply(probe, snap);
            self.probe_state = probe;
            if !ok {
                continue;
            }
            let key = h.min(0xfff) << 20 | (self.seq & 0xf_ffff);
            self.seq = self.seq.wrapping_add(1);
            if !self.regular.push(key, node, snap) {
                if self.config.shed_when_full && self.regular.len > 1 {
                    self.stats.shed += self.regular.shed_worse_half() as u64;
                }
                if !self.regular.push(key, node, snap) {
                    result = Err(Region::RegularOpen);
                    break;
                }
            }
            self.stats.generated += 1;
            let r = 2 * a + usize::from(is_running);
            if self.config.preferred_operators
                && self.relax.in_relaxed_plan(r)
                && !self.preferred.push(key, node, snap)
            {
                if self.config.shed_when_full && self.preferred.len > 1 {
                    self.stats.shed += self.preferred.shed_worse_half() as u64;
                }
                if !self.preferred.push(key, node, snap) {
                    result = Err(Region::PreferredOpen);
                    break;
                }
            }
        }
        self.load_protection(&running[..running_n], false);
        result
    }

    /// Run at most `budget` expansions.
    pub fn step(&mut self, budget: u32) -> Status {
        for _ in 0..budget {
            if self.status != Status::Searching {
                break;
            }
            let entry = if (self.turn || self.boost > 0) && self.preferred.len > 0 {
                self.boost = self.boost.saturating_sub(1);
                self.preferred.pop()
            } else {
                self.regular.pop().or_else(|| self.preferred.pop())
            };
            self.turn = !self.turn;
            let Some((_, parent, snap)) = entry else {
                // With entries shed, an empty open list proves nothing.
                self.status = if self.stats.shed > 0 {
                    Status::OutOfMemory(Region::RegularOpen)
                } else {
                    Status::Unsolvable
                };
                break;
            };
            match self.expand(parent, snap) {
                Ok(()) => {}
                // A path too long to extend is a branch dropped, not the search's end.
                Err(Region::PlanLength) => self.stats.too_long += 1,
                Err(r) => self.status = Status::OutOfMemory(r),
            }
        }
        let s = self.stats();
        self.stats.peak_words = s.peak_words;
        self.status
    }

    fn expand(&mut self, parent: u32, snap: u32) -> Result<(), Region> {
        self.stats.expanded += 1;
        self.load_path(parent)?;
        let steps = self.loaded_steps;
        let task = self.task;
        let a = (snap >> 2) as usize;
        // The child's state.
        let sw = self.child_state.len();
        self.child_state[..sw].copy_from_slice(&self.parent_state[..sw]);
        let running_n = self.parent_state[self.running_at()] as usize;
        let mut running = [0u32; MAX_RUNNING];
        running[..running_n].copy_from_slice(self.running(self.parent_state));
        self.load_protection(&running[..running_n], true);
        let child = core::mem::take(&mut self.child_state);
        let ok = self.apply(child, snap);
        self.child_state = child;
        self.load_protection(&running[..running_n], false);
        if !ok {
            return Ok(());
        }
        // Its constraints.
        let mut cons = [Constraint {
            before: 0,
            after: 0,
            lb: 0,
            ub: 0,
        }; 64];
        let mut n = 0usize;
        let kind = snap & 3;
        let new_steps = if kind == COMPRESSED { 2 } else { 1 };
        if steps + new_steps + 2 >= self.path_snap.len() {
            return Err(Region::PlanLength);
        }
        let j = steps + 1;
        let start_step = if kind == END {
            let i = running[..running_n].binary_search(&(a as u32)).unwrap_or(0);
            self.running_start[i] as usize
        } else {
            0
        };
        self.step_constraints(j, a, kind == END, start_step, &mut cons, &mut n)?;
        self.path_snap[j] = (a as u32) << 1 | u32::from(kind == END);
        if kind == COMPRESSED {
            // The end straight after: the start is a step of the path now.
            let mut saved = [(0usize, 0u32); 64];
            let mut n_saved = 0;
            for_each_write(&task, a, false, &mut |id, _| {
                if n_saved < saved.len() {
                    saved[n_saved] = (id, self.last_writer[id]);
                    n_saved += 1;
                }
            });
            for &(id, _) in &saved[..n_saved] {
                self.last_writer[id] = j as u32;
            }
            self.path_snap[j + 1] = (a as u32) << 1 | 1;
            let r = self.step_constraints(j + 1, a, true, j, &mut cons, &mut n);
            for &(id, w) in saved[..n_saved].iter().rev() {
                self.last_writer[id] = w;
            }
            r?;
        }
        // STN check, warm-started from the parent's earliest times.
        let last = steps + new_steps;
        self.est_child[..=steps].copy_from_slice(&self.est_parent[..=steps]);
        self.est_child[steps + 1..=last]
            .iter_mut()
            .for_each(|x| *x = 0);
        let base = 3 * self.loaded_constraints;
        if base + 3 * n > self.path_constraints.len() {
            return Err(Region::PlanLength);
        }
        for (i, c) in cons[..n].iter().enumerate() {
            self.path_constraints[base + 3 * i] = u32::from(c.before) | u32::from(c.after) << 16;
            self.path_constraints[base + 3 * i + 1] = c.lb;
            self.path_constraints[base + 3 * i + 2] = c.ub;
        }
        let snaps = &self.path_snap;
        let window = |k: usize| step_window(&task, snaps[k]);
        let consistent = earliest_words(
            last,
            &self.path_constraints[..base + 3 * n],
            &window,
            self.est_child,
        )
        .is_ok();
        if !consistent {
            self.stats.inconsistent += 1;
            return Ok(());
        }
        // Duplicates.
        let hash = self.state_hash(self.child_state);
        let quiescent = self.child_state[self.running_at()] == 0;
        let prune = match self.config.duplicates {
            Duplicates::Keep => false,
            Duplicates::PruneQuiescent => quiescent,
            Duplicates::PruneAll => true,
        };
        if prune && self.find_duplicate(self.child_state, hash) {
            self.stats.duplicates += 1;
            return Ok(());
        }
        if self.config.duplicates == Duplicates::PruneQuiescent
            && !quiescent
            && kind != START
            && self.repeats_ancestor(&running[..running_n], (kind == END).then_some(a))
        {
            self.stats.duplicates += 1;
            return Ok(());
        }
        // Heuristic.
        let h = {
            let cs = &*self.child_state;
            let at = self.running_at();
            let rn = cs[at] as usize;
            self.stats.evaluated += 1;
            self.relax
                .evaluate(&task, &|f| Self::fact(cs, f), &cs[at + 1..at + 1 + rn])
        };
        if h == DEAD_END {
            self.stats.dead_ends += 1;
            return Ok(());
        }
        if h < self.stats.best_h {
            self.stats.best_h = h;
            self.boost += BOOST;
        }
        // Store.
        let mut at = 0usize;
        for c in &cons[..n] {
            constraints::encode(c, task.epsilon(), &mut self.child_bytes, &mut at)
                .map_err(|_| Region::PlanLength)?;
        }
        let node = self
            .store_node(parent, snap, h, at, hash)
            .ok_or(Region::Nodes)?;
        if self.is_goal(self.child_state) {
            self.goal_node = node;
            self.status = Status::Solved;
            return Ok(());
        }
        self.push_successors(node, h)
    }

    /// Whether the child state (in `child_state`, reached by an end or a compressed action from
    /// the loaded path, whose running actions are `parent_running` in the order of
    /// `running_start`) equals an ancestor's state at which every action running in the child
    /// was already running, started by the same step. That ancestor dominates the child: the
    /// same facts, values and running instances, with the running actions as far from their
    /// ends or farther, and the child's later steps constrained by everything the ancestor's
    /// are and more. `ended` is the action whose end the child applied.
    fn repeats_ancestor(&self, parent_running: &[u32], ended: Option<usize>) -> bool {
        // The latest start step among the child's running actions.
        let mut latest_start = 0usize;
        for (i, &r) in parent_running.iter().enumerate() {
            if Some(r as usize) != ended {
                latest_start = latest_start.max(self.running_start[i] as usize);
            }
        }
        let n = self.used_state_words(self.child_state);
        let mut steps_at = self.loaded_steps;
        for d in (0..self.loaded_depth).rev() {
            if steps_at < latest_start {
                break;
            }
            let node = self.path_nodes[d];
            let state = self.node_state(node);
            if state.get(..n) == self.child_state.get(..n) {
                return true;
            }
            steps_at -= match self.node_snap(node) {
                NONE => 0,
                s if s & 3 == COMPRESSED => 2,
                _ => 1,
            };
        }
        false
    }

    // ----- the plan -----------------------------------------------------------------------------

    /// The plan found (after [`Status::Solved`]): actions in order of their starts, written to
    /// `out`; returns how many, or None if there is no plan or `out` is too short.
    pub fn plan(&mut self, out: &mut [PlannedAction]) -> Option<(usize, u32)> {
        if self.goal_node == NONE {
            return None;
        }
        self.loaded_node = NONE;
        self.load_path(self.goal_node).ok()?;
        let steps = self.loaded_steps;
        let makespan = self.est_parent[..=steps].iter().copied().max().unwrap_or(0);
        let task = self.task;
        let snaps = &self.path_snap;
        let window = |k: usize| step_window(&task, snaps[k]);
        latest_words(
            steps,
            &self.path_constraints[..3 * self.loaded_constraints],
            &window,
            makespan,
            self.est_child,
        )
        .ok()?;
        let mut count = 0;
        for s in 1..=steps {
            let snap = self.path_snap[s];
            if snap & 1 == 1 {
                continue;
            }
            let a = snap >> 1;
            let mut e = s + 1;
            while e <= steps && self.path_snap[e] != (a << 1 | 1) {
                e += 1;
            }
            let slot = out.get_mut(count)?;
            let start = self.est_parent[s];
            *slot = PlannedAction {
                action: a as u16,
                start,
                duration: self.est_parent.get(e).copied().unwrap_or(start) - start,
                start_lb: start,
                start_ub: self.est_child[s],
            };
            count += 1;
        }
        out[..count].sort_unstable_by_key(|p| (p.start, p.action));
        Some((count, makespan))
    }
}

/// The window of plan step `snap` (`action << 1 | is_end`).
fn step_window(task: &Task<'_>, snap: u32) -> (u32, u32) {
    let act = task.action((snap >> 1) as usize);
    if snap & 1 == 1 {
        act.end_window
    } else {
        act.start_window
    }
}

fn unpack(words: &[u32], i: usize) -> Constraint {
    let w = words[3 * i];
    Constraint {
        before: (w & 0xffff) as u16,
        after: (w >> 16) as u16,
        lb: words[3 * i + 1],
        ub: words[3 * i + 2],
    }
}

/// [`stn::earliest`] over constraints packed three words each.
fn earliest_words(
    steps: usize,
    words: &[u32],
    window: &dyn Fn(usize) -> (u32, u32),
    est: &mut [u32],
) -> Result<(), stn::Inconsistent> {
    stn::earliest_with(steps, words.len() / 3, &|i| unpack(words, i), window, est)
}

fn latest_words(
    steps: usize,
    words: &[u32],
    window: &dyn Fn(usize) -> (u32, u32),
    horizon: u32,
    lst: &mut [u32],
) -> Result<(), stn::Inconsistent> {
    stn::latest_with(
        steps,
        words.len() / 3,
        &|i| unpack(words, i),
        window,
        horizon,
        lst,
    )
}

/// Every fact or variable (`facts + v`) the start or end of `a` reads, for ordering.
fn for_each_read(task: &Task<'_>, a: usize, end: bool, f: &mut dyn FnMut(usize)) {
    let act = task.action(a);
    let facts = task.fact_count();
    let lists: &[FactList] = if end {
        &[FactList::PreEnd]
    } else {
        &[FactList::PreStart, FactList::Invariant]
    };
    for &l in lists {
        for p in act.facts(l).iter() {
            f(p);
        }
    }
    let numeric: &[NumericList] = if end {
        &[
            NumericList::CondEnd,
            NumericList::CondInvariant,
            NumericList::EffEnd,
        ]
    } else {
        &[
            NumericList::CondStart,
            NumericList::CondInvariant,
            NumericList::EffStart,
        ]
    };
    for &l in numeric {
        for c in act.numeric(l) {
            for v in c.term_vars() {
                f(facts + v);
            }
        }
    }
}

/// Every fact or variable the start or end of `a` writes, with whether it is a delete.
fn for_each_write(task: &Task<'_>, a: usize, end: bool, f: &mut dyn FnMut(usize, bool)) {
    let act = task.action(a);
    let facts = task.fact_count();
    let (add, del, effs) = if end {
        (FactList::AddEnd, FactList::DelEnd, NumericList::EffEnd)
    } else {
        (
            FactList::AddStart,
            FactList::DelStart,
            NumericList::EffStart,
        )
    };
    for p in act.facts(add).iter() {
        f(p, false);
    }
    for p in act.facts(del).iter() {
        f(p, true);
    }
    for e in act.numeric(effs) {
        f(facts + e.target, false);
    }
}

/// Whether the start or end of `a` reads `id`; an end's invariants count for deletes only
/// (and numeric invariants always).
fn snap_reads(task: &Task<'_>, a: u32, end: bool, id: usize, for_delete: bool) -> bool {
    let act = task.action(a as usize);
    let facts = task.fact_count();
    if id < facts {
        if end {
            act.facts(FactList::PreEnd).contains(id)
                || (for_delete && act.facts(FactList::Invariant).contains(id))
        } else {
            act.facts(FactList::PreStart).contains(id)
                || act.facts(FactList::Invariant).contains(id)
        }
    } else {
        let mut found = false;
        for_each_read(task, a as usize, end, &mut |x| found |= x == id);
        found
    }
}
