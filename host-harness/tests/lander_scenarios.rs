//! `hil lander run` and the shipped lander missions: RSM-1 and every ELAP scenario under
//! `scenarios/lander/elap/` (a new file is covered without touching this test) run natively and
//! meet their expectations; runs are deterministic; expectations can fail; bad files are
//! reported at file:line:column; the command's exit codes.
use std::path::{Path, PathBuf};
use std::process::Command;

use hil::diag::SourceFile;
use hil::lander::run_checked;
use hil::study::{load_scenario, parse_scenario};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// RSM-1 and every ELAP scenario.
fn shipped() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("scenarios/lander/elap"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files.push(repo().join("scenarios/lander/rsm-1.toml"));
    files
}

#[test]
fn every_shipped_lander_mission_meets_its_expectations() {
    let files = shipped();
    assert!(
        files.len() >= 13,
        "the twelve ELAP scenarios of V.B.1 are not all in scenarios/lander/elap/: {files:?}"
    );
    let mut failed = Vec::new();
    for path in &files {
        let s = load_scenario(path).unwrap_or_else(|e| panic!("{}", e.render()));
        assert!(
            !s.expect.is_empty(),
            "{}: a shipped mission needs expectations",
            path.display()
        );
        let o = run_checked(&s, None, None).unwrap();
        if !o.passed() {
            failed.push(format!("{}:\n{}", path.display(), hil::lander::summary(&o)));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn same_seed_same_run() {
    for path in shipped() {
        let s = load_scenario(&path).unwrap();
        let a = run_checked(&s, None, None).unwrap();
        let b = run_checked(&s, None, None).unwrap();
        assert_eq!(a.result, b.result, "{}", path.display());
        assert_eq!(a.verdicts, b.verdicts, "{}", path.display());
    }
    // And a different seed differs where there is randomness (RSM-1 draws failures).
    let s = load_scenario(&repo().join("scenarios/lander/rsm-1.toml")).unwrap();
    let seeds: Vec<_> = (1..=4)
        .map(|seed| run_checked(&s, Some(seed), None).unwrap().result)
        .collect();
    assert!(seeds.windows(2).any(|w| w[0] != w[1]));
}

#[test]
fn a_broken_expectation_fails() {
    let path = repo().join("scenarios/lander/rsm-1.toml");
    let mut s = load_scenario(&path).unwrap();
    let o = run_checked(&s, None, None).unwrap();
    assert!(o.passed());
    let samples = o.result.samples_analyzed;
    // One more sample than the run analyses: that expectation fails, the others still pass.
    s.expect.push(lander_sim::expect::Expectation {
        kind: "samples".into(),
        min: Some(f64::from(samples + 1)),
        ..Default::default()
    });
    let o = run_checked(&s, None, None).unwrap();
    assert!(!o.passed());
    let last = o.verdicts.last().unwrap();
    assert!(!last.passed, "{last:?}");
    assert!(last.detail.contains(&format!("samples analysed {samples}")));
    assert_eq!(o.verdicts.iter().filter(|v| !v.passed).count(), 1);
    assert!(hil::lander::summary(&o).contains("FAIL samples"));
}

#[test]
fn bad_expectations_are_reported_at_file_line_column() {
    let text = std::fs::read_to_string(repo().join("scenarios/lander/rsm-1.toml")).unwrap();
    let line_of =
        |t: &str, needle: &str| t.lines().position(|l| l.starts_with(needle)).unwrap() + 1;
    // An unknown kind: at its value, naming the known ones.
    let bad = text.replacen("kind = \"samples\"", "kind = \"sample_count\"", 1);
    let e = parse_scenario(SourceFile::new("r.toml", bad.clone())).unwrap_err();
    let line = line_of(&bad, "kind = \"sample_count\"");
    assert!(e.field.ends_with(".kind"), "{e}");
    assert_eq!((e.line(), e.column()), (line, 8), "{e}");
    assert!(
        e.to_string().starts_with(&format!("r.toml:{line}:8")),
        "{e}"
    );
    assert!(e.message.contains("no_stranded_samples"), "{e}");
    // A field the kind does not take.
    let bad = text.replacen(
        "kind = \"no_stranded_samples\"",
        "kind = \"no_stranded_samples\"\nmax = 3",
        1,
    );
    let e = parse_scenario(SourceFile::new("r.toml", bad.clone())).unwrap_err();
    assert!(e.field.ends_with(".max"), "{e}");
    assert_eq!(e.line(), line_of(&bad, "max = 3"), "{e}");
    // A field no expectation has: TOML's error, at its place.
    let bad = text.replacen("min = 5", "minimum = 5", 1);
    let e = parse_scenario(SourceFile::new("r.toml", bad.clone())).unwrap_err();
    assert_eq!(e.line(), line_of(&bad, "minimum = 5"), "{e}");
    // A required field missing, an unknown end and a change that does not exist.
    let bad = format!("{text}\n[[expect]]\nkind = \"site_order\"\n");
    let e = parse_scenario(SourceFile::new("r.toml", bad)).unwrap_err();
    assert!(e.message.contains("needs `order`"), "{e}");
    let bad = format!("{text}\n[[expect]]\nkind = \"end\"\nreason = \"exploded\"\n");
    let e = parse_scenario(SourceFile::new("r.toml", bad.clone())).unwrap_err();
    assert_eq!(e.line(), line_of(&bad, "reason = \"exploded\""), "{e}");
    let bad = format!("{text}\n[[expect]]\nkind = \"change_applied\"\nchange = 0\n");
    let e = parse_scenario(SourceFile::new("r.toml", bad.clone())).unwrap_err();
    assert!(e.message.contains("no ground change 0"), "{e}");
    assert_eq!(e.line(), line_of(&bad, "change = 0"), "{e}");
    // A ground change with two triggers.
    let bad = format!("{text}\n[[ground.changes]]\nat_h = 5\nafter_samples = 2\nrate_bps = 5000\n");
    let e = parse_scenario(SourceFile::new("r.toml", bad.clone())).unwrap_err();
    assert_eq!(e.field, "ground.changes[0]", "{e}");
    assert!(e.message.contains("exactly one trigger"), "{e}");
}

fn hil(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .current_dir(repo())
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

#[test]
fn hil_lander_run_exits_0_1_2() {
    let (code, out) = hil(&["lander", "run", "scenarios/lander/rsm-1.toml"]);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("PASS holds_respected"), "{out}");
    assert!(out.contains("sols simulated"), "{out}");
    assert!(out.contains("utility"), "{out}");
    // A broken expectation: exit 1.
    let dir = std::env::temp_dir().join(format!("hil-lander-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(repo().join("scenarios/lander/rsm-1.toml")).unwrap();
    let broken = dir.join("broken.toml");
    std::fs::write(&broken, text.replacen("min = 5", "min = 50", 1)).unwrap();
    let (code, out) = hil(&["lander", "run", broken.to_str().unwrap()]);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("FAIL samples"), "{out}");
    // A bad file: exit 2 with file:line:column.
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        text.replacen("kind = \"samples\"", "kind = \"nope\"", 1),
    )
    .unwrap();
    let (code, out) = hil(&["lander", "run", bad.to_str().unwrap()]);
    assert_eq!(code, 2, "{out}");
    assert!(out.contains(&format!("{}:", bad.display())), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pending_elap_scenarios_are_valid_and_still_fail() {
    // The ELAP scenarios the autonomy does not meet yet: valid files, each with a failing
    // expectation (when one passes, it belongs in scenarios/lander/elap/).
    // (None pending since data volume reached the planning: the directory may be absent.)
    let dir = repo().join("scenarios/lander/elap-pending");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        let s = load_scenario(&path).unwrap_or_else(|e| panic!("{}", e.render()));
        let o = run_checked(&s, None, None).unwrap();
        assert!(
            !o.passed(),
            "{} meets its expectations now: move it to scenarios/lander/elap/",
            path.display()
        );
    }
}
