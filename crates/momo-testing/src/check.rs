//! A one-line derivative check for researchers' motion models.

use crate::{FocalScaled, canned};
use momo_core::check::{JacobianMismatch, check_motion_jacobian, check_residual_jacobian};
use momo_core::{FrameObservations, Manifold, ResidualMetric, Rig};
use momo_costs::{AnglePlane, GeoLine, Sampson};
use momo_models::{Se3, SingleTrack2d, SingleTrack3d};

/// Matches per camera at the true motion in [`check_model`] (plus [`CHECK_OFF_EPIPOLAR`]).
pub const CHECK_INLIERS: usize = 12;
/// Off-epipolar matches per camera in [`check_model`] (pixel in frame k moved by 3 to 30 px).
pub const CHECK_OFF_EPIPOLAR: usize = 4;

fn worst<M: Manifold, R: ResidualMetric>(
    acc: f64,
    model: &M,
    metric: &R,
    rig: &Rig,
    obs: &FrameObservations,
    params: &[f64],
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    check_residual_jacobian(model, metric, rig, obs, params, tol)
        .map(|e| acc.max(e))
        .map_err(|mut e| {
            e.what = format!("{} with {metric:?}: {}", std::any::type_name::<M>(), e.what);
            e
        })
}

/// Checks a motion model's automatic derivatives against central finite differences at
/// `params`, in one call: the Jacobian of the motion itself
/// ([`momo_core::check::check_motion_jacobian`]), of a soft manifold's prior residuals
/// ([`momo_core::check::check_prior_jacobian`]) and the Jacobians of the residuals of every
/// built-in metric ([`momo_core::check::check_residual_jacobian`]) on two canned rigs
/// ([`crate::canned`]): a pinhole camera ([`AnglePlane`], [`GeoLine`], [`Sampson`]) and a
/// four-camera Kannala-Brandt rig ([`AnglePlane`], [`Sampson`] in tangent planes; [`GeoLine`] is
/// pinhole only). The matches are noise-free projections under the motion at `params`
/// (residuals near zero) plus a few off-epipolar ones (non-zero residuals).
///
/// The pixel metrics are checked divided by the focal length ([`FocalScaled`]), so that `tol`
/// means the same for every metric: in pixels, the rounding noise of the finite differences
/// (steps 1e-6 and 5e-7) alone reaches ~1e-6 for short motions seen by a camera with a lever arm.
///
/// Returns the largest relative error (`|ad - fd| / max(1, |fd|)`), or the first mismatch
/// beyond `tol` (a parameter vector of the wrong length is reported as a mismatch, too).
/// `tol = 1e-6` suits models written with [`momo_core::sinc`], [`momo_core::cosc`],
/// [`momo_core::so3_exp`].
///
/// ```
/// use momo_models::Se3;
/// use momo_testing::check_model;
/// assert!(check_model(&Se3, &[0.0, 0.0, 0.0, 0.0, 0.0, 1.0], 1e-6).is_ok());
/// ```
pub fn check_model<M: Manifold>(
    model: &M,
    params: &[f64],
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    if params.len() != M::PARAMS.len() {
        return Err(JacobianMismatch {
            what: format!(
                "expected {} parameters {:?}, got {}",
                M::PARAMS.len(),
                M::PARAMS,
                params.len()
            ),
            row: 0,
            col: 0,
            ad: f64::NAN,
            fd: f64::NAN,
            error: f64::INFINITY,
            tolerance: tol,
        });
    }
    let mut acc = check_motion_jacobian(model, params, tol)?;
    acc = acc.max(momo_core::check::check_prior_jacobian(model, params, tol)?);
    let motion = model.motion(params);

    for (rig, seed) in [
        (canned::pinhole_rig(), 0x5eed_u64),
        (canned::fisheye_rig(), 0xf15e_u64),
    ] {
        let obs =
            canned::synthetic_observations(&rig, &motion, CHECK_INLIERS, CHECK_OFF_EPIPOLAR, seed);
        acc = worst(acc, model, &AnglePlane, &rig, &obs, params, tol)?;
        acc = worst(acc, model, &FocalScaled(Sampson), &rig, &obs, params, tol)?;
        // GeoLine is pinhole only.
        if rig
            .cameras()
            .iter()
            .all(|c| GeoLine.supports(&c.model).is_ok())
        {
            acc = worst(acc, model, &FocalScaled(GeoLine), &rig, &obs, params, tol)?;
        }
    }
    Ok(acc)
}

