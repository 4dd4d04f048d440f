//! Words the kernel writes and partitions may only read: they live in `.kshared`, inside the
//! shared-code block that every partition maps read-only, while the kernel (MMU off) writes
//! them physically. Code that runs on both sides (the defmt logger, the panic handler, log
//! timestamps) uses them to know where it is running.
use core::sync::atomic::{AtomicU32, Ordering};

/// 1 while kernel code runs (boot, trap handlers, idle), 0 while a partition runs.
#[link_section = ".kshared"]
static KERNEL_ACTIVE: AtomicU32 = AtomicU32::new(1);

/// Index of the partition that runs (or last ran).
#[link_section = ".kshared"]
static CURRENT_PARTITION: AtomicU32 = AtomicU32::new(0);

/// Timebase at this boot, upper and lower word (the reference for log timestamps).
#[link_section = ".kshared"]
static BOOT_TICKS_HI: AtomicU32 = AtomicU32::new(0);
#[link_section = ".kshared"]
static BOOT_TICKS_LO: AtomicU32 = AtomicU32::new(0);

/// True in kernel context, false in a partition.
#[inline]
pub fn in_kernel() -> bool {
    KERNEL_ACTIVE.load(Ordering::Relaxed) != 0
}

/// The partition that runs; meaningful only when [`in_kernel`] is false.
#[inline]
pub fn current_partition() -> usize {
    CURRENT_PARTITION.load(Ordering::Relaxed) as usize
}

/// Kernel only: record who runs next (None: the kernel itself, idle included).
pub fn set_running(partition: Option<usize>) {
    match partition {
        Some(p) => {
            CURRENT_PARTITION.store(p as u32, Ordering::Relaxed);
            KERNEL_ACTIVE.store(0, Ordering::Relaxed);
        }
        None => KERNEL_ACTIVE.store(1, Ordering::Relaxed),
    }
}

/// Kernel only, at boot.
pub fn set_boot_ticks(ticks: u64) {
    BOOT_TICKS_HI.store((ticks >> 32) as u32, Ordering::Relaxed);
    BOOT_TICKS_LO.store(ticks as u32, Ordering::Relaxed);
}

pub fn boot_ticks() -> u64 {
    (u64::from(BOOT_TICKS_HI.load(Ordering::Relaxed)) << 32)
        | u64::from(BOOT_TICKS_LO.load(Ordering::Relaxed))
}
