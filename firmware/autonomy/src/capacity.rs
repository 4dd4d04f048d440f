//! Every fixed capacity of the autonomy core, in one place. Exceeding one is an error value
//! (an uplink rejection, a refused plan modification, a dropped report counted in
//! [`crate::autonomy::StepReport`]), never a panic.
//!
//! Sized for the lander missions (issue 14): 256 tasks in a network, 64 timelines, 16
//! constraints and 16 impacts per task, 512 plan entries. Every structure is fixed-size, so
//! its RAM is the same whatever it holds: the README's "Capacities and RAM" table gives each
//! one at these capacities and `tests/tests/capacities.rs` checks them against the partition
//! regions. Loops run over what a structure holds, never over its capacity.
//!
//! Derived capacities, and why:
//! - [`MAX_COMMITTED`] (64): the executive's tasks committed and not finished. The commit
//!   window is 60 s in the shipped networks; a lander's parallel activities (hotel loads,
//!   heaters, seismometer, sampling chain, comms) stay well below 64 at once, and a plan entry
//!   the executive cannot take is returned and committed again later (counted in
//!   [`crate::planner::PlannerStats::returned`]).
//! - [`MAX_TASK_REPORTS`] (128): up to two reports per committed task (start and end) between
//!   two planner cycles; over it a report is dropped and counted
//!   ([`crate::planner::PlannerStats::dropped_reports`]).
//! - [`MAX_STATE_KEYS`] (96): one per measured timeline ([`MAX_TIMELINES`]) and 32 more for
//!   condition terms on state-buffer entries no timeline measures.
//! - [`MAX_CANDIDATES`] (4096): the critical start times of one placement search grow with
//!   the events on the timelines a task touches times its relative instants; 8x the 512 that
//!   served 48 entries of 4 impacts. Over it the search is counted in
//!   [`crate::planner::PlannerStats::candidate_overflows`] and uses the candidates it has.
//! - `timeline::MAX_PLAN_EVENTS` (1024): a cache; a plan with more events is answered
//!   without it.
//!
//! Index types: a task definition is a `u8` everywhere (plan entries, commits, reports), so
//! [`MAX_TASKS`] is at most 256; timeline indices are `u8`; instance ids and plan-entry
//! positions are `u16`; uplink element counts are `u16` (so a 257th task can be named and
//! refused with `TooManyTasks`).

/// Timelines in one task network.
pub const MAX_TIMELINES: usize = 64;
/// Enumerated values of one state timeline (allowed-value sets are `u32` masks).
pub const MAX_STATE_VALUES: usize = 32;
/// Task definitions (requested tasks and templates) in one task network.
pub const MAX_TASKS: usize = 256;
/// PRE and MAINTAIN constraints of one task.
pub const MAX_CONSTRAINTS_PER_TASK: usize = 16;
/// PRE, MAINTAIN and POST impacts of one task.
pub const MAX_IMPACTS_PER_TASK: usize = 16;
/// Contingencies (failure kind -> action) of one task.
pub const MAX_CONTINGENCIES_PER_TASK: usize = 4;
/// Templates one task permits the planner to add.
pub const MAX_ADD_PERMISSIONS_PER_TASK: usize = 4;
/// Control conditions (boolean expression trees) in one task network.
pub const MAX_CONDITIONS: usize = 16;
/// Nodes (terms and operators) of one control condition.
pub const MAX_CONDITION_TERMS: usize = 8;
/// Nesting depth of one control condition (a single term has depth 1).
pub const MAX_CONDITION_DEPTH: usize = 4;
/// Temporal constraints between requested tasks in one task network.
pub const MAX_TEMPORAL_CONSTRAINTS: usize = 16;
/// Timed values of external timelines (Earth in view, ground-station passes) in one task
/// network: 32 window edges a sol over two sols of an 84-hour Europa cycle, or a day of
/// ground-station passes.
pub const MAX_TIMED_VALUES: usize = 64;
/// Thresholds of one derived state timeline (so up to 8 derived values).
pub const MAX_THRESHOLDS: usize = 7;
/// Model parameters of a network (uplink format 5).
pub const MAX_PARAMS: usize = 8;
/// Durations and impact magnitudes one model parameter sets.
pub const MAX_PARAM_USES: usize = 8;
/// Bytes of a task or timeline name.
pub const MAX_NAME_LEN: usize = 32;
/// Task instances the planner holds at once (requested, added, restarted; finished ones are
/// consolidated away).
pub const MAX_PLAN_ENTRIES: usize = 512;
/// Tasks the executive holds at once (committed and not yet finished).
pub const MAX_COMMITTED: usize = 64;
/// State-buffer entries the core remembers.
pub const MAX_STATE_KEYS: usize = MAX_TIMELINES + 32;
/// Command responses queued between two steps.
pub const MAX_PENDING_RESPONSES: usize = 16;
/// Execution reports queued from the executive to the planner.
pub const MAX_TASK_REPORTS: usize = 2 * MAX_COMMITTED;
/// Commits queued from the planner to the executive.
pub const MAX_PENDING_COMMITS: usize = MAX_COMMITTED;
/// Valid intervals returned for one task.
pub const MAX_VALID_INTERVALS: usize = 16;
/// Candidate start times examined by one valid-interval computation.
pub const MAX_CANDIDATES: usize = 4096;
/// Conflict repairs attempted in one planner cycle.
pub const MAX_REPAIRS_PER_CYCLE: usize = 16;

/// Largest mission time an uplink may name (about 36 years in µs); keeps all sums far from
/// `u64` overflow.
pub const MAX_MISSION_TIME_US: u64 = 1 << 60;
/// Longest task duration or timeout an uplink may name (30 days).
pub const MAX_DURATION_US: u64 = 30 * 86_400 * 1_000_000;
/// Longest staleness bound a measured timeline may declare (`TimelineSpec::stale_after_us`,
/// 30 days): a value older than its bound reads unknown to the autonomy.
pub const MAX_STALE_AFTER_US: u64 = MAX_DURATION_US;
/// Largest magnitude of an impact or constraint offset (1 day).
pub const MAX_OFFSET_US: i64 = 86_400 * 1_000_000;
/// Largest magnitude of a cumulative value, change or rate (keeps `i64` sums exact).
pub const MAX_MAGNITUDE: i64 = 1 << 48;
/// Largest `max_retries` or `max_repairs` bound for one cause: what bounds are for is keeping
/// the commands a misbehaving subsystem can draw small.
pub const MAX_RESPONSE_BOUND: u8 = 15;
/// Task ids at or above this are given by the planner to added and restarted instances.
pub const FIRST_INSTANCE_ID: u16 = 0x8000;

// Task definitions are `u8` indices (plan entries, commits, reports, the uplink's `def`).
const _: () = assert!(MAX_TASKS <= 1 << 8);
// Timeline indices are `u8`, and an allowed-value set is a `u32` mask.
const _: () = assert!(MAX_TIMELINES <= 1 << 8 && MAX_STATE_VALUES <= 32);
// Uplink element counts are `u16`; planner-given instance ids start at FIRST_INSTANCE_ID.
const _: () =
    assert!(MAX_TASKS < u16::MAX as usize && MAX_PLAN_ENTRIES < FIRST_INSTANCE_ID as usize);
// Constraint and impact indices are `u8` in error sites and conflicts.
const _: () = assert!(MAX_CONSTRAINTS_PER_TASK <= 1 << 8 && MAX_IMPACTS_PER_TASK <= 1 << 8);
