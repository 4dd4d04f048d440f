//! Action elimination after the search (Nakhost & Müller 2010, greedy action elimination),
//! for plan quality: the lookahead along the relaxed plan ([`super::lookahead`]) applies
//! relaxed-plan snaps the plan does not need (satellite 2: 25 actions where the search
//! without it found 13), and nothing else removes them.
//!
//! Anytime: the search's plan is there as soon as the search reaches the goal
//! ([`Planner::has_plan`], [`Planner::plan`]); the elimination then improves it in units of
//! [`Planner::step`]'s budget while the status stays [`Status::Searching`], and
//! [`Planner::plan`] at any unit boundary gives the best plan so far (the search's, or the
//! one with the removals kept so far), valid. A caller that stops stepping (a window, an
//! expansion or a time limit) takes that plan.
//!
//! When the search reaches the goal ([`Planner::plan_found`]), the plan's snaps (start, end or
//! compressed, as the nodes hold them) are copied to scratch. Then, in plan order, the plan
//! without an action is run from the state before it with the search's own checks
//! ([`Planner::apply`], the running actions' invariants protected), and every later action
//! whose start (or compressed step) no longer applies is dropped too; an end that no longer
//! applies after its start did refuses the removal. If the goal holds at the end, the snaps'
//! temporal constraints are rebuilt from the shorter path as the search builds them
//! ([`Planner::step_constraints`], `path.rs`), and the removal is kept if they are consistent
//! with a makespan no longer than before; the plan's schedule is then the shorter path's
//! earliest times.
//!
//! Units: a try is divided so that no unit is dearer than an expansion: the prefix state
//! kept and the run of the plan take at most [`ELIM_SNAPS_PER_UNIT`] snaps a unit, the
//! rebuild of the constraints a quarter of that ([`ELIM_REBUILD_WEIGHT`]: a long plan's
//! rebuild scans earlier steps for each write, about 2 to 4 M guest instructions on rovers 20
//! whole), and the schedule (the STN's earliest times) is a unit of its own. When the last pass removes nothing, the plan
//! with the removals kept is rebuilt the same way (unless the last kept removal's rebuild is
//! still loaded), so that [`Planner::plan`] then only reads it.
//!
//! Bounded: a pass tries each action of the plan once (a kept removal tries the action now at
//! the same place next); passes repeat until one removes nothing, so that no action of the
//! result can be removed (with the actions that then no longer apply), and every pass but the
//! last removes an action: at most n passes for n actions, two or three on the benchmarks.
//! The scratch is the regular open list's words (the plan's snaps and a bit each),
//! `probe_state` (the state before the removal tried, kept as a pass goes) and `child_state`
//! (the try's state), which the finished search no longer needs; if they cannot hold the plan
//! (a tiny arena), the plan is reported as found. A plan with no action removed is read from
//! its nodes as before, so it is the search's plan bit for bit. [`Planner::plan`] called
//! during a try's rebuild loads another path: that try starts again at the next unit.
use super::*;

/// Snaps a unit of the elimination applies at most (the prefix state and the try's run). A
/// snap applied costs about 3,700 guest instructions: 16 keep a unit well under an expansion
/// on the benchmarks (measured on the target in the README).
pub const ELIM_SNAPS_PER_UNIT: usize = 16;
/// A snap rebuilt counts as this many applied: its writes scan the steps since the last
/// writer, dearer on a long plan (16 rebuilt in a unit cost driverlog 14 about 17,000 ticks
/// on the target, as much as its costliest expansion), so a unit rebuilds 4.
pub const ELIM_REBUILD_WEIGHT: usize = 4;

/// Where the elimination stands.
const ELIM_NONE: u8 = 0;
const ELIM_RUNNING: u8 = 1;
/// Done, with at least one action removed: the plan is the snaps in scratch.
const ELIM_DONE: u8 = 2;

