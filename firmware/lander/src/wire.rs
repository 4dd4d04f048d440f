//! The executor's values on the link ([`fsw_bridge::lander`]): observations, directives and
//! decisions, converted both ways, exactly (the tests round-trip every kind).
use fsw_bridge::lander::{
    LanderComms, LanderDecision, LanderDecisionKind, LanderDirective, LanderEvent,
    LanderObservation, LanderProduct, LanderReason, LanderTaskResult,
};

use crate::comms::CommsModel;
use crate::downlink::DataProduct;
use crate::htn::Tier;

use crate::assessor::Biosignature;
use crate::executor::{
    Decision, DecisionKind, Directive, Event, Observation, Outcome, Reason, TaskResult,
};
use crate::htn::PrimitiveKind;

/// A wire value that names something this side does not have (a primitive kind index out of
/// range).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnknownKind(pub u8);

pub fn reason_to_wire(r: Reason) -> LanderReason {
    match r {
        Reason::Initial => LanderReason::Initial,
        Reason::Failed => LanderReason::Failed,
        Reason::PreconditionsUnmet => LanderReason::PreconditionsUnmet,
        Reason::Fault => LanderReason::Fault,
        Reason::Discovery => LanderReason::Discovery,
        Reason::Overrun => LanderReason::Overrun,
        Reason::ReplanFailed => LanderReason::ReplanFailed,
        Reason::DataVolume => LanderReason::DataVolume,
    }
}

pub fn reason_from_wire(r: LanderReason) -> Reason {
    match r {
        LanderReason::Initial => Reason::Initial,
        LanderReason::Failed => Reason::Failed,
        LanderReason::PreconditionsUnmet => Reason::PreconditionsUnmet,
        LanderReason::Fault => Reason::Fault,
        LanderReason::Discovery => Reason::Discovery,
        LanderReason::Overrun => Reason::Overrun,
        LanderReason::ReplanFailed => Reason::ReplanFailed,
        LanderReason::DataVolume => Reason::DataVolume,
    }
}

pub fn observation_to_wire(o: &Observation) -> LanderObservation {
    LanderObservation {
        now: o.now,
        battery_mj: o.battery_mj,
        preconditions_met: o.preconditions_met,
        event: o.event.map(|e| match e {
            Event::Finished(out) => LanderEvent::Finished {
                result: match out.result {
                    TaskResult::Succeeded => LanderTaskResult::Succeeded,
                    TaskResult::Failed => LanderTaskResult::Failed,
                    TaskResult::Faulted => LanderTaskResult::Faulted,
                },
                duration_us: out.duration_us,
                energy_mj: out.energy_mj,
                positive: out.biosignature.map(|b| b == Biosignature::Positive),
            },
            Event::GroundResume => LanderEvent::GroundResume,
        }),
    }
}

pub fn observation_from_wire(o: &LanderObservation) -> Observation {
    Observation {
        now: o.now,
        battery_mj: o.battery_mj,
        preconditions_met: o.preconditions_met,
        event: o.event.map(|e| match e {
            LanderEvent::Finished {
                result,
                duration_us,
                energy_mj,
                positive,
            } => Event::Finished(Outcome {
                result: match result {
                    LanderTaskResult::Succeeded => TaskResult::Succeeded,
                    LanderTaskResult::Failed => TaskResult::Failed,
                    LanderTaskResult::Faulted => TaskResult::Faulted,
                },
                duration_us,
                energy_mj,
                biosignature: positive.map(|p| {
                    if p {
                        Biosignature::Positive
                    } else {
                        Biosignature::Negative
                    }
                }),
            }),
            LanderEvent::GroundResume => Event::GroundResume,
        }),
    }
}

fn kind_index(k: PrimitiveKind) -> u8 {
    PrimitiveKind::ALL
        .iter()
        .position(|&x| x == k)
        .map_or(u8::MAX, |i| i as u8)
}

pub fn directive_to_wire(d: &Directive) -> LanderDirective {
    match *d {
        Directive::Dispatch {
            chain,
            primitive,
            kind,
            site,
            target,
            expected_end,
            expected_energy_mj,
        } => LanderDirective::Dispatch {
            chain,
            primitive,
            kind: kind_index(kind),
            site,
            target,
            expected_end,
            expected_energy_mj,
        },
        Directive::Running { expected_end } => LanderDirective::Running { expected_end },
        Directive::Wait { until } => LanderDirective::Wait { until },
        Directive::Pushing { deadline } => LanderDirective::Pushing { deadline },
        Directive::Planning { reason } => LanderDirective::Planning {
            reason: reason_to_wire(reason),
        },
        Directive::HaltedForGround { reason } => LanderDirective::HaltedForGround {
            reason: reason_to_wire(reason),
        },
        Directive::Abandoned { reason } => LanderDirective::Abandoned {
            reason: reason_to_wire(reason),
        },
        Directive::Done => LanderDirective::Done,
    }
}

