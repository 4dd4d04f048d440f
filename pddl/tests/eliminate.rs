//! Action elimination after the search (`temporal`'s `search/eliminate.rs`) on benchmark
//! plans: the plan with the elimination is valid (the independent validator), a sub-multiset
//! of the search's plan with no more actions and no longer makespan, and no single action of
//! it can be removed (brute force: every plan with one action left out, its times kept, is
//! refused by the validator); what was removed is counted in the statistics.
mod common;

use common::{Planned, Step, Validator};
use temporal::PlannerConfig;

const EPSILON: f64 = 0.01;
const ARENA_WORDS: usize = 4 << 20;

fn files(domain: &str, instance: u32) -> (String, String) {
    let dir = format!("{}/tests/benchmarks/{domain}", env!("CARGO_MANIFEST_DIR"));
    let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain file");
    let p =
        std::fs::read_to_string(format!("{dir}/instance-{instance}.pddl")).expect("instance file");
    (d, p)
}

fn planned(compiled: &pddl::Compiled, eliminate: bool) -> Planned {
    let config = PlannerConfig {
        eliminate,
        ..PlannerConfig::default()
    };
    let p = common::plan(compiled, config, ARENA_WORDS, 200_000);
    assert_eq!(p.status, temporal::Status::Solved, "{:?}", p.stats);
    p
}

fn names(plan: &[Step]) -> Vec<String> {
    let mut v: Vec<String> = plan.iter().map(|s| s.action.clone()).collect();
    v.sort();
    v
}

/// Whether `small` is a sub-multiset of `big` (both sorted).
fn sub_multiset(small: &[String], big: &[String]) -> bool {
    let mut j = 0;
    for s in small {
        while j < big.len() && big[j] < *s {
            j += 1;
        }
        if j == big.len() || big[j] != *s {
            return false;
        }
        j += 1;
    }
    true
}

/// Returns the actions removed.
fn check(domain: &str, instance: u32) -> u64 {
    let (d, p) = files(domain, instance);
    let compiled = common::compile(&d, &p).expect("compiles");
    let validator = Validator::new(&d, &p, EPSILON);
    let found = planned(&compiled, false);
    let short = planned(&compiled, true);
    let tag = format!("{domain} {instance}");
    // The search is the same: the elimination comes after it.
    assert_eq!(found.stats.expanded, short.stats.expanded, "{tag}");
    assert_eq!(found.stats.elimination_checks, 0, "{tag}");
    assert_eq!(found.stats.eliminated, 0, "{tag}");
    validator
        .validate(&short.plan)
        .unwrap_or_else(|why| panic!("{tag}: invalid plan after elimination: {why}"));
    assert_eq!(
        short.plan.len() as u64 + short.stats.eliminated,
        found.plan.len() as u64,
        "{tag}: the count removed"
    );
    assert!(
        sub_multiset(&names(&short.plan), &names(&found.plan)),
        "{tag}: only removals"
    );
    assert!(short.makespan <= found.makespan + 1e-9, "{tag}");
    // At least a check per action of the result (the last pass tried every one).
    assert!(
        short.stats.elimination_checks >= short.plan.len() as u64,
        "{tag}"
    );
    for k in 0..short.plan.len() {
        let mut without = short.plan.clone();
        let gone = without.remove(k);
        assert!(
            validator.validate(&without).is_err(),
            "{tag}: {} could still be removed",
            gone.action
        );
    }
    short.stats.eliminated
}

#[test]
fn eliminated_benchmark_plans_are_valid_shorter_and_have_no_removable_action() {
    let mut removed = 0;
    for domain in ["satellite", "rovers", "driverlog"] {
        for i in 1..=3 {
            removed += check(domain, i);
        }
    }
    // Satellite 2's plan with the lookahead has unneeded turns and calibrations (25 actions
    // found, 17 after the elimination when this test was written).
    assert!(removed >= 8, "{removed}");
}

#[test]
fn satellite_2_loses_its_unneeded_actions_and_makespan() {
    let (d, p) = files("satellite", 2);
    let compiled = common::compile(&d, &p).expect("compiles");
    let found = planned(&compiled, false);
    let short = planned(&compiled, true);
    assert!(
        short.plan.len() + 5 <= found.plan.len(),
        "{} {}",
        short.plan.len(),
        found.plan.len()
    );
    assert!(
        short.makespan + 10.0 <= found.makespan,
        "{} {}",
        short.makespan,
        found.makespan
    );
}

/// The elimination is a unit of the budget at a time: any budget reaches the same plan, and
/// the status is Searching until every removal was tried.
#[test]
fn elimination_in_units_of_any_budget_reaches_the_same_plan() {
    let (d, p) = files("satellite", 2);
    let compiled = common::compile(&d, &p).expect("compiles");
    let reference = planned(&compiled, true);
    for budget in [1u32, 2, 7, 1000] {
        let task = temporal::Task::parse(&compiled.task).expect("valid");
        let tpu = f64::from(task.ticks_per_unit());
        let mut arena = vec![0u32; ARENA_WORDS];
        let mut planner =
            temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
        let mut calls = 0u64;
        while planner.step(budget) == temporal::Status::Searching {
            calls += 1;
        }
        let stats = planner.stats();
        assert_eq!(stats, reference.stats, "budget {budget}");
        if budget == 1 {
            // One unit a call: every expansion, lookahead snap and removal tried was a call.
            assert!(
                calls >= stats.expanded + stats.elimination_checks,
                "{calls}"
            );
        }
        let mut out = vec![temporal::PlannedAction::default(); 256];
        let (n, m) = planner.plan(&mut out).expect("plan");
        assert_eq!(common::steps_of(&compiled, &out[..n], tpu), reference.plan);
        assert!((f64::from(m) / tpu - reference.makespan).abs() < 1e-9);
    }
}

