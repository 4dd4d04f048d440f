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
    count("frames", "frames", "lockstep frames granted"),
];

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
}
