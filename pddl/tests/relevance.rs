//! The front end's relevance pruning (`pddl::Options::prune_irrelevant`) against a
//! straightforward fixpoint: on the benchmark instances kept in the tests, the actions the
//! pruned task keeps are exactly those a scan of every action of the unpruned task, repeated
//! until nothing changes, finds relevant (an action is relevant if it adds a goal or a
//! condition of a relevant action, or has a numeric effect), in the same order.
use std::collections::HashSet;

use temporal::task::{FactList, NumericList, Task};

mod common;

fn compile(domain: &str, problem: &str, prune: bool) -> pddl::Compiled {
    let options = pddl::Options {
        prune_irrelevant: prune,
        ..Default::default()
    };
    common::compile_with(domain, problem, &options).expect("compiles")
}

/// The relevant actions' names by repeated scans of every action of the unpruned task.
fn relevant_by_scans(full: &pddl::Compiled) -> Vec<String> {
    let task = Task::parse(&full.task).expect("valid");
    let mut facts: HashSet<usize> = task.goal_facts().iter().collect();
    let mut relevant = vec![false; task.action_count()];
    loop {
        let mut changed = false;
        for (a, rel) in relevant.iter_mut().enumerate() {
            if *rel {
                continue;
            }
            let act = task.action(a);
            let adds = act
                .facts(FactList::AddStart)
                .iter()
                .chain(act.facts(FactList::AddEnd).iter())
                .any(|f| facts.contains(&f));
            let numeric =
                act.has_numeric(NumericList::EffStart) || act.has_numeric(NumericList::EffEnd);
            if adds || numeric {
                *rel = true;
                changed = true;
                for list in [FactList::PreStart, FactList::Invariant, FactList::PreEnd] {
                    facts.extend(act.facts(list).iter());
                }
            }
        }
        if !changed {
            break;
        }
    }
    (0..task.action_count())
        .filter(|&a| relevant[a])
        .map(|a| full.action_names[a].clone())
        .collect()
}

#[test]
fn pruning_keeps_exactly_the_actions_a_fixpoint_over_every_action_finds_relevant() {
    let mut pruned_some = 0;
    for domain in ["satellite", "rovers", "driverlog", "crew", "pipesworld"] {
        let dir = format!("{}/tests/benchmarks/{domain}", env!("CARGO_MANIFEST_DIR"));
        let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain");
        for i in 1..=3 {
            let p = std::fs::read_to_string(format!("{dir}/instance-{i}.pddl")).expect("problem");
            let full = compile(&d, &p, false);
            let pruned = compile(&d, &p, true);
            let expected = relevant_by_scans(&full);
            assert_eq!(pruned.action_names, expected, "{domain} {i}");
            if expected.len() < full.action_names.len() {
                pruned_some += 1;
            }
            // The facts kept are those the kept actions and the goal name.
            assert!(pruned.fact_names.len() <= full.fact_names.len());
        }
    }
    // Not vacuous: some instances lose actions.
    assert!(pruned_some >= 3, "{pruned_some}");
}
