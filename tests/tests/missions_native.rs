//! The shipped flyby scenarios on the native target (the flight application compiled into the
//! harness): fast, no QEMU. The same scenarios run on the emulated target in `missions_qemu.rs`.
use std::path::{Path, PathBuf};

use hil::mission::report::MissionReport;
use hil::mission::runner::{prepare, run};
use hil::mission::target::NativeTarget;

fn scenario(name: &str) -> PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

fn run_native(path: &Path) -> MissionReport {
    let prepared = prepare(path).unwrap_or_else(|e| panic!("{e}"));
    let mut target = NativeTarget::new();
    run(&prepared, &mut target, None, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_passes(name: &str) -> MissionReport {
    let report = run_native(&scenario(name));
    assert!(report.passed, "{}", hil::mission::report::summary(&report));
    report
}

#[test]
fn every_shipped_flyby_scenario_passes_natively() {
    let mut names: Vec<String> = std::fs::read_dir(hil::repo_root().join("scenarios"))
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("flyby-") && n.ends_with(".toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 8, "{names:?}");
    for name in names {
        assert_passes(&name);
    }
}

/// Issue 11 item 8: the passes start when the station's timed values open its windows (10:20,
/// 12:00), the transmitter's integer temperature reads WARM through its threshold, and the
/// battery drains by the hotel load's background rate between measurements.
#[test]
fn the_orbiter_downlink_pass_flies_its_station_windows() {
    let report = assert_passes("orbiter-downlink.toml");
    let started = |name: &str| {
        report
            .tasks
            .iter()
            .find(|t| t.name == name)
            .and_then(|t| t.start.clone())
    };
    assert_eq!(started("Downlink Pass 1").as_deref(), Some("10:20:00"));
    assert_eq!(started("Downlink Pass 2").as_deref(), Some("12:00:00"));
}

/// Issue 11 item 8 e, f, g: the helper waits 60 s after the heating ends (its temporal
/// constraint with the requested task), its command carries the pass's station and target and
/// its own end, and the pass runs the 20 minutes its length parameter was given at 10:00.
#[test]
fn the_orbiter_pointing_pass_binds_its_helper_and_takes_its_arguments_and_length() {
    let report = assert_passes("orbiter-pointing.toml");
    let span = |name: &str| {
        report
            .tasks
            .iter()
            .find(|t| t.name == name)
            .map(|t| (t.start.clone(), t.end.clone()))
    };
    assert_eq!(
        span("Point At Earth"),
        Some((Some("10:16:00".into()), Some("10:18:00".into())))
    );
    assert_eq!(
        span("Downlink Pass"),
        Some((Some("10:20:00".into()), Some("10:40:00".into())))
    );
}

#[test]
fn early_reset_reproduces_seed_003_figure_7() {
    let r = assert_passes("flyby-early-reset.toml");
    let rows: Vec<String> = r
        .tasks
        .iter()
        .map(|t| {
            format!(
                "{} ({}) {}-{} {}",
                t.name,
                t.origin,
                t.start.as_deref().unwrap_or("-"),
                t.end.as_deref().unwrap_or("-"),
                t.outcome
            )
        })
        .collect();
    assert_eq!(
        rows,
        [
            "GncAttain NADIR (requested) 10:00:00-10:15:00 completed",
            "Instrument Flyby (requested) 10:15:00-10:30:00 interrupted",
            "Instrument Flyby Request (requested) 10:15:00-11:05:00 completed",
            "GncAttain EARTH (requested) 11:05:00-11:20:00 completed",
            "Instrument Flyby (restarted) 10:48:00-11:05:00 completed",
            "GncAttain NADIR (template) (added) 10:33:00-10:48:00 completed",
            "Instrument Degraded Flyby (added) 10:33:00-10:48:00 completed",
        ]
    );
    assert_eq!(r.resets.len(), 1);
    assert_eq!(r.resets[0].reset_cause, "warm");
    // The autonomy's own verdict on the interrupted flyby, after the restart: aborted at
    // 10:33 (its NADIR constraint no longer held), as in seed 003's Fig. 7.
    let flyby = &r.tasks[1];
    assert_eq!(flyby.after_restart.as_deref(), Some("aborted at 10:33:00"));
}

#[test]
fn the_same_scenario_and_seed_give_the_same_transcript() {
    let a = run_native(&scenario("flyby-link-corruption.toml"));
    let b = run_native(&scenario("flyby-link-corruption.toml"));
    assert_eq!(a.transcript_sha256, b.transcript_sha256);
    assert_eq!(a.decisions, b.decisions);
    assert!(a.injected_link_faults > 0);
}

#[test]
fn another_seed_gives_another_link_fault_pattern() {
    let path = scenario("flyby-link-corruption.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("seed = 11", "seed = 12");
    let dir = hil_tests::beside_the_flyby_tasknet();
    std::fs::write(dir.path().join("s.toml"), text).unwrap();
    let a = run_native(&path);
    let b = run_native(&dir.path().join("s.toml"));
    assert_ne!(a.transcript_sha256, b.transcript_sha256);
}

#[test]
fn realtime_mode_paces_the_grants_by_the_wall_clock() {
    let dir = hil_tests::beside_the_flyby_tasknet();
    let path = dir.path().join("rt.toml");
    std::fs::write(
        &path,
        "name = \"rt\"\n[mission]\ntasknet = \"tasknets/flyby.toml\"\nstart = \"09:59:58\"\nend = \"10:00:00\"\n",
    )
    .unwrap();
    let mut prepared = prepare(&path).unwrap();
    prepared.realtime = true;
    let started = std::time::Instant::now();
    run(&prepared, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap();
    // Two mission seconds cannot take less than two wall seconds (a busy host only adds).
    assert!(
        started.elapsed() >= std::time::Duration::from_secs(2),
        "{:?}",
        started.elapsed()
    );
}
