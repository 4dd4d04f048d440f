//! Earth in view in the placement (issue 11 items 5 and 8): downlinks are placed only inside
//! the in-view windows, and a chain whose data cannot reach Earth before the mission ends is
//! not added.
use fsw_bridge::MissionTimeUs;
use lander::executor::{ExecConfig, Executor, Strategy};
use lander::htn::{
    flatten, Chain, ChainProduct, FlatNetwork, FlattenOptions, PhaseTimeline, PrimitiveKind,
    PrimitiveSpec, ProductSpec, Tier,
};
use lander::placement::{
    downlink_spans, is_downlink, EarthView, TimelinePlacement, ViewError, ViewTimeline, ViewWindow,
};
use lander::rsm1::{self, Rsm1Options, HOUR_US};
use lander::search::{ChainPlacement, PlacedChain, Search, SearchConfig};
use lander::utility::{Rank, RankedUtility, Score};

fn h(x: u64) -> MissionTimeUs {
    MissionTimeUs(x * HOUR_US)
}

fn window(a: u64, b: u64) -> ViewWindow {
    ViewWindow {
        start: h(a),
        end: h(b),
    }
}

fn spec(kind: PrimitiveKind, hours: u64, product: bool) -> PrimitiveSpec {
    PrimitiveSpec {
        kind,
        site: None,
        target: None,
        duration_us: hours * HOUR_US,
        energy_mj: 1,
        utility: RankedUtility::ZERO,
        product: product.then_some(ProductSpec {
            size_bytes: 1_000,
            tier: Tier::Mandatory,
            value: 1,
        }),
    }
}

/// Primitives: 0 analysis (2 h, a product), 1 downlink (1 h), 2 panorama (1 h, a product).
fn primitives() -> [PrimitiveSpec; 3] {
    [
        spec(PrimitiveKind::ScienceAnalyze, 2, true),
        spec(PrimitiveKind::Downlink, 1, false),
        spec(PrimitiveKind::TakeMonoPanorama, 1, true),
    ]
}

fn chain(task: u8, primitives: &[u8], specs: &[PrimitiveSpec]) -> Chain {
    let one = RankedUtility::single(Rank::Mission, Score::new(5_000).expect("score"));
    let mut c = Chain::bare(u16::from(task), task, one, 1);
    let mut at = 0;
    for &p in primitives {
        c.primitives.push(p).expect("capacity");
        at += specs[usize::from(p)].duration_us;
        if specs[usize::from(p)].product.is_some() {
            c.products
                .push(ChainProduct {
                    offset_us: at,
                    spec: specs[usize::from(p)].product.expect("product"),
                })
                .expect("capacity");
        }
    }
    c.duration_us = at;
    c
}

fn placement(
    windows: &[ViewWindow],
    specs: &[PrimitiveSpec],
    net: &FlatNetwork,
) -> TimelinePlacement {
    TimelinePlacement {
        horizon_start: MissionTimeUs::ZERO,
        horizon_end: h(100),
        phases: PhaseTimeline::default(),
        battery_mj: 1_000,
        hotel_load_mw: 0,
        earth: EarthView::new(ViewTimeline::new(windows).expect("valid"), specs, net),
    }
}

#[test]
fn view_timelines_are_sorted_disjoint_and_bounded() {
    assert_eq!(
        ViewTimeline::new(&[window(0, 5), window(4, 8)]),
        Err(ViewError::Order)
    );
    assert_eq!(ViewTimeline::new(&[window(3, 3)]), Err(ViewError::Order));
    let many: Vec<ViewWindow> = (0..=lander::capacity::MAX_VIEW_WINDOWS as u64)
        .map(|k| window(2 * k, 2 * k + 1))
        .collect();
    assert_eq!(ViewTimeline::new(&many), Err(ViewError::TooMany));
    let t = ViewTimeline::new(&[window(0, 5), window(5, 8)]).expect("touching is fine");
    assert!(t.contains(h(1).0, h(5).0));
    assert!(
        !t.contains(h(4).0, h(6).0),
        "across two windows is not inside one"
    );
}

#[test]
fn downlink_spans_cover_the_downlink_primitives() {
    let specs = primitives();
    let mut net = FlatNetwork::default();
    net.chains
        .push(chain(0, &[0, 1], &specs))
        .expect("capacity");
    net.chains.push(chain(1, &[2], &specs)).expect("capacity");
    let spans = downlink_spans(&specs, &net, |p| {
        specs.get(usize::from(p)).map(|s| s.duration_us)
    });
    assert_eq!(spans.as_slice(), &[Some((h(2).0, h(3).0)), None]);
    assert!(is_downlink(PrimitiveKind::DownlinkWithGroundHold));
}

