//! The mission part of a scenario file: the task network, the mission span, the simulated
//! spacecraft, timed events (resets, power cycles, faults), link faults, and expectations.
//!
//! ```toml
//! seed = 7
//! [mission]
//! tasknet = "tasknets/flyby.toml"   # relative to the scenario file
//! start = "09:50"
//! end = "11:30"
//! max_frame = "5min"                # longest grant when nothing happens (default: no limit)
//!
//! [[events]]
//! at = "10:30"
//! warm_reset = { recovery = "3min" } # fault protection runs 3 min before the software restarts
//!
//! [link]
//! corrupt = 0.01                     # per byte, both directions
//!
//! [[expect]]
//! task = "Instrument Flyby"
//! instance = 1
//! outcome = "aborted"
//! ```
//!
//! Expectations that hold for a reset at any time (campaigns, `hil campaign`):
//!
//! ```toml
//! [[expect]]                         # exactly one of them at a time, except while the
//! covered_by = ["Instrument Flyby", "Instrument Degraded Flyby"]   # software is down
//! from = "10:15"
//! to = "11:05"
//! exclusive = true                   # never two of the listed tasks at once
//! allow_reset_gaps = true            # gaps from a reset to its restart are excused
//!
//! [[expect]]                         # every instance ran only while the state held
//! timeline = "GncAttitude"           # (downtimes excepted)
//! value = "NADIR"
//! during = "Instrument Flyby"
//!
//! [[expect]]                         # on time, or at the restart if the flight
//! task = "GncAttain EARTH"           # software was down at 11:05
//! started_at = "11:05"
//! or_at_restart = true
//! ```
use serde::Deserialize;

/// `[mission]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionSpec {
    /// Task network (TOML), relative to the scenario file.
    pub tasknet: String,
    pub start: String,
    pub end: String,
    /// Longest single grant; idle stretches longer than this are split (default: no limit).
    pub max_frame: Option<String>,
}

/// One `[[events]]` entry: a time and exactly one action.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventSpec {
    pub at: String,
    pub warm_reset: Option<ResetSpec>,
    pub power_cycle: Option<ResetSpec>,
    pub command_failure: Option<CommandFaultSpec>,
    pub command_timeout: Option<CommandFaultSpec>,
    pub state_override: Option<StateOverrideSpec>,
    pub state_change: Option<StateChangeSpec>,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetSpec {
    /// How long fault protection runs before the flight software restarts (default 0).
    pub recovery: Option<String>,
}

/// A command fault armed from the event's time on: the `occurrence`-th dispatch of `opcode`
/// after that time (default the first), or each dispatch with `probability` (seeded).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandFaultSpec {
    pub opcode: u16,
    pub occurrence: Option<u32>,
    pub probability: Option<f64>,
    /// For command_failure: "failed" (default) or "rejected".
    pub status: Option<String>,
    /// For command_failure with status "failed": the subsystem's failure code (default 1).
    pub code: Option<u16>,
}

/// Force a state to a value (an exogenous change, or a sensor that lies).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateOverrideSpec {
    pub timeline: String,
    /// A value name for state timelines, an integer for cumulative ones.
    pub value: toml::Value,
}

/// Change a simulated cumulative state by an amount (e.g. a sudden battery drop).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateChangeSpec {
    pub timeline: String,
    pub by: i64,
}

/// `[link]`: faults injected by the host on the serial link, seeded.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkFaultSpec {
    /// Probability that a byte is corrupted (one bit flipped), both directions.
    #[serde(default)]
    pub corrupt: f64,
    /// Probability that a whole frame is dropped, both directions.
    #[serde(default)]
    pub drop: f64,
    /// Probability that a host-to-target frame is held back to the next frame.
    #[serde(default)]
    pub delay: f64,
}

/// One `[[expect]]` entry: exactly one kind of check.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpectSpec {
    /// Task definition name (requested task or template): checks its `instance`-th instance.
    pub task: Option<String>,
    /// 1-based, in order of first appearance (default 1).
    pub instance: Option<u32>,
    /// completed | aborted | failed | skipped | deleted | not-run
    pub outcome: Option<String>,
    /// The instance started at this time (with `task`).
    pub started_at: Option<String>,
    /// The instance ended at this time (with `task`).
    pub ended_at: Option<String>,
    /// With `started_at`: if the flight software was down (between a reset and its restart)
    /// at `started_at`, the instance must start at that restart instead.
    pub or_at_restart: Option<bool>,
    /// Template name: the planner added it `count` times (default: at least once).
    pub added: Option<String>,
    pub count: Option<u32>,
    /// Timeline name: the spacecraft's state at `at` was `value`.
    pub timeline: Option<String>,
    pub at: Option<String>,
    pub value: Option<toml::Value>,
    /// With `timeline` instead of `at`: while any instance of this task ran (downtimes
    /// excepted), the spacecraft's state was `value`.
    pub during: Option<String>,
    /// Labels that must occur in this order, e.g. "Instrument Flyby aborted",
    /// "GncAttain NADIR added", "Instrument Flyby started".
    pub order: Option<Vec<String>>,
    /// Tasks whose running intervals together must cover `from`..`to`.
    pub covered_by: Option<Vec<String>>,
    pub from: Option<String>,
    pub to: Option<String>,
    /// With `covered_by`: the listed tasks never ran at the same time within `from`..`to`.
    pub exclusive: Option<bool>,
    /// With `covered_by`: gaps while the flight software is down (from a reset to its
    /// restart) are not gaps.
    pub allow_reset_gaps: Option<bool>,
    /// A metric of the run (see the report) must be at most `max` / at least `min`.
    pub metric: Option<String>,
    pub max: Option<u64>,
    pub min: Option<u64>,
}
