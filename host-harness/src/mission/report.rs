//! Running a mission scenario end to end and reporting it: the terminal summary, the JSON
//! report, JUnit XML, and the Gantt chart.
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::driver::{drive, Mission, MissionError};
use super::expect::{self, Verdict};
use super::record::MissionRecord;
use super::target::{EmulatedTarget, MissionTarget, NativeTarget};
use super::time::fmt_time;
use super::CompiledNetwork;
use crate::firmware::{self, build_id_hex, FirmwareImage};
use crate::qemu::QemuProfile;
use crate::run::RunOptions;
use crate::scenario::{Scenario, ScenarioError, TargetKind};

/// A scenario whose mission has been checked against its task network.
pub struct PreparedMission {
    pub scenario: Scenario,
    pub path: PathBuf,
    pub network: CompiledNetwork,
    pub mission: Mission,
}

fn located(
    path: &Path,
    text: &str,
    span: Option<std::ops::Range<usize>>,
    message: String,
) -> ScenarioError {
    let (line, column) = crate::scenario::line_col(text, span.map(|s| s.start).unwrap_or(0));
    ScenarioError::Invalid {
        path: path.to_path_buf(),
        line,
        column,
        message,
    }
}

/// Compile the task network and resolve the mission; errors point into the scenario file (or
/// the task-network file).
pub fn prepare(path: &Path, scenario: Scenario) -> Result<PreparedMission, ScenarioError> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let spec = scenario
        .mission
        .as_ref()
        .expect("prepare is called for mission scenarios");
    let net_path = super::driver::network_path(path, &spec.get_ref().tasknet);
    let network = CompiledNetwork::compile(&net_path).map_err(|m| {
        located(
            path,
            &text,
            Some(spec.span()),
            format!("mission.tasknet: {m}"),
        )
    })?;
    for (i, e) in scenario.expect.iter().enumerate() {
        expect::validate(e.get_ref(), &network)
            .map_err(|m| located(path, &text, Some(e.span()), format!("expect[{i}].{m}")))?;
    }
    let mission = Mission::resolve(&scenario, spec.get_ref(), &network).map_err(|e| {
        let msg = e.to_string();
        let span = msg
            .strip_prefix("events[")
            .and_then(|r| r.split(']').next())
            .and_then(|i| i.parse::<usize>().ok())
            .and_then(|i| scenario.events.get(i))
            .map(|e| e.span())
            .or_else(|| msg.starts_with("mission.").then(|| spec.span()));
        located(path, &text, span, msg)
    })?;
    // The spacecraft's names are checked now too, not halfway into a run.
    super::sim::Spacecraft::new(&scenario.spacecraft, &network, mission.start, 0)
        .map_err(|e| located(path, &text, None, format!("{}: {}", e.field, e.message)))?;
    Ok(PreparedMission {
        path: path.to_path_buf(),
        scenario,
        network,
        mission,
    })
}

/// One task instance on the Gantt chart and in the JSON report.
#[derive(Clone, Debug, Serialize)]
pub struct GanttRow {
    pub name: String,
    pub origin: String,
    pub planned_start: Option<String>,
    pub start: Option<String>,
    pub end: Option<String>,
    pub outcome: String,
}

/// The JSON report of a mission run.
#[derive(Clone, Debug, Serialize)]
pub struct MissionReport {
    pub scenario: String,
    pub description: String,
    pub seed: u64,
    pub target: String,
    pub firmware_build_id: Option<String>,
    pub passed: bool,
    pub expectations: Vec<Verdict>,
    pub tasks: Vec<GanttRow>,
    pub events: Vec<(String, String)>,
    pub resets: Vec<super::record::ResetRecord>,
    /// Every boot with its boot-to-ready cost (emulated target).
    pub boots: Vec<super::record::BootRecord>,
    pub faults: Vec<(String, String)>,
    pub metrics: std::collections::BTreeMap<String, u64>,
    pub frames: u64,
    pub transcript_sha256: String,
    pub transcript_frames: u64,
    pub injected_link_faults: u64,
    pub mission_start: String,
    pub mission_end: String,
    pub wall_time_ms: u64,
    /// Mission time covered per second of wall time.
    pub speedup: f64,
    pub decisions: Vec<super::record::Decision>,
    #[serde(skip)]
    pub record: MissionRecord,
    /// Every frame both ways, one readable line each (the hashed transcript).
    #[serde(skip)]
    pub transcript: Vec<String>,
}

