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

pub mod trace;

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

impl World {
    pub fn new(s: &Scenario, model: &HtnModel, seed: u64, prescient: bool) -> Self {
        let earth = EarthSchedule::from_scenario(s);
        let horizon = horizon_us(s);
        // Quakes: a schedule drawn up front, so every strategy sees the same ones.
        let mut rq = Rng::stream(seed, Stream::Quakes);
        let per_h = ppm(s.seismometer.quakes_per_h);
        let quakes = (0..horizon / HOUR_US)
            .filter_map(|h| {
                rq.chance_ppm(per_h)
                    .then_some(h * HOUR_US + rq.below(HOUR_US))
            })
            .collect();
        // Science: per site positive or negative, strengths per target; fixed ones override.
        let mut rs = Rng::stream(seed, Stream::Science);
        let p_pos = ppm(s.science.p_site_positive);
        let mut outcomes: Vec<Vec<(bool, u64)>> = (0..s.mission.sites)
            .map(|_| {
                let positive = rs.chance_ppm(p_pos);
                (0..s.mission.targets_per_site)
                    .map(|_| (positive, if positive { 500 + rs.below(501) } else { 0 }))
                    .collect()
            })
            .collect();
        for t in &s.science.targets {
            if let Some(o) = outcomes
                .get_mut(usize::from(t.site))
                .and_then(|site| site.get_mut(usize::from(t.target)))
            {
                *o = (t.positive, milli(t.strength).clamp(0, 1_000) as u64);
            }
        }
        let th = &s.thermal;
        let h = milli(th.heating_fraction).clamp(0, 1_000) as u64;
        let heat_milli = (1_000 - h)
            + h * th.operating_k.saturating_sub(th.ambient_k)
                / th.operating_k.saturating_sub(th.baseline_k).max(1);
        let excavation_prior_us = model
            .primitives
            .iter()
            .find(|p| p.kind == PrimitiveKind::ExcavateSite)
            .map_or(6 * HOUR_US, |p| p.duration_us);
        let required_mcm = s.sampling.required_depth_cm * 1_000;
        let rate_mcm_per_h = s
            .sampling
            .rate_cm_per_h
            .map(|r| (r * 1_000.0).round() as u64)
            .or_else(|| {
                Some(
                    (u128::from(required_mcm) * u128::from(HOUR_US)
                        / u128::from(excavation_prior_us.max(1))) as u64,
                )
            });
        let capacity = s.mission.battery_wh * WH_MJ;
        let mut drops: Vec<(u64, u64, Option<u64>)> = s
            .power
            .drops
            .iter()
            .map(|d| {
                (
                    d.at_h * HOUR_US,
                    d.wh * WH_MJ,
                    d.to_soc.map(|x| mul_ppm(capacity, u64::from(ppm(x)))),
                )
            })
            .collect();
        let volume = |x: f64| milli(x).max(0) as u64;
        drops.sort_unstable();
        let f = &s.failures;
        Self {
            earth,
            now: 0,
            battery_mj: start_charge_mj(s),
            dead: false,
            hotel_mw: s.power.hotel_w * 1_000,
            seismo_mw: s.power.seismometer_w * 1_000,
            seismo_on: false,
            seismo_bytes_per_h: s.seismometer.bytes_per_h,
            seismo_bytes: 0,
            seismo_value_milli_per_mb: milli(s.seismometer.value_per_mb).max(0) as u64,
            quakes,
            quake_bytes: s.seismometer.quake_bytes,
            quake_value: s.seismometer.quake_value,
            next_quake: 0,
            drops,
            next_drop: 0,
            volume_milli: [
                volume(s.data.critical),
                volume(s.data.decisional),
                volume(s.data.mandatory),
                volume(s.data.residual),
            ],
            hold_ready: None,
            holds_set: 0,
            holds_released: 0,
            stored: Vec::new(),
            sent: Vec::new(),
            trench_mcm: vec![0; usize::from(s.mission.sites)],
            required_mcm,
            depth_limit_mcm: (0..s.mission.sites)
                .map(|i| {
                    s.sampling
                        .depth_limit_cm
                        .get(usize::from(i))
                        .copied()
                        .unwrap_or(0)
                        * 1_000
                })
                .collect(),
            rate_mcm_per_h,
            rate_sd_milli: if prescient {
                0
            } else {
                milli(s.sampling.rate_sd)
            },
            collapse_ppm_per_h: if prescient {
                0
            } else {
                ppm(s.sampling.collapse_per_h)
            },
            collapse_mcm: s.sampling.collapse_cm * 1_000,
            arm: None,
            instrument: None,
            outcomes,
            negative_value_milli: milli(s.science.negative_value).clamp(0, 1_000) as u64,
            heat_milli,
            blocks: Vec::new(),
            resolved: Vec::new(),
            comm_energy_by_sol: Vec::new(),
            light_us: s.comms.light_time_min * MIN_US,
            rate_bps: s.comms.rate_bps,
            overhead_us: s.comms.overhead_min * MIN_US,
            thermal_limit_us: s.comms.thermal_limit_h * HOUR_US,
            per_downlink_mj: s.comms.per_downlink_wh * WH_MJ,
            per_sol_mj: s.comms.per_sol_wh * WH_MJ,
            radio_mw: s.comms.radio_w * 1_000,
            ground_response_us: s.ground.response_h * HOUR_US,
            p_fail: if prescient { 0 } else { ppm(f.p_fail) },
            p_fe: ppm(f.p_fe),
            p_replan: ppm(f.p_replan),
            failed_fraction_ppm: u64::from(ppm(f.failed_attempt_fraction)),
            replan_block_us: f.replan_block_min * MIN_US,
            bias_milli: if prescient { 0 } else { milli(s.energy.bias) },
            sd_milli: if prescient { 0 } else { milli(s.energy.sd) },
            rng_fail: Rng::stream(seed, Stream::Failures),
            rng_energy: Rng::stream(seed, Stream::Energy),
            rng_sampling: Rng::stream(seed, Stream::Sampling),
            downlinks: Vec::new(),
            commanded: None,
        }
    }

