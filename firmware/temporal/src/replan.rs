//! Replanning from the middle of a plan (seed 001, sections 5.1 to 5.3).
//!
//! The planner only plans from a quiescent initial state (nothing running, time zero). A
//! replan starts from wherever execution got to, so this module turns "where execution got to"
//! into an ordinary task the planner can take, and turns a plan (from this host or from the
//! planner partition) back into a dispatchable network:
//!
//! - [`initial_state`], [`apply`] and [`replay`]: the facts and numeric values now, from the
//!   task's initial state and the happenings executed so far (starts and ends, in order).
//! - [`pause`] and [`is_pausable`] (5.1: planning pauses activity into its inactive states):
//!   the convention is a fact the host names inactive (in our PDDL, a predicate whose name
//!   starts with `inactive-`). An action that deletes such a fact at start and adds it back at
//!   end takes a component out of its inactive state for its duration; it is pausable. Pausing
//!   it undoes its at-start fact effects (the component is back in its inactive state, what it
//!   was doing is not done) and its at-end effects never happen. Numeric start effects stay
//!   (what was spent is spent). Every other running action keeps running to its end.
//! - [`write_replan_task`]: the task from now: the initial facts and values are the state now;
//!   every timed-literal window moves to the new epoch (`now` becomes 0; a window already closed
//!   is the empty window `(UNBOUNDED, UNBOUNDED)`, which no schedule meets); each running
//!   action that is not paused becomes a completion action `(finish (ACTION))`: it must start
//!   at the new epoch (window `[0, 0]`), lasts what is left of the running action, keeps its
//!   invariants, has its at-end conditions and effects, and adds a fresh fact that is a goal,
//!   so every plan ends it. Extra goal facts (opportunistic goals) are appended after the
//!   task's own goals, so the indices of the task's goals (and of `dropped_goals`) stay. The
//!   original actions keep their ids; completion `k` is action `action_count() + k`.
//! - [`network_from_plan`]: a plan (actions with start times and durations) back into a
//!   [`PlanNetwork`] for the [`crate::Dispatcher`], with its ordering constraints recreated from
//!   the steps' conditions and effects by the search's rules (a read after the last writer, a
//!   write after the last writer and every reader since, `epsilon` apart; an end its duration
//!   after its start). So a plan made on the target is dispatched exactly as one made here.
//!
//! A ground action never overlaps itself in the planner; across a replan, a carried action's
//! own record also needs its completion's fact at start, so it starts again only after the
//! running one ended.
//!
//! `no_std`, heap-free: the caller hands in the state's storage and the output buffer; at most
//! [`MAX_CARRIED`] running actions and [`MAX_EXTRA_GOALS`] extra goals.
#![deny(clippy::indexing_slicing)]

use crate::constraints::Constraint;
use crate::dispatch::{NetworkError, PlanNetwork, PlanStep, MAX_DISPATCH_STEPS};
use crate::search::{for_each_read, for_each_write, snap_reads, PlannedAction};
use crate::task::{
    FactList, Linear, NumericList, Task, HEADER_BYTES, MAGIC, MAX_IDS, UNBOUNDED, VERSION,
};

/// Most running actions a replan carries as completions.
pub const MAX_CARRIED: usize = 32;
/// Most extra goal facts a replan adds.
pub const MAX_EXTRA_GOALS: usize = 32;
/// Most numeric effects of one snap action applied by [`apply`].
const MAX_SNAP_EFFECTS: usize = 16;

/// A step that was executed: the start or the end of `action`, at `at` ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Happening {
    pub action: u16,
    pub end: bool,
    pub at: u32,
}

/// A running action carried into a replan: what is left of it, in ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Carried {
    pub action: u16,
    pub remaining_lb: u32,
    pub remaining_ub: u32,
}

/// Why a replan could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReplanError {
    /// An action id not in the task.
    UnknownAction,
    /// A fact id not in the task.
    UnknownFact,
    /// The state storage is too small for the task.
    StateTooSmall,
    /// A numeric effect overflowed, or a snap has more than 16 numeric effects.
    Numeric,
    /// More than [`MAX_CARRIED`] running actions or [`MAX_EXTRA_GOALS`] extra goals.
    TooMany,
    /// The output buffer is too small.
    NoRoom,
    /// An end without a start before it, or a happening out of time order.
    BadHistory,
}

