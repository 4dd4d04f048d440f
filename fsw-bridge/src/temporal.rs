//! Temporal planning on the target (issue 13): a compiled temporal task (the `temporal`
//! crate's binary format, written by `hil`'s PDDL front end) is uplinked to the planner
//! partition in chunks, planned there anytime across the partition's windows, and the plan
//! comes back step by step.
//!
//! Host to target: [`HostToTarget::TemporalBegin`](crate::HostToTarget::TemporalBegin)
//! announces a job (its length, its CRC-32 and how to search), then
//! [`HostToTarget::TemporalChunk`](crate::HostToTarget::TemporalChunk)s carry the bytes in
//! order. Target to host: [`TemporalReport`]s inside
//! [`TargetToHost::Temporal`](crate::TargetToHost::Temporal): `Accepted` once the whole task
//! arrived, matched its CRC and validated (or `Refused`, naming why), then after the search
//! one `Step` per planned action, `Stats` and `Done`.
//!
//! The bytes the chunks carry are a secured task (`sdls::temporal`: a security header, the
//! compiled task, an HMAC-SHA-256 trailer that also covers the job and its configuration);
//! `len` and `crc32` are the secured string's. The planner partition authenticates it with the
//! key and the anti-replay counter of its own security area before it validates it.
//!
//! Times are integers with their unit in the name: a plan's times are in the task's ticks
//! (`ticks_per_unit` of them make one PDDL time unit), the planning's CPU cost in timebase
//! ticks. Every report fits the planner partition's outbound port (64 bytes, checked by this
//! crate's tests for the largest instance of each).
use heapless::Vec;
use serde::{Deserialize, Serialize};

/// Bytes of task carried by one TemporalChunk (the same as a task-network uplink chunk).
pub const TEMPORAL_CHUNK_MAX: usize = 128;

/// Which repeated states the search prunes (`temporal::Duplicates`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalDuplicates {
    Keep,
    PruneQuiescent,
    PruneAll,
}

/// How to search (`temporal::PlannerConfig`, plus the limits of the job on the target).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct TemporalConfig {
    /// Longest plan in snap actions.
    pub max_steps: u16,
    /// Apply compression-safe actions' ends with their starts.
    pub compression: bool,
    /// The second open list (preferred operators).
    pub preferred_operators: bool,
    /// A full open list sheds its worse half instead of ending the search.
    pub shed_when_full: bool,
    pub duplicates: TemporalDuplicates,
    /// Heuristic supporters by duration instead of by action count.
    pub duration_costs: bool,
    /// Goal facts left out (bit i: the task's i-th goal fact).
    pub dropped_goals: u64,
    /// Stop after this many expansions (0: no limit).
    pub max_expansions: u32,
    /// Stop after this many planner windows of search (0: no limit).
    pub max_windows: u32,
}

impl TemporalConfig {
    /// `temporal::PlannerConfig::default()`, no limits.
    pub const DEFAULT: Self = Self {
        max_steps: 2048,
        compression: true,
        preferred_operators: true,
        shed_when_full: true,
        duplicates: TemporalDuplicates::PruneQuiescent,
        duration_costs: false,
        dropped_goals: 0,
        max_expansions: 0,
        max_windows: 0,
    };
}

impl Default for TemporalConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The arena region that ran out (`temporal::Region`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalRegion {
    /// The arena cannot hold the task's tables and scratch.
    Tables,
    Nodes,
    RegularOpen,
    PreferredOpen,
    PlanLength,
}

/// Why a job was refused before planning.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalRefusal {
    /// A chunk for no job, for another job, or not at the next offset.
    OutOfSequence { expected_offset: u32 },
    /// The announced length is zero or over the target's task buffer (`capacity` bytes).
    TooLarge { capacity: u32 },
    /// The bytes received do not have the announced CRC-32.
    BadCrc { computed: u32 },
    /// The task does not validate (`temporal::TaskError`): `kind` is the index of its
    /// `TaskErrorKind`, `offset` the byte where reading stopped.
    BadTask { kind: u8, offset: u32 },
    /// The secured task failed the security checks (`sdls::temporal`: no key, truncated, bad
    /// length, unknown key, bad MAC, replayed sequence number, or the counter could not be
    /// stored): nothing was planned and no counter moved (but for `CounterNotStored`, none
    /// moved either). Appended: the variants before it keep their index.
    Security(crate::security::SecurityRefusal),
    /// A Begin while job `job` is planning or reporting: that job goes on (a Begin abandons
    /// only a job still being received, so that no message from outside, authentic or not,
    /// can end an accepted job before it is authenticated). Appended.
    Busy { job: u16 },
}