    /// The link as the autonomy is told it (rate, overhead, thermal limit, radio, allowances).
    pub fn comms_model(&self) -> lander::comms::CommsModel {
        lander::comms::CommsModel {
            rate_bps: self.rate_bps.max(1),
            overhead_us: self.overhead_us,
            thermal_limit_us: self.thermal_limit_us,
            radio_power_mw: self.radio_mw,
            per_downlink_mj: self.per_downlink_mj,
            per_sol_mj: self.per_sol_mj,
            sol_us: SOL_US,
        }
    }

    /// The products onboard as the autonomy measures them (most urgent and oldest first, at
    /// most the downlink manager's capacity).
    pub fn onboard_products(&self) -> Vec<lander::downlink::DataProduct> {
        let mut out: Vec<_> = self
            .stored
            .iter()
            .map(|p| lander::downlink::DataProduct {
                size_bytes: p.bytes - p.sent_bytes,
                value: p.value_milli / 1_000,
                created_at: MissionTimeUs(p.created_us),
                tier: p.tier,
            })
            .collect();
        out.sort_by_key(|p| (tier_index(p.tier), p.created_at));
        out.truncate(lander::capacity::MAX_DATA_PRODUCTS);
        out
    }

    /// A product's volume in this world.
    fn volume(&self, tier: Tier, bytes: u64) -> u64 {
        mul_milli(bytes, self.volume_milli[tier_index(tier)])
    }

    /// Whether a ground hold is in force.
    pub fn hold_in_force(&self) -> bool {
        self.hold_ready.is_some()
    }

    /// A downlink with ground hold ended: a hold is in force until the ground has seen its data
    /// for `response_h` and an uplink carries the release.
    fn set_hold(&mut self) {
        self.holds_set += 1;
        let received = self.downlinks.last().map(|d| d.end_us + self.light_us);
        // Only a downlink that carried data gives the ground something to release on.
        let ready = match received {
            Some(r) if self.downlinks.last().is_some_and(|d| d.bytes > 0) => {
                r + self.ground_response_us
            }
            _ => u64::MAX,
        };
        self.hold_ready = Some(ready);
    }

    /// An uplink started at `start`: it releases the hold if the ground's release was ready
    /// when it was sent (a light time before).
    fn uplink(&mut self, start: u64) {
        if let Some(ready) = self.hold_ready {
            if ready.saturating_add(self.light_us) <= start {
                self.hold_ready = None;
                self.holds_released += 1;
            }
        }
    }

    fn load_mw(&self) -> u64 {
        self.hotel_mw + if self.seismo_on { self.seismo_mw } else { 0 }
    }

    /// Drains `mj` from the battery; false (and dead) when it runs out.
    pub fn spend(&mut self, mj: u64) -> bool {
        if mj >= self.battery_mj && mj > 0 {
            self.battery_mj = 0;
            self.dead = true;
            return false;
        }
        self.battery_mj -= mj;
        true
    }

