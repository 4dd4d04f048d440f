//! The executive partition (placeholder until the autonomy core's executive moves in): counts
//! state updates and command responses, answers each TimeGrant with FrameDone (its busy ticks
//! are the CPU ticks it used in this window), publishes a status word on its sampling port, and
//! on request times null system calls for the syscall benchmark.
//!
//! Where the autonomy core goes: [`ExecutiveState`] lives in this partition's 2 MiB region
//! (`.bss.part.executive`); put the executive's state there (a `ZeroValid` struct, initialised
//! in place in [`partition_executive_main`]), handle the routed messages in the receive loop,
//! send CommandDispatch/Telemetry with `send_to_host(PORT_EXECUTIVE_TO_IO, ..)`, checkpoint
//! through `sys::warm_write` (this partition owns the warm area).
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use fsw_bridge::{HostToTarget, StateKey, TargetToHost, TelemetryEvent};
use kernel_config::abi::{control, metric, SYSCALL_BENCH_CALLS};
use kernel_config::system::{PORT_EXECUTIVE_STATUS, PORT_EXECUTIVE_TO_IO, PORT_IO_TO_EXECUTIVE};

use super::{receive_routed, send_to_host, zeroed_state, ZeroValid};
use crate::board::timebase;
use crate::sys;

pub struct ExecutiveState {
    pub state_updates: u32,
    pub command_responses: u32,
    pub time_grants: u32,
}

// SAFETY: integers only.
unsafe impl ZeroValid for ExecutiveState {}

#[link_section = ".bss.part.executive"]
static mut STATE: MaybeUninit<ExecutiveState> = MaybeUninit::uninit();

#[no_mangle]
pub extern "C" fn partition_executive_main() -> ! {
    // SAFETY: STATE is this partition's static, zeroed by the partition start; entry runs once
    // per (re)start.
    let state = unsafe { zeroed_state(addr_of_mut!(STATE)) };
    loop {
        while let Some((msg, _generation)) = receive_routed(PORT_IO_TO_EXECUTIVE) {
            handle(state, msg);
        }
        let _ = sys::port_send(PORT_EXECUTIVE_STATUS, &state.state_updates.to_be_bytes());
        sys::wait_next_window();
    }
}

fn metric(id: u16, value: u64) {
    let _ = send_to_host(
        PORT_EXECUTIVE_TO_IO,
        &TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }),
    );
}

fn handle(state: &mut ExecutiveState, msg: HostToTarget) {
    match msg {
        HostToTarget::TimeGrant { frame, .. } => {
            state.time_grants += 1;
            let (_, window_ticks) = sys::cpu_time();
            let _ = send_to_host(
                PORT_EXECUTIVE_TO_IO,
                &TargetToHost::FrameDone {
                    frame,
                    next_wakeup: None,
                    busy_ticks: window_ticks,
                },
            );
        }
        HostToTarget::StateUpdate {
            key: StateKey(control::SYSCALL_BENCH),
            ..
        } => {
            let ticks = syscall_bench();
            metric(metric::SYSCALL_BENCH_TICKS, ticks);
            metric(
                metric::EXECUTIVE_STATE_UPDATES,
                u64::from(state.state_updates),
            );
        }
        HostToTarget::StateUpdate { .. } => state.state_updates += 1,
        HostToTarget::CommandResponse { .. } => state.command_responses += 1,
        _ => {}
    }
}

/// Ticks for SYSCALL_BENCH_CALLS null system calls, timed at the start of a fresh window so no
/// window switch falls inside the measurement.
fn syscall_bench() -> u64 {
    sys::wait_next_window();
    let start = timebase::now().0;
    for _ in 0..SYSCALL_BENCH_CALLS {
        sys::identity();
    }
    timebase::now().0 - start
}
