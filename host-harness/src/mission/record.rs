//! What happened in a mission: every decision the target reported, the as-executed task
//! instances reconstructed from them, the spacecraft's actual states, resets, metrics; and the
//! evaluation of a scenario's expectations against all that.
use std::collections::BTreeMap;

use autonomy::{PlanModificationKind, TaskNetwork, TaskState, FIRST_INSTANCE_ID};
use fsw_bridge::{
    CommandArgs, MissionTimeUs, Opcode, ResetCause, StateKey, StateValue, TelemetryEvent,
};
use serde::Serialize;

use super::plan::Outcome;
use crate::time::fmt_time;

/// One decision of the autonomy, as reported by the target, with its mission time.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub enum Decision {
    Dispatch {
        at: u64,
        id: u32,
        opcode: u16,
        args: Vec<i32>,
    },
    Transition {
        at: u64,
        task: u16,
        from: u8,
        to: u8,
    },
    PlanModification {
        at: u64,
        kind: u8,
        task: u16,
        template: u16,
    },
    /// The value of state key `key`, measured at `measured_at`, was older than its staleness
    /// bound at `at`: the autonomy reads it as unknown from then on.
    StateStale { at: u64, key: u16, measured_at: u64 },
}

/// One task instance as executed.
#[derive(Clone, Debug, Serialize)]
pub struct Instance {
    pub id: u16,
    /// Ground id of its task definition.
    pub definition: u16,
    pub name: String,
    /// When the planner handed it to the executive (first commit).
    pub committed_at: Option<u64>,
    /// Start of execution: the dispatch of its command (Running for a no-op task).
    pub started_at: Option<u64>,
    pub ended_at: Option<u64>,
    /// Final state code (TaskState::code), if it finished.
    pub outcome: Option<u8>,
    /// How it came to be: requested, added, restarted.
    pub origin: String,
    /// A reset of the flight software cut its execution short at this time (its real end:
    /// `ended_at` is set to it).
    pub interrupted_at: Option<u64>,
    /// Its definition sends a command (it executes on a subsystem, so a reset interrupts it).
    pub commanded: bool,
    /// What the autonomy decided about it after the restart that followed the interruption
    /// (e.g. aborted, when its maintain constraint no longer held): time and state code.
    pub after_restart: Option<(u64, u8)>,
}

impl Instance {
    /// How it ended (an instance cut short by a reset is interrupted, whatever the autonomy
    /// decided after the restart).
    pub fn outcome(&self) -> Outcome {
        if self.interrupted_at.is_some() {
            return Outcome::Interrupted;
        }
        match self.outcome.and_then(TaskState::from_code) {
            None if self.started_at.is_none() => Outcome::NotRun,
            None => Outcome::NotFinished,
            Some(state) => outcome_of(state).unwrap_or(Outcome::NotFinished),
        }
    }

    pub fn outcome_name(&self) -> &'static str {
        self.outcome().name()
    }

    /// Why it failed, when it did: "command_rejected".
    pub fn failure_cause(&self) -> Option<&'static str> {
        match self.outcome.and_then(TaskState::from_code) {
            Some(TaskState::Failed(kind)) if self.interrupted_at.is_none() => {
                Some(failure_name(kind))
            }
            _ => None,
        }
    }

    /// One line: "Instrument Flyby (requested): 10:15:00 to 10:30:00, interrupted by the
    /// reset (aborted after the restart, at 10:33:00)".
    pub fn describe(&self) -> String {
        let span = match (self.started_at, self.ended_at) {
            (Some(s), Some(e)) => format!(
                "{} to {}",
                fmt_time(MissionTimeUs(s)),
                fmt_time(MissionTimeUs(e))
            ),
            (Some(s), None) => format!("from {}", fmt_time(MissionTimeUs(s))),
            (None, Some(e)) => format!("never started, ended {}", fmt_time(MissionTimeUs(e))),
            (None, None) => "never started".to_string(),
        };
        let after = self
            .after_restart_text()
            .map(|a| format!(" ({a} after the restart)"))
            .unwrap_or_default();
        format!(
            "{} ({}): {span}, {}{after}",
            self.name,
            self.origin,
            self.outcome_name()
        )
    }

    /// What the autonomy decided about an interrupted instance after the restart: "aborted at
    /// 10:33:00".
    pub fn after_restart_text(&self) -> Option<String> {
        let (at, code) = self.after_restart?;
        Some(format!(
            "{} at {}",
            TaskState::from_code(code)
                .and_then(outcome_of)
                .map_or("changed", Outcome::name),
            fmt_time(MissionTimeUs(at))
        ))
    }
}

