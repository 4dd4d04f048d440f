//! Space partitioning with the 750's MMU: the kernel runs with translation off; partitions run
//! with translation on and see only what the BATs map. DBAT0 maps the shared code read-only,
//! IBAT0 its lower half (everything but the deferred code) executable, IBAT1 the deferred code
//! once the kernel has checked it (`super::deferred`); DBAT1..3 map the running partition's
//! regions (from the configuration); IBAT2..3 stay invalid, so partition data is never
//! executable. The hashed page table is all
//! invalid, so every access outside a BAT is a DSI/ISI for the health monitor.
use core::arch::asm;

use kernel_config as kc;

use super::at;
use crate::config::{Bat, BOOT_CODE_IBAT, DEFERRED_CODE_IBAT, PARTITION_DBATS, SHARED_CODE_BAT};

macro_rules! set_bat {
    ($upper:literal, $lower:literal, $bat:expr) => {{
        let bat: Bat = $bat;
        // SAFETY:
        // 1. Supervisor state with translation off: the BATs only affect partitions.
        // 2. The upper word is written invalid first, so no half-written BAT is ever valid.
        //    It keeps the old block's address and length while invalid: QEMU drops the
        //    translations it cached for a BAT over the length of the value written, so writing
        //    0 (a 128 KiB length) left the rest of a larger old block (the planner's 4 MiB, the
        //    executive's 2 MiB) readable and writable by the next partition until QEMU's TLB
        //    happened to lose it. A real 750 caches no BAT translations; this is the same
        //    there.
        unsafe {
            asm!(
                concat!("mfspr {old}, ", $upper),
                "rlwinm {old}, {old}, 0, 0, 29",
                concat!("mtspr ", $upper, ", {old}"),
                concat!("mtspr ", $lower, ", {lower}"),
                concat!("mtspr ", $upper, ", {upper}"),
                old = out(reg) _,
                lower = in(reg) bat.lower,
                upper = in(reg) bat.upper,
                options(nostack, nomem)
            )
        }
    }};
}

/// Program SDR1 (all-invalid page table), the segment registers and the fixed BATs.
pub fn init() {
    // SAFETY:
    // 1. Supervisor state, translation off. SDR1 points at the 64 KiB table the reset stub
    //    zeroed (HTABMASK 0); segment registers get VSID = segment number, T=0.
    unsafe {
        asm!("mtspr 25, {0}", "sync", in(reg) kc::HTAB_BASE, options(nostack, nomem));
        for segment in 0..16u32 {
            asm!("mtsrin {0}, {1}", in(reg) segment, in(reg) segment << 28, options(nostack, nomem));
        }
        asm!("isync", options(nostack, nomem));
    }
    set_bat!("528", "529", BOOT_CODE_IBAT);
    set_bat!("530", "531", Bat::INVALID);
    set_bat!("532", "533", Bat::INVALID);
    set_bat!("534", "535", Bat::INVALID);
    set_bat!("536", "537", SHARED_CODE_BAT);
    set_bat!("538", "539", Bat::INVALID);
    set_bat!("540", "541", Bat::INVALID);
    set_bat!("542", "543", Bat::INVALID);
}

/// Map partition `p`'s regions into DBAT1..3 (the shared code stays in IBAT0/DBAT0).
pub fn map(p: usize) {
    let bats = *at(&PARTITION_DBATS, p);
    set_bat!("538", "539", bats[0]);
    set_bat!("540", "541", bats[1]);
    set_bat!("542", "543", bats[2]);
}

/// Make the deferred code executable for the partitions (IBAT1), once checked.
pub fn map_deferred_code() {
    set_bat!("530", "531", DEFERRED_CODE_IBAT);
}
