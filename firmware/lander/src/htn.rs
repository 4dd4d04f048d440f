//! The lander's hierarchical task network (seed 000 II.C, III.A) and its flattening.
//!
//! A model has primitive tasks (the 15 commandable RSM-1 primitives of II.C, the hotel load and
//! seismometer-on) and parent tasks with alternative decompositions into steps, each step a
//! primitive or another parent. A decomposition is schedulable only in the mission phases it
//! names (Fig. 4; the phase is a timeline, [`PhaseTimeline`]), and only in the autonomy mode it
//! names: with the fully-autonomous flag the ground-hold checkpoints of RSM-1 are gone, so the
//! decompositions that downlink with a ground hold are dropped and those written for fully
//! autonomous operation are kept.
//!
//! [`flatten`] is the III.A pre-processing: every top-level parent becomes one [`Chain`] per
//! way of expanding it into primitives, with summed utility, energy and duration, the data
//! products it creates (with their offsets from the chain's start) and its flags. It is
//! exponential in the worst case, so it runs offline, once per model, on the host (`hil`), and
//! the uplink would carry the flattened form. It is nonetheless `no_std` and heap-free like the
//! rest of this crate, so the same code could run on the target after a model update, and so
//! the host and the target can never disagree about what a chain is.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use autonomy::Name;
use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
use crate::utility::{RankedUtility, UtilityOverflow};

/// The primitive tasks (seed 000 II.C): the 15 the lander is commanded to perform, and the two
/// that stand for background resource use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum PrimitiveKind {
    TakeMonoPanorama,
    /// Collect Sample(N, M): site N, target M.
    CollectSample,
    FindExcavationSites,
    TransportSample,
    StartSeismometer,
    PrepareArm,
    PrepareHgaComm,
    /// Excavate Site(N).
    ExcavateSite,
    DiscardSample,
    /// Find Collection Targets(N).
    FindCollectionTargets,
    StopSeismometer,
    ScienceAnalyze,
    Downlink,
    /// A downlink after which a ground hold applies: sampling waits for the ground's release.
    DownlinkWithGroundHold,
    Uplink,
    /// The small continual energy cost, scheduled at the start of the mission.
    HotelLoad,
    /// The resource cost of running the seismometer.
    SeismometerOn,
}

impl PrimitiveKind {
    /// Every kind, commandable ones first.
    pub const ALL: [PrimitiveKind; 17] = [
        PrimitiveKind::TakeMonoPanorama,
        PrimitiveKind::CollectSample,
        PrimitiveKind::FindExcavationSites,
        PrimitiveKind::TransportSample,
        PrimitiveKind::StartSeismometer,
        PrimitiveKind::PrepareArm,
        PrimitiveKind::PrepareHgaComm,
        PrimitiveKind::ExcavateSite,
        PrimitiveKind::DiscardSample,
        PrimitiveKind::FindCollectionTargets,
        PrimitiveKind::StopSeismometer,
        PrimitiveKind::ScienceAnalyze,
        PrimitiveKind::Downlink,
        PrimitiveKind::DownlinkWithGroundHold,
        PrimitiveKind::Uplink,
        PrimitiveKind::HotelLoad,
        PrimitiveKind::SeismometerOn,
    ];

    /// Whether the lander can be commanded to perform it (the 15 of II.C).
    pub fn is_commandable(self) -> bool {
        !matches!(
            self,
            PrimitiveKind::HotelLoad | PrimitiveKind::SeismometerOn
        )
    }
}

/// Downlink priority of a data product (seed 000 II.B.2, Appendix A).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Tier {
    /// Downlinked now: at the first opportunity after it is created.
    Critical,
    /// Downlinked at the next downlink, for the ground's decisions.
    Decisional,
    /// Downlinked before the mission ends.
    Mandatory,
    /// Downlinked only if energy remains.
    Residual,
}

/// A data product a primitive creates when it completes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ProductSpec {
    pub size_bytes: u64,
    pub tier: Tier,
    /// Integer value for the downlink manager (equation 6).
    pub value: u64,
}

