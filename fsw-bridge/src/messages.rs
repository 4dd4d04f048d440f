//! The message set ([`crate::PROTOCOL_VERSION`]), one enum per direction so that neither side
//! can be handed a message meant for the other.
//!
//! Every capacity is a named constant; every message fits in one frame
//! ([`crate::codec::MAX_PAYLOAD_LEN`]), which the codec tests check for the largest instance of
//! each variant.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::lander::{LanderChunkBytes, LanderInput, LanderObservation, LanderReport};
use crate::security::{CommandRefusal, GroundCommand, SecurityHeader, MAC_LEN};
use crate::temporal::{RoverEvent, TemporalChunkBytes, TemporalConfig, TemporalReport};
use crate::types::{
    CommandArgs, CommandStatus, KernelFault, MissionTimeUs, Opcode, ResetCause, ResetKind,
    StateKey, StateValue,
};

/// Bytes of defmt-encoded log data carried by one Log frame.
pub const LOG_CHUNK_MAX: usize = 96;
/// Bytes of task-network uplink carried by one UplinkChunk frame.
pub const UPLINK_CHUNK_MAX: usize = 128;
/// Bytes of source path kept in a Panic report (the tail of the path is kept).
pub const PANIC_FILE_MAX: usize = 64;
/// Length of the firmware build identifier (a hash of the image, set at build time).
pub const BUILD_ID_LEN: usize = 8;

/// Counters kept by a frame decoder; the target reports its own in every Pong.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LinkCounters {
    /// Frames decoded and accepted.
    pub frames_ok: u32,
    /// Frames whose CRC-32 did not match.
    pub crc_errors: u32,
    /// Byte runs longer than the largest frame before a delimiter.
    pub oversize: u32,
    /// Frames with a valid CRC but a message type this side does not know.
    pub unknown_type: u32,
    /// Frames too short to hold a CRC, bad COBS, or a payload that ended early.
    pub truncated: u32,
    /// Frames with a valid CRC and type whose fields did not decode (bad field value, trailing
    /// bytes).
    pub malformed: u32,
}

impl LinkCounters {
    /// Every rejected frame, whatever the reason.
    pub fn errors(&self) -> u32 {
        self.crc_errors
            .saturating_add(self.oversize)
            .saturating_add(self.unknown_type)
            .saturating_add(self.truncated)
            .saturating_add(self.malformed)
    }
}

/// Messages the host (harness, simulated spacecraft, ground) sends to the target.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum HostToTarget {
    /// Liveness probe; the target answers Pong with the same sequence number.
    Ping { seq: u32 },
    /// Lockstep time driver: the target may run its schedule up to mission time `until`,
    /// then reports FrameDone for `frame`.
    TimeGrant {
        frame: u32,
        now: MissionTimeUs,
        until: MissionTimeUs,
    },
    /// A state-buffer entry changed (published by a simulated or real subsystem).
    StateUpdate {
        key: StateKey,
        value: StateValue,
        timestamp: MissionTimeUs,
    },
    /// Reply to a CommandDispatch with the same `id`.
    CommandResponse {
        id: u32,
        status: CommandStatus,
        data: Option<i64>,
    },
    /// One piece of a binary task-network uplink; `seq` counts from 0 to `total - 1`.
    UplinkChunk {
        seq: u16,
        total: u16,
        bytes: Vec<u8, UPLINK_CHUNK_MAX>,
    },
    /// Ask the target to reset itself.
    ResetRequest { kind: ResetKind },
    /// A command from the ground, authenticated in the manner of CCSDS SDLS: security header,
    /// command, security trailer (HMAC-SHA-256 over the header and the command, see
    /// `sdls::command_mac`). The target answers GroundCommandAck or GroundCommandNak with the
    /// header's sequence number. A `mac` shorter than [`MAC_LEN`] is refused as truncated.
    GroundCommand {
        header: SecurityHeader,
        command: GroundCommand,
        mac: Vec<u8, MAC_LEN>,
    },
    /// A temporal planning job for the planner partition ([`crate::temporal`]): `len` bytes of
    /// secured task (`sdls::temporal`) with CRC-32 `crc32` follow in TemporalChunks. A new
    /// Begin abandons a job still being received; one while a job plans is refused (`Busy`).
    TemporalBegin {
        job: u16,
        len: u32,
        crc32: u32,
        config: TemporalConfig,
    },
    /// The task's bytes at `offset` (chunks in order, each at the end of the one before).
    TemporalChunk {
        job: u16,
        offset: u32,
        bytes: TemporalChunkBytes,
    },
    /// A setup of the lander's executor for the planner partition ([`crate::lander`]): `len`
    /// bytes with CRC-32 `crc32` follow in LanderChunks. A new Begin ends the executor in force.
    LanderBegin { setup: u16, len: u32, crc32: u32 },
    /// The setup's bytes at `offset` (chunks in order, each at the end of the one before).
    LanderChunk {
        setup: u16,
        offset: u32,
        bytes: LanderChunkBytes,
    },
    /// Step `seq` (from 0 per setup) of the lander's executor.
    LanderStep {
        setup: u16,
        seq: u32,
        observation: LanderObservation,
    },
    /// (Appended.) A link or data input of the lander's executor for setup `setup`, applied
    /// before the next step.
    LanderInput { setup: u16, input: LanderInput },
    /// (Appended.) An event of the onboard rover mission flying temporal job `job`'s task
    /// ([`crate::temporal::RoverEvent`]); `Start` names the job before it is uplinked.
    Rover { job: u16, event: RoverEvent },
}

