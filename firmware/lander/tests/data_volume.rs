//! Data volume and downlink capacity in the planning (issue 11 items 5 and 8, seed 000
//! Appendix A): the downlink manager in the placement ([`lander::comms::DataPlacement`]), the
//! executor's comms and onboard-data inputs, downlinks sized to their data, product volumes
//! measured, and a rate drop from the ground reaching the plan.
use fsw_bridge::MissionTimeUs;
use lander::comms::{
    next_downlink, push_segments, CommsError, CommsModel, DataPlacement, DataView, VolumeFactors,
};
use lander::downlink::DataProduct;
use lander::executor::{
    DecisionKind, Directive, Event, ExecConfig, Executor, Observation, Outcome, Reason, Strategy,
    TaskResult,
};
use lander::htn::{flatten, Chain, ChainProduct, FlatNetwork, FlattenOptions, PrimitiveKind};
use lander::htn::{PhaseTimeline, ProductSpec, Tier};
use lander::placement::{DownlinkSpans, EarthView, TimelinePlacement, ViewTimeline, ViewWindow};
use lander::rsm1::{self, Rsm1Options, HOUR_US, SEC_US, WH_MJ};
use lander::search::{ChainPlacement, PlacedChain};
use lander::utility::{Rank, RankedUtility, Score};

const MB: u64 = 1_000_000;

fn h(x: u64) -> MissionTimeUs {
    MissionTimeUs(x * HOUR_US)
}

/// The RSM-1 link: 50 kbps, 20 min of set-up, 3 h thermal limit, a 60 W radio, 200 Wh per
/// downlink, 400 Wh per sol.
fn comms(rate_bps: u64) -> CommsModel {
    CommsModel {
        rate_bps,
        overhead_us: 1_200 * SEC_US,
        thermal_limit_us: 3 * HOUR_US,
        radio_power_mw: 60_000,
        per_downlink_mj: 200 * WH_MJ,
        per_sol_mj: 400 * WH_MJ,
        sol_us: rsm1::SOL_US,
    }
}

fn product(mb: u64, tier: Tier, at_h: u64) -> DataProduct {
    DataProduct {
        size_bytes: mb * MB,
        value: 10,
        created_at: h(at_h),
        tier,
    }
}

/// A chain of `hours` creating `products` (MB, tier, offset h) and, with `downlink`, a
/// downlink span (from, to) in hours into it.
fn chain(task: u8, hours: u64, products: &[(u64, Tier, u64)]) -> Chain {
    let mut c = Chain::bare(
        u16::from(task),
        task,
        RankedUtility::single(Rank::Default, Score::new(5_000).expect("score")),
        1,
    );
    c.duration_us = hours * HOUR_US;
    for &(mb, tier, at) in products {
        c.products
            .push(ChainProduct {
                offset_us: at * HOUR_US,
                spec: ProductSpec {
                    size_bytes: mb * MB,
                    tier,
                    value: 10,
                },
            })
            .expect("capacity");
    }
    c
}

fn timeline() -> TimelinePlacement {
    TimelinePlacement {
        horizon_start: MissionTimeUs::ZERO,
        horizon_end: h(200),
        phases: PhaseTimeline::default(),
        battery_mj: u64::MAX / 4,
        hotel_load_mw: 0,
        earth: EarthView::default(),
    }
}

/// Chain 0: a 2 h downlink creating nothing (capacity at 50 kbps: 100 min of transmission,
/// 37.5 MB). Chains 1 and 2: 1 h tasks creating 30 MB of Mandatory data each, no downlink.
/// Chain 3: like 1, creating 5 MB of Residual data.
fn network() -> (FlatNetwork, DownlinkSpans) {
    let mut net = FlatNetwork::default();
    let mut spans = DownlinkSpans::new();
    net.chains.push(chain(0, 2, &[])).expect("capacity");
    spans.push(Some((0, 2 * HOUR_US))).expect("capacity");
    for task in 1..=2 {
        net.chains
            .push(chain(task, 1, &[(30, Tier::Mandatory, 1)]))
            .expect("capacity");
        spans.push(None).expect("capacity");
    }
    net.chains
        .push(chain(3, 1, &[(5, Tier::Residual, 1)]))
        .expect("capacity");
    spans.push(None).expect("capacity");
    (net, spans)
}

