//! Europa Lander autonomy algorithms (seed 000): what the lander's planner plug-in needs to
//! choose what to do with a battery that cannot be recharged, when utility counts only once
//! its data reaches Earth.
//!
//! - [`utility`]: ranked utility (IV.C.1), seven fixed-point scores added rank by rank and
//!   compared lexicographically, and the ranked ratio T.utility / T.cost the search orders by.
//! - [`htn`]: the HTN model (parents with alternative decompositions, the 17 primitives,
//!   phases, ground holds, the fully-autonomous flag) and its flattening into chains (III.A).
//! - [`search`]: Algorithm 1, the utility-maximising search with energy pruning and the phased
//!   outer loop of RSM-1, anytime; "can the chain be added" is the [`search::ChainPlacement`]
//!   trait, implemented by [`placement`] (a simple single-resource timeline with energy),
//!   [`gate`] (the downlink manager's veto on top of another placement) and [`mexec`] (the
//!   autonomy crate's MEXEC timelines).
//! - [`assessor`]: the Assessor (IV.C.2), utility predicted from the science context, and
//!   the science subway map enforced through the Mission rank ([`assessor::AssessedPlacement`]).
//! - [`executor`]: flexible execution (task push, automated retry), replanning from the current
//!   state, model parameter updates and the four strategies (III.B-D, IV.C.3), as a value-in,
//!   value-out step with a search budget.
//! - [`downlink`]: the downlink manager (Appendix A): Critical and Decisional products placed
//!   first, the rest by an exact, anytime multiple-knapsack branch and bound.
//! - [`comms`]: data volume and downlink capacity in the planning: the link and the products
//!   onboard as executor inputs, measured product volumes, downlinks sized to their data, and
//!   the downlink manager's check on every chain ([`comms::DataPlacement`]).
//!
//! `no_std`, heap-free, integer time in µs and energy in mJ, capacities in [`capacity`]; no
//! floating point, so host and target decide bit for bit the same. The executor runs in the
//! planner partition behind `flight_app::LanderApp`, built from a [`setup`] uplinked by the
//! host, its values on the link converted by [`wire`].
#![no_std]
#![forbid(unsafe_code)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

#[cfg(test)]
extern crate std;

pub mod assessor;
pub mod capacity;
pub mod comms;
pub mod downlink;
pub mod executor;
pub mod gate;
pub mod htn;
pub mod mexec;
pub mod placement;
pub mod rsm1;
pub mod search;
pub mod setup;
mod small_sort;
pub mod utility;
pub mod wire;
