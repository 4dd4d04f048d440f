//! The lander executor's plug-in (`LanderApp`) natively, with a scripted CPU clock: a step
//! whose search needs many windows is answered, after as many windows as its CPU needs, with
//! the directive and decisions of one native call with a large budget; a window's calls stop
//! before its planning share; bad setups and steps are refused with their reason.
use flight_app::{
    lander_crc32, CpuClock, LanderApp, LanderStorage, PlannerPlugin, MAX_LANDER_SETUP_BYTES,
};
use fsw_bridge::lander::{LanderRefusal, LanderReport, LanderSetupError, LANDER_CHUNK_MAX};
use fsw_bridge::{HostToTarget, MissionTimeUs, TargetToHost};
use lander::downlink::DownlinkManager;
use lander::executor::{Directive, ExecConfig, Executor, Observation, Strategy};
use lander::htn::{flatten, FlattenOptions, HtnModel};
use lander::rsm1::{self, Rsm1Options, WH_MJ};
use lander::setup::{encode, LanderSetup};
use lander::wire::{decision_from_wire, directive_from_wire, observation_to_wire};

/// A clock that advances `per_read` ticks at every reading (so every call costs about that).
struct Clock {
    now: u64,
    per_read: u64,
}

impl CpuClock for Clock {
    fn ticks(&mut self) -> u64 {
        self.now += self.per_read;
        self.now
    }
}

fn setup() -> (HtnModel, LanderSetup) {
    let model = rsm1::model(Rsm1Options::FULL).unwrap();
    let network = flatten(
        &model,
        FlattenOptions {
            fully_autonomous: true,
        },
    )
    .unwrap();
    let timeline = rsm1::placement(6, 20_000 * WH_MJ).unwrap();
    let s = LanderSetup {
        config: ExecConfig::new(Strategy::Replan),
        primitives: model.primitives.clone(),
        network,
        timeline,
        context: rsm1::context(Rsm1Options::FULL),
        learned: Default::default(),
    };
    (model, s)
}

fn messages(id: u16, bytes: &[u8]) -> Vec<HostToTarget> {
    let mut m = vec![HostToTarget::LanderBegin {
        setup: id,
        len: bytes.len() as u32,
        crc32: lander_crc32(bytes),
    }];
    for (i, c) in bytes.chunks(LANDER_CHUNK_MAX).enumerate() {
        m.push(HostToTarget::LanderChunk {
            setup: id,
            offset: (i * LANDER_CHUNK_MAX) as u32,
            bytes: heapless::Vec::from_slice(c).unwrap(),
        });
    }
    m
}

