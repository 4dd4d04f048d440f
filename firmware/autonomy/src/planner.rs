//! The planner (seed 000 IV.A.3, seed 003): every cycle it takes in execution reports and
//! applies contingencies, consolidates the past, schedules unscheduled tasks into valid
//! intervals (adding permitted templates to enable them), repairs conflicts with the permitted
//! modifiers (move, add, delete) and commits tasks in the commit window to the executive.
//!
//! Its responses to failures are bounded ([`FailureLedger`]): per task definition and cause it
//! counts consecutive failures, delays each new instance it puts in the plan for them by the
//! definition's back-off, and past the definition's `max_repairs` for a cause it gives up on
//! that definition (reported with [`crate::telemetry::gave_up_code`]) instead of restarting,
//! moving or re-adding it, until an instance of it completes.
//!
//! It is anytime: [`Planner::step`] is given a budget of validity checks; a scheduling or repair
//! job that starts finishes, but no new job starts once the budget is spent, and the next call
//! resumes the cycle where it stopped. Commits happen on every call, whatever the budget.
//!
//! Valid intervals follow seed 003 by construction: the validity of a placement only changes
//! where one of the task's relative instants (start or end plus an offset) meets an event or a
//! constraint boundary of another task, so checking each such critical start and the instant
//! after it gives the exact valid intervals for state, claimable and cumulative (step)
//! timelines. With rate impacts the same candidates are used and the chosen placement is still
//! checked exactly, but a window that opens between candidates may be missed.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::capacity::*;
pub use crate::interface::{Commit, ReportKind, TaskReport};
use crate::interface::{Outputs, ToPlanner};
use crate::model::*;
use crate::plan::{Origin, PlanEntry};
use crate::telemetry::{gave_up_code, FailureKind, PlanModificationKind, TaskState};
use crate::timeline::{
    consolidate, constraint_holds, constraint_span, shift, Anchors, Candidate, CandidateEvents,
    Measurement, PlanEvents, PlanView, TimelineAnchor,
};
use fsw_bridge::{MissionTimeUs, TelemetryEvent};

/// A constraint that does not hold in the projected plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Conflict {
    pub instance: u16,
    pub constraint: u8,
    /// Violated from `from` until `to` (exclusive).
    pub from: MissionTimeUs,
    pub to: MissionTimeUs,
}

/// A closed interval of valid start times `[start, end]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ValidInterval {
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
}

/// What the planner remembers of one task definition's failures: how many in a row for each
/// cause, which causes it gave up on, and until when its next response waits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FailureLedger {
    /// Consecutive failures per cause since an instance of the definition last completed
    /// (causes in [`FailureKind::REPAIRABLE`] only).
    pub consecutive: PerCause,
    /// Causes (bits of [`FailureKind::bit`]) whose bound was exceeded: the planner no longer
    /// restarts, moves or re-adds the definition.
    pub gave_up: u8,
    /// The back-off after the last failure: no instance put in the plan in response starts
    /// earlier.
    pub not_before: MissionTimeUs,
    /// Instances of the definition in this run: those live when an instance last completed
    /// (or the requested one), and every one the planner put in the plan since. At most
    /// [`TaskNetwork::max_instances_per_run`], so the commands one run can send are bounded
    /// even when instances are added faster than they fail.
    pub instances: u8,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
enum Phase {
    Idle,
    Consolidate,
    Schedule,
    Repair,
}

/// Counters for benchmarks and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlannerStats {
    pub cycles: u32,
    pub validity_checks: u32,
    pub candidate_overflows: u32,
    pub dropped_reports: u32,
    pub plan_full: u32,
    /// Responses declined because a bound was exceeded (gave-up reports).
    pub gave_up: u32,
    /// Commits the executive gave back because it was full ([`ToPlanner::Returned`]); each
    /// was committed again later.
    pub returned: u32,
}

