//! Fuzz target: the estimator (momo and the 5-point baseline) fed arbitrary finite and
//! non-finite matches and arc lengths through `momo_vo::MotionDriver` (see
//! `momo_fuzz::estimator`).
#![no_main]

libfuzzer_sys::fuzz_target!(|input: momo_fuzz::EstimatorInput| momo_fuzz::estimator(&input));
