//! The integration tests of `momo-models`, in one test binary (each module was its own
//! binary before 2026-11-28; one binary compiles and links the dependencies' code once).

mod jacobians;
mod kernel;
mod motion;
mod register;
mod rotation;
mod soft;
mod specs;
