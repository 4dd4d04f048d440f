//! The executive (seed 000 IV.A.4, seed 003 "controller"): one state machine per committed task.
//! Wait for the start time, then for the PRE constraints and the start condition (up to the
//! wait timeout: flexible execution's task push), dispatch the command, await its response (up
//! to the response timeout), monitor MAINTAIN constraints and the maintain condition, complete
//! after the duration once the POST assignments on measured timelines hold. A violated MAINTAIN
//! constraint aborts the task cleanly. Every transition is reported as telemetry and, as a
//! [`TaskReport`], to the planner.
//!
//! Automatic retries (seed 000 III.B) are bounded per instance and per cause (the task's
//! `max_retries`): a command rejected, failed, unanswered or completed with the wrong state is
//! dispatched again, the first time at once and then after a back-off that doubles in mission
//! time; past the bound the task fails with that cause. A commanded task that was running when
//! the last checkpoint was taken is never continued after a restore: the reset cut it short
//! ([`FailureKind::Interrupted`], or the MAINTAIN abort if a constraint no longer holds).
//!
//! The executive sees the spacecraft only through the state buffer ([`StateTable`]): constraints
//! on internal timelines (requests, claims) are the planner's business.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::capacity::*;
use crate::condition::{evaluate, measured_value, StateTable};
use crate::interface::{Commit, Outputs, ReportKind, TaskReport};
use crate::model::*;
use crate::telemetry::{FailureKind, TaskState};
use crate::timeline::shift;
use fsw_bridge::{CommandStatus, MissionTimeUs, TelemetryEvent};

/// One task owned by the executive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExecEntry {
    pub instance: u16,
    pub def: u8,
    pub state: TaskState,
    pub planned_start: MissionTimeUs,
    pub duration_us: u64,
    /// When the task started (dispatch, or no-op start).
    pub started_at: MissionTimeUs,
    /// `started_at + duration_us`.
    pub end_at: MissionTimeUs,
    pub command_id: u32,
    pub dispatched_at: MissionTimeUs,
    /// Retries granted to this instance, per cause (the one waiting for its back-off
    /// included).
    pub retries: PerCause,
    /// A retry (state WaitingPre after a failed attempt) waits until this time.
    pub retry_at: MissionTimeUs,
    /// Restored from a checkpoint in which its command was dispatched (Dispatched or Running):
    /// a reset came in between, so the next step ends it.
    pub interrupted: bool,
    /// [`Commit::served`]: whose command arguments [`InstanceArg::Served`] reads.
    pub served: u8,
    /// [`Commit::window`]: the start times its temporal constraints allow.
    pub window: Option<(MissionTimeUs, MissionTimeUs)>,
}

/// Counters for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ExecutiveStats {
    pub dispatches: u32,
    pub dropped_commits: u32,
    pub dropped_responses: u32,
    pub unmatched_responses: u32,
}

/// Executive state; all of it is saved in checkpoints.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Executive {
    entries: Vec<ExecEntry, MAX_COMMITTED>,
    responses: Vec<(u32, CommandStatus), MAX_PENDING_RESPONSES>,
    next_command_id: u32,
    pub stats: ExecutiveStats,
}

/// Decodes an executive as a checkpoint holds it (its `Serialize`) into the executive itself,
/// each list straight into its place ([`crate::in_place`]).
pub(crate) struct ExecutiveInPlace<'a>(pub &'a mut Executive);

impl<'de> serde::de::DeserializeSeed<'de> for ExecutiveInPlace<'_> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        // Four fields: entries, responses, next_command_id, stats.
        deserializer.deserialize_tuple(4, self)
    }
}

impl<'de> serde::de::Visitor<'de> for ExecutiveInPlace<'_> {
    type Value = ();

    fn expecting(&self, formatter: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        formatter.write_str("a saved executive")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        use crate::in_place::{field, field_into, VecInto};
        let e = self.0;
        field_into(&mut seq, VecInto(&mut e.entries), 0)?;
        field_into(&mut seq, VecInto(&mut e.responses), 1)?;
        e.next_command_id = field(&mut seq, 2)?;
        e.stats = field(&mut seq, 3)?;
        Ok(())
    }
}

