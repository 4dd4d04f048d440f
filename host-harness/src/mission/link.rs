//! The host's end of the reliable link during a mission (`fsw_bridge::link`, CCSDS COP-1 style)
//! together with the seeded fault injector and the transcript.
//!
//! Every message the host sends in a mission goes through [`LinkSession::send`]: it is queued on
//! its virtual channel and delivered exactly once and in order, or the run ends with the link
//! lost. [`LinkSession::exchange`] runs lockstep rounds with the target (a burst each way, each
//! ended by the never-damaged RoundEnd doorbell) until everything queued is acknowledged, the
//! target has nothing more on the Mission channel, and what the caller waits for (a FrameDone,
//! the uplink's final acknowledgement) has been delivered. Rounds, not host time, count every
//! timeout, so a result never depends on how fast the host is.
//!
//! Faults come from `fsw_bridge::link::channel::LossyChannel`: whether a byte is corrupted or a
//! frame dropped, duplicated or delayed by a round is a pure function of the seed, the direction,
//! the frame's identity (virtual channel and sequence number for data frames) and its
//! transmission attempt. The native and the emulated target send the same Mission stream, so
//! they meet the same faults; Instrument traffic (costs, logs, kernel events, which only the
//! emulated target sends) travels in whatever rounds there are and never changes the round
//! sequence.
//!
//! The transcript has one line per frame both ways. Its hash covers the Mission channel, the
//! rounds, the expedited frames and the Mission half of each Report, which are the same run to
//! run; Instrument frames (whose costs and log timestamps vary by a tick) are listed but not
//! hashed, and neither are the instrumentation messages the kernel sends expedited as its last
//! words before a reset (found by a mid-frame reset test that failed about one run in ten under
//! load: the last log line's timestamp took one more varint byte).
use fsw_bridge::codec::FrameDecoder;
use fsw_bridge::link::channel::LossyChannel;
use fsw_bridge::link::faults::{Direction, FaultRates};
use fsw_bridge::link::{
    downlink_service, uplink_service, HostEndpoint, LinkConfig, LinkFrame, LinkLost, LinkMessage,
    MessageClass, Received, Role, Service, VirtualChannel,
};
use fsw_bridge::{HostToTarget, TargetToHost, TelemetryEvent};
use serde::Serialize;
use sha2::{Digest, Sha256};

use super::plan::LinkFaults;
use super::target::{MissionTarget, TargetError};

/// Rounds one exchange may take before the link is declared lost even though the transmission
/// limit was not reached (a target that keeps answering without ever settling, e.g. because it
/// keeps saying it is busy). A flyby uplink over a link that corrupts 5 % of the bytes takes a
/// few hundred rounds.
pub const MAX_ROUNDS_PER_EXCHANGE: u32 = 20_000;

/// True for the metrics only the emulated target sends (measured guest costs and the
/// platform's metrics): the telemetry dictionary puts them on the Instrument channel. The same
/// answer on both targets.
pub fn is_instrument_metric(id: u16) -> bool {
    fsw_bridge::dictionary::metric_channel(id) == VirtualChannel::Instrument
}

/// The virtual channel (or expedited service) of a target message.
pub fn service_of(msg: &TargetToHost) -> Service {
    downlink_service(msg)
}

/// How an exchange ended.
#[derive(Debug)]
pub enum Exchanged {
    /// Everything was delivered both ways and the awaited message arrived.
    Settled,
    /// The target said Hello in the middle of the exchange: it reset itself (a mid-frame reset
    /// the host armed, or its health monitor). What was not acknowledged is lost with the
    /// reset (counted); the link restarts.
    TargetReset(TargetToHost),
}

