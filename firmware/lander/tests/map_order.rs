//! The subway map's order is binding (seed 000 IV.C.2, ELAP scenario 4: the ground changes the
//! excavation order): while a site earlier on the map is open, a sample at a later one scores
//! below any sample taken in order in the Mission rank, and the executor's plan follows the
//! order of the current context's site values, not the one the model was written with.
mod sim;

use lander::assessor::*;
use lander::executor::{ExecConfig, Strategy};
use lander::rsm1::{self, WH_MJ};
use lander::utility::{Rank, Score, SCORE_ONE};
use sim::{samples, small, Exec, Sim, SMALL, SOLS};

fn s(v: u32) -> Score {
    Score::new(v).expect("score in range")
}

fn sample(site: u8, target: u8) -> SampleRef {
    SampleRef { site, target }
}

const FULL: Support = Support {
    excavation: true,
    imaging: true,
};

/// Two sites of three targets; site 0 first on the map.
fn context() -> ScienceContext {
    let mut c = ScienceContext::default();
    for (value, targets) in [
        (8_000, [7_000, 6_000, 5_000]),
        (6_000, [9_000, 8_000, 7_000]),
    ] {
        c.sites
            .push(SiteRecord {
                estimated: s(value),
                pre_excavation: None,
                post_excavation: None,
                targets: targets
                    .iter()
                    .map(|&t| TargetRecord::estimated(s(t)))
                    .collect(),
            })
            .expect("site");
    }
    c
}

fn mission(c: &ScienceContext, planned: &[SampleRef], x: SampleRef) -> u32 {
    Assessor::default()
        .predict_sample(c, planned, x, FULL)
        .expect("allowed")
        .at(Rank::Mission)
}

#[test]
fn a_sample_past_an_open_earlier_site_scores_below_every_sample_in_order() {
    let c = context();
    // Position 8 (site 1, its best target): in order it would score 1 - 9 steps.
    let in_order = u32::from(SCORE_ONE) - 9 * MISSION_STEP;
    let early = mission(&c, &[], sample(1, 0));
    assert!(c.open_site_before(&[], 1));
    assert!(
        early < MISSION_STEP,
        "below the lowest in-order score: {early}"
    );
    assert!(early > 0, "still positive: sampled when site 0 cannot be");
    // Site 0 with two samples planned is still open: the order still binds.
    let two = [sample(0, 0), sample(0, 1)];
    assert!(mission(&c, &two, sample(1, 0)) < MISSION_STEP);
    // Site 0 full (three planned): moving on is in order.
    let three = [sample(0, 0), sample(0, 1), sample(0, 2)];
    assert!(!c.open_site_before(&three, 1));
    assert_eq!(mission(&c, &three, sample(1, 0)), in_order);
    // Site 0 ruled out by a negative biosignature: in order.
    let mut negative = context();
    negative.sites[0].targets[0].collected = true;
    negative.sites[0].targets[0].biosignature = Some(Biosignature::Negative);
    assert_eq!(mission(&negative, &[], sample(1, 0)), in_order);
    // Site 0's targets all failed or collected: nothing left there, in order.
    let mut spent = context();
    for t in spent.sites[0].targets.iter_mut() {
        t.failed = true;
    }
    assert_eq!(mission(&spent, &[], sample(1, 0)), in_order);
    // The first site is never out of order.
    assert!(!c.open_site_before(&[], 0));
}

#[test]
fn the_ground_order_is_the_map_order() {
    // The ground re-values the sites: site 1 first now.
    let mut c = context();
    c.sites[0].estimated = s(3_000);
    c.sites[1].estimated = s(9_000);
    assert!(c.open_site_before(&[], 0));
    assert!(!c.open_site_before(&[], 1));
    assert!(mission(&c, &[], sample(0, 0)) < MISSION_STEP);
}

fn run_with_site_values(values: [u32; 2]) -> Vec<(u8, u8)> {
    let (model, net) = small();
    let timeline = rsm1::placement(SOLS, 40_000 * WH_MJ).expect("placement");
    let mut c = rsm1::context(SMALL);
    for (site, v) in c.sites.iter_mut().zip(values) {
        site.estimated = s(v);
    }
    let mut exec = Box::new(
        Exec::new(
            ExecConfig::new(Strategy::Replan),
            &model,
            &net,
            &timeline,
            &c,
            None,
        )
        .expect("executor"),
    );
    let end = Sim::new(vec![]).run(&mut exec);
    samples(&end)
}

#[test]
fn the_executor_samples_in_the_order_of_the_current_site_values() {
    // The model was written with site 0 first (and site 0's excavation is cheaper).
    let model_order = run_with_site_values([9_000, 7_000]);
    assert_eq!(model_order.len(), 4, "{model_order:?}");
    assert_eq!(
        model_order.iter().map(|s| s.0).collect::<Vec<_>>(),
        [0, 0, 1, 1]
    );
    // The ground re-values them: site 1 first, although its excavation costs more.
    let ground_order = run_with_site_values([3_000, 9_000]);
    assert_eq!(ground_order.len(), 4, "{ground_order:?}");
    assert_eq!(
        ground_order.iter().map(|s| s.0).collect::<Vec<_>>(),
        [1, 1, 0, 0],
        "{ground_order:?}"
    );
}

/// The reference RSM-1 (three sites of three targets) at the configured exploration bound,
/// planned from a context with the given site values: the sites in the order sampled.
fn rsm1_site_order(values: [u32; 3]) -> Vec<u8> {
    let options = rsm1::Rsm1Options::FULL;
    let model = rsm1::model(options).expect("model");
    let net = lander::htn::flatten(
        &model,
        lander::htn::FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flattens");
    let timeline = rsm1::placement(12, 26_000 * WH_MJ).expect("placement");
    let mut c = rsm1::context(options);
    for (site, v) in c.sites.iter_mut().zip(values) {
        site.estimated = s(v);
    }
    let mut exec = Box::new(
        Exec::new(
            ExecConfig::new(Strategy::Replan),
            &model,
            &net,
            &timeline,
            &c,
            None,
        )
        .expect("executor"),
    );
    let end = Sim::new(vec![]).with_model(model).run(&mut exec);
    samples(&end).iter().map(|s| s.0).collect()
}

#[test]
fn at_the_configured_bound_the_search_explores_in_the_current_map_order() {
    // The search's exploration order (h) takes T.utility from the network: the executor
    // re-assesses the sampling chains in the current context before each plan, so the
    // ground's order is explored first although site 0's excavation is the cheapest and the
    // model was written with site 0 first.
    for (values, map) in [
        ([3_000, 5_000, 9_000], [2u8, 1, 0]),
        ([5_000, 9_000, 3_000], [1, 0, 2]),
    ] {
        let order = rsm1_site_order(values);
        let rank = |site: &u8| map.iter().position(|m| m == site);
        let mut in_map_order = order.clone();
        in_map_order.sort_by_key(rank);
        assert!(order.len() >= 4, "{order:?}");
        assert_eq!(order[..3], [map[0]; 3], "the first site filled first");
        assert_eq!(order, in_map_order, "{values:?}");
    }
}
