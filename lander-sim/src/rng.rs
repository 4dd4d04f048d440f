//! The simulation's random numbers: SplitMix64, one independent stream per purpose (failures,
//! energy noise, science, quakes, sampling), so that two runs with the same seed under different
//! strategies draw the same failures for their n-th dispatch and the same biosignatures (common
//! random numbers: the strategies' differences are not noise). Integer arithmetic only: the same
//! seed gives the same run on any machine, which sharding across machines relies on.

/// SplitMix64.
#[derive(Clone, Debug)]
pub struct Rng(u64);

/// The streams of one run.
#[derive(Clone, Copy, Debug)]
pub enum Stream {
    Failures = 1,
    Energy = 2,
    Science = 3,
    Quakes = 4,
    Sampling = 5,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The stream `stream` of the run with seed `seed`.
    pub fn stream(seed: u64, stream: Stream) -> Self {
        let mut r = Self(seed ^ (stream as u64).wrapping_mul(0xA076_1D64_78BD_642F));
        r.next_u64();
        r
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (n > 0), without modulo bias worth mentioning (128-bit multiply).
    pub fn below(&mut self, n: u64) -> u64 {
        ((u128::from(self.next_u64()) * u128::from(n)) >> 64) as u64
    }

    /// True with probability `ppm` / 1,000,000.
    pub fn chance_ppm(&mut self, ppm: u32) -> bool {
        self.below(1_000_000) < u64::from(ppm)
    }

    /// A standard normal deviate in thousandths (sd 1000), by the Irwin-Hall sum of twelve
    /// uniforms minus six: integer arithmetic, bounded to +-6 sd.
    pub fn normal_milli(&mut self) -> i64 {
        let sum: i64 = (0..12).map(|_| self.below(1_000_000) as i64).sum();
        (sum - 6_000_000) / 1_000
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_sd_and_zero_mean() {
        let mut r = Rng::new(7);
        let n = 20_000i64;
        let xs: Vec<i64> = (0..n).map(|_| r.normal_milli()).collect();
        let mean = xs.iter().sum::<i64>() / n;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<i64>() / n;
        assert!(mean.abs() < 30, "mean {mean}");
        assert!((var - 1_000_000).abs() < 50_000, "variance {var}");
    }

    #[test]
    fn streams_differ_and_repeat() {
        let a: Vec<u64> = (0..4)
            .map(|_| Rng::stream(1, Stream::Failures).next_u64())
            .collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(
            Rng::stream(1, Stream::Failures).next_u64(),
            Rng::stream(1, Stream::Energy).next_u64()
        );
    }
}
