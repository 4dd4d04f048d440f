//! The shipped flyby scenarios on the emulated RAD750 proxy (the flight application in the
//! executive partition of the partitioning kernel, under qemu-system-ppc with icount), and the
//! comparison with the native build: the same decisions at the same mission times.
use std::path::{Path, PathBuf};

use hil::mission::record::Decision;
use hil::mission::report::{prepare, run, MissionReport};
use hil::mission::target::{EmulatedTarget, NativeTarget};
use hil_tests::{firmware, profile};

fn scenario(name: &str) -> PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

fn run_emulated(path: &Path) -> MissionReport {
    let _one = hil_tests::exclusive_qemu();
    let loaded = hil::scenario::load(path).unwrap_or_else(|e| panic!("{e}"));
    let prepared = prepare(path, loaded).unwrap_or_else(|e| panic!("{e}"));
    let nv = std::env::temp_dir().join(format!(
        "hil-test-nv-{}-{}.bin",
        std::process::id(),
        path.file_stem().unwrap().to_string_lossy()
    ));
    let mut target = EmulatedTarget::new(profile(), firmware().clone(), false, nv, false);
    run(&prepared, &mut target, Some(firmware()), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn run_native(path: &Path) -> MissionReport {
    let loaded = hil::scenario::load(path).unwrap();
    let prepared = prepare(path, loaded).unwrap();
    run(&prepared, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap()
}

/// Scenarios that run on the emulated target today (the power cycle needs the emulated
/// non-volatile memory in the kernel, not there yet).
const EMULATED: [&str; 7] = [
    "flyby-nominal.toml",
    "flyby-early-reset.toml",
    "flyby-late-reset.toml",
    "flyby-two-resets.toml",
    "flyby-reset-during-turn.toml",
    "flyby-command-failure.toml",
    "flyby-link-corruption.toml",
];

/// Decisions without the command ids, which the target numbers from its own counter (equal
/// here too, but not part of what the autonomy decided).
fn decisions(r: &MissionReport) -> Vec<Decision> {
    r.decisions
        .iter()
        .map(|d| match d {
            Decision::Dispatch {
                at, opcode, args, ..
            } => Decision::Dispatch {
                at: *at,
                id: 0,
                opcode: *opcode,
                args: args.clone(),
            },
            other => other.clone(),
        })
        .collect()
}

#[test]
fn the_flyby_scenarios_pass_on_the_emulated_target_with_the_same_decisions_as_native() {
    for name in EMULATED {
        let path = scenario(name);
        let emulated = run_emulated(&path);
        assert!(
            emulated.passed,
            "{name}\n{}",
            hil::mission::report::summary(&emulated)
        );
        let native = run_native(&path);
        assert_eq!(
            decisions(&emulated),
            decisions(&native),
            "{name}: the emulated target decided differently from the native build"
        );
        assert!(!emulated.decisions.is_empty());
    }
}

#[test]
fn early_reset_recovery_is_measured_in_guest_ticks_and_within_budget() {
    let r = run_emulated(&scenario("flyby-early-reset.toml"));
    assert!(r.passed, "{}", hil::mission::report::summary(&r));
    let ticks = r.resets[0]
        .recovery_ticks
        .expect("recovery measured on the target");
    assert!(ticks > 0);
    assert_eq!(r.metrics["max_recovery_ticks"], ticks);
    // The budget of issue 4: 10 ms at the proxy rate (2.5 M instructions).
    assert!(
        r.metrics["max_recovery_instructions"] < 2_500_000,
        "{:?}",
        r.metrics
    );
    assert!(r.metrics["max_checkpoint_ticks"] > 0);
    assert!(r.metrics["max_restore_ticks"] > 0);
}

/// The transcript (everything both sides said, guest-tick measurements aside) is the same on
/// every run, and so are the decisions. The costs are the same to within one tick: under QEMU
/// 7.2's icount the instruction at which a decrementer write or read takes effect is now and
/// then one off, which moves a measurement across a tick boundary (seen: one run in three).
#[test]
fn the_same_scenario_gives_the_same_transcript_and_the_same_costs_twice() {
    let path = scenario("flyby-two-resets.toml");
    let a = run_emulated(&path);
    let b = run_emulated(&path);
    assert_eq!(a.transcript_sha256, b.transcript_sha256);
    assert_eq!(a.decisions, b.decisions);
    assert_eq!(
        a.metrics.keys().collect::<Vec<_>>(),
        b.metrics.keys().collect::<Vec<_>>()
    );
    for (name, value) in &a.metrics {
        let other = b.metrics[name];
        let tolerance = if name.ends_with("_ticks") {
            1
        } else if name.ends_with("_instructions") {
            hil::mission::record::INSTRUCTIONS_PER_TICK_X1000.div_ceil(1000)
        } else {
            0
        };
        assert!(
            value.abs_diff(other) <= tolerance,
            "{name}: {value} then {other}\n{:?}\n{:?}",
            a.metrics,
            b.metrics
        );
    }
}