    /// Advances the clock to `to` (never back): the background load drains, the seismometer
    /// records, quakes and exogenous drops happen. False when the battery runs out on the way
    /// (the clock then stops when it did).
    pub fn advance(&mut self, to: u64) -> bool {
        while self.now < to && !self.dead {
            let next_drop = self.drops.get(self.next_drop).map(|d| d.0);
            let next_quake = self.quakes.get(self.next_quake).copied();
            let stop = [next_drop, next_quake]
                .into_iter()
                .flatten()
                .filter(|&t| t > self.now && t <= to)
                .min()
                .unwrap_or(to);
            let dt = stop - self.now;
            let load = self.load_mw();
            let drain = (u128::from(load) * u128::from(dt) / 1_000_000) as u64;
            if drain >= self.battery_mj && drain > 0 {
                // Dies part-way.
                let t = (u128::from(self.battery_mj) * 1_000_000 / u128::from(load.max(1))) as u64;
                self.now += t.min(dt);
                self.battery_mj = 0;
                self.dead = true;
                return false;
            }
            self.battery_mj -= drain;
            if self.seismo_on {
                self.seismo_bytes += (u128::from(self.seismo_bytes_per_h) * u128::from(dt)
                    / u128::from(HOUR_US)) as u64;
            }
            self.now = stop;
            while let Some(&(t, mj, to)) = self.drops.get(self.next_drop) {
                if t > self.now {
                    break;
                }
                self.next_drop += 1;
                let loss = to.map_or(mj, |to| self.battery_mj.saturating_sub(to));
                if loss > 0 && !self.spend(loss) {
                    return false;
                }
            }
            while let Some(&t) = self.quakes.get(self.next_quake) {
                if t > self.now {
                    break;
                }
                self.next_quake += 1;
                if self.seismo_on {
                    self.stored.push(Product {
                        kind: "quake".into(),
                        tier: Tier::Decisional,
                        bytes: self.volume(Tier::Decisional, self.quake_bytes),
                        value_milli: self.quake_value * 1_000,
                        created_us: t,
                        received_us: None,
                        site: None,
                        target: None,
                        sent_bytes: 0,
                    });
                }
            }
        }
        !self.dead
    }

    /// Whether the preconditions of `spec` hold now.
    pub fn preconditions(&self, spec: &PrimitiveSpec) -> bool {
        let blocked = self.blocks.iter().any(|b| {
            b.kind == spec.kind
                && b.site == spec.site
                && b.target == spec.target
                && self.now < b.until
        });
        if blocked {
            return false;
        }
        match spec.kind {
            PrimitiveKind::CollectSample | PrimitiveKind::FindCollectionTargets => spec
                .site
                .and_then(|s| self.trench_mcm.get(usize::from(s)))
                .is_some_and(|&d| d >= self.required_mcm),
            _ => true,
        }
    }

    /// The energy noise factor of one dispatch, in thousandths.
    fn energy_factor(&mut self) -> u64 {
        let z = self.rng_energy.normal_milli();
        (1_000 + self.bias_milli + self.sd_milli * z / 1_000).max(0) as u64
    }

    /// Excavation of `site`: (duration, energy scale in thousandths of the prior, reached).
    fn excavate(&mut self, site: u8, prior_us: u64) -> (u64, u64, bool) {
        let i = usize::from(site);
        let have = self.trench_mcm.get(i).copied().unwrap_or(0);
        if have >= self.required_mcm {
            // The trench is there: a look, minutes.
            return (6 * MIN_US, 1, true);
        }
        let limit = self.depth_limit_mcm.get(i).copied().unwrap_or(0);
        let mean = self.rate_mcm_per_h.unwrap_or(10_000).max(1);
        let z = self.rng_sampling.normal_milli();
        let rate = ((mean as i64) * (1_000 + self.rate_sd_milli * z / 1_000) / 1_000)
            .max(mean as i64 / 10)
            .max(1) as u64;
        // Dig in steps of 6 minutes.
        let step_us = 6 * MIN_US;
        let per_step = rate / 10;
        let collapse_ppm = self.collapse_ppm_per_h / 10;
        let mut depth = have;
        let mut t = 0u64;
        let max_t = 10 * prior_us.max(HOUR_US);
        let reached = loop {
            if depth >= self.required_mcm {
                break true;
            }
            if (limit > 0 && depth >= limit) || t >= max_t {
                break false;
            }
            t += step_us;
            depth += per_step.max(1);
            if limit > 0 {
                depth = depth.min(limit);
            }
            if collapse_ppm > 0 && self.rng_sampling.chance_ppm(collapse_ppm) {
                depth = depth.saturating_sub(self.collapse_mcm);
            }
        };
        if let Some(d) = self.trench_mcm.get_mut(i) {
            *d = depth;
        }
        // Energy scales with the digging time against the prior's.
        let scale = (u128::from(t) * 1_000 / u128::from(prior_us.max(1))) as u64;
        (t, scale, reached)
    }

    fn product(&mut self, spec: &PrimitiveSpec) {
        let Some(p) = spec.product else { return };
        let mut value = p.value * 1_000;
        if spec.kind == PrimitiveKind::ScienceAnalyze {
            if let Some((site, target)) = self.instrument {
                if let Some(&(positive, strength)) = self
                    .outcomes
                    .get(usize::from(site))
                    .and_then(|s| s.get(usize::from(target)))
                {
                    value = if positive {
                        mul_milli(value, 1_000 + strength)
                    } else {
                        mul_milli(value, self.negative_value_milli)
                    };
                }
            }
        }
        let (site, target) = if spec.kind == PrimitiveKind::ScienceAnalyze {
            self.instrument.unzip()
        } else {
            (spec.site, spec.target)
        };
        self.stored.push(Product {
            kind: format!("{:?}", spec.kind),
            tier: p.tier,
            bytes: self.volume(p.tier, p.size_bytes),
            value_milli: value,
            created_us: self.now,
            received_us: None,
            site,
            target,
            sent_bytes: 0,
        });
    }

