//! Powell's dogleg with a trust region.

use crate::common::{self, Accepted};
use crate::linalg::solve_damped;
use momo_core::{
    LeastSquares, Linearization, MAX_PARAMS, ParamVec, Solver, SolverReport, Termination,
};
use serde::{Deserialize, Serialize};

/// Powell's dogleg: within a trust region `|D δ| ≤ Δ` the step follows the path from the
/// Cauchy point (the minimiser of the quadratic model along the scaled steepest descent) to the
/// Gauss-Newton point, cut at the region's boundary.
///
/// The region is scaled by `D = √diag H` (Jacobi scaling, recomputed at each linearisation), so
/// that the radius does not depend on the parameters' units: `|D δ|` is about the change of the
/// (robustified) residual vector that the step causes. Both end points are computed once per
/// linearisation; a rejected step only shrinks the radius (to a quarter of the rejected step)
/// and costs one [`LeastSquares::cost`], no new factorisation. A step with gain ratio
/// `ρ > 0` is accepted; `ρ < ¼` shrinks the radius, `ρ > ¾` with a step on the boundary
/// widens it.
///
/// One iteration is one trial step, accepted or rejected.
///
/// ```
/// use momo_solvers::Dogleg;
/// let dl = Dogleg::default().with_initial_radius(1.0);
/// assert_eq!(dl.initial_radius, 1.0);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Dogleg {
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
    /// Trust-region radius of the first step, in the scaled norm `|D δ|`. The large default
    /// lets a warm-started problem take the Gauss-Newton step at once.
    pub initial_radius: f64,
    /// Largest radius.
    pub max_radius: f64,
    /// Smallest radius: below it no step is possible and the solver stops.
    pub min_radius: f64,
}

impl Default for Dogleg {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            function_tolerance: 1e-6,
            gradient_tolerance: 1e-10,
            parameter_tolerance: 1e-8,
            initial_radius: 1e4,
            max_radius: 1e16,
            min_radius: 1e-32,
        }
    }
}

with_setters!(Dogleg {
    with_max_iterations => max_iterations: usize,
    with_function_tolerance => function_tolerance: f64,
    with_gradient_tolerance => gradient_tolerance: f64,
    with_parameter_tolerance => parameter_tolerance: f64,
    with_initial_radius => initial_radius: f64,
    with_max_radius => max_radius: f64,
    with_min_radius => min_radius: f64,
});

/// The two ends of the dogleg path at one linearisation.
struct Path {
    /// Jacobi scaling `D`.
    d: ParamVec,
    /// Cauchy point (unscaled), or `None` if the model has no curvature along the gradient.
    cauchy: Option<ParamVec>,
    /// Scaled length `|D δ|` of the Cauchy point.
    cauchy_norm: f64,
    /// Scaled steepest-descent direction `-D⁻² g`, unit length in the scaled norm.
    descent: ParamVec,
    /// Gauss-Newton point, or `None` if the system could not be solved.
    gauss_newton: Option<ParamVec>,
    /// Scaled length of the Gauss-Newton point.
    gauss_newton_norm: f64,
}

impl Path {
    fn new(lin: &Linearization, n: usize) -> Self {
        let h = &lin.hessian;
        let g = &lin.gradient;
        let max_diag = (0..n).fold(0.0_f64, |m, i| m.max(h[(i, i)]));
        let floor = if max_diag > 0.0 {
            1e-12 * max_diag
        } else {
            1.0
        };
        let mut d = ParamVec::zeros();
        for i in 0..MAX_PARAMS {
            d[i] = if i < n {
                h[(i, i)].max(floor).sqrt()
            } else {
                1.0
            };
        }
        // Steepest descent in the scaled variables y = D x: g_y = D⁻¹ g, the step in x is
        // D⁻¹ (-g_y) = -D⁻² g.
        let gy = g.component_div(&d);
        let gy_norm = gy.norm();
        let dir = -gy.component_div(&d); // -D⁻² g
        let descent = if gy_norm > 0.0 {
            dir / gy_norm
        } else {
            ParamVec::zeros()
        };
        let curvature = dir.dot(&(h * dir));
        let (cauchy, cauchy_norm) = if curvature > 0.0 && gy_norm > 0.0 {
            let t = gy_norm * gy_norm / curvature;
            (Some(dir * t), t * gy_norm)
        } else {
            (None, f64::INFINITY)
        };
        let gauss_newton = solve_damped(h, g, n, 0.0, false)
            .map(|(s, _)| s)
            .filter(|s| g.dot(s) < 0.0);
        let gauss_newton_norm = gauss_newton.map_or(f64::INFINITY, |s| s.component_mul(&d).norm());
        Self {
            d,
            cauchy,
            cauchy_norm,
            descent,
            gauss_newton,
            gauss_newton_norm,
        }
    }

