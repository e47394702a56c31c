//! momo-costs
