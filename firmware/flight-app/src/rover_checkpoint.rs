//! The rover mission's checkpoint (issue 13 item 3 made robust): what a reset of the planner
//! partition must not lose of a flying mission, in memory a warm reset keeps, and taking it up
//! again after a (re)start.
//!
//! What is kept: the mission's configuration (job, slack, expansion limit, planning-time
//! model), where its task is and the task's CRC-32, the state now (facts, numeric values), the
//! components' inactive states, the running actions, the opportunistic goals that arrived and
//! which are kept, the time of the last event, the dispatch bookkeeping (the epoch, the last
//! wait), the events taken, and the current plan: its dispatch network (steps, constraints,
//! makespan), each step's window as planned, and when each step was executed.
//!
//! When: before the mission takes an event ([`save`], from the plug-in), so a checkpoint is the
//! state after the events whose answers the host has all received (it sends the next one only
//! then); and at the task's acceptance. A reset in the middle of an event's answer (a replan's
//! search, say) loses that event's work; the host sends it again and the mission, being
//! deterministic, answers it as it would have. The plan's network changes only with a new
//! plan, so it is a record of its own, written again only when the plan changed; the state
//! record (35 to 71 words for the rover's day) is written at every event.
//!
//! Format: two slots for each of the two records, written alternately, so a reset while one
//! is written leaves the other whole. A slot is `[magic, version, sequence, n, payload (n
//! words), CRC-32]`, the CRC over the words before it (big-endian bytes). The state record
//! names the plan record's generation and CRC. Restoring ([`restore`]) takes the newest whole
//! state record, checks every field against the capacities and the task (whose bytes must
//! match the CRC-32 kept), finds the plan record it names, and rebuilds the dispatcher; a
//! record that is damaged (its length, its CRC), of another version, of another task, or with a
//! field out of range is refused with its reason ([`RoverResumeRefusal`]), never a panic.
//! Memory that holds no record (zeros after a cold boot under QEMU, garbage on a board) fails
//! the magic in both slots: nothing to resume, and nothing is said.
//!
//! Bounds: [`STATE_SLOT_WORDS`] and [`PLAN_SLOT_WORDS`] hold a mission at every capacity of
//! [`super`] (4,096 facts, 64 numeric variables, 16 running actions, 16 goals, a network of
//! 256 steps and 2,048 constraints); 65,696 bytes in all.
#![deny(clippy::indexing_slicing)]

use fsw_bridge::temporal::RoverResumeRefusal;
use temporal::constraints::Constraint;
use temporal::dispatch::{PlanStep, MAX_DISPATCH_CONSTRAINTS, MAX_DISPATCH_STEPS};
use temporal::replan;
use temporal::task::UNBOUNDED;
use temporal::Task;

use super::{
    RoverMission, Running, FLYING, MAX_ROVER_ACTIVE, MAX_ROVER_FACT_WORDS, MAX_ROVER_GOALS,
    MAX_ROVER_NUMERICS, READY, STOPPED,
};

/// "RVST": a state record.
const STATE_MAGIC: u32 = u32::from_be_bytes(*b"RVST");
/// "RVPL": a plan record.
const PLAN_MAGIC: u32 = u32::from_be_bytes(*b"RVPL");
/// The format's version (both records).
pub const VERSION: u32 = 1;
/// Words of a slot before the payload, and after it.
const HEADER: usize = 4;
const TRAILER: usize = 1;
/// Words of a state slot: the scalars, the facts, the values, the inactive marks, the running
/// actions, the goals and each step's execution time, at their capacities.
pub const STATE_SLOT_WORDS: usize = HEADER
    + 32
    + 2 * MAX_ROVER_FACT_WORDS
    + 2 * MAX_ROVER_NUMERICS
    + 1
    + 4 * MAX_ROVER_ACTIVE
    + 1
    + 2 * MAX_ROVER_GOALS
    + 1
    + (MAX_DISPATCH_STEPS + 1)
    + TRAILER;
