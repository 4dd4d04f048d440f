//! Compression safety (and the search's completeness) against brute force on small random
//! tasks: whenever some timed plan of at most three actions exists (found by trying every start
//! time on the integer grid, each candidate checked by the independent validator), the planner
//! with compression finds a plan too, and every plan it finds is valid. Compression may not
//! lose plans the uncompressed search finds either. Pruning every repeated state
//! ([`temporal::Duplicates::PruneAll`]) does lose plans: a fixed task shows it.
//!
//! Plans never run two instances of one ground action at once (the planner's running-action
//! facts say only whether an action runs, as in POPF and Stellar), so brute force does not
//! either. Times: one tick per time unit and an epsilon of one tick, durations of 1-3, so the earliest
//! schedule of any plan is on the integer grid and the first action can start at 0.
mod common;

use common::{Rng, Step, Validator};
use temporal::PlannerConfig;

const FACTS: usize = 5;
const ACTIONS: usize = 3;
const MAX_INSTANCES: usize = 3;
const MAX_DURATION: u64 = 3;
/// Latest start worth trying: every earlier action's duration plus two epsilons each.
const HORIZON: u32 = (MAX_INSTANCES as u32 - 1) * (ENVELOPE_DURATION + 2);
/// The envelope action's duration: room for any other action inside it.
const ENVELOPE_DURATION: u32 = MAX_DURATION as u32 + 2;
/// The fact only the enveloped action adds, in the goal of envelope tasks.
const ENVELOPED_GOAL: usize = FACTS - 1;

struct RandomTask {
    domain: String,
    problem: String,
    durations: Vec<u32>,
}

