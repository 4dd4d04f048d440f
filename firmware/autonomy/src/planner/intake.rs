//! The planner's intake: execution reports applied in arrival order, with the network's
//! contingencies, and the failure ledger that bounds its responses.

use super::*;
impl Planner {
    /// Applies queued execution reports in arrival order, with contingencies.
    pub(super) fn intake(&mut self, ctx: &Ctx<'_>, out: &mut impl Outputs) {
        // By index, then cleared: taking the list would copy all of it, its capacity
        // (MAX_TASK_REPORTS), onto the stack at every step. Nothing in the loop queues reports.
        for k in 0..self.reports.len() {
            let Some(r) = self.reports.get(k).copied() else {
                break;
            };
            let Some(i) = self.entry_index(r.instance) else {
                continue;
            };
            let Some(e) = self.entries.get_mut(i) else {
                continue;
            };
            match r.kind {
                ReportKind::Started => {
                    let duration = e.end.0.saturating_sub(e.start.0);
                    e.start = r.at;
                    e.end = r.at.saturating_add(duration);
                    e.started = true;
                    e.state = TaskState::Running;
                }
                ReportKind::Completed => {
                    e.end = r.at;
                    e.state = TaskState::Completed;
                    // The run of failures of this definition is over; the next run starts with
                    // the instances still live.
                    let def = e.def;
                    let live = self
                        .entries
                        .iter()
                        .filter(|x| x.def == def && !x.state.is_terminal())
                        .count();
                    if let Some(l) = self.ledger.get_mut(usize::from(def)) {
                        *l = FailureLedger {
                            instances: u8::try_from(live).unwrap_or(u8::MAX),
                            ..FailureLedger::default()
                        };
                    }
                }
                ReportKind::Skipped => e.state = TaskState::Skipped,
                ReportKind::Failed { kind, started } => {
                    e.started = started;
                    if started {
                        e.end = r.at;
                    }
                    e.state = TaskState::Failed(kind);
                    let entry = *e;
                    if self.record_failure(ctx, &entry, kind, out) {
                        self.apply_contingency(ctx, entry, kind, out);
                    }
                }
            }
        }
        self.reports.clear();
    }

    /// Gives up requested tasks whose window has closed without a placement.
    pub(super) fn expire(&mut self, ctx: &Ctx<'_>, out: &mut impl Outputs) {
        let mut i = 0;
        while let Some(e) = self.entries.get(i).copied() {
            i += 1;
            if e.state == TaskState::Unscheduled && e.latest_start < ctx.now {
                let kind = FailureKind::Unschedulable;
                if let Some(x) = self.entries.get_mut(i - 1) {
                    x.state = TaskState::Failed(kind);
                }
                Self::emit_transition(
                    out,
                    e.instance,
                    TaskState::Unscheduled,
                    TaskState::Failed(kind),
                    ctx.now,
                );
                self.apply_contingency(ctx, e, kind, out);
            }
        }
    }

    /// Counts a failure of `failed`'s definition with cause `kind` and starts its back-off.
    /// Returns whether the planner may still respond to it with a new instance; the first time
    /// the consecutive failures for `kind` exceed the definition's `max_repairs`, reports that
    /// it gives up. Failures outside [`FailureKind::REPAIRABLE`] are not counted.
    pub(super) fn record_failure(
        &mut self,
        ctx: &Ctx<'_>,
        failed: &PlanEntry,
        kind: FailureKind,
        out: &mut impl Outputs,
    ) -> bool {
        if FailureKind::REPAIRABLE & kind.bit() == 0 {
            return true;
        }
        let bound = ctx.network.max_repairs(failed.def).get(kind);
        let backoff = ctx.network.backoff(failed.def);
        let Some(l) = self.ledger.get_mut(usize::from(failed.def)) else {
            return false;
        };
        let n = l.consecutive.bump(kind);
        l.not_before = l
            .not_before
            .max(ctx.now.saturating_add(backoff.delay_us(u32::from(n))));
        if n <= bound {
            return true;
        }
        if l.gave_up & kind.bit() == 0 {
            l.gave_up |= kind.bit();
            self.stats.gave_up = self.stats.gave_up.saturating_add(1);
            let template = failed.template_id(ctx.network);
            out.telemetry(TelemetryEvent::PlanModification {
                kind: gave_up_code(kind),
                task: failed.instance,
                template,
                at: ctx.now,
            });
        }
        false
    }

