//! Data volume and downlink capacity in the lander's planning (seed 000 Appendix A; issue 11
//! items 5 and 8): "each time a new task is considered to be included in the plan, the
//! resulting partial plan must be evaluated to determine if there will be enough time and
//! resources not only to perform the task, but to downlink all data products including any
//! from the new task".
//!
//! - [`CommsModel`]: the link as the executor knows it (rate, set-up overhead, thermal limit,
//!   radio power, per-downlink and per-sol energy allowances, the sol length). It is an
//!   executor input ([`crate::executor::Executor::set_comms`]): a rate the ground changes
//!   reaches the planning through it.
//! - [`VolumeFactors`]: product sizes measured against the model's (a product onboard is
//!   measured; the factor of its primitive kind replaces the prior at the next plan, like the
//!   durations and energies of IV.C.3).
//! - [`size_downlinks`]: Appendix A's "downlink task duration and energy costs are
//!   context-dependent": a chain's downlink lasts at least its prior duration and long enough
//!   to carry the chain's own products at the current rate (set-up overhead plus the
//!   transmission), at most the overhead plus the longest transmission the thermal limit and
//!   the per-downlink allowance allow; its energy scales with its duration.
//! - [`DataPlacement`]: the downlink manager in the placement. The opportunities are the
//!   plan's own downlinks (each chain's downlink span, already inside an Earth-in-view window
//!   by [`crate::placement::EarthView`]), with byte capacities from [`crate::downlink::capacities`]: the
//!   transmission time (the span less the overhead, at most the thermal limit and the
//!   per-downlink allowance) within each sol's allowance (less what this sol has already spent),
//!   times the rate. The products are those onboard (measured) and those the plan's chains and
//!   the candidate will create (at the measured volume factors). The manager places Critical
//!   and Decisional products in the first opportunity after their creation and the rest by the
//!   exact multiple knapsack (Mandatory first by its bonus, Residual with what is left). The
//!   candidate is accepted only if every product it creates is downlinked and it leaves no
//!   more Critical, Decisional or Mandatory products behind than the plan without it does (a
//!   product onboard that no downlink could carry does not block every candidate).
//!
//! Simplifications (documented, conservative): the check is made at the earliest start the
//! inner placement gives (a later start that would fit is not searched); a knapsack not proven
//! optimal within [`DATA_KNAPSACK_BUDGET`] nodes decides with its best assignment so far (it can
//! only refuse a chain the optimum would admit); products are not split across downlinks
//! (equation 12).
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
use crate::downlink::{DataProduct, DownlinkManager, DownlinkOpportunity, Placement};
use crate::downlink::{SolAllocation, Tier};
use crate::htn::{FlatNetwork, PrimitiveKind, PrimitiveSpec};
use crate::placement::{is_downlink, DownlinkSpans};
use crate::search::{ChainPlacement, PlacedChain};
use crate::utility::{Rank, RankedUtility, Score};

/// Knapsack nodes one placement check may use before its best assignment decides.
pub const DATA_KNAPSACK_BUDGET: u32 = 4_000;

/// The link to Earth as the executor knows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommsModel {
    /// Downlink rate, bits per second.
    pub rate_bps: u64,
    /// Set-up time of a downlink before data flows.
    pub overhead_us: u64,
    /// Longest transmission before the radio reaches its temperature limit.
    pub thermal_limit_us: u64,
    /// Radio power while transmitting, in mW (the allowances are counted in it).
    pub radio_power_mw: u64,
    /// Energy one downlink may spend transmitting, in mJ.
    pub per_downlink_mj: u64,
    /// Energy the downlinks of one sol may spend transmitting, in mJ.
    pub per_sol_mj: u64,
    /// Length of a sol (the allowance's period), µs; sol `k` is `[k * sol_us, (k+1) * sol_us)`.
    pub sol_us: u64,
}

/// Why a [`CommsModel`] or a list of products was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CommsError {
    /// A zero rate or a zero sol length.
    Invalid,
    /// More than [`MAX_DATA_PRODUCTS`] products onboard.
    TooManyProducts,
    /// A product above [`MAX_BYTES`] or [`MAX_PRODUCT_VALUE`].
    ProductOutOfRange,
}

