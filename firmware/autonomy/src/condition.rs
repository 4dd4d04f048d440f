//! Control conditions: the core's copy of the state buffer ([`StateTable`]) and the evaluation
//! of boolean expression trees (AND, OR, NOT over relational terms) against it, as the executive
//! does at every stage of a task (seed 003 "MEXEC Planner and Controller").
//!
//! Each entry keeps the mission time it was measured at, and whether it is stale: older than
//! its timeline's staleness bound ([`crate::TimelineSpec::stale_after_us`]) at the step being
//! run. [`crate::Autonomy`] sets that at the start of every step; every read here
//! ([`StateTable::value`], [`measured_value`], [`evaluate`]) then gives [`VALUE_UNKNOWN`] for a
//! stale entry, exactly as for an entry its owner reported unknown.
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::capacity::*;
use crate::model::*;
use fsw_bridge::{MissionTimeUs, StateKey, StateValue};

/// One remembered state-buffer entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateEntry {
    pub key: StateKey,
    /// The value as reported (readers see it as unknown while `stale`).
    pub value: StateValue,
    /// When it was measured (the update's timestamp).
    pub at: MissionTimeUs,
    /// Older than its staleness bound at the last step: it reads unknown until a newer
    /// measurement arrives.
    pub stale: bool,
}

impl StateEntry {
    /// The value readers see: `StateValue::Unknown` while stale.
    pub fn reading(&self) -> StateValue {
        if self.stale {
            StateValue::Unknown
        } else {
            self.value
        }
    }

    /// Whether this measurement is older than `bound_us` at `now`: `now - at > bound_us`.
    pub fn is_older_than(&self, bound_us: u64, now: MissionTimeUs) -> bool {
        now.0.saturating_sub(self.at.0) > bound_us
    }

    /// The first instant at which this measurement is older than `bound_us`.
    pub fn stale_from(&self, bound_us: u64) -> MissionTimeUs {
        MissionTimeUs(self.at.0.saturating_add(bound_us).saturating_add(1))
    }
}

/// What [`StateTable::update`] did with an update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateOutcome {
    /// A newer measurement of the key (or its first): stored, and fresh until the next step
    /// judges its age.
    Stored,
    /// Older than the stored measurement, or the very same measurement again: ignored.
    Ignored,
    /// The key is new and the table is full: dropped.
    TableFull,
}

/// The latest value of each state-buffer entry the core has been told about.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateTable {
    entries: Vec<StateEntry, MAX_STATE_KEYS>,
}

/// Decodes a state table as a checkpoint holds it (its `Serialize`: one list) into the table
/// itself, the list straight into its place ([`crate::in_place`]).
pub(crate) struct StateTableInPlace<'a>(pub &'a mut StateTable);

impl<'de> serde::de::DeserializeSeed<'de> for StateTableInPlace<'_> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_tuple(1, self)
    }
}

impl<'de> serde::de::Visitor<'de> for StateTableInPlace<'_> {
    type Value = ();

    fn expecting(&self, formatter: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        formatter.write_str("a saved state table")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        crate::in_place::field_into(&mut seq, crate::in_place::VecInto(&mut self.0.entries), 0)
    }
}

/// Converts a state-buffer value to the integer timelines and conditions use.
pub fn state_value_to_i64(value: StateValue) -> i64 {
    match value {
        StateValue::Unknown => VALUE_UNKNOWN,
        StateValue::Bool(b) => i64::from(b),
        StateValue::Enum(e) => i64::from(e),
        StateValue::Int(i) => i.max(VALUE_UNKNOWN + 1),
    }
}

impl StateTable {
    pub const fn new() -> Self {
        Self {
            entries: Vec::new(),
        }
    }

