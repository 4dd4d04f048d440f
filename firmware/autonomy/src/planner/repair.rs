//! Repair: conflicts in the projected plan found and resolved with the permitted modifiers
//! (move, add a template, delete).

use super::*;
impl Planner {
    /// The first constraint that does not hold in the projected plan, scanning placed and
    /// executing instances by start time. With `skip_tried`, conflicts already worked on in
    /// this cycle are passed over.
    pub(super) fn first_conflict(&mut self, ctx: &Ctx<'_>, skip_tried: bool) -> Option<Conflict> {
        self.scratch.events.build(ctx.network, &self.entries);
        let view = PlanView::new(ctx.network, &self.entries, &self.anchors)
            .with_events(&self.scratch.events);
        let mut best: Option<(MissionTimeUs, u16, Conflict)> = None;
        for e in self.entries.iter().filter(|e| is_live(e)) {
            let Some(spec) = ctx.network.task(e.def) else {
                continue;
            };
            for (k, c) in spec.constraints.iter().enumerate() {
                let k = k as u8;
                if skip_tried && self.tried.contains(&(e.instance, k)) {
                    continue;
                }
                if constraint_holds(&view, e.instance, c, e.start, e.end, ctx.now) {
                    continue;
                }
                let (a, b) = constraint_span(c, e.start, e.end);
                let a = a.max(ctx.now);
                let (from, to) = match c.when {
                    ConstraintWhen::Pre => (a, b),
                    ConstraintWhen::Maintain => view
                        .first_violation(c.timeline, &c.require, a, b)
                        .unwrap_or((a, b)),
                };
                let conflict = Conflict {
                    instance: e.instance,
                    constraint: k,
                    from,
                    to,
                };
                if best.is_none_or(|(s, i, _)| (e.start, e.instance) < (s, i)) {
                    best = Some((e.start, e.instance, conflict));
                }
                break;
            }
        }
        best.map(|(_, _, c)| c)
    }

    /// Every constraint that does not hold in the projected plan (tests, reports).
    pub fn conflicts(
        &self,
        network: &TaskNetwork,
        now: MissionTimeUs,
    ) -> Vec<Conflict, MAX_PLAN_ENTRIES> {
        let ctx = Ctx { network, now };
        let view = PlanView::new(network, &self.entries, &self.anchors);
        let mut out = Vec::new();
        for e in self.entries.iter().filter(|e| is_live(e)) {
            let Some(spec) = network.task(e.def) else {
                continue;
            };
            for (k, c) in spec.constraints.iter().enumerate() {
                if !constraint_holds(&view, e.instance, c, e.start, e.end, ctx.now) {
                    let (a, b) = constraint_span(c, e.start, e.end);
                    let _ = out.push(Conflict {
                        instance: e.instance,
                        constraint: k as u8,
                        from: a,
                        to: b,
                    });
                }
            }
        }
        out
    }

    /// Repairs one conflict: move the task (if permitted and uncommitted), else add a permitted
    /// template that restores the timeline, else delete the task (if permitted and uncommitted).
    pub(super) fn repair(&mut self, ctx: &Ctx<'_>, conflict: Conflict, out: &mut impl Outputs) {
        let Some(i) = self.entry_index(conflict.instance) else {
            return;
        };
        let Some(entry) = self.entries.get(i).copied() else {
            return;
        };
        let Some(spec) = ctx.network.task(entry.def) else {
            return;
        };
        let uncommitted = entry.state == TaskState::Scheduled;
        if uncommitted && spec.permissions.may_move {
            if let Some(e) = self.entries.get_mut(i) {
                e.state = TaskState::Unscheduled;
            }
            if self.schedule(ctx, entry.instance, true, out) {
                return;
            }
            // Put it back where it was and try the other modifiers.
            if let Some(e) = self
                .entry_index(entry.instance)
                .and_then(|i| self.entries.get_mut(i))
            {
                e.state = TaskState::Scheduled;
                e.start = entry.start;
                e.end = entry.end;
            }
        }
        if self.add_for_conflict(ctx, &entry, conflict, out) {
            return;
        }
        if uncommitted && spec.permissions.may_delete {
            if let Some(e) = self.entries.get_mut(i) {
                e.state = TaskState::Deleted;
            }
            Self::emit_modification(
                out,
                PlanModificationKind::Delete,
                entry.instance,
                spec.id,
                ctx.now,
            );
            Self::emit_transition(
                out,
                entry.instance,
                TaskState::Scheduled,
                TaskState::Deleted,
                ctx.now,
            );
        }
    }

