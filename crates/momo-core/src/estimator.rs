//! The dynamic outer shell: a type-erased frame estimator built once per run from a
//! configuration that names model and metric by type tag (`DESIGN.md`, "Static inner loop,
//! dynamic outer shell").
//!
//! The model is erased at its motion ([`DynManifold`]), the metric at the estimator: the
//! per-match loop is monomorphised per metric (and number of free parameters) inside
//! [`Erased`]; everything above it works with `Box<dyn FrameEstimator>`. [`ModelSpec`] and
//! [`MetricSpec`] are the typetag-registered configuration traits; [`crate::register_model!`]
//! and [`crate::register_metric!`] implement them with one line, and any registered model
//! pairs with any registered metric: `metric.estimator(model.manifold())`.

use crate::dyn_manifold::DynManifold;
use crate::error::CoreError;
use crate::lie::Pose;
use crate::loss::RobustLoss;
use crate::manifold::{Manifold, MotionPrior};
use crate::metric::{ResidualMetric, RotationOnly};
use crate::problem::{GroupedLinearization, Problem};
use crate::rig::{FrameObservations, Rig};
use crate::solver::{LeastSquares, Linearization, ParamVec, Solver, SolverReport};
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
    /// Use the rotation-only residual ([`RotationOnly`], standstill): parameters that do not
    /// move the rotation at the start (found by automatic differentiation,
    /// [`DynManifold::moves_rotation`](crate::DynManifold)) are held fixed.
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
    /// Per match, all cameras in order (camera 0's matches first): whether its residual norm
    /// is within the loss scale at [`params`](Self::params) (the matches counted in
    /// [`inliers_per_camera`](Self::inliers_per_camera)).
    pub inlier_mask: Vec<bool>,
    /// Where a later stage refitted this solution but reports an earlier stage's normal matrix,
    /// cost and inliers (`momo-vo`'s `final_fit.first_stage_covariance`): the refit's own
    /// normal matrix, final cost and support size. `None` otherwise.
    pub refit_curvature: Option<(crate::NormalMatrix, f64, usize)>,
}

impl FrameSolution {
    /// Total inliers over all cameras.
    pub fn inliers(&self) -> usize {
        self.inliers_per_camera.iter().sum()
    }
}

