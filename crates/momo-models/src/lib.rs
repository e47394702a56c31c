//! momo-models