#[test]
fn a_downlink_is_placed_only_inside_a_window_opening_as_it_starts() {
    let specs = primitives();
    let mut net = FlatNetwork::default();
    // Analysis (2 h) then downlink (1 h): the downlink starts 2 h into the chain.
    net.chains
        .push(chain(0, &[0, 1], &specs))
        .expect("capacity");
    // Not modelled: at the horizon start, as before.
    let mut free = placement(&[], &specs, &net);
    assert_eq!(free.place(&net, &[], 0), Some(h(0)));
    // Earth rises at 10 h: the chain starts at 8 h so that its downlink starts at Earth rise.
    let mut p = placement(&[window(10, 20)], &specs, &net);
    assert_eq!(p.place(&net, &[], 0), Some(h(8)));
    // In view from the start: at the horizon start.
    let mut p = placement(&[window(0, 20)], &specs, &net);
    assert_eq!(p.place(&net, &[], 0), Some(h(0)));
    // A window too short for the downlink is skipped, and one that closes during it too.
    let mut p = placement(&[window(1, 2), window(4, 5), window(30, 31)], &specs, &net);
    // [4, 5) holds the 1 h downlink: start at 2 h.
    assert_eq!(p.place(&net, &[], 0), Some(h(2)));
    let mut p = placement(&[window(0, 2), window(30, 40)], &specs, &net);
    assert_eq!(p.place(&net, &[], 0), Some(h(28)));
    // A placed chain over the first opening: the downlink goes later in the same window.
    let mut two = net.clone();
    two.chains
        .push(chain(1, &[0, 1], &specs))
        .expect("capacity");
    let mut p = placement(&[window(10, 20)], &specs, &two);
    let plan = [PlacedChain {
        chain: 0,
        start: h(8),
    }];
    // Chain 0 takes [8, 11); chain 1 starts at 11 and downlinks at [13, 14).
    assert_eq!(p.place(&two, &plan, 1), Some(h(11)));
}

#[test]
fn a_chain_whose_data_cannot_reach_earth_is_not_added() {
    let specs = primitives();
    let mut net = FlatNetwork::default();
    // With its own downlink, and a panorama whose data waits for a later downlink.
    net.chains
        .push(chain(0, &[0, 1], &specs))
        .expect("capacity");
    net.chains.push(chain(1, &[2], &specs)).expect("capacity");
    // Earth is in view only before 5 h.
    let mut p = placement(&[window(0, 5)], &specs, &net);
    let late = [PlacedChain {
        chain: 0,
        start: h(0),
    }];
    // The downlinking chain fits the window at first...
    assert_eq!(p.place(&net, &[], 0), Some(h(0)));
    // ...the panorama has room left after it: [1, 5) in view.
    assert_eq!(p.place(&net, &[], 1), Some(h(0)));
    // After chain 0 ([0, 3)) the panorama ends at 4 h, with [4, 5) still in view.
    assert_eq!(p.place(&net, &late, 1), Some(h(3)));
    // With the window's rest taken, the panorama's data has no downlink left: pruned.
    let mut p = placement(&[window(0, 4)], &specs, &net);
    assert_eq!(p.place(&net, &late, 1), None);
    // And a downlinking chain with no window left is pruned as well.
    let mut p = placement(&[window(0, 2)], &specs, &net);
    assert_eq!(p.place(&net, &[], 0), None);

    // In the search: neither chain adds utility once no window is left.
    let mut p = placement(&[window(0, 2)], &specs, &net);
    p.horizon_start = h(2);
    let mut search: Search<64, 128> = Search::new(SearchConfig::exhaustive(1_000));
    search.start(&net, &[]).expect("starts");
    search.run(&net, &mut p);
    let mut plan: heapless::Vec<PlacedChain, { lander::capacity::MAX_PLAN_CHAINS }> =
        heapless::Vec::new();
    search.best_plan(&mut plan);
    assert!(plan.is_empty(), "{plan:?}");
    assert_eq!(search.best_value().0, RankedUtility::ZERO);
}

#[test]
fn the_executor_plans_every_downlink_of_rsm1_inside_a_window_and_takes_new_windows() {
    let options = Rsm1Options::FULL;
    let model = rsm1::model(options).expect("model");
    let net = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .expect("flattens");
    let sols = 12;
    let mut timeline = rsm1::placement(sols, 26_000 * 3_600_000).expect("placement");
    // Earth in view 42 h of every 84 h.
    let windows: Vec<ViewWindow> = (0..13).map(|k| window(84 * k, 84 * k + 42)).collect();
    timeline.earth.windows = ViewTimeline::new(&windows).expect("valid");
    let mut exec: Executor = Executor::new(
        ExecConfig::new(Strategy::Replan),
        &model,
        &net,
        &timeline,
        &rsm1::context(options),
        None,
    )
    .expect("executor");
    // The first step makes the plan.
    let obs = lander::executor::Observation {
        now: MissionTimeUs::ZERO,
        battery_mj: timeline.battery_mj,
        preconditions_met: true,
        event: None,
    };
    exec.step(&obs, u32::MAX);
    let downlinks: Vec<_> = exec
        .remaining()
        .iter()
        .filter(|s| is_downlink(model.primitives[usize::from(s.primitive)].kind))
        .copied()
        .collect();
    assert!(downlinks.len() >= 3, "{downlinks:?}");
    for d in &downlinks {
        let (a, b) = (d.planned_start.0, d.planned_start.0 + d.duration_us);
        assert!(
            exec.view_windows().contains(a, b),
            "a downlink planned in a blackout: {:.1} h .. {:.1} h",
            a as f64 / HOUR_US as f64,
            b as f64 / HOUR_US as f64
        );
    }
    // Updatable: new windows are what the executor's placement uses from the next plan.
    let fewer = ViewTimeline::new(&windows[..2]).expect("valid");
    exec.set_view_windows(&fewer);
    assert_eq!(exec.view_windows(), &fewer);
}
