//! Two link endpoints in lockstep over the lossy channel: the host (initiator) and the target
//! (responder), each with queues of messages to send per virtual channel, recording what was
//! accepted for sending and what was delivered, so that tests can check exactly-once in-order
//! delivery at every step.
use std::collections::VecDeque;

use fsw_bridge::codec::FrameDecoder;
use fsw_bridge::link::channel::LossyChannel;
use fsw_bridge::link::faults::{Direction, FaultRates};
use fsw_bridge::link::{
    Endpoint, LinkConfig, LinkFrame, Received, Role, SubmitError, VirtualChannel, VC_COUNT,
};
use fsw_bridge::{HostToTarget, TargetToHost};

/// Host endpoint sized for tests (the real HostEndpoint is 130 KiB).
pub type SimHost = Endpoint<HostToTarget, TargetToHost, 16384, 128>;
/// The target's real endpoint.
pub type SimTarget = fsw_bridge::link::TargetEndpoint;

/// One direction's bookkeeping, per VC. A session ends when its side resets: the sender's
/// (what it submitted) and the receiver's (what it delivered) separately, because they do not
/// reset at the same moment (the host only on the target's Hello), and frames of the old
/// session may still be delivered to the old receiver in between.
#[derive(Default, Clone, Debug)]
pub struct Stream<M> {
    /// Waiting to be submitted (submit said Full, or not offered yet).
    pub pending: [VecDeque<M>; VC_COUNT],
    /// Accepted by `submit`, in order, one entry per sender session (the last is current).
    pub submitted: Vec<[Vec<M>; VC_COUNT]>,
    /// Delivered by the receiver, in order, one entry per receiver session.
    pub delivered: Vec<[Vec<M>; VC_COUNT]>,
    /// Expedited messages delivered (no ordering guarantee).
    pub expedited_delivered: Vec<M>,
}

impl<M: Clone + PartialEq + core::fmt::Debug> Stream<M> {
    pub fn new() -> Self {
        Self {
            pending: [VecDeque::new(), VecDeque::new()],
            submitted: vec![[Vec::new(), Vec::new()]],
            delivered: vec![[Vec::new(), Vec::new()]],
            expedited_delivered: Vec::new(),
        }
    }

    /// The current receiver session's deliveries on `vc`.
    pub fn delivered_now(&self, vc: VirtualChannel) -> &Vec<M> {
        &self.delivered.last().unwrap()[vc.index()]
    }

    /// The current sender session's submissions on `vc`.
    pub fn submitted_now(&self, vc: VirtualChannel) -> &Vec<M> {
        &self.submitted.last().unwrap()[vc.index()]
    }

    /// In every session, what was delivered is a prefix of what was submitted: exactly once,
    /// in order, and never from another session.
    pub fn check_prefix(&self, what: &str) -> Result<(), String> {
        let none = [Vec::new(), Vec::new()];
        for (k, delivered) in self.delivered.iter().enumerate() {
            let submitted = self.submitted.get(k).unwrap_or(&none);
            for vc in VirtualChannel::ALL {
                let i = vc.index();
                let (sub, del) = (&submitted[i], &delivered[i]);
                if del.len() > sub.len() || del[..] != sub[..del.len()] {
                    let first_bad = del
                        .iter()
                        .zip(sub.iter())
                        .position(|(a, b)| a != b)
                        .unwrap_or(sub.len());
                    return Err(format!(
                        "{what} {} session {k}: delivered {} messages, submitted {}, first difference at {first_bad}",
                        vc.name(),
                        del.len(),
                        sub.len()
                    ));
                }
            }
        }
        Ok(())
    }

    /// Nothing pending, both sides in the same session, everything submitted delivered.
    pub fn complete(&self) -> bool {
        self.submitted.len() == self.delivered.len()
            && VirtualChannel::ALL.iter().all(|&vc| {
                self.pending[vc.index()].is_empty()
                    && self.delivered_now(vc).len() == self.submitted_now(vc).len()
            })
    }

    fn sender_reset(&mut self) {
        self.submitted.push([Vec::new(), Vec::new()]);
    }

    fn receiver_reset(&mut self) {
        self.delivered.push([Vec::new(), Vec::new()]);
    }
}