/// Words of a plan slot: the network's steps and constraints and each step's window as
/// planned, at their capacities.
pub const PLAN_SLOT_WORDS: usize = HEADER
    + 4
    + 3 * MAX_DISPATCH_STEPS
    + 3 * MAX_DISPATCH_CONSTRAINTS
    + 2 * (MAX_DISPATCH_STEPS + 1)
    + TRAILER;

/// The checkpoint's memory: two slots for each record. Every bit pattern is a valid value
/// (words), so the planner partition keeps it in memory it never zeroes.
pub struct RoverCheckpoint {
    pub state: [[u32; STATE_SLOT_WORDS]; 2],
    pub plan: [[u32; PLAN_SLOT_WORDS]; 2],
}

impl RoverCheckpoint {
    /// An empty checkpoint (natively; on the target the memory is whatever it holds).
    pub fn new() -> Self {
        Self {
            state: [[0; STATE_SLOT_WORDS]; 2],
            plan: [[0; PLAN_SLOT_WORDS]; 2],
        }
    }

    /// No mission to resume: both records' slots lose their magic.
    pub fn clear(&mut self) {
        for slot in self.state.iter_mut() {
            if let Some(w) = slot.first_mut() {
                *w = 0;
            }
        }
        for slot in self.plan.iter_mut() {
            if let Some(w) = slot.first_mut() {
                *w = 0;
            }
        }
    }

    /// Whether a slot of the state record has its magic (a record, whole or not, to look at).
    pub fn holds_a_record(&self) -> bool {
        self.state
            .iter()
            .any(|s| s.first().copied() == Some(STATE_MAGIC))
    }
}

impl Default for RoverCheckpoint {
    fn default() -> Self {
        Self::new()
    }
}

/// What the mission last wrote (in the mission, zeroed at a (re)start: restoring sets it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Saved {
    /// The sequence number of the last state record, and its slot.
    pub seq: u32,
    pub slot: u8,
    /// Whether a plan record was written, its plan generation and its CRC.
    pub plan_saved: bool,
    pub plan_gen: u32,
    pub plan_crc: u32,
}

impl Saved {
    pub const NONE: Self = Self {
        seq: 0,
        slot: 1,
        plan_saved: false,
        plan_gen: 0,
        plan_crc: 0,
    };
}

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 (ISO-HDLC) of bytes.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

fn crc_words(words: &[u32]) -> u32 {
    let mut d = CRC32.digest();
    for w in words {
        d.update(&w.to_be_bytes());
    }
    d.finalize()
}

/// Writes words into a slot's payload; `ok` false once one did not fit.
struct Put<'b> {
    words: &'b mut [u32],
    at: usize,
    ok: bool,
}

impl Put<'_> {
    fn put(&mut self, v: u32) {
        match self.words.get_mut(self.at) {
            Some(w) => *w = v,
            None => self.ok = false,
        }
        self.at += 1;
    }
    fn all(&mut self, vs: &[u32]) {
        for &v in vs {
            self.put(v);
        }
    }
}

/// Seals a slot whose payload `n` words are written: header and CRC. Returns the CRC.
fn seal(slot: &mut [u32], magic: u32, seq: u32, n: usize) -> Option<u32> {
    let end = HEADER + n;
    if end + TRAILER > slot.len() {
        return None;
    }
    let head = slot.get_mut(..HEADER)?;
    head.copy_from_slice(&[magic, VERSION, seq, n as u32]);
    let crc = crc_words(slot.get(..end)?);
    *slot.get_mut(end)? = crc;
    Some(crc)
}

/// Reads a slot's payload back.
struct Get<'b> {
    words: &'b [u32],
    at: usize,
}

