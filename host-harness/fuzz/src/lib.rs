//! Fuzz target logic for the host harness's file formats, in plain functions shared by the
//! libFuzzer wrappers (`fuzz_targets/`) and the bounded run on stable
//! (`host-harness/tests/fuzz_bounded.rs`). A file `hil` reads must come back as a plan or as a
//! `Diagnostic`, never as a panic.
//!
//! * [`tasknet_toml`]: any text as a task network. A network that compiles has an uplink the
//!   target's validator accepts and that decodes to the compiled network; an error renders.
//! * [`scenario_toml`]: any text as a scenario file, parsed and, for a mission, resolved
//!   against its task network into a mission plan. The network is always one of the shipped
//!   ones (the file name the scenario gives, if shipped, else the flyby), and a `link.key_file`
//!   is always one that does not exist (its error path is still taken), so a fuzzed path never
//!   makes the harness read an arbitrary file.
//!
//! Seeds are in `seeds/<target>/`: the shipped scenarios and task networks. `examples/seeds.rs`
//! writes every fuzz crate's seed corpora.
use std::path::{Path, PathBuf};

use hil::mission::plan::MissionPlan;

#[path = "../../../fsw-bridge/fuzz/src/bounded.rs"]
pub mod bounded;

/// The targets of this crate, by name.
pub const TARGETS: &[bounded::Target] = &[
    ("tasknet_toml", tasknet_toml),
    ("scenario_toml", scenario_toml),
];

/// Any text as a task network.
pub fn tasknet_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match hil::tasknet::compile_str(text, "fuzz.toml") {
        Err(diagnostic) => {
            assert!(!diagnostic.render().is_empty());
        }
        Ok(net) => {
            autonomy::TaskNetwork::validate_uplink(&net.uplink)
                .expect("a compiled network's uplink validates");
            let mut back = autonomy::TaskNetwork::EMPTY;
            autonomy::uplink::decode_into(&mut back, &net.uplink).expect("decodes");
            assert_eq!(back, net.network, "the uplink is the compiled network");
        }
    }
}

/// The shipped scenarios' folder (scenario paths and task networks are relative to it).
pub fn scenarios_dir() -> PathBuf {
    hil::repo_root().join("scenarios")
}

/// Any text as a scenario file.
pub fn scenario_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = scenarios_dir().join("fuzz.toml");
    let mut scenario = match hil::scenario::parse(text, &path) {
        Err(diagnostic) => {
            assert!(!diagnostic.render().is_empty());
            return;
        }
        Ok(s) => s,
    };
    if let Some(file) = scenario.file.link.key_file.as_mut() {
        *file = NO_KEY_FILE.into();
    }
    let Some(mission) = scenario.file.mission.as_mut() else {
        return;
    };
    mission.tasknet = shipped_tasknet(&mission.tasknet);
    match MissionPlan::build(scenario) {
        Err(diagnostic) => {
            assert!(!diagnostic.render().is_empty());
        }
        Ok(plan) => {
            assert!(plan.start < plan.end);
            let resets = plan.reset_times();
            assert!(resets.iter().all(|t| plan.start <= *t && *t <= plan.end));
        }
    }
}

/// What a fuzzed `link.key_file` is replaced with: a file that is not there.
const NO_KEY_FILE: &str = "fuzz-no-such-key-file.key";

/// `tasknets/<name>` when the file name of `tasknet` is a shipped task network, else the
/// flyby's.
fn shipped_tasknet(tasknet: &str) -> String {
    let dir = scenarios_dir().join("tasknets");
    let name = Path::new(tasknet)
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| n.ends_with(".toml") && dir.join(n).is_file())
        .unwrap_or("flyby.toml");
    format!("tasknets/{name}")
}
