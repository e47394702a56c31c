//! The integration tests of `momo-solvers`, in one test binary (each module was its own
//! binary before 2026-11-28; one binary compiles and links the dependencies' code once).
#![allow(clippy::unwrap_used)] // tests may unwrap (the shared `common` module too)

mod common;
mod core_problem;
mod properties;
mod serde;
mod solvers;
