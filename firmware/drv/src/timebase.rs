//! The 750's 64-bit timebase. On g3beige it ticks at 16.6 MHz; under `-icount shift=2` every
//! guest instruction advances virtual time by 4 ns. QEMU does NOT reset the timebase on
//! `system_reset`, so only differences are meaningful: never assume it starts at zero.
//!
//! [`Delay`] implements `embedded_hal::delay::DelayNs` over any [`TickSource`]: a wait of `n`
//! nanoseconds spins until at least `n` ns' worth of ticks (rounded up, in exact integer
//! arithmetic: 166 ticks per 10 µs) have passed, measured as a wrapping difference, so a wait
//! across the counter's wrap is as long as any other.
use embedded_hal::delay::DelayNs;

/// Timebase frequency of QEMU's g3beige.
pub const TIMEBASE_HZ: u64 = 16_600_000;
/// Ticks in 10 µs (exact: 16.6 per µs).
const TICKS_PER_10_US: u64 = 166;

/// A free-running 64-bit tick counter at [`TIMEBASE_HZ`].
pub trait TickSource {
    fn ticks(&self) -> u64;
}

impl<T: TickSource + ?Sized> TickSource for &T {
    #[inline]
    fn ticks(&self) -> u64 {
        (**self).ticks()
    }
}

/// Convert a tick count (a duration) to microseconds, rounded down: 16.6 ticks per µs.
pub const fn ticks_to_us(ticks: u64) -> u64 {
    ticks.saturating_mul(10) / 166
}

/// The ticks of at least `ns` nanoseconds (rounded up), for any `ns` without overflow.
pub const fn ns_to_ticks(ns: u64) -> u64 {
    // 10 µs = 10_000 ns = 166 ticks exactly; split so that no product overflows.
    let whole = ns / 10_000;
    let rest = ns % 10_000;
    whole * TICKS_PER_10_US + (rest * TICKS_PER_10_US).div_ceil(10_000)
}

/// The ticks of at least `us` microseconds (rounded up); no overflow for any `u32`.
pub const fn us_to_ticks(us: u32) -> u64 {
    (us as u64 * TICKS_PER_10_US).div_ceil(10)
}

/// The ticks of `ms` milliseconds (exact: 16,600 per ms); no overflow for any `u32`.
pub const fn ms_to_ticks(ms: u32) -> u64 {
    ms as u64 * (TIMEBASE_HZ / 1000)
}

/// Busy-wait delays over a [`TickSource`].
pub struct Delay<T: TickSource> {
    source: T,
}

impl<T: TickSource> Delay<T> {
    pub const fn new(source: T) -> Self {
        Self { source }
    }

    /// Spin until `ticks` ticks have passed since the call (wrapping difference).
    pub fn wait_ticks(&mut self, ticks: u64) {
        let start = self.source.ticks();
        while self.source.ticks().wrapping_sub(start) < ticks {}
    }
}

impl<T: TickSource> DelayNs for Delay<T> {
    fn delay_ns(&mut self, ns: u32) {
        self.wait_ticks(ns_to_ticks(u64::from(ns)));
    }

    fn delay_us(&mut self, us: u32) {
        self.wait_ticks(us_to_ticks(us));
    }

    fn delay_ms(&mut self, ms: u32) {
        self.wait_ticks(ms_to_ticks(ms));
    }
}

#[cfg(target_arch = "powerpc")]
pub use self::ppc::Timebase;

#[cfg(target_arch = "powerpc")]
mod ppc {
    use core::arch::asm;

    /// The 750's timebase register (`mftbu`/`mftb`), readable in any privilege state.
    #[derive(Clone, Copy, Default)]
    pub struct Timebase;

    impl Timebase {
        /// Read the 64-bit timebase consistently (upper half re-read until stable).
        #[inline]
        pub fn read() -> u64 {
            loop {
                let (hi, lo, hi2): (u32, u32, u32);
                // SAFETY: reading the timebase has no side effects.
                unsafe {
                    asm!("mftbu {0}", "mftb {1}", "mftbu {2}", out(reg) hi, out(reg) lo,
                         out(reg) hi2, options(nomem, nostack));
                }
                if hi == hi2 {
                    return (u64::from(hi) << 32) | u64::from(lo);
                }
            }
        }
    }

    impl super::TickSource for Timebase {
        #[inline]
        fn ticks(&self) -> u64 {
            Self::read()
        }
    }
}

