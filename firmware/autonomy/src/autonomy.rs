//! The integration API: [`Autonomy`] owns the task network, the planner, the executive and the
//! core's copy of the state buffer, and runs them in order on every [`Autonomy::step`].
//!
//! Wiring for the firmware (and the host harness):
//! 1. Place one `Autonomy` statically (`Autonomy::new()` is `const`). It holds every byte of
//!    plan and execution state; nothing is allocated.
//! 2. On boot, offer it the warm-restart area: [`Autonomy::restore_from`]. `Ok` means the task
//!    network, the plan and the executive state are back as of the last checkpoint; `Err` means
//!    a cold start (wait for an uplink).
//! 3. Feed it inputs as they arrive: [`Autonomy::load_uplink`] for a whole task-network uplink
//!    (on `Err`, send `UplinkNak { reason: err.code.code() }`; the running plan is untouched),
//!    [`Autonomy::on_state_update`] for every state-buffer value (after a restore, publish the
//!    whole current state buffer before the first step), [`Autonomy::on_command_response`] for
//!    every command response.
//! 4. Once per frame call [`Autonomy::step`] with the granted mission time, a planner budget and
//!    an [`Outputs`] sink: it dispatches commands and emits telemetry through the sink.
//!    [`Autonomy::step_timed`] does the same and also times the planner's and the executive's
//!    parts of the step with a clock the caller gives (the firmware's partition CPU time).
//! 5. After the step, [`Autonomy::checkpoint_to`] the warm-restart area, and report
//!    [`Autonomy::next_wakeup`] to the time driver.
//!
//! Measured values age: each state-buffer entry keeps the mission time it was measured at, and
//! at the start of every step the core marks stale every value older than its timeline's
//! bound ([`TimelineSpec::stale_after_us`]). A stale value reads unknown to the executive
//! (constraints, conditions) and to the planner (the timeline is unknown from that step on,
//! as if its owner had published unknown then), is reported once as
//! [`TelemetryEvent::StateStale`], and is a state change like any other: MAINTAIN constraints
//! on it are violated, the planner repairs. A newer measurement makes it fresh again. The
//! instant a value goes stale is a wake-up ([`Autonomy::next_wakeup`]), so the core reacts at
//! exactly that instant in lockstep. Ages are part of the checkpoint: a value restored after a
//! long recovery goes stale when its bound says, not a bound after the restart.
//!
//! The two loops: the planner ([`crate::planner::Planner`], the planning loop) and the
//! control loop ([`ControlLoop`]: the executive and the state buffer copy) share nothing but
//! the task network; everything else they exchange is a [`crate::interface`] message
//! ([`ToPlanner`]: measurements, task reports, commits given back; commits the other way).
//! This wrapper hands each message over at once and runs the planner within the step; the
//! firmware can run each loop in its own partition with a port in between.
use crate::capacity::{MAX_COMMITTED, MAX_MISSION_TIME_US};
use crate::checkpoint::{
    self, CheckpointError, PayloadDefect, PayloadError, PayloadSite, Record, RestoreInfo,
    RestoredState, WarmRestartArea, WrittenRecord,
};
use crate::condition::{StateTable, StateTableInPlace};
use crate::control::ControlLoop;
use crate::executive::{Executive, ExecutiveInPlace};
use crate::in_place;
use crate::interface::{Commit, Outputs, ToPlanner};
use crate::model::*;
use crate::plan::PlanEntry;
use crate::planner::{Planner, PlannerInPlace};
use crate::telemetry::PlanModificationKind;
use crate::uplink::{self, ValidationError};
use fsw_bridge::{CommandStatus, MissionTimeUs, StateKey, StateValue, TelemetryEvent};

/// How much planning one step may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepBudget {
    /// Validity checks the planner may spend (see [`crate::planner`]); the job in progress
    /// when the budget runs out finishes, then the planner yields.
    pub planner_checks: u32,
}

