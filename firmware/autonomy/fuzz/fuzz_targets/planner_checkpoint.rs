//! libFuzzer wrapper of [`autonomy_fuzz::planner_checkpoint`]. Run from `firmware/autonomy/fuzz/`:
//!     cargo +nightly fuzz run planner_checkpoint corpus/planner_checkpoint seeds/planner_checkpoint
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| autonomy_fuzz::planner_checkpoint(data));
