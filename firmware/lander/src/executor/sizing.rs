//! Sizing the downlink being dispatched (what it carries and how long it lasts), divided
//! across executor calls: the downlink manager's knapsack runs at most
//! [`SIZING_NODES_PER_EXPLORATION`] nodes per exploration of the call's budget, and the
//! executor answers [`Directive::Planning`] until the knapsack is proven or has used its
//! [`DATA_KNAPSACK_BUDGET`] nodes; then the primitive is dispatched. The knapsack resumes
//! exactly, so the downlink is sized as [`crate::comms::next_downlink`] sizes it in one call,
//! whatever the budget per call (a large budget does it all in the dispatching call).
//!
//! Why: one call of up to 4,000 knapsack nodes (about 4 million guest instructions) does not
//! fit the planner partition's window, and the kernel's health monitor reported it as an
//! overrun (ELAP 12, step 29).
use fsw_bridge::MissionTimeUs;
use heapless::Vec;

use super::*;
use crate::comms::{NextDownlink, DATA_KNAPSACK_BUDGET};
use crate::downlink::DownlinkManager;
use crate::placement::is_downlink;

/// Knapsack nodes per exploration of an executor call's budget while a dispatched downlink is
/// sized: an exploration of the RSM-1 model costs about as much as 30 to 50 knapsack nodes
/// (about 36,600 and 1,000 guest instructions), so a call sizing a downlink costs no more than
/// one that searches.
pub const SIZING_NODES_PER_EXPLORATION: u32 = 32;

/// A dispatched downlink being sized.
pub(super) struct Sizing {
    manager: DownlinkManager,
    next: NextDownlink,
    /// Knapsack nodes used so far.
    used: u32,
    /// (sol, mJ spent in it before this downlink).
    spent: (u16, u64),
}

impl Sizing {
    pub(super) const fn new() -> Self {
        Self {
            manager: DownlinkManager::new(),
            next: NextDownlink::new(),
            used: 0,
            spent: (0, 0),
        }
    }
}

impl<const NODES: usize, const QUEUE: usize> Executor<NODES, QUEUE> {
    /// Starts sizing the downlink about to be dispatched (the downlink manager's assignment
    /// over the onboard products and those the rest of the plan creates, against it and the
    /// plan's later downlinks): false when the pending primitive is not a downlink or no link
    /// is modelled (nothing to size).
    pub(super) fn begin_sizing(&mut self) -> bool {
        let Some(comms) = self.comms else {
            return false;
        };
        let Some(step) = self.steps.get(self.cursor).copied() else {
            return false;
        };
        let is_dl = |p: u8| {
            self.primitives
                .get(usize::from(p))
                .is_some_and(|s| is_downlink(s.kind))
        };
        if !is_dl(step.primitive) {
            return false;
        }
        let mut later: Vec<DataProduct, MAX_DATA_PRODUCTS> = Vec::new();
        let mut downlinks: Vec<(u64, u64), MAX_DOWNLINKS> = Vec::new();
        for s in self.steps.iter().skip(self.cursor + 1) {
            let end = s.start.0.saturating_add(s.duration_us);
            if is_dl(s.primitive) {
                let _ = downlinks.push((s.start.0, end));
            }
            if let Some(spec) = self.primitives.get(usize::from(s.primitive)) {
                if let Some(p) = spec.product {
                    let _ = later.push(DataProduct {
                        size_bytes: self.volumes.scale(spec.kind, p.size_bytes),
                        value: p.value,
                        created_at: MissionTimeUs(end),
                        tier: p.tier,
                    });
                }
            }
        }
        let now = self.now.0;
        let window_end = self
            .timeline
            .earth
            .windows
            .windows()
            .iter()
            .find(|w| w.start.0 <= now && now < w.end.0)
            .map_or(u64::MAX, |w| w.end.0);
        let sol = comms.sol_of(now);
        let spent = if self.comm_spent.0 == sol {
            self.comm_spent
        } else {
            (sol, 0)
        };
        let sizing = &mut self.sizing;
        sizing.used = 0;
        sizing.spent = spent;
        let loaded = sizing.next.load(
            &comms,
            &self.onboard,
            &later,
            (now, step.duration_us, window_end),
            &downlinks,
            spent,
            &mut sizing.manager,
            &mut self.payload,
        );
        if !loaded {
            // Nothing to run: `continue_sizing` finishes at once.
            sizing.used = DATA_KNAPSACK_BUDGET;
        }
        true
    }

    /// Runs the sizing's knapsack for `budget` explorations' worth of nodes; true when it is
    /// done and the downlink sized (its duration, energy and payload set, the sol's radio
    /// energy counted).
    pub(super) fn continue_sizing(&mut self, budget: u32) -> bool {
        let sizing = &mut self.sizing;
        if sizing.used < DATA_KNAPSACK_BUDGET && !sizing.manager.proven_optimal() {
            let nodes = budget
                .max(1)
                .saturating_mul(SIZING_NODES_PER_EXPLORATION)
                .min(DATA_KNAPSACK_BUDGET - sizing.used);
            let step = sizing.manager.step(nodes);
            sizing.used = sizing.used.saturating_add(step.used);
            if !step.done && sizing.used < DATA_KNAPSACK_BUDGET {
                return false;
            }
        }
        let Some(comms) = self.comms else {
            return true;
        };
        let duration = sizing
            .next
            .finish(&comms, &sizing.manager, &mut self.payload);
        let (sol, spent) = sizing.spent;
        if let Some(s) = self.steps.get_mut(self.cursor) {
            if duration != s.duration_us && s.duration_us > 0 {
                s.energy_mj = u64::try_from(
                    u128::from(s.energy_mj) * u128::from(duration) / u128::from(s.duration_us),
                )
                .unwrap_or(MAX_ENERGY_MJ)
                .min(MAX_ENERGY_MJ);
                s.duration_us = duration;
            }
        }
        let tx = duration
            .saturating_sub(comms.overhead_us)
            .min(comms.max_transmit_us());
        let mj = u64::try_from(u128::from(tx) * u128::from(comms.radio_power_mw) / 1_000_000)
            .unwrap_or(u64::MAX);
        self.comm_spent = (sol, spent.saturating_add(mj));
        true
    }
}
