//! Scenario files (TOML), the first stage of `hil`'s pipeline: the file's schema, read and
//! checked once. A scenario is either a list of link-check steps or a mission; a mission is
//! resolved against its task network into a [`crate::mission::plan::MissionPlan`] next.
//! Every error is a [`Diagnostic`] at the file, line and column of the offending field.
//!
//! ```toml
//! name = "smoke"
//! description = "Boot, handshake, pings, warm reset through QMP."
//!
//! [target]
//! profile = "rad750-proxy"      # qemu/rad750-proxy.toml; or: serial = "/dev/ttyUSB0"
//!
//! [[steps]]
//! expect_hello = { reset_cause = "power-on" }
//! [[steps]]
//! ping = { count = 20 }
//! [[steps]]
//! warm_reset = { via = "qmp" }  # or "link": the target's own ResetRequest handling
//! [[steps]]
//! expect_hello = { reset_cause = "warm" }
//! [[steps]]
//! corrupt_frames = { count = 5 } # send 5 frames with one flipped bit; the target must count them
//! ```
pub mod mission;

use std::ops::Deref;
use std::path::{Path, PathBuf};

use fsw_bridge::ResetCause;
use serde::Deserialize;

use crate::diag::{Diagnostic, SourceFile};
use mission::{EventEntry, ExpectEntry, LinkSection, MissionSection, SpacecraftConfig};

/// Most pings one step may ask for.
pub const MAX_PINGS_PER_STEP: u32 = 100_000;
/// Most corrupted frames one step may send.
pub const MAX_CORRUPT_PER_STEP: u32 = 10_000;

/// A scenario file as read: its schema, its text (for locating later errors) and its path.
#[derive(Clone, Debug)]
pub struct Scenario {
    pub path: PathBuf,
    pub source: SourceFile,
    pub file: ScenarioFile,
}

impl Deref for Scenario {
    type Target = ScenarioFile;
    fn deref(&self) -> &ScenarioFile {
        &self.file
    }
}

/// The schema of a scenario file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Seed for everything random in the run (noise, probabilistic faults, link faults).
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub target: TargetSpec,
    /// Link-level steps (handshake, pings, resets). A scenario has steps or a mission.
    #[serde(default)]
    pub steps: Vec<Step>,
    /// A mission: task network, span, events, expectations (see [`mission`]).
    pub mission: Option<MissionSection>,
    #[serde(default)]
    pub spacecraft: SpacecraftConfig,
    #[serde(default)]
    pub events: Vec<EventEntry>,
    #[serde(default)]
    pub link: LinkSection,
    #[serde(default)]
    pub expect: Vec<ExpectEntry>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// Where the flight software runs: "qemu" (default: the emulated RAD750 proxy, or a real
    /// board with `serial`) or "native" (compiled into hil; missions only).
    #[serde(default)]
    pub kind: TargetKind,
    /// QEMU profile name (`qemu/<profile>.toml`) or path.
    #[serde(default = "default_profile")]
    pub profile: String,
    /// A real serial device instead of QEMU.
    pub serial: Option<String>,
    pub baud: Option<u32>,
    /// How long to wait for each Hello, in milliseconds of wall time.
    #[serde(default = "default_hello_timeout_ms")]
    pub hello_timeout_ms: u64,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, serde::Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum TargetKind {
    #[default]
    Qemu,
    Native,
}

impl Default for TargetSpec {
    fn default() -> Self {
        Self {
            kind: TargetKind::Qemu,
            profile: default_profile(),
            serial: None,
            baud: None,
            hello_timeout_ms: default_hello_timeout_ms(),
        }
    }
}

fn default_profile() -> String {
    "rad750-proxy".into()
}

fn default_hello_timeout_ms() -> u64 {
    20_000
}

#[derive(Clone, Debug, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Step {
    /// Wait for the target's Hello and check the reset cause it reports.
    ExpectHello { reset_cause: CauseName },
    /// Ping round trips; every Pong must carry the same sequence number.
    Ping { count: u32 },
    /// Reset the target, RAM kept.
    WarmReset { via: ResetVia },
    /// Send frames with one bit flipped; the target must count each as a CRC error and keep
    /// answering.
    CorruptFrames { count: u32 },
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum CauseName {
    PowerOn,
    Warm,
    Watchdog,
    HealthMonitor,
    KernelFault,
}

impl CauseName {
    pub fn matches(self, cause: ResetCause) -> bool {
        matches!(
            (self, cause),
            (Self::PowerOn, ResetCause::PowerOn)
                | (Self::Warm, ResetCause::Warm)
                | (Self::Watchdog, ResetCause::Watchdog)
                | (Self::HealthMonitor, ResetCause::HealthMonitor)
                | (Self::KernelFault, ResetCause::KernelFault)
        )
    }
}

/// Name of a reset cause as scenarios and reports spell it.
pub fn cause_name(cause: ResetCause) -> &'static str {
    match cause {
        ResetCause::PowerOn => "power-on",
        ResetCause::Warm => "warm",
        ResetCause::Watchdog => "watchdog",
        ResetCause::HealthMonitor => "health-monitor",
        ResetCause::KernelFault => "kernel-fault",
    }
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ResetVia {
    /// QMP `system_reset` (QEMU only).
    Qmp,
    /// A ResetRequest message on the link.
    Link,
}

