//! The reliable link layer, modelled on CCSDS COP-1 (CCSDS 232.1-B: FOP-1 on the sender, FARM-1
//! on the receiver) and counted in lockstep rounds instead of wall time. With it every message
//! that carries meaning is delivered exactly once and in order, in both directions, or the link
//! is declared lost with the last acknowledged sequence numbers both ways ([`LinkLost`]).
//!
//! # Frames
//!
//! The codec ([`crate::codec`]: `0x00, COBS(postcard(payload) ++ CRC-32), 0x00`) stays the
//! framing; its payload becomes a [`LinkFrame`]:
//!
//! | frame                  | COP-1 name | carries                                                      | fault injector |
//! |------------------------|------------|--------------------------------------------------------------|----------------|
//! | `Ad { vc, ns, msg }`   | Type-AD    | a message on a virtual channel, sequence number N(S)         | any fault      |
//! | `Bd(msg)`              | Type-BD    | an expedited message, no sequence control (Hello, Ping, Pong) | any fault, except Hello |
//! | `Bc { round, directive }` | Type-BC | Unlock or Set V(R) for one VC of the peer's receiver         | any fault      |
//! | `Report(LinkReport)`   | (CLCW)     | per VC: the receiver's CLCW, the sender's V(S) and backlog   | any fault      |
//! | `RoundEnd { round }`   | -          | the lockstep doorbell: the sender's burst is complete        | never          |
//!
//! RoundEnd and the target's Hello are never damaged, dropped, duplicated or delayed: RoundEnd is
//! the harness's synchronisation (as QMP is), and Hello is the boot announcement that resets the
//! link. Every other frame may be corrupted, dropped, duplicated or delayed by a round.
//!
//! # Virtual channels and services
//!
//! Two virtual channels per direction, both reliable, with independent sequence numbers:
//! [`VirtualChannel::Mission`] (VC0) carries what the mission depends on and
//! [`VirtualChannel::Instrument`] (VC1) what only the emulated target sends (measured costs,
//! kernel health events, logs, panic reports). [`uplink_service`] and [`downlink_service`]
//! say which message goes where; Hello, Ping and Pong are Type-BD. Because the Mission stream,
//! its sequence numbers and the round sequence do not depend on VC1 (see "Rounds" below), the
//! same seed injects the same faults into it on the native and the emulated target.
//!
//! # Rounds (time)
//!
//! Nothing here reads a clock. The two sides talk in rounds: the initiator (the host) sends a
//! burst, the responder (the target) processes it and answers with its own burst, and so on.
//! A burst is, in order: for each VC the directives it needs (to open the channel or end a
//! lockout) or its retransmissions (every unacknowledged frame, in order) then its new frames
//! while the window has room; then the Report, [`LinkConfig::report_copies`] times; then
//! `RoundEnd { round }`. Type-BD frames the caller wants to send go before the RoundEnd.
//! The initiator numbers rounds 1, 2, ...; the responder's burst carries the number of the round
//! it answers. A Report or directive is applied only at the RoundEnd of its own round, so a
//! delayed or duplicated one from another round is discarded, never obeyed.
//!
//! Every timeout is counted in rounds: T1 expires when a round ends with frames still
//! unacknowledged and nothing asked for them ([`LinkConfig::t1_rounds`], default 1), and the
//! transmission limit counts transmissions of the oldest unacknowledged frame. Results therefore
//! never depend on the speed of the host. The host decides that a lockstep frame's exchange is
//! complete when [`Endpoint::is_settled`] holds for the Mission channel.
//!
//! # The rules
//!
//! Receiver (FARM-1, [`Farm`]): accept an AD frame iff N(S) = V(R) (then V(R) += 1, retransmit
//! flag cleared); N(S) ahead within the positive window: discard, set the retransmit flag;
//! behind within the negative window (a duplicate): discard silently; anywhere else: discard and
//! enter lockout (no AD frame is accepted until an Unlock directive). If the consumer has no
//! room for an in-sequence message the frame is discarded with the wait flag set. There is no
//! reordering buffer (go-back-N, as COP-1). The windows: [`FARM_POSITIVE_WINDOW`] and
//! [`FARM_NEGATIVE_WINDOW`] (64 each), so a frame delayed by a round (at most 2K behind) is
//! still recognised as a duplicate.
//!
//! Sender (FOP-1, [`Fop`]): at most K ([`LinkConfig::window_width`], default 16, at most
//! [`MAX_WINDOW_WIDTH`]) unacknowledged frames per VC; messages beyond it wait in the same ring
//! (the backlog) and `submit` says [`SubmitError::Full`] when the ring has no room, so nothing
//! is ever dropped silently. A CLCW with N(R) in [NN(R), V(S)] removes acknowledged frames; any
//! other N(R) is an invalid CLCW (counted, ignored). The retransmit flag or T1 sends every
//! unacknowledged frame again. The oldest unacknowledged frame may be transmitted
//! [`LinkConfig::transmission_limit`] times (the count starts again whenever frames are
//! acknowledged, as in COP-1) before the link is lost.
//!
//! Deviations from COP-1, each for a reason given where it is implemented: the Report carries
//! the sender's V(S) so that a receiver asks for a lost tail at once ([`LinkReport`]);
//! directives carry their round ([`LinkFrame::Bc`]); a FARM starts in lockout and each FOP opens
//! its channel with Unlock and Set V(R) before its first AD frame, so that nothing from before a
//! reset is ever accepted ([`farm`]); wait is a flag rather than a state; timers are rounds.
//!
//! Opening a channel takes a round trip: in round 1 the host's bursts carry Unlock and Set
//! V(R) = 0 for its channels and the target's answer confirms them (its CLCW: unlocked, V(R) =
//! 0); the target's channels are opened by its answer in round 1 and confirmed by the host's
//! Report in round 2. Messages submitted meanwhile wait in the backlog. Wait-flag
//! retransmissions (the peer's consumer was full) do not count toward the limit: a busy peer is
//! not a broken link. Type-BD frames carry no VC; they count on the Mission channel's FARM-B
//! counter. The Report's backlog flag is per VC so that settledness can be per VC.
//!
//! # Resets
//!
//! After a reset the target says Hello (Type-BD) before anything else; on it the host calls
//! [`Endpoint::reset`], and the target calls it at boot. Both sides restart with V(S) = V(R) = 0,
//! flush their queues (counting each flushed message in `lost_to_reset`: some of them may have
//! arrived just before the reset, a ResetRequest always has) and reopen their channels as
//! above. Frames from before the reset (in a UART FIFO, or held back by the fault injector)
//! are never accepted: the FARM is locked until the new session's Unlock, and directives and
//! Reports of other rounds are ignored. A fresh host session with a target that did not reset
//! is not supported: reset the target first (as `hil` does).
//!
//! # Integration
//!
//! ```text
//! host (Role::Initiator)                      target (Role::Responder)
//! ----------------------                      ------------------------
//!                                             at boot: reset(); send Hello as Type-BD
//! loop per lockstep frame:
//!   submit(vc, msg) for what is due           (submit may say Full: keep the message)
//!   loop:
//!     write BD frames (Ping), then
//!     produce_burst(sink)        ── burst ──► for each decoded frame: on_frame(frame, has_room)
//!                                               Delivered -> the application; Expedited(Ping)
//!                                               -> answer Pong as BD in the next burst
//!                                             on Received::RoundEnd: submit what is queued,
//!                                               write BD frames, produce_burst(sink)
//!     on_frame(...) for each frame ◄── burst ──
//!       Expedited(Hello) -> reset(), and start the next round at once (the answer to this
//!         one may never come; if it does, its RoundEnd is stale and ignored)
//!       RoundEnd { round } -> end of the round
//!     until is_settled(Mission) and the frame's FrameDone arrived
//!   lost() is Some -> the run ends with the "link lost" verdict (its Display names the
//!   sequence numbers both ways)
//! ```
//!
//! A responder may hold its answer until it has something to say (until the granted frame's
//! work is done, so that FrameDone travels in the answer): rounds have no deadline. The host
//! must decide when a frame's exchange is complete from the Mission channel alone, so that the
//! round sequence, and with it the faults the Mission stream meets, is the same on the native
//! target (no Instrument traffic) and the emulated one; Instrument frames travel in whatever
//! rounds there are. `downlink_service` routes metrics by the telemetry dictionary
//! ([`crate::dictionary`]), the same on both.
//!
//! Throughput is go-back-N's: each round delivers, per VC, the frames up to the first one lost.
//! With 1 % byte corruption and 10 % loss a 25-byte frame gets through about 7 times in 10, so
//! a round delivers 2 to 3 new messages per VC; clean links deliver the whole window (K = 16).
//!
//! # Capacities and cost
//!
//! Per outgoing VC an endpoint keeps up to `QUEUE_LEN` encoded frames in a ring of `RING_BYTES`
//! bytes (window and backlog together). [`TargetEndpoint`] (2 KiB and 64 frames per VC) takes
//! 5528 bytes of RAM: 4096 for the rings, 768 for the frame slots, the rest for the FARMs, the
//! round state and the counters; [`TARGET_ENDPOINT_BYTES_MAX`] is its budget (a test checks
//! it). It needs no heap; the deepest call, `produce_burst`, uses about 1 KiB of stack (three
//! frame buffers and the codec's own).
//!
//! # Testing support
//!
//! [`faults`] holds the deterministic fault decisions (a pure function of seed, direction,
//! frame identity, attempt and byte index) that the tests' lossy channel and the host's fault
//! injector share; with the `std` feature, `channel::LossyChannel` applies them to bursts.
pub mod class;
pub mod endpoint;
pub mod farm;
pub mod faults;
pub mod fop;
pub mod frame;
pub mod stats;

