//! Missions: a task network run against the simulated spacecraft on a target (the emulated
//! RAD750 proxy or the native build), frame by frame under the host's lockstep time driver, with
//! resets and faults injected at exact mission times, and expectations checked at the end.
//!
//! The pipeline, one stage per module: a scenario file ([`crate::scenario`]) is resolved
//! against its task network into a [`plan::MissionPlan`]; [`driver`] flies the plan on a
//! [`target`] while [`sim`] plays the spacecraft, recording into a [`record::MissionRecord`];
//! [`expect`] judges the record; [`report`] turns it all into the summary, JSON, JUnit and the
//! Gantt chart ([`gantt`]); [`runner`] ties the stages together for `hil run` and campaigns.
pub mod auth;
pub mod driver;
pub mod expect;
pub mod gantt;
pub mod link;
pub mod metrics;
pub mod plan;
pub mod record;
pub mod report;
pub mod rng;
pub mod runner;
pub mod sim;
pub mod target;

pub use crate::tasknet::CompiledNetwork;
