//! The executor's setup on the wire (`lander::setup`) and its values on the link
//! (`lander::wire`): what the planner partition decodes is what the host encoded, bad bytes
//! are refused with their reason, and an executor built in place (`Executor::reset`, the
//! target's way) decides exactly as one built by `Executor::new`, also when given what a
//! replaced executor had learned (`Executor::set_learned`, the setup's learned part).
use fsw_bridge::lander::LanderSetupError;
use fsw_bridge::MissionTimeUs;
use lander::assessor::Biosignature;
use lander::comms::VolumeFactors;
use lander::executor::{
    Decision, DecisionKind, Directive, Event, ExecConfig, Executor, Learned, Observation, Outcome,
    ParameterUpdate, Reason, Strategy, TaskResult,
};
use lander::htn::{flatten, FlattenOptions, PrimitiveKind};
use lander::placement::{ViewTimeline, ViewWindow};
use lander::rsm1::{self, Rsm1Options, HOUR_US, SOL_US, WH_MJ};
use lander::setup::{decode_into, encode, validate, LanderSetup};
use lander::wire::*;

fn rsm1_setup(strategy: Strategy) -> LanderSetup {
    let options = Rsm1Options::FULL;
    let model = rsm1::model(options).unwrap();
    let network = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .unwrap();
    let mut timeline = rsm1::placement(6, 20_000 * WH_MJ).unwrap();
    timeline.hotel_load_mw = 9_000;
    let windows: Vec<ViewWindow> = (0..4u64)
        .map(|k| ViewWindow {
            start: MissionTimeUs(k * 84 * HOUR_US),
            end: MissionTimeUs((k * 84 + 42) * HOUR_US),
        })
        .collect();
    timeline.earth.windows = ViewTimeline::new(&windows).unwrap();
    let mut context = rsm1::context(options);
    context.sites[1].targets[0].biosignature = Some(Biosignature::Negative);
    context.sites[0].targets[1].collected = true;
    LanderSetup {
        config: ExecConfig::new(strategy),
        primitives: model.primitives.clone(),
        network,
        timeline,
        context,
        learned: Default::default(),
    }
}

