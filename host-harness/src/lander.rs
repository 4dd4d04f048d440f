//! `hil lander run`: one lander mission (`scenarios/lander/*.toml`, e.g. RSM-1 or an ELAP
//! scenario of seed 000 V.B.1 under `scenarios/lander/elap/`) on the host lander simulation,
//! checked against the scenario's `[[expect]]` success criteria. Exit 0 when every expectation
//! is met, 1 when one is not, 2 on bad input (like `hil run`).
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use lander_sim::expect::{self, Verdict};
use lander_sim::report::{self, LanderReport};
use lander_sim::scenario::{Scenario, StrategyName};
use lander_sim::sim::trace::{Recording, Trace};
use lander_sim::sim::{self, RunConfig, RunResult};

use crate::study::load_scenario;

/// `hil lander`.
#[derive(Clone, Debug, clap::Subcommand)]
pub enum LanderCommand {
    /// Run one lander scenario natively and check its expectations (PASS/FAIL each).
    ///
    /// `--report DIR` writes the long-mission report: HTML with a Gantt chart over sols,
    /// battery, data-on-board and utility timelines and the downlinks per tier, with its data
    /// as JSON and CSV. A progress bar (mission hours) shows on stderr when it is a terminal,
    /// never in piped output or the JSON.
    Run(LanderRunArgs),
}

#[derive(Clone, Debug, clap::Args)]
pub struct LanderRunArgs {
    /// Lander scenario (TOML), e.g. scenarios/lander/elap/08-sudden-low-battery.toml
    pub scenario: PathBuf,
    /// Seed (default: the scenario's `run.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Strategy: static, ground, fe or replan (default: the scenario's `run.strategy`).
    #[arg(long, value_parser = parse_strategy)]
    pub strategy: Option<StrategyName>,
    /// Write the mission report into this directory: report.html (self-contained, inline SVG:
    /// a Gantt chart over sols of every dispatched primitive by kind and site, with failures,
    /// retries, replans and ground halts marked over Earth-in-view bands; the battery's charge
    /// and the data on board over time; the utility realised, which rises only when a
    /// downlink's data reaches Earth; each downlink's products and volume per tier), plus
    /// report.json, primitives.csv, timeline.csv, utility.csv and downlinks.csv.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Write the run's result and verdicts (JSON) here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Make the executor's decisions on the emulated RAD750, in the planner partition (QEMU),
    /// compared with a native shadow at every step (`crate::lander_emulated`).
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: the firmware ELF to boot (default: build it).
    #[arg(long, requires = "emulated")]
    pub firmware: Option<PathBuf>,
}

fn parse_strategy(s: &str) -> Result<StrategyName, String> {
    match s {
        "static" => Ok(StrategyName::Static),
        "ground" => Ok(StrategyName::Ground),
        "fe" => Ok(StrategyName::Fe),
        "replan" => Ok(StrategyName::Replan),
        _ => Err(format!(
            "unknown strategy `{s}` (static, ground, fe, replan)"
        )),
    }
}

/// A checked run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LanderOutcome {
    pub scenario: String,
    pub seed: u64,
    pub strategy: StrategyName,
    pub result: RunResult,
    pub verdicts: Vec<Verdict>,
    #[serde(skip)]
    pub wall: Duration,
}

impl LanderOutcome {
    pub fn passed(&self) -> bool {
        self.verdicts.iter().all(|v| v.passed)
    }
}

/// Runs `s` (with the seed and strategy given, else the scenario's) and checks its
/// expectations.
pub fn run_checked(
    s: &Scenario,
    seed: Option<u64>,
    strategy: Option<StrategyName>,
) -> Result<LanderOutcome, String> {
    let seed = seed.unwrap_or(s.run.seed);
    let strategy = strategy.unwrap_or(s.run.strategy);
    let started = Instant::now();
    let result = sim::run(s, &RunConfig::new(strategy.strategy(), seed))?;
    let wall = started.elapsed();
    let verdicts = expect::check_all(s, &result);
    Ok(LanderOutcome {
        scenario: s.name.clone(),
        seed,
        strategy,
        result,
        verdicts,
        wall,
    })
}

