//! The I/O partition: the link's owner. The kernel moves the link's bytes (`SYS_LINK_READ`,
//! `SYS_LINK_WRITE`, over the serial line or shared memory); this partition runs the frame
//! codec, says Hello once per boot (with the reset cause the kernel determined), answers
//! Ping with its decoder counters, honours ResetRequest through the kernel (a mid-frame kind is
//! held until the next TimeGrant has been routed, then armed on the executive's work on that
//! grant), and routes:
//! TimeGrant, StateUpdate, CommandResponse and UplinkChunk to the executive (where the flight
//! application runs), StateUpdate to the planner, and reserved control keys (`abi::control`) to whoever they address; in the
//! other direction the executive's and planner's outbound ports, the kernel's log stream and
//! the kernel's events (health monitor, metrics) go to the host. A message for a full port is
//! held (and nothing more decoded) until its destination has made room.
//!
//! When everything received is handled and everything for the host has left, it waits for the
//! host with `SYS_WAIT_FOR_INPUT`: at the end of a lockstep round (FrameDone and what came
//! before it sent, nobody else busy) the kernel stops the schedule until the host's next bytes.
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use fsw_bridge::messages::LOG_CHUNK_MAX;
use fsw_bridge::{
    HostToTarget, ResetCause, ResetKind, StateKey, StateValue, TargetToHost, PROTOCOL_VERSION,
};
use kernel_config::abi::{control, reset_at, E_FULL, REPORT_OFF};
use kernel_config::system::{
    OUTBOUND_MESSAGE_SIZE, PORT_EXECUTIVE_TO_IO, PORT_IO_TO_EXECUTIVE, PORT_IO_TO_PLANNER,
    PORT_PLANNER_TO_IO, ROUTED_MESSAGE_SIZE,
};

use crate::link::Link;
use crate::sys;

#[link_section = ".bss.part.io"]
static mut LINK: MaybeUninit<Link> = MaybeUninit::uninit();

fn reset_cause(code: u32) -> ResetCause {
    match code {
        2 => ResetCause::Warm,
        3 => ResetCause::Watchdog,
        4 => ResetCause::HealthMonitor,
        _ => ResetCause::PowerOn,
    }
}

#[no_mangle]
pub extern "C" fn partition_io_main() -> ! {
    // SAFETY: LINK is this partition's own static; entry runs once per (re)start, so this is the
    // only reference. `write` initialises it before use.
    let link = unsafe { (*addr_of_mut!(LINK)).write(Link::new()) };
    let (_, generation) = sys::identity();
    if generation == 0 {
        let (cause, boot_count) = sys::boot_info();
        link.send(&TargetToHost::Hello {
            protocol_version: PROTOCOL_VERSION,
            build_id: crate::BUILD_ID,
            reset_cause: reset_cause(cause),
            boot_count,
        });
    } else {
        defmt::warn!("io: restarted, generation {=u32}", generation);
    }
    // A mid-frame reset the host asked for, waiting for the grant it applies to: (mode, value).
    let mut reset_in_next_frame: Option<(u32, u32)> = None;
    // A message waiting for room in a port (nothing more is decoded until it is delivered, so
    // the host's bytes wait in the kernel's ring and then in the UART: flow control, not loss).
    let mut held: Option<Routing> = None;
    loop {
        pump_outbound(link);
        if let Some(routing) = held.take() {
            held = deliver(routing, &mut reset_in_next_frame);
        }
        while held.is_none() {
            let Some(next) = link.poll() else {
                break;
            };
            match next {
                Ok(msg) => held = handle(link, &mut reset_in_next_frame, msg),
                Err(error) => {
                    defmt::warn!("link: frame rejected: {=str}", decode_error_name(error))
                }
            }
            pump_outbound(link);
        }
        link.flush();
        if held.is_some() {
            // Its destination takes messages in its own window.
            sys::wait_next_window();
            continue;
        }
        // Everything received is handled and everything for the host has left: wait for the
        // host. The kernel stops the schedule if nothing else has work either, and comes back
        // at once if input is already waiting.
        sys::wait_for_input();
    }
}

