//! The emulated target: the RAD750 proxy under QEMU, driven over its link. Each lockstep
//! round writes the host's burst to the target's serial line and reads the target's frames
//! back up to the RoundEnd that closes its burst (or up to its Hello, when it reset in the
//! round). A warm reset either goes through QMP between frames, or, when a campaign armed one,
//! lands inside the next frame at a seeded point of the executive's work, carried out by the
//! target's own kernel.
use std::path::PathBuf;
use std::time::{Duration, Instant};

use fsw_bridge::codec::{encode, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::link::LinkFrame;
use fsw_bridge::{HostToTarget, MissionTimeUs, ResetKind, TargetToHost, TelemetryEvent};
use kernel_config::abi::{metric as kernel_metric, reset_at};

use super::native::NV_BYTES;
use super::{Hello, MissionTarget, ResetLanding, TargetError};
use crate::cleanup::ScratchFile;
use crate::defmt_log::LogLine;
use crate::firmware::FirmwareImage;
use crate::mission::rng::Rng;
use crate::qemu::{LaunchOptions, QemuProfile};
use crate::session::{Session, SessionError};
use crate::time::fmt_wall;

/// How long the emulated target may take to answer one round (wall time; a liveness bound for
/// a hung target, not a measurement: a round's work is a frame's).
pub const ROUND_TIMEOUT: Duration = Duration::from_secs(60);

/// Bytes of the emulated target's warm-restart area that hold the executive's checkpoints
/// (slots A and B): its slice.
const EMULATED_WARM_CHECKPOINT_BYTES: u32 = kernel_config::system::EXECUTIVE_WARM.len;
/// The planner partition's slice of the warm-restart area (its own A/B records).
const PLANNER_WARM_CHECKPOINT_BYTES: u32 = kernel_config::system::PLANNER_WARM.len;
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
pub fn mid_frame_reset_kind(
    seed: u64,
    expected_ticks: u32,
    planner_expected_ticks: u32,
) -> ResetKind {
    let mut rng = Rng::new(seed).fork(0x71);
    let write = rng.below(4) == 0;
    // Half the points fall in the planner partition's work on the frame (the executive's
    // first message to it, its planning, its checkpoint), half in the executive's.
    let planner = rng.fork(0x72).below(2) == 0;
    let expected_ticks = if planner {
        planner_expected_ticks
    } else {
        expected_ticks
    };
    if write {
        let permille = rng.below(1000) as u16;
        if planner {
            ResetKind::PlannerDuringCheckpointWrite { permille }
        } else {
            ResetKind::WarmDuringCheckpointWrite { permille }
        }
    } else {
        let span = u64::from(expected_ticks.div_ceil(EXPECTED_WORK_QUANTUM).max(1))
            * u64::from(EXPECTED_WORK_QUANTUM);
        let ticks = (1 + ((span * (rng.next_u64() >> 32)) >> 32)).min(u64::from(u32::MAX)) as u32;
        if planner {
            ResetKind::PlannerAfterTicks { ticks }
        } else {
            ResetKind::WarmAfterTicks { ticks }
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
            ResetKind::WarmAfterTicks { ticks } | ResetKind::PlannerAfterTicks { ticks } => {
                format!("armed at tick {ticks}")
            }
            ResetKind::WarmDuringCheckpointWrite { permille }
            | ResetKind::PlannerDuringCheckpointWrite { permille } => {
                format!("armed at {permille} permille of the checkpoint write")
            }
            ResetKind::Warm => "armed at once".into(),
        };
        let ticks = self
            .ticks
            .map_or_else(|| "?".to_string(), |t| t.to_string());
        // A point in the partition's own code is where it was armed (the kernel measures a
        // few ticks more: its own entry); other landings say what the kernel measured.
        let point = match self.kind {
            ResetKind::WarmAfterTicks { ticks } | ResetKind::PlannerAfterTicks { ticks } => {
                ticks.to_string()
            }
            _ => ticks.clone(),
        };
        let who = if self.kind.in_planner() {
            "planner"
        } else {
            "executive"
        };
        let write = self.checkpoint_write;
        let mut lines = vec![match (self.landed, write) {
            (Some(reset_at::LANDED_IN_WARM_WRITE), Some(w)) => format!(
                "reset after {ticks} {who} ticks in the frame at {at} ({armed}): inside the {who}'s work, in its checkpoint write to warm slot {}: {} of {} bytes copied (write ticks {}..{}), slot {} torn",
                slot_name(w.slot), w.copied, w.len, w.start_tick, w.end_tick, slot_name(w.slot)
            ),
            (Some(reset_at::LANDED_IN_CODE), Some(w)) => format!(
                "reset after {point} {who} ticks in the frame at {at}: inside the {who}'s work, after its checkpoint write to warm slot {} ({} bytes, write ticks {}..{}) completed, before its FrameDone left the target",
                slot_name(w.slot), w.len, w.start_tick, w.end_tick
            ),
            (Some(reset_at::LANDED_IN_CODE), None) => format!(
                "reset after {point} {who} ticks in the frame at {at}: inside the {who}'s work, before its checkpoint write (the warm area held the previous frame's checkpoint)"
            ),
            (Some(reset_at::LANDED_AFTER_WORK), w) => format!(
                "frame finished first: the {who}'s work on the frame at {at} took {ticks} ticks ({armed}{}); reset at the boundary, as it finished, before its FrameDone left the target",
                w.map(|w| format!("; checkpoint write to warm slot {} at ticks {}..{}", slot_name(w.slot), w.start_tick, w.end_tick)).unwrap_or_default()
            ),
            (Some(reset_at::LANDED_PARTITION_STOPPED), _) => format!(
                "the health monitor stopped the {who} after {ticks} ticks of its work on the frame at {at} ({armed}); reset then"
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
    /// Busy ticks of the last frame the executive stepped (its FRAME_BUSY_TICKS metric).
    last_busy_ticks: u32,
    /// The planner partition's work on the last frame (its window's planning and checkpoint).
    last_planner_ticks: u32,
    /// A mid-frame reset armed for the next round: its request goes out ahead of the burst.
    pending_request: Option<ResetKind>,
    /// The Hello that ended a frame with a mid-frame reset, for the next `boot`.
    pending_hello: Option<Hello>,
    /// Mid-frame resets carried out, in order.
    mid_frame_reports: Vec<MidFrameReport>,
    /// The last report still waits for the restart's restore metrics.
    awaiting_restore: bool,
    /// The non-volatile memory file when it is temporary: removed with the target.
    temporary_nv: Option<ScratchFile>,
}

impl EmulatedTarget {
    /// A QEMU target whose non-volatile memory file is temporary: it outlives every QEMU the
    /// target starts (power cycles) and is removed with the target.
    pub fn with_temporary_nv(
        profile: QemuProfile,
        firmware: FirmwareImage,
        realtime: bool,
        echo_logs: bool,
    ) -> std::io::Result<Self> {
        let nv = ScratchFile::new("nv")?;
        let mut target = Self::new(
            profile,
            firmware,
            realtime,
            nv.path().to_path_buf(),
            echo_logs,
        );
        target.temporary_nv = Some(nv);
        Ok(target)
    }

    /// A QEMU target with its non-volatile memory in the file `nv_file` (created fresh), which
    /// stays after the run.
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
            last_planner_ticks: 0,
            pending_request: None,
            pending_hello: None,
            mid_frame_reports: Vec::new(),
            awaiting_restore: false,
            temporary_nv: None,
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

    /// Keep what a mid-frame reset needs from the target's messages: the cost of the last
    /// frame, the restore after the reset.
    fn note(&mut self, msg: &TargetToHost) {
        match *msg {
            TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: flight_app::metric::FRAME_BUSY_TICKS,
                value,
            }) if value > 0 => {
                self.last_busy_ticks = u32::try_from(value).unwrap_or(u32::MAX);
            }
            TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: flight_app::metric::PLANNER_TICKS,
                value,
            }) if value > 0 => {
                self.last_planner_ticks = u32::try_from(value).unwrap_or(u32::MAX);
            }
            TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: flight_app::metric::PLANNER_CHECKPOINT_TICKS,
                value,
            }) if value > 0 => {
                self.last_planner_ticks = self
                    .last_planner_ticks
                    .saturating_add(u32::try_from(value).unwrap_or(u32::MAX));
            }
            TargetToHost::Log { ref bytes } => {
                if let Some(s) = self.session.as_mut() {
                    s.take_log(bytes);
                }
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
                slot: (offset
                    / (if report.kind.in_planner() {
                        PLANNER_WARM_CHECKPOINT_BYTES
                    } else {
                        EMULATED_WARM_CHECKPOINT_BYTES
                    } / 2)) as u8,
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

    /// The frames of one round's answer, read up to the RoundEnd of `round` or a Hello.
    fn read_answer(&mut self, round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        let deadline = Instant::now() + ROUND_TIMEOUT;
        let mut frames = Vec::new();
        let mut last_words = Vec::new();
        let firmware = &self.firmware;
        let session = self
            .session
            .as_mut()
            .ok_or_else(|| TargetError::Other("the target is not running".into()))?;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let frame = match session.link.recv_frame(left) {
                Ok(frame) => frame,
                Err(crate::link::LinkError::Timeout(_)) => {
                    return Err(TargetError::RoundTimeout {
                        round,
                        waited: fmt_wall(ROUND_TIMEOUT),
                        detail: format!(
                            "received {} frames of its answer; {}; the end of QEMU's output: {:?}",
                            frames.len(),
                            cpu_whereabouts(session, firmware),
                            session.qemu_output_tail().unwrap_or_default()
                        ),
                    })
                }
                Err(e) => return Err(TargetError::Session(e.into())),
            };
            // Only the transport looks inside here, and only at what the link never damages:
            // the RoundEnd doorbell and the target's expedited announcements.
            let decoded = decode_one(&frame);
            frames.push(frame);
            match decoded {
                Some(LinkFrame::RoundEnd { round: r }) if r == round => return Ok(frames),
                Some(LinkFrame::Bd(msg @ TargetToHost::Hello { .. })) => {
                    let hello = session
                        .check_hello(&msg)?
                        .expect("a Hello message is a Hello");
                    self.pending_hello = Some(hello);
                    if let Some(last) = self.mid_frame_reports.pop() {
                        let report = Self::landing(last.kind, last.frame_at, &last_words);
                        self.mid_frame_reports.push(report);
                        self.awaiting_restore = true;
                    }
                    return Ok(frames);
                }
                Some(LinkFrame::Bd(msg)) => last_words.push(msg),
                _ => {}
            }
        }
    }

    /// One round: the armed reset's request if any, the burst, the answer.
    fn exchange(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        if let Some(kind) = self.pending_request.take() {
            // The armed reset's request, ahead of the burst with the frame's grant: a test
            // instrument, like QMP, so an expedited frame outside the mission's stream.
            let mut frame = [0u8; MAX_FRAME_LEN];
            let len = encode(
                &LinkFrame::Bd(HostToTarget::ResetRequest { kind }),
                &mut frame,
            )
            .expect("a reset request fits a frame");
            self.send_all(&[frame[..len].to_vec()])?;
        }
        self.send_all(wire)?;
        self.read_answer(round)
    }

    /// `error`, or that QEMU ended if it did: the cause of a closed link or a silent target.
    fn explain(&mut self, error: TargetError) -> TargetError {
        let ended = self
            .session
            .as_mut()
            .and_then(|s| s.qemu_ended(&error.to_string()));
        ended.map_or(error, TargetError::Session)
    }
}

/// The single link frame `bytes` hold, if they hold exactly one valid frame.
fn decode_one(bytes: &[u8]) -> Option<LinkFrame<TargetToHost>> {
    let mut decoder = FrameDecoder::new();
    let mut found = None;
    for &b in bytes {
        match decoder.push::<LinkFrame<TargetToHost>>(b) {
            Some(Ok(frame)) if found.is_none() => found = Some(frame),
            Some(_) => return None,
            None => {}
        }
    }
    found
}

impl MissionTarget for EmulatedTarget {
    fn describe(&self) -> String {
        match &self.session {
            Some(s) => s.describe.clone(),
            None => format!(
                "{} (QEMU starts at the first boot, link over {})",
                self.profile.name,
                self.profile.transport.name()
            ),
        }
    }

    fn counts_cycles(&self) -> bool {
        true
    }

    /// Into the non-volatile memory file QEMU maps (created at its full size if it is not
    /// there yet: `EmulatedTarget::new` removed the old one).
    fn provision_key(&mut self, key: &sdls::Key) -> Result<(), TargetError> {
        let Some(path) = self.options.nv_file.clone() else {
            return Err(TargetError::Other(
                "this target has no non-volatile memory to hold a key".into(),
            ));
        };
        crate::mission::auth::provision_nv_file(&path, key, NV_BYTES as u64)
            .map_err(TargetError::Other)
    }

    fn boot(&mut self) -> Result<Hello, TargetError> {
        if let Some(hello) = self.pending_hello.take() {
            // The target already said Hello when it reset inside the last round.
            return Ok(hello);
        }
        if self.session.is_none() {
            let mut session = Session::boot_qemu(&self.profile, &self.firmware, &self.options)?;
            session.echo_logs = self.echo_logs;
            self.session = Some(session);
        }
        let hello = self
            .session()?
            .expect_hello(ROUND_TIMEOUT)
            .map_err(|e| self.explain(e.into()))?;
        self.drain_logs();
        Ok(hello)
    }

    fn round(&mut self, wire: &[Vec<u8>], round: u32) -> Result<Vec<Vec<u8>>, TargetError> {
        let answer = self.exchange(wire, round);
        self.drain_logs();
        answer.map_err(|e| self.explain(e))
    }

    fn warm_reset(&mut self, at: MissionTimeUs) -> Result<ResetLanding, TargetError> {
        self.awaiting_restore = false;
        let Some(arm) = self.mid_frame_arm.take() else {
            self.session()?.warm_reset_qmp()?;
            return Ok(ResetLanding::Now);
        };
        let kind = match arm {
            MidFrameArm::Exact(kind) => kind,
            MidFrameArm::Seeded(seed) => mid_frame_reset_kind(
                seed,
                self.last_busy_ticks.saturating_add(FRAME_OVERHEAD_TICKS),
                self.last_planner_ticks.saturating_add(FRAME_OVERHEAD_TICKS),
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
        self.pending_request = Some(kind);
        Ok(ResetLanding::InsideNextFrame)
    }

    fn power_cycle(&mut self) -> Result<(), TargetError> {
        self.awaiting_restore = false;
        // A Hello kept from a reset before this one is stale: the next boot waits for QEMU's.
        self.pending_hello = None;
        self.drain_logs();
        // Dropping the session ends QEMU (RAM gone); the NV file stays for the next process.
        self.session = None;
        Ok(())
    }

    fn observe(&mut self, msg: &TargetToHost) {
        self.note(msg);
    }

    fn take_logs(&mut self) -> Vec<LogLine> {
        self.drain_logs();
        std::mem::take(&mut self.logs)
    }

    /// A real reset inside the frame, on the target: see the module documentation.
    fn arm_mid_frame_reset(&mut self, seed: u64) {
        self.mid_frame_arm = Some(MidFrameArm::Seeded(seed));
    }

    fn reset_notes(&self) -> Vec<String> {
        self.mid_frame_reports
            .iter()
            .flat_map(MidFrameReport::describe)
            .collect()
    }
}

/// CPU samples taken when a target stops answering.
const STALL_SAMPLES: usize = 24;

/// Where the guest CPU spends its time, for a target that stopped answering: a few samples of
/// the instruction address (with its function) and the stack pointer (whose region names the
/// partition, or the kernel), most frequent first.
fn cpu_whereabouts(session: &mut Session, firmware: &FirmwareImage) -> String {
    let Some(qemu) = session.qemu.as_mut() else {
        return "no QEMU to ask where the CPU is".into();
    };
    let mut seen: Vec<(String, usize)> = Vec::new();
    for _ in 0..STALL_SAMPLES {
        let text = match qemu.cpu_registers() {
            Ok(text) => text,
            Err(e) => return format!("the CPU's registers could not be read ({e})"),
        };
        let place = cpu_place(&text, firmware);
        match seen.iter_mut().find(|(p, _)| *p == place) {
            Some((_, n)) => *n += 1,
            None => seen.push((place, 1)),
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    seen.sort_by_key(|(_, n)| std::cmp::Reverse(*n));
    let places: Vec<String> = seen
        .iter()
        .take(4)
        .map(|(place, n)| format!("{n}x {place}"))
        .collect();
    format!(
        "the CPU, sampled {STALL_SAMPLES} times: {}",
        places.join(", ")
    )
}

/// One sample from QEMU's `info registers`: `NIP 0000368c   LR 00000000 ...` and `GPR00 <r0>
/// <r1> <r2> <r3>` (64-bit wide).
fn cpu_place(text: &str, firmware: &FirmwareImage) -> String {
    let field = |name: &str, nth: usize| -> Option<u32> {
        let at = text.find(name)? + name.len();
        let value = text[at..].split_whitespace().nth(nth)?;
        u64::from_str_radix(value, 16).ok().map(|v| v as u32)
    };
    let function = match field("NIP ", 0) {
        Some(a) => firmware
            .symbolize(a)
            .unwrap_or_else(|| format!("{a:#010x}")),
        None => "?".into(),
    };
    let owner = field("GPR00", 1).map_or("?".to_string(), |sp| {
        // The test image's partitions include the product's, at the same places.
        kernel_config::system::TEST
            .partitions
            .iter()
            .find(|p| {
                p.regions
                    .iter()
                    .any(|r| (r.base as u64..r.end()).contains(&u64::from(sp)))
            })
            .map_or("kernel".to_string(), |p| p.name.to_string())
    });
    format!("{owner}: {function}")
}
