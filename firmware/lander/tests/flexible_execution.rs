//! Flexible execution and replanning (seed 000 III.B, III.C) and model parameter updates
//! (IV.C.3) on the host: task push, automated retry with updated predictions, replanning from
//! the current state, measured parameters replacing the priors for the same site, and the
//! executor's step API (deterministic, and the same whatever the search budget per step).
mod sim;

use fsw_bridge::MissionTimeUs;
use lander::executor::*;
use lander::htn::PrimitiveKind as K;
use lander::rsm1::{HOUR_US, WH_MJ};
use sim::*;

/// The index (1-based) of the first dispatch of (kind, site, target) in a run without
/// failures.
fn first_dispatch(kind: K, site: Option<u8>, target: Option<u8>) -> usize {
    let mut exec = executor(Strategy::FlexibleExecution);
    let end = Sim::new(vec![]).run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    1 + end
        .dispatched
        .iter()
        .position(|d| *d == (kind, site, target))
        .expect("dispatched")
}

/// The plan's step for (kind, site, target), once the executor has planned.
fn planned_step(exec: &mut Exec, kind: K, site: Option<u8>, target: Option<u8>) -> ExecStep {
    let model = small().0;
    let _ = exec.step(
        &Observation {
            now: MissionTimeUs::ZERO,
            battery_mj: BATTERY_MJ,
            preconditions_met: true,
            event: None,
        },
        u32::MAX,
    );
    *exec
        .remaining()
        .iter()
        .find(|s| {
            let p = &model.primitives[usize::from(s.primitive)];
            p.kind == kind && p.site == site && p.target == target
        })
        .expect("planned")
}

fn count(exec: &Exec, kind: DecisionKind) -> usize {
    exec.log().iter().filter(|d| d.kind == kind).count()
}

const COLLECT_00: (K, Option<u8>, Option<u8>) = (K::CollectSample, Some(0), Some(0));

fn block_collect_00(exec: &mut Exec, late_by_us: u64) -> (Sim, MissionTimeUs) {
    let step = planned_step(exec, COLLECT_00.0, COLLECT_00.1, COLLECT_00.2);
    let mut sim = Sim::new(vec![]);
    sim.blocks.push(Block {
        kind: COLLECT_00.0,
        site: COLLECT_00.1,
        target: COLLECT_00.2,
        from: MissionTimeUs::ZERO,
        until: MissionTimeUs(step.start.0 + late_by_us),
    });
    (sim, step.start)
}

#[test]
fn task_push_waits_for_preconditions_and_dispatches_when_they_hold() {
    let mut exec = executor(Strategy::FlexibleExecution);
    let (mut sim, start) = block_collect_00(&mut exec, HOUR_US / 2);
    let end = sim.run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert_eq!(count(&exec, DecisionKind::PushStarted), 1);
    assert_eq!(count(&exec, DecisionKind::PushTimedOut), 0);
    assert_eq!(exec.stats().ground_halts, 0);
    let push = exec
        .log()
        .iter()
        .find(|d| d.kind == DecisionKind::PushStarted)
        .unwrap();
    assert_eq!(push.at, start, "the push starts when the primitive is due");
    let dispatch = exec
        .log()
        .iter()
        .skip_while(|d| d.kind != DecisionKind::PushStarted)
        .find(|d| d.kind == DecisionKind::Dispatched)
        .unwrap();
    assert_eq!(
        dispatch.at,
        MissionTimeUs(start.0 + HOUR_US / 2),
        "dispatched as soon as the preconditions hold"
    );
    assert_eq!(samples(&end), vec![(0, 0), (0, 1), (1, 0), (1, 1)]);
}

