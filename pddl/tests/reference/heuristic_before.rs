//! TEST-ONLY REFERENCE: the temporal planner's FF heuristic as it was before its propagation
//! was made cheaper per evaluation (`firmware/temporal/src/heuristic.rs` at commit d119e2d,
//! copied verbatim but for the `use` line and this header). `heuristic_reference.rs` checks
//! that the planner's heuristic gives the same h, relaxed plan and ready set as this one on
//! many states of benchmark tasks. Not used by the planner.
#![allow(dead_code)]
use temporal::task::{FactList, Task};

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
    /// Per relaxed action r, two words: `waiting[2r]` its preconditions not yet reached,
    /// `waiting[2r + 1]` the sum of their costs (side by side: one index for both).
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
}

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
    add_offsets: &'a [u32],
    add_index: &'a [u32],
    own_cost: &'a [u32],
    cost: &'a mut [u32],
    supporter: &'a mut [u32],
    /// Per relaxed action: (preconditions not yet reached, the sum of their costs).
    counts: &'a mut [[u32; 2]],
    ready: &'a mut [u32],
    end_follows: &'a [u32],
    /// The first running-action fact (the task's fact count).
    facts: usize,
}

impl Propagation<'_> {
    /// Relaxed action `r` fires: its effects get its cost if that is cheaper, or the same
    /// cost from a lower-numbered supporter.
    ///
    /// A start whose end needs nothing but the action running (an `end_follows` action) reaches
    /// its running-action fact here, at its final cost (the start is that fact's only achiever
    /// and fires once), so the end fires at once instead of after the fact's trip through the
    /// queue. The order differs from the queue's, the outcome does not: every fact of cost at
    /// most the last goal's still has its final cost and supporter when the propagation stops.
    #[inline(always)]
    fn fire(&mut self, r: usize, q: &mut Queue<'_>) {
        let c = self.fire_effects(r, q);
        if r.is_multiple_of(2) {
            let a = r / 2;
            if self.end_follows[a / 32] & (1 << (a % 32)) != 0 {
                let f = self.facts + a;
                if c < self.cost[f] {
                    self.cost[f] = c;
                    self.supporter[f] = r as u32;
                    let e = r + 1;
                    self.counts[e] = [0, c];
                    if c == 0 {
                        self.ready[e / 32] |= 1 << (e % 32);
                    }
                    self.fire_effects(e, q);
                }
            }
        }
    }

    /// The effects of relaxed action `r` at its cost, which it returns. The running-action
    /// fact of an `end_follows` start is left to [`Self::fire`].
    #[inline(always)]
    fn fire_effects(&mut self, r: usize, q: &mut Queue<'_>) -> u32 {
        let c = self.counts[r][1].saturating_add(self.own_cost[r]);
        let (lo, mut hi) = (
            self.add_offsets[r] as usize,
            self.add_offsets[r + 1] as usize,
        );
        // A start's running-action fact is its last effect.
        if r.is_multiple_of(2) && self.end_follows[r / 64] & (1 << ((r / 2) % 32)) != 0 {
            hi -= 1;
        }
        for &f in &self.add_index[lo..hi] {
            let f = f as usize;
            let old = self.cost[f];
            // The cheapest achiever, the lowest-numbered among equals: the same supporter
            // whatever order the heap takes equal costs in.
            if c < old || (c == old && c != u32::MAX && (r as u32) < self.supporter[f]) {
                if c < old {
                    q.push(c, f as u32);
                }
                self.cost[f] = c;
                self.supporter[f] = r as u32;
            }
        }
        c
    }

    /// Fact `f` reached at cost `c`: each relaxed action it is a precondition of counts it,
    /// and fires when its last precondition is reached.
    #[inline(always)]
    fn reach(&mut self, f: usize, c: u32, q: &mut Queue<'_>) {
        let (lo, hi) = (
            self.pre_offsets[f] as usize,
            self.pre_offsets[f + 1] as usize,
        );
        for &r in &self.pre_index[lo..hi] {
            let r = r as usize;
            let [waiting, sum] = self.counts[r];
            let left = waiting - 1;
            let sum = sum.saturating_add(c);
            self.counts[r] = [left, sum];
            if left == 0 {
                if sum == 0 {
                    self.ready[r / 32] |= 1 << (r % 32);
                }
                self.fire(r, q);
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
            waiting: take(2 * relaxed)?,
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
        };
        relax.buckets.iter_mut().for_each(|b| *b = u32::MAX);
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
                self.pre_offsets[p + 1] += 1;
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
        // Fill using `cost` as the per-fact insertion cursor.
        for f in 0..facts {
            self.cost[f] = self.pre_offsets[f];
        }
        for r in 0..2 * task.action_count() {
            let (lo, hi) = (
                self.pre_list_offsets[r] as usize,
                self.pre_list_offsets[r + 1] as usize,
            );
            for i in lo..hi {
                let p = self.pre_list[i] as usize;
                let at = self.cost[p] as usize;
                self.pre_index[at] = r as u32;
                self.cost[p] += 1;
            }
        }
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
            let (lo, hi) = (
                self.pre_offsets[f] as usize,
                self.pre_offsets[f + 1] as usize,
            );
            for &r in &self.pre_index[lo..hi] {
                let r = r as usize;
                if r / 2 != a && self.in_relaxed_plan(r) {
                    n += 1;
                }
            }
        }
        n
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
        self.cost[..all].iter_mut().for_each(|x| *x = u32::MAX);
        // `supporter` is not cleared: it is read only for facts of nonzero finite cost, and
        // those got theirs in this evaluation (when their cost was set).
        let (counts, _) = self.waiting[..2 * relaxed].as_chunks_mut::<2>();
        for (pair, &n) in counts.iter_mut().zip(self.pre_count[..relaxed].iter()) {
            *pair = [n, 0];
        }
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
            add_offsets: &*self.add_offsets,
            add_index: &*self.add_index,
            own_cost: &*self.own_cost,
            cost: &mut *self.cost,
            supporter: &mut *self.supporter,
            counts,
            ready: &mut *self.ready,
            end_follows: &*self.end_follows,
            facts,
        };
        for (w, &bits) in fact_bits.iter().enumerate().take(facts.div_ceil(32)) {
            let mut bits = bits;
            while bits != 0 {
                let f = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if f < facts {
                    prop.cost[f] = 0;
                    q.push(0, f as u32);
                }
            }
        }
        for &a in running {
            let f = facts + a as usize;
            prop.cost[f] = 0;
            q.push(0, f as u32);
        }
        // Relaxed actions without preconditions fire at once.
        for &r in self.free.iter() {
            let r = r as usize;
            prop.ready[r / 32] |= 1 << (r % 32);
            prop.fire(r, &mut q);
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
        while let Some((c, f)) = q.pop() {
            let f = f as usize;
            if c > prop.cost[f] {
                continue;
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
            let r = self.supporter[f];
            if self.cost[f] == 0 || r == u32::MAX {
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
        h
    }
}
