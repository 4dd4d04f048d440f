//! The link envelope: what travels inside one codec frame once the reliable layer is on. A
//! [`LinkFrame`] wraps a message of the direction's message set (Type-AD or Type-BD) or carries
//! the link's own control (Type-BC directives, the [`LinkReport`] with the CLCWs, the
//! [`LinkFrame::RoundEnd`] doorbell). The wire layout is postcard, like the messages.
use serde::{Deserialize, Serialize};

use crate::codec::WireMessage;

/// Virtual channels per direction. Each is a separate reliable, in-order stream with its own
/// sequence numbers.
pub const VC_COUNT: usize = 2;

/// A virtual channel (VC) of one direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum VirtualChannel {
    /// VC0: everything the mission's outcome depends on (time grants and frame completions,
    /// state updates, command dispatches and responses, uplink chunks and their replies, reset
    /// requests, the autonomy's task and plan telemetry). Identical on the native and the
    /// emulated target.
    Mission,
    /// VC1: instrumentation only the emulated target produces (measured costs, kernel health
    /// events, defmt logs, panic reports). Kept apart so that the mission stream, its sequence
    /// numbers and therefore its injected faults are the same with or without it.
    Instrument,
}

impl VirtualChannel {
    /// Both channels, in index order.
    pub const ALL: [VirtualChannel; VC_COUNT] =
        [VirtualChannel::Mission, VirtualChannel::Instrument];

    /// Index into per-VC arrays (0 for Mission, 1 for Instrument).
    pub const fn index(self) -> usize {
        match self {
            VirtualChannel::Mission => 0,
            VirtualChannel::Instrument => 1,
        }
    }

    /// Short lowercase name for reports.
    pub const fn name(self) -> &'static str {
        match self {
            VirtualChannel::Mission => "mission",
            VirtualChannel::Instrument => "instrument",
        }
    }
}

/// A COP-1 control command, carried in a Type-BC frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Directive {
    /// Leave lockout (and clear the wait and retransmit flags) on the receiver of `vc`.
    Unlock { vc: VirtualChannel },
    /// Set the receiver's V(R) on `vc` (ignored while in lockout, as in COP-1: unlock first).
    SetVr { vc: VirtualChannel, vr: u8 },
}

impl Directive {
    /// The virtual channel the directive is for.
    pub const fn vc(self) -> VirtualChannel {
        match self {
            Directive::Unlock { vc } | Directive::SetVr { vc, .. } => vc,
        }
    }
}

/// Communications Link Control Word: what the receiver (FARM-1) of one virtual channel reports
/// to the sender (FOP-1). On the wire it takes two bytes: N(R), then the flags (bit 0 lockout,
/// bit 1 wait, bit 2 retransmit, bits 3-4 the FARM-B counter), so that a Report stays short
/// (every byte of it is exposed to corruption) and has the same length whatever it says.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "ClcwWire", try_from = "ClcwWire")]
pub struct Clcw {
    /// N(R): the receiver's V(R), the next sequence number it expects. Every frame before it
    /// was accepted.
    pub report_value: u8,
    /// The receiver is in lockout: it discards every AD frame until an Unlock directive.
    pub lockout: bool,
    /// The receiver refused the in-sequence frame because its consumer was full.
    pub wait: bool,
    /// The receiver knows it missed frames: retransmit everything unacknowledged.
    pub retransmit: bool,
    /// Accepted BD and BC frames, modulo 4 (COP-1's two-bit FARM-B counter).
    pub farm_b_counter: u8,
}

const CLCW_LOCKOUT: u8 = 1 << 0;
const CLCW_WAIT: u8 = 1 << 1;
const CLCW_RETRANSMIT: u8 = 1 << 2;
const CLCW_FARM_B_SHIFT: u32 = 3;
const CLCW_FARM_B_MASK: u8 = 0b11;
const CLCW_KNOWN_BITS: u8 =
    CLCW_LOCKOUT | CLCW_WAIT | CLCW_RETRANSMIT | (CLCW_FARM_B_MASK << CLCW_FARM_B_SHIFT);

/// The CLCW as it is serialized.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct ClcwWire(u8, u8);

