//! The search proper: the root, successors pushed on the open lists, the bounded
//! [`Planner::step`] and the expansion of one node.

use super::*;
impl<'t, 'm> Planner<'t, 'm> {
    // ----- search -------------------------------------------------------------------------------

    /// The root: its state (left in `child_state`), its heuristic value, the node stored. The
    /// root and its h if its successors are to be pushed next ([`Self::push_successors`]);
    /// None if the search already ended (a dead end, no memory, or the goal holds).
    pub(super) fn start_root(&mut self) -> Option<(u32, u32)> {
        let task = self.task;
        let cs = core::mem::take(&mut self.child_state);
        self.initial_state(cs);
        self.child_state = cs;
        let h = {
            let cs = &*self.child_state;
            self.relax.evaluate(&task, &cs[..self.fact_words], &[])
        };
        self.stats.evaluated += 1;
        if h == DEAD_END {
            self.status = Status::Unsolvable;
            return None;
        }
        self.stats.best_h = h;
        let hash = self.state_hash(self.child_state);
        let Some(root) = self.store_node(NONE, NONE, h, 0, hash) else {
            self.status = Status::OutOfMemory(Region::Nodes);
            return None;
        };
        self.best_node = root;
        self.committed_node = root;
        if self.is_goal(self.child_state) {
            self.goal_node = root;
            self.status = Status::Solved;
            return None;
        }
        Some((root, h))
    }

    /// The root and its successors at once (a restart of the search: the set-up does the two
    /// as pieces of their own).
    pub(super) fn start(&mut self) {
        if let Some((root, h)) = self.start_root() {
            if let Err(r) = self.push_successors(root, h) {
                self.status = Status::OutOfMemory(r);
            }
        }
    }

