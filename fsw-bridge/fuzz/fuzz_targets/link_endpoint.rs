//! libFuzzer wrapper of [`fsw_bridge_fuzz::link_endpoint`] (the script format is documented
//! there). Run from `fsw-bridge/fuzz/`:
//!     cargo +nightly fuzz run link_endpoint corpus/link_endpoint seeds/link_endpoint
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| fsw_bridge_fuzz::link_endpoint(data));
