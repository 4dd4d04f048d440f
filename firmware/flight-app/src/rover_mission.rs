//! The rover mission's onboard side (issue 13 item 3, seed 001 section 5): dispatch, replay of
//! what happened into the mid-plan state, the replan task, the pause and carry decisions, the
//! dropping of opportunistic goals and each plan's dispatch network, in the planner partition.
//!
//! It runs inside the temporal plug-in ([`crate::TemporalApp`]), which already holds the task
//! and plans: the mission's task is an ordinary authenticated temporal job that
//! [`RoverEvent::Start`] named before it was uplinked; once accepted it stays in the task buffer
//! for the whole mission, and every attempt's replan task is written after it (at
//! [`ROVER_REPLAN_AT`]) and planned by the plug-in's search, across windows, as any job. The
//! host plays the rover and the world (when a started action ends, the rover's own estimate of
//! its end, obstacles, the arrival of opportunistic goals) and keeps the time; every decision
//! is taken here and reported ([`RoverReport`]): which action starts when (the
//! [`Dispatcher`] against the STN windows), when a step is past its ub, the pauses and carries,
//! the attempts and the goals dropped, the new network.
//!
//! Memory: a [`RoverMission`] is about 51 KB of fixed arrays (the dispatcher, the state, the
//! scratch of `network_from_plan`), zero-filled in place at the first `Start` (every field is an
//! integer, a bool or an array of them, so all-zero bytes are a valid, idle mission): a
//! partition (re)start costs nothing for it. Capacities are the named constants below; an
//! event beyond them is refused ([`RoverRefusal::Capacity`]), never a panic.
//!
//! A mission survives a reset of the partition: before it takes each event it checkpoints the
//! state the last one left ([`checkpoint`]), and after a (re)start the plug-in takes it up
//! again from there.
#![deny(clippy::indexing_slicing)]

#[path = "rover_checkpoint.rs"]
pub mod checkpoint;

use fsw_bridge::temporal::{
    RoverRefusal, RoverReplanWhy, RoverReport, RoverStartKind, TemporalOutcome,
};
use temporal::dispatch::{Decision, Dispatcher, MAX_DISPATCH_STEPS};
use temporal::replan::{self, Carried, ReplanInput};
use temporal::task::TaskLayout;
use temporal::task::UNBOUNDED;
use temporal::{PlannedAction, Task};

/// Where each attempt's replan task goes in the task buffer (the mission's own task, secured,
/// must fit before it): half of [`crate::MAX_TEMPORAL_TASK_BYTES`].
pub const ROVER_REPLAN_AT: usize = crate::MAX_TEMPORAL_TASK_BYTES / 2;
/// Most actions running at once on the rover.
pub const MAX_ROVER_ACTIVE: usize = 16;
/// Most opportunistic goals that arrive in one mission.
pub const MAX_ROVER_GOALS: usize = 16;
/// Most facts of the mission's task, in words of 32 (4,096 facts).
pub const MAX_ROVER_FACT_WORDS: usize = 128;
/// Most numeric variables of the mission's task.
pub const MAX_ROVER_NUMERICS: usize = 64;
/// Words of `network_from_plan`'s scratch: one per fact and numeric variable.
const SCRATCH_WORDS: usize = MAX_ROVER_FACT_WORDS * 32 + MAX_ROVER_NUMERICS;
/// Words of a readiness mask ([`RoverMission::ready_mask`]): a bit per step of a network.
pub const READY_MASK_WORDS: usize = (MAX_DISPATCH_STEPS + 1).div_ceil(32);
/// Which start steps of the flown network are ready in the state now.
pub type ReadyMask = [u32; READY_MASK_WORDS];
/// A start ready more than this before its lb was held to it (ticks: one second).
pub const HELD_MS: u32 = 1000;

/// How a start at mission-relative time `rel` (ms) stands to its planned window's lower bound
/// `lb` (issue 13 item 3): early (the network allowed it before lb), at lb, held to lb (the
/// start was ready `waited_ms` before lb and waited longer than [`HELD_MS`]: `held` is the
/// hold's (from, until) when it ended at this start), or late within (lb, ub]. One rule for the
/// mission's own dispatcher and the executive's decider ([`crate::rover_exec`]).
pub(crate) fn start_kind(rel: u32, lb: u32, held: Option<(u32, u32)>) -> RoverStartKind {
    let waited = held.map_or(0, |(from, until)| until.saturating_sub(from));
    if rel < lb {
        RoverStartKind::Early { by_ms: lb - rel }
    } else if rel == lb {
        if waited > HELD_MS {
            RoverStartKind::HeldToLb { waited_ms: waited }
        } else {
            RoverStartKind::AtLb
        }
    } else {
        RoverStartKind::Late { by_ms: rel - lb }
    }
}
/// "No step" in a report's action field.
pub const NO_ACTION: u16 = u16::MAX;

