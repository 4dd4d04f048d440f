//! The configuration checker: [`check`] is a `const fn` that refuses a bad configuration with
//! a [`ConfigError`] naming the offending entries, [`assert_valid`] turns that into a compile
//! error, and [`ConfigError::describe`] writes the sentence the build shows.

use crate::queries::str_eq;
use crate::*;

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
