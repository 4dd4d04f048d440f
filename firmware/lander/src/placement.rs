//! A simple "can be added" check for the search ([`ChainPlacement`]): the lander does one
//! chain at a time (a single claimable resource: the arm, the instruments and the radio are
//! used in sequence), the battery cannot be recharged (chain energy plus the hotel load's
//! background drain up to the latest end), each chain runs only in its mission phases
//! ([`PhaseTimeline`]), exogenous chains start at their fixed time, and a waiting chain does
//! not start while a ground hold is in force.
//!
//! A chain is placed at the earliest start that satisfies all of these. The set of valid starts
//! is a union of intervals whose left ends are among: the horizon start, the end of a placed
//! chain, a phase change, the release of a hold, and (for a chain that holds) just after a
//! waiting chain's start minus its own duration; so checking those candidates in increasing
//! order gives the exact earliest start. It is the reference the tests use and what the
//! measurements run; the MEXEC timelines plug in through [`crate::mexec`].
//!
//! **Earth in view** ([`EarthView`], issue 11 items 5 and 8): when the placement is given the
//! in-view windows (an external availability timeline, [`ViewTimeline`]), a chain's downlink
//! primitives (from the first one's start to the last one's end, [`DownlinkSpans`]) must lie
//! entirely inside one window, so the plan's predicted downlink times are real; each window's
//! opening minus the chain's downlink offset is then one more candidate start (the valid starts
//! for a window are an interval whose left end is that), so the earliest start stays exact.
//! A chain that creates data its own downlinks do not carry (no downlink, or products created
//! after its first downlink starts) is placed only if some window still has room after the
//! chain's end: in-view time before the horizon end not taken by a placed chain. So a
//! candidate whose data cannot be downlinked before the mission ends is not added. Without
//! windows ([`EarthView::default`]) Earth is not modelled (always in view), as before.
//! How much data a downlink can carry is not checked here: [`crate::comms::DataPlacement`]
//! wraps this placement with the downlink manager.
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
use crate::htn::{Chain, FlatNetwork, PhaseTimeline, PrimitiveKind, PrimitiveSpec};
use crate::search::{ChainPlacement, PlacedChain};

/// One Earth-in-view window, [start, end).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewWindow {
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
}

/// Why a [`ViewTimeline`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewError {
    /// More than [`MAX_VIEW_WINDOWS`] windows.
    TooMany,
    /// A window is empty, or not after the previous one (windows must be sorted and disjoint).
    Order,
}

/// The Earth-in-view windows: sorted, disjoint, non-empty, at most [`MAX_VIEW_WINDOWS`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ViewTimeline {
    windows: Vec<ViewWindow, MAX_VIEW_WINDOWS>,
}

impl ViewTimeline {
    pub fn new(windows: &[ViewWindow]) -> Result<Self, ViewError> {
        let mut prev_end = 0u64;
        for (i, w) in windows.iter().enumerate() {
            if w.start >= w.end || (i > 0 && w.start.0 < prev_end) {
                return Err(ViewError::Order);
            }
            prev_end = w.end.0;
        }
        Ok(Self {
            windows: Vec::from_slice(windows).map_err(|_| ViewError::TooMany)?,
        })
    }

    pub fn windows(&self) -> &[ViewWindow] {
        &self.windows
    }

    /// Whether [start, end) lies inside one window. The windows are sorted and disjoint, so
    /// only the last one opening at or before `start` can hold it (an earlier one ends at or
    /// before that one opens): found by binary search, not by a scan of every window.
    pub fn contains(&self, start: u64, end: u64) -> bool {
        let after = self.windows.partition_point(|w| w.start.0 <= start);
        after
            .checked_sub(1)
            .and_then(|i| self.windows.get(i))
            .is_some_and(|w| end <= w.end.0)
    }
}

/// Per chain of the network (by index): its downlink span relative to the chain's start, from
/// the first downlink primitive's start to the last one's end, or `None` (no downlink). A chain
/// past the end of the list has none.
pub type DownlinkSpans = Vec<Option<(u64, u64)>, MAX_CHAINS>;

/// Whether `kind` transmits to Earth.
pub fn is_downlink(kind: PrimitiveKind) -> bool {
    matches!(
        kind,
        PrimitiveKind::Downlink | PrimitiveKind::DownlinkWithGroundHold
    )
}

/// The downlink spans of `network`'s chains, primitive `p` taking `duration(p)` (`None`: a
/// primitive the model does not have, taking no time).
pub fn downlink_spans(
    primitives: &[PrimitiveSpec],
    network: &FlatNetwork,
    duration: impl Fn(u8) -> Option<u64>,
) -> DownlinkSpans {
    let mut out = DownlinkSpans::new();
    for chain in network.chains.iter() {
        let mut at = 0u64;
        let mut span: Option<(u64, u64)> = None;
        for &p in &chain.primitives {
            let d = duration(p).unwrap_or(0);
            let end = at.saturating_add(d);
            if primitives
                .get(usize::from(p))
                .is_some_and(|s| is_downlink(s.kind))
            {
                span = Some(span.map_or((at, end), |(o, _)| (o, end)));
            }
            at = end;
        }
        // Never fails: one entry per chain, at most MAX_CHAINS.
        let _ = out.push(span);
    }
    out
}

