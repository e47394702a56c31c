//! The non-robust loss, kept in core because checks and tests need it.

use crate::loss::RobustLoss;
use serde::{Deserialize, Serialize};

/// `ρ(s) = s`: plain least squares.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrivialLoss;

#[typetag::serde(name = "trivial")]
impl RobustLoss for TrivialLoss {
    fn evaluate(&self, s: f64) -> [f64; 3] {
        [s, 1.0, 0.0]
    }
    fn scale(&self) -> f64 {
        f64::INFINITY
    }
}