const US_PER_S: u128 = 1_000_000;

impl CommsModel {
    /// Checks the model: a rate and a sol length above zero.
    pub fn validate(&self) -> Result<(), CommsError> {
        if self.rate_bps == 0 || self.sol_us == 0 {
            return Err(CommsError::Invalid);
        }
        Ok(())
    }

    /// The longest transmission of one downlink: the thermal limit, and what the per-downlink
    /// allowance pays for.
    pub fn max_transmit_us(&self) -> u64 {
        let paid = if self.radio_power_mw == 0 {
            u64::MAX
        } else {
            u64::try_from(
                u128::from(self.per_downlink_mj) * US_PER_S / u128::from(self.radio_power_mw),
            )
            .unwrap_or(u64::MAX)
        };
        self.thermal_limit_us.min(paid)
    }

    /// Bytes sent in `us` of transmission.
    pub fn bytes_in(&self, us: u64) -> u64 {
        u64::try_from(u128::from(self.rate_bps) * u128::from(us) / 8 / US_PER_S).unwrap_or(u64::MAX)
    }

    /// Transmission time of `bytes` (rounded up).
    pub fn transmit_us(&self, bytes: u64) -> u64 {
        let bits = u128::from(bytes) * 8 * US_PER_S;
        let rate = u128::from(self.rate_bps.max(1));
        u64::try_from(bits.div_ceil(rate)).unwrap_or(u64::MAX)
    }

    /// The byte capacity of one downlink of `duration_us` on its own (no sol allowance).
    pub fn capacity_of(&self, duration_us: u64) -> u64 {
        let tx = duration_us
            .saturating_sub(self.overhead_us)
            .min(self.max_transmit_us());
        self.bytes_in(tx)
    }

    /// The longest useful downlink: the overhead and the longest transmission.
    pub fn max_duration_us(&self) -> u64 {
        self.overhead_us.saturating_add(self.max_transmit_us())
    }

    /// The downlink duration that carries `bytes`, at most [`Self::max_duration_us`].
    pub fn duration_for(&self, bytes: u64) -> u64 {
        self.overhead_us
            .saturating_add(self.transmit_us(bytes))
            .min(self.max_duration_us())
    }

    /// The sol of time `t`.
    pub fn sol_of(&self, t: u64) -> u16 {
        u16::try_from(t / self.sol_us.max(1)).unwrap_or(u16::MAX)
    }

    /// The downlink opportunity of a downlink `[start, end)`.
    pub fn opportunity(&self, start: u64, end: u64) -> DownlinkOpportunity {
        DownlinkOpportunity {
            start: MissionTimeUs(start),
            end: MissionTimeUs(end.max(start)),
            overhead_us: self.overhead_us,
            sol: self.sol_of(start),
            rate_bps: self.rate_bps,
            radio_power_mw: self.radio_power_mw,
            thermal_limit_us: self.max_transmit_us(),
        }
    }
}

/// The largest volume factor learnt: a product measured 1,000 times its model's size.
pub const MAX_VOLUME_PPM: u64 = 1_000_000_000;

/// Measured product sizes against the model's, per primitive kind, in parts per million.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VolumeFactors {
    entries: Vec<(PrimitiveKind, u64), { PrimitiveKind::ALL.len() }>,
}

impl VolumeFactors {
    /// The factor of `kind` (1,000,000: as modelled).
    pub fn ppm(&self, kind: PrimitiveKind) -> u64 {
        self.entries
            .iter()
            .find(|(k, _)| *k == kind)
            .map_or(1_000_000, |&(_, f)| f)
    }

