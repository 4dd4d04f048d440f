//! The downlink manager as a veto in the search (seed 000 Appendix A): a chain that creates data
//! is added only if the downlink manager, solving the problem with the plan's products and the
//! chain's, downlinks every product of the chain and leaves no Critical, Decisional or
//! Mandatory product behind. So the lander stops generating data while it still has the
//! downlink capacity to return everything it must.
//!
//! [`DownlinkGate`] wraps another [`ChainPlacement`]: the inner placement says where the chain
//! starts; the products' creation times follow from that start and their offsets in the chain.
//! Chains that create no data pass through. The opportunities and their capacities are given
//! (they come from the comms model: Earth in view, per-sol allocations, thermal limit, rate);
//! the energy of the Downlink primitives is in the chains' costs.
//!
//! The knapsack gets `knapsack_budget` nodes per check; when it is not proven optimal by then,
//! the best assignment found decides (a conservative answer: a chain may be refused that the
//! optimum would have admitted). [`GateStats`] counts the checks, the vetoes and the knapsack
//! nodes, and how many checks ended unproven.
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use crate::capacity::*;
use crate::downlink::{DataProduct, DownlinkManager, Placement};
use crate::htn::FlatNetwork;
use crate::search::{ChainPlacement, PlacedChain};

/// Counters of a gate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GateStats {
    /// Downlink problems solved.
    pub checks: u32,
    /// Chains refused because their data (or required data) would not go down.
    pub vetoes: u32,
    /// Chains refused because the products exceeded [`MAX_DATA_PRODUCTS`].
    pub capacity_vetoes: u32,
    /// Knapsack nodes over all checks (branch and bound and surrogate checks).
    pub knapsack_nodes: u64,
    /// Largest knapsack node count of one check.
    pub max_knapsack_nodes: u64,
    /// Checks whose knapsack was not proven optimal within the budget.
    pub unproven: u32,
}

/// A placement with the downlink manager's veto.
pub struct DownlinkGate<P> {
    pub inner: P,
    /// Products already onboard (or otherwise expected), created before the plan's.
    existing: Vec<DataProduct, MAX_DATA_PRODUCTS>,
    starts: Vec<MissionTimeUs, MAX_DOWNLINKS>,
    capacities: Vec<u64, MAX_DOWNLINKS>,
    /// Knapsack nodes per check; `None`: to the proof.
    pub knapsack_budget: Option<u32>,
    manager: DownlinkManager,
    pub stats: GateStats,
}

impl<P> DownlinkGate<P> {
    /// A gate over `inner` for these opportunities (`starts` and byte `capacities`, in start
    /// order, for example from [`crate::downlink::capacities`]) and products onboard.
    pub fn new(
        inner: P,
        existing: &[DataProduct],
        starts: &[MissionTimeUs],
        capacities: &[u64],
    ) -> Option<Self> {
        if starts.len() != capacities.len() {
            return None;
        }
        Some(Self {
            inner,
            existing: Vec::from_slice(existing).ok()?,
            starts: Vec::from_slice(starts).ok()?,
            capacities: Vec::from_slice(capacities).ok()?,
            knapsack_budget: None,
            manager: DownlinkManager::new(),
            stats: GateStats::default(),
        })
    }

    /// The manager as left by the last check (its products: existing, then the plan's in plan
    /// order, then the candidate's).
    pub fn last_solution(&self) -> &DownlinkManager {
        &self.manager
    }
}

impl<P: ChainPlacement> ChainPlacement for DownlinkGate<P> {
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<MissionTimeUs> {
        let start = self.inner.place(network, plan, candidate)?;
        let chain = network.chains.get(usize::from(candidate))?;
        if chain.products.is_empty() {
            return Some(start);
        }
        let mut products: Vec<DataProduct, MAX_DATA_PRODUCTS> = self.existing.clone();
        let candidate_placed = PlacedChain {
            chain: candidate,
            start,
        };
        let placed = plan.iter().chain(core::iter::once(&candidate_placed));
        for p in placed {
            let Some(c) = network.chains.get(usize::from(p.chain)) else {
                continue;
            };
            for product in &c.products {
                let made = DataProduct {
                    size_bytes: product.spec.size_bytes,
                    value: product.spec.value,
                    created_at: MissionTimeUs(p.start.0.saturating_add(product.offset_us)),
                    tier: product.spec.tier,
                };
                if products.push(made).is_err() {
                    self.stats.capacity_vetoes += 1;
                    return None;
                }
            }
        }
        let first_candidate_product = products.len() - chain.products.len();
        if self
            .manager
            .load_capacities(&products, &self.starts, &self.capacities)
            .is_err()
        {
            self.stats.capacity_vetoes += 1;
            return None;
        }
        match self.knapsack_budget {
            Some(budget) => {
                self.manager.step(budget);
            }
            None => self.manager.solve(),
        }
        let knapsack = self.manager.knapsack();
        let nodes = knapsack.nodes() + knapsack.bound_nodes();
        self.stats.checks += 1;
        self.stats.knapsack_nodes += nodes;
        self.stats.max_knapsack_nodes = self.stats.max_knapsack_nodes.max(nodes);
        if !self.manager.proven_optimal() {
            self.stats.unproven += 1;
        }
        let own_downlinked = (first_candidate_product..products.len())
            .all(|i| self.manager.placement(i) != Placement::NotDownlinked);
        if own_downlinked && self.manager.required_unplaced() == 0 {
            Some(start)
        } else {
            self.stats.vetoes += 1;
            None
        }
    }

    fn utility(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> crate::utility::RankedUtility {
        self.inner.utility(network, plan, candidate)
    }
}
