//! Flexible dispatch of a temporal plan (seed 001, section 5.2).
//!
//! A plan is not a timetable: its steps (each action's start and end, step 0 the plan's epoch)
//! are bound only by the temporal constraints the search recreated from it (orderings,
//! durations, timed-literal windows) and by its makespan. [`PlanNetwork`] holds that network;
//! [`Dispatcher`] executes it. Every time it is asked it works the windows out again from what
//! has happened (the times at which steps were executed, and that nothing not yet executed can
//! happen before now): each step's window [lb, ub] is its earliest and latest time in a
//! schedule that keeps the makespan. So a late start or an action that overruns its duration
//! narrows what follows, and an early one widens it.
//!
//! The rule for a start: the action of a step whose predecessors have all been executed starts
//! at `lb` if it is ready early (the dispatcher says when to ask again), and at once when it is
//! ready within (lb, ub]. A step that can no longer be executed inside its window (its ub has
//! passed, or what happened leaves no schedule within the makespan) asks for a replan, naming
//! the step. Ends are not dispatched: the executive reports when an action ended
//! ([`Dispatcher::executed`]).
//!
//! `no_std`, heap-free: a network holds at most [`MAX_DISPATCH_STEPS`] steps and
//! [`MAX_DISPATCH_CONSTRAINTS`] constraints. Times are ticks since the plan's epoch.
#![deny(clippy::indexing_slicing)]

use crate::constraints::Constraint;
use crate::stn;
use crate::task::UNBOUNDED;

#[path = "dispatch/sliced.rs"]
mod sliced;
pub use sliced::MAX_DEFERRED;

/// Most plan steps a [`PlanNetwork`] holds (two per action; step 0, the epoch, not counted).
pub const MAX_DISPATCH_STEPS: usize = 256;
/// Most constraints a [`PlanNetwork`] holds.
pub const MAX_DISPATCH_CONSTRAINTS: usize = 2048;
/// Words of a bit set over the steps (the epoch included).
const BLOCKED_WORDS: usize = (MAX_DISPATCH_STEPS + 1).div_ceil(32);

/// One step of a plan: the start or the end of an action, and its window from timed literals
/// (`(0, UNBOUNDED)` for none).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlanStep {
    pub action: u16,
    pub end: bool,
    pub window: (u32, u32),
}

/// Why a network could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NetworkError {
    /// More steps than [`MAX_DISPATCH_STEPS`].
    TooManySteps,
    /// More constraints than [`MAX_DISPATCH_CONSTRAINTS`].
    TooManyConstraints,
    /// A constraint names a step the network does not have.
    UnknownStep,
    /// The planner has no plan.
    NoPlan,
    /// The network has no schedule within the horizon.
    Inconsistent,
}

/// A plan's steps and the temporal constraints between them (`t[after] - t[before]` in
/// `[lb, ub]`; step 0 is the epoch, step k is `steps[k - 1]`), and its makespan.
#[derive(Clone, Debug)]
pub struct PlanNetwork {
    steps: [PlanStep; MAX_DISPATCH_STEPS],
    step_count: usize,
    constraints: [Constraint; MAX_DISPATCH_CONSTRAINTS],
    constraint_count: usize,
    pub makespan: u32,
}

const NO_CONSTRAINT: Constraint = Constraint {
    before: 0,
    after: 0,
    lb: 0,
    ub: UNBOUNDED,
};

impl Default for PlanNetwork {
    fn default() -> Self {
        Self::new()
    }
}

impl PlanNetwork {
    pub const fn new() -> Self {
        Self {
            steps: [PlanStep {
                action: 0,
                end: false,
                window: (0, UNBOUNDED),
            }; MAX_DISPATCH_STEPS],
            step_count: 0,
            constraints: [NO_CONSTRAINT; MAX_DISPATCH_CONSTRAINTS],
            constraint_count: 0,
            makespan: 0,
        }
    }

    /// Empties the network.
    pub fn clear(&mut self) {
        self.step_count = 0;
        self.constraint_count = 0;
        self.makespan = 0;
    }

    /// Adds a step; returns its index (1 for the first).
    pub fn add_step(&mut self, step: PlanStep) -> Result<usize, NetworkError> {
        let slot = self
            .steps
            .get_mut(self.step_count)
            .ok_or(NetworkError::TooManySteps)?;
        *slot = step;
        self.step_count += 1;
        Ok(self.step_count)
    }

    /// Adds a constraint between steps already added (or step 0).
    pub fn add_constraint(&mut self, c: Constraint) -> Result<(), NetworkError> {
        if usize::from(c.before) > self.step_count || usize::from(c.after) > self.step_count {
            return Err(NetworkError::UnknownStep);
        }
        let slot = self
            .constraints
            .get_mut(self.constraint_count)
            .ok_or(NetworkError::TooManyConstraints)?;
        *slot = c;
        self.constraint_count += 1;
        Ok(())
    }

