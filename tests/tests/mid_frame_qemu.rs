//! Warm resets at a chosen instruction point inside a frame on the emulated RAD750 (issue 5,
//! item 4): the target's kernel resets the module at a point of the executive partition's work
//! on the granted frame, counted in its own CPU ticks, the same point on every run. The flyby
//! recovers from it, a reset inside the checkpoint copy tears the newest warm slot and the
//! restart falls back to the other one, and the same armed point gives the same transcript.
use fsw_bridge::{MissionTimeUs, ResetKind};
use hil::mission::report::MissionReport;
use hil::mission::runner::{prepare, run};
use hil::mission::target::{EmulatedTarget, MidFrameReport, MissionTarget};
use hil_tests::{firmware, profile};
use kernel_config::abi::reset_at;

/// The warm reset lands in the frame at this time: the flyby is running (Fig. 7's reset time).
const RESET_AT: &str = "10:30";
const RECOVERY_US: u64 = 180_000_000;

/// The campaign's flyby with one warm reset at RESET_AT, armed at `kind` inside its frame.
fn flyby_reset_at(kind: ResetKind, tag: &str) -> (MissionReport, Vec<MidFrameReport>, Vec<String>) {
    let _one = hil_tests::exclusive_qemu();
    let path = hil::repo_root().join("scenarios/flyby-campaign.toml");
    let mut prepared = prepare(&path).unwrap_or_else(|e| panic!("{e}"));
    prepared.add_warm_reset(
        hil::time::parse_time(&RESET_AT.into(), hil::time::Epoch::default()).unwrap(),
        RECOVERY_US,
    );
    let mut target =
        EmulatedTarget::with_temporary_nv(profile(), firmware().clone(), false, false).unwrap();
    target.arm_mid_frame_reset_exactly(kind);
    let report = run(&prepared, &mut target, Some(firmware()), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{tag}: {e}"));
    (
        report,
        target.mid_frame_reports().to_vec(),
        target.reset_notes(),
    )
}

/// The reset happened, as a warm reset, at RESET_AT, and the flyby's expectations held.
fn assert_recovered(report: &MissionReport, log: &[String]) {
    let summary = hil::mission::report::summary(report);
    assert!(report.passed, "{summary}\n{log:#?}");
    assert_eq!(report.resets.len(), 1, "{summary}");
    let reset = &report.resets[0];
    assert_eq!(reset.kind, "warm reset");
    assert_eq!(reset.reset_cause, "warm", "{summary}");
    assert_eq!(
        MissionTimeUs(reset.at),
        hil::time::parse_time(&RESET_AT.into(), hil::time::Epoch::default()).unwrap(),
        "{summary}"
    );
    assert!(
        report
            .events
            .iter()
            .any(|(_, label)| label == "plan restored from checkpoint"),
        "{summary}"
    );
}

#[test]
fn a_reset_armed_mid_frame_lands_inside_the_executives_work_and_the_flyby_recovers_the_same_way_twice(
) {
    let kind = ResetKind::WarmAfterTicks { ticks: 500 };
    let (a, a_reports, a_log) = flyby_reset_at(kind, "a");
    assert_recovered(&a, &a_log);
    assert_eq!(a_reports.len(), 1, "{a_log:#?}");
    let landing = &a_reports[0];
    assert_eq!(
        landing.frame_at,
        hil::time::parse_time(&RESET_AT.into(), hil::time::Epoch::default()).unwrap()
    );
    assert_eq!(landing.kind, kind);
    // 500 ticks into the executive's first window of the frame, whose work is ~1,000 ticks
    // (its pass, then its checkpoint from about tick 700): before the checkpoint write.
    assert_eq!(landing.landed, Some(reset_at::LANDED_IN_CODE), "{a_log:#?}");
    assert!(landing.inside_work());
    assert!(landing.checkpoint_write.is_none(), "{a_log:#?}");
    let ticks = landing.ticks.expect("the kernel reported the point");
    assert!((500..600).contains(&ticks), "{a_log:#?}");
    assert!(
        a_log[0].starts_with("reset after 500 executive ticks in the frame at 10:30:00")
            && a_log[0].contains("inside the executive's work"),
        "{a_log:#?}"
    );
    assert!(
        a_log
            .iter()
            .any(|l| l.contains("plan restored from checkpoint")),
        "{a_log:#?}"
    );
    assert!(landing.restored.is_some(), "{a_log:#?}");

    // The same armed point: the same transcript, the same landing, the same restore.
    let (b, b_reports, b_log) = flyby_reset_at(kind, "b");
    assert_recovered(&b, &b_log);
    assert_eq!(a.transcript_sha256, b.transcript_sha256);
    assert_eq!(a.decisions, b.decisions);
    // Where it landed and what the restart restored (the tick counts themselves may differ
    // by one between runs, see `hil::mission::driver::is_tick_measurement`).
    let facts = |r: &MidFrameReport| (r.frame_at, r.kind, r.landed, r.checkpoint_write, r.restored);
    assert_eq!(facts(&a_reports[0]), facts(&b_reports[0]));
}

#[test]
fn a_reset_inside_the_checkpoint_copy_tears_the_newest_slot_and_the_restart_takes_the_other_one() {
    // Probe: a point far beyond the frame's work. The executive finishes first and the kernel
    // resets at the end of its work, saying where the checkpoint copy ran.
    let probe_kind = ResetKind::WarmAfterTicks { ticks: 10_000_000 };
    let (probe, reports, log) = flyby_reset_at(probe_kind, "probe");
    assert_recovered(&probe, &log);
    let finished = &reports[0];
    assert_eq!(
        finished.landed,
        Some(reset_at::LANDED_AFTER_WORK),
        "{log:#?}"
    );
    assert!(!finished.inside_work());
    assert!(
        log[0].starts_with("frame finished first") && log[0].contains("reset at the boundary"),
        "{log:#?}"
    );
    let write = finished
        .checkpoint_write
        .expect("the frame wrote its checkpoint");
    assert!(!write.torn(), "{log:#?}");
    assert!(write.start_tick < write.end_tick, "{write:?}");
    assert!(write.end_tick as u64 <= finished.ticks.unwrap(), "{log:#?}");
    // The whole checkpoint of that frame survived: it is what the restart restored.
    let (whole_sequence, whole_slot) = finished.restored.expect("restored");
    assert_eq!(whole_slot, write.slot, "{log:#?}");

    // Armed in the middle of that copy (the same frame does the same work): the copy stops
    // there, the newest slot is torn, the restart takes the previous checkpoint from the other
    // slot, and the flyby still recovers.
    // The decrementer that fires the point and the tick count that reports the copy's span
    // can differ by a tick or two (see `is_tick_measurement`), and a copy of a checkpoint
    // this size spans only a few ticks: the last tick of the copy lands inside it with bytes
    // copied (a point at the copy's first ticks can fire before its first chunk).
    let middle = write.end_tick.saturating_sub(1).max(write.start_tick + 1);
    let (torn, reports, log) = flyby_reset_at(ResetKind::WarmAfterTicks { ticks: middle }, "torn");
    assert_recovered(&torn, &log);
    let landing = &reports[0];
    assert_eq!(
        landing.landed,
        Some(reset_at::LANDED_IN_WARM_WRITE),
        "{log:#?}"
    );
    assert!(landing.inside_work());
    let tear = landing.checkpoint_write.expect("the torn write");
    assert_eq!(tear.slot, write.slot);
    assert_eq!(tear.len, write.len);
    assert!(tear.torn() && tear.copied > 0, "{tear:?}");
    let (sequence, slot) = landing.restored.expect("restored");
    assert_ne!(slot, tear.slot, "the torn slot was restored: {log:#?}");
    assert_eq!(sequence + 1, whole_sequence, "{log:#?}");
    assert!(
        log[0].contains("in its checkpoint write") && log[0].contains("torn"),
        "{log:#?}"
    );
    assert!(log[1].contains("(the torn slot"), "{log:#?}");

    // The other way to ask for it: a fraction of the copy.
    let half = ResetKind::WarmDuringCheckpointWrite { permille: 500 };
    let (halved, reports, log) = flyby_reset_at(half, "half");
    assert_recovered(&halved, &log);
    let landing = &reports[0];
    assert_eq!(
        landing.landed,
        Some(reset_at::LANDED_IN_WARM_WRITE),
        "{log:#?}"
    );
    let tear = landing.checkpoint_write.expect("the torn write");
    assert_eq!(tear.copied, tear.len / 2, "{tear:?}");
    assert_eq!(landing.restored, Some((sequence, slot)), "{log:#?}");
}

/// Issue 14: the same inside the planner partition's work on the frame (counted from its
/// receipt of the executive's first message of the frame) and inside its checkpoint copy: the
/// flyby recovers, each partition restoring its own newest whole checkpoint, and the same
/// armed point gives the same transcript.
#[test]
fn a_reset_armed_inside_the_planners_work_or_its_checkpoint_copy_recovers_the_same_way_twice() {
    let kind = ResetKind::PlannerAfterTicks { ticks: 200 };
    let (a, a_reports, a_log) = flyby_reset_at(kind, "planner a");
    assert_recovered(&a, &a_log);
    assert_eq!(a_reports.len(), 1, "{a_log:#?}");
    let landing = &a_reports[0];
    assert_eq!(landing.kind, kind);
    assert_eq!(landing.landed, Some(reset_at::LANDED_IN_CODE), "{a_log:#?}");
    let ticks = landing.ticks.expect("the kernel reported the point");
    assert!((100..300).contains(&ticks), "{ticks}: {a_log:#?}");
    assert!(
        a_log[0].contains("planner ticks") && a_log[0].contains("inside the planner's work"),
        "{a_log:#?}"
    );
    let (b, b_reports, b_log) = flyby_reset_at(kind, "planner b");
    assert_recovered(&b, &b_log);
    assert_eq!(a.transcript_sha256, b.transcript_sha256);
    assert_eq!(a.decisions, b.decisions);
    let facts = |r: &MidFrameReport| (r.frame_at, r.kind, r.landed, r.checkpoint_write, r.restored);
    assert_eq!(facts(&a_reports[0]), facts(&b_reports[0]));

    // Half-way through the planner's checkpoint copy: its newest slot is torn, the restart
    // takes its other one, and the pair still recovers the flyby.
    let kind = ResetKind::PlannerDuringCheckpointWrite { permille: 500 };
    let (c, c_reports, c_log) = flyby_reset_at(kind, "planner write");
    assert_recovered(&c, &c_log);
    let landing = &c_reports[0];
    assert_eq!(
        landing.landed,
        Some(reset_at::LANDED_IN_WARM_WRITE),
        "{c_log:#?}"
    );
    let write = landing
        .checkpoint_write
        .expect("the planner's checkpoint write");
    assert!(write.torn(), "{write:?}");
    assert_eq!(write.copied, write.len / 2, "{write:?}");
}
