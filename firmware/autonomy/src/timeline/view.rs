//! The plan as the timelines see it ([`PlanView`]): values at an instant, constraints over an
//! interval.

use super::*;

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

    /// Calls `f` for every event on `timeline`, in no particular order: the placed
    /// instances' impacts, then the network's timed values on it (an external timeline has
    /// no impacts, so their tie-break key, their index, never meets an instance's).
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
        // (The placement search asks this thousands of times: a network without timed values,
        // the flyby's, pays one length check.)
        if !self.network.timed().is_empty()
            && self
                .network
                .timeline(timeline)
                .is_some_and(|spec| spec.external)
        {
            for (i, tv) in self.network.timed().iter().enumerate() {
                if tv.timeline == timeline {
                    f(Event {
                        at: tv.at,
                        seq: i as u32,
                        kind: EventKind::Assign(tv.value),
                    });
                }
            }
        }
    }

    pub(super) fn has_rates(&self, timeline: u8) -> bool {
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
    pub(super) fn for_each_check_point(
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
