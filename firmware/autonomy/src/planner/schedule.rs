//! Scheduling: unscheduled instances placed at their earliest valid start, the candidate starts
//! a placement search tries (critical instants, seed 003) and the valid intervals they give.

use super::*;
impl Planner {
    /// The next unscheduled instance in the scheduling window: earliest start first, then
    /// higher priority, then lower instance id.
    pub(super) fn next_to_schedule(&self, ctx: &Ctx<'_>) -> Option<u16> {
        let horizon = ctx
            .now
            .saturating_add(ctx.network.config().scheduling_window_us);
        self.entries
            .iter()
            .filter(|e| e.state == TaskState::Unscheduled && !self.attempted.contains(&e.instance))
            .filter(|e| e.earliest_start <= horizon)
            .min_by_key(|e| {
                let priority = ctx.network.task(e.def).map(|t| t.priority).unwrap_or(0);
                (e.earliest_start, u8::MAX - priority, e.instance)
            })
            .map(|e| e.instance)
    }

    /// The end of an instance of `def` starting at `start`.
    pub(super) fn end_for(
        network: &TaskNetwork,
        entry: &PlanEntry,
        start: MissionTimeUs,
    ) -> Option<MissionTimeUs> {
        let spec = network.task(entry.def)?;
        let duration = match entry.origin {
            Origin::Restarted { .. } if entry.latest_start == MissionTimeUs::MAX => {
                Some(spec.duration_us)
            }
            _ => spec.duration_from(start),
        }?;
        Some(start.saturating_add(duration))
    }

    /// The window of start times for `entry`: its own window, the plan horizon, and the
    /// temporal constraints with requested tasks (of a requested instance, or of a template's
    /// instance).
    pub(super) fn start_window(
        &self,
        ctx: &Ctx<'_>,
        entry: &PlanEntry,
    ) -> Option<(MissionTimeUs, MissionTimeUs)> {
        let spec = ctx.network.task(entry.def)?;
        let lo = entry.earliest_start.max(ctx.now);
        let mut hi = entry
            .latest_start
            .min(ctx.now.saturating_add(ctx.network.config().plan_horizon_us));
        if entry.latest_start != MissionTimeUs::MAX || entry.origin == Origin::Requested {
            hi = hi.min(MissionTimeUs(
                spec.latest_end.0.saturating_sub(spec.min_duration_us),
            ));
        }
        let bound = entry.origin == Origin::Requested || spec.role == TaskRole::Template;
        let (lo, hi) = if bound {
            let (tlo, thi) = temporal_window(ctx.network, &self.entries, entry)?;
            (lo.max(tlo), hi.min(thi))
        } else {
            (lo, hi)
        };
        (lo <= hi).then_some((lo, hi))
    }

    /// Places instance `instance` at its earliest valid start, adding permitted templates to
    /// enable it if need be. Returns whether it was placed.
    pub(super) fn schedule(
        &mut self,
        ctx: &Ctx<'_>,
        instance: u16,
        is_move: bool,
        out: &mut impl Outputs,
    ) -> bool {
        let Some(entry) = self
            .entry_index(instance)
            .and_then(|i| self.entries.get(i))
            .copied()
        else {
            return false;
        };
        if let Some(start) = self.earliest_valid(ctx, &entry) {
            self.place(ctx, instance, start, is_move, out);
            return true;
        }
        if self.enable(ctx, &entry, is_move, out) {
            return true;
        }
        if !entry.persistent && !is_move {
            let kind = FailureKind::Unschedulable;
            if let Some(e) = self
                .entry_index(instance)
                .and_then(|i| self.entries.get_mut(i))
            {
                e.state = TaskState::Failed(kind);
            }
            Self::emit_transition(
                out,
                instance,
                TaskState::Unscheduled,
                TaskState::Failed(kind),
                ctx.now,
            );
        }
        false
    }

