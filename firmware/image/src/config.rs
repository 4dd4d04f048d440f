//! The configuration this image runs (kernel-config's PRODUCT, or TEST with the rogue partition
//! under the `test-partitions` feature), checked at compile time, and the tables the kernel
//! derives from it at compile time: BAT values per partition and port storage offsets.
use kernel_config::{self as kc, system, Access, SystemConfig};

#[cfg(not(feature = "test-partitions"))]
pub const SYSTEM: SystemConfig = system::PRODUCT;
#[cfg(feature = "test-partitions")]
pub const SYSTEM: SystemConfig = system::TEST;

// A bad configuration stops the build here, with a message naming the offending entry.
const _: () = kc::assert_valid(&SYSTEM);

// The partitions look their ports up in userlib's copy of the choice: it must be this one
// (`cargo build --workspace` here would unify userlib's test-partitions feature, which the
// rogue partition needs, with an image built without it).
const _: () = assert!(
    userlib::SYSTEM.partitions.len() == SYSTEM.partitions.len()
        && userlib::SYSTEM.ports.len() == SYSTEM.ports.len(),
    "userlib and the image run different configurations: build the image with the same `test-partitions` feature as userlib"
);

pub const PARTITION_COUNT: usize = SYSTEM.partitions.len();
pub const WINDOW_COUNT: usize = SYSTEM.schedule.windows.len();
pub const PORT_COUNT: usize = SYSTEM.ports.len();
pub const PORT_STORAGE_BYTES: usize = kc::port_storage_bytes(&SYSTEM);

/// The partition that owns the link (the checker makes sure there is exactly one).
// The tables below are evaluated at compile time: an index out of range is a build error, never a
// panic on the target.
#[allow(clippy::indexing_slicing)]
pub const LINK_OWNER: usize = {
    let mut p = 0;
    while !SYSTEM.partitions[p].capabilities.link_owner {
        p += 1;
    }
    p
};

/// Where the linker put a partition (generated from the configuration by build.rs).
#[derive(Clone, Copy)]
pub struct PartitionImage {
    /// Stack top (32-byte aligned); the run-time header follows it, then the statics. The
    /// stack's bottom is the first byte of the partition's memory, so a stack overflow runs
    /// off the region into unmapped memory (a DSI) rather than into statics.
    pub stack_top: u32,
    /// End of the statics (32-byte aligned): `[stack_top, zero_end)` is zeroed at every start
    /// (the header and the statics; the stack is not).
    pub zero_end: u32,
    pub entry: u32,
}

impl PartitionImage {
    pub const NONE: PartitionImage = PartitionImage {
        stack_top: 0,
        zero_end: 0,
        entry: 0,
    };

    /// The partition's run-time header (logger state), right above its stack.
    pub fn header(&self) -> u32 {
        self.stack_top
    }
}

include!(concat!(env!("OUT_DIR"), "/partitions.rs"));

/// One BAT pair (upper, lower).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bat {
    pub upper: u32,
    pub lower: u32,
}

impl Bat {
    pub const INVALID: Bat = Bat { upper: 0, lower: 0 };

    /// A user-valid BAT mapping `base..base+size` 1:1.
    pub const fn user(base: u32, size: u32, access: Access) -> Bat {
        let block_length = (size >> 17) - 1;
        // Vp (user valid) only: the kernel runs with translation off.
        let upper = base | (block_length << 2) | 0x1;
        let (wimg, pp) = match access {
            Access::ReadWrite => (0, 0b10),
            Access::ReadOnly => (0, 0b01),
            // Cache-inhibited, guarded.
            Access::Device => (0b0101, 0b10),
        };
        Bat {
            upper,
            lower: base | (wimg << 3) | pp,
        }
    }
}

/// The shared code, read-only for every partition (DBAT0).
pub const SHARED_CODE_BAT: Bat =
    Bat::user(kc::SHARED_CODE_BASE, kc::SHARED_CODE_SIZE, Access::ReadOnly);
/// The shared code below the deferred code, executable by every partition (IBAT0).
pub const BOOT_CODE_IBAT: Bat = Bat::user(
    kc::SHARED_CODE_BASE,
    kc::DEFERRED_CODE_BASE - kc::SHARED_CODE_BASE,
    Access::ReadOnly,
);
/// The deferred code, executable once the kernel has checked it (IBAT1; `kernel::deferred`).
pub const DEFERRED_CODE_IBAT: Bat = Bat::user(
    kc::DEFERRED_CODE_BASE,
    kc::DEFERRED_CODE_SIZE,
    Access::ReadOnly,
);
const _: () = assert!(
    kc::DEFERRED_CODE_BASE + kc::DEFERRED_CODE_SIZE == kc::SHARED_CODE_BASE + kc::SHARED_CODE_SIZE
        && (kc::DEFERRED_CODE_BASE - kc::SHARED_CODE_BASE).is_power_of_two()
        && kc::DEFERRED_CODE_SIZE.is_power_of_two()
        && kc::DEFERRED_CODE_BASE.is_multiple_of(kc::DEFERRED_CODE_SIZE)
);

/// DBAT1..3 of each partition.
#[allow(clippy::indexing_slicing)] // Compile time (see LINK_OWNER).
pub const PARTITION_DBATS: [[Bat; kc::MAX_REGIONS]; PARTITION_COUNT] = {
    let mut table = [[Bat::INVALID; kc::MAX_REGIONS]; PARTITION_COUNT];
    let mut p = 0;
    while p < PARTITION_COUNT {
        let regions = SYSTEM.partitions[p].regions;
        let mut r = 0;
        while r < regions.len() {
            table[p][r] = Bat::user(regions[r].base, regions[r].size, regions[r].access);
            r += 1;
        }
        p += 1;
    }
    table
};

/// Offset of each port's first slot in the kernel's port storage.
#[allow(clippy::indexing_slicing)] // Compile time (see LINK_OWNER).
pub const PORT_OFFSETS: [usize; PORT_COUNT] = {
    let mut offsets = [0; PORT_COUNT];
    let mut total = 0;
    let mut i = 0;
    while i < PORT_COUNT {
        offsets[i] = total;
        total += kc::port_slot_bytes(&SYSTEM.ports[i]) * SYSTEM.ports[i].depth as usize;
        i += 1;
    }
    offsets
};
