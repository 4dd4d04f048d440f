//! The Assessor (seed 000 IV.C.2): its predictions on constructed contexts, each rule of the
//! science subway map, and the map enforced in the search through the Mission rank.
use heapless::Vec as HVec;
use lander::assessor::*;
use lander::htn::{flatten, FlattenOptions};
use lander::rsm1::{self, Rsm1Options, WH_MJ};
use lander::search::{PlacedChain, Search, SearchConfig};
use lander::utility::{Rank, RankedUtility, Score, SCORE_ONE};

fn s(v: u32) -> Score {
    Score::new(v).expect("score in range")
}

fn site(estimated: u32, targets: &[u32]) -> SiteRecord {
    SiteRecord {
        estimated: s(estimated),
        pre_excavation: None,
        post_excavation: None,
        targets: targets
            .iter()
            .map(|&t| TargetRecord::estimated(s(t)))
            .collect(),
    }
}

/// Two sites: site 0 worth more; its target 1 worth more than its target 0.
fn context() -> ScienceContext {
    let mut c = ScienceContext::default();
    c.sites
        .push(site(8_000, &[5_000, 7_000, 6_000, 4_000]))
        .unwrap();
    c.sites.push(site(6_000, &[9_000, 3_000])).unwrap();
    c
}

const FULL: Support = Support {
    excavation: true,
    imaging: true,
};

fn sample(site: u8, target: u8) -> SampleRef {
    SampleRef { site, target }
}

fn predict(c: &ScienceContext, planned: &[SampleRef], x: SampleRef) -> RankedUtility {
    Assessor::default()
        .predict_sample(c, planned, x, FULL)
        .expect("allowed")
}

#[test]
fn a_fresh_sample_is_predicted_from_the_estimates_and_the_priors() {
    let a = Assessor::default();
    let u = predict(&context(), &[], sample(0, 1));
    // Site 0 is first on the map, its target 1 first within it: position 0.
    assert_eq!(u.at(Rank::Mission), u32::from(SCORE_ONE) - MISSION_STEP);
    assert_eq!(u.at(Rank::Analysis), 7_000, "the target's estimated value");
    assert_eq!(
        u.at(Rank::PostCollection),
        u32::from(a.post_collection_prior.ten_thousandths())
    );
    assert_eq!(
        u.at(Rank::PreCollection),
        u32::from(a.pre_collection_prior.ten_thousandths()),
        "imaging planned by the chain: the prior"
    );
    assert_eq!(
        u.at(Rank::PostExcavation),
        u32::from(a.post_excavation_prior.ten_thousandths())
    );
    assert_eq!(u.at(Rank::PreExcavation), 8_000, "the site's estimate");
    assert_eq!(
        u.at(Rank::Default),
        u32::from(a.default_score.ten_thousandths())
    );
}

#[test]
fn existing_data_products_replace_the_priors() {
    let mut c = context();
    c.sites[0].pre_excavation = Some(s(2_500));
    c.sites[0].post_excavation = Some(s(9_500));
    c.sites[0].targets[1].imaging = Some(s(8_800));
    let u = predict(&c, &[], sample(0, 1));
    assert_eq!(u.at(Rank::PreExcavation), 2_500);
    assert_eq!(u.at(Rank::PostExcavation), 9_500);
    assert_eq!(u.at(Rank::PreCollection), 8_800);
    // An excavated site needs no planned excavation.
    let without = Assessor::default().predict_sample(
        &c,
        &[],
        sample(0, 1),
        Support {
            excavation: false,
            imaging: false,
        },
    );
    let without = without.expect("excavated already");
    assert_eq!(without.at(Rank::PostExcavation), 9_500);
    assert_eq!(without.at(Rank::PreCollection), 8_800, "imaging exists");
    // Without existing or planned imaging, nothing is predicted for it.
    let fresh = Assessor::default()
        .predict_sample(
            &c,
            &[],
            sample(0, 2),
            Support {
                excavation: false,
                imaging: false,
            },
        )
        .expect("allowed");
    assert_eq!(fresh.at(Rank::PreCollection), 0);
}

