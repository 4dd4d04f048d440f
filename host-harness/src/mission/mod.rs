//! Missions: a task network run against the simulated spacecraft on a target (the emulated
//! RAD750 proxy or the native build), frame by frame under the host's lockstep time driver, with
//! resets and faults injected at exact mission times, and expectations checked at the end.
pub mod driver;
pub mod expect;
pub mod gantt;
pub mod record;
pub mod report;
pub mod rng;
pub mod sim;
pub mod spec;
pub mod target;
pub mod time;

use std::path::Path;

use autonomy::TaskNetwork;
use fsw_bridge::StateKey;
use serde::Deserialize;

/// A compiled task network with the names the scenario may use.
pub struct CompiledNetwork {
    pub network: TaskNetwork,
    pub uplink: Vec<u8>,
    /// Timeline name, state key, value names (state timelines only).
    pub timelines: Vec<(String, Option<StateKey>, Vec<String>)>,
}

#[derive(Deserialize)]
struct NamesOnly {
    #[serde(default)]
    timeline: Vec<TimelineNames>,
}

#[derive(Deserialize)]
struct TimelineNames {
    name: String,
    #[serde(default)]
    values: Vec<String>,
    state_key: Option<u16>,
}

impl CompiledNetwork {
    /// Compile a task-network TOML file (errors as `file:line:column: field: message`).
    pub fn compile(path: &Path) -> Result<Self, String> {
        let (network, uplink) = crate::tasknet::compile_file(path).map_err(|e| e.to_string())?;
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let names: NamesOnly =
            toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(Self {
            network,
            uplink,
            timelines: names
                .timeline
                .into_iter()
                .map(|t| (t.name, t.state_key.map(StateKey), t.values))
                .collect(),
        })
    }

    /// State key and value names of a timeline.
    pub fn timeline(&self, name: &str) -> Option<(Option<StateKey>, &[String])> {
        self.timelines
            .iter()
            .find(|t| t.0 == name)
            .map(|t| (t.1, t.2.as_slice()))
    }
}

impl sim::NetworkNames for CompiledNetwork {
    fn timeline(&self, name: &str) -> Option<(StateKey, Vec<String>)> {
        let (key, values) = CompiledNetwork::timeline(self, name)?;
        Some((key?, values.to_vec()))
    }
}
