//! libFuzzer wrapper of [`flight_app_fuzz::messages`]. Run from `firmware/flight-app/fuzz/`:
//!     cargo +nightly fuzz run messages corpus/messages seeds/messages
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| flight_app_fuzz::messages(data));
