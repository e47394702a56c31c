//! The integration tests of `momo-solvers`, one test binary (each module was its own binary before
//! 2026-11-28: one binary links once, which is most of CI's test build time).

mod common;
mod core_problem;
mod properties;
mod serde;
mod solvers;
