//! Task networks in TOML: the human-readable form the ground writes, compiled into the autonomy
//! core's network type and its binary uplink, checked by the very validator the target runs
//! (`autonomy::uplink`), with every error reported as `file:line:column: field: message`.
//!
//! # Format
//!
//! Times (`earliest_start`, `latest_start`, `latest_end`) and durations follow [`crate::time`],
//! the grammar scenario files use too: `"10:00"`, `"1T10:00"`, `"2028-041T10:00"` (year-day,
//! on or after the epoch), seconds; `"never"` means no limit. The epoch (mission time 0) is
//! `[network] epoch`, default `"2028-040T00:00"`. Durations: `"15min"`, `"90s"`, `"1h30min"`,
//! `"250ms"`, seconds; offsets may start with `-`.
//! State values are named (`"NADIR"`) after the timeline's `values`.
//!
//! ```toml
//! [network]
//! id = 3
//! epoch = "2028-040T00:00"          # mission time 0
//! commit_window = "60s"
//! scheduling_window = "6h"
//! plan_horizon = "12h"
//! plan_process_interval = "5m"
//! # Responses to failures, for every task that does not set its own (defaults shown):
//! max_retries = 0                   # executive re-dispatches per instance and cause
//! max_repairs = 2                   # planner restarts/re-adds per definition and cause
//! retry_backoff = "10s"             # 1st response at once, then 10s, 20s, 40s, ...
//! retry_backoff_max = "10m"         # ... capped here
//! stale_after = "15min"             # staleness bound of every measured timeline that sets
//!                                   # none itself (default: none, values never go stale)
//!
//! [[timeline]]
//! name = "GncAttitude"
//! kind = "state"                    # state | claimable | cumulative
//! values = ["INERTIAL", "NADIR", "TURNING", "UNKNOWN", "EARTH"]
//! initial = "INERTIAL"
//! state_key = 1                     # measured by this state-buffer entry
//! stale_after = "10min"             # a measurement older than this reads UNKNOWN; "never"
//!                                   # opts out of the network's default
//!
//! [[timeline]]
//! name = "FlybyRequest"
//! kind = "cumulative"
//! initial = 0
//! min = 0
//! max = 8
//!
//! [[timeline]]
//! name = "Instrument"
//! kind = "claimable"
//!
//! [[timeline]]
//! name = "Heater"                   # only the planner knows it (no state_key) ...
//! kind = "state"
//! values = ["OFF", "ON"]
//! after_reset = "OFF"               # ... and a reset turns it off
//!
//! [[timeline]]
//! name = "StationInView"            # an external availability timeline: set by its
//! kind = "state"                    # schedule (and measurements), never by a task
//! values = ["NO", "YES"]
//! external = true
//! schedule = [ { at = "10:20", value = "YES" }, { at = "10:50", value = "NO" } ]
//!
//! [[timeline]]
//! name = "Battery"
//! kind = "cumulative"
//! initial = 2000000
//! min = 0
//! max = 2000000
//! background_rate = -20             # per second from mission time 0 (a hotel load)
//!
//! [[timeline]]
//! name = "TransmitterTemp"          # derived: measured as an integer, COLD below 2630,
//! kind = "state"                    # WARM from 2630 (one threshold fewer than values)
//! values = ["COLD", "WARM"]
//! state_key = 21
//! thresholds = [2630]
//!
//! [[condition]]
//! name = "attitude_known"
//! expr = { not = { timeline = "GncAttitude", op = "==", value = "UNKNOWN" } }
//! # also: { all = [...] }, { any = [...] }, { state_key = 7, op = ">=", value = 3 }
//!
//! [[task]]
//! id = 3
//! name = "Instrument Flyby"
//! role = "requested"                # requested (default) | template
//! priority = 40
//! command = { opcode = 0x0201, args = [] }   # omit for a no-op task
//! # arguments taken from the instance at dispatch, after `args` (at most 4 in all):
//! # command = { opcode = 0x0101, args = [1], from_instance = ["served_arg_0", "end"] }
//! #   instance: the instance id; end, duration: as executed, in whole mission seconds (a
//! #   restart's shortened end); served_arg_K: argument K of the task the instance serves
//! #   (the one a template instance was added for; a restart's failed instance), else -1
//! duration = "50m"
//! min_duration = "5m"               # default: duration
//! earliest_start = "10:15"
//! latest_start = "11:00"            # default: earliest_start (requested), never (template)
//! latest_end = "11:05"              # default: never
//! constraints = [
//!   { when = "pre", timeline = "GncAttitude", in = ["NADIR"] },
//!   { when = "maintain", timeline = "GncAttitude", in = ["NADIR"] },
//!   # cumulative/claimable: { when = "maintain", timeline = "FlybyRequest", min = 1, max = 8 }
//!   # offsets: start_offset = "1s", end_offset = "-30s"
//! ]
//! impacts = [
//!   { when = "maintain", timeline = "FlybyRequest", add = 1 },
//!   { when = "maintain", timeline = "Instrument", claim = true },
//!   # { when = "post", timeline = "GncAttitude", assign = "NADIR" }, { ..., rate = -5 }
//! ]
//! pre_wait_timeout = "1m"
//! response_timeout = "1m"
//! max_retries = { command_failed = 2, response_timeout = 1 }   # or one number for every cause
//! max_repairs = 3                   # or { any = 3, command_rejected = 0 }
//! retry_backoff = "30s"             # retry_backoff_max too; unset ones are the network's
//! start_condition = "attitude_known"   # also maintain_condition, skip_condition
//! on_failure_command = { opcode = 0x0200, args = [] }
//! contingencies = [ { on = "any", action = "restart" } ]
//! # on: "any" or a list of pre_timeout, response_timeout, command_failed, command_rejected,
//! #     maintain_violation, unschedulable, post_condition, interrupted;
//! #     action: restart | move | delete | { add_template = "name" }
//! may_move = true
//! may_delete = false
//! may_add = ["GncAttain NADIR (template)", "Instrument Degraded Flyby"]
//!
//! [[temporal]]                      # to_point(to) - from_point(from) in [min, max]
//!                                   # between two requested tasks, or a template and a
//!                                   # requested task: then every instance of the template
//!                                   # is bound to the requested task (never two templates)
//! from = "GncAttain NADIR"
//! from_point = "end"
//! to = "Instrument Flyby"
//! to_point = "start"
//! min = "0s"
//! max = "1h"
//!
//! [[parameter]]                     # a model parameter (format 5): the durations and impact
//! name = "PassLength"               # magnitudes it names take its prior, and every
//! prior = "25min"                   # measurement of `measured_by` within [min, max] replaces
//! min = "15min"                     # it (durations: duration text; impacts: numbers)
//! max = "30min"
//! measured_by = "PassLengthReport"  # a measured cumulative timeline; omit: fixed
//! uses = [ { task = "Downlink Pass 2", duration = true } ]   # or { task = ..., impact = 1 }
//! ```
//!
//! Staleness (`stale_after`, a duration): a state-buffer value measured at `t` reads UNKNOWN to
//! the autonomy (conditions, constraints, the planner) from the first step at which
//! `now - t > stale_after`, until a newer measurement arrives; the target reports it
//! (`TelemetryEvent::StateStale`) and reacts as to any state change. Only timelines with a
//! `state_key` take one; it must be positive and at most 30 days. `[network] stale_after` is
//! the default for every measured timeline that does not set its own (`"never"` opts out); the
//! uplink carries the resulting bound of each timeline. The host must publish each measured
//! value again, stamped with the time it is published, more often than its bound.
//!
//! Response bounds (`max_retries`, `max_repairs`) are per failure cause. One number sets every
//! cause it applies to (retries: response_timeout, command_failed, command_rejected,
//! post_condition; repairs: all but unschedulable); a table sets the causes it names (`any`
//! first, then the others), leaving the rest as the network's (or the built-in default). At
//! most 15 per cause. Cause names are those of `contingencies.on`.
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;

use autonomy::uplink::{ErrorSite, ResponseField, TaskField, ValidationError};
use autonomy::{
    Backoff, CommandArgs, CommandSpec, CondNode, ConditionSpec, ConstraintSpec, ConstraintWhen,
    Contingency, ContingencyAction, ControlSpec, Effect, FailureKind, ImpactSpec, ImpactWhen,
    InstanceArg, MissionTimeUs, Name, NetworkSpec, Opcode, Operand, ParamSpec, ParamUse, PerCause,
    Permissions, PlannerConfig, RelOp, Requirement, ResponsePolicy, StateKey, TaskNetwork,
    TaskPoint, TaskRole, TaskSpec, TemporalConstraint, TimelineKind, TimelineSpec,
};
use serde::Deserialize;
use toml::Spanned;

use crate::diag::{Diagnostic, SourceFile};
use crate::time::{self, Epoch, TimeText};

/// A task network that did not compile, located in its file (with the target's validation
/// code when the target's own validator refused it).
pub type TaskNetError = Diagnostic;

/// A compiled task network: the autonomy core's network, its binary uplink, and the names a
/// scenario may use (its symbol table). Compiled once per run.
#[derive(Clone, Debug)]
pub struct CompiledNetwork {
    pub network: TaskNetwork,
    pub uplink: Vec<u8>,
    pub symbols: Symbols,
}

/// The names of a task network, as the ground wrote them.
#[derive(Clone, Debug, Default)]
pub struct Symbols {
    /// Mission time 0.
    pub epoch: Epoch,
    pub timelines: Vec<TimelineSymbol>,
}

/// One timeline's name, kind, value names and the state key that measures it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TimelineSymbol {
    pub name: String,
    pub kind: TimelineKindName,
    /// Value names of a state timeline (empty for the others).
    pub values: Vec<String>,
    pub state_key: Option<StateKey>,
    /// Staleness bound in µs (its own or the network's default): the host must publish the
    /// value again more often than this, or the target reads it as unknown.
    pub stale_after_us: Option<u64>,
}

/// The kind of a timeline, which fixes the type of value a measurement of it must carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimelineKindName {
    /// Enumerated values: measured as `StateValue::Enum`.
    State,
    /// Integer quantity: measured as `StateValue::Int` (also a state timeline derived from an
    /// integer measurement by `thresholds`).
    Cumulative,
    /// Claims only; never measured.
    Claimable,
}

impl TimelineKindName {
    pub fn name(self) -> &'static str {
        match self {
            Self::State => "state",
            Self::Cumulative => "cumulative",
            Self::Claimable => "claimable",
        }
    }
}

impl CompiledNetwork {
    /// A timeline by name.
    pub fn timeline(&self, name: &str) -> Option<&TimelineSymbol> {
        self.symbols.timelines.iter().find(|t| t.name == name)
    }

    /// A task definition's ground id by name.
    pub fn task_id(&self, name: &str) -> Option<u16> {
        self.network
            .tasks()
            .iter()
            .find(|t| t.name.as_str() == name)
            .map(|t| t.id)
    }

    /// A task definition's name by ground id.
    pub fn task_name(&self, id: u16) -> Option<&str> {
        self.network
            .tasks()
            .iter()
            .find(|t| t.id == id)
            .map(|t| t.name.as_str())
    }
}

/// Reads and compiles a TOML task network.
pub fn compile_file(path: &Path) -> Result<CompiledNetwork, TaskNetError> {
    compile(&SourceFile::read(path)?)
}

/// Compiles TOML source `src` (named `file_name` in errors).
pub fn compile_str(src: &str, file_name: &str) -> Result<CompiledNetwork, TaskNetError> {
    compile(&SourceFile::new(file_name, src))
}

