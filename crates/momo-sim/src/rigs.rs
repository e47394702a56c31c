//! Rig presets: KITTI-like mono and stereo pinhole rigs and a four-camera fisheye surround rig.
//!
//! Vehicle frame x forward, y left, z up; camera frame x right, y down, z = viewing direction
//! (`FORMAT.md`). [`camera_mount`] builds `T_vehicle_camera` from a position, a heading and a
//! downward tilt.

use momo_core::{Camera, KannalaBrandt, Pinhole, Pose, Rig, RigCamera};
use nalgebra::{Matrix3, Vector3};

/// `T_vehicle_camera` of a camera at `position` (vehicle frame, metres) looking along heading
/// `yaw` (radians about the vehicle z axis: 0 forward, π/2 left, π backward, -π/2 right),
/// tilted down by `pitch_down` radians. The camera's x axis points to the right of the viewing
/// direction and stays horizontal; y = z × x points down.
pub fn camera_mount(position: Vector3<f64>, yaw: f64, pitch_down: f64) -> Pose<f64> {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch_down.sin_cos();
    let z = Vector3::new(cp * cy, cp * sy, -sp);
    let x = Vector3::new(sy, -cy, 0.0);
    let y = z.cross(&x);
    // Snap rounding residue (cos(π/2) = 6e-17) and negative zeros to exact zeros.
    let r = Matrix3::from_columns(&[x, y, z]).map(|v| if v.abs() < 1e-15 { 0.0 } else { v });
    Pose::new(r, position)
}

/// The rotation of a forward-looking, level camera: camera z = vehicle x, camera x = vehicle -y,
/// camera y = vehicle -z (exact zeros and ones).
fn forward_rotation() -> Matrix3<f64> {
    Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0)
}

/// The KITTI grey camera (sequence 00 calibration): pinhole fx = fy = 718.856,
/// (cx, cy) = (607.1928, 185.2157), 1241x376.
pub fn kitti_camera() -> Camera {
    Camera::Pinhole(Pinhole {
        fx: 718.856,
        fy: 718.856,
        cx: 607.1928,
        cy: 185.2157,
        width: 1241.0,
        height: 376.0,
    })
}

/// One KITTI camera 1 m ahead of the motion centre and 1.65 m up, looking forward
/// (`FORMAT.md`'s example rig).
pub fn kitti_mono() -> Rig {
    Rig::new(vec![RigCamera {
        name: "cam0".into(),
        model: kitti_camera(),
        t_vehicle_camera: Pose::new(forward_rotation(), Vector3::new(1.0, 0.0, 1.65)),
    }])
    .unwrap_or_else(|_| unreachable!("the rotation is a permutation matrix"))
}

/// [`kitti_mono`] plus a second, identical camera 0.54 m to its right (the KITTI baseline).
pub fn kitti_stereo() -> Rig {
    let mut cameras = kitti_mono().cameras().to_vec();
    cameras.push(RigCamera {
        name: "cam1".into(),
        model: kitti_camera(),
        t_vehicle_camera: Pose::new(forward_rotation(), Vector3::new(1.0, -0.54, 1.65)),
    });
    Rig::new(cameras).unwrap_or_else(|_| unreachable!("the rotation is a permutation matrix"))
}

/// The fisheye model of [`surround_fisheye`]: Kannala-Brandt, fx = fy = 330, 1280x960, principal
/// point at the image centre (639.5, 479.5), k = (0.02, -0.005, 0.001, -0.0001). Its horizontal
/// field of view exceeds 180°.
pub fn surround_fisheye_camera() -> Camera {
    Camera::KannalaBrandt(KannalaBrandt {
        fx: 330.0,
        fy: 330.0,
        cx: 639.5,
        cy: 479.5,
        k1: 0.02,
        k2: -0.005,
        k3: 0.001,
        k4: -0.0001,
        width: 1280.0,
        height: 960.0,
    })
}

