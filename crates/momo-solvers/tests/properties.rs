//! Properties over random starts and random systems: never a worse point than the start, never
//! NaN parameters, consistent reports; the rank-revealing fallback solves what it can.

#![allow(clippy::unwrap_used)]

mod common;

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
            let lin = problem.linearize(&r.x);
            assert_eq!(lin.cost, r.final_cost);
            assert_eq!(lin.hessian, r.normal_matrix);
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

    /// `H = JᵀJ` of a random `J` of rank `r ≤ n` and `g = Jᵀ e`: the solution satisfies
    /// `H δ = -g` whatever the rank, by Cholesky or by the SVD fallback.
    #[test]
    fn normal_equations_of_any_rank(
        n in 1usize..=MAX_PARAMS,
        rank_deficit in 0usize..3,
        seed in proptest::collection::vec(-1.0..1.0f64, 200),
        scales in proptest::collection::vec(-3.0..3.0f64, MAX_PARAMS),
    ) {
        let r = n.saturating_sub(rank_deficit).max(1);
        let m = 12;
        let mut it = seed.iter().cycle().copied();
        let b = nalgebra::DMatrix::from_fn(m, r, |_, _| it.next().unwrap());
        let c = nalgebra::DMatrix::from_fn(r, n, |_, _| it.next().unwrap());
        let mut j = b * c;
        // Parameters of very different units.
        for k in 0..n {
            j.column_mut(k).scale_mut(10f64.powf(scales[k]));
        }
        let e = nalgebra::DVector::from_fn(m, |_, _| it.next().unwrap());
        let hd = j.transpose() * &j;
        let gd = j.transpose() * e;
        let mut h = NormalMatrix::zeros();
        let mut g = ParamVec::zeros();
        h.view_mut((0, 0), (n, n)).copy_from(&hd);
        g.rows_mut(0, n).copy_from(&gd);
        let (x, method) = solve_damped(&h, &g, n, 0.0, false).unwrap();
        if r < n {
            if method != SolveMethod::TruncatedSvd {
                let c = h.view((0, 0), (n, n)).into_owned().cholesky().unwrap();
                eprintln!("H = {h} L = {}", c.l());
                eprintln!("sv = {}", hd.singular_values());
            }
            prop_assert_eq!(method, SolveMethod::TruncatedSvd);
        }
        prop_assert!(x.rows(n, MAX_PARAMS - n).iter().all(|&v| v == 0.0));
        // The (consistent) system holds in the Jacobi-scaled variables y = D x, S = D⁻¹HD⁻¹.
        let d: Vec<f64> = (0..n).map(|k| if h[(k, k)] > 0.0 { h[(k, k)].sqrt() } else { 1.0 }).collect();
        let sm = nalgebra::DMatrix::from_fn(n, n, |i, k| h[(i, k)] / (d[i] * d[k]));
        let y = nalgebra::DVector::from_fn(n, |k, _| x[k] * d[k]);
        let bs = nalgebra::DVector::from_fn(n, |k, _| g[k] / d[k]);
        let res = &sm * &y + &bs;
        prop_assert!(res.norm() <= 1e-8 * (sm.norm() * y.norm() + bs.norm()),
            "rank {r} of {n}: residual {res} y {y}");
    }
}
