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

/// The kernel's metrics and the partitions' instrumentation (ids below 0x1000): only the
/// emulated target sends them, all on the Instrument channel. Per-partition ids add the
/// partition index to the first id.
pub mod platform {
    use super::{armed_reset_point, boot_image, PARTITION_IDS};

    metric_table! {
        PLATFORM_METRICS;
        /// Ticks partition p used in the last complete major frame.
        FRAME_TICKS = 0x0100 * PARTITION_IDS,
            "frame_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// Most ticks partition p used in any one major frame since boot.
        WORST_FRAME_TICKS = 0x0110 * PARTITION_IDS,
            "worst_frame_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// Windows in which partition p was still running at the end (preempted).
        OVERRUNS = 0x0120 * PARTITION_IDS,
            "overruns", Count, Value, Kernel, Instrument;
        /// Largest start jitter of p's windows (actual switch-in minus scheduled start), ticks.
        MAX_JITTER = 0x0130 * PARTITION_IDS,
            "max_jitter_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// Generation of p (number of restarts).
        GENERATION = 0x0140 * PARTITION_IDS,
            "generation", Count, Value, Kernel, Instrument;
        /// The number of the major frame the per-partition figures sent with it belong to.
        FRAME_NUMBER = 0x0200,
            "frame_number", Count, Value, Kernel, Instrument;
        /// Largest window-start jitter over all partitions since boot, ticks.
        MAX_JITTER_ALL = 0x0201,
            "max_jitter_all_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// Kernel time per partition switch (timer interrupt entry to return), averaged over
        /// all switches since boot, in thousandths of a tick.
        SWITCH_MILLITICKS = 0x0202,
            "switch_mean_milliticks", MilliTicks, MeasuredCost, Kernel, Instrument;
        /// Number of partition switches since boot.
        SWITCHES = 0x0203,
            "switches", Count, Value, Kernel, Instrument;
        /// Largest kernel time of one switch, ticks.
        SWITCH_MAX_TICKS = 0x0204,
            "switch_max_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// Kernel events dropped because the queue was full.
        EVENTS_DROPPED = 0x0210,
            "kernel_events_dropped", Count, Value, Kernel, Instrument;
        /// Log bytes dropped because the kernel log buffer was full.
        LOG_BYTES_DROPPED = 0x0211,
            "log_bytes_dropped", Bytes, Value, Kernel, Instrument;
        /// Bytes the kernel received on the link since boot (in every kernel report).
        LINK_RX_BYTES = 0x0212,
            "link_rx_bytes", Bytes, Value, Kernel, Instrument;
        /// Bytes the link's receiver lost since boot (UART overruns; QEMU's ESCC holds bytes
        /// back instead, so on the emulated target this stays 0).
        LINK_RX_LOST = 0x0213,
            "link_rx_lost_bytes", Bytes, Value, Kernel, Instrument;
        /// Times the kernel's receive ring was full and the kernel left bytes in the UART until
        /// the I/O partition read (flow control, nothing lost).
        LINK_RX_RING_FULL = 0x0214,
            "link_rx_ring_full", Count, Value, Kernel, Instrument;
        /// Times the module stopped its schedule to wait for input (SYS_WAIT_FOR_INPUT parked).
        PARKS = 0x0215,
            "parks", Count, Value, Kernel, Instrument;
        /// The link's transport: 0 the serial line, 1 shared memory (the emulated target with
        /// the link device).
        LINK_TRANSPORT = 0x0216,
            "link_transport", Code, Value, Kernel, Instrument,
            values &[(0, "serial line"), (1, "shared memory")];
        /// Shared-memory rings whose counts made no sense, dropped (the host wrote garbage).
        LINK_RING_ERRORS = 0x0217,
            "link_ring_errors", Count, Value, Kernel, Instrument;
        /// Messages for the host's Instrument channel (costs, kernel events, logs) the I/O
        /// partition dropped since boot because that channel's send queue and its holding
        /// queue were full (a link too noisy for the instrumentation), or because the link was
        /// lost. Sent by the I/O partition, on the Instrument channel, after a drop, once it
        /// has room.
        LINK_INSTRUMENT_DROPPED = 0x0218,
            "instrument_messages_dropped", Count, Value, Io, Instrument;
        /// Queuing-port messages the kernel dropped on receive since boot because their
        /// sender had restarted since it sent them (an older generation:
        /// `kernel_logic::port_queue`). In every kernel report, before EVENTS_DROPPED.
        PORT_STALE_DROPPED = 0x0219,
            "port_stale_messages_dropped", Count, Value, Kernel, Instrument;
        /// An armed reset (SYS_RESET_MODULE with a point) is about to happen: where it landed,
        /// one of [`armed_reset_point`]. Sent straight to the host with the next ones, before
        /// the Hello.
        ARMED_RESET_POINT = 0x0220,
            "armed_reset_point", Code, Value, Kernel, Instrument,
            values &[
                (armed_reset_point::IN_CODE, "in code"),
                (armed_reset_point::IN_WARM_WRITE, "in warm write"),
                (armed_reset_point::AFTER_WORK, "after work"),
                (armed_reset_point::PARTITION_STOPPED, "partition stopped"),
            ];
        /// Ticks the partition ran from its receipt of the anchor message to the reset
        /// (measured with the decrementer, so the same on every run).
        ARMED_RESET_TICKS = 0x0221,
            "armed_reset_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// The partition's last warm-area write since the anchor: offset in the checkpoint part
        /// << 32 | length in bytes. Sent only if there was one.
        ARMED_RESET_WARM_WRITE = 0x0222,
            "armed_reset_warm_write", OffsetLength, Value, Kernel, Instrument;
        /// Bytes of that write copied before the reset (its whole length unless it was torn).
        ARMED_RESET_WARM_COPIED = 0x0223,
            "armed_reset_warm_copied", Bytes, Value, Kernel, Instrument;
        /// When that write ran: ticks since the anchor at its start << 32 | at its end (or
        /// tear).
        ARMED_RESET_WARM_WRITE_TICKS = 0x0224,
            "armed_reset_warm_write_ticks", TickPair, MeasuredCost, Kernel, Instrument;
        /// CRC-32 of the planner's search table (sent by the planner on request).
        PLANNER_CHECKSUM = 0x0300,
            "planner_checksum", Checksum, Value, Planner, Instrument;
        /// State updates the executive received since its (re)start.
        EXECUTIVE_STATE_UPDATES = 0x0301,
            "executive_state_updates", Count, Value, Executive, Instrument;
        /// Ticks for SYSCALL_BENCH_CALLS null system calls (sent by the executive on request).
        SYSCALL_BENCH_TICKS = 0x0302,
            "syscall_bench_ticks", Ticks, MeasuredCost, Executive, Instrument;
        /// Planner iterations since its (re)start.
        PLANNER_ITERATIONS = 0x0303,
            "planner_iterations", Count, Value, Planner, Instrument;
        /// Generation of the planner seen by the planner itself when it reports its checksum.
        PLANNER_GENERATION = 0x0304,
            "planner_generation", Count, Value, Planner, Instrument;
        /// Test image: the rogue partition's probe, sent through `rogue_to_io` (value: the
        /// rogue's generation when it sent it); the stale-message test watches for it.
        ROGUE_PROBE = 0x03f0,
            "rogue_probe", Count, Value, Rogue, Instrument;
        /// Boot to ready, sent by the executive once per boot when the flight application has
        /// restored its checkpoint (or found none) and can take its first grant: the kernel's
        /// boot (reset vector to the start of the schedule, SYS_UPTIME's r5) plus the CPU the
        /// executive partition used from its start to that point. Ticks of CPU on the way to
        /// ready, the same every boot from the same memory contents; the schedule's latency
        /// (the lead time, the other partitions' windows before and between the executive's)
        /// is not in it.
        BOOT_TO_READY_TICKS = 0x0310,
            "boot_to_ready_ticks", Ticks, MeasuredCost, Executive, Instrument;
        /// The kernel's part of BOOT_TO_READY_TICKS (reset vector to the start of the
        /// schedule), sent just before it.
        KERNEL_BOOT_TICKS = 0x0311,
            "kernel_boot_ticks", Ticks, MeasuredCost, Executive, Instrument;
        /// The boot breakdown, sent by the kernel at the start of the schedule (the parts of
        /// KERNEL_BOOT_TICKS) and by the executive with BOOT_TO_READY_TICKS (the parts of its
        /// own), all in ticks of CPU. The reset stub's image step: reset vector to the RAM
        /// image checked (or copied from ROM) and `.kshared` and the kernel data reloaded.
        BOOT_STUB_IMAGE_TICKS = 0x0312,
            "boot_image_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// The reset stub's clearing of `.bss` and the hashed page table.
        BOOT_STUB_CLEAR_TICKS = 0x0313,
            "boot_clear_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// From the stub's end to the start of the schedule: board bring-up (PCI, mac-io, the
        /// interrupt controller, the ESCC, the ivshmem devices), the boot record, the first log
        /// lines, MMU and BATs, the kernel's tables.
        BOOT_KERNEL_INIT_TICKS = 0x0314,
            "boot_kernel_init_ticks", Ticks, MeasuredCost, Kernel, Instrument;
        /// How the reset stub made the RAM image good: one of [`boot_image`]. A fact, not a
        /// cost (sent with the costs, on the Instrument channel).
        BOOT_IMAGE = 0x0315,
            "boot_image", Code, Value, Kernel, Instrument,
            values &[
                (boot_image::VERIFIED, "verified"),
                (boot_image::COPIED, "copied"),
                (boot_image::REPAIRED, "repaired"),
            ];
        /// The executive partition's start: its statics and stack zeroed by the kernel's
        /// partition start, up to its entry function.
        BOOT_EXECUTIVE_START_TICKS = 0x0316,
            "boot_executive_start_ticks", Ticks, MeasuredCost, Executive, Instrument;
        /// The executive's entry up to the flight application's boot: the application put in
        /// place and the checkpoint records of both memories read through the kernel.
        BOOT_EXECUTIVE_INIT_TICKS = 0x0317,
            "boot_executive_init_ticks", Ticks, MeasuredCost, Executive, Instrument;
        /// The planner partition's start at a boot: its statics and stack zeroed by the
        /// kernel's partition start, up to its entry function (its restore is
        /// PLANNER_RESTORE_TICKS). Sent once per boot.
        BOOT_PLANNER_START_TICKS = 0x0318,
            "boot_planner_start_ticks", Ticks, MeasuredCost, Planner, Instrument;
    }
}

