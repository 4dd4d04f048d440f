//! The executor's setup on the wire: what [`Executor::new`](crate::executor::Executor::new)
//! and [`Executor::set_view_windows`](crate::executor::Executor::set_view_windows) take (the
//! configuration, the model's primitives, the flattened network, the placement's horizon,
//! charge, hotel load, phases and Earth-in-view windows, the science context), and what the
//! executor it replaces had learned ([`Learned`], given by
//! [`Executor::set_learned`](crate::executor::Executor::set_learned)), encoded by the
//! host and uplinked in chunks to the planner partition, which decodes it in place
//! ([`decode_into`]) and validates it ([`validate`]) before it builds the executor
//! ([`Executor::reset`](crate::executor::Executor::reset)).
//!
//! Format (postcard, one part after the other, so that the target decodes a chain at a time
//! into its place and never holds a whole network on its stack): a [`Header`], then
//! `primitives` [`PrimitiveSpec`]s, then `chains` [`Chain`]s, and nothing after. The chains'
//! downlink spans are not carried: the executor computes them at every plan.
//!
//! Bad bytes are a [`LanderSetupError`], never a panic.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use fsw_bridge::lander::LanderSetupError;
use fsw_bridge::MissionTimeUs;

use crate::assessor::{
    Biosignature, ScienceContext, SiteRecord, TargetRecord, MAX_SITES, MAX_TARGETS_PER_SITE,
};
use crate::capacity::*;
use crate::comms::VolumeFactors;
use crate::executor::{ExecConfig, Learned, ParameterUpdate, Strategy, MAX_PARAMETER_UPDATES};
use crate::htn::PrimitiveKind;
use crate::htn::{Chain, FlatNetwork, PhaseTimeline, PrimitiveSpec};
use crate::placement::{EarthView, TimelinePlacement, ViewTimeline, ViewWindow};
use crate::utility::Score;

/// The format's version (the header's first field). 2: the header ends with the learned
/// part (measured parameters, volume factors, the sol's radio energy spent).
pub const SETUP_VERSION: u8 = 2;

/// Everything the executor is built from. All-zero bytes are a valid (empty) setup: the
/// planner partition keeps one in memory that is not zeroed for it, zeroes it once and decodes
/// into it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LanderSetup {
    pub config: ExecConfig,
    pub primitives: Vec<PrimitiveSpec, MAX_PRIMITIVES>,
    pub network: FlatNetwork,
    /// The placement (its horizon start and charge are the executor's start; its
    /// `earth.windows` are the Earth-in-view windows; `earth.downlinks` is not carried).
    pub timeline: TimelinePlacement,
    pub context: ScienceContext,
    /// What the executor starts with learned (a model uplink carries the replaced
    /// executor's; empty at the mission's start).
    pub learned: Learned,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct WireTarget {
    estimated: u16,
    imaging: Option<u16>,
    collected: bool,
    /// Some(true): positive.
    biosignature: Option<bool>,
    failed: bool,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct WireSite {
    estimated: u16,
    pre_excavation: Option<u16>,
    post_excavation: Option<u16>,
    targets: Vec<WireTarget, MAX_TARGETS_PER_SITE>,
}

/// The setup's first part.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct Header {
    version: u8,
    /// `Strategy` as 0 Static, 1 Ground, 2 FE, 3 Replan.
    strategy: u8,
    push_timeout_us: u64,
    max_retries: u8,
    exploration_bound: Option<u32>,
    reserve_mj: u64,
    horizon_start: MissionTimeUs,
    horizon_end: MissionTimeUs,
    phases: PhaseTimeline,
    battery_mj: u64,
    hotel_load_mw: u64,
    /// Earth-in-view windows [start, end) in µs.
    windows: Vec<(u64, u64), MAX_VIEW_WINDOWS>,
    sites: Vec<WireSite, MAX_SITES>,
    primitives: u16,
    chains: u16,
    /// The learned part ([`Learned`]).
    params: Vec<ParameterUpdate, MAX_PARAMETER_UPDATES>,
    volumes: Vec<(PrimitiveKind, u64), { PrimitiveKind::ALL.len() }>,
    comm_spent: (u16, u64),
}

