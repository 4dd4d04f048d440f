//! Action elimination after the search (Nakhost & Müller 2010, greedy action elimination),
//! for plan quality: the lookahead along the relaxed plan ([`super::lookahead`]) applies
//! relaxed-plan snaps the plan does not need (satellite 2: 25 actions where the search
//! without it found 13), and nothing else removes them.
//!
//! When the search reaches the goal ([`Planner::plan_found`]), the plan's snaps (start, end or
//! compressed, as the nodes hold them) are copied to scratch. Then, one action a unit of
//! [`Planner::step`]'s budget, in plan order: the plan without that action is run from the
//! initial state with the search's own checks ([`Planner::apply`], the running actions'
//! invariants protected), and every later action whose start (or compressed step) no longer
//! applies is dropped too; an end that no longer applies after its start did refuses the
//! removal. The removal is kept if the goal holds at the end (every action ended) and the
//! snaps' temporal constraints, rebuilt from the shorter path as the search builds them
//! ([`Planner::step_constraints`], `path.rs`), are consistent with a makespan no longer than
//! before; the plan's schedule is then the shorter path's earliest times.
//!
//! Bounded: a pass tries each action of the plan once (a kept removal tries the action now at
//! the same place next); passes repeat until one removes nothing, so that no action of the
//! result can be removed (with the actions that then no longer apply), and every pass but the
//! last removes an action: at most n passes for n actions, two or three on the benchmarks. Each check is a unit of the search's budget (on the target a
//! window stops before a unit costlier than its share, as for expansions). The plan is valid
//! after every unit; the status says [`Status::Solved`] once every action was tried. The
//! scratch is the regular open list's words (the plan's snaps and a bit each) and
//! `probe_state` (the state before the removal tried, kept as a pass goes), which the finished
//! search no longer needs; if they cannot hold the plan (a tiny arena), the plan is reported as
//! found. A caller that stops calling [`Planner::step`] while the status is still
//! [`Status::Searching`] (an expansion or frame limit reached during the elimination) gets no
//! plan, as during the search. A plan with no
//! action removed is read from its nodes as before, so it is the search's plan bit for bit.
use super::*;

/// Where the elimination stands ([`Planner::elim_phase`]).
pub(super) const ELIM_NONE: u8 = 0;
pub(super) const ELIM_RUNNING: u8 = 1;
/// Done, with at least one action removed: the plan is the snaps in scratch.
pub(super) const ELIM_DONE: u8 = 2;

impl<'t, 'm> Planner<'t, 'm> {
    /// The search reached the goal at `node`: eliminate the plan's unneeded actions first if
    /// the configuration asks for it ([`PlannerConfig::eliminate`]), else the plan is found.
    pub(super) fn plan_found(&mut self, node: u32) {
        self.goal_node = node;
        self.lookahead_node = NONE;
        if self.config.eliminate && self.begin_elimination() {
            self.elim_phase = ELIM_RUNNING;
            self.status = Status::Searching;
        } else {
            self.status = Status::Solved;
        }
    }

    /// Whether an elimination is under way ([`Self::step`] goes on with it).
    pub(super) fn eliminating(&self) -> bool {
        self.elim_phase == ELIM_RUNNING
    }

    /// Copy the goal node's snaps to scratch; false if they do not fit (or no path loads).
    fn begin_elimination(&mut self) -> bool {
        let mut count = 0usize;
        let mut n = self.goal_node;
        while n != NONE {
            if self.node_snap(n) != NONE {
                count += 1;
            }
            n = self.node_parent(n);
        }
        if count < 1 || count + count.div_ceil(32) + 1 > self.regular.words.len() {
            return false;
        }
        self.regular.len = 0;
        self.preferred.len = 0;
        let mut at = count;
        let mut n = self.goal_node;
        while n != NONE {
            let snap = self.node_snap(n);
            if snap != NONE {
                at -= 1;
                self.regular.words[at] = snap;
            }
            n = self.node_parent(n);
        }
        self.loaded_node = NONE;
        if self.load_path(self.goal_node).is_err() {
            return false;
        }
        self.elim_makespan = self.est_parent[..=self.loaded_steps]
            .iter()
            .copied()
            .max()
            .unwrap_or(0);
        self.elim_found_makespan = self.elim_makespan;
        self.elim_entries = count;
        self.elim_next = 0;
        self.elim_pass_base = self.stats.eliminated;
        self.reset_prefix();
        true
    }