/// The flight application's metrics (ids from 0x1000): sent on every target, the native one
/// included. Values travel on the Mission channel (identical on every target); measured costs
/// on the Instrument channel (the native target counts no cycles).
pub mod app {
    use super::restored_from;
    use crate::security::SecurityRefusal;

    metric_table! {
        APP_METRICS;
        /// Ticks the autonomy step of one frame took (planner and executive, and the clock
        /// reads that split them: at least PLANNER_TICKS + EXECUTIVE_TICKS of the same frame).
        STEP_TICKS = 0x1000,
            "step_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ticks one checkpoint write took (both areas).
        CHECKPOINT_TICKS = 0x1001,
            "checkpoint_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ticks the restore at boot took.
        RESTORE_TICKS = 0x1002,
            "restore_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ticks the application spent recovering after a restore, from the end of its boot to
        /// the end of the step that committed the repaired plan: the host's inputs in between
        /// (the state buffer published again, command responses) and the step(s) of the
        /// granted frames until the planner has no work pending (violations detected, aborts,
        /// contingencies, repair, commits); checkpoint writes of the frames before that one
        /// are included, the last frame's is not. Sent once per restore.
        RECOVERY_TICKS = 0x1003,
            "recovery_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Sequence number of the checkpoint restored at boot.
        RESTORED_SEQUENCE = 0x1004,
            "restored_sequence", Sequence, Value, FlightApp, Mission;
        /// Checkpoint writes that failed in one frame (a plan image larger than an area's
        /// slot).
        CHECKPOINT_WRITE_FAILURES = 0x1005,
            "checkpoint_write_failures", Count, Value, FlightApp, Mission;
        /// Ticks the planner's part of one frame's step took (reports and contingencies, its
        /// anytime cycle within the step budget, commits).
        PLANNER_TICKS = 0x1006,
            "planner_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ticks the executive's part of one frame's step took (both executive passes).
        EXECUTIVE_TICKS = 0x1007,
            "executive_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Where the checkpoint restored at boot came from: one of [`restored_from`].
        RESTORED_FROM = 0x1008,
            "restored_from", Code, Value, FlightApp, Mission,
            values &[
                (restored_from::WARM, "warm-restart area"),
                (restored_from::NV, "non-volatile memory"),
            ];
        /// Slot of the checkpoint restored at boot, in the memory it came from: 0 = A (first
        /// half), 1 = B (second half).
        RESTORED_SLOT = 0x1009,
            "restored_slot", Code, Value, FlightApp, Mission,
            values &[(0, "A"), (1, "B")];
        /// State-buffer updates so far whose value was not of the type their timeline takes (an
        /// integer for a state timeline, an enumeration value beyond its values, ...): each was
        /// taken as unknown (`autonomy::Autonomy::state_type_mismatches`; the types are in
        /// `TaskNetwork::measured_timelines`). Sent with the frame's FrameDone the first time
        /// it is not zero and in every frame it changed (after a restore: in the first frame),
        /// so a host can fail the run naming it. A count, not a cost.
        STATE_TYPE_MISMATCHES = 0x100A,
            "state_type_mismatches", Count, Value, FlightApp, Mission;
        /// The state key of the last such update; sent right after STATE_TYPE_MISMATCHES.
        STATE_TYPE_MISMATCH_KEY = 0x100B,
            "state_type_mismatch_key", StateKey, Value, FlightApp, Mission;
        /// Ticks the whole frame's work took (the step and the checkpoint writes): what
        /// FrameDone carried in protocol v1. A measured cost, so it travels on the link's
        /// Instrument channel and FrameDone stays the same on every target.
        FRAME_BUSY_TICKS = 0x100C,
            "frame_busy_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ground holds after an accepted SetHold or ReleaseHold (bit h: hold h), and at boot
        /// when any is set. A mask, not a cost.
        GROUND_HOLDS = 0x100D,
            "ground_holds", Mask, Value, FlightApp, Mission;
        /// Ticks the security checks of a reassembled uplink took (header, HMAC-SHA-256 over
        /// the whole image, sequence number), from the last chunk's receipt to the verdict; the
        /// counter write and the loading are not included. A measured cost.
        UPLINK_VERIFY_TICKS = 0x100E,
            "uplink_verify_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ground commands refused since boot although authentic (their sequence number is
        /// spent): a hold number out of range. Sent after each.
        GROUND_COMMANDS_NOT_CARRIED_OUT = 0x100F,
            "ground_commands_not_carried_out", Count, Value, FlightApp, Mission;
        /// Uplinks and ground commands refused by the security checks since boot, one metric
        /// per reason: id `SECURITY_REFUSALS_FIRST + SecurityRefusal::index()` (0x1010 NoKey,
        /// 0x1011 UnknownKey, 0x1012 Truncated, 0x1013 BadMac, 0x1014 Replay, 0x1015
        /// BadLength, 0x1016 CounterNotStored), value the count for that reason; sent after
        /// each refusal.
        SECURITY_REFUSALS_FIRST = 0x1010 * SecurityRefusal::COUNT as u16,
            "security_refusals", Count, Value, FlightApp, Mission;
        /// The parts of the application's boot (the boot breakdown; sent at every boot,
        /// whereas RESTORE_TICKS, their sum, only when a checkpoint was restored): the security
        /// area read and its key checked.
        BOOT_SECURITY_TICKS = 0x1020,
            "boot_security_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Finding the checkpoint to restore: the records' headers and the records needed read
        /// in (on a target whose memories sit behind system calls), their CRCs checked, and the
        /// memory chosen.
        RESTORE_CHECK_TICKS = 0x1021,
            "boot_restore_check_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Decoding and validating the chosen checkpoint and the restart adjustments (a few
        /// ticks when there is nothing to restore).
        RESTORE_DECODE_TICKS = 0x1022,
            "boot_restore_decode_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// The planner partition: ticks its restore at boot took (finding, decoding and
        /// validating its checkpoint). Sent when it restored one.
        PLANNER_RESTORE_TICKS = 0x1023,
            "planner_restore_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// The planner partition's CPU from the start of its restore to the end of the first
        /// window with no planning pending (the repaired plan committed), its checkpoints
        /// included. Sent once per restore.
        PLANNER_RECOVERY_TICKS = 0x1024,
            "planner_recovery_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Ticks the planner partition's checkpoint write took (both areas).
        PLANNER_CHECKPOINT_TICKS = 0x1025,
            "planner_checkpoint_ticks", Ticks, MeasuredCost, FlightApp, Instrument;
        /// Checkpoint writes of the planner partition that failed in one window.
        PLANNER_CHECKPOINT_WRITE_FAILURES = 0x1026,
            "planner_checkpoint_write_failures", Count, Value, FlightApp, Mission;
        /// Mission time (µs) from the frame that started a planner cycle to the frame whose
        /// window finished it, when that is more than one frame (a throttled planner: it
        /// committed its plan that much later). A value, not a cost: the same on every target
        /// with the same planner budget.
        PLANNING_LATENCY_US = 0x1027,
            "planning_latency_us", Micros, Value, FlightApp, Mission;
        /// Commits the executive dropped since boot because they were planned for a network
        /// that is no longer loaded; sent when it changes.
        STALE_COMMITS = 0x1028,
            "stale_commits", Count, Value, FlightApp, Mission;
        /// Frames in which the planner's cycle stopped on its budget and went on in the next
        /// frame's window (the planner was throttled), since boot; sent when it changes.
        PLANNER_PENDING_FRAMES = 0x1029,
            "planner_pending_frames", Count, Value, FlightApp, Mission;
    }

