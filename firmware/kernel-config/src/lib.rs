//! The static configuration of the partitioning kernel, in the ARINC 653 / XtratuM vocabulary:
//! partitions with their memory regions and stacks, the major frame and its windows (timebase
//! ticks), inter-partition ports, and the health-monitor action per partition and error kind.
//!
//! Nothing is discovered at run time. The configurations the image runs are [`system::PRODUCT`] and, in the test image,
//! [`system::TEST`];
//! [`check`] validates any configuration and is a `const fn`, so the image evaluates it in a
//! `const` item and a bad configuration is a compile error whose message names the offending
//! entry (see [`ConfigError::describe`]). The firmware's `build.rs` generates the partition part
//! of the linker script from the same description, so the memory map agrees by construction.
//!
//! This crate is `no_std` and also a member of the host workspace, where the checker is
//! unit-tested on good and bad configurations.
#![no_std]

pub mod abi;
pub mod message;
pub mod system;

pub use message::Message;

/// Timebase ticks per second on QEMU's g3beige (16.6 MHz).
pub const TIMEBASE_HZ: u32 = 16_600_000;

/// Most partitions a configuration may have (sizes the kernel's tables).
pub const MAX_PARTITIONS: usize = 8;
/// Most windows in a major frame.
pub const MAX_WINDOWS: usize = 16;
/// Most ports.
pub const MAX_PORTS: usize = 16;
/// Largest message a port may carry, in bytes.
pub const MAX_PORT_MESSAGE: u32 = 256;
/// Deepest queuing port.
pub const MAX_PORT_DEPTH: u32 = 16;
/// Most destinations of one sampling port.
pub const MAX_DESTINATIONS: usize = 4;
/// Memory regions per partition: the 750 has four data BATs and the kernel keeps DBAT0 for the
/// shared, read-only code and constants, which leaves three.
pub const MAX_REGIONS: usize = 3;

/// Smallest BAT block on the 750 (128 KiB); regions are power-of-two multiples of it.
pub const BAT_MIN_BLOCK: u32 = 0x2_0000;
/// Largest BAT block (256 MiB).
pub const BAT_MAX_BLOCK: u32 = 0x1000_0000;

/// Kernel text, rodata and the read-only shared page: mapped read/execute-only into every
/// partition (libcore, postcard and the partitions' own code live here).
pub const SHARED_CODE_BASE: u32 = 0x0000_0000;
pub const SHARED_CODE_SIZE: u32 = 0x0008_0000;
/// Kernel data, bss and stack: never mapped for partitions.
pub const KERNEL_DATA_BASE: u32 = 0x0008_0000;
pub const KERNEL_DATA_SIZE: u32 = 0x0008_0000;
/// Warm-restart area (survives a warm reset); reached by partitions only through system calls.
pub const WARM_AREA_BASE: u32 = 0x0010_0000;
pub const WARM_AREA_SIZE: u32 = 0x0001_0000;
/// Bytes at the start of the warm area that hold the kernel's boot record and, after it, the
/// reset stub's image record.
pub const WARM_BOOT_RECORD_SIZE: u32 = 64;
/// Offset in the warm area of the reset stub's image record (the ROM build id, length and
/// checksum of the RAM image it last copied; see the firmware's `boot.rs`).
pub const WARM_IMAGE_RECORD_OFFSET: u32 = 32;
/// Where the kernel maps the non-volatile memory device (QEMU `ivshmem-plain` backed by a file
/// that outlives the process: a power cycle keeps it), when the board has one.
pub const NV_BASE: u32 = 0x9000_0000;
/// Largest part of the non-volatile device the kernel offers to its owner partition.
pub const NV_MAX_BYTES: u32 = 0x0010_0000;
/// Where the kernel maps the shared-memory link device (a second QEMU `ivshmem-plain`, see
/// `kernel_logic::shm_link`), when the board has one: far above any non-volatile memory.
pub const LINK_SHM_BASE: u32 = 0x9800_0000;
/// Hashed page table (64 KiB, all invalid: every translation outside a BAT faults).
pub const HTAB_BASE: u32 = 0x0011_0000;
pub const HTAB_SIZE: u32 = 0x0001_0000;
/// Partition RAM regions live in [PARTITION_RAM_BASE, RAM_END).
pub const PARTITION_RAM_BASE: u32 = 0x0020_0000;
/// End of the RAM the QEMU profile gives the machine (128 MiB).
pub const RAM_END: u32 = 0x0800_0000;
/// Device (MMIO) regions must lie at or above this address.
pub const DEVICE_SPACE_BASE: u32 = 0x8000_0000;
/// Bytes at the start of each partition's first region reserved for its run-time header
/// (its defmt logger state); zeroed with the partition's statics at every (re)start.
pub const PARTITION_HEADER_SIZE: u32 = 1024;

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