    pub(super) fn earliest_valid(
        &mut self,
        ctx: &Ctx<'_>,
        entry: &PlanEntry,
    ) -> Option<MissionTimeUs> {
        let (lo, hi) = self.start_window(ctx, entry)?;
        self.collect_candidates(ctx, entry, lo, hi);
        // The candidates are read in place (taking the 4 KiB buffer out and putting it back
        // cost two copies of it per call, a sixth of a reset's recovery on the 750). They are
        // tried in increasing order, each once: the first few found by a scan for the next
        // smallest (most searches end there: a whole sort of a few hundred 64-bit times cost
        // more than the checks), the rest after sorting what is left.
        let mut checks = 0u32;
        let valid = |planner: &Self, start: MissionTimeUs| {
            Self::end_for(ctx.network, entry, start).is_some_and(|end| {
                placement_valid_with_events(
                    ctx.network,
                    &planner.entries,
                    &planner.anchors,
                    Some(&planner.scratch.events),
                    entry,
                    start,
                    end,
                    ctx.now,
                )
            })
        };
        let mut tried: Option<u64> = None;
        let mut found = None;
        let mut exhausted = false;
        for _ in 0..SCANNED_CANDIDATES {
            let Some(c) = next_candidate(&self.scratch.candidates, tried) else {
                exhausted = true;
                break;
            };
            tried = Some(c);
            checks = checks.saturating_add(1);
            if valid(self, MissionTimeUs(c)) {
                found = Some(MissionTimeUs(c));
                break;
            }
        }
        if found.is_none() && !exhausted {
            self.sort_candidates();
            found = self
                .scratch
                .candidates
                .iter()
                .copied()
                .filter(|&c| tried.is_none_or(|t| c > t))
                .map(MissionTimeUs)
                .find(|&start| {
                    checks = checks.saturating_add(1);
                    valid(self, start)
                });
        }
        self.stats.validity_checks = self.stats.validity_checks.saturating_add(checks);
        found
    }

    pub(super) fn place(
        &mut self,
        ctx: &Ctx<'_>,
        instance: u16,
        start: MissionTimeUs,
        is_move: bool,
        out: &mut impl Outputs,
    ) {
        let Some(i) = self.entry_index(instance) else {
            return;
        };
        let Some(entry) = self.entries.get(i).copied() else {
            return;
        };
        let Some(end) = Self::end_for(ctx.network, &entry, start) else {
            return;
        };
        if let Some(e) = self.entries.get_mut(i) {
            e.start = start;
            e.end = end;
            e.state = TaskState::Scheduled;
        }
        if is_move {
            let template = entry.template_id(ctx.network);
            Self::emit_modification(out, PlanModificationKind::Move, instance, template, ctx.now);
        } else {
            Self::emit_transition(
                out,
                instance,
                TaskState::Unscheduled,
                TaskState::Scheduled,
                ctx.now,
            );
        }
    }

