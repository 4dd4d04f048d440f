//! The metrics a mission run reports, declared once: name, unit, what it counts and whether
//! only the emulated target measures it (guest CPU costs). Expectations and budgets name
//! metrics from this list, so a misspelt name is refused before the run, and the report knows
//! which metrics the native target cannot have without parsing their names.
//!
//! The metrics reduced from the target's telemetry ([`FROM_WIRE`]) take their names, units and
//! kinds from the telemetry dictionary (`fsw_bridge::dictionary`): a measured cost `x` is
//! reported as its largest value `max_x`, a value as `x`.
use std::sync::LazyLock;

use fsw_bridge::dictionary::{self, Kind};
use serde::Serialize;

/// What a metric's value is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MetricKind {
    /// A guest CPU cost under icount (timebase ticks or instructions): the emulated target
    /// only; the native target counts no cycles.
    GuestCost,
    /// A count of things that happened (any target).
    Count,
}

/// One declared metric.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MetricDef {
    pub name: &'static str,
    pub unit: &'static str,
    pub kind: MetricKind,
    pub meaning: &'static str,
}

const fn cost(name: &'static str, unit: &'static str, meaning: &'static str) -> MetricDef {
    MetricDef {
        name,
        unit,
        kind: MetricKind::GuestCost,
        meaning,
    }
}

const fn count(name: &'static str, unit: &'static str, meaning: &'static str) -> MetricDef {
    MetricDef {
        name,
        unit,
        kind: MetricKind::Count,
        meaning,
    }
}

/// The metrics of a mission report that the host measures or reduces itself (the rest come
/// from the telemetry dictionary: [`FROM_WIRE`]).
const HOST_METRICS: &[MetricDef] = &[
    cost(
        "max_reset_recovery_ticks",
        "ticks",
        "the worst reset vector to repaired plan committed",
    ),
    cost(
        "max_reset_recovery_instructions",
        "instructions",
        "max_reset_recovery_ticks in guest instructions",
    ),
    count(
        "link_faults_injected",
        "faults",
        "link faults the host injected (corrupted, dropped or delayed frames)",
    ),
    count("frames", "frames", "lockstep frames granted"),
    count(
        "authenticated_accepted",
        "messages",
        "authenticated uplinks and ground commands the target accepted",
    ),
    count(
        "refused_no_key",
        "messages",
        "authenticated messages refused: no key provisioned",
    ),
    count(
        "refused_unknown_key",
        "messages",
        "authenticated messages refused: their SPI names a key the target does not hold",
    ),
    count(
        "refused_truncated",
        "messages",
        "authenticated messages refused: shorter than their header, trailer or announced length",
    ),
    count(
        "refused_bad_mac",
        "messages",
        "authenticated messages refused: the MAC did not match (forged, or another key)",
    ),
    count(
        "refused_replay",
        "messages",
        "authenticated messages refused: a sequence number not above the last accepted",
    ),
    count(
        "refused_bad_length",
        "messages",
        "authenticated uplinks refused: longer than their header announces",
    ),
    count(
        "refused_counter_not_stored",
        "messages",
        "authenticated messages refused: the anti-replay counter could not be written",
    ),
    count(
        "refused_hold_out_of_range",
        "messages",
        "authentic ground commands not carried out: a hold number out of range",
    ),
];

/// How the mission record reduces a metric of the target's telemetry to report metrics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    /// The largest value of the run: `max_<name>` for a measured cost, `<name>` for a value.
    Max,
    /// The last value: `<name>`.
    Last,
    /// The largest value over the warm boots (every boot but a power-on): `max_warm_<name>`.
    MaxOverWarmBoots,
    /// The largest value per boot kind: `max_<name>_power_on` and `max_<name>_warm`.
    MaxPerBootKind,
}

/// A report metric reduced from a telemetry metric.
#[derive(Clone, Copy, Debug)]
pub struct FromWire {
    /// The telemetry dictionary's id.
    pub id: u16,
    pub reduce: Reduce,
    /// A ticks maximum that also has an `*_instructions` twin.
    pub instructions: bool,
    /// What the report metric says (the dictionary's entry says what the target measured).
    pub meaning: &'static str,
}

const fn wire(id: u16, reduce: Reduce, meaning: &'static str) -> FromWire {
    FromWire {
        id,
        reduce,
        instructions: false,
        meaning,
    }
}

