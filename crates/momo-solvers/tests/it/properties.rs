//! Properties over random starts and random systems: never a worse point than the start, never
//! NaN parameters, consistent reports; the rank-revealing fallback solves what it can.

#![allow(clippy::unwrap_used)]

use crate::common;

use common::*;
use momo_core::{LeastSquares, MAX_PARAMS, NormalMatrix, ParamVec, Termination};
use momo_solvers::linalg::{SolveMethod, solve_damped};
use proptest::prelude::*;

/// The report of every solver is no worse than the start, finite and consistent.
fn check_all(problem: &dyn LeastSquares, x0: &ParamVec) -> Vec<momo_core::SolverReport> {
    let n = problem.num_params();
    let mut out = Vec::new();
    for s in defaults() {
        let r = s.solve(problem, x0);
        assert!(r.x.iter().all(|v| v.is_finite()), "{s:?}: {r:?}");
        assert!(r.iterations <= 50);
        if r.initial_cost.is_finite() {
            assert!(r.final_cost <= r.initial_cost, "{s:?}: {r:?}");
            check_final(problem, &r);
        } else {
            assert_eq!(r.termination, Termination::NumericalFailure);
            assert_eq!(r.x.rows(0, n), x0.rows(0, n));
        }
        out.push(r);
    }
    out
}

proptest! {
    #[test]
    fn rosenbrock_from_anywhere(a in -5.0..5.0f64, b in -5.0..5.0f64) {
        let p = Fit::new(Rosenbrock);
        for r in check_all(&p, &pv(&[a, b])) {
            if r.termination.is_converged() {
                prop_assert!((r.x[0] - 1.0).abs() < 1e-6 && (r.x[1] - 1.0).abs() < 1e-6, "{r:?}");
            }
        }
    }

    #[test]
    fn exponential_fit_from_anywhere(a in -5.0..5.0f64, b in -5.0..5.0f64, c in -5.0..5.0f64) {
        let p = Fit::new(ExpFit::new());
        check_all(&p, &pv(&[a, b, c]));
    }

    #[test]
    fn nan_region_from_anywhere(a in -1.0..30.0f64, b in -1.0..30.0f64) {
        let p = Fit::new(LogSqrt);
        let x0 = pv(&[a, b]);
        for r in check_all(&p, &x0) {
            if a < 0.0 || b < 0.0 {
                prop_assert_eq!(r.termination, Termination::NumericalFailure);
                prop_assert_eq!(r.iterations, 0);
            } else if r.termination.is_converged() {
                prop_assert!((r.x[0] - std::f64::consts::E).abs() < 1e-6, "{:?}", r);
                prop_assert!((r.x[1] - 4.0).abs() < 1e-6, "{:?}", r);
            }
        }
    }

    #[test]
    fn robust_fit_from_anywhere(a in -10.0..10.0f64, b in -10.0..10.0f64) {
        let p = Fit::cauchy(OutlierLine::new(), 0.05);
        check_all(&p, &pv(&[a, b]));
    }

    #[test]
    fn flat_and_dependent_from_anywhere(a in -5.0..5.0f64, b in -3.0..3.0f64, c in -5.0..5.0f64, d in -5.0..5.0f64) {
        let p = Fit::new(FlatExp(ExpFit::new()));
        for r in check_all(&p, &pv(&[a, b, c, d])) {
            prop_assert_eq!(r.x[2], c);
        }
        let p = Fit::new(SumOnly);
        check_all(&p, &pv(&[a, b, c]));
    }

    /// `H = JᵀJ` of a random `J` of rank `r ≤ n` (the product of random factors, possibly very
    /// ill-conditioned) and `g = Jᵀ e`: the solution satisfies `H δ = -g`, by Cholesky or by the
    /// SVD fallback.
    #[test]
    fn normal_equations_of_any_rank(
        n in 1usize..=MAX_PARAMS,
        rank_deficit in 0usize..3,
        seed in proptest::collection::vec(-1.0..1.0f64, 200),
        scales in proptest::collection::vec(-3.0..3.0f64, MAX_PARAMS),
    ) {
        let r = n.saturating_sub(rank_deficit).max(1);
        let mut it = seed.iter().cycle().copied();
        let b = nalgebra::DMatrix::from_fn(M, r, |_, _| it.next().unwrap());
        let c = nalgebra::DMatrix::from_fn(r, n, |_, _| it.next().unwrap());
        check_system(b * c, &scales, &mut it)?;
    }

    /// An exact dependence between parameters (`J = B [I | W] P`, `B` well conditioned, `P` a
    /// permutation) is found, whatever the parameters' units, and the step is the minimum-norm
    /// one in the Jacobi-scaled variables.
    #[test]
    fn dependent_parameters_are_detected(
        n in 2usize..=MAX_PARAMS,
        rank_deficit in 1usize..4,
        seed in proptest::collection::vec(-1.0..1.0f64, 200),
        keys in proptest::collection::vec(0.0..1.0f64, MAX_PARAMS),
        scales in proptest::collection::vec(-3.0..3.0f64, MAX_PARAMS),
    ) {
        let r = n.saturating_sub(rank_deficit).max(1);
        let mut it = seed.iter().cycle().copied();
        let b = nalgebra::DMatrix::from_fn(M, r, |i, k| it.next().unwrap() + if i == k { 3.0 } else { 0.0 });
        let mut perm: Vec<usize> = (0..n).collect();
        perm.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]));
        let mut c = nalgebra::DMatrix::zeros(r, n);
        for (col, &k) in perm.iter().enumerate() {
            for row in 0..r {
                c[(row, k)] = if col < r { f64::from(u8::from(row == col)) } else { it.next().unwrap() };
            }
        }
        let (x, method, s, y, _) = check_system(b * c, &scales, &mut it)?;
        prop_assert_eq!(method, SolveMethod::TruncatedSvd);
        // Minimum norm: y has no component along the null space of S (the residual is checked
        // by `check_system`).
        let eig = s.symmetric_eigen();
        let mut nullity = 0;
        for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
            if lambda.abs() < 1e-10 {
                nullity += 1;
                let v = eig.eigenvectors.column(k);
                prop_assert!(v.dot(&y).abs() <= 1e-8 * y.norm().max(1e-12), "y {} has {} along {}", y, v.dot(&y), v);
            }
        }
        prop_assert_eq!(nullity, n - r, "x {}", x);
    }
}

