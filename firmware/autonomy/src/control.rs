//! The control loop (MEXEC's controller, seed 003; the executive of seed 000 IV.A.4): the
//! executive and the core's copy of the state buffer. It runs every frame, whatever the
//! planner is doing: command responses, start, maintain and end checks, timeouts, flexible
//! execution, and the ages of measured values. It talks to the planning loop only through
//! [`crate::interface`] messages: [`ToPlanner`] out (measurements, task reports, commits it had
//! no room for), [`crate::ToExecutive`] in (commits).
use crate::condition::{state_value_to_i64, StateTable, UpdateOutcome};
use crate::executive::Executive;
use crate::interface::{Commit, Outputs, TaskReport, ToPlanner};
use crate::model::{TaskNetwork, TimelineSpec, VALUE_UNKNOWN};
use fsw_bridge::{MissionTimeUs, StateKey, StateValue, TelemetryEvent};

/// The executive and the state buffer copy (see the module docs).
#[derive(Clone, Debug)]
pub struct ControlLoop {
    pub(crate) executive: Executive,
    pub(crate) states: StateTable,
    /// Counts state updates whose value does not fit the timeline's kind
    /// ([`TimelineSpec::measured_value_type`]); each is taken as unknown.
    pub(crate) state_type_mismatches: u32,
    /// The state key of the last such update.
    pub(crate) last_state_type_mismatch: Option<StateKey>,
}

impl Default for ControlLoop {
    fn default() -> Self {
        Self::new()
    }
}

impl ControlLoop {
    pub const fn new() -> Self {
        Self {
            executive: Executive::new(),
            states: StateTable::new(),
            state_type_mismatches: 0,
            last_state_type_mismatch: None,
        }
    }

    /// Makes this loop what [`ControlLoop::new`] is, in place.
    pub fn reset(&mut self) {
        self.executive.reset();
        self.states.clear();
        self.state_type_mismatches = 0;
        self.last_state_type_mismatch = None;
    }

    pub fn executive(&self) -> &Executive {
        &self.executive
    }

    pub fn states(&self) -> &StateTable {
        &self.states
    }

    pub fn state_type_mismatches(&self) -> u32 {
        self.state_type_mismatches
    }

    pub fn last_state_type_mismatch(&self) -> Option<StateKey> {
        self.last_state_type_mismatch
    }

    fn timeline_value(&mut self, network: &TaskNetwork, timeline: u8, value: StateValue) -> i64 {
        let Some(spec) = network.timeline(timeline) else {
            return VALUE_UNKNOWN;
        };
        match fitted_value(spec, value) {
            Some(v) => v,
            None => {
                self.state_type_mismatches = self.state_type_mismatches.saturating_add(1);
                self.last_state_type_mismatch = spec.state_key;
                VALUE_UNKNOWN
            }
        }
    }

    /// A new network was loaded: what the state buffer already told us goes to the planner
    /// for the new timelines; the new network's bounds judge the ages again at the next step.
    pub fn after_load(&mut self, network: &TaskNetwork, to_planner: &mut impl FnMut(ToPlanner)) {
        self.states.clear_staleness();
        let states = self.states.clone();
        for e in states.entries() {
            if let Some(t) = network.timeline_of_key(e.key) {
                let value = self.timeline_value(network, t, e.value);
                to_planner(ToPlanner::Measured {
                    timeline: t,
                    value,
                    at: e.at,
                    replaces: false,
                });
            }
        }
    }

    /// Records a state-buffer value measured at `at` (see [`crate::Autonomy::on_state_update`]).
    /// A measurement of a timeline that measures model parameters updates them in `network`
    /// (see [`TaskNetwork::measure_params`]); returns whether one changed.
    pub fn on_state_update(
        &mut self,
        network: &mut TaskNetwork,
        key: StateKey,
        value: StateValue,
        at: MissionTimeUs,
        to_planner: &mut impl FnMut(ToPlanner),
    ) -> bool {
        let outcome = self.states.update(key, value, at);
        let mut params_changed = false;
        if let Some(t) = network.timeline_of_key(key) {
            let v = self.timeline_value(network, t, value);
            if !network.params().is_empty()
                && v != VALUE_UNKNOWN
                && outcome == UpdateOutcome::Stored
            {
                params_changed = network.measure_params(t, v).0 > 0;
            }
            let replaces = match outcome {
                // The table has put it in order; it replaces even a stale mark made later
                // than `at`.
                UpdateOutcome::Stored => true,
                // Not in the table: the planner orders its own copy by time.
                UpdateOutcome::TableFull => false,
                UpdateOutcome::Ignored => return params_changed,
            };
            to_planner(ToPlanner::Measured {
                timeline: t,
                value: v,
                at,
                replaces,
            });
        }
        params_changed
    }