/// What is wrong with a configuration; indices refer to the offending entries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    NoPartitions,
    TooManyPartitions,
    PartitionWithoutRegions {
        partition: usize,
    },
    TooManyRegions {
        partition: usize,
    },
    FirstRegionNotReadWrite {
        partition: usize,
    },
    RegionSizeNotBatBlock {
        partition: usize,
        region: usize,
    },
    RegionMisaligned {
        partition: usize,
        region: usize,
    },
    RegionOutsidePartitionRam {
        partition: usize,
        region: usize,
    },
    DeviceRegionInRam {
        partition: usize,
        region: usize,
    },
    DeviceRegionWithoutLinkOwner {
        partition: usize,
        region: usize,
    },
    RegionsOverlap {
        a: (usize, usize),
        b: (usize, usize),
    },
    BadStackSize {
        partition: usize,
    },
    StackDoesNotFit {
        partition: usize,
    },
    LinkOwnerCount {
        count: usize,
    },
    /// Two partitions' slices of the warm-restart area overlap.
    WarmAreaOwners,
    /// Two partitions' slices of the non-volatile memory overlap.
    NvMemoryOwners,
    /// A partition's slice is empty or reaches past its memory.
    SliceOutOfRange {
        partition: usize,
    },
    ContinueNotPossible {
        partition: usize,
        kind: ErrorKind,
    },
    EmptyMajorFrame,
    NoWindows,
    TooManyWindows,
    WindowUnknownPartition {
        window: usize,
    },
    WindowEmpty {
        window: usize,
    },
    WindowBeyondMajorFrame {
        window: usize,
    },
    WindowsOutOfOrder {
        window: usize,
        previous: usize,
    },
    WindowsOverlap {
        window: usize,
        previous: usize,
    },
    PartitionWithoutWindow {
        partition: usize,
    },
    TooManyPorts,
    PortUnknownSource {
        port: usize,
    },
    PortWithoutDestination {
        port: usize,
    },
    PortUnknownDestination {
        port: usize,
        destination: usize,
    },
    PortToItself {
        port: usize,
    },
    /// Two ports share a name (partitions find their ports by name).
    PortDuplicateName {
        port: usize,
    },
    PortBadSize {
        port: usize,
    },
    PortBadDepth {
        port: usize,
    },
    QueuingPortDestinations {
        port: usize,
    },
}

