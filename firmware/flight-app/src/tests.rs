extern crate std;
use std::vec::Vec;

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

fn grant(frame: u32, secs: u64) -> HostToTarget {
    HostToTarget::TimeGrant {
        frame,
        now: MissionTimeUs::from_secs(secs),
        until: MissionTimeUs::from_secs(secs + 1),
    }
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

fn metrics(out: &[TargetToHost], id: u16) -> Vec<u64> {
    out.iter()
        .filter_map(|m| match m {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if *i == id => {
                Some(*value)
            }
            _ => None,
        })
        .collect()
}

/// The key the tests provision.
const TEST_KEY: sdls::Key = sdls::Key {
    spi: 1,
    bytes: [0x11; 32],
};

/// A security area in memory; `fail_writes` makes every write fail.
#[derive(Clone)]
struct TestNv {
    area: [u8; sdls::nv::SECURITY_AREA_BYTES],
    fail_writes: bool,
}

impl TestNv {
    fn provisioned(key: &sdls::Key) -> Self {
        let mut area = [0u8; sdls::nv::SECURITY_AREA_BYTES];
        sdls::nv::provision(&mut area, key).unwrap();
        Self {
            area,
            fail_writes: false,
        }
    }
}

impl SecurityStore for TestNv {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        area.copy_from_slice(&self.area);
        Ok(())
    }
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        if self.fail_writes {
            return Err(StoreError);
        }
        self.area
            .get_mut(offset..offset + bytes.len())
            .ok_or(StoreError)?
            .copy_from_slice(bytes);
        Ok(())
    }
}

fn flyby_image() -> Vec<u8> {
    let network = autonomy::scenarios::flyby_network().unwrap();
    let mut image = std::vec![0u8; MAX_UPLINK_BYTES];
    let len = network.encode(&mut image).unwrap();
    image.truncate(len);
    image
}

/// The flyby network secured with `key` and sequence number `sequence`.
fn signed_flyby(key: &sdls::Key, sequence: u32) -> Vec<u8> {
    let image = flyby_image();
    let mut out = std::vec![0u8; image.len() + sdls::uplink::OVERHEAD];
    let n = sdls::uplink::sign_into(key, sequence, &image, &mut out).unwrap();
    out.truncate(n);
    out
}

/// Send `secured` in chunks; everything the application answered.
fn send_uplink(app: &mut FlightApp, mem: &mut Memories<'_>, secured: &[u8]) -> Vec<TargetToHost> {
    let chunks: Vec<&[u8]> = secured.chunks(UPLINK_CHUNK_MAX).collect();
    let mut out: Vec<TargetToHost> = Vec::new();
    for (seq, c) in chunks.iter().enumerate() {
        let msg = HostToTarget::UplinkChunk {
            seq: seq as u16,
            total: chunks.len() as u16,
            bytes: heapless::Vec::from_slice(c).unwrap(),
        };
        app.handle(&msg, mem, &mut NoClock, &mut |m| out.push(m));
    }
    out
}

/// The verdict on a whole uplink: the reply with `seq == total`.
fn verdict(out: &[TargetToHost]) -> Option<&TargetToHost> {
    out.iter().rev().find(|m| {
        matches!(m, TargetToHost::UplinkNak { .. }) || matches!(m, TargetToHost::UplinkAck { .. })
    })
}

