//! Central camera models exactly as `FORMAT.md` defines them: [`Pinhole`],
//! [`KannalaBrandt`] (equidistant fisheye), [`Radtan`] (OpenCV radial-tangential),
//! [`DoubleSphere`] and [`Unified`] (wide-angle), and the [`Camera`] enum that `rig.json` names
//! by `"type"`. `docs/CAMERAS.md` lists their parameters and valid regions.
//!
//! Unprojection returns a *unit bearing vector* in the camera frame (x right, y down,
//! z forward). Pixels follow OpenCV: the centre of the top-left pixel is (0, 0).

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// What every central camera model offers.
pub trait CameraModel {
    /// Projects a point in camera coordinates to pixels; `None` where the model is undefined
    /// (behind a pinhole camera, at the projection centre).
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>>;
    /// The unit bearing vector of a pixel; `None` where the model cannot invert it.
    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>>;
    /// Image size `(width, height)` in pixels.
    fn size(&self) -> (f64, f64);
    /// The projection's Jacobian `∂π/∂p` (2×3, rows `u`, `v`) at a point `p` in camera
    /// coordinates, in closed form; `None` where [`project`](Self::project) is undefined at `p`
    /// or the model has no closed form there (e.g. on a fisheye's optical axis), and for models
    /// that do not provide it (the default). Callers then differentiate `project` numerically.
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        let _ = p;
        None
    }
    /// Whether a pixel lies inside the image, extended by `margin` pixels on every side.
    fn contains(&self, px: &Vector2<f64>, margin: f64) -> bool {
        let (w, h) = self.size();
        px.x >= -0.5 - margin
            && px.y >= -0.5 - margin
            && px.x <= w - 0.5 + margin
            && px.y <= h - 0.5 + margin
    }
}

/// The pinhole model: `u = fx X/Z + cx`, `v = fy Y/Z + cy`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pinhole {
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Image width, pixels.
    pub width: f64,
    /// Image height, pixels.
    pub height: f64,
}

impl Pinhole {
    /// The calibration matrix `K`.
    pub fn k(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// The inverse calibration matrix `K⁻¹`.
    pub fn k_inv(&self) -> Matrix3<f64> {
        Matrix3::new(
            1.0 / self.fx,
            0.0,
            -self.cx / self.fx,
            0.0,
            1.0 / self.fy,
            -self.cy / self.fy,
            0.0,
            0.0,
            1.0,
        )
    }
}

impl CameraModel for Pinhole {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        (p.z > 0.0)
            .then(|| Vector2::new(self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy))
    }

    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        let v = Vector3::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy, 1.0);
        v.try_normalize(0.0)
    }

    /// `[[fx/Z, 0, −fx X/Z²], [0, fy/Z, −fy Y/Z²]]` for `Z > 0` (denominator `Z`).
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        (p.z > 0.0).then(|| projective_jacobian(self.fx, self.fy, p, p.z, &Vector3::z()))
    }

    fn size(&self) -> (f64, f64) {
        (self.width, self.height)
    }
}

/// The Kannala-Brandt equidistant fisheye model (OpenCV `fisheye`, Kalibr `pinhole-equi`):
/// `θ = atan2(ρ, Z)`, `d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`,
/// `u = fx d X/ρ + cx`, `v = fy d Y/ρ + cy`. Fields of view beyond 180° are allowed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KannalaBrandt {
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Distortion coefficient of θ³.
    pub k1: f64,
    /// Distortion coefficient of θ⁵.
    pub k2: f64,
    /// Distortion coefficient of θ⁷.
    pub k3: f64,
    /// Distortion coefficient of θ⁹.
    pub k4: f64,
    /// Image width, pixels.
    pub width: f64,
    /// Image height, pixels.
    pub height: f64,
}

impl KannalaBrandt {
    /// The distorted radius `d(θ)` and its derivative `d'(θ)`.
    fn distort(&self, theta: f64) -> (f64, f64) {
        let t2 = theta * theta;
        let poly = 1.0 + t2 * (self.k1 + t2 * (self.k2 + t2 * (self.k3 + t2 * self.k4)));
        let dpoly = 1.0
            + t2 * (3.0 * self.k1
                + t2 * (5.0 * self.k2 + t2 * (7.0 * self.k3 + t2 * 9.0 * self.k4)));
        (theta * poly, dpoly)
    }
}

