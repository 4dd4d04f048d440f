//! The strategy study of seed 000 V.A (issue 12 item 4): a scenario (BSM-1) under each of the
//! four strategies and each energy variant (unbiased 10% sd, +10%, -10%), `runs` runs per cell.
//!
//! Run `r` of every cell uses seed `seed + r`: the strategies of a variant see the same
//! biosignatures, quakes, and failure and noise draws for their n-th dispatch (common random
//! numbers), so their differences are the strategies'. Per cell: the mean utility with a 95%
//! confidence interval (Student's t). Beside it, the analytical model of equations 2-5 with
//! u_avg from prescient runs (no failures, no noise, the planner's priors equal to the true,
//! bias-scaled costs), as the paper does; see [`ModelInputs`] for how each term is taken.
//!
//! Sharding: the study's jobs are (cell, run) in a fixed order, job `j` = cell index * runs +
//! run; shard `k/n` runs the jobs with `j % n == k - 1`. A shard's report holds its runs;
//! [`merge`] puts reports back together and recomputes the cells, giving exactly the report of
//! the unsharded study (the report holds no wall time).
use lander::executor::Strategy;
use serde::{Deserialize, Serialize};

use crate::scenario::Scenario;
use crate::sim::{self, EndReason, RunConfig, World, MIN_US};

pub const STRATEGIES: [Strategy; 4] = [
    Strategy::Static,
    Strategy::Ground,
    Strategy::FlexibleExecution,
    Strategy::Replan,
];

pub fn strategy_name(s: Strategy) -> &'static str {
    match s {
        Strategy::Static => "Static",
        Strategy::Ground => "Ground",
        Strategy::FlexibleExecution => "FE",
        Strategy::Replan => "Replan",
    }
}

/// An energy variant (V.A): noise sd and bias.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Variant {
    pub name: String,
    pub sd: f64,
    pub bias: f64,
}

impl Variant {
    /// The paper's three: unbiased, +10% and -10%, each with 10% sd.
    pub fn paper() -> Vec<Variant> {
        [
            ("unbiased", 0.0),
            ("+10% energy", 0.1),
            ("-10% energy", -0.1),
        ]
        .into_iter()
        .map(|(name, bias)| Variant {
            name: name.into(),
            sd: 0.1,
            bias,
        })
        .collect()
    }
}

/// What a study is: the same config (and scenario) is required to merge shards.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StudyConfig {
    pub scenario: Scenario,
    pub runs: u32,
    pub seed: u64,
    /// Prescient runs per variant for the model's inputs.
    pub prescient_runs: u32,
    pub variants: Vec<Variant>,
}

impl StudyConfig {
    pub fn new(scenario: Scenario, runs: u32, seed: u64) -> Self {
        Self {
            scenario,
            runs,
            seed,
            prescient_runs: 20,
            variants: Variant::paper(),
        }
    }

    pub fn cells(&self) -> usize {
        self.variants.len() * STRATEGIES.len()
    }

    pub fn jobs(&self) -> u64 {
        self.cells() as u64 * u64::from(self.runs)
    }

    /// The scenario of a variant.
    pub fn scenario_of(&self, variant: &Variant) -> Scenario {
        let mut s = self.scenario.clone();
        s.energy.sd = variant.sd;
        s.energy.bias = variant.bias;
        s
    }
}

/// One run of the study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub job: u64,
    pub variant: String,
    pub strategy: String,
    pub run: u32,
    pub seed: u64,
    pub utility_milli: u64,
    pub end: EndReason,
    pub end_us: u64,
    pub energy_spent_mj: u64,
    pub dispatched: u32,
    pub failures: [u32; 3],
    pub retries: u32,
    pub replans: u32,
    pub ground_halts: u32,
    pub samples_analyzed: u32,
    pub negatives: u32,
}

