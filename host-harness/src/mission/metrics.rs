//! The metrics a mission run reports, declared once: name, unit, what it counts and whether
//! only the emulated target measures it (guest CPU costs). Expectations and budgets name
//! metrics from this list, so a misspelt name is refused before the run, and the report knows
//! which metrics the native target cannot have without parsing their names.
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

/// Every metric a mission report can carry.
pub const METRICS: &[MetricDef] = &[
    cost(
        "max_step_ticks",
        "ticks",
        "the worst frame's autonomy step (planner and executive)",
    ),
    cost(
        "max_planner_ticks",
        "ticks",
        "the worst frame's planner part of the step",
    ),
    cost(
        "max_executive_ticks",
        "ticks",
        "the worst frame's executive part of the step",
    ),
    cost(
        "max_checkpoint_ticks",
        "ticks",
        "the worst checkpoint write (warm and non-volatile)",
    ),
    cost(
        "max_restore_ticks",
        "ticks",
        "the worst restore of a checkpoint at boot",
    ),
    cost(
        "max_recovery_ticks",
        "ticks",
        "the worst recovery after a restore, to the repaired plan committed",
    ),
    cost(
        "max_recovery_instructions",
        "instructions",
        "max_recovery_ticks in guest instructions",
    ),
    cost(
        "max_boot_to_ready_ticks_power_on",
        "ticks",
        "reset vector to ready after a power-on",
    ),
    cost(
        "max_boot_to_ready_ticks_warm",
        "ticks",
        "reset vector to ready after a warm reset",
    ),
    cost(
        "max_warm_boot_image_ticks",
        "ticks",
        "warm boot: reset vector to the RAM image checked (or copied from ROM)",
    ),
    cost(
        "max_warm_boot_clear_ticks",
        "ticks",
        "warm boot: the reset stub's clearing of .bss and the page table",
    ),
    cost(
        "max_warm_boot_kernel_init_ticks",
        "ticks",
        "warm boot: board bring-up and kernel set-up, to the start of the schedule",
    ),
    cost(
        "max_warm_boot_executive_start_ticks",
        "ticks",
        "warm boot: the executive partition's start (statics zeroed)",
    ),
    cost(
        "max_warm_boot_executive_init_ticks",
        "ticks",
        "warm boot: the flight application put in place, the memories probed",
    ),
    cost(
        "max_warm_boot_security_ticks",
        "ticks",
        "warm boot: the security area read and its key checked",
    ),
    cost(
        "max_warm_boot_restore_check_ticks",
        "ticks",
        "warm boot: checkpoint records read, CRCs checked, memory chosen",
    ),
    cost(
        "max_warm_boot_restore_decode_ticks",
        "ticks",
        "warm boot: the checkpoint decoded and validated",
    ),
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
        "checkpoint_write_failures",
        "writes",
        "checkpoint writes that failed (a plan image larger than a slot)",
    ),
    count(
        "link_faults_injected",
        "faults",
        "link faults the host injected (corrupted, dropped or delayed frames)",
    ),
    count(
        "instrument_messages_dropped",
        "messages",
        "Instrument-channel messages (costs, kernel events, logs) the target dropped because that channel was full or the link lost; the most in any one boot (emulated target only)",
    ),
    count("frames", "frames", "lockstep frames granted"),
    cost(
        "max_uplink_verify_ticks",
        "ticks",
        "the longest security check of a reassembled uplink (header, HMAC-SHA-256, sequence number)",
    ),
    cost(
        "max_uplink_verify_instructions",
        "instructions",
        "max_uplink_verify_ticks in guest instructions",
    ),
    count(
        "ground_holds",
        "mask",
        "the ground holds as the target last reported them (bit h: hold h; absent until one is set)",
    ),
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

/// The metric counting refusals named `reason` (`SecurityRefusal::name`, `CommandRefusal::name`):
/// `refused_<reason>` with `-` as `_`.
pub fn refused_metric(reason: &str) -> String {
    format!("refused_{}", reason.replace('-', "_"))
}

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
