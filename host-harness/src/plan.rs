//! `hil plan DOMAIN PROBLEM`: compile a temporal PDDL task with the front end (crate `pddl`)
//! and plan it with the `no_std` planner (crate `temporal`) on the host, in an arena of a
//! chosen size, the way the planner partition will run it; print the plan, its makespan, the
//! search statistics and the arena's high-water mark.
//!
//! `--emulated` plans on the RAD750 proxy instead, in the planner partition, with the same
//! search (see [`crate::plan_emulated`]), and adds the guest CPU it took.
use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use crate::diag::{Diagnostic, SourceFile};

/// How to plan.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// Arena size in bytes (rounded down to whole words).
    pub arena_bytes: usize,
    /// Stop after this many expansions (0: no limit).
    pub max_expansions: u64,
    /// Stop after this much host time, in milliseconds (0: no limit). Host wall time: for
    /// benchmarks only; the search itself counts expansions.
    pub time_limit_ms: u64,
    pub config: temporal::PlannerConfig,
    pub pddl: pddl::Options,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            arena_bytes: 256 << 20,
            max_expansions: 0,
            time_limit_ms: 0,
            config: temporal::PlannerConfig::default(),
            pddl: pddl::Options::default(),
        }
    }
}

/// One action of a plan, times in PDDL time units.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PlanStep {
    pub start: f64,
    pub action: String,
    pub duration: f64,
    /// The window of start times the plan's STN allows with the makespan kept.
    pub start_window: [f64; 2],
}

/// What `hil plan` reports.
#[derive(Clone, Debug, Serialize)]
pub struct PlanReport {
    pub domain: String,
    pub problem: String,
    /// "solved", "unsolvable", "out of memory: ...", "expansion limit", "time limit".
    pub outcome: String,
    pub solved: bool,
    pub makespan: Option<f64>,
    pub plan: Vec<PlanStep>,
    /// The search's plan before the elimination after it improved it (`temporal`'s
    /// eliminate.rs): its actions and makespan (`plan`'s without an elimination), and the
    /// actions removed and removals tried.
    pub first_plan_actions: usize,
    pub first_plan_makespan: Option<f64>,
    pub eliminated: u64,
    pub elimination_checks: u64,
    pub facts: usize,
    pub numeric_variables: usize,
    pub actions: usize,
    pub til_windows: usize,
    pub task_bytes: usize,
    pub expanded: u64,
    pub generated: u64,
    pub evaluated: u64,
    pub inconsistent: u64,
    pub duplicates: u64,
    pub dead_ends: u64,
    pub nodes: u64,
    /// Successors dropped for a plan longer than the step limit.
    pub too_long: u64,
    /// Open-list entries dropped because a list was full.
    pub shed: u64,
    /// The lowest heuristic value reached.
    pub best_h: u32,
    pub peak_arena_bytes: u64,
    pub arena_bytes: u64,
    /// Host wall time, milliseconds (depends on the host and its load; the search's is 0 on
    /// the emulated target, whose cost is `emulated`).
    pub compile_ms: f64,
    pub search_ms: f64,
    /// "native" or "emulated".
    pub target: String,
    /// The emulated target's costs (guest CPU), None natively.
    pub emulated: Option<crate::plan_emulated::EmulatedCosts>,
}

/// A report of `compiled` with nothing planned yet.
pub fn empty_report(compiled: &pddl::Compiled) -> PlanReport {
    let (facts, numeric_variables, actions) = match temporal::Task::parse(&compiled.task) {
        Ok(t) => (t.fact_count(), t.numeric_count(), t.action_count()),
        Err(_) => (0, 0, 0),
    };
    PlanReport {
        domain: String::new(),
        problem: String::new(),
        outcome: String::new(),
        solved: false,
        makespan: None,
        plan: Vec::new(),
        first_plan_actions: 0,
        first_plan_makespan: None,
        eliminated: 0,
        elimination_checks: 0,
        facts,
        numeric_variables,
        actions,
        til_windows: compiled.til_windows,
        task_bytes: compiled.task.len(),
        expanded: 0,
        generated: 0,
        evaluated: 0,
        inconsistent: 0,
        duplicates: 0,
        dead_ends: 0,
        nodes: 0,
        too_long: 0,
        shed: 0,
        best_h: 0,
        peak_arena_bytes: 0,
        arena_bytes: 0,
        compile_ms: 0.0,
        search_ms: 0.0,
        target: "native".into(),
        emulated: None,
    }
}

