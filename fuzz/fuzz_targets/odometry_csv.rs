//! Fuzz target: odometry.csv (see `momo_fuzz::odometry_csv`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::odometry_csv(data));
