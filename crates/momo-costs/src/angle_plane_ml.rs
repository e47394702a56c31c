//! [`AnglePlaneMl`]: the paper's metric weighted by its pixel-noise standard deviation, so that
//! least squares on it is the (first-order) maximum-likelihood estimate under isotropic pixel
//! noise on any central camera.

use crate::NORM_EPS_SQ;
use momo_core::{
    Camera, CameraModel, Observation, Pose, ResidualMetric, Scalar, dot_const, essential,
    mul_const, tr_mul_const,
};
use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector3};
use serde::{Deserialize, Serialize};

/// [`crate::AnglePlane`] divided by its standard deviation under 1 px isotropic noise at both
/// ends of the match (issue 14), rescaled to the units of `AnglePlane` at the image centre.
///
/// Pixel noise is isotropic in the image, but `AnglePlane` measures an angle: on a fisheye,
/// and towards the edges of a pinhole image, one pixel is a different angle in different
/// directions and places. With `r = f1ᵀ E f0 / ‖E f0‖` ([`crate::AnglePlane`]) and the
/// bearing covariance per unit pixel noise `Σᵢ = Jᵢ Jᵢᵀ` (`Jᵢ` = the 3×2 Jacobian of the
/// bearing with respect to the pixel at the observed pixel, from the camera model), the
/// residual is
///
/// `r_ml = r · s_ref / sqrt(∇₁rᵀ Σ₁ ∇₁r + ∇₀rᵀ Σ₀ ∇₀r)`, `s_ref = √2 / fₚₓ`,
///
/// with `∇₁r = E f0 / ‖E f0‖` and `∇₀r = (Eᵀ f1 − r Eᵀ n / ‖n‖) / ‖n‖` (`n = E f0`). At the
/// centre of a pinhole image `Σᵢ = (I − fᵢ fᵢᵀ) / fₚₓ²`, so `r_ml ≈ r` there and the loss scales
/// of `angle_plane` fit it (radians). Like the Sampson error, the weight depends on the motion
/// (it is differentiated with it); unlike [`crate::Sampson`] off pinholes, it uses the
/// camera's true pixel-to-ray Jacobian instead of an isotropic angular error.
///
/// `Jᵢ` is `U (∂π/∂x · U)⁻¹` with `U` an orthonormal basis of the tangent plane at the bearing
/// and `∂π/∂x` the projection's Jacobian by central differences (projection is closed-form for
/// every model); where that fails (a pixel outside the model's domain) the isotropic
/// `(I − f fᵀ) / fₚₓ²` is used. No fused kernel: Jacobians by automatic differentiation.
///
/// ```
/// use momo_core::{Camera, Observation, Pose, ResidualMetric, Pinhole};
/// use momo_costs::{AnglePlane, AnglePlaneMl};
/// use nalgebra::{Matrix3, Vector2, Vector3};
///
/// let cam = Camera::Pinhole(Pinhole { fx: 500.0, fy: 500.0, cx: 320.0, cy: 240.0, width: 640.0, height: 480.0 });
/// let c = Pose::new(Matrix3::identity(), Vector3::new(0.1, 0.0, 1.0));
/// // A match near the image centre, 1 mrad off its epipolar plane.
/// let f0 = Vector3::new(0.01, 0.0, 1.0).normalize();
/// let f1 = Vector3::new(0.011, 0.001, 1.0).normalize();
/// let obs = Observation { px0: Vector2::new(325.0, 240.0), px1: Vector2::new(325.5, 240.5), f0, f1 };
/// let (mut a, mut m) = ([0.0], [0.0]);
/// AnglePlane.residuals(&AnglePlane.prepare(&cam, &c), &obs, &mut a);
/// AnglePlaneMl.residuals(&AnglePlaneMl.prepare(&cam, &c), &obs, &mut m);
/// assert!(a[0] != 0.0 && (m[0] / a[0] - 1.0).abs() < 0.2);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct AnglePlaneMl;

