//! Events: what each impact of a placed (or hypothetical) instance does to a timeline and when,
//! and the tables that list them once per timeline for the planner's many queries.

use super::*;

/// What an event does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    Assign(i64),
    Add(i64),
    Rate(i64),
}

/// One change of a timeline at one instant, with its tie-break key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    pub at: MissionTimeUs,
    pub seq: u32,
    pub kind: EventKind,
}

impl Event {
    pub(super) fn key(&self) -> (MissionTimeUs, u32) {
        (self.at, self.seq)
    }

    /// The instance whose impact this event is (the upper bits of the tie-break key).
    pub fn instance(&self) -> u16 {
        (self.seq >> SEQ_INSTANCE_SHIFT) as u16
    }
}

// A timeline's bit in a `u64` (see `PlanEvents::build`).
const _: () = assert!(MAX_TIMELINES <= 64);

/// Most events a [`PlanEvents`] table holds (1024 events of 32 bytes, 32 KiB: two per plan
/// entry at [`MAX_PLAN_ENTRIES`]; the table was 128 events when a plan held 48 entries). A
/// plan with more (at most
/// `MAX_PLAN_ENTRIES * MAX_IMPACTS_PER_TASK * 2`) is answered without the table, as fast as
/// before it existed; the flyby plans have a few dozen. Only `build` fills it and only the
/// events listed are read, so its size costs RAM, not time.
pub const MAX_PLAN_EVENTS: usize = 1024;

/// Bits of an event's tie-break key ([`Event::seq`]) below the instance id: the impact's index
/// in its task (4 bits: [`MAX_IMPACTS_PER_TASK`] is at most 16) and whether the event ends a
/// MAINTAIN interval (1 bit). Events of one instance at one instant sort in impact order.
const SEQ_INSTANCE_SHIFT: u32 = 5;
const SEQ_IMPACT_MASK: u32 = (1 << (SEQ_INSTANCE_SHIFT - 1)) - 1;
const _: () = assert!(MAX_IMPACTS_PER_TASK <= 1 << (SEQ_INSTANCE_SHIFT - 1));
// The table's indices are u16.
const _: () = assert!(MAX_PLAN_EVENTS < u16::MAX as usize);

/// Every event the entries of a plan put on each timeline, generated once: the events of
/// timeline `t` are those [`PlanView::for_each_event`] would generate from the entries, in the
/// same order (entry order, then impact order). A view given the table (see
/// [`PlanView::with_events`]) reads them from it instead of generating them from the entries
/// for every query; exclusions and the hypothetical placement are applied as before. The table
/// describes the entries as they were when it was built: build it again after any change.
#[derive(Clone, Debug)]
pub struct PlanEvents {
    events: Vec<Event, MAX_PLAN_EVENTS>,
    /// Scratch of `build`: each contributing entry's contribution, definition, instance and
    /// impacted timelines (empty outside `build`).
    impacting: Vec<(Contribution, u8, u16, u64), MAX_PLAN_ENTRIES>,
    /// Events of timeline `t`: `events[first[t]..first[t + 1]]`, for `t < timelines`.
    first: [u16; MAX_TIMELINES + 1],
    timelines: u8,
    /// Number of entries the table was built from (a cheap check that a view matches it).
    entries: u16,
    /// False when the events did not fit (then views ignore the table).
    complete: bool,
}

impl Default for PlanEvents {
    fn default() -> Self {
        Self::new()
    }
}

impl PlanEvents {
    /// An empty table that no view uses until it is built.
    pub const fn new() -> Self {
        Self {
            events: Vec::new(),
            impacting: Vec::new(),
            first: [0; MAX_TIMELINES + 1],
            timelines: 0,
            entries: 0,
            complete: false,
        }
    }

    /// Empties the table (no view uses it until it is built again).
    pub fn clear(&mut self) {
        self.events.clear();
        self.impacting.clear();
        self.timelines = 0;
        self.entries = 0;
        self.complete = false;
    }

    /// Lists the events of `entries` on every timeline of `network`.
    pub fn build(&mut self, network: &TaskNetwork, entries: &[PlanEntry]) {
        self.clear();
        let timelines = network.timelines().len();
        let (Ok(entry_count), true) = (u16::try_from(entries.len()), timelines <= MAX_TIMELINES)
        else {
            return;
        };
        // Each entry's contribution, definition and impacted timelines (a bit per timeline),
        // found once rather than once per timeline (an entry that impacts none is left out).
        // Kept in the table (20 KiB at MAX_PLAN_ENTRIES), not on the stack. More entries than
        // a plan holds: no table (views generate the events).
        for e in entries {
            if let (Some(c), Some(spec)) = (e.contribution(), network.task(e.def)) {
                let mask = spec.impacts.iter().fold(0u64, |m, i| {
                    m | 1u64.checked_shl(u32::from(i.timeline)).unwrap_or(0)
                });
                if mask != 0 && self.impacting.push((c, e.def, e.instance, mask)).is_err() {
                    self.impacting.clear();
                    return;
                }
            }
        }
        let mut fits = true;
        for t in 0..timelines {
            if let Some(slot) = self.first.get_mut(t) {
                *slot = self.events.len() as u16;
            }
            let bit = 1u64 << t;
            for &(c, def, instance, mask) in &self.impacting {
                if mask & bit == 0 {
                    continue;
                }
                if let Some(spec) = network.task(def) {
                    impact_events(spec, instance, c, t as u8, &mut |ev| {
                        fits &= self.events.push(ev).is_ok();
                    });
                }
            }
        }
        self.impacting.clear();
        if let Some(slot) = self.first.get_mut(timelines) {
            *slot = self.events.len() as u16;
        }
        self.timelines = timelines as u8;
        self.entries = entry_count;
        self.complete = fits;
    }