    /// The per-reason refusal count metric of `reason`.
    pub const fn security_refusals(reason: SecurityRefusal) -> u16 {
        SECURITY_REFUSALS_FIRST + reason.index() as u16
    }

    /// The reason a refusal count metric counts, if `id` is one.
    pub fn security_refusal_of(id: u16) -> Option<SecurityRefusal> {
        let index = id.checked_sub(SECURITY_REFUSALS_FIRST)?;
        SecurityRefusal::ALL.get(usize::from(index)).copied()
    }
}

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
mod tests {
    use super::*;

    #[test]
    fn the_compact_routes_the_firmware_links_agree_with_the_dictionary() {
        for m in metrics() {
            for id in m.id..m.id + m.instances {
                assert_eq!(metric_channel(id), m.channel, "{}", m.name);
            }
        }
        for id in [0x0fff, 0x1fff, 0xffff] {
            if metric(id).is_none() {
                assert_eq!(metric_channel(id), VirtualChannel::Instrument);
            }
        }
        let at = crate::MissionTimeUs::ZERO;
        let events = [
            TelemetryEvent::TaskTransition {
                task: 1,
                from: 0,
                to: 1,
                at,
            },
            TelemetryEvent::PlanModification {
                kind: 1,
                task: 1,
                template: 1,
                at,
            },
            TelemetryEvent::StateStale {
                key: crate::StateKey(1),
                measured_at: at,
                at,
            },
        ];
        for ev in &events {
            assert_eq!(event_channel(ev), event(ev).channel);
        }
    }
    use crate::security::SecurityRefusal;
    use std::collections::BTreeSet;
    use std::vec::Vec;

