//! `hil`: the host harness of the RAD750 proxy. It boots the firmware under qemu-system-ppc (or
//! opens a real serial port), speaks the framed link of `fsw-bridge`, drives scenarios, decodes
//! the target's defmt logs, and reports.
//!
//! The binary (`src/main.rs`) is a thin clap front end over this library; the integration tests
//! in `tests/` use the library directly.
pub mod bench;
pub mod bench_kernel;
pub mod bench_missions;
pub mod budget;
pub mod campaign;
pub mod defmt_log;
pub mod firmware;
pub mod link;
pub mod mission;
pub mod qemu;
pub mod run;
pub mod scenario;
pub mod session;
pub mod shm;
pub mod tasknet;

use std::path::PathBuf;

/// The repository this `hil` was built from (firmware sources, QEMU profiles, scenarios).
/// `HIL_REPO` overrides it.
pub fn repo_root() -> PathBuf {
    if let Some(dir) = std::env::var_os("HIL_REPO") {
        return PathBuf::from(dir);
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("."))
}