    /// The events of `timeline`, if the table is complete, holds that timeline and was built
    /// from `entries` entries.
    pub(super) fn timeline(&self, timeline: u8, entries: usize) -> Option<&[Event]> {
        if !self.complete || timeline >= self.timelines || usize::from(self.entries) != entries {
            return None;
        }
        let t = usize::from(timeline);
        let from = usize::from(*self.first.get(t)?);
        let to = usize::from(*self.first.get(t + 1)?);
        self.events.get(from..to)
    }
}

pub(super) fn effect_kind(effect: Effect, sign: i64) -> EventKind {
    match effect {
        Effect::Assign(v) => EventKind::Assign(v),
        Effect::Add(d) => EventKind::Add(d.saturating_mul(sign)),
        Effect::Rate(r) => EventKind::Rate(r.saturating_mul(sign)),
        Effect::Claim => EventKind::Add(sign),
    }
}

/// Calls `f` for every event the impacts of `spec`, applied over `c`, put on `timeline`.
pub fn impact_events(
    spec: &TaskSpec,
    instance: u16,
    c: Contribution,
    timeline: u8,
    f: &mut impl FnMut(Event),
) {
    for (i, impact) in spec.impacts.iter().enumerate() {
        if impact.timeline != timeline {
            continue;
        }
        let seq = (u32::from(instance) << SEQ_INSTANCE_SHIFT) | ((i as u32 & SEQ_IMPACT_MASK) << 1);
        match impact.when {
            ImpactWhen::Pre => f(Event {
                at: shift(c.start, impact.start_offset_us),
                seq,
                kind: effect_kind(impact.effect, 1),
            }),
            ImpactWhen::Post => {
                if c.post {
                    f(Event {
                        at: shift(c.end, impact.end_offset_us),
                        seq,
                        kind: effect_kind(impact.effect, 1),
                    })
                }
            }
            ImpactWhen::Maintain => {
                let a = shift(c.start, impact.start_offset_us);
                let b = shift(c.end, impact.end_offset_us);
                if a < b {
                    f(Event {
                        at: a,
                        seq,
                        kind: effect_kind(impact.effect, 1),
                    });
                    f(Event {
                        at: b,
                        seq: seq | 1,
                        kind: effect_kind(impact.effect, -1),
                    });
                }
            }
        }
    }
}

/// The events of one hypothetical placement ([`Candidate`]) on every timeline, generated once:
/// a placement check asks for the candidate's events in every value it computes (two scans per
/// value, a value per event of the timeline), and generating them (offsets, signs, 64-bit
/// arithmetic) cost about a tenth of a reset's recovery. A view given them (see
/// [`PlanView::with_candidate`]) reads them from here, in the order
/// [`impact_events`] generates them.
#[derive(Clone, Debug)]
pub struct CandidateEvents {
    pub(super) candidate: Candidate,
    /// (timeline, event), each timeline's events in [`impact_events`]'s order.
    pub(super) events: Vec<(u8, Event), { 2 * MAX_IMPACTS_PER_TASK }>,
}

impl CandidateEvents {
    /// No candidate yet ([`CandidateEvents::fill`] gives it one): a view given this generates
    /// the events of its candidate.
    pub const fn none() -> Self {
        Self {
            candidate: Candidate {
                instance: 0,
                def: u8::MAX,
                start: MissionTimeUs::MAX,
                end: MissionTimeUs::ZERO,
            },
            events: Vec::new(),
        }
    }

    /// Lists the events of `c` (none if its definition is not in `network`, as a view
    /// generates none for it either). Filled in place: the list is a few hundred bytes that
    /// a returned value would copy.
    pub fn fill(&mut self, network: &TaskNetwork, c: Candidate) {
        self.candidate = c;
        self.events.clear();
        let Some(spec) = network.task(c.def) else {
            return;
        };
        let events = &mut self.events;
        for (n, impact) in spec.impacts.iter().enumerate() {
            let tl = impact.timeline;
            if spec.impacts.iter().take(n).any(|i| i.timeline == tl) {
                continue;
            }
            impact_events(spec, c.instance, c.contribution(), tl, &mut |e| {
                // At most two events per impact: always room.
                let _ = events.push((tl, e));
            });
        }
    }
}

/// A hypothetical placement of one instance (the one being scheduled).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Candidate {
    pub instance: u16,
    pub def: u8,
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
}

impl Candidate {
    pub fn contribution(&self) -> Contribution {
        Contribution {
            start: self.start,
            end: self.end,
            post: true,
        }
    }
}
