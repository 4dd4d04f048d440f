//! The executive partition's side of the rover's dispatch decisions, run natively beside the
//! mission (issue 13 item 3, step 1's decisions, not yet its routing): each network the mission
//! flies goes from a planner partition to an executive partition in chunks
//! (`autonomy::partitioned::DispatchSender`, the checkpointed channel), and at every `Poll` the
//! executive's [`RoverDecider`] decides, with its dispatcher's poll divided in calls of
//! `ROVER_SLICE_UNITS` units and the readiness mask the mission made after the last happening
//! it applied; each `Ended` reaches both. Its answer is set against the mission's own, poll for
//! poll: any difference is recorded ([`ExecShadow::differences`]). The mission still answers
//! the host: the transcript is the mission's.
use autonomy::partitioned::{DispatchNote, DispatchSender, ExecutivePartition, PlannerPartition};
use flight_app::rover_exec::{ExecAnswer, RoverDecider, RoverPlanNote};
use flight_app::rover_mission::MAX_ROVER_ACTIVE;
use flight_app::TemporalApp;
use fsw_bridge::temporal::{RoverEvent, RoverReport};
use temporal::dispatch::PlanNetwork;

/// What the shadow executive did in a run.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ShadowStats {
    /// Polls both decided, and how many of them the decider answered as the mission.
    pub polls: usize,
    pub agreed: usize,
    /// Starts, waits, replans and finishes among the agreed.
    pub starts: usize,
    pub waits: usize,
    pub replans: usize,
    /// Networks sent to the executive, their chunks, and networks too large to send
    /// (`DispatchSender::check`: the mission dispatches those itself).
    pub networks: usize,
    pub chunks: usize,
    pub too_large: usize,
    /// Steps the executive reported executed to the planner (`Executed` notes).
    pub executed_notes: usize,
    /// The costliest poll in work units, and in calls of `ROVER_SLICE_UNITS`.
    pub most_units: u32,
    pub most_calls: u32,
    /// Polls at which the mask said some step not ready (the mask mattered).
    pub polls_with_unready: usize,
}

/// The executive partition's side, beside a native mission: see the module's documentation.
pub struct ExecShadow {
    executive: Box<ExecutivePartition>,
    planner: Box<PlannerPartition>,
    decider: Box<RoverDecider>,
    plan: u32,
    /// The executive's answer to the poll in flight.
    pending: Option<ExecAnswer>,
    pub stats: ShadowStats,
    /// The executive decides (its answers are the host's; the mission applies its starts and
    /// replans on its request), else it only runs beside the mission and is compared.
    pub decides: bool,
    /// Restore the executive partition (its checkpoint: the channel, the dispatch part) and
    /// its decider (its record) into new ones after every this many of its polls, as a reset
    /// of the executive partition between two events does (None: never).
    pub restore_every: Option<usize>,
    /// Tests: networks over this many chunks are taken as over the executive's
    /// (`MAX_CHECKPOINTED_DISPATCH_CHUNKS`, 112, which no shipped scenario's network reaches),
    /// so the mission's own dispatch of such a network runs (None: the executive's limit).
    pub max_chunks: Option<usize>,
    /// Restores done, and the largest decider record written.
    pub restores: usize,
    polls_decided: usize,
    pub most_record_bytes: usize,
    /// Polls whose answers differ: (mission time, the executive's, the mission's).
    pub differences: Vec<String>,
}

impl Default for ExecShadow {
    fn default() -> Self {
        Self::new()
    }
}

impl ExecShadow {
    pub fn new() -> Self {
        Self {
            executive: Box::new(ExecutivePartition::new()),
            planner: Box::new(PlannerPartition::new()),
            decider: Box::new(RoverDecider::new()),
            plan: 0,
            pending: None,
            stats: ShadowStats::default(),
            decides: false,
            restore_every: None,
            max_chunks: None,
            restores: 0,
            polls_decided: 0,
            most_record_bytes: 0,
            differences: Vec::new(),
        }
    }

    /// One window each way, as a frame hands the ports over; the notes the planner got.
    fn exchange(&mut self) {
        let (executive, planner) = (&mut self.executive, &mut self.planner);
        planner.checkpointed();
        planner.transmit(&mut |w| {
            executive.receive(w);
            true
        });
        executive.checkpointed();
        executive.transmit(&mut |w| {
            planner.receive(w);
            true
        });
        for n in self.planner.take_dispatch_notes() {
            match n {
                DispatchNote::Executed { .. } => self.stats.executed_notes += 1,
                DispatchNote::Loaded { .. } => {}
                other => self.differences.push(format!("a note: {other:?}")),
            }
        }
    }

