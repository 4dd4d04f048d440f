//! Validity of one placement against the projected plan's timelines, and the temporal window
//! the network's constraints leave a task.

use super::*;

/// Instances whose constraints the planner still watches: placed and not finished.
pub(super) fn is_live(e: &PlanEntry) -> bool {
    !e.state.is_terminal() && e.state != TaskState::Unscheduled
}

/// Exact validity check (seed 003): the candidate's own constraints hold; no constraint of
/// another live instance that held now fails; no timeline the candidate impacts leaves its
/// bounds where it did not before. Instants before `now` are not checked.
pub fn placement_valid(
    network: &TaskNetwork,
    entries: &[PlanEntry],
    anchors: &[TimelineAnchor],
    entry: &PlanEntry,
    start: MissionTimeUs,
    end: MissionTimeUs,
    now: MissionTimeUs,
) -> bool {
    placement_valid_with_events(network, entries, anchors, None, entry, start, end, now)
}

/// [`placement_valid`], reading the entries' events from `events` (built from `network` and
/// `entries` as they are now) instead of generating them for every query. Same answer.
#[allow(clippy::too_many_arguments)]
pub fn placement_valid_with_events(
    network: &TaskNetwork,
    entries: &[PlanEntry],
    anchors: &[TimelineAnchor],
    events: Option<&PlanEvents>,
    entry: &PlanEntry,
    start: MissionTimeUs,
    end: MissionTimeUs,
    now: MissionTimeUs,
) -> bool {
    let Some(spec) = network.task(entry.def) else {
        return false;
    };
    let x = Candidate {
        instance: entry.instance,
        def: entry.def,
        start,
        end,
    };
    let mut base = PlanView::new(network, entries, anchors).without(entry.instance);
    if let Some(events) = events {
        base = base.with_events(events);
    }
    // The candidate's events, generated once for the many values asked below.
    let mut candidate_events = CandidateEvents::none();
    candidate_events.fill(network, x);
    let with = base.with_candidate(&candidate_events);
    for c in &spec.constraints {
        if !constraint_holds(&with, x.instance, c, start, end, now) {
            return false;
        }
    }
    for (n, impact) in spec.impacts.iter().enumerate() {
        let tl = impact.timeline;
        if spec.impacts.iter().take(n).any(|i| i.timeline == tl) {
            continue;
        }
        for other in entries
            .iter()
            .filter(|e| e.instance != entry.instance && is_live(e))
        {
            let Some(ospec) = network.task(other.def) else {
                continue;
            };
            for c in ospec.constraints.iter().filter(|c| c.timeline == tl) {
                if !constraint_holds(&with, other.instance, c, other.start, other.end, now)
                    && constraint_holds(&base, other.instance, c, other.start, other.end, now)
                {
                    return false;
                }
            }
        }
        // A state timeline (or none) has no bounds of its own: within them at every instant.
        if matches!(
            network.timeline(tl).map(|t| t.kind),
            None | Some(TimelineKind::State { .. })
        ) {
            continue;
        }
        let mut first = None::<MissionTimeUs>;
        crate::timeline::impact_events(spec, x.instance, x.contribution(), tl, &mut |e| {
            first = Some(first.map_or(e.at, |f| f.min(e.at)));
        });
        let from = first.unwrap_or(now).max(now);
        let mut ok = with.within_bounds_at(tl, from) || !base.within_bounds_at(tl, from);
        with.for_each_event(tl, |e| {
            if ok && e.at >= from {
                ok = with.within_bounds_at(tl, e.at) || !base.within_bounds_at(tl, e.at);
            }
        });
        if !ok {
            return false;
        }
    }
    true
}

