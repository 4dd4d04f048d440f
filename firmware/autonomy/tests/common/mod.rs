//! Test support shared by the host tests: the seed 003 flyby network built in Rust (the same
//! network `scenarios/tasknets/flyby.toml` describes), a deterministic fake spacecraft, and a
//! lockstep runner that records every decision and can reset the core at any instant.
#![allow(dead_code)]

use autonomy::*;
use fsw_bridge::{
    CommandArgs, CommandStatus, MissionTimeUs, Opcode, StateKey, StateValue, TelemetryEvent,
};

pub use autonomy::scenarios::*;

pub fn flyby_spec() -> NetworkSpec {
    autonomy::scenarios::flyby_spec().expect("flyby fits")
}

/// The network through the uplink: encoded, validated and decoded as the target does, and
/// decoded equal to what was encoded.
pub fn uplinked(spec: NetworkSpec) -> TaskNetwork {
    let network = TaskNetwork::from_spec(spec).unwrap();
    let mut buf = vec![0u8; 1 << 16];
    let len = network.encode(&mut buf).unwrap();
    autonomy::uplink::validate_uplink(&buf[..len]).unwrap();
    let mut decoded = TaskNetwork::EMPTY;
    autonomy::uplink::decode_into(&mut decoded, &buf[..len]).unwrap();
    assert_eq!(decoded, network);
    decoded
}

pub fn flyby_network() -> TaskNetwork {
    TaskNetwork::from_spec(flyby_spec()).expect("flyby network validates")
}

/// Something the core did, with its mission time.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Decision {
    Transition {
        task: u16,
        from: TaskState,
        to: TaskState,
        at: MissionTimeUs,
    },
    Modification {
        kind: u8,
        task: u16,
        template: u16,
        at: MissionTimeUs,
    },
    Dispatch {
        id: u32,
        opcode: Opcode,
        args: CommandArgs,
        at: MissionTimeUs,
    },
    /// The value of `key` measured at `measured_at` went stale at `at`.
    Stale {
        key: StateKey,
        measured_at: MissionTimeUs,
        at: MissionTimeUs,
    },
}

/// Records outputs.
#[derive(Default)]
pub struct Recorder {
    pub now: MissionTimeUs,
    pub decisions: Vec<Decision>,
    pub dispatches: Vec<(u32, Opcode, CommandArgs)>,
}

impl Outputs for Recorder {
    fn dispatch(&mut self, id: u32, opcode: Opcode, args: &CommandArgs) {
        self.decisions.push(Decision::Dispatch {
            id,
            opcode,
            args: args.clone(),
            at: self.now,
        });
        self.dispatches.push((id, opcode, args.clone()));
    }

    fn telemetry(&mut self, event: TelemetryEvent) {
        match event {
            TelemetryEvent::TaskTransition { task, from, to, at } => {
                self.decisions.push(Decision::Transition {
                    task,
                    from: TaskState::from_code(from).expect("known state"),
                    to: TaskState::from_code(to).expect("known state"),
                    at,
                })
            }
            TelemetryEvent::PlanModification {
                kind,
                task,
                template,
                at,
            } => self.decisions.push(Decision::Modification {
                kind,
                task,
                template,
                at,
            }),
            TelemetryEvent::StateStale {
                key,
                measured_at,
                at,
            } => self.decisions.push(Decision::Stale {
                key,
                measured_at,
                at,
            }),
            _ => {}
        }
    }
}

/// What the fake spacecraft feeds: the single core, or the executive partition of the split
/// core.
pub trait Inputs {
    fn on_state_update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs);
    fn on_command_response(&mut self, id: u32, status: CommandStatus);
}

impl Inputs for Autonomy {
    fn on_state_update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        Autonomy::on_state_update(self, key, value, at)
    }
    fn on_command_response(&mut self, id: u32, status: CommandStatus) {
        Autonomy::on_command_response(self, id, status)
    }
}

impl Inputs for autonomy::partitioned::ExecutivePartition {
    fn on_state_update(&mut self, key: StateKey, value: StateValue, at: MissionTimeUs) {
        autonomy::partitioned::ExecutivePartition::on_state_update(self, key, value, at)
    }
    fn on_command_response(&mut self, id: u32, status: CommandStatus) {
        autonomy::partitioned::ExecutivePartition::on_command_response(self, id, status)
    }
}

#[derive(Clone, Debug)]
enum SimEvent {
    State(StateKey, StateValue),
    Response(u32, CommandStatus),
}