#[test]
fn a_push_past_its_timeout_is_a_failure() {
    // FE: the failure goes to ground, which resolves it.
    let mut exec = executor(Strategy::FlexibleExecution);
    let (mut sim, start) = block_collect_00(&mut exec, 3 * HOUR_US);
    let end = sim.run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    let timeout = exec
        .log()
        .iter()
        .find(|d| d.kind == DecisionKind::PushTimedOut)
        .unwrap();
    assert_eq!(
        timeout.at,
        MissionTimeUs(start.0 + ExecConfig::new(Strategy::FlexibleExecution).push_timeout_us)
    );
    assert_eq!(
        count(
            &exec,
            DecisionKind::HaltedForGround(Reason::PreconditionsUnmet)
        ),
        1
    );
    assert_eq!(end.ground_answers, 1);
    // Replan: the target is given up and the plan goes on without it.
    let mut exec = executor(Strategy::Replan);
    let (mut sim, _) = block_collect_00(&mut exec, 3 * HOUR_US);
    let end = sim.run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert_eq!(count(&exec, DecisionKind::PushTimedOut), 1);
    assert_eq!(
        count(
            &exec,
            DecisionKind::ReplanStarted(Reason::PreconditionsUnmet)
        ),
        1
    );
    assert_eq!(exec.stats().ground_halts, 0);
    assert!(!samples(&end).contains(&(0, 0)));
    assert!(exec.context().sites[0].targets[0].failed);
    // Static and Ground do not push.
    let mut exec = executor(Strategy::Static);
    let (mut sim, start) = block_collect_00(&mut exec, HOUR_US / 2);
    let end = sim.run(&mut exec);
    assert_eq!(
        end.last,
        Directive::Abandoned {
            reason: Reason::PreconditionsUnmet
        }
    );
    assert_eq!(end.now, start);
    assert_eq!(count(&exec, DecisionKind::PushStarted), 0);
    let mut exec = executor(Strategy::Ground);
    let (mut sim, _) = block_collect_00(&mut exec, HOUR_US / 2);
    sim.ground_answers = false;
    let end = sim.run(&mut exec);
    assert!(is_halt(&end.last, Reason::PreconditionsUnmet));
    assert_eq!(count(&exec, DecisionKind::PushStarted), 0);
}

fn failing_collect(measured: (u64, u64)) -> Scripted {
    Scripted {
        result: TaskResult::Failed,
        measured: Some(measured),
        ..Scripted::on(COLLECT_00.0, COLLECT_00.1, COLLECT_00.2)
    }
}

#[test]
fn a_retry_updates_the_predicted_end_and_energy() {
    let n = first_dispatch(COLLECT_00.0, COLLECT_00.1, COLLECT_00.2);
    // Just before the failing dispatch.
    let mut before = executor(Strategy::FlexibleExecution);
    let mut sim = Sim::new(vec![]);
    sim.stop_after = Some(n - 1);
    sim.run(&mut before);
    let p0 = before.prediction();
    let collect = before.remaining()[0];
    // The collection fails after 3 h and 500 Wh, with its preconditions still holding.
    let failed = (3 * HOUR_US, 500 * WH_MJ);
    let mut exec = executor(Strategy::FlexibleExecution);
    let mut sim = Sim::new(vec![failing_collect(failed)]);
    sim.stop_after = Some(n);
    let end = sim.run(&mut exec);
    assert!(
        matches!(end.last, Directive::Dispatch { .. }),
        "retried at once"
    );
    assert_eq!(count(&exec, DecisionKind::Retried), 1);
    let retry = exec.remaining()[0];
    assert_eq!(retry.primitive, collect.primitive);
    assert_eq!(retry.retries, 1);
    assert_eq!(retry.start, end.now);
    assert_eq!(retry.start.0, collect.start.0 + failed.0);
    let next = exec.remaining()[1];
    assert_eq!(
        next.start.0,
        retry.start.0 + retry.duration_us,
        "the rest moves after the retry"
    );
    let p1 = exec.prediction();
    assert_eq!(p1.energy_mj, p0.energy_mj + failed.1);
    assert!(p1.end > p0.end && p1.end.0 <= p0.end.0 + failed.0);
    // And the run finishes with the sample taken.
    let mut exec = executor(Strategy::FlexibleExecution);
    let end = Sim::new(vec![failing_collect(failed)]).run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert!(exec.context().sites[0].targets[0].collected);
}

