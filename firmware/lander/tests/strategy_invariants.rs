//! Random failure scripts under every strategy (seeded, reproducible), with random windows in
//! which some primitive's preconditions fail: every run ends (done, abandoned, or halted when
//! ground does not answer), and each strategy uses only its own responses: Static never
//! retries, replans or halts; Ground never pushes, retries or replans; FE never replans;
//! Replan halts only for a fault or a failed replan. Executed tasks are never executed twice,
//! and a run is a function of its script.
mod common;
mod sim;

use common::Rng;
use lander::assessor::Biosignature;
use lander::executor::*;
use lander::htn::PrimitiveKind as K;
use lander::rsm1::{HOUR_US, WH_MJ};
use sim::*;

const CASES: u64 = 60;

const KINDS: [(K, bool, bool); 7] = [
    (K::ExcavateSite, true, false),
    (K::FindCollectionTargets, true, false),
    (K::CollectSample, true, true),
    (K::ScienceAnalyze, false, false),
    (K::Downlink, false, false),
    (K::TransportSample, false, false),
    (K::TakeMonoPanorama, false, false),
];

/// Windows in which a random primitive's preconditions do not hold.
fn random_blocks(rng: &mut Rng) -> Vec<Block> {
    (0..rng.range(0, 3))
        .map(|_| {
            let (kind, has_site, has_target) = KINDS[rng.range(0, KINDS.len() as u64 - 1) as usize];
            let from = rng.range(0, 300) * HOUR_US;
            Block {
                kind,
                site: has_site.then(|| rng.range(0, 1) as u8),
                target: has_target.then(|| rng.range(0, 1) as u8),
                from: fsw_bridge::MissionTimeUs(from),
                until: fsw_bridge::MissionTimeUs(from + rng.range(1, 8) * HOUR_US / 2),
            }
        })
        .collect()
}

fn random_script(rng: &mut Rng) -> Vec<Scripted> {
    let kinds = KINDS;
    (0..rng.range(0, 6))
        .map(|_| {
            let (kind, has_site, has_target) = kinds[rng.range(0, kinds.len() as u64 - 1) as usize];
            let site = has_site.then(|| rng.range(0, 1) as u8);
            let target = has_target.then(|| rng.range(0, 1) as u8);
            let result = match rng.range(0, 3) {
                0 => TaskResult::Succeeded,
                1 | 2 => TaskResult::Failed,
                _ => TaskResult::Faulted,
            };
            Scripted {
                attempt: rng.range(1, 2) as u32,
                nth: (!has_site).then(|| rng.range(1, 3) as usize),
                result,
                measured: rng
                    .chance(50)
                    .then(|| (rng.range(1, 8) * HOUR_US, rng.range(10, 2_000) * WH_MJ)),
                biosignature: (kind == K::ScienceAnalyze && rng.chance(50)).then(|| {
                    if rng.chance(50) {
                        Biosignature::Negative
                    } else {
                        Biosignature::Positive
                    }
                }),
                blocks_for_us: if rng.chance(30) {
                    rng.range(1, 12) * HOUR_US
                } else {
                    0
                },
                ..Scripted::on(kind, site, target)
            }
        })
        .collect()
}

#[test]
fn every_strategy_ends_and_uses_only_its_own_responses() {
    // What the cases exercised, over all of them: (abandoned, retries, pushes, replans, halts).
    let mut seen = (0u32, 0u32, 0u32, 0u32, 0u32);
    for seed in 0..CASES {
        let mut rng = Rng::new(seed);
        let script = random_script(&mut rng);
        let blocks = random_blocks(&mut rng);
        let ground_answers = rng.chance(70);
        for strategy in [
            Strategy::Static,
            Strategy::Ground,
            Strategy::FlexibleExecution,
            Strategy::Replan,
        ] {
            let run = || {
                let mut exec = executor(strategy);
                let mut sim = Sim::new(script.clone());
                sim.ground_answers = ground_answers;
                sim.blocks = blocks.clone();
                let end = sim.run(&mut exec);
                (end, exec)
            };
            let (end, exec) = run();
            let case = format!("seed {seed} {strategy:?} {script:?}");
            let s = *exec.stats();
            seen.0 += u32::from(matches!(end.last, Directive::Abandoned { .. }));
            seen.1 += s.retries;
            seen.2 += s.pushes;
            seen.3 += s.replans;
            seen.4 += s.ground_halts;
            match end.last {
                Directive::Done => {}
                Directive::Abandoned { .. } => assert_eq!(strategy, Strategy::Static, "{case}"),
                Directive::HaltedForGround { .. } => {
                    assert!(!ground_answers && strategy != Strategy::Static, "{case}")
                }
                other => panic!("{case}: ended with {other:?}"),
            }
            let halts: Vec<Reason> = exec
                .log()
                .iter()
                .filter_map(|d| match d.kind {
                    DecisionKind::HaltedForGround(r) => Some(r),
                    _ => None,
                })
                .collect();
            match strategy {
                Strategy::Static => {
                    assert_eq!(
                        (s.retries, s.replans, s.ground_halts, s.pushes),
                        (0, 0, 0, 0),
                        "{case}"
                    )
                }
                Strategy::Ground => {
                    assert_eq!((s.retries, s.replans, s.pushes), (0, 0, 0), "{case}")
                }
                Strategy::FlexibleExecution => assert_eq!(s.replans, 0, "{case}"),
                Strategy::Replan => assert!(
                    halts
                        .iter()
                        .all(|r| matches!(r, Reason::Fault | Reason::ReplanFailed)),
                    "{case}: {halts:?}"
                ),
            }
            assert_eq!(halts.len() as u32, s.ground_halts, "{case}");
            let mut tasks: Vec<u16> = exec
                .executed()
                .iter()
                .map(|p| exec.network().chains[usize::from(p.chain)].task)
                .collect();
            let n = tasks.len();
            tasks.sort();
            tasks.dedup();
            assert_eq!(tasks.len(), n, "{case}: a task executed twice");
            assert_eq!(s.log_overflows, 0, "{case}");
            let (again, exec_again) = run();
            assert_eq!(end, again, "{case}");
            assert_eq!(exec.log(), exec_again.log(), "{case}");
        }
    }
    println!("abandoned, retries, pushes, replans, ground halts: {seen:?}");
    assert!(
        seen.0 > 0 && seen.1 > 0 && seen.2 > 0 && seen.3 > 0 && seen.4 > 0,
        "the cases exercise every response: {seen:?}"
    );
}
