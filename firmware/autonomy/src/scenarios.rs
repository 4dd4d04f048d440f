//! Reference task networks built in code: the seed 003 flyby (Figs 4-8), the same network
//! `scenarios/tasknets/flyby.toml` describes (a host test checks that the two are identical).
//! Used by the host tests, the benchmarks and firmware demos that run without an uplink.
//!
//! Times: epoch 2028-040T00:00 is mission time 0, so 10:00 is 36 000 s. Attitude values are
//! INERTIAL 0, NADIR 1, TURNING 2, UNKNOWN 3, EARTH 4 (state key 1). Opcodes: GNC attain
//! 0x0101 (argument: the attitude), instrument flyby 0x0201, degraded flyby 0x0202.
use crate::model::*;
use crate::telemetry::FailureKind;
use fsw_bridge::{CommandArgs, MissionTimeUs, Opcode, StateKey};

/// A list in the network was full (cannot happen at the configured capacities).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CapacityExceeded;

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

fn mask(values: &[u16]) -> u32 {
    values
        .iter()
        .fold(0, |m, &v| m | 1u32.checked_shl(u32::from(v)).unwrap_or(0))
}

fn name(s: &str) -> Result<Name, CapacityExceeded> {
    Name::try_from(s).map_err(|_| CapacityExceeded)
}

fn args(a: &[i32]) -> Result<CommandArgs, CapacityExceeded> {
    CommandArgs::from_slice(a).map_err(|_| CapacityExceeded)
}

