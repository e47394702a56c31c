//! # momo-solvers
//!
//! Solvers for the small dense robust least-squares problems of momo (1 to
//! [`MAX_PARAMS`](momo_core::MAX_PARAMS) unknowns, tens to thousands of residuals), seen through
//! their robustified normal equations ([`momo_core::LeastSquares`]):
//!
//! - [`GaussNewton`]: Gauss-Newton steps with a backtracking line search;
//! - [`LevenbergMarquardt`]: Marquardt's diagonal scaling, Nielsen's damping update; also for
//!   problems with their own linear algebra ([`LmProblem`]: the mount calibration's Schur
//!   complement, the five-point refinement on its manifold), so momo has one LM;
//! - [`Dogleg`]: Powell's dogleg in a Jacobi-scaled trust region.
//!
//! Each is a plain struct of options (`Default`, builder-style `with_*` methods, `serde` with
//! defaults for missing fields) that implements [`momo_core::Solver`], registered with typetag
//! as `"gauss_newton"`, `"levenberg_marquardt"` and `"dogleg"`, so a configuration can name it:
//! `{"type": "levenberg_marquardt", "max_iterations": 20}`.
//!
//! ## Choosing a solver
//!
//! From a warm start (the previous frame's motion) all three take the same Gauss-Newton steps
//! and converge in a few iterations; Gauss-Newton and the dogleg (whose large default radius
//! admits the Gauss-Newton step at once) are then step for step identical. They differ from a
//! bad start: Gauss-Newton backtracks along its step, Levenberg-Marquardt damps it (and spends
//! rejected trials while it learns the damping), the dogleg bends it towards steepest descent
//! within a trust region. With a robust loss whose `ρ'' ≤ 0` (Cauchy), the problem's normal
//! matrix is that of iteratively reweighted least squares, so convergence near the end is
//! linear rather than quadratic for every solver.
//!
//! ## What the solvers promise
//!
//! - The robust loss is already folded into the linearisation by the problem (Triggs
//!   correction), so a solver minimises the given cost with the given gradient and normal
//!   matrix.
//! - Every stop has a reason, a [`Termination`](momo_core::Termination):
//!   - `CostConverged`: at a linearised point the Gauss-Newton model predicts that at most
//!     `function_tolerance` of the cost can still be gained (`½ gᵀH⁺g ≤ tol · cost`, half the
//!     squared Newton decrement). This is checked *before* a step is tried, so a converged
//!     solve does not pay for one more trial and linearisation, and a big step that happens to
//!     land at about the same cost (a jump across a valley) is not mistaken for convergence.
//!     LM and dogleg also stop here when a rejected trial changes the cost by at most that
//!     fraction while the model predicts no more (MINPACK's rule for the rounding floor);
//!   - `GradientConverged`: the gradient's max-norm is at most `gradient_tolerance` (checked
//!     at the start and after every accepted step);
//!   - `StepConverged`: the step is at most `parameter_tolerance · (|x| + parameter_tolerance)`
//!     (Ceres' rule); the small step is still taken if it decreases the cost;
//!   - `MaxIterations`; `NumericalFailure` (non-finite cost or linearisation at the start, no
//!     finite point with a lower cost along the step, an unsolvable system);
//!     `NoFreeParameters` (`n = 0`: the cost is evaluated once and returned).
//! - The result is never worse than `x0` and never contains NaN: only steps that decrease the
//!   cost are taken, and a failure returns the last good point (entries beyond `n` are zero).
//! - `normal_matrix` in the report is the problem's normal matrix at the final `x` (every
//!   accepted point is linearised, so it always matches), for a covariance; `final_cost` is
//!   the cost of that linearisation.
//! - An iteration is one step computed from a linearisation and tried (accepted or rejected;
//!   for Gauss-Newton one line search); `iterations ≤ max_iterations`. Convergence is checked
//!   before the iteration limit, so a solve that converges on its last allowed step says so.
//!
//! ## Cost of a solve
//!
//! Evaluating the problem is what costs: a trial step costs one [`LeastSquares::cost`], and
//! only an accepted step is linearised ([`LeastSquares::linearize`]), so a solve of `k` accepted
//! steps costs `k + 1` linearisations. Solving the small normal equations is noise next to
//! that (LM solves the undamped system once per linearisation for the convergence test).
//! Nothing is allocated on the heap: vectors and matrices are fixed-size (`8` entries, leading
//! `n x n` block used), and so are the buffers of the SVD fallback.
//!
//! [`LeastSquares::cost`]: momo_core::LeastSquares::cost
//! [`LeastSquares::linearize`]: momo_core::LeastSquares::linearize
//!
//! ## nalgebra and faer
//!
//! The normal equations are solved by nalgebra's fixed-size Cholesky factorisation: for 2 to 6
//! unknowns it was measured about 3x faster than faer, whose routines work on dynamic sizes. faer
//! earns its place in the rank-revealing fallback ([`linalg`]): when the Cholesky factorisation
//! fails or one of its pivots reveals a dependent column (a parameter that does not affect the
//! cost, two parameters that act only together), the system is solved by faer's SVD, truncated
//! and minimum-norm, on stack buffers. A parameter the data do not determine then keeps its value
//! instead of sending the step to infinity.
//!
//! ## Example
//!
//! Fitting `y = a exp(b t)` with a problem implemented by hand:
//!
//! ```
//! use momo_core::{LeastSquares, Linearization, NormalMatrix, ParamVec, Solver, Termination};
//! use momo_solvers::{Dogleg, GaussNewton, LevenbergMarquardt};
//!
//! struct ExpFit {
//!     t: Vec<f64>,
//!     y: Vec<f64>,
//! }
//!
//! impl LeastSquares for ExpFit {
//!     fn num_params(&self) -> usize {
//!         2
//!     }
//!     fn cost(&self, x: &ParamVec) -> f64 {
//!         let r = |(t, y): (&f64, &f64)| x[0] * (x[1] * t).exp() - y;
//!         0.5 * self.t.iter().zip(&self.y).map(|p| r(p).powi(2)).sum::<f64>()
//!     }
//!     fn linearize(&self, x: &ParamVec) -> Linearization {
//!         let mut lin = Linearization {
//!             cost: 0.0,
//!             gradient: ParamVec::zeros(),
//!             hessian: NormalMatrix::zeros(),
//!         };
//!         for (t, y) in self.t.iter().zip(&self.y) {
//!             let e = (x[1] * t).exp();
//!             let r = x[0] * e - y;
//!             let mut j = ParamVec::zeros();
//!             j[0] = e;
//!             j[1] = x[0] * t * e;
//!             lin.cost += 0.5 * r * r;
//!             lin.gradient += j * r;
//!             lin.hessian += j * j.transpose();
//!         }
//!         lin
//!     }
//! }
//!
//! let t: Vec<f64> = (0..10).map(|i| 0.1 * i as f64).collect();
//! let y = t.iter().map(|t| 2.0 * (-1.5 * t).exp()).collect();
//! let problem = ExpFit { t, y };
//! let x0 = ParamVec::from_column_slice(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
//!
//! let solvers: [Box<dyn Solver>; 3] = [
//!     Box::new(GaussNewton::default()),
//!     Box::new(LevenbergMarquardt::default()),
//!     Box::new(Dogleg::default()),
//! ];
//! for solver in &solvers {
//!     let report = solver.solve(&problem, &x0);
//!     assert!(report.termination.is_converged(), "{report:?}");
//!     assert!((report.x[0] - 2.0).abs() < 1e-8 && (report.x[1] + 1.5).abs() < 1e-8);
//!     assert!(report.final_cost < 1e-16);
//! }
//!
//! // A configuration names the solver by its type tag; missing options keep their defaults.
//! let solver: Box<dyn Solver> =
//!     serde_json::from_str(r#"{"type": "levenberg_marquardt", "max_iterations": 1}"#).unwrap();
//! assert_eq!(solver.solve(&problem, &x0).termination, Termination::MaxIterations);
//! ```

/// Generates the builder-style `with_*` setters of a solver's options.
macro_rules! with_setters {
    ($ty:ident { $($setter:ident => $field:ident: $t:ty),* $(,)? }) => {
        impl $ty {
            $(
                #[doc = concat!("Sets [`Self::", stringify!($field), "`].")]
                pub fn $setter(mut self, v: $t) -> Self {
                    self.$field = v;
                    self
                }
            )*
        }
    };
}

mod common;
mod dogleg;
mod gauss_newton;
mod levenberg_marquardt;
pub mod linalg;

pub use dogleg::Dogleg;
pub use gauss_newton::GaussNewton;
pub use levenberg_marquardt::{LevenbergMarquardt, LmProblem, LmRun};