impl CameraModel for KannalaBrandt {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        let rho = p.x.hypot(p.y);
        if rho == 0.0 {
            return (p.z > 0.0).then_some(Vector2::new(self.cx, self.cy));
        }
        let theta = rho.atan2(p.z);
        let (d, _) = self.distort(theta);
        Some(Vector2::new(
            self.fx * d * p.x / rho + self.cx,
            self.fy * d * p.y / rho + self.cy,
        ))
    }

    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        let mx = (px.x - self.cx) / self.fx;
        let my = (px.y - self.cy) / self.fy;
        let r = mx.hypot(my);
        if r == 0.0 {
            return Some(Vector3::z());
        }
        // Newton on d(θ) = r, started at θ = r (exact for the undistorted model).
        let mut theta = r;
        for _ in 0..50 {
            let (d, dd) = self.distort(theta);
            if dd.abs() < 1e-12 {
                return None;
            }
            let step = (d - r) / dd;
            theta -= step;
            if step.abs() < 1e-14 {
                break;
            }
        }
        let (d, _) = self.distort(theta);
        if !theta.is_finite() || theta < 0.0 || (d - r).abs() > 1e-9 * r.max(1.0) {
            return None;
        }
        let s = theta.sin();
        Some(Vector3::new(s * mx / r, s * my / r, theta.cos()))
    }

    /// With `ρ = ‖(X, Y)‖`, `‖p‖² = ρ² + Z²`, `s = d(θ)/ρ`, `k = d'(θ) Z / (ρ² ‖p‖²) − d(θ)/ρ³`
    /// (`∂s/∂X = k X`, `∂s/∂Y = k Y`, `∂s/∂Z = −d'(θ)/‖p‖²`): `∂u/∂p = fx (s eₓ + X ∇s)`,
    /// `∂v/∂p = fy (s e_y + Y ∇s)`. `None` on the optical axis (`ρ = 0`).
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        let rho = p.x.hypot(p.y);
        if !(rho > 0.0) {
            return None;
        }
        let theta = rho.atan2(p.z);
        let (d, dd) = self.distort(theta);
        let r2 = rho * rho + p.z * p.z;
        let s = d / rho;
        let k = dd * p.z / (rho * rho * r2) - s / (rho * rho);
        let sz = -dd / r2;
        let j = Matrix2x3::new(
            self.fx * (s + p.x * p.x * k),
            self.fx * p.x * p.y * k,
            self.fx * p.x * sz,
            self.fy * p.x * p.y * k,
            self.fy * (s + p.y * p.y * k),
            self.fy * p.y * sz,
        );
        j.iter().all(|v| v.is_finite()).then_some(j)
    }

    fn size(&self) -> (f64, f64) {
        (self.width, self.height)
    }
}

/// The OpenCV radial-tangential model (`radtan`; ROS `plumb_bob`; Kalibr `pinhole-radtan`):
/// with `x = X/Z`, `y = Y/Z`, `r² = x² + y²` and `R = 1 + k1 r² + k2 r⁴ + k3 r⁶`,
///
/// `x_d = x R + 2 p1 x y + p2 (r² + 2x²)`, `y_d = y R + p1 (r² + 2y²) + 2 p2 x y`,
/// `u = fx x_d + cx`, `v = fy y_d + cy`.
///
/// **Valid region** (`docs/CAMERAS.md`): `Z > 0`, and the radial profile `r ↦ r R(r)` strictly
/// increasing on `[0, r]` (beyond its first maximum the polynomial folds back and two radii give
/// the same pixel), and a positive Jacobian determinant of the distortion at the point. Outside
/// it [`project`](CameraModel::project) returns `None`; [`unproject`](CameraModel::unproject)
/// inverts the distortion by damped Newton iterations to a pixel residual below
/// [`RADTAN_TOLERANCE_PX`] and returns `None` (never NaN) when they do not converge or end
/// outside the valid region.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Radtan {
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Radial coefficient of r².
    pub k1: f64,
    /// Radial coefficient of r⁴.
    pub k2: f64,
    /// Tangential coefficient p1.
    pub p1: f64,
    /// Tangential coefficient p2.
    pub p2: f64,
    /// Radial coefficient of r⁶ (0 for the four-coefficient form).
    #[serde(default)]
    pub k3: f64,
    /// Image width, pixels.
    pub width: f64,
    /// Image height, pixels.
    pub height: f64,
}

/// Largest pixel residual `‖project(unproject(px)) − px‖` that [`Radtan::unproject`] accepts.
pub const RADTAN_TOLERANCE_PX: f64 = 1e-9;

impl Radtan {
    /// The distorted normalised point `(x_d, y_d)` and the Jacobian `∂(x_d, y_d)/∂(x, y)`
    /// (rows: x_d, y_d).
    pub fn distort(&self, x: f64, y: f64) -> (Vector2<f64>, Matrix2<f64>) {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // dR/d(r²)
        let dradial = self.k1 + r2 * (2.0 * self.k2 + r2 * 3.0 * self.k3);
        let (p1, p2) = (self.p1, self.p2);
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let j = Matrix2::new(
            radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x,
            2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y,
            2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y,
            radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x,
        );
        (Vector2::new(xd, yd), j)
    }

    /// `d(r R(r))/dr = 1 + 3 k1 s + 5 k2 s² + 7 k3 s³` at `s = r²`.
    fn radial_slope(&self, s: f64) -> f64 {
        1.0 + s * (3.0 * self.k1 + s * (5.0 * self.k2 + s * 7.0 * self.k3))
    }

    /// Whether the radial profile `r ↦ r R(r)` is strictly increasing on `[0, √s]`: the slope
    /// (a cubic in `s` with value 1 at 0) is positive at `s` and at every stationary point in
    /// `(0, s)` (roots of `3 k1 + 10 k2 s + 21 k3 s²`), hence on the whole interval. Exact and
    /// cheap, so it is evaluated per point.
    pub fn radially_monotonic(&self, s: f64) -> bool {
        if !(s.is_finite() && s >= 0.0) || self.radial_slope(s) <= 0.0 {
            return false;
        }
        let (a, b, c) = (21.0 * self.k3, 10.0 * self.k2, 3.0 * self.k1);
        let mut stationary = [f64::NAN; 2];
        if a == 0.0 {
            if b != 0.0 {
                stationary[0] = -c / b;
            }
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc >= 0.0 {
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                stationary = [q / a, if q != 0.0 { c / q } else { 0.0 }];
            }
        }
        stationary
            .iter()
            .filter(|t| t.is_finite() && **t > 0.0 && **t < s)
            .all(|&t| self.radial_slope(t) > 0.0)
    }