/// How a search ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TemporalOutcome {
    Solved,
    /// The open lists emptied: no plan (within the pruning used).
    Unsolvable,
    /// The arena is exhausted.
    OutOfMemory(TemporalRegion),
    /// The job's expansion limit was reached.
    ExpansionLimit,
    /// The job's window limit was reached.
    WindowLimit,
}

/// What the planner partition says about a temporal job.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TemporalReport {
    /// The whole task arrived, matched its CRC and validated; planning starts in the next
    /// granted frame's window.
    Accepted {
        job: u16,
        facts: u32,
        actions: u32,
        task_bytes: u32,
        ticks_per_unit: u32,
        /// The planner partition's CPU spent receiving and checking the job (copying the
        /// chunks, absorbing them into the MAC, the CRC-32, the security checks and the
        /// counter write, the task's validation), timebase ticks (0 without a clock).
        receive_ticks: u32,
        /// The part of `receive_ticks` spent authenticating it (the security association
        /// read at the first job, the MAC absorbed chunk by chunk, the checks, the counter
        /// written to non-volatile memory).
        auth_ticks: u32,
    },
    /// The job was refused; nothing is planned for it.
    Refused { job: u16, reason: TemporalRefusal },
    /// Action `index` (in order of starts) of the plan. Times in task ticks.
    Step {
        job: u16,
        index: u16,
        action: u16,
        start: u32,
        duration: u32,
        /// The start window the plan's STN allows with the makespan kept.
        start_lb: u32,
        start_ub: u32,
    },
    /// Search statistics (saturated at u32::MAX).
    Stats {
        job: u16,
        expanded: u32,
        generated: u32,
        evaluated: u32,
        inconsistent: u32,
        duplicates: u32,
        dead_ends: u32,
        nodes: u32,
        too_long: u32,
        shed: u32,
        best_h: u32,
    },
    /// The job is over; after the steps and the statistics.
    Done {
        job: u16,
        outcome: TemporalOutcome,
        /// Steps sent (the plan's actions; 0 without a plan).
        steps: u16,
        /// The plan's makespan in task ticks (0 without a plan).
        makespan: u32,
        ticks_per_unit: u32,
        peak_arena_bytes: u32,
        arena_bytes: u32,
        /// The planner partition's CPU spent setting up and searching, in timebase ticks
        /// (0 natively).
        planning_ticks: u64,
        /// Planner windows in which the search ran.
        windows: u32,
        /// The costliest expansion's CPU (with a clock reading), timebase ticks (0 natively).
        worst_expansion_ticks: u32,
        /// The costliest piece of the search's set-up (`temporal::Planner::set_up_step`,
        /// with a clock reading), timebase ticks (0 natively).
        worst_set_up_ticks: u32,
    },
    /// After a warm reset (or a restart of the planner partition) the job accepted before it
    /// was found in memory the reset keeps, its task checked again (CRC-32 and validation)
    /// and its search restarted from the beginning: the same search, so the same plan. Steps,
    /// statistics or Done of the job sent before the reset are void; they come again.
    /// Appended.
    Resumed {
        job: u16,
        task_bytes: u32,
        /// The planner partition's CPU spent checking the stored task again, timebase ticks.
        verify_ticks: u32,
    },
}

impl TemporalReport {
    /// The job the report is about.
    pub fn job(&self) -> u16 {
        match *self {
            TemporalReport::Accepted { job, .. }
            | TemporalReport::Refused { job, .. }
            | TemporalReport::Step { job, .. }
            | TemporalReport::Stats { job, .. }
            | TemporalReport::Done { job, .. }
            | TemporalReport::Resumed { job, .. } => job,
        }
    }
}

/// The bytes of a TemporalChunk.
pub type TemporalChunkBytes = Vec<u8, TEMPORAL_CHUNK_MAX>;