/// Command ids skipped after a restore, so that a response to a command sent after the last
/// checkpoint cannot be taken for one sent after the restore.
pub const RESTORE_COMMAND_ID_GAP: u32 = 1 << 16;

impl Executive {
    pub const fn new() -> Self {
        Self {
            entries: Vec::new(),
            responses: Vec::new(),
            next_command_id: 1,
            stats: ExecutiveStats {
                dispatches: 0,
                dropped_commits: 0,
                dropped_responses: 0,
                unmatched_responses: 0,
            },
        }
    }

    /// Makes this executive what [`Executive::new`] is, in place (no constant image copied).
    pub fn reset(&mut self) {
        self.entries.clear();
        self.responses.clear();
        self.next_command_id = 1;
        self.stats = ExecutiveStats {
            dispatches: 0,
            dropped_commits: 0,
            dropped_responses: 0,
            unmatched_responses: 0,
        };
    }

    /// The tasks the executive owns, in commit order.
    pub fn entries(&self) -> &[ExecEntry] {
        &self.entries
    }

    /// Whether the executive can take another commit.
    pub fn has_room(&self) -> bool {
        !self.entries.is_full()
    }

    /// Takes ownership of a committed task. Returns false (and counts it) when full.
    pub fn accept(&mut self, commit: Commit) -> bool {
        let entry = ExecEntry {
            instance: commit.instance,
            def: commit.def,
            state: TaskState::Committed,
            planned_start: commit.start,
            duration_us: commit.end.0.saturating_sub(commit.start.0),
            started_at: commit.start,
            end_at: commit.end,
            command_id: 0,
            dispatched_at: MissionTimeUs::ZERO,
            retries: PerCause::ZERO,
            retry_at: MissionTimeUs::ZERO,
            interrupted: false,
            served: commit.served,
            window: commit.window,
        };
        if self.entries.push(entry).is_err() {
            self.stats.dropped_commits = self.stats.dropped_commits.saturating_add(1);
            return false;
        }
        true
    }

    /// Queues a command response; it is processed at the next step, in arrival order.
    pub fn on_command_response(&mut self, id: u32, status: CommandStatus) {
        if self.responses.push((id, status)).is_err() {
            self.stats.dropped_responses = self.stats.dropped_responses.saturating_add(1);
        }
    }

    /// After a restore: skip command ids (see [`RESTORE_COMMAND_ID_GAP`]) and mark every task
    /// whose command was out when the checkpoint was taken as interrupted. No-op tasks (no
    /// command, nothing running on a subsystem) carry on.
    pub(crate) fn after_restore(&mut self) {
        self.next_command_id = self
            .next_command_id
            .wrapping_add(RESTORE_COMMAND_ID_GAP)
            .max(1);
        for e in &mut self.entries {
            if matches!(e.state, TaskState::Dispatched | TaskState::Running) && e.command_id != 0 {
                e.interrupted = true;
            }
        }
    }

    /// The id the next command dispatched will get (never 0).
    pub(crate) fn next_command_id(&self) -> u32 {
        self.next_command_id
    }

    /// Whether responses are waiting to be processed.
    pub fn work_pending(&self) -> bool {
        !self.responses.is_empty()
    }