/// What the placement knows about Earth: the in-view windows and each chain's downlinks.
/// The default (no windows) does not model Earth: downlinks go anywhere.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EarthView {
    pub windows: ViewTimeline,
    pub downlinks: DownlinkSpans,
}

impl EarthView {
    /// The windows, with the spans of `network` at the model's prior durations.
    pub fn new(windows: ViewTimeline, primitives: &[PrimitiveSpec], network: &FlatNetwork) -> Self {
        let downlinks = downlink_spans(primitives, network, |p| {
            primitives.get(usize::from(p)).map(|s| s.duration_us)
        });
        Self { windows, downlinks }
    }

    /// Whether Earth is modelled at all.
    pub fn modelled(&self) -> bool {
        !self.windows.windows().is_empty()
    }

    fn span(&self, chain: u16) -> Option<(u64, u64)> {
        self.downlinks.get(usize::from(chain)).copied().flatten()
    }
}

/// The simple single-resource timeline with energy.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TimelinePlacement {
    /// Nothing starts before this.
    pub horizon_start: MissionTimeUs,
    /// Everything ends by this.
    pub horizon_end: MissionTimeUs,
    pub phases: PhaseTimeline,
    /// Battery charge at `horizon_start`, in mJ.
    pub battery_mj: u64,
    /// Background drain (hotel load, seismometer on) in mW, i.e. mJ per second.
    pub hotel_load_mw: u64,
    /// Earth-in-view windows and the chains' downlinks ([`EarthView::default`]: not modelled).
    pub earth: EarthView,
}

/// Candidate starts examined for one placement.
const MAX_PLACEMENT_CANDIDATES: usize =
    3 * MAX_PLAN_CHAINS + MAX_PHASE_CHANGES + MAX_VIEW_WINDOWS + 1;

#[derive(Clone, Copy)]
struct Span {
    start: u64,
    end: u64,
    holds: bool,
    waits: bool,
    uplink: bool,
}

fn span_of(chain: &Chain, start: MissionTimeUs) -> Span {
    Span {
        start: start.0,
        end: start.0.saturating_add(chain.duration_us),
        holds: chain.holds_for_ground,
        waits: chain.waits_for_ground_release,
        uplink: chain.is_uplink,
    }
}

impl TimelinePlacement {
    /// Energy the hotel load drains from the horizon start to `t`, in mJ.
    pub fn hotel_energy_mj(&self, t: MissionTimeUs) -> u64 {
        let seconds_us = t.0.saturating_sub(self.horizon_start.0);
        // In u64 when the product fits (always at mission sizes): the same value without the
        // 128-bit division, a library call on the 32-bit target.
        if let Some(product) = self.hotel_load_mw.checked_mul(seconds_us) {
            return product / 1_000_000;
        }
        let mj = u128::from(self.hotel_load_mw) * u128::from(seconds_us) / 1_000_000;
        u64::try_from(mj).unwrap_or(u64::MAX)
    }

    /// Whether `energy_mj` plus the hotel load's energy to `t` is within the battery:
    /// `energy_mj.saturating_add(self.hotel_energy_mj(t)) <= self.battery_mj`, decided by
    /// multiplying instead of dividing when the numbers fit in u64 (a 64-bit division is a
    /// library call on the 32-bit target): floor(p / 10^6) <= room iff p <= room * 10^6 +
    /// 999,999.
    fn energy_fits(&self, t: MissionTimeUs, energy_mj: u64) -> bool {
        if self.battery_mj == u64::MAX {
            return true;
        }
        let Some(room) = self.battery_mj.checked_sub(energy_mj) else {
            return false;
        };
        let seconds_us = t.0.saturating_sub(self.horizon_start.0);
        let limit = room
            .checked_mul(1_000_000)
            .and_then(|l| l.checked_add(999_999));
        match (self.hotel_load_mw.checked_mul(seconds_us), limit) {
            (Some(product), Some(limit)) => product <= limit,
            _ => self.hotel_energy_mj(t) <= room,
        }
    }

    /// When the hold that starts at `from` is released: the end of the first uplink that starts
    /// at or after `from`, or never.
    fn release(spans: &[Span], extra: Option<Span>, from: u64) -> u64 {
        spans
            .iter()
            .chain(extra.iter())
            .filter(|s| s.uplink && s.start >= from)
            .min_by_key(|s| s.start)
            .map_or(u64::MAX, |s| s.end)
    }