pub fn directive_from_wire(d: &LanderDirective) -> Result<Directive, UnknownKind> {
    Ok(match *d {
        LanderDirective::Dispatch {
            chain,
            primitive,
            kind,
            site,
            target,
            expected_end,
            expected_energy_mj,
        } => Directive::Dispatch {
            chain,
            primitive,
            kind: *PrimitiveKind::ALL
                .get(usize::from(kind))
                .ok_or(UnknownKind(kind))?,
            site,
            target,
            expected_end,
            expected_energy_mj,
        },
        LanderDirective::Running { expected_end } => Directive::Running { expected_end },
        LanderDirective::Wait { until } => Directive::Wait { until },
        LanderDirective::Pushing { deadline } => Directive::Pushing { deadline },
        LanderDirective::Planning { reason } => Directive::Planning {
            reason: reason_from_wire(reason),
        },
        LanderDirective::HaltedForGround { reason } => Directive::HaltedForGround {
            reason: reason_from_wire(reason),
        },
        LanderDirective::Abandoned { reason } => Directive::Abandoned {
            reason: reason_from_wire(reason),
        },
        LanderDirective::Done => Directive::Done,
    })
}

pub fn decision_to_wire(d: &Decision) -> LanderDecision {
    LanderDecision {
        at: d.at,
        chain: d.chain,
        primitive: d.primitive,
        kind: match d.kind {
            DecisionKind::Dispatched => LanderDecisionKind::Dispatched,
            DecisionKind::Completed => LanderDecisionKind::Completed,
            DecisionKind::Failed => LanderDecisionKind::Failed,
            DecisionKind::Retried => LanderDecisionKind::Retried,
            DecisionKind::PushStarted => LanderDecisionKind::PushStarted,
            DecisionKind::PushTimedOut => LanderDecisionKind::PushTimedOut,
            DecisionKind::ParameterUpdated => LanderDecisionKind::ParameterUpdated,
            DecisionKind::ReplanStarted(r) => LanderDecisionKind::ReplanStarted(reason_to_wire(r)),
            DecisionKind::Planned { chains } => LanderDecisionKind::Planned { chains },
            DecisionKind::HaltedForGround(r) => {
                LanderDecisionKind::HaltedForGround(reason_to_wire(r))
            }
            DecisionKind::GroundResumed => LanderDecisionKind::GroundResumed,
            DecisionKind::Abandoned(r) => LanderDecisionKind::Abandoned(reason_to_wire(r)),
            DecisionKind::Finished => LanderDecisionKind::Finished,
        },
    }
}

pub fn decision_from_wire(d: &LanderDecision) -> Decision {
    Decision {
        at: d.at,
        chain: d.chain,
        primitive: d.primitive,
        kind: match d.kind {
            LanderDecisionKind::Dispatched => DecisionKind::Dispatched,
            LanderDecisionKind::Completed => DecisionKind::Completed,
            LanderDecisionKind::Failed => DecisionKind::Failed,
            LanderDecisionKind::Retried => DecisionKind::Retried,
            LanderDecisionKind::PushStarted => DecisionKind::PushStarted,
            LanderDecisionKind::PushTimedOut => DecisionKind::PushTimedOut,
            LanderDecisionKind::ParameterUpdated => DecisionKind::ParameterUpdated,
            LanderDecisionKind::ReplanStarted(r) => {
                DecisionKind::ReplanStarted(reason_from_wire(r))
            }
            LanderDecisionKind::Planned { chains } => DecisionKind::Planned { chains },
            LanderDecisionKind::HaltedForGround(r) => {
                DecisionKind::HaltedForGround(reason_from_wire(r))
            }
            LanderDecisionKind::GroundResumed => DecisionKind::GroundResumed,
            LanderDecisionKind::Abandoned(r) => DecisionKind::Abandoned(reason_from_wire(r)),
            LanderDecisionKind::Finished => DecisionKind::Finished,
        },
    }
}

pub fn comms_to_wire(c: &CommsModel) -> LanderComms {
    LanderComms {
        rate_bps: c.rate_bps,
        overhead_us: c.overhead_us,
        thermal_limit_us: c.thermal_limit_us,
        radio_power_mw: c.radio_power_mw,
        per_downlink_mj: c.per_downlink_mj,
        per_sol_mj: c.per_sol_mj,
        sol_us: c.sol_us,
    }
}

pub fn comms_from_wire(c: &LanderComms) -> CommsModel {
    CommsModel {
        rate_bps: c.rate_bps,
        overhead_us: c.overhead_us,
        thermal_limit_us: c.thermal_limit_us,
        radio_power_mw: c.radio_power_mw,
        per_downlink_mj: c.per_downlink_mj,
        per_sol_mj: c.per_sol_mj,
        sol_us: c.sol_us,
    }
}

const TIERS: [Tier; 4] = [
    Tier::Critical,
    Tier::Decisional,
    Tier::Mandatory,
    Tier::Residual,
];

pub fn product_to_wire(p: &DataProduct) -> LanderProduct {
    LanderProduct {
        size_bytes: p.size_bytes,
        value: p.value,
        created_at: p.created_at,
        tier: TIERS.iter().position(|&t| t == p.tier).unwrap_or(0) as u8,
    }
}

/// A product from the wire; an unknown tier index is refused (the index).
pub fn product_from_wire(p: &LanderProduct) -> Result<DataProduct, UnknownKind> {
    let tier = *TIERS.get(usize::from(p.tier)).ok_or(UnknownKind(p.tier))?;
    Ok(DataProduct {
        size_bytes: p.size_bytes,
        value: p.value,
        created_at: p.created_at,
        tier,
    })
}