/// Result of one [`Planner::step`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlannerStepReport {
    /// Validity checks spent.
    pub checks: u32,
    /// True when the cycle stopped on the budget and wants to run again at once.
    pub work_pending: bool,
    /// A cycle ended in this step: the mission time from the step that started it (the first
    /// step after the event that made the plan dirty, or the periodic cycle's time) to this
    /// one, whose commits carry its result. 0 when the cycle fitted in one step; more when it
    /// ran over several (a throttled planner: see [`crate::Autonomy`]).
    pub cycle_latency_us: Option<u64>,
}

/// Scheduling passes in one planner cycle (a pass that placed something is followed by
/// another, up to this many).
pub(crate) const MAX_SCHEDULE_PASSES: u8 = 3;

/// Candidate starts a placement search takes by scanning for the next smallest before it
/// sorts the rest.
const SCANNED_CANDIDATES: usize = 8;

/// Planner state. Everything but the scratch buffer is saved in checkpoints.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Planner {
    entries: Vec<PlanEntry, MAX_PLAN_ENTRIES>,
    anchors: Anchors,
    next_instance: u16,
    phase: Phase,
    dirty: bool,
    last_cycle_at: Option<MissionTimeUs>,
    /// Instances already attempted in the current scheduling pass.
    attempted: Vec<u16, MAX_PLAN_ENTRIES>,
    placed_in_pass: bool,
    passes: u8,
    /// (instance, constraint) conflicts already worked on this cycle.
    tried: Vec<(u16, u8), MAX_REPAIRS_PER_CYCLE>,
    reports: Vec<TaskReport, MAX_TASK_REPORTS>,
    /// One per task definition of the network, in network order.
    ledger: Vec<FailureLedger, MAX_TASKS>,
    pub stats: PlannerStats,
    #[serde(skip)]
    scratch: Scratch,
}

/// Decodes a planner as a checkpoint holds it (every field of [`Planner`] but the scratch
/// buffers, in the same order: what `Planner`'s `Serialize` wrote) into the planner itself, each
/// list straight into its place ([`crate::in_place`]); the scratch buffers are left as they
/// are (the restore's [`Planner::after_restore`] empties them). Decoding a whole `Planner` as a
/// value built its scratch buffers too and then moved all of it into place.
pub(crate) struct PlannerInPlace<'a>(pub &'a mut Planner);

/// Fields of a saved planner.
const SAVED_PLANNER_FIELDS: usize = 13;

impl<'de> serde::de::DeserializeSeed<'de> for PlannerInPlace<'_> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_tuple(SAVED_PLANNER_FIELDS, self)
    }
}

impl<'de> serde::de::Visitor<'de> for PlannerInPlace<'_> {
    type Value = ();

    fn expecting(&self, formatter: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        formatter.write_str("a saved planner")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        use crate::in_place::{field, field_into, VecInto};
        let p = self.0;
        field_into(&mut seq, VecInto(&mut p.entries), 0)?;
        field_into(&mut seq, VecInto(&mut p.anchors), 1)?;
        p.next_instance = field(&mut seq, 2)?;
        p.phase = field(&mut seq, 3)?;
        p.dirty = field(&mut seq, 4)?;
        p.last_cycle_at = field(&mut seq, 5)?;
        field_into(&mut seq, VecInto(&mut p.attempted), 6)?;
        p.placed_in_pass = field(&mut seq, 7)?;
        p.passes = field(&mut seq, 8)?;
        field_into(&mut seq, VecInto(&mut p.tried), 9)?;
        field_into(&mut seq, VecInto(&mut p.reports), 10)?;
        field_into(&mut seq, VecInto(&mut p.ledger), 11)?;
        p.stats = field(&mut seq, 12)?;
        Ok(())
    }
}

#[derive(Clone, Debug, Default)]
struct Scratch {
    candidates: Vec<u64, MAX_CANDIDATES>,
    /// The plan's events listed once per timeline for the validity checks of one placement
    /// search (built by `fill_candidates`, stale as soon as the entries change).
    events: PlanEvents,
    /// When the cycle in progress started (not saved: a restore starts a new cycle).
    cycle_started_at: Option<MissionTimeUs>,
}

