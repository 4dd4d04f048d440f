//! A lookahead along the relaxed plan (Vidal's YAHSP, 2004), for plateaus where h is noise.
//!
//! After a state is evaluated and its successors pushed, the snaps of its relaxed plan are
//! applied in the order of the relaxed planning graph (lowest cost of their relaxed
//! preconditions first), each as soon as it applies, one after the other from that state,
//! until none of them applies (or [`LOOKAHEAD_MAX_STEPS`]). Each snap goes through the search's
//! own checks (the temporal rules, compression safety, the STN, repeated states), and becomes a
//! node of the store with its constraints, so the plan to the last one is an ordinary path;
//! only the last state is evaluated, and its successors are pushed like any evaluated node's.
//! One evaluation thus stands for a whole stretch of the plan where the relaxed plan was right.
//! The state's own successors are pushed as before: the search loses nothing, it gains a
//! state farther on.
//!
//! Why (satellite 20, measured): h is the FF relaxed plan's size from additive-cost best
//! supporters, and on satellite with many instruments per satellite it jumps by 5 to 10
//! between states that differ by one turn, as ties between satellites are broken another way
//! (a satellite in mid-turn points nowhere, and the relaxed plan gives its images to another
//! satellite: lower h there than once the turn ends). The first search reaches h 144 in 210
//! expansions and then evaluates 500 states without a lower h; every search of the portfolio
//! spends most of its evaluations on such plateaus.

use super::*;

/// Most snaps one lookahead applies.
pub const LOOKAHEAD_MAX_STEPS: u32 = 256;

/// Expansions without a new best h before the search looks ahead (0: from every state).
pub const LOOKAHEAD_AFTER: u64 = 0;

/// The searches of the portfolio (bit p: search p) that look ahead ([`Planner::lookahead`]).
pub const LOOKAHEAD_PHASES: u8 = 1;

impl<'t, 'm> Planner<'t, 'm> {
    /// Begin a lookahead from `node`, just evaluated (its relaxed plan in the heuristic's
    /// marks) and its successors pushed: [`Self::lookahead_step`] applies its relaxed plan's
    /// snaps while they apply, one a call, storing each as a node, then evaluates the last
    /// state and pushes its successors. One snap a call, so that no unit of the search's work
    /// ([`Self::step`]'s budget) is much more than an expansion: on the target the search
    /// stops before a unit that would overrun the window's share.
    pub(super) fn lookahead(&mut self, node: u32) -> Result<(), Region> {
        if self.lookahead_phases & 1 << self.phase == 0
            || self.stats.expanded - self.last_progress < self.lookahead_after
            || self.task_has_windows
            || self.status != Status::Searching
        {
            return Ok(());
        }
        let words = self.lookahead_todo.len().min(self.relax.marked.len());
        self.lookahead_todo[..words].copy_from_slice(&self.relax.marked[..words]);
        self.lookahead_node = node;
        self.lookahead_origin = node;
        self.lookahead_count = 0;
        Ok(())
    }

    /// Whether a lookahead is under way ([`Self::step`] goes on with it before anything else).
    pub(super) fn looking_ahead(&self) -> bool {
        self.lookahead_node != NONE
    }

    /// One unit of the lookahead under way: apply its next snap, or, when none applies (or
    /// after [`LOOKAHEAD_MAX_STEPS`]), end it: evaluate its last state and push its successors.
    pub(super) fn lookahead_step(&mut self) -> Result<(), Region> {
        let r = self.lookahead_unit();
        if r.is_err() {
            // A path too long (or the store full) ends the lookahead; the search goes on as
            // [`Self::step`] says.
            self.lookahead_node = NONE;
        }
        r
    }

