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
    let rhs = negated_rhs(g, n);
    if let Some(x) = cholesky_solve_block(h, &rhs, n, damping, scaled) {
        return Some((x, SolveMethod::Cholesky));
    }
    let a = damped(h, n, damping, scaled);
    truncated_svd_solve(&a, &rhs, n, RANK_TOLERANCE).map(|x| (x, SolveMethod::TruncatedSvd))
}

/// [`cholesky_solve`] of the damped matrix `A = H + λ D` ([`damped`]) on the leading `n x n`
/// block only, bit for bit: nalgebra's factorisation of the padded `8 x 8` matrix is the
/// left-looking column Cholesky (`L_ij = (A_ij - Σ_{k<j} L_jk L_ik) / L_jj`, the sum taken as
/// `(-L_jk) L_ik + v` for `k = 0, 1, ...`, `L_jj = √v_jj`, refused where `v_jj` is zero, negative
/// or NaN), and the two triangular solves are `x_k ← (-c_i) L_ki + x_k` after `c_i = x_i / L_ii`
/// (forward) and `x_i ← (x_i - Σ_{k>i} L_ki x_k) / L_ii` with the sum from `+0` in increasing `k`
/// (backward). The padding (identity, zero right-hand side) contributes `+0` to every entry of
/// the leading block, and an added `+0` never changes a sum that started at `+0`, so the same
/// operations on the `n x n` block give the same bits (test
/// `block_cholesky_matches_the_padded_factorisation`). Returns `None` where [`cholesky_solve`]
/// does.
fn cholesky_solve_block(
    h: &NormalMatrix,
    b: &ParamVec,
    n: usize,
    damping: f64,
    scaled: bool,
) -> Option<ParamVec> {
    // One instance per size, so that the loops have constant bounds (`MAX_PARAMS` = 8).
    match n {
        0 => Some(*b),
        1 => cholesky_solve_n::<1>(h, b, damping, scaled),
        2 => cholesky_solve_n::<2>(h, b, damping, scaled),
        3 => cholesky_solve_n::<3>(h, b, damping, scaled),
        4 => cholesky_solve_n::<4>(h, b, damping, scaled),
        5 => cholesky_solve_n::<5>(h, b, damping, scaled),
        6 => cholesky_solve_n::<6>(h, b, damping, scaled),
        7 => cholesky_solve_n::<7>(h, b, damping, scaled),
        _ => cholesky_solve_n::<MAX_PARAMS>(h, b, damping, scaled),
    }
}

