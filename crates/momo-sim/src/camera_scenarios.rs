//! Scenarios of the camera models of format version 2 (`docs/CAMERAS.md`): `radtan_mono`
//! (one OpenCV radial-tangential camera) and `wide_angle_surround` (double sphere front and
//! rear, unified left and right). Kept apart from [`crate::sim`] so that the scenario list grows
//! by name only there.

use crate::rigs::{RigPreset, camera_mount};
use crate::sim::SimConfig;
use momo_core::{Camera, DoubleSphere, Pose, Radtan, Rig, RigCamera, Unified};
use nalgebra::{Matrix3, Vector3};

/// The scenario names of this module, in the order of [`SimConfig::SCENARIOS`].
pub const CAMERA_SCENARIOS: &[&str] = &["radtan_mono", "wide_angle_surround"];

/// The preset of a name in [`CAMERA_SCENARIOS`]; `None` for any other name.
pub fn camera_scenario(name: &str) -> Option<SimConfig> {
    match name {
        "radtan_mono" => Some(radtan_mono()),
        "wide_angle_surround" => Some(wide_angle_surround()),
        _ => None,
    }
}

/// A 1280x720 camera with strong barrel distortion: fx = 700, fy = 699, (cx, cy) =
/// (641.3, 358.9), k1 = -0.28, k2 = 0.07, p1 = 2e-4, p2 = -1e-4, k3 = 0 (the magnitudes of a
/// typical wide-angle OpenCV calibration). The whole image lies in the valid region (the
/// radial profile still rises at the corners).
pub fn radtan_camera() -> Camera {
    Camera::Radtan(Radtan {
        fx: 700.0,
        fy: 699.0,
        cx: 641.3,
        cy: 358.9,
        k1: -0.28,
        k2: 0.07,
        p1: 2e-4,
        p2: -1e-4,
        k3: 0.0,
        width: 1280.0,
        height: 720.0,
    })
}

/// One [`radtan_camera`] 1 m ahead of the motion centre and 1.65 m up, looking forward (the
/// KITTI mono mount).
pub fn radtan_mono_rig() -> Rig {
    let forward = Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
    Rig::new(vec![RigCamera {
        name: "cam0".into(),
        model: radtan_camera(),
        t_vehicle_camera: Pose::new(forward, Vector3::new(1.0, 0.0, 1.65)),
    }])
    .unwrap_or_else(|_| unreachable!("the rotation is a permutation matrix"))
}

/// Double sphere camera of [`wide_angle_surround`]: 1280x960, fx = fy = 300, principal point
/// at the centre, ξ = -0.2, α = 0.55 (the signs and magnitudes of Basalt's calibrations; about
/// 180° across the image width).
pub fn double_sphere_camera() -> Camera {
    Camera::DoubleSphere(DoubleSphere {
        fx: 300.0,
        fy: 300.0,
        cx: 639.5,
        cy: 479.5,
        xi: -0.2,
        alpha: 0.55,
        width: 1280.0,
        height: 960.0,
    })
}

/// Unified camera of [`wide_angle_surround`]: 1280x960, fx = fy = 560, principal point at the
/// centre, ξ = 0.9 (about 180° across the image width).
pub fn unified_camera() -> Camera {
    Camera::Unified(Unified {
        fx: 560.0,
        fy: 560.0,
        cx: 639.5,
        cy: 479.5,
        xi: 0.9,
        width: 1280.0,
        height: 960.0,
    })
}

/// The mounts of [`crate::surround_fisheye`] with double sphere cameras front and rear and
/// unified cameras left and right.
pub fn wide_angle_surround_rig() -> Rig {
    let tilt = 10f64.to_radians();
    let side = 25f64.to_radians();
    let half_pi = std::f64::consts::FRAC_PI_2;
    let cams = [
        (
            "front",
            Vector3::new(2.0, 0.0, 0.9),
            0.0,
            tilt,
            double_sphere_camera(),
        ),
        (
            "rear",
            Vector3::new(-0.9, 0.0, 1.0),
            std::f64::consts::PI,
            tilt,
            double_sphere_camera(),
        ),
        (
            "left",
            Vector3::new(1.0, 0.95, 1.05),
            half_pi,
            side,
            unified_camera(),
        ),
        (
            "right",
            Vector3::new(1.0, -0.95, 1.05),
            -half_pi,
            side,
            unified_camera(),
        ),
    ];
    Rig::new(
        cams.into_iter()
            .map(|(name, p, yaw, pitch, model)| RigCamera {
                name: name.into(),
                model,
                t_vehicle_camera: camera_mount(p, yaw, pitch),
            })
            .collect(),
    )
    .unwrap_or_else(|_| unreachable!("camera_mount builds orthonormal rotations"))
}

/// [`radtan_mono_rig`] with the settings of the default scenario: 300 matches, σ = 0.5 px,
/// 10% outliers, no stops.
pub fn radtan_mono() -> SimConfig {
    SimConfig {
        rig: RigPreset::Custom(radtan_mono_rig()),
        ..SimConfig::default()
    }
}

/// [`wide_angle_surround_rig`], 200 matches per camera, σ = 0.5 px, 10% outliers, stops (the
/// settings of `fisheye_surround` without its blinded camera; along a KITTI trajectory the
/// vehicle drives level, as there: `trajectory_mount`).
pub fn wide_angle_surround() -> SimConfig {
    SimConfig {
        rig: RigPreset::Custom(wide_angle_surround_rig()),
        matches_per_camera: 200,
        stops: true,
        trajectory_mount: Some(crate::rigs::kitti_mono().cameras()[0].t_vehicle_camera),
        ..SimConfig::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::CameraModel;
    use nalgebra::Vector2;

    /// Every pixel of the new cameras (on a grid including the corners) unprojects and
    /// projects back, so the simulator samples the whole image.
    #[test]
    fn whole_images_are_valid() {
        for cam in [radtan_camera(), double_sphere_camera(), unified_camera()] {
            let (w, h) = cam.size();
            for i in 0..=20 {
                for j in 0..=20 {
                    let px = Vector2::new(
                        -0.5 + w * f64::from(i) / 20.0,
                        -0.5 + h * f64::from(j) / 20.0,
                    );
                    let b = cam.unproject(&px).expect("inside the valid region");
                    let back = cam.project(&b).expect("projects");
                    assert!((back - px).norm() < 1e-6, "{cam:?} {px}");
                }
            }
        }
        // The wide-angle cameras see about 90° from the axis at the left and right borders.
        for cam in [double_sphere_camera(), unified_camera()] {
            let b = cam.unproject(&Vector2::new(-0.5, 479.5)).expect("valid");
            assert!(b.z.abs() < 0.1, "{cam:?}: {b}");
        }
    }
}
