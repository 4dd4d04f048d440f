//! A scripted lander for the executor tests: it answers every directive at once (a dispatched
//! primitive finishes after its scripted duration, a wait jumps to its time, ground answers a
//! halt after a fixed delay), so a run is a pure function of the script and the strategy.
#![allow(dead_code)]

use fsw_bridge::MissionTimeUs;
use lander::assessor::Biosignature;
use lander::executor::{
    Directive, Event, ExecConfig, Executor, Observation, Outcome, Reason, Strategy, TaskResult,
};
use lander::htn::{flatten, FlatNetwork, FlattenOptions, HtnModel, PrimitiveKind};
use lander::rsm1::{self, Rsm1Options, HOUR_US, WH_MJ};

/// A small RSM-1: two sites of two targets, one panorama, two uplinks, over three sols.
pub const SMALL: Rsm1Options = Rsm1Options {
    sites: 2,
    targets_per_site: 2,
    panoramas: 1,
    uplinks: 2,
};
pub const SOLS: u64 = 4;
pub const BATTERY_MJ: u64 = 12_000 * WH_MJ;
pub const GROUND_DELAY_US: u64 = 12 * HOUR_US;

pub type Exec = Executor<2_048, 8_192>;

pub fn small() -> (HtnModel, FlatNetwork) {
    let model = rsm1::model(SMALL).expect("model");
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flattens");
    (model, net)
}

pub fn executor(strategy: Strategy) -> Box<Exec> {
    let (model, net) = small();
    let timeline = rsm1::placement(SOLS, BATTERY_MJ).expect("placement");
    Box::new(
        Exec::new(
            ExecConfig::new(strategy),
            &model,
            &net,
            &timeline,
            &rsm1::context(SMALL),
            None,
        )
        .expect("executor"),
    )
}

/// What happens to one dispatch: matched on the primitive's kind, site, target and attempt
/// (1 for the first dispatch of that primitive of that chain).
#[derive(Clone, Copy, Debug)]
pub struct Scripted {
    pub kind: PrimitiveKind,
    pub site: Option<u8>,
    pub target: Option<u8>,
    pub attempt: u32,
    /// Only the n-th dispatch of (kind, site, target) in the run, counting every chain's
    /// (for primitives without a site, such as the analysis).
    pub nth: Option<usize>,
    pub result: TaskResult,
    /// Measured duration and energy, when not the predicted ones.
    pub measured: Option<(u64, u64)>,
    pub biosignature: Option<Biosignature>,
    /// After this dispatch, the preconditions of this primitive (same kind, site, target)
    /// fail for this long.
    pub blocks_for_us: u64,
}

impl Scripted {
    pub fn on(kind: PrimitiveKind, site: Option<u8>, target: Option<u8>) -> Self {
        Self {
            kind,
            site,
            target,
            attempt: 1,
            nth: None,
            result: TaskResult::Succeeded,
            measured: None,
            biosignature: None,
            blocks_for_us: 0,
        }
    }
}

/// Preconditions of a primitive that fail over a time window.
#[derive(Clone, Copy, Debug)]
pub struct Block {
    pub kind: PrimitiveKind,
    pub site: Option<u8>,
    pub target: Option<u8>,
    pub from: MissionTimeUs,
    pub until: MissionTimeUs,
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunEnd {
    pub last: Directive,
    pub now: MissionTimeUs,
    pub battery_mj: u64,
    /// Every dispatch: (kind, site, target).
    pub dispatched: Vec<(PrimitiveKind, Option<u8>, Option<u8>)>,
    /// Ground halts answered.
    pub ground_answers: u32,
}

pub struct Sim {
    pub script: Vec<Scripted>,
    pub blocks: Vec<Block>,
    /// Answer ground halts (after [`GROUND_DELAY_US`]); when false, a halt ends the run.
    pub ground_answers: bool,
    /// Search explorations per step.
    pub budget: u32,
    /// Stop after this many dispatches (to inspect the executor mid-run).
    pub stop_after: Option<usize>,
    model: HtnModel,
}

impl Sim {
    pub fn new(script: Vec<Scripted>) -> Self {
        Self {
            script,
            blocks: Vec::new(),
            ground_answers: true,
            budget: 1_000_000,
            stop_after: None,
            model: small().0,
        }
    }

    /// The same, for an executor of `model` (its primitive table names what is dispatched).
    pub fn with_model(mut self, model: HtnModel) -> Self {
        self.model = model;
        self
    }

