//! Test support shared by the host tests: the seed 003 flyby network built in Rust (the same
//! network `scenarios/tasknets/flyby.toml` describes), a deterministic fake spacecraft, and a
//! lockstep runner that records every decision and can reset the core at any instant.
#![allow(dead_code)]

use autonomy::*;
use fsw_bridge::{
    CommandArgs, CommandStatus, MissionTimeUs, Opcode, StateKey, StateValue, TelemetryEvent,
};

pub const SEC: u64 = 1_000_000;
pub const MIN: u64 = 60 * SEC;

/// Mission time of `hh:mm` on the flyby day (epoch 2028-040T00:00 is mission time 0).
pub const fn hm(h: u64, m: u64) -> MissionTimeUs {
    MissionTimeUs((h * 60 + m) * MIN)
}

pub const ATTITUDE_KEY: StateKey = StateKey(1);
pub const INERTIAL: u16 = 0;
pub const NADIR: u16 = 1;
pub const TURNING: u16 = 2;
pub const UNKNOWN: u16 = 3;
pub const EARTH: u16 = 4;

pub const GNC_ATTAIN: Opcode = Opcode(0x0101);
pub const INSTRUMENT_FLYBY: Opcode = Opcode(0x0201);
pub const INSTRUMENT_DEGRADED_FLYBY: Opcode = Opcode(0x0202);

pub const TL_ATTITUDE: u8 = 0;
pub const TL_REQUEST: u8 = 1;
pub const TL_GNC_SLEW: u8 = 2;
pub const TL_INSTRUMENT: u8 = 3;

pub const ID_GNC_NADIR: u16 = 1;
pub const ID_REQUEST: u16 = 2;
pub const ID_FLYBY: u16 = 3;
pub const ID_GNC_EARTH: u16 = 4;
pub const ID_GNC_NADIR_TEMPLATE: u16 = 11;
pub const ID_DEGRADED_TEMPLATE: u16 = 12;

const fn mask(values: &[u16]) -> u32 {
    let mut m = 0;
    let mut i = 0;
    while i < values.len() {
        m |= 1 << values[i];
        i += 1;
    }
    m
}

fn name(s: &str) -> Name {
    Name::try_from(s).expect("name fits")
}

fn args(a: &[i32]) -> CommandArgs {
    CommandArgs::from_slice(a).expect("args fit")
}

fn control(response_timeout_us: u64, pre_wait_timeout_us: u64) -> ControlSpec {
    ControlSpec {
        start_condition: None,
        maintain_condition: None,
        skip_condition: None,
        pre_wait_timeout_us,
        response_timeout_us,
        max_retries: 0,
        on_failure_command: None,
    }
}

fn no_permissions() -> Permissions {
    Permissions {
        may_move: false,
        may_delete: false,
        may_add: heapless::Vec::new(),
    }
}

fn constraint(
    when: ConstraintWhen,
    timeline: u8,
    require: Requirement,
    start_offset_us: i64,
) -> ConstraintSpec {
    ConstraintSpec {
        when,
        timeline,
        require,
        start_offset_us,
        end_offset_us: 0,
    }
}

fn impact(when: ImpactWhen, timeline: u8, effect: Effect) -> ImpactSpec {
    ImpactSpec {
        when,
        timeline,
        effect,
        start_offset_us: 0,
        end_offset_us: 0,
    }
}

/// A GncAttain task: PRE impact TURNING, POST impact `target`, MAINTAIN claim on the GNC slew,
/// MAINTAIN constraint "TURNING or target" from one second after the start (the GNC reports
/// TURNING within a second of the command).
fn gnc_attain(
    id: u16,
    task_name: &str,
    role: TaskRole,
    target: u16,
    earliest: MissionTimeUs,
    latest_start: MissionTimeUs,
) -> TaskSpec {
    let mut t = TaskSpec {
        id,
        name: name(task_name),
        priority: 50,
        role,
        command: Some(CommandSpec {
            opcode: GNC_ATTAIN,
            args: args(&[i32::from(target)]),
        }),
        duration_us: 15 * MIN,
        min_duration_us: 15 * MIN,
        earliest_start: earliest,
        latest_start,
        latest_end: MissionTimeUs::MAX,
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: control(16 * MIN, MIN),
        contingencies: heapless::Vec::new(),
        permissions: no_permissions(),
    };
    t.constraints
        .push(constraint(
            ConstraintWhen::Maintain,
            TL_ATTITUDE,
            Requirement::OneOf {
                mask: mask(&[TURNING, target]),
            },
            SEC as i64,
        ))
        .unwrap();
    t.impacts
        .push(impact(
            ImpactWhen::Pre,
            TL_ATTITUDE,
            Effect::Assign(i64::from(TURNING)),
        ))
        .unwrap();
    t.impacts
        .push(impact(
            ImpactWhen::Post,
            TL_ATTITUDE,
            Effect::Assign(i64::from(target)),
        ))
        .unwrap();
    t.impacts
        .push(impact(ImpactWhen::Maintain, TL_GNC_SLEW, Effect::Claim))
        .unwrap();
    t
}