    /// The earliest time a task needs attention (start, wait or response timeout, end, the
    /// start of MAINTAIN monitoring).
    pub fn next_wakeup(&self, network: &TaskNetwork, now: MissionTimeUs) -> Option<MissionTimeUs> {
        let mut next: Option<MissionTimeUs> = None;
        // Anything due at or before `now` was handled by the last step; what remains due then
        // waits for input (a state update, a response), which brings its own step.
        let mut consider = |t: MissionTimeUs| {
            if t > now {
                next = Some(next.map_or(t, |n| n.min(t)));
            }
        };
        for e in &self.entries {
            let Some(spec) = network.task(e.def) else {
                continue;
            };
            match e.state {
                TaskState::Committed => consider(e.planned_start),
                TaskState::WaitingPre => {
                    consider(e.retry_at);
                    if let Some((not_before, not_after)) = e.window {
                        consider(not_before);
                        consider(not_after.saturating_add(1));
                    }
                    consider(wait_from(e).saturating_add(spec.control.pre_wait_timeout_us));
                }
                TaskState::Dispatched | TaskState::Running => {
                    if e.state == TaskState::Dispatched {
                        consider(
                            e.dispatched_at
                                .saturating_add(spec.control.response_timeout_us),
                        );
                    }
                    consider(e.end_at);
                    for c in spec
                        .constraints
                        .iter()
                        .filter(|c| c.when == ConstraintWhen::Maintain)
                    {
                        let from = shift(e.started_at, c.start_offset_us);
                        consider(from);
                    }
                }
                _ => {}
            }
        }
        next
    }

    /// Runs every task state machine once at `now`. Reports go to `report` (for the planner).
    pub fn step(
        &mut self,
        network: &TaskNetwork,
        states: &StateTable,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        report: &mut impl FnMut(TaskReport),
    ) {
        // Responses, in arrival order. One to a command sent before a reset does not count:
        // the task it was for is interrupted.
        let responses = core::mem::take(&mut self.responses);
        for &(id, status) in &responses {
            let Some(i) = self.entries.iter().position(|e| {
                e.command_id == id && e.state == TaskState::Dispatched && !e.interrupted
            }) else {
                self.stats.unmatched_responses = self.stats.unmatched_responses.saturating_add(1);
                continue;
            };
            match status {
                CommandStatus::Ok => self.transition(i, TaskState::Running, now, out),
                CommandStatus::Failed(_) => self.command_failed(
                    network,
                    states,
                    i,
                    FailureKind::CommandFailed,
                    now,
                    out,
                    report,
                ),
                CommandStatus::Rejected => self.command_failed(
                    network,
                    states,
                    i,
                    FailureKind::CommandRejected,
                    now,
                    out,
                    report,
                ),
            }
        }
        // Tasks, by planned start then instance id.
        let mut order: Vec<(MissionTimeUs, u16), MAX_COMMITTED> = Vec::new();
        for e in &self.entries {
            let _ = order.push((e.planned_start, e.instance));
        }
        // Not the library's sort, whose code the warm boot would check (`small_sort`).
        crate::small_sort::sort(&mut order);
        for &(_, instance) in &order {
            let Some(i) = self.entries.iter().position(|e| e.instance == instance) else {
                continue;
            };
            self.advance(network, states, i, now, out, report);
        }
        self.entries.retain(|e| !e.state.is_terminal());
    }

    fn entry(&self, i: usize) -> Option<ExecEntry> {
        self.entries.get(i).copied()
    }

    fn transition(&mut self, i: usize, to: TaskState, now: MissionTimeUs, out: &mut impl Outputs) {
        if let Some(e) = self.entries.get_mut(i) {
            let from = e.state;
            e.state = to;
            out.telemetry(TelemetryEvent::TaskTransition {
                task: e.instance,
                from: from.code(),
                to: to.code(),
                at: now,
            });
        }
    }

