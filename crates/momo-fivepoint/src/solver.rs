//! The minimal 5-point solver (Stewénius, Engels, Nistér 2006: the Gröbner-basis / action-matrix
//! form of Nistér's solver).
//!
//! 1. Each correspondence gives one row of the 5x9 constraint matrix `f1ᵀ E f0 = 0`; its
//!    4-dimensional null space `E = x X + y Y + z Z + W` comes from the SVD (nalgebra).
//! 2. `det E = 0` and `2 E Eᵀ E - tr(E Eᵀ) E = 0` are 10 cubic equations in `(x, y, z)` over the
//!    20 monomials of degree ≤ 3; Gauss-Jordan elimination of the 10 cubic monomials (an LU
//!    solve with full pivoting) leaves them as combinations of the 10 monomials of degree ≤ 2.
//! 3. The 10x10 action matrix of multiplication by `x` on that quotient-ring basis has the
//!    solutions' `x` as eigenvalues; real eigenvalues come from nalgebra's real Schur form, the
//!    eigenvectors (the basis monomials evaluated at the solution, so `y`, `z` too) from the null
//!    vector of `A - x I`.
//!
//! Up to 10 essential matrices are returned, each with unit Frobenius norm, in this crate's
//! convention `f1ᵀ E f0 = 0`, `E = Rᵀ [t]ₓ` ([`momo_core::essential`]).

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// The 20 monomials `x^a y^b z^c` of degree ≤ 3, cubic ones first; the last 10 (degree ≤ 2) are
/// the basis of the quotient ring.
const MONOMIALS: [[u8; 3]; 20] = [
    [3, 0, 0],
    [2, 1, 0],
    [2, 0, 1],
    [1, 2, 0],
    [1, 1, 1],
    [1, 0, 2],
    [0, 3, 0],
    [0, 2, 1],
    [0, 1, 2],
    [0, 0, 3],
    [2, 0, 0],
    [1, 1, 0],
    [1, 0, 1],
    [0, 2, 0],
    [0, 1, 1],
    [0, 0, 2],
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1],
    [0, 0, 0],
];

/// Index of a monomial in [`MONOMIALS`], `NONE` if its degree exceeds 3.
const NONE: u8 = u8::MAX;

const fn monomial_index(e: [u8; 3]) -> u8 {
    let mut i = 0;
    while i < 20 {
        let m = MONOMIALS[i];
        if m[0] == e[0] && m[1] == e[1] && m[2] == e[2] {
            return i as u8;
        }
        i += 1;
    }
    NONE
}

/// `PRODUCT[i][j]`: the index of monomial i times monomial j (or `NONE`).
const PRODUCT: [[u8; 20]; 20] = {
    let mut t = [[NONE; 20]; 20];
    let mut i = 0;
    while i < 20 {
        let mut j = 0;
        while j < 20 {
            let a = MONOMIALS[i];
            let b = MONOMIALS[j];
            t[i][j] = monomial_index([a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
            j += 1;
        }
        i += 1;
    }
    t
};

/// A polynomial in `(x, y, z)` of degree ≤ 3, coefficients over [`MONOMIALS`].
#[derive(Clone, Copy, Debug)]
struct Poly([f64; 20]);

impl Poly {
    const ZERO: Poly = Poly([0.0; 20]);

    /// `a x + b y + c z + d`.
    fn linear(a: f64, b: f64, c: f64, d: f64) -> Poly {
        let mut p = Poly::ZERO;
        p.0[16] = a;
        p.0[17] = b;
        p.0[18] = c;
        p.0[19] = d;
        p
    }

    /// The product; terms of degree > 3 must not occur (they are dropped).
    fn mul(&self, o: &Poly) -> Poly {
        let mut r = Poly::ZERO;
        for (i, &a) in self.0.iter().enumerate() {
            if a == 0.0 {
                continue;
            }
            for (j, &b) in o.0.iter().enumerate() {
                if b == 0.0 {
                    continue;
                }
                let k = PRODUCT[i][j];
                debug_assert!(k != NONE, "degree overflow");
                if k != NONE {
                    r.0[k as usize] += a * b;
                }
            }
        }
        r
    }

    fn add(&self, o: &Poly) -> Poly {
        let mut r = *self;
        r.0.iter_mut().zip(o.0.iter()).for_each(|(a, b)| *a += b);
        r
    }

    fn sub(&self, o: &Poly) -> Poly {
        let mut r = *self;
        r.0.iter_mut().zip(o.0.iter()).for_each(|(a, b)| *a -= b);
        r
    }

    fn scale(&self, s: f64) -> Poly {
        let mut r = *self;
        r.0.iter_mut().for_each(|a| *a *= s);
        r
    }
}

/// The row of the constraint matrix for one correspondence: `q · vec(E) = f1ᵀ E f0`, `vec`
/// row-major.
fn constraint_row(f0: &Vector3<f64>, f1: &Vector3<f64>) -> [f64; 9] {
    let mut q = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            q[3 * i + j] = f1[i] * f0[j];
        }
    }
    q
}