/// Where the mission runs.
pub fn make_target(
    prepared: &PreparedMission,
    options: &RunOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<(Box<dyn MissionTarget>, Option<FirmwareImage>), String> {
    let native = options.native || prepared.scenario.target.kind == TargetKind::Native;
    if native {
        return Ok((Box::new(NativeTarget::new()), None));
    }
    if options.serial.is_some() || prepared.scenario.target.serial.is_some() {
        return Err("missions on a real serial board are not supported yet: resets need QEMU's QMP (use target.kind = \"qemu\" or \"native\")".into());
    }
    let fw = match &options.firmware {
        Some(elf) => FirmwareImage::open(elf).map_err(|e| e.to_string())?,
        None => {
            progress("building firmware (cargo, powerpc-unknown-linux-gnu) ...");
            firmware::build().map_err(|e| e.to_string())?
        }
    };
    progress(&format!(
        "firmware  build {}  {}",
        build_id_hex(&fw.build_id),
        fw.elf.display()
    ));
    let profile =
        QemuProfile::load(&prepared.scenario.target.profile).map_err(|e| e.to_string())?;
    let nv = std::env::temp_dir().join(format!(
        "hil-nv-{}-{}.bin",
        std::process::id(),
        NV_COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    Ok((
        Box::new(EmulatedTarget::new(
            profile,
            fw.clone(),
            options.realtime,
            nv,
            options.echo_logs,
        )),
        Some(fw),
    ))
}

static NV_COUNTER: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

/// Run a prepared mission on `target` and judge it.
pub fn run(
    prepared: &PreparedMission,
    target: &mut dyn MissionTarget,
    firmware: Option<&FirmwareImage>,
    progress: super::driver::Progress<'_>,
) -> Result<MissionReport, MissionError> {
    let started = Instant::now();
    let run = drive(
        &prepared.mission,
        &prepared.network,
        &prepared.scenario.spacecraft,
        target,
        progress,
    )?;
    let wall = started.elapsed();
    let record = run.record;
    let expectations: Vec<Verdict> = prepared
        .scenario
        .expect
        .iter()
        .enumerate()
        .map(|(i, e)| {
            expect::evaluate(
                i + 1,
                e.get_ref(),
                &record,
                &prepared.network,
                target.counts_cycles(),
            )
        })
        .collect();
    let t = |x: Option<u64>| x.map(|v| fmt_time(fsw_bridge::MissionTimeUs(v)));
    let tasks = record
        .instances
        .iter()
        .map(|i| GanttRow {
            name: i.name.clone(),
            origin: i.origin.clone(),
            planned_start: t(i.committed_at),
            start: t(i.started_at),
            end: t(i.ended_at),
            outcome: i.outcome_name().into(),
        })
        .collect();
    let span_us = prepared.mission.end.0 - prepared.mission.start.0;
    Ok(MissionReport {
        scenario: prepared.scenario.name.clone(),
        description: prepared.scenario.description.clone(),
        seed: prepared.scenario.seed,
        target: target.describe(),
        firmware_build_id: firmware.map(|f| build_id_hex(&f.build_id)),
        passed: expectations.iter().all(|v| v.passed),
        expectations,
        tasks,
        events: record
            .labels
            .iter()
            .map(|(at, l)| (fmt_time(fsw_bridge::MissionTimeUs(*at)), l.clone()))
            .collect(),
        resets: record.resets.clone(),
        boots: record.boots.clone(),
        faults: record
            .faults
            .iter()
            .map(|(at, l)| (fmt_time(fsw_bridge::MissionTimeUs(*at)), l.clone()))
            .collect(),
        metrics: record.metrics.clone(),
        frames: record.frames,
        transcript_sha256: run.transcript_sha256,
        transcript_frames: run.transcript_frames,
        transcript: run.transcript,
        injected_link_faults: run.injected_link_faults,
        mission_start: fmt_time(prepared.mission.start),
        mission_end: fmt_time(prepared.mission.end),
        wall_time_ms: wall.as_millis() as u64,
        speedup: span_us as f64 / 1e6 / wall.as_secs_f64().max(1e-9),
        decisions: record.decisions.clone(),
        record,
    })
}

/// The terminal summary.
pub fn summary(r: &MissionReport) -> String {
    let mut out = String::new();
    out.push_str("  as executed:\n");
    for row in &r.tasks {
        out.push_str(&format!(
            "    {:<28} {:<10} {} - {}  {}\n",
            row.name,
            row.origin,
            row.start.as_deref().unwrap_or("-"),
            row.end.as_deref().unwrap_or("-"),
            row.outcome
        ));
    }
    if let Some(ticks) = r.boots.first().and_then(|b| b.boot_to_ready_ticks) {
        out.push_str(&format!(
            "  boot ({}): ready after {ticks} ticks = {} instructions{}\n",
            r.boots[0].reset_cause,
            super::record::to_instructions(ticks),
            r.boots[0]
                .kernel_boot_ticks
                .map(|k| format!(" (kernel {k}, executive {})", ticks.saturating_sub(k)))
                .unwrap_or_default()
        ));
    }
    for reset in &r.resets {
        let cost = match (
            reset.boot_to_ready_ticks,
            reset.recovery_ticks,
            reset.reset_recovery_ticks,
        ) {
            (Some(boot), Some(recovery), Some(total)) => format!(
                "; reset to repaired plan {total} ticks = {} instructions (boot to ready {boot}, recovery {recovery})",
                super::record::to_instructions(total)
            ),
            (_, Some(recovery), _) => format!(
                "; recovery took {recovery} ticks = {} instructions",
                super::record::to_instructions(recovery)
            ),
            _ => String::new(),
        };
        out.push_str(&format!(
            "  {} at {}: down {} s, restarted ({}), {}{cost}\n",
            reset.kind,
            fmt_time(fsw_bridge::MissionTimeUs(reset.at)),
            reset.recovery_us / 1_000_000,
            reset.reset_cause,
            match &reset.restored_from {
                Some(from) => format!("plan restored from the {from}"),
                None => "no plan restored".to_string(),
            },
        ));
    }
    out.push_str("  expectations:\n");
    for v in &r.expectations {
        out.push_str(&format!(
            "    [{}] {}: {}\n",
            if v.passed { "ok  " } else { "FAIL" },
            v.what,
            v.detail
        ));
    }
    let passed = r.expectations.iter().filter(|v| v.passed).count();
    out.push_str(&format!(
        "{} {}: {}/{} expectations met; {} frames, mission {} to {} in {:.1} s wall ({:.0}x real time); transcript sha256 {}",
        if r.passed { "PASS" } else { "FAIL" },
        r.scenario,
        passed,
        r.expectations.len(),
        r.frames,
        r.mission_start,
        r.mission_end,
        r.wall_time_ms as f64 / 1000.0,
        r.speedup,
        &r.transcript_sha256[..16],
    ));
    out
}

/// JUnit XML: one test case per expectation.
pub fn junit(r: &MissionReport) -> String {
    let esc = |s: &str| {
        s.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
    };
    let failures = r.expectations.iter().filter(|v| !v.passed).count();
    let mut x = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuite name=\"{}\" tests=\"{}\" failures=\"{}\" time=\"{:.3}\">\n",
        esc(&r.scenario),
        r.expectations.len(),
        failures,
        r.wall_time_ms as f64 / 1000.0
    );
    for v in &r.expectations {
        x.push_str(&format!(
            "  <testcase classname=\"{}\" name=\"{}\"",
            esc(&r.scenario),
            esc(&v.what)
        ));
        if v.passed {
            x.push_str("/>\n");
        } else {
            x.push_str(&format!(
                ">\n    <failure message=\"{}\"/>\n  </testcase>\n",
                esc(&v.detail)
            ));
        }
    }
    x.push_str("</testsuite>\n");
    x
}
