//! The FF heuristic on the temporal relaxation (seed 001, section 4.2).
//!
//! Each durative action `a` becomes two classical actions: its start (preconditions: the
//! propositional start conditions and the invariants its start does not add; effects: its start
//! adds and the running-action fact `r_a`) and its end (preconditions: its end conditions and
//! `r_a`; effects: its end adds). Costs are unit or durations ([`RelaxedCost`]). Deletes
//! and numbers are ignored. The running actions of the state are facts `r_a` already true.
//! Costs are propagated by a Dijkstra-style additive pass, a relaxed plan is extracted from the
//! best supporters, and the ends of started or running actions missing from it are added.
//! h is the number of actions in that plan; the actions in it that are applicable now are the
//! preferred operators.
//!
//! Relaxed action `2a` is the start of `a`, `2a + 1` its end; fact ids `facts + a` are `r_a`.
use crate::task::{FactList, Task};

/// h of a dead end (the goal is unreachable even relaxed).
pub const DEAD_END: u32 = u32::MAX;

/// Whether bit `i` of a dropped-goals mask is set (goals past the 64th are never dropped).
pub fn goal_dropped(mask: u64, i: usize) -> bool {
    i < 64 && mask & (1 << i) != 0
}

/// What a relaxed snap action costs in the cost propagation that picks best supporters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RelaxedCost {
    /// Every snap action costs 1: supporters that need the fewest actions (FF's h_add with
    /// unit costs). Solves more of the benchmark instances (see the README's table).
    Unit,
    /// A start costs its minimum duration plus epsilon, an end epsilon: supporters that are
    /// reached soonest (the temporal relaxation's time estimate). Shorter makespans, more
    /// expansions.
    Duration,
}

/// Scratch and the precondition index the heuristic needs; all slices come from the arena.
pub struct Relaxation<'m> {
    /// For relaxed fact f, the relaxed actions that have it as a precondition:
    /// `pre_index[pre_offsets[f]..pre_offsets[f + 1]]`.
    pub pre_offsets: &'m mut [u32],
    pub pre_index: &'m mut [u32],
    /// Precondition count of each relaxed action.
    pub pre_count: &'m mut [u32],
    /// For relaxed action r, its relaxed preconditions (each once):
    /// `pre_list[pre_list_offsets[r]..pre_list_offsets[r + 1]]` (the relaxed plan's extraction
    /// reads these instead of decoding action records).
    pub pre_list_offsets: &'m mut [u32],
    pub pre_list: &'m mut [u32],
    /// Relaxed actions without preconditions (they fire at once in every state).
    pub free: &'m mut [u32],
    /// Per relaxed fact: cost (u32::MAX unreached) and best supporter (valid only for facts
    /// the last evaluation reached at a nonzero cost).
    pub cost: &'m mut [u32],
    pub supporter: &'m mut [u32],
    /// Per relaxed action r, four words side by side (one index for all): `waiting[4r]` its
    /// preconditions not yet reached (for a pair, [`PAIR`] over its two facts xored, never
    /// changed) and `waiting[4r + 1]` the sum of their costs, valid if
    /// `waiting[4r + 2]` is this evaluation's `epoch` (else they are `waiting[4r + 3]` and
    /// zero: nothing reached yet), and `waiting[4r + 3]`, for a counted relaxed action, how
    /// many of its relaxed preconditions are facts false in `last_state` ([`NOT_COUNTED`]
    /// for a direct start, a group's other start or an action without preconditions). The
    /// last is kept up to date from the facts that differ between one evaluated state and the
    /// next, so the facts true in the state are never counted one relaxed action at a time,
    /// and the counters are not reset each evaluation (a new epoch voids them): rovers'
    /// `available` and `channel_free` are preconditions of every communicate and hold in
    /// nearly every state (about half the counting was of facts true in the state).
    pub waiting: &'m mut [u32],
    /// The priority queue's storage: a binary heap of (cost, fact) pairs, two words each, from
    /// the front, for costs of [`BUCKETS`] or more; (fact, next) entries of the bucket lists,
    /// two words each, from the back. Every push is one entry of one or the other, and an
    /// evaluation pushes at most once per fact plus once per effect of a relaxed action.
    pub heap: &'m mut [u32],
    /// Heads of the bucket lists of facts by cost (u32::MAX: empty), costs below [`BUCKETS`]:
    /// with unit costs nearly every push lands here, at a constant cost instead of a heap's
    /// logarithmic one (the heap's sifting was most of an evaluation).
    pub buckets: &'m mut [u32],
    /// Relaxed-plan membership of relaxed actions (bitset) and the extraction stack.
    pub marked: &'m mut [u32],
    pub stack: &'m mut [u32],
    /// Bit per fact: a goal.
    pub goal: &'m mut [u32],
    /// For relaxed action r, the relaxed facts it adds: `add_index[add_offsets[r]..add_offsets[r + 1]]`,
    /// and its own cost.
    pub add_offsets: &'m mut [u32],
    pub add_index: &'m mut [u32],
    pub own_cost: &'m mut [u32],
    /// Bit per relaxed action: all its relaxed preconditions hold in the state last evaluated
    /// (it fired at cost zero). Every applicable snap action's relaxed counterpart is set here,
    /// so the search generates successors from these bits instead of testing every action.
    pub ready: &'m mut [u32],
    /// Bit per action: its end's only relaxed precondition is its running-action fact, so
    /// the end fires as soon as its start does, at the start's cost (see
    /// [`Propagation::fire`]), without a trip of that fact through the queue.
    pub end_follows: &'m mut [u32],
    /// For relaxed fact f, where its direct starts end in `pre_index`: the starts whose only
    /// relaxed precondition is f come first in f's list, `pre_index[pre_offsets[f]..
    /// pre_split[f]]`, the other relaxed actions after.
    pub pre_split: &'m mut [u32],
    /// For relaxed fact f, what its direct starts do once f is reached at cost c, flattened:
    /// `direct[3 * direct_offsets[f]..3 * direct_offsets[f + 1]]`, entries of three words
    /// (fact, cost over c, supporter): each start's effects, then its end's if the end follows
    /// (at the start's own cost plus the end's; the supporter is the end, odd), else its
    /// running-action fact. Reaching f relaxes these directly instead of counting, firing and
    /// decoding each start (satellite's turns, nearly all its actions; rovers' calibrations
    /// and drops; driverlog's walks).
    pub direct_offsets: &'m mut [u32],
    pub direct: &'m mut [u32],
    /// Per relaxed action r, four words: where its effects are in `add_index` (from, to; a
    /// start's without its running-action fact), its own cost, and for a start 1 if its end
    /// follows (see `end_follows`): what firing it reads, side by side.
    pub fire_info: &'m mut [u32],
    /// Per action a, three words, read where `2a` leads a group (see [`GROUP`]): the group's
    /// entries in `direct` (from, to: entries of three words, as a direct start's) and how
    /// many starts it has (those of actions a, a + 1, ...). Starts with two or more relaxed
    /// preconditions that follow each other in action order with the same preconditions
    /// (rovers' navigates from one waypoint, one per destination) are counted once, as one
    /// relaxed action, and their effects relaxed from the flattened entries when the group
    /// fires, instead of each start being counted, fired and decoded.
    pub group_info: &'m mut [u32],
    /// Per relaxed fact: how many relaxed actions of the last relaxed plan have it as a
    /// relaxed precondition (counted after the extraction, cleared through the plan's actions
    /// at the next evaluation's start): what [`Self::plan_conflicts`] adds up.
    pub plan_need: &'m mut [u32],
    /// Bit per relaxed action: counted, and all its relaxed preconditions are facts true in
    /// `last_state` (`waiting[4r + 3]` is zero): it fires at cost zero at once.
    pub zero_left: &'m mut [u32],
    /// The facts of the state last evaluated (bitset; all false before the first).
    pub last_state: &'m mut [u32],
    /// This evaluation's number: counters stamped with another are void (see `waiting`).
    pub epoch: u32,
}