/// Read, compile and plan. File and PDDL errors are diagnostics at file:line:column.
pub fn plan_files(
    domain: &Path,
    problem: &Path,
    modules: &pddl::ModuleRegistry,
    options: &PlanOptions,
) -> Result<PlanReport, Diagnostic> {
    let (d, p, compiled, compile_ms) = compile_files(domain, problem, modules, options)?;
    let mut report = plan_compiled(&compiled, options).map_err(|m| p.error(0..0, "", m))?;
    report.domain = d.name.clone();
    report.problem = p.name.clone();
    report.compile_ms = compile_ms;
    Ok(report)
}

/// Read and compile the two files; the sources (for diagnostics), the task and the host
/// milliseconds compiling took.
pub fn compile_files(
    domain: &Path,
    problem: &Path,
    modules: &pddl::ModuleRegistry,
    options: &PlanOptions,
) -> Result<(SourceFile, SourceFile, pddl::Compiled, f64), Diagnostic> {
    let d = SourceFile::read(domain)?;
    let p = SourceFile::read(problem)?;
    let started = Instant::now();
    let compiled = pddl::compile(
        pddl::Source {
            name: &d.name,
            text: &d.text,
        },
        pddl::Source {
            name: &p.name,
            text: &p.text,
        },
        modules,
        &options.pddl,
    )
    .map_err(|e| {
        let file = if e.file == d.name { &d } else { &p };
        file.error(e.span.clone(), "", e.message.clone())
    })?;
    let compile_ms = started.elapsed().as_secs_f64() * 1e3;
    Ok((d, p, compiled, compile_ms))
}

/// Plan a compiled task natively.
pub fn plan_compiled(
    compiled: &pddl::Compiled,
    options: &PlanOptions,
) -> Result<PlanReport, String> {
    let task = temporal::Task::parse(&compiled.task).map_err(|e| e.to_string())?;
    let mut arena = vec![0u32; options.arena_bytes / 4];
    let started = Instant::now();
    let tpu = f64::from(task.ticks_per_unit());
    let mut report = empty_report(compiled);
    report.arena_bytes = (arena.len() * 4) as u64;
    let mut planner = match temporal::Planner::new(task, &mut arena, options.config) {
        Ok(p) => p,
        Err(region) => {
            report.outcome =
                format!("out of memory: the arena cannot hold the task's tables ({region:?})");
            return Ok(report);
        }
    };
    let status = loop {
        let status = planner.step(256);
        if status != temporal::Status::Searching {
            break status;
        }
        let stats = planner.stats();
        if options.max_expansions > 0 && stats.expanded >= options.max_expansions {
            break status;
        }
        if options.time_limit_ms > 0
            && started.elapsed().as_millis() as u64 >= options.time_limit_ms
        {
            break status;
        }
    };
    report.search_ms = started.elapsed().as_secs_f64() * 1e3;
    let stats = planner.stats();
    report.expanded = stats.expanded;
    report.generated = stats.generated;
    report.evaluated = stats.evaluated;
    report.inconsistent = stats.inconsistent;
    report.duplicates = stats.duplicates;
    report.dead_ends = stats.dead_ends;
    report.nodes = stats.nodes;
    report.too_long = stats.too_long;
    report.shed = stats.shed;
    report.best_h = stats.best_h;
    report.peak_arena_bytes = stats.peak_words * 4;
    // A limit reached while the elimination improves the plan found: the best plan so far.
    let status = if planner.has_plan() {
        temporal::Status::Solved
    } else {
        status
    };
    report.eliminated = stats.eliminated;
    report.elimination_checks = stats.elimination_checks;
    report.outcome = match status {
        temporal::Status::Solved => "solved".into(),
        temporal::Status::Unsolvable => "unsolvable".into(),
        temporal::Status::OutOfMemory(r) => format!("out of memory ({r:?})"),
        temporal::Status::Searching => {
            if options.max_expansions > 0 && stats.expanded >= options.max_expansions {
                "expansion limit".into()
            } else {
                "time limit".into()
            }
        }
    };
    if status == temporal::Status::Solved {
        let mut out = vec![temporal::PlannedAction::default(); temporal::search::MAX_PLAN_ACTIONS];
        let (n, makespan) = planner
            .plan(&mut out)
            .ok_or("the planner reported a plan but could not write it")?;
        report.solved = true;
        report.makespan = Some(f64::from(makespan) / tpu);
        report.first_plan_actions = n + stats.eliminated as usize;
        report.first_plan_makespan =
            Some(f64::from(planner.makespan_before_elimination().unwrap_or(makespan)) / tpu);
        report.plan = out[..n]
            .iter()
            .map(|s| PlanStep {
                start: f64::from(s.start) / tpu,
                action: compiled.action_names[s.action as usize].clone(),
                duration: f64::from(s.duration) / tpu,
                start_window: [f64::from(s.start_lb) / tpu, f64::from(s.start_ub) / tpu],
            })
            .collect();
    }
    Ok(report)
}

