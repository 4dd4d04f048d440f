//! The fuzz targets of `firmware/flight-app/fuzz`, run on stable: each over its seed corpus and
//! a fixed number of deterministic mutations (the long campaigns run under cargo-fuzz). The
//! seeds must reach the deep paths: uplinks that load, frames that fly, resets that restore,
//! and every verdict of the security checks.
#[path = "../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod fuzz_logic;

use fsw_bridge::{HostToTarget, SecurityRefusal};
use fuzz_logic::{bounded, decode_ops, Harness, Op};
use std::path::Path;

fn seeds(target: &str) -> Vec<(String, Vec<u8>)> {
    bounded::seeds(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/seeds")
            .join(target),
    )
}

const REGENERATE: &str =
    "regenerate the seeds: cargo run --manifest-path host-harness/fuzz/Cargo.toml --example seeds";

#[test]
fn every_target_has_a_seed_corpus() {
    for (name, _) in fuzz_logic::TARGETS {
        assert!(!seeds(name).is_empty());
    }
}

#[test]
fn messages_hold_over_their_seeds_and_300_mutations() {
    let seeds = seeds("messages");
    let ran = bounded::run(&seeds, 300, 0x3e55, 16 * 1024, fuzz_logic::messages);
    assert_eq!(ran, seeds.len() + 300);
}

#[test]
fn uplink_chunks_hold_over_their_seeds_and_600_mutations() {
    let seeds = seeds("uplink_chunks");
    let ran = bounded::run(&seeds, 600, 0xc4c4, 8 * 1024, fuzz_logic::uplink_chunks);
    assert_eq!(ran, seeds.len() + 600);
}

#[test]
fn rover_checkpoints_hold_over_their_seeds_and_300_mutations() {
    let seeds = seeds("rover_checkpoint");
    // Every seed is a mission a reset left: each is taken up (and round-trips).
    for (name, data) in &seeds {
        assert!(
            fuzz_logic::rover_checkpoint_restores(data),
            "{name}: not taken up; {REGENERATE}"
        );
    }
    let ran = bounded::run(&seeds, 300, 0x7e57, 64 * 1024, fuzz_logic::rover_checkpoint);
    assert_eq!(ran, seeds.len() + 300);
}

#[test]
fn message_seeds_load_networks_fly_frames_and_restore_after_resets() {
    let (mut loaded, mut frames, mut resets) = (0, 0, 0);
    for (_, bytes) in seeds("messages") {
        let ops = decode_ops(&bytes);
        let mut h = Harness::new();
        for op in &ops {
            h.apply(op);
            match op {
                Op::Message(HostToTarget::TimeGrant { .. }) => frames += 1,
                Op::WarmReset | Op::PowerCycle => resets += 1,
                _ => {}
            }
        }
        if !h.app().network().tasks().is_empty() {
            loaded += 1;
        }
    }
    assert!(loaded >= 10, "{loaded} seeds load a network; {REGENERATE}");
    assert!(
        frames >= 200 && resets >= 5,
        "{frames} frames, {resets} resets"
    );
}

#[test]
fn chunk_seeds_deliver_whole_networks() {
    let mut acknowledged = 0;
    for (_, bytes) in seeds("uplink_chunks") {
        let ops = fuzz_logic::chunk_ops(&bytes);
        let total = ops
            .iter()
            .find_map(|op| match op {
                Op::Message(HostToTarget::UplinkChunk { total, .. }) => Some(*total),
                _ => None,
            })
            .unwrap();
        let mut h = Harness::new();
        for op in &ops {
            h.apply(op);
        }
        if !h.app().network().tasks().is_empty() && total > 1 {
            acknowledged += 1;
        }
    }
    assert!(
        acknowledged >= 3,
        "{acknowledged} seeds load a network; {REGENERATE}"
    );
}