    fn biosignature(&self) -> Option<Biosignature> {
        let (site, target) = self.instrument?;
        let &(positive, _) = self
            .outcomes
            .get(usize::from(site))?
            .get(usize::from(target))?;
        Some(if positive {
            Biosignature::Positive
        } else {
            Biosignature::Negative
        })
    }

    /// A downlink: waits for Earth if it must, transmits, realises the products' value.
    /// Returns the time it took and false if the battery ran out.
    fn downlink(
        &mut self,
        planned_us: u64,
        energy_mj: u64,
        payload: &[lander::downlink::DataProduct],
    ) -> (u64, bool) {
        let dispatched = self.now;
        if !self.advance(self.earth.next_in_view(self.now)) {
            return (self.now - dispatched, false);
        }
        let start = self.now;
        let view_end = self.earth.view_end(start);
        let tx_start = start + self.overhead_us;
        let mut tx_end = (start + planned_us)
            .min(view_end)
            .min(tx_start + self.thermal_limit_us)
            .max(tx_start);
        // Energy allowances: per downlink and per sol (of the radio's power).
        let sol = (start / SOL_US) as usize;
        if self.comm_energy_by_sol.len() <= sol {
            self.comm_energy_by_sol.resize(sol + 1, 0);
        }
        let sol_left = self.per_sol_mj.saturating_sub(self.comm_energy_by_sol[sol]);
        let allowance = self.per_downlink_mj.min(sol_left);
        let max_tx = (u128::from(allowance) * 1_000_000 / u128::from(self.radio_mw.max(1))) as u64;
        tx_end = tx_end.min(tx_start + max_tx);
        let tx_us = tx_end - tx_start;
        self.comm_energy_by_sol[sol] +=
            (u128::from(self.radio_mw) * u128::from(tx_us) / 1_000_000) as u64;
        // The seismometer's continuous data so far becomes a product.
        if self.seismo_bytes > 0 {
            let bytes = std::mem::take(&mut self.seismo_bytes);
            self.stored.push(Product {
                kind: "seismic".into(),
                tier: Tier::Residual,
                bytes: self.volume(Tier::Residual, bytes),
                value_milli: (u128::from(bytes) * u128::from(self.seismo_value_milli_per_mb)
                    / 1_000_000) as u64,
                created_us: start,
                received_us: None,
                site: None,
                target: None,
                sent_bytes: 0,
            });
        }
        let mut capacity = (u128::from(self.rate_bps) * u128::from(tx_us) / 8_000_000) as u64;
        // The autonomy's assignment first, then the rest by tier and age.
        let assigned = |p: &Product| {
            payload.iter().any(|a| {
                a.created_at.0 == p.created_us
                    && a.tier == p.tier
                    && a.size_bytes == p.bytes - p.sent_bytes
            })
        };
        self.stored
            .sort_by_key(|p| (!assigned(p), tier_index(p.tier), p.created_us));
        let mut record = DownlinkRecord {
            dispatched_us: dispatched,
            start_us: tx_start,
            end_us: tx_end,
            bytes: 0,
            per_tier: [0; 4],
            value_milli: 0,
        };
        let mut kept = Vec::new();
        // A product larger than any one downlink can carry goes down over several.
        let largest = self.comms_model();
        let largest = largest.capacity_of(largest.max_duration_us());
        for mut p in std::mem::take(&mut self.stored) {
            let left = p.bytes - p.sent_bytes;
            if left > largest && left > capacity && capacity > 0 {
                p.sent_bytes += capacity;
                record.bytes += capacity;
                capacity = 0;
                kept.push(p);
            } else if left <= capacity {
                capacity -= left;
                record.bytes += left;
                record.per_tier[tier_index(p.tier)] += 1;
                record.value_milli += p.value_milli;
                p.received_us = Some(tx_end + self.light_us);
                self.sent.push(p);
            } else {
                kept.push(p);
            }
        }
        self.stored = kept;
        self.downlinks.push(record);
        let ok = self.advance(start + planned_us) && self.spend(energy_mj);
        (self.now - dispatched, ok)
    }

