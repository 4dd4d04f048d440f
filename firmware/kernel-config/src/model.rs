//! The configuration's vocabulary: memory regions and their access, error kinds and the
//! health-monitor actions taken on them, warm-area slices and capabilities, partitions, the
//! major frame's windows, ports, and the [`SystemConfig`] that holds them all.

use crate::{WARM_AREA_SIZE, WARM_BOOT_RECORD_SIZE};

/// What a partition may do with a region (the kernel always may do anything).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Partition data: statics, stack, state. Not executable (no IBAT).
    ReadWrite,
    /// Constant data the partition may read but not change.
    ReadOnly,
    /// Device registers: read/write, cache-inhibited and guarded.
    Device,
}

/// One contiguous block of the physical address space, mapped 1:1 by one BAT.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub base: u32,
    pub size: u32,
    pub access: Access,
}

impl Region {
    pub const fn end(&self) -> u64 {
        self.base as u64 + self.size as u64
    }

    pub const fn overlaps(&self, other: &Region) -> bool {
        (self.base as u64) < other.end() && (other.base as u64) < self.end()
    }

    /// True if `[addr, addr + len)` lies entirely inside this region.
    pub const fn contains(&self, addr: u32, len: u32) -> bool {
        let end = addr as u64 + len as u64;
        addr >= self.base && end <= self.end()
    }
}

/// Error kinds the health monitor distinguishes. The numeric value is the `kind` field of
/// `TelemetryEvent::HealthMonitor`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum ErrorKind {
    /// Data storage interrupt (0x300): a load or store outside the partition's regions or
    /// against their access rights.
    DataStorage = 1,
    /// Instruction storage interrupt (0x400): execution outside the shared code.
    InstructionStorage = 2,
    /// Alignment interrupt (0x600).
    Alignment = 3,
    /// Program interrupt (0x700): illegal or privileged instruction, trap.
    Program = 4,
    /// Floating-point unavailable (0x800): partitions run with MSR[FP]=0.
    FloatingPointUnavailable = 5,
    /// A system call with an unknown number, a bad pointer or length, a port the partition does
    /// not own, or a service it is not allowed. The call also returns an error code.
    IllegalSyscall = 6,
    /// The partition's code panicked.
    Panic = 7,
    /// The partition was still running when its window ended (it is preempted either way; this
    /// is the cycle throttle).
    Overrun = 8,
    /// Any other exception taken in the partition.
    OtherException = 9,
}

impl ErrorKind {
    pub const COUNT: usize = 9;
    pub const ALL: [ErrorKind; Self::COUNT] = [
        ErrorKind::DataStorage,
        ErrorKind::InstructionStorage,
        ErrorKind::Alignment,
        ErrorKind::Program,
        ErrorKind::FloatingPointUnavailable,
        ErrorKind::IllegalSyscall,
        ErrorKind::Panic,
        ErrorKind::Overrun,
        ErrorKind::OtherException,
    ];

    pub const fn index(self) -> usize {
        self as usize - 1
    }

    pub const fn name(self) -> &'static str {
        match self {
            ErrorKind::DataStorage => "data-storage",
            ErrorKind::InstructionStorage => "instruction-storage",
            ErrorKind::Alignment => "alignment",
            ErrorKind::Program => "program",
            ErrorKind::FloatingPointUnavailable => "fp-unavailable",
            ErrorKind::IllegalSyscall => "illegal-syscall",
            ErrorKind::Panic => "panic",
            ErrorKind::Overrun => "overrun",
            ErrorKind::OtherException => "other-exception",
        }
    }

    /// The kind for an exception vector taken while a partition ran.
    pub const fn from_vector(vector: u32) -> ErrorKind {
        match vector {
            0x300 => ErrorKind::DataStorage,
            0x400 => ErrorKind::InstructionStorage,
            0x600 => ErrorKind::Alignment,
            0x700 => ErrorKind::Program,
            0x800 => ErrorKind::FloatingPointUnavailable,
            _ => ErrorKind::OtherException,
        }
    }
}

/// Health-monitor actions (XtratuM names). The numeric value is the `action` field of
/// `TelemetryEvent::HealthMonitor`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum HmAction {
    /// Report and continue: a bad system call returns its error code; an exception resumes
    /// after the faulting instruction; an overrun is only counted. Not allowed for panics and
    /// instruction-storage faults, which cannot be continued.
    Log = 0,
    /// Stop the partition: it never runs again until the module is reset; its windows idle.
    HaltPartition = 1,
    /// Cold-restart the partition: statics and stack zeroed, entry called again, generation
    /// number incremented (messages it sent before carry the old generation).
    RestartPartition = 2,
    /// Warm-reset the whole module (reset cause HealthMonitor in the next Hello).
    WarmReset = 3,
}

impl HmAction {
    pub const fn name(self) -> &'static str {
        match self {
            HmAction::Log => "log",
            HmAction::HaltPartition => "halt partition",
            HmAction::RestartPartition => "restart partition",
            HmAction::WarmReset => "warm reset",
        }
    }
}