    /// Records a product of `kind` measured at `measured` bytes against the model's `prior`;
    /// true when the factor changed by more than 1% (a new prediction for later plans).
    pub fn learn(&mut self, kind: PrimitiveKind, prior: u64, measured: u64) -> bool {
        if prior == 0 {
            return false;
        }
        let f = u64::try_from(u128::from(measured) * 1_000_000 / u128::from(prior))
            .unwrap_or(u64::MAX)
            .min(MAX_VOLUME_PPM);
        let old = self.ppm(kind);
        let changed = f.abs_diff(old) * 100 > old;
        match self.entries.iter_mut().find(|(k, _)| *k == kind) {
            Some(e) => e.1 = f,
            // Never full: one entry per kind.
            None => {
                let _ = self.entries.push((kind, f));
            }
        }
        changed
    }

    /// The factors measured, one per kind at most, in the order first learned.
    pub fn entries(&self) -> &[(PrimitiveKind, u64)] {
        &self.entries
    }

    /// The factors `entries` (as [`Self::entries`] gives them): `None` when a kind comes twice
    /// or a factor is over [`MAX_VOLUME_PPM`].
    pub fn from_entries(entries: &[(PrimitiveKind, u64)]) -> Option<Self> {
        let mut out = Self::default();
        for (i, &(kind, ppm)) in entries.iter().enumerate() {
            let twice = entries
                .get(..i)
                .is_some_and(|e| e.iter().any(|x| x.0 == kind));
            if twice || ppm > MAX_VOLUME_PPM {
                return None;
            }
            out.entries.push((kind, ppm)).ok()?;
        }
        Some(out)
    }

    /// `prior` bytes of a product of `kind`, at the measured factor.
    pub fn scale(&self, kind: PrimitiveKind, prior: u64) -> u64 {
        let b = u128::from(prior) * u128::from(self.ppm(kind)) / 1_000_000;
        u64::try_from(b).unwrap_or(MAX_BYTES).min(MAX_BYTES)
    }
}

/// Appends `p` to `products`, split into segments of at most `segment` bytes when it is larger
/// (a product no single downlink can carry goes down over several, as the onboard file
/// transfer does; equation 12 then holds per segment). Returns how many items were appended,
/// or `None` when `products` is full.
pub fn push_segments(
    products: &mut Vec<DataProduct, MAX_DATA_PRODUCTS>,
    p: DataProduct,
    segment: u64,
) -> Option<usize> {
    if segment == 0 || p.size_bytes <= segment {
        products.push(p).ok()?;
        return Some(1);
    }
    let n = p.size_bytes.div_ceil(segment);
    let mut left = p.size_bytes;
    for k in 0..n {
        let size = left.min(segment);
        left -= size;
        let value = p.value / n + u64::from(k < p.value % n);
        products
            .push(DataProduct {
                size_bytes: size,
                value,
                ..p
            })
            .ok()?;
    }
    usize::try_from(n).ok()
}

/// Per chain: its sized downlink (duration, energy), if it has exactly one downlink primitive.
pub type DownlinkSizes = Vec<Option<(u64, u64)>, MAX_CHAINS>;

