//! The reliable link under injected faults on the emulated target: for a few seeds of each kind
//! of fault the suite sweeps natively (`link_faults.rs`), the flyby on QEMU makes exactly the
//! decisions of the clean run, and exactly those of the native run with the same seed. The
//! faults are a function of the seed, the direction, the frame's sequence and the byte index,
//! never of the target's timing: so the Mission channel's traffic, faults and retransmissions,
//! round for round, are the native run's too.
use hil::mission::plan::{LinkFaults, MissionPlan};
use hil_tests::{decisions, fly_emulated, fly_native, mission_link_figures, prepared, profile};

fn flyby_over(faults: &LinkFaults, seed: u64) -> MissionPlan {
    let mut plan = prepared("flyby-nominal.toml");
    plan.set_seed(seed);
    plan.link = faults.clone();
    plan
}

fn check(faults: LinkFaults, seeds: &[u64]) {
    let clean = fly_native(&prepared("flyby-nominal.toml"));
    for &seed in seeds {
        let plan = flyby_over(&faults, seed);
        let native = fly_native(&plan);
        let emulated = fly_emulated(&plan, profile());
        for (name, r) in [("native", &native), ("emulated", &emulated)] {
            assert!(
                r.passed && r.ended_early.is_none(),
                "seed {seed}, {faults:?}, {name}:\n{}",
                hil::mission::report::summary(r)
            );
            assert!(r.injected_link_faults > 0, "seed {seed}: no fault injected");
        }
        assert_eq!(
            decisions(&emulated),
            decisions(&clean),
            "seed {seed}, {faults:?}: the emulated run decided otherwise than the clean run"
        );
        assert_eq!(decisions(&emulated), decisions(&native), "seed {seed}");
        assert_eq!(
            mission_link_figures(&emulated),
            mission_link_figures(&native),
            "seed {seed}, {faults:?}: the Mission channel's traffic differs between the targets"
        );
    }
}

#[test]
fn one_percent_byte_corruption_on_qemu_decides_as_native() {
    check(
        LinkFaults {
            corrupt: 0.01,
            ..Default::default()
        },
        &[1, 2, 3],
    );
}

#[test]
fn five_percent_byte_corruption_on_qemu_decides_as_native() {
    check(
        LinkFaults {
            corrupt: 0.05,
            ..Default::default()
        },
        &[4, 5],
    );
}

#[test]
fn ten_percent_frame_loss_with_delays_on_qemu_decides_as_native() {
    check(
        LinkFaults {
            drop: 0.10,
            delay: 0.05,
            ..Default::default()
        },
        &[6, 7],
    );
}

#[test]
fn a_link_that_cannot_deliver_ends_the_run_with_link_lost_on_both_targets() {
    // 30 % of the bytes corrupted: hardly a frame gets through whole, and the oldest
    // unacknowledged one reaches the transmission limit during the first uplink.
    let plan = flyby_over(
        &LinkFaults {
            corrupt: 0.30,
            ..Default::default()
        },
        1,
    );
    for (name, r) in [
        ("native", fly_native(&plan)),
        ("emulated", fly_emulated(&plan, profile())),
    ] {
        assert!(!r.passed, "{name}");
        let why = r.ended_early.as_deref().unwrap_or_default();
        assert!(
            why.contains("link lost") && why.contains("transmission limit"),
            "{name}: {why}"
        );
        assert!(
            why.contains("sent acknowledged up to N(R)="),
            "{name}: {why}"
        );
    }
}
