//! Replanning from the middle of a plan (seed 001, 5.1-5.3; `temporal::replan`): the state
//! reached by executing a prefix of a valid plan, its running actions carried as completions
//! (or paused into their inactive states), the timed-literal windows moved to the new epoch;
//! the plan found from there, appended to the prefix, is checked by the independent validator.
mod common;

use common::rover::{long_rover, plan_task, rover};

use temporal::dispatch::{Decision, Dispatcher, PlanNetwork};
use temporal::replan::{self, Carried, Happening, ReplanInput};
use temporal::{PlannedAction, Task};

fn steps(compiled: &pddl::Compiled, plan: &[(u16, u32, u32)]) -> Vec<common::Step> {
    plan.iter()
        .map(|&(a, start, duration)| common::Step {
            start: f64::from(start) / 1000.0,
            action: compiled.action_names[usize::from(a)].clone(),
            duration: f64::from(duration) / 1000.0,
        })
        .collect()
}

/// The happenings of `plan` before `cut` (ticks), in time order (a start before its own end).
fn history(plan: &[PlannedAction], cut: u32) -> Vec<Happening> {
    let mut h: Vec<(u32, usize, bool)> = Vec::new();
    for (i, p) in plan.iter().enumerate() {
        if p.start < cut {
            h.push((p.start, i, false));
        }
        if p.start + p.duration < cut {
            h.push((p.start + p.duration, i, true));
        }
    }
    h.sort();
    h.into_iter()
        .map(|(at, i, end)| Happening {
            action: plan[i].action,
            end,
            at,
        })
        .collect()
}

/// Replan at `cut` after executing `plan` up to it (pausing the pausable running actions if
/// `pause`); the prefix plus the new plan shifted by `cut`, and what was carried and paused.
fn replan_at(
    compiled: &pddl::Compiled,
    plan: &[PlannedAction],
    cut: u32,
    pause: bool,
) -> (Vec<(u16, u32, u32)>, usize, usize) {
    let task = Task::parse(&compiled.task).unwrap();
    let inactive = |f: usize| compiled.fact_names[f].starts_with("(inactive-");
    let hist = history(plan, cut);
    let mut facts = vec![0u32; replan::fact_words(&task)];
    let mut values = vec![0i64; task.numeric_count()];
    replan::replay(&task, &hist, &mut facts, &mut values).expect("replays");
    let mut carried = Vec::new();
    let mut paused = Vec::new();
    for p in plan {
        if p.start < cut && p.start + p.duration >= cut {
            if pause && replan::is_pausable(&task, usize::from(p.action), &inactive) {
                replan::pause(&task, usize::from(p.action), &mut facts).unwrap();
                paused.push(p.action);
            } else {
                carried.push(Carried {
                    action: p.action,
                    remaining_lb: p.start + p.duration - cut,
                    remaining_ub: p.start + p.duration - cut,
                });
            }
        }
    }
    let mut out = vec![0u8; 1 << 20];
    let len = replan::write_replan_task(
        &ReplanInput {
            task,
            now: cut,
            facts: &facts,
            values: &values,
            carried: &carried,
            extra_goals: &[],
        },
        &mut out,
    )
    .expect("writes");
    let new_task = Task::parse(&out[..len]).expect("the replan task is a valid task");
    assert_eq!(new_task.action_count(), task.action_count() + carried.len());
    // A carried action starts again only after its completion ended: its completion's fact
    // is an at-start condition of its own record.
    for (k, c) in carried.iter().enumerate() {
        let pre = new_task
            .action(usize::from(c.action))
            .facts(temporal::task::FactList::PreStart);
        assert!(pre.contains(task.fact_count() + k));
        let before = task
            .action(usize::from(c.action))
            .facts(temporal::task::FactList::PreStart);
        assert_eq!(pre.len(), before.len() + 1);
    }
    let new_plan = plan_task(new_task).unwrap_or_else(|| panic!("no plan from {cut}"));
    // Every running action carried is ended by the new plan, at the epoch's start.
    for k in 0..carried.len() {
        let c = new_plan
            .iter()
            .find(|p| usize::from(p.action) == task.action_count() + k)
            .unwrap_or_else(|| panic!("completion {k} missing from the replan at {cut}"));
        assert_eq!(c.start, 0);
        assert!(new_task
            .action_name(usize::from(c.action))
            .starts_with("(finish ("));
    }
    let mut whole: Vec<(u16, u32, u32)> = plan
        .iter()
        .filter(|p| p.start < cut && !paused.contains(&p.action))
        .map(|p| (p.action, p.start, p.duration))
        .collect();
    whole.extend(
        new_plan
            .iter()
            .filter(|p| usize::from(p.action) < task.action_count())
            .map(|p| (p.action, p.start + cut, p.duration)),
    );
    (whole, carried.len(), paused.len())
}

