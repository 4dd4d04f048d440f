//! Targets a mission runs on: the emulated RAD750 proxy (QEMU, or a real board on a serial
//! port) and the native target (the same flight application compiled into `hil`, no QEMU).
//!
//! The driver hands a target raw frame bytes (so injected corruption reaches the target's own
//! decoder) and gets back every message up to the FrameDone of the frame it granted.
use std::path::PathBuf;
use std::time::Duration;

use flight_app::{FlightApp, Memories, NoClock};
use fsw_bridge::codec::FrameDecoder;
use fsw_bridge::{
    HostToTarget, MissionTimeUs, ResetCause, ResetKind, TargetToHost, TelemetryEvent,
    PROTOCOL_VERSION,
};
use kernel_config::abi::{metric as kernel_metric, reset_at};

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
    /// [`NativeTarget::damage_on_next_warm_reset`]): the reset lands while the last frame's
    /// checkpoint is written.
    ///
    /// The emulated target really resets inside a frame, deterministically: for a warm reset
    /// due at mission time T the driver grants the frame at T together with a
    /// `ResetRequest { kind: WarmAfterTicks | WarmDuringCheckpointWrite }` (see
    /// [`mid_frame_reset_request`](Self::mid_frame_reset_request)), and the target's kernel
    /// warm-resets the module at that point of the executive partition's work on the frame,
    /// counted in the executive's own CPU ticks from the start of that work (the start of its
    /// window after the grant arrived; counted with the decrementer, so the point does not
    /// depend on host timing): 3 in 4 after a seeded number of ticks spread over the work the
    /// previous frame took, 1 in 4 part-way (a seeded permille) through the copy of the frame's
    /// checkpoint into the warm-restart area, which tears the newest slot. If the
    /// executive finishes the frame before the point, the kernel resets when it finishes,
    /// before its FrameDone leaves the target. Either way the target answers with a Hello
    /// (cause Warm) and no FrameDone; [`mid_frame_log`](Self::mid_frame_log) says where the
    /// reset landed and which checkpoint the restart restored.
    fn arm_mid_frame_reset(&mut self, seed: u64) -> bool {
        let _ = seed;
        false
    }
    /// What the mid-frame resets armed with `arm_mid_frame_reset` actually did, in order.
    fn mid_frame_log(&self) -> Vec<String> {
        Vec::new()
    }
    /// For a target whose armed mid-frame reset is carried out by the target itself inside the
    /// frame granted at `at`: the ResetRequest to send with that frame, just before its grant
    /// (then call [`exchange_until_reset`](Self::exchange_until_reset) instead of `warm_reset`).
    /// None: reset at the frame boundary with `warm_reset` (any armed damage applies there).
    fn mid_frame_reset_request(&mut self, at: MissionTimeUs) -> Option<HostToTarget> {
        let _ = at;
        None
    }
    /// Send `frames` (inputs, the request from `mid_frame_reset_request`, the grant of `frame`)
    /// and return what the target sent until it reset, its Hello last (kept for the next
    /// `boot`).
    fn exchange_until_reset(
        &mut self,
        frames: &[Vec<u8>],
        frame: u32,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        let _ = (frames, frame);
        Err(TargetError::Other(
            "this target does not reset inside a frame".into(),
        ))
    }
}

/// Bytes of the emulated target's warm-restart area that hold checkpoints (slots A and B).
const EMULATED_WARM_CHECKPOINT_BYTES: u32 =
    kernel_config::WARM_AREA_SIZE - kernel_config::WARM_BOOT_RECORD_SIZE;
/// What the executive does for a frame besides what FrameDone's `busy_ticks` counts (the
/// autonomy step and the checkpoint encoding): decoding the grant, copying the checkpoint into
/// the warm-restart area, queuing its messages. Measured on the flyby: 400 to 500 ticks.
pub const FRAME_OVERHEAD_TICKS: u32 = 500;
/// The expected work a mid-frame point is drawn over is rounded up to a multiple of this, so
/// that a measured frame one tick longer or shorter does not move the point.
pub const EXPECTED_WORK_QUANTUM: u32 = 1_024;

