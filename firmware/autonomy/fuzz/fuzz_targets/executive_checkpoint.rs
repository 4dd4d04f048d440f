//! libFuzzer wrapper of [`autonomy_fuzz::executive_checkpoint`]. Run from `firmware/autonomy/fuzz/`:
//!     cargo +nightly fuzz run executive_checkpoint corpus/executive_checkpoint seeds/executive_checkpoint
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| autonomy_fuzz::executive_checkpoint(data));
