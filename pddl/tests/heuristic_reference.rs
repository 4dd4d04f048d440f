//! The planner's heuristic (`temporal::heuristic`) against the computation it replaced, kept
//! as a test-only reference (`reference/heuristic_before.rs`), on benchmark tasks: the same h,
//! the same relaxed plan (the preferred operators) and the same set of relaxed actions ready in
//! the state (the search's successor candidates), state after state in one set of tables each,
//! with unit and duration costs and with goals dropped. The change made an evaluation cheaper;
//! it must not change what an evaluation says, so plans stay what they were.
//!
//! The states: random walks from the initial state over the snap actions the heuristic finds
//! ready (a start of an action not running, an end of one running: its deletes, then its adds;
//! invariants and numbers are not checked, the heuristic ignores them), with now and then a
//! state of random facts and running actions (dead ends among them).
mod common;

#[path = "reference/heuristic_before.rs"]
mod reference;

use common::Rng;
use temporal::heuristic::{Relaxation, RelaxedCost, DEAD_END};
use temporal::task::{FactList, Task};

const ARENA_WORDS: usize = 2 << 20;

fn files(domain: &str, instance: u32) -> (String, String) {
    let dir = format!("{}/tests/benchmarks/{domain}", env!("CARGO_MANIFEST_DIR"));
    let d = std::fs::read_to_string(format!("{dir}/domain.pddl")).expect("domain file");
    let p =
        std::fs::read_to_string(format!("{dir}/instance-{instance}.pddl")).expect("instance file");
    (d, p)
}

struct Walk {
    facts: Vec<u32>,
    running: Vec<u32>,
}

impl Walk {
    fn initial(task: &Task<'_>) -> Self {
        let mut facts = vec![0u32; task.fact_count().div_ceil(32)];
        for f in 0..task.fact_count() {
            if task.initially_true(f) {
                facts[f / 32] |= 1 << (f % 32);
            }
        }
        Walk {
            facts,
            running: Vec::new(),
        }
    }

    fn random(task: &Task<'_>, rng: &mut Rng) -> Self {
        let percent = 5 + rng.below(60);
        let mut facts = vec![0u32; task.fact_count().div_ceil(32)];
        for f in 0..task.fact_count() {
            if rng.chance(percent) {
                facts[f / 32] |= 1 << (f % 32);
            }
        }
        let mut running: Vec<u32> = (0..task.action_count() as u32)
            .filter(|_| rng.below(1000) < 3)
            .take(64)
            .collect();
        running.sort_unstable();
        Walk { facts, running }
    }

    fn set(&mut self, f: usize, on: bool) {
        if on {
            self.facts[f / 32] |= 1 << (f % 32);
        } else {
            self.facts[f / 32] &= !(1 << (f % 32));
        }
    }

    /// Apply relaxed action `r` as a snap (start or end), ignoring invariants and numbers.
    fn apply(&mut self, task: &Task<'_>, r: usize) {
        let a = r / 2;
        let act = task.action(a);
        let (del, add) = if r.is_multiple_of(2) {
            self.running.push(a as u32);
            self.running.sort_unstable();
            (FactList::DelStart, FactList::AddStart)
        } else {
            self.running.retain(|&x| x as usize != a);
            (FactList::DelEnd, FactList::AddEnd)
        };
        for f in act.facts(del).iter() {
            self.set(f, false);
        }
        for f in act.facts(add).iter() {
            self.set(f, true);
        }
    }
}

/// Evaluate `states` states of a walk on `domain` `instance` with both heuristics and compare
/// everything the search reads; the number of states compared and of dead ends among them.
fn compare(domain: &str, instance: u32, costs: RelaxedCost, dropped: u64, states: usize) -> usize {
    let (d, p) = files(domain, instance);
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).expect("valid");
    let relaxed = 2 * task.action_count();
    let mut arena_new = vec![0u32; ARENA_WORDS];
    let mut arena_old = vec![0u32; ARENA_WORDS];
    let (mut rest, mut used) = (&mut arena_new[..], 0);
    let mut new = Relaxation::new(&task, &mut rest, &mut used, costs, dropped).expect("fits");
    let (mut rest, mut used) = (&mut arena_old[..], 0);
    let old_costs = match costs {
        RelaxedCost::Unit => reference::RelaxedCost::Unit,
        RelaxedCost::Duration => reference::RelaxedCost::Duration,
    };
    let mut old =
        reference::Relaxation::new(&task, &mut rest, &mut used, old_costs, dropped).expect("fits");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ u64::from(instance) << 8 ^ dropped);
    let mut walk = Walk::initial(&task);
    let mut dead_ends = 0;
    for i in 0..states {
        let h_new = new.evaluate(&task, &walk.facts, &walk.running);
        let h_old = old.evaluate(&task, &walk.facts, &walk.running);
        assert_eq!(
            h_new, h_old,
            "{domain} {instance} {costs:?} dropped {dropped:#x}: h of state {i}"
        );
        for r in 0..relaxed {
            assert_eq!(
                new.is_ready(r),
                old.is_ready(r),
                "{domain} {instance} {costs:?}: ready {r} in state {i}"
            );
            if h_new != DEAD_END {
                assert_eq!(
                    new.in_relaxed_plan(r),
                    old.in_relaxed_plan(r),
                    "{domain} {instance} {costs:?}: relaxed plan {r} in state {i}"
                );
            }
        }
        if h_new == DEAD_END {
            dead_ends += 1;
        }
        // The next state: a random one now and then, else a ready snap of this one.
        let candidates: Vec<usize> = (0..relaxed)
            .filter(|&r| new.is_ready(r) && (r % 2 == 1) == walk.running.contains(&(r as u32 / 2)))
            .collect();
        if rng.chance(8) || candidates.is_empty() {
            walk = if rng.chance(50) {
                Walk::random(&task, &mut rng)
            } else {
                Walk::initial(&task)
            };
        } else {
            // Prefer the relaxed plan's snaps, as the search does, so walks go somewhere.
            let preferred: Vec<usize> = candidates
                .iter()
                .copied()
                .filter(|&r| new.in_relaxed_plan(r))
                .collect();
            let pool = if !preferred.is_empty() && rng.chance(70) {
                &preferred
            } else {
                &candidates
            };
            let r = pool[rng.below(pool.len() as u64) as usize];
            if walk.running.len() < 64 || r % 2 == 1 {
                walk.apply(&task, r);
            }
        }
    }
    dead_ends
}