#[test]
fn a_positive_biosignature_at_the_site_raises_the_predicted_analysis() {
    let mut c = context();
    let before = predict(&c, &[], sample(0, 2)).at(Rank::Analysis);
    c.sites[0].targets[1].collected = true;
    c.sites[0].targets[1].biosignature = Some(Biosignature::Positive);
    let after = predict(&c, &[], sample(0, 2)).at(Rank::Analysis);
    assert_eq!(before, 6_000);
    assert_eq!(after, 6_000 + (10_000 - 6_000) / 2);
}

#[test]
fn the_map_orders_sites_then_targets_by_estimated_value() {
    let c = context();
    let mission = |x| predict(&c, &[], x).at(Rank::Mission);
    // Site 0 (0.8) before site 1 (0.6), whatever the targets' values; within site 0 the
    // targets go 1 (0.7), 2 (0.6), 0 (0.5), 3 (0.4).
    let order = [
        sample(0, 1),
        sample(0, 2),
        sample(0, 0),
        sample(0, 3),
        sample(1, 0),
        sample(1, 1),
    ];
    for pair in order.windows(2) {
        assert!(mission(pair[0]) > mission(pair[1]), "{pair:?}");
    }
    assert!(mission(sample(0, 3)) > mission(sample(1, 0)));
    assert!(mission(sample(1, 1)) > 0);
    // The Mission rank dominates: the best target of the worse site scores more at Analysis,
    // yet less overall.
    assert!(
        predict(&c, &[], sample(1, 0)).at(Rank::Analysis)
            > predict(&c, &[], sample(0, 0)).at(Rank::Analysis)
    );
    assert!(predict(&c, &[], sample(1, 0)) < predict(&c, &[], sample(0, 0)));
}

#[test]
fn staying_at_a_site_beats_moving_on_early() {
    let c = context();
    let first = sample(0, 1);
    let stay = predict(&c, &[first], sample(0, 2));
    let move_on = predict(&c, &[first], sample(1, 0));
    assert!(stay > move_on);
}

fn rule(c: &ScienceContext, planned: &[SampleRef], x: SampleRef, support: Support) -> MapRule {
    Assessor::default()
        .predict_sample(c, planned, x, support)
        .expect_err("forbidden")
}

#[test]
fn at_most_three_samples_per_site_collected_and_planned_together() {
    let mut c = context();
    // Three planned.
    let planned = [sample(0, 0), sample(0, 1), sample(0, 2)];
    assert_eq!(rule(&c, &planned, sample(0, 3), FULL), MapRule::SiteFull);
    // Two collected and one planned.
    c.sites[0].targets[0].collected = true;
    c.sites[0].targets[1].collected = true;
    assert_eq!(
        rule(&c, &[sample(0, 2)], sample(0, 3), FULL),
        MapRule::SiteFull
    );
    // Two collected, none planned: the third is allowed; the other site is unaffected.
    assert!(Assessor::default()
        .predict_sample(&c, &[], sample(0, 3), FULL)
        .is_ok());
    assert!(Assessor::default()
        .predict_sample(&c, &planned, sample(1, 0), FULL)
        .is_ok());
}

#[test]
fn a_negative_biosignature_moves_the_map_to_the_next_site() {
    let mut c = context();
    c.sites[0].targets[1].collected = true;
    c.sites[0].targets[1].biosignature = Some(Biosignature::Negative);
    assert_eq!(rule(&c, &[], sample(0, 2), FULL), MapRule::NegativeAtSite);
    assert_eq!(rule(&c, &[], sample(0, 0), FULL), MapRule::NegativeAtSite);
    assert!(Assessor::default()
        .predict_sample(&c, &[], sample(1, 0), FULL)
        .is_ok());
    // A positive one keeps it there.
    c.sites[0].targets[1].biosignature = Some(Biosignature::Positive);
    assert!(Assessor::default()
        .predict_sample(&c, &[], sample(0, 2), FULL)
        .is_ok());
}