/// The readable summary: what happened, then a PASS/FAIL line per expectation.
pub fn summary(o: &LanderOutcome) -> String {
    let r = &o.result;
    let wh = |mj: u64| mj as f64 / 3_600_000.0;
    let mut out = String::new();
    out += &format!(
        "  {} sols simulated ({:.1} h), ended {:?}, strategy {:?}, seed {}\n",
        format_args!("{:.1}", r.end_us as f64 / sim::SOL_US as f64),
        r.end_us as f64 / sim::HOUR_US as f64,
        r.end,
        o.strategy,
        o.seed
    );
    let per_tier = r.downlinks.iter().fold([0u32; 4], |mut a, d| {
        for (x, y) in a.iter_mut().zip(d.per_tier) {
            *x += y;
        }
        a
    });
    out += &format!(
        "  utility {:.1}; {} downlinks ({} products: {} critical, {} decisional, {} mandatory, {} residual; {} left on board)\n",
        r.utility_milli as f64 / 1_000.0,
        r.downlinks.len(),
        per_tier.iter().sum::<u32>(),
        per_tier[0],
        per_tier[1],
        per_tier[2],
        per_tier[3],
        r.unsent
    );
    out += &format!(
        "  samples {} collected, {} analysed ({} negative); energy {:.0} of {:.0} Wh left\n",
        r.collections.len(),
        r.samples_analyzed,
        r.negatives,
        wh(r.battery_end_mj),
        wh(r.battery_start_mj)
    );
    out += &format!(
        "  dispatches {}, failures {:?} (FE, replan, ground), retries {}, replans {}, ground halts {}, holds {} set / {} released, ground changes {} in effect\n",
        r.dispatched,
        r.failures,
        r.retries,
        r.replans,
        r.ground_halts,
        r.holds_set,
        r.holds_released,
        r.changes.len()
    );
    out += &format!("  wall time {:.3} s\n", o.wall.as_secs_f64());
    for v in &o.verdicts {
        out += &format!(
            "  {} {}{}: {}\n",
            if v.passed { "PASS" } else { "FAIL" },
            v.kind,
            if v.note.is_empty() {
                String::new()
            } else {
                format!(" ({})", v.note)
            },
            v.detail
        );
    }
    let failed = o.verdicts.iter().filter(|v| !v.passed).count();
    out += &format!(
        "  {}: {} of {} expectation(s) met\n",
        if failed == 0 { "PASS" } else { "FAIL" },
        o.verdicts.len() - failed,
        o.verdicts.len()
    );
    out
}

fn run_file(path: &Path, args: &LanderRunArgs) -> Result<ExitCode, String> {
    let scenario = load_scenario(path).map_err(|d| d.render())?;
    // The run is recorded (the report, the progress bar) however it is made.
    let recording = start_recording(&scenario);
    println!("hil lander run {} — {}", path.display(), scenario.name);
    let outcome = if args.emulated {
        match crate::lander_emulated::cli_run(&scenario, args)? {
            Ok(o) => o,
            // A divergence or a target that stopped answering: the verdict names the step.
            Err(verdict) => {
                println!("  FAIL emulated: {verdict}");
                return Ok(ExitCode::from(1));
            }
        }
    } else {
        run_checked(&scenario, args.seed, args.strategy)?
    };
    print!("{}", summary(&outcome));
    let trace = recording.finish();
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&outcome).map_err(|e| e.to_string())?;
        std::fs::write(p, text + "\n").map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        println!("  result: {}", p.display());
    }
    if let Some(dir) = &args.report {
        let strategy = format!("{:?}", outcome.strategy);
        let report = LanderReport::new(&scenario, &strategy, outcome.result.clone(), trace);
        report::write_dir(&report, dir)?;
        println!("  report: {}", dir.join("report.html").display());
    }
    Ok(if outcome.passed() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// A recording of the run about to be made on this thread, with a progress bar in mission
/// hours on stderr when it is a terminal (cleared when the run ends).
fn start_recording(s: &Scenario) -> Recording {
    let bar = crate::progress::bar(
        sim::horizon_us(s) / sim::HOUR_US,
        "  {bar:40} {pos}/{len} mission hours",
    );
    let mut trace = Trace::new(s);
    trace.on_progress(move |now| match now {
        Some(t) => bar.set_position(t / sim::HOUR_US),
        None => bar.finish_and_clear(),
    });
    Recording::start(trace)
}

/// The `hil lander` command.
pub fn cli(command: LanderCommand) -> Result<ExitCode, String> {
    match command {
        LanderCommand::Run(args) => run_file(&args.scenario.clone(), &args),
    }
}
