//! The executive partition: runs the flight application (`flight-app`: the autonomy core with
//! the lockstep and uplink protocol around it). It receives the host's state updates, command
//! responses, uplink chunks and time grants routed by the I/O partition, steps the autonomy
//! once per grant (at the start of its window after the one the grant arrived in), checkpoints the plan into the warm-restart area (through the kernel: this
//! partition owns it), and queues what it decided (command dispatches, telemetry, FrameDone)
//! for the I/O partition. It also serves the kernel's syscall benchmark on request.
//!
//! The planner and the executive of the core still run together here; they exchange only
//! commits and task reports, so splitting them over the planner partition is a move of code,
//! not of design.
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use flight_app::{CpuClock, Downlink, FlightApp, Memories};
use fsw_bridge::{HostToTarget, StateKey, TargetToHost, TelemetryEvent};
use heapless::Deque;
use kernel_config::abi::{control, metric, SYSCALL_BENCH_CALLS};
use kernel_config::system::{PORT_EXECUTIVE_STATUS, PORT_EXECUTIVE_TO_IO, PORT_IO_TO_EXECUTIVE};
use kernel_config::{WARM_AREA_SIZE, WARM_BOOT_RECORD_SIZE};

use super::{receive_routed, send_to_host, zeroed_state, ZeroValid};
use crate::board::timebase;
use crate::sys;

/// Bytes of the warm-restart area available for checkpoints (after the boot record).
pub const WARM_CHECKPOINT_BYTES: usize = (WARM_AREA_SIZE - WARM_BOOT_RECORD_SIZE) as usize;
/// Messages for the host the partition holds while the outbound port is full.
pub const OUTBOX_CAPACITY: usize = 128;

pub struct ExecutiveState {
    pub state_updates: u32,
    pub command_responses: u32,
    pub time_grants: u32,
    /// Messages lost because the outbox was full.
    pub outbox_overflows: u32,
    /// Checkpoint copies the kernel refused.
    pub warm_write_errors: u32,
    /// This partition's copy of the warm-restart area's checkpoint part.
    pub warm: [u8; WARM_CHECKPOINT_BYTES],
    pub outbox: Deque<TargetToHost, OUTBOX_CAPACITY>,
}

// SAFETY: integers, a byte array, and a heapless Deque whose all-zero value is the empty queue
// (indices 0, not full; the buffer is MaybeUninit).
unsafe impl ZeroValid for ExecutiveState {}

#[link_section = ".bss.part.executive"]
static mut STATE: MaybeUninit<ExecutiveState> = MaybeUninit::uninit();

#[link_section = ".bss.part.executive"]
static mut APP: MaybeUninit<FlightApp> = MaybeUninit::uninit();

/// The initial application, copied into place (never built on the stack).
const APP_INIT: FlightApp = FlightApp::new();

/// CPU time of this partition only, so costs do not depend on other partitions' windows.
struct PartitionClock;

impl CpuClock for PartitionClock {
    fn ticks(&mut self) -> u64 {
        sys::cpu_time().0
    }
}

/// Queues messages for the host.
struct Outbox<'a> {
    queue: &'a mut Deque<TargetToHost, OUTBOX_CAPACITY>,
    overflows: &'a mut u32,
}

impl Downlink for Outbox<'_> {
    fn send(&mut self, msg: TargetToHost) {
        if self.queue.push_back(msg).is_err() {
            *self.overflows = self.overflows.saturating_add(1);
        }
    }
}

#[no_mangle]
pub extern "C" fn partition_executive_main() -> ! {
    // SAFETY: STATE and APP are this partition's statics, zeroed by the partition start; the
    // entry runs once per (re)start, so nothing else refers to them.
    let state = unsafe { zeroed_state(addr_of_mut!(STATE)) };
    // SAFETY: as above; APP is written whole before its first use.
    let app: &'static mut FlightApp = unsafe { (*addr_of_mut!(APP)).write(APP_INIT) };
    if sys::warm_read(0, &mut state.warm).is_err() {
        defmt::warn!("executive: warm-restart area unreadable; cold start");
    }
    {
        let mut outbox = Outbox {
            queue: &mut state.outbox,
            overflows: &mut state.outbox_overflows,
        };
        let mut memories = Memories {
            warm: &mut state.warm,
            nv: None,
        };
        let outcome = app.boot(&mut memories, &mut PartitionClock, &mut outbox);
        match outcome {
            flight_app::BootOutcome::Cold => {
                defmt::info!("executive: cold start, waiting for an uplink")
            }
            flight_app::BootOutcome::RestoredWarm(info)
            | flight_app::BootOutcome::RestoredNv(info) => {
                defmt::info!(
                    "executive: plan restored from checkpoint {=u32}",
                    info.sequence
                )
            }
        }
    }
    // A time grant taken in one window waits here for the start of the next: a frame's work
    // starts at the same instruction of a window on every run, whatever part of a window the
    // host's bytes arrived in, so its costs (and a reset the host armed inside it, counted by
    // the kernel from that window's start) are the same on every run.
    let mut granted: Option<HostToTarget> = None;
    loop {
        flush(state);
        if let Some(grant) = granted.take() {
            handle(state, app, grant);
            flush(state);
        }
        while let Some((msg, _generation)) = receive_routed(PORT_IO_TO_EXECUTIVE) {
            if matches!(msg, HostToTarget::TimeGrant { .. }) {
                granted = Some(msg);
                break;
            }
            handle(state, app, msg);
            flush(state);
        }
        let _ = sys::port_send(PORT_EXECUTIVE_STATUS, &state.state_updates.to_be_bytes());
        sys::wait_next_window();
    }
}

/// Hand queued messages to the I/O partition until its port is full.
fn flush(state: &mut ExecutiveState) {
    while let Some(msg) = state.outbox.front() {
        if send_to_host(PORT_EXECUTIVE_TO_IO, msg).is_err() {
            return;
        }
        state.outbox.pop_front();
    }
}

fn metric(id: u16, value: u64) {
    let _ = send_to_host(
        PORT_EXECUTIVE_TO_IO,
        &TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }),
    );
}

fn handle(state: &mut ExecutiveState, app: &mut FlightApp, msg: HostToTarget) {
    match &msg {
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
            return;
        }
        HostToTarget::StateUpdate { .. } => state.state_updates += 1,
        HostToTarget::CommandResponse { .. } => state.command_responses += 1,
        HostToTarget::TimeGrant { .. } => state.time_grants += 1,
        _ => {}
    }
    let mut outbox = Outbox {
        queue: &mut state.outbox,
        overflows: &mut state.outbox_overflows,
    };
    let mut memories = Memories {
        warm: &mut state.warm,
        nv: None,
    };
    app.handle(&msg, &mut memories, &mut PartitionClock, &mut outbox);
    if let Some((start, end)) = app.take_warm_write() {
        // Only the bytes this checkpoint wrote go to the warm-restart area; a reset in the
        // middle of the copy leaves the other slot whole (A/B records).
        if sys::warm_write(start as u32, &state.warm[start..end]).is_err() {
            state.warm_write_errors = state.warm_write_errors.saturating_add(1);
        }
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