#[test]
fn a_step_planned_over_many_windows_answers_as_one_native_call() {
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(|| {
            let (model, s) = setup();
            let mut buf = vec![0u8; 1 << 20];
            let n = encode(&s, &mut buf).unwrap();
            let bytes = &buf[..n];
            let mut store = vec![0u8; MAX_LANDER_SETUP_BYTES];
            let mut decoded = Box::new(s.clone());
            let mut exec: Box<Executor> = Box::new(
                Executor::new(s.config, &model, &s.network, &s.timeline, &s.context, None).unwrap(),
            );
            let mut manager = Box::new(DownlinkManager::new());
            let mut app = LanderApp::new();
            app.give_storage(LanderStorage {
                bytes: &mut store,
                setup: &mut decoded,
                executor: &mut exec,
                downlink: &mut manager,
            });
            let mut out = Vec::new();
            let mut clock = Clock {
                now: 0,
                per_read: 1_000,
            };
            for m in messages(7, bytes) {
                assert!(app.handle_with_clock(&m, &mut clock, &mut |x| out.push(x)));
            }
            assert!(
                matches!(
                    out.as_slice(),
                    [TargetToHost::Lander(LanderReport::Accepted {
                        setup: 7,
                        ..
                    })]
                ),
                "{out:?}"
            );
            out.clear();
            let obs = Observation {
                now: MissionTimeUs(0),
                battery_mj: s.timeline.battery_mj,
                preconditions_met: true,
                event: None,
            };
            // Out of order, then step 0.
            let step = |seq| HostToTarget::LanderStep {
                setup: 7,
                seq,
                observation: observation_to_wire(&obs),
            };
            app.handle(&step(3), &mut |x| out.push(x));
            assert_eq!(
                out.pop(),
                Some(TargetToHost::Lander(LanderReport::Refused {
                    setup: 7,
                    seq: Some(3),
                    reason: LanderRefusal::OutOfOrder { expected: 0 }
                }))
            );
            app.handle(&step(0), &mut |x| out.push(x));
            assert!(out.is_empty());
            // Windows of a 10,000-tick share: each call reads the clock once (1,000 ticks),
            // so at most 10 calls a window.
            let mut windows = 0;
            while app.planning_pending() {
                let start = clock.now;
                let before = clock.now;
                app.run(&mut clock, Some(start + 10_000), Some(start + 12_000));
                assert!(clock.now - before <= 12_000, "a window ran past its end");
                windows += 1;
                assert!(windows < 10_000, "no answer");
            }
            assert!(windows > 10, "the plan took {windows} windows");
            app.report(64, &mut |x| out.push(x));
            let (mut decisions, mut directive) = (Vec::new(), None);
            for m in &out {
                match m {
                    TargetToHost::Lander(LanderReport::Decision { decision, .. }) => {
                        decisions.push(decision_from_wire(decision))
                    }
                    TargetToHost::Lander(LanderReport::Answer {
                        directive: d,
                        windows: w,
                        ..
                    }) => {
                        assert_eq!(usize::from(*w), windows);
                        directive = Some(directive_from_wire(d).unwrap());
                    }
                    other => panic!("{other:?}"),
                }
            }
            let mut native: Box<Executor> = Box::new(
                Executor::new(s.config, &model, &s.network, &s.timeline, &s.context, None).unwrap(),
            );
            let want = native.step(&obs, 1_000_000);
            assert!(!matches!(want, Directive::Planning { .. }));
            assert_eq!(directive, Some(want));
            assert_eq!(decisions, native.log());

            // A setup whose CRC does not match, and one that does not decode.
            out.clear();
            let mut bad = messages(8, bytes);
            if let HostToTarget::LanderChunk { bytes, .. } = &mut bad[1] {
                bytes[3] ^= 1;
            }
            for m in &bad {
                app.handle(m, &mut |x| out.push(x));
            }
            assert!(
                matches!(
                    out.as_slice(),
                    [TargetToHost::Lander(LanderReport::Refused {
                        setup: 8,
                        seq: None,
                        reason: LanderRefusal::BadCrc { .. }
                    })]
                ),
                "{out:?}"
            );
            out.clear();
            for m in messages(9, &bytes[..bytes.len() / 2]) {
                app.handle(&m, &mut |x| out.push(x));
            }
            assert!(
                matches!(
                    out.as_slice(),
                    [TargetToHost::Lander(LanderReport::Refused {
                        setup: 9,
                        seq: None,
                        reason: LanderRefusal::BadSetup(LanderSetupError::Malformed { .. })
                    })]
                ),
                "{out:?}"
            );
            // No executor after a refused setup; a chunk of no upload; a setup too large.
            out.clear();
            app.handle(&step(0), &mut |x| out.push(x));
            app.handle(
                &HostToTarget::LanderChunk {
                    setup: 9,
                    offset: 0,
                    bytes: heapless::Vec::new(),
                },
                &mut |x| out.push(x),
            );
            app.handle(
                &HostToTarget::LanderBegin {
                    setup: 10,
                    len: MAX_LANDER_SETUP_BYTES as u32 + 1,
                    crc32: 0,
                },
                &mut |x| out.push(x),
            );
            let reasons: Vec<_> = out
                .iter()
                .map(|m| match m {
                    TargetToHost::Lander(LanderReport::Refused { reason, .. }) => *reason,
                    other => panic!("{other:?}"),
                })
                .collect();
            assert_eq!(
                reasons,
                [
                    LanderRefusal::NoSetup,
                    LanderRefusal::OutOfSequence { expected_offset: 0 },
                    LanderRefusal::TooLarge {
                        capacity: MAX_LANDER_SETUP_BYTES as u32
                    }
                ]
            );
        })
        .unwrap()
        .join()
        .unwrap();
}

