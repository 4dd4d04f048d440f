//! A poll divided across calls (the executive's cycles: issue 13 item 3, the STN within the
//! executive's cycle budget). [`Dispatcher::poll_begin`] then [`Dispatcher::poll_continue`]
//! with a budget of work units, until it gives the decision: the one [`Dispatcher::poll`] gives
//! at the same time over the same state, with the same windows worked out. A unit is one
//! constraint looked at (a relaxation in a propagation's pass, or the pass that finds the steps
//! whose predecessors are not all executed) or one step looked at; a call stops at the first
//! constraint or step after its budget is spent (a loop over the steps that sets up or checks
//! a propagation, at most `MAX_DISPATCH_STEPS` + 1 units, runs whole).
//!
//! The work is the whole poll's, in the same order (the same label-correcting passes, the same
//! retry from nothing when a propagation from the last windows fails), cut between
//! constraints: nothing else writes the dispatcher between two calls. A step marked executed
//! ([`Dispatcher::executed`]) while a poll is in progress (an action that ended) is held and
//! marked, in order, once the poll has decided, so the decision is the whole poll's at the
//! time it began and the steps are marked after it, as a whole poll then the marks would be;
//! more than [`MAX_DEFERRED`] of them in one poll: all are marked at once and the poll begins
//! again at the same time (from nothing if a propagation was under way; then the ub of a
//! replan whose propagation failed, which is the latest time last worked out, may differ from
//! a whole poll's). [`Dispatcher::poll`] ends a divided poll (marking the steps held first);
//! [`Dispatcher::restart`] and [`Dispatcher::network_mut`] end it and drop them. While a poll
//! is in progress the windows ([`Dispatcher::window`]) are a propagation's intermediate values.
use super::*;

/// No poll in progress (all-zero bytes: a zero-filled dispatcher has none).
const IDLE: u8 = 0;
/// Begun: nothing done yet.
const BEGIN: u8 = 1;
/// In a pass of the earliest times' propagation, at constraint `i`.
const EST_PASS: u8 = 2;
/// In a pass of the latest times' propagation (the constraints backwards), `i` to go.
const LST_PASS: u8 = 3;
/// Finding the steps a predecessor not executed blocks, at constraint `i`.
const BLOCKED: u8 = 4;
/// Looking at the steps for the decision, at step `k`.
const SCAN: u8 = 5;

/// Steps marked executed during one divided poll that are held until it decides.
pub const MAX_DEFERRED: usize = 32;

/// A divided poll's progress (every field an integer, a bool or an array of them).
#[derive(Clone, Copy, Debug)]
pub(super) struct Slice {
    stage: u8,
    now: u32,
    /// The propagation's parameters (see `Dispatcher::propagate`): the earliest times kept,
    /// worked out from the last ones; this is the retry from nothing.
    keep_est: bool,
    warm: bool,
    retry: bool,
    first_open: usize,
    i: usize,
    passes: usize,
    changed: bool,
    blocked: [u32; BLOCKED_WORDS],
    k: usize,
    has_until: bool,
    until: u32,
    /// Steps executed during the poll, and when: marked once it has decided.
    deferred: [(u16, u32); MAX_DEFERRED],
    deferred_len: usize,
    /// Units of work the poll took so far (the last one's once it decided).
    spent: u32,
}

impl Slice {
    pub(super) const IDLE: Self = Self {
        stage: IDLE,
        now: 0,
        keep_est: false,
        warm: false,
        retry: false,
        first_open: 0,
        i: 0,
        passes: 0,
        changed: false,
        blocked: [0; BLOCKED_WORDS],
        k: 0,
        has_until: false,
        until: 0,
        deferred: [(0, 0); MAX_DEFERRED],
        deferred_len: 0,
        spent: 0,
    };

    /// A propagation is under way (its windows are intermediate values).
    pub(super) fn propagating(&self) -> bool {
        matches!(self.stage, EST_PASS | LST_PASS)
    }

    pub(super) fn active(&self) -> bool {
        self.stage != IDLE
    }
}

/// How a step of the work ended.
enum Step {
    /// Go on (with the stage set).
    More,
    /// The decision.
    Done(Decision),
}

impl Dispatcher {
    /// Begins a poll at `now` divided across calls of [`Self::poll_continue`] (one in progress
    /// is given up).
    pub fn poll_begin(&mut self, now: u32) {
        self.end_slice();
        self.mark_deferred();
        self.slice.stage = BEGIN;
        self.slice.now = now;
        self.slice.spent = 0;
    }

    /// Units of work of the divided poll in progress so far, or of the last one once it
    /// decided (a poll begun again after more than [`MAX_DEFERRED`] ends counts anew).
    pub fn poll_units(&self) -> u32 {
        self.slice.spent
    }

