//! Authenticated uplinks and ground commands on the emulated RAD750 proxy, driven message by
//! message over the target's serial link (`hil::session`, the link the firmware's I/O partition
//! speaks): the key provisioned into the `ivshmem-plain` file before QEMU starts, the executive
//! partition verifying with `sdls` and writing the anti-replay counter through `SYS_NV_WRITE`
//! before anything takes effect. Forged, wrong-key, unknown-key, truncated and replayed uplinks
//! and commands are refused with their reasons and counted; the replays stay refused after a
//! QMP warm reset and after a power cycle (a new QEMU process on the same file); the
//! verification's cost is measured in guest instructions. The mission-level version (the whole
//! flyby with these attacks, compared with the native target) is in `missions_qemu.rs`.
use std::path::Path;
use std::time::{Duration, Instant};

use flight_app::metric;
use fsw_bridge::{
    CommandRefusal, GroundCommand, HostToTarget, ResetCause, SecurityRefusal, TargetToHost,
    TelemetryEvent,
};
use hil::mission::auth::{authenticated_command, provision_nv_file, Attack, Signer, TEST_KEY};
use hil::mission::record::to_instructions;
use hil::mission::target::native::NV_BYTES;
use hil::qemu::LaunchOptions;
use hil::session::Session;
use hil_tests::{exclusive_qemu, firmware, profile};

/// Liveness bound (wall time); only a hang reaches it.
const PATIENCE: Duration = Duration::from_secs(120);
/// Bytes per uplink chunk, as `hil` sends them.
const CHUNK: usize = hil::mission::driver::UPLINK_CHUNK_BYTES;

fn boot(nv: &Path, cause: ResetCause) -> Session {
    let options = LaunchOptions {
        realtime: false,
        nv_file: Some(nv.to_path_buf()),
        nv_size: Some(NV_BYTES as u64),
    };
    let mut target = Session::boot_qemu(&profile(), firmware(), &options)
        .unwrap_or_else(|e| panic!("cannot boot: {e}"));
    let hello = target.expect_hello(PATIENCE).unwrap();
    assert_eq!(hello.reset_cause, cause);
    target
}

/// Receive until `done` holds for a message; every message received, in order.
fn until(
    target: &mut Session,
    what: &str,
    done: impl Fn(&TargetToHost) -> bool,
) -> Vec<TargetToHost> {
    let deadline = Instant::now() + PATIENCE;
    let mut got = Vec::new();
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "no {what} within {PATIENCE:?}: {got:?}");
        let msg = target
            .recv(left)
            .unwrap_or_else(|e| panic!("waiting for {what}: {e}"));
        let last = done(&msg);
        got.push(msg);
        if last {
            return got;
        }
    }
}

/// Send a secured uplink in chunks; everything up to the verdict on the whole of it.
fn uplink(target: &mut Session, secured: &[u8]) -> Vec<TargetToHost> {
    let chunks: Vec<&[u8]> = secured.chunks(CHUNK).collect();
    let total = chunks.len() as u16;
    let mut got = Vec::new();
    for (seq, chunk) in chunks.iter().enumerate() {
        target
            .link
            .send(&HostToTarget::UplinkChunk {
                seq: seq as u16,
                total,
                bytes: heapless::Vec::from_slice(chunk).unwrap(),
            })
            .unwrap();
        // One chunk at a time: the executive takes a chunk per batch.
        got.extend(until(target, "an uplink chunk's answer", |m| {
            matches!(m, TargetToHost::UplinkNak { .. })
                || matches!(m, TargetToHost::UplinkAck { seq: s } if usize::from(*s) == seq)
        }));
        if matches!(got.last(), Some(TargetToHost::UplinkNak { .. })) {
            return got;
        }
    }
    got.extend(until(target, "the uplink's verdict", |m| {
        matches!(m, TargetToHost::UplinkNak { .. })
            || matches!(m, TargetToHost::UplinkAck { seq } if *seq == total)
    }));
    // Its costs and counters travel on the link's Instrument channel, beside the verdict.
    target.sync(64, PATIENCE).unwrap();
    let verdict = got.pop();
    got.extend(target.take_delivered());
    got.extend(verdict);
    got
}

fn verdict(got: &[TargetToHost]) -> Result<(), SecurityRefusal> {
    match got.last() {
        Some(TargetToHost::UplinkAck { .. }) => Ok(()),
        Some(TargetToHost::UplinkNak { reason, .. }) => Err(SecurityRefusal::from_code(*reason)
            .unwrap_or_else(|| {
                panic!("refused for a reason that is not a security refusal: {reason:#06x}")
            })),
        other => panic!("no verdict: {other:?}"),
    }
}

