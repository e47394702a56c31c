//! The integration tests of `momo-io`, one test binary (each module was its own binary before
//! 2026-11-28: one binary links once, which is most of CI's test build time).

mod calib_import;
mod cameras;
mod cross_camera;
mod errors;
mod numpy;
mod regressions;
mod reliability;
mod roundtrip;
