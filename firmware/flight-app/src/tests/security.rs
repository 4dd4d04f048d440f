//! Uplink and ground-command security: chunk order, forged, replayed and wrongly keyed uplinks,
//! missing keys or memories, the stored counter across resets, commands and holds.

use super::*;

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