    /// Whether the data `chain` creates (placed as `x`) can reach Earth: its downlinks lie in a
    /// window, and data they do not carry has a window with room after the chain's end.
    fn reaches_earth(&self, spans: &[Span], x: Span, chain: &Chain, index: u16) -> bool {
        if !self.earth.modelled() {
            return true;
        }
        let own = self.earth.span(index);
        if let Some((from, to)) = own {
            if !self
                .earth
                .windows
                .contains(x.start.saturating_add(from), x.start.saturating_add(to))
            {
                return false;
            }
        }
        let later = chain
            .products
            .iter()
            .any(|p| own.is_none_or(|(from, _)| p.offset_us > from));
        !later || self.room_after(spans, x.end)
    }

    /// Whether some window has in-view time after `t`, before the horizon end, that no placed
    /// chain takes.
    fn room_after(&self, spans: &[Span], t: u64) -> bool {
        self.earth.windows.windows().iter().any(|w| {
            let (a, b) = (w.start.0.max(t), w.end.0.min(self.horizon_end.0));
            if a >= b {
                return false;
            }
            let taken: u64 = spans
                .iter()
                .map(|s| s.end.min(b).saturating_sub(s.start.max(a)))
                .sum();
            taken < b - a
        })
    }

    /// Whether `x` may be added next to `spans` (no overlap, holds respected both ways).
    fn compatible(&self, spans: &[Span], x: Span, chain: &Chain) -> bool {
        if x.start < self.horizon_start.0 || x.end > self.horizon_end.0 {
            return false;
        }
        if !self
            .phases
            .allows_span(chain.phases, MissionTimeUs(x.start), MissionTimeUs(x.end))
        {
            return false;
        }
        // One chain at a time (zero-length chains overlap nothing).
        if spans
            .iter()
            .any(|s| x.start < s.end && s.start < x.end && x.start < x.end && s.start < s.end)
        {
            return false;
        }
        let blocked = |w: u64, h: &Span| {
            let release = Self::release(spans, Some(x), h.end);
            w >= h.end && w < release
        };
        if x.waits
            && spans
                .iter()
                .filter(|h| h.holds)
                .any(|h| blocked(x.start, h))
        {
            return false;
        }
        if x.holds
            && spans
                .iter()
                .filter(|w| w.waits)
                .any(|w| blocked(w.start, &x))
        {
            return false;
        }
        true
    }
}

impl TimelinePlacement {
    /// The placement as first written (each candidate start checked against every placed
    /// chain, each hold's release searched again per check): the reference
    /// [`ChainPlacement::place`] must agree with (`tests/placement_index.rs`). Not used by the
    /// search.
    #[doc(hidden)]
    pub fn place_reference(
        &self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let chain = network.chains.get(usize::from(candidate))?;
        let mut spans: Vec<Span, MAX_PLAN_CHAINS> = Vec::new();
        let (plan_energy_mj, latest_end) = self.plan_spans(network, plan, &mut spans)?;
        let energy_mj = plan_energy_mj.saturating_add(chain.energy_mj);
        let fits_energy = |end: u64| {
            let end = MissionTimeUs(end.max(latest_end));
            energy_mj.saturating_add(self.hotel_energy_mj(end)) <= self.battery_mj
        };
        let valid = |x: &Span| {
            self.compatible(&spans, *x, chain)
                && fits_energy(x.end)
                && self.reaches_earth(&spans, *x, chain, candidate)
        };
        if let Some(start) = chain.fixed_start {
            return valid(&span_of(chain, start)).then_some(start);
        }
        let mut candidates: Vec<u64, MAX_PLACEMENT_CANDIDATES> = Vec::new();
        let _ = candidates.push(self.horizon_start.0);
        for s in &spans {
            let _ = candidates.push(s.end);
            if s.holds {
                let _ = candidates.push(Self::release(&spans, None, s.end));
            }
            if chain.holds_for_ground && s.waits {
                let _ = candidates.push((s.start + 1).saturating_sub(chain.duration_us));
            }
        }
        if let Some(from) =
            self.phases
                .earliest_span(chain.phases, self.horizon_start, chain.duration_us)
        {
            let _ = candidates.push(from.0);
        }
        for t in (0..MAX_PHASE_CHANGES).filter_map(|i| self.phase_change(i)) {
            let _ = candidates.push(t.0);
        }
        if let (true, Some((from, _))) = (self.earth.modelled(), self.earth.span(candidate)) {
            // The downlink starts as a window opens.
            for w in self.earth.windows.windows() {
                if let Some(s) = w.start.0.checked_sub(from) {
                    let _ = candidates.push(s);
                }
            }
        }
        candidates.sort_unstable();
        candidates
            .iter()
            .filter(|&&s| s >= self.horizon_start.0 && s != u64::MAX)
            .map(|&s| span_of(chain, MissionTimeUs(s)))
            .find(valid)
            .map(|x| MissionTimeUs(x.start))
    }
}

impl TimelinePlacement {
    fn phase_change(&self, index: usize) -> Option<MissionTimeUs> {
        self.phases.change_time(index)
    }
}