impl Default for Planner {
    fn default() -> Self {
        Self::new()
    }
}

/// The context every placement helper needs.
struct Ctx<'a> {
    network: &'a TaskNetwork,
    now: MissionTimeUs,
}

impl Planner {
    pub const fn new() -> Self {
        Self {
            entries: Vec::new(),
            anchors: Vec::new(),
            next_instance: FIRST_INSTANCE_ID,
            phase: Phase::Idle,
            dirty: false,
            last_cycle_at: None,
            attempted: Vec::new(),
            placed_in_pass: false,
            passes: 0,
            tried: Vec::new(),
            reports: Vec::new(),
            ledger: Vec::new(),
            stats: PlannerStats {
                cycles: 0,
                validity_checks: 0,
                candidate_overflows: 0,
                dropped_reports: 0,
                plan_full: 0,
                gave_up: 0,
                returned: 0,
            },
            scratch: Scratch {
                candidates: Vec::new(),
                events: PlanEvents::new(),
                cycle_started_at: None,
            },
        }
    }

    /// Makes this planner what [`Planner::new`] is, in place: `*self = Self::new()` copies a
    /// constant image of a whole planner, which sits in the firmware image (and the reset
    /// stub's image check reads it at every boot).
    pub fn reset(&mut self) {
        self.entries.clear();
        self.anchors.clear();
        self.next_instance = FIRST_INSTANCE_ID;
        self.phase = Phase::Idle;
        self.dirty = false;
        self.last_cycle_at = None;
        self.attempted.clear();
        self.placed_in_pass = false;
        self.passes = 0;
        self.tried.clear();
        self.reports.clear();
        self.ledger.clear();
        self.stats = PlannerStats::default();
        self.scratch.candidates.clear();
        self.scratch.events.clear();
        self.scratch.cycle_started_at = None;
    }

    /// Forgets the plan and starts from `network`'s requested tasks, all unscheduled.
    pub fn load(&mut self, network: &TaskNetwork) {
        self.reset();
        for t in network.timelines() {
            let _ = self.anchors.push(TimelineAnchor::initial(t));
        }
        for t in network.tasks() {
            let _ = self.ledger.push(FailureLedger {
                instances: u8::from(t.role == TaskRole::Requested),
                ..FailureLedger::default()
            });
        }
        for (i, t) in network.tasks().iter().enumerate() {
            if t.role != TaskRole::Requested {
                continue;
            }
            let _ = self.entries.push(PlanEntry {
                instance: t.id,
                def: i as u8,
                state: TaskState::Unscheduled,
                start: t.earliest_start,
                end: t.earliest_start,
                earliest_start: t.earliest_start,
                latest_start: t.latest_start,
                started: false,
                persistent: true,
                origin: Origin::Requested,
            });
        }
        self.dirty = true;
    }

    /// The plan's instances, in the order they were created.
    pub fn entries(&self) -> &[PlanEntry] {
        &self.entries
    }

    /// The timeline anchors (consolidated past and measurements).
    pub fn anchors(&self) -> &[TimelineAnchor] {
        &self.anchors
    }

    /// The failure ledger of every task definition, in network order.
    pub fn ledger(&self) -> &[FailureLedger] {
        &self.ledger
    }

    /// The failure ledger of task definition `def`.
    pub fn ledger_of(&self, def: u8) -> Option<&FailureLedger> {
        self.ledger.get(usize::from(def))
    }

    /// A view of the whole plan, for projections.
    pub fn view<'a>(&'a self, network: &'a TaskNetwork) -> PlanView<'a> {
        PlanView::new(network, &self.entries, &self.anchors)
    }

    /// Records a state-buffer value for the timeline it measures.
    pub fn on_measurement(&mut self, timeline: u8, value: i64, at: MissionTimeUs) {
        if let Some(a) = self.anchors.get_mut(usize::from(timeline)) {
            let newer = a.measured.is_none_or(|m| at >= m.at);
            if newer {
                if a.measured.is_none_or(|m| m.value != value) {
                    self.dirty = true;
                }
                a.measured = Some(Measurement { value, at });
            }
        }
    }

