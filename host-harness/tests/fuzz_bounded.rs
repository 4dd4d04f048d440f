//! The fuzz targets of `host-harness/fuzz`, run on stable: each over its seed corpus (the
//! shipped scenario and task-network files) and a fixed number of deterministic mutations
//! (the long campaigns run under cargo-fuzz). Every text comes back as a plan or a Diagnostic.
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
fn tasknet_toml_holds_over_its_seeds_and_300_mutations() {
    let seeds = seeds("tasknet_toml");
    let ran = bounded::run(&seeds, 300, 0x70e1, 16 * 1024, fuzz_logic::tasknet_toml);
    assert_eq!(ran, seeds.len() + 300);
}

#[test]
fn scenario_toml_holds_over_its_seeds_and_300_mutations() {
    let seeds = seeds("scenario_toml");
    let ran = bounded::run(&seeds, 300, 0x5ce7, 16 * 1024, fuzz_logic::scenario_toml);
    assert_eq!(ran, seeds.len() + 300);
}

#[test]
fn the_seeds_are_the_shipped_files_and_they_are_accepted() {
    let mut plans = 0;
    for (name, text) in seeds("scenario_toml") {
        let text = String::from_utf8(text).unwrap();
        let path = fuzz_logic::scenarios_dir().join(&name);
        let scenario = hil::scenario::parse(&text, &path).unwrap();
        if scenario.mission.is_some() {
            hil::mission::plan::MissionPlan::build(scenario).unwrap();
            plans += 1;
        }
    }
    assert!(plans >= 9, "{plans} mission plans among the scenario seeds");
    for (name, text) in seeds("tasknet_toml") {
        let text = String::from_utf8(text).unwrap();
        let compiled = hil::tasknet::compile_str(&text, &name);
        // Regression seeds are inputs a fuzz run found a panic with: refused, not shipped.
        if name.starts_with("regression") {
            assert!(compiled.is_err(), "{name} compiles");
        } else {
            compiled.unwrap();
        }
    }
}