/// The plan in the usual PDDL form (`start: (action args) [duration]`), times to 3 decimals.
pub fn plan_text(report: &PlanReport) -> String {
    let mut s = String::new();
    for step in &report.plan {
        s.push_str(&format!(
            "{:.3}: {} [{:.3}]\n",
            step.start, step.action, step.duration
        ));
    }
    s
}

/// The report for people.
pub fn summary(report: &PlanReport) -> String {
    let mut s = String::new();
    s.push_str(&format!("hil plan {} {}\n", report.domain, report.problem));
    s.push_str(&format!(
        "  task      {} facts, {} numeric variables, {} actions, {} timed-literal windows, {} bytes (compiled in {:.1} ms)\n",
        report.facts, report.numeric_variables, report.actions, report.til_windows, report.task_bytes, report.compile_ms
    ));
    match report.makespan {
        Some(m) => s.push_str(&format!(
            "  plan      {} actions, makespan {m:.3}\n",
            report.plan.len()
        )),
        None => s.push_str(&format!("  no plan   {}\n", report.outcome)),
    }
    if let (Some(m), true) = (report.first_plan_makespan, report.elimination_checks > 0) {
        s.push_str(&format!(
            "            the search's plan {} actions, makespan {m:.3}; action elimination after it removed {} ({} removals tried)\n",
            report.first_plan_actions, report.eliminated, report.elimination_checks
        ));
    }
    for step in &report.plan {
        s.push_str(&format!(
            "    {:>10.3}: {} [{:.3}]   start window [{:.3}, {:.3}]\n",
            step.start, step.action, step.duration, step.start_window[0], step.start_window[1]
        ));
    }
    s.push_str(&format!(
        "  search    {} expanded, {} generated, {} evaluated, {} inconsistent, {} duplicates, {} dead ends, {} too long, {} shed, {} nodes stored, best h {} ({:.1} ms host time)\n",
        report.expanded, report.generated, report.evaluated, report.inconsistent, report.duplicates, report.dead_ends, report.too_long, report.shed, report.nodes, report.best_h, report.search_ms
    ));
    s.push_str(&format!(
        "  memory    peak arena {} bytes ({:.1} KiB) of {} bytes\n",
        report.peak_arena_bytes,
        report.peak_arena_bytes as f64 / 1024.0,
        report.arena_bytes
    ));
    if let Some(e) = &report.emulated {
        s.push_str(&format!(
            "  target    emulated RAD750, planner partition: {} guest instructions ({} timebase ticks) to the search's plan, in {} planner windows (costliest expansion {} ticks, costliest set-up piece {} ticks); {} frames granted ({} ms of mission time)\n",
            e.guest_instructions, e.planning_ticks, e.planner_windows, e.worst_expansion_ticks, e.worst_set_up_ticks, e.frames, e.frames as u64 * crate::plan_emulated::FRAME_US / 1000
        ));
        if e.elimination_instructions > 0 {
            s.push_str(&format!(
                "            action elimination after it: {} guest instructions ({} ticks, costliest unit {} ticks); the improved plan at {} guest instructions\n",
                e.elimination_instructions, e.elimination_ticks, e.worst_elimination_ticks, e.improved_plan_instructions
            ));
        }
        s.push_str(&format!(
            "            receiving and checking the task: {} guest instructions ({} ticks), authentication {} of them ({} ticks)\n",
            e.receive_instructions, e.receive_ticks, e.auth_instructions, e.auth_ticks
        ));
        s.push_str(&format!(
            "            kernel health events during the job: {}\n",
            if e.health_events.is_empty() {
                "none".to_string()
            } else {
                e.health_events.join("; ")
            }
        ));
        if e.resets > 0 || e.resumed {
            s.push_str(&format!(
                "            {} warm reset(s) during the search; job resumed: {} (stored task checked again in {} ticks, then searched from the start)\n",
                e.resets,
                if e.resumed { "yes" } else { "no" },
                e.verify_ticks
            ));
        }
    }
    s
}