#[cfg(test)]
mod tests {
    use core::cell::Cell;

    use super::*;

    /// A counter that advances `step` ticks at every read, from `start`.
    struct Stepping {
        now: Cell<u64>,
        step: u64,
        reads: Cell<u64>,
    }

    impl Stepping {
        fn new(start: u64, step: u64) -> Self {
            Self {
                now: Cell::new(start),
                step,
                reads: Cell::new(0),
            }
        }
    }

    impl TickSource for Stepping {
        fn ticks(&self) -> u64 {
            let t = self.now.get();
            self.now.set(t.wrapping_add(self.step));
            self.reads.set(self.reads.get() + 1);
            t
        }
    }

    /// Ticks that passed between the delay's first read and its last.
    fn waited(start: u64, step: u64, f: impl FnOnce(&mut Delay<&Stepping>)) -> u64 {
        let src = Stepping::new(start, step);
        f(&mut Delay::new(&src));
        step * (src.reads.get() - 1)
    }

    #[test]
    fn conversions_are_exact_and_round_up() {
        assert_eq!(ns_to_ticks(0), 0);
        assert_eq!(ns_to_ticks(1), 1);
        assert_eq!(ns_to_ticks(1_000), 17, "16.6 ticks per µs, rounded up");
        assert_eq!(ns_to_ticks(10_000), 166);
        assert_eq!(ns_to_ticks(1_000_000_000), TIMEBASE_HZ);
        assert_eq!(us_to_ticks(1), 17);
        assert_eq!(us_to_ticks(5), 83);
        assert_eq!(us_to_ticks(1_000_000), TIMEBASE_HZ);
        assert_eq!(ms_to_ticks(1000), TIMEBASE_HZ);
        assert_eq!(ticks_to_us(166), 10);
    }

    #[test]
    fn conversions_do_not_overflow_at_the_extremes() {
        assert_eq!(ms_to_ticks(u32::MAX), u64::from(u32::MAX) * 16_600);
        assert_eq!(
            us_to_ticks(u32::MAX),
            (u128::from(u32::MAX) * 166).div_ceil(10) as u64
        );
        assert_eq!(
            ns_to_ticks(u64::MAX),
            (u128::from(u64::MAX) * 166).div_ceil(10_000) as u64
        );
    }

    #[test]
    fn rounding_up_matches_a_wide_reference_everywhere() {
        for ns in (0..200_000u64).chain([4_294_967_295, 123_456_789_012]) {
            assert_eq!(
                u128::from(ns_to_ticks(ns)),
                (u128::from(ns) * 166).div_ceil(10_000),
                "{ns} ns"
            );
        }
        for us in 0..20_000u32 {
            assert_eq!(
                u128::from(us_to_ticks(us)),
                (u128::from(us) * 166).div_ceil(10),
                "{us} µs"
            );
        }
    }

    #[test]
    fn delay_ns_waits_at_least_the_ticks_and_stops_at_the_first_read_past_them() {
        // One tick per read: the wait ends at exactly the tick count.
        assert_eq!(waited(1_000, 1, |d| d.delay_ns(1_000)), 17);
        assert_eq!(waited(1_000, 1, |d| d.delay_us(10)), 166);
        assert_eq!(waited(0, 1, |d| d.delay_ms(2)), 33_200);
        // Coarser reads overshoot by less than one step.
        let w = waited(0, 7, |d| d.delay_us(100));
        assert!((1_660..1_660 + 7).contains(&w), "{w}");
    }

    #[test]
    fn a_zero_wait_reads_twice_and_returns() {
        assert_eq!(waited(5, 1, |d| d.delay_ns(0)), 1);
    }

    #[test]
    fn a_wait_across_the_counter_wrap_is_as_long_as_any_other() {
        assert_eq!(waited(u64::MAX - 5, 1, |d| d.delay_us(1)), 17);
        assert_eq!(waited(u64::MAX - 100, 3, |d| d.delay_ms(1)), 16_602);
    }

    #[test]
    fn the_longest_delay_ms_is_exact() {
        // u32::MAX ms is 71.3e12 ticks: counted with a 1e9-tick step, it ends one step past
        // the exact count at most.
        let w = waited(0, 1_000_000_000, |d| d.delay_ms(u32::MAX));
        let exact = u64::from(u32::MAX) * 16_600;
        assert!(w >= exact && w < exact + 1_000_000_000, "{w}");
    }
}
