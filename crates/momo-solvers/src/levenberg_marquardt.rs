//! Levenberg-Marquardt with Marquardt's diagonal scaling and Nielsen's damping update.

use crate::common;
use crate::linalg::solve_damped;
use momo_core::{LeastSquares, Linearization, ParamVec, Solver, SolverReport, Termination};
use serde::{Deserialize, Serialize};

/// Levenberg-Marquardt: the step solves `(H + λ diag H) δ = -g` (Marquardt's scaling, so that λ
/// does not depend on the parameters' units), and the trial point is linearised right away
/// (one pass over the residuals gives its cost and, if it is accepted, the next normal
/// equations), except for a last step predicted to end the solve, which costs one
/// [`LeastSquares::cost`] ([`skip_last_linearization`](Self::skip_last_linearization)).
///
/// The damping follows Nielsen's rule on the gain ratio `ρ = actual / predicted decrease`: an
/// accepted step (`ρ > 0`) multiplies λ by `max(1 / lambda_decrease, 1 - (2ρ - 1)³)`, a
/// rejected one by `ν` (starting at `lambda_increase`, doubling on every consecutive rejection).
///
/// One iteration is one trial step, accepted or rejected.
///
/// ```
/// use momo_solvers::LevenbergMarquardt;
/// let lm = LevenbergMarquardt::default().with_initial_lambda(1e-3).with_max_iterations(20);
/// assert_eq!(lm.initial_lambda, 1e-3);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LevenbergMarquardt {
    /// Most iterations (trial steps, accepted or rejected).
    pub max_iterations: usize,
    /// Stop ([`Termination::CostConverged`]) when the Gauss-Newton model predicts that at most
    /// this fraction of the cost can still be gained: `½ gᵀH⁺g ≤ function_tolerance · cost` at
    /// a linearised point (half the squared Newton decrement).
    /// Also when a rejected trial changes the cost by at most this fraction while the model
    /// predicts no more for it (MINPACK's rule: the rounding floor is reached).
    pub function_tolerance: f64,
    /// Stop ([`Termination::GradientConverged`]) when the gradient's max-norm is at most this.
    pub gradient_tolerance: f64,
    /// Stop ([`Termination::StepConverged`]) when the step is at most
    /// `parameter_tolerance · (|x| + parameter_tolerance)`; the small step is still taken if it
    /// decreases the cost.
    pub parameter_tolerance: f64,
    /// Damping λ of the first step, relative to the diagonal of the normal matrix.
    pub initial_lambda: f64,
    /// Factor on λ after a rejected step (doubling on each consecutive rejection).
    pub lambda_increase: f64,
    /// Largest divisor of λ after a very successful step (3 in Nielsen's rule).
    pub lambda_decrease: f64,
    /// Smallest λ.
    pub min_lambda: f64,
    /// Largest λ: beyond it no step is possible and the solver stops.
    pub max_lambda: f64,
    /// Take the last step without linearising its end point, where the problem allows it
    /// ([`LmProblem::can_finish_with_cost`]): when the Gauss-Newton model's predicted decrease,
    /// extrapolated geometrically from the last two linearised points (`p_k² / p_(k-1)`), is
    /// at most `function_tolerance · cost` and the ratio `p_k / p_(k-1)` at most 0.3, the step
    /// is tried on one [`LeastSquares::cost`]
    /// and, if it decreases the cost, taken as the last one ([`Termination::CostConverged`]);
    /// the report's normal matrix is then the one of the point before it. Saves one
    /// linearisation per solve where the convergence is linear (robust losses). `false`
    /// linearises every trial point, as before.
    pub skip_last_linearization: bool,
    /// Lengthen a step by the curvature ratio measured on the step before, for the linear
    /// convergence of a robust (iteratively re-weighted) fit, whose normal matrix
    /// overestimates the cost's curvature. After an accepted step `s` from a linearised point
    /// (cost `c`, gradient `g`, model curvature `κ_m = sᵀHs`) to a point of cost `c'`, the
    /// cost's own curvature along `s` is `κ = 2 (c' - c - gᵀs)`; the first trial from the new
    /// point is then `t δ` with `t = κ_m / κ` clamped to `[1, max_step_extrapolation]` (the
    /// minimum along `δ` of a quadratic with that curvature, if the next step is about
    /// parallel to the last, as it is when the convergence is linear). A longer trial that
    /// does not decrease the cost is retried at `t = 1` (one more iteration, same damping), and
    /// the rest of that solve takes no lengthened step. A point reached by a lengthened step
    /// does not take the last step of [`skip_last_linearization`](Self::skip_last_linearization)
    /// (the ratio of its predicted decrease to the one before is not a rate of convergence).
    /// The damping follows the gain ratio against the unscaled step's predicted decrease.
    /// `1` (the default) never lengthens a step: every pose bit-identical to before. Only
    /// problems that can scale a step ([`LmProblem::scale_step`]) use it.
    pub max_step_extrapolation: f64,
    /// Most linearisations in a solve before its last step (`0`, the default: no limit).
    /// Once a solve has linearised this many points (the start included), the next trial is
    /// taken as the last one on one [`LeastSquares::cost`], as with
    /// [`skip_last_linearization`](Self::skip_last_linearization) (where the problem allows it,
    /// [`LmProblem::can_finish_with_cost`]): accepted if it decreases the cost
    /// ([`Termination::CostConverged`]), else the solve goes on with linearised trials. `1`
    /// makes a solve from a good start one damped Gauss-Newton step (the final efficient stage's
    /// `one_step`). The report's normal matrix is then the start's.
    pub max_linearizations: usize,
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            // 1e-5: with the default configuration on KITTI 00 (200 matches) and seven simulated
            // scenarios, 1e-6 took about 1.2-1.4x the iterations for the same accuracy; 1e-4
            // saved more but lost accuracy on a four-camera fisheye rig (docs/RESULTS.md,
            // "Speed"). Gauss-Newton and dogleg keep 1e-6.
            function_tolerance: 1e-5,
            gradient_tolerance: 1e-10,
            parameter_tolerance: 1e-8,
            initial_lambda: 1e-4,
            lambda_increase: 2.0,
            lambda_decrease: 3.0,
            min_lambda: 1e-16,
            max_lambda: 1e16,
            skip_last_linearization: true,
            max_step_extrapolation: 1.0,
            max_linearizations: 0,
        }
    }
}