    /// Carries out one dispatch of `spec` (chain, primitive) predicted at `expected_us`.
    fn execute(&mut self, chain: u16, primitive: u8, spec: &PrimitiveSpec) -> (Outcome, u8) {
        let start = self.now;
        let commanded = self.commanded.take();
        let factor = self.energy_factor();
        let heat = if is_heated(spec.kind) {
            self.heat_milli
        } else {
            1_000
        };
        let mut duration = mul_milli(spec.duration_us, heat);
        let mut energy = mul_milli(mul_milli(spec.energy_mj, factor), heat);
        // Failure draw (one per dispatch, from its own stream).
        let drawn = draw_failure(&mut self.rng_fail, self.p_fail, self.p_fe, self.p_replan);
        let resolved_at = self.resolved.iter().position(|r| *r == (chain, primitive));
        let class = if let Some(i) = resolved_at {
            self.resolved.swap_remove(i);
            None
        } else {
            drawn.map(|c| c as u8)
        };
        let mut biosignature = None;
        let result = if let Some(class) = class {
            duration = mul_ppm(duration, self.failed_fraction_ppm);
            energy = mul_ppm(energy, self.failed_fraction_ppm);
            self.resolved.push((chain, primitive));
            if class == 1 {
                self.blocks.push(Block {
                    kind: spec.kind,
                    site: spec.site,
                    target: spec.target,
                    until: start + duration + self.replan_block_us,
                });
            }
            let ok = self.advance(start + duration) && self.spend(energy);
            let _ = ok;
            if class == 2 {
                TaskResult::Faulted
            } else {
                TaskResult::Failed
            }
        } else if is_downlink(spec.kind) {
            // The commanded duration (sized by the autonomy to its data); energy scales.
            let (commanded, payload) = commanded.unwrap_or((duration, Vec::new()));
            energy =
                (u128::from(energy) * u128::from(commanded) / u128::from(duration.max(1))) as u64;
            duration = commanded;
            let _ = self.downlink(duration, energy, &payload);
            TaskResult::Succeeded
        } else {
            let mut result = TaskResult::Succeeded;
            match spec.kind {
                PrimitiveKind::ExcavateSite => {
                    let site = spec.site.unwrap_or(0);
                    let (t, scale, reached) = self.excavate(site, spec.duration_us);
                    duration = mul_milli(t, heat);
                    energy = mul_milli(mul_milli(spec.energy_mj, factor), heat);
                    energy = mul_milli(energy, scale);
                    if !reached {
                        // The site cannot be dug (depth limit): blocked for good.
                        self.blocks.push(Block {
                            kind: spec.kind,
                            site: spec.site,
                            target: spec.target,
                            until: u64::MAX,
                        });
                        result = TaskResult::Failed;
                    }
                }
                PrimitiveKind::CollectSample => {
                    self.arm = spec.site.zip(spec.target);
                }
                PrimitiveKind::TransportSample => {
                    self.instrument = self.arm.take();
                }
                PrimitiveKind::StartSeismometer => self.seismo_on = true,
                PrimitiveKind::StopSeismometer => self.seismo_on = false,
                _ => {}
            }
            let ok = self.advance(start + duration) && self.spend(energy);
            if ok && result == TaskResult::Succeeded {
                if spec.kind == PrimitiveKind::ScienceAnalyze {
                    biosignature = self.biosignature();
                }
                self.product(spec);
            }
            result
        };
        (
            Outcome {
                result,
                duration_us: self.now - start,
                energy_mj: energy,
                biosignature,
            },
            class.map_or(u8::MAX, |c| c),
        )
    }

    /// A ground answer to a halt at `now`: when it arrives on board.
    pub fn ground_answer_at(&self, now: u64) -> u64 {
        let seen = self.earth.next_in_view(now) + self.light_us;
        let uplink = self.earth.next_uplink(seen + self.ground_response_us);
        uplink + self.light_us
    }

    /// The ground resolves the halted primitive's problem: its blocks go.
    fn ground_fix(&mut self, spec: Option<&PrimitiveSpec>) {
        if let Some(spec) = spec {
            self.blocks.retain(|b| {
                !(b.kind == spec.kind && b.site == spec.site && b.target == spec.target)
                    || b.until == u64::MAX
            });
        }
    }
}

/// The value of the products that reached Earth.
fn realised_of(products: &[Product]) -> u64 {
    products
        .iter()
        .filter(|p| p.received_us.is_some())
        .map(|p| p.value_milli)
        .sum()
}

/// The executor type the simulation drives (the default capacities).
pub type Autonomy = Executor;

