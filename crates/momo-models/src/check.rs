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
