//! The second stage of `hil`'s pipeline: a scenario's mission resolved once against its task
//! network into a [`MissionPlan`]: typed mission times, the resolved events, validated link
//! faults, the simulated spacecraft checked against the network, and each `[[expect]]` entry
//! as one [`Expect`] variant. Everything a run could trip over later is refused here, before
//! anything boots, with a [`Diagnostic`] at the file, line, column and field concerned.
//!
//! The next stages take the plan as it is: [`super::driver`] flies it, [`super::expect`]
//! judges the record against its expectations, [`super::report`] reports.
use fsw_bridge::{CommandStatus, GroundCommand, MissionTimeUs, Opcode, StateKey, StateValue};

use super::auth::Attack;

use super::metrics;
use super::sim::{CommandFate, Spacecraft};
use crate::diag::{Diagnostic, SourceFile};
use crate::scenario::mission::{CommandFaultSpec, EventEntry, ExpectEntry, LinkSection};
use crate::scenario::Scenario;
use crate::tasknet::{CompiledNetwork, TimelineKindName};
use crate::time::{self, fmt_duration_us, fmt_time, TimeText};

/// Most frames a mission may need at its shortest `max_frame` (a sanity bound: each frame is a
/// round trip to the target and a line of the transcript).
pub const MAX_MISSION_FRAMES: u64 = 1_000_000;
/// Link fault probabilities accepted per byte or frame (above this, nothing gets through in a
/// bounded number of retransmissions).
pub const MAX_LINK_FAULT_PROBABILITY: f64 = 0.5;

/// A mission ready to fly.
pub struct MissionPlan {
    /// The scenario file it came from (name, description, target, spacecraft configuration).
    pub scenario: Scenario,
    /// The task network, compiled once, with its symbol table.
    pub network: CompiledNetwork,
    pub start: MissionTimeUs,
    pub end: MissionTimeUs,
    /// Longest single grant (None: as long as nothing happens).
    pub max_frame_us: Option<u64>,
    /// How often the whole state buffer is published again (None: only after resets).
    pub republish_us: Option<u64>,
    /// The planner partition's budget per window, sent after every boot (None: the
    /// firmware's default).
    pub planner_checks_per_window: Option<u32>,
    /// Scenario events in time order (ties in file order).
    pub events: Vec<Event>,
    pub link: LinkFaults,
    /// The key uplinks and ground commands are signed with, provisioned into the target's
    /// non-volatile memory before boot.
    pub key: sdls::Key,
    pub expectations: Vec<Expect>,
    /// Seed of everything random in the run.
    pub seed: u64,
    /// Pace grants by the wall clock (one mission second per second), for a real peer on the
    /// link; off: lockstep, as fast as the target runs.
    pub realtime: bool,
}

/// One scenario event with its time resolved.
#[derive(Clone, Debug)]
pub struct Event {
    pub at: MissionTimeUs,
    /// Position in the file (campaign variants come after).
    pub index: usize,
    pub action: Action,
}

#[derive(Clone, Debug)]
pub enum Action {
    WarmReset {
        recovery_us: u64,
    },
    PowerCycle {
        recovery_us: u64,
    },
    CommandFault(CommandFault),
    Override {
        key: StateKey,
        value: StateValue,
        name: String,
    },
    Change {
        key: StateKey,
        by: i64,
        name: String,
    },
    /// An authenticated ground command, signed with the mission's key and the next sequence
    /// number.
    GroundCommand(GroundCommand),
    /// A deliberately bad authenticated message the target must refuse with
    /// `attack.expected()`.
    Attack {
        attack: Attack,
        on: AttackOn,
    },
}

/// What an attack is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttackOn {
    /// The mission's task-network uplink.
    Uplink,
    /// A ground command (SetHold(0); a replay resends the last accepted command).
    Command,
}

impl AttackOn {
    pub fn name(self) -> &'static str {
        match self {
            AttackOn::Uplink => "uplink",
            AttackOn::Command => "ground command",
        }
    }
}

/// A command fault armed from its event on.
#[derive(Clone, Debug)]
pub struct CommandFault {
    pub opcode: Opcode,
    /// Remaining dispatches to let through before the one that fails (None: probabilistic).
    pub skip: Option<u32>,
    pub probability: f64,
    pub fate: CommandFate,
    pub spent: bool,
}

