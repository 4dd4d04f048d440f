//! The rover mission of seed 001 (issue 13 items 3 and 5), natively: `hil rover run
//! scenarios/rover/sahara-day.toml` meets the file's expectations (an overrun noticed past a
//! step's ub and the replan that follows, a running action paused into its inactive state, an
//! opportunistic goal accepted and one dropped, every hard goal achieved), the same seed gives
//! the same transcript, and a bad scenario is a clear error.
use hil::rover::{run_file, Backend};

fn sahara() -> std::path::PathBuf {
    hil::repo_root().join("scenarios/rover/sahara-day.toml")
}

#[test]
fn the_rover_day_meets_its_expectations_natively() {
    let (run, verdicts) = run_file(&sahara(), None, &mut Backend::native()).expect("runs");
    for v in &verdicts {
        assert!(v.ok, "{}: {}\n{}", v.what, v.got, run.transcript.join("\n"));
    }
    // The expectations the file names, and what they stand for in the transcript.
    assert!(verdicts.len() >= 11, "{verdicts:?}");
    let text = run.decisions.join("\n");
    // The three dispatch cases of section 5.2: held to lb, late within (lb, ub], replan past ub.
    assert!(text.contains("held to lb"), "{text}");
    assert!(text.contains("after lb, within (lb, ub]"), "{text}");
    assert!(text.contains("replan: overrun:"), "{text}");
    assert!(text.contains("pause (sample-rock r0 w2)"), "{text}");
    assert!(
        text.contains("drop opportunistic goal (image-sent o4)"),
        "{text}"
    );
    assert!(text.contains("carry (traverse"), "{text}");
    // A paused sample is done again: the rock is sent.
    assert!(run.achieved.contains(&"(rock-sent w2)".to_string()));
    // Nothing new is dispatched while planning: no dispatch before the time the last planning
    // said it ends.
    let mut until = 0.0f64;
    let mut plannings = 0;
    for line in &run.decisions {
        let at: f64 = line.split_whitespace().next().unwrap().parse().unwrap();
        if let Some(rest) = line.split("nothing new dispatched until ").nth(1) {
            until = rest.trim().parse().unwrap();
            plannings += 1;
        }
        if line.contains("dispatch (") {
            assert!(at >= until, "{line} before the planning's end {until}");
        }
    }
    assert_eq!(plannings, run.plannings.len());
    let times: Vec<f64> = run.plannings.iter().map(|p| p.at_s).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    assert!(run.plannings.iter().all(|p| p.solved));
}

#[test]
fn the_same_seed_gives_the_same_transcript_and_another_seed_another() {
    let mut backend = Backend::native();
    let (a, _) = run_file(&sahara(), Some(7), &mut backend).expect("runs");
    let (b, _) = run_file(&sahara(), Some(7), &mut backend).expect("runs");
    assert_eq!(a.decisions, b.decisions);
    assert_eq!(a.decisions_sha256, b.decisions_sha256);
    let (c, _) = run_file(&sahara(), Some(8), &mut backend).expect("runs");
    assert_ne!(
        a.decisions, c.decisions,
        "the seed drives the simulated terrain"
    );
}

#[test]
fn a_scenario_with_an_unknown_goal_or_field_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let root = hil::repo_root().join("scenarios/rover");
    for f in ["domain.pddl", "problem.pddl"] {
        std::fs::copy(root.join(f), dir.path().join(f)).unwrap();
    }
    let text = std::fs::read_to_string(sahara()).unwrap();
    let bad_goal = dir.path().join("bad-goal.toml");
    std::fs::write(
        &bad_goal,
        text.replace("(image-sent o4)", "(image-sent o9)"),
    )
    .unwrap();
    let e = run_file(&bad_goal, None, &mut Backend::native()).expect_err("refused");
    assert!(e.contains("no fact (image-sent o9)"), "{e}");
    let bad_field = dir.path().join("bad-field.toml");
    std::fs::write(&bad_field, text.replace("slow_percent", "slowness")).unwrap();
    let e = run_file(&bad_field, None, &mut Backend::native()).expect_err("refused");
    assert!(
        e.contains("bad-field.toml") && e.contains("slowness"),
        "{e}"
    );
}

#[test]
fn the_field_trial_drops_its_optional_goal_when_a_delay_leaves_no_plan_with_it() {
    let file = hil::repo_root().join("scenarios/rover/field-trial.toml");
    let (run, verdicts) = run_file(&file, None, &mut Backend::native()).expect("runs");
    for v in &verdicts {
        assert!(v.ok, "{}: {}\n{}", v.what, v.got, run.transcript.join("\n"));
    }
    // The first plan kept the optional goal; the overrun replan dropped it.
    let first = &run.plannings[0];
    assert_eq!(first.attempts.len(), 1);
    assert_eq!(first.attempts[0].outcome, "solved");
    assert!(first.dropped.is_empty());
    let replan = run
        .plannings
        .iter()
        .find(|p| p.reason.starts_with("overrun"))
        .expect("an overrun replan");
    assert_eq!(replan.dropped, vec!["(image-sent o4)".to_string()]);
    assert_eq!(replan.attempts.len(), 2);
    assert!(!run.achieved.contains(&"(image-sent o4)".to_string()));
}
