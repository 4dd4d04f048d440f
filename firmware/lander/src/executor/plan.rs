//! The executor's model updates (IV.C.3), science context, replanning from the current state
//! (III.C), plan installation and the prediction helpers: a second `impl` block of
//! [`Executor`].
use heapless::Vec;

use fsw_bridge::MissionTimeUs;

use super::*;
use crate::assessor::{assess_chains, AssessedPlacement, Biosignature, SampleRef};
use crate::comms::{size_downlinks, DataPlacement, DataView};
use crate::downlink::Tier;
use crate::placement::{downlink_spans, is_downlink, CachedTimeline};

impl<const NODES: usize, const QUEUE: usize> Executor<NODES, QUEUE> {
    /// Model parameter update (IV.C.3).
    pub(super) fn learn(&mut self, spec: &PrimitiveSpec, outcome: Outcome) {
        let Some(site) = spec.site else {
            return;
        };
        let update = ParameterUpdate {
            kind: spec.kind,
            site,
            duration_us: outcome.duration_us,
            energy_mj: outcome.energy_mj.min(MAX_ENERGY_MJ),
        };
        match self
            .params
            .iter_mut()
            .find(|p| p.kind == spec.kind && p.site == site)
        {
            Some(p) => *p = update,
            None => {
                if self.params.push(update).is_err() {
                    return;
                }
            }
        }
        self.stats.parameter_updates += 1;
        self.record_step(DecisionKind::ParameterUpdated);
        for i in self.cursor + 1..self.steps.len() {
            let Some(primitive) = self.steps.get(i).map(|s| s.primitive) else {
                continue;
            };
            let same = self
                .primitives
                .get(usize::from(primitive))
                .is_some_and(|p| p.kind == spec.kind && p.site == Some(site));
            if let (true, Some(s)) = (same, self.steps.get_mut(i)) {
                s.duration_us = update.duration_us;
                s.energy_mj = update.energy_mj;
            }
        }
    }

    /// Updates the science context from a finished primitive of a sampling chain.
    pub(super) fn note_science(&mut self, spec: &PrimitiveSpec, step: &ExecStep, outcome: Outcome) {
        let sample: Option<SampleRef> = self
            .science
            .get(usize::from(step.chain))
            .and_then(|s| s.sample);
        match spec.kind {
            PrimitiveKind::ExcavateSite => {
                let prior = self.assessor.post_excavation_prior;
                if let Some(site) = spec
                    .site
                    .and_then(|s| self.context.sites.get_mut(usize::from(s)))
                {
                    site.post_excavation.get_or_insert(prior);
                }
            }
            PrimitiveKind::CollectSample => {
                if let Some(t) = sample.and_then(|s| self.context.target_mut(s)) {
                    t.collected = true;
                }
            }
            PrimitiveKind::ScienceAnalyze => {
                if let (Some(bio), Some(t)) = (
                    outcome.biosignature,
                    sample.and_then(|s| self.context.target_mut(s)),
                ) {
                    t.biosignature = Some(bio);
                    if bio == Biosignature::Negative {
                        self.replan_pending = Some(Reason::Discovery);
                    }
                }
            }
            _ => {}
        }
    }

    /// A chain ends: executed to the end (`done`), or abandoned after a failure (its task is
    /// then failed, and its target too).
    pub(super) fn close_chain(&mut self, chain: u16, done: bool) {
        let Some(c) = self.network.chains.get(usize::from(chain)) else {
            return;
        };
        if !self.closed_tasks.contains(&c.task_slot) {
            let _ = self.closed_tasks.push(c.task_slot);
        }
        if done {
            let start = self
                .steps
                .iter()
                .find(|s| s.chain == chain)
                .map_or(self.now, |s| s.start);
            let _ = self.executed.push(PlacedChain { chain, start });
        } else if let Some(sample) = self.science.get(usize::from(chain)).and_then(|s| s.sample) {
            if let Some(t) = self.context.target_mut(sample) {
                if !t.collected {
                    t.failed = true;
                }
            }
        }
    }

    /// Starts the search from the current state.
    pub(super) fn begin_planning(&mut self, reason: Reason) {
        self.record_step(DecisionKind::ReplanStarted(reason));
        if reason != Reason::Initial {
            self.stats.replans += 1;
        }
        self.restart_planning(reason);
    }