/// Link faults the host injects, seeded (validated probabilities).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinkFaults {
    /// Probability that a byte is corrupted (one bit flipped), both directions.
    pub corrupt: f64,
    /// Probability that a whole frame is dropped, both directions.
    pub drop: f64,
    /// Probability that a frame is held back to the next round.
    pub delay: f64,
}

impl LinkFaults {
    pub fn active(&self) -> bool {
        self.corrupt > 0.0 || self.drop > 0.0 || self.delay > 0.0
    }
}

/// How a task instance ended, as expectations name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Completed,
    /// Failed because a maintain constraint stopped holding.
    Aborted,
    Failed,
    /// Cut short by a reset of the flight software.
    Interrupted,
    Skipped,
    Deleted,
    /// The instance never started.
    NotRun,
    /// Started, and still running at the end of the mission.
    NotFinished,
}

impl Outcome {
    pub const ALL: [Outcome; 8] = [
        Outcome::Completed,
        Outcome::Aborted,
        Outcome::Failed,
        Outcome::Interrupted,
        Outcome::Skipped,
        Outcome::Deleted,
        Outcome::NotRun,
        Outcome::NotFinished,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Outcome::Completed => "completed",
            Outcome::Aborted => "aborted",
            Outcome::Failed => "failed",
            Outcome::Interrupted => "interrupted",
            Outcome::Skipped => "skipped",
            Outcome::Deleted => "deleted",
            Outcome::NotRun => "not-run",
            Outcome::NotFinished => "not-finished",
        }
    }

    pub fn parse(text: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.name() == text)
    }
}

/// One checked `[[expect]]` entry.
#[derive(Clone, Debug, PartialEq)]
pub enum Expect {
    /// The `instance`-th instance of a task definition (1-based, in order of appearance).
    Task {
        task: String,
        instance: u32,
        outcome: Option<Outcome>,
        started_at: Option<MissionTimeUs>,
        /// With `started_at`: if the flight software was down then, it starts at the restart.
        or_at_restart: bool,
        ended_at: Option<MissionTimeUs>,
    },
    /// The planner added this template `count` times (None: at least once).
    Added {
        template: String,
        count: Option<u32>,
    },
    /// The spacecraft's state at a time.
    StateAt {
        timeline: String,
        key: StateKey,
        value: StateValue,
        at: MissionTimeUs,
    },
    /// The spacecraft's state while every instance of a task ran (downtime excepted).
    StateDuring {
        timeline: String,
        key: StateKey,
        value: StateValue,
        task: String,
    },
    /// These labels happened in this order.
    Order(Vec<String>),
    /// The listed tasks together ran throughout `from..to`.
    Coverage {
        tasks: Vec<String>,
        from: MissionTimeUs,
        to: MissionTimeUs,
        /// Never two of them at once.
        exclusive: bool,
        /// The flight software's downtime (reset to restart) is excused instead of a gap.
        allow_downtime: bool,
    },
    /// A command with `opcode` dispatched at `at` carried `args`.
    Command {
        opcode: u16,
        at: MissionTimeUs,
        args: Vec<i32>,
    },
    /// A metric of the run within bounds.
    Metric {
        name: String,
        min: Option<u64>,
        max: Option<u64>,
    },
}

