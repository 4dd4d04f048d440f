//! The temporal PDDL planner (seed 001, crate `temporal`) as a plug-in of the planner
//! partition (issue 13): a compiled task uplinked in chunks ([`HostToTarget::TemporalBegin`],
//! [`HostToTarget::TemporalChunk`]) is checked (length, CRC-32, then `temporal::Task::parse`)
//! and planned anytime, in the windows of granted frames, within the window's CPU share; the
//! plan, the statistics and the costs go back as [`TemporalReport`]s.
//!
//! Memory: the task's bytes and the search arena are handed in by the partition
//! ([`TemporalStorage`]); on the target they are statics of the planner partition's region
//! that are not zeroed at its start. The search borrows them while a job plans; when the job
//! ends (or a new one begins) the borrow ends with it and the application asks for them
//! again ([`TemporalApp::needs_storage`]). Nothing here allocates, and nothing from outside
//! can make it panic: bad bytes are a [`TemporalRefusal`].
//!
//! # A job kept across a warm reset
//!
//! The task buffer and the arena are in memory a warm reset does not clear (on the target,
//! `.bss.noinit.planner`), and so is a small record of the accepted job
//! ([`TemporalApp::keep_jobs_in`]: magic, version, job, lengths, CRC-32, where the task is,
//! its configuration, and the record's own CRC-32). It is written when a job is accepted and
//! cleared when the job ends or a Begin abandons it. After a (re)start,
//! [`TemporalApp::resume`] takes the job up again if the record is whole; memory that a cold
//! boot leaves holding anything (zeros under QEMU, garbage on a board) fails the magic or the
//! record's CRC and resumes nothing. A resumed job's task is then checked again in the
//! partition's windows, a piece at a time (its CRC-32 within the window's share, then
//! `Task::parse`): memory that kept a whole record but not the task is refused (`BadCrc` or
//! `BadTask`) and nothing is planned. It is not authenticated again: the record is only ever
//! written by this partition after the job passed the security checks (and its sequence
//! number is spent), and no other partition can write this memory. Then the search restarts
//! from the beginning: it is deterministic, so the plan is the one an uninterrupted search
//! finds. The host is told with [`TemporalReport::Resumed`]; what it received of the job
//! before the reset is void.
//!
//! # The onboard rover mission
//!
//! A job that a `RoverEvent::Start` named before its Begin is not planned as a job but flown
//! ([`crate::rover_mission`]): its task stays in the task buffer, each planning attempt is
//! written after it and searched here across windows as any job (its plan not reported but
//! taken by the mission), and the host's events (`HostToTarget::Rover`) are taken one per window.
//! While a mission flies, a Begin for another job is refused (`Busy`): it would overwrite the
//! mission's task.
//!
//! # Authentication
//!
//! The chunks carry a secured task ([`sdls::temporal`]: security header, compiled task,
//! HMAC-SHA-256 trailer over the service, the job, its configuration and the task). Once the
//! whole string has arrived and matched its CRC-32 (a line error is `BadCrc`, as before), the
//! plug-in checks it with its [`SecurityAssociation`] (`NoKey`, `Truncated`, `BadLength`,
//! `UnknownKey`, `BadMac`, `Replay`, in that order), writes the new anti-replay counter to
//! non-volatile memory (`CounterNotStored` if it cannot), and only then validates the task and
//! accepts it. A refusal is [`TemporalRefusal::Security`], counted per reason
//! ([`TemporalApp::security_refused`]); the refused job plans nothing, no counter moves, and
//! the plug-in takes the next job as before.
//!
//! **Where it is verified: here, in the planner partition**, with a security association of its
//! own: the same key (provisioned by `hil` into the planner's slice of non-volatile memory as
//! well as the executive's) and its own A/B anti-replay counter records, written before the
//! task takes effect, so a replay stays refused after a warm reset and a power cycle, as the
//! executive's do. Why not the executive, which verifies task networks and commands:
//! - the planner partition is where the bytes are (it reassembles them in its 2 MiB task
//!   buffer); routing up to 2 MiB through the executive, or a digest and a verdict between
//!   the two partitions, would need new traffic on the autonomy core's checkpointed channel
//!   (`autonomy::partitioned`), which the MEXEC planner's protocol owns, and would make the
//!   executive's windows, whose costs are budgeted, pay for the planner's jobs;
//! - each partition's slice of non-volatile memory has one owner (kernel-checked): the
//!   executive's counter records are written by the executive only, the planner's by the
//!   planner only, so no two partitions ever race on one A/B record pair;
//! - the MAC is absorbed chunk by chunk as the task arrives ([`sdls::temporal::TemporalMac`]),
//!   in the planner's own CPU time, so no window pays for hashing the whole task at once.
//!
//! The cost of two associations: the key is held in two places, and the two counters are
//! separate (each service's sequence numbers are checked against its own counter; a temporal
//! task's tag has its own service byte, so it can never pass for a task network's or a
//! command's). The host keeps one sequence counter per association.
use fsw_bridge::temporal::{
    RoverEvent, RoverRefusal, RoverReport, TemporalConfig, TemporalDuplicates, TemporalOutcome,
    TemporalRefusal, TemporalRegion, TemporalReport,
};
use sdls::temporal::TemporalMac;
use temporal::{PlannedAction, Planner, Region, Status, Task, TaskErrorKind};

use super::*;
use crate::rover_mission::checkpoint::{self as rover_checkpoint, RoverCheckpoint};
use crate::rover_mission::{RoverCtx, RoverMission, RoverNext, ROVER_REPLAN_AT};

/// Reports of the onboard rover mission waiting for room in the outbound queue (a replan with
/// a plan of 128 actions, the most a dispatch network holds, makes about 150).
pub const MAX_ROVER_REPORTS: usize = 200;

/// Bytes of the search arena on the target: 8 MiB. The benchmark instances 1-3 of satellite,
/// rovers and driverlog peak at 0.5 to 2.2 MiB (`hil plan --native`).
pub const TEMPORAL_ARENA_BYTES: usize = 8 << 20;
/// Largest compiled task the target takes: 2 MiB (satellite 3 is about 18 KiB, driverlog 20
/// 1.39 MB; with the 8 MiB arena and the statics the planner partition uses about 11 of its
/// 16 MiB region).
pub const MAX_TEMPORAL_TASK_BYTES: usize = 2 << 20;
/// Most actions of a plan the target reports: plans of up to 2,048 snap actions
/// (`temporal::PlannerConfig`'s default `max_steps`; a job asking for more is held to it).
pub const MAX_TEMPORAL_PLAN_ACTIONS: usize = 1024;
/// Words of the record of the accepted job kept in memory a warm reset does not clear
/// ([`TemporalApp::keep_jobs_in`]).
pub const TEMPORAL_RESUME_RECORD_WORDS: usize = 16;
/// "TJOB": a record of an accepted job.
const RESUME_MAGIC: u32 = u32::from_be_bytes(*b"TJOB");
const RESUME_VERSION: u32 = 1;
/// Bytes of a resumed job's task CRC-checked between two readings of the clock: 4 KiB, about
/// 2,000 ticks.
const VERIFY_PIECE_BYTES: usize = 4096;
/// The CRC of a resumed job's task, checked a piece at a time (a static, so that its digest
/// can be kept between windows).
static TASK_CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Expansions between two readings of the CPU clock: one, since one expansion costs a good
/// part of a window (satellite 2: about 270,000 guest instructions, 18,000 ticks, of the
/// planner window's 33,200).
const EXPANSIONS_PER_CHECK: u32 = 1;