    /// Sets up the search from the current state (new inputs while planning start it again).
    pub(super) fn restart_planning(&mut self, reason: Reason) {
        reparameterize(
            &self.primitives,
            &self.params,
            &self.context,
            &mut self.network,
        );
        assess_chains(
            &self.assessor,
            &self.context,
            &self.science,
            &mut self.network,
        );
        let (primitives, params, context) = (&self.primitives, &self.params, &self.context);
        let prior = |p: u8| {
            let (d, e) = predicted(primitives, params, p)?;
            Some(if already_done(primitives, context, p) {
                (0, 0)
            } else {
                (d, e)
            })
        };
        // The chains' downlink offsets under the same predictions the plan installs with.
        self.timeline.earth.downlinks =
            downlink_spans(primitives, &self.network, |p| prior(p).map(|(d, _)| d));
        self.downlink_sizes.clear();
        if let Some(comms) = &self.comms {
            // Products at their measured volumes, downlinks sized to carry them.
            let before: Vec<u64, MAX_CHAINS> =
                self.network.chains.iter().map(|c| c.duration_us).collect();
            self.downlink_sizes =
                size_downlinks(primitives, &mut self.network, comms, &self.volumes, prior);
            for ((span, chain), was) in self
                .timeline
                .earth
                .downlinks
                .iter_mut()
                .zip(self.network.chains.iter())
                .zip(before.iter())
            {
                if let Some((_, to)) = span {
                    *to = to.saturating_add(chain.duration_us.saturating_sub(*was));
                }
            }
        }
        self.planning_from = (self.now, self.battery_mj);
        // The placement plans from now with the charge now: set here once, not in a copy of
        // the timeline (several KB with the chains' downlink spans) made at every call.
        self.timeline.horizon_start = self.now;
        self.timeline.battery_mj = self.battery_mj;
        // The chains may have changed above: the kept plan index no longer applies.
        self.index_cache.clear();
        let config = SearchConfig {
            battery_mj: self.battery_mj,
            reserve_mj: self.config.reserve_mj,
            exploration_bound: self.config.exploration_bound,
            energy_pruning: true,
        };
        self.search.reconfigure(config);
        match self
            .search
            .start_excluding(&self.network, &[], &self.closed_tasks)
        {
            Ok(()) => self.mode = Mode::Planning { reason },
            Err(_) => self.halt(Reason::ReplanFailed),
        }
    }

    /// A finished primitive's product, measured onboard (the product of its tier created when
    /// it ended): its size against the model's updates the volume factor of its kind; under
    /// Replan a change makes a replan at the next chain boundary. Only with data volume
    /// modelled ([`Executor::set_comms`]).
    pub(super) fn learn_volume(&mut self, spec: &PrimitiveSpec) {
        let (Some(_), Some(prior)) = (self.comms, spec.product) else {
            return;
        };
        let now = self.now;
        let Some(measured) = self
            .onboard
            .iter()
            .find(|p| p.created_at == now && p.tier == prior.tier)
            .map(|p| p.size_bytes)
        else {
            return;
        };
        if self.volumes.learn(spec.kind, prior.size_bytes, measured) {
            self.stats.parameter_updates += 1;
            self.record_step(DecisionKind::ParameterUpdated);
            if self.config.strategy == Strategy::Replan {
                self.replan_pending.get_or_insert(Reason::DataVolume);
            }
        }
    }

    /// Under Replan with data volume modelled: whether data onboard that must go down
    /// (Critical, Decisional, Mandatory) appeared since the last plan started and the rest of
    /// the plan has no downlink left to carry it (e.g. a quake record after the plan's last
    /// downlink), and the model has a backlog downlink not yet used: a replan then adds one for
    /// it.
    pub(super) fn stranded_new_data(&self) -> bool {
        if self.comms.is_none() || self.config.strategy != Strategy::Replan {
            return false;
        }
        let since = self.planning_from.0;
        let new = self
            .onboard
            .iter()
            .any(|p| p.tier != Tier::Residual && p.created_at > since);
        let downlink_left = self.remaining().iter().skip(1).any(|s| {
            self.primitives
                .get(usize::from(s.primitive))
                .is_some_and(|p| is_downlink(p.kind))
        });
        // Only a model with backlog downlinks (no data of their own) still to use can help.
        let drain_left = self.network.chains.iter().any(|c| {
            c.products.is_empty()
                && !self.closed_tasks.contains(&c.task_slot)
                && c.primitives.iter().any(|&p| {
                    self.primitives
                        .get(usize::from(p))
                        .is_some_and(|s| is_downlink(s.kind))
                })
        });
        new && !downlink_left && drain_left
    }

