//! The search's small portfolio (`temporal::search::RESTART_AFTER`): a first search that makes
//! no progress restarts from the root pruning every repeated state; if that second search ends
//! without a plan, a third runs as configured. On a task whose only plans need two actions
//! running in a state seen before (pruning every repeat loses them), restarting at once must
//! still find a valid plan, through the third search, and report the restarts.
mod common;

use common::Validator;
use temporal::PlannerConfig;

const DOMAIN: &str =
    "(define (domain r) (:requirements :durative-actions) (:predicates (p0) (p1) (p2) (p3) (p4))
  (:durative-action a0 :parameters () :duration (= ?duration 2)
    :condition (and (at end (p4)))
    :effect (and (at start (p2)) (at start (not (p3))) (at end (not (p0)))))
  (:durative-action a1 :parameters () :duration (= ?duration 3)
    :condition (and (over all (p2)))
    :effect (and (at start (p0)) (at start (not (p0))) (at end (p3))))
  (:durative-action a2 :parameters () :duration (= ?duration 3)
    :condition (and)
    :effect (and (at start (not (p3))) (at end (p4)))))";
const PROBLEM: &str = "(define (problem q) (:domain r) (:init (p1)) (:goal (and (p0) (p4))))";

fn run(
    config: PlannerConfig,
    restart_after: Option<u64>,
) -> (temporal::Status, temporal::Stats, Vec<common::Step>) {
    run_with(config, restart_after, Some(0))
}

/// [`run`] with the lookahead along the relaxed plan in the searches of `lookahead` (None: the
/// default). The portfolio's tests search without it: with it, the first search fills this
/// small arena (the scratch for 2,048 steps leaves a few thousand words of nodes) with the
/// lookaheads' nodes and gives way to the second search, which finds the plan.
fn run_with(
    config: PlannerConfig,
    restart_after: Option<u64>,
    lookahead: Option<u8>,
) -> (temporal::Status, temporal::Stats, Vec<common::Step>) {
    let compiled = common::compile(DOMAIN, PROBLEM).expect("compiles");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let tpu = f64::from(task.ticks_per_unit());
    let mut arena = vec![0u32; 1 << 16];
    let mut planner = temporal::Planner::new(task, &mut arena, config).expect("fits");
    // The portfolio as it was measured here: without the check that drops successors whose
    // running actions can no longer end (`temporal::search::CHECK_RUNNING_ENDS`, on for tasks
    // without windows such as this one), which drops this task's dead state before the
    // pruning of every repeat can lose the plan (see compression_brute_force.rs).
    planner.set_check_running_ends(temporal::search::RunningEnds::Off);
    if let Some(mask) = lookahead {
        planner.set_lookahead_phases(mask);
        // The portfolio as it was measured here: the first search gives way, never commits
        // (`temporal::search::FIRST_COMMIT_AFTER`: after a commit its empty open list proves
        // nothing, and the second search, which sheds in this small arena, decides).
        planner.set_first_commit_after(u64::MAX);
    }
    if let Some(n) = restart_after {
        planner.set_restart_after(n);
    }
    let status = planner.step(100_000);
    let mut plan = Vec::new();
    if status == temporal::Status::Solved {
        let mut out = vec![temporal::PlannedAction::default(); 64];
        let (n, _) = planner.plan(&mut out).expect("a plan");
        plan = common::steps_of(&compiled, &out[..n], tpu);
    }
    (status, planner.stats(), plan)
}

#[test]
fn a_second_search_that_prunes_too_much_hands_over_to_a_third_that_finds_the_plan() {
    // The front end's default epsilon (`pddl::Options::default()`), in PDDL time units.
    let validator = Validator::new(DOMAIN, PROBLEM, 0.01);
    // Pruning every repeated state loses this task's plans (see compression_brute_force.rs).
    let (all, _, _) = run(
        PlannerConfig {
            duplicates: temporal::Duplicates::PruneAll,
            ..PlannerConfig::default()
        },
        None,
    );
    assert_eq!(all, temporal::Status::Unsolvable);
    // Without restarts the default finds a plan, in its first search.
    let (first, stats, plan) = run(PlannerConfig::default(), None);
    assert_eq!(first, temporal::Status::Solved);
    assert_eq!(stats.restarts, 0, "{stats:?}");
    validator.validate(&plan).expect("valid");
    // With the lookahead (the default), a valid plan too, from the second search.
    let (status, stats, plan) = run_with(PlannerConfig::default(), None, None);
    assert_eq!(status, temporal::Status::Solved, "{stats:?}");
    assert!(stats.lookahead_steps > 0, "{stats:?}");
    validator.validate(&plan).expect("valid");
    // Restarting at once: the third search (every repeat pruned) empties its open lists, so
    // does the novelty search that prunes as much (`temporal::search::NOVELTY_LAST`), and the
    // last, as configured, finds a valid plan; none answers "unsolvable".
    let (status, stats, plan) = run(PlannerConfig::default(), Some(0));
    assert_eq!(status, temporal::Status::Solved, "{stats:?}");
    assert_eq!(stats.restarts, 4, "{stats:?}");
    validator.validate(&plan).expect("valid");
    // Asked to prune every repeat, the searches after a restart prune as asked: the answer
    // stays "unsolvable" (there is no third search to hand over to).
    let (status, stats, _) = run(
        PlannerConfig {
            duplicates: temporal::Duplicates::PruneAll,
            ..PlannerConfig::default()
        },
        Some(0),
    );
    assert_eq!(status, temporal::Status::Unsolvable, "{stats:?}");
}
