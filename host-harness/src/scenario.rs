//! Scenario files (TOML). A scenario names its target and lists steps; errors point at the file,
//! line and column of the offending field.
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
use std::ops::Range;
use std::path::{Path, PathBuf};

use fsw_bridge::ResetCause;
use serde::Deserialize;
use toml::Spanned;

use crate::mission::sim::SpacecraftConfig;
use crate::mission::spec::{EventSpec, ExpectSpec, LinkFaultSpec, MissionSpec};

/// Most pings one step may ask for.
pub const MAX_PINGS_PER_STEP: u32 = 100_000;
/// Most corrupted frames one step may send.
pub const MAX_CORRUPT_PER_STEP: u32 = 10_000;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
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
    pub steps: Vec<Spanned<Step>>,
    /// A mission: task network, span, events, expectations (see `crate::mission`).
    pub mission: Option<Spanned<MissionSpec>>,
    #[serde(default)]
    pub spacecraft: SpacecraftConfig,
    #[serde(default)]
    pub events: Vec<Spanned<EventSpec>>,
    #[serde(default)]
    pub link: LinkFaultSpec,
    #[serde(default)]
    pub expect: Vec<Spanned<ExpectSpec>>,
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

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
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
}

impl CauseName {
    pub fn matches(self, cause: ResetCause) -> bool {
        matches!(
            (self, cause),
            (Self::PowerOn, ResetCause::PowerOn)
                | (Self::Warm, ResetCause::Warm)
                | (Self::Watchdog, ResetCause::Watchdog)
                | (Self::HealthMonitor, ResetCause::HealthMonitor)
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

/// A scenario file that could not be used: where, and why.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("cannot read scenario {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}:{column}: {message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
}

/// Read, parse and validate a scenario file.
pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScenarioError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&text, path)
}

/// Parse and validate scenario text; `path` is used in error messages.
pub fn parse(text: &str, path: &Path) -> Result<Scenario, ScenarioError> {
    let invalid = |span: Option<Range<usize>>, message: String| {
        let (line, column) = line_col(text, span.map(|s| s.start).unwrap_or(0));
        ScenarioError::Invalid {
            path: path.to_path_buf(),
            line,
            column,
            message,
        }
    };
    let scenario: Scenario =
        toml::from_str(text).map_err(|e| invalid(e.span(), e.message().to_string()))?;
    match (&scenario.mission, scenario.steps.is_empty()) {
        (None, true) => {
            return Err(invalid(
                None,
                "a scenario needs [[steps]] (link checks) or a [mission]".into(),
            ))
        }
        (Some(m), false) => {
            return Err(invalid(
                Some(m.span()),
                "mission: a scenario has either [[steps]] or a [mission], not both".into(),
            ))
        }
        _ => {}
    }
    if scenario.mission.is_none() {
        for (what, span) in [
            ("events", scenario.events.first().map(|e| e.span())),
            ("expect", scenario.expect.first().map(|e| e.span())),
        ] {
            if let Some(span) = span {
                return Err(invalid(
                    Some(span),
                    format!("{what}: only a [mission] has {what}"),
                ));
            }
        }
        if scenario.target.kind == TargetKind::Native {
            return Err(invalid(
                None,
                "target.kind: \"native\" runs missions only".into(),
            ));
        }
    }
    for step in &scenario.steps {
        let problem = match step.get_ref() {
            Step::Ping { count } if *count == 0 || *count > MAX_PINGS_PER_STEP => Some(format!(
                "ping.count: {count} is out of range 1..={MAX_PINGS_PER_STEP}"
            )),
            Step::CorruptFrames { count } if *count == 0 || *count > MAX_CORRUPT_PER_STEP => Some(
                format!("corrupt_frames.count: {count} is out of range 1..={MAX_CORRUPT_PER_STEP}"),
            ),
            Step::WarmReset { via: ResetVia::Qmp } if scenario.target.serial.is_some() => {
                Some("warm_reset.via: \"qmp\" needs a QEMU target, but target.serial is set".into())
            }
            _ => None,
        };
        if let Some(message) = problem {
            return Err(invalid(Some(step.span()), message));
        }
    }
    Ok(scenario)
}

/// 1-based line and column of a byte offset in a TOML file (for `file:line:column` errors).
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map(|i| i + 1).unwrap_or(0) + 1;
    (line, column)
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
        assert!(matches!(s.steps[0].get_ref(), Step::Ping { count: 3 }));
    }

    #[test]
    fn unknown_step_names_file_line_and_variant() {
        let e = err("name = \"x\"\n[[steps]]\npong = { count = 3 }\n");
        assert!(e.starts_with("s.toml:3:1: "), "{e}");
        assert!(e.contains("unknown variant `pong`"), "{e}");
    }

    #[test]
    fn out_of_range_count_points_at_the_step() {
        let e = err("name = \"x\"\n\n[[steps]]\nping = { count = 0 }\n");
        assert!(e.starts_with("s.toml:3:"), "{e}");
        assert!(e.contains("ping.count: 0 is out of range"), "{e}");
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
    fn qmp_reset_on_a_serial_target_is_refused() {
        let e = err(
            "name = \"x\"\n[target]\nserial = \"/dev/ttyUSB0\"\n[[steps]]\nwarm_reset = { via = \"qmp\" }\n",
        );
        assert!(e.starts_with("s.toml:4:"), "{e}");
        assert!(e.contains("needs a QEMU target"), "{e}");
    }

    #[test]
    fn line_col_counts_from_one() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
    }
}
