//! libFuzzer wrapper of [`fsw_bridge_fuzz::frame_decoder`]. Run from `fsw-bridge/fuzz/`:
//!     cargo +nightly fuzz run frame_decoder corpus/frame_decoder seeds/frame_decoder
//! (new inputs go to `corpus/`, which is not committed; `seeds/` is).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| fsw_bridge_fuzz::frame_decoder(data));
