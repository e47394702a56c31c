//! Fuzz target: rig.json (see `momo_fuzz::rig_json`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::rig_json(data));
