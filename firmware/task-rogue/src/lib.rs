//! The rogue partition, built only into the test image: on command (a StateUpdate with the
//! reserved key `control::ROGUE_MODE`, value `Enum(abi::rogue::*)`) it writes into the
//! planner's memory, spins forever, passes bad pointers to every system call, panics, runs a
//! privileged instruction, sends a message and restarts before it is taken (a stale message),
//! or makes the kernel itself fault, so the tests can watch the kernel contain it. Panicking is
//! one of its jobs, hence the allowance.
//!
//! Entry: [`partition_rogue_main`]; it has no state of its own.
#![no_std]
// The autonomy core's lints (no panicking path) come from the firmware workspace's
// `[workspace.lints]` (firmware/image/Cargo.toml), except that panicking on command is one of
// this one's jobs.
#![allow(clippy::panic)]

use core::arch::asm;
use core::ptr::addr_of_mut;

use fsw_bridge::{HostToTarget, StateKey, StateValue, TargetToHost, TelemetryEvent};
use kernel_config::abi::{self, control, rogue};
use kernel_config::system::{PORT_IO_TO_EXECUTIVE, PORT_IO_TO_ROGUE, ROGUE_REGION};
use userlib::{ports, receive_routed, sys};

extern "C" {
    /// The planner partition's state (`task-planner`'s `STATE`), by its symbol: the rogue
    /// knows the address, as a stray pointer would, but not the crate.
    static mut partition_planner_state: u32;
}

#[no_mangle]
pub extern "C" fn partition_rogue_main() -> ! {
    let (_, generation) = sys::identity();
    defmt::info!("rogue: started, generation {=u32}", generation);
    loop {
        while let Some((msg, _)) = receive_routed(ports::IO_TO_ROGUE) {
            if let HostToTarget::StateUpdate {
                key: StateKey(control::ROGUE_MODE),
                value: StateValue::Enum(mode),
                ..
            } = msg
            {
                act(mode);
            }
        }
        sys::wait_idle();
    }
}

fn act(mode: u16) {
    match mode {
        rogue::WRITE_PLANNER => {
            // Taking the address needs no unsafe; the write below is the point of the test.
            let target = addr_of_mut!(partition_planner_state);
            defmt::info!(
                "rogue: writing into the planner's memory at {=u32:#x} (as partition {=usize})",
                target as u32,
                sys::identity().0
            );
            for i in 0..64 {
                // SAFETY: deliberately not safe: this partition has no mapping for the
                // planner's region, so the first store raises a DSI.
                unsafe { core::ptr::write_volatile(target.add(i), 0xdead_beef) };
            }
            defmt::error!("rogue: the write went through");
        }
        rogue::ENDLESS_LOOP => {
            defmt::info!("rogue: spinning forever");
            let mut n: u32 = 0;
            loop {
                // SAFETY: a plain volatile store to this partition's own stack variable.
                unsafe { core::ptr::write_volatile(&mut n, n.wrapping_add(1)) };
            }
        }
        rogue::BAD_POINTERS => bad_pointers(),
        rogue::PANIC => panic!("rogue: asked to panic"),
        rogue::PRIVILEGED => {
            defmt::info!("rogue: mfmsr in problem state");
            // SAFETY: deliberately privileged: raises a program exception in problem state.
            unsafe { asm!("mfmsr {0}", out(reg) _, options(nomem, nostack)) };
            defmt::error!("rogue: mfmsr went through");
        }
        rogue::SEND_THEN_RESTART => {
            send_probe();
            panic!("rogue: restarting with a message in flight");
        }
        rogue::SEND => send_probe(),
        rogue::KERNEL_FAULT => {
            defmt::info!("rogue: asking the kernel to fault");
            let _ = sys::raw_number(rogue::KERNEL_FAULT_CALL, [0; 5]);
            defmt::error!("rogue: the kernel did not fault");
        }
        _ => defmt::warn!("rogue: unknown mode {=u16}", mode),
    }
}

