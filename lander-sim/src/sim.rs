//! The lander simulation (seed 000, issue 12 item 1): a seeded, deterministic world advanced in
//! integer mission time (µs) and energy (mJ), driving the lander autonomy
//! ([`lander::executor::Executor`]) through its value-in, value-out step: every
//! [`Observation`] (time, charge, whether the pending primitive's preconditions hold, a finished
//! primitive or a ground answer) is the world's, every [`Directive`] is carried out by the world.
//! The same loop can later drive the autonomy on the emulated target, with the step behind the
//! link instead of a function call.
//!
//! What the world models:
//! - **Sampling.** Excavation digs at a noisy rate to a required depth; a site may have a depth
//!   it cannot be dug past (the excavation then fails, and the site stays blocked); a trench may
//!   collapse and lose progress. A trench, once dug, stays: excavating it again takes minutes.
//!   Collection needs the site's trench.
//! - **Instruments.** Each target has a biosignature outcome (positive with a strength, or
//!   negative) from the scenario or drawn per run and site; the analysis reports it to the
//!   executor and the analysis product's value depends on it. Data products have the model's
//!   tiers and volumes (raw or compressed: the model's two analysis alternatives).
//! - **Seismometer** (continuous data while on, quakes) and **camera** (panorama products).
//! - **Thermal.** Excavation, collection and analysis heat their hardware from the ambient
//!   temperature first; the priors hold at the baseline (100 K); a colder ambient lengthens and
//!   costs more.
//! - **Battery.** Non-rechargeable; the hotel load (and the seismometer) drains it continuously,
//!   each primitive spends its prior times the energy noise, exogenous drops take charge at
//!   fixed times. The lander dies at zero charge (the charge never goes negative).
//! - **Comms.** Earth in view `in_view_h` of every `period_h` (42 of 84), given to the
//!   executor's placement as its in-view windows ([`EarthSchedule::view_timeline`]) when it is
//!   built and rebuilt, so downlinks are planned inside them; a downlink dispatched while Earth
//!   is not in view (an overrun pushed it out) waits for Earth rise; it transmits at the DSN rate after its
//!   overhead, until its planned end, Earth set or the thermal limit, within the per-downlink and
//!   per-sol energy allowances, the stored products by tier (Critical first) and age. Utility is
//!   realised when a product reaches Earth (transmission end plus the light time). The
//!   autonomy is told the link ([`World::comms_model`], again when the ground changes the rate
//!   or an allowance) and the products onboard ([`World::onboard_products`]) before each step;
//!   a downlink lasts as long as the autonomy commands and sends the products it assigned first
//!   ([`lander::executor::Executor::downlink_payload`]); a product larger than any one downlink
//!   can carry goes down in parts over several.
//! - **Ground.** A halt is seen at the next Earth-in-view plus the light time; the answer is
//!   ready `response_h` later and goes up at the next uplink window; it arrives a light time later
//!   ([`Event::GroundResume`]) and clears what blocked the primitive.
//! - **Task failures** (V.A). Each dispatch fails with P(fail); the failure's class is drawn with
//!   P(FE), P(replan), P(ground): FE-class completes with a failure code while the preconditions
//!   still hold (a retry resolves it), replan-class also loses the primitive's preconditions for a
//!   while (a retry cannot; a replan or the ground can), ground-class is a fault. Each resolution
//!   succeeds (V.A: "always succeed in resolving the issue"): the next attempt of that primitive
//!   does not fail again. A failed attempt spends a fraction of its time and energy.
//! - **Replanning** costs the lander the planner's time and energy ([`crate::scenario::ReplanCost`]).
use fsw_bridge::MissionTimeUs;
use lander::assessor::Biosignature;
use lander::executor::{
    Directive, Event, ExecConfig, Executor, Observation, Outcome, Strategy, TaskResult,
};
use lander::htn::{flatten, FlattenOptions, HtnModel, PrimitiveKind, PrimitiveSpec, Tier};
use lander::rsm1::{self, Rsm1Options};
/// Mission time and energy units (the reference model's).
pub use lander::rsm1::{HOUR_US, SOL_US, WH_MJ};
use serde::{Deserialize, Serialize};

use crate::rng::{Rng, Stream};
use crate::scenario::{milli, ppm, Scenario};

pub const MIN_US: u64 = 60_000_000;

mod run;
pub mod trace;
mod world;

pub use run::{run, run_watched, step_to_answer, Autonomy, StepWatch};