/// Words of fact bits a state of `task` needs.
pub fn fact_words(task: &Task<'_>) -> usize {
    task.fact_count().div_ceil(32)
}

/// Whether `fact` is set in `facts`.
pub fn fact(facts: &[u32], fact: usize) -> bool {
    facts
        .get(fact / 32)
        .is_some_and(|w| w & (1 << (fact % 32)) != 0)
}

fn set(facts: &mut [u32], fact: usize, on: bool) {
    if let Some(w) = facts.get_mut(fact / 32) {
        if on {
            *w |= 1 << (fact % 32);
        } else {
            *w &= !(1 << (fact % 32));
        }
    }
}

fn check_storage(task: &Task<'_>, facts: &[u32], values: &[i64]) -> Result<(), ReplanError> {
    if facts.len() < fact_words(task) || values.len() < task.numeric_count() {
        return Err(ReplanError::StateTooSmall);
    }
    Ok(())
}

/// The task's initial state into `facts` (bits) and `values` (fixed point).
pub fn initial_state(
    task: &Task<'_>,
    facts: &mut [u32],
    values: &mut [i64],
) -> Result<(), ReplanError> {
    check_storage(task, facts, values)?;
    facts.iter_mut().for_each(|w| *w = 0);
    for f in 0..task.fact_count() {
        set(facts, f, task.initially_true(f));
    }
    for (v, x) in values.iter_mut().enumerate().take(task.numeric_count()) {
        *x = task.initial_value(v);
    }
    Ok(())
}

/// Whether the start of `action` may happen in the state: its at-start and over-all conditions
/// (facts and numeric) hold.
pub fn start_holds(task: &Task<'_>, action: usize, facts: &[u32], values: &[i64]) -> bool {
    if action >= task.action_count() {
        return false;
    }
    let act = task.action(action);
    let value = |v: usize| values.get(v).copied().unwrap_or(0);
    act.facts(FactList::PreStart).iter().all(|f| fact(facts, f))
        && act
            .facts(FactList::Invariant)
            .iter()
            .all(|f| fact(facts, f))
        && act.numeric(NumericList::CondStart).all(|c| c.holds(&value))
        && act
            .numeric(NumericList::CondInvariant)
            .all(|c| c.holds(&value))
}

/// Apply the effects of the start (or end) of `action`: numeric effects on the values before
/// the snap, then deletes, then adds. Conditions are not checked (what happened happened).
pub fn apply(
    task: &Task<'_>,
    action: usize,
    end: bool,
    facts: &mut [u32],
    values: &mut [i64],
) -> Result<(), ReplanError> {
    check_storage(task, facts, values)?;
    if action >= task.action_count() {
        return Err(ReplanError::UnknownAction);
    }
    let act = task.action(action);
    let (add, del, effs) = if end {
        (FactList::AddEnd, FactList::DelEnd, NumericList::EffEnd)
    } else {
        (
            FactList::AddStart,
            FactList::DelStart,
            NumericList::EffStart,
        )
    };
    let mut new = [(0usize, 0i64); MAX_SNAP_EFFECTS];
    let mut n = 0;
    for e in act.numeric(effs) {
        let x = e
            .apply(&|v| values.get(v).copied().unwrap_or(0))
            .ok_or(ReplanError::Numeric)?;
        *new.get_mut(n).ok_or(ReplanError::Numeric)? = (e.target, x);
        n += 1;
    }
    for f in act.facts(del).iter() {
        set(facts, f, false);
    }
    for f in act.facts(add).iter() {
        set(facts, f, true);
    }
    for &(v, x) in new.get(..n).unwrap_or(&[]) {
        if let Some(slot) = values.get_mut(v) {
            *slot = x;
        }
    }
    Ok(())
}