/// A cell's statistics (utility in the model's value units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    pub variant: String,
    pub strategy: String,
    pub runs: u32,
    pub mean: f64,
    pub sd: f64,
    /// The 95% confidence interval of the mean.
    pub ci95: [f64; 2],
    /// The analytical model's prediction (equations 2-5).
    pub model: f64,
    pub mean_samples: f64,
    pub mean_replans: f64,
    pub mean_ground_halts: f64,
}

/// The analytical model's inputs for one variant, and how each is taken:
/// - `u_prescient`, `e_prescient_wh`, `n_tasks`: the mean utility, energy spent (primitives,
///   hotel load, everything) and dispatches of the prescient runs (Static, no failures);
/// - `u_avg` = u_prescient / e_prescient (utility per Wh), `b_wh` = e_prescient: the budget the
///   prescient plan spends (the battery when it binds; the paper's b), `c_avg` = b / n;
/// - `c_g_wh`: the energy a ground intervention costs: the background load over the mean wait
///   from a failure (uniform over an Earth period) to the ground's answer on board;
/// - `c_r_wh`: a replan's energy plus the background load over its duration;
/// - `d_u_d`: utility discovery, measured: the mean over the prescient seeds of the prescient
///   Replan's utility minus the prescient Static's (what exploiting the biosignatures gained;
///   it can be negative).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelInputs {
    pub variant: String,
    pub u_prescient: f64,
    pub e_prescient_wh: f64,
    pub n_tasks: f64,
    pub u_avg: f64,
    pub b_wh: f64,
    pub c_avg_wh: f64,
    pub c_g_wh: f64,
    pub c_r_wh: f64,
    pub d_u_d: f64,
    pub p_fail: f64,
    pub p_fe: f64,
    pub p_replan: f64,
    pub p_ground: f64,
    /// Equations 2, 3, 4, 5 (Static, Ground, FE, Replan).
    pub predicted: [f64; 4],
}

/// The ordering of one variant's means.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ordering {
    pub variant: String,
    /// Strategies from lowest to highest mean, e.g. "Static < Ground < FE < Replan" (`=` for
    /// equal means).
    pub measured: String,
    pub model: String,
    /// Whether the measured means are strictly Static < Ground < FE < Replan (the paper's).
    pub matches_paper: bool,
    /// The pairs out of the paper's order, and whether their 95% intervals overlap.
    pub differences: Vec<String>,
}

/// The study's report (JSON). Deterministic: no wall time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StudyReport {
    pub config: StudyConfig,
    /// The shards whose runs this report holds ("2/4"); empty: the whole study.
    pub shards: Vec<String>,
    /// Whether every job is in this report.
    pub complete: bool,
    pub runs: Vec<RunRecord>,
    pub cells: Vec<Cell>,
    pub models: Vec<ModelInputs>,
    pub orderings: Vec<Ordering>,
}

/// Student's t quantile 0.975 for `df` degrees of freedom.
pub fn t975(df: u32) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => T[df as usize - 1],
        // 40: 2.021, 60: 2.000, 120: 1.980, inf: 1.960.
        _ => 1.960 + 2.4 / f64::from(df),
    }
}

/// Mean, sd and the 95% interval of `xs`.
pub fn mean_ci(xs: &[f64]) -> (f64, f64, [f64; 2]) {
    let n = xs.len();
    if n == 0 {
        return (0.0, 0.0, [0.0, 0.0]);
    }
    let mean = xs.iter().sum::<f64>() / n as f64;
    if n == 1 {
        return (mean, 0.0, [mean, mean]);
    }
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
    let sd = var.sqrt();
    let half = t975(n as u32 - 1) * sd / (n as f64).sqrt();
    (mean, sd, [mean - half, mean + half])
}

/// Whether job `job` is in shard `k/n` (1-based k).
pub fn in_shard(job: u64, shard: Option<(u32, u32)>) -> bool {
    shard.is_none_or(|(k, n)| job % u64::from(n) == u64::from(k - 1))
}

/// Runs the study (or one shard of it). `progress` is called after each run.
pub fn run_study(
    config: &StudyConfig,
    shard: Option<(u32, u32)>,
    progress: &mut dyn FnMut(&RunRecord),
) -> Result<StudyReport, String> {
    run_study_with(config, shard, progress, &mut |s, c| sim::run(s, c))
}

