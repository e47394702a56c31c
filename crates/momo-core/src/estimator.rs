//! The dynamic outer shell: a type-erased frame estimator built once per run from a
//! configuration that names model and metric by type tag (`DESIGN.md`, "Static inner loop,
//! dynamic outer shell").
//!
//! The per-match loop is monomorphised for a (model, metric) pair inside [`erase`]; everything
//! above it works with `Box<dyn FrameEstimator>`. [`ModelSpec`] and [`MetricSpec`] are the
//! typetag-registered configuration traits; `momo_models::register_model!` implements them for
//! a new model with one line.

use crate::error::CoreError;
use crate::lie::Pose;
use crate::loss::RobustLoss;
use crate::manifold::{Manifold, MotionPrior};
use crate::metric::{ResidualMetric, RotationOnly};
use crate::problem::Problem;
use crate::rig::{FrameObservations, Rig};
use crate::solver::{LeastSquares, Solver, SolverReport};
use std::any::Any;
use std::fmt::Debug;

/// What one solve needs besides the model and metric.
#[derive(Clone, Copy, Debug)]
pub struct SolveRequest<'a> {
    /// The rig.
    pub rig: &'a Rig,
    /// The frame pair's matches per camera.
    pub observations: &'a FrameObservations,
    /// The robust loss.
    pub loss: &'a dyn RobustLoss,
    /// The solver.
    pub solver: &'a dyn Solver,
    /// Start values (full parameter vector; fixed entries keep these values).
    pub initial: &'a [f64],
    /// `fixed[i]`: hold parameter i at its start value.
    pub fixed: &'a [bool],
    /// Use the rotation-only residual (standstill): parameters that do not move the rotation
    /// are held fixed automatically.
    pub rotation_only: bool,
    /// A prior on the change of motion (usually centred on the previous frame's parameters).
    pub motion_prior: Option<&'a MotionPrior>,
}

/// The result of one solve.
#[derive(Clone, Debug)]
pub struct FrameSolution {
    /// Full parameter vector at the end.
    pub params: Vec<f64>,
    /// Indices of the parameters that were free.
    pub free: Vec<usize>,
    /// The solver's report.
    pub report: SolverReport,
    /// Matches whose residual norm is within the loss scale, per camera.
    pub inliers_per_camera: Vec<usize>,
}

impl FrameSolution {
    /// Total inliers over all cameras.
    pub fn inliers(&self) -> usize {
        self.inliers_per_camera.iter().sum()
    }
}