    /// Whether a poll begun by [`Self::poll_begin`] has not given its decision yet.
    pub fn polling(&self) -> bool {
        self.slice.active()
    }

    /// Goes on with the poll begun, about `budget` units of work (at least one); its decision
    /// once done ([`Self::poll`]'s at the time given to [`Self::poll_begin`]), else None (also
    /// when no poll is in progress). `ready` must answer the same through the calls.
    pub fn poll_continue(&mut self, ready: &dyn Fn(u16) -> bool, budget: u32) -> Option<Decision> {
        let mut units = 0u32;
        let budget = budget.max(1);
        let spent_before = self.slice.spent;
        loop {
            if !self.slice.active() {
                return None;
            }
            let step = match self.slice.stage {
                BEGIN => self.slice_begin(&mut units),
                EST_PASS => self.slice_est(&mut units, budget),
                LST_PASS => self.slice_lst(&mut units, budget),
                BLOCKED => self.slice_blocked(&mut units, budget),
                _ => self.slice_scan(ready, &mut units, budget),
            };
            self.slice.spent = spent_before.saturating_add(units);
            match step {
                Step::Done(d) => {
                    self.slice.stage = IDLE;
                    self.mark_deferred();
                    return Some(d);
                }
                Step::More if units >= budget => return None,
                Step::More => {}
            }
        }
    }

    /// Gives up the poll in progress (its windows from nothing next time if a propagation was
    /// under way).
    pub(super) fn end_slice(&mut self) {
        if self.slice.propagating() {
            self.forget_windows();
        }
        self.slice.stage = IDLE;
    }

    /// Gives up the poll in progress and drops the steps it held (a new network, a restart).
    pub(super) fn drop_slice(&mut self) {
        self.end_slice();
        self.slice.deferred_len = 0;
    }

    /// Step `k` executed at `at` during the poll in progress: held until it decides; beyond
    /// [`MAX_DEFERRED`], everything held is marked and the poll begins again.
    pub(super) fn defer_executed(&mut self, k: usize, at: u32) -> Result<(), NetworkError> {
        let held = self
            .slice
            .deferred
            .get(..self.slice.deferred_len)
            .unwrap_or_default();
        let step = u16::try_from(k).map_err(|_| NetworkError::UnknownStep)?;
        if held.iter().any(|&(s, _)| s == step) {
            return Err(NetworkError::UnknownStep);
        }
        if let Some(slot) = self.slice.deferred.get_mut(self.slice.deferred_len) {
            *slot = (step, at);
            self.slice.deferred_len += 1;
            return Ok(());
        }
        let now = self.slice.now;
        self.end_slice();
        self.mark_deferred();
        self.mark_executed(k, at)?;
        self.poll_begin(now);
        Ok(())
    }

    /// Marks the steps held, in order.
    pub(super) fn mark_deferred(&mut self) {
        let n = core::mem::take(&mut self.slice.deferred_len);
        for i in 0..n {
            if let Some(&(k, at)) = self.slice.deferred.get(i) {
                // Checked when it was held; nothing marks a step between.
                let _ = self.mark_executed(usize::from(k), at);
            }
        }
    }

    fn open_window(&self, k: usize, now: u32) -> (u32, u32) {
        match self.done.get(k).copied() {
            Some(t) if t != UNBOUNDED => (t, t),
            _ => {
                let (lo, hi) = self.net.step(k).map_or((0, UNBOUNDED), |s| s.window);
                (lo.max(now), hi)
            }
        }
    }

    /// Constraint `i` as the propagations see it (none between two executed steps).
    fn seen(&self, i: usize) -> Constraint {
        match self.net.constraints().get(i).copied() {
            Some(c)
                if self.done.get(usize::from(c.before)) != Some(&UNBOUNDED)
                    && self.done.get(usize::from(c.after)) != Some(&UNBOUNDED) =>
            {
                NO_CONSTRAINT
            }
            Some(c) => c,
            None => NO_CONSTRAINT,
        }
    }

    /// `poll`'s start and `propagate`'s: whether every step is executed, which windows are kept.
    fn slice_begin(&mut self, units: &mut u32) -> Step {
        let now = self.slice.now;
        let steps = self.net.step_count;
        *units = units.saturating_add(2 * steps as u32 + 1);
        if (1..=steps).all(|k| self.executed_at(k).is_some()) {
            return Step::Done(Decision::Finished);
        }
        if self.whole_only || !self.est_warm || now < self.est_now {
            self.forget_windows();
        }
        let keep_est = self.est_warm && !self.executed_since && {
            let (done, est) = (&self.done, &self.est);
            (1..=steps)
                .all(|k| done.get(k) != Some(&UNBOUNDED) || est.get(k).is_some_and(|&e| now <= e))
        };
        self.slice.retry = false;
        self.slice.keep_est = keep_est;
        self.slice.warm = self.est_warm;
        self.slice_from(units)
    }

