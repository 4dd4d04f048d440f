//! A lander scenario: the mission (the reference model's size, sols, battery), and the world
//! the simulation plays (power, thermal, sampling, science, seismometer, comms, ground, task
//! failures, energy noise, the cost of a replan). Units are in the field names (`_h`, `_min`,
//! `_wh`, `_w`, `_k`, `_bps`, `_bytes`); probabilities and fractions are numbers in [0, 1],
//! turned into integer parts per million when the simulation is built, so that a run is integer
//! arithmetic from there on.
//!
//! The files live in `scenarios/lander/` (TOML); `hil` reads them and reports bad input at
//! file:line:column ([`Scenario::validate`] names the field of each error). [`Scenario::bsm1`]
//! is the built-in BSM-1, equal to `scenarios/lander/bsm-1.toml` (a test checks it).
use serde::{Deserialize, Serialize};

/// The whole scenario.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub mission: Mission,
    #[serde(default)]
    pub power: Power,
    #[serde(default)]
    pub thermal: Thermal,
    #[serde(default)]
    pub sampling: Sampling,
    #[serde(default)]
    pub science: Science,
    #[serde(default)]
    pub seismometer: Seismometer,
    #[serde(default)]
    pub comms: Comms,
    #[serde(default)]
    pub ground: Ground,
    #[serde(default)]
    pub failures: Failures,
    #[serde(default)]
    pub energy: EnergyNoise,
    #[serde(default)]
    pub replan: ReplanCost,
    /// Data product volumes, per tier, against the model's.
    #[serde(default)]
    pub data: DataVolume,
    /// How `hil lander run` runs the scenario (the study sets its own strategies and seeds).
    #[serde(default)]
    pub run: RunSpec,
    /// Success criteria, checked at the end of a run ([`crate::expect`]).
    #[serde(default)]
    pub expect: Vec<crate::expect::Expectation>,
}

/// The mission: the reference model (`lander::rsm1`) at this size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mission {
    /// Europa sols (85 h each) of the planning horizon.
    pub sols: u64,
    pub battery_wh: u64,
    pub sites: u8,
    pub targets_per_site: u8,
    pub panoramas: u8,
    /// Exogenous uplinks in the plan (one per Earth-in-view period).
    #[serde(default)]
    pub uplinks: u8,
    /// No ground holds (BSM-1: no ground in the loop).
    #[serde(default = "yes")]
    pub fully_autonomous: bool,
}

fn yes() -> bool {
    true
}

/// The battery's loads and exogenous drops.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Power {
    /// Continuous hotel load.
    pub hotel_w: u64,
    /// Added while the seismometer is on.
    pub seismometer_w: u64,
    /// Exogenous drops of charge.
    pub drops: Vec<Drop>,
    /// State of charge at the start, as a fraction of `mission.battery_wh` (the lander knows
    /// it: its plan starts from this charge).
    pub start_soc: f64,
}

impl Default for Power {
    fn default() -> Self {
        Self {
            hotel_w: 8,
            seismometer_w: 2,
            drops: Vec::new(),
            start_soc: 1.0,
        }
    }
}

/// A sudden loss of charge at a mission time: `wh` lost, or (`to_soc`) the charge falls to
/// this fraction of `mission.battery_wh` if it is above it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Drop {
    pub at_h: u64,
    #[serde(default)]
    pub wh: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to_soc: Option<f64>,
}

/// Heating: excavation, collection and analysis heat their hardware to the operating
/// temperature first; the priors are written for the baseline ambient temperature.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Thermal {
    pub ambient_k: u64,
    pub baseline_k: u64,
    pub operating_k: u64,
    /// The part of a heated primitive's time and energy that is heating at the baseline.
    pub heating_fraction: f64,
}

impl Default for Thermal {
    fn default() -> Self {
        Self {
            ambient_k: 100,
            baseline_k: 100,
            operating_k: 250,
            heating_fraction: 0.2,
        }
    }
}