/// The state after `history` (in the order it happened) from the task's initial state.
/// Returns how many actions are still running (started, not ended).
pub fn replay(
    task: &Task<'_>,
    history: &[Happening],
    facts: &mut [u32],
    values: &mut [i64],
) -> Result<usize, ReplanError> {
    initial_state(task, facts, values)?;
    let mut last = 0u32;
    let mut running = 0usize;
    for (i, h) in history.iter().enumerate() {
        if h.at < last {
            return Err(ReplanError::BadHistory);
        }
        last = h.at;
        if h.end {
            let started = history
                .get(..i)
                .unwrap_or(&[])
                .iter()
                .filter(|p| p.action == h.action)
                .fold(0i32, |n, p| if p.end { n - 1 } else { n + 1 });
            if started <= 0 {
                return Err(ReplanError::BadHistory);
            }
            running -= 1;
        } else {
            running += 1;
        }
        apply(task, usize::from(h.action), h.end, facts, values)?;
    }
    Ok(running)
}

/// Whether `action` is pausable: it deletes at start a fact `inactive` names and adds it back at
/// end (it takes a component out of its inactive state for its duration).
pub fn is_pausable(task: &Task<'_>, action: usize, inactive: &dyn Fn(usize) -> bool) -> bool {
    if action >= task.action_count() {
        return false;
    }
    let act = task.action(action);
    let add_end = act.facts(FactList::AddEnd);
    act.facts(FactList::DelStart)
        .iter()
        .any(|f| inactive(f) && add_end.contains(f))
}

/// Pause the running `action`: undo its at-start fact effects (restore what it deleted, remove
/// what it added that it did not also delete). Its at-end effects will not happen.
pub fn pause(task: &Task<'_>, action: usize, facts: &mut [u32]) -> Result<(), ReplanError> {
    if action >= task.action_count() {
        return Err(ReplanError::UnknownAction);
    }
    if facts.len() < fact_words(task) {
        return Err(ReplanError::StateTooSmall);
    }
    let act = task.action(action);
    let del = act.facts(FactList::DelStart);
    for f in act.facts(FactList::AddStart).iter() {
        if !del.contains(f) {
            set(facts, f, false);
        }
    }
    for f in del.iter() {
        set(facts, f, true);
    }
    Ok(())
}

/// A window moved to an epoch `now` ticks later; a window closed before `now` is empty.
pub fn shift_window(w: (u32, u32), now: u32) -> (u32, u32) {
    let (lo, hi) = w;
    if hi == UNBOUNDED {
        return (lo.saturating_sub(now), UNBOUNDED);
    }
    if hi < now {
        return (UNBOUNDED, UNBOUNDED);
    }
    (lo.saturating_sub(now), hi - now)
}

/// What a replan starts from.
#[derive(Clone, Copy)]
pub struct ReplanInput<'a> {
    /// The task being executed (epoch 0 is its time zero).
    pub task: Task<'a>,
    /// The new epoch, ticks after the task's.
    pub now: u32,
    /// The state now (after pausing what was paused).
    pub facts: &'a [u32],
    pub values: &'a [i64],
    /// Running actions that go on to their end.
    pub carried: &'a [Carried],
    /// Goal facts to add after the task's own (duplicates of its goals are left out).
    pub extra_goals: &'a [u16],
}

/// Bytes a linear record takes.
fn linear_len(l: &Linear<'_>, effect: bool) -> usize {
    1 + if effect { 2 } else { 0 } + 1 + 8 + 10 * l.terms
}

/// A bounded writer into the output buffer.
struct Out<'o> {
    buf: &'o mut [u8],
    at: usize,
}

impl Out<'_> {
    fn put(&mut self, b: &[u8]) -> Result<(), ReplanError> {
        let end = self.at.checked_add(b.len()).ok_or(ReplanError::NoRoom)?;
        self.buf
            .get_mut(self.at..end)
            .ok_or(ReplanError::NoRoom)?
            .copy_from_slice(b);
        self.at = end;
        Ok(())
    }
    fn u16(&mut self, v: u16) -> Result<(), ReplanError> {
        self.put(&v.to_le_bytes())
    }
    fn u32(&mut self, v: u32) -> Result<(), ReplanError> {
        self.put(&v.to_le_bytes())
    }
    fn linear(&mut self, l: &Linear<'_>, effect: bool) -> Result<(), ReplanError> {
        self.put(&[l.kind])?;
        if effect {
            self.u16(l.target as u16)?;
        }
        self.put(&[l.terms as u8])?;
        self.put(&l.constant.to_le_bytes())?;
        for i in 0..l.terms {
            let (v, w) = l.term(i);
            self.u16(v as u16)?;
            self.put(&w.to_le_bytes())?;
        }
        Ok(())
    }
}

