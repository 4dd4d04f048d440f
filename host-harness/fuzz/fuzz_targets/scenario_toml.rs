//! libFuzzer wrapper of [`hil_fuzz::scenario_toml`]. Run from `host-harness/fuzz/`:
//!     cargo +nightly fuzz run scenario_toml corpus/scenario_toml seeds/scenario_toml
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| hil_fuzz::scenario_toml(data));