    fn advance(
        &mut self,
        network: &TaskNetwork,
        states: &StateTable,
        i: usize,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        report: &mut impl FnMut(TaskReport),
    ) {
        let Some(e) = self.entry(i) else {
            return;
        };
        let Some(spec) = network.task(e.def) else {
            return;
        };
        match e.state {
            TaskState::Committed | TaskState::WaitingPre => {
                if now < e.planned_start || now < e.retry_at {
                    return;
                }
                if let Some((window_start, not_after)) = e.window {
                    let (unreached, not_before) = self.temporal_hold(network, &e, now);
                    let not_before = not_before.max(window_start);
                    if let Some(x) = self.entries.get_mut(i) {
                        x.window = Some((not_before, not_after));
                    }
                    if now > not_after {
                        // Its temporal window closed while it waited (a push, a retry).
                        let started = e.command_id != 0;
                        let kind = FailureKind::PreTimeout;
                        self.fail(network, i, kind, started, now, out, report);
                        return;
                    }
                    if now < not_before || unreached {
                        // Not yet in its window, or a task it must follow has not reached the
                        // point it follows (it ran late): wait, up to the window's end.
                        if e.state == TaskState::Committed {
                            self.transition(i, TaskState::WaitingPre, now, out);
                        }
                        return;
                    }
                }
                if e.state == TaskState::Committed {
                    let skip = spec
                        .control
                        .skip_condition
                        .and_then(|c| network.condition(c))
                        .is_some_and(|c| evaluate(network, c, states));
                    if skip {
                        self.transition(i, TaskState::Skipped, now, out);
                        report(TaskReport {
                            instance: e.instance,
                            kind: ReportKind::Skipped,
                            at: now,
                        });
                        return;
                    }
                }
                if pre_conditions_hold(network, spec, states) {
                    self.start(network, i, now, out, report);
                } else if now >= wait_from(&e).saturating_add(spec.control.pre_wait_timeout_us) {
                    // A retry that times out waiting had started (its first attempt did).
                    let started = e.command_id != 0;
                    self.fail(
                        network,
                        i,
                        FailureKind::PreTimeout,
                        started,
                        now,
                        out,
                        report,
                    );
                } else if e.state == TaskState::Committed {
                    self.transition(i, TaskState::WaitingPre, now, out);
                }
            }
            TaskState::Dispatched | TaskState::Running => {
                if e.interrupted {
                    // Restored with its command out: the reset cut it short. A MAINTAIN
                    // constraint that no longer holds is the clean abort of seed 003; otherwise
                    // it is reported interrupted, never completed.
                    let kind = if maintain_conditions_hold(network, spec, states, &e, now) {
                        FailureKind::Interrupted
                    } else {
                        FailureKind::MaintainViolation
                    };
                    self.fail(network, i, kind, true, now, out, report);
                    return;
                }
                if e.state == TaskState::Running && now >= e.end_at {
                    if spec.command.is_some() && !post_conditions_hold(network, spec, states) {
                        self.command_failed(
                            network,
                            states,
                            i,
                            FailureKind::PostConditionNotMet,
                            now,
                            out,
                            report,
                        );
                        return;
                    }
                    self.transition(i, TaskState::Completed, now, out);
                    report(TaskReport {
                        instance: e.instance,
                        kind: ReportKind::Completed,
                        at: now,
                    });
                    return;
                }
                if !maintain_conditions_hold(network, spec, states, &e, now) {
                    self.fail(
                        network,
                        i,
                        FailureKind::MaintainViolation,
                        true,
                        now,
                        out,
                        report,
                    );
                    return;
                }
                if e.state == TaskState::Dispatched
                    && now
                        >= e.dispatched_at
                            .saturating_add(spec.control.response_timeout_us)
                {
                    self.command_failed(
                        network,
                        states,
                        i,
                        FailureKind::ResponseTimeout,
                        now,
                        out,
                        report,
                    );
                }
            }
            _ => {}
        }
    }