impl Get<'_> {
    fn get(&mut self) -> Result<u32, RoverResumeRefusal> {
        let v = self
            .words
            .get(self.at)
            .copied()
            .ok_or(RoverResumeRefusal::BadLength)?;
        self.at += 1;
        Ok(v)
    }
    /// A count or an index at most `max`.
    fn upto(&mut self, max: usize) -> Result<usize, RoverResumeRefusal> {
        let v = self.get()? as usize;
        if v > max {
            return Err(RoverResumeRefusal::OutOfRange);
        }
        Ok(v)
    }
    fn flag(&mut self) -> Result<bool, RoverResumeRefusal> {
        match self.get()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(RoverResumeRefusal::OutOfRange),
        }
    }
    fn fill(&mut self, out: &mut [u32]) -> Result<(), RoverResumeRefusal> {
        for w in out.iter_mut() {
            *w = self.get()?;
        }
        Ok(())
    }
}

/// A slot's state: not a record (no magic), a whole one (its sequence and payload), or a
/// damaged one (why).
enum Slot<'b> {
    Empty,
    Whole(u32, &'b [u32], u32),
    Damaged(RoverResumeRefusal),
}

fn look(slot: &[u32], magic: u32) -> Slot<'_> {
    let head = |i: usize| slot.get(i).copied().unwrap_or(0);
    if head(0) != magic {
        return Slot::Empty;
    }
    if head(1) != VERSION {
        return Slot::Damaged(RoverResumeRefusal::Version { found: head(1) });
    }
    let n = head(3) as usize;
    let end = HEADER.saturating_add(n);
    let (Some(words), Some(&crc)) = (slot.get(..end), slot.get(end)) else {
        return Slot::Damaged(RoverResumeRefusal::BadLength);
    };
    if crc_words(words) != crc {
        return Slot::Damaged(RoverResumeRefusal::BadCrc);
    }
    Slot::Whole(head(2), words.get(HEADER..).unwrap_or_default(), crc)
}

/// Checkpoint the mission's state (before it takes an event, or at its task's acceptance):
/// the plan record first if the plan changed since it was written, then the state record, each
/// into the slot not holding the newest whole one. Nothing is written for a mission that is
/// not flying or is planning (the last checkpoint stays).
pub fn save(m: &mut RoverMission, cp: &mut RoverCheckpoint) {
    if !m.checkpointable() {
        return;
    }
    if m.has_plan && !(m.saved.plan_saved && m.saved.plan_gen == m.plan_gen) {
        let slot_i = (m.plan_gen % 2) as usize;
        let Some(slot) = cp.plan.get_mut(slot_i) else {
            return;
        };
        let n = {
            let net = m.dispatcher.network();
            let steps = net.step_count();
            let mut p = Put {
                words: slot
                    .get_mut(HEADER..PLAN_SLOT_WORDS - TRAILER)
                    .unwrap_or_default(),
                at: 0,
                ok: true,
            };
            p.all(&[
                net.makespan,
                steps as u32,
                net.constraints().len() as u32,
                0,
            ]);
            for k in 1..=steps {
                let s = net.step(k).unwrap_or_default();
                p.all(&[
                    u32::from(s.action) | (u32::from(s.end) << 16),
                    s.window.0,
                    s.window.1,
                ]);
            }
            for c in net.constraints() {
                p.all(&[u32::from(c.before) | (u32::from(c.after) << 16), c.lb, c.ub]);
            }
            for k in 0..=steps {
                let (lb, ub) = m.planned.get(k).copied().unwrap_or((0, 0));
                p.all(&[lb, ub]);
            }
            if !p.ok {
                return;
            }
            p.at
        };
        let Some(crc) = seal(slot, PLAN_MAGIC, m.plan_gen, n) else {
            return;
        };
        m.saved.plan_saved = true;
        m.saved.plan_gen = m.plan_gen;
        m.saved.plan_crc = crc;
    }
    let slot_i = usize::from(1 - m.saved.slot.min(1));
    let Some(slot) = cp.state.get_mut(slot_i) else {
        return;
    };
    let fw = usize::from(m.fact_words).min(MAX_ROVER_FACT_WORDS);
    let nv = usize::from(m.numerics).min(MAX_ROVER_NUMERICS);
    let mut p = Put {
        words: slot
            .get_mut(HEADER..STATE_SLOT_WORDS - TRAILER)
            .unwrap_or_default(),
        at: 0,
        ok: true,
    };
    let (plan_gen, plan_crc) = if m.has_plan {
        (m.saved.plan_gen, m.saved.plan_crc)
    } else {
        (0, 0)
    };
    p.all(&[
        u32::from(m.job),
        u32::from(m.phase),
        m.horizon_slack,
        m.max_expansions,
        m.us_per_expansion,
        m.task_at as u32,
        m.task_len as u32,
        m.task_crc,
        m.events,
        m.last_ms,
        u32::from(m.has_plan),
        m.epoch,
        u32::from(m.waited),
        m.wait_until,
        m.wait_at,
        u32::from(m.held),
        m.held_until,
        m.held_from,
        plan_gen,
        plan_crc,
        fw as u32,
        nv as u32,
    ]);
    p.all(m.facts.get(..fw).unwrap_or_default());
    for v in m.values.get(..nv).unwrap_or_default() {
        p.all(&[(*v >> 32) as u32, *v as u32]);
    }
    p.all(m.inactive.get(..fw).unwrap_or_default());
    p.put(m.running_len as u32);
    for r in m.running.get(..m.running_len).unwrap_or_default() {
        p.all(&[
            u32::from(r.action),
            r.started,
            r.ends,
            u32::from(r.end_step),
        ]);
    }
    p.put(m.arrived_len as u32);
    for i in 0..m.arrived_len {
        let fact = m.arrived.get(i).copied().unwrap_or(0);
        let kept = m.kept.get(i).copied().unwrap_or(false);
        p.all(&[u32::from(fact), u32::from(kept)]);
    }
    let steps = if m.has_plan {
        m.dispatcher.network().step_count()
    } else {
        0
    };
    p.put(steps as u32);
    for k in 0..=steps {
        p.put(m.dispatcher.executed_at(k).unwrap_or(UNBOUNDED));
    }
    if !p.ok {
        return;
    }
    let n = p.at;
    let seq = m.saved.seq.wrapping_add(1);
    if seal(slot, STATE_MAGIC, seq, n).is_some() {
        m.saved.seq = seq;
        m.saved.slot = slot_i as u8;
    }
}