const M: usize = 12;

type Checked = (
    ParamVec,
    SolveMethod,
    nalgebra::DMatrix<f64>,
    nalgebra::DVector<f64>,
    nalgebra::DVector<f64>,
);

/// Scales the columns of `j` by `10^scales`, solves the normal equations with `g = Jᵀ e` and
/// checks the (consistent) system in the Jacobi-scaled variables `y = D x`, `S = D⁻¹HD⁻¹`.
/// Returns the solution, the method, `S`, `y` and `D⁻¹ g`.
fn check_system(
    mut j: nalgebra::DMatrix<f64>,
    scales: &[f64],
    it: &mut impl Iterator<Item = f64>,
) -> Result<Checked, TestCaseError> {
    let n = j.ncols();
    for k in 0..n {
        j.column_mut(k).scale_mut(10f64.powf(scales[k]));
    }
    let e = nalgebra::DVector::from_fn(M, |_, _| it.next().unwrap());
    let mut h = NormalMatrix::zeros();
    let mut g = ParamVec::zeros();
    h.view_mut((0, 0), (n, n)).copy_from(&(j.transpose() * &j));
    g.rows_mut(0, n).copy_from(&(j.transpose() * e));
    let (x, method) = solve_damped(&h, &g, n, 0.0, false).unwrap();
    prop_assert!(x.rows(n, MAX_PARAMS - n).iter().all(|&v| v == 0.0));
    let d: Vec<f64> = (0..n)
        .map(|k| {
            if h[(k, k)] > 0.0 {
                h[(k, k)].sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let s = nalgebra::DMatrix::from_fn(n, n, |i, k| h[(i, k)] / (d[i] * d[k]));
    let y = nalgebra::DVector::from_fn(n, |k, _| x[k] * d[k]);
    let bs = nalgebra::DVector::from_fn(n, |k, _| g[k] / d[k]);
    let res = &s * &y + &bs;
    // Solved exactly, or (truncated SVD) in the least-squares sense: what is left of the
    // residual lies along the dropped directions, those with singular values below
    // `RANK_TOLERANCE · σ_max`, which `S` maps to (nearly) nothing.
    let least_squares =
        method == SolveMethod::TruncatedSvd && (&s * &res).norm() <= 1e-8 * s.norm() * res.norm();
    prop_assert!(
        res.norm() <= 1e-8 * (s.norm() * y.norm() + bs.norm()) || least_squares,
        "residual {res} y {y} method {method:?}"
    );
    Ok((x, method, s, y, bs))
}