    /// Number of steps (the epoch not counted).
    pub fn step_count(&self) -> usize {
        self.step_count
    }

    /// Step `k` (1-based; None for 0 or past the last).
    pub fn step(&self, k: usize) -> Option<PlanStep> {
        k.checked_sub(1)
            .and_then(|i| self.steps.get(..self.step_count)?.get(i).copied())
    }

    pub fn constraints(&self) -> &[Constraint] {
        self.constraints.get(..self.constraint_count).unwrap_or(&[])
    }

    /// The step that ends the action started at step `start`.
    pub fn end_of(&self, start: usize) -> Option<usize> {
        let s = self.step(start)?;
        (start + 1..=self.step_count)
            .find(|&k| self.step(k).is_some_and(|e| e.end && e.action == s.action))
    }
}

/// What the executive should do now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Start the action of step `step` now.
    Start { step: usize, action: u16 },
    /// Nothing to start now: ask again at `until` (a ready step's lb), or when something is
    /// reported (an action ended, an action became ready) if None.
    Wait { until: Option<u32> },
    /// Step `step` can no longer be executed within its window (its latest time `ub` has
    /// passed, or what happened leaves no schedule within the makespan): replan.
    Replan { step: usize, ub: u32 },
    /// Every step has been executed.
    Finished,
}

/// Executes a [`PlanNetwork`]: see the module's documentation.
#[derive(Clone, Debug)]
pub struct Dispatcher {
    net: PlanNetwork,
    /// The time each step was executed at (UNBOUNDED: not yet); index 0 is the epoch.
    done: [u32; MAX_DISPATCH_STEPS + 1],
    est: [u32; MAX_DISPATCH_STEPS + 1],
    lst: [u32; MAX_DISPATCH_STEPS + 1],
    /// Latest time of any step: the makespan kept, or later if the caller allows.
    horizon: u32,
    /// `est` is the least schedule worked out at `est_now` for the steps executed then, and
    /// what was executed since keeps it a lower bound of the next one (see [`Self::executed`]):
    /// the next propagation may start from it. False (all-zero memory) means work it out anew.
    est_warm: bool,
    /// `lst` is the greatest schedule for the steps executed now (it does not depend on the
    /// time now): the next propagation keeps it.
    lst_kept: bool,
    /// Something was executed since `est` was worked out.
    executed_since: bool,
    /// The time `est` was worked out at.
    est_now: u32,
    /// Every propagation worked out whole (the reference the incremental one is tested against).
    whole_only: bool,
    /// A poll divided across calls, in progress ([`Self::poll_begin`]).
    slice: sliced::Slice,
}

impl Dispatcher {
    /// A dispatcher for `net` whose steps must all happen by `horizon` (at least the plan's
    /// makespan; the makespan itself keeps it). Fails if the network has no such schedule.
    pub fn new(net: PlanNetwork, horizon: u32) -> Result<Self, NetworkError> {
        let mut d = Self {
            net,
            done: [UNBOUNDED; MAX_DISPATCH_STEPS + 1],
            est: [0; MAX_DISPATCH_STEPS + 1],
            lst: [0; MAX_DISPATCH_STEPS + 1],
            horizon,
            est_warm: false,
            lst_kept: false,
            executed_since: false,
            est_now: 0,
            whole_only: false,
            slice: sliced::Slice::IDLE,
        };
        if let Some(epoch) = d.done.get_mut(0) {
            *epoch = 0;
        }
        match d.propagate(0) {
            Ok(()) => Ok(d),
            Err(_) => Err(NetworkError::Inconsistent),
        }
    }

    /// A dispatcher of the empty network, nothing worked out (all-zero but the network's
    /// unused constraint slots): `const`, for a partition's static state; give it a network
    /// with [`Self::network_mut`] and [`Self::restart`].
    pub const fn empty() -> Self {
        Self {
            net: PlanNetwork::new(),
            done: [0; MAX_DISPATCH_STEPS + 1],
            est: [0; MAX_DISPATCH_STEPS + 1],
            lst: [0; MAX_DISPATCH_STEPS + 1],
            horizon: 0,
            est_warm: false,
            lst_kept: false,
            executed_since: false,
            est_now: 0,
            whole_only: false,
            slice: sliced::Slice::IDLE,
        }
    }

    /// The latest time of any step, as given to [`Self::restart`].
    pub fn horizon(&self) -> u32 {
        self.horizon
    }

    pub fn network(&self) -> &PlanNetwork {
        &self.net
    }

