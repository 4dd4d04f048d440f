//! The fuzz targets of `fsw-bridge/fuzz`, run on stable: each over its seed corpus and a fixed
//! number of deterministic mutations (the long campaigns run under cargo-fuzz).
#[path = "../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod fuzz_logic;

use fuzz_logic::bounded;
use std::path::Path;

fn seeds(target: &str) -> Vec<(String, Vec<u8>)> {
    bounded::seeds(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/seeds")
            .join(target),
    )
}

#[test]
fn every_target_has_a_seed_corpus() {
    for (name, _) in fuzz_logic::TARGETS {
        assert!(!seeds(name).is_empty());
    }
}

#[test]
fn frame_decoder_holds_over_its_seeds_and_2000_mutations() {
    let seeds = seeds("frame_decoder");
    let ran = bounded::run(&seeds, 2_000, 0xf4a3e, 600, fuzz_logic::frame_decoder);
    assert_eq!(ran, seeds.len() + 2_000);
}

#[test]
fn frame_decoder_seeds_are_whole_frames_of_both_directions() {
    use fsw_bridge::codec::FrameDecoder;
    use fsw_bridge::{HostToTarget, TargetToHost};
    let (mut host, mut target) = (0, 0);
    for (name, bytes) in seeds("frame_decoder") {
        let mut to_target = FrameDecoder::new();
        let mut to_host = FrameDecoder::new();
        for &b in &bytes {
            if let Some(Ok(_)) = to_target.push::<HostToTarget>(b) {
                host += 1;
            }
            if let Some(Ok(_)) = to_host.push::<TargetToHost>(b) {
                target += 1;
            }
        }
        assert!(
            to_target.counters().frames_ok + to_host.counters().frames_ok > 0,
            "seed {name} decodes in neither direction"
        );
    }
    assert!(
        host >= 6 && target >= 9,
        "every message kind: {host} {target}"
    );
}

#[test]
fn the_mutator_is_deterministic_and_changes_its_input() {
    let corpus: Vec<&[u8]> = vec![b"abcdefgh", b"0123"];
    let run = |seed| {
        let mut m = bounded::Mutator::new(seed);
        (0..50)
            .map(|_| m.mutate(corpus[0], &corpus, 64))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(7), run(7));
    assert_ne!(run(7), run(8));
    assert!(run(7).iter().filter(|m| m.as_slice() != corpus[0]).count() > 40);
    assert!(run(7).iter().all(|m| m.len() <= 64));
}