/// The plan's chains indexed once per placement, so that each candidate start is checked in
/// about `log n` steps instead of against every chain (and every hold's release searched once,
/// not once per check): the free gaps between the plan's chains (from the busy intervals sorted
/// by start), the uplinks sorted by start (ties in plan order), and each hold's release by the
/// plan's uplinks.
/// [`ChainPlacement::place`] with it decides exactly as [`TimelinePlacement::place_reference`].
/// The arrays are the caller's locals, filled in place ([`index_plan`]): no large value is
/// built and moved per placement.
#[derive(Clone, Copy)]
struct PlanIndex<'a> {
    /// The free gaps [a, b) between `from` and `busy_end`, in increasing order: no non-empty
    /// span meets a gap, and every instant of `[from, busy_end)` outside the gaps is in one.
    gaps: &'a [(u64, u64)],
    /// Uplinks as (start, position in the plan, end), sorted: by start, ties in plan order.
    uplinks: &'a [(u64, u16, u64)],
    /// Holding chains as (end, the plan's uplink that releases it: (start, end)).
    holds: &'a [(u64, Option<(u64, u64)>)],
    /// Starts of the chains that wait for a ground release.
    waits: &'a [u64],
    /// The latest of `waits` (0: none): a holding chain ending after it blocks no waiting
    /// chain of the plan.
    latest_wait: u64,
    /// The latest end of a non-empty span (0: none).
    busy_end: u64,
    /// The longest free time from `from` to `busy_end` between non-empty spans: a non-empty
    /// chain longer than this cannot start at any `s` in `[from, busy_end)` without
    /// overlapping one (whatever is free there is a gap shorter than the chain).
    longest_gap: u64,
}

type Busy = Vec<(u64, u64), MAX_PLAN_CHAINS>;
type Uplinks = Vec<(u64, u16, u64), MAX_PLAN_CHAINS>;
type Holds = Vec<(u64, Option<(u64, u64)>), MAX_PLAN_CHAINS>;
type Waits = Vec<u64, MAX_PLAN_CHAINS>;

/// The plan's first uplink (by start, then plan order) that starts at or after `from`.
fn first_uplink(uplinks: &[(u64, u16, u64)], from: u64) -> Option<(u64, u64)> {
    let at = uplinks.partition_point(|&(start, _, _)| start < from);
    uplinks.get(at).map(|&(start, _, end)| (start, end))
}

/// Indexes `spans` (the plan) into the caller's (empty) arrays; `from` is the horizon start.
fn index_plan<'a>(
    spans: &[Span],
    from: u64,
    busy: &'a mut Busy,
    uplinks: &'a mut Uplinks,
    holds: &'a mut Holds,
    waits: &'a mut Waits,
) -> PlanIndex<'a> {
    // Never fail: at most one entry per span, at most MAX_PLAN_CHAINS spans.
    for (position, s) in spans.iter().enumerate() {
        if s.start < s.end {
            let _ = busy.push((s.start, s.end));
        }
        if s.uplink {
            let _ = uplinks.push((s.start, position as u16, s.end));
        }
        if s.waits {
            let _ = waits.push(s.start);
        }
    }
    busy.sort_unstable();
    // The gaps, written over the sorted intervals (gap k is written at or before interval k).
    let mut latest = from;
    let mut longest_gap = 0u64;
    let mut gaps = 0usize;
    for k in 0..busy.len() {
        let Some(&(start, end)) = busy.get(k) else {
            break;
        };
        if start > latest {
            longest_gap = longest_gap.max(start - latest);
            if let Some(slot) = busy.get_mut(gaps) {
                *slot = (latest, start);
            }
            gaps += 1;
        }
        latest = latest.max(end);
    }
    let busy_end = if busy.is_empty() { 0 } else { latest };
    busy.truncate(gaps);
    let latest_wait = waits.iter().copied().max().unwrap_or(0);
    // Equal starts in plan order, as `TimelinePlacement::release` takes the first.
    uplinks.sort_unstable();
    for s in spans.iter().filter(|s| s.holds) {
        let base = first_uplink(uplinks, s.end);
        let _ = holds.push((s.end, base));
    }
    PlanIndex {
        busy_end,
        longest_gap,
        latest_wait,
        gaps: busy,
        uplinks,
        holds,
        waits,
    }
}

impl PlanIndex<'_> {
    /// [`TimelinePlacement::release`] over the plan and `x`, given the plan's own answer
    /// `base` for `from`: `x` releases only if it is an uplink starting strictly before it.
    fn release_with(base: Option<(u64, u64)>, x: &Span, from: u64) -> u64 {
        if x.uplink && x.start >= from && base.is_none_or(|(start, _)| x.start < start) {
            return x.end;
        }
        base.map_or(u64::MAX, |(_, end)| end)
    }

    /// Whether non-empty `x` overlaps a non-empty span of the plan, for `x` starting at or
    /// after `from`: it does unless it starts after every span or lies inside one gap (the
    /// last gap opening at or before its start).
    fn overlaps(&self, x: &Span) -> bool {
        if x.start >= x.end || x.start >= self.busy_end {
            return false;
        }
        let after = self.gaps.partition_point(|&(a, _)| a <= x.start);
        after
            .checked_sub(1)
            .and_then(|i| self.gaps.get(i))
            .is_none_or(|&(_, b)| x.end > b)
    }
}