/// Sets every chain's product sizes to the measured volumes and sizes its downlink to carry
/// them (see the module docs); `prior(p)` is primitive `p`'s predicted (duration, energy) as
/// [`crate::executor::reparameterize`] used them (0 for a primitive already done). Adjusts the
/// chains' durations, energies and product offsets, and returns each chain's downlink size.
pub fn size_downlinks(
    primitives: &[PrimitiveSpec],
    network: &mut FlatNetwork,
    comms: &CommsModel,
    volumes: &VolumeFactors,
    prior: impl Fn(u8) -> Option<(u64, u64)>,
) -> DownlinkSizes {
    let mut out = DownlinkSizes::new();
    for chain in network.chains.iter_mut() {
        // The products' sizes at the measured volumes, in primitive order.
        let mut k = 0usize;
        let mut downlinks = 0usize;
        let mut downlink: Option<(usize, u64, u64)> = None; // (position, duration, energy)
        for (pos, &p) in chain.primitives.iter().enumerate() {
            let Some(spec) = primitives.get(usize::from(p)) else {
                continue;
            };
            if let Some(product) = spec.product {
                if let Some(cp) = chain.products.get_mut(k) {
                    cp.spec.size_bytes = volumes.scale(spec.kind, product.size_bytes);
                }
                k += 1;
            }
            if is_downlink(spec.kind) {
                downlinks += 1;
                let (d, e) = prior(p).unwrap_or((0, 0));
                downlink = Some((pos, d, e));
            }
        }
        let sized = match (downlinks, downlink) {
            (1, Some((pos, d, e))) if d > 0 => {
                let bytes = chain
                    .products
                    .iter()
                    .fold(0u64, |b, p| b.saturating_add(p.spec.size_bytes));
                let need = comms.duration_for(bytes).max(d);
                let energy = u64::try_from(u128::from(e) * u128::from(need) / u128::from(d))
                    .unwrap_or(MAX_ENERGY_MJ)
                    .min(MAX_ENERGY_MJ);
                let (extra_d, extra_e) = (need - d, energy.saturating_sub(e));
                if extra_d > 0 {
                    // Products created after the downlink starts move with its end.
                    let starts_at = chain.primitives.iter().take(pos).fold(0u64, |at, &p| {
                        at.saturating_add(prior(p).map_or(0, |(d, _)| d))
                    });
                    for cp in chain.products.iter_mut() {
                        if cp.offset_us > starts_at {
                            cp.offset_us = cp.offset_us.saturating_add(extra_d);
                        }
                    }
                    chain.duration_us = chain.duration_us.saturating_add(extra_d);
                    chain.energy_mj = chain.energy_mj.saturating_add(extra_e).min(MAX_ENERGY_MJ);
                }
                Some((need, energy))
            }
            _ => None,
        };
        // Never fails: one entry per chain, at most MAX_CHAINS.
        let _ = out.push(sized);
    }
    out
}

/// Counters of a [`DataPlacement`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DataStats {
    /// Downlink problems solved.
    pub checks: u32,
    /// Chains refused because their data, or data already planned, would not go down.
    pub vetoes: u32,
    /// Chains refused because a problem exceeded [`MAX_DATA_PRODUCTS`] or [`MAX_DOWNLINKS`].
    pub capacity_vetoes: u32,
    /// Knapsack nodes over all checks, and the largest of one check.
    pub knapsack_nodes: u64,
    pub max_knapsack_nodes: u64,
    /// Checks whose knapsack was not proven optimal within the budget.
    pub unproven: u32,
}

/// The data the planning knows: the link, what is onboard, the chains' downlink spans, and
/// the energy the current sol's downlinks have already spent.
#[derive(Clone, Copy, Debug)]
pub struct DataView<'a> {
    pub comms: &'a CommsModel,
    pub onboard: &'a [DataProduct],
    pub spans: &'a DownlinkSpans,
    /// (sol, mJ): radio energy already spent in that sol.
    pub spent: (u16, u64),
}

/// A placement with the downlink manager's check on data volume (see the module docs).
pub struct DataPlacement<'a, P> {
    pub inner: P,
    pub data: DataView<'a>,
    pub knapsack_budget: u32,
    manager: DownlinkManager,
    pub stats: DataStats,
}

impl<'a, P> DataPlacement<'a, P> {
    pub fn new(inner: P, data: DataView<'a>) -> Self {
        Self {
            inner,
            data,
            knapsack_budget: DATA_KNAPSACK_BUDGET,
            manager: DownlinkManager::new(),
            stats: DataStats::default(),
        }
    }

