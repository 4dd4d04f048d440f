//! MEXEC-style onboard autonomy core: task networks, timelines, planner, executive and
//! warm-restart checkpoints (seed 003; seed 000 section IV.A).
//!
//! `no_std`, heap-free, integer time in microseconds ([`MissionTimeUs`]), fixed capacities named
//! in [`capacity`]. The same code runs natively (host tests, Monte Carlo) and on the RAD750-proxy
//! target; decisions are bit-identical on both because nothing here uses floating point,
//! hashing, randomness or platform-sized integers in a way that changes results.
//!
//! Start at [`Autonomy`]: it owns the task network, the planner and the executive and runs them in
//! order. Uplinks arrive as bytes ([`TaskNetwork::validate_uplink`], [`Autonomy::load_uplink`]);
//! everything the core decides leaves through the [`Outputs`] trait as command dispatches and
//! [`TelemetryEvent`]s whose codes are defined in [`telemetry`].
//!
//! Responses to failures are bounded ([`ResponsePolicy`]): retries per instance and cause,
//! repairs per task definition and cause, backed off in mission time, so a misbehaving
//! subsystem draws at most [`TaskNetwork::max_dispatches_per_run`] commands per task between
//! two completions of it.
#![no_std]
#![forbid(unsafe_code)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod autonomy;
pub mod capacity;
pub mod checkpoint;
pub mod condition;
pub mod control;
pub mod executive;
mod in_place;
pub mod interface;
pub mod model;
pub mod partitioned;
pub mod plan;
pub mod planner;
pub mod scenarios;
pub mod small_sort;
pub mod telemetry;
pub mod timeline;
pub mod uplink;

pub use autonomy::{Autonomy, LoadError, StepBudget, StepCost, StepReport};
pub use capacity::*;
pub use checkpoint::{CheckpointError, RestoreInfo, WarmRestartArea, WrittenRecord};
pub use control::ControlLoop;
pub use fsw_bridge::{
    CommandArgs, CommandStatus, MissionTimeUs, Opcode, StateKey, StateValue, TelemetryEvent,
};
pub use interface::{Commit, Outputs, ReportKind, TaskReport, ToExecutive, ToPlanner};
pub use model::*;
pub use telemetry::{FailureKind, PlanModificationKind, TaskState};
pub use uplink::{ErrorSite, TaskField, ValidationCode, ValidationError};