/// The point of an emulated mid-frame reset, drawn from `seed` for a frame whose executive work
/// is expected to take about `expected_ticks`: 1 in 4 part-way through the frame's checkpoint
/// copy into the warm-restart area (a seeded permille of its bytes), otherwise after a number
/// of the executive's ticks drawn uniformly from 1 to `expected_ticks` (rounded up to
/// [`EXPECTED_WORK_QUANTUM`]).
pub fn mid_frame_reset_kind(seed: u64, expected_ticks: u32) -> ResetKind {
    let mut rng = super::rng::Rng::new(seed).fork(0x71);
    if rng.below(4) == 0 {
        ResetKind::WarmDuringCheckpointWrite {
            permille: rng.below(1000) as u16,
        }
    } else {
        let span = u64::from(expected_ticks.div_ceil(EXPECTED_WORK_QUANTUM).max(1))
            * u64::from(EXPECTED_WORK_QUANTUM);
        let ticks = 1 + ((span * (rng.next_u64() >> 32)) >> 32);
        ResetKind::WarmAfterTicks {
            ticks: ticks.min(u64::from(u32::MAX)) as u32,
        }
    }
}

/// The checkpoint write of the frame a mid-frame reset landed in, as the target reported it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CheckpointWriteReport {
    /// Warm slot written: 0 = A, 1 = B.
    pub slot: u8,
    pub len: u32,
    /// Bytes copied before the reset (`len` unless the reset tore the write).
    pub copied: u32,
    /// Executive ticks since its receipt of the grant at the start and at the end (or tear).
    pub start_tick: u32,
    pub end_tick: u32,
}

impl CheckpointWriteReport {
    pub fn torn(&self) -> bool {
        self.copied < self.len
    }
}

/// What an emulated mid-frame reset did, from the kernel's report (sent just before the reset)
/// and the restart's restore metrics.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MidFrameReport {
    /// Mission time of the frame the reset landed in.
    pub frame_at: MissionTimeUs,
    /// The point asked for.
    pub kind: ResetKind,
    /// Where it landed (`kernel_config::abi::reset_at::LANDED_*`); None if the target did not
    /// say.
    pub landed: Option<u64>,
    /// Executive ticks from its receipt of the grant to the reset.
    pub ticks: Option<u64>,
    /// The frame's checkpoint write, if the executive got to it.
    pub checkpoint_write: Option<CheckpointWriteReport>,
    /// The checkpoint the restart restored: (sequence, warm slot).
    pub restored: Option<(u32, u8)>,
}

fn slot_name(slot: u8) -> &'static str {
    ["A", "B"].get(usize::from(slot)).copied().unwrap_or("?")
}

impl MidFrameReport {
    /// The reset landed inside the executive's work on the frame (not after it finished).
    pub fn inside_work(&self) -> bool {
        matches!(
            self.landed,
            Some(reset_at::LANDED_IN_CODE | reset_at::LANDED_IN_WARM_WRITE)
        )
    }

    /// One line for what happened at the reset, one for the restore (once known).
    pub fn describe(&self) -> Vec<String> {
        let at = crate::time::fmt_time(self.frame_at);
        let armed = match self.kind {
            ResetKind::WarmAfterTicks { ticks } => format!("armed at tick {ticks}"),
            ResetKind::WarmDuringCheckpointWrite { permille } => {
                format!("armed at {permille} permille of the checkpoint write")
            }
            ResetKind::Warm => "armed at once".into(),
        };
        let ticks = self
            .ticks
            .map_or_else(|| "?".to_string(), |t| t.to_string());
        // A point in the executive's own code is where it was armed (the kernel measures a
        // few ticks more: its own entry); other landings say what the kernel measured.
        let point = match self.kind {
            ResetKind::WarmAfterTicks { ticks } => ticks.to_string(),
            _ => ticks.clone(),
        };
        let write = self.checkpoint_write;
        let mut lines = vec![match (self.landed, write) {
            (Some(reset_at::LANDED_IN_WARM_WRITE), Some(w)) => format!(
                "reset after {ticks} executive ticks in the frame at {at} ({armed}): inside the executive's work, in its checkpoint write to warm slot {}: {} of {} bytes copied (write ticks {}..{}), slot {} torn",
                slot_name(w.slot), w.copied, w.len, w.start_tick, w.end_tick, slot_name(w.slot)
            ),
            (Some(reset_at::LANDED_IN_CODE), Some(w)) => format!(
                "reset after {point} executive ticks in the frame at {at}: inside the executive's work, after its checkpoint write to warm slot {} ({} bytes, write ticks {}..{}) completed, before its FrameDone left the target",
                slot_name(w.slot), w.len, w.start_tick, w.end_tick
            ),
            (Some(reset_at::LANDED_IN_CODE), None) => format!(
                "reset after {point} executive ticks in the frame at {at}: inside the executive's work, before its checkpoint write (the warm area held the previous frame's checkpoint)"
            ),
            (Some(reset_at::LANDED_AFTER_WORK), w) => format!(
                "frame finished first: the executive's work on the frame at {at} took {ticks} ticks ({armed}{}); reset at the boundary, as it finished, before its FrameDone left the target",
                w.map(|w| format!("; checkpoint write to warm slot {} at ticks {}..{}", slot_name(w.slot), w.start_tick, w.end_tick)).unwrap_or_default()
            ),
            (Some(reset_at::LANDED_PARTITION_STOPPED), _) => format!(
                "the health monitor stopped the executive after {ticks} ticks of its work on the frame at {at} ({armed}); reset then"
            ),
            _ => format!(
                "reset in the frame at {at} ({armed}); the target did not say where it landed"
            ),
        }];
        if let Some((sequence, slot)) = self.restored {
            let skipped = match write {
                Some(w) if w.torn() && w.slot != slot => {
                    format!(" (the torn slot {} skipped)", slot_name(w.slot))
                }
                _ => String::new(),
            };
            lines.push(format!(
                "restart after the reset in the frame at {at}: plan restored from checkpoint {sequence} in warm slot {}{skipped}",
                slot_name(slot)
            ));
        }
        lines
    }
}

