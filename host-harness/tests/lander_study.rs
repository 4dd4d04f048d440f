//! `hil study` on the host: the shipped lander scenarios, errors at file:line:column, shards
//! taken through each batch engine's environment merging into the unsharded study, and the
//! shipped Slurm and Kubernetes definitions.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use hil::diag::SourceFile;
use hil::shard_env::shard_from_vars;
use hil::study::{load_scenario, parse_scenario};
use lander_sim::scenario::Scenario;
use lander_sim::study::{merge, run_study, StudyConfig, StudyReport};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn the_shipped_bsm1_is_the_built_in_one() {
    let s = load_scenario(&repo().join("scenarios/lander/bsm-1.toml")).unwrap();
    assert_eq!(s, Scenario::bsm1());
}

#[test]
fn bad_lander_scenarios_are_reported_at_file_line_column() {
    let text = std::fs::read_to_string(repo().join("scenarios/lander/bsm-1.toml")).unwrap();
    let bad = text.replace("p_fe = 0.03", "p_fe = 1.5");
    let e = parse_scenario(SourceFile::new("bsm-bad.toml", bad.clone())).unwrap_err();
    let line = bad
        .lines()
        .position(|l| l.starts_with("p_fe = 1.5"))
        .unwrap()
        + 1;
    assert_eq!(e.field, "failures.p_fe");
    assert_eq!(e.line(), line);
    assert_eq!(e.column(), 8, "{e}");
    assert!(
        e.to_string().starts_with(&format!("bsm-bad.toml:{line}:8")),
        "{e}"
    );
    // The classes must add up to P(fail).
    let bad = text.replace("p_ground = 0.028", "p_ground = 0.05");
    let e = parse_scenario(SourceFile::new("x.toml", bad)).unwrap_err();
    assert_eq!(e.field, "failures.p_fail");
    assert!(e.message.contains("p_fe + p_replan + p_ground"), "{e}");
    // Unknown fields and wrong types, from TOML, at their place.
    let bad = text.replace("hotel_w = 8", "hotel_watts = 8");
    let e = parse_scenario(SourceFile::new("x.toml", bad.clone())).unwrap_err();
    let line = bad
        .lines()
        .position(|l| l.starts_with("hotel_watts"))
        .unwrap()
        + 1;
    assert_eq!(e.line(), line, "{e}");
    assert!(e.message.contains("hotel_watts"), "{e}");
    let bad = text.replace("sols = 8", "sols = \"eight\"");
    let e = parse_scenario(SourceFile::new("x.toml", bad.clone())).unwrap_err();
    let line = bad.lines().position(|l| l.starts_with("sols")).unwrap() + 1;
    assert_eq!(e.line(), line, "{e}");
    // An uplink window outside the Earth-in-view period.
    let bad = text.replace(
        "uplink_offsets_h = [1, 13, 25, 37]",
        "uplink_offsets_h = [1, 50]",
    );
    let e = parse_scenario(SourceFile::new("x.toml", bad)).unwrap_err();
    assert_eq!(e.field, "ground.uplink_offsets_h[1]");
}

fn vars(pairs: &[(&str, String)]) -> BTreeMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect()
}

