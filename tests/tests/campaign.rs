//! Campaigns (`hil campaign`): random-reset variants of the flyby on the native target, run in
//! parallel, sharded and merged. The same campaign on the emulated target is at the end.
use hil::campaign::{
    merge, run_campaign, CampaignOptions, CampaignReport, Failure, ResetPoint, Shard,
};
use hil::scenario::TargetKind;

fn flyby_campaign(runs: u32) -> CampaignOptions {
    let mut o = CampaignOptions::new(
        hil::repo_root().join("scenarios/flyby-campaign.toml"),
        runs,
        1,
    );
    o.native = true;
    o.jobs = 2;
    o
}

fn run(opts: &CampaignOptions) -> CampaignReport {
    run_campaign(opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn twenty_random_reset_variants_of_the_flyby_all_recover_with_a_consistent_plan() {
    let report = run(&flyby_campaign(20));
    let summary = hil::campaign::summary(&report);
    assert_eq!(report.results.len(), 20, "{summary}");
    assert!(report.passed(), "{summary}");
    assert_eq!(report.stats.passed, 20, "{summary}");
    // Run-index order, seeds S + i, one warm reset each inside the default window.
    for (i, r) in report.results.iter().enumerate() {
        assert_eq!(r.variant.run, i as u32);
        assert_eq!(r.variant.seed, 1 + i as u64);
        assert!(r.failures.is_empty(), "{summary}");
        assert!(r.metrics["frames"] > 0);
    }
    assert_eq!(report.reset_window, "09:50:00..11:10:00");
    // Both kinds of reset point, and every mid-frame reset really tore a checkpoint.
    let mid: Vec<_> = report
        .results
        .iter()
        .filter(|r| r.variant.reset_point == ResetPoint::MidFrame)
        .collect();
    assert!(!mid.is_empty() && mid.len() < 20, "{summary}");
    for r in mid {
        assert!(
            r.mid_frame.iter().any(|l| l.contains("torn from byte")),
            "{:?}",
            r.mid_frame
        );
    }
    for metric in ["frames", "wall_time_ms", "link_faults_injected"] {
        assert!(report.stats.metrics.contains_key(metric), "{summary}");
    }
}

/// A thousand variants natively (a few seconds): resets in every minute of the flyby, at frame
/// boundaries and mid-frame. Two classes of failure lived here until found this way: a reset
/// just before GncAttain NADIR was committed delayed the flyby by less than the degraded
/// flyby's minimum and left the request uncovered (seeds 33, 106, 189), and a reset during the
/// first checkpoint write lost the only plan (seeds 381, 622, 694, 909).
#[test]
fn a_thousand_random_reset_variants_all_recover() {
    let report = run(&flyby_campaign(1000));
    let summary = hil::campaign::summary(&report);
    assert_eq!(report.stats.passed, 1000, "{summary}");
    for run in [32, 105, 188, 380, 621, 693, 908] {
        assert!(report.results[run].passed, "run {run}: {summary}");
    }
}

/// Resets in the first second of the flyby, half of them mid-frame: the native model tears
/// only what the target could be writing then (the first frame's checkpoint, never the
/// uplink's, which the target writes before it acknowledges the uplink). The old model tore
/// the newest record whatever wrote it, and lost the acknowledged plan in 111 of 300 runs.
#[test]
fn resets_in_the_first_second_never_tear_the_acknowledged_uplink_checkpoint() {
    let mut opts = flyby_campaign(300);
    opts.reset_window = Some(hil::campaign::parse_window("09:50:00..09:50:01").unwrap());
    let report = run(&opts);
    let summary = hil::campaign::summary(&report);
    assert_eq!(report.stats.passed, 300, "{summary}");
    let mid: Vec<_> = report
        .results
        .iter()
        .filter(|r| r.variant.reset_point == ResetPoint::MidFrame)
        .collect();
    assert!(mid.len() > 100, "{summary}");
    for r in mid {
        // The reset lands after the first frame (its checkpoint is torn) or before any
        // frame wrote one (nothing is being written): never inside the uplink's checkpoint.
        assert!(
            r.mid_frame.iter().all(|l| l.contains("torn from byte")
                || l.contains("no checkpoint write was in progress")),
            "{:?}",
            r.mid_frame
        );
    }
}

#[test]
fn a_run_whose_checkpoints_are_all_destroyed_fails_with_its_reproducer() {
    let mut opts = flyby_campaign(4);
    opts.destroy_checkpoints_in = vec![2];
    let report = run(&opts);
    let summary = hil::campaign::summary(&report);
    assert!(!report.passed(), "{summary}");
    assert_eq!(report.stats.failed, 1, "{summary}");
    let bad = &report.results[2];
    assert!(!bad.passed);
    assert!(bad.variant.destroy_checkpoints);
    assert!(
        bad.failures
            .iter()
            .any(|f| matches!(f, Failure::LostCheckpoint { .. })),
        "{:?}",
        bad.failures
    );
    // Without its plan the target never flies the flyby or the next maneuver.
    assert!(bad.failures.len() > 1, "{:?}", bad.failures);
    // The summary names the variant's tuple and the command that reproduces it.
    assert!(
        summary.contains(&format!(
            "run 2 (seed 3): warm reset at {}, {}, recovery 180s",
            bad.variant.reset_at,
            bad.variant.reset_point.name()
        )),
        "{summary}"
    );
    assert!(
        summary.contains(
            "--seed 1 --only 2 --reset-window 09:50:00..11:10:00 --recovery 180s --native"
        ),
        "{summary}"
    );
    for (i, r) in report.results.iter().enumerate() {
        assert_eq!(r.passed, i != 2, "{summary}");
    }
}

#[test]
fn only_reproduces_one_variant_exactly() {
    let all = run(&flyby_campaign(6));
    let mut opts = flyby_campaign(6);
    opts.only = Some(4);
    let one = run(&opts);
    assert_eq!(one.results.len(), 1);
    assert_eq!(
        one.deterministic_results()[0],
        all.deterministic_results()[4]
    );
}

#[test]
fn shards_one_and_two_of_two_merge_into_the_unsharded_campaign() {
    let whole = run(&flyby_campaign(8));
    let shard = |k| {
        let mut o = flyby_campaign(8);
        o.shard = Some(Shard { k, n: 2 });
        o.jobs = 1;
        run(&o)
    };
    let (a, b) = (shard(1), shard(2));
    assert_eq!(a.results.len(), 4);
    assert!(a.results.iter().all(|r| r.variant.run % 2 == 0));
    assert_eq!(a.stats.missing_runs, [1, 3, 5, 7]);
    // Merge through JSON, as shard reports from other machines arrive.
    let dir = tempfile::tempdir().unwrap();
    let through_json = |r: &CampaignReport| {
        hil::campaign::load_report(&{
            let p = dir
                .path()
                .join(format!("{}.json", r.shards.join("_").replace('/', "of")));
            hil::campaign::save_report(r, &p).unwrap();
            p
        })
        .unwrap()
    };
    let merged = merge(vec![through_json(&b), through_json(&a)]).unwrap();
    assert_eq!(
        merged.deterministic_results(),
        whole.deterministic_results()
    );
    assert!(merged.shards.is_empty() && merged.stats.missing_runs.is_empty());
    assert_eq!(merged.stats.passed, whole.stats.passed);
    assert_eq!(
        merged.stats.metrics["frames"],
        whole.stats.metrics["frames"]
    );
}

#[test]
fn mismatched_or_overlapping_reports_are_refused() {
    let mut o = flyby_campaign(4);
    o.shard = Some(Shard { k: 1, n: 2 });
    let a = run(&o);
    let mut other_seed = o.clone();
    other_seed.seed = 2;
    other_seed.shard = Some(Shard { k: 2, n: 2 });
    let e = merge(vec![a.clone(), run(&other_seed)]).unwrap_err();
    assert!(
        e.contains("different campaigns") && e.contains("seed 1 vs 2"),
        "{e}"
    );

    let mut other_runs = o.clone();
    other_runs.runs = 6;
    other_runs.shard = Some(Shard { k: 2, n: 2 });
    let e = merge(vec![a.clone(), run(&other_runs)]).unwrap_err();
    assert!(e.contains("runs 4 vs 6"), "{e}");

    let e = merge(vec![a.clone(), a.clone()]).unwrap_err();
    assert!(
        e.contains("run 0 is in both shard 1/2 and shard 1/2"),
        "{e}"
    );

    let mut other_scenario = a.clone();
    other_scenario.scenario = "flyby-nominal".into();
    let e = merge(vec![a, other_scenario]).unwrap_err();
    assert!(
        e.contains("scenario flyby-campaign vs flyby-nominal"),
        "{e}"
    );
}

/// Twenty random-reset variants of the flyby on the emulated RAD750 (the flight application in
/// the executive partition), every one recovering with a consistent plan and no lost
/// checkpoint. Mid-frame variants are real warm resets at a seeded point of the executive's
/// work in the frame at the reset time (see `MissionTarget::arm_mid_frame_reset`); each says
/// where it landed and what the restart restored.
#[test]
fn campaign_on_the_emulated_target() {
    let _one = hil_tests::exclusive_qemu();
    let mut opts = flyby_campaign(20);
    opts.native = false;
    // One QEMU at a time (it holds one slot, see `exclusive_qemu`), on the image the other
    // tests use.
    opts.jobs = 1;
    opts.firmware = Some(hil_tests::firmware().elf.clone());
    let report = run(&opts);
    let summary = hil::campaign::summary(&report);
    assert_eq!(report.target, TargetKind::Qemu);
    assert!(report.passed(), "{summary}");
    let mid: Vec<_> = report
        .results
        .iter()
        .filter(|r| r.variant.reset_point == ResetPoint::MidFrame)
        .collect();
    assert!(!mid.is_empty() && mid.len() < 20, "{summary}");
    let mut inside = 0;
    let mut in_planner = 0;
    for r in &mid {
        eprintln!("{}", r.variant.describe());
        for line in &r.mid_frame {
            eprintln!("    {line}");
        }
        // One line for where it landed (in the frame at the reset time), one for the restore.
        assert_eq!(r.mid_frame.len(), 2, "{:?}", r.mid_frame);
        let landing = &r.mid_frame[0];
        // "... in the frame at T: inside the executive's work ..." or "frame finished first:
        // the executive's work on the frame at T took ...".
        assert!(
            landing.contains(&format!("the frame at {}", r.variant.reset_at)),
            "{landing}"
        );
        assert!(
            landing.contains("inside the executive's work")
                || landing.contains("inside the planner's work")
                || landing.starts_with("frame finished first"),
            "{landing}"
        );
        if landing.contains("inside the executive's work")
            || landing.contains("inside the planner's work")
        {
            inside += 1;
        }
        if landing.contains("planner") {
            in_planner += 1;
        }
        assert!(
            r.mid_frame[1].contains("plan restored from checkpoint"),
            "{:?}",
            r.mid_frame
        );
    }
    eprintln!(
        "{} mid-frame resets, {inside} inside a partition's work, {in_planner} in the planner partition's",
        mid.len()
    );
    assert!(inside * 2 > mid.len(), "{summary}");
    // Both partitions' work is hit: the planner's (its planning, its checkpoint copy, the
    // messages in flight to it) as well as the executive's.
    assert!(in_planner > 0 && in_planner < mid.len(), "{summary}");
}

/// Two emulated targets at once on a two-core machine, and every run passes: a target waiting
/// for the host stops its schedule (no host CPU), so the two QEMUs no longer starve each other.
/// Before, with each guest busy-polling while it waited, such a campaign lost runs to "timed out
/// after 60 s waiting for the target".
#[test]
fn an_emulated_campaign_runs_two_targets_at_once_and_every_run_passes() {
    let _one = hil_tests::exclusive_qemu();
    let mut opts = flyby_campaign(4);
    opts.native = false;
    // Two QEMUs on one slot (see `exclusive_qemu`): other tests may run theirs meanwhile.
    opts.jobs = 2;
    opts.firmware = Some(hil_tests::firmware().elf.clone());
    let report = run(&opts);
    let summary = hil::campaign::summary(&report);
    assert_eq!(report.target, TargetKind::Qemu);
    assert_eq!(report.results.len(), 4, "{summary}");
    assert_eq!(report.stats.passed, 4, "{summary}");
    assert!(report.passed(), "{summary}");
    for r in &report.results {
        assert!(r.failures.is_empty(), "{summary}");
        assert!(r.metrics["frames"] > 0, "{summary}");
    }
}

/// The native torn-checkpoint model against the emulated target on the same seeds, where the
/// old model was wrong: resets in the flyby's first second, half of them mid-frame. On QEMU the
/// reset is real (a seeded point of the executive's work, its checkpoint write included); the
/// native model tears only what the target could be writing then. Both must agree run for run:
/// every run passes, the same runs are mid-frame, and every restart restores a plan (the
/// acknowledged uplink's checkpoint is never lost on either).
#[test]
fn the_native_torn_checkpoint_model_agrees_with_the_emulated_target_on_the_same_seeds() {
    let _one = hil_tests::exclusive_qemu();
    let mut native = flyby_campaign(12);
    native.reset_window = Some(hil::campaign::parse_window("09:50:00..09:50:01").unwrap());
    let mut emulated = native.clone();
    emulated.native = false;
    emulated.jobs = 1;
    emulated.firmware = Some(hil_tests::firmware().elf.clone());
    let native = run(&native);
    let emulated = run(&emulated);
    let summary = format!(
        "native:\n{}\nemulated:\n{}",
        hil::campaign::summary(&native),
        hil::campaign::summary(&emulated)
    );
    assert_eq!(native.stats.passed, 12, "{summary}");
    assert_eq!(emulated.stats.passed, 12, "{summary}");
    let mut mid = 0;
    for (n, e) in native.results.iter().zip(&emulated.results) {
        assert_eq!(n.variant, e.variant, "the same seeds, the same variants");
        if e.variant.reset_point != ResetPoint::MidFrame {
            continue;
        }
        mid += 1;
        assert!(
            e.mid_frame
                .iter()
                .any(|l| l.contains("plan restored from checkpoint")),
            "run {}: {:?}",
            e.variant.run,
            e.mid_frame
        );
        assert!(
            n.mid_frame.iter().all(|l| l.contains("torn from byte")
                || l.contains("no checkpoint write was in progress")),
            "run {}: {:?}",
            n.variant.run,
            n.mid_frame
        );
    }
    assert!(mid > 0, "{summary}");
}