// The mission's phases (a plain integer, so that all-zero bytes are a valid mission).
/// No mission.
const IDLE: u8 = 0;
/// `Start` came: waiting for its job's task to be accepted.
const ARMED: u8 = 1;
/// The task is accepted; opportunistic goals known from the start may come, then the first
/// `Poll` plans.
const READY: u8 = 2;
/// Flying a plan (or waiting for events).
const FLYING: u8 = 3;
/// An attempt is being planned by the plug-in's search.
const PLANNING: u8 = 4;
/// No plan came: only `Close` is taken.
const STOPPED: u8 = 5;
/// A plan came: its dispatch network is being built, a piece per window.
const NETWORK: u8 = 6;

/// A running action on the rover, as the mission knows it.
#[derive(Clone, Copy, Debug, Default)]
struct Running {
    action: u16,
    started: u32,
    /// When it ends by the rover's own estimate (`Expected`), else by the task's duration.
    ends: u32,
    /// Its end step in the current network (0: none).
    end_step: u16,
}

/// What the plug-in must do after a mission step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RoverNext {
    /// Nothing: the answer is in the reports.
    Answered,
    /// Plan the replan task of `len` bytes at [`ROVER_REPLAN_AT`] with `max_expansions`.
    Plan { len: usize, max_expansions: u32 },
    /// The plan's network is being built: the next piece in the next window
    /// ([`RoverMission::network_piece`]), with the plan still in the plug-in's plan buffer.
    Building,
}

/// The onboard mission: see the module's documentation.
pub struct RoverMission {
    phase: u8,
    job: u16,
    horizon_slack: u32,
    max_expansions: u32,
    us_per_expansion: u32,
    /// The mission's task in the task buffer.
    task_at: usize,
    task_len: usize,
    /// The state now: the task's initial state with the executed happenings applied.
    facts: [u32; MAX_ROVER_FACT_WORDS],
    values: [i64; MAX_ROVER_NUMERICS],
    running: [Running; MAX_ROVER_ACTIVE],
    running_len: usize,
    /// Opportunistic goals that arrived (fact ids, arrival order), and which are still kept.
    arrived: [u16; MAX_ROVER_GOALS],
    kept: [bool; MAX_ROVER_GOALS],
    arrived_len: usize,
    /// The replan in progress: its time, the carried actions (in `running` order), the
    /// attempts made, the expansions spent, the goals in the current attempt.
    replan_at: u32,
    carried: [Carried; MAX_ROVER_ACTIVE],
    carried_len: usize,
    attempts: u16,
    expansions: u32,
    /// The last event's time (events come in time order).
    last_ms: u32,
    /// A plan is being dispatched: its epoch, each step's window when it was made.
    has_plan: bool,
    epoch: u32,
    planned: [(u32, u32); MAX_DISPATCH_STEPS + 1],
    dispatcher: Dispatcher,
    /// The last Wait's (until, when) if it named one: a poll at `until` finds the step that
    /// waited for it held to its lb.
    waited: bool,
    wait_until: u32,
    wait_at: u32,
    held: bool,
    held_until: u32,
    held_from: u32,
    scratch: [u32; SCRATCH_WORDS],
    /// The facts that are components' inactive states (5.1; `Inactive` events).
    inactive: [u32; MAX_ROVER_FACT_WORDS],
    /// The CPU of the current attempt's replan task, and its length.
    build_ticks: u32,
    replan_len: usize,
    /// The task's CRC-32, its fact words and numeric variables (for the checkpoint).
    task_crc: u32,
    fact_words: u16,
    numerics: u16,
    /// Events taken since the task was accepted.
    events: u32,
    /// Plans made (the network's generation), and the checkpoint's bookkeeping.
    plan_gen: u32,
    saved: checkpoint::Saved,
    /// The network being built (phase NETWORK): the plan's length (in the plug-in's plan
    /// buffer), how far the steps are, the costliest step so far, the CPU so far.
    plan_len: usize,
    progress: replan::NetworkProgress,
    step_most: u64,
    network_ticks: u64,
    /// Where the mission's task and the current attempt's replan task were validated: each is
    /// taken up again from its layout, not validated at every event (the task buffer holds
    /// them unchanged: nothing writes it while the mission flies).
    task_layout: TaskLayout,
    replan_layout: TaskLayout,
}

/// The mission's inputs each time it runs: the task buffer, the plan buffer, the CPU clock.
pub struct RoverCtx<'c> {
    pub task_buffer: &'c mut [u8],
    pub clock: &'c mut dyn crate::CpuClock,
    /// The window's share and its end (`PluginWindow`'s; None: no limit): a plan's network is
    /// built in pieces within them ([`crate::piece_fits`]).
    pub until: Option<u64>,
    pub hard_until: Option<u64>,
}

fn sat(v: u64) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

