//! Bad PDDL and features outside the supported subset are refused at file:line:column with a
//! message that names the problem or the feature.
mod common;

/// A satellite-like domain, with `HOLE` replaced by the text under test.
fn domain_with(hole: &str) -> String {
    format!(
        "(define (domain d)
  (:requirements :typing :durative-actions)
  (:types thing)
  (:predicates (ready ?t - thing) (done ?t - thing))
  (:durative-action work
    :parameters (?t - thing)
    :duration (= ?duration 2)
    :condition (at start (ready ?t))
    :effect {hole}))
"
    )
}

const PROBLEM: &str = "(define (problem p) (:domain d) (:objects a - thing)
  (:init (ready a)) (:goal (done a)))
";

/// The error compiling `domain` and `problem`, as `file:line:column: message`.
fn error(domain: &str, problem: &str) -> String {
    match common::compile(domain, problem) {
        Ok(_) => panic!("compiled:\n{domain}\n{problem}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn unsupported_effects_are_named_where_they_appear() {
    // The effect starts on line 9, column 13.
    let e = error(
        &domain_with("(at end (when (ready ?t) (done ?t)))"),
        PROBLEM,
    );
    assert_eq!(
        e,
        "domain.pddl:9:21: unsupported PDDL feature: conditional effects (`when`)"
    );
    let e = error(
        &domain_with("(forall (?x - thing) (at end (done ?x)))"),
        PROBLEM,
    );
    assert_eq!(
        e,
        "domain.pddl:9:13: unsupported PDDL feature: universal effects (`forall`)"
    );
    let e = error(&domain_with("(at end (increase (fuel) (* #t 2)))"), PROBLEM);
    assert!(e.starts_with("domain.pddl:9:"), "{e}");
    assert!(e.contains("continuous effects (`#t`)"), "{e}");
}

#[test]
fn unsupported_conditions_and_requirements_are_named() {
    let d = domain_with("(at end (done ?t))").replace(
        "(at start (ready ?t))",
        "(at start (or (ready ?t) (done ?t)))",
    );
    let e = error(&d, PROBLEM);
    assert_eq!(
        e,
        "domain.pddl:8:26: unsupported PDDL feature: disjunctive conditions (`or`)"
    );
    let d = domain_with("(at end (done ?t))").replace(
        ":durative-actions)",
        ":durative-actions :derived-predicates)",
    );
    let e = error(&d, PROBLEM);
    assert_eq!(
        e,
        "domain.pddl:2:44: unsupported PDDL feature: requirement `:derived-predicates`"
    );
    let d = domain_with("(at end (done ?t))")
        .replace("(:types thing)", "(:types thing - (either a b))");
    let e = error(&d, PROBLEM);
    assert!(e.starts_with("domain.pddl:3:"), "{e}");
    assert!(e.contains("`either` types"), "{e}");
}

#[test]
fn syntax_errors_point_at_the_bracket() {
    // An unclosed list: the `(` that opens it (here `(define`, the file's last `)` gone).
    let full = domain_with("(at end (done ?t))");
    let d = full.trim_end().strip_suffix(')').expect("ends with `)`");
    let e = error(d, PROBLEM);
    assert_eq!(e, "domain.pddl:1:1: this `(` is never closed");
    // A stray `)` in the problem, line 2 column 38.
    let e = error(
        &domain_with("(at end (done ?t))"),
        &PROBLEM.replace("(done a)))", "(done a))))"),
    );
    assert_eq!(e, "problem.pddl:2:38: unbalanced `)`: no list is open here");
}

#[test]
fn a_goal_that_can_never_hold_is_refused_at_the_goal() {
    // `ready` is static (no action changes it) and false for `a` in the goal.
    let p = PROBLEM
        .replace("(:goal (done a))", "(:goal (ready b))")
        .replace("(:objects a - thing)", "(:objects a b - thing)");
    let e = error(&domain_with("(at end (done ?t))"), &p);
    assert!(e.starts_with("problem.pddl:2:"), "{e}");
    assert!(e.contains("can never hold"), "{e}");
}

#[test]
fn a_good_task_compiles() {
    // The same texts without the faults: the errors above come from the faults.
    let c = common::compile(&domain_with("(at end (done ?t))"), PROBLEM).expect("compiles");
    assert_eq!(c.action_names, vec!["(work a)".to_string()]);
}