/// Why the mission could not go on over the link.
#[derive(Debug, thiserror::Error)]
pub enum LinkFailure {
    #[error("link lost: {0}")]
    Lost(LinkLost),
    #[error("link lost: {rounds} rounds without settling (Mission channel: {detail})")]
    NotSettling { rounds: u32, detail: String },
    #[error(transparent)]
    Target(#[from] TargetError),
}

/// Retransmissions and faults, for the report.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LinkSummary {
    /// Lockstep rounds (each one burst each way).
    pub rounds: u64,
    /// Per message class, both directions.
    pub classes: Vec<ClassSummary>,
    /// Data frames sent again: the host's retransmissions, plus the target's as the host saw
    /// them arrive again (or discarded them for a gap before them).
    pub retransmissions: u64,
    /// Frames the host's decoder rejected (damaged on the way).
    pub frames_rejected: u64,
    /// Host messages unacknowledged when the target reset (lost with it, as in flight).
    pub lost_to_reset: u64,
    /// Faults injected: (uplink, downlink) frames corrupted, dropped, duplicated, delayed.
    pub injected_uplink: u64,
    pub injected_downlink: u64,
    /// Retransmitted frames per 1,000 frames sent (both directions, both channels).
    pub retransmissions_per_1000_frames: u64,
    /// Rounds run after the mission, not counted above, to bring in what the target still had
    /// queued on the Instrument channel (costs, logs).
    pub instrument_drain_rounds: u64,
    /// Whether that channel emptied (false: some instrumentation never arrived; the report
    /// says so).
    pub instrument_drained: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct ClassSummary {
    pub class: &'static str,
    /// Sent by the host (first transmissions) and sent again.
    pub sent: u64,
    pub retransmitted: u64,
    /// Delivered to the host, and arrived again or out of sequence (the target's resends).
    pub received: u64,
    pub received_again: u64,
}

/// The host's end of the link for one mission.
pub struct LinkSession {
    endpoint: Box<HostEndpoint>,
    channel: LossyChannel,
    decoder: FrameDecoder,
    /// Expedited messages for the next burst.
    expedited: Vec<HostToTarget>,
    rounds: u64,
    transcript: Transcript,
    /// Messages the current exchange delivered so far.
    delivered: Vec<TargetToHost>,
    /// Target-to-host data frames the host discarded as duplicates or out of sequence, per
    /// message class: what the target had to send (or sent) again.
    downlink_discards: std::collections::BTreeMap<&'static str, u64>,
}

impl LinkSession {
    pub fn new(seed: u64, faults: &LinkFaults) -> Self {
        let endpoint = Box::new(
            HostEndpoint::new(Role::Initiator, LinkConfig::DEFAULT)
                .expect("the default link configuration is valid"),
        );
        let rates = FaultRates::from_probabilities(faults.corrupt, faults.drop, 0.0, faults.delay);
        Self {
            endpoint,
            channel: LossyChannel::new(seed, rates),
            decoder: FrameDecoder::new(),
            expedited: Vec::new(),
            rounds: 0,
            transcript: Transcript::default(),
            downlink_discards: Default::default(),
            delivered: Vec::new(),
        }
    }

    /// Queue `msg` for delivery (exactly once and in order on its channel).
    pub fn send(&mut self, msg: HostToTarget) -> Result<(), LinkFailure> {
        match uplink_service(&msg) {
            Service::Expedited => self.expedited.push(msg),
            Service::Sequenced(vc) => {
                self.endpoint.submit(vc, &msg).map_err(|e| {
                    LinkFailure::Lost(self.endpoint.lost().copied().unwrap_or_else(|| {
                        panic!("the host's send queue refused a message ({e:?}): {msg:?}")
                    }))
                })?;
            }
        }
        Ok(())
    }

    /// The target (re)started: restart the link (what was queued is counted lost to reset).
    pub fn reset(&mut self) {
        self.endpoint.reset();
        self.decoder = FrameDecoder::new();
        self.expedited.clear();
    }

    /// Record the Hello that opened the session (it comes from the target's boot, outside any
    /// round).
    pub fn hello(&mut self, hello: &TargetToHost) {
        self.transcript
            .line(true, format!("< BD {}", describe(hello)));
    }

    /// Run rounds until everything queued is acknowledged, the target has nothing more on the
    /// Mission channel, and `until` matched a delivered message (`until` = None: settling is
    /// enough). Returns how it ended and every message delivered, in order.
    pub fn exchange(
        &mut self,
        target: &mut dyn MissionTarget,
        until: Option<&mut dyn FnMut(&TargetToHost) -> bool>,
    ) -> Result<(Exchanged, Vec<TargetToHost>), LinkFailure> {
        self.rounds_until(target, until, false, MAX_ROUNDS_PER_EXCHANGE)
    }

    /// After the mission (and after [`LinkSession::finish_transcript`]): rounds with nothing
    /// new from the host until the Instrument channel has delivered what the target still had
    /// queued (costs, logs), at most `max_rounds`. Returns the rounds run, whether everything
    /// arrived, and what was delivered. These rounds are not part of the mission's figures:
    /// how many there are depends on the instrumentation, which differs between boards.
    pub fn drain_instrument(
        &mut self,
        target: &mut dyn MissionTarget,
        max_rounds: u32,
    ) -> Result<(u32, bool, Vec<TargetToHost>), LinkFailure> {
        let rounds_before = self.rounds;
        let result = self.rounds_until(target, None, true, max_rounds);
        let rounds = (self.rounds - rounds_before) as u32;
        self.rounds = rounds_before;
        match result {
            Ok((_, delivered)) => Ok((rounds, true, delivered)),
            Err(LinkFailure::NotSettling { .. }) => Ok((rounds, false, self.take_stranded())),
            Err(e) => Err(e),
        }
    }

