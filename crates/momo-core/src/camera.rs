//! Central camera models exactly as `FORMAT.md` defines them: [`Pinhole`] and
//! [`KannalaBrandt`] (equidistant fisheye), and the [`Camera`] enum that `rig.json` names by
//! `"type"`.
//!
//! Unprojection returns a *unit bearing vector* in the camera frame (x right, y down,
//! z forward). Pixels follow OpenCV: the centre of the top-left pixel is (0, 0).

use nalgebra::{Matrix3, Vector2, Vector3};
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

    fn size(&self) -> (f64, f64) {
        (self.width, self.height)
    }
}

/// A camera of a rig: one of the models of `FORMAT.md`, tagged by `"type"` in `rig.json`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Camera {
    /// `"type": "pinhole"`.
    Pinhole(Pinhole),
    /// `"type": "kannala_brandt"`.
    KannalaBrandt(KannalaBrandt),
}

impl Camera {
    /// The pinhole model, if this is one (metrics in pixels need it).
    pub fn as_pinhole(&self) -> Option<&Pinhole> {
        match self {
            Camera::Pinhole(p) => Some(p),
            Camera::KannalaBrandt(_) => None,
        }
    }

    /// A typical focal length in pixels (mean of `fx` and `fy`), to convert angles to pixels.
    pub fn focal_length(&self) -> f64 {
        match self {
            Camera::Pinhole(p) => 0.5 * (p.fx + p.fy),
            Camera::KannalaBrandt(k) => 0.5 * (k.fx + k.fy),
        }
    }
}

impl CameraModel for Camera {
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        match self {
            Camera::Pinhole(c) => c.project(p),
            Camera::KannalaBrandt(c) => c.project(p),
        }
    }
    fn unproject(&self, px: &Vector2<f64>) -> Option<Vector3<f64>> {
        match self {
            Camera::Pinhole(c) => c.unproject(px),
            Camera::KannalaBrandt(c) => c.unproject(px),
        }
    }
    fn size(&self) -> (f64, f64) {
        match self {
            Camera::Pinhole(c) => c.size(),
            Camera::KannalaBrandt(c) => c.size(),
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
}
