//! The partitions' side of the RAD750-proxy kernel (after Hubris's `sys/userlib`): what every
//! partition crate (`firmware/task-*`) links to talk to the kernel and to the others. Code here
//! runs in problem state, in the calling partition's windows; the kernel is `firmware/image`.
//!
//! - [`sys`]: the system calls, thin wrappers over `sc` (numbers and errors:
//!   `kernel_config::abi`);
//! - [`port`]: typed ports, a [`Port<T>`](port::Port) found by its name in [`SYSTEM`] at compile
//!   time and carrying `T` over postcard; [`ports`] lists this image's ports, typed;
//! - a partition's state: [`ZeroValid`] and [`zeroed_state`] (used in place in its
//!   `.bss.part.<name>` section, zeroed by the kernel at every (re)start);
//! - the flight application's glue, shared by the executive and planner partitions: their CPU
//!   clock, their memories read and written through the kernel, their outbox for the host and
//!   the autonomy core's channel between them.
//!
//! A partition crate exports its entry function (`#[no_mangle] extern "C"`, named in the
//! configuration), keeps its state in statics placed in its own region
//! (`#[link_section = ".bss.part.<name>"]`) and talks to the others only through ports and
//! system calls. The image links the partition crates, and its build script places each
//! partition's sections in its region.
#![no_std]
// The autonomy core's lints (no panicking path) come from the firmware workspace's
// `[workspace.lints]` (firmware/image/Cargo.toml).

pub mod port;
pub mod sys;

use kernel_config::{system, SystemConfig};

/// The configuration the image runs (kernel-config's PRODUCT, or TEST with the rogue partition
/// under the `test-partitions` feature): ports are looked up in it. The image checks at compile
/// time that it runs the same one.
#[cfg(not(feature = "test-partitions"))]
pub const SYSTEM: SystemConfig = system::PRODUCT;
#[cfg(feature = "test-partitions")]
pub const SYSTEM: SystemConfig = system::TEST;

use core::mem::MaybeUninit;

use flight_app::{
    CpuClock, Downlink, Memories, MemoryFetch, MemoryKind, SecurityStore, StoreError,
};
use fsw_bridge::{HostToTarget, TargetToHost};
use heapless::Deque;
use kernel_config::abi::SysError;
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::port::{Port, PortError};

/// CPU time of the calling partition only, so costs do not depend on other partitions' windows.
pub struct PartitionClock;

impl CpuClock for PartitionClock {
    fn ticks(&mut self) -> u64 {
        sys::cpu_time().0
    }
}

/// Copies the byte ranges a checkpoint wrote into a partition's copy of a memory to the memory
/// itself (`write`: `sys::warm_write` or `sys::nv_write`), in order; only those bytes, so a
/// reset in the middle of a copy leaves the other slot whole (A/B records). Returns the number
/// of copies refused.
pub fn copy_out(
    ranges: &[(usize, usize)],
    copy: &[u8],
    write: fn(u32, &[u8]) -> Result<(), SysError>,
) -> u32 {
    let mut refused = 0u32;
    for &(start, end) in ranges {
        let ok = match (copy.get(start..end), u32::try_from(start)) {
            (Some(bytes), Ok(at)) => write(at, bytes).is_ok(),
            _ => false,
        };
        if !ok {
            refused = refused.saturating_add(1);
        }
    }
    refused
}

