//! The I/O partition: the link's owner, and the target's end of the reliable link
//! (`fsw_bridge::link`, CCSDS COP-1 style). The kernel moves the link's bytes (`SYS_LINK_READ`,
//! `SYS_LINK_WRITE`, over the serial line or shared memory); this partition decodes frames,
//! says Hello once per boot (an expedited frame, with the reset cause the kernel determined),
//! answers Ping at once with its decoder counters, and runs the lockstep rounds: every data
//! frame the host's burst carries goes through the link's receiver (delivered exactly once and
//! in order), and at the burst's RoundEnd it answers with its own burst once the round's work is
//! done (the messages it routed handled, the executive's answers and the kernel's news taken in,
//! nobody else busy): retransmissions, new frames within the window, its Report, RoundEnd.
//!
//! It routes TimeGrant, StateUpdate, CommandResponse and UplinkChunk to the executive (where the
//! flight application runs), StateUpdate to the planner, reserved control keys (`abi::control`)
//! to whoever they address, and honours ResetRequest through the kernel (a mid-frame kind is
//! held until the next TimeGrant has been routed, then armed on the executive's work on that
//! grant). In the other direction the executive's and planner's outbound ports, the kernel's
//! log stream and the kernel's events go to the host on the link's Mission or Instrument
//! channel. Host messages wait in order for room in their ports (a full inbound queue refuses
//! further data frames with the link's wait flag: the host sends them again), and a message for
//! the host waits for room in the send window: flow control, not loss.
//!
//! After answering a round, with everything handled and sent, it waits for the host with
//! `SYS_WAIT_FOR_INPUT`: the kernel stops the schedule until the host's next burst.
//!
//! Entry: [`partition_io_main`]; state: `.bss.part.io`.
#![no_std]
// The autonomy core's lints (no panicking path) come from the firmware workspace's
// `[workspace.lints]` (firmware/image/Cargo.toml).

mod link;

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use fsw_bridge::link::{
    downlink_service, LinkConfig, Received, Role, Service, SubmitError, TargetEndpoint,
    VirtualChannel,
};
use fsw_bridge::messages::LOG_CHUNK_MAX;
use fsw_bridge::{
    HostToTarget, ResetCause, ResetKind, StateKey, StateValue, TargetToHost, TelemetryEvent,
    PROTOCOL_VERSION,
};
use kernel_config::abi::{control, reset_at, SysError, REPORT_OFF};
use kernel_logic::event::event_message;
use userlib::port::{Port, PortError};
use userlib::{ports, sys};

use crate::link::Link;

#[link_section = ".bss.part.io"]
static mut LINK: MaybeUninit<Link> = MaybeUninit::uninit();

#[link_section = ".bss.part.io"]
static mut ENDPOINT: MaybeUninit<TargetEndpoint> = MaybeUninit::uninit();

#[link_section = ".bss.part.io"]
static mut INBOUND: MaybeUninit<Inbound> = MaybeUninit::uninit();

/// Delivered host messages still on their way to their ports, in the link's order: a round
/// carries at most a window of new frames on each of the two channels, so a round's messages
/// always fit, whenever the partitions they go to run. Only a host that outruns the window, or
/// partitions that stop taking their messages, meet a full queue: further data frames are then
/// refused with the link's wait flag (sent again by the host), never lost.
const INBOUND_CAPACITY: usize = 2 * LINK_CONFIG.window_width as usize + 4;

type Inbound = heapless::Deque<Routing, INBOUND_CAPACITY>;

/// The reliable link's parameters (the host uses the same).
const LINK_CONFIG: LinkConfig = LinkConfig::DEFAULT;

/// Log bytes per Log message (at most [`LOG_CHUNK_MAX`]). Short frames get through a noisy
/// link: at 5 % byte corruption a frame of 96 log bytes arrives whole 4 times in 1,000 (it would
/// reach the transmission limit, losing the link), one of 32 about 1 time in 10; on a clean
/// link the price is a few bytes of framing per 32.
const LOG_BYTES_PER_FRAME: usize = 32;
const _: () = assert!(LOG_BYTES_PER_FRAME <= LOG_CHUNK_MAX);