/// What the GNC does with one GncAttain command (issue 15's misbehaving subsystems).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GncFate {
    /// TURNING at once; after 15 minutes the commanded attitude and an Ok response.
    Nominal,
    /// Answers Rejected at once; the attitude does not change.
    Reject,
    /// Answers Failed at once; the attitude does not change.
    Fail,
    /// Answers Ok at once but never turns: the attitude does not change.
    AcceptNoSlew,
    /// TURNING at once, then nothing: no response, never arrives.
    NoResponse,
    /// TURNING at once and Ok after 15 minutes, but the attitude stays TURNING.
    WrongEndState,
    /// Nothing at all: no response, no state change.
    Silent,
}

/// What an instrument does with one flyby command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InstrumentFate {
    /// Ok at once.
    Nominal,
    Reject,
    Fail,
    /// Never answers.
    Silent,
}

/// A deterministic fake spacecraft. GNC: on GncAttain it reports TURNING at once and, after
/// 15 minutes, the commanded attitude and an Ok response. Instruments answer Ok at once. A reset
/// loses every pending completion and leaves the attitude UNKNOWN until the next GncAttain.
/// `gnc_fates` and `instrument_fates`, when not empty, say what happens to the n-th command of
/// each kind (cycling through the list) instead. With `republish`, the attitude is also
/// published again periodically, stamped with the time of publication.
pub struct FakeSpacecraft {
    pending: Vec<(MissionTimeUs, u64, SimEvent)>,
    order: u64,
    pub attitude: StateValue,
    pub attitude_at: MissionTimeUs,
    pub gnc_fates: Vec<GncFate>,
    pub instrument_fates: Vec<InstrumentFate>,
    gnc_commands: usize,
    instrument_commands: usize,
    pub republish: Option<Republish>,
}

/// Periodic publication of the attitude: every `every_us` from `next`, except the ones due in
/// `[lost_from, lost_until)`, which are lost on the way.
#[derive(Clone, Copy, Debug)]
pub struct Republish {
    pub every_us: u64,
    pub next: MissionTimeUs,
    pub lost_from: MissionTimeUs,
    pub lost_until: MissionTimeUs,
}

impl Republish {
    /// Every `every_us` from `first`, none lost.
    pub fn every(every_us: u64, first: MissionTimeUs) -> Self {
        Self {
            every_us,
            next: first,
            lost_from: MissionTimeUs::ZERO,
            lost_until: MissionTimeUs::ZERO,
        }
    }
}

impl FakeSpacecraft {
    pub fn new(at: MissionTimeUs) -> Self {
        let mut sc = Self {
            pending: Vec::new(),
            order: 0,
            attitude: StateValue::Enum(INERTIAL),
            attitude_at: at,
            gnc_fates: Vec::new(),
            instrument_fates: Vec::new(),
            gnc_commands: 0,
            instrument_commands: 0,
            republish: None,
        };
        sc.push(
            at,
            SimEvent::State(ATTITUDE_KEY, StateValue::Enum(INERTIAL)),
        );
        sc
    }

    fn push(&mut self, at: MissionTimeUs, e: SimEvent) {
        self.order += 1;
        self.pending.push((at, self.order, e));
    }

    pub fn next_event(&self) -> Option<MissionTimeUs> {
        let republish = self.republish.map(|r| r.next);
        self.pending.iter().map(|p| p.0).chain(republish).min()
    }

