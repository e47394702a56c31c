//! The integration tests of `momo-io`, in one test binary (each module was its own
//! binary before 2026-11-28; one binary compiles and links the dependencies' code once).

mod calib_import;
mod cameras;
mod cross_camera;
mod errors;
mod numpy;
mod regressions;
mod reliability;
mod roundtrip;