/// Smallest ratio of the 5th to the 1st singular value of the constraint matrix accepted as a
/// non-degenerate sample.
pub const DEGENERACY_RATIO: f64 = 1e-10;

/// The 4 null-space vectors (as 3x3 matrices, row-major `vec`) of the 5 constraints, or `None`
/// for a degenerate sample (rank < 5, e.g. repeated correspondences).
fn null_space(f0: &[Vector3<f64>; 5], f1: &[Vector3<f64>; 5]) -> Option<[Matrix3<f64>; 4]> {
    let mut q = SMatrix::<f64, 9, 9>::zeros();
    for k in 0..5 {
        let row = constraint_row(&f0[k], &f1[k]);
        for (c, v) in row.iter().enumerate() {
            q[(k, c)] = *v;
        }
    }
    let svd = q.try_svd(false, true, f64::EPSILON, 500)?;
    let v_t = svd.v_t?;
    let mut order: [usize; 9] = [0, 1, 2, 3, 4, 5, 6, 7, 8];
    let s = &svd.singular_values;
    order.sort_by(|&a, &b| s[b].total_cmp(&s[a]));
    let largest = s[order[0]];
    if !(largest > 0.0) || !(s[order[4]] > DEGENERACY_RATIO * largest) {
        return None;
    }
    let mut basis = [Matrix3::zeros(); 4];
    for (b, &idx) in basis.iter_mut().zip(order[5..].iter()) {
        let r = v_t.row(idx);
        *b = Matrix3::new(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]);
    }
    Some(basis)
}

/// All essential matrices (unit Frobenius norm, sign arbitrary) consistent with 5
/// correspondences of unit (or any non-zero) bearing vectors: `f1[i]ᵀ E f0[i] = 0`.
///
/// Returns up to 10 matrices; none for a degenerate configuration. The solutions are not
/// guaranteed to be distinct (a double root can appear twice). Every one returned is essential
/// (`det E` within 1e-9, the cubic constraints within 1e-8); a candidate that is not (a nearly
/// real complex pair of roots) is dropped.
///
/// ```
/// use momo_core::{Pose, essential, so3_exp};
/// use momo_fivepoint::solve_five_point;
/// use nalgebra::Vector3;
///
/// let c = Pose::new(so3_exp(&Vector3::new(0.02, -0.1, 0.03)), Vector3::new(0.1, 0.0, 1.0));
/// let points = [[1.0, 0.5, 6.0], [-2.0, 0.3, 9.0], [0.4, -1.0, 5.0], [3.0, 1.2, 14.0], [-0.5, -0.7, 7.0]];
/// let (mut f0, mut f1) = ([Vector3::zeros(); 5], [Vector3::zeros(); 5]);
/// for (i, p) in points.iter().enumerate() {
///     let x0 = Vector3::from(*p); // frame k-1
///     let x1 = c.inverse().transform_point(&x0); // frame k
///     (f0[i], f1[i]) = (x0.normalize(), x1.normalize());
/// }
/// let truth = essential(&c).normalize();
/// let solutions = solve_five_point(&f0, &f1);
/// assert!(solutions.iter().any(|e| (e - truth).amax().min((e + truth).amax()) < 1e-9));
/// ```
pub fn solve_five_point(f0: &[Vector3<f64>; 5], f1: &[Vector3<f64>; 5]) -> Vec<Matrix3<f64>> {
    let Some([bx, by, bz, bw]) = null_space(f0, f1) else {
        return Vec::new();
    };
    // E as a matrix of linear polynomials.
    let e: [[Poly; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| Poly::linear(bx[(i, j)], by[(i, j)], bz[(i, j)], bw[(i, j)]))
    });
    let mut m = SMatrix::<f64, 10, 20>::zeros();
    // det E.
    let det = e[0][0]
        .mul(&e[1][1].mul(&e[2][2]).sub(&e[1][2].mul(&e[2][1])))
        .sub(&e[0][1].mul(&e[1][0].mul(&e[2][2]).sub(&e[1][2].mul(&e[2][0]))))
        .add(&e[0][2].mul(&e[1][0].mul(&e[2][1]).sub(&e[1][1].mul(&e[2][0]))));
    for c in 0..20 {
        m[(0, c)] = det.0[c];
    }
    // E Eᵀ and its trace.
    let eet: [[Poly; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| (0..3).fold(Poly::ZERO, |acc, k| acc.add(&e[i][k].mul(&e[j][k]))))
    });
    let trace = eet[0][0].add(&eet[1][1]).add(&eet[2][2]);
    for i in 0..3 {
        for j in 0..3 {
            let p = (0..3)
                .fold(Poly::ZERO, |acc, k| acc.add(&eet[i][k].mul(&e[k][j])))
                .scale(2.0)
                .sub(&trace.mul(&e[i][j]));
            for c in 0..20 {
                m[(1 + 3 * i + j, c)] = p.0[c];
            }
        }
    }
    // Gauss-Jordan: [M1 | M2] → [I | B].
    let m1 = m.fixed_view::<10, 10>(0, 0).into_owned();
    let m2 = m.fixed_view::<10, 10>(0, 10).into_owned();
    let lu = m1.full_piv_lu();
    let Some(b) = lu.solve(&m2) else {
        return Vec::new();
    };
    if !b.iter().all(|v| v.is_finite()) {
        return Vec::new();
    }
    // Action matrix of x on the basis [x², xy, xz, y², yz, z², x, y, z, 1]:
    // x·x² = x³, x·xy = x²y, x·xz = x²z, x·y² = xy², x·yz = xyz, x·z² = xz² (rows 0..5 of the
    // reduced system, m_i = -B_i · basis), x·x = x², x·y = xy, x·z = xz, x·1 = x.
    let mut a = SMatrix::<f64, 10, 10>::zeros();
    for r in 0..6 {
        for c in 0..10 {
            a[(r, c)] = -b[(r, c)];
        }
    }
    a[(6, 0)] = 1.0;
    a[(7, 1)] = 1.0;
    a[(8, 2)] = 1.0;
    a[(9, 6)] = 1.0;
    let Some(schur) = a.try_schur(f64::EPSILON, 1000) else {
        return Vec::new();
    };
    let scale = a.amax().max(1.0);
    let mut out = Vec::with_capacity(10);
    for lambda in schur.complex_eigenvalues().iter() {
        if !(lambda.im.abs() <= 1e-8 * (scale + lambda.re.abs())) {
            continue;
        }
        let x = lambda.re;
        // The cheap eigenvector first; where polishing from it does not reach an essential
        // matrix, the eigenvector from the SVD of `A - x I` (see `y_z_by_svd`).
        let tries: [EigenvectorYZ; 2] = [y_z_of_root, y_z_by_svd];
        for y_z in tries {
            let Some((y, z)) = y_z(&a, x) else {
                continue;
            };
            let (x, y, z) = polish(&m, x, y, z);
            let em = bx * x + by * y + bz * z + bw;
            let n = em.norm();
            if n > 0.0 && n.is_finite() && is_essential(&(em / n)) {
                out.push(em / n);
                break;
            }
        }
    }
    out
}

