//! The integration tests of `momo-match`, one test binary (each module was its own binary before
//! 2026-11-28: one binary links once, which is most of CI's test build time).

mod matching;
mod refine;
