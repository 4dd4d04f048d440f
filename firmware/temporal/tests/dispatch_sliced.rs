//! A poll divided across calls (`Dispatcher::poll_begin`, `poll_continue` with a budget of work
//! units: the executive's cycles) against the whole poll, on random networks executed at
//! random: the same decision and the same window for every step at every poll, with budgets
//! from one unit up, the incremental and the whole propagation, replans included, and actions
//! that end while a divided poll is in progress (it begins again at the same time).
mod common;

use common::{random_network, Rng};
use temporal::constraints::Constraint;
use temporal::dispatch::MAX_DEFERRED;
use temporal::task::UNBOUNDED;
use temporal::{Decision, Dispatcher, PlanNetwork, PlanStep};

/// Runs a divided poll to its decision with budgets drawn from `budgets`; `between` is called
/// between two calls (it may mark steps executed). Returns the decision and the calls it took.
fn divided(
    d: &mut Dispatcher,
    now: u32,
    ready: &dyn Fn(u16) -> bool,
    rng: &mut Rng,
    budgets: u64,
    between: &mut dyn FnMut(&mut Dispatcher, &mut Rng),
) -> (Decision, usize) {
    d.poll_begin(now);
    let mut calls = 0;
    loop {
        let budget = 1 + rng.below(budgets) as u32;
        calls += 1;
        assert!(calls < 1_000_000, "a divided poll must end");
        if let Some(decision) = d.poll_continue(ready, budget) {
            assert!(!d.polling());
            return (decision, calls);
        }
        assert!(d.polling());
        between(d, rng);
    }
}

/// One random execution with a whole dispatcher and a divided one side by side (the divided
/// one incremental or whole by `whole`); returns (polls, replans, polls that took more than
/// one call, ends marked during a divided poll).
fn run(rng: &mut Rng, whole_divided: bool) -> (usize, usize, usize, usize) {
    let (net, horizon) = random_network(rng);
    let (Ok(mut div), Ok(mut whole)) = (
        Dispatcher::new(net.clone(), horizon),
        Dispatcher::new(net.clone(), horizon),
    ) else {
        return (0, 0, 0, 0);
    };
    whole.set_whole_propagation(true);
    div.set_whole_propagation(whole_divided);
    let steps = net.step_count();
    let mut ready: Vec<bool> = (0..steps).map(|_| rng.chance(70)).collect();
    let mut now = 0u32;
    let mut running: Vec<(usize, u32)> = Vec::new();
    let (mut polls, mut replans, mut divided_polls, mut mid_ends) = (0, 0, 0, 0);
    for _ in 0..4 * steps + 10 {
        let r = ready.clone();
        let is_ready = move |a: u16| r.get(usize::from(a)).copied().unwrap_or(false);
        // Some running actions may end while the divided poll is in progress (at `now`).
        let mut ended: Vec<usize> = Vec::new();
        let budgets = [1, 4, 16, 200][rng.below(4) as usize];
        let (a, calls) = {
            let running = &mut running;
            let ended = &mut ended;
            let mut between = |d: &mut Dispatcher, rng: &mut Rng| {
                if !running.is_empty() && rng.chance(3) {
                    let (end, _) = running.swap_remove(rng.below(running.len() as u64) as usize);
                    d.executed(end, now).unwrap();
                    assert_eq!(d.executed_at(end), None, "held until the poll decides");
                    assert!(d.executed(end, now).is_err(), "held once");
                    ended.push(end);
                    assert!(d.polling(), "the poll goes on");
                }
            };
            divided(&mut div, now, &is_ready, rng, budgets, &mut between)
        };
        // The ends during the divided poll are marked after its decision: the whole poll's,
        // then the same marks.
        let b = whole.poll(now, &is_ready);
        assert_eq!(a, b, "decision at {now}");
        for k in 0..=steps {
            assert_eq!(div.window(k), whole.window(k), "step {k}'s window at {now}");
        }
        for &end in &ended {
            whole.executed(end, now).unwrap();
            assert_eq!(div.executed_at(end), Some(now), "marked after the decision");
        }
        mid_ends += ended.len();
        polls += 1;
        if calls > 1 {
            divided_polls += 1;
        }
        match a {
            Decision::Start { step, .. } => {
                assert_eq!(div.executed(step, now), whole.executed(step, now));
                if let Some(end) = net.end_of(step) {
                    running.push((end, now));
                }
            }
            Decision::Finished => break,
            Decision::Replan { .. } => replans += 1,
            Decision::Wait { .. } => {}
        }
        now += match rng.below(4) {
            0 => 0,
            1 => rng.below(5) as u32,
            2 => rng.below(30) as u32,
            _ => rng.below(120) as u32,
        };
        let mut i = 0;
        while i < running.len() {
            if rng.chance(40) {
                let (end, _) = running.swap_remove(i);
                assert_eq!(div.executed(end, now), whole.executed(end, now));
            } else {
                i += 1;
            }
        }
        if rng.chance(30) {
            ready = (0..steps).map(|_| rng.chance(70)).collect();
        }
    }
    (polls, replans, divided_polls, mid_ends)
}