fn command(target: &mut Session, msg: &HostToTarget) -> Result<(), CommandRefusal> {
    let HostToTarget::GroundCommand { header, .. } = msg else {
        unreachable!()
    };
    let sequence = header.sequence;
    target.link.send(msg).unwrap();
    let got = until(target, "a ground command's answer", |m| {
        matches!(m, TargetToHost::GroundCommandAck { sequence: s }
            | TargetToHost::GroundCommandNak { sequence: s, .. } if *s == sequence)
    });
    match got.last() {
        Some(TargetToHost::GroundCommandAck { .. }) => Ok(()),
        Some(TargetToHost::GroundCommandNak { reason, .. }) => Err(*reason),
        _ => unreachable!(),
    }
}

fn metrics(got: &[TargetToHost], id: u16) -> Vec<u64> {
    got.iter()
        .filter_map(|m| match m {
            TargetToHost::Telemetry(TelemetryEvent::Metric { id: i, value }) if *i == id => {
                Some(*value)
            }
            _ => None,
        })
        .collect()
}

#[test]
fn the_executive_refuses_bad_uplinks_and_commands_and_its_counter_survives_resets() {
    let _one = exclusive_qemu();
    let dir = tempfile::tempdir().unwrap();
    let nv = dir.path().join("nv.bin");
    provision_nv_file(&nv, &TEST_KEY, NV_BYTES as u64).unwrap();
    let image = hil::tasknet::compile_file(&hil::repo_root().join("scenarios/tasknets/flyby.toml"))
        .unwrap()
        .uplink;
    let mut signer = Signer::new(TEST_KEY);

    let mut target = boot(&nv, ResetCause::PowerOn);
    let (_, accepted) = signer.sign_uplink(&image);
    let got = uplink(&mut target, &accepted);
    assert_eq!(verdict(&got), Ok(()));
    let verify_ticks = metrics(&got, metric::UPLINK_VERIFY_TICKS);
    assert_eq!(verify_ticks.len(), 1, "{got:?}");
    let instructions = to_instructions(verify_ticks[0]);
    eprintln!(
        "uplink verification: {} bytes secured, {} ticks = {instructions} guest instructions",
        accepted.len(),
        verify_ticks[0]
    );
    assert!(instructions > 0 && instructions < 250_000, "{instructions}");

    // Every kind of bad uplink: refused with its reason, counted.
    for attack in Attack::ALL {
        let sequence = signer.burn_sequence();
        let got = uplink(
            &mut target,
            &attack.uplink(&TEST_KEY, sequence, &image, &accepted),
        );
        assert_eq!(verdict(&got), Err(attack.expected()), "{attack:?}");
        assert_eq!(
            metrics(&got, metric::security_refusals(attack.expected())).len(),
            1,
            "{attack:?}: {got:?}"
        );
    }
    // Ground commands, good and bad.
    let (_, set_hold) = signer.sign_command(GroundCommand::SetHold(2));
    assert_eq!(command(&mut target, &set_hold), Ok(()));
    for attack in Attack::ALL {
        let sequence = signer.burn_sequence();
        let msg = attack.command(&TEST_KEY, sequence, GroundCommand::SetHold(0), &set_hold);
        assert_eq!(
            command(&mut target, &msg),
            Err(CommandRefusal::Security(attack.expected())),
            "{attack:?}"
        );
    }

    // A warm reset through QMP: RAM kept, the counter read back from NV.
    target.warm_reset_qmp().unwrap();
    let hello = target.expect_hello(PATIENCE).unwrap();
    assert_eq!(hello.reset_cause, ResetCause::Warm);
    assert_eq!(
        verdict(&uplink(&mut target, &accepted)),
        Err(SecurityRefusal::Replay)
    );
    assert_eq!(
        command(&mut target, &set_hold),
        Err(CommandRefusal::Security(SecurityRefusal::Replay))
    );
    drop(target);

    // A power cycle: a new QEMU process on the same NV file.
    let mut target = boot(&nv, ResetCause::PowerOn);
    assert_eq!(
        verdict(&uplink(&mut target, &accepted)),
        Err(SecurityRefusal::Replay)
    );
    assert_eq!(
        command(&mut target, &set_hold),
        Err(CommandRefusal::Security(SecurityRefusal::Replay))
    );
    // The counter moved on: the next good command is accepted.
    let (sequence, release) = signer.sign_command(GroundCommand::ReleaseHold(2));
    assert_eq!(
        release,
        authenticated_command(&TEST_KEY, sequence, GroundCommand::ReleaseHold(2))
    );
    assert_eq!(command(&mut target, &release), Ok(()));
    drop(target);
    let shown = hil::mission::auth::describe_nv_file(&nv).unwrap();
    assert!(
        shown.contains(&format!("last accepted sequence {sequence},")),
        "{shown}"
    );
}