    /// Whether a normalised point `(x, y)` lies in the valid region.
    pub fn valid_normalized(&self, x: f64, y: f64) -> bool {
        self.radially_monotonic(x * x + y * y) && self.distort(x, y).1.determinant() > 0.0
    }
}

impl CameraModel for Radtan {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        if !(p.z > 0.0) {
            return None;
        }
        let (x, y) = (p.x / p.z, p.y / p.z);
        if !self.valid_normalized(x, y) {
            return None;
        }
        let (d, _) = self.distort(x, y);
        Some(Vector2::new(
            self.fx * d.x + self.cx,
            self.fy * d.y + self.cy,
        ))
    }

    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        let target = Vector2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        if !(target.x.is_finite() && target.y.is_finite()) {
            return None;
        }
        // Residual in pixels.
        let residual = |m: &Vector2<f64>| {
            let (d, j) = self.distort(m.x, m.y);
            let e = d - target;
            (Vector2::new(e.x * self.fx, e.y * self.fy), e, j)
        };
        let mut m = target;
        let (mut e_px, mut e, mut j) = residual(&m);
        for _ in 0..100 {
            if e_px.norm() < 1e-3 * RADTAN_TOLERANCE_PX {
                break;
            }
            let step = j.try_inverse()? * e;
            // Damped Newton: halve the step until the pixel residual decreases and the point
            // stays in the valid region.
            let mut t = 1.0;
            let mut accepted = false;
            for _ in 0..40 {
                let cand = m - step * t;
                if self.valid_normalized(cand.x, cand.y) {
                    let (ce_px, ce, cj) = residual(&cand);
                    if ce_px.norm() < e_px.norm() {
                        (m, e_px, e, j) = (cand, ce_px, ce, cj);
                        accepted = true;
                        break;
                    }
                }
                t *= 0.5;
            }
            if !accepted {
                break;
            }
        }
        if !(e_px.norm() < RADTAN_TOLERANCE_PX) || !self.valid_normalized(m.x, m.y) {
            return None;
        }
        Vector3::new(m.x, m.y, 1.0).try_normalize(0.0)
    }

    /// `diag(fx, fy) · ∂(x_d, y_d)/∂(x, y) · [[1/Z, 0, −x/Z], [0, 1/Z, −y/Z]]` in the valid
    /// region (`x = X/Z`, `y = Y/Z`).
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        if !(p.z > 0.0) {
            return None;
        }
        let (x, y) = (p.x / p.z, p.y / p.z);
        if !self.valid_normalized(x, y) {
            return None;
        }
        let (_, jd) = self.distort(x, y);
        // ∂(x, y)/∂p: the pinhole's with unit focal lengths.
        let dn = projective_jacobian(1.0, 1.0, p, p.z, &Vector3::z());
        let j = Matrix2::new(self.fx, 0.0, 0.0, self.fy) * jd * dn;
        j.iter().all(|v| v.is_finite()).then_some(j)
    }

    fn size(&self) -> (f64, f64) {
        (self.width, self.height)
    }
}

/// The double sphere model (Usenko, Demmel, Cremers, "The Double Sphere Camera Model", 3DV
/// 2018; Basalt and Kalibr `ds`): with `d1 = ‖(X, Y, Z)‖`,
/// `d2 = ‖(X, Y, ξ d1 + Z)‖` and `den = α d2 + (1 − α)(ξ d1 + Z)`,
/// `u = fx X/den + cx`, `v = fy Y/den + cy`.
///
/// **Valid region** (exact; `docs/CAMERAS.md` derives it): `ξ d1 + Z > −w1 d2` with
/// `w1 = α/(1−α)` for `α ≤ 1/2` and `(1−α)/α` otherwise, i.e. the point seen from the second
/// sphere's centre lies inside the injective part of the unified projection with parameter
/// `α/(1−α)`. The paper's bound `Z > −w2 d1`, `w2 = (w1 + ξ)/√(2 w1 ξ + ξ² + 1)`, differs from
/// it: it is too loose for some `ξ < 0` (accepts folded points) and too strict for `ξ > 0`.
/// Unprojection requires `r² < 1/(2α − 1)` for `α > 1/2` (`r` the normalised pixel radius).
/// Parameters: `−1 < ξ < 1`, `0 ≤ α ≤ 1`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoubleSphere {
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// ξ: the shift between the two unit spheres' centres.
    pub xi: f64,
    /// α: the mixing of the second sphere and the pinhole plane.
    pub alpha: f64,
    /// Image width, pixels.
    pub width: f64,
    /// Image height, pixels.
    pub height: f64,
}

impl DoubleSphere {
    /// `w1` of the valid region: `α/(1−α)` for `α ≤ 1/2`, `(1−α)/α` otherwise.
    pub fn w1(&self) -> f64 {
        if self.alpha <= 0.5 {
            self.alpha / (1.0 - self.alpha)
        } else {
            (1.0 - self.alpha) / self.alpha
        }
    }

    /// Whether a point (camera coordinates, not the origin) lies in the exact valid region
    /// `ξ d1 + Z > −w1 d2`.
    pub fn valid_point(&self, p: &Vector3<f64>) -> bool {
        let d1 = p.norm();
        let zs = self.xi * d1 + p.z;
        let d2 = p.x.hypot(p.y).hypot(zs);
        d1 > 0.0 && zs > -self.w1() * d2
    }

