//! The executive partition: runs the flight application (`flight-app`: the autonomy core with
//! the lockstep and uplink protocol around it). It receives the host's state updates, command
//! responses, uplink chunks and time grants routed by the I/O partition, steps the autonomy
//! once per grant, checkpoints the plan into the warm-restart area and, when the board has it,
//! into non-volatile memory (both through the kernel: this partition owns them), and queues
//! what it decided (command dispatches, telemetry, FrameDone) for the I/O partition. It also
//! serves the kernel's syscall benchmark on request.
//!
//! Host input is handled at window starts: what the I/O partition routes is queued until the
//! message the host waits for an answer to (a time grant, an uplink chunk) has arrived, and the
//! whole batch is handled at the start of the partition's next window. So a frame's work starts
//! at the same point of a window however the host's bytes were spread over the I/O
//! partition's windows, and its costs (partition CPU ticks, read from the timebase with 15
//! instructions per tick) come out the same run to run; handled as it trickled in, a frame's
//! step could start at a different point in the window and its tick count differ by one.
//!
//! The key and the anti-replay counter of authenticated uplinks and ground commands (`sdls`)
//! live in non-volatile memory's security area, right after the checkpoint areas
//! ([`NV_SECURITY_OFFSET`]); the flight application reads it at boot and writes a counter
//! record through [`NvSecurityStore`] (a `SYS_NV_WRITE` that has returned before the message
//! takes effect). A board without non-volatile memory, or with less than the checkpoint and
//! security areas, has no key: authenticated traffic is refused with `NoKey`.
//!
//! The planner runs in the planner partition (`task-planner`): a granted frame starts
//! here (the first executive window: host input, the first executive pass, a checkpoint, then
//! the messages for the planner on `executive_to_planner`), goes on in the planner's window, and
//! ends in a later window of this partition, once the planner's answer has come in on
//! `planner_to_executive` (the second executive window: the commits, the second pass, a
//! checkpoint, `FrameDone`). While it waits the partition gives up each window at once: its
//! CPU per window does not depend on the planner.
//!
//! Entry: [`partition_executive_main`]; state: `.bss.part.executive`.
#![no_std]
// The autonomy core's lints (no panicking path) come from the firmware workspace's
// `[workspace.lints]` (firmware/image/Cargo.toml).

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use flight_app::{Downlink, ExecutiveApp, SecurityStore, StoreError};
use fsw_bridge::{HostToTarget, StateKey, TargetToHost, TelemetryEvent};
use heapless::Deque;
use kernel_config::abi::{control, metric, SYSCALL_BENCH_CALLS};
use kernel_config::system::{EXECUTIVE_NV, EXECUTIVE_WARM};
use kernel_config::{WARM_AREA_SIZE, WARM_BOOT_RECORD_SIZE};

use drv_g3beige::timebase::Timebase;
use userlib::{
    ports, receive_routed, receive_wire, send_to_host, send_wire, sys, zeroed_state, HostOutbox,
    KernelMemories, MemoryCopies, PartitionClock, ZeroValid,
};

/// Bytes of the warm-restart area for this partition's checkpoints: its slice.
pub const WARM_CHECKPOINT_BYTES: usize = EXECUTIVE_WARM.len as usize;
/// Bytes of non-volatile memory used for checkpoints (A/B records): the whole checkpoint part
/// of the warm area's size, as before the planner had a slice of its own, so that the security
/// area stays where provisioned keys are.
pub const NV_CHECKPOINT_BYTES: usize = (WARM_AREA_SIZE - WARM_BOOT_RECORD_SIZE) as usize;
/// Offset of the security area (`sdls::nv`: key slot, A/B anti-replay counter records) in
/// non-volatile memory: right after the checkpoint areas. `hil` provisions keys at the same
/// offset (`host-harness/src/mission/auth.rs`).
pub const NV_SECURITY_OFFSET: usize = NV_CHECKPOINT_BYTES;
/// Bytes of non-volatile memory the partition uses: checkpoints and the security area.
pub const NV_USED_BYTES: usize = NV_SECURITY_OFFSET + sdls::nv::SECURITY_AREA_BYTES;
const _: () = assert!(NV_USED_BYTES <= EXECUTIVE_NV.len as usize);
/// Messages for the host the partition holds while the outbound port is full.
pub const OUTBOX_CAPACITY: usize = 128;
/// Host messages held until their batch is complete (a frame's state updates and responses).
pub const PENDING_CAPACITY: usize = 32;

pub struct ExecutiveState {
    pub state_updates: u32,
    pub command_responses: u32,
    pub time_grants: u32,
    /// The copies of this partition's slices of the warm-restart area and of the start of
    /// non-volatile memory (its checkpoint areas).
    pub copies: MemoryCopies<WARM_CHECKPOINT_BYTES, NV_CHECKPOINT_BYTES>,
    /// The non-volatile memory also holds the security area (it is at least
    /// [`NV_USED_BYTES`] long).
    pub has_security_area: bool,
    pub outbox: HostOutbox<OUTBOX_CAPACITY>,
    /// Host messages received, in order, not handled yet.
    pub pending: Deque<HostToTarget, PENDING_CAPACITY>,
    /// `pending` ends with a message the host waits for: handle it at the next window start.
    pub batch_complete: bool,
    /// Batches handled early because `pending` was full.
    pub pending_overflows: u32,
}