/// Set in `Relaxation::waiting[4r]` of a counted relaxed action with exactly two relaxed
/// preconditions (a pair), over the two facts' ids xored: a pair is not counted, it fires
/// when the later of its two facts is reached (see [`Propagation::reach`]; driverlog's
/// load, unload, drive and disembark starts, most of its counting).
pub const PAIR: u32 = 1 << 31;

/// `Relaxation::waiting[4r + 3]` of a relaxed action that is not counted (never zero, never reached by
/// the updates).
pub const NOT_COUNTED: u32 = 1 << 30;

/// Set on a `pre_index` entry that is a group of starts (see [`Relaxation::group_info`]):
/// the rest is the group's first start, whose counter the group uses.
pub const GROUP: u32 = 1 << 31;

/// Costs with a bucket of their own in the heuristic's queue (larger ones go to a heap).
pub const BUCKETS: usize = 1024;

/// The heuristic's queue during one evaluation: Dial's buckets for small costs, a binary heap
/// above them, in the relaxation's `heap` and `buckets` words. Pops come in nondecreasing cost
/// (every relaxed action costs at least one), so the buckets are taken in order from `cur`.
///
/// The propagation works on local slices (this queue and [`Propagation`]) rather than through
/// `&mut self`: the compiler then keeps their addresses and lengths in registers instead of
/// loading them again after every store (about a third of an evaluation's instructions on the
/// PowerPC 750).
struct Queue<'a> {
    heap: &'a mut [u32],
    buckets: &'a mut [u32],
    heap_len: usize,
    entries: usize,
    cur: usize,
    max_bucket: usize,
}

impl Queue<'_> {
    #[inline(always)]
    fn push(&mut self, cost: u32, fact: u32) {
        let c = cost as usize;
        if c < BUCKETS {
            self.entries += 1;
            let at = self.heap.len() - 2 * self.entries;
            self.heap[at] = fact;
            self.heap[at + 1] = self.buckets[c];
            self.buckets[c] = at as u32;
            self.max_bucket = self.max_bucket.max(c);
        } else {
            self.heap_push(cost, fact);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, u32)> {
        while self.cur < BUCKETS {
            let head = self.buckets[self.cur];
            if head != u32::MAX {
                let at = head as usize;
                self.buckets[self.cur] = self.heap[at + 1];
                return Some((self.cur as u32, self.heap[at]));
            }
            self.cur += 1;
        }
        self.heap_pop()
    }

    fn heap_push(&mut self, cost: u32, fact: u32) {
        let heap = &mut *self.heap;
        let mut i = self.heap_len;
        self.heap_len += 1;
        heap[2 * i] = cost;
        heap[2 * i + 1] = fact;
        while i > 0 {
            let parent = (i - 1) / 2;
            if heap[2 * parent] <= heap[2 * i] {
                break;
            }
            heap.swap(2 * parent, 2 * i);
            heap.swap(2 * parent + 1, 2 * i + 1);
            i = parent;
        }
    }

    fn heap_pop(&mut self) -> Option<(u32, u32)> {
        if self.heap_len == 0 {
            return None;
        }
        let heap = &mut *self.heap;
        let top = (heap[0], heap[1]);
        self.heap_len -= 1;
        let last = self.heap_len;
        heap[0] = heap[2 * last];
        heap[1] = heap[2 * last + 1];
        let mut i = 0;
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut m = i;
            if l < last && heap[2 * l] < heap[2 * m] {
                m = l;
            }
            if r < last && heap[2 * r] < heap[2 * m] {
                m = r;
            }
            if m == i {
                break;
            }
            heap.swap(2 * m, 2 * i);
            heap.swap(2 * m + 1, 2 * i + 1);
            i = m;
        }
        Some(top)
    }
}

