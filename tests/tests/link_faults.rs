//! The reliable link under injected faults, natively (no QEMU): whatever the link corrupts,
//! drops or delays, every message is delivered exactly once and in order, so the flyby makes
//! exactly the decisions it makes on a clean link, at the same mission times, for every seed.
use hil::mission::plan::{LinkFaults, MissionPlan};
use hil::mission::record::Decision;
use hil::mission::report::MissionReport;
use hil::mission::runner::{prepare, run};
use hil::mission::target::NativeTarget;

fn flyby() -> MissionPlan {
    prepare(&hil::repo_root().join("scenarios/flyby-nominal.toml"))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn fly(plan: &MissionPlan) -> MissionReport {
    run(plan, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

/// Fly the flyby over a link with `faults` for seeds `seeds`; every run must pass and decide
/// exactly what the clean run decided. Returns (runs, faults injected, retransmissions).
fn sweep(faults: LinkFaults, seeds: std::ops::RangeInclusive<u64>) -> (u64, u64, u64) {
    let clean = fly(&flyby());
    assert!(clean.passed, "{}", hil::mission::report::summary(&clean));
    let reference: Vec<Decision> = clean.decisions.clone();
    let (mut runs, mut injected, mut resent) = (0, 0, 0);
    for seed in seeds {
        let mut plan = flyby();
        plan.set_seed(seed);
        plan.link = faults.clone();
        let r = fly(&plan);
        assert!(
            r.passed && r.ended_early.is_none(),
            "seed {seed}, {faults:?}:\n{}",
            hil::mission::report::summary(&r)
        );
        assert_eq!(
            r.decisions, reference,
            "seed {seed}, {faults:?}: the decisions differ from the clean run's"
        );
        runs += 1;
        injected += r.injected_link_faults;
        resent += r.link.retransmissions;
    }
    assert!(
        injected > runs,
        "the faults were really injected ({injected} in {runs} runs)"
    );
    (runs, injected, resent)
}

#[test]
fn one_percent_byte_corruption_changes_no_decision_for_200_seeds() {
    let (_, _, resent) = sweep(
        LinkFaults {
            corrupt: 0.01,
            ..Default::default()
        },
        1..=200,
    );
    assert!(resent > 0);
}

#[test]
fn five_percent_byte_corruption_changes_no_decision_for_200_seeds() {
    sweep(
        LinkFaults {
            corrupt: 0.05,
            ..Default::default()
        },
        1..=200,
    );
}

#[test]
fn ten_percent_frame_loss_with_delays_changes_no_decision_for_200_seeds() {
    sweep(
        LinkFaults {
            drop: 0.10,
            delay: 0.05,
            ..Default::default()
        },
        1..=200,
    );
}
