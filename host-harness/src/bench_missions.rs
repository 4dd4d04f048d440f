//! `hil bench missions`: how fast missions run, in wall time (host-dependent numbers, never
//! pass/fail): the lockstep speed-up of the flyby on the emulated target, the same mission on
//! the native target and the ratio between them, the wall time of one campaign run, and the
//! recovery cost after the early reset in guest instructions (that one is deterministic).
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use crate::campaign::{run_campaign, CampaignOptions};
use crate::firmware::FirmwareImage;
use crate::mission::report::MissionReport;
use crate::mission::runner::{prepare, run};
use crate::mission::target::{EmulatedTarget, NativeTarget};
use crate::qemu::QemuProfile;

/// One scenario, emulated once and native `native_runs` times.
#[derive(Clone, Debug, Serialize)]
pub struct MissionSpeed {
    pub scenario: String,
    /// Mission time covered, in seconds.
    pub mission_s: f64,
    /// Wall time of the emulated run (QEMU boot included).
    pub emulated_wall_ms: f64,
    /// Mission time over wall time, emulated target, lockstep.
    pub emulated_speedup: f64,
    /// Mean wall time of one native run.
    pub native_wall_ms: f64,
    pub native_speedup: f64,
    /// How many times faster the native run is.
    pub native_over_emulated: f64,
    /// Guest instructions of the first frame after the first reset, if the scenario has one.
    pub recovery_instructions: Option<u64>,
    pub passed: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct CampaignSpeed {
    pub scenario: String,
    pub runs: u32,
    pub jobs: usize,
    /// Wall time of the whole campaign over its runs.
    pub wall_ms_per_run: f64,
    pub native_wall_ms_per_run: f64,
    pub passed: u32,
}

#[derive(Clone, Debug, Serialize)]
pub struct MissionBench {
    pub missions: Vec<MissionSpeed>,
    pub campaign: CampaignSpeed,
}

fn mission_seconds(r: &MissionReport) -> f64 {
    let parse = |t: &str| {
        crate::time::parse_time(&t.into(), crate::time::Epoch::default())
            .map(|t| t.0)
            .unwrap_or(0)
    };
    (parse(&r.mission_end).saturating_sub(parse(&r.mission_start))) as f64 / 1e6
}

fn run_one(
    path: &Path,
    target: &mut dyn crate::mission::target::MissionTarget,
    firmware: Option<&FirmwareImage>,
) -> Result<(MissionReport, f64), String> {
    let prepared = prepare(path).map_err(|e| e.to_string())?;
    let started = Instant::now();
    let report = run(&prepared, target, firmware, &mut |_, _, _| {})
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((report, started.elapsed().as_secs_f64() * 1000.0))
}

/// Measure `scenarios` (emulated once each, native `native_runs` times each) and a campaign of
/// `campaign_runs` random-reset variants of `campaign_scenario`.
pub fn missions(
    profile: &QemuProfile,
    firmware: &FirmwareImage,
    scenarios: &[PathBuf],
    native_runs: u32,
    campaign_scenario: &Path,
    campaign_runs: u32,
    progress: &mut dyn FnMut(&str),
) -> Result<MissionBench, String> {
    let native_runs = native_runs.max(1);
    let mut rows = Vec::new();
    for path in scenarios {
        progress(&format!("{}: emulated", path.display()));
        let nv = std::env::temp_dir().join(format!("hil-bench-nv-{}.bin", std::process::id()));
        let mut target =
            EmulatedTarget::new(profile.clone(), firmware.clone(), false, nv.clone(), false);
        let started = Instant::now();
        let (emulated, _) = run_one(path, &mut target, Some(firmware))?;
        drop(target);
        let emulated_ms = started.elapsed().as_secs_f64() * 1000.0;
        let _ = std::fs::remove_file(&nv);
        progress(&format!("{}: native x{native_runs}", path.display()));
        let mut native_ms = 0.0;
        for _ in 0..native_runs {
            let (_, ms) = run_one(path, &mut NativeTarget::new(), None)?;
            native_ms += ms;
        }
        native_ms /= f64::from(native_runs);
        let mission_s = mission_seconds(&emulated);
        rows.push(MissionSpeed {
            scenario: emulated.scenario.clone(),
            mission_s,
            emulated_wall_ms: emulated_ms,
            emulated_speedup: mission_s * 1000.0 / emulated_ms.max(1e-3),
            native_wall_ms: native_ms,
            native_speedup: mission_s * 1000.0 / native_ms.max(1e-3),
            native_over_emulated: emulated_ms / native_ms.max(1e-3),
            recovery_instructions: emulated.metrics.get("max_recovery_instructions").copied(),
            passed: emulated.passed,
        });
    }
    let campaign = |native: bool, progress: &mut dyn FnMut(&str)| {
        progress(&format!(
            "{}: campaign of {campaign_runs} runs ({})",
            campaign_scenario.display(),
            if native { "native" } else { "emulated" }
        ));
        let mut opts = CampaignOptions::new(campaign_scenario, campaign_runs.max(1), 1);
        opts.native = native;
        opts.firmware = (!native).then(|| firmware.elf.clone());
        let started = Instant::now();
        let report = run_campaign(&opts, &mut |_| {})?;
        let ms = started.elapsed().as_secs_f64() * 1000.0;
        let passed = report.results.iter().filter(|r| r.passed).count() as u32;
        Ok::<_, String>((ms / f64::from(campaign_runs.max(1)), passed))
    };
    let (emulated_per_run, passed) = campaign(false, progress)?;
    let (native_per_run, _) = campaign(true, progress)?;
    Ok(MissionBench {
        missions: rows,
        campaign: CampaignSpeed {
            scenario: campaign_scenario.display().to_string(),
            runs: campaign_runs.max(1),
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            wall_ms_per_run: emulated_per_run,
            native_wall_ms_per_run: native_per_run,
            passed,
        },
    })
}

/// The table `hil bench missions` prints.
pub fn table(b: &MissionBench) -> String {
    let mut out = String::from(
        "mission speed (wall time; depends on the host and its load)\n\
         scenario                     mission   emulated  speed-up     native  speed-up  native/emulated  recovery (instr)\n",
    );
    for r in &b.missions {
        out.push_str(&format!(
            "{:<28} {:>6.0} s {:>8.0} ms {:>8.0}x {:>8.1} ms {:>8.0}x {:>15.0}x  {:>16}{}\n",
            r.scenario,
            r.mission_s,
            r.emulated_wall_ms,
            r.emulated_speedup,
            r.native_wall_ms,
            r.native_speedup,
            r.native_over_emulated,
            r.recovery_instructions
                .map(|i| i.to_string())
                .unwrap_or_else(|| "-".into()),
            if r.passed {
                ""
            } else {
                "  (expectations FAILED)"
            }
        ));
    }
    let c = &b.campaign;
    out.push_str(&format!(
        "campaign {} x{} runs ({} worker threads): {:.0} ms per run emulated, {:.1} ms per run native; {}/{} passed (emulated)\n",
        c.scenario, c.runs, c.jobs, c.wall_ms_per_run, c.native_wall_ms_per_run, c.passed, c.runs
    ));
    out
}