    /// One unit: try removing the next action of the plan.
    pub(super) fn eliminate_step(&mut self) {
        let entries = self.elim_entries;
        let mut i = self.elim_next;
        while i < entries && self.regular.words[i] & 3 == END {
            i += 1;
        }
        if i >= entries && self.stats.eliminated > self.elim_pass_base {
            // A removal can make an action tried before removable: another pass, until one
            // removes nothing (each pass but the last removes an action).
            self.elim_pass_base = self.stats.eliminated;
            self.elim_next = 0;
            self.reset_prefix();
            return;
        }
        if i >= entries {
            self.elim_phase = if self.stats.eliminated > 0 {
                ELIM_DONE
            } else {
                ELIM_NONE
            };
            self.loaded_node = NONE;
            self.status = Status::Solved;
            return;
        }
        self.stats.elimination_checks += 1;
        self.advance_prefix(i);
        match self.load_entries(Some(i)) {
            Some(makespan) if makespan <= self.elim_makespan => {
                // Keep it: the plan is the entries not skipped.
                let bits = entries;
                let mut kept = 0usize;
                let mut removed = 0u64;
                for k in 0..entries {
                    let skipped = self.regular.words[bits + k / 32] & 1 << (k % 32) != 0;
                    let snap = self.regular.words[k];
                    if skipped {
                        removed += u64::from(snap & 3 != END);
                    } else {
                        self.regular.words[kept] = snap;
                        kept += 1;
                    }
                }
                self.stats.eliminated += removed;
                self.elim_entries = kept;
                self.elim_makespan = makespan;
            }
            _ => self.elim_next = i + 1,
        }
        self.loaded_node = NONE;
    }

    /// Load the plan in scratch as the loaded path (its steps, constraints and earliest times),
    /// without entry `without` (an action's start or compressed step) and every later action
    /// that then no longer applies, marking the entries left out in the bits after the
    /// entries. The makespan, or None if an end no longer applies, the goal does not hold or
    /// the constraints are inconsistent (or the path is too long).
    pub(super) fn load_entries(&mut self, without: Option<usize>) -> Option<u32> {
        let entries = self.elim_entries;
        let bits = entries;
        for w in 0..entries.div_ceil(32) {
            self.regular.words[bits + w] = 0;
        }
        if let Some(i) = without {
            self.skip_action(i);
        }
        // The states first (cheap, and most removals fail here), the constraints and the
        // schedule only for a plan that reaches the goal.
        // The entries before `without` apply as they did: their end state is kept
        // (`probe_state`, after `elim_prefix` entries).
        let state = core::mem::take(&mut self.child_state);
        let from = match without {
            Some(i) if i == self.elim_prefix => {
                let sw = state.len();
                state[..sw].copy_from_slice(&self.probe_state[..sw]);
                i
            }
            _ => {
                self.initial_state(state);
                0
            }
        };
        let reaches = self.simulate_entries(state, from);
        self.child_state = state;
        if !reaches {
            return None;
        }
        self.rebuild_entries()
    }

    /// The state before the plan's first entry in `probe_state` (the finished search no
    /// longer needs it).
    fn reset_prefix(&mut self) {
        let probe = core::mem::take(&mut self.probe_state);
        self.initial_state(probe);
        self.probe_state = probe;
        self.elim_prefix = 0;
    }

    /// The state kept in `probe_state` was overwritten (by a test's check between calls of
    /// [`Self::step`]): start it again from the initial state.
    pub(super) fn elimination_scratch_lost(&mut self) {
        if self.eliminating() {
            self.reset_prefix();
        }
    }

    /// Apply the plan's entries up to `i` to the state in `probe_state`: a removal tried at `i`
    /// leaves the plan before it as it was, and a kept one removes nothing before it, so the
    /// state is that of the entries before every later try of the pass.
    fn advance_prefix(&mut self, i: usize) {
        let probe = core::mem::take(&mut self.probe_state);
        for k in self.elim_prefix..i {
            let snap = self.regular.words[k];
            let mut running = [0u32; MAX_RUNNING];
            let rn = probe[self.running_at()] as usize;
            running[..rn].copy_from_slice(self.running(probe));
            self.load_protection(&running[..rn], true);
            // The plan applies: it was checked when it was kept.
            let _ = self.apply(probe, snap);
            self.load_protection(&running[..rn], false);
        }
        self.probe_state = probe;
        self.elim_prefix = i;
    }

    /// Mark entry `i` left out, and if it is a start, its action's end after it.
    fn skip_action(&mut self, i: usize) {
        let bits = self.elim_entries;
        self.regular.words[bits + i / 32] |= 1 << (i % 32);
        let snap = self.regular.words[i];
        if snap & 3 == START {
            let end = (snap >> 2) << 2 | END;
            if let Some(j) = (i + 1..self.elim_entries).find(|&j| self.regular.words[j] == end) {
                self.regular.words[bits + j / 32] |= 1 << (j % 32);
            }
        }
    }

