//! One end of the reliable link, the same type on the target and on the host: a FOP-1 per
//! outgoing virtual channel, a FARM-1 per incoming one, the round bookkeeping that replaces
//! COP-1's timers, and the counters. See the [module docs](crate::link) for the protocol.
use core::marker::PhantomData;

use crate::codec::{encode, DecodeError, EncodeError, MAX_FRAME_LEN};
use crate::link::class::LinkMessage;
use crate::link::farm::{AdVerdict, Farm};
use crate::link::fop::{Fop, SubmitError};
use crate::link::frame::{Directive, LinkFrame, LinkReport, VirtualChannel, VC_COUNT};
use crate::link::stats::{bump, LinkStats};
use crate::link::{ConfigError, FrameSink, LinkConfig, LinkLost, LostReason};

/// Which side starts each round. The host is the initiator: it numbers the rounds (1, 2, ...)
/// and sends first; the target is the responder and answers each burst with its own, carrying
/// the same round number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Initiator,
    Responder,
}

/// What one received frame amounted to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Received<M> {
    /// The next message of `vc`, in order and exactly once: hand it to the consumer.
    Delivered { vc: VirtualChannel, msg: M },
    /// A Type-BD message (no sequence control: may be a duplicate, may come after a loss).
    Expedited(M),
    /// The peer's burst for `round` is complete and has been taken into account: this side may
    /// now produce its own burst.
    RoundEnd { round: u32 },
    /// A Report or directive, kept until its round's RoundEnd.
    Noted,
    /// Nothing to deliver, and why.
    Discarded(Discard),
}

/// Why a received frame delivered nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Discard {
    /// The codec rejected the frame (corrupted on the way).
    Rejected(DecodeError),
    /// Negative window: already accepted.
    Duplicate { vc: VirtualChannel, ns: u8 },
    /// Positive window: a frame before it is missing (retransmission requested).
    OutOfSequence { vc: VirtualChannel, ns: u8 },
    /// In sequence, but the consumer had no room (wait flag set).
    RefusedBusy { vc: VirtualChannel, ns: u8 },
    /// Outside both windows: the receiver entered lockout.
    EnteredLockout { vc: VirtualChannel, ns: u8 },
    /// The receiver is in lockout (or not yet opened by the peer).
    InLockout { vc: VirtualChannel, ns: u8 },
    /// A Report or directive from another round than the one being received.
    StaleControl,
    /// A RoundEnd for a round this initiator is not waiting for.
    StaleRoundEnd { round: u32 },
}

/// What a burst contained.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BurstSummary {
    /// The round number the burst carries.
    pub round: u32,
    /// Frames written, RoundEnd included.
    pub frames: u32,
    /// Bytes written.
    pub bytes: u32,
}

/// Reports and directives of the burst being received, applied at its RoundEnd if their round
/// is that RoundEnd's. Only the newest round's are kept.
#[derive(Clone, Copy, Debug, Default)]
struct ControlInbox {
    round: Option<u32>,
    /// Frames merged into this inbox (for the stale counter if it is discarded).
    frames: u32,
    report: Option<LinkReport>,
    unlock: [bool; VC_COUNT],
    set_vr: [Option<u8>; VC_COUNT],
}

impl ControlInbox {
    const EMPTY: Self = Self {
        round: None,
        frames: 0,
        report: None,
        unlock: [false; VC_COUNT],
        set_vr: [None; VC_COUNT],
    };

    /// Make room for a control frame of `round`: returns false if the frame is older than what
    /// the inbox holds (stale), counting whatever gets thrown away in `stale`.
    fn admit(&mut self, round: u32, stale: &mut u32) -> bool {
        match self.round {
            Some(held) if round < held => {
                bump(stale);
                return false;
            }
            Some(held) if round > held => {
                *stale = stale.saturating_add(self.frames);
                *self = Self::EMPTY;
            }
            _ => {}
        }
        self.round = Some(round);
        self.frames = self.frames.saturating_add(1);
        true
    }
}

/// The peer's send state from the Report of the round that ended last.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PeerSendState {
    /// A Report arrived in the last round (otherwise the fields below are from an older one).
    pub current: bool,
    pub sent_vs: [u8; VC_COUNT],
    pub backlog: [bool; VC_COUNT],
}

/// One end of the reliable link: sends `Out` messages, receives `In` messages. Each outgoing
/// virtual channel holds up to `QUEUE_LEN` encoded frames (window and backlog) in a ring of
/// `RING_BYTES` bytes; see [`crate::link::TargetEndpoint`] for the target's sizes.
#[derive(Clone, Debug)]
pub struct Endpoint<Out, In, const RING_BYTES: usize, const QUEUE_LEN: usize> {
    role: Role,
    config: LinkConfig,
    fops: [Fop<RING_BYTES, QUEUE_LEN>; VC_COUNT],
    farms: [Farm; VC_COUNT],
    /// The initiator: the round of its last burst. The responder: the round of the last
    /// RoundEnd it received (the one its next burst answers).
    round: u32,
    inbox: ControlInbox,
    peer: PeerSendState,
    lost: Option<LinkLost>,
    stats: LinkStats,
    _messages: PhantomData<fn(&Out) -> In>,
}

