//! Opportunistic goals (seed 001, 5.3): a goal that makes planning fail is dropped and
//! planning is tried again without it; a goal that can be reached is kept.
mod common;

use temporal::opportunistic::plan_dropping;
use temporal::{PlannedAction, PlannerConfig, Status, Task};

const DOMAIN: &str = "(define (domain tiny)
  (:requirements :typing :durative-actions)
  (:types place)
  (:predicates (at ?p - place) (link ?a ?b - place) (seen ?p - place))
  (:durative-action move :parameters (?a ?b - place)
    :duration (= ?duration 5)
    :condition (and (at start (at ?a)) (over all (link ?a ?b)))
    :effect (and (at start (not (at ?a))) (at end (at ?b))))
  (:durative-action look :parameters (?p - place)
    :duration (= ?duration 2)
    :condition (over all (at ?p))
    :effect (at end (seen ?p))))";

/// Places a, b, c, d; the rover at a; a-b linked both ways, c linked from b, d from nowhere.
fn problem(goals: &str) -> String {
    format!(
        "(define (problem p) (:domain tiny)
          (:objects a b c d - place)
          (:init (at a) (link a b) (link b a) (link b c))
          (:goal (and {goals})))"
    )
}

/// The index among the task's goal facts of the goal fact named `name`.
fn goal_index(compiled: &pddl::Compiled, name: &str) -> usize {
    let task = Task::parse(&compiled.task).unwrap();
    task.goal_facts()
        .iter()
        .position(|f| compiled.fact_names[f] == name)
        .unwrap_or_else(|| panic!("no goal {name} in {:?}", compiled.fact_names))
}

fn run(goals: &str, opportunistic: &[&str]) -> (temporal::opportunistic::Outcome, Vec<String>) {
    let compiled = common::compile(DOMAIN, &problem(goals)).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let order: Vec<usize> = opportunistic
        .iter()
        .map(|g| goal_index(&compiled, g))
        .collect();
    let mut arena = vec![0u32; 1 << 20];
    let mut out = vec![PlannedAction::default(); 64];
    let outcome = plan_dropping(
        task,
        &mut arena,
        PlannerConfig::default(),
        &order,
        10_000,
        &mut out,
    );
    let names = outcome
        .plan
        .map(|(n, _)| {
            out[..n]
                .iter()
                .map(|p| compiled.action_names[usize::from(p.action)].clone())
                .collect()
        })
        .unwrap_or_default();
    (outcome, names)
}

#[test]
fn an_unreachable_opportunistic_goal_is_dropped_and_the_rest_planned() {
    let (outcome, plan) = run("(seen b) (seen d)", &["(seen d)"]);
    assert_eq!(outcome.status, Status::Solved);
    assert_eq!(
        outcome.attempts, 2,
        "one failed attempt, then without (seen d)"
    );
    assert!(outcome.plan.is_some());
    assert_eq!(outcome.dropped.count_ones(), 1);
    assert!(
        plan.iter().any(|a| a.contains("look") && a.contains('b')),
        "{plan:?}"
    );
}

#[test]
fn a_reachable_opportunistic_goal_is_kept() {
    let (outcome, plan) = run("(seen b) (seen c)", &["(seen c)"]);
    assert_eq!(outcome.status, Status::Solved);
    assert_eq!((outcome.attempts, outcome.dropped), (1, 0));
    assert!(
        plan.iter().any(|a| a.contains("look") && a.contains('c')),
        "{plan:?}"
    );
}

#[test]
fn goals_are_dropped_in_the_order_given_until_a_plan_comes() {
    // Two opportunistic goals, only the second reachable: the first is dropped, the second
    // kept.
    let (outcome, plan) = run("(seen b) (seen d) (seen c)", &["(seen d)", "(seen c)"]);
    assert_eq!(outcome.status, Status::Solved);
    assert_eq!(outcome.attempts, 2);
    assert!(
        plan.iter().any(|a| a.contains("look") && a.contains('c')),
        "{plan:?}"
    );
    // A required goal that cannot be reached: every opportunistic goal dropped, still no plan.
    let (outcome, plan) = run("(seen d) (seen c)", &["(seen c)"]);
    assert!(outcome.plan.is_none() && plan.is_empty());
    assert_eq!(outcome.attempts, 2);
    assert_ne!(outcome.status, Status::Solved);
}
