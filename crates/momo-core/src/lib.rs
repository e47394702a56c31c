//! # momo-core
//!
//! The traits and the least-squares problem of momo ("Momo: Monocular Motion Estimation on
//! Manifolds"): a frame-to-frame vehicle motion is estimated by robust non-linear least squares
//! on a *motion manifold*.
//!
//! - [`Manifold`]: the motion model, `T_{k-1,k}` as a function of a few parameters, generic over
//!   the [`Scalar`] so that num-dual differentiates it;
//! - [`ResidualMetric`]: the residuals of one match given the camera motion;
//! - [`RobustLoss`]: `ρ(s)` on the squared residual (typetag-serialisable);
//! - [`Solver`]: one trait for Gauss-Newton, Levenberg-Marquardt, dogleg (in `momo-solvers`);
//! - [`Camera`], [`Rig`], [`Observation`]: the cameras of `FORMAT.md` and the matches;
//! - [`Problem`]: ties them together, `C_j = P_j⁻¹ M P_j` per camera;
//! - [`check`]: AD-versus-finite-difference checks for your own models, metrics and losses.
//!
//! ```
//! use momo_core::{Manifold, Pose, Scalar, check::check_motion_jacobian, cosc, sinc};
//! use nalgebra::{Matrix3, Vector3};
//!
//! /// Planar motion on a circle (the single-track model), written once for f64 and duals.
//! #[derive(Clone, Debug)]
//! struct Circle;
//!
//! impl Manifold for Circle {
//!     const PARAMS: &'static [&'static str] = &["yaw", "arc_length"];
//!     const ARC_LENGTH: Option<usize> = Some(1);
//!     fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
//!         let (yaw, l) = (p[0], p[1]);
//!         let (s, c) = (yaw.sin(), yaw.cos());
//!         let z = T::zero();
//!         let r = Matrix3::new(c, -s, z, s, c, z, z, z, T::one());
//!         Pose::new(r, Vector3::new(l * sinc(yaw), l * cosc(yaw), z))
//!     }
//! }
//!
//! // The AD Jacobian matches finite differences, also at exactly zero yaw.
//! assert!(check_motion_jacobian(&Circle, &[0.0, 1.2], 1e-6).is_ok());
//! assert!(check_motion_jacobian(&Circle, &[0.1, 1.2], 1e-6).is_ok());
//! ```

pub mod camera;
pub mod check;
pub mod dyn_manifold;
pub mod error;
pub mod estimator;
pub mod lie;
pub mod loss;
mod loss_trivial;
pub mod manifold;
pub mod metric;
pub mod problem;
pub mod rig;
pub mod scalar;
pub mod solver;

pub use camera::{Camera, CameraModel, DoubleSphere, KannalaBrandt, Pinhole, Radtan, Unified};
pub use dyn_manifold::{DynManifold, ErasedScalar, RuntimeManifold};
pub use error::CoreError;
pub use estimator::{
    Erased, FrameEstimator, FrameSolution, MetricSpec, ModelSpec, SolveRequest, erase, erase_dyn,
};
pub use lie::{Pose, hat, so3_exp, so3_log, vee};
pub use loss::RobustLoss;
pub use loss_trivial::TrivialLoss;
pub use manifold::{MAX_PRIOR_RESIDUALS, Manifold, MotionPrior, ROTATION_PRIOR_CAUCHY};
pub use metric::{
    KernelInputsKind, MAX_KERNEL_INPUTS, MAX_RESIDUALS, ResidualMetric, RotationOnly, essential,
};
pub use problem::{
    GroupedLinearization, Problem, camera_motion, compute_match_constants, cross_camera_motion,
};
pub use rig::{CrossObservation, FrameObservations, Observation, Rig, RigCamera};
pub use scalar::{Scalar, cosc, dot_const, mul_const, sinc, tr_mul_const};
pub use solver::{
    LeastSquares, Linearization, MAX_PARAMS, NormalMatrix, ParamVec, Solver, SolverReport,
    Termination, solve_normal_equations,
};

/// Re-exported so that downstream crates and examples use the matching versions.
pub use nalgebra;
pub use num_dual;
pub use typetag;
