//! Gauss-Newton with a backtracking line search.

use crate::common::{self, Accepted};
use crate::linalg::solve_damped;
use momo_core::{LeastSquares, ParamVec, Solver, SolverReport, Termination};
use serde::{Deserialize, Serialize};

/// Gauss-Newton: the step solves `H δ = -g` (the robustified normal equations of the problem),
/// and a backtracking line search along it (Armijo's condition, quadratic interpolation)
/// guarantees that the cost never increases.
///
/// The fastest choice near the solution (a warm-started frame); with a bad start or a
/// strongly non-linear cost prefer [`LevenbergMarquardt`](crate::LevenbergMarquardt) or
/// [`Dogleg`](crate::Dogleg). A rank-deficient `H` (a parameter that does not affect the cost)
/// gets the minimum-norm step of the truncated SVD ([`crate::linalg`]).
///
/// One iteration is one linearisation and one step; line-search trials cost one
/// [`LeastSquares::cost`] each.
///
/// ```
/// use momo_solvers::GaussNewton;
/// let gn = GaussNewton::default().with_max_iterations(20).with_function_tolerance(1e-10);
/// assert_eq!(gn.max_iterations, 20);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GaussNewton {
    /// Most iterations (Gauss-Newton steps).
    pub max_iterations: usize,
    /// Stop ([`Termination::CostConverged`]) when the Gauss-Newton model predicts that at most
    /// this fraction of the cost can still be gained: `½ gᵀH⁺g ≤ function_tolerance · cost` at
    /// a linearised point (half the squared Newton decrement).
    pub function_tolerance: f64,
    /// Stop ([`Termination::GradientConverged`]) when the gradient's max-norm is at most this.
    pub gradient_tolerance: f64,
    /// Stop ([`Termination::StepConverged`]) when the step is at most
    /// `parameter_tolerance · (|x| + parameter_tolerance)`; the small step is still taken if it
    /// decreases the cost.
    pub parameter_tolerance: f64,
    /// Most step-length reductions of the line search per iteration.
    pub max_line_search_steps: usize,
}

impl Default for GaussNewton {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            function_tolerance: 1e-6,
            gradient_tolerance: 1e-10,
            parameter_tolerance: 1e-8,
            max_line_search_steps: 10,
        }
    }
}

with_setters!(GaussNewton {
    with_max_iterations => max_iterations: usize,
    with_function_tolerance => function_tolerance: f64,
    with_gradient_tolerance => gradient_tolerance: f64,
    with_parameter_tolerance => parameter_tolerance: f64,
    with_max_line_search_steps => max_line_search_steps: usize,
});

/// Armijo's sufficient-decrease constant.
const ARMIJO: f64 = 1e-4;

#[typetag::serde(name = "gauss_newton")]
impl Solver for GaussNewton {
    fn solve(&self, problem: &dyn LeastSquares, x0: &ParamVec) -> SolverReport {
        let common::Start { mut x, mut lin, n } =
            match common::start(problem, x0, self.gradient_tolerance, self.max_iterations) {
                common::Begin::Go(s) => s,
                common::Begin::Done(report) => return report,
            };
        let initial_cost = lin.cost;
        let mut iterations = 0;
        let termination = loop {
            let Some((step, _)) = solve_damped(&lin.hessian, &lin.gradient, n, 0.0, false) else {
                break Termination::NumericalFailure;
            };
            if common::model_converged(&lin, &step, self.function_tolerance) {
                break Termination::CostConverged;
            }
            if iterations >= self.max_iterations {
                break Termination::MaxIterations;
            }
            iterations += 1;
            if common::step_is_small(&step, &x, self.parameter_tolerance) {
                break common::take_final_step(problem, &mut x, &mut lin, &step, n);
            }
            let slope = lin.gradient.dot(&step);
            if slope.is_nan() || slope >= 0.0 {
                // Not a descent direction: the normal matrix is not positive semi-definite.
                break Termination::NumericalFailure;
            }
            let f0 = lin.cost;
            let mut alpha = 1.0;
            let mut found = None;
            for _ in 0..=self.max_line_search_steps {
                let trial = x + step * alpha;
                let c = problem.cost(&trial);
                if c.is_finite() && c < f0 && c <= f0 + ARMIJO * alpha * slope {
                    found = Some((trial, c));
                    break;
                }
                // Minimiser of the quadratic through f0, slope and c, kept in [0.1, 0.5] α.
                let denom = 2.0 * (c - f0 - slope * alpha);
                alpha = if c.is_finite() && denom > 0.0 {
                    (-slope * alpha * alpha / denom).clamp(0.1 * alpha, 0.5 * alpha)
                } else {
                    0.5 * alpha
                };
            }
            // No decrease along the step: nothing left to do from here.
            let Some((trial, c)) = found else {
                break Termination::NumericalFailure;
            };
            match common::relinearize(problem, &trial, n, f0, c) {
                Accepted::Moved(new) => {
                    x = trial;
                    lin = new;
                }
                Accepted::NonFinite => break Termination::NumericalFailure,
                Accepted::NotBetter => break Termination::CostConverged,
            }
            if common::gradient_converged(&lin, self.gradient_tolerance) {
                break Termination::GradientConverged;
            }
        };
        common::report(
            x,
            n,
            initial_cost,
            lin.cost,
            iterations,
            termination,
            lin.hessian,
        )
    }
}