/// A failure kind as reports and scenario files name it.
pub fn failure_name(kind: autonomy::FailureKind) -> &'static str {
    use autonomy::FailureKind::*;
    match kind {
        PreTimeout => "pre_timeout",
        ResponseTimeout => "response_timeout",
        CommandFailed => "command_failed",
        CommandRejected => "command_rejected",
        MaintainViolation => "maintain_violation",
        Unschedulable => "unschedulable",
        PostConditionNotMet => "post_condition",
        Interrupted => "interrupted",
    }
}

/// The planner stopped responding to one cause of failure of a task definition (its
/// `max_repairs` bound for that cause was crossed).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct GaveUp {
    pub at: u64,
    pub task: String,
    pub cause: &'static str,
}

/// The outcome a terminal task state means.
fn outcome_of(state: TaskState) -> Option<Outcome> {
    Some(match state {
        TaskState::Completed => Outcome::Completed,
        TaskState::Skipped => Outcome::Skipped,
        TaskState::Deleted => Outcome::Deleted,
        TaskState::Failed(autonomy::FailureKind::MaintainViolation) => Outcome::Aborted,
        TaskState::Failed(_) => Outcome::Failed,
        _ => return None,
    })
}

/// A reset the host caused (or the target reported).
#[derive(Clone, Debug, Serialize)]
pub struct ResetRecord {
    pub at: u64,
    pub kind: String,
    pub recovery_us: u64,
    pub restart_at: u64,
    pub reset_cause: String,
    /// Guest ticks from the reset vector to ready (the boot this reset caused; see
    /// [`BootRecord::boot_to_ready_ticks`]), when measured.
    pub boot_to_ready_ticks: Option<u64>,
    /// Guest ticks the flight application spent after its restore until the repaired plan was
    /// committed (`flight_app::metric::RECOVERY_TICKS`), when measured.
    pub recovery_ticks: Option<u64>,
    /// Where the target restored its plan from ("warm-restart area", "non-volatile memory"),
    /// with the checkpoint's sequence number; None if it came up without a plan.
    pub restored_from: Option<String>,
    #[serde(skip)]
    restored_sequence: Option<u64>,
    /// The planner partition's part, on a target that runs the planner in a partition of its
    /// own: its start (`BOOT_PLANNER_START_TICKS`) plus its CPU from its restore to the end of
    /// its first window with nothing pending (`PLANNER_RECOVERY_TICKS`), when measured.
    pub planner_recovery_ticks: Option<u64>,
    #[serde(skip)]
    planner_start_ticks: Option<u64>,
    /// Reset vector to repaired plan committed: `boot_to_ready_ticks + recovery_ticks`, plus
    /// `planner_recovery_ticks` where the planner has a partition of its own (the CPU of both
    /// partitions on the way to the repaired plan).
    pub reset_recovery_ticks: Option<u64>,
}

/// The autonomy step of one frame, in guest ticks (emulated target): the whole step and its
/// planner and executive parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct StepCost {
    /// Frames granted before this one.
    pub frame: u64,
    pub step: u64,
    pub planner: Option<u64>,
    pub executive: Option<u64>,
}

/// One boot of the target: the first one, and one per reset.
#[derive(Clone, Debug, Serialize)]
pub struct BootRecord {
    /// Mission time of the reset that caused it (the mission start for the first boot).
    pub at: u64,
    pub reset_cause: String,
    /// Guest ticks of CPU from the reset vector to ready (the flight application restored or
    /// cold-started and able to take a grant): the kernel's boot plus the executive
    /// partition's CPU (`kernel_config::abi::metric::BOOT_TO_READY_TICKS`). Emulated target
    /// only.
    pub boot_to_ready_ticks: Option<u64>,
    /// The kernel's part of it: reset vector to the start of the schedule (reset stub with the
    /// RAM image checked or copied from ROM, board bring-up, kernel set-up).
    pub kernel_boot_ticks: Option<u64>,
    /// Where the boot's CPU went, part by part (emulated target).
    pub breakdown: BootBreakdown,
}

