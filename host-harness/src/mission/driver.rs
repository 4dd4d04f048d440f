//! The lockstep time driver. The host grants mission time frame by frame: before each grant it
//! delivers what the spacecraft published and answered since the last one; the target consumes
//! input only at frame boundaries, runs one frame, reports its decisions and FrameDone with the
//! earliest time it next needs to run. The next grant is at the earliest of that, the next
//! spacecraft event, the next scenario event and `max_frame`: idle stretches cost nothing.
//!
//! Link faults are injected by the host, seeded: bytes corrupted or frames dropped or delayed
//! in both directions. A grant or FrameDone lost that way is retransmitted at once (the target
//! answers a repeated grant with the same FrameDone), so a lossy link costs inputs and
//! decisions, as it would in flight, but never stalls the run or makes it depend on wall time.

use fsw_bridge::codec::{encode, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::{HostToTarget, LinkCounters, MissionTimeUs, Opcode, ResetCause, TargetToHost};
use sha2::{Digest, Sha256};

use super::plan::{Action, CommandFault, LinkFaults, MissionPlan};
use super::record::MissionRecord;
use super::rng::Rng;
use super::sim::{CommandFate, Spacecraft};
use super::target::{MissionTarget, TargetError};
use super::CompiledNetwork;
use crate::time::fmt_time;

/// Consecutive grants at the same mission time after which the run is declared stuck.
pub const MAX_ZERO_ADVANCE_FRAMES: u32 = 10_000;
/// Retransmissions of one grant before the run gives up.
pub const MAX_GRANT_ATTEMPTS: u32 = 50;

#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    #[error(transparent)]
    Target(#[from] TargetError),
    #[error("the target refused the task-network uplink (reason code {reason:#06x})")]
    UplinkRefused { reason: u16 },
    #[error("the target kept asking to run at {at} ({frames} frames without time advancing)")]
    Stuck { at: String, frames: u32 },
    #[error("the grant for frame {frame} was lost {attempts} times in a row")]
    LinkDown { frame: u32, attempts: u32 },
    #[error("expected reset cause {expected} after the {what} at {at}, got {got}")]
    WrongResetCause {
        what: String,
        at: String,
        expected: String,
        got: String,
    },
}

/// Host-side link fault injection.
struct FaultInjector {
    spec: LinkFaults,
    tx_rng: Rng,
    rx_rng: Rng,
    delayed: Vec<Vec<u8>>,
    rx_decoder: FrameDecoder,
    injected_tx: u64,
    injected_rx: u64,
}

fn frame_of<M: serde::Serialize>(msg: &M) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = encode(msg, &mut buf).expect("messages fit a frame");
    buf[..n].to_vec()
}

impl FaultInjector {
    fn new(spec: LinkFaults, seed: u64) -> Self {
        let rng = Rng::new(seed);
        Self {
            spec,
            tx_rng: rng.fork(0x7e),
            rx_rng: rng.fork(0x7f),
            delayed: Vec::new(),
            rx_decoder: FrameDecoder::new(),
            injected_tx: 0,
            injected_rx: 0,
        }
    }

    fn active(&self) -> bool {
        self.spec.active()
    }

    /// Corrupt bytes of `frame` (not the delimiters); true if anything changed.
    fn corrupt(rng: &mut Rng, p: f64, frame: &mut [u8]) -> bool {
        let mut hit = false;
        let len = frame.len();
        for b in frame.iter_mut().take(len.saturating_sub(1)).skip(1) {
            if rng.chance(p) {
                *b ^= 1 << rng.below(8);
                hit = true;
            }
        }
        hit
    }