with_setters!(LevenbergMarquardt {
    with_max_iterations => max_iterations: usize,
    with_function_tolerance => function_tolerance: f64,
    with_gradient_tolerance => gradient_tolerance: f64,
    with_parameter_tolerance => parameter_tolerance: f64,
    with_initial_lambda => initial_lambda: f64,
    with_lambda_increase => lambda_increase: f64,
    with_lambda_decrease => lambda_decrease: f64,
    with_min_lambda => min_lambda: f64,
    with_max_lambda => max_lambda: f64,
    with_skip_last_linearization => skip_last_linearization: bool,
    with_max_step_extrapolation => max_step_extrapolation: f64,
    with_max_linearizations => max_linearizations: usize,
});

/// A least-squares problem as Levenberg-Marquardt sees it, for problems whose normal equations
/// the solver does not hold itself: a block-structured system solved by a Schur complement (the
/// mount calibration: one block per frame plus the mount), or a point on a manifold moved by a
/// retraction (the five-point refinement: a rotation and a unit translation). The dense
/// problems of momo ([`LeastSquares`], at most [`MAX_PARAMS`](momo_core::MAX_PARAMS) unknowns)
/// go through the same algorithm ([`Solver::solve`]), so there is one Levenberg-Marquardt.
///
/// The cost is `½ Σ ρ(rᵢ²)`; a linearisation holds that cost, its gradient `g` and a normal
/// matrix `H` (Gauss-Newton, or robustified), each in the problem's own layout.
pub trait LmProblem {
    /// A point: the unknowns.
    type Point: Clone;
    /// A linearisation at a point: cost, gradient, normal matrix.
    type Lin;
    /// A step in the tangent space of a point.
    type Step;
    /// Linearises at `x`. A point where the problem is not defined gives a linearisation that
    /// is not finite ([`is_finite`](Self::is_finite)); it is then rejected.
    fn linearize(&self, x: &Self::Point) -> Self::Lin;
    /// The cost at `x` alone (not finite where the problem is not defined).
    fn cost(&self, x: &Self::Point) -> f64;
    /// [`linearize`](Self::linearize) at a point whose cost is known already.
    fn linearize_known_cost(&self, x: &Self::Point, _cost: f64) -> Self::Lin {
        self.linearize(x)
    }
    /// The cost of a linearisation.
    fn lin_cost(&self, lin: &Self::Lin) -> f64;
    /// Cost, gradient and normal matrix are finite.
    fn is_finite(&self, lin: &Self::Lin) -> bool;
    /// The gradient's largest absolute entry.
    fn gradient_max_norm(&self, lin: &Self::Lin) -> f64;
    /// The step solving `(H + λ D) δ = -g`, with `D = diag H` if `scaled` (Marquardt) and no
    /// damping for `λ = 0`; `None` if the system cannot be solved.
    fn solve_damped(&self, lin: &Self::Lin, lambda: f64, scaled: bool) -> Option<Self::Step>;
    /// The decrease of the quadratic model, `-(gᵀδ + ½ δᵀHδ)`.
    fn predicted_decrease(&self, lin: &Self::Lin, step: &Self::Step) -> f64;
    /// The step is below `tol · (|x| + tol)` (Ceres' parameter tolerance).
    fn step_is_small(&self, step: &Self::Step, x: &Self::Point, tol: f64) -> bool;
    /// The point reached from `x` by `step` (`x + δ` in a vector space).
    fn retract(&self, x: &Self::Point, step: &Self::Step) -> Self::Point;
    /// Whether a solve may end on a point that was not linearised
    /// ([`LevenbergMarquardt::skip_last_linearization`]): its result then carries the gradient
    /// and normal matrix of the point before, with the new cost
    /// ([`finish_with_cost`](Self::finish_with_cost)). `false` by default.
    fn can_finish_with_cost(&self) -> bool {
        false
    }
    /// Replaces the cost of `lin` (the last linearisation) by `cost`, the cost at the final
    /// point one step away; only called if [`can_finish_with_cost`](Self::can_finish_with_cost).
    fn finish_with_cost(&self, lin: &mut Self::Lin, cost: f64) {
        let _ = (lin, cost);
    }
    /// The step `t δ` ([`LevenbergMarquardt::max_step_extrapolation`]); `None` (the default)
    /// if the problem cannot scale a step, which turns the extrapolation off.
    fn scale_step(&self, step: &Self::Step, t: f64) -> Option<Self::Step> {
        let _ = (step, t);
        None
    }
}