    /// Sets the measurement of `timeline` to `value` at `at`, replacing the one it holds even
    /// if that is newer: for the core's state table, which has already put its updates in
    /// order, and for a measurement that went stale (unknown from the step that found it so).
    /// A change of value makes the planner run a cycle, as any state change does.
    pub fn set_measurement(&mut self, timeline: u8, value: i64, at: MissionTimeUs) {
        if let Some(a) = self.anchors.get_mut(usize::from(timeline)) {
            if a.measured.is_none_or(|m| m.value != value) {
                self.dirty = true;
            }
            a.measured = Some(Measurement { value, at });
        }
    }

    /// Takes one message from the control loop (see [`crate::interface`]).
    pub fn receive(&mut self, message: ToPlanner) {
        match message {
            ToPlanner::Measured {
                timeline,
                value,
                at,
                replaces: true,
            } => self.set_measurement(timeline, value, at),
            ToPlanner::Measured {
                timeline,
                value,
                at,
                replaces: false,
            } => self.on_measurement(timeline, value, at),
            ToPlanner::Report(report) => self.on_report(report),
            ToPlanner::Returned { instance } => self.on_returned(instance),
        }
    }

    /// The executive had no room for committed `instance`: it is scheduled again, and the
    /// next step commits it again (when the planner's count says there is room).
    pub fn on_returned(&mut self, instance: u16) {
        if let Some(e) = self
            .entries
            .iter_mut()
            .find(|e| e.instance == instance && e.state == TaskState::Committed)
        {
            e.state = TaskState::Scheduled;
            self.stats.returned = self.stats.returned.saturating_add(1);
        }
    }

    /// Tasks the planner has committed that have not finished (committed or running): what it
    /// believes the executive holds.
    pub fn in_executive(&self) -> usize {
        self.entries
            .iter()
            .filter(|e| matches!(e.state, TaskState::Committed | TaskState::Running))
            .count()
    }

    /// Queues an execution report from the executive (processed at the next step, in order).
    pub fn on_report(&mut self, report: TaskReport) {
        if self.reports.push(report).is_err() {
            self.stats.dropped_reports = self.stats.dropped_reports.saturating_add(1);
        }
        self.dirty = true;
    }

    /// Whether a cycle is in progress (stopped on its budget).
    pub fn work_pending(&self) -> bool {
        self.phase != Phase::Idle || !self.reports.is_empty()
    }

    /// The earliest time the planner needs to run: now if work is pending, else the next
    /// commit or the next periodic cycle.
    pub fn next_wakeup(&self, network: &TaskNetwork, now: MissionTimeUs) -> Option<MissionTimeUs> {
        if self.work_pending() || self.dirty {
            return Some(now);
        }
        let config = network.config();
        let mut next: Option<MissionTimeUs> = None;
        let mut consider = |t: MissionTimeUs| next = Some(next.map_or(t, |n| n.min(t)));
        for e in &self.entries {
            match e.state {
                TaskState::Scheduled => {
                    let commit_at =
                        MissionTimeUs(e.start.0.saturating_sub(config.commit_window_us));
                    if commit_at > now {
                        consider(commit_at);
                    }
                }
                TaskState::Unscheduled if e.persistent => {
                    let window_at = MissionTimeUs(
                        e.earliest_start
                            .0
                            .saturating_sub(config.scheduling_window_us),
                    );
                    if window_at > now {
                        consider(window_at);
                    }
                }
                _ => {}
            }
        }
        // A repair held back by a back-off is tried again when the back-off ends.
        for l in &self.ledger {
            if l.gave_up == 0 && l.not_before > now {
                consider(l.not_before);
            }
        }
        if self.entries.iter().any(|e| !e.state.is_terminal()) {
            if let Some(last) = self.last_cycle_at {
                consider(
                    last.saturating_add(config.plan_process_interval_us)
                        .max(now),
                );
            }
        }
        next
    }

