//! Fuzz target: PNG and JPEG headers and images (see `momo_fuzz::image_header`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::image_header(data));