/// The outcome of [`LevenbergMarquardt::minimize`]: the final point, its linearisation (for a
/// covariance), the start's cost, the iterations and why it stopped. The point is never worse
/// than the start.
#[derive(Clone, Debug)]
pub struct LmRun<X, L> {
    /// The final point.
    pub x: X,
    /// Its linearisation.
    pub lin: L,
    /// The cost at the start.
    pub initial_cost: f64,
    /// Trial steps taken (accepted or rejected).
    pub iterations: usize,
    /// Why the solve stopped.
    pub termination: Termination,
}

impl LevenbergMarquardt {
    /// Minimises `problem` from `x0`: the same algorithm, options and stopping rules as
    /// [`Solver::solve`] (the start is linearised; a start that is not finite is a
    /// [`Termination::NumericalFailure`], one that satisfies the gradient tolerance is
    /// converged).
    ///
    /// ```
    /// use momo_solvers::{LevenbergMarquardt, LmProblem};
    /// // min ½ (x² - 2)² over x > 0 on the log scale: x = exp(u), steps in u.
    /// struct Sqrt2;
    /// impl LmProblem for Sqrt2 {
    ///     type Point = f64; // x
    ///     type Lin = (f64, f64, f64); // cost, gradient, normal "matrix" in u
    ///     type Step = f64;
    ///     fn linearize(&self, x: &f64) -> (f64, f64, f64) {
    ///         let r = x * x - 2.0;
    ///         let j = 2.0 * x * x; // dr/du
    ///         (0.5 * r * r, j * r, j * j)
    ///     }
    ///     fn cost(&self, x: &f64) -> f64 { 0.5 * (x * x - 2.0).powi(2) }
    ///     fn lin_cost(&self, l: &(f64, f64, f64)) -> f64 { l.0 }
    ///     fn is_finite(&self, l: &(f64, f64, f64)) -> bool {
    ///         l.0.is_finite() && l.1.is_finite() && l.2.is_finite()
    ///     }
    ///     fn gradient_max_norm(&self, l: &(f64, f64, f64)) -> f64 { l.1.abs() }
    ///     fn solve_damped(&self, l: &(f64, f64, f64), lambda: f64, scaled: bool) -> Option<f64> {
    ///         let h = l.2 + if scaled { lambda * l.2 } else { lambda };
    ///         (h > 0.0).then(|| -l.1 / h)
    ///     }
    ///     fn predicted_decrease(&self, l: &(f64, f64, f64), d: &f64) -> f64 {
    ///         -(l.1 * d + 0.5 * d * l.2 * d)
    ///     }
    ///     fn step_is_small(&self, d: &f64, x: &f64, tol: f64) -> bool {
    ///         d.abs() <= tol * (x.ln().abs() + tol)
    ///     }
    ///     fn retract(&self, x: &f64, d: &f64) -> f64 { x * d.exp() }
    /// }
    /// let run = LevenbergMarquardt::default().with_function_tolerance(1e-12).minimize(&Sqrt2, 5.0);
    /// assert!(run.termination.is_converged());
    /// assert!((run.x - 2f64.sqrt()).abs() < 1e-6, "{}", run.x);
    /// ```
    pub fn minimize<P: LmProblem>(&self, problem: &P, x0: P::Point) -> LmRun<P::Point, P::Lin> {
        let lin = problem.linearize(&x0);
        let cost = problem.lin_cost(&lin);
        let done = |termination, lin| LmRun {
            x: x0.clone(),
            lin,
            initial_cost: cost,
            iterations: 0,
            termination,
        };
        if !problem.is_finite(&lin) {
            return done(Termination::NumericalFailure, lin);
        }
        if problem.gradient_max_norm(&lin) <= self.gradient_tolerance {
            return done(Termination::GradientConverged, lin);
        }
        if self.max_iterations == 0 {
            return done(Termination::MaxIterations, lin);
        }
        self.iterate(problem, x0.clone(), lin)
    }