/// Where a try (or the final rebuild) stands within [`ELIM_RUNNING`].
const TRY_BEGIN: u8 = 0;
/// Running the plan without the action tried, from entry `at`, the state in `child_state`.
const TRY_RUN: u8 = 1;
/// Rebuilding the constraints of the entries not skipped, from entry `at`.
const TRY_BUILD: u8 = 2;
/// The rebuilt path's schedule.
const TRY_SCHEDULE: u8 = 3;
/// The plan with the removals kept, rebuilt before the end (entries from `at`).
const FINAL_BUILD: u8 = 4;
const FINAL_SCHEDULE: u8 = 5;

/// The elimination's state in the planner ([`Planner`]'s `elim`).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Elimination {
    phase: u8,
    sub: u8,
    /// The plan's snaps in scratch (regular open list's words), then a bit each.
    entries: usize,
    /// The next entry to try, and the entry tried.
    next: usize,
    tried: usize,
    /// The next entry to run or rebuild in the try under way, and the path's steps so far.
    at: usize,
    steps: usize,
    /// The plan's makespan now, and the search's plan's.
    makespan: u32,
    found_makespan: u32,
    /// `stats.eliminated` when the pass began.
    pass_base: u64,
    /// Entries applied to the state in `probe_state`.
    prefix: usize,
    /// The loaded path is the plan with the removals kept (the last kept try's rebuild, or
    /// the final one).
    loaded: bool,
}

impl Elimination {
    pub(super) const fn new() -> Self {
        Self {
            phase: ELIM_NONE,
            sub: TRY_BEGIN,
            entries: 0,
            next: 0,
            tried: 0,
            at: 0,
            steps: 0,
            makespan: 0,
            found_makespan: 0,
            pass_base: 0,
            prefix: 0,
            loaded: false,
        }
    }
}

impl<'t, 'm> Planner<'t, 'm> {
    /// The search reached the goal at `node`: the plan is found (and [`Self::plan`] gives it);
    /// its unneeded actions are eliminated in the units after, if the configuration asks for
    /// it ([`PlannerConfig::eliminate`]), with the status [`Status::Searching`] until done.
    pub(super) fn plan_found(&mut self, node: u32) {
        self.goal_node = node;
        self.lookahead_node = NONE;
        if self.config.eliminate && self.begin_elimination() {
            self.elim.phase = ELIM_RUNNING;
            self.status = Status::Searching;
        } else {
            self.status = Status::Solved;
        }
    }

    /// Whether an elimination is under way ([`Self::step`] goes on with it).
    pub(super) fn eliminating(&self) -> bool {
        self.elim.phase == ELIM_RUNNING
    }

    /// Whether the search has found a plan ([`Self::plan`] gives it, or the best one so far
    /// while the elimination improves it).
    pub fn has_plan(&self) -> bool {
        self.goal_node != NONE
    }

    /// Whether the elimination after the search is under way: the status is
    /// [`Status::Searching`] with a plan already found ([`Self::has_plan`]).
    pub fn improving(&self) -> bool {
        self.eliminating()
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
        let makespan = self.est_parent[..=self.loaded_steps]
            .iter()
            .copied()
            .max()
            .unwrap_or(0);
        self.elim = Elimination {
            entries: count,
            makespan,
            found_makespan: makespan,
            pass_base: self.stats.eliminated,
            ..Elimination::new()
        };
        self.reset_prefix();
        true
    }

    /// One unit of the elimination: at most [`ELIM_SNAPS_PER_UNIT`] snaps applied or rebuilt,
    /// or a schedule.
    pub(super) fn eliminate_step(&mut self) {
        let mut left = ELIM_SNAPS_PER_UNIT;
        loop {
            match self.elim.sub {
                TRY_BEGIN => {
                    if !self.begin_try(&mut left) {
                        return;
                    }
                }
                TRY_RUN => {
                    if !self.run_try(&mut left) {
                        return;
                    }
                }
                TRY_BUILD | FINAL_BUILD => {
                    if !self.build_some(&mut left) {
                        return;
                    }
                }
                _ => {
                    // The schedule: a unit of its own.
                    if left < ELIM_SNAPS_PER_UNIT {
                        return;
                    }
                    self.schedule();
                    return;
                }
            }
        }
    }