/// Check a configuration. `const`, so the image runs it at compile time.
pub const fn check(config: &SystemConfig) -> Result<(), ConfigError> {
    let parts = config.partitions;
    if parts.is_empty() {
        return Err(ConfigError::NoPartitions);
    }
    if parts.len() > MAX_PARTITIONS {
        return Err(ConfigError::TooManyPartitions);
    }
    let mut link_owners = 0;
    let mut p = 0;
    while p < parts.len() {
        let part = &parts[p];
        let regions = part.regions;
        if regions.is_empty() {
            return Err(ConfigError::PartitionWithoutRegions { partition: p });
        }
        if regions.len() > MAX_REGIONS {
            return Err(ConfigError::TooManyRegions { partition: p });
        }
        if !matches!(regions[0].access, Access::ReadWrite) {
            return Err(ConfigError::FirstRegionNotReadWrite { partition: p });
        }
        let mut r = 0;
        while r < regions.len() {
            let region = &regions[r];
            let size = region.size;
            if size < BAT_MIN_BLOCK || size > BAT_MAX_BLOCK || !size.is_power_of_two() {
                return Err(ConfigError::RegionSizeNotBatBlock {
                    partition: p,
                    region: r,
                });
            }
            if region.base & (size - 1) != 0 {
                return Err(ConfigError::RegionMisaligned {
                    partition: p,
                    region: r,
                });
            }
            match region.access {
                Access::Device => {
                    if (region.base as u64) < DEVICE_SPACE_BASE as u64 {
                        return Err(ConfigError::DeviceRegionInRam {
                            partition: p,
                            region: r,
                        });
                    }
                    if !part.capabilities.link_owner {
                        return Err(ConfigError::DeviceRegionWithoutLinkOwner {
                            partition: p,
                            region: r,
                        });
                    }
                }
                Access::ReadWrite | Access::ReadOnly => {
                    if region.base < PARTITION_RAM_BASE || region.end() > RAM_END as u64 {
                        return Err(ConfigError::RegionOutsidePartitionRam {
                            partition: p,
                            region: r,
                        });
                    }
                }
            }
            // Against every region declared before this one (any partition).
            let mut q = 0;
            while q <= p {
                let other = parts[q].regions;
                let limit = if q == p { r } else { other.len() };
                let mut s = 0;
                while s < limit {
                    if region.overlaps(&other[s]) {
                        return Err(ConfigError::RegionsOverlap {
                            a: (p, r),
                            b: (q, s),
                        });
                    }
                    s += 1;
                }
                q += 1;
            }
            r += 1;
        }
        if part.stack_size == 0 || !part.stack_size.is_multiple_of(16) {
            return Err(ConfigError::BadStackSize { partition: p });
        }
        if PARTITION_HEADER_SIZE as u64 + part.stack_size as u64 > regions[0].size as u64 {
            return Err(ConfigError::StackDoesNotFit { partition: p });
        }
        if part.capabilities.link_owner {
            link_owners += 1;
        }
        if let Some(slice) = part.capabilities.warm_area {
            if slice.len == 0 || slice.end() > WARM_CHECKPOINT_PART {
                return Err(ConfigError::SliceOutOfRange { partition: p });
            }
        }
        if let Some(slice) = part.capabilities.nv_memory {
            if slice.len == 0 || slice.end() > NV_MAX_BYTES {
                return Err(ConfigError::SliceOutOfRange { partition: p });
            }
        }
        let mut q = 0;
        while q < p {
            let other = &parts[q].capabilities;
            if let (Some(a), Some(b)) = (part.capabilities.warm_area, other.warm_area) {
                if a.overlaps(&b) {
                    return Err(ConfigError::WarmAreaOwners);
                }
            }
            if let (Some(a), Some(b)) = (part.capabilities.nv_memory, other.nv_memory) {
                if a.overlaps(&b) {
                    return Err(ConfigError::NvMemoryOwners);
                }
            }
            q += 1;
        }
        if matches!(part.health.action(ErrorKind::Panic), HmAction::Log) {
            return Err(ConfigError::ContinueNotPossible {
                partition: p,
                kind: ErrorKind::Panic,
            });
        }
        if matches!(
            part.health.action(ErrorKind::InstructionStorage),
            HmAction::Log
        ) {
            return Err(ConfigError::ContinueNotPossible {
                partition: p,
                kind: ErrorKind::InstructionStorage,
            });
        }
        p += 1;
    }
    if link_owners != 1 {
        return Err(ConfigError::LinkOwnerCount { count: link_owners });
    }

    let schedule = &config.schedule;
    if schedule.major_frame == 0 {
        return Err(ConfigError::EmptyMajorFrame);
    }
    let windows = schedule.windows;
    if windows.is_empty() {
        return Err(ConfigError::NoWindows);
    }
    if windows.len() > MAX_WINDOWS {
        return Err(ConfigError::TooManyWindows);
    }
    let mut w = 0;
    while w < windows.len() {
        let window = &windows[w];
        if window.partition >= parts.len() {
            return Err(ConfigError::WindowUnknownPartition { window: w });
        }
        if window.duration == 0 {
            return Err(ConfigError::WindowEmpty { window: w });
        }
        if window.end() > schedule.major_frame as u64 {
            return Err(ConfigError::WindowBeyondMajorFrame { window: w });
        }
        // Overlap with any earlier window (reported before ordering, which is the clearer
        // message when both apply).
        let mut v = 0;
        while v < w {
            let other = &windows[v];
            if (window.offset as u64) < other.end() && (other.offset as u64) < window.end() {
                return Err(ConfigError::WindowsOverlap {
                    window: w,
                    previous: v,
                });
            }
            v += 1;
        }
        if w > 0 && window.offset < windows[w - 1].offset {
            return Err(ConfigError::WindowsOutOfOrder {
                window: w,
                previous: w - 1,
            });
        }
        w += 1;
    }
    let mut p = 0;
    while p < parts.len() {
        let mut found = false;
        let mut w = 0;
        while w < windows.len() {
            if windows[w].partition == p {
                found = true;
            }
            w += 1;
        }
        if !found {
            return Err(ConfigError::PartitionWithoutWindow { partition: p });
        }
        p += 1;
    }

    let ports = config.ports;
    if ports.len() > MAX_PORTS {
        return Err(ConfigError::TooManyPorts);
    }
    let mut i = 0;
    while i < ports.len() {
        let port = &ports[i];
        if port.source >= parts.len() {
            return Err(ConfigError::PortUnknownSource { port: i });
        }
        if port.destinations.is_empty() {
            return Err(ConfigError::PortWithoutDestination { port: i });
        }
        let mut d = 0;
        while d < port.destinations.len() {
            if port.destinations[d] >= parts.len() {
                return Err(ConfigError::PortUnknownDestination {
                    port: i,
                    destination: d,
                });
            }
            if port.destinations[d] == port.source {
                return Err(ConfigError::PortToItself { port: i });
            }
            d += 1;
        }
        let mut j = 0;
        while j < i {
            if str_eq(ports[j].name, port.name) {
                return Err(ConfigError::PortDuplicateName { port: i });
            }
            j += 1;
        }
        if port.message_size == 0 || port.message_size > MAX_PORT_MESSAGE {
            return Err(ConfigError::PortBadSize { port: i });
        }
        match port.kind {
            PortKind::Sampling => {
                if port.depth != 1 {
                    return Err(ConfigError::PortBadDepth { port: i });
                }
                if port.destinations.len() > MAX_DESTINATIONS {
                    return Err(ConfigError::PortUnknownDestination {
                        port: i,
                        destination: MAX_DESTINATIONS,
                    });
                }
            }
            PortKind::Queuing => {
                if port.depth == 0 || port.depth > MAX_PORT_DEPTH {
                    return Err(ConfigError::PortBadDepth { port: i });
                }
                if port.destinations.len() != 1 {
                    return Err(ConfigError::QueuingPortDestinations { port: i });
                }
            }
        }
        i += 1;
    }
    Ok(())
}