/// The tables one evaluation's cost propagation reads and writes, as local slices (see
/// [`Queue`]).
struct Propagation<'a> {
    pre_offsets: &'a [u32],
    pre_index: &'a [u32],
    add_index: &'a [u32],
    cost: &'a mut [u32],
    supporter: &'a mut [u32],
    /// Per relaxed action: (preconditions not yet reached, the sum of their costs).
    counts: &'a mut [[u32; 4]],
    /// This evaluation's epoch (see [`Relaxation::waiting`]).
    epoch: u32,
    ready: &'a mut [u32],
    /// Per relaxed action: its effects' range in `add_index` (a start's without its
    /// running-action fact), its own cost, and (starts) whether its end follows.
    fire_info: &'a [[u32; 4]],
    pre_split: &'a [u32],
    direct_offsets: &'a [u32],
    direct: &'a [u32],
    /// Per action: a group's entries in `direct` and its number of starts (see
    /// [`Relaxation::group_info`]).
    group_info: &'a [[u32; 3]],
    /// The first running-action fact (the task's fact count).
    facts: usize,
}

impl Propagation<'_> {
    /// Relaxed action `r` fires with `sum`, the sum of its preconditions' costs: its effects
    /// get its cost if that is cheaper, or the same cost from a lower-numbered supporter.
    ///
    /// A start's running-action fact (its last effect in the table) is its own case: the start
    /// is that fact's only achiever and fires once an evaluation. A start whose end needs
    /// nothing but the action running (an `end_follows` action) fires that end at once, at the
    /// start's cost plus the end's own, instead of sending the fact through the queue, and
    /// leaves the fact's cost and supporter alone: the relaxed plan's extraction knows the
    /// fact's supporter (the start) without them. The order differs from the queue's, the
    /// outcome does not: every fact of cost at most the last goal's still has its final cost
    /// and supporter when the propagation stops.
    #[inline(always)]
    fn fire(&mut self, r: usize, sum: u32, q: &mut Queue<'_>) {
        let [lo, hi, own, follows] = self.fire_info[r];
        let c = sum.saturating_add(own);
        self.effects(r, c, lo as usize, hi as usize, q);
        if !r.is_multiple_of(2) {
            return;
        }
        let f = self.facts + r / 2;
        // The action runs in the state (the fact's cost is zero, its end fired already from
        // it), or the start reaches the fact now, for the only time.
        if c < self.cost[f] {
            if follows != 0 {
                let e = r + 1;
                if c == 0 {
                    self.ready[e / 32] |= 1 << (e % 32);
                }
                let [lo, hi, own, _] = self.fire_info[e];
                self.effects(e, c.saturating_add(own), lo as usize, hi as usize, q);
            } else {
                q.push(c, f as u32);
                self.cost[f] = c;
            }
        }
    }

    /// Relaxed action `r`'s effects `add_index[lo..hi]` at cost `c`.
    #[inline(always)]
    fn effects(&mut self, r: usize, c: u32, lo: usize, hi: usize, q: &mut Queue<'_>) {
        for &f in &self.add_index[lo..hi] {
            let f = f as usize;
            let old = self.cost[f];
            // The cheapest achiever, the lowest-numbered among equals: the same supporter
            // whatever order the queue takes equal costs in.
            if c < old || (c == old && c != u32::MAX && (r as u32) < self.supporter[f]) {
                if c < old {
                    q.push(c, f as u32);
                }
                self.cost[f] = c;
                self.supporter[f] = r as u32;
            }
        }
    }

    /// Fact `f` reached at cost `c`: each relaxed action it is a precondition of counts it,
    /// and fires when its last precondition is reached (its count is not written back then:
    /// nothing reads it again this evaluation).
    ///
    /// The starts whose only precondition is f (its direct starts) are not counted: their
    /// effects, and their ends' where the end follows, are relaxed from f's `direct` entries,
    /// as [`Self::fire`] would (also the end of an action running in the state: its effects
    /// got their costs from the running-action fact first, see [`Relaxation::evaluate`], and
    /// relaxing them again changes nothing).
    #[inline(always)]
    fn reach(&mut self, f: usize, c: u32, q: &mut Queue<'_>) {
        self.reach_direct(f, c, q);
        let (split, hi) = (self.pre_split[f] as usize, self.pre_offsets[f + 1] as usize);
        for &r in &self.pre_index[split..hi] {
            let i = (r & !GROUP) as usize;
            let [waiting, sum, epoch, left] = self.counts[i];
            if waiting & PAIR != 0 {
                // Two preconditions, f and g: no count. The pair fires once, when the later of
                // the two (by cost, then by id) is reached; the other's cost is final then
                // (every relaxed action costs at least one, so facts of cost c have theirs
                // before the first of them is taken), and a g of cost zero holds in the state
                // (or is an action running in it, reached first).
                let g = ((waiting & !PAIR) as usize) ^ f;
                let cg = self.cost[g];
                if cg < c || (cg == c && g < f) {
                    let sum = c.saturating_add(cg);
                    if r & GROUP != 0 {
                        self.fire_group(i, sum, q);
                    } else {
                        if sum == 0 {
                            self.ready[i / 32] |= 1 << (i % 32);
                        }
                        self.fire(i, sum, q);
                    }
                }
                continue;
            }
            let (waiting, sum) = if epoch == self.epoch {
                (waiting, sum)
            } else {
                (left, 0)
            };
            let sum = sum.saturating_add(c);
            if waiting > 1 {
                self.counts[i] = [waiting - 1, sum, self.epoch, left];
                continue;
            }
            if r & GROUP != 0 {
                self.fire_group(i, sum, q);
                continue;
            }
            if sum == 0 {
                self.ready[i / 32] |= 1 << (i % 32);
            }
            self.fire(i, sum, q);
        }
    }

    /// What fact `f` reached at cost `c` does through its direct starts (see [`Self::reach`]).
    #[inline(always)]
    fn reach_direct(&mut self, f: usize, c: u32, q: &mut Queue<'_>) {
        let (lo, split) = (self.pre_offsets[f] as usize, self.pre_split[f] as usize);
        if c == 0 {
            // Direct starts ready in the state, and the ends that fire at cost zero with them.
            for &r in &self.pre_index[lo..split] {
                let r = r as usize;
                self.ready[r / 32] |= 1 << (r % 32);
                let [_, _, own, follows] = self.fire_info[r];
                if own == 0 && follows != 0 {
                    let e = r + 1;
                    self.ready[e / 32] |= 1 << (e % 32);
                }
            }
        }
        let (dlo, dhi) = (
            3 * self.direct_offsets[f] as usize,
            3 * self.direct_offsets[f + 1] as usize,
        );
        let (entries, _) = self.direct[dlo..dhi].as_chunks::<3>();
        for &[g, delta, r] in entries {
            let g = g as usize;
            let cg = c.saturating_add(delta);
            let old = self.cost[g];
            if cg < old || (cg == old && cg != u32::MAX && r < self.supporter[g]) {
                if cg < old {
                    q.push(cg, g as u32);
                }
                self.cost[g] = cg;
                self.supporter[g] = r;
            }
        }
    }

    /// The group of starts led by start `r0` fires with `sum`, its preconditions' cost sum:
    /// each start fires as [`Self::fire`] would fire it, from the group's flattened entries
    /// (an action running in the state: as for a direct start in [`Self::reach`]).
    #[inline(always)]
    fn fire_group(&mut self, r0: usize, sum: u32, q: &mut Queue<'_>) {
        let [lo, hi, n] = self.group_info[r0 / 2];
        if sum == 0 {
            for r in (r0..r0 + 2 * n as usize).step_by(2) {
                self.ready[r / 32] |= 1 << (r % 32);
                let [_, _, own, follows] = self.fire_info[r];
                if own == 0 && follows != 0 {
                    let e = r + 1;
                    self.ready[e / 32] |= 1 << (e % 32);
                }
            }
        }
        let (entries, _) = self.direct[3 * lo as usize..3 * hi as usize].as_chunks::<3>();
        for &[g, delta, r] in entries {
            let g = g as usize;
            let cg = sum.saturating_add(delta);
            let old = self.cost[g];
            if cg < old || (cg == old && cg != u32::MAX && r < self.supporter[g]) {
                if cg < old {
                    q.push(cg, g as u32);
                }
                self.cost[g] = cg;
                self.supporter[g] = r;
            }
        }
    }
}