#[test]
fn message_seeds_reach_every_security_verdict_the_harness_can_produce() {
    let mut total = fuzz_logic::Verdicts::default();
    for (_, bytes) in seeds("messages") {
        let mut h = Harness::new();
        for op in &decode_ops(&bytes) {
            h.apply(op);
        }
        let v = h.verdicts();
        for (sum, n) in total.security_refusals.iter_mut().zip(v.security_refusals) {
            *sum += n;
        }
        total.invalid += v.invalid;
        total.busy += v.busy;
        total.loaded += v.loaded;
        total.commands += v.commands;
        total.commands_not_carried_out += v.commands_not_carried_out;
    }
    // The harness always provisions its key, so NoKey cannot happen (flight-app's own tests
    // cover a board without one).
    for reason in SecurityRefusal::ALL {
        let n = total.security_refusals[reason.index()];
        if reason == SecurityRefusal::NoKey {
            assert_eq!(n, 0);
        } else {
            assert!(
                n > 0,
                "no seed is refused as {reason:?}: {total:?}; {REGENERATE}"
            );
        }
    }
    assert!(total.loaded >= 10, "{total:?}; {REGENERATE}");
    assert!(
        total.invalid > 0 && total.busy > 0,
        "authentic uplinks refused by validation and as busy: {total:?}"
    );
    assert!(
        total.commands > 0 && total.commands_not_carried_out > 0,
        "{total:?}"
    );
}

#[test]
fn an_unsecured_or_altered_chunked_uplink_is_refused_before_validation() {
    // The flyby as the chunk seeds carry it, sent unsecured and with one bit flipped: both
    // refused by the security checks (and the same bytes secured load, see above).
    let (_, whole) = seeds("uplink_chunks")
        .into_iter()
        .find(|(n, _)| n == "flyby-127.chunks")
        .expect("the flyby chunk seed");
    let mut unsecured = whole.clone();
    unsecured[2] |= fuzz_logic::RAW_IMAGE;
    let mut flipped = whole.clone();
    flipped.extend([8, 5]);
    for input in [unsecured, flipped] {
        let mut h = Harness::new();
        for op in &fuzz_logic::chunk_ops(&input) {
            h.apply(op);
        }
        assert_eq!(h.verdicts().loaded, 0);
        assert_eq!(
            h.verdicts().security_refusals.iter().sum::<u64>(),
            1,
            "{:?}",
            h.verdicts()
        );
        assert!(h.app().network().tasks().is_empty());
    }
}

/// What a harness ended with: the verdicts, the model's counter and holds, the application's
/// whole plan and execution state and its memories.
fn outcome(h: &Harness) -> impl PartialEq + std::fmt::Debug {
    let mut state = vec![0u8; 256 * 1024];
    let len = h.app().encode_state(&mut state).unwrap();
    state.truncate(len);
    (
        h.verdicts().clone(),
        (h.security().last_sequence, h.security().holds),
        state,
        h.warm_checkpoint().map(<[u8]>::to_vec),
    )
}

#[test]
fn a_harness_powered_on_again_runs_every_seed_as_a_new_one_does() {
    // The targets reuse one harness (`Harness::power_on` between inputs): after any earlier
    // input, the next must run exactly as on a new harness.
    let mut seeds = seeds("messages");
    seeds.extend(self::seeds("uplink_chunks"));
    let ops_of = |name: &str, bytes: &[u8]| {
        if name.ends_with(".chunks") {
            fuzz_logic::chunk_ops(bytes)
        } else {
            decode_ops(bytes)
        }
    };
    let mut reused = Harness::new();
    let mut compared = 0;
    for (i, (name, bytes)) in seeds.iter().enumerate() {
        // The reused harness first runs the previous seed, so it carries a network, a plan,
        // checkpoints, a spent counter and holds into the power-on.
        let (prev_name, prev) = &seeds[(i + seeds.len() - 1) % seeds.len()];
        for op in &ops_of(prev_name, prev) {
            reused.apply(op);
        }
        reused.power_on();
        let mut new = Harness::new();
        for op in &ops_of(name, bytes) {
            reused.apply(op);
            new.apply(op);
        }
        assert_eq!(outcome(&reused), outcome(&new), "{name} after {prev_name}");
        compared += 1;
    }
    assert!(compared >= 20, "{compared} seeds");
}