/// Compile-time gate: panics (a compile error in a `const` item) with a message naming the
/// offending entry.
pub const fn assert_valid(config: &SystemConfig) {
    if let Err(error) = check(config) {
        let message = error.describe(config);
        panic!("{}", message.as_str());
    }
}

impl ConfigError {
    /// A sentence naming the offending entries, e.g.
    /// "window 3 (planner) overlaps window 2 (executive)".
    pub const fn describe(self, config: &SystemConfig) -> Message {
        let m = Message::new().str("kernel configuration: ");
        match self {
            ConfigError::NoPartitions => m.str("no partitions"),
            ConfigError::TooManyPartitions => m
                .str("more than ")
                .num(MAX_PARTITIONS as u64)
                .str(" partitions"),
            ConfigError::PartitionWithoutRegions { partition } => {
                part(m, config, partition).str(" has no memory region")
            }
            ConfigError::TooManyRegions { partition } => part(m, config, partition)
                .str(" has more than ")
                .num(MAX_REGIONS as u64)
                .str(" regions (one data BAT each; DBAT0 is the shared code)"),
            ConfigError::FirstRegionNotReadWrite { partition } => part(m, config, partition)
                .str(": region 0 must be ReadWrite (it holds the statics and the stack)"),
            ConfigError::RegionSizeNotBatBlock { partition, region } => {
                reg(m, config, partition, region)
                    .str(" size is not a power of two between 128 KiB and 256 MiB (a BAT block)")
            }
            ConfigError::RegionMisaligned { partition, region } => {
                reg(m, config, partition, region).str(" is not aligned to its size")
            }
            ConfigError::RegionOutsidePartitionRam { partition, region } => {
                reg(m, config, partition, region)
                    .str(" is outside partition RAM [")
                    .hex(PARTITION_RAM_BASE)
                    .str(", ")
                    .hex(RAM_END)
                    .str(")")
            }
            ConfigError::DeviceRegionInRam { partition, region } => {
                reg(m, config, partition, region)
                    .str(" is a device region below ")
                    .hex(DEVICE_SPACE_BASE)
            }
            ConfigError::DeviceRegionWithoutLinkOwner { partition, region } => {
                reg(m, config, partition, region)
                    .str(" maps devices, but only the I/O (link owner) partition may")
            }
            ConfigError::RegionsOverlap { a, b } => {
                let m = reg(m, config, a.0, a.1).str(" overlaps ");
                reg(m, config, b.0, b.1)
            }
            ConfigError::BadStackSize { partition } => part(m, config, partition)
                .str(": stack size ")
                .num(config.partitions[partition].stack_size as u64)
                .str(" is not a non-zero multiple of 16"),
            ConfigError::StackDoesNotFit { partition } => {
                part(m, config, partition).str(": header and stack do not fit in region 0")
            }
            ConfigError::LinkOwnerCount { count } => m
                .str("exactly one partition must own the link, found ")
                .num(count as u64),
            ConfigError::WarmAreaOwners => m.str("two partitions' slices of the warm area overlap"),
            ConfigError::NvMemoryOwners => {
                m.str("two partitions' slices of the non-volatile memory overlap")
            }
            ConfigError::SliceOutOfRange { partition } => part(m, config, partition)
                .str(": a persistent-memory slice is empty or reaches past the memory"),
            ConfigError::ContinueNotPossible { partition, kind } => part(m, config, partition)
                .str(": health-monitor action `log` (continue) is not possible for ")
                .str(kind.name()),
            ConfigError::EmptyMajorFrame => m.str("the major frame is 0 ticks long"),
            ConfigError::NoWindows => m.str("the major frame has no windows"),
            ConfigError::TooManyWindows => {
                m.str("more than ").num(MAX_WINDOWS as u64).str(" windows")
            }
            ConfigError::WindowUnknownPartition { window } => m
                .str("window ")
                .num(window as u64)
                .str(" names partition ")
                .num(config.schedule.windows[window].partition as u64)
                .str(", which does not exist"),
            ConfigError::WindowEmpty { window } => win(m, config, window).str(" is 0 ticks long"),
            ConfigError::WindowBeyondMajorFrame { window } => win(m, config, window)
                .str(" ends at tick ")
                .num(config.schedule.windows[window].end())
                .str(", after the major frame (")
                .num(config.schedule.major_frame as u64)
                .str(" ticks)"),
            ConfigError::WindowsOutOfOrder { window, previous } => {
                let m = win(m, config, window).str(" starts before ");
                win(m, config, previous).str(" (list windows by offset)")
            }
            ConfigError::WindowsOverlap { window, previous } => {
                let m = win(m, config, window).str(" overlaps ");
                win(m, config, previous)
            }
            ConfigError::PartitionWithoutWindow { partition } => {
                part(m, config, partition).str(" has no window in the major frame")
            }
            ConfigError::TooManyPorts => m.str("more than ").num(MAX_PORTS as u64).str(" ports"),
            ConfigError::PortUnknownSource { port: i } => {
                port(m, config, i).str(" has no source (its source partition does not exist)")
            }
            ConfigError::PortWithoutDestination { port: i } => {
                port(m, config, i).str(" has no destination")
            }
            ConfigError::PortUnknownDestination {
                port: i,
                destination,
            } => port(m, config, i)
                .str(": destination ")
                .num(destination as u64)
                .str(" does not exist"),
            ConfigError::PortToItself { port: i } => {
                port(m, config, i).str(" sends to its own source partition")
            }
            ConfigError::PortDuplicateName { port: i } => {
                port(m, config, i).str(": another port has the same name")
            }
            ConfigError::PortBadSize { port: i } => port(m, config, i)
                .str(": message size must be 1..=")
                .num(MAX_PORT_MESSAGE as u64),
            ConfigError::PortBadDepth { port: i } => port(m, config, i)
                .str(": depth must be 1 for sampling ports and 1..=")
                .num(MAX_PORT_DEPTH as u64)
                .str(" for queuing ports"),
            ConfigError::QueuingPortDestinations { port: i } => {
                port(m, config, i).str(": a queuing port has exactly one destination")
            }
        }
    }
}