    pub fn on_dispatch(&mut self, now: MissionTimeUs, id: u32, opcode: Opcode, args: &CommandArgs) {
        if opcode == GNC_ATTAIN {
            let fate = cycle(&self.gnc_fates, self.gnc_commands).unwrap_or(GncFate::Nominal);
            self.gnc_commands += 1;
            let target = args.first().copied().unwrap_or(0) as u16;
            let turning = SimEvent::State(ATTITUDE_KEY, StateValue::Enum(TURNING));
            let done = now.saturating_add(15 * MIN);
            match fate {
                GncFate::Nominal => {
                    self.push(now, turning);
                    self.push(
                        done,
                        SimEvent::State(ATTITUDE_KEY, StateValue::Enum(target)),
                    );
                    self.push(done, SimEvent::Response(id, CommandStatus::Ok));
                }
                GncFate::Reject => self.push(now, SimEvent::Response(id, CommandStatus::Rejected)),
                GncFate::Fail => self.push(now, SimEvent::Response(id, CommandStatus::Failed(9))),
                GncFate::AcceptNoSlew => self.push(now, SimEvent::Response(id, CommandStatus::Ok)),
                GncFate::NoResponse => self.push(now, turning),
                GncFate::WrongEndState => {
                    self.push(now, turning);
                    self.push(done, SimEvent::Response(id, CommandStatus::Ok));
                }
                GncFate::Silent => {}
            }
        } else {
            let fate = cycle(&self.instrument_fates, self.instrument_commands)
                .unwrap_or(InstrumentFate::Nominal);
            self.instrument_commands += 1;
            let status = match fate {
                InstrumentFate::Nominal => CommandStatus::Ok,
                InstrumentFate::Reject => CommandStatus::Rejected,
                InstrumentFate::Fail => CommandStatus::Failed(9),
                InstrumentFate::Silent => return,
            };
            self.push(now, SimEvent::Response(id, status));
        }
    }

    /// Delivers every event due at or before `now`, in time then issue order.
    pub fn deliver(&mut self, now: MissionTimeUs, autonomy: &mut impl Inputs) {
        self.pending.sort_by_key(|p| (p.0, p.1));
        let due: Vec<_> = self
            .pending
            .iter()
            .filter(|p| p.0 <= now)
            .cloned()
            .collect();
        self.pending.retain(|p| p.0 > now);
        for (at, _, e) in due {
            match e {
                SimEvent::State(key, value) => {
                    if key == ATTITUDE_KEY {
                        self.attitude = value;
                        self.attitude_at = at;
                    }
                    autonomy.on_state_update(key, value, at)
                }
                SimEvent::Response(id, status) => autonomy.on_command_response(id, status),
            }
        }
        if let Some(r) = self.republish.as_mut() {
            if r.next <= now {
                if !(r.lost_from..r.lost_until).contains(&now) {
                    autonomy.on_state_update(ATTITUDE_KEY, self.attitude, now);
                }
                while r.next <= now {
                    r.next = r.next.saturating_add(r.every_us);
                }
            }
        }
    }

    /// Flight software reset at `at`: fault protection drops every command in progress and the
    /// attitude is no longer known.
    pub fn reset(&mut self, at: MissionTimeUs) {
        self.pending.clear();
        self.attitude = StateValue::Enum(UNKNOWN);
        self.attitude_at = at;
    }

    /// The whole state buffer, as published to a core that just restarted.
    pub fn publish_all(&self, autonomy: &mut impl Inputs) {
        autonomy.on_state_update(ATTITUDE_KEY, self.attitude, self.attitude_at);
    }
}

/// The `n`-th entry of `list`, cycling; None when the list is empty.
fn cycle<T: Copy>(list: &[T], n: usize) -> Option<T> {
    list.get(n.checked_rem(list.len())?).copied()
}

/// A reset at `at`, the core being down for `recovery_us` (fault protection).
#[derive(Clone, Copy, Debug)]
pub struct Reset {
    pub at: MissionTimeUs,
    pub recovery_us: u64,
}

/// Lockstep runner: the core, the fake spacecraft and the warm-restart area that survives
/// resets.
pub struct Sim {
    pub autonomy: Box<Autonomy>,
    pub sc: FakeSpacecraft,
    pub area: Vec<u8>,
    pub out: Recorder,
    pub budget: StepBudget,
    pub now: MissionTimeUs,
    pub steps: u64,
    /// The mission time of every step, in order.
    pub step_times: Vec<MissionTimeUs>,
    /// Step with `step_timed` and a clock that advances by one per read, recording the costs.
    pub timed: bool,
    pub costs: Vec<StepCost>,
}

pub const WARM_AREA_LEN: usize = 64 * 1024;

impl Sim {
    pub fn new(network: TaskNetwork, start: MissionTimeUs) -> Self {
        let mut autonomy = Box::new(Autonomy::new());
        autonomy.load_network(network).expect("loads");
        Self {
            autonomy,
            sc: FakeSpacecraft::new(start),
            area: vec![0u8; WARM_AREA_LEN],
            out: Recorder::default(),
            budget: StepBudget::UNLIMITED,
            now: start,
            steps: 0,
            step_times: Vec::new(),
            timed: false,
            costs: Vec::new(),
        }
    }

    pub fn flyby() -> Self {
        Self::new(flyby_network(), hm(9, 50))
    }

