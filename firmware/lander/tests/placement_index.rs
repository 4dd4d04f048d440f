//! The indexed placement ([`ChainPlacement::place`] of [`TimelinePlacement`], which sorts the
//! plan's busy intervals and uplinks once per call) decides exactly as the placement as first
//! written ([`TimelinePlacement::place_reference`]) on seeded random plans: chains of zero and
//! non-zero length, ground holds, waits and uplinks, phases, fixed starts, Earth-in-view
//! windows with downlink spans and products, energy and hotel load, plans built by the
//! placement and plans with chains put anywhere (overlapping ones included).
mod common;

use common::*;
use fsw_bridge::MissionTimeUs;
use lander::htn::{Chain, ChainProduct, FlatNetwork, PhaseMask, PhaseTimeline, ProductSpec, Tier};
use lander::placement::{
    CachedTimeline, DownlinkSpans, EarthView, PlanIndexCache, TimelinePlacement, ViewTimeline,
    ViewWindow,
};
use lander::search::{ChainPlacement, PlacedChain};

const CASES: u64 = 400;

fn network(rng: &mut Rng) -> (FlatNetwork, DownlinkSpans) {
    let mut net = FlatNetwork::default();
    let mut spans = DownlinkSpans::new();
    let chains = rng.range(4, 24);
    for i in 0..chains {
        let mut c = Chain::bare(i as u16, i as u8, small_utility(rng), rng.range(0, 9));
        c.duration_us = if rng.chance(10) {
            0
        } else {
            rng.range(1, 8) * HOUR / 2
        };
        c.holds_for_ground = rng.chance(30);
        c.waits_for_ground_release = rng.chance(30);
        c.is_uplink = rng.chance(25);
        c.phases = match rng.range(0, 3) {
            0 => PhaseMask::ANY,
            k => PhaseMask::only(k as u8 - 1),
        };
        if rng.chance(10) {
            c.fixed_start = Some(MissionTimeUs(rng.range(0, 60) * HOUR / 2));
        }
        let span = (c.duration_us > 0 && rng.chance(40)).then(|| {
            let from = rng.range(0, c.duration_us / (HOUR / 2) - 1) * HOUR / 2;
            (from, c.duration_us)
        });
        for _ in 0..rng.range(0, 2) {
            let _ = c.products.push(ChainProduct {
                offset_us: rng.range(0, c.duration_us / (HOUR / 2)) * HOUR / 2,
                spec: ProductSpec {
                    size_bytes: 1_000,
                    tier: Tier::Mandatory,
                    value: 1,
                },
            });
        }
        net.chains.push(c).expect("capacity");
        spans.push(span).expect("capacity");
    }
    (net, spans)
}

fn placement(rng: &mut Rng, downlinks: DownlinkSpans) -> TimelinePlacement {
    let phases = PhaseTimeline::new(&[(hours(rng.range(2, 10)), 1), (hours(rng.range(11, 20)), 2)])
        .expect("valid");
    let mut windows = Vec::new();
    if rng.chance(60) {
        let mut at = rng.range(0, 4);
        while at < 40 {
            let len = rng.range(1, 6);
            windows.push(ViewWindow {
                start: hours(at),
                end: hours(at + len),
            });
            at += len + rng.range(1, 6);
        }
    }
    TimelinePlacement {
        horizon_start: hours(rng.range(0, 2)),
        horizon_end: hours(rng.range(20, 40)),
        phases,
        // The hotel load's drain to the chain's end decides about half the time.
        battery_mj: if rng.chance(5) {
            u64::MAX
        } else {
            rng.range(10, 80) + rng.range(0, 1) * rng.range(0, 150_000)
        },
        hotel_load_mw: rng.range(0, 1) * rng.range(0, 5),
        earth: EarthView {
            windows: ViewTimeline::new(&windows).expect("sorted"),
            downlinks,
        },
    }
}