/// Step a planner for `compiled` `units` units of the budget (one a call), or until the status
/// is no longer Searching; the units run.
fn run_units(planner: &mut temporal::Planner<'_, '_>, units: u64) -> u64 {
    let mut ran = 0;
    while ran < units && planner.status() == temporal::Status::Searching {
        planner.step(1);
        ran += 1;
    }
    ran
}

fn plan_now(
    planner: &mut temporal::Planner<'_, '_>,
    compiled: &pddl::Compiled,
    tpu: f64,
) -> Option<(Vec<Step>, f64)> {
    let mut out = vec![temporal::PlannedAction::default(); 512];
    let (n, m) = planner.plan(&mut out)?;
    Some((
        common::steps_of(compiled, &out[..n], tpu),
        f64::from(m) / tpu,
    ))
}

/// Anytime: a caller that stops at any unit boundary of the elimination gets a valid plan
/// (the search's as soon as the search ends, then the best so far: only removals of it, no
/// longer), and asking for it there does not change where the elimination ends (the same
/// plan and makespan as without stopping).
fn stop_at_every_unit(domain: &str, instance: u32) {
    let (d, p) = files(domain, instance);
    let compiled = common::compile(&d, &p).expect("compiles");
    let validator = Validator::new(&d, &p, EPSILON);
    let found = planned(&compiled, false);
    let reference = planned(&compiled, true);
    let tag = format!("{domain} {instance}");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let tpu = f64::from(task.ticks_per_unit());
    // The units of the whole run, and the first unit after which there is a plan.
    let mut arena = vec![0u32; ARENA_WORDS];
    let mut planner =
        temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
    let mut first = None;
    let mut total = 0u64;
    while planner.status() == temporal::Status::Searching {
        planner.step(1);
        total += 1;
        if first.is_none() && planner.has_plan() {
            first = Some(total);
            // The search's plan, at once, while the elimination has not begun.
            assert!(planner.improving(), "{tag}: the elimination follows");
            let (plan, makespan) = plan_now(&mut planner, &compiled, tpu).expect("a plan");
            assert_eq!(plan, found.plan, "{tag}: the first plan is the search's");
            assert!((makespan - found.makespan).abs() < 1e-9, "{tag}");
        }
    }
    let first = first.expect("solved");
    assert!(
        total > first + 2,
        "{tag}: the elimination takes units ({first}, {total})"
    );
    let names_found = names(&found.plan);
    for k in first..total {
        let task = temporal::Task::parse(&compiled.task).expect("valid");
        let mut arena = vec![0u32; ARENA_WORDS];
        let mut planner =
            temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
        assert_eq!(run_units(&mut planner, k), k, "{tag}");
        assert!(planner.has_plan(), "{tag} unit {k}");
        assert_eq!(
            planner.status(),
            temporal::Status::Searching,
            "{tag} unit {k}: still improving"
        );
        let (plan, makespan) = plan_now(&mut planner, &compiled, tpu).expect("a plan");
        validator
            .validate(&plan)
            .unwrap_or_else(|why| panic!("{tag}: plan after {k} units invalid: {why}"));
        assert!(sub_multiset(&names(&plan), &names_found), "{tag} unit {k}");
        assert!(makespan <= found.makespan + 1e-9, "{tag} unit {k}");
        assert!(plan.len() >= reference.plan.len(), "{tag} unit {k}");
        // Asked for mid-pass, the plan does not change where the elimination ends.
        while planner.step(1) == temporal::Status::Searching {}
        let (end, end_makespan) = plan_now(&mut planner, &compiled, tpu).expect("a plan");
        assert_eq!(end, reference.plan, "{tag} unit {k}: the same end");
        assert!(
            (end_makespan - reference.makespan).abs() < 1e-9,
            "{tag} unit {k}"
        );
    }
}

#[test]
fn stopping_at_every_unit_of_the_elimination_leaves_a_valid_plan() {
    stop_at_every_unit("satellite", 2);
    stop_at_every_unit("driverlog", 1);
    stop_at_every_unit("rovers", 3);
}

/// No unit of the elimination applies more than `ELIM_SNAPS_PER_UNIT` snaps or rebuilds more
/// than a `ELIM_REBUILD_WEIGHT`th of that: a long plan's rebuild is divided (driverlog 2:
/// about 54 snaps, some 15 units a rebuild).
#[test]
fn a_long_plans_elimination_takes_many_units() {
    let (d, p) = files("driverlog", 2);
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = temporal::Task::parse(&compiled.task).expect("valid");
    let mut arena = vec![0u32; ARENA_WORDS];
    let mut planner =
        temporal::Planner::new(task, &mut arena, PlannerConfig::default()).expect("fits");
    let mut units = 0u64;
    while planner.status() == temporal::Status::Searching {
        let improving = planner.improving();
        planner.step(1);
        units += u64::from(improving);
    }
    let stats = planner.stats();
    let found = stats.eliminated
        + planner
            .plan(&mut [temporal::PlannedAction::default(); 256])
            .expect("plan")
            .0 as u64;
    // Every kept removal rebuilds the plan's snaps (about twice its actions) in units of at
    // most `per_unit`, and a schedule unit.
    let snaps = 2 * (found - stats.eliminated);
    let per_unit = temporal::search::ELIM_SNAPS_PER_UNIT / temporal::search::ELIM_REBUILD_WEIGHT;
    let per_rebuild = snaps.div_ceil(per_unit as u64) + 1;
    assert!(stats.eliminated >= 5, "{stats:?}");
    assert!(
        units >= stats.elimination_checks + per_rebuild,
        "{units} units, {} checks, {per_rebuild} a rebuild",
        stats.elimination_checks
    );
}
