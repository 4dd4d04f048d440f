//! FOP-1, the sending end of one virtual channel (CCSDS 232.1-B, section 5), counted in
//! lockstep rounds instead of wall time. Submitted messages are encoded once, as Type-AD
//! frames with their N(S), into a fixed byte ring; the first K of them (the sliding window) are
//! sent, the rest wait there (the backlog) until acknowledgements make room. A CLCW from the
//! peer's FARM removes acknowledged frames, and its retransmit flag (or T1: a round that ends
//! with frames still unacknowledged and nothing asked) sends every unacknowledged frame again,
//! in order (go-back-N).
//!
//! As in COP-1, the transmission count belongs to the first frame of the sent queue and starts
//! again at 1 whenever an acknowledgement removes frames: the link is declared lost only when
//! that frame has been transmitted `transmission_limit` times without the peer accepting it,
//! never while frames are getting through. Retransmissions asked for with the wait flag (the
//! peer is alive but its consumer is full) do not count.
//!
//! The channel is opened (after construction and after every reset) by sending Unlock and Set
//! V(R) = NN(R) in Type-BC frames, and no AD frame until a CLCW shows the peer's FARM unlocked
//! with V(R) = NN(R) (COP-1's "initiate AD service with Set V(R)").
use heapless::Deque;

use crate::codec::{encode, EncodeError, MAX_FRAME_LEN};
use crate::link::class::MessageClass;
use crate::link::frame::{Clcw, Directive, LinkFrame, VirtualChannel};
use crate::link::stats::{add, bump, ClassStats, SendStats};
use crate::link::{FrameSink, LinkConfig, LostReason};

/// Where an encoded frame sits in the ring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct QueuedFrame {
    start: u16,
    len: u16,
    class: MessageClass,
}

/// Encoded frames, oldest first, in a fixed byte ring: a frame takes the bytes it needs (a
/// Ping-sized message about 20, the largest 256), and may wrap around the end.
#[derive(Clone, Debug)]
struct FrameRing<const BYTES: usize, const FRAMES: usize> {
    bytes: [u8; BYTES],
    /// Offset of the oldest frame's first byte.
    head: usize,
    /// Bytes held.
    used: usize,
    frames: Deque<QueuedFrame, FRAMES>,
}

impl<const BYTES: usize, const FRAMES: usize> FrameRing<BYTES, FRAMES> {
    /// Checked when an endpoint is instantiated: any frame fits in an empty ring, offsets fit
    /// in a u16, and the frames held have distinct 8-bit sequence numbers.
    const CAPACITY_CHECK: () = {
        assert!(BYTES >= MAX_FRAME_LEN, "ring must hold the largest frame");
        assert!(BYTES <= u16::MAX as usize + 1, "ring offsets are u16");
        assert!(FRAMES >= 1 && FRAMES <= 255, "1..=255 frames (8-bit N(S))");
    };

    const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CAPACITY_CHECK;
        Self {
            bytes: [0; BYTES],
            head: 0,
            used: 0,
            frames: Deque::new(),
        }
    }

    fn len(&self) -> usize {
        self.frames.len()
    }

    fn can_take_frame(&self) -> bool {
        !self.frames.is_full()
    }

    /// Append a frame; false if the ring lacks the bytes or a slot.
    fn push(&mut self, frame: &[u8], class: MessageClass) -> bool {
        if self.frames.is_full() || frame.len() > BYTES - self.used || frame.is_empty() {
            return false;
        }
        let start = (self.head + self.used) % BYTES;
        let first = frame.len().min(BYTES - start);
        let (before_end, wrapped) = frame.split_at(first);
        self.bytes[start..start + first].copy_from_slice(before_end);
        self.bytes[..wrapped.len()].copy_from_slice(wrapped);
        self.used += frame.len();
        // Cannot fail: checked not full above. start < BYTES <= 65536 and len <= 256.
        let _ = self.frames.push_back(QueuedFrame {
            start: start as u16,
            len: frame.len() as u16,
            class,
        });
        true
    }

    /// Remove the oldest frame.
    fn pop_front(&mut self) -> Option<QueuedFrame> {
        let frame = self.frames.pop_front()?;
        self.head = (self.head + usize::from(frame.len)) % BYTES;
        self.used -= usize::from(frame.len);
        if self.frames.is_empty() {
            self.head = 0;
            self.used = 0;
        }
        Some(frame)
    }

    fn clear(&mut self) {
        self.frames.clear();
        self.head = 0;
        self.used = 0;
    }

    /// The bytes of `frame`, made contiguous in `scratch`.
    fn copy_out<'s>(&self, frame: &QueuedFrame, scratch: &'s mut [u8; MAX_FRAME_LEN]) -> &'s [u8] {
        let start = usize::from(frame.start);
        let len = usize::from(frame.len).min(MAX_FRAME_LEN);
        let first = len.min(BYTES - start);
        scratch[..first].copy_from_slice(&self.bytes[start..start + first]);
        scratch[first..len].copy_from_slice(&self.bytes[..len - first]);
        &scratch[..len]
    }
}