    /// What goes on the wire for `msg` this frame (nothing, if dropped or delayed). Returns the
    /// bytes and whether they arrive intact.
    fn tx(&mut self, msg: &HostToTarget, out: &mut Vec<Vec<u8>>) -> bool {
        let mut frame = frame_of(msg);
        if !self.active() {
            out.push(frame);
            return true;
        }
        if self.tx_rng.chance(self.spec.drop) {
            self.injected_tx += 1;
            return false;
        }
        if self.tx_rng.chance(self.spec.delay) {
            self.injected_tx += 1;
            self.delayed.push(frame);
            return false;
        }
        let hit = Self::corrupt(&mut self.tx_rng, self.spec.corrupt, &mut frame);
        if hit {
            self.injected_tx += 1;
        }
        out.push(frame);
        !hit
    }

    /// Frames held back from the previous frame.
    fn take_delayed(&mut self) -> Vec<Vec<u8>> {
        std::mem::take(&mut self.delayed)
    }

    /// What the host receives of `msg` after the link. Cost metrics are instrumentation that
    /// only the emulated target sends: they pass untouched and draw nothing from the fault
    /// stream, so native and emulated runs lose the same decisions to the same seed.
    fn rx(&mut self, msg: TargetToHost) -> Option<TargetToHost> {
        if !self.active()
            || matches!(
                msg,
                TargetToHost::Telemetry(fsw_bridge::TelemetryEvent::Metric { .. })
            )
        {
            return Some(msg);
        }
        if self.rx_rng.chance(self.spec.drop) {
            self.injected_rx += 1;
            return None;
        }
        let mut frame = frame_of(&msg);
        if !Self::corrupt(&mut self.rx_rng, self.spec.corrupt, &mut frame) {
            return Some(msg);
        }
        self.injected_rx += 1;
        let mut got = None;
        for b in frame {
            if let Some(Ok(m)) = self.rx_decoder.push::<TargetToHost>(b) {
                got = Some(m);
            }
        }
        got
    }
}

/// Guest-tick measurements among the target's metrics (costs, and where in its work an armed
/// reset landed in ticks). Their values go to the run's metrics and reset records, not into the
/// transcript hash: under QEMU 7.2's icount a measurement can come out one tick apart between
/// two runs of the same scenario (the instruction at which a decrementer write or read takes
/// effect is occasionally one off), while everything the target decided and said is the same.
pub fn is_tick_measurement(id: u16) -> bool {
    use flight_app::metric as app;
    use kernel_config::abi::metric as kernel;
    app::is_measured_cost(id)
        || matches!(
            id,
            kernel::BOOT_TO_READY_TICKS
                | kernel::KERNEL_BOOT_TICKS
                | kernel::ARMED_RESET_TICKS
                | kernel::ARMED_RESET_WARM_WRITE_TICKS
                | kernel::SYSCALL_BENCH_TICKS
                | kernel::SWITCH_MILLITICKS
                | kernel::SWITCH_MAX_TICKS
                | kernel::MAX_JITTER_ALL
        )
        || [
            kernel::FRAME_TICKS,
            kernel::WORST_FRAME_TICKS,
            kernel::MAX_JITTER,
        ]
        .iter()
        .any(|base| (*base..*base + 0x10).contains(&id))
}

/// `msg` as the transcript hash sees it: guest-tick measurements (FrameDone's `busy_ticks`,
/// [`is_tick_measurement`] metrics) read as 0.
pub fn without_tick_measurements(msg: &TargetToHost) -> TargetToHost {
    match msg {
        TargetToHost::FrameDone {
            frame, next_wakeup, ..
        } => TargetToHost::FrameDone {
            frame: *frame,
            next_wakeup: *next_wakeup,
            busy_ticks: 0,
        },
        TargetToHost::Telemetry(fsw_bridge::TelemetryEvent::Metric { id, .. })
            if is_tick_measurement(*id) =>
        {
            TargetToHost::Telemetry(fsw_bridge::TelemetryEvent::Metric { id: *id, value: 0 })
        }
        other => other.clone(),
    }
}