/// Compiles a task-network file.
pub fn compile(source: &SourceFile) -> Result<CompiledNetwork, TaskNetError> {
    let mut c = Compiler {
        src: source,
        sites: Sites::default(),
    };
    let raw: RawFile = toml::from_str(&source.text).map_err(|e| source.toml_error(&e, ""))?;
    let (spec, symbols) = c.build(&raw)?;
    let network = TaskNetwork::from_spec(spec).map_err(|e| c.validation_error(e))?;
    let mut buf = vec![0u8; 1 << 20];
    let len = network
        .encode(&mut buf)
        .map_err(|_| c.error(0..0, "network", "network too large to encode".into()))?;
    buf.truncate(len);
    // The bytes the target will see must pass the target's own check too.
    TaskNetwork::validate_uplink(&buf).map_err(|e| c.validation_error(e))?;
    Ok(CompiledNetwork {
        network,
        uplink: buf,
        symbols,
    })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    network: Spanned<RawNetwork>,
    #[serde(default)]
    timeline: Vec<Spanned<RawTimeline>>,
    #[serde(default)]
    condition: Vec<Spanned<RawCondition>>,
    #[serde(default)]
    task: Vec<Spanned<RawTask>>,
    #[serde(default)]
    temporal: Vec<Spanned<RawTemporal>>,
    #[serde(default)]
    parameter: Vec<Spanned<RawParam>>,
}

/// A model parameter (uplink format 5): `prior`, `min`, `max` are durations (`"25min"`) when
/// it sets durations, else numbers.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawParam {
    name: String,
    prior: RawNumOrText,
    min: RawNumOrText,
    max: RawNumOrText,
    measured_by: Option<String>,
    uses: Vec<RawParamUse>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawParamUse {
    task: String,
    #[serde(default)]
    duration: bool,
    impact: Option<u8>,
}

