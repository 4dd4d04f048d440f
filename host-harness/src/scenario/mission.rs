//! The schema of a scenario's mission parts: the task network and mission span, the simulated
//! spacecraft, timed events (resets, power cycles, faults), link faults and expectations. Times
//! and durations follow [`crate::time`] (the same grammar as task networks). What the values
//! mean is checked when the mission is planned ([`crate::mission::plan`]).
//!
//! ```toml
//! seed = 7
//! [mission]
//! tasknet = "tasknets/flyby.toml"   # relative to the scenario file
//! start = "09:50"
//! end = "11:30"
//! max_frame = "5min"                # longest grant when nothing happens (default: no limit)
//! planner_checks_per_window = 64     # emulated target: the planner partition's budget per
//!                                   # window (default: the firmware's, 20,000); the native
//!                                   # target plans unthrottled whatever it says
//!
//! [[events]]
//! at = "10:30"
//! warm_reset = { recovery = "3min" } # fault protection runs 3 min before the software restarts
//!
//! [link]
//! corrupt = 0.01                     # per byte, both directions
//! key_file = "keys/mission.key"      # or key = "<64 hex digits>"; default: hil's test key
//!
//! [[events]]                         # authenticated traffic (signed with the mission's key)
//! at = "10:05"
//! ground_command = { command = "set-hold", hold = 2 }   # or "release-hold", "no-op"
//!
//! [[events]]                         # a deliberately bad one, which the target must refuse
//! at = "10:06"
//! attack = { kind = "forged", on = "uplink" }   # forged | replayed | wrong-key |
//!                                               # unknown-key | truncated; uplink | command
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

use crate::time::TimeText;

/// `[mission]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionSection {
    /// Task network (TOML), relative to the scenario file.
    pub tasknet: String,
    pub start: TimeText,
    pub end: TimeText,
    /// Longest single grant; idle stretches longer than this are split (default: no limit).
    pub max_frame: Option<TimeText>,
    /// The planner partition's budget in validity checks per window (emulated target; the
    /// native target is the unthrottled reference and ignores it).
    pub planner_checks_per_window: Option<u32>,
}

/// One `[[events]]` entry: a time and exactly one action.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventEntry {
    pub at: TimeText,
    pub warm_reset: Option<ResetSpec>,
    pub power_cycle: Option<ResetSpec>,
    pub command_failure: Option<CommandFaultSpec>,
    pub command_timeout: Option<CommandFaultSpec>,
    /// Commands accepted and answered Ok, but carried out with no effect at all.
    pub command_no_effect: Option<CommandFaultSpec>,
    /// Commands carried out and answered Ok, but the state they set ends at another value.
    pub command_wrong_state: Option<WrongStateSpec>,
    pub state_override: Option<StateOverrideSpec>,
    pub state_change: Option<StateChangeSpec>,
    /// An authenticated ground command from the ground, signed with the mission's key.
    pub ground_command: Option<GroundCommandSpec>,
    /// A deliberately bad authenticated uplink or ground command the target must refuse.
    pub attack: Option<AttackSpec>,
}

/// `ground_command = { command = "set-hold", hold = 2 }`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundCommandSpec {
    /// "no-op", "set-hold" or "release-hold".
    pub command: String,
    /// The hold number (set-hold, release-hold).
    pub hold: Option<u8>,
}

/// `attack = { kind = "forged", on = "uplink" }`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttackSpec {
    /// forged | replayed | wrong-key | unknown-key | truncated.
    pub kind: String,
    /// "uplink" (the mission's task network) or "command" (a set-hold).
    pub on: String,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetSpec {
    /// How long fault protection runs before the flight software restarts (default 0).
    pub recovery: Option<TimeText>,
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

/// A command that completes with the wrong result: the `occurrence`-th dispatch of `opcode`
/// (or each with `probability`) sets `timeline` to `value` instead of what it commanded.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WrongStateSpec {
    pub opcode: u16,
    pub timeline: String,
    pub value: toml::Value,
    pub occurrence: Option<u32>,
    pub probability: Option<f64>,
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

/// `[link]`: faults injected by the host on the link, seeded.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSection {
    /// Probability that a byte is corrupted (one bit flipped), both directions.
    #[serde(default)]
    pub corrupt: f64,
    /// Probability that a whole frame is dropped, both directions.
    #[serde(default)]
    pub drop: f64,
    /// Probability that a host-to-target frame is held back to the next frame.
    #[serde(default)]
    pub delay: f64,
    /// The key uplinks and ground commands are signed with (and provisioned into the target's
    /// non-volatile memory before boot): 64 hexadecimal digits. Default: `hil`'s built-in test
    /// key (`mission::auth::TEST_KEY`).
    pub key: Option<String>,
    /// A file holding the key instead (32 raw bytes or 64 hexadecimal digits), relative to the
    /// scenario file.
    pub key_file: Option<String>,
    /// The key's security parameter index (default 1).
    pub spi: Option<u16>,
}