#[test]
fn replanning_after_any_prefix_gives_a_plan_that_completes_it_validly() {
    let (d, p) = rover();
    let compiled = common::compile(&d, &p).expect("compiles");
    let validator = common::Validator::new(&d, &p, 0.01);
    let task = Task::parse(&compiled.task).unwrap();
    let original = plan_task(task).expect("the rover day has a plan");
    let as_steps: Vec<_> = original
        .iter()
        .map(|p| (p.action, p.start, p.duration))
        .collect();
    validator
        .validate(&steps(&compiled, &as_steps))
        .expect("the original plan is valid");
    // Cut inside every action, just after every start, and after the first window closed.
    let mut cuts: Vec<u32> = original
        .iter()
        .flat_map(|p| [p.start + 1, p.start + p.duration / 2])
        .collect();
    cuts.push(950_000);
    cuts.sort();
    cuts.dedup();
    let (mut carried_total, mut cut_count) = (0, 0);
    for &cut in &cuts {
        let (whole, carried, _) = replan_at(&compiled, &original, cut, false);
        carried_total += carried;
        cut_count += 1;
        validator
            .validate(&steps(&compiled, &whole))
            .unwrap_or_else(|e| panic!("cut at {cut} ticks: {e}\n{whole:?}"));
    }
    assert!(
        cut_count >= 10 && carried_total >= 5,
        "{cut_count} cuts, {carried_total} carried"
    );
}

#[test]
fn pausing_puts_the_component_back_inactive_and_the_new_plan_does_its_work_again() {
    let (d, p) = rover();
    let compiled = common::compile(&d, &p).expect("compiles");
    let validator = common::Validator::new(&d, &p, 0.01);
    let task = Task::parse(&compiled.task).unwrap();
    let original = plan_task(task).expect("plan");
    let inactive = |f: usize| compiled.fact_names[f].starts_with("(inactive-");
    let name = |a: u16| compiled.action_names[usize::from(a)].clone();
    // The convention: imaging, sampling and sending are pausable, a traverse is not.
    for a in 0..task.action_count() {
        let pausable = replan::is_pausable(&task, a, &inactive);
        assert_eq!(
            pausable,
            !compiled.action_names[a].starts_with("(traverse"),
            "{}",
            compiled.action_names[a]
        );
    }
    let mut paused_somewhere = 0;
    for p in original
        .iter()
        .filter(|p| !name(p.action).starts_with("(traverse"))
    {
        let cut = p.start + p.duration / 2;
        let (whole, _, paused) = replan_at(&compiled, &original, cut, true);
        assert!(paused >= 1);
        paused_somewhere += 1;
        // The paused action's work is done again after the cut (a send maybe from another
        // waypoint or in the other window: the same schema, rover and object).
        let work = |a: u16| name(a).split(' ').take(3).collect::<Vec<_>>().join(" ");
        assert!(
            whole
                .iter()
                .any(|&(a, s, _)| work(a) == work(p.action) && s >= cut),
            "{} not done again after {cut}",
            name(p.action)
        );
        validator
            .validate(&steps(&compiled, &whole))
            .unwrap_or_else(|e| panic!("pause at {cut}: {e}"));
    }
    assert!(paused_somewhere >= 3);
    // The state after pausing has the component inactive again.
    let image = original
        .iter()
        .find(|p| name(p.action).starts_with("(take-image"))
        .unwrap();
    let mut facts = vec![0u32; replan::fact_words(&task)];
    let mut values = vec![0i64; task.numeric_count()];
    let camera = compiled
        .fact_names
        .iter()
        .position(|f| f == "(inactive-camera r0)")
        .unwrap();
    replan::replay(
        &task,
        &history(&original, image.start + 1),
        &mut facts,
        &mut values,
    )
    .unwrap();
    assert!(!replan::fact(&facts, camera));
    replan::pause(&task, usize::from(image.action), &mut facts).unwrap();
    assert!(replan::fact(&facts, camera));
}

