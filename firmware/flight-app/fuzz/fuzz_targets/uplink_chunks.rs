//! libFuzzer wrapper of [`flight_app_fuzz::uplink_chunks`]. Run from `firmware/flight-app/fuzz/`:
//!     cargo +nightly fuzz run uplink_chunks corpus/uplink_chunks seeds/uplink_chunks
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| flight_app_fuzz::uplink_chunks(data));