/// Boot `app` (which reads the key) and uplink the flyby with sequence number 1.
fn boot_and_uplink_flyby(app: &mut FlightApp, mem: &mut Memories<'_>) {
    app.boot(mem, &mut NoClock, &mut |_| {});
    let secured = signed_flyby(&TEST_KEY, 1);
    let total = secured.len().div_ceil(UPLINK_CHUNK_MAX) as u16;
    let out = send_uplink(app, mem, &secured);
    assert_eq!(out.last(), Some(&TargetToHost::UplinkAck { seq: total }));
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

#[test]
fn uplink_chunks_out_of_order_are_refused_and_nothing_is_loaded() {
    let mut app = std::boxed::Box::new(FlightApp::new());
    let (mut warm, mut nv) = (std::vec![0u8; 8192], std::vec![0u8; 8192]);
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: None,
    };
    let mut out: Vec<TargetToHost> = Vec::new();
    let chunk = |seq, total| HostToTarget::UplinkChunk {
        seq,
        total,
        bytes: heapless::Vec::from_slice(&[1, 2, 3]).unwrap(),
    };
    app.handle(&chunk(1, 3), &mut mem, &mut NoClock, &mut |m| out.push(m));
    assert_eq!(
        out.pop(),
        Some(TargetToHost::UplinkNak {
            seq: 1,
            reason: uplink_reason::OUT_OF_SEQUENCE
        })
    );
    app.handle(&chunk(0, 2), &mut mem, &mut NoClock, &mut |m| out.push(m));
    assert_eq!(out.pop(), Some(TargetToHost::UplinkAck { seq: 0 }));
    app.handle(&chunk(1, 3), &mut mem, &mut NoClock, &mut |m| out.push(m));
    assert_eq!(
        out.pop(),
        Some(TargetToHost::UplinkNak {
            seq: 1,
            reason: uplink_reason::BAD_TOTAL
        })
    );
    // Garbage that completes a transfer is refused by the validator, not loaded.
    app.handle(&chunk(0, 1), &mut mem, &mut NoClock, &mut |m| out.push(m));
    assert!(matches!(
        out.pop(),
        Some(TargetToHost::UplinkNak { seq: 1, .. })
    ));
    assert!(app.executive().executive().network().tasks().is_empty());
}

/// The whole plan and execution state, to show that a refusal left it untouched.
fn state_image(app: &FlightApp) -> Vec<u8> {
    let mut buf = std::vec![0u8; 64 * 1024];
    let n = app.executive().executive().encode_state(&mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// Security refusal metrics in `out`: (reason, count so far).
fn refusal_metrics(out: &[TargetToHost]) -> Vec<(SecurityRefusal, u64)> {
    out.iter()
        .filter_map(|m| match m {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }) => {
                metric::security_refusal_of(*id).map(|r| (r, *value))
            }
            _ => None,
        })
        .collect()
}

fn nak_reason(out: &[TargetToHost]) -> Option<SecurityRefusal> {
    match verdict(out) {
        Some(TargetToHost::UplinkNak { reason, .. }) => SecurityRefusal::from_code(*reason),
        _ => None,
    }
}

/// An application with the flyby loaded (sequence 1) and one frame run, so its state is
/// not that of a freshly loaded network, with nothing owned by the executive yet (so a
/// second uplink, if accepted, would load).
fn flying(mem: &mut Memories<'_>) -> std::boxed::Box<FlightApp> {
    let mut app = std::boxed::Box::new(FlightApp::new());
    boot_and_uplink_flyby(&mut app, mem);
    app.handle(&grant(0, 9 * 3600), mem, &mut NoClock, &mut |_| {});
    assert!(app
        .executive()
        .executive()
        .control()
        .executive()
        .entries()
        .is_empty());
    app
}

