//! Plans for small benchmark instances (satellite, rovers, driverlog, crew planning and
//! pipesworld with deadline TILs, instances 1-3), each checked by the independent validator in
//! `common`; and the validator itself refuses broken plans (so a passing plan means something).
mod common;

use common::{Step, Validator};
use temporal::PlannerConfig;

const EPSILON: f64 = 0.01;
/// 16 MiB of arena: more than any of these instances needs.
const ARENA_WORDS: usize = 4 << 20;

fn files(domain: &str, instance: u32) -> (String, String) {
    let dir = format!("{}/tests/benchmarks/{domain}", env!("CARGO_MANIFEST_DIR"));
    let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain file");
    let p =
        std::fs::read_to_string(format!("{dir}/instance-{instance}.pddl")).expect("instance file");
    (d, p)
}

fn solve_and_validate(domain: &str, instance: u32, config: PlannerConfig) -> (Vec<Step>, f64) {
    let (d, p) = files(domain, instance);
    let compiled = common::compile(&d, &p).unwrap_or_else(|e| panic!("{domain} {instance}: {e}"));
    let planned = common::plan(&compiled, config, ARENA_WORDS, 200_000);
    assert_eq!(
        planned.status,
        temporal::Status::Solved,
        "{domain} {instance}: {:?}",
        planned.stats
    );
    assert!(!planned.plan.is_empty());
    let validator = Validator::new(&d, &p, EPSILON);
    if let Err(why) = validator.validate(&planned.plan) {
        panic!(
            "{domain} {instance}: invalid plan: {why}\n{:#?}",
            planned.plan
        );
    }
    let end = planned
        .plan
        .iter()
        .map(|s| s.start + s.duration)
        .fold(0.0, f64::max);
    assert!(
        (end - planned.makespan).abs() < 1e-6,
        "the makespan is the last end"
    );
    // The arena's high-water mark is reported and within the arena.
    assert!(planned.stats.peak_words > 0 && planned.stats.peak_words <= ARENA_WORDS as u64);
    (planned.plan, planned.makespan)
}

#[test]
fn satellite_instances_1_to_3_give_valid_plans() {
    for i in 1..=3 {
        solve_and_validate("satellite", i, PlannerConfig::default());
    }
}

#[test]
fn rovers_instances_1_to_3_give_valid_plans() {
    for i in 1..=3 {
        solve_and_validate("rovers", i, PlannerConfig::default());
    }
}

#[test]
fn driverlog_instances_1_to_3_give_valid_plans() {
    for i in 1..=3 {
        solve_and_validate("driverlog", i, PlannerConfig::default());
    }
}

#[test]
fn crew_planning_instances_1_to_3_give_valid_plans() {
    for i in 1..=3 {
        solve_and_validate("crew", i, PlannerConfig::default());
    }
}

#[test]
fn pipesworld_with_deadline_tils_instances_1_to_3_give_valid_plans() {
    for i in 1..=3 {
        solve_and_validate("pipesworld", i, PlannerConfig::default());
    }
}

#[test]
fn every_search_option_gives_valid_plans() {
    use temporal::heuristic::RelaxedCost;
    for config in [
        PlannerConfig {
            compression: false,
            ..PlannerConfig::default()
        },
        PlannerConfig {
            preferred_operators: false,
            ..PlannerConfig::default()
        },
        PlannerConfig {
            duplicates: temporal::Duplicates::PruneAll,
            ..PlannerConfig::default()
        },
        PlannerConfig {
            duplicates: temporal::Duplicates::Keep,
            ..PlannerConfig::default()
        },
        PlannerConfig {
            relaxed_cost: RelaxedCost::Duration,
            ..PlannerConfig::default()
        },
    ] {
        for domain in ["satellite", "rovers", "driverlog"] {
            solve_and_validate(domain, 1, config);
        }
    }
}

#[test]
fn the_same_task_gives_the_same_plan() {
    let a = solve_and_validate("rovers", 3, PlannerConfig::default());
    let b = solve_and_validate("rovers", 3, PlannerConfig::default());
    assert_eq!(a, b);
}

#[test]
fn anytime_steps_of_any_budget_reach_the_same_plan() {
    let (d, p) = files("driverlog", 3);
    let compiled = common::compile(&d, &p).expect("compiles");
    let run = |budget: u32| {
        let task = temporal::Task::parse(&compiled.task).expect("valid");
        let mut arena = vec![0u32; ARENA_WORDS];
        let mut planner =
            temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
        let mut calls = 0;
        while planner.step(budget) == temporal::Status::Searching {
            calls += 1;
            assert!(calls < 1_000_000);
        }
        let mut out = vec![temporal::PlannedAction::default(); 512];
        let (n, makespan) = planner.plan(&mut out).expect("solved");
        (out[..n].to_vec(), makespan, planner.stats().expanded, calls)
    };
    let one = run(1);
    let many = run(1 << 20);
    assert_eq!((&one.0, one.1, one.2), (&many.0, many.1, many.2));
    assert!(one.3 > 1, "the search was resumed across calls");
}

