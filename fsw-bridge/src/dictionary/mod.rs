//! The telemetry dictionary: every metric id and every telemetry event the firmware sends, with
//! its name, unit, kind (a measurement on the guest clock or an exactly reproducible value),
//! who sends it, the virtual channel it travels on, and (for events) its severity.
//!
//! The firmware takes its metric ids from here (`kernel_config::abi::metric` re-exports
//! [`platform`], `flight_app::metric` re-exports [`app`]), and the host looks meaning up here
//! ([`metric`], [`event`]) instead of re-deriving it from id ranges or name suffixes. The wire
//! ids are fixed: transcripts, `budgets.toml` and tests depend on them. A new metric is one
//! entry in one of the two tables below; the tests check that ids and names are unique, that
//! families do not overlap, and that every measured cost travels on the Instrument channel.
use crate::link::VirtualChannel;
use crate::messages::TelemetryEvent;

/// What a metric's value counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Timebase ticks of guest CPU (16.6 MHz on g3beige).
    Ticks,
    /// Thousandths of a timebase tick (an average).
    MilliTicks,
    /// Two tick counts in one value: the first << 32 | the second.
    TickPair,
    /// Guest instructions.
    Instructions,
    /// Mission time in microseconds.
    Micros,
    /// Things that happened (frames, switches, refusals, ...).
    Count,
    /// Bytes.
    Bytes,
    /// An offset << 32 | a length in bytes.
    OffsetLength,
    /// A bit mask.
    Mask,
    /// One of a small set of codes: the entry's `values` name them.
    Code,
    /// A sequence number.
    Sequence,
    /// A CRC-32.
    Checksum,
    /// A state key.
    StateKey,
}

impl Unit {
    /// The unit's name in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Unit::Ticks => "ticks",
            Unit::MilliTicks => "milliticks",
            Unit::TickPair => "ticks<<32|ticks",
            Unit::Instructions => "instructions",
            Unit::Micros => "µs",
            Unit::Count => "count",
            Unit::Bytes => "bytes",
            Unit::OffsetLength => "offset<<32|bytes",
            Unit::Mask => "mask",
            Unit::Code => "code",
            Unit::Sequence => "sequence",
            Unit::Checksum => "crc32",
            Unit::StateKey => "state key",
        }
    }
}

/// Whether a metric's value is reproducible to the bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A measurement on the guest's timebase (a CPU cost, a jitter): only a target with a CPU
    /// clock reports it, and a span can come out one tick longer or shorter depending on where
    /// between two ticks it started, so transcript hashes leave it out.
    MeasuredCost,
    /// A value (a count, a code, a mask): the same on every run of the same scenario.
    Value,
}

/// Who sends a metric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Sender {
    /// The partitioning kernel (its event queue, drained by the I/O partition).
    Kernel,
    /// The I/O partition (the link owner).
    Io,
    /// The executive partition's own code around the flight application.
    Executive,
    /// The planner partition.
    Planner,
    /// The test image's rogue partition.
    Rogue,
    /// The flight application (`flight_app`), on every target, native included.
    FlightApp,
}

/// How serious a telemetry event is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// A measurement or a count: nothing to look at unless a budget says so.
    Debug,
    /// The autonomy doing its work (a task transition, a plan change).
    Info,
    /// Something degraded that the autonomy copes with (a stale measurement).
    Warning,
    /// A fault the kernel's health monitor handled.
    Error,
}

impl Severity {
    pub const fn name(self) -> &'static str {
        match self {
            Severity::Debug => "debug",
            Severity::Info => "info",
            Severity::Warning => "warning",
            Severity::Error => "error",
        }
    }
}

/// One metric (or a family of `instances` consecutive ids: per partition, per reason).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Metric {
    /// The first wire id.
    pub id: u16,
    /// How many consecutive ids the entry covers (1 for a single metric).
    pub instances: u16,
    /// The constant's name in the firmware (`STEP_TICKS`).
    pub constant: &'static str,
    /// The name reports use (snake case; the host derives its report names from it).
    pub name: &'static str,
    pub unit: Unit,
    pub kind: Kind,
    pub sender: Sender,
    /// The reliable link's virtual channel it travels on.
    pub channel: VirtualChannel,
    /// The names of the values of a [`Unit::Code`] metric.
    pub values: &'static [(u64, &'static str)],
    /// What it measures (the constant's documentation).
    pub meaning: &'static str,
}

