//! [`GeoLine`]: the symmetric distance of the pixels to their epipolar lines (pinhole only).

use crate::NORM_EPS_SQ;
use momo_core::{
    Camera, Observation, Pose, ResidualMetric, Scalar, dot_const, essential, mul_const,
    tr_mul_const,
};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// The fundamental matrix `F = K⁻ᵀ E K⁻¹` of a pinhole camera for the camera motion `C`, so that
/// `x1ᵀ F x0 = 0` for homogeneous pixels `x = (u, v, 1)` (the paper, Sec. III-A).
///
/// For a camera that is not a pinhole `K = I` is used, i.e. `F = E`; metrics that call this
/// reject such cameras in [`ResidualMetric::supports`].
#[inline]
pub fn fundamental<T: Scalar>(camera: &Camera, motion: &Pose<T>) -> Matrix3<T> {
    let e = essential(motion);
    match camera.as_pinhole() {
        Some(p) => {
            let k_inv = p.k_inv().map(T::c);
            k_inv.transpose() * e * k_inv
        }
        None => e,
    }
}

/// The pinhole-only reason shared by the pixel metrics.
pub(crate) fn pinhole_only(camera: &Camera) -> Result<(), String> {
    match camera {
        Camera::Pinhole(_) => Ok(()),
        _ => Err("it measures distances in pixels of a pinhole image; \
             use angle_plane (or sampson) for kannala_brandt, radtan, double_sphere and unified \
             cameras"
            .into()),
    }
}

/// Homogeneous pixel `(u, v, 1)` lifted into the scalar type.
#[inline]
pub(crate) fn homogeneous<T: Scalar>(px: &nalgebra::Vector2<f64>) -> Vector3<T> {
    Vector3::new(T::c(px.x), T::c(px.y), T::one())
}

/// The geometric distance of each pixel to its epipolar line, in pixels (the paper's *GeoLine*,
/// Sec. III-A):
///
/// `r₀ = x1ᵀ F x0 / sqrt((F x0)₁² + (F x0)₂²)`, `r₁ = x0ᵀ Fᵀ x1 / sqrt((Fᵀ x1)₁² + (Fᵀ x1)₂²)`,
///
/// with `F = K⁻ᵀ E K⁻¹` ([`fundamental`]) and homogeneous pixels `x = (u, v, 1)`. Two residuals
/// per match (the paper sums both squares). Pinhole cameras only: [`supports`](ResidualMetric::supports)
/// returns an error for the other models. The residuals use the pixels `px0`, `px1` of the
/// [`Observation`], not its bearings. Line normals are guarded like [`crate::AnglePlane`]'s
/// (`sqrt(‖·‖² + 1e-24)`), so degenerate lines give finite values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct GeoLine;

impl ResidualMetric for GeoLine {
    const RESIDUALS: usize = 2;

    /// The fundamental matrix `F`.
    type Prepared<T: Scalar> = Matrix3<T>;

    fn supports(&self, camera: &Camera) -> Result<(), String> {
        pinhole_only(camera)
    }

    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> Matrix3<T> {
        fundamental(camera, motion)
    }

    #[inline]
    fn residuals<T: Scalar>(&self, f: &Matrix3<T>, obs: &Observation, out: &mut [T]) {
        // Pixels stay f64: dual x f64 products are cheap (the per-match hot path).
        let x0 = homogeneous::<f64>(&obs.px0);
        let x1 = homogeneous::<f64>(&obs.px1);
        let l1 = mul_const(f, &x0); // epipolar line of x0 in image k
        let l0 = tr_mul_const(f, &x1); // epipolar line of x1 in image k-1
        let num = dot_const(&l1, &x1);
        let eps = T::c(NORM_EPS_SQ);
        out[0] = num / (l1.x * l1.x + l1.y * l1.y + eps).sqrt();
        out[1] = num / (l0.x * l0.x + l0.y * l0.y + eps).sqrt();
    }
}

momo_core::register_metric!(GeoLine, "geo_line");
