//! Control conditions: the core's copy of the state buffer ([`StateTable`]) and the evaluation
//! of boolean expression trees (AND, OR, NOT over relational terms) against it, as the executive
//! does at every stage of a task (seed 003 "MEXEC Planner and Controller").
use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::capacity::*;
use crate::model::*;
use fsw_bridge::{MissionTimeUs, StateKey, StateValue};

/// One remembered state-buffer entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateEntry {
    pub key: StateKey,
    pub value: StateValue,
    pub at: MissionTimeUs,
}

/// The latest value of each state-buffer entry the core has been told about.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateTable {
    entries: Vec<StateEntry, MAX_STATE_KEYS>,
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

    /// Records an update; returns false if the table is full and `key` is new (the update is
    /// dropped). An update older than the stored one is ignored.
    pub fn update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) -> bool {
        if let Some(e) = self.entries.iter_mut().find(|e| e.key == key) {
            if at >= e.at {
                e.value = value;
                e.at = at;
            }
            return true;
        }
        self.entries.push(StateEntry { key, value, at }).is_ok()
    }

    pub fn get(&self, key: StateKey) -> Option<&StateEntry> {
        self.entries.iter().find(|e| e.key == key)
    }

    /// Value of `key` as an integer ([`VALUE_UNKNOWN`] if never reported).
    pub fn value(&self, key: StateKey) -> i64 {
        self.get(key)
            .map(|e| state_value_to_i64(e.value))
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
/// ([`VALUE_UNKNOWN`] when it is not of the timeline's type, as the planner takes it), or the
/// timeline's initial value if its key was never reported.
pub fn measured_value(network: &TaskNetwork, timeline: u8, states: &StateTable) -> Option<i64> {
    let spec = network.timeline(timeline)?;
    let key = spec.state_key?;
    let expected = spec.measured_value_type()?;
    Some(match states.get(key) {
        Some(e) if expected.accepts(e.value) => state_value_to_i64(e.value),
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