impl MissionPlan {
    /// Resolve `scenario` (a mission scenario) against its task network.
    pub fn build(scenario: Scenario) -> Result<Self, Diagnostic> {
        let src = scenario.source.clone();
        let Some(section) = scenario.mission.as_ref() else {
            return Err(src.error(0..0, "mission", "not a mission scenario (no [mission])"));
        };
        let net_path = scenario
            .path
            .parent()
            .unwrap_or(std::path::Path::new("."))
            .join(&section.tasknet);
        let network = match crate::tasknet::compile_file(&net_path) {
            Ok(n) => n,
            // The network file's own diagnostic, pointing into that file.
            Err(e) if e.line_col().is_some() => return Err(e),
            Err(e) => {
                return Err(src.error_at(
                    "mission.tasknet",
                    format!("{} ({})", e.message, net_path.display()),
                ))
            }
        };
        let epoch = network.symbols.epoch;
        let time_at = |field: &str, v: &TimeText| {
            time::parse_time(v, epoch).map_err(|m| src.error_at(field, m))
        };
        let duration_at =
            |field: &str, v: &TimeText| time::parse_duration(v).map_err(|m| src.error_at(field, m));
        let start = time_at("mission.start", &section.start)?;
        let end = time_at("mission.end", &section.end)?;
        if end <= start {
            return Err(src.error_at(
                "mission.end",
                format!(
                    "{} is not after mission.start ({})",
                    fmt_time(end),
                    fmt_time(start)
                ),
            ));
        }
        let max_frame_us = section
            .max_frame
            .as_ref()
            .map(|d| duration_at("mission.max_frame", d))
            .transpose()?;
        if let Some(max) = max_frame_us {
            let frames = (end.0 - start.0).div_ceil(max.max(1));
            if max == 0 || frames > MAX_MISSION_FRAMES {
                return Err(src.error_at(
                    "mission.max_frame",
                    format!(
                        "{} would split the {} mission into {} frames (at most {MAX_MISSION_FRAMES}): use a longer max_frame",
                        fmt_duration_us(max),
                        fmt_duration_us(end.0 - start.0),
                        if max == 0 { "endless".to_string() } else { frames.to_string() },
                    ),
                ));
            }
        }
        let planner_checks_per_window = section.planner_checks_per_window;
        if planner_checks_per_window == Some(0) {
            return Err(src.error_at(
                "mission.planner_checks_per_window",
                "0 validity checks per window: the planner would never plan (at least 1)",
            ));
        }
        let republish_us = scenario
            .spacecraft
            .republish_every
            .as_ref()
            .map(|d| duration_at("spacecraft.republish_every", d))
            .transpose()?;
        if let Some(every) = republish_us {
            let times = (end.0 - start.0) / every.max(1);
            if every == 0 || times > MAX_MISSION_FRAMES {
                return Err(src.error_at(
                    "spacecraft.republish_every",
                    format!(
                        "{} would publish the state buffer {} times in the {} mission (at most {MAX_MISSION_FRAMES})",
                        fmt_duration_us(every),
                        if every == 0 { "endless".to_string() } else { times.to_string() },
                        fmt_duration_us(end.0 - start.0),
                    ),
                ));
            }
        }
        let mut events = Vec::new();
        for (index, ev) in scenario.events.iter().enumerate() {
            let field = format!("events[{index}]");
            let at = time_at(&format!("{field}.at"), &ev.at)?;
            if at < start || at > end {
                return Err(src.error_at(
                    &format!("{field}.at"),
                    format!(
                        "{} is outside the mission ({} to {})",
                        fmt_time(at),
                        fmt_time(start),
                        fmt_time(end)
                    ),
                ));
            }
            let action = resolve_action(&src, ev, &field, &network)?;
            events.push(Event { at, index, action });
        }
        events.sort_by_key(|e| (e.at, e.index));
        let link = link_faults(&src, &scenario.link)?;
        let key = mission_key(&src, &scenario.link, &scenario.path)?;
        // The spacecraft's names and value types are checked now, not halfway into a run.
        Spacecraft::new(&scenario.spacecraft, &network, start, 0)
            .map_err(|e| src.error_at(&e.field, e.message))?;
        let expectations = scenario
            .expect
            .iter()
            .enumerate()
            .map(|(i, e)| expectation(&src, &format!("expect[{i}]"), e, &network, start, end))
            .collect::<Result<Vec<_>, _>>()?;
        let seed = scenario.seed;
        Ok(Self {
            scenario,
            network,
            start,
            end,
            max_frame_us,
            republish_us,
            planner_checks_per_window,
            events,
            link,
            key,
            expectations,
            seed,
            realtime: false,
        })
    }

    /// The scenario's name.
    pub fn name(&self) -> &str {
        &self.scenario.name
    }

    /// Times of the resets this mission injects (for campaigns and reports).
    pub fn reset_times(&self) -> Vec<MissionTimeUs> {
        self.events
            .iter()
            .filter(|e| {
                matches!(
                    e.action,
                    Action::WarmReset { .. } | Action::PowerCycle { .. }
                )
            })
            .map(|e| e.at)
            .collect()
    }

    /// Add a warm reset at `at` (campaign variants), after the file's events at that time.
    pub fn add_warm_reset(&mut self, at: MissionTimeUs, recovery_us: u64) {
        let index = self.scenario.events.len() + self.events.len();
        self.events.push(Event {
            at,
            index,
            action: Action::WarmReset { recovery_us },
        });
        self.events.sort_by_key(|e| (e.at, e.index));
    }