/// The ports the partitions use: named as in the configuration (their ids derived from the
/// names at compile time), typed with what they carry.
pub mod ports {
    use flight_app::{ExecutiveInput, PlannerInput, Wire};
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
    /// The executive's side of the autonomy core's channel to the planner.
    pub const EXECUTIVE_TO_PLANNER: Port<Wire<PlannerInput>> = Port::named("executive_to_planner");
    /// The planner's side of it.
    pub const PLANNER_TO_EXECUTIVE: Port<Wire<ExecutiveInput>> =
        Port::named("planner_to_executive");
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

// SAFETY: every field of an ExecutiveApp, down to the leaves, is an integer, a bool, an array
// of them, a fieldless enum whose first variant is 0, an Option or tuple of these, or a
// heapless Vec or Deque (a length or indices and MaybeUninit storage: empty when zero); there
// is no reference, NonZero or function pointer, so all-zero bytes are a valid ExecutiveApp.
// The executive partition's entry then makes it the new application with
// `ExecutiveApp::reset`, which writes every field: the application is never copied from a
// constant image of it (tens of KiB in the RAM image, read by the reset stub's image check at
// every boot). (Here rather than in `task-executive`: the trait's crate or the type's must
// hold the impl.)
unsafe impl ZeroValid for flight_app::ExecutiveApp {}

// SAFETY: as for ExecutiveApp: integers, bools, arrays of them, fieldless enums whose first
// variant is 0, Options and tuples of these, and heapless Vecs and Deques; all-zero bytes are a
// valid PlannerApp, which the planner partition's entry makes the new application with
// `PlannerApp::reset`.
unsafe impl ZeroValid for flight_app::PlannerApp {}

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

/// The warm-restart area and non-volatile memory (the calling partition's slices), read
/// through the kernel into the partition's copies: only what the flight application asks for (record headers, then the
/// records it checks), not both 64 KiB areas.
pub struct KernelMemories;

impl MemoryFetch for KernelMemories {
    fn fetch(
        &mut self,
        memory: MemoryKind,
        offset: usize,
        bytes: &mut [u8],
    ) -> Result<(), StoreError> {
        let offset = u32::try_from(offset).map_err(|_| StoreError)?;
        let read = match memory {
            MemoryKind::Warm => sys::warm_read(offset, bytes),
            MemoryKind::Nv => sys::nv_read(offset, bytes).map(|_| ()),
        };
        read.map_err(|_| {
            defmt::warn!(
                "a read of {=usize} bytes at {=u32} failed; taken as no record",
                bytes.len(),
                offset
            );
            StoreError
        })
    }
}

/// Messages for the host a partition holds while its outbound port is full, and how many were
/// lost because this queue was full too.
pub struct HostOutbox<const N: usize> {
    pub queue: Deque<TargetToHost, N>,
    pub overflows: u32,
}

// SAFETY: a heapless Deque whose all-zero value is the empty queue (indices 0, not full; the
// buffer is MaybeUninit) and an integer.
unsafe impl<const N: usize> ZeroValid for HostOutbox<N> {}

impl<const N: usize> Downlink for HostOutbox<N> {
    fn send(&mut self, msg: TargetToHost) {
        if self.queue.push_back(msg).is_err() {
            self.overflows = self.overflows.saturating_add(1);
        }
    }
}

impl<const N: usize> HostOutbox<N> {
    /// Hands queued messages to the I/O partition through `port` until it is full.
    pub fn flush(&mut self, port: Port<TargetToHost>) {
        while let Some(msg) = self.queue.front() {
            if send_to_host(port, msg).is_err() {
                return;
            }
            self.queue.pop_front();
        }
    }
}

/// A partition's copies of its slices of the warm-restart area (`W` bytes) and of non-volatile
/// memory (`N` bytes): the records its application read in and those it wrote (the rest stays
/// zero), and the copies the kernel refused.
pub struct MemoryCopies<const W: usize, const N: usize> {
    pub warm: [u8; W],
    pub nv: [u8; N],
    /// The board has non-volatile memory large enough for the slice.
    pub has_nv: bool,
    pub warm_write_errors: u32,
    pub nv_write_errors: u32,
}

// SAFETY: byte arrays, a boolean and integers.
unsafe impl<const W: usize, const N: usize> ZeroValid for MemoryCopies<W, N> {}

impl<const W: usize, const N: usize> MemoryCopies<W, N> {
    /// The copies as the application's memories, with `security` if the partition owns it.
    pub fn memories<'a>(&'a mut self, security: Option<&'a mut dyn SecurityStore>) -> Memories<'a> {
        Memories {
            warm: &mut self.warm,
            nv: self.has_nv.then_some(&mut self.nv[..]),
            security,
        }
    }

    /// What the application's checkpoints wrote into the copies (`warm`, `nv`: byte ranges)
    /// goes to the memories, refusals counted.
    pub fn write_out(&mut self, warm: &[(usize, usize)], nv: &[(usize, usize)]) {
        self.warm_write_errors =
            self.warm_write_errors
                .saturating_add(copy_out(warm, &self.warm, sys::warm_write));
        self.nv_write_errors =
            self.nv_write_errors
                .saturating_add(copy_out(nv, &self.nv, sys::nv_write));
    }
}

/// The next message of the autonomy core's channel on `port` (from the other partition); an
/// undecodable one is dropped with a warning (the channel sends it again, numbered).
pub fn receive_wire<T: DeserializeOwned>(port: Port<T>) -> Option<T> {
    loop {
        match port.receive() {
            Ok(Some(got)) => return Some(got.value),
            Ok(None) | Err(PortError::Sys(_) | PortError::TooBig) => return None,
            Err(PortError::Undecodable) => {
                defmt::warn!(
                    "port {=usize}: undecodable channel message dropped",
                    port.id()
                )
            }
        }
    }
}

/// Sends one message of the channel on `port`; false if it did not go (a full port: the
/// channel keeps it for the next window).
pub fn send_wire<T: Serialize>(port: Port<T>, wire: &T) -> bool {
    match port.send(wire) {
        Ok(()) => true,
        Err(PortError::TooBig) => {
            defmt::error!(
                "port {=usize}: a channel message is over the port's size",
                port.id()
            );
            false
        }
        Err(_) => false,
    }
}