    /// Before the mission takes `event`: the executive's side of it.
    pub fn before(&mut self, app: &TemporalApp<'_>, event: &RoverEvent) {
        self.pending = None;
        match *event {
            RoverEvent::Poll { now_ms } => self.pending = self.decide(app, now_ms),
            RoverEvent::Ended { action, at_ms } => {
                // Without a plan of its own (the mission dispatches one too large to send, or
                // replans) an end of an action the mission started is the mission's alone.
                let held = self.decider.has_plan();
                if let Err(r) = self
                    .decider
                    .ended(&mut self.executive, action, at_ms)
                    .or_else(|r| if held { Err(r) } else { Ok(()) })
                {
                    self.differences
                        .push(format!("at {at_ms}: the end of {action} refused: {r:?}"));
                }
            }
            _ => {}
        }
        self.exchange();
    }

    /// The executive's answer to a poll at `now_ms`, with the mission's readiness mask now
    /// (None: the executive holds no plan, the mission answers).
    pub fn decide(&mut self, app: &TemporalApp<'_>, now_ms: u32) -> Option<ExecAnswer> {
        if !self.decider.has_plan() {
            return None;
        }
        let got = app
            .rover_view(|m, task| Some((m.ready_mask(task)?, m.executed_steps()?)))
            .flatten();
        let Some((mask, stamp)) = got else {
            self.differences
                .push(format!("at {now_ms}: no readiness mask from the mission"));
            return None;
        };
        self.decider.set_ready(&self.executive, &mask, stamp);
        let unready = self
            .executive
            .dispatch()
            .loaded()
            .map(|(_, d)| {
                let net = d.network();
                (1..=net.step_count()).any(|k| {
                    net.step(k).is_some_and(|s| {
                        !s.end && d.executed_at(k).is_none() && !self.decider.is_ready(s.action)
                    })
                })
            })
            .unwrap_or(false);
        if unready {
            self.stats.polls_with_unready += 1;
        }
        let answer = self.decider.poll(&mut self.executive, now_ms);
        self.stats.most_units = self.stats.most_units.max(self.decider.last_units);
        self.stats.most_calls = self.stats.most_calls.max(self.decider.last_calls);
        if self.decides {
            self.stats.polls += 1;
            self.stats.agreed += 1;
            match answer {
                ExecAnswer::Report(RoverReport::Dispatch { .. }) => self.stats.starts += 1,
                ExecAnswer::Report(RoverReport::Wait { .. }) => self.stats.waits += 1,
                ExecAnswer::Replan { .. } => self.stats.replans += 1,
                _ => {}
            }
        }
        self.exchange();
        self.polls_decided += 1;
        if self
            .restore_every
            .is_some_and(|n| n > 0 && self.polls_decided.is_multiple_of(n))
        {
            self.restore();
        }
        Some(answer)
    }

    /// The executive partition and its decider taken up from their checkpoints in new ones.
    fn restore(&mut self) {
        let mut buf = vec![0u8; 512 * 1024];
        let Some(n) = self.executive.encode_state(&mut buf) else {
            self.differences
                .push("the executive's checkpoint does not encode".into());
            return;
        };
        let mut executive = Box::new(ExecutivePartition::new());
        if executive.decode_state(&buf[..n]).is_none() {
            self.differences
                .push("the executive's checkpoint does not restore".into());
            return;
        }
        let steps = self
            .executive
            .dispatch()
            .loaded()
            .map_or(0, |(_, d)| d.network().step_count());
        let mut record = vec![0u8; flight_app::rover_exec::RECORD_MAX_BYTES];
        let Some(len) = self.decider.encode(steps, &mut record) else {
            self.differences
                .push("the decider's record does not encode".into());
            return;
        };
        self.most_record_bytes = self.most_record_bytes.max(len);
        let mut decider = Box::new(RoverDecider::new());
        if let Err(e) = decider.decode(&record[..len]) {
            self.differences
                .push(format!("the decider's record refused: {e:?}"));
            return;
        }
        self.executive = executive;
        self.decider = decider;
        self.restores += 1;
    }