    /// Find the next action to try and start its try (the prefix state kept first); at the
    /// end of a pass, another pass or the end. Whether the unit goes on.
    fn begin_try(&mut self, left: &mut usize) -> bool {
        let entries = self.elim.entries;
        let mut i = self.elim.next;
        while i < entries && self.regular.words[i] & 3 == END {
            i += 1;
        }
        if i >= entries {
            if self.stats.eliminated > self.elim.pass_base {
                // A removal can make an action tried before removable: another pass, until
                // one removes nothing (each pass but the last removes an action).
                self.elim.pass_base = self.stats.eliminated;
                self.elim.next = 0;
                self.reset_prefix();
                return true;
            }
            if self.stats.eliminated == 0 {
                self.finish(ELIM_NONE);
            } else if self.elim.loaded {
                self.finish(ELIM_DONE);
            } else {
                self.clear_skips();
                self.begin_build(FINAL_BUILD);
                return true;
            }
            return false;
        }
        if !self.advance_prefix(i, left) {
            return false;
        }
        self.stats.elimination_checks += 1;
        self.clear_skips();
        self.skip_action(i);
        let sw = self.child_state.len();
        self.child_state.copy_from_slice(&self.probe_state[..sw]);
        self.elim.tried = i;
        self.elim.at = i;
        self.elim.sub = TRY_RUN;
        true
    }

    /// The elimination ends with `phase` ([`ELIM_NONE`]: the search's plan).
    fn finish(&mut self, phase: u8) {
        self.elim.phase = phase;
        self.elim.sub = TRY_BEGIN;
        if phase == ELIM_NONE {
            self.elim.loaded = false;
        }
        self.status = Status::Solved;
    }

    /// The try under way is refused: the next action is tried.
    fn refuse_try(&mut self) {
        self.elim.next = self.elim.tried + 1;
        self.elim.sub = TRY_BEGIN;
    }

    /// Run the plan without the action tried, up to `left` snaps. Whether the unit goes on.
    fn run_try(&mut self, left: &mut usize) -> bool {
        let entries = self.elim.entries;
        let bits = entries;
        let state = core::mem::take(&mut self.child_state);
        let mut k = self.elim.at;
        let mut ended = false;
        while k < entries && *left > 0 {
            if self.regular.words[bits + k / 32] & 1 << (k % 32) != 0 {
                k += 1;
                continue;
            }
            *left -= 1;
            let snap = self.regular.words[k];
            let mut running = [0u32; MAX_RUNNING];
            let rn = state[self.running_at()] as usize;
            running[..rn].copy_from_slice(self.running(state));
            self.load_protection(&running[..rn], true);
            let ok = self.apply(state, snap);
            self.load_protection(&running[..rn], false);
            if !ok {
                if snap & 3 == END {
                    ended = true;
                    break;
                }
                self.skip_action(k);
            }
            k += 1;
        }
        let goal = k >= entries && !ended && self.is_goal(state);
        self.child_state = state;
        self.elim.at = k;
        if ended || (k >= entries && !goal) {
            self.refuse_try();
            return *left > 0;
        }
        if k < entries {
            return false;
        }
        // The goal holds: the constraints and the schedule of the shorter plan.
        self.begin_build(TRY_BUILD);
        *left > 0
    }

    /// Start rebuilding the entries not skipped as the loaded path.
    fn begin_build(&mut self, sub: u8) {
        self.loaded_node = NONE;
        self.truncatable = false;
        self.last_writer.iter_mut().for_each(|x| *x = 0);
        self.loaded_depth = 0;
        self.loaded_steps = 0;
        self.loaded_constraints = 0;
        self.writer_undo_len = 0;
        self.est_undo_len = 0;
        self.est_parent[0] = 0;
        self.elim.loaded = false;
        self.elim.at = 0;
        self.elim.steps = 0;
        self.elim.sub = sub;
    }