/// `hil plan`'s arguments.
#[derive(clap::Args, Debug)]
pub struct PlanArgs {
    /// Domain file (PDDL).
    pub domain: std::path::PathBuf,
    /// Problem file (PDDL).
    pub problem: std::path::PathBuf,
    /// Plan on the host with the no_std planner (the default).
    #[arg(long, conflicts_with = "emulated")]
    pub native: bool,
    /// Plan on the emulated RAD750, in the planner partition (QEMU), with an arena of
    /// `flight_app::TEMPORAL_ARENA_BYTES` (8 MiB); `--arena-kib` does not apply.
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: the firmware ELF to boot (default: build it).
    #[arg(long, requires = "emulated")]
    pub firmware: Option<std::path::PathBuf>,
    /// With --emulated: give up after this many granted frames (10 ms of mission time each).
    #[arg(long, default_value_t = 200_000)]
    pub max_frames: u32,
    /// With --emulated: warm-reset the target in the middle of the search, in the N-th frame
    /// granted after the task's acceptance (from 0), once the planner partition has run
    /// `--reset-ticks` ticks of CPU in it; the target resumes the job (the same plan).
    #[arg(long, requires = "emulated")]
    pub warm_reset_after_frames: Option<u32>,
    /// With --warm-reset-after-frames: the planner partition's CPU in that frame before the
    /// reset lands, timebase ticks.
    #[arg(long, default_value_t = 10_000, requires = "warm_reset_after_frames")]
    pub reset_ticks: u32,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Print only the plan, one `start: (action) [duration]` line per action (for validators).
    #[arg(long, conflicts_with = "json")]
    pub plan_only: bool,
    /// Arena for the planner's search memory, in KiB.
    #[arg(long, default_value_t = 256 * 1024)]
    pub arena_kib: usize,
    /// Stop after this many expansions (0: none).
    #[arg(long, default_value_t = 0)]
    pub max_expansions: u64,
    /// Stop after this many seconds of host time (0: none; for benchmarks).
    #[arg(long, default_value_t = 0.0)]
    pub time_limit: f64,
    /// Which repeated states to prune: none, quiescent (nothing running; the default) or all.
    #[arg(long, value_enum, default_value = "quiescent")]
    pub duplicates: DuplicatesArg,
    /// Do not apply compression-safe actions' ends with their starts.
    #[arg(long)]
    pub no_compression: bool,
    /// Use one open list only (no preferred operators).
    #[arg(long)]
    pub no_preferred: bool,
    /// Heuristic supporters by duration (soonest reached) instead of by action count.
    #[arg(long)]
    pub duration_costs: bool,
}

