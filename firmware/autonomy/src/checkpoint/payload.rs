//! The validation of a restored checkpoint's contents: a whole record's payload, decoded, is
//! checked like an uplink before the core runs on it, and refused with a [`PayloadError`] naming
//! the defect and where it is.

use crate::capacity::*;
use crate::condition::StateTable;
use crate::executive::Executive;
use crate::model::{TaskNetwork, TaskRole, TimelineKind, VALUE_UNKNOWN};
use crate::plan::Origin;
use crate::planner::{Planner, MAX_SCHEDULE_PASSES};
use crate::telemetry::{FailureKind, TaskState};
use crate::uplink::ValidationError;
use fsw_bridge::MissionTimeUs;

/// Latest finite mission time a checkpoint may hold. The core takes no input time later than
/// [`MAX_MISSION_TIME_US`] (later grants are clamped to it, later state updates ignored), and
/// what it computes from one adds at most a plan horizon (itself at most
/// [`MAX_MISSION_TIME_US`]) and durations, offsets and back-offs of at most
/// [`MAX_DURATION_US`] each: every time it stores stays below this. [`MissionTimeUs::MAX`]
/// is "never", where a time may be unbounded.
pub const MAX_RESTORED_TIME_US: u64 = 4 * MAX_MISSION_TIME_US;

/// Why a whole record's payload was refused: what is wrong, and where.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PayloadError {
    pub defect: PayloadDefect,
    pub site: PayloadSite,
}

impl PayloadError {
    pub const fn new(defect: PayloadDefect, site: PayloadSite) -> Self {
        Self { defect, site }
    }
}

/// What is wrong with a restored payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PayloadDefect {
    /// The bytes do not decode (a bad varint or tag, a list over its capacity, the payload
    /// ends inside a part).
    Decode,
    /// Bytes remain after the last part.
    TrailingBytes,
    /// The task network inside fails the uplink validation.
    InvalidNetwork(ValidationError),
    /// A list whose length is fixed by the network has another one (timeline anchors, one per
    /// timeline; failure ledgers, one per task definition).
    CountMismatch,
    /// A plan or executive entry names a task definition the network does not have.
    DanglingDefinition,
    /// An entry names a definition that cannot be its own: a requested instance whose
    /// definition is a template or has another ground id, a second requested instance of one
    /// definition, an added instance of a definition that is not a template.
    WrongDefinition,
    /// An executive entry that is not a committed or running instance of the plan with the
    /// same definition.
    NotInPlan,
    /// An index that does not exist (a constraint of a task).
    IndexOutOfRange,
    /// An instance or command id from the wrong range: a planner-given instance id below
    /// [`FIRST_INSTANCE_ID`], a command id of 0 for the next command.
    IdOutOfRange,
    /// A time after [`MAX_RESTORED_TIME_US`] that is not "never", or a task that does not end
    /// within its definition's duration of its start.
    TimeOutOfRange,
    /// A life-cycle state the core never puts there: an executive state in the plan, a
    /// finished task in the executive, a started flag on an instance that never started, a
    /// dispatched task without a command or command id, an interrupted task that was not
    /// dispatched, a plan without a loaded network, a cause given up on that is never counted.
    ImpossibleState,
    /// A count over its bound: scheduling passes, the retries of an instance over its
    /// definition's `max_retries`, consecutive failures of a cause the planner does not count.
    CountOutOfRange,
    /// A timeline value its timeline cannot hold: a state timeline outside its values, a rate
    /// on a timeline that is not cumulative.
    ValueOutOfRange,
    /// Two state-buffer entries with the same key.
    DuplicateKey,
    /// Two plan entries with the same instance id, or the id the planner gives next already
    /// in the plan (the planner gives each instance its own; reports and commands find their
    /// instance by it).
    DuplicateInstance,
}

/// Where in a restored payload a defect is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PayloadSite {
    /// The header part (loaded flag, mission time, state type mismatch count).
    Meta,
    /// The task network, or the length before it.
    Network,
    /// The planner as a whole (its cursor, counters and the lists below).
    Planner,
    /// Plan entry `i`.
    PlanEntry(u16),
    /// The anchor of timeline `i`.
    Anchor(u16),
    /// The failure ledger of task definition `i`.
    Ledger(u16),
    /// Queued execution report `i`.
    Report(u16),
    /// Conflict `i` already tried in the current planner cycle.
    Tried(u16),
    /// The executive as a whole.
    Executive,
    /// Executive entry `i`.
    ExecEntry(u16),
    /// The state buffer copy as a whole.
    States,
    /// State-buffer entry `i`.
    StateEntry(u16),
    /// After the last part.
    End,
}

/// Everything a checkpoint payload restores, decoded and not yet trusted.
pub(crate) struct RestoredState<'a> {
    pub loaded: bool,
    pub now: MissionTimeUs,
    pub network: &'a TaskNetwork,
    pub planner: &'a Planner,
    pub executive: &'a Executive,
    pub states: &'a StateTable,
}

