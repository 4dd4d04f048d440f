//! The search: lazy greedy best-first search over snap actions (seed 001, section 4.1) with
//! two open lists (all successors, and those the relaxed plan prefers), all of it in one fixed
//! arena of 32-bit words handed in by the caller.
//!
//! A search node is a record in the arena: its parent, the snap action that reached it, its h,
//! its state's hash, its duplicate-chain link and the serialised temporal constraints its own
//! step added ([`crate::constraints`]). Its bit-packed state (facts one bit each, numeric
//! values, the running actions) is not stored: it is rebuilt from the path where needed
//! ([`replay`]) from the nearest ancestor that keeps one (one node in [`STATE_EVERY`]):
//! driverlog 18's 820 facts made a node's header and state about 34 words, its header is 5
//! now (beside the constraint bytes). Nothing else is stored per state: when a node is taken from an open list, the plan to its parent is walked
//! back, the ordering annotations are recreated from the steps' conditions and effects, the
//! constraints are unpacked and the STN is checked ([`crate::stn`]).
//!
//! The first search of a small portfolio orders the preferred successors of equal h by how
//! much of the relaxed plan they undo (the other list keeps the order generated), and gives way after [`ORDERED_RESTART_AFTER`] expansions without
//! progress to the searches before it ([`RESTART_AFTER`]).
//! Each state the first search evaluates also begins a lookahead along its relaxed plan
//! ([`LOOKAHEAD_PHASES`], YAHSP-style: `lookahead.rs`), which adds the state the relaxed plan's
//! applicable snaps lead to, evaluated once. After [`FIRST_COMMIT_AFTER`] expansions without
//! progress it commits to its best node and goes on from there (`climb.rs`), and gives way
//! only when that makes no progress either.
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
use crate::heuristic::{self, carve, Relaxation, RelaxedCost, DEAD_END};
use crate::stn;
use crate::task::{FactList, NumericList, Task, UNBOUNDED};

mod climb;
mod commit;
mod eliminate;
pub use eliminate::{ELIM_REBUILD_WEIGHT, ELIM_SNAPS_PER_UNIT};
mod expand;
mod load_check;
mod lookahead;
mod novelty;
mod path;
mod replay;
mod running_ends;
pub(crate) use path::{for_each_read, for_each_write, snap_reads};
mod setup;
mod state;

pub use climb::FIRST_COMMIT_AFTER;
pub use lookahead::{LOOKAHEAD_AFTER, LOOKAHEAD_MAX_STEPS, LOOKAHEAD_PHASES};
pub use novelty::{NoveltyTable, NOVELTY_PARTITIONS};
pub use running_ends::{RunningEnds, CHECK_RUNNING_ENDS};
use setup::SetUp;
pub use setup::BUCKET_WORDS_PER_PIECE;

