//! What the planning loop and the control loop say to each other, and where their decisions go.
//!
//! MEXEC runs two loops (seed 003, "MEXEC Planner and Controller"; seed 000 IV.A): the planner
//! deliberates, the executive (the controller) acts every frame. They share no state: the
//! planner hands the executive [`Commit`]s, the executive tells the planner what became of them
//! ([`TaskReport`]) and what the state buffer measured ([`ToPlanner::Measured`]). Every
//! exchange is one of the messages below, so the two loops can run in different partitions
//! with a port in between (each message is serde-encoded; postcard keeps them small), or side
//! by side in one [`crate::Autonomy`], which hands each message over at once.
//!
//! The planner commits a task only while the executive has room for it by the planner's own
//! count (tasks it committed that have not finished); an executive that is full all the same
//! (a report still on its way) gives the commit back with [`ToPlanner::Returned`], and the
//! planner commits it again later. No message is lost without a count.
use serde::{Deserialize, Serialize};

use crate::telemetry::FailureKind;
use fsw_bridge::{CommandArgs, MissionTimeUs, Opcode, TelemetryEvent};

/// Where the core's decisions go. The firmware forwards them on the link
/// (`TargetToHost::CommandDispatch` and `TargetToHost::Telemetry`); tests record them.
pub trait Outputs {
    /// Send command `opcode(args)` with correlation id `id`; its response must come back through
    /// [`crate::Autonomy::on_command_response`] with the same id.
    fn dispatch(&mut self, id: u32, opcode: Opcode, args: &CommandArgs);
    /// Report a decision (task transition or plan modification; codes in [`crate::telemetry`]).
    fn telemetry(&mut self, event: TelemetryEvent);
}

/// A task handed from the planner to the executive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Commit {
    pub instance: u16,
    pub def: u8,
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
    /// The definition of the task this instance serves ([`crate::InstanceArg::Served`]: the
    /// one a template instance was added for, the failed one a restart replaces), or
    /// [`NO_SERVED`].
    pub served: u8,
    /// The start times the network's temporal constraints allow it, as the planner knew them
    /// at the commit (`None`: it has none): the executive does not dispatch it before the
    /// first, and fails it ([`crate::FailureKind::PreTimeout`]) once past the second.
    pub window: Option<(MissionTimeUs, MissionTimeUs)>,
}

/// [`Commit::served`] of an instance that serves no other task.
pub const NO_SERVED: u8 = u8::MAX;

/// What happened to a committed task, sent from the executive to the planner.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ReportKind {
    /// The task started (command accepted, or no-op begun).
    Started,
    Completed,
    Skipped,
    /// The task failed; `started` says whether its impacts had begun.
    Failed {
        kind: FailureKind,
        started: bool,
    },
}

/// One execution report.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TaskReport {
    pub instance: u16,
    pub kind: ReportKind,
    pub at: MissionTimeUs,
}

/// From the control loop (executive) to the planning loop (planner).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ToPlanner {
    /// Timeline `timeline` measured `value` (the timelines' integer form; unknown as
    /// [`crate::model::VALUE_UNKNOWN`]) at `at`. `replaces`: the control loop has put its
    /// measurements in order (its state table), so this one replaces the planner's even if
    /// that is newer (a value gone stale is unknown from the step that found it so); otherwise
    /// the planner keeps the newer of the two.
    Measured {
        timeline: u8,
        value: i64,
        at: MissionTimeUs,
        replaces: bool,
    },
    /// What became of a committed task.
    Report(TaskReport),
    /// The executive had no room for this commit: it is the planner's again (scheduled).
    Returned { instance: u16 },
}

/// From the planning loop (planner) to the control loop (executive).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ToExecutive {
    /// Take this task: it is the executive's from now on.
    Commit(Commit),
}
