//! The configuration the image runs: the product's three partitions (I/O, executive, planner)
//! and, in the test image (feature `test-partitions`), a rogue partition used only by tests.
//!
//! Memory map (physical = effective; every partition region is one BAT block):
//!
//! | range                   | what                                   | partitions see         |
//! |-------------------------|----------------------------------------|------------------------|
//! | 0x00000000-0x000fffff   | vectors, kernel+partition code, rodata | read/execute only      |
//! | 0x00100000-0x0010ffff   | warm-restart area                      | via system calls only  |
//! | 0x00110000-0x0011ffff   | hashed page table (all invalid)        | nothing                |
//! | 0x00180000-0x001fffff   | kernel data, bss, stack, port buffers  | nothing                |
//! | 0x00200000-0x0027ffff   | I/O partition (512 KiB)                | I/O: read/write        |
//! | 0x00400000-0x005fffff   | executive (2 MiB)                      | executive: read/write  |
//! | 0x00c00000-0x00c1ffff   | rogue (128 KiB, test image only)       | rogue: read/write      |
//! | 0x01000000-0x01ffffff   | planner (16 MiB)                       | planner: read/write    |
//! | 0x90000000-             | non-volatile memory (ivshmem)          | via system calls only  |
//! | 0x98000000-0x9801ffff   | shared-memory link (emulated target)   | nothing (kernel only)  |
//! | 0xf3000000-0xf307ffff   | mac-io (ESCC UART, Heathrow PIC)       | nothing (kernel only)  |
//!
//! Major frame: 10 ms (166 000 ticks): I/O 1.5 ms, executive 2 ms, planner 4 ms, (rogue 1 ms in
//! the test image), the rest idle.
use crate::{port_id, ErrorKind, HmAction};
use crate::{
    Access, Capabilities, HealthTable, Partition, Port, PortKind, Region, Schedule, SystemConfig,
    Window,
};
use crate::{Slice, WARM_CHECKPOINT_PART};

/// Partition indices, the same in both images (the `partition` field of health-monitor
/// events, metric id offsets).
pub const IO: usize = 0;
pub const EXECUTIVE: usize = 1;
pub const PLANNER: usize = 2;
/// Test image only.
pub const ROGUE: usize = 3;

/// Where the kernel maps mac-io (Heathrow BAR0, set at boot). The kernel drives the UART and the
/// interrupt controller itself (it is the link's byte pipe), so no partition maps it; the
/// region stays here for configurations that give a partition a device.
pub const MAC_IO_BASE: u32 = 0xf300_0000;

pub const IO_REGION: Region = Region {
    base: 0x0020_0000,
    size: 0x0008_0000,
    access: Access::ReadWrite,
};
pub const MAC_IO_REGION: Region = Region {
    base: MAC_IO_BASE,
    size: 0x0008_0000,
    access: Access::Device,
};
pub const EXECUTIVE_REGION: Region = Region {
    base: 0x0040_0000,
    size: 0x0020_0000,
    access: Access::ReadWrite,
};
/// 16 MiB (one BAT block, so 16 MiB-aligned): the MEXEC planner's state (about 0.8 MiB), and
/// the temporal planner's search arena (8 MiB) and task buffer (1 MiB), which are not zeroed
/// at the partition's start (`.bss.noinit.planner`; see `firmware/image/build.rs`). It was
/// 4 MiB at 0x00800000 before the temporal planner.
pub const PLANNER_REGION: Region = Region {
    base: 0x0100_0000,
    size: 0x0100_0000,
    access: Access::ReadWrite,
};
pub const ROGUE_REGION: Region = Region {
    base: 0x00c0_0000,
    size: 0x0002_0000,
    access: Access::ReadWrite,
};

/// The executive's slice of the warm-restart area's checkpoint part: its A/B checkpoint
/// records (the control loop: network, executive, state table, its end of the ports).
pub const EXECUTIVE_WARM: Slice = Slice {
    offset: 0,
    len: 0x8000,
};
/// The planner's slice: the rest (its A/B records: network, plan, its end of the ports).
pub const PLANNER_WARM: Slice = Slice {
    offset: EXECUTIVE_WARM.len,
    len: WARM_CHECKPOINT_PART - EXECUTIVE_WARM.len,
};
/// The executive's slice of non-volatile memory: its checkpoint records (laid out as the warm
/// area's checkpoint part was when it was the only owner, so that a provisioned key stays
/// where `hil nv provision` put it), then the security area (key slot, anti-replay counter
/// records), with room to spare: 128 KiB.
pub const EXECUTIVE_NV: Slice = Slice {
    offset: 0,
    len: 0x2_0000,
};
/// The planner's slice of non-volatile memory, after the executive's: its checkpoint records
/// (as long as its warm slice), then its security area (the key and the anti-replay counter
/// of temporal uplinks, `sdls::nv`'s layout) at [`PLANNER_NV_SECURITY_OFFSET`].
pub const PLANNER_NV: Slice = Slice {
    offset: EXECUTIVE_NV.len,
    len: PLANNER_WARM.len + PLANNER_NV_SECURITY_BYTES,
};
/// Offset of the planner's security area in its slice of non-volatile memory.
pub const PLANNER_NV_SECURITY_OFFSET: u32 = PLANNER_WARM.len;
/// Bytes kept for it (`sdls::nv::SECURITY_AREA_BYTES` is 128; room to spare).
pub const PLANNER_NV_SECURITY_BYTES: u32 = 0x100;