#[test]
fn the_heuristic_says_what_it_said_before_on_satellite() {
    for i in [1, 3, 18] {
        compare("satellite", i, RelaxedCost::Unit, 0, 300);
    }
    compare("satellite", 17, RelaxedCost::Unit, 0, 120);
    compare("satellite", 3, RelaxedCost::Duration, 0, 300);
    compare("satellite", 3, RelaxedCost::Unit, 0b101, 200);
}

#[test]
fn the_heuristic_says_what_it_said_before_on_rovers() {
    for i in [2, 6, 18] {
        compare("rovers", i, RelaxedCost::Unit, 0, 300);
    }
    compare("rovers", 6, RelaxedCost::Duration, 0, 300);
    compare("rovers", 18, RelaxedCost::Unit, 0b11, 200);
}

#[test]
fn the_heuristic_says_what_it_said_before_on_driverlog_crew_and_pipesworld() {
    let mut dead_ends = 0;
    for i in [3, 14] {
        dead_ends += compare("driverlog", i, RelaxedCost::Unit, 0, 400);
    }
    dead_ends += compare("driverlog", 14, RelaxedCost::Duration, 0, 300);
    dead_ends += compare("crew", 2, RelaxedCost::Unit, 0, 300);
    dead_ends += compare("pipesworld", 2, RelaxedCost::Unit, 0, 300);
    dead_ends += compare("pipesworld", 2, RelaxedCost::Duration, 0, 300);
    // The random states include dead ends, so those are compared too.
    assert!(dead_ends > 0, "no dead end among the states compared");
}

/// The plans of two instances measured with the cheaper evaluation (README, "Temporal PDDL
/// planning"), in the target's 8 MiB arena: valid (the independent validator), and searched as
/// before the change: satellite 13 (newly within issue 13's 500 million instructions on the
/// target) in 445 evaluations and 444 expansions to a makespan of 211.37, driverlog 2 in 532
/// evaluations to 162.18, as the README measured them before (driverlog 2's 697 expansions
/// measured with the change); rovers 19 and 20 (newly within the 500 million with the groups
/// of starts, the counters kept from the state before and the cheaper task lists) in 813 and
/// 744 evaluations to 255.25 and 369.44, as before those changes; driverlog 14 (newly within
/// with the task's cheaper reads) in 1,499 evaluations to 241.31.
#[test]
fn plans_with_the_cheaper_evaluation_are_valid_and_searched_as_before() {
    for (domain, instance, evaluated, expanded, makespan) in [
        ("satellite", 13, 445, 444, 211.37),
        ("driverlog", 2, 532, 697, 162.18),
        ("rovers", 19, 813, 895, 255.25),
        ("rovers", 20, 744, 754, 369.44),
        ("driverlog", 14, 1499, 2318, 241.31),
    ] {
        let (d, p) = files(domain, instance);
        let compiled = common::compile(&d, &p).expect("compiles");
        // The search these were measured with: without the lookahead along the relaxed plan
        // (`temporal::search::LOOKAHEAD_PHASES`, since), which changes the search, not h.
        let planned = common::plan_with(
            &compiled,
            temporal::PlannerConfig::default(),
            2 << 20,
            50_000,
            |p| p.set_lookahead_phases(0),
        );
        assert_eq!(
            planned.status,
            temporal::Status::Solved,
            "{domain} {instance}"
        );
        let validator = common::Validator::new(&d, &p, 0.01);
        if let Err(why) = validator.validate(&planned.plan) {
            panic!("{domain} {instance}: invalid plan: {why}");
        }
        assert_eq!(
            (planned.stats.evaluated, planned.stats.expanded),
            (evaluated, expanded),
            "{domain} {instance}"
        );
        assert!(
            (planned.makespan - makespan).abs() < 0.005,
            "{domain} {instance}"
        );
    }
}
