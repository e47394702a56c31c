//! [`FocalScaled`]: a pixel metric expressed in units of the focal length.

use momo_core::{Camera, Observation, Pose, ResidualMetric, Scalar};

/// Wraps a metric in pixels ([`crate::GeoLine`], [`crate::Sampson`]) and divides its residuals
/// by the camera's focal length ([`Camera::focal_length`]), so that they are in the units of
/// [`crate::AnglePlane`] (radians near the image centre).
///
/// Derivative checks use it (`momo_models::check_model`): the checks in `momo_core::check` judge `|ad - fd| / max(1, |fd|)` with a fixed step of 1e-6, and
/// in pixels the rounding noise of the finite differences alone reaches ~1e-6 for short motions
/// seen by a camera with a lever arm (the camera translation is a difference of metre-sized
/// vectors, and a pixel is 1/f of a radian), while in focal units 1e-6 means the same for every
/// metric. It can also give cameras of different focal lengths one loss scale. Not a
/// configuration type (no `MetricSpec`).
///
/// ```
/// use momo_core::{Pose, ResidualMetric, camera_motion};
/// use momo_costs::GeoLine;
/// use momo_testing::{FocalScaled, canned};
/// use nalgebra::{Matrix3, Vector3};
///
/// let rig = canned::pinhole_rig();
/// let cam = &rig.cameras()[0];
/// let m = Pose::new(Matrix3::identity(), Vector3::new(1.0, 0.0, 0.0));
/// let wrong = Pose::new(Matrix3::identity(), Vector3::new(1.0, 0.1, 0.0));
/// let o = canned::synthetic_observations(&rig, &m, 1, 0, 3).per_camera[0][0];
/// let c = camera_motion(&wrong, &cam.t_vehicle_camera);
/// let (mut px, mut rad) = ([0.0; 2], [0.0; 2]);
/// GeoLine.residuals(&GeoLine.prepare(&cam.model, &c), &o, &mut px);
/// let scaled = FocalScaled(GeoLine);
/// scaled.residuals(&scaled.prepare(&cam.model, &c), &o, &mut rad);
/// assert!((rad[0] * cam.model.focal_length() - px[0]).abs() < 1e-9);
/// ```
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct FocalScaled<R>(pub R);

impl<R: ResidualMetric> ResidualMetric for FocalScaled<R> {
    const RESIDUALS: usize = R::RESIDUALS;

    /// The inner metric's data and `1 / f`.
    type Prepared<T: Scalar> = (R::Prepared<T>, f64);

    fn supports(&self, camera: &Camera) -> Result<(), String> {
        self.0.supports(camera)
    }

    fn prepare<T: Scalar>(&self, camera: &Camera, motion: &Pose<T>) -> Self::Prepared<T> {
        (self.0.prepare(camera, motion), 1.0 / camera.focal_length())
    }

    #[inline]
    fn residuals<T: Scalar>(&self, prepared: &Self::Prepared<T>, obs: &Observation, out: &mut [T]) {
        self.0.residuals(&prepared.0, obs, out);
        let s = T::c(prepared.1);
        for r in &mut out[..R::RESIDUALS] {
            *r *= s;
        }
    }
}
