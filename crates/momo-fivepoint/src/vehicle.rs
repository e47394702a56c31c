//! Camera motion (unit translation) → vehicle motion, with the scale from the odometry arc length.

use momo_core::Pose;

/// `sin(θ/2) / (θ/2)`: the ratio of chord to arc length of a circular arc turning by `θ`.
pub fn half_angle_sinc(theta: f64) -> f64 {
    let h = 0.5 * theta;
    if h.abs() < 1e-4 {
        1.0 - h * h / 6.0
    } else {
        h.sin() / h
    }
}

/// The vehicle motion `M = P C_s P⁻¹` of a camera motion `C = [R_C | t_C]` known up to scale
/// (`C_s = [R_C | s t_C/|t_C|]`), `P = T_vehicle_camera`.
///
/// `R_M = R_P R_C R_Pᵀ` and `t_M = s a + b` with `a = R_P t_C/|t_C|` and
/// `b = (I - R_M) p` (`p` the camera's position in the vehicle frame). The scale `s ≥ 0` solves
/// `|t_M| = chord`, the scalar quadratic `s² + 2 (a·b) s + |b|² - chord² = 0` (its larger
/// root). If no `s ≥ 0` reaches the chord exactly (`|b|` too large, only with a large lever arm
/// and a tiny arc), the closest `s ≥ 0` is used.
///
/// The chord is the one of a circular arc of length `|arc_length|` turning by the rotation
/// angle `θ` of `M`: `|arc_length| · sin(θ/2)/(θ/2)`, as in `momo_models::Se3` (for planar
/// motion exactly the single-track chord). `Some(0.0)` gives the rotation only (`t_M = 0`,
/// standstill); `None` gives a unit chord, i.e. the direction of travel only.
///
/// The sign of `t_C` is taken as is (the cheirality test fixed it). `None` if `C` or `P` is not
/// finite; a zero camera translation gives the rotation only.
pub fn vehicle_motion_from_camera(
    camera_motion: &Pose<f64>,
    t_vehicle_camera: &Pose<f64>,
    arc_length: Option<f64>,
) -> Option<Pose<f64>> {
    let finite = |p: &Pose<f64>| {
        p.rotation
            .iter()
            .chain(p.translation.iter())
            .all(|v| v.is_finite())
    };
    if !finite(camera_motion) || !finite(t_vehicle_camera) {
        return None;
    }
    let rp = t_vehicle_camera.rotation;
    let p = t_vehicle_camera.translation;
    let rm = rp * camera_motion.rotation * rp.transpose();
    let rotation_only = Pose::new(rm, nalgebra::Vector3::zeros());
    let Some(tc) = camera_motion.translation.try_normalize(0.0) else {
        return Some(rotation_only);
    };
    let theta = Pose::new(rm, nalgebra::Vector3::zeros()).rotation_angle();
    let chord = match arc_length {
        Some(l) if !l.is_finite() => return None,
        Some(l) => l.abs() * half_angle_sinc(theta),
        None => 1.0,
    };
    if chord == 0.0 {
        return Some(rotation_only);
    }
    let a = rp * tc;
    let b = p - rm * p;
    let ab = a.dot(&b);
    let disc = ab * ab - b.norm_squared() + chord * chord;
    let s = if disc >= 0.0 {
        (-ab + disc.sqrt()).max(0.0)
    } else {
        (-ab).max(0.0)
    };
    Some(Pose::new(rm, a * s + b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::{camera_motion, so3_exp};
    use nalgebra::Vector3;

    fn extrinsic() -> Pose<f64> {
        Pose::new(
            so3_exp(&Vector3::new(-1.2, 1.2, -1.2)),
            Vector3::new(1.5, 0.1, 1.6),
        )
    }

    #[test]
    fn round_trip_through_the_camera() {
        let (yaw, l) = (0.15_f64, 1.3);
        let m = Pose::new(
            so3_exp(&Vector3::new(0.0, 0.0, yaw)),
            Vector3::new(l * yaw.sin() / yaw, l * (1.0 - yaw.cos()) / yaw, 0.0),
        );
        let p = extrinsic();
        let mut c = camera_motion(&m, &p);
        c.translation /= c.translation.norm() * 3.0; // the unknown scale
        let back = vehicle_motion_from_camera(&c, &p, Some(l)).unwrap();
        assert!((back.rotation - m.rotation).amax() < 1e-12);
        assert!(
            (back.translation - m.translation).amax() < 1e-12,
            "{back:?}"
        );
        let dir = vehicle_motion_from_camera(&c, &p, None).unwrap();
        assert!((dir.translation.norm() - 1.0).abs() < 1e-12);
        let rot = vehicle_motion_from_camera(&c, &p, Some(0.0)).unwrap();
        assert_eq!(rot.translation, Vector3::zeros());
        assert!(vehicle_motion_from_camera(&c, &p, Some(f64::NAN)).is_none());
    }

    #[test]
    fn half_angle_sinc_is_continuous() {
        assert!((half_angle_sinc(2e-4) - half_angle_sinc(2.0001e-4)).abs() < 1e-12);
        assert!((half_angle_sinc(0.5) - (0.25f64.sin() / 0.25)).abs() < 1e-15);
    }
}
