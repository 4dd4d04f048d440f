//! Frames and telemetry: the application's metrics in the dictionary, repeated grants, a reset
//! application, each frame's planner and executive parts, state updates of the wrong type.

use super::*;

/// Every metric id the application sends is in the telemetry dictionary under its own
/// constant's name; the costs travel on the Instrument channel, the rest on the Mission
/// channel (the native target's stream is the emulated one's).
#[test]
fn every_application_metric_is_in_the_dictionary() {
    use fsw_bridge::dictionary;
    use fsw_bridge::link::VirtualChannel::{Instrument, Mission};
    let ids = [
        (metric::STEP_TICKS, "STEP_TICKS", Instrument),
        (metric::CHECKPOINT_TICKS, "CHECKPOINT_TICKS", Instrument),
        (metric::RESTORE_TICKS, "RESTORE_TICKS", Instrument),
        (metric::RECOVERY_TICKS, "RECOVERY_TICKS", Instrument),
        (metric::RESTORED_SEQUENCE, "RESTORED_SEQUENCE", Mission),
        (
            metric::CHECKPOINT_WRITE_FAILURES,
            "CHECKPOINT_WRITE_FAILURES",
            Mission,
        ),
        (metric::PLANNER_TICKS, "PLANNER_TICKS", Instrument),
        (metric::EXECUTIVE_TICKS, "EXECUTIVE_TICKS", Instrument),
        (metric::RESTORED_FROM, "RESTORED_FROM", Mission),
        (metric::RESTORED_SLOT, "RESTORED_SLOT", Mission),
        (
            metric::STATE_TYPE_MISMATCHES,
            "STATE_TYPE_MISMATCHES",
            Mission,
        ),
        (
            metric::STATE_TYPE_MISMATCH_KEY,
            "STATE_TYPE_MISMATCH_KEY",
            Mission,
        ),
        (metric::FRAME_BUSY_TICKS, "FRAME_BUSY_TICKS", Instrument),
        (metric::GROUND_HOLDS, "GROUND_HOLDS", Mission),
        (
            metric::UPLINK_VERIFY_TICKS,
            "UPLINK_VERIFY_TICKS",
            Instrument,
        ),
        (
            metric::GROUND_COMMANDS_NOT_CARRIED_OUT,
            "GROUND_COMMANDS_NOT_CARRIED_OUT",
            Mission,
        ),
        (
            metric::SECURITY_REFUSALS_FIRST,
            "SECURITY_REFUSALS_FIRST",
            Mission,
        ),
        (
            metric::BOOT_SECURITY_TICKS,
            "BOOT_SECURITY_TICKS",
            Instrument,
        ),
        (
            metric::RESTORE_CHECK_TICKS,
            "RESTORE_CHECK_TICKS",
            Instrument,
        ),
        (
            metric::RESTORE_DECODE_TICKS,
            "RESTORE_DECODE_TICKS",
            Instrument,
        ),
        (
            metric::PLANNER_RESTORE_TICKS,
            "PLANNER_RESTORE_TICKS",
            Instrument,
        ),
        (
            metric::PLANNER_RECOVERY_TICKS,
            "PLANNER_RECOVERY_TICKS",
            Instrument,
        ),
        (
            metric::PLANNER_CHECKPOINT_TICKS,
            "PLANNER_CHECKPOINT_TICKS",
            Instrument,
        ),
        (
            metric::PLANNER_CHECKPOINT_WRITE_FAILURES,
            "PLANNER_CHECKPOINT_WRITE_FAILURES",
            Mission,
        ),
        (metric::PLANNING_LATENCY_US, "PLANNING_LATENCY_US", Mission),
        (metric::STALE_COMMITS, "STALE_COMMITS", Mission),
        (
            metric::PLANNER_PENDING_FRAMES,
            "PLANNER_PENDING_FRAMES",
            Mission,
        ),
        (
            metric::CHANNEL_REFUSED_TO_PLANNER,
            "CHANNEL_REFUSED_TO_PLANNER",
            Mission,
        ),
        (
            metric::CHANNEL_REFUSED_TO_EXECUTIVE,
            "CHANNEL_REFUSED_TO_EXECUTIVE",
            Mission,
        ),
        (
            metric::PLANNER_TELEMETRY_DROPPED,
            "PLANNER_TELEMETRY_DROPPED",
            Mission,
        ),
    ];
    assert_eq!(
        ids.len(),
        metric::APP_METRICS.len(),
        "a constant is missing here"
    );
    // The wire ids are fixed (transcripts and budgets depend on them): spot checks.
    assert_eq!(metric::STEP_TICKS, 0x1000);
    assert_eq!(metric::SECURITY_REFUSALS_FIRST, 0x1010);
    assert_eq!(metric::RESTORE_DECODE_TICKS, 0x1022);
    for (id, constant, channel) in ids {
        let m = dictionary::metric(id).unwrap_or_else(|| panic!("{constant} not in dictionary"));
        assert_eq!((m.id, m.constant, m.channel), (id, constant, channel));
    }
    for reason in SecurityRefusal::ALL {
        let m = dictionary::metric(metric::security_refusals(reason)).unwrap();
        assert_eq!(m.constant, "SECURITY_REFUSALS_FIRST");
    }
    let from = dictionary::metric(metric::RESTORED_FROM).unwrap();
    assert!(from.value_name(metric::RESTORED_FROM_WARM).is_some());
    assert!(from.value_name(metric::RESTORED_FROM_NV).is_some());
}