/// The parts of a boot's CPU, in guest ticks (`kernel_config::abi::metric::BOOT_*` and
/// `flight_app::metric::BOOT_SECURITY_TICKS`, `RESTORE_CHECK_TICKS`, `RESTORE_DECODE_TICKS`):
/// in order, they make up boot to ready, less a few hundred ticks of metric sends and system
/// calls between them. Emulated target only; the restore's parts only when it restored.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct BootBreakdown {
    /// How the reset stub made the RAM image good: "verified" (checked in RAM after a warm
    /// reset), "copied" (from ROM: power-on, new firmware), "repaired" (copied from ROM because
    /// the RAM copy failed its checksum).
    pub image: Option<String>,
    /// Reset vector to the RAM image checked or copied.
    pub stub_image_ticks: Option<u64>,
    /// The stub's clearing of `.bss` and the hashed page table.
    pub stub_clear_ticks: Option<u64>,
    /// Board bring-up and kernel set-up, to the start of the schedule.
    pub kernel_init_ticks: Option<u64>,
    /// The executive partition's start (its statics zeroed).
    pub executive_start_ticks: Option<u64>,
    /// The flight application put in place and the memories' record headers probed.
    pub executive_init_ticks: Option<u64>,
    /// The security area read and its key checked.
    pub security_ticks: Option<u64>,
    /// The checkpoint records read and their CRCs checked, the memory chosen.
    pub restore_check_ticks: Option<u64>,
    /// The checkpoint decoded and validated, the restart adjustments.
    pub restore_decode_ticks: Option<u64>,
}

impl BootBreakdown {
    /// (label, ticks) of the parts measured, in boot order.
    pub fn parts(&self) -> Vec<(&'static str, u64)> {
        [
            ("image", self.stub_image_ticks),
            ("clears", self.stub_clear_ticks),
            ("kernel set-up", self.kernel_init_ticks),
            ("executive start", self.executive_start_ticks),
            ("executive init", self.executive_init_ticks),
            ("security area", self.security_ticks),
            ("record check", self.restore_check_ticks),
            ("decode", self.restore_decode_ticks),
        ]
        .into_iter()
        .filter_map(|(label, ticks)| ticks.map(|t| (label, t)))
        .collect()
    }
}

/// Everything recorded during a mission.
#[derive(Clone, Debug, Default, Serialize)]
pub struct MissionRecord {
    pub decisions: Vec<Decision>,
    pub instances: Vec<Instance>,
    /// Labelled happenings in order: "<task> added", "<task> started", "warm reset", ...
    pub labels: Vec<(u64, String)>,
    pub resets: Vec<ResetRecord>,
    /// Every boot, in order (one more than there are resets).
    pub boots: Vec<BootRecord>,
    /// Every frame's autonomy step cost, in order (emulated target).
    #[serde(skip)]
    pub step_costs: Vec<StepCost>,
    /// The planner partition's last window cost, for the frame whose step comes next.
    #[serde(skip)]
    pending_planner_ticks: Option<u64>,
    /// Actual spacecraft states as published, per state key.
    #[serde(skip)]
    pub states: BTreeMap<StateKey, Vec<(MissionTimeUs, StateValue)>>,
    /// Named metrics (maxima over the run unless the name says otherwise).
    pub metrics: BTreeMap<String, u64>,
    /// Frames granted.
    pub frames: u64,
    /// Injected faults, in order.
    pub faults: Vec<(u64, String)>,
    /// Where the autonomy gave up on a task and why, in order.
    pub gave_up: Vec<GaveUp>,
    /// Commands sent per task definition (ground id): every dispatch, retries included.
    pub commands_per_definition: BTreeMap<u16, u32>,
    /// Every authenticated uplink and ground command the host sent, with the target's answer.
    pub authenticated: Vec<AuthenticatedRecord>,
}

/// One authenticated uplink or ground command the host sent, and what the target said.
#[derive(Clone, Debug, Serialize)]
pub struct AuthenticatedRecord {
    /// Mission time (µs) it was sent.
    pub at: u64,
    /// "task-network uplink", "ground command SetHold(2)", "forged uplink", ...
    pub what: String,
    /// Its anti-replay sequence number.
    pub sequence: u32,
    /// None: accepted; else the refusal's name ("bad-mac", "replay", ...).
    pub refused: Option<String>,
    /// For a deliberately bad message: the refusal the target owed it.
    pub expected_refusal: Option<String>,
}

impl AuthenticatedRecord {
    /// A deliberately bad message that was not refused as it should have been.
    pub fn attack_not_refused(&self) -> bool {
        self.expected_refusal.is_some() && self.refused != self.expected_refusal
    }
}

/// Instructions per timebase tick under `-icount shift=2` (4 ns per instruction, 16.6 MHz).
pub const INSTRUCTIONS_PER_TICK_X1000: u64 = 15_060;

/// Guest instructions in `ticks` timebase ticks (see [`INSTRUCTIONS_PER_TICK_X1000`]).
pub fn to_instructions(ticks: u64) -> u64 {
    ticks * INSTRUCTIONS_PER_TICK_X1000 / 1000
}

