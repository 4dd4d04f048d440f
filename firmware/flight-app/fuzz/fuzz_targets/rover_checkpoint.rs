//! libFuzzer wrapper of [`flight_app_fuzz::rover_checkpoint`]. Run from `firmware/flight-app/fuzz/`:
//!     cargo +nightly fuzz run rover_checkpoint corpus/rover_checkpoint seeds/rover_checkpoint
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| flight_app_fuzz::rover_checkpoint(data));