    /// Push every applicable snap of the state in `child_state` (stored as `node`) into the
    /// open lists with key `h`; those in the relaxed plan also into the preferred list.
    ///
    /// The candidates are the relaxed actions the heuristic found ready in this state (all
    /// their relaxed preconditions true: [`Relaxation::is_ready`]), a superset of the
    /// applicable snaps (a start's relaxed preconditions are its conditions and the invariants
    /// it does not add, which must hold before it; an end's are its conditions and its
    /// action running). So the heuristic must have evaluated `child_state` last. Candidates
    /// are taken in action order, as a scan of every action would.
    pub(super) fn push_successors(&mut self, node: u32, h: u32) -> Result<(), Region> {
        let running_n = self.child_state[self.running_at()] as usize;
        let mut running = [0u32; MAX_RUNNING];
        running[..running_n].copy_from_slice(self.running(self.child_state));
        self.load_protection(&running[..running_n], true);
        let sw = self.probe_state.len();
        let mut result = Ok(());
        // In a novelty search the regular list takes the successors of a state novel in its
        // partition first, then by h.
        let novel_bit = match self.novelty(h) {
            2 => 1 << 31,
            _ => 0,
        };
        let words = self.relax.ready.len();
        'words: for w in 0..words {
            let mut bits = self.relax.ready[w];
            while bits != 0 {
                let r = 32 * w + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let a = r / 2;
                let is_end = r % 2 == 1;
                let is_running = running[..running_n].binary_search(&(a as u32)).is_ok();
                if is_end != is_running {
                    continue;
                }
                let snap = if is_running {
                    (a as u32) << 2 | END
                } else if self.config.compression && self.compression_safe(a) {
                    (a as u32) << 2 | COMPRESSED
                } else {
                    (a as u32) << 2 | START
                };
                let (probe, child) = (&mut *self.probe_state, &*self.child_state);
                probe[..sw].copy_from_slice(&child[..sw]);
                let probe = core::mem::take(&mut self.probe_state);
                let ok = self.apply(probe, snap);
                self.probe_state = probe;
                if !ok {
                    continue;
                }
                // The regular list takes successors of equal h in the order generated: ties
                // go by parent node and then snap (the heap compares all three words).
                let key = if self.novelty_words > 0 {
                    novel_bit | h.min(0x7fff) << 16
                } else {
                    h.min(0xffff) << 16
                };
                if !self.regular.push(key, node, snap) {
                    if self.config.shed_when_full && self.regular.len > 1 {
                        self.stats.shed += self.regular.shed_worse_half() as u64;
                    }
                    if !self.regular.push(key, node, snap) {
                        result = Err(Region::RegularOpen);
                        break 'words;
                    }
                }
                self.stats.generated += 1;
                if !(self.config.preferred_operators && self.relax.in_relaxed_plan(r)) {
                    continue;
                }
                // In the first search, the preferred list tries successors of equal h that
                // undo less of the relaxed plan first (see [`ORDERED_RESTART_AFTER`]); the
                // search alternates between the two lists, so it alternates between that
                // order and the order generated.
                // The second search, with novelty, orders only its regular list by it: its
                // preferred list stays greedy in h (novelty in both cost driverlog 4, 6, 14 and
                // 17 more evaluations); the last resort ([`NOVELTY_LAST`]) orders both (with
                // the preferred list greedy it does not solve driverlog 16). See the README's
                // "A width-based search".
                let key = if self.phase == 0 {
                    key | self.relaxed_plan_conflicts(a, snap & 3).min(0xffff)
                } else if self.phase == NOVELTY_LAST {
                    key
                } else {
                    h.min(0xffff) << 16
                };
                if !self.preferred.push(key, node, snap) {
                    if self.config.shed_when_full && self.preferred.len > 1 {
                        self.stats.shed += self.preferred.shed_worse_half() as u64;
                    }
                    if !self.preferred.push(key, node, snap) {
                        result = Err(Region::PreferredOpen);
                        break 'words;
                    }
                }
            }
        }
        self.load_protection(&running[..running_n], false);
        result
    }

    /// How many actions of the relaxed plan last evaluated (other than `a`'s own start and
    /// end) need a fact that snap `kind` of action `a` deletes. Trying the successors that
    /// undo less of the relaxed plan first gets off plateaus sooner where h counts on several
    /// things being done from the current state (satellite: the relaxed plan turns a satellite
    /// from where it points to every direction it needs; each real turn deletes that pointing,
    /// leaves h unchanged or one higher, and before this order the search evaluated every turn
    /// before the switch-on or calibration that lowers h).
    pub(super) fn relaxed_plan_conflicts(&self, a: usize, kind: u32) -> u32 {
        let act = self.task.action(a);
        let start = act.facts(FactList::DelStart);
        let end = act.facts(FactList::DelEnd);
        match kind {
            START => self.relax.plan_conflicts(a, start.iter()),
            END => self.relax.plan_conflicts(a, end.iter()),
            _ => self.relax.plan_conflicts(a, start.iter().chain(end.iter())),
        }
    }

    /// Run at most `budget` expansions.
    pub fn step(&mut self, budget: u32) -> Status {
        // A planner made with `new_deferred` finishes its set-up first.
        while self.set_up_step() {}
        for _ in 0..budget {
            if self.status != Status::Searching {
                break;
            }
            // The elimination after the search, a removal tried a unit (`eliminate.rs`).
            if self.eliminating() {
                self.eliminate_step();
                continue;
            }
            // A lookahead under way goes on first, a snap a unit of the budget.
            if self.looking_ahead() {
                let r = self.lookahead_step();
                self.unit_ended(r);
                continue;
            }
            let stalled = self.stats.expanded - self.last_progress;
            if self.first_search_commits(stalled) {
                continue;
            }
            if self.phase == 0 && stalled > self.ordered_restart_after {
                self.restart(1);
                continue;
            }
            // A committing search that stalls goes on from its latest node of the lowest h.
            if stalled > self.commit_after && self.commits_here() && self.commit_to_best() {
                continue;
            }
            if self.phase == 2 && stalled > self.third_gives_way_after && self.pruning_more() {
                self.restart(self.after_pruning_more());
                continue;
            }
            if self.phase == 1 && stalled > self.restart_after {
                self.restart(2);
                continue;
            }
            let entry = if (self.turn || self.boost > 0) && self.preferred.len > 0 {
                self.boost = self.boost.saturating_sub(1);
                self.preferred.pop()
            } else {
                self.regular.pop().or_else(|| self.preferred.pop())
            };
            self.turn = !self.turn;
            let Some((_, parent, snap)) = entry else {
                // The second search prunes more than asked: its end proves nothing, and the
                // third (as asked) decides.
                // So does a search that committed to a prefix ([`super::commit`]): the
                // search after it decides (the fourth, as configured, never restarts itself).
                if self.phase == 0 && self.has_committed() {
                    self.restart(1);
                    continue;
                }
                if self.pruning_more() || (self.has_committed() && self.phase != 3) {
                    self.restart(self.after_pruning_more());
                    continue;
                }
                // With entries shed, or after a commit, an empty open list proves nothing.
                self.status = if self.stats.shed > self.shed_base || self.has_committed() {
                    Status::OutOfMemory(Region::RegularOpen)
                } else {
                    Status::Unsolvable
                };
                break;
            };
            let r = self.expand(parent, snap);
            self.unit_ended(r);
        }
        let s = self.stats();
        self.stats.peak_words = s.peak_words;
        self.status
    }

    /// The child's least schedule in `est_child` (steps `steps + 1..=last` new): the parent's
    /// earliest times, then the child's new constraints `cons`, written after the loaded path's
    /// constraints, relaxed from them alone where they move no step of the parent's
    /// ([`stn::earliest_extend`]), else every constraint's passes. Whether it is consistent;
    /// None if the path's constraint scratch has no room for `cons`. For [`Self::expand`]'s
    /// successors and the lookahead's steps alike.
    pub(super) fn child_schedule(
        &mut self,
        steps: usize,
        last: usize,
        cons: &[Constraint],
    ) -> Option<bool> {
        let n = cons.len();
        self.est_child[..=steps].copy_from_slice(&self.est_parent[..=steps]);
        let base = 3 * self.loaded_constraints;
        if base + 3 * n > self.path_constraints.len() {
            return None;
        }
        for (i, c) in cons.iter().enumerate() {
            self.path_constraints[base + 3 * i] = u32::from(c.before) | u32::from(c.after) << 16;
            self.path_constraints[base + 3 * i + 1] = c.lb;
            self.path_constraints[base + 3 * i + 2] = c.ub;
        }
        let wins = &self.path_window;
        let window = |k: usize| (wins[2 * k], wins[2 * k + 1]);
        let words = &self.path_constraints[..base + 3 * n];
        Some(
            stn::earliest_extend(
                steps,
                last,
                base / 3,
                base / 3 + n,
                &|i| unpack(words, i),
                &window,
                self.est_child,
            ) || earliest_words(last, words, &window, self.est_child).is_ok(),
        )
    }

    /// What an expansion's (or a lookahead step's) error does to the search.
    /// The heuristic of the state in `child_state` (its facts and running actions), counted as
    /// an evaluation.
    pub(super) fn evaluate_child(&mut self) -> u32 {
        let task = self.task;
        let cs = &*self.child_state;
        let at = self.running_at();
        let rn = cs[at] as usize;
        self.stats.evaluated += 1;
        self.relax
            .evaluate(&task, &cs[..self.fact_words], &cs[at + 1..at + 1 + rn])
    }

    fn unit_ended(&mut self, r: Result<(), Region>) {
        match r {
            Ok(()) => {}
            // A path too long to extend is a branch dropped, not the search's end.
            Err(Region::PlanLength) => self.stats.too_long += 1,
            // A committing search whose store is full goes on from its best node.
            Err(Region::Nodes) if self.commits_here() && self.commit_to_best() => {}
            Err(_) if self.pruning_more() => self.restart(self.after_pruning_more()),
            // The ordered search gives way to the searches as before.
            Err(_) if self.phase == 0 => self.restart(1),
            Err(r) => self.status = Status::OutOfMemory(r),
        }
    }

    /// Whether the search under way prunes more repeated states than the configuration asks
    /// (the search after [`RESTART_AFTER`]).
    fn pruning_more(&self) -> bool {
        (self.phase == 2 || self.phase == NOVELTY_LAST) && self.duplicates != self.config.duplicates
    }

    /// The search after one that pruned more than asked and ended without a plan: the novelty
    /// search that prunes as much ([`NOVELTY_LAST`]) if the portfolio has it and it has not
    /// run, then the search as configured.
    fn after_pruning_more(&self) -> u8 {
        if self.phase == 2 && self.novelty_phases & 1 << NOVELTY_LAST != 0 {
            NOVELTY_LAST
        } else {
            3
        }
    }

    /// Abandon the search under way and start again from the root as search `phase` (1, 2, 3 or
    /// [`NOVELTY_LAST`]; see [`ORDERED_RESTART_AFTER`] and [`RESTART_AFTER`]): the nodes, the duplicate table and the
    /// open lists are emptied (the arena's high-water mark and the statistics carry on).
    pub(super) fn restart(&mut self, phase: u8) {
        let s = self.stats();
        self.stats.peak_words = s.peak_words;
        self.stats.restarts += 1;
        self.phase = phase;
        self.boost_amount = if phase == 1 {
            BOOST_FIRST
        } else {
            BOOST_SECOND
        };
        self.duplicates = match (phase, self.config.duplicates) {
            (2 | NOVELTY_LAST, Duplicates::PruneQuiescent) => Duplicates::PruneAll,
            (_, asked) => asked,
        };
        self.shed_base = self.stats.shed;
        self.lookahead_node = NONE;
        self.boost = 0;
        self.turn = false;
        self.nodes_used = 0;
        self.set_novelty_table();
        self.loaded_node = NONE;
        self.buckets.iter_mut().for_each(|b| *b = NONE);
        self.regular.len = 0;
        self.preferred.len = 0;
        self.stats.best_h = u32::MAX;
        self.last_progress = self.stats.expanded;
        self.status = Status::Searching;
        self.start();
    }

    pub(super) fn expand(&mut self, parent: u32, snap: u32) -> Result<(), Region> {
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
        self.set_step(j, (a as u32) << 1 | u32::from(kind == END));
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
            self.set_step(j + 1, (a as u32) << 1 | 1);
            let r = self.step_constraints(j + 1, a, true, j, &mut cons, &mut n);
            for &(id, w) in saved[..n_saved].iter().rev() {
                self.last_writer[id] = w;
            }
            r?;
        }
        // STN check, from the parent's earliest times: the new constraints alone where they
        // move no step of the parent's ([`stn::earliest_extend`]), else every constraint.
        let last = steps + new_steps;
        let base = 3 * self.loaded_constraints;
        match self.child_schedule(steps, last, &cons[..n]) {
            None => return Err(Region::PlanLength),
            Some(false) => {
                self.stats.inconsistent += 1;
                return Ok(());
            }
            Some(true) => {}
        }
        // Duplicates.
        let hash = self.state_hash(self.child_state);
        let quiescent = self.child_state[self.running_at()] == 0;
        let prune = match self.duplicates {
            Duplicates::Keep => false,
            Duplicates::PruneQuiescent => quiescent,
            Duplicates::PruneAll => true,
        };
        if prune && self.find_duplicate(hash) {
            self.stats.duplicates += 1;
            return Ok(());
        }
        if self.duplicates == Duplicates::PruneQuiescent
            && !quiescent
            && kind != START
            && self.repeats_ancestor(&running[..running_n], (kind == END).then_some(a), hash)
        {
            self.stats.duplicates += 1;
            return Ok(());
        }
        // A running action that can no longer end in time ([`super::running_ends`]).
        if !self.running_ends_schedulable(snap, &running[..running_n], last, base / 3 + n) {
            return Ok(());
        }
        // Heuristic.
        let h = self.evaluate_child();
        if h == DEAD_END {
            self.stats.dead_ends += 1;
            return Ok(());
        }
        if h < self.stats.best_h {
            self.stats.best_h = h;
            self.boost += self.boost_amount;
            self.last_progress = self.stats.expanded;
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
        if h <= self.stats.best_h {
            self.best_node = node;
        }
        if self.is_goal(self.child_state) {
            self.plan_found(node);
            return Ok(());
        }
        self.push_successors(node, h)?;
        self.lookahead(node)
    }

    /// Whether the child state (in `child_state`, reached by an end or a compressed action from
    /// the loaded path, whose running actions are `parent_running` in the order of
    /// `running_start`) equals an ancestor's state at which every action running in the child
    /// was already running, started by the same step. That ancestor dominates the child: the
    /// same facts, values and running instances, with the running actions as far from their
    /// ends or farther, and the child's later steps constrained by everything the ancestor's
    /// are and more. `ended` is the action whose end the child applied.
    pub(super) fn repeats_ancestor(
        &mut self,
        parent_running: &[u32],
        ended: Option<usize>,
        hash: u32,
    ) -> bool {
        // The latest start step among the child's running actions.
        let mut latest_start = 0usize;
        for (i, &r) in parent_running.iter().enumerate() {
            if Some(r as usize) != ended {
                latest_start = latest_start.max(self.running_start[i] as usize);
            }
        }
        let mut steps_at = self.loaded_steps;
        for d in (0..self.loaded_depth).rev() {
            if steps_at < latest_start {
                break;
            }
            let node = self.path_nodes[d];
            if self.node_has_child_state(node, hash) {
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
}