/// [`run_study`] with each run made by `run` (the emulated target's, `hil study --emulated`);
/// the analytical model's prescient runs stay native.
pub fn run_study_with(
    config: &StudyConfig,
    shard: Option<(u32, u32)>,
    progress: &mut dyn FnMut(&RunRecord),
    run: &mut dyn FnMut(&Scenario, &RunConfig) -> Result<sim::RunResult, String>,
) -> Result<StudyReport, String> {
    if let Some((k, n)) = shard {
        if k == 0 || n == 0 || k > n {
            return Err(format!("bad shard {k}/{n}: expected 1 <= k <= n"));
        }
    }
    let mut runs = Vec::new();
    for (vi, variant) in config.variants.iter().enumerate() {
        let scenario = config.scenario_of(variant);
        for (si, strategy) in STRATEGIES.iter().enumerate() {
            for r in 0..config.runs {
                let job =
                    (vi * STRATEGIES.len() + si) as u64 * u64::from(config.runs) + u64::from(r);
                if !in_shard(job, shard) {
                    continue;
                }
                let seed = config.seed.wrapping_add(u64::from(r));
                let result = run(&scenario, &RunConfig::new(*strategy, seed))?;
                let record = RunRecord {
                    job,
                    variant: variant.name.clone(),
                    strategy: strategy_name(*strategy).into(),
                    run: r,
                    seed,
                    utility_milli: result.utility_milli,
                    end: result.end,
                    end_us: result.end_us,
                    energy_spent_mj: result.energy_spent_mj(),
                    dispatched: result.dispatched,
                    failures: result.failures,
                    retries: result.retries,
                    replans: result.replans,
                    ground_halts: result.ground_halts,
                    samples_analyzed: result.samples_analyzed,
                    negatives: result.negatives,
                };
                progress(&record);
                runs.push(record);
            }
        }
    }
    let models = config
        .variants
        .iter()
        .map(|v| model_inputs(config, v))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(assemble(
        config.clone(),
        shard.map(|(k, n)| format!("{k}/{n}")).into_iter().collect(),
        runs,
        models,
    ))
}

/// The analytical model's inputs and predictions for `variant` (see [`ModelInputs`]).
pub fn model_inputs(config: &StudyConfig, variant: &Variant) -> Result<ModelInputs, String> {
    let s = config.scenario_of(variant);
    let (mut u, mut e, mut n, mut d) = (0.0, 0.0, 0.0, 0.0);
    let runs = config.prescient_runs.max(1);
    for r in 0..runs {
        let seed = config.seed.wrapping_add(u64::from(r));
        let mut c = RunConfig::new(Strategy::Static, seed);
        c.prescient = true;
        let stat = sim::run(&s, &c)?;
        c.strategy = Strategy::Replan;
        let replan = sim::run(&s, &c)?;
        u += stat.utility_milli as f64 / 1_000.0;
        e += stat.energy_spent_mj() as f64 / 3.6e6;
        n += f64::from(stat.dispatched);
        d += (replan.utility_milli as f64 - stat.utility_milli as f64) / 1_000.0;
    }
    let k = f64::from(runs);
    let (u, e, n, d) = (u / k, e / k, n / k, d / k);
    // Ground: the mean wait from a failure to the ground's answer, over one Earth period.
    let (model, ..) = sim::autonomy_inputs(&s, true)?;
    let world = World::new(&s, &model, 0, true);
    let period = world.earth.period_us;
    let step = 10 * MIN_US;
    let waits: Vec<u64> = (0..period / step)
        .map(|i| world.ground_answer_at(i * step) - i * step)
        .collect();
    let mean_wait_h = waits.iter().sum::<u64>() as f64 / waits.len() as f64 / 3.6e9;
    let load_w = (s.power.hotel_w + s.power.seismometer_w) as f64;
    let c_g = load_w * mean_wait_h;
    let c_r = s.replan.energy_wh as f64 + load_w * s.replan.duration_min as f64 / 60.0;
    let f = &s.failures;
    let u_avg = if e > 0.0 { u / e } else { 0.0 };
    let b = e;
    let c_avg = if n > 0.0 { b / n } else { 0.0 };
    let static_ = (u_avg * b).min(u_avg * c_avg * (1.0 - f.p_fail) / f.p_fail.max(1e-9));
    let ground = u_avg * (b - f.p_fail * n * c_g);
    let fe = u_avg * (b - (f.p_fail - f.p_fe) * n * c_g);
    let replan = d + u_avg * (b - n * (f.p_ground * c_g + f.p_replan * c_r));
    Ok(ModelInputs {
        variant: variant.name.clone(),
        u_prescient: u,
        e_prescient_wh: e,
        n_tasks: n,
        u_avg,
        b_wh: b,
        c_avg_wh: c_avg,
        c_g_wh: c_g,
        c_r_wh: c_r,
        d_u_d: d,
        p_fail: f.p_fail,
        p_fe: f.p_fe,
        p_replan: f.p_replan,
        p_ground: f.p_ground,
        predicted: [static_, ground, fe, replan],
    })
}

