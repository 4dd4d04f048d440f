//! The 750's 64-bit timebase. On g3beige it ticks at 16.6 MHz; under `-icount shift=2` every
//! guest instruction advances virtual time by 4 ns. QEMU does NOT reset the timebase on
//! `system_reset`, so only differences are meaningful: never assume it starts at zero.
use core::arch::asm;

use fsw_bridge::Ticks;

/// Timebase frequency of QEMU's g3beige.
#[allow(dead_code)]
pub const TIMEBASE_HZ: u64 = 16_600_000;

/// Read the 64-bit timebase consistently (upper half re-read until stable).
#[inline]
pub fn now() -> Ticks {
    loop {
        let (hi, lo, hi2): (u32, u32, u32);
        // SAFETY: reading the timebase has no side effects.
        unsafe {
            asm!("mftbu {0}", "mftb {1}", "mftbu {2}", out(reg) hi, out(reg) lo, out(reg) hi2,
                 options(nomem, nostack));
        }
        if hi == hi2 {
            return Ticks((u64::from(hi) << 32) | u64::from(lo));
        }
    }
}

/// Convert a tick count (a duration) to microseconds: 16.6 ticks per µs.
pub const fn ticks_to_us(ticks: u64) -> u64 {
    ticks.saturating_mul(10) / 166
}

/// Remember the timebase at the reset vector (`ticks`, read by the reset stub): the reference
/// for log timestamps, the uptime and boot to ready. Kernel only.
pub fn mark_boot(ticks: u64) {
    crate::shared::set_boot_ticks(ticks);
}

/// Guest microseconds since the reset vector; callable from the kernel and from partitions.
pub fn micros_since_boot() -> u64 {
    ticks_to_us(now().0.wrapping_sub(crate::shared::boot_ticks()))
}