/// Messages for the host taken from the kernel or a port and not yet in their channel's send
/// queue (which was full), per channel: at most a batch of kernel events.
const OUTBOUND_HELD_CAPACITY: usize = sys::EVENT_DRAIN_BATCH;

type Held = heapless::Deque<TargetToHost, OUTBOUND_HELD_CAPACITY>;

/// The partition's round state.
struct Rounds {
    /// A RoundEnd came in and its answer has not gone out.
    answer_due: bool,
    /// Mission messages for the host that found the channel's send window and backlog full,
    /// in order. While any wait, nothing more is taken from the partitions' ports (their
    /// messages keep their order), and the round is answered at once.
    mission_held: Held,
    /// The same for the Instrument channel. That channel never holds anything else up: its
    /// sources in the kernel (log bytes, events) wait there while this is not empty, and an
    /// Instrument message from a port that finds this full is dropped and counted. So when
    /// the target answers, and what the Mission channel carries, never depend on the
    /// instrumentation, which differs between boards and runs.
    instrument_held: Held,
    /// Instrument messages dropped since boot (the metric LINK_INSTRUMENT_DROPPED).
    instrument_dropped: u32,
    /// The count last reported to the host.
    instrument_dropped_reported: u32,
    /// Messages for the host the link refused for good (it was lost, or one was too large).
    dropped_for_host: u32,
}

impl Rounds {
    fn held(&mut self, vc: VirtualChannel) -> &mut Held {
        match vc {
            VirtualChannel::Mission => &mut self.mission_held,
            VirtualChannel::Instrument => &mut self.instrument_held,
        }
    }
}

/// The channel `msg` travels on (Hello and Pong go out directly and never come here; a panic
/// report does not either: it is the kernel's).
fn channel_of(msg: &TargetToHost) -> VirtualChannel {
    match downlink_service(msg) {
        Service::Sequenced(vc) => vc,
        Service::Expedited => VirtualChannel::Instrument,
    }
}

extern "C" {
    /// The image's build id (`firmware/image`, stamped by its build script: a hash of every
    /// source that goes into it), in the shared code every partition may read.
    static FIRMWARE_BUILD_ID: [u8; 8];
}

/// The build id of the image this partition runs in.
fn build_id() -> [u8; 8] {
    // SAFETY:
    // 1. The image defines `FIRMWARE_BUILD_ID` as 8 bytes (word-aligned, which [u8; 8] does
    //    not require), never written.
    // 2. It is in the shared code block every partition maps read-only.
    unsafe { FIRMWARE_BUILD_ID }
}

fn reset_cause(code: u32) -> ResetCause {
    match code {
        2 => ResetCause::Warm,
        3 => ResetCause::Watchdog,
        4 => ResetCause::HealthMonitor,
        5 => ResetCause::KernelFault,
        _ => ResetCause::PowerOn,
    }
}

