//! The Assessor (seed 000 IV.C.2): predicts the utility of a hypothetical sampling task from its
//! context, and enforces the science subway map of RSM-1 through the Mission rank.
//!
//! The context ([`ScienceContext`]) is what the lander knows: per site its estimated value
//! (onboard vision), its pre- and post-excavation imagery scores once taken; per target its
//! estimated value, its pre-collection imaging score once taken, whether it was collected, and
//! its biosignature result once analysed. The planned context is the sampling tasks the plan
//! already holds before the new one ([`SampleRef`]s) and whether the excavation and the
//! imaging that support it are planned, by its own chain or an earlier one ([`Support`]).
//!
//! A prediction for sample (site N, target M) is, rank by rank:
//! - Mission: the subway map. Sites are ordered by estimated value (ties: lower index), targets
//!   within a site likewise; position `p = site_rank * MAX_TARGETS_PER_SITE + target_rank`
//!   scores `SCORE_ONE - (p + 1) * MISSION_STEP`, so a plan that stays at a site beats one that
//!   moves on early, and better sites and targets come first. The order is binding: while a
//!   site earlier on the map is open ([`ScienceContext::open_site_before`]: not negative, not
//!   full, a target left), a sample at a later site scores its in-order score divided by
//!   [`MAP_POSITIONS`], below any sample taken in order, so a cheaper excavation at a later site
//!   cannot win the search's ordering (h) or the plan's value over the map's order (the
//!   ground's, after it re-values the sites); when the earlier sites cannot be afforded the
//!   later ones are still sampled. A sample the map forbids
//!   ([`MapRule`]) gets no prediction at all: the planner refuses it ([`AssessedPlacement`]),
//!   so zero Mission score is never scheduled.
//! - Analysis: the target's estimated value; raised halfway to 1.0 when the site already has a
//!   positive biosignature (the evidence that the site is promising).
//! - Post-collection: the configured prior.
//! - Pre-collection: the target's imaging score if it exists, else the prior if the chain plans
//!   the imaging, else zero.
//! - Post-excavation: the site's measured score if it is excavated, else the prior if the chain
//!   plans the excavation (a site neither excavated nor planned for excavation cannot be
//!   sampled: [`MapRule::NotExcavated`]).
//! - Pre-excavation: the site's imagery score if it exists, else its estimated value.
//! - Default: the configured score.
//!
//! The map's rules (each a [`MapRule`]): at most [`MAX_SAMPLES_PER_SITE`] samples per site
//! (collected and planned together); no sample at a site with a negative biosignature (move on
//! to the next site); no target sampled twice; no sample at a target that failed for good.
use heapless::Vec;

use crate::capacity::{MAX_CHAINS, MAX_PLAN_CHAINS};
use crate::htn::{FlatNetwork, PrimitiveKind, PrimitiveSpec};
use crate::search::{ChainPlacement, PlacedChain};
use crate::utility::{Rank, RankedUtility, Score, RANK_COUNT, SCORE_ONE};

/// Sites the context describes.
pub const MAX_SITES: usize = 8;
/// Targets per site the context describes.
pub const MAX_TARGETS_PER_SITE: usize = 8;
/// The subway map's limit: at most three samples per site.
pub const MAX_SAMPLES_PER_SITE: usize = 3;
/// Mission score between two adjacent positions of the map (the last position keeps a positive
/// score).
pub const MISSION_STEP: u32 = SCORE_ONE as u32 / MAP_POSITIONS;
/// Positions on the map, plus one (so the last position keeps a positive score). An
/// out-of-order sample's Mission score is its in-order score divided by this: below
/// [`MISSION_STEP`], the lowest score of any sample taken in order.
pub const MAP_POSITIONS: u32 = (MAX_SITES * MAX_TARGETS_PER_SITE + 1) as u32;

/// An onboard biosignature analysis result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Biosignature {
    Positive,
    Negative,
}

/// What is known about one sampling target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TargetRecord {
    /// Estimated science value from onboard vision.
    pub estimated: Score,
    /// Pre-collection imaging score, once the imaging exists.
    pub imaging: Option<Score>,
    pub collected: bool,
    pub biosignature: Option<Biosignature>,
    /// Failed for good (for example lost in a replan after a failure): not sampled again.
    pub failed: bool,
}

impl TargetRecord {
    pub const fn estimated(estimated: Score) -> Self {
        Self {
            estimated,
            imaging: None,
            collected: false,
            biosignature: None,
            failed: false,
        }
    }
}

/// What is known about one site.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SiteRecord {
    /// Estimated science value from onboard vision.
    pub estimated: Score,
    /// Pre-excavation imagery score, once taken.
    pub pre_excavation: Option<Score>,
    /// Post-excavation imagery score: `Some` once the site is excavated.
    pub post_excavation: Option<Score>,
    pub targets: Vec<TargetRecord, MAX_TARGETS_PER_SITE>,
}

