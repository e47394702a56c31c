//! The solver interface: small dense robust least-squares problems (1 to [`MAX_PARAMS`]
//! unknowns), seen through their normal equations.

use nalgebra::{DMatrix, SMatrix, SVector};
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// Most free parameters a problem may have.
pub const MAX_PARAMS: usize = 8;

/// A parameter vector; entries at and beyond the problem's [`LeastSquares::num_params`] are zero.
pub type ParamVec = SVector<f64, MAX_PARAMS>;

/// A normal matrix; only the leading `n x n` block is used.
pub type NormalMatrix = SMatrix<f64, MAX_PARAMS, MAX_PARAMS>;

/// The robustified linearisation of a problem at a point: `cost = ½ Σ ρ(|r_i|²)`,
/// `gradient = Σ ρ' J_iᵀ r_i` and `hessian ≈ Σ J̃_iᵀ J̃_i` (Gauss-Newton with the Triggs
/// correction of Ceres' `Corrector`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linearization {
    /// Cost at the point.
    pub cost: f64,
    /// Gradient of the cost.
    pub gradient: ParamVec,
    /// Gauss-Newton approximation of the Hessian.
    pub hessian: NormalMatrix,
}

/// What a solver sees of a problem.
pub trait LeastSquares {
    /// Number of free parameters `n` (`0..=MAX_PARAMS`).
    fn num_params(&self) -> usize;
    /// Cost at `x` (may be non-finite where the model is undefined).
    fn cost(&self, x: &ParamVec) -> f64;
    /// Cost, gradient and normal matrix at `x`.
    fn linearize(&self, x: &ParamVec) -> Linearization;
    /// Like [`linearize`](Self::linearize) where the solver already evaluated `cost(x)` (an
    /// accepted trial step): the problem may skip evaluating `ρ` itself. The default ignores
    /// the hint.
    fn linearize_known_cost(&self, x: &ParamVec, cost: f64) -> Linearization {
        let _ = cost;
        self.linearize(x)
    }
}

/// Why a solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// The relative cost decrease fell below the tolerance.
    CostConverged,
    /// The gradient's max-norm fell below the tolerance.
    GradientConverged,
    /// The step fell below the tolerance relative to the parameters.
    StepConverged,
    /// The iteration limit was reached first.
    MaxIterations,
    /// Non-finite cost or an unsolvable system: the result is the last good point.
    NumericalFailure,
    /// The problem has no free parameters.
    NoFreeParameters,
}

impl Termination {
    /// True for the three kinds of convergence (and for an empty problem).
    pub fn is_converged(self) -> bool {
        matches!(
            self,
            Termination::CostConverged
                | Termination::GradientConverged
                | Termination::StepConverged
                | Termination::NoFreeParameters
        )
    }
}

/// The result of a solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverReport {
    /// Final parameters (free parameters only).
    pub x: ParamVec,
    /// Number of free parameters.
    pub num_params: usize,
    /// Cost at the start.
    pub initial_cost: f64,
    /// Cost at the end.
    pub final_cost: f64,
    /// Iterations taken (linearisations accepted or rejected).
    pub iterations: usize,
    /// Why the solver stopped.
    pub termination: Termination,
    /// The normal matrix `JᵀJ` (robustified) at the final point, for a covariance; after a
    /// last step taken without a linearisation (Levenberg-Marquardt's
    /// `skip_last_linearization`), at the point one step before it.
    pub normal_matrix: NormalMatrix,
}

impl SolverReport {
    /// The covariance `σ² (JᵀJ)⁻¹` of the free parameters (`n x n`), if the normal matrix is
    /// invertible. `sigma2` is the variance of one residual (in the metric's units).
    pub fn covariance(&self, sigma2: f64) -> Option<DMatrix<f64>> {
        let n = self.num_params;
        let h = self.normal_matrix.view((0, 0), (n, n)).into_owned();
        h.try_inverse().map(|inv| inv * sigma2)
    }
}

/// A least-squares solver. Options are plain fields of the implementing struct (with
/// `Default`); the configuration names the solver by type tag, e.g.
/// `{"type": "levenberg_marquardt", "max_iterations": 50}`.
#[typetag::serde(tag = "type")]
pub trait Solver: Debug + Send + Sync {
    /// Minimises the problem's cost from `x0`.
    fn solve(&self, problem: &dyn LeastSquares, x0: &ParamVec) -> SolverReport;
}

/// Solves `(H + λ diag) δ = -g` on the leading `n x n` block by Cholesky, padding the unused
/// block with the identity so that a fixed-size factorisation serves every `n`.
/// `damping` adds `λ · max(diag(H), 1e-12)` to the diagonal (Marquardt's scaling) when `scaled`,
/// or `λ` otherwise. Returns `None` if the system is not positive definite.
pub fn solve_normal_equations(
    h: &NormalMatrix,
    g: &ParamVec,
    n: usize,
    damping: f64,
    scaled: bool,
) -> Option<ParamVec> {
    let mut a = *h;
    for i in 0..MAX_PARAMS {
        if i < n {
            let d = if scaled { a[(i, i)].max(1e-12) } else { 1.0 };
            a[(i, i)] += damping * d;
        } else {
            a.row_mut(i).fill(0.0);
            a.column_mut(i).fill(0.0);
            a[(i, i)] = 1.0;
        }
    }
    let mut rhs = -*g;
    for i in n..MAX_PARAMS {
        rhs[i] = 0.0;
    }
    let chol = a.cholesky()?;
    let x = chol.solve(&rhs);
    x.iter().all(|v| v.is_finite()).then_some(x)
}