/// Excavation: progress at a noisy rate to a required depth; a site may have a depth it cannot
/// be dug past; a trench may collapse and lose progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Sampling {
    pub required_depth_cm: u64,
    /// Mean rate: by default the one the excavation prior assumes (required depth over the
    /// prior's duration).
    pub rate_cm_per_h: Option<f64>,
    /// Relative standard deviation of the rate, per excavation.
    pub rate_sd: f64,
    /// Per site, the depth it cannot be dug past (absent or 0: none).
    pub depth_limit_cm: Vec<u64>,
    /// Probability per hour of digging that the trench collapses.
    pub collapse_per_h: f64,
    /// Progress lost in a collapse.
    pub collapse_cm: u64,
}

impl Default for Sampling {
    fn default() -> Self {
        Self {
            required_depth_cm: 60,
            rate_cm_per_h: None,
            rate_sd: 0.0,
            depth_limit_cm: Vec::new(),
            collapse_per_h: 0.0,
            collapse_cm: 20,
        }
    }
}

/// Biosignature outcomes and the value of analysis data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Science {
    /// Per run, each site is positive with this probability (all its targets then positive,
    /// with a strength drawn from 0.5..1), else negative. Targets listed in `targets` override.
    pub p_site_positive: f64,
    /// Fixed outcomes.
    pub targets: Vec<TargetOutcome>,
    /// The value of a negative sample's analysis data, as a fraction of its nominal value (a
    /// positive one is worth 1 + strength times its nominal value).
    pub negative_value: f64,
}

impl Default for Science {
    fn default() -> Self {
        Self {
            p_site_positive: 0.7,
            targets: Vec::new(),
            negative_value: 0.25,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetOutcome {
    pub site: u8,
    pub target: u8,
    pub positive: bool,
    #[serde(default)]
    pub strength: f64,
}

/// The seismometer: continuous data while on, and quakes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Seismometer {
    pub bytes_per_h: u64,
    /// Value of 1 MB of continuous data (Residual tier), in value units.
    pub value_per_mb: f64,
    pub quakes_per_h: f64,
    pub quake_bytes: u64,
    /// Value of one quake record (Decisional tier).
    pub quake_value: u64,
}

impl Default for Seismometer {
    fn default() -> Self {
        Self {
            bytes_per_h: 50_000,
            value_per_mb: 0.5,
            quakes_per_h: 0.01,
            quake_bytes: 500_000,
            quake_value: 5,
        }
    }
}

/// The link to Earth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Comms {
    /// Earth is in view for `in_view_h` of every `period_h`, from time 0.
    pub period_h: u64,
    pub in_view_h: u64,
    pub rate_bps: u64,
    pub light_time_min: u64,
    pub radio_w: u64,
    /// Set-up time of a downlink before data flows.
    pub overhead_min: u64,
    /// Longest transmission in one downlink before the radio must cool.
    pub thermal_limit_h: u64,
    pub per_downlink_wh: u64,
    pub per_sol_wh: u64,
}

impl Default for Comms {
    fn default() -> Self {
        Self {
            period_h: 84,
            in_view_h: 42,
            rate_bps: 50_000,
            light_time_min: 45,
            radio_w: 60,
            overhead_min: 20,
            thermal_limit_h: 3,
            per_downlink_wh: 200,
            per_sol_wh: 400,
        }
    }
}

/// The ground: it sees a halt at the next Earth-in-view plus the light time, works on it, and
/// answers at the next uplink window. It releases ground holds (a hold set by a downlink with
/// ground hold is released by the first uplink that starts once the ground has had the
/// downlinked data for `response_h`), and it uplinks changes ([`GroundChange`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ground {
    /// Uplink windows: these offsets into every Earth-in-view period.
    pub uplink_offsets_h: Vec<u64>,
    /// Between the ground seeing a problem and its answer being ready to uplink.
    pub response_h: u64,
    /// Changes the ground uplinks during the mission.
    pub changes: Vec<GroundChange>,
}

impl Default for Ground {
    fn default() -> Self {
        Self {
            uplink_offsets_h: vec![1, 13, 25, 37],
            response_h: 4,
            changes: Vec::new(),
        }
    }
}

