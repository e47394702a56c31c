//! # momo-testing
//!
//! Test support for momo, kept out of the layers it tests (`momo-core` <- `momo-costs`,
//! `momo-models` <- this crate): what a researcher needs to check a new motion model or
//! residual metric in one line, and what momo's own tests, examples and benches share.
//!
//! - [`canned`]: a KITTI-like pinhole rig, a four-camera fisheye rig and deterministic
//!   noise-free matches of a given motion.
//! - [`check_model`] / [`check_metric`]: a model's (or metric's) automatic derivatives against
//!   central finite differences, with every built-in metric (model) on both canned rigs.
//! - [`test_model!`] / [`test_metric!`]: the same as property tests over a parameter box, plus
//!   the model's closed-form inverse ([`Manifold::params_from_motion`]), in the manner of
//!   factrs's `test_variable!`.
//! - [`FocalScaled`]: a pixel metric divided by the focal length, so that one tolerance means
//!   the same for every metric.
//!
//! ```
//! use momo_core::{Manifold, Pose, Scalar};
//! use momo_testing::{check_model, test_model};
//! use nalgebra::{Matrix3, Vector3};
//!
//! /// Straight ahead only: one parameter, the arc length.
//! #[derive(Clone, Debug)]
//! struct Straight;
//!
//! impl Manifold for Straight {
//!     const PARAMS: &'static [&'static str] = &["arc_length"];
//!     const ARC_LENGTH: Option<usize> = Some(0);
//!     fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
//!         Pose::new(Matrix3::identity(), Vector3::new(p[0], T::zero(), T::zero()))
//!     }
//! }
//!
//! // One call, at one parameter point ...
//! assert!(check_model(&Straight, &[1.2], 1e-6).is_ok());
//! // ... or as property tests (`#[test]` functions in a module `straight`) in a test file:
//! test_model!(straight, Straight, [0.1..3.0]);
//! ```

mod check;
mod focal_scaled;

pub mod canned;

pub use check::{CHECK_INLIERS, CHECK_OFF_EPIPOLAR, check_metric, check_metric_at, check_model};
pub use focal_scaled::FocalScaled;

/// Re-exported for the macros ([`test_model!`], [`test_metric!`]).
#[doc(hidden)]
pub use proptest;

use momo_core::{Manifold, Pose};

/// The largest difference between two motions: rotation matrix entries and translation
/// components (metres), whichever is larger.
pub fn motion_difference(a: &Pose<f64>, b: &Pose<f64>) -> f64 {
    (a.rotation - b.rotation)
        .amax()
        .max((a.translation - b.translation).amax())
}

/// Checks a model's closed-form inverse at `params`: when
/// [`Manifold::params_from_motion`] gives parameters for `motion(params)`, they must give the
/// same motion back (within `tol`; parameters themselves may differ where a model's
/// parameterisation is not unique). A model without an inverse (`None`) passes. Returns the
/// difference of the two motions (0 without an inverse).
///
/// ```
/// use momo_models::SingleTrack2d;
/// assert!(momo_testing::check_inverse(&SingleTrack2d, &[0.1, 2.0], 1e-12).unwrap() < 1e-12);
/// ```
pub fn check_inverse<M: Manifold>(model: &M, params: &[f64], tol: f64) -> Result<f64, String> {
    if params.len() != M::PARAMS.len() {
        return Err(format!(
            "expected {} parameters {:?}, got {}",
            M::PARAMS.len(),
            M::PARAMS,
            params.len()
        ));
    }
    let motion = model.motion(params);
    let Some(back) = model.params_from_motion(&motion) else {
        return Ok(0.0);
    };
    if back.len() != M::PARAMS.len() {
        return Err(format!(
            "params_from_motion gave {} parameters, the model has {}",
            back.len(),
            M::PARAMS.len()
        ));
    }
    let e = motion_difference(&motion, &model.motion(&back));
    if e.is_finite() && e <= tol {
        Ok(e)
    } else {
        Err(format!(
            "params_from_motion({params:?}) = {back:?} gives a motion {e:e} away (tolerance {tol:e})"
        ))
    }
}

