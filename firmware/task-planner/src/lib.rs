//! The planner partition: the flight application's planner side (`flight_app::PlannerApp`:
//! the autonomy core's planning loop, its copy of the network, its end of the channel with the
//! executive), in its own windows, with its own slices of the warm-restart area and of
//! non-volatile memory for its checkpoints.
//!
//! Each window it takes what the executive sent (`executive_to_planner`: task reports,
//! measurements, returned commits, a network streamed in chunks, and the frame to plan for);
//! when a frame has come it plans within its budget of validity checks
//! ([`flight_app::DEFAULT_PLANNER_BUDGET`]), checkpoints, and sends its commits, decisions and
//! status (`planner_to_executive`). A cycle that needs more than one window's budget stops and
//! goes on in the next frame's window: the planner is anytime, and the executive's windows run
//! on schedule whatever it does. With nothing to plan and nothing to send it declares itself
//! idle, so the module can stop its schedule while the host thinks.
//!
//! On request (`control::PLANNER_CHECKSUM`) it reports the CRC-32 of a table in its region,
//! which the isolation test compares before and after a rogue partition tries to write it.
//!
//! Entry: [`partition_planner_main`]; state: `.bss.part.planner`.
#![no_std]
// The autonomy core's lints (no panicking path) come from the firmware workspace's
// `[workspace.lints]` (firmware/image/Cargo.toml).

mod lander;
mod plugin_glue;
mod temporal;

// The plug-ins' work (a temporal or lander message taken in, a window of their planning) is in
// functions named `deferred_*`, never inlined: `linker/g3beige.ld` puts them, with the temporal
// planner's and the lander's crates, in the deferred code, which a warm boot does not check and
// the kernel checks before it first runs (the image's `kernel::deferred`). What every start and
// every loop runs of the plug-ins (their start, whether they have work, their reports) stays in
// the code checked at boot.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use crc::{Crc, CRC_32_ISO_HDLC};
use flight_app::{Downlink, PlannerApp, PlannerPlugin};
use fsw_bridge::{HostToTarget, StateKey, StateValue, TargetToHost, TelemetryEvent};
use kernel_config::abi::{control, metric};
use kernel_config::system::{PLANNER_WARM, PLANNER_WINDOW_TICKS};

use userlib::{
    ports, receive_routed, receive_wire, send_wire, sys, zeroed_state, HostOutbox, KernelMemories,
    MemoryCopies, PartitionClock, ZeroValid,
};

/// Words of the table the isolation test checks.
pub const TABLE_WORDS: usize = 16 * 1024;
/// Bytes of the warm-restart area for this partition's checkpoints: its slice.
pub const WARM_CHECKPOINT_BYTES: usize = PLANNER_WARM.len as usize;
/// Bytes of non-volatile memory for its checkpoints: its slice, as long as the warm one.
pub const NV_CHECKPOINT_BYTES: usize = WARM_CHECKPOINT_BYTES;
/// CPU the planning may take in one window: three quarters of the planner's window, the rest
/// for what comes before (the executive's messages) and after (the checkpoint, the messages
/// for the executive). The planner then yields at its window's end, its cycle pending, rather
/// than being preempted there with no answer for the frame.
pub const PLANNING_TICKS_PER_WINDOW: u64 = PLANNER_WINDOW_TICKS as u64 * 3 / 4;
/// Messages for the host the partition holds while the outbound port is full.
pub const OUTBOX_CAPACITY: usize = 64;

pub struct PlannerState {
    /// The isolation test's table, filled at its first request.
    pub table: [u32; TABLE_WORDS],
    pub table_filled: bool,
    /// Windows in which the planner planned since its (re)start.
    pub iterations: u32,
    /// This partition's copies of its slices of the two memories.
    pub copies: MemoryCopies<WARM_CHECKPOINT_BYTES, NV_CHECKPOINT_BYTES>,
    pub outbox: HostOutbox<OUTBOX_CAPACITY>,
}

// SAFETY: integers, booleans, word arrays, and ZeroValid parts.
unsafe impl ZeroValid for PlannerState {}

/// The partition's state. Exported by name for the isolation test only: the test image's rogue
/// partition writes at this address (and must be stopped), without linking this crate.
#[link_section = ".bss.part.planner"]
#[export_name = "partition_planner_state"]
pub static mut STATE: MaybeUninit<PlannerState> = MaybeUninit::uninit();

#[link_section = ".bss.part.planner"]
static mut APP: MaybeUninit<PlannerApp> = MaybeUninit::uninit();

// PlannerApp is ZeroValid (`userlib`): the partition entry makes it the new application
// with `PlannerApp::reset`, in place.

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