    /// Runs the planner up to `budget` validity checks: intake, then the cycle (resumed or
    /// started), then commits. Commits go to `commits`; decisions to `out` as telemetry.
    pub fn step(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        budget: u32,
        commits: &mut impl FnMut(Commit),
        out: &mut impl Outputs,
    ) -> PlannerStepReport {
        let ctx = Ctx { network, now };
        let start_checks = self.stats.validity_checks;
        self.intake(&ctx, out);
        self.expire(&ctx, out);
        let periodic = self
            .last_cycle_at
            .is_none_or(|l| now >= l.saturating_add(network.config().plan_process_interval_us));
        let backoff_ended = self.last_cycle_at.is_some_and(|last| {
            self.ledger
                .iter()
                .any(|l| l.gave_up == 0 && l.not_before > last && l.not_before <= now)
        });
        if self.phase == Phase::Idle && (self.dirty || periodic || backoff_ended) {
            self.phase = Phase::Consolidate;
            self.dirty = false;
            self.tried.clear();
            self.attempted.clear();
            self.placed_in_pass = false;
            self.passes = 0;
            self.stats.cycles = self.stats.cycles.saturating_add(1);
            self.scratch.cycle_started_at = Some(now);
        }
        let mut cycle_latency_us = None;
        let spent = |p: &Self| p.stats.validity_checks.wrapping_sub(start_checks);
        loop {
            match self.phase {
                Phase::Idle => break,
                Phase::Consolidate => {
                    consolidate(network, &mut self.entries, &mut self.anchors, now);
                    self.phase = Phase::Schedule;
                }
                Phase::Schedule => {
                    if spent(self) >= budget {
                        break;
                    }
                    match self.next_to_schedule(&ctx) {
                        Some(instance) => {
                            let _ = self.attempted.push(instance);
                            if self.schedule(&ctx, instance, false, out) {
                                self.placed_in_pass = true;
                            }
                        }
                        None => {
                            let retry = self.placed_in_pass
                                && self.passes + 1 < MAX_SCHEDULE_PASSES
                                && self
                                    .entries
                                    .iter()
                                    .any(|e| e.state == TaskState::Unscheduled && e.persistent);
                            if retry {
                                self.passes += 1;
                                self.attempted.clear();
                                self.placed_in_pass = false;
                            } else {
                                self.phase = Phase::Repair;
                            }
                        }
                    }
                }
                Phase::Repair => {
                    if spent(self) >= budget {
                        break;
                    }
                    let conflict = if self.tried.is_full() {
                        None
                    } else {
                        self.first_conflict(&ctx, true)
                    };
                    match conflict {
                        Some(c) => {
                            let _ = self.tried.push((c.instance, c.constraint));
                            self.repair(&ctx, c, out);
                        }
                        None => {
                            self.phase = Phase::Idle;
                            self.last_cycle_at = Some(now);
                            cycle_latency_us = Some(
                                self.scratch
                                    .cycle_started_at
                                    .take()
                                    .map_or(0, |started| now.0.saturating_sub(started.0)),
                            );
                        }
                    }
                }
            }
        }
        self.commit(&ctx, commits, out);
        PlannerStepReport {
            checks: spent(self),
            work_pending: self.phase != Phase::Idle,
            cycle_latency_us,
        }
    }

    fn emit_transition(
        out: &mut impl Outputs,
        instance: u16,
        from: TaskState,
        to: TaskState,
        at: MissionTimeUs,
    ) {
        out.telemetry(TelemetryEvent::TaskTransition {
            task: instance,
            from: from.code(),
            to: to.code(),
            at,
        });
    }

    fn emit_modification(
        out: &mut impl Outputs,
        kind: PlanModificationKind,
        instance: u16,
        template: u16,
        at: MissionTimeUs,
    ) {
        out.telemetry(TelemetryEvent::PlanModification {
            kind: kind as u8,
            task: instance,
            template,
            at,
        });
    }

