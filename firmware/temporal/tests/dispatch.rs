//! Flexible dispatch (seed 001, section 5.2): a start at lb when its action is ready early, at
//! once within (lb, ub], a replan past ub, windows narrowed by a late start or an overrun.
use temporal::constraints::Constraint;
use temporal::task::UNBOUNDED;
use temporal::{Decision, Dispatcher, NetworkError, PlanNetwork, PlanStep};

fn step(action: u16, end: bool) -> PlanStep {
    PlanStep {
        action,
        end,
        window: (0, UNBOUNDED),
    }
}

fn c(before: u16, after: u16, lb: u32, ub: u32) -> Constraint {
    Constraint {
        before,
        after,
        lb,
        ub,
    }
}

/// Action 0 (10 ticks, steps 1-2), then action 1 (5 ticks, steps 3-4) after action 0's end;
/// action 2 (3 ticks, steps 5-6) independent but not before 8 (a timed window).
fn network() -> PlanNetwork {
    let mut net = PlanNetwork::new();
    net.add_step(step(0, false)).unwrap();
    net.add_step(step(0, true)).unwrap();
    net.add_step(step(1, false)).unwrap();
    net.add_step(step(1, true)).unwrap();
    net.add_step(PlanStep {
        action: 2,
        end: false,
        window: (8, UNBOUNDED),
    })
    .unwrap();
    net.add_step(step(2, true)).unwrap();
    net.add_constraint(c(1, 2, 10, 10)).unwrap();
    net.add_constraint(c(2, 3, 1, UNBOUNDED)).unwrap();
    net.add_constraint(c(3, 4, 5, 5)).unwrap();
    net.add_constraint(c(5, 6, 3, 3)).unwrap();
    net.makespan = 16;
    net
}

const ALL: &dyn Fn(u16) -> bool = &|_| true;
const NONE: &dyn Fn(u16) -> bool = &|_| false;

#[test]
fn windows_keep_the_makespan() {
    let d = Dispatcher::new(network(), 20).unwrap();
    assert_eq!(d.window(1), Some((0, 4)));
    assert_eq!(d.window(3), Some((11, 15)));
    assert_eq!(d.window(5), Some((8, 17)));
    assert_eq!(
        Dispatcher::new(network(), 15).err(),
        Some(NetworkError::Inconsistent),
        "no schedule ends by 15"
    );
}

#[test]
fn a_start_ready_early_waits_for_its_lb() {
    let mut d = Dispatcher::new(network(), 20).unwrap();
    d.executed(1, 0).unwrap();
    // Only action 2 ready, at 5: its lb is 8.
    let only2 = |a: u16| a == 2;
    assert_eq!(d.poll(5, &only2), Decision::Wait { until: Some(8) });
    assert_eq!(d.poll(8, &only2), Decision::Start { step: 5, action: 2 });
}

#[test]
fn a_start_ready_within_its_window_starts_at_once_and_a_late_one_asks_for_a_replan() {
    let mut d = Dispatcher::new(network(), 20).unwrap();
    assert_eq!(d.poll(0, ALL), Decision::Start { step: 1, action: 0 });
    d.executed(1, 0).unwrap();
    // Action 1 follows action 0's end: nothing to start until it is reported.
    assert_eq!(d.poll(3, &|a| a == 1), Decision::Wait { until: None });
    d.executed(2, 10).unwrap();
    // Not ready at 11 (its lb), ready at 13: inside (lb, ub] = (11, 15], at once.
    assert_eq!(d.poll(11, NONE), Decision::Wait { until: None });
    assert_eq!(d.window(3), Some((11, 15)));
    assert_eq!(
        d.poll(13, &|a| a == 1),
        Decision::Start { step: 3, action: 1 }
    );
    // Had it still not been ready at 16, past its ub of 15: a replan naming it.
    let mut late = Dispatcher::new(network(), 20).unwrap();
    late.executed(1, 0).unwrap();
    late.executed(2, 10).unwrap();
    assert_eq!(late.poll(15, NONE), Decision::Wait { until: None });
    assert!(matches!(
        late.poll(16, NONE),
        Decision::Replan { step: 3, .. }
    ));
}