/// Send the host a probe through `rogue_to_io`: a metric whose value is this generation.
fn send_probe() {
    let (_, generation) = sys::identity();
    let probe = TargetToHost::Telemetry(TelemetryEvent::Metric {
        id: rogue::PROBE_METRIC,
        value: u64::from(generation),
    });
    match ports::ROGUE_TO_IO.send(&probe) {
        Ok(()) => defmt::info!("rogue: probe sent, generation {=u32}", generation),
        Err(_) => defmt::error!("rogue: probe refused"),
    }
}

/// Every system call with arguments it must refuse. Each result is logged; the summary line
/// says how many were refused.
fn bad_pointers() {
    let own = ROGUE_REGION.base + ROGUE_REGION.size - 64;
    let kernel_data = kernel_config::KERNEL_DATA_BASE;
    let planner = kernel_config::system::PLANNER_REGION.base;
    let device = kernel_config::system::MAC_IO_BASE + 0x13000;
    let cases: [(u32, [u32; 5]); 26] = [
        (
            abi::SYS_PORT_SEND,
            [PORT_IO_TO_ROGUE as u32, kernel_data, 16, 0, 0],
        ),
        (
            abi::SYS_PORT_SEND,
            [PORT_IO_TO_ROGUE as u32, 0xffff_fff0, 0x20, 0, 0],
        ),
        (
            abi::SYS_PORT_SEND,
            [PORT_IO_TO_EXECUTIVE as u32, own, 16, 0, 0],
        ),
        (
            abi::SYS_PORT_RECEIVE,
            [PORT_IO_TO_ROGUE as u32, 0x100, 16, 0, 0],
        ),
        (
            abi::SYS_PORT_RECEIVE,
            [PORT_IO_TO_ROGUE as u32, planner, 160, 0, 0],
        ),
        (abi::SYS_PORT_RECEIVE, [99, own, 16, 0, 0]),
        (abi::SYS_LOG, [kernel_config::WARM_AREA_BASE, 8, 0, 0, 0]),
        (abi::SYS_LOG, [device, 4, 0, 0, 0]),
        (abi::SYS_WARM_READ, [0, kernel_data, 16, 0, 0]),
        (abi::SYS_WARM_READ, [0, own, 16, 0, 0]),
        (abi::SYS_WARM_WRITE, [0, device, 1, 0, 0]),
        (abi::SYS_NV_READ, [0, kernel_data, 16, 0, 0]),
        (abi::SYS_NV_WRITE, [0, own, 16, 0, 0]),
        (abi::SYS_BOOT_INFO, [0; 5]),
        (abi::SYS_LOG_DRAIN, [planner, 64, 0, 0, 0]),
        (abi::SYS_EVENT_DRAIN, [kernel_data, 0, 0, 0, 0]),
        (abi::SYS_SET_MISSION_TIME, [0, 0, 0, 0, 0]),
        (abi::SYS_RESET_MODULE, [0; 5]),
        (abi::SYS_REQUEST_METRICS, [0; 5]),
        (abi::SYS_LOG, [own, 0x1000, 0, 0, 0]),
        // Not a mode of the call (and so no wait either).
        (abi::SYS_WAIT_NEXT_WINDOW, [7, 0, 0, 0, 0]),
        // Link owner only.
        (abi::SYS_LINK_READ, [own, 16, 0, 0, 0]),
        (abi::SYS_LINK_WRITE, [own, 16, 0, 0, 0]),
        (abi::SYS_WAIT_FOR_INPUT, [0; 5]),
        (abi::SYSCALL_COUNT, [0; 5]),
        (0xffff_ffff, [kernel_data; 5]),
    ];
    let mut refused = 0u32;
    for (call, args) in cases {
        let (r3, _, _) = sys::raw_number(call, args);
        defmt::info!("rogue: call {=u32} -> {=i32}", call, r3 as i32);
        if kernel_config::abi::decode_result(r3).is_err() {
            refused += 1;
        }
    }
    defmt::info!(
        "rogue: bad pointers done, {=u32} of {=u32} calls refused",
        refused,
        cases.len() as u32
    );
}