#[test]
fn shards_from_each_engines_environment_merge_into_the_unsharded_study() {
    let mut config = StudyConfig::new(Scenario::bsm1(), 2, 11);
    config.prescient_runs = 2;
    let whole = run_study(&config, None, &mut |_| {}).unwrap();
    let n = 3u32;
    type Env = fn(u32, u32) -> Vec<(&'static str, String)>;
    let engines: [(&str, Env); 4] = [
        ("GitLab", |i, n| {
            vec![
                ("CI_NODE_INDEX", (i + 1).to_string()),
                ("CI_NODE_TOTAL", n.to_string()),
            ]
        }),
        ("Slurm", |i, n| {
            vec![
                ("SLURM_ARRAY_TASK_ID", i.to_string()),
                ("SLURM_ARRAY_TASK_COUNT", n.to_string()),
            ]
        }),
        ("Slurm", |i, n| {
            vec![
                ("SLURM_ARRAY_TASK_ID", (i + 1).to_string()),
                ("SLURM_ARRAY_TASK_COUNT", n.to_string()),
                ("SLURM_ARRAY_TASK_MIN", "1".to_string()),
            ]
        }),
        ("Kubernetes", |i, n| {
            vec![
                ("JOB_COMPLETION_INDEX", i.to_string()),
                ("JOB_COMPLETIONS", n.to_string()),
            ]
        }),
    ];
    for (engine, env) in engines {
        let mut reports: Vec<StudyReport> = Vec::new();
        for i in 0..n {
            let (shard, which) = shard_from_vars(&vars(&env(i, n))).unwrap().unwrap();
            assert_eq!(which, engine);
            // JSON in between, as the shard files are.
            let report = run_study(&config, Some((shard.k, shard.n)), &mut |_| {}).unwrap();
            let text = serde_json::to_string(&report).unwrap();
            reports.push(serde_json::from_str(&text).unwrap());
        }
        let merged = merge(reports).unwrap();
        assert_eq!(merged, whole, "{engine}");
        assert_eq!(
            serde_json::to_string(&merged).unwrap(),
            serde_json::to_string(&whole).unwrap()
        );
    }
}

#[test]
fn the_kubernetes_manifest_states_its_completions_count_twice_alike() {
    let text =
        std::fs::read_to_string(repo().join("deploy/kubernetes/study-indexed-job.yaml")).unwrap();
    let completions = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("completions: "))
        .unwrap();
    let env = text
        .lines()
        .skip_while(|l| !l.contains("name: JOB_COMPLETIONS"))
        .nth(1)
        .and_then(|l| l.trim().strip_prefix("value: "))
        .unwrap();
    assert_eq!(
        env.split('#').next().unwrap().trim(),
        format!("\"{completions}\"")
    );
    assert!(text.contains("completionMode: Indexed"));
    assert!(text.contains("hil study merge"));
}

#[test]
fn the_slurm_array_script_runs_on_a_slurm_where_one_is_installed() {
    let script = repo().join("deploy/slurm/study-array.sh");
    // Its shell syntax, everywhere.
    let status = std::process::Command::new("sh")
        .arg("-n")
        .arg(&script)
        .status()
        .unwrap();
    assert!(status.success(), "sh -n {}", script.display());
    let has = |cmd: &str| {
        std::process::Command::new("sh")
            .args(["-c", &format!("command -v {cmd}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !has("sbatch") || !has("squeue") {
        println!(
            "skipped: the Slurm array run: sbatch/squeue are not installed (install Debian's slurm-wlm for a single-node Slurm to run it)"
        );
        return;
    }
    let ok = std::process::Command::new("sh")
        .args(["-c", "sinfo -h -o %a | grep -q up"])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        println!(
            "skipped: the Slurm array run: sbatch is installed but no partition is up (sinfo)"
        );
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let status = std::process::Command::new("sh")
        .arg(&script)
        .args(["2", "2"])
        .arg(out.path())
        .env("HIL", env!("CARGO_BIN_EXE_hil"))
        .current_dir(repo())
        .status()
        .unwrap();
    assert!(status.success());
    let merged = out.path().join("study.json");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(600);
    while !merged.exists() {
        assert!(
            std::time::Instant::now() < deadline,
            "the merge job did not finish"
        );
        std::thread::sleep(std::time::Duration::from_secs(2));
    }
    std::thread::sleep(std::time::Duration::from_secs(1));
    let report: StudyReport =
        serde_json::from_str(&std::fs::read_to_string(&merged).unwrap()).unwrap();
    let config = StudyConfig::new(Scenario::bsm1(), 2, 1);
    assert_eq!(report, run_study(&config, None, &mut |_| {}).unwrap());
}
