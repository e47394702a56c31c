//! The integration tests of `momo-vo`, in one test binary (each module was its own
//! binary before 2026-11-28; one binary compiles and links the dependencies' code once).

mod calibrate;
mod candidates;
mod degenerate;
mod final_fit;
mod fuzz_regressions;
mod hostile;
mod hypotheses;
mod noise;
mod priors;
mod slow_pull;
mod soft_sigma;
mod stereo_scale;
mod support;
mod trust;
mod trust_speed;