/// The two endpoints, the channel, and the bookkeeping.
pub struct Sim {
    pub host: Box<SimHost>,
    pub target: Box<SimTarget>,
    pub channel: LossyChannel,
    host_decoder: FrameDecoder,
    target_decoder: FrameDecoder,
    pub up: Stream<HostToTarget>,
    pub down: Stream<TargetToHost>,
    /// Rounds run.
    pub rounds: u32,
    /// Expedited messages to send with the next burst of each side.
    pub host_expedited: Vec<HostToTarget>,
    pub target_expedited: Vec<TargetToHost>,
    /// Whether each side's consumer takes messages (false: it refuses, wait flag).
    pub host_consumer_ready: bool,
    pub target_consumer_ready: bool,
    /// Per round: the Mission messages delivered to each side, with the round they arrived in
    /// (for comparing two runs).
    pub mission_log: Vec<(u32, String)>,
    /// The target rebooted and the host has not seen its Hello yet: nothing may be delivered
    /// to the target meanwhile (its receivers wait for the host to reopen them).
    awaiting_hello: bool,
    /// Hellos the host acted on.
    pub hellos_seen: u32,
}

pub fn hello() -> TargetToHost {
    TargetToHost::Hello {
        protocol_version: fsw_bridge::PROTOCOL_VERSION,
        build_id: [7; 8],
        reset_cause: fsw_bridge::ResetCause::Warm,
        boot_count: 2,
        kernel_fault: None,
    }
}

pub fn is_hello(msg: &TargetToHost) -> bool {
    matches!(msg, TargetToHost::Hello { .. })
}

impl Sim {
    pub fn new(config: LinkConfig, seed: u64, rates: FaultRates) -> Self {
        Self {
            host: Box::new(SimHost::new(Role::Initiator, config).expect("valid config")),
            target: Box::new(SimTarget::new(Role::Responder, config).expect("valid config")),
            channel: LossyChannel::new(seed, rates),
            host_decoder: FrameDecoder::new(),
            target_decoder: FrameDecoder::new(),
            up: Stream::new(),
            down: Stream::new(),
            rounds: 0,
            host_expedited: Vec::new(),
            target_expedited: Vec::new(),
            host_consumer_ready: true,
            target_consumer_ready: true,
            mission_log: Vec::new(),
            awaiting_hello: false,
            hellos_seen: 0,
        }
    }

    /// Offer pending messages to an endpoint until it says Full.
    fn submit_pending<
        Out: fsw_bridge::link::LinkMessage + Clone + core::fmt::Debug + PartialEq,
        In,
        const R: usize,
        const Q: usize,
    >(
        endpoint: &mut Endpoint<Out, In, R, Q>,
        stream: &mut Stream<Out>,
    ) where
        In: fsw_bridge::link::LinkMessage,
    {
        for vc in VirtualChannel::ALL {
            let i = vc.index();
            while let Some(msg) = stream.pending[i].front() {
                match endpoint.submit(vc, msg) {
                    Ok(_) => {
                        let msg = stream.pending[i].pop_front().unwrap();
                        stream.submitted.last_mut().unwrap()[i].push(msg);
                    }
                    Err(SubmitError::Full) | Err(SubmitError::LinkLost) => break,
                    Err(SubmitError::TooLarge) => panic!("test message too large: {msg:?}"),
                }
            }
        }
    }