    /// Arm a command fault at `at` (campaign variants), after the file's events at that time.
    pub fn add_command_fault(&mut self, at: MissionTimeUs, fault: CommandFault) {
        let index = self.scenario.events.len() + self.events.len();
        self.events.push(Event {
            at,
            index,
            action: Action::CommandFault(fault),
        });
        self.events.sort_by_key(|e| (e.at, e.index));
    }

    /// The same mission with another seed (campaign variants).
    pub fn set_seed(&mut self, seed: u64) {
        self.seed = seed;
        self.scenario.file.seed = seed;
    }
}

fn link_faults(src: &SourceFile, link: &LinkSection) -> Result<LinkFaults, Diagnostic> {
    for (field, p) in [
        ("link.corrupt", link.corrupt),
        ("link.drop", link.drop),
        ("link.delay", link.delay),
    ] {
        if !(0.0..=MAX_LINK_FAULT_PROBABILITY).contains(&p) {
            return Err(src.error_at(
                field,
                format!("{p} is not a probability in 0..={MAX_LINK_FAULT_PROBABILITY}"),
            ));
        }
    }
    Ok(LinkFaults {
        corrupt: link.corrupt,
        drop: link.drop,
        delay: link.delay,
    })
}

/// The mission's key: `link.key`, `link.key_file` (relative to the scenario), or the test key.
fn mission_key(
    src: &SourceFile,
    link: &LinkSection,
    scenario_path: &std::path::Path,
) -> Result<sdls::Key, Diagnostic> {
    let bytes = match (&link.key, &link.key_file) {
        (Some(_), Some(_)) => {
            return Err(src.error_at("link.key_file", "give link.key or link.key_file, not both"))
        }
        (Some(hex), None) => {
            super::auth::parse_key_hex(hex).map_err(|m| src.error_at("link.key", m))?
        }
        (None, Some(file)) => {
            let path = scenario_path
                .parent()
                .unwrap_or(std::path::Path::new("."))
                .join(file);
            super::auth::read_key_file(&path).map_err(|m| src.error_at("link.key_file", m))?
        }
        (None, None) => super::auth::TEST_KEY.bytes,
    };
    Ok(sdls::Key {
        spi: link.spi.unwrap_or(super::auth::TEST_KEY.spi),
        bytes,
    })
}