    fn rounds_until(
        &mut self,
        target: &mut dyn MissionTarget,
        mut until: Option<&mut dyn FnMut(&TargetToHost) -> bool>,
        all_channels: bool,
        max_rounds: u32,
    ) -> Result<(Exchanged, Vec<TargetToHost>), LinkFailure> {
        let mut matched = until.is_none();
        // Kept in the session until the exchange returns them: if it fails, what arrived
        // before the failure is still there for the report ([`LinkSession::take_stranded`]).
        self.delivered.clear();
        for _ in 0..max_rounds {
            let mut burst: Vec<Vec<u8>> = Vec::new();
            for msg in std::mem::take(&mut self.expedited) {
                let _ = self
                    .endpoint
                    .send_expedited(&msg, &mut |f: &[u8]| burst.push(f.to_vec()));
            }
            let summary = self
                .endpoint
                .produce_burst(&mut |f: &[u8]| burst.push(f.to_vec()));
            if let Some(lost) = self.endpoint.lost() {
                return Err(LinkFailure::Lost(*lost));
            }
            let round = summary.round;
            self.rounds += 1;
            let wire = self
                .channel
                .carry::<HostToTarget>(Direction::Uplink, round, &burst, |_| false);
            self.transcript
                .burst::<HostToTarget>(round, '>', &burst, &wire);
            let reply = target.round(&wire, round)?;
            // The target's expedited frames are its boot and reset announcements (Hello, a
            // panic report, the kernel's last words before a reset): never damaged.
            let received =
                self.channel
                    .carry::<TargetToHost>(Direction::Downlink, round, &reply, |_| true);
            self.transcript
                .burst::<TargetToHost>(round, '<', &reply, &received);
            for bytes in &received {
                for &b in bytes {
                    let Some(frame) = self.decoder.push::<LinkFrame<TargetToHost>>(b) else {
                        continue;
                    };
                    let class = match &frame {
                        Ok(LinkFrame::Ad { msg, .. }) => Some(msg.class()),
                        _ => None,
                    };
                    match self.endpoint.on_frame(frame, |_| true) {
                        Received::Delivered { msg, .. } => {
                            if let Some(until) = until.as_mut() {
                                matched |= until(&msg);
                            }
                            self.delivered.push(msg);
                        }
                        Received::Expedited(msg @ TargetToHost::Hello { .. }) => {
                            self.reset();
                            return Ok((
                                Exchanged::TargetReset(msg),
                                std::mem::take(&mut self.delivered),
                            ));
                        }
                        Received::Expedited(TargetToHost::Panic { file, line }) => {
                            return Err(LinkFailure::Target(TargetError::Panic {
                                file: String::from_utf8_lossy(&file).into_owned(),
                                line,
                            }));
                        }
                        // The kernel's last words before a reset it makes (events, logs).
                        Received::Expedited(msg) => self.delivered.push(msg),
                        Received::Discarded(
                            fsw_bridge::link::Discard::Duplicate { .. }
                            | fsw_bridge::link::Discard::OutOfSequence { .. },
                        ) => {
                            // A frame the target sent again, or will have to: counted as the
                            // target's retransmission of its class.
                            if let Some(class) = class {
                                *self.downlink_discards.entry(class.name()).or_insert(0) += 1;
                            }
                        }
                        _ => {}
                    }
                }
            }
            if let Some(lost) = self.endpoint.lost() {
                return Err(LinkFailure::Lost(*lost));
            }
            let settled = if all_channels {
                self.endpoint.is_all_settled()
            } else {
                self.endpoint.is_settled(VirtualChannel::Mission)
            };
            if matched && settled {
                return Ok((Exchanged::Settled, std::mem::take(&mut self.delivered)));
            }
        }
        let fop = self.endpoint.fop(VirtualChannel::Mission);
        Err(LinkFailure::NotSettling {
            rounds: max_rounds,
            detail: format!(
                "host V(S) {} acknowledged to {}, received to V(R) {}, target reported V(S) {}",
                fop.v_s(),
                fop.nn_r(),
                self.endpoint.farm(VirtualChannel::Mission).v_r(),
                self.endpoint.peer().sent_vs[VirtualChannel::Mission.index()],
            ),
        })
    }