#[cfg(feature = "std")]
pub mod channel;

use core::fmt;

use crate::messages::{HostToTarget, TargetToHost};

pub use class::{downlink_service, uplink_service, LinkMessage, MessageClass, Service};
pub use endpoint::{BurstSummary, Discard, Endpoint, PeerSendState, Received, Role};
pub use farm::{AdVerdict, Farm, FARM_NEGATIVE_WINDOW, FARM_POSITIVE_WINDOW, FARM_WINDOW_WIDTH};
pub use fop::{Fop, FopState, SubmitError};
pub use frame::{Clcw, Directive, FrameKind, LinkFrame, LinkReport, VirtualChannel, VC_COUNT};
pub use stats::{ClassStats, LinkStats, ReceiveStats, SendStats};

/// Largest sliding window K: a frame delayed by one round is at most 2K behind V(R), which must
/// stay inside the negative window (and K < PW, as COP-1 requires).
pub const MAX_WINDOW_WIDTH: u8 = FARM_NEGATIVE_WINDOW / 2;
// K < PW (COP-1), and a frame delayed by a round (at most 2K behind V(R)) is a duplicate.
const _: () = assert!(
    MAX_WINDOW_WIDTH < FARM_POSITIVE_WINDOW
        && 2 * (MAX_WINDOW_WIDTH as u16) <= FARM_NEGATIVE_WINDOW as u16
        && DEFAULT_WINDOW_WIDTH <= MAX_WINDOW_WIDTH
);