#[test]
fn forged_replayed_wrong_key_unknown_key_and_truncated_uplinks_are_refused_counted_and_change_nothing(
) {
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    let mut app = flying(&mut mem);
    let before = state_image(&app);

    let mut forged = signed_flyby(&TEST_KEY, 2);
    forged[sdls::uplink::HEADER_LEN + 7] ^= 0x01;
    let wrong_key = signed_flyby(
        &sdls::Key {
            spi: TEST_KEY.spi,
            bytes: [0x22; 32],
        },
        2,
    );
    let unknown_key = signed_flyby(
        &sdls::Key {
            spi: 9,
            bytes: TEST_KEY.bytes,
        },
        2,
    );
    let good = signed_flyby(&TEST_KEY, 2);
    let truncated = good[..good.len() - 1].to_vec();
    let mut long = good.clone();
    long.push(0);
    let replayed = signed_flyby(&TEST_KEY, 1);
    let cases = [
        (forged, SecurityRefusal::BadMac),
        (wrong_key, SecurityRefusal::BadMac),
        (unknown_key, SecurityRefusal::UnknownKey),
        (truncated, SecurityRefusal::Truncated),
        (long, SecurityRefusal::BadLength),
        (replayed, SecurityRefusal::Replay),
    ];
    for (bytes, reason) in &cases {
        let out = send_uplink(&mut app, &mut mem, bytes);
        assert_eq!(nak_reason(&out), Some(*reason), "{out:?}");
        let count = cases
            .iter()
            .take_while(|(b, _)| !core::ptr::eq(b, bytes))
            .filter(|(_, r)| r == reason)
            .count() as u64
            + 1;
        assert_eq!(refusal_metrics(&out), [(*reason, count)]);
        assert_eq!(state_image(&app), before, "{reason:?} changed the plan");
        assert_eq!(app.security().last_sequence(), 1);
    }
    assert_eq!(app.security_refusals(SecurityRefusal::BadMac), 2);
    // The same network, signed properly with a fresh number, is loaded: the checks above
    // were what kept the others out.
    let out = send_uplink(&mut app, &mut mem, &good);
    assert!(matches!(
        verdict(&out),
        Some(TargetToHost::UplinkAck { .. })
    ));
    assert_ne!(state_image(&app), before);
    assert_eq!(app.security().last_sequence(), 2);
}

#[test]
fn without_a_key_or_without_non_volatile_memory_every_uplink_is_refused_with_no_key() {
    fn refused_with_no_key<'a>(warm: &'a mut [u8], store: Option<&'a mut dyn SecurityStore>) {
        let mut mem = Memories {
            warm,
            nv: None,
            security: store,
        };
        let mut app = std::boxed::Box::new(FlightApp::new());
        app.boot(&mut mem, &mut NoClock, &mut |_| {});
        let out = send_uplink(&mut app, &mut mem, &signed_flyby(&TEST_KEY, 1));
        assert_eq!(nak_reason(&out), Some(SecurityRefusal::NoKey));
        assert!(app.executive().executive().network().tasks().is_empty());
    }
    let mut blank = TestNv::provisioned(&TEST_KEY);
    blank.area = [0; sdls::nv::SECURITY_AREA_BYTES];
    refused_with_no_key(&mut std::vec![0u8; 60 * 1024], Some(&mut blank));
    refused_with_no_key(&mut std::vec![0u8; 60 * 1024], None);
}

#[test]
fn an_uplink_whose_counter_cannot_be_stored_is_refused_and_not_loaded() {
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    security.fail_writes = true;
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    let mut app = std::boxed::Box::new(FlightApp::new());
    app.boot(&mut mem, &mut NoClock, &mut |_| {});
    let out = send_uplink(&mut app, &mut mem, &signed_flyby(&TEST_KEY, 1));
    assert_eq!(nak_reason(&out), Some(SecurityRefusal::CounterNotStored));
    assert!(app.executive().executive().network().tasks().is_empty());
    assert_eq!(app.security().last_sequence(), 0);
}