// SAFETY: integers, booleans, byte arrays, and heapless Deques whose all-zero value is the empty
// queue (indices 0, not full; the buffer is MaybeUninit).
unsafe impl ZeroValid for ExecutiveState {}

#[link_section = ".bss.part.executive"]
static mut STATE: MaybeUninit<ExecutiveState> = MaybeUninit::uninit();

#[link_section = ".bss.part.executive"]
static mut APP: MaybeUninit<ExecutiveApp> = MaybeUninit::uninit();

// ExecutiveApp is ZeroValid (`userlib`): the partition entry makes it the new application
// with `ExecutiveApp::reset`, in place.

/// The security area in non-volatile memory, through the kernel (this partition owns NV).
struct NvSecurityStore;

impl SecurityStore for NvSecurityStore {
    fn read(&mut self, area: &mut [u8; sdls::nv::SECURITY_AREA_BYTES]) -> Result<(), StoreError> {
        sys::nv_read(NV_SECURITY_OFFSET as u32, area)
            .map(|_| ())
            .map_err(|_| StoreError)
    }

    /// Returns once the kernel has copied the bytes into the device.
    fn write(&mut self, offset: usize, bytes: &[u8]) -> Result<(), StoreError> {
        let at = NV_SECURITY_OFFSET
            .checked_add(offset)
            .and_then(|at| u32::try_from(at).ok())
            .ok_or(StoreError)?;
        sys::nv_write(at, bytes).map_err(|_| StoreError)
    }
}

/// The security store of a board that has the security area.
fn security_store(
    has_security_area: bool,
    store: &mut NvSecurityStore,
) -> Option<&mut dyn SecurityStore> {
    has_security_area.then_some(store as &mut dyn SecurityStore)
}

#[no_mangle]
pub extern "C" fn partition_executive_main() -> ! {
    // SAFETY: STATE and APP are this partition's statics, zeroed by the partition start; the
    // entry runs once per (re)start, so nothing else refers to them.
    let state = unsafe { zeroed_state(addr_of_mut!(STATE)) };
    let entered = sys::cpu_time().0;
    // SAFETY: as above (APP is zeroed by the partition start too, and FlightApp is
    // ZeroValid); `reset` makes it the new application before its first use.
    let app: &'static mut ExecutiveApp = unsafe { zeroed_state(addr_of_mut!(APP)) };
    app.reset();
    // The copies of the two memories start out zero (no record); the flight application
    // reads what it needs into them (`KernelMemories`). Probe non-volatile memory's size first
    // (a read of 0 bytes), so a small device is refused here rather than by the kernel as an
    // out-of-range access.
    state.copies.has_nv = match sys::nv_read(0, &mut []) {
        Ok(size) if size as usize >= NV_CHECKPOINT_BYTES => {
            state.has_security_area = size as usize >= NV_USED_BYTES;
            if !state.has_security_area {
                defmt::warn!(
                    "executive: non-volatile memory of {=u32} bytes has no room for the security area; authenticated uplinks and commands will be refused (no key)",
                    size
                );
            }
            true
        }
        Ok(size) => {
            defmt::warn!(
                "executive: non-volatile memory of {=u32} bytes is smaller than a checkpoint area ({=usize}); warm area only",
                size,
                NV_CHECKPOINT_BYTES
            );
            false
        }
        Err(_) => {
            defmt::info!("executive: no non-volatile memory on this board; warm area only");
            false
        }
    };
    let initialised = sys::cpu_time().0;
    // The restore starts in a fresh window, so that however long it takes the boot never
    // overruns the executive's window.
    sys::wait_next_window();
    {
        let outbox = &mut state.outbox;
        let mut store = NvSecurityStore;
        let secured = state.copies.has_nv && state.has_security_area;
        let outcome = app.boot_fetching(
            &mut state.copies.memories(security_store(secured, &mut store)),
            Some(&mut KernelMemories),
            &mut PartitionClock,
            outbox,
        );
        // Ready: the first grant can be taken. Once per boot (a restart by the health
        // monitor is not a boot, and this partition's CPU time counts from the boot).
        if sys::identity().1 == 0 {
            let (_, kernel_boot) = sys::uptime();
            let ready = kernel_boot + sys::cpu_time().0;
            outbox.send(TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: metric::BOOT_EXECUTIVE_START_TICKS,
                value: entered,
            }));
            outbox.send(TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: metric::BOOT_EXECUTIVE_INIT_TICKS,
                value: initialised - entered,
            }));
            outbox.send(TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: metric::KERNEL_BOOT_TICKS,
                value: kernel_boot,
            }));
            outbox.send(TargetToHost::Telemetry(TelemetryEvent::Metric {
                id: metric::BOOT_TO_READY_TICKS,
                value: ready,
            }));
        }
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
    // A batch completed in one window (see the module comment) is handled at the start of the
    // next: a frame's work starts at the same instruction of a window on every run, so its
    // costs, and a reset the host armed inside it (counted by the kernel from that window's
    // start), are the same on every run.
    loop {
        // The planner's messages (its window ran since our last one), then the host's batch,
        // then the frame's second window if the planner has answered it, then what the
        // checkpoints allow to go to the planner.
        while let Some(wire) = receive_wire(ports::PLANNER_TO_EXECUTIVE) {
            app.receive(wire);
        }
        if core::mem::replace(&mut state.batch_complete, false) {
            handle_pending(state, app);
        }
        second_window(state, app);
        to_planner(state, app);
        flush(state);
        while let Some((msg, _generation)) = receive_routed(ports::IO_TO_EXECUTIVE) {
            if let HostToTarget::StateUpdate {
                key: StateKey(control::SYSCALL_BENCH),
                ..
            } = msg
            {
                // Times itself from a window start of its own.
                handle(state, app, msg);
                flush(state);
                continue;
            }
            let answer_awaited = matches!(
                msg,
                HostToTarget::TimeGrant { .. }
                    | HostToTarget::UplinkChunk { .. }
                    | HostToTarget::GroundCommand { .. }
            );
            if let Err(msg) = state.pending.push_back(msg) {
                // More than a batch can hold: handle what there is now (correct, but this
                // frame's costs may then differ by a tick from run to run).
                state.pending_overflows = state.pending_overflows.saturating_add(1);
                defmt::warn!(
                    "executive: more than {=usize} messages in one batch",
                    PENDING_CAPACITY
                );
                handle_pending(state, app);
                handle(state, app, msg);
                flush(state);
                continue;
            }
            state.batch_complete |= answer_awaited;
        }
        if state.batch_complete || !state.outbox.queue.is_empty() || app.awaiting_planner() {
            sys::wait_next_window();
        } else {
            // Nothing to do until the host sends more (a batch still waiting for its grant
            // included): the module may stop its schedule meanwhile.
            sys::wait_idle();
        }
    }
}