/// Four fisheye cameras ([`surround_fisheye_camera`]) about 1 m up: `front` 2.0 m ahead of the
/// motion centre (tilted 10° down), `rear` 0.9 m behind looking back (10° down), `left` and
/// `right` in the mirrors at x = 1.0 m, y = ±0.95 m looking sideways (25° down).
pub fn surround_fisheye() -> Rig {
    let tilt = 10f64.to_radians();
    let side = 25f64.to_radians();
    let half_pi = std::f64::consts::FRAC_PI_2;
    let cams = [
        ("front", Vector3::new(2.0, 0.0, 0.9), 0.0, tilt),
        (
            "rear",
            Vector3::new(-0.9, 0.0, 1.0),
            std::f64::consts::PI,
            tilt,
        ),
        ("left", Vector3::new(1.0, 0.95, 1.05), half_pi, side),
        ("right", Vector3::new(1.0, -0.95, 1.05), -half_pi, side),
    ];
    Rig::new(
        cams.into_iter()
            .map(|(name, p, yaw, pitch)| RigCamera {
                name: name.into(),
                model: surround_fisheye_camera(),
                t_vehicle_camera: camera_mount(p, yaw, pitch),
            })
            .collect(),
    )
    .unwrap_or_else(|_| unreachable!("camera_mount builds orthonormal rotations"))
}

/// A rig for [`SimConfig`](crate::SimConfig): one of the presets or your own.
#[derive(Clone, Debug, PartialEq)]
pub enum RigPreset {
    /// [`kitti_mono`].
    KittiMono,
    /// [`kitti_stereo`].
    KittiStereo,
    /// [`surround_fisheye`].
    SurroundFisheye,
    /// Any rig.
    Custom(Rig),
}

impl RigPreset {
    /// The rig.
    pub fn rig(&self) -> Rig {
        match self {
            RigPreset::KittiMono => kitti_mono(),
            RigPreset::KittiStereo => kitti_stereo(),
            RigPreset::SurroundFisheye => surround_fisheye(),
            RigPreset::Custom(r) => r.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::CameraModel;

    #[test]
    fn mounts_look_where_they_should() {
        let rig = surround_fisheye();
        let expect = [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(-1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, -1.0, 0.0),
        ];
        for (c, e) in rig.cameras().iter().zip(expect) {
            let r = c.t_vehicle_camera.rotation;
            assert!(c.t_vehicle_camera.orthonormality_error() < 1e-15);
            let z = r.column(2).into_owned();
            let horizontal = Vector3::new(z.x, z.y, 0.0).normalize();
            assert!((horizontal - e).norm() < 1e-12, "{}: {z}", c.name);
            assert!(z.z < 0.0, "tilted down");
            // camera y points down-ish, x horizontal
            assert!(r.column(1).z < 0.0);
            assert!(r.column(0).z.abs() < 1e-15);
            assert!((c.t_vehicle_camera.translation.z - 1.0).abs() < 0.15);
        }
        // A level forward mount equals the KITTI rotation.
        let m = camera_mount(Vector3::new(1.0, 0.0, 1.65), 0.0, 0.0);
        assert_eq!(m, kitti_mono().cameras()[0].t_vehicle_camera);
    }

    #[test]
    fn stereo_second_camera_is_to_the_right() {
        let rig = kitti_stereo();
        let d = rig.cameras()[1].t_vehicle_camera.translation
            - rig.cameras()[0].t_vehicle_camera.translation;
        assert_eq!(d, Vector3::new(0.0, -0.54, 0.0));
        // In camera 0's frame the second camera is at +x (right).
        let c0 = rig.cameras()[0].t_vehicle_camera;
        let p = c0
            .inverse()
            .transform_point(&rig.cameras()[1].t_vehicle_camera.translation);
        assert!((p - Vector3::new(0.54, 0.0, 0.0)).norm() < 1e-15);
        // A point ahead of the vehicle projects into the image.
        let px =
            kitti_camera().project(&c0.inverse().transform_point(&Vector3::new(20.0, 0.0, 1.65)));
        assert!(px.is_some_and(|px| kitti_camera().contains(&px, 0.0)));
    }
}