/// A type-erased estimator for one (model, metric) pair. Object safe.
pub trait FrameEstimator: Send + Sync + Debug {
    /// The motion model.
    fn model(&self) -> &dyn DynManifold;
    /// The model's parameter names.
    fn param_names(&self) -> &[&'static str] {
        self.model().params()
    }
    /// Index of the arc-length parameter, if any.
    fn arc_length_index(&self) -> Option<usize> {
        self.model().arc_length_index()
    }
    /// The vehicle motion for the full parameter vector.
    fn motion(&self, params: &[f64]) -> Pose<f64> {
        self.model().motion_f64(params)
    }
    /// A neutral start with the given arc length.
    fn initial_params(&self, arc_length: f64) -> Vec<f64> {
        self.model().initial_params(arc_length)
    }
    /// Closed-form parameters of a motion, if the model has them.
    fn params_from_motion(&self, motion: &Pose<f64>) -> Option<Vec<f64>> {
        self.model().params_from_motion(motion)
    }
    /// Which parameters the rig can observe.
    fn observable(&self, rig: &Rig) -> Vec<bool> {
        self.model().observable(rig)
    }
    /// The soft manifold's prior residuals at a full parameter vector (empty for a hard
    /// manifold; [`Manifold::prior_residuals`]).
    fn prior_residuals(&self, params: &[f64]) -> Vec<f64> {
        let m = self.model();
        let mut q = vec![0.0; m.prior_residual_count()];
        if params.len() == m.params().len() {
            m.prior_residuals_f64(params, &mut q);
        }
        q
    }
    /// Solves one frame pair.
    fn solve(&self, request: &SolveRequest<'_>) -> Result<FrameSolution, CoreError>;
    /// The cost `½ Σ ρ(|r|²)` at a full parameter vector (for landscapes and restarts).
    fn cost(&self, request: &SolveRequest<'_>, params: &[f64]) -> Result<f64, CoreError>;
    /// The robustified normal equations over the free parameters (`request.fixed`) at a full
    /// parameter vector: what one solver iteration sees (for block-structured problems built
    /// from frames, such as the mount calibration).
    fn linearize(
        &self,
        request: &SolveRequest<'_>,
        params: &[f64],
    ) -> Result<Linearization, CoreError>;
    /// The data terms' exact robust normal equations at a full parameter vector, in total and
    /// per group of matches of each labelling, in one pass
    /// ([`Problem::exact_data_terms_by_group`]; no prior terms). `None` (the default): the
    /// estimator cannot say (`momo-vo`'s jackknife then solves each leave-one-cell-out
    /// problem in full).
    fn exact_data_terms_by_group(
        &self,
        _request: &SolveRequest<'_>,
        _params: &[f64],
        _labellings: &[(&[usize], usize)],
    ) -> Result<Option<GroupedLinearization>, CoreError> {
        Ok(None)
    }
    /// Matches whose residual norm is within the loss scale, per camera, at a full parameter
    /// vector.
    fn inliers(&self, request: &SolveRequest<'_>, params: &[f64]) -> Result<Vec<usize>, CoreError>;
    /// The residual norm `|r|` of every match (per camera, in order; the metric's units) at a
    /// full parameter vector: what a final stage estimates the noise from. The default (for
    /// estimators that cannot say) is an empty list.
    fn residual_norms(
        &self,
        _request: &SolveRequest<'_>,
        _params: &[f64],
    ) -> Result<Vec<Vec<f64>>, CoreError> {
        Ok(Vec::new())
    }
    /// The number of per-match constants of the metric
    /// ([`ResidualMetric::MATCH_CONSTANTS`]); 0 (the default): none.
    fn match_constant_count(&self) -> usize {
        0
    }
    /// The metric's per-match constants of every match of `request.observations` (camera
    /// order, [`match_constant_count`](Self::match_constant_count) each;
    /// [`crate::problem::compute_match_constants`]): computed once by a caller that evaluates
    /// the same matches, or a subset of them, several times (the final stage: the residual
    /// norms on all matches, then the refit on its support), and handed to
    /// [`solve_with_constants`](Self::solve_with_constants) and
    /// [`residual_norms_with_constants`](Self::residual_norms_with_constants). Empty (the
    /// default) for a metric without any.
    fn match_constants(&self, _request: &SolveRequest<'_>) -> Vec<f64> {
        Vec::new()
    }
    /// [`solve`](Self::solve) with the metric's per-match constants of
    /// `request.observations` given ([`match_constants`](Self::match_constants), or the
    /// constants of the matches a subset kept, in order): bit for bit the same solution, without
    /// computing them again. Empty `constants`: as `solve`; constants of the wrong length are
    /// an error. (A rotation-only solve uses another metric and ignores them.)
    fn solve_with_constants(
        &self,
        request: &SolveRequest<'_>,
        _constants: &[f64],
    ) -> Result<FrameSolution, CoreError> {
        self.solve(request)
    }
    /// [`residual_norms`](Self::residual_norms) with the metric's per-match constants given
    /// (as in [`solve_with_constants`](Self::solve_with_constants)).
    fn residual_norms_with_constants(
        &self,
        request: &SolveRequest<'_>,
        params: &[f64],
        _constants: &[f64],
    ) -> Result<Vec<Vec<f64>>, CoreError> {
        self.residual_norms(request, params)
    }
}

/// The estimator of a model with a metric: the model erased, the metric's per-match loop
/// monomorphised. Built by [`MetricSpec::estimator`] or [`erase`].
#[derive(Debug)]
pub struct Erased<R> {
    /// The motion model.
    pub model: Box<dyn DynManifold>,
    /// The residual metric.
    pub metric: R,
}

/// Erases a (model, metric) pair into a boxed [`FrameEstimator`].
pub fn erase<M: Manifold, R: ResidualMetric>(model: M, metric: R) -> Box<dyn FrameEstimator> {
    erase_dyn(Box::new(model), metric)
}

/// Pairs an erased model with a metric into a boxed [`FrameEstimator`] (what
/// [`MetricSpec::estimator`] does).
pub fn erase_dyn<R: ResidualMetric>(
    model: Box<dyn DynManifold>,
    metric: R,
) -> Box<dyn FrameEstimator> {
    Box::new(Erased { model, metric })
}

/// Counts the inliers (residual norm within the loss scale) per camera at the solver's `x`, and
/// marks them per match (all cameras in order); reuses the residuals of the solver's last
/// evaluation when it was at `x`.
fn count_inliers<R: ResidualMetric>(
    problem: &Problem<'_, R>,
    rig: &Rig,
    scale: f64,
    x: &ParamVec,
) -> (Vec<usize>, Vec<bool>) {
    let mut inliers = vec![0; rig.len()];
    let mut mask = Vec::with_capacity(problem.num_matches());
    problem.for_each_residual_norm_at(x, |j, n| {
        let inlier = n <= scale;
        inliers[j] += usize::from(inlier);
        mask.push(inlier);
    });
    (inliers, mask)
}

fn run<R: ResidualMetric>(
    model: &dyn DynManifold,
    metric: &R,
    req: &SolveRequest<'_>,
    fixed: &[bool],
    constants: &[f64],
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
    .with_motion_prior(req.motion_prior)
    .with_match_constants(constants)?;
    let report = req.solver.solve(&problem, &problem.free_params());
    let params = problem.full_params(&report.x);
    let (inliers, inlier_mask) = count_inliers(&problem, req.rig, req.loss.scale(), &report.x);
    Ok(FrameSolution {
        free: problem.free_indices().to_vec(),
        params,
        report,
        inliers_per_camera: inliers,
        inlier_mask,
        refit_curvature: None,
    })
}

impl<R: ResidualMetric> Erased<R> {
    /// The problem at `params` with the request's loss, fixed parameters and prior.
    fn problem<'a>(
        &'a self,
        req: &SolveRequest<'a>,
        params: &[f64],
    ) -> Result<Problem<'a, R>, CoreError> {
        Ok(Problem::new(
            self.model.as_ref(),
            &self.metric,
            req.loss,
            req.rig,
            req.observations,
            params,
        )?
        .with_fixed(req.fixed)
        .with_motion_prior(req.motion_prior))
    }
}

impl<R: ResidualMetric> FrameEstimator for Erased<R> {
    fn model(&self) -> &dyn DynManifold {
        self.model.as_ref()
    }

