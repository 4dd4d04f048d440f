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

mod intake;
mod repair;
mod schedule;
mod validity;

use validity::{is_live, template_impacting};
pub use validity::{placement_valid, placement_valid_with_events, temporal_window};

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
    /// Each entry's first and last impact event, for one consolidation.
    spans: crate::timeline::Spans,
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

/// When the planner's cycle stops for this step: asked before each scheduling or repair job
/// (a job that starts finishes) with the validity checks spent in the step so far.
pub trait Budget {
    fn exhausted(&mut self, checks_spent: u32) -> bool;
}

/// A number of validity checks.
impl Budget for u32 {
    fn exhausted(&mut self, checks_spent: u32) -> bool {
        checks_spent >= *self
    }
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
                spans: Vec::new(),
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

    /// Runs the planner until `budget` is exhausted (a number of validity checks, or see
    /// [`Budget`]): intake, then the cycle (resumed or started), then commits. Commits go to
    /// `commits`; decisions to `out` as telemetry.
    pub fn step(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        mut budget: impl Budget,
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
                    if !network.params().is_empty() {
                        self.refresh_durations(network);
                    }
                    consolidate(
                        network,
                        &mut self.entries,
                        &mut self.anchors,
                        now,
                        &mut self.scratch.spans,
                    );
                    self.phase = Phase::Schedule;
                }
                Phase::Schedule => {
                    if budget.exhausted(spent(self)) {
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
                    if budget.exhausted(spent(self)) {
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

    /// The id for an instance being added: [`Planner::next_instance_id`], which no plan entry
    /// has (a helper about to be added takes it beforehand). The counter then moves on to the
    /// next id no entry has, so an id stays its instance's own after the counter wraps (the
    /// executive's reports and the commands find their instance by it).
    fn new_instance_id(&mut self) -> u16 {
        let id = self.next_instance;
        // The plan holds fewer entries than there are planner-given ids, so one of the next
        // MAX_PLAN_ENTRIES + 1 is free.
        for _ in 0..=MAX_PLAN_ENTRIES {
            self.next_instance = self
                .next_instance
                .checked_add(1)
                .unwrap_or(FIRST_INSTANCE_ID);
            let next = self.next_instance;
            if !self.entries.iter().any(|e| e.instance == next) {
                break;
            }
        }
        id
    }
}

impl Planner {
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
            let Some(&planned) = self.entries.get(i) else {
                break;
            };
            let commit = Commit {
                instance: planned.instance,
                def: planned.def,
                start: planned.start,
                end: planned.end,
                served: self.served_def(&planned),
                window: self.dispatch_window(ctx.network, &planned),
            };
            let Some(e) = self.entries.get_mut(i) else {
                break;
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

    /// Scheduled (uncommitted) instances take their definitions' durations as the model
    /// parameters now say (a measurement changed one): the next plan uses the new values, and
    /// a placement the change made invalid is a conflict the repair phase handles.
    fn refresh_durations(&mut self, network: &TaskNetwork) {
        for i in 0..self.entries.len() {
            let Some(e) = self.entries.get(i).copied() else {
                continue;
            };
            if e.state != TaskState::Scheduled {
                continue;
            }
            if let Some(end) = Self::end_for(network, &e, e.start) {
                if let Some(x) = self.entries.get_mut(i) {
                    x.end = end;
                }
            }
        }
    }

    /// The definition of the task `entry` serves (see [`Commit::served`]).
    fn served_def(&self, entry: &PlanEntry) -> u8 {
        let of = match entry.origin {
            Origin::Requested => return crate::interface::NO_SERVED,
            Origin::Added { for_instance } => for_instance,
            // The failed instance was of the same definition (and may have left the plan).
            Origin::Restarted { .. } => return entry.def,
        };
        self.entries
            .iter()
            .find(|e| e.instance == of)
            .map_or(crate::interface::NO_SERVED, |e| e.def)
    }

    /// The start times the temporal constraints allow `entry` now (see [`Commit::window`]):
    /// for a requested instance or a template's instance whose definition a constraint
    /// names; `None` for the others (and when the constraints cannot be met: the planner
    /// placed it, so it is not held back).
    fn dispatch_window(
        &self,
        network: &TaskNetwork,
        entry: &PlanEntry,
    ) -> Option<(MissionTimeUs, MissionTimeUs)> {
        if network.temporal().is_empty() {
            return None;
        }
        let spec = network.task(entry.def)?;
        let bound = entry.origin == Origin::Requested || spec.role == TaskRole::Template;
        let named = network
            .temporal()
            .iter()
            .any(|t| t.from_task == spec.id || t.to_task == spec.id);
        if !bound || !named {
            return None;
        }
        temporal_window(network, &self.entries, entry)
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