#[test]
fn a_divided_poll_decides_as_the_whole_one() {
    let mut rng = Rng(0x5eed_5111_ced0_0001);
    let (mut polls, mut replans, mut divided_polls, mut mid_ends) = (0, 0, 0, 0);
    for i in 0..3000 {
        let (p, r, d, m) = run(&mut rng, i % 4 == 3);
        polls += p;
        replans += r;
        divided_polls += d;
        mid_ends += m;
    }
    // Dispatching, replanning, polls across several calls and ends during them are covered.
    assert!(polls > 20_000, "{polls} polls compared");
    assert!(replans > 2_000, "{replans} replans compared");
    assert!(
        divided_polls > polls / 2,
        "{divided_polls} of {polls} divided"
    );
    assert!(mid_ends > 500, "{mid_ends} ends during a divided poll");
}

/// A whole poll, a restart or a new network while a divided poll is in progress ends it; a
/// divided poll begun again gives the whole one's decision.
#[test]
fn a_divided_poll_is_ended_by_a_whole_poll_and_a_new_network() {
    let mut rng = Rng(0xd1_71de);
    let mut checked = 0;
    for _ in 0..300 {
        let (net, horizon) = random_network(&mut rng);
        let Ok(mut d) = Dispatcher::new(net.clone(), horizon) else {
            continue;
        };
        let mut reference = d.clone();
        d.poll_begin(3);
        assert_eq!(d.poll_continue(&|_| true, 1), None);
        assert!(d.polling());
        assert_eq!(d.poll(5, &|_| true), reference.poll(5, &|_| true));
        assert!(!d.polling());
        assert_eq!(
            d.poll_continue(&|_| true, 1_000),
            None,
            "nothing in progress"
        );
        d.poll_begin(7);
        let _ = d.poll_continue(&|_| true, 1);
        d.restart(horizon).unwrap();
        assert!(!d.polling());
        d.poll_begin(9);
        let _ = d.poll_continue(&|_| true, 1);
        let _ = d.network_mut();
        assert!(!d.polling());
        d.restart(horizon).unwrap();
        let mut fresh = Dispatcher::new(net, horizon).unwrap();
        d.poll_begin(11);
        let got = loop {
            if let Some(x) = d.poll_continue(&|_| true, 2) {
                break x;
            }
        };
        assert_eq!(got, fresh.poll(11, &|_| true));
        checked += 1;
    }
    assert!(checked > 100, "{checked}");
}

/// More ends during one divided poll than it holds: the first `MAX_DEFERRED` and the one over
/// are marked at once and the poll begins again at the same time; the rest are held. The
/// decision is the whole poll's after the first ones, then the rest are marked.
#[test]
fn more_ends_during_a_divided_poll_than_it_holds() {
    let actions = MAX_DEFERRED + 8;
    let mut net = PlanNetwork::new();
    for a in 0..actions {
        let s = net
            .add_step(PlanStep {
                action: a as u16,
                end: false,
                window: (0, UNBOUNDED),
            })
            .unwrap();
        let e = net
            .add_step(PlanStep {
                action: a as u16,
                end: true,
                window: (0, UNBOUNDED),
            })
            .unwrap();
        net.add_constraint(Constraint {
            before: s as u16,
            after: e as u16,
            lb: 10 + a as u32,
            ub: UNBOUNDED,
        })
        .unwrap();
    }
    // One more action after every end.
    let last = net
        .add_step(PlanStep {
            action: actions as u16,
            end: false,
            window: (0, UNBOUNDED),
        })
        .unwrap();
    for a in 0..actions {
        net.add_constraint(Constraint {
            before: (2 * a + 2) as u16,
            after: last as u16,
            lb: 0,
            ub: UNBOUNDED,
        })
        .unwrap();
    }
    net.makespan = 1_000;
    let mut div = Dispatcher::new(net.clone(), 2_000).unwrap();
    let mut whole = div.clone();
    for a in 0..actions {
        let k = 2 * a + 1;
        assert_eq!(
            div.poll(0, &|_| true),
            Decision::Start {
                step: k,
                action: a as u16
            }
        );
        div.executed(k, 0).unwrap();
        whole.executed(k, 0).unwrap();
    }
    let now = 100;
    div.poll_begin(now);
    assert_eq!(div.poll_continue(&|_| true, 1), None);
    for a in 0..actions {
        div.executed(2 * a + 2, now).unwrap();
        assert!(div.polling());
        let marked = (0..actions)
            .filter(|&b| div.executed_at(2 * b + 2).is_some())
            .count();
        assert_eq!(
            marked,
            if a < MAX_DEFERRED {
                0
            } else {
                MAX_DEFERRED + 1
            }
        );
    }
    let got = loop {
        if let Some(d) = div.poll_continue(&|_| true, 3) {
            break d;
        }
    };
    for a in 0..=MAX_DEFERRED {
        whole.executed(2 * a + 2, now).unwrap();
    }
    assert_eq!(got, whole.poll(now, &|_| true));
    for a in MAX_DEFERRED + 1..actions {
        whole.executed(2 * a + 2, now).unwrap();
    }
    assert_eq!(div.poll(now, &|_| true), whole.poll(now, &|_| true));
    assert_eq!(
        div.poll(now, &|_| true),
        Decision::Start {
            step: last,
            action: actions as u16
        }
    );
}