/// How the next mid-frame reset of an [`EmulatedTarget`] is chosen.
#[derive(Clone, Copy, Debug)]
enum MidFrameArm {
    /// Drawn from a seed when the frame is known (campaigns).
    Seeded(u64),
    /// Exactly this point (tests).
    Exact(ResetKind),
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
    /// The mid-frame reset armed for the next warm reset.
    mid_frame_arm: Option<MidFrameArm>,
    /// Busy ticks of the last frame the executive stepped (from its FrameDone).
    last_busy_ticks: u32,
    /// The Hello that ended a frame with a mid-frame reset, for the next `boot`.
    pending_hello: Option<Hello>,
    /// Mid-frame resets carried out, in order.
    mid_frame_reports: Vec<MidFrameReport>,
    /// The last report still waits for the restart's restore metrics.
    awaiting_restore: bool,
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
            mid_frame_arm: None,
            last_busy_ticks: 0,
            pending_hello: None,
            mid_frame_reports: Vec::new(),
            awaiting_restore: false,
        }
    }

    /// Make the next warm reset land exactly at `kind` inside its frame (a mid-frame kind; see
    /// [`MissionTarget::arm_mid_frame_reset`] for the seeded draw campaigns use).
    pub fn arm_mid_frame_reset_exactly(&mut self, kind: ResetKind) {
        self.mid_frame_arm = Some(MidFrameArm::Exact(kind));
    }

    /// The mid-frame resets carried out so far, with what the target reported about each.
    pub fn mid_frame_reports(&self) -> &[MidFrameReport] {
        &self.mid_frame_reports
    }

    /// Keep what the driver needs to know from the target's messages: the cost of the last
    /// frame, the restore after a mid-frame reset.
    fn observe(&mut self, msg: &TargetToHost) {
        match *msg {
            TargetToHost::FrameDone { busy_ticks, .. } if busy_ticks > 0 => {
                self.last_busy_ticks = busy_ticks;
            }
            TargetToHost::Telemetry(TelemetryEvent::Metric { id, value })
                if self.awaiting_restore =>
            {
                let Some(report) = self.mid_frame_reports.last_mut() else {
                    return;
                };
                let (sequence, slot) = report.restored.unwrap_or((0, 0));
                match id {
                    flight_app::metric::RESTORED_SEQUENCE => {
                        report.restored = Some((value as u32, slot));
                    }
                    flight_app::metric::RESTORED_SLOT => {
                        report.restored = Some((sequence, value as u8));
                        self.awaiting_restore = false;
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }

    /// The report of a mid-frame reset from the kernel's metrics sent just before it.
    fn landing(kind: ResetKind, frame_at: MissionTimeUs, msgs: &[TargetToHost]) -> MidFrameReport {
        let mut report = MidFrameReport {
            frame_at,
            kind,
            landed: None,
            ticks: None,
            checkpoint_write: None,
            restored: None,
        };
        let (mut write, mut copied, mut write_ticks) = (None, None, None);
        for msg in msgs {
            if let TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }) = *msg {
                match id {
                    kernel_metric::ARMED_RESET_POINT => report.landed = Some(value),
                    kernel_metric::ARMED_RESET_TICKS => report.ticks = Some(value),
                    kernel_metric::ARMED_RESET_WARM_WRITE => write = Some(value),
                    kernel_metric::ARMED_RESET_WARM_COPIED => copied = Some(value),
                    kernel_metric::ARMED_RESET_WARM_WRITE_TICKS => write_ticks = Some(value),
                    _ => {}
                }
            }
        }
        if let Some(write) = write {
            let (offset, len) = ((write >> 32) as u32, write as u32);
            let ticks = write_ticks.unwrap_or(0);
            report.checkpoint_write = Some(CheckpointWriteReport {
                slot: (offset / (EMULATED_WARM_CHECKPOINT_BYTES / 2)) as u8,
                len,
                copied: copied.map_or(len, |c| c as u32),
                start_tick: (ticks >> 32) as u32,
                end_tick: ticks as u32,
            });
        }
        report
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
        if let Some(hello) = self.pending_hello.take() {
            // The target already said Hello when its mid-frame reset ended the frame.
            return Ok(hello);
        }
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
        receive_until(
            session,
            frame,
            &mut out,
            |_, msg| {
                Ok(
                    matches!(msg, TargetToHost::FrameDone { frame: f, .. } if *f == frame)
                        .then_some(()),
                )
            },
            |n| format!("received {n} messages this frame"),
        )?;
        for msg in &out {
            self.observe(msg);
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
        self.awaiting_restore = false;
        self.session()?.warm_reset_qmp()?;
        Ok(())
    }

    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.awaiting_restore = false;
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

    /// A real reset inside the frame, on the target (see the trait's documentation).
    fn arm_mid_frame_reset(&mut self, seed: u64) -> bool {
        self.mid_frame_arm = Some(MidFrameArm::Seeded(seed));
        true
    }

    fn mid_frame_log(&self) -> Vec<String> {
        self.mid_frame_reports
            .iter()
            .flat_map(MidFrameReport::describe)
            .collect()
    }

    fn mid_frame_reset_request(&mut self, at: MissionTimeUs) -> Option<HostToTarget> {
        let kind = match self.mid_frame_arm.take()? {
            MidFrameArm::Exact(kind) => kind,
            MidFrameArm::Seeded(seed) => mid_frame_reset_kind(
                seed,
                self.last_busy_ticks.saturating_add(FRAME_OVERHEAD_TICKS),
            ),
        };
        self.mid_frame_reports.push(MidFrameReport {
            frame_at: at,
            kind,
            landed: None,
            ticks: None,
            checkpoint_write: None,
            restored: None,
        });
        self.awaiting_restore = false;
        Some(HostToTarget::ResetRequest { kind })
    }

    fn exchange_until_reset(
        &mut self,
        frames: &[Vec<u8>],
        frame: u32,
    ) -> Result<Vec<TargetToHost>, TargetError> {
        self.send_all(frames)?;
        let session = self.session()?;
        let mut out = Vec::new();
        let hello = receive_until(
            session,
            frame,
            &mut out,
            |session, msg| Ok(session.check_hello(msg)?),
            |n| {
                format!(
                    "a mid-frame reset was armed in this frame but the target did not reset (received {n} messages, no Hello)"
                )
            },
        )?;
        self.pending_hello = Some(hello);
        if let Some(last) = self.mid_frame_reports.pop() {
            let report = Self::landing(last.kind, last.frame_at, &out);
            self.mid_frame_reports.push(report);
            self.awaiting_restore = true;
        }
        self.drain_logs();
        Ok(out)
    }
}

/// Receive messages into `out` until `stop` picks one (its value is returned), for at most
/// FRAME_TIMEOUT from now; `detail` says what had arrived (given how many) if none did.
fn receive_until<T>(
    session: &mut Session,
    frame: u32,
    out: &mut Vec<TargetToHost>,
    mut stop: impl FnMut(&Session, &TargetToHost) -> Result<Option<T>, TargetError>,
    detail: impl Fn(usize) -> String,
) -> Result<T, TargetError> {
    let deadline = std::time::Instant::now() + FRAME_TIMEOUT;
    loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        match session.recv(left) {
            Ok(msg) => {
                let picked = stop(session, &msg)?;
                out.push(msg);
                if let Some(value) = picked {
                    return Ok(value);
                }
            }
            Err(e) => return Err(frame_error(e, frame, detail(out.len()), session)),
        }
    }
}

/// What went wrong while waiting for the target during frame `frame`: its panic, a timeout
/// (with `what` it had received and where QEMU's output is), or the link error itself.
fn frame_error(e: SessionError, frame: u32, what: String, session: &Session) -> TargetError {
    match e {
        SessionError::TargetPanic { file, line } => TargetError::Panic { file, line },
        SessionError::Link(crate::link::LinkError::Timeout(_)) => TargetError::FrameTimeout {
            frame,
            waited: FRAME_TIMEOUT,
            detail: format!(
                "{what}; QEMU output: {}",
                session
                    .qemu_log()
                    .map(|p| p.display().to_string())
                    .unwrap_or_default()
            ),
        },
        e => e.into(),
    }
}
