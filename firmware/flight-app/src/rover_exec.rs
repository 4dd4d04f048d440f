//! The executive's side of the rover's dispatch decisions (issue 13 item 3): the decisions the
//! rover mission takes today in the planner partition ([`crate::rover_mission`]'s `poll`: which
//! step starts, at what against its window, when to wake, which step is past its ub), taken
//! from the network the executive holds (`autonomy::partitioned::ExecutiveDispatch`, sent by
//! the planner in chunks) with its dispatcher's poll divided across calls of a budget of work
//! units (`temporal::Dispatcher::poll_begin`, `poll_continue`: the executive's cycles).
//!
//! What the executive cannot know by itself comes from the planner partition, which keeps the
//! mission's state:
//! - [`RoverPlanNote`], once per plan: its generation (the network's plan), its epoch, the
//!   task's action count (the completions of carried actions are the actions after it: they
//!   start at the epoch) and the actions running with their end steps;
//! - a readiness mask ([`crate::rover_mission::ReadyMask`], `RoverMission::ready_mask`) after
//!   each happening the mission applied: which start steps' actions have their at-start
//!   conditions holding in the state now. Readiness changes only by the happenings the mission
//!   applies (a start, an end, a pause), so the mask made after the last one answers the poll
//!   as the mission's own `start_holds` does (the host's lockstep must then give the executive
//!   the mask before its next poll: an `Ended`'s answer after the planner applied it).
//!
//! The decider's answers are the mission's reports (`Dispatch`, `Wait`, `Finished`) or a
//! replan for the planner with its reason, so the host's transcript and its decisions' hash
//! are the mission's. Memory: fixed arrays (about 3 KB), no heap; every input out of range is
//! refused ([`RoverRefusal`]), never a panic.
#![deny(clippy::indexing_slicing)]

use autonomy::partitioned::ExecutivePartition;
use fsw_bridge::temporal::{RoverRefusal, RoverReplanWhy, RoverReport};
use temporal::dispatch::{Decision, MAX_DISPATCH_STEPS};
use temporal::task::UNBOUNDED;

use crate::rover_mission::{start_kind, ReadyMask, MAX_ROVER_ACTIVE, NO_ACTION};

/// Work units of one call of the divided poll (a unit is a constraint or a step looked at).
pub const ROVER_SLICE_UNITS: u32 = 256;

/// What the planner tells the executive of a plan once its network is sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RoverPlanNote {
    /// The network's plan (`DispatchSender`'s and the executive's `loaded()` plan).
    pub plan: u32,
    /// Mission time (ms) of the network's time 0.
    pub epoch: u32,
    /// The mission's task's action count: steps of actions from it on are completions of
    /// carried actions, executed at the epoch.
    pub base_actions: u16,
    /// The actions running on the rover and their end steps in this network (0: none).
    pub running: [(u16, u16); MAX_ROVER_ACTIVE],
    pub running_len: u8,
}

/// The executive's answer to a poll.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExecAnswer {
    /// A report for the host: `Dispatch`, `Wait` or `Finished`.
    Report(RoverReport),
    /// The plan no longer fits: the planner replans from `at_ms` for `why` (its `Replan`).
    Replan { at_ms: u32, why: RoverReplanWhy },
    /// The event is refused, nothing changed.
    Refused(RoverRefusal),
}

/// The executive's rover dispatch: see the module's documentation.
pub struct RoverDecider {
    has_plan: bool,
    plan: u32,
    epoch: u32,
    /// Each step's window when the plan was loaded (relative to the epoch).
    planned: [(u32, u32); MAX_DISPATCH_STEPS + 1],
    /// The actions ready now, sorted (from the last readiness mask).
    ready: [u16; MAX_DISPATCH_STEPS],
    ready_len: usize,
    /// The steps the planner's mission had executed when it made the mask (None: no mask
    /// since the plan was loaded or the decider restored).
    ready_stamp: Option<u16>,
    running: [(u16, u16); MAX_ROVER_ACTIVE],
    running_len: usize,
    waited: bool,
    wait_until: u32,
    wait_at: u32,
    held: bool,
    held_until: u32,
    held_from: u32,
    last_ms: u32,
    /// A divided poll in progress, at this mission time.
    polling: Option<u32>,
    /// Work units and calls of the last poll.
    pub last_units: u32,
    pub last_calls: u32,
}