const fn part(m: Message, config: &SystemConfig, p: usize) -> Message {
    m.str("partition ").str(config.partitions[p].name)
}

const fn reg(m: Message, config: &SystemConfig, p: usize, r: usize) -> Message {
    let region = &config.partitions[p].regions[r];
    part(m, config, p)
        .str(" region ")
        .num(r as u64)
        .str(" (")
        .hex(region.base)
        .str(", ")
        .hex(region.size)
        .str(" bytes)")
}

const fn win(m: Message, config: &SystemConfig, w: usize) -> Message {
    let window = &config.schedule.windows[w];
    let m = m.str("window ").num(w as u64).str(" (");
    let m = if window.partition < config.partitions.len() {
        m.str(config.partitions[window.partition].name)
    } else {
        m.str("?")
    };
    m.str(")")
}

const fn port(m: Message, config: &SystemConfig, i: usize) -> Message {
    m.str("port ").str(config.ports[i].name)
}

/// Index of the partition named `name` (const, for tables built from the configuration).
pub const fn partition_index(config: &SystemConfig, name: &str) -> Option<usize> {
    let mut p = 0;
    while p < config.partitions.len() {
        if str_eq(config.partitions[p].name, name) {
            return Some(p);
        }
        p += 1;
    }
    None
}

/// Index of the port named `name`.
pub const fn port_index(config: &SystemConfig, name: &str) -> Option<usize> {
    let mut i = 0;
    while i < config.ports.len() {
        if str_eq(config.ports[i].name, name) {
            return Some(i);
        }
        i += 1;
    }
    None
}