#[test]
fn a_repeated_grant_gets_the_same_frame_done_without_stepping_again() {
    let mut app = std::boxed::Box::new(FlightApp::new());
    let (mut warm, mut nv) = (std::vec![0u8; 8192], std::vec![0u8; 8192]);
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: None,
    };
    let mut out: Vec<TargetToHost> = Vec::new();
    app.handle(&grant(7, 10), &mut mem, &mut NoClock, &mut |m| out.push(m));
    app.handle(&grant(7, 10), &mut mem, &mut NoClock, &mut |m| out.push(m));
    let done: Vec<&TargetToHost> = out
        .iter()
        .filter(|m| matches!(m, TargetToHost::FrameDone { .. }))
        .collect();
    assert_eq!(done.len(), 2);
    assert_eq!(done[0], done[1]);
    app.handle(&grant(8, 20), &mut mem, &mut NoClock, &mut |m| out.push(m));
    assert!(matches!(
        out.last(),
        Some(TargetToHost::FrameDone { frame: 8, .. })
    ));
}

/// A clock that advances by 10 ticks per read.
struct Counting(u64);

impl CpuClock for Counting {
    fn ticks(&mut self) -> u64 {
        self.0 += 10;
        self.0
    }
}

/// Boot, uplink the flyby and fly ten frames with fresh memories; everything answered.
fn fly_ten_frames(app: &mut FlightApp) -> Vec<TargetToHost> {
    let (mut warm, mut nv) = (std::vec![0u8; 60 * 1024], std::vec![0u8; 60 * 1024]);
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: Some(&mut security),
    };
    boot_and_uplink_flyby(app, &mut mem);
    let mut out: Vec<TargetToHost> = Vec::new();
    for frame in 0..10u32 {
        let g = grant(frame, 9 * 3600 + 50 * 60 + 60 * u64::from(frame));
        app.handle(&g, &mut mem, &mut Counting(0), &mut |m| out.push(m));
    }
    out
}

/// Both sides' whole states, as their checkpoints hold them.
fn encoded_core(app: &FlightApp) -> Vec<u8> {
    let mut buf = std::vec![0u8; 1 << 16];
    let len = app.executive.executive.encode_state(&mut buf).unwrap();
    buf.truncate(len);
    let mut planner = std::vec![0u8; 1 << 16];
    let len = app.planner.partition.encode_state(&mut planner).unwrap();
    buf.extend_from_slice(&planner[..len]);
    buf
}