    fn lookahead_unit(&mut self) -> Result<(), Region> {
        let at = self.lookahead_node;
        self.load_path(at)?;
        if self.lookahead_count < LOOKAHEAD_MAX_STEPS {
            if let Some((r, snap)) = self.lookahead_pick() {
                self.lookahead_todo[r / 32] &= !(1 << (r % 32));
                let Some(next) = self.advance(at, snap)? else {
                    return Ok(());
                };
                self.lookahead_node = next;
                self.lookahead_count += 1;
                self.stats.lookahead_steps += 1;
                if snap & 3 == START {
                    // Its end comes later in the lookahead (the relaxed plan counts it without
                    // marking it when only the start is in the plan).
                    let e = r + 1;
                    self.lookahead_todo[e / 32] |= 1 << (e % 32);
                }
                if self.is_goal(self.child_state) {
                    self.plan_found(next);
                }
                return Ok(());
            }
        }
        self.lookahead_node = NONE;
        if at == self.lookahead_origin {
            return Ok(());
        }
        // The last node's state (the loaded path's end; `child_state` may hold a snap tried
        // and refused since).
        let sw = self.child_state.len();
        self.child_state[..sw].copy_from_slice(&self.parent_state[..sw]);
        let h = self.evaluate_child();
        if h == DEAD_END {
            self.stats.dead_ends += 1;
            return Ok(());
        }
        let w = at as usize + 2;
        self.nodes[w] = self.nodes[w] & 0xffff | h.min(0xffff) << 16;
        let bucket = self.node_hash(at) as usize & (self.buckets.len() - 1);
        self.nodes[at as usize + 4] = self.buckets[bucket];
        self.buckets[bucket] = at;
        if h < self.stats.best_h {
            self.stats.best_h = h;
            self.boost += self.boost_amount;
            self.last_progress = self.stats.expanded;
        }
        self.push_successors(at, h)
    }

    /// Whether some action of the task has a start or end window (timed initial literals, a
    /// replan's completions that must start at once): no lookahead then. The lookahead
    /// applies the relaxed plan's snaps in an order chosen without the windows (the heuristic
    /// ignores them), and a step put before a snap whose window is closing makes that window
    /// unmeetable on the whole stretch; the states after it look good to h and lead nowhere
    /// (measured: the rover mission's replan with a carried traverse, whose completion must
    /// start at time 0, ran into its 1,500-expansion limit twice and the mission stopped).
    /// The search without lookahead meets the windows through its STN check of each successor.
    pub(super) fn windows_in(task: &Task<'_>) -> bool {
        (0..task.action_count()).any(|a| {
            let (_, start, end) = task.action_times(a);
            start != (0, UNBOUNDED) || end != (0, UNBOUNDED)
        })
    }

    /// The snap of the lookahead's relaxed plan (`lookahead_todo`) to apply next in the loaded
    /// path's last state (`parent_state`): of those whose relaxed preconditions hold there, the
    /// one whose preconditions cost least in the relaxed planning graph of the state the
    /// lookahead started from (the heuristic's costs are still that evaluation's), the lowest
    /// relaxed action among equals. Its relaxed action and snap id.
    fn lookahead_pick(&self) -> Option<(usize, u32)> {
        let facts = self.task.fact_count();
        let state = &*self.parent_state;
        let mut best: Option<(u32, usize)> = None;
        for (w, &bits) in self.lookahead_todo.iter().enumerate() {
            let mut bits = bits;
            while bits != 0 {
                let r = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let a = r / 2;
                let is_end = r % 2 == 1;
                if is_end != self.is_running(state, a) {
                    continue;
                }
                let mut level = 0u32;
                let mut holds = true;
                for &p in self.relax.preconditions(r) {
                    let p = p as usize;
                    let true_now = if p < facts {
                        Self::fact(state, p)
                    } else {
                        self.is_running(state, p - facts)
                    };
                    if !true_now {
                        holds = false;
                        break;
                    }
                    level = level.max(self.relax.cost[p]);
                }
                if holds && best.is_none_or(|(l, _)| level < l) {
                    best = Some((level, r));
                }
            }
        }
        let (_, r) = best?;
        let a = (r / 2) as u32;
        let snap = if r % 2 == 1 {
            a << 2 | END
        } else if self.config.compression && self.compression_safe(r / 2) {
            a << 2 | COMPRESSED
        } else {
            a << 2 | START
        };
        Some((r, snap))
    }