/// An executor for the state `now`, `charge_mj`, `context` (what the lander has learned) with
/// the model of `options` (a model uplink: the executor is rebuilt and plans from the state).
#[allow(clippy::too_many_arguments)]
fn rebuild(
    s: &Scenario,
    options: Rsm1Options,
    context: &lander::assessor::ScienceContext,
    now: u64,
    charge_mj: u64,
    strategy: Strategy,
    preamble_done: bool,
    watch: &mut dyn StepWatch,
) -> Result<(HtnModel, Box<Autonomy>), String> {
    let model = rsm1::model_with_drains(options, s.mission.uplinks)
        .map_err(|_| "the new model exceeds the capacities")?;
    let mut net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: s.mission.fully_autonomous,
        },
    )
    .map_err(|e| format!("the new model does not flatten: {e:?}"))?;
    if preamble_done {
        // The new model's preamble (task 1) is done already: not planned again.
        net.chains.retain(|c| c.task != PREAMBLE_TASK);
    }
    let mut timeline =
        rsm1::placement(s.mission.sols, charge_mj).ok_or("no placement for the mission")?;
    timeline.horizon_start = MissionTimeUs(now);
    timeline.hotel_load_mw = (s.power.hotel_w + s.power.seismometer_w) * 1_000;
    timeline.earth.windows = EarthSchedule::from_scenario(s).view_timeline(now, horizon_us(s));
    let exec = Box::new(
        Executor::new(
            ExecConfig::new(strategy),
            &model,
            &net,
            &timeline,
            context,
            None,
        )
        .map_err(|e| format!("the executor refused the new model: {e:?}"))?,
    );
    watch.built(ExecConfig::new(strategy), &model, &net, &timeline, context)?;
    Ok((model, exec))
}

/// The reference model's preamble task.
const PREAMBLE_TASK: u16 = 1;

/// A ground change on its way.
struct PendingChange {
    index: usize,
    decided_us: u64,
    /// On board (u64::MAX until its trigger happened).
    arrives_us: u64,
}

/// The next arrival of a ground change still to come.
fn next_arrival(pending: &[PendingChange]) -> Option<u64> {
    pending
        .iter()
        .map(|p| p.arrives_us)
        .filter(|&t| t != u64::MAX)
        .min()
}

/// What watches the executor the simulation drives (the emulated target, which runs the same
/// executor and must decide the same; tests that keep the decisions). An error ends the run
/// with it.
pub trait StepWatch {
    /// An executor was built (at the start, and at each model uplink) from these inputs, as
    /// [`Executor::new`] takes them without a plan.
    fn built(
        &mut self,
        config: ExecConfig,
        model: &HtnModel,
        network: &lander::htn::FlatNetwork,
        timeline: &lander::placement::TimelinePlacement,
        context: &lander::assessor::ScienceContext,
    ) -> Result<(), String> {
        let _ = (config, model, network, timeline, context);
        Ok(())
    }

    /// The executor answered `observation` with `directive` ([`step_to_answer`]); `exec` is
    /// the executor after the step (its log holds the step's decisions at its end).
    fn stepped(
        &mut self,
        observation: &Observation,
        directive: &Directive,
        exec: &Autonomy,
    ) -> Result<(), String> {
        let _ = (observation, directive, exec);
        Ok(())
    }
}

/// No watch.
impl StepWatch for () {}

/// One step as the planner partition answers it: the search runs `budget` explorations a
/// call, and the executor is called again (with the same observation, its event already
/// taken) while it answers [`Directive::Planning`], so the simulation sees only the step's
/// final directive and its mission time does not depend on how the search was split.
pub fn step_to_answer(exec: &mut Autonomy, observation: &Observation, budget: u32) -> Directive {
    let mut directive = exec.step(observation, budget);
    let again = Observation {
        event: None,
        ..*observation
    };
    while let Directive::Planning { .. } = directive {
        directive = exec.step(&again, budget);
    }
    directive
}

/// Runs one mission of scenario `s` under `config`.
pub fn run(s: &Scenario, config: &RunConfig) -> Result<RunResult, String> {
    run_watched(s, config, &mut ())
}