/// A way to read `(y, z)` of the action matrix's eigenvector for an eigenvalue `x`.
type EigenvectorYZ = fn(&SMatrix<f64, 10, 10>, f64) -> Option<(f64, f64)>;

/// Whether a unit-norm `E` satisfies the essential-matrix constraints: `det E = 0` (within
/// 1e-9) and the cubic constraints `2 E Eᵀ E − tr(E Eᵀ) E = 0` (within 1e-8). A nearly real
/// complex pair of the action matrix's eigenvalues passes the eigenvalue test but has no real
/// root nearby: [`polish`] cannot converge there and the matrix it gives is not essential
/// (seen: `det E` 7.4e-4, the cubic constraints 2.3e-3, returned twice).
fn is_essential(e: &Matrix3<f64>) -> bool {
    let eet = e * e.transpose();
    let cubic = 2.0 * eet * e - eet.trace() * e;
    e.determinant().abs() <= 1e-9 && cubic.amax() <= 1e-8
}

/// `(y, z)` of the eigenvector of the action matrix `a` for the eigenvalue `x`.
///
/// The eigenvector is the basis `v = [x², xy, xz, y², yz, z², x, y, z, 1]` at the solution;
/// with `v₉ = 1` the trivial rows 6..9 fix `v₆ = x`, `v₀ = x²`, `v₁ = x y`, `v₂ = x z`, and
/// rows 0..5 of `A v = x v` (right-hand sides `x³, x²y, x²z, xy², xyz, xz²`) are 6 linear equations in `u = (y², yz, z², y, z)`, solved in the
/// least-squares sense (cheaper than a 10x10 SVD per root; [`polish`] removes the error).
fn y_z_of_root(a: &SMatrix<f64, 10, 10>, x: f64) -> Option<(f64, f64)> {
    let mut g = SMatrix::<f64, 6, 5>::zeros();
    let mut h = SVector::<f64, 6>::zeros();
    for r in 0..6 {
        // The right-hand side x v_r: x³, x² y, x² z, x y², x yz, x z².
        let d = |k: usize| if r == k { 1.0 } else { 0.0 };
        g[(r, 0)] = a[(r, 3)] - x * d(3);
        g[(r, 1)] = a[(r, 4)] - x * d(4);
        g[(r, 2)] = a[(r, 5)] - x * d(5);
        g[(r, 3)] = a[(r, 1)] * x + a[(r, 7)] - x * x * d(1);
        g[(r, 4)] = a[(r, 2)] * x + a[(r, 8)] - x * x * d(2);
        h[r] = -(a[(r, 0)] * x * x + a[(r, 6)] * x + a[(r, 9)]) + x * x * x * d(0);
    }
    let u = g.svd(true, true).solve(&h, 1e-14).ok()?;
    (u[3].is_finite() && u[4].is_finite()).then_some((u[3], u[4]))
}