#[test]
fn retries_are_bounded_and_need_the_preconditions() {
    // Fails every time: two retries, then ground (FE).
    let script: Vec<Scripted> = (1..=3)
        .map(|attempt| Scripted {
            attempt,
            ..failing_collect((HOUR_US, 100 * WH_MJ))
        })
        .collect();
    let mut exec = executor(Strategy::FlexibleExecution);
    let mut sim = Sim::new(script.clone());
    sim.ground_answers = false;
    let end = sim.run(&mut exec);
    assert!(is_halt(&end.last, Reason::Failed));
    assert_eq!(exec.stats().retries, 2);
    // A failure that breaks the preconditions is not retried.
    let mut exec = executor(Strategy::FlexibleExecution);
    let mut sim = Sim::new(vec![Scripted {
        blocks_for_us: 10 * HOUR_US,
        ..failing_collect((HOUR_US, 100 * WH_MJ))
    }]);
    sim.ground_answers = false;
    let end = sim.run(&mut exec);
    assert!(is_halt(&end.last, Reason::Failed));
    assert_eq!(exec.stats().retries, 0);
}

#[test]
fn measured_parameters_replace_the_priors_for_the_same_site() {
    let model = small().0;
    let n = first_dispatch(COLLECT_00.0, COLLECT_00.1, COLLECT_00.2);
    let measured = (3 * HOUR_US, 500 * WH_MJ);
    let mut exec = executor(Strategy::FlexibleExecution);
    let mut sim = Sim::new(vec![Scripted {
        measured: Some(measured),
        ..Scripted::on(COLLECT_00.0, COLLECT_00.1, COLLECT_00.2)
    }]);
    sim.stop_after = Some(n);
    sim.run(&mut exec);
    assert!(exec.parameters().contains(&ParameterUpdate {
        kind: K::CollectSample,
        site: 0,
        duration_us: measured.0,
        energy_mj: measured.1,
    }));
    let collect = |site: u8, target: u8| {
        *exec
            .remaining()
            .iter()
            .find(|s| {
                let p = &model.primitives[usize::from(s.primitive)];
                p.kind == K::CollectSample && p.site == Some(site) && p.target == Some(target)
            })
            .expect("planned")
    };
    let same_site = collect(0, 1);
    assert_eq!((same_site.duration_us, same_site.energy_mj), measured);
    assert_eq!(exec.predicted(same_site.primitive), Some(measured));
    let other_site = collect(1, 0);
    let prior = &model.primitives[usize::from(other_site.primitive)];
    assert_eq!(
        (other_site.duration_us, other_site.energy_mj),
        (prior.duration_us, prior.energy_mj)
    );
    assert_ne!((prior.duration_us, prior.energy_mj), measured);
}

#[test]
fn reparameterize_updates_the_chains_of_the_same_site_only() {
    let (model, flat) = small();
    let collect_01 = model
        .primitives
        .iter()
        .position(|p| p.kind == K::CollectSample && p.site == Some(0) && p.target == Some(1))
        .unwrap() as u8;
    let prior = &model.primitives[usize::from(collect_01)];
    let params = [ParameterUpdate {
        kind: K::CollectSample,
        site: 0,
        duration_us: prior.duration_us + HOUR_US,
        energy_mj: prior.energy_mj + 100 * WH_MJ,
    }];
    let mut net = flat.clone();
    reparameterize(
        &model.primitives,
        &params,
        &lander::assessor::ScienceContext::default(),
        &mut net,
    );
    let mut changed = 0;
    for (before, after) in flat.chains.iter().zip(&net.chains) {
        let site0 = before.primitives.iter().any(|&p| {
            let s = &model.primitives[usize::from(p)];
            s.kind == K::CollectSample && s.site == Some(0)
        });
        if site0 {
            changed += 1;
            assert_eq!(after.duration_us, before.duration_us + HOUR_US);
            assert_eq!(after.energy_mj, before.energy_mj + 100 * WH_MJ);
            // Products made after the collection move by the hour.
            for (b, a) in before.products.iter().zip(&after.products) {
                assert_eq!(a.offset_us, b.offset_us + HOUR_US);
            }
        } else {
            assert_eq!(after, before);
        }
    }
    assert_eq!(changed, 4, "two targets at site 0, raw and compressed");
    // Without measurements, the flattened network is reproduced.
    let mut same = flat.clone();
    reparameterize(
        &model.primitives,
        &[],
        &lander::assessor::ScienceContext::default(),
        &mut same,
    );
    assert_eq!(same, flat);
}

