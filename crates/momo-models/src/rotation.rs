//! Elementary rotations and the circular-arc chord, generic over the scalar.

use momo_core::{Scalar, cosc, sinc};
use nalgebra::{Matrix3, Vector3};

/// `Rz(a)`: rotation by `a` about the z axis (yaw; positive turns x towards y, i.e. left).
#[inline]
pub fn rot_z<T: Scalar>(a: T) -> Matrix3<T> {
    let (s, c) = (a.sin(), a.cos());
    let (z, o) = (T::zero(), T::one());
    Matrix3::new(c, -s, z, s, c, z, z, z, o)
}

/// `Ry(a)`: rotation by `a` about the y axis (pitch; positive turns x towards -z, nose down).
#[inline]
pub fn rot_y<T: Scalar>(a: T) -> Matrix3<T> {
    let (s, c) = (a.sin(), a.cos());
    let (z, o) = (T::zero(), T::one());
    Matrix3::new(c, z, s, z, o, z, -s, z, c)
}

/// `Rx(a)`: rotation by `a` about the x axis (roll; positive turns y towards z).
#[inline]
pub fn rot_x<T: Scalar>(a: T) -> Matrix3<T> {
    let (s, c) = (a.sin(), a.cos());
    let (z, o) = (T::zero(), T::one());
    Matrix3::new(o, z, z, z, c, -s, z, s, c)
}

/// The chord of a planar circular arc of length `l` that turns by `yaw` (the paper's
/// Eq. (motion_model) with radius `r = l / γ`):
/// `t = (l sin γ / γ, l (1 - cos γ) / γ, 0) = l · sinc(γ/2) · (cos(γ/2), sin(γ/2), 0)`,
/// with [`sinc`] and [`cosc`] exact in value and derivative at `γ = 0`.
#[inline]
pub fn arc_chord<T: Scalar>(yaw: T, arc_length: T) -> Vector3<T> {
    Vector3::new(arc_length * sinc(yaw), arc_length * cosc(yaw), T::zero())
}

/// The arc length whose [`arc_chord`] with this `yaw` is closest to `t` (the in-plane least
/// squares projection `(t · u) / sinc(γ/2)` with `u = (cos(γ/2), sin(γ/2), 0)`); negative when
/// `t` points backwards. `|γ| <= π` keeps `sinc(γ/2) >= 2/π`.
pub fn arc_length_from_chord(yaw: f64, t: &Vector3<f64>) -> f64 {
    let h = 0.5 * yaw;
    (t.x * h.cos() + t.y * h.sin()) / sinc(h)
}

/// `sin(θ/2) / (θ/2)` as a function of `θ²`: the ratio of chord to arc length of a circular arc
/// that turns by `θ`. A Taylor series in `θ²` below `θ² = 1e-6`
/// (`1 - θ²/24 + θ⁴/1920`), so that value and derivative are exact at `θ = 0` without taking
/// `sqrt(0)` of a dual number.
#[inline]
pub fn half_angle_sinc<T: Scalar>(theta_sq: T) -> T {
    if theta_sq < T::c(1e-6) {
        T::one() - theta_sq / T::c(24.0) + theta_sq * theta_sq / T::c(1920.0)
    } else {
        let h = theta_sq.sqrt() * T::c(0.5);
        h.sin() / h
    }
}