/// `--duplicates`: see [`temporal::Duplicates`].
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum DuplicatesArg {
    Keep,
    Quiescent,
    All,
}

/// Run `hil plan`. Exit 0 with a plan, 1 without one, 2 on bad input.
pub fn cli(args: PlanArgs) -> Result<std::process::ExitCode, String> {
    // A missing firmware is refused before anything is compiled or built.
    if let Some(elf) = &args.firmware {
        if !elf.is_file() {
            return Err(format!(
                "--firmware {}: no such file (give the firmware ELF, e.g. target/firmware/powerpc-unknown-linux-gnu/release/rad750-firmware, or leave --firmware out to build it)",
                elf.display()
            ));
        }
    }
    let options = PlanOptions {
        arena_bytes: args.arena_kib * 1024,
        max_expansions: args.max_expansions,
        time_limit_ms: (args.time_limit * 1e3) as u64,
        config: temporal::PlannerConfig {
            duplicates: match args.duplicates {
                DuplicatesArg::Keep => temporal::Duplicates::Keep,
                DuplicatesArg::Quiescent => temporal::Duplicates::PruneQuiescent,
                DuplicatesArg::All => temporal::Duplicates::PruneAll,
            },
            compression: !args.no_compression,
            preferred_operators: !args.no_preferred,
            relaxed_cost: if args.duration_costs {
                temporal::heuristic::RelaxedCost::Duration
            } else {
                temporal::heuristic::RelaxedCost::Unit
            },
            ..temporal::PlannerConfig::default()
        },
        ..PlanOptions::default()
    };
    let report = if args.emulated {
        plan_emulated_files(&args, &options)?
    } else {
        plan_files(
            &args.domain,
            &args.problem,
            &pddl::ModuleRegistry::new(),
            &options,
        )
        .map_err(|e| e.render())?
    };
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?
        );
    } else if args.plan_only {
        print!("{}", plan_text(&report));
    } else {
        print!("{}", summary(&report));
    }
    Ok(if report.solved {
        std::process::ExitCode::SUCCESS
    } else {
        std::process::ExitCode::FAILURE
    })
}