impl<Out, In, const RING_BYTES: usize, const QUEUE_LEN: usize>
    Endpoint<Out, In, RING_BYTES, QUEUE_LEN>
where
    Out: LinkMessage,
    In: LinkMessage,
{
    /// A fresh endpoint: nothing queued, every channel about to be opened.
    pub const fn new(role: Role, config: LinkConfig) -> Result<Self, ConfigError> {
        if let Err(e) = config.validate() {
            return Err(e);
        }
        Ok(Self {
            role,
            config,
            fops: [
                Fop::new(VirtualChannel::Mission),
                Fop::new(VirtualChannel::Instrument),
            ],
            farms: [Farm::new(), Farm::new()],
            round: 0,
            inbox: ControlInbox::EMPTY,
            peer: PeerSendState {
                current: false,
                sent_vs: [0; VC_COUNT],
                backlog: [false; VC_COUNT],
            },
            lost: None,
            stats: LinkStats::ZERO,
            _messages: PhantomData,
        })
    }

    pub fn role(&self) -> Role {
        self.role
    }

    pub fn config(&self) -> &LinkConfig {
        &self.config
    }

    /// See the `round` field: the initiator's last burst, the responder's last RoundEnd.
    pub fn round(&self) -> u32 {
        self.round
    }

    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    /// Why and where the link was lost, if it was. Sticky until [`Self::reset`].
    pub fn lost(&self) -> Option<&LinkLost> {
        self.lost.as_ref()
    }

    /// The sending state of `vc`.
    pub fn fop(&self, vc: VirtualChannel) -> &Fop<RING_BYTES, QUEUE_LEN> {
        &self.fops[vc.index()]
    }

    /// The receiving state of `vc`.
    pub fn farm(&self, vc: VirtualChannel) -> &Farm {
        &self.farms[vc.index()]
    }

    /// What the peer's last Report said about its sending.
    pub fn peer(&self) -> &PeerSendState {
        &self.peer
    }

    /// Queue `msg` on `vc` (Type-AD). It goes out in the next burst if the window has room,
    /// later otherwise. Returns its N(S). On `Err` nothing was queued and the caller keeps the
    /// message.
    pub fn submit(&mut self, vc: VirtualChannel, msg: &Out) -> Result<u8, SubmitError> {
        if self.lost.is_some() {
            return Err(SubmitError::LinkLost);
        }
        let class = msg.class();
        self.fops[vc.index()].submit(
            class,
            |ns, buffer| encode(&LinkFrame::Ad { vc, ns, msg }, buffer),
            &mut self.stats.sent[vc.index()],
        )
    }

    /// Encode `msg` as a Type-BD frame into `out` (at least [`MAX_FRAME_LEN`] bytes to be
    /// sure); returns the length. Send it with the current burst, before
    /// [`Self::produce_burst`] writes the RoundEnd, or (Hello) on its own at boot.
    pub fn encode_expedited(&mut self, msg: &Out, out: &mut [u8]) -> Result<usize, EncodeError> {
        let len = encode(&LinkFrame::Bd(msg), out)?;
        bump(&mut self.stats.expedited_sent);
        bump(&mut self.stats.class_mut(msg.class()).sent);
        Ok(len)
    }

    /// [`Self::encode_expedited`] straight into a sink.
    pub fn send_expedited(
        &mut self,
        msg: &Out,
        sink: &mut impl FrameSink,
    ) -> Result<(), EncodeError> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = self.encode_expedited(msg, &mut frame)?;
        sink.send_frame(&frame[..len]);
        Ok(())
    }

    /// Take one frame from the decoder (`FrameDecoder::push::<LinkFrame<In>>`), damaged or
    /// not. `consumer_has_room(vc)` is asked before an in-sequence message is accepted; say
    /// false when the message could not be handed on (the peer will send it again).
    pub fn on_frame(
        &mut self,
        frame: Result<LinkFrame<In>, DecodeError>,
        consumer_has_room: impl FnOnce(VirtualChannel) -> bool,
    ) -> Received<In> {
        let frame = match frame {
            Ok(frame) => frame,
            Err(e) => {
                bump(&mut self.stats.frames_rejected);
                return Received::Discarded(Discard::Rejected(e));
            }
        };
        match frame {
            LinkFrame::Ad { vc, ns, msg } => self.on_ad(vc, ns, msg, consumer_has_room),
            LinkFrame::Bd(msg) => {
                // BD frames carry no VC; they count on the Mission channel's FARM-B counter.
                self.farms[VirtualChannel::Mission.index()].on_expedited();
                bump(&mut self.stats.expedited_received);
                bump(&mut self.stats.class_mut(msg.class()).delivered);
                Received::Expedited(msg)
            }
            LinkFrame::Bc { round, directive } => {
                if !self
                    .inbox
                    .admit(round, &mut self.stats.stale_control_frames)
                {
                    return Received::Discarded(Discard::StaleControl);
                }
                let i = directive.vc().index();
                match directive {
                    Directive::Unlock { .. } => self.inbox.unlock[i] = true,
                    Directive::SetVr { vr, .. } => self.inbox.set_vr[i] = Some(vr),
                }
                Received::Noted
            }
            LinkFrame::Report(report) => {
                if !self
                    .inbox
                    .admit(report.round, &mut self.stats.stale_control_frames)
                {
                    return Received::Discarded(Discard::StaleControl);
                }
                self.inbox.report = Some(report);
                Received::Noted
            }
            LinkFrame::RoundEnd { round } => self.on_round_end(round),
        }
    }

    fn on_ad(
        &mut self,
        vc: VirtualChannel,
        ns: u8,
        msg: In,
        consumer_has_room: impl FnOnce(VirtualChannel) -> bool,
    ) -> Received<In> {
        let i = vc.index();
        let stats = &mut self.stats.received[i];
        match self.farms[i].on_ad(ns, || consumer_has_room(vc)) {
            AdVerdict::Accepted => {
                bump(&mut stats.accepted);
                bump(&mut self.stats.classes[msg.class().index()].delivered);
                Received::Delivered { vc, msg }
            }
            AdVerdict::RefusedBusy => {
                bump(&mut stats.refused_busy);
                Received::Discarded(Discard::RefusedBusy { vc, ns })
            }
            AdVerdict::OutOfSequence => {
                bump(&mut stats.out_of_sequence_discarded);
                Received::Discarded(Discard::OutOfSequence { vc, ns })
            }
            AdVerdict::Duplicate => {
                bump(&mut stats.duplicates_discarded);
                Received::Discarded(Discard::Duplicate { vc, ns })
            }
            AdVerdict::EnteredLockout => {
                bump(&mut stats.lockouts_entered);
                Received::Discarded(Discard::EnteredLockout { vc, ns })
            }
            AdVerdict::DiscardedInLockout => {
                bump(&mut stats.discarded_in_lockout);
                Received::Discarded(Discard::InLockout { vc, ns })
            }
        }
    }

    /// The peer's burst for `round` is complete: execute its directives, apply its Report
    /// (acknowledgements, retransmission requests, its send state), run T1.
    fn on_round_end(&mut self, round: u32) -> Received<In> {
        match self.role {
            Role::Initiator if round != self.round => {
                bump(&mut self.stats.stale_round_ends);
                return Received::Discarded(Discard::StaleRoundEnd { round });
            }
            Role::Initiator => {}
            Role::Responder => self.round = round,
        }
        bump(&mut self.stats.rounds_ended);
        let inbox = core::mem::replace(&mut self.inbox, ControlInbox::EMPTY);
        let mut clcws = [None; VC_COUNT];
        self.peer.current = false;
        if inbox.round == Some(round) {
            for (i, farm) in self.farms.iter_mut().enumerate() {
                let stats = &mut self.stats.received[i];
                if inbox.unlock[i] {
                    farm.on_unlock();
                    bump(&mut stats.directives_executed);
                }
                if let Some(vr) = inbox.set_vr[i] {
                    if farm.on_set_vr(vr) {
                        bump(&mut stats.directives_executed);
                    }
                }
            }
            if let Some(report) = inbox.report {
                bump(&mut self.stats.reports_applied);
                if report.lost && self.lost.is_none() {
                    self.declare_lost(LostReason::PeerLost);
                }
                for (i, farm) in self.farms.iter_mut().enumerate() {
                    if farm.on_peer_sent(report.sent_vs[i]) {
                        bump(&mut self.stats.received[i].missing_tail_detected);
                    }
                    clcws[i] = Some(report.clcw[i]);
                }
                self.peer = PeerSendState {
                    current: true,
                    sent_vs: report.sent_vs,
                    backlog: report.backlog,
                };
            }
        } else {
            self.stats.stale_control_frames =
                self.stats.stale_control_frames.saturating_add(inbox.frames);
        }
        if self.lost.is_none() {
            for (i, clcw) in clcws.into_iter().enumerate() {
                let reason = self.fops[i].on_round_end(clcw, &self.config, &mut self.stats.sent[i]);
                if let Some(reason) = reason {
                    self.declare_lost(reason);
                    break;
                }
            }
        }
        Received::RoundEnd { round }
    }

    /// Write this side's burst: per channel the directives or the retransmissions and new
    /// frames, then the Report (`report_copies` times), then RoundEnd. The initiator starts a
    /// new round with it; the responder answers the round of the last RoundEnd it received.
    /// After the link is lost only the Report and RoundEnd are written.
    pub fn produce_burst(&mut self, sink: &mut impl FrameSink) -> BurstSummary {
        if self.role == Role::Initiator {
            self.round = self.round.wrapping_add(1);
        }
        let round = self.round;
        let mut counting = CountingSink {
            inner: sink,
            frames: 0,
            bytes: 0,
        };
        if self.lost.is_none() {
            for i in 0..VC_COUNT {
                let reason = self.fops[i].transmit(
                    round,
                    &self.config,
                    &mut counting,
                    &mut self.stats.sent[i],
                    &mut self.stats.classes,
                );
                if let Some(reason) = reason {
                    self.declare_lost(reason);
                    break;
                }
            }
        }
        let report = self.report(round);
        let mut frame = [0u8; MAX_FRAME_LEN];
        if let Ok(len) = encode(&LinkFrame::<()>::Report(report), &mut frame) {
            for _ in 0..self.config.report_copies {
                counting.send_frame(&frame[..len]);
            }
        }
        if let Ok(len) = encode(&LinkFrame::<()>::RoundEnd { round }, &mut frame) {
            counting.send_frame(&frame[..len]);
        }
        BurstSummary {
            round,
            frames: counting.frames,
            bytes: counting.bytes,
        }
    }

    /// The Report this side would send now for `round`.
    pub fn report(&self, round: u32) -> LinkReport {
        LinkReport {
            round,
            clcw: [self.farms[0].clcw(), self.farms[1].clcw()],
            sent_vs: [self.fops[0].v_s(), self.fops[1].v_s()],
            backlog: [self.fops[0].backlog() > 0, self.fops[1].backlog() > 0],
            lost: self.lost.is_some(),
        }
    }

    /// `vc` is quiet both ways as far as this side can tell: it is open, everything this side
    /// queued on it was acknowledged, and the peer's Report of the round that just ended showed
    /// it had sent nothing this side has not accepted and had nothing waiting. The host uses
    /// this (on the Mission channel only, so that instrumentation never changes the round
    /// sequence) to decide that a lockstep frame's exchange is complete.
    pub fn is_settled(&self, vc: VirtualChannel) -> bool {
        let i = vc.index();
        self.lost.is_none()
            && self.fops[i].is_settled()
            && !self.farms[i].is_locked_out()
            && self.peer.current
            && self.peer.sent_vs[i] == self.farms[i].v_r()
            && !self.peer.backlog[i]
    }

    /// [`Self::is_settled`] on every channel.
    pub fn is_all_settled(&self) -> bool {
        VirtualChannel::ALL.iter().all(|&vc| self.is_settled(vc))
    }

    /// Restart the link (after the target's Hello on the host, at boot on the target): every
    /// queued message is dropped and counted as lost to reset, V(S) = V(R) = 0, each FARM
    /// waits for the peer's Unlock, each FOP opens its channel again. Counters are kept.
    pub fn reset(&mut self) {
        for fop in self.fops.iter_mut() {
            let i = fop.vc().index();
            fop.reset(&mut self.stats.sent[i], &mut self.stats.classes);
        }
        self.farms = [Farm::new(), Farm::new()];
        self.inbox = ControlInbox::EMPTY;
        self.peer = PeerSendState::default();
        self.lost = None;
        if self.role == Role::Responder {
            self.round = 0;
        }
        bump(&mut self.stats.resets);
    }

    fn declare_lost(&mut self, reason: LostReason) {
        self.lost = Some(LinkLost {
            reason,
            round: self.round,
            sent_acknowledged: [self.fops[0].nn_r(), self.fops[1].nn_r()],
            sent_acknowledged_total: [
                self.fops[0].acknowledged_total(),
                self.fops[1].acknowledged_total(),
            ],
            received: [self.farms[0].v_r(), self.farms[1].v_r()],
            received_total: [
                self.farms[0].accepted_total(),
                self.farms[1].accepted_total(),
            ],
        });
    }
}

/// Counts what passes to the caller's sink.
struct CountingSink<'a, S> {
    inner: &'a mut S,
    frames: u32,
    bytes: u32,
}

impl<S: FrameSink> FrameSink for CountingSink<'_, S> {
    fn send_frame(&mut self, frame: &[u8]) {
        self.frames = self.frames.saturating_add(1);
        self.bytes = self
            .bytes
            .saturating_add(u32::try_from(frame.len()).unwrap_or(u32::MAX));
        self.inner.send_frame(frame);
    }
}
