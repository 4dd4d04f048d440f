//! The 750's 64-bit timebase (driver: `drv_g3beige::timebase`): 16.6 MHz on g3beige, not reset
//! by QEMU's `system_reset`, so only differences are meaningful.
use drv_g3beige::timebase::{ticks_to_us, Timebase};
use fsw_bridge::Ticks;

/// Read the 64-bit timebase consistently (upper half re-read until stable).
#[inline]
pub fn now() -> Ticks {
    Ticks(Timebase::read())
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