#[test]
fn a_chain_whose_data_exceeds_the_remaining_capacity_is_not_placed() {
    let (net, spans) = network();
    let link = comms(50_000);
    assert_eq!(link.capacity_of(2 * HOUR_US), 37_500_000);
    let plan = [PlacedChain {
        chain: 0,
        start: h(10),
    }];
    let mut p = DataPlacement::new(
        timeline(),
        DataView {
            comms: &link,
            onboard: &[],
            spans: &spans,
            spent: (0, 0),
        },
    );
    // The first 30 MB fit the downlink at 10 h.
    let first = p.place(&net, &plan, 1).expect("30 MB fit 37.5 MB");
    let plan2 = [
        plan[0],
        PlacedChain {
            chain: 1,
            start: first,
        },
    ];
    // The second 30 MB do not fit what is left (7.5 MB): refused, though the timeline alone
    // has room for it.
    assert_eq!(p.place(&net, &plan2, 2), None);
    assert!(timeline().place(&net, &plan2, 2).is_some());
    assert_eq!(p.stats.vetoes, 1);
    // 5 MB of Residual data still fit in what is left.
    assert!(p.place(&net, &plan2, 3).is_some());
    // Data already onboard takes capacity too: with 10 MB of Mandatory data waiting, even the
    // first 30 MB no longer fit.
    let onboard = [product(10, Tier::Mandatory, 0)];
    let mut q = DataPlacement::new(
        timeline(),
        DataView {
            comms: &link,
            onboard: &onboard,
            spans: &spans,
            spent: (0, 0),
        },
    );
    assert_eq!(q.place(&net, &plan, 1), None);
    // And data no downlink can take does not block chains that add nothing to it.
    let huge = [product(500, Tier::Mandatory, 0)];
    let mut r = DataPlacement::new(
        timeline(),
        DataView {
            comms: &link,
            onboard: &huge,
            spans: &spans,
            spent: (0, 0),
        },
    );
    assert!(r.place(&net, &plan, 3).is_some());
}

#[test]
fn a_rate_drop_or_a_spent_allowance_leaves_data_without_a_downlink() {
    let (net, spans) = network();
    let plan = [PlacedChain {
        chain: 0,
        start: h(10),
    }];
    let view = |link: &CommsModel, spent| {
        DataPlacement::new(
            timeline(),
            DataView {
                comms: link,
                onboard: &[],
                spans: &spans,
                spent,
            },
        )
        .place(&net, &plan, 1)
    };
    assert!(view(&comms(50_000), (0, 0)).is_some());
    // At 5 kbps the downlink carries 3.75 MB: the chain is pruned.
    assert_eq!(view(&comms(5_000), (0, 0)), None);
    // The sol's allowance mostly spent (390 of 400 Wh: 10 min of radio left) : pruned too.
    assert_eq!(view(&comms(50_000), (0, 390 * WH_MJ)), None);
    // A later sol is not affected by this sol's spending.
    assert!(view(&comms(50_000), (5, 390 * WH_MJ)).is_some());
}

#[test]
fn comms_models_and_onboard_lists_are_checked() {
    let link = comms(50_000);
    assert_eq!(link.validate(), Ok(()));
    assert_eq!(comms(0).validate(), Err(CommsError::Invalid));
    // The longest transmission: the thermal limit (3 h) below what 200 Wh pay for (3.33 h).
    assert_eq!(link.max_transmit_us(), 3 * HOUR_US);
    assert_eq!(link.bytes_in(3 * HOUR_US), 67_500_000);
    assert_eq!(link.duration_for(15 * MB), 1_200 * SEC_US + 2_400 * SEC_US);
    assert_eq!(link.duration_for(1_000 * MB), link.max_duration_us());
    // Segments: 10 MB over downlinks of 6.75 MB (5 kbps) is two items, values summing up.
    let mut items = heapless::Vec::new();
    let n = push_segments(&mut items, product(10, Tier::Mandatory, 0), 6_750_000);
    assert_eq!(n, Some(2));
    assert_eq!(items.iter().map(|p| p.size_bytes).sum::<u64>(), 10 * MB);
    assert_eq!(items.iter().map(|p| p.value).sum::<u64>(), 10);
    // Volumes: a product three times the model's changes the factor; the same again does not.
    let mut v = VolumeFactors::default();
    assert!(v.learn(PrimitiveKind::ScienceAnalyze, 10 * MB, 30 * MB));
    assert!(!v.learn(PrimitiveKind::ScienceAnalyze, 40 * MB, 120 * MB));
    assert_eq!(v.scale(PrimitiveKind::ScienceAnalyze, 40 * MB), 120 * MB);
    assert_eq!(v.scale(PrimitiveKind::TakeMonoPanorama, 20 * MB), 20 * MB);

    let opts = Rsm1Options::FULL;
    let model = rsm1::model(opts).expect("model");
    let flat = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flatten");
    let place = rsm1::placement(6, 20_000 * WH_MJ).expect("placement");
    let mut e: Executor = Executor::new(
        ExecConfig::new(Strategy::Replan),
        &model,
        &flat,
        &place,
        &rsm1::context(opts),
        None,
    )
    .expect("executor");
    assert_eq!(e.set_comms(Some(comms(0))), Err(CommsError::Invalid));
    assert_eq!(e.comms(), None, "a refused model changes nothing");
    let many = vec![product(1, Tier::Residual, 0); lander::capacity::MAX_DATA_PRODUCTS + 1];
    assert_eq!(e.set_onboard_data(&many), Err(CommsError::TooManyProducts));
    let mut bad = product(1, Tier::Residual, 0);
    bad.size_bytes = u64::MAX;
    assert_eq!(
        e.set_onboard_data(&[bad]),
        Err(CommsError::ProductOutOfRange)
    );
}