#[test]
fn windows_move_to_the_new_epoch_and_closed_ones_are_empty() {
    use temporal::task::UNBOUNDED;
    assert_eq!(replan::shift_window((600, 900), 100), (500, 800));
    assert_eq!(replan::shift_window((600, 900), 700), (0, 200));
    assert_eq!(
        replan::shift_window((600, 900), 901),
        (UNBOUNDED, UNBOUNDED)
    );
    assert_eq!(replan::shift_window((0, UNBOUNDED), 50), (0, UNBOUNDED));
    // After the first window closed, a send can only use the second one.
    let (d, p) = rover();
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let original = plan_task(task).unwrap();
    let (whole, _, _) = replan_at(&compiled, &original, 950_000, false);
    for &(a, s, _) in &whole {
        let n = &compiled.action_names[usize::from(a)];
        if n.starts_with("(send") && s >= 950_000 {
            assert!(n.ends_with("c2)"), "{n} at {s}");
            assert!(s >= 1_200_000, "{n} at {s}");
        }
    }
}

#[test]
fn a_network_rebuilt_from_a_plan_dispatches_it_as_planned() {
    let (d, p) = rover();
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let original = plan_task(task).unwrap();
    let mut net = PlanNetwork::new();
    let mut scratch = vec![0u32; task.fact_count() + task.numeric_count()];
    replan::network_from_plan(&task, &original, false, &mut scratch, &mut net).expect("network");
    assert_eq!(net.step_count(), 2 * original.len());
    let makespan = original.iter().map(|p| p.start + p.duration).max().unwrap();
    assert_eq!(net.makespan, makespan);
    let mut d = Dispatcher::new(net, makespan).expect("consistent");
    // Execute every start when told, every end at its planned time: no replan, the same times.
    let mut now = 0u32;
    let mut ends: Vec<(u32, usize)> = Vec::new();
    let mut started = 0;
    let mut used: Vec<usize> = Vec::new();
    loop {
        match d.poll(now, &|_| true) {
            Decision::Start { step, action } => {
                // The first occurrence of the action not started yet (a traverse may repeat).
                let i = (0..original.len())
                    .find(|&i| original[i].action == action && !used.contains(&i))
                    .expect("a planned action");
                used.push(i);
                let p = &original[i];
                assert_eq!(
                    now,
                    p.start,
                    "{}",
                    compiled.action_names[usize::from(action)]
                );
                d.executed(step, now).unwrap();
                let end = d.network().end_of(step).unwrap();
                ends.push((now + p.duration, end));
                started += 1;
            }
            Decision::Wait { until } => {
                ends.sort();
                let next_end = ends.first().map(|e| e.0);
                let next = match (until, next_end) {
                    (Some(u), Some(e)) => u.min(e),
                    (a, b) => a.or(b).expect("something to wait for"),
                };
                now = next;
                while ends.first().is_some_and(|e| e.0 <= now) {
                    let (t, k) = ends.remove(0);
                    d.executed(k, t).unwrap();
                }
            }
            Decision::Replan { step, .. } => panic!("replan at step {step}"),
            Decision::Finished => break,
        }
    }
    assert_eq!(started, original.len());
}