const PARTITIONS_PRODUCT: [Partition; 3] = [
    Partition {
        name: "io",
        entry: "partition_io_main",
        regions: &[IO_REGION],
        stack_size: 0x4000,
        capabilities: Capabilities {
            link_owner: true,
            warm_area: None,
            nv_memory: None,
        },
        health: HealthTable::RESTART_ON_FAULT,
    },
    Partition {
        name: "executive",
        entry: "partition_executive_main",
        regions: &[EXECUTIVE_REGION],
        stack_size: 0x20000,
        capabilities: Capabilities {
            link_owner: false,
            warm_area: Some(EXECUTIVE_WARM),
            nv_memory: Some(EXECUTIVE_NV),
        },
        health: HealthTable::RESTART_ON_FAULT,
    },
    Partition {
        name: "planner",
        entry: "partition_planner_main",
        regions: &[PLANNER_REGION],
        // 128 KiB: the plug-ins' work is in functions of its own (in the deferred code, checked
        // before it first runs), whose frames (the lander's window about 20 KB) now add to the
        // entry's (about 44 KB) instead of sharing it; at 64 KiB the lander's setup overflowed.
        stack_size: 0x20000,
        capabilities: Capabilities {
            link_owner: false,
            warm_area: Some(PLANNER_WARM),
            nv_memory: Some(PLANNER_NV),
        },
        health: HealthTable::RESTART_ON_FAULT,
    },
];

const ROGUE_PARTITION: Partition = Partition {
    name: "rogue",
    entry: "partition_rogue_main",
    regions: &[ROGUE_REGION],
    stack_size: 0x2000,
    capabilities: Capabilities::NONE,
    // Bad system calls are reported and the call returns its error, so the rogue can try
    // every call; everything else restarts it.
    health: HealthTable::RESTART_ON_FAULT.with(ErrorKind::IllegalSyscall, HmAction::Log),
};

const PARTITIONS_TEST: [Partition; 4] = [
    PARTITIONS_PRODUCT[0],
    PARTITIONS_PRODUCT[1],
    PARTITIONS_PRODUCT[2],
    ROGUE_PARTITION,
];

/// 10 ms at 16.6 MHz.
pub const MAJOR_FRAME_TICKS: u32 = 166_000;
/// The planner partition's window: 2 ms of each major frame.
pub const PLANNER_WINDOW_TICKS: u32 = 33_200;

const WINDOWS_PRODUCT: [Window; 3] = [
    Window {
        partition: IO,
        offset: 0,
        duration: 24_900,
    },
    // 4 ms: the flight application's worst frame (the replanning after a second reset,
    // about 36,000 ticks, plus the checkpoint writes) fits in one window without overrunning.
    Window {
        partition: EXECUTIVE,
        offset: 24_900,
        duration: 66_400,
    },
    Window {
        partition: PLANNER,
        offset: 91_300,
        duration: PLANNER_WINDOW_TICKS,
    },
];

const WINDOWS_TEST: [Window; 4] = [
    WINDOWS_PRODUCT[0],
    WINDOWS_PRODUCT[1],
    WINDOWS_PRODUCT[2],
    Window {
        partition: ROGUE,
        offset: 124_500,
        duration: 16_600,
    },
];

/// Largest message routed from the link to a partition (a postcard-encoded `HostToTarget`;
/// an UplinkChunk with 128 bytes is the largest).
pub const ROUTED_MESSAGE_SIZE: u32 = 160;
/// Largest message from the executive to the planner: a postcard-encoded
/// `Wire<autonomy::partitioned::PlannerInput>`, the largest being a network chunk of 96 bytes
/// (a flight-app test checks that every kind fits).
pub const EXECUTIVE_TO_PLANNER_MESSAGE_SIZE: u32 = 128;
/// Largest message from the planner to the executive: a postcard-encoded
/// `Wire<autonomy::partitioned::ExecutiveInput>` (a commit, a planner decision for the host,
/// the planner's status).
pub const PLANNER_TO_EXECUTIVE_MESSAGE_SIZE: u32 = 96;
/// Largest message a partition sends towards the host (a postcard-encoded `TargetToHost`
/// other than Log: CommandDispatch, Telemetry, FrameDone).
pub const OUTBOUND_MESSAGE_SIZE: u32 = 64;