    /// Whether the planner may put a new instance of definition `def` in the plan, and the
    /// earliest start it may have (its back-off). `cause`: the failure the instance answers
    /// (a contingency; its bound was checked by [`Self::record_failure`]), or None for a
    /// template added to enable or repair a task, which is refused once the planner gave up on
    /// any cause of the definition. Either way at most
    /// [`TaskNetwork::max_instances_per_run`] instances per run.
    pub(super) fn may_add(
        &self,
        network: &TaskNetwork,
        def: u8,
        cause: Option<FailureKind>,
    ) -> Option<MissionTimeUs> {
        let l = self.ledger.get(usize::from(def))?;
        let given_up = match cause {
            Some(c) => l.gave_up & c.bit() != 0,
            None => l.gave_up != 0,
        };
        let room = u32::from(l.instances) < network.max_instances_per_run(def);
        (!given_up && room).then_some(l.not_before)
    }

    /// Counts an instance of `def` put in the plan.
    pub(super) fn count_instance(&mut self, def: u8) {
        if let Some(l) = self.ledger.get_mut(usize::from(def)) {
            l.instances = l.instances.saturating_add(1);
        }
    }

    pub(super) fn add_entry(&mut self, entry: PlanEntry) -> bool {
        if self.entries.push(entry).is_err() {
            self.stats.plan_full = self.stats.plan_full.saturating_add(1);
            return false;
        }
        true
    }

    pub(super) fn apply_contingency(
        &mut self,
        ctx: &Ctx<'_>,
        failed: PlanEntry,
        kind: FailureKind,
        out: &mut impl Outputs,
    ) {
        let Some(spec) = ctx.network.task(failed.def) else {
            return;
        };
        // An instance that failed to be scheduled is not restarted (that would loop).
        let Some(action) = spec.contingency_for(kind) else {
            return;
        };
        match action {
            ContingencyAction::Restart | ContingencyAction::Move => {
                if kind == FailureKind::Unschedulable {
                    return;
                }
                let Some(not_before) = self.may_add(ctx.network, failed.def, Some(kind)) else {
                    return;
                };
                let instance = self.new_instance_id();
                let earliest = spec.earliest_start.max(ctx.now).max(not_before);
                let latest_start = if action == ContingencyAction::Move {
                    MissionTimeUs::MAX
                } else {
                    spec.latest_start
                };
                if self.add_entry(PlanEntry {
                    instance,
                    def: failed.def,
                    state: TaskState::Unscheduled,
                    start: earliest,
                    end: earliest,
                    earliest_start: earliest,
                    latest_start,
                    started: false,
                    persistent: false,
                    origin: Origin::Restarted {
                        of_instance: failed.instance,
                    },
                }) {
                    self.count_instance(failed.def);
                    Self::emit_modification(
                        out,
                        PlanModificationKind::Restart,
                        instance,
                        spec.id,
                        ctx.now,
                    );
                }
            }
            ContingencyAction::AddTemplate(id) => {
                let Some(def) = ctx.network.def_of_id(id) else {
                    return;
                };
                // The response to `failed` (its bound was checked) and an instance of the
                // template (which must not be given up on, and has its own back-off).
                let Some(not_before) = self.may_add(ctx.network, failed.def, Some(kind)) else {
                    return;
                };
                let Some(template_not_before) = self.may_add(ctx.network, def, None) else {
                    return;
                };
                let earliest = ctx.now.max(not_before).max(template_not_before);
                let instance = self.new_instance_id();
                if self.add_entry(PlanEntry {
                    instance,
                    def,
                    state: TaskState::Unscheduled,
                    start: earliest,
                    end: earliest,
                    earliest_start: earliest,
                    latest_start: MissionTimeUs::MAX,
                    started: false,
                    persistent: false,
                    origin: Origin::Added {
                        for_instance: failed.instance,
                    },
                }) {
                    self.count_instance(def);
                    Self::emit_modification(out, PlanModificationKind::Add, instance, id, ctx.now);
                }
            }
            ContingencyAction::Delete => {
                Self::emit_modification(
                    out,
                    PlanModificationKind::Delete,
                    failed.instance,
                    spec.id,
                    ctx.now,
                );
            }
        }
    }
}
