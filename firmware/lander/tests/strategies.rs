//! The four planning and execution strategies (seed 000 III.D) on one scripted failure
//! sequence, and on a utility discovery: Static abandons, Ground halts at every failure, FE
//! retries and halts for what retrying cannot resolve, Replan retries, replans, and halts only
//! for a fault.
mod sim;

use lander::assessor::Biosignature;
use lander::executor::*;
use lander::htn::PrimitiveKind as K;
use lander::rsm1::{HOUR_US, WH_MJ};
use sim::*;

/// The sequence: the collection at (0, 0) fails once with its preconditions still holding (a
/// retry resolves it); the collection at (0, 1) fails and loses its target for 10 hours (a
/// retry cannot; a replan or ground can); the collection at (1, 1) faults (only ground can
/// resolve it).
fn sequence() -> Vec<Scripted> {
    vec![
        Scripted {
            result: TaskResult::Failed,
            measured: Some((HOUR_US, 200 * WH_MJ)),
            ..Scripted::on(K::CollectSample, Some(0), Some(0))
        },
        Scripted {
            result: TaskResult::Failed,
            measured: Some((HOUR_US, 200 * WH_MJ)),
            blocks_for_us: 10 * HOUR_US,
            ..Scripted::on(K::CollectSample, Some(0), Some(1))
        },
        Scripted {
            result: TaskResult::Faulted,
            ..Scripted::on(K::CollectSample, Some(1), Some(1))
        },
    ]
}

struct Run {
    end: RunEnd,
    stats: ExecStats,
    halts: Vec<Reason>,
    collected: Vec<(u8, u8)>,
}

fn run(strategy: Strategy, script: Vec<Scripted>) -> Run {
    let mut exec = executor(strategy);
    let end = Sim::new(script).run(&mut exec);
    let halts = exec
        .log()
        .iter()
        .filter_map(|d| match d.kind {
            DecisionKind::HaltedForGround(r) => Some(r),
            _ => None,
        })
        .collect();
    let mut collected = Vec::new();
    for (s, site) in exec.context().sites.iter().enumerate() {
        for (t, target) in site.targets.iter().enumerate() {
            if target.collected {
                collected.push((s as u8, t as u8));
            }
        }
    }
    Run {
        end,
        stats: *exec.stats(),
        halts,
        collected,
    }
}

#[test]
fn static_abandons_the_plan_at_the_first_failure() {
    let r = run(Strategy::Static, sequence());
    assert_eq!(
        r.end.last,
        Directive::Abandoned {
            reason: Reason::Failed
        }
    );
    assert_eq!(r.stats.retries, 0);
    assert_eq!(r.stats.replans, 0);
    assert_eq!(r.stats.ground_halts, 0);
    assert!(r.collected.is_empty());
    // The failed collection was the last dispatch.
    assert_eq!(
        r.end.dispatched.last(),
        Some(&(K::CollectSample, Some(0), Some(0)))
    );
}

#[test]
fn ground_halts_at_every_failure_and_resumes_on_ground_input() {
    let r = run(Strategy::Ground, sequence());
    assert_eq!(r.end.last, Directive::Done);
    assert_eq!(r.halts, vec![Reason::Failed, Reason::Failed, Reason::Fault]);
    assert_eq!(r.end.ground_answers, 3);
    assert_eq!(r.stats.retries, 0);
    assert_eq!(r.stats.replans, 0);
    assert_eq!(r.collected, vec![(0, 0), (0, 1), (1, 0), (1, 1)]);
}

#[test]
fn fe_retries_what_it_can_and_goes_to_ground_for_the_rest() {
    let r = run(Strategy::FlexibleExecution, sequence());
    assert_eq!(r.end.last, Directive::Done);
    assert_eq!(r.stats.retries, 1, "the first failure is retried");
    assert_eq!(r.halts, vec![Reason::Failed, Reason::Fault]);
    assert_eq!(r.stats.replans, 0);
    assert_eq!(r.collected, vec![(0, 0), (0, 1), (1, 0), (1, 1)]);
}

#[test]
fn replan_retries_then_replans_and_goes_to_ground_only_for_the_fault() {
    let r = run(Strategy::Replan, sequence());
    assert_eq!(r.end.last, Directive::Done);
    assert_eq!(r.stats.retries, 1);
    assert_eq!(r.stats.replans, 1, "the lost target is replanned around");
    assert_eq!(r.halts, vec![Reason::Fault]);
    assert_eq!(r.collected, vec![(0, 0), (1, 0), (1, 1)]);
}

#[test]
fn strategies_spend_time_in_order_of_their_ground_halts() {
    // Each ground answer costs the scripted delay: Ground waits longest, Replan least.
    let ground = run(Strategy::Ground, sequence()).end.now;
    let fe = run(Strategy::FlexibleExecution, sequence()).end.now;
    let replan = run(Strategy::Replan, sequence()).end.now;
    assert!(ground > fe, "{ground:?} {fe:?}");
    assert!(fe > replan, "{fe:?} {replan:?}");
}

#[test]
fn only_replan_exploits_a_negative_biosignature() {
    // The first sample's analysis is negative: the map says move on to site 1. Replan drops
    // the second sample at site 0 at the end of the first one's chain; the others keep to the
    // plan made before and sample site 0 again.
    let negative = vec![Scripted {
        biosignature: Some(Biosignature::Negative),
        nth: Some(1),
        ..Scripted::on(K::ScienceAnalyze, None, None)
    }];
    for strategy in [
        Strategy::Static,
        Strategy::Ground,
        Strategy::FlexibleExecution,
    ] {
        let r = run(strategy, negative.clone());
        assert_eq!(r.end.last, Directive::Done);
        assert_eq!(r.stats.replans, 0);
        assert!(r.collected.contains(&(0, 1)), "{strategy:?}");
    }
    let mut exec = executor(Strategy::Replan);
    let end = Sim::new(negative).run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert_eq!(
        exec.log()
            .iter()
            .filter(|d| d.kind == DecisionKind::ReplanStarted(Reason::Discovery))
            .count(),
        1
    );
    let site0: Vec<_> = samples(&end).into_iter().filter(|s| s.0 == 0).collect();
    assert_eq!(site0, vec![(0, 0)]);
    assert!(exec.context().sites[1].targets.iter().all(|t| t.collected));
}
