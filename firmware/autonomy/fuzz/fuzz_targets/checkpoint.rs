//! libFuzzer wrapper of [`autonomy_fuzz::checkpoint`]. Run from `firmware/autonomy/fuzz/`:
//!     cargo +nightly fuzz run checkpoint corpus/checkpoint seeds/checkpoint
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| autonomy_fuzz::checkpoint(data));
