//! Simple Temporal Network consistency (Dechter, Meiri and Pearl 1991) over plan steps: step 0
//! is time zero, every step is at or after it, each step may have a global window [lo, hi]
//! (from timed initial literals), and each constraint bounds the distance between two steps.
//!
//! [`earliest`] computes the least schedule (every step as early as it can be) by label
//! correcting in passes over the constraints (Bellman-Ford on the "at least" form of every
//! bound); a positive cycle, a window missed or time zero pushed later means no schedule
//! exists. [`latest`] computes the greatest schedule under a horizon, which with the earliest
//! gives each step's window of start times for flexible dispatch (section 5.2).
#![deny(clippy::indexing_slicing)]

use crate::constraints::Constraint;
use crate::task::UNBOUNDED;

/// Why the network has no schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inconsistent {
    /// A step's earliest time is after its window closes.
    WindowMissed { step: u16 },
    /// The bounds contradict each other (a positive cycle of lower bounds).
    Cycle,
    /// A step named by a constraint is not in the network.
    UnknownStep,
}

/// The least schedule of `steps + 1` steps (0 = time zero) into `est[..=steps]`.
///
/// `est` may come in holding a lower bound on every step's earliest time (the earliest times of
/// a prefix of this network, zero for new steps): the search passes its parent's times so that a
/// child's check takes one or two passes. `window(step)` is the step's (lo, hi).
pub fn earliest(
    steps: usize,
    constraints: &[Constraint],
    window: &dyn Fn(usize) -> (u32, u32),
    est: &mut [u32],
) -> Result<(), Inconsistent> {
    let get = |i: usize| constraints.get(i).copied().unwrap_or(NO_CONSTRAINT);
    earliest_with(steps, constraints.len(), &get, window, est)
}

/// A constraint that says nothing (time zero before itself by at least zero).
const NO_CONSTRAINT: Constraint = Constraint {
    before: 0,
    after: 0,
    lb: 0,
    ub: UNBOUNDED,
};