impl MissionRecord {
    fn instance_mut(&mut self, id: u16, network: &TaskNetwork) -> &mut Instance {
        if let Some(i) = self.instances.iter().position(|i| i.id == id) {
            return &mut self.instances[i];
        }
        let (definition, origin, name) = if id < FIRST_INSTANCE_ID {
            (id, "requested".to_string(), task_name(network, id))
        } else {
            // Its PlanModification (which names the template) has not been received.
            (
                u16::MAX,
                "added".to_string(),
                format!("added instance {id:#06x} (template not reported)"),
            )
        };
        self.instances.push(Instance {
            id,
            definition,
            name,
            committed_at: None,
            started_at: None,
            ended_at: None,
            outcome: None,
            origin,
            interrupted_at: None,
            commanded: id < FIRST_INSTANCE_ID && has_command(network, id),
            after_restart: None,
        });
        self.instances.last_mut().expect("just pushed")
    }

    /// Every security count at 0, so that an expectation on one holds when nothing happened.
    pub fn start_security_counts(&mut self) {
        for m in super::metrics::METRICS.iter() {
            if m.name == "authenticated_accepted" || m.name.starts_with("refused_") {
                self.metrics.entry(m.name.to_string()).or_insert(0);
            }
        }
    }

    /// An authenticated message and the target's answer (`refused`: None when accepted).
    pub fn authenticated(&mut self, entry: AuthenticatedRecord) {
        let at = MissionTimeUs(entry.at);
        let metric = match &entry.refused {
            None => "authenticated_accepted".to_string(),
            Some(reason) => super::metrics::refused_metric(reason),
        };
        *self.metrics.entry(metric).or_insert(0) += 1;
        let outcome = match &entry.refused {
            None => "accepted".to_string(),
            Some(reason) => format!("refused ({reason})"),
        };
        self.label(at, format!("{} #{} {outcome}", entry.what, entry.sequence));
        self.authenticated.push(entry);
    }

    pub fn label(&mut self, at: MissionTimeUs, text: impl Into<String>) {
        self.labels.push((at.0, text.into()));
    }

    pub fn dispatch(&mut self, at: MissionTimeUs, id: u32, opcode: Opcode, args: &CommandArgs) {
        self.decisions.push(Decision::Dispatch {
            at: at.0,
            id,
            opcode: opcode.0,
            args: args.to_vec(),
        });
    }

    /// A telemetry event from the target.
    pub fn telemetry(&mut self, event: &TelemetryEvent, network: &TaskNetwork) {
        match *event {
            TelemetryEvent::TaskTransition { task, from, to, at } => {
                self.decisions.push(Decision::Transition {
                    at: at.0,
                    task,
                    from,
                    to,
                });
                let inst = self.instance_mut(task, network);
                let state = TaskState::from_code(to);
                match state {
                    Some(TaskState::Committed) if inst.committed_at.is_none() => {
                        inst.committed_at = Some(at.0)
                    }
                    // Execution starts with the dispatch (a no-op task goes straight to
                    // Running); a retry does not move the start.
                    Some(TaskState::Dispatched | TaskState::Running)
                        if inst.started_at.is_none() =>
                    {
                        inst.started_at = Some(at.0)
                    }
                    _ => {}
                }
                if state == Some(TaskState::Dispatched) {
                    let def = inst.definition;
                    *self.commands_per_definition.entry(def).or_insert(0) += 1;
                }
                let inst = self.instance_mut(task, network);
                match state {
                    // An instance a reset interrupted keeps its real end; the autonomy's later
                    // verdict on it is recorded beside it.
                    Some(s) if s.is_terminal() && inst.interrupted_at.is_some() => {
                        inst.after_restart.get_or_insert((at.0, to));
                    }
                    Some(s) if s.is_terminal() => {
                        inst.ended_at = Some(at.0);
                        inst.outcome = Some(to);
                    }
                    _ => {}
                }
                let name = inst.name.clone();
                let verb = match state {
                    Some(TaskState::Committed) => Some("committed"),
                    Some(TaskState::Dispatched) => Some("dispatched"),
                    Some(TaskState::Running) => Some("started"),
                    Some(TaskState::Completed) => Some("completed"),
                    Some(TaskState::Skipped) => Some("skipped"),
                    Some(TaskState::Deleted) => Some("deleted"),
                    Some(TaskState::Failed(autonomy::FailureKind::MaintainViolation)) => {
                        Some("aborted")
                    }
                    Some(TaskState::Failed(_)) => Some("failed"),
                    _ => None,
                };
                if let Some(verb) = verb {
                    self.label(at, format!("{name} {verb}"));
                }
            }
            TelemetryEvent::PlanModification {
                kind,
                task,
                template,
                at,
            } => {
                self.decisions.push(Decision::PlanModification {
                    at: at.0,
                    kind,
                    task,
                    template,
                });
                let name = task_name(network, template);
                if let Some(cause) = autonomy::telemetry::gave_up_cause(kind) {
                    let cause = failure_name(cause);
                    self.label(at, format!("{name} gave up on {cause}"));
                    self.gave_up.push(GaveUp {
                        at: at.0,
                        task: name,
                        cause,
                    });
                    return;
                }
                let verb = match kind {
                    k if k == PlanModificationKind::Add as u8 => "added",
                    k if k == PlanModificationKind::Delete as u8 => "deleted from the plan",
                    k if k == PlanModificationKind::Move as u8 => "moved",
                    k if k == PlanModificationKind::Restart as u8 => "restarted",
                    k if k == PlanModificationKind::NetworkLoaded as u8 => {
                        self.label(at, "task network loaded");
                        return;
                    }
                    k if k == PlanModificationKind::Restored as u8 => {
                        self.label(at, "plan restored from checkpoint");
                        return;
                    }
                    _ => "modified",
                };
                if task != 0 {
                    let inst = self.instance_mut(task, network);
                    inst.commanded = has_command(network, template);
                    inst.definition = template;
                    inst.name = name.clone();
                    inst.origin = verb.to_string();
                }
                self.label(at, format!("{name} {verb}"));
            }
            TelemetryEvent::StateStale {
                key,
                measured_at,
                at,
            } => {
                self.decisions.push(Decision::StateStale {
                    at: at.0,
                    key: key.0,
                    measured_at: measured_at.0,
                });
                let name = network
                    .timeline_of_key(key)
                    .and_then(|t| network.timeline(t))
                    .map_or_else(|| format!("state key {}", key.0), |t| t.name.to_string());
                self.label(
                    at,
                    format!("{name} stale (measured at {})", fmt_time(measured_at)),
                );
            }
            TelemetryEvent::Metric { id, value } => self.metric_event(id, value),
            TelemetryEvent::HealthMonitor {
                partition,
                kind,
                address,
                action,
            } => {
                self.faults.push((
                    0,
                    format!("health monitor: partition {partition} kind {kind} at {address:#x}, action {action}"),
                ));
            }
        }
    }