/// [`cholesky_solve_block`] for `n = N`.
#[inline]
fn cholesky_solve_n<const N: usize>(
    h: &NormalMatrix,
    b: &ParamVec,
    damping: f64,
    scaled: bool,
) -> Option<ParamVec> {
    let n = N;
    // `l[j][i]` = `L_ij` (column j), the lower triangle of the damped block.
    let mut l = [[0.0_f64; N]; N];
    let mut diag = [0.0_f64; N];
    for j in 0..n {
        for i in j..n {
            l[j][i] = h[(i, j)];
        }
        if damping != 0.0 {
            let d = if scaled { l[j][j].max(1e-12) } else { 1.0 };
            l[j][j] += damping * d;
        }
        diag[j] = l[j][j];
    }
    for j in 0..n {
        for k in 0..j {
            let factor = -l[k][j];
            let (head, tail) = l.split_at_mut(j);
            let (col_k, col_j) = (&head[k], &mut tail[0]);
            for i in j..n {
                col_j[i] += factor * col_k[i];
            }
        }
        let v = l[j][j];
        // nalgebra: `is_zero` refuses ±0, `try_sqrt` a negative value or NaN.
        if v == 0.0 || !(v >= 0.0) {
            return None;
        }
        let denom = v.sqrt();
        l[j][j] = denom;
        for i in j + 1..n {
            l[j][i] /= denom;
        }
    }
    for i in 0..n {
        let p = l[i][i];
        if p.is_nan() || p * p <= PIVOT_TOLERANCE * diag[i] {
            return None;
        }
    }
    let mut x = *b;
    for i in 0..n {
        let coeff = x[i] / l[i][i];
        x[i] = coeff;
        for k in i + 1..n {
            x[k] += -coeff * l[i][k];
        }
    }
    for i in (0..n).rev() {
        let mut res = 0.0;
        for k in i + 1..n {
            res += l[i][k] * x[k];
        }
        x[i] = (x[i] - res) / l[i][i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Solves `A x = b` by the fixed-size Cholesky factorisation, or `None` if `A` is not positive
/// definite, a pivot is relatively tiny (a possible rank deficiency, [`PIVOT_TOLERANCE`]) or
/// the result is not finite. The reference of [`cholesky_solve_block`] (which replaced it).
#[cfg(test)]
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

    /// The `n x n` block solve gives the bits of the padded `8 x 8` factorisation (or fails
    /// where it fails) on random symmetric systems: positive definite ones of every size, with
    /// and without damping, nearly dependent and indefinite ones, zero and NaN entries.
    #[test]
    fn block_cholesky_matches_the_padded_factorisation() {
        use proptest::prelude::*;
        use proptest::test_runner::{Config, TestRunner};
        let mut runner = TestRunner::new(Config::with_cases(2000));
        let case = (
            1..=MAX_PARAMS,
            proptest::collection::vec(-3.0..3.0_f64, MAX_PARAMS * MAX_PARAMS),
            proptest::collection::vec(-2.0..2.0_f64, MAX_PARAMS),
            0..6_u8,
            prop_oneof![Just(0.0), 1e-6..10.0_f64],
            any::<bool>(),
            0..MAX_PARAMS * MAX_PARAMS,
        );
        let solved = std::cell::Cell::new(0);
        let refused = std::cell::Cell::new(0);
        runner
            .run(&case, |(n, m, g, kind, damping, scaled, at)| {
                // H = M Mᵀ (positive semi-definite), or M + Mᵀ (indefinite), with one entry
                // made zero / NaN / a dependent column for some kinds.
                let m = NormalMatrix::from_column_slice(&m);
                let mut h = match kind {
                    1 => m + m.transpose(),
                    _ => m * m.transpose(),
                };
                let (r, c) = (at % MAX_PARAMS, at / MAX_PARAMS);
                match kind {
                    2 => {
                        h[(r, c)] = 0.0;
                        h[(c, r)] = 0.0;
                    }
                    3 => {
                        h[(r, c)] = f64::NAN;
                        h[(c, r)] = f64::NAN;
                    }
                    4 if n > 1 => {
                        // Column 1 = column 0 (1 + 1e-9): nearly dependent.
                        for i in 0..MAX_PARAMS {
                            h[(i, 1)] = h[(i, 0)] * (1.0 + 1e-9);
                            h[(1, i)] = h[(i, 1)];
                        }
                        h[(1, 1)] = h[(0, 0)] * (1.0 + 1e-9) * (1.0 + 1e-9);
                    }
                    _ => {}
                }
                let g = ParamVec::from_column_slice(&g);
                let rhs = negated_rhs(&g, n);
                let reference = cholesky_solve(&damped(&h, n, damping, scaled), &rhs, n);
                let block = cholesky_solve_block(&h, &rhs, n, damping, scaled);
                match (&reference, &block) {
                    (Some(x), Some(y)) => {
                        solved.set(solved.get() + 1);
                        for i in 0..MAX_PARAMS {
                            prop_assert_eq!(x[i].to_bits(), y[i].to_bits(), "n {} entry {}", n, i);
                        }
                    }
                    (None, None) => refused.set(refused.get() + 1),
                    _ => {
                        return Err(proptest::test_runner::TestCaseError::fail(format!(
                            "n {n}: {reference:?} vs {block:?}"
                        )));
                    }
                }
                Ok(())
            })
            .unwrap();
        // Both outcomes are exercised.
        let (solved, refused) = (solved.get(), refused.get());
        assert!(
            solved > 500 && refused > 100,
            "{solved} solved, {refused} refused"
        );
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
