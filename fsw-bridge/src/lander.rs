//! The Europa Lander's executor on the target (issues 11 and 12): the executor
//! (`lander::executor::Executor`) runs in the planner partition behind the `LanderApp`
//! plug-in, and the host's lander simulation steps it over the link.
//!
//! Host to target: [`HostToTarget::LanderBegin`](crate::HostToTarget::LanderBegin) announces a
//! setup (its length and CRC-32): what `Executor::new` takes, encoded by `lander::setup` (the
//! executor's configuration, the model's primitives, the flattened network, the placement's
//! horizon, charge, phases and Earth-in-view windows, the science context), then
//! [`HostToTarget::LanderChunk`](crate::HostToTarget::LanderChunk)s carry its bytes in order.
//! Once it is accepted, [`HostToTarget::LanderStep`](crate::HostToTarget::LanderStep) carries
//! one observation, numbered from 0 per setup. Target to host, inside
//! [`TargetToHost::Lander`](crate::TargetToHost::Lander): `Accepted` or `Refused` (with the
//! reason) for a setup; for a step, the decisions the executor logged since the last answer
//! (`Decision`, in order), then `Answer` with the directive. A step whose search needs more than
//! a window's CPU share goes on in the next granted windows: the target answers only with the
//! final directive, so the host's mission time does not depend on how the search was split.
//!
//! Times are integers with their unit in the name (mission time in µs, energy in mJ, the
//! planner partition's CPU in timebase ticks). Every report fits the planner partition's
//! outbound port (64 bytes, checked by this crate's tests for the largest of each).
use serde::{Deserialize, Serialize};

use crate::MissionTimeUs;

/// Bytes of setup carried by one LanderChunk (as a temporal task's chunk).
pub const LANDER_CHUNK_MAX: usize = 128;

/// The bytes of a LanderChunk.
pub type LanderChunkBytes = heapless::Vec<u8, LANDER_CHUNK_MAX>;

/// How a dispatched primitive ended (`lander::executor::TaskResult`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderTaskResult {
    Succeeded,
    Failed,
    Faulted,
}

/// Something that happened since the last step (`lander::executor::Event`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderEvent {
    Finished {
        result: LanderTaskResult,
        duration_us: u64,
        energy_mj: u64,
        /// The biosignature result: Some(true) positive, Some(false) negative.
        positive: Option<bool>,
    },
    GroundResume,
}

/// The link to Earth as the executor knows it (`lander::comms::CommsModel`), integers with
/// their unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LanderComms {
    pub rate_bps: u64,
    pub overhead_us: u64,
    pub thermal_limit_us: u64,
    pub radio_power_mw: u64,
    pub per_downlink_mj: u64,
    pub per_sol_mj: u64,
    pub sol_us: u64,
}

/// A data product onboard (`lander::downlink::DataProduct`); `tier` is the tier's index
/// (Critical 0, Decisional 1, Mandatory 2, Residual 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LanderProduct {
    pub size_bytes: u64,
    pub value: u64,
    pub created_at: MissionTimeUs,
    pub tier: u8,
}

/// Products carried by one [`LanderInput::Products`] (the largest fits the routed port).
pub const LANDER_PRODUCTS_PER_MESSAGE: usize = 4;

/// The executor's link and data inputs (elap-downlink's `Executor::set_comms` and
/// `Executor::set_onboard_data`), sent before the step that sees them.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LanderInput {
    /// The link model in force (None: data volume not modelled).
    Comms(Option<LanderComms>),
    /// Products `first..first + products.len()` of the `total` onboard; the list is applied
    /// when its last part arrives (parts in order, from 0).
    Products {
        first: u8,
        total: u8,
        products: heapless::Vec<LanderProduct, LANDER_PRODUCTS_PER_MESSAGE>,
    },
}

/// One step's input (`lander::executor::Observation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LanderObservation {
    pub now: MissionTimeUs,
    pub battery_mj: u64,
    pub preconditions_met: bool,
    pub event: Option<LanderEvent>,
}

/// Why execution stopped or replanned (`lander::executor::Reason`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderReason {
    Initial,
    Failed,
    PreconditionsUnmet,
    Fault,
    Discovery,
    Overrun,
    ReplanFailed,
    /// Appended (elap-downlink): a task's data could not be downlinked.
    DataVolume,
}

/// One step's output (`lander::executor::Directive`); `kind` is the primitive kind's index in
/// `lander::htn::PrimitiveKind::ALL`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderDirective {
    Dispatch {
        chain: u16,
        primitive: u8,
        kind: u8,
        site: Option<u8>,
        target: Option<u8>,
        expected_end: MissionTimeUs,
        expected_energy_mj: u64,
    },
    Running {
        expected_end: MissionTimeUs,
    },
    Wait {
        until: MissionTimeUs,
    },
    Pushing {
        deadline: MissionTimeUs,
    },
    Planning {
        reason: LanderReason,
    },
    HaltedForGround {
        reason: LanderReason,
    },
    Abandoned {
        reason: LanderReason,
    },
    Done,
}

