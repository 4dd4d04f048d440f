//! The deterministic fault functions and the lossy channel built on them: same inputs, same
//! faults; another attempt, an independent decision; the rates as asked; RoundEnd and Hello
//! never touched; delay, duplication and drop as documented.
mod common;

use common::link_sim::{hello, is_hello};
use fsw_bridge::codec::{encode, FrameDecoder, MAX_FRAME_LEN};
use fsw_bridge::link::channel::LossyChannel;
use fsw_bridge::link::faults::{
    byte_fault, corrupt_frame, frame_fate, Direction, FaultKey, FaultRates, FrameFate,
    FrameIdentity, PPM,
};
use fsw_bridge::link::{LinkFrame, LinkReport, VirtualChannel};
use fsw_bridge::{HostToTarget, TargetToHost};
use proptest::prelude::*;

fn identities() -> impl Strategy<Value = FrameIdentity> {
    let vc = prop_oneof![
        Just(VirtualChannel::Mission),
        Just(VirtualChannel::Instrument)
    ];
    prop_oneof![
        (vc.clone(), any::<u8>()).prop_map(|(vc, ns)| FrameIdentity::Ad { vc, ns }),
        (any::<u32>(), any::<u16>()).prop_map(|(round, index)| FrameIdentity::Bd { round, index }),
        (any::<u32>(), vc, any::<bool>()).prop_map(|(round, vc, set_vr)| FrameIdentity::Bc {
            round,
            vc,
            set_vr
        }),
        (any::<u32>(), any::<u16>())
            .prop_map(|(round, copy)| FrameIdentity::Report { round, copy }),
    ]
}

fn directions() -> impl Strategy<Value = Direction> {
    prop_oneof![Just(Direction::Uplink), Just(Direction::Downlink)]
}

fn keys() -> impl Strategy<Value = FaultKey> {
    (any::<u64>(), directions(), identities(), 0u32..64).prop_map(
        |(seed, direction, frame, attempt)| FaultKey {
            seed,
            direction,
            frame,
            attempt,
        },
    )
}

fn rates() -> impl Strategy<Value = FaultRates> {
    (0..=PPM, 0..=PPM / 3, 0..=PPM / 3, 0..=PPM / 3).prop_map(|(c, d, u, l)| FaultRates {
        corrupt_byte_ppm: c,
        drop_ppm: d,
        duplicate_ppm: u,
        delay_ppm: l,
    })
}

const HALF: FaultRates = FaultRates {
    corrupt_byte_ppm: PPM / 2,
    drop_ppm: PPM / 2,
    duplicate_ppm: 0,
    delay_ppm: 0,
};