    /// The dogleg step for the radius.
    fn step(&self, radius: f64) -> ParamVec {
        if let Some(gn) = self.gauss_newton {
            if self.gauss_newton_norm <= radius {
                return gn;
            }
        }
        match (self.cauchy, self.gauss_newton) {
            (Some(c), Some(gn)) if self.cauchy_norm < radius => {
                // |a + τ (b - a)| = Δ in the scaled norm, τ in [0, 1].
                let a = c.component_mul(&self.d);
                let b = gn.component_mul(&self.d);
                let diff = b - a;
                let aa = a.norm_squared();
                let ad = a.dot(&diff);
                let dd = diff.norm_squared();
                let r2 = radius * radius;
                let disc = (ad * ad + dd * (r2 - aa)).max(0.0).sqrt();
                let tau = if ad <= 0.0 {
                    (disc - ad) / dd
                } else {
                    (r2 - aa) / (ad + disc)
                };
                let tau = if tau.is_finite() {
                    tau.clamp(0.0, 1.0)
                } else {
                    0.0
                };
                c + (gn - c) * tau
            }
            // No Gauss-Newton point: the Cauchy point, inside the region.
            (Some(c), None) if self.cauchy_norm < radius => c,
            // The Cauchy point is outside the region (or undefined): steepest descent to the
            // boundary.
            _ => self.descent * radius,
        }
    }
}

#[typetag::serde(name = "dogleg")]
impl Solver for Dogleg {
    fn solve(&self, problem: &dyn LeastSquares, x0: &ParamVec) -> SolverReport {
        let common::Start { mut x, mut lin, n } =
            match common::start(problem, x0, self.gradient_tolerance, self.max_iterations) {
                common::Begin::Go(s) => s,
                common::Begin::Done(report) => return report,
            };
        let initial_cost = lin.cost;
        let mut radius = self.initial_radius.min(self.max_radius);
        let mut path = Path::new(&lin, n);
        let mut iterations = 0;
        // True right after a linearisation: the model test is due.
        let mut fresh = true;
        let termination = loop {
            if fresh {
                fresh = false;
                if let Some(gn) = &path.gauss_newton {
                    if common::model_converged(&lin, gn, self.function_tolerance) {
                        break Termination::CostConverged;
                    }
                }
            }
            if iterations >= self.max_iterations {
                break Termination::MaxIterations;
            }
            if radius.is_nan() || radius < self.min_radius {
                break Termination::StepConverged;
            }
            let step = path.step(radius);
            iterations += 1;
            if common::step_is_small(&step, &x, self.parameter_tolerance) {
                break common::take_final_step(problem, &mut x, &mut lin, &step, n);
            }
            let step_norm = step.component_mul(&path.d).norm();
            let trial = x + step;
            let c = problem.cost(&trial);
            let predicted = common::predicted_decrease(&lin, &step);
            if !(c.is_finite() && c < lin.cost) {
                if common::at_noise_floor(lin.cost, c, predicted, self.function_tolerance) {
                    break Termination::CostConverged;
                }
                radius = 0.25 * step_norm.min(radius);
                if radius.is_nan() || radius < self.min_radius {
                    break if c.is_finite() {
                        Termination::StepConverged
                    } else {
                        Termination::NumericalFailure
                    };
                }
                continue;
            }
            let old_cost = lin.cost;
            match common::relinearize(problem, &trial, n, old_cost, c) {
                Accepted::Moved(new) => {
                    x = trial;
                    lin = new;
                }
                Accepted::NonFinite => {
                    radius = 0.25 * step_norm.min(radius);
                    if radius.is_nan() || radius < self.min_radius {
                        break Termination::NumericalFailure;
                    }
                    continue;
                }
                Accepted::NotBetter => break Termination::CostConverged,
            }
            let rho = if predicted > 0.0 {
                (old_cost - c) / predicted
            } else {
                1.0
            };
            if rho < 0.25 {
                radius = 0.25 * step_norm.min(radius);
            } else if rho > 0.75 && step_norm >= 0.99 * radius {
                radius = (3.0 * step_norm).max(radius).min(self.max_radius);
            }
            if common::gradient_converged(&lin, self.gradient_tolerance) {
                break Termination::GradientConverged;
            }
            path = Path::new(&lin, n);
            fresh = true;
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
