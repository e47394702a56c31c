//! Fuzz target: configurations in TOML (see `momo_fuzz::config_toml`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::config_toml(data));
