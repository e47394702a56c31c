//! Robust losses on the squared residual (Ceres convention).

use std::fmt::Debug;

/// A robust loss `ρ(s)` on the squared residual norm `s = |r|²` of one match, Ceres style.
///
/// Serialisable as a tagged trait object: `{"type": "cauchy", "scale": 0.0065}` in JSON,
/// `type = "cauchy"` / `scale = 0.0065` in TOML.
#[typetag::serde(tag = "type")]
pub trait RobustLoss: Debug + Send + Sync {
    /// `[ρ(s), ρ'(s), ρ''(s)]`.
    fn evaluate(&self, s: f64) -> [f64; 3];

    /// `[ρ'(s), ρ''(s)]` only: what the normal equations need. Override it where `ρ` itself is
    /// expensive (Cauchy's logarithm); the default calls [`evaluate`](Self::evaluate).
    fn weights(&self, s: f64) -> [f64; 2] {
        let [_, d1, d2] = self.evaluate(s);
        [d1, d2]
    }

    /// `ρ(s)` only: what a cost evaluation needs. Override it where the derivatives cost extra
    /// divisions (Cauchy); it must equal `evaluate(s)[0]` bit for bit. The default calls
    /// [`evaluate`](Self::evaluate).
    fn rho(&self, s: f64) -> f64 {
        self.evaluate(s)[0]
    }

    /// [`evaluate`](Self::evaluate) of four squared norms at once (the lanes of the fused
    /// linearisation, `Problem`): one call instead of four. Each entry must equal
    /// `evaluate(s[l])` bit for bit; the default loops. Override it to save the virtual calls.
    fn evaluate_lanes(&self, s: &[f64; 4]) -> [[f64; 3]; 4] {
        s.map(|v| self.evaluate(v))
    }

    /// [`weights`](Self::weights) of four squared norms at once; each entry must equal
    /// `weights(s[l])` bit for bit. The default loops.
    fn weights_lanes(&self, s: &[f64; 4]) -> [[f64; 2]; 4] {
        s.map(|v| self.weights(v))
    }

    /// The residual magnitude that separates inliers from outliers (`|r| <= scale`), in the
    /// metric's units; `f64::INFINITY` for a non-robust loss.
    fn scale(&self) -> f64;
}
