//! Packed search states: facts, numeric values and running actions; applying snap actions to
//! them; and which actions may be compressed (start and end as one step).

use super::*;
impl<'t, 'm> Planner<'t, 'm> {
    // ----- compression safety -------------------------------------------------------------

    /// An action is compression safe (a sufficient condition, checked against brute force in
    /// the tests) when its end has no numeric conditions or effects and no numeric invariants,
    /// every end precondition is one of its invariants or a start precondition no action
    /// deletes, and every fact its end adds or deletes is touched by no other action (no
    /// other action's condition, invariant or effect names it) and is not a window fact.
    /// Then applying the end at once changes no other step's support, threatens nothing, and
    /// adds no ordering the original plan did not have.
    pub(super) fn mark_compression_safe(&mut self) {
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
        // The actions whose end may break another's invariant: protect[f] = 1 marks the
        // facts that are some action's invariant.
        self.protect.iter_mut().for_each(|x| *x = 0);
        for a in 0..task.action_count() {
            for f in task.action(a).facts(FactList::Invariant).iter() {
                self.protect[f] = 1;
            }
        }
        self.may_block.iter_mut().for_each(|x| *x = 0);
        for a in 0..task.action_count() {
            let act = task.action(a);
            let add = act.facts(FactList::AddEnd);
            if act
                .facts(FactList::DelEnd)
                .iter()
                .any(|f| self.protect[f] == 1 && !add.contains(f))
            {
                self.may_block[a / 32] |= 1 << (a % 32);
            }
        }
        self.protect.iter_mut().for_each(|x| *x = 0);
        self.last_writer.iter_mut().for_each(|x| *x = 0);
    }

    /// Whether the end of `a` deletes some action's invariant (a superset of the actions
    /// [`Self::end_breaks_invariant`] finds for any other action).
    pub(super) fn may_block(&self, a: usize) -> bool {
        self.may_block[a / 32] & (1 << (a % 32)) != 0
    }

    // ----- states -----------------------------------------------------------------------------

    pub(super) fn fact(state: &[u32], f: usize) -> bool {
        state[f / 32] & (1 << (f % 32)) != 0
    }
    pub(super) fn set_fact(state: &mut [u32], f: usize, on: bool) {
        if on {
            state[f / 32] |= 1 << (f % 32);
        } else {
            state[f / 32] &= !(1 << (f % 32));
        }
    }
    pub(super) fn value(&self, state: &[u32], v: usize) -> i64 {
        let at = self.fact_words + 2 * v;
        (u64::from(state[at]) | u64::from(state[at + 1]) << 32) as i64
    }
    pub(super) fn set_value(&self, state: &mut [u32], v: usize, x: i64) {
        let at = self.fact_words + 2 * v;
        state[at] = x as u64 as u32;
        state[at + 1] = (x as u64 >> 32) as u32;
    }
    pub(super) fn running_at(&self) -> usize {
        self.fact_words + 2 * self.task.numeric_count()
    }
    pub(super) fn running<'s>(&self, state: &'s [u32]) -> &'s [u32] {
        let at = self.running_at();
        let n = state[at] as usize;
        &state[at + 1..at + 1 + n]
    }
    /// Words of the state that are in use (the running list is variable).
    pub(super) fn used_state_words(&self, state: &[u32]) -> usize {
        self.running_at() + 1 + state[self.running_at()] as usize
    }
    pub(super) fn is_running(&self, state: &[u32], a: usize) -> bool {
        self.running(state).binary_search(&(a as u32)).is_ok()
    }

    pub(super) fn initial_state(&self, state: &mut [u32]) {
        state.iter_mut().for_each(|x| *x = 0);
        for f in 0..self.task.fact_count() {
            Self::set_fact(state, f, self.task.initially_true(f));
        }
        for v in 0..self.task.numeric_count() {
            self.set_value(state, v, self.task.initial_value(v));
        }
    }

    /// Recompute the invariant protection counts for the running actions of `state`.
    pub(super) fn load_protection(&mut self, running: &[u32], add: bool) {
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

    pub(super) fn numeric_ok(&self, state: &[u32], list: NumericList, a: usize) -> bool {
        let act = self.task.action(a);
        act.numeric(list)
            .all(|c| c.holds(&|v| self.value(state, v)))
    }

    /// Apply the start (`end == false`) or end of `a` to `state` in place. Returns false if it
    /// is not applicable or breaks an invariant (the protection counts must describe the
    /// running actions of `state` before this snap, without `a`'s own entry for an end).
    pub(super) fn apply_snap(
        &self,
        state: &mut [u32],
        a: usize,
        end: bool,
        own_protected: bool,
    ) -> bool {
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
        // (Not `numeric_ok`: the record is decoded already.)
        if !act
            .numeric(conds)
            .all(|c| c.holds(&|v| self.value(state, v)))
        {
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
            if self.may_block(a)
                && list[..n].iter().any(|&r| {
                    self.may_block(r as usize) && self.ends_block_each_other(a, r as usize)
                })
            {
                return false;
            }
            let i = list[..n].partition_point(|&x| x < a as u32);
            list.copy_within(i..n, i + 1);
            list[i] = a as u32;
            state[at] += 1;
            // The new action's own invariants must hold once it has started.
            if !inv.iter().all(|f| Self::fact(state, f))
                || !act
                    .numeric(NumericList::CondInvariant)
                    .all(|c| c.holds(&|v| self.value(state, v)))
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
    pub(super) fn end_breaks_invariant(&self, x: usize, y: usize) -> bool {
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
    pub(super) fn ends_block_each_other(&self, x: usize, y: usize) -> bool {
        x != y && self.end_breaks_invariant(x, y) && self.end_breaks_invariant(y, x)
    }

    /// Apply snap id `snap` (start, end or compressed) to `state` in place.
    pub(super) fn apply(&self, state: &mut [u32], snap: u32) -> bool {
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

    pub(super) fn is_goal(&self, state: &[u32]) -> bool {
        state[self.running_at()] == 0
            && self.task.goal_facts().iter().enumerate().all(|(i, g)| {
                heuristic::goal_dropped(self.config.dropped_goals, i) || Self::fact(state, g)
            })
            && self
                .task
                .goal_conditions()
                .all(|c| c.holds(&|v| self.value(state, v)))
    }
}