    fn step_at(&mut self, t: MissionTimeUs) {
        self.now = t;
        self.out.now = t;
        self.sc.deliver(t, &mut *self.autonomy);
        if self.timed {
            let mut reads = 0u64;
            let (_, cost) = self
                .autonomy
                .step_timed(t, self.budget, &mut self.out, &mut || {
                    reads += 1;
                    reads
                });
            self.costs.push(cost);
        } else {
            self.autonomy.step(t, self.budget, &mut self.out);
        }
        self.steps += 1;
        self.step_times.push(t);
        for (id, opcode, args) in std::mem::take(&mut self.out.dispatches) {
            self.sc.on_dispatch(t, id, opcode, &args);
        }
        let mut area = WarmRestartArea::new(&mut self.area);
        self.autonomy
            .checkpoint_to(&mut area)
            .expect("checkpoint fits");
    }

    /// Runs until `end`, applying `resets` (sorted by time) when they come due.
    pub fn run(&mut self, end: MissionTimeUs, resets: &[Reset]) {
        let mut resets = resets.to_vec();
        self.step_at(self.now);
        loop {
            let mut next = [self.autonomy.next_wakeup(), self.sc.next_event()]
                .into_iter()
                .flatten()
                .min();
            if let Some(r) = resets.first() {
                if next.is_none_or(|n| r.at <= n) {
                    next = Some(r.at);
                }
            }
            let Some(next) = next else { break };
            if next > end {
                break;
            }
            if let Some(r) = resets.first().copied() {
                if r.at == next {
                    resets.remove(0);
                    self.reset(r);
                    continue;
                }
            }
            assert!(next >= self.now, "time went backwards");
            if self.steps > 5_000 {
                for l in decision_lines(self).iter().rev().take(30) {
                    eprintln!("{l}");
                }
                panic!("runaway at {}", fmt_time(next));
            }
            self.step_at(next);
        }
    }

    /// Warm reset: the core's RAM state is gone except the warm-restart area; fault protection
    /// runs for `recovery_us` with the attitude UNKNOWN; then the core restores and sees the
    /// state buffer.
    pub fn reset(&mut self, r: Reset) {
        self.sc.reset(r.at);
        *self.autonomy = Autonomy::new(); // RAM state gone
        let restart = r.at.saturating_add(r.recovery_us);
        let area = WarmRestartArea::new(&mut self.area);
        self.autonomy
            .restore_from(&area)
            .expect("a whole checkpoint survives");
        self.sc.publish_all(&mut *self.autonomy);
        self.step_at(restart);
    }

    /// Ground id of the definition of `instance`, from the decision log.
    pub fn template_of(&self, instance: u16) -> u16 {
        if instance < FIRST_INSTANCE_ID {
            return instance;
        }
        self.out
            .decisions
            .iter()
            .find_map(|d| match d {
                Decision::Modification {
                    task,
                    template,
                    kind,
                    ..
                } if *task == instance
                    && (*kind == PlanModificationKind::Add as u8
                        || *kind == PlanModificationKind::Restart as u8) =>
                {
                    Some(*template)
                }
                _ => None,
            })
            .unwrap_or(u16::MAX)
    }

    /// Every command the core dispatched for a task, as (mission time, ground id of the task's
    /// definition, instance), in order. A dispatch is the task's: the executive reports the
    /// task's move to Dispatched right after it.
    pub fn task_dispatches(&self) -> Vec<(MissionTimeUs, u16, u16)> {
        let mut out = Vec::new();
        let mut pending: Option<MissionTimeUs> = None;
        for d in &self.out.decisions {
            match *d {
                Decision::Dispatch { at, .. } => pending = Some(at),
                Decision::Transition {
                    task,
                    to: TaskState::Dispatched,
                    at,
                    ..
                } if pending == Some(at) => {
                    out.push((at, self.template_of(task), task));
                    pending = None;
                }
                _ => pending = None,
            }
        }
        out
    }