/// Checkpoint the mission into a memory it has not written before (tests and fuzzing: the
/// round trip `restore(save(m))`): both records anew, from sequence 1.
pub fn save_all(m: &mut RoverMission, cp: &mut RoverCheckpoint) {
    m.saved = Saved::NONE;
    save(m, cp);
}

/// Take the mission up again from `cp` into `m` (an idle mission, as the partition's start
/// leaves it), its task in `task_buffer`. `Ok(None)`: no record to resume (nothing is said);
/// `Ok(Some(events))`: resumed after that many events; `Err`: a record was refused (the
/// mission stays idle). [`restore_piece`]'s pieces all in one.
pub fn restore(
    m: &mut RoverMission,
    cp: &RoverCheckpoint,
    task_buffer: &[u8],
) -> Result<Option<u32>, RoverResumeRefusal> {
    let mut r = Restoring::new();
    loop {
        if let Some(done) = restore_piece(m, cp, task_buffer, &mut r, &mut || true) {
            return done;
        }
    }
}

/// Where a restore divided across windows stands ([`restore_piece`]). [`Restoring::new`]
/// begins one.
#[derive(Clone, Copy, Debug)]
pub struct Restoring {
    /// The whole state records to try, newest first: (sequence, slot).
    order: [Option<(u32, usize)>; 2],
    /// The next of `order` to try.
    next: usize,
    /// What is next for the record being taken up: the state (0), the plan's network (1), the
    /// dispatcher's windows and the executed steps (2).
    stage: u8,
    /// The slots were looked at.
    looked: bool,
    first_refusal: Option<RoverResumeRefusal>,
    any: bool,
    /// The record being taken up: its plan's generation and CRC, its steps, the task's
    /// actions, and where its executed steps' times begin in its payload.
    plan_gen: u32,
    plan_crc: u32,
    steps: usize,
    actions: usize,
    done_at: usize,
}

impl Default for Restoring {
    fn default() -> Self {
        Self::new()
    }
}

