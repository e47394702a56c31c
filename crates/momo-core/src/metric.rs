//! Residual metrics: how far one match is from agreeing with a camera motion.

use crate::camera::Camera;
use crate::lie::Pose;
use crate::rig::Observation;
use crate::scalar::Scalar;
use std::fmt::Debug;

/// Most residuals one match may produce.
pub const MAX_RESIDUALS: usize = 3;

/// A residual metric: the residuals of one match given the camera motion `C = [R | t]`
/// (the pose of the camera at frame k in the camera at k-1), generic over the scalar.
///
/// Evaluation has two steps so that per-camera work (e.g. the essential matrix
/// `E = Rᵀ [t]_x`) is done once per camera and not once per match:
/// [`prepare`](Self::prepare) per camera and motion, then [`residuals`](Self::residuals) per match.
pub trait ResidualMetric: Clone + Debug + Send + Sync + 'static {
    /// Number of residuals per match (1..=[`MAX_RESIDUALS`]).
    const RESIDUALS: usize;

    /// Per-camera quantities derived from the camera motion.
    type Prepared<T: Scalar>;

    /// `Ok` if the metric can work with this camera model; otherwise the reason.
    fn supports(&self, _camera: &Camera) -> Result<(), String> {
        Ok(())
    }

    /// Derives the per-camera quantities from the camera motion `C`.
    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> Self::Prepared<T>;

    /// Writes the `RESIDUALS` residuals of one match into `out[..RESIDUALS]`.
    fn residuals<T: Scalar>(&self, prepared: &Self::Prepared<T>, obs: &Observation, out: &mut [T]);
}

/// The essential matrix `E = Rᵀ [t]_x` of a camera motion `C = [R | t]`, so that
/// `f1ᵀ E f0 = 0` (`docs/DESIGN.md`: coplanarity `(R f1) · (t × f0) = 0`).
///
/// The paper (Sec. "Formulation of the potential function") writes `E(M) = [t]_x R` with the
/// bearing of the earlier frame on the left, `f0ᵀ [t]_x R f1 = 0`; ours is its negative
/// transpose, `Rᵀ [t]_x = −([t]_x R)ᵀ`, for the same constraint with `f1` on the left.
#[inline]
pub fn essential<T: Scalar>(motion: &Pose<T>) -> nalgebra::Matrix3<T> {
    motion.rotation.transpose() * crate::lie::hat(&motion.translation)
}

/// The standstill metric: the angle between `f0` and `R f1`, as the three components of
/// `f0 × R f1` (their norm is the sine of the angle). Translation is ignored, so it is defined
/// when the epipolar plane is not (`t ≈ 0`). The odometry driver switches to it at standstill.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RotationOnly;

impl ResidualMetric for RotationOnly {
    const RESIDUALS: usize = 3;
    type Prepared<T: Scalar> = nalgebra::Matrix3<T>;

    fn prepare<T: Scalar>(&self, _camera: &Camera, motion: &Pose<T>) -> Self::Prepared<T> {
        motion.rotation
    }

    #[inline]
    fn residuals<T: Scalar>(&self, r: &Self::Prepared<T>, obs: &Observation, out: &mut [T]) {
        let f0 = &obs.f0;
        let rf1 = crate::scalar::mul_const(r, &obs.f1);
        // f0 × (R f1) with f0 constant.
        out[0] = rf1.z * f0.y - rf1.y * f0.z;
        out[1] = rf1.x * f0.z - rf1.z * f0.x;
        out[2] = rf1.y * f0.x - rf1.x * f0.y;
    }
}
