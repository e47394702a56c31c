//! The general motion model [`Se3`].

use crate::rotation::half_angle_sinc;
use momo_core::{Manifold, Pose, Scalar, so3_exp, so3_log};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// General rigid motion, parameterised for a vehicle: a rotation vector, the direction of
/// travel on the unit sphere and the arc length.
///
/// Parameters `["rot_x", "rot_y", "rot_z", "heading", "climb", "arc_length"]`:
///
/// - `R = exp([w]ₓ)` with `w = (rot_x, rot_y, rot_z)` ([`momo_core::so3_exp`], exact at
///   `w = 0`; for a planar curve `rot_z` is the yaw);
/// - direction `d = (cos(climb) cos(heading), cos(climb) sin(heading), sin(climb))`;
/// - `t = d · l · sin(θ/2) / (θ/2)` with `θ = ‖w‖`: the chord of a circular arc of length `l`
///   that turns by `θ`, so that a planar motion agrees with [`crate::SingleTrack2d`]
///   (`|t| = l sinc(γ/2)`). The factor is [`crate::half_angle_sinc`] of `θ²`, differentiable
///   at `w = 0`.
///
/// With the arc length held fixed (from odometry) 5 parameters are free. Type tag `se3`.
///
/// ```
/// use momo_core::Manifold;
/// use momo_models::{Se3, SingleTrack2d};
///
/// // A planar left curve: Se3 with rot_z = yaw and heading = yaw/2 is the single-track motion.
/// let (yaw, l) = (0.2, 1.3);
/// let a = Se3.motion(&[0.0, 0.0, yaw, 0.5 * yaw, 0.0, l]);
/// let b = SingleTrack2d.motion(&[yaw, l]);
/// assert!((a.rotation - b.rotation).amax() < 1e-15);
/// assert!((a.translation - b.translation).amax() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Se3;

impl Manifold for Se3 {
    const PARAMS: &'static [&'static str] =
        &["rot_x", "rot_y", "rot_z", "heading", "climb", "arc_length"];
    const ARC_LENGTH: Option<usize> = Some(5);

    #[inline]
    fn motion<T: Scalar>(&self, p: &[T]) -> Pose<T> {
        let w = Vector3::new(p[0], p[1], p[2]);
        let (heading, climb, l) = (p[3], p[4], p[5]);
        let cc = climb.cos();
        let d = Vector3::new(cc * heading.cos(), cc * heading.sin(), climb.sin());
        Pose::new(so3_exp(&w), d * (l * half_angle_sinc(w.norm_squared())))
    }

    /// `w = log(R)` ([`momo_core::so3_log`]); `d = t / |t|`, flipped (with a negative arc length)
    /// when it points backwards (`d.x < 0`) so that the heading stays within ±90° of the
    /// vehicle's forward axis; `heading = atan2(d.y, d.x)`, `climb = atan2(d.z, hypot(d.x, d.y))`,
    /// `l = ±|t| / sinc(θ/2)`. A zero translation gives heading, climb and arc length 0.
    fn params_from_motion(&self, m: &Pose<f64>) -> Option<Vec<f64>> {
        let w = so3_log(&m.rotation);
        let t = m.translation;
        let n = t.norm();
        if n == 0.0 {
            return Some(vec![w.x, w.y, w.z, 0.0, 0.0, 0.0]);
        }
        let (d, sign) = if t.x < 0.0 {
            (-t / n, -1.0)
        } else {
            (t / n, 1.0)
        };
        let heading = d.y.atan2(d.x);
        let climb = d.z.atan2(d.x.hypot(d.y));
        let l = sign * n / half_angle_sinc(w.norm_squared());
        Some(vec![w.x, w.y, w.z, heading, climb, l])
    }
}
