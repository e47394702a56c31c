//! The integration tests of `momo-vo`, one test binary (each module was its own binary before
//! 2026-11-28: one binary links once, which is most of CI's test build time).

mod support;
mod calibrate;
mod degenerate;
mod final_fit;
mod fuzz_regressions;
mod hostile;
mod hypotheses;
mod priors;
mod soft_sigma;
mod stereo_scale;
mod trust;
mod trust_speed;