#[test]
fn a_small_arena_is_an_out_of_memory_status_not_a_panic() {
    let (d, p) = files("satellite", 3);
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let mut tiny = vec![0u32; 64];
    assert!(temporal::Planner::new(task, &mut tiny, PlannerConfig::default()).is_err());
    // The least arena that holds the tables (and a root node).
    let fits = |words: usize| {
        let mut arena = vec![0u32; words];
        temporal::Planner::new(task, &mut arena, PlannerConfig::default()).is_ok()
    };
    let (mut lo, mut hi) = (64usize, 1 << 22);
    assert!(fits(hi));
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if fits(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    // Just above it the tables fit but the search does not: it stops with OutOfMemory; with
    // more room it solves. Either way the high-water mark stays inside the arena.
    let search = |words: usize| {
        let mut arena = vec![0u32; words];
        let mut planner =
            temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
        let mut status = planner.step(1000);
        while status == temporal::Status::Searching {
            status = planner.step(1000);
        }
        assert!(planner.stats().peak_words <= words as u64);
        status
    };
    assert!(
        matches!(search(hi), temporal::Status::OutOfMemory(_)),
        "{:?}",
        search(hi)
    );
    assert_eq!(search(hi + 50_000), temporal::Status::Solved);
}

// ----- the validator refuses broken plans ---------------------------------------------------

fn good_plan() -> (String, String, Vec<Step>) {
    let (d, p) = files("rovers", 1);
    let (plan, _) = solve_and_validate("rovers", 1, PlannerConfig::default());
    (d, p, plan)
}

#[test]
fn the_validator_refuses_a_plan_missing_an_action() {
    let (d, p, plan) = good_plan();
    let v = Validator::new(&d, &p, EPSILON);
    for drop in 0..plan.len() {
        let mut broken = plan.clone();
        broken.remove(drop);
        assert!(
            v.validate(&broken).is_err(),
            "without step {drop} ({}) the plan still passed",
            plan[drop].action
        );
    }
}

#[test]
fn the_validator_refuses_wrong_durations_and_early_starts() {
    let (d, p, plan) = good_plan();
    let v = Validator::new(&d, &p, EPSILON);
    let mut longer = plan.clone();
    longer[0].duration += 1.0;
    assert!(
        v.validate(&longer).is_err(),
        "a duration outside the action's bounds passed"
    );
    // Every action but the first starts after something it needs: move each to time 0.
    let mut refused = 0;
    for k in 1..plan.len() {
        if plan[k].start > 0.5 {
            let mut early = plan.clone();
            early[k].start = 0.0;
            refused += usize::from(v.validate(&early).is_err());
        }
    }
    assert!(refused > 0, "no action moved to time zero was refused");
}

#[test]
fn the_validator_refuses_interfering_happenings_closer_than_epsilon() {
    // Two actions where the second needs the first's end effect: at epsilon apart the plan is
    // valid, closer it is not.
    let d = "(define (domain d) (:requirements :durative-actions)
      (:predicates (a) (b) (c))
      (:durative-action one :parameters () :duration (= ?duration 2)
        :condition (at start (a)) :effect (at end (b)))
      (:durative-action two :parameters () :duration (= ?duration 1)
        :condition (at start (b)) :effect (at end (c))))";
    let p = "(define (problem p) (:domain d) (:init (a)) (:goal (c)))";
    let v = Validator::new(d, p, EPSILON);
    let step = |start: f64, action: &str, duration: f64| Step {
        start,
        action: action.into(),
        duration,
    };
    assert!(v
        .validate(&[step(0.0, "(one)", 2.0), step(2.01, "(two)", 1.0)])
        .is_ok());
    assert!(v
        .validate(&[step(0.0, "(one)", 2.0), step(2.0, "(two)", 1.0)])
        .is_err());
    assert!(v
        .validate(&[step(0.0, "(one)", 2.0), step(2.005, "(two)", 1.0)])
        .is_err());
    assert!(v
        .validate(&[step(0.0, "(one)", 2.0), step(1.5, "(two)", 1.0)])
        .is_err());
    assert!(
        v.validate(&[step(0.0, "(one)", 2.0)]).is_err(),
        "goal missing"
    );
    // And the planner's plan for it passes.
    let compiled = common::compile(d, p).expect("compiles");
    let planned = common::plan(&compiled, PlannerConfig::default(), 1 << 16, 1000);
    assert_eq!(planned.status, temporal::Status::Solved);
    v.validate(&planned.plan)
        .expect("the planner's plan is valid");
    assert!(
        (planned.makespan - 3.01).abs() < 1e-9,
        "makespan {}",
        planned.makespan
    );
}

