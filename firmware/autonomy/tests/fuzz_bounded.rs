//! The fuzz targets of `firmware/autonomy/fuzz`, run on stable: each over its seed corpus and a
//! fixed number of deterministic mutations (the long campaigns run under cargo-fuzz). The
//! seeds must reach the deep paths: networks that load and fly, checkpoints that restore.
#[path = "../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod fuzz_logic;

use autonomy::{Autonomy, TaskNetwork, WarmRestartArea};
use fuzz_logic::bounded;
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
fn uplink_holds_over_its_seeds_and_1000_mutations() {
    let seeds = seeds("uplink");
    let ran = bounded::run(&seeds, 1_000, 0x0b11, 8 * 1024, fuzz_logic::uplink);
    assert_eq!(ran, seeds.len() + 1_000);
}

#[test]
fn checkpoint_holds_over_its_seeds_and_800_mutations() {
    let seeds = seeds("checkpoint");
    let ran = bounded::run(&seeds, 800, 0xc4ec, 8 * 1024, fuzz_logic::checkpoint);
    assert_eq!(ran, seeds.len() + 800);
}

#[test]
fn uplink_seeds_hold_valid_networks_and_each_capacity_refusal() {
    let seeds = seeds("uplink");
    let mut valid = 0;
    let mut codes = std::collections::BTreeSet::new();
    for (_, bytes) in &seeds {
        match TaskNetwork::validate_uplink(bytes) {
            Ok(()) => valid += 1,
            Err(e) => {
                codes.insert(format!("{:?}", e.code));
            }
        }
    }
    assert!(
        valid >= 3,
        "{valid} valid networks among the seeds; {REGENERATE}"
    );
    for code in ["TooManyTasks", "TooManyConstraints", "NameTooLong"] {
        assert!(
            codes.contains(code),
            "no seed refused with {code}: {codes:?}"
        );
    }
}

#[test]
fn checkpoint_seeds_restore_with_plans_in_flight() {
    let seeds = seeds("checkpoint");
    let mut with_plans = 0;
    for (name, payload) in &seeds {
        let mut bytes = vec![0u8; 2 * (payload.len() + 64)];
        let mut area = WarmRestartArea::new(&mut bytes);
        area.write(|buf| {
            buf[..payload.len()].copy_from_slice(payload);
            Some(payload.len())
        })
        .unwrap();
        let mut core = Box::new(Autonomy::new());
        if name.starts_with("regression") {
            continue;
        }
        core.restore_from(&area)
            .unwrap_or_else(|e| panic!("seed {name} does not restore ({e:?}); {REGENERATE}"));
        if !core.executive().entries().is_empty() {
            with_plans += 1;
        }
    }
    assert!(with_plans >= 10, "{with_plans} seeds with tasks in flight");
}

#[test]
fn executive_checkpoint_holds_over_its_seeds_and_300_mutations() {
    let seeds = seeds("executive_checkpoint");
    let ran = bounded::run(
        &seeds,
        300,
        0xec4e,
        64 * 1024,
        fuzz_logic::executive_checkpoint,
    );
    assert_eq!(ran, seeds.len() + 300);
}

#[test]
fn planner_checkpoint_holds_over_its_seeds_and_300_mutations() {
    let seeds = seeds("planner_checkpoint");
    let ran = bounded::run(
        &seeds,
        300,
        0x91c4,
        64 * 1024,
        fuzz_logic::planner_checkpoint,
    );
    assert_eq!(ran, seeds.len() + 300);
}

/// The partition sides' seeds are what the flight application wrote: every one restores (a
/// corpus of refused payloads would only exercise the first decode step).
#[test]
fn partition_checkpoint_seeds_restore() {
    type Restores = fn(&[u8]) -> bool;
    let targets: [(&str, Restores); 2] = [
        (
            "executive_checkpoint",
            fuzz_logic::executive_checkpoint_restores,
        ),
        (
            "planner_checkpoint",
            fuzz_logic::planner_checkpoint_restores,
        ),
    ];
    for (target, restores) in targets {
        let seeds = seeds(target);
        let mut restored = 0;
        for (name, payload) in &seeds {
            if name.starts_with("regression") {
                continue;
            }
            assert!(
                restores(payload),
                "{target} seed {name} does not restore; {REGENERATE}"
            );
            restored += 1;
        }
        assert!(restored >= 10, "{restored} {target} seeds");
    }
}
