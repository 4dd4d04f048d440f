//! Plain data types shared by the target, the host and the autonomy core.
//!
//! Time is always an integer with its unit in the name: mission time in microseconds
//! ([`MissionTimeUs`]), guest CPU time in timebase ticks ([`Ticks`]).
use serde::{Deserialize, Serialize};

/// Mission time in microseconds since the scenario's epoch.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct MissionTimeUs(pub u64);

impl MissionTimeUs {
    pub const ZERO: Self = Self(0);
    pub const MAX: Self = Self(u64::MAX);

    pub const fn from_secs(secs: u64) -> Self {
        Self(secs * 1_000_000)
    }

    pub const fn from_mins(mins: u64) -> Self {
        Self(mins * 60_000_000)
    }

    pub const fn saturating_add(self, us: u64) -> Self {
        Self(self.0.saturating_add(us))
    }
}

/// Guest CPU time in timebase ticks (16.6 MHz on g3beige; under `-icount shift=2` one
/// instruction is 4 ns of virtual time).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Ticks(pub u64);

/// Identifies one entry of the spacecraft state buffer (attitude, battery energy, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct StateKey(pub u16);

/// A state-buffer value. Enumerated states (attitude NADIR, TURNING, ...) are small codes
/// whose names live in the task network; quantities are integers in the unit of their key.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum StateValue {
    /// The owner of this state cannot vouch for it (for example attitude after a reset).
    Unknown,
    Bool(bool),
    Enum(u16),
    Int(i64),
}

/// Command opcode understood by a simulated (or real) subsystem.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Opcode(pub u16);

/// Most arguments one command carries.
pub const MAX_COMMAND_ARGS: usize = 4;

/// Arguments of a dispatched command.
pub type CommandArgs = heapless::Vec<i32, MAX_COMMAND_ARGS>;

/// Outcome of a dispatched command, as reported by the subsystem.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CommandStatus {
    /// Completed as commanded.
    Ok,
    /// The subsystem tried and failed; the code is subsystem-specific.
    Failed(u16),
    /// The subsystem refused the command (bad arguments, wrong mode).
    Rejected,
}

/// Why the target (re)started. Reported in every Hello.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ResetCause {
    /// RAM contents were not trusted: first boot of this QEMU process or of the board.
    PowerOn,
    /// A reset with RAM kept, requested from outside (QMP `system_reset`, the host's
    /// ResetRequest, a reset line).
    Warm,
    /// The kernel's watchdog expired.
    Watchdog,
    /// The health monitor (or a panic) decided to reset the module.
    HealthMonitor,
    /// An exception inside the kernel itself (supervisor code outside a partition): the kernel
    /// recorded it ([`KernelFault`], in the Hello) and reset the module, RAM kept.
    KernelFault,
}

/// A fault inside the kernel itself, recorded in the warm-restart area before the warm reset it
/// caused and reported in the next boot's Hello.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct KernelFault {
    /// The exception vector offset (0x300 DSI, 0x400 ISI, 0x600 alignment, 0x700 program ...).
    pub vector: u32,
    /// Where it happened (SRR0: the faulting instruction, or the next one for some vectors).
    pub pc: u32,
    /// The data address of a DSI or alignment fault (DAR; 0 for other vectors).
    pub dar: u32,
}

/// How the host asks the target to reset itself. New kinds are appended at the end (postcard
/// encodes the variant index).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ResetKind {
    /// Restart from the reset vector, RAM kept (warm-restart area survives), now.
    Warm,
    /// A warm reset in the middle of the next granted frame: once the executive partition has
    /// run `ticks` timebase ticks of CPU from its receipt of the next TimeGrant (its work on that
    /// frame: the autonomy step, the checkpoint encoding, the warm-area copy, its messages). If
    /// it finishes that work first, the reset happens when it does (before its FrameDone leaves
    /// the target). Send it before the grant it applies to; the target answers with a Hello.
    WarmAfterTicks { ticks: u32 },
    /// A warm reset in the middle of the executive's copy of the next granted frame's checkpoint
    /// into the warm-restart area, after `permille`/1000 of its bytes (so the newest slot is
    /// torn). If the executive finishes that frame without writing a checkpoint, the reset
    /// happens when it finishes.
    WarmDuringCheckpointWrite { permille: u16 },
    /// As `WarmAfterTicks`, in the planner partition's work on the next granted frame: once
    /// it has run `ticks` ticks of CPU from its receipt of the executive's first message of
    /// that frame (its planning, its checkpoint, its messages). If it finishes first, the
    /// reset happens when it does.
    PlannerAfterTicks { ticks: u32 },
    /// As `WarmDuringCheckpointWrite`, in the planner partition's copy of its checkpoint of
    /// the next granted frame into its slice of the warm-restart area.
    PlannerDuringCheckpointWrite { permille: u16 },
}

impl ResetKind {
    /// The point is in the planner partition's work (else the executive's, for the mid-frame
    /// kinds).
    pub const fn in_planner(self) -> bool {
        matches!(
            self,
            ResetKind::PlannerAfterTicks { .. } | ResetKind::PlannerDuringCheckpointWrite { .. }
        )
    }
}