impl Metric {
    /// True if `id` is one of this entry's ids.
    pub const fn covers(&self, id: u16) -> bool {
        id >= self.id && id - self.id < self.instances
    }

    /// The name of `value` of a [`Unit::Code`] metric.
    pub fn value_name(&self, value: u64) -> Option<&'static str> {
        self.values
            .iter()
            .find(|(v, _)| *v == value)
            .map(|(_, name)| *name)
    }

    /// A measurement on the guest clock (see [`Kind::MeasuredCost`]).
    pub const fn is_measured_cost(&self) -> bool {
        matches!(self.kind, Kind::MeasuredCost)
    }
}

/// One kind of telemetry event (a [`TelemetryEvent`] variant; the id is its postcard index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    pub id: u8,
    pub name: &'static str,
    pub severity: Severity,
    /// The virtual channel it travels on ([`TelemetryEvent::Metric`]: the metric's).
    pub channel: VirtualChannel,
    pub meaning: &'static str,
}

macro_rules! metric_table {
    (
        $table:ident;
        $(
            $(#[doc = $doc:literal])*
            $konst:ident = $id:literal $(* $instances:expr)?,
            $name:literal, $unit:ident, $kind:ident, $sender:ident, $channel:ident
            $(, values $values:expr)?;
        )*
    ) => {
        $(
            $(#[doc = $doc])*
            pub const $konst: u16 = $id;
        )*
        /// Every entry of this table, in id order.
        pub const $table: &[super::Metric] = &[
            $(
                super::Metric {
                    id: $konst,
                    instances: metric_table!(@instances $($instances)?),
                    constant: stringify!($konst),
                    name: $name,
                    unit: super::Unit::$unit,
                    kind: super::Kind::$kind,
                    sender: super::Sender::$sender,
                    channel: crate::link::VirtualChannel::$channel,
                    values: metric_table!(@values $($values)?),
                    meaning: concat!($($doc, "\n"),*),
                },
            )*
        ];
    };
    (@instances) => { 1 };
    (@instances $n:expr) => { $n };
    (@values) => { &[] };
    (@values $v:expr) => { $v };
}

/// Ids a per-partition family spans (the kernel supports fewer partitions than this).
pub const PARTITION_IDS: u16 = 16;

/// `platform::BOOT_IMAGE` values: how the reset stub made the RAM image good.
pub mod boot_image {
    /// After a warm reset: the RAM copy matched its image record's checksum; not copied.
    pub const VERIFIED: u64 = 1;
    /// Copied from ROM: no valid image record for this ROM (power-on, new firmware, a damaged
    /// record).
    pub const COPIED: u64 = 2;
    /// Copied from ROM because the RAM copy failed its checksum (damaged since the last copy).
    pub const REPAIRED: u64 = 3;
}

/// `platform::ARMED_RESET_POINT` values: where an armed reset landed.
pub mod armed_reset_point {
    /// The count ran out while the partition ran its own code (or in a system call other than
    /// a warm-area write, the reset then following that call).
    pub const IN_CODE: u64 = 1;
    /// Inside a warm-area write: part of its bytes copied (`ARMED_RESET_WARM_COPIED`).
    pub const IN_WARM_WRITE: u64 = 2;
    /// The partition finished first (gave up its window); the reset followed at once.
    pub const AFTER_WORK: u64 = 3;
    /// The health monitor stopped or restarted the partition first; the reset followed.
    pub const PARTITION_STOPPED: u64 = 4;
}

/// `app::RESTORED_FROM` values: where the checkpoint restored at boot came from.
pub mod restored_from {
    pub const WARM: u64 = 1;
    pub const NV: u64 = 2;
}

pub mod app;
pub mod platform;

/// Both tables.
pub const TABLES: [&[Metric]; 2] = [platform::PLATFORM_METRICS, app::APP_METRICS];

/// Every metric entry, the platform's first.
pub fn metrics() -> impl Iterator<Item = &'static Metric> {
    TABLES.into_iter().flatten()
}

/// The entry covering metric id `id`.
pub fn metric(id: u16) -> Option<&'static Metric> {
    let table = if id < 0x1000 {
        platform::PLATFORM_METRICS
    } else {
        app::APP_METRICS
    };
    table.iter().find(|m| m.covers(id))
}

/// The entry named `name`.
pub fn metric_named(name: &str) -> Option<&'static Metric> {
    metrics().find(|m| m.name == name)
}