/// The memory a job plans in.
pub struct TemporalStorage<'a> {
    /// Room for the task's bytes ([`MAX_TEMPORAL_TASK_BYTES`] on the target).
    pub task: &'a mut [u8],
    /// The search arena ([`TEMPORAL_ARENA_BYTES`] on the target).
    pub arena: &'a mut [u32],
}

/// Where a job is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Chunks arriving: `received` bytes so far.
    Receiving { received: u32 },
    /// Resumed after a reset: the stored task is being checked again, `checked` bytes so far.
    Verifying { checked: u32 },
    /// Accepted: searching in granted windows (the search is set up in the first).
    Planning,
    /// The search ended: reporting the plan's action `next`, then the statistics, then Done.
    Reporting {
        next: usize,
        stats_sent: bool,
        /// The `Improved` report (the search's plan and the elimination) went after the
        /// statistics.
        improved_sent: bool,
    },
}

#[derive(Clone, Copy, Debug)]
struct Job {
    id: u16,
    /// Bytes of the secured task (header, task, trailer).
    len: u32,
    crc32: u32,
    /// Where the compiled task is in the task buffer (after the security header), and its
    /// length; set when the job is accepted.
    task_at: u32,
    task_len: u32,
    config: TemporalConfig,
    phase: Phase,
    ticks_per_unit: u32,
    /// CPU spent setting up and searching, timebase ticks.
    spent_ticks: u64,
    /// Windows in which the search ran.
    windows: u32,
    /// The CPU of the costliest expansion so far (with its clock reading), timebase ticks.
    most_step_ticks: u64,
    /// The last window ran no expansion (the costliest did not fit it).
    stalled: bool,
    /// The CPU of the costliest piece of the search's set-up so far, timebase ticks.
    most_set_up_ticks: u64,
    /// CPU spent until the search's plan was found (before the elimination that improves it,
    /// `temporal::Planner::improving`), and the costliest unit of that elimination.
    first_plan_ticks: Option<u64>,
    most_elim_ticks: u64,
    /// The costliest expansion until the search's plan (the elimination's units after it are
    /// in `most_step_ticks`, which paces the windows, and `most_elim_ticks`).
    most_search_ticks: u64,
    outcome: Option<TemporalOutcome>,
    /// Actions of the plan (in `TemporalApp::plan`) and its makespan.
    plan_len: usize,
    makespan: u32,
    /// The search's plan's makespan (before the elimination; the plan's without one).
    first_makespan: u32,
    stats: temporal::Stats,
}

impl Job {
    fn new(id: u16, len: u32, crc32: u32, config: TemporalConfig) -> Self {
        Self {
            id,
            len,
            crc32,
            task_at: 0,
            task_len: 0,
            config,
            phase: Phase::Receiving { received: 0 },
            ticks_per_unit: 0,
            spent_ticks: 0,
            windows: 0,
            most_step_ticks: 0,
            stalled: false,
            most_set_up_ticks: 0,
            first_plan_ticks: None,
            most_elim_ticks: 0,
            most_search_ticks: 0,
            outcome: None,
            plan_len: 0,
            makespan: 0,
            first_makespan: 0,
            stats: temporal::Stats::default(),
        }
    }
}

/// The temporal planner plug-in.
pub struct TemporalApp<'a> {
    storage: Option<TemporalStorage<'a>>,
    planner: Option<Planner<'a, 'a>>,
    job: Option<Job>,
    /// The plan of the job being reported, in order of starts.
    plan: &'a mut [PlannedAction],
    arena_bytes: u32,
    /// Bytes of task the storage holds.
    task_capacity: u32,
    /// Jobs refused and jobs planned since the start (for logs and tests).
    pub refused: u32,
    pub finished: u32,
    /// Jobs refused by the security checks, per reason (`SecurityRefusal::index`); included
    /// in `refused`.
    pub security_refused: [u32; SecurityRefusal::COUNT],
    /// The key and the anti-replay counter (read from `store` at the first job).
    security: SecurityAssociation,
    security_loaded: bool,
    /// The planner partition's security area in non-volatile memory.
    store: Option<&'a mut dyn SecurityStore>,
    /// The MAC of the job being received (None: no key).
    mac: Option<TemporalMac>,
    /// The partition's CPU clock for the cost of receiving a job (None: not counted).
    receive_clock: Option<fn() -> u64>,
    /// CPU spent so far receiving the job in progress, timebase ticks.
    receive_ticks: u64,
    /// The record of the accepted job, in memory a warm reset keeps (None: not kept).
    record: Option<&'a mut [u32; TEMPORAL_RESUME_RECORD_WORDS]>,
    /// The CRC of a resumed job's task, so far.
    verify_digest: Option<crc::Digest<'static, u32>>,
    /// Jobs resumed after a reset (their task checked again) since the start.
    pub resumed: u32,
    /// The part of it spent on authentication (loading the association, the MAC, the
    /// checks, the counter write).
    auth_ticks: u64,
    /// Memory for the onboard rover mission (zero-filled at its first `Start`), and the
    /// mission once it is.
    rover_memory: Option<fn() -> &'a mut RoverMission>,
    rover: Option<&'a mut RoverMission>,
    /// The mission's event waiting for the next window, and its reports waiting for room.
    rover_event: Option<RoverEvent>,
    rover_reports: heapless::Deque<RoverReport, MAX_ROVER_REPORTS>,
    /// Reports lost to a full queue (cannot happen within the capacities).
    pub rover_reports_lost: u32,
    /// The job in progress is an attempt of the rover mission (planned, not reported).
    rover_attempt: bool,
    /// The rover mission's checkpoint, in memory a warm reset keeps (None: not kept), and a
    /// record found there at the (re)start, taken up in the next window.
    rover_checkpoint: Option<&'a mut RoverCheckpoint>,
    rover_resume: bool,
    /// Where taking the mission up again stands (it is divided across windows), the costliest
    /// piece so far and the ticks of its pieces so far.
    rover_restoring: rover_checkpoint::Restoring,
    rover_restore_most: u64,
    rover_restore_ticks: u64,
    /// The layout of the rover attempt's replan task, as its search validated it.
    rover_replan_layout: Option<temporal::task::TaskLayout>,
}

/// `temporal::PlannerConfig` for a job's configuration (`max_steps` held to what the plan
/// buffer of `plan_capacity` actions reports).
pub fn planner_config(config: &TemporalConfig, plan_capacity: usize) -> temporal::PlannerConfig {
    temporal::PlannerConfig {
        max_steps: usize::from(config.max_steps).min(2 * plan_capacity),
        compression: config.compression,
        duplicates: match config.duplicates {
            TemporalDuplicates::Keep => temporal::Duplicates::Keep,
            TemporalDuplicates::PruneQuiescent => temporal::Duplicates::PruneQuiescent,
            TemporalDuplicates::PruneAll => temporal::Duplicates::PruneAll,
        },
        preferred_operators: config.preferred_operators,
        shed_when_full: config.shed_when_full,
        relaxed_cost: if config.duration_costs {
            temporal::heuristic::RelaxedCost::Duration
        } else {
            temporal::heuristic::RelaxedCost::Unit
        },
        dropped_goals: config.dropped_goals,
        eliminate: true,
    }
}