impl Step {
    /// One line describing the step, for progress and reports.
    pub fn describe(&self) -> String {
        match self {
            Step::ExpectHello { reset_cause } => {
                format!("expect Hello, reset cause {reset_cause:?}")
            }
            Step::Ping { count } => format!("ping x{count}"),
            Step::WarmReset { via } => format!("warm reset via {via:?}"),
            Step::CorruptFrames { count } => format!("send {count} corrupted frames"),
        }
    }
}

/// Read, parse and check a scenario file.
pub fn load(path: &Path) -> Result<Scenario, Diagnostic> {
    let source = SourceFile::read(path)?;
    parse_source(source, path)
}

/// Parse and check scenario text; `path` names it in errors and anchors relative paths.
pub fn parse(text: &str, path: &Path) -> Result<Scenario, Diagnostic> {
    parse_source(SourceFile::new(path.display().to_string(), text), path)
}

fn parse_source(source: SourceFile, path: &Path) -> Result<Scenario, Diagnostic> {
    let file: ScenarioFile = toml::from_str(&source.text).map_err(|e| source.toml_error(&e, ""))?;
    let scenario = Scenario {
        path: path.to_path_buf(),
        source,
        file,
    };
    check(&scenario)?;
    Ok(scenario)
}

/// What can be checked without the task network: the kind of scenario and its steps.
fn check(s: &Scenario) -> Result<(), Diagnostic> {
    let src = &s.source;
    match (&s.mission, s.steps.is_empty()) {
        (None, true) => {
            return Err(src.error(
                0..0,
                "steps",
                "a scenario needs [[steps]] (link checks) or a [mission]",
            ))
        }
        (Some(_), false) => {
            return Err(src.error_at(
                "mission",
                "a scenario has either [[steps]] or a [mission], not both",
            ))
        }
        _ => {}
    }
    if s.mission.is_none() {
        for (what, present) in [
            ("events", !s.events.is_empty()),
            ("expect", !s.expect.is_empty()),
        ] {
            if present {
                return Err(src.error_at(what, format!("only a [mission] has {what}")));
            }
        }
        if s.target.kind == TargetKind::Native {
            return Err(src.error_at(
                "target.kind",
                "\"native\" runs missions only; link checks need the emulated target",
            ));
        }
    }
    for (i, step) in s.steps.iter().enumerate() {
        let (field, problem) = match step {
            Step::Ping { count } if *count == 0 || *count > MAX_PINGS_PER_STEP => (
                "ping.count",
                format!("{count} is out of range 1..={MAX_PINGS_PER_STEP}"),
            ),
            Step::CorruptFrames { count } if *count == 0 || *count > MAX_CORRUPT_PER_STEP => (
                "corrupt_frames.count",
                format!("{count} is out of range 1..={MAX_CORRUPT_PER_STEP}"),
            ),
            Step::WarmReset { via: ResetVia::Qmp } if s.target.serial.is_some() => (
                "warm_reset.via",
                "\"qmp\" needs a QEMU target, but target.serial is set".into(),
            ),
            _ => continue,
        };
        return Err(src.error_at(&format!("steps[{i}].{field}"), problem));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        parse(text, Path::new("s.toml")).unwrap_err().to_string()
    }

    #[test]
    fn a_valid_scenario_parses_with_defaults() {
        let s = parse(
            "name = \"x\"\n[[steps]]\nping = { count = 3 }\n",
            Path::new("s.toml"),
        )
        .unwrap();
        assert_eq!(s.target.profile, "rad750-proxy");
        assert!(matches!(s.steps[0], Step::Ping { count: 3 }));
    }

    #[test]
    fn unknown_step_names_file_line_field_and_variant() {
        let e = err("name = \"x\"\n[[steps]]\npong = { count = 3 }\n");
        assert!(e.starts_with("s.toml:3:1: steps[0]: "), "{e}");
        assert!(e.contains("unknown variant `pong`"), "{e}");
    }

    #[test]
    fn out_of_range_count_points_at_the_count() {
        let e = err("name = \"x\"\n\n[[steps]]\nping = { count = 0 }\n");
        assert_eq!(
            e,
            "s.toml:4:18: steps[0].ping.count: 0 is out of range 1..=100000"
        );
    }

    #[test]
    fn wrong_type_names_the_field() {
        let e = err("name = \"x\"\n[[steps]]\nping = { count = \"many\" }\n");
        assert!(e.starts_with("s.toml:3:"), "{e}");
        assert!(e.contains("invalid type"), "{e}");
    }

    #[test]
    fn missing_name_is_reported() {
        let e = err("[[steps]]\nping = { count = 1 }\n");
        assert!(e.contains("missing field `name`"), "{e}");
    }

    #[test]
    fn qmp_reset_on_a_serial_target_is_refused_at_the_step() {
        let e = err(
            "name = \"x\"\n[target]\nserial = \"/dev/ttyUSB0\"\n[[steps]]\nwarm_reset = { via = \"qmp\" }\n",
        );
        assert!(
            e.starts_with("s.toml:5:22: steps[0].warm_reset.via: "),
            "{e}"
        );
        assert!(e.contains("needs a QEMU target"), "{e}");
    }
}