#[no_mangle]
pub extern "C" fn partition_io_main() -> ! {
    // SAFETY: LINK and ENDPOINT are this partition's own statics; entry runs once per
    // (re)start, so these are the only references. `write` initialises them before use.
    let link = unsafe { (*addr_of_mut!(LINK)).write(Link::new()) };
    // SAFETY: as above.
    let endpoint = unsafe {
        (*addr_of_mut!(ENDPOINT)).write(match TargetEndpoint::new(Role::Responder, LINK_CONFIG) {
            Ok(e) => e,
            // The configuration is a constant checked by the link's tests; a partition restart
            // would meet the same error, so the health monitor hears of it as a panic.
            #[allow(clippy::panic)]
            Err(_) => panic!("bad link configuration"),
        })
    };
    // SAFETY: as above.
    let inbound = unsafe { (*addr_of_mut!(INBOUND)).write(Inbound::new()) };
    let (_, generation) = sys::identity();
    if generation == 0 {
        let (cause, boot_count) = sys::boot_info();
        link.send_expedited(&TargetToHost::Hello {
            protocol_version: PROTOCOL_VERSION,
            build_id: build_id(),
            reset_cause: reset_cause(cause),
            boot_count,
            kernel_fault: sys::boot_kernel_fault(),
        });
        link.flush();
    } else {
        // A restarted I/O partition lost the link's state: the host's next round finds the
        // channels closed and opens them again (what was in flight is sent again).
        defmt::warn!("io: restarted, generation {=u32}", generation);
    }
    // A mid-frame reset the host asked for, waiting for the grant it applies to: (mode, value).
    let mut reset_in_next_frame: Option<(u32, u32, bool)> = None;
    let mut rounds = Rounds {
        answer_due: false,
        mission_held: Held::new(),
        instrument_held: Held::new(),
        instrument_dropped: 0,
        instrument_dropped_reported: 0,
        dropped_for_host: 0,
    };
    loop {
        pump_outbound(endpoint, &mut rounds);
        route_inbound(inbound, &mut reset_in_next_frame);
        while let Some(next) = link.poll() {
            let has_room = !inbound.is_full();
            match endpoint.on_frame(next, |_| has_room) {
                Received::Delivered { msg, .. } | Received::Expedited(msg) => {
                    if let Some(routing) = handle(link, &mut reset_in_next_frame, msg) {
                        // Room was checked before the frame was accepted (expedited frames
                        // routed here are control keys, which a full queue refuses too).
                        if inbound.push_back(routing).is_err() {
                            defmt::warn!("io: inbound queue full, a host message dropped");
                        }
                        route_inbound(inbound, &mut reset_in_next_frame);
                    }
                }
                Received::RoundEnd { .. } => rounds.answer_due = true,
                // Damaged frames are counted by the decoder (by reason, in every Pong): a log
                // line each would multiply the traffic of a noisy link.
                Received::Noted | Received::Discarded(_) => {}
            }
        }
        pump_outbound(endpoint, &mut rounds);
        if rounds.answer_due && round_work_done(inbound, &rounds) {
            endpoint.produce_burst(link);
            rounds.answer_due = false;
        }
        link.flush();
        if !inbound.is_empty() || rounds.answer_due {
            // The round's work goes on in the other partitions' windows.
            sys::wait_next_window();
            continue;
        }
        // The round is answered and nothing is left: wait for the host. The kernel stops the
        // schedule if nothing else has work either, and comes back at once if input is already
        // waiting.
        sys::wait_for_input();
    }
}

/// The round's answer can go: either the send queue is full (the answer carries what fits, its
/// Report says more is waiting, and the host comes back for it: waiting would deadlock, as
/// acknowledgements only come with the host's next burst), or every message the round
/// delivered is routed and the executive, which answers the host's grants and uplink chunks,
/// is done with what it was sent (it declared itself idle since; a message to it withdraws
/// that) and its answers are in the send queue (drained by [`pump_outbound`] just before).
/// Other partitions do not hold the answer: the planner's work spans frames, and a partition
/// that never stops (a rogue in an endless loop) must not stop the link.
fn round_work_done(inbound: &Inbound, rounds: &Rounds) -> bool {
    // First: with the Mission send queue full, nothing moves until the host acknowledges,
    // which it does only in its next burst. Host messages may then still wait for a port (the
    // executive stops taking them while its own answers cannot leave): holding the answer
    // for them would deadlock the link. (A full Instrument queue holds nothing up.)
    if !rounds.mission_held.is_empty() {
        return true;
    }
    if !inbound.is_empty() {
        return false;
    }
    let (_reasons, busy) = sys::link_quiet();
    busy & (1 << kernel_config::system::EXECUTIVE) == 0
}