fn key(seed: u64, ns: u8, attempt: u32) -> FaultKey {
    FaultKey {
        seed,
        direction: Direction::Uplink,
        frame: FrameIdentity::Ad {
            vc: VirtualChannel::Mission,
            ns,
        },
        attempt,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn the_decisions_are_a_pure_function_of_their_inputs(
        rates in rates(),
        key in keys(),
        bytes in proptest::collection::vec(1u8..=255, 2..100),
    ) {
        prop_assert_eq!(frame_fate(&rates, &key), frame_fate(&rates, &key));
        for i in 0..bytes.len() {
            prop_assert_eq!(byte_fault(&rates, &key, i), byte_fault(&rates, &key, i));
        }
        let (mut a, mut b) = (bytes.clone(), bytes.clone());
        prop_assert_eq!(corrupt_frame(&rates, &key, &mut a), corrupt_frame(&rates, &key, &mut b));
        prop_assert_eq!(&a, &b);
        // Only the bytes between the delimiters change, one bit each.
        prop_assert_eq!(a[0], bytes[0]);
        prop_assert_eq!(a[a.len() - 1], bytes[bytes.len() - 1]);
        for (x, y) in a.iter().zip(&bytes) {
            prop_assert!((x ^ y).count_ones() <= 1);
        }
    }

    /// Two channels with the same seed, given the same bursts, deliver the same bytes.
    #[test]
    fn the_lossy_channel_is_deterministic(
        seed in any::<u64>(),
        seqs in proptest::collection::vec(any::<u32>(), 1..20),
    ) {
        let rates = FaultRates::from_probabilities(0.05, 0.1, 0.1, 0.1);
        let burst: Vec<Vec<u8>> = seqs
            .iter()
            .enumerate()
            .map(|(i, &seq)| common::frame(&LinkFrame::Ad {
                vc: VirtualChannel::Mission,
                ns: i as u8,
                msg: HostToTarget::Ping { seq },
            }))
            .chain([common::frame(&LinkFrame::<()>::RoundEnd { round: 1 })])
            .collect();
        let mut a = LossyChannel::new(seed, rates);
        let mut b = LossyChannel::new(seed, rates);
        for round in 1..4 {
            prop_assert_eq!(
                a.carry::<HostToTarget>(Direction::Uplink, round, &burst, |_| false),
                b.carry::<HostToTarget>(Direction::Uplink, round, &burst, |_| false)
            );
        }
    }
}

#[test]
fn another_attempt_gets_an_independent_decision() {
    // Over 20000 frames at 50 % loss: attempts 0 and 1 both lost about a quarter of the time
    // (independent), not half (the same fate) or never (anti-correlated).
    let (mut first, mut both, mut second_only) = (0, 0, 0);
    for seed in 0..20_000u64 {
        let k0 = key(seed, (seed % 256) as u8, 0);
        let k1 = FaultKey { attempt: 1, ..k0 };
        let lost0 = frame_fate(&HALF, &k0) == FrameFate::Drop;
        let lost1 = frame_fate(&HALF, &k1) == FrameFate::Drop;
        first += lost0 as u32;
        both += (lost0 && lost1) as u32;
        second_only += (!lost0 && lost1) as u32;
    }
    assert!((9_500..10_500).contains(&first), "{first}");
    assert!((4_600..5_400).contains(&both), "{both}");
    assert!((4_600..5_400).contains(&second_only), "{second_only}");

    // The same for which bytes are corrupted: attempt 1's pattern differs from attempt 0's.
    let mut same_pattern = 0;
    for seed in 0..1_000u64 {
        let pattern = |attempt| {
            (0..32)
                .map(|i| byte_fault(&HALF, &key(seed, 3, attempt), i).is_some())
                .collect::<Vec<_>>()
        };
        same_pattern += (pattern(0) == pattern(1)) as u32;
    }
    assert_eq!(
        same_pattern, 0,
        "32 fair coin flips agreeing by chance: 2^-32"
    );
}

#[test]
fn seed_direction_identity_and_byte_index_all_change_the_decision() {
    let base = key(42, 7, 0);
    let variants = [
        FaultKey { seed: 43, ..base },
        FaultKey {
            direction: Direction::Downlink,
            ..base
        },
        FaultKey {
            frame: FrameIdentity::Ad {
                vc: VirtualChannel::Instrument,
                ns: 7,
            },
            ..base
        },
        FaultKey {
            frame: FrameIdentity::Ad {
                vc: VirtualChannel::Mission,
                ns: 8,
            },
            ..base
        },
    ];
    let pattern = |k: &FaultKey| {
        (0..64)
            .map(|i| byte_fault(&HALF, k, i).is_some())
            .collect::<Vec<_>>()
    };
    for v in &variants {
        assert_ne!(pattern(v), pattern(&base), "{v:?}");
    }
}

#[test]
fn the_rates_are_the_fractions_injected() {
    let rates = FaultRates::from_probabilities(0.01, 0.10, 0.05, 0.02);
    assert_eq!(
        rates,
        FaultRates {
            corrupt_byte_ppm: 10_000,
            drop_ppm: 100_000,
            duplicate_ppm: 50_000,
            delay_ppm: 20_000
        }
    );
    let n = 200_000u32;
    let mut counts = [0u32; 4];
    let mut corrupted = 0u32;
    for i in 0..n {
        let k = FaultKey {
            seed: 9,
            direction: Direction::Downlink,
            frame: FrameIdentity::Report { round: i, copy: 0 },
            attempt: 0,
        };
        counts[match frame_fate(&rates, &k) {
            FrameFate::Deliver => 0,
            FrameFate::Drop => 1,
            FrameFate::Duplicate => 2,
            FrameFate::Delay => 3,
        }] += 1;
        corrupted += byte_fault(&rates, &k, 5).is_some() as u32;
    }
    let near = |count: u32, ppm: u32| {
        let expected = f64::from(n) * f64::from(ppm) / f64::from(PPM);
        (f64::from(count) - expected).abs() < 5.0 * expected.sqrt() + 1.0
    };
    assert!(near(counts[1], 100_000), "{counts:?}");
    assert!(near(counts[2], 50_000), "{counts:?}");
    assert!(near(counts[3], 20_000), "{counts:?}");
    assert!(near(corrupted, 10_000), "{corrupted}");
    assert!(!FaultRates::from_probabilities(0.0, 0.5, 0.5, 0.1).is_valid());
    assert!(!FaultRates::NONE.any());
}

#[test]
fn round_end_and_hello_are_never_damaged() {
    // Every other frame is dropped or corrupted in every byte.
    let all_lost = FaultRates {
        corrupt_byte_ppm: PPM,
        drop_ppm: PPM,
        duplicate_ppm: 0,
        delay_ppm: 0,
    };
    let round_end = FrameIdentity::RoundEnd { round: 3 };
    let k = FaultKey {
        seed: 1,
        direction: Direction::Downlink,
        frame: round_end,
        attempt: 0,
    };
    assert_eq!(frame_fate(&all_lost, &k), FrameFate::Deliver);
    assert_eq!(byte_fault(&all_lost, &k, 1), None);

    let burst: Vec<Vec<u8>> = vec![
        common::frame(&LinkFrame::Bd(hello())),
        common::frame(&LinkFrame::Bd(TargetToHost::Pong {
            seq: 1,
            link: Default::default(),
        })),
        common::frame(&LinkFrame::<()>::Report(LinkReport::default())),
        common::frame(&LinkFrame::<()>::RoundEnd { round: 3 }),
    ];
    let mut channel = LossyChannel::new(1, all_lost);
    let out = channel.carry::<TargetToHost>(Direction::Downlink, 3, &burst, is_hello);
    assert_eq!(out, vec![burst[0].clone(), burst[3].clone()]);
    assert_eq!(channel.injected(Direction::Downlink).dropped, 2);
}

#[test]
fn a_corrupted_frame_is_rejected_never_misread() {
    let rates = FaultRates::from_probabilities(0.05, 0.0, 0.0, 0.0);
    let msg = LinkFrame::Ad {
        vc: VirtualChannel::Mission,
        ns: 9,
        msg: HostToTarget::Ping { seq: 77 },
    };
    let mut clean = [0u8; MAX_FRAME_LEN];
    let len = encode(&msg, &mut clean).unwrap();
    let mut damaged_seen = 0;
    for attempt in 0..2_000 {
        let mut bytes = clean[..len].to_vec();
        let k = key(5, 9, attempt);
        if corrupt_frame(&rates, &k, &mut bytes) == 0 {
            continue;
        }
        damaged_seen += 1;
        let mut decoder = FrameDecoder::new();
        for &b in &bytes {
            if let Some(result) = decoder.push::<LinkFrame<HostToTarget>>(b) {
                assert!(result.is_err(), "a damaged frame decoded: {result:?}");
            }
        }
    }
    assert!(damaged_seen > 500);
}

#[test]
fn delayed_frames_come_first_in_the_next_burst_and_duplicates_twice() {
    let frames: Vec<Vec<u8>> = (0..200u8)
        .map(|ns| {
            common::frame(&LinkFrame::Ad {
                vc: VirtualChannel::Mission,
                ns,
                msg: HostToTarget::Ping { seq: 0 },
            })
        })
        .collect();
    let end = |round| common::frame(&LinkFrame::<()>::RoundEnd { round });
    let mut burst1 = frames[..100].to_vec();
    burst1.push(end(1));
    let mut burst2 = frames[100..].to_vec();
    burst2.push(end(2));
    let rates = FaultRates::from_probabilities(0.0, 0.0, 0.2, 0.2);
    let mut channel = LossyChannel::new(77, rates);
    let out1 = channel.carry::<HostToTarget>(Direction::Uplink, 1, &burst1, |_| false);
    let after1 = *channel.injected(Direction::Uplink);
    assert!(after1.delayed > 5 && after1.duplicated > 5, "{after1:?}");
    assert_eq!(out1.last(), Some(&end(1)), "RoundEnd stays last");
    assert_eq!(
        out1.len() as u64,
        101 - after1.delayed + after1.duplicated,
        "each frame once, duplicates twice, delayed ones not yet"
    );
    // In order, each frame of burst 1 is either there (once or twice in a row) or held back.
    let mut held_back = Vec::new();
    let mut rest = &out1[..];
    for f in &burst1[..100] {
        match rest {
            [a, b, tail @ ..] if a == f && b == f => rest = tail,
            [a, tail @ ..] if a == f => rest = tail,
            _ => held_back.push(f.clone()),
        }
    }
    assert_eq!(held_back.len() as u64, after1.delayed);
    let out2 = channel.carry::<HostToTarget>(Direction::Uplink, 2, &burst2, |_| false);
    assert_eq!(
        out2[..held_back.len()],
        held_back[..],
        "held-back frames open the next burst, in order"
    );
    assert_eq!(out2.last(), Some(&end(2)));
}