/// Take `n` words off the front of `rest`, counting them in `used`.
pub fn carve<'m>(rest: &mut &'m mut [u32], n: usize, used: &mut usize) -> Option<&'m mut [u32]> {
    if n > rest.len() {
        return None;
    }
    let (head, tail) = core::mem::take(rest).split_at_mut(n);
    *rest = tail;
    *used += n;
    Some(head)
}

/// Words of arena the effect table needs: (offsets, entries).
pub fn add_words(task: &Task<'_>) -> (usize, usize) {
    let mut entries = 0;
    for a in 0..task.action_count() {
        let act = task.action(a);
        entries += act.facts(FactList::AddStart).len() + act.facts(FactList::AddEnd).len() + 1;
    }
    (2 * task.action_count() + 1, entries)
}

/// Words of arena the index needs for `task`: (offsets, entries, per-action counts).
pub fn index_words(task: &Task<'_>) -> (usize, usize, usize) {
    let facts = task.fact_count() + task.action_count();
    let mut entries = 0;
    for a in 0..task.action_count() {
        let act = task.action(a);
        let add_start = act.facts(FactList::AddStart);
        entries += act.facts(FactList::PreStart).len()
            + act
                .facts(FactList::Invariant)
                .iter()
                .filter(|&f| !add_start.contains(f))
                .count()
            + act.facts(FactList::PreEnd).len()
            + 1;
    }
    (facts + 1, entries, 2 * task.action_count())
}

/// The relaxed preconditions of relaxed action `r`, each once.
fn for_each_pre(task: &Task<'_>, r: usize, f: &mut dyn FnMut(usize)) {
    let a = r / 2;
    let act = task.action(a);
    if r.is_multiple_of(2) {
        let pre = act.facts(FactList::PreStart);
        let add = act.facts(FactList::AddStart);
        let inv = act.facts(FactList::Invariant);
        for (i, p) in pre.iter().enumerate() {
            if !(0..i).any(|j| pre.get(j) as usize == p) {
                f(p);
            }
        }
        for (i, p) in inv.iter().enumerate() {
            if !add.contains(p) && !pre.contains(p) && !(0..i).any(|j| inv.get(j) as usize == p) {
                f(p);
            }
        }
    } else {
        let pre = act.facts(FactList::PreEnd);
        for (i, p) in pre.iter().enumerate() {
            if !(0..i).any(|j| pre.get(j) as usize == p) {
                f(p);
            }
        }
        f(task.fact_count() + a);
    }
}

/// Relaxed actions without relaxed preconditions (starts with no conditions at all).
pub fn free_words(task: &Task<'_>) -> usize {
    (0..2 * task.action_count())
        .filter(|&r| {
            let mut n = 0;
            for_each_pre(task, r, &mut |_| n += 1);
            n == 0
        })
        .count()
}

