//! Opportunistic goals (seed 001, section 5.3): a goal that arrived as an opportunity (a
//! science target noticed on the way) must not cost the mission its plan. Planning first tries
//! for every goal; when an attempt ends without a plan (no plan exists, the arena ran out, or
//! the attempt's expansion budget is spent), the next opportunistic goal is dropped and planning
//! is tried again without it, until a plan comes or none are left to drop.
#![deny(clippy::indexing_slicing)]

use crate::heuristic::goal_dropped;
use crate::search::{PlannedAction, Planner, PlannerConfig, Region, Stats, Status};
use crate::task::Task;

/// How planning with opportunistic goals ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Outcome {
    /// The plan written to `out`: (actions, makespan), if one was found.
    pub plan: Option<(usize, u32)>,
    /// The goals dropped (bit i: the task's i-th goal fact), as in
    /// [`PlannerConfig::dropped_goals`].
    pub dropped: u64,
    /// Planning attempts made (1 when every goal was kept).
    pub attempts: u32,
    /// The last attempt's status and statistics.
    pub status: Status,
    pub stats: Stats,
}

impl Outcome {
    /// Whether the task's `i`-th goal fact was dropped.
    pub fn dropped(&self, i: usize) -> bool {
        goal_dropped(self.dropped, i)
    }
}

/// Plans `task` in `arena`, dropping the goals `opportunistic` names (indices into the task's
/// goal facts, below 64), in that order, one per failed attempt; each attempt may expand at
/// most `expansions` states. The plan goes to `out` (see [`Planner::plan`]).
pub fn plan_dropping(
    task: Task<'_>,
    arena: &mut [u32],
    config: PlannerConfig,
    opportunistic: &[usize],
    expansions: u64,
    out: &mut [PlannedAction],
) -> Outcome {
    let mut dropped = config.dropped_goals;
    let mut attempts = 0u32;
    let mut next = opportunistic.iter().filter(|&&g| g < 64);
    loop {
        attempts += 1;
        let cfg = PlannerConfig {
            dropped_goals: dropped,
            ..config
        };
        let (status, stats, plan) = match Planner::new(task, &mut *arena, cfg) {
            Ok(mut planner) => {
                let mut status = planner.status();
                while status == Status::Searching && planner.stats().expanded < expansions {
                    let left = expansions - planner.stats().expanded;
                    status = planner.step(u32::try_from(left.min(4096)).unwrap_or(4096));
                }
                let plan = (status == Status::Solved)
                    .then(|| planner.plan(out))
                    .flatten();
                (status, planner.stats(), plan)
            }
            Err(_) => (Status::OutOfMemory(Region::Tables), Stats::default(), None),
        };
        let give_up = matches!(status, Status::Solved | Status::OutOfMemory(Region::Tables));
        match next.next() {
            Some(&g) if !give_up => dropped |= 1 << g,
            _ => {
                return Outcome {
                    plan,
                    dropped,
                    attempts,
                    status,
                    stats,
                }
            }
        }
    }
}