/// The transcript: every frame both ways, in order (what the target sent without its
/// guest-tick measurements, see [`without_tick_measurements`]), and its SHA-256; plus one
/// readable line per frame with the measured values (`hil run` writes them to
/// `transcript.txt`). With `HIL_DEBUG_TRANSCRIPT` set in the environment every frame is also
/// printed to stderr.
pub struct Transcript {
    hasher: Sha256,
    pub frames: u64,
    pub bytes: u64,
    pub lines: Vec<String>,
    echo: bool,
}

impl Default for Transcript {
    fn default() -> Self {
        Self {
            hasher: Sha256::default(),
            frames: 0,
            bytes: 0,
            lines: Vec::new(),
            echo: std::env::var_os("HIL_DEBUG_TRANSCRIPT").is_some(),
        }
    }
}

impl Transcript {
    fn sent(&mut self, frame: &[u8]) {
        if self.echo {
            eprintln!("T {frame:02x?}");
        }
        self.hasher.update(b"T");
        self.hasher.update((frame.len() as u32).to_be_bytes());
        self.hasher.update(frame);
        self.frames += 1;
        self.bytes += frame.len() as u64;
        let mut decoder = FrameDecoder::new();
        let decoded = frame.iter().find_map(|&b| decoder.push::<HostToTarget>(b));
        self.lines.push(match decoded {
            Some(Ok(msg)) => format!("-> {msg:?}"),
            _ => format!("-> (undecodable, {} bytes) {frame:02x?}", frame.len()),
        });
    }

    fn received(&mut self, msg: &TargetToHost) {
        if self.echo {
            eprintln!("R {msg:?}");
        }
        let frame = frame_of(&without_tick_measurements(msg));
        self.hasher.update(b"R");
        self.hasher.update((frame.len() as u32).to_be_bytes());
        self.hasher.update(&frame);
        self.frames += 1;
        self.bytes += frame.len() as u64;
        self.lines.push(format!("<- {msg:?}"));
    }

    pub fn finish(self) -> (String, Vec<String>) {
        let hash = self
            .hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        (hash, self.lines)
    }
}

/// The outcome of driving a mission.
pub struct MissionRun {
    pub record: MissionRecord,
    pub transcript_sha256: String,
    pub transcript_frames: u64,
    /// One line per frame, in transcript order.
    pub transcript: Vec<String>,
    pub injected_link_faults: u64,
    pub host_link_errors: LinkCounters,
}

/// Progress callback: (mission time now, mission start, mission end).
pub type Progress<'a> = &'a mut dyn FnMut(MissionTimeUs, MissionTimeUs, MissionTimeUs);

/// The host's side of a running mission: the simulated spacecraft, the link fault injector, the
/// armed command faults, the record and the transcript.
struct Host<'a> {
    net: &'a CompiledNetwork,
    sim: Spacecraft,
    faults: FaultInjector,
    fault_rng: Rng,
    armed: Vec<CommandFault>,
    rec: MissionRecord,
    transcript: Transcript,
    /// Messages for the next grant.
    inputs: Vec<HostToTarget>,
}