fn order_of(names: &[&str], values: &[f64]) -> String {
    let mut idx: Vec<usize> = (0..values.len()).collect();
    idx.sort_by(|&a, &b| values[a].total_cmp(&values[b]).then(a.cmp(&b)));
    let mut out = String::new();
    for (i, &j) in idx.iter().enumerate() {
        if i > 0 {
            out.push_str(if values[idx[i - 1]] == values[j] {
                " = "
            } else {
                " < "
            });
        }
        out.push_str(names[j]);
    }
    out
}

/// Builds the report from runs (any order) and model inputs: runs sorted by job, cells and
/// orderings computed from them.
pub fn assemble(
    config: StudyConfig,
    mut shards: Vec<String>,
    mut runs: Vec<RunRecord>,
    models: Vec<ModelInputs>,
) -> StudyReport {
    runs.sort_by_key(|r| r.job);
    shards.sort();
    let mut cells = Vec::new();
    let mut orderings = Vec::new();
    for (vi, v) in config.variants.iter().enumerate() {
        let model = models.get(vi);
        let mut means = Vec::new();
        let mut cis = Vec::new();
        for (si, strategy) in STRATEGIES.iter().enumerate() {
            let name = strategy_name(*strategy);
            let of: Vec<&RunRecord> = runs
                .iter()
                .filter(|r| r.variant == v.name && r.strategy == name)
                .collect();
            let xs: Vec<f64> = of
                .iter()
                .map(|r| r.utility_milli as f64 / 1_000.0)
                .collect();
            let (mean, sd, ci95) = mean_ci(&xs);
            let avg = |f: &dyn Fn(&RunRecord) -> u32| {
                if of.is_empty() {
                    0.0
                } else {
                    of.iter().map(|r| f64::from(f(r))).sum::<f64>() / of.len() as f64
                }
            };
            means.push(mean);
            cis.push(ci95);
            cells.push(Cell {
                variant: v.name.clone(),
                strategy: name.into(),
                runs: xs.len() as u32,
                mean,
                sd,
                ci95,
                model: model.map_or(0.0, |m| m.predicted[si]),
                mean_samples: avg(&|r| r.samples_analyzed),
                mean_replans: avg(&|r| r.replans),
                mean_ground_halts: avg(&|r| r.ground_halts),
            });
        }
        let names: Vec<&str> = STRATEGIES.iter().map(|s| strategy_name(*s)).collect();
        let mut differences = Vec::new();
        for i in 0..STRATEGIES.len() {
            for j in i + 1..STRATEGIES.len() {
                if means[i] >= means[j] {
                    let overlap = cis[i][0] <= cis[j][1] && cis[j][0] <= cis[i][1];
                    differences.push(format!(
                        "{} ({:.1}) >= {} ({:.1}){}",
                        names[i],
                        means[i],
                        names[j],
                        means[j],
                        if overlap {
                            ", 95% intervals overlap"
                        } else {
                            ", 95% intervals apart"
                        }
                    ));
                }
            }
        }
        orderings.push(Ordering {
            variant: v.name.clone(),
            measured: order_of(&names, &means),
            model: model.map_or(String::new(), |m| order_of(&names, &m.predicted)),
            matches_paper: differences.is_empty(),
            differences,
        });
    }
    let complete = runs.len() as u64 == config.jobs();
    if complete {
        shards.clear();
    }
    StudyReport {
        config,
        shards,
        complete,
        runs,
        cells,
        models,
        orderings,
    }
}

