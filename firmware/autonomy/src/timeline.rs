//! Timeline library (seed 003 "MEXEC Planner and Controller", seed 000 IV.A.2): projects the
//! impacts of placed task instances onto state, claimable and cumulative timelines, answers
//! "what is the value at t", checks constraints over intervals, and consolidates the past.
//!
//! A timeline's value at `t` is its anchor (the consolidated past, or the latest measurement
//! from the state buffer, whichever is newer) followed by the impacts of the instances still in
//! the plan. A measurement overrides projections: assignments and changes at or before the
//! measurement time are taken as already reflected in it (rates keep integrating). Events at the
//! same time apply in a fixed order (instance id, impact index), so projections are
//! deterministic. No sorting: each query is a scan, over the plan or, when the caller built
//! one, over a [`PlanEvents`] table that lists every entry's events once per timeline (the
//! planner's placement searches ask thousands of questions of the same plan).
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::capacity::*;
use crate::model::*;
use crate::plan::{Contribution, PlanEntry};
use fsw_bridge::MissionTimeUs;

/// `t + offset`, saturating.
pub fn shift(t: MissionTimeUs, offset_us: i64) -> MissionTimeUs {
    MissionTimeUs(t.0.saturating_add_signed(offset_us))
}

/// A measurement taken from the state buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Measurement {
    pub value: i64,
    pub at: MissionTimeUs,
}

/// Where a timeline's projection starts: the consolidated value and rate at `at`, and the
/// latest measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TimelineAnchor {
    pub value: i64,
    /// Value units per second (cumulative timelines).
    pub rate: i64,
    pub at: MissionTimeUs,
    pub measured: Option<Measurement>,
}

impl TimelineAnchor {
    /// The anchor of a freshly loaded timeline.
    pub fn initial(spec: &TimelineSpec) -> Self {
        let value = match spec.kind {
            TimelineKind::State { initial, .. } => i64::from(initial),
            TimelineKind::Claimable => 0,
            TimelineKind::Cumulative { initial, .. } => initial,
        };
        Self {
            value,
            rate: 0,
            at: MissionTimeUs::ZERO,
            measured: None,
        }
    }
}

/// The anchors of every timeline of the loaded network.
pub type Anchors = Vec<TimelineAnchor, MAX_TIMELINES>;

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
    fn key(&self) -> (MissionTimeUs, u32) {
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
    fn timeline(&self, timeline: u8, entries: usize) -> Option<&[Event]> {
        if !self.complete || timeline >= self.timelines || usize::from(self.entries) != entries {
            return None;
        }
        let t = usize::from(timeline);
        let from = usize::from(*self.first.get(t)?);
        let to = usize::from(*self.first.get(t + 1)?);
        self.events.get(from..to)
    }
}

fn effect_kind(effect: Effect, sign: i64) -> EventKind {
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
    candidate: Candidate,
    /// (timeline, event), each timeline's events in [`impact_events`]'s order.
    events: Vec<(u8, Event), { 2 * MAX_IMPACTS_PER_TASK }>,
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

/// The plan as the timelines see it: the placed instances, minus up to two excluded ones,
/// plus at most one hypothetical placement.
#[derive(Clone, Copy)]
pub struct PlanView<'a> {
    pub network: &'a TaskNetwork,
    pub entries: &'a [PlanEntry],
    pub anchors: &'a [TimelineAnchor],
    pub exclude: [Option<u16>; 2],
    pub extra: Option<Candidate>,
    /// The entries' events listed once (built from `entries`), or None to generate them.
    pub events: Option<&'a PlanEvents>,
    /// The events of `extra` generated once, or None to generate them (used only while they
    /// are the events of `extra`).
    pub extra_events: Option<&'a CandidateEvents>,
}

impl<'a> PlanView<'a> {
    pub fn new(
        network: &'a TaskNetwork,
        entries: &'a [PlanEntry],
        anchors: &'a [TimelineAnchor],
    ) -> Self {
        Self {
            network,
            entries,
            anchors,
            exclude: [None, None],
            extra: None,
            events: None,
            extra_events: None,
        }
    }

