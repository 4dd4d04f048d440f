//! Setting the search up in pieces (issue 13, the last gap of the planner on the target):
//! [`Planner::new_deferred`] only lays the arena out; [`Planner::set_up_step`] then does the
//! rest one piece at a time, so that a caller with a CPU budget per window (the planner
//! partition) can stop between pieces and go on in its next window, as it does between
//! expansions. [`Planner::new`] runs every piece at once.
//!
//! The pieces, in order: the duplicate table's buckets emptied [`BUCKET_WORDS_PER_PIECE`] at a
//! time; the relaxation's precondition and add indexes; the compression-safety marks; the
//! root's state and heuristic value; the root's successors pushed (the two halves of about one
//! expansion's work).
//! Each is a fixed amount of work for a task; none depends on the clock, so the search that
//! follows is the same however the pieces were spread over windows.
use super::*;

/// Buckets of the duplicate table emptied per piece (16 Ki words: on the 750, about 33,000
/// guest instructions).
pub const BUCKET_WORDS_PER_PIECE: usize = 16 * 1024;

/// The next piece of the set-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum SetUp {
    /// Empty the buckets from this index on.
    Buckets(usize),
    /// Build the relaxation's indexes.
    Index,
    /// Mark the compression-safe actions.
    Compression,
    /// Evaluate the root.
    Root,
    /// Push the successors of the root (node `root`, heuristic `h`; its state is in
    /// `child_state`, which nothing else touches before).
    RootSuccessors { root: u32, h: u32 },
    /// Set up: the search may step.
    Done,
}

impl<'t, 'm> Planner<'t, 'm> {
    /// A planner laid out in `arena` for `task`, not set up yet: call
    /// [`Self::set_up_step`] until it returns false (or [`Self::step`], which finishes the
    /// set-up first). The arena's layout, and so the search, is [`Self::new`]'s.
    pub fn new_deferred(
        task: Task<'t>,
        arena: &'m mut [u32],
        config: PlannerConfig,
    ) -> Result<Self, Region> {
        Self::lay_out(task, arena, config)
    }

    /// The set-up is not finished: [`Self::set_up_step`] has pieces left.
    pub fn setting_up(&self) -> bool {
        self.set_up != SetUp::Done
    }

    /// The next piece of the set-up empties buckets: a small, fixed amount of work (the others,
    /// the indexes, the compression marks and the root, each cost up to about an expansion).
    pub fn next_set_up_piece_is_small(&self) -> bool {
        matches!(self.set_up, SetUp::Buckets(_))
    }

    /// Do the next piece of the set-up; true while pieces remain after it.
    pub fn set_up_step(&mut self) -> bool {
        match self.set_up {
            SetUp::Buckets(from) => {
                let end = from
                    .saturating_add(BUCKET_WORDS_PER_PIECE)
                    .min(self.buckets.len());
                if let Some(part) = self.buckets.get_mut(from..end) {
                    part.iter_mut().for_each(|b| *b = NONE);
                }
                self.set_up = if end >= self.buckets.len() {
                    SetUp::Index
                } else {
                    SetUp::Buckets(end)
                };
            }
            SetUp::Index => {
                let config = self.config;
                self.relax
                    .build_index(&self.task, config.relaxed_cost, config.dropped_goals);
                self.set_up = SetUp::Compression;
            }
            SetUp::Compression => {
                self.mark_compression_safe();
                self.task_has_windows = Self::windows_in(&self.task);
                self.set_up = SetUp::Root;
            }
            SetUp::Root => {
                self.set_up = match self.start_root() {
                    Some((root, h)) => SetUp::RootSuccessors { root, h },
                    None => SetUp::Done,
                };
            }
            SetUp::RootSuccessors { root, h } => {
                self.set_up = SetUp::Done;
                if let Err(r) = self.push_successors(root, h) {
                    self.status = Status::OutOfMemory(r);
                }
            }
            SetUp::Done => {}
        }
        self.setting_up()
    }
}