    /// The iterations from a linearised start that is finite and not converged.
    fn iterate<P: LmProblem>(
        &self,
        problem: &P,
        mut x: P::Point,
        mut lin: P::Lin,
    ) -> LmRun<P::Point, P::Lin> {
        let initial_cost = problem.lin_cost(&lin);
        let increase = self.lambda_increase.max(1.0 + f64::EPSILON);
        let min_factor = 1.0 / self.lambda_decrease.max(1.0);
        let mut lambda = self.initial_lambda.max(self.min_lambda).max(0.0);
        let mut nu = increase;
        let mut iterations = 0;
        // True right after a linearisation: the model test is due.
        let mut fresh = true;
        // The model's predicted decrease (relative to the cost) at the last linearised point.
        let mut last_relative: Option<f64> = None;
        // The next trial is the last one: its point is not linearised.
        let mut last_step = false;
        let finish = self.skip_last_linearization && problem.can_finish_with_cost();
        // Linearised points so far (the start's included; `max_linearizations`).
        let mut linearizations = 1;
        let capped = self.max_linearizations > 0 && problem.can_finish_with_cost();
        // The factor on the next trial step (`max_step_extrapolation`); 1: none.
        let mut extrapolate = 1.0;
        let max_t = if self.max_step_extrapolation.is_finite() {
            self.max_step_extrapolation.max(1.0)
        } else {
            1.0
        };
        let mut extrapolating = max_t > 1.0;
        // The last accepted step was lengthened: the ratio of the predicted decreases it leaves
        // says nothing about the rate of the convergence, so the last step is not extrapolated.
        let mut lengthened = false;
        let termination = 'outer: loop {
            if fresh {
                fresh = false;
                // The undamped (Gauss-Newton) step only serves the model test: one small solve.
                if let Some(gn) = problem.solve_damped(&lin, 0.0, false) {
                    let predicted = problem.predicted_decrease(&lin, &gn);
                    let cost = problem.lin_cost(&lin);
                    if predicted <= self.function_tolerance * cost {
                        break 'outer Termination::CostConverged;
                    }
                    // Linear convergence: the next point's predicted decrease extrapolated
                    // from the last two.
                    let relative = predicted / cost;
                    last_step = finish
                        && !lengthened
                        && last_relative.is_some_and(|before| {
                            let rate = relative / before;
                            rate <= LAST_STEP_MAX_RATE && relative * rate <= self.function_tolerance
                        });
                    last_relative = Some(relative);
                } else {
                    last_relative = None;
                }
                if capped && linearizations >= self.max_linearizations {
                    last_step = true;
                }
            }
            if iterations >= self.max_iterations {
                break 'outer Termination::MaxIterations;
            }
            iterations += 1;
            // The block ends only for a rejected trial; it says whether the rejection was
            // numerical (non-finite cost or linearisation, unsolvable system).
            let rejected_non_finite = 'trial: {
                let Some(step) = problem.solve_damped(&lin, lambda, true) else {
                    break 'trial true;
                };
                // A lengthened trial (`max_step_extrapolation`): `unscaled` is the solved step.
                let t = std::mem::replace(&mut extrapolate, 1.0);
                let (step, unscaled) =
                    match (t > 1.0).then(|| problem.scale_step(&step, t)).flatten() {
                        Some(longer) => (longer, Some(step)),
                        None => (step, None),
                    };
                if problem.step_is_small(&step, &x, self.parameter_tolerance) {
                    break 'outer take_final_step(problem, &mut x, &mut lin, &step);
                }
                let trial = problem.retract(&x, &step);
                if last_step {
                    // One cost evaluation decides; a rejected last step falls back to the
                    // linearised trials.
                    last_step = false;
                    let c = problem.cost(&trial);
                    let old_cost = problem.lin_cost(&lin);
                    if c.is_finite() && c < old_cost {
                        x = trial;
                        problem.finish_with_cost(&mut lin, c);
                        break 'outer Termination::CostConverged;
                    }
                    break 'trial !c.is_finite();
                }
                // Steps are rarely rejected here (the damping starts small and follows the
                // gain ratio), so the trial point is linearised right away: one pass over the
                // matches gives its cost and, when it is accepted, the next normal equations.
                let new = problem.linearize(&trial);
                linearizations += 1;
                let c = problem.lin_cost(&new);
                let old_cost = problem.lin_cost(&lin);
                let predicted =
                    problem.predicted_decrease(&lin, unscaled.as_ref().unwrap_or(&step));
                if unscaled.is_some() && !(c.is_finite() && c < old_cost && problem.is_finite(&new))
                {
                    // The lengthened trial failed: the solved step next, same damping, and no
                    // more lengthening in this solve (the cost is not near a quadratic along the
                    // steps).
                    extrapolating = false;
                    continue 'outer;
                }
                if !(c.is_finite() && c < old_cost) {
                    if common::at_noise_floor(old_cost, c, predicted, self.function_tolerance) {
                        break 'outer Termination::CostConverged;
                    }
                    break 'trial !c.is_finite();
                }
                if !problem.is_finite(&new) {
                    break 'trial true;
                }
                if extrapolating {
                    extrapolate =
                        curvature_ratio(problem, &lin, &step, old_cost - c).clamp(1.0, max_t);
                }
                x = trial;
                lin = new;
                lengthened = unscaled.is_some();
                let rho = if predicted > 0.0 {
                    (old_cost - c) / predicted
                } else {
                    1.0
                };
                let t = 2.0 * rho - 1.0;
                lambda = (lambda * (1.0 - t * t * t).max(min_factor)).max(self.min_lambda);
                nu = increase;
                if problem.gradient_max_norm(&lin) <= self.gradient_tolerance {
                    break 'outer Termination::GradientConverged;
                }
                fresh = true;
                continue 'outer;
            };
            // Rejected: more damping.
            lambda = (lambda * nu).max(self.min_lambda).max(1e-12);
            nu *= 2.0;
            if lambda.is_nan() || lambda > self.max_lambda {
                break 'outer if rejected_non_finite {
                    Termination::NumericalFailure
                } else {
                    Termination::StepConverged
                };
            }
        };
        LmRun {
            x,
            lin,
            initial_cost,
            iterations,
            termination,
        }
    }
}

