//! The Europa Lander's executor (`lander::executor::Executor`, seed 000) as a plug-in of the
//! planner partition (issues 11 and 12): a setup uplinked in chunks
//! ([`HostToTarget::LanderBegin`], [`HostToTarget::LanderChunk`]) is checked (order, length,
//! CRC-32), decoded in place and validated (`lander::setup`), and the executor is built from it
//! in place ([`Executor::reset`]); then each [`HostToTarget::LanderStep`] (numbered from 0 per
//! setup) is one `Executor::step`. A step whose search does not fit one window's CPU share goes
//! on in the next granted windows: the executor is called again with the same observation (its
//! event already taken) while it answers `Planning`, a few explorations a call, and only the
//! final directive is answered, after the decisions logged since the last answer
//! ([`LanderReport`]). Native `Executor::step` with a large budget decides exactly the same
//! (the search resumes exactly; `lander-sim`'s `step_to_answer` is the same loop).
//!
//! Memory: the setup's bytes, the decoded setup and the executor are handed in by the
//! partition ([`LanderStorage`]); on the target they are statics of the planner partition's
//! region that are not zeroed at its start. Nothing here allocates, and nothing from outside
//! can make it panic: bad bytes and out-of-order steps are a [`LanderRefusal`].
use fsw_bridge::lander::{
    LanderInput, LanderObservation, LanderRefusal, LanderReport, LanderSetupError,
};
use lander::capacity::MAX_DATA_PRODUCTS;
use lander::comms::CommsError;
use lander::downlink::{DataProduct, DownlinkError, DownlinkManager};
use lander::executor::{Directive, Executor, Observation};
use lander::setup::{decode_downlink_problem, decode_into, LanderSetup, DOWNLINK_PROBLEM_TAG};
use lander::wire::{
    comms_from_wire, decision_to_wire, directive_to_wire, observation_from_wire, product_from_wire,
};

use super::*;

/// Largest setup the target takes: 64 KiB (RSM-1's full model is about 15 KB).
pub const MAX_LANDER_SETUP_BYTES: usize = 64 << 10;
/// Search explorations per executor call while a step plans: the CPU clock is read between
/// calls, and a call must fit what is left of the window's share (an exploration of the RSM-1
/// model costs a few thousand ticks).
pub const LANDER_EXPLORATIONS_PER_CALL: u32 = 4;

/// The memory the executor works in.
pub struct LanderStorage<'a> {
    /// Room for a setup's bytes ([`MAX_LANDER_SETUP_BYTES`] on the target).
    pub bytes: &'a mut [u8],
    /// The decoded setup.
    pub setup: &'a mut LanderSetup,
    pub executor: &'a mut Executor,
    /// The downlink manager a downlink problem is solved in (the measure of its cost).
    pub downlink: &'a mut DownlinkManager,
}

/// Knapsack nodes per downlink manager call while a downlink problem is solved.
pub const DOWNLINK_NODES_PER_CALL: u32 = 64;

/// A downlink problem being solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Solve {
    setup: u16,
    ticks: u64,
    windows: u16,
    most_call_ticks: u64,
    /// The last window ran no call: the next runs one anyway.
    stalled: bool,
    done: bool,
}