#[test]
fn the_counter_survives_a_warm_reset_and_a_power_cycle_so_the_last_uplink_cannot_be_replayed() {
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    let _ = flying(&mut mem);
    let last = signed_flyby(&TEST_KEY, 1);
    // Warm reset: RAM is a fresh application, the warm area and the NV stay.
    let mut app = std::boxed::Box::new(FlightApp::new());
    assert!(matches!(
        app.boot(&mut mem, &mut NoClock, &mut |_| {}),
        BootOutcome::RestoredWarm(_)
    ));
    let before = state_image(&app);
    let out = send_uplink(&mut app, &mut mem, &last);
    assert_eq!(nak_reason(&out), Some(SecurityRefusal::Replay));
    assert_eq!(state_image(&app), before);
    // Power cycle: the warm area is gone too (no plan to restore), the NV stays.
    mem.warm.fill(0);
    let mut app = std::boxed::Box::new(FlightApp::new());
    assert_eq!(
        app.boot(&mut mem, &mut NoClock, &mut |_| {}),
        BootOutcome::Cold
    );
    let out = send_uplink(&mut app, &mut mem, &last);
    assert_eq!(nak_reason(&out), Some(SecurityRefusal::Replay));
    assert!(app.executive().executive().network().tasks().is_empty());
    let out = send_uplink(&mut app, &mut mem, &signed_flyby(&TEST_KEY, 2));
    assert!(matches!(
        verdict(&out),
        Some(TargetToHost::UplinkAck { .. })
    ));
}

fn command(key: &sdls::Key, sequence: u32, command: GroundCommand) -> HostToTarget {
    let header = SecurityHeader {
        spi: key.spi,
        sequence,
    };
    HostToTarget::GroundCommand {
        header,
        command,
        mac: heapless::Vec::from_slice(&sdls::command_mac(key, &header, &command)).unwrap(),
    }
}

fn send(app: &mut FlightApp, mem: &mut Memories<'_>, msg: &HostToTarget) -> Vec<TargetToHost> {
    let mut out = Vec::new();
    app.handle(msg, mem, &mut NoClock, &mut |m| out.push(m));
    out
}

fn security_nak(reason: SecurityRefusal, sequence: u32) -> TargetToHost {
    TargetToHost::GroundCommandNak {
        sequence,
        reason: CommandRefusal::Security(reason),
    }
}