    /// A metric from the target: what it says about the steps, the resets and the boots, and
    /// the report metrics it is reduced to ([`super::metrics::FROM_WIRE`], named from the
    /// telemetry dictionary: a measured cost's largest value is `max_<name>`).
    fn metric_event(&mut self, id: u16, value: u64) {
        use super::metrics::{self, Reduce};
        use flight_app::metric;
        use kernel_config::abi::metric as platform;
        match id {
            metric::STEP_TICKS => {
                // A planner partition's window comes before the executive's second one and
                // reports first; a single core reports its planner part after its step.
                let planner = self.pending_planner_ticks.take();
                self.step_costs.push(StepCost {
                    frame: self.frames,
                    step: value,
                    planner,
                    executive: None,
                })
            }
            metric::PLANNER_TICKS => {
                self.pending_planner_ticks = Some(value);
            }
            metric::EXECUTIVE_TICKS => {
                if let Some(c) = self.step_costs.last_mut() {
                    c.executive.get_or_insert(value);
                }
            }
            metric::RECOVERY_TICKS => {
                if let Some(r) = self.resets.last_mut() {
                    r.recovery_ticks.get_or_insert(value);
                }
                self.reset_recovered();
            }
            // Every boot but the first is a reset's.
            platform::BOOT_PLANNER_START_TICKS if self.boots.len() > 1 => {
                if let Some(r) = self.resets.last_mut() {
                    r.planner_start_ticks.get_or_insert(value);
                }
            }
            metric::PLANNER_RECOVERY_TICKS => {
                if let Some(r) = self.resets.last_mut() {
                    if let Some(start) = r.planner_start_ticks {
                        r.planner_recovery_ticks.get_or_insert(start + value);
                    }
                }
                self.reset_recovered();
            }
            metric::RESTORED_SEQUENCE => {
                if let Some(r) = self.resets.last_mut() {
                    r.restored_sequence = Some(value);
                }
            }
            metric::RESTORED_FROM => {
                if let Some(r) = self.resets.last_mut() {
                    let memory = fsw_bridge::dictionary::metric(id)
                        .and_then(|m| m.value_name(value))
                        .unwrap_or("unknown memory");
                    r.restored_from = Some(match r.restored_sequence {
                        Some(seq) => format!("{memory}, checkpoint {seq}"),
                        None => memory.to_string(),
                    });
                }
            }
            metric::BOOT_SECURITY_TICKS => self.boot_part(value, |b| &mut b.security_ticks),
            metric::RESTORE_CHECK_TICKS => self.boot_part(value, |b| &mut b.restore_check_ticks),
            metric::RESTORE_DECODE_TICKS => self.boot_part(value, |b| &mut b.restore_decode_ticks),
            platform::BOOT_STUB_IMAGE_TICKS => self.boot_part(value, |b| &mut b.stub_image_ticks),
            platform::BOOT_STUB_CLEAR_TICKS => self.boot_part(value, |b| &mut b.stub_clear_ticks),
            platform::BOOT_KERNEL_INIT_TICKS => self.boot_part(value, |b| &mut b.kernel_init_ticks),
            platform::BOOT_EXECUTIVE_START_TICKS => {
                self.boot_part(value, |b| &mut b.executive_start_ticks)
            }
            platform::BOOT_EXECUTIVE_INIT_TICKS => {
                self.boot_part(value, |b| &mut b.executive_init_ticks)
            }
            platform::BOOT_IMAGE => {
                if let Some(boot) = self.boots.last_mut() {
                    let how = fsw_bridge::dictionary::metric(id)
                        .and_then(|m| m.value_name(value))
                        .unwrap_or("unknown");
                    boot.breakdown.image.get_or_insert_with(|| how.to_string());
                }
            }
            platform::KERNEL_BOOT_TICKS => {
                if let Some(boot) = self.boots.last_mut() {
                    boot.kernel_boot_ticks.get_or_insert(value);
                }
            }
            platform::BOOT_TO_READY_TICKS => {
                if let Some(boot) = self.boots.last_mut() {
                    boot.boot_to_ready_ticks.get_or_insert(value);
                    // Every boot but the first is a reset's.
                    if self.boots.len() > 1 {
                        if let Some(r) = self.resets.last_mut() {
                            r.boot_to_ready_ticks.get_or_insert(value);
                        }
                        self.reset_recovered();
                    }
                }
            }
            _ => {}
        }
        let Some(w) = metrics::FROM_WIRE.iter().find(|w| w.id == id) else {
            return;
        };
        let power_on = self
            .boots
            .last()
            .map(|b| b.reset_cause == crate::scenario::cause_name(ResetCause::PowerOn));
        let name = match (w.reduce, power_on) {
            (Reduce::Max, _) => metrics::report_name(id),
            (Reduce::Last, _) => {
                if let Some(name) = metrics::report_name(id) {
                    self.metrics.insert(name, value);
                }
                return;
            }
            (Reduce::MaxOverWarmBoots, Some(false)) => metrics::warm_boot_name(id),
            (Reduce::MaxPerBootKind, Some(power_on)) => metrics::boot_kind_name(id, power_on),
            (Reduce::MaxOverWarmBoots | Reduce::MaxPerBootKind, _) => None,
        };
        let Some(name) = name else {
            return;
        };
        if w.instructions {
            self.max_metric(&metrics::instructions_name(&name), to_instructions(value));
        }
        self.max_metric(&name, value);
    }