/// Move `vc`'s held messages into the link's send queue, in order, while it has room; true when
/// none is left held.
fn submit_held(endpoint: &mut TargetEndpoint, rounds: &mut Rounds, vc: VirtualChannel) -> bool {
    while let Some(msg) = rounds.held(vc).front() {
        match endpoint.submit(vc, msg) {
            Ok(_) => {}
            Err(SubmitError::Full) => return false,
            Err(_) => {
                // The link is lost (or the message too large): dropped and counted. Logged
                // once per boot only: the log line itself travels on the link, and logging
                // each would feed this loop forever.
                if rounds.dropped_for_host == 0 {
                    defmt::error!("io: messages for the host are being dropped (link lost?)");
                }
                rounds.dropped_for_host = rounds.dropped_for_host.saturating_add(1);
                if vc == VirtualChannel::Instrument {
                    rounds.instrument_dropped = rounds.instrument_dropped.saturating_add(1);
                }
            }
        }
        rounds.held(vc).pop_front();
    }
    true
}

/// Queue `msg` for the host on its channel (held if the channel's send queue is full; an
/// Instrument message that finds its holding queue full too is dropped and counted).
fn submit(endpoint: &mut TargetEndpoint, rounds: &mut Rounds, msg: TargetToHost) {
    let vc = channel_of(&msg);
    if rounds.held(vc).push_back(msg).is_err() {
        // Only the Instrument queue can be full here: Mission messages are taken only while
        // none is held.
        rounds.instrument_dropped = rounds.instrument_dropped.saturating_add(1);
    }
    submit_held(endpoint, rounds, vc);
}

/// Everything waiting for the host, into the link's send queues until they are full: the held
/// messages first; then, while nothing is held for the Instrument channel, the kernel's log
/// bytes and events (a batch at a time; they wait in the kernel otherwise) and the count of
/// dropped Instrument messages if it grew; then, while nothing is held for the Mission channel,
/// the partitions' messages.
fn pump_outbound(endpoint: &mut TargetEndpoint, rounds: &mut Rounds) {
    let mission_room = submit_held(endpoint, rounds, VirtualChannel::Mission);
    if submit_held(endpoint, rounds, VirtualChannel::Instrument) {
        pump_kernel(endpoint, rounds);
    }
    if mission_room {
        pump_ports(endpoint, rounds);
    }
}

/// The kernel's log bytes and events, and the dropped-message count, while the Instrument
/// channel takes them.
fn pump_kernel(endpoint: &mut TargetEndpoint, rounds: &mut Rounds) {
    if rounds.instrument_dropped != rounds.instrument_dropped_reported {
        rounds.instrument_dropped_reported = rounds.instrument_dropped;
        let count = TargetToHost::Telemetry(TelemetryEvent::Metric {
            id: kernel_config::abi::metric::LINK_INSTRUMENT_DROPPED,
            value: u64::from(rounds.instrument_dropped),
        });
        submit(endpoint, rounds, count);
    }
    while rounds.instrument_held.is_empty() {
        let mut chunk = [0u8; LOG_BYTES_PER_FRAME];
        let n = sys::log_drain(&mut chunk);
        if n == 0 {
            break;
        }
        let log = TargetToHost::Log {
            bytes: heapless::Vec::from_slice(chunk.get(..n).unwrap_or_default())
                .unwrap_or_default(),
        };
        submit(endpoint, rounds, log);
    }
    while rounds.instrument_held.is_empty() {
        let mut records = [[0u32; 4]; OUTBOUND_HELD_CAPACITY];
        let n = sys::event_drain(&mut records);
        for record in records.iter().take(n) {
            if let Some(msg) = event_message(record) {
                submit(endpoint, rounds, msg);
            }
        }
        if n < records.len() {
            break;
        }
    }
}

/// The ports that carry partitions' messages for the host (the test image adds the rogue's).
const OUTBOUND_PORTS: [Port<TargetToHost>; if cfg!(feature = "test-partitions") {
    3
} else {
    2
}] = [
    ports::EXECUTIVE_TO_IO,
    ports::PLANNER_TO_IO,
    #[cfg(feature = "test-partitions")]
    ports::ROGUE_TO_IO,
];

