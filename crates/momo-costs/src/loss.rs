//! Robust losses [`Cauchy`], [`Huber`], [`Tukey`] on the squared residual `s = ‖r‖²`, with the
//! conventions of Ceres Solver (`ρ(s) ≈ s` for small `s`; `ρ'(0) = 1`).
//!
//! Each loss has one parameter, the scale `b`, in the *metric's* residual units (dimensionless
//! sine of an angle for [`crate::AnglePlane`], pixels for [`crate::GeoLine`] and
//! [`crate::Sampson`]). Matches with `‖r‖ <= b` count as inliers.

use momo_core::RobustLoss;
use serde::{Deserialize, Deserializer, Serialize};

/// Deserialises a scale and rejects values that are not finite and positive.
fn positive_scale<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let b = f64::deserialize(d)?;
    if b.is_finite() && b > 0.0 {
        Ok(b)
    } else {
        Err(serde::de::Error::custom(format!(
            "loss scale must be finite and positive, got {b}"
        )))
    }
}

fn check_scale(loss: &str, b: f64) -> f64 {
    assert!(
        b.is_finite() && b > 0.0,
        "{loss} loss: scale must be finite and positive, got {b}"
    );
    b
}

/// The Cauchy (Lorentzian) loss, the paper's choice (Sec. III-B):
/// `ρ(s) = b² ln(1 + s/b²)`, `ρ'(s) = 1 / (1 + s/b²)`, `ρ''(s) = -ρ'(s)² / b²`.
///
/// Its influence vanishes for large residuals without the hard cut-off of [`Tukey`].
/// The default scale is `0.002` (for [`crate::AnglePlane`], about 1.4 px at KITTI's focal
/// length), which beat the paper's `0.0065` in the prototype when random mismatches are present
/// (`DESIGN.md`).
///
/// ```
/// use momo_core::RobustLoss;
/// let loss: Box<dyn RobustLoss> = serde_json::from_str(r#"{"type": "cauchy", "scale": 0.0065}"#).unwrap();
/// assert_eq!(loss.scale(), 0.0065);
/// assert_eq!(loss.evaluate(0.0), [0.0, 1.0, -1.0 / 0.0065f64.powi(2)]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cauchy {
    /// The scale `b`, in the metric's residual units.
    #[serde(default = "Cauchy::default_scale", deserialize_with = "positive_scale")]
    pub scale: f64,
}

impl Cauchy {
    /// The default scale, `0.002`.
    pub const DEFAULT_SCALE: f64 = 0.002;

    fn default_scale() -> f64 {
        Self::DEFAULT_SCALE
    }

    /// A Cauchy loss with scale `b`.
    ///
    /// # Panics
    /// If `scale` is not finite and positive.
    pub fn new(scale: f64) -> Self {
        Self {
            scale: check_scale("cauchy", scale),
        }
    }
}

impl Default for Cauchy {
    fn default() -> Self {
        Self::new(Self::DEFAULT_SCALE)
    }
}

#[typetag::serde(name = "cauchy")]
impl RobustLoss for Cauchy {
    fn evaluate(&self, s: f64) -> [f64; 3] {
        let b2 = self.scale * self.scale;
        let d1 = 1.0 / (1.0 + s / b2);
        // ln(1 + x) is several times faster than ln_1p(x) (a hot spot of the profile); ln_1p
        // only where ln(1 + x) would lose its relative accuracy.
        let x = s / b2;
        let log = if x < 0.01 { x.ln_1p() } else { (1.0 + x).ln() };
        [b2 * log, d1, -d1 * d1 / b2]
    }

    fn rho(&self, s: f64) -> f64 {
        let b2 = self.scale * self.scale;
        let x = s / b2;
        let log = if x < 0.01 { x.ln_1p() } else { (1.0 + x).ln() };
        b2 * log
    }

    fn weights(&self, s: f64) -> [f64; 2] {
        let b2 = self.scale * self.scale;
        let d1 = b2 / (b2 + s);
        [d1, -d1 * d1 / b2]
    }

    fn evaluate_lanes(&self, s: &[f64; 4]) -> [[f64; 3]; 4] {
        s.map(|v| Self::evaluate(self, v))
    }

    fn weights_lanes(&self, s: &[f64; 4]) -> [[f64; 2]; 4] {
        s.map(|v| Self::weights(self, v))
    }