/// Default sliding window K (frames sent and unacknowledged per VC).
pub const DEFAULT_WINDOW_WIDTH: u8 = 16;
/// Default transmission limit: transmissions of the oldest unacknowledged frame before the link
/// is declared lost. A round costs one exchange, not a timeout, so the limit can be generous:
/// on a link that corrupts 5 % of the bytes and loses 10 % of the frames a 25-byte frame gets
/// through one attempt in five, and 64 failures in a row happen about once in 10^6 frames. With
/// 16, a third of 100-message runs over that link were declared lost; with 32, about 1 %
/// (`tests/link_property.rs` exercises these rates). The largest frames a mission sends (an
/// uplink chunk, about 48 bytes on the wire as `hil` cuts them) get through a 5 % link one
/// attempt in twelve: with 255 transmissions the chance that one of them is refused every time
/// is about 10^-10. A dead link is still declared lost within 255 rounds.
pub const DEFAULT_TRANSMISSION_LIMIT: u8 = 255;
/// Default T1, in rounds.
pub const DEFAULT_T1_ROUNDS: u8 = 1;
/// Default number of copies of the Report in each burst.
pub const DEFAULT_REPORT_COPIES: u8 = 2;

/// Link parameters. Both sides should use the same.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LinkConfig {
    /// K: frames per VC sent and not yet acknowledged, 1..=[`MAX_WINDOW_WIDTH`].
    pub window_width: u8,
    /// Transmissions of the oldest unacknowledged frame (and bursts of opening directives, and
    /// consecutive lockout reports) before the link is lost, at least 1.
    pub transmission_limit: u8,
    /// T1: round ends with frames unacknowledged and nothing asked before they go out again, at
    /// least 1.
    pub t1_rounds: u8,
    /// Copies of the Report per burst, at least 1. Acknowledgements only travel in Reports, so
    /// on a noisy link a second copy saves many retransmissions for a few bytes (COP-1 puts the
    /// CLCW in every downlink frame for the same reason).
    pub report_copies: u8,
}

impl LinkConfig {
    /// The defaults above.
    pub const DEFAULT: Self = Self {
        window_width: DEFAULT_WINDOW_WIDTH,
        transmission_limit: DEFAULT_TRANSMISSION_LIMIT,
        t1_rounds: DEFAULT_T1_ROUNDS,
        report_copies: DEFAULT_REPORT_COPIES,
    };

    /// Check every field's range.
    pub const fn validate(&self) -> Result<(), ConfigError> {
        if self.window_width == 0 || self.window_width > MAX_WINDOW_WIDTH {
            return Err(ConfigError::WindowWidth);
        }
        if self.transmission_limit == 0 {
            return Err(ConfigError::TransmissionLimit);
        }
        if self.t1_rounds == 0 {
            return Err(ConfigError::T1Rounds);
        }
        if self.report_copies == 0 {
            return Err(ConfigError::ReportCopies);
        }
        Ok(())
    }
}