    /// The child of `parent` by `snap`, as [`Self::expand`] makes it (the temporal rules, its
    /// constraints, the STN, repeated states) but not evaluated: stored with its parent's h,
    /// its state left in `child_state`. None if it is not applicable, inconsistent or a
    /// repeated state.
    fn advance(&mut self, parent: u32, snap: u32) -> Result<Option<u32>, Region> {
        self.load_path(parent)?;
        let steps = self.loaded_steps;
        let task = self.task;
        let a = (snap >> 2) as usize;
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
            return Ok(None);
        }
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
            return Ok(None);
        }
        let j = steps + 1;
        let start_step = if kind == END {
            let i = running[..running_n].binary_search(&(a as u32)).unwrap_or(0);
            self.running_start[i] as usize
        } else {
            0
        };
        if self
            .step_constraints(j, a, kind == END, start_step, &mut cons, &mut n)
            .is_err()
        {
            return Ok(None);
        }
        self.set_step(j, (a as u32) << 1 | u32::from(kind == END));
        if kind == COMPRESSED {
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
            self.set_step(j + 1, (a as u32) << 1 | 1);
            let r = self.step_constraints(j + 1, a, true, j, &mut cons, &mut n);
            for &(id, w) in saved[..n_saved].iter().rev() {
                self.last_writer[id] = w;
            }
            if r.is_err() {
                return Ok(None);
            }
        }
        let last = steps + new_steps;
        // The STN from the parent's earliest times, as [`Self::expand`] checks it (every
        // lookahead step ran the passes over every constraint before: a tenth of driverlog 17's
        // search natively).
        match self.child_schedule(steps, last, &cons[..n]) {
            None => return Ok(None),
            Some(false) => {
                self.stats.inconsistent += 1;
                return Ok(None);
            }
            Some(true) => {}
        }
        let hash = self.state_hash(self.child_state);
        let quiescent = self.child_state[self.running_at()] == 0;
        let prune = match self.duplicates {
            Duplicates::Keep => false,
            Duplicates::PruneQuiescent => quiescent,
            Duplicates::PruneAll => true,
        };
        if prune && self.find_duplicate(hash) {
            self.stats.duplicates += 1;
            return Ok(None);
        }
        if self.duplicates == Duplicates::PruneQuiescent
            && !quiescent
            && kind != START
            && self.repeats_ancestor(&running[..running_n], (kind == END).then_some(a), hash)
        {
            self.stats.duplicates += 1;
            return Ok(None);
        }
        let mut at = 0usize;
        for c in &cons[..n] {
            if constraints::encode(c, task.epsilon(), &mut self.child_bytes, &mut at).is_err() {
                return Ok(None);
            }
        }
        let h = self.nodes[parent as usize + 2] >> 16;
        let node = self
            .store_node(parent, snap, h, at, hash)
            .ok_or(Region::Nodes)?;
        // Not in the duplicate table (yet): a state on the way is never expanded, so a state
        // the search reaches again by another path must not be pruned as its repeat (that
        // would lose its successors: the rover's mission task was "unsolvable" so). The last
        // node is entered when its successors are pushed ([`Self::lookahead`]).
        let bucket = hash as usize & (self.buckets.len() - 1);
        self.buckets[bucket] = self.nodes[node as usize + 4];
        self.extend_loaded_path(node);
        Ok(Some(node))
    }

    /// Make the loaded path (the parent's) the path to `node`, its child just stored by
    /// [`Self::advance`], in place: the node is applied to the loaded path as a load would
    /// apply it ([`Self::extend_path`]: its steps, constraints and earliest times, with the
    /// marks and undo logs a later cut back needs), without walking the whole path again (the
    /// next lookahead step starts from `node`). `child_state` is the node's state. If the
    /// node cannot be applied, nothing is loaded and the next load starts from the root.
    fn extend_loaded_path(&mut self, node: u32) {
        let d = self.loaded_depth;
        if d >= self.path_nodes.len() {
            self.loaded_node = NONE;
            return;
        }
        self.path_nodes[d] = node;
        if self.extend_path(d).is_err() {
            self.loaded_node = NONE;
            return;
        }
        let last = self.loaded_steps;
        let sw = self.parent_state.len();
        self.parent_state[..sw].copy_from_slice(&self.child_state[..sw]);
        let at = self.running_at();
        let running_n = self.parent_state[at] as usize;
        for i in 0..running_n {
            let r = self.parent_state[at + 1 + i];
            let mut s = last;
            while s > 0 && self.path_snap[s] != r << 1 {
                s -= 1;
            }
            self.running_start[i] = s as u32;
        }
        self.loaded_node = node;
    }
}
