//! momo-solvers