#[test]
fn ground_commands_are_acknowledged_or_refused_with_their_reason_and_holds_survive_resets() {
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    let mut app = flying(&mut mem);
    let before = state_image(&app);
    let out = send(
        &mut app,
        &mut mem,
        &command(&TEST_KEY, 2, GroundCommand::NoOp),
    );
    assert_eq!(out, [TargetToHost::GroundCommandAck { sequence: 2 }]);
    let out = send(
        &mut app,
        &mut mem,
        &command(&TEST_KEY, 5, GroundCommand::SetHold(3)),
    );
    assert_eq!(
        out,
        [
            metric_event(metric::GROUND_HOLDS, 1 << 3),
            TargetToHost::GroundCommandAck { sequence: 5 }
        ]
    );
    // Refusals: each with its reason and count, holds and counter unchanged.
    let mut forged = command(&TEST_KEY, 6, GroundCommand::SetHold(4));
    if let HostToTarget::GroundCommand { mac, .. } = &mut forged {
        mac[0] ^= 0x80;
    }
    let mut truncated = command(&TEST_KEY, 6, GroundCommand::ReleaseHold(3));
    if let HostToTarget::GroundCommand { mac, .. } = &mut truncated {
        mac.truncate(MAC_LEN - 4);
    }
    let wrong_key = sdls::Key {
        spi: TEST_KEY.spi,
        bytes: [0x33; 32],
    };
    let unknown_key = sdls::Key {
        spi: 2,
        bytes: TEST_KEY.bytes,
    };
    let cases = [
        (forged, SecurityRefusal::BadMac, 6),
        (truncated, SecurityRefusal::Truncated, 6),
        (
            command(&wrong_key, 6, GroundCommand::ReleaseHold(3)),
            SecurityRefusal::BadMac,
            6,
        ),
        (
            command(&unknown_key, 6, GroundCommand::ReleaseHold(3)),
            SecurityRefusal::UnknownKey,
            6,
        ),
        (
            command(&TEST_KEY, 5, GroundCommand::SetHold(3)),
            SecurityRefusal::Replay,
            5,
        ),
        (
            command(&TEST_KEY, 4, GroundCommand::ReleaseHold(3)),
            SecurityRefusal::Replay,
            4,
        ),
    ];
    for (msg, reason, sequence) in &cases {
        let out = send(&mut app, &mut mem, msg);
        assert_eq!(
            out.last(),
            Some(&security_nak(*reason, *sequence)),
            "{msg:?}"
        );
        assert_eq!(refusal_metrics(&out).len(), 1);
        assert_eq!(refusal_metrics(&out)[0].0, *reason);
        assert_eq!(app.security().holds(), 1 << 3);
        assert_eq!(app.security().last_sequence(), 5);
    }
    assert_eq!(app.security_refusals(SecurityRefusal::BadMac), 2);
    assert_eq!(app.security_refusals(SecurityRefusal::Replay), 2);
    // Authentic but out of range: refused, its number spent, nothing else changed.
    let out = send(
        &mut app,
        &mut mem,
        &command(&TEST_KEY, 7, GroundCommand::SetHold(40)),
    );
    assert_eq!(
        out.last(),
        Some(&TargetToHost::GroundCommandNak {
            sequence: 7,
            reason: CommandRefusal::HoldOutOfRange
        })
    );
    assert_eq!(app.security().last_sequence(), 7);
    assert_eq!(app.security().holds(), 1 << 3);
    // None of it touched the plan.
    assert_eq!(state_image(&app), before);

    // Warm reset and power cycle: the hold and the counter come back from NV.
    for power_cycle in [false, true] {
        if power_cycle {
            mem.warm.fill(0);
        }
        let mut app = std::boxed::Box::new(FlightApp::new());
        let mut out = Vec::new();
        app.boot(&mut mem, &mut NoClock, &mut |m| out.push(m));
        assert_eq!(
            out.first(),
            Some(&metric_event(metric::GROUND_HOLDS, 1 << 3))
        );
        assert_eq!(app.security().holds(), 1 << 3);
        let out = send(
            &mut app,
            &mut mem,
            &command(&TEST_KEY, 5, GroundCommand::ReleaseHold(3)),
        );
        assert_eq!(out.last(), Some(&security_nak(SecurityRefusal::Replay, 5)));
    }
    let mut app = std::boxed::Box::new(FlightApp::new());
    app.boot(&mut mem, &mut NoClock, &mut |_| {});
    let out = send(
        &mut app,
        &mut mem,
        &command(&TEST_KEY, 8, GroundCommand::ReleaseHold(3)),
    );
    assert_eq!(
        out,
        [
            metric_event(metric::GROUND_HOLDS, 0),
            TargetToHost::GroundCommandAck { sequence: 8 }
        ]
    );
}

#[test]
fn an_uplink_signature_is_not_a_command_signature() {
    // The same key, header and bytes under the other service: never accepted.
    let mut warm = std::vec![0u8; 60 * 1024];
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: None,
        security: Some(&mut security),
    };
    let mut app = std::boxed::Box::new(FlightApp::new());
    app.boot(&mut mem, &mut NoClock, &mut |_| {});
    let header = SecurityHeader {
        spi: TEST_KEY.spi,
        sequence: 3,
    };
    let (bytes, len) = sdls::command_bytes(&GroundCommand::NoOp);
    let uplink_tag = sdls::mac::tag(
        &TEST_KEY.bytes,
        &[
            &[sdls::Service::Uplink as u8],
            &sdls::mac::header_bytes(&header),
            &bytes[..len],
        ],
    );
    let msg = HostToTarget::GroundCommand {
        header,
        command: GroundCommand::NoOp,
        mac: heapless::Vec::from_slice(&uplink_tag).unwrap(),
    };
    let out = send(&mut app, &mut mem, &msg);
    assert_eq!(out.last(), Some(&security_nak(SecurityRefusal::BadMac, 3)));
}