/// A network built in pieces (any number of steps a piece, down to one) is the network built
/// whole: the same steps, constraints and makespan, for a plan of over 60 actions.
#[test]
fn a_network_built_in_pieces_is_the_network_built_whole() {
    let (d, p) = long_rover(30);
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let plan = plan_task(task).expect("a plan");
    assert!(plan.len() >= 60, "{} actions", plan.len());
    let mut scratch = vec![0u32; task.fact_count() + task.numeric_count()];
    let mut whole = PlanNetwork::new();
    replan::network_from_plan(&task, &plan, true, &mut scratch, &mut whole).expect("network");
    for per_piece in [1usize, 2, 7, 50] {
        let mut net = PlanNetwork::new();
        let mut scratch = vec![0u32; task.fact_count() + task.numeric_count()];
        let mut progress =
            replan::network_from_plan_begin(&task, &plan, &mut scratch, &mut net).unwrap();
        assert_eq!(progress.total, 2 * plan.len());
        let mut pieces = 0;
        loop {
            pieces += 1;
            let mut left = per_piece - 1;
            let mut more = || {
                let go = left > 0;
                left = left.saturating_sub(1);
                go
            };
            let done = replan::network_from_plan_steps(
                &task,
                &plan,
                true,
                &mut scratch,
                &mut net,
                &mut progress,
                &mut more,
            )
            .unwrap();
            if done {
                break;
            }
            assert_eq!(progress.next, pieces * per_piece);
        }
        assert_eq!(pieces, (2 * plan.len()).div_ceil(per_piece));
        assert_eq!(net.step_count(), whole.step_count());
        assert_eq!(net.makespan, whole.makespan);
        assert_eq!(
            net.constraints(),
            whole.constraints(),
            "{per_piece} a piece"
        );
        for k in 1..=net.step_count() {
            assert_eq!(net.step(k), whole.step(k));
        }
        // A piece out of step with the network is refused.
        progress.next = 3;
        assert!(replan::network_from_plan_steps(
            &task,
            &plan,
            true,
            &mut scratch,
            &mut net,
            &mut progress,
            &mut || true
        )
        .is_err());
    }
}

#[test]
fn bad_replan_inputs_are_refused_never_a_panic() {
    use temporal::replan::ReplanError;
    let (d, p) = rover();
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let original = plan_task(task).unwrap();
    let mut facts = vec![0u32; replan::fact_words(&task)];
    let mut values = vec![0i64; task.numeric_count()];
    // An end before its start, and happenings out of time order.
    let a = original[0].action;
    let end_first = [Happening {
        action: a,
        end: true,
        at: 5,
    }];
    assert_eq!(
        replan::replay(&task, &end_first, &mut facts, &mut values),
        Err(ReplanError::BadHistory)
    );
    let backwards = [
        Happening {
            action: a,
            end: false,
            at: 9,
        },
        Happening {
            action: a,
            end: true,
            at: 3,
        },
    ];
    assert_eq!(
        replan::replay(&task, &backwards, &mut facts, &mut values),
        Err(ReplanError::BadHistory)
    );
    // State storage too small, an unknown action, too many carried, every short buffer.
    assert_eq!(
        replan::initial_state(&task, &mut [], &mut values),
        Err(ReplanError::StateTooSmall)
    );
    replan::initial_state(&task, &mut facts, &mut values).unwrap();
    let input = |carried: &'static [Carried]| ReplanInput {
        task,
        now: 1000,
        facts: Box::leak(facts.clone().into_boxed_slice()),
        values: Box::leak(values.clone().into_boxed_slice()),
        carried,
        extra_goals: &[],
    };
    let unknown: &'static [Carried] = Box::leak(Box::new([Carried {
        action: u16::MAX,
        remaining_lb: 1,
        remaining_ub: 1,
    }]));
    let mut out = vec![0u8; 1 << 20];
    assert_eq!(
        replan::write_replan_task(&input(unknown), &mut out),
        Err(ReplanError::UnknownAction)
    );
    let many: &'static [Carried] = Box::leak(
        vec![
            Carried {
                action: a,
                remaining_lb: 1,
                remaining_ub: 1
            };
            replan::MAX_CARRIED + 1
        ]
        .into_boxed_slice(),
    );
    assert_eq!(
        replan::write_replan_task(&input(many), &mut out),
        Err(ReplanError::TooMany)
    );
    let one: &'static [Carried] = Box::leak(Box::new([Carried {
        action: a,
        remaining_lb: 7,
        remaining_ub: 7,
    }]));
    let len = replan::write_replan_task(&input(one), &mut out).expect("fits");
    for short in 0..len {
        assert_eq!(
            replan::write_replan_task(&input(one), &mut out[..short]),
            Err(ReplanError::NoRoom),
            "{short} bytes"
        );
    }
    // A network refuses an action the task does not have.
    let mut net = PlanNetwork::new();
    let mut scratch = vec![0u32; task.fact_count() + task.numeric_count()];
    let bad = [PlannedAction {
        action: u16::MAX,
        ..PlannedAction::default()
    }];
    assert!(replan::network_from_plan(&task, &bad, true, &mut scratch, &mut net).is_err());
}