    /// The paper's (and Basalt's) validity test `Z > −w2 d1`, kept to document and test where it
    /// differs from [`DoubleSphere::valid_point`].
    pub fn valid_point_paper(&self, p: &Vector3<f64>) -> bool {
        let w1 = self.w1();
        let xi = self.xi;
        let w2 = (w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt();
        p.z > -w2 * p.norm()
    }
}

impl CameraModel for DoubleSphere {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        if !self.valid_point(p) {
            return None;
        }
        let d1 = p.norm();
        let zs = self.xi * d1 + p.z;
        let d2 = p.x.hypot(p.y).hypot(zs);
        let den = self.alpha * d2 + (1.0 - self.alpha) * zs;
        if !(den > 0.0) {
            return None;
        }
        Some(Vector2::new(
            self.fx * p.x / den + self.cx,
            self.fy * p.y / den + self.cy,
        ))
    }

    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        let mx = (px.x - self.cx) / self.fx;
        let my = (px.y - self.cy) / self.fy;
        let r2 = mx * mx + my * my;
        let a = self.alpha;
        let under = 1.0 - (2.0 * a - 1.0) * r2;
        if !(under > 0.0) {
            return None;
        }
        let mz = (1.0 - a * a * r2) / (a * under.sqrt() + 1.0 - a);
        let xi = self.xi;
        let root = mz * mz + (1.0 - xi * xi) * r2;
        if !(root >= 0.0) {
            return None;
        }
        let k = (mz * xi + root.sqrt()) / (mz * mz + r2);
        let b = Vector3::new(k * mx, k * my, k * mz - xi).try_normalize(0.0)?;
        (self.valid_point(&b) && b.iter().all(|v| v.is_finite())).then_some(b)
    }

    /// With `∇zs = ξ p/d1 + e_z`, `∇d2 = (X eₓ + Y e_y + zs ∇zs)/d2` and
    /// `∇den = α ∇d2 + (1 − α) ∇zs`: `∂u/∂p = fx (eₓ − X ∇den/den)/den`,
    /// `∂v/∂p = fy (e_y − Y ∇den/den)/den`, in the valid region.
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        if !self.valid_point(p) {
            return None;
        }
        let d1 = p.norm();
        let zs = self.xi * d1 + p.z;
        let d2 = p.x.hypot(p.y).hypot(zs);
        let den = self.alpha * d2 + (1.0 - self.alpha) * zs;
        if !(den > 0.0 && d2 > 0.0) {
            return None;
        }
        let dzs = p * (self.xi / d1) + Vector3::z();
        let dd2 = (Vector3::new(p.x, p.y, 0.0) + dzs * zs) / d2;
        let dden = dd2 * self.alpha + dzs * (1.0 - self.alpha);
        Some(projective_jacobian(self.fx, self.fy, p, den, &dden))
    }

    fn size(&self) -> (f64, f64) {
        (self.width, self.height)
    }
}

/// The unified camera model (Geyer-Daniilidis, Mei and Rives, ICRA 2007; Kalibr `omni`
/// without distortion): with `d = ‖(X, Y, Z)‖`, `u = fx X/(Z + ξ d) + cx`,
/// `v = fy Y/(Z + ξ d) + cy`.
///
/// **Valid region**: `Z > −w d` with `w = ξ` for `ξ ≤ 1` and `1/ξ` for `ξ > 1`; unprojection
/// requires `r² < 1/(ξ² − 1)` for `ξ > 1`. Parameter: `ξ ≥ 0` (`ξ = 0` is the pinhole).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Unified {
    /// Focal length in x, pixels.
    pub fx: f64,
    /// Focal length in y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// ξ: the distance of the projection centre from the unit sphere's centre.
    pub xi: f64,
    /// Image width, pixels.
    pub width: f64,
    /// Image height, pixels.
    pub height: f64,
}

impl Unified {
    /// `w` of the valid region: `ξ` for `ξ ≤ 1`, `1/ξ` otherwise.
    pub fn w(&self) -> f64 {
        if self.xi <= 1.0 {
            self.xi
        } else {
            1.0 / self.xi
        }
    }

    /// Whether a point (camera coordinates, not the origin) lies in the valid region
    /// `Z > −w d`.
    pub fn valid_point(&self, p: &Vector3<f64>) -> bool {
        let d = p.norm();
        d > 0.0 && p.z > -self.w() * d
    }
}

impl CameraModel for Unified {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        if !self.valid_point(p) {
            return None;
        }
        let den = p.z + self.xi * p.norm();
        if !(den > 0.0) {
            return None;
        }
        Some(Vector2::new(
            self.fx * p.x / den + self.cx,
            self.fy * p.y / den + self.cy,
        ))
    }

    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        let mx = (px.x - self.cx) / self.fx;
        let my = (px.y - self.cy) / self.fy;
        let r2 = mx * mx + my * my;
        let xi = self.xi;
        let under = 1.0 + (1.0 - xi * xi) * r2;
        if !(under > 0.0) {
            return None;
        }
        let k = (xi + under.sqrt()) / (1.0 + r2);
        let b = Vector3::new(k * mx, k * my, k - xi).try_normalize(0.0)?;
        (self.valid_point(&b) && b.iter().all(|v| v.is_finite())).then_some(b)
    }

    /// With `∇den = ξ p/‖p‖ + e_z`: `∂u/∂p = fx (eₓ − X ∇den/den)/den`,
    /// `∂v/∂p = fy (e_y − Y ∇den/den)/den`, in the valid region.
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        if !self.valid_point(p) {
            return None;
        }
        let d = p.norm();
        let den = p.z + self.xi * d;
        if !(den > 0.0) {
            return None;
        }
        let dden = p * (self.xi / d) + Vector3::z();
        Some(projective_jacobian(self.fx, self.fy, p, den, &dden))
    }

    fn size(&self) -> (f64, f64) {
        (self.width, self.height)
    }
}