/// The real memories behind a target's copies (as the firmware's are behind the kernel):
/// serves the application's reads and logs them.
struct Backing {
    warm: Vec<u8>,
    nv: Vec<u8>,
    reads: Reads,
}

impl MemoryFetch for Backing {
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError> {
        self.reads.push((memory, offset, bytes.len()));
        let source = match memory {
            MemoryKind::Warm => &self.warm,
            MemoryKind::Nv => &self.nv,
        };
        bytes.copy_from_slice(source.get(offset..offset + bytes.len()).ok_or(StoreError)?);
        Ok(())
    }
}

const AREA: usize = 60 * 1024;

/// Reads logged by [`Backing`]: (memory, offset, length).
type Reads = Vec<(MemoryKind, usize, usize)>;

/// The executive's shares of warm and non-volatile memory (`AREA` bytes each) after the
/// flyby uplink and `frames` granted frames, and the security area.
fn flown(frames: u32) -> (Vec<u8>, Vec<u8>, TestNv) {
    let mut app = std::boxed::Box::new(FlightApp::new());
    let (mut warm, mut nv) = (std::vec![0u8; 2 * AREA], std::vec![0u8; 2 * AREA]);
    let mut security = TestNv::provisioned(&TEST_KEY);
    let mut mem = Memories {
        warm: &mut warm,
        nv: Some(&mut nv),
        security: Some(&mut security),
    };
    boot_and_uplink_flyby(&mut app, &mut mem);
    for frame in 0..frames {
        let at = 9 * 3600 + 600 * u64::from(frame);
        app.handle(&grant(frame, at), &mut mem, &mut NoClock, &mut |_| {});
    }
    assert_eq!(executive_share(2 * AREA), AREA);
    warm.truncate(AREA);
    nv.truncate(AREA);
    (warm, nv, security)
}

/// Byte `at` of slot `slot`'s payload flipped (the record no longer whole).
fn torn(mut area: Vec<u8>, slot: usize, at: usize) -> Vec<u8> {
    area[slot * (AREA / 2) + autonomy::checkpoint::RECORD_HEADER_LEN + at] ^= 0x40;
    area
}

/// The slot of the newest whole record of an area.
fn newest_slot(area: &mut [u8]) -> usize {
    usize::from(WarmRestartArea::new(area).latest().unwrap().0)
}