fn region(r: Region) -> TemporalRegion {
    match r {
        Region::Tables => TemporalRegion::Tables,
        Region::Nodes => TemporalRegion::Nodes,
        Region::RegularOpen => TemporalRegion::RegularOpen,
        Region::PreferredOpen => TemporalRegion::PreferredOpen,
        Region::PlanLength => TemporalRegion::PlanLength,
    }
}

/// The index of a task error kind on the wire.
pub fn task_error_code(kind: TaskErrorKind) -> u8 {
    match kind {
        TaskErrorKind::BadMagic => 0,
        TaskErrorKind::UnsupportedVersion => 1,
        TaskErrorKind::Truncated => 2,
        TaskErrorKind::FactOutOfRange => 3,
        TaskErrorKind::VariableOutOfRange => 4,
        TaskErrorKind::BadComparison => 5,
        TaskErrorKind::BadEffectOp => 6,
        TaskErrorKind::DurationBoundsReversed => 7,
        TaskErrorKind::WindowReversed => 8,
        TaskErrorKind::OffsetOutOfRange => 9,
        TaskErrorKind::TooMany => 10,
        TaskErrorKind::BadName => 11,
        TaskErrorKind::ZeroEpsilon => 12,
    }
}

fn sat(v: u64) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 (ISO-HDLC, the link's) of a temporal task, as TemporalBegin carries it.
pub fn temporal_crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

impl<'a> TemporalApp<'a> {
    /// An application with `plan` for the plan of the job being reported (at most its length
    /// in actions is planned: see [`planner_config`]).
    pub fn new(plan: &'a mut [PlannedAction]) -> Self {
        Self {
            storage: None,
            planner: None,
            job: None,
            plan,
            arena_bytes: 0,
            task_capacity: 0,
            refused: 0,
            finished: 0,
            security_refused: [0; SecurityRefusal::COUNT],
            security: SecurityAssociation::none(),
            security_loaded: false,
            store: None,
            mac: None,
            receive_clock: None,
            receive_ticks: 0,
            auth_ticks: 0,
            record: None,
            verify_digest: None,
            resumed: 0,
            rover_memory: None,
            rover: None,
            rover_event: None,
            rover_reports: heapless::Deque::new(),
            rover_reports_lost: 0,
            rover_attempt: false,
            rover_checkpoint: None,
            rover_resume: false,
            rover_restoring: rover_checkpoint::Restoring::new(),
            rover_restore_most: 0,
            rover_restore_ticks: 0,
            rover_replan_layout: None,
        }
    }

    /// Keep the rover mission's checkpoint in `checkpoint` ([`crate::rover_mission::checkpoint`]):
    /// memory a warm reset does not clear. Call [`Self::resume_rover`] after the storage is
    /// given.
    pub fn keep_rover_in(&mut self, checkpoint: &'a mut RoverCheckpoint) {
        self.rover_checkpoint = Some(checkpoint);
    }

    /// After a (re)start: whether the checkpoint holds a record of a mission, which the next
    /// window then takes up again (or refuses, saying why).
    pub fn resume_rover(&mut self) -> bool {
        self.rover_restoring = rover_checkpoint::Restoring::new();
        self.rover_restore_most = 0;
        self.rover_restore_ticks = 0;
        self.rover_resume = self.storage.is_some()
            && self.rover_memory.is_some()
            && self
                .rover_checkpoint
                .as_deref()
                .is_some_and(|c| c.holds_a_record());
        self.rover_resume
    }

    /// The mission is being taken up again from its checkpoint (its pieces go on in the next
    /// windows; it takes no event meanwhile).
    pub fn rover_resuming(&self) -> bool {
        self.rover_resume
    }

    /// The window's work of taking the mission up again from its checkpoint: its pieces
    /// ([`rover_checkpoint::restore_piece`]) while the costliest so far fits the window's
    /// share (the window's first always runs: [`crate::piece_fits`]' rule), the rest in the
    /// next windows; `Resumed` says the ticks of all the pieces.
    fn rover_resume_window(
        &mut self,
        clock: &mut dyn CpuClock,
        until: Option<u64>,
        hard_until: Option<u64>,
    ) {
        let t0 = clock.ticks();
        if self.rover.is_none() {
            self.rover = self.rover_memory.take().map(|zeroed| zeroed());
        }
        let (Some(m), Some(cp), Some(storage)) = (
            self.rover.as_deref_mut(),
            self.rover_checkpoint.as_deref(),
            self.storage.as_ref(),
        ) else {
            self.rover_resume = false;
            return;
        };
        let mut last = t0;
        let mut most = self.rover_restore_most;
        let mut fits = || {
            let now = clock.ticks();
            most = most.max(now.wrapping_sub(last));
            last = now;
            until.is_none_or(|u| crate::piece_fits(now, most, false, false, u, hard_until))
        };
        let done = rover_checkpoint::restore_piece(
            m,
            cp,
            storage.task,
            &mut self.rover_restoring,
            &mut fits,
        );
        let now = clock.ticks();
        self.rover_restore_most = most.max(now.wrapping_sub(last));
        self.rover_restore_ticks = self
            .rover_restore_ticks
            .saturating_add(now.wrapping_sub(t0));
        let Some(done) = done else {
            return;
        };
        self.rover_resume = false;
        let report = match done {
            Ok(None) => return,
            Ok(Some(events)) => RoverReport::Resumed {
                events,
                last_ms: m.last_ms(),
                restore_ticks: sat(self.rover_restore_ticks),
            },
            Err(reason) => RoverReport::NotResumed { reason },
        };
        self.rover_say(report);
    }

    /// Memory for the onboard rover mission ([`crate::rover_mission`]): `memory` returns it
    /// zero-filled (all-zero bytes are an idle mission) or as [`RoverMission::new`] made it,
    /// and is called once, at the first `Start` (so a partition start costs nothing for it).
    /// Without it a rover `Start` is refused (`Capacity`).
    pub fn fly_rover_in(&mut self, memory: fn() -> &'a mut RoverMission) {
        self.rover_memory = Some(memory);
    }

    fn rover_say(&mut self, report: RoverReport) {
        if self.rover_reports.push_back(report).is_err() {
            self.rover_reports_lost = self.rover_reports_lost.saturating_add(1);
        }
    }

    /// A rover mission event from the host: `Start` arms the mission for job `job`; any other
    /// waits for the next window (one at a time).
    fn rover_event(&mut self, job: u16, event: RoverEvent) {
        if let RoverEvent::Start {
            horizon_slack_ms,
            max_expansions,
            us_per_expansion,
        } = event
        {
            if self.job.is_some() || self.rover_event.is_some() {
                self.rover_say(RoverReport::Refused {
                    reason: RoverRefusal::Busy,
                });
                return;
            }
            if self.rover.is_none() {
                self.rover = self.rover_memory.take().map(|zeroed| zeroed());
            }
            let Some(m) = self.rover.as_deref_mut() else {
                self.rover_say(RoverReport::Refused {
                    reason: RoverRefusal::Capacity,
                });
                return;
            };
            m.arm(job, horizon_slack_ms, max_expansions, us_per_expansion);
            if let Some(cp) = self.rover_checkpoint.as_deref_mut() {
                cp.clear();
            }
            return;
        }
        let flying = self
            .rover
            .as_deref()
            .and_then(|m| m.job())
            .is_some_and(|j| j == job);
        if !flying {
            self.rover_say(RoverReport::Refused {
                reason: RoverRefusal::NoMission,
            });
            return;
        }
        if self.rover_event.is_some() || self.rover.as_deref().is_some_and(|m| m.planning()) {
            self.rover_say(RoverReport::Refused {
                reason: RoverRefusal::Busy,
            });
            return;
        }
        self.rover_event = Some(event);
    }

    /// The rover mission and the task buffer it reads (None: no mission memory, or the
    /// storage is not given): what the executive's side of the decisions needs of it
    /// ([`crate::rover_exec`]: the plan flown, the readiness mask).
    pub fn rover_view<R>(&self, f: impl FnOnce(&RoverMission, &[u8]) -> R) -> Option<R> {
        let m = self.rover.as_deref()?;
        let storage = self.storage.as_ref()?;
        Some(f(m, &*storage.task))
    }

    /// What the executive's side of the decisions ([`crate::rover_exec`]) tells the mission:
    /// a start it took (the mission applies it) or a replan it asks for (the mission replans;
    /// the attempts then run in the next windows as an event's). Its reports (a refusal, or
    /// the replan's) come out as the events'. False if no mission is flying or the storage is
    /// not given. Each is one of the mission's inputs as an event is (checkpointed before it,
    /// counted). Natively only for now (the partitions' messages carrying these are step 1's
    /// routing, not yet done).
    pub fn rover_from_executive(&mut self, what: FromExecutive) -> bool {
        let (Some(m), Some(storage)) = (self.rover.as_deref_mut(), self.storage.as_mut()) else {
            return false;
        };
        let reports = &mut self.rover_reports;
        let lost = &mut self.rover_reports_lost;
        let mut out = |r: RoverReport| {
            if reports.push_back(r).is_err() {
                *lost = lost.saturating_add(1);
            }
        };
        let mut clock = crate::NoClock;
        let mut ctx = RoverCtx {
            task_buffer: &mut *storage.task,
            clock: &mut clock,
            until: None,
            hard_until: None,
        };
        // An input of the mission as an event is: the state before it checkpointed, counted
        // (a reset after it is taken up from there and the inputs since sent again).
        if let Some(cp) = self.rover_checkpoint.as_deref_mut() {
            rover_checkpoint::save(m, cp);
        }
        m.took_event();
        let next = match what {
            FromExecutive::Started { step, at_ms } => m.started(&mut ctx, step, at_ms, &mut out),
            FromExecutive::Replan { at_ms, why } => {
                m.replan_requested(&mut ctx, at_ms, why, &mut out)
            }
        };
        if let RoverNext::Plan {
            len,
            max_expansions,
        } = next
        {
            let config = TemporalConfig {
                duration_costs: true,
                max_expansions,
                ..TemporalConfig::DEFAULT
            };
            let id = m.job().unwrap_or(0);
            self.job = Some(Job {
                task_at: ROVER_REPLAN_AT as u32,
                task_len: sat(len as u64),
                phase: Phase::Planning,
                ..Job::new(id, sat(len as u64), 0, config)
            });
            self.rover_attempt = true;
        }
        true
    }

    /// A window's work of the rover mission: an attempt's end, or the event waiting. True if
    /// there was some.
    fn rover_window(
        &mut self,
        clock: &mut dyn CpuClock,
        until: Option<u64>,
        hard_until: Option<u64>,
    ) -> bool {
        let attempt_over = self.rover_attempt
            && self
                .job
                .is_some_and(|j| matches!(j.phase, Phase::Reporting { .. }));
        let building = self.rover.as_deref().and_then(|m| m.building());
        if !attempt_over && building.is_none() && self.rover_event.is_none() {
            return false;
        }
        let (Some(m), Some(storage)) = (self.rover.as_deref_mut(), self.storage.as_mut()) else {
            return false;
        };
        let reports = &mut self.rover_reports;
        let lost = &mut self.rover_reports_lost;
        let mut out = |r: RoverReport| {
            if reports.push_back(r).is_err() {
                *lost = lost.saturating_add(1);
            }
        };
        let mut ctx = RoverCtx {
            task_buffer: &mut *storage.task,
            clock,
            until,
            hard_until,
        };
        let next = if let Some(plan_len) = building {
            let plan = self.plan.get(..plan_len).unwrap_or_default();
            m.network_piece(&mut ctx, plan, &mut out)
        } else if attempt_over {
            let Some(job) = self.job else {
                return false;
            };
            let plan = self.plan.get(..job.plan_len).unwrap_or_default();
            let outcome = job.outcome.unwrap_or(TemporalOutcome::Unsolvable);
            let next = m.attempt_ended(
                &mut ctx,
                outcome,
                &job.stats,
                job.spent_ticks,
                plan,
                job.makespan,
                self.rover_replan_layout.take(),
                &mut out,
            );
            self.planner = None;
            self.job = None;
            self.rover_attempt = false;
            next
        } else {
            // The state the last event left, before this one changes it.
            if let Some(cp) = self.rover_checkpoint.as_deref_mut() {
                rover_checkpoint::save(m, cp);
            }
            m.took_event();
            match self.rover_event.take() {
                Some(RoverEvent::Goal { fact, at_ms }) => m.goal(&mut ctx, fact, at_ms, &mut out),
                Some(RoverEvent::Ended { action, at_ms }) => {
                    m.ended(&mut ctx, action, at_ms, &mut out)
                }
                Some(RoverEvent::Poll { now_ms }) => m.poll(&mut ctx, now_ms, &mut out),
                Some(RoverEvent::Close { now_ms }) => m.close(&mut ctx, now_ms, &mut out),
                Some(RoverEvent::Inactive { fact }) => m.inactive(&mut ctx, fact, &mut out),
                Some(RoverEvent::Expected { action, ends_ms }) => {
                    m.expected(action, ends_ms, &mut out)
                }
                Some(RoverEvent::Start { .. }) | None => RoverNext::Answered,
            }
        };

        if let RoverNext::Plan {
            len,
            max_expansions,
        } = next
        {
            let config = TemporalConfig {
                duration_costs: true,
                max_expansions,
                ..TemporalConfig::DEFAULT
            };
            let id = m.job().unwrap_or(0);
            self.job = Some(Job {
                task_at: ROVER_REPLAN_AT as u32,
                task_len: sat(len as u64),
                phase: Phase::Planning,
                ..Job::new(id, sat(len as u64), 0, config)
            });
            self.rover_attempt = true;
        }
        true
    }

    /// Keep the record of the accepted job in `record`: memory a warm reset does not clear,
    /// as the task buffer and the arena. Call [`Self::resume`] after the storage is given.
    pub fn keep_jobs_in(&mut self, record: &'a mut [u32; TEMPORAL_RESUME_RECORD_WORDS]) {
        self.record = Some(record);
    }

    /// After a (re)start, with the storage given: take up the job the record describes, if
    /// the record is whole (its magic, version, CRC-32 and fields hold) and no job is in
    /// progress. Its task is checked again in the next windows, then planned from the start.
    /// False if there is nothing to resume.
    pub fn resume(&mut self) -> bool {
        if self.job.is_some() || self.storage.is_none() {
            return false;
        }
        let Some(found) = self.record.as_deref().and_then(decode_record) else {
            return false;
        };
        if found.len > self.task_capacity {
            return false;
        }
        self.job = Some(Job {
            phase: Phase::Verifying { checked: 0 },
            ..found
        });
        self.verify_digest = Some(TASK_CRC.digest());
        true
    }

    /// The clock that counts what receiving a job costs (`Accepted`'s `receive_ticks`).
    pub fn set_receive_clock(&mut self, clock: fn() -> u64) {
        self.receive_clock = Some(clock);
    }

    fn receive_clock(&self) -> u64 {
        self.receive_clock.map_or(0, |c| c())
    }

    /// Where the key and the anti-replay counter of temporal uplinks are: the planner
    /// partition's security area (None: no key, every job is refused with `NoKey`). Read at
    /// the first job's Begin, not here, so that a (re)start costs nothing for it.
    pub fn secure(&mut self, store: Option<&'a mut dyn SecurityStore>) {
        self.store = store;
        self.security_loaded = false;
        self.security = SecurityAssociation::none();
    }

    /// The security association in use (the last sequence number accepted, for tests).
    pub fn security(&self) -> &SecurityAssociation {
        &self.security
    }

    /// No job holds the task bytes and the arena, and none were given since: hand them in
    /// with [`TemporalApp::give_storage`] before the next message or window.
    pub fn needs_storage(&self) -> bool {
        self.storage.is_none() && self.planner.is_none()
    }

    /// The memory jobs plan in.
    pub fn give_storage(&mut self, storage: TemporalStorage<'a>) {
        self.arena_bytes = sat((storage.arena.len() * 4) as u64);
        self.task_capacity = sat(storage.task.len() as u64);
        self.storage = Some(storage);
    }

    /// The job in progress, if any.
    pub fn job(&self) -> Option<u16> {
        self.job.map(|j| j.id)
    }

    fn refuse(&mut self, job: u16, reason: TemporalRefusal, downlink: &mut dyn Downlink) {
        self.refused = self.refused.saturating_add(1);
        if let TemporalRefusal::Security(r) = reason {
            if let Some(n) = self.security_refused.get_mut(r.index()) {
                *n = n.saturating_add(1);
            }
        }
        downlink.send(TargetToHost::Temporal(TemporalReport::Refused {
            job,
            reason,
        }));
    }

    /// Ends the job in progress: the search's borrow of the storage ends with it.
    fn end_job(&mut self) {
        self.planner = None;
        self.job = None;
        self.rover_attempt = false;
        self.mac = None;
        self.verify_digest = None;
        if let Some(record) = self.record.as_deref_mut() {
            record[0] = 0;
        }
    }

    fn begin(
        &mut self,
        id: u16,
        len: u32,
        crc32: u32,
        config: TemporalConfig,
        downlink: &mut dyn Downlink,
    ) {
        // An accepted job is never ended from outside before the new one is authenticated
        // (which needs the task buffer the search is reading): the Begin is refused instead.
        if let Some(j) = self.job {
            if !matches!(j.phase, Phase::Receiving { .. }) {
                self.refuse(id, TemporalRefusal::Busy { job: j.id }, downlink);
                return;
            }
        }
        // A rover mission flying keeps its task in the task buffer: another job would
        // overwrite it (the mission's own task comes as the job its Start named).
        if let Some(m) = self.rover.as_deref() {
            if let (Some(flying), None) = (m.job(), m.armed_for().filter(|&j| j == id)) {
                self.refuse(id, TemporalRefusal::Busy { job: flying }, downlink);
                return;
            }
        }
        // A mission closed is forgotten once another job begins; until then a reset takes
        // it up as it was before its Close (the host may not have had the answer).
        let armed = self.rover.as_deref().and_then(|m| m.armed_for()) == Some(id);
        if let (false, Some(cp)) = (armed, self.rover_checkpoint.as_deref_mut()) {
            cp.clear();
        }
        self.end_job();
        self.receive_ticks = 0;
        self.auth_ticks = 0;
        let capacity = self.task_capacity;
        if len == 0 || len > capacity {
            self.refuse(id, TemporalRefusal::TooLarge { capacity }, downlink);
            return;
        }
        let t0 = self.receive_clock();
        if !self.security_loaded {
            self.security = SecurityAssociation::load(self.store.as_deref_mut());
            self.security_loaded = true;
        }
        // No key: the job is received all the same and refused with `NoKey` at its end, in
        // the order of the checks (a refusal now would make every chunk a stray).
        self.mac = self.security.begin_temporal(id, &config, len).ok();
        self.auth_ticks = self.receive_clock().wrapping_sub(t0);
        self.job = Some(Job::new(id, len, crc32, config));
    }

    fn chunk(
        &mut self,
        id: u16,
        offset: u32,
        bytes: &[u8],
        started: u64,
        downlink: &mut dyn Downlink,
    ) {
        let (Some(job), Some(storage)) = (self.job.as_mut(), self.storage.as_mut()) else {
            self.refuse(
                id,
                TemporalRefusal::OutOfSequence { expected_offset: 0 },
                downlink,
            );
            return;
        };
        let Phase::Receiving { received } = job.phase else {
            let expected_offset = job.len;
            self.refuse(
                id,
                TemporalRefusal::OutOfSequence { expected_offset },
                downlink,
            );
            return;
        };
        let end = offset.checked_add(sat(bytes.len() as u64));
        let fits = end.is_some_and(|e| e <= job.len);
        if job.id != id || offset != received || !fits {
            // The job in progress stays as it is: the chunk is the stranger.
            self.refuse(
                id,
                TemporalRefusal::OutOfSequence {
                    expected_offset: received,
                },
                downlink,
            );
            return;
        }
        let (start, end) = (offset as usize, end.unwrap_or(offset) as usize);
        let Some(dest) = storage.task.get_mut(start..end) else {
            let capacity = sat(storage.task.len() as u64);
            self.refuse(id, TemporalRefusal::TooLarge { capacity }, downlink);
            return;
        };
        dest.copy_from_slice(bytes);
        let clock = self.receive_clock;
        let now = || clock.map_or(0, |c| c());
        let t0 = now();
        if let Some(mac) = self.mac.as_mut() {
            mac.absorb(offset, bytes);
        }
        self.auth_ticks = self.auth_ticks.wrapping_add(now().wrapping_sub(t0));
        let received = end as u32;
        job.phase = Phase::Receiving { received };
        if received < job.len {
            return;
        }
        let (len, crc32) = (job.len as usize, job.crc32);
        let task_bytes = storage.task.get(..len).unwrap_or_default();
        let computed = temporal_crc32(task_bytes);
        if computed != crc32 {
            self.end_job();
            self.refuse(id, TemporalRefusal::BadCrc { computed }, downlink);
            return;
        }
        // Authentic and fresh, with the counter stored, before anything else happens.
        let t0 = now();
        let checked = match self.mac.take() {
            None => Err(SecurityRefusal::NoKey),
            Some(mac) => self.security.check_temporal(mac, task_bytes),
        };
        let (header, image) = match checked {
            Ok(ok) => ok,
            Err(r) => {
                self.end_job();
                self.refuse(id, TemporalRefusal::Security(r), downlink);
                return;
            }
        };
        // The task follows the security header (`sdls::temporal`'s layout).
        let task_at = sdls::uplink::HEADER_LEN as u32;
        let task_len = sat(image.len() as u64);
        let holds = self.security.holds();
        if let Err(r) = self
            .security
            .accept(header.sequence, holds, self.store.as_deref_mut())
        {
            self.end_job();
            self.refuse(id, TemporalRefusal::Security(r), downlink);
            return;
        }
        self.auth_ticks = self.auth_ticks.wrapping_add(now().wrapping_sub(t0));
        // Authentic, so its sequence number is spent whether or not the task validates.
        match Task::parse(image) {
            Err(e) => {
                self.end_job();
                self.refuse(
                    id,
                    TemporalRefusal::BadTask {
                        kind: task_error_code(e.kind),
                        offset: sat(e.offset as u64),
                    },
                    downlink,
                );
            }
            Ok(task) => {
                let facts = sat(task.fact_count() as u64);
                let actions = sat(task.action_count() as u64);
                let ticks_per_unit = task.ticks_per_unit();
                let Some(job) = self.job.as_mut() else {
                    return;
                };
                job.phase = Phase::Planning;
                job.ticks_per_unit = ticks_per_unit;
                job.task_at = task_at;
                job.task_len = task_len;
                let kept = *job;
                if let Some(record) = self.record.as_deref_mut() {
                    *record = encode_record(&kept);
                }
                let receive_ticks = sat(self
                    .receive_ticks
                    .wrapping_add(self.receive_clock().wrapping_sub(started)));
                downlink.send(TargetToHost::Temporal(TemporalReport::Accepted {
                    job: id,
                    facts,
                    actions,
                    task_bytes: task_len,
                    ticks_per_unit,
                    receive_ticks,
                    auth_ticks: sat(self.auth_ticks),
                }));
                // The rover mission's task is flown, not planned as a job: it stays in the
                // task buffer for the mission, which plans from it.
                let armed = self.rover.as_deref().and_then(|m| m.armed_for()) == Some(id);
                if let (true, Some(m), Some(storage)) =
                    (armed, self.rover.as_deref_mut(), self.storage.as_ref())
                {
                    let report = m.accepted(storage.task, task_at as usize, task_len as usize);
                    if let Some(cp) = self.rover_checkpoint.as_deref_mut() {
                        rover_checkpoint::save(m, cp);
                    }
                    self.end_job();
                    self.rover_say(report);
                }
            }
        }
    }

    /// Lays the search out for the accepted job (its first window); the set-up follows in
    /// pieces ([`Self::set_up_pieces`]).
    fn set_up(&mut self) -> Result<(), Region> {
        let (Some(job), Some(storage)) = (self.job.as_ref(), self.storage.take()) else {
            return Err(Region::Tables);
        };
        let TemporalStorage { task, arena } = storage;
        let task: &'a [u8] = task;
        let (at, len) = (job.task_at as usize, job.task_len as usize);
        let bytes = task.get(at..at.saturating_add(len)).unwrap_or_default();
        // Validated on arrival; a failure here would be a bug, reported as bad tables.
        let parsed = Task::parse(bytes).map_err(|_| Region::Tables)?;
        let config = planner_config(&job.config, self.plan.len());
        self.planner = Some(Planner::new_deferred(parsed, arena, config)?);
        Ok(())
    }

    /// A window's share of checking a resumed job's task again: its CRC-32 a piece at a time,
    /// then its validation; then it plans (the search is set up in the next window).
    fn verify(
        &mut self,
        clock: &mut dyn CpuClock,
        until: Option<u64>,
        downlink: &mut dyn Downlink,
    ) {
        let t0 = clock.ticks();
        let (Some(job), Some(storage), Some(digest)) = (
            self.job.as_mut(),
            self.storage.as_ref(),
            self.verify_digest.as_mut(),
        ) else {
            return;
        };
        let Phase::Verifying { mut checked } = job.phase else {
            return;
        };
        let len = job.len as usize;
        loop {
            let from = checked as usize;
            let end = from.saturating_add(VERIFY_PIECE_BYTES).min(len);
            let Some(piece) = storage.task.get(from..end) else {
                break;
            };
            digest.update(piece);
            checked = end as u32;
            if end >= len || until.is_some_and(|u| clock.ticks() >= u) {
                break;
            }
        }
        job.phase = Phase::Verifying { checked };
        job.windows = job.windows.saturating_add(1);
        let (id, crc32) = (job.id, job.crc32);
        if (checked as usize) < len {
            job.spent_ticks = job.spent_ticks.wrapping_add(clock.ticks().wrapping_sub(t0));
            return;
        }
        let computed = self.verify_digest.take().map_or(0, |d| d.finalize());
        if computed != crc32 {
            self.end_job();
            self.refuse(id, TemporalRefusal::BadCrc { computed }, downlink);
            return;
        }
        let (at, task_len) = (job.task_at as usize, job.task_len as usize);
        let image = storage
            .task
            .get(at..at.saturating_add(task_len))
            .unwrap_or_default();
        match Task::parse(image) {
            Err(e) => {
                self.end_job();
                self.refuse(
                    id,
                    TemporalRefusal::BadTask {
                        kind: task_error_code(e.kind),
                        offset: sat(e.offset as u64),
                    },
                    downlink,
                );
            }
            Ok(_) => {
                let spent = clock.ticks().wrapping_sub(t0);
                let Some(job) = self.job.as_mut() else {
                    return;
                };
                job.spent_ticks = job.spent_ticks.wrapping_add(spent);
                job.phase = Phase::Planning;
                self.resumed = self.resumed.saturating_add(1);
                downlink.send(TargetToHost::Temporal(TemporalReport::Resumed {
                    job: id,
                    task_bytes: task_len as u32,
                    verify_ticks: sat(job.spent_ticks),
                }));
            }
        }
    }

    /// One window of search within `until` on `clock` (None: to the end).
    fn search(&mut self, clock: &mut dyn CpuClock, until: Option<u64>, hard_until: Option<u64>) {
        let t0 = clock.ticks();
        let Some(job) = self.job else {
            return;
        };
        if job.phase != Phase::Planning {
            return;
        }
        // A rover attempt's plan found in the window before: taken out of the search in this
        // one (see below).
        let extracting = job.outcome.is_some();
        let mut outcome = job.outcome;
        let mut most = job.most_step_ticks;
        let mut first_plan = job.first_plan_ticks;
        let mut most_elim = job.most_elim_ticks;
        let mut most_search = job.most_search_ticks;
        let mut ran = u32::from(extracting);
        // Setting the search up (the layout, the duplicate table, the relaxation's indexes,
        // the compression marks, the root) comes in pieces, in windows of their own: the whole
        // costs more than a window (satellite 2: about 54,000 ticks), so it is divided (see
        // `set_up_pieces`), and the search starts in the window after the last piece.
        if self.planner.is_none() {
            if let Err(r) = self.set_up() {
                outcome = Some(TemporalOutcome::OutOfMemory(region(r)));
            }
        }
        let mut most_set_up = job.most_set_up_ticks;
        let set_up = self.planner.as_ref().is_some_and(|p| p.setting_up());
        if let (None, Some(planner), true) = (outcome, self.planner.as_mut(), set_up) {
            let (done, most_piece, pieces) = set_up_pieces(
                planner,
                clock,
                (until, hard_until),
                most_set_up,
                job.stalled,
            );
            most_set_up = most_piece;
            ran = pieces;
            if done {
                outcome = match planner.status() {
                    Status::Searching => None,
                    Status::Solved => Some(TemporalOutcome::Solved),
                    Status::Unsolvable => Some(TemporalOutcome::Unsolvable),
                    Status::OutOfMemory(r) => Some(TemporalOutcome::OutOfMemory(region(r))),
                };
            }
        } else if self.planner.is_none() {
            ran = 1;
        }
        let mut ran_none = true;
        if let (None, Some(planner), false) = (outcome, self.planner.as_mut(), set_up) {
            let mut now = clock.ticks();
            loop {
                // Stop before an expansion that would end past the share, going by the
                // costliest one so far; the first of a window may use the rest of the window,
                // and runs whatever it costs after a window that ran none (progress).
                // The elimination after the search goes by its own costliest unit once it has
                // one (its units are cheaper than the search's costliest expansion, which
                // would leave them one a window).
                let improving = planner.improving();
                let pace = if improving && most_elim > 0 {
                    most_elim
                } else {
                    most
                };
                if let Some(u) = until {
                    if !piece_fits(now, pace, ran == 0, job.stalled, u, hard_until) {
                        break;
                    }
                }
                ran += 1;
                ran_none = false;
                let status = planner.step(EXPANSIONS_PER_CHECK);
                let after = clock.ticks();
                most = most.max(after.wrapping_sub(now));
                if improving {
                    most_elim = most_elim.max(after.wrapping_sub(now));
                }
                if first_plan.is_none() {
                    most_search = most;
                    if planner.has_plan() {
                        first_plan = Some(job.spent_ticks.wrapping_add(after.wrapping_sub(t0)));
                    }
                }
                now = after;
                outcome = match status {
                    Status::Searching => None,
                    Status::Solved => Some(TemporalOutcome::Solved),
                    Status::Unsolvable => Some(TemporalOutcome::Unsolvable),
                    Status::OutOfMemory(r) => Some(TemporalOutcome::OutOfMemory(region(r))),
                };
                let limit = job.config.max_expansions;
                if outcome.is_none() && limit > 0 && planner.stats().expanded >= u64::from(limit) {
                    outcome = Some(solved_if_plan(planner, TemporalOutcome::ExpansionLimit));
                }
                if outcome.is_some() {
                    break;
                }
            }
        }
        let spent = clock.ticks().wrapping_sub(t0);
        let Some(job) = self.job.as_mut() else {
            return;
        };
        job.spent_ticks = job.spent_ticks.wrapping_add(spent);
        job.most_step_ticks = most;
        job.most_set_up_ticks = most_set_up;
        job.first_plan_ticks = first_plan;
        job.most_elim_ticks = most_elim;
        job.most_search_ticks = most_search;
        job.stalled = ran_none && ran == 0;
        job.windows = job.windows.saturating_add(1);
        if outcome.is_none() && job.config.max_windows > 0 && job.windows >= job.config.max_windows
        {
            outcome = Some(
                self.planner
                    .as_ref()
                    .map_or(TemporalOutcome::WindowLimit, |p| {
                        solved_if_plan(p, TemporalOutcome::WindowLimit)
                    }),
            );
        }
        let Some(outcome) = outcome else {
            return;
        };
        job.outcome = Some(outcome);
        // Taking a rover attempt's plan out of the search (its steps' STN windows: work that
        // grows with the plan's length) waits for a window of its own when the search ran in
        // this one.
        if self.rover_attempt
            && !extracting
            && until.is_some()
            && outcome == TemporalOutcome::Solved
        {
            return;
        }
        job.phase = Phase::Reporting {
            next: 0,
            stats_sent: false,
            improved_sent: false,
        };
        if let Some(planner) = self.planner.as_mut() {
            job.stats = planner.stats();
            if outcome == TemporalOutcome::Solved {
                match planner.plan(self.plan) {
                    Some((n, makespan)) => {
                        job.plan_len = n;
                        job.makespan = makespan;
                        job.first_makespan =
                            planner.makespan_before_elimination().unwrap_or(makespan);
                    }
                    // Longer than the plan buffer (cannot happen with `max_steps` held to
                    // it): reported as a plan too long.
                    None => {
                        job.outcome = Some(TemporalOutcome::OutOfMemory(TemporalRegion::PlanLength))
                    }
                }
            }
        }
        // A rover mission's attempt gives its storage back: the mission reads the task buffer
        // in the next window.
        if self.rover_attempt {
            self.rover_replan_layout = self.planner.as_ref().map(|p| p.task().layout());
            self.planner = None;
        }
    }
}

impl PlannerPlugin for TemporalApp<'_> {
    fn name(&self) -> &'static str {
        "temporal"
    }

    fn handle(&mut self, msg: &HostToTarget, downlink: &mut dyn Downlink) -> bool {
        let started = self.receive_clock();
        match msg {
            HostToTarget::TemporalBegin {
                job,
                len,
                crc32,
                config,
            } => self.begin(*job, *len, *crc32, *config, downlink),
            HostToTarget::TemporalChunk { job, offset, bytes } => {
                self.chunk(*job, *offset, bytes, started, downlink)
            }
            HostToTarget::Rover { job, event } => {
                self.rover_event(*job, *event);
                return true;
            }
            _ => return false,
        }
        if self
            .job
            .is_some_and(|j| matches!(j.phase, Phase::Receiving { .. }))
        {
            self.receive_ticks = self
                .receive_ticks
                .wrapping_add(self.receive_clock().wrapping_sub(started));
        }
        true
    }

    fn planning_pending(&self) -> bool {
        self.rover_resume
            || self.rover_event.is_some()
            || self
                .rover
                .as_deref()
                .is_some_and(|m| m.building().is_some())
            || self.job.is_some_and(|j| {
                matches!(j.phase, Phase::Planning | Phase::Verifying { .. })
                    || (self.rover_attempt && matches!(j.phase, Phase::Reporting { .. }))
            })
    }

    fn busy(&self) -> bool {
        !self.rover_reports.is_empty()
            || (!self.rover_attempt
                && self
                    .job
                    .is_some_and(|j| matches!(j.phase, Phase::Reporting { .. })))
    }

    fn window(&mut self, w: &mut PluginWindow<'_, '_>) {
        if self.rover_resume {
            self.rover_resume_window(w.clock, w.until, w.hard_until);
            return;
        }
        if self.rover_window(w.clock, w.until, w.hard_until) {
            return;
        }
        if self
            .job
            .is_some_and(|j| matches!(j.phase, Phase::Verifying { .. }))
        {
            self.verify(w.clock, w.until, w.downlink);
            return;
        }
        self.search(w.clock, w.until, w.hard_until);
    }

    fn report(&mut self, mut room: usize, downlink: &mut dyn Downlink) {
        let rover_job = self.rover.as_deref().and_then(|m| m.job()).unwrap_or(0);
        while room > 0 {
            let Some(report) = self.rover_reports.pop_front() else {
                break;
            };
            downlink.send(TargetToHost::Temporal(TemporalReport::Rover {
                job: rover_job,
                report,
            }));
            room -= 1;
        }
        if self.rover_attempt {
            return;
        }
        let Some(job) = self.job.as_mut() else {
            return;
        };
        let Phase::Reporting {
            mut next,
            mut stats_sent,
            mut improved_sent,
        } = job.phase
        else {
            return;
        };
        while room > 0 && next < job.plan_len {
            let Some(a) = self.plan.get(next) else {
                break;
            };
            downlink.send(TargetToHost::Temporal(TemporalReport::Step {
                job: job.id,
                index: next as u16,
                action: a.action,
                start: a.start,
                duration: a.duration,
                start_lb: a.start_lb,
                start_ub: a.start_ub,
            }));
            next += 1;
            room -= 1;
        }
        if room > 0 && next >= job.plan_len && !stats_sent {
            let s = &job.stats;
            downlink.send(TargetToHost::Temporal(TemporalReport::Stats {
                job: job.id,
                expanded: sat(s.expanded),
                generated: sat(s.generated),
                evaluated: sat(s.evaluated),
                inconsistent: sat(s.inconsistent),
                duplicates: sat(s.duplicates),
                dead_ends: sat(s.dead_ends),
                nodes: sat(s.nodes),
                too_long: sat(s.too_long),
                shed: sat(s.shed),
                best_h: s.best_h,
            }));
            stats_sent = true;
            room -= 1;
        }
        if room > 0 && stats_sent && !improved_sent {
            let solved = job.outcome == Some(TemporalOutcome::Solved);
            downlink.send(TargetToHost::Temporal(TemporalReport::Improved {
                job: job.id,
                first_plan_ticks: job.first_plan_ticks.unwrap_or(job.spent_ticks),
                first_plan_steps: if solved {
                    (job.plan_len as u64 + job.stats.eliminated).min(u64::from(u16::MAX)) as u16
                } else {
                    0
                },
                first_makespan: if solved { job.first_makespan } else { 0 },
                elimination_checks: sat(job.stats.elimination_checks),
                worst_elimination_ticks: sat(job.most_elim_ticks),
            }));
            improved_sent = true;
            room -= 1;
        }
        job.phase = Phase::Reporting {
            next,
            stats_sent,
            improved_sent,
        };
        if room > 0 && improved_sent {
            let solved = job.outcome == Some(TemporalOutcome::Solved);
            downlink.send(TargetToHost::Temporal(TemporalReport::Done {
                job: job.id,
                outcome: job.outcome.unwrap_or(TemporalOutcome::Unsolvable),
                steps: if solved { job.plan_len as u16 } else { 0 },
                makespan: if solved { job.makespan } else { 0 },
                ticks_per_unit: job.ticks_per_unit,
                peak_arena_bytes: sat(job.stats.peak_words.saturating_mul(4)),
                arena_bytes: self.arena_bytes,
                planning_ticks: job.spent_ticks,
                windows: job.windows,
                worst_expansion_ticks: sat(job.most_search_ticks),
                worst_set_up_ticks: sat(job.most_set_up_ticks),
            }));
            self.finished = self.finished.saturating_add(1);
            self.end_job();
        }
    }
}

