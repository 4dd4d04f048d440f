//! The planner partition (placeholder until the autonomy core's planner moves in): an anytime
//! worker that keeps a 64 KiB search table and a 1 MiB arena in its 4 MiB region, does a
//! bounded amount of integer work per window and waits for the next. On request it reports the
//! CRC-32 of its search table, which the isolation test compares before and after a rogue
//! partition tries to write it. It acknowledges uplink chunks.
//!
//! Where the autonomy core goes: [`PlannerState`] lives in `.bss.part.planner` and is used in
//! place (never constructed on the stack); replace the table and arena with the planner's
//! state (a `ZeroValid` struct of up to ~3.9 MiB), initialise it in
//! [`partition_planner_main`], run one bounded planner step per loop iteration: the kernel
//! preempts it at the window end anyway, and it resumes where it was.
use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use crc::{Crc, CRC_32_ISO_HDLC};
use fsw_bridge::{HostToTarget, StateKey, TargetToHost, TelemetryEvent};
use kernel_config::abi::{control, metric};

use super::{ports, receive_routed, send_to_host, zeroed_state, ZeroValid};
use crate::sys;

pub const TABLE_WORDS: usize = 16 * 1024;
/// Room reserved for the autonomy core's planner state (proves a megabyte-sized state fits).
pub const ARENA_BYTES: usize = 1 << 20;
/// Table entries visited per window.
const WORK_PER_WINDOW: usize = 2048;

pub struct PlannerState {
    pub table: [u32; TABLE_WORDS],
    pub cursor: u32,
    pub accumulator: u32,
    pub iterations: u32,
    #[allow(dead_code)] // reserved for the autonomy core
    pub arena: [u8; ARENA_BYTES],
}

// SAFETY: integers and arrays of integers only.
unsafe impl ZeroValid for PlannerState {}

#[link_section = ".bss.part.planner"]
pub static mut STATE: MaybeUninit<PlannerState> = MaybeUninit::uninit();

const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

#[no_mangle]
pub extern "C" fn partition_planner_main() -> ! {
    // SAFETY: STATE is this partition's static, zeroed by the partition start; entry runs once
    // per (re)start.
    let state = unsafe { zeroed_state(addr_of_mut!(STATE)) };
    // A deterministic table (xorshift32), the same after every restart.
    let mut x: u32 = 0x2545_f491;
    for entry in state.table.iter_mut() {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        *entry = x;
    }
    loop {
        while let Some((msg, _generation)) = receive_routed(ports::IO_TO_PLANNER) {
            handle(state, msg);
        }
        for _ in 0..WORK_PER_WINDOW {
            let i = state.cursor as usize % TABLE_WORDS;
            state.accumulator = state.accumulator.rotate_left(5) ^ state.table[i];
            state.cursor = state.cursor.wrapping_add(1);
        }
        state.iterations = state.iterations.wrapping_add(1);
        let _ = ports::PLAN_SUMMARY.send(&state.accumulator);
        // The placeholder's work is a fixed amount per window, not something the module has to
        // finish: it lets the module stop its schedule while waiting for the host.
        sys::wait_idle();
    }
}

fn metric(id: u16, value: u64) {
    let _ = send_to_host(
        ports::PLANNER_TO_IO,
        &TargetToHost::Telemetry(TelemetryEvent::Metric { id, value }),
    );
}

fn handle(state: &mut PlannerState, msg: HostToTarget) {
    match msg {
        HostToTarget::StateUpdate {
            key: StateKey(control::PLANNER_CHECKSUM),
            ..
        } => {
            let mut digest = CRC32.digest();
            for word in state.table.iter() {
                digest.update(&word.to_be_bytes());
            }
            metric(metric::PLANNER_CHECKSUM, u64::from(digest.finalize()));
            metric(metric::PLANNER_GENERATION, u64::from(sys::identity().1));
            metric(metric::PLANNER_ITERATIONS, u64::from(state.iterations));
        }
        HostToTarget::UplinkChunk { seq, .. } => {
            let _ = send_to_host(ports::PLANNER_TO_IO, &TargetToHost::UplinkAck { seq });
        }
        _ => {}
    }
}