#[test]
fn an_overrun_narrows_what_follows_and_past_the_makespan_asks_for_a_replan() {
    let mut d = Dispatcher::new(network(), 20).unwrap();
    d.executed(1, 2).unwrap();
    // Action 0 ran 3 ticks over (12 + 3): action 1's window shrinks to (16, 15]: empty.
    d.executed(2, 15).unwrap();
    assert!(matches!(d.poll(15, ALL), Decision::Replan { step: 3, .. }));
    // A smaller overrun leaves room: (14, 15].
    let mut d = Dispatcher::new(network(), 20).unwrap();
    d.executed(1, 2).unwrap();
    d.executed(2, 13).unwrap();
    assert_eq!(d.poll(13, &|a| a == 1), Decision::Wait { until: Some(14) });
    assert_eq!(d.window(3), Some((14, 15)));
}

#[test]
fn a_whole_plan_executed_as_dispatched_finishes() {
    let mut d = Dispatcher::new(network(), 16).unwrap();
    let mut now = 0;
    let mut started = Vec::new();
    for _ in 0..100 {
        match d.poll(now, ALL) {
            Decision::Start { step, action } => {
                d.executed(step, now).unwrap();
                started.push((action, now));
            }
            Decision::Finished => break,
            Decision::Wait { until } => {
                // Report every end that is due (durations as planned), else move on.
                let mut reported = false;
                for s in 1..=6 {
                    let Some(st) = d.network().step(s) else {
                        continue;
                    };
                    if st.end || d.executed_at(s).is_none() {
                        continue;
                    }
                    let e = d.network().end_of(s).unwrap();
                    let dur = [10, 5, 3][usize::from(st.action)];
                    if d.executed_at(e).is_none() && d.executed_at(s).unwrap() + dur <= now {
                        d.executed(e, d.executed_at(s).unwrap() + dur).unwrap();
                        reported = true;
                    }
                }
                if !reported {
                    now = until.unwrap_or(now + 1).max(now + 1);
                }
            }
            Decision::Replan { step, ub } => panic!("replan at {now}: step {step} ub {ub}"),
        }
    }
    assert_eq!(d.poll(now, ALL), Decision::Finished);
    assert_eq!(started, vec![(0, 0), (2, 8), (1, 11)]);
    assert!(d.executed(1, 0).is_err(), "a step is executed once");
}

/// A dispatcher rebuilt in place (`network_mut`, then `restart`: how the planner partition
/// reuses one without moving 30 KB on its stack) is a new one: nothing executed, the same
/// windows, the same decisions; a network with no schedule by the horizon is refused.
#[test]
fn a_dispatcher_restarted_in_place_is_a_new_one() {
    let mut d = Dispatcher::new(PlanNetwork::new(), 0).unwrap();
    // Used a first time on another network, with a step executed.
    *d.network_mut() = network();
    d.restart(30).unwrap();
    assert!(matches!(d.poll(0, ALL), Decision::Start { step: 1, .. }));
    d.executed(1, 0).unwrap();
    // Rebuilt: the same as a fresh dispatcher of that network.
    d.network_mut().clear();
    *d.network_mut() = network();
    d.restart(20).unwrap();
    let fresh = Dispatcher::new(network(), 20).unwrap();
    for k in 0..=6 {
        assert_eq!(d.window(k), fresh.window(k), "step {k}");
        assert_eq!(d.executed_at(k), fresh.executed_at(k), "step {k}");
    }
    assert_eq!(d.executed_at(1), None);
    let mut fresh = fresh;
    assert_eq!(d.poll(0, ALL), fresh.poll(0, ALL));
    assert_eq!(d.restart(15), Err(NetworkError::Inconsistent));
}