    /// Rebuild up to `left` entries of the path. Whether the unit goes on.
    fn build_some(&mut self, left: &mut usize) -> bool {
        let final_build = self.elim.sub == FINAL_BUILD;
        let entries = self.elim.entries;
        let to = entries.min(self.elim.at + *left / ELIM_REBUILD_WEIGHT);
        let from = self.elim.at;
        let mut steps = self.elim.steps;
        let built = self.rebuild_range(from, to, &mut steps);
        *left = left.saturating_sub((to - from) * ELIM_REBUILD_WEIGHT);
        self.elim.at = to;
        self.elim.steps = steps;
        if !built {
            if final_build {
                // The plan kept was checked when it was kept; a rebuild that fails now
                // (cannot happen) leaves the search's plan.
                self.finish(ELIM_NONE);
                self.stats.eliminated = 0;
            } else {
                self.refuse_try();
                return *left > 0;
            }
            return false;
        }
        if to < entries || *left < ELIM_REBUILD_WEIGHT {
            // The rest (or the schedule) in the next unit.
            if to >= entries {
                self.elim.sub = if final_build {
                    FINAL_SCHEDULE
                } else {
                    TRY_SCHEDULE
                };
            }
            return false;
        }
        self.elim.sub = if final_build {
            FINAL_SCHEDULE
        } else {
            TRY_SCHEDULE
        };
        *left > 0
    }

    /// The rebuilt path's schedule; a try kept or refused, or the end.
    fn schedule(&mut self) {
        let makespan = self.least_schedule();
        if self.elim.sub == FINAL_SCHEDULE {
            match makespan {
                Some(_) => {
                    self.elim.loaded = true;
                    self.finish(ELIM_DONE);
                }
                None => {
                    self.finish(ELIM_NONE);
                    self.stats.eliminated = 0;
                }
            }
            return;
        }
        match makespan {
            Some(m) if m <= self.elim.makespan => self.keep_try(m),
            _ => self.refuse_try(),
        }
    }

    /// Keep the try's removal: the plan is the entries not skipped, and the loaded path is
    /// its rebuild.
    fn keep_try(&mut self, makespan: u32) {
        let entries = self.elim.entries;
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
        self.elim.entries = kept;
        self.elim.makespan = makespan;
        self.elim.loaded = true;
        // The action now at the place tried is next; the prefix state still holds.
        self.elim.next = self.elim.tried;
        self.elim.sub = TRY_BEGIN;
    }

    /// Zero the bits of the entries left out.
    fn clear_skips(&mut self) {
        let entries = self.elim.entries;
        for w in 0..entries.div_ceil(32) {
            self.regular.words[entries + w] = 0;
        }
    }

    /// The state before the plan's first entry in `probe_state` (the finished search no
    /// longer needs it).
    fn reset_prefix(&mut self) {
        let probe = core::mem::take(&mut self.probe_state);
        self.initial_state(probe);
        self.probe_state = probe;
        self.elim.prefix = 0;
    }

    /// The scratch was overwritten (a test's check between calls of [`Self::step`] uses
    /// `probe_state` and loads paths): the prefix state from the initial state again, the
    /// try under way from its beginning, and the plan kept no longer loaded.
    pub(super) fn elimination_scratch_lost(&mut self) {
        self.elim.loaded = false;
        if self.eliminating() {
            self.reset_prefix();
            self.elimination_path_lost();
        }
    }

    /// Another path was loaded ([`Self::plan`] during the elimination): a try under way
    /// starts again (the prefix state holds), and so does the final rebuild.
    fn elimination_path_lost(&mut self) {
        if !self.eliminating() {
            return;
        }
        self.elim.loaded = false;
        match self.elim.sub {
            TRY_BEGIN => {}
            FINAL_BUILD | FINAL_SCHEDULE => {
                // The pass found nothing to remove: the next unit ends it again.
                self.elim.next = self.elim.entries;
                self.elim.sub = TRY_BEGIN;
            }
            _ => {
                self.elim.next = self.elim.tried;
                self.elim.sub = TRY_BEGIN;
            }
        }
    }

