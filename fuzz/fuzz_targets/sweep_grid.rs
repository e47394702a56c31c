//! Fuzz target: sweep grids in TOML (see `momo_fuzz::sweep_grid`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::sweep_grid(data));
