//! [`AnglePlane`]: the paper's metric, valid for every central camera.

use crate::NORM_EPS_SQ;
use momo_core::{
    Camera, MAX_KERNEL_INPUTS, Observation, Pose, ResidualMetric, Scalar, dot_const, essential,
    mul_const,
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
/// Fused kernel ([`ResidualMetric::kernel`]): the inputs are the nine entries of `E`
/// (row-major); per match, with `n = E f0`, `d = sqrt(‖n‖² + 1e-24)` and `r = (f1 · n) / d`,
/// the derivatives are `∂r/∂E_ab = g_a f0_b` with `g = (f1 − r n / d) / d`, all in plain `f64`
/// (the same order of operations as the dual-number path's real part, so the linearisation's
/// cost is bit-identical to it).
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

    const KERNEL_INPUTS: usize = 9;
    const KERNEL_INPUTS_KIND: momo_core::KernelInputsKind = momo_core::KernelInputsKind::Essential;

    /// The essential matrix `E = Rᵀ [t]ₓ`, row-major.
    fn kernel_inputs<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>, out: &mut [T]) {
        let e = essential(motion);
        for a in 0..3 {
            for b in 0..3 {
                out[3 * a + b] = e[(a, b)];
            }
        }
    }

    #[inline(always)]
    fn kernel(
        &self,
        _camera: &Camera,
        e: &[f64],
        obs: &Observation,
        _constants: &[f64],
        r: &mut [f64],
        dr_de: &mut [[f64; MAX_KERNEL_INPUTS]],
    ) {
        let (f0, f1) = (&obs.f0, &obs.f1);
        let n = [
            e[0] * f0.x + e[1] * f0.y + e[2] * f0.z,
            e[3] * f0.x + e[4] * f0.y + e[5] * f0.z,
            e[6] * f0.x + e[7] * f0.y + e[8] * f0.z,
        ];
        let num = n[0] * f1.x + n[1] * f1.y + n[2] * f1.z;
        let d = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + NORM_EPS_SQ).sqrt();
        // As num-dual divides: times the reciprocal.
        let inv_d = d.recip();
        let res = num * inv_d;
        r[0] = res;
        let k = res * inv_d;
        let row = &mut dr_de[0];
        for a in 0..3 {
            let ga = (f1[a] - k * n[a]) * inv_d;
            row[3 * a] = ga * f0.x;
            row[3 * a + 1] = ga * f0.y;
            row[3 * a + 2] = ga * f0.z;
        }
    }
}

// The final efficient stage (`[odometry.final_fit]`) refits with the maximum-likelihood
// weighting of the same angle (docs/RESULTS.md §9, eighth session).
momo_core::register_metric!(AnglePlane, "angle_plane", final_stage = "angle_plane_ml");