/// One primitive task definition.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PrimitiveSpec {
    pub kind: PrimitiveKind,
    /// Site N, for the kinds that take one.
    pub site: Option<u8>,
    /// Target M within the site, for Collect Sample.
    pub target: Option<u8>,
    pub duration_us: u64,
    pub energy_mj: u64,
    /// Utility of the data this primitive produces (assigned or predicted by the Assessor).
    pub utility: RankedUtility,
    pub product: Option<ProductSpec>,
}

/// A set of mission phases: bit `p` allows phase `p` (`p < MAX_PHASES`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct PhaseMask(pub u16);

impl PhaseMask {
    pub const ANY: Self = Self(u16::MAX);

    /// The mask of exactly `phase` (empty for a phase out of range).
    pub const fn only(phase: u8) -> Self {
        if (phase as usize) < MAX_PHASES {
            Self(1 << phase)
        } else {
            Self(0)
        }
    }

    pub const fn allows(self, phase: u8) -> bool {
        (phase as usize) < MAX_PHASES && self.0 & (1 << phase) != 0
    }

    pub const fn intersect(self, other: Self) -> Self {
        Self(self.0 & other.0)
    }
}

/// The mission phase as a timeline: phase 0 from time 0, then each change from its time on.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PhaseTimeline {
    /// (time, phase) in increasing time order.
    changes: Vec<(MissionTimeUs, u8), MAX_PHASE_CHANGES>,
}

/// Why a phase timeline was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhaseTimelineError {
    TooManyChanges,
    /// Change `index` is not later than the one before it, or names a phase out of range.
    BadChange {
        index: usize,
    },
}

impl PhaseTimeline {
    /// A timeline with these changes (increasing times, phases below [`MAX_PHASES`]).
    pub fn new(changes: &[(MissionTimeUs, u8)]) -> Result<Self, PhaseTimelineError> {
        let mut out = Vec::new();
        let mut last: Option<MissionTimeUs> = None;
        for (index, &(at, phase)) in changes.iter().enumerate() {
            if last.is_some_and(|l| at <= l) || usize::from(phase) >= MAX_PHASES {
                return Err(PhaseTimelineError::BadChange { index });
            }
            out.push((at, phase))
                .map_err(|_| PhaseTimelineError::TooManyChanges)?;
            last = Some(at);
        }
        Ok(Self { changes: out })
    }

    /// The time of change `index`, if there is one.
    pub fn change_time(&self, index: usize) -> Option<MissionTimeUs> {
        self.changes.get(index).map(|&(at, _)| at)
    }

    /// The phase at `t`.
    pub fn phase_at(&self, t: MissionTimeUs) -> u8 {
        self.changes
            .iter()
            .take_while(|(at, _)| *at <= t)
            .last()
            .map_or(0, |&(_, p)| p)
    }

    /// Whether every instant of `[start, end)` (or `start` alone when empty) is in `mask`.
    pub fn allows_span(&self, mask: PhaseMask, start: MissionTimeUs, end: MissionTimeUs) -> bool {
        if !mask.allows(self.phase_at(start)) {
            return false;
        }
        self.changes
            .iter()
            .filter(|(at, _)| *at > start && *at < end)
            .all(|&(_, p)| mask.allows(p))
    }

    /// The earliest `s >= from` such that `[s, s + duration_us)` lies in `mask`, if any.
    pub fn earliest_span(
        &self,
        mask: PhaseMask,
        from: MissionTimeUs,
        duration_us: u64,
    ) -> Option<MissionTimeUs> {
        let fits = |s: MissionTimeUs| {
            self.allows_span(mask, s, MissionTimeUs(s.0.saturating_add(duration_us)))
        };
        if fits(from) {
            return Some(from);
        }
        // Otherwise a valid start is the start of a phase interval.
        self.changes
            .iter()
            .map(|&(at, _)| at)
            .filter(|&at| at > from)
            .find(|&at| fits(at))
    }
}

