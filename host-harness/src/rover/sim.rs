//! The simulated rover and its world: how long each action the onboard mission starts really
//! takes (seeded terrain, named obstacles). The host plays this; the mission decides.
use super::SimulationSection;

// ----- the simulated rover ----------------------------------------------------------------------

/// xorshift64*: the same numbers on every machine.
pub(super) struct Rng(u64);

impl Rng {
    pub(super) fn new(seed: u64) -> Self {
        Self(seed ^ 0x9e37_79b9_7f4a_7c15 | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [lo, hi], in thousandths.
    fn factor(&mut self, [lo, hi]: [f64; 2]) -> f64 {
        lo + (hi - lo) * (self.next() % 1001) as f64 / 1000.0
    }
}

/// How long the simulated rover takes for each action it is commanded.
pub(super) struct RoverSim {
    pub(super) rng: Rng,
    pub(super) sim: SimulationSection,
    pub(super) blocked: Vec<String>,
}

impl RoverSim {
    /// The actual duration of `name` whose estimate is `estimate` ticks.
    pub(super) fn duration(&mut self, name: &str, estimate: u32) -> (u32, Option<&'static str>) {
        if !name.starts_with("(traverse") {
            return (estimate, None);
        }
        if let Some(i) = self.blocked.iter().position(|b| b == name) {
            self.blocked.remove(i);
            let f = self
                .sim
                .obstacles
                .iter()
                .find(|o| o.traverse == name)
                .map_or(1.0, |o| o.factor);
            return ((f64::from(estimate) * f).round() as u32, Some("obstacle"));
        }
        let slow = self.rng.next() % 100 < self.sim.slow_percent;
        let f = if slow {
            self.rng.factor(self.sim.slow_factor)
        } else {
            self.rng.factor(self.sim.nominal_factor)
        };
        (
            (f64::from(estimate) * f).round() as u32,
            slow.then_some("terrain"),
        )
    }
}