    fn max_metric(&mut self, name: &str, value: u64) {
        let slot = self.metrics.entry(name.to_string()).or_insert(0);
        *slot = (*slot).max(value);
    }

    /// Once both halves of the last reset's recovery are known: reset vector to repaired plan.
    fn reset_recovered(&mut self) {
        let Some(r) = self.resets.last_mut() else {
            return;
        };
        // Where the planner has a partition (its start was reported), its part is needed too.
        let planner = match (r.planner_start_ticks, r.planner_recovery_ticks) {
            (None, _) => Some(0),
            (Some(_), measured) => measured,
        };
        if let (Some(boot), Some(recovery), Some(planner), None) = (
            r.boot_to_ready_ticks,
            r.recovery_ticks,
            planner,
            r.reset_recovery_ticks,
        ) {
            let total = boot + recovery + planner;
            r.reset_recovery_ticks = Some(total);
            self.max_metric("max_reset_recovery_ticks", total);
            self.max_metric("max_reset_recovery_instructions", to_instructions(total));
        }
    }

    /// The target booted (the mission's first boot; resets record theirs in [`Self::reset`]).
    pub fn boot(&mut self, at: MissionTimeUs, cause: ResetCause) {
        self.boots.push(BootRecord {
            at: at.0,
            reset_cause: crate::scenario::cause_name(cause).into(),
            boot_to_ready_ticks: None,
            kernel_boot_ticks: None,
            breakdown: BootBreakdown::default(),
        });
    }

    /// A part of the last boot's breakdown, recorded with it (the warm boots' maxima are
    /// [`super::metrics::Reduce::MaxOverWarmBoots`]).
    fn boot_part(&mut self, value: u64, slot: fn(&mut BootBreakdown) -> &mut Option<u64>) {
        if let Some(boot) = self.boots.last_mut() {
            slot(&mut boot.breakdown).get_or_insert(value);
        }
    }