/// The largest ratio of two consecutive predicted decreases for which the next one is
/// extrapolated ([`LevenbergMarquardt::skip_last_linearization`]): the convergence must be
/// clearly linear, so that the remaining gains after the last step, `p q / (1 - q)` for a rate
/// `q`, stay within 1.5 times the tolerance.
const LAST_STEP_MAX_RATE: f64 = 0.3;

/// `κ_m / κ` along the accepted step `s` from the point linearised in `lin` (cost decrease
/// `actual`): the model's curvature `sᵀHs` over the cost's, `2 (-actual - gᵀs)`
/// ([`LevenbergMarquardt::max_step_extrapolation`]); 1 where the problem cannot scale a step or
/// the cost's curvature is not positive.
fn curvature_ratio<P: LmProblem>(problem: &P, lin: &P::Lin, step: &P::Step, actual: f64) -> f64 {
    let Some(double) = problem.scale_step(step, 2.0) else {
        return 1.0;
    };
    // pd(s) = -(gᵀs + ½ κ_m), pd(2s) = -(2 gᵀs + 2 κ_m).
    let p1 = problem.predicted_decrease(lin, step);
    let p2 = problem.predicted_decrease(lin, &double);
    let kappa_model = 2.0 * p1 - p2;
    let slope = -p1 - 0.5 * kappa_model;
    let kappa = 2.0 * (-actual - slope);
    if kappa > 0.0 && kappa_model > 0.0 {
        kappa_model / kappa
    } else {
        1.0
    }
}