/// The partitions' messages for the host, while the Mission channel takes them.
fn pump_ports(endpoint: &mut TargetEndpoint, rounds: &mut Rounds) {
    for port in OUTBOUND_PORTS {
        while rounds.mission_held.is_empty() {
            match port.receive() {
                Ok(Some(got)) => submit(endpoint, rounds, got.value),
                Ok(None) | Err(PortError::Sys(_) | PortError::TooBig) => break,
                Err(PortError::Undecodable) => {
                    defmt::warn!("io: undecodable message on port {=usize}", port.id())
                }
            }
        }
    }
}

/// A host message on its way to up to two ports (a state update goes to the executive and to
/// the planner); a port it has reached is taken off.
struct Routing {
    msg: HostToTarget,
    to: [Option<Port<HostToTarget>>; 2],
}

impl Routing {
    fn to(msg: HostToTarget, port: Port<HostToTarget>) -> Self {
        Self {
            msg,
            to: [Some(port), None],
        }
    }
}

/// Why a message did not reach a port.
enum RouteError {
    /// The port is full: try again after its destination has run.
    Full,
    /// Refused for good (logged).
    Refused,
}

/// Queue `msg` on `port`.
fn route(port: Port<HostToTarget>, msg: &HostToTarget) -> Result<(), RouteError> {
    match port.send(msg) {
        Ok(()) => Ok(()),
        Err(PortError::Sys(SysError::Full)) => Err(RouteError::Full),
        Err(PortError::Sys(error)) => {
            defmt::warn!(
                "io: port {=usize} refused a message ({=i32})",
                port.id(),
                error.code()
            );
            Err(RouteError::Refused)
        }
        Err(PortError::TooBig | PortError::Undecodable) => {
            defmt::warn!("io: message too large for port {=usize}", port.id());
            Err(RouteError::Refused)
        }
    }
}

/// Route the inbound messages, oldest first, until one meets a full port (it and those behind
/// it wait: the order the host sent them in is the order their partitions see).
fn route_inbound(inbound: &mut Inbound, reset_in_next_frame: &mut Option<(u32, u32, bool)>) {
    while let Some(routing) = inbound.pop_front() {
        if let Some(left) = deliver(routing, reset_in_next_frame) {
            // Cannot fail: one was just taken off.
            let _ = inbound.push_front(left);
            return;
        }
    }
}

/// Deliver `routing` to the ports it still has to reach; what is left if one is full.
fn deliver(
    mut routing: Routing,
    reset_in_next_frame: &mut Option<(u32, u32, bool)>,
) -> Option<Routing> {
    let mut delivered = false;
    for slot in routing.to.iter_mut() {
        let Some(port) = *slot else {
            continue;
        };
        match route(port, &routing.msg) {
            Ok(()) => delivered = true,
            Err(RouteError::Full) => return Some(routing),
            Err(RouteError::Refused) => {}
        }
        *slot = None;
    }
    if delivered && matches!(routing.msg, HostToTarget::TimeGrant { .. }) {
        // The grant is now the last message for the executive: the kernel counts the
        // executive's work from its receipt.
        if let Some((mode, value, planner)) = reset_in_next_frame.take() {
            // In the planner's work: on the executive's first message to it after the grant.
            let chain = planner.then_some(ports::EXECUTIVE_TO_PLANNER.id());
            if let Err(error) = sys::arm_reset(mode, value, ports::IO_TO_EXECUTIVE.id(), chain) {
                defmt::warn!(
                    "io: the kernel refused the mid-frame reset ({=i32})",
                    error.code()
                );
            }
        }
    }
    None
}

