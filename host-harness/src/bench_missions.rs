//! `hil bench missions`: how fast missions run, in wall time (host-dependent numbers, never
//! pass/fail): the lockstep speed-up of the flybys on the emulated target over each link
//! transport (with and without the QEMU start and boot), the same missions on the native target
//! and the ratio, a campaign's throughput with one emulated target at a time and with two at
//! once, and the recovery cost after the early reset in guest instructions (that one is
//! deterministic).
use std::path::{Path, PathBuf};
use std::time::Instant;

use fsw_bridge::{MissionTimeUs, TargetToHost};
use serde::Serialize;

use crate::campaign::{run_campaign, CampaignOptions};
use crate::defmt_log::LogLine;
use crate::firmware::FirmwareImage;
use crate::mission::report::MissionReport;
use crate::mission::runner::{prepare, run};
use crate::mission::target::{
    EmulatedTarget, MissionTarget, NativeTarget, ResetLanding, TargetError,
};
use crate::qemu::{QemuProfile, Transport};
use crate::session::Hello;

/// One emulated run of a scenario over one transport.
#[derive(Clone, Debug, Serialize)]
pub struct EmulatedSpeed {
    pub transport: String,
    /// Wall time of the whole run: QEMU start and boot included.
    pub wall_ms: f64,
    /// Wall time from the first Hello (the target booted) to the end.
    pub after_boot_ms: f64,
    /// Mission time over wall time, whole run.
    pub speedup: f64,
    /// Mission time over wall time after boot.
    pub speedup_after_boot: f64,
    pub passed: bool,
    pub transcript_sha256: String,
}

/// One scenario, emulated once per transport and native `native_runs` times.
#[derive(Clone, Debug, Serialize)]
pub struct MissionSpeed {
    pub scenario: String,
    /// Mission time covered, in seconds.
    pub mission_s: f64,
    pub emulated: Vec<EmulatedSpeed>,
    /// Mean wall time of one native run.
    pub native_wall_ms: f64,
    pub native_speedup: f64,
    /// How many times faster the native run is than the fastest emulated one (whole runs).
    pub native_over_emulated: f64,
    /// Guest instructions of the first frame after the first reset, if the scenario has one.
    pub recovery_instructions: Option<u64>,
}

/// A campaign run with `jobs` targets at once.
#[derive(Clone, Debug, Serialize)]
pub struct CampaignRun {
    pub jobs: usize,
    pub wall_ms: f64,
    pub runs_per_second: f64,
    pub passed: u32,
}

#[derive(Clone, Debug, Serialize)]
pub struct CampaignSpeed {
    pub scenario: String,
    pub runs: u32,
    /// The link transport of the emulated runs.
    pub transport: String,
    /// One emulated target at a time, then two at once.
    pub emulated: Vec<CampaignRun>,
    /// Throughput with two at once over throughput with one.
    pub two_jobs_over_one: f64,
    pub native_wall_ms_per_run: f64,
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

/// A target that notes when its first boot answered (the Hello), so that a run's wall time can
/// be split into the boot and the rest.
struct BootTimer<'a> {
    inner: &'a mut dyn MissionTarget,
    booted: Option<Instant>,
}

impl MissionTarget for BootTimer<'_> {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn counts_cycles(&self) -> bool {
        self.inner.counts_cycles()
    }
    fn provision_key(&mut self, key: &sdls::Key) -> Result<(), TargetError> {
        self.inner.provision_key(key)
    }
    fn boot(&mut self) -> Result<Hello, TargetError> {
        let hello = self.inner.boot()?;
        self.booted.get_or_insert_with(Instant::now);
        Ok(hello)
    }
    fn round(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        self.inner.round(wire, round)
    }
    fn warm_reset(&mut self, at: MissionTimeUs) -> Result<ResetLanding, TargetError> {
        self.inner.warm_reset(at)
    }
    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.inner.power_cycle()
    }
    fn observe(&mut self, msg: &TargetToHost) {
        self.inner.observe(msg)
    }
    fn take_logs(&mut self) -> Vec<LogLine> {
        self.inner.take_logs()
    }
    fn arm_mid_frame_reset(&mut self, seed: u64) {
        self.inner.arm_mid_frame_reset(seed)
    }
    fn reset_notes(&self) -> Vec<String> {
        self.inner.reset_notes()
    }
}

/// Run `path` on `target`: the report, the whole wall time and the wall time after the first
/// boot (both in ms).
fn run_one(
    path: &Path,
    target: &mut dyn MissionTarget,
    firmware: Option<&FirmwareImage>,
) -> Result<(MissionReport, f64, f64), String> {
    let prepared = prepare(path).map_err(|e| e.to_string())?;
    let mut timed = BootTimer {
        inner: target,
        booted: None,
    };
    let started = Instant::now();
    let report = run(&prepared, &mut timed, firmware, &mut |_, _, _| {})
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let ms = |since: Instant| since.elapsed().as_secs_f64() * 1000.0;
    let whole = ms(started);
    Ok((report, whole, timed.booted.map_or(whole, ms)))
}