impl RoverMission {
    /// An idle mission (natively; on the target the partition zero-fills one in place, which
    /// is the same: every field is an integer, a bool or an array of them).
    pub fn new() -> Option<Self> {
        Some(Self {
            phase: IDLE,
            job: 0,
            horizon_slack: 0,
            max_expansions: 0,
            us_per_expansion: 0,
            task_at: 0,
            task_len: 0,
            facts: [0; MAX_ROVER_FACT_WORDS],
            values: [0; MAX_ROVER_NUMERICS],
            running: [Running::default(); MAX_ROVER_ACTIVE],
            running_len: 0,
            arrived: [0; MAX_ROVER_GOALS],
            kept: [false; MAX_ROVER_GOALS],
            arrived_len: 0,
            replan_at: 0,
            carried: [Carried {
                action: 0,
                remaining_lb: 0,
                remaining_ub: 0,
            }; MAX_ROVER_ACTIVE],
            carried_len: 0,
            attempts: 0,
            expansions: 0,
            last_ms: 0,
            has_plan: false,
            epoch: 0,
            planned: [(0, 0); MAX_DISPATCH_STEPS + 1],
            dispatcher: Dispatcher::new(temporal::dispatch::PlanNetwork::new(), 0).ok()?,
            waited: false,
            wait_until: 0,
            wait_at: 0,
            held: false,
            held_until: 0,
            held_from: 0,
            scratch: [0; SCRATCH_WORDS],
            inactive: [0; MAX_ROVER_FACT_WORDS],
            build_ticks: 0,
            replan_len: 0,
            task_crc: 0,
            fact_words: 0,
            numerics: 0,
            events: 0,
            plan_gen: 0,
            saved: checkpoint::Saved::NONE,
            plan_len: 0,
            progress: replan::NetworkProgress { next: 0, total: 0 },
            step_most: 0,
            network_ticks: 0,
            task_layout: TaskLayout::default(),
            replan_layout: TaskLayout::default(),
        })
    }

    /// Arm a new mission for job `job` (whatever this one was doing is forgotten).
    pub fn arm(&mut self, job: u16, horizon_slack: u32, max_expansions: u32, us_per_exp: u32) {
        self.phase = ARMED;
        self.job = job;
        self.horizon_slack = horizon_slack;
        self.max_expansions = max_expansions;
        self.us_per_expansion = us_per_exp;
        self.running_len = 0;
        self.arrived_len = 0;
        self.carried_len = 0;
        self.attempts = 0;
        self.expansions = 0;
        self.last_ms = 0;
        self.has_plan = false;
        self.epoch = 0;
        self.waited = false;
        self.held = false;
        self.inactive.iter_mut().for_each(|w| *w = 0);
        self.events = 0;
        self.plan_gen = 0;
        self.saved = checkpoint::Saved::NONE;
    }

    /// The job whose task the armed mission waits for.
    pub fn armed_for(&self) -> Option<u16> {
        (self.phase == ARMED).then_some(self.job)
    }

    /// The job of the mission flying (any phase but idle).
    pub fn job(&self) -> Option<u16> {
        (self.phase != IDLE).then_some(self.job)
    }

    /// Back to an idle mission (what a refused checkpoint leaves).
    fn reset_idle(&mut self) {
        self.phase = IDLE;
        self.running_len = 0;
        self.arrived_len = 0;
        self.carried_len = 0;
        self.has_plan = false;
        self.waited = false;
        self.held = false;
        self.events = 0;
        self.plan_gen = 0;
        self.saved = checkpoint::Saved::NONE;
        self.dispatcher.network_mut().clear();
    }

    /// An event is taken (after the checkpoint of the state before it).
    pub fn took_event(&mut self) {
        self.events = self.events.saturating_add(1);
    }

    /// Whether a mission is flying whose state a checkpoint should keep (its task accepted,
    /// not planning).
    pub fn checkpointable(&self) -> bool {
        matches!(self.phase, READY | FLYING | STOPPED)
    }

    /// The time of the last event taken.
    pub fn last_ms(&self) -> u32 {
        self.last_ms
    }

    /// Whether an attempt is being planned, or its plan's network built.
    pub fn planning(&self) -> bool {
        matches!(self.phase, PLANNING | NETWORK)
    }

    /// Whether a plan's network is being built (the next piece waits for a window), and the
    /// plan's length in the plug-in's plan buffer.
    pub fn building(&self) -> Option<usize> {
        (self.phase == NETWORK).then_some(self.plan_len)
    }

    /// The armed mission's task was accepted at `task_at`, `task_len` bytes of `buffer`.
    pub fn accepted(&mut self, buffer: &[u8], task_at: usize, task_len: usize) -> RoverReport {
        let bytes = buffer
            .get(task_at..task_at.saturating_add(task_len))
            .unwrap_or_default();
        let Ok(task) = Task::parse(bytes) else {
            self.phase = IDLE;
            return RoverReport::Refused {
                reason: RoverRefusal::BadTask,
            };
        };
        if task_at.saturating_add(task_len) > ROVER_REPLAN_AT
            || replan::fact_words(&task) > MAX_ROVER_FACT_WORDS
            || task.numeric_count() > MAX_ROVER_NUMERICS
        {
            self.phase = IDLE;
            return RoverReport::Refused {
                reason: RoverRefusal::Capacity,
            };
        }
        if replan::initial_state(&task, &mut self.facts, &mut self.values).is_err() {
            self.phase = IDLE;
            return RoverReport::Refused {
                reason: RoverRefusal::BadTask,
            };
        }
        self.task_at = task_at;
        self.task_len = task_len;
        self.task_crc = checkpoint::crc32(bytes);
        self.task_layout = task.layout();
        self.fact_words = replan::fact_words(&task) as u16;
        self.numerics = task.numeric_count() as u16;
        self.phase = READY;
        RoverReport::Ready {
            facts: sat(task.fact_count() as u64),
            actions: sat(task.action_count() as u64),
        }
    }