    /// Apply the plan's entries up to `i` to the state in `probe_state`, at most `left` of
    /// them: a removal tried at `i` leaves the plan before it as it was, and a kept one
    /// removes nothing before it, so the state is that of the entries before every later try
    /// of the pass. Whether it reached `i`.
    fn advance_prefix(&mut self, i: usize, left: &mut usize) -> bool {
        let probe = core::mem::take(&mut self.probe_state);
        let mut k = self.elim.prefix;
        while k < i && *left > 0 {
            let snap = self.regular.words[k];
            let mut running = [0u32; MAX_RUNNING];
            let rn = probe[self.running_at()] as usize;
            running[..rn].copy_from_slice(self.running(probe));
            self.load_protection(&running[..rn], true);
            // The plan applies: it was checked when it was kept.
            let _ = self.apply(probe, snap);
            self.load_protection(&running[..rn], false);
            k += 1;
            *left -= 1;
        }
        self.probe_state = probe;
        self.elim.prefix = k;
        k >= i
    }

    /// Mark entry `i` left out, and if it is a start, its action's end after it.
    fn skip_action(&mut self, i: usize) {
        let bits = self.elim.entries;
        self.regular.words[bits + i / 32] |= 1 << (i % 32);
        let snap = self.regular.words[i];
        if snap & 3 == START {
            let end = (snap >> 2) << 2 | END;
            if let Some(j) = (i + 1..self.elim.entries).find(|&j| self.regular.words[j] == end) {
                self.regular.words[bits + j / 32] |= 1 << (j % 32);
            }
        }
    }

    /// Append the entries `from..to` not skipped to the loaded path (`steps` so far): their
    /// steps and the constraints the search builds for them. False if too long.
    fn rebuild_range(&mut self, from: usize, to: usize, steps: &mut usize) -> bool {
        let bits = self.elim.entries;
        for k in from..to {
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
                let j = *steps + 1;
                if j + 2 >= self.path_snap.len() {
                    return false;
                }
                let end = kind == 1;
                // An end's start: the latest start of its action before it.
                let start_step = if end {
                    match (1..j).rev().find(|&s| self.path_snap[s] == (a as u32) << 1) {
                        Some(s) => s,
                        None => return false,
                    }
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
                if self
                    .step_constraints(j, a, end, start_step, &mut cons, &mut n)
                    .is_err()
                {
                    return false;
                }
                let base = 3 * self.loaded_constraints;
                if base + 3 * n > self.path_constraints.len() {
                    return false;
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
                *steps = j;
                self.loaded_steps = j;
            }
        }
        true
    }

    /// The least schedule of the loaded path from zero (the STN raises the times it is
    /// given, and these hold the last path's): its makespan, or None if inconsistent.
    fn least_schedule(&mut self) -> Option<u32> {
        let steps = self.loaded_steps;
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
        (self.elim.phase != ELIM_NONE || self.stats.elimination_checks > 0)
            .then_some(self.elim.found_makespan)
    }

    /// Load the best plan so far as the loaded path: the plan with the removals kept if any
    /// (already loaded after the elimination, or rebuilt whole here), else the goal node's
    /// path. False if there is none. During the elimination, a try under way starts again.
    pub(super) fn load_plan(&mut self) -> bool {
        if self.goal_node == NONE {
            return false;
        }
        if self.stats.eliminated > 0 && self.elim.loaded {
            return true;
        }
        self.elimination_path_lost();
        self.loaded_node = NONE;
        if self.stats.eliminated == 0 {
            return self.load_path(self.goal_node).is_ok();
        }
        // Removals kept, not loaded: rebuilt whole (during the elimination, between tries:
        // the next try loads its own path).
        self.clear_skips();
        self.begin_build(TRY_BEGIN);
        let mut steps = 0;
        let ok =
            self.rebuild_range(0, self.elim.entries, &mut steps) && self.least_schedule().is_some();
        self.elim.loaded = ok;
        ok
    }
}