/// The frame's second window, once the planner has answered: the commits, the second
/// executive pass, the checkpoint, FrameDone.
fn second_window(state: &mut ExecutiveState, app: &mut ExecutiveApp) {
    if !app.awaiting_planner() {
        return;
    }
    app.second_window(
        &mut state.copies.memories(None),
        Some(&mut KernelMemories),
        &mut PartitionClock,
        &mut state.outbox,
    );
    write_checkpoints(state, app);
}

/// What the executive's checkpoint holds goes to the planner, until its port is full (the
/// rest goes at the next window: the channel keeps it).
fn to_planner(state: &mut ExecutiveState, app: &mut ExecutiveApp) {
    app.checkpoint_if_needed(
        &mut state.copies.memories(None),
        Some(&mut KernelMemories),
        &mut state.outbox,
    );
    write_checkpoints(state, app);
    app.transmit(&mut |wire| send_wire(ports::EXECUTIVE_TO_PLANNER, &wire));
}

/// The checkpoint bytes the application wrote into its copies go to the memories.
fn write_checkpoints(state: &mut ExecutiveState, app: &mut ExecutiveApp) {
    state
        .copies
        .write_out(&app.take_warm_writes(), &app.take_nv_writes());
}

/// Handle every queued host message, in order.
fn handle_pending(state: &mut ExecutiveState, app: &mut ExecutiveApp) {
    while let Some(msg) = state.pending.pop_front() {
        handle(state, app, msg);
        flush(state);
    }
}

/// Hand queued messages to the I/O partition until its port is full.
fn flush(state: &mut ExecutiveState) {
    state.outbox.flush(ports::EXECUTIVE_TO_IO);
}

fn metric(id: u16, value: u64) {
    let _ = send_to_host(
        ports::EXECUTIVE_TO_IO,
        &TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }),
    );
}

fn handle(state: &mut ExecutiveState, app: &mut ExecutiveApp, msg: HostToTarget) {
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
    let mut store = NvSecurityStore;
    let secured = state.copies.has_nv && state.has_security_area;
    app.handle_fetching(
        &msg,
        &mut state.copies.memories(security_store(secured, &mut store)),
        Some(&mut KernelMemories),
        &mut PartitionClock,
        &mut state.outbox,
    );
    write_checkpoints(state, app);
}

/// Ticks for SYSCALL_BENCH_CALLS null system calls, timed at the start of a fresh window so no
/// window switch falls inside the measurement.
fn syscall_bench() -> u64 {
    sys::wait_next_window();
    let start = Timebase::read();
    for _ in 0..SYSCALL_BENCH_CALLS {
        sys::identity();
    }
    Timebase::read() - start
}
