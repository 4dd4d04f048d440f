//! The shipped flyby scenarios on the native target (the flight application compiled into the
//! harness): fast, no QEMU. The same scenarios run on the emulated target in `missions_qemu.rs`.
use std::path::{Path, PathBuf};

use hil::mission::report::{prepare, run, MissionReport};
use hil::mission::target::NativeTarget;

fn scenario(name: &str) -> PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

fn run_native(path: &Path) -> MissionReport {
    let scenario = hil::scenario::load(path).unwrap_or_else(|e| panic!("{e}"));
    let prepared = prepare(path, scenario).unwrap_or_else(|e| panic!("{e}"));
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
            "Instrument Flyby (requested) 10:15:00-10:33:00 aborted",
            "Instrument Flyby Request (requested) 10:15:00-11:05:00 completed",
            "GncAttain EARTH (requested) 11:05:00-11:20:00 completed",
            "Instrument Flyby (restarted) 10:48:00-11:05:00 completed",
            "GncAttain NADIR (template) (added) 10:33:00-10:48:00 completed",
            "Instrument Degraded Flyby (added) 10:33:00-10:48:00 completed",
        ]
    );
    assert_eq!(r.resets.len(), 1);
    assert_eq!(r.resets[0].reset_cause, "warm");
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
    let dir = std::env::temp_dir().join(format!("hil-seed-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("tasknets")).unwrap();
    std::fs::copy(
        hil::repo_root().join("scenarios/tasknets/flyby.toml"),
        dir.join("tasknets/flyby.toml"),
    )
    .unwrap();
    std::fs::write(dir.join("s.toml"), text).unwrap();
    let a = run_native(&path);
    let b = run_native(&dir.join("s.toml"));
    assert_ne!(a.transcript_sha256, b.transcript_sha256);
}

/// Write a scenario next to a copy of the flyby network and return the load/prepare error.
fn mission_error(body: &str) -> String {
    let dir = std::env::temp_dir().join(format!("hil-bad-{}-{}", std::process::id(), body.len()));
    std::fs::create_dir_all(dir.join("tasknets")).unwrap();
    std::fs::copy(
        hil::repo_root().join("scenarios/tasknets/flyby.toml"),
        dir.join("tasknets/flyby.toml"),
    )
    .unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, body).unwrap();
    let err = match hil::scenario::load(&path) {
        Err(e) => e.to_string(),
        Ok(s) => prepare(&path, s)
            .err()
            .expect("must be refused")
            .to_string(),
    };
    err.replacen(&path.display().to_string(), "bad.toml", 1)
}

const GOOD_HEAD: &str = "name = \"x\"\n[mission]\ntasknet = \"tasknets/flyby.toml\"\nstart = \"09:50\"\nend = \"11:30\"\n";

#[test]
fn mission_files_with_mistakes_are_refused_with_file_line_and_field() {
    let e = mission_error(&format!(
        "{GOOD_HEAD}[[events]]\nat = \"10:30\"\nwarm_reboot = {{ recovery = \"3min\" }}\n"
    ));
    assert!(
        e.starts_with("bad.toml:8:1: unknown field `warm_reboot`"),
        "{e}"
    );

    let e = mission_error(&format!(
        "{GOOD_HEAD}\n[[events]]\nat = \"12:30\"\nwarm_reset = {{}}\n"
    ));
    assert!(
        e.starts_with("bad.toml:7:1: events[0].at: 12:30 is outside the mission"),
        "{e}"
    );

    let e = mission_error(&format!(
        "{GOOD_HEAD}[[events]]\nat = \"10:30\"\nwarm_reset = {{ recovery = \"3 fortnights\" }}\n"
    ));
    assert!(
        e.contains("events[0].warm_reset.recovery: bad duration"),
        "{e}"
    );

    let e = mission_error(&format!(
        "{GOOD_HEAD}[[expect]]\ntask = \"Instrument Flyover\"\noutcome = \"completed\"\n"
    ));
    assert!(
        e.starts_with("bad.toml:6:1: expect[0].task: no task named \"Instrument Flyover\""),
        "{e}"
    );

    let e = mission_error(&format!(
        "{GOOD_HEAD}[[expect]]\ntask = \"Instrument Flyby\"\noutcome = \"exploded\"\n"
    ));
    assert!(e.contains("outcome: \"exploded\" is not one of"), "{e}");

    let e = mission_error(&format!(
        "{GOOD_HEAD}[[expect]]\ntimeline = \"GncAttitude\"\nat = \"10:00\"\nvalue = \"SIDEWAYS\"\n"
    ));
    assert!(
        e.contains("\"SIDEWAYS\" is not a value of this timeline"),
        "{e}"
    );

    let e = mission_error(&format!("{GOOD_HEAD}[spacecraft.gnc]\nattitude = \"Attitude\"\nattain_opcode = 257\nslew = \"15min\"\ninitial = \"INERTIAL\"\nturning = \"TURNING\"\nafter_reset = \"UNKNOWN\"\n"));
    assert!(
        e.contains("spacecraft.gnc.attitude: no timeline named \"Attitude\""),
        "{e}"
    );

    let e = mission_error("name = \"x\"\n[mission]\ntasknet = \"tasknets/missing.toml\"\nstart = \"09:50\"\nend = \"11:30\"\n");
    assert!(e.starts_with("bad.toml:2:1: mission.tasknet:"), "{e}");
    assert!(e.contains("missing.toml"), "{e}");

    let e = mission_error("name = \"x\"\n[mission]\ntasknet = \"tasknets/flyby.toml\"\nstart = \"11:50\"\nend = \"11:30\"\n");
    assert!(
        e.contains("mission.end: must be after mission.start"),
        "{e}"
    );
}

#[test]
fn realtime_mode_paces_the_grants_by_the_wall_clock() {
    let dir = std::env::temp_dir().join(format!("hil-rt-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("tasknets")).unwrap();
    std::fs::copy(
        hil::repo_root().join("scenarios/tasknets/flyby.toml"),
        dir.join("tasknets/flyby.toml"),
    )
    .unwrap();
    let path = dir.join("rt.toml");
    std::fs::write(
        &path,
        "name = \"rt\"\n[mission]\ntasknet = \"tasknets/flyby.toml\"\nstart = \"09:59:58\"\nend = \"10:00:00\"\n",
    )
    .unwrap();
    let mut prepared = prepare(&path, hil::scenario::load(&path).unwrap()).unwrap();
    prepared.mission.realtime = true;
    let started = std::time::Instant::now();
    run(&prepared, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap();
    // Two mission seconds cannot take less than two wall seconds (a busy host only adds).
    assert!(
        started.elapsed() >= std::time::Duration::from_secs(2),
        "{:?}",
        started.elapsed()
    );
}