    /// What a failed exchange had delivered before it failed, in order (then nothing).
    pub fn take_stranded(&mut self) -> Vec<TargetToHost> {
        std::mem::take(&mut self.delivered)
    }

    /// Retransmissions and faults so far.
    pub fn summary(&self) -> LinkSummary {
        let stats = self.endpoint.stats();
        let mut classes = Vec::new();
        let (mut retransmissions, mut frames) = (0u64, 0u64);
        for class in MessageClass::ALL {
            let c = stats.class(class);
            let received_again = self
                .downlink_discards
                .get(class.name())
                .copied()
                .unwrap_or(0);
            if c.sent == 0 && c.retransmissions == 0 && c.delivered == 0 && received_again == 0 {
                continue;
            }
            retransmissions += u64::from(c.retransmissions) + received_again;
            frames += u64::from(c.sent)
                + u64::from(c.retransmissions)
                + u64::from(c.delivered)
                + received_again;
            classes.push(ClassSummary {
                class: class.name(),
                sent: u64::from(c.sent),
                retransmitted: u64::from(c.retransmissions),
                received: u64::from(c.delivered),
                received_again,
            });
        }
        let injected = |d| self.channel.injected(d).total();
        LinkSummary {
            rounds: self.rounds,
            classes,
            retransmissions,
            frames_rejected: u64::from(stats.frames_rejected),
            lost_to_reset: stats.sent.iter().map(|s| u64::from(s.lost_to_reset)).sum(),
            injected_uplink: injected(Direction::Uplink),
            injected_downlink: injected(Direction::Downlink),
            retransmissions_per_1000_frames: (retransmissions * 1000)
                .checked_div(frames)
                .unwrap_or(0),
            instrument_drain_rounds: 0,
            instrument_drained: true,
        }
    }

    /// Faults injected so far, both directions.
    pub fn injected_faults(&self) -> u64 {
        self.channel.injected(Direction::Uplink).total()
            + self.channel.injected(Direction::Downlink).total()
    }

    /// The transcript: (frames recorded, SHA-256 of its hashed part, every line).
    pub fn finish_transcript(&mut self) -> (u64, String, Vec<String>) {
        std::mem::take(&mut self.transcript).finish()
    }
}

/// Every frame both ways, one line each, and a running hash of the part that is the same run
/// to run (see the module documentation).
#[derive(Default)]
struct Transcript {
    hasher: Sha256,
    lines: Vec<String>,
    frames: u64,
}

impl Transcript {
    fn line(&mut self, hashed: bool, text: String) {
        if hashed {
            self.hasher.update(text.as_bytes());
            self.hasher.update(b"\n");
        }
        if std::env::var_os("HIL_DEBUG_TRANSCRIPT").is_some() {
            eprintln!("{text}");
        }
        self.lines.push(if hashed {
            text
        } else {
            format!("{text}  (not hashed)")
        });
    }

    /// One burst: what the sender wrote (`sent`) and what crossed the link (`crossed`).
    fn burst<M: fsw_bridge::codec::WireMessage + Describe>(
        &mut self,
        round: u32,
        arrow: char,
        sent: &[Vec<u8>],
        crossed: &[Vec<u8>],
    ) {
        self.frames += sent.len() as u64;
        for bytes in crossed {
            let lines = match decode_one::<M>(bytes) {
                // Which channel it was on is unknowable: an Instrument frame's length (and so
                // where the faults fell) can differ by a byte run to run.
                None => vec![(false, format!("damaged frame, {} bytes", bytes.len()))],
                Some(frame) => frame_lines(&frame),
            };
            for (hashed, text) in lines {
                self.line(hashed, format!("r{round} {arrow} {text}"));
            }
        }
        if crossed.len() < sent.len() {
            self.line(
                false,
                format!(
                    "r{round} {arrow} ({} frame(s) dropped or held back)",
                    sent.len() - crossed.len()
                ),
            );
        }
    }

    fn finish(self) -> (u64, String, Vec<String>) {
        let hash = self
            .hasher
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        (self.frames, hash, self.lines)
    }
}

/// A message as a transcript line shows it.
pub trait Describe {
    fn describe(&self) -> String;

