//! The plan: task instances the planner knows about, with their placement and life-cycle state.
//! The timeline library projects their impacts; the planner edits them; the checkpoint saves
//! them.
use serde::{Deserialize, Serialize};

use crate::model::TaskNetwork;
use crate::telemetry::TaskState;
use fsw_bridge::MissionTimeUs;

/// How an instance came to be in the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Origin {
    /// Requested by the ground (its instance id is the ground id).
    Requested,
    /// Added from a template to enable or repair the instance named.
    Added { for_instance: u16 },
    /// Restarted (contingency) after the failure of the instance named.
    Restarted { of_instance: u16 },
}

/// One task instance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlanEntry {
    /// Telemetry id: the ground id for requested tasks, planner-given ids from
    /// [`crate::FIRST_INSTANCE_ID`] for the others.
    pub instance: u16,
    /// Index of its definition in the network.
    pub def: u8,
    pub state: TaskState,
    /// Planned start, or the actual start once started.
    pub start: MissionTimeUs,
    /// Planned end, or the actual end once finished.
    pub end: MissionTimeUs,
    /// Earliest start allowed for this instance.
    pub earliest_start: MissionTimeUs,
    /// Latest start allowed for this instance.
    pub latest_start: MissionTimeUs,
    /// True once the executive reported the start.
    pub started: bool,
    /// True for requested tasks: scheduling is retried every cycle until the window closes.
    /// Added and restarted instances are given up as soon as they cannot be placed.
    pub persistent: bool,
    pub origin: Origin,
}

/// The span over which an instance's impacts apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Contribution {
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
    /// Whether POST impacts apply (not for aborted or failed tasks).
    pub post: bool,
}

impl PlanEntry {
    /// The impacts this instance has (or is projected to have) on timelines.
    pub fn contribution(&self) -> Option<Contribution> {
        let span = |post| {
            Some(Contribution {
                start: self.start,
                end: self.end,
                post,
            })
        };
        match self.state {
            TaskState::Unscheduled | TaskState::Deleted | TaskState::Skipped => None,
            TaskState::Failed(_) => {
                if self.started {
                    span(false)
                } else {
                    None
                }
            }
            _ => span(true),
        }
    }

    /// Whether the planner may still change this instance.
    pub fn is_uncommitted(&self) -> bool {
        matches!(self.state, TaskState::Unscheduled | TaskState::Scheduled)
    }

    /// Ground id of its definition.
    pub fn template_id(&self, network: &TaskNetwork) -> u16 {
        network.task(self.def).map(|t| t.id).unwrap_or(u16::MAX)
    }
}