    /// This view reading the entries' events from `events`, which must have been built from
    /// this view's `network` and `entries` as they are now. Answers are the same as without it.
    pub fn with_events(mut self, events: &'a PlanEvents) -> Self {
        self.events = Some(events);
        self
    }

    /// This view without instance `instance`.
    pub fn without(mut self, instance: u16) -> Self {
        if self.exclude[0].is_none() {
            self.exclude[0] = Some(instance);
        } else {
            self.exclude[1] = Some(instance);
        }
        self
    }

    /// This view with the hypothetical placement `c`.
    pub fn with(mut self, c: Candidate) -> Self {
        self.extra = Some(c);
        self
    }

    /// This view with the hypothetical placement whose events `events` lists (filled by
    /// [`CandidateEvents::fill`] from this view's `network`). Answers are the same as with
    /// [`PlanView::with`] of its candidate.
    pub fn with_candidate(mut self, events: &'a CandidateEvents) -> Self {
        self.extra = Some(events.candidate);
        self.extra_events = Some(events);
        self
    }

    /// Calls `f` for every event on `timeline`, in no particular order.
    pub fn for_each_event(&self, timeline: u8, mut f: impl FnMut(Event)) {
        if let Some(events) = self
            .events
            .and_then(|table| table.timeline(timeline, self.entries.len()))
        {
            for e in events {
                if !self.exclude.contains(&Some(e.instance())) {
                    f(*e);
                }
            }
        } else {
            for e in self.entries {
                if self.exclude.contains(&Some(e.instance)) {
                    continue;
                }
                if let (Some(c), Some(spec)) = (e.contribution(), self.network.task(e.def)) {
                    impact_events(spec, e.instance, c, timeline, &mut f);
                }
            }
        }
        if let Some(x) = self.extra {
            match self.extra_events.filter(|pre| pre.candidate == x) {
                Some(pre) => {
                    for &(tl, e) in &pre.events {
                        if tl == timeline {
                            f(e);
                        }
                    }
                }
                None => {
                    if let Some(spec) = self.network.task(x.def) {
                        impact_events(spec, x.instance, x.contribution(), timeline, &mut f);
                    }
                }
            }
        }
    }

    fn has_rates(&self, timeline: u8) -> bool {
        let mut any = self
            .anchors
            .get(usize::from(timeline))
            .is_some_and(|a| a.rate != 0);
        self.for_each_event(timeline, |e| any |= matches!(e.kind, EventKind::Rate(_)));
        any
    }

    /// Projected value of `timeline` at `t` (after every event at or before `t`).
    ///
    /// Without rates (no anchor rate, no rate event at or before `t`) the value is the base
    /// plus additions, summed in 64 bits (a 128-bit addition takes twice the instructions on
    /// the 32-bit target); a rate or a sum that does not fit 64 bits takes
    /// [`PlanView::value_at_exact`]. Both give the same answer.
    pub fn value_at(&self, timeline: u8, t: MissionTimeUs) -> i64 {
        let Some(anchor) = self.anchors.get(usize::from(timeline)) else {
            return VALUE_UNKNOWN;
        };
        if anchor.rate != 0 {
            return self.value_at_exact(timeline, t);
        }
        let mut base_value = anchor.value;
        let filter_at = anchor.measured.map(|m| m.at);
        if let Some(m) = anchor.measured {
            if m.at >= anchor.at {
                base_value = m.value;
            }
        }
        let passes = |e: &Event| e.at <= t && filter_at.is_none_or(|m| e.at > m);
        let mut last_assign: Option<(MissionTimeUs, u32, i64)> = None;
        let mut adds: Option<i64> = Some(0);
        let mut added = false;
        let mut rates = false;
        self.for_each_event(timeline, |e| match e.kind {
            EventKind::Assign(v) => {
                if passes(&e) && last_assign.is_none_or(|(at, seq, _)| e.key() > (at, seq)) {
                    last_assign = Some((e.at, e.seq, v));
                }
            }
            EventKind::Add(d) => {
                if passes(&e) {
                    added = true;
                    adds = adds.and_then(|sum| sum.checked_add(d));
                }
            }
            EventKind::Rate(_) => rates |= e.at <= t,
        });
        if rates {
            return self.value_at_exact(timeline, t);
        }
        if let Some((at, seq, v)) = last_assign {
            base_value = v;
            let after = (at, seq);
            adds = Some(0);
            // The additions after the last assignment are among those the first pass saw
            // (a state timeline has none: no second pass).
            if added {
                self.for_each_event(timeline, |e| {
                    if let EventKind::Add(d) = e.kind {
                        if passes(&e) && e.key() > after {
                            adds = adds.and_then(|sum| sum.checked_add(d));
                        }
                    }
                });
            }
        }
        if base_value == VALUE_UNKNOWN {
            return VALUE_UNKNOWN;
        }
        match adds.and_then(|sum| base_value.checked_add(sum)) {
            Some(value) => value.max(VALUE_UNKNOWN + 1),
            None => self.value_at_exact(timeline, t),
        }
    }