    /// The spacecraft published `value` for `key` at `at`.
    pub fn state(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        self.states.entry(key).or_default().push((at, value));
    }

    /// The spacecraft's value of `key` at `t` (last publication at or before `t`).
    pub fn state_at(&self, key: StateKey, t: MissionTimeUs) -> Option<StateValue> {
        self.states
            .get(&key)?
            .iter()
            .take_while(|(at, _)| *at <= t)
            .last()
            .map(|(_, v)| *v)
    }

    pub fn reset(&mut self, at: MissionTimeUs, kind: &str, recovery_us: u64, cause: ResetCause) {
        self.resets.push(ResetRecord {
            at: at.0,
            kind: kind.into(),
            recovery_us,
            restart_at: at.0 + recovery_us,
            reset_cause: crate::scenario::cause_name(cause).into(),
            boot_to_ready_ticks: None,
            recovery_ticks: None,
            planner_recovery_ticks: None,
            planner_start_ticks: None,
            restored_from: None,
            restored_sequence: None,
            reset_recovery_ticks: None,
        });
        self.boot(at, cause);
        self.label(at, kind.to_string());
        // Whatever was executing a command stopped with the flight software (commands in
        // flight are lost with it). Tasks without a command are the planner's bookkeeping
        // (a request held open): they carry on across the restart.
        for inst in &mut self.instances {
            if inst.started_at.is_some() && inst.ended_at.is_none() && inst.commanded {
                inst.ended_at = Some(at.0);
                inst.interrupted_at = Some(at.0);
                let label = format!("{} interrupted", inst.name);
                self.labels.push((at.0, label));
            }
        }
    }

    /// The frame count as a metric (at the end of a run).
    pub fn frames_metric(&mut self) {
        self.metrics.insert("frames".into(), self.frames);
    }

    /// Decision lines ("10:30:00 Instrument Flyby aborted"), for the terminal and diffs.
    pub fn timeline_lines(&self) -> Vec<String> {
        self.labels
            .iter()
            .map(|(at, l)| format!("{} {l}", fmt_time(MissionTimeUs(*at))))
            .collect()
    }
}

/// True if the task definition with ground id `id` sends a command.
fn has_command(network: &TaskNetwork, id: u16) -> bool {
    network
        .tasks()
        .iter()
        .any(|t| t.id == id && t.command.is_some())
}