/// Messages the target sends to the host (in protocol v2 inside the reliable link's frames,
/// [`crate::link::LinkFrame`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TargetToHost {
    /// Sent once on every boot, before anything else.
    Hello {
        protocol_version: u16,
        build_id: [u8; BUILD_ID_LEN],
        reset_cause: ResetCause,
        /// Boots since the warm-restart area was last initialised (power-on counts as 1).
        boot_count: u32,
        /// The kernel fault that caused this reset (reset cause KernelFault), as the kernel
        /// recorded it; None for every other cause. Added in protocol v3.
        kernel_fault: Option<KernelFault>,
    },
    /// Answer to Ping, with the target's decoder counters.
    Pong { seq: u32, link: LinkCounters },
    /// The target finished the frame granted by TimeGrant `frame`. `next_wakeup` is the earliest
    /// mission time at which it needs to run again (None: only when input arrives).
    ///
    /// It carries no measured cost (the frame's guest ticks go out as an Instrument metric,
    /// `flight_app::metric::FRAME_BUSY_TICKS`): the Mission stream is the same on the native
    /// and the emulated target, byte for byte.
    FrameDone {
        frame: u32,
        next_wakeup: Option<MissionTimeUs>,
    },
    /// The executive asks a subsystem to carry out a command.
    CommandDispatch {
        id: u32,
        opcode: Opcode,
        args: CommandArgs,
    },
    /// defmt-encoded log bytes, decoded on the host against the firmware ELF.
    Log { bytes: Vec<u8, LOG_CHUNK_MAX> },
    /// Something the autonomy or the kernel did.
    Telemetry(TelemetryEvent),
    /// Uplink chunk `seq` was stored.
    UplinkAck { seq: u16 },
    /// Uplink chunk `seq` (or the whole uplink) was refused; `reason` is a validation code.
    UplinkNak { seq: u16, reason: u16 },
    /// The target panicked at `file:line`; it resets itself (cause HealthMonitor) right after.
    Panic {
        file: Vec<u8, PANIC_FILE_MAX>,
        line: u32,
    },
    /// The ground command with this sequence number was authentic and fresh, its sequence
    /// number is stored, and it was carried out.
    GroundCommandAck { sequence: u32 },
    /// The ground command with this sequence number was refused, and why. A security refusal
    /// leaves everything as it was (counter included); any other was authentic, so its sequence
    /// number is spent.
    GroundCommandNak {
        sequence: u32,
        reason: CommandRefusal,
    },
    /// What the planner partition says about a temporal planning job.
    Temporal(TemporalReport),
    /// What the planner partition says about the lander's executor.
    Lander(LanderReport),
}

/// Events reported as telemetry. New kinds are appended at the end (postcard encodes the
/// variant index), and a change that is not append-only bumps the protocol version.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TelemetryEvent {
    /// A task of the executive changed state (codes defined by the autonomy core).
    TaskTransition {
        task: u16,
        from: u8,
        to: u8,
        at: MissionTimeUs,
    },
    /// The planner modified the plan (kind codes defined by the autonomy core).
    PlanModification {
        kind: u8,
        task: u16,
        template: u16,
        at: MissionTimeUs,
    },
    /// The kernel's health monitor handled an error. `address`: the faulting data or
    /// instruction address (0 for an overrun: where a window ended is not reproducible).
    HealthMonitor {
        partition: u8,
        kind: u8,
        address: u32,
        action: u8,
    },
    /// A named measurement (ids defined by the firmware; values in the unit the id names).
    Metric { id: u16, value: u64 },
    /// The autonomy found the state-buffer value of `key`, measured at `measured_at`, older
    /// than its timeline's staleness bound at the step at mission time `at` (the first step at
    /// or after `measured_at + bound + 1 µs`): from then on it reads the value as unknown,
    /// until a newer measurement of `key` arrives. Reported once per measurement.
    StateStale {
        key: StateKey,
        measured_at: MissionTimeUs,
        at: MissionTimeUs,
    },
}
