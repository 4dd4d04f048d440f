//! The MEXEC timelines as the search's "can be added" check: an adapter from the autonomy
//! crate's exact validity check ([`autonomy::planner::placement_valid`]) to [`ChainPlacement`].
//!
//! Each primitive of the HTN model maps to a task definition of an autonomy [`TaskNetwork`]
//! (its constraints and impacts: claims, energy, states). To test a chain, the adapter lays out
//! the plan as MEXEC plan entries (the instances the planner already holds, then every chain of
//! the plan with its primitives back to back from the chain's start) and tries the chain's
//! start at `now` and at each end of an entry, in time order; a start is accepted when every
//! primitive, placed one after the other, passes the exact MEXEC check against everything
//! placed before it. The answer is sound (an accepted chain is valid on the MEXEC timelines)
//! but not always the earliest valid start: a window that opens between two candidates is
//! missed, as the planner's own candidates miss one with rate impacts.
//!
//! **Earth in view** ([`MexecEarth`], issue 11 items 5 and 8), as [`TimelinePlacement`] has
//! it: with the in-view windows given, a chain's downlink primitives (its span in
//! [`EarthView::downlinks`]) must lie entirely inside one window, each window's opening minus
//! the chain's downlink offset is one more candidate start (so the windows do not make the
//! earliest start missed), and a chain that creates data its own downlinks do not carry is
//! placed only if some window still has in-view time after the chain's end, before the horizon
//! end, that no entry of the plan (held or laid out) takes; with Earth given, a chain also
//! ends by that horizon end (the simple timeline's horizon). How much data the downlinks carry
//! is [`crate::comms::DataPlacement`]'s check, which wraps this placement as it wraps the
//! simple one. Without windows (`earth: None`) Earth is not modelled.
//!
//! [`TimelinePlacement`]: crate::placement::TimelinePlacement
//!
//! Limits: a plan's primitives and the planner's entries share the autonomy crate's
//! [`autonomy::MAX_PLAN_ENTRIES`] (512): a plan that would need more is refused (counted in
//! [`MexecPlacement::plan_full`]). One list of entries (24 KiB at that capacity) is on the
//! stack during a placement; each trial start appends to it and truncates it back, rather than
//! copying it (a partition's stack is 64 KiB). The primitives' durations
//! are the task definitions' durations, which should match the HTN model's.
use heapless::Vec;

use autonomy::plan::{Origin, PlanEntry};
use autonomy::planner::placement_valid;
use autonomy::timeline::TimelineAnchor;
use autonomy::{TaskNetwork, TaskState, FIRST_INSTANCE_ID, MAX_PLAN_ENTRIES};
use fsw_bridge::MissionTimeUs;

use crate::capacity::MAX_VIEW_WINDOWS;
use crate::htn::FlatNetwork;
use crate::placement::EarthView;
use crate::search::{ChainPlacement, PlacedChain};

/// The adapter. Borrowed state is the MEXEC planner's: its network, its timelines' anchors and
/// the entries it holds.
pub struct MexecPlacement<'a> {
    pub network: &'a TaskNetwork,
    pub anchors: &'a [TimelineAnchor],
    /// Instances already in the MEXEC plan (committed or executing), kept as they are.
    pub held: &'a [PlanEntry],
    /// Per HTN primitive index: the task definition (index into `network.tasks()`).
    pub definition_of: &'a [u8],
    pub now: MissionTimeUs,
    /// Plans refused because they needed more than [`MAX_PLAN_ENTRIES`] entries.
    pub plan_full: u32,
    /// Earth-in-view windows and the chains' downlink spans (`None`: not modelled).
    pub earth: Option<MexecEarth<'a>>,
}

/// What the MEXEC placement knows about Earth: the windows and the chains' downlink spans
/// (as [`crate::placement::TimelinePlacement::earth`]), and the horizon end chains end by and
/// data must reach Earth by.
#[derive(Clone, Copy, Debug)]
pub struct MexecEarth<'a> {
    pub view: &'a EarthView,
    pub horizon_end: MissionTimeUs,
}