use crate::dispatch::{NetworkError, PlanNetwork, PlanStep};
use path::{earliest_words, latest_words, step_window, unpack};

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
/// One node in this many along a path keeps its state (after its constraint bytes); the others'
/// are rebuilt from it by applying at most this many - 1 snaps ([`replay`]). At most 15 (four
/// bits of the node's header). Every node keeping one cost driverlog 18 the arena (not solved
/// in 8 MiB); none keeping one cost driverlog 2 20 % more guest instructions (77.5 M instead
/// of 64.3 M: every expansion replayed its whole path).
const STATE_EVERY: u32 = 8;
/// Nodes of the loaded path whose place is marked, at most, so that loading another node's
/// path goes back to where the two paths part and applies the other's nodes after it, instead
/// of loading it from the root (a path deeper than that is loaded from the root when it must
/// be cut back below its end). `load_path` was two fifths of a driverlog expansion natively:
/// the search moves between paths of about 66 nodes that differ in about 3 at their ends. Fewer
/// in a small arena (one node per [`ARENA_WORDS_PER_MARK`] words), never more than the plan's
/// steps. The undo logs of the loaded path's last writers and of its earliest times hold four
/// and a half entries per marked node (a path whose logs run out is loaded from the root when
/// it must be cut back): 13 words per marked node in all, 26 KiB in the target's 8 MiB arena.
const MARKED_DEPTH: usize = 512;
const ARENA_WORDS_PER_MARK: usize = 4096;
/// Words of a node record before its constraint bytes: parent, snap, h and byte count, state
/// hash, next node of its duplicate bucket.
const NODE_HEADER: usize = 5;
/// Preferred-queue pops granted after progress (a new best h) in the first search. Fast
/// Downward grants 1000; on driverlog the successor that makes progress is often not a
/// preferred one, and each new best h then cost the whole boost in preferred pops that lead
/// nowhere (driverlog 4: 23,057 expansions with 1000, 631 with 25).
const BOOST_FIRST: u32 = 25;
/// The boost of the searches after a restart (satellite 20 is solved with 1000 and not with
/// small boosts).
const BOOST_SECOND: u32 = 1000;
/// Expansions without a new best h after which the first search, which orders the preferred
/// list's successors of equal h by how much of the relaxed plan they undo
/// ([`Planner::relaxed_plan_conflicts`]), gives way to the second, which takes them in the
/// order generated, from the root (as if the first had not run). The order cuts the
/// evaluations on satellite by 2 to 5 times and on rovers by about 2, and traps some driverlog
/// searches on plateaus (driverlog 4: 12,616 evaluations where the generated order takes 409);
/// stopping it after 500 expansions without progress keeps those near their cost before
/// (driverlog 4: 790). An ordered search that fills the arena gives way too.
///
/// Only the preferred list is ordered; the regular list keeps the order generated, and the
/// search alternates between the two (as Fast Downward alternates its open lists), so half the
/// pops follow each order. Ordering both lists cost driverlog (2: 993 evaluations, 8: 1,565,
/// 9: 1,060); ordering only the preferred one takes 532, 535 and 510 there, and satellite 15
/// and 19 174 and 158 instead of 383 and 307, every other instance measured the same within 2
/// evaluations. Ordering only the regular list loses satellite's gains (satellite 12: 637
/// instead of 107). The whole portfolio is the same on every target.
pub const ORDERED_RESTART_AFTER: u64 = 500;

/// Expansions without a new best h after which the second search is abandoned and the search
/// restarts from the root with [`BOOST_SECOND`], pruning every repeated state if the
/// configuration asks for [`Duplicates::PruneQuiescent`] (driverlog 12 and 13 are solved that
/// way and not otherwise in 8 MiB). That third search may lose plans that need concurrency,
/// so if it ends without one (its open lists empty, or the arena full), a fourth starts from
/// the root as configured: only the first, the second and the fourth can answer
/// "unsolvable". A small portfolio of configurations, one after the other in the same arena,
/// the same on every target.
pub const RESTART_AFTER: u64 = 3000;

/// The searches of the portfolio (bit p: search p, 0 to 3, and [`NOVELTY_LAST`]) that order
/// their regular open list (the last resort: both lists) by novelty first and h second
/// ([`NoveltyTable`]): the second search and the last resort, chosen by measurement (the README's
/// "A width-based search").
pub const NOVELTY_PHASES: u8 = 1 << 1 | 1 << NOVELTY_LAST;

/// A search that runs only if bit 4 of [`NOVELTY_PHASES`] is set: after the third search
/// (which prunes every repeated state) ends without a plan, a novelty search that prunes as
/// much, before the fourth (as configured).
pub const NOVELTY_LAST: u8 = 4;

/// The searches of the portfolio (bit p: search p, as [`NOVELTY_PHASES`]) that, after
/// [`COMMIT_AFTER`] expansions without a new best h or when the node store is full, go on from
/// their latest node of the lowest h with the path to it committed ([`commit`]): the last
/// resort, chosen by measurement (the README's "Committing to the best node").
pub const COMMIT_PHASES: u8 = 1 << NOVELTY_LAST;

/// Expansions without a new best h after which a search of [`COMMIT_PHASES`] commits to its
/// latest node of the lowest h ([`commit`]).
pub const COMMIT_AFTER: u64 = 5000;

