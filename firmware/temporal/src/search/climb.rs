//! The first search commits to its best node instead of giving way (issue 13: driverlog 16-20).
//!
//! The first search (the preferred list ordered, the lookahead along the relaxed plan) gets
//! most of the way on driverlog 16-20 in a few hundred evaluations (driverlog 20 from h 79 to
//! h 10 in 132 evaluations, 18 to h 14 in 463, 17 to h 20 in 248) and then stalls on a
//! plateau for [`super::ORDERED_RESTART_AFTER`] expansions; the searches after it begin again
//! from the root and spend tens of thousands of evaluations. Here the first search, after
//! [`FIRST_COMMIT_AFTER`] expansions without a new best h (fewer than the restart's limit),
//! keeps only the path to its latest node of the lowest h and goes on from it
//! ([`super::commit`]: a local search's restart, as the last resort does), looking ahead as
//! before. A first search that has made no node as good as its best h since its last commit
//! cannot commit again ([`Planner::commit_to_best`]): it stalls on to the restart's limit and
//! gives way to the second search from the root, as without this, so the portfolio stays as
//! complete as it was (driverlog 16 and 19 go that way: their first search commits down to
//! h 6 and 8 and is trapped there). An empty open list after a commit proves nothing either:
//! the second search starts then.
//!
//! Not in a task with windows (timed initial literals, a replan's completions that must start
//! at once), as the lookahead: a committed prefix may have closed a window the rest of the
//! plan needs; the rover mission's decisions stay as they were.
//!
//! The limit is measured (the README's "The first search commits"): satellite and rovers never
//! stall 50 expansions in the first search (satellite 20 does stall 25, and commits there cost
//! it 1,600 times its evaluations); driverlog 2-14, which stall on small plateaus, mostly take
//! fewer evaluations with it and some longer plans.
use super::*;

/// Expansions without a new best h after which the first search commits to its latest node of
/// the lowest h (`u64::MAX`: never; it then gives way after [`ORDERED_RESTART_AFTER`] only).
pub const FIRST_COMMIT_AFTER: u64 = 50;

impl<'t, 'm> Planner<'t, 'm> {
    /// Whether the first search, `stalled` expansions without a new best h, committed to its
    /// best node now ([`FIRST_COMMIT_AFTER`]).
    pub(super) fn first_search_commits(&mut self, stalled: u64) -> bool {
        self.phase == 0
            && stalled > self.first_commit_after
            && !self.task_has_windows
            && self.commit_to_best()
    }

    /// Commit the first search after `expansions` without a new best h instead of
    /// [`FIRST_COMMIT_AFTER`] (for measuring; before the first [`Self::step`]).
    pub fn set_first_commit_after(&mut self, expansions: u64) {
        self.first_commit_after = expansions;
    }

    /// Let the first search give way after `expansions` without a new best h instead of
    /// [`ORDERED_RESTART_AFTER`] (for measuring; the later searches' limits stay).
    pub fn set_first_gives_way_after(&mut self, expansions: u64) {
        self.ordered_restart_after = expansions;
    }
}
