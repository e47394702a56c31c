//! The integration tests of `momo-costs`, one test binary (each module was its own binary before
//! 2026-11-28: one binary links once, which is most of CI's test build time).

mod losses;
mod metrics;