    fn preconditions(&self, exec: &Exec, now: MissionTimeUs) -> bool {
        let Some(step) = exec.remaining().first() else {
            return true;
        };
        let spec = &self.model.primitives[usize::from(step.primitive)];
        !self.blocks.iter().any(|b| {
            b.kind == spec.kind
                && b.site == spec.site
                && b.target == spec.target
                && b.from <= now
                && now < b.until
        })
    }

    pub fn run(&mut self, exec: &mut Exec) -> RunEnd {
        let mut now = MissionTimeUs::ZERO;
        let mut battery = BATTERY_MJ;
        let mut event = None;
        let mut dispatched = Vec::new();
        let mut attempts: Vec<((u16, u8), u32)> = Vec::new();
        let mut ground = 0;
        for _ in 0..100_000 {
            let observation = Observation {
                now,
                battery_mj: battery,
                preconditions_met: self.preconditions(exec, now),
                event: event.take(),
            };
            let directive = exec.step(&observation, self.budget);
            match directive {
                Directive::Dispatch {
                    chain,
                    primitive,
                    kind,
                    site,
                    target,
                    expected_end,
                    expected_energy_mj,
                } => {
                    dispatched.push((kind, site, target));
                    let nth = dispatched
                        .iter()
                        .filter(|d| **d == (kind, site, target))
                        .count();
                    let attempt = match attempts.iter_mut().find(|(k, _)| *k == (chain, primitive))
                    {
                        Some((_, n)) => {
                            *n += 1;
                            *n
                        }
                        None => {
                            attempts.push(((chain, primitive), 1));
                            1
                        }
                    };
                    let scripted = self.script.iter().find(|s| {
                        s.kind == kind
                            && s.site == site
                            && s.target == target
                            && s.attempt == attempt
                            && s.nth.is_none_or(|n| n == nth)
                    });
                    let (duration, energy) = scripted
                        .and_then(|s| s.measured)
                        .unwrap_or((expected_end.0 - now.0, expected_energy_mj));
                    now = MissionTimeUs(now.0 + duration);
                    battery = battery.saturating_sub(energy);
                    if let Some(s) = scripted {
                        if s.blocks_for_us > 0 {
                            self.blocks.push(Block {
                                kind,
                                site,
                                target,
                                from: now,
                                until: MissionTimeUs(now.0 + s.blocks_for_us),
                            });
                        }
                    }
                    event = Some(Event::Finished(Outcome {
                        result: scripted.map_or(TaskResult::Succeeded, |s| s.result),
                        duration_us: duration,
                        energy_mj: energy,
                        biosignature: scripted.and_then(|s| s.biosignature),
                    }));
                    if self.stop_after == Some(dispatched.len()) {
                        // Deliver the outcome, then stop.
                        let observation = Observation {
                            now,
                            battery_mj: battery,
                            preconditions_met: self.preconditions(exec, now),
                            event: event.take(),
                        };
                        let last = exec.step(&observation, self.budget);
                        return RunEnd {
                            last,
                            now,
                            battery_mj: battery,
                            dispatched,
                            ground_answers: ground,
                        };
                    }
                }
                Directive::Wait { until } => now = until,
                Directive::Pushing { deadline } => {
                    // The next change: a block ending, or the deadline.
                    let next = self
                        .blocks
                        .iter()
                        .map(|b| b.until)
                        .filter(|&u| u > now)
                        .min()
                        .map_or(deadline, |u| u.min(deadline));
                    now = next;
                }
                Directive::Planning { .. } | Directive::Running { .. } => {}
                Directive::HaltedForGround { .. } if self.ground_answers => {
                    ground += 1;
                    now = MissionTimeUs(now.0 + GROUND_DELAY_US);
                    event = Some(Event::GroundResume);
                }
                Directive::HaltedForGround { .. }
                | Directive::Abandoned { .. }
                | Directive::Done => {
                    return RunEnd {
                        last: directive,
                        now,
                        battery_mj: battery,
                        dispatched,
                        ground_answers: ground,
                    }
                }
            }
        }
        panic!("the run did not end");
    }
}

/// The samples collected successfully in a run, in order.
pub fn samples(end: &RunEnd) -> Vec<(u8, u8)> {
    end.dispatched
        .iter()
        .filter(|(k, _, _)| *k == PrimitiveKind::CollectSample)
        .filter_map(|(_, s, t)| Some(((*s)?, (*t)?)))
        .collect()
}

pub fn is_halt(d: &Directive, reason: Reason) -> bool {
    *d == Directive::HaltedForGround { reason }
}