/// Bytes of the completion record of `action`.
fn completion_len(task: &Task<'_>, action: usize) -> usize {
    let act = task.action(action);
    let lists = [
        0,
        act.facts(FactList::Invariant).len(),
        act.facts(FactList::PreEnd).len(),
        0,
        0,
        act.facts(FactList::AddEnd).len() + 1,
        act.facts(FactList::DelEnd).len(),
    ];
    let numeric: usize = [
        NumericList::CondInvariant,
        NumericList::CondEnd,
        NumericList::EffEnd,
    ]
    .iter()
    .map(|&l| {
        act.numeric(l)
            .map(|x| linear_len(&x, l == NumericList::EffEnd))
            .sum::<usize>()
    })
    .sum();
    24 + lists.iter().map(|n| 2 + 2 * n).sum::<usize>() + 5 + numeric
}

const COMPLETION_PREFIX: &[u8] = b"(finish ";

/// Write the replan task (see the module's documentation) into `out`; returns its length.
pub fn write_replan_task(input: &ReplanInput<'_>, out: &mut [u8]) -> Result<usize, ReplanError> {
    let task = &input.task;
    check_storage(task, input.facts, input.values)?;
    if input.carried.len() > MAX_CARRIED || input.extra_goals.len() > MAX_EXTRA_GOALS {
        return Err(ReplanError::TooMany);
    }
    let facts = task.fact_count();
    let actions = task.action_count();
    let k = input.carried.len();
    let new_facts = facts + k;
    let new_actions = actions + k;
    if new_facts >= MAX_IDS || new_actions >= MAX_IDS {
        return Err(ReplanError::TooMany);
    }
    for c in input.carried {
        if usize::from(c.action) >= actions || c.remaining_lb > c.remaining_ub {
            return Err(ReplanError::UnknownAction);
        }
    }
    let goals = task.goal_facts();
    let mut extra = [0u16; MAX_EXTRA_GOALS];
    let mut n_extra = 0;
    for &g in input.extra_goals {
        if usize::from(g) >= facts {
            return Err(ReplanError::UnknownFact);
        }
        let seen =
            goals.contains(usize::from(g)) || extra.get(..n_extra).unwrap_or(&[]).contains(&g);
        if !seen {
            if let Some(slot) = extra.get_mut(n_extra) {
                *slot = g;
                n_extra += 1;
            }
        }
    }
    let extra = extra.get(..n_extra).unwrap_or(&[]);
    let goal_count = goals.len() + n_extra + k;
    if goal_count >= MAX_IDS {
        return Err(ReplanError::TooMany);
    }
    let conds_len: usize = task.goal_conditions().map(|c| linear_len(&c, false)).sum();
    let records_at = HEADER_BYTES
        + new_facts.div_ceil(8)
        + 8 * task.numeric_count()
        + 2 * goal_count
        + conds_len
        + 4 * new_actions;
    // A carried action's own record needs its completion's fact to start again (no
    // self-overlap across the replan): two bytes more per lock.
    let locks = |a: usize| {
        input
            .carried
            .iter()
            .filter(move |c| usize::from(c.action) == a)
            .count()
    };
    let record_len = |a: usize| task.action_record(a).len() + 2 * locks(a);
    let originals: usize = (0..actions).map(record_len).sum();
    let completions: usize = input
        .carried
        .iter()
        .map(|c| completion_len(task, usize::from(c.action)))
        .sum();
    let names_at = records_at + originals + completions;
    let mut o = Out { buf: out, at: 0 };
    o.put(&MAGIC)?;
    o.u16(VERSION)?;
    o.u16(new_facts as u16)?;
    o.u16(task.numeric_count() as u16)?;
    o.u16(new_actions as u16)?;
    o.u32(task.epsilon())?;
    o.u32(task.ticks_per_unit())?;
    o.u16(goal_count as u16)?;
    o.u16(task.goal_conditions().count() as u16)?;
    o.u32(u32::try_from(names_at).map_err(|_| ReplanError::NoRoom)?)?;
    for byte in 0..new_facts.div_ceil(8) {
        let mut b = 0u8;
        for bit in 0..8 {
            let f = 8 * byte + bit;
            if f < facts && fact(input.facts, f) {
                b |= 1 << bit;
            }
        }
        o.put(&[b])?;
    }
    for v in 0..task.numeric_count() {
        o.put(&input.values.get(v).copied().unwrap_or(0).to_le_bytes())?;
    }
    for g in goals.iter() {
        o.u16(g as u16)?;
    }
    for &g in extra {
        o.u16(g)?;
    }
    for i in 0..k {
        o.u16((facts + i) as u16)?;
    }
    for c in task.goal_conditions() {
        o.linear(&c, false)?;
    }
    let mut at = records_at;
    for a in 0..actions {
        o.u32(at as u32)?;
        at += record_len(a);
    }
    for c in input.carried {
        o.u32(at as u32)?;
        at += completion_len(task, usize::from(c.action));
    }
    // The original records, their windows moved to the new epoch.
    for a in 0..actions {
        let act = task.action(a);
        let record = task.action_record(a);
        let (sw, ew) = (
            shift_window(act.start_window, input.now),
            shift_window(act.end_window, input.now),
        );
        o.put(record.get(..8).ok_or(ReplanError::NoRoom)?)?;
        for x in [sw.0, sw.1, ew.0, ew.1] {
            o.u32(x)?;
        }
        let n = locks(a);
        if n == 0 {
            o.put(record.get(24..).ok_or(ReplanError::NoRoom)?)?;
            continue;
        }
        // The at-start conditions, then the completions' facts, then the rest as it was.
        let pre = act.facts(FactList::PreStart);
        o.u16(u16::try_from(pre.len() + n).map_err(|_| ReplanError::TooMany)?)?;
        for f in pre.iter() {
            o.u16(f as u16)?;
        }
        for (k, c) in input.carried.iter().enumerate() {
            if usize::from(c.action) == a {
                o.u16((facts + k) as u16)?;
            }
        }
        o.put(
            record
                .get(26 + 2 * pre.len()..)
                .ok_or(ReplanError::NoRoom)?,
        )?;
    }
    // The completions.
    for (i, c) in input.carried.iter().enumerate() {
        let act = task.action(usize::from(c.action));
        o.u32(c.remaining_lb)?;
        o.u32(c.remaining_ub)?;
        let ew = shift_window(act.end_window, input.now);
        for x in [0, 0, ew.0, ew.1] {
            o.u32(x)?;
        }
        let lists = [
            None,
            Some(FactList::Invariant),
            Some(FactList::PreEnd),
            None,
            None,
            Some(FactList::AddEnd),
            Some(FactList::DelEnd),
        ];
        for list in lists {
            let done = list == Some(FactList::AddEnd);
            match list {
                None => o.u16(0)?,
                Some(l) => {
                    let fl = act.facts(l);
                    o.u16((fl.len() + usize::from(done)) as u16)?;
                    for f in fl.iter() {
                        o.u16(f as u16)?;
                    }
                    if done {
                        o.u16((facts + i) as u16)?;
                    }
                }
            }
        }
        let numeric = [
            None,
            Some(NumericList::CondInvariant),
            Some(NumericList::CondEnd),
            None,
            Some(NumericList::EffEnd),
        ];
        for list in numeric {
            match list {
                None => o.put(&[0])?,
                Some(l) => {
                    o.put(&[act.numeric(l).count() as u8])?;
                    for x in act.numeric(l) {
                        o.linear(&x, l == NumericList::EffEnd)?;
                    }
                }
            }
        }
    }
    if o.at != names_at {
        return Err(ReplanError::NoRoom);
    }
    for a in 0..actions {
        let name = task.action_name(a).as_bytes();
        o.u16(name.len() as u16)?;
        o.put(name)?;
    }
    for c in input.carried {
        let name = task.action_name(usize::from(c.action)).as_bytes();
        let len = COMPLETION_PREFIX.len() + name.len() + 1;
        o.u16(u16::try_from(len).map_err(|_| ReplanError::TooMany)?)?;
        o.put(COMPLETION_PREFIX)?;
        o.put(name)?;
        o.put(b")")?;
    }
    Ok(o.at)
}