    fn scale(&self) -> f64 {
        self.scale
    }
}

/// The Huber loss: `ρ(s) = s` for `s <= b²`, `ρ(s) = 2 b √s - b²` beyond;
/// `ρ' = 1`, `ρ'' = 0` inside, `ρ' = b / √s`, `ρ'' = -ρ' / (2 s)` beyond.
///
/// Quadratic for inliers, linear for outliers: outliers keep a constant pull. The default scale
/// is `0.001` (the classical 95 %-efficiency ratio 1.345 / 2.385 to the Cauchy default).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Huber {
    /// The scale `b`, in the metric's residual units.
    #[serde(default = "Huber::default_scale", deserialize_with = "positive_scale")]
    pub scale: f64,
}

impl Huber {
    /// The default scale, `0.001`.
    pub const DEFAULT_SCALE: f64 = 0.001;

    fn default_scale() -> f64 {
        Self::DEFAULT_SCALE
    }

    /// A Huber loss with scale `b`.
    ///
    /// # Panics
    /// If `scale` is not finite and positive.
    pub fn new(scale: f64) -> Self {
        Self {
            scale: check_scale("huber", scale),
        }
    }
}

impl Default for Huber {
    fn default() -> Self {
        Self::new(Self::DEFAULT_SCALE)
    }
}

#[typetag::serde(name = "huber")]
impl RobustLoss for Huber {
    fn evaluate(&self, s: f64) -> [f64; 3] {
        let b = self.scale;
        if s <= b * b {
            [s, 1.0, 0.0]
        } else {
            let r = s.sqrt();
            let d1 = b / r;
            [2.0 * b * r - b * b, d1, -0.5 * d1 / s]
        }
    }

    fn evaluate_lanes(&self, s: &[f64; 4]) -> [[f64; 3]; 4] {
        s.map(|v| Self::evaluate(self, v))
    }

    fn weights_lanes(&self, s: &[f64; 4]) -> [[f64; 2]; 4] {
        s.map(|v| Self::weights(self, v))
    }

    fn scale(&self) -> f64 {
        self.scale
    }
}

/// Tukey's biweight: `ρ(s) = b²/3 (1 - (1 - s/b²)³)` for `s <= b²`, `b²/3` beyond;
/// `ρ' = (1 - s/b²)²`, `ρ'' = -2 (1 - s/b²) / b²` inside, both zero beyond.
///
/// Outliers beyond `b` have no influence at all, which makes it the most aggressive of the
/// three and the most prone to local minima (the paper prefers Cauchy). The default scale is
/// `0.004` (the classical 95 %-efficiency ratio 4.685 / 2.385 to the Cauchy default).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tukey {
    /// The scale `b`, in the metric's residual units.
    #[serde(default = "Tukey::default_scale", deserialize_with = "positive_scale")]
    pub scale: f64,
}

impl Tukey {
    /// The default scale, `0.004`.
    pub const DEFAULT_SCALE: f64 = 0.004;

    fn default_scale() -> f64 {
        Self::DEFAULT_SCALE
    }

    /// A Tukey loss with scale `b`.
    ///
    /// # Panics
    /// If `scale` is not finite and positive.
    pub fn new(scale: f64) -> Self {
        Self {
            scale: check_scale("tukey", scale),
        }
    }
}

impl Default for Tukey {
    fn default() -> Self {
        Self::new(Self::DEFAULT_SCALE)
    }
}

#[typetag::serde(name = "tukey")]
impl RobustLoss for Tukey {
    fn evaluate(&self, s: f64) -> [f64; 3] {
        let b2 = self.scale * self.scale;
        if s <= b2 {
            let v = 1.0 - s / b2;
            // b²/3 (1 - v³) = s/3 (1 + v + v²): no cancellation for s ≪ b².
            [s / 3.0 * (1.0 + v + v * v), v * v, -2.0 * v / b2]
        } else {
            [b2 / 3.0, 0.0, 0.0]
        }
    }

    fn evaluate_lanes(&self, s: &[f64; 4]) -> [[f64; 3]; 4] {
        s.map(|v| Self::evaluate(self, v))
    }

    fn weights_lanes(&self, s: &[f64; 4]) -> [[f64; 2]; 4] {
        s.map(|v| Self::weights(self, v))
    }

    fn scale(&self) -> f64 {
        self.scale
    }
}
