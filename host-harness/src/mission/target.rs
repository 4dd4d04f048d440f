//! Targets a mission runs on: the emulated RAD750 proxy (QEMU, or a real board on a serial
//! port) and the native target (the same flight application compiled into `hil`, no QEMU).
//!
//! The driver hands a target raw frame bytes (so injected corruption reaches the target's own
//! decoder) and gets back every message up to the FrameDone of the frame it granted.
use std::path::PathBuf;
use std::time::Duration;

use flight_app::{FlightApp, Memories, NoClock};
use fsw_bridge::codec::FrameDecoder;
use fsw_bridge::{HostToTarget, ResetCause, TargetToHost, PROTOCOL_VERSION};

use crate::defmt_log::LogLine;
use crate::firmware::FirmwareImage;
use crate::qemu::{LaunchOptions, QemuProfile};
use crate::session::{Hello, Session, SessionError};

/// How long an emulated target may take to finish one granted frame (wall time; a liveness
/// bound, not a measurement).
pub const FRAME_TIMEOUT: Duration = Duration::from_secs(60);
/// Bytes of the warm-restart area given to the flight application (as on the target).
pub const WARM_AREA_BYTES: usize = 60 * 1024;
/// Bytes of non-volatile memory given to the flight application (as on the target).
pub const NV_BYTES: usize = 1 << 20;
/// Build id the native target reports in its Hello.
pub const NATIVE_BUILD_ID: [u8; 8] = *b"native\0\0";

#[derive(Debug, thiserror::Error)]
pub enum TargetError {
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error("the target did not finish frame {frame} within {waited:?}: {detail}")]
    FrameTimeout {
        frame: u32,
        waited: Duration,
        detail: String,
    },
    #[error("the target reported a panic at {file}:{line}")]
    Panic { file: String, line: u32 },
    #[error("{0}")]
    Other(String),
}

/// A target the lockstep driver can run a mission on.
pub trait MissionTarget {
    /// Human-readable description (for reports).
    fn describe(&self) -> String;
    /// Start (first boot, or after a reset or power cycle) and return its Hello.
    fn boot(&mut self) -> Result<Hello, TargetError>;
    /// Send `frames` (encoded, possibly corrupted on purpose) and return every message the
    /// target sends until it reports FrameDone for `frame`.
    fn exchange(
        &mut self,
        frames: &[Vec<u8>],
        frame: u32,
    ) -> Result<Vec<TargetToHost>, TargetError>;
    /// Send `frames` and return what the target sent in response until `until` matches one of
    /// its messages (uplink acknowledgements).
    fn exchange_until(
        &mut self,
        frames: &[Vec<u8>],
        until: &dyn Fn(&TargetToHost) -> bool,
    ) -> Result<Vec<TargetToHost>, TargetError>;
    /// Warm reset (RAM kept). Call `boot` afterwards.
    fn warm_reset(&mut self) -> Result<(), TargetError>;
    /// Power cycle (RAM lost, non-volatile memory kept). Call `boot` afterwards.
    fn power_cycle(&mut self) -> Result<(), TargetError>;
    /// Log lines decoded so far (drained).
    fn take_logs(&mut self) -> Vec<LogLine>;
    /// True for the emulated target (costs are guest ticks), false for native.
    fn counts_cycles(&self) -> bool;
    /// Make the next warm reset land in the middle of a frame (a "random instruction point")
    /// instead of at a frame boundary; `seed` picks the instant. Returns false if this target
    /// cannot do that (the reset then happens at the frame boundary as usual).
    ///
    /// The native target models it as a torn checkpoint (see
    /// [`NativeTarget::damage_on_next_warm_reset`]). The emulated target would need the driver
    /// to send the grant, wait a seeded number of microseconds and issue QMP `system_reset`
    /// while the guest computes; that hook is not wired into the driver yet.
    fn arm_mid_frame_reset(&mut self, seed: u64) -> bool {
        let _ = seed;
        false
    }
    /// What the mid-frame resets armed with `arm_mid_frame_reset` actually did, in order.
    fn mid_frame_log(&self) -> Vec<String> {
        Vec::new()
    }
}

/// Damage a [`NativeTarget`] does to its checkpoints at the next warm reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CheckpointDamage {
    /// The reset lands while the last frame's checkpoint is written to the warm-restart area:
    /// the newest warm record is garbage from byte `offset_permille`/1000 of its length on
    /// (the other slot is whole), and the non-volatile write of that frame never started (its
    /// newest record is invalidated, which restores exactly like the older record it would
    /// still hold). Garbage comes from `seed`.
    TornWarm { offset_permille: u32, seed: u64 },
    /// The reset lands while the last frame's checkpoint is written to non-volatile memory
    /// (the warm write of that frame completed).
    TornNv { offset_permille: u32, seed: u64 },
    /// Test knob: every checkpoint is gone, in both warm slots and in NV. Recovery must fail;
    /// campaigns use it to prove their checks notice.
    DestroyAll,
}