/// The lander's science knowledge: the existing data products the Assessor predicts from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ScienceContext {
    pub sites: Vec<SiteRecord, MAX_SITES>,
}

/// A sampling task: site and target indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleRef {
    pub site: u8,
    pub target: u8,
}

/// What the new task's own chain plans in support of the sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Support {
    pub excavation: bool,
    pub imaging: bool,
}

/// A subway-map rule that forbids a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapRule {
    /// The site or target is not in the context.
    UnknownTarget,
    /// The target is already collected or planned.
    AlreadySampled,
    /// The site already has [`MAX_SAMPLES_PER_SITE`] samples collected or planned.
    SiteFull,
    /// The site has a negative biosignature: move on to the next site.
    NegativeAtSite,
    /// The target failed for good.
    TargetFailed,
    /// The site is neither excavated nor planned for excavation.
    NotExcavated,
}

/// The Assessor's priors: what it predicts for data that does not exist yet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Assessor {
    pub post_collection_prior: Score,
    pub pre_collection_prior: Score,
    pub post_excavation_prior: Score,
    pub default_score: Score,
}

impl Default for Assessor {
    fn default() -> Self {
        let s = |v| Score::new(v).unwrap_or(Score::ZERO);
        Self {
            post_collection_prior: s(3_000),
            pre_collection_prior: s(3_000),
            post_excavation_prior: s(4_000),
            default_score: s(1_000),
        }
    }
}

/// The rank of `index` among `values` by decreasing value, ties to the lower index.
fn rank_by_value(values: impl Iterator<Item = Score> + Clone, index: usize) -> Option<usize> {
    let mine = values.clone().nth(index)?;
    Some(
        values
            .enumerate()
            .filter(|&(i, v)| v > mine || (v == mine && i < index))
            .count(),
    )
}

impl ScienceContext {
    pub fn target(&self, sample: SampleRef) -> Option<&TargetRecord> {
        self.sites
            .get(usize::from(sample.site))?
            .targets
            .get(usize::from(sample.target))
    }

    pub fn target_mut(&mut self, sample: SampleRef) -> Option<&mut TargetRecord> {
        self.sites
            .get_mut(usize::from(sample.site))?
            .targets
            .get_mut(usize::from(sample.target))
    }

    /// The sample's position on the subway map: sites by estimated value, then targets.
    pub fn map_position(&self, sample: SampleRef) -> Option<usize> {
        let site = self.sites.get(usize::from(sample.site))?;
        let site_rank = rank_by_value(
            self.sites.iter().map(|s| s.estimated),
            usize::from(sample.site),
        )?;
        let target_rank = rank_by_value(
            site.targets.iter().map(|t| t.estimated),
            usize::from(sample.target),
        )?;
        Some(site_rank * MAX_TARGETS_PER_SITE + target_rank)
    }

    /// Whether a site earlier on the map than `site` (higher estimated value, ties to the
    /// lower index) is still open given the samples `planned`: no negative biosignature there,
    /// fewer than [`MAX_SAMPLES_PER_SITE`] samples collected and planned, and a target neither
    /// collected, failed nor planned. While one is, the map says to sample there first.
    pub fn open_site_before(&self, planned: &[SampleRef], site: u8) -> bool {
        let Some(mine) = rank_by_value(self.sites.iter().map(|s| s.estimated), usize::from(site))
        else {
            return false;
        };
        self.sites.iter().enumerate().any(|(i, s)| {
            let earlier =
                rank_by_value(self.sites.iter().map(|s| s.estimated), i).is_some_and(|r| r < mine);
            let negative = s
                .targets
                .iter()
                .any(|t| t.biosignature == Some(Biosignature::Negative));
            let here = |p: &&SampleRef| usize::from(p.site) == i;
            let taken = s.targets.iter().filter(|t| t.collected).count()
                + planned.iter().filter(here).count();
            let available = s.targets.iter().enumerate().any(|(t, r)| {
                !r.collected
                    && !r.failed
                    && !planned
                        .iter()
                        .filter(here)
                        .any(|p| usize::from(p.target) == t)
            });
            earlier && !negative && taken < MAX_SAMPLES_PER_SITE && available
        })
    }
}

fn clamp_score(v: u32) -> Score {
    Score::new(v.min(u32::from(SCORE_ONE))).unwrap_or(Score::ONE)
}

