//! Counters an endpoint keeps: per virtual channel for each direction, per message class, and
//! for the link as a whole. They only grow (saturating) and survive link resets, so a report
//! table covers the whole run.
use crate::link::class::MessageClass;
use crate::link::frame::VC_COUNT;

/// Add one to a counter without wrapping.
pub(crate) fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// Add `n` to a counter without wrapping.
pub(crate) fn add(counter: &mut u32, n: u32) {
    *counter = counter.saturating_add(n);
}

/// The sending side (FOP-1) of one virtual channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SendStats {
    /// Messages accepted by `submit`.
    pub submitted: u32,
    /// `submit` calls refused because neither window nor backlog had room.
    pub refused_full: u32,
    /// AD frames sent for the first time.
    pub first_transmissions: u32,
    /// AD frames sent again (go-back-N: every unacknowledged frame, in order).
    pub retransmissions: u32,
    /// Frames the peer acknowledged.
    pub acknowledged: u32,
    /// CLCWs whose N(R) was outside [NN(R), V(S)] (ignored).
    pub invalid_clcws: u32,
    /// Retransmissions started by the peer's retransmit flag.
    pub retransmit_requests: u32,
    /// Retransmissions started by T1 (a round ended with frames still unacknowledged and no
    /// request for them).
    pub t1_expiries: u32,
    /// CLCWs with the wait flag (the peer's consumer was full).
    pub peer_busy: u32,
    /// CLCWs reporting lockout.
    pub lockouts_reported: u32,
    /// Unlock directives sent (to end a lockout, or to open the channel).
    pub unlocks_sent: u32,
    /// Set V(R) directives sent (to open the channel).
    pub set_vr_sent: u32,
    /// Messages still unacknowledged (sent or waiting) when the link was reset. Some may have
    /// reached the peer before it reset; none is resent.
    pub lost_to_reset: u32,
}

impl SendStats {
    /// Every counter at zero.
    pub const ZERO: Self = Self {
        submitted: 0,
        refused_full: 0,
        first_transmissions: 0,
        retransmissions: 0,
        acknowledged: 0,
        invalid_clcws: 0,
        retransmit_requests: 0,
        t1_expiries: 0,
        peer_busy: 0,
        lockouts_reported: 0,
        unlocks_sent: 0,
        set_vr_sent: 0,
        lost_to_reset: 0,
    };
}

/// The receiving side (FARM-1) of one virtual channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReceiveStats {
    /// AD frames accepted and delivered.
    pub accepted: u32,
    /// AD frames in the negative window (already accepted), discarded.
    pub duplicates_discarded: u32,
    /// AD frames in the positive window (a frame before them missing), discarded.
    pub out_of_sequence_discarded: u32,
    /// In-sequence AD frames refused because the consumer was full.
    pub refused_busy: u32,
    /// Times the receiver entered lockout on an unexplainable N(S).
    pub lockouts_entered: u32,
    /// AD frames discarded while in lockout (including before the channel was opened).
    pub discarded_in_lockout: u32,
    /// Reports showing frames sent that never arrived (the lost tail of a burst).
    pub missing_tail_detected: u32,
    /// Unlock and Set V(R) directives executed.
    pub directives_executed: u32,
}

impl ReceiveStats {
    /// Every counter at zero.
    pub const ZERO: Self = Self {
        accepted: 0,
        duplicates_discarded: 0,
        out_of_sequence_discarded: 0,
        refused_busy: 0,
        lockouts_entered: 0,
        discarded_in_lockout: 0,
        missing_tail_detected: 0,
        directives_executed: 0,
    };
}

/// One message class, both directions as seen by this endpoint.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClassStats {
    /// Sent for the first time (AD or BD).
    pub sent: u32,
    /// AD retransmissions.
    pub retransmissions: u32,
    /// Received and delivered to the consumer (AD in order, or BD).
    pub delivered: u32,
    /// Unacknowledged when the link was reset.
    pub lost_to_reset: u32,
}

impl ClassStats {
    /// Every counter at zero.
    pub const ZERO: Self = Self {
        sent: 0,
        retransmissions: 0,
        delivered: 0,
        lost_to_reset: 0,
    };
}

/// Everything an endpoint counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Per outgoing VC, by [`crate::link::VirtualChannel::index`].
    pub sent: [SendStats; VC_COUNT],
    /// Per incoming VC.
    pub received: [ReceiveStats; VC_COUNT],
    /// Per message class, by [`MessageClass::index`].
    pub classes: [ClassStats; MessageClass::COUNT],
    /// Frames the decoder rejected (CRC, COBS, type, fields): the frame is unknown, so it is
    /// counted for the link, not for a channel.
    pub frames_rejected: u32,
    /// Peer Reports applied at their round's end.
    pub reports_applied: u32,
    /// Reports and directives discarded because their round was not the round that ended
    /// (delayed or duplicated from another round).
    pub stale_control_frames: u32,
    /// RoundEnd frames for a round this (initiating) endpoint is not waiting for.
    pub stale_round_ends: u32,
    /// Rounds that ended (peer RoundEnd frames accepted).
    pub rounds_ended: u32,
    /// BD frames sent and received.
    pub expedited_sent: u32,
    pub expedited_received: u32,
    /// Link resets (`Endpoint::reset`).
    pub resets: u32,
}

impl LinkStats {
    /// Every counter at zero.
    pub const ZERO: Self = Self {
        sent: [SendStats::ZERO; VC_COUNT],
        received: [ReceiveStats::ZERO; VC_COUNT],
        classes: [ClassStats::ZERO; MessageClass::COUNT],
        frames_rejected: 0,
        reports_applied: 0,
        stale_control_frames: 0,
        stale_round_ends: 0,
        rounds_ended: 0,
        expedited_sent: 0,
        expedited_received: 0,
        resets: 0,
    };

    /// The counters of `class`.
    pub fn class(&self, class: MessageClass) -> &ClassStats {
        &self.classes[class.index()]
    }

    pub(crate) fn class_mut(&mut self, class: MessageClass) -> &mut ClassStats {
        &mut self.classes[class.index()]
    }
}