impl Restoring {
    pub const fn new() -> Self {
        Self {
            order: [None, None],
            next: 0,
            stage: 0,
            looked: false,
            first_refusal: None,
            any: false,
            plan_gen: 0,
            plan_crc: 0,
            steps: 0,
            actions: 0,
            done_at: 0,
        }
    }
}

/// One piece of taking the mission up again (see [`restore`]), then more while `fits()` says
/// the next one fits the window (`flight_app::piece_fits`' rule, the caller's): the state
/// record (checked, the task's bytes against its CRC and validated), then the plan record's
/// network, then the dispatcher's windows over it (an STN propagation) and the executed steps
/// marked. `None`: more to do in a later window (the mission must take no event meanwhile);
/// `Some(result)`: [`restore`]'s result, the same whatever the pieces. A record refused in a
/// later piece falls back to the other slot as a whole restore does.
pub fn restore_piece(
    m: &mut RoverMission,
    cp: &RoverCheckpoint,
    task_buffer: &[u8],
    r: &mut Restoring,
    fits: &mut dyn FnMut() -> bool,
) -> Option<Result<Option<u32>, RoverResumeRefusal>> {
    if !r.looked {
        r.looked = true;
        let looks = [
            look(cp.state.first().map_or(&[][..], |s| &s[..]), STATE_MAGIC),
            look(cp.state.get(1).map_or(&[][..], |s| &s[..]), STATE_MAGIC),
        ];
        // The newest whole record first, then the other whole one.
        for (i, l) in looks.iter().enumerate() {
            match l {
                Slot::Whole(seq, _, _) => {
                    if let Some(o) = r.order.get_mut(i) {
                        *o = Some((*seq, i));
                    }
                }
                Slot::Damaged(why) => {
                    r.first_refusal.get_or_insert(*why);
                }
                Slot::Empty => {}
            }
        }
        match r.order {
            // Sequence numbers wrap: the newer is the one just after the other.
            [Some(a), Some(b)] if b.0.wrapping_sub(a.0) < u32::MAX / 2 => {
                r.order = [Some(b), Some(a)];
            }
            [None, Some(b)] => r.order = [Some(b), None],
            _ => {}
        }
    }
    let mut first = true;
    loop {
        let Some(&Some((seq, i))) = r.order.get(r.next) else {
            return Some(match r.first_refusal {
                Some(why) => Err(why),
                None if r.any => Err(RoverResumeRefusal::OutOfRange),
                None => Ok(None),
            });
        };
        if !first && !fits() {
            return None;
        }
        first = false;
        // The slot's payload: whole when looked at, and nothing writes the records while the
        // mission is taken up.
        let payload = cp
            .state
            .get(i)
            .and_then(|s| {
                let n = s.get(3).copied()? as usize;
                s.get(HEADER..HEADER.checked_add(n)?)
            })
            .unwrap_or(&[]);
        let piece = match r.stage {
            0 => {
                r.any = true;
                m.reset_idle();
                decode(m, payload, task_buffer, r).map(|()| {
                    let has_plan = m.has_plan;
                    r.stage = 1;
                    !has_plan
                })
            }
            1 => restore_plan(m, cp, r.plan_gen, r.plan_crc, r.steps, r.actions).map(|()| {
                r.stage = 2;
                false
            }),
            _ => plan_windows(m, payload, r).map(|()| true),
        };
        match piece {
            Ok(false) => {}
            Ok(true) => {
                m.saved = Saved {
                    seq,
                    slot: i as u8,
                    plan_saved: m.has_plan,
                    plan_gen: m.plan_gen,
                    plan_crc: m.saved.plan_crc,
                };
                return Some(Ok(Some(m.events)));
            }
            Err(why) => {
                m.reset_idle();
                r.first_refusal.get_or_insert(why);
                r.next += 1;
                r.stage = 0;
            }
        }
    }
}

