//! A small seeded PRNG (SplitMix64): the same seed gives the same run on every host.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x5851_f42d_4c95_7f2d)
    }

    /// An independent stream for one purpose (link faults, noise, ...).
    pub fn fork(&self, stream: u64) -> Self {
        let mut r = Self(self.0 ^ stream.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        r.next_u64();
        r
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// True with probability `p` (0.0..=1.0), decided in integers so every host agrees.
    pub fn chance(&mut self, p: f64) -> bool {
        if p <= 0.0 {
            return false;
        }
        let threshold = (p.min(1.0) * (u32::MAX as f64)) as u64;
        (self.next_u64() >> 32) < threshold
    }

    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n.max(1)
    }

    /// Gaussian-ish noise in per-mille: sum of 4 uniforms scaled to a standard deviation of
    /// `sd_permille` (integer arithmetic only).
    pub fn noise_permille(&mut self, sd_permille: i64) -> i64 {
        // Irwin-Hall with n=4: variance 4/12, so sd = 0.577 of the unit; scale accordingly.
        let sum: i64 = (0..4).map(|_| (self.next_u64() % 2001) as i64 - 1000).sum();
        sum * sd_permille / 1155
    }
}