/// Per-camera data of [`AnglePlaneMl`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnglePlaneMlPrepared<T: Scalar> {
    /// The essential matrix `E = Rᵀ [t]ₓ`.
    pub e: Matrix3<T>,
    /// The camera (for the pixel-to-ray Jacobians).
    pub camera: Camera,
    /// `s_ref = √2 / fₚₓ`: the residual's standard deviation at the image centre.
    pub s_ref: f64,
}

/// The covariance of the unit bearing `f` under unit isotropic pixel noise, `J Jᵀ` with `J`
/// the bearing's Jacobian with respect to the pixel (see [`AnglePlaneMl`]).
pub fn bearing_covariance(camera: &Camera, f: &Vector3<f64>) -> Matrix3<f64> {
    let fl = camera.focal_length();
    let iso = (Matrix3::identity() - f * f.transpose()) / (fl * fl);
    // Tangent basis: u ⟂ f from the axis least aligned with f, v = f × u.
    let axis = if f.x.abs() <= f.y.abs() && f.x.abs() <= f.z.abs() {
        Vector3::x()
    } else if f.y.abs() <= f.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let u = f.cross(&axis).normalize();
    let v = f.cross(&u);
    let h = 1e-6;
    let mut a = Matrix2::zeros();
    for (k, d) in [u, v].iter().enumerate() {
        let (Some(p), Some(m)) = (camera.project(&(f + d * h)), camera.project(&(f - d * h)))
        else {
            return iso;
        };
        let col = (p - m) / (2.0 * h);
        a[(0, k)] = col.x;
        a[(1, k)] = col.y;
    }
    let Some(a_inv) = a.try_inverse() else {
        return iso;
    };
    let j: Matrix3x2<f64> = Matrix3x2::from_columns(&[u, v]) * a_inv;
    let cov = j * j.transpose();
    if cov.iter().all(|x| x.is_finite()) {
        cov
    } else {
        iso
    }
}

/// `gᵀ Σ g` for a constant symmetric `Σ`.
#[inline]
fn quad<T: Scalar>(s: &Matrix3<f64>, g: &Vector3<T>) -> T {
    let sg = Vector3::new(
        g.x * s[(0, 0)] + g.y * s[(0, 1)] + g.z * s[(0, 2)],
        g.x * s[(1, 0)] + g.y * s[(1, 1)] + g.z * s[(1, 2)],
        g.x * s[(2, 0)] + g.y * s[(2, 1)] + g.z * s[(2, 2)],
    );
    sg.x * g.x + sg.y * g.y + sg.z * g.z
}

impl ResidualMetric for AnglePlaneMl {
    const RESIDUALS: usize = 1;

    type Prepared<T: Scalar> = AnglePlaneMlPrepared<T>;

    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> AnglePlaneMlPrepared<T> {
        AnglePlaneMlPrepared {
            e: essential(motion),
            camera: *camera,
            s_ref: std::f64::consts::SQRT_2 / camera.focal_length(),
        }
    }

    #[inline]
    fn residuals<T: Scalar>(
        &self,
        prep: &AnglePlaneMlPrepared<T>,
        obs: &Observation,
        out: &mut [T],
    ) {
        let e = &prep.e;
        let n = mul_const(e, &obs.f0);
        let d = (n.norm_squared() + T::c(NORM_EPS_SQ)).sqrt();
        let r = dot_const(&n, &obs.f1) / d;
        let g1 = n / d;
        let etn = e.transpose() * n;
        let g0 = (tr_mul_const(e, &obs.f1) - etn * (r / d)) / d;
        let s1 = bearing_covariance(&prep.camera, &obs.f1);
        let s0 = bearing_covariance(&prep.camera, &obs.f0);
        let var = quad(&s1, &g1) + quad(&s0, &g0);
        // Guard: a vanishing gradient (standstill, degenerate geometry) keeps a finite residual.
        let floor = T::c(1e-6 * prep.s_ref * prep.s_ref);
        out[0] = r * T::c(prep.s_ref) / (var + floor).sqrt();
    }
}

momo_core::register_metric!(AnglePlaneMl, "angle_plane_ml");
