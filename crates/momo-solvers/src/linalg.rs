//! Solving the (damped) normal equations `(H + λ D) δ = -g` on the leading `n x n` block.
//!
//! The normal path is a fixed-size nalgebra Cholesky factorisation (for 2 to 6 unknowns it was
//! measured about 3x faster than faer's dynamic-size routines). A factorisation that fails, or
//! whose pivots reveal a (numerically) dependent column, falls back to a truncated SVD computed
//! by faer: the system is Jacobi-scaled (`D⁻¹ A D⁻¹` with `D = √diag A`, so that the truncation
//! does not depend on the parameters' units), singular values below
//! [`RANK_TOLERANCE`] times the largest are dropped, and the minimum-norm solution (in the
//! scaled variables) is returned. A parameter that does not affect the cost thus keeps its
//! value instead of making the step explode. The fallback works on stack buffers and allocates
//! nothing.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::svd::{ComputeSvdVectors, svd, svd_scratch};
use faer::{MatMut, MatRef, Par, diag::DiagMut};
use momo_core::{MAX_PARAMS, NormalMatrix, ParamVec};
use std::mem::MaybeUninit;

/// Relative pivot tolerance of the Cholesky path: a pivot `lᵢᵢ² ≤ PIVOT_TOLERANCE · Aᵢᵢ`
/// means that column `i` is a combination of the previous ones up to a relative residual of
/// `√PIVOT_TOLERANCE` (1 - R² in the language of regression). Such a system is handed to the
/// SVD, which decides on the rank with [`RANK_TOLERANCE`]: the pivot is only a cheap, early
/// hint, because rounding in an ill-conditioned matrix can hide an exact dependence behind a
/// pivot well above machine precision. After a pivot `p` (relative), the rounding error of
/// the later pivots is about `ε / p`; an exact dependence behind a near-dependence therefore
/// shows as a pivot of `ε / p`, and is caught only if both `p` and `ε / p` cannot pass the
/// test, i.e. if `PIVOT_TOLERANCE² ≫ ε`. With `1e-8` a near-dependence of `2.5e-8` hid an
/// exact one behind a pivot of `2.4e-8` (a property test found it); `1e-6` leaves a margin
/// of 10⁴. The SVD of a system that turns out to have full rank gives the same solution as
/// the Cholesky factorisation.
pub const PIVOT_TOLERANCE: f64 = 1e-6;

/// Relative rank tolerance of the SVD fallback: singular values of the Jacobi-scaled system
/// below `RANK_TOLERANCE · σ_max` are dropped.
pub const RANK_TOLERANCE: f64 = 1e-12;

/// Bytes of stack scratch for faer's SVD of an `8 x 8` matrix (measured need: well below).
const SVD_SCRATCH_BYTES: usize = 16 * 1024;

/// How a system was solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SolveMethod {
    /// The fixed-size Cholesky factorisation succeeded with well-conditioned pivots.
    Cholesky,
    /// The truncated-SVD fallback produced the (scaled) minimum-norm solution.
    TruncatedSvd,
}

/// The damped system matrix `A = H + λ D` on the leading `n x n` block, with `D = max(diag H,
/// 1e-12)` when `scaled` (Marquardt) or the identity otherwise; the unused block is the identity.
/// The same convention as [`momo_core::solve_normal_equations`].
#[inline]
fn damped(h: &NormalMatrix, n: usize, damping: f64, scaled: bool) -> NormalMatrix {
    let mut a = *h;
    for i in 0..MAX_PARAMS {
        if i < n {
            if damping != 0.0 {
                let d = if scaled { a[(i, i)].max(1e-12) } else { 1.0 };
                a[(i, i)] += damping * d;
            }
        } else {
            a.row_mut(i).fill(0.0);
            a.column_mut(i).fill(0.0);
            a[(i, i)] = 1.0;
        }
    }
    a
}

#[inline]
fn negated_rhs(g: &ParamVec, n: usize) -> ParamVec {
    let mut rhs = -*g;
    for i in n..MAX_PARAMS {
        rhs[i] = 0.0;
    }
    rhs
}

/// Solves `(H + λ D) δ = -g` (see [`momo_core::solve_normal_equations`] for the damping
/// convention) by Cholesky, falling back to the truncated SVD ([`truncated_svd_solve`] with
/// [`RANK_TOLERANCE`]) when the matrix is not positive definite or a pivot is below
/// [`PIVOT_TOLERANCE`]. Returns the step and the method used,
/// or `None` if neither produced a finite solution. Entries at and beyond `n` are zero.
pub fn solve_damped(
    h: &NormalMatrix,
    g: &ParamVec,
    n: usize,
    damping: f64,
    scaled: bool,
) -> Option<(ParamVec, SolveMethod)> {
    let n = n.min(MAX_PARAMS);
    let a = damped(h, n, damping, scaled);
    let rhs = negated_rhs(g, n);
    if let Some(x) = cholesky_solve(&a, &rhs, n) {
        return Some((x, SolveMethod::Cholesky));
    }
    truncated_svd_solve(&a, &rhs, n, RANK_TOLERANCE).map(|x| (x, SolveMethod::TruncatedSvd))
}

