//! What the three solvers share: the start (empty problem, non-finite start, converged start),
//! tests on linearisations and steps, and the report.

use momo_core::{
    LeastSquares, Linearization, MAX_PARAMS, NormalMatrix, ParamVec, SolverReport, Termination,
};

/// A solve that may proceed: the start point, its linearisation and the number of unknowns.
pub(crate) struct Start {
    pub x: ParamVec,
    pub lin: Linearization,
    pub n: usize,
}

/// How a solve begins.
pub(crate) enum Begin {
    /// Iterate from here.
    Go(Start),
    /// Nothing to iterate: the final report.
    Done(SolverReport),
}

/// Validates the problem at `x0`: the final report for an empty problem, a non-finite start or
/// a start that already satisfies the gradient tolerance (or an iteration limit of zero), and
/// the start otherwise.
pub(crate) fn start(
    problem: &dyn LeastSquares,
    x0: &ParamVec,
    gradient_tolerance: f64,
    max_iterations: usize,
) -> Begin {
    let n = problem.num_params();
    if n > MAX_PARAMS {
        let cost = f64::NAN;
        return Begin::Done(report(
            *x0,
            n.min(MAX_PARAMS),
            cost,
            cost,
            0,
            Termination::NumericalFailure,
            NormalMatrix::zeros(),
        ));
    }
    let mut x = *x0;
    for i in n..MAX_PARAMS {
        x[i] = 0.0;
    }
    if n == 0 {
        let cost = problem.cost(&x);
        return Begin::Done(report(
            x,
            0,
            cost,
            cost,
            0,
            Termination::NoFreeParameters,
            NormalMatrix::zeros(),
        ));
    }
    let lin = sanitize(problem.linearize(&x), n);
    let fail = |t| report(x, n, lin.cost, lin.cost, 0, t, lin.hessian);
    if !x.iter().all(|v| v.is_finite()) || !is_finite(&lin) {
        return Begin::Done(fail(Termination::NumericalFailure));
    }
    if max_norm(&lin.gradient) <= gradient_tolerance {
        return Begin::Done(fail(Termination::GradientConverged));
    }
    if max_iterations == 0 {
        return Begin::Done(fail(Termination::MaxIterations));
    }
    Begin::Go(Start { x, lin, n })
}

/// Zeroes the gradient entries and normal-matrix rows and columns beyond `n`, so that
/// fixed-size products over all [`MAX_PARAMS`] entries only see the leading block.
#[inline]
pub(crate) fn sanitize(mut lin: Linearization, n: usize) -> Linearization {
    for i in n..MAX_PARAMS {
        lin.gradient[i] = 0.0;
        lin.hessian.row_mut(i).fill(0.0);
        lin.hessian.column_mut(i).fill(0.0);
    }
    lin
}

/// Cost, gradient and normal matrix are finite (assumes [`sanitize`]d).
#[inline]
pub(crate) fn is_finite(lin: &Linearization) -> bool {
    lin.cost.is_finite()
        && lin.gradient.iter().all(|v| v.is_finite())
        && lin.hessian.iter().all(|v| v.is_finite())
}

/// Largest absolute entry.
#[inline]
pub(crate) fn max_norm(v: &ParamVec) -> f64 {
    v.iter().fold(0.0_f64, |m, &x| m.max(x.abs()))
}

/// The step is below `tol · (|x| + tol)` (Ceres' parameter tolerance).
#[inline]
pub(crate) fn step_is_small(step: &ParamVec, x: &ParamVec, tol: f64) -> bool {
    step.norm() <= tol * (x.norm() + tol)
}

/// Decrease of the quadratic model `-(gᵀδ + ½ δᵀHδ)` (assumes [`sanitize`]d).
#[inline]
pub(crate) fn predicted_decrease(lin: &Linearization, step: &ParamVec) -> f64 {
    -(lin.gradient.dot(step) + 0.5 * step.dot(&(lin.hessian * step)))
}

/// The outcome of linearising at an accepted trial point.
// Returned by value on the stack: boxing the linearisation would allocate in the loop.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Accepted {
    /// The new linearisation (finite, cost not above the old one).
    Moved(Linearization),
    /// The linearisation is not finite: the point must be rejected.
    NonFinite,
    /// The linearisation's cost is above the current one (rounding between `cost` and
    /// `linearize`): the point is not better, stop at the current one.
    NotBetter,
}

/// Linearises at an accepted trial point and classifies the result.
#[inline]
pub(crate) fn relinearize(
    problem: &dyn LeastSquares,
    x: &ParamVec,
    n: usize,
    current_cost: f64,
    trial_cost: f64,
) -> Accepted {
    let lin = sanitize(problem.linearize_known_cost(x, trial_cost), n);
    if !is_finite(&lin) {
        Accepted::NonFinite
    } else if lin.cost > current_cost {
        Accepted::NotBetter
    } else {
        Accepted::Moved(lin)
    }
}

/// A step below the parameter tolerance ends the solve, but it is still the best guess: it is
/// taken if it decreases the cost (and the new point is linearised, for the report). Returns the
/// termination: [`Termination::StepConverged`], or [`Termination::NumericalFailure`] if the
/// cost at the trial point is not finite (no step possible, e.g. at the edge of the region
/// where the model is defined).
pub(crate) fn take_final_step(
    problem: &dyn LeastSquares,
    x: &mut ParamVec,
    lin: &mut Linearization,
    step: &ParamVec,
    n: usize,
) -> Termination {
    let trial = *x + step;
    let c = problem.cost(&trial);
    if !c.is_finite() {
        return Termination::NumericalFailure;
    }
    if c < lin.cost {
        if let Accepted::Moved(new) = relinearize(problem, &trial, n, lin.cost, c) {
            *x = trial;
            *lin = new;
        }
    }
    Termination::StepConverged
}

/// The gradient test after a linearisation.
#[inline]
pub(crate) fn gradient_converged(lin: &Linearization, gradient_tolerance: f64) -> bool {
    max_norm(&lin.gradient) <= gradient_tolerance
}

/// The cost test at a linearised point: the Gauss-Newton model predicts that at most
/// `function_tolerance` of the cost can still be gained, `½ gᵀH⁺g ≤ tol · cost` (half the
/// squared Newton decrement), with `gauss_newton` the step `-H⁺g`.
#[inline]
pub(crate) fn model_converged(
    lin: &Linearization,
    gauss_newton: &ParamVec,
    function_tolerance: f64,
) -> bool {
    predicted_decrease(lin, gauss_newton) <= function_tolerance * lin.cost
}

/// A rejected trial at the noise floor: both the actual and the predicted change of the cost are
/// within the function tolerance, so no step can make a significant difference.
#[inline]
pub(crate) fn at_noise_floor(
    current_cost: f64,
    trial_cost: f64,
    predicted: f64,
    function_tolerance: f64,
) -> bool {
    let tol = function_tolerance * current_cost;
    trial_cost.is_finite() && (current_cost - trial_cost).abs() <= tol && predicted <= tol
}

/// The report.
pub(crate) fn report(
    x: ParamVec,
    n: usize,
    initial_cost: f64,
    final_cost: f64,
    iterations: usize,
    termination: Termination,
    normal_matrix: NormalMatrix,
) -> SolverReport {
    SolverReport {
        x,
        num_params: n,
        initial_cost,
        final_cost,
        iterations,
        termination,
        normal_matrix,
    }
}
