//! Search nodes keep no state (`temporal::search::replay`): a node's state is rebuilt from its
//! path when the search needs it. On benchmark instances, at several points of the search,
//! every stored node's rebuilt state must equal the straightforward computation (the search's
//! own checked application of each snap of the path from the initial state) and the hash
//! stored when the node was made; and the restarts' searches with pruned duplicates must still
//! find plans the validator accepts. The paths the search loads by cutting the loaded path back
//! to where two paths part and extending it (`Planner::load_path`) must equal loads from the
//! root, node after node.
mod common;

use temporal::{PlannerConfig, Status};

fn check(domain: &str, instance: &str, config: PlannerConfig) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/benchmarks");
    let d = std::fs::read_to_string(format!("{dir}/{domain}/domain.pddl")).expect("domain");
    let p = std::fs::read_to_string(format!("{dir}/{domain}/{instance}.pddl")).expect("problem");
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let mut arena = vec![0u32; 1 << 20];
    let mut planner = temporal::Planner::new(task, &mut arena, config).expect("fits");
    let mut checked = 0;
    let mut loads = 0;
    let mut status = Status::Searching;
    for round in 0..40 {
        status = planner.step(25);
        let nodes = planner
            .verify_node_states()
            .unwrap_or_else(|n| panic!("{domain} {instance}: node {n} rebuilt differently"));
        checked += nodes;
        // Paths loaded by cutting the loaded one back and extending it, against loads from
        // the root (every eighth round: each is about two loads per node times 8).
        if round % 8 == 1 {
            loads += planner.verify_path_loads().unwrap_or_else(|n| {
                panic!("{domain} {instance}: node {n}'s path loaded differently after a cut")
            });
        }
        if status != Status::Searching {
            break;
        }
    }
    assert!(
        checked > 20,
        "{domain} {instance}: only {checked} nodes checked"
    );
    assert!(
        loads > 20,
        "{domain} {instance}: only {loads} loads compared"
    );
    if status == Status::Solved {
        let mut out = vec![temporal::PlannedAction::default(); 256];
        assert!(planner.plan(&mut out).is_some(), "{domain} {instance}");
    }
}

#[test]
fn rebuilt_node_states_equal_the_states_the_search_applied() {
    for (domain, instance) in [
        ("driverlog", "instance-2"),
        ("driverlog", "instance-14"),
        ("rovers", "instance-3"),
        ("satellite", "instance-2"),
    ] {
        check(domain, instance, PlannerConfig::default());
        check(
            domain,
            instance,
            PlannerConfig {
                duplicates: temporal::Duplicates::Keep,
                ..PlannerConfig::default()
            },
        );
    }
}