impl Default for RoverDecider {
    fn default() -> Self {
        Self::new()
    }
}

impl RoverDecider {
    pub const fn new() -> Self {
        Self {
            has_plan: false,
            plan: 0,
            epoch: 0,
            planned: [(0, 0); MAX_DISPATCH_STEPS + 1],
            ready: [0; MAX_DISPATCH_STEPS],
            ready_len: 0,
            ready_stamp: None,
            running: [(0, 0); MAX_ROVER_ACTIVE],
            running_len: 0,
            waited: false,
            wait_until: 0,
            wait_at: 0,
            held: false,
            held_until: 0,
            held_from: 0,
            last_ms: 0,
            polling: None,
            last_units: 0,
            last_calls: 0,
        }
    }

    /// Whether a plan is being dispatched.
    pub fn has_plan(&self) -> bool {
        self.has_plan
    }

    /// The plan the planner described in `note` is held whole by `exec`: dispatch it from now
    /// on. Its windows as planned are the dispatcher's now; the completions of carried actions
    /// are executed at the epoch (each reaches the planner as an `Executed` note).
    pub fn plan_loaded(
        &mut self,
        exec: &mut ExecutivePartition,
        note: &RoverPlanNote,
    ) -> Result<(), RoverRefusal> {
        let held = exec.dispatch().loaded().map(|(p, _)| p);
        if held != Some(note.plan) || usize::from(note.running_len) > MAX_ROVER_ACTIVE {
            return Err(RoverRefusal::BadTask);
        }
        let Some(d) = exec.dispatcher_mut() else {
            return Err(RoverRefusal::BadTask);
        };
        let steps = d.network().step_count();
        for k in 0..=MAX_DISPATCH_STEPS {
            if let Some(p) = self.planned.get_mut(k) {
                *p = if k <= steps {
                    d.window(k).unwrap_or((0, 0))
                } else {
                    (0, 0)
                };
            }
        }
        for k in 1..=steps {
            let completion = exec
                .dispatch()
                .loaded()
                .and_then(|(_, d)| d.network().step(k))
                .is_some_and(|s| !s.end && s.action >= note.base_actions);
            if completion && exec.dispatch_executed(k as u16, 0).is_err() {
                return Err(RoverRefusal::BadTask);
            }
        }
        self.has_plan = true;
        self.plan = note.plan;
        self.epoch = note.epoch;
        self.running = note.running;
        self.running_len = usize::from(note.running_len);
        self.waited = false;
        self.held = false;
        self.polling = None;
        self.ready_len = 0;
        self.ready_stamp = None;
        Ok(())
    }

    /// The planner replans (an opportunistic goal, or this decider's `Replan`): nothing is
    /// dispatched until the next plan.
    pub fn plan_dropped(&mut self) {
        self.has_plan = false;
        self.waited = false;
        self.held = false;
        self.polling = None;
    }

    /// The readiness mask the planner made after the last happening it applied, when its
    /// mission had executed `stamp` steps of the flown network
    /// (`RoverMission::executed_steps`). The lockstep: [`Self::poll_begin`] refuses to poll
    /// (`Busy`) until the mask's stamp is the count of steps this executive has executed, so a
    /// poll never uses readiness from before a happening the planner has not applied yet.
    pub fn set_ready(&mut self, exec: &ExecutivePartition, mask: &ReadyMask, stamp: u16) {
        self.ready_len = 0;
        self.ready_stamp = Some(stamp);
        let Some((_, d)) = exec.dispatch().loaded() else {
            return;
        };
        let net = d.network();
        for k in 1..=net.step_count() {
            let set = mask.get(k / 32).is_some_and(|w| w & (1 << (k % 32)) != 0);
            let Some(s) = net.step(k).filter(|s| set && !s.end) else {
                continue;
            };
            // Insertion into the sorted, distinct list (at most one entry per step).
            let list = self.ready.get(..self.ready_len).unwrap_or_default();
            let Err(at) = list.binary_search(&s.action) else {
                continue;
            };
            if self.ready_len >= self.ready.len() {
                break;
            }
            if let Some(tail) = self.ready.get_mut(at..=self.ready_len) {
                tail.rotate_right(1);
                if let Some(first) = tail.first_mut() {
                    *first = s.action;
                }
            }
            self.ready_len += 1;
        }
    }