const PORTS_PRODUCT: [Port; 6] = [
    Port {
        name: "io_to_executive",
        kind: PortKind::Queuing,
        message_size: ROUTED_MESSAGE_SIZE,
        depth: 8,
        source: IO,
        destinations: &[EXECUTIVE],
    },
    Port {
        name: "io_to_planner",
        kind: PortKind::Queuing,
        message_size: ROUTED_MESSAGE_SIZE,
        depth: 8,
        source: IO,
        destinations: &[PLANNER],
    },
    Port {
        name: "executive_to_io",
        kind: PortKind::Queuing,
        message_size: OUTBOUND_MESSAGE_SIZE,
        depth: 8,
        source: EXECUTIVE,
        destinations: &[IO],
    },
    Port {
        name: "planner_to_io",
        kind: PortKind::Queuing,
        message_size: OUTBOUND_MESSAGE_SIZE,
        depth: 8,
        source: PLANNER,
        destinations: &[IO],
    },
    // The planner partition's channel with the executive (`autonomy::partitioned`): numbered
    // messages kept by the sender until acknowledged, so a full port only delays them.
    Port {
        name: "executive_to_planner",
        kind: PortKind::Queuing,
        message_size: EXECUTIVE_TO_PLANNER_MESSAGE_SIZE,
        depth: 16,
        source: EXECUTIVE,
        destinations: &[PLANNER],
    },
    Port {
        name: "planner_to_executive",
        kind: PortKind::Queuing,
        message_size: PLANNER_TO_EXECUTIVE_MESSAGE_SIZE,
        depth: 16,
        source: PLANNER,
        destinations: &[EXECUTIVE],
    },
];

const PORTS_TEST: [Port; 8] = [
    PORTS_PRODUCT[0],
    PORTS_PRODUCT[1],
    PORTS_PRODUCT[2],
    PORTS_PRODUCT[3],
    PORTS_PRODUCT[4],
    PORTS_PRODUCT[5],
    Port {
        name: "io_to_rogue",
        kind: PortKind::Queuing,
        message_size: ROUTED_MESSAGE_SIZE,
        depth: 2,
        source: IO,
        destinations: &[ROGUE],
    },
    // The rogue's messages for the host: the stale-message test sends one and restarts before
    // the I/O partition takes it.
    Port {
        name: "rogue_to_io",
        kind: PortKind::Queuing,
        message_size: OUTBOUND_MESSAGE_SIZE,
        depth: 2,
        source: ROGUE,
        destinations: &[IO],
    },
];

/// Port ids, derived from the ports' names at compile time (`port_id`: a name the
/// configuration lacks stops the build). The test image's ports extend the product's, which
/// keep their ids (a test checks).
pub const PORT_IO_TO_EXECUTIVE: usize = port_id(&PRODUCT, "io_to_executive");
pub const PORT_IO_TO_PLANNER: usize = port_id(&PRODUCT, "io_to_planner");
pub const PORT_EXECUTIVE_TO_IO: usize = port_id(&PRODUCT, "executive_to_io");
pub const PORT_PLANNER_TO_IO: usize = port_id(&PRODUCT, "planner_to_io");
pub const PORT_EXECUTIVE_TO_PLANNER: usize = port_id(&PRODUCT, "executive_to_planner");
pub const PORT_PLANNER_TO_EXECUTIVE: usize = port_id(&PRODUCT, "planner_to_executive");
pub const PORT_IO_TO_ROGUE: usize = port_id(&TEST, "io_to_rogue");
pub const PORT_ROGUE_TO_IO: usize = port_id(&TEST, "rogue_to_io");

/// The product: I/O, executive, planner.
pub const PRODUCT: SystemConfig = SystemConfig {
    partitions: &PARTITIONS_PRODUCT,
    schedule: Schedule {
        major_frame: MAJOR_FRAME_TICKS,
        windows: &WINDOWS_PRODUCT,
    },
    ports: &PORTS_PRODUCT,
};

/// The test image: the product plus the rogue partition, its window and its port. The
/// product's partitions, windows and ports keep their indices and timing.
pub const TEST: SystemConfig = SystemConfig {
    partitions: &PARTITIONS_TEST,
    schedule: Schedule {
        major_frame: MAJOR_FRAME_TICKS,
        windows: &WINDOWS_TEST,
    },
    ports: &PORTS_TEST,
};
