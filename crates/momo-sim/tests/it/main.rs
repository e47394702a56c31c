//! The integration tests of `momo-sim`, in one test binary (each module was its own
//! binary before 2026-11-28; one binary compiles and links the dependencies' code once).

mod bound;
mod scenarios;
mod sim;
mod surround;
mod traffic;