    /// Apply the entries not skipped to `state` (the initial state) with the search's checks,
    /// skipping every action whose start (or compressed step) no longer applies. Whether every
    /// end applied and the goal holds at the end.
    fn simulate_entries(&mut self, state: &mut [u32], from: usize) -> bool {
        let entries = self.elim_entries;
        let bits = entries;
        for k in from..entries {
            if self.regular.words[bits + k / 32] & 1 << (k % 32) != 0 {
                continue;
            }
            let snap = self.regular.words[k];
            let mut running = [0u32; MAX_RUNNING];
            let rn = state[self.running_at()] as usize;
            running[..rn].copy_from_slice(self.running(state));
            self.load_protection(&running[..rn], true);
            let ok = self.apply(state, snap);
            self.load_protection(&running[..rn], false);
            if !ok {
                if snap & 3 == END {
                    return false;
                }
                self.skip_action(k);
            }
        }
        self.is_goal(state)
    }

    /// Load the entries not skipped as the loaded path: their steps, the constraints the search
    /// builds for them and the earliest times. The makespan, or None if inconsistent (or too
    /// long).
    fn rebuild_entries(&mut self) -> Option<u32> {
        self.loaded_node = NONE;
        self.truncatable = false;
        self.last_writer.iter_mut().for_each(|x| *x = 0);
        self.loaded_depth = 0;
        self.loaded_steps = 0;
        self.loaded_constraints = 0;
        self.writer_undo_len = 0;
        self.est_undo_len = 0;
        self.est_parent[0] = 0;
        let entries = self.elim_entries;
        let bits = entries;
        let mut steps = 0usize;
        for k in 0..entries {
            if self.regular.words[bits + k / 32] & 1 << (k % 32) != 0 {
                continue;
            }
            let snap = self.regular.words[k];
            let a = (snap >> 2) as usize;
            let kinds: &[u32] = match snap & 3 {
                START => &[0],
                END => &[1],
                _ => &[0, 1],
            };
            for &kind in kinds {
                let j = steps + 1;
                if j + 2 >= self.path_snap.len() {
                    return None;
                }
                let end = kind == 1;
                // An end's start: the latest start of its action before it.
                let start_step = if end {
                    (1..j)
                        .rev()
                        .find(|&s| self.path_snap[s] == (a as u32) << 1)?
                } else {
                    0
                };
                let mut cons = [Constraint {
                    before: 0,
                    after: 0,
                    lb: 0,
                    ub: 0,
                }; 64];
                let mut n = 0usize;
                self.step_constraints(j, a, end, start_step, &mut cons, &mut n)
                    .ok()?;
                let base = 3 * self.loaded_constraints;
                if base + 3 * n > self.path_constraints.len() {
                    return None;
                }
                for (c_i, c) in cons[..n].iter().enumerate() {
                    self.path_constraints[base + 3 * c_i] =
                        u32::from(c.before) | u32::from(c.after) << 16;
                    self.path_constraints[base + 3 * c_i + 1] = c.lb;
                    self.path_constraints[base + 3 * c_i + 2] = c.ub;
                }
                self.loaded_constraints += n;
                self.set_step(j, (a as u32) << 1 | kind);
                self.record_writes(j, a, end);
                steps = j;
                self.loaded_steps = steps;
            }
        }
        // The least schedule from zero: the STN raises the times it is given, and these hold
        // the last path's.
        self.est_parent[..=steps].iter_mut().for_each(|t| *t = 0);
        let wins = &self.path_window;
        let window = |k: usize| (wins[2 * k], wins[2 * k + 1]);
        let words = &self.path_constraints[..3 * self.loaded_constraints];
        earliest_words(steps, words, &window, self.est_parent).ok()?;
        Some(self.est_parent[..=steps].iter().copied().max().unwrap_or(0))
    }

    /// The makespan of the plan the search found, before the elimination (None if no
    /// elimination ran: the plan is the search's).
    pub fn makespan_before_elimination(&self) -> Option<u32> {
        (self.elim_phase != ELIM_NONE || self.stats.elimination_checks > 0)
            .then_some(self.elim_found_makespan)
    }

    /// Load the plan found as the loaded path: the eliminated plan if actions were removed,
    /// else the goal node's path. False if there is none.
    pub(super) fn load_plan(&mut self) -> bool {
        if self.goal_node == NONE {
            return false;
        }
        self.loaded_node = NONE;
        let ok = if self.elim_phase == ELIM_DONE {
            self.load_entries(None).is_some()
        } else {
            self.load_path(self.goal_node).is_ok()
        };
        if self.elim_phase == ELIM_DONE {
            self.loaded_node = NONE;
        }
        ok
    }
}
