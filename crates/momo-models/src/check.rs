//! A one-line derivative check for researchers' motion models.

use momo_core::check::{JacobianMismatch, check_motion_jacobian, check_residual_jacobian};
use momo_core::{FrameObservations, Manifold, ResidualMetric, Rig};
use momo_costs::{AnglePlane, FocalScaled, GeoLine, Sampson, canned};

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
/// ([`momo_costs::canned`]): a pinhole camera ([`AnglePlane`], [`GeoLine`], [`Sampson`]) and a
/// four-camera Kannala-Brandt rig ([`AnglePlane`], [`Sampson`] in tangent planes; [`GeoLine`] is
/// pinhole only). The matches are noise-free projections under the motion at `params`
/// (residuals near zero) plus a few off-epipolar ones (non-zero residuals).
///
/// The pixel metrics are checked divided by the focal length ([`FocalScaled`]), so that `tol`
/// means the same for every metric: in pixels, the rounding noise of the finite differences
/// (step 1e-6) alone reaches ~1e-6 for short motions seen by a camera with a lever arm.
///
/// Returns the largest relative error (`|ad - fd| / max(1, |fd|)`), or the first mismatch
/// beyond `tol` (a parameter vector of the wrong length is reported as a mismatch, too).
/// `tol = 1e-6` suits models written with [`momo_core::sinc`], [`momo_core::cosc`],
/// [`momo_core::so3_exp`].
///
/// ```
/// use momo_models::{Se3, check_model};
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

    let pinhole = canned::pinhole_rig();
    let obs = canned::synthetic_observations(
        &pinhole,
        &motion,
        CHECK_INLIERS,
        CHECK_OFF_EPIPOLAR,
        0x5eed,
    );
    acc = worst(acc, model, &AnglePlane, &pinhole, &obs, params, tol)?;
    acc = worst(
        acc,
        model,
        &FocalScaled(GeoLine),
        &pinhole,
        &obs,
        params,
        tol,
    )?;
    acc = worst(
        acc,
        model,
        &FocalScaled(Sampson),
        &pinhole,
        &obs,
        params,
        tol,
    )?;

    let fisheye = canned::fisheye_rig();
    let obs = canned::synthetic_observations(
        &fisheye,
        &motion,
        CHECK_INLIERS,
        CHECK_OFF_EPIPOLAR,
        0xf15e,
    );
    acc = worst(acc, model, &AnglePlane, &fisheye, &obs, params, tol)?;
    acc = worst(
        acc,
        model,
        &FocalScaled(Sampson),
        &fisheye,
        &obs,
        params,
        tol,
    )?;
    Ok(acc)
}

/// Checks a residual metric's automatic derivatives against central finite differences, in one
/// call: the Jacobians of its residuals ([`momo_core::check::check_residual_jacobian`]) with
/// every built-in model ([`crate::SingleTrack2d`], [`crate::SingleTrack3d`], [`crate::Se3`])
/// at a straight and a curved motion, on the canned pinhole camera and, where the metric
/// supports it ([`ResidualMetric::supports`]), the four-camera Kannala-Brandt rig
/// ([`momo_costs::canned`]). The matches are as in [`check_model`]. The metric is checked as
/// it is: give `tol` in its own units (for a metric in pixels, divide by the focal length or
/// use a looser `tol`).
///
/// Returns the largest relative error, or the first mismatch beyond `tol`.
///
/// ```
/// use momo_models::check_metric;
/// assert!(check_metric(&momo_costs::AnglePlane, 1e-6).is_ok());
/// ```
pub fn check_metric<R: ResidualMetric>(metric: &R, tol: f64) -> Result<f64, JacobianMismatch> {
    use crate::{Se3, SingleTrack2d, SingleTrack3d};
    let mut acc: f64 = 0.0;
    let rigs = [
        (canned::pinhole_rig(), 0x5eed_u64),
        (canned::fisheye_rig(), 0xf15e_u64),
    ];
    for (rig, seed) in &rigs {
        if rig
            .cameras()
            .iter()
            .any(|c| metric.supports(&c.model).is_err())
        {
            continue;
        }
        for yaw in [0.0, 0.05] {
            let st2 = [yaw, 1.2];
            let st3 = [yaw, 1.2, 0.01, -0.005];
            let se3 = [0.01, 0.002, yaw, 0.01, 0.005, 1.2];
            let motion = SingleTrack3d::default().motion(&st3);
            let obs = canned::synthetic_observations(
                rig,
                &motion,
                CHECK_INLIERS,
                CHECK_OFF_EPIPOLAR,
                *seed,
            );
            acc = worst(acc, &SingleTrack2d, metric, rig, &obs, &st2, tol)?;
            acc = worst(acc, &SingleTrack3d::default(), metric, rig, &obs, &st3, tol)?;
            acc = worst(acc, &Se3, metric, rig, &obs, &se3, tol)?;
        }
    }
    Ok(acc)
}