/// The last piece of a restore: the dispatcher's windows over the plan's network, then the
/// steps executed (their times from the state record's payload, at `r.done_at`).
fn plan_windows(
    m: &mut RoverMission,
    payload: &[u32],
    r: &Restoring,
) -> Result<(), RoverResumeRefusal> {
    use RoverResumeRefusal::OutOfRange;
    let makespan = m.dispatcher.network().makespan;
    m.dispatcher
        .restart(makespan.saturating_add(m.horizon_slack))
        .map_err(|_| OutOfRange)?;
    let done = payload
        .get(r.done_at..)
        .and_then(|d| d.get(..=r.steps))
        .ok_or(OutOfRange)?;
    for (k, &at) in done.iter().enumerate().skip(1) {
        if at != UNBOUNDED {
            m.dispatcher.executed(k, at).map_err(|_| OutOfRange)?;
        }
    }
    Ok(())
}

/// The state record's payload into `m`, checked field by field; what the later pieces need of
/// it (its plan record, where its executed steps' times are) into `r`.
fn decode(
    m: &mut RoverMission,
    payload: &[u32],
    task_buffer: &[u8],
    r: &mut Restoring,
) -> Result<(), RoverResumeRefusal> {
    use RoverResumeRefusal::{OutOfRange, PlanMissing, TaskChanged};
    let mut g = Get {
        words: payload,
        at: 0,
    };
    let job = u16::try_from(g.get()?).map_err(|_| OutOfRange)?;
    let phase = g.get()?;
    let phase = match u8::try_from(phase) {
        Ok(p @ (READY | FLYING | STOPPED)) => p,
        _ => return Err(OutOfRange),
    };
    let horizon_slack = g.get()?;
    let max_expansions = g.get()?;
    let us_per_expansion = g.get()?;
    let task_at = g.get()? as usize;
    let task_len = g.get()? as usize;
    let task_crc = g.get()?;
    if task_at.saturating_add(task_len) > super::ROVER_REPLAN_AT {
        return Err(OutOfRange);
    }
    let bytes = task_buffer
        .get(task_at..task_at + task_len)
        .ok_or(OutOfRange)?;
    if crc32(bytes) != task_crc {
        return Err(TaskChanged);
    }
    let task = Task::parse(bytes).map_err(|_| TaskChanged)?;
    m.task_layout = task.layout();
    let events = g.get()?;
    let last_ms = g.get()?;
    let has_plan = g.flag()?;
    let epoch = g.get()?;
    let waited = g.flag()?;
    let wait_until = g.get()?;
    let wait_at = g.get()?;
    let held = g.flag()?;
    let held_until = g.get()?;
    let held_from = g.get()?;
    let plan_gen = g.get()?;
    let plan_crc = g.get()?;
    let fw = g.upto(MAX_ROVER_FACT_WORDS)?;
    let nv = g.upto(MAX_ROVER_NUMERICS)?;
    if fw != replan::fact_words(&task) || nv != task.numeric_count() {
        return Err(TaskChanged);
    }
    g.fill(m.facts.get_mut(..fw).ok_or(OutOfRange)?)?;
    for v in m.values.get_mut(..nv).ok_or(OutOfRange)? {
        let hi = g.get()?;
        let lo = g.get()?;
        *v = ((u64::from(hi) << 32) | u64::from(lo)) as i64;
    }
    g.fill(m.inactive.get_mut(..fw).ok_or(OutOfRange)?)?;
    let actions = task.action_count();
    let running = g.upto(MAX_ROVER_ACTIVE)?;
    for i in 0..running {
        let action = g.get()? as usize;
        let started = g.get()?;
        let ends = g.get()?;
        let end_step = g.upto(MAX_DISPATCH_STEPS)?;
        if action >= actions {
            return Err(OutOfRange);
        }
        let r = m.running.get_mut(i).ok_or(OutOfRange)?;
        *r = Running {
            action: action as u16,
            started,
            ends,
            end_step: end_step as u16,
        };
    }
    let arrived = g.upto(MAX_ROVER_GOALS)?;
    for i in 0..arrived {
        let fact = g.get()? as usize;
        let kept = g.flag()?;
        if fact >= task.fact_count() {
            return Err(OutOfRange);
        }
        *m.arrived.get_mut(i).ok_or(OutOfRange)? = fact as u16;
        *m.kept.get_mut(i).ok_or(OutOfRange)? = kept;
    }
    let steps = g.upto(MAX_DISPATCH_STEPS)?;
    // The executed steps' times, marked in the last piece.
    let done_at = g.at;
    g.at = g.at.saturating_add(steps + 1);
    // A plan is dispatched only while flying.
    if g.at != payload.len() || (has_plan && phase != FLYING) {
        return Err(if g.at > payload.len() {
            RoverResumeRefusal::BadLength
        } else {
            OutOfRange
        });
    }
    if !has_plan && steps != 0 {
        return Err(PlanMissing);
    }
    *r = Restoring {
        plan_gen,
        plan_crc,
        steps,
        actions,
        done_at,
        ..*r
    };
    m.job = job;
    m.phase = phase;
    m.horizon_slack = horizon_slack;
    m.max_expansions = max_expansions;
    m.us_per_expansion = us_per_expansion;
    m.task_at = task_at;
    m.task_len = task_len;
    m.task_crc = task_crc;
    m.fact_words = fw as u16;
    m.numerics = nv as u16;
    m.events = events;
    m.last_ms = last_ms;
    m.has_plan = has_plan;
    m.epoch = epoch;
    m.replan_at = epoch;
    m.waited = waited;
    m.wait_until = wait_until;
    m.wait_at = wait_at;
    m.held = held;
    m.held_until = held_until;
    m.held_from = held_from;
    m.running_len = running;
    m.arrived_len = arrived;
    m.plan_gen = plan_gen;
    m.saved.plan_crc = plan_crc;
    Ok(())
}