    /// One round: the host's burst to the target, the target's answer to the host. Returns an
    /// error if delivery broke the exactly-once in-order rule.
    pub fn round(&mut self) -> Result<(), String> {
        // Host burst.
        Self::submit_pending(&mut *self.host, &mut self.up);
        let mut frames: Vec<Vec<u8>> = Vec::new();
        for msg in core::mem::take(&mut self.host_expedited) {
            self.host
                .send_expedited(&msg, &mut |f: &[u8]| frames.push(f.to_vec()))
                .unwrap();
        }
        let burst = self
            .host
            .produce_burst(&mut |f: &[u8]| frames.push(f.to_vec()));
        self.rounds += 1;
        let round = burst.round;
        let wire = self
            .channel
            .carry::<HostToTarget>(Direction::Uplink, round, &frames, |_| false);

        // Target receives; answers at the RoundEnd.
        let mut answer: Vec<Vec<u8>> = Vec::new();
        let mut answered = false;
        for bytes in &wire {
            for &b in bytes {
                let Some(result) = self.target_decoder.push::<LinkFrame<HostToTarget>>(b) else {
                    continue;
                };
                let ready = self.target_consumer_ready;
                match self.target.on_frame(result, |_| ready) {
                    Received::Delivered { vc, msg } => {
                        if self.awaiting_hello {
                            return Err(format!(
                                "round {round}: {msg:?} delivered to the rebooted target before the host reopened the link"
                            ));
                        }
                        if vc == VirtualChannel::Mission {
                            self.mission_log.push((round, format!("up {msg:?}")));
                        }
                        self.up.delivered.last_mut().unwrap()[vc.index()].push(msg);
                    }
                    Received::Expedited(msg) => self.up.expedited_delivered.push(msg),
                    Received::RoundEnd { .. } => {
                        Self::submit_pending(&mut *self.target, &mut self.down);
                        for msg in core::mem::take(&mut self.target_expedited) {
                            self.target
                                .send_expedited(&msg, &mut |f: &[u8]| answer.push(f.to_vec()))
                                .unwrap();
                        }
                        self.target
                            .produce_burst(&mut |f: &[u8]| answer.push(f.to_vec()));
                        answered = true;
                    }
                    Received::Noted | Received::Discarded(_) => {}
                }
            }
        }
        self.up.check_prefix("uplink")?;
        if !answered {
            return Err(format!("round {round}: the target never saw the RoundEnd"));
        }
        let wire =
            self.channel
                .carry::<TargetToHost>(Direction::Downlink, round, &answer, is_hello);
        let mut round_ended = false;
        for bytes in &wire {
            for &b in bytes {
                let Some(result) = self.host_decoder.push::<LinkFrame<TargetToHost>>(b) else {
                    continue;
                };
                let ready = self.host_consumer_ready;
                match self.host.on_frame(result, |_| ready) {
                    Received::Delivered { vc, msg } => {
                        if vc == VirtualChannel::Mission {
                            self.mission_log.push((round, format!("down {msg:?}")));
                        }
                        self.down.delivered.last_mut().unwrap()[vc.index()].push(msg);
                    }
                    Received::Expedited(msg) => {
                        if is_hello(&msg) {
                            self.host.reset();
                            self.up.sender_reset();
                            self.down.receiver_reset();
                            self.awaiting_hello = false;
                            self.hellos_seen += 1;
                        }
                        self.down.expedited_delivered.push(msg)
                    }
                    Received::RoundEnd { round: r } => round_ended |= r == round,
                    Received::Noted | Received::Discarded(_) => {}
                }
            }
        }
        self.down.check_prefix("downlink")?;
        if !round_ended {
            return Err(format!(
                "round {round}: the host never saw the target's RoundEnd"
            ));
        }
        Ok(())
    }

    /// Everything queued both ways was delivered.
    pub fn complete(&self) -> bool {
        self.up.complete() && self.down.complete()
    }

    pub fn lost(&self) -> bool {
        self.host.lost().is_some() || self.target.lost().is_some()
    }

    /// Run rounds until everything is delivered, the link is lost, or `max_rounds` ran.
    /// Returns the rounds run.
    pub fn run(&mut self, max_rounds: u32) -> Result<u32, String> {
        let start = self.rounds;
        while self.rounds - start < max_rounds {
            if self.complete() || self.lost() {
                break;
            }
            self.round()?;
        }
        Ok(self.rounds - start)
    }

    /// The target reboots between rounds: its endpoint restarts and its next burst starts with
    /// Hello, on which the host restarts its own.
    pub fn target_reboot(&mut self) {
        self.target.reset();
        self.down.sender_reset();
        self.up.receiver_reset();
        self.target_expedited.insert(0, hello());
        self.awaiting_hello = true;
    }

    /// The target resets: both endpoints restart the link (the target at boot, the host on
    /// its Hello, which the channel never damages). Bookkeeping starts a new session.
    pub fn reset_both(&mut self) {
        self.target.reset();
        self.host.reset();
        self.up.sender_reset();
        self.up.receiver_reset();
        self.down.sender_reset();
        self.down.receiver_reset();
    }

    pub fn queue_up(&mut self, vc: VirtualChannel, msgs: impl IntoIterator<Item = HostToTarget>) {
        self.up.pending[vc.index()].extend(msgs);
    }

    pub fn queue_down(&mut self, vc: VirtualChannel, msgs: impl IntoIterator<Item = TargetToHost>) {
        self.down.pending[vc.index()].extend(msgs);
    }
}
