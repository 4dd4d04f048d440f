//! Successors whose running actions can no longer end in time are dropped before they are
//! evaluated (`temporal::search::CHECK_RUNNING_ENDS`, the search's `running_ends` module).
//! Crew planning 16 was not solved without it (its search sat on states of h 3 whose running
//! `conduct_payload_activity` could never end: 60 minutes long, with two days of steps its end
//! must follow); with it the plan is found at once and passes the validator. The check must
//! lose no plan: `tests/compression_brute_force.rs` runs with it on (the default) against brute
//! force, and here the small benchmark instances are solved with it on and off. By default
//! it checks only tasks without windows (`RunningEnds::WithoutWindows`): pipesworld lost an
//! instance with it.
mod common;

use common::Validator;
use temporal::search::RunningEnds;
use temporal::{PlannerConfig, Status};

fn bench(domain: &str, instance: u32) -> (String, String) {
    let dir = format!("{}/tests/benchmarks/{domain}", env!("CARGO_MANIFEST_DIR"));
    let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain");
    let p = std::fs::read_to_string(format!("{dir}/instance-{instance}.pddl")).expect("problem");
    (d, p)
}

struct Run {
    status: Status,
    stats: temporal::Stats,
    late_ends: u64,
    plan: Vec<common::Step>,
}

/// Plan in the target's 8 MiB arena, at most `expansions`, the check as `check`.
fn run(d: &str, p: &str, check: RunningEnds, expansions: u64) -> Run {
    let compiled = common::compile(d, p).expect("compiles");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let tpu = f64::from(task.ticks_per_unit());
    let mut arena = vec![0u32; 8192 * 256];
    let mut planner =
        temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
    planner.set_check_running_ends(check);
    let status = loop {
        let s = planner.step(64);
        if s != Status::Searching || planner.stats().expanded >= expansions {
            break s;
        }
    };
    let mut plan = Vec::new();
    if status == Status::Solved {
        let mut out = vec![temporal::PlannedAction::default(); 1024];
        let (n, _) = planner.plan(&mut out).expect("a plan");
        plan = common::steps_of(&compiled, &out[..n], tpu);
    }
    Run {
        status,
        stats: planner.stats(),
        late_ends: planner.late_ends(),
        plan,
    }
}

/// Crew 16: without the check, 5,000 expansions find no plan (the search spends them below
/// states whose running action cannot end); with it, a plan within them, valid, with
/// successors dropped by the check.
#[test]
fn crew_16_is_solved_once_late_ends_are_dropped() {
    let (d, p) = bench("crew", 16);
    let off = run(&d, &p, RunningEnds::Off, 5_000);
    assert_ne!(off.status, Status::Solved, "{:?}", off.stats);
    assert_eq!(off.late_ends, 0);
    // Crew has no windows: the default checks it.
    assert_eq!(
        temporal::search::CHECK_RUNNING_ENDS,
        RunningEnds::WithoutWindows
    );
    let on = run(&d, &p, RunningEnds::WithoutWindows, 5_000);
    assert_eq!(on.status, Status::Solved, "{:?}", on.stats);
    assert!(on.late_ends > 0, "{:?}", on.stats);
    Validator::new(&d, &p, 0.01)
        .validate(&on.plan)
        .expect("crew 16's plan is valid");
}

/// The small benchmark instances (crew and pipesworld: envelopes and deadlines) are solved
/// with the check as without it, each plan valid; by default pipesworld (windows) is not
/// checked, and with the check forced on its successors are dropped.
#[test]
fn the_check_loses_no_small_benchmark_plan() {
    for (domain, instance) in [
        ("crew", 1),
        ("crew", 2),
        ("crew", 3),
        ("pipesworld", 1),
        ("pipesworld", 2),
        ("pipesworld", 3),
    ] {
        let (d, p) = bench(domain, instance);
        let validator = Validator::new(&d, &p, 0.01);
        for check in [
            RunningEnds::Off,
            RunningEnds::WithoutWindows,
            RunningEnds::Always,
        ] {
            let r = run(&d, &p, check, 100_000);
            if domain == "pipesworld" && check == RunningEnds::WithoutWindows {
                assert_eq!(r.late_ends, 0, "{domain} {instance}");
            }
            assert_eq!(
                r.status,
                Status::Solved,
                "{domain} {instance} check {check:?}"
            );
            validator
                .validate(&r.plan)
                .unwrap_or_else(|e| panic!("{domain} {instance} check {check:?}: {e}"));
        }
    }
    // Pipesworld 2 with the check forced on: successors dropped.
    let (d, p) = bench("pipesworld", 2);
    assert!(run(&d, &p, RunningEnds::Always, 100_000).late_ends > 0);
}
