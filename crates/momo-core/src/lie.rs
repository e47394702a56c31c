//! Rigid motions: [`Pose`] and our own SO(3) / SE(3) exponential and logarithm maps.
//!
//! nalgebra's `Rotation3::new` and `UnitQuaternion::from_scaled_axis` branch on the norm of the
//! rotation vector and return a *zero* Jacobian at the identity when evaluated on dual numbers.
//! The maps here branch on the squared norm and use Taylor series near zero, so that value and
//! derivative are exact at (and near) the identity. Formulas: Barfoot, *State Estimation for
//! Robotics*, eqs. (7.14), (7.86), (7.95).

use crate::scalar::Scalar;
use nalgebra::{Matrix3, Matrix4, Vector3};
use serde::{Deserialize, Serialize};

/// Below this squared angle (rad²) the series expansions are used.
const SMALL_ANGLE_SQ: f64 = 1e-6;

/// The skew-symmetric matrix `[w]_x` with `[w]_x v = w × v`.
#[inline]
pub fn hat<T: Scalar>(w: &Vector3<T>) -> Matrix3<T> {
    let z = T::zero();
    Matrix3::new(z, -w.z, w.y, w.z, z, -w.x, -w.y, w.x, z)
}

/// The inverse of [`hat`]: `(m[2,1], m[0,2], m[1,0])`.
#[inline]
pub fn vee<T: Scalar>(m: &Matrix3<T>) -> Vector3<T> {
    Vector3::new(m[(2, 1)], m[(0, 2)], m[(1, 0)])
}

/// Coefficients `a = sin θ / θ`, `b = (1 - cos θ) / θ²`, `c = (θ - sin θ) / θ³` from `θ²`.
#[inline]
fn so3_coefficients<T: Scalar>(theta_sq: T) -> (T, T, T) {
    if theta_sq < T::c(SMALL_ANGLE_SQ) {
        let t2 = theta_sq;
        let t4 = t2 * t2;
        (
            T::one() - t2 / T::c(6.0) + t4 / T::c(120.0),
            T::c(0.5) - t2 / T::c(24.0) + t4 / T::c(720.0),
            T::c(1.0 / 6.0) - t2 / T::c(120.0) + t4 / T::c(5040.0),
        )
    } else {
        let theta = theta_sq.sqrt();
        let s = theta.sin();
        (
            s / theta,
            {
                let h = (theta * T::c(0.5)).sin();
                h * h * T::c(2.0) / theta_sq
            },
            (theta - s) / (theta_sq * theta),
        )
    }
}

/// SO(3) exponential (Rodrigues): `R = I + a [w]_x + b [w]_x²`.
///
/// Written out entry by entry in the order nalgebra evaluates `I + k a + (k k) b` with
/// `k = [w]_x`: `R_ij = (I_ij + k_ij a) + ((k_i0 k_0j + k_i1 k_1j) + k_i2 k_2j) b`. nalgebra's
/// generic product (its `gemv` per column) forms the same sums with extra factors of exactly
/// one (`(1 · k_i0) k_0j + 1 · y`), which change no bit on `f64` or on dual numbers, so this is
/// bit-identical to the matrix expression (test `so3_exp_matches_the_matrix_expression_bitwise`)
/// without its calls and copies (the dual-number motion of every linearisation).
#[inline]
pub fn so3_exp<T: Scalar>(w: &Vector3<T>) -> Matrix3<T> {
    let (a, b, _) = so3_coefficients(w.norm_squared());
    let k = hat(w);
    let (z, o) = (T::zero(), T::one());
    Matrix3::from_fn(|i, j| {
        let kk = (k[(i, 0)] * k[(0, j)] + k[(i, 1)] * k[(1, j)]) + k[(i, 2)] * k[(2, j)];
        let id = if i == j { o } else { z };
        (id + k[(i, j)] * a) + kk * b
    })
}