/// How a run is configured beyond its scenario.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunConfig {
    pub strategy: Strategy,
    pub seed: u64,
    /// Prescient (V.A's u_avg): no failures and no noise, and the priors are the true
    /// (bias-scaled) costs, so execution matches the planner's predictions.
    pub prescient: bool,
    /// Search explorations per executor call ([`step_to_answer`] calls again while it plans).
    pub budget: u32,
}

impl RunConfig {
    pub fn new(strategy: Strategy, seed: u64) -> Self {
        Self {
            strategy,
            seed,
            prescient: false,
            budget: 1_000_000,
        }
    }
}

/// Earth in view `in_view` of every `period`, from time 0; uplink windows at offsets into each
/// in-view part.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EarthSchedule {
    pub period_us: u64,
    pub in_view_us: u64,
    pub uplink_offsets_us: Vec<u64>,
}

impl EarthSchedule {
    pub fn from_scenario(s: &Scenario) -> Self {
        let mut offsets: Vec<u64> = s
            .ground
            .uplink_offsets_h
            .iter()
            .map(|h| h * HOUR_US)
            .collect();
        offsets.sort_unstable();
        Self {
            period_us: s.comms.period_h * HOUR_US,
            in_view_us: s.comms.in_view_h * HOUR_US,
            uplink_offsets_us: offsets,
        }
    }

    pub fn in_view(&self, t: u64) -> bool {
        t % self.period_us < self.in_view_us
    }

    /// The first time at or after `t` when Earth is in view.
    pub fn next_in_view(&self, t: u64) -> u64 {
        if self.in_view(t) {
            t
        } else {
            (t / self.period_us + 1) * self.period_us
        }
    }

    /// When the in-view part containing `t` ends (`t` itself when Earth is not in view).
    pub fn view_end(&self, t: u64) -> u64 {
        if self.in_view(t) {
            (t / self.period_us) * self.period_us + self.in_view_us
        } else {
            t
        }
    }

    /// The in-view windows that end after `from` and start before `horizon` (clipped to it), at
    /// most [`lander::capacity::MAX_VIEW_WINDOWS`]: the availability timeline the executor's
    /// placement allows downlinks in.
    pub fn view_timeline(&self, from: u64, horizon: u64) -> lander::placement::ViewTimeline {
        use lander::placement::{ViewTimeline, ViewWindow};
        let mut windows = Vec::new();
        let mut start = (from / self.period_us) * self.period_us;
        while start < horizon && windows.len() < lander::capacity::MAX_VIEW_WINDOWS {
            let end = (start + self.in_view_us).min(horizon);
            if end > from {
                windows.push(ViewWindow {
                    start: MissionTimeUs(start),
                    end: MissionTimeUs(end),
                });
            }
            start += self.period_us;
        }
        // Sorted, disjoint, non-empty and within the capacity by construction.
        ViewTimeline::new(&windows).unwrap_or_default()
    }

    /// The first uplink window at or after `t`.
    pub fn next_uplink(&self, t: u64) -> u64 {
        let mut base = (t / self.period_us) * self.period_us;
        loop {
            if let Some(o) = self.uplink_offsets_us.iter().find(|&&o| base + o >= t) {
                return base + o;
            }
            base += self.period_us;
        }
    }
}

/// A data product on board or sent.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Product {
    pub kind: String,
    pub tier: Tier,
    pub bytes: u64,
    /// Value in thousandths of the model's value units.
    pub value_milli: u64,
    pub created_us: u64,
    /// When it reached Earth (transmission end plus light time).
    pub received_us: Option<u64>,
    /// The sample an analysis product is about.
    #[serde(default)]
    pub site: Option<u8>,
    #[serde(default)]
    pub target: Option<u8>,
    /// Bytes already sent in earlier downlinks (a product larger than any one downlink goes
    /// down over several; it reaches Earth with its last part).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub sent_bytes: u64,
}

fn is_zero(x: &u64) -> bool {
    *x == 0
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum EndReason {
    /// The plan was executed.
    Done,
    /// Static: the first failure abandoned the rest.
    Abandoned,
    /// The battery reached zero.
    BatteryExhausted,
    /// The mission's horizon passed (e.g. waiting for the ground).
    MissionEnd,
}

/// One downlink as it happened.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DownlinkRecord {
    pub dispatched_us: u64,
    /// Transmission start (after any wait for Earth rise and the overhead).
    pub start_us: u64,
    pub end_us: u64,
    pub bytes: u64,
    /// Products sent per tier (Critical, Decisional, Mandatory, Residual).
    pub per_tier: [u32; 4],
    pub value_milli: u64,
}