    /// Solves the downlink problem of `plan` (and `extra`, placed); `None` past a capacity.
    /// Returns (required products unplaced, whether every product of `extra` is placed).
    fn solve(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        extra: Option<PlacedChain>,
    ) -> Option<(usize, bool)> {
        let comms = self.data.comms;
        let mut opportunities: Vec<(u64, u16, DownlinkOpportunity), MAX_DOWNLINKS> = Vec::new();
        let segment = comms.capacity_of(comms.max_duration_us());
        let mut products: Vec<DataProduct, MAX_DATA_PRODUCTS> = Vec::new();
        for p in self.data.onboard {
            push_segments(&mut products, *p, segment)?;
        }
        let mut first_extra = usize::MAX;
        for p in plan.iter().chain(extra.iter()) {
            let chain = network.chains.get(usize::from(p.chain))?;
            if let Some(Some((from, to))) = self.data.spans.get(usize::from(p.chain)) {
                let s = p.start.0.saturating_add(*from);
                let e = p.start.0.saturating_add(*to);
                opportunities
                    .push((s, p.chain, comms.opportunity(s, e)))
                    .ok()?;
            }
            if Some(p) == extra.as_ref() {
                first_extra = products.len();
            }
            for cp in &chain.products {
                let made = DataProduct {
                    size_bytes: cp.spec.size_bytes,
                    value: cp.spec.value,
                    created_at: MissionTimeUs(p.start.0.saturating_add(cp.offset_us)),
                    tier: cp.spec.tier,
                };
                push_segments(&mut products, made, segment)?;
            }
        }
        opportunities.sort_unstable_by_key(|&(s, c, _)| (s, c));
        let opps: Vec<DownlinkOpportunity, MAX_DOWNLINKS> =
            opportunities.iter().map(|&(_, _, o)| o).collect();
        let mut allocations: Vec<SolAllocation, MAX_SOLS> = Vec::new();
        for o in &opps {
            if !allocations.iter().any(|a| a.sol == o.sol) {
                let spent = if o.sol == self.data.spent.0 {
                    self.data.spent.1
                } else {
                    0
                };
                allocations
                    .push(SolAllocation {
                        sol: o.sol,
                        energy_mj: comms.per_sol_mj.saturating_sub(spent),
                    })
                    .ok()?;
            }
        }
        self.manager.load(&products, &opps, &allocations).ok()?;
        self.manager.step(self.knapsack_budget);
        let knapsack = self.manager.knapsack();
        let nodes = knapsack.nodes() + knapsack.bound_nodes();
        self.stats.checks += 1;
        self.stats.knapsack_nodes += nodes;
        self.stats.max_knapsack_nodes = self.stats.max_knapsack_nodes.max(nodes);
        if !self.manager.proven_optimal() {
            self.stats.unproven += 1;
        }
        let own = first_extra == usize::MAX
            || (first_extra..products.len())
                .all(|i| self.manager.placement(i) != Placement::NotDownlinked);
        Some((self.manager.required_unplaced(), own))
    }

    /// Whether `candidate` at `start` keeps the plan's data downlinkable.
    fn fits(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
        start: MissionTimeUs,
    ) -> bool {
        let placed = PlacedChain {
            chain: candidate,
            start,
        };
        let Some((with, own)) = self.solve(network, plan, Some(placed)) else {
            self.stats.capacity_vetoes += 1;
            return false;
        };
        let creates = network
            .chains
            .get(usize::from(candidate))
            .is_some_and(|c| !c.products.is_empty());
        let ok = if creates {
            own && (with == 0
                || self
                    .solve(network, plan, None)
                    .is_some_and(|(without, _)| with <= without))
        } else {
            // A downlink creating no data: admitted when it carries required data that would
            // otherwise stay onboard (its utility, [`Self::helped`]).
            self.helped(network, plan, with) > 0
        };
        if !ok {
            self.stats.vetoes += 1;
        }
        ok
    }
}

impl<P> DataPlacement<'_, P> {
    /// How many more required products (segments) go down with a candidate than without it,
    /// `with` being the count left behind with it.
    fn helped(&mut self, network: &FlatNetwork, plan: &[PlacedChain], with: usize) -> usize {
        self.solve(network, plan, None)
            .map_or(0, |(without, _)| without.saturating_sub(with))
    }
}

/// Whether chain `c` of `network` creates data or downlinks it.
fn touches_data(network: &FlatNetwork, spans: &DownlinkSpans, c: u16) -> bool {
    network
        .chains
        .get(usize::from(c))
        .is_some_and(|chain| !chain.products.is_empty())
        || matches!(spans.get(usize::from(c)), Some(Some(_)))
}