#[test]
fn the_next_downlink_carries_decisional_data_first_and_is_sized_to_it() {
    let link = comms(50_000);
    // Onboard: a 50 MB Decisional survey and 30 MB of Mandatory data; a later downlink at 20 h.
    let onboard = [
        product(50, Tier::Decisional, 1),
        product(30, Tier::Mandatory, 0),
    ];
    let mut payload = heapless::Vec::new();
    let planned = HOUR_US; // 15 MB as planned
    let d = next_downlink(
        &link,
        &onboard,
        &[],
        2 * HOUR_US,
        planned,
        u64::MAX,
        &[(20 * HOUR_US, 23 * HOUR_US)],
        (0, 0),
        &mut payload,
    );
    // The survey goes now (Decisional: the next downlink), the Mandatory data later.
    assert_eq!(payload.as_slice(), &[onboard[0]]);
    // The downlink is lengthened to carry it: 50 MB at 50 kbps is 8,000 s, plus set-up.
    assert_eq!(d, 1_200 * SEC_US + 8_000 * SEC_US);
    // Without a later downlink the Mandatory data rides too if it fits (it does not: 80 MB
    // is more than one downlink carries), so only the survey goes.
    let d2 = next_downlink(
        &link,
        &onboard,
        &[],
        2 * HOUR_US,
        planned,
        u64::MAX,
        &[],
        (0, 0),
        &mut payload,
    );
    assert_eq!(payload.as_slice(), &[onboard[0]]);
    assert_eq!(d2, d);
    // Earth sets at 3 h: the downlink ends there.
    let d3 = next_downlink(
        &link,
        &onboard,
        &[],
        2 * HOUR_US,
        planned,
        3 * HOUR_US,
        &[],
        (0, 0),
        &mut payload,
    );
    assert_eq!(d3, planned);
}

/// A world that does exactly what the executor predicts, reporting `onboard` as its data
/// (products `volume` times the model's).
struct World {
    now: MissionTimeUs,
    battery: u64,
    event: Option<Event>,
    onboard: Vec<DataProduct>,
    volume: u64,
}

impl World {
    fn new(volume: u64) -> Self {
        Self {
            now: MissionTimeUs::ZERO,
            battery: 20_000 * WH_MJ,
            event: None,
            onboard: Vec::new(),
            volume,
        }
    }
}