impl From<Clcw> for ClcwWire {
    fn from(c: Clcw) -> Self {
        let mut flags = (c.farm_b_counter & CLCW_FARM_B_MASK) << CLCW_FARM_B_SHIFT;
        if c.lockout {
            flags |= CLCW_LOCKOUT;
        }
        if c.wait {
            flags |= CLCW_WAIT;
        }
        if c.retransmit {
            flags |= CLCW_RETRANSMIT;
        }
        ClcwWire(c.report_value, flags)
    }
}

impl TryFrom<ClcwWire> for Clcw {
    type Error = &'static str;

    fn try_from(w: ClcwWire) -> Result<Self, Self::Error> {
        let ClcwWire(report_value, flags) = w;
        if flags & !CLCW_KNOWN_BITS != 0 {
            return Err("unknown CLCW flag bits");
        }
        Ok(Clcw {
            report_value,
            lockout: flags & CLCW_LOCKOUT != 0,
            wait: flags & CLCW_WAIT != 0,
            retransmit: flags & CLCW_RETRANSMIT != 0,
            farm_b_counter: (flags >> CLCW_FARM_B_SHIFT) & CLCW_FARM_B_MASK,
        })
    }
}

/// What one endpoint tells the other at the end of each of its bursts: for each VC the peer
/// sends on, the CLCW of this side's receiver; for each VC this side sends on, its V(S) and
/// whether more messages wait for window space.
///
/// The V(S) is a deviation from pure COP-1, which learns of a lost tail of frames only from the
/// T1 timer: a receiver that sees a V(S) ahead of its V(R) knows it missed the end of the burst
/// and asks for retransmission at once (retransmit flag), one round earlier than T1 would.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LinkReport {
    /// The round this report belongs to (the number in the RoundEnd that follows it). A
    /// report is applied only at the RoundEnd of its own round, so a delayed or duplicated
    /// old report can never be mistaken for a fresh one.
    pub round: u32,
    /// Receiver state per VC of the peer's direction, by [`VirtualChannel::index`].
    pub clcw: [Clcw; VC_COUNT],
    /// This side's V(S) per VC: the sequence number of the next frame it will send for the
    /// first time (everything before it has been sent at least once).
    pub sent_vs: [u8; VC_COUNT],
    /// Per VC: this side has messages waiting for window space (it is not done sending).
    pub backlog: [bool; VC_COUNT],
    /// This side has declared the link lost: it sends nothing more until a reset, and the
    /// peer ends too (with [`super::LostReason::PeerLost`]) instead of waiting for traffic
    /// that will never come.
    pub lost: bool,
}

/// One frame of the reliable link. `M` is the direction's message set (`HostToTarget` or
/// `TargetToHost`); a sender may encode a `LinkFrame<&M>`, which serializes identically.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LinkFrame<M> {
    /// Type-AD: sequence-controlled data on a virtual channel. `ns` is N(S).
    Ad { vc: VirtualChannel, ns: u8, msg: M },
    /// Type-BD: expedited data, no sequence control (Hello, Ping, Pong). May be lost or
    /// duplicated by the channel: only for messages that tolerate that.
    Bd(M),
    /// Type-BC: a control command for the peer's receiver. `round` is the round of the burst
    /// that carries it; a directive is applied at that round's RoundEnd and only then, so a
    /// delayed or duplicated directive from another round (or from before a reset) is never
    /// executed. (An addition to COP-1's BC frame, which relies on its frame sequence.)
    Bc { round: u32, directive: Directive },
    /// The sender's CLCWs and send state; see [`LinkReport`].
    Report(LinkReport),
    /// The lockstep doorbell: the sender's burst for `round` is complete. Never damaged by the
    /// fault injector (it is the harness's synchronisation, like QMP, not flight traffic).
    RoundEnd { round: u32 },
}

impl<M: WireMessage> WireMessage for LinkFrame<M> {
    const VARIANT_COUNT: u8 = 5;
}

/// The kind of a frame, without its contents.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FrameKind {
    Ad,
    Bd,
    Bc,
    Report,
    RoundEnd,
}

impl<M> LinkFrame<M> {
    /// This frame's kind.
    pub fn kind(&self) -> FrameKind {
        match self {
            LinkFrame::Ad { .. } => FrameKind::Ad,
            LinkFrame::Bd(_) => FrameKind::Bd,
            LinkFrame::Bc { .. } => FrameKind::Bc,
            LinkFrame::Report(_) => FrameKind::Report,
            LinkFrame::RoundEnd { .. } => FrameKind::RoundEnd,
        }
    }
}