/// Solves `A x = b` by the fixed-size Cholesky factorisation, or `None` if `A` is not positive
/// definite, a pivot is relatively tiny (a possible rank deficiency, [`PIVOT_TOLERANCE`]) or
/// the result is not finite.
fn cholesky_solve(a: &NormalMatrix, b: &ParamVec, n: usize) -> Option<ParamVec> {
    let diag = a.diagonal();
    let chol = a.cholesky()?;
    let l = chol.l_dirty();
    for i in 0..n {
        let p = l[(i, i)];
        if p.is_nan() || p * p <= PIVOT_TOLERANCE * diag[i] {
            return None;
        }
    }
    let x = chol.solve(b);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Solves the symmetric system `A x = b` on the leading `n x n` block in the least-squares,
/// minimum-norm sense by faer's SVD of the Jacobi-scaled matrix `S = D⁻¹ A D⁻¹`
/// (`D = √|diag A|`, 1 where the diagonal is zero), dropping singular values below
/// `rcond · σ_max`. Rows and columns of `A` without off-diagonal entries are left out: their
/// entries of `x` are `bᵢ / aᵢᵢ`, or exactly zero where `aᵢᵢ` is zero too. Returns `None` if
/// the SVD fails or the result is not finite. Entries at and beyond `n` of the result are
/// zero. No heap allocation.
pub fn truncated_svd_solve(
    a: &NormalMatrix,
    b: &ParamVec,
    n: usize,
    rcond: f64,
) -> Option<ParamVec> {
    let n_all = n.min(MAX_PARAMS);
    let mut x = ParamVec::zeros();
    // Rows and columns without off-diagonal entries are deflated: a parameter that does not
    // affect the cost (an entirely zero row) gets exactly zero, one that is decoupled from the
    // others gets `bᵢ / aᵢᵢ` exactly (its Jacobi-scaled singular value is 1, never truncated),
    // without the rounding of the other parameters' SVD leaking into it.
    let mut idx = [0usize; MAX_PARAMS];
    let mut n = 0;
    for i in 0..n_all {
        if (0..n_all).any(|k| k != i && (a[(i, k)] != 0.0 || a[(k, i)] != 0.0)) {
            idx[n] = i;
            n += 1;
        } else if a[(i, i)] != 0.0 {
            x[i] = b[i] / a[(i, i)];
        }
    }
    if n == 0 {
        return x.iter().all(|v| v.is_finite()).then_some(x);
    }
    let mut d = [1.0; MAX_PARAMS];
    for (i, &ii) in idx[..n].iter().enumerate() {
        let v = a[(ii, ii)].abs().sqrt();
        if v > 0.0 && v.is_finite() {
            d[i] = v;
        }
    }
    // Scaled matrix, column-major n x n.
    let mut s_buf = [0.0; MAX_PARAMS * MAX_PARAMS];
    for j in 0..n {
        for i in 0..n {
            s_buf[j * n + i] = a[(idx[i], idx[j])] / (d[i] * d[j]);
        }
    }
    if !s_buf[..n * n].iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut sv = [0.0; MAX_PARAMS];
    let mut u_buf = [0.0; MAX_PARAMS * MAX_PARAMS];
    let mut v_buf = [0.0; MAX_PARAMS * MAX_PARAMS];
    {
        let s_mat = MatRef::from_column_major_slice(&s_buf[..n * n], n, n);
        let u = MatMut::from_column_major_slice_mut(&mut u_buf[..n * n], n, n);
        let v = MatMut::from_column_major_slice_mut(&mut v_buf[..n * n], n, n);
        let sd = DiagMut::from_slice_mut(&mut sv[..n]);
        let req = svd_scratch::<f64>(
            n,
            n,
            ComputeSvdVectors::Full,
            ComputeSvdVectors::Full,
            Par::Seq,
            Default::default(),
        );
        let mut scratch = [const { MaybeUninit::<u8>::uninit() }; SVD_SCRATCH_BYTES];
        let result = if req.unaligned_bytes_required() <= SVD_SCRATCH_BYTES {
            let stack = MemStack::new(&mut scratch);
            svd(
                s_mat,
                sd,
                Some(u),
                Some(v),
                Par::Seq,
                stack,
                Default::default(),
            )
        } else {
            let mut buf = MemBuffer::new(req);
            let stack = MemStack::new(&mut buf);
            svd(
                s_mat,
                sd,
                Some(u),
                Some(v),
                Par::Seq,
                stack,
                Default::default(),
            )
        };
        result.ok()?;
    }
    let smax = sv[..n].iter().fold(0.0_f64, |m, &s| m.max(s));
    if !smax.is_finite() {
        return None;
    }
    if smax == 0.0 {
        return x.iter().all(|v| v.is_finite()).then_some(x);
    }
    let tol = rcond * smax;
    // y = V Σ⁺ Uᵀ (D⁻¹ b), x = D⁻¹ y.
    let mut bs = [0.0; MAX_PARAMS];
    for i in 0..n {
        bs[i] = b[idx[i]] / d[i];
    }
    let mut y = [0.0; MAX_PARAMS];
    for k in 0..n {
        if sv[k].is_nan() || sv[k] <= tol {
            continue;
        }
        let mut c = 0.0;
        for i in 0..n {
            c += u_buf[k * n + i] * bs[i];
        }
        c /= sv[k];
        for i in 0..n {
            y[i] += v_buf[k * n + i] * c;
        }
    }
    for i in 0..n {
        x[idx[i]] = y[i] / d[i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svd_scratch_fits_on_the_stack() {
        for n in 1..=MAX_PARAMS {
            let req = svd_scratch::<f64>(
                n,
                n,
                ComputeSvdVectors::Full,
                ComputeSvdVectors::Full,
                Par::Seq,
                Default::default(),
            );
            assert!(
                req.unaligned_bytes_required() <= SVD_SCRATCH_BYTES,
                "n = {n}: {req:?}"
            );
        }
    }

    #[test]
    fn cholesky_path_matches_core() {
        let mut h = NormalMatrix::zeros();
        h[(0, 0)] = 4.0;
        h[(0, 1)] = 1.0;
        h[(1, 0)] = 1.0;
        h[(1, 1)] = 3.0;
        let mut g = ParamVec::zeros();
        g[0] = 1.0;
        g[1] = -2.0;
        let (x, m) = solve_damped(&h, &g, 2, 0.1, true).unwrap();
        let y = momo_core::solve_normal_equations(&h, &g, 2, 0.1, true).unwrap();
        assert_eq!(m, SolveMethod::Cholesky);
        assert!((x - y).norm() < 1e-15);
    }

    #[test]
    fn flat_direction_gets_no_step() {
        // The second parameter does not affect the cost: zero row and column.
        let mut h = NormalMatrix::zeros();
        h[(0, 0)] = 2.0;
        h[(0, 2)] = 0.5;
        h[(2, 0)] = 0.5;
        h[(2, 2)] = 1.0;
        let mut g = ParamVec::zeros();
        g[0] = 1.0;
        g[2] = 1.0;
        let (x, m) = solve_damped(&h, &g, 3, 0.0, false).unwrap();
        assert_eq!(m, SolveMethod::TruncatedSvd);
        assert_eq!(x[1], 0.0);
        // The other two solve their 2 x 2 block.
        let det = 2.0 * 1.0 - 0.25;
        let x0 = -(1.0 * 1.0 - 0.5 * 1.0) / det;
        let x2 = -(2.0 * 1.0 - 0.5 * 1.0) / det;
        assert!(
            (x[0] - x0).abs() < 1e-14 && (x[2] - x2).abs() < 1e-14,
            "{x}"
        );
    }

    #[test]
    fn dependent_columns_get_the_minimum_norm_step() {
        // Two parameters that only act through their sum: H = [[1, 1], [1, 1]], g = [1, 1].
        let mut h = NormalMatrix::zeros();
        for i in 0..2 {
            for j in 0..2 {
                h[(i, j)] = 1.0;
            }
        }
        let mut g = ParamVec::zeros();
        g[0] = 1.0;
        g[1] = 1.0;
        let (x, m) = solve_damped(&h, &g, 2, 0.0, false).unwrap();
        assert_eq!(m, SolveMethod::TruncatedSvd);
        assert!(
            (x[0] + 0.5).abs() < 1e-14 && (x[1] + 0.5).abs() < 1e-14,
            "{x}"
        );
    }

    #[test]
    fn nan_matrix_is_refused() {
        let mut h = NormalMatrix::identity();
        h[(0, 1)] = f64::NAN;
        h[(1, 0)] = f64::NAN;
        let g = ParamVec::repeat(1.0);
        assert!(solve_damped(&h, &g, 2, 0.0, false).is_none());
    }
}