/// Steps `e` in `w` until `stop` says so or the plan ends.
fn fly(e: &mut Executor, w: &mut World, mut stop: impl FnMut(&Executor, &Directive) -> bool) {
    let model = rsm1::model(Rsm1Options::FULL).expect("model");
    for _ in 0..10_000 {
        e.set_onboard_data(&w.onboard).expect("onboard");
        let d = e.step(
            &Observation {
                now: w.now,
                battery_mj: w.battery,
                preconditions_met: true,
                event: w.event.take(),
            },
            100_000,
        );
        // The directive is carried out before stopping, so that a later call resumes.
        let done = stop(e, &d);
        match d {
            Directive::Dispatch {
                primitive,
                expected_end,
                expected_energy_mj,
                ..
            } => {
                let start = w.now;
                let spec = &model.primitives[usize::from(primitive)];
                if lander::placement::is_downlink(spec.kind) {
                    let sent = e.downlink_payload().to_vec();
                    w.onboard.retain(|p| !sent.contains(p));
                }
                w.now = expected_end;
                w.battery -= expected_energy_mj;
                if let Some(p) = spec.product {
                    w.onboard.push(DataProduct {
                        size_bytes: p.size_bytes * w.volume,
                        value: p.value,
                        created_at: w.now,
                        tier: p.tier,
                    });
                }
                w.event = Some(Event::Finished(Outcome {
                    result: TaskResult::Succeeded,
                    duration_us: expected_end.0 - start.0,
                    energy_mj: expected_energy_mj,
                    biosignature: Some(lander::assessor::Biosignature::Positive),
                }));
            }
            Directive::Wait { until } => w.now = until.max(w.now),
            Directive::Planning { .. } | Directive::Running { .. } => {}
            _ => return,
        }
        if done {
            return;
        }
    }
}

fn rsm1_executor(comms_model: Option<CommsModel>) -> Executor {
    let opts = Rsm1Options::FULL;
    let model = rsm1::model_with_drains(opts, 6).expect("model");
    let flat = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flatten");
    let mut place = rsm1::placement(12, 20_000 * WH_MJ).expect("placement");
    let windows: Vec<ViewWindow> = (0..12)
        .map(|k| ViewWindow {
            start: h(84 * k),
            end: h(84 * k + 42),
        })
        .collect();
    place.earth.windows = ViewTimeline::new(&windows).expect("windows");
    let mut e: Executor = Executor::new(
        ExecConfig::new(Strategy::Replan),
        &model,
        &flat,
        &place,
        &rsm1::context(opts),
        None,
    )
    .expect("executor");
    e.set_comms(comms_model).expect("comms");
    e
}

/// Whether a plan was installed after a replan for data volume that started at or after log
/// entry `from`.
fn replanned_for_data_since(e: &Executor, from: usize) -> bool {
    let log = e.log().get(from..).unwrap_or(&[]);
    log.iter()
        .position(|d| d.kind == DecisionKind::ReplanStarted(Reason::DataVolume))
        .is_some_and(|i| {
            log[i..]
                .iter()
                .any(|d| matches!(d.kind, DecisionKind::Planned { .. }))
        })
}

/// The sampling chains in the executor's plan (remaining).
fn samples_planned(e: &Executor) -> usize {
    let mut chains: Vec<u16> = e
        .remaining()
        .iter()
        .filter(|s| {
            e.network().chains[usize::from(s.chain)]
                .products
                .iter()
                .any(|p| p.spec.tier == Tier::Mandatory)
        })
        .map(|s| s.chain)
        .collect();
    chains.dedup();
    chains.len()
}

#[test]
fn a_rate_drop_from_the_ground_prunes_sampling_whose_data_cannot_go_down() {
    let mut w = World::new(1);
    let mut e = rsm1_executor(Some(comms(50_000)));
    // Plan, and stop at the first dispatch.
    fly(&mut e, &mut w, |_, d| {
        matches!(d, Directive::Dispatch { .. })
    });
    let before = samples_planned(&e);
    assert!(before >= 3, "at 50 kbps the plan samples ({before})");
    // The ground lowers the rate to 5 kbps: one downlink carries at most 6.75 MB (3 h
    // thermal limit), less than an analysis (10 MB compressed), so every sampling chain would
    // leave part of its analysis onboard. The executor replans at the next chain boundary and
    // samples no more.
    let from = e.log().len();
    e.set_comms(Some(comms(5_000))).expect("comms");
    fly(&mut e, &mut w, |e, _| replanned_for_data_since(e, from));
    assert!(
        replanned_for_data_since(&e, from),
        "{:?}",
        &e.log()[from.saturating_sub(3)..]
    );
    assert_eq!(
        samples_planned(&e),
        0,
        "no sampling whose data cannot go down"
    );
}

#[test]
fn without_the_data_check_the_same_rate_drop_changes_nothing() {
    // The reference: the same executor without a comms model keeps sampling at any rate.
    let mut w = World::new(1);
    let mut e = rsm1_executor(None);
    fly(&mut e, &mut w, |_, d| {
        matches!(d, Directive::Dispatch { .. })
    });
    assert!(samples_planned(&e) >= 3);
    assert!(e.data_stats().checks == 0);
}