    /// What the temporal constraints that make `e` start after a point (start or end) of a
    /// requested task this executive holds say now: whether one of those points is not
    /// reached yet (the task ran late: wait), and the earliest start the reached ones allow
    /// (the start as dispatched, or now for an end reached in this step). A task no longer
    /// held finished before this step; the planner's window at the commit covers it.
    fn temporal_hold(
        &self,
        network: &TaskNetwork,
        e: &ExecEntry,
        now: MissionTimeUs,
    ) -> (bool, MissionTimeUs) {
        let mut unreached = false;
        let mut not_before = MissionTimeUs::ZERO;
        let Some(me) = network.task(e.def).map(|t| t.id) else {
            return (unreached, not_before);
        };
        for tc in network.temporal() {
            // (the task followed, its point, the least delay after it).
            let follows = if tc.to_task == me && tc.to_point == TaskPoint::Start {
                (tc.min_us >= 0).then_some((tc.from_task, tc.from_point, tc.min_us))
            } else if tc.from_task == me && tc.from_point == TaskPoint::Start {
                (tc.max_us <= 0).then_some((tc.to_task, tc.to_point, tc.max_us.saturating_neg()))
            } else {
                None
            };
            let Some((id, point, delay)) = follows else {
                continue;
            };
            let Some(x) = self.entries.iter().find(|x| x.instance == id) else {
                continue;
            };
            let reached_at = match point {
                TaskPoint::Start => {
                    (!matches!(x.state, TaskState::Committed | TaskState::WaitingPre))
                        .then_some(x.started_at)
                }
                TaskPoint::End => x.state.is_terminal().then_some(now),
            };
            match reached_at {
                Some(at) => not_before = not_before.max(shift(at, delay)),
                None => unreached = true,
            }
        }
        (unreached, not_before)
    }

    /// The arguments of `command` dispatched for `e` at `now`: its fixed ones, then those it
    /// takes from the instance ([`InstanceArg`]).
    fn command_args(
        &self,
        network: &TaskNetwork,
        command: &CommandSpec,
        e: &ExecEntry,
        now: MissionTimeUs,
    ) -> fsw_bridge::CommandArgs {
        let mut args = command.args.clone();
        let seconds = |us: u64| i32::try_from(us / 1_000_000).unwrap_or(i32::MAX);
        for a in &command.from_instance {
            let value = match *a {
                InstanceArg::Instance => i32::from(e.instance),
                InstanceArg::EndS => seconds(now.0.saturating_add(e.duration_us)),
                InstanceArg::DurationS => seconds(e.duration_us),
                InstanceArg::Served(k) => network
                    .task(e.served)
                    .and_then(|t| t.command.as_ref())
                    .and_then(|c| c.args.get(usize::from(k)).copied())
                    .unwrap_or(-1),
            };
            // Validation keeps fixed and instance arguments within one command.
            let _ = args.push(value);
        }
        args
    }

    /// Dispatches the command (or starts a no-op task).
    fn start(
        &mut self,
        network: &TaskNetwork,
        i: usize,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        report: &mut impl FnMut(TaskReport),
    ) {
        let Some(e) = self.entry(i) else {
            return;
        };
        let Some(spec) = network.task(e.def) else {
            return;
        };
        let first_start = !matches!(e.state, TaskState::WaitingPre) || e.command_id == 0;
        let command_id = match &spec.command {
            Some(command) => {
                let id = self.next_command_id;
                self.next_command_id = self.next_command_id.wrapping_add(1).max(1);
                self.stats.dispatches = self.stats.dispatches.saturating_add(1);
                let args = self.command_args(network, command, &e, now);
                out.dispatch(id, command.opcode, &args);
                id
            }
            None => 0,
        };
        if let Some(x) = self.entries.get_mut(i) {
            x.command_id = command_id;
            x.dispatched_at = now;
            x.started_at = now;
            x.end_at = now.saturating_add(x.duration_us);
        }
        let to = if spec.command.is_some() {
            TaskState::Dispatched
        } else {
            TaskState::Running
        };
        self.transition(i, to, now, out);
        if first_start {
            report(TaskReport {
                instance: e.instance,
                kind: ReportKind::Started,
                at: now,
            });
        }
    }

    /// An attempt went wrong with `kind`: retry (after the back-off) while the task's bound for
    /// `kind` allows, else fail the task with `kind`.
    #[allow(clippy::too_many_arguments)]
    fn command_failed(
        &mut self,
        network: &TaskNetwork,
        states: &StateTable,
        i: usize,
        kind: FailureKind,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        report: &mut impl FnMut(TaskReport),
    ) {
        let Some(e) = self.entry(i) else {
            return;
        };
        let retryable = FailureKind::RETRYABLE & kind.bit() != 0;
        let bound = network.max_retries(e.def).get(kind);
        if retryable && e.retries.get(kind) < bound {
            let delay = {
                let Some(x) = self.entries.get_mut(i) else {
                    return;
                };
                x.retries.bump(kind);
                let delay = network.backoff(e.def).delay_us(x.retries.total());
                x.retry_at = now.saturating_add(delay);
                delay
            };
            self.transition(i, TaskState::WaitingPre, now, out);
            let pre_ok = network
                .task(e.def)
                .is_some_and(|spec| pre_conditions_hold(network, spec, states));
            if delay == 0 && pre_ok {
                self.start(network, i, now, out, report);
            }
            return;
        }
        self.fail(network, i, kind, true, now, out, report);
    }