impl<'m> Relaxation<'m> {
    /// Carve the heuristic's tables and scratch for `task` off the front of `rest` (counting
    /// the words in `used`) and fill the indexes: once per task. None if `rest` is too small.
    pub fn new(
        task: &Task<'_>,
        rest: &mut &'m mut [u32],
        used: &mut usize,
        costs: RelaxedCost,
        dropped_goals: u64,
    ) -> Option<Self> {
        let mut relax = Self::carve_tables(task, rest, used)?;
        relax.build_index(task, costs, dropped_goals);
        Some(relax)
    }

    /// [`Self::new`] without filling the indexes: the search's set-up fills them as a piece of
    /// its own ([`Self::build_index`]), so that a planner partition can spread it over windows.
    pub(crate) fn carve_tables(
        task: &Task<'_>,
        rest: &mut &'m mut [u32],
        used: &mut usize,
    ) -> Option<Self> {
        let facts = task.fact_count();
        let all = facts + task.action_count();
        let relaxed = 2 * task.action_count();
        let (offsets_n, entries_n, _) = index_words(task);
        let (add_offsets_n, add_entries_n) = add_words(task);
        let free_n = free_words(task);
        let mut take = |n: usize| carve(rest, n, used);
        let relax = Relaxation {
            pre_offsets: take(offsets_n)?,
            pre_index: take(entries_n)?,
            pre_count: take(relaxed)?,
            pre_list_offsets: take(relaxed + 1)?,
            pre_list: take(entries_n)?,
            free: take(free_n)?,
            cost: take(all.max(offsets_n))?,
            supporter: take(all)?,
            waiting: take(4 * relaxed)?,
            heap: take(2 * (all + add_entries_n + 1))?,
            buckets: take(BUCKETS)?,
            marked: take(relaxed.div_ceil(32))?,
            stack: take(entries_n + task.goal_facts().len() + 1)?,
            goal: take(facts.div_ceil(32))?,
            add_offsets: take(add_offsets_n)?,
            add_index: take(add_entries_n)?,
            own_cost: take(relaxed)?,
            ready: take(relaxed.div_ceil(32))?,
            end_follows: take(task.action_count().div_ceil(32))?,
            pre_split: take(all)?,
            direct_offsets: take(all + 1)?,
            direct: take(3 * add_entries_n)?,
            fire_info: take(4 * relaxed)?,
            group_info: take(3 * task.action_count())?,
            plan_need: take(all)?,
            zero_left: take(relaxed.div_ceil(32))?,
            last_state: take(facts.div_ceil(32))?,
            epoch: 1,
        };
        relax.buckets.iter_mut().for_each(|b| *b = u32::MAX);
        relax.marked.iter_mut().for_each(|x| *x = 0);
        relax.plan_need.iter_mut().for_each(|x| *x = 0);
        Some(relax)
    }