/// `hil plan --emulated`: compile on the host, plan on the emulated target.
fn plan_emulated_files(args: &PlanArgs, options: &PlanOptions) -> Result<PlanReport, String> {
    let (d, p, compiled, compile_ms) = compile_files(
        &args.domain,
        &args.problem,
        &pddl::ModuleRegistry::new(),
        options,
    )
    .map_err(|e| e.render())?;
    let fw = match &args.firmware {
        Some(elf) => crate::firmware::FirmwareImage::open(elf).map_err(|e| e.to_string())?,
        None => {
            eprintln!("building firmware (cargo, powerpc-unknown-linux-gnu) ...");
            crate::firmware::build().map_err(|e| e.to_string())?
        }
    };
    let mut target = crate::plan_emulated::EmulatedPlanner::boot(&fw)?;
    let reset =
        args.warm_reset_after_frames
            .map(|after_frames| crate::plan_emulated::MidSearchReset {
                after_frames,
                planner_ticks: args.reset_ticks,
            });
    let mut report = target
        .plan_with_reset(&compiled, options, args.max_frames, reset)
        .map_err(|e| e.to_string())?;
    report.domain = d.name.clone();
    report.problem = p.name.clone();
    report.compile_ms = compile_ms;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bench(domain: &str, file: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../pddl/tests/benchmarks")
            .join(domain)
            .join(file)
    }

    #[test]
    fn a_benchmark_instance_gives_a_plan_with_its_makespan_and_arena_high_water_mark() {
        let options = PlanOptions {
            arena_bytes: 16 << 20,
            ..PlanOptions::default()
        };
        let r = plan_files(
            &bench("satellite", "domain.pddl"),
            &bench("satellite", "instance-1.pddl"),
            &pddl::ModuleRegistry::new(),
            &options,
        )
        .expect("compiles");
        assert!(r.solved, "{}", r.outcome);
        let end = r
            .plan
            .iter()
            .map(|s| s.start + s.duration)
            .fold(0.0, f64::max);
        assert_eq!(r.makespan, Some(end));
        assert!(r.peak_arena_bytes > 0 && r.peak_arena_bytes <= r.arena_bytes);
        for s in &r.plan {
            assert!(s.start_window[0] <= s.start && s.start <= s.start_window[1]);
        }
        // One `start: (action) [duration]` line per action, as validators read plans.
        let text = plan_text(&r);
        assert_eq!(text.lines().count(), r.plan.len());
        assert!(text.lines().all(|l| l.contains(": (") && l.ends_with(']')));
        assert!(summary(&r).contains("peak arena"));
    }

    #[test]
    fn bad_pddl_is_a_diagnostic_at_its_line_and_column() {
        let dir = tempfile::tempdir().expect("temp dir");
        let domain = dir.path().join("d.pddl");
        std::fs::write(
            &domain,
            "(define (domain d)\n  (:requirements :durative-actions :derived-predicates))\n",
        )
        .expect("write");
        let e = plan_files(
            &domain,
            &bench("satellite", "instance-1.pddl"),
            &pddl::ModuleRegistry::new(),
            &PlanOptions::default(),
        )
        .expect_err("refused");
        assert_eq!(e.line_col(), Some((2, 36)));
        assert!(
            e.message.contains("requirement `:derived-predicates`"),
            "{}",
            e.message
        );
    }

    #[test]
    fn a_missing_firmware_is_a_clear_error_before_anything_runs() {
        let args = PlanArgs {
            domain: bench("satellite", "domain.pddl"),
            problem: bench("satellite", "instance-1.pddl"),
            native: false,
            emulated: true,
            firmware: Some("/nonexistent/rad750-firmware".into()),
            max_frames: 10,
            warm_reset_after_frames: None,
            reset_ticks: 10_000,
            json: false,
            plan_only: false,
            arena_kib: 1024,
            max_expansions: 0,
            time_limit: 0.0,
            duplicates: DuplicatesArg::Quiescent,
            no_compression: false,
            no_preferred: false,
            duration_costs: false,
        };
        let e = cli(args).expect_err("no firmware");
        assert!(
            e.contains("--firmware /nonexistent/rad750-firmware: no such file"),
            "{e}"
        );
    }

    #[test]
    fn the_arguments_parse_and_firmware_needs_emulated() {
        use clap::Parser;
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            plan: PlanArgs,
        }
        let a = Cli::try_parse_from([
            "hil",
            "d.pddl",
            "p.pddl",
            "--emulated",
            "--firmware",
            "fw.elf",
            "--json",
        ])
        .expect("parses");
        assert!(a.plan.emulated && a.plan.json);
        assert_eq!(a.plan.firmware.as_deref(), Some(Path::new("fw.elf")));
        // --firmware alone, and --native with --emulated, are refused by name.
        let e = Cli::try_parse_from(["hil", "d.pddl", "p.pddl", "--firmware", "fw.elf"])
            .err()
            .expect("refused");
        assert!(e.to_string().contains("--emulated"), "{e}");
        let e = Cli::try_parse_from(["hil", "d.pddl", "p.pddl", "--native", "--emulated"])
            .err()
            .expect("refused");
        assert!(e.to_string().contains("cannot be used with"), "{e}");
    }

    #[test]
    fn the_wire_configuration_is_the_native_search_configuration() {
        let options = PlanOptions::default();
        let wire = crate::plan_emulated::wire_config(&options).expect("fits");
        let back = flight_app::planner_config(&wire, flight_app::MAX_TEMPORAL_PLAN_ACTIONS);
        let native = options.config;
        assert_eq!(back.max_steps, native.max_steps);
        assert_eq!(back.compression, native.compression);
        assert_eq!(back.duplicates, native.duplicates);
        assert_eq!(back.preferred_operators, native.preferred_operators);
        assert_eq!(back.shed_when_full, native.shed_when_full);
        assert_eq!(back.relaxed_cost, native.relaxed_cost);
        assert_eq!(back.dropped_goals, native.dropped_goals);
    }
}