    /// Instrumentation (logs, cost metrics, health events): what the Instrument channel
    /// carries. The kernel's last words before a reset are such messages sent expedited; like
    /// the Instrument channel they stay out of the transcript's hash, because a log's guest
    /// timestamp (and so its length) and a measured tick count depend on where between two
    /// timebase ticks the work started, which depends on how long the guest waited for the host.
    fn is_instrumentation(&self) -> bool {
        false
    }
}

impl Describe for HostToTarget {
    fn describe(&self) -> String {
        match self {
            HostToTarget::UplinkChunk { seq, total, bytes } => {
                format!(
                    "UplinkChunk {{ seq: {seq}, total: {total}, {} bytes }}",
                    bytes.len()
                )
            }
            HostToTarget::GroundCommand {
                header,
                command,
                mac,
            } => format!(
                "GroundCommand {{ spi: {}, sequence: {}, {command:?}, mac {} bytes {:02x}{:02x}.. }}",
                header.spi,
                header.sequence,
                mac.len(),
                mac.first().copied().unwrap_or(0),
                mac.get(1).copied().unwrap_or(0),
            ),
            other => format!("{other:?}"),
        }
    }
}

impl Describe for TargetToHost {
    fn describe(&self) -> String {
        match self {
            TargetToHost::Log { bytes } => format!("Log {{ {} bytes }}", bytes.len()),
            other => format!("{other:?}"),
        }
    }

    fn is_instrumentation(&self) -> bool {
        service_of(self) == Service::Sequenced(VirtualChannel::Instrument)
    }
}

fn describe(msg: &impl Describe) -> String {
    msg.describe()
}

/// The transcript lines of one decoded link frame: (hashed, text).
fn frame_lines<M: Describe>(frame: &LinkFrame<M>) -> Vec<(bool, String)> {
    match frame {
        LinkFrame::Ad { vc, ns, msg } => vec![(
            *vc == VirtualChannel::Mission,
            format!("AD {}#{ns} {}", vc.name(), msg.describe()),
        )],
        LinkFrame::Bd(msg) => vec![(!msg.is_instrumentation(), format!("BD {}", msg.describe()))],
        LinkFrame::Bc { round, directive } => vec![(true, format!("BC r{round} {directive:?}"))],
        LinkFrame::Report(r) => {
            let (m, i) = (
                VirtualChannel::Mission.index(),
                VirtualChannel::Instrument.index(),
            );
            vec![
                (
                    true,
                    format!(
                        "Report r{} mission {{ {:?}, V(S) {}, backlog {} }}",
                        r.round, r.clcw[m], r.sent_vs[m], r.backlog[m]
                    ),
                ),
                (
                    false,
                    format!(
                        "       instrument {{ {:?}, V(S) {}, backlog {} }}",
                        r.clcw[i], r.sent_vs[i], r.backlog[i]
                    ),
                ),
            ]
        }
        LinkFrame::RoundEnd { round } => vec![(true, format!("RoundEnd r{round}"))],
    }
}

/// The single frame `bytes` hold, if they hold exactly one valid frame.
fn decode_one<M: fsw_bridge::codec::WireMessage>(bytes: &[u8]) -> Option<LinkFrame<M>> {
    let mut decoder = FrameDecoder::new();
    let mut found = None;
    for &b in bytes {
        match decoder.push::<LinkFrame<M>>(b) {
            Some(Ok(frame)) if found.is_none() => found = Some(frame),
            Some(_) => return None,
            None => {}
        }
    }
    found
}

/// A measured-cost metric on the transcript (for readers): the telemetry dictionary's kind.
pub fn is_cost_metric(msg: &TargetToHost) -> bool {
    matches!(msg, TargetToHost::Telemetry(TelemetryEvent::Metric { id, .. }) if fsw_bridge::dictionary::is_measured_cost(*id))
}

#[cfg(test)]
mod transcript_tests {
    use super::*;
    use fsw_bridge::TelemetryEvent;

    #[test]
    fn expedited_instrumentation_is_listed_but_not_hashed() {
        let log = LinkFrame::Bd(TargetToHost::Log {
            bytes: heapless::Vec::from_slice(&[1, 2, 3]).unwrap(),
        });
        let metric = LinkFrame::Bd(TargetToHost::Telemetry(TelemetryEvent::Metric {
            id: 545,
            value: 1508,
        }));
        let pong = LinkFrame::Bd(TargetToHost::Pong {
            seq: 7,
            link: Default::default(),
        });
        assert_eq!(
            frame_lines(&log),
            vec![(false, "BD Log { 3 bytes }".to_string())]
        );
        assert!(!frame_lines(&metric)[0].0);
        assert!(frame_lines(&pong)[0].0, "a Pong is part of the exchange");
    }
}
