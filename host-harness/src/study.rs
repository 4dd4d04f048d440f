//! `hil study`: the strategy study of seed 000 V.A (issue 12 item 4) on the host lander
//! simulation (`lander-sim`), sharded across machines by `--shard k/n` or the batch engine's
//! environment ([`crate::shard_env`]), and `hil study merge` to put shard reports back together.
//! Lander scenarios (`scenarios/lander/*.toml`) are read here, with errors at file:line:column
//! ([`load_scenario`]).
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use lander_sim::scenario::Scenario;
use lander_sim::study::{self, StudyConfig, StudyReport};

use crate::diag::{Diagnostic, SourceFile};

/// Reads a lander scenario: TOML errors and bad values at file:line:column, naming the field.
pub fn load_scenario(path: &Path) -> Result<Scenario, Diagnostic> {
    parse_scenario(SourceFile::read(path)?)
}

/// Parses lander scenario text (`source` names the file in errors).
pub fn parse_scenario(source: SourceFile) -> Result<Scenario, Diagnostic> {
    let scenario: Scenario = toml::from_str(&source.text).map_err(|e| source.toml_error(&e, ""))?;
    if let Some(e) = scenario.validate().into_iter().next() {
        return Err(source.error_at(&e.field, e.message));
    }
    Ok(scenario)
}

/// The default scenario: `scenarios/lander/bsm-1.toml` of the repository.
pub fn default_scenario() -> PathBuf {
    crate::repo_root().join("scenarios/lander/bsm-1.toml")
}

/// `hil study`.
#[derive(Clone, Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct StudyArgs {
    #[command(subcommand)]
    pub merge: Option<StudyMerge>,
    /// Lander scenario (TOML; default scenarios/lander/bsm-1.toml).
    #[arg(long, value_name = "FILE")]
    pub scenario: Option<PathBuf>,
    /// Runs per cell (strategy x energy variant).
    #[arg(long, default_value_t = 50)]
    pub runs: u32,
    /// Base seed: run r of every cell uses seed S + r.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run only the jobs j with j % n == k - 1 (1-based k), e.g. 2/4. Default: from GitLab's
    /// CI_NODE_INDEX/CI_NODE_TOTAL, Slurm's SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT, or
    /// Kubernetes' JOB_COMPLETION_INDEX/JOB_COMPLETIONS, else the whole study.
    #[arg(long, value_name = "k/n")]
    pub shard: Option<String>,
    /// Make every run's decisions on the emulated RAD750 (one QEMU for the study), compared
    /// with the native executor at every step (`crate::lander_emulated`).
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: the firmware ELF to boot (default: build it).
    #[arg(long, requires = "emulated")]
    pub firmware: Option<PathBuf>,
    #[command(flatten)]
    pub out: StudyOutputs,
}

#[derive(Clone, Debug, clap::Args)]
pub struct StudyOutputs {
    /// Write the report (JSON) here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the plot (SVG, like the paper's Figs. 10-11) here.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
}

#[derive(Clone, Debug, clap::Subcommand)]
pub enum StudyMerge {
    /// Merge shard reports into the report of the whole study.
    Merge {
        /// The shard reports (JSON).
        #[arg(required = true)]
        reports: Vec<PathBuf>,
        #[command(flatten)]
        out: StudyOutputs,
    },
}

pub fn load_report(path: &Path) -> Result<StudyReport, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: not a study report: {e}", path.display()))
}

fn write(report: &StudyReport, out: &StudyOutputs) -> Result<(), String> {
    if let Some(p) = &out.json {
        let text = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
        std::fs::write(p, text + "\n").map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        println!("  report: {}", p.display());
    }
    if let Some(p) = &out.svg {
        std::fs::write(p, study::svg(report))
            .map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        println!("  plot: {}", p.display());
    }
    Ok(())
}

/// The `hil study` command.
pub fn cli(args: StudyArgs) -> Result<ExitCode, String> {
    let (report, out) = match args.merge {
        Some(StudyMerge::Merge { reports, out }) => {
            let reports = reports
                .iter()
                .map(|p| load_report(p))
                .collect::<Result<Vec<_>, _>>()?;
            (study::merge(reports)?, out)
        }
        None => {
            let path = args.scenario.clone().unwrap_or_else(default_scenario);
            let scenario = load_scenario(&path).map_err(|d| d.render())?;
            let config = StudyConfig::new(scenario, args.runs, args.seed);
            let shard = crate::shard_env::resolve(
                args.shard.as_deref(),
                &crate::shard_env::process_vars(),
            )?;
            let jobs = match shard {
                Some(s) => (0..config.jobs())
                    .filter(|j| j % u64::from(s.n) == u64::from(s.k - 1))
                    .count() as u64,
                None => config.jobs(),
            };
            println!(
                "hil study {} — {} strategies x {} variants x {} runs{}: {} run(s)",
                path.display(),
                study::STRATEGIES.len(),
                config.variants.len(),
                config.runs,
                shard.map_or(String::new(), |s| format!(", shard {s}")),
                jobs
            );
            // On stderr, only when it is a terminal.
            let bar = crate::progress::bar(jobs, "  {bar:40} {pos}/{len} runs");
            let started = Instant::now();
            let shard = shard.map(|s| (s.k, s.n));
            let report = if args.emulated {
                let fw = crate::lander_emulated::firmware_for(args.firmware.as_deref())?;
                let mut target = crate::lander_emulated::EmulatedLander::boot(&fw)?;
                study::run_study_with(&config, shard, &mut |_| bar.inc(1), &mut |s, c| {
                    target
                        .run(s, c)
                        .map(|r| r.result)
                        .map_err(|e| format!("{:?} seed {}: {e}", c.strategy, c.seed))
                })?
            } else {
                study::run_study(&config, shard, &mut |_| bar.inc(1))?
            };
            bar.finish_and_clear();
            println!("  wall time {:.2} s", started.elapsed().as_secs_f64());
            (report, args.out)
        }
    };
    print!("{}", study::table(&report));
    write(&report, &out)?;
    Ok(ExitCode::SUCCESS)
}