/// Act on one host message; a message for partitions is returned, to be routed in order.
fn handle(
    link: &mut Link,
    reset_in_next_frame: &mut Option<(u32, u32, bool)>,
    msg: HostToTarget,
) -> Option<Routing> {
    let routing = match msg {
        HostToTarget::Ping { seq } => {
            // A link check, outside the rounds: answered at once.
            link.send_expedited(&TargetToHost::Pong {
                seq,
                link: link.counters(),
            });
            link.flush();
            return None;
        }
        HostToTarget::ResetRequest { kind } => {
            match kind {
                ResetKind::Warm => {
                    defmt::info!("reset requested by host: warm");
                    // What was answered before the request leaves first.
                    link.flush();
                    sys::reset_module();
                }
                ResetKind::WarmAfterTicks { ticks } => {
                    defmt::info!("reset requested by host: warm, {=u32} ticks into the executive's next frame", ticks);
                    *reset_in_next_frame = Some((reset_at::AFTER_TICKS, ticks, false));
                }
                ResetKind::WarmDuringCheckpointWrite { permille } => {
                    defmt::info!("reset requested by host: warm, {=u16} permille into the next checkpoint write", permille);
                    *reset_in_next_frame = Some((
                        reset_at::IN_WARM_WRITE,
                        u32::from(permille.min(1000)),
                        false,
                    ));
                }
                ResetKind::PlannerAfterTicks { ticks } => {
                    defmt::info!("reset requested by host: warm, {=u32} ticks into the planner's work on the next frame", ticks);
                    *reset_in_next_frame = Some((reset_at::AFTER_TICKS, ticks, true));
                }
                ResetKind::PlannerDuringCheckpointWrite { permille } => {
                    defmt::info!("reset requested by host: warm, {=u16} permille into the planner's next checkpoint write", permille);
                    *reset_in_next_frame =
                        Some((reset_at::IN_WARM_WRITE, u32::from(permille.min(1000)), true));
                }
            }
            return None;
        }
        HostToTarget::TimeGrant { now, .. } => {
            sys::set_mission_time(now.0);
            Routing::to(msg, ports::IO_TO_EXECUTIVE)
        }
        HostToTarget::StateUpdate {
            key: StateKey(key), ..
        } if key >= control::FIRST => control(key, msg)?,
        HostToTarget::StateUpdate { .. } => Routing {
            msg,
            to: [Some(ports::IO_TO_EXECUTIVE), Some(ports::IO_TO_PLANNER)],
        },
        // The flight application (autonomy core) runs in the executive partition.
        HostToTarget::CommandResponse { .. }
        | HostToTarget::UplinkChunk { .. }
        | HostToTarget::GroundCommand { .. } => Routing::to(msg, ports::IO_TO_EXECUTIVE),
        // Temporal planning jobs and the lander executor are the planner partition's.
        HostToTarget::TemporalBegin { .. }
        | HostToTarget::TemporalChunk { .. }
        | HostToTarget::LanderBegin { .. }
        | HostToTarget::LanderChunk { .. }
        | HostToTarget::LanderStep { .. }
        | HostToTarget::LanderInput { .. }
        | HostToTarget::Rover { .. } => Routing::to(msg, ports::IO_TO_PLANNER),
    };
    Some(routing)
}

/// A reserved control key: acted on here, or the routing to whoever it addresses.
fn control(key: u16, msg: HostToTarget) -> Option<Routing> {
    match key {
        control::REQUEST_METRICS => {
            let period = match msg {
                HostToTarget::StateUpdate {
                    value: StateValue::Int(n),
                    ..
                } if n > 0 => u32::try_from(n).unwrap_or(u32::MAX - 1),
                HostToTarget::StateUpdate {
                    value: StateValue::Int(n),
                    ..
                } if n < 0 => REPORT_OFF,
                _ => 0,
            };
            sys::request_metrics(period);
            None
        }
        control::PLANNER_CHECKSUM | control::PLANNER_BUDGET => {
            Some(Routing::to(msg, ports::IO_TO_PLANNER))
        }
        control::SYSCALL_BENCH => Some(Routing::to(msg, ports::IO_TO_EXECUTIVE)),
        #[cfg(feature = "test-partitions")]
        control::ROGUE_MODE => Some(Routing::to(msg, ports::IO_TO_ROGUE)),
        _ => {
            defmt::warn!("io: unknown control key {=u16:#x}", key);
            None
        }
    }
}