/// The seed 003 flyby network (Figs 4-8).
pub fn flyby_spec() -> NetworkSpec {
    let mut n = NetworkSpec::new(3, PlannerConfig::DEFAULT);
    n.timelines
        .push(TimelineSpec {
            name: name("GncAttitude"),
            kind: TimelineKind::State {
                value_count: 5,
                initial: INERTIAL,
            },
            state_key: Some(ATTITUDE_KEY),
        })
        .unwrap();
    n.timelines
        .push(TimelineSpec {
            name: name("FlybyRequest"),
            kind: TimelineKind::Cumulative {
                initial: 0,
                min: 0,
                max: 8,
            },
            state_key: None,
        })
        .unwrap();
    n.timelines
        .push(TimelineSpec {
            name: name("GncSlew"),
            kind: TimelineKind::Claimable,
            state_key: None,
        })
        .unwrap();
    n.timelines
        .push(TimelineSpec {
            name: name("Instrument"),
            kind: TimelineKind::Claimable,
            state_key: None,
        })
        .unwrap();

    n.tasks
        .push(gnc_attain(
            ID_GNC_NADIR,
            "GncAttain NADIR",
            TaskRole::Requested,
            NADIR,
            hm(10, 0),
            hm(10, 0),
        ))
        .unwrap();

    let mut request = TaskSpec {
        id: ID_REQUEST,
        name: name("Instrument Flyby Request"),
        priority: 10,
        role: TaskRole::Requested,
        command: None,
        duration_us: 50 * MIN,
        min_duration_us: 50 * MIN,
        earliest_start: hm(10, 15),
        latest_start: hm(10, 15),
        latest_end: hm(11, 5),
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: control(0, 0),
        contingencies: heapless::Vec::new(),
        permissions: no_permissions(),
    };
    request
        .constraints
        .push(constraint(
            ConstraintWhen::Maintain,
            TL_REQUEST,
            Requirement::Range { min: 1, max: 8 },
            0,
        ))
        .unwrap();
    n.tasks.push(request).unwrap();

    let mut flyby = TaskSpec {
        id: ID_FLYBY,
        name: name("Instrument Flyby"),
        priority: 40,
        role: TaskRole::Requested,
        command: Some(CommandSpec {
            opcode: INSTRUMENT_FLYBY,
            args: args(&[]),
        }),
        duration_us: 50 * MIN,
        min_duration_us: 5 * MIN,
        earliest_start: hm(10, 15),
        latest_start: hm(11, 0),
        latest_end: hm(11, 5),
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: control(MIN, MIN),
        contingencies: heapless::Vec::new(),
        permissions: Permissions {
            may_move: true,
            may_delete: false,
            may_add: heapless::Vec::from_slice(&[ID_GNC_NADIR_TEMPLATE, ID_DEGRADED_TEMPLATE])
                .unwrap(),
        },
    };
    let nadir = Requirement::OneOf {
        mask: mask(&[NADIR]),
    };
    flyby
        .constraints
        .push(constraint(ConstraintWhen::Pre, TL_ATTITUDE, nadir, 0))
        .unwrap();
    flyby
        .constraints
        .push(constraint(ConstraintWhen::Maintain, TL_ATTITUDE, nadir, 0))
        .unwrap();
    flyby
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_REQUEST, Effect::Add(1)))
        .unwrap();
    flyby
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_INSTRUMENT, Effect::Claim))
        .unwrap();
    flyby
        .contingencies
        .push(Contingency {
            on: FailureKind::ANY,
            action: ContingencyAction::Restart,
        })
        .unwrap();
    n.tasks.push(flyby).unwrap();

    n.tasks
        .push(gnc_attain(
            ID_GNC_EARTH,
            "GncAttain EARTH",
            TaskRole::Requested,
            EARTH,
            hm(11, 5),
            hm(11, 5),
        ))
        .unwrap();
    n.tasks
        .push(gnc_attain(
            ID_GNC_NADIR_TEMPLATE,
            "GncAttain NADIR (template)",
            TaskRole::Template,
            NADIR,
            MissionTimeUs::ZERO,
            MissionTimeUs::MAX,
        ))
        .unwrap();

    let mut degraded = TaskSpec {
        id: ID_DEGRADED_TEMPLATE,
        name: name("Instrument Degraded Flyby"),
        priority: 30,
        role: TaskRole::Template,
        command: Some(CommandSpec {
            opcode: INSTRUMENT_DEGRADED_FLYBY,
            args: args(&[]),
        }),
        duration_us: 50 * MIN,
        min_duration_us: MIN,
        earliest_start: hm(10, 15),
        latest_start: hm(11, 4),
        latest_end: hm(11, 5),
        constraints: heapless::Vec::new(),
        impacts: heapless::Vec::new(),
        control: control(MIN, MIN),
        contingencies: heapless::Vec::new(),
        permissions: no_permissions(),
    };
    degraded
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_REQUEST, Effect::Add(1)))
        .unwrap();
    degraded
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_INSTRUMENT, Effect::Claim))
        .unwrap();
    n.tasks.push(degraded).unwrap();
    n
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
            _ => {}
        }
    }
}

