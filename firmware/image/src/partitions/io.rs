//! The I/O partition: the only one with the UART (mac-io is mapped into it alone). It runs the
//! frame codec, says Hello once per boot (with the reset cause the kernel determined), answers
//! Ping with its decoder counters, honours ResetRequest through the kernel (a mid-frame kind is
//! held until the next TimeGrant has been routed, then armed on the executive's work on that
//! grant), and routes:
//! TimeGrant, StateUpdate, CommandResponse and UplinkChunk to the executive (where the flight
//! application runs), StateUpdate to the planner, and reserved control keys (`abi::control`) to whoever they address; in the
//! other direction the executive's and planner's outbound ports, the kernel's log stream and
//! the kernel's events (health monitor, metrics) go to the host.
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use fsw_bridge::messages::LOG_CHUNK_MAX;
use fsw_bridge::{
    HostToTarget, ResetCause, ResetKind, StateKey, StateValue, TargetToHost, PROTOCOL_VERSION,
};
use kernel_config::abi::{control, reset_at, REPORT_OFF};
use kernel_config::system::{
    OUTBOUND_MESSAGE_SIZE, PORT_EXECUTIVE_TO_IO, PORT_IO_TO_EXECUTIVE, PORT_IO_TO_PLANNER,
    PORT_PLANNER_TO_IO, ROUTED_MESSAGE_SIZE,
};

use crate::board::escc::EsccChannelA;
use crate::link::Link;
use crate::sys;

#[link_section = ".bss.part.io"]
static mut LINK: MaybeUninit<Link<EsccChannelA>> = MaybeUninit::uninit();

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
    // SAFETY:
    // 1. LINK is this partition's own static; entry runs once per (re)start, so this is the only
    //    reference. `write` initialises it before use.
    // 2. The kernel initialised the ESCC at boot and maps mac-io only into this partition.
    let link = unsafe { (*addr_of_mut!(LINK)).write(Link::new(EsccChannelA::attach())) };
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
    loop {
        pump_outbound(link);
        while let Some(next) = link.poll() {
            match next {
                Ok(msg) => handle(link, &mut reset_in_next_frame, msg),
                Err(error) => {
                    defmt::warn!("link: frame rejected: {=str}", decode_error_name(error))
                }
            }
            pump_outbound(link);
        }
        sys::wait_next_window();
    }
}

/// Everything waiting for the host: kernel log bytes, kernel events, partitions' messages.
fn pump_outbound(link: &mut Link<EsccChannelA>) {
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
    while let Some(record) = sys::event_drain() {
        if let Some(msg) = crate::kernel::health::event_message(&record) {
            link.send(&msg);
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

/// Queue `msg` on `port`; false if it was refused (and logged).
fn route(port: usize, msg: &HostToTarget) -> bool {
    let mut buf = [0u8; ROUTED_MESSAGE_SIZE as usize];
    match postcard::to_slice(msg, &mut buf) {
        Ok(bytes) => match sys::port_send(port, bytes) {
            Ok(()) => true,
            Err(code) => {
                defmt::warn!("io: port {=usize} refused a message ({=i32})", port, code);
                false
            }
        },
        Err(_) => {
            defmt::warn!("io: message too large for port {=usize}", port);
            false
        }
    }
}

fn handle(
    link: &mut Link<EsccChannelA>,
    reset_in_next_frame: &mut Option<(u32, u32)>,
    msg: HostToTarget,
) {
    match msg {
        HostToTarget::Ping { seq } => {
            link.send(&TargetToHost::Pong {
                seq,
                link: link.counters(),
            });
        }
        HostToTarget::ResetRequest { kind } => {
            match kind {
                ResetKind::Warm => {
                    defmt::info!("reset requested by host: warm");
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
        }
        HostToTarget::TimeGrant { now, .. } => {
            sys::set_mission_time(now.0);
            if route(PORT_IO_TO_EXECUTIVE, &msg) {
                // The grant is now the last message for the executive: the kernel counts the
                // executive's work from its receipt.
                if let Some((mode, value)) = reset_in_next_frame.take() {
                    if let Err(code) = sys::arm_reset(mode, value, PORT_IO_TO_EXECUTIVE) {
                        defmt::warn!("io: the kernel refused the mid-frame reset ({=i32})", code);
                    }
                }
            }
        }
        HostToTarget::StateUpdate {
            key: StateKey(key), ..
        } if key >= control::FIRST => control(key, &msg),
        HostToTarget::StateUpdate { .. } => {
            route(PORT_IO_TO_EXECUTIVE, &msg);
            route(PORT_IO_TO_PLANNER, &msg);
        }
        HostToTarget::CommandResponse { .. } => {
            route(PORT_IO_TO_EXECUTIVE, &msg);
        }
        // The flight application (autonomy core) runs in the executive partition.
        HostToTarget::UplinkChunk { .. } | HostToTarget::GroundCommand { .. } => {
            route(PORT_IO_TO_EXECUTIVE, &msg);
        }
    }
}

fn control(key: u16, msg: &HostToTarget) {
    match key {
        control::REQUEST_METRICS => {
            let period = match msg {
                HostToTarget::StateUpdate {
                    value: StateValue::Int(n),
                    ..
                } if *n > 0 => u32::try_from(*n).unwrap_or(u32::MAX - 1),
                HostToTarget::StateUpdate {
                    value: StateValue::Int(n),
                    ..
                } if *n < 0 => REPORT_OFF,
                _ => 0,
            };
            sys::request_metrics(period)
        }
        control::PLANNER_CHECKSUM => {
            route(PORT_IO_TO_PLANNER, msg);
        }
        control::SYSCALL_BENCH => {
            route(PORT_IO_TO_EXECUTIVE, msg);
        }
        #[cfg(feature = "test-partitions")]
        control::ROGUE_MODE => {
            route(kernel_config::system::PORT_IO_TO_ROGUE, msg);
        }
        _ => defmt::warn!("io: unknown control key {=u16:#x}", key),
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