/// A list index as a [`PayloadSite`] names it (every list's capacity is below `u16::MAX`).
fn index(i: usize) -> u16 {
    u16::try_from(i).unwrap_or(u16::MAX)
}

fn time_ok(t: MissionTimeUs) -> bool {
    t.0 <= MAX_RESTORED_TIME_US || t == MissionTimeUs::MAX
}

fn check(ok: bool, defect: PayloadDefect, site: PayloadSite) -> Result<(), PayloadError> {
    if ok {
        Ok(())
    } else {
        Err(PayloadError::new(defect, site))
    }
}

/// Checks a decoded checkpoint the way an uplink is checked: every index refers to something
/// that exists, every time is in range, every state and count is one the core can reach, and
/// the plan, the executive and the network belong together. The network itself was validated
/// as it was decoded. Only true invariants of the core are checked: a checkpoint the core
/// wrote, whatever its inputs were, always passes (the fuzz targets check that).
pub(crate) fn check_restored(s: &RestoredState<'_>) -> Result<(), PayloadError> {
    check_planner_restored(s.loaded, s.now, s.network, s.planner)?;
    check_executive_restored(s.loaded, s.now, s.network, s.executive, s.states)?;
    // Every task the executive holds is one the planner committed.
    for (i, e) in s.executive.entries().iter().enumerate() {
        let in_plan = s.planner.entries().iter().any(|p| {
            p.instance == e.instance
                && p.def == e.def
                && matches!(p.state, TaskState::Committed | TaskState::Running)
        });
        check(
            in_plan,
            PayloadDefect::NotInPlan,
            PayloadSite::ExecEntry(index(i)),
        )?;
    }
    Ok(())
}

/// The planner's half of [`check_restored`]: what a planner partition's checkpoint holds.
pub(crate) fn check_planner_restored(
    loaded: bool,
    now: MissionTimeUs,
    network: &TaskNetwork,
    planner: &Planner,
) -> Result<(), PayloadError> {
    use PayloadDefect::*;
    use PayloadSite as At;
    let tasks = network.tasks();
    check(time_ok(now), TimeOutOfRange, At::Meta)?;
    let empty_network = tasks.is_empty() && network.timelines().is_empty();
    check(
        loaded || (empty_network && planner.entries().is_empty()),
        ImpossibleState,
        At::Meta,
    )?;

    // The planner's own cursor and counters.
    check(
        planner.next_instance_id() >= FIRST_INSTANCE_ID,
        IdOutOfRange,
        At::Planner,
    )?;
    // The id the next added instance gets is one no instance has.
    let next_in_use = planner
        .entries()
        .iter()
        .any(|e| e.instance == planner.next_instance_id());
    check(!next_in_use, DuplicateInstance, At::Planner)?;
    check(
        planner.schedule_passes() < MAX_SCHEDULE_PASSES,
        CountOutOfRange,
        At::Planner,
    )?;
    check(
        planner.last_cycle_at().is_none_or(time_ok),
        TimeOutOfRange,
        At::Planner,
    )?;
    check(
        planner.anchors().len() == network.timelines().len(),
        CountMismatch,
        At::Planner,
    )?;
    check(
        planner.ledger().len() == tasks.len(),
        CountMismatch,
        At::Planner,
    )?;

    for (i, e) in planner.entries().iter().enumerate() {
        let at = At::PlanEntry(index(i));
        let spec = network
            .task(e.def)
            .ok_or(PayloadError::new(DanglingDefinition, at))?;
        match e.origin {
            Origin::Requested => {
                check(
                    spec.role == TaskRole::Requested && e.instance == spec.id,
                    WrongDefinition,
                    at,
                )?;
                let requested_before = planner
                    .entries()
                    .iter()
                    .take(i)
                    .any(|x| x.origin == Origin::Requested && x.def == e.def);
                check(!requested_before, WrongDefinition, at)?;
            }
            Origin::Added { .. } => {
                check(spec.role == TaskRole::Template, WrongDefinition, at)?;
                check(e.instance >= FIRST_INSTANCE_ID, IdOutOfRange, at)?;
            }
            Origin::Restarted { .. } => check(e.instance >= FIRST_INSTANCE_ID, IdOutOfRange, at)?,
        }
        let times = [e.start, e.end, e.earliest_start, e.latest_start];
        check(times.into_iter().all(time_ok), TimeOutOfRange, at)?;
        // Until it ends, an instance spans at most its definition's duration (a start report
        // keeps the span, so a longer one would push its end out of range).
        let span_ok = e.state.is_terminal()
            || (e.start <= e.end && e.end.0 - e.start.0 <= network.max_duration_us(e.def));
        check(span_ok, TimeOutOfRange, at)?;
        let executive_state = matches!(e.state, TaskState::WaitingPre | TaskState::Dispatched);
        let unstarted = matches!(
            e.state,
            TaskState::Unscheduled | TaskState::Scheduled | TaskState::Committed
        );
        let started_unstarted = e.started && unstarted;
        check(!executive_state && !started_unstarted, ImpossibleState, at)?;
        let seen_before = planner
            .entries()
            .iter()
            .take(i)
            .any(|x| x.instance == e.instance);
        check(!seen_before, DuplicateInstance, at)?;
    }

    for (i, a) in planner.anchors().iter().enumerate() {
        let at = At::Anchor(index(i));
        let times_ok = time_ok(a.at) && a.measured.is_none_or(|m| time_ok(m.at));
        check(times_ok, TimeOutOfRange, at)?;
        let spec = network
            .timelines()
            .get(i)
            .ok_or(PayloadError::new(CountMismatch, at))?;
        match spec.kind {
            TimelineKind::State { value_count, .. } => {
                let fits = |v: i64| v == VALUE_UNKNOWN || (0..i64::from(value_count)).contains(&v);
                let values_ok = fits(a.value) && a.measured.is_none_or(|m| fits(m.value));
                check(values_ok && a.rate == 0, ValueOutOfRange, at)?;
            }
            TimelineKind::Claimable => check(a.rate == 0, ValueOutOfRange, at)?,
            TimelineKind::Cumulative { .. } => {}
        }
    }

    for (i, l) in planner.ledger().iter().enumerate() {
        let at = At::Ledger(index(i));
        check(time_ok(l.not_before), TimeOutOfRange, at)?;
        check(
            l.gave_up & !FailureKind::REPAIRABLE == 0,
            ImpossibleState,
            at,
        )?;
        check(
            l.consecutive.nonzero_causes() & !FailureKind::REPAIRABLE == 0,
            CountOutOfRange,
            at,
        )?;
    }

    for (i, r) in planner.queued_reports().iter().enumerate() {
        check(time_ok(r.at), TimeOutOfRange, At::Report(index(i)))?;
    }
    for (i, &(_, constraint)) in planner.tried_conflicts().iter().enumerate() {
        check(
            usize::from(constraint) < MAX_CONSTRAINTS_PER_TASK,
            IndexOutOfRange,
            At::Tried(index(i)),
        )?;
    }

    Ok(())
}