#[test]
fn replanning_starts_from_the_current_state() {
    // The collection at (0, 1) fails and its target is lost (preconditions broken for 10 h).
    let lost = Scripted {
        result: TaskResult::Failed,
        blocks_for_us: 10 * HOUR_US,
        ..Scripted::on(K::CollectSample, Some(0), Some(1))
    };
    let mut exec = executor(Strategy::Replan);
    let end = Sim::new(vec![lost]).run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert_eq!(exec.stats().replans, 1);
    assert_eq!(exec.stats().ground_halts, 0);
    let replan = exec
        .log()
        .iter()
        .position(|d| d.kind == DecisionKind::ReplanStarted(Reason::Failed))
        .unwrap();
    let at = exec.log()[replan].at;
    // Everything after the replan starts at or after it.
    assert!(exec.log()[replan..]
        .iter()
        .filter(|d| d.kind == DecisionKind::Dispatched)
        .all(|d| d.at >= at));
    // The executed tasks are not planned again, the lost target is not tried again, and the
    // next site is sampled.
    let mut tasks: Vec<u16> = exec
        .executed()
        .iter()
        .map(|p| exec.network().chains[usize::from(p.chain)].task)
        .collect();
    let all = tasks.len();
    tasks.sort();
    tasks.dedup();
    assert_eq!(tasks.len(), all);
    assert!(exec.context().sites[0].targets[1].failed);
    assert_eq!(samples(&end), vec![(0, 0), (0, 1), (1, 0), (1, 1)]);
    assert!(exec.context().sites[1].targets.iter().all(|t| t.collected));
    assert!(!exec.context().sites[0].targets[1].collected);
}

#[test]
fn an_energy_overrun_replans_with_the_measured_charge_and_parameters() {
    // The collection at (0, 0) costs 5,000 Wh instead of 400: the rest of the plan (four
    // samples) no longer fits the charge. Replan replans at the chain's end, with the measured
    // collection cost for site 0; the map's order binds (site 0 is still open), so the second
    // sample there comes first at its measured cost and site 1's samples no longer fit; FE
    // goes on with the plan.
    let measured = (6 * HOUR_US, 5_000 * WH_MJ);
    let overrun = Scripted {
        measured: Some(measured),
        ..Scripted::on(K::CollectSample, Some(0), Some(0))
    };
    let mut exec = executor(Strategy::Replan);
    let end = Sim::new(vec![overrun]).run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert_eq!(
        count(&exec, DecisionKind::ReplanStarted(Reason::Overrun)),
        1
    );
    assert_eq!(
        samples(&end),
        vec![(0, 0), (0, 1)],
        "site 0 finished first at the measured cost; site 1 no longer fits"
    );
    // The replan's network carries the measured collection energy.
    let model = small().0;
    let collect_01 = model
        .primitives
        .iter()
        .position(|p| p.kind == K::CollectSample && p.site == Some(0) && p.target == Some(1))
        .unwrap() as u8;
    assert_eq!(exec.predicted(collect_01), Some(measured));
    let mut fe = executor(Strategy::FlexibleExecution);
    let end = Sim::new(vec![overrun]).run(&mut fe);
    assert_eq!(fe.stats().replans, 0);
    assert!(samples(&end).contains(&(0, 1)));
}

#[test]
fn the_step_api_is_deterministic_and_independent_of_the_search_budget() {
    let script = vec![
        failing_collect((HOUR_US, 100 * WH_MJ)),
        Scripted {
            result: TaskResult::Failed,
            blocks_for_us: 10 * HOUR_US,
            ..Scripted::on(K::CollectSample, Some(0), Some(1))
        },
    ];
    let run = |budget: u32| {
        let mut exec = executor(Strategy::Replan);
        let mut sim = Sim::new(script.clone());
        sim.budget = budget;
        let end = sim.run(&mut exec);
        (end, exec.log().to_vec(), *exec.stats())
    };
    let (end_a, log_a, stats_a) = run(u32::MAX);
    let (end_b, log_b, stats_b) = run(u32::MAX);
    assert_eq!((&end_a, &log_a), (&end_b, &log_b));
    assert_eq!(stats_a, stats_b);
    let (end_c, log_c, stats_c) = run(7);
    assert_eq!(end_a, end_c);
    assert_eq!(log_a, log_c);
    assert_eq!(stats_a, stats_c);
    assert!(stats_a.replans >= 1 && stats_a.retries == 1);
}

