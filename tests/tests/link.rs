//! The foundation under qemu-system-ppc: handshake, pings, defmt logs, warm resets with the
//! right reset cause, corrupted frames counted by the target while the link keeps working. The
//! link tests run over both transports: the serial line a real board uses, and the emulated
//! target's shared-memory link.
use std::time::Duration;

use fsw_bridge::{HostToTarget, ResetCause, TargetToHost, PROTOCOL_VERSION};
use hil::link::corrupted_frame;
use hil_tests::{boot, boot_over, firmware, PATIENCE, TRANSPORTS};

#[test]
fn handshake_reports_power_on_and_the_build_that_was_booted() {
    let mut target = boot();
    let hello = target.expect_hello(PATIENCE).expect("Hello");
    assert_eq!(hello.reset_cause, ResetCause::PowerOn);
    assert_eq!(hello.boot_count, 1);
    assert_eq!(hello.build_id, firmware().build_id);
}

#[test]
fn pings_come_back_with_their_sequence_numbers() {
    for transport in TRANSPORTS {
        pings_come_back_over(transport);
    }
}

fn pings_come_back_over(transport: hil::qemu::Transport) {
    let mut target = boot_over(transport);
    target.expect_hello(PATIENCE).unwrap();
    for seq in [0u32, 1, 2, 77, 1_000_000, u32::MAX] {
        target.link.send(&HostToTarget::Ping { seq }).unwrap();
        // The target volunteers telemetry (after a boot: its boot-to-ready cost); anything
        // else before the Pong is wrong.
        let reply = loop {
            match target.recv(PATIENCE).unwrap() {
                TargetToHost::Telemetry(_) => continue,
                other => break other,
            }
        };
        match reply {
            TargetToHost::Pong { seq: got, link } => {
                assert_eq!(got, seq, "{transport:?}");
                assert_eq!(link.errors(), 0, "no frame was corrupted: {link:?}");
            }
            other => panic!("{transport:?}: expected Pong {seq}, got {other:?}"),
        }
    }
}

#[test]
fn the_boot_log_line_is_decoded_from_defmt_with_a_timestamp() {
    let mut target = boot();
    target.expect_hello(PATIENCE).unwrap();
    // The boot log travels on the reliable link's Instrument channel, in lockstep rounds.
    target.sync(64, PATIENCE).unwrap();
    let line = target
        .logs
        .iter()
        .find(|l| l.message.starts_with("boot:"))
        .unwrap_or_else(|| panic!("no boot line in {:?}", target.logs));
    assert_eq!(
        line.message,
        format!("boot: reset cause power-on, boot 1, protocol v{PROTOCOL_VERSION}")
    );
    assert_eq!(line.level, "INFO");
    assert!(
        line.timestamp.parse::<f64>().is_ok(),
        "timestamp {:?}",
        line.timestamp
    );
    assert!(
        line.location
            .as_deref()
            .unwrap_or("")
            .starts_with("src/main.rs:"),
        "{line:?}"
    );
}

#[test]
fn qmp_system_reset_restarts_the_target_with_reset_cause_warm() {
    for transport in TRANSPORTS {
        qmp_system_reset_over(transport);
    }
}

fn qmp_system_reset_over(transport: hil::qemu::Transport) {
    let mut target = boot_over(transport);
    target.expect_hello(PATIENCE).unwrap();
    target.ping(1, PATIENCE).unwrap();
    target.warm_reset_qmp().unwrap();
    let hello = target.expect_hello(PATIENCE).expect("second Hello");
    assert_eq!(hello.reset_cause, ResetCause::Warm);
    assert_eq!(
        hello.boot_count, 2,
        "the warm-restart area survived the reset"
    );
    target
        .ping(2, PATIENCE)
        .expect("link works after the reset");
    target.warm_reset_qmp().unwrap();
    let hello = target.expect_hello(PATIENCE).expect("third Hello");
    assert_eq!((hello.reset_cause, hello.boot_count), (ResetCause::Warm, 3));
}

#[test]
fn a_reset_request_on_the_link_restarts_the_target_warm() {
    for transport in TRANSPORTS {
        let mut target = boot_over(transport);
        reset_request(&mut target);
    }
}

fn reset_request(target: &mut hil::session::Session) {
    target.expect_hello(PATIENCE).unwrap();
    target.request_reset().unwrap();
    let hello = target
        .expect_hello(PATIENCE)
        .expect("Hello after ResetRequest");
    assert_eq!(hello.reset_cause, ResetCause::Warm);
    assert_eq!(hello.boot_count, 2);
}

#[test]
fn corrupted_frames_are_counted_as_crc_errors_and_the_link_keeps_working() {
    for transport in TRANSPORTS {
        let mut target = boot_over(transport);
        corrupted_frames(&mut target);
    }
}

fn corrupted_frames(target: &mut hil::session::Session) {
    target.expect_hello(PATIENCE).unwrap();
    let (_, before) = target.ping(1, PATIENCE).unwrap();
    assert_eq!(before.crc_errors, 0);
    let corrupted = 25u32;
    for i in 0..corrupted {
        let frame = corrupted_frame(&HostToTarget::Ping { seq: 500 + i }, i as usize * 5);
        target.link.send_raw(&frame).unwrap();
    }
    // A corrupted ping must never be answered.
    let (_, after) = target.ping(2, PATIENCE).unwrap();
    assert_eq!(after.crc_errors, corrupted, "{after:?}");
    assert_eq!(after.frames_ok, before.frames_ok + 1);
    assert!(
        !target
            .unsolicited
            .iter()
            .any(|m| matches!(m, TargetToHost::Pong { seq, .. } if *seq >= 500)),
        "a corrupted ping was answered: {:?}",
        target.unsolicited
    );
    // Garbage between frames loses nothing either.
    target.link.send_raw(&[0x13, 0x37, 0xff, 0x42]).unwrap();
    let (_, last) = target.ping(3, PATIENCE).unwrap();
    assert_eq!(last.frames_ok, after.frames_ok + 1);
}

#[test]
fn the_qemu_process_is_ended_when_the_session_is_dropped() {
    let target = boot();
    let pid = target.qemu.as_ref().unwrap().pid();
    assert!(std::path::Path::new(&format!("/proc/{pid}")).exists());
    drop(target);
    std::thread::sleep(Duration::from_millis(50));
    assert!(
        !std::path::Path::new(&format!("/proc/{pid}")).exists(),
        "QEMU pid {pid} outlived its session"
    );
}

#[test]
fn corrupt_frames_at_its_documented_maximum_passes() {
    let _one = hil_tests::exclusive_qemu();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("corrupt-max.toml");
    let max = hil::scenario::MAX_CORRUPT_PER_STEP;
    std::fs::write(
        &path,
        format!(
            "name = \"corrupt-max\"\n[[steps]]\nexpect_hello = {{ reset_cause = \"power-on\" }}\n\
             [[steps]]\ncorrupt_frames = {{ count = {max} }}\n"
        ),
    )
    .unwrap();
    let scenario = hil::scenario::load(&path).unwrap();
    let options = hil::options::RunOptions {
        firmware: Some(firmware().elf.clone()),
        ..Default::default()
    };
    let report = hil::run::run_scenario(&scenario, &options, &mut |_| {}).unwrap();
    assert!(report.passed, "{}", hil::run::summary(&report));
    assert!(
        report.steps[1].detail.contains(&format!(
            "target counted {max} CRC errors and still answers"
        )),
        "{}",
        report.steps[1].detail
    );
}