    /// Whether `action` is ready by the last mask.
    pub fn is_ready(&self, action: u16) -> bool {
        self.ready
            .get(..self.ready_len)
            .is_some_and(|l| l.binary_search(&action).is_ok())
    }

    /// The rover says `action` ended at `at`: its end step is executed (an `Executed` note for
    /// the planner). The planner applies the end itself (the host's `Ended` goes to both).
    pub fn ended(
        &mut self,
        exec: &mut ExecutivePartition,
        action: u16,
        at: u32,
    ) -> Result<(), RoverRefusal> {
        let n = self.running_len;
        let Some(i) = self
            .running
            .get(..n)
            .and_then(|rs| rs.iter().position(|r| r.0 == action))
        else {
            return Err(RoverRefusal::NotRunning { action });
        };
        if at < self.last_ms {
            return Err(RoverRefusal::OutOfOrder {
                last_ms: self.last_ms,
            });
        }
        let end_step = self.running.get(i).map_or(0, |r| r.1);
        self.last_ms = at;
        if let Some(rs) = self.running.get_mut(i..n) {
            rs.rotate_left(1);
        }
        self.running_len -= 1;
        if self.has_plan && end_step != 0 {
            // A step executed already changes nothing (as in the mission).
            let _ = exec.dispatch_executed(end_step, at.saturating_sub(self.epoch));
        }
        Ok(())
    }

    /// Begins the poll at mission time `now` (divided: see [`Self::poll_continue`]).
    pub fn poll_begin(
        &mut self,
        exec: &mut ExecutivePartition,
        now: u32,
    ) -> Result<(), RoverRefusal> {
        if !self.has_plan {
            return Err(RoverRefusal::NoMission);
        }
        if now < self.last_ms {
            return Err(RoverRefusal::OutOfOrder {
                last_ms: self.last_ms,
            });
        }
        let Some(d) = exec.dispatcher_mut() else {
            return Err(RoverRefusal::NoMission);
        };
        if self.ready_stamp != Some(executed_steps(d)) {
            // The planner's mask after the last happening has not come back yet.
            return Err(RoverRefusal::Busy);
        }
        self.last_ms = now;
        if self.waited {
            self.waited = false;
            self.held = self.wait_until == now;
            self.held_until = self.wait_until;
            self.held_from = self.wait_at;
        }
        d.poll_begin(now.saturating_sub(self.epoch));
        self.polling = Some(now);
        self.last_calls = 0;
        Ok(())
    }

    /// About `budget` units more of the poll begun; its answer once decided, else None.
    pub fn poll_continue(
        &mut self,
        exec: &mut ExecutivePartition,
        budget: u32,
    ) -> Option<ExecAnswer> {
        let now = self.polling?;
        let decision = {
            let d = exec.dispatcher_mut()?;
            let ready = |a: u16| self.is_ready(a);
            d.poll_continue(&ready, budget)
        };
        self.last_calls = self.last_calls.saturating_add(1);
        let decision = decision?;
        self.polling = None;
        self.last_units = exec.dispatch().loaded().map_or(0, |(_, d)| d.poll_units());
        Some(self.decided(exec, now, decision))
    }

    /// A whole poll at `now` (divided in calls of [`ROVER_SLICE_UNITS`], run to its end).
    pub fn poll(&mut self, exec: &mut ExecutivePartition, now: u32) -> ExecAnswer {
        if let Err(r) = self.poll_begin(exec, now) {
            return ExecAnswer::Refused(r);
        }
        loop {
            if let Some(a) = self.poll_continue(exec, ROVER_SLICE_UNITS) {
                return a;
            }
            if self.polling.is_none() {
                return ExecAnswer::Refused(RoverRefusal::NoMission);
            }
        }
    }