#[derive(Clone, Debug)]
enum SimEvent {
    State(StateKey, StateValue),
    Response(u32, CommandStatus),
}

/// A deterministic fake spacecraft. GNC: on GncAttain it reports TURNING at once and, after
/// 15 minutes, the commanded attitude and an Ok response. Instruments answer Ok at once. A reset
/// loses every pending completion and leaves the attitude UNKNOWN until the next GncAttain.
pub struct FakeSpacecraft {
    pending: Vec<(MissionTimeUs, u64, SimEvent)>,
    order: u64,
    pub attitude: StateValue,
    pub attitude_at: MissionTimeUs,
}

impl FakeSpacecraft {
    pub fn new(at: MissionTimeUs) -> Self {
        let mut sc = Self {
            pending: Vec::new(),
            order: 0,
            attitude: StateValue::Enum(INERTIAL),
            attitude_at: at,
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
        self.pending.iter().map(|p| p.0).min()
    }

    pub fn on_dispatch(&mut self, now: MissionTimeUs, id: u32, opcode: Opcode, args: &CommandArgs) {
        if opcode == GNC_ATTAIN {
            let target = args.first().copied().unwrap_or(0) as u16;
            self.push(
                now,
                SimEvent::State(ATTITUDE_KEY, StateValue::Enum(TURNING)),
            );
            let done = now.saturating_add(15 * MIN);
            self.push(
                done,
                SimEvent::State(ATTITUDE_KEY, StateValue::Enum(target)),
            );
            self.push(done, SimEvent::Response(id, CommandStatus::Ok));
        } else {
            self.push(now, SimEvent::Response(id, CommandStatus::Ok));
        }
    }

    /// Delivers every event due at or before `now`, in time then issue order.
    pub fn deliver(&mut self, now: MissionTimeUs, autonomy: &mut Autonomy) {
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
    }

    /// Flight software reset at `at`: fault protection drops every command in progress and the
    /// attitude is no longer known.
    pub fn reset(&mut self, at: MissionTimeUs) {
        self.pending.clear();
        self.attitude = StateValue::Enum(UNKNOWN);
        self.attitude_at = at;
    }

    /// The whole state buffer, as published to a core that just restarted.
    pub fn publish_all(&self, autonomy: &mut Autonomy) {
        autonomy.on_state_update(ATTITUDE_KEY, self.attitude, self.attitude_at);
    }
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
        }
    }

    pub fn flyby() -> Self {
        Self::new(flyby_network(), hm(9, 50))
    }

    fn step_at(&mut self, t: MissionTimeUs) {
        self.now = t;
        self.out.now = t;
        self.sc.deliver(t, &mut self.autonomy);
        self.autonomy.step(t, self.budget, &mut self.out);
        self.steps += 1;
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
        self.autonomy = Box::new(Autonomy::new());
        let restart = r.at.saturating_add(r.recovery_us);
        let area = WarmRestartArea::new(&mut self.area);
        self.autonomy
            .restore_from(&area)
            .expect("a whole checkpoint survives");
        self.sc.publish_all(&mut self.autonomy);
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
    if t.0 % SEC == 0 {
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
        })
        .collect()
}
