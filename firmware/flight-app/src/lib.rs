//! The flight application's side of the lockstep protocol, independent of where it runs.
//!
//! The autonomy core runs as two partitions (`autonomy::partitioned`): [`ExecutiveApp`] (the
//! executive partition: the host's messages, the control loop, uplinks and security, the
//! frame's two executive windows and `FrameDone`) and [`PlannerApp`] (the planner partition:
//! the planning loop within its budget per window). Each checkpoints its own state into its own
//! slices of the warm-restart area (RAM kept across a warm reset) and, when there is one, of
//! non-volatile memory (kept across a power cycle), both memories under one sequence number
//! ([`persistence`]); on boot each restores the newest whole checkpoint of its two memories
//! whose contents validate, comparing sequence numbers with wrap-around, and falls back to the
//! next newest when one is refused. [`FlightApp`] runs both, the ports between them as calls,
//! for a target without partitions (`hil`'s native target: the planner unthrottled, the
//! reference).
//!
//! Task-network uplinks and ground commands are authenticated ([`sdls`], in the manner of CCSDS
//! SDLS): a reassembled uplink is verified (key, MAC, anti-replay sequence number) before it is
//! validated and loaded, a ground command before it is carried out, and in both cases the new
//! anti-replay counter is written to non-volatile memory before anything takes effect. A
//! refused one is answered with its typed reason ([`fsw_bridge::SecurityRefusal`]: as the
//! `UplinkNak` reason code, or in `GroundCommandNak`), counted in a metric
//! ([`metric::SECURITY_REFUSALS_FIRST`]), and changes nothing: the running plan, the counter and
//! the holds stay as they were.
//!
//! The firmware runs it inside its partitions; `hil`'s native target runs the very same code in
//! the host process, which is what makes the native-versus-emulated comparison meaningful.
#![no_std]
#![forbid(unsafe_code)]

use autonomy::checkpoint::{self, Record, RECORD_HEADER_LEN};
pub use autonomy::partitioned::{ExecutiveInput, PlannerInput, PlannerStatus as Status, Wire};
use autonomy::partitioned::{ExecutivePartition, PartitionSide, PlannerPartition, PlannerStatus};
use autonomy::{Outputs, RestoreInfo, WarmRestartArea};
use fsw_bridge::messages::UPLINK_CHUNK_MAX;
use fsw_bridge::security::{MAC_LEN, MAX_GROUND_HOLDS};
use fsw_bridge::{
    CommandArgs, CommandRefusal, GroundCommand, HostToTarget, MissionTimeUs, Opcode,
    SecurityHeader, SecurityRefusal, TargetToHost, TelemetryEvent,
};
pub use sdls::{SecurityAssociation, SecurityStore, StoreError};

/// Largest secured task-network uplink the application accepts, in bytes: the image plus its
/// security header and trailer (`sdls::uplink::OVERHEAD`, 42 bytes). 32 KiB since the lander
/// capacities (issue 14): a network of 256 light tasks (two constraints, three impacts each) is
/// about 25 KiB; at 16 KiB the largest such network was 162 tasks. What a checkpoint slot
/// holds is the tighter bound now (see the README's "Capacities and RAM").
pub const MAX_UPLINK_BYTES: usize = 32 * 1024;

/// `UplinkNak` reasons of the transfer itself (validation failures use the autonomy core's
/// `ValidationCode::code()`, which stay below 0xff00).
pub mod uplink_reason {
    /// A chunk arrived out of order (or a continuation without a first chunk).
    pub const OUT_OF_SEQUENCE: u16 = 0xff01;
    /// The announced or accumulated size exceeds [`super::MAX_UPLINK_BYTES`].
    pub const TOO_LARGE: u16 = 0xff02;
    /// The executive still owns tasks of the running plan; uplink again when it is idle.
    pub const BUSY: u16 = 0xff03;
    /// `total` was zero, or changed in the middle of a transfer.
    pub const BAD_TOTAL: u16 = 0xff04;
    // 0xff10 and up: the security refusals, `fsw_bridge::SecurityRefusal::code()`.
}

/// Ids of the `TelemetryEvent::Metric` records this application emits: the telemetry
/// dictionary's application table (`fsw_bridge::dictionary::app`, ids 0x1000-0x1fff), where
/// each id's name, unit, kind (measured cost or value) and channel are declared; the kernel's
/// are below 0x1000 (kernel-config's `abi::metric`, the dictionary's platform table).
pub mod metric {
    pub use fsw_bridge::dictionary::app::*;
    use fsw_bridge::dictionary::restored_from;

    /// `RESTORED_FROM`: the warm-restart area.
    pub const RESTORED_FROM_WARM: u64 = restored_from::WARM;
    /// `RESTORED_FROM`: non-volatile memory.
    pub const RESTORED_FROM_NV: u64 = restored_from::NV;
}

/// Validity checks the planner may spend in one window (see `autonomy::planner`); a cycle
/// that needs more goes on in the next frame's window.
pub const DEFAULT_PLANNER_BUDGET: u32 = 20_000;

/// Where the application's messages go.
pub trait Downlink {
    fn send(&mut self, msg: TargetToHost);
}

impl<F: FnMut(TargetToHost)> Downlink for F {
    fn send(&mut self, msg: TargetToHost) {
        self(msg)
    }
}

/// A CPU clock for cost accounting (the timebase on the target, 0 natively).
pub trait CpuClock {
    fn ticks(&mut self) -> u64;
}

/// A clock that always reads 0: the native target counts no cycles.
pub struct NoClock;

impl CpuClock for NoClock {
    fn ticks(&mut self) -> u64 {
        0
    }
}

/// How the application came up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BootOutcome {
    /// No whole checkpoint anywhere: waiting for an uplink.
    Cold,
    /// Restored from the warm-restart area.
    RestoredWarm(RestoreInfo),
    /// Restored from non-volatile memory.
    RestoredNv(RestoreInfo),
}

/// Sends the core's decisions down the link.
struct Decisions<'d, D: Downlink> {
    downlink: &'d mut D,
}

impl<D: Downlink> Outputs for Decisions<'_, D> {
    fn dispatch(&mut self, id: u32, opcode: Opcode, args: &CommandArgs) {
        self.downlink.send(TargetToHost::CommandDispatch {
            id,
            opcode,
            args: args.clone(),
        });
    }

    fn telemetry(&mut self, event: TelemetryEvent) {
        self.downlink.send(TargetToHost::Telemetry(event));
    }
}

/// Count a refusal for `reason`; the new count.
fn count_refusal(counts: &mut [u32; SecurityRefusal::COUNT], reason: SecurityRefusal) -> u64 {
    let count = &mut counts[reason.index()];
    *count = count.saturating_add(1);
    u64::from(*count)
}

fn metric_event(id: u16, value: u64) -> TargetToHost {
    TargetToHost::Telemetry(TelemetryEvent::Metric { id, value })
}

mod combined;
mod executive_app;
mod lander_app;
mod memories;
pub mod persistence;
mod planner_app;
mod plugin;
pub mod rover_exec;
pub mod rover_mission;
mod temporal_app;
#[cfg(test)]
mod tests;

pub use combined::*;
pub use executive_app::*;
pub use lander_app::*;
pub use memories::*;
pub use persistence::*;
pub use planner_app::*;
pub use plugin::*;
pub use temporal_app::*;
