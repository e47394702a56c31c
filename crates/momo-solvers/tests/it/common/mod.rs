//! Hand-written least-squares problems for the solver tests.

#![allow(dead_code)]

use momo_core::{LeastSquares, Linearization, NormalMatrix, ParamVec, Solver};
use momo_solvers::{Dogleg, GaussNewton, LevenbergMarquardt};
use std::cell::Cell;

/// Scalar residuals and their Jacobian rows.
pub trait Residuals {
    /// Number of parameters.
    fn num_params(&self) -> usize;
    /// Calls `f(r, ∂r/∂x)` for every residual.
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec));
}

/// `½ Σ ρ(r²)` of some residuals, with `ρ` the identity or Cauchy's loss of scale `b`, and
/// the robustified normal equations built as in `momo_core::Problem` (Ceres' corrector).
/// Counts the evaluations.
pub struct Fit<R> {
    pub res: R,
    pub cauchy: Option<f64>,
    pub costs: Cell<usize>,
    pub linearizations: Cell<usize>,
}

impl<R: Residuals> Fit<R> {
    pub fn new(res: R) -> Self {
        Self {
            res,
            cauchy: None,
            costs: Cell::new(0),
            linearizations: Cell::new(0),
        }
    }

    pub fn cauchy(res: R, b: f64) -> Self {
        Self {
            cauchy: Some(b),
            ..Self::new(res)
        }
    }

    /// `[ρ, ρ', ρ'']` at the squared residual `s`.
    fn rho(&self, s: f64) -> [f64; 3] {
        match self.cauchy {
            None => [s, 1.0, 0.0],
            Some(b) => {
                let b2 = b * b;
                let inv = 1.0 / (1.0 + s / b2);
                [b2 * (1.0 + s / b2).ln(), inv, -inv * inv / b2]
            }
        }
    }

    pub fn reset_counts(&self) {
        self.costs.set(0);
        self.linearizations.set(0);
    }
}

impl<R: Residuals> LeastSquares for Fit<R> {
    fn num_params(&self) -> usize {
        self.res.num_params()
    }

    fn cost(&self, x: &ParamVec) -> f64 {
        self.costs.set(self.costs.get() + 1);
        let mut cost = 0.0;
        self.res
            .each(x, &mut |r, _| cost += 0.5 * self.rho(r * r)[0]);
        cost
    }

    fn linearize(&self, x: &ParamVec) -> Linearization {
        self.linearizations.set(self.linearizations.get() + 1);
        let mut lin = Linearization {
            cost: 0.0,
            gradient: ParamVec::zeros(),
            hessian: NormalMatrix::zeros(),
        };
        self.res.each(x, &mut |r, j| {
            let s = r * r;
            let [rho, rho1, rho2] = self.rho(s);
            lin.cost += 0.5 * rho;
            let sqrt_rho1 = rho1.sqrt();
            let (scaling, alpha_sq_norm) = if s == 0.0 || rho2 <= 0.0 {
                (sqrt_rho1, 0.0)
            } else {
                let alpha = 1.0 - (1.0 + 2.0 * s * rho2 / rho1).sqrt();
                (sqrt_rho1 / (1.0 - alpha), alpha / s)
            };
            let jt = (j - j * (alpha_sq_norm * r * r)) * sqrt_rho1;
            lin.hessian += jt * jt.transpose();
            lin.gradient += jt * (scaling * r);
        });
        lin
    }
}

pub fn pv(v: &[f64]) -> ParamVec {
    let mut x = ParamVec::zeros();
    x.rows_mut(0, v.len()).copy_from_slice(v);
    x
}

/// `y = a exp(b t) + c` on exact data from `(2, -1.5, 0.5)`.
pub struct ExpFit {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
}

pub const EXP_TRUTH: [f64; 3] = [2.0, -1.5, 0.5];

impl ExpFit {
    pub fn new() -> Self {
        let t: Vec<f64> = (0..25).map(|i| 0.1 * i as f64).collect();
        let [a, b, c] = EXP_TRUTH;
        let y = t.iter().map(|t| a * (b * t).exp() + c).collect();
        Self { t, y }
    }
}

impl Residuals for ExpFit {
    fn num_params(&self) -> usize {
        3
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        for (t, y) in self.t.iter().zip(&self.y) {
            let e = (x[1] * t).exp();
            f(x[0] * e + x[2] - y, &pv(&[e, x[0] * t * e, 1.0]));
        }
    }
}

/// Rosenbrock's function as residuals `[10 (y - x²), 1 - x]`; minimum 0 at `(1, 1)`.
pub struct Rosenbrock;

impl Residuals for Rosenbrock {
    fn num_params(&self) -> usize {
        2
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        f(10.0 * (x[1] - x[0] * x[0]), &pv(&[-20.0 * x[0], 10.0]));
        f(1.0 - x[0], &pv(&[-1.0, 0.0]));
    }
}

/// A quadratic `p0 + p1 t + p2 t²` fitted to noisy data (non-zero residual at the minimum),
/// with the solution in closed form.
pub struct Quadratic {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
}

impl Quadratic {
    pub fn new() -> Self {
        let t: Vec<f64> = (0..30).map(|i| -1.0 + 0.1 * i as f64).collect();
        let y = t
            .iter()
            .enumerate()
            .map(|(i, t)| 0.3 - 1.2 * t + 0.7 * t * t + 0.05 * (7.3 * i as f64).sin())
            .collect();
        Self { t, y }
    }

