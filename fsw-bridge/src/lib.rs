//! The wire protocol between the RAD750-proxy target and the host harness.
//!
//! Both sides compile this crate: the firmware for `powerpc-unknown-linux-gnu` (no_std, no heap),
//! the host natively. It holds the message set ([`messages`]), the frame codec ([`codec`]: postcard
//! payload, CRC-32, COBS framing), the reliable link layer carried inside those frames
//! ([`link`]: CCSDS COP-1 style, counted in lockstep rounds) and the plain types the autonomy core
//! sees ([`types`]), and the telemetry dictionary ([`dictionary`]: every metric and event the
//! firmware sends, with its name, unit, kind and channel).
//!
//! Features: `std` adds the host-only lossy channel simulator (`link::channel`).
#![no_std]
#![forbid(unsafe_code)]

// Unit tests and the `std` feature's host-only modules use std; the target build never does.
#[cfg(any(test, feature = "std"))]
extern crate std;

pub mod codec;
pub mod dictionary;
pub mod lander;
pub mod link;
pub mod messages;
pub mod security;
pub mod temporal;
pub mod types;

pub use messages::{HostToTarget, LinkCounters, TargetToHost, TelemetryEvent};
pub use security::{CommandRefusal, GroundCommand, SecurityHeader, SecurityRefusal};
pub use types::*;

/// Version of the message set. Both sides refuse a peer that speaks another version.
/// v3: Hello carries the recorded kernel fault, and ResetCause has KernelFault.
/// v4: the temporal planner's messages (`TemporalBegin`, `TemporalChunk` up, `Temporal`
/// reports down), the lander's (`LanderBegin`, `LanderChunk`, `LanderStep`, `LanderInput`
/// up, `Lander` reports down) and the onboard rover mission's (`Rover` events up, `TemporalReport::Rover`
/// reports down) appended: a peer of v3 would take them for garbage, so a `hil`
/// and a firmware a message set apart now refuse each other at the Hello by name instead of
/// looking like a lost link.
/// v5: the rover mission's `RoverReport::Resumed` and `NotResumed` (with
/// `RoverResumeRefusal`) after a planner-partition restart appended: a v4 `hil` would take
/// them for garbage.
pub const PROTOCOL_VERSION: u16 = 5;