/// [`earliest`] over `count` constraints read through `constraint(i)`.
pub fn earliest_with(
    steps: usize,
    count: usize,
    constraint: &dyn Fn(usize) -> Constraint,
    window: &dyn Fn(usize) -> (u32, u32),
    est: &mut [u32],
) -> Result<(), Inconsistent> {
    let est = est.get_mut(..=steps).ok_or(Inconsistent::UnknownStep)?;
    for (k, e) in est.iter_mut().enumerate().skip(1) {
        *e = (*e).max(window(k).0);
    }
    if let Some(origin) = est.first_mut() {
        *origin = 0;
    }
    let mut passes = 0usize;
    loop {
        let mut changed = false;
        for i in 0..count {
            let c = constraint(i);
            let (b, a) = (c.before as usize, c.after as usize);
            let (Some(&tb), Some(&ta)) = (est.get(b), est.get(a)) else {
                return Err(Inconsistent::UnknownStep);
            };
            let need_a = tb.saturating_add(c.lb);
            if ta < need_a {
                if a == 0 {
                    // Time zero cannot move.
                    return Err(Inconsistent::Cycle);
                }
                if let Some(x) = est.get_mut(a) {
                    *x = need_a;
                }
                changed = true;
            }
            if c.ub != UNBOUNDED {
                let ta = est.get(a).copied().unwrap_or(0);
                let need_b = ta.saturating_sub(c.ub);
                if tb < need_b {
                    if b == 0 {
                        return Err(Inconsistent::Cycle);
                    }
                    if let Some(x) = est.get_mut(b) {
                        *x = need_b;
                    }
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
        passes += 1;
        if passes > steps + 1 {
            return Err(Inconsistent::Cycle);
        }
    }
    for (k, &e) in est.iter().enumerate().skip(1) {
        if e > window(k).1 || e == UNBOUNDED {
            return Err(Inconsistent::WindowMissed { step: k as u16 });
        }
    }
    Ok(())
}

/// The least schedule of a network extended by new steps and constraints, worked out from the
/// network's before, without a pass over its old constraints where the new ones move no old
/// step (the search's usual case: a plan grows by a step ordered after earlier ones).
///
/// `est[..=old_steps]` must hold the least schedule of the old network: steps up to
/// `old_steps` and constraints `0..first`, which name only those steps. Steps `old_steps +
/// 1..=steps` and constraints `first..count` are new. The new steps start at their windows'
/// lo and the new constraints are relaxed once, in their order (the search appends them by
/// their later step, each after the steps it names first). Returns true if that settled the
/// schedule: every new constraint holds, every new step is within its window, and no old step
/// had to move; `est[..=steps]` is then the least schedule ([`earliest_with`]'s, whose every
/// raise is forced as this one's is) and the old steps' times are as they came in. Returns
/// false otherwise, with the old steps' times untouched and the new steps' lower bounds of
/// their earliest times: [`earliest_with`] over every constraint then decides (from `est` as
/// it is left, a warm start).
pub fn earliest_extend(
    old_steps: usize,
    steps: usize,
    first: usize,
    count: usize,
    constraint: &dyn Fn(usize) -> Constraint,
    window: &dyn Fn(usize) -> (u32, u32),
    est: &mut [u32],
) -> bool {
    let Some(est) = est.get_mut(..=steps) else {
        return false;
    };
    if old_steps >= steps {
        return false;
    }
    for (k, e) in est.iter_mut().enumerate().skip(old_steps + 1) {
        *e = window(k).0;
    }
    // Relax the new constraints' lower bounds once, in order, raising only new steps.
    for i in first..count {
        let c = constraint(i);
        let (b, a) = (c.before as usize, c.after as usize);
        let (Some(&tb), Some(&ta)) = (est.get(b), est.get(a)) else {
            return false;
        };
        let need_a = tb.saturating_add(c.lb);
        if ta < need_a {
            if a <= old_steps {
                return false;
            }
            if let Some(x) = est.get_mut(a) {
                *x = need_a;
            }
        }
    }
    // Every new constraint must hold as the times are now (a later raise may have broken an
    // earlier one's lower bound, or an upper bound pushes a step back).
    for i in first..count {
        let c = constraint(i);
        let (b, a) = (c.before as usize, c.after as usize);
        let (Some(&tb), Some(&ta)) = (est.get(b), est.get(a)) else {
            return false;
        };
        if ta < tb.saturating_add(c.lb) || (c.ub != UNBOUNDED && tb < ta.saturating_sub(c.ub)) {
            return false;
        }
    }
    est.iter()
        .enumerate()
        .skip(old_steps + 1)
        .all(|(k, &e)| e <= window(k).1 && e != UNBOUNDED)
}

/// The greatest schedule with every step at or before `horizon` (and its window's hi), into
/// `lst[..=steps]`. Call it on a consistent network whose earliest schedule ends by `horizon`.
pub fn latest(
    steps: usize,
    constraints: &[Constraint],
    window: &dyn Fn(usize) -> (u32, u32),
    horizon: u32,
    lst: &mut [u32],
) -> Result<(), Inconsistent> {
    let get = |i: usize| constraints.get(i).copied().unwrap_or(NO_CONSTRAINT);
    latest_with(steps, constraints.len(), &get, window, horizon, lst)
}

/// [`latest`] over `count` constraints read through `constraint(i)`.
pub fn latest_with(
    steps: usize,
    count: usize,
    constraint: &dyn Fn(usize) -> Constraint,
    window: &dyn Fn(usize) -> (u32, u32),
    horizon: u32,
    lst: &mut [u32],
) -> Result<(), Inconsistent> {
    let lst = lst.get_mut(..=steps).ok_or(Inconsistent::UnknownStep)?;
    for (k, l) in lst.iter_mut().enumerate() {
        *l = if k == 0 { 0 } else { window(k).1.min(horizon) };
    }
    let mut passes = 0usize;
    loop {
        let mut changed = false;
        for i in (0..count).rev() {
            let c = constraint(i);
            let (b, a) = (c.before as usize, c.after as usize);
            let (Some(&tb), Some(&ta)) = (lst.get(b), lst.get(a)) else {
                return Err(Inconsistent::UnknownStep);
            };
            // t[before] <= t[after] - lb
            if ta < c.lb {
                return Err(Inconsistent::Cycle);
            }
            if tb > ta - c.lb {
                if b == 0 {
                    return Err(Inconsistent::Cycle);
                }
                if let Some(x) = lst.get_mut(b) {
                    *x = ta - c.lb;
                }
                changed = true;
            }
            // t[after] <= t[before] + ub
            if c.ub != UNBOUNDED {
                let tb = lst.get(b).copied().unwrap_or(0);
                let cap = tb.saturating_add(c.ub);
                if lst.get(a).is_some_and(|&x| x > cap) {
                    if let Some(x) = lst.get_mut(a) {
                        *x = cap;
                    }
                    changed = true;
                }
            }
        }
        if !changed {
            return Ok(());
        }
        passes += 1;
        if passes > steps + 1 {
            return Err(Inconsistent::Cycle);
        }
    }
}