impl Host<'_> {
    /// The frames that go out before the grant at `now`: frames held back from the previous
    /// frame, then what the spacecraft published and answered (link faults applied).
    fn input_frames(&mut self, now: MissionTimeUs) -> Vec<Vec<u8>> {
        self.inputs.extend(self.sim.due(now));
        for msg in &self.inputs {
            if let HostToTarget::StateUpdate {
                key,
                value,
                timestamp,
            } = msg
            {
                self.rec.state(*key, *value, *timestamp);
            }
        }
        let mut wire = self.faults.take_delayed();
        for msg in self.inputs.drain(..) {
            self.faults.tx(&msg, &mut wire);
        }
        wire
    }

    /// Append `grant` to `wire`, retransmitted at once if the link damaged or lost it.
    fn push_grant(&mut self, grant: &HostToTarget, wire: &mut Vec<Vec<u8>>) {
        if !self.faults.tx(grant, wire) {
            wire.push(frame_of(grant));
        }
    }

    /// One message the target sent in the frame `frame` granted at `now`, after the link.
    /// Returns `Some(next_wakeup)` for that frame's FrameDone.
    #[allow(clippy::option_option)]
    fn take_output(
        &mut self,
        msg: TargetToHost,
        now: MissionTimeUs,
        frame: u32,
    ) -> Option<Option<MissionTimeUs>> {
        let msg = self.faults.rx(msg)?;
        self.transcript.received(&msg);
        match &msg {
            TargetToHost::CommandDispatch { id, opcode, args } => {
                self.rec.dispatch(now, *id, *opcode, args);
                let fate = fate_of(&mut self.armed, *opcode, &mut self.fault_rng);
                if fate != CommandFate::Nominal {
                    self.rec.faults.push((
                        now.0,
                        format!("command {id} (opcode {:#06x}): {fate:?}", opcode.0),
                    ));
                }
                self.sim.on_dispatch(now, *id, *opcode, args, fate);
            }
            TargetToHost::Telemetry(ev) => self.rec.telemetry(ev, &self.net.network),
            TargetToHost::FrameDone {
                frame: f,
                next_wakeup,
                ..
            } if *f == frame => return Some(*next_wakeup),
            TargetToHost::Hello { reset_cause, .. } => {
                // The target reset itself (health monitor, watchdog).
                self.rec
                    .reset(now, "target-initiated reset", 0, *reset_cause);
                self.inputs = self.sim.publish_all(now);
            }
            _ => {}
        }
        None
    }
}

