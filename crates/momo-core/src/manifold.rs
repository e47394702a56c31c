//! The motion model: a low-dimensional parameterisation of the vehicle motion `T_{k-1,k}`.

use crate::lie::Pose;
use crate::rig::Rig;
use crate::scalar::Scalar;
use std::fmt::Debug;

/// The most prior residuals a [`Manifold`] may have.
pub const MAX_PRIOR_RESIDUALS: usize = 8;

/// A Gaussian prior on the change of the motion between consecutive frames (vehicle dynamics):
/// `½ Σ_i (s · (p_i − center_i) · inv_sigma_i)²` over the free parameters, with `s` the loss
/// scale (the data's noise unit). `center` is usually the previous frame's parameters and
/// `inv_sigma_i = 1 / σ_i` the inverse of how much parameter i may change from frame to frame
/// (0: no prior on it).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MotionPrior {
    /// The expected parameters (full vector of the model).
    pub center: Vec<f64>,
    /// Inverse standard deviations per parameter (full vector; 0 for none).
    pub inv_sigma: Vec<f64>,
}

impl MotionPrior {
    /// Whether the prior constrains anything.
    pub fn is_active(&self) -> bool {
        self.inv_sigma.iter().any(|w| *w != 0.0)
    }
}

/// A motion manifold (motion model): the vehicle motion `M = T_{k-1,k}` as a function of a few
/// parameters, written once over the scalar so that num-dual differentiates it.
///
/// `M` is the pose of the vehicle at frame k in the vehicle frame at k-1 (x forward, y left,
/// z up). Implementations must be exact and differentiable everywhere a vehicle goes, in
/// particular at zero yaw and zero rotation (use [`crate::sinc`], [`crate::cosc`],
/// [`crate::so3_exp`]).
///
/// ```
/// use momo_core::{Manifold, Pose, Scalar};
/// use nalgebra::{Matrix3, Vector3};
///
/// /// Straight-line motion: one parameter, the arc length.
/// #[derive(Clone, Debug)]
/// struct Straight;
///
/// impl Manifold for Straight {
///     const PARAMS: &'static [&'static str] = &["arc_length"];
///     const ARC_LENGTH: Option<usize> = Some(0);
///     fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
///         Pose::new(Matrix3::identity(), Vector3::new(p[0], T::zero(), T::zero()))
///     }
/// }
/// assert_eq!(Straight.motion(&[2.0]).translation.x, 2.0);
/// ```
pub trait Manifold: Clone + Debug + Send + Sync + 'static {
    /// Names of the parameters, in order (as in the paper: `yaw`, `arc_length`, ...).
    /// At most [`crate::MAX_PARAMS`].
    const PARAMS: &'static [&'static str];

    /// Index of the arc-length parameter, which odometry can fix, if the model has one.
    const ARC_LENGTH: Option<usize>;

    /// The vehicle motion `T_{k-1,k}` for parameters `p` (`p.len() == Self::PARAMS.len()`).
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T>;

    /// Number of prior residuals of a *soft* manifold ([`Manifold::prior_residuals`]); 0 (the
    /// default) for a hard manifold. At most [`MAX_PRIOR_RESIDUALS`].
    const PRIOR_RESIDUALS: usize = 0;

    /// The prior residuals of a soft manifold at parameters `p`: deviations from the motion
    /// the model prefers, each divided by its standard deviation (dimensionless), written to
    /// `out` (`out.len() == Self::PRIOR_RESIDUALS`). The problem adds them to the cost as
    /// `½ Σ (s · out_k)²` with `s` the loss scale (the data's noise unit), not robustified:
    /// a soft constraint instead of a hard one (a model that is a prior, not a manifold).
    /// Written once over the scalar, like [`Manifold::motion`], so num-dual differentiates it.
    fn prior_residuals<T: Scalar>(&self, _p: &[T], _out: &mut [T]) {}

    /// A neutral start: straight ahead with the given arc length (all other parameters zero).
    fn initial_params(&self, arc_length: f64) -> Vec<f64> {
        let mut p = vec![0.0; Self::PARAMS.len()];
        if let Some(i) = Self::ARC_LENGTH {
            p[i] = arc_length;
        }
        p
    }

    /// The parameters closest to a given motion, if the model can compute them in closed form
    /// (used to start from another estimator's result or from ground truth).
    fn params_from_motion(&self, _motion: &Pose<f64>) -> Option<Vec<f64>> {
        None
    }

    /// Which parameters the rig can observe. The default: all, except the arc length when every
    /// camera sits in the motion centre (then scale is unobservable, the paper's Sec. 3.5).
    fn observable(&self, rig: &Rig) -> Vec<bool> {
        let mut o = vec![true; Self::PARAMS.len()];
        if let Some(i) = Self::ARC_LENGTH {
            o[i] = rig.max_lever_arm() > 1e-3;
        }
        o
    }
}