/// What is left of an action started `elapsed` ticks ago by its duration bounds (at least 0).
pub fn remaining(task: &Task<'_>, action: usize, elapsed: u32) -> Option<Carried> {
    if action >= task.action_count() {
        return None;
    }
    let act = task.action(action);
    let ub = if act.duration_ub == UNBOUNDED {
        UNBOUNDED
    } else {
        act.duration_ub.saturating_sub(elapsed)
    };
    Some(Carried {
        action: action as u16,
        remaining_lb: act.duration_lb.saturating_sub(elapsed).min(ub),
        remaining_ub: ub,
    })
}

// ----- a plan back into a network ----------------------------------------------------------------

// The search's own rules for what a snap reads and writes ([`crate::search`]'s ordering), so
// a plan from the target and a plan from the search recreate the same constraints.

/// The network of `plan` (actions of `task` with their start times and durations, ticks):
/// its steps in time order (a start before its own end), the constraints recreated between
/// them, its makespan. `scratch` needs a word per fact and numeric variable of the task.
///
/// With `open_ends`, an action's end is bounded below by its duration's lower bound only: an
/// action that runs longer than planned (a traverse slower than its estimate; ends are
/// reported, not dispatched) does not by itself invalidate the plan, only when what must
/// follow it can no longer start within its window (section 5.2). Without, the duration's
/// upper bound stays and an overrun past it asks for a replan at once.
pub fn network_from_plan(
    task: &Task<'_>,
    plan: &[PlannedAction],
    open_ends: bool,
    scratch: &mut [u32],
    net: &mut PlanNetwork,
) -> Result<(), NetworkError> {
    let mut progress = network_from_plan_begin(task, plan, scratch, net)?;
    network_from_plan_steps(
        task,
        plan,
        open_ends,
        scratch,
        net,
        &mut progress,
        &mut || true,
    )?;
    Ok(())
}