/// The flight application in this process: what runs in the firmware's partitions, without
/// the kernel and without QEMU. RAM is a fresh `FlightApp` per boot; the warm-restart area and
/// non-volatile memory are byte buffers that outlive resets exactly as on the target.
pub struct NativeTarget {
    app: Box<FlightApp>,
    warm: Vec<u8>,
    nv: Vec<u8>,
    decoder: FrameDecoder,
    boot_count: u32,
    next_cause: ResetCause,
    /// Damage to apply at the next warm reset (mid-frame resets, test knobs).
    pending_damage: Option<CheckpointDamage>,
    /// Mission time of the last grant delivered (for the damage log).
    last_grant: Option<fsw_bridge::MissionTimeUs>,
    damage_log: Vec<String>,
    /// What the application sent while booting; goes out with the next exchange, as the
    /// emulated target's outbox does.
    boot_messages: Vec<TargetToHost>,
}

impl Default for NativeTarget {
    fn default() -> Self {
        Self::new()
    }
}

impl NativeTarget {
    pub fn new() -> Self {
        Self {
            app: new_app(),
            warm: vec![0; WARM_AREA_BYTES],
            nv: vec![0; NV_BYTES],
            decoder: FrameDecoder::new(),
            boot_count: 0,
            next_cause: ResetCause::PowerOn,
            pending_damage: None,
            last_grant: None,
            damage_log: Vec::new(),
            boot_messages: Vec::new(),
        }
    }

    /// Apply `damage` to the checkpoints at the next warm reset (once).
    pub fn damage_on_next_warm_reset(&mut self, damage: CheckpointDamage) {
        self.pending_damage = Some(damage);
    }

    /// What the damage applied so far did (one line per reset).
    pub fn damage_log(&self) -> &[String] {
        &self.damage_log
    }

    fn apply_damage(&mut self, damage: CheckpointDamage) {
        let frame = self
            .last_grant
            .map(super::time::fmt_time)
            .unwrap_or_else(|| "-".into());
        let line = match damage {
            CheckpointDamage::DestroyAll => {
                self.warm.iter_mut().for_each(|b| *b = 0);
                self.nv.iter_mut().for_each(|b| *b = 0);
                "every checkpoint destroyed (warm slots A and B, non-volatile memory)".to_string()
            }
            CheckpointDamage::TornWarm {
                offset_permille,
                seed,
            } => {
                let torn = tear_newest(&mut self.warm, offset_permille, seed);
                let nv = invalidate_newest(&mut self.nv);
                format!(
                    "reset during the warm checkpoint write of the frame at {frame}: {torn}; {nv}"
                )
            }
            CheckpointDamage::TornNv {
                offset_permille,
                seed,
            } => {
                let torn = tear_newest(&mut self.nv, offset_permille, seed);
                format!("reset during the non-volatile checkpoint write of the frame at {frame}: {torn}")
            }
        };
        self.damage_log.push(line);
    }

    fn deliver(&mut self, frames: &[Vec<u8>], out: &mut Vec<TargetToHost>) {
        out.append(&mut self.boot_messages);
        for byte in frames.iter().flatten().copied() {
            let Some(Ok(msg)) = self.decoder.push::<HostToTarget>(byte) else {
                continue;
            };
            if let HostToTarget::TimeGrant { now, .. } = msg {
                self.last_grant = Some(now);
            }
            let mut memories = Memories {
                warm: &mut self.warm,
                nv: Some(&mut self.nv),
            };
            let mut sent = Vec::new();
            let handled = self
                .app
                .handle(&msg, &mut memories, &mut NoClock, &mut |m| sent.push(m));
            if !handled {
                if let HostToTarget::Ping { seq } = msg {
                    sent.push(TargetToHost::Pong {
                        seq,
                        link: self.decoder.counters(),
                    });
                }
            }
            out.extend(sent);
        }
    }
}

/// Slot index, start and length (header plus payload) of the newest whole record of a
/// checkpoint area (layout: `autonomy::checkpoint`).
fn newest_record(area: &mut [u8]) -> Option<(u8, usize, usize, u32)> {
    let half = area.len() / 2;
    let wrapped = autonomy::checkpoint::WarmRestartArea::new(area);
    let (slot, sequence, payload) = wrapped.latest()?;
    Some((
        slot,
        usize::from(slot) * half,
        autonomy::checkpoint::RECORD_HEADER_LEN + payload.len(),
        sequence,
    ))
}