/// In which autonomy mode a decomposition may be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ModeUse {
    Always,
    /// Only with ground in the loop (the fully-autonomous flag clear): e.g. the decomposition
    /// that downlinks with a ground hold.
    GroundInTheLoop,
    /// Only with the fully-autonomous flag set.
    FullyAutonomous,
}

/// One step of a decomposition.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Step {
    /// Index into [`HtnModel::primitives`].
    Primitive(u8),
    /// Index into [`HtnModel::parents`]; must be lower than the parent being decomposed, so the
    /// model is acyclic by construction.
    Parent(u8),
}

/// One way of performing a parent task.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Decomposition {
    pub steps: Vec<Step, MAX_STEPS>,
    /// Phases in which this decomposition may run (every primitive of it).
    pub phases: PhaseMask,
    pub mode: ModeUse,
    /// Sampling after a ground-hold checkpoint: may not start while a hold is in force.
    pub waits_for_ground_release: bool,
}

/// One parent task definition.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ParentSpec {
    /// Ground id; the search adds at most one chain per top-level id to a plan.
    pub id: u16,
    pub name: Name,
    /// Top-level parents become search edges; the others exist only as steps of other parents.
    pub top_level: bool,
    /// Priority batch of the phased outer loop: 0 for the exogenous uplinks (placed first, held
    /// fixed), then 1, 2, ... in decreasing priority.
    pub batch: u8,
    /// Fixed start (exogenous uplink windows); `None` for tasks the planner places.
    pub fixed_start: Option<MissionTimeUs>,
    pub decompositions: Vec<Decomposition, MAX_DECOMPOSITIONS>,
}

/// A lander HTN model.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct HtnModel {
    pub primitives: Vec<PrimitiveSpec, MAX_PRIMITIVES>,
    pub parents: Vec<ParentSpec, MAX_PARENTS>,
}

/// Options of the flattening.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FlattenOptions {
    /// The RSM-1 fully-autonomous flag.
    pub fully_autonomous: bool,
}

/// A data product a chain creates, `offset_us` after the chain's start (when the primitive
/// that creates it ends).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChainProduct {
    pub offset_us: u64,
    pub spec: ProductSpec,
}

/// One flattened decomposition of a top-level parent: a search edge.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Chain {
    /// Ground id of the top-level parent.
    pub task: u16,
    /// Dense index of the top-level parent (`< MAX_SEARCH_TASKS`), for the search's task sets.
    pub task_slot: u8,
    /// Which of the parent's flattened chains this is.
    pub alternative: u8,
    /// Primitive indices, in execution order (one after the other).
    pub primitives: Vec<u8, MAX_CHAIN_PRIMITIVES>,
    pub utility: RankedUtility,
    pub energy_mj: u64,
    pub duration_us: u64,
    pub phases: PhaseMask,
    pub batch: u8,
    pub fixed_start: Option<MissionTimeUs>,
    /// Contains a Downlink with Ground Hold: a hold is in force from its end until the end of
    /// the first uplink chain that starts at or after it.
    pub holds_for_ground: bool,
    /// May not start while a ground hold is in force.
    pub waits_for_ground_release: bool,
    /// Contains an Uplink: releases the ground holds in force when it ends.
    pub is_uplink: bool,
    pub products: Vec<ChainProduct, MAX_CHAIN_PRODUCTS>,
}

impl Chain {
    /// A chain with no primitives, for tests and tools that build chains directly.
    pub fn bare(task: u16, task_slot: u8, utility: RankedUtility, energy_mj: u64) -> Self {
        Self {
            task,
            task_slot,
            alternative: 0,
            primitives: Vec::new(),
            utility,
            energy_mj,
            duration_us: 0,
            phases: PhaseMask::ANY,
            batch: 1,
            fixed_start: None,
            holds_for_ground: false,
            waits_for_ground_release: false,
            is_uplink: false,
            products: Vec::new(),
        }
    }
}

/// The flattened model: the search's edges.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FlatNetwork {
    pub chains: Vec<Chain, MAX_CHAINS>,
}