    /// Tries permitted templates that impact the timeline of a constraint `entry` cannot meet.
    pub(super) fn enable(
        &mut self,
        ctx: &Ctx<'_>,
        entry: &PlanEntry,
        is_move: bool,
        out: &mut impl Outputs,
    ) -> bool {
        let Some(spec) = ctx.network.task(entry.def) else {
            return false;
        };
        let Some((_, hi)) = self.start_window(ctx, entry) else {
            return false;
        };
        for constraint in spec.constraints.iter() {
            for &template_id in spec.permissions.may_add.iter() {
                let Some((tdef, _)) =
                    template_impacting(ctx.network, template_id, constraint.timeline)
                else {
                    continue;
                };
                let Some(not_before) = self.may_add(ctx.network, tdef, None) else {
                    continue;
                };
                let earliest = ctx.now.max(not_before);
                let helper = self.new_helper(tdef, entry, earliest, earliest, hi);
                let Some(helper_start) = self.earliest_valid(ctx, &helper) else {
                    continue;
                };
                let Some(helper_end) = Self::end_for(ctx.network, &helper, helper_start) else {
                    continue;
                };
                let placed = PlanEntry {
                    state: TaskState::Scheduled,
                    start: helper_start,
                    end: helper_end,
                    ..helper
                };
                if self.entries.push(placed).is_err() {
                    self.stats.plan_full = self.stats.plan_full.saturating_add(1);
                    return false;
                }
                if let Some(start) = self.earliest_valid(ctx, entry) {
                    let helper_id = self.new_instance_id();
                    self.count_instance(tdef);
                    Self::emit_modification(
                        out,
                        PlanModificationKind::Add,
                        helper_id,
                        template_id,
                        ctx.now,
                    );
                    Self::emit_transition(
                        out,
                        helper_id,
                        TaskState::Unscheduled,
                        TaskState::Scheduled,
                        ctx.now,
                    );
                    self.place(ctx, entry.instance, start, is_move, out);
                    return true;
                }
                self.entries.pop();
            }
        }
        false
    }

    /// Exact validity check of `entry` placed at `start` against the rest of the plan
    /// (seed 003 validity checks), counting one budget step. `scratch.events` must list the
    /// plan's events as they are now.
    pub(super) fn placement_valid(
        &mut self,
        ctx: &Ctx<'_>,
        entry: &PlanEntry,
        start: MissionTimeUs,
    ) -> bool {
        self.stats.validity_checks = self.stats.validity_checks.saturating_add(1);
        let Some(end) = Self::end_for(ctx.network, entry, start) else {
            return false;
        };
        placement_valid_with_events(
            ctx.network,
            &self.entries,
            &self.anchors,
            Some(&self.scratch.events),
            entry,
            start,
            end,
            ctx.now,
        )
    }

    /// Collects the critical start times of `entry` in `[lo, hi]`, sorted and unique, and
    /// lists the plan's events in `scratch.events` for the validity checks that follow.
    pub(super) fn fill_candidates(
        &mut self,
        ctx: &Ctx<'_>,
        entry: &PlanEntry,
        lo: MissionTimeUs,
        hi: MissionTimeUs,
    ) {
        self.collect_candidates(ctx, entry, lo, hi);
        self.sort_candidates();
    }