/// Whether the FOP may send AD frames yet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FopState {
    /// Opening the channel: Unlock and Set V(R) go out each burst until a CLCW confirms.
    Initiating,
    /// Sending AD frames.
    Active,
}

/// Why the unacknowledged frames go out again in the next burst.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Retransmission {
    /// Retransmit flag or T1: counts toward the transmission limit.
    Counted,
    /// Wait flag: the peer is alive but was full; does not count.
    Uncounted,
}

/// Why `submit` refused a message. The caller keeps the message and offers it again later.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubmitError {
    /// Neither the window nor the backlog has room (slots or bytes). Try after the next round.
    Full,
    /// The message does not fit in one frame.
    TooLarge,
    /// The link is lost; nothing more is accepted until a reset.
    LinkLost,
}

/// The sending end of one virtual channel, with room for `QUEUE_LEN` frames in `RING_BYTES`
/// bytes (window and backlog together).
#[derive(Clone, Debug)]
pub struct Fop<const RING_BYTES: usize, const QUEUE_LEN: usize> {
    vc: VirtualChannel,
    ring: FrameRing<RING_BYTES, QUEUE_LEN>,
    state: FopState,
    /// Bursts that carried the opening directives since the last reset.
    initiation_attempts: u8,
    /// NN(R): the N(S) of the oldest unacknowledged frame (the expected acknowledgement).
    nn_r: u8,
    /// V(S): the N(S) of the next frame to be sent for the first time.
    v_s: u8,
    /// Transmissions of the first frame of the sent queue since it became first (COP-1's
    /// Transmission_Count).
    head_transmissions: u8,
    retransmission: Option<Retransmission>,
    /// Round ends since the last acknowledgement or retransmission with frames outstanding.
    t1_rounds_waited: u8,
    unlock_pending: bool,
    /// Consecutive CLCWs reporting lockout.
    lockout_reports: u8,
    /// Frames acknowledged since the last reset (NN(R) without the modulo).
    acknowledged_total: u32,
}

impl<const RING_BYTES: usize, const QUEUE_LEN: usize> Fop<RING_BYTES, QUEUE_LEN> {
    /// A FOP after a (re)start: nothing queued, about to open the channel.
    pub const fn new(vc: VirtualChannel) -> Self {
        Self {
            vc,
            ring: FrameRing::new(),
            state: FopState::Initiating,
            initiation_attempts: 0,
            nn_r: 0,
            v_s: 0,
            head_transmissions: 0,
            retransmission: None,
            t1_rounds_waited: 0,
            unlock_pending: false,
            lockout_reports: 0,
            acknowledged_total: 0,
        }
    }

    /// The virtual channel this FOP sends on.
    pub fn vc(&self) -> VirtualChannel {
        self.vc
    }

    pub fn state(&self) -> FopState {
        self.state
    }

    /// NN(R): frames before it were acknowledged.
    pub fn nn_r(&self) -> u8 {
        self.nn_r
    }

    /// V(S): frames before it were sent at least once.
    pub fn v_s(&self) -> u8 {
        self.v_s
    }

    /// Frames acknowledged since the last reset.
    pub fn acknowledged_total(&self) -> u32 {
        self.acknowledged_total
    }

    /// Frames sent and not yet acknowledged.
    pub fn outstanding(&self) -> usize {
        usize::from(self.v_s.wrapping_sub(self.nn_r))
    }

    /// Frames queued and not yet sent (waiting for the channel to open or for window space).
    pub fn backlog(&self) -> usize {
        self.ring.len() - self.outstanding()
    }

