//! A mission scenario end to end: load and plan it ([`prepare`]), pick its target
//! ([`make_target`]), fly and judge it ([`run`]), and write its reports ([`write_outputs`]).
//! `hil run`, campaigns and the benchmarks all go through here.
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::driver::{drive, MissionError, Progress};
use super::plan::MissionPlan;
use super::report::{self, MissionReport};
use super::target::{EmulatedTarget, MissionTarget, NativeTarget};
use crate::defmt_log::LogLine;
use crate::diag::Diagnostic;
use crate::firmware::{self, build_id_hex, FirmwareImage};
use crate::options::RunOptions;
use crate::qemu::QemuProfile;
use crate::scenario::{self, TargetKind};

/// Load a mission scenario and plan it against its task network.
pub fn prepare(path: &Path) -> Result<MissionPlan, Diagnostic> {
    MissionPlan::build(scenario::load(path)?)
}

/// Where the mission runs: the native target, or the emulated one (building the firmware
/// unless `options.firmware` names an image).
pub fn make_target(
    plan: &MissionPlan,
    options: &RunOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<(Box<dyn MissionTarget>, Option<FirmwareImage>), String> {
    let target = &plan.scenario.target;
    if options.native || target.kind == TargetKind::Native {
        return Ok((Box::new(NativeTarget::new()), None));
    }
    if options.serial.is_some() || target.serial.is_some() {
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
    let profile = QemuProfile::load(&target.profile).map_err(|e| e.to_string())?;
    let target = match &options.keep_nv {
        Some(path) => EmulatedTarget::new(
            profile,
            fw.clone(),
            options.realtime,
            path.clone(),
            options.echo_logs,
        ),
        None => EmulatedTarget::with_temporary_nv(
            profile,
            fw.clone(),
            options.realtime,
            options.echo_logs,
        )
        .map_err(|e| format!("cannot create the non-volatile memory file: {e}"))?,
    };
    Ok((Box::new(target), Some(fw)))
}

/// Fly `plan` on `target` and judge it.
pub fn run(
    plan: &MissionPlan,
    target: &mut dyn MissionTarget,
    firmware: Option<&FirmwareImage>,
    progress: Progress<'_>,
) -> Result<MissionReport, MissionError> {
    let started = Instant::now();
    let flown = drive(plan, target, progress)?;
    Ok(MissionReport::new(
        plan,
        flown,
        target.describe(),
        target.counts_cycles(),
        firmware,
        started.elapsed(),
    ))
}

/// Files a mission run writes besides its run directory.
#[derive(Clone, Debug, Default)]
pub struct MissionOutputs {
    pub report: Option<PathBuf>,
    pub junit: Option<PathBuf>,
    pub gantt: Option<PathBuf>,
}

/// Write `target/hil-runs/<scenario>/` (report.json, junit.xml, gantt.html, target.log,
/// transcript.txt) and the extra copies `outputs` asks for; returns the files written.
pub fn write_outputs(
    plan: &MissionPlan,
    report: &MissionReport,
    logs: &[LogLine],
    outputs: &MissionOutputs,
) -> Result<Vec<PathBuf>, String> {
    let dir = crate::repo_root()
        .join("target/hil-runs")
        .join(report.scenario.replace(['/', ' '], "_"));
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let json = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
    let html = super::gantt::render(report, &plan.network, plan.start, plan.end);
    let xml = report::junit(report);
    let log: String = logs.iter().map(|l| format!("{l}\n")).collect();
    let transcript: String = report.transcript.iter().map(|l| format!("{l}\n")).collect();
    let mut written = Vec::new();
    for (name, explicit, contents) in [
        ("report.json", &outputs.report, &json),
        ("junit.xml", &outputs.junit, &xml),
        ("gantt.html", &outputs.gantt, &html),
        ("target.log", &None, &log),
        ("transcript.txt", &None, &transcript),
    ] {
        for file in [Some(dir.join(name)), explicit.clone()]
            .into_iter()
            .flatten()
        {
            std::fs::write(&file, contents)
                .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
            written.push(file);
        }
    }
    Ok(written)
}