impl Default for LinkConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A [`LinkConfig`] field out of range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    /// `window_width` not in 1..=[`MAX_WINDOW_WIDTH`].
    WindowWidth,
    /// `transmission_limit` is 0.
    TransmissionLimit,
    /// `t1_rounds` is 0.
    T1Rounds,
    /// `report_copies` is 0.
    ReportCopies,
}

/// Why the link was declared lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LostReason {
    /// Frame `ns` of `vc` was transmitted the transmission limit number of times and the peer
    /// never accepted it.
    TransmissionLimit { vc: VirtualChannel, ns: u8 },
    /// The peer's receiver on `vc` stayed in lockout through the transmission limit number of
    /// Unlock directives.
    Lockout { vc: VirtualChannel },
    /// The peer never confirmed opening `vc` (Unlock and Set V(R) sent the transmission limit
    /// number of times).
    InitiationFailed { vc: VirtualChannel },
    /// The peer's Report said it had declared the link lost (for one of the reasons above, on
    /// its side).
    PeerLost,
}

/// The "link lost" verdict: why, when, and how far each direction got.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LinkLost {
    pub reason: LostReason,
    /// The round in which it was declared.
    pub round: u32,
    /// Per VC this side sends on: NN(R), the first N(S) the peer has not acknowledged (every
    /// frame before it was).
    pub sent_acknowledged: [u8; VC_COUNT],
    /// Frames acknowledged per VC since the last reset (NN(R) without the modulo).
    pub sent_acknowledged_total: [u32; VC_COUNT],
    /// Per VC the peer sends on: V(R), the next N(S) this side would accept.
    pub received: [u8; VC_COUNT],
    /// Frames accepted (delivered) per VC since the last reset.
    pub received_total: [u32; VC_COUNT],
}

impl fmt::Display for LinkLost {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "link lost in round {}: ", self.round)?;
        match self.reason {
            LostReason::TransmissionLimit { vc, ns } => write!(
                f,
                "{} frame N(S)={ns} reached the transmission limit unacknowledged",
                vc.name()
            )?,
            LostReason::Lockout { vc } => {
                write!(f, "the peer's {} receiver stayed in lockout", vc.name())?
            }
            LostReason::InitiationFailed { vc } => {
                write!(f, "the peer never opened the {} channel", vc.name())?
            }
            LostReason::PeerLost => write!(
                f,
                "the peer declared the link lost (one of its frames reached the transmission limit, or it could not open a channel)"
            )?,
        }
        for vc in VirtualChannel::ALL {
            let i = vc.index();
            write!(
                f,
                "; {}: sent acknowledged up to N(R)={} ({} frames), received up to V(R)={} ({} frames)",
                vc.name(),
                self.sent_acknowledged[i],
                self.sent_acknowledged_total[i],
                self.received[i],
                self.received_total[i],
            )?;
        }
        Ok(())
    }
}

/// Where an endpoint writes its frames (whole encoded frames, delimiters included).
pub trait FrameSink {
    fn send_frame(&mut self, frame: &[u8]);
}

impl<F: FnMut(&[u8])> FrameSink for F {
    fn send_frame(&mut self, frame: &[u8]) {
        self(frame)
    }
}

/// Bytes of ring per outgoing VC on the target: about 20 full-size log frames, or 80 typical
/// mission messages.
pub const TARGET_RING_BYTES: usize = 2048;
/// Frames per outgoing VC on the target (window and backlog).
pub const TARGET_QUEUE_LEN: usize = 64;
/// The target's endpoint: sends `TargetToHost`, receives `HostToTarget`.
pub type TargetEndpoint = Endpoint<TargetToHost, HostToTarget, TARGET_RING_BYTES, TARGET_QUEUE_LEN>;
/// Most bytes a [`TargetEndpoint`] takes (checked by a test; the I/O partition's budget).
pub const TARGET_ENDPOINT_BYTES_MAX: usize = 6 * 1024;

/// Bytes of ring per outgoing VC on the host (a whole task-network uplink fits).
pub const HOST_RING_BYTES: usize = 64 * 1024;
/// Frames per outgoing VC on the host.
pub const HOST_QUEUE_LEN: usize = 255;
/// The host's endpoint: sends `HostToTarget`, receives `TargetToHost`. About 130 KiB: box it.
pub type HostEndpoint = Endpoint<HostToTarget, TargetToHost, HOST_RING_BYTES, HOST_QUEUE_LEN>;