    /// Writes the decider's state into `buf` (for the executive's checkpoint beside its
    /// dispatch part, which holds the network and its executed steps): `[format, fields,
    /// the planned windows of the network's steps, CRC-32]`, at most [`RECORD_MAX_BYTES`].
    /// The readiness list is not kept: the planner sends its mask before the next poll. A
    /// poll in progress is not kept either: it begins again. None if `buf` is too small.
    pub fn encode(&self, steps: usize, buf: &mut [u8]) -> Option<usize> {
        let steps = steps.min(MAX_DISPATCH_STEPS);
        let mut w = Writer { buf, at: 0 };
        w.put(&[
            RECORD_FORMAT,
            u8::from(self.has_plan),
            u8::from(self.waited),
            u8::from(self.held),
        ])?;
        for v in [
            self.plan,
            self.epoch,
            self.wait_until,
            self.wait_at,
            self.held_until,
            self.held_from,
            self.last_ms,
        ] {
            w.put(&v.to_le_bytes())?;
        }
        w.put(&[u8::try_from(self.running_len).ok()?])?;
        for &(a, e) in self.running.get(..self.running_len)? {
            w.put(&a.to_le_bytes())?;
            w.put(&e.to_le_bytes())?;
        }
        w.put(&(steps as u16).to_le_bytes())?;
        for &(lb, ub) in self.planned.get(..=steps)? {
            w.put(&lb.to_le_bytes())?;
            w.put(&ub.to_le_bytes())?;
        }
        let len = w.at;
        let crc = crate::rover_mission::checkpoint::crc32(w.buf.get(..len)?);
        w.put(&crc.to_le_bytes())?;
        Some(w.at)
    }

    /// Takes the state [`Self::encode`] wrote (after a reset of the executive partition); a
    /// damaged record is refused with its reason and changes nothing.
    pub fn decode(&mut self, bytes: &[u8]) -> Result<usize, RecordError> {
        let mut r = Reader { bytes, at: 0 };
        let head = r.take(4)?;
        if head.first() != Some(&RECORD_FORMAT) {
            return Err(RecordError::Version);
        }
        let flag = |i: usize| head.get(i).is_some_and(|&b| b != 0);
        let mut v = [0u32; 7];
        for x in v.iter_mut() {
            *x = r.u32()?;
        }
        let running_len = usize::from(*r.take(1)?.first().ok_or(RecordError::BadLength)?);
        if running_len > MAX_ROVER_ACTIVE {
            return Err(RecordError::OutOfRange);
        }
        let mut running = [(0u16, 0u16); MAX_ROVER_ACTIVE];
        for slot in running.iter_mut().take(running_len) {
            *slot = (r.u16()?, r.u16()?);
        }
        let steps = usize::from(r.u16()?);
        if steps > MAX_DISPATCH_STEPS {
            return Err(RecordError::OutOfRange);
        }
        let planned_at = r.at;
        r.take((steps + 1) * 8)?;
        let len = r.at;
        let crc = r.u32()?;
        if crate::rover_mission::checkpoint::crc32(bytes.get(..len).unwrap_or_default()) != crc {
            return Err(RecordError::BadCrc);
        }
        let mut p = Reader {
            bytes,
            at: planned_at,
        };
        for k in 0..=MAX_DISPATCH_STEPS {
            let w = if k <= steps {
                (p.u32()?, p.u32()?)
            } else {
                (0, 0)
            };
            if let Some(slot) = self.planned.get_mut(k) {
                *slot = w;
            }
        }
        self.has_plan = flag(1);
        self.waited = flag(2);
        self.held = flag(3);
        let [plan, epoch, wait_until, wait_at, held_until, held_from, last_ms] = v;
        self.plan = plan;
        self.epoch = epoch;
        self.wait_until = wait_until;
        self.wait_at = wait_at;
        self.held_until = held_until;
        self.held_from = held_from;
        self.last_ms = last_ms;
        self.running = running;
        self.running_len = running_len;
        self.ready_len = 0;
        self.ready_stamp = None;
        self.polling = None;
        Ok(r.at)
    }

