//! The heuristic's precondition index and counter-based cost propagation against a
//! straightforward computation on random small tasks: costs by iterating every relaxed action
//! to a fixpoint, best supporters by scanning every achiever, the relaxed plan by closure from
//! the goals, and the ready set (the search's successor candidates) by testing every relaxed
//! action's preconditions. h, the relaxed plan (the preferred operators) and the ready set must
//! be the same for every state, evaluated one after another in one set of tables (so scratch
//! left over from one state would show in the next). So must the count of relaxed-plan
//! actions whose preconditions a snap's deletes undo (the search's successor order).
mod common;

use common::Rng;
use temporal::heuristic::{Relaxation, RelaxedCost, DEAD_END};
use temporal::task::{write_task, ActionSpec, FactList, Task, UNBOUNDED};

struct RandomTask {
    facts: usize,
    actions: usize,
    lists: Vec<[Vec<u16>; 7]>,
    lb: Vec<u32>,
    init: Vec<u16>,
    goals: Vec<u16>,
}

fn subset(rng: &mut Rng, facts: usize, percent: u64) -> Vec<u16> {
    (0..facts as u16).filter(|_| rng.chance(percent)).collect()
}

fn random_task(rng: &mut Rng) -> RandomTask {
    let facts = 2 + rng.below(10) as usize;
    let actions = 1 + rng.below(9) as usize;
    let mut lists = Vec::new();
    let mut lb = Vec::new();
    for _ in 0..actions {
        let mut l: [Vec<u16>; 7] = Default::default();
        for (i, list) in l.iter_mut().enumerate() {
            // Conditions sparser than effects; a repeated fact now and then.
            *list = subset(rng, facts, if i < 3 { 20 } else { 25 });
            if !list.is_empty() && rng.chance(10) {
                list.push(list[0]);
            }
        }
        lists.push(l);
        // Long durations now and then: costs past the queue's buckets go to its heap.
        let longest = if rng.chance(50) { 20 } else { 700 };
        lb.push(1 + rng.below(longest) as u32);
    }
    RandomTask {
        facts,
        actions,
        lists,
        lb,
        init: subset(rng, facts, 35),
        goals: subset(rng, facts, 30),
    }
}

fn bytes_of(t: &RandomTask) -> Vec<u8> {
    let names: Vec<String> = (0..t.actions).map(|a| format!("(a{a})")).collect();
    let specs: Vec<ActionSpec<'_>> = (0..t.actions)
        .map(|a| ActionSpec {
            name: &names[a],
            duration_lb: t.lb[a],
            duration_ub: t.lb[a] + 5,
            start_window: (0, UNBOUNDED),
            end_window: (0, UNBOUNDED),
            facts: [
                &t.lists[a][0],
                &t.lists[a][1],
                &t.lists[a][2],
                &t.lists[a][3],
                &t.lists[a][4],
                &t.lists[a][5],
                &t.lists[a][6],
            ],
            numeric: [&[], &[], &[], &[], &[]],
        })
        .collect();
    let mut out = Vec::new();
    write_task(
        &mut |b| out.extend_from_slice(b),
        t.facts as u16,
        0,
        1,
        1,
        &t.init,
        &[],
        &t.goals,
        &[],
        &specs,
    );
    out
}

/// What the straightforward computation gives for one state.
#[derive(Debug, PartialEq)]
struct Expected {
    h: u32,
    /// Relaxed-plan membership per relaxed action (only meaningful when h is not DEAD_END).
    marked: Vec<bool>,
    ready: Vec<bool>,
}

/// Relaxed preconditions and effects of relaxed action r, straight from the definition
/// (seed 001 section 4.2): a start needs its start conditions and the invariants it does not
/// add, and adds its start effects and r_a; an end needs its end conditions and r_a.
fn relaxed_pre(t: &RandomTask, r: usize) -> Vec<usize> {
    let a = r / 2;
    let l = &t.lists[a];
    let mut pre: Vec<usize> = if r.is_multiple_of(2) {
        let mut p: Vec<usize> = l[FactList::PreStart as usize]
            .iter()
            .map(|&f| f as usize)
            .collect();
        p.extend(
            l[FactList::Invariant as usize]
                .iter()
                .filter(|f| !l[FactList::AddStart as usize].contains(f))
                .map(|&f| f as usize),
        );
        p
    } else {
        let mut p: Vec<usize> = l[FactList::PreEnd as usize]
            .iter()
            .map(|&f| f as usize)
            .collect();
        p.push(t.facts + a);
        p
    };
    pre.sort_unstable();
    pre.dedup();
    pre
}

fn relaxed_add(t: &RandomTask, r: usize) -> Vec<usize> {
    let a = r / 2;
    let l = &t.lists[a];
    if r.is_multiple_of(2) {
        let mut v: Vec<usize> = l[FactList::AddStart as usize]
            .iter()
            .map(|&f| f as usize)
            .collect();
        v.push(t.facts + a);
        v
    } else {
        l[FactList::AddEnd as usize]
            .iter()
            .map(|&f| f as usize)
            .collect()
    }
}