fn facts(rng: &mut Rng, max: u64) -> Vec<usize> {
    let mut out: Vec<usize> = (0..rng.below(max + 1))
        .map(|_| rng.below(FACTS as u64) as usize)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

fn and(items: &[String]) -> String {
    format!("(and {})", items.join(" "))
}

fn random_task(rng: &mut Rng) -> RandomTask {
    let mut actions = String::new();
    let mut durations = Vec::new();
    // Half the tasks get an envelope: a0 makes a fact true only while it runs and a1 needs it
    // throughout, so a1 must run inside a0 (compressing a0 would lose every plan that needs a1).
    let envelope = rng.chance(50).then(|| rng.below(FACTS as u64 - 1) as usize);
    for a in 0..ACTIONS {
        let d = if envelope.is_some() && a == 0 {
            ENVELOPE_DURATION
        } else {
            1 + rng.below(MAX_DURATION) as u32
        };
        durations.push(d);
        let mut cond = Vec::new();
        for f in facts(rng, 2) {
            cond.push(format!("(at start (p{f}))"));
        }
        for f in facts(rng, 1) {
            cond.push(format!("(over all (p{f}))"));
        }
        match envelope {
            Some(e) if a == 1 => cond.push(format!("(over all (p{e}))")),
            _ => {}
        }
        for f in facts(rng, 1) {
            cond.push(format!("(at end (p{f}))"));
        }
        let mut eff = Vec::new();
        for f in facts(rng, 1) {
            eff.push(format!("(at start (p{f}))"));
        }
        for f in facts(rng, 1) {
            eff.push(format!("(at start (not (p{f})))"));
        }
        for f in facts(rng, 2) {
            eff.push(format!("(at end (p{f}))"));
        }
        for f in facts(rng, 1) {
            eff.push(format!("(at end (not (p{f})))"));
        }
        match envelope {
            Some(e) if a == 0 => eff.push(format!("(at start (p{e})) (at end (not (p{e})))")),
            Some(_) if a == 1 => eff.push(format!("(at end (p{ENVELOPED_GOAL}))")),
            _ => {}
        }
        if eff.is_empty() {
            eff.push(format!("(at end (p{}))", rng.below(FACTS as u64)));
        }
        actions.push_str(&format!(
            "(:durative-action a{a} :parameters () :duration (= ?duration {d})\n  :condition {}\n  :effect {})\n",
            and(&cond),
            and(&eff)
        ));
    }
    let preds: String = (0..FACTS).map(|f| format!("(p{f}) ")).collect();
    let domain = format!(
        "(define (domain r) (:requirements :durative-actions) (:predicates {preds})\n{actions})"
    );
    let mut init = facts(rng, 2);
    let mut goal: Vec<usize> = facts(rng, 2)
        .into_iter()
        .filter(|g| !init.contains(g))
        .collect();
    if let Some(e) = envelope {
        init.retain(|&f| f != e && f != ENVELOPED_GOAL);
        if !goal.contains(&ENVELOPED_GOAL) {
            goal.push(ENVELOPED_GOAL);
        }
    }
    if goal.is_empty() {
        goal.push((0..FACTS).find(|f| !init.contains(f)).unwrap_or(0));
    }
    let init: String = init.iter().map(|f| format!("(p{f}) ")).collect();
    let goal: Vec<String> = goal.iter().map(|f| format!("(p{f})")).collect();
    let problem = format!(
        "(define (problem q) (:domain r) (:init {init}) (:goal {}))",
        and(&goal)
    );
    RandomTask {
        domain,
        problem,
        durations,
    }
}

/// Some valid plan of at most MAX_INSTANCES actions with integer start times, if one exists;
/// with `sequential`, only plans whose actions do not overlap in time.
fn brute_force_solvable(
    task: &RandomTask,
    validator: &Validator,
    sequential: bool,
) -> Option<Vec<Step>> {
    // Multisets of actions (non-decreasing sequences), then start times: one at 0, the others
    // anywhere on the grid up to HORIZON.
    fn multisets(len: usize, from: usize, prefix: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if prefix.len() == len {
            out.push(prefix.clone());
            return;
        }
        for a in from..ACTIONS {
            prefix.push(a);
            multisets(len, a, prefix, out);
            prefix.pop();
        }
    }
    for len in 1..=MAX_INSTANCES {
        let mut sets = Vec::new();
        multisets(len, 0, &mut Vec::new(), &mut sets);
        for set in sets {
            let others = len - 1;
            let combos = (HORIZON as usize + 1).pow(others as u32);
            for first in 0..len {
                for c in 0..combos {
                    let mut rest = c;
                    let mut plan = Vec::with_capacity(len);
                    for (k, &a) in set.iter().enumerate() {
                        let start = if k == first {
                            0
                        } else {
                            let t = rest % (HORIZON as usize + 1);
                            rest /= HORIZON as usize + 1;
                            t
                        };
                        plan.push(Step {
                            start: start as f64,
                            action: format!("(a{a})"),
                            duration: f64::from(task.durations[a]),
                        });
                    }
                    let overlaps = || {
                        plan.iter().enumerate().any(|(i, x)| {
                            plan[i + 1..].iter().any(|y| {
                                x.start < y.start + y.duration && y.start < x.start + x.duration
                            })
                        })
                    };
                    // The planner never runs two instances of one ground action at once.
                    let self_overlaps = plan.iter().enumerate().any(|(i, x)| {
                        plan[i + 1..].iter().any(|y| {
                            y.action == x.action
                                && x.start < y.start + y.duration
                                && y.start < x.start + x.duration
                        })
                    });
                    if !self_overlaps
                        && (!sequential || !overlaps())
                        && validator.validate(&plan).is_ok()
                    {
                        return Some(plan);
                    }
                }
            }
        }
    }
    None
}

fn compile(task: &RandomTask) -> Result<pddl::Compiled, pddl::PddlError> {
    pddl::compile(
        pddl::Source {
            name: "domain.pddl",
            text: &task.domain,
        },
        pddl::Source {
            name: "problem.pddl",
            text: &task.problem,
        },
        &pddl::ModuleRegistry::new(),
        &pddl::Options {
            ticks_per_unit: 1,
            epsilon_ticks: 1,
            ..Default::default()
        },
    )
}

#[test]
fn compression_loses_no_plan_brute_force_finds() {
    let mut rng = Rng(0xc0de_5afe);
    let (mut solvable, mut used_safe, mut had_unsafe) = (0, 0, 0);
    let mut needs_concurrency = 0;
    for round in 0..400 {
        let task = random_task(&mut rng);
        let validator = Validator::new(&task.domain, &task.problem, 1.0);
        let brute = brute_force_solvable(&task, &validator, false);
        let compiled = match compile(&task) {
            Ok(c) => c,
            Err(e) if e.message.contains("can never hold") => {
                // The front end proves the goal unreachable: brute force agrees.
                assert!(
                    brute.is_none(),
                    "{e}, but {brute:?} is valid\n{}\n{}",
                    task.domain,
                    task.problem
                );
                continue;
            }
            Err(e) => panic!("{e}\n{}\n{}", task.domain, task.problem),
        };
        let on = common::plan(&compiled, PlannerConfig::default(), 1 << 16, 50_000);
        let off = common::plan(
            &compiled,
            PlannerConfig {
                compression: false,
                ..PlannerConfig::default()
            },
            1 << 16,
            50_000,
        );
        let context = || {
            format!(
                "round {round}\n{}\n{}\nbrute force: {brute:?}",
                task.domain, task.problem
            )
        };
        for (name, run) in [("compressed", &on), ("uncompressed", &off)] {
            if run.status == temporal::Status::Solved {
                if let Err(why) = validator.validate(&run.plan) {
                    panic!("{name} plan invalid: {why}\n{:?}\n{}", run.plan, context());
                }
            }
        }
        if brute.is_some() || off.status == temporal::Status::Solved {
            assert_eq!(
                on.status,
                temporal::Status::Solved,
                "compression lost a plan\n{}",
                context()
            );
        }
        if brute.is_some() {
            assert_eq!(
                off.status,
                temporal::Status::Solved,
                "the search lost a plan\n{}",
                context()
            );
        }
        if brute.is_some() {
            solvable += 1;
            needs_concurrency +=
                usize::from(brute_force_solvable(&task, &validator, true).is_none());
            let t = temporal::Task::parse(&compiled.task).expect("valid");
            let mut arena = vec![0u32; 1 << 16];
            let p = temporal::Planner::new(t, &mut arena, PlannerConfig::default()).expect("fits");
            let safe: Vec<bool> = (0..t.action_count())
                .map(|a| p.compression_safe(a))
                .collect();
            let name_safe = |n: &str| {
                compiled
                    .action_names
                    .iter()
                    .position(|x| x == n)
                    .is_some_and(|a| safe[a])
            };
            used_safe += usize::from(on.plan.iter().any(|s| name_safe(&s.action)));
            had_unsafe += usize::from(safe.iter().any(|s| !s));
        }
    }
    // The random tasks exercised both kinds of action in solvable tasks.
    eprintln!(
        "{solvable} solvable ({needs_concurrency} only with actions overlapping), {used_safe} used a safe action, {had_unsafe} had an unsafe one"
    );
    // The random tasks exercised both kinds of action, and plans that need concurrency.
    assert!(solvable >= 40, "only {solvable} solvable tasks");
    assert!(
        used_safe >= 15,
        "only {used_safe} plans used a compression-safe action"
    );
    assert!(
        had_unsafe >= 30,
        "only {had_unsafe} solvable tasks had an unsafe action"
    );
    assert!(
        needs_concurrency >= 5,
        "only {needs_concurrency} tasks needed overlapping actions"
    );
}

/// Why the default prunes a repeated state only when nothing runs in it: here the state "a0 and
/// a2 running" is first reached with a0 started first, from which a0's end (it needs a2's end
/// effect) can never come in time; the plan starts a2 first.
#[test]
fn pruning_every_repeated_state_loses_a_plan_the_default_finds() {
    let task = RandomTask {
        domain: "(define (domain r) (:requirements :durative-actions) (:predicates (p0) (p1) (p2) (p3) (p4))
          (:durative-action a0 :parameters () :duration (= ?duration 2)
            :condition (and (at end (p4)))
            :effect (and (at start (p2)) (at start (not (p3))) (at end (not (p0)))))
          (:durative-action a1 :parameters () :duration (= ?duration 3)
            :condition (and (over all (p2)))
            :effect (and (at start (p0)) (at start (not (p0))) (at end (p3))))
          (:durative-action a2 :parameters () :duration (= ?duration 3)
            :condition (and)
            :effect (and (at start (not (p3))) (at end (p4)))))"
            .into(),
        problem: "(define (problem q) (:domain r) (:init (p1)) (:goal (and (p0) (p4))))".into(),
        durations: vec![2, 3, 3],
    };
    let validator = Validator::new(&task.domain, &task.problem, 1.0);
    assert!(brute_force_solvable(&task, &validator, false).is_some());
    let compiled = compile(&task).expect("compiles");
    let with = |duplicates| {
        common::plan(
            &compiled,
            PlannerConfig {
                duplicates,
                ..PlannerConfig::default()
            },
            1 << 16,
            50_000,
        )
    };
    let default = with(temporal::Duplicates::PruneQuiescent);
    assert_eq!(default.status, temporal::Status::Solved);
    validator.validate(&default.plan).expect("valid");
    assert_eq!(
        with(temporal::Duplicates::Keep).status,
        temporal::Status::Solved
    );
    // The dead state is a0 running with its end too late: the running-ends check (on by
    // default) drops it before the duplicate table keeps it, so the loss shows with it off.
    let prune_all = |check| {
        common::plan_with(
            &compiled,
            PlannerConfig {
                duplicates: temporal::Duplicates::PruneAll,
                ..PlannerConfig::default()
            },
            1 << 16,
            50_000,
            |p| p.set_check_running_ends(check),
        )
    };
    use temporal::search::RunningEnds;
    assert_eq!(
        prune_all(RunningEnds::Off).status,
        temporal::Status::Unsolvable
    );
    let checked = prune_all(RunningEnds::WithoutWindows);
    assert_eq!(checked.status, temporal::Status::Solved);
    validator.validate(&checked.plan).expect("valid");
}
