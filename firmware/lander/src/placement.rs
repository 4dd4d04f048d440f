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
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
use crate::htn::{Chain, FlatNetwork, PhaseTimeline};
use crate::search::{ChainPlacement, PlacedChain};

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
}

/// Candidate starts examined for one placement.
const MAX_PLACEMENT_CANDIDATES: usize = 3 * MAX_PLAN_CHAINS + MAX_PHASE_CHANGES + 1;

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
        let mj = u128::from(self.hotel_load_mw) * u128::from(seconds_us) / 1_000_000;
        u64::try_from(mj).unwrap_or(u64::MAX)
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

impl ChainPlacement for TimelinePlacement {
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let chain = network.chains.get(usize::from(candidate))?;
        let mut spans: Vec<Span, MAX_PLAN_CHAINS> = Vec::new();
        let mut energy_mj = chain.energy_mj;
        let mut latest_end = self.horizon_start.0;
        for p in plan {
            let c = network.chains.get(usize::from(p.chain))?;
            let s = span_of(c, p.start);
            latest_end = latest_end.max(s.end);
            energy_mj = energy_mj.saturating_add(c.energy_mj);
            spans.push(s).ok()?;
        }
        let fits_energy = |end: u64| {
            let end = MissionTimeUs(end.max(latest_end));
            energy_mj.saturating_add(self.hotel_energy_mj(end)) <= self.battery_mj
        };
        if let Some(start) = chain.fixed_start {
            let x = span_of(chain, start);
            return (self.compatible(&spans, x, chain) && fits_energy(x.end)).then_some(start);
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
        candidates.sort_unstable();
        candidates
            .iter()
            .filter(|&&s| s >= self.horizon_start.0 && s != u64::MAX)
            .map(|&s| span_of(chain, MissionTimeUs(s)))
            .find(|x| self.compatible(&spans, *x, chain) && fits_energy(x.end))
            .map(|x| MissionTimeUs(x.start))
    }
}

impl TimelinePlacement {
    fn phase_change(&self, index: usize) -> Option<MissionTimeUs> {
        self.phases.change_time(index)
    }
}
