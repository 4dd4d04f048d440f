//! Every fixed capacity of the lander algorithms, in one place. Exceeding one is an error value
//! (a flattening error, a refused product, a search that reports it is no longer exhaustive),
//! never a panic. The sizes are chosen for RSM-1 (three sites, three targets each, raw or
//! compressed downlinks, seismometry and panoramas over tens of sols).

/// Primitive task definitions in one HTN model (the 17 kinds, with site and target arguments).
pub const MAX_PRIMITIVES: usize = 64;
/// Parent task definitions in one HTN model (top-level and nested).
pub const MAX_PARENTS: usize = 48;
/// Alternative decompositions of one parent task.
pub const MAX_DECOMPOSITIONS: usize = 8;
/// Steps (primitives or parent tasks) of one decomposition.
pub const MAX_STEPS: usize = 12;
/// Primitives in one flattened chain.
pub const MAX_CHAIN_PRIMITIVES: usize = 24;
/// Flattened chains (search edges) of one model, nested parents' included.
pub const MAX_CHAINS: usize = 128;
/// Data products one chain creates.
pub const MAX_CHAIN_PRODUCTS: usize = 6;
/// Mission phases (bits of a [`crate::htn::PhaseMask`]).
pub const MAX_PHASES: usize = 16;
/// Phase changes on the phase timeline.
pub const MAX_PHASE_CHANGES: usize = 32;
/// Earth-in-view windows the placement knows ([`crate::placement::ViewTimeline`]): one per
/// 84 h Earth period covers missions of over 110 days.
pub const MAX_VIEW_WINDOWS: usize = 32;
/// Priority batches of the phased outer loop (batch 0 is the exogenous uplinks).
pub const MAX_BATCHES: usize = 8;

/// Chains in one plan (fixed roots and searched chains together).
pub const MAX_PLAN_CHAINS: usize = 64;
/// Distinct top-level tasks the search tells apart ("edge.task not in new_plan").
pub const MAX_SEARCH_TASKS: usize = 128;
/// Default node collection of the search (partial plans kept).
pub const MAX_SEARCH_NODES: usize = 1024;
/// Default exploration queue of the search ((plan, chain) pairs waiting).
pub const MAX_EXPLORE_QUEUE: usize = 2048;

/// Data products the downlink manager considers at once (existing and predicted).
pub const MAX_DATA_PRODUCTS: usize = 64;
/// Downlink opportunities the downlink manager considers at once.
pub const MAX_DOWNLINKS: usize = 16;
/// Sols with their own downlink energy allocation.
pub const MAX_SOLS: usize = 64;

/// Largest energy any one cost, battery charge or allocation may name (about 305 kWh in mJ):
/// keeps every sum of [`MAX_PLAN_CHAINS`] costs exact in `u64` and every cross-multiplication of
/// the ranked ratio exact in `u128`.
pub const MAX_ENERGY_MJ: u64 = 1 << 40;
/// Largest data product size or downlink capacity (1 TiB): sums of [`MAX_DATA_PRODUCTS`] fit
/// `u64` with room to spare.
pub const MAX_BYTES: u64 = 1 << 40;
/// Largest value of one data product for the downlink manager: with the mandatory-tier bonus
/// ([`crate::downlink::MANDATORY_BONUS`]) every total over [`MAX_DATA_PRODUCTS`] fits `u64`.
pub const MAX_PRODUCT_VALUE: u64 = 1 << 40;