/// The executor's link and data inputs (`LanderInput`): a valid link model and product list
/// reach the executor (it holds exactly what was sent, the list applied when its last part
/// arrives); a zero rate, an unknown tier, a part out of order, too many products, or an input
/// for no setup are refused with their reason and the executor keeps what it had.
#[test]
fn link_and_data_inputs_reach_the_executor_and_bad_ones_are_refused() {
    use fsw_bridge::lander::{LanderComms, LanderInput, LanderProduct};
    std::thread::Builder::new()
        .stack_size(64 << 20)
        .spawn(|| {
            let (model, s) = setup();
            let mut buf = vec![0u8; 1 << 20];
            let n = encode(&s, &mut buf).unwrap();
            let bytes = &buf[..n];
            let mut store = vec![0u8; MAX_LANDER_SETUP_BYTES];
            let mut decoded = Box::new(s.clone());
            let mut exec: Box<Executor> = Box::new(
                Executor::new(s.config, &model, &s.network, &s.timeline, &s.context, None).unwrap(),
            );
            let mut manager = Box::new(DownlinkManager::new());
            let mut app = LanderApp::new();
            app.give_storage(LanderStorage {
                bytes: &mut store,
                setup: &mut decoded,
                executor: &mut exec,
                downlink: &mut manager,
            });
            let mut clock = Clock {
                now: 0,
                per_read: 1_000,
            };
            let mut out = Vec::new();
            let comms = |rate_bps| LanderComms {
                rate_bps,
                overhead_us: 600_000_000,
                thermal_limit_us: 3_600_000_000,
                radio_power_mw: 50_000,
                per_downlink_mj: 100_000_000,
                per_sol_mj: 200_000_000,
                sol_us: rsm1::SOL_US,
            };
            let input = |setup, input| HostToTarget::LanderInput { setup, input };
            // No setup yet.
            assert!(app.handle_with_clock(
                &input(7, LanderInput::Comms(Some(comms(50_000)))),
                &mut clock,
                &mut |x| out.push(x)
            ));
            let refused = |out: &[TargetToHost]| match out {
                [TargetToHost::Lander(LanderReport::Refused {
                    reason, seq: None, ..
                })] => Some(*reason),
                _ => None,
            };
            assert_eq!(refused(&out), Some(LanderRefusal::NoSetup));
            out.clear();
            for m in messages(7, bytes) {
                assert!(app.handle_with_clock(&m, &mut clock, &mut |x| out.push(x)));
            }
            out.clear();
            let mut send = |app: &mut LanderApp, msg: HostToTarget| {
                let mut out = Vec::new();
                assert!(app.handle_with_clock(&msg, &mut clock, &mut |x| out.push(x)));
                match refused(&out) {
                    Some(r) => Some(r),
                    None if out.is_empty() => None,
                    None => panic!("{out:?}"),
                }
            };
            // A valid link model is applied, silently.
            assert_eq!(
                send(&mut app, input(7, LanderInput::Comms(Some(comms(50_000))))),
                None
            );
            assert_eq!(
                app.executor().unwrap().comms().map(|c| c.rate_bps),
                Some(50_000)
            );
            // A zero rate is refused; the model in force stays.
            assert_eq!(
                send(&mut app, input(7, LanderInput::Comms(Some(comms(0))))),
                Some(LanderRefusal::BadInput { error: 0 })
            );
            assert_eq!(
                app.executor().unwrap().comms().map(|c| c.rate_bps),
                Some(50_000)
            );
            // Six products in two parts: applied when the second arrives.
            let p = |tier, i: u64| LanderProduct {
                size_bytes: 1_000 + i,
                value: 5,
                created_at: MissionTimeUs(i),
                tier,
            };
            let part = |first: u8, total: u8, ps: &[LanderProduct]| {
                input(
                    7,
                    LanderInput::Products {
                        first,
                        total,
                        products: heapless::Vec::from_slice(ps).unwrap(),
                    },
                )
            };
            let six: Vec<_> = (0..6).map(|i| p(i as u8 % 4, i)).collect();
            assert_eq!(send(&mut app, part(0, 6, &six[..4])), None);
            assert!(app.executor().unwrap().onboard().is_empty());
            assert_eq!(send(&mut app, part(4, 6, &six[4..])), None);
            let onboard = app.executor().unwrap().onboard();
            assert_eq!(onboard.len(), 6);
            assert_eq!(onboard[5].size_bytes, 1_005);
            // Bad lists, each refused; the six stay.
            assert_eq!(
                send(&mut app, part(0, 1, &[p(9, 0)])),
                Some(LanderRefusal::BadInput { error: 4 })
            );
            assert_eq!(
                send(&mut app, part(4, 6, &six[4..])),
                Some(LanderRefusal::BadInput { error: 3 })
            );
            assert_eq!(
                send(&mut app, part(0, 65, &six[..4])),
                Some(LanderRefusal::BadInput { error: 1 })
            );
            assert_eq!(app.executor().unwrap().onboard().len(), 6);
            // Another setup's input.
            assert_eq!(
                send(&mut app, input(8, LanderInput::Comms(None))),
                Some(LanderRefusal::NoSetup)
            );
        })
        .unwrap()
        .join()
        .unwrap();
}