    /// Before the mission takes `event`, when the executive decides: an `Ended` to the
    /// executive too (the mission applies it, the executive marks its end step).
    pub fn ended(&mut self, event: &RoverEvent) {
        if let RoverEvent::Ended { action, at_ms } = *event {
            // Without a plan of its own (the mission dispatches one too large to send, or
            // replans) an end of an action the mission started is the mission's alone.
            let held = self.decider.has_plan();
            if let Err(r) = self
                .decider
                .ended(&mut self.executive, action, at_ms)
                .or_else(|r| if held { Err(r) } else { Ok(()) })
            {
                self.differences
                    .push(format!("at {at_ms}: the end of {action} refused: {r:?}"));
            }
            self.exchange();
        }
    }

    /// After the mission's answer to `event`: the answers compared, a new plan sent.
    pub fn after(&mut self, app: &TemporalApp<'_>, event: &RoverEvent, answer: &[RoverReport]) {
        if let (RoverEvent::Poll { now_ms }, Some(ours)) = (event, self.pending.take()) {
            self.stats.polls += 1;
            let theirs = answer.iter().find_map(|r| match *r {
                RoverReport::Dispatch { .. } | RoverReport::Wait { .. } | RoverReport::Finished => {
                    Some(ExecAnswer::Report(super::onboard::decision_of(r)))
                }
                RoverReport::Replan { at_ms, why } => Some(ExecAnswer::Replan { at_ms, why }),
                _ => None,
            });
            let ours = match ours {
                ExecAnswer::Report(r) => ExecAnswer::Report(super::onboard::decision_of(&r)),
                other => other,
            };
            if theirs == Some(ours) {
                self.stats.agreed += 1;
                match ours {
                    ExecAnswer::Report(RoverReport::Dispatch { .. }) => self.stats.starts += 1,
                    ExecAnswer::Report(RoverReport::Wait { .. }) => self.stats.waits += 1,
                    ExecAnswer::Replan { .. } => self.stats.replans += 1,
                    _ => {}
                }
            } else {
                self.differences.push(format!(
                    "at {now_ms}: the executive {ours:?}, the mission {theirs:?}"
                ));
            }
        }
        if answer
            .iter()
            .any(|r| matches!(r, RoverReport::Replan { .. } | RoverReport::NoPlan))
        {
            self.decider.plan_dropped();
        }
        if answer
            .iter()
            .any(|r| matches!(r, RoverReport::NewPlan { .. }))
        {
            self.send_plan(app);
        }
    }

    /// The mission's new plan to the executive: its network in chunks, then its note.
    fn send_plan(&mut self, app: &TemporalApp<'_>) {
        let got = app.rover_view(|m, task| {
            let (_, epoch, d) = m.flying_plan()?;
            let mut running = [(0u16, 0u16); MAX_ROVER_ACTIVE];
            let mut n = 0usize;
            for (slot, r) in running.iter_mut().zip(m.running_ends()) {
                *slot = r;
                n += 1;
            }
            Some((
                epoch,
                d.network().clone(),
                d.horizon(),
                running,
                n,
                m.base_actions(task)?,
            ))
        });
        let Some(Some((epoch, net, horizon, running, n, base_actions))) = got else {
            self.differences
                .push("a new plan the mission does not show".to_string());
            return;
        };
        if !self.send_network(&net, horizon) {
            return;
        }
        let note = RoverPlanNote {
            plan: self.plan,
            epoch,
            base_actions,
            running,
            running_len: n as u8,
        };
        if let Err(r) = self.decider.plan_loaded(&mut self.executive, &note) {
            self.differences
                .push(format!("plan {} not loaded: {r:?}", self.plan));
        }
        self.exchange();
    }

    /// Sends `net`; false if it is not sent (over the executive's chunks: the mission
    /// dispatches it itself, its own poll answering the host).
    fn send_network(&mut self, net: &PlanNetwork, horizon: u32) -> bool {
        let lowered = self
            .max_chunks
            .is_some_and(|m| temporal::dispatch_wire::chunks(net) > m);
        if DispatchSender::check(net).is_err() || lowered {
            self.stats.too_large += 1;
            self.decider.plan_dropped();
            return false;
        }
        self.plan = self.plan.wrapping_add(1);
        let mut sender = DispatchSender::new(self.plan, horizon);
        while !sender.done(net) {
            self.stats.chunks += sender.pump(net, &mut self.planner);
            self.exchange();
        }
        self.exchange();
        self.stats.networks += 1;
        true
    }
}
