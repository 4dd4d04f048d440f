//! Searches that commit to their best node (`temporal::search::COMMIT_PHASES`): when such a
//! search stalls or its node store is full, it keeps only the path to the latest node of its
//! lowest h and goes on from there, the path a committed prefix of the plan. The plans found
//! that way must pass the validator, every node left after a commit must rebuild its state
//! (the path's nodes moved to the store's start), and a search that ran out of memory without
//! commits must find a plan with them.
mod common;

use common::Validator;
use temporal::{PlannerConfig, Status};

struct Run {
    status: Status,
    stats: temporal::Stats,
    commits: u64,
    steps: Vec<common::Step>,
}

/// Plan `p` of domain `d` in an arena of `kib` KiB with at most `expansions` expansions, the
/// searches of `commit_phases` committing (None: the portfolio's own), checking every node's
/// state after each commit.
fn plan_in(d: &str, p: &str, kib: usize, commit_phases: Option<u8>, expansions: u64) -> Run {
    let compiled = common::compile(d, p).expect("compiles");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let tpu = f64::from(task.ticks_per_unit());
    let mut arena = vec![0u32; kib * 256];
    let mut planner =
        temporal::Planner::new_deferred(task, &mut arena, PlannerConfig::default()).expect("fits");
    if let Some(mask) = commit_phases {
        // Only the searches of `mask` commit: not the first search by its own limit
        // (`temporal::search::FIRST_COMMIT_AFTER`).
        planner.set_first_commit_after(u64::MAX);
        planner.set_commit(
            mask,
            temporal::search::COMMIT_AFTER,
            temporal::search::THIRD_GIVES_WAY_AFTER,
        );
    }
    let mut commits = 0;
    let status = loop {
        let s = planner.step(64);
        if planner.commits() != commits {
            commits = planner.commits();
            // The store holds the committed path and what was made since: every node's
            // state rebuilds as the search's own application of its path.
            planner
                .verify_node_states()
                .unwrap_or_else(|n| panic!("node {n} after commit {commits}"));
        }
        if s != Status::Searching || planner.stats().expanded >= expansions {
            break s;
        }
    };
    let mut steps = Vec::new();
    if status == Status::Solved {
        let mut out = vec![temporal::PlannedAction::default(); 1024];
        let (n, _) = planner.plan(&mut out).expect("a plan");
        steps = common::steps_of(&compiled, &out[..n], tpu);
    }
    Run {
        status,
        stats: planner.stats(),
        commits,
        steps,
    }
}

fn driverlog(instance: u32) -> (String, String) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/benchmarks/driverlog");
    let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain");
    let p = std::fs::read_to_string(format!("{dir}/instance-{instance}.pddl")).expect("problem");
    (d, p)
}

/// Driverlog 2 in a 300 KiB arena: the portfolio without commits fills the node store (its
/// second search ends out of memory); with every search committing when its store is full it
/// finds a plan, which the validator accepts, and every node's state is right after each
/// commit.
#[test]
fn committing_when_the_store_is_full_solves_what_ran_out_of_memory() {
    let (d, p) = driverlog(2);
    let validator = Validator::new(&d, &p, 0.01);
    let without = plan_in(&d, &p, 300, Some(0), 100_000);
    assert_eq!(
        without.status,
        Status::OutOfMemory(temporal::Region::Nodes),
        "{:?}",
        without.stats
    );
    assert_eq!(without.commits, 0);
    let with = plan_in(&d, &p, 300, Some(0x1f), 100_000);
    assert_eq!(with.status, Status::Solved, "{:?}", with.stats);
    assert!(with.commits >= 1, "{:?}", with.stats);
    validator.validate(&with.steps).expect("valid");
}

/// Driverlog 19 and 20 from `../shared/benchmarks` (the arena full in every search before the
/// commits), 16 and 18 (fewer evaluations), each solved by the portfolio in the target's 8 MiB
/// arena, each plan through the validator. Long in a debug build: `cargo test --release -p
/// pddl --test commit -- --ignored`.
#[test]
#[ignore]
fn driverlog_16_18_19_and_20_are_solved_with_commits_and_their_plans_are_valid() {
    let dir = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/benchmarks/pddl/driverlog-time-simple-automatic"
    );
    for instance in [16, 18, 19, 20] {
        let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain");
        let p = std::fs::read_to_string(format!("{dir}/instances/instance-{instance}.pddl"))
            .expect("problem");
        let validator = Validator::new(&d, &p, 0.01);
        let run = plan_in(&d, &p, 8192, None, 2_000_000);
        assert_eq!(
            run.status,
            Status::Solved,
            "driverlog {instance}: {:?}",
            run.stats
        );
        assert!(run.commits >= 1, "driverlog {instance}: {:?}", run.stats);
        validator
            .validate(&run.steps)
            .unwrap_or_else(|e| panic!("driverlog {instance}: {e}"));
        println!(
            "driverlog {instance}: {} evaluations, {} commits, {} actions",
            run.stats.evaluated,
            run.commits,
            run.steps.len()
        );
    }
}