    /// Runs the search within `budget`; true when the plan is installed (or planning failed).
    pub(super) fn continue_planning(&mut self, budget: u32) -> bool {
        let timeline = &self.timeline;
        let step = match &self.comms {
            Some(comms) => {
                let sol = comms.sol_of(self.planning_from.0 .0);
                let view = DataView {
                    comms,
                    onboard: &self.onboard,
                    spans: &self.timeline.earth.downlinks,
                    spent: if self.comm_spent.0 == sol {
                        self.comm_spent
                    } else {
                        (sol, 0)
                    },
                };
                let cached = CachedTimeline {
                    timeline,
                    cache: &mut self.index_cache,
                };
                let mut placement = AssessedPlacement {
                    inner: DataPlacement::new(cached, view),
                    assessor: self.assessor,
                    context: &self.context,
                    science: &self.science,
                    refused: 0,
                };
                // The call's budget covers `budget` explorations and at most `budget`
                // downlink-manager checks (at least one exploration): a backlog downlink's
                // exploration solves up to four problems, so calls of such explorations would
                // otherwise cost several times the calls before them, and the planner
                // partition, which sizes a call by the costliest so far, overran its window
                // (ELAP 2's Discovery replan). The search resumes exactly: the plan is the same
                // however the calls are cut.
                let budget = budget.max(1);
                let mut used = 0u32;
                let step = loop {
                    let s = self.search.step(&self.network, &mut placement, 1);
                    used = used.saturating_add(s.used.max(1));
                    if s.done || used >= budget || placement.inner.stats.checks >= budget {
                        break s;
                    }
                };
                let d = placement.inner.stats;
                let t = &mut self.data_stats;
                t.checks = t.checks.saturating_add(d.checks);
                t.vetoes = t.vetoes.saturating_add(d.vetoes);
                t.capacity_vetoes = t.capacity_vetoes.saturating_add(d.capacity_vetoes);
                t.knapsack_nodes = t.knapsack_nodes.saturating_add(d.knapsack_nodes);
                t.max_knapsack_nodes = t.max_knapsack_nodes.max(d.max_knapsack_nodes);
                t.unproven = t.unproven.saturating_add(d.unproven);
                step
            }
            None => {
                let mut placement = AssessedPlacement {
                    inner: CachedTimeline {
                        timeline,
                        cache: &mut self.index_cache,
                    },
                    assessor: self.assessor,
                    context: &self.context,
                    science: &self.science,
                    refused: 0,
                };
                self.search
                    .step(&self.network, &mut placement, budget.max(1))
            }
        };
        if !step.done {
            return false;
        }
        let s = *self.search.stats();
        self.last_search = s;
        self.last_plan_value = self.search.best_value();
        self.stats.explored = self.stats.explored.saturating_add(s.explored);
        self.stats.nodes = self.stats.nodes.saturating_add(s.nodes);
        let mut plan: Vec<PlacedChain, MAX_PLAN_CHAINS> = Vec::new();
        self.search.best_plan(&mut plan);
        if self.install(&plan).is_err() {
            self.halt(Reason::ReplanFailed);
        }
        true
    }

