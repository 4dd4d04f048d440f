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
        })
        .map_err(|_| CapacityExceeded)?;
    n.timelines
        .push(TimelineSpec {
            name: name("GncSlew")?,
            kind: TimelineKind::Claimable,
            state_key: None,
            after_reset: None,
            stale_after_us: None,
        })
        .map_err(|_| CapacityExceeded)?;
    n.timelines
        .push(TimelineSpec {
            name: name("Instrument")?,
            kind: TimelineKind::Claimable,
            state_key: None,
            after_reset: None,
            stale_after_us: None,
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