#[test]
fn a_target_is_sampled_once_and_a_failed_one_not_again() {
    let mut c = context();
    assert_eq!(
        rule(&c, &[sample(0, 2)], sample(0, 2), FULL),
        MapRule::AlreadySampled
    );
    c.sites[0].targets[2].collected = true;
    assert_eq!(rule(&c, &[], sample(0, 2), FULL), MapRule::AlreadySampled);
    c.sites[1].targets[0].failed = true;
    assert_eq!(rule(&c, &[], sample(1, 0), FULL), MapRule::TargetFailed);
}

#[test]
fn a_site_must_be_excavated_or_planned_for_excavation_and_known() {
    let c = context();
    let imaging_only = Support {
        excavation: false,
        imaging: true,
    };
    assert_eq!(
        rule(&c, &[], sample(0, 1), imaging_only),
        MapRule::NotExcavated
    );
    assert_eq!(rule(&c, &[], sample(2, 0), FULL), MapRule::UnknownTarget);
    assert_eq!(rule(&c, &[], sample(1, 5), FULL), MapRule::UnknownTarget);
}

/// Samples per site in the best plan of a search of RSM-1 with four targets per site, with or
/// without the Assessor.
fn samples_per_site(context: Option<&ScienceContext>) -> [usize; 3] {
    let options = Rsm1Options {
        sites: 3,
        targets_per_site: 4,
        panoramas: 0,
        uplinks: 2,
    };
    let model = rsm1::model(options).unwrap();
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .unwrap();
    let battery = 60_000 * WH_MJ;
    let mut search: Box<Search<4_096, 16_384>> = Box::new(Search::new(SearchConfig {
        exploration_bound: Some(2_000),
        ..SearchConfig::exhaustive(battery)
    }));
    search.start(&net, &[]).unwrap();
    let timeline = rsm1::placement(12, battery).unwrap();
    let science = chain_science(&model.primitives, &net);
    match context {
        Some(context) => {
            let mut placement = AssessedPlacement {
                inner: timeline,
                assessor: Assessor::default(),
                context,
                science: &science,
                refused: 0,
            };
            search.run(&net, &mut placement);
            assert!(placement.refused > 0, "the map refused chains");
        }
        None => search.run(&net, &mut timeline.clone()),
    }
    let mut plan: HVec<PlacedChain, 64> = HVec::new();
    search.best_plan(&mut plan);
    let mut per_site = [0usize; 3];
    for p in &plan {
        if let Some(x) = science[usize::from(p.chain)].sample {
            per_site[usize::from(x.site)] += 1;
        }
    }
    per_site
}

#[test]
fn the_search_with_the_assessor_keeps_to_three_samples_per_site() {
    let options = Rsm1Options {
        sites: 3,
        targets_per_site: 4,
        panoramas: 0,
        uplinks: 2,
    };
    let without = samples_per_site(None);
    assert!(
        without.iter().any(|&n| n > MAX_SAMPLES_PER_SITE),
        "without the map the battery pays for more: {without:?}"
    );
    let with = samples_per_site(Some(&rsm1::context(options)));
    assert_eq!(with, [3, 3, 3]);
}

#[test]
fn the_search_with_the_assessor_leaves_a_negative_site() {
    let options = Rsm1Options {
        sites: 3,
        targets_per_site: 4,
        panoramas: 0,
        uplinks: 2,
    };
    let mut c = rsm1::context(options);
    c.sites[0].targets[0].collected = true;
    c.sites[0].targets[0].biosignature = Some(Biosignature::Negative);
    let with = samples_per_site(Some(&c));
    assert_eq!(with, [0, 3, 3]);
}

/// The site of the one sample the search chooses when the battery pays for only one.
fn one_sample_site(context: Option<&ScienceContext>) -> Vec<u8> {
    let options = Rsm1Options {
        sites: 3,
        targets_per_site: 1,
        panoramas: 0,
        uplinks: 2,
    };
    let model = rsm1::model(options).unwrap();
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .unwrap();
    let battery = 3_500 * WH_MJ;
    let mut search: Box<Search<4_096, 16_384>> =
        Box::new(Search::new(SearchConfig::exhaustive(battery)));
    search.start(&net, &[]).unwrap();
    let timeline = rsm1::placement(4, battery).unwrap();
    let science = chain_science(&model.primitives, &net);
    match context {
        Some(context) => search.run(
            &net,
            &mut AssessedPlacement {
                inner: timeline,
                assessor: Assessor::default(),
                context,
                science: &science,
                refused: 0,
            },
        ),
        None => search.run(&net, &mut timeline.clone()),
    }
    assert!(search.stats().exhaustive());
    let mut plan: HVec<PlacedChain, 64> = HVec::new();
    search.best_plan(&mut plan);
    plan.iter()
        .filter_map(|p| science[usize::from(p.chain)].sample.map(|x| x.site))
        .collect()
}