fn resolve_action(
    src: &SourceFile,
    ev: &EventEntry,
    field: &str,
    net: &CompiledNetwork,
) -> Result<Action, Diagnostic> {
    let given: Vec<&str> = [
        ("warm_reset", ev.warm_reset.is_some()),
        ("power_cycle", ev.power_cycle.is_some()),
        ("command_failure", ev.command_failure.is_some()),
        ("command_timeout", ev.command_timeout.is_some()),
        ("command_no_effect", ev.command_no_effect.is_some()),
        ("command_wrong_state", ev.command_wrong_state.is_some()),
        ("state_override", ev.state_override.is_some()),
        ("state_change", ev.state_change.is_some()),
        ("ground_command", ev.ground_command.is_some()),
        ("attack", ev.attack.is_some()),
    ]
    .into_iter()
    .filter_map(|(name, present)| present.then_some(name))
    .collect();
    match given.as_slice() {
        [_] => {}
        [] => return Err(src.error_at(field, "an event needs one action (warm_reset, power_cycle, command_failure, command_timeout, command_no_effect, command_wrong_state, state_override, state_change, ground_command, attack)")),
        [_, second, ..] => {
            return Err(src.error_at(
                &format!("{field}.{second}"),
                format!("an event has exactly one action, this one has {}: split it into several events", given.join(" and ")),
            ))
        }
    }
    let recovery = |r: &crate::scenario::mission::ResetSpec, what: &str| {
        r.recovery
            .as_ref()
            .map(|d| {
                time::parse_duration(d)
                    .map_err(|m| src.error_at(&format!("{field}.{what}.recovery"), m))
            })
            .transpose()
            .map(|v| v.unwrap_or(0))
    };
    if let Some(r) = &ev.warm_reset {
        return Ok(Action::WarmReset {
            recovery_us: recovery(r, "warm_reset")?,
        });
    }
    if let Some(r) = &ev.power_cycle {
        return Ok(Action::PowerCycle {
            recovery_us: recovery(r, "power_cycle")?,
        });
    }
    if let Some(f) = &ev.command_failure {
        let f_path = format!("{field}.command_failure");
        let status = match f.status.as_deref().unwrap_or("failed") {
            "failed" => CommandStatus::Failed(f.code.unwrap_or(1)),
            "rejected" => {
                if f.code.is_some() {
                    return Err(src.error_at(
                        &format!("{f_path}.code"),
                        "a rejected command carries no failure code (give status = \"failed\")",
                    ));
                }
                CommandStatus::Rejected
            }
            other => {
                return Err(src.error_at(
                    &format!("{f_path}.status"),
                    format!("{other:?} is not one of \"failed\", \"rejected\""),
                ))
            }
        };
        return Ok(Action::CommandFault(command_fault(
            src,
            f,
            CommandFate::Answer(status),
            &f_path,
        )?));
    }
    if let Some(f) = &ev.command_timeout {
        let f_path = format!("{field}.command_timeout");
        for (name, present) in [("status", f.status.is_some()), ("code", f.code.is_some())] {
            if present {
                return Err(src.error_at(
                    &format!("{f_path}.{name}"),
                    "a command that times out is never answered: it has no status or code",
                ));
            }
        }
        return Ok(Action::CommandFault(command_fault(
            src,
            f,
            CommandFate::Silent,
            &f_path,
        )?));
    }
    if let Some(f) = &ev.command_no_effect {
        let f_path = format!("{field}.command_no_effect");
        for (name, present) in [("status", f.status.is_some()), ("code", f.code.is_some())] {
            if present {
                return Err(src.error_at(
                    &format!("{f_path}.{name}"),
                    "a command with no effect is answered Ok: it has no status or code",
                ));
            }
        }
        return Ok(Action::CommandFault(command_fault(
            src,
            f,
            CommandFate::NoEffect,
            &f_path,
        )?));
    }
    if let Some(w) = &ev.command_wrong_state {
        let f_path = format!("{field}.command_wrong_state");
        let (_, tl) = measured_timeline(src, net, &w.timeline, &format!("{f_path}.timeline"))?;
        let value =
            value_of(&w.value, tl).map_err(|m| src.error_at(&format!("{f_path}.value"), m))?;
        let as_fault = CommandFaultSpec {
            opcode: w.opcode,
            occurrence: w.occurrence,
            probability: w.probability,
            status: None,
            code: None,
        };
        return Ok(Action::CommandFault(command_fault(
            src,
            &as_fault,
            CommandFate::WrongState(value),
            &f_path,
        )?));
    }
    if let Some(o) = &ev.state_override {
        let f = format!("{field}.state_override");
        let (key, tl) = measured_timeline(src, net, &o.timeline, &format!("{f}.timeline"))?;
        let value = value_of(&o.value, tl).map_err(|m| src.error_at(&format!("{f}.value"), m))?;
        return Ok(Action::Override {
            key,
            value,
            name: o.timeline.clone(),
        });
    }
    if let Some(g) = &ev.ground_command {
        let f = format!("{field}.ground_command");
        let hold = |present: bool| match (present, g.hold) {
            (true, Some(h)) => Ok(h),
            (true, None) => Err(src.error_at(
                &f,
                format!("{:?} needs a hold number (hold = N)", g.command),
            )),
            (false, Some(_)) => {
                Err(src.error_at(&format!("{f}.hold"), "no-op takes no hold number"))
            }
            (false, None) => Ok(0),
        };
        let command = match g.command.as_str() {
            "no-op" => hold(false).map(|_| GroundCommand::NoOp)?,
            "set-hold" => GroundCommand::SetHold(hold(true)?),
            "release-hold" => GroundCommand::ReleaseHold(hold(true)?),
            other => {
                return Err(src.error_at(
                    &format!("{f}.command"),
                    format!("{other:?} is not one of \"no-op\", \"set-hold\", \"release-hold\""),
                ))
            }
        };
        return Ok(Action::GroundCommand(command));
    }
    if let Some(a) = &ev.attack {
        let f = format!("{field}.attack");
        let attack = Attack::from_name(&a.kind).ok_or_else(|| {
            src.error_at(
                &format!("{f}.kind"),
                format!(
                    "{:?} is not one of {}",
                    a.kind,
                    Attack::ALL.map(|a| format!("{:?}", a.name())).join(", ")
                ),
            )
        })?;
        let on = match a.on.as_str() {
            "uplink" => AttackOn::Uplink,
            "command" => AttackOn::Command,
            other => {
                return Err(src.error_at(
                    &format!("{f}.on"),
                    format!("{other:?} is not one of \"uplink\", \"command\""),
                ))
            }
        };
        return Ok(Action::Attack { attack, on });
    }
    let c = ev.state_change.as_ref().expect("one action is given");
    let f = format!("{field}.state_change");
    let (key, tl) = measured_timeline(src, net, &c.timeline, &format!("{f}.timeline"))?;
    if tl.kind != TimelineKindName::Cumulative {
        return Err(src.error_at(
            &format!("{f}.timeline"),
            format!(
                "{:?} is a {} timeline: only a cumulative quantity changes by an amount (use state_override)",
                c.timeline,
                tl.kind.name()
            ),
        ));
    }
    Ok(Action::Change {
        key,
        by: c.by,
        name: c.timeline.clone(),
    })
}