impl<P: ChainPlacement> ChainPlacement for DataPlacement<'_, P> {
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let start = self.inner.place(network, plan, candidate)?;
        if !touches_data(network, self.data.spans, candidate) {
            return Some(start);
        }
        self.fits(network, plan, candidate, start).then_some(start)
    }

    /// A chain that downlinks without creating data is worth what it saves: a Default-rank
    /// score of 0.25 per required product (segment) it downlinks that would otherwise stay
    /// onboard (at most 1.0); other chains as the inner placement says.
    fn utility(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> RankedUtility {
        let drain = network.chains.get(usize::from(candidate)).is_some_and(|c| {
            c.products.is_empty()
                && matches!(self.data.spans.get(usize::from(candidate)), Some(Some(_)))
        });
        if !drain {
            return self.inner.utility(network, plan, candidate);
        }
        let Some(start) = self.inner.place(network, plan, candidate) else {
            return RankedUtility::ZERO;
        };
        let placed = PlacedChain {
            chain: candidate,
            start,
        };
        let Some((with, _)) = self.solve(network, plan, Some(placed)) else {
            return RankedUtility::ZERO;
        };
        let saved = self.helped(network, plan, with);
        let score = u32::try_from(saved.saturating_mul(2_500))
            .unwrap_or(10_000)
            .min(10_000);
        RankedUtility::single(Rank::Default, Score::new(score).unwrap_or(Score::ZERO))
    }
}

/// What the downlink starting at `start` for `duration_us` (the plan's next) should carry: the
/// manager's assignment over the products onboard and those the rest of the plan creates
/// (`later`: (created, product) pairs), against this downlink at its longest and the plan's
/// later downlinks (`later_downlinks`: [start, end)). Fills `payload` with the onboard products
/// it assigns to this downlink (Critical and Decisional first, as placed), and returns the
/// duration that carries them: at least `duration_us`, at most the overhead and the longest
/// transmission (and `window_end`, when Earth sets earlier).
///
/// In one call: [`NextDownlink::load`], the knapsack's [`DATA_KNAPSACK_BUDGET`] nodes, then
/// [`NextDownlink::finish`]. The executor makes the same three steps over several calls
/// (the knapsack resumes exactly), so that no call of the planner partition runs the whole
/// budget at once.
#[allow(clippy::too_many_arguments)]
pub fn next_downlink(
    comms: &CommsModel,
    onboard: &[DataProduct],
    later: &[DataProduct],
    start: u64,
    duration_us: u64,
    window_end: u64,
    later_downlinks: &[(u64, u64)],
    spent: (u16, u64),
    payload: &mut Vec<DataProduct, MAX_DATA_PRODUCTS>,
) -> u64 {
    let mut manager = DownlinkManager::new();
    let mut next = NextDownlink::new();
    let loaded = next.load(
        comms,
        onboard,
        later,
        (start, duration_us, window_end),
        later_downlinks,
        spent,
        &mut manager,
        payload,
    );
    if loaded {
        manager.step(DATA_KNAPSACK_BUDGET);
    }
    next.finish(comms, &manager, payload)
}

/// [`next_downlink`] in parts: what [`NextDownlink::finish`] needs of what
/// [`NextDownlink::load`] set up, while the knapsack runs in between.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct NextDownlink {
    /// Per onboard product (in `payload`'s order after `load`), its items' range.
    ranges: Vec<(u8, u8), MAX_DATA_PRODUCTS>,
    /// The planned duration, and the longest the downlink may last.
    duration_us: u64,
    longest: u64,
    /// Whether the problem was loaded (otherwise the planned duration stands, nothing sent).
    loaded: bool,
}

impl NextDownlink {
    pub const fn new() -> Self {
        Self {
            ranges: Vec::new(),
            duration_us: 0,
            longest: 0,
            loaded: false,
        }
    }