/// How far a network built in pieces is ([`network_from_plan_begin`], then
/// [`network_from_plan_steps`] until it says done): steps added so far, of `total`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NetworkProgress {
    pub next: usize,
    pub total: usize,
}

/// The plan's snaps (time, plan index, is end) in time order, into `order`; their number.
fn plan_order(
    task: &Task<'_>,
    plan: &[PlannedAction],
    order: &mut [(u32, u16, bool); MAX_DISPATCH_STEPS],
) -> Result<usize, NetworkError> {
    if 2 * plan.len() > MAX_DISPATCH_STEPS {
        return Err(NetworkError::TooManySteps);
    }
    let mut n = 0;
    for (i, p) in plan.iter().enumerate() {
        if usize::from(p.action) >= task.action_count() {
            return Err(NetworkError::UnknownStep);
        }
        let end = p
            .start
            .checked_add(p.duration)
            .ok_or(NetworkError::Inconsistent)?;
        for s in [(p.start, i as u16, false), (end, i as u16, true)] {
            *order.get_mut(n).ok_or(NetworkError::TooManySteps)? = s;
            n += 1;
        }
    }
    let order = order.get_mut(..n).unwrap_or(&mut []);
    // An insertion sort (at most 256 entries, all distinct, so the order is the one any sort
    // gives): the standard library's sort monomorphised for these tuples would put about 13 KB
    // more code in the target's image, which the warm boot checks word by word.
    for k in 1..order.len() {
        let mut j = k;
        while j > 0 && order.get(j - 1) > order.get(j) {
            order.swap(j - 1, j);
            j -= 1;
        }
    }
    Ok(n)
}

/// [`network_from_plan`] in pieces: the first, which checks the plan, empties `net` and sets
/// its makespan. The steps follow by [`network_from_plan_steps`], with the same `scratch` and
/// `net` untouched in between.
pub fn network_from_plan_begin(
    task: &Task<'_>,
    plan: &[PlannedAction],
    scratch: &mut [u32],
    net: &mut PlanNetwork,
) -> Result<NetworkProgress, NetworkError> {
    let ids = task.fact_count() + task.numeric_count();
    let last_writer = scratch.get_mut(..ids).ok_or(NetworkError::TooManySteps)?;
    last_writer.iter_mut().for_each(|w| *w = 0);
    let mut order = [(0u32, 0u16, false); MAX_DISPATCH_STEPS];
    let n = plan_order(task, plan, &mut order)?;
    net.clear();
    net.makespan = order
        .get(..n)
        .unwrap_or(&[])
        .iter()
        .map(|s| s.0)
        .max()
        .unwrap_or(0);
    Ok(NetworkProgress { next: 0, total: n })
}