    fn solve(&self, req: &SolveRequest<'_>) -> Result<FrameSolution, CoreError> {
        self.solve_with_constants(req, &[])
    }

    fn match_constant_count(&self) -> usize {
        R::MATCH_CONSTANTS
    }

    fn match_constants(&self, req: &SolveRequest<'_>) -> Vec<f64> {
        crate::problem::compute_match_constants(&self.metric, req.rig, req.observations)
    }

    fn solve_with_constants(
        &self,
        req: &SolveRequest<'_>,
        constants: &[f64],
    ) -> Result<FrameSolution, CoreError> {
        if !req.rotation_only {
            return run(self.model.as_ref(), &self.metric, req, req.fixed, constants);
        }
        // Hold every parameter that does not move the rotation at the start.
        let np = self.model.params().len();
        let mut fixed = req.fixed.to_vec();
        fixed.resize(np, false);
        if req.initial.len() == np {
            for (f, moves) in fixed.iter_mut().zip(self.model.moves_rotation(req.initial)) {
                *f |= !moves;
            }
        }
        run(self.model.as_ref(), &RotationOnly, req, &fixed, &[])
    }

    fn cost(&self, req: &SolveRequest<'_>, params: &[f64]) -> Result<f64, CoreError> {
        let problem = Problem::new(
            self.model.as_ref(),
            &self.metric,
            req.loss,
            req.rig,
            req.observations,
            params,
        )?
        .with_motion_prior(req.motion_prior);
        Ok(problem.cost(&problem.free_params()))
    }

    fn linearize(
        &self,
        req: &SolveRequest<'_>,
        params: &[f64],
    ) -> Result<Linearization, CoreError> {
        let problem = self.problem(req, params)?;
        let x: ParamVec = problem.free_params();
        Ok(problem.linearize(&x))
    }

    fn exact_data_terms_by_group(
        &self,
        req: &SolveRequest<'_>,
        params: &[f64],
        labellings: &[(&[usize], usize)],
    ) -> Result<Option<GroupedLinearization>, CoreError> {
        let problem = self.problem(req, params)?;
        Ok(Some(problem.exact_data_terms_by_group(
            &problem.free_params(),
            labellings,
        )))
    }

    fn inliers(&self, req: &SolveRequest<'_>, params: &[f64]) -> Result<Vec<usize>, CoreError> {
        let problem = self.problem(req, params)?;
        Ok(count_inliers(&problem, req.rig, req.loss.scale(), &problem.free_params()).0)
    }

    fn residual_norms(
        &self,
        req: &SolveRequest<'_>,
        params: &[f64],
    ) -> Result<Vec<Vec<f64>>, CoreError> {
        self.residual_norms_with_constants(req, params, &[])
    }