/// Boot the executive's application and run the first window of a frame twice: with
/// complete copies of the memories (`boot`, `handle`), and with empty copies filled on
/// demand from `Backing` (`boot_fetching`, `handle_fetching`, each checkpoint's bytes
/// copied out as the firmware does). Both must decide the same, say the same, and leave
/// the memories byte for byte the same. Returns the outcome and the reads of the fetching
/// boot (before the frame) and of the frame.
fn boot_both_ways(warm: &[u8], nv: &[u8], security: &TestNv) -> (BootOutcome, Reads, Reads) {
    let frame = grant(40, 10 * 3600);
    // Complete copies.
    let (mut full_warm, mut full_nv) = (warm.to_vec(), nv.to_vec());
    let mut full_security = security.clone();
    let mut full_app = std::boxed::Box::new(ExecutiveApp::new());
    let mut full_out: Vec<TargetToHost> = Vec::new();
    let mut mem = Memories {
        warm: &mut full_warm,
        nv: Some(&mut full_nv),
        security: Some(&mut full_security),
    };
    let full_outcome = full_app.boot(&mut mem, &mut NoClock, &mut |m| full_out.push(m));
    full_app.handle(&frame, &mut mem, &mut NoClock, &mut |m| full_out.push(m));
    // Copies filled on demand.
    let mut backing = Backing {
        warm: warm.to_vec(),
        nv: nv.to_vec(),
        reads: Vec::new(),
    };
    let (mut copy_warm, mut copy_nv) = (std::vec![0u8; AREA], std::vec![0u8; AREA]);
    let mut copy_security = security.clone();
    let mut app = std::boxed::Box::new(ExecutiveApp::new());
    let mut out: Vec<TargetToHost> = Vec::new();
    let mut mem = Memories {
        warm: &mut copy_warm,
        nv: Some(&mut copy_nv),
        security: Some(&mut copy_security),
    };
    let outcome = app.boot_fetching(&mut mem, Some(&mut backing), &mut NoClock, &mut |m| {
        out.push(m)
    });
    let boot_reads = core::mem::take(&mut backing.reads);
    app.handle_fetching(
        &frame,
        &mut mem,
        Some(&mut backing),
        &mut NoClock,
        &mut |m| out.push(m),
    );
    for (start, end) in app.take_warm_writes() {
        backing.warm[start..end].copy_from_slice(&mem.warm[start..end]);
    }
    for (start, end) in app.take_nv_writes() {
        let nv = mem.nv.as_deref().unwrap();
        backing.nv[start..end].copy_from_slice(&nv[start..end]);
    }
    assert_eq!(outcome, full_outcome);
    assert_eq!(out, full_out);
    if backing.warm != full_warm {
        let diff: Vec<usize> = (0..full_warm.len())
            .filter(|&i| backing.warm[i] != full_warm[i])
            .collect();
        panic!(
            "warm memories differ at {} bytes, first {:?} last {:?}",
            diff.len(),
            diff.first(),
            diff.last()
        );
    }
    assert!(backing.nv == full_nv, "non-volatile memories differ");
    (outcome, boot_reads, backing.reads)
}

fn payload_reads(reads: &Reads, memory: MemoryKind) -> usize {
    reads
        .iter()
        .filter(|&&(m, _, len)| m == memory && len != autonomy::checkpoint::RECORD_HEADER_LEN)
        .count()
}

#[test]
fn a_boot_that_reads_what_it_needs_decides_and_writes_as_one_given_both_whole_memories() {
    let (warm, nv, security) = flown(3);
    let (mut later_warm, later_nv, _) = flown(4);

    // Both memories as written (the same sequence numbers): the warm area's newest record
    // and the headers; non-volatile memory's records only before its first write.
    let (outcome, boot, frame) = boot_both_ways(&warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(_)));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 1);
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);
    assert_eq!(boot.len(), 5, "four headers and one record: {boot:?}");
    assert_eq!(payload_reads(&frame, MemoryKind::Nv), 1);

    // The warm area's newest record torn: its other record, as new as non-volatile
    // memory's newest (sequence numbers equal): the warm one, from the other slot.
    let slot = newest_slot(&mut later_warm.clone());
    let (outcome, boot, _) = boot_both_ways(&torn(later_warm.clone(), slot, 7), &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if usize::from(info.slot) != slot));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);

    // Torn, and non-volatile memory a frame newer: non-volatile memory's.
    let (outcome, _, _) = boot_both_ways(&torn(later_warm.clone(), slot, 7), &later_nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(_)));

    // Non-volatile memory newer than the warm area (a reset after its write only).
    let (outcome, boot, _) = boot_both_ways(&warm, &later_nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(_)));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);

    // ... with its newest record torn: its other one (the checkpoint of the same frame's
    // first window) is still newer than the warm area's: non-volatile memory's other
    // slot, and the warm area's records are read only before its first write.
    let nv_slot = newest_slot(&mut later_nv.clone());
    let (outcome, boot, frame) =
        boot_both_ways(&warm, &torn(later_nv.clone(), nv_slot, 3), &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(info) if usize::from(info.slot) != nv_slot));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 2);
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 0);
    assert_eq!(payload_reads(&frame, MemoryKind::Warm), 1);

    // A power cycle: the warm area is gone.
    let (outcome, _, _) = boot_both_ways(&std::vec![0u8; AREA], &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(_)));

    // Nothing anywhere: cold, and the first frame writes the first records.
    let blank = std::vec![0u8; AREA];
    let (outcome, _, _) = boot_both_ways(&blank, &blank, &security);
    assert_eq!(outcome, BootOutcome::Cold);

    // The warm area's newest record whole but not a plan (a firmware whose layout changed
    // without a new format version): the next newest whole record of either memory, here
    // the warm area's other one (a frame newer than non-volatile memory's; the uplink's
    // checkpoint is number 1, and each frame writes two, one per executive window).
    let not_a_plan = |buf: &mut [u8]| {
        buf[..4].copy_from_slice(&[0xff; 4]);
        Some(4)
    };
    WarmRestartArea::new(&mut later_warm)
        .write(not_a_plan)
        .unwrap();
    let (outcome, boot, _) = boot_both_ways(&later_warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if info.sequence == 9));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);

    // Neither of the warm area's records a plan: non-volatile memory's newest, whose
    // records the choice had not needed until then.
    WarmRestartArea::new(&mut later_warm)
        .write(not_a_plan)
        .unwrap();
    let (outcome, boot, _) = boot_both_ways(&later_warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(info) if info.sequence == 7));
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 2);
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);
}