/// The next steps of a network built in pieces, each with the constraints into it: one step,
/// then more while `more()` says so (it is asked before each further step). True when the
/// last step is in: the network is [`network_from_plan`]'s.
pub fn network_from_plan_steps(
    task: &Task<'_>,
    plan: &[PlannedAction],
    open_ends: bool,
    scratch: &mut [u32],
    net: &mut PlanNetwork,
    progress: &mut NetworkProgress,
    more: &mut dyn FnMut() -> bool,
) -> Result<bool, NetworkError> {
    let ids = task.fact_count() + task.numeric_count();
    let last_writer = scratch.get_mut(..ids).ok_or(NetworkError::TooManySteps)?;
    let mut order = [(0u32, 0u16, false); MAX_DISPATCH_STEPS];
    let n = plan_order(task, plan, &mut order)?;
    if n != progress.total || progress.next > n || net.step_count() != progress.next {
        return Err(NetworkError::UnknownStep);
    }
    let order = order.get(..n).unwrap_or(&[]);
    // Each action's start step (a start comes before its own end).
    let mut start_step = [0u16; MAX_DISPATCH_STEPS];
    for (j0, &(_, i, end)) in order.iter().enumerate() {
        if !end {
            if let Some(s) = start_step.get_mut(usize::from(i)) {
                *s = (j0 + 1) as u16;
            }
        }
    }
    let eps = task.epsilon();
    let facts = task.fact_count();
    let from = progress.next;
    for (j0, &(_, i, end)) in order.iter().enumerate().skip(from) {
        if j0 > from && !more() {
            return Ok(false);
        }
        let j = j0 + 1;
        let p = plan.get(usize::from(i)).ok_or(NetworkError::UnknownStep)?;
        let a = usize::from(p.action);
        let act = task.action(a);
        net.add_step(PlanStep {
            action: p.action,
            end,
            window: if end {
                act.end_window
            } else {
                act.start_window
            },
        })?;
        // Constraints into step j, merged per earlier step.
        let mut cs = [(0usize, 0u32, UNBOUNDED); 64];
        let mut m = 0usize;
        let mut failed = false;
        let mut add = |before: usize, lb: u32, ub: u32| {
            if before == 0 && lb == 0 {
                return;
            }
            for c in cs.iter_mut().take(m) {
                if c.0 == before {
                    c.1 = c.1.max(lb);
                    c.2 = c.2.min(ub);
                    return;
                }
            }
            match cs.get_mut(m) {
                Some(slot) => {
                    *slot = (before, lb, ub);
                    m += 1;
                }
                None => failed = true,
            }
        };
        let writer = |id: usize| last_writer.get(id).copied().unwrap_or(0) as usize;
        for_each_read(task, a, end, &mut |id| {
            let w = writer(id);
            if w > 0 {
                add(w, eps, UNBOUNDED);
            }
        });
        let steps_so_far = &*net;
        for_each_write(task, a, end, &mut |id, is_delete| {
            let w = writer(id);
            if w > 0 {
                add(w, eps, UNBOUNDED);
            }
            for s in w + 1..j {
                if let Some(step) = steps_so_far.step(s) {
                    if snap_reads(
                        task,
                        u32::from(step.action),
                        step.end,
                        id,
                        is_delete || id >= facts,
                    ) {
                        add(s, eps, UNBOUNDED);
                    }
                }
            }
        });
        if end {
            let s = start_step.get(usize::from(i)).copied().unwrap_or(0);
            let ub = if open_ends {
                UNBOUNDED
            } else {
                act.duration_ub
            };
            add(usize::from(s), act.duration_lb, ub);
        }
        if failed {
            return Err(NetworkError::TooManyConstraints);
        }
        for &(before, lb, ub) in cs.get(..m).unwrap_or(&[]) {
            net.add_constraint(Constraint {
                before: before as u16,
                after: j as u16,
                lb,
                ub,
            })?;
        }
        for_each_write(task, a, end, &mut |id, _| {
            if let Some(w) = last_writer.get_mut(id) {
                *w = j as u32;
            }
        });
        progress.next = j;
    }
    Ok(true)
}