/// Rovers 6: two images with one camera, started together, deadlock (each needs the camera
/// calibrated throughout and uncalibrates it at its end). The search refuses such starts; when
/// it did not, it spent its whole arena (over 100,000 states at h = 21) around that dead end.
#[test]
fn rovers_6_needs_no_more_than_a_few_thousand_expansions() {
    let (d, p) = files("rovers", 6);
    let compiled = common::compile(&d, &p).expect("compiles");
    let planned = common::plan(&compiled, PlannerConfig::default(), ARENA_WORDS, 5_000);
    assert_eq!(
        planned.status,
        temporal::Status::Solved,
        "{:?}",
        planned.stats
    );
    Validator::new(&d, &p, EPSILON)
        .validate(&planned.plan)
        .expect("valid");
}

#[test]
fn a_step_limit_drops_long_branches_and_the_search_goes_on() {
    let (d, p) = files("satellite", 1);
    let compiled = common::compile(&d, &p).expect("compiles");
    // Too few steps for any plan: every branch ends at the limit, and the search runs out of
    // states instead of stopping at the first long one.
    let short = PlannerConfig {
        max_steps: 4,
        ..PlannerConfig::default()
    };
    let planned = common::plan(&compiled, short, ARENA_WORDS, 1_000_000);
    assert_eq!(
        planned.status,
        temporal::Status::Unsolvable,
        "{:?}",
        planned.stats
    );
    assert!(planned.stats.too_long > 0);
    // With room it solves, and its plan fits the limit given.
    let fits = PlannerConfig {
        max_steps: 40,
        ..PlannerConfig::default()
    };
    let planned = common::plan(&compiled, fits, ARENA_WORDS, 100_000);
    assert_eq!(
        planned.status,
        temporal::Status::Solved,
        "{:?}",
        planned.stats
    );
    assert!(2 * planned.plan.len() <= 40);
}

/// In fixed memory a full open list sheds its worse half and the search goes on: driverlog 2
/// in 90,000 words fills its open list before a plan without shedding, and finds a valid one
/// with it (the arena is small: since the search's boost was lowered, driverlog 2 takes
/// hundreds of expansions, not tens of thousands). Without the lookahead along the relaxed
/// plan: with it, driverlog 2 takes 188 evaluations and never fills its open list in any arena
/// that holds its tables.
#[test]
fn a_full_open_list_sheds_its_worse_half_and_the_search_goes_on() {
    let (d, p) = files("driverlog", 2);
    let compiled = common::compile(&d, &p).expect("compiles");
    let words = 90_000;
    let strict = PlannerConfig {
        shed_when_full: false,
        ..PlannerConfig::default()
    };
    // Nor the first search's commits (`temporal::search::FIRST_COMMIT_AFTER`), which take it
    // to the plan in fewer nodes.
    let no_lookahead = |p: &mut temporal::Planner<'_, '_>| {
        p.set_lookahead_phases(0);
        p.set_first_commit_after(u64::MAX);
    };
    let without = common::plan_with(&compiled, strict, words, 1_000_000, no_lookahead);
    assert_eq!(
        without.status,
        temporal::Status::OutOfMemory(temporal::Region::RegularOpen)
    );
    assert_eq!(without.stats.shed, 0);
    let with = common::plan_with(
        &compiled,
        PlannerConfig::default(),
        words,
        1_000_000,
        no_lookahead,
    );
    assert_eq!(with.status, temporal::Status::Solved, "{:?}", with.stats);
    assert!(with.stats.shed > 0);
    assert!(with.stats.peak_words <= words as u64);
    Validator::new(&d, &p, EPSILON)
        .validate(&with.plan)
        .expect("valid");
}