/// `(y, z)` of the eigenvector of `a` for the eigenvalue `x`, as the right singular vector of
/// `A - x I` with the smallest singular value (`v₇ / v₉`, `v₈ / v₉`).
///
/// The fallback of [`y_z_of_root`]: its 6x5 least-squares system drops rows 6..9 and loses
/// the root when those 6 equations are nearly dependent at `x`; the full 10x10 null vector
/// does not. On 200,000 random 5-point samples (general motions, points 2-30 m in a 90 x 70 deg
/// view) the true `E` was missed 13 times with the 6x5 system alone and 3 times with this
/// fallback, which runs only for roots the first try did not turn into an essential matrix.
fn y_z_by_svd(a: &SMatrix<f64, 10, 10>, x: f64) -> Option<(f64, f64)> {
    let shifted = a - SMatrix::<f64, 10, 10>::identity() * x;
    let svd = shifted.svd(false, true);
    let v_t = svd.v_t?;
    let s = &svd.singular_values;
    let i = (0..10).min_by(|&p, &q| s[p].total_cmp(&s[q]))?;
    let v = v_t.row(i);
    let (y, z) = (v[7] / v[9], v[8] / v[9]);
    (y.is_finite() && z.is_finite()).then_some((y, z))
}

/// `x^a y^b z^c` with `powi` on small exponents.
fn pow3(x: f64, y: f64, z: f64, e: [u8; 3]) -> f64 {
    x.powi(e[0] as i32) * y.powi(e[1] as i32) * z.powi(e[2] as i32)
}

/// A few Gauss-Newton steps on the 10 cubic equations `M m(x, y, z) = 0` from a root of the
/// action matrix. Eigenvectors of nearly equal eigenvalues are ill-conditioned, so `(y, z)`
/// read from them can be off by far more than rounding; the equations themselves are
/// well-conditioned near a simple root. A step is kept only if it lowers the residual.
fn polish(m: &SMatrix<f64, 10, 20>, x: f64, y: f64, z: f64) -> (f64, f64, f64) {
    let residual = |x: f64, y: f64, z: f64| {
        let mono = SVector::<f64, 20>::from_fn(|i, _| pow3(x, y, z, MONOMIALS[i]));
        m * mono
    };
    let (mut x, mut y, mut z) = (x, y, z);
    let mut r = residual(x, y, z);
    let mut norm = r.norm_squared();
    for _ in 0..5 {
        if !(norm > 0.0) {
            break;
        }
        let mut d = SMatrix::<f64, 20, 3>::zeros();
        for (i, e) in MONOMIALS.iter().enumerate() {
            for v in 0..3 {
                if e[v] > 0 {
                    let mut lower = *e;
                    lower[v] -= 1;
                    d[(i, v)] = e[v] as f64 * pow3(x, y, z, lower);
                }
            }
        }
        let j = m * d;
        let Some(step) = (j.transpose() * j).lu().solve(&(-(j.transpose() * r))) else {
            break;
        };
        let (nx, ny, nz) = (x + step[0], y + step[1], z + step[2]);
        let nr = residual(nx, ny, nz);
        let nn = nr.norm_squared();
        if !(nn < norm) {
            break;
        }
        (x, y, z, r, norm) = (nx, ny, nz, nr, nn);
    }
    (x, y, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_table_is_consistent() {
        // x · x² = x³, z · 1 = z, x² · x² overflows.
        assert_eq!(PRODUCT[16][10], 0);
        assert_eq!(PRODUCT[18][19], 18);
        assert_eq!(PRODUCT[10][10], NONE);
    }

    #[test]
    fn identical_correspondences_are_degenerate() {
        let f = Vector3::new(0.1, 0.2, 1.0).normalize();
        assert!(solve_five_point(&[f; 5], &[f; 5]).is_empty());
    }
}