    /// Transmissions of the oldest unacknowledged frame since it became the oldest.
    pub fn head_transmissions(&self) -> u8 {
        self.head_transmissions
    }

    /// Bytes of the ring in use (window and backlog).
    pub fn ring_bytes_used(&self) -> usize {
        self.ring.used
    }

    /// Open, nothing queued, nothing to tell the peer.
    pub fn is_settled(&self) -> bool {
        self.state == FopState::Active && self.ring.len() == 0 && !self.unlock_pending
    }

    /// Queue a message as the next Type-AD frame. `encode_frame(ns, buffer)` writes the whole
    /// frame for sequence number `ns` into `buffer` and returns its length. Returns the N(S).
    pub fn submit(
        &mut self,
        class: MessageClass,
        encode_frame: impl FnOnce(u8, &mut [u8]) -> Result<usize, EncodeError>,
        stats: &mut SendStats,
    ) -> Result<u8, SubmitError> {
        if !self.ring.can_take_frame() {
            bump(&mut stats.refused_full);
            return Err(SubmitError::Full);
        }
        // At most 255 frames are queued, so the new frame's N(S) is distinct from theirs.
        let ns = self.nn_r.wrapping_add(self.ring.len() as u8);
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = match encode_frame(ns, &mut frame) {
            Ok(len) => len,
            Err(EncodeError::PayloadTooLarge) => return Err(SubmitError::TooLarge),
            // The buffer is a whole frame: the codec never needs more.
            Err(EncodeError::OutputTooSmall) => return Err(SubmitError::TooLarge),
        };
        if !self.ring.push(&frame[..len.min(MAX_FRAME_LEN)], class) {
            bump(&mut stats.refused_full);
            return Err(SubmitError::Full);
        }
        bump(&mut stats.submitted);
        Ok(ns)
    }

    /// Apply the peer's CLCW for this channel at the end of a round (None: no valid Report
    /// for this round arrived), then run T1. Returns why the link is lost, if it now is.
    pub fn on_round_end(
        &mut self,
        clcw: Option<Clcw>,
        config: &LinkConfig,
        stats: &mut SendStats,
    ) -> Option<LostReason> {
        if self.state == FopState::Initiating {
            if let Some(c) = clcw {
                if !c.lockout && c.report_value == self.nn_r {
                    self.state = FopState::Active;
                    self.lockout_reports = 0;
                }
            }
            return None;
        }
        let mut requested = None;
        if let Some(c) = clcw {
            let acknowledged = c.report_value.wrapping_sub(self.nn_r);
            if usize::from(acknowledged) > self.outstanding() {
                // N(R) outside [NN(R), V(S)]: not a state this FOP could have caused.
                bump(&mut stats.invalid_clcws);
            } else {
                if acknowledged > 0 {
                    for _ in 0..acknowledged {
                        self.ring.pop_front();
                    }
                    self.nn_r = c.report_value;
                    self.acknowledged_total = self
                        .acknowledged_total
                        .wrapping_add(u32::from(acknowledged));
                    add(&mut stats.acknowledged, u32::from(acknowledged));
                    self.head_transmissions = if self.outstanding() > 0 { 1 } else { 0 };
                    self.t1_rounds_waited = 0;
                }
                if c.lockout {
                    bump(&mut stats.lockouts_reported);
                    self.lockout_reports = self.lockout_reports.saturating_add(1);
                    if self.lockout_reports > config.transmission_limit {
                        return Some(LostReason::Lockout { vc: self.vc });
                    }
                    // Frames sent before the Unlock takes effect would be discarded: the next
                    // burst carries only the Unlock, and the CLCW after it asks for the rest.
                    self.unlock_pending = true;
                    self.retransmission = None;
                    self.t1_rounds_waited = 0;
                    return None;
                }
                self.lockout_reports = 0;
                if c.wait {
                    bump(&mut stats.peer_busy);
                }
                if self.outstanding() > 0 {
                    if c.wait {
                        requested = Some(Retransmission::Uncounted);
                    } else if c.retransmit {
                        bump(&mut stats.retransmit_requests);
                        requested = Some(Retransmission::Counted);
                    }
                }
            }
        }
        if self.outstanding() == 0 {
            self.retransmission = None;
            self.t1_rounds_waited = 0;
        } else if let Some(r) = requested {
            self.retransmission = Some(r);
            self.t1_rounds_waited = 0;
        } else {
            self.t1_rounds_waited = self.t1_rounds_waited.saturating_add(1);
            if self.t1_rounds_waited >= config.t1_rounds {
                bump(&mut stats.t1_expiries);
                self.retransmission = Some(Retransmission::Counted);
                self.t1_rounds_waited = 0;
            }
        }
        None
    }