impl Assessor {
    /// Checks the subway map for `sample` given the context and the samples planned before it.
    pub fn check_map(
        &self,
        context: &ScienceContext,
        planned: &[SampleRef],
        sample: SampleRef,
        support: Support,
    ) -> Result<(), MapRule> {
        let site = context
            .sites
            .get(usize::from(sample.site))
            .ok_or(MapRule::UnknownTarget)?;
        let target = context.target(sample).ok_or(MapRule::UnknownTarget)?;
        if target.collected || planned.contains(&sample) {
            return Err(MapRule::AlreadySampled);
        }
        if target.failed {
            return Err(MapRule::TargetFailed);
        }
        if site
            .targets
            .iter()
            .any(|t| t.biosignature == Some(Biosignature::Negative))
        {
            return Err(MapRule::NegativeAtSite);
        }
        let at_site = site.targets.iter().filter(|t| t.collected).count()
            + planned.iter().filter(|p| p.site == sample.site).count();
        if at_site >= MAX_SAMPLES_PER_SITE {
            return Err(MapRule::SiteFull);
        }
        if site.post_excavation.is_none() && !support.excavation {
            return Err(MapRule::NotExcavated);
        }
        Ok(())
    }

    /// The predicted utility of sampling `sample` (its whole science: excavation imagery,
    /// imaging, collection, analysis and the map's Mission score), or the map rule that forbids
    /// it.
    pub fn predict_sample(
        &self,
        context: &ScienceContext,
        planned: &[SampleRef],
        sample: SampleRef,
        support: Support,
    ) -> Result<RankedUtility, MapRule> {
        self.check_map(context, planned, sample, support)?;
        let site = context
            .sites
            .get(usize::from(sample.site))
            .ok_or(MapRule::UnknownTarget)?;
        let target = context.target(sample).ok_or(MapRule::UnknownTarget)?;
        let position = context.map_position(sample).ok_or(MapRule::UnknownTarget)?;
        let in_order = (u32::from(SCORE_ONE))
            .saturating_sub((position as u32 + 1).saturating_mul(MISSION_STEP))
            .max(1);
        // The map's order is binding: while a site earlier on the map is still open, a sample
        // here scores below every sample taken in order.
        let mission = if context.open_site_before(planned, sample.site) {
            (in_order / MAP_POSITIONS).max(1)
        } else {
            in_order
        };
        let positive_here = site
            .targets
            .iter()
            .any(|t| t.biosignature == Some(Biosignature::Positive));
        let estimated = u32::from(target.estimated.ten_thousandths());
        let analysis = if positive_here {
            estimated + (u32::from(SCORE_ONE) - estimated) / 2
        } else {
            estimated
        };
        let pre_collection = match (target.imaging, support.imaging) {
            (Some(s), _) => s,
            (None, true) => self.pre_collection_prior,
            (None, false) => Score::ZERO,
        };
        let post_excavation = site.post_excavation.unwrap_or(self.post_excavation_prior);
        let pre_excavation = site.pre_excavation.unwrap_or(site.estimated);
        let mut scores = [Score::ZERO; RANK_COUNT];
        for (rank, score) in [
            (Rank::Mission, clamp_score(mission)),
            (Rank::Analysis, clamp_score(analysis)),
            (Rank::PostCollection, self.post_collection_prior),
            (Rank::PreCollection, pre_collection),
            (Rank::PostExcavation, post_excavation),
            (Rank::PreExcavation, pre_excavation),
            (Rank::Default, self.default_score),
        ] {
            if let Some(s) = scores.get_mut(rank as usize) {
                *s = score;
            }
        }
        Ok(RankedUtility::from_scores(scores))
    }
}

/// What a chain does for science, from its primitives: the sample it collects (if any) and the
/// support it plans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChainScience {
    pub sample: Option<SampleRef>,
    /// The support the chain plans for its own sample.
    pub support: Support,
    /// The site the chain excavates, if any (support for later samples there).
    pub excavates: Option<u8>,
    /// The site whose targets the chain images, if any (support for later samples there).
    pub images: Option<u8>,
    /// Utility of the chain's primitives the Assessor does not predict (downlinks, panoramas):
    /// added to the prediction.
    pub other_utility: RankedUtility,
}

/// Whether the Assessor's prediction replaces this primitive's model utility in a sampling chain.
fn predicted_kind(kind: PrimitiveKind) -> bool {
    matches!(
        kind,
        PrimitiveKind::ExcavateSite
            | PrimitiveKind::FindCollectionTargets
            | PrimitiveKind::CollectSample
            | PrimitiveKind::ScienceAnalyze
    )
}