/// A change the ground makes (seed 000 II.D: onboard state values, task parameters, the task
/// network), with its delay: decided at `at_h` (it goes up at the next uplink window and is on
/// board a light time later), or in reaction to the lander's `after_samples`-th sample
/// collection (the ground sees it at the next Earth-in-view plus the light time, answers
/// `ground.response_h` later at the next uplink window). Exactly one trigger.
///
/// A new value or model is a model uplink: the executor is rebuilt at the next chain boundary
/// from the state (time, charge, the science context it has learned) with the new model, and
/// plans from there; a new rate applies on arrival.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundChange {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_h: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub after_samples: Option<u32>,
    /// New estimated science values of the sites, in site order (the excavation order).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub site_values: Vec<f64>,
    /// A new mission model that samples only the first this many targets of each site,
    /// whatever their science value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub targets_per_site: Option<u8>,
    /// A new DSN downlink rate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_bps: Option<u64>,
    /// A new per-sol communication energy allowance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_sol_wh: Option<u64>,
    /// Task parameters the ground sets (a model uplink, like a new model: the executor is
    /// rebuilt with them among what it has learned).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parameters: Vec<GroundParameter>,
}

/// A task's duration and energy at a site, set by the ground (seed 000 II.D's task parameters;
/// IV.C.3's model parameters, not only measured): they replace the model's prior and what the
/// lander measured for every primitive of that kind at that site, until the lander measures
/// one again.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundParameter {
    /// The primitive task, snake case: `collect_sample`, `excavate_site`,
    /// `find_collection_targets`, ... (the kinds that take a site).
    pub task: String,
    pub site: u8,
    pub duration_min: u64,
    pub energy_wh: u64,
}

/// The primitive kind named `name` in snake case (`collect_sample` is
/// `PrimitiveKind::CollectSample`).
pub fn kind_named(name: &str) -> Option<lander::htn::PrimitiveKind> {
    lander::htn::PrimitiveKind::ALL
        .into_iter()
        .find(|k| snake_case(&format!("{k:?}")) == name)
}

fn snake_case(camel: &str) -> String {
    let mut out = String::new();
    for (i, c) in camel.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

impl GroundChange {
    /// Whether the change is a model uplink (the executor is rebuilt).
    pub fn changes_model(&self) -> bool {
        !self.site_values.is_empty()
            || self.targets_per_site.is_some()
            || !self.parameters.is_empty()
    }
}

/// Data volumes: each product of a tier is this many times the model's size (seed 000 V.B.1
/// scenarios 7 and 12: "significantly more" decisional or mandatory data). The autonomy's
/// model keeps its sizes: the lander does not know.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DataVolume {
    pub critical: f64,
    pub decisional: f64,
    pub mandatory: f64,
    pub residual: f64,
}

impl Default for DataVolume {
    fn default() -> Self {
        Self {
            critical: 1.0,
            decisional: 1.0,
            mandatory: 1.0,
            residual: 1.0,
        }
    }
}

/// The strategy, as a scenario names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StrategyName {
    Static,
    Ground,
    Fe,
    Replan,
}

impl StrategyName {
    pub fn strategy(self) -> lander::executor::Strategy {
        use lander::executor::Strategy as S;
        match self {
            Self::Static => S::Static,
            Self::Ground => S::Ground,
            Self::Fe => S::FlexibleExecution,
            Self::Replan => S::Replan,
        }
    }
}

/// How a single run of the scenario is made (`hil lander run`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RunSpec {
    pub strategy: StrategyName,
    pub seed: u64,
}

impl Default for RunSpec {
    fn default() -> Self {
        Self {
            strategy: StrategyName::Replan,
            seed: 1,
        }
    }
}