    /// Write this channel's part of a burst for `round`: the opening directives, or an Unlock,
    /// or the retransmissions due and then new frames while the window has room. Returns why
    /// the link is lost if the transmission limit is reached (nothing is written then).
    pub fn transmit(
        &mut self,
        round: u32,
        config: &LinkConfig,
        sink: &mut impl FrameSink,
        stats: &mut SendStats,
        classes: &mut [ClassStats; MessageClass::COUNT],
    ) -> Option<LostReason> {
        let mut scratch = [0u8; MAX_FRAME_LEN];
        if self.state == FopState::Initiating {
            if self.initiation_attempts >= config.transmission_limit {
                return Some(LostReason::InitiationFailed { vc: self.vc });
            }
            self.initiation_attempts += 1;
            send_directive(round, Directive::Unlock { vc: self.vc }, sink);
            bump(&mut stats.unlocks_sent);
            send_directive(
                round,
                Directive::SetVr {
                    vc: self.vc,
                    vr: self.nn_r,
                },
                sink,
            );
            bump(&mut stats.set_vr_sent);
            return None;
        }
        if self.unlock_pending {
            self.unlock_pending = false;
            send_directive(round, Directive::Unlock { vc: self.vc }, sink);
            bump(&mut stats.unlocks_sent);
            return None;
        }
        let outstanding = self.outstanding();
        if let Some(cause) = self.retransmission.take() {
            if outstanding > 0 {
                if cause == Retransmission::Counted {
                    if self.head_transmissions >= config.transmission_limit {
                        return Some(LostReason::TransmissionLimit {
                            vc: self.vc,
                            ns: self.nn_r,
                        });
                    }
                    self.head_transmissions += 1;
                }
                for frame in self.ring.frames.iter().take(outstanding) {
                    sink.send_frame(self.ring.copy_out(frame, &mut scratch));
                    bump(&mut stats.retransmissions);
                    bump(&mut classes[frame.class.index()].retransmissions);
                }
            }
        }
        let room = usize::from(config.window_width).saturating_sub(outstanding);
        for frame in self.ring.frames.iter().skip(outstanding).take(room) {
            sink.send_frame(self.ring.copy_out(frame, &mut scratch));
            bump(&mut stats.first_transmissions);
            bump(&mut classes[frame.class.index()].sent);
            if self.v_s == self.nn_r {
                self.head_transmissions = 1;
            }
            self.v_s = self.v_s.wrapping_add(1);
        }
        None
    }

    /// Forget everything queued (counting it as lost to reset) and start opening the channel
    /// again with V(S) = NN(R) = 0.
    pub fn reset(
        &mut self,
        stats: &mut SendStats,
        classes: &mut [ClassStats; MessageClass::COUNT],
    ) {
        for frame in self.ring.frames.iter() {
            bump(&mut stats.lost_to_reset);
            bump(&mut classes[frame.class.index()].lost_to_reset);
        }
        // Field by field: building a fresh Fop would put a whole ring on the stack.
        self.ring.clear();
        self.state = FopState::Initiating;
        self.initiation_attempts = 0;
        self.nn_r = 0;
        self.v_s = 0;
        self.head_transmissions = 0;
        self.retransmission = None;
        self.t1_rounds_waited = 0;
        self.unlock_pending = false;
        self.lockout_reports = 0;
        self.acknowledged_total = 0;
    }
}

/// Encode and send one Type-BC frame.
fn send_directive(round: u32, directive: Directive, sink: &mut impl FrameSink) {
    let mut frame = [0u8; MAX_FRAME_LEN];
    // A directive is a few bytes: it always fits.
    if let Ok(len) = encode(&LinkFrame::<()>::Bc { round, directive }, &mut frame) {
        sink.send_frame(&frame[..len]);
    }
}
