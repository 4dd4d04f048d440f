//! Shared by the brute-force tests: a small deterministic random generator, and the random
//! plan networks the dispatcher's tests execute.
#![allow(dead_code)]

/// xorshift64*: the same numbers on every machine, no dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in 0..n.
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }
    pub fn chance(&mut self, percent: u64) -> bool {
        self.below(100) < percent
    }
}

/// A random plan of `actions` actions (each a start and an end step, in the order the steps
/// are added), durations with or without an upper bound, orderings from earlier steps to later
/// ones (some with an upper bound: a deadline relative to another step), timed windows on some
/// starts.
pub fn random_network(rng: &mut Rng) -> (temporal::PlanNetwork, u32) {
    let actions = 1 + rng.below(14) as usize;
    let mut net = temporal::PlanNetwork::new();
    let mut starts = Vec::new();
    for a in 0..actions {
        let lo = if rng.chance(25) {
            rng.below(60) as u32
        } else {
            0
        };
        let hi = if rng.chance(20) {
            lo + 20 + rng.below(200) as u32
        } else {
            temporal::task::UNBOUNDED
        };
        let s = net
            .add_step(temporal::PlanStep {
                action: a as u16,
                end: false,
                window: (lo, hi),
            })
            .unwrap();
        let e = net
            .add_step(temporal::PlanStep {
                action: a as u16,
                end: true,
                window: (0, temporal::task::UNBOUNDED),
            })
            .unwrap();
        let d = 1 + rng.below(30) as u32;
        let ub = if rng.chance(50) {
            d + rng.below(10) as u32
        } else {
            temporal::task::UNBOUNDED
        };
        net.add_constraint(temporal::constraints::Constraint {
            before: s as u16,
            after: e as u16,
            lb: d,
            ub,
        })
        .unwrap();
        starts.push((s, e));
    }
    let steps = net.step_count();
    for _ in 0..rng.below(3 * actions as u64 + 1) {
        let a = 2 + rng.below(steps as u64 - 1) as usize;
        let b = 1 + rng.below(a as u64 - 1) as usize;
        let lb = rng.below(8) as u32;
        let ub = if rng.chance(15) {
            lb + rng.below(80) as u32
        } else {
            temporal::task::UNBOUNDED
        };
        let _ = net.add_constraint(temporal::constraints::Constraint {
            before: b as u16,
            after: a as u16,
            lb,
            ub,
        });
    }
    let makespan = 50 + rng.below(400) as u32;
    net.makespan = makespan;
    (net, makespan + rng.below(40) as u32)
}