/// A step below the parameter tolerance ends the solve, but it is still the best guess: it is
/// taken if it decreases the cost (and the new point is linearised, for the report). Returns
/// [`Termination::StepConverged`], or [`Termination::NumericalFailure`] if the cost at the
/// trial point is not finite.
fn take_final_step<P: LmProblem>(
    problem: &P,
    x: &mut P::Point,
    lin: &mut P::Lin,
    step: &P::Step,
) -> Termination {
    let trial = problem.retract(x, step);
    let c = problem.cost(&trial);
    if !c.is_finite() {
        return Termination::NumericalFailure;
    }
    let current = problem.lin_cost(lin);
    if c < current {
        let new = problem.linearize_known_cost(&trial, c);
        // Rounding between `cost` and `linearize` may put the new point above the old one.
        if problem.is_finite(&new) && problem.lin_cost(&new) <= current {
            *x = trial;
            *lin = new;
        }
    }
    Termination::StepConverged
}

/// A dense problem of at most [`MAX_PARAMS`](momo_core::MAX_PARAMS) unknowns as an
/// [`LmProblem`]: fixed-size vectors, the leading `n` entries used.
struct Dense<'a> {
    problem: &'a dyn LeastSquares,
    n: usize,
}

impl LmProblem for Dense<'_> {
    type Point = ParamVec;
    type Lin = Linearization;
    type Step = ParamVec;
    fn linearize(&self, x: &ParamVec) -> Linearization {
        common::sanitize(self.problem.linearize(x), self.n)
    }
    fn cost(&self, x: &ParamVec) -> f64 {
        self.problem.cost(x)
    }
    fn linearize_known_cost(&self, x: &ParamVec, cost: f64) -> Linearization {
        common::sanitize(self.problem.linearize_known_cost(x, cost), self.n)
    }
    fn lin_cost(&self, lin: &Linearization) -> f64 {
        lin.cost
    }
    fn is_finite(&self, lin: &Linearization) -> bool {
        common::is_finite(lin)
    }
    fn gradient_max_norm(&self, lin: &Linearization) -> f64 {
        common::max_norm(&lin.gradient)
    }
    fn solve_damped(&self, lin: &Linearization, lambda: f64, scaled: bool) -> Option<ParamVec> {
        solve_damped(&lin.hessian, &lin.gradient, self.n, lambda, scaled).map(|(x, _)| x)
    }
    fn predicted_decrease(&self, lin: &Linearization, step: &ParamVec) -> f64 {
        common::predicted_decrease(lin, step)
    }
    fn step_is_small(&self, step: &ParamVec, x: &ParamVec, tol: f64) -> bool {
        common::step_is_small(step, x, tol)
    }
    fn retract(&self, x: &ParamVec, step: &ParamVec) -> ParamVec {
        x + step
    }
    fn can_finish_with_cost(&self) -> bool {
        true
    }
    fn finish_with_cost(&self, lin: &mut Linearization, cost: f64) {
        lin.cost = cost;
    }
    fn scale_step(&self, step: &ParamVec, t: f64) -> Option<ParamVec> {
        Some(step * t)
    }
}

#[typetag::serde(name = "levenberg_marquardt")]
impl Solver for LevenbergMarquardt {
    fn solve(&self, problem: &dyn LeastSquares, x0: &ParamVec) -> SolverReport {
        let common::Start { x, lin, n } =
            match common::start(problem, x0, self.gradient_tolerance, self.max_iterations) {
                common::Begin::Go(s) => s,
                common::Begin::Done(report) => return report,
            };
        let run = self.iterate(&Dense { problem, n }, x, lin);
        common::report(
            run.x,
            n,
            run.initial_cost,
            run.lin.cost,
            run.iterations,
            run.termination,
            run.lin.hessian,
        )
    }
}