fn control(response_timeout_us: u64, pre_wait_timeout_us: u64) -> ControlSpec {
    ControlSpec {
        pre_wait_timeout_us,
        response_timeout_us,
        ..ControlSpec::NONE
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
) -> Result<TaskSpec, CapacityExceeded> {
    let mut t = TaskSpec {
        id,
        name: name(task_name)?,
        priority: 50,
        role,
        command: Some(CommandSpec {
            opcode: GNC_ATTAIN,
            args: args(&[i32::from(target)])?,
            from_instance: heapless::Vec::new(),
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
        .map_err(|_| CapacityExceeded)?;
    t.impacts
        .push(impact(
            ImpactWhen::Pre,
            TL_ATTITUDE,
            Effect::Assign(i64::from(TURNING)),
        ))
        .map_err(|_| CapacityExceeded)?;
    t.impacts
        .push(impact(
            ImpactWhen::Post,
            TL_ATTITUDE,
            Effect::Assign(i64::from(target)),
        ))
        .map_err(|_| CapacityExceeded)?;
    t.impacts
        .push(impact(ImpactWhen::Maintain, TL_GNC_SLEW, Effect::Claim))
        .map_err(|_| CapacityExceeded)?;
    Ok(t)
}

/// The seed 003 flyby network (Figs 4-8).
pub fn flyby_spec() -> Result<NetworkSpec, CapacityExceeded> {
    let mut n = NetworkSpec::new(3, PlannerConfig::DEFAULT);
    n.timelines
        .push(TimelineSpec {
            name: name("GncAttitude")?,
            kind: TimelineKind::State {
                value_count: 5,
                initial: INERTIAL,
            },
            state_key: Some(ATTITUDE_KEY),
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .map_err(|_| CapacityExceeded)?;
    n.timelines
        .push(TimelineSpec {
            name: name("FlybyRequest")?,
            kind: TimelineKind::Cumulative {
                initial: 0,
                min: 0,
                max: 8,
            },
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .map_err(|_| CapacityExceeded)?;
    n.timelines
        .push(TimelineSpec {
            name: name("GncSlew")?,
            kind: TimelineKind::Claimable,
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .map_err(|_| CapacityExceeded)?;
    n.timelines
        .push(TimelineSpec {
            name: name("Instrument")?,
            kind: TimelineKind::Claimable,
            state_key: None,
            after_reset: None,
            stale_after_us: None,
            background_rate: 0,
            external: false,
            thresholds: heapless::Vec::new(),
        })
        .map_err(|_| CapacityExceeded)?;

    n.tasks
        .push(gnc_attain(
            ID_GNC_NADIR,
            "GncAttain NADIR",
            TaskRole::Requested,
            NADIR,
            hm(10, 0),
            hm(10, 0),
        )?)
        .map_err(|_| CapacityExceeded)?;

    let mut request = TaskSpec {
        id: ID_REQUEST,
        name: name("Instrument Flyby Request")?,
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
        .map_err(|_| CapacityExceeded)?;
    n.tasks.push(request).map_err(|_| CapacityExceeded)?;

    let mut flyby = TaskSpec {
        id: ID_FLYBY,
        name: name("Instrument Flyby")?,
        priority: 40,
        role: TaskRole::Requested,
        command: Some(CommandSpec {
            opcode: INSTRUMENT_FLYBY,
            args: args(&[])?,
            from_instance: heapless::Vec::new(),
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
                .map_err(|_| CapacityExceeded)?,
        },
    };
    let nadir = Requirement::OneOf {
        mask: mask(&[NADIR]),
    };
    flyby
        .constraints
        .push(constraint(ConstraintWhen::Pre, TL_ATTITUDE, nadir, 0))
        .map_err(|_| CapacityExceeded)?;
    flyby
        .constraints
        .push(constraint(ConstraintWhen::Maintain, TL_ATTITUDE, nadir, 0))
        .map_err(|_| CapacityExceeded)?;
    flyby
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_REQUEST, Effect::Add(1)))
        .map_err(|_| CapacityExceeded)?;
    flyby
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_INSTRUMENT, Effect::Claim))
        .map_err(|_| CapacityExceeded)?;
    flyby
        .contingencies
        .push(Contingency {
            on: FailureKind::ANY,
            action: ContingencyAction::Restart,
        })
        .map_err(|_| CapacityExceeded)?;
    n.tasks.push(flyby).map_err(|_| CapacityExceeded)?;

    n.tasks
        .push(gnc_attain(
            ID_GNC_EARTH,
            "GncAttain EARTH",
            TaskRole::Requested,
            EARTH,
            hm(11, 5),
            hm(11, 5),
        )?)
        .map_err(|_| CapacityExceeded)?;
    n.tasks
        .push(gnc_attain(
            ID_GNC_NADIR_TEMPLATE,
            "GncAttain NADIR (template)",
            TaskRole::Template,
            NADIR,
            MissionTimeUs::ZERO,
            MissionTimeUs::MAX,
        )?)
        .map_err(|_| CapacityExceeded)?;

    let mut degraded = TaskSpec {
        id: ID_DEGRADED_TEMPLATE,
        name: name("Instrument Degraded Flyby")?,
        priority: 30,
        role: TaskRole::Template,
        command: Some(CommandSpec {
            opcode: INSTRUMENT_DEGRADED_FLYBY,
            args: args(&[])?,
            from_instance: heapless::Vec::new(),
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
        .map_err(|_| CapacityExceeded)?;
    degraded
        .impacts
        .push(impact(ImpactWhen::Maintain, TL_INSTRUMENT, Effect::Claim))
        .map_err(|_| CapacityExceeded)?;
    n.tasks.push(degraded).map_err(|_| CapacityExceeded)?;
    Ok(n)
}

/// The validated flyby network.
pub fn flyby_network() -> Option<TaskNetwork> {
    TaskNetwork::from_spec(flyby_spec().ok()?).ok()
}

/// Opcode of the synthetic networks' tasks (argument: the task's index).
pub const SYNTHETIC_TASK: Opcode = Opcode(0x0301);

/// Resources (claimable timelines) the tasks of a synthetic network share.
pub const SYNTHETIC_RESOURCES: usize = 8;
/// Timelines every synthetic network has: the resources, `Energy` (cumulative) and `Mode`
/// (state, four values).
pub const SYNTHETIC_BASE_TIMELINES: usize = SYNTHETIC_RESOURCES + 2;

/// The shape of a synthetic network ([`synthetic_into`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyntheticShape {
    /// Requested tasks.
    pub tasks: usize,
    /// Timelines: at least [`SYNTHETIC_BASE_TIMELINES`]; the others are cumulative `Aux<k>`
    /// timelines that the extra constraints and impacts use.
    pub timelines: usize,
    /// Constraints per task: at least 2 (PRE on `Mode`, MAINTAIN on `Energy`); the others are
    /// MAINTAIN ranges on `Aux` timelines (always satisfiable).
    pub constraints: usize,
    /// Impacts per task: at least 3 (claim of a resource, PRE use of energy, POST mode); the
    /// others are MAINTAIN additions on `Aux` timelines.
    pub impacts: usize,
    /// Seed of the deterministic generator (xorshift32; 0 is taken as 1).
    pub seed: u32,
}

impl SyntheticShape {
    /// The planner benchmark's networks: `tasks` tasks contending for
    /// [`SYNTHETIC_RESOURCES`] resources, two constraints and three impacts each.
    pub const fn bench(tasks: usize) -> Self {
        Self {
            tasks,
            timelines: SYNTHETIC_BASE_TIMELINES,
            constraints: 2,
            impacts: 3,
            seed: 0x5eed_0014,
        }
    }

    /// Every capacity at once: [`crate::MAX_TASKS`] tasks, [`crate::MAX_TIMELINES`]
    /// timelines, [`crate::MAX_CONSTRAINTS_PER_TASK`] constraints and
    /// [`crate::MAX_IMPACTS_PER_TASK`] impacts in every task.
    pub const fn at_capacity() -> Self {
        Self {
            tasks: crate::MAX_TASKS,
            timelines: crate::MAX_TIMELINES,
            constraints: crate::MAX_CONSTRAINTS_PER_TASK,
            impacts: crate::MAX_IMPACTS_PER_TASK,
            seed: 0x5eed_0014,
        }
    }
}

struct XorShift(u32);

impl XorShift {
    fn next(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// A number in `0..n` (n > 0).
    fn below(&mut self, n: u64) -> u64 {
        u64::from(self.next()) % n.max(1)
    }
}

/// Writes a synthetic network of `shape` into `spec` (in place: a network at capacity is too
/// large for a partition's stack), for the planner benchmark and the capacity tests. The same
/// shape gives the same network. Task `i` (id `i + 1`, `T<i>`) becomes ready about 2 minutes
/// after task `i - 1`, runs 5 to 30 minutes, claims resource `i % 8` for its duration, uses
/// energy, requires `Mode` to be 0 or 1 and sets it to `i % 2`; its window is a day long, and
/// the scheduling window and horizon cover a week, so a planner cycle schedules every task.
/// Fails when the shape is over a capacity (a spec's lists refuse the item that does not fit)
/// or under the base timelines and constraints it needs.
pub fn synthetic_into(
    spec: &mut NetworkSpec,
    shape: SyntheticShape,
) -> Result<(), CapacityExceeded> {
    use core::fmt::Write;
    const ENERGY: u8 = SYNTHETIC_RESOURCES as u8;
    const MODE: u8 = ENERGY + 1;
    const FULL: i64 = 1_000_000_000_000;
    const AUX: i64 = 1_000_000_000;
    if shape.timelines < SYNTHETIC_BASE_TIMELINES || shape.constraints < 2 || shape.impacts < 3 {
        return Err(CapacityExceeded);
    }
    let aux_count = shape.timelines - SYNTHETIC_BASE_TIMELINES;
    let day = 24 * 60 * MIN;
    let config = PlannerConfig {
        commit_window_us: MIN,
        scheduling_window_us: 7 * day,
        plan_horizon_us: 7 * day,
        plan_process_interval_us: 5 * MIN,
    };
    // Field by field: a whole `NetworkSpec` value would be built on the stack.
    spec.header = NetworkHeader {
        format_version: UPLINK_FORMAT_VERSION,
        network_id: 0x5157,
        config,
        responses: ResponsePolicy::DEFAULT,
    };
    spec.timelines.clear();
    spec.conditions.clear();
    spec.tasks.clear();
    spec.temporal.clear();
    let label = |prefix: &str, i: usize| -> Result<Name, CapacityExceeded> {
        let mut n = Name::new();
        write!(n, "{prefix}{i}").map_err(|_| CapacityExceeded)?;
        Ok(n)
    };
    let timeline = |name: Name, kind: TimelineKind| TimelineSpec {
        name,
        kind,
        state_key: None,
        after_reset: None,
        stale_after_us: None,
        background_rate: 0,
        external: false,
        thresholds: heapless::Vec::new(),
    };
    for r in 0..SYNTHETIC_RESOURCES {
        spec.timelines
            .push(timeline(label("Res", r)?, TimelineKind::Claimable))
            .map_err(|_| CapacityExceeded)?;
    }
    let energy = TimelineKind::Cumulative {
        initial: FULL,
        min: 0,
        max: FULL,
    };
    spec.timelines
        .push(timeline(name("Energy")?, energy))
        .map_err(|_| CapacityExceeded)?;
    let mode = TimelineKind::State {
        value_count: 4,
        initial: 0,
    };
    spec.timelines
        .push(timeline(name("Mode")?, mode))
        .map_err(|_| CapacityExceeded)?;
    for k in 0..aux_count {
        let aux = TimelineKind::Cumulative {
            initial: 0,
            min: -AUX,
            max: AUX,
        };
        spec.timelines
            .push(timeline(label("Aux", k)?, aux))
            .map_err(|_| CapacityExceeded)?;
    }
    let aux_timeline = |i: usize, j: usize| -> Result<u8, CapacityExceeded> {
        let k = (i + j) % aux_count.max(1);
        u8::try_from(SYNTHETIC_BASE_TIMELINES + k).map_err(|_| CapacityExceeded)
    };
    let mut rng = XorShift(shape.seed.max(1));
    for i in 0..shape.tasks {
        let duration_us = (5 + rng.below(26)) * MIN;
        let ready = MissionTimeUs(10 * MIN + (i as u64) * 2 * MIN + rng.below(10 * MIN));
        let use_energy = 1_000 + rng.below(9_000) as i64;
        let priority = rng.below(100) as u8;
        spec.tasks
            .push(TaskSpec {
                id: u16::try_from(i + 1).map_err(|_| CapacityExceeded)?,
                name: label("T", i)?,
                priority,
                role: TaskRole::Requested,
                command: Some(CommandSpec {
                    opcode: SYNTHETIC_TASK,
                    args: args(&[i32::try_from(i).map_err(|_| CapacityExceeded)?])?,
                    from_instance: heapless::Vec::new(),
                }),
                duration_us,
                min_duration_us: duration_us,
                earliest_start: ready,
                latest_start: MissionTimeUs(ready.0 + day),
                latest_end: MissionTimeUs::MAX,
                constraints: heapless::Vec::new(),
                impacts: heapless::Vec::new(),
                control: control(duration_us + MIN, 0),
                contingencies: heapless::Vec::new(),
                permissions: no_permissions(),
            })
            .map_err(|_| CapacityExceeded)?;
        let t = spec.tasks.last_mut().ok_or(CapacityExceeded)?;
        let mut constraints = [
            constraint(
                ConstraintWhen::Pre,
                MODE,
                Requirement::OneOf {
                    mask: mask(&[0, 1]),
                },
                0,
            ),
            constraint(
                ConstraintWhen::Maintain,
                ENERGY,
                Requirement::Range { min: 0, max: FULL },
                0,
            ),
        ]
        .into_iter()
        .map(Ok)
        .chain((2..shape.constraints).map(|j| {
            Ok(constraint(
                ConstraintWhen::Maintain,
                aux_timeline(i, j)?,
                Requirement::Range {
                    min: -AUX,
                    max: AUX,
                },
                0,
            ))
        }));
        constraints.try_for_each(|c: Result<ConstraintSpec, CapacityExceeded>| {
            t.constraints.push(c?).map_err(|_| CapacityExceeded)
        })?;
        let resource = u8::try_from(i % SYNTHETIC_RESOURCES).map_err(|_| CapacityExceeded)?;
        let mut impacts = [
            impact(ImpactWhen::Maintain, resource, Effect::Claim),
            impact(ImpactWhen::Pre, ENERGY, Effect::Add(-use_energy)),
            impact(ImpactWhen::Post, MODE, Effect::Assign((i % 2) as i64)),
        ]
        .into_iter()
        .map(Ok)
        .chain((3..shape.impacts).map(|j| {
            Ok(impact(
                ImpactWhen::Maintain,
                aux_timeline(i, j)?,
                Effect::Add(1),
            ))
        }));
        impacts.try_for_each(|m: Result<ImpactSpec, CapacityExceeded>| {
            t.impacts.push(m?).map_err(|_| CapacityExceeded)
        })?;
    }
    Ok(())
}
