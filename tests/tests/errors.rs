//! Errors a user can act on: a missing QEMU, a target that is silent, a target that speaks
//! another protocol version or runs another build, a bad scenario file.
use std::io::Write;
use std::path::Path;
use std::time::Duration;

use fsw_bridge::codec::{encode, MAX_FRAME_LEN};
use fsw_bridge::{ResetCause, TargetToHost, PROTOCOL_VERSION};
use hil::qemu::{LaunchOptions, Qemu, QemuError};
use hil::session::{Session, SessionError};
use hil_tests::{firmware, profile, pty_pair};

/// `msg` as a protocol v2 target sends it outside the rounds (an expedited frame).
fn frame(msg: &TargetToHost) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(&fsw_bridge::link::LinkFrame::Bd(msg), &mut buf).unwrap();
    buf[..n].to_vec()
}

/// `msg` as a protocol v1 target sent it (a bare message in the frame).
fn v1_frame(msg: &TargetToHost) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn hello(protocol_version: u16, build_id: [u8; 8]) -> TargetToHost {
    TargetToHost::Hello {
        protocol_version,
        build_id,
        reset_cause: ResetCause::PowerOn,
        boot_count: 1,
        kernel_fault: None,
    }
}

#[test]
fn a_missing_qemu_says_how_to_install_it() {
    let mut p = profile();
    p.binary = "qemu-system-ppc-not-installed-here".into();
    let err = Qemu::launch(&p, &firmware().elf, &LaunchOptions::default())
        .err()
        .expect("launch must fail");
    assert!(matches!(err, QemuError::Missing(_)), "{err:?}");
    let text = err.to_string();
    assert!(
        text.contains(
            "`qemu-system-ppc-not-installed-here` (the binary of QEMU profile rad750-proxy)"
        ),
        "{text}"
    );
    // Where it was looked for: every directory on PATH.
    let path = std::env::var_os("PATH").unwrap();
    let first = std::env::split_paths(&path).next().unwrap();
    assert!(
        text.contains(&format!("searched: {}", first.display())),
        "{text}"
    );
    assert!(
        text.contains("apt-get install -y qemu-system-ppc"),
        "{text}"
    );
    assert!(text.contains("HIL_QEMU"), "{text}");
}

#[test]
fn a_target_speaking_another_protocol_version_is_refused_by_name() {
    let mut pty = pty_pair();
    let mut session = Session::open_serial(&pty.slave_path, 115_200, None).unwrap();
    pty.master
        .write_all(&frame(&hello(PROTOCOL_VERSION + 1, [0; 8])))
        .unwrap();
    let err = session.expect_hello(Duration::from_secs(10)).unwrap_err();
    assert!(
        matches!(err, SessionError::ProtocolMismatch { target, host }
            if target == PROTOCOL_VERSION + 1 && host == PROTOCOL_VERSION),
        "{err:?}"
    );
    assert!(err.to_string().contains("protocol mismatch"), "{err}");
}

/// A target from before the reliable link frames its Hello without the link's envelope: it is
/// still recognised, and refused by name rather than as garbage.
#[test]
fn a_protocol_v1_target_is_refused_by_name() {
    let mut pty = pty_pair();
    let mut session = Session::open_serial(&pty.slave_path, 115_200, None).unwrap();
    pty.master.write_all(&v1_frame(&hello(1, [0; 8]))).unwrap();
    let err = session.expect_hello(Duration::from_secs(10)).unwrap_err();
    assert!(
        matches!(err, SessionError::ProtocolMismatch { target: 1, host } if host == PROTOCOL_VERSION),
        "{err:?}"
    );
}

#[test]
fn a_target_running_another_build_is_refused_with_both_build_ids() {
    let mut pty = pty_pair();
    let fw = firmware();
    let mut session = Session::open_serial(&pty.slave_path, 115_200, Some(fw)).unwrap();
    let mut other = fw.build_id;
    other[0] ^= 0xff;
    pty.master
        .write_all(&frame(&hello(PROTOCOL_VERSION, other)))
        .unwrap();
    let err = session.expect_hello(Duration::from_secs(10)).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, SessionError::BuildMismatch { .. }), "{err:?}");
    assert!(
        text.contains(&hil::firmware::build_id_hex(&fw.build_id)),
        "{text}"
    );
    assert!(
        text.contains(&hil::firmware::build_id_hex(&other)),
        "{text}"
    );
}

#[test]
fn a_silent_target_reports_what_was_received() {
    let mut pty = pty_pair();
    let mut session = Session::open_serial(&pty.slave_path, 115_200, None).unwrap();
    // Noise, but no frame.
    pty.master.write_all(b"\x00garbage\x00").unwrap();
    let err = session
        .expect_hello(Duration::from_millis(800))
        .unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, SessionError::Silent { .. }), "{err:?}");
    assert!(text.contains("9 bytes received"), "{text}");
    assert!(text.contains("1 rejected"), "{text}");
    assert!(text.contains(&pty.slave_path), "{text}");
}

#[test]
fn bad_scenario_files_name_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        "name = \"bad\"\n\n[[steps]]\nexpect_hello = { reset_cause = \"lukewarm\" }\n",
    )
    .unwrap();
    let err = hil::scenario::load(&path).unwrap_err().to_string();
    assert!(err.starts_with(&format!("{}:4:", path.display())), "{err}");
    assert!(err.contains("lukewarm"), "{err}");

    let missing = hil::scenario::load(Path::new("/nonexistent/scenario.toml"))
        .unwrap_err()
        .to_string();
    assert!(missing.contains("/nonexistent/scenario.toml"), "{missing}");
}

#[test]
fn the_shipped_smoke_scenario_passes() {
    let _one = hil_tests::exclusive_qemu();
    let path = hil::repo_root().join("scenarios/smoke.toml");
    let scenario = hil::scenario::load(&path).unwrap();
    let options = hil::run::RunOptions {
        firmware: Some(firmware().elf.clone()),
        ..Default::default()
    };
    let report = hil::run::run_scenario(&scenario, &options, &mut |_| {}).unwrap();
    assert!(report.passed, "{}", hil::run::summary(&report));
    assert_eq!(report.steps.len(), 9);
    assert!(report
        .logs
        .iter()
        .any(|l| l.message.contains("reset cause warm, boot 3")));
}
