//! Fuzz target: KITTI poses (poses.txt) (see `momo_fuzz::kitti_poses`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| momo_fuzz::kitti_poses(data));