impl TimelinePlacement {
    /// [`Self::compatible`] with the plan indexed; `free`: `x` is known to overlap no span of
    /// the plan (lies inside a gap of the index), so that is not searched again.
    fn compatible_indexed(&self, index: PlanIndex<'_>, x: Span, chain: &Chain, free: bool) -> bool {
        if x.start < self.horizon_start.0
            || x.end > self.horizon_end.0
            || (!free && index.overlaps(&x))
        {
            return false;
        }
        if !self
            .phases
            .allows_span(chain.phases, MissionTimeUs(x.start), MissionTimeUs(x.end))
        {
            return false;
        }
        // A chain that is not an uplink releases no hold: each hold blocks [end, its plan
        // release), as `release_with` gives for it, without its branches.
        if x.waits
            && if x.uplink {
                index.holds.iter().any(|&(end, base)| {
                    x.start >= end && x.start < PlanIndex::release_with(base, &x, end)
                })
            } else {
                index.holds.iter().any(|&(end, base)| {
                    x.start >= end && x.start < base.map_or(u64::MAX, |(_, release)| release)
                })
            }
        {
            return false;
        }
        // No waiting chain starts at or after `x.end` when `x.end` is past the latest one.
        if x.holds && !index.waits.is_empty() && x.end <= index.latest_wait {
            let release = PlanIndex::release_with(first_uplink(index.uplinks, x.end), &x, x.end);
            if index
                .waits
                .iter()
                .any(|&start| start >= x.end && start < release)
            {
                return false;
            }
        }
        true
    }
}

impl TimelinePlacement {
    /// What both placements start from: the plan's spans (into the caller's `spans`, not
    /// returned by value: a plan-sized vector copied per placement), their energy (saturating:
    /// the same whatever the order the candidate's is added in), and the latest end among them
    /// (the horizon's start for an empty plan). None when the plan names a chain the network
    /// does not have or holds more than a plan can.
    fn plan_spans(
        &self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        spans: &mut Vec<Span, MAX_PLAN_CHAINS>,
    ) -> Option<(u64, u64)> {
        spans.clear();
        let mut energy_mj = 0u64;
        let mut latest_end = self.horizon_start.0;
        for p in plan {
            let c = network.chains.get(usize::from(p.chain))?;
            let s = span_of(c, p.start);
            latest_end = latest_end.max(s.end);
            energy_mj = energy_mj.saturating_add(c.energy_mj);
            spans.push(s).ok()?;
        }
        Some((energy_mj, latest_end))
    }
}

/// A plan's spans with what a placement needs of them: the spans in plan order, their energy
/// (saturating), their latest end (the horizon start for an empty plan) and the index.
#[derive(Clone, Copy)]
struct IndexedPlan<'a> {
    spans: &'a [Span],
    energy_mj: u64,
    latest_end: u64,
    index: PlanIndex<'a>,
}

impl ChainPlacement for TimelinePlacement {
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let chain = network.chains.get(usize::from(candidate))?;
        let mut spans: Vec<Span, MAX_PLAN_CHAINS> = Vec::new();
        // Without the candidate's energy: `place_indexed` adds it (saturating sums of
        // unsigned values do not depend on the order).
        let (energy_mj, latest_end) = self.plan_spans(network, plan, &mut spans)?;
        let (mut busy, mut uplinks) = (Busy::new(), Uplinks::new());
        let (mut holds, mut waits) = (Holds::new(), Waits::new());
        let index = index_plan(
            &spans,
            self.horizon_start.0,
            &mut busy,
            &mut uplinks,
            &mut holds,
            &mut waits,
        );
        self.place_indexed(
            chain,
            candidate,
            IndexedPlan {
                spans: &spans,
                energy_mj,
                latest_end,
                index,
            },
        )
    }
}