    /// [`PlanView::value_at`] computed in 128 bits throughout (rates integrated): the
    /// reference the 64-bit path is tested against.
    pub fn value_at_exact(&self, timeline: u8, t: MissionTimeUs) -> i64 {
        let Some(anchor) = self.anchors.get(usize::from(timeline)) else {
            return VALUE_UNKNOWN;
        };
        let (mut base_value, mut base_at) = (anchor.value, anchor.at);
        let filter_at = anchor.measured.map(|m| m.at);
        if let Some(m) = anchor.measured {
            if m.at >= anchor.at {
                base_value = m.value;
                base_at = m.at;
            }
        }
        let passes = |e: &Event| e.at <= t && filter_at.is_none_or(|m| e.at > m);
        // The last assignment at or before t replaces the base. One pass finds it and, in case
        // there is none (most timelines: claims, additions, rates), also sums what the second
        // pass would: the events are generated afresh for every pass, which is most of the
        // cost of a placement check.
        let mut last_assign: Option<Event> = None;
        let mut adds: i128 = 0;
        let mut rate_integral: i128 = 0;
        self.for_each_event(timeline, |e| match e.kind {
            EventKind::Assign(_) => {
                if passes(&e) && last_assign.is_none_or(|l| e.key() > l.key()) {
                    last_assign = Some(e);
                }
            }
            EventKind::Add(d) => {
                if passes(&e) {
                    adds += i128::from(d);
                }
            }
            EventKind::Rate(r) => {
                if e.at <= t {
                    let from = e.at.max(base_at);
                    rate_integral += i128::from(r) * i128::from(t.0.saturating_sub(from.0));
                }
            }
        });
        let mut value = i128::from(base_value);
        let mut integral: i128;
        if let Some(Event {
            kind: EventKind::Assign(v),
            at,
            seq,
        }) = last_assign
        {
            base_value = v;
            base_at = base_at.max(at);
            let after = (at, seq);
            value = i128::from(base_value);
            integral = i128::from(anchor.rate) * i128::from(t.0.saturating_sub(base_at.0));
            self.for_each_event(timeline, |e| match e.kind {
                EventKind::Add(d) => {
                    if passes(&e) && e.key() > after {
                        value += i128::from(d);
                    }
                }
                EventKind::Rate(r) => {
                    if e.at <= t {
                        let from = e.at.max(base_at);
                        integral += i128::from(r) * i128::from(t.0.saturating_sub(from.0));
                    }
                }
                EventKind::Assign(_) => {}
            });
        } else {
            value += adds;
            integral =
                i128::from(anchor.rate) * i128::from(t.0.saturating_sub(base_at.0)) + rate_integral;
        }
        if base_value == VALUE_UNKNOWN {
            return VALUE_UNKNOWN;
        }
        if integral != 0 {
            // (A 128-bit division is a library call on a 32-bit CPU.)
            value += integral / 1_000_000;
        }
        value.clamp(i128::from(VALUE_UNKNOWN + 1), i128::from(i64::MAX)) as i64
    }