    /// Fill the precondition index and the effect table (once, when the planner starts).
    /// `dropped_goals`: bit i set leaves the task's i-th goal fact out of the goal (see
    /// [`crate::PlannerConfig::dropped_goals`]).
    pub(crate) fn build_index(&mut self, task: &Task<'_>, costs: RelaxedCost, dropped_goals: u64) {
        let facts = task.fact_count() + task.action_count();
        self.pre_offsets.iter_mut().for_each(|x| *x = 0);
        let mut at = 0usize;
        let mut free = 0usize;
        for r in 0..2 * task.action_count() {
            let mut n = 0;
            self.pre_list_offsets[r] = at as u32;
            for_each_pre(task, r, &mut |p| {
                self.pre_list[at] = p as u32;
                at += 1;
                n += 1;
            });
            self.pre_count[r] = n;
            if n == 0 {
                self.free[free] = r as u32;
                free += 1;
            }
        }
        self.pre_list_offsets[2 * task.action_count()] = at as u32;
        self.end_follows.iter_mut().for_each(|x| *x = 0);
        for a in 0..task.action_count() {
            let (lo, hi) = (
                self.pre_list_offsets[2 * a + 1] as usize,
                self.pre_list_offsets[2 * a + 2] as usize,
            );
            if hi == lo + 1 && self.pre_list[lo] as usize == task.fact_count() + a {
                self.end_follows[a / 32] |= 1 << (a % 32);
            }
        }
        // Groups: runs of starts of consecutive actions with the same two or more relaxed
        // preconditions (in the same order). The first start of a run leads it
        // (`group_info`'s count is the run's length); the others have a count of zero and are
        // left out of the precondition index.
        let mut leader = usize::MAX;
        for a in 0..task.action_count() {
            self.group_info[3 * a + 2] = 0;
            let r = 2 * a;
            if self.pre_count[r] < 2 {
                leader = usize::MAX;
                continue;
            }
            if leader != usize::MAX && self.preconditions(2 * leader) == self.preconditions(r) {
                self.group_info[3 * leader + 2] += 1;
            } else {
                leader = a;
                self.group_info[3 * a + 2] = 1;
            }
        }
        for r in 0..2 * task.action_count() {
            if self.is_group_member(r) {
                continue;
            }
            let (lo, hi) = (
                self.pre_list_offsets[r] as usize,
                self.pre_list_offsets[r + 1] as usize,
            );
            for i in lo..hi {
                self.pre_offsets[self.pre_list[i] as usize + 1] += 1;
            }
        }
        for f in 0..facts {
            self.pre_offsets[f + 1] += self.pre_offsets[f];
        }
        let eps = task.epsilon();
        let mut at = 0usize;
        for a in 0..task.action_count() {
            let act = task.action(a);
            for (r, list) in [(2 * a, FactList::AddStart), (2 * a + 1, FactList::AddEnd)] {
                self.add_offsets[r] = at as u32;
                for f in act.facts(list).iter() {
                    self.add_index[at] = f as u32;
                    at += 1;
                }
                if r.is_multiple_of(2) {
                    self.add_index[at] = (task.fact_count() + a) as u32;
                    at += 1;
                    self.own_cost[r] = match costs {
                        RelaxedCost::Unit => 1,
                        RelaxedCost::Duration => act.duration_lb.saturating_add(eps),
                    };
                } else {
                    self.own_cost[r] = match costs {
                        RelaxedCost::Unit => 1,
                        RelaxedCost::Duration => eps,
                    };
                }
            }
        }
        self.add_offsets[2 * task.action_count()] = at as u32;
        self.goal.iter_mut().for_each(|x| *x = 0);
        for (i, g) in task.goal_facts().iter().enumerate() {
            if !goal_dropped(dropped_goals, i) {
                self.goal[g / 32] |= 1 << (g % 32);
            }
        }
        for r in 0..2 * task.action_count() {
            let start = r.is_multiple_of(2);
            let a = r / 2;
            let follows = start && self.end_follows[a / 32] & (1 << (a % 32)) != 0;
            self.fire_info[4 * r..4 * r + 4].copy_from_slice(&[
                self.add_offsets[r],
                self.add_offsets[r + 1] - u32::from(start),
                self.own_cost[r],
                u32::from(follows),
            ]);
        }
        // Fill using `cost` as the per-fact insertion cursor: each fact's direct starts
        // first, then the other relaxed actions.
        for f in 0..facts {
            self.cost[f] = self.pre_offsets[f];
        }
        for direct_pass in [true, false] {
            for r in 0..2 * task.action_count() {
                if self.is_direct(r) != direct_pass || self.is_group_member(r) {
                    continue;
                }
                let id = if self.is_group_leader(r) {
                    r as u32 | GROUP
                } else {
                    r as u32
                };
                let (lo, hi) = (
                    self.pre_list_offsets[r] as usize,
                    self.pre_list_offsets[r + 1] as usize,
                );
                for i in lo..hi {
                    let p = self.pre_list[i] as usize;
                    let at = self.cost[p] as usize;
                    self.pre_index[at] = id;
                    self.cost[p] += 1;
                }
            }
            if direct_pass {
                for f in 0..facts {
                    self.pre_split[f] = self.cost[f];
                }
            }
        }
        // The direct starts' entries, fact by fact.
        let mut at = 0usize;
        for f in 0..facts {
            self.direct_offsets[f] = at as u32;
            let (lo, split) = (self.pre_offsets[f] as usize, self.pre_split[f] as usize);
            for i in lo..split {
                let r = self.pre_index[i] as usize;
                at = self.start_entries(task, r, at);
            }
        }
        self.direct_offsets[facts] = at as u32;
        // The groups' entries, after the facts'.
        for a in 0..task.action_count() {
            if !self.is_group_leader(2 * a) {
                continue;
            }
            let n = self.group_info[3 * a + 2] as usize;
            self.group_info[3 * a] = at as u32;
            for b in a..a + n {
                at = self.start_entries(task, 2 * b, at);
            }
            self.group_info[3 * a + 1] = at as u32;
        }
        // Every fact false in the (empty) state last evaluated.
        self.last_state.iter_mut().for_each(|x| *x = 0);
        self.zero_left.iter_mut().for_each(|x| *x = 0);
        self.epoch = 1;
        for r in 0..2 * task.action_count() {
            let left = if self.pre_count[r] == 0 || self.is_direct(r) || self.is_group_member(r) {
                NOT_COUNTED
            } else {
                self.pre_count[r]
            };
            let pair = match self.preconditions(r) {
                &[f, g] if left != NOT_COUNTED => PAIR | (f ^ g),
                _ => 0,
            };
            self.waiting[4 * r..4 * r + 4].copy_from_slice(&[pair, 0, 0, left]);
        }
    }

    /// Write start `r`'s entries for `direct` from entry `at` on (its effects but its
    /// running-action fact, then its end's if the end follows, else the running-action fact:
    /// see [`Self::direct`]); returns the next free entry.
    fn start_entries(&mut self, task: &Task<'_>, r: usize, mut at: usize) -> usize {
        let a = r / 2;
        let own = self.own_cost[r];
        // The start's effects but its running-action fact (its last).
        let (slo, shi) = (
            self.add_offsets[r] as usize,
            self.add_offsets[r + 1] as usize - 1,
        );
        for k in slo..shi {
            self.direct[3 * at..3 * at + 3].copy_from_slice(&[self.add_index[k], own, r as u32]);
            at += 1;
        }
        if self.end_follows[a / 32] & (1 << (a % 32)) != 0 {
            let e = r + 1;
            let both = own.saturating_add(self.own_cost[e]);
            let (elo, ehi) = (
                self.add_offsets[e] as usize,
                self.add_offsets[e + 1] as usize,
            );
            for k in elo..ehi {
                self.direct[3 * at..3 * at + 3].copy_from_slice(&[
                    self.add_index[k],
                    both,
                    e as u32,
                ]);
                at += 1;
            }
        } else {
            self.direct[3 * at..3 * at + 3].copy_from_slice(&[
                (task.fact_count() + a) as u32,
                own,
                r as u32,
            ]);
            at += 1;
        }
        at
    }

    /// Whether relaxed action `r` is the first start of a group (see [`GROUP`]).
    fn is_group_leader(&self, r: usize) -> bool {
        r.is_multiple_of(2) && self.pre_count[r] >= 2 && self.group_info[3 * (r / 2) + 2] > 0
    }

    /// Whether relaxed action `r` is a start of a group other than its first.
    fn is_group_member(&self, r: usize) -> bool {
        r.is_multiple_of(2) && self.pre_count[r] >= 2 && self.group_info[3 * (r / 2) + 2] == 0
    }

    /// Whether relaxed action `r` is a start with one relaxed precondition (a direct start of
    /// that fact: see [`Self::direct`]).
    fn is_direct(&self, r: usize) -> bool {
        r.is_multiple_of(2) && self.pre_count[r] == 1
    }