    #[allow(clippy::too_many_arguments)]
    fn fail(
        &mut self,
        network: &TaskNetwork,
        i: usize,
        kind: FailureKind,
        started: bool,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        report: &mut impl FnMut(TaskReport),
    ) {
        let Some(e) = self.entry(i) else {
            return;
        };
        self.transition(i, TaskState::Failed(kind), now, out);
        if let Some(command) = network
            .task(e.def)
            .and_then(|s| s.control.on_failure_command.as_ref())
        {
            let id = self.next_command_id;
            self.next_command_id = self.next_command_id.wrapping_add(1).max(1);
            let args = self.command_args(network, command, &e, now);
            out.dispatch(id, command.opcode, &args);
        }
        report(TaskReport {
            instance: e.instance,
            kind: ReportKind::Failed { kind, started },
            at: now,
        });
    }
}

/// When a task in WaitingPre started waiting: its planned start, or the end of the back-off of
/// the retry it waits to make. The wait timeout counts from there.
fn wait_from(e: &ExecEntry) -> MissionTimeUs {
    e.planned_start.max(e.retry_at)
}

/// Whether every POST assignment of `spec` on a measured timeline holds in the state buffer:
/// the state the command was to bring about is there.
fn post_conditions_hold(network: &TaskNetwork, spec: &TaskSpec, states: &StateTable) -> bool {
    spec.impacts
        .iter()
        .filter(|i| i.when == ImpactWhen::Post)
        .all(
            |i| match (i.effect, measured_value(network, i.timeline, states)) {
                (Effect::Assign(v), Some(measured)) => measured == v,
                _ => true, // not an assignment, or an internal timeline: the planner's business
            },
        )
}

/// PRE constraints on measured timelines, and the start condition.
fn pre_conditions_hold(network: &TaskNetwork, spec: &TaskSpec, states: &StateTable) -> bool {
    let constraints_ok = spec
        .constraints
        .iter()
        .filter(|c| c.when == ConstraintWhen::Pre)
        .all(|c| match measured_value(network, c.timeline, states) {
            Some(v) => c.require.accepts(v),
            None => true, // internal timeline: the planner's business
        });
    let condition_ok = spec
        .control
        .start_condition
        .and_then(|c| network.condition(c))
        .is_none_or(|c| evaluate(network, c, states));
    constraints_ok && condition_ok
}

/// MAINTAIN constraints on measured timelines that cover `now`, and the maintain condition.
fn maintain_conditions_hold(
    network: &TaskNetwork,
    spec: &TaskSpec,
    states: &StateTable,
    e: &ExecEntry,
    now: MissionTimeUs,
) -> bool {
    let constraints_ok = spec
        .constraints
        .iter()
        .filter(|c| c.when == ConstraintWhen::Maintain)
        .filter(|c| {
            // A task still waiting for its response after its nominal end has not ended: its
            // MAINTAIN constraints stay monitored until it completes.
            let still_running = e.state == TaskState::Dispatched;
            now >= shift(e.started_at, c.start_offset_us)
                && (still_running || now < shift(e.end_at, c.end_offset_us))
        })
        .all(|c| match measured_value(network, c.timeline, states) {
            Some(v) => c.require.accepts(v),
            None => true,
        });
    let condition_ok = spec
        .control
        .maintain_condition
        .and_then(|c| network.condition(c))
        .is_none_or(|c| evaluate(network, c, states));
    constraints_ok && condition_ok
}