    fn every_id() -> Vec<(u16, &'static str)> {
        metrics()
            .flat_map(|m| (0..m.instances).map(move |i| (m.id + i, m.constant)))
            .collect()
    }

    #[test]
    fn every_id_is_unique_and_families_do_not_overlap() {
        let ids = every_id();
        let unique: BTreeSet<u16> = ids.iter().map(|(id, _)| *id).collect();
        assert_eq!(unique.len(), ids.len(), "an id is used twice: {ids:x?}");
        for (id, constant) in &ids {
            let found = metric(*id).expect("every id resolves");
            assert_eq!(found.constant, *constant, "{id:#06x}");
        }
        assert!(metric(0x0fff).is_none());
        assert!(metric(0x0100 + PARTITION_IDS).is_some_and(|m| m.constant == "WORST_FRAME_TICKS"));
    }

    #[test]
    fn names_and_constants_are_unique_and_lookups_find_them() {
        let names: BTreeSet<&str> = metrics().map(|m| m.name).collect();
        let constants: BTreeSet<&str> = metrics().map(|m| m.constant).collect();
        let count = metrics().count();
        assert_eq!(names.len(), count, "a name is used twice");
        assert_eq!(constants.len(), count, "a constant is used twice");
        for m in metrics() {
            assert_eq!(metric_named(m.name), Some(m));
            assert!(
                !m.meaning.trim().is_empty(),
                "{} has no meaning",
                m.constant
            );
            assert!(
                m.name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_'),
                "{} is not snake case",
                m.name
            );
        }
    }