#[test]
fn a_reset_application_is_the_new_one_and_flies_as_it() {
    let mut used = std::boxed::Box::new(FlightApp::new());
    let first = fly_ten_frames(&mut used);
    let fresh = std::boxed::Box::new(FlightApp::new());
    assert_ne!(encoded_core(&used), encoded_core(&fresh));
    assert_ne!(used.security(), fresh.security());
    used.reset();
    assert_eq!(encoded_core(&used), encoded_core(&fresh));
    let (u, f) = (&used.executive, &fresh.executive);
    assert_eq!(u.uplink_len, f.uplink_len);
    assert_eq!(u.uplink_progress, f.uplink_progress);
    assert_eq!(u.recovering, f.recovering);
    assert_eq!(u.last_done, f.last_done);
    assert_eq!(u.awaiting, f.awaiting);
    assert_eq!(u.persist, f.persist);
    assert_eq!(
        u.reported_state_type_mismatches,
        f.reported_state_type_mismatches
    );
    assert_eq!(u.reported_stale_commits, f.reported_stale_commits);
    assert_eq!(u.security, f.security);
    assert_eq!(u.security_refusals, f.security_refusals);
    assert_eq!(u.commands_not_carried_out, f.commands_not_carried_out);
    let (u, f) = (&used.planner, &fresh.planner);
    assert_eq!(u.persist, f.persist);
    assert_eq!(u.budget, f.budget);
    assert_eq!(u.recovering, f.recovering);
    assert_eq!(fly_ten_frames(&mut used), first);
}

#[test]
fn each_frame_reports_its_planner_and_executive_parts_and_a_restore_its_recovery() {
    let mut app = std::boxed::Box::new(FlightApp::new());
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    boot_and_uplink_flyby(&mut app, &mut mem);
    let mut out: Vec<TargetToHost> = Vec::new();
    let mut clock = Counting(0);
    app.handle(&grant(0, 9 * 3600), &mut mem, &mut clock, &mut |m| {
        out.push(m)
    });
    // Each window reads the clock before its work, between the work and its checkpoint,
    // and after: the executive's two passes (10 each), the planner's (10), each checkpoint
    // 10.
    assert_eq!(metrics(&out, metric::STEP_TICKS), [20]);
    assert_eq!(metrics(&out, metric::EXECUTIVE_TICKS), [20]);
    assert_eq!(metrics(&out, metric::CHECKPOINT_TICKS), [20]);
    assert_eq!(metrics(&out, metric::FRAME_BUSY_TICKS), [40]);
    assert_eq!(metrics(&out, metric::PLANNER_TICKS), [10]);
    assert_eq!(metrics(&out, metric::PLANNER_CHECKPOINT_TICKS), [10]);
    assert!(metrics(&out, metric::RECOVERY_TICKS).is_empty());
    // The planner counts its way to its first plan after any boot, a cold one too (the
    // host counts it only after a reset).
    assert_eq!(metrics(&out, metric::PLANNER_RECOVERY_TICKS).len(), 1);

    // Warm reset: a fresh application restores, hears two state updates, then a grant.
    let mut app = std::boxed::Box::new(FlightApp::new());
    let mut out: Vec<TargetToHost> = Vec::new();
    let outcome = app.boot(&mut mem, &mut clock, &mut |m| out.push(m));
    assert!(matches!(outcome, BootOutcome::RestoredWarm(_)));
    for _ in 0..2 {
        let update = HostToTarget::StateUpdate {
            key: autonomy::scenarios::ATTITUDE_KEY,
            value: fsw_bridge::StateValue::Enum(autonomy::scenarios::UNKNOWN),
            timestamp: MissionTimeUs::from_secs(9 * 3600 + 60),
        };
        app.handle(&update, &mut mem, &mut clock, &mut |m| out.push(m));
    }
    app.handle(&grant(1, 9 * 3600 + 60), &mut mem, &mut clock, &mut |m| {
        out.push(m)
    });
    // The executive: 10 ticks per state update, 20 for the first window and its
    // checkpoint, 10 for the second window's pass (the plan is repaired: its checkpoint is
    // not counted). The planner partition counts its own, from its restore on.
    assert_eq!(metrics(&out, metric::RECOVERY_TICKS), [50]);
    assert_eq!(metrics(&out, metric::PLANNER_RECOVERY_TICKS).len(), 1);
    assert!(metrics(&out, metric::PLANNER_RECOVERY_TICKS)[0] >= 20);
    // Once per restore.
    app.handle(&grant(2, 9 * 3600 + 120), &mut mem, &mut clock, &mut |m| {
        out.push(m)
    });
    assert_eq!(metrics(&out, metric::RECOVERY_TICKS), [50]);
    assert_eq!(metrics(&out, metric::PLANNER_RECOVERY_TICKS).len(), 1);
    assert_eq!(metrics(&out, metric::STEP_TICKS).len(), 2);
}