/// What a decision was (`lander::executor::DecisionKind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderDecisionKind {
    Dispatched,
    Completed,
    Failed,
    Retried,
    PushStarted,
    PushTimedOut,
    ParameterUpdated,
    ReplanStarted(LanderReason),
    Planned { chains: u8 },
    HaltedForGround(LanderReason),
    GroundResumed,
    Abandoned(LanderReason),
    Finished,
}

/// One entry of the executor's transcript (`lander::executor::Decision`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LanderDecision {
    pub at: MissionTimeUs,
    pub chain: u16,
    pub primitive: u8,
    pub kind: LanderDecisionKind,
}

/// Why a setup does not decode or validate (the part that is wrong; `lander::setup`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderSetupError {
    /// The bytes do not decode as a setup (cut short, a bad tag, a list over its capacity):
    /// `part` 0 the header, 1 a primitive, 2 a chain, 3 a downlink problem; `offset` where
    /// reading stopped.
    Malformed { part: u8, offset: u32 },
    /// The header's format version is not this target's.
    Version { got: u8 },
    /// Bytes after the last chain.
    TrailingBytes { offset: u32 },
    /// A strategy number out of range.
    BadStrategy,
    /// A score above 1.0 in the science context.
    BadScore,
    /// The phase changes are not in increasing time order, or name a phase out of range.
    BadPhases,
    /// The Earth-in-view windows are not sorted, disjoint and non-empty, or too many.
    BadWindows,
    /// The horizon ends before it starts.
    BadHorizon,
    /// An energy over the algorithms' largest (`lander::capacity::MAX_ENERGY_MJ`), or a product
    /// size or value over its largest: `index` the primitive or chain; `u16::MAX` a value of
    /// the header (the charge, reserve or hotel load, or in the learned part a parameter's
    /// energy, the sol's radio energy, or a volume factor over its largest or given twice).
    OutOfRange { index: u16 },
    /// More primitives or chains than the target holds.
    TooMany,
    /// Chain `chain` names a primitive the model does not have, has none, or a task slot or
    /// batch over the search's capacity.
    BadChain { chain: u16 },
    /// The downlink manager refused the problem (`lander::downlink::DownlinkError`'s index).
    BadDownlinkProblem { error: u8 },
}

/// Why a setup or a step was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LanderRefusal {
    /// A chunk for no setup, for another one, or not at the next offset.
    OutOfSequence { expected_offset: u32 },
    /// The announced length is zero or over the target's setup buffer (`capacity` bytes).
    TooLarge { capacity: u32 },
    /// The bytes received do not have the announced CRC-32.
    BadCrc { computed: u32 },
    /// The setup does not decode or validate.
    BadSetup(LanderSetupError),
    /// A step for no accepted setup, or for another one than the one in force.
    NoSetup,
    /// A step whose number is not the next one (`expected`).
    OutOfOrder { expected: u32 },
    /// A step while the previous one is still being answered.
    Busy,
    /// (Appended.) A link model or product list the executor refused
    /// (`lander::comms::CommsError`'s index: 0 invalid, 1 too many products, 2 a product out
    /// of range), or a product part out of order (3) or with an unknown tier (4).
    BadInput { error: u8 },
}

/// What the planner partition says about the lander's executor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LanderReport {
    /// Setup `setup` arrived whole, matched its CRC, decoded and validated; the executor is
    /// built from it (its steps are numbered from 0).
    Accepted {
        setup: u16,
        primitives: u16,
        chains: u16,
        bytes: u32,
        /// The planner partition's CPU to decode, validate and build the executor, timebase
        /// ticks (0 natively).
        build_ticks: u32,
    },
    /// A setup (`seq` None) or a step (`seq`) was refused.
    Refused {
        setup: u16,
        seq: Option<u32>,
        reason: LanderRefusal,
    },
    /// Decision `index` of the executor's transcript (in order, before the step's Answer).
    Decision {
        setup: u16,
        index: u16,
        decision: LanderDecision,
    },
    /// Step `seq` answered: its directive; `log_len` decisions in the transcript so far.
    Answer {
        setup: u16,
        seq: u32,
        directive: LanderDirective,
        log_len: u16,
        /// The planner partition's CPU for the step (every window of it), timebase ticks
        /// (saturated; 0 natively).
        ticks: u32,
        /// Planner windows the step ran in.
        windows: u16,
    },
    /// The downlink problem uplinked as `setup` (a blob tagged
    /// `lander::setup::DOWNLINK_PROBLEM_TAG`) solved by the downlink manager (issue 11's
    /// measure of its cost): the value downlinked, whether it is proven optimal, the knapsack's
    /// nodes, and the planner partition's CPU to load and solve it in its windows. (After
    /// Answer: variants are only ever appended, so recorded messages keep decoding.)
    DownlinkSolved {
        setup: u16,
        value: u64,
        proven: bool,
        nodes: u32,
        ticks: u32,
        windows: u16,
    },
}