/// Overwrite the newest record of `area` with garbage from `offset_permille` of its length on.
fn tear_newest(area: &mut [u8], offset_permille: u32, seed: u64) -> String {
    let Some((slot, start, len, sequence)) = newest_record(area) else {
        return "no whole record to tear".into();
    };
    let offset = (len as u64 * u64::from(offset_permille.min(999)) / 1000) as usize;
    let mut rng = super::rng::Rng::new(seed);
    for b in &mut area[start + offset..start + len] {
        *b = rng.next_u64() as u8;
    }
    format!(
        "record {sequence} in slot {} torn from byte {offset} of {len}",
        ["A", "B"][usize::from(slot)]
    )
}

/// Invalidate the newest record of `area` (its write never started).
fn invalidate_newest(area: &mut [u8]) -> String {
    let Some((slot, start, _, sequence)) = newest_record(area) else {
        return "no non-volatile record".into();
    };
    area[start..start + 4].fill(0);
    format!(
        "non-volatile record {sequence} in slot {} not written yet",
        ["A", "B"][usize::from(slot)]
    )
}

fn new_app() -> Box<FlightApp> {
    // FlightApp is large; build it in place on the heap rather than on the stack.
    let mut app: Box<std::mem::MaybeUninit<FlightApp>> = Box::new_uninit();
    app.write(FlightApp::new());
    // SAFETY: just initialised.
    unsafe { app.assume_init() }
}

impl MissionTarget for NativeTarget {
    fn describe(&self) -> String {
        "native (flight application compiled into hil, no QEMU)".into()
    }

    fn boot(&mut self) -> Result<Hello, TargetError> {
        self.app = new_app();
        self.decoder = FrameDecoder::new();
        self.boot_count += 1;
        let cause = std::mem::replace(&mut self.next_cause, ResetCause::Warm);
        let mut memories = Memories {
            warm: &mut self.warm,
            nv: Some(&mut self.nv),
        };
        let mut sink = Vec::new();
        self.app
            .boot(&mut memories, &mut NoClock, &mut |m| sink.push(m));
        self.boot_messages = sink;
        let _ = PROTOCOL_VERSION;
        Ok(Hello {
            build_id: NATIVE_BUILD_ID,
            reset_cause: cause,
            boot_count: self.boot_count,
        })
    }

    fn exchange(
        &mut self,
        frames: &[Vec<u8>],
        frame: u32,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        let mut out = Vec::new();
        self.deliver(frames, &mut out);
        if !out
            .iter()
            .any(|m| matches!(m, TargetToHost::FrameDone { frame: f, .. } if *f == frame))
        {
            return Err(TargetError::FrameTimeout {
                frame,
                waited: Duration::ZERO,
                detail: "the native target did not receive the grant".into(),
            });
        }
        Ok(out)
    }

    fn exchange_until(
        &mut self,
        frames: &[Vec<u8>],
        until: &dyn Fn(&TargetToHost) -> bool,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        let mut out = Vec::new();
        self.deliver(frames, &mut out);
        if out.iter().any(until) {
            Ok(out)
        } else {
            Err(TargetError::Other(format!(
                "the native target did not answer as expected (sent {} frames, got {out:?})",
                frames.len()
            )))
        }
    }

    fn warm_reset(&mut self) -> Result<(), TargetError> {
        self.next_cause = ResetCause::Warm;
        if let Some(damage) = self.pending_damage.take() {
            self.apply_damage(damage);
        }
        Ok(())
    }

    fn power_cycle(&mut self) -> Result<(), TargetError> {
        // RAM, including the warm-restart area, is gone; NV survives.
        self.warm.iter_mut().for_each(|b| *b = 0);
        self.boot_count = 0;
        self.next_cause = ResetCause::PowerOn;
        Ok(())
    }

    fn take_logs(&mut self) -> Vec<LogLine> {
        Vec::new()
    }

    fn counts_cycles(&self) -> bool {
        false
    }

    /// A torn checkpoint: the reset lands while the last frame's checkpoint is being written,
    /// to the warm-restart area (3 in 4) or to non-volatile memory, at a seeded offset.
    fn arm_mid_frame_reset(&mut self, seed: u64) -> bool {
        let mut rng = super::rng::Rng::new(seed).fork(0x70);
        let offset_permille = rng.below(1000) as u32;
        let garbage = rng.next_u64();
        self.pending_damage = Some(if rng.below(4) < 3 {
            CheckpointDamage::TornWarm {
                offset_permille,
                seed: garbage,
            }
        } else {
            CheckpointDamage::TornNv {
                offset_permille,
                seed: garbage,
            }
        });
        true
    }