    /// Replaces the remaining plan by `plan` (chains, in any order), primitives back to back
    /// from each chain's start with the current predictions.
    pub(super) fn install(&mut self, plan: &[PlacedChain]) -> Result<(), ExecError> {
        let mut sorted: Vec<PlacedChain, MAX_PLAN_CHAINS> =
            Vec::from_slice(plan).map_err(|_| ExecError::PlanTooLong)?;
        sorted.sort_unstable_by_key(|p| (p.start, p.chain));
        self.steps.clear();
        self.cursor = 0;
        for p in &sorted {
            let chain = self
                .network
                .chains
                .get(usize::from(p.chain))
                .ok_or(ExecError::UnknownChain)?;
            let mut at = p.start.0;
            let first = self.steps.len();
            let sized = self
                .downlink_sizes
                .get(usize::from(p.chain))
                .copied()
                .flatten();
            for &primitive in chain.primitives.iter() {
                let (mut duration_us, mut energy_mj) =
                    predicted(&self.primitives, &self.params, primitive)
                        .ok_or(ExecError::UnknownChain)?;
                let downlink = self
                    .primitives
                    .get(usize::from(primitive))
                    .is_some_and(|s| is_downlink(s.kind));
                if let (true, Some((d, e))) = (downlink, sized) {
                    (duration_us, energy_mj) = (d, e);
                }
                if already_done(&self.primitives, &self.context, primitive) {
                    continue;
                }
                self.steps
                    .push(ExecStep {
                        chain: p.chain,
                        primitive,
                        planned_start: MissionTimeUs(at),
                        start: MissionTimeUs(at),
                        duration_us,
                        energy_mj,
                        retries: 0,
                        last_in_chain: false,
                    })
                    .map_err(|_| ExecError::PlanTooLong)?;
                at = at.saturating_add(duration_us);
            }
            match self.steps.get_mut(first..).and_then(|s| s.last_mut()) {
                Some(last) => last.last_in_chain = true,
                // Nothing left to do in it: executed as it stands.
                None => {
                    let task = chain.task_slot;
                    if !self.closed_tasks.contains(&task) {
                        let _ = self.closed_tasks.push(task);
                    }
                    let _ = self.executed.push(*p);
                }
            }
        }
        self.mode = Mode::Ready;
        self.plans = self.plans.wrapping_add(1);
        self.record(
            NONE_CHAIN,
            NONE_PRIMITIVE,
            DecisionKind::Planned {
                chains: u8::try_from(sorted.len()).unwrap_or(u8::MAX),
            },
        );
        Ok(())
    }
}

/// The predicted (duration, energy) of primitive `index` under the measured `params`.
pub fn predicted(
    primitives: &[PrimitiveSpec],
    params: &[ParameterUpdate],
    index: u8,
) -> Option<(u64, u64)> {
    let spec = primitives.get(usize::from(index))?;
    let measured = spec.site.and_then(|site| {
        params
            .iter()
            .find(|p| p.kind == spec.kind && p.site == site)
    });
    Some(measured.map_or((spec.duration_us, spec.energy_mj), |p| {
        (p.duration_us, p.energy_mj)
    }))
}

/// Whether primitive `index` has nothing left to do in the state `context` describes: the
/// excavation of a site already excavated (the reference model folds an excavation into every
/// sampling chain; the trench is dug once). Such a primitive costs nothing in a replan and is
/// not dispatched.
pub fn already_done(primitives: &[PrimitiveSpec], context: &ScienceContext, index: u8) -> bool {
    primitives.get(usize::from(index)).is_some_and(|spec| {
        spec.kind == PrimitiveKind::ExcavateSite
            && spec
                .site
                .and_then(|site| context.sites.get(usize::from(site)))
                .is_some_and(|site| site.post_excavation.is_some())
    })
}

/// Recomputes every chain's duration, energy and product offsets from its primitives under the
/// measured `params` (IV.C.3) in the state `context` describes (primitives
/// [`already_done`] cost nothing). Utilities are left as flattened: the Assessor predicts them
/// in context during the search.
pub fn reparameterize(
    primitives: &[PrimitiveSpec],
    params: &[ParameterUpdate],
    context: &ScienceContext,
    network: &mut FlatNetwork,
) {
    for chain in network.chains.iter_mut() {
        let (mut duration, mut energy) = (0u64, 0u64);
        let mut product = 0usize;
        for &p in &chain.primitives {
            let Some((d, e)) = predicted(primitives, params, p) else {
                continue;
            };
            let (d, e) = if already_done(primitives, context, p) {
                (0, 0)
            } else {
                (d, e)
            };
            duration = duration.saturating_add(d);
            energy = energy.saturating_add(e).min(MAX_ENERGY_MJ);
            if primitives
                .get(usize::from(p))
                .is_some_and(|s| s.product.is_some())
            {
                if let Some(cp) = chain.products.get_mut(product) {
                    cp.offset_us = duration;
                }
                product += 1;
            }
        }
        chain.duration_us = duration;
        chain.energy_mj = energy;
    }
}