impl MexecEarth<'_> {
    /// Whether chain `index` of `flat` started at `start` and ending at `end` reaches Earth
    /// with `entries` placed (the rule of the module docs).
    fn reaches_earth(
        &self,
        flat: &FlatNetwork,
        entries: &[PlanEntry],
        index: u16,
        start: u64,
        end: u64,
    ) -> bool {
        if end > self.horizon_end.0 {
            return false;
        }
        if !self.view.modelled() {
            return true;
        }
        let own = self
            .view
            .downlinks
            .get(usize::from(index))
            .copied()
            .flatten();
        if let Some((from, to)) = own {
            if !self
                .view
                .windows
                .contains(start.saturating_add(from), start.saturating_add(to))
            {
                return false;
            }
        }
        let later = flat.chains.get(usize::from(index)).is_some_and(|c| {
            c.products
                .iter()
                .any(|p| own.is_none_or(|(from, _)| p.offset_us > from))
        });
        !later || self.room_after(entries, end)
    }

    /// Whether some window has an instant after `t`, before the horizon end, that no
    /// non-empty entry covers. The free time of `[a, b)` is a union of intervals each opening
    /// at `a` or at an entry's end, so those instants are the ones to try.
    fn room_after(&self, entries: &[PlanEntry], t: u64) -> bool {
        let covered = |x: u64| {
            entries
                .iter()
                .any(|e| e.start.0 < e.end.0 && e.start.0 <= x && x < e.end.0)
        };
        self.view.windows.windows().iter().any(|w| {
            let (a, b) = (w.start.0.max(t), w.end.0.min(self.horizon_end.0));
            a < b
                && (!covered(a)
                    || entries
                        .iter()
                        .any(|e| a <= e.end.0 && e.end.0 < b && !covered(e.end.0)))
        })
    }
}

type Entries = Vec<PlanEntry, MAX_PLAN_ENTRIES>;

/// An instance id no entry uses: above every planner-given id (held entries keep the ids the
/// MEXEC planner gave them, which need not be dense), and never a ground id. Reusing a held
/// entry's id would make [`placement_valid`] check the candidate without that entry.
fn fresh_instance(entries: &[PlanEntry]) -> Option<u16> {
    match entries.iter().map(|e| e.instance).max() {
        Some(highest) if highest >= FIRST_INSTANCE_ID => highest.checked_add(1),
        _ => Some(FIRST_INSTANCE_ID),
    }
}

impl MexecPlacement<'_> {
    fn entry(&self, instance: u16, def: u8, start: MissionTimeUs) -> Option<PlanEntry> {
        let spec = self.network.task(def)?;
        let end = MissionTimeUs(start.0.saturating_add(spec.duration_us));
        Some(PlanEntry {
            instance,
            def,
            state: TaskState::Scheduled,
            start,
            end,
            earliest_start: start,
            latest_start: start,
            started: false,
            persistent: false,
            origin: Origin::Requested,
        })
    }

    /// Appends chain `chain`'s primitives from `start`, checking each when `check`; returns the
    /// chain's end, or `None` when a primitive is invalid or the entries are full.
    fn lay_out(
        &mut self,
        flat: &FlatNetwork,
        entries: &mut Entries,
        chain: u16,
        start: MissionTimeUs,
        check: bool,
    ) -> Option<MissionTimeUs> {
        let c = flat.chains.get(usize::from(chain))?;
        let mut at = start;
        for &primitive in &c.primitives {
            let def = *self.definition_of.get(usize::from(primitive))?;
            let instance = fresh_instance(entries)?;
            let entry = self.entry(instance, def, at)?;
            if check
                && !placement_valid(
                    self.network,
                    entries,
                    self.anchors,
                    &entry,
                    entry.start,
                    entry.end,
                    self.now,
                )
            {
                return None;
            }
            if entries.push(entry).is_err() {
                self.plan_full += 1;
                return None;
            }
            at = entry.end;
        }
        Some(at)
    }
}

impl ChainPlacement for MexecPlacement<'_> {
    fn place(
        &mut self,
        flat: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let mut base: Entries = Vec::from_slice(self.held).ok()?;
        for p in plan {
            self.lay_out(flat, &mut base, p.chain, p.start, false)?;
        }
        let chain = flat.chains.get(usize::from(candidate))?;
        let mut starts: Vec<u64, { MAX_PLAN_ENTRIES + 1 + MAX_VIEW_WINDOWS }> = Vec::new();
        match chain.fixed_start {
            Some(fixed) => {
                let _ = starts.push(fixed.0);
            }
            None => {
                let _ = starts.push(self.now.0);
                for e in &base {
                    if e.end >= self.now {
                        let _ = starts.push(e.end.0);
                    }
                }
                let span = self
                    .earth
                    .and_then(|e| e.view.downlinks.get(usize::from(candidate)).copied())
                    .flatten();
                if let (Some(earth), Some((from, _))) = (self.earth, span) {
                    // The downlink starts as a window opens.
                    for w in earth.view.windows.windows() {
                        let s = w.start.0.checked_sub(from).filter(|&s| s >= self.now.0);
                        if s.is_some_and(|s| starts.push(s).is_err()) {
                            break;
                        }
                    }
                }
            }
        }
        starts.sort_unstable();
        let mut previous = None;
        let held = base.len();
        for &s in &starts {
            if previous == Some(s) {
                continue;
            }
            previous = Some(s);
            let placed = self.lay_out(flat, &mut base, candidate, MissionTimeUs(s), true);
            base.truncate(held);
            let reaches = |end: MissionTimeUs| {
                self.earth
                    .is_none_or(|e| e.reaches_earth(flat, &base, candidate, s, end.0))
            };
            if placed.is_some_and(reaches) {
                return Some(MissionTimeUs(s));
            }
        }
        None
    }
}