    /// `propagate_from`'s start, with `slice.keep_est` and `slice.warm`.
    fn slice_from(&mut self, units: &mut u32) -> Step {
        let steps = self.net.step_count;
        let now = self.slice.now;
        self.slice.first_open = (1..=steps)
            .find(|&k| self.done.get(k).is_some_and(|&t| t == UNBOUNDED))
            .unwrap_or(0);
        *units = units.saturating_add(steps as u32 + 1);
        if self.slice.keep_est {
            return self.slice_lst_from(units);
        }
        if !self.slice.warm {
            self.est.iter_mut().for_each(|e| *e = 0);
        }
        for k in 1..=steps {
            let lo = self.open_window(k, now).0;
            if let Some(e) = self.est.get_mut(k) {
                *e = (*e).max(lo);
            }
        }
        if let Some(origin) = self.est.first_mut() {
            *origin = 0;
        }
        self.slice.i = 0;
        self.slice.passes = 0;
        self.slice.changed = false;
        self.slice.stage = EST_PASS;
        Step::More
    }

    /// The earliest times' passes (`stn::earliest_with`'s), then their check.
    fn slice_est(&mut self, units: &mut u32, budget: u32) -> Step {
        let steps = self.net.step_count;
        let count = self.net.constraints().len();
        while self.slice.i < count {
            if *units >= budget {
                return Step::More;
            }
            *units += 1;
            let c = self.seen(self.slice.i);
            self.slice.i += 1;
            let (b, a) = (usize::from(c.before), usize::from(c.after));
            let (Some(&tb), Some(&ta)) = (
                self.est.get(b).filter(|_| b <= steps),
                self.est.get(a).filter(|_| a <= steps),
            ) else {
                let f = self.slice.first_open;
                return self.slice_failed(f, units);
            };
            let need_a = tb.saturating_add(c.lb);
            if ta < need_a {
                if a == 0 {
                    let f = self.slice.first_open;
                    return self.slice_failed(f, units);
                }
                if let Some(x) = self.est.get_mut(a) {
                    *x = need_a;
                }
                self.slice.changed = true;
            }
            if c.ub != UNBOUNDED {
                let ta = self.est.get(a).copied().unwrap_or(0);
                let need_b = ta.saturating_sub(c.ub);
                if tb < need_b {
                    if b == 0 {
                        let f = self.slice.first_open;
                        return self.slice_failed(f, units);
                    }
                    if let Some(x) = self.est.get_mut(b) {
                        *x = need_b;
                    }
                    self.slice.changed = true;
                }
            }
        }
        if self.slice.changed {
            self.slice.passes += 1;
            if self.slice.passes > steps + 1 {
                let f = self.slice.first_open;
                return self.slice_failed(f, units);
            }
            self.slice.i = 0;
            self.slice.changed = false;
            return Step::More;
        }
        *units = units.saturating_add(steps as u32);
        let now = self.slice.now;
        for k in 1..=steps {
            let e = self.est.get(k).copied().unwrap_or(0);
            if e > self.open_window(k, now).1 || e == UNBOUNDED {
                return self.slice_failed(k, units);
            }
        }
        self.slice_lst_from(units)
    }

    /// The latest times' start (`stn::latest_with`'s), unless they are kept.
    fn slice_lst_from(&mut self, units: &mut u32) -> Step {
        if self.lst_kept {
            return self.slice_check(units);
        }
        let steps = self.net.step_count;
        let now = self.slice.now;
        *units = units.saturating_add(steps as u32 + 1);
        for k in 0..=steps {
            let v = if k == 0 {
                0
            } else {
                self.open_window(k, now).1.min(self.horizon)
            };
            if let Some(l) = self.lst.get_mut(k) {
                *l = v;
            }
        }
        self.slice.i = self.net.constraints().len();
        self.slice.passes = 0;
        self.slice.changed = false;
        self.slice.stage = LST_PASS;
        Step::More
    }