impl StepBudget {
    /// Run the planner cycle to completion.
    pub const UNLIMITED: Self = Self {
        planner_checks: u32::MAX,
    };
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepReport {
    pub planner_checks: u32,
    /// The planner stopped on its budget: call `step` again soon (`next_wakeup` says now).
    pub planner_pending: bool,
    /// A planner cycle ended in this step, this long (mission time, µs) after the step that
    /// started it: 0 when it fitted in one step (see
    /// [`crate::planner::PlannerStepReport::cycle_latency_us`]).
    pub planning_latency_us: Option<u64>,
}

/// CPU the two halves of one step took, in the units of the clock given to
/// [`Autonomy::step_timed`] (0 for [`Autonomy::step`]). The step is three passes: the executive,
/// the planner, the executive again; the clock is read four times, around them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepCost {
    /// Both executive passes (command responses, start/maintain/end checks, timeouts,
    /// completions, task reports to the planner; then starting what was committed for now),
    /// and the step's own bookkeeping before the first one.
    pub executive: u64,
    /// The planner pass: task reports and contingencies, its anytime cycle within the budget,
    /// and its commits (the executive's acceptance of each commit included).
    pub planner: u64,
}

/// Why a network could not be loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadError {
    /// The uplink failed validation (nothing changed).
    Invalid(ValidationError),
    /// The executive still owns tasks of the running plan (or, split over two partitions,
    /// the previous network is still on its way to the planner); load when it is idle.
    Busy,
    /// The network's image is larger than the partitions exchange
    /// ([`crate::partitioned::MAX_NETWORK_IMAGE`]).
    TooLarge,
}

/// The autonomy core: task network + planner + control loop (executive, state buffer copy).
pub struct Autonomy {
    network: TaskNetwork,
    planner: Planner,
    control: ControlLoop,
    now: MissionTimeUs,
    loaded: bool,
    /// Emit a `Restored` plan modification at the next step.
    restored: Option<u32>,
}

impl Default for Autonomy {
    fn default() -> Self {
        Self::new()
    }
}

impl Autonomy {
    /// Makes this core what [`Autonomy::new`] is, in place (`*self = Self::new()` copies a
    /// constant image of the whole core, 24 KiB of the firmware image that the reset stub's
    /// image check reads at every boot).
    pub fn reset(&mut self) {
        self.network.clear();
        self.planner.reset();
        self.control.reset();
        self.now = MissionTimeUs::ZERO;
        self.loaded = false;
        self.restored = None;
    }

    /// An empty core (no network). `const`, so it can live in a `static`.
    pub const fn new() -> Self {
        Self {
            network: TaskNetwork::EMPTY,
            planner: Planner::new(),
            control: ControlLoop::new(),
            now: MissionTimeUs::ZERO,
            loaded: false,
            restored: None,
        }
    }

    /// Loads a validated network and starts a new plan from its requested tasks (scheduled at
    /// the next step). Refused while the executive still owns tasks.
    pub fn load_network(&mut self, network: TaskNetwork) -> Result<(), LoadError> {
        if !self.control.executive.entries().is_empty() {
            return Err(LoadError::Busy);
        }
        self.network = network;
        self.after_load();
        Ok(())
    }

    /// Validates and loads a binary uplink ([`crate::uplink`] format). On any error nothing
    /// changes; `err.code.code()` is the reason to report to the ground.
    pub fn load_uplink(&mut self, bytes: &[u8]) -> Result<(), LoadError> {
        uplink::validate_uplink(bytes).map_err(LoadError::Invalid)?;
        if !self.control.executive.entries().is_empty() {
            return Err(LoadError::Busy);
        }
        uplink::decode_into(&mut self.network, bytes).map_err(LoadError::Invalid)?;
        self.after_load();
        Ok(())
    }

    fn after_load(&mut self) {
        let Self {
            network,
            planner,
            control,
            ..
        } = self;
        planner.load(network);
        self.loaded = true;
        control.after_load(network, &mut |m| planner.receive(m));
    }

    /// The loaded network.
    pub fn network(&self) -> &TaskNetwork {
        &self.network
    }

    /// The plan (every instance the planner still holds).
    pub fn plan(&self) -> &[PlanEntry] {
        self.planner.entries()
    }

    pub fn planner(&self) -> &Planner {
        &self.planner
    }

    pub fn planner_mut(&mut self) -> (&TaskNetwork, &mut Planner) {
        (&self.network, &mut self.planner)
    }

    pub fn executive(&self) -> &Executive {
        &self.control.executive
    }

    pub fn states(&self) -> &StateTable {
        &self.control.states
    }

    /// The control loop (executive and state buffer copy).
    pub fn control(&self) -> &ControlLoop {
        &self.control
    }