impl LanderReport {
    /// The setup the report is about.
    pub fn setup(&self) -> u16 {
        match *self {
            LanderReport::Accepted { setup, .. }
            | LanderReport::Refused { setup, .. }
            | LanderReport::Decision { setup, .. }
            | LanderReport::Answer { setup, .. }
            | LanderReport::DownlinkSolved { setup, .. } => setup,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{HostToTarget, TargetToHost};

    fn size<T: Serialize>(v: &T) -> usize {
        let mut buf = [0u8; 512];
        postcard::to_slice(v, &mut buf).map(|b| b.len()).unwrap()
    }

    /// The largest of each report fits the planner's outbound port (64 bytes), the largest
    /// host message its routed port (160 bytes).
    #[test]
    fn largest_messages_fit_their_ports() {
        let t = MissionTimeUs(u64::MAX);
        let dispatch = LanderDirective::Dispatch {
            chain: u16::MAX,
            primitive: u8::MAX,
            kind: u8::MAX,
            site: Some(u8::MAX),
            target: Some(u8::MAX),
            expected_end: t,
            expected_energy_mj: u64::MAX,
        };
        let reports = [
            LanderReport::Accepted {
                setup: u16::MAX,
                primitives: u16::MAX,
                chains: u16::MAX,
                bytes: u32::MAX,
                build_ticks: u32::MAX,
            },
            LanderReport::Refused {
                setup: u16::MAX,
                seq: Some(u32::MAX),
                reason: LanderRefusal::BadSetup(LanderSetupError::Malformed {
                    part: u8::MAX,
                    offset: u32::MAX,
                }),
            },
            LanderReport::Decision {
                setup: u16::MAX,
                index: u16::MAX,
                decision: LanderDecision {
                    at: t,
                    chain: u16::MAX,
                    primitive: u8::MAX,
                    kind: LanderDecisionKind::Planned { chains: u8::MAX },
                },
            },
            LanderReport::DownlinkSolved {
                setup: u16::MAX,
                value: u64::MAX,
                proven: true,
                nodes: u32::MAX,
                ticks: u32::MAX,
                windows: u16::MAX,
            },
            LanderReport::Answer {
                setup: u16::MAX,
                seq: u32::MAX,
                directive: dispatch,
                log_len: u16::MAX,
                ticks: u32::MAX,
                windows: u16::MAX,
            },
        ];
        for r in reports {
            let n = size(&TargetToHost::Lander(r));
            assert!(n <= 64, "{r:?}: {n} bytes");
        }
        let step = HostToTarget::LanderStep {
            setup: u16::MAX,
            seq: u32::MAX,
            observation: LanderObservation {
                now: t,
                battery_mj: u64::MAX,
                preconditions_met: true,
                event: Some(LanderEvent::Finished {
                    result: LanderTaskResult::Faulted,
                    duration_us: u64::MAX,
                    energy_mj: u64::MAX,
                    positive: Some(false),
                }),
            },
        };
        assert!(size(&step) <= 160);
        let comms = HostToTarget::LanderInput {
            setup: u16::MAX,
            input: LanderInput::Comms(Some(LanderComms {
                rate_bps: u64::MAX,
                overhead_us: u64::MAX,
                thermal_limit_us: u64::MAX,
                radio_power_mw: u64::MAX,
                per_downlink_mj: u64::MAX,
                per_sol_mj: u64::MAX,
                sol_us: u64::MAX,
            })),
        };
        assert!(size(&comms) <= 160, "{}", size(&comms));
        let product = LanderProduct {
            size_bytes: u64::MAX,
            value: u64::MAX,
            created_at: t,
            tier: u8::MAX,
        };
        let products = HostToTarget::LanderInput {
            setup: u16::MAX,
            input: LanderInput::Products {
                first: u8::MAX,
                total: u8::MAX,
                products: heapless::Vec::from_slice(&[product; LANDER_PRODUCTS_PER_MESSAGE])
                    .unwrap(),
            },
        };
        assert!(size(&products) <= 160, "{}", size(&products));
        let chunk = HostToTarget::LanderChunk {
            setup: u16::MAX,
            offset: u32::MAX,
            bytes: LanderChunkBytes::from_slice(&[0xff; LANDER_CHUNK_MAX]).unwrap(),
        };
        assert!(size(&chunk) <= 160, "{}", size(&chunk));
    }
}