    /// As [`Planner::fill_candidates`], unsorted and with repeats.
    pub(super) fn collect_candidates(
        &mut self,
        ctx: &Ctx<'_>,
        entry: &PlanEntry,
        lo: MissionTimeUs,
        hi: MissionTimeUs,
    ) {
        self.scratch.events.build(ctx.network, &self.entries);
        let candidates = &mut self.scratch.candidates;
        candidates.clear();
        let Some(spec) = ctx.network.task(entry.def) else {
            return;
        };
        let mut overflow = false;
        let mut push = |t: u64| {
            if t >= lo.0 && t <= hi.0 && candidates.push(t).is_err() {
                overflow = true;
            }
        };
        push(lo.0);
        push(hi.0);
        let mut start_offsets: Vec<i64, { MAX_CONSTRAINTS_PER_TASK + MAX_IMPACTS_PER_TASK }> =
            Vec::new();
        let mut end_offsets: Vec<i64, { MAX_CONSTRAINTS_PER_TASK + MAX_IMPACTS_PER_TASK }> =
            Vec::new();
        let mut timelines: Vec<u8, { MAX_CONSTRAINTS_PER_TASK + MAX_IMPACTS_PER_TASK }> =
            Vec::new();
        let mut impacted: Vec<u8, MAX_IMPACTS_PER_TASK> = Vec::new();
        // Each distinct offset once: a repeated offset would only push the same candidates
        // again for every instant (the flyby's tasks mostly use offset 0 throughout).
        fn add_once<const N: usize>(offsets: &mut Vec<i64, N>, o: i64) {
            if !offsets.contains(&o) {
                let _ = offsets.push(o);
            }
        }
        for c in &spec.constraints {
            add_once(&mut start_offsets, c.start_offset_us);
            if c.when == ConstraintWhen::Maintain {
                add_once(&mut end_offsets, c.end_offset_us);
            }
            if !timelines.contains(&c.timeline) {
                let _ = timelines.push(c.timeline);
            }
        }
        for i in &spec.impacts {
            match i.when {
                ImpactWhen::Pre => add_once(&mut start_offsets, i.start_offset_us),
                ImpactWhen::Post => add_once(&mut end_offsets, i.end_offset_us),
                ImpactWhen::Maintain => {
                    add_once(&mut start_offsets, i.start_offset_us);
                    add_once(&mut end_offsets, i.end_offset_us);
                }
            }
            if !timelines.contains(&i.timeline) {
                let _ = timelines.push(i.timeline);
            }
            if !impacted.contains(&i.timeline) {
                let _ = impacted.push(i.timeline);
            }
        }
        let duration = spec.duration_us;
        let latest_end = spec.latest_end;
        let mut from_instant = |t: MissionTimeUs| {
            for &o in &start_offsets {
                let s = t.0.saturating_add_signed(o.saturating_neg());
                push(s);
                push(s.saturating_add(1));
            }
            for &o in &end_offsets {
                let s =
                    t.0.saturating_add_signed(o.saturating_neg())
                        .saturating_sub(duration);
                push(s);
                push(s.saturating_add(1));
            }
        };
        from_instant(ctx.now);
        if latest_end != MissionTimeUs::MAX {
            for &o in end_offsets.clone().iter() {
                from_instant(shift(latest_end, o));
            }
            let s = latest_end.0.saturating_sub(duration);
            from_instant(MissionTimeUs(s));
        }
        let view = PlanView::new(ctx.network, &self.entries, &self.anchors)
            .with_events(&self.scratch.events)
            .without(entry.instance);
        for &tl in &timelines {
            view.for_each_event(tl, |e| from_instant(e.at));
        }
        for other in self
            .entries
            .iter()
            .filter(|e| e.instance != entry.instance && is_live(e))
        {
            let Some(ospec) = ctx.network.task(other.def) else {
                continue;
            };
            for c in ospec
                .constraints
                .iter()
                .filter(|c| impacted.contains(&c.timeline))
            {
                let (a, b) = constraint_span(c, other.start, other.end);
                from_instant(a);
                from_instant(b);
            }
        }
        if overflow {
            self.stats.candidate_overflows = self.stats.candidate_overflows.saturating_add(1);
        }
    }

    /// Sorts the candidates and drops repeats.
    pub(super) fn sort_candidates(&mut self) {
        let candidates = &mut self.scratch.candidates;
        heapsort(candidates);
        let mut w = 0usize;
        for r in 0..candidates.len() {
            let (Some(&v), prev) = (
                candidates.get(r),
                w.checked_sub(1).and_then(|p| candidates.get(p)).copied(),
            ) else {
                continue;
            };
            if prev != Some(v) {
                if let Some(slot) = candidates.get_mut(w) {
                    *slot = v;
                }
                w += 1;
            }
        }
        candidates.truncate(w);
    }