/// [`run`], with `watch` told of every executor built and every step.
pub fn run_watched(
    s: &Scenario,
    config: &RunConfig,
    watch: &mut dyn StepWatch,
) -> Result<RunResult, String> {
    let (mut model, net, timeline, context) = autonomy_inputs(s, config.prescient)?;
    let mut exec: Box<Autonomy> = Box::new(
        Executor::new(
            ExecConfig::new(config.strategy),
            &model,
            &net,
            &timeline,
            &context,
            None,
        )
        .map_err(|e| format!("the executor refused the plan: {e:?}"))?,
    );
    watch.built(
        ExecConfig::new(config.strategy),
        &model,
        &net,
        &timeline,
        &context,
    )?;
    // The world's truth: the model's priors (prescient: bias-scaled, as the planner's).
    let mut world = World::new(s, &model, config.seed, config.prescient);
    let _ = exec.set_comms(Some(world.comms_model()));
    let battery_start = world.battery_mj;
    let horizon = horizon_us(s);
    let replan_us = s.replan.duration_min * MIN_US;
    let replan_mj = s.replan.energy_wh * WH_MJ;
    let mut event = None;
    let mut dispatched = 0u32;
    let mut completed = 0u32;
    let mut failures = [0u32; 3];
    let mut replans_charged = 0u32;
    let mut analyzed = 0u32;
    let mut negatives = 0u32;
    let mut collections = Vec::new();
    let mut analyses = Vec::new();
    let mut hold_violations = 0u32;
    let mut options = rsm1_options(s);
    // Panoramas taken (the preamble's first, the panorama tasks' after it).
    let mut panoramas_taken = 0u8;
    let mut preamble_done = false;
    // Counters of the executors replaced by model uplinks.
    let mut past = lander::executor::ExecStats::default();
    let mut applied = Vec::new();
    let mut pending: Vec<PendingChange> = s
        .ground
        .changes
        .iter()
        .enumerate()
        .map(|(index, c)| {
            let decided = c.at_h.map_or(u64::MAX, |h| h * HOUR_US);
            PendingChange {
                index,
                decided_us: decided,
                arrives_us: if decided == u64::MAX {
                    u64::MAX
                } else {
                    world.earth.next_uplink(decided) + world.light_us
                },
            }
        })
        .collect();
    // The last dispatched primitive's chain, and whether it was the chain's last.
    let mut last_dispatch: Option<(u16, bool)> = None;
    let spec_of = |exec: &Autonomy, model: &HtnModel| {
        exec.remaining()
            .first()
            .and_then(|st| model.primitives.get(usize::from(st.primitive)))
            .cloned()
    };
    let mut end = EndReason::MissionEnd;
    for _ in 0..1_000_000 {
        trace::with(|t| t.loop_top(&world));
        if world.dead {
            end = EndReason::BatteryExhausted;
            break;
        }
        if world.now >= horizon {
            end = EndReason::MissionEnd;
            break;
        }
        // Ground changes on board: a rate or allowance at once, a model at a chain boundary.
        if event.is_none() {
            let boundary = match (exec.remaining().first(), last_dispatch) {
                (None, _) | (_, None) => true,
                (Some(step), Some((chain, last))) => last || step.chain != chain,
            };
            let mut k = 0;
            while k < pending.len() {
                let p = &pending[k];
                let change = &s.ground.changes[p.index];
                if p.arrives_us > world.now || (change.changes_model() && !boundary) {
                    k += 1;
                    continue;
                }
                let p = pending.remove(k);
                if let Some(r) = change.rate_bps {
                    world.rate_bps = r;
                }
                if let Some(w) = change.per_sol_wh {
                    world.per_sol_mj = w * WH_MJ;
                }
                let _ = exec.set_comms(Some(world.comms_model()));
                if change.changes_model() {
                    let mut context = exec.context().clone();
                    for (site, &v) in context.sites.iter_mut().zip(&change.site_values) {
                        site.estimated =
                            lander::utility::Score::new((milli(v).clamp(0, 1_000) * 10) as u32)
                                .unwrap_or(lander::utility::Score::ZERO);
                    }
                    if let Some(t) = change.targets_per_site {
                        options.targets_per_site = t;
                    }
                    // The new model holds the panoramas still to take.
                    let tasks_done = panoramas_taken.saturating_sub(u8::from(preamble_done));
                    options.panoramas = s.mission.panoramas.saturating_sub(tasks_done);
                    let stats = *exec.stats();
                    past.retries += stats.retries;
                    past.replans += stats.replans;
                    past.ground_halts += stats.ground_halts;
                    let (m, e) = rebuild(
                        s,
                        options,
                        &context,
                        world.now,
                        world.battery_mj,
                        config.strategy,
                        preamble_done,
                        watch,
                    )?;
                    model = m;
                    exec = e;
                    let _ = exec.set_comms(Some(world.comms_model()));
                    replans_charged = 0;
                    last_dispatch = None;
                }
                applied.push(AppliedChange {
                    index: p.index,
                    decided_us: p.decided_us,
                    arrived_us: p.arrives_us,
                    applied_us: world.now,
                });
            }
        }
        let preconditions_met =
            spec_of(&exec, &model).is_none_or(|spec| world.preconditions(&spec));
        let _ = exec.set_onboard_data(&world.onboard_products());
        let observation = Observation {
            now: MissionTimeUs(world.now),
            battery_mj: world.battery_mj,
            preconditions_met,
            event: event.take(),
        };
        let directive = step_to_answer(&mut exec, &observation, config.budget);
        watch.stepped(&observation, &directive, &exec)?;
        let replans = exec.stats().replans;
        while replans_charged < replans {
            replans_charged += 1;
            let to = world.now + replan_us;
            if !(world.advance(to) && world.spend(replan_mj)) {
                break;
            }
        }
        trace::with(|t| t.step(&world, &directive, exec.stats()));
        match directive {
            Directive::Dispatch {
                chain,
                primitive,
                expected_end,
                ..
            } => {
                let Some(spec) = model.primitives.get(usize::from(primitive)).cloned() else {
                    return Err(format!(
                        "the executor dispatched unknown primitive {primitive}"
                    ));
                };
                let chain_info = exec.network().chains.get(usize::from(chain));
                if world.hold_in_force() && chain_info.is_some_and(|c| c.waits_for_ground_release) {
                    hold_violations += 1;
                }
                last_dispatch = Some((
                    chain,
                    exec.remaining().first().is_none_or(|st| st.last_in_chain),
                ));
                dispatched += 1;
                let start = world.now;
                if is_downlink(spec.kind) {
                    let payload = exec.downlink_payload().to_vec();
                    world.commanded = Some((expected_end.0.saturating_sub(start), payload));
                }
                let (outcome, class) = world.execute(chain, primitive, &spec);
                trace::with(|t| {
                    t.dispatched(&world, chain, primitive, &spec, start, &outcome, class)
                });
                if let Some(f) = failures.get_mut(usize::from(class)) {
                    *f += 1;
                }
                if outcome.result == TaskResult::Succeeded && !world.dead {
                    completed += 1;
                    match spec.kind {
                        PrimitiveKind::ScienceAnalyze => {
                            analyzed += 1;
                            let negative = outcome.biosignature == Some(Biosignature::Negative);
                            if negative {
                                negatives += 1;
                            }
                            if let Some((site, target)) = world.instrument {
                                analyses.push(SampleEvent {
                                    at_us: start,
                                    site,
                                    target,
                                    positive: outcome
                                        .biosignature
                                        .map(|b| b == Biosignature::Positive),
                                });
                            }
                        }
                        PrimitiveKind::CollectSample => {
                            if let (Some(site), Some(target)) = (spec.site, spec.target) {
                                collections.push(SampleEvent {
                                    at_us: start,
                                    site,
                                    target,
                                    positive: None,
                                });
                                let n = collections.len() as u32;
                                for p in pending.iter_mut() {
                                    if s.ground.changes[p.index].after_samples == Some(n) {
                                        p.decided_us = world.now;
                                        p.arrives_us = world.ground_answer_at(world.now);
                                    }
                                }
                            }
                        }
                        PrimitiveKind::TakeMonoPanorama => {
                            panoramas_taken = panoramas_taken.saturating_add(1);
                        }
                        PrimitiveKind::FindExcavationSites => preamble_done = true,
                        PrimitiveKind::DownlinkWithGroundHold => world.set_hold(),
                        PrimitiveKind::Uplink => world.uplink(start),
                        _ => {}
                    }
                }
                event = Some(Event::Finished(outcome));
            }
            Directive::Wait { until } => {
                // Stop for a ground change arriving on the way.
                let next = next_arrival(&pending).unwrap_or(u64::MAX);
                world.advance(until.0.min(next).max(world.now).min(horizon));
            }
            Directive::Pushing { deadline } => {
                let next = world
                    .blocks
                    .iter()
                    .map(|b| b.until)
                    .filter(|&u| u > world.now)
                    .min()
                    .map_or(deadline.0, |u| u.min(deadline.0))
                    .min(next_arrival(&pending).unwrap_or(u64::MAX));
                world.advance(next.max(world.now + 1).min(horizon));
            }
            Directive::Planning { .. } | Directive::Running { .. } => {}
            Directive::HaltedForGround { .. } => {
                let at = world.ground_answer_at(world.now);
                if at >= horizon {
                    world.advance(horizon);
                    end = EndReason::MissionEnd;
                    break;
                }
                if world.advance(at) {
                    let spec = spec_of(&exec, &model);
                    world.ground_fix(spec.as_ref());
                    event = Some(Event::GroundResume);
                }
            }
            Directive::Abandoned { .. } => {
                end = EndReason::Abandoned;
                break;
            }
            Directive::Done => {
                // A model uplink still to come brings a new plan: wait for it.
                let next = pending
                    .iter()
                    .filter(|p| s.ground.changes[p.index].changes_model())
                    .map(|p| p.arrives_us)
                    .min();
                match next {
                    Some(t) if t < horizon => {
                        world.advance(t.max(world.now));
                    }
                    _ => {
                        end = EndReason::Done;
                        break;
                    }
                }
            }
        }
    }
    trace::with(|t| t.end(&world));
    if world.dead {
        end = EndReason::BatteryExhausted;
    }
    let stats = *exec.stats();
    let mut products = std::mem::take(&mut world.sent);
    products.extend(world.stored.iter().cloned());
    Ok(RunResult {
        seed: config.seed,
        utility_milli: realised_of(&products),
        end,
        end_us: world.now,
        battery_start_mj: battery_start,
        battery_end_mj: world.battery_mj,
        dispatched,
        completed,
        failures,
        retries: past.retries + stats.retries,
        replans: past.replans + stats.replans,
        ground_halts: past.ground_halts + stats.ground_halts,
        samples_analyzed: analyzed,
        negatives,
        downlinks: std::mem::take(&mut world.downlinks),
        unsent: world.stored.len() as u32,
        products,
        collections,
        analyses,
        holds_set: world.holds_set,
        holds_released: world.holds_released,
        hold_violations,
        changes: applied,
    })
}