const fn wire_with_instructions(id: u16, meaning: &'static str) -> FromWire {
    FromWire {
        id,
        reduce: Reduce::Max,
        instructions: true,
        meaning,
    }
}

/// The telemetry metrics a mission report carries, and how.
pub const FROM_WIRE: &[FromWire] = {
    use flight_app::metric as app;
    use kernel_config::abi::metric as platform;
    use Reduce::*;
    &[
        wire(app::STEP_TICKS, Max, MAX_STEP_TICKS),
        wire(app::PLANNER_TICKS, Max, MAX_PLANNER_TICKS),
        wire(app::EXECUTIVE_TICKS, Max, MAX_EXECUTIVE_TICKS),
        wire(app::CHECKPOINT_TICKS, Max, MAX_CHECKPOINT_TICKS),
        wire(
            app::PLANNER_CHECKPOINT_TICKS,
            Max,
            "the worst checkpoint write of the planner partition (warm and non-volatile)",
        ),
        wire(
            app::PLANNER_RESTORE_TICKS,
            Max,
            "the worst restore of the planner partition's checkpoint at boot",
        ),
        wire(
            app::PLANNER_RECOVERY_TICKS,
            Max,
            "the planner partition's worst CPU from its restore to its first window with nothing pending",
        ),
        wire(
            app::PLANNING_LATENCY_US,
            Max,
            "the worst planning latency: mission time from the frame that started a planner cycle to the frame whose window finished it (a throttled planner)",
        ),
        wire(
            app::PLANNER_PENDING_FRAMES,
            Last,
            "frames whose planner cycle stopped on its budget and went on in the next frame (the planner throttled)",
        ),
        wire(app::RESTORE_TICKS, Max, MAX_RESTORE_TICKS),
        wire_with_instructions(app::RECOVERY_TICKS, MAX_RECOVERY_TICKS),
        wire(
            platform::BOOT_TO_READY_TICKS,
            MaxPerBootKind,
            "reset vector to ready, per boot kind (power-on, warm)",
        ),
        wire(
            platform::BOOT_STUB_IMAGE_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_IMAGE_TICKS,
        ),
        wire(
            platform::BOOT_STUB_CLEAR_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_CLEAR_TICKS,
        ),
        wire(
            platform::BOOT_KERNEL_INIT_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_KERNEL_INIT_TICKS,
        ),
        wire(
            platform::BOOT_EXECUTIVE_START_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_EXECUTIVE_START_TICKS,
        ),
        wire(
            platform::BOOT_EXECUTIVE_INIT_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_EXECUTIVE_INIT_TICKS,
        ),
        wire(
            app::BOOT_SECURITY_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_SECURITY_TICKS,
        ),
        wire(
            app::RESTORE_CHECK_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_RESTORE_CHECK_TICKS,
        ),
        wire(
            app::RESTORE_DECODE_TICKS,
            MaxOverWarmBoots,
            MAX_WARM_BOOT_RESTORE_DECODE_TICKS,
        ),
        wire(
            app::CHECKPOINT_WRITE_FAILURES,
            Max,
            CHECKPOINT_WRITE_FAILURES,
        ),
        wire(
            app::STATE_TYPE_MISMATCHES,
            Max,
            "state-buffer updates whose value was not of their timeline's type (taken as unknown)",
        ),
        wire(
            app::STATE_TYPE_MISMATCH_KEY,
            Max,
            "the largest state key of such an update",
        ),
        wire(
            platform::LINK_INSTRUMENT_DROPPED,
            Max,
            INSTRUMENT_MESSAGES_DROPPED,
        ),
        wire_with_instructions(app::UPLINK_VERIFY_TICKS, MAX_UPLINK_VERIFY_TICKS),
        wire(app::GROUND_HOLDS, Last, GROUND_HOLDS),
    ]
};

const MAX_STEP_TICKS: &str = "the worst frame's autonomy step (planner and executive)";
const MAX_PLANNER_TICKS: &str = "the worst frame's planner part of the step";
const MAX_EXECUTIVE_TICKS: &str = "the worst frame's executive part of the step";
const MAX_CHECKPOINT_TICKS: &str = "the worst checkpoint write (warm and non-volatile)";
const MAX_RESTORE_TICKS: &str = "the worst restore of a checkpoint at boot";
const MAX_RECOVERY_TICKS: &str =
    "the worst recovery after a restore, to the repaired plan committed";