    /// After a restore: the unmeasured timelines declared to revert after a reset (a heater is
    /// off) take that value at `now`, as if measured at the restart.
    pub fn after_reset_values(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        to_planner: &mut impl FnMut(ToPlanner),
    ) {
        for (t, timeline) in network.timelines().iter().enumerate() {
            if let (Some(value), Ok(t)) = (timeline.after_reset, u8::try_from(t)) {
                to_planner(ToPlanner::Measured {
                    timeline: t,
                    value,
                    at: now,
                    replaces: false,
                });
            }
        }
    }

    /// Judges the age of every measured value whose timeline has a staleness bound at `now`:
    /// a value older than its bound is marked stale (it reads unknown), handed to the planner
    /// as unknown from `now`, and reported once. Values never measured keep reading as the
    /// timeline's initial value.
    pub fn judge_ages(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        to_planner: &mut impl FnMut(ToPlanner),
    ) {
        for (t, timeline) in network.timelines().iter().enumerate() {
            let (Some(key), Some(bound), Ok(t)) =
                (timeline.state_key, timeline.stale_after_us, u8::try_from(t))
            else {
                continue;
            };
            let Some(entry) = self.states.get(key).copied() else {
                continue;
            };
            let stale = entry.is_older_than(bound, now);
            if self.states.set_stale(key, stale).is_none() {
                continue;
            }
            if stale {
                to_planner(ToPlanner::Measured {
                    timeline: t,
                    value: VALUE_UNKNOWN,
                    at: now,
                    replaces: true,
                });
                out.telemetry(TelemetryEvent::StateStale {
                    key,
                    measured_at: entry.at,
                    at: now,
                });
            } else {
                // Fresh again with no newer measurement (time stepped back): as measured.
                let value = fitted_value(timeline, entry.value).unwrap_or(VALUE_UNKNOWN);
                to_planner(ToPlanner::Measured {
                    timeline: t,
                    value,
                    at: entry.at,
                    replaces: true,
                });
            }
        }
    }

    /// The first instant after which a fresh measured value will be older than its bound.
    pub fn next_staleness(&self, network: &TaskNetwork) -> Option<MissionTimeUs> {
        network
            .timelines()
            .iter()
            .filter_map(|timeline| {
                let bound = timeline.stale_after_us?;
                let entry = self.states.get(timeline.state_key?)?;
                (!entry.stale).then(|| entry.stale_from(bound))
            })
            .min()
    }

    /// Takes a commit; one the executive has no room for goes back to the planner.
    pub fn accept(&mut self, commit: Commit, to_planner: &mut impl FnMut(ToPlanner)) {
        if !self.executive.accept(commit) {
            to_planner(ToPlanner::Returned {
                instance: commit.instance,
            });
        }
    }

    /// One pass of the executive at `now`; its reports go to the planner.
    pub fn step(
        &mut self,
        network: &TaskNetwork,
        now: MissionTimeUs,
        out: &mut impl Outputs,
        to_planner: &mut impl FnMut(ToPlanner),
    ) {
        let Self {
            executive, states, ..
        } = self;
        executive.step(network, states, now, out, &mut |r: TaskReport| {
            to_planner(ToPlanner::Report(r))
        });
    }

    /// The earliest time the executive needs to run, counting the ages of measured values.
    pub fn next_wakeup(&self, network: &TaskNetwork, now: MissionTimeUs) -> Option<MissionTimeUs> {
        if self.executive.work_pending() {
            return Some(now);
        }
        let executive = self.executive.next_wakeup(network, now).map(|t| t.max(now));
        // A value going stale is a state change the core must see when it happens.
        let staleness = self.next_staleness(network).map(|t| t.max(now));
        [executive, staleness].into_iter().flatten().min()
    }
}

/// `value` as the integer timelines use, or None when it is not of `spec`'s measured type.
pub(crate) fn fitted_value(spec: &TimelineSpec, value: StateValue) -> Option<i64> {
    spec.measured_value_type()
        .is_none_or(|expected| expected.accepts(value))
        .then(|| spec.derived_value(state_value_to_i64(value)))
}