/// SO(3) logarithm: the rotation vector `w` with `so3_exp(w) = r`, `|w| <= π`.
///
/// Exact in value and derivative near the identity (series in `sin θ`), and stable near `θ = π`
/// (axis from the symmetric part).
pub fn so3_log<T: Scalar>(r: &Matrix3<T>) -> Vector3<T> {
    let cos_theta = ((r.trace() - T::one()) * T::c(0.5)).clamp(-T::one(), T::one());
    let s = vee(&(r - r.transpose())) * T::c(0.5); // sin θ · axis
    if cos_theta > T::c(1.0 - 1e-6) {
        // θ ≈ sin θ (1 + sin²θ / 6)
        let s2 = s.norm_squared();
        s * (T::one() + s2 / T::c(6.0) + s2 * s2 * T::c(3.0 / 40.0))
    } else if cos_theta < T::c(-1.0 + 1e-6) {
        // Near π: sym(R) = cos θ I + (1 - cos θ) n nᵀ; take n from its largest diagonal entry
        // and the sign from the antisymmetric part (sin θ · n).
        let nn = ((r + r.transpose()) * T::c(0.5) - Matrix3::identity() * cos_theta)
            / (T::one() - cos_theta);
        let i = if nn[(0, 0)] >= nn[(1, 1)] && nn[(0, 0)] >= nn[(2, 2)] {
            0
        } else if nn[(1, 1)] >= nn[(2, 2)] {
            1
        } else {
            2
        };
        let n = (nn.column(i) / nn[(i, i)].max(T::c(1e-300)).sqrt()).normalize();
        let theta = s.norm().atan2(cos_theta);
        if n.dot(&s) < T::zero() {
            n * -theta
        } else {
            n * theta
        }
    } else {
        let sn = s.norm();
        s * (sn.atan2(cos_theta) / sn)
    }
}

/// A rigid motion `x ↦ R x + t` (an element of SE(3)), generic over the scalar.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose<T: Scalar> {
    /// Rotation matrix `R` (orthonormal, det +1).
    pub rotation: Matrix3<T>,
    /// Translation `t`.
    pub translation: Vector3<T>,
}

impl<T: Scalar> Pose<T> {
    /// A pose from rotation and translation.
    #[inline]
    pub fn new(rotation: Matrix3<T>, translation: Vector3<T>) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// The identity motion.
    #[inline]
    pub fn identity() -> Self {
        Self::new(Matrix3::identity(), Vector3::zeros())
    }

    /// Composition `self ∘ other`: `x ↦ R_s (R_o x + t_o) + t_s`.
    #[inline]
    pub fn compose(&self, other: &Pose<T>) -> Pose<T> {
        Pose::new(
            self.rotation * other.rotation,
            self.rotation * other.translation + self.translation,
        )
    }

    /// The inverse motion `x ↦ Rᵀ (x - t)`.
    #[inline]
    pub fn inverse(&self) -> Pose<T> {
        let rt = self.rotation.transpose();
        Pose::new(rt, -(rt * self.translation))
    }

    /// Applies the motion to a point.
    #[inline]
    pub fn transform_point(&self, p: &Vector3<T>) -> Vector3<T> {
        self.rotation * p + self.translation
    }

    /// SE(3) exponential of the twist `(ρ, w)`: `R = exp(w)`, `t = V ρ` with
    /// `V = I + b [w]_x + c [w]_x²`.
    pub fn exp(rho: &Vector3<T>, w: &Vector3<T>) -> Pose<T> {
        let (a, b, c) = so3_coefficients(w.norm_squared());
        let k = hat(w);
        let k2 = k * k;
        let r = Matrix3::identity() + k * a + k2 * b;
        let v = Matrix3::identity() + k * b + k2 * c;
        Pose::new(r, v * rho)
    }

    /// SE(3) logarithm: the twist `(ρ, w)` with `Pose::exp(ρ, w) = self`.
    pub fn log(&self) -> (Vector3<T>, Vector3<T>) {
        let w = so3_log(&self.rotation);
        let theta_sq = w.norm_squared();
        let k = hat(&w);
        // V⁻¹ = I - ½ [w]_x + d [w]_x², d = (1 - a / (2 b)) / θ².
        let d = if theta_sq < T::c(SMALL_ANGLE_SQ) {
            T::c(1.0 / 12.0) + theta_sq / T::c(720.0) + theta_sq * theta_sq / T::c(30240.0)
        } else {
            let (a, b, _) = so3_coefficients(theta_sq);
            (T::one() - a / (b * T::c(2.0))) / theta_sq
        };
        let v_inv = Matrix3::identity() - k * T::c(0.5) + k * k * d;
        (v_inv * self.translation, w)
    }

    /// Lifts an `f64` pose into this scalar type (constants, zero derivative).
    #[inline]
    pub fn lift(p: &Pose<f64>) -> Pose<T> {
        Pose::new(p.rotation.map(T::c), p.translation.map(T::c))
    }
}

impl Pose<f64> {
    /// The 4x4 homogeneous matrix `[R t; 0 1]`.
    pub fn to_homogeneous(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }

