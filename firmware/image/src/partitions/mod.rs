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
use kernel_config::abi::SysError;
use kernel_config::system::OUTBOUND_MESSAGE_SIZE;

use crate::sys;

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
pub fn send_to_host(port: usize, msg: &TargetToHost) -> Result<(), SysError> {
    let mut buf = [0u8; OUTBOUND_MESSAGE_SIZE as usize];
    let bytes = postcard::to_slice(msg, &mut buf).map_err(|_| SysError::TooBig)?;
    sys::port_send(port, bytes)
}

/// The next routed host message on `port`, with the I/O partition's generation when it sent it.
pub fn receive_routed(port: usize) -> Option<(HostToTarget, u32)> {
    let mut buf = [0u8; kernel_config::system::ROUTED_MESSAGE_SIZE as usize];
    loop {
        let got = sys::port_receive(port, &mut buf).ok()?;
        match postcard::from_bytes::<HostToTarget>(&buf[..got.len]) {
            Ok(msg) => return Some((msg, got.generation)),
            Err(_) => defmt::warn!("port {=usize}: undecodable message dropped", port),
        }
    }
}