const MAX_WARM_BOOT_IMAGE_TICKS: &str =
    "warm boot: reset vector to the RAM image checked (or copied from ROM)";
const MAX_WARM_BOOT_CLEAR_TICKS: &str =
    "warm boot: the reset stub's clearing of .bss and the page table";
const MAX_WARM_BOOT_KERNEL_INIT_TICKS: &str =
    "warm boot: board bring-up and kernel set-up, to the start of the schedule";
const MAX_WARM_BOOT_EXECUTIVE_START_TICKS: &str =
    "warm boot: the executive partition's start (statics zeroed)";
const MAX_WARM_BOOT_EXECUTIVE_INIT_TICKS: &str =
    "warm boot: the flight application put in place, the memories probed";
const MAX_WARM_BOOT_SECURITY_TICKS: &str = "warm boot: the security area read and its key checked";
const MAX_WARM_BOOT_RESTORE_CHECK_TICKS: &str =
    "warm boot: checkpoint records read, CRCs checked, memory chosen";
const MAX_WARM_BOOT_RESTORE_DECODE_TICKS: &str = "warm boot: the checkpoint decoded and validated";
const CHECKPOINT_WRITE_FAILURES: &str =
    "checkpoint writes that failed (a plan image larger than a slot)";
const INSTRUMENT_MESSAGES_DROPPED: &str = "Instrument-channel messages (costs, kernel events, logs) the target dropped because that channel was full or the link lost; the most in any one boot (emulated target only)";
const MAX_UPLINK_VERIFY_TICKS: &str =
    "the longest security check of a reassembled uplink (header, HMAC-SHA-256, sequence number)";
const GROUND_HOLDS: &str =
    "the ground holds as the target last reported them (bit h: hold h; absent until one is set)";

/// The metric counting refusals named `reason` (`SecurityRefusal::name`, `CommandRefusal::name`):
/// `refused_<reason>` with `-` as `_`.
pub fn refused_metric(reason: &str) -> String {
    format!("refused_{}", reason.replace('-', "_"))
}

/// The dictionary entry of a report metric reduced from the wire.
fn entry(w: &FromWire) -> &'static dictionary::Metric {
    dictionary::metric(w.id).expect("FROM_WIRE names dictionary ids (tested)")
}

/// The report metric for `id` reduced by [`Reduce::Max`] or [`Reduce::Last`]: `max_<name>` for
/// a measured cost, `<name>` for a value (None: not in the dictionary).
pub fn report_name(id: u16) -> Option<String> {
    let m = dictionary::metric(id)?;
    Some(match m.kind {
        Kind::MeasuredCost => format!("max_{}", m.name),
        Kind::Value => m.name.to_string(),
    })
}

/// The report metric for `id` over the warm boots: `max_warm_<name>`.
pub fn warm_boot_name(id: u16) -> Option<String> {
    dictionary::metric(id).map(|m| format!("max_warm_{}", m.name))
}

/// The report metric for `id` per boot kind: `max_<name>_power_on` or `max_<name>_warm`.
pub fn boot_kind_name(id: u16, power_on: bool) -> Option<String> {
    let kind = if power_on { "power_on" } else { "warm" };
    dictionary::metric(id).map(|m| format!("max_{}_{kind}", m.name))
}

/// The `*_instructions` twin of a ticks maximum (`max_x_ticks` -> `max_x_instructions`).
pub fn instructions_name(ticks_name: &str) -> String {
    let stem = ticks_name.strip_suffix("_ticks").unwrap_or(ticks_name);
    format!("{stem}_instructions")
}

fn leak(name: String) -> &'static str {
    Box::leak(name.into_boxed_str())
}

