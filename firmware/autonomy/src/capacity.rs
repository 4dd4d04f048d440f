//! Every fixed capacity of the autonomy core, in one place. Exceeding one is an error value
//! (an uplink rejection, a refused plan modification, a dropped report counted in
//! [`crate::autonomy::StepReport`]), never a panic.

/// Timelines in one task network.
pub const MAX_TIMELINES: usize = 16;
/// Enumerated values of one state timeline (allowed-value sets are `u32` masks).
pub const MAX_STATE_VALUES: usize = 32;
/// Task definitions (requested tasks and templates) in one task network.
pub const MAX_TASKS: usize = 32;
/// PRE and MAINTAIN constraints of one task.
pub const MAX_CONSTRAINTS_PER_TASK: usize = 4;
/// PRE, MAINTAIN and POST impacts of one task.
pub const MAX_IMPACTS_PER_TASK: usize = 4;
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
/// Bytes of a task or timeline name.
pub const MAX_NAME_LEN: usize = 32;
/// Task instances the planner holds at once (requested, added, restarted; finished ones are
/// consolidated away).
pub const MAX_PLAN_ENTRIES: usize = 48;
/// Tasks the executive holds at once (committed and not yet finished).
pub const MAX_COMMITTED: usize = 16;
/// State-buffer entries the core remembers.
pub const MAX_STATE_KEYS: usize = 32;
/// Command responses queued between two steps.
pub const MAX_PENDING_RESPONSES: usize = 16;
/// Execution reports queued from the executive to the planner.
pub const MAX_TASK_REPORTS: usize = 32;
/// Commits queued from the planner to the executive.
pub const MAX_PENDING_COMMITS: usize = 16;
/// Valid intervals returned for one task.
pub const MAX_VALID_INTERVALS: usize = 16;
/// Candidate start times examined by one valid-interval computation.
pub const MAX_CANDIDATES: usize = 512;
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
