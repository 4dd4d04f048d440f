//! `hil`: the host harness of the RAD750 proxy. It boots the firmware under qemu-system-ppc (or
//! opens a real serial port), speaks the framed link of `fsw-bridge`, drives scenarios, decodes
//! the target's defmt logs, and reports.
//!
//! The pipeline of a mission: [`scenario`] (the file's schema) -> [`mission::plan`] (resolved
//! against the [`tasknet`]) -> [`mission::driver`] (flown on a [`mission::target`]) ->
//! [`mission::expect`] and [`mission::report`]. Every file error is a [`diag::Diagnostic`];
//! times and durations have one grammar ([`time`]).
//!
//! The binary (`src/main.rs`) only calls [`cli::main`]; the integration tests in `tests/` use
//! the library directly.
pub mod bench;
pub mod bench_kernel;
pub mod bench_missions;
pub mod bench_planner;
pub mod budget;
pub mod campaign;
pub mod cleanup;
pub mod cli;
pub mod defmt_log;
pub mod diag;
pub mod firmware;
pub mod lander;
pub mod lander_emulated;
pub mod link;
pub mod mission;
pub mod options;
pub mod plan;
pub mod plan_emulated;
pub mod progress;
pub mod qemu;
pub mod rover;
pub mod run;
pub mod scenario;
pub mod session;
pub mod shard_env;
pub mod shm;
pub mod study;
pub mod tasknet;
pub mod time;

use std::path::PathBuf;

/// The repository `hil` works in (firmware sources, QEMU profiles, scenarios, run outputs):
/// `HIL_REPO` if set; else the checkout that contains the current directory; else the one that
/// contains the `hil` executable (`target/release/hil` inside a checkout); else the source
/// tree it was built from, if it still exists; else the current directory. So a copied or
/// installed `hil` works inside any checkout, not only the one it was built in.
pub fn repo_root() -> PathBuf {
    if let Some(dir) = std::env::var_os("HIL_REPO") {
        return PathBuf::from(dir);
    }
    let is_checkout = |dir: &std::path::Path| {
        dir.join("firmware/image/Cargo.toml").is_file() && dir.join("qemu").is_dir()
    };
    let enclosing = |start: PathBuf| {
        start
            .ancestors()
            .find(|d| is_checkout(d))
            .map(PathBuf::from)
    };
    let built_in = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(PathBuf::from);
    std::env::current_dir()
        .ok()
        .and_then(enclosing)
        .or_else(|| std::env::current_exe().ok().and_then(enclosing))
        .or_else(|| built_in.filter(|d| is_checkout(d)))
        .unwrap_or_else(|| PathBuf::from("."))
}
