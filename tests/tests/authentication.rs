//! Authenticated uplinks and ground commands (`sdls`, in the manner of CCSDS SDLS) on the native
//! target: forged, replayed, wrong-key, unknown-key and truncated uplinks and commands are
//! refused with their typed reasons, counted, and leave the plan untouched, before and after a
//! warm reset and a power cycle; a board without a key refuses the uplink; the scenario's key is
//! the one that signs and is provisioned. The same scenario on the emulated target is in
//! `missions_qemu.rs`.
use std::path::{Path, PathBuf};

use fsw_bridge::{MissionTimeUs, TargetToHost};
use hil::defmt_log::LogLine;
use hil::mission::driver::MissionError;
use hil::mission::report::{summary, MissionReport};
use hil::mission::runner::{prepare, run};
use hil::mission::target::{Hello, MissionTarget, NativeTarget, ResetLanding, TargetError};

fn scenario(name: &str) -> PathBuf {
    hil::repo_root().join("scenarios").join(name)
}

fn run_on(path: &Path, target: &mut dyn MissionTarget) -> Result<MissionReport, MissionError> {
    let prepared = prepare(path).unwrap_or_else(|e| panic!("{e}"));
    run(&prepared, target, None, &mut |_, _, _| {})
}

fn rows(r: &MissionReport) -> Vec<String> {
    r.tasks
        .iter()
        .map(|t| {
            format!(
                "{} ({}) {:?}-{:?} {}",
                t.name, t.origin, t.start, t.end, t.outcome
            )
        })
        .collect()
}

#[test]
fn bad_uplinks_and_commands_are_refused_with_their_reasons_and_the_plan_flies_as_nominal() {
    let r = run_on(
        &scenario("flyby-authentication.toml"),
        &mut NativeTarget::new(),
    )
    .unwrap();
    assert!(r.passed, "{}", summary(&r));
    let nominal = run_on(&scenario("flyby-nominal.toml"), &mut NativeTarget::new()).unwrap();
    assert_eq!(rows(&r), rows(&nominal), "the attacks changed the plan");
    // Each attack got exactly the refusal it was owed.
    let attacks: Vec<_> = r
        .authenticated
        .iter()
        .filter(|a| a.expected_refusal.is_some())
        .collect();
    assert_eq!(attacks.len(), 15);
    for a in &attacks {
        assert_eq!(a.refused, a.expected_refusal, "{a:?}");
    }
    // After the warm reset (09:53) and after the power cycle (09:55), the last accepted
    // uplink (sequence 1) and command (sequence 3) replayed byte for byte are refused.
    for after in ["09:54:00", "09:56:00"] {
        let replays: Vec<_> = attacks
            .iter()
            .filter(|a| hil::time::fmt_time(MissionTimeUs(a.at)) == after)
            .map(|a| (a.what.as_str(), a.sequence, a.refused.as_deref()))
            .collect();
        assert_eq!(
            replays,
            [
                ("replayed uplink", 1, Some("replay")),
                ("replayed ground command", 3, Some("replay"))
            ],
            "after {after}"
        );
    }
    assert_eq!(r.resets.len(), 2);
    assert_eq!(r.resets[1].kind, "power cycle");
    // The good ones, counter continuing across both resets: the uplink, then four commands.
    let accepted: Vec<(String, u32)> = r
        .authenticated
        .iter()
        .filter(|a| a.refused.is_none())
        .map(|a| (a.what.clone(), a.sequence))
        .collect();
    assert_eq!(
        accepted,
        [
            ("task-network uplink".to_string(), 1),
            ("ground command NoOp".to_string(), 2),
            ("ground command SetHold(2)".to_string(), 3),
            ("ground command ReleaseHold(2)".to_string(), 18),
            ("ground command NoOp".to_string(), 20),
        ]
    );
    // Deterministic: the same transcript again.
    let again = run_on(
        &scenario("flyby-authentication.toml"),
        &mut NativeTarget::new(),
    )
    .unwrap();
    assert_eq!(again.transcript_sha256, r.transcript_sha256);
}

/// A native target whose key slot is never written (a board nobody provisioned), or that is
/// provisioned with another key than the scenario's.
struct Provisioned {
    inner: NativeTarget,
    key: Option<sdls::Key>,
}

impl MissionTarget for Provisioned {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn counts_cycles(&self) -> bool {
        false
    }
    fn provision_key(&mut self, _scenario_key: &sdls::Key) -> Result<(), TargetError> {
        match &self.key {
            Some(key) => self.inner.provision_key(key),
            None => Ok(()),
        }
    }
    fn boot(&mut self) -> Result<Hello, TargetError> {
        self.inner.boot()
    }
    fn round(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        self.inner.round(wire, round)
    }
    fn warm_reset(&mut self, at: MissionTimeUs) -> Result<ResetLanding, TargetError> {
        self.inner.warm_reset(at)
    }
    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.inner.power_cycle()
    }
    fn observe(&mut self, msg: &TargetToHost) {
        self.inner.observe(msg)
    }
    fn take_logs(&mut self) -> Vec<LogLine> {
        self.inner.take_logs()
    }
    fn arm_mid_frame_reset(&mut self, seed: u64) {
        self.inner.arm_mid_frame_reset(seed)
    }
    fn reset_notes(&self) -> Vec<String> {
        self.inner.reset_notes()
    }
}

fn refusal_of(result: Result<MissionReport, MissionError>) -> String {
    match result {
        Err(MissionError::UplinkRefused { name, .. }) => name,
        Err(other) => panic!("refused for another reason: {other}"),
        Ok(r) => panic!("the uplink was accepted:\n{}", summary(&r)),
    }
}

#[test]
fn a_target_without_a_key_refuses_the_uplink_with_no_key() {
    let mut target = Provisioned {
        inner: NativeTarget::new(),
        key: None,
    };
    let result = run_on(&scenario("flyby-nominal.toml"), &mut target);
    assert_eq!(refusal_of(result), "no-key");
}

#[test]
fn the_scenarios_key_signs_the_uplink_and_another_provisioned_key_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scenario("flyby-nominal.toml"))
        .unwrap()
        .replace(
            "tasknets/flyby.toml",
            &scenario("tasknets/flyby.toml").display().to_string(),
        );
    let key_hex = "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f";
    std::fs::write(dir.path().join("mission.key"), format!("{key_hex}\n")).unwrap();
    let path = dir.path().join("keyed.toml");
    std::fs::write(
        &path,
        format!("{text}\n[link]\nkey_file = \"mission.key\"\nspi = 9\n"),
    )
    .unwrap();
    // hil provisions the scenario's key: the mission flies.
    let r = run_on(&path, &mut NativeTarget::new()).unwrap();
    assert!(r.passed, "{}", summary(&r));
    // A target holding the test key under SPI 9 cannot verify it ...
    let mut other = Provisioned {
        inner: NativeTarget::new(),
        key: Some(sdls::Key {
            spi: 9,
            ..hil::mission::auth::TEST_KEY
        }),
    };
    assert_eq!(refusal_of(run_on(&path, &mut other)), "bad-mac");
    // ... and one holding it under SPI 1 does not know key 9.
    let mut other = Provisioned {
        inner: NativeTarget::new(),
        key: Some(hil::mission::auth::TEST_KEY),
    };
    assert_eq!(refusal_of(run_on(&path, &mut other)), "unknown-key");
}
