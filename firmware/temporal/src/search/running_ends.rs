//! Temporal dead ends: a successor in which some running action can no longer end in time is
//! dropped before it is evaluated (issue 13, crew planning).
//!
//! A running action's end, whenever it comes, is ordered after the last writer of every fact
//! it reads or writes and after every reader since ([`Planner::step_constraints`]), and at
//! most its duration's upper bound after its start. Later steps only move those last writers
//! later (a write is itself ordered after the writer before it), so if the ends of the running
//! actions, appended to the successor's plan now (each ordered only after the plan's steps, not
//! after each other), make the temporal network inconsistent, so will they in every plan that
//! extends it: the successor is a dead end. The relaxation cannot see it: it has no time.
//!
//! Crew planning 16 (issue 13): the lookahead starts `conduct_payload_activity pa2_12 c1`
//! (60 minutes) and the search then runs through two days with it running; its end writes
//! `available c1`, whose last writer by then is a `post_sleep` 1,440 minutes later, so the end
//! can never come. Every state on that path had h 3 (end it, report, done), and the search
//! spent 400,000 expansions (349,513 of them repeated states) below such states without a
//! plan. A check per successor with actions running: one pass over the new constraints
//! ([`stn::earliest_extend`]), the whole network only where that moves an earlier step.
use super::*;

/// Which tasks' searches drop successors whose running actions can no longer end in time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunningEnds {
    /// None.
    Off,
    /// Tasks without windows (timed initial literals), the default: on pipesworld (deadlines)
    /// the check cut the evaluations of instances 2, 3, 4, 8 and 13 (by up to 4.6 times) but
    /// lost instance 22 (solved in 9,171 evaluations before, the 8 MiB arena full with it) and
    /// solved no new one (the README's "Running actions that can no longer end").
    WithoutWindows,
    /// Every task.
    Always,
}

/// Which tasks' searches check that their running actions can still end, unless set otherwise
/// ([`Planner::set_check_running_ends`]).
pub const CHECK_RUNNING_ENDS: RunningEnds = RunningEnds::WithoutWindows;

/// Most fact and variable writes of one successor's snaps the check records (a snap writing
/// more is not checked: no successor is dropped then).
const MAX_WRITES: usize = 64;

impl<'t, 'm> Planner<'t, 'm> {
    /// Which tasks' searches check that the running actions of every successor can still end
    /// in time ([`CHECK_RUNNING_ENDS`] otherwise; for measuring).
    pub fn set_check_running_ends(&mut self, which: RunningEnds) {
        self.check_running_ends = which;
    }

    /// Successors dropped because an action running in them could no longer end in time.
    pub fn late_ends(&self) -> u64 {
        self.late_ends
    }

    /// Whether the child (in `child_state`: snap `snap` appended to the loaded path as step
    /// `steps + 1`, and its end as `steps + 2` if compressed; its least schedule in
    /// `est_child[..=last]` and its constraints in `path_constraints[..count]`) can still end
    /// every action running in it. `parent_running` are the parent's running actions, in the
    /// order of `running_start`. Uses `est_child` and the path's scratch after `last`; leaves
    /// `last_writer` as it found it.
    pub(super) fn running_ends_schedulable(
        &mut self,
        snap: u32,
        parent_running: &[u32],
        last: usize,
        count: usize,
    ) -> bool {
        let on = match self.check_running_ends {
            RunningEnds::Off => false,
            RunningEnds::WithoutWindows => !self.task_has_windows,
            RunningEnds::Always => true,
        };
        if !on {
            return true;
        }
        let task = self.task;
        let a = (snap >> 2) as usize;
        let kind = snap & 3;
        let j = self.loaded_steps + 1;
        let at = self.running_at();
        let rn = self.child_state[at] as usize;
        if rn == 0 {
            return true;
        }
        let mut running = [0u32; MAX_RUNNING];
        running[..rn].copy_from_slice(&self.child_state[at + 1..at + 1 + rn]);
        if last + rn + 1 >= self.path_snap.len() {
            return true;
        }
        // The child's writes, as loading its path would record them.
        let mut saved = [(0usize, 0u32); MAX_WRITES];
        let mut n_saved = 0usize;
        let mut overflow = false;
        let writes: [(usize, bool); 2] = match kind {
            COMPRESSED => [(j, false), (j + 1, true)],
            END => [(j, true), (0, false)],
            _ => [(j, false), (0, false)],
        };
        for &(step, end) in writes.iter().filter(|w| w.0 > 0) {
            for_each_write(&task, a, end, &mut |id, _| {
                if n_saved < MAX_WRITES {
                    saved[n_saved] = (id, self.last_writer[id]);
                    n_saved += 1;
                    self.last_writer[id] = step as u32;
                } else {
                    overflow = true;
                }
            });
        }
        let ok =
            overflow || self.ends_consistent(a, kind, parent_running, &running[..rn], last, count);
        for &(id, w) in saved[..n_saved].iter().rev() {
            self.last_writer[id] = w;
        }
        if !ok {
            self.late_ends += 1;
        }
        ok
    }

    /// The check proper, with the child's writes in `last_writer`: each running action's end
    /// appended after step `last` with the constraints it would get there.
    fn ends_consistent(
        &mut self,
        a: usize,
        kind: u32,
        parent_running: &[u32],
        running: &[u32],
        last: usize,
        count: usize,
    ) -> bool {
        let j = self.loaded_steps + 1;
        let mut total = count;
        for (i, &r) in running.iter().enumerate() {
            let start_step = if kind == START && r as usize == a {
                j
            } else {
                match parent_running.binary_search(&r) {
                    Ok(p) => self.running_start[p] as usize,
                    Err(_) => return true,
                }
            };
            let mut cons = [Constraint {
                before: 0,
                after: 0,
                lb: 0,
                ub: 0,
            }; 64];
            let mut n = 0usize;
            // Ordered after the child's steps only: the ends are not ordered after each other.
            if self
                .step_constraints(last + 1, r as usize, true, start_step, &mut cons, &mut n)
                .is_err()
            {
                return true;
            }
            if 3 * (total + n) > self.path_constraints.len() {
                return true;
            }
            let step = last + 1 + i;
            for c in &cons[..n] {
                self.path_constraints[3 * total] = u32::from(c.before) | (step as u32) << 16;
                self.path_constraints[3 * total + 1] = c.lb;
                self.path_constraints[3 * total + 2] = c.ub;
                total += 1;
            }
        }
        for (i, &r) in running.iter().enumerate() {
            self.set_step(last + 1 + i, r << 1 | 1);
        }
        let steps = last + running.len();
        let wins = &self.path_window;
        let window = |k: usize| (wins[2 * k], wins[2 * k + 1]);
        let words = &self.path_constraints[..3 * total];
        stn::earliest_extend(
            last,
            steps,
            count,
            total,
            &|i| unpack(words, i),
            &window,
            self.est_child,
        ) || earliest_words(steps, words, &window, self.est_child).is_ok()
    }
}