/// Flexible dispatch of real plans (rovers, satellite and driverlog instances 1-2): executed
/// with every action ready at once and lasting as planned, each starts at its planned start
/// (the earliest the plan's network allows) and no replan is asked for; an action that
/// overruns its duration by the whole makespan makes the dispatcher ask for a replan.
#[test]
fn benchmark_plans_dispatch_as_planned_and_an_overrun_asks_for_a_replan() {
    use temporal::{Decision, Dispatcher, PlanNetwork};
    for (domain, instance) in [
        ("rovers", 1),
        ("rovers", 2),
        ("satellite", 1),
        ("driverlog", 2),
    ] {
        let (d, p) = files(domain, instance);
        let compiled = common::compile(&d, &p).expect("compiles");
        let task = temporal::Task::parse(&compiled.task).expect("valid");
        let mut arena = vec![0u32; ARENA_WORDS];
        let mut planner =
            temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
        while planner.step(1 << 16) == temporal::Status::Searching {}
        let mut out = vec![temporal::PlannedAction::default(); 512];
        let (n, makespan) = planner.plan(&mut out).expect("solved");
        let planned = &out[..n];
        let mut net = Box::new(PlanNetwork::new());
        planner.plan_network(&mut net).expect("network");
        assert_eq!(net.makespan, makespan);
        assert_eq!(
            net.step_count(),
            2 * n,
            "{domain} {instance}: a start and an end per action"
        );
        let duration = |a: u16| {
            planned
                .iter()
                .find(|p| p.action == a)
                .map(|p| p.duration)
                .unwrap()
        };
        // As planned.
        let mut dispatcher = Dispatcher::new((*net).clone(), makespan).expect("consistent");
        let (mut now, mut started) = (0u32, Vec::new());
        let mut guard = 0;
        loop {
            guard += 1;
            assert!(
                guard < 100_000,
                "{domain} {instance}: dispatch does not end"
            );
            // Report the ends due by now.
            for s in 1..=net.step_count() {
                let st = net.step(s).unwrap();
                if let (false, Some(at)) = (st.end, dispatcher.executed_at(s)) {
                    let e = net.end_of(s).unwrap();
                    let end = at + duration(st.action);
                    if dispatcher.executed_at(e).is_none() && end <= now {
                        dispatcher.executed(e, end).unwrap();
                    }
                }
            }
            match dispatcher.poll(now, &|_| true) {
                Decision::Start { step, action } => {
                    dispatcher.executed(step, now).unwrap();
                    started.push((action, now));
                }
                Decision::Finished => break,
                Decision::Wait { until } => {
                    // The next due end or the next lb, whichever comes first.
                    let next_end = (1..=net.step_count())
                        .filter_map(|s| {
                            let st = net.step(s).unwrap();
                            let at = dispatcher.executed_at(s)?;
                            let e = net.end_of(s)?;
                            (!st.end && dispatcher.executed_at(e).is_none())
                                .then(|| at + duration(st.action))
                        })
                        .min();
                    now = [until, next_end]
                        .into_iter()
                        .flatten()
                        .min()
                        .expect("something pending");
                }
                Decision::Replan { step, ub } => {
                    panic!("{domain} {instance}: replan at {now}, step {step}, ub {ub}")
                }
            }
        }
        let mut expected: Vec<(u16, u32)> = planned.iter().map(|p| (p.action, p.start)).collect();
        started.sort_unstable_by_key(|&(a, t)| (t, a));
        expected.sort_unstable_by_key(|&(a, t)| (t, a));
        assert_eq!(
            started, expected,
            "{domain} {instance}: each at its planned start"
        );
        // The first action overruns by the makespan: the rest cannot keep it.
        let mut dispatcher = Dispatcher::new((*net).clone(), makespan).expect("consistent");
        let Decision::Start { step, .. } = dispatcher.poll(0, &|_| true) else {
            panic!("{domain} {instance}: nothing to start at 0");
        };
        dispatcher.executed(step, 0).unwrap();
        let end = net.end_of(step).unwrap();
        if n > 1 {
            dispatcher.executed(end, 2 * makespan).unwrap();
            assert!(
                matches!(
                    dispatcher.poll(2 * makespan, &|_| true),
                    Decision::Replan { .. }
                ),
                "{domain} {instance}: an overrun past the makespan asks for a replan"
            );
        }
    }
}

/// The first search orders only the preferred list by how much of the relaxed plan a successor
/// undoes, and alternates with the regular list in the order generated
/// (`temporal::search::ORDERED_RESTART_AFTER`). Ordering both lists trapped driverlog 2 on a
/// plateau until the search gave way (993 evaluations; 532 with the preferred list alone);
/// ordering neither (or only the regular list) loses satellite's gains (satellite 17: 712
/// evaluations; 169 ordered).
#[test]
fn the_ordered_preferred_list_keeps_satellites_gains_and_spares_driverlog() {
    for (domain, instance, most) in [("driverlog", 2, 700), ("satellite", 17, 250)] {
        let (d, p) = files(domain, instance);
        let compiled = common::compile(&d, &p).expect("compiles");
        let planned = common::plan(&compiled, PlannerConfig::default(), ARENA_WORDS, 200_000);
        assert_eq!(
            planned.status,
            temporal::Status::Solved,
            "{domain} {instance}"
        );
        assert!(
            planned.stats.evaluated <= most,
            "{domain} {instance}: {} evaluations, more than {most}",
            planned.stats.evaluated
        );
        Validator::new(&d, &p, EPSILON)
            .validate(&planned.plan)
            .expect("valid");
        println!(
            "{domain} {instance}: {} evaluations",
            planned.stats.evaluated
        );
    }
}