/// Expansions without a new best h after which the third search (every repeated state
/// pruned) gives way to the last resort ([`NOVELTY_LAST`]), as it does when its open lists
/// empty or its store fills: as many as the second search's ([`RESTART_AFTER`]). Driverlog
/// 18's third search stalled 116,000 expansions at h 16 before its plan; the last resort,
/// committing, takes driverlog 16 to 20 to their plans in fewer evaluations (limits of 5,000,
/// 10,000 and 30,000 measured 1 to 40 % dearer; satellite 20's third search, which solves it,
/// stalls at most about 2,300 expansions: the README's "Committing to the best node").
pub const THIRD_GIVES_WAY_AFTER: u64 = RESTART_AFTER;

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
    /// Goal facts left out of the goal: bit i for the task's i-th goal fact (the first 64 can
    /// be dropped; numeric goal conditions always stay). An opportunistic goal that makes
    /// planning fail is dropped this way and planning tried again ([`crate::opportunistic`]).
    pub dropped_goals: u64,
    /// Remove the actions the plan found does not need before reporting it (greedy action
    /// elimination, `eliminate.rs`), in units of [`Planner::step`]'s budget.
    pub eliminate: bool,
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
            dropped_goals: 0,
            eliminate: true,
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
    /// The best h seen (in the search under way: a restart begins again).
    pub best_h: u32,
    /// Snaps applied by lookaheads along relaxed plans ([`LOOKAHEAD_PHASES`]; not expansions).
    pub lookahead_steps: u64,
    /// Times the search restarted from the root with its second configuration (see
    /// [`RESTART_AFTER`]).
    pub restarts: u64,
    /// Actions the elimination after the search removed from the plan found (`eliminate.rs`).
    pub eliminated: u64,
    /// Removals the elimination tried, one unit of [`Planner::step`]'s budget each.
    pub elimination_checks: u64,
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

/// A binary min-heap of three-word entries (key, node, snap) in an arena slice, ordered by
/// the three words in turn: among equal keys, the older parent node (nodes are stored in the
/// order they are made) and then the lower snap first, i.e. first generated first, without a
/// sequence counter that wraps.
struct Heap<'m> {
    words: &'m mut [u32],
    len: usize,
    peak: usize,
}