    #[test]
    fn the_tables_hold_their_id_ranges() {
        assert!(platform::PLATFORM_METRICS
            .iter()
            .all(|m| m.id + m.instances <= 0x1000));
        assert!(app::APP_METRICS.iter().all(|m| m.id >= 0x1000));
    }

    /// The Mission channel must be identical on the native and the emulated target: a measured
    /// cost (which the native target cannot have) never travels on it, nor does anything only
    /// the firmware's platform sends.
    #[test]
    fn measured_costs_and_platform_metrics_are_instrumentation() {
        for m in metrics() {
            if m.is_measured_cost() || m.sender != Sender::FlightApp {
                assert_eq!(m.channel, VirtualChannel::Instrument, "{}", m.constant);
            } else {
                assert_eq!(m.channel, VirtualChannel::Mission, "{}", m.constant);
            }
        }
        assert!(is_measured_cost(app::STEP_TICKS));
        assert!(!is_measured_cost(app::GROUND_HOLDS));
        assert_eq!(metric_channel(0x0fff), VirtualChannel::Instrument);
        assert_eq!(metric_channel(app::GROUND_HOLDS), VirtualChannel::Mission);
        assert_eq!(
            metric_channel(platform::OVERRUNS + 3),
            VirtualChannel::Instrument
        );
    }