    /// The latest times' passes, the constraints backwards.
    fn slice_lst(&mut self, units: &mut u32, budget: u32) -> Step {
        let steps = self.net.step_count;
        while self.slice.i > 0 {
            if *units >= budget {
                return Step::More;
            }
            *units += 1;
            self.slice.i -= 1;
            let c = self.seen(self.slice.i);
            let (b, a) = (usize::from(c.before), usize::from(c.after));
            let (Some(&tb), Some(&ta)) = (
                self.lst.get(b).filter(|_| b <= steps),
                self.lst.get(a).filter(|_| a <= steps),
            ) else {
                let f = self.slice.first_open;
                return self.slice_failed(f, units);
            };
            if ta < c.lb {
                let f = self.slice.first_open;
                return self.slice_failed(f, units);
            }
            if tb > ta - c.lb {
                if b == 0 {
                    let f = self.slice.first_open;
                    return self.slice_failed(f, units);
                }
                if let Some(x) = self.lst.get_mut(b) {
                    *x = ta - c.lb;
                }
                self.slice.changed = true;
            }
            if c.ub != UNBOUNDED {
                let tb = self.lst.get(b).copied().unwrap_or(0);
                let cap = tb.saturating_add(c.ub);
                if self.lst.get(a).is_some_and(|&x| x > cap) {
                    if let Some(x) = self.lst.get_mut(a) {
                        *x = cap;
                    }
                    self.slice.changed = true;
                }
            }
        }
        if !self.slice.changed {
            return self.slice_check(units);
        }
        self.slice.passes += 1;
        if self.slice.passes > steps + 1 {
            let f = self.slice.first_open;
            return self.slice_failed(f, units);
        }
        self.slice.i = self.net.constraints().len();
        self.slice.changed = false;
        Step::More
    }

    /// `propagate_from`'s last check, then the propagation's success.
    fn slice_check(&mut self, units: &mut u32) -> Step {
        let steps = self.net.step_count;
        *units = units.saturating_add(steps as u32);
        for k in 1..=steps {
            if self.done.get(k) == Some(&UNBOUNDED) && self.est.get(k) > self.lst.get(k) {
                return self.slice_failed(k, units);
            }
        }
        self.est_warm = true;
        self.lst_kept = true;
        self.executed_since = false;
        self.est_now = self.slice.now;
        self.slice.blocked = [0; BLOCKED_WORDS];
        self.slice.i = 0;
        self.slice.stage = BLOCKED;
        Step::More
    }

    /// The propagation failed at `step`: once again from nothing if it started from kept
    /// windows, else a replan.
    fn slice_failed(&mut self, step: usize, units: &mut u32) -> Step {
        let from_kept = self.slice.keep_est || self.slice.warm || self.lst_kept;
        self.forget_windows();
        if !self.slice.retry && from_kept {
            self.slice.retry = true;
            self.slice.keep_est = false;
            self.slice.warm = false;
            return self.slice_from(units);
        }
        let ub = self.lst.get(step).copied().unwrap_or(0);
        Step::Done(Decision::Replan { step, ub })
    }

    /// `blocked`'s pass over the constraints.
    fn slice_blocked(&mut self, units: &mut u32, budget: u32) -> Step {
        let count = self.net.constraints().len();
        while self.slice.i < count {
            if *units >= budget {
                return Step::More;
            }
            *units += 1;
            let Some(c) = self.net.constraints().get(self.slice.i).copied() else {
                break;
            };
            self.slice.i += 1;
            if c.before != 0 && self.executed_at(usize::from(c.before)).is_none() {
                let a = usize::from(c.after);
                if let Some(w) = self.slice.blocked.get_mut(a / 32) {
                    *w |= 1 << (a % 32);
                }
            }
        }
        self.slice.k = 1;
        self.slice.has_until = false;
        self.slice.until = 0;
        self.slice.stage = SCAN;
        Step::More
    }

    /// `poll`'s look at the steps.
    fn slice_scan(&mut self, ready: &dyn Fn(u16) -> bool, units: &mut u32, budget: u32) -> Step {
        let steps = self.net.step_count;
        let now = self.slice.now;
        while self.slice.k <= steps {
            if *units >= budget {
                return Step::More;
            }
            *units += 1;
            let k = self.slice.k;
            self.slice.k += 1;
            let Some(step) = self.net.step(k) else {
                continue;
            };
            let enabled = self
                .slice
                .blocked
                .get(k / 32)
                .is_some_and(|w| w & (1 << (k % 32)) == 0);
            if step.end || self.executed_at(k).is_some() || !enabled {
                continue;
            }
            let (lb, ub) = (
                self.est.get(k).copied().unwrap_or(0),
                self.lst.get(k).copied().unwrap_or(0),
            );
            if now > ub {
                return Step::Done(Decision::Replan { step: k, ub });
            }
            if !ready(step.action) {
                continue;
            }
            if now >= lb {
                return Step::Done(Decision::Start {
                    step: k,
                    action: step.action,
                });
            }
            self.slice.until = if self.slice.has_until {
                self.slice.until.min(lb)
            } else {
                lb
            };
            self.slice.has_until = true;
        }
        Step::Done(Decision::Wait {
            until: self.slice.has_until.then_some(self.slice.until),
        })
    }
}