    fn residual_norms_with_constants(
        &self,
        req: &SolveRequest<'_>,
        params: &[f64],
        constants: &[f64],
    ) -> Result<Vec<Vec<f64>>, CoreError> {
        let problem = self.problem(req, params)?.with_match_constants(constants)?;
        let mut out = vec![Vec::new(); req.rig.len()];
        problem.for_each_residual_norm(params, |j, n| out[j].push(n));
        Ok(out)
    }
}

/// A motion model as it appears in a configuration (`[model] type = "se3"`). Implemented by
/// [`crate::register_model!`].
#[typetag::serde(tag = "type")]
pub trait ModelSpec: Debug + Send + Sync {
    /// The motion model, erased.
    fn manifold(&self) -> Box<dyn DynManifold>;
    /// Builds the estimator of this model with the given metric (any registered metric:
    /// [`MetricSpec::estimator`]).
    fn build(&self, metric: &dyn MetricSpec) -> Result<Box<dyn FrameEstimator>, CoreError> {
        Ok(metric.estimator(self.manifold()))
    }
}

/// A residual metric as it appears in a configuration (`[metric] type = "angle_plane"`).
/// Implemented by [`crate::register_metric!`].
#[typetag::serde(tag = "type")]
pub trait MetricSpec: Debug + Send + Sync {
    /// The estimator of this metric with any motion model (the per-match loop compiled for
    /// this metric).
    fn estimator(&self, model: Box<dyn DynManifold>) -> Box<dyn FrameEstimator>;
    /// The registered type tag of the metric a final efficient stage should refit with after
    /// this one: the same residual in the same units, weighted for efficiency (e.g.
    /// `angle_plane` names `angle_plane_ml`, its maximum-likelihood weighting). `None` (the
    /// default): this metric itself. Declared with
    /// `register_metric!(Type, "name", final_stage = "other")`.
    fn final_stage_metric(&self) -> Option<&'static str> {
        None
    }
}

/// Registers a motion model: implements [`ModelSpec`] for `$ty` under the type tag `$name`,
/// so that a configuration names it (`[model] type = "$name"`) and it is built with every
/// registered metric, built-in or not.
///
/// `$ty` must implement [`Manifold`], `serde::Serialize` and `serde::Deserialize`. The calling
/// crate needs `serde` for the derives; `typetag` comes through this macro.
///
/// ```
/// use momo_core::{Manifold, ModelSpec, Pose, Scalar, nalgebra::{Matrix3, Vector3}};
/// use serde::{Deserialize, Serialize};
///
/// /// Straight-line motion with a vertical component.
/// #[derive(Clone, Debug, Serialize, Deserialize)]
/// struct Ramp { slope: f64 }
///
/// impl Manifold for Ramp {
///     const PARAMS: &'static [&'static str] = &["arc_length"];
///     const ARC_LENGTH: Option<usize> = Some(0);
///     fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
///         let s = T::c(self.slope);
///         Pose::new(Matrix3::identity(), Vector3::new(p[0], T::zero(), p[0] * s))
///     }
/// }
/// momo_core::register_model!(Ramp, "doc_ramp");
///
/// let spec: Box<dyn ModelSpec> = serde_json::from_str(r#"{"type": "doc_ramp", "slope": 0.1}"#).unwrap();
/// assert_eq!(spec.manifold().params(), &["arc_length"]);
/// assert!((spec.manifold().motion_f64(&[2.0]).translation.z - 0.2).abs() < 1e-15);
/// ```
#[macro_export]
macro_rules! register_model {
    ($ty:ty, $name:literal) => {
        const _: () = {
            use $crate::typetag;

            #[typetag::serde(name = $name)]
            impl $crate::ModelSpec for $ty {
                fn manifold(&self) -> ::std::boxed::Box<dyn $crate::DynManifold> {
                    ::std::boxed::Box::new(::core::clone::Clone::clone(self))
                }
            }
        };
    };
}

/// Registers a residual metric: implements [`MetricSpec`] for `$ty` under the type tag
/// `$name`, so that a configuration names it (`[metric] type = "$name"`) and every registered
/// model, built-in or not, is built with it.
///
/// `$ty` must implement [`ResidualMetric`], `Clone`, `serde::Serialize` and
/// `serde::Deserialize`.
#[macro_export]
macro_rules! register_metric {
    (@impl $ty:ty, $name:literal, $final_stage:expr) => {
        const _: () = {
            use $crate::typetag;

            #[typetag::serde(name = $name)]
            impl $crate::MetricSpec for $ty {
                fn estimator(
                    &self,
                    model: ::std::boxed::Box<dyn $crate::DynManifold>,
                ) -> ::std::boxed::Box<dyn $crate::FrameEstimator> {
                    $crate::estimator::erase_dyn(model, ::core::clone::Clone::clone(self))
                }
                fn final_stage_metric(&self) -> ::core::option::Option<&'static str> {
                    $final_stage
                }
            }
        };
    };
    ($ty:ty, $name:literal) => {
        $crate::register_metric!(@impl $ty, $name, ::core::option::Option::None);
    };
    ($ty:ty, $name:literal, final_stage = $final_stage:literal) => {
        $crate::register_metric!(
            @impl $ty,
            $name,
            ::core::option::Option::Some($final_stage)
        );
    };
}