/// `∂/∂p (fx X/den, fy Y/den)` for a denominator `den(p)` with gradient `dden`.
fn projective_jacobian(
    fx: f64,
    fy: f64,
    p: &Vector3<f64>,
    den: f64,
    dden: &Vector3<f64>,
) -> Matrix2x3<f64> {
    let inv = 1.0 / den;
    let (x, y) = (p.x * inv, p.y * inv);
    Matrix2x3::new(
        fx * (1.0 - x * dden.x) * inv,
        -fx * x * dden.y * inv,
        -fx * x * dden.z * inv,
        -fy * y * dden.x * inv,
        fy * (1.0 - y * dden.y) * inv,
        -fy * y * dden.z * inv,
    )
}

/// A camera of a rig: one of the models of `FORMAT.md`, tagged by `"type"` in `rig.json`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Camera {
    /// `"type": "pinhole"`.
    Pinhole(Pinhole),
    /// `"type": "kannala_brandt"`.
    KannalaBrandt(KannalaBrandt),
    /// `"type": "radtan"` (format version 2).
    Radtan(Radtan),
    /// `"type": "double_sphere"` (format version 2).
    DoubleSphere(DoubleSphere),
    /// `"type": "unified"` (format version 2).
    Unified(Unified),
}

impl Camera {
    /// The pinhole model, if this is one (metrics in pixels need it).
    pub fn as_pinhole(&self) -> Option<&Pinhole> {
        match self {
            Camera::Pinhole(p) => Some(p),
            _ => None,
        }
    }

    /// A typical focal length in pixels (mean of `fx` and `fy`), to convert angles to pixels.
    pub fn focal_length(&self) -> f64 {
        match self {
            Camera::Pinhole(p) => 0.5 * (p.fx + p.fy),
            Camera::KannalaBrandt(k) => 0.5 * (k.fx + k.fy),
            Camera::Radtan(c) => 0.5 * (c.fx + c.fy),
            Camera::DoubleSphere(c) => 0.5 * (c.fx + c.fy),
            Camera::Unified(c) => 0.5 * (c.fx + c.fy),
        }
    }
}