    /// Records an update measured at `at`. An update older than the stored one is ignored,
    /// and so is the same measurement again (same time, same value: a stale entry stays
    /// stale); a newer one replaces it and is fresh until the next step judges its age.
    pub fn update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) -> UpdateOutcome {
        if let Some(e) = self.entries.iter_mut().find(|e| e.key == key) {
            if at < e.at || (at == e.at && value == e.value) {
                return UpdateOutcome::Ignored;
            }
            *e = StateEntry {
                key,
                value,
                at,
                stale: false,
            };
            return UpdateOutcome::Stored;
        }
        match self.entries.push(StateEntry {
            key,
            value,
            at,
            stale: false,
        }) {
            Ok(()) => UpdateOutcome::Stored,
            Err(_) => UpdateOutcome::TableFull,
        }
    }

    /// The entry of `key` as stored (its value as reported, its age, whether it is stale).
    /// Readers that decide something use [`StateTable::value`] or [`measured_value`].
    pub fn get(&self, key: StateKey) -> Option<&StateEntry> {
        self.entries.iter().find(|e| e.key == key)
    }

    /// Marks the entry of `key` stale or fresh; returns the entry if that changed it.
    pub fn set_stale(&mut self, key: StateKey, stale: bool) -> Option<StateEntry> {
        let e = self.entries.iter_mut().find(|e| e.key == key)?;
        if e.stale == stale {
            return None;
        }
        e.stale = stale;
        Some(*e)
    }

    /// Marks every entry fresh (a new network brings new bounds; the next step judges again).
    pub fn clear_staleness(&mut self) {
        for e in &mut self.entries {
            e.stale = false;
        }
    }

    /// Value of `key` as an integer ([`VALUE_UNKNOWN`] if never reported, or stale).
    pub fn value(&self, key: StateKey) -> i64 {
        self.get(key)
            .map(|e| state_value_to_i64(e.reading()))
            .unwrap_or(VALUE_UNKNOWN)
    }

    pub fn entries(&self) -> &[StateEntry] {
        &self.entries
    }

    pub fn clear(&mut self) {
        self.entries.clear();
    }
}

/// Value a measured timeline has "now" according to the state table: the reported value
/// ([`VALUE_UNKNOWN`] when it is not of the timeline's type, as the planner takes it, or when
/// it is stale), or the timeline's initial value if its key was never reported.
pub fn measured_value(network: &TaskNetwork, timeline: u8, states: &StateTable) -> Option<i64> {
    let spec = network.timeline(timeline)?;
    let key = spec.state_key?;
    let expected = spec.measured_value_type()?;
    Some(match states.get(key) {
        Some(e) if e.stale => VALUE_UNKNOWN,
        Some(e) if expected.accepts(e.value) => spec.derived_value(state_value_to_i64(e.value)),
        Some(_) => VALUE_UNKNOWN,
        None => match spec.kind {
            TimelineKind::State { initial, .. } => i64::from(initial),
            TimelineKind::Claimable => 0,
            TimelineKind::Cumulative { initial, .. } => initial,
        },
    })
}

fn relate(left: i64, op: RelOp, right: i64) -> bool {
    if left == VALUE_UNKNOWN {
        return false;
    }
    match op {
        RelOp::Eq => left == right,
        RelOp::Ne => left != right,
        RelOp::Lt => left < right,
        RelOp::Le => left <= right,
        RelOp::Gt => left > right,
        RelOp::Ge => left >= right,
    }
}

/// Evaluates a validated condition. A malformed one (impossible after validation) is false.
pub fn evaluate(network: &TaskNetwork, condition: &ConditionSpec, states: &StateTable) -> bool {
    let mut stack: Vec<bool, MAX_CONDITION_TERMS> = Vec::new();
    for node in &condition.nodes {
        let value = match *node {
            CondNode::Term { operand, op, value } => {
                let left = match operand {
                    Operand::State(key) => states.value(key),
                    Operand::Timeline(t) => {
                        measured_value(network, t, states).unwrap_or(VALUE_UNKNOWN)
                    }
                };
                relate(left, op, value)
            }
            CondNode::Not => match stack.pop() {
                Some(v) => !v,
                None => return false,
            },
            CondNode::And | CondNode::Or => match (stack.pop(), stack.pop()) {
                (Some(a), Some(b)) => {
                    if *node == CondNode::And {
                        a && b
                    } else {
                        a || b
                    }
                }
                _ => return false,
            },
        };
        if stack.push(value).is_err() {
            return false;
        }
    }
    stack.pop().unwrap_or(false) && stack.is_empty()
}