    /// Templates permitted for a conflict on `timeline`: those the constrained task may add,
    /// then those every task definition that impacts the timeline may add (in network order),
    /// without repeats. This depends on the network only, never on what is left in the plan.
    pub(super) fn permitted_templates(
        &self,
        network: &TaskNetwork,
        owner: &PlanEntry,
        timeline: u8,
    ) -> Vec<u16, MAX_TASKS> {
        let mut out: Vec<u16, MAX_TASKS> = Vec::new();
        let mut add_from = |s: &TaskSpec| {
            for &id in &s.permissions.may_add {
                if !out.contains(&id) {
                    let _ = out.push(id);
                }
            }
        };
        if let Some(s) = network.task(owner.def) {
            add_from(s);
        }
        for s in network.tasks() {
            if s.impacts.iter().any(|i| i.timeline == timeline) {
                add_from(s);
            }
        }
        out
    }

    pub(super) fn add_for_conflict(
        &mut self,
        ctx: &Ctx<'_>,
        owner: &PlanEntry,
        conflict: Conflict,
        out: &mut impl Outputs,
    ) -> bool {
        let Some(constraint) = ctx
            .network
            .task(owner.def)
            .and_then(|s| s.constraints.get(usize::from(conflict.constraint)))
            .copied()
        else {
            return false;
        };
        let templates = self.permitted_templates(ctx.network, owner, constraint.timeline);
        for &template_id in &templates {
            let Some((tdef, tspec)) =
                template_impacting(ctx.network, template_id, constraint.timeline)
            else {
                continue;
            };
            let Some(not_before) = self.may_add(ctx.network, tdef, None) else {
                continue;
            };
            let earliest = ctx.now.max(not_before);
            let helper = self.new_helper(tdef, owner, conflict.from, earliest, conflict.from);
            // First try covering the violation exactly (a MAINTAIN impact filling a gap), then
            // the earliest valid placement that ends its changes before the violation.
            let gap = conflict.to.0.saturating_sub(conflict.from.0);
            let cover_duration = gap.max(tspec.min_duration_us).min(tspec.duration_us);
            let mut trials: Vec<(MissionTimeUs, MissionTimeUs), 2> = Vec::new();
            if conflict.from >= earliest {
                let _ = trials.push((conflict.from, conflict.from.saturating_add(cover_duration)));
            }
            if let Some(s) = self.earliest_valid(ctx, &helper) {
                if let Some(end) = Self::end_for(ctx.network, &helper, s) {
                    let _ = trials.push((s, end));
                }
            }
            for (start, end) in trials {
                if self.place_helper(ctx, owner, &constraint, conflict, &helper, start, end) {
                    self.announce_added(ctx, owner, conflict, template_id, out);
                    return true;
                }
            }
            // The gap is shorter than the template can run (a flyby delayed by less than the
            // degraded flyby's minimum): make room by starting the movable task that ends the
            // gap that much later, then cover the whole gap.
            let cover_end = conflict.from.saturating_add(cover_duration);
            if gap < cover_duration && conflict.from >= earliest {
                if let Some((j, before)) = self.make_room(ctx, owner, conflict.from, cover_end) {
                    if self.place_helper(
                        ctx,
                        owner,
                        &constraint,
                        conflict,
                        &helper,
                        conflict.from,
                        cover_end,
                    ) {
                        let template = before.template_id(ctx.network);
                        Self::emit_modification(
                            out,
                            PlanModificationKind::Move,
                            before.instance,
                            template,
                            ctx.now,
                        );
                        self.announce_added(ctx, owner, conflict, template_id, out);
                        return true;
                    }
                    if let Some(e) = self.entries.get_mut(j) {
                        *e = before;
                    }
                }
            }
        }
        false
    }

    /// A not yet placed instance of template `def`, added for `owner`, tentatively at `at`,
    /// to start within `earliest..=latest` (it gets the next instance id if it is kept).
    pub(super) fn new_helper(
        &self,
        def: u8,
        owner: &PlanEntry,
        at: MissionTimeUs,
        earliest: MissionTimeUs,
        latest: MissionTimeUs,
    ) -> PlanEntry {
        PlanEntry {
            instance: self.next_instance,
            def,
            state: TaskState::Unscheduled,
            start: at,
            end: at,
            earliest_start: earliest,
            latest_start: latest,
            started: false,
            persistent: false,
            origin: Origin::Added {
                for_instance: owner.instance,
            },
        }
    }