impl CameraModel for Camera {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        match self {
            Camera::Pinhole(c) => c.project(p),
            Camera::KannalaBrandt(c) => c.project(p),
            Camera::Radtan(c) => c.project(p),
            Camera::DoubleSphere(c) => c.project(p),
            Camera::Unified(c) => c.project(p),
        }
    }
    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        match self {
            Camera::Pinhole(c) => c.unproject(px),
            Camera::KannalaBrandt(c) => c.unproject(px),
            Camera::Radtan(c) => c.unproject(px),
            Camera::DoubleSphere(c) => c.unproject(px),
            Camera::Unified(c) => c.unproject(px),
        }
    }
    fn project_jacobian(&self, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        match self {
            Camera::Pinhole(c) => c.project_jacobian(p),
            Camera::KannalaBrandt(c) => c.project_jacobian(p),
            Camera::Radtan(c) => c.project_jacobian(p),
            Camera::DoubleSphere(c) => c.project_jacobian(p),
            Camera::Unified(c) => c.project_jacobian(p),
        }
    }
    fn size(&self) -> (f64, f64) {
        match self {
            Camera::Pinhole(c) => c.size(),
            Camera::KannalaBrandt(c) => c.size(),
            Camera::Radtan(c) => c.size(),
            Camera::DoubleSphere(c) => c.size(),
            Camera::Unified(c) => c.size(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn fisheye() -> KannalaBrandt {
        KannalaBrandt {
            fx: 330.0,
            fy: 331.0,
            cx: 640.0,
            cy: 480.0,
            k1: 0.02,
            k2: -0.005,
            k3: 0.001,
            k4: -0.0001,
            width: 1280.0,
            height: 960.0,
        }
    }

    proptest! {
        #[test]
        fn pinhole_roundtrip(x in -5.0..5.0f64, y in -5.0..5.0f64, z in 0.5..50.0f64) {
            let c = Pinhole { fx: 718.856, fy: 718.856, cx: 607.19, cy: 185.22, width: 1241.0, height: 376.0 };
            let p = Vector3::new(x, y, z);
            let px = c.project(&p).expect("in front");
            let b = c.unproject(&px).expect("finite");
            prop_assert!((b - p.normalize()).amax() < 1e-12);
        }

        /// Includes angles beyond 90 degrees (points behind the image plane), up to 110 degrees.
        #[test]
        fn fisheye_roundtrip(theta in 0.0..1.92f64, phi in -std::f64::consts::PI..std::f64::consts::PI, depth in 0.5..50.0f64) {
            let c = fisheye();
            let p = Vector3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()) * depth;
            let px = c.project(&p).expect("fisheye projects everything but the centre");
            let b = c.unproject(&px).expect("invertible");
            prop_assert!((b - p.normalize()).amax() < 1e-9, "theta {theta}: {b} vs {}", p.normalize());
        }
    }

    /// `∂π/∂p` by central differences (step `h` relative to `‖p‖`).
    fn numeric_jacobian(c: &Camera, p: &Vector3<f64>) -> Option<Matrix2x3<f64>> {
        let h = 1e-6 * p.norm();
        let mut j = Matrix2x3::zeros();
        for k in 0..3 {
            let mut d = Vector3::zeros();
            d[k] = h;
            let col = (c.project(&(p + d))? - c.project(&(p - d))?) / (2.0 * h);
            j[(0, k)] = col.x;
            j[(1, k)] = col.y;
        }
        Some(j)
    }

    fn every_model() -> Vec<Camera> {
        vec![
            Camera::Pinhole(Pinhole {
                fx: 718.856,
                fy: 712.0,
                cx: 607.19,
                cy: 185.22,
                width: 1241.0,
                height: 376.0,
            }),
            Camera::KannalaBrandt(fisheye()),
            Camera::Radtan(radtan()),
            Camera::DoubleSphere(DoubleSphere {
                fx: 350.0,
                fy: 352.0,
                cx: 640.0,
                cy: 400.0,
                xi: -0.2,
                alpha: 0.59,
                width: 1280.0,
                height: 800.0,
            }),
            Camera::DoubleSphere(DoubleSphere {
                fx: 350.0,
                fy: 352.0,
                cx: 640.0,
                cy: 400.0,
                xi: 0.3,
                alpha: 0.4,
                width: 1280.0,
                height: 800.0,
            }),
            Camera::Unified(Unified {
                fx: 500.0,
                fy: 498.0,
                cx: 640.0,
                cy: 400.0,
                xi: 0.8,
                width: 1280.0,
                height: 800.0,
            }),
            Camera::Unified(Unified {
                fx: 500.0,
                fy: 498.0,
                cx: 640.0,
                cy: 400.0,
                xi: 1.6,
                width: 1280.0,
                height: 800.0,
            }),
        ]
    }

    proptest! {
        /// The closed-form projection Jacobian of every model against central differences of
        /// `project` wherever both exist (relative 1e-6 of the Jacobian's size: the differences'
        /// own error is about 1e-10 · ‖p‖ / h); where `project` is undefined, so is the Jacobian.
        #[test]
        fn projection_jacobian_matches_central_differences(theta in 0.0..3.0f64, phi in -std::f64::consts::PI..std::f64::consts::PI, depth in 0.2..40.0f64) {
            let p = unit(theta, phi) * depth;
            for c in every_model() {
                let analytic = c.project_jacobian(&p);
                if c.project(&p).is_none() {
                    prop_assert!(analytic.is_none(), "{c:?} at {p}");
                    continue;
                }
                let (Some(a), Some(n)) = (analytic, numeric_jacobian(&c, &p)) else {
                    continue;
                };
                // Compared where a match can be: the pixel within the image extended by its own
                // size. Beyond, near a model's singular denominator (a unified camera's
                // `Z + ξ‖p‖ → 0`), the pixel runs to infinity and the differences' reference
                // itself fails (seen: 3e10 px per unit against the closed form's exact value).
                let (w, h) = c.size();
                if !c.project(&p).is_some_and(|px| c.contains(&px, w.max(h))) {
                    continue;
                }
                let size = n.amax().max(1e-300);
                prop_assert!((a - n).amax() <= 1e-6 * size, "{c:?} at {p}: {a} vs {n}");
            }
        }
    }

    #[test]
    fn projection_jacobian_of_the_fisheye_axis_is_none() {
        let c = fisheye();
        assert!(c.project_jacobian(&Vector3::new(0.0, 0.0, 1.0)).is_none());
        let j = c
            .project_jacobian(&Vector3::new(1e-9, 0.0, 1.0))
            .expect("off the axis");
        assert!((j[(0, 0)] - c.fx).abs() < 1e-6 * c.fx && (j[(1, 1)] - c.fy).abs() < 1e-6 * c.fy);
    }

    #[test]
    fn fisheye_beyond_ninety_degrees_unprojects_behind() {
        let c = fisheye();
        let p = Vector3::new(1.0, 0.0, -0.3);
        let b = c
            .unproject(&c.project(&p).expect("projects"))
            .expect("unprojects");
        assert!(b.z < 0.0);
        assert!((b - p.normalize()).norm() < 1e-9);
    }

    #[test]
    fn pinhole_behind_is_none() {
        let c = Pinhole {
            fx: 500.0,
            fy: 500.0,
            cx: 320.0,
            cy: 240.0,
            width: 640.0,
            height: 480.0,
        };
        assert!(c.project(&Vector3::new(0.0, 0.0, -1.0)).is_none());
        assert!((c.k() * c.k_inv() - Matrix3::identity()).amax() < 1e-15);
    }

    #[test]
    fn camera_json_is_tagged_by_type() {
        let j = r#"{"type":"pinhole","fx":1,"fy":1,"cx":0,"cy":0,"width":10,"height":10}"#;
        let c: Camera = serde_json::from_str(j).expect("parses");
        assert!(c.as_pinhole().is_some());
    }

    /// A strong wide-angle OpenCV calibration (k3 ≠ 0, visible tangential terms).
    fn radtan() -> Radtan {
        Radtan {
            fx: 460.0,
            fy: 458.0,
            cx: 367.2,
            cy: 248.4,
            k1: -0.283,
            k2: 0.074,
            p1: 1.9e-4,
            p2: 1.8e-5,
            k3: -0.0052,
            width: 752.0,
            height: 480.0,
        }
    }

    fn unit(theta: f64, phi: f64) -> Vector3<f64> {
        Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    proptest! {
        /// Points in the valid region: project, unproject, back to the same ray; the pixel
        /// round trip is below the 1e-9 px tolerance.
        #[test]
        fn radtan_roundtrip(theta in 0.0..1.2f64, phi in -std::f64::consts::PI..std::f64::consts::PI, depth in 0.5..50.0f64) {
            let c = radtan();
            let p = unit(theta, phi) * depth;
            let Some(px) = c.project(&p) else {
                // Only outside the monotonic region.
                prop_assert!(!c.valid_normalized(p.x / p.z, p.y / p.z));
                return Ok(());
            };
            let b = c.unproject(&px).expect("valid points unproject");
            prop_assert!((b - p.normalize()).amax() < 1e-9, "{b} vs {}", p.normalize());
            let back = c.project(&b).expect("projects");
            prop_assert!((back - px).norm() < RADTAN_TOLERANCE_PX);
        }

        /// Every pixel of the image unprojects (this calibration is valid over the whole image)
        /// and projects back within 1e-9 px.
        #[test]
        fn radtan_every_image_pixel_inverts(u in -0.5..751.5f64, v in -0.5..479.5f64) {
            let c = radtan();
            let px = Vector2::new(u, v);
            let b = c.unproject(&px).expect("inside the image");
            prop_assert!((b.norm() - 1.0).abs() < 1e-12);
            let back = c.project(&b).expect("projects");
            prop_assert!((back - px).norm() < RADTAN_TOLERANCE_PX, "{}", (back - px).norm());
        }

        /// Random parameters and directions: a point projects iff it is in the exact valid
        /// region, and valid points round-trip (including rays behind the camera for ξ > 0).
        #[test]
        fn double_sphere_roundtrip(xi in -0.9..0.9f64, alpha in 0.0..1.0f64, theta in 0.0..3.1f64, phi in -std::f64::consts::PI..std::f64::consts::PI, depth in 0.5..50.0f64) {
            let c = DoubleSphere { fx: 350.0, fy: 351.0, cx: 640.0, cy: 400.0, xi, alpha, width: 1280.0, height: 800.0 };
            let p = unit(theta, phi) * depth;
            let px = c.project(&p);
            prop_assert_eq!(px.is_some(), c.valid_point(&p));
            if let Some(px) = px {
                // Stay off the boundary itself, where the image radius diverges or folds.
                let d1 = p.norm();
                let zs = xi * d1 + p.z;
                prop_assume!(zs + c.w1() * p.x.hypot(p.y).hypot(zs) > 1e-3 * d1);
                let b = c.unproject(&px).expect("valid points unproject");
                prop_assert!((b - p.normalize()).norm() < 1e-8, "{b} vs {}", p.normalize());
            }
        }

        #[test]
        fn unified_roundtrip(xi in 0.0..3.0f64, theta in 0.0..3.1f64, phi in -std::f64::consts::PI..std::f64::consts::PI, depth in 0.5..50.0f64) {
            let c = Unified { fx: 600.0, fy: 601.0, cx: 640.0, cy: 400.0, xi, width: 1280.0, height: 800.0 };
            let p = unit(theta, phi) * depth;
            let px = c.project(&p);
            prop_assert_eq!(px.is_some(), c.valid_point(&p));
            if let Some(px) = px {
                prop_assume!(p.z + c.w() * p.norm() > 1e-3 * p.norm());
                let b = c.unproject(&px).expect("valid points unproject");
                prop_assert!((b - p.normalize()).norm() < 1e-8, "{b} vs {}", p.normalize());
            }
        }

        /// Pixels that unproject come back to themselves (no folded branch is returned).
        #[test]
        fn wide_angle_pixel_roundtrip(xi in -0.9..0.9f64, alpha in 0.0..1.0f64, uxi in 0.0..3.0f64, u in -0.5..1279.5f64, v in -0.5..799.5f64) {
            let px = Vector2::new(u, v);
            let ds = DoubleSphere { fx: 350.0, fy: 351.0, cx: 640.0, cy: 400.0, xi, alpha, width: 1280.0, height: 800.0 };
            if let Some(b) = ds.unproject(&px) {
                let back = ds.project(&b).expect("unprojected rays are valid");
                prop_assert!((back - px).norm() < 1e-6, "ds {}", (back - px).norm());
            }
            let uc = Unified { fx: 350.0, fy: 351.0, cx: 640.0, cy: 400.0, xi: uxi, width: 1280.0, height: 800.0 };
            if let Some(b) = uc.unproject(&px) {
                let back = uc.project(&b).expect("unprojected rays are valid");
                prop_assert!((back - px).norm() < 1e-6, "unified {}", (back - px).norm());
            }
        }
    }

    /// The image radius `m(θ)` of a double sphere camera along one meridian: the exact valid
    /// region ends where `m` stops increasing (or its denominator vanishes).
    fn ds_radius(c: &DoubleSphere, theta: f64) -> Option<f64> {
        let p = unit(theta, 0.0);
        let zs = c.xi + p.z;
        let den = c.alpha * p.x.hypot(zs) + (1.0 - c.alpha) * zs;
        (den > 0.0).then(|| p.x / den)
    }

    /// The exact condition equals the numerically found fold of `m(θ)` for ξ of both signs, and
    /// the paper's bound is shown too loose for ξ < 0 (it accepts points past the fold, which
    /// then do not round-trip) and too strict for ξ > 0.
    #[test]
    fn double_sphere_valid_region_is_exact() {
        for (xi, alpha) in [
            (-0.8, 0.9),
            (-0.5, 0.7),
            (-0.3, 0.6),
            (0.0, 0.3),
            (0.5, 0.7),
            (0.8, 0.6),
        ] {
            let c = DoubleSphere {
                fx: 1.0,
                fy: 1.0,
                cx: 0.0,
                cy: 0.0,
                xi,
                alpha,
                width: 1.0,
                height: 1.0,
            };
            // First θ where m(θ) is no longer increasing, on a fine grid.
            let n = 200_000;
            let mut prev = -1.0;
            let mut fold = std::f64::consts::PI;
            for i in 1..=n {
                let th = std::f64::consts::PI * i as f64 / n as f64;
                match ds_radius(&c, th) {
                    Some(m) if m > prev => prev = m,
                    _ => {
                        fold = th;
                        break;
                    }
                }
            }
            let step = std::f64::consts::PI / n as f64;
            assert!(
                c.valid_point(&unit(fold - 2.0 * step, 0.0)),
                "xi {xi} alpha {alpha}"
            );
            assert!(
                !c.valid_point(&unit(fold + step, 0.0)),
                "xi {xi} alpha {alpha}"
            );
        }
        // ξ = -0.8, α = 0.9: the fold is at cos θ = 0.7227, the paper's bound at 0.5697.
        let c = DoubleSphere {
            fx: 300.0,
            fy: 300.0,
            cx: 0.0,
            cy: 0.0,
            xi: -0.8,
            alpha: 0.9,
            width: 1.0,
            height: 1.0,
        };
        let p = unit(0.65f64.acos(), 0.3);
        assert!(c.valid_point_paper(&p) && !c.valid_point(&p));
        assert!(c.project(&p).is_none());
        // Projected anyway (the formula), the pixel unprojects to another ray: folded.
        let d1 = p.norm();
        let zs = c.xi * d1 + p.z;
        let den = c.alpha * p.x.hypot(p.y).hypot(zs) + (1.0 - c.alpha) * zs;
        let px = Vector2::new(c.fx * p.x / den, c.fy * p.y / den);
        if let Some(b) = c.unproject(&px) {
            assert!((b - p).norm() > 1e-3);
        }
        // ξ = 0.5, α = 0.7: cos θ = -0.75 is valid (fold at -0.7905) but the paper rejects it.
        let c = DoubleSphere {
            xi: 0.5,
            alpha: 0.7,
            ..c
        };
        let p = unit((-0.75f64).acos(), 1.0);
        assert!(c.valid_point(&p) && !c.valid_point_paper(&p));
        let b = c
            .unproject(&c.project(&p).expect("valid"))
            .expect("unprojects");
        assert!((b - p).norm() < 1e-9);
    }

    /// The radtan valid region ends at the fold of the radial profile; beyond it projection and
    /// unprojection give `None`, not NaN.
    #[test]
    fn radtan_outside_the_valid_region_is_none() {
        // k1 = -0.3 alone: r(1 - 0.3 r²) folds at r² = 1/0.9.
        let c = Radtan {
            k1: -0.3,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
            k3: 0.0,
            ..radtan()
        };
        assert!(c.radially_monotonic(1.0 / 0.9 - 1e-9));
        assert!(!c.radially_monotonic(1.0 / 0.9 + 1e-9));
        assert!(c.project(&Vector3::new(1.1, 0.0, 1.0)).is_none());
        assert!(c.project(&Vector3::new(1.0, 0.0, 1.0)).is_some());
        // The largest distorted radius is r_max (1 − 0.3 r_max²) = 0.7027; a pixel beyond it has
        // no preimage.
        let r_max = (1.0f64 / 0.9).sqrt();
        let d_max = r_max * (1.0 - 0.3 * r_max * r_max);
        let beyond = Vector2::new(c.cx + c.fx * (d_max + 0.01), c.cy);
        assert!(c.unproject(&beyond).is_none());
        let inside = Vector2::new(c.cx + c.fx * (d_max - 0.01), c.cy);
        let b = c.unproject(&inside).expect("inside");
        assert!((c.project(&b).expect("valid") - inside).norm() < RADTAN_TOLERANCE_PX);
        assert!(c.unproject(&Vector2::new(f64::NAN, 0.0)).is_none());
        assert!(c.project(&Vector3::new(0.0, 0.0, -1.0)).is_none());
        // A positive k2 after the fold makes the slope positive again: still invalid past it.
        let c = Radtan {
            k1: -0.5,
            k2: 0.06,
            ..c
        };
        // slope 1 − 1.5 s + 0.3 s² has roots s = 0.7767 and 4.29.
        assert!(!c.radially_monotonic(5.0));
        assert!(c.radial_slope(5.0) > 0.0);
        assert!(c.radially_monotonic(0.7));
    }

    #[test]
    fn new_models_parse_by_type() {
        let j = r#"{"type":"radtan","fx":1,"fy":1,"cx":0,"cy":0,"k1":0.1,"k2":0,"p1":0,"p2":0,"width":10,"height":10}"#;
        let c: Camera = serde_json::from_str(j).expect("k3 defaults to 0");
        assert!(matches!(c, Camera::Radtan(Radtan { k3: 0.0, .. })));
        let j = r#"{"type":"double_sphere","fx":1,"fy":1,"cx":0,"cy":0,"xi":-0.2,"alpha":0.6,"width":10,"height":10}"#;
        assert!(matches!(
            serde_json::from_str(j).expect("parses"),
            Camera::DoubleSphere(_)
        ));
        let j = r#"{"type":"unified","fx":1,"fy":1,"cx":0,"cy":0,"xi":0.9,"width":10,"height":10}"#;
        assert!(matches!(
            serde_json::from_str(j).expect("parses"),
            Camera::Unified(_)
        ));
    }
}