    /// Calls `f` with each instant at which the value on `[a, b)` must be checked: `a`, every
    /// event in `(a, b)`, and with rates also the instant before each event and `b - 1`.
    /// Stops early when `f` returns false; returns false then.
    fn for_each_check_point(
        &self,
        timeline: u8,
        a: MissionTimeUs,
        b: MissionTimeUs,
        mut f: impl FnMut(MissionTimeUs) -> bool,
    ) -> bool {
        if a >= b {
            return true;
        }
        if !f(a) {
            return false;
        }
        let rates = self.has_rates(timeline);
        let mut ok = true;
        self.for_each_event(timeline, |e| {
            if !ok {
                return;
            }
            if e.at > a && e.at < b {
                ok = f(e.at);
            }
            if ok && rates && e.at > a && e.at <= b {
                ok = f(MissionTimeUs(e.at.0 - 1));
            }
        });
        if ok && rates {
            ok = f(MissionTimeUs(b.0 - 1));
        }
        ok
    }

    /// Whether `require` holds on `timeline` at every instant of `[a, b)`.
    pub fn holds_over(
        &self,
        timeline: u8,
        require: &Requirement,
        a: MissionTimeUs,
        b: MissionTimeUs,
    ) -> bool {
        self.for_each_check_point(timeline, a, b, |t| {
            require.accepts(self.value_at(timeline, t))
        })
    }

    /// The first sub-interval of `[a, b)` on which `require` does not hold, as
    /// `[violation start, next instant where it holds again or b)`.
    pub fn first_violation(
        &self,
        timeline: u8,
        require: &Requirement,
        a: MissionTimeUs,
        b: MissionTimeUs,
    ) -> Option<(MissionTimeUs, MissionTimeUs)> {
        let mut first: Option<MissionTimeUs> = None;
        self.for_each_check_point(timeline, a, b, |t| {
            if first.is_none_or(|f| t < f) && !require.accepts(self.value_at(timeline, t)) {
                first = Some(t);
            }
            true
        });
        let start = first?;
        let mut end = b;
        self.for_each_check_point(timeline, start, b, |t| {
            if t > start && t < end && require.accepts(self.value_at(timeline, t)) {
                end = t;
            }
            true
        });
        Some((start, end))
    }

    /// Whether the timeline stays within its own bounds (cumulative min/max, claim count 0..=1)
    /// at `t`.
    /// A state timeline has no bounds of its own: true without computing its value.
    pub fn within_bounds_at(&self, timeline: u8, t: MissionTimeUs) -> bool {
        let Some(spec) = self.network.timeline(timeline) else {
            return true;
        };
        match spec.kind {
            TimelineKind::State { .. } => true,
            TimelineKind::Claimable => (0..=1).contains(&self.value_at(timeline, t)),
            TimelineKind::Cumulative { min, max, .. } => {
                let v = self.value_at(timeline, t);
                v == VALUE_UNKNOWN || (min..=max).contains(&v)
            }
        }
    }
}

/// The instant a PRE constraint is checked, or the interval a MAINTAIN constraint covers, for
/// an instance placed over `[start, end)`.
pub fn constraint_span(
    c: &ConstraintSpec,
    start: MissionTimeUs,
    end: MissionTimeUs,
) -> (MissionTimeUs, MissionTimeUs) {
    let a = shift(start, c.start_offset_us);
    match c.when {
        ConstraintWhen::Pre => (a, MissionTimeUs(a.0.saturating_add(1))),
        ConstraintWhen::Maintain => (a, shift(end, c.end_offset_us)),
    }
}