#[test]
fn a_larger_product_than_modelled_is_learnt_and_replanned_for() {
    let mut w = World::new(3);
    let mut e = rsm1_executor(Some(comms(50_000)));
    // Products three times the model's: the first analysis measures it.
    let mut learnt: Option<usize> = None;
    fly(&mut e, &mut w, |e, _| {
        if learnt.is_none() && e.volumes().ppm(PrimitiveKind::ScienceAnalyze) != 1_000_000 {
            learnt = Some(e.log().len());
        }
        learnt.is_some_and(|from| replanned_for_data_since(e, from - 2))
    });
    assert_eq!(e.volumes().ppm(PrimitiveKind::ScienceAnalyze), 3_000_000);
    // The replanned sampling chains carry their data in their own downlinks, sized to it: a
    // raw analysis (120 MB) fits no downlink, so only compressed ones (30 MB) are planned,
    // each downlink long enough for 30 MB.
    let model = rsm1::model_with_drains(Rsm1Options::FULL, 6).expect("model");
    let mut sized = 0;
    for s in e.remaining() {
        let chain = &e.network().chains[usize::from(s.chain)];
        let kind = model.primitives[usize::from(s.primitive)].kind;
        if let Some(p) = chain
            .products
            .iter()
            .find(|p| p.spec.tier == Tier::Mandatory)
        {
            assert_eq!(
                p.spec.size_bytes,
                30 * MB,
                "only compressed analyses are planned"
            );
            if lander::placement::is_downlink(kind) {
                assert!(s.duration_us >= comms(50_000).duration_for(30 * MB));
                sized += 1;
            }
        }
    }
    assert!(sized >= 1, "some sampling is still planned");
}

#[test]
fn a_rate_drop_moves_data_to_a_later_downlink() {
    // A 20 MB Mandatory product onboard; the next downlink can last only 1 h (Earth sets),
    // a later one 3 h.
    let onboard = [product(20, Tier::Mandatory, 0)];
    let mut payload = heapless::Vec::new();
    let next = |rate, payload: &mut heapless::Vec<DataProduct, 64>| {
        next_downlink(
            &comms(rate),
            &onboard,
            &[],
            2 * HOUR_US,
            HOUR_US,
            3 * HOUR_US,
            &[(20 * HOUR_US, 23 * HOUR_US)],
            (0, 0),
            payload,
        )
    };
    // At 100 kbps the next downlink carries 30 MB: the product goes now.
    next(100_000, &mut payload);
    assert_eq!(payload.as_slice(), &onboard);
    // At 50 kbps it carries 15 MB: the product waits for the later downlink (60 MB).
    next(50_000, &mut payload);
    assert!(payload.is_empty());
}

#[test]
fn required_data_after_the_plans_last_downlink_gets_a_backlog_downlink() {
    let model = rsm1::model_with_drains(Rsm1Options::FULL, 6).expect("model");
    let is_dl = |p: u8| lander::placement::is_downlink(model.primitives[usize::from(p)].kind);
    let mut w = World::new(1);
    let mut e = rsm1_executor(Some(comms(50_000)));
    // Fly until the rest of the plan has no downlink left (only uplinks).
    fly(&mut e, &mut w, |e, _| {
        !e.remaining().is_empty() && e.remaining().iter().all(|s| !is_dl(s.primitive))
    });
    assert!(!e.remaining().is_empty(), "the plan ends with uplinks");
    // A quake record (Decisional) appears: at the next chain boundary the executor replans,
    // and a backlog downlink carries it.
    let quake = DataProduct {
        size_bytes: 500_000,
        value: 5,
        created_at: MissionTimeUs(w.now.0 + 1),
        tier: Tier::Decisional,
    };
    w.onboard.push(quake);
    let from = e.log().len();
    let mut carried = false;
    fly(&mut e, &mut w, |e, d| {
        if let Directive::Dispatch { primitive, .. } = d {
            carried |= is_dl(*primitive) && e.downlink_payload().contains(&quake);
        }
        carried
    });
    assert!(replanned_for_data_since(&e, from), "{:?}", &e.log()[from..]);
    assert!(carried, "a downlink carried the quake record");
}