/// A type-erased estimator for one (model, metric) pair. Object safe.
pub trait FrameEstimator: Send + Sync + Debug {
    /// The model's parameter names.
    fn param_names(&self) -> &'static [&'static str];
    /// Index of the arc-length parameter, if any.
    fn arc_length_index(&self) -> Option<usize>;
    /// The vehicle motion for the full parameter vector.
    fn motion(&self, params: &[f64]) -> Pose<f64>;
    /// A neutral start with the given arc length.
    fn initial_params(&self, arc_length: f64) -> Vec<f64>;
    /// Closed-form parameters of a motion, if the model has them.
    fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>>;
    /// Which parameters the rig can observe.
    fn observable(&self, rig: &Rig) -> Vec<bool>;
    /// The soft manifold's prior residuals at a full parameter vector (empty for a hard
    /// manifold; [`Manifold::prior_residuals`]).
    fn prior_residuals(&self, params: &[f64]) -> Vec<f64>;
    /// Solves one frame pair.
    fn solve(&self, request: &SolveRequest<'_>) -> Result<FrameSolution, CoreError>;
    /// The cost `½ Σ ρ(|r|²)` at a full parameter vector (for landscapes and restarts).
    fn cost(&self, request: &SolveRequest<'_>, params: &[f64]) -> Result<f64, CoreError>;
}

/// The monomorphised estimator behind [`erase`].
#[derive(Clone, Debug)]
pub struct Erased<M, R> {
    /// The motion model.
    pub model: M,
    /// The residual metric.
    pub metric: R,
}

/// Erases a (model, metric) pair into a boxed [`FrameEstimator`].
pub fn erase<M: Manifold, R: ResidualMetric>(model: M, metric: R) -> Box<dyn FrameEstimator> {
    Box::new(Erased { model, metric })
}

fn run<M: Manifold, R: ResidualMetric>(
    model: &M,
    metric: &R,
    req: &SolveRequest<'_>,
    fixed: &[bool],
) -> Result<FrameSolution, CoreError> {
    let problem = Problem::new(
        model,
        metric,
        req.loss,
        req.rig,
        req.observations,
        req.initial,
    )?
    .with_fixed(fixed)
    .with_motion_prior(req.motion_prior);
    let report = req.solver.solve(&problem, &problem.free_params());
    let params = problem.full_params(&report.x);
    let scale = req.loss.scale();
    let mut inliers = vec![0; req.rig.len()];
    problem.for_each_residual_norm(&params, |j, n| {
        if n <= scale {
            inliers[j] += 1;
        }
    });
    Ok(FrameSolution {
        free: problem.free_indices().to_vec(),
        params,
        report,
        inliers_per_camera: inliers,
    })
}

impl<M: Manifold, R: ResidualMetric> FrameEstimator for Erased<M, R> {
    fn param_names(&self) -> &'static [&'static str] {
        M::PARAMS
    }
    fn arc_length_index(&self) -> Option<usize> {
        M::ARC_LENGTH
    }
    fn motion(&self, params: &[f64]) -> Pose<f64> {
        self.model.motion(params)
    }
    fn initial_params(&self, arc_length: f64) -> Vec<f64> {
        self.model.initial_params(arc_length)
    }
    fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>> {
        self.model.params_from_motion(motion)
    }
    fn observable(&self, rig: &Rig) -> Vec<bool> {
        self.model.observable(rig)
    }
    fn prior_residuals(&self, params: &[f64]) -> Vec<f64> {
        let mut q = vec![0.0; M::PRIOR_RESIDUALS];
        if params.len() == M::PARAMS.len() {
            self.model.prior_residuals(params, &mut q);
        }
        q
    }

    fn solve(&self, req: &SolveRequest<'_>) -> Result<FrameSolution, CoreError> {
        if !req.rotation_only {
            return run(&self.model, &self.metric, req, req.fixed);
        }
        // Hold every parameter that does not move the rotation at this point (found by
        // differentiating the rotation with respect to each free parameter).
        let mut fixed = req.fixed.to_vec();
        fixed.resize(M::PARAMS.len(), false);
        for i in 0..M::PARAMS.len() {
            if fixed[i] {
                continue;
            }
            let h = 1e-6;
            let mut a = req.initial.to_vec();
            let mut b = req.initial.to_vec();
            a[i] += h;
            b[i] -= h;
            let d = (self.model.motion(&a).rotation - self.model.motion(&b).rotation).amax();
            if d < 1e-12 {
                fixed[i] = true;
            }
        }
        run(&self.model, &RotationOnly, req, &fixed)
    }

    fn cost(&self, req: &SolveRequest<'_>, params: &[f64]) -> Result<f64, CoreError> {
        let problem = Problem::new(
            &self.model,
            &self.metric,
            req.loss,
            req.rig,
            req.observations,
            params,
        )?
        .with_motion_prior(req.motion_prior);
        Ok(problem.cost(&problem.free_params()))
    }
}

/// A motion model as it appears in a configuration (`[model] type = "se3"`). Implemented by
/// `momo_models::register_model!`.
#[typetag::serde(tag = "type")]
pub trait ModelSpec: Debug + Send + Sync {
    /// Builds the estimator of this model with the given metric.
    fn build(&self, metric: &dyn MetricSpec) -> Result<Box<dyn FrameEstimator>, CoreError>;
    /// For downcasting in [`MetricSpec::build_with_model`].
    fn as_any(&self) -> &dyn Any;
}

/// A residual metric as it appears in a configuration (`[metric] type = "angle_plane"`).
#[typetag::serde(tag = "type")]
pub trait MetricSpec: Debug + Send + Sync {
    /// For downcasting in [`ModelSpec::build`].
    fn as_any(&self) -> &dyn Any;
    /// For metrics defined outside momo: build with a model that does not know this metric.
    fn build_with_model(&self, _model: &dyn ModelSpec) -> Option<Box<dyn FrameEstimator>> {
        None
    }
}