    /// State updates whose value did not fit the timeline's kind
    /// ([`TimelineSpec::measured_value_type`]); each was taken as unknown.
    pub fn state_type_mismatches(&self) -> u32 {
        self.control.state_type_mismatches
    }

    /// The state key of the last such update.
    pub fn last_state_type_mismatch(&self) -> Option<StateKey> {
        self.control.last_state_type_mismatch
    }

    /// Mission time of the last step.
    pub fn now(&self) -> MissionTimeUs {
        self.now
    }

    /// Records a state-buffer value (measured at `at`). Values of the wrong type for their
    /// timeline are taken as unknown and counted in `state_type_mismatches`. An update older
    /// than the one the core holds is ignored; a newer one is fresh until the next step judges
    /// its age. An update measured after [`MAX_MISSION_TIME_US`] is ignored (no time the core
    /// keeps may be later; see [`checkpoint::MAX_RESTORED_TIME_US`]).
    pub fn on_state_update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        if at.0 > MAX_MISSION_TIME_US {
            return;
        }
        let Self {
            network,
            planner,
            control,
            ..
        } = self;
        // A changed model parameter is in the network the planner plans with, and the
        // measurement that changed it makes the planner run a cycle.
        control.on_state_update(network, key, value, at, &mut |m| planner.receive(m));
    }

    /// Records the response to command `id`; processed at the next step, in arrival order.
    pub fn on_command_response(&mut self, id: u32, status: CommandStatus) {
        self.control.executive.on_command_response(id, status);
    }

    /// Runs one step at `now`: the executive (responses, state checks, timeouts, completions),
    /// the planner (reports and contingencies, then its cycle within `budget`, then commits),
    /// and the executive again so that tasks committed for `now` start at once.
    pub fn step(
        &mut self,
        now: MissionTimeUs,
        budget: StepBudget,
        out: &mut impl Outputs,
    ) -> StepReport {
        self.step_timed(now, budget, out, &mut || 0).0
    }

    /// [`Autonomy::step`], timing its planner and executive parts with `clock` (a CPU clock:
    /// the firmware's partition CPU time). A `now` after [`MAX_MISSION_TIME_US`] is taken as
    /// that time. The clock is only read, never consulted, so the
    /// decisions are exactly those of `step`.
    pub fn step_timed(
        &mut self,
        now: MissionTimeUs,
        budget: StepBudget,
        out: &mut impl Outputs,
        clock: &mut impl FnMut() -> u64,
    ) -> (StepReport, StepCost) {
        let t0 = clock();
        // Mission time stops at the latest time an uplink may name, so that every time the
        // core keeps stays in range (see `checkpoint::MAX_RESTORED_TIME_US`).
        let now = MissionTimeUs(now.0.min(MAX_MISSION_TIME_US));
        self.now = now;
        let Self {
            network,
            planner,
            control,
            ..
        } = self;
        let mut to_planner = |m: ToPlanner| planner.receive(m);
        if let Some(seq) = self.restored.take() {
            out.telemetry(restored_event(seq, now));
            control.after_reset_values(network, now, &mut to_planner);
        }
        if !self.loaded {
            let cost = StepCost {
                executive: clock().wrapping_sub(t0),
                planner: 0,
            };
            return (StepReport::default(), cost);
        }
        control.judge_ages(network, now, out, &mut to_planner);
        control.step(network, now, out, &mut to_planner);
        let t1 = clock();
        // The planner's commits reach the control loop after its pass, as they would through a
        // port; the planner commits no more than its count of the executive's room.
        let mut commits: heapless::Vec<Commit, MAX_COMMITTED> = heapless::Vec::new();
        let mut overflow: heapless::Vec<u16, MAX_COMMITTED> = heapless::Vec::new();
        let report = planner.step(
            network,
            now,
            budget.planner_checks,
            &mut |c| {
                if commits.push(c).is_err() {
                    let _ = overflow.push(c.instance);
                }
            },
            out,
        );
        // By reference: a list moved into its iterator is copied whole (its capacity).
        for &instance in &overflow {
            planner.on_returned(instance);
        }
        for &c in &commits {
            control.accept(c, &mut |m| planner.receive(m));
        }
        let t2 = clock();
        control.step(network, now, out, &mut |m| planner.receive(m));
        let t3 = clock();
        let cost = StepCost {
            executive: t1.wrapping_sub(t0).wrapping_add(t3.wrapping_sub(t2)),
            planner: t2.wrapping_sub(t1),
        };
        let report = StepReport {
            planner_checks: report.checks,
            planner_pending: report.work_pending,
            planning_latency_us: report.cycle_latency_us,
        };
        (report, cost)
    }

    /// The earliest mission time at which `step` must run again (if no input arrives first),
    /// or `None` when only input can create work.
    pub fn next_wakeup(&self) -> Option<MissionTimeUs> {
        if !self.loaded {
            return None;
        }
        if self.control.executive.work_pending() || self.restored.is_some() {
            return Some(self.now);
        }
        let planner = self.planner.next_wakeup(&self.network, self.now);
        let control = self.control.next_wakeup(&self.network, self.now);
        [planner, control].into_iter().flatten().min()
    }

    /// Writes the whole plan and execution state as a new record in `area` (the slot not
    /// holding the newest record). Returns the record's sequence number.
    pub fn checkpoint_to(&self, area: &mut WarmRestartArea<'_>) -> Result<u32, CheckpointError> {
        self.checkpoint_record_to(area)
            .map(|written| written.sequence)
    }

    /// As [`Autonomy::checkpoint_to`], and says where the record went and which bytes of the
    /// area it wrote.
    pub fn checkpoint_record_to(
        &self,
        area: &mut WarmRestartArea<'_>,
    ) -> Result<WrittenRecord, CheckpointError> {
        self.checkpoint_record_after(area, None)
    }

    /// As [`Autonomy::checkpoint_record_to`], numbered after both `area`'s newest record and
    /// `newest_elsewhere` (see [`WarmRestartArea::write_after`]): for a caller that keeps the
    /// same checkpoints in several memories under one sequence number.
    pub fn checkpoint_record_after(
        &self,
        area: &mut WarmRestartArea<'_>,
        newest_elsewhere: Option<u32>,
    ) -> Result<WrittenRecord, CheckpointError> {
        area.write_after(newest_elsewhere, |buf| self.encode_state(buf))
    }

    /// Encodes the whole plan and execution state (the checkpoint payload) into `buf`;
    /// returns the length used, or `None` if it does not fit.
    pub fn encode_state(&self, buf: &mut [u8]) -> Option<usize> {
        let mut len = 0usize;
        let meta = ImageMeta {
            loaded: self.loaded,
            now: self.now,
            state_type_mismatches: self.control.state_type_mismatches,
            last_state_type_mismatch: self.control.last_state_type_mismatch,
        };
        len += postcard::to_slice(&meta, buf.get_mut(len..)?).ok()?.len();
        // Network length prefix, then the network in uplink format.
        let prefix_at = len;
        len += 4;
        let net_len = self.network.encode(buf.get_mut(len..)?).ok()?;
        buf.get_mut(prefix_at..prefix_at + 4)?
            .copy_from_slice(&u32::try_from(net_len).ok()?.to_be_bytes());
        len += net_len;
        len += postcard::to_slice(&self.planner, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.control.executive, buf.get_mut(len..)?)
            .ok()?
            .len();
        len += postcard::to_slice(&self.control.states, buf.get_mut(len..)?)
            .ok()?
            .len();
        Some(len)
    }

    /// Restores the state saved by the newest whole record in `area` whose payload decodes and
    /// validates ([`checkpoint::check_restored`]); a refused newest record falls back to the
    /// other one. On success the next
    /// [`Autonomy::step`] (after the current state buffer has been published with
    /// `on_state_update`) sets the unmeasured timelines that declare an `after_reset` value to
    /// it, ends every commanded task that was running at the checkpoint (aborted if a MAINTAIN
    /// constraint no longer holds, else [`crate::FailureKind::Interrupted`]: never completed),
    /// checks the other tasks against the present state, applies contingencies and repairs the
    /// plan. Retry counts, back-offs and failure counts come back with the rest, and so does
    /// every state-buffer value with the time it was measured: one not published again goes
    /// stale at the first step past its bound, however long the recovery took. On error
    /// `self` is a cold, empty core; [`CheckpointError::BadPayload`] carries why the newest
    /// record was refused.
    pub fn restore_from(
        &mut self,
        area: &WarmRestartArea<'_>,
    ) -> Result<RestoreInfo, CheckpointError> {
        let mut refused = None;
        // Newest claim first; a CRC is computed only for a record tried (usually one).
        for slot in area.candidates().into_iter().flatten() {
            let Some((sequence, payload)) = area.record(slot) else {
                continue;
            };
            match self.restore_record(Record {
                slot,
                sequence,
                payload,
            }) {
                Ok(info) => return Ok(info),
                Err(e) => {
                    refused.get_or_insert(e);
                }
            }
        }
        Err(refused.map_or(CheckpointError::NoValidRecord, CheckpointError::BadPayload))
    }

    /// Restores from one record the caller already found whole (with
    /// [`WarmRestartArea::record`] or [`checkpoint::records`]; its CRC is not checked again):
    /// see [`Autonomy::restore_from`]; a caller with several memories picks the record. On
    /// error, why its payload was refused, and `self` is a cold, empty core.
    pub fn restore_record(&mut self, record: Record<'_>) -> Result<RestoreInfo, PayloadError> {
        if let Err(e) = self.decode_state(record.payload) {
            self.reset();
            return Err(e);
        }
        self.planner.after_restore();
        self.control.executive.after_restore();
        self.restored = Some(record.sequence);
        Ok(RestoreInfo {
            slot: record.slot,
            sequence: record.sequence,
            payload_len: u32::try_from(record.payload.len()).unwrap_or(u32::MAX),
        })
    }

    /// Replaces the state with one encoded by [`Autonomy::encode_state`] (no restart
    /// adjustments; [`Autonomy::restore_from`] adds them), after checking it like an uplink
    /// ([`checkpoint::check_restored`]). On error, why the bytes were refused; `self` may then
    /// be partly overwritten.
    pub fn decode_state(&mut self, payload: &[u8]) -> Result<(), PayloadError> {
        use PayloadDefect::*;
        let fail = |defect, site| PayloadError::new(defect, site);
        let (meta, rest): (ImageMeta, _) =
            postcard::take_from_bytes(payload).map_err(|_| fail(Decode, PayloadSite::Meta))?;
        let net_len = rest
            .get(..4)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_be_bytes)
            .and_then(|n| usize::try_from(n).ok())
            .ok_or(fail(Decode, PayloadSite::Network))?;
        let net_bytes = rest
            .get(4..)
            .and_then(|r| r.get(..net_len))
            .ok_or(fail(Decode, PayloadSite::Network))?;
        // Checked as an uplink is (a checkpoint is trusted no more than its CRC and format
        // version), but decoded once.
        uplink::decode_then_validate(&mut self.network, net_bytes)
            .map_err(|e| fail(InvalidNetwork(e), PayloadSite::Network))?;
        let rest = rest.get(4 + net_len..).unwrap_or(&[]);
        // The planner, the executive and the state table are decoded in place, not built as
        // values and moved in.
        let rest = in_place::take_in_place(rest, PlannerInPlace(&mut self.planner))
            .ok_or(fail(Decode, PayloadSite::Planner))?;
        let rest = in_place::take_in_place(rest, ExecutiveInPlace(&mut self.control.executive))
            .ok_or(fail(Decode, PayloadSite::Executive))?;
        let rest = in_place::take_in_place(rest, StateTableInPlace(&mut self.control.states))
            .ok_or(fail(Decode, PayloadSite::States))?;
        if !rest.is_empty() {
            return Err(fail(TrailingBytes, PayloadSite::End));
        }
        checkpoint::check_restored(&RestoredState {
            loaded: meta.loaded,
            now: meta.now,
            network: &self.network,
            planner: &self.planner,
            executive: &self.control.executive,
            states: &self.control.states,
        })?;
        self.loaded = meta.loaded;
        self.now = meta.now;
        self.control.state_type_mismatches = meta.state_type_mismatches;
        self.control.last_state_type_mismatch = meta.last_state_type_mismatch;
        Ok(())
    }
}

#[derive(serde::Serialize, serde::Deserialize)]
struct ImageMeta {
    loaded: bool,
    now: MissionTimeUs,
    state_type_mismatches: u32,
    last_state_type_mismatch: Option<StateKey>,
}

/// The `Restored` plan modification: the core restarted from checkpoint record `sequence`
/// (its low 16 bits in the `template` field).
pub(crate) fn restored_event(sequence: u32, at: MissionTimeUs) -> TelemetryEvent {
    TelemetryEvent::PlanModification {
        kind: PlanModificationKind::Restored as u8,
        task: 0,
        template: sequence as u16,
        at,
    }
}
