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

mod events;
mod view;

pub use events::{
    impact_events, Candidate, CandidateEvents, Event, EventKind, PlanEvents, MAX_PLAN_EVENTS,
};
pub use view::{constraint_holds, constraint_span, PlanView};

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
            rate: match spec.kind {
                TimelineKind::Cumulative { .. } => spec.background_rate,
                _ => 0,
            },
            at: MissionTimeUs::ZERO,
            measured: None,
        }
    }
}

/// The anchors of every timeline of the loaded network.
pub type Anchors = Vec<TimelineAnchor, MAX_TIMELINES>;

/// Per plan entry: whether it is terminal, and its first and last impact event (None: it has
/// none). Scratch space for [`consolidate`].
pub type Spans = Vec<(bool, Option<(MissionTimeUs, MissionTimeUs)>), MAX_PLAN_ENTRIES>;

/// Consolidation (seed 000 IV.A.3): folds finished instances whose impacts all lie at or before
/// the fold time into the anchors and removes them from `entries`. The fold time is `now`,
/// pulled back to the first impact of any instance that stays, so that no remaining event
/// precedes an anchor. Returns the number of instances folded.
pub fn consolidate(
    network: &TaskNetwork,
    entries: &mut Vec<PlanEntry, MAX_PLAN_ENTRIES>,
    anchors: &mut Anchors,
    now: MissionTimeUs,
    spans: &mut Spans,
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
    // Each entry's span is worked out once (the passes can be as many as the entries).
    spans.clear();
    for e in entries.iter() {
        let _ = spans.push((e.state.is_terminal(), first_last(e)));
    }
    let mut fold_at = now;
    loop {
        let mut changed = false;
        for &(terminal, span) in spans.iter() {
            let foldable = terminal && span.is_none_or(|(_, last)| last <= fold_at);
            if !foldable {
                if let Some((first, _)) = span {
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
