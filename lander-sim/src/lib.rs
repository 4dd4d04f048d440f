//! The Europa Lander simulation on the host and the strategy study of seed 000 V.A (issue 12).
//!
//! - [`scenario`]: what a lander scenario says (the files in `scenarios/lander/`, read by `hil`).
//! - [`sim`]: the world, seeded and deterministic in integer mission time, driving
//!   `lander::executor` through its `Observation`/`Directive` step.
//! - [`study`]: BSM-1 under the four strategies and three energy variants, the statistics, the
//!   analytical model of equations 2-5, the JSON report, shard merging, and the SVG plot.
//! - [`report`]: the long-mission report (Gantt over sols, battery, data and utility
//!   timelines, downlinks per tier) from a run and its [`sim::trace`].
//! - [`expect`]: a scenario's success criteria (`[[expect]]`), checked against a run.
//! - [`rng`]: the seeded streams.
pub mod expect;
pub mod report;
pub mod rng;
pub mod scenario;
pub mod sim;
pub mod study;