#[no_mangle]
pub extern "C" fn partition_planner_main() -> ! {
    // SAFETY: STATE and APP are this partition's statics, zeroed by the partition start; the
    // entry runs once per (re)start, so nothing else refers to them.
    let state = unsafe { zeroed_state(addr_of_mut!(STATE)) };
    let entered = sys::cpu_time().0;
    // SAFETY: as above; `reset` makes it the new application before its first use.
    let app: &'static mut PlannerApp = unsafe { zeroed_state(addr_of_mut!(APP)) };
    app.reset();
    app.set_cpu_budget(Some(PLANNING_TICKS_PER_WINDOW));
    let nv_size = sys::nv_read(0, &mut []).map_or(0, |size| size as usize);
    state.copies.has_nv = nv_size >= NV_CHECKPOINT_BYTES;
    if sys::identity().1 == 0 {
        metric(state, metric::BOOT_PLANNER_START_TICKS, entered);
    }
    let temporal = temporal::start(
        nv_size
            >= kernel_config::system::PLANNER_NV_SECURITY_OFFSET as usize
                + sdls::nv::SECURITY_AREA_BYTES,
    );
    let lander = lander::start();
    app.boot_fetching(
        &mut state.copies.memories(None),
        Some(&mut KernelMemories),
        &mut PartitionClock,
        &mut state.outbox,
    );
    loop {
        while let Some((msg, _generation)) = receive_routed(ports::IO_TO_PLANNER) {
            if !temporal::handle(temporal, &msg, &mut state.outbox)
                && !lander::handle(lander, &msg, &mut state.outbox)
            {
                handle(state, app, msg);
            }
        }
        while let Some(wire) = receive_wire(ports::EXECUTIVE_TO_PLANNER) {
            app.receive(wire);
        }
        if app.frame_pending() {
            app.window(
                &mut state.copies.memories(None),
                Some(&mut KernelMemories),
                &mut PartitionClock,
                &mut state.outbox,
            );
            state.iterations = state.iterations.wrapping_add(1);
            state
                .copies
                .write_out(&app.take_warm_writes(), &app.take_nv_writes());
            // The temporal planner's share: what is left of the window's planning CPU.
            temporal::window(
                temporal,
                app.window_started(),
                PLANNING_TICKS_PER_WINDOW,
                &mut state.copies.memories(None),
                &mut state.outbox,
            );
            // The lander executor's: what is left after the temporal planner's.
            lander::window(
                lander,
                app.window_started(),
                PLANNING_TICKS_PER_WINDOW,
                &mut state.copies.memories(None),
                &mut state.outbox,
            );
        }
        temporal::report(temporal, &mut state.outbox);
        lander::report(lander, &mut state.outbox);
        app.transmit(&mut |wire| send_wire(ports::PLANNER_TO_EXECUTIVE, &wire));
        state.outbox.flush(ports::PLANNER_TO_IO);
        if app.unsent() > 0 || !state.outbox.queue.is_empty() || temporal.busy() || lander.busy() {
            sys::wait_next_window();
        } else {
            // Nothing to plan until the executive sends a frame: the module may stop its
            // schedule meanwhile.
            sys::wait_idle();
        }
    }
}

fn metric(state: &mut PlannerState, id: u16, value: u64) {
    state
        .outbox
        .send(TargetToHost::Telemetry(TelemetryEvent::Metric {
            id,
            value,
        }));
}

fn handle(state: &mut PlannerState, app: &mut PlannerApp, msg: HostToTarget) {
    if let HostToTarget::StateUpdate {
        key: StateKey(control::PLANNER_BUDGET),
        value,
        ..
    } = msg
    {
        let checks = match value {
            StateValue::Int(n) if n >= 1 => u32::try_from(n).unwrap_or(u32::MAX),
            _ => flight_app::DEFAULT_PLANNER_BUDGET,
        };
        defmt::info!("planner: {=u32} validity checks per window", checks);
        app.set_budget(checks);
        return;
    }
    if let HostToTarget::StateUpdate {
        key: StateKey(control::PLANNER_CHECKSUM),
        ..
    } = msg
    {
        fill_table(state);
        let mut digest = CRC32.digest();
        for word in state.table.iter() {
            digest.update(&word.to_be_bytes());
        }
        let checksum = digest.finalize();
        metric(state, metric::PLANNER_CHECKSUM, u64::from(checksum));
        metric(
            state,
            metric::PLANNER_GENERATION,
            u64::from(sys::identity().1),
        );
        let iterations = state.iterations;
        metric(state, metric::PLANNER_ITERATIONS, u64::from(iterations));
    }
}

/// The isolation test's table: deterministic (xorshift32), the same after every restart.
fn fill_table(state: &mut PlannerState) {
    if state.table_filled {
        return;
    }
    let mut x: u32 = 0x2545_f491;
    for entry in state.table.iter_mut() {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        *entry = x;
    }
    state.table_filled = true;
}
