//! The partitions of the image. Each has an entry function (named in the configuration), runs
//! in problem state in its own windows, keeps its state in statics placed in its own region
//! (`#[link_section = ".bss.part.<name>"]`, zeroed at every (re)start) and talks to the others
//! only through ports and system calls.
//!
//! - [`io`]: owns the UART and the frame codec; says Hello, answers pings, routes host messages
//!   to the other partitions' ports and their outbound messages, the kernel's log and events
//!   to the host.
//! - [`executive`] and [`planner`]: placeholders with real regions, stacks, windows and ports,
//!   where the autonomy core goes.
//! - `rogue` (test image only): misbehaves on command, to prove the isolation.
pub mod executive;
pub mod io;
pub mod planner;
#[cfg(feature = "test-partitions")]
pub mod rogue;

use core::mem::MaybeUninit;

use fsw_bridge::{HostToTarget, TargetToHost};

use crate::port::{Port, PortError};

/// The ports the partitions use: named as in the configuration (their ids derived from the
/// names at compile time), typed with what they carry.
pub mod ports {
    use fsw_bridge::{HostToTarget, TargetToHost};

    use crate::port::Port;

    /// Host messages routed by the I/O partition to the executive.
    pub const IO_TO_EXECUTIVE: Port<HostToTarget> = Port::named("io_to_executive");
    /// Host messages routed by the I/O partition to the planner.
    pub const IO_TO_PLANNER: Port<HostToTarget> = Port::named("io_to_planner");
    /// The executive's messages for the host.
    pub const EXECUTIVE_TO_IO: Port<TargetToHost> = Port::named("executive_to_io");
    /// The planner's messages for the host.
    pub const PLANNER_TO_IO: Port<TargetToHost> = Port::named("planner_to_io");
    /// The planner's summary for the executive (its accumulator).
    pub const PLAN_SUMMARY: Port<u32> = Port::named("plan_summary");
    /// The executive's status for the planner (state updates handled).
    pub const EXECUTIVE_STATUS: Port<u32> = Port::named("executive_status");
    /// Test image: host messages for the rogue partition.
    #[cfg(feature = "test-partitions")]
    pub const IO_TO_ROGUE: Port<HostToTarget> = Port::named("io_to_rogue");
    /// Test image: the rogue partition's messages for the host.
    #[cfg(feature = "test-partitions")]
    pub const ROGUE_TO_IO: Port<TargetToHost> = Port::named("rogue_to_io");
}

/// Types whose all-zero bit pattern is a valid value: a partition's state in its section is
/// zeroed by the partition start, and used in place without being constructed (so a state of a
/// megabyte never passes through the stack).
///
/// # Safety
/// Implement only for types made of integers, arrays of them, and other `ZeroValid` types.
pub unsafe trait ZeroValid {}

/// The partition's state in its section, as zeroed by the partition start.
///
/// # Safety
/// 1. `slot` is a static in the calling partition's own `.bss.part.<name>` section.
/// 2. Called once per (re)start, so no other reference to the state exists.
pub unsafe fn zeroed_state<T: ZeroValid>(slot: *mut MaybeUninit<T>) -> &'static mut T {
    &mut *(slot as *mut T)
}

/// Send a message for the host through an outbound port (to the I/O partition).
pub fn send_to_host(port: Port<TargetToHost>, msg: &TargetToHost) -> Result<(), PortError> {
    port.send(msg)
}

/// The next routed host message on `port`, with the I/O partition's generation when it sent it.
pub fn receive_routed(port: Port<HostToTarget>) -> Option<(HostToTarget, u32)> {
    loop {
        match port.receive() {
            Ok(Some(got)) => return Some((got.value, got.generation)),
            Ok(None) | Err(PortError::Sys(_) | PortError::TooBig) => return None,
            Err(PortError::Undecodable) => {
                defmt::warn!("port {=usize}: undecodable message dropped", port.id())
            }
        }
    }
}