/// Partition number used in health-monitor reports for the kernel itself.
pub const KERNEL_PARTITION_ID: u8 = 0xff;

/// The action for each error kind, indexed by [`ErrorKind::index`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HealthTable(pub [HmAction; ErrorKind::COUNT]);

impl HealthTable {
    /// Restart on every fault, count overruns only.
    pub const RESTART_ON_FAULT: HealthTable = HealthTable([
        HmAction::RestartPartition,
        HmAction::RestartPartition,
        HmAction::RestartPartition,
        HmAction::RestartPartition,
        HmAction::RestartPartition,
        HmAction::RestartPartition,
        HmAction::RestartPartition,
        HmAction::Log,
        HmAction::RestartPartition,
    ]);

    pub const fn action(&self, kind: ErrorKind) -> HmAction {
        self.0[kind.index()]
    }

    /// The same table with one kind's action replaced.
    pub const fn with(self, kind: ErrorKind, action: HmAction) -> HealthTable {
        let mut table = self.0;
        table[kind.index()] = action;
        HealthTable(table)
    }
}

/// The part of a persistent memory one partition owns: bytes `offset..offset + len` of the
/// warm-restart area's checkpoint part (after the boot record) or of the non-volatile memory.
/// The partition's system calls count offsets from the start of its slice, and cannot reach
/// past its end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slice {
    pub offset: u32,
    pub len: u32,
}

impl Slice {
    /// One past the last byte (saturated).
    pub const fn end(&self) -> u32 {
        self.offset.saturating_add(self.len)
    }

    /// Whether the two share a byte.
    pub const fn overlaps(&self, other: &Slice) -> bool {
        self.offset < other.end() && other.offset < self.end()
    }
}

/// Bytes of the warm-restart area's checkpoint part (after the boot record) that partitions
/// can own.
pub const WARM_CHECKPOINT_PART: u32 = WARM_AREA_SIZE - WARM_BOOT_RECORD_SIZE;

/// Services beyond the common system calls, granted per partition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// Owns the link: drains the kernel's log and events, reads boot information, sets mission
    /// time, requests a module reset. Exactly one partition has it.
    pub link_owner: bool,
    /// Its slice of the warm-restart area's checkpoint part, if it may read and write one.
    /// Slices do not overlap.
    pub warm_area: Option<Slice>,
    /// Its slice of the non-volatile memory (survives a power cycle), if any. Slices do not
    /// overlap.
    pub nv_memory: Option<Slice>,
}

impl Capabilities {
    pub const NONE: Capabilities = Capabilities {
        link_owner: false,
        warm_area: None,
        nv_memory: None,
    };
}

/// One partition.
#[derive(Clone, Copy, Debug)]
pub struct Partition {
    /// Short name, used in messages, section names (`.bss.part.<name>`) and linker symbols.
    pub name: &'static str,
    /// Symbol of the entry function (`extern "C" fn() -> !`), called in problem state on the
    /// partition's stack at every (re)start.
    pub entry: &'static str,
    /// Its memory. The first region must be ReadWrite: it holds the header, the partition's
    /// statics (`.bss.part.<name>`) and its stack.
    pub regions: &'static [Region],
    /// Stack bytes (multiple of 16).
    pub stack_size: u32,
    pub capabilities: Capabilities,
    pub health: HealthTable,
}

/// One window of the major frame.
#[derive(Clone, Copy, Debug)]
pub struct Window {
    /// Index into [`SystemConfig::partitions`].
    pub partition: usize,
    /// Ticks from the start of the major frame.
    pub offset: u32,
    /// Ticks.
    pub duration: u32,
}

impl Window {
    pub const fn end(&self) -> u64 {
        self.offset as u64 + self.duration as u64
    }
}

/// The cyclic schedule.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    /// Length of the major frame in timebase ticks.
    pub major_frame: u32,
    /// Windows in increasing offset order; gaps between them are idle time.
    pub windows: &'static [Window],
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PortKind {
    /// Latest value wins; readers see it with its age. Depth must be 1.
    Sampling,
    /// FIFO of `depth` messages; exactly one destination.
    Queuing,
}

/// A channel between partitions; the kernel copies messages in and out.
#[derive(Clone, Copy, Debug)]
pub struct Port {
    pub name: &'static str,
    pub kind: PortKind,
    /// Largest message in bytes.
    pub message_size: u32,
    /// Messages held (1 for sampling ports).
    pub depth: u32,
    /// Partition index that may send.
    pub source: usize,
    /// Partition indices that may receive.
    pub destinations: &'static [usize],
}

/// The whole static configuration.
#[derive(Clone, Copy, Debug)]
pub struct SystemConfig {
    pub partitions: &'static [Partition],
    pub schedule: Schedule,
    pub ports: &'static [Port],
}