#[test]
fn a_plan_made_before_execution_is_executed_as_made() {
    // The executor's own first plan, handed to a new executor as a plan made beforehand (the
    // Static strategy's "generated before execution time"): the same primitives, in the same
    // order, at the same times.
    let mut planner = executor(Strategy::FlexibleExecution);
    let _ = planned_step(&mut planner, COLLECT_00.0, COLLECT_00.1, COLLECT_00.2);
    let mut plan: Vec<lander::search::PlacedChain> = Vec::new();
    for s in planner.remaining() {
        if !plan.iter().any(|p| p.chain == s.chain) {
            plan.push(lander::search::PlacedChain {
                chain: s.chain,
                start: s.planned_start,
            });
        }
    }
    let (model, net) = small();
    let timeline = lander::rsm1::placement(SOLS, BATTERY_MJ).unwrap();
    let mut given = Box::new(
        Exec::new(
            ExecConfig::new(Strategy::Static),
            &model,
            &net,
            &timeline,
            &lander::rsm1::context(SMALL),
            Some(&plan),
        )
        .unwrap(),
    );
    assert_eq!(given.remaining(), planner.remaining());
    let a = Sim::new(vec![]).run(&mut planner);
    let b = Sim::new(vec![]).run(&mut given);
    assert_eq!(a, b);
    assert_eq!(given.stats().explored, 0, "no search");
    // A plan naming a chain the network does not have is refused.
    let bad = [lander::search::PlacedChain {
        chain: 999,
        start: MissionTimeUs::ZERO,
    }];
    assert!(matches!(
        Exec::new(
            ExecConfig::new(Strategy::Static),
            &model,
            &net,
            &timeline,
            &lander::rsm1::context(SMALL),
            Some(&bad),
        ),
        Err(ExecError::UnknownChain)
    ));
}

#[test]
fn a_replan_does_not_excavate_a_site_twice() {
    // The state: site 0 excavated. Its excavation then costs nothing in a replan, and only
    // there.
    let model = small().0;
    let excavate_0 = model
        .primitives
        .iter()
        .position(|p| p.kind == K::ExcavateSite && p.site == Some(0))
        .unwrap() as u8;
    let mut context = lander::rsm1::context(SMALL);
    assert!(!already_done(&model.primitives, &context, excavate_0));
    context.sites[0].post_excavation = Some(lander::utility::Score::ONE);
    assert!(already_done(&model.primitives, &context, excavate_0));
    let (_, flat) = small();
    let mut net = flat.clone();
    reparameterize(&model.primitives, &[], &context, &mut net);
    for (before, after) in flat.chains.iter().zip(&net.chains) {
        if before.primitives.contains(&excavate_0) {
            let prior = &model.primitives[usize::from(excavate_0)];
            assert_eq!(after.energy_mj, before.energy_mj - prior.energy_mj);
            assert_eq!(after.duration_us, before.duration_us - prior.duration_us);
        } else {
            assert_eq!(after, before);
        }
    }
    // In execution: the collection at (0, 0) is lost after the excavation; Replan plans (0, 1)
    // without a second excavation, where the plan made before execution has two.
    let lost = Scripted {
        result: TaskResult::Failed,
        blocks_for_us: 100 * HOUR_US,
        ..Scripted::on(K::CollectSample, Some(0), Some(0))
    };
    let excavations = |end: &RunEnd| {
        end.dispatched
            .iter()
            .filter(|d| **d == (K::ExcavateSite, Some(0), None))
            .count()
    };
    let mut exec = executor(Strategy::Replan);
    let end = Sim::new(vec![lost]).run(&mut exec);
    assert_eq!(end.last, Directive::Done);
    assert_eq!(exec.stats().replans, 1);
    assert!(samples(&end).contains(&(0, 1)));
    assert_eq!(excavations(&end), 1);
    let mut fe = executor(Strategy::FlexibleExecution);
    let end = Sim::new(vec![]).run(&mut fe);
    assert_eq!(
        excavations(&end),
        2,
        "the plan made before excavates per sample"
    );
}