/// The dispatcher's incremental windows are the whole propagation's on long-day's plan (the
/// rover's day with thirty objectives, over 60 actions): executed with every action's end on
/// time, a tenth early and a tenth late by turns, every decision and every step's window at every poll the
/// same as the propagation from nothing's, through the replans the late ends cause.
#[test]
fn incremental_dispatch_windows_are_the_whole_propagations_on_a_long_plan() {
    let (d, p) = long_rover(30);
    let compiled = common::compile(&d, &p).expect("compiles");
    let task = Task::parse(&compiled.task).unwrap();
    let plan = plan_task(task).expect("a plan");
    assert!(plan.len() >= 60, "{} actions", plan.len());
    let mut scratch = vec![0u32; task.fact_count() + task.numeric_count()];
    let mut net = PlanNetwork::new();
    replan::network_from_plan(&task, &plan, false, &mut scratch, &mut net).expect("network");
    let steps = net.step_count();
    let (mut finished, mut replanned) = (0, 0);
    for (run, slack) in [(0u32, 0u32), (1, 60_000), (2, 600_000)] {
        let horizon = net.makespan + slack;
        let mut inc = Dispatcher::new(net.clone(), horizon).expect("consistent");
        let mut whole = Dispatcher::new(net.clone(), horizon).expect("consistent");
        whole.set_whole_propagation(true);
        let mut now = 0u32;
        let mut ends: Vec<(u32, usize)> = Vec::new();
        let (mut polls, mut starts, mut replans) = (0, 0, 0);
        for _ in 0..8 * steps {
            let a = inc.poll(now, &|_| true);
            assert_eq!(a, whole.poll(now, &|_| true), "run {run} at {now}");
            for k in 0..=steps {
                assert_eq!(
                    inc.window(k),
                    whole.window(k),
                    "run {run}: step {k} at {now}"
                );
            }
            polls += 1;
            match a {
                Decision::Start { step, action } => {
                    inc.executed(step, now).unwrap();
                    whole.executed(step, now).unwrap();
                    let planned = plan
                        .iter()
                        .find(|p| p.action == action)
                        .map_or(1000, |p| p.duration);
                    // By turns on time, a tenth early, a tenth late.
                    let took = match (starts + run as usize) % 3 {
                        0 => planned,
                        1 => planned - planned / 10,
                        _ => planned + planned / 10,
                    };
                    ends.push((now + took, inc.network().end_of(step).unwrap()));
                    starts += 1;
                }
                Decision::Wait { until } => {
                    ends.sort();
                    let next = match (until, ends.first().map(|e| e.0)) {
                        (Some(u), Some(e)) => u.min(e),
                        (a, b) => match a.or(b) {
                            Some(t) => t,
                            None => break,
                        },
                    };
                    now = next.max(now);
                    while ends.first().is_some_and(|e| e.0 <= now) {
                        let (t, k) = ends.remove(0);
                        inc.executed(k, t).unwrap();
                        whole.executed(k, t).unwrap();
                    }
                }
                Decision::Replan { .. } => {
                    // Go on as a replan would not: time passes, the ends come in.
                    replans += 1;
                    now += 5_000;
                    while ends.first().is_some_and(|e| e.0 <= now) {
                        let (t, k) = ends.remove(0);
                        inc.executed(k, t).unwrap();
                        whole.executed(k, t).unwrap();
                    }
                    if replans > 100 {
                        break;
                    }
                }
                Decision::Finished => break,
            }
        }
        eprintln!("run {run}: {polls} polls, {starts} starts, {replans} replans");
        assert!(starts > 10, "run {run}: {starts} starts");
        finished += usize::from(starts == plan.len());
        replanned += usize::from(replans > 0);
    }
    // Both a run dispatched to the end and one past a step's ub were compared.
    assert!(
        finished > 0 && replanned > 0,
        "{finished} finished, {replanned} replanned"
    );
}
