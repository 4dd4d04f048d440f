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
    /// Per relaxed fact: cost (u32::MAX unreached) and best supporter (u32::MAX none).
    pub cost: &'m mut [u32],
    pub supporter: &'m mut [u32],
    /// Per relaxed action: preconditions not yet reached, and the sum of their costs.
    pub waiting: &'m mut [u32],
    pub action_cost: &'m mut [u32],
    /// A binary heap of (cost, fact) pairs, two words each.
    pub heap: &'m mut [u32],
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
        for p in pre.iter() {
            f(p);
        }
        for p in act.facts(FactList::Invariant).iter() {
            if !add.contains(p) && !pre.contains(p) {
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

impl<'m> Relaxation<'m> {
    /// Fill the precondition index and the effect table (once, when the planner starts).
    /// `dropped_goals`: bit i set leaves the task's i-th goal fact out of the goal (see
    /// [`crate::PlannerConfig::dropped_goals`]).
    pub fn build_index(&mut self, task: &Task<'_>, costs: RelaxedCost, dropped_goals: u64) {
        let facts = task.fact_count() + task.action_count();
        self.pre_offsets.iter_mut().for_each(|x| *x = 0);
        for r in 0..2 * task.action_count() {
            let mut n = 0;
            for_each_pre(task, r, &mut |p| {
                self.pre_offsets[p + 1] += 1;
                n += 1;
            });
            self.pre_count[r] = n;
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
            for_each_pre(task, r, &mut |p| {
                let at = self.cost[p] as usize;
                self.pre_index[at] = r as u32;
                self.cost[p] += 1;
            });
        }
    }

    fn heap_push(&mut self, len: &mut usize, cost: u32, fact: u32) {
        let mut i = *len;
        *len += 1;
        self.heap[2 * i] = cost;
        self.heap[2 * i + 1] = fact;
        while i > 0 {
            let parent = (i - 1) / 2;
            if self.heap[2 * parent] <= self.heap[2 * i] {
                break;
            }
            self.heap.swap(2 * parent, 2 * i);
            self.heap.swap(2 * parent + 1, 2 * i + 1);
            i = parent;
        }
    }

    fn heap_pop(&mut self, len: &mut usize) -> Option<(u32, u32)> {
        if *len == 0 {
            return None;
        }
        let top = (self.heap[0], self.heap[1]);
        *len -= 1;
        let last = *len;
        self.heap[0] = self.heap[2 * last];
        self.heap[1] = self.heap[2 * last + 1];
        let mut i = 0;
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut m = i;
            if l < last && self.heap[2 * l] < self.heap[2 * m] {
                m = l;
            }
            if r < last && self.heap[2 * r] < self.heap[2 * m] {
                m = r;
            }
            if m == i {
                break;
            }
            self.heap.swap(2 * m, 2 * i);
            self.heap.swap(2 * m + 1, 2 * i + 1);
            i = m;
        }
        Some(top)
    }

    /// Whether relaxed action `r` is in the last relaxed plan.
    pub fn in_relaxed_plan(&self, r: usize) -> bool {
        self.marked[r / 32] & (1 << (r % 32)) != 0
    }

    /// h for the state whose true facts are `fact_true` and running actions `running`; marks
    /// the relaxed plan (see [`Self::in_relaxed_plan`]). [`DEAD_END`] if the goal is unreachable.
    pub fn evaluate(
        &mut self,
        task: &Task<'_>,
        fact_true: &dyn Fn(usize) -> bool,
        running: &[u32],
    ) -> u32 {
        let facts = task.fact_count();
        let all = facts + task.action_count();
        let relaxed = 2 * task.action_count();
        self.cost[..all].iter_mut().for_each(|x| *x = u32::MAX);
        self.supporter[..all].iter_mut().for_each(|x| *x = u32::MAX);
        self.waiting[..relaxed].copy_from_slice(&self.pre_count[..relaxed]);
        self.action_cost[..relaxed].iter_mut().for_each(|x| *x = 0);
        self.marked.iter_mut().for_each(|x| *x = 0);
        let mut len = 0usize;
        for f in 0..facts {
            if fact_true(f) {
                self.cost[f] = 0;
                self.heap_push(&mut len, 0, f as u32);
            }
        }
        for &a in running {
            let f = facts + a as usize;
            self.cost[f] = 0;
            self.heap_push(&mut len, 0, f as u32);
        }
        // Relaxed actions without preconditions fire at once.
        for r in 0..relaxed {
            if self.waiting[r] == 0 {
                self.fire(r, &mut len);
            }
        }
        let goals = task.goal_facts();
        // Distinct goal facts not yet true.
        let mut goals_left = 0;
        for f in 0..facts {
            if self.goal[f / 32] & (1 << (f % 32)) != 0 && self.cost[f] != 0 {
                goals_left += 1;
            }
        }
        while let Some((c, f)) = self.heap_pop(&mut len) {
            let f = f as usize;
            if c > self.cost[f] {
                continue;
            }
            if f < facts && c > 0 && self.goal[f / 32] & (1 << (f % 32)) != 0 {
                goals_left -= 1;
                if goals_left == 0 {
                    break;
                }
            }
            let (lo, hi) = (
                self.pre_offsets[f] as usize,
                self.pre_offsets[f + 1] as usize,
            );
            for i in lo..hi {
                let r = self.pre_index[i] as usize;
                self.waiting[r] -= 1;
                self.action_cost[r] = self.action_cost[r].saturating_add(c);
                if self.waiting[r] == 0 {
                    self.fire(r, &mut len);
                }
            }
        }
        let is_goal = |goal: &[u32], g: usize| goal[g / 32] & (1 << (g % 32)) != 0;
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
            let stack = &mut *self.stack;
            for_each_pre(task, r, &mut |p| {
                if top < stack.len() {
                    stack[top] = p as u32;
                    top += 1;
                }
            });
        }
        // Ends of started-in-the-relaxed-plan or running actions that the plan lacks.
        for a in 0..task.action_count() {
            let started = self.in_relaxed_plan(2 * a);
            if started && !self.in_relaxed_plan(2 * a + 1) {
                h += 1;
            }
        }
        for &a in running {
            if !self.in_relaxed_plan(2 * a as usize + 1) {
                h += 1;
                let r = 2 * a as usize + 1;
                self.marked[r / 32] |= 1 << (r % 32);
            }
        }
        h
    }

    fn fire(&mut self, r: usize, len: &mut usize) {
        let c = self.action_cost[r].saturating_add(self.own_cost[r]);
        let (lo, hi) = (
            self.add_offsets[r] as usize,
            self.add_offsets[r + 1] as usize,
        );
        for i in lo..hi {
            let f = self.add_index[i] as usize;
            if c < self.cost[f] {
                self.cost[f] = c;
                self.supporter[f] = r as u32;
                self.heap_push(len, c, f as u32);
            }
        }
    }
}