/// The plan record of generation `gen` (CRC `crc`, `steps` steps) into the dispatcher's
/// network (its windows are the next piece's).
fn restore_plan(
    m: &mut RoverMission,
    cp: &RoverCheckpoint,
    gen: u32,
    crc: u32,
    steps: usize,
    actions: usize,
) -> Result<(), RoverResumeRefusal> {
    use RoverResumeRefusal::{OutOfRange, PlanMissing};
    let slot = cp.plan.get((gen % 2) as usize).ok_or(PlanMissing)?;
    let Slot::Whole(found_gen, payload, found_crc) = look(&slot[..], PLAN_MAGIC) else {
        return Err(PlanMissing);
    };
    if found_gen != gen || found_crc != crc {
        return Err(PlanMissing);
    }
    let mut g = Get {
        words: payload,
        at: 0,
    };
    let makespan = g.get()?;
    if g.upto(MAX_DISPATCH_STEPS)? != steps {
        return Err(OutOfRange);
    }
    let constraints = g.upto(MAX_DISPATCH_CONSTRAINTS)?;
    let _reserved = g.get()?;
    let net = m.dispatcher.network_mut();
    net.clear();
    for _ in 0..steps {
        let a = g.get()?;
        let (action, end) = (a & 0xffff, a >> 16);
        // The network's actions are the replan task's: the task's, then one completion per
        // carried action.
        if action as usize >= actions + MAX_ROVER_ACTIVE || end > 1 {
            return Err(OutOfRange);
        }
        let window = (g.get()?, g.get()?);
        net.add_step(PlanStep {
            action: action as u16,
            end: end == 1,
            window,
        })
        .map_err(|_| OutOfRange)?;
    }
    for _ in 0..constraints {
        let ba = g.get()?;
        let (lb, ub) = (g.get()?, g.get()?);
        net.add_constraint(Constraint {
            before: (ba & 0xffff) as u16,
            after: (ba >> 16) as u16,
            lb,
            ub,
        })
        .map_err(|_| OutOfRange)?;
    }
    net.makespan = makespan;
    for k in 0..=steps {
        let w = (g.get()?, g.get()?);
        *m.planned.get_mut(k).ok_or(OutOfRange)? = w;
    }
    if g.at != payload.len() {
        return Err(OutOfRange);
    }
    Ok(())
}
