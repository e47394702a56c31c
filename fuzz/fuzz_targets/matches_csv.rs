//! Fuzz target: matches.csv (see `momo_fuzz::matches_csv`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::matches_csv(data));