/// The report metrics one telemetry metric gives.
fn wire_defs(w: &FromWire) -> Vec<MetricDef> {
    let m = entry(w);
    let kind = match m.kind {
        Kind::MeasuredCost => MetricKind::GuestCost,
        Kind::Value => MetricKind::Count,
    };
    let def = |name: String, unit: &'static str, meaning: &'static str| MetricDef {
        name: leak(name),
        unit,
        kind,
        meaning,
    };
    let unit = m.unit.name();
    let mut defs = match w.reduce {
        Reduce::Max | Reduce::Last => vec![def(report_name(w.id).unwrap(), unit, w.meaning)],
        Reduce::MaxOverWarmBoots => vec![def(warm_boot_name(w.id).unwrap(), unit, w.meaning)],
        Reduce::MaxPerBootKind => vec![
            def(boot_kind_name(w.id, true).unwrap(), unit, w.meaning),
            def(boot_kind_name(w.id, false).unwrap(), unit, w.meaning),
        ],
    };
    if w.instructions {
        let twin = instructions_name(defs[0].name);
        defs.push(def(
            twin,
            "instructions",
            "the same maximum in guest instructions",
        ));
    }
    defs
}

/// Every metric a mission report can carry: those reduced from the target's telemetry (the
/// step's costs first), then the host's own.
pub static METRICS: LazyLock<Vec<MetricDef>> = LazyLock::new(|| {
    FROM_WIRE
        .iter()
        .flat_map(wire_defs)
        .chain(HOST_METRICS.iter().copied())
        .collect()
});

/// The metric named `name`.
pub fn lookup(name: &str) -> Option<&'static MetricDef> {
    METRICS.iter().find(|m| m.name == name)
}

/// Every metric name, in declaration order.
pub fn names() -> Vec<&'static str> {
    METRICS.iter().map(|m| m.name).collect()
}

/// True if only the emulated target measures `name`.
pub fn is_guest_cost(name: &str) -> bool {
    lookup(name).is_some_and(|m| m.kind == MetricKind::GuestCost)
}

/// Whether `name` measures the planner's throttle (its budget per window), which a target that
/// plans unthrottled (the native one, the reference) never reports.
pub fn is_throttle_measure(name: &str) -> bool {
    [
        flight_app::metric::PLANNING_LATENCY_US,
        flight_app::metric::PLANNER_PENDING_FRAMES,
    ]
    .into_iter()
    .filter_map(report_name)
    .any(|n| n == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_costs_are_marked() {
        let mut names = names();
        names.sort_unstable();
        let before = names.len();
        names.dedup();
        assert_eq!(names.len(), before, "a metric is declared twice");
        assert!(is_guest_cost("max_reset_recovery_instructions"));
        assert!(!is_guest_cost("link_faults_injected"));
        assert!(!is_guest_cost("no_such_metric"));
    }

    /// The report's names for telemetry metrics come from the dictionary: the names budgets.toml
    /// and the scenarios' expectations use stay what they were.
    #[test]
    fn wire_metrics_take_their_names_from_the_dictionary() {
        for w in FROM_WIRE {
            let m = dictionary::metric(w.id).expect("a FROM_WIRE id is in the dictionary");
            let defs = wire_defs(w);
            let named = defs.iter().filter(|d| d.name.contains(m.name)).count();
            let twins = defs.iter().filter(|d| d.unit == "instructions").count();
            assert_eq!(named + twins, defs.len(), "{}", m.name);
            assert_eq!(twins, usize::from(w.instructions), "{}", m.name);
            if w.instructions {
                assert_eq!(m.unit, dictionary::Unit::Ticks, "{}", m.name);
            }
        }
        for name in [
            "max_step_ticks",
            "max_planner_ticks",
            "max_recovery_instructions",
            "max_boot_to_ready_ticks_power_on",
            "max_boot_to_ready_ticks_warm",
            "max_warm_boot_image_ticks",
            "max_warm_boot_restore_decode_ticks",
            "max_uplink_verify_instructions",
            "checkpoint_write_failures",
            "instrument_messages_dropped",
            "ground_holds",
        ] {
            assert!(lookup(name).is_some(), "{name} is not declared");
        }
        assert!(is_guest_cost("max_warm_boot_clear_ticks"));
        assert!(!is_guest_cost("ground_holds"));
        assert_eq!(lookup("ground_holds").unwrap().unit, "mask");
    }

    #[test]
    fn every_refusal_reason_has_its_declared_count() {
        use fsw_bridge::{CommandRefusal, SecurityRefusal};
        for reason in SecurityRefusal::ALL {
            let name = refused_metric(reason.name());
            assert!(lookup(&name).is_some(), "{name} is not declared");
        }
        let name = refused_metric(CommandRefusal::HoldOutOfRange.name());
        assert!(lookup(&name).is_some(), "{name} is not declared");
    }
}