    /// The network, to rebuild in place (then [`Self::restart`]): a dispatcher is about 30 KB,
    /// too large to move on a partition's stack. Every field of a dispatcher is an integer or a
    /// bool, so all-zero bytes are a valid (empty) one: the planner partition zero-fills one in
    /// place and builds each plan's network into it.
    pub fn network_mut(&mut self) -> &mut PlanNetwork {
        self.drop_slice();
        self.forget_windows();
        &mut self.net
    }

    /// Starts dispatching the network anew (nothing executed, the epoch at 0), every step by
    /// `horizon`: [`Self::new`] in place. Fails if the network has no such schedule.
    pub fn restart(&mut self, horizon: u32) -> Result<(), NetworkError> {
        self.drop_slice();
        self.done.iter_mut().for_each(|d| *d = UNBOUNDED);
        self.est.iter_mut().for_each(|e| *e = 0);
        self.lst.iter_mut().for_each(|l| *l = 0);
        self.horizon = horizon;
        self.forget_windows();
        if let Some(epoch) = self.done.get_mut(0) {
            *epoch = 0;
        }
        self.propagate(0).map_err(|_| NetworkError::Inconsistent)
    }

    /// Step `k`'s window as last worked out: (lb, ub).
    pub fn window(&self, k: usize) -> Option<(u32, u32)> {
        Some((*self.est.get(k)?, *self.lst.get(k)?))
    }

    /// When step `k` was executed, if it was.
    pub fn executed_at(&self, k: usize) -> Option<u32> {
        self.done.get(k).copied().filter(|&t| t != UNBOUNDED)
    }

    /// The next propagation works every window out anew.
    fn forget_windows(&mut self) {
        self.est_warm = false;
        self.lst_kept = false;
        self.executed_since = false;
    }

    /// Every propagation worked out whole, from nothing (`true`), or incrementally (the
    /// default): the two give the same windows and decisions; the whole one is the reference
    /// the tests hold the incremental one to.
    pub fn set_whole_propagation(&mut self, whole: bool) {
        self.end_slice();
        self.mark_deferred();
        self.whole_only = whole;
        self.forget_windows();
    }

    /// Works out every step's window at time `now`. Err(step): the first step not yet executed
    /// whose window is empty (or the network has no schedule at all: the first step not yet
    /// executed).
    ///
    /// Incrementally, with the same result as from nothing: the latest times do not depend on
    /// `now`, so they are kept until a step is executed; the earliest times are kept when
    /// nothing was executed and `now` has not passed any open step's earliest time (they are
    /// then still the least schedule), and otherwise worked out from the last ones (label
    /// correcting from a lower bound ends at the least schedule). The last ones are a lower
    /// bound of the new least schedule when time went forward and the new one exists with
    /// every executed step at the time it happened at, at or after its last earliest time:
    /// for a step not executed, every bound into it is still there and its window only
    /// narrowed, so the last least schedule's every iterate stays below the new one. When the
    /// new one does not exist, or a step was executed before its earliest time (an action
    /// that ended early), the propagation from the last times fails (the executed step's
    /// window is its time) and is worked out again from nothing, so a refusal names the same
    /// step as the whole propagation's.
    fn propagate(&mut self, now: u32) -> Result<(), usize> {
        if self.whole_only || !self.est_warm || now < self.est_now {
            self.forget_windows();
        }
        let steps = self.net.step_count;
        let keep_est = self.est_warm && !self.executed_since && {
            let (done, est) = (&self.done, &self.est);
            (1..=steps)
                .all(|k| done.get(k) != Some(&UNBOUNDED) || est.get(k).is_some_and(|&e| now <= e))
        };
        let warm = self.est_warm;
        let r = self.propagate_from(now, keep_est, warm);
        let r = if r.is_err() && (keep_est || warm || self.lst_kept) {
            self.forget_windows();
            self.propagate_from(now, false, false)
        } else {
            r
        };
        match r {
            Ok(()) => {
                self.est_warm = true;
                self.lst_kept = true;
                self.executed_since = false;
                self.est_now = now;
            }
            Err(_) => self.forget_windows(),
        }
        r
    }