    /// Loads [`next_downlink`]'s problem into `manager` (`at`: the downlink's start, planned
    /// duration and Earth's setting) and `payload` with the onboard products it may carry;
    /// false when the problem does not load (the downlink then keeps its planned duration
    /// and carries nothing). Then run the knapsack ([`DATA_KNAPSACK_BUDGET`] nodes in all) and
    /// [`Self::finish`].
    #[allow(clippy::too_many_arguments)]
    pub fn load(
        &mut self,
        comms: &CommsModel,
        onboard: &[DataProduct],
        later: &[DataProduct],
        at: (u64, u64, u64),
        later_downlinks: &[(u64, u64)],
        spent: (u16, u64),
        manager: &mut DownlinkManager,
        payload: &mut Vec<DataProduct, MAX_DATA_PRODUCTS>,
    ) -> bool {
        let (start, duration_us, window_end) = at;
        payload.clear();
        self.ranges.clear();
        self.duration_us = duration_us;
        self.loaded = false;
        let longest = comms
            .max_duration_us()
            .max(duration_us)
            .min(window_end.saturating_sub(start).max(duration_us));
        self.longest = longest;
        let mut opps: Vec<DownlinkOpportunity, MAX_DOWNLINKS> = Vec::new();
        let _ = opps.push(comms.opportunity(start, start.saturating_add(longest)));
        for &(s, e) in later_downlinks {
            if opps.push(comms.opportunity(s, e)).is_err() {
                break;
            }
        }
        let segment = comms.capacity_of(comms.max_duration_us());
        let mut products: Vec<DataProduct, MAX_DATA_PRODUCTS> = Vec::new();
        for (k, p) in onboard.iter().chain(later).enumerate() {
            let first = products.len();
            match push_segments(&mut products, *p, segment) {
                Some(n) => {
                    // Only the onboard products' ranges are read (at most 64 items: u8).
                    if k < onboard.len() {
                        let _ = self.ranges.push((first as u8, (first + n) as u8));
                        let _ = payload.push(*p);
                    }
                }
                None => break,
            }
        }
        let mut allocations: Vec<SolAllocation, MAX_SOLS> = Vec::new();
        for o in &opps {
            if !allocations.iter().any(|a| a.sol == o.sol) {
                let spent = if o.sol == spent.0 { spent.1 } else { 0 };
                let _ = allocations.push(SolAllocation {
                    sol: o.sol,
                    energy_mj: comms.per_sol_mj.saturating_sub(spent),
                });
            }
        }
        if manager.load(&products, &opps, &allocations).is_err() {
            payload.clear();
            return false;
        }
        self.loaded = true;
        true
    }

    /// After the knapsack: keeps in `payload` (as [`Self::load`] left it) the onboard products
    /// assigned to this downlink, ordered by tier and age, and returns the duration that
    /// carries them ([`next_downlink`]'s answer).
    pub fn finish(
        &self,
        comms: &CommsModel,
        manager: &DownlinkManager,
        payload: &mut Vec<DataProduct, MAX_DATA_PRODUCTS>,
    ) -> u64 {
        if !self.loaded {
            payload.clear();
            return self.duration_us;
        }
        let segment = comms.capacity_of(comms.max_duration_us());
        let mut required = 0u64;
        let mut k = 0usize;
        payload.retain(|p| {
            let (a, b) = self.ranges.get(k).copied().unwrap_or((0, 0));
            k += 1;
            let here: u64 = (usize::from(a)..usize::from(b))
                .filter(|&i| manager.placement(i) == Placement::Downlink(0))
                .filter_map(|i| manager.products().get(i).map(|x| x.size_bytes))
                .sum();
            if here > 0 && p.tier != Tier::Residual {
                required = required.saturating_add(here);
            }
            here > 0
        });
        payload.sort_unstable_by_key(|p| (p.tier, p.created_at));
        // Long enough for the required products; Residual ones ride in what that leaves.
        let duration = comms
            .duration_for(required)
            .max(self.duration_us)
            .min(self.longest);
        let mut room = comms.capacity_of(duration);
        payload.retain(|p| {
            // A product larger than any one downlink goes down in part.
            let fits = p.size_bytes <= room || (p.size_bytes > segment && room > 0);
            if fits {
                room = room.saturating_sub(p.size_bytes);
            }
            fits
        });
        duration
    }
}
