//! libFuzzer wrapper of [`hil_fuzz::tasknet_toml`]. Run from `host-harness/fuzz/`:
//!     cargo +nightly fuzz run tasknet_toml corpus/tasknet_toml seeds/tasknet_toml
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| hil_fuzz::tasknet_toml(data));