/// What a run achieved and how.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunResult {
    pub seed: u64,
    /// The value of the data that reached Earth, in thousandths.
    pub utility_milli: u64,
    pub end: EndReason,
    pub end_us: u64,
    pub battery_start_mj: u64,
    pub battery_end_mj: u64,
    /// Dispatches (attempts) and the primitives' count that completed.
    pub dispatched: u32,
    pub completed: u32,
    /// Failures drawn, by class: FE, replan, ground.
    pub failures: [u32; 3],
    pub retries: u32,
    pub replans: u32,
    pub ground_halts: u32,
    pub samples_analyzed: u32,
    pub negatives: u32,
    pub downlinks: Vec<DownlinkRecord>,
    /// Products still on board at the end.
    pub unsent: u32,
    /// Every data product: those that reached Earth, then those still on board.
    pub products: Vec<Product>,
    /// Sample collections, in order.
    pub collections: Vec<SampleEvent>,
    /// Sample analyses, in order.
    pub analyses: Vec<SampleEvent>,
    /// Ground holds set (downlinks with ground hold) and released (by uplinks).
    pub holds_set: u32,
    pub holds_released: u32,
    /// Primitives of chains that wait for the ground's release dispatched while a hold was in
    /// force.
    pub hold_violations: u32,
    /// Ground changes, by their index in the scenario, with when they arrived on board and
    /// when they took effect (a model uplink at the next chain boundary).
    pub changes: Vec<AppliedChange>,
}

/// A sample collected or analysed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SampleEvent {
    /// When the primitive started.
    pub at_us: u64,
    pub site: u8,
    pub target: u8,
    /// The analysis' result (analyses only).
    pub positive: Option<bool>,
}

/// A ground change as it happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AppliedChange {
    pub index: usize,
    pub decided_us: u64,
    pub arrived_us: u64,
    pub applied_us: u64,
}

impl RunResult {
    pub fn energy_spent_mj(&self) -> u64 {
        self.battery_start_mj - self.battery_end_mj
    }
}

#[derive(Clone, Copy, Debug)]
struct Block {
    kind: PrimitiveKind,
    site: Option<u8>,
    target: Option<u8>,
    until: u64,
}

/// The resolvability class of a failure (V.A).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FailureClass {
    /// A retry resolves it.
    FlexibleExecution = 0,
    /// A replan (or the ground) resolves it.
    Replan = 1,
    /// Only the ground resolves it.
    Ground = 2,
}

/// One dispatch's failure draw: None (success) with probability 1 - p_fail, else the class
/// with probabilities p_fe, p_replan and the rest (p_ground); all in parts per million.
pub fn draw_failure(rng: &mut Rng, p_fail: u32, p_fe: u32, p_replan: u32) -> Option<FailureClass> {
    let draw = rng.below(1_000_000) as u32;
    if draw >= p_fail {
        None
    } else if draw < p_fe {
        Some(FailureClass::FlexibleExecution)
    } else if draw < p_fe + p_replan {
        Some(FailureClass::Replan)
    } else {
        Some(FailureClass::Ground)
    }
}