impl TimelinePlacement {
    /// [`ChainPlacement::place`] of chain `candidate` (`chain`) on the plan indexed.
    fn place_indexed(
        &self,
        chain: &Chain,
        candidate: u16,
        plan: IndexedPlan<'_>,
    ) -> Option<MissionTimeUs> {
        let (spans, index, latest_end) = (plan.spans, plan.index, plan.latest_end);
        let energy_mj = plan.energy_mj.saturating_add(chain.energy_mj);
        let from = self.horizon_start.0;
        let fits_energy =
            |end: u64| self.energy_fits(MissionTimeUs(end.max(latest_end)), energy_mj);
        // `free`: the caller knows that `x` overlaps no span of the plan (it lies inside a
        // gap), so the index's binary search for it is not made again.
        let valid = |x: &Span, free: bool| {
            self.compatible_indexed(index, *x, chain, free)
                && fits_energy(x.end)
                && self.reaches_earth(spans, *x, chain, candidate)
        };
        if let Some(start) = chain.fixed_start {
            return valid(&span_of(chain, start), false).then_some(start);
        }
        // The earliest valid one of `place_reference`'s candidate starts, found without
        // sorting them: a candidate is checked only while it is earlier than the best so far
        // (those before the horizon start, and never, are not candidates), and not where the
        // chain is longer than any gap before the plan's latest end (it would overlap).
        let mut best = u64::MAX;
        let consider = |s: u64, best: &mut u64, free: bool| {
            if s >= from
                && s < *best
                && !(s < index.busy_end
                    && s.saturating_add(chain.duration_us) - s > index.longest_gap)
                && valid(&span_of(chain, MissionTimeUs(s)), free)
            {
                *best = s;
            }
        };
        consider(from, &mut best, false);
        // A span's end is a candidate. For a chain of non-zero length, one before the plan's
        // latest end can only be valid where a gap opens (the chain must lie inside a gap,
        // and a span ending strictly inside a gap would meet it), so only those, the latest
        // end and the ends of empty spans are checked: every gap opens at `from` or at a
        // span's end.
        let all_ends = chain.duration_us == 0;
        if !all_ends {
            // A chain longer than a gap overlaps a span if it starts at the gap's opening
            // (the check's overlap test would say so): not checked.
            for &(a, b) in index.gaps {
                if a >= best {
                    break;
                }
                if b - a >= chain.duration_us {
                    // It lies inside this gap: free.
                    consider(a, &mut best, true);
                }
            }
            if !index.gaps.is_empty() || index.busy_end > 0 {
                consider(index.busy_end, &mut best, false);
            }
        }
        for s in spans {
            if all_ends || s.start >= s.end {
                consider(s.end, &mut best, false);
            }
            if chain.holds_for_ground && s.waits {
                consider(
                    (s.start + 1).saturating_sub(chain.duration_us),
                    &mut best,
                    false,
                );
            }
        }
        for &(_, base) in index.holds {
            consider(base.map_or(u64::MAX, |(_, end)| end), &mut best, false);
        }
        if let Some(at) =
            self.phases
                .earliest_span(chain.phases, self.horizon_start, chain.duration_us)
        {
            consider(at.0, &mut best, false);
        }
        for t in (0..MAX_PHASE_CHANGES).filter_map(|i| self.phase_change(i)) {
            consider(t.0, &mut best, false);
        }
        if let (true, Some((offset, _))) = (self.earth.modelled(), self.earth.span(candidate)) {
            // The downlink starts as a window opens.
            // The openings are in increasing order: past the best so far the rest are later
            // still, and one where the chain would not lie inside a gap of the plan is skipped
            // without the full check (a gap pointer moves forward with them).
            let mut opened = 0usize;
            for w in self.earth.windows.windows() {
                let Some(s) = w.start.0.checked_sub(offset) else {
                    continue;
                };
                if s >= best {
                    break;
                }
                let mut free = false;
                if chain.duration_us > 0 && s >= from && s < index.busy_end {
                    while index.gaps.get(opened).is_some_and(|&(a, _)| a <= s) {
                        opened += 1;
                    }
                    let inside = opened
                        .checked_sub(1)
                        .and_then(|i| index.gaps.get(i))
                        .is_some_and(|&(_, b)| s.saturating_add(chain.duration_us) <= b);
                    if !inside {
                        continue;
                    }
                    // Inside the gap found: what the overlap test would find again.
                    free = true;
                }
                consider(s, &mut best, free);
            }
        }
        (best != u64::MAX).then_some(MissionTimeUs(best))
    }
}

/// The plan index kept between placements ([`CachedTimeline`]): the search asks for many
/// chains on one plan (a node's pairs are often explored one after the other) and a child's
/// plan is its parent's plus one chain, so the index of the last plan asked is kept and, for a
/// plan that extends it by one chain, updated in place (that chain's interval taken out of the
/// gaps, its uplink inserted in order, the holds' releases it changes updated) instead of
/// built again with two sorts. Any other plan is indexed again from the start, chain by chain
/// the same way. Decides exactly as [`TimelinePlacement`]'s own placement
/// (`tests/placement_index.rs`). Heap-free, about 7.7 KB at [`MAX_PLAN_CHAINS`].
#[derive(Clone)]
pub struct PlanIndexCache {
    /// The plan indexed (empty and `from` 0 when nothing is: an empty plan indexes to nothing).
    plan: Vec<PlacedChain, MAX_PLAN_CHAINS>,
    /// The horizon start it was indexed from; `None`: nothing cached.
    from: Option<u64>,
    spans: Vec<Span, MAX_PLAN_CHAINS>,
    energy_mj: u64,
    latest_end: u64,
    gaps: Busy,
    uplinks: Uplinks,
    holds: Holds,
    waits: Waits,
    /// `index_plan`'s `latest`: the latest end of a non-empty span, at least `from`.
    latest: u64,
    /// Whether some span is non-empty (`busy_end` is 0 otherwise).
    busy: bool,
    longest_gap: u64,
    latest_wait: u64,
}