/// Why a model could not be flattened. `parent` is an index into [`HtnModel::parents`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlattenError {
    /// A step names a primitive that does not exist.
    UnknownPrimitive { parent: usize, step: usize },
    /// A step names a parent at or after its own index (which could make a cycle).
    ParentOrder { parent: usize, step: usize },
    /// More than [`MAX_CHAINS`] chains in all.
    TooManyChains { parent: usize },
    /// A chain longer than [`MAX_CHAIN_PRIMITIVES`].
    ChainTooLong { parent: usize },
    /// A chain creating more than [`MAX_CHAIN_PRODUCTS`] products.
    TooManyProducts { parent: usize },
    /// A chain's energy above [`MAX_ENERGY_MJ`], or its duration past `u64`.
    TooLarge { parent: usize },
    /// A chain's utility left `u32` in some rank.
    Utility { parent: usize },
    /// More than [`MAX_SEARCH_TASKS`] top-level parents.
    TooManyTasks,
}

impl From<UtilityOverflow> for FlattenError {
    fn from(_: UtilityOverflow) -> Self {
        FlattenError::Utility { parent: 0 }
    }
}

fn mode_applies(mode: ModeUse, options: FlattenOptions) -> bool {
    match mode {
        ModeUse::Always => true,
        ModeUse::GroundInTheLoop => !options.fully_autonomous,
        ModeUse::FullyAutonomous => options.fully_autonomous,
    }
}

/// Appends `part` to `chain` (sequentially), for parent `parent`.
fn append(chain: &mut Chain, part: &Chain, parent: usize) -> Result<(), FlattenError> {
    for &p in &part.primitives {
        chain
            .primitives
            .push(p)
            .map_err(|_| FlattenError::ChainTooLong { parent })?;
    }
    for product in &part.products {
        let shifted = ChainProduct {
            offset_us: chain
                .duration_us
                .checked_add(product.offset_us)
                .ok_or(FlattenError::TooLarge { parent })?,
            spec: product.spec,
        };
        chain
            .products
            .push(shifted)
            .map_err(|_| FlattenError::TooManyProducts { parent })?;
    }
    chain.utility = chain
        .utility
        .checked_add(&part.utility)
        .map_err(|_| FlattenError::Utility { parent })?;
    chain.energy_mj = chain
        .energy_mj
        .checked_add(part.energy_mj)
        .filter(|&e| e <= MAX_ENERGY_MJ)
        .ok_or(FlattenError::TooLarge { parent })?;
    chain.duration_us = chain
        .duration_us
        .checked_add(part.duration_us)
        .ok_or(FlattenError::TooLarge { parent })?;
    chain.phases = chain.phases.intersect(part.phases);
    chain.holds_for_ground |= part.holds_for_ground;
    chain.waits_for_ground_release |= part.waits_for_ground_release;
    chain.is_uplink |= part.is_uplink;
    Ok(())
}

/// The one-primitive chain of primitive `index`.
fn primitive_chain(
    model: &HtnModel,
    index: u8,
    parent: usize,
    step: usize,
) -> Result<Chain, FlattenError> {
    let spec = model
        .primitives
        .get(usize::from(index))
        .ok_or(FlattenError::UnknownPrimitive { parent, step })?;
    let mut chain = Chain::bare(0, 0, spec.utility, spec.energy_mj);
    if spec.energy_mj > MAX_ENERGY_MJ {
        return Err(FlattenError::TooLarge { parent });
    }
    chain.duration_us = spec.duration_us;
    let _ = chain.primitives.push(index);
    if let Some(product) = spec.product {
        let _ = chain.products.push(ChainProduct {
            offset_us: spec.duration_us,
            spec: product,
        });
    }
    chain.holds_for_ground = spec.kind == PrimitiveKind::DownlinkWithGroundHold;
    chain.is_uplink = spec.kind == PrimitiveKind::Uplink;
    Ok(chain)
}