fn encoded(s: &LanderSetup) -> Vec<u8> {
    let mut buf = vec![0u8; 1 << 20];
    let n = encode(s, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

fn empty() -> Box<LanderSetup> {
    let mut s = rsm1_setup(Strategy::Static);
    s.primitives.clear();
    s.network.chains.clear();
    s.context.sites.clear();
    Box::new(s)
}

#[test]
fn a_setup_decodes_to_what_was_encoded() {
    for strategy in [
        Strategy::Static,
        Strategy::Ground,
        Strategy::FlexibleExecution,
        Strategy::Replan,
    ] {
        let s = rsm1_setup(strategy);
        validate(&s).unwrap();
        let bytes = encoded(&s);
        let mut out = empty();
        decode_into(&bytes, &mut out).unwrap();
        assert_eq!(*out, s, "{strategy:?}");
        // RSM-1's full setup fits the target's 64 KiB buffer with room to spare.
        assert!(bytes.len() < 32 * 1024, "{} bytes", bytes.len());
    }
}

#[test]
fn bad_setups_are_refused_with_their_reason() {
    let s = rsm1_setup(Strategy::Replan);
    let bytes = encoded(&s);
    let mut out = empty();
    // Cut short anywhere: malformed (or, cut inside the header, malformed at the header).
    for cut in [1, 10, bytes.len() / 2, bytes.len() - 1] {
        let e = decode_into(&bytes[..cut], &mut out).unwrap_err();
        assert!(
            matches!(e, LanderSetupError::Malformed { .. }),
            "{cut}: {e:?}"
        );
    }
    // A byte more.
    let mut long = bytes.clone();
    long.push(0);
    assert_eq!(
        decode_into(&long, &mut out),
        Err(LanderSetupError::TrailingBytes {
            offset: bytes.len() as u32
        })
    );
    // Another version.
    let mut v = bytes.clone();
    v[0] = 9;
    assert_eq!(
        decode_into(&v, &mut out),
        Err(LanderSetupError::Version { got: 9 })
    );
    // A chain naming a primitive the model does not have.
    let mut bad = rsm1_setup(Strategy::Replan);
    let n = bad.primitives.len() as u8;
    bad.network.chains[3].primitives[0] = n;
    assert_eq!(
        decode_into(&encoded(&bad), &mut out),
        Err(LanderSetupError::BadChain { chain: 3 })
    );
    // An energy over the largest the algorithms take.
    let mut bad = rsm1_setup(Strategy::Replan);
    bad.primitives[2].energy_mj = u64::MAX;
    assert_eq!(
        decode_into(&encoded(&bad), &mut out),
        Err(LanderSetupError::OutOfRange { index: 2 })
    );
    // A horizon that ends before it starts.
    let mut bad = rsm1_setup(Strategy::Replan);
    bad.timeline.horizon_start = MissionTimeUs(bad.timeline.horizon_end.0 + 1);
    assert_eq!(
        decode_into(&encoded(&bad), &mut out),
        Err(LanderSetupError::BadHorizon)
    );
    // Windows out of order (the encoder writes what it is given; the target checks).
    let ok = rsm1_setup(Strategy::Replan);
    let good = encoded(&ok);
    let w0 = ok.timeline.earth.windows.windows()[0];
    let w1 = ok.timeline.earth.windows.windows()[1];
    // The header's window list spliced in by hand with two windows in the wrong order.
    let swapped = {
        let mut without = ok.clone();
        without.timeline.earth.windows = ViewTimeline::default();
        let mut alt = encoded(&without);
        let empty_list = postcard::to_allocvec(&heapless::Vec::<(u64, u64), 2>::new()).unwrap();
        let pos = find_list(&alt, &empty_list, &without);
        let list: heapless::Vec<(u64, u64), 2> =
            heapless::Vec::from_slice(&[(w1.start.0, w1.end.0), (w0.start.0, w0.end.0)]).unwrap();
        alt.splice(
            pos..pos + empty_list.len(),
            postcard::to_allocvec(&list).unwrap(),
        );
        alt
    };
    assert_eq!(
        decode_into(&swapped, &mut out),
        Err(LanderSetupError::BadWindows)
    );
    // A strategy number out of range.
    let mut b = good.clone();
    b[1] = 7;
    assert_eq!(
        decode_into(&b, &mut out),
        Err(LanderSetupError::BadStrategy)
    );
}

/// Where the header's (empty) window list is: the offset after the fields before it, found by
/// encoding the same header with one window and comparing.
fn find_list(bytes: &[u8], empty_list: &[u8], s: &LanderSetup) -> usize {
    let mut one = s.clone();
    one.timeline.earth.windows = ViewTimeline::new(&[ViewWindow {
        start: MissionTimeUs(0),
        end: MissionTimeUs(1),
    }])
    .unwrap();
    let other = encoded(&one);
    let pos = bytes.iter().zip(&other).position(|(a, b)| a != b).unwrap();
    assert_eq!(&bytes[pos..pos + empty_list.len()], empty_list);
    pos
}

/// Steps `exec` through a scripted mission: every primitive dispatched succeeds after its
/// predicted duration, every analysis is negative, the fourth dispatch fails once.
fn script(exec: &mut Executor, budget: u32) -> (Vec<Decision>, Vec<Directive>) {
    let mut now = 0u64;
    let mut battery = 20_000 * WH_MJ;
    let mut event = None;
    let mut directives = Vec::new();
    let mut dispatches = 0;
    for _ in 0..400 {
        let obs = Observation {
            now: MissionTimeUs(now),
            battery_mj: battery,
            preconditions_met: true,
            event: event.take(),
        };
        let mut d = exec.step(&obs, budget);
        while let Directive::Planning { .. } = d {
            d = exec.step(&Observation { event: None, ..obs }, budget);
        }
        directives.push(d);
        match d {
            Directive::Dispatch {
                kind,
                expected_end,
                expected_energy_mj,
                ..
            } => {
                dispatches += 1;
                now = expected_end.0.max(now + 1);
                battery = battery.saturating_sub(expected_energy_mj);
                event = Some(Event::Finished(Outcome {
                    result: if dispatches == 4 {
                        TaskResult::Failed
                    } else {
                        TaskResult::Succeeded
                    },
                    duration_us: expected_end.0 - obs.now.0,
                    energy_mj: expected_energy_mj,
                    biosignature: (kind == PrimitiveKind::ScienceAnalyze)
                        .then_some(Biosignature::Negative),
                }));
            }
            Directive::Wait { until } => now = until.0.max(now + 1),
            Directive::Pushing { deadline } => now = deadline.0,
            Directive::Done | Directive::Abandoned { .. } => break,
            Directive::HaltedForGround { .. } => event = Some(Event::GroundResume),
            Directive::Running { .. } | Directive::Planning { .. } => now += 1,
        }
        if now > 6 * SOL_US {
            break;
        }
    }
    (exec.log().to_vec(), directives)
}

#[test]
fn an_executor_built_in_place_decides_as_a_new_one() {
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(|| {
            for strategy in [Strategy::FlexibleExecution, Strategy::Replan] {
                let s = rsm1_setup(strategy);
                let model = lander::htn::HtnModel {
                    primitives: s.primitives.clone(),
                    ..Default::default()
                };
                let mut new = Box::new(
                    Executor::new(s.config, &model, &s.network, &s.timeline, &s.context, None)
                        .unwrap(),
                );
                // Reset an executor that ran another mission first: nothing of it may remain.
                let mut reset = Box::new(
                    Executor::new(
                        ExecConfig::new(Strategy::Static),
                        &model,
                        &s.network,
                        &s.timeline,
                        &lander::rsm1::context(Rsm1Options::FULL),
                        None,
                    )
                    .unwrap(),
                );
                let _ = script(&mut reset, 1_000);
                reset.reset(
                    s.config,
                    &s.primitives,
                    &s.network,
                    &s.timeline,
                    &s.context,
                    &Learned::default(),
                );
                let a = script(&mut new, 1_000_000);
                let b = script(&mut reset, 3);
                assert!(
                    a.0.iter()
                        .any(|d| d.kind == DecisionKind::ReplanStarted(Reason::Discovery))
                        || strategy != Strategy::Replan,
                    "{strategy:?}: the script replans after the negatives: {:?}",
                    a.0
                );
                assert!(a.0.len() > 20, "{strategy:?}: {:?}", a.0);
                assert_eq!(a, b, "{strategy:?}");
            }
        })
        .unwrap()
        .join()
        .unwrap();
}

#[test]
fn values_cross_the_link_unchanged() {
    let s = rsm1_setup(Strategy::Replan);
    let model = lander::htn::HtnModel {
        primitives: s.primitives.clone(),
        ..Default::default()
    };
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(move || {
            let mut exec = Box::new(
                Executor::new(s.config, &model, &s.network, &s.timeline, &s.context, None).unwrap(),
            );
            let (log, directives) = script(&mut exec, 1_000);
            for d in &log {
                assert_eq!(decision_from_wire(&decision_to_wire(d)), *d);
            }
            for d in &directives {
                assert_eq!(directive_from_wire(&directive_to_wire(d)).unwrap(), *d);
            }
            for event in [
                None,
                Some(Event::GroundResume),
                Some(Event::Finished(Outcome {
                    result: TaskResult::Faulted,
                    duration_us: 7,
                    energy_mj: 9,
                    biosignature: Some(Biosignature::Positive),
                })),
            ] {
                let o = Observation {
                    now: MissionTimeUs(5),
                    battery_mj: 6,
                    preconditions_met: false,
                    event,
                };
                assert_eq!(observation_from_wire(&observation_to_wire(&o)), o);
            }
        })
        .unwrap()
        .join()
        .unwrap();
}

/// The link model and the products onboard (elap-downlink's inputs, `LanderInput`) cross
/// the link unchanged, every tier; a tier index the target does not have is refused.
#[test]
fn link_and_data_inputs_cross_the_link_unchanged() {
    use lander::comms::CommsModel;
    use lander::downlink::DataProduct;
    use lander::htn::Tier;
    use lander::wire::{comms_from_wire, comms_to_wire, product_from_wire, product_to_wire};
    let c = CommsModel {
        rate_bps: 50_000,
        overhead_us: 1,
        thermal_limit_us: 2,
        radio_power_mw: 3,
        per_downlink_mj: 4,
        per_sol_mj: 5,
        sol_us: 6,
    };
    assert_eq!(comms_from_wire(&comms_to_wire(&c)), c);
    for tier in [
        Tier::Critical,
        Tier::Decisional,
        Tier::Mandatory,
        Tier::Residual,
    ] {
        let p = DataProduct {
            size_bytes: u64::MAX,
            value: 7,
            created_at: MissionTimeUs(8),
            tier,
        };
        assert_eq!(product_from_wire(&product_to_wire(&p)), Ok(p));
    }
    let mut w = product_to_wire(&DataProduct {
        size_bytes: 1,
        value: 1,
        created_at: MissionTimeUs(0),
        tier: Tier::Residual,
    });
    w.tier = 4;
    assert_eq!(product_from_wire(&w), Err(lander::wire::UnknownKind(4)));
}

/// What a replaced executor learned: excavation and sampling at site 0 cost twice their priors
/// and take 1.5 times as long, panoramas come out three times their size, and sol 0's
/// downlinks spent 50 Wh.
fn learned(s: &LanderSetup) -> Learned {
    let mut l = Learned::default();
    for kind in [PrimitiveKind::ExcavateSite, PrimitiveKind::CollectSample] {
        let prior = s
            .primitives
            .iter()
            .find(|p| p.kind == kind && p.site == Some(0))
            .unwrap();
        assert!(l.set_parameter(ParameterUpdate {
            kind,
            site: 0,
            duration_us: prior.duration_us * 3 / 2,
            energy_mj: prior.energy_mj * 2,
        }));
    }
    l.volumes =
        VolumeFactors::from_entries(&[(PrimitiveKind::TakeMonoPanorama, 3_000_000)]).unwrap();
    l.comm_spent = (0, 50 * WH_MJ);
    l
}

#[test]
fn the_learned_part_crosses_the_link_and_bad_values_are_refused() {
    let mut s = rsm1_setup(Strategy::Replan);
    s.learned = learned(&s);
    let bytes = encoded(&s);
    let mut out = empty();
    decode_into(&bytes, &mut out).unwrap();
    assert_eq!(*out, s);
    assert_eq!(out.learned.params.len(), 2);
    // An energy over the largest the algorithms take.
    let mut bad = s.clone();
    bad.learned.params[1].energy_mj = u64::MAX;
    assert_eq!(
        decode_into(&encoded(&bad), &mut out),
        Err(LanderSetupError::OutOfRange { index: u16::MAX })
    );
    let mut bad = s.clone();
    bad.learned.comm_spent.1 = u64::MAX;
    assert_eq!(
        decode_into(&encoded(&bad), &mut out),
        Err(LanderSetupError::OutOfRange { index: u16::MAX })
    );
    // A volume factor given twice, or over the largest (the encoder cannot write them: spliced
    // in by hand, the second entry's kind or factor changed).
    let mut two = s.clone();
    two.learned.volumes = VolumeFactors::from_entries(&[
        (PrimitiveKind::TakeMonoPanorama, 2_000_000),
        (PrimitiveKind::CollectSample, 2_000_000),
    ])
    .unwrap();
    let good = encoded(&two);
    let factor = postcard::to_allocvec(&2_000_000u64).unwrap();
    let mut entries = vec![2u8, 0];
    entries.extend(&factor);
    entries.push(1);
    entries.extend(&factor);
    let at = good
        .windows(entries.len())
        .position(|w| w == entries.as_slice())
        .expect("the volume list");
    decode_into(&good, &mut out).unwrap();
    let mut twice = good.clone();
    twice[at + 2 + factor.len()] = 0;
    assert_eq!(
        decode_into(&twice, &mut out),
        Err(LanderSetupError::OutOfRange { index: u16::MAX })
    );
    let mut huge = good[..at + 2 + factor.len() + 1].to_vec();
    huge.extend(postcard::to_allocvec(&(lander::comms::MAX_VOLUME_PPM + 1)).unwrap());
    huge.extend(&good[at + entries.len()..]);
    assert_eq!(
        decode_into(&huge, &mut out),
        Err(LanderSetupError::OutOfRange { index: u16::MAX })
    );
}

#[test]
fn an_executor_given_what_was_learned_decides_in_place_as_a_new_one_and_otherwise_than_without() {
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(|| {
            let s = rsm1_setup(Strategy::Replan);
            let l = learned(&s);
            let model = lander::htn::HtnModel {
                primitives: s.primitives.clone(),
                ..Default::default()
            };
            let build = || {
                Box::new(
                    Executor::new(s.config, &model, &s.network, &s.timeline, &s.context, None)
                        .unwrap(),
                )
            };
            let mut new = build();
            new.set_learned(&l);
            assert_eq!(new.learned(), l);
            let mut reset = build();
            let _ = script(&mut reset, 1_000);
            reset.reset(
                s.config,
                &s.primitives,
                &s.network,
                &s.timeline,
                &s.context,
                &l,
            );
            let mut without = build();
            let a = script(&mut new, 1_000_000);
            let b = script(&mut reset, 3);
            let c = script(&mut without, 1_000_000);
            assert!(a.0.len() > 20, "{:?}", a.0);
            assert_eq!(a, b);
            // The learned values are used: the predictions (and so the directives) differ.
            assert_ne!(a.1, c.1);
            // The sampling at site 0 is expected to cost what was learned.
            let collect = s
                .primitives
                .iter()
                .find(|p| p.kind == PrimitiveKind::CollectSample && p.site == Some(0))
                .unwrap();
            let dispatched = a.1.iter().find_map(|d| match *d {
                Directive::Dispatch {
                    kind: PrimitiveKind::CollectSample,
                    site: Some(0),
                    expected_energy_mj,
                    ..
                } => Some(expected_energy_mj),
                _ => None,
            });
            assert_eq!(dispatched, Some(collect.energy_mj * 2));
        })
        .unwrap()
        .join()
        .unwrap();
}
