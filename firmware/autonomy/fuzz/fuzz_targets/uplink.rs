//! libFuzzer wrapper of [`autonomy_fuzz::uplink`]. Run from `firmware/autonomy/fuzz/`:
//!     cargo +nightly fuzz run uplink corpus/uplink seeds/uplink
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| autonomy_fuzz::uplink(data));