    #[test]
    fn code_values_have_names_and_codes_only() {
        for m in metrics() {
            assert_eq!(m.unit == Unit::Code, !m.values.is_empty(), "{}", m.constant);
            let values: BTreeSet<u64> = m.values.iter().map(|(v, _)| *v).collect();
            assert_eq!(values.len(), m.values.len(), "{}", m.constant);
        }
        let boot = metric(platform::BOOT_IMAGE).unwrap();
        assert_eq!(boot.value_name(boot_image::REPAIRED), Some("repaired"));
        assert_eq!(boot.value_name(99), None);
    }

    #[test]
    fn refusal_family_covers_every_reason() {
        for reason in SecurityRefusal::ALL {
            let id = app::security_refusals(reason);
            assert_eq!(app::security_refusal_of(id), Some(reason));
            assert_eq!(
                metric(id).map(|m| m.constant),
                Some("SECURITY_REFUSALS_FIRST")
            );
        }
        let past = app::SECURITY_REFUSALS_FIRST + SecurityRefusal::COUNT as u16;
        assert_eq!(app::security_refusal_of(past), None);
        assert!(metric(past).is_none());
    }

    #[test]
    fn events_are_indexed_by_their_variant_and_have_severities() {
        use crate::types::{MissionTimeUs, StateKey};
        let at = MissionTimeUs(1);
        let samples = [
            TelemetryEvent::TaskTransition {
                task: 1,
                from: 0,
                to: 1,
                at,
            },
            TelemetryEvent::PlanModification {
                kind: 0,
                task: 1,
                template: 2,
                at,
            },
            TelemetryEvent::HealthMonitor {
                partition: 1,
                kind: 2,
                address: 0,
                action: 1,
            },
            TelemetryEvent::Metric {
                id: app::GROUND_HOLDS,
                value: 1,
            },
            TelemetryEvent::StateStale {
                key: StateKey(3),
                measured_at: at,
                at,
            },
        ];
        for (i, ev) in samples.iter().enumerate() {
            let def = event(ev);
            assert_eq!(usize::from(def.id), i);
            // The id is the variant's postcard index: its first byte on the wire.
            let mut buf = [0u8; 32];
            let bytes = postcard::to_slice(ev, &mut buf).unwrap();
            assert_eq!(bytes[0], def.id, "{ev:?}");
        }
        assert_eq!(event(&samples[2]).severity, Severity::Error);
        assert!(event(&samples[4]).severity > Severity::Info);
        // A metric event travels where its metric does.
        assert_eq!(event_channel(&samples[3]), VirtualChannel::Mission);
        assert_eq!(
            event_channel(&TelemetryEvent::Metric {
                id: app::STEP_TICKS,
                value: 1
            }),
            VirtualChannel::Instrument
        );
    }
}
