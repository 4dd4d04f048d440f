//! Planning split across calls (issue 12, the emulated side): on the target the executor's
//! search runs within each planner window's CPU share, a few explorations a call, and the
//! executor is called again with the same observation while it answers `Planning`
//! (`flight_app::LanderApp`; natively `lander_sim::sim::step_to_answer`). Every shipped lander
//! mission must then decide exactly what one call with a large budget decides: the same
//! decisions (times included), the same directives, the same run.
use hil::lander_emulated::Recorder;
use hil::study::load_scenario;
use lander_sim::sim::{run_watched, RunConfig};

fn scenarios() -> Vec<std::path::PathBuf> {
    let root = hil::repo_root().join("scenarios/lander");
    let mut files = vec![
        root.join("bsm-1.toml"),
        root.join("rsm-1.toml"),
        root.join("learned-across-uplink.toml"),
        root.join("ground-sets-parameters.toml"),
    ];
    let mut elap: Vec<_> = std::fs::read_dir(root.join("elap"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    elap.sort();
    files.extend(elap);
    files
}

#[test]
fn a_search_split_over_many_calls_decides_what_one_call_decides() {
    let files = scenarios();
    assert!(files.len() >= 11, "{files:?}");
    for path in files {
        let s = load_scenario(&path).unwrap_or_else(|d| panic!("{}", d.render()));
        let config = RunConfig::new(s.run.strategy.strategy(), s.run.seed);
        let mut whole = Recorder::default();
        let one = run_watched(&s, &config, &mut whole).unwrap();
        let plans = whole
            .transcript
            .logs
            .iter()
            .flatten()
            .filter(|d| matches!(d.kind, lander::executor::DecisionKind::Planned { .. }))
            .count();
        assert!(plans >= 1, "{}: no plan made", path.display());
        for budget in [1, 4, 37] {
            let mut split = Recorder::default();
            let config = RunConfig { budget, ..config };
            let r = run_watched(&s, &config, &mut split).unwrap();
            let tag = format!("{} with {budget} explorations a call", path.display());
            assert_eq!(split.transcript.logs, whole.transcript.logs, "{tag}");
            assert_eq!(
                split.transcript.directives, whole.transcript.directives,
                "{tag}"
            );
            assert_eq!(r, one, "{tag}");
        }
    }
}
