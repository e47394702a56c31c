//! [`AnglePlane`]: the paper's metric, valid for every central camera.

use crate::NORM_EPS_SQ;
use momo_core::{
    Camera, Observation, Pose, ResidualMetric, Scalar, dot_const, essential, mul_const,
};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// The sine of the angle between the line of sight of a match in frame k and its epipolar plane
/// (the paper's *AnglePlane*, Sec. III-A):
///
/// `r = f1ᵀ E f0 / ‖E f0‖`, with `E = Rᵀ [t]ₓ` ([`momo_core::essential`]).
///
/// `E f0` is the normal of the epipolar plane spanned by the baseline and `f0`, expressed in the
/// camera at frame k, so `r` is the sine of the angle between `f1` and that plane. One residual
/// per match, dimensionless (radians for small angles); works on bearings, hence with any central
/// camera model (pinhole and Kannala-Brandt fisheye alike).
///
/// Degenerate geometry: the norm is evaluated as `sqrt(‖E f0‖² + 1e-24)`, so a match on the
/// baseline (`E f0 = 0`) or a standstill (`t = 0`) gives a finite residual and finite derivatives
/// (no NaN, also on dual numbers) instead of `0 / 0`. At a standstill the residual carries no
/// information; the odometry driver switches to [`momo_core::RotationOnly`] there.
///
/// ```
/// use momo_core::{Camera, Observation, Pose, ResidualMetric, Pinhole};
/// use momo_costs::AnglePlane;
/// use nalgebra::{Matrix3, Vector2, Vector3};
///
/// let cam = Camera::Pinhole(Pinhole { fx: 500.0, fy: 500.0, cx: 320.0, cy: 240.0, width: 640.0, height: 480.0 });
/// // Camera moves 1 m forward (along its z axis); a point 10 m ahead, 1 m to the right.
/// let c = Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, 1.0));
/// let x0 = Vector3::new(1.0, 0.2, 10.0);
/// let x1 = x0 - c.translation; // the same point seen from frame k
/// let obs = Observation { px0: Vector2::zeros(), px1: Vector2::zeros(), f0: x0.normalize(), f1: x1.normalize() };
/// let mut r = [0.0];
/// AnglePlane.residuals(&AnglePlane.prepare(&cam, &c), &obs, &mut r);
/// assert!(r[0].abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct AnglePlane;

impl ResidualMetric for AnglePlane {
    const RESIDUALS: usize = 1;

    /// The essential matrix `E = Rᵀ [t]ₓ`.
    type Prepared<T: Scalar> = Matrix3<T>;

    fn prepare<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>) -> Matrix3<T> {
        essential(motion)
    }

    #[inline]
    fn residuals<T: Scalar>(&self, e: &Matrix3<T>, obs: &Observation, out: &mut [T]) {
        // Constants stay f64: dual x f64 products are cheap (the per-match hot path).
        let n = mul_const(e, &obs.f0);
        out[0] = dot_const(&n, &obs.f1) / (n.norm_squared() + T::c(NORM_EPS_SQ)).sqrt();
    }
}

momo_core::register_metric!(AnglePlane, "angle_plane");
