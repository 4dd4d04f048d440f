//! The dispatcher's incremental windows (the latest times kept until a step is executed, the
//! earliest kept or worked out from the last ones) against the whole propagation from nothing,
//! on random networks executed at random: the same decision and the same window for every step
//! at every poll, replans included (actions that end early, late, or past every window).
mod common;

use common::{random_network, Rng};
use temporal::{Decision, Dispatcher};

/// Runs both dispatchers side by side over one random execution; returns how many polls agreed
/// and how many of them were replans.
fn run(rng: &mut Rng) -> (usize, usize) {
    let (net, horizon) = random_network(rng);
    let (Ok(mut inc), Ok(mut whole)) = (
        Dispatcher::new(net.clone(), horizon),
        Dispatcher::new(net.clone(), horizon),
    ) else {
        return (0, 0);
    };
    whole.set_whole_propagation(true);
    let steps = net.step_count();
    // Which actions are ready (their conditions hold in the executive's view), drawn anew now
    // and then.
    let mut ready: Vec<bool> = (0..steps).map(|_| rng.chance(70)).collect();
    let mut now = 0u32;
    let mut running: Vec<(usize, u32)> = Vec::new();
    let mut polls = 0;
    let mut replans = 0;
    for _ in 0..4 * steps + 10 {
        let r = ready.clone();
        let is_ready = move |a: u16| r.get(usize::from(a)).copied().unwrap_or(false);
        let a = inc.poll(now, &is_ready);
        let b = whole.poll(now, &is_ready);
        assert_eq!(a, b, "decision at {now}");
        for k in 0..=steps {
            assert_eq!(inc.window(k), whole.window(k), "step {k}'s window at {now}");
        }
        polls += 1;
        match a {
            Decision::Start { step, .. } => {
                assert_eq!(inc.executed(step, now), whole.executed(step, now));
                if let Some(end) = net.end_of(step) {
                    running.push((end, now));
                }
            }
            Decision::Finished => break,
            Decision::Replan { .. } => replans += 1,
            Decision::Wait { .. } => {}
        }
        // Time goes on (sometimes not at all, sometimes far), some running actions end (early,
        // on time or late: the end is at `now`), readiness changes.
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
                assert_eq!(inc.executed(end, now), whole.executed(end, now));
            } else {
                i += 1;
            }
        }
        if rng.chance(30) {
            ready = (0..steps).map(|_| rng.chance(70)).collect();
        }
    }
    (polls, replans)
}

#[test]
fn incremental_windows_are_the_whole_propagations() {
    let mut rng = Rng(0x5eed_d15a_7c4e_0001);
    let mut polls = 0;
    let mut replans = 0;
    for _ in 0..3000 {
        let (p, r) = run(&mut rng);
        polls += p;
        replans += r;
    }
    // Both kinds of decision are covered: dispatching and replanning.
    assert!(polls > 20_000, "{polls} polls compared");
    assert!(replans > 2_000, "{replans} replans compared");
}

/// A dispatcher taken up again (made anew, then the executed steps marked, as the rover's
/// checkpoint does) polls as the whole propagation taken up the same way.
#[test]
fn a_restarted_dispatcher_polls_as_the_whole_one() {
    let mut rng = Rng(0x0dd_ba11);
    for _ in 0..300 {
        let (net, horizon) = random_network(&mut rng);
        let Ok(mut whole) = Dispatcher::new(net.clone(), horizon) else {
            continue;
        };
        whole.set_whole_propagation(true);
        let mut now = 0;
        for _ in 0..net.step_count() {
            if let Decision::Start { step, .. } = whole.poll(now, &|_| true) {
                whole.executed(step, now).unwrap();
            }
            now += rng.below(20) as u32;
        }
        let mut inc = Dispatcher::new(net.clone(), horizon).unwrap();
        let mut taken_up = Dispatcher::new(net.clone(), horizon).unwrap();
        taken_up.set_whole_propagation(true);
        for k in 1..=net.step_count() {
            if let Some(t) = whole.executed_at(k) {
                inc.executed(k, t).unwrap();
                taken_up.executed(k, t).unwrap();
            }
        }
        for later in [0, 7, 50] {
            let a = inc.poll(now + later, &|_| true);
            assert_eq!(a, taken_up.poll(now + later, &|_| true));
            for k in 0..=net.step_count() {
                assert_eq!(inc.window(k), taken_up.window(k));
            }
        }
    }
}
