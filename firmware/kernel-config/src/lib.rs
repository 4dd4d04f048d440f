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

mod checker;
mod model;
mod queries;

pub use checker::{assert_valid, check, ConfigError};
pub use message::Message;
pub use model::*;
pub use queries::*;

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
/// partition (libcore, postcard and the partitions' own code live here). 1 MiB since the
/// lander's executor joined the temporal planner in the planner partition (the RAM image
/// passed 512 KiB: 527,344 bytes); it was 512 KiB with the kernel data right after it.
pub const SHARED_CODE_BASE: u32 = 0x0000_0000;
pub const SHARED_CODE_SIZE: u32 = 0x0010_0000;
/// The upper half of the shared code: the code checked before it first runs rather than at a
/// warm boot (the temporal planner's and the lander's; `linker/g3beige.ld` puts it here). The
/// partitions' instruction BAT maps only the lower half until the kernel has checked this block
/// against the image record (IBAT1, on the first instruction fetch from it); reading it as data
/// is allowed throughout (DBAT0 maps the whole shared code).
pub const DEFERRED_CODE_BASE: u32 = 0x0008_0000;
pub const DEFERRED_CODE_SIZE: u32 = 0x0008_0000;
/// Kernel data, bss and stack: never mapped for partitions. After the warm-restart area and
/// the hashed page table, below the first partition region.
pub const KERNEL_DATA_BASE: u32 = 0x0018_0000;
pub const KERNEL_DATA_SIZE: u32 = 0x0008_0000;
/// Warm-restart area (survives a warm reset); reached by partitions only through system calls.
pub const WARM_AREA_BASE: u32 = 0x0010_0000;
pub const WARM_AREA_SIZE: u32 = 0x0001_0000;
/// Bytes at the start of the warm area that hold the kernel's boot record and, after it, the
/// reset stub's image record.
pub const WARM_BOOT_RECORD_SIZE: u32 = 64;
/// Offset in the warm area of the reset stub's image record (the ROM build id and the checksums
/// of the two parts of the RAM image it last copied; see the firmware's `boot.rs`).
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
#[cfg(test)]
mod tests;
