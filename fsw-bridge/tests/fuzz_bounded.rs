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
fn frame_decoder_seeds_are_link_frames_of_every_kind_carrying_every_message_kind() {
    use fsw_bridge::codec::{FrameDecoder, WireMessage};
    use fsw_bridge::link::{FrameKind, LinkFrame};
    use fsw_bridge::{HostToTarget, TargetToHost};
    use std::collections::BTreeSet;
    // A message's variant index: postcard writes it first (every index is below 128, one byte).
    fn variant_index(msg: &impl serde::Serialize) -> u8 {
        let mut buf = [0u8; 512];
        postcard::to_slice(msg, &mut buf).expect("a decoded message re-encodes")[0]
    }
    let (mut host, mut target) = (BTreeSet::new(), BTreeSet::new());
    let mut kinds = BTreeSet::new();
    for (name, bytes) in seeds("frame_decoder") {
        let mut to_target = FrameDecoder::new();
        let mut to_host = FrameDecoder::new();
        for &b in &bytes {
            if let Some(Ok(frame)) = to_target.push::<LinkFrame<HostToTarget>>(b) {
                kinds.insert(frame.kind());
                if let LinkFrame::Ad { msg, .. } | LinkFrame::Bd(msg) = frame {
                    host.insert(variant_index(&msg));
                }
            }
            if let Some(Ok(frame)) = to_host.push::<LinkFrame<TargetToHost>>(b) {
                kinds.insert(frame.kind());
                if let LinkFrame::Ad { msg, .. } | LinkFrame::Bd(msg) = frame {
                    target.insert(variant_index(&msg));
                }
            }
        }
        assert!(
            to_target.counters().frames_ok + to_host.counters().frames_ok > 0,
            "seed {name} decodes as link frames in neither direction"
        );
    }
    assert_eq!(
        host.len(),
        usize::from(HostToTarget::VARIANT_COUNT),
        "every host message kind"
    );
    assert_eq!(
        target.len(),
        usize::from(TargetToHost::VARIANT_COUNT),
        "every target message kind"
    );
    let all = [
        FrameKind::Ad,
        FrameKind::Bd,
        FrameKind::Bc,
        FrameKind::Report,
        FrameKind::RoundEnd,
    ];
    assert_eq!(kinds, all.into_iter().collect(), "every link frame kind");
}

#[test]
fn link_endpoint_holds_over_its_seeds_and_1500_mutations() {
    let seeds = seeds("link_endpoint");
    let ran = bounded::run(&seeds, 1_500, 0x11c0, 4 * 1024, fuzz_logic::link_endpoint);
    assert_eq!(ran, seeds.len() + 1_500);
}

#[test]
fn link_endpoint_seeds_talk_with_a_peer_in_both_roles_on_both_channels() {
    let (mut target_role, mut host_role) = ([0u32; 2], [0u32; 2]);
    for (name, bytes) in seeds("link_endpoint") {
        let run = fuzz_logic::run_link_script(&bytes);
        assert!(run.bursts > 0, "seed {name} never answers");
        let sum = if bytes[0] % 2 == 0 {
            &mut target_role
        } else {
            &mut host_role
        };
        for (s, d) in sum.iter_mut().zip(run.delivered) {
            *s += d;
        }
    }
    assert!(
        target_role.iter().chain(&host_role).all(|&d| d > 0),
        "deliveries per VC, as the target {target_role:?}, as the host {host_role:?}"
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