fn downlink_error_code(e: DownlinkError) -> u8 {
    match e {
        DownlinkError::TooManyProducts => 0,
        DownlinkError::TooManyOpportunities => 1,
        DownlinkError::TooManySols => 2,
        DownlinkError::ProductOutOfRange { .. } => 3,
        DownlinkError::OpportunityOutOfOrder { .. } => 4,
        DownlinkError::NoAllocation { .. } => 5,
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Upload {
    setup: u16,
    len: u32,
    crc32: u32,
    received: u32,
}

/// A step being answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pending {
    seq: u32,
    observation: Observation,
    /// The executor was called for it (its event taken).
    started: bool,
    ticks: u64,
    windows: u16,
    /// The costliest executor call so far, timebase ticks.
    most_call_ticks: u64,
    /// The last window ran no call (the costliest did not fit it): the next runs one anyway.
    stalled: bool,
    answer: Option<Directive>,
}

/// The lander executor plug-in.
pub struct LanderApp<'a> {
    storage: Option<LanderStorage<'a>>,
    upload: Option<Upload>,
    /// The setup the executor was built from.
    active: Option<u16>,
    next_seq: u32,
    pending: Option<Pending>,
    /// Decisions of the executor's log reported so far.
    reported: usize,
    solve: Option<Solve>,
    /// The product list being received ([`LanderInput::Products`] parts), applied whole.
    products: heapless::Vec<DataProduct, MAX_DATA_PRODUCTS>,
    /// Setups accepted and refused, steps answered and refused, since the start.
    pub accepted: u32,
    pub refused: u32,
    pub answered: u32,
}

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 (ISO-HDLC, the link's) of a setup, as LanderBegin carries it.
pub fn lander_crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

fn sat32(v: u64) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

impl Default for LanderApp<'_> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'a> LanderApp<'a> {
    pub const fn new() -> Self {
        Self {
            storage: None,
            upload: None,
            active: None,
            next_seq: 0,
            pending: None,
            reported: 0,
            solve: None,
            products: heapless::Vec::new(),
            accepted: 0,
            refused: 0,
            answered: 0,
        }
    }

    /// Whether the plug-in has its memory ([`LanderApp::give_storage`]).
    pub fn has_storage(&self) -> bool {
        self.storage.is_some()
    }

    /// The memory the executor works in (once; the plug-in keeps it).
    pub fn give_storage(&mut self, storage: LanderStorage<'a>) {
        self.storage = Some(storage);
    }

    /// The executor, once a setup was accepted.
    pub fn executor(&self) -> Option<&Executor> {
        match (self.active, self.storage.as_ref()) {
            (Some(_), Some(s)) => Some(&*s.executor),
            _ => None,
        }
    }

    fn refuse(
        &mut self,
        setup: u16,
        seq: Option<u32>,
        reason: LanderRefusal,
        downlink: &mut dyn Downlink,
    ) {
        self.refused = self.refused.saturating_add(1);
        downlink.send(TargetToHost::Lander(LanderReport::Refused {
            setup,
            seq,
            reason,
        }));
    }

    fn begin(&mut self, setup: u16, len: u32, crc32: u32, downlink: &mut dyn Downlink) {
        // A new setup ends the executor in force (and a step being answered).
        self.active = None;
        self.pending = None;
        self.upload = None;
        self.solve = None;
        let capacity = self
            .storage
            .as_ref()
            .map_or(0, |s| sat32(s.bytes.len() as u64));
        if len == 0 || len > capacity {
            self.refuse(setup, None, LanderRefusal::TooLarge { capacity }, downlink);
            return;
        }
        self.upload = Some(Upload {
            setup,
            len,
            crc32,
            received: 0,
        });
    }

    fn chunk(
        &mut self,
        setup: u16,
        offset: u32,
        bytes: &[u8],
        clock: &mut dyn CpuClock,
        downlink: &mut dyn Downlink,
    ) {
        let (Some(up), Some(storage)) = (self.upload, self.storage.as_mut()) else {
            let reason = LanderRefusal::OutOfSequence { expected_offset: 0 };
            self.refuse(setup, None, reason, downlink);
            return;
        };
        let end = offset.checked_add(sat32(bytes.len() as u64));
        let fits = end.is_some_and(|e| e <= up.len);
        if up.setup != setup || offset != up.received || !fits {
            let reason = LanderRefusal::OutOfSequence {
                expected_offset: up.received,
            };
            self.refuse(setup, None, reason, downlink);
            return;
        }
        let (start, end) = (offset as usize, end.unwrap_or(offset) as usize);
        let Some(dest) = storage.bytes.get_mut(start..end) else {
            let capacity = sat32(storage.bytes.len() as u64);
            self.upload = None;
            self.refuse(setup, None, LanderRefusal::TooLarge { capacity }, downlink);
            return;
        };
        dest.copy_from_slice(bytes);
        let received = end as u32;
        self.upload = Some(Upload { received, ..up });
        if received < up.len {
            return;
        }
        self.upload = None;
        let t0 = clock.ticks();
        let all = storage.bytes.get(..up.len as usize).unwrap_or_default();
        let computed = lander_crc32(all);
        if computed != up.crc32 {
            self.refuse(setup, None, LanderRefusal::BadCrc { computed }, downlink);
            return;
        }
        if all.first() == Some(&DOWNLINK_PROBLEM_TAG) {
            let loaded = decode_downlink_problem(all).and_then(|p| {
                storage
                    .downlink
                    .load(&p.products, &p.opportunities, &p.allocations)
                    .map_err(|e| LanderSetupError::BadDownlinkProblem {
                        error: downlink_error_code(e),
                    })
            });
            match loaded {
                Err(e) => self.refuse(setup, None, LanderRefusal::BadSetup(e), downlink),
                Ok(()) => {
                    self.solve = Some(Solve {
                        setup,
                        ticks: clock.ticks().wrapping_sub(t0),
                        windows: 0,
                        most_call_ticks: 0,
                        stalled: false,
                        done: false,
                    })
                }
            }
            return;
        }
        if let Err(e) = decode_into(all, storage.setup) {
            self.refuse(setup, None, LanderRefusal::BadSetup(e), downlink);
            return;
        }
        let s = &*storage.setup;
        if s.network.chains.len() >= usize::from(u16::MAX) {
            let reason = LanderRefusal::BadSetup(LanderSetupError::TooMany);
            self.refuse(setup, None, reason, downlink);
            return;
        }
        // With what the executor it replaces had learned (natively: `set_learned` after
        // `new`; the same executor, its first plan set up once here).
        storage.executor.reset(
            s.config,
            &s.primitives,
            &s.network,
            &s.timeline,
            &s.context,
            &s.learned,
        );
        self.active = Some(setup);
        self.next_seq = 0;
        self.reported = 0;
        self.accepted = self.accepted.saturating_add(1);
        let build_ticks = sat32(clock.ticks().wrapping_sub(t0));
        downlink.send(TargetToHost::Lander(LanderReport::Accepted {
            setup,
            primitives: s.primitives.len() as u16,
            chains: s.network.chains.len() as u16,
            bytes: up.len,
            build_ticks,
        }));
    }

    fn step(
        &mut self,
        setup: u16,
        seq: u32,
        observation: &LanderObservation,
        downlink: &mut dyn Downlink,
    ) {
        if self.active != Some(setup) || self.storage.is_none() {
            self.refuse(setup, Some(seq), LanderRefusal::NoSetup, downlink);
            return;
        }
        if self.pending.is_some() {
            self.refuse(setup, Some(seq), LanderRefusal::Busy, downlink);
            return;
        }
        if seq != self.next_seq {
            let reason = LanderRefusal::OutOfOrder {
                expected: self.next_seq,
            };
            self.refuse(setup, Some(seq), reason, downlink);
            return;
        }
        self.next_seq = self.next_seq.wrapping_add(1);
        self.pending = Some(Pending {
            seq,
            observation: observation_from_wire(observation),
            started: false,
            ticks: 0,
            windows: 0,
            most_call_ticks: 0,
            stalled: false,
            answer: None,
        });
    }

    /// A link or data input for the executor of `setup`: given to it at once (the next step
    /// sees it); a product list when its last part arrives. Refused with the reason
    /// ([`LanderRefusal::BadInput`]) when the executor refuses it, a part is out of order or a
    /// tier unknown; the executor keeps what it had.
    fn input(&mut self, setup: u16, input: &LanderInput, downlink: &mut dyn Downlink) {
        const OUT_OF_ORDER: u8 = 3;
        const UNKNOWN_TIER: u8 = 4;
        let code = |e: CommsError| match e {
            CommsError::Invalid => 0,
            CommsError::TooManyProducts => 1,
            CommsError::ProductOutOfRange => 2,
        };
        if self.active != Some(setup) || self.storage.is_none() {
            self.refuse(setup, None, LanderRefusal::NoSetup, downlink);
            return;
        }
        if self.pending.is_some() {
            self.refuse(setup, None, LanderRefusal::Busy, downlink);
            return;
        }
        let error = match input {
            LanderInput::Comms(c) => {
                let comms = c.as_ref().map(comms_from_wire);
                match self.storage.as_mut() {
                    Some(s) => s.executor.set_comms(comms).err().map(code),
                    None => None,
                }
            }
            LanderInput::Products {
                first,
                total,
                products,
            } => {
                if *first == 0 {
                    self.products.clear();
                }
                let mut error = None;
                if usize::from(*first) != self.products.len() {
                    error = Some(OUT_OF_ORDER);
                } else if usize::from(*total) > MAX_DATA_PRODUCTS {
                    error = Some(code(CommsError::TooManyProducts));
                } else {
                    for p in products.iter() {
                        match product_from_wire(p) {
                            Ok(p) if self.products.push(p).is_ok() => {}
                            Ok(_) => error = Some(code(CommsError::TooManyProducts)),
                            Err(_) => error = Some(UNKNOWN_TIER),
                        }
                        if error.is_some() {
                            break;
                        }
                    }
                }
                if error.is_none() && self.products.len() > usize::from(*total) {
                    error = Some(OUT_OF_ORDER);
                }
                if error.is_none() && self.products.len() == usize::from(*total) {
                    if let Some(s) = self.storage.as_mut() {
                        error = s.executor.set_onboard_data(&self.products).err().map(code);
                    }
                }
                if error.is_some() {
                    self.products.clear();
                }
                error
            }
        };
        if let Some(error) = error {
            self.refuse(setup, None, LanderRefusal::BadInput { error }, downlink);
        }
    }

    /// Takes a host message routed to the planner partition: true if it was the plug-in's.
    /// `clock` counts the setup's decoding and the executor's building.
    pub fn handle_with_clock(
        &mut self,
        msg: &HostToTarget,
        clock: &mut dyn CpuClock,
        downlink: &mut dyn Downlink,
    ) -> bool {
        match msg {
            HostToTarget::LanderBegin { setup, len, crc32 } => {
                self.begin(*setup, *len, *crc32, downlink)
            }
            HostToTarget::LanderChunk {
                setup,
                offset,
                bytes,
            } => self.chunk(*setup, *offset, bytes, clock, downlink),
            HostToTarget::LanderStep {
                setup,
                seq,
                observation,
            } => self.step(*setup, *seq, observation, downlink),
            HostToTarget::LanderInput { setup, input } => self.input(*setup, input, downlink),
            _ => return false,
        }
        true
    }

    /// Runs the pending step within `until` on `clock` (None: to its answer). The first call
    /// of a window runs when it fits before `hard_until` (going by the costliest call so far),
    /// or whatever it costs when the last window ran none (progress: a call that fits no window
    /// overruns one, and the kernel's health monitor reports it).
    pub fn run(&mut self, clock: &mut dyn CpuClock, until: Option<u64>, hard_until: Option<u64>) {
        self.run_solve(clock, until, hard_until);
        let (Some(p), Some(storage)) = (self.pending.as_mut(), self.storage.as_mut()) else {
            return;
        };
        if p.answer.is_some() {
            return;
        }
        let t0 = clock.ticks();
        let mut now = t0;
        let mut calls = 0u32;
        loop {
            if let Some(u) = until {
                if !piece_fits(now, p.most_call_ticks, calls == 0, p.stalled, u, hard_until) {
                    break;
                }
            }
            let directive = storage
                .executor
                .step(&p.observation, LANDER_EXPLORATIONS_PER_CALL);
            p.observation.event = None;
            p.started = true;
            calls += 1;
            let after = clock.ticks();
            p.most_call_ticks = p.most_call_ticks.max(after.wrapping_sub(now));
            now = after;
            if !matches!(directive, Directive::Planning { .. }) {
                p.answer = Some(directive);
                break;
            }
        }
        p.stalled = calls == 0;
        p.ticks = p.ticks.wrapping_add(now.wrapping_sub(t0));
        p.windows = p.windows.saturating_add(1);
    }

    /// The downlink problem's knapsack within `until`, as a step's search.
    fn run_solve(&mut self, clock: &mut dyn CpuClock, until: Option<u64>, hard_until: Option<u64>) {
        let (Some(sv), Some(storage)) = (self.solve.as_mut(), self.storage.as_mut()) else {
            return;
        };
        if sv.done {
            return;
        }
        let t0 = clock.ticks();
        let mut now = t0;
        let mut calls = 0u32;
        loop {
            if let Some(u) = until {
                if !piece_fits(
                    now,
                    sv.most_call_ticks,
                    calls == 0,
                    sv.stalled,
                    u,
                    hard_until,
                ) {
                    break;
                }
            }
            let step = storage.downlink.step(DOWNLINK_NODES_PER_CALL);
            calls += 1;
            let after = clock.ticks();
            sv.most_call_ticks = sv.most_call_ticks.max(after.wrapping_sub(now));
            now = after;
            if step.done {
                sv.done = true;
                break;
            }
        }
        sv.stalled = calls == 0;
        sv.ticks = sv.ticks.wrapping_add(now.wrapping_sub(t0));
        sv.windows = sv.windows.saturating_add(1);
    }

    /// Hands out the answered step's decisions and answer, at most `room` messages.
    pub fn report_to(&mut self, mut room: usize, downlink: &mut dyn Downlink) {
        if let (Some(sv), Some(storage), true) = (self.solve, self.storage.as_ref(), room > 0) {
            if sv.done {
                let k = storage.downlink.knapsack();
                downlink.send(TargetToHost::Lander(LanderReport::DownlinkSolved {
                    setup: sv.setup,
                    value: storage.downlink.downlinked_value(),
                    proven: k.proven_optimal(),
                    nodes: sat32(k.nodes().saturating_add(k.bound_nodes())),
                    ticks: sat32(sv.ticks),
                    windows: sv.windows,
                }));
                self.solve = None;
                room -= 1;
            }
        }
        let (Some(p), Some(setup), Some(storage)) =
            (self.pending, self.active, self.storage.as_ref())
        else {
            return;
        };
        let Some(answer) = p.answer else {
            return;
        };
        let log = storage.executor.log();
        while room > 0 {
            let Some(d) = log.get(self.reported) else {
                break;
            };
            downlink.send(TargetToHost::Lander(LanderReport::Decision {
                setup,
                index: self.reported as u16,
                decision: decision_to_wire(d),
            }));
            self.reported += 1;
            room -= 1;
        }
        if room == 0 || self.reported < log.len() {
            return;
        }
        downlink.send(TargetToHost::Lander(LanderReport::Answer {
            setup,
            seq: p.seq,
            directive: directive_to_wire(&answer),
            log_len: log.len() as u16,
            ticks: sat32(p.ticks),
            windows: p.windows,
        }));
        self.answered = self.answered.saturating_add(1);
        self.pending = None;
    }
}

impl PlannerPlugin for LanderApp<'_> {
    fn name(&self) -> &'static str {
        "lander"
    }

    fn handle(&mut self, msg: &HostToTarget, downlink: &mut dyn Downlink) -> bool {
        self.handle_with_clock(msg, &mut NoClock, downlink)
    }

    fn planning_pending(&self) -> bool {
        self.pending.is_some_and(|p| p.answer.is_none()) || self.solve.is_some_and(|s| !s.done)
    }

    fn busy(&self) -> bool {
        self.pending.is_some_and(|p| p.answer.is_some()) || self.solve.is_some_and(|s| s.done)
    }

    fn window(&mut self, w: &mut PluginWindow<'_, '_>) {
        self.run(w.clock, w.until, w.hard_until);
    }

    fn report(&mut self, room: usize, downlink: &mut dyn Downlink) {
        self.report_to(room, downlink);
    }
}