/// Merges shard reports into one: the same study (config and scenario), no job twice.
pub fn merge(reports: Vec<StudyReport>) -> Result<StudyReport, String> {
    let mut it = reports.into_iter();
    let first = it.next().ok_or("nothing to merge")?;
    let (config, models) = (first.config.clone(), first.models.clone());
    let mut shards = first.shards.clone();
    let mut runs = first.runs;
    for r in it {
        if r.config != config {
            return Err(format!(
                "cannot merge: shard {} is of a different study (scenario, runs, seed or variants differ)",
                r.shards.join("+")
            ));
        }
        if r.models != models {
            return Err(
                "cannot merge: the reports' model inputs differ (different builds?)".into(),
            );
        }
        shards.extend(r.shards);
        runs.extend(r.runs);
    }
    runs.sort_by_key(|r| r.job);
    if let Some(w) = runs.windows(2).find(|w| w[0].job == w[1].job) {
        return Err(format!(
            "cannot merge: job {} ({} {} run {}) is in two reports (overlapping shards)",
            w[0].job, w[0].variant, w[0].strategy, w[0].run
        ));
    }
    Ok(assemble(config, shards, runs, models))
}

/// The table for a terminal.
pub fn table(report: &StudyReport) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "study: {} — {} run(s) per cell, base seed {}{}\n",
        report.config.scenario.name,
        report.config.runs,
        report.config.seed,
        if report.complete {
            String::new()
        } else {
            format!(
                " (partial: shard(s) {}, {} of {} runs)",
                report.shards.join(", "),
                report.runs.len(),
                report.config.jobs()
            )
        }
    ));
    out.push_str("| variant | strategy | runs | mean utility | 95% CI | model (eq. 2-5) | samples | replans | ground halts |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|\n");
    for c in &report.cells {
        out.push_str(&format!(
            "| {} | {} | {} | {:.1} | {:.1} .. {:.1} | {:.1} | {:.2} | {:.2} | {:.2} |\n",
            c.variant,
            c.strategy,
            c.runs,
            c.mean,
            c.ci95[0],
            c.ci95[1],
            c.model,
            c.mean_samples,
            c.mean_replans,
            c.mean_ground_halts
        ));
    }
    for m in &report.models {
        out.push_str(&format!(
            "model inputs, {}: u_avg {:.4}/Wh, b {:.0} Wh, n {:.1}, c_avg {:.1} Wh, c_g {:.0} Wh, c_r {:.1} Wh, d*u_d {:.1}\n",
            m.variant, m.u_avg, m.b_wh, m.n_tasks, m.c_avg_wh, m.c_g_wh, m.c_r_wh, m.d_u_d
        ));
    }
    for o in &report.orderings {
        out.push_str(&format!(
            "ordering, {}: measured {}; model {}; paper Static < Ground < FE < Replan: {}\n",
            o.variant,
            o.measured,
            o.model,
            if o.matches_paper {
                "matches".to_string()
            } else {
                format!("differs ({})", o.differences.join("; "))
            }
        ));
    }
    out
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The plot (like Figs. 10-11): one panel per variant, a bar per strategy (mean utility, 95%
/// interval whiskers) and the model's prediction as a diamond. Hand-written SVG.
pub fn svg(report: &StudyReport) -> String {
    let (panel_w, h, left, top, bottom) = (300.0, 380.0, 60.0, 50.0, 60.0);
    let panels = report.config.variants.len().max(1);
    let width = left + panel_w * panels as f64 + 20.0;
    let max = report
        .cells
        .iter()
        .flat_map(|c| [c.ci95[1], c.model, c.mean])
        .fold(1.0f64, f64::max)
        * 1.1;
    let plot_h = h - top - bottom;
    let y = |v: f64| top + plot_h * (1.0 - (v.max(0.0) / max));
    let mut s = String::new();
    s.push_str(&format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {width:.0} {h:.0}\" font-family=\"sans-serif\" font-size=\"12\">\n"
    ));
    s.push_str(&format!(
        "<title>{}: mean utility per strategy (95% CI) and the model of equations 2-5</title>\n",
        escape(&report.config.scenario.name)
    ));
    s.push_str("<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    s.push_str(&format!(
        "<text x=\"{:.0}\" y=\"20\" font-size=\"14\" text-anchor=\"middle\">{} — mean utility over {} runs per cell (bars, 95% CI) and model (diamonds)</text>\n",
        width / 2.0,
        escape(&report.config.scenario.name),
        report.config.runs
    ));
    // Axis ticks.
    for i in 0..=5 {
        let v = max * f64::from(i) / 5.0;
        s.push_str(&format!(
            "<line x1=\"{left}\" x2=\"{:.0}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#ddd\"/>\n<text x=\"{:.0}\" y=\"{:.1}\" text-anchor=\"end\">{v:.0}</text>\n",
            width - 20.0,
            y(v),
            y(v),
            left - 5.0,
            y(v) + 4.0
        ));
    }
    let colors = ["#999999", "#d95f02", "#7570b3", "#1b9e77"];
    for (p, variant) in report.config.variants.iter().enumerate() {
        let x0 = left + panel_w * p as f64;
        s.push_str(&format!(
            "<text x=\"{:.0}\" y=\"{:.0}\" text-anchor=\"middle\" font-size=\"13\">{}</text>\n",
            x0 + panel_w / 2.0,
            h - 15.0,
            escape(&variant.name)
        ));
        let cells: Vec<&Cell> = report
            .cells
            .iter()
            .filter(|c| c.variant == variant.name)
            .collect();
        let bw = panel_w / (cells.len().max(1) as f64 + 1.0);
        for (i, c) in cells.iter().enumerate() {
            let cx = x0 + bw * (i as f64 + 1.0);
            let color = colors[i % colors.len()];
            s.push_str(&format!(
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"{color}\"><title>{} {}: mean {:.1}, 95% CI {:.1}..{:.1}, model {:.1}</title></rect>\n",
                cx - bw * 0.35,
                y(c.mean),
                bw * 0.7,
                (y(0.0) - y(c.mean)).max(0.0),
                escape(&c.variant),
                escape(&c.strategy),
                c.mean,
                c.ci95[0],
                c.ci95[1],
                c.model
            ));
            s.push_str(&format!(
                "<line x1=\"{cx:.1}\" x2=\"{cx:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"black\"/>\n",
                y(c.ci95[0]),
                y(c.ci95[1])
            ));
            let my = y(c.model);
            s.push_str(&format!(
                "<path d=\"M {cx:.1} {:.1} L {:.1} {my:.1} L {cx:.1} {:.1} L {:.1} {my:.1} Z\" fill=\"black\"/>\n",
                my - 6.0,
                cx + 6.0,
                my + 6.0,
                cx - 6.0
            ));
            s.push_str(&format!(
                "<text x=\"{cx:.1}\" y=\"{:.0}\" text-anchor=\"middle\">{}</text>\n",
                h - bottom + 16.0,
                escape(&c.strategy)
            ));
        }
    }
    s.push_str(&format!(
        "<line x1=\"{left}\" x2=\"{left}\" y1=\"{top}\" y2=\"{:.0}\" stroke=\"black\"/>\n",
        y(0.0)
    ));
    s.push_str("</svg>\n");
    s
}
