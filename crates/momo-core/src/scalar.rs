//! The scalar abstraction: everything differentiable is written once over [`Scalar`] and runs on
//! `f64` and on num-dual's fixed-size dual numbers ([`num_dual::DualSVec64`]).

use nalgebra::{Matrix3, RealField, Vector3};
use std::ops::Mul;

/// A real scalar that the motion models and residual metrics are generic over.
///
/// Implemented for every `T: RealField + Copy + Mul<f64>`, in particular `f64` and
/// `num_dual::DualSVec64<N>`. Multiplying by a plain `f64` ([`mul_const`], [`dot_const`]) is
/// much cheaper on dual numbers than lifting the constant first: use it in per-match code. Comparisons (`<`, `>`) on dual numbers look at the real part only,
/// which is what branches of series expansions need.
pub trait Scalar: RealField + Copy + Mul<f64, Output = Self> {
    /// Lifts a constant into the scalar type (a dual number with zero derivative).
    #[inline(always)]
    fn c(x: f64) -> Self {
        nalgebra::convert(x)
    }
}

impl<T: RealField + Copy + Mul<f64, Output = T>> Scalar for T {}

/// `m v` for a matrix of scalars and a constant vector, without lifting the constants.
#[inline(always)]
pub fn mul_const<T: Scalar>(m: &Matrix3<T>, v: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(
        m[(0, 0)] * v.x + m[(0, 1)] * v.y + m[(0, 2)] * v.z,
        m[(1, 0)] * v.x + m[(1, 1)] * v.y + m[(1, 2)] * v.z,
        m[(2, 0)] * v.x + m[(2, 1)] * v.y + m[(2, 2)] * v.z,
    )
}

/// `mᵀ v` for a matrix of scalars and a constant vector, without lifting the constants.
#[inline(always)]
pub fn tr_mul_const<T: Scalar>(m: &Matrix3<T>, v: &Vector3<f64>) -> Vector3<T> {
    Vector3::new(
        m[(0, 0)] * v.x + m[(1, 0)] * v.y + m[(2, 0)] * v.z,
        m[(0, 1)] * v.x + m[(1, 1)] * v.y + m[(2, 1)] * v.z,
        m[(0, 2)] * v.x + m[(1, 2)] * v.y + m[(2, 2)] * v.z,
    )
}

/// `a · b` for a vector of scalars and a constant vector.
#[inline(always)]
pub fn dot_const<T: Scalar>(a: &Vector3<T>, b: &Vector3<f64>) -> T {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// `sin(x) / x`, exact in value and derivative at `x = 0` (Taylor series for `|x| < 1e-3`).
#[inline]
pub fn sinc<T: Scalar>(x: T) -> T {
    if x.abs() < T::c(1e-3) {
        let x2 = x * x;
        T::one() - x2 / T::c(6.0) + x2 * x2 / T::c(120.0)
    } else {
        x.sin() / x
    }
}

/// `(1 - cos(x)) / x`, exact in value and derivative at `x = 0` (Taylor series for `|x| < 1e-3`).
#[inline]
pub fn cosc<T: Scalar>(x: T) -> T {
    if x.abs() < T::c(1e-3) {
        let x2 = x * x;
        x / T::c(2.0) - x * x2 / T::c(24.0) + x * x2 * x2 / T::c(720.0)
    } else {
        let h = (x * T::c(0.5)).sin();
        h * h * T::c(2.0) / x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::DualSVec64;

    fn d(x: f64) -> DualSVec64<1> {
        DualSVec64::from_re(x).derivative(0)
    }

    #[test]
    fn sinc_and_cosc_are_smooth_at_zero() {
        let s = sinc(d(0.0));
        assert_eq!(s.re, 1.0);
        assert_eq!(s.eps.unwrap_generic(nalgebra::U1, nalgebra::U1)[0], 0.0);
        let c = cosc(d(0.0));
        assert_eq!(c.re, 0.0);
        assert!((c.eps.unwrap_generic(nalgebra::U1, nalgebra::U1)[0] - 0.5).abs() < 1e-15);
        // Both branches agree at the switch point.
        for x in [0.999e-3, 1.001e-3] {
            assert!((sinc(x) - f64::sin(x) / x).abs() < 1e-15);
            assert!((cosc(x) - 2.0 * f64::sin(0.5 * x).powi(2) / x).abs() < 1e-15);
        }
    }
}