/// Whether constraint `c` of instance `instance` placed over `[start, end)` holds in `view`
/// (which must contain the instance for MAINTAIN checks), considering only instants at or after
/// `from`. PRE constraints are evaluated without the instance's own impacts.
pub fn constraint_holds(
    view: &PlanView<'_>,
    instance: u16,
    c: &ConstraintSpec,
    start: MissionTimeUs,
    end: MissionTimeUs,
    from: MissionTimeUs,
) -> bool {
    let (a, b) = constraint_span(c, start, end);
    let a = a.max(from);
    if a >= b {
        return true;
    }
    match c.when {
        ConstraintWhen::Pre => {
            let mut v = *view;
            if v.extra.is_some_and(|x| x.instance == instance) {
                v.extra = None;
            }
            let v = v.without(instance);
            c.require.accepts(v.value_at(c.timeline, a))
        }
        ConstraintWhen::Maintain => view.holds_over(c.timeline, &c.require, a, b),
    }
}

/// Consolidation (seed 000 IV.A.3): folds finished instances whose impacts all lie at or before
/// the fold time into the anchors and removes them from `entries`. The fold time is `now`,
/// pulled back to the first impact of any instance that stays, so that no remaining event
/// precedes an anchor. Returns the number of instances folded.
pub fn consolidate(
    network: &TaskNetwork,
    entries: &mut Vec<PlanEntry, MAX_PLAN_ENTRIES>,
    anchors: &mut Anchors,
    now: MissionTimeUs,
) -> usize {
    let first_last = |e: &PlanEntry| -> Option<(MissionTimeUs, MissionTimeUs)> {
        let c = e.contribution()?;
        let spec = network.task(e.def)?;
        let mut span: Option<(MissionTimeUs, MissionTimeUs)> = None;
        for t in 0..network.timelines().len() {
            impact_events(spec, e.instance, c, t as u8, &mut |ev: Event| {
                span = Some(match span {
                    None => (ev.at, ev.at),
                    Some((lo, hi)) => (lo.min(ev.at), hi.max(ev.at)),
                });
            });
        }
        span
    };
    // Find the fold time: shrink until every instance is either wholly before it or after it.
    let mut fold_at = now;
    loop {
        let mut changed = false;
        for e in entries.iter() {
            let foldable =
                e.state.is_terminal() && first_last(e).is_none_or(|(_, last)| last <= fold_at);
            if !foldable {
                if let Some((first, _)) = first_last(e) {
                    if first < fold_at {
                        fold_at = first;
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    let foldable = |e: &PlanEntry| {
        e.state.is_terminal() && first_last(e).is_none_or(|(_, last)| last <= fold_at)
    };
    if !entries.iter().any(foldable) {
        return 0;
    }
    // New anchors: the value at the fold time seen through the folded instances only. They
    // are moved to the front of `entries` (a stable partition in place: a copy of them would
    // be up to MAX_PLAN_ENTRIES entries, 24 KiB, on the stack), each group keeping its order.
    let mut folded = 0;
    for i in 0..entries.len() {
        if entries.get(i).is_some_and(foldable) {
            if let Some(run) = entries.get_mut(folded..=i) {
                run.rotate_right(1);
            }
            folded += 1;
        }
    }
    let folded_only = entries.get(..folded).unwrap_or(&[]);
    let mut new_anchors: Anchors = Vec::new();
    for t in 0..anchors.len() {
        let tl = t as u8;
        let view = PlanView::new(network, folded_only, anchors);
        let value = view.value_at(tl, fold_at);
        let mut rate = anchors.get(t).map(|a| a.rate).unwrap_or(0);
        view.for_each_event(tl, |e| {
            if let EventKind::Rate(r) = e.kind {
                if e.at <= fold_at {
                    rate = rate.saturating_add(r);
                }
            }
        });
        let measured = anchors.get(t).and_then(|a| a.measured);
        let at = anchors.get(t).map(|a| a.at.max(fold_at)).unwrap_or(fold_at);
        let _ = new_anchors.push(TimelineAnchor {
            value,
            rate,
            at,
            measured,
        });
    }
    *anchors = new_anchors;
    let before = entries.len();
    entries.retain(|e| !foldable(e));
    before - entries.len()
}
