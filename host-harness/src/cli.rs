//! The `hil` command line: clap's definitions of the subcommands and what each one does with
//! the library. Exit status: 0 when every expectation or step holds, 1 when one fails, 2 when
//! the run could not start (bad input, no QEMU, a firmware that does not build).
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate as hil;
use crate::firmware::{self, build_id_hex, FirmwareImage};
use crate::mission::runner::{self, MissionOutputs};
use crate::options::RunOptions;
use crate::qemu::QemuProfile;
use crate::run::{run_scenario, summary};
use crate::scenario;

#[derive(Parser)]
#[command(
    name = "hil",
    version,
    about = "Hardware-in-the-loop harness for the RAD750-proxy target"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario: boot the target under QEMU (or use --serial), drive it, report.
    Run {
        /// Scenario file (TOML), e.g. scenarios/smoke.toml
        scenario: PathBuf,
        /// Talk to a real target on this serial device instead of launching QEMU.
        #[arg(long, value_name = "DEVICE")]
        serial: Option<String>,
        /// Baud rate for --serial.
        #[arg(long)]
        baud: Option<u32>,
        /// Firmware ELF (default: build firmware/image). With --serial, used to decode logs.
        #[arg(long, value_name = "ELF")]
        firmware: Option<PathBuf>,
        /// Pace guest time by the wall clock (icount align=on) instead of lockstep.
        #[arg(long)]
        realtime: bool,
        /// Write the JSON report here.
        #[arg(long, value_name = "FILE")]
        report: Option<PathBuf>,
        /// Write JUnit XML here (missions: one test case per expectation).
        #[arg(long, value_name = "FILE")]
        junit: Option<PathBuf>,
        /// Write the Gantt chart (HTML with SVG) here.
        #[arg(long, value_name = "FILE")]
        gantt: Option<PathBuf>,
        /// Run a mission on the native target (flight application compiled into hil, no QEMU).
        #[arg(long)]
        native: bool,
        /// Do not print the target's log lines.
        #[arg(long)]
        no_logs: bool,
        /// Keep the emulated target's non-volatile memory image in this file (default: a
        /// temporary file, removed when the run ends).
        #[arg(long, value_name = "FILE")]
        keep_nv: Option<PathBuf>,
    },
    /// Timing budgets: measure on the emulated target (guest ticks and instructions under
    /// icount), print quantity / measured / budget / headroom / change, fail naming every
    /// quantity over budget. `hil bench link` and friends are wall-time benchmarks.
    Bench {
        #[command(subcommand)]
        what: Option<BenchWhat>,
        /// Budgets file (default: budgets.toml in the repository).
        #[arg(long, value_name = "FILE")]
        budgets: Option<PathBuf>,
        /// Baseline file (default: budgets-baseline.toml in the repository).
        #[arg(long, value_name = "FILE")]
        baseline: Option<PathBuf>,
        /// Print JSON instead of the table.
        #[arg(long)]
        json: bool,
        /// Record these measurements as the new baseline.
        #[arg(long)]
        save_baseline: bool,
        /// Firmware ELF to measure (default: build it).
        #[arg(long, value_name = "ELF")]
        firmware: Option<PathBuf>,
    },
    /// Build the firmware image and print its path and build id.
    Build,
    /// Campaign: many seeded random-reset variants of a mission scenario, in parallel,
    /// shardable across machines, merged into one report.
    Campaign(hil::campaign::CampaignArgs),
    /// The strategy study of seed 000 V.A on the host lander simulation: BSM-1 under Static,
    /// Ground, FE and Replan and three energy variants, mean utility with 95% intervals beside
    /// the analytical model (equations 2-5); shardable (--shard, or the batch engine's
    /// environment), `hil study merge` to merge.
    Study(hil::study::StudyArgs),
    /// Lander missions on the host simulation (seed 000): `hil lander run FILE` runs one
    /// scenario (RSM-1, an ELAP scenario) and checks its expectations; exit 0 all met, 1 one
    /// failed, 2 bad input.
    #[command(subcommand)]
    Lander(hil::lander::LanderCommand),
    /// Plan a temporal PDDL problem with the onboard temporal planner (seed 001): print the
    /// plan, its makespan, the search statistics and the planner's peak arena bytes.
    Plan(hil::plan::PlanArgs),
    /// The planetary rover mission (seed 001): `hil rover run FILE [--emulated] [--json]` plans,
    /// dispatches with start windows, replans on overruns and opportunistic goals, and checks
    /// the file's expectations; exit 0 all met, 1 one failed, 2 bad input.
    #[command(subcommand)]
    Rover(hil::rover::RoverCommand),
    /// The target's non-volatile memory image: provision the key that authenticates uplinks and
    /// ground commands, or show what it holds.
    Nv {
        #[command(subcommand)]
        what: NvWhat,
    },
}

