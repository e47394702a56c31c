//! Fuzz target: configurations in JSON (see `momo_fuzz::config_json`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::config_json(data));