/// Per chain of `network`, its [`ChainScience`] (`primitives` is the model's primitive table).
pub fn chain_science(
    primitives: &[PrimitiveSpec],
    network: &FlatNetwork,
) -> Vec<ChainScience, MAX_CHAINS> {
    let mut out = Vec::new();
    for chain in &network.chains {
        let mut science = ChainScience::default();
        for spec in chain
            .primitives
            .iter()
            .filter_map(|&p| primitives.get(usize::from(p)))
        {
            match (spec.kind, spec.site, spec.target) {
                (PrimitiveKind::CollectSample, Some(site), Some(target)) => {
                    science.sample = Some(SampleRef { site, target });
                }
                (PrimitiveKind::ExcavateSite, site, _) => {
                    science.support.excavation = true;
                    science.excavates = site;
                }
                (PrimitiveKind::FindCollectionTargets, site, _) => {
                    science.support.imaging = true;
                    science.images = site;
                }
                _ => {}
            }
        }
        for spec in chain
            .primitives
            .iter()
            .filter_map(|&p| primitives.get(usize::from(p)))
        {
            if science.sample.is_none() || !predicted_kind(spec.kind) {
                science.other_utility = science.other_utility.saturating_add(&spec.utility);
            }
        }
        let _ = out.push(science);
    }
    out
}

/// Sets each sampling chain's utility in `network` to the Assessor's prediction for it in
/// `context` with nothing planned before it (plus its other primitives' model utility; a chain
/// the map forbids keeps only that), so the search's exploration order (h(P,T) =
/// P.utility + T.utility/T.cost, T from the network) follows the map of the current context
/// (the ground's site values after a model uplink, discoveries after a replan) rather than the
/// values the model was written with. Other chains are left as they are. The plan's value is
/// still the in-context prediction of [`AssessedPlacement`].
pub fn assess_chains(
    assessor: &Assessor,
    context: &ScienceContext,
    science: &[ChainScience],
    network: &mut FlatNetwork,
) {
    for (chain, science) in network.chains.iter_mut().zip(science) {
        let Some(sample) = science.sample else {
            continue;
        };
        chain.utility = match assessor.predict_sample(context, &[], sample, science.support) {
            Ok(u) => u.saturating_add(&science.other_utility),
            Err(_) => science.other_utility,
        };
    }
}

/// A placement that asks the Assessor: sampling chains the subway map forbids in the plan's
/// context are refused, and every sampling chain adds its predicted utility (plus its other
/// primitives' model utility) instead of its flattened one. Other chains pass through.
///
/// The planned context of a sample is the plan's chains before it: the samples they take (for
/// the map's counts) and the excavation and imaging they plan at its site (support, as if its
/// own chain planned them).
pub struct AssessedPlacement<'a, P> {
    pub inner: P,
    pub assessor: Assessor,
    pub context: &'a ScienceContext,
    /// [`chain_science`] of the network being searched.
    pub science: &'a [ChainScience],
    /// Chains refused by the map.
    pub refused: u32,
}

impl<P> AssessedPlacement<'_, P> {
    fn planned(&self, plan: &[PlacedChain]) -> Vec<SampleRef, MAX_PLAN_CHAINS> {
        plan.iter()
            .filter_map(|p| self.science.get(usize::from(p.chain))?.sample)
            .collect()
    }

    fn assess(
        &self,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<Result<RankedUtility, MapRule>> {
        let science = self.science.get(usize::from(candidate))?;
        let sample = science.sample?;
        let planned = self.planned(plan);
        let mut support = science.support;
        for earlier in plan
            .iter()
            .filter_map(|p| self.science.get(usize::from(p.chain)))
        {
            support.excavation |= earlier.excavates == Some(sample.site);
            support.imaging |= earlier.images == Some(sample.site);
        }
        Some(
            self.assessor
                .predict_sample(self.context, &planned, sample, support)
                .map(|u| u.saturating_add(&science.other_utility)),
        )
    }
}

impl<P: ChainPlacement> ChainPlacement for AssessedPlacement<'_, P> {
    fn place(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<fsw_bridge::MissionTimeUs> {
        if let Some(Err(_)) = self.assess(plan, candidate) {
            self.refused += 1;
            return None;
        }
        self.inner.place(network, plan, candidate)
    }

    fn utility(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> RankedUtility {
        match self.assess(plan, candidate) {
            Some(Ok(u)) => u,
            Some(Err(_)) => RankedUtility::ZERO,
            None => self.inner.utility(network, plan, candidate),
        }
    }

    /// The Assessor asked once for both answers.
    fn place_valued(
        &mut self,
        network: &FlatNetwork,
        plan: &[PlacedChain],
        candidate: u16,
    ) -> Option<(fsw_bridge::MissionTimeUs, RankedUtility)> {
        match self.assess(plan, candidate) {
            Some(Err(_)) => {
                self.refused += 1;
                None
            }
            Some(Ok(utility)) => Some((self.inner.place(network, plan, candidate)?, utility)),
            None => self.inner.place_valued(network, plan, candidate),
        }
    }
}
