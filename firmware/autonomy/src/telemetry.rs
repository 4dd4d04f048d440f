//! Codes the autonomy core puts in [`fsw_bridge::TelemetryEvent`]s. They are part of the
//! interface with the host: append new codes, never renumber.
//!
//! * `TaskTransition { task, from, to, at }`: `task` is the instance id (the ground id for a
//!   requested task, [`crate::FIRST_INSTANCE_ID`] and up for instances the planner added or
//!   restarted), `from`/`to` are [`TaskState::code`]s, `at` the mission time of the decision.
//! * `PlanModification { kind, task, template, at }`: `kind` is a [`PlanModificationKind`] code
//!   or a [`gave_up_code`] (the planner stopped responding to one cause of failure of a task
//!   definition), `task` the instance concerned, `template` the ground id of its task
//!   definition, `at` the mission time of the decision.
//! * `StateStale { key, measured_at, at }`: the value of state key `key`, measured at
//!   `measured_at`, was older than its timeline's staleness bound at the step at `at`; the
//!   core reads it as unknown from then until a newer measurement arrives (once per
//!   measurement).
use serde::{Deserialize, Serialize};

/// Why a task failed. The code is `FailureKind as u8`; contingencies select kinds with the bit
/// `1 << code`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum FailureKind {
    /// PRE constraints or the start condition did not hold within the wait timeout.
    PreTimeout = 0,
    /// The command response did not arrive within the response timeout.
    ResponseTimeout = 1,
    /// The subsystem answered `Failed`.
    CommandFailed = 2,
    /// The subsystem answered `Rejected`.
    CommandRejected = 3,
    /// A MAINTAIN constraint or the maintain condition stopped holding: the task was aborted.
    MaintainViolation = 4,
    /// The planner found no valid interval for it (and had no permitted repair).
    Unschedulable = 5,
    /// The command completed (response Ok, duration over) but a measured timeline the task's
    /// POST assignment names does not hold the assigned value: "completed with the wrong
    /// state" (a GNC that answers Ok without reaching the commanded attitude).
    PostConditionNotMet = 6,
    /// The task was running (its command dispatched) when the last checkpoint before a reset
    /// was taken: the reset cut it short, and whatever its subsystem did afterwards is unknown.
    /// Reported at the first step after the restore when no MAINTAIN constraint is violated
    /// then (a violation is reported as [`FailureKind::MaintainViolation`], seed 003).
    Interrupted = 7,
}

impl FailureKind {
    /// Number of failure kinds (codes `0..COUNT`).
    pub const COUNT: usize = 8;

    /// Contingency mask selecting every failure kind.
    pub const ANY: u8 = 0xff;

    /// Every kind, in code order.
    pub const ALL: [FailureKind; Self::COUNT] = [
        Self::PreTimeout,
        Self::ResponseTimeout,
        Self::CommandFailed,
        Self::CommandRejected,
        Self::MaintainViolation,
        Self::Unschedulable,
        Self::PostConditionNotMet,
        Self::Interrupted,
    ];

    /// Causes the executive can answer by dispatching the command again (`max_retries`):
    /// the command itself went wrong.
    pub const RETRYABLE: u8 = Self::ResponseTimeout.bit()
        | Self::CommandFailed.bit()
        | Self::CommandRejected.bit()
        | Self::PostConditionNotMet.bit();

    /// Causes the planner answers with a new instance of the task (`max_repairs`: a restart,
    /// move or add-template contingency, or adding a template again). Not
    /// [`FailureKind::Unschedulable`]: nothing was commanded, and the planner never restarts
    /// an instance it could not place.
    pub const REPAIRABLE: u8 = Self::ANY & !Self::Unschedulable.bit();

    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }

    pub fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0 => Self::PreTimeout,
            1 => Self::ResponseTimeout,
            2 => Self::CommandFailed,
            3 => Self::CommandRejected,
            4 => Self::MaintainViolation,
            5 => Self::Unschedulable,
            6 => Self::PostConditionNotMet,
            7 => Self::Interrupted,
            _ => return None,
        })
    }
}