impl Default for PlanIndexCache {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a plan could not be indexed: it names a chain the network does not have, or holds more
/// than a plan can.
struct Unindexable;

impl PlanIndexCache {
    pub const fn new() -> Self {
        Self {
            plan: Vec::new(),
            from: None,
            spans: Vec::new(),
            energy_mj: 0,
            latest_end: 0,
            gaps: Vec::new(),
            uplinks: Vec::new(),
            holds: Vec::new(),
            waits: Vec::new(),
            latest: 0,
            busy: false,
            longest_gap: 0,
            latest_wait: 0,
        }
    }

    /// Forgets the plan indexed: to be called whenever the network's chains change (their
    /// durations, flags), which the cache cannot see.
    pub fn clear(&mut self) {
        self.from = None;
    }

    fn reset(&mut self, from: u64) {
        self.plan.clear();
        self.spans.clear();
        self.gaps.clear();
        self.uplinks.clear();
        self.holds.clear();
        self.waits.clear();
        self.from = Some(from);
        self.energy_mj = 0;
        self.latest_end = from;
        self.latest = from;
        self.busy = false;
        self.longest_gap = 0;
        self.latest_wait = 0;
    }

    /// Makes the cache index `plan` from `from`.
    fn index(&mut self, network: &FlatNetwork, plan: &[PlacedChain], from: u64) -> bool {
        let known = self.plan.len();
        let extends = self.from == Some(from)
            && plan.len() >= known
            && plan.len() <= known + 1
            && plan
                .get(..known)
                .is_some_and(|head| head == self.plan.as_slice());
        let result = if extends {
            match plan.get(known) {
                Some(p) => self.add(network, *p),
                None => Ok(()),
            }
        } else {
            self.reset(from);
            plan.iter().try_for_each(|p| self.add(network, *p))
        };
        if result.is_err() {
            self.from = None;
        }
        result.is_ok()
    }

    /// Adds `placed` at the end of the plan indexed: what `index_plan` would give for the plan
    /// with it (the gaps are the free time of `[from, latest)` in maximal intervals, so
    /// taking one more busy interval out of them gives the same gaps as sorting every interval
    /// again; the uplinks are sorted by (start, position), the new one having the last
    /// position; a hold's release is the first uplink at or after its end).
    fn add(&mut self, network: &FlatNetwork, placed: PlacedChain) -> Result<(), Unindexable> {
        let chain = network
            .chains
            .get(usize::from(placed.chain))
            .ok_or(Unindexable)?;
        let s = span_of(chain, placed.start);
        let position = self.spans.len() as u16;
        self.spans.push(s).map_err(|_| Unindexable)?;
        // Never fails: one entry per span.
        let _ = self.plan.push(placed);
        self.energy_mj = self.energy_mj.saturating_add(chain.energy_mj);
        self.latest_end = self.latest_end.max(s.end);
        if s.start < s.end {
            self.take_busy(s.start, s.end);
        }
        if s.uplink {
            let entry = (s.start, position, s.end);
            let at = self.uplinks.partition_point(|u| *u < entry);
            let _ = self.uplinks.insert(at, entry);
            for (end, base) in self.holds.iter_mut() {
                if s.start >= *end && base.is_none_or(|(start, _)| s.start < start) {
                    *base = Some((s.start, s.end));
                }
            }
        }
        if s.waits {
            let _ = self.waits.push(s.start);
            self.latest_wait = self.latest_wait.max(s.start);
        }
        if s.holds {
            let base = first_uplink(&self.uplinks, s.end);
            let _ = self.holds.push((s.end, base));
        }
        Ok(())
    }

    /// Takes the non-empty interval [start, end) out of the free time.
    fn take_busy(&mut self, start: u64, end: u64) {
        self.busy = true;
        if start > self.latest {
            // After everything busy: the time between is a new gap.
            self.longest_gap = self.longest_gap.max(start - self.latest);
            let _ = self.gaps.push((self.latest, start));
            self.latest = end;
            return;
        }
        self.latest = self.latest.max(end);
        // The gaps it meets are consecutive: from the first ending after `start` to the last
        // opening before `end`; what is left of them is at most a piece before `start` (of the
        // first) and one after `end` (of the last).
        let first = self.gaps.partition_point(|&(_, b)| b <= start);
        let last = self.gaps.partition_point(|&(a, _)| a < end);
        if first >= last {
            return;
        }
        let (Some(&(a, _)), Some(&(_, b))) = (self.gaps.get(first), self.gaps.get(last - 1)) else {
            return;
        };
        let mut pieces: Vec<(u64, u64), 2> = Vec::new();
        if a < start {
            let _ = pieces.push((a, start));
        }
        if end < b {
            let _ = pieces.push((end, b));
        }
        // Replace gaps[first..last] by the pieces.
        let removed = last - first;
        for _ in 0..removed {
            self.gaps.remove(first);
        }
        for (k, piece) in pieces.iter().enumerate() {
            // Never fails: at most one more gap than before, one per non-empty span.
            let _ = self.gaps.insert(first + k, *piece);
        }
        self.longest_gap = self.gaps.iter().map(|&(a, b)| b - a).max().unwrap_or(0);
    }