impl<'m> Heap<'m> {
    /// Whether entry `i` comes before entry `j`.
    #[inline(always)]
    fn less(&self, i: usize, j: usize) -> bool {
        self.words[3 * i..3 * i + 3] < self.words[3 * j..3 * j + 3]
    }
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
            if !self.less(i, p) {
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
        records.sort_unstable();
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
            if l < last && self.less(l, m) {
                m = l;
            }
            if r < last && self.less(r, m) {
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

/// The planner: a task, its arena, and the search in progress.
pub struct Planner<'t, 'm> {
    task: Task<'t>,
    config: PlannerConfig,
    relax: Relaxation<'m>,
    /// Bit per action: compression safe.
    safe: &'m mut [u32],
    /// Bit per action: its end deletes (without adding back) a fact that is some action's
    /// invariant, so it may block another action's end ([`Planner::ends_block_each_other`]
    /// needs two such actions; the start's check skips the rest without decoding them).
    may_block: &'m mut [u32],
    /// Per fact: how many running actions protect it as an invariant (for the current state).
    protect: &'m mut [u32],
    /// Per fact and numeric variable: the last step of the loaded path that wrote it (0: none).
    last_writer: &'m mut [u32],
    /// The loaded path: per step its snap (`action << 1 | is_end`), node ids root..parent.
    path_snap: &'m mut [u32],
    /// The loaded path's step windows (lo, hi per step, two words), set with its snaps
    /// ([`Planner::set_step`]): the STN reads each step's window on every check.
    path_window: &'m mut [u32],
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
    /// What loading another node's path keeps of the loaded one ([`path`]'s
    /// `load_path`): per node of the loaded path (the first [`MARKED_DEPTH`]), four words: the
    /// steps, the constraints, the `last_writer` undo entries and the earliest-time undo
    /// entries there were after it; the undo entries (id or step, value before, two words
    /// each); whether every node after the first marked one logged its undo entries.
    path_marks: &'m mut [u32],
    writer_undo: &'m mut [u32],
    est_undo: &'m mut [u32],
    writer_undo_len: usize,
    est_undo_len: usize,
    truncatable: bool,
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
    boost: u32,
    /// The boost of the search under way ([`BOOST_FIRST`], then [`BOOST_SECOND`]).
    boost_amount: u32,
    /// Expansions when the best h last improved.
    last_progress: u64,
    /// Which search of the portfolio runs (0 to 3, or [`NOVELTY_LAST`]; see
    /// [`ORDERED_RESTART_AFTER`] and [`RESTART_AFTER`]), the repeated
    /// states it prunes, and the shed count when it started.
    phase: u8,
    duplicates: Duplicates,
    shed_base: u64,
    /// [`RESTART_AFTER`] unless set otherwise ([`Planner::set_restart_after`]).
    restart_after: u64,
    /// [`ORDERED_RESTART_AFTER`] unless set otherwise ([`Planner::set_restart_after`]).
    ordered_restart_after: u64,
    turn: bool,
    /// [`NOVELTY_PHASES`] unless set otherwise ([`Planner::set_novelty_phases`]).
    novelty_phases: u8,
    /// Words at the end of the node store that hold the novelty table while a novelty search
    /// runs (0 otherwise): the nodes end before them.
    novelty_words: usize,
    /// [`LOOKAHEAD_PHASES`] unless set otherwise ([`Planner::set_lookahead_phases`]), and the
    /// relaxed plan's snaps a lookahead has still to apply (bit per relaxed action).
    lookahead_phases: u8,
    /// [`LOOKAHEAD_AFTER`] unless set otherwise ([`Planner::set_lookahead_after`]).
    lookahead_after: u64,
    lookahead_todo: &'m mut [u32],
    /// The lookahead under way: its last node ([`NONE`]: none under way), the node it started
    /// from, and the snaps it applied.
    lookahead_node: u32,
    lookahead_origin: u32,
    lookahead_count: u32,
    /// Whether an action of the task has a window (set up with the compression marks): no
    /// lookahead then ([`Planner::windows_in`]).
    task_has_windows: bool,
    /// [`COMMIT_PHASES`], [`COMMIT_AFTER`] and [`THIRD_GIVES_WAY_AFTER`] unless set
    /// otherwise ([`Planner::set_commit`]).
    commit_phases: u8,
    commit_after: u64,
    third_gives_way_after: u64,
    /// [`FIRST_COMMIT_AFTER`] unless set otherwise ([`Planner::set_first_commit_after`]).
    first_commit_after: u64,
    /// The node of the lowest h made last in the search under way, the node it last committed
    /// to (the root at first), and how many commits all searches made ([`commit`]).
    best_node: u32,
    committed_node: u32,
    commits: u64,
    goal_node: u32,
    /// The elimination after the search (`eliminate.rs`).
    elim: eliminate::Elimination,
    /// [`CHECK_RUNNING_ENDS`] unless set otherwise, and the successors it dropped
    /// ([`running_ends`]).
    check_running_ends: RunningEnds,
    late_ends: u64,
    status: Status,
    stats: Stats,
    fact_words: usize,
    /// The next piece of the set-up ([`setup`]).
    set_up: SetUp,
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
        config: PlannerConfig,
    ) -> Result<Self, Region> {
        let mut planner = Self::lay_out(task, arena, config)?;
        while planner.set_up_step() {}
        Ok(planner)
    }

    /// The arena laid out for `task`, nothing set up ([`Self::new_deferred`]).
    fn lay_out(
        task: Task<'t>,
        arena: &'m mut [u32],
        mut config: PlannerConfig,
    ) -> Result<Self, Region> {
        config.max_steps = config.max_steps.clamp(2, MAX_STEPS - 2);
        let arena_words = arena.len();
        let facts = task.fact_count();
        let actions = task.action_count();
        let ids = facts + task.numeric_count();
        let steps = config.max_steps + 3;
        let max_constraints = 8 * steps;
        let sw = state_words(&task);
        let mut rest: &'m mut [u32] = arena;
        let mut used = 0usize;
        // The indexes are filled by the set-up ([`SetUp::Index`]).
        let relax = Relaxation::carve_tables(&task, &mut rest, &mut used).ok_or(Region::Tables)?;
        let mut take = |n: usize| carve(&mut rest, n, &mut used).ok_or(Region::Tables);
        let safe = take(actions.div_ceil(32))?;
        let may_block = take(actions.div_ceil(32))?;
        let protect = take(facts)?;
        let last_writer = take(ids)?;
        let path_snap = take(steps)?;
        let path_window = take(2 * steps)?;
        let path_nodes = take(steps)?;
        let est_parent = take(steps)?;
        let est_child = take(steps)?;
        let path_constraints = take(3 * max_constraints)?;
        let marked = MARKED_DEPTH
            .min(steps)
            .min(arena_words / ARENA_WORDS_PER_MARK);
        let path_marks = take(4 * marked)?;
        let writer_undo = take(2 * 4 * marked)?;
        let est_undo = take(2 * (marked / 2))?;
        let parent_state = take(sw)?;
        let child_state = take(sw)?;
        let probe_state = take(sw)?;
        let lookahead_todo = take((2 * actions).div_ceil(32))?;
        let fixed = used;
        let remaining = rest.len();
        let bucket_count = (remaining / 64).clamp(1024, 1 << 16).next_power_of_two();
        let buckets = carve(&mut rest, bucket_count, &mut used).ok_or(Region::Tables)?;
        let remaining = rest.len();
        let regular = carve(&mut rest, remaining / 4 / 3 * 3, &mut used).ok_or(Region::Tables)?;
        let preferred = carve(&mut rest, remaining / 8 / 3 * 3, &mut used).ok_or(Region::Tables)?;
        let nodes = rest;
        let planner = Self {
            task,
            config,
            relax,
            safe,
            may_block,
            protect,
            last_writer,
            path_snap,
            path_window,
            path_nodes,
            est_parent,
            est_child,
            path_constraints,
            loaded_constraints: 0,
            loaded_steps: 0,
            loaded_depth: 0,
            loaded_node: NONE,
            running_start: [0; MAX_RUNNING],
            path_marks,
            writer_undo,
            est_undo,
            writer_undo_len: 0,
            est_undo_len: 0,
            truncatable: false,
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
            boost: 0,
            last_progress: 0,
            phase: 0,
            duplicates: config.duplicates,
            shed_base: 0,
            restart_after: RESTART_AFTER,
            ordered_restart_after: ORDERED_RESTART_AFTER,
            boost_amount: BOOST_FIRST,
            turn: false,
            novelty_phases: NOVELTY_PHASES,
            novelty_words: 0,
            lookahead_phases: LOOKAHEAD_PHASES,
            lookahead_after: LOOKAHEAD_AFTER,
            lookahead_todo,
            lookahead_node: NONE,
            lookahead_origin: NONE,
            lookahead_count: 0,
            task_has_windows: false,
            commit_phases: COMMIT_PHASES,
            commit_after: COMMIT_AFTER,
            third_gives_way_after: THIRD_GIVES_WAY_AFTER,
            first_commit_after: FIRST_COMMIT_AFTER,
            best_node: NONE,
            committed_node: NONE,
            commits: 0,
            goal_node: NONE,
            elim: eliminate::Elimination::new(),
            check_running_ends: CHECK_RUNNING_ENDS,
            late_ends: 0,
            status: Status::Searching,
            stats: Stats {
                arena_words: arena_words as u64,
                best_h: u32::MAX,
                ..Stats::default()
            },
            fact_words: facts.div_ceil(32),
            set_up: SetUp::Buckets(0),
        };
        let mut planner = planner;
        planner.set_novelty_table();
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
        let used = self.fixed_words
            + self.nodes_used
            + self.novelty_words
            + 3 * self.regular.peak
            + 3 * self.preferred.peak;
        s.peak_words = s.peak_words.max(used as u64);
        s
    }
    /// Restart the first search after `expansions` without a new best h instead of
    /// [`RESTART_AFTER`] (for tests of the portfolio on small tasks).
    pub fn set_restart_after(&mut self, expansions: u64) {
        self.restart_after = expansions;
        self.ordered_restart_after = expansions;
    }
    /// Order the searches of the portfolio in `mask` (bit p: search p) by novelty instead of
    /// [`NOVELTY_PHASES`] (for measuring placements; before the first [`Self::step`] of a
    /// planner made with [`Self::new_deferred`] to cover the first search).
    pub fn set_novelty_phases(&mut self, mask: u8) {
        self.novelty_phases = mask;
        self.set_novelty_table();
    }
    /// Look ahead along the relaxed plan in the searches of `mask` (bit p: search p) instead
    /// of [`LOOKAHEAD_PHASES`] (for measuring placements).
    pub fn set_lookahead_phases(&mut self, mask: u8) {
        self.lookahead_phases = mask;
    }
    /// Look ahead only after `expansions` without a new best h instead of [`LOOKAHEAD_AFTER`]
    /// (for measuring placements).
    pub fn set_lookahead_after(&mut self, expansions: u64) {
        self.lookahead_after = expansions;
    }
    /// Whether the end of `action` may be applied straight after its start without losing plans.
    pub fn compression_safe(&self, action: usize) -> bool {
        self.safe[action / 32] & (1 << (action % 32)) != 0
    }
    /// Whether the end of `action` deletes (without adding back) some action's invariant: only
    /// such actions can block each other's ends, so a start's deadlock check looks no further
    /// for the others.
    pub fn end_may_block(&self, action: usize) -> bool {
        self.may_block(action)
    }
}

impl<'t, 'm> Planner<'t, 'm> {
    // ----- the plan -----------------------------------------------------------------------------

    /// The plan's temporal network (after [`Status::Solved`]): its steps in plan order, the
    /// constraints the search recreated between them (orderings, durations) and the
    /// makespan, for flexible dispatch ([`crate::dispatch::Dispatcher`]).
    pub fn plan_network(&mut self, net: &mut PlanNetwork) -> Result<(), NetworkError> {
        if !self.load_plan() {
            return Err(NetworkError::NoPlan);
        }
        let steps = self.loaded_steps;
        net.clear();
        net.makespan = self.est_parent[..=steps].iter().copied().max().unwrap_or(0);
        for s in 1..=steps {
            let snap = self.path_snap[s];
            net.add_step(PlanStep {
                action: (snap >> 1) as u16,
                end: snap & 1 == 1,
                window: step_window(&self.task, snap),
            })?;
        }
        for i in 0..self.loaded_constraints {
            net.add_constraint(unpack(self.path_constraints, i))?;
        }
        Ok(())
    }

    /// The plan found (after [`Status::Solved`]): actions in order of their starts, written to
    /// `out`; returns how many, or None if there is no plan or `out` is too short.
    pub fn plan(&mut self, out: &mut [PlannedAction]) -> Option<(usize, u32)> {
        if !self.load_plan() {
            return None;
        }
        let steps = self.loaded_steps;
        let makespan = self.est_parent[..=steps].iter().copied().max().unwrap_or(0);
        let wins = &self.path_window;
        let window = |k: usize| (wins[2 * k], wins[2 * k + 1]);
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

#[cfg(test)]
mod tests {
    extern crate std;
    use super::Heap;

    /// The open lists' heap pops entries in the order of a sort by (key, node, snap), with
    /// many equal keys (the search's ties), and after shedding keeps the better half.
    #[test]
    fn heap_pops_in_the_order_of_a_sort_by_all_three_words() {
        let mut seed = 0x0123_4567_89ab_cdefu64;
        let mut next = |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % u64::from(n)) as u32
        };
        for round in 0..50 {
            let mut words = [0u32; 3 * 300];
            let mut heap = Heap {
                words: &mut words,
                len: 0,
                peak: 0,
            };
            let mut all = std::vec::Vec::new();
            let count = 1 + next(300) as usize;
            for _ in 0..count {
                let e = [next(4) << 16 | next(3), next(50), next(20)];
                assert!(heap.push(e[0], e[1], e[2]));
                all.push(e);
            }
            all.sort_unstable();
            if round % 2 == 1 {
                let dropped = heap.shed_worse_half();
                all.truncate(all.len() - dropped);
                assert_eq!(all.len(), count / 2);
            }
            for want in &all {
                let got = heap.pop().map(|(k, n, s)| [k, n, s]);
                assert_eq!(got, Some(*want), "round {round}");
            }
            assert!(heap.pop().is_none());
        }
    }
}