fn strategy_code(s: Strategy) -> u8 {
    match s {
        Strategy::Static => 0,
        Strategy::Ground => 1,
        Strategy::FlexibleExecution => 2,
        Strategy::Replan => 3,
    }
}

fn strategy_of(code: u8) -> Option<Strategy> {
    Some(match code {
        0 => Strategy::Static,
        1 => Strategy::Ground,
        2 => Strategy::FlexibleExecution,
        3 => Strategy::Replan,
        _ => return None,
    })
}

fn score(v: u16) -> Result<Score, LanderSetupError> {
    Score::new(u32::from(v)).map_err(|_| LanderSetupError::BadScore)
}

/// Why [`encode`] could not write a setup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The buffer is too small.
    BufferFull,
}

/// Writes `setup` into `out`; the bytes written.
pub fn encode(setup: &LanderSetup, out: &mut [u8]) -> Result<usize, EncodeError> {
    let c = &setup.config;
    let t = &setup.timeline;
    let mut windows = Vec::new();
    for w in t.earth.windows.windows() {
        // Never fails: the same capacity.
        let _ = windows.push((w.start.0, w.end.0));
    }
    let mut sites = Vec::new();
    for s in setup.context.sites.iter() {
        let mut targets = Vec::new();
        for r in s.targets.iter() {
            let _ = targets.push(WireTarget {
                estimated: r.estimated.ten_thousandths(),
                imaging: r.imaging.map(|s| s.ten_thousandths()),
                collected: r.collected,
                biosignature: r.biosignature.map(|b| b == Biosignature::Positive),
                failed: r.failed,
            });
        }
        let _ = sites.push(WireSite {
            estimated: s.estimated.ten_thousandths(),
            pre_excavation: s.pre_excavation.map(|s| s.ten_thousandths()),
            post_excavation: s.post_excavation.map(|s| s.ten_thousandths()),
            targets,
        });
    }
    let header = Header {
        version: SETUP_VERSION,
        strategy: strategy_code(c.strategy),
        push_timeout_us: c.push_timeout_us,
        max_retries: c.max_retries,
        exploration_bound: c.exploration_bound,
        reserve_mj: c.reserve_mj,
        horizon_start: t.horizon_start,
        horizon_end: t.horizon_end,
        phases: t.phases.clone(),
        battery_mj: t.battery_mj,
        hotel_load_mw: t.hotel_load_mw,
        windows,
        sites,
        primitives: setup.primitives.len() as u16,
        chains: setup.network.chains.len() as u16,
        params: setup.learned.params.clone(),
        // Never fails: the same capacity.
        volumes: Vec::from_slice(setup.learned.volumes.entries()).unwrap_or_default(),
        comm_spent: setup.learned.comm_spent,
    };
    let mut used = 0usize;
    let put = |out: &mut [u8], used: &mut usize, v: &dyn Fn(&mut [u8]) -> Option<usize>| {
        let rest = out.get_mut(*used..).ok_or(EncodeError::BufferFull)?;
        let n = v(rest).ok_or(EncodeError::BufferFull)?;
        *used += n;
        Ok::<(), EncodeError>(())
    };
    put(out, &mut used, &|b| {
        postcard::to_slice(&header, b).ok().map(|s| s.len())
    })?;
    for p in setup.primitives.iter() {
        put(out, &mut used, &|b| {
            postcard::to_slice(p, b).ok().map(|s| s.len())
        })?;
    }
    for ch in setup.network.chains.iter() {
        put(out, &mut used, &|b| {
            postcard::to_slice(ch, b).ok().map(|s| s.len())
        })?;
    }
    Ok(used)
}

fn offset_of(all: &[u8], rest: &[u8]) -> u32 {
    (all.len() - rest.len()) as u32
}

