//! The motion model: a low-dimensional parameterisation of the vehicle motion `T_{k-1,k}`.

use crate::lie::Pose;
use crate::rig::Rig;
use crate::scalar::Scalar;
use std::fmt::Debug;

/// The most prior residuals a [`Manifold`] may have.
pub const MAX_PRIOR_RESIDUALS: usize = 8;

/// Scale of the Cauchy loss on the normalised rotation change of [`MotionPrior`], in standard
/// deviations.
pub const ROTATION_PRIOR_CAUCHY: f64 = 3.0;

/// A prior on the change of the motion between consecutive frames (vehicle dynamics),
/// in units `s` of the data's noise ([`MotionPrior::scale`], by default the loss scale), with
/// two independent parts:
///
/// - per parameter: `½ Σ_i (s · (p_i − center_i) · inv_sigma_i)²` over the free parameters
///   (`center` is usually the previous frame's parameters, `inv_sigma_i = 1 / σ_i` how much
///   parameter i may change from frame to frame, 0 for no prior on it; both empty for none);
/// - on the rotation, for every model alike: `½ s² ρ(|d|²)` with `d = (log R(p) −
///   rotation_center) · rotation_inv_sigma`, `log R(p)` the rotation vector of the vehicle
///   motion ([`crate::so3_log`]) and `rotation_center` that of the previous frame. It limits the
///   change of the yaw, pitch and roll rates from one frame to the next whatever the parameters
///   are called (the yaw of a single-track model, the rotation vector of `Se3`). `ρ` is a
///   Cauchy loss with scale [`ROTATION_PRIOR_CAUCHY`] (in σ): Gaussian within a few σ, but a
///   change of tens of σ that the matches clearly show (a dropped frame, a sharp jolt) costs
///   only logarithmically more, so the data can still win it; a Gaussian prior would hold the
///   estimate against all of them, since the robust data cost is bounded.
///
/// ```
/// use momo_core::MotionPrior;
///
/// // 0.002 rad of rotation change per frame, centred on a motion turning by 0.01 rad.
/// let prior = MotionPrior::rotation([0.0, 0.0, 0.01], 0.002);
/// assert!(prior.is_active());
/// assert!(!MotionPrior::default().is_active());
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MotionPrior {
    /// The expected parameters (full vector of the model; empty for no per-parameter prior).
    pub center: Vec<f64>,
    /// Inverse standard deviations per parameter (full vector; 0 for none; empty for none).
    pub inv_sigma: Vec<f64>,
    /// The expected rotation vector of the vehicle motion (radians).
    pub rotation_center: [f64; 3],
    /// Inverse standard deviation of each component of the rotation vector's change (0: none).
    pub rotation_inv_sigma: f64,
    /// The expected values of a soft manifold's prior residuals
    /// ([`Manifold::prior_residuals`]), subtracted from them (empty: zero). The odometry sets
    /// it to their running mean over the recent moving frames, which removes a constant part
    /// (a camera mount a few tenths of a degree off nominal turns into a constant side slip)
    /// from the model prior. Unlike the other parts it applies on every frame.
    pub soft_center: Vec<f64>,
    /// Per prior residual of a soft manifold, a factor `k_i ≤ 1` on its centred residual
    /// `q_i − c_i` (empty: 1 for all): the residual's standard deviation becomes `σ_i / k_i`.
    /// The odometry learns it from the data (`odometry.soft_prior_sigma_learning`): where the
    /// true motion slips more than the model's `σ` (the KITTI ground truth's jittery direction
    /// of travel), a prior at the model's `σ` would bias the rotation. Like `soft_center`, it
    /// applies on every frame.
    pub soft_inv_scale: Vec<f64>,
    /// Per prior residual of a soft manifold, the scale `b_i` of a Cauchy loss on its scaled
    /// residual `z_i = k_i (q_i − c_i)` (units of its standard deviation; 0 or empty: least
    /// squares): the term becomes `½ s² b_i² ln(1 + z_i² / b_i²)`, quadratic for `|z_i| ≪ b_i`
    /// and with a bounded pull far out, so that a slip the data back strongly (the KITTI 08
    /// ground truth's chord climbing by 0.4-1.5 rad at a level body) wins against the prior
    /// while a small one is held as before (`odometry.soft_prior_cauchy`).
    pub soft_cauchy: Vec<f64>,
    /// The unit `s` of the prior terms, the data's noise in the metric's units (0: the loss
    /// scale). The odometry sets it to the first stage's loss scale, so that a second stage
    /// with a wider loss (`[refine_loss]`, Tukey 0.0075) weighs the priors as the first does:
    /// inliers cost about `½ r²` under any loss, the priors `½ s² d²`.
    pub scale: f64,
}

impl MotionPrior {
    /// A prior on the rotation only: the rotation vector may change by `sigma` radians per
    /// frame around `center`.
    pub fn rotation(center: [f64; 3], sigma: f64) -> Self {
        Self {
            rotation_center: center,
            rotation_inv_sigma: 1.0 / sigma,
            ..Self::default()
        }
    }

    /// Whether the prior constrains or shifts anything.
    pub fn is_active(&self) -> bool {
        self.inv_sigma.iter().any(|w| *w != 0.0)
            || self.rotation_inv_sigma != 0.0
            || self.soft_center.iter().any(|c| *c != 0.0)
            || self.soft_cauchy.iter().any(|b| *b > 0.0)
    }

    /// Whether the per-parameter part applies to a model with `n_params` parameters.
    pub fn has_params(&self, n_params: usize) -> bool {
        self.center.len() == n_params
            && self.inv_sigma.len() == n_params
            && self.inv_sigma.iter().any(|w| *w != 0.0)
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
    /// camera sits in the motion centre (then scale is unobservable: the paper, Sec. "Optimization on manifolds of the motion space", Fig. 3).
    fn observable(&self, rig: &Rig) -> Vec<bool> {
        let mut o = vec![true; Self::PARAMS.len()];
        if let Some(i) = Self::ARC_LENGTH {
            o[i] = rig.max_lever_arm() > 1e-3;
        }
        o
    }
}