/// A limit reached while the elimination after the search improves the plan found: the job
/// is solved with the best plan so far (`temporal::Planner::plan` gives it); `limit` before
/// the search found one.
fn solved_if_plan(planner: &Planner<'_, '_>, limit: TemporalOutcome) -> TemporalOutcome {
    if planner.has_plan() {
        TemporalOutcome::Solved
    } else {
        limit
    }
}

/// A window's pieces of the search's set-up (`temporal::Planner::set_up_step`), within `until`
/// on `clock` (None: every piece at once), as expansions are: the window's first piece runs if
/// the costliest piece so far (`most`) fits before `hard_until`, or whatever it costs after a
/// window that ran none (`stalled`: progress); a piece that empties buckets (a small, fixed
/// amount of work) follows while the costliest piece still fits the share; any other piece
/// (the indexes, the compression marks, the root: each up to about an expansion's work) runs
/// only as the window's first, so no window takes two of them. Returns whether the set-up is
/// done, the costliest piece, and the pieces run.
fn set_up_pieces(
    planner: &mut Planner<'_, '_>,
    clock: &mut dyn CpuClock,
    (until, hard_until): (Option<u64>, Option<u64>),
    mut most: u64,
    stalled: bool,
) -> (bool, u64, u32) {
    let mut now = clock.ticks();
    let mut pieces = 0u32;
    loop {
        if let Some(u) = until {
            let first = pieces == 0;
            if !(piece_fits(now, most, first, stalled, u, hard_until)
                && (first || planner.next_set_up_piece_is_small()))
            {
                return (false, most, pieces);
            }
        }
        let more = planner.set_up_step();
        pieces += 1;
        let after = clock.ticks();
        most = most.max(after.wrapping_sub(now));
        now = after;
        if !more {
            return (true, most, pieces);
        }
    }
}