/// The III.A pre-processing: flattens every top-level parent of `model` into chains of
/// primitives (one per combination of its and its nested parents' decompositions that applies
/// in the mode of `options`), in parent order, then decomposition order, then the nested
/// alternatives' order (the last step varying fastest).
pub fn flatten(model: &HtnModel, options: FlattenOptions) -> Result<FlatNetwork, FlattenError> {
    // Every parent's chains, nested ones included; `ranges[p]` is parent p's slice of `pool`.
    let mut pool: Vec<Chain, MAX_CHAINS> = Vec::new();
    let mut ranges: Vec<(usize, usize), MAX_PARENTS> = Vec::new();
    let mut out = FlatNetwork::default();
    let mut task_slot: usize = 0;
    for (p, parent) in model.parents.iter().enumerate() {
        let first = pool.len();
        if parent.top_level && task_slot >= MAX_SEARCH_TASKS {
            return Err(FlattenError::TooManyTasks);
        }
        for decomposition in parent.decompositions.iter() {
            if !mode_applies(decomposition.mode, options) {
                continue;
            }
            // The alternatives of each step: a primitive has one, a parent its chains.
            let mut alternatives: Vec<(usize, usize), MAX_STEPS> = Vec::new();
            for (s, step) in decomposition.steps.iter().enumerate() {
                let range = match *step {
                    Step::Primitive(i) => {
                        if usize::from(i) >= model.primitives.len() {
                            return Err(FlattenError::UnknownPrimitive { parent: p, step: s });
                        }
                        (0, 1)
                    }
                    Step::Parent(q) => {
                        if usize::from(q) >= p {
                            return Err(FlattenError::ParentOrder { parent: p, step: s });
                        }
                        ranges
                            .get(usize::from(q))
                            .copied()
                            .ok_or(FlattenError::ParentOrder { parent: p, step: s })?
                    }
                };
                let _ = alternatives.push(range);
            }
            if alternatives.iter().any(|(a, b)| a >= b) {
                continue; // a nested parent with no applicable chain: no way to do this one
            }
            // Odometer over the alternatives, last step fastest.
            let mut pick: Vec<usize, MAX_STEPS> = alternatives.iter().map(|&(a, _)| a).collect();
            loop {
                let mut chain = Chain::bare(parent.id, task_slot as u8, RankedUtility::ZERO, 0);
                chain.phases = decomposition.phases;
                chain.waits_for_ground_release = decomposition.waits_for_ground_release;
                chain.batch = parent.batch;
                chain.fixed_start = parent.fixed_start;
                for (s, (step, &choice)) in decomposition.steps.iter().zip(pick.iter()).enumerate()
                {
                    match *step {
                        Step::Primitive(i) => {
                            let part = primitive_chain(model, i, p, s)?;
                            append(&mut chain, &part, p)?;
                        }
                        Step::Parent(_) => {
                            let part = pool
                                .get(choice)
                                .cloned()
                                .ok_or(FlattenError::ParentOrder { parent: p, step: s })?;
                            append(&mut chain, &part, p)?;
                        }
                    }
                }
                chain.alternative = u8::try_from(pool.len() - first)
                    .map_err(|_| FlattenError::TooManyChains { parent: p })?;
                pool.push(chain)
                    .map_err(|_| FlattenError::TooManyChains { parent: p })?;
                // Advance the odometer.
                let mut s = pick.len();
                loop {
                    if s == 0 {
                        break;
                    }
                    s -= 1;
                    let (Some(slot), Some(&(lo, hi))) = (pick.get_mut(s), alternatives.get(s))
                    else {
                        break;
                    };
                    *slot += 1;
                    if *slot < hi {
                        s = usize::MAX; // advanced without carry
                        break;
                    }
                    *slot = lo;
                }
                if s != usize::MAX {
                    break; // every combination done
                }
            }
        }
        let _ = ranges.push((first, pool.len()));
        if parent.top_level {
            for chain in pool.get(first..).unwrap_or(&[]) {
                out.chains
                    .push(chain.clone())
                    .map_err(|_| FlattenError::TooManyChains { parent: p })?;
            }
            task_slot += 1;
        }
    }
    Ok(out)
}