/// Name of a task definition by ground id.
pub fn task_name(network: &TaskNetwork, id: u16) -> String {
    network
        .tasks()
        .iter()
        .find(|t| t.id == id)
        .map(|t| t.name.as_str().to_string())
        .unwrap_or_else(|| format!("task id {id} (not in the task network)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metric(rec: &mut MissionRecord, id: u16, value: u64) {
        rec.telemetry(&TelemetryEvent::Metric { id, value }, &TaskNetwork::EMPTY);
    }

    #[test]
    fn boot_to_ready_goes_to_its_boot_and_a_reset_adds_its_recovery() {
        use flight_app::metric::{PLANNER_RECOVERY_TICKS, PLANNER_TICKS, RECOVERY_TICKS};
        use kernel_config::abi::metric::{BOOT_PLANNER_START_TICKS, BOOT_TO_READY_TICKS};
        let mut rec = MissionRecord::default();
        rec.boot(MissionTimeUs(0), ResetCause::PowerOn);
        metric(
            &mut rec,
            kernel_config::abi::metric::KERNEL_BOOT_TICKS,
            30_000,
        );
        metric(&mut rec, BOOT_TO_READY_TICKS, 40_000);
        metric(&mut rec, PLANNER_TICKS, 500);
        metric(&mut rec, PLANNER_TICKS, 300);
        rec.reset(MissionTimeUs(10), "warm reset", 5, ResetCause::Warm);
        metric(&mut rec, BOOT_TO_READY_TICKS, 70_000);
        assert_eq!(rec.resets[0].reset_recovery_ticks, None);
        metric(&mut rec, RECOVERY_TICKS, 20_000);
        rec.reset(MissionTimeUs(20), "warm reset", 5, ResetCause::Warm);
        metric(&mut rec, BOOT_TO_READY_TICKS, 71_000);
        metric(&mut rec, RECOVERY_TICKS, 10_000);

        let boots: Vec<Option<u64>> = rec.boots.iter().map(|b| b.boot_to_ready_ticks).collect();
        assert_eq!(boots, [Some(40_000), Some(70_000), Some(71_000)]);
        assert_eq!(rec.boots[0].kernel_boot_ticks, Some(30_000));
        assert_eq!(rec.boots[1].kernel_boot_ticks, None);
        assert_eq!(rec.resets[0].reset_recovery_ticks, Some(90_000));
        assert_eq!(rec.resets[1].reset_recovery_ticks, Some(81_000));
        // A target with a planner partition: its start and its recovery count too, and the
        // total waits for them.
        rec.reset(MissionTimeUs(30), "warm reset", 5, ResetCause::Warm);
        metric(&mut rec, BOOT_TO_READY_TICKS, 60_000);
        metric(&mut rec, BOOT_PLANNER_START_TICKS, 1_000);
        metric(&mut rec, RECOVERY_TICKS, 10_000);
        assert_eq!(rec.resets[2].reset_recovery_ticks, None);
        metric(&mut rec, PLANNER_RECOVERY_TICKS, 2_000);
        assert_eq!(rec.resets[2].planner_recovery_ticks, Some(3_000));
        assert_eq!(rec.resets[2].reset_recovery_ticks, Some(73_000));
        let m = &rec.metrics;
        assert_eq!(m["max_boot_to_ready_ticks_power_on"], 40_000);
        assert_eq!(m["max_boot_to_ready_ticks_warm"], 71_000);
        assert_eq!(m["max_planner_ticks"], 500);
        assert_eq!(m["max_recovery_ticks"], 20_000);
        assert_eq!(m["max_reset_recovery_ticks"], 90_000);
        assert_eq!(m["max_reset_recovery_instructions"], 90_000 * 15_060 / 1000);
    }

    #[test]
    fn the_boot_breakdown_goes_to_its_boot_and_warm_boots_to_their_maxima() {
        use kernel_config::abi::{boot_image, metric as k};
        let mut rec = MissionRecord::default();
        rec.boot(MissionTimeUs(0), ResetCause::PowerOn);
        metric(&mut rec, k::BOOT_STUB_IMAGE_TICKS, 22_000);
        metric(&mut rec, k::BOOT_IMAGE, boot_image::COPIED);
        metric(&mut rec, k::BOOT_EXECUTIVE_START_TICKS, 800);
        rec.reset(MissionTimeUs(10), "warm reset", 5, ResetCause::Warm);
        metric(&mut rec, k::BOOT_STUB_IMAGE_TICKS, 16_000);
        metric(&mut rec, k::BOOT_STUB_CLEAR_TICKS, 1_500);
        metric(&mut rec, k::BOOT_IMAGE, boot_image::VERIFIED);
        metric(&mut rec, flight_app::metric::RESTORE_DECODE_TICKS, 9_000);
        rec.reset(MissionTimeUs(20), "warm reset", 5, ResetCause::Warm);
        metric(&mut rec, k::BOOT_STUB_IMAGE_TICKS, 22_100);
        metric(&mut rec, k::BOOT_IMAGE, boot_image::REPAIRED);

        let b = |i: usize| &rec.boots[i].breakdown;
        assert_eq!(b(0).image.as_deref(), Some("copied"));
        assert_eq!(b(0).parts(), [("image", 22_000), ("executive start", 800)]);
        assert_eq!(b(1).image.as_deref(), Some("verified"));
        assert_eq!(
            b(1).parts(),
            [("image", 16_000), ("clears", 1_500), ("decode", 9_000)]
        );
        assert_eq!(b(2).image.as_deref(), Some("repaired"));
        // The power-on boot's copy is not a warm boot's.
        assert_eq!(rec.metrics["max_warm_boot_image_ticks"], 22_100);
        assert_eq!(rec.metrics["max_warm_boot_clear_ticks"], 1_500);
        assert_eq!(rec.metrics["max_warm_boot_restore_decode_ticks"], 9_000);
        assert!(!rec
            .metrics
            .contains_key("max_warm_boot_executive_start_ticks"));
        for name in rec.metrics.keys() {
            assert!(
                crate::mission::metrics::lookup(name).is_some(),
                "{name} is not declared"
            );
        }
    }

    #[test]
    fn a_stale_report_is_a_decision_labelled_with_its_timeline() {
        let network = autonomy::scenarios::flyby_network().unwrap();
        let mut rec = MissionRecord::default();
        let (measured_at, at) = (MissionTimeUs(36_900_000_000), MissionTimeUs(37_500_000_001));
        rec.telemetry(
            &TelemetryEvent::StateStale {
                key: StateKey(1),
                measured_at,
                at,
            },
            &network,
        );
        assert_eq!(
            rec.decisions,
            [Decision::StateStale {
                at: at.0,
                key: 1,
                measured_at: measured_at.0
            }]
        );
        assert_eq!(
            rec.labels,
            [(at.0, "GncAttitude stale (measured at 10:15:00)".to_string())]
        );
    }
}
