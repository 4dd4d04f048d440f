//! `hil rover run` as a user runs it: exit 0 with every expectation met, 1 when one fails
//! (naming it), 2 on a file it cannot run; `--json` gives the run and the verdicts.
use std::process::Command;

fn repo() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn hil(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .current_dir(repo())
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn hil_rover_run_exits_0_1_2_and_speaks_json() {
    let (code, out, err) = hil(&["rover", "run", "scenarios/rover/sahara-day.toml"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("PASS sahara-day: 11/11 expectations met"),
        "{out}"
    );
    assert!(
        out.contains("drop opportunistic goal (image-sent o4)"),
        "{out}"
    );
    // An expectation the run cannot meet: exit 1, that expectation FAIL.
    let dir = tempfile::tempdir().unwrap();
    for f in ["domain.pddl", "problem.pddl"] {
        std::fs::copy(repo().join("scenarios/rover").join(f), dir.path().join(f)).unwrap();
    }
    let text = std::fs::read_to_string(repo().join("scenarios/rover/sahara-day.toml")).unwrap();
    let broken = dir.path().join("broken.toml");
    std::fs::write(
        &broken,
        text.replace(
            "dropped = [\"(image-sent o4)\"]",
            "dropped = [\"(image-sent o3)\"]",
        ),
    )
    .unwrap();
    let (code, out, err) = hil(&["rover", "run", broken.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(
        out.contains("[FAIL] opportunistic (image-sent o3) dropped: not dropped"),
        "{out}"
    );
    // A file that does not parse: exit 2, naming the file.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[rover]\nname = 3\n").unwrap();
    let (code, _, err) = hil(&["rover", "run", bad.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("bad.toml"), "{err}");
    // JSON: the run (decisions, plannings with their attempts) and the verdicts.
    let (code, out, err) = hil(&["rover", "run", "scenarios/rover/sahara-day.toml", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    assert_eq!(v["run"]["target"], "native");
    assert!(v["run"]["plannings"].as_array().unwrap().len() >= 4);
    assert!(v["verdicts"]
        .as_array()
        .unwrap()
        .iter()
        .all(|x| x["ok"] == true));
}
