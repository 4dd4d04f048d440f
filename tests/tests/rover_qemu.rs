//! The rover missions with their planning on the emulated RAD750 (issue 13 items 3 to 5): every
//! plan and replan of `hil rover run scenarios/rover/{sahara-day,field-trial}.toml --emulated`
//! is a job in the planner partition of one QEMU, and each run makes exactly the native run's
//! decisions
//! (the dispatcher and the simulated rover stay on the host). Each planning's cost is counted
//! in guest instructions.
use hil::plan_emulated::EmulatedPlanner;
use hil::rover::{run_file, Backend};

#[test]
fn the_emulated_rover_missions_make_the_native_decisions() {
    let _one = hil_tests::exclusive_qemu();
    // One QEMU for both runs: each plan is a job of its own.
    let target = EmulatedPlanner::boot(hil_tests::firmware()).expect("boots");
    let mut backend = Backend::Emulated(Box::new(target));
    for name in ["sahara-day", "field-trial"] {
        same_decisions(name, &mut backend);
    }
    // The target ends with the QEMU it booted (dropped here, ended by its PID).
    drop(backend);
}

fn same_decisions(name: &str, backend: &mut Backend) {
    let scenario = hil::repo_root().join(format!("scenarios/rover/{name}.toml"));
    let (native, _) = run_file(&scenario, None, &mut Backend::native()).expect("native run");
    let (emulated, verdicts) = run_file(&scenario, None, backend).expect("emulated run");
    assert_eq!(emulated.target, "emulated");
    assert_eq!(native.decisions, emulated.decisions);
    assert_eq!(native.decisions_sha256, emulated.decisions_sha256);
    for v in &verdicts {
        assert!(v.ok, "{}: {}", v.what, v.got);
    }
    assert_eq!(native.plannings.len(), emulated.plannings.len());
    for (n, e) in native.plannings.iter().zip(&emulated.plannings) {
        assert_eq!(n.attempts.len(), e.attempts.len());
        for (na, ea) in n.attempts.iter().zip(&e.attempts) {
            assert_eq!(na.outcome, ea.outcome);
            assert_eq!(na.expanded, ea.expanded);
            assert!(ea.guest_instructions.is_some_and(|g| g > 0));
            assert!(na.guest_instructions.is_none());
        }
    }
}