    /// Valid start intervals of `instance` within its window (seed 003 valid intervals).
    pub fn valid_intervals(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        instance: u16,
    ) -> Vec<ValidInterval, MAX_VALID_INTERVALS> {
        let ctx = Ctx { network, now };
        let mut out: Vec<ValidInterval, MAX_VALID_INTERVALS> = Vec::new();
        let Some(entry) = self
            .entry_index(instance)
            .and_then(|i| self.entries.get(i))
            .copied()
        else {
            return out;
        };
        let Some((lo, hi)) = self.start_window(&ctx, &entry) else {
            return out;
        };
        self.fill_candidates(&ctx, &entry, lo, hi);
        // By index: taking the list would copy all of it (MAX_CANDIDATES, 32 KiB) onto the
        // stack. The validity checks do not touch the candidates.
        let mut open: Option<ValidInterval> = None;
        for j in 0..self.scratch.candidates.len() {
            let Some(&c) = self.scratch.candidates.get(j) else {
                break;
            };
            let piece_end = self
                .scratch
                .candidates
                .get(j + 1)
                .map(|n| n - 1)
                .unwrap_or(hi.0);
            if self.placement_valid(&ctx, &entry, MissionTimeUs(c)) {
                open = Some(match open {
                    Some(iv) => ValidInterval {
                        end: MissionTimeUs(piece_end),
                        ..iv
                    },
                    None => ValidInterval {
                        start: MissionTimeUs(c),
                        end: MissionTimeUs(piece_end),
                    },
                });
            } else if let Some(iv) = open.take() {
                let _ = out.push(iv);
            }
        }
        if let Some(iv) = open {
            let _ = out.push(iv);
        }
        out
    }

    /// Exact validity check of `instance` placed at `start`, for tests and tools.
    pub fn is_valid_placement(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        instance: u16,
        start: MissionTimeUs,
    ) -> bool {
        let ctx = Ctx { network, now };
        let Some(entry) = self
            .entry_index(instance)
            .and_then(|i| self.entries.get(i))
            .copied()
        else {
            return false;
        };
        match self.start_window(&ctx, &entry) {
            Some((lo, hi)) if start >= lo && start <= hi => {
                self.scratch.events.build(network, &self.entries);
                self.placement_valid(&ctx, &entry, start)
            }
            _ => false,
        }
    }
}

/// Sorts `v` in increasing order ([`crate::small_sort::heapsort`]). The library's
/// `sort_unstable` of `u64` is about 8.7 KiB of code (its small-slice sorting networks), all of
/// it in the RAM image that the reset stub checks at every warm boot; this is a few hundred
/// bytes, and the candidates are sorted only when a search goes past the first few found by
/// [`next_candidate`]. Sorted values are the same whatever the algorithm.
pub(super) fn heapsort(v: &mut [u64]) {
    crate::small_sort::heapsort(v);
}

/// The smallest candidate after `tried` (the first if None): taking these in turn gives the
/// candidates in the order [`Planner::sort_candidates`] leaves them.
pub(super) fn next_candidate(candidates: &[u64], tried: Option<u64>) -> Option<u64> {
    candidates
        .iter()
        .copied()
        .filter(|&c| tried.is_none_or(|t| c > t))
        .min()
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn candidates_taken_one_by_one_come_in_sorted_order_once_each(
            values in proptest::collection::vec(0u64..40, 0..MAX_CANDIDATES),
            scanned in 0usize..12,
        ) {
            let mut p = Planner::new();
            for &v in &values {
                prop_assert!(p.scratch.candidates.push(v).is_ok());
            }
            // What earliest_valid does: a few by scanning, the rest from the sorted list.
            let mut order = std::vec::Vec::new();
            let mut tried = None;
            for _ in 0..scanned {
                let Some(c) = next_candidate(&p.scratch.candidates, tried) else {
                    break;
                };
                order.push(c);
                tried = Some(c);
            }
            p.sort_candidates();
            order.extend(p.scratch.candidates.iter().copied().filter(|&c| tried.is_none_or(|t| c > t)));
            let mut sorted = values.clone();
            sorted.sort_unstable();
            sorted.dedup();
            prop_assert_eq!(order, sorted);
        }

        #[test]
        fn the_heapsort_sorts_as_the_library_does(
            values in proptest::collection::vec(any::<u64>(), 0..MAX_CANDIDATES),
        ) {
            let mut ours = values.clone();
            heapsort(&mut ours);
            let mut sorted = values;
            sorted.sort_unstable();
            prop_assert_eq!(ours, sorted);
        }
    }
}