/// Life cycle of a task instance, shared by the planner (first three) and the executive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TaskState {
    /// Known to the planner, not placed. Code 0.
    Unscheduled,
    /// Placed by the planner. Code 1.
    Scheduled,
    /// Handed to the executive (the planner may no longer change it). Code 2.
    Committed,
    /// Start time reached; waiting for PRE constraints and the start condition. Code 3.
    WaitingPre,
    /// Command sent; waiting for its response. Code 4.
    Dispatched,
    /// Started (response Ok, or a no-op task); MAINTAIN constraints monitored. Code 5.
    Running,
    /// Ran for its duration with every MAINTAIN constraint holding. Code 6.
    Completed,
    /// Skip condition held at the start time. Code 7.
    Skipped,
    /// Removed from the plan by the planner. Code 8.
    Deleted,
    /// Failed; code `0x10 + FailureKind` (0x14 is the clean abort on a MAINTAIN violation,
    /// 0x16 a completion with the wrong state, 0x17 a task a reset interrupted).
    Failed(FailureKind),
}

impl TaskState {
    pub const fn code(self) -> u8 {
        match self {
            Self::Unscheduled => 0,
            Self::Scheduled => 1,
            Self::Committed => 2,
            Self::WaitingPre => 3,
            Self::Dispatched => 4,
            Self::Running => 5,
            Self::Completed => 6,
            Self::Skipped => 7,
            Self::Deleted => 8,
            Self::Failed(kind) => 0x10 + kind as u8,
        }
    }

    pub fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0 => Self::Unscheduled,
            1 => Self::Scheduled,
            2 => Self::Committed,
            3 => Self::WaitingPre,
            4 => Self::Dispatched,
            5 => Self::Running,
            6 => Self::Completed,
            7 => Self::Skipped,
            8 => Self::Deleted,
            c if c >= 0x10 => Self::Failed(FailureKind::from_code(c - 0x10)?),
            _ => return None,
        })
    }

    /// Whether the instance is finished (no further transitions).
    pub const fn is_terminal(self) -> bool {
        matches!(
            self,
            Self::Completed | Self::Skipped | Self::Deleted | Self::Failed(_)
        )
    }
}

/// Plan modifications reported in `PlanModification.kind`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum PlanModificationKind {
    /// A template instance was added (repair, enabling a task, or an AddTemplate contingency).
    Add = 1,
    /// A task was deleted.
    Delete = 2,
    /// An uncommitted task was moved to a new start time.
    Move = 3,
    /// A failed task was restarted as a new instance (contingency Restart or Move).
    Restart = 4,
    /// A network was loaded; `task` is 0, `template` the low 16 bits of the network id.
    NetworkLoaded = 5,
    /// The plan was restored from a warm-restart checkpoint; `task` is 0, `template` the low 16
    /// bits of the checkpoint sequence number.
    Restored = 6,
}

/// First code of the "gave up" family of `PlanModification.kind`s: `GAVE_UP_BASE + cause`
/// (a [`FailureKind`] code, so 0x20..=0x27). The planner reports it once, when a failure of
/// cause `cause` of instance `task` (definition `template`) takes the consecutive failures of
/// that definition for that cause over the definition's `max_repairs` bound: from then on the
/// planner neither restarts, moves nor re-adds that definition (until an instance of it
/// completes). The failures counted are `max_repairs[cause] + 1`.
pub const GAVE_UP_BASE: u8 = 0x20;

/// The `PlanModification.kind` reporting that the planner gave up on `cause`.
pub const fn gave_up_code(cause: FailureKind) -> u8 {
    GAVE_UP_BASE + cause as u8
}

/// The cause of a "gave up" `PlanModification.kind`, or None for any other kind.
pub fn gave_up_cause(kind: u8) -> Option<FailureKind> {
    FailureKind::from_code(kind.checked_sub(GAVE_UP_BASE)?)
}
