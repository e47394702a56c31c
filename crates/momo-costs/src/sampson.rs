//! [`Sampson`]: the first-order geometric (Sampson) error.

use crate::NORM_EPS_SQ;
use crate::geo_line::{fundamental, homogeneous};
use momo_core::{
    Camera, Observation, Pose, ResidualMetric, Scalar, dot_const, essential, mul_const,
    tr_mul_const,
};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// The Sampson error, the first-order approximation of the reprojection error of a match
/// (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., eq. (11.9)), one residual per match,
/// in pixels.
///
/// - Pinhole camera: on homogeneous pixels `x = (u, v, 1)` with `F = K⁻ᵀ E K⁻¹`,
///   `r = x1ᵀ F x0 / sqrt((F x0)₁² + (F x0)₂² + (Fᵀ x1)₁² + (Fᵀ x1)₂²)`.
/// - Any other central camera (Kannala-Brandt): the same formula on the unit bearings, with
///   the gradients projected into the tangent planes of the unit sphere at `f0` and `f1`
///   (the first-order *angular* error), scaled by the camera's mean focal length
///   ([`Camera::focal_length`]) so that it is in (approximate) pixels as well:
///   `r = fₚₓ · f1ᵀ E f0 / sqrt(‖(I - f1 f1ᵀ) E f0‖² + ‖(I - f0 f0ᵀ) Eᵀ f1‖²)`.
///   A rig that mixes pinhole and fisheye cameras therefore sees one unit, and one loss scale
///   fits all cameras (at the centre of a fisheye image one radian is `fₚₓ` pixels).
///
/// Denominators are guarded like [`crate::AnglePlane`]'s (`sqrt(‖·‖² + 1e-24)`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Sampson;

/// Per-camera data of [`Sampson`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampsonPrepared<T: Scalar> {
    /// Pinhole camera: the fundamental matrix `F`, evaluated on pixels.
    Pixels(Matrix3<T>),
    /// Other central cameras: the essential matrix `E`, evaluated on bearings in the tangent
    /// planes, and the focal length in pixels that converts radians to pixels.
    Bearings(Matrix3<T>, f64),
}

impl ResidualMetric for Sampson {
    const RESIDUALS: usize = 1;

    type Prepared<T: Scalar> = SampsonPrepared<T>;

    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> SampsonPrepared<T> {
        match camera {
            Camera::Pinhole(_) => SampsonPrepared::Pixels(fundamental(camera, motion)),
            _ => SampsonPrepared::Bearings(essential(motion), camera.focal_length()),
        }
    }

    #[inline]
    fn residuals<T: Scalar>(&self, prep: &SampsonPrepared<T>, obs: &Observation, out: &mut [T]) {
        let eps = T::c(NORM_EPS_SQ);
        out[0] = match prep {
            SampsonPrepared::Pixels(f) => {
                let x0 = homogeneous::<f64>(&obs.px0);
                let x1 = homogeneous::<f64>(&obs.px1);
                let a = mul_const(f, &x0);
                let b = tr_mul_const(f, &x1);
                dot_const(&a, &x1) / (a.x * a.x + a.y * a.y + b.x * b.x + b.y * b.y + eps).sqrt()
            }
            SampsonPrepared::Bearings(e, focal) => {
                let (f0, f1) = (&obs.f0, &obs.f1);
                let a = mul_const(e, f0); // gradient with respect to f1
                let b = tr_mul_const(e, f1); // gradient with respect to f0
                let num = dot_const(&a, f1);
                // Tangent-plane projections: (I - f fᵀ) g = g - f (f · g), and f1 · a = f0 · b = num.
                let ga = a - f1.map(|v| num * v);
                let gb = b - f0.map(|v| num * v);
                T::c(*focal) * num / (ga.norm_squared() + gb.norm_squared() + eps).sqrt()
            }
        };
    }
}

momo_core::register_metric!(Sampson, "sampson");