    /// The pose of a 4x4 homogeneous matrix (the bottom row is not checked).
    pub fn from_homogeneous(m: &Matrix4<f64>) -> Self {
        Pose::new(
            m.fixed_view::<3, 3>(0, 0).into_owned(),
            m.fixed_view::<3, 1>(0, 3).into_owned(),
        )
    }

    /// Largest deviation of `RᵀR` from the identity and of `det R` from 1.
    pub fn orthonormality_error(&self) -> f64 {
        let e = (self.rotation.transpose() * self.rotation - Matrix3::identity()).amax();
        e.max((self.rotation.determinant() - 1.0).abs())
    }

    /// The pose with its rotation replaced by the nearest rotation matrix (polar
    /// decomposition by SVD, `U Vᵀ` with its determinant made +1): a product of poses read to
    /// a file's precision drifts from orthonormal by the sum of their errors.
    pub fn orthonormalized(&self) -> Self {
        let svd = self.rotation.svd(true, true);
        let rotation = match (svd.u, svd.v_t) {
            (Some(mut u), Some(v_t)) => {
                if (u * v_t).determinant() < 0.0 {
                    u.column_mut(2).neg_mut();
                }
                u * v_t
            }
            _ => self.rotation,
        };
        Pose::new(rotation, self.translation)
    }

