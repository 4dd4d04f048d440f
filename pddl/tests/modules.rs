//! External functions as modules (seed 001, section 4.5): a rover traverse whose duration is a
//! path estimate evaluated at compile time on every pair of waypoints; a missing module is a
//! located error.
mod common;

use pddl::{ModuleRegistry, PathEstimate};
use temporal::PlannerConfig;

const DOMAIN: &str = "(define (domain rover)
  (:requirements :typing :durative-actions :numeric-fluents)
  (:types waypoint)
  (:predicates (at ?w - waypoint) (imaged ?w - waypoint) (link ?a ?b - waypoint))
  (:modules (:module paths (:function (path-time ?from ?to - waypoint))))
  (:durative-action traverse
    :parameters (?from ?to - waypoint)
    :duration (= ?duration (path-time ?from ?to))
    :condition (and (at start (at ?from)) (over all (link ?from ?to)))
    :effect (and (at start (not (at ?from))) (at end (at ?to))))
  (:durative-action image
    :parameters (?w - waypoint)
    :duration (= ?duration 2)
    :condition (over all (at ?w))
    :effect (at end (imaged ?w))))
";

const PROBLEM: &str = "(define (problem p) (:domain rover)
  (:objects w0 w1 w2 - waypoint)
  (:init (at w0) (link w0 w1) (link w1 w2) (link w0 w2))
  (:goal (imaged w2)))
";

fn compile(modules: &ModuleRegistry) -> Result<pddl::Compiled, pddl::PddlError> {
    pddl::compile(
        pddl::Source {
            name: "domain.pddl",
            text: DOMAIN,
        },
        pddl::Source {
            name: "problem.pddl",
            text: PROBLEM,
        },
        modules,
        &pddl::Options::default(),
    )
}

fn registry(w2: (f64, f64)) -> ModuleRegistry {
    let mut m = ModuleRegistry::new();
    m.register(Box::new(PathEstimate::new(
        "paths",
        "path-time",
        &[("w0", 0.0, 0.0), ("w1", 3.0, 4.0), ("w2", w2.0, w2.1)],
        1.0,
    )));
    m
}

/// Without the lookahead along the relaxed plan (`temporal::search::LOOKAHEAD_PHASES`): with
/// it, the first state expanded is the traverse to w1 under way, whose relaxed plan goes on
/// through w1 to the image, and the lookahead reaches the goal that way (makespan 10.02 where
/// the direct traverse gives 6.01): a greedy search keeps the first plan it reaches.
fn plan_with(modules: &ModuleRegistry) -> (Vec<common::Step>, f64) {
    let compiled = compile(modules).expect("compiles");
    let planned = common::plan_with(&compiled, PlannerConfig::default(), 1 << 20, 10_000, |p| {
        p.set_lookahead_phases(0)
    });
    assert_eq!(planned.status, temporal::Status::Solved);
    (planned.plan, planned.makespan)
}

#[test]
fn traverse_durations_come_from_the_path_estimate() {
    // w0 -> w1 is 5, w1 -> w2 is 5, w0 -> w2 is 13: the durations in the plan are the module's.
    let (plan, _) = plan_with(&registry((3.0, 9.0)));
    let traverse: Vec<_> = plan
        .iter()
        .filter(|s| s.action.starts_with("(traverse"))
        .collect();
    assert!(!traverse.is_empty());
    for s in &traverse {
        let expected = match s.action.as_str() {
            "(traverse w0 w1)" | "(traverse w1 w2)" => 5.0,
            "(traverse w0 w2)" => (9.0f64 + 81.0).sqrt(),
            other => panic!("unexpected {other}"),
        };
        assert!(
            (s.duration - expected).abs() < 1e-3,
            "{} lasts {}",
            s.action,
            s.duration
        );
    }
}

#[test]
fn a_different_estimate_changes_the_plan() {
    // With w2 far from w0 but near w1, going through w1 is shorter.
    let (direct, direct_makespan) = plan_with(&registry((0.0, 4.0)));
    assert!(
        direct.iter().any(|s| s.action == "(traverse w0 w2)"),
        "{direct:?}"
    );
    let (via, via_makespan) = plan_with(&registry((3.0, 40.0)));
    assert!(via_makespan > direct_makespan);
    // Each plan's durations match its own module's numbers (checked by duration bounds).
    for (plan, w2) in [(&direct, (0.0, 4.0)), (&via, (3.0, 40.0))] {
        for s in plan.iter().filter(|s| s.action.starts_with("(traverse")) {
            let pos = |w: &str| -> (f64, f64) {
                match w {
                    "w0" => (0.0, 0.0),
                    "w1" => (3.0, 4.0),
                    _ => w2,
                }
            };
            let args: Vec<&str> = s
                .action
                .trim_matches(|c| c == '(' || c == ')')
                .split(' ')
                .collect();
            let ((x0, y0), (x1, y1)) = (pos(args[1]), pos(args[2]));
            let d: f64 = ((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0)).sqrt();
            assert!(
                (s.duration - d).abs() < 1e-3,
                "{} lasts {} not {d}",
                s.action,
                s.duration
            );
        }
    }
}

#[test]
fn a_module_nobody_registered_is_a_located_error() {
    let e = compile(&ModuleRegistry::new()).expect_err("no module");
    assert_eq!(e.file, "domain.pddl");
    assert_eq!(e.line, 5, "{e}");
    assert!(e.message.contains("no external module `paths`"), "{e}");
}