#[derive(Deserialize, Clone)]
#[serde(untagged)]
enum RawNumOrText {
    Int(i64),
    Text(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNetwork {
    id: u32,
    epoch: Option<Spanned<String>>,
    commit_window: Option<Spanned<RawNumOrText>>,
    scheduling_window: Option<Spanned<RawNumOrText>>,
    plan_horizon: Option<Spanned<RawNumOrText>>,
    plan_process_interval: Option<Spanned<RawNumOrText>>,
    max_retries: Option<Spanned<RawBound>>,
    max_repairs: Option<Spanned<RawBound>>,
    retry_backoff: Option<Spanned<RawNumOrText>>,
    retry_backoff_max: Option<Spanned<RawNumOrText>>,
    stale_after: Option<Spanned<RawNumOrText>>,
}

/// A response bound: one number for every cause it applies to, or one per named cause.
#[derive(Deserialize, Clone)]
#[serde(untagged)]
enum RawBound {
    All(i64),
    PerCause(BTreeMap<String, i64>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTimeline {
    name: Spanned<String>,
    kind: Spanned<String>,
    values: Option<Vec<String>>,
    initial: Option<Spanned<RawNumOrText>>,
    min: Option<i64>,
    max: Option<i64>,
    state_key: Option<u16>,
    after_reset: Option<Spanned<RawNumOrText>>,
    stale_after: Option<Spanned<RawNumOrText>>,
    /// Cumulative: change per second from mission time 0 (a hotel load).
    background_rate: Option<Spanned<i64>>,
    /// External availability timeline, set by `schedule` (and measurements), never by tasks.
    external: Option<bool>,
    /// The timed values of an external timeline.
    #[serde(default)]
    schedule: Vec<Spanned<RawTimedValue>>,
    /// Measured state: the value is the number of thresholds at or below the measured integer.
    thresholds: Option<Spanned<Vec<i64>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTimedValue {
    at: Spanned<RawNumOrText>,
    value: Spanned<RawNumOrText>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCondition {
    name: Spanned<String>,
    expr: Spanned<RawExpr>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawExpr {
    All {
        all: Vec<RawExpr>,
    },
    Any {
        any: Vec<RawExpr>,
    },
    Not {
        not: Box<RawExpr>,
    },
    Term {
        timeline: Option<String>,
        state_key: Option<u16>,
        op: String,
        value: RawNumOrText,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCommand {
    opcode: u16,
    #[serde(default)]
    args: Vec<i32>,
    #[serde(default)]
    from_instance: Vec<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConstraint {
    when: String,
    timeline: String,
    #[serde(rename = "in")]
    one_of: Option<Vec<String>>,
    min: Option<i64>,
    max: Option<i64>,
    start_offset: Option<RawNumOrText>,
    end_offset: Option<RawNumOrText>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawImpact {
    when: String,
    timeline: String,
    assign: Option<RawNumOrText>,
    add: Option<i64>,
    rate: Option<i64>,
    claim: Option<bool>,
    start_offset: Option<RawNumOrText>,
    end_offset: Option<RawNumOrText>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawOn {
    One(String),
    Many(Vec<String>),
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawAction {
    Simple(String),
    AddTemplate { add_template: String },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawContingency {
    on: RawOn,
    action: RawAction,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTask {
    id: Spanned<u16>,
    name: Spanned<String>,
    role: Option<Spanned<String>>,
    #[serde(default)]
    priority: u8,
    command: Option<Spanned<RawCommand>>,
    duration: Spanned<RawNumOrText>,
    min_duration: Option<Spanned<RawNumOrText>>,
    earliest_start: Option<Spanned<RawNumOrText>>,
    latest_start: Option<Spanned<RawNumOrText>>,
    latest_end: Option<Spanned<RawNumOrText>>,
    #[serde(default)]
    constraints: Vec<Spanned<RawConstraint>>,
    #[serde(default)]
    impacts: Vec<Spanned<RawImpact>>,
    pre_wait_timeout: Option<Spanned<RawNumOrText>>,
    response_timeout: Option<Spanned<RawNumOrText>>,
    max_retries: Option<Spanned<RawBound>>,
    max_repairs: Option<Spanned<RawBound>>,
    retry_backoff: Option<Spanned<RawNumOrText>>,
    retry_backoff_max: Option<Spanned<RawNumOrText>>,
    start_condition: Option<Spanned<String>>,
    maintain_condition: Option<Spanned<String>>,
    skip_condition: Option<Spanned<String>>,
    on_failure_command: Option<RawCommand>,
    #[serde(default)]
    contingencies: Vec<Spanned<RawContingency>>,
    #[serde(default)]
    may_move: bool,
    #[serde(default)]
    may_delete: bool,
    #[serde(default)]
    may_add: Vec<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTemporal {
    from: String,
    from_point: String,
    to: String,
    to_point: String,
    min: RawNumOrText,
    max: RawNumOrText,
}

/// Where each element came from, to locate the validator's errors.
#[derive(Default)]
struct Sites {
    network: Range<usize>,
    /// Network fields by name (`max_retries`, `max_repairs`, `retry_backoff`).
    network_fields: BTreeMap<String, Range<usize>>,
    timelines: Vec<Range<usize>>,
    /// The `after_reset` value of each timeline, where given.
    timeline_after_reset: Vec<Option<Range<usize>>>,
    /// Where each timeline's staleness bound came from (its own field, or the network's
    /// default) and that field's path.
    timeline_stale_after: Vec<Option<(Range<usize>, String)>>,
    conditions: Vec<Range<usize>>,
    tasks: Vec<BTreeMap<String, Range<usize>>>,
    temporal: Vec<Range<usize>>,
    /// Each timeline's `thresholds` field, where given.
    timeline_thresholds: Vec<Option<Range<usize>>>,
    /// Each timed value and its path (`timeline[i].schedule[k]`).
    timed: Vec<(Range<usize>, String)>,
    parameters: Vec<Range<usize>>,
}

struct Compiler<'a> {
    src: &'a SourceFile,
    sites: Sites,
}

impl RawNumOrText {
    /// As a time or duration in [`crate::time`]'s grammar.
    fn as_time_text(&self) -> TimeText {
        match self {
            RawNumOrText::Int(s) => TimeText::Seconds(*s),
            RawNumOrText::Text(t) => TimeText::Text(t.clone()),
        }
    }
}

/// Failure causes by their names in the file (`contingencies.on`, response bounds).
const CAUSE_NAMES: [(&str, FailureKind); FailureKind::COUNT] = [
    ("pre_timeout", FailureKind::PreTimeout),
    ("response_timeout", FailureKind::ResponseTimeout),
    ("command_failed", FailureKind::CommandFailed),
    ("command_rejected", FailureKind::CommandRejected),
    ("maintain_violation", FailureKind::MaintainViolation),
    ("unschedulable", FailureKind::Unschedulable),
    ("post_condition", FailureKind::PostConditionNotMet),
    ("interrupted", FailureKind::Interrupted),
];

fn cause_by_name(name: &str) -> Option<FailureKind> {
    CAUSE_NAMES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, kind)| kind)
}

fn response_field_name(f: ResponseField) -> &'static str {
    match f {
        ResponseField::MaxRetries => "max_retries",
        ResponseField::MaxRepairs => "max_repairs",
        ResponseField::Backoff => "retry_backoff",
    }
}

fn field_path(kind: &str, index: usize, field: &str) -> String {
    if field.is_empty() {
        format!("{kind}[{index}]")
    } else {
        format!("{kind}[{index}].{field}")
    }
}

impl<'a> Compiler<'a> {
    fn error(&self, span: Range<usize>, field: &str, message: String) -> TaskNetError {
        self.src.error(span, field, message)
    }

    fn validation_error(&self, e: ValidationError) -> TaskNetError {
        let (span, field) = match e.site {
            ErrorSite::Network => (self.sites.network.clone(), "network".to_string()),
            ErrorSite::NetworkResponses(f) => {
                let key = response_field_name(f);
                (
                    self.sites
                        .network_fields
                        .get(key)
                        .cloned()
                        .unwrap_or(self.sites.network.clone()),
                    format!("network.{key}"),
                )
            }
            ErrorSite::TimelineAfterReset(i) => (
                self.sites
                    .timeline_after_reset
                    .get(usize::from(i))
                    .cloned()
                    .flatten()
                    .or_else(|| self.sites.timelines.get(usize::from(i)).cloned())
                    .unwrap_or(0..0),
                format!("timeline[{i}].after_reset"),
            ),
            ErrorSite::TimelineStaleAfter(i) => self
                .sites
                .timeline_stale_after
                .get(usize::from(i))
                .cloned()
                .flatten()
                .unwrap_or_else(|| {
                    (
                        self.sites
                            .timelines
                            .get(usize::from(i))
                            .cloned()
                            .unwrap_or(0..0),
                        format!("timeline[{i}].stale_after"),
                    )
                }),
            ErrorSite::Timeline(i) => (
                self.sites
                    .timelines
                    .get(usize::from(i))
                    .cloned()
                    .unwrap_or(0..0),
                format!("timeline[{i}]"),
            ),
            ErrorSite::Condition { condition, node } => (
                self.sites
                    .conditions
                    .get(usize::from(condition))
                    .cloned()
                    .unwrap_or(0..0),
                format!("condition[{condition}].expr (node {node})"),
            ),
            ErrorSite::TimelineThresholds(i) => (
                self.sites
                    .timeline_thresholds
                    .get(usize::from(i))
                    .cloned()
                    .flatten()
                    .or_else(|| self.sites.timelines.get(usize::from(i)).cloned())
                    .unwrap_or(0..0),
                format!("timeline[{i}].thresholds"),
            ),
            ErrorSite::TimedValue(i) => self
                .sites
                .timed
                .get(usize::from(i))
                .cloned()
                .unwrap_or((0..0, format!("timed value {i}"))),
            ErrorSite::Param(i) => (
                self.sites
                    .parameters
                    .get(usize::from(i))
                    .cloned()
                    .unwrap_or(0..0),
                format!("parameter[{i}]"),
            ),
            ErrorSite::Temporal(i) => (
                self.sites
                    .temporal
                    .get(usize::from(i))
                    .cloned()
                    .unwrap_or(0..0),
                format!("temporal[{i}]"),
            ),
            ErrorSite::Task { task, field } => {
                let key = match field {
                    TaskField::Whole => String::new(),
                    TaskField::Id => "id".into(),
                    TaskField::Name => "name".into(),
                    TaskField::Command => "command".into(),
                    TaskField::Duration => "duration".into(),
                    TaskField::Window => "earliest_start".into(),
                    TaskField::Constraint(k) => format!("constraints[{k}]"),
                    TaskField::Impact(k) => format!("impacts[{k}]"),
                    TaskField::Control => "control".into(),
                    TaskField::Contingency(k) => format!("contingencies[{k}]"),
                    TaskField::Permission(k) => format!("may_add[{k}]"),
                    TaskField::Responses(f) => response_field_name(f).into(),
                };
                let sites = self.sites.tasks.get(usize::from(task));
                let span = sites
                    .and_then(|s| s.get(&key).or_else(|| s.get("")))
                    .cloned()
                    .unwrap_or(0..0);
                (span, field_path("task", usize::from(task), &key))
            }
        };
        self.error(
            span,
            &field,
            format!("{} (validation code {})", describe(e), e.code.code()),
        )
        .with_code(e.code.code())
    }

    fn duration_us(&self, v: &Spanned<RawNumOrText>, field: &str) -> Result<i64, TaskNetError> {
        self.duration_value(v.get_ref(), v.span(), field)
    }

    fn duration_value(
        &self,
        v: &RawNumOrText,
        span: Range<usize>,
        field: &str,
    ) -> Result<i64, TaskNetError> {
        time::parse_offset(&v.as_time_text()).map_err(|m| self.error(span, field, m))
    }

    /// A response bound: a number sets every cause in `applicable`, a table the causes it
    /// names (`any` first) on top of `base`.
    fn bound(
        &self,
        v: &Spanned<RawBound>,
        base: PerCause,
        applicable: u8,
        field: &str,
    ) -> Result<PerCause, TaskNetError> {
        let count = |n: i64| {
            u8::try_from(n).map_err(|_| {
                self.error(
                    v.span(),
                    field,
                    format!(
                        "{n} is not a bound (a count from 0 to {})",
                        autonomy::MAX_RESPONSE_BOUND
                    ),
                )
            })
        };
        match v.get_ref() {
            RawBound::All(n) => Ok(PerCause::uniform(count(*n)?, applicable)),
            RawBound::PerCause(causes) => {
                let mut out = base;
                if let Some(&n) = causes.get("any") {
                    let n = count(n)?;
                    for kind in FailureKind::ALL {
                        if applicable & kind.bit() != 0 {
                            out.set(kind, n);
                        }
                    }
                }
                for (name, &n) in causes.iter().filter(|(name, _)| *name != "any") {
                    let kind = cause_by_name(name).ok_or_else(|| {
                        let names: Vec<&str> = CAUSE_NAMES.iter().map(|(n, _)| *n).collect();
                        self.error(
                            v.span(),
                            field,
                            format!("unknown failure cause `{name}` (any, {})", names.join(", ")),
                        )
                    })?;
                    out.set(kind, count(n)?);
                }
                Ok(out)
            }
        }
    }

    /// `retry_backoff` and `retry_backoff_max` over `base`; None when neither is given.
    fn backoff(
        &self,
        initial: &Option<Spanned<RawNumOrText>>,
        max: &Option<Spanned<RawNumOrText>>,
        base: Backoff,
        path: &dyn Fn(&str) -> String,
    ) -> Result<Option<Backoff>, TaskNetError> {
        if initial.is_none() && max.is_none() {
            return Ok(None);
        }
        let value = |v: &Option<Spanned<RawNumOrText>>, name: &str, default: u64| match v {
            None => Ok(default),
            Some(v) => {
                let us = self.duration_us(v, &path(name))?;
                u64::try_from(us)
                    .map_err(|_| self.error(v.span(), &path(name), "must not be negative".into()))
            }
        };
        Ok(Some(Backoff {
            initial_us: value(initial, "retry_backoff", base.initial_us)?,
            max_us: value(max, "retry_backoff_max", base.max_us)?,
        }))
    }

    /// A staleness bound: a duration, or `"never"` (None). Zero and over-long bounds are left
    /// to the target's validator (with its code); a negative one is refused here.
    fn stale_after(
        &self,
        v: &Spanned<RawNumOrText>,
        field: &str,
    ) -> Result<Option<u64>, TaskNetError> {
        if matches!(v.get_ref(), RawNumOrText::Text(t) if t == "never") {
            return Ok(None);
        }
        let us = self.duration_us(v, field)?;
        u64::try_from(us).map(Some).map_err(|_| {
            self.error(
                v.span(),
                field,
                "must be a positive duration (or \"never\")".into(),
            )
        })
    }

    fn time(
        &self,
        v: &Spanned<RawNumOrText>,
        epoch: Epoch,
        field: &str,
    ) -> Result<MissionTimeUs, TaskNetError> {
        if matches!(v.get_ref(), RawNumOrText::Text(t) if t == "never") {
            return Ok(MissionTimeUs::MAX);
        }
        time::parse_time(&v.get_ref().as_time_text(), epoch)
            .map_err(|m| self.error(v.span(), field, m))
    }

    fn name(&self, s: &Spanned<String>, field: &str) -> Result<Name, TaskNetError> {
        Name::try_from(s.get_ref().as_str()).map_err(|_| {
            self.error(
                s.span(),
                field,
                format!("name longer than {} bytes", autonomy::MAX_NAME_LEN),
            )
        })
    }

    fn build(&mut self, raw: &RawFile) -> Result<(NetworkSpec, Symbols), TaskNetError> {
        self.sites.network = raw.network.span();
        let n = raw.network.get_ref();
        let epoch = match &n.epoch {
            Some(e) => time::parse_epoch(e.get_ref())
                .map_err(|m| self.error(e.span(), "network.epoch", m))?,
            None => Epoch::default(),
        };
        let mut symbols = Symbols {
            epoch,
            timelines: Vec::new(),
        };
        let mut config = PlannerConfig::DEFAULT;
        for (value, target, field) in [
            (
                &n.commit_window,
                &mut config.commit_window_us,
                "network.commit_window",
            ),
            (
                &n.scheduling_window,
                &mut config.scheduling_window_us,
                "network.scheduling_window",
            ),
            (
                &n.plan_horizon,
                &mut config.plan_horizon_us,
                "network.plan_horizon",
            ),
            (
                &n.plan_process_interval,
                &mut config.plan_process_interval_us,
                "network.plan_process_interval",
            ),
        ] {
            if let Some(v) = value {
                let us = self.duration_us(v, field)?;
                *target = u64::try_from(us)
                    .map_err(|_| self.error(v.span(), field, "must not be negative".into()))?;
            }
        }
        let mut spec = NetworkSpec::new(n.id, config);
        let defaults = ResponsePolicy::DEFAULT;
        let network_path = |f: &str| format!("network.{f}");
        if let Some(b) = &n.max_retries {
            self.sites
                .network_fields
                .insert("max_retries".into(), b.span());
            spec.header.responses.max_retries = self.bound(
                b,
                defaults.max_retries,
                FailureKind::RETRYABLE,
                "network.max_retries",
            )?;
        }
        if let Some(b) = &n.max_repairs {
            self.sites
                .network_fields
                .insert("max_repairs".into(), b.span());
            spec.header.responses.max_repairs = self.bound(
                b,
                defaults.max_repairs,
                FailureKind::REPAIRABLE,
                "network.max_repairs",
            )?;
        }
        if let Some(backoff) = self.backoff(
            &n.retry_backoff,
            &n.retry_backoff_max,
            defaults.backoff,
            &network_path,
        )? {
            let span = n
                .retry_backoff
                .as_ref()
                .or(n.retry_backoff_max.as_ref())
                .map_or(self.sites.network.clone(), |v| v.span());
            self.sites
                .network_fields
                .insert("retry_backoff".into(), span);
            spec.header.responses.backoff = backoff;
        }
        // The network's staleness bound, for every measured timeline without its own. The
        // target's own range check, with its code: the uplink only carries the bounds it
        // gives the timelines, and there may be none to carry it.
        let default_stale_after = match &n.stale_after {
            None => None,
            Some(v) => {
                let bound = self.stale_after(v, "network.stale_after")?;
                if bound.is_some_and(|us| !autonomy::uplink::stale_bound_in_range(us)) {
                    let e = ValidationError::new(
                        autonomy::ValidationCode::BadStaleBound,
                        ErrorSite::Network,
                    );
                    return Err(self
                        .error(
                            v.span(),
                            "network.stale_after",
                            format!("{} (validation code {})", describe(e), e.code.code()),
                        )
                        .with_code(e.code.code()));
                }
                bound.map(|us| (us, v.span()))
            }
        };

        // Timelines and their value names.
        let mut value_names: Vec<Vec<String>> = Vec::new();
        for (i, t) in raw.timeline.iter().enumerate() {
            let span = t.span();
            let t = t.get_ref();
            let path = |f: &str| field_path("timeline", i, f);
            let kind = match t.kind.get_ref().as_str() {
                "state" => {
                    let values = t.values.clone().unwrap_or_default();
                    let initial = match &t.initial {
                        None => 0,
                        Some(v) => {
                            self.state_value(&values, v.get_ref(), v.span(), &path("initial"))?
                        }
                    };
                    let count = u8::try_from(values.len()).map_err(|_| {
                        self.error(span.clone(), &path("values"), "too many values".into())
                    })?;
                    TimelineKind::State {
                        value_count: count,
                        initial,
                    }
                }
                "claimable" => TimelineKind::Claimable,
                "cumulative" => {
                    let initial = match &t.initial {
                        None => 0,
                        Some(v) => match v.get_ref() {
                            RawNumOrText::Int(i) => *i,
                            RawNumOrText::Text(_) => {
                                return Err(self.error(
                                    v.span(),
                                    &path("initial"),
                                    "a cumulative timeline starts at an integer".into(),
                                ))
                            }
                        },
                    };
                    TimelineKind::Cumulative {
                        initial,
                        min: t.min.unwrap_or(i64::MIN / 4),
                        max: t.max.unwrap_or(i64::MAX / 4),
                    }
                }
                other => {
                    return Err(self.error(
                        t.kind.span(),
                        &path("kind"),
                        format!("unknown timeline kind `{other}` (state, claimable or cumulative)"),
                    ))
                }
            };
            let after_reset = match (&t.after_reset, kind) {
                (None, _) => None,
                (Some(v), TimelineKind::State { .. }) => Some(i64::from(self.state_value(
                    t.values.as_deref().unwrap_or(&[]),
                    v.get_ref(),
                    v.span(),
                    &path("after_reset"),
                )?)),
                // Refused by the validator (only state timelines revert), with its code.
                (Some(v), _) => Some(match v.get_ref() {
                    RawNumOrText::Int(i) => *i,
                    RawNumOrText::Text(_) => 0,
                }),
            };
            let (stale_after_us, stale_after_site) = match (&t.stale_after, &default_stale_after) {
                (Some(v), _) => {
                    let field = path("stale_after");
                    (self.stale_after(v, &field)?, Some((v.span(), field)))
                }
                (None, Some((us, span))) if t.state_key.is_some() => (
                    Some(*us),
                    Some((span.clone(), "network.stale_after".to_string())),
                ),
                (None, _) => (None, None),
            };
            let mut thresholds: heapless::Vec<i64, { autonomy::MAX_THRESHOLDS }> =
                heapless::Vec::new();
            if let Some(th) = &t.thresholds {
                for &v in th.get_ref() {
                    if thresholds.push(v).is_err() {
                        return Err(self.capacity(
                            th.span(),
                            &path("thresholds"),
                            "thresholds",
                            autonomy::MAX_THRESHOLDS,
                        ));
                    }
                }
            }
            let external = t.external.unwrap_or(false);
            if !t.schedule.is_empty() && !external {
                return Err(self.error(
                    span.clone(),
                    &path("schedule"),
                    "a schedule is for an external timeline (external = true)".into(),
                ));
            }
            let timeline_index = spec.timelines.len() as u8;
            for (k, tv) in t.schedule.iter().enumerate() {
                let field = format!("{}[{k}]", path("schedule"));
                let at = self.time(&tv.get_ref().at, epoch, &format!("{field}.at"))?;
                let value = match (kind, tv.get_ref().value.get_ref()) {
                    (TimelineKind::State { .. }, v) => i64::from(self.state_value(
                        t.values.as_deref().unwrap_or(&[]),
                        v,
                        tv.get_ref().value.span(),
                        &format!("{field}.value"),
                    )?),
                    (_, RawNumOrText::Int(i)) => *i,
                    (_, RawNumOrText::Text(_)) => {
                        return Err(self.error(
                            tv.get_ref().value.span(),
                            &format!("{field}.value"),
                            "an integer value".into(),
                        ))
                    }
                };
                let timed = autonomy::TimedValue {
                    timeline: timeline_index,
                    at,
                    value,
                };
                if spec.timed.push(timed).is_err() {
                    return Err(self.capacity(
                        tv.span(),
                        &field,
                        "timed values",
                        autonomy::MAX_TIMED_VALUES,
                    ));
                }
                self.sites.timed.push((tv.span(), field));
            }
            let timeline = TimelineSpec {
                name: self.name(&t.name, &path("name"))?,
                kind,
                state_key: t.state_key.map(StateKey),
                after_reset,
                stale_after_us,
                background_rate: t.background_rate.as_ref().map_or(0, |r| *r.get_ref()),
                external,
                thresholds,
            };
            if spec.timelines.push(timeline).is_err() {
                return Err(self.capacity(span, &path(""), "timelines", autonomy::MAX_TIMELINES));
            }
            self.sites.timelines.push(span);
            self.sites
                .timeline_after_reset
                .push(t.after_reset.as_ref().map(|v| v.span()));
            self.sites.timeline_stale_after.push(stale_after_site);
            self.sites
                .timeline_thresholds
                .push(t.thresholds.as_ref().map(|v| v.span()));
            value_names.push(t.values.clone().unwrap_or_default());
            symbols.timelines.push(TimelineSymbol {
                name: t.name.get_ref().clone(),
                kind: match kind {
                    // Derived by thresholds: measured as an integer.
                    TimelineKind::State { .. } if t.thresholds.is_some() => {
                        TimelineKindName::Cumulative
                    }
                    TimelineKind::State { .. } => TimelineKindName::State,
                    TimelineKind::Claimable => TimelineKindName::Claimable,
                    _ => TimelineKindName::Cumulative,
                },
                values: t.values.clone().unwrap_or_default(),
                state_key: t.state_key.map(StateKey),
                stale_after_us,
            });
        }
        let timeline_index = |name: &str| {
            raw.timeline
                .iter()
                .position(|t| t.get_ref().name.get_ref() == name)
        };

        // Conditions.
        let mut condition_names: Vec<String> = Vec::new();
        for (i, c) in raw.condition.iter().enumerate() {
            let span = c.span();
            let c = c.get_ref();
            let mut nodes = Vec::new();
            self.expr(
                c.expr.get_ref(),
                c.expr.span(),
                &field_path("condition", i, "expr"),
                &timeline_index,
                &value_names,
                &mut nodes,
            )?;
            let mut spec_c = ConditionSpec::default();
            for node in nodes {
                if spec_c.nodes.push(node).is_err() {
                    return Err(self.capacity(
                        c.expr.span(),
                        &field_path("condition", i, "expr"),
                        "condition terms",
                        autonomy::MAX_CONDITION_TERMS,
                    ));
                }
            }
            if spec.conditions.push(spec_c).is_err() {
                return Err(self.capacity(
                    span,
                    &field_path("condition", i, ""),
                    "conditions",
                    autonomy::MAX_CONDITIONS,
                ));
            }
            self.sites.conditions.push(c.expr.span());
            condition_names.push(c.name.get_ref().clone());
        }

        // Tasks: a name names one task.
        for (i, t) in raw.task.iter().enumerate() {
            let name = t.get_ref().name.get_ref();
            if let Some(first) = raw.task[..i]
                .iter()
                .position(|o| o.get_ref().name.get_ref() == name)
            {
                return Err(self.error(
                    t.get_ref().name.span(),
                    &field_path("task", i, "name"),
                    format!("task[{first}] has the name `{name}` already: task names must be unique (scenarios and reports refer to tasks by name)"),
                ));
            }
        }
        let task_id = |name: &str| -> Option<u16> {
            raw.task
                .iter()
                .find(|t| t.get_ref().name.get_ref() == name)
                .map(|t| *t.get_ref().id.get_ref())
        };
        for (i, t) in raw.task.iter().enumerate() {
            let span = t.span();
            let responses = spec.header.responses;
            let task = self.task(
                i,
                t.get_ref(),
                span.clone(),
                &responses,
                epoch,
                &timeline_index,
                &value_names,
                &condition_names,
                &task_id,
            )?;
            if spec.tasks.push(task).is_err() {
                return Err(self.capacity(
                    span,
                    &field_path("task", i, ""),
                    "tasks",
                    autonomy::MAX_TASKS,
                ));
            }
        }

        // Temporal constraints.
        for (i, tc) in raw.temporal.iter().enumerate() {
            let span = tc.span();
            let tc = tc.get_ref();
            let path = field_path("temporal", i, "");
            let point = |p: &str| match p {
                "start" => Ok(TaskPoint::Start),
                "end" => Ok(TaskPoint::End),
                other => Err(self.error(
                    span.clone(),
                    &path,
                    format!("unknown point `{other}` (start or end)"),
                )),
            };
            let id = |name: &str| {
                task_id(name).ok_or_else(|| {
                    self.error(span.clone(), &path, format!("no task named `{name}`"))
                })
            };
            let constraint = TemporalConstraint {
                from_task: id(&tc.from)?,
                from_point: point(&tc.from_point)?,
                to_task: id(&tc.to)?,
                to_point: point(&tc.to_point)?,
                min_us: self.duration_value(&tc.min, span.clone(), &path)?,
                max_us: self.duration_value(&tc.max, span.clone(), &path)?,
            };
            if spec.temporal.push(constraint).is_err() {
                return Err(self.capacity(
                    span,
                    &path,
                    "temporal constraints",
                    autonomy::MAX_TEMPORAL_CONSTRAINTS,
                ));
            }
            self.sites.temporal.push(span);
        }
        if let Some(cycle) = inconsistent_temporal_cycle(&spec) {
            let names: Vec<String> = cycle.iter().map(|i| format!("temporal[{i}]")).collect();
            let first = cycle.first().copied().unwrap_or(0);
            return Err(self.error(
                self.sites.temporal.get(first).cloned().unwrap_or(0..0),
                &field_path("temporal", first, ""),
                format!(
                    "these temporal constraints form a cycle that no schedule can meet (with the tasks' durations): {}",
                    names.join(" -> ")
                ),
            ));
        }
        self.parameters(raw, &mut spec, &timeline_index)?;
        Ok((spec, symbols))
    }

    /// The `[[parameter]]` entries: each use's number in the tasks becomes the prior.
    fn parameters(
        &mut self,
        raw: &RawFile,
        spec: &mut NetworkSpec,
        timeline_index: &dyn Fn(&str) -> Option<usize>,
    ) -> Result<(), TaskNetError> {
        for (i, p) in raw.parameter.iter().enumerate() {
            let span = p.span();
            let p = p.get_ref();
            let path = field_path("parameter", i, "");
            let durations = p.uses.iter().any(|u| u.duration);
            let number = |v: &RawNumOrText| -> Result<i64, TaskNetError> {
                match (v, durations) {
                    (RawNumOrText::Int(n), false) => Ok(*n),
                    (_, true) => self.duration_value(v, span.clone(), &path),
                    (RawNumOrText::Text(t), false) => Err(self.error(
                        span.clone(),
                        &path,
                        format!("`{t}`: a parameter of impacts is a number"),
                    )),
                }
            };
            let (prior, min, max) = (number(&p.prior)?, number(&p.min)?, number(&p.max)?);
            let measured_by = match &p.measured_by {
                Some(name) => Some(
                    timeline_index(name)
                        .and_then(|t| u8::try_from(t).ok())
                        .ok_or_else(|| {
                            self.error(span.clone(), &path, format!("no timeline named `{name}`"))
                        })?,
                ),
                None => None,
            };
            let mut uses = heapless::Vec::new();
            for u in &p.uses {
                let Some(task) = spec.tasks.iter_mut().find(|t| t.name.as_str() == u.task) else {
                    return Err(self.error(
                        span.clone(),
                        &path,
                        format!("parameter `{}`: no task named `{}`", p.name, u.task),
                    ));
                };
                let one_use = match (u.duration, u.impact) {
                    (true, None) => {
                        task.duration_us = u64::try_from(prior).unwrap_or(0);
                        ParamUse::Duration { task: task.id }
                    }
                    (false, Some(k)) => {
                        if let Some(Effect::Add(v) | Effect::Rate(v) | Effect::Assign(v)) =
                            task.impacts.get_mut(usize::from(k)).map(|i| &mut i.effect)
                        {
                            *v = prior;
                        }
                        ParamUse::Impact {
                            task: task.id,
                            impact: k,
                        }
                    }
                    _ => {
                        return Err(self.error(
                            span.clone(),
                            &path,
                            "each use sets either the task's duration (duration = true) or \
                             one of its impacts (impact = index)"
                                .into(),
                        ))
                    }
                };
                if uses.push(one_use).is_err() {
                    return Err(self.capacity(
                        span.clone(),
                        &path,
                        "uses of one parameter",
                        autonomy::MAX_PARAM_USES,
                    ));
                }
            }
            let param = ParamSpec {
                prior,
                value: prior,
                min,
                max,
                measured_by,
                uses,
            };
            if spec.params.push(param).is_err() {
                return Err(self.capacity(span, &path, "parameters", autonomy::MAX_PARAMS));
            }
            self.sites.parameters.push(span);
        }
        Ok(())
    }

    fn capacity(&self, span: Range<usize>, field: &str, what: &str, max: usize) -> TaskNetError {
        self.error(
            span,
            field,
            format!("more than {max} {what} (the target's capacity)"),
        )
    }

    fn state_value(
        &self,
        values: &[String],
        v: &RawNumOrText,
        span: Range<usize>,
        field: &str,
    ) -> Result<u16, TaskNetError> {
        match v {
            RawNumOrText::Int(i) => u16::try_from(*i)
                .map_err(|_| self.error(span, field, format!("{i} is not a state value"))),
            RawNumOrText::Text(name) => values
                .iter()
                .position(|v| v == name)
                .map(|p| p as u16)
                .ok_or_else(|| {
                    self.error(
                        span,
                        field,
                        format!("`{name}` is not one of the timeline's values {values:?}"),
                    )
                }),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn expr(
        &self,
        e: &RawExpr,
        span: Range<usize>,
        field: &str,
        timeline_index: &dyn Fn(&str) -> Option<usize>,
        value_names: &[Vec<String>],
        out: &mut Vec<CondNode>,
    ) -> Result<(), TaskNetError> {
        match e {
            RawExpr::All { all: items } | RawExpr::Any { any: items } => {
                let joiner = if matches!(e, RawExpr::All { .. }) {
                    CondNode::And
                } else {
                    CondNode::Or
                };
                if items.is_empty() {
                    return Err(self.error(span, field, "empty all/any".into()));
                }
                for (k, item) in items.iter().enumerate() {
                    self.expr(item, span.clone(), field, timeline_index, value_names, out)?;
                    if k > 0 {
                        out.push(joiner);
                    }
                }
            }
            RawExpr::Not { not } => {
                self.expr(not, span.clone(), field, timeline_index, value_names, out)?;
                out.push(CondNode::Not);
            }
            RawExpr::Term {
                timeline,
                state_key,
                op,
                value,
            } => {
                let op = match op.as_str() {
                    "==" => RelOp::Eq,
                    "!=" => RelOp::Ne,
                    "<" => RelOp::Lt,
                    "<=" => RelOp::Le,
                    ">" => RelOp::Gt,
                    ">=" => RelOp::Ge,
                    other => {
                        return Err(self.error(span, field, format!("unknown operator `{other}`")))
                    }
                };
                let (operand, names) = match (timeline, state_key) {
                    (Some(name), None) => {
                        let t = timeline_index(name).ok_or_else(|| {
                            self.error(span.clone(), field, format!("no timeline named `{name}`"))
                        })?;
                        (
                            Operand::Timeline(t as u8),
                            value_names.get(t).cloned().unwrap_or_default(),
                        )
                    }
                    (None, Some(key)) => (Operand::State(StateKey(*key)), Vec::new()),
                    _ => {
                        return Err(self.error(
                            span,
                            field,
                            "a term names exactly one of `timeline` or `state_key`".into(),
                        ))
                    }
                };
                let value = match value {
                    RawNumOrText::Int(i) => *i,
                    text => i64::from(self.state_value(&names, text, span.clone(), field)?),
                };
                out.push(CondNode::Term { operand, op, value });
            }
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn task(
        &mut self,
        i: usize,
        t: &RawTask,
        span: Range<usize>,
        responses: &ResponsePolicy,
        epoch: Epoch,
        timeline_index: &dyn Fn(&str) -> Option<usize>,
        value_names: &[Vec<String>],
        condition_names: &[String],
        task_id: &dyn Fn(&str) -> Option<u16>,
    ) -> Result<TaskSpec, TaskNetError> {
        let path = |f: &str| field_path("task", i, f);
        let mut sites: BTreeMap<String, Range<usize>> = BTreeMap::new();
        sites.insert(String::new(), span.clone());
        sites.insert("id".into(), t.id.span());
        sites.insert("name".into(), t.name.span());
        sites.insert("duration".into(), t.duration.span());
        sites.insert(
            "earliest_start".into(),
            t.earliest_start.as_ref().map_or(span.clone(), |s| s.span()),
        );
        if let Some(c) = &t.command {
            sites.insert("command".into(), c.span());
        }
        let control_span = t
            .response_timeout
            .as_ref()
            .or(t.pre_wait_timeout.as_ref())
            .map(|s| s.span())
            .or_else(|| t.start_condition.as_ref().map(|s| s.span()))
            .unwrap_or(span.clone());
        sites.insert("control".into(), control_span);

        let role = match t.role.as_ref().map(|r| r.get_ref().as_str()) {
            None | Some("requested") => TaskRole::Requested,
            Some("template") => TaskRole::Template,
            Some(other) => {
                let r = t.role.as_ref().map(|r| r.span()).unwrap_or(span.clone());
                return Err(self.error(
                    r,
                    &path("role"),
                    format!("unknown role `{other}` (requested or template)"),
                ));
            }
        };
        let non_negative = |us: i64, s: Range<usize>, f: &str| {
            u64::try_from(us).map_err(|_| self.error(s, &path(f), "must not be negative".into()))
        };
        let duration_us = non_negative(
            self.duration_us(&t.duration, &path("duration"))?,
            t.duration.span(),
            "duration",
        )?;
        let min_duration_us = match &t.min_duration {
            Some(d) => non_negative(
                self.duration_us(d, &path("min_duration"))?,
                d.span(),
                "min_duration",
            )?,
            None => duration_us,
        };
        let earliest_start = match &t.earliest_start {
            Some(v) => self.time(v, epoch, &path("earliest_start"))?,
            None => MissionTimeUs::ZERO,
        };
        let latest_start = match (&t.latest_start, role) {
            (Some(v), _) => self.time(v, epoch, &path("latest_start"))?,
            (None, TaskRole::Requested) => earliest_start,
            (None, TaskRole::Template) => MissionTimeUs::MAX,
        };
        let latest_end = match &t.latest_end {
            Some(v) => self.time(v, epoch, &path("latest_end"))?,
            None => MissionTimeUs::MAX,
        };
        let command =
            |c: &RawCommand, s: Range<usize>, f: &str| -> Result<CommandSpec, TaskNetError> {
                Ok(CommandSpec {
                    opcode: Opcode(c.opcode),
                    args: CommandArgs::from_slice(&c.args).map_err(|_| {
                        self.error(
                            s.clone(),
                            &path(f),
                            format!(
                                "more than {} command arguments",
                                fsw_bridge::MAX_COMMAND_ARGS
                            ),
                        )
                    })?,
                    from_instance: {
                        let mut v = heapless::Vec::new();
                        for a in &c.from_instance {
                            let arg = instance_arg(a).ok_or_else(|| {
                                self.error(
                                    s.clone(),
                                    &path(f),
                                    format!(
                                        "unknown instance argument `{a}` (instance, end, \
                                         duration, served_arg_0 .. served_arg_3)"
                                    ),
                                )
                            })?;
                            if v.push(arg).is_err() {
                                return Err(self.error(
                                    s.clone(),
                                    &path(f),
                                    format!(
                                        "more than {} command arguments",
                                        fsw_bridge::MAX_COMMAND_ARGS
                                    ),
                                ));
                            }
                        }
                        v
                    },
                })
            };
        let timeline = |name: &str, s: Range<usize>, f: &str| -> Result<usize, TaskNetError> {
            timeline_index(name)
                .ok_or_else(|| self.error(s, &path(f), format!("no timeline named `{name}`")))
        };
        let offset =
            |v: &Option<RawNumOrText>, s: Range<usize>, f: &str| -> Result<i64, TaskNetError> {
                match v {
                    Some(v) => self.duration_value(v, s, &path(f)),
                    None => Ok(0),
                }
            };

        let mut spec = TaskSpec {
            id: *t.id.get_ref(),
            name: self.name(&t.name, &path("name"))?,
            priority: t.priority,
            role,
            command: match &t.command {
                Some(c) => Some(command(c.get_ref(), c.span(), "command")?),
                None => None,
            },
            duration_us,
            min_duration_us,
            earliest_start,
            latest_start,
            latest_end,
            constraints: Default::default(),
            impacts: Default::default(),
            control: ControlSpec::NONE,
            contingencies: Default::default(),
            permissions: Permissions {
                may_move: t.may_move,
                may_delete: t.may_delete,
                may_add: Default::default(),
            },
        };
        for (k, c) in t.constraints.iter().enumerate() {
            let f = format!("constraints[{k}]");
            let s = c.span();
            sites.insert(f.clone(), s.clone());
            let c = c.get_ref();
            let tl = timeline(&c.timeline, s.clone(), &f)?;
            let when = match c.when.as_str() {
                "pre" => ConstraintWhen::Pre,
                "maintain" => ConstraintWhen::Maintain,
                other => {
                    return Err(self.error(
                        s,
                        &path(&f),
                        format!("unknown constraint time `{other}` (pre or maintain)"),
                    ))
                }
            };
            let require = match (&c.one_of, c.min, c.max) {
                (Some(values), None, None) => {
                    let mut mask = 0u32;
                    for v in values {
                        let code = self.state_value(
                            value_names.get(tl).map_or(&[][..], |v| v),
                            &RawNumOrText::Text(v.clone()),
                            s.clone(),
                            &path(&f),
                        )?;
                        mask |= 1u32.checked_shl(u32::from(code)).unwrap_or(0);
                    }
                    Requirement::OneOf { mask }
                }
                (None, min, max) if min.is_some() || max.is_some() => Requirement::Range {
                    min: min.unwrap_or(-(1 << 48)),
                    max: max.unwrap_or(1 << 48),
                },
                _ => {
                    return Err(self.error(
                        s,
                        &path(&f),
                        "give either `in = [values]` or `min`/`max`".into(),
                    ))
                }
            };
            let constraint = ConstraintSpec {
                when,
                timeline: tl as u8,
                require,
                start_offset_us: offset(&c.start_offset, s.clone(), &f)?,
                end_offset_us: offset(&c.end_offset, s.clone(), &f)?,
            };
            if spec.constraints.push(constraint).is_err() {
                return Err(self.capacity(
                    s,
                    &path(&f),
                    "constraints per task",
                    autonomy::MAX_CONSTRAINTS_PER_TASK,
                ));
            }
        }
        for (k, m) in t.impacts.iter().enumerate() {
            let f = format!("impacts[{k}]");
            let s = m.span();
            sites.insert(f.clone(), s.clone());
            let m = m.get_ref();
            let tl = timeline(&m.timeline, s.clone(), &f)?;
            let when = match m.when.as_str() {
                "pre" => ImpactWhen::Pre,
                "maintain" | "during" => ImpactWhen::Maintain,
                "post" => ImpactWhen::Post,
                other => {
                    return Err(self.error(
                        s,
                        &path(&f),
                        format!("unknown impact time `{other}` (pre, maintain or post)"),
                    ))
                }
            };
            let effect = match (&m.assign, m.add, m.rate, m.claim) {
                (Some(v), None, None, None) => Effect::Assign(match v {
                    RawNumOrText::Int(i) => *i,
                    text => i64::from(self.state_value(
                        value_names.get(tl).map_or(&[][..], |v| v),
                        text,
                        s.clone(),
                        &path(&f),
                    )?),
                }),
                (None, Some(d), None, None) => Effect::Add(d),
                (None, None, Some(r), None) => Effect::Rate(r),
                (None, None, None, Some(true)) => Effect::Claim,
                _ => {
                    return Err(self.error(
                        s,
                        &path(&f),
                        "give exactly one of `assign`, `add`, `rate` or `claim = true`".into(),
                    ))
                }
            };
            let impact = ImpactSpec {
                when,
                timeline: tl as u8,
                effect,
                start_offset_us: offset(&m.start_offset, s.clone(), &f)?,
                end_offset_us: offset(&m.end_offset, s.clone(), &f)?,
            };
            if spec.impacts.push(impact).is_err() {
                return Err(self.capacity(
                    s,
                    &path(&f),
                    "impacts per task",
                    autonomy::MAX_IMPACTS_PER_TASK,
                ));
            }
        }
        let timeout = |v: &Option<Spanned<RawNumOrText>>, f: &str| -> Result<u64, TaskNetError> {
            match v {
                Some(v) => non_negative(self.duration_us(v, &path(f))?, v.span(), f),
                None => Ok(0),
            }
        };
        spec.control.pre_wait_timeout_us = timeout(&t.pre_wait_timeout, "pre_wait_timeout")?;
        spec.control.response_timeout_us = timeout(&t.response_timeout, "response_timeout")?;
        if let Some(b) = &t.max_retries {
            sites.insert("max_retries".into(), b.span());
            spec.control.max_retries = Some(self.bound(
                b,
                responses.max_retries,
                FailureKind::RETRYABLE,
                &path("max_retries"),
            )?);
        }
        if let Some(b) = &t.max_repairs {
            sites.insert("max_repairs".into(), b.span());
            spec.control.max_repairs = Some(self.bound(
                b,
                responses.max_repairs,
                FailureKind::REPAIRABLE,
                &path("max_repairs"),
            )?);
        }
        spec.control.backoff = self.backoff(
            &t.retry_backoff,
            &t.retry_backoff_max,
            responses.backoff,
            &path,
        )?;
        if let Some(v) = t.retry_backoff.as_ref().or(t.retry_backoff_max.as_ref()) {
            sites.insert("retry_backoff".into(), v.span());
        }
        let condition =
            |c: &Option<Spanned<String>>, f: &str| -> Result<Option<u8>, TaskNetError> {
                match c {
                    None => Ok(None),
                    Some(name) => condition_names
                        .iter()
                        .position(|n| n == name.get_ref())
                        .map(|p| Some(p as u8))
                        .ok_or_else(|| {
                            self.error(
                                name.span(),
                                &path(f),
                                format!("no condition named `{}`", name.get_ref()),
                            )
                        }),
                }
            };
        spec.control.start_condition = condition(&t.start_condition, "start_condition")?;
        spec.control.maintain_condition = condition(&t.maintain_condition, "maintain_condition")?;
        spec.control.skip_condition = condition(&t.skip_condition, "skip_condition")?;
        if let Some(c) = &t.on_failure_command {
            spec.control.on_failure_command = Some(command(c, span.clone(), "on_failure_command")?);
        }
        for (k, c) in t.contingencies.iter().enumerate() {
            let f = format!("contingencies[{k}]");
            let s = c.span();
            sites.insert(f.clone(), s.clone());
            let c = c.get_ref();
            let kinds: Vec<String> = match &c.on {
                RawOn::One(k) => vec![k.clone()],
                RawOn::Many(ks) => ks.clone(),
            };
            let mut on = 0u8;
            for kind in &kinds {
                on |= match (kind.as_str(), cause_by_name(kind)) {
                    ("any", _) => FailureKind::ANY,
                    (_, Some(cause)) => cause.bit(),
                    (other, None) => {
                        return Err(self.error(
                            s,
                            &path(&f),
                            format!("unknown failure kind `{other}`"),
                        ))
                    }
                };
            }
            let action = match &c.action {
                RawAction::Simple(a) => match a.as_str() {
                    "restart" => ContingencyAction::Restart,
                    "move" => ContingencyAction::Move,
                    "delete" => ContingencyAction::Delete,
                    other => return Err(self.error(s, &path(&f), format!("unknown action `{other}` (restart, move, delete or {{ add_template = \"name\" }})"))),
                },
                RawAction::AddTemplate { add_template } => ContingencyAction::AddTemplate(
                    task_id(add_template).ok_or_else(|| self.error(s.clone(), &path(&f), format!("no task named `{add_template}`")))?,
                ),
            };
            if spec.contingencies.push(Contingency { on, action }).is_err() {
                return Err(self.capacity(
                    s,
                    &path(&f),
                    "contingencies per task",
                    autonomy::MAX_CONTINGENCIES_PER_TASK,
                ));
            }
        }
        for (k, name) in t.may_add.iter().enumerate() {
            let f = format!("may_add[{k}]");
            sites.insert(f.clone(), name.span());
            let id = task_id(name.get_ref()).ok_or_else(|| {
                self.error(
                    name.span(),
                    &path(&f),
                    format!("no task named `{}`", name.get_ref()),
                )
            })?;
            if spec.permissions.may_add.push(id).is_err() {
                return Err(self.capacity(
                    name.span(),
                    &path(&f),
                    "templates per task",
                    autonomy::MAX_ADD_PERMISSIONS_PER_TASK,
                ));
            }
        }
        self.sites.tasks.push(sites);
        Ok(spec)
    }
}

/// An instance argument's TOML name: `instance`, `end`, `duration`, `served_arg_K`.
fn instance_arg(name: &str) -> Option<InstanceArg> {
    Some(match name {
        "instance" => InstanceArg::Instance,
        "end" => InstanceArg::EndS,
        "duration" => InstanceArg::DurationS,
        _ => {
            let k: u8 = name.strip_prefix("served_arg_")?.parse().ok()?;
            (usize::from(k) < fsw_bridge::MAX_COMMAND_ARGS).then_some(InstanceArg::Served(k))?
        }
    })
}

/// The temporal constraints (by index) on a cycle that no schedule can meet, if any: a negative
/// cycle of the simple temporal network whose nodes are the start and end of each task, with
/// `end - start` in `[min_duration, duration]` and each constraint's `[min, max]`.
fn inconsistent_temporal_cycle(spec: &NetworkSpec) -> Option<Vec<usize>> {
    let node = |id: u16, point: TaskPoint| -> Option<usize> {
        let d = spec.tasks.iter().position(|t| t.id == id)?;
        Some(2 * d + usize::from(point == TaskPoint::End))
    };
    // Edges u -> v with weight w mean v - u <= w; the constraint index, if one made it.
    let mut edges: Vec<(usize, usize, i64, Option<usize>)> = Vec::new();
    for (d, t) in spec.tasks.iter().enumerate() {
        let (start, end) = (2 * d, 2 * d + 1);
        edges.push((start, end, t.duration_us.min(i64::MAX as u64) as i64, None));
        edges.push((
            end,
            start,
            -(t.min_duration_us.min(i64::MAX as u64) as i64),
            None,
        ));
    }
    for (i, tc) in spec.temporal.iter().enumerate() {
        let (Some(u), Some(v)) = (
            node(tc.from_task, tc.from_point),
            node(tc.to_task, tc.to_point),
        ) else {
            continue;
        };
        edges.push((u, v, tc.max_us, Some(i)));
        edges.push((v, u, tc.min_us.saturating_neg(), Some(i)));
    }
    let n = 2 * spec.tasks.len();
    // Bellman-Ford from a virtual source joined to every node by a 0 edge.
    let mut dist = vec![0i64; n];
    let mut pred: Vec<Option<usize>> = vec![None; n];
    let mut last_changed = None;
    for _ in 0..=n {
        last_changed = None;
        for (k, &(u, v, w, _)) in edges.iter().enumerate() {
            let cand = dist[u].saturating_add(w);
            if cand < dist[v] {
                dist[v] = cand;
                pred[v] = Some(k);
                last_changed = Some(v);
            }
        }
        last_changed?;
    }
    // Still relaxing after n rounds: walk back n times to land on the cycle, then collect it.
    let mut v = last_changed?;
    for _ in 0..n {
        v = edges[pred[v]?].0;
    }
    let start = v;
    let mut constraints = Vec::new();
    loop {
        let (u, _, _, index) = edges[pred[v]?];
        if let Some(i) = index {
            if !constraints.contains(&i) {
                constraints.push(i);
            }
        }
        v = u;
        if v == start {
            break;
        }
    }
    constraints.reverse();
    Some(constraints)
}

/// A sentence for each validation code.
fn describe(e: ValidationError) -> &'static str {
    use autonomy::ValidationCode::*;
    match e.code {
        Decode => "does not decode",
        TrailingBytes => "bytes after the end of the network",
        FormatVersion => "unknown uplink format version",
        TooManyTimelines
        | TooManyTasks
        | TooManyConstraints
        | TooManyImpacts
        | TooManyConditions
        | TooManyConditionTerms
        | TooManyContingencies
        | TooManyPermissions
        | TooManyTemporalConstraints
        | TooManyCommandArgs
        | TooManyTimedValues
        | TooManyParams
        | TooManyThresholds => "over the target's capacity",
        BadParam => {
            "a parameter's min and max must hold its prior; it is measured by a measured \
             cumulative timeline; a duration it sets is at least the task's min_duration and \
             at most 30 days; an impact it sets is an add, rate or assign on a cumulative \
             timeline"
        }
        TooManyStateValues => "a state timeline needs 1 to 32 values",
        NameTooLong => "name too long",
        DuplicateTaskId => "another task has this id",
        TaskIdReserved => "task ids must be below 0x8000 (higher ids are the planner's)",
        DuplicateTimelineName => "another timeline has this name",
        DanglingTimeline => "no such timeline",
        DanglingCondition => "no such condition",
        DanglingTemplate => "not a template task",
        DanglingTemporalTask => "temporal constraints relate two different tasks",
        TemporalTemplatePair => {
            "a temporal constraint binds a template to a requested task, never two templates"
        }
        TemporalCycle => "these temporal constraints form a cycle that no schedule can meet",
        BadInstanceArg => {
            "fixed and instance arguments together are at most 4, and served_arg_K names \
             argument 0 to 3"
        }
        DuplicateStateKey => "another timeline is measured by this state key",
        TypeMismatch => "does not fit the timeline's kind",
        ValueOutOfRange => "value outside the timeline's values or bounds",
        EmptyRequirement => "nothing can satisfy this requirement",
        ClaimNotMaintain => "a claim must be a maintain impact",
        MaintainAssign => "assignments happen at pre or post, not maintain",
        TermNotMeasured => "conditions can only read measured timelines (with a state_key)",
        BadContingency => "bad failure kind set",
        BadTimeWindow => "earliest_start is after latest_start",
        BadDuration => "duration must be positive, at least min_duration, at most 30 days",
        WindowTooShort => "the task cannot fit between earliest_start and latest_end",
        TimeOutOfRange => "time out of range",
        BadOffset => "offset out of range, or an empty maintain interval",
        BadPlannerConfig => "planner windows must be positive and commit <= scheduling <= horizon",
        BadTemporalBounds => "min must not exceed max",
        BadTimeout => "a task with a command needs a response_timeout (at most 30 days)",
        MalformedCondition => "malformed condition",
        ConditionTooDeep => "condition nested too deep",
        EmptyCondition => "empty condition",
        BadResponseBound => "a response bound is at most 15 per cause",
        BoundNotApplicable => {
            "a bound for a cause it cannot apply to (retries: response_timeout, command_failed, \
             command_rejected, post_condition, and only on a task with a command; repairs: any \
             cause but unschedulable)"
        }
        BadBackoff => {
            "retry_backoff must not exceed retry_backoff_max (at most 30 days), and is zero \
             only when the cap is zero"
        }
        RevertMeasuredTimeline => {
            "after_reset is for timelines without a state_key (the state buffer says what a \
             measured one is after a reset)"
        }
        RevertNotState => "only state timelines take an after_reset value",
        BadStaleBound => "a staleness bound must be positive and at most 30 days",
        StaleNotMeasured => {
            "stale_after is for timelines with a state_key (only measured values age)"
        }
        BadBackgroundRate => "only cumulative timelines take a background_rate (|rate| <= 2^48)",
        ExternalTimeline => {
            "an external timeline is state or cumulative and set only by its schedule and \
             measurements, never by a task's impact"
        }
        BadTimedValue => "schedule times must be in range and in order",
        BadThresholds => {
            "thresholds are for a measured state timeline: strictly increasing, one fewer \
             than its values"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FLYBY: &str = include_str!("../../scenarios/tasknets/flyby.toml");

    #[test]
    fn flyby_compiles_and_its_uplink_passes_the_target_validator() {
        let net = compile_str(FLYBY, "flyby.toml").unwrap();
        let (network, bytes) = (net.network, net.uplink);
        assert_eq!(network.tasks().len(), 6);
        assert_eq!(network.timelines().len(), 4);
        assert!(TaskNetwork::validate_uplink(&bytes).is_ok());
        let mut again = TaskNetwork::EMPTY;
        autonomy::uplink::decode_into(&mut again, &bytes).unwrap();
        assert_eq!(again, network);
    }

    #[test]
    fn task_times_use_the_shared_grammar_and_the_epoch() {
        let src = "[network]\nid = 1\nepoch = \"2028-040T00:00\"\n[[task]]\nid = 1\nname = \"a\"\nduration = \"15min\"\nearliest_start = \"2028-041T10:00\"\nlatest_start = \"1T10:00:30\"\n";
        let net = compile_str(src, "t.toml").unwrap();
        let t = &net.network.tasks()[0];
        assert_eq!(t.duration_us, 900_000_000);
        assert_eq!(t.earliest_start.0, (86_400 + 36_000) * 1_000_000);
        assert_eq!(t.latest_start.0, (86_400 + 36_030) * 1_000_000);
    }

    /// One truth for the flyby: the TOML the scenarios fly is exactly the network
    /// `autonomy::scenarios::flyby_spec()` builds for the autonomy core's own tests.
    #[test]
    fn flyby_toml_is_the_rust_flyby_network() {
        let net = compile_str(FLYBY, "flyby.toml").unwrap();
        let built = TaskNetwork::from_spec(autonomy::scenarios::flyby_spec().unwrap()).unwrap();
        assert_eq!(net.network, built);
        let mut buf = vec![0u8; 1 << 16];
        let len = built.encode(&mut buf).unwrap();
        assert_eq!(net.uplink, &buf[..len], "same uplink bytes");
        let att = net.timeline("GncAttitude").unwrap();
        assert_eq!(att.kind, TimelineKindName::State);
        assert_eq!(att.state_key, Some(StateKey(1)));
        assert_eq!(att.values[1], "NADIR");
        assert_eq!(net.task_id("Instrument Flyby"), Some(3));
    }

    #[test]
    fn two_tasks_with_one_name_are_refused_at_the_second() {
        let src = format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\n\n[[task]]\nid = 2\nname = \"t\"\nduration = \"1m\"\n"
        );
        let e = error_of(&src);
        assert_eq!(
            (e.line(), e.column(), e.field.as_str()),
            (17, 8, "task[1].name"),
            "{e}"
        );
        assert!(
            e.message.contains("task[0] has the name `t` already"),
            "{e}"
        );
    }

    const POINTING: &str = include_str!("../../scenarios/tasknets/orbiter-pointing.toml");

    #[test]
    fn format_5_fields_compile_into_the_spec_and_pass_the_target_validator() {
        let net = compile_str(POINTING, "orbiter-pointing.toml").unwrap();
        TaskNetwork::validate_uplink(&net.uplink).unwrap();
        let spec = net.network.spec();
        let point = spec.tasks.iter().find(|t| t.id == 10).unwrap();
        assert_eq!(
            point.command.as_ref().unwrap().from_instance.as_slice(),
            &[
                InstanceArg::Served(0),
                InstanceArg::Served(1),
                InstanceArg::EndS
            ]
        );
        // A temporal constraint from a requested task to a template.
        assert_eq!(spec.temporal.len(), 1);
        assert_eq!(
            (spec.temporal[0].from_task, spec.temporal[0].to_task),
            (1, 10)
        );
        // The parameter: its prior is the pass's duration, measured by PassLengthReport.
        let p = &spec.params[0];
        assert_eq!(
            (p.prior, p.min, p.max),
            (1_500_000_000, 600_000_000, 1_800_000_000)
        );
        assert_eq!(
            p.measured_by,
            net.network.timeline_by_name("PassLengthReport")
        );
        assert_eq!(p.uses.as_slice(), &[ParamUse::Duration { task: 2 }]);
        assert_eq!(spec.tasks[1].duration_us, 1_500_000_000);
    }

    #[test]
    fn format_5_mistakes_are_reported_at_their_field() {
        let bad_arg = POINTING.replace("\"served_arg_1\"", "\"served_arg_9\"");
        let e = compile_str(&bad_arg, "p.toml").unwrap_err();
        assert!(
            e.message
                .contains("unknown instance argument `served_arg_9`"),
            "{e}"
        );
        // A template related to itself: refused at the entry.
        let pair = POINTING.replace("from = \"Heat Transmitter\"", "from = \"Point At Earth\"");
        let e = compile_str(&pair, "p.toml").unwrap_err();
        assert!(e.field.starts_with("temporal[0]"), "{e}");
        // A parameter whose minimum is below the pass's minimum duration.
        let short = POINTING.replace("min_duration = \"10min\"", "min_duration = \"15min\"");
        let e = compile_str(&short, "p.toml").unwrap_err();
        assert_eq!(
            (e.field.as_str(), e.code),
            ("parameter[0]", Some(87)),
            "{e}"
        );
    }

    #[test]
    fn temporal_constraints_no_schedule_can_meet_are_refused_naming_the_cycle() {
        let tasks = "\n[[task]]\nid = 1\nname = \"a\"\nduration = \"1m\"\n\n[[task]]\nid = 2\nname = \"b\"\nduration = \"1m\"\n";
        // b starts at least 10 min after a ends, and a starts at least 10 min after b ends.
        let cycle = "\n[[temporal]]\nfrom = \"a\"\nfrom_point = \"end\"\nto = \"b\"\nto_point = \"start\"\nmin = \"10min\"\nmax = \"1h\"\n\n[[temporal]]\nfrom = \"b\"\nfrom_point = \"end\"\nto = \"a\"\nto_point = \"start\"\nmin = \"10min\"\nmax = \"1h\"\n";
        let e = error_of(&format!("{HEAD}{tasks}{cycle}"));
        assert!(e.field.starts_with("temporal["), "{e}");
        assert!(
            e.message.contains("temporal[0] -> temporal[1]")
                || e.message.contains("temporal[1] -> temporal[0]"),
            "{e}"
        );
        // The same pair with a consistent window (b within 10 min of a, a within 10 min after
        // b's start at the latest) is a cycle a schedule can meet: accepted.
        let fine = "\n[[temporal]]\nfrom = \"a\"\nfrom_point = \"end\"\nto = \"b\"\nto_point = \"start\"\nmin = \"0s\"\nmax = \"10min\"\n\n[[temporal]]\nfrom = \"b\"\nfrom_point = \"start\"\nto = \"a\"\nto_point = \"end\"\nmin = \"-10min\"\nmax = \"0s\"\n";
        compile_str(&format!("{HEAD}{tasks}{fine}"), "t.toml").unwrap();
    }

    #[test]
    fn an_unreadable_network_says_cannot_read_without_a_fake_position() {
        let e = compile_file(Path::new("/nonexistent/net.toml")).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("/nonexistent/net.toml: cannot read the file:"),
            "{e}"
        );
    }

    #[test]
    fn a_too_large_duration_says_too_long() {
        let e = error_of(&format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"999999999999h\"\n"
        ));
        assert!(e.message.contains("too long"), "{e}");
    }

    fn error_of(src: &str) -> TaskNetError {
        compile_str(src, "t.toml").unwrap_err()
    }

    const ORBITER: &str = include_str!("../../scenarios/tasknets/orbiter-downlink.toml");

    #[test]
    fn orbiter_pass_compiles_its_schedule_background_rate_and_thresholds_into_the_uplink() {
        let net = compile_str(ORBITER, "orbiter-downlink.toml").unwrap();
        let n = &net.network;
        let view = &n.timelines()[0];
        assert!(view.external);
        let hour = 3_600_000_000u64;
        let at = |h: u64, m: u64| MissionTimeUs(h * hour + m * 60_000_000);
        let timed: Vec<(u8, MissionTimeUs, i64)> = n
            .timed()
            .iter()
            .map(|t| (t.timeline, t.at, t.value))
            .collect();
        assert_eq!(
            timed,
            vec![
                (0, at(10, 20), 1),
                (0, at(10, 50), 0),
                (0, at(12, 0), 1),
                (0, at(12, 25), 0)
            ]
        );
        assert_eq!(n.timelines()[1].background_rate, -20);
        assert_eq!(n.timelines()[2].thresholds.as_slice(), &[2630]);
        // A derived state is measured as an integer: the symbol says so to the simulation.
        assert_eq!(net.symbols.timelines[2].kind, TimelineKindName::Cumulative);
        // Five constraints on a downlink (more than the 4 the format once held).
        assert_eq!(n.tasks()[1].constraints.len(), 5);
        let mut again = TaskNetwork::EMPTY;
        autonomy::uplink::decode_into(&mut again, &net.uplink).unwrap();
        assert_eq!(&again, n);
    }

    #[test]
    fn misused_schedule_thresholds_and_external_impacts_are_reported_where_written() {
        let ext = "[network]\nid = 1\n\n[[timeline]]\nname = \"View\"\nkind = \"state\"\nvalues = [\"NO\", \"YES\"]\n";
        let e = error_of(&format!(
            "{ext}schedule = [ {{ at = \"10:00\", value = \"YES\" }} ]\n"
        ));
        assert_eq!(e.field, "timeline[0].schedule", "{e}");
        let e = error_of(&format!(
            "{ext}external = true\nschedule = [ {{ at = \"10:00\", value = \"MAYBE\" }} ]\n"
        ));
        assert_eq!(e.field, "timeline[0].schedule[0].value", "{e}");
        let e = error_of(&format!(
            "{ext}external = true\nschedule = [ {{ at = \"10:00\", value = \"YES\" }}, {{ at = \"09:00\", value = \"NO\" }} ]\n"
        ));
        assert_eq!(e.field, "timeline[0].schedule[1]", "{e}");
        assert!(e.message.contains("in order"), "{e}");
        let e = error_of(&format!(
            "{ext}external = true\n\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\nearliest_start = \"10:00\"\nimpacts = [ {{ when = \"post\", timeline = \"View\", assign = \"YES\" }} ]\n"
        ));
        assert_eq!(e.field, "task[0].impacts[0]", "{e}");
        assert!(e.message.contains("external"), "{e}");
        let e = error_of(&format!("{ext}thresholds = [10]\n"));
        assert_eq!(e.field, "timeline[0].thresholds", "{e}");
        let e = error_of(&format!("{ext}background_rate = -3\n"));
        assert_eq!(e.field, "timeline[0]", "{e}");
        assert!(e.message.contains("background_rate"), "{e}");
    }

    const HEAD: &str = "[network]\nid = 1\n\n[[timeline]]\nname = \"Att\"\nkind = \"state\"\nvalues = [\"A\", \"B\"]\nstate_key = 1\n";

    #[test]
    fn unknown_timeline_is_reported_at_its_constraint() {
        let src = format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\nearliest_start = \"10:00\"\nconstraints = [\n  {{ when = \"pre\", timeline = \"Nope\", in = [\"A\"] }},\n]\n"
        );
        let e = error_of(&src);
        assert_eq!((e.line(), e.column()), (16, 3), "{e}");
        assert_eq!(e.field, "task[0].constraints[0]");
        assert!(
            e.to_string()
                .starts_with("t.toml:16:3: task[0].constraints[0]: no timeline named `Nope`"),
            "{e}"
        );
    }

    #[test]
    fn validator_errors_carry_the_target_code_and_the_line() {
        // earliest after latest start: the target's BadTimeWindow (50).
        let src = format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\nearliest_start = \"10:00\"\nlatest_start = \"09:00\"\n"
        );
        let e = error_of(&src);
        assert_eq!(e.code, Some(50));
        assert_eq!(e.line(), 14, "{e}");
        assert_eq!(e.field, "task[0].earliest_start");
        // A claim impact on a state timeline: TypeMismatch (40) at the impact.
        let src = format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\nimpacts = [{{ when = \"maintain\", timeline = \"Att\", claim = true }}]\n"
        );
        let e = error_of(&src);
        assert_eq!((e.code, e.line(), e.column()), (Some(40), 14, 12), "{e}");
        // Reserved task id (31).
        let src = format!("{HEAD}\n[[task]]\nid = 40000\nname = \"t\"\nduration = \"1m\"\n");
        let e = error_of(&src);
        assert_eq!(
            (e.code, e.line(), e.field.as_str()),
            (Some(31), 11, "task[0].id"),
            "{e}"
        );
    }

    #[test]
    fn toml_syntax_and_type_errors_have_positions() {
        let e = error_of("[network]\nid = \"x\"\n");
        assert_eq!(e.line(), 2, "{e}");
        let e = error_of(&format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"soon\"\n"
        ));
        assert_eq!(
            (e.line(), e.column(), e.field.as_str()),
            (13, 12, "task[0].duration"),
            "{e}"
        );
        assert!(e.message.contains("not a duration"));
    }

    #[test]
    fn bad_state_value_names_the_choices() {
        let src = format!(
            "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\nimpacts = [{{ when = \"post\", timeline = \"Att\", assign = \"C\" }}]\n"
        );
        let e = error_of(&src);
        assert!(
            e.message
                .contains("`C` is not one of the timeline's values [\"A\", \"B\"]"),
            "{e}"
        );
    }

    #[test]
    fn condition_depth_is_checked_by_the_target_validator() {
        let term = "{ timeline = \"Att\", op = \"==\", value = \"A\" }";
        let deep = format!("{{ not = {{ not = {{ not = {{ not = {term} }} }} }} }}");
        let src = format!("{HEAD}\n[[condition]]\nname = \"c\"\nexpr = {deep}\n");
        let e = error_of(&src);
        assert_eq!((e.code, e.line()), (Some(61), 12), "{e}");
    }
    /// Compiles `src` and returns the error, checking it names `field` at `line` with `code`.
    fn refused(src: &str, line: usize, field: &str, code: Option<u16>) -> TaskNetError {
        let e = error_of(src);
        assert_eq!(
            (e.line(), e.field.as_str(), e.code),
            (line, field, code),
            "{e}"
        );
        assert!(e.to_string().starts_with(&format!("t.toml:{line}:")), "{e}");
        e
    }

    const TASK: &str = "\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\ncommand = { opcode = 1 }\nresponse_timeout = \"1m\"\n";

    #[test]
    fn response_bounds_compile_network_wide_and_per_task() {
        let src = format!(
            "[network]\nid = 1\nmax_retries = 1\nmax_repairs = {{ any = 3, command_rejected = 0 }}\nretry_backoff = \"5s\"\nretry_backoff_max = \"1m\"\n{TASK}max_retries = {{ command_failed = 2 }}\nmax_repairs = 4\nretry_backoff = \"30s\"\ncontingencies = [ {{ on = [\"interrupted\", \"post_condition\"], action = \"restart\" }} ]\n"
        );
        let net = compile_str(&src, "t.toml").unwrap_or_else(|e| panic!("{e}"));
        let (network, bytes) = (net.network, net.uplink);
        assert!(TaskNetwork::validate_uplink(&bytes).is_ok());
        let r = network.responses();
        assert_eq!(r.max_retries, PerCause::uniform(1, FailureKind::RETRYABLE));
        let mut repairs = PerCause::uniform(3, FailureKind::REPAIRABLE);
        repairs.set(FailureKind::CommandRejected, 0);
        assert_eq!(r.max_repairs, repairs);
        assert_eq!(
            r.backoff,
            Backoff {
                initial_us: 5_000_000,
                max_us: 60_000_000
            }
        );
        let control = &network.tasks()[0].control;
        // A table sets the causes it names on top of the network's values.
        let mut retries = PerCause::uniform(1, FailureKind::RETRYABLE);
        retries.set(FailureKind::CommandFailed, 2);
        assert_eq!(control.max_retries, Some(retries));
        assert_eq!(
            control.max_repairs,
            Some(PerCause::uniform(4, FailureKind::REPAIRABLE))
        );
        // The cap not given is the network's.
        assert_eq!(
            control.backoff,
            Some(Backoff {
                initial_us: 30_000_000,
                max_us: 60_000_000
            })
        );
        assert_eq!(
            network.tasks()[0].contingencies[0].on,
            FailureKind::Interrupted.bit() | FailureKind::PostConditionNotMet.bit()
        );
        // Absent everywhere: the built-in defaults.
        let plain = compile_str(&format!("[network]\nid = 1\n{TASK}"), "t.toml")
            .unwrap()
            .network;
        assert_eq!(plain.responses(), &ResponsePolicy::DEFAULT);
        assert_eq!(plain.tasks()[0].control.max_retries, None);
        assert_eq!(plain.tasks()[0].control.backoff, None);
    }

    #[test]
    fn bad_response_bounds_are_reported_at_their_field_with_the_target_code() {
        // Line numbers: HEAD is 8 lines, TASK starts with a blank line 9, [[task]] on 10,
        // response_timeout on 15; the field under test is on line 16.
        refused(
            &format!("{HEAD}{TASK}max_repairs = 16\n"),
            16,
            "task[0].max_repairs",
            Some(70),
        );
        refused(
            &format!("{HEAD}{TASK}max_retries = {{ maintain_violation = 1 }}\n"),
            16,
            "task[0].max_retries",
            Some(71),
        );
        refused(
            &format!(
                "{HEAD}\n[[task]]\nid = 1\nname = \"t\"\nduration = \"1m\"\nmax_retries = 1\n"
            ),
            14,
            "task[0].max_retries",
            Some(71),
        );
        refused(
            &format!("{HEAD}{TASK}retry_backoff = \"1m\"\nretry_backoff_max = \"10s\"\n"),
            16,
            "task[0].retry_backoff",
            Some(72),
        );
        refused(
            "[network]\nid = 1\nretry_backoff = \"0s\"\n",
            3,
            "network.retry_backoff",
            Some(72),
        );
        refused(
            "[network]\nid = 1\nmax_retries = { unschedulable = 2 }\n",
            3,
            "network.max_retries",
            Some(71),
        );
        // Mistakes the compiler catches itself (no target code), also at the field.
        let e = refused(
            &format!("{HEAD}{TASK}max_repairs = {{ rejected = 1 }}\n"),
            16,
            "task[0].max_repairs",
            None,
        );
        assert!(
            e.message.contains("unknown failure cause `rejected`"),
            "{e}"
        );
        assert!(e.message.contains("command_rejected"), "{e}");
        let e = refused(
            &format!("{HEAD}{TASK}max_repairs = -1\n"),
            16,
            "task[0].max_repairs",
            None,
        );
        assert!(e.message.contains("not a bound"), "{e}");
    }

    #[test]
    fn after_reset_compiles_and_is_checked() {
        let heater =
            "\n[[timeline]]\nname = \"Heater\"\nkind = \"state\"\nvalues = [\"OFF\", \"ON\"]\n";
        let network = compile_str(&format!("{HEAD}{heater}after_reset = \"OFF\"\n"), "t.toml")
            .unwrap_or_else(|e| panic!("{e}"))
            .network;
        assert_eq!(network.timelines()[1].after_reset, Some(0));
        assert_eq!(network.timelines()[0].after_reset, None);
        // On a measured timeline (73), at the value.
        let e = refused(
            &HEAD.replace("state_key = 1\n", "state_key = 1\nafter_reset = \"A\"\n"),
            9,
            "timeline[0].after_reset",
            Some(73),
        );
        assert_eq!(e.column(), 15, "{e}");
        // On a claimable timeline (74).
        refused(
            &format!(
                "{HEAD}\n[[timeline]]\nname = \"Slew\"\nkind = \"claimable\"\nafter_reset = 0\n"
            ),
            13,
            "timeline[1].after_reset",
            Some(74),
        );
        // A value the timeline does not have.
        let e = refused(
            &format!("{HEAD}{heater}after_reset = \"WARM\"\n"),
            14,
            "timeline[1].after_reset",
            None,
        );
        assert!(e.message.contains("[\"OFF\", \"ON\"]"), "{e}");
    }

    #[test]
    fn stale_after_compiles_per_timeline_and_network_wide() {
        let heater =
            "\n[[timeline]]\nname = \"Heater\"\nkind = \"state\"\nvalues = [\"OFF\", \"ON\"]\n";
        let own = HEAD.replace(
            "state_key = 1\n",
            "state_key = 1\nstale_after = \"10min\"\n",
        );
        let net =
            compile_str(&format!("{own}{heater}"), "t.toml").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(net.network.timelines()[0].stale_after_us, Some(600_000_000));
        assert_eq!(net.network.timelines()[1].stale_after_us, None);
        assert_eq!(net.symbols.timelines[0].stale_after_us, Some(600_000_000));
        // The uplink carries it.
        let mut decoded = TaskNetwork::EMPTY;
        autonomy::uplink::decode_into(&mut decoded, &net.uplink).unwrap();
        assert_eq!(decoded.timelines()[0].stale_after_us, Some(600_000_000));

        // A network-wide default: every measured timeline without its own takes it; the
        // unmeasured one does not; a timeline's own bound (or "never") wins.
        let with_default = |head: &str| {
            compile_str(
                &format!(
                    "{}{heater}\n[[timeline]]\nname = \"Temp\"\nkind = \"cumulative\"\nmin = 0\nmax = 100\nstate_key = 2\n",
                    head.replace("id = 1\n", "id = 1\nstale_after = \"15min\"\n")
                ),
                "t.toml",
            )
            .unwrap_or_else(|e| panic!("{e}"))
            .network
        };
        let n = with_default(HEAD);
        let bounds: Vec<Option<u64>> = n.timelines().iter().map(|t| t.stale_after_us).collect();
        assert_eq!(bounds, [Some(900_000_000), None, Some(900_000_000)]);
        let n = with_default(&own);
        assert_eq!(n.timelines()[0].stale_after_us, Some(600_000_000));
        let never = HEAD.replace(
            "state_key = 1\n",
            "state_key = 1\nstale_after = \"never\"\n",
        );
        let n = with_default(&never);
        assert_eq!(n.timelines()[0].stale_after_us, None);
        assert_eq!(n.timelines()[2].stale_after_us, Some(900_000_000));

        // Absent everywhere: no bound (the shipped flyby has none).
        let flyby = compile_str(FLYBY, "flyby.toml").unwrap().network;
        assert!(flyby.timelines().iter().all(|t| t.stale_after_us.is_none()));
    }

    #[test]
    fn bad_stale_after_is_reported_at_its_field_with_the_target_code() {
        let own = |v: &str| {
            HEAD.replace(
                "state_key = 1\n",
                &format!("state_key = 1\nstale_after = {v}\n"),
            )
        };
        // Zero and over 30 days: BadStaleBound (75), at the value.
        for v in ["\"0s\"", "0", "\"721h\""] {
            let e = refused(&own(v), 9, "timeline[0].stale_after", Some(75));
            assert_eq!(e.column(), 15, "{e}");
            assert!(e.message.contains("positive and at most 30 days"), "{e}");
        }
        // Exactly 30 days is accepted.
        compile_str(&own("\"720h\""), "t.toml").unwrap_or_else(|e| panic!("{e}"));
        // On a timeline without a state key: StaleNotMeasured (76).
        let e = refused(
            &format!("{HEAD}\n[[timeline]]\nname = \"Slew\"\nkind = \"claimable\"\nstale_after = \"1min\"\n"),
            13,
            "timeline[1].stale_after",
            Some(76),
        );
        assert!(e.message.contains("state_key"), "{e}");
        // A bad network-wide default is refused at it, with the same code, even when no
        // timeline would take it.
        refused(
            "[network]\nid = 1\nstale_after = \"0s\"\n",
            3,
            "network.stale_after",
            Some(75),
        );
        refused(
            &HEAD.replace("id = 1\n", "id = 1\nstale_after = \"31d\"\n"),
            3,
            "network.stale_after",
            Some(75),
        );
        // Mistakes the compiler catches itself (no target code).
        let e = refused(&own("\"-5min\""), 9, "timeline[0].stale_after", None);
        assert!(e.message.contains("positive duration"), "{e}");
        let e = refused(&own("\"soon\""), 9, "timeline[0].stale_after", None);
        assert!(e.message.contains("not a duration"), "{e}");
    }
}