    /// The decision as the mission's `poll` reports it.
    fn decided(
        &mut self,
        exec: &mut ExecutivePartition,
        now: u32,
        decision: Decision,
    ) -> ExecAnswer {
        let epoch = self.epoch;
        let rel = now.saturating_sub(epoch);
        match decision {
            Decision::Start { step, action } => {
                let (lb, ub) = self.planned.get(step).copied().unwrap_or((0, 0));
                let Ok(step16) = u16::try_from(step) else {
                    return ExecAnswer::Refused(RoverRefusal::BadTask);
                };
                if exec.dispatch_executed(step16, rel).is_err() {
                    return ExecAnswer::Refused(RoverRefusal::BadTask);
                }
                if self.running_len >= MAX_ROVER_ACTIVE {
                    return ExecAnswer::Refused(RoverRefusal::Capacity);
                }
                let end_step = exec
                    .dispatch()
                    .loaded()
                    .and_then(|(_, d)| d.network().end_of(step))
                    .unwrap_or(0);
                let held = (self.held && self.held_until == now)
                    .then_some((self.held_from, self.held_until));
                let kind = start_kind(rel, lb, held);
                if let Some(r) = self.running.get_mut(self.running_len) {
                    *r = (action, u16::try_from(end_step).unwrap_or(0));
                }
                self.running_len += 1;
                ExecAnswer::Report(RoverReport::Dispatch {
                    step: step16,
                    action,
                    at_ms: now,
                    lb_ms: lb.saturating_add(epoch),
                    ub_ms: ub.saturating_add(epoch),
                    kind,
                    poll_ticks: 0,
                })
            }
            Decision::Replan { step, ub } => {
                let (executed, action, end) =
                    exec.dispatch()
                        .loaded()
                        .map_or((false, NO_ACTION, false), |(_, d)| {
                            let (a, e) = d
                                .network()
                                .step(step)
                                .map_or((NO_ACTION, false), |s| (s.action, s.end));
                            (d.executed_at(step).is_some(), a, e)
                        });
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
                self.plan_dropped();
                ExecAnswer::Replan { at_ms: now, why }
            }
            Decision::Wait { until } => {
                // Wake at a ready step's lb, or just past the earliest ub of a step not yet
                // executed (an overrun is noticed when it happens).
                let earliest_ub = exec.dispatch().loaded().and_then(|(_, d)| {
                    (1..=d.network().step_count())
                        .filter(|&k| d.executed_at(k).is_none())
                        .filter_map(|k| d.window(k).map(|w| w.1))
                        .filter(|&ub| ub != UNBOUNDED)
                        .min()
                        .map(|ub| ub.saturating_add(epoch).saturating_add(1))
                });
                let until = until.map(|u| u.saturating_add(epoch));
                let wake = [until, earliest_ub]
                    .into_iter()
                    .flatten()
                    .filter(|&x| x > now)
                    .min();
                self.waited = true;
                self.wait_until = until.unwrap_or(UNBOUNDED);
                self.wait_at = now;
                ExecAnswer::Report(RoverReport::Wait {
                    wake_ms: wake,
                    poll_ticks: 0,
                })
            }
            Decision::Finished => ExecAnswer::Report(RoverReport::Finished),
        }
    }
}

/// The format of [`RoverDecider::encode`]'s record.
pub const RECORD_FORMAT: u8 = 1;
/// The largest record: the fields, every running action, every step's planned window, the CRC.
pub const RECORD_MAX_BYTES: usize =
    4 + 7 * 4 + 1 + MAX_ROVER_ACTIVE * 4 + 2 + (MAX_DISPATCH_STEPS + 1) * 8 + 4;

/// Why a decider's record was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordError {
    Version,
    BadLength,
    BadCrc,
    OutOfRange,
}

struct Writer<'b> {
    buf: &'b mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) -> Option<()> {
        let end = self.at.checked_add(bytes.len())?;
        self.buf.get_mut(self.at..end)?.copy_from_slice(bytes);
        self.at = end;
        Some(())
    }
}

struct Reader<'b> {
    bytes: &'b [u8],
    at: usize,
}

impl<'b> Reader<'b> {
    fn take(&mut self, n: usize) -> Result<&'b [u8], RecordError> {
        let end = self.at.checked_add(n).ok_or(RecordError::BadLength)?;
        let b = self.bytes.get(self.at..end).ok_or(RecordError::BadLength)?;
        self.at = end;
        Ok(b)
    }
    fn u16(&mut self) -> Result<u16, RecordError> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([
            b.first().copied().unwrap_or(0),
            b.get(1).copied().unwrap_or(0),
        ]))
    }
    fn u32(&mut self) -> Result<u32, RecordError> {
        let b = self.take(4)?;
        let mut a = [0u8; 4];
        a.copy_from_slice(b);
        Ok(u32::from_le_bytes(a))
    }
}

/// Steps of `d`'s network executed (the epoch not counted): what a readiness mask is stamped
/// with.
pub fn executed_steps(d: &temporal::Dispatcher) -> u16 {
    let n = (1..=d.network().step_count())
        .filter(|&k| d.executed_at(k).is_some())
        .count();
    u16::try_from(n).unwrap_or(u16::MAX)
}