#[test]
fn the_search_ranks_plans_by_the_assessed_utility() {
    // The model's flattened utilities favour site 0; the context (vision after landing) says
    // site 2 is worth most: with the Assessor the search samples there.
    assert_eq!(one_sample_site(None), vec![0]);
    let options = Rsm1Options {
        sites: 3,
        targets_per_site: 1,
        panoramas: 0,
        uplinks: 2,
    };
    let mut c = rsm1::context(options);
    c.sites[2].estimated = s(9_900);
    assert_eq!(one_sample_site(Some(&c)), vec![2]);
}

#[test]
fn planned_tasks_that_support_a_sample_are_its_context() {
    use lander::htn::{Chain, FlatNetwork, PrimitiveKind, PrimitiveSpec};
    use lander::search::ChainPlacement;
    let spec = |kind, site, target| PrimitiveSpec {
        kind,
        site,
        target,
        duration_us: 3_600_000_000,
        energy_mj: WH_MJ,
        utility: RankedUtility::ZERO,
        product: None,
    };
    // Excavation, imaging and collection as separate tasks (the reference model folds them
    // into each sampling chain).
    let primitives = [
        spec(PrimitiveKind::ExcavateSite, Some(0), None),
        spec(PrimitiveKind::FindCollectionTargets, Some(0), None),
        spec(PrimitiveKind::CollectSample, Some(0), Some(1)),
        spec(PrimitiveKind::ExcavateSite, Some(1), None),
    ];
    let mut net = FlatNetwork::default();
    for (slot, p) in [0u8, 1, 2, 3].into_iter().enumerate() {
        let mut c = Chain::bare(slot as u16, slot as u8, RankedUtility::ZERO, WH_MJ);
        c.primitives.push(p).unwrap();
        c.duration_us = 3_600_000_000;
        net.chains.push(c).unwrap();
    }
    let science = chain_science(&primitives, &net);
    let c = context();
    let mut placement = AssessedPlacement {
        inner: rsm1::placement(4, 10_000 * WH_MJ).unwrap(),
        assessor: Assessor::default(),
        context: &c,
        science: &science,
        refused: 0,
    };
    // Chains at the start of surface operations, `hour` hours in.
    let at = |chain: u16, hour: u64| PlacedChain {
        chain,
        start: fsw_bridge::MissionTimeUs(rsm1::SOL_US + hour * rsm1::HOUR_US),
    };
    // Alone, the collection has no excavation: the map refuses it.
    assert_eq!(placement.place(&net, &[], 2), None);
    // Another site's excavation does not help.
    assert_eq!(placement.place(&net, &[at(3, 0)], 2), None);
    // After a planned excavation of its site it is allowed, with the predicted post-excavation
    // score, and no pre-collection score (no imaging planned).
    let excavated = [at(0, 0)];
    assert!(placement.place(&net, &excavated, 2).is_some());
    let u = placement.utility(&net, &excavated, 2);
    let a = Assessor::default();
    assert_eq!(
        u.at(Rank::PostExcavation),
        u32::from(a.post_excavation_prior.ten_thousandths())
    );
    assert_eq!(u.at(Rank::PreCollection), 0);
    // With the imaging planned too, its prior is predicted.
    let imaged = [at(0, 0), at(1, 1)];
    let u = placement.utility(&net, &imaged, 2);
    assert_eq!(
        u.at(Rank::PreCollection),
        u32::from(a.pre_collection_prior.ten_thousandths())
    );
    assert_eq!(placement.refused, 2);
}