    /// Rotation angle of `R` in radians (0..=π).
    pub fn rotation_angle(&self) -> f64 {
        so3_log(&self.rotation).norm()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::U1;
    use num_dual::DualSVec64;
    use proptest::prelude::*;

    type D3 = DualSVec64<3>;

    /// d exp(w) / d w_i at w = 0 must be the generator hat(e_i).
    #[test]
    fn so3_exp_jacobian_at_identity_is_the_generator() {
        let w = Vector3::new(
            D3::from_re(0.0).derivative(0),
            D3::from_re(0.0).derivative(1),
            D3::from_re(0.0).derivative(2),
        );
        let r = so3_exp(&w);
        for i in 0..3 {
            let mut e = Vector3::zeros();
            e[i] = 1.0;
            let g = hat(&e);
            for row in 0..3 {
                for col in 0..3 {
                    let eps = r[(row, col)].eps.unwrap_generic(nalgebra::U3, U1);
                    assert_eq!(eps[i], g[(row, col)], "entry ({row},{col}) wrt w{i}");
                }
            }
        }
    }

    /// The matrix expression [`so3_exp`] writes out (its reference).
    fn so3_exp_matrix<T: Scalar>(w: &Vector3<T>) -> Matrix3<T> {
        let (a, b, _) = so3_coefficients(w.norm_squared());
        let k = hat(w);
        Matrix3::identity() + k * a + k * k * b
    }

    /// The bits of a dual number: value and derivatives (`None` as no bits).
    fn dual_bits<const N: usize>(x: &DualSVec64<N>) -> (u64, Option<Vec<u64>>) {
        (
            x.re.to_bits(),
            x.eps
                .0
                .as_ref()
                .map(|e| e.iter().map(|v| v.to_bits()).collect()),
        )
    }

    proptest! {
        /// Bit for bit on `f64` and on dual numbers (5 and 8 derivatives, some components
        /// constant), over both branches of the coefficients and with exact zeros (signed).
        #[test]
        fn so3_exp_matches_the_matrix_expression_bitwise(
            w in proptest::array::uniform3(prop_oneof![
                Just(0.0), Just(-0.0), -1e-4..1e-4_f64, -3.0..3.0_f64
            ]),
            free in proptest::array::uniform3(any::<bool>()),
        ) {
            let v = Vector3::from(w);
            let (x, y) = (so3_exp(&v), so3_exp_matrix(&v));
            for i in 0..9 {
                prop_assert_eq!(x[i].to_bits(), y[i].to_bits());
            }
            let d5 = Vector3::from_fn(|i, _| {
                let d = DualSVec64::<5>::from_re(w[i]);
                if free[i] { d.derivative(i + 1) } else { d }
            });
            let (x, y) = (so3_exp(&d5), so3_exp_matrix(&d5));
            for i in 0..9 {
                prop_assert_eq!(dual_bits(&x[i]), dual_bits(&y[i]));
            }
            let d8 = Vector3::from_fn(|i, _| DualSVec64::<8>::from_re(w[i]).derivative(2 * i));
            let (x, y) = (so3_exp(&d8), so3_exp_matrix(&d8));
            for i in 0..9 {
                prop_assert_eq!(dual_bits(&x[i]), dual_bits(&y[i]));
            }
        }
    }

    /// nalgebra's own map gets this wrong on dual numbers; this documents why we have our own.
    #[test]
    fn nalgebra_rotation_new_has_zero_jacobian_at_identity() {
        let w = Vector3::new(
            D3::from_re(0.0).derivative(0),
            D3::from_re(0.0),
            D3::from_re(0.0),
        );
        let r = nalgebra::Rotation3::new(w);
        let eps = r.matrix()[(2, 1)].eps.unwrap_generic(nalgebra::U3, U1);
        assert_eq!(
            eps[0], 0.0,
            "if nalgebra fixed this, our workaround may be retired"
        );
    }

    fn vec3(scale: f64) -> impl Strategy<Value = Vector3<f64>> {
        (-scale..scale, -scale..scale, -scale..scale).prop_map(|(x, y, z)| Vector3::new(x, y, z))
    }

    proptest! {
        #[test]
        fn exp_log_roundtrip(w in vec3(3.0), tiny in vec3(1e-5)) {
            for w in [w, tiny] {
                prop_assume!(w.norm() < 3.1);
                let r = so3_exp(&w);
                let r2 = so3_exp(&so3_log(&r));
                prop_assert!((r - r2).amax() < 1e-12);
                prop_assert!((so3_log(&r) - w).amax() < 1e-10);
                prop_assert!(Pose::new(r, Vector3::zeros()).orthonormality_error() < 1e-12);
            }
        }

        #[test]
        fn exp_log_near_pi(axis in vec3(1.0), delta in -1e-4f64..1e-4) {
            prop_assume!(axis.norm() > 0.1);
            let w = axis.normalize() * (std::f64::consts::PI - delta.abs());
            let r = so3_exp(&w);
            prop_assert!((so3_exp(&so3_log(&r)) - r).amax() < 1e-8);
        }

        #[test]
        fn se3_exp_log_roundtrip(rho in vec3(5.0), w in vec3(2.0)) {
            prop_assume!(w.norm() < 3.1);
            let p = Pose::exp(&rho, &w);
            let (rho2, w2) = p.log();
            prop_assert!((rho - rho2).amax() < 1e-9);
            prop_assert!((w - w2).amax() < 1e-10);
        }

        #[test]
        fn so3_log_derivative_matches_finite_differences(w in vec3(1.0), tiny in vec3(1e-4)) {
            for w0 in [w, tiny] {
                // d log(exp(w)) / dw = I everywhere inside the ball
                let wd = Vector3::new(
                    D3::from_re(w0.x).derivative(0),
                    D3::from_re(w0.y).derivative(1),
                    D3::from_re(w0.z).derivative(2),
                );
                let l = so3_log(&so3_exp(&wd));
                for i in 0..3 {
                    let eps = l[i].eps.unwrap_generic(nalgebra::U3, U1);
                    for j in 0..3 {
                        let expect = if i == j { 1.0 } else { 0.0 };
                        prop_assert!((eps[j] - expect).abs() < 1e-8, "{eps} at {w0}");
                    }
                }
            }
        }
    }

    #[test]
    fn compose_inverse_is_identity() {
        let p = Pose::exp(&Vector3::new(1.0, -2.0, 0.5), &Vector3::new(0.1, 0.2, -0.3));
        let i = p.compose(&p.inverse());
        assert!((i.rotation - Matrix3::identity()).amax() < 1e-14);
        assert!(i.translation.amax() < 1e-14);
        let h = p.to_homogeneous();
        assert_eq!(Pose::from_homogeneous(&h), p);
    }

    #[test]
    fn orthonormalized_is_the_nearest_rotation() {
        let r = so3_exp(&Vector3::new(0.3, -0.2, 0.1));
        let p = Pose::new(r, Vector3::new(1.0, 2.0, 3.0));
        // A rotation off by 2e-6, as a product of two poses read to 1e-6.
        let mut off = p;
        off.rotation[(0, 1)] += 2e-6;
        off.rotation[(2, 2)] -= 1e-6;
        assert!(off.orthonormality_error() > 1e-6);
        let q = off.orthonormalized();
        assert!(q.orthonormality_error() < 1e-14);
        assert!((q.rotation - r).amax() < 3e-6);
        assert_eq!(q.translation, p.translation);
        // A reflection becomes a rotation.
        let mut mirrored = p;
        mirrored.rotation.column_mut(0).neg_mut();
        let q = mirrored.orthonormalized();
        assert!(q.orthonormality_error() < 1e-14);
        assert!((q.rotation.determinant() - 1.0).abs() < 1e-12);
    }
}