/// Run `mission` on `target`.
pub fn drive(
    mission: &MissionPlan,
    target: &mut dyn MissionTarget,
    progress: Progress<'_>,
) -> Result<MissionRun, MissionError> {
    let net = &mission.network;
    let sim = Spacecraft::new(
        &mission.scenario.spacecraft,
        net,
        mission.start,
        mission.seed,
    )
    .map_err(|e| MissionError::Target(TargetError::Other(format!("{}: {}", e.field, e.message))))?;
    let mut host = Host {
        net,
        sim,
        faults: FaultInjector::new(mission.link.clone(), mission.seed),
        fault_rng: Rng::new(mission.seed).fork(0xfa),
        armed: Vec::new(),
        rec: MissionRecord::default(),
        transcript: Transcript::default(),
        inputs: Vec::new(),
    };
    let mut events = mission.events.iter().peekable();

    let hello = target.boot()?;
    host.transcript.received(&hello_message(&hello));
    host.rec.boot(mission.start, hello.reset_cause);
    host.rec.label(
        mission.start,
        format!("boot ({})", crate::scenario::cause_name(hello.reset_cause)),
    );
    uplink(target, net, &mut host.transcript, &mut host.rec)?;

    let mut now = mission.start;
    let wall_start = std::time::Instant::now();
    let pace = |now: MissionTimeUs| {
        if mission.realtime {
            // Real time: the grant for `now` goes out when the wall clock says so.
            let due = wall_start + std::time::Duration::from_micros(now.0 - mission.start.0);
            if let Some(wait) = due.checked_duration_since(std::time::Instant::now()) {
                std::thread::sleep(wait);
            }
        }
    };
    let mut frame: u32 = 0;
    host.inputs = host.sim.publish_all(now);
    let mut zero_advance = 0u32;
    loop {
        // Scenario events due now happen before the grant.
        while let Some(ev) = events.next_if(|e| e.at <= now) {
            match &ev.action {
                Action::WarmReset { recovery_us } | Action::PowerCycle { recovery_us } => {
                    let power = matches!(ev.action, Action::PowerCycle { .. });
                    let what = if power { "power cycle" } else { "warm reset" };
                    let in_frame = if power {
                        None
                    } else {
                        target.mid_frame_reset_request(now)
                    };
                    if power {
                        target.power_cycle()?;
                    } else if let Some(request) = in_frame {
                        // The reset lands inside the frame at `now`, on the target itself: that
                        // frame gets its inputs and grant with the request just before the
                        // grant, and the target resets instead of finishing it.
                        let mut wire = host.input_frames(now);
                        pace(now);
                        let until =
                            next_stop(now, mission, &host.sim, None, events.peek().map(|e| e.at));
                        let grant = HostToTarget::TimeGrant { frame, now, until };
                        // A test instrument, like QMP: never damaged by injected link faults.
                        wire.push(frame_of(&request));
                        host.push_grant(&grant, &mut wire);
                        for f in &wire {
                            host.transcript.sent(f);
                        }
                        for msg in target.exchange_until_reset(&wire, frame)? {
                            // The Hello that ends the frame is the boot's, below.
                            if !matches!(msg, TargetToHost::Hello { .. }) {
                                let _ = host.take_output(msg, now, frame);
                            }
                        }
                        host.rec.frames += 1;
                        frame = frame.wrapping_add(1);
                    } else {
                        target.warm_reset()?;
                    }
                    host.sim.reset(now);
                    // Fault protection runs; the flight software is down.
                    now = now.saturating_add(*recovery_us);
                    let _ = host.sim.due(now);
                    let hello = target.boot()?;
                    host.transcript.received(&hello_message(&hello));
                    let expected = if power {
                        ResetCause::PowerOn
                    } else {
                        ResetCause::Warm
                    };
                    if hello.reset_cause != expected {
                        return Err(MissionError::WrongResetCause {
                            what: what.into(),
                            at: fmt_time(ev.at),
                            expected: crate::scenario::cause_name(expected).into(),
                            got: crate::scenario::cause_name(hello.reset_cause).into(),
                        });
                    }
                    host.rec.reset(ev.at, what, *recovery_us, hello.reset_cause);
                    host.rec.label(
                        now,
                        format!(
                            "flight software restarted ({})",
                            crate::scenario::cause_name(hello.reset_cause)
                        ),
                    );
                    // A power-cycled target has no network in RAM; it restores from NV.
                    host.inputs = host.sim.publish_all(now);
                }
                Action::CommandFault(f) => {
                    host.rec.faults.push((
                        now.0,
                        format!("armed {:?} for opcode {:#06x}", f.fate, f.opcode.0),
                    ));
                    host.armed.push(f.clone());
                }
                Action::Override { key, value, name } => {
                    host.sim.override_state(*key, *value, now);
                    host.rec
                        .faults
                        .push((now.0, format!("{name} forced to {value:?}")));
                }
                Action::Change { key, by, name } => {
                    host.sim.add_to(*key, *by, now).map_err(|e| {
                        MissionError::Target(TargetError::Other(format!(
                            "state_change of {name}: {e}"
                        )))
                    })?;
                    host.rec
                        .faults
                        .push((now.0, format!("{name} changed by {by}")));
                }
            }
        }
        // Frames for this grant: held-back frames, inputs, the grant.
        let mut wire = host.input_frames(now);
        pace(now);
        let until = next_stop(now, mission, &host.sim, None, events.peek().map(|e| e.at));
        let grant = HostToTarget::TimeGrant { frame, now, until };
        host.push_grant(&grant, &mut wire);
        let mut next_wakeup = None;
        let mut attempts = 0;
        loop {
            for f in &wire {
                host.transcript.sent(f);
            }
            let outputs = target.exchange(&wire, frame)?;
            let mut done = false;
            for msg in outputs {
                if let Some(w) = host.take_output(msg, now, frame) {
                    done = true;
                    next_wakeup = w;
                }
            }
            if done {
                break;
            }
            attempts += 1;
            if attempts >= MAX_GRANT_ATTEMPTS {
                return Err(MissionError::LinkDown { frame, attempts });
            }
            wire = vec![frame_of(&grant)];
        }
        host.rec.frames += 1;
        progress(now, mission.start, mission.end);
        if now >= mission.end {
            break;
        }
        let next = next_stop(
            now,
            mission,
            &host.sim,
            next_wakeup,
            events.peek().map(|e| e.at),
        );
        if next <= now {
            zero_advance += 1;
            if zero_advance > MAX_ZERO_ADVANCE_FRAMES {
                return Err(MissionError::Stuck {
                    at: fmt_time(now),
                    frames: zero_advance,
                });
            }
        } else {
            zero_advance = 0;
        }
        now = next.max(now);
        frame = frame.wrapping_add(1);
    }
    let injected = host.faults.injected_tx + host.faults.injected_rx;
    host.rec
        .metrics
        .insert("link_faults_injected".into(), injected);
    let transcript_frames = host.transcript.frames;
    let (transcript_sha256, transcript) = host.transcript.finish();
    Ok(MissionRun {
        record: host.rec,
        transcript_frames,
        transcript_sha256,
        transcript,
        injected_link_faults: injected,
        host_link_errors: host.faults.rx_decoder.counters(),
    })
}