/// What the link needs of a metric entry: its ids and its channel. The firmware routes by
/// these compact tables, made from the dictionary at compile time, so that the names and
/// meanings (kilobytes of text the reset stub would check at every warm boot) stay out of the
/// image; only the host reads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Route {
    id: u16,
    instances: u16,
    channel: VirtualChannel,
}

const fn routes<const N: usize>(table: &[Metric]) -> [Route; N] {
    let mut out = [Route {
        id: 0,
        instances: 0,
        channel: VirtualChannel::Instrument,
    }; N];
    let mut i = 0;
    while i < N {
        out[i] = Route {
            id: table[i].id,
            instances: table[i].instances,
            channel: table[i].channel,
        };
        i += 1;
    }
    out
}

const PLATFORM_ROUTES: [Route; platform::PLATFORM_METRICS.len()] =
    routes(platform::PLATFORM_METRICS);
const APP_ROUTES: [Route; app::APP_METRICS.len()] = routes(app::APP_METRICS);

/// The virtual channel metric `id` travels on. An id the dictionary does not know goes on the
/// Instrument channel: only the Mission channel must be identical on every target.
pub fn metric_channel(id: u16) -> VirtualChannel {
    let routes: &[Route] = if id < 0x1000 {
        &PLATFORM_ROUTES
    } else {
        &APP_ROUTES
    };
    routes
        .iter()
        .find(|r| id >= r.id && id - r.id < r.instances)
        .map_or(VirtualChannel::Instrument, |r| r.channel)
}

/// A metric whose value is a measurement on the guest clock (left out of transcript hashes).
/// An unknown id counts as one (it is instrumentation, see [`metric_channel`]).
pub fn is_measured_cost(id: u16) -> bool {
    metric(id).is_none_or(|m| m.is_measured_cost())
}

/// Every telemetry event kind, by [`TelemetryEvent`] variant index.
pub const EVENTS: [Event; 5] = [
    Event {
        id: 0,
        name: "task_transition",
        severity: Severity::Info,
        channel: VirtualChannel::Mission,
        meaning: "a task of the executive changed state",
    },
    Event {
        id: 1,
        name: "plan_modification",
        severity: Severity::Info,
        channel: VirtualChannel::Mission,
        meaning: "the planner modified the plan",
    },
    Event {
        id: 2,
        name: "health_monitor",
        severity: Severity::Error,
        channel: VirtualChannel::Instrument,
        meaning: "the kernel's health monitor handled an error in a partition",
    },
    Event {
        id: 3,
        name: "metric",
        severity: Severity::Debug,
        channel: VirtualChannel::Instrument,
        meaning: "a named measurement: see the metric tables for its id",
    },
    Event {
        id: 4,
        name: "state_stale",
        severity: Severity::Warning,
        channel: VirtualChannel::Mission,
        meaning: "a state-buffer value older than its timeline's staleness bound, read as unknown",
    },
];

/// The index in [`EVENTS`] of `event`'s kind (its variant index).
const fn event_index(event: &TelemetryEvent) -> usize {
    match event {
        TelemetryEvent::TaskTransition { .. } => 0,
        TelemetryEvent::PlanModification { .. } => 1,
        TelemetryEvent::HealthMonitor { .. } => 2,
        TelemetryEvent::Metric { .. } => 3,
        TelemetryEvent::StateStale { .. } => 4,
    }
}

/// The dictionary entry of `event`'s kind.
pub const fn event(event: &TelemetryEvent) -> &'static Event {
    &EVENTS[event_index(event)]
}

/// The channel of each event kind, by id (from [`EVENTS`] at compile time: no names linked).
const EVENT_CHANNELS: [VirtualChannel; EVENTS.len()] = {
    let mut out = [VirtualChannel::Instrument; EVENTS.len()];
    let mut i = 0;
    while i < EVENTS.len() {
        out[i] = EVENTS[i].channel;
        i += 1;
    }
    out
};

/// The virtual channel `event` travels on (a metric: its entry's).
pub fn event_channel(ev: &TelemetryEvent) -> VirtualChannel {
    match ev {
        TelemetryEvent::Metric { id, .. } => metric_channel(*id),
        other => EVENT_CHANNELS
            .get(event_index(other))
            .copied()
            .unwrap_or(VirtualChannel::Instrument),
    }
}

#[cfg(test)]
mod tests;