    fn mid_frame_log(&self) -> Vec<String> {
        self.damage_log.clone()
    }
}

/// The RAD750 proxy under QEMU (or a real board: `serial`), driven over its link.
pub struct EmulatedTarget {
    profile: QemuProfile,
    firmware: FirmwareImage,
    options: LaunchOptions,
    session: Option<Session>,
    /// Log lines not yet handed out.
    logs: Vec<LogLine>,
    echo_logs: bool,
}

impl EmulatedTarget {
    /// A QEMU target with a non-volatile memory file in `nv_dir` (created fresh).
    pub fn new(
        profile: QemuProfile,
        firmware: FirmwareImage,
        realtime: bool,
        nv_file: PathBuf,
        echo_logs: bool,
    ) -> Self {
        let _ = std::fs::remove_file(&nv_file);
        Self {
            profile,
            firmware,
            options: LaunchOptions {
                realtime,
                nv_file: Some(nv_file),
                nv_size: Some(NV_BYTES as u64),
            },
            session: None,
            logs: Vec::new(),
            echo_logs,
        }
    }

    fn session(&mut self) -> Result<&mut Session, TargetError> {
        self.session
            .as_mut()
            .ok_or_else(|| TargetError::Other("the target is not running".into()))
    }

    fn drain_logs(&mut self) {
        if let Some(s) = self.session.as_mut() {
            self.logs.append(&mut s.logs);
        }
    }

    fn send_all(&mut self, frames: &[Vec<u8>]) -> Result<(), TargetError> {
        let session = self.session()?;
        for f in frames {
            session.link.send_raw(f).map_err(SessionError::from)?;
        }
        Ok(())
    }
}

impl MissionTarget for EmulatedTarget {
    fn describe(&self) -> String {
        match &self.session {
            Some(s) => s.describe.clone(),
            None => format!("{} (not running)", self.profile.name),
        }
    }

    fn boot(&mut self) -> Result<Hello, TargetError> {
        if self.session.is_none() {
            let mut session = Session::boot_qemu(&self.profile, &self.firmware, &self.options)?;
            session.echo_logs = self.echo_logs;
            self.session = Some(session);
        }
        let hello = self.session()?.expect_hello(Duration::from_secs(30))?;
        self.drain_logs();
        Ok(hello)
    }

    fn exchange(
        &mut self,
        frames: &[Vec<u8>],
        frame: u32,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        self.send_all(frames)?;
        let session = self.session()?;
        let mut out = Vec::new();
        let deadline = std::time::Instant::now() + FRAME_TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match session.recv(left) {
                Ok(msg) => {
                    let done =
                        matches!(msg, TargetToHost::FrameDone { frame: f, .. } if f == frame);
                    out.push(msg);
                    if done {
                        break;
                    }
                }
                Err(SessionError::TargetPanic { file, line }) => {
                    return Err(TargetError::Panic { file, line })
                }
                Err(SessionError::Link(crate::link::LinkError::Timeout(_))) => {
                    return Err(TargetError::FrameTimeout {
                        frame,
                        waited: FRAME_TIMEOUT,
                        detail: format!(
                            "received {} messages this frame; QEMU output: {}",
                            out.len(),
                            session
                                .qemu_log()
                                .map(|p| p.display().to_string())
                                .unwrap_or_default()
                        ),
                    })
                }
                Err(e) => return Err(e.into()),
            }
        }
        self.drain_logs();
        Ok(out)
    }

    fn exchange_until(
        &mut self,
        frames: &[Vec<u8>],
        until: &dyn Fn(&TargetToHost) -> bool,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        self.send_all(frames)?;
        let session = self.session()?;
        let mut out = Vec::new();
        loop {
            let msg = session.recv(FRAME_TIMEOUT)?;
            let stop = until(&msg);
            out.push(msg);
            if stop {
                break;
            }
        }
        self.drain_logs();
        Ok(out)
    }

    fn warm_reset(&mut self) -> Result<(), TargetError> {
        self.session()?.warm_reset_qmp()?;
        Ok(())
    }

    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.drain_logs();
        // Dropping the session ends QEMU (RAM gone); the NV file stays for the next process.
        self.session = None;
        Ok(())
    }

    fn take_logs(&mut self) -> Vec<LogLine> {
        self.drain_logs();
        std::mem::take(&mut self.logs)
    }

    fn counts_cycles(&self) -> bool {
        true
    }
}