fn expected(
    t: &RandomTask,
    costs: RelaxedCost,
    dropped: u64,
    true_facts: &[bool],
    running: &[u32],
) -> Expected {
    let n = t.facts + t.actions;
    let relaxed = 2 * t.actions;
    let own = |r: usize| match costs {
        RelaxedCost::Unit => 1u32,
        RelaxedCost::Duration => {
            if r.is_multiple_of(2) {
                t.lb[r / 2] + 1
            } else {
                1
            }
        }
    };
    let mut cost = vec![u32::MAX; n];
    for (f, &on) in true_facts.iter().enumerate() {
        if on {
            cost[f] = 0;
        }
    }
    for &a in running {
        cost[t.facts + a as usize] = 0;
    }
    let action_cost = |cost: &[u32], r: usize| -> Option<u32> {
        let mut sum = 0u32;
        for p in relaxed_pre(t, r) {
            if cost[p] == u32::MAX {
                return None;
            }
            sum += cost[p];
        }
        Some(sum + own(r))
    };
    // Costs: iterate every relaxed action until nothing changes.
    loop {
        let mut changed = false;
        for r in 0..relaxed {
            if let Some(c) = action_cost(&cost, r) {
                for f in relaxed_add(t, r) {
                    if c < cost[f] {
                        cost[f] = c;
                        changed = true;
                    }
                }
            }
        }
        if !changed {
            break;
        }
    }
    let ready: Vec<bool> = (0..relaxed)
        .map(|r| relaxed_pre(t, r).iter().all(|&p| cost[p] == 0))
        .collect();
    let goals: Vec<usize> = t
        .goals
        .iter()
        .enumerate()
        .filter(|&(i, _)| !(i < 64 && dropped & (1 << i) != 0))
        .map(|(_, &g)| g as usize)
        .collect();
    if goals.iter().any(|&g| cost[g] == u32::MAX) {
        return Expected {
            h: DEAD_END,
            marked: vec![false; relaxed],
            ready,
        };
    }
    // Best supporter: the cheapest achiever, the lowest-numbered among equals.
    let supporter = |f: usize| -> Option<usize> {
        (0..relaxed)
            .find(|&r| relaxed_add(t, r).contains(&f) && action_cost(&cost, r) == Some(cost[f]))
    };
    let mut marked = vec![false; relaxed];
    let mut todo = goals.clone();
    while let Some(f) = todo.pop() {
        if cost[f] == 0 {
            continue;
        }
        let r = supporter(f).expect("a reached fact has an achiever at its cost");
        if !marked[r] {
            marked[r] = true;
            todo.extend(relaxed_pre(t, r));
        }
    }
    let mut h = marked.iter().filter(|&&m| m).count() as u32;
    for a in 0..t.actions {
        if marked[2 * a] && !marked[2 * a + 1] {
            h += 1;
        }
    }
    for &a in running {
        if !marked[2 * a as usize + 1] {
            h += 1;
            marked[2 * a as usize + 1] = true;
        }
    }
    Expected { h, marked, ready }
}

fn check(seed: u64, costs: RelaxedCost) {
    let mut rng = Rng(seed);
    // Actions whose end fires with their start (no end condition but the action running):
    // the propagation takes a shortcut for them, which these rounds must exercise.
    let mut end_follows = 0;
    let mut conflicts = 0;
    for round in 0..300 {
        let t = random_task(&mut rng);
        let bytes = bytes_of(&t);
        let task = Task::parse(&bytes).expect("valid task");
        let dropped = if rng.chance(20) { rng.next_u64() } else { 0 };
        let mut arena = vec![0u32; 1 << 16];
        let mut rest: &mut [u32] = &mut arena;
        let mut used = 0;
        let mut relax = Relaxation::new(&task, &mut rest, &mut used, costs, dropped).expect("fits");
        end_follows += relax
            .end_follows
            .iter()
            .map(|w| w.count_ones())
            .sum::<u32>();
        // Several states in a row in the same tables.
        for state in 0..8 {
            let true_facts: Vec<bool> = (0..t.facts).map(|_| rng.chance(40)).collect();
            let running: Vec<u32> = (0..t.actions as u32).filter(|_| rng.chance(20)).collect();
            let mut bits = vec![0u32; t.facts.div_ceil(32)];
            for (f, &on) in true_facts.iter().enumerate() {
                if on {
                    bits[f / 32] |= 1 << (f % 32);
                }
            }
            let h = relax.evaluate(&task, &bits, &running);
            let want = expected(&t, costs, dropped, &true_facts, &running);
            let ctx = format!(
                "seed {seed} round {round} state {state}: facts {true_facts:?} running {running:?}"
            );
            assert_eq!(h, want.h, "h, {ctx}");
            let ready: Vec<bool> = (0..2 * t.actions).map(|r| relax.is_ready(r)).collect();
            assert_eq!(ready, want.ready, "ready set, {ctx}");
            if h != DEAD_END {
                let marked: Vec<bool> = (0..2 * t.actions)
                    .map(|r| relax.in_relaxed_plan(r))
                    .collect();
                assert_eq!(marked, want.marked, "relaxed plan, {ctx}");
                // The successor order's count: deleted facts against the relaxed plan's
                // preconditions, pair by pair, from the definitions.
                for a in 0..t.actions {
                    for list in [FactList::DelStart, FactList::DelEnd] {
                        let dels = &t.lists[a][list as usize];
                        let want_conflicts: usize = dels
                            .iter()
                            .map(|&f| {
                                (0..2 * t.actions)
                                    .filter(|&r| {
                                        r / 2 != a
                                            && want.marked[r]
                                            && relaxed_pre(&t, r).contains(&(f as usize))
                                    })
                                    .count()
                            })
                            .sum();
                        let got = relax.plan_conflicts(a, dels.iter().map(|&f| f as usize));
                        assert_eq!(got as usize, want_conflicts, "conflicts of {a}, {ctx}");
                        conflicts += want_conflicts;
                    }
                }
            }
        }
    }
    assert!(
        end_follows > 100,
        "only {end_follows} end-follows actions exercised"
    );
    assert!(conflicts > 100, "only {conflicts} conflicts exercised");
}