/// The executive's half of [`check_restored`]: what an executive partition's checkpoint holds
/// (its tasks are checked against the network; against the plan only where both are in one
/// checkpoint).
pub(crate) fn check_executive_restored(
    loaded: bool,
    now: MissionTimeUs,
    network: &TaskNetwork,
    executive: &Executive,
    states: &StateTable,
) -> Result<(), PayloadError> {
    use PayloadDefect::*;
    use PayloadSite as At;
    check(time_ok(now), TimeOutOfRange, At::Meta)?;
    let empty_network = network.tasks().is_empty() && network.timelines().is_empty();
    check(
        loaded || (empty_network && executive.entries().is_empty()),
        ImpossibleState,
        At::Meta,
    )?;
    check(
        executive.next_command_id() != 0,
        IdOutOfRange,
        At::Executive,
    )?;
    for (i, e) in executive.entries().iter().enumerate() {
        let at = At::ExecEntry(index(i));
        let spec = network
            .task(e.def)
            .ok_or(PayloadError::new(DanglingDefinition, at))?;
        let times = [
            e.planned_start,
            e.started_at,
            e.end_at,
            e.dispatched_at,
            e.retry_at,
        ];
        check(times.into_iter().all(time_ok), TimeOutOfRange, at)?;
        check(
            e.duration_us <= network.max_duration_us(e.def),
            TimeOutOfRange,
            at,
        )?;
        check(
            e.served == crate::interface::NO_SERVED || network.task(e.served).is_some(),
            DanglingDefinition,
            at,
        )?;
        let window_ok = e
            .window
            .is_none_or(|(lo, hi)| lo <= hi && time_ok(lo) && time_ok(hi));
        check(window_ok, TimeOutOfRange, at)?;
        let has_command = spec.command.is_some();
        let state_ok = match e.state {
            TaskState::Committed | TaskState::WaitingPre => true,
            TaskState::Dispatched => has_command && e.command_id != 0,
            TaskState::Running => has_command == (e.command_id != 0),
            _ => false,
        };
        let interrupted_ok =
            !e.interrupted || matches!(e.state, TaskState::Dispatched | TaskState::Running);
        check(state_ok && interrupted_ok, ImpossibleState, at)?;
        let bound = network.max_retries(e.def);
        let retries_ok = FailureKind::ALL
            .iter()
            .all(|&k| e.retries.get(k) <= bound.get(k));
        check(retries_ok, CountOutOfRange, at)?;
    }

    for (i, e) in states.entries().iter().enumerate() {
        let at = At::StateEntry(index(i));
        check(time_ok(e.at), TimeOutOfRange, at)?;
        let seen_before = states.entries().iter().take(i).any(|x| x.key == e.key);
        check(!seen_before, DuplicateKey, at)?;
    }
    Ok(())
}
