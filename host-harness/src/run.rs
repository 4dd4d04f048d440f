//! `hil run`: execute a scenario against a target and produce a verdict and a report.

pub use crate::options::RunOptions;
use std::time::{Duration, Instant};

use fsw_bridge::HostToTarget;
use serde::Serialize;

use crate::defmt_log::LogLine;
use crate::firmware::{self, build_id_hex, FirmwareImage};
use crate::link::corrupted_frame;
use crate::qemu::{LaunchOptions, QemuProfile};
use crate::scenario::{cause_name, ResetVia, Scenario, Step};
use crate::session::{Session, SessionError};

/// How long one ping may take before the step fails.
pub const PING_TIMEOUT: Duration = Duration::from_secs(5);
/// Lockstep rounds a link check runs after a Hello to take in what the boot queued.
pub const SYNC_ROUNDS: u32 = 64;

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Firmware(#[from] firmware::FirmwareError),
    #[error(transparent)]
    Qemu(#[from] crate::qemu::QemuError),
    #[error(transparent)]
    Session(#[from] SessionError),
}

#[derive(Clone, Debug, Serialize)]
pub struct StepReport {
    pub index: usize,
    pub step: String,
    pub passed: bool,
    pub detail: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct PingStats {
    pub count: usize,
    pub median_us: u64,
    pub p99_us: u64,
    pub max_us: u64,
}

impl PingStats {
    pub fn from_rtts(rtts: &mut [Duration]) -> Option<Self> {
        if rtts.is_empty() {
            return None;
        }
        rtts.sort();
        let at = |q: f64| rtts[((rtts.len() - 1) as f64 * q).round() as usize].as_micros() as u64;
        Some(Self {
            count: rtts.len(),
            median_us: at(0.5),
            p99_us: at(0.99),
            max_us: at(1.0),
        })
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct LogReport {
    pub timestamp: String,
    pub level: String,
    pub message: String,
    pub location: Option<String>,
}

impl From<&LogLine> for LogReport {
    fn from(l: &LogLine) -> Self {
        Self {
            timestamp: l.timestamp.clone(),
            level: l.level.clone(),
            message: l.message.clone(),
            location: l.location.clone(),
        }
    }
}

/// The outcome of one scenario run (also the JSON report).
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    pub scenario: String,
    pub target: String,
    pub firmware_build_id: Option<String>,
    pub passed: bool,
    pub steps: Vec<StepReport>,
    pub pings: Option<PingStats>,
    /// Frames the host rejected (target to host direction).
    pub host_rejected_frames: u32,
    pub logs: Vec<LogReport>,
    pub wall_time_ms: u64,
    /// The end of QEMU's output at the end of the run (emulated targets).
    pub qemu_output_tail: Option<String>,
}

/// Run `scenario`; `progress` receives human-readable lines as the run goes.
pub fn run_scenario(
    scenario: &Scenario,
    options: &RunOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<RunReport, RunError> {
    let started = Instant::now();
    let serial = options
        .serial
        .clone()
        .or_else(|| scenario.target.serial.clone());
    let mut session = match &serial {
        Some(path) => {
            let fw = options
                .firmware
                .as_deref()
                .map(FirmwareImage::open)
                .transpose()?;
            let baud = options
                .baud
                .or(scenario.target.baud)
                .unwrap_or(crate::link::DEFAULT_BAUD);
            Session::open_serial(path, baud, fw.as_ref())?
        }
        None => {
            let fw = match &options.firmware {
                Some(elf) => FirmwareImage::open(elf)?,
                None => {
                    progress("building firmware (cargo, powerpc-unknown-linux-gnu) ...");
                    firmware::build()?
                }
            };
            progress(&format!(
                "firmware  build {}  {}",
                build_id_hex(&fw.build_id),
                fw.elf.display()
            ));
            let profile = QemuProfile::load(&scenario.target.profile)?;
            let launch = LaunchOptions {
                realtime: options.realtime,
                ..Default::default()
            };
            Session::boot_qemu(&profile, &fw, &launch)?
        }
    };
    session.echo_logs = options.echo_logs;
    progress(&format!("target    {}", session.describe));

    let hello_timeout = Duration::from_millis(scenario.target.hello_timeout_ms);
    let mut steps = Vec::new();
    let mut rtts = Vec::new();
    let mut build_id = None;
    let total = scenario.steps.len();
    for (index, step) in scenario.steps.iter().enumerate() {
        let outcome = run_step(step, &mut session, hello_timeout, &mut rtts, &mut build_id);
        let (passed, detail) = match outcome {
            Ok(detail) => (true, detail),
            Err(detail) => (false, detail),
        };
        progress(&format!(
            "[{}/{}] {:<36} {}  {}",
            index + 1,
            total,
            step.describe(),
            if passed { "ok  " } else { "FAIL" },
            detail
        ));
        steps.push(StepReport {
            index: index + 1,
            step: step.describe(),
            passed,
            detail,
        });
        if !passed {
            for (later, step) in scenario.steps.iter().enumerate().skip(index + 1) {
                steps.push(StepReport {
                    index: later + 1,
                    step: step.describe(),
                    passed: false,
                    detail: "not run: an earlier step failed".into(),
                });
            }
            break;
        }
    }
    let report = RunReport {
        scenario: scenario.name.clone(),
        target: session.describe.clone(),
        firmware_build_id: build_id,
        passed: steps.iter().all(|s| s.passed),
        steps,
        pings: PingStats::from_rtts(&mut rtts),
        host_rejected_frames: session.link.host_counters().errors(),
        logs: session.logs.iter().map(LogReport::from).collect(),
        wall_time_ms: started.elapsed().as_millis() as u64,
        qemu_output_tail: session.qemu_output_tail(),
    };
    Ok(report)
}

fn run_step(
    step: &Step,
    session: &mut Session,
    hello_timeout: Duration,
    rtts: &mut Vec<Duration>,
    build_id: &mut Option<String>,
) -> Result<String, String> {
    match step {
        Step::ExpectHello { reset_cause } => {
            let hello = session
                .expect_hello(hello_timeout)
                .map_err(|e| e.to_string())?;
            // Open the reliable link and take in what the boot queued (its log lines).
            session
                .sync(SYNC_ROUNDS, PING_TIMEOUT)
                .map_err(|e| format!("after the Hello, the link did not settle: {e}"))?;
            *build_id = Some(build_id_hex(&hello.build_id));
            let detail = format!(
                "reset cause {}, boot {}, build {}",
                cause_name(hello.reset_cause),
                hello.boot_count,
                build_id_hex(&hello.build_id)
            );
            if reset_cause.matches(hello.reset_cause) {
                Ok(detail)
            } else {
                Err(format!(
                    "expected reset cause {reset_cause:?}; got {detail}"
                ))
            }
        }
        Step::Ping { count } => {
            let mut step_rtts = Vec::with_capacity(*count as usize);
            for seq in 0..*count {
                let (rtt, _) = session
                    .ping(seq, PING_TIMEOUT)
                    .map_err(|e| format!("ping {seq}: {e}"))?;
                step_rtts.push(rtt);
            }
            rtts.extend_from_slice(&step_rtts);
            let stats = PingStats::from_rtts(&mut step_rtts).expect("count >= 1");
            Ok(format!(
                "{} round trips, median {} us, p99 {} us",
                stats.count, stats.median_us, stats.p99_us
            ))
        }
        Step::WarmReset { via } => {
            match via {
                ResetVia::Qmp => session.warm_reset_qmp(),
                ResetVia::Link => session.request_reset(),
            }
            .map_err(|e| e.to_string())?;
            Ok(match via {
                ResetVia::Qmp => "QMP system_reset sent".into(),
                ResetVia::Link => "ResetRequest sent".into(),
            })
        }
        Step::CorruptFrames { count } => {
            let (_, before) = session
                .ping(u32::MAX - 1, PING_TIMEOUT)
                .map_err(|e| format!("ping before corruption: {e}"))?;
            for i in 0..*count {
                let frame = corrupted_frame(&HostToTarget::Ping { seq: i }, i as usize * 7 + 3);
                session.link.send_raw(&frame).map_err(|e| e.to_string())?;
            }
            let (_, after) = session
                .ping(u32::MAX, PING_TIMEOUT)
                .map_err(|e| format!("ping after corruption: {e}"))?;
            let counted = after.crc_errors - before.crc_errors;
            if counted == *count && after.frames_ok > before.frames_ok {
                Ok(format!(
                    "target counted {counted} CRC errors and still answers"
                ))
            } else {
                Err(format!(
                    "target counted {counted} CRC errors for {count} corrupted frames (counters before {before:?}, after {after:?})"
                ))
            }
        }
    }
}

/// The terminal summary printed after a run.
pub fn summary(report: &RunReport) -> String {
    let passed = report.steps.iter().filter(|s| s.passed).count();
    let mut out = format!(
        "{} {}: {}/{} steps passed in {:.1} s",
        if report.passed { "PASS" } else { "FAIL" },
        report.scenario,
        passed,
        report.steps.len(),
        report.wall_time_ms as f64 / 1000.0
    );
    if let Some(p) = &report.pings {
        out.push_str(&format!(
            "; {} pings, round trip median {} us, p99 {} us",
            p.count, p.median_us, p.p99_us
        ));
    }
    if report.host_rejected_frames > 0 {
        out.push_str(&format!(
            "; host rejected {} frames from the target",
            report.host_rejected_frames
        ));
    }
    for s in report.steps.iter().filter(|s| !s.passed) {
        out.push_str(&format!("\n  step {} ({}): {}", s.index, s.step, s.detail));
    }
    if !report.passed {
        if let Some(tail) = report.qemu_output_tail.as_deref().filter(|t| !t.is_empty()) {
            out.push_str(&format!("\n  the end of QEMU's output:\n{tail}"));
        }
    }
    out
}
