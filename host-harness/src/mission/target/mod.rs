//! Targets a mission runs on: the emulated RAD750 proxy ([`emulated`]: QEMU) and the native
//! target ([`native`]: the same flight application compiled into `hil`, no QEMU).
//!
//! The driver talks to a target in lockstep rounds of the reliable link
//! ([`super::link::LinkSession`]): it hands the target one burst of raw frames (with the link's
//! faults already applied, so that injected corruption reaches the target's own decoder) and
//! gets back the target's answering burst, up to the RoundEnd that closes it. Each target
//! decides by itself how a warm reset lands ([`MissionTarget::warm_reset`]).
use fsw_bridge::{MissionTimeUs, ResetCause, TargetToHost};

use crate::defmt_log::LogLine;
pub use crate::session::Hello;
use crate::session::SessionError;

pub mod emulated;
pub mod native;

pub use emulated::{EmulatedTarget, MidFrameReport};
pub use native::{CheckpointDamage, NativeTarget};

#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error("the target did not finish round {round} within {waited}: {detail}")]
    RoundTimeout {
        round: u32,
        waited: String,
        detail: String,
    },
    #[error("the target reported a panic at {file}:{line}")]
    Panic { file: String, line: u32 },
    #[error("{0}")]
    Other(String),
}

/// Where a warm reset the host asked for lands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetLanding {
    /// The target has reset, between frames: call [`MissionTarget::boot`].
    Now,
    /// The reset lands inside the next granted frame, on the target itself: that frame's
    /// exchange ends with the target's Hello instead of its FrameDone.
    InsideNextFrame,
}

/// A target the lockstep driver can fly a mission on.
pub trait MissionTarget {
    /// Human-readable description (for reports).
    fn describe(&self) -> String;
    /// True for the emulated target (costs are guest ticks), false for native.
    fn counts_cycles(&self) -> bool;
    /// Write `key` into the key slot of the target's non-volatile memory (before the first
    /// boot: the target reads its key at boot). The anti-replay counters stay as they are.
    fn provision_key(&mut self, key: &sdls::Key) -> Result<(), TargetError>;
    /// Start (first boot, or after a reset or power cycle) and return its Hello.
    fn boot(&mut self) -> Result<Hello, TargetError>;
    /// One lockstep round: put `wire` (whole frames, faults applied) on the link and return
    /// every frame the target sent, undamaged, up to and including its RoundEnd for `round`,
    /// or up to and including its Hello if it reset during the round.
    fn round(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError>;
    /// A warm reset (RAM kept) is due at mission time `at`, between frames. The target
    /// chooses where it lands: at once (QMP), inside the next frame (an armed mid-frame reset
    /// on the emulated target), with a torn checkpoint (an armed mid-frame reset natively).
    fn warm_reset(&mut self, at: MissionTimeUs) -> Result<ResetLanding, TargetError>;
    /// Power cycle (RAM lost, non-volatile memory kept). Call `boot` afterwards.
    fn power_cycle(&mut self) -> Result<(), TargetError>;
    /// A message the link delivered: the target may learn from it (the emulated target keeps
    /// the last frame's cost to draw a mid-frame reset point, and decodes log bytes).
    fn observe(&mut self, msg: &TargetToHost) {
        let _ = msg;
    }
    /// Log lines decoded so far (drained).
    fn take_logs(&mut self) -> Vec<LogLine>;
    /// Campaigns: make the next warm reset land in the middle of a frame, at a point drawn
    /// from `seed` (see each target for what that means on it).
    fn arm_mid_frame_reset(&mut self, seed: u64);
    /// What the resets armed with `arm_mid_frame_reset` did, in order.
    fn reset_notes(&self) -> Vec<String>;
}

/// The Hello a target sent, as a message (for the transcript and the link).
pub fn hello_message(h: &Hello) -> TargetToHost {
    TargetToHost::Hello {
        protocol_version: fsw_bridge::PROTOCOL_VERSION,
        build_id: h.build_id,
        reset_cause: h.reset_cause,
        boot_count: h.boot_count,
        kernel_fault: h.kernel_fault,
    }
}

/// A Hello message back as the session's [`Hello`].
pub fn hello_of(msg: &TargetToHost) -> Option<Hello> {
    match *msg {
        TargetToHost::Hello {
            build_id,
            reset_cause,
            boot_count,
            kernel_fault,
            ..
        } => Some(Hello {
            build_id,
            reset_cause,
            boot_count,
            kernel_fault,
        }),
        _ => None,
    }
}

/// Name of a reset cause (re-exported for the targets' logs).
pub fn cause(c: ResetCause) -> &'static str {
    crate::scenario::cause_name(c)
}
