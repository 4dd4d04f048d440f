//! The temporal PDDL planner on the emulated RAD750 (issue 13, items 2 and 4): `hil plan
//! --emulated` plans in the planner partition, anytime across its windows, with the plan the
//! native planner finds (the same search, the same arena size), and every plan passes the
//! independent validator of `pddl`'s tests. A corrupted or malformed task is refused with its
//! reason, and the target plans the next one as before.
use fsw_bridge::temporal::TemporalConfig;
use fsw_bridge::HostToTarget;
use hil::plan::{plan_compiled, PlanOptions, PlanReport};
use hil::plan_emulated::{EmulatedError, EmulatedPlanner};
use hil_tests::firmware;

#[path = "../../pddl/tests/common/mod.rs"]
#[allow(dead_code, clippy::all)]
mod pddl_common;

/// The compiled tasks' epsilon, in PDDL time units (`pddl::Options::default()`).
const EPSILON: f64 = 0.01;
/// Frames a job may take before the test gives up (the instances here take tens).
const MAX_FRAMES: u32 = 5_000;

/// Small benchmark instances: every domain of the goal's three, a few seconds of QEMU.
const INSTANCES: [(&str, u32); 5] = [
    ("satellite", 1),
    ("satellite", 2),
    ("rovers", 1),
    ("rovers", 2),
    ("driverlog", 1),
];

fn files(domain: &str, instance: u32) -> (String, String) {
    let dir = hil::repo_root().join("pddl/tests/benchmarks").join(domain);
    (
        std::fs::read_to_string(dir.join("domain.pddl")).unwrap(),
        std::fs::read_to_string(dir.join(format!("instance-{instance}.pddl"))).unwrap(),
    )
}

/// The same options on both targets: the target's arena size natively too, so that the open
/// lists and the duplicate table have the same sizes.
fn options() -> PlanOptions {
    PlanOptions {
        arena_bytes: flight_app::TEMPORAL_ARENA_BYTES,
        ..PlanOptions::default()
    }
}

fn steps(r: &PlanReport) -> Vec<pddl_common::Step> {
    r.plan
        .iter()
        .map(|s| pddl_common::Step {
            start: s.start,
            action: s.action.clone(),
            duration: s.duration,
        })
        .collect()
}

#[test]
fn emulated_plans_are_the_native_plans_and_valid_and_bad_tasks_are_refused() {
    let _one = hil_tests::exclusive_qemu();
    let mut target = EmulatedPlanner::boot(firmware()).unwrap_or_else(|e| panic!("{e}"));
    let options = options();
    for (domain, instance) in INSTANCES {
        let (d, p) = files(domain, instance);
        let compiled = pddl_common::compile(&d, &p).unwrap();
        let native = plan_compiled(&compiled, &options).unwrap();
        let emulated = target
            .plan(&compiled, &options, MAX_FRAMES)
            .unwrap_or_else(|e| panic!("{domain} {instance}: {e}"));
        let tag = format!("{domain} {instance}");
        assert!(emulated.solved, "{tag}: {}", emulated.outcome);
        assert_eq!(emulated.plan, native.plan, "{tag}: the same plan");
        assert_eq!(emulated.makespan, native.makespan, "{tag}");
        assert_eq!(
            (
                emulated.expanded,
                emulated.generated,
                emulated.evaluated,
                emulated.nodes,
                emulated.best_h
            ),
            (
                native.expanded,
                native.generated,
                native.evaluated,
                native.nodes,
                native.best_h
            ),
            "{tag}: the same search"
        );
        assert_eq!(emulated.peak_arena_bytes, native.peak_arena_bytes, "{tag}");
        let validator = pddl_common::Validator::new(&d, &p, EPSILON);
        if let Err(why) = validator.validate(&steps(&emulated)) {
            panic!("{tag}: the emulated plan is invalid: {why}");
        }
        let costs = emulated.emulated.clone().expect("guest costs");
        assert!(costs.planning_ticks > 0 && costs.guest_instructions > costs.planning_ticks);
        assert!(costs.planner_windows >= 1 && costs.frames >= costs.planner_windows);
        println!(
            "{tag}: makespan {:?}, {} expanded, {} guest instructions, {} planner windows, {} frames, peak arena {} bytes, costliest expansion {} ticks, health events so far {:?}",
            emulated.makespan,
            emulated.expanded,
            costs.guest_instructions,
            costs.planner_windows,
            costs.frames,
            emulated.peak_arena_bytes,
            costs.worst_expansion_ticks,
            target.health_events
        );
    }
    // The search stays within its windows; what may overrun is a job's set-up (building the
    // tables and the root's heuristic is not anytime: satellite 2's takes more than a
    // window). The kernel preempts it, logs it, and it goes on in the next window: at most
    // one overrun per job, all of them the planner partition's (2), logged only (action 0).
    assert!(
        target.health_events.len() <= INSTANCES.len()
            && target
                .health_events
                .iter()
                .all(|e| e == "partition 2: error kind 8, action 0"),
        "{:?}",
        target.health_events
    );

    // Corrupted on the way (a flipped bit under the announced CRC), malformed (a bad header
    // under a matching CRC), cut short, and a chunk of no job: each refused with its reason.
    let (d, p) = files("satellite", 1);
    let compiled = pddl_common::compile(&d, &p).unwrap();
    let task = &compiled.task;
    let config = TemporalConfig::DEFAULT;
    let job = target.new_job();
    let mut msgs = EmulatedPlanner::job_messages(job, task, config);
    if let HostToTarget::TemporalChunk { bytes, .. } = &mut msgs[1] {
        bytes[40] ^= 0x10;
    }
    let e = target.uplink(job, msgs).expect_err("corrupted");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r.starts_with("BadCrc")),
        "{e}"
    );

    let mut bad = task.clone();
    bad[0] = b'X';
    let job = target.new_job();
    let e = target
        .uplink(job, EmulatedPlanner::job_messages(job, &bad, config))
        .expect_err("malformed");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r == "BadTask { kind: 0, offset: 0 }"),
        "{e}"
    );

    let job = target.new_job();
    let short = &task[..task.len() / 3];
    let e = target
        .uplink(job, EmulatedPlanner::job_messages(job, short, config))
        .expect_err("truncated");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r.starts_with("BadTask")),
        "{e}"
    );

    let job = target.new_job();
    let stray = EmulatedPlanner::job_messages(job, task, config).remove(2);
    let e = target.uplink(job, vec![stray]).expect_err("no job");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r.starts_with("OutOfSequence")),
        "{e}"
    );

    let job = target.new_job();
    let e = target
        .uplink(
            job,
            vec![HostToTarget::TemporalBegin {
                job,
                len: (flight_app::MAX_TEMPORAL_TASK_BYTES + 1) as u32,
                crc32: 0,
                config,
            }],
        )
        .expect_err("too large");
    assert!(
        matches!(&e, EmulatedError::Refused(r) if r == "TooLarge { capacity: 1048576 }"),
        "{e}"
    );

    // The target kept running: the next job plans as the first did.
    let again = target.plan(&compiled, &options, MAX_FRAMES).unwrap();
    let native = plan_compiled(&compiled, &options).unwrap();
    assert!(again.solved);
    assert_eq!(again.plan, native.plan);
}