/// Property tests for a motion model, in one line: a module `$name` with two `#[test]`
/// functions that draw parameter vectors uniformly from the given box (one range per
/// parameter, in [`Manifold::PARAMS`] order) and check
/// - `jacobians`: [`check_model`] (the motion's, the prior's and every built-in metric's
///   Jacobians on both canned rigs) within `1e-6` (or the tolerance given after the box);
/// - `inverse`: [`check_inverse`] within `1e-9`.
///
/// ```
/// momo_testing::test_model!(single_track_2d, momo_models::SingleTrack2d, [-0.3..0.3, 0.1..3.0]);
/// momo_testing::test_model!(se3_loose, momo_models::Se3,
///     [-0.1..0.1, -0.1..0.1, -0.3..0.3, -0.2..0.2, -0.1..0.1, 0.1..3.0], tol = 1e-5);
/// ```
#[macro_export]
macro_rules! test_model {
    ($name:ident, $model:expr, [$($lo:literal .. $hi:literal),+ $(,)?] $(,)?) => {
        $crate::test_model!($name, $model, [$($lo..$hi),+], tol = 1e-6);
    };
    ($name:ident, $model:expr, [$($lo:literal .. $hi:literal),+ $(,)?], tol = $tol:expr $(,)?) => {
        #[allow(missing_docs, dead_code)]
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            use $crate::proptest::prelude::*;

            fn params() -> impl Strategy<Value = Vec<f64>> {
                vec![$(($lo as f64)..($hi as f64)),+]
            }

            $crate::proptest::proptest! {
                #![proptest_config(ProptestConfig::with_cases(64))]

                #[test]
                fn jacobians(p in params()) {
                    let model = $model;
                    if let Err(e) = $crate::check_model(&model, &p, $tol) {
                        return Err(TestCaseError::fail(format!("at {p:?}: {e}")));
                    }
                }

                #[test]
                fn inverse(p in params()) {
                    let model = $model;
                    if let Err(e) = $crate::check_inverse(&model, &p, 1e-9) {
                        return Err(TestCaseError::fail(e));
                    }
                }
            }
        }
    };
}

/// Property tests for a residual metric, in one line: a module `$name` with a `#[test]`
/// function that draws a curve (yaw in ±0.3 rad, arc length 0.1-3 m, pitch and roll in ±0.02
/// rad) and a seed for the canned matches, and runs [`check_metric_at`] there (every built-in
/// model, both canned rigs where the metric supports the camera) within the tolerance given (in
/// the metric's own units; `1e-6` by default).
///
/// ```
/// momo_testing::test_metric!(angle_plane, momo_costs::AnglePlane);
/// momo_testing::test_metric!(sampson, momo_testing::FocalScaled(momo_costs::Sampson), tol = 1e-5);
/// ```
#[macro_export]
macro_rules! test_metric {
    ($name:ident, $metric:expr $(,)?) => {
        $crate::test_metric!($name, $metric, tol = 1e-6);
    };
    ($name:ident, $metric:expr, tol = $tol:expr $(,)?) => {
        #[allow(missing_docs, dead_code)]
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            use $crate::proptest::prelude::*;

            $crate::proptest::proptest! {
                #![proptest_config(ProptestConfig::with_cases(32))]

                #[test]
                fn jacobians(
                    yaw in -0.3..0.3f64, l in 0.1..3.0f64, pitch in -0.02..0.02f64,
                    roll in -0.02..0.02f64, seed in any::<u64>(),
                ) {
                    let metric = $metric;
                    if let Err(e) = $crate::check_metric_at(&metric, [yaw, l, pitch, roll], seed, $tol) {
                        return Err(TestCaseError::fail(format!("at {:?}, seed {seed}: {e}", [yaw, l, pitch, roll])));
                    }
                }
            }
        }
    };
}