/// Decodes `bytes` into `out` (in place: a chain at a time) and validates it. On error `out`
/// holds part of what was read.
pub fn decode_into(bytes: &[u8], out: &mut LanderSetup) -> Result<(), LanderSetupError> {
    let malformed = |part: u8, rest: &[u8]| LanderSetupError::Malformed {
        part,
        offset: offset_of(bytes, rest),
    };
    let (h, mut rest) =
        postcard::take_from_bytes::<Header>(bytes).map_err(|_| malformed(0, bytes))?;
    if h.version != SETUP_VERSION {
        return Err(LanderSetupError::Version { got: h.version });
    }
    out.config = ExecConfig {
        strategy: strategy_of(h.strategy).ok_or(LanderSetupError::BadStrategy)?,
        push_timeout_us: h.push_timeout_us,
        max_retries: h.max_retries,
        exploration_bound: h.exploration_bound,
        reserve_mj: h.reserve_mj,
    };
    // The phase changes as the checked constructor takes them (postcard does not check them).
    let mut changes: Vec<(MissionTimeUs, u8), MAX_PHASE_CHANGES> = Vec::new();
    let mut i = 0;
    while let Some(at) = h.phases.change_time(i) {
        changes
            .push((at, h.phases.phase_at(at)))
            .map_err(|_| LanderSetupError::BadPhases)?;
        i += 1;
    }
    let phases = PhaseTimeline::new(&changes).map_err(|_| LanderSetupError::BadPhases)?;
    if phases != h.phases {
        return Err(LanderSetupError::BadPhases);
    }
    let mut windows: Vec<ViewWindow, MAX_VIEW_WINDOWS> = Vec::new();
    for &(start, end) in h.windows.iter() {
        let _ = windows.push(ViewWindow {
            start: MissionTimeUs(start),
            end: MissionTimeUs(end),
        });
    }
    let windows = ViewTimeline::new(&windows).map_err(|_| LanderSetupError::BadWindows)?;
    out.timeline.horizon_start = h.horizon_start;
    out.timeline.horizon_end = h.horizon_end;
    out.timeline.phases = phases;
    out.timeline.battery_mj = h.battery_mj;
    out.timeline.hotel_load_mw = h.hotel_load_mw;
    out.timeline.earth = EarthView {
        windows,
        downlinks: Vec::new(),
    };
    out.context.sites.clear();
    for s in h.sites.iter() {
        let mut targets = Vec::new();
        for r in s.targets.iter() {
            let _ = targets.push(TargetRecord {
                estimated: score(r.estimated)?,
                imaging: r.imaging.map(score).transpose()?,
                collected: r.collected,
                biosignature: r.biosignature.map(|p| {
                    if p {
                        Biosignature::Positive
                    } else {
                        Biosignature::Negative
                    }
                }),
                failed: r.failed,
            });
        }
        let _ = out.context.sites.push(SiteRecord {
            estimated: score(s.estimated)?,
            pre_excavation: s.pre_excavation.map(score).transpose()?,
            post_excavation: s.post_excavation.map(score).transpose()?,
            targets,
        });
    }
    out.learned = Learned {
        params: h.params.clone(),
        volumes: VolumeFactors::from_entries(&h.volumes)
            .ok_or(LanderSetupError::OutOfRange { index: u16::MAX })?,
        comm_spent: h.comm_spent,
    };
    out.primitives.clear();
    for _ in 0..h.primitives {
        let (p, r) =
            postcard::take_from_bytes::<PrimitiveSpec>(rest).map_err(|_| malformed(1, rest))?;
        out.primitives
            .push(p)
            .map_err(|_| LanderSetupError::TooMany)?;
        rest = r;
    }
    out.network.chains.clear();
    for _ in 0..h.chains {
        let (c, r) = postcard::take_from_bytes::<Chain>(rest).map_err(|_| malformed(2, rest))?;
        out.network
            .chains
            .push(c)
            .map_err(|_| LanderSetupError::TooMany)?;
        rest = r;
    }
    if !rest.is_empty() {
        return Err(LanderSetupError::TrailingBytes {
            offset: offset_of(bytes, rest),
        });
    }
    validate(out)
}