    /// [`Self::propagate`]'s work: the earliest times kept (`keep_est`), worked out from the
    /// last ones (`warm`) or from nothing; the latest kept if `lst_kept`.
    fn propagate_from(&mut self, now: u32, keep_est: bool, warm: bool) -> Result<(), usize> {
        let steps = self.net.step_count;
        let net = &self.net;
        let done = &self.done;
        let window = |k: usize| match done.get(k).copied() {
            Some(t) if t != UNBOUNDED => (t, t),
            _ => {
                let (lo, hi) = net.step(k).map_or((0, UNBOUNDED), |s| s.window);
                (lo.max(now), hi)
            }
        };
        let first_open = (1..=steps)
            .find(|&k| done.get(k).is_some_and(|&t| t == UNBOUNDED))
            .unwrap_or(0);
        let cs = self.net.constraints();
        // Between two executed steps a constraint says nothing any more: what happened
        // happened (an action that overran its duration ended when it ended).
        let get = |i: usize| match cs.get(i).copied() {
            Some(c)
                if done.get(usize::from(c.before)) != Some(&UNBOUNDED)
                    && done.get(usize::from(c.after)) != Some(&UNBOUNDED) =>
            {
                NO_CONSTRAINT
            }
            Some(c) => c,
            None => NO_CONSTRAINT,
        };
        if !keep_est {
            if !warm {
                self.est.iter_mut().for_each(|e| *e = 0);
            }
            match stn::earliest_with(steps, cs.len(), &get, &window, &mut self.est) {
                Ok(()) => {}
                Err(stn::Inconsistent::WindowMissed { step }) => return Err(usize::from(step)),
                Err(_) => return Err(first_open),
            }
        }
        if !self.lst_kept
            && stn::latest_with(steps, cs.len(), &get, &window, self.horizon, &mut self.lst)
                .is_err()
        {
            return Err(first_open);
        }
        for k in 1..=steps {
            if done.get(k) == Some(&UNBOUNDED) && self.est.get(k) > self.lst.get(k) {
                return Err(k);
            }
        }
        Ok(())
    }

    /// The steps some step that must come before has not been executed for (one bit a step),
    /// in one pass over the constraints.
    fn blocked(&self) -> [u32; BLOCKED_WORDS] {
        let mut blocked = [0u32; BLOCKED_WORDS];
        for c in self.net.constraints() {
            if c.before != 0 && self.executed_at(usize::from(c.before)).is_none() {
                let a = usize::from(c.after);
                if let Some(w) = blocked.get_mut(a / 32) {
                    *w |= 1 << (a % 32);
                }
            }
        }
        blocked
    }

    /// What to do at time `now`, given which actions are ready to start (their conditions hold
    /// in the executive's view).
    pub fn poll(&mut self, now: u32, ready: &dyn Fn(u16) -> bool) -> Decision {
        if self.slice.active() {
            self.end_slice();
            self.mark_deferred();
        }
        let steps = self.net.step_count;
        if (1..=steps).all(|k| self.executed_at(k).is_some()) {
            return Decision::Finished;
        }
        if let Err(step) = self.propagate(now) {
            let ub = self.lst.get(step).copied().unwrap_or(0);
            return Decision::Replan { step, ub };
        }
        let blocked = self.blocked();
        let enabled = |k: usize| {
            blocked
                .get(k / 32)
                .is_some_and(|w| w & (1 << (k % 32)) == 0)
        };
        let mut until: Option<u32> = None;
        for k in 1..=steps {
            let Some(step) = self.net.step(k) else {
                continue;
            };
            if step.end || self.executed_at(k).is_some() || !enabled(k) {
                continue;
            }
            let (lb, ub) = (
                self.est.get(k).copied().unwrap_or(0),
                self.lst.get(k).copied().unwrap_or(0),
            );
            if now > ub {
                return Decision::Replan { step: k, ub };
            }
            if !ready(step.action) {
                continue;
            }
            if now >= lb {
                return Decision::Start {
                    step: k,
                    action: step.action,
                };
            }
            until = Some(until.map_or(lb, |u| u.min(lb)));
        }
        Decision::Wait { until }
    }

    /// Step `k` (a start the dispatcher gave, or an action's end) was executed at `at`.
    /// Err if `k` is not a step or was executed already (nothing changes). While a divided poll
    /// is in progress ([`Self::poll_begin`]) the step is marked once it has decided (until then
    /// [`Self::executed_at`] does not show it; marked twice is refused the same).
    pub fn executed(&mut self, k: usize, at: u32) -> Result<(), NetworkError> {
        if k == 0 || k > self.net.step_count || self.executed_at(k).is_some() {
            return Err(NetworkError::UnknownStep);
        }
        if self.slice.active() {
            // Marked once the divided poll in progress has decided (see `sliced`).
            return self.defer_executed(k, at);
        }
        self.mark_executed(k, at)
    }

    /// [`Self::executed`]'s marking.
    fn mark_executed(&mut self, k: usize, at: u32) -> Result<(), NetworkError> {
        let slot = self.done.get_mut(k).ok_or(NetworkError::UnknownStep)?;
        *slot = at;
        self.lst_kept = false;
        self.executed_since = true;
        // A step executed before its earliest time makes the last earliest times no lower
        // bound of the next ones: the next propagation starts from nothing.
        if self.est.get(k).is_none_or(|&e| at < e) {
            self.est_warm = false;
        }
        Ok(())
    }
}
