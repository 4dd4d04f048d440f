//! Helpers shared by the lander tests: a seeded generator (SplitMix64, so every case is
//! reproducible from its seed) and random flat networks.
#![allow(dead_code)]

use fsw_bridge::MissionTimeUs;
use lander::htn::{Chain, FlatNetwork, PhaseMask};
use lander::utility::{RankedUtility, Score, RANK_COUNT};

pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x5eed_1a2d_e7a1_0000)
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `lo..=hi`.
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }

    pub fn chance(&mut self, percent: u64) -> bool {
        self.range(0, 99) < percent
    }
}

/// A utility with a few small scores (small so that ties happen).
pub fn small_utility(rng: &mut Rng) -> RankedUtility {
    let mut scores = [Score::ZERO; RANK_COUNT];
    for s in scores.iter_mut() {
        if rng.chance(35) {
            *s = Score::new(rng.range(0, 3) as u32 * 2_500).unwrap_or(Score::ZERO);
        }
    }
    RankedUtility::from_scores(scores)
}

/// A random flat network: `tasks` top-level tasks with 1..=3 alternatives each, durations in
/// whole hours, energies 1..=9 units, batches in `1..=batches`.
pub fn random_network(rng: &mut Rng, tasks: u8, batches: u8) -> FlatNetwork {
    let mut net = FlatNetwork::default();
    for task in 0..tasks {
        let alternatives = rng.range(1, 3);
        let batch = rng.range(1, u64::from(batches)) as u8;
        for alternative in 0..alternatives {
            let mut c = Chain::bare(
                100 + u16::from(task),
                task,
                small_utility(rng),
                rng.range(1, 9),
            );
            c.alternative = alternative as u8;
            c.duration_us = rng.range(1, 4) * 3_600_000_000;
            c.batch = batch;
            c.phases = PhaseMask::ANY;
            net.chains.push(c).expect("capacity");
        }
    }
    net
}

pub const HOUR: u64 = 3_600_000_000;

pub fn hours(h: u64) -> MissionTimeUs {
    MissionTimeUs(h * HOUR)
}