    /// The relaxed preconditions of relaxed action `r`, each once.
    pub fn preconditions(&self, r: usize) -> &[u32] {
        let (lo, hi) = (
            self.pre_list_offsets[r] as usize,
            self.pre_list_offsets[r + 1] as usize,
        );
        &self.pre_list[lo..hi]
    }

    /// Whether relaxed action `r`'s relaxed preconditions all held in the state last evaluated.
    pub fn is_ready(&self, r: usize) -> bool {
        self.ready[r / 32] & (1 << (r % 32)) != 0
    }

    /// How many (deleted fact, relaxed-plan action) pairs there are: for each fact of
    /// `deletes` (repeats counted), the relaxed actions of the last relaxed plan that have it
    /// as a relaxed precondition, other than action `a`'s own start and end. How much of the
    /// relaxed plan a snap of `a` with those deletes undoes (the search's successor order).
    pub fn plan_conflicts(&self, a: usize, deletes: impl Iterator<Item = usize>) -> u32 {
        let mut n = 0u32;
        for f in deletes {
            n += self.plan_need[f];
            // Less `a`'s own start and end where they are in the plan and need f.
            for r in [2 * a, 2 * a + 1] {
                if self.in_relaxed_plan(r) && self.preconditions(r).contains(&(f as u32)) {
                    n -= 1;
                }
            }
        }
        n
    }

    /// Add (`up`) or clear the relaxed plan's actions' preconditions in `plan_need`.
    fn count_plan_needs(&mut self, up: bool) {
        for (w, &bits) in self.marked.iter().enumerate() {
            let mut bits = bits;
            while bits != 0 {
                let r = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (lo, hi) = (
                    self.pre_list_offsets[r] as usize,
                    self.pre_list_offsets[r + 1] as usize,
                );
                for &p in &self.pre_list[lo..hi] {
                    let need = &mut self.plan_need[p as usize];
                    *need = if up { *need + 1 } else { 0 };
                }
            }
        }
    }

    /// Whether relaxed action `r` is in the last relaxed plan.
    pub fn in_relaxed_plan(&self, r: usize) -> bool {
        self.marked[r / 32] & (1 << (r % 32)) != 0
    }