    fn task<'b>(&self, buffer: &'b [u8]) -> Option<Task<'b>> {
        let bytes = buffer.get(self.task_at..self.task_at.saturating_add(self.task_len))?;
        Task::from_layout(bytes, &self.task_layout)
    }

    /// The event's time is not before the last one's.
    fn in_order(&mut self, at: u32, out: &mut dyn FnMut(RoverReport)) -> bool {
        if at < self.last_ms {
            out(RoverReport::Refused {
                reason: RoverRefusal::OutOfOrder {
                    last_ms: self.last_ms,
                },
            });
            return false;
        }
        true
    }

    fn refuse(out: &mut dyn FnMut(RoverReport), reason: RoverRefusal) -> RoverNext {
        out(RoverReport::Refused { reason });
        RoverNext::Answered
    }

    /// An opportunistic goal arrived at `at`.
    pub fn goal(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        fact: u16,
        at: u32,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if !matches!(self.phase, READY | FLYING) {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let f = usize::from(fact);
        let arrived = self.arrived.get(..self.arrived_len).unwrap_or_default();
        if f >= task.fact_count() || task.goal_facts().contains(f) || arrived.contains(&fact) {
            return Self::refuse(out, RoverRefusal::UnknownGoal { fact });
        }
        if self.arrived_len >= MAX_ROVER_GOALS {
            return Self::refuse(out, RoverRefusal::Capacity);
        }
        if !self.in_order(at, out) {
            return RoverNext::Answered;
        }
        self.last_ms = at;
        if let (Some(a), Some(k)) = (
            self.arrived.get_mut(self.arrived_len),
            self.kept.get_mut(self.arrived_len),
        ) {
            *a = fact;
            *k = true;
        }
        self.arrived_len += 1;
        if self.phase == READY {
            out(RoverReport::Optional { fact });
            return RoverNext::Answered;
        }
        self.replan(ctx, at, RoverReplanWhy::Goal { fact }, out)
    }

    /// Fact `fact` is a component's inactive state (taken before the first plan).
    pub fn inactive(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        fact: u16,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if self.phase != READY {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let f = usize::from(fact);
        let Some(w) = self
            .inactive
            .get_mut(f / 32)
            .filter(|_| f < task.fact_count())
        else {
            return Self::refuse(out, RoverRefusal::UnknownGoal { fact });
        };
        *w |= 1 << (f % 32);
        out(RoverReport::InactiveTaken { fact });
        RoverNext::Answered
    }

    /// The rover's own estimate of when running action `action` ends.
    pub fn expected(
        &mut self,
        action: u16,
        ends: u32,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if !matches!(self.phase, FLYING) {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        let n = self.running_len;
        let Some(r) = self
            .running
            .get_mut(..n)
            .and_then(|rs| rs.iter_mut().find(|r| r.action == action))
        else {
            return Self::refuse(out, RoverRefusal::NotRunning { action });
        };
        if ends < r.started {
            return Self::refuse(out, RoverRefusal::OutOfOrder { last_ms: r.started });
        }
        r.ends = ends;
        out(RoverReport::ExpectedTaken { action });
        RoverNext::Answered
    }

    /// The rover says `action` ended at `at`: its end effects, its end step executed.
    pub fn ended(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        action: u16,
        at: u32,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if !matches!(self.phase, FLYING | STOPPED) {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        let n = self.running_len;
        let found = self
            .running
            .get(..n)
            .unwrap_or_default()
            .iter()
            .position(|r| r.action == action);
        let Some((i, r)) = found.and_then(|i| Some((i, *self.running.get(i)?))) else {
            return Self::refuse(out, RoverRefusal::NotRunning { action });
        };
        if !self.in_order(at, out) {
            return RoverNext::Answered;
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        if replan::apply(
            &task,
            usize::from(action),
            true,
            &mut self.facts,
            &mut self.values,
        )
        .is_err()
        {
            return Self::refuse(out, RoverRefusal::BadTask);
        }
        self.last_ms = at;
        if let Some(rs) = self.running.get_mut(i..n) {
            rs.rotate_left(1);
        }
        self.running_len -= 1;
        if self.has_plan && r.end_step != 0 {
            // Executed already (cannot happen for a step the mission set): nothing changes.
            let _ = self
                .dispatcher
                .executed(usize::from(r.end_step), at.saturating_sub(self.epoch));
        }
        out(RoverReport::EndTaken { action });
        RoverNext::Answered
    }

    /// The plan being flown, as the executive needs it to dispatch it (see [`crate::rover_exec`]):
    /// its generation, its epoch (mission time of its time 0) and the dispatcher holding its
    /// network (the windows as planned, the completions of carried actions executed at 0).
    /// None while no plan is flown (before the first, while planning, stopped).
    pub fn flying_plan(&self) -> Option<(u32, u32, &Dispatcher)> {
        (self.phase == FLYING && self.has_plan).then_some((
            self.plan_gen,
            self.epoch,
            &self.dispatcher,
        ))
    }

    /// The mission's task's action count (the actions after it in a replan task are the
    /// completions of carried actions).
    pub fn base_actions(&self, task_buffer: &[u8]) -> Option<u16> {
        u16::try_from(self.task(task_buffer)?.action_count()).ok()
    }

    /// The actions running on the rover with their end steps in the current network (0: none),
    /// in the mission's order.
    pub fn running_ends(&self) -> impl Iterator<Item = (u16, u16)> + '_ {
        self.running
            .iter()
            .take(self.running_len)
            .map(|r| (r.action, r.end_step))
    }

    /// Steps of the flown network this mission has executed (the readiness mask's stamp,
    /// see [`crate::rover_exec::RoverDecider::set_ready`]). None while no plan is flown.
    pub fn executed_steps(&self) -> Option<u16> {
        let (_, _, d) = self.flying_plan()?;
        Some(crate::rover_exec::executed_steps(d))
    }

    /// The readiness of the flown network's start steps in the state now (the facts and
    /// numeric values only this partition keeps): bit `k` is set when step `k` starts an
    /// action [`Self::poll`] takes as ready (a completion of a carried action, or one whose
    /// at-start conditions hold). The state changes only by the happenings the mission
    /// applies (a start, an end, a pause), so a mask made after each of them answers every
    /// poll until the next as `poll`'s own readiness does. None while no plan is flown.
    pub fn ready_mask(&self, task_buffer: &[u8]) -> Option<ReadyMask> {
        let (_, _, d) = self.flying_plan()?;
        let task = self.task(task_buffer)?;
        let base_actions = task.action_count();
        let mut mask = [0u32; READY_MASK_WORDS];
        let net = d.network();
        for k in 1..=net.step_count() {
            let Some(s) = net.step(k) else { continue };
            if s.end {
                continue;
            }
            let a = usize::from(s.action);
            if a >= base_actions || replan::start_holds(&task, a, &self.facts, &self.values) {
                if let Some(w) = mask.get_mut(k / 32) {
                    *w |= 1 << (k % 32);
                }
            }
        }
        Some(mask)
    }

    /// The executive started step `step` of the flown network at mission time `at` (its
    /// `Dispatch`, taken there with this mission's readiness mask, see [`crate::rover_exec`]):
    /// the start's effects applied to the state now, the action running, the step executed in
    /// this mission's copy of the network, as [`Self::poll`] does for a start it decides. No
    /// report unless refused (the executive reported the start).
    pub fn started(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        step: u16,
        at: u32,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if self.phase != FLYING || !self.has_plan {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        if !self.in_order(at, out) {
            return RoverNext::Answered;
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let k = usize::from(step);
        let Some(s) = self.dispatcher.network().step(k).filter(|s| !s.end) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        if self.running_len >= MAX_ROVER_ACTIVE {
            return Self::refuse(out, RoverRefusal::Capacity);
        }
        if self
            .dispatcher
            .executed(k, at.saturating_sub(self.epoch))
            .is_err()
        {
            return Self::refuse(out, RoverRefusal::BadTask);
        }
        if replan::apply(
            &task,
            usize::from(s.action),
            false,
            &mut self.facts,
            &mut self.values,
        )
        .is_err()
        {
            return Self::refuse(out, RoverRefusal::BadTask);
        }
        self.last_ms = at;
        let end_step = self.dispatcher.network().end_of(k).unwrap_or(0);
        let estimate = task.action(usize::from(s.action)).duration_lb;
        if let Some(r) = self.running.get_mut(self.running_len) {
            *r = Running {
                action: s.action,
                started: at,
                ends: at.saturating_add(estimate),
                end_step: u16::try_from(end_step).unwrap_or(0),
            };
        }
        self.running_len += 1;
        RoverNext::Answered
    }

    /// The executive found the flown plan no longer fits at `at` (its `Replan` decision, for
    /// `why`): replan as [`Self::poll`] does when it decides so.
    pub fn replan_requested(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        at: u32,
        why: RoverReplanWhy,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if self.phase != FLYING || !self.has_plan {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        if !self.in_order(at, out) {
            return RoverNext::Answered;
        }
        self.last_ms = at;
        self.replan(ctx, at, why, out)
    }

    /// The time is `now`: decide.
    pub fn poll(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        now: u32,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if self.phase == READY {
            if !self.in_order(now, out) {
                return RoverNext::Answered;
            }
            self.last_ms = now;
            return self.replan(ctx, now, RoverReplanWhy::Initial, out);
        }
        if self.phase != FLYING || !self.has_plan {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        if !self.in_order(now, out) {
            return RoverNext::Answered;
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        self.last_ms = now;
        let t0 = ctx.clock.ticks();
        // The first poll after a Wait: at the time it named, the step that waited is held.
        if self.waited {
            self.waited = false;
            self.held = self.wait_until == now;
            self.held_until = self.wait_until;
            self.held_from = self.wait_at;
        }
        let base_actions = task.action_count();
        let epoch = self.epoch;
        let rel = now.saturating_sub(epoch);
        let (facts, values) = (&self.facts, &self.values);
        let ready = |a: u16| {
            usize::from(a) >= base_actions
                || replan::start_holds(&task, usize::from(a), facts, values)
        };
        match self.dispatcher.poll(rel, &ready) {
            Decision::Start { step, action } => {
                let (lb, ub) = self.planned.get(step).copied().unwrap_or((0, 0));
                if self.dispatcher.executed(step, rel).is_err() {
                    return Self::refuse(out, RoverRefusal::BadTask);
                }
                if self.running_len >= MAX_ROVER_ACTIVE {
                    return Self::refuse(out, RoverRefusal::Capacity);
                }
                let end_step = self.dispatcher.network().end_of(step).unwrap_or(0);
                let held = (self.held && self.held_until == now)
                    .then_some((self.held_from, self.held_until));
                let kind = start_kind(rel, lb, held);
                if replan::apply(
                    &task,
                    usize::from(action),
                    false,
                    &mut self.facts,
                    &mut self.values,
                )
                .is_err()
                {
                    return Self::refuse(out, RoverRefusal::BadTask);
                }
                let estimate = task.action(usize::from(action)).duration_lb;
                if let Some(r) = self.running.get_mut(self.running_len) {
                    *r = Running {
                        action,
                        started: now,
                        ends: now.saturating_add(estimate),
                        end_step: u16::try_from(end_step).unwrap_or(0),
                    };
                }
                self.running_len += 1;
                let poll_ticks = sat(ctx.clock.ticks().wrapping_sub(t0));
                out(RoverReport::Dispatch {
                    step: step as u16,
                    action,
                    at_ms: now,
                    lb_ms: lb.saturating_add(epoch),
                    ub_ms: ub.saturating_add(epoch),
                    kind,
                    poll_ticks,
                });
                RoverNext::Answered
            }
            Decision::Replan { step, ub } => {
                let executed = self.dispatcher.executed_at(step).is_some();
                let (action, end) = self
                    .dispatcher
                    .network()
                    .step(step)
                    .map_or((NO_ACTION, false), |s| (s.action, s.end));
                let step16 = u16::try_from(step).unwrap_or(u16::MAX);
                let why = if executed {
                    RoverReplanWhy::NoLongerFits {
                        step: step16,
                        action,
                        end,
                    }
                } else {
                    RoverReplanWhy::PastUb {
                        step: step16,
                        action,
                        end,
                        ub_ms: ub.saturating_add(epoch),
                    }
                };
                self.replan(ctx, now, why, out)
            }
            Decision::Wait { until } => {
                // Wake at a ready step's lb, or just past the earliest ub of a step not yet
                // executed (an overrun is noticed when it happens).
                let d = &self.dispatcher;
                let steps = d.network().step_count();
                let earliest_ub = (1..=steps)
                    .filter(|&k| d.executed_at(k).is_none())
                    .filter_map(|k| d.window(k).map(|w| w.1))
                    .filter(|&ub| ub != UNBOUNDED)
                    .min()
                    .map(|ub| ub.saturating_add(epoch).saturating_add(1));
                let until = until.map(|u| u.saturating_add(epoch));
                let wake = [until, earliest_ub]
                    .into_iter()
                    .flatten()
                    .filter(|&x| x > now)
                    .min();
                self.waited = true;
                self.wait_until = until.unwrap_or(UNBOUNDED);
                self.wait_at = now;
                let poll_ticks = sat(ctx.clock.ticks().wrapping_sub(t0));
                out(RoverReport::Wait {
                    wake_ms: wake,
                    poll_ticks,
                });
                RoverNext::Answered
            }
            Decision::Finished => {
                out(RoverReport::Finished);
                RoverNext::Answered
            }
        }
    }

    /// The run is over: the goals that hold, the opportunistic goals kept.
    pub fn close(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        now: u32,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if !matches!(self.phase, READY | FLYING | STOPPED) {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        if !self.in_order(now, out) {
            return RoverNext::Answered;
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let arrived = self.arrived.get(..self.arrived_len).unwrap_or_default();
        let goals = task.goal_facts();
        for f in 0..task.fact_count() {
            let is_goal = goals.contains(f) || arrived.iter().any(|&g| usize::from(g) == f);
            if is_goal && replan::fact(&self.facts, f) {
                out(RoverReport::Achieved { fact: f as u16 });
            }
        }
        for (g, k) in arrived.iter().zip(&self.kept) {
            if *k {
                out(RoverReport::Kept { fact: *g });
            }
        }
        out(RoverReport::Closed);
        self.phase = IDLE;
        RoverNext::Answered
    }

    /// Plan from `t`: nothing new is dispatched, pausable running actions go back to their
    /// inactive state, the others are carried; then the first attempt.
    fn replan(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        t: u32,
        why: RoverReplanWhy,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        let Some(task) = self.task(ctx.task_buffer) else {
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        out(RoverReport::Replan { at_ms: t, why });
        // A component's inactive state is a fact named `(inactive-...)` (the `inactive-`
        // convention of `temporal::replan`).
        let marks = &self.inactive;
        let inactive = |f: usize| replan::fact(marks, f);
        let n = self.running_len;
        let mut keep = 0usize;
        self.carried_len = 0;
        for i in 0..n {
            let Some(r) = self.running.get(i).copied() else {
                break;
            };
            if replan::is_pausable(&task, usize::from(r.action), &inactive) {
                if replan::pause(&task, usize::from(r.action), &mut self.facts).is_err() {
                    return Self::refuse(out, RoverRefusal::BadTask);
                }
                out(RoverReport::Paused { action: r.action });
            } else {
                let left = r.ends.saturating_sub(t);
                if let Some(c) = self.carried.get_mut(self.carried_len) {
                    *c = Carried {
                        action: r.action,
                        remaining_lb: left,
                        remaining_ub: left,
                    };
                }
                self.carried_len += 1;
                if let Some(slot) = self.running.get_mut(keep) {
                    *slot = r;
                }
                keep += 1;
            }
        }
        self.running_len = keep;
        for i in 0..keep {
            if let Some(r) = self.running.get(i) {
                out(RoverReport::Carried {
                    action: r.action,
                    since_ms: r.started,
                    left_ms: r.ends.saturating_sub(t),
                });
            }
        }
        self.has_plan = false;
        self.waited = false;
        self.held = false;
        self.replan_at = t;
        self.attempts = 0;
        self.expansions = 0;
        self.attempt(ctx, out)
    }

    /// Builds the next attempt's replan task (the state now, the carried actions, the goals
    /// still kept) at [`ROVER_REPLAN_AT`].
    fn attempt(&mut self, ctx: &mut RoverCtx<'_>, out: &mut dyn FnMut(RoverReport)) -> RoverNext {
        let t0 = ctx.clock.ticks();
        let mut extra = [0u16; MAX_ROVER_GOALS];
        let mut extras = 0usize;
        for (g, k) in self.arrived.iter().zip(&self.kept).take(self.arrived_len) {
            if *k {
                if let Some(e) = extra.get_mut(extras) {
                    *e = *g;
                }
                extras += 1;
            }
        }
        let extra = extra.get(..extras).unwrap_or_default();
        let (base, rest) = ctx
            .task_buffer
            .split_at_mut(ROVER_REPLAN_AT.min(ctx.task_buffer.len()));
        let Some(task) = base
            .get(self.task_at..self.task_at.saturating_add(self.task_len))
            .and_then(|b| Task::from_layout(b, &self.task_layout))
        else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let written = replan::write_replan_task(
            &ReplanInput {
                task,
                now: self.replan_at,
                facts: &self.facts,
                values: &self.values,
                carried: self.carried.get(..self.carried_len).unwrap_or_default(),
                extra_goals: extra,
            },
            rest,
        );
        let Ok(len) = written else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        for &fact in extra {
            out(RoverReport::AttemptGoal { fact });
        }
        self.build_ticks = sat(ctx.clock.ticks().wrapping_sub(t0));
        self.replan_len = len;
        self.phase = PLANNING;
        RoverNext::Plan {
            len,
            max_expansions: self.max_expansions,
        }
    }

    /// The attempt's search ended: report it; a plan becomes the network dispatched from now
    /// on; without one, the newest opportunistic goal still kept is dropped and the next
    /// attempt built, or the mission stops.
    #[allow(clippy::too_many_arguments)]
    pub fn attempt_ended(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        outcome: TemporalOutcome,
        stats: &temporal::Stats,
        planning_ticks: u64,
        plan: &[PlannedAction],
        makespan: u32,
        replan_layout: Option<TaskLayout>,
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if self.phase != PLANNING {
            return Self::refuse(out, RoverRefusal::NoMission);
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        self.attempts = self.attempts.saturating_add(1);
        let expanded = sat(stats.expanded);
        self.expansions = self.expansions.saturating_add(expanded);
        let solved = outcome == TemporalOutcome::Solved;
        out(RoverReport::Attempt {
            index: self.attempts,
            hard_goals: u16::try_from(task.goal_facts().len()).unwrap_or(u16::MAX),
            outcome,
            actions: if solved { plan.len() as u16 } else { 0 },
            expanded,
            peak_arena_bytes: sat(stats.peak_words.saturating_mul(4)),
            build_ticks: self.build_ticks,
            planning_ticks,
        });
        if !solved {
            // Drop the newest opportunistic goal still kept, and try again.
            let newest = (0..self.arrived_len)
                .rev()
                .find(|&i| self.kept.get(i).copied().unwrap_or(false));
            return match newest {
                Some(i) => {
                    if let Some(k) = self.kept.get_mut(i) {
                        *k = false;
                    }
                    let fact = self.arrived.get(i).copied().unwrap_or(0);
                    out(RoverReport::Dropped { fact });
                    self.attempt(ctx, out)
                }
                None => {
                    out(RoverReport::NoPlan);
                    self.phase = STOPPED;
                    RoverNext::Answered
                }
            };
        }
        let t0 = ctx.clock.ticks();
        // The replan task as the search validated it (its layout), or validated here.
        let bytes = ctx
            .task_buffer
            .get(ROVER_REPLAN_AT..ROVER_REPLAN_AT.saturating_add(self.replan_len))
            .unwrap_or_default();
        let new_task = match replan_layout.and_then(|l| Task::from_layout(bytes, &l)) {
            Some(t) => Some(t),
            None => Task::parse(bytes).ok(),
        };
        let Some(new_task) = new_task else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        self.replan_layout = new_task.layout();
        let net = self.dispatcher.network_mut();
        let Ok(progress) = replan::network_from_plan_begin(&new_task, plan, &mut self.scratch, net)
        else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let _ = makespan;
        self.progress = progress;
        self.plan_len = plan.len();
        self.step_most = 0;
        self.network_ticks = u64::from(sat(ctx.clock.ticks().wrapping_sub(t0)));
        self.phase = NETWORK;
        self.network_piece(ctx, plan, out)
    }

    /// A window's piece of the plan's network (phase NETWORK): its steps in time order, each
    /// with the constraints into it, while the costliest step so far fits the window's share
    /// (the first of a window always runs); then, first in the window after the last step's,
    /// the dispatcher's windows over the whole network and the new plan's reports. The network
    /// is `network_from_plan`'s whatever the pieces.
    pub fn network_piece(
        &mut self,
        ctx: &mut RoverCtx<'_>,
        plan: &[PlannedAction],
        out: &mut dyn FnMut(RoverReport),
    ) -> RoverNext {
        if self.phase != NETWORK || plan.len() != self.plan_len {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        }
        let t0 = ctx.clock.ticks();
        let Some(new_task) = ctx
            .task_buffer
            .get(ROVER_REPLAN_AT..ROVER_REPLAN_AT.saturating_add(self.replan_len))
            .and_then(|b| Task::from_layout(b, &self.replan_layout))
        else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let (until, hard_until) = (ctx.until, ctx.hard_until);
        let clock = &mut *ctx.clock;
        let mut last = clock.ticks();
        let mut most = self.step_most;
        let mut fits = || {
            let now = clock.ticks();
            most = most.max(now.wrapping_sub(last));
            last = now;
            until.is_none_or(|u| crate::piece_fits(now, most, false, false, u, hard_until))
        };
        let steps_done = if self.progress.next < self.progress.total {
            let net = self.dispatcher.network_mut();
            match replan::network_from_plan_steps(
                &new_task,
                plan,
                true,
                &mut self.scratch,
                net,
                &mut self.progress,
                &mut fits,
            ) {
                // The rest (the dispatcher's windows over the whole network, an STN
                // propagation that costs several steps' work) in a window of its own.
                Ok(_) => false,
                Err(_) => {
                    self.phase = STOPPED;
                    return Self::refuse(out, RoverRefusal::BadTask);
                }
            }
        } else {
            true
        };
        self.step_most = most;
        if !steps_done {
            self.network_ticks = self
                .network_ticks
                .saturating_add(ctx.clock.ticks().wrapping_sub(t0));
            return RoverNext::Building;
        }
        let Some(task) = self.task(ctx.task_buffer) else {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        };
        let t = self.replan_at;
        let makespan_net = self.dispatcher.network().makespan;
        if self
            .dispatcher
            .restart(makespan_net.saturating_add(self.horizon_slack))
            .is_err()
        {
            self.phase = STOPPED;
            return Self::refuse(out, RoverRefusal::BadTask);
        }
        let steps = self.dispatcher.network().step_count();
        for k in 0..=steps {
            if let Some(p) = self.planned.get_mut(k) {
                *p = self.dispatcher.window(k).unwrap_or((0, 0));
            }
        }
        // The completions start at the epoch: they are the carried actions going on.
        let base_actions = task.action_count();
        for k in 1..=steps {
            let Some(s) = self.dispatcher.network().step(k) else {
                continue;
            };
            if s.end || usize::from(s.action) < base_actions {
                continue;
            }
            let i = usize::from(s.action) - base_actions;
            let _ = self.dispatcher.executed(k, 0);
            let end = self.dispatcher.network().end_of(k).unwrap_or(0);
            if let Some(r) = self.running.get_mut(i) {
                r.end_step = u16::try_from(end).unwrap_or(0);
            }
        }
        // Steps of actions still running that the new network does not have.
        let network_ticks = sat(self
            .network_ticks
            .saturating_add(ctx.clock.ticks().wrapping_sub(t0)));
        out(RoverReport::NewPlan {
            actions: plan.len() as u16,
            makespan_ms: makespan_net,
            network_ticks,
        });
        for (i, p) in plan.iter().enumerate() {
            out(RoverReport::PlanStep {
                index: i as u16,
                action: p.action,
                start_ms: t.saturating_add(p.start),
                duration_ms: p.duration,
                lb_ms: t.saturating_add(p.start_lb),
                ub_ms: t.saturating_add(p.start_ub),
            });
        }
        let planning = u64::from(self.expansions)
            .saturating_mul(u64::from(self.us_per_expansion))
            .saturating_add(500)
            / 1000;
        out(RoverReport::PlanningTakes {
            expansions: self.expansions,
            until_ms: t.saturating_add(sat(planning)),
        });
        self.has_plan = true;
        self.epoch = t;
        self.plan_gen = self.plan_gen.wrapping_add(1);
        self.phase = FLYING;
        RoverNext::Answered
    }
}