/// An area holding one record, numbered `sequence`, of `payload`.
fn area_with(sequence: u32, payload: &[u8]) -> Vec<u8> {
    let mut area = std::vec![0u8; AREA];
    WarmRestartArea::new(&mut area)
        .write_after(Some(sequence.wrapping_sub(1)), |buf| {
            buf[..payload.len()].copy_from_slice(payload);
            Some(payload.len())
        })
        .unwrap();
    area
}

#[test]
fn a_boot_that_reads_what_it_needs_compares_sequence_numbers_across_the_wrap() {
    let (mut older, _, security) = flown(3);
    let (mut newer, _, _) = flown(4);
    let older = WarmRestartArea::new(&mut older)
        .latest()
        .unwrap()
        .2
        .to_vec();
    let newer = WarmRestartArea::new(&mut newer)
        .latest()
        .unwrap()
        .2
        .to_vec();
    let newest = |area: &mut [u8]| WarmRestartArea::new(area).latest().map(|r| r.1);

    // Non-volatile memory's checkpoint numbered 0, after the warm area's u32::MAX: newer,
    // tried first, and the only payload read at boot; the warm area's is read before its
    // first write, and both memories go on at 1.
    let (warm, nv) = (area_with(u32::MAX, &older), area_with(0, &newer));
    let (outcome, boot, frame) = boot_both_ways(&warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredNv(info) if info.sequence == 0));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 1);
    assert_eq!(payload_reads(&boot, MemoryKind::Warm), 0);
    assert_eq!(payload_reads(&frame, MemoryKind::Warm), 1);
    let mut full_warm = warm.clone();
    let mut full_nv = nv.clone();
    let mut app = std::boxed::Box::new(ExecutiveApp::new());
    let mut security_copy = security.clone();
    let mut mem = Memories {
        warm: &mut full_warm,
        nv: Some(&mut full_nv),
        security: Some(&mut security_copy),
    };
    app.boot(&mut mem, &mut NoClock, &mut |_| {});
    app.handle(&grant(40, 10 * 3600), &mut mem, &mut NoClock, &mut |_| {});
    assert_eq!(newest(&mut full_warm), Some(1));
    assert_eq!(newest(&mut full_nv), Some(1));

    // The other way round: the warm area's, without reading non-volatile memory's.
    let (warm, nv) = (area_with(0, &newer), area_with(u32::MAX, &older));
    let (outcome, boot, _) = boot_both_ways(&warm, &nv, &security);
    assert!(matches!(outcome, BootOutcome::RestoredWarm(info) if info.sequence == 0));
    assert_eq!(payload_reads(&boot, MemoryKind::Nv), 0);
}