/// Measure `scenarios` (emulated once per transport, native `native_runs` times each) and a
/// campaign of `campaign_runs` random-reset variants of `campaign_scenario` (emulated with one
/// target at a time and with two at once, and native).
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
        let mut emulated = Vec::new();
        let mut first_report = None;
        for transport in [Transport::Serial, Transport::SharedMemory] {
            progress(&format!(
                "{}: emulated, {}",
                path.display(),
                transport.name()
            ));
            let mut target = EmulatedTarget::with_temporary_nv(
                profile.clone().with_transport(transport),
                firmware.clone(),
                false,
                false,
            )
            .map_err(|e| format!("cannot create the non-volatile memory file: {e}"))?;
            let (report, wall_ms, after_boot_ms) = run_one(path, &mut target, Some(firmware))?;
            drop(target);
            let mission_s = mission_seconds(&report);
            emulated.push(EmulatedSpeed {
                transport: transport.name().into(),
                wall_ms,
                after_boot_ms,
                speedup: mission_s * 1000.0 / wall_ms.max(1e-3),
                speedup_after_boot: mission_s * 1000.0 / after_boot_ms.max(1e-3),
                passed: report.passed,
                transcript_sha256: report.transcript_sha256.clone(),
            });
            first_report.get_or_insert(report);
        }
        let report = first_report.expect("two transports");
        progress(&format!("{}: native x{native_runs}", path.display()));
        let mut native_ms = 0.0;
        for _ in 0..native_runs {
            let (_, ms, _) = run_one(path, &mut NativeTarget::new(), None)?;
            native_ms += ms;
        }
        native_ms /= f64::from(native_runs);
        let mission_s = mission_seconds(&report);
        let fastest = emulated
            .iter()
            .map(|e| e.wall_ms)
            .fold(f64::INFINITY, f64::min);
        rows.push(MissionSpeed {
            scenario: report.scenario.clone(),
            mission_s,
            emulated,
            native_wall_ms: native_ms,
            native_speedup: mission_s * 1000.0 / native_ms.max(1e-3),
            native_over_emulated: fastest / native_ms.max(1e-3),
            recovery_instructions: report.metrics.get("max_recovery_instructions").copied(),
        });
    }
    let runs = campaign_runs.max(1);
    let campaign = |native: bool, jobs: usize, progress: &mut dyn FnMut(&str)| {
        progress(&format!(
            "{}: campaign of {runs} runs, {} ({jobs} at once)",
            campaign_scenario.display(),
            if native { "native" } else { "emulated" }
        ));
        let mut opts = CampaignOptions::new(campaign_scenario, runs, 1);
        opts.native = native;
        opts.jobs = jobs;
        opts.firmware = (!native).then(|| firmware.elf.clone());
        let started = Instant::now();
        let report = run_campaign(&opts, &mut |_| {})?;
        let wall_ms = started.elapsed().as_secs_f64() * 1000.0;
        Ok::<_, String>(CampaignRun {
            jobs,
            wall_ms,
            runs_per_second: f64::from(runs) * 1000.0 / wall_ms.max(1e-3),
            passed: report.results.iter().filter(|r| r.passed).count() as u32,
        })
    };
    let one = campaign(false, 1, progress)?;
    let two = campaign(false, 2, progress)?;
    let native = campaign(true, 1, progress)?;
    let transport = crate::scenario::load(campaign_scenario)
        .ok()
        .and_then(|s| QemuProfile::load(&s.target.profile).ok())
        .map_or_else(|| "?".into(), |p| p.transport.name().to_string());
    Ok(MissionBench {
        missions: rows,
        campaign: CampaignSpeed {
            scenario: campaign_scenario.display().to_string(),
            runs,
            transport,
            two_jobs_over_one: two.runs_per_second / one.runs_per_second.max(1e-9),
            emulated: vec![one, two],
            native_wall_ms_per_run: native.wall_ms / f64::from(runs),
        },
    })
}

/// The table `hil bench missions` prints.
pub fn table(b: &MissionBench) -> String {
    let mut out = String::from(
        "mission speed (wall time; depends on the host and its load)\n\
         scenario                  mission  transport         whole run  speed-up   after boot  speed-up\n",
    );
    for r in &b.missions {
        for (i, e) in r.emulated.iter().enumerate() {
            let name = if i == 0 { r.scenario.as_str() } else { "" };
            let mission = if i == 0 {
                format!("{:>6.0} s", r.mission_s)
            } else {
                String::new()
            };
            out.push_str(&format!(
                "{:<25} {:>8}  {:<14} {:>9.0} ms {:>8.0}x {:>9.0} ms {:>8.0}x{}\n",
                name,
                mission,
                e.transport,
                e.wall_ms,
                e.speedup,
                e.after_boot_ms,
                e.speedup_after_boot,
                if e.passed {
                    ""
                } else {
                    "  (expectations FAILED)"
                }
            ));
        }
        let same = r
            .emulated
            .windows(2)
            .all(|w| w[0].transcript_sha256 == w[1].transcript_sha256);
        out.push_str(&format!(
            "{:<25} {:>8}  {:<14} {:>9.1} ms {:>8.0}x  (native/emulated {:.0}x){}{}\n",
            "",
            "",
            "native",
            r.native_wall_ms,
            r.native_speedup,
            r.native_over_emulated,
            r.recovery_instructions
                .map(|i| format!("; recovery {i} instructions"))
                .unwrap_or_default(),
            if same {
                ""
            } else {
                "; TRANSCRIPTS DIFFER between transports"
            }
        ));
    }
    let c = &b.campaign;
    out.push_str(&format!(
        "campaign {} x{} runs, emulated over {}:\n",
        c.scenario, c.runs, c.transport
    ));
    for run in &c.emulated {
        out.push_str(&format!(
            "  {} at once: {:>7.0} ms, {:.2} runs/s, {}/{} passed\n",
            run.jobs, run.wall_ms, run.runs_per_second, run.passed, c.runs
        ));
    }
    out.push_str(&format!(
        "  two at once over one at a time: {:.2}x throughput; native {:.1} ms per run\n",
        c.two_jobs_over_one, c.native_wall_ms_per_run
    ));
    out
}