#[derive(Subcommand)]
enum NvWhat {
    /// Write a key into the security area of a non-volatile memory image (QEMU's ivshmem
    /// backing file, or an image for a board), creating the file if it is not there. The
    /// anti-replay counter stays: a new key starts at sequence 0, the same key keeps its
    /// counter.
    Provision {
        /// Key file: 32 raw bytes or 64 hexadecimal digits.
        #[arg(long, value_name = "FILE")]
        key_file: PathBuf,
        /// The key's security parameter index (the ground signs with the same).
        #[arg(long, default_value_t = hil::mission::auth::TEST_KEY.spi)]
        spi: u16,
        /// The non-volatile memory image.
        #[arg(long, value_name = "FILE")]
        nv: PathBuf,
        /// Size of the image if it is created or shorter (default: the emulated target's 1 MiB).
        #[arg(long, default_value_t = hil::mission::target::native::NV_BYTES as u64)]
        size: u64,
    },
    /// Print the provisioned key's SPI and check (never the key), the last accepted sequence
    /// number and the ground holds.
    Show {
        /// The non-volatile memory image.
        #[arg(long, value_name = "FILE")]
        nv: PathBuf,
    },
}

#[derive(Subcommand)]
enum BenchWhat {
    /// Partitioning kernel: switch cost, window jitter, syscall round trip (guest ticks and
    /// instructions, deterministic), kernel RAM/ROM footprint.
    Kernel {
        /// Major frames to run before reading the accounting.
        #[arg(long, default_value_t = 300)]
        frames: u64,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Mission speed: the flybys' lockstep speed-up on the emulated target over each link
    /// transport (whole run and after boot), the native target and the ratio, a campaign's
    /// throughput with one and two emulated targets at once, recovery instructions (wall times
    /// depend on the host).
    Missions {
        /// Native repetitions per scenario (averaged).
        #[arg(long, default_value_t = 20)]
        native_runs: u32,
        /// Runs of the campaign part (emulated one and two at once, and native).
        #[arg(long, default_value_t = 8)]
        campaign_runs: u32,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Planner cycle cost against network size (synthetic networks of 8, 32, 128 and 256 tasks,
    /// natively, in validity checks), the growth exponent, and each network's uplink and
    /// checkpoint size against the uplink buffer and a checkpoint slot.
    Planner {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Boot-to-Hello time, ping round trips and frames per second on the link.
    Link {
        /// Number of pings (sequential, then the same number pipelined).
        #[arg(long, default_value_t = 1000)]
        pings: u32,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// Parse the command line and run it.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match execute(cli.command) {
        Ok(code) => code,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}

fn run_mission(
    path: &std::path::Path,
    options: &RunOptions,
    outputs: &MissionOutputs,
) -> Result<ExitCode, String> {
    let mut plan = runner::prepare(path).map_err(|e| e.render())?;
    plan.realtime = options.realtime;
    let (mut target, fw) = runner::make_target(&plan, options, &mut |l| println!("  {l}"))?;
    println!("  target    {}", target.describe());
    let (start, end) = (plan.start, plan.end);
    let bar = indicatif::ProgressBar::new((end.0 - start.0) / 1_000_000);
    bar.set_style(
        indicatif::ProgressStyle::with_template("  {bar:40} {msg} mission time")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let result = runner::run(&plan, target.as_mut(), fw.as_ref(), &mut |now, s, _| {
        bar.set_position((now.0 - s.0) / 1_000_000);
        bar.set_message(crate::time::fmt_time(now));
    });
    bar.finish_and_clear();
    let report = result.map_err(|e| e.to_string())?;
    let logs = target.take_logs();
    drop(target);
    println!("{}", crate::mission::report::summary(&report));
    let written = runner::write_outputs(&plan, &report, &logs, outputs)?;
    println!(
        "  reports: {}",
        written
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn bench_budgets(
    budgets: Option<PathBuf>,
    baseline: Option<PathBuf>,
    json: bool,
    save_baseline: bool,
    firmware: Option<PathBuf>,
) -> Result<ExitCode, String> {
    use hil::budget;
    let root = hil::repo_root();
    let budgets_path = budgets.unwrap_or_else(|| root.join("budgets.toml"));
    let baseline_path = baseline.unwrap_or_else(|| root.join("budgets-baseline.toml"));
    let list = budget::load(&budgets_path).map_err(|e| e.render())?;
    let fw = match firmware {
        Some(elf) => FirmwareImage::open(&elf).map_err(|e| e.to_string())?,
        None => firmware::build().map_err(|e| e.to_string())?,
    };
    let (measured, missing) = budget::measure(&list, &fw, &mut |l| eprintln!("  {l}"));
    let base = budget::load_baseline(&baseline_path)?;
    let rows = budget::evaluate(&list, &measured, &missing, &base);
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&rows).map_err(|e| e.to_string())?
        );
    } else {
        println!(
            "timing budgets ({}; firmware build {}; guest ticks/instructions under icount)",
            budgets_path.display(),
            build_id_hex(&fw.build_id)
        );
        print!("{}", budget::table(&rows));
    }
    if save_baseline {
        budget::save_baseline(&baseline_path, &rows)?;
        eprintln!("baseline written to {}", baseline_path.display());
    }
    let offenders = budget::offenders(&rows);
    if offenders.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        for o in &offenders {
            eprintln!("budget exceeded: {o}");
        }
        Ok(ExitCode::FAILURE)
    }
}

fn execute(command: Command) -> Result<ExitCode, String> {
    match command {
        Command::Run {
            scenario: path,
            serial,
            baud,
            firmware,
            realtime,
            report,
            junit,
            gantt,
            native,
            no_logs,
            keep_nv,
        } => {
            let scenario = scenario::load(&path).map_err(|e| e.render())?;
            println!("hil run {} — {}", scenario.name, scenario.description);
            let options = RunOptions {
                serial,
                baud,
                firmware,
                realtime,
                echo_logs: !no_logs,
                verbose: true,
                native,
                keep_nv,
            };
            if scenario.mission.is_some() {
                let outputs = MissionOutputs {
                    report,
                    junit,
                    gantt,
                };
                return run_mission(&path, &options, &outputs);
            }
            let result = run_scenario(&scenario, &options, &mut |line| println!("  {line}"))
                .map_err(|e| e.to_string())?;
            println!("{}", summary(&result));
            if let Some(out) = report {
                let json = serde_json::to_string_pretty(&result).map_err(|e| e.to_string())?;
                std::fs::write(&out, json)
                    .map_err(|e| format!("cannot write report {}: {e}", out.display()))?;
                println!("report: {}", out.display());
            }
            Ok(if result.passed {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            })
        }
        Command::Bench {
            what: None,
            budgets,
            baseline,
            json,
            save_baseline,
            firmware,
        } => bench_budgets(budgets, baseline, json, save_baseline, firmware),
        Command::Bench {
            what:
                Some(BenchWhat::Missions {
                    native_runs,
                    campaign_runs,
                    json,
                }),
            ..
        } => {
            let fw = firmware::build().map_err(|e| e.to_string())?;
            let profile = QemuProfile::load("rad750-proxy").map_err(|e| e.to_string())?;
            let root = hil::repo_root().join("scenarios");
            let scenarios = [
                root.join("flyby-nominal.toml"),
                root.join("flyby-early-reset.toml"),
                root.join("flyby-power-cycle.toml"),
            ];
            let bench = hil::bench_missions::missions(
                &profile,
                &fw,
                &scenarios,
                native_runs,
                &root.join("flyby-campaign.toml"),
                campaign_runs,
                &mut |l| eprintln!("  measuring: {l}"),
            )?;
            if json {
                println!("{}", serde_json::to_string_pretty(&bench).unwrap());
            } else {
                print!("{}", hil::bench_missions::table(&bench));
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Bench {
            what: Some(BenchWhat::Link { pings, json }),
            ..
        } => {
            if pings == 0 {
                return Err("--pings must be at least 1".into());
            }
            let fw = firmware::build().map_err(|e| e.to_string())?;
            let profile = QemuProfile::load("rad750-proxy").map_err(|e| e.to_string())?;
            let bench = hil::bench::link(&profile, &fw, pings).map_err(|e| e.to_string())?;
            if json {
                println!("{}", serde_json::to_string_pretty(&bench).unwrap());
            } else {
                print!("{}", hil::bench::link_table(&bench));
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Bench {
            what: Some(BenchWhat::Planner { json }),
            ..
        } => {
            let b = hil::bench_planner::planner(&hil::bench_planner::SIZES)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&b).unwrap());
            } else {
                print!("{}", hil::bench_planner::table(&b));
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Campaign(args) => hil::campaign::cli(args),
        Command::Study(args) => hil::study::cli(args),
        Command::Lander(command) => hil::lander::cli(command),
        Command::Plan(args) => hil::plan::cli(args),
        Command::Rover(command) => hil::rover::cli(command),
        Command::Bench {
            what: Some(BenchWhat::Kernel { frames, json }),
            ..
        } => {
            let fw = firmware::build().map_err(|e| e.to_string())?;
            let profile = QemuProfile::load("rad750-proxy").map_err(|e| e.to_string())?;
            let b = hil::bench_kernel::kernel(&profile, &fw, frames).map_err(|e| e.to_string())?;
            if json {
                println!("{}", serde_json::to_string_pretty(&b).unwrap());
            } else {
                print_kernel_bench(&b);
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Nv {
            what:
                NvWhat::Provision {
                    key_file,
                    spi,
                    nv,
                    size,
                },
        } => {
            let key = sdls::Key {
                spi,
                bytes: hil::mission::auth::read_key_file(&key_file)?,
            };
            hil::mission::auth::provision_nv_file(&nv, &key, size)?;
            println!(
                "provisioned key SPI {spi} (check {:08x}) into {} at offset {:#x}",
                key.check(),
                nv.display(),
                hil::mission::auth::NV_SECURITY_OFFSET
            );
            println!("{}", hil::mission::auth::describe_nv_file(&nv)?);
            Ok(ExitCode::SUCCESS)
        }
        Command::Nv {
            what: NvWhat::Show { nv },
        } => {
            println!("{}", hil::mission::auth::describe_nv_file(&nv)?);
            Ok(ExitCode::SUCCESS)
        }
        Command::Build => {
            let fw = firmware::build().map_err(|e| e.to_string())?;
            let fw = FirmwareImage::open(&fw.elf).map_err(|e| e.to_string())?;
            println!(
                "{} (build {})",
                fw.elf.display(),
                build_id_hex(&fw.build_id)
            );
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn print_kernel_bench(b: &crate::bench_kernel::KernelBench) {
    println!("kernel benchmark (guest timebase ticks at 16.6 MHz; 1 tick = 15.06 instructions under icount shift=2)");
    println!(
        "  partition switch     mean {:.1} ticks ({:.0} instructions), max {} ticks, over {} window starts",
        b.switch_mean_ticks, b.switch_mean_instructions, b.switch_max_ticks, b.switches
    );
    println!(
        "  syscall round trip   {:.2} ticks ({:.0} instructions)",
        b.syscall_round_trip_ticks, b.syscall_round_trip_instructions
    );
    println!(
        "  window start jitter  max {} ticks over {} frames",
        b.jitter_max_ticks, b.frames
    );
    for p in &b.partitions {
        println!(
            "    {:<10} jitter max {:>3} ticks, last frame {:>6} ticks, worst frame {:>6} ticks, overruns {}",
            p.name, p.max_jitter_ticks, p.frame_ticks, p.worst_frame_ticks, p.overruns
        );
    }
    println!(
        "  stale port messages  {} dropped (sender restarted since sending)",
        b.port_stale_dropped
    );
    let f = &b.footprint;
    println!(
        "  kernel RAM           {} bytes ({:.1} KiB; plus the {} KiB all-invalid page table)",
        f.kernel_ram_bytes,
        f.kernel_ram_bytes as f64 / 1024.0,
        f.page_table_bytes / 1024
    );
    println!(
        "  kernel ROM           {} bytes ({:.1} KiB) of a {} byte image",
        f.kernel_rom_bytes,
        f.kernel_rom_bytes as f64 / 1024.0,
        f.image_rom_bytes
    );
}