/// Task failures (V.A): every dispatch fails with `p_fail`; a failure is resolvable by flexible
/// execution (`p_fe`), by replanning (`p_replan`) or only by the ground (`p_ground`), which sum
/// to `p_fail`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Failures {
    pub p_fail: f64,
    pub p_fe: f64,
    pub p_replan: f64,
    pub p_ground: f64,
    /// The part of its time and energy a failed attempt spends.
    pub failed_attempt_fraction: f64,
    /// A failure only replanning (or the ground) resolves leaves the primitive's preconditions
    /// unmet this long (the target is lost; a retry cannot work).
    pub replan_block_min: u64,
}

impl Default for Failures {
    fn default() -> Self {
        Self {
            p_fail: 0.1,
            p_fe: 0.03,
            p_replan: 0.042,
            p_ground: 0.028,
            failed_attempt_fraction: 0.5,
            replan_block_min: 30,
        }
    }
}

/// Energy noise (V.A): each dispatch spends its prior times 1 + bias + sd * N(0, 1) (at least 0).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EnergyNoise {
    pub sd: f64,
    pub bias: f64,
}

impl Default for EnergyNoise {
    fn default() -> Self {
        Self { sd: 0.1, bias: 0.0 }
    }
}

/// What a replan costs the lander (the planner's CPU time at its power).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReplanCost {
    pub duration_min: u64,
    pub energy_wh: u64,
}

impl Default for ReplanCost {
    fn default() -> Self {
        Self {
            duration_min: 10,
            energy_wh: 2,
        }
    }
}

/// A field that is wrong, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldError {
    /// TOML path, e.g. `failures.p_fe`.
    pub field: String,
    pub message: String,
}

fn fraction(errors: &mut Vec<FieldError>, field: &str, x: f64) {
    if !(0.0..=1.0).contains(&x) {
        errors.push(FieldError {
            field: field.into(),
            message: format!("{x} is not a probability or fraction in [0, 1]"),
        });
    }
}

fn positive(errors: &mut Vec<FieldError>, field: &str, x: u64) {
    if x == 0 {
        errors.push(FieldError {
            field: field.into(),
            message: "must be at least 1".into(),
        });
    }
}

/// Parts per million of a fraction in [0, 1].
pub fn ppm(x: f64) -> u32 {
    (x.clamp(0.0, 1.0) * 1_000_000.0).round() as u32
}

/// Thousandths of a number (any sign).
pub fn milli(x: f64) -> i64 {
    (x * 1_000.0).round() as i64
}

impl Scenario {
    /// The built-in BSM-1 (seed 000 II.B.1, V.A): one site, three samples, seismometry and
    /// periodic panoramas, no ground in the loop.
    pub fn bsm1() -> Self {
        Self {
            name: "bsm-1".into(),
            description: "Basic Surface Mission 1 (seed 000 II.B.1, V.A): one site, three samples, seismometry and periodic panoramas, no ground in the loop".into(),
            mission: Mission {
                sols: 8,
                battery_wh: 5_500,
                sites: 1,
                targets_per_site: 3,
                panoramas: 4,
                uplinks: 0,
                fully_autonomous: true,
            },
            power: Power::default(),
            thermal: Thermal::default(),
            sampling: Sampling::default(),
            science: Science::default(),
            seismometer: Seismometer::default(),
            comms: Comms::default(),
            ground: Ground::default(),
            failures: Failures::default(),
            energy: EnergyNoise::default(),
            replan: ReplanCost::default(),
            data: DataVolume::default(),
            run: RunSpec::default(),
            expect: Vec::new(),
        }
    }