#[test]
fn state_updates_of_the_wrong_type_are_reported_the_first_time_and_when_the_count_changes() {
    let mut app = std::boxed::Box::new(FlightApp::new());
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    boot_and_uplink_flyby(&mut app, &mut mem);
    let key = autonomy::scenarios::ATTITUDE_KEY;
    let update = |value| HostToTarget::StateUpdate {
        key,
        value,
        timestamp: MissionTimeUs::from_secs(9 * 3600),
    };
    let mut out: Vec<TargetToHost> = Vec::new();
    let frame = |app: &mut FlightApp, mem: &mut Memories<'_>, n: u32| {
        let mut out: Vec<TargetToHost> = Vec::new();
        app.handle(
            &grant(n, 9 * 3600 + u64::from(n)),
            mem,
            &mut NoClock,
            &mut |m| out.push(m),
        );
        (
            metrics(&out, metric::STATE_TYPE_MISMATCHES),
            metrics(&out, metric::STATE_TYPE_MISMATCH_KEY),
        )
    };
    assert_eq!(frame(&mut app, &mut mem, 0), (std::vec![], std::vec![]));
    // An integer for the attitude (a state timeline): counted, reported with its key.
    app.handle(
        &update(fsw_bridge::StateValue::Int(1)),
        &mut mem,
        &mut NoClock,
        &mut |m| out.push(m),
    );
    assert_eq!(
        frame(&mut app, &mut mem, 1),
        (std::vec![1], std::vec![u64::from(key.0)])
    );
    // Unchanged: not reported again.
    assert_eq!(frame(&mut app, &mut mem, 2), (std::vec![], std::vec![]));
    for _ in 0..2 {
        app.handle(
            &update(fsw_bridge::StateValue::Enum(77)),
            &mut mem,
            &mut NoClock,
            &mut |m| out.push(m),
        );
    }
    assert_eq!(
        frame(&mut app, &mut mem, 3),
        (std::vec![3], std::vec![u64::from(key.0)])
    );
    // After a warm reset the restored count is reported in the first frame.
    let mut app = std::boxed::Box::new(FlightApp::new());
    app.boot(&mut mem, &mut NoClock, &mut |m| out.push(m));
    assert_eq!(
        frame(&mut app, &mut mem, 4),
        (std::vec![3], std::vec![u64::from(key.0)])
    );
    // Updates of the right type do not count.
    app.handle(
        &update(fsw_bridge::StateValue::Enum(1)),
        &mut mem,
        &mut NoClock,
        &mut |m| out.push(m),
    );
    assert_eq!(frame(&mut app, &mut mem, 5), (std::vec![], std::vec![]));
}