/// The id of the port named `name`, for `const` items: partitions name their ports, and the
/// id is derived from the configuration at compile time (a name the configuration does not
/// have stops the build).
pub const fn port_id(config: &SystemConfig, name: &str) -> usize {
    match port_index(config, name) {
        Some(i) => i,
        None => panic!("kernel configuration: no port of that name"),
    }
}

/// The largest message of any port of `config`, in bytes (sizes the partitions' buffers).
pub const fn max_port_message(config: &SystemConfig) -> usize {
    let mut largest = 0;
    let mut i = 0;
    while i < config.ports.len() {
        if config.ports[i].message_size as usize > largest {
            largest = config.ports[i].message_size as usize;
        }
        i += 1;
    }
    largest
}

/// Bytes of kernel RAM all port buffers need (each slot: message bytes rounded up to 4, plus
/// a 16-byte header).
pub const fn port_storage_bytes(config: &SystemConfig) -> usize {
    let mut total = 0;
    let mut i = 0;
    while i < config.ports.len() {
        total += port_slot_bytes(&config.ports[i]) * config.ports[i].depth as usize;
        i += 1;
    }
    total
}

/// Bytes one message slot of `port` takes.
pub const fn port_slot_bytes(port: &Port) -> usize {
    PORT_SLOT_HEADER + ((port.message_size as usize + 3) & !3)
}

/// Bytes of the per-slot header in port storage (length, sender generation, timestamp).
pub const PORT_SLOT_HEADER: usize = 16;

const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

#[cfg(test)]
mod tests;