#[test]
fn counter_heuristic_matches_the_fixpoint_with_unit_costs() {
    check(0x5eed_0001, RelaxedCost::Unit);
    check(0x5eed_0002, RelaxedCost::Unit);
}

#[test]
fn counter_heuristic_matches_the_fixpoint_with_duration_costs() {
    check(0x5eed_0003, RelaxedCost::Duration);
}

#[test]
fn ready_set_covers_every_applicable_start_and_end() {
    // The search takes successors from the ready set only: a start whose start conditions
    // hold and whose invariants hold after it (what applying it requires, numbers aside)
    // must be ready, and so must the end of a running action whose end conditions hold.
    let mut rng = Rng(0x5eed_0004);
    for _ in 0..300 {
        let t = random_task(&mut rng);
        let bytes = bytes_of(&t);
        let task = Task::parse(&bytes).expect("valid task");
        let mut arena = vec![0u32; 1 << 16];
        let mut rest: &mut [u32] = &mut arena;
        let mut used = 0;
        let mut relax =
            Relaxation::new(&task, &mut rest, &mut used, RelaxedCost::Unit, 0).expect("fits");
        let true_facts: Vec<bool> = (0..t.facts).map(|_| rng.chance(50)).collect();
        let running: Vec<u32> = (0..t.actions as u32).filter(|_| rng.chance(30)).collect();
        let mut bits = vec![0u32; t.facts.div_ceil(32)];
        for (f, &on) in true_facts.iter().enumerate() {
            if on {
                bits[f / 32] |= 1 << (f % 32);
            }
        }
        relax.evaluate(&task, &bits, &running);
        for a in 0..t.actions {
            let l = &t.lists[a];
            let holds = |list: FactList| l[list as usize].iter().all(|&f| true_facts[f as usize]);
            let mut after = true_facts.clone();
            for &f in &l[FactList::DelStart as usize] {
                after[f as usize] = false;
            }
            for &f in &l[FactList::AddStart as usize] {
                after[f as usize] = true;
            }
            let invariants_after = l[FactList::Invariant as usize]
                .iter()
                .all(|&f| after[f as usize]);
            if holds(FactList::PreStart) && invariants_after {
                assert!(
                    relax.is_ready(2 * a),
                    "start of {a} applicable but not ready"
                );
            }
            if running.contains(&(a as u32)) && holds(FactList::PreEnd) {
                assert!(
                    relax.is_ready(2 * a + 1),
                    "end of {a} applicable but not ready"
                );
            }
        }
    }
}

/// The search's filter for the start's deadlock check (`Planner::end_may_block`) against a
/// scan of every pair of actions: every action whose end deletes another action's invariant
/// without adding it back must be marked (it may block that one's end), and no other.
#[test]
fn end_may_block_marks_exactly_the_ends_that_delete_an_invariant() {
    let mut rng = Rng(0x5eed_0005);
    let (mut marked, mut unmarked) = (0, 0);
    for _ in 0..300 {
        let t = random_task(&mut rng);
        let bytes = bytes_of(&t);
        let task = Task::parse(&bytes).expect("valid task");
        let mut arena = vec![0u32; 1 << 18];
        let planner = temporal::Planner::new(task, &mut arena, temporal::PlannerConfig::default())
            .expect("fits");
        for x in 0..t.actions {
            let l = &t.lists[x];
            let deletes = |f: &u16| !l[FactList::AddEnd as usize].contains(f);
            let expected = l[FactList::DelEnd as usize].iter().any(|f| {
                deletes(f)
                    && (0..t.actions).any(|y| t.lists[y][FactList::Invariant as usize].contains(f))
            });
            assert_eq!(
                planner.end_may_block(x),
                expected,
                "action {x} of {:?}",
                t.lists
            );
            if expected {
                marked += 1;
            } else {
                unmarked += 1;
            }
        }
    }
    assert!(
        marked > 50 && unmarked > 50,
        "{marked} marked, {unmarked} not"
    );
}