    /// Every error of the scenario's values (the types are TOML's business).
    pub fn validate(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        let m = &self.mission;
        positive(&mut e, "mission.sols", m.sols);
        positive(&mut e, "mission.battery_wh", m.battery_wh);
        positive(&mut e, "mission.sites", u64::from(m.sites));
        positive(
            &mut e,
            "mission.targets_per_site",
            u64::from(m.targets_per_site),
        );
        if m.sites > 3 || m.targets_per_site > 3 {
            e.push(FieldError {
                field: if m.sites > 3 {
                    "mission.sites"
                } else {
                    "mission.targets_per_site"
                }
                .into(),
                message: "the reference model has at most 3 sites of 3 targets (the subway map)"
                    .into(),
            });
        }
        if m.sols > lander::capacity::MAX_SOLS as u64 {
            e.push(FieldError {
                field: "mission.sols".into(),
                message: format!("at most {} sols", lander::capacity::MAX_SOLS),
            });
        }
        fraction(
            &mut e,
            "thermal.heating_fraction",
            self.thermal.heating_fraction,
        );
        if self.thermal.operating_k <= self.thermal.baseline_k
            || self.thermal.operating_k <= self.thermal.ambient_k
        {
            e.push(FieldError {
                field: "thermal.operating_k".into(),
                message: "must be above the ambient and baseline temperatures".into(),
            });
        }
        positive(
            &mut e,
            "sampling.required_depth_cm",
            self.sampling.required_depth_cm,
        );
        if let Some(r) = self.sampling.rate_cm_per_h {
            if r.is_nan() || r <= 0.0 {
                e.push(FieldError {
                    field: "sampling.rate_cm_per_h".into(),
                    message: format!("{r} is not a positive rate"),
                });
            }
        }
        fraction(&mut e, "sampling.rate_sd", self.sampling.rate_sd);
        fraction(
            &mut e,
            "sampling.collapse_per_h",
            self.sampling.collapse_per_h,
        );
        fraction(
            &mut e,
            "science.p_site_positive",
            self.science.p_site_positive,
        );
        fraction(
            &mut e,
            "science.negative_value",
            self.science.negative_value,
        );
        for (i, t) in self.science.targets.iter().enumerate() {
            fraction(
                &mut e,
                &format!("science.targets[{i}].strength"),
                t.strength,
            );
            if t.site >= m.sites || t.target >= m.targets_per_site {
                e.push(FieldError {
                    field: format!("science.targets[{i}]"),
                    message: format!(
                        "no target ({}, {}): the mission has {} site(s) of {} target(s)",
                        t.site, t.target, m.sites, m.targets_per_site
                    ),
                });
            }
        }
        fraction(
            &mut e,
            "seismometer.quakes_per_h",
            self.seismometer.quakes_per_h,
        );
        let c = &self.comms;
        positive(&mut e, "comms.period_h", c.period_h);
        positive(&mut e, "comms.rate_bps", c.rate_bps);
        if c.in_view_h == 0 || c.in_view_h > c.period_h {
            e.push(FieldError {
                field: "comms.in_view_h".into(),
                message: format!("must be in 1..={} (the period)", c.period_h),
            });
        }
        if self.ground.uplink_offsets_h.is_empty() {
            e.push(FieldError {
                field: "ground.uplink_offsets_h".into(),
                message: "the ground needs at least one uplink window".into(),
            });
        }
        for (i, &o) in self.ground.uplink_offsets_h.iter().enumerate() {
            if o >= c.in_view_h {
                e.push(FieldError {
                    field: format!("ground.uplink_offsets_h[{i}]"),
                    message: format!(
                        "{o} h is not inside the Earth-in-view period ({} h)",
                        c.in_view_h
                    ),
                });
            }
        }
        let f = &self.failures;
        for (field, x) in [
            ("failures.p_fail", f.p_fail),
            ("failures.p_fe", f.p_fe),
            ("failures.p_replan", f.p_replan),
            ("failures.p_ground", f.p_ground),
            (
                "failures.failed_attempt_fraction",
                f.failed_attempt_fraction,
            ),
        ] {
            fraction(&mut e, field, x);
        }
        let sum = ppm(f.p_fe) + ppm(f.p_replan) + ppm(f.p_ground);
        if sum != ppm(f.p_fail) {
            e.push(FieldError {
                field: "failures.p_fail".into(),
                message: format!(
                    "p_fe + p_replan + p_ground = {} but p_fail = {} (each failure has one resolvability class)",
                    f64::from(sum) / 1e6,
                    f.p_fail
                ),
            });
        }
        if !(0.0..=1.0).contains(&self.energy.sd) {
            e.push(FieldError {
                field: "energy.sd".into(),
                message: format!("{} is not a relative sd in [0, 1]", self.energy.sd),
            });
        }
        if !(-0.9..=1.0).contains(&self.energy.bias) {
            e.push(FieldError {
                field: "energy.bias".into(),
                message: format!("{} is not a relative bias in [-0.9, 1]", self.energy.bias),
            });
        }
        fraction(&mut e, "power.start_soc", self.power.start_soc);
        for (i, d) in self.power.drops.iter().enumerate() {
            match d.to_soc {
                Some(x) => {
                    fraction(&mut e, &format!("power.drops[{i}].to_soc"), x);
                    if d.wh != 0 {
                        e.push(FieldError {
                            field: format!("power.drops[{i}].wh"),
                            message: "give wh or to_soc, not both".into(),
                        });
                    }
                }
                None => positive(&mut e, &format!("power.drops[{i}].wh"), d.wh),
            }
        }
        for (field, x) in [
            ("data.critical", self.data.critical),
            ("data.decisional", self.data.decisional),
            ("data.mandatory", self.data.mandatory),
            ("data.residual", self.data.residual),
        ] {
            if x.is_nan() || !(0.0..=1_000.0).contains(&x) {
                e.push(FieldError {
                    field: field.into(),
                    message: format!("{x} is not a volume factor in [0, 1000]"),
                });
            }
        }
        for (i, c) in self.ground.changes.iter().enumerate() {
            let at = format!("ground.changes[{i}]");
            if c.at_h.is_some() == c.after_samples.is_some() {
                e.push(FieldError {
                    field: at.clone(),
                    message: "give exactly one trigger: at_h or after_samples".into(),
                });
            }
            if c.after_samples == Some(0) {
                e.push(FieldError {
                    field: format!("{at}.after_samples"),
                    message: "must be at least 1".into(),
                });
            }
            if !c.changes_model() && c.rate_bps.is_none() && c.per_sol_wh.is_none() {
                e.push(FieldError {
                    field: at.clone(),
                    message: "changes nothing: give site_values, targets_per_site, parameters, rate_bps or per_sol_wh".into(),
                });
            }
            if !c.site_values.is_empty() && c.site_values.len() != usize::from(m.sites) {
                e.push(FieldError {
                    field: format!("{at}.site_values"),
                    message: format!("{} value(s) for {} site(s)", c.site_values.len(), m.sites),
                });
            }
            for (k, &v) in c.site_values.iter().enumerate() {
                fraction(&mut e, &format!("{at}.site_values[{k}]"), v);
            }
            if let Some(t) = c.targets_per_site {
                if t == 0 || t > m.targets_per_site {
                    e.push(FieldError {
                        field: format!("{at}.targets_per_site"),
                        message: format!("must be in 1..={}", m.targets_per_site),
                    });
                }
            }
            for (k, p) in c.parameters.iter().enumerate() {
                let field = format!("{at}.parameters[{k}]");
                let sited = ["excavate_site", "find_collection_targets", "collect_sample"];
                if kind_named(&p.task).is_none() {
                    e.push(FieldError {
                        field: format!("{field}.task"),
                        message: format!("unknown task {:?}: one of {sited:?}", p.task),
                    });
                }
                if p.site >= m.sites {
                    e.push(FieldError {
                        field: format!("{field}.site"),
                        message: format!("must be below {} (the sites)", m.sites),
                    });
                }
                if p.duration_min == 0 || p.duration_min > 100 * 24 * 60 {
                    e.push(FieldError {
                        field: format!("{field}.duration_min"),
                        message: "must be in 1..=144000 (100 days)".into(),
                    });
                }
                if p.energy_wh > 1_000_000 {
                    e.push(FieldError {
                        field: format!("{field}.energy_wh"),
                        message: "must be at most 1000000".into(),
                    });
                }
            }
            if c.rate_bps == Some(0) {
                e.push(FieldError {
                    field: format!("{at}.rate_bps"),
                    message: "must be at least 1".into(),
                });
            }
        }
        e.extend(crate::expect::validate(
            &self.expect,
            m,
            self.ground.changes.len(),
        ));
        e
    }
}