    fn indexed(&self) -> IndexedPlan<'_> {
        IndexedPlan {
            spans: &self.spans,
            energy_mj: self.energy_mj,
            latest_end: self.latest_end,
            index: PlanIndex {
                gaps: &self.gaps,
                uplinks: &self.uplinks,
                holds: &self.holds,
                waits: &self.waits,
                latest_wait: self.latest_wait,
                busy_end: if self.busy { self.latest } else { 0 },
                longest_gap: self.longest_gap,
            },
        }
    }
}

/// [`TimelinePlacement`] with its plan index kept between calls ([`PlanIndexCache`], the
/// caller's, so that it outlives one planning call): the same decisions. The cache must be
/// cleared when the network's chains change.
pub struct CachedTimeline<'a> {
    pub timeline: &'a TimelinePlacement,
    pub cache: &'a mut PlanIndexCache,
}

impl ChainPlacement for CachedTimeline<'_> {
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let chain = network.chains.get(usize::from(candidate))?;
        if !self
            .cache
            .index(network, plan, self.timeline.horizon_start.0)
        {
            return None;
        }
        self.timeline
            .place_indexed(chain, candidate, self.cache.indexed())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ViewTimeline::contains` (binary search) answers as a scan of every window, on windows
    /// touching and apart, for intervals empty and not, inside, across and outside them.
    #[test]
    fn contains_is_the_scan_of_every_window() {
        let w = |a: u64, b: u64| ViewWindow {
            start: MissionTimeUs(a),
            end: MissionTimeUs(b),
        };
        let timelines = [
            ViewTimeline::new(&[]).unwrap_or_default(),
            ViewTimeline::new(&[w(10, 20)]).unwrap_or_default(),
            ViewTimeline::new(&[w(0, 10), w(10, 20), w(25, 30), w(31, 40)]).unwrap_or_default(),
            ViewTimeline::new(&[w(5, 6), w(8, 12), w(12, 13), w(20, 45)]).unwrap_or_default(),
        ];
        let mut inside = 0u32;
        for t in &timelines {
            for start in 0..50u64 {
                for end in start..52u64 {
                    let scan = t
                        .windows()
                        .iter()
                        .any(|w| w.start.0 <= start && end <= w.end.0);
                    assert_eq!(t.contains(start, end), scan, "{start} {end} {t:?}");
                    inside += u32::from(scan);
                }
            }
        }
        assert!(inside > 500, "{inside}");
    }

    /// `energy_fits` is the division it replaces, at and around the rounding boundary.
    #[test]
    fn energy_fits_is_the_divided_sum() {
        let mut t = TimelinePlacement {
            horizon_start: MissionTimeUs(1_000),
            horizon_end: MissionTimeUs(u64::MAX),
            phases: PhaseTimeline::default(),
            battery_mj: 0,
            hotel_load_mw: 0,
            earth: EarthView::default(),
        };
        let mut checked = 0u32;
        for load in [0u64, 1, 7, 1_000, 60_000, u64::MAX / 3] {
            for battery in [0u64, 5, 1_000, 123_456_789, u64::MAX - 1, u64::MAX] {
                for energy in [0u64, 3, 999, 123_456_788, u64::MAX] {
                    for end in [
                        0u64,
                        1_000,
                        1_001,
                        999_999_999,
                        1_000_000_000,
                        123_456_789_000,
                        u64::MAX,
                    ] {
                        t.hotel_load_mw = load;
                        t.battery_mj = battery;
                        let at = MissionTimeUs(end);
                        let expected = energy.saturating_add(t.hotel_energy_mj(at)) <= battery;
                        assert_eq!(
                            t.energy_fits(at, energy),
                            expected,
                            "{load} {battery} {energy} {end}"
                        );
                        checked += 1;
                    }
                }
            }
        }
        // The exact boundary: 7 mW for 1 s less 1 us after the start is 6.999993 mJ.
        t.hotel_load_mw = 7;
        t.battery_mj = 10;
        assert!(t.energy_fits(MissionTimeUs(1_000 + 999_999), 4));
        assert!(!t.energy_fits(MissionTimeUs(1_000 + 1_000_000), 4));
        assert!(checked > 1_000);
    }
}