#[test]
fn the_indexed_placement_decides_as_the_reference() {
    let (mut placed, mut refused, mut compared) = (0u32, 0u32, 0u32);
    let mut holds_checked = 0u32;
    for seed in 0..CASES {
        let mut rng = Rng::new(seed);
        let (net, downlinks) = network(&mut rng);
        let mut place = placement(&mut rng, downlinks);
        let mut plan: Vec<PlacedChain> = Vec::new();
        let anywhere = rng.chance(30);
        for _ in 0..rng.range(1, 14) {
            for candidate in 0..net.chains.len() as u16 {
                let fast = place.place(&net, &plan, candidate);
                let reference = place.place_reference(&net, &plan, candidate);
                assert_eq!(
                    fast, reference,
                    "seed {seed}: chain {candidate} after {plan:?}"
                );
                compared += 1;
                if fast.is_some() {
                    placed += 1;
                } else {
                    refused += 1;
                }
                let c = &net.chains[usize::from(candidate)];
                if fast.is_some()
                    && (c.holds_for_ground || c.waits_for_ground_release)
                    && plan.iter().any(|p| {
                        let q = &net.chains[usize::from(p.chain)];
                        q.is_uplink || q.holds_for_ground
                    })
                {
                    holds_checked += 1;
                }
            }
            let chain = rng.range(0, net.chains.len() as u64 - 1) as u16;
            let start = if anywhere {
                Some(MissionTimeUs(rng.range(0, 60) * HOUR / 2))
            } else {
                place.place_reference(&net, &plan, chain)
            };
            if let Some(start) = start {
                plan.push(PlacedChain { chain, start });
            }
        }
    }
    // Not vacuous: both answers are common, and holds met uplinks often.
    assert!(compared > 20_000, "{compared}");
    assert!(
        placed > compared / 10 && refused > compared / 10,
        "{placed} {refused}"
    );
    assert!(holds_checked > 1_000, "{holds_checked}");
}

/// The placement with its index kept between calls ([`CachedTimeline`]) decides as the
/// placement that indexes every plan again, over sequences of plans as the search asks them:
/// the same plan again, the plan with one chain more (updated in place), a shorter plan, a
/// plan whose last chain moved, another horizon start (indexed again), on the same random
/// plans as above (overlapping ones included).
#[test]
fn the_kept_index_decides_as_the_index_built_per_call() {
    let (mut compared, mut extended, mut placed) = (0u32, 0u32, 0u32);
    let mut cache = PlanIndexCache::new();
    for seed in 0..CASES {
        let mut rng = Rng::new(seed ^ 0x5eed);
        let (net, downlinks) = network(&mut rng);
        let mut place = placement(&mut rng, downlinks);
        // A new network: what the cache holds no longer applies.
        cache.clear();
        let mut plan: Vec<PlacedChain> = Vec::new();
        let anywhere = rng.chance(30);
        for _ in 0..rng.range(1, 16) {
            // The plan asked: mostly the current one, sometimes a shorter one, one with its
            // last chain moved, or from another horizon start.
            let mut asked = plan.clone();
            let mut timeline = place.clone();
            match rng.range(0, 9) {
                0 => asked.truncate(rng.range(0, asked.len() as u64) as usize),
                1 => {
                    if let Some(last) = asked.last_mut() {
                        last.start = MissionTimeUs(last.start.0 + HOUR / 2);
                    }
                }
                2 => timeline.horizon_start = MissionTimeUs(timeline.horizon_start.0 + HOUR),
                _ => {}
            }
            for candidate in 0..net.chains.len() as u16 {
                let fresh = timeline.place(&net, &asked, candidate);
                let kept = CachedTimeline {
                    timeline: &timeline,
                    cache: &mut cache,
                }
                .place(&net, &asked, candidate);
                assert_eq!(
                    kept, fresh,
                    "seed {seed}: chain {candidate} after {asked:?}"
                );
                compared += 1;
                placed += u32::from(fresh.is_some());
            }
            let chain = rng.range(0, net.chains.len() as u64 - 1) as u16;
            let start = if anywhere {
                Some(MissionTimeUs(rng.range(0, 60) * HOUR / 2))
            } else {
                place.place(&net, &plan, chain)
            };
            if let Some(start) = start {
                plan.push(PlacedChain { chain, start });
                extended += 1;
            }
        }
    }
    assert!(compared > 20_000, "{compared}");
    assert!(extended > 2_000, "{extended}");
    assert!(
        placed > compared / 10 && placed < compared * 9 / 10,
        "{placed}"
    );
}