/// Bounds on the start of `entry` implied by the temporal constraints and the placed requested
/// instances: shortest paths (Bellman-Ford) on the temporal constraint graph whose nodes are a
/// zero point and the start and end of each requested task. For a requested instance only the
/// constraints between requested tasks count; for an instance of a template, also the
/// template's own constraints with requested tasks (its node is the instance). `None` when
/// the constraints cannot be met.
pub fn temporal_window(
    network: &TaskNetwork,
    entries: &[PlanEntry],
    entry: &PlanEntry,
) -> Option<(MissionTimeUs, MissionTimeUs)> {
    let my_spec = network.task(entry.def)?;
    let me = my_spec.id;
    let template = my_spec.role == TaskRole::Template;
    if !network
        .temporal()
        .iter()
        .any(|t| t.from_task == me || t.to_task == me)
    {
        return Some((MissionTimeUs::ZERO, MissionTimeUs::MAX));
    }
    // Only the requested tasks' nodes and, for a template instance, its own take part.
    let counts = |def: u8| {
        def == entry.def
            || network
                .task(def)
                .is_some_and(|t| t.role == TaskRole::Requested)
    };
    // The nodes: the zero point, then the start and end of each task a counted constraint
    // names (a task no constraint names cannot bound another). At most 33 tasks, so the
    // distance arrays stay small on the partition's stack (a node per task definition made
    // 8 KiB of them, allocated by every call).
    const MAX_NAMED: usize = 2 * MAX_TEMPORAL_CONSTRAINTS + 1;
    const NODES: usize = 1 + 2 * MAX_NAMED;
    let mut named: Vec<u8, MAX_NAMED> = Vec::new();
    let _ = named.push(entry.def);
    for tc in network.temporal() {
        let (Some(a), Some(b)) = (
            network.def_of_id(tc.from_task),
            network.def_of_id(tc.to_task),
        ) else {
            continue;
        };
        if counts(a) && counts(b) {
            for d in [a, b] {
                if !named.contains(&d) {
                    let _ = named.push(d);
                }
            }
        }
    }
    let slot = |def: usize| named.iter().position(|&d| usize::from(d) == def);
    let node = |def: usize, point: TaskPoint| {
        slot(def).map_or(NODES, |k| 1 + 2 * k + usize::from(point == TaskPoint::End))
    };
    let tasks = network.tasks();
    // Calls f(from, to, weight) for every edge: to - from <= weight.
    let edges = |f: &mut dyn FnMut(usize, usize, i64)| {
        for tc in network.temporal() {
            let (Some(a), Some(b)) = (
                network.def_of_id(tc.from_task),
                network.def_of_id(tc.to_task),
            ) else {
                continue;
            };
            if !counts(a) || !counts(b) {
                continue;
            }
            let (u, v) = (
                node(usize::from(a), tc.from_point),
                node(usize::from(b), tc.to_point),
            );
            f(u, v, tc.max_us);
            f(v, u, tc.min_us.saturating_neg());
        }
        if template {
            let d = usize::from(entry.def);
            let (s, e) = (node(d, TaskPoint::Start), node(d, TaskPoint::End));
            f(s, e, my_spec.duration_us as i64);
            f(e, s, (my_spec.min_duration_us as i64).saturating_neg());
        }
        for (d, t) in tasks.iter().enumerate() {
            if t.role != TaskRole::Requested || slot(d).is_none() {
                continue;
            }
            let (s, e) = (node(d, TaskPoint::Start), node(d, TaskPoint::End));
            f(s, e, t.duration_us as i64);
            f(e, s, (t.min_duration_us as i64).saturating_neg());
            let placed = entries.iter().find(|p| {
                p.def as usize == d
                    && p.origin == Origin::Requested
                    && p.instance != entry.instance
                    && p.state != TaskState::Unscheduled
            });
            if let Some(p) = placed {
                for (n, at) in [(s, p.start), (e, p.end)] {
                    let at = at.0.min(MAX_MISSION_TIME_US) as i64;
                    f(0, n, at);
                    f(n, 0, at.saturating_neg());
                }
            } else {
                // Not placed yet: its own window still bounds it.
                f(
                    s,
                    0,
                    (t.earliest_start.0.min(MAX_MISSION_TIME_US) as i64).saturating_neg(),
                );
                if t.latest_start.0 <= MAX_MISSION_TIME_US {
                    f(0, s, t.latest_start.0 as i64);
                }
            }
        }
    };
    // Shortest distances from the zero node, forward (upper bounds) and backward (lower bounds).
    let shortest = |reverse: bool| -> Option<[i64; NODES]> {
        let mut dist = [i64::MAX; NODES];
        *dist.get_mut(0)? = 0;
        for round in 0..=NODES {
            let mut changed = false;
            edges(&mut |u, v, w| {
                let (u, v) = if reverse { (v, u) } else { (u, v) };
                let du = dist.get(u).copied().unwrap_or(i64::MAX);
                if du == i64::MAX {
                    return;
                }
                let cand = du.saturating_add(w);
                if let Some(dv) = dist.get_mut(v) {
                    if cand < *dv {
                        *dv = cand;
                        changed = true;
                    }
                }
            });
            if !changed {
                return Some(dist);
            }
            if round == NODES {
                return None; // negative cycle: inconsistent
            }
        }
        Some(dist)
    };
    let start_node = node(usize::from(entry.def), TaskPoint::Start);
    let upper = shortest(false)?
        .get(start_node)
        .copied()
        .unwrap_or(i64::MAX);
    let lower = shortest(true)?.get(start_node).copied().unwrap_or(i64::MAX);
    let hi = if upper == i64::MAX {
        u64::MAX
    } else {
        upper.max(0) as u64
    };
    let lo = if lower == i64::MAX {
        0
    } else {
        lower.saturating_neg().max(0) as u64
    };
    Some((MissionTimeUs(lo), MissionTimeUs(hi)))
}

/// The definition (index and spec) of template `template_id` if it has an impact on `timeline` (a task the
/// planner may add to change that timeline); None when the template does not exist or does not
/// touch the timeline.
pub(super) fn template_impacting(
    network: &TaskNetwork,
    template_id: u16,
    timeline: u8,
) -> Option<(u8, &TaskSpec)> {
    let def = network.def_of_id(template_id)?;
    let spec = network.task(def)?;
    spec.impacts
        .iter()
        .any(|i| i.timeline == timeline)
        .then_some((def, spec))
}