fn record_crc(words: &[u32]) -> u32 {
    let mut digest = TASK_CRC.digest();
    for w in words {
        digest.update(&w.to_be_bytes());
    }
    digest.finalize()
}

/// The record of an accepted job (see "A job kept across a warm reset" above).
fn encode_record(job: &Job) -> [u32; TEMPORAL_RESUME_RECORD_WORDS] {
    let mut words = [0u32; TEMPORAL_RESUME_RECORD_WORDS];
    words[0] = RESUME_MAGIC;
    words[1] = RESUME_VERSION;
    words[2] = u32::from(job.id);
    words[3] = job.len;
    words[4] = job.crc32;
    words[5] = job.task_at;
    words[6] = job.task_len;
    words[7] = job.ticks_per_unit;
    let mut config = [0u8; 24];
    config[..sdls::temporal::CONFIG_BYTES]
        .copy_from_slice(&sdls::temporal::config_bytes(&job.config));
    for (w, b) in words[8..14].iter_mut().zip(config.chunks_exact(4)) {
        *w = u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    }
    words[15] = record_crc(&words[..15]);
    words
}

/// The job a record describes, if it is a whole record (phase and costs are the caller's).
fn decode_record(words: &[u32; TEMPORAL_RESUME_RECORD_WORDS]) -> Option<Job> {
    if words[0] != RESUME_MAGIC
        || words[1] != RESUME_VERSION
        || words[14] != 0
        || words[15] != record_crc(&words[..15])
    {
        return None;
    }
    let mut config = [0u8; sdls::temporal::CONFIG_BYTES];
    let mut bytes = [0u8; 24];
    for (b, w) in bytes.chunks_exact_mut(4).zip(&words[8..14]) {
        b.copy_from_slice(&w.to_be_bytes());
    }
    config.copy_from_slice(&bytes[..sdls::temporal::CONFIG_BYTES]);
    let (len, task_at, task_len) = (words[3], words[5], words[6]);
    if task_at.checked_add(task_len)? > len || bytes[23] != 0 {
        return None;
    }
    let id = u16::try_from(words[2]).ok()?;
    let config = sdls::temporal::config_from_bytes(&config)?;
    Some(Job {
        task_at,
        task_len,
        phase: Phase::Verifying { checked: 0 },
        ticks_per_unit: words[7],
        ..Job::new(id, len, words[4], config)
    })
}

/// What the executive's side of the rover's decisions tells the mission
/// ([`TemporalApp::rover_from_executive`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FromExecutive {
    /// Step `step` of the flown network started at `at_ms`.
    Started { step: u16, at_ms: u32 },
    /// The flown plan no longer fits at `at_ms`, for `why`.
    Replan {
        at_ms: u32,
        why: fsw_bridge::temporal::RoverReplanWhy,
    },
}