/// The world's state during a run.
pub struct World {
    pub earth: EarthSchedule,
    pub now: u64,
    pub battery_mj: u64,
    pub dead: bool,
    // Integer parameters.
    hotel_mw: u64,
    seismo_mw: u64,
    seismo_on: bool,
    seismo_bytes_per_h: u64,
    seismo_bytes: u64,
    seismo_value_milli_per_mb: u64,
    quakes: Vec<u64>,
    quake_bytes: u64,
    quake_value: u64,
    next_quake: usize,
    /// (time, mJ lost, or the charge it falls to).
    drops: Vec<(u64, u64, Option<u64>)>,
    next_drop: usize,
    /// Product volume per tier, in thousandths of the model's.
    volume_milli: [u64; 4],
    /// A ground hold in force: when the ground's release can be ready (u64::MAX until the held
    /// downlink's data reached Earth).
    hold_ready: Option<u64>,
    pub holds_set: u32,
    pub holds_released: u32,
    pub stored: Vec<Product>,
    pub sent: Vec<Product>,
    trench_mcm: Vec<u64>,
    required_mcm: u64,
    depth_limit_mcm: Vec<u64>,
    rate_mcm_per_h: Option<u64>,
    rate_sd_milli: i64,
    collapse_ppm_per_h: u32,
    collapse_mcm: u64,
    arm: Option<(u8, u8)>,
    pub(crate) instrument: Option<(u8, u8)>,
    /// Per site, per target: (positive, strength in thousandths).
    outcomes: Vec<Vec<(bool, u64)>>,
    negative_value_milli: u64,
    heat_milli: u64,
    blocks: Vec<Block>,
    /// (chain, primitive) whose failure was resolved: the next attempt succeeds.
    resolved: Vec<(u16, u8)>,
    comm_energy_by_sol: Vec<u64>,
    pub(crate) light_us: u64,
    pub rate_bps: u64,
    overhead_us: u64,
    thermal_limit_us: u64,
    per_downlink_mj: u64,
    pub per_sol_mj: u64,
    radio_mw: u64,
    ground_response_us: u64,
    p_fail: u32,
    p_fe: u32,
    p_replan: u32,
    failed_fraction_ppm: u64,
    replan_block_us: u64,
    bias_milli: i64,
    sd_milli: i64,
    rng_fail: Rng,
    rng_energy: Rng,
    rng_sampling: Rng,
    downlinks: Vec<DownlinkRecord>,
    /// The downlink being dispatched: its commanded duration and the products the autonomy
    /// assigned to it (sent first).
    commanded: Option<(u64, Vec<lander::downlink::DataProduct>)>,
}

fn mul_ppm(x: u64, ppm: u64) -> u64 {
    (u128::from(x) * u128::from(ppm) / 1_000_000) as u64
}

fn mul_milli(x: u64, m: u64) -> u64 {
    (u128::from(x) * u128::from(m) / 1_000) as u64
}

fn is_heated(kind: PrimitiveKind) -> bool {
    matches!(
        kind,
        PrimitiveKind::ExcavateSite | PrimitiveKind::CollectSample | PrimitiveKind::ScienceAnalyze
    )
}

fn is_downlink(kind: PrimitiveKind) -> bool {
    matches!(
        kind,
        PrimitiveKind::Downlink | PrimitiveKind::DownlinkWithGroundHold
    )
}

fn tier_index(t: Tier) -> usize {
    match t {
        Tier::Critical => 0,
        Tier::Decisional => 1,
        Tier::Mandatory => 2,
        Tier::Residual => 3,
    }
}

/// The model, flattened network, placement and science context the executor gets, from the
/// scenario (the reference model of `lander::rsm1` at the scenario's size). Prescient: the
/// priors' energies are scaled by the scenario's bias.
pub fn autonomy_inputs(
    s: &Scenario,
    prescient: bool,
) -> Result<
    (
        HtnModel,
        lander::htn::FlatNetwork,
        lander::placement::TimelinePlacement,
        lander::assessor::ScienceContext,
    ),
    String,
> {
    let options = rsm1_options(s);
    let mut model = rsm1::model_with_drains(options, s.mission.uplinks)
        .map_err(|_| "the model exceeds the capacities")?;
    if prescient {
        let f = (1_000 + milli(s.energy.bias)).max(0) as u64;
        for p in model.primitives.iter_mut() {
            p.energy_mj = mul_milli(p.energy_mj, f);
        }
    }
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: s.mission.fully_autonomous,
        },
    )
    .map_err(|e| format!("the model does not flatten: {e:?}"))?;
    let mut timeline = rsm1::placement(s.mission.sols, start_charge_mj(s))
        .ok_or("no placement for the mission")?;
    // The placement's background drain: the hotel load and the seismometer.
    timeline.hotel_load_mw = (s.power.hotel_w + s.power.seismometer_w) * 1_000;
    // Earth in view: downlinks are placed inside the windows.
    timeline.earth.windows = EarthSchedule::from_scenario(s).view_timeline(0, horizon_us(s));
    Ok((model, net, timeline, rsm1::context(options)))
}

pub fn rsm1_options(s: &Scenario) -> Rsm1Options {
    Rsm1Options {
        sites: s.mission.sites,
        targets_per_site: s.mission.targets_per_site,
        panoramas: s.mission.panoramas,
        uplinks: s.mission.uplinks,
    }
}

/// The charge at the start: `power.start_soc` of the battery.
pub fn start_charge_mj(s: &Scenario) -> u64 {
    mul_ppm(
        s.mission.battery_wh * WH_MJ,
        u64::from(ppm(s.power.start_soc)),
    )
}

/// The mission's horizon end.
pub fn horizon_us(s: &Scenario) -> u64 {
    s.mission.sols * SOL_US
}