/// One `[[expect]]` entry as written: exactly one kind of check (see
/// [`crate::mission::plan::Expect`] for what each means once checked).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpectEntry {
    /// Task definition name (requested task or template): checks its `instance`-th instance.
    pub task: Option<String>,
    /// 1-based, in order of first appearance (default 1).
    pub instance: Option<u32>,
    /// completed | aborted | failed | interrupted | skipped | deleted | not-run | not-finished
    pub outcome: Option<String>,
    /// The instance started at this time (with `task`).
    pub started_at: Option<TimeText>,
    /// The instance ended at this time (with `task`).
    pub ended_at: Option<TimeText>,
    /// With `started_at`: if the flight software was down (between a reset and its restart)
    /// at `started_at`, the instance must start at that restart instead.
    pub or_at_restart: Option<bool>,
    /// Template name: the planner added it `count` times (default: at least once).
    pub added: Option<String>,
    pub count: Option<u32>,
    /// Timeline name: the spacecraft's state at `at` was `value`.
    pub timeline: Option<String>,
    pub at: Option<TimeText>,
    pub value: Option<toml::Value>,
    /// With `timeline` instead of `at`: while any instance of this task ran (downtimes
    /// excepted), the spacecraft's state was `value`.
    pub during: Option<String>,
    /// Labels that must occur in this order, e.g. "Instrument Flyby aborted",
    /// "GncAttain NADIR added", "Instrument Flyby started".
    pub order: Option<Vec<String>>,
    /// Tasks whose running intervals together must cover `from`..`to`.
    pub covered_by: Option<Vec<String>>,
    pub from: Option<TimeText>,
    pub to: Option<TimeText>,
    /// With `covered_by`: the listed tasks never ran at the same time within `from`..`to`.
    pub exclusive: Option<bool>,
    /// With `covered_by`: gaps while the flight software is down (from a reset to its
    /// restart) are not gaps.
    pub allow_reset_gaps: Option<bool>,
    /// Opcode: a command with it was dispatched at `at` carrying exactly `args` (the
    /// arguments the target took from the instance included).
    pub command: Option<u16>,
    pub args: Option<Vec<i32>>,
    /// A metric of the run (see the report) must be at most `max` / at least `min`.
    pub metric: Option<String>,
    pub max: Option<u64>,
    pub min: Option<u64>,
}

/// `[spacecraft]`: the simulated subsystems (see [`crate::mission::sim`]).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpacecraftConfig {
    pub gnc: Option<GncConfig>,
    pub power: Option<PowerConfig>,
    #[serde(default)]
    pub instruments: Vec<InstrumentConfig>,
    pub thermal: Option<ThermalConfig>,
    /// How long commands without a model take to answer (default: at once).
    pub response_delay: Option<TimeText>,
    /// Publish the whole state buffer again this often (as well as after every reset), so
    /// that a value the target missed or let go stale heals (default: only after resets).
    pub republish_every: Option<TimeText>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GncConfig {
    /// State timeline that holds the attitude.
    pub attitude: String,
    /// Opcode of the attain command; its first argument is the target attitude's value code.
    pub attain_opcode: u16,
    /// Slew duration.
    pub slew: TimeText,
    /// Attitude at the start of the scenario.
    pub initial: String,
    /// Value reported while slewing.
    pub turning: String,
    /// Value reported after a reset until the next slew completes.
    pub after_reset: String,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowerConfig {
    /// Cumulative timeline of battery energy (in its own unit, e.g. Wh).
    pub battery: String,
    pub initial: i64,
    /// Energy drawn per hour by the hotel load.
    pub hotel_per_hour: i64,
    /// Per-command activity loads.
    #[serde(default)]
    pub loads: Vec<ActivityLoad>,
    /// Standard deviation of activity loads, in percent (seeded).
    #[serde(default)]
    pub noise_percent: u32,
    /// Systematic bias of activity loads, in percent (+10: everything draws 10 % more).
    #[serde(default)]
    pub bias_percent: i32,
    /// How often the battery value is published (default 1 min).
    pub publish_every: Option<TimeText>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActivityLoad {
    pub opcode: u16,
    pub per_hour: i64,
    pub duration: TimeText,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentConfig {
    pub opcode: u16,
    /// Cumulative timeline of stored data volume.
    pub data_volume: String,
    pub per_hour: i64,
    pub duration: TimeText,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalConfig {
    pub temperature: String,
    pub heater_opcode: u16,
    pub warmup: TimeText,
    /// Temperature before the heater runs (published at the start).
    pub cold: i64,
    pub warm: i64,
}