/// Checks a residual metric's automatic derivatives against central finite differences, in one
/// call: the Jacobians of its residuals ([`momo_core::check::check_residual_jacobian`]) with
/// every built-in model ([`SingleTrack2d`], [`SingleTrack3d`], [`Se3`]) at a straight and a
/// curved motion ([`check_metric_at`] at yaw 0 and 0.05 rad, 1.2 m, slight pitch and roll), on
/// the canned pinhole camera and, where the metric supports it ([`ResidualMetric::supports`]),
/// the four-camera Kannala-Brandt rig ([`crate::canned`]). The matches are as in
/// [`check_model`]. The metric is checked as it is: give `tol` in its own units (for a metric in
/// pixels, divide by the focal length ([`FocalScaled`]) or use a looser `tol`).
///
/// Returns the largest relative error, or the first mismatch beyond `tol`.
///
/// ```
/// use momo_testing::check_metric;
/// assert!(check_metric(&momo_costs::AnglePlane, 1e-6).is_ok());
/// ```
pub fn check_metric<R: ResidualMetric>(metric: &R, tol: f64) -> Result<f64, JacobianMismatch> {
    let mut acc: f64 = 0.0;
    for yaw in [0.0, 0.05] {
        acc = acc.max(check_metric_at(metric, [yaw, 1.2, 0.01, -0.005], 0, tol)?);
    }
    Ok(acc)
}

/// [`check_metric`] at one curve `[yaw, arc_length, pitch, roll]` (a [`SingleTrack3d`] motion
/// that the matches are generated from) with the canned matches of `seed`: the residual
/// Jacobians of `metric` with [`SingleTrack2d`] (yaw, arc length), [`SingleTrack3d`] and
/// [`Se3`] at that curve's parameters, on both canned rigs where the metric supports the
/// cameras. Used by [`crate::test_metric!`] with random curves and seeds.
///
/// ```
/// use momo_testing::check_metric_at;
/// assert!(check_metric_at(&momo_costs::AnglePlane, [0.2, 2.0, 0.0, 0.01], 7, 1e-6).is_ok());
/// ```
pub fn check_metric_at<R: ResidualMetric>(
    metric: &R,
    curve: [f64; 4],
    seed: u64,
    tol: f64,
) -> Result<f64, JacobianMismatch> {
    let mut acc: f64 = 0.0;
    let [yaw, l, pitch, roll] = curve;
    let st3 = [yaw, l, pitch, roll];
    let motion = SingleTrack3d::default().motion(&st3);
    let st2 = [yaw, l];
    let mut se3 = [0.0; 6];
    if let Some(p) = Se3.params_from_motion(&motion) {
        se3.copy_from_slice(&p);
    } else {
        se3 = [pitch, roll, yaw, 0.5 * yaw, 0.0, l];
    }
    let rigs = [
        (canned::pinhole_rig(), 0x5eed_u64 ^ seed),
        (canned::fisheye_rig(), 0xf15e_u64 ^ seed),
    ];
    for (rig, seed) in &rigs {
        if rig
            .cameras()
            .iter()
            .any(|c| metric.supports(&c.model).is_err())
        {
            continue;
        }
        let obs =
            canned::synthetic_observations(rig, &motion, CHECK_INLIERS, CHECK_OFF_EPIPOLAR, *seed);
        acc = worst(acc, &SingleTrack2d, metric, rig, &obs, &st2, tol)?;
        acc = worst(acc, &SingleTrack3d::default(), metric, rig, &obs, &st3, tol)?;
        acc = worst(acc, &Se3, metric, rig, &obs, &se3, tol)?;
    }
    Ok(acc)
}
