//! A Stellar-style temporal planner (seed 001, Coles et al. 2019): forward search over snap
//! actions for temporal PDDL tasks with durative actions, [lb, ub] durations, timed initial
//! literal windows, and discrete numeric conditions and effects.
//!
//! `no_std` and heap-free. The task is the compact binary the host's front end (crate `pddl`)
//! writes, validated on load ([`Task::parse`]); all search memory is one arena of words handed
//! to [`Planner::new`], whose high-water mark is reported ([`Stats::peak_words`]). Time is
//! integer ticks (the task says how many make one PDDL time unit). The search is anytime:
//! [`Planner::step`] expands a bounded number of states and can be called again to resume.
//!
//! The parts: [`task`] (the binary task), [`constraints`] (the compact serialised encoding of
//! temporal constraints), [`stn`] (temporal consistency), [`dispatch`] (flexible
//! dispatch of a plan, section 5.2), [`opportunistic`] (dropping an opportunistic goal that makes planning
//! fail, section 5.3), [`replan`] (replanning from the middle of a plan, sections 5.1-5.3), [`heuristic`] (FF on the temporal
//! relaxation, with running-action facts and preferred operators), [`search`] (the planner).
#![no_std]
#![forbid(unsafe_code)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod constraints;
pub mod dispatch;
pub mod dispatch_wire;
pub mod heuristic;
pub mod opportunistic;
pub mod replan;
pub mod search;
pub mod stn;
pub mod task;

pub use dispatch::{Decision, Dispatcher, NetworkError, PlanNetwork, PlanStep};
pub use search::{Duplicates, PlannedAction, Planner, PlannerConfig, Region, Stats, Status};
pub use task::{Task, TaskError, TaskErrorKind};