    /// The least-squares solution by a QR decomposition.
    pub fn solution(&self) -> [f64; 3] {
        let a = nalgebra::DMatrix::from_fn(self.t.len(), 3, |i, k| self.t[i].powi(k as i32));
        let b = nalgebra::DVector::from_column_slice(&self.y);
        let qr = a.qr();
        let qtb = qr.q().transpose() * b;
        let p = qr.r().solve_upper_triangular(&qtb).unwrap();
        [p[0], p[1], p[2]]
    }
}

impl Residuals for Quadratic {
    fn num_params(&self) -> usize {
        3
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        for (t, y) in self.t.iter().zip(&self.y) {
            f(x[0] + x[1] * t + x[2] * t * t - y, &pv(&[1.0, *t, t * t]));
        }
    }
}

/// The exponential fit with a third parameter that does not affect the cost.
pub struct FlatExp(pub ExpFit);

impl Residuals for FlatExp {
    fn num_params(&self) -> usize {
        4
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        // Parameters (a, b, unused, c).
        let y = pv(&[x[0], x[1], x[3]]);
        self.0
            .each(&y, &mut |r, j| f(r, &pv(&[j[0], j[1], 0.0, j[2]])));
    }
}

/// A line `y = (p0 + p1) t + p2` where only the sum of the first two parameters matters.
pub struct SumOnly;

impl Residuals for SumOnly {
    fn num_params(&self) -> usize {
        3
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        for i in 0..10 {
            let t = i as f64;
            f(
                (x[0] + x[1]) * t + x[2] - (3.0 * t - 1.0),
                &pv(&[t, t, 1.0]),
            );
        }
    }
}

/// Residuals `[ln x - 1, √y - 2]`: minimum 0 at `(e, 4)`, NaN cost for `x < 0` or `y < 0`.
pub struct LogSqrt;

impl Residuals for LogSqrt {
    fn num_params(&self) -> usize {
        2
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        f(x[0].ln() - 1.0, &pv(&[1.0 / x[0], 0.0]));
        let s = x[1].sqrt();
        f(s - 2.0, &pv(&[0.0, 0.5 / s]));
    }
}

/// A line `y = 1 + 0.5 t` with a third of the points gross outliers, for Cauchy's loss.
pub struct OutlierLine {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
}

impl OutlierLine {
    pub fn new() -> Self {
        let t: Vec<f64> = (0..60).map(|i| 0.1 * i as f64).collect();
        let y = t
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let clean = 1.0 + 0.5 * t + 0.01 * (3.1 * i as f64).sin();
                if i % 3 == 0 {
                    clean + 3.0 + (1.7 * i as f64).cos()
                } else {
                    clean
                }
            })
            .collect();
        Self { t, y }
    }
}

impl Residuals for OutlierLine {
    fn num_params(&self) -> usize {
        2
    }
    fn each(&self, x: &ParamVec, f: &mut dyn FnMut(f64, &ParamVec)) {
        for (t, y) in self.t.iter().zip(&self.y) {
            f(x[0] + x[1] * t - y, &pv(&[1.0, *t]));
        }
    }
}

/// A problem without free parameters and a constant cost of 3.
pub struct Empty;

impl LeastSquares for Empty {
    fn num_params(&self) -> usize {
        0
    }
    fn cost(&self, _: &ParamVec) -> f64 {
        3.0
    }
    fn linearize(&self, _: &ParamVec) -> Linearization {
        Linearization {
            cost: 3.0,
            gradient: ParamVec::zeros(),
            hessian: NormalMatrix::zeros(),
        }
    }
}

/// The three solvers with default options.
pub fn defaults() -> Vec<Box<dyn Solver>> {
    vec![
        Box::new(GaussNewton::default()),
        Box::new(LevenbergMarquardt::default()),
        Box::new(Dogleg::default()),
    ]
}

/// The three solvers with tolerances at the limit of double precision and generous iteration
/// limits.
pub fn tight() -> Vec<Box<dyn Solver>> {
    vec![
        Box::new(
            GaussNewton::default()
                .with_max_iterations(200)
                .with_function_tolerance(1e-15)
                .with_gradient_tolerance(1e-14)
                .with_parameter_tolerance(1e-14),
        ),
        Box::new(
            LevenbergMarquardt::default()
                .with_max_iterations(200)
                .with_function_tolerance(1e-15)
                .with_gradient_tolerance(1e-14)
                .with_parameter_tolerance(1e-14),
        ),
        Box::new(
            Dogleg::default()
                .with_max_iterations(200)
                .with_function_tolerance(1e-15)
                .with_gradient_tolerance(1e-14)
                .with_parameter_tolerance(1e-14),
        ),
    ]
}

/// The report's final cost and normal matrix belong to its final point; or, after
/// Levenberg-Marquardt's last step taken without a linearisation
/// (`LevenbergMarquardt::skip_last_linearization`), the cost is the final point's
/// (`LeastSquares::cost`) and the normal matrix is that of the point one step before, which
/// must then be a converged solve.
#[allow(dead_code)]
pub fn check_final(problem: &dyn LeastSquares, r: &momo_core::SolverReport) {
    let lin = problem.linearize(&r.x);
    if lin.hessian == r.normal_matrix {
        assert_eq!(lin.cost, r.final_cost, "{r:?}");
    } else {
        assert_eq!(
            r.termination,
            momo_core::Termination::CostConverged,
            "{r:?}"
        );
        assert_eq!(problem.cost(&r.x), r.final_cost, "{r:?}");
    }
}