fn hello_message(h: &crate::session::Hello) -> TargetToHost {
    TargetToHost::Hello {
        protocol_version: fsw_bridge::PROTOCOL_VERSION,
        build_id: h.build_id,
        reset_cause: h.reset_cause,
        boot_count: h.boot_count,
    }
}

/// The next time anything needs to happen, never past the mission's end.
fn next_stop(
    now: MissionTimeUs,
    mission: &MissionPlan,
    sim: &Spacecraft,
    wakeup: Option<MissionTimeUs>,
    next_event: Option<MissionTimeUs>,
) -> MissionTimeUs {
    let mut next = mission.end;
    for t in [wakeup, sim.next_event(), next_event].into_iter().flatten() {
        next = next.min(t.max(now));
    }
    if let Some(max) = mission.max_frame_us {
        next = next.min(now.saturating_add(max));
    }
    next
}

fn fate_of(armed: &mut [CommandFault], opcode: Opcode, rng: &mut Rng) -> CommandFate {
    for f in armed.iter_mut().filter(|f| f.opcode == opcode && !f.spent) {
        match &mut f.skip {
            Some(0) => {
                f.spent = true;
                return f.fate;
            }
            Some(n) => *n -= 1,
            None => {
                if rng.chance(f.probability) {
                    return f.fate;
                }
            }
        }
    }
    CommandFate::Nominal
}

/// Send the task network in chunks; every chunk must be acknowledged and the last one
/// validated (UplinkAck with seq == total). Telemetry that arrives meanwhile (the boot's cost
/// metrics) is recorded.
fn uplink(
    target: &mut dyn MissionTarget,
    net: &CompiledNetwork,
    transcript: &mut Transcript,
    rec: &mut MissionRecord,
) -> Result<(), MissionError> {
    let bytes = &net.uplink;
    let chunks: Vec<&[u8]> = bytes.chunks(UPLINK_CHUNK_MAX).collect();
    let total = u16::try_from(chunks.len()).map_err(|_| {
        MissionError::Target(TargetError::Other(
            "the task network is too large to uplink (more than 65535 chunks)".into(),
        ))
    })?;
    for (seq, chunk) in chunks.iter().enumerate() {
        let seq = seq as u16;
        let msg = HostToTarget::UplinkChunk {
            seq,
            total,
            bytes: heapless::Vec::from_slice(chunk).expect("chunk fits"),
        };
        let frame = frame_of(&msg);
        transcript.sent(&frame);
        let last = seq + 1 == total;
        let replies = target.exchange_until(&[frame], &|m| match m {
            TargetToHost::UplinkNak { .. } => true,
            TargetToHost::UplinkAck { seq: s } => (!last && *s == seq) || (last && *s == total),
            _ => false,
        })?;
        for r in &replies {
            transcript.received(r);
            match r {
                TargetToHost::UplinkNak { reason, .. } => {
                    return Err(MissionError::UplinkRefused { reason: *reason })
                }
                TargetToHost::Telemetry(ev) => rec.telemetry(ev, &net.network),
                _ => {}
            }
        }
    }
    Ok(())
}