    /// Place `helper` at `start..end` if that is valid and makes `owner`'s `constraint` hold
    /// where the violation started; otherwise leave the plan as it was.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn place_helper(
        &mut self,
        ctx: &Ctx<'_>,
        owner: &PlanEntry,
        constraint: &ConstraintSpec,
        conflict: Conflict,
        helper: &PlanEntry,
        start: MissionTimeUs,
        end: MissionTimeUs,
    ) -> bool {
        self.stats.validity_checks = self.stats.validity_checks.saturating_add(1);
        self.scratch.events.build(ctx.network, &self.entries);
        if !placement_valid_with_events(
            ctx.network,
            &self.entries,
            &self.anchors,
            Some(&self.scratch.events),
            helper,
            start,
            end,
            ctx.now,
        ) {
            return false;
        }
        let placed = PlanEntry {
            state: TaskState::Scheduled,
            start,
            end,
            earliest_start: start,
            latest_start: start,
            ..*helper
        };
        if self.entries.push(placed).is_err() {
            self.stats.plan_full = self.stats.plan_full.saturating_add(1);
            return false;
        }
        // Progress: the constraint now holds at the instant the violation started.
        let view = PlanView::new(ctx.network, &self.entries, &self.anchors);
        let fixed = match constraint.when {
            ConstraintWhen::Pre => constraint_holds(
                &view,
                owner.instance,
                constraint,
                owner.start,
                owner.end,
                ctx.now,
            ),
            ConstraintWhen::Maintain => view.holds_over(
                constraint.timeline,
                &constraint.require,
                conflict.from,
                MissionTimeUs(conflict.from.0.saturating_add(1)),
            ),
        };
        if !fixed {
            self.entries.pop();
        }
        fixed
    }

    /// Report the helper `place_helper` just placed, and look at `owner`'s constraint again
    /// (it may still fail later on).
    pub(super) fn announce_added(
        &mut self,
        ctx: &Ctx<'_>,
        owner: &PlanEntry,
        conflict: Conflict,
        template_id: u16,
        out: &mut impl Outputs,
    ) {
        let id = self.new_instance_id();
        if let Some(def) = ctx.network.def_of_id(template_id) {
            self.count_instance(def);
        }
        Self::emit_modification(out, PlanModificationKind::Add, id, template_id, ctx.now);
        Self::emit_transition(
            out,
            id,
            TaskState::Unscheduled,
            TaskState::Scheduled,
            ctx.now,
        );
        self.tried
            .retain(|&(i, k)| !(i == owner.instance && k == conflict.constraint));
    }

    /// Start the uncommitted, movable task that begins inside `(from, until)` at `until`
    /// instead, if its window allows and it stays valid there. Returns its index and its entry
    /// as it was (to put back), or None with the plan unchanged.
    pub(super) fn make_room(
        &mut self,
        ctx: &Ctx<'_>,
        owner: &PlanEntry,
        from: MissionTimeUs,
        until: MissionTimeUs,
    ) -> Option<(usize, PlanEntry)> {
        let j = self.entries.iter().position(|e| {
            e.state == TaskState::Scheduled
                && !e.started
                && e.instance != owner.instance
                && e.start > from
                && e.start < until
                && ctx
                    .network
                    .task(e.def)
                    .is_some_and(|s| s.permissions.may_move)
        })?;
        let before = *self.entries.get(j)?;
        let (lo, hi) = self.start_window(ctx, &before)?;
        if until < lo || until > hi {
            return None;
        }
        let end = Self::end_for(ctx.network, &before, until)?;
        self.stats.validity_checks = self.stats.validity_checks.saturating_add(1);
        self.scratch.events.build(ctx.network, &self.entries);
        if !placement_valid_with_events(
            ctx.network,
            &self.entries,
            &self.anchors,
            Some(&self.scratch.events),
            &before,
            until,
            end,
            ctx.now,
        ) {
            return None;
        }
        let e = self.entries.get_mut(j)?;
        e.start = until;
        e.end = end;
        Some((j, before))
    }
}