/// A timeline the spacecraft publishes (it has a state key).
fn measured_timeline<'n>(
    src: &SourceFile,
    net: &'n CompiledNetwork,
    name: &str,
    field: &str,
) -> Result<(StateKey, &'n crate::tasknet::TimelineSymbol), Diagnostic> {
    let tl = net.timeline(name).ok_or_else(|| {
        src.error_at(
            field,
            format!(
                "no timeline named {name:?} in the task network (timelines: {})",
                net.symbols
                    .timelines
                    .iter()
                    .map(|t| t.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
    })?;
    let key = tl.state_key.ok_or_else(|| {
        src.error_at(
            field,
            format!("{name:?} has no state key: the spacecraft does not publish it"),
        )
    })?;
    Ok((key, tl))
}

fn command_fault(
    src: &SourceFile,
    f: &CommandFaultSpec,
    fate: CommandFate,
    field: &str,
) -> Result<CommandFault, Diagnostic> {
    if let Some(p) = f.probability {
        if !(0.0..=1.0).contains(&p) {
            return Err(src.error_at(
                &format!("{field}.probability"),
                format!("{p} is not a probability in 0..=1"),
            ));
        }
        if f.occurrence.is_some() {
            return Err(src.error_at(
                &format!("{field}.occurrence"),
                "give either occurrence or probability, not both",
            ));
        }
    }
    let occurrence = f.occurrence.unwrap_or(1);
    if occurrence == 0 {
        return Err(src.error_at(
            &format!("{field}.occurrence"),
            "occurrences count from 1 (the first dispatch after the event)",
        ));
    }
    Ok(CommandFault {
        opcode: Opcode(f.opcode),
        skip: if f.probability.is_some() {
            None
        } else {
            Some(occurrence - 1)
        },
        probability: f.probability.unwrap_or(0.0),
        fate,
        spent: false,
    })
}

/// A value as a scenario writes it for `timeline`: a value name of a state timeline, or an
/// integer for a cumulative one.
pub fn value_of(
    v: &toml::Value,
    timeline: &crate::tasknet::TimelineSymbol,
) -> Result<StateValue, String> {
    let values = &timeline.values;
    match (v, timeline.kind) {
        (toml::Value::String(name), _) if name == "UNKNOWN" && !values.contains(name) => {
            Ok(StateValue::Unknown)
        }
        (toml::Value::String(name), TimelineKindName::State) => values
            .iter()
            .position(|x| x == name)
            .map(|i| StateValue::Enum(i as u16))
            .ok_or_else(|| {
                format!(
                    "{name:?} is not a value of {} (values: {})",
                    timeline.name,
                    values.join(", ")
                )
            }),
        (toml::Value::Integer(i), TimelineKindName::Cumulative) => Ok(StateValue::Int(*i)),
        (toml::Value::Integer(_), kind) => Err(format!(
            "{} is a {} timeline: give a value name, not an integer",
            timeline.name,
            kind.name()
        )),
        (toml::Value::String(_), kind) => Err(format!(
            "{} is a {} timeline: give an integer",
            timeline.name,
            kind.name()
        )),
        (toml::Value::Boolean(b), _) => Ok(StateValue::Bool(*b)),
        (other, _) => Err(format!("{other} is not a value name or an integer")),
    }
}

/// Check one `[[expect]]` entry into an [`Expect`].
fn expectation(
    src: &SourceFile,
    field: &str,
    e: &ExpectEntry,
    net: &CompiledNetwork,
    start: MissionTimeUs,
    end: MissionTimeUs,
) -> Result<Expect, Diagnostic> {
    let at = |name: &str| format!("{field}.{name}");
    let err = |name: &str, message: String| src.error_at(&at(name), message);
    let kinds: Vec<&str> = [
        ("task", e.task.is_some()),
        ("added", e.added.is_some()),
        ("timeline", e.timeline.is_some()),
        ("order", e.order.is_some()),
        ("covered_by", e.covered_by.is_some()),
        ("metric", e.metric.is_some()),
        ("command", e.command.is_some()),
    ]
    .into_iter()
    .filter_map(|(k, present)| present.then_some(k))
    .collect();
    let kind = match kinds.as_slice() {
        [k] => *k,
        [] => return Err(src.error_at(field, "an expectation checks exactly one of: task, added, timeline, order, covered_by, metric, command")),
        [_, second, ..] => {
            return Err(err(
                second,
                format!(
                    "an expectation checks exactly one thing, this one names {}: split it",
                    kinds.join(" and ")
                ),
            ))
        }
    };
    // Fields that belong to another kind are refused rather than silently ignored.
    let allowed: &[&str] = match kind {
        "task" => &[
            "instance",
            "outcome",
            "started_at",
            "ended_at",
            "or_at_restart",
        ],
        "added" => &["count"],
        "timeline" => &["at", "value", "during"],
        "order" => &[],
        "covered_by" => &["from", "to", "exclusive", "allow_reset_gaps"],
        "command" => &["at", "args"],
        _ => &["min", "max"],
    };
    for (name, present) in [
        ("instance", e.instance.is_some()),
        ("outcome", e.outcome.is_some()),
        ("started_at", e.started_at.is_some()),
        ("ended_at", e.ended_at.is_some()),
        ("or_at_restart", e.or_at_restart.is_some()),
        ("count", e.count.is_some()),
        ("at", e.at.is_some()),
        ("value", e.value.is_some()),
        ("during", e.during.is_some()),
        ("from", e.from.is_some()),
        ("to", e.to.is_some()),
        ("exclusive", e.exclusive.is_some()),
        ("allow_reset_gaps", e.allow_reset_gaps.is_some()),
        ("min", e.min.is_some()),
        ("max", e.max.is_some()),
        ("args", e.args.is_some()),
    ] {
        if present && !allowed.contains(&name) {
            return Err(err(
                name,
                format!(
                    "`{name}` does not apply to a `{kind}` expectation (it takes: {})",
                    if allowed.is_empty() {
                        "nothing else".to_string()
                    } else {
                        allowed.join(", ")
                    }
                ),
            ));
        }
    }
    let known_task = |name: &str, f: &str| -> Result<String, Diagnostic> {
        if net.task_id(name).is_some() {
            Ok(name.to_string())
        } else {
            Err(err(
                f,
                format!(
                    "no task named {name:?} in the task network (tasks: {})",
                    net.network
                        .tasks()
                        .iter()
                        .map(|t| t.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ))
        }
    };
    let mission_time =
        |name: &str, v: &Option<TimeText>| -> Result<Option<MissionTimeUs>, Diagnostic> {
            let Some(v) = v else { return Ok(None) };
            let t = time::parse_time(v, net.symbols.epoch).map_err(|m| err(name, m))?;
            if t < start || t > end {
                return Err(err(
                    name,
                    format!(
                    "{} is outside the mission ({} to {}): the expectation could never be checked",
                    fmt_time(t),
                    fmt_time(start),
                    fmt_time(end)
                ),
                ));
            }
            Ok(Some(t))
        };
    Ok(match kind {
        "task" => {
            let task = known_task(e.task.as_deref().unwrap_or_default(), "task")?;
            let instance = e.instance.unwrap_or(1);
            if instance == 0 {
                return Err(err(
                    "instance",
                    "instances count from 1 (the first instance of the task)".into(),
                ));
            }
            let outcome = e
                .outcome
                .as_deref()
                .map(|o| {
                    Outcome::parse(o).ok_or_else(|| {
                        err(
                            "outcome",
                            format!(
                                "{o:?} is not one of {}",
                                Outcome::ALL.map(Outcome::name).join(", ")
                            ),
                        )
                    })
                })
                .transpose()?;
            let started_at = mission_time("started_at", &e.started_at)?;
            let ended_at = mission_time("ended_at", &e.ended_at)?;
            if outcome.is_none() && started_at.is_none() && ended_at.is_none() {
                return Err(err("task", "give outcome, started_at or ended_at".into()));
            }
            if e.or_at_restart.is_some() && started_at.is_none() {
                return Err(err(
                    "or_at_restart",
                    "applies to started_at, which is not given".into(),
                ));
            }
            if let (Some(s), Some(en)) = (started_at, ended_at) {
                if en < s {
                    return Err(err(
                        "ended_at",
                        format!("{} is before started_at ({})", fmt_time(en), fmt_time(s)),
                    ));
                }
            }
            Expect::Task {
                task,
                instance,
                outcome,
                started_at,
                or_at_restart: e.or_at_restart == Some(true),
                ended_at,
            }
        }
        "added" => Expect::Added {
            template: known_task(e.added.as_deref().unwrap_or_default(), "added")?,
            count: e.count,
        },
        "timeline" => {
            let name = e.timeline.as_deref().unwrap_or_default();
            let (key, tl) = measured_timeline(src, net, name, &at("timeline"))?;
            let v = e
                .value
                .as_ref()
                .ok_or_else(|| err("timeline", "give value".into()))?;
            let value = value_of(v, tl).map_err(|m| err("value", m))?;
            match (mission_time("at", &e.at)?, &e.during) {
                (None, None) => return Err(err("timeline", "give at or during".into())),
                (Some(_), Some(_)) => {
                    return Err(err("during", "give at or during, not both".into()))
                }
                (Some(t), None) => Expect::StateAt {
                    timeline: name.to_string(),
                    key,
                    value,
                    at: t,
                },
                (None, Some(task)) => Expect::StateDuring {
                    timeline: name.to_string(),
                    key,
                    value,
                    task: known_task(task, "during")?,
                },
            }
        }
        "order" => {
            let order = e.order.clone().unwrap_or_default();
            if order.len() < 2 {
                return Err(err("order", "give at least two labels to order".into()));
            }
            Expect::Order(order)
        }
        "covered_by" => {
            let tasks = e.covered_by.clone().unwrap_or_default();
            if tasks.is_empty() {
                return Err(err("covered_by", "name at least one task".into()));
            }
            for (i, t) in tasks.iter().enumerate() {
                known_task(t, &format!("covered_by[{i}]"))?;
            }
            let (Some(from), Some(to)) =
                (mission_time("from", &e.from)?, mission_time("to", &e.to)?)
            else {
                return Err(err("covered_by", "give from and to".into()));
            };
            if to <= from {
                return Err(err(
                    "to",
                    format!(
                        "{} is not after from ({}): the span is empty and would check nothing",
                        fmt_time(to),
                        fmt_time(from)
                    ),
                ));
            }
            Expect::Coverage {
                tasks,
                from,
                to,
                exclusive: e.exclusive == Some(true),
                allow_downtime: e.allow_reset_gaps == Some(true),
            }
        }
        "command" => {
            let (Some(at), Some(args)) = (mission_time("at", &e.at)?, e.args.clone()) else {
                return Err(err("command", "give at and args".into()));
            };
            Expect::Command {
                opcode: e.command.unwrap_or_default(),
                at,
                args,
            }
        }
        _ => {
            let name = e.metric.clone().unwrap_or_default();
            if metrics::lookup(&name).is_none() {
                return Err(err(
                    "metric",
                    format!(
                        "no metric named {name:?} (metrics: {})",
                        metrics::names().join(", ")
                    ),
                ));
            }
            match (e.min, e.max) {
                (None, None) => return Err(err("metric", "give max or min".into())),
                (Some(lo), Some(hi)) if lo > hi => {
                    return Err(err(
                        "min",
                        format!("{lo} is above max ({hi}): nothing can pass"),
                    ))
                }
                _ => {}
            }
            Expect::Metric {
                name,
                min: e.min,
                max: e.max,
            }
        }
    })
}
