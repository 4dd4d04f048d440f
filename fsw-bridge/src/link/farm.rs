//! FARM-1, the receiving end of one virtual channel (CCSDS 232.1-B, section 6): it accepts
//! Type-AD frames strictly in sequence (go-back-N, no reordering buffer), discards duplicates,
//! asks for retransmission when it sees a gap, locks out on a sequence number it cannot explain,
//! and reports its state in a [`Clcw`].
//!
//! The sliding window (modulo-256 arithmetic on N(S) − V(R)):
//!
//! | N(S) − V(R)                         | verdict                                              |
//! |-------------------------------------|------------------------------------------------------|
//! | 0                                   | accept (if the consumer has room), V(R) += 1, retransmit flag cleared; no room: discard, wait and retransmit flags set |
//! | 1 ..= PW − 1 (positive window)      | discard, retransmit flag set (a frame before it was lost) |
//! | −NW ..= −1 (negative window)        | discard silently (a duplicate of an accepted frame)   |
//! | anything else                       | discard, lockout: every AD frame is discarded until an Unlock |
//!
//! Differences from COP-1, and why:
//! - A FARM starts (and restarts after a link reset) in lockout. The peer's FOP opens the
//!   channel with Unlock and Set V(R) before its first AD frame (COP-1's "initiate AD service
//!   with Set V(R)"), so a frame left over from before a reset (still in a UART FIFO, or held
//!   back by the fault injector) can never be accepted as a new one.
//! - Wait is a flag, not a state: each in-sequence frame asks the consumer again, and the first
//!   one it takes clears the flag. COP-1 needs a separate buffer-release signal for that.
//! - The peer's V(S) from its [`crate::link::LinkReport`] also sets the retransmit flag when it
//!   is ahead of V(R) ([`Farm::on_peer_sent`]): the tail of the burst was lost.
use crate::link::frame::Clcw;

/// FARM sliding window width W (COP-1: even, 2..=254); PW = NW = W / 2.
pub const FARM_WINDOW_WIDTH: u8 = 128;
/// Positive window PW: how far ahead of V(R) an N(S) may be before it means lockout.
pub const FARM_POSITIVE_WINDOW: u8 = FARM_WINDOW_WIDTH / 2;
/// Negative window NW: how far behind V(R) an N(S) may be and still be a plain duplicate.
pub const FARM_NEGATIVE_WINDOW: u8 = FARM_WINDOW_WIDTH / 2;

/// What the FARM did with one Type-AD frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdVerdict {
    /// N(S) = V(R) and the consumer took it: deliver the message. V(R) moved on.
    Accepted,
    /// N(S) = V(R) but the consumer had no room: discarded, wait (and retransmit) flag set.
    RefusedBusy,
    /// N(S) in the positive window: a frame before it is missing. Discarded, retransmit flag set.
    OutOfSequence,
    /// N(S) in the negative window: already accepted. Discarded silently.
    Duplicate,
    /// N(S) outside both windows: discarded, the FARM entered lockout.
    EnteredLockout,
    /// The FARM was in lockout: discarded.
    DiscardedInLockout,
}

/// The receiver state of one virtual channel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Farm {
    /// V(R): the N(S) expected next.
    v_r: u8,
    lockout: bool,
    wait: bool,
    retransmit: bool,
    /// Accepted BD and BC frames (the CLCW carries the two low bits).
    farm_b_counter: u8,
    /// Frames accepted since the last reset.
    accepted_total: u32,
}

impl Default for Farm {
    fn default() -> Self {
        Self::new()
    }
}

impl Farm {
    /// A FARM after a (re)start: V(R) = 0, in lockout until the peer's Unlock.
    pub const fn new() -> Self {
        Self {
            v_r: 0,
            lockout: true,
            wait: false,
            retransmit: false,
            farm_b_counter: 0,
            accepted_total: 0,
        }
    }

    /// V(R), the next N(S) this receiver will accept.
    pub fn v_r(&self) -> u8 {
        self.v_r
    }

    /// Frames accepted since the last reset.
    pub fn accepted_total(&self) -> u32 {
        self.accepted_total
    }

    /// In lockout: no AD frame is accepted until an Unlock.
    pub fn is_locked_out(&self) -> bool {
        self.lockout
    }

    /// The CLCW reporting this receiver's state.
    pub fn clcw(&self) -> Clcw {
        Clcw {
            report_value: self.v_r,
            lockout: self.lockout,
            wait: self.wait,
            retransmit: self.retransmit,
            farm_b_counter: self.farm_b_counter & 0b11,
        }
    }

    /// Apply the window rules to a Type-AD frame with sequence number `ns`. `consumer_has_room`
    /// is asked only for an in-sequence frame, right before it would be accepted.
    pub fn on_ad(&mut self, ns: u8, consumer_has_room: impl FnOnce() -> bool) -> AdVerdict {
        if self.lockout {
            return AdVerdict::DiscardedInLockout;
        }
        let ahead = ns.wrapping_sub(self.v_r);
        let behind = self.v_r.wrapping_sub(ns);
        if ahead == 0 {
            if consumer_has_room() {
                self.v_r = self.v_r.wrapping_add(1);
                self.accepted_total = self.accepted_total.wrapping_add(1);
                self.retransmit = false;
                self.wait = false;
                AdVerdict::Accepted
            } else {
                self.wait = true;
                self.retransmit = true;
                AdVerdict::RefusedBusy
            }
        } else if ahead < FARM_POSITIVE_WINDOW {
            self.retransmit = true;
            AdVerdict::OutOfSequence
        } else if behind <= FARM_NEGATIVE_WINDOW {
            AdVerdict::Duplicate
        } else {
            self.lockout = true;
            AdVerdict::EnteredLockout
        }
    }

    /// A Type-BD frame was received (it only counts in the FARM-B counter).
    pub fn on_expedited(&mut self) {
        self.farm_b_counter = self.farm_b_counter.wrapping_add(1);
    }

    /// Execute an Unlock directive: lockout, wait and retransmit flags cleared; V(R) kept.
    pub fn on_unlock(&mut self) {
        self.farm_b_counter = self.farm_b_counter.wrapping_add(1);
        self.lockout = false;
        self.wait = false;
        self.retransmit = false;
    }

    /// Execute a Set V(R) directive. In lockout it is not executed (only counted), as in
    /// COP-1. Returns whether V(R) was set.
    pub fn on_set_vr(&mut self, vr: u8) -> bool {
        self.farm_b_counter = self.farm_b_counter.wrapping_add(1);
        if self.lockout {
            return false;
        }
        self.v_r = vr;
        self.wait = false;
        self.retransmit = false;
        true
    }

    /// The peer reported `sent_vs` as its V(S) for this channel at the end of its burst. If it
    /// is ahead of V(R) (within the positive window) frames are missing, typically the tail of
    /// the burst: set the retransmit flag. Returns whether frames are missing.
    pub fn on_peer_sent(&mut self, sent_vs: u8) -> bool {
        if self.lockout {
            return false;
        }
        let missing = sent_vs.wrapping_sub(self.v_r);
        if missing != 0 && missing < FARM_POSITIVE_WINDOW {
            self.retransmit = true;
            true
        } else {
            false
        }
    }
}