/// Everything waiting for the host: kernel log bytes, kernel events, partitions' messages.
fn pump_outbound(link: &mut Link) {
    loop {
        let mut chunk = [0u8; LOG_CHUNK_MAX];
        let n = sys::log_drain(&mut chunk);
        if n == 0 {
            break;
        }
        link.send(&TargetToHost::Log {
            bytes: heapless::Vec::from_slice(&chunk[..n]).unwrap_or_default(),
        });
    }
    loop {
        let mut records = [[0u32; 4]; sys::EVENT_DRAIN_BATCH];
        let n = sys::event_drain(&mut records);
        for record in &records[..n] {
            if let Some(msg) = crate::kernel::health::event_message(record) {
                link.send(&msg);
            }
        }
        if n < records.len() {
            break;
        }
    }
    for port in [PORT_EXECUTIVE_TO_IO, PORT_PLANNER_TO_IO] {
        let mut buf = [0u8; OUTBOUND_MESSAGE_SIZE as usize];
        while let Ok(got) = sys::port_receive(port, &mut buf) {
            match postcard::from_bytes::<TargetToHost>(&buf[..got.len]) {
                Ok(msg) => link.send(&msg),
                Err(_) => defmt::warn!("io: undecodable message on port {=usize}", port),
            }
        }
    }
}

/// A host message on its way to up to two ports (a state update goes to the executive and to
/// the planner); a port it has reached is taken off.
struct Routing {
    msg: HostToTarget,
    to: [Option<usize>; 2],
}

impl Routing {
    fn to(msg: HostToTarget, port: usize) -> Self {
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
fn route(port: usize, msg: &HostToTarget) -> Result<(), RouteError> {
    let mut buf = [0u8; ROUTED_MESSAGE_SIZE as usize];
    let Ok(bytes) = postcard::to_slice(msg, &mut buf) else {
        defmt::warn!("io: message too large for port {=usize}", port);
        return Err(RouteError::Refused);
    };
    match sys::port_send(port, bytes) {
        Ok(()) => Ok(()),
        Err(E_FULL) => Err(RouteError::Full),
        Err(code) => {
            defmt::warn!("io: port {=usize} refused a message ({=i32})", port, code);
            Err(RouteError::Refused)
        }
    }
}

/// Deliver `routing` to the ports it still has to reach; what is left if one is full.
fn deliver(mut routing: Routing, reset_in_next_frame: &mut Option<(u32, u32)>) -> Option<Routing> {
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
        if let Some((mode, value)) = reset_in_next_frame.take() {
            if let Err(code) = sys::arm_reset(mode, value, PORT_IO_TO_EXECUTIVE) {
                defmt::warn!("io: the kernel refused the mid-frame reset ({=i32})", code);
            }
        }
    }
    None
}

/// Act on one host message; a message still on its way to a full port is returned.
fn handle(
    link: &mut Link,
    reset_in_next_frame: &mut Option<(u32, u32)>,
    msg: HostToTarget,
) -> Option<Routing> {
    let routing = match msg {
        HostToTarget::Ping { seq } => {
            link.send(&TargetToHost::Pong {
                seq,
                link: link.counters(),
            });
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
                    *reset_in_next_frame = Some((reset_at::AFTER_TICKS, ticks));
                }
                ResetKind::WarmDuringCheckpointWrite { permille } => {
                    defmt::info!("reset requested by host: warm, {=u16} permille into the next checkpoint write", permille);
                    *reset_in_next_frame =
                        Some((reset_at::IN_WARM_WRITE, u32::from(permille.min(1000))));
                }
            }
            return None;
        }
        HostToTarget::TimeGrant { now, .. } => {
            sys::set_mission_time(now.0);
            Routing::to(msg, PORT_IO_TO_EXECUTIVE)
        }
        HostToTarget::StateUpdate {
            key: StateKey(key), ..
        } if key >= control::FIRST => control(key, msg)?,
        HostToTarget::StateUpdate { .. } => Routing {
            msg,
            to: [Some(PORT_IO_TO_EXECUTIVE), Some(PORT_IO_TO_PLANNER)],
        },
        // The flight application (autonomy core) runs in the executive partition.
        HostToTarget::CommandResponse { .. } | HostToTarget::UplinkChunk { .. } => {
            Routing::to(msg, PORT_IO_TO_EXECUTIVE)
        }
    };
    deliver(routing, reset_in_next_frame)
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
        control::PLANNER_CHECKSUM => Some(Routing::to(msg, PORT_IO_TO_PLANNER)),
        control::SYSCALL_BENCH => Some(Routing::to(msg, PORT_IO_TO_EXECUTIVE)),
        #[cfg(feature = "test-partitions")]
        control::ROGUE_MODE => Some(Routing::to(msg, kernel_config::system::PORT_IO_TO_ROGUE)),
        _ => {
            defmt::warn!("io: unknown control key {=u16:#x}", key);
            None
        }
    }
}

fn decode_error_name(error: fsw_bridge::codec::DecodeError) -> &'static str {
    use fsw_bridge::codec::DecodeError::*;
    match error {
        BadCrc => "bad CRC",
        Oversize => "oversize",
        UnknownType(_) => "unknown type",
        Truncated => "truncated",
        Malformed => "malformed",
    }
}