    /// Per task definition (ground id), the commands sent in each run: a run of a definition
    /// ends when one of its instances completes (what clears the planner's failure counts).
    pub fn dispatches_per_run(&self) -> std::collections::BTreeMap<u16, Vec<u32>> {
        let mut runs: std::collections::BTreeMap<u16, Vec<u32>> = Default::default();
        let mut pending: Option<MissionTimeUs> = None;
        for d in &self.out.decisions {
            match *d {
                Decision::Dispatch { at, .. } => {
                    pending = Some(at);
                    continue;
                }
                Decision::Transition {
                    task,
                    to: TaskState::Dispatched,
                    at,
                    ..
                } if pending == Some(at) => {
                    let r = runs
                        .entry(self.template_of(task))
                        .or_insert_with(|| vec![0]);
                    if let Some(last) = r.last_mut() {
                        *last += 1;
                    }
                }
                Decision::Transition {
                    task,
                    to: TaskState::Completed,
                    ..
                } => runs
                    .entry(self.template_of(task))
                    .or_insert_with(|| vec![0])
                    .push(0),
                _ => {}
            }
            pending = None;
        }
        runs
    }

    /// Dispatches per task definition (ground id).
    pub fn dispatches_per_definition(&self) -> std::collections::BTreeMap<u16, u32> {
        let mut counts = std::collections::BTreeMap::new();
        for (_, def, _) in self.task_dispatches() {
            *counts.entry(def).or_insert(0) += 1;
        }
        counts
    }

    /// The most steps the core ran at one mission time.
    pub fn max_steps_at_one_time(&self) -> usize {
        let mut best = 0;
        let mut run = 0;
        let mut last = None;
        for &t in &self.step_times {
            run = if last == Some(t) { run + 1 } else { 1 };
            last = Some(t);
            best = best.max(run);
        }
        best
    }

    /// The as-executed timeline: (definition name, instance, start, end, final state) for every
    /// task that started, ordered by start then instance.
    pub fn as_executed(&self) -> Vec<Executed> {
        let network = flyby_network();
        let mut rows: Vec<Executed> = Vec::new();
        for d in &self.out.decisions {
            let Decision::Transition { task, to, at, .. } = *d else {
                continue;
            };
            let starts = matches!(to, TaskState::Dispatched | TaskState::Running);
            let pos = rows.iter().position(|r| r.instance == task);
            match pos {
                None if starts => {
                    let def = network
                        .def_of_id(self.template_of(task))
                        .expect("known definition");
                    rows.push(Executed {
                        name: network.task(def).unwrap().name.to_string(),
                        instance: task,
                        start: at,
                        end: None,
                        outcome: to,
                    })
                }
                Some(i) => {
                    if to.is_terminal() {
                        rows[i].end = Some(at);
                    }
                    rows[i].outcome = to;
                }
                None => {}
            }
        }
        rows.sort_by_key(|r| (r.start, r.instance));
        rows
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Executed {
    pub name: String,
    pub instance: u16,
    pub start: MissionTimeUs,
    pub end: Option<MissionTimeUs>,
    pub outcome: TaskState,
}

pub fn fmt_time(t: MissionTimeUs) -> String {
    let s = t.0 / SEC;
    if t.0.is_multiple_of(SEC) {
        format!("{:02}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
    } else {
        format!(
            "{:02}:{:02}:{:02}.{:06}",
            s / 3600,
            (s / 60) % 60,
            s % 60,
            t.0 % SEC
        )
    }
}

/// The as-executed timeline as lines "start-end name outcome", for exact comparison.
pub fn timeline_lines(rows: &[Executed]) -> Vec<String> {
    rows.iter()
        .map(|r| {
            format!(
                "{}-{} {} {:?}",
                fmt_time(r.start),
                r.end.map(fmt_time).unwrap_or_else(|| "..".into()),
                r.name,
                r.outcome
            )
        })
        .collect()
}

pub fn decision_lines(sim: &Sim) -> Vec<String> {
    sim.out
        .decisions
        .iter()
        .map(|d| match d {
            Decision::Transition { task, from, to, at } => format!(
                "{} task {:#06x} {:?} -> {:?}",
                fmt_time(*at),
                task,
                from,
                to
            ),
            Decision::Modification {
                kind,
                task,
                template,
                at,
            } => format!(
                "{} mod {} task {:#06x} template {}",
                fmt_time(*at),
                kind,
                task,
                template
            ),
            Decision::Dispatch {
                id,
                opcode,
                args,
                at,
            } => format!(
                "{} dispatch {} {:#06x} {:?}",
                fmt_time(*at),
                id,
                opcode.0,
                args
            ),
            Decision::Stale {
                key,
                measured_at,
                at,
            } => format!(
                "{} stale key {} measured {}",
                fmt_time(*at),
                key.0,
                fmt_time(*measured_at)
            ),
        })
        .collect()
}