    /// h for the state whose true facts are the bitset `fact_bits` (fact f is bit f % 32 of
    /// word f / 32) and running actions `running`; marks the relaxed plan (see
    /// [`Self::in_relaxed_plan`]) and the relaxed actions ready in the state (see
    /// [`Self::is_ready`]). [`DEAD_END`] if the goal is unreachable.
    ///
    /// Costs are propagated Dijkstra-style with a counter per relaxed action (its
    /// preconditions not yet reached): an action fires when its counter reaches zero, so the
    /// work is the precondition-index entries of the facts reached, never a scan of every
    /// action. A fact's best supporter is its cheapest achiever, the lowest-numbered among
    /// equals (the same in every evaluation order).
    pub fn evaluate(&mut self, task: &Task<'_>, fact_bits: &[u32], running: &[u32]) -> u32 {
        let facts = task.fact_count();
        let all = facts + task.action_count();
        let relaxed = 2 * task.action_count();
        self.count_plan_needs(false);
        self.cost[..all].iter_mut().for_each(|x| *x = u32::MAX);
        // `supporter` is not cleared: it is read only for facts of nonzero finite cost, and
        // those got theirs in this evaluation (when their cost was set).
        // The counted relaxed actions' preconditions false in this state, from the last
        // state's by the facts that changed.
        for (w, (&bits, last)) in fact_bits.iter().zip(self.last_state.iter_mut()).enumerate() {
            let mut now = bits;
            if 32 * (w + 1) > facts {
                now &= (1u32 << (facts % 32)) - 1;
            }
            let mut changed = now ^ *last;
            *last = now;
            while changed != 0 {
                let b = changed.trailing_zeros();
                changed &= changed - 1;
                let f = 32 * w + b as usize;
                let (split, hi) = (self.pre_split[f] as usize, self.pre_offsets[f + 1] as usize);
                let now_true = now & (1 << b) != 0;
                for &r in &self.pre_index[split..hi] {
                    let i = (r & !GROUP) as usize;
                    let left = &mut self.waiting[4 * i + 3];
                    if now_true {
                        *left -= 1;
                        if *left == 0 {
                            self.zero_left[i / 32] |= 1 << (i % 32);
                        }
                    } else {
                        if *left == 0 {
                            self.zero_left[i / 32] &= !(1 << (i % 32));
                        }
                        *left += 1;
                    }
                }
            }
        }
        // A new epoch voids every counter (after 2^32 - 1 evaluations, stamp them all void).
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            for r in 0..relaxed {
                self.waiting[4 * r + 2] = 0;
            }
            self.epoch = 1;
        }
        let (counts, _) = self.waiting[..4 * relaxed].as_chunks_mut::<4>();
        self.marked.iter_mut().for_each(|x| *x = 0);
        self.ready.iter_mut().for_each(|x| *x = 0);
        let mut q = Queue {
            heap: &mut *self.heap,
            buckets: &mut *self.buckets,
            heap_len: 0,
            entries: 0,
            cur: 0,
            max_bucket: 0,
        };
        let mut prop = Propagation {
            pre_offsets: &*self.pre_offsets,
            pre_index: &*self.pre_index,
            add_index: &*self.add_index,
            cost: &mut *self.cost,
            supporter: &mut *self.supporter,
            counts,
            epoch: self.epoch,
            ready: &mut *self.ready,
            fire_info: self.fire_info[..4 * relaxed].as_chunks::<4>().0,
            pre_split: &*self.pre_split,
            direct_offsets: &*self.direct_offsets,
            direct: &*self.direct,
            group_info: self.group_info[..3 * task.action_count()]
                .as_chunks::<3>()
                .0,
            facts,
        };
        for (w, &bits) in fact_bits.iter().enumerate().take(facts.div_ceil(32)) {
            let mut bits = bits;
            while bits != 0 {
                let f = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if f < facts {
                    prop.cost[f] = 0;
                }
            }
        }
        // The running actions' facts are reached first, before anything is taken from the
        // queue: their ends fire now, so when a direct start later relaxes the end of a
        // running action (`reach` does not look whether it runs), the end's effects have
        // their costs from the running-action fact already, at most the start's path's, with
        // the same supporter: nothing changes and nothing is pushed (every relaxed action's
        // effects are pushed at most once, the queue's bound).
        for &a in running {
            prop.cost[facts + a as usize] = 0;
        }
        for &a in running {
            prop.reach(facts + a as usize, 0, &mut q);
        }
        // The facts true in the state: their direct starts (counted relaxed actions count
        // only the facts false in the state, see `left`).
        for (w, &bits) in fact_bits.iter().enumerate().take(facts.div_ceil(32)) {
            let mut bits = bits;
            while bits != 0 {
                let f = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if f < facts {
                    prop.reach_direct(f, 0, &mut q);
                }
            }
        }
        // The counted relaxed actions whose preconditions all hold.
        for (w, &bits) in self.zero_left.iter().enumerate() {
            let mut bits = bits;
            while bits != 0 {
                let r = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if r.is_multiple_of(2) && self.group_info[3 * (r / 2) + 2] > 0 {
                    prop.fire_group(r, 0, &mut q);
                } else {
                    prop.ready[r / 32] |= 1 << (r % 32);
                    prop.fire(r, 0, &mut q);
                }
            }
        }
        // Relaxed actions without preconditions fire at once.
        for &r in self.free.iter() {
            let r = r as usize;
            prop.ready[r / 32] |= 1 << (r % 32);
            prop.fire(r, 0, &mut q);
        }
        let goals = task.goal_facts();
        let is_goal = |goal: &[u32], g: usize| goal[g / 32] & (1 << (g % 32)) != 0;
        let goal = &*self.goal;
        // Distinct goal facts not yet true.
        let mut goals_left = 0;
        for (w, &bits) in goal.iter().enumerate() {
            let mut bits = bits;
            while bits != 0 {
                let f = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if prop.cost[f] != 0 {
                    goals_left += 1;
                }
            }
        }
        let mut level = 0;
        while let Some((c, f)) = q.pop() {
            let f = f as usize;
            if c > prop.cost[f] {
                continue;
            }
            // The first fact taken at a new cost c: every fact of cost below c was taken and
            // fired its relaxed actions, so every fact of cost c has its final cost and
            // supporter (what fires from here on adds c + 1 or more). If every goal not yet
            // taken costs c, nothing taken from here on changes h, the relaxed plan or the
            // ready set: stop (the facts of the last goal's cost were taken before for
            // nothing, up to the goal).
            if c != level {
                level = c;
                let mut at_level = 0;
                for (w, &bits) in goal.iter().enumerate() {
                    let mut bits = bits;
                    while bits != 0 {
                        let g = 32 * w + bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        if prop.cost[g] == c {
                            at_level += 1;
                        }
                    }
                }
                if at_level == goals_left {
                    break;
                }
            }
            // Every fact of cost zero is taken before any other (every relaxed action costs
            // at least one), so stopping at the last goal never cuts the ready set short.
            if f < facts && c > 0 && is_goal(goal, f) {
                goals_left -= 1;
                if goals_left == 0 {
                    break;
                }
            }
            prop.reach(f, c, &mut q);
        }
        // Empty the buckets the early stop left filled (all of them start empty).
        let used = (q.max_bucket + 1).min(BUCKETS);
        self.buckets[..used].iter_mut().for_each(|b| *b = u32::MAX);
        if goals
            .iter()
            .any(|g| is_goal(self.goal, g) && self.cost[g] == u32::MAX)
        {
            return DEAD_END;
        }
        // Extract the relaxed plan from the best supporters.
        let mut top = 0usize;
        for g in goals.iter() {
            if is_goal(self.goal, g) {
                self.stack[top] = g as u32;
                top += 1;
            }
        }
        let mut h = 0u32;
        while top > 0 {
            top -= 1;
            let f = self.stack[top] as usize;
            if self.cost[f] == 0 {
                continue;
            }
            // A running-action fact's only achiever is its action's start (the propagation
            // does not record it: see [`Propagation::fire`]); it is on the stack only as a
            // precondition of an end that fired, so it was reached.
            let r = if f >= facts {
                2 * (f - facts) as u32
            } else {
                self.supporter[f]
            };
            if r == u32::MAX {
                continue;
            }
            let r = r as usize;
            if self.in_relaxed_plan(r) {
                continue;
            }
            self.marked[r / 32] |= 1 << (r % 32);
            h += 1;
            let (lo, hi) = (
                self.pre_list_offsets[r] as usize,
                self.pre_list_offsets[r + 1] as usize,
            );
            for i in lo..hi {
                if top < self.stack.len() {
                    self.stack[top] = self.pre_list[i];
                    top += 1;
                }
            }
        }
        // Ends of started-in-the-relaxed-plan actions that the plan lacks (the starts are the
        // even bits of the marked set).
        for &bits in self.marked.iter() {
            let starts = bits & 0x5555_5555;
            let ends = (bits >> 1) & 0x5555_5555;
            h += (starts & !ends).count_ones();
        }
        // ... and of running actions.
        for &a in running {
            let r = 2 * a as usize + 1;
            if !self.in_relaxed_plan(r) {
                h += 1;
                self.marked[r / 32] |= 1 << (r % 32);
            }
        }
        self.count_plan_needs(true);
        h
    }
}