    fn entry_index(&self, instance: u16) -> Option<usize> {
        self.entries.iter().position(|e| e.instance == instance)
    }

    fn new_instance_id(&mut self) -> u16 {
        let id = self.next_instance;
        self.next_instance = self
            .next_instance
            .checked_add(1)
            .unwrap_or(FIRST_INSTANCE_ID);
        id
    }

    /// Applies queued execution reports in arrival order, with contingencies.
    fn intake(&mut self, ctx: &Ctx<'_>, out: &mut impl Outputs) {
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
    fn expire(&mut self, ctx: &Ctx<'_>, out: &mut impl Outputs) {
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
    fn record_failure(
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
    fn may_add(
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
    fn count_instance(&mut self, def: u8) {
        if let Some(l) = self.ledger.get_mut(usize::from(def)) {
            l.instances = l.instances.saturating_add(1);
        }
    }

    fn add_entry(&mut self, entry: PlanEntry) -> bool {
        if self.entries.push(entry).is_err() {
            self.stats.plan_full = self.stats.plan_full.saturating_add(1);
            return false;
        }
        true
    }

    fn apply_contingency(
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

    /// The next unscheduled instance in the scheduling window: earliest start first, then
    /// higher priority, then lower instance id.
    fn next_to_schedule(&self, ctx: &Ctx<'_>) -> Option<u16> {
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
    fn end_for(
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
    /// temporal constraints with other requested tasks.
    fn start_window(
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
        let (lo, hi) = if entry.origin == Origin::Requested {
            let (tlo, thi) = temporal_window(ctx.network, &self.entries, entry)?;
            (lo.max(tlo), hi.min(thi))
        } else {
            (lo, hi)
        };
        (lo <= hi).then_some((lo, hi))
    }

    /// Places instance `instance` at its earliest valid start, adding permitted templates to
    /// enable it if need be. Returns whether it was placed.
    fn schedule(
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

    fn earliest_valid(&mut self, ctx: &Ctx<'_>, entry: &PlanEntry) -> Option<MissionTimeUs> {
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

    fn place(
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
    fn enable(
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
    fn placement_valid(&mut self, ctx: &Ctx<'_>, entry: &PlanEntry, start: MissionTimeUs) -> bool {
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
    fn fill_candidates(
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
    fn collect_candidates(
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
    fn sort_candidates(&mut self) {
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

    /// The first constraint that does not hold in the projected plan, scanning placed and
    /// executing instances by start time. With `skip_tried`, conflicts already worked on in
    /// this cycle are passed over.
    fn first_conflict(&mut self, ctx: &Ctx<'_>, skip_tried: bool) -> Option<Conflict> {
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
    fn repair(&mut self, ctx: &Ctx<'_>, conflict: Conflict, out: &mut impl Outputs) {
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
    fn permitted_templates(
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

    fn add_for_conflict(
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
    fn new_helper(
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
    fn place_helper(
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
    fn announce_added(
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
    fn make_room(
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

    /// Commits every scheduled instance starting within the commit window, earliest first.
    fn commit(&mut self, ctx: &Ctx<'_>, commits: &mut impl FnMut(Commit), out: &mut impl Outputs) {
        let mut in_executive = self.in_executive();
        let window_end = ctx
            .now
            .saturating_add(ctx.network.config().commit_window_us);
        loop {
            let next = self
                .entries
                .iter()
                .enumerate()
                .filter(|(_, e)| e.state == TaskState::Scheduled && e.start <= window_end)
                .min_by_key(|(_, e)| (e.start, e.instance))
                .map(|(i, _)| i);
            let Some(i) = next else {
                break;
            };
            let Some(e) = self.entries.get_mut(i) else {
                break;
            };
            let commit = Commit {
                instance: e.instance,
                def: e.def,
                start: e.start,
                end: e.end,
            };
            // The executive is full (by the planner's count): try again at the next step.
            if in_executive >= MAX_COMMITTED {
                break;
            }
            commits(commit);
            in_executive += 1;
            e.state = TaskState::Committed;
            Self::emit_transition(
                out,
                commit.instance,
                TaskState::Scheduled,
                TaskState::Committed,
                ctx.now,
            );
        }
    }

    /// The id the next instance the planner adds will get.
    pub(crate) fn next_instance_id(&self) -> u16 {
        self.next_instance
    }

    /// Scheduling passes done in the current cycle.
    pub(crate) fn schedule_passes(&self) -> u8 {
        self.passes
    }

    /// When the last cycle ended.
    pub(crate) fn last_cycle_at(&self) -> Option<MissionTimeUs> {
        self.last_cycle_at
    }

    /// Execution reports queued for the next step.
    pub(crate) fn queued_reports(&self) -> &[TaskReport] {
        &self.reports
    }

    /// (instance, constraint) conflicts already worked on in the current cycle.
    pub(crate) fn tried_conflicts(&self) -> &[(u16, u8)] {
        &self.tried
    }

    /// Restores the scratch buffers after a checkpoint restore (they are not saved).
    pub(crate) fn after_restore(&mut self) {
        self.scratch.candidates.clear();
        self.scratch.events.clear();
        self.scratch.cycle_started_at = None;
        self.dirty = true;
    }
}

/// Sorts `v` in increasing order (heapsort). The library's `sort_unstable` of `u64` is about
/// 8.7 KiB of code (its small-slice sorting networks), all of it in the RAM image that the
/// reset stub checks at every warm boot; this is a few hundred bytes, and the candidates are
/// sorted only when a search goes past the first few found by [`next_candidate`]. Sorted
/// values are the same whatever the algorithm.
fn heapsort(v: &mut [u64]) {
    fn sift_down(v: &mut [u64], mut root: usize, end: usize) {
        loop {
            let mut child = 2 * root + 1;
            if child >= end {
                return;
            }
            if child + 1 < end && v.get(child) < v.get(child + 1) {
                child += 1;
            }
            if v.get(root) >= v.get(child) {
                return;
            }
            v.swap(root, child);
            root = child;
        }
    }
    let n = v.len();
    for start in (0..n / 2).rev() {
        sift_down(v, start, n);
    }
    for end in (1..n).rev() {
        v.swap(0, end);
        sift_down(v, 0, end);
    }
}

/// The smallest candidate after `tried` (the first if None): taking these in turn gives the
/// candidates in the order [`Planner::sort_candidates`] leaves them.
fn next_candidate(candidates: &[u64], tried: Option<u64>) -> Option<u64> {
    candidates
        .iter()
        .copied()
        .filter(|&c| tried.is_none_or(|t| c > t))
        .min()
}

/// Instances whose constraints the planner still watches: placed and not finished.
fn is_live(e: &PlanEntry) -> bool {
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

/// Bounds on the start of requested instance `entry` implied by the temporal constraints and
/// the placed requested instances: shortest paths (Bellman-Ford) on the temporal constraint
/// graph whose nodes are a zero point and the start and end of each requested task. `None` when
/// the constraints cannot be met.
pub fn temporal_window(
    network: &TaskNetwork,
    entries: &[PlanEntry],
    entry: &PlanEntry,
) -> Option<(MissionTimeUs, MissionTimeUs)> {
    let me = network.task(entry.def)?.id;
    if !network
        .temporal()
        .iter()
        .any(|t| t.from_task == me || t.to_task == me)
    {
        return Some((MissionTimeUs::ZERO, MissionTimeUs::MAX));
    }
    const NODES: usize = 1 + 2 * MAX_TASKS;
    let node = |def: usize, point: TaskPoint| 1 + 2 * def + usize::from(point == TaskPoint::End);
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
            let (u, v) = (
                node(usize::from(a), tc.from_point),
                node(usize::from(b), tc.to_point),
            );
            f(u, v, tc.max_us);
            f(v, u, tc.min_us.saturating_neg());
        }
        for (d, t) in tasks.iter().enumerate() {
            if t.role != TaskRole::Requested {
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
fn template_impacting(
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