/// What the algorithms assume of their input and the wire cannot say: energies, sizes and
/// values within the capacities' largest, chains naming primitives that exist, task slots and
/// batches within the search's capacity, a horizon that ends after it starts.
pub fn validate(setup: &LanderSetup) -> Result<(), LanderSetupError> {
    let t = &setup.timeline;
    if t.horizon_end < t.horizon_start {
        return Err(LanderSetupError::BadHorizon);
    }
    let l = &setup.learned;
    if t.battery_mj > MAX_ENERGY_MJ
        || setup.config.reserve_mj > MAX_ENERGY_MJ
        || t.hotel_load_mw > MAX_ENERGY_MJ
        || l.params.iter().any(|p| p.energy_mj > MAX_ENERGY_MJ)
        || l.comm_spent.1 > MAX_ENERGY_MJ
        || VolumeFactors::from_entries(l.volumes.entries()).is_none()
    {
        return Err(LanderSetupError::OutOfRange { index: u16::MAX });
    }
    for (i, p) in setup.primitives.iter().enumerate() {
        let product_ok = p
            .product
            .is_none_or(|x| x.size_bytes <= MAX_BYTES && x.value <= MAX_PRODUCT_VALUE);
        if p.energy_mj > MAX_ENERGY_MJ || !product_ok {
            return Err(LanderSetupError::OutOfRange { index: i as u16 });
        }
    }
    for (i, c) in setup.network.chains.iter().enumerate() {
        let chain = i as u16;
        if c.energy_mj > MAX_ENERGY_MJ
            || c.products
                .iter()
                .any(|p| p.spec.size_bytes > MAX_BYTES || p.spec.value > MAX_PRODUCT_VALUE)
        {
            return Err(LanderSetupError::OutOfRange { index: chain });
        }
        let known = c
            .primitives
            .iter()
            .all(|&p| usize::from(p) < setup.primitives.len());
        if c.primitives.is_empty()
            || !known
            || usize::from(c.task_slot) >= MAX_SEARCH_TASKS
            || usize::from(c.batch) >= MAX_BATCHES
        {
            return Err(LanderSetupError::BadChain { chain });
        }
    }
    Ok(())
}

/// The first byte of an uplinked downlink-manager problem ([`DownlinkProblem`]), where a setup
/// has its format version: the planner partition solves it (the downlink manager's cost on the
/// target, issue 11's measure) instead of building an executor.
pub const DOWNLINK_PROBLEM_TAG: u8 = 0xd1;

/// A downlink manager's problem (Appendix A): what [`DownlinkManager::load`] takes.
///
/// [`DownlinkManager::load`]: crate::downlink::DownlinkManager::load
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DownlinkProblem {
    pub products: Vec<crate::downlink::DataProduct, MAX_DATA_PRODUCTS>,
    pub opportunities: Vec<crate::downlink::DownlinkOpportunity, MAX_DOWNLINKS>,
    pub allocations: Vec<crate::downlink::SolAllocation, MAX_SOLS>,
}

/// Writes `problem` into `out` after [`DOWNLINK_PROBLEM_TAG`]; the bytes written.
pub fn encode_downlink_problem(
    problem: &DownlinkProblem,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let (tag, rest) = out.split_first_mut().ok_or(EncodeError::BufferFull)?;
    *tag = DOWNLINK_PROBLEM_TAG;
    let n = postcard::to_slice(problem, rest)
        .map_err(|_| EncodeError::BufferFull)?
        .len();
    Ok(n + 1)
}

/// Decodes a downlink problem (after its tag); the manager's own `load` checks the rest.
pub fn decode_downlink_problem(bytes: &[u8]) -> Result<DownlinkProblem, LanderSetupError> {
    let body = match bytes.split_first() {
        Some((&DOWNLINK_PROBLEM_TAG, body)) => body,
        _ => return Err(LanderSetupError::Malformed { part: 3, offset: 0 }),
    };
    let (p, rest) = postcard::take_from_bytes::<DownlinkProblem>(body)
        .map_err(|_| LanderSetupError::Malformed { part: 3, offset: 1 })?;
    if !rest.is_empty() {
        return Err(LanderSetupError::TrailingBytes {
            offset: offset_of(bytes, rest),
        });
    }
    Ok(p)
}
