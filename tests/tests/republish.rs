//! State knowledge that heals (natively): with a staleness bound on the attitude, the target
//! reads a value older than the bound as UNKNOWN, and the host's periodic republication of the
//! whole state buffer keeps it fresh. With republication the flyby decides exactly what it
//! decides without a bound; without it, the attitude goes stale in the middle of the flyby and
//! the autonomy aborts it.
use hil::mission::report::MissionReport;
use hil::mission::runner::{prepare, run};
use hil::mission::target::NativeTarget;

/// The nominal flyby with `stale_after` on every measured timeline and the spacecraft's
/// `republish_every` (None: only after resets), in a temporary directory.
fn flyby(stale_after: &str, republish: Option<&str>) -> MissionReport {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("tasknets")).unwrap();
    let net =
        std::fs::read_to_string(hil::repo_root().join("scenarios/tasknets/flyby.toml")).unwrap();
    let net = net.replacen(
        "[network]\n",
        &format!("[network]\nstale_after = \"{stale_after}\"\n"),
        1,
    );
    std::fs::write(dir.path().join("tasknets/flyby.toml"), net).unwrap();
    let mut scenario =
        std::fs::read_to_string(hil::repo_root().join("scenarios/flyby-nominal.toml")).unwrap();
    if let Some(every) = republish {
        scenario = scenario.replacen(
            "[spacecraft.gnc]\n",
            &format!("[spacecraft]\nrepublish_every = \"{every}\"\n\n[spacecraft.gnc]\n"),
            1,
        );
    }
    let path = dir.path().join("flyby.toml");
    std::fs::write(&path, scenario).unwrap();
    let plan = prepare(&path).unwrap_or_else(|e| panic!("{e}"));
    run(&plan, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn reference() -> MissionReport {
    let plan = prepare(&hil::repo_root().join("scenarios/flyby-nominal.toml")).unwrap();
    run(&plan, &mut NativeTarget::new(), None, &mut |_, _, _| {}).unwrap()
}

#[test]
fn republishing_every_five_minutes_keeps_a_ten_minute_bound_from_ever_acting() {
    let r = flyby("10min", Some("5min"));
    let summary = hil::mission::report::summary(&r);
    assert!(r.passed, "{summary}");
    assert!(
        !r.events.iter().any(|(_, l)| l.contains("stale")),
        "nothing went stale: {summary}"
    );
    let base = reference();
    let tasks = |r: &MissionReport| -> Vec<(String, Option<String>, Option<String>, String)> {
        r.tasks
            .iter()
            .map(|t| {
                (
                    t.name.clone(),
                    t.start.clone(),
                    t.end.clone(),
                    t.outcome.clone(),
                )
            })
            .collect()
    };
    assert_eq!(tasks(&r), tasks(&base), "{summary}");
}

#[test]
fn without_republication_the_attitude_goes_stale_and_the_flyby_is_aborted() {
    let r = flyby("10min", None);
    let summary = hil::mission::report::summary(&r);
    // The turn reports TURNING at 10:00 and nothing for 15 minutes: the attitude goes stale
    // 10 minutes and a microsecond later, and the turn (whose MAINTAIN constraint needs TURNING
    // or NADIR) is aborted then.
    assert!(
        r.events
            .iter()
            .any(|(at, l)| l.starts_with("GncAttitude stale") && at == "10:10:00.000001"),
        "{summary}"
    );
    assert!(!r.passed, "{summary}");
    assert!(
        r.tasks
            .iter()
            .any(|t| t.name == "GncAttain NADIR" && t.outcome == "aborted"),
        "{summary}"
    );
}
