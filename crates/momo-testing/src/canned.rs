//! Canned rigs and noise-free synthetic matches, for derivative checks, doc examples and tests
//! (`momo_models::check_model` uses them). Deterministic: the same seed gives the same matches.
//! This is not a simulator (no noise model, no image bounds, no moving objects); see the
//! simulation crate for that.

use momo_core::{
    Camera, CameraModel, FrameObservations, KannalaBrandt, Observation, Pinhole, Pose, Rig,
    RigCamera, camera_motion, so3_exp,
};
use nalgebra::{Matrix3, Vector2, Vector3};

/// `T_vehicle_camera` rotation of a camera looking along the vehicle's x axis (camera z →
/// vehicle x, camera x → vehicle -y, camera y → vehicle -z).
pub fn forward_looking() -> Matrix3<f64> {
    Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0)
}

/// A KITTI-like pinhole camera (focal length 718.856 px, 1241 x 376).
pub fn kitti_pinhole() -> Pinhole {
    Pinhole {
        fx: 718.856,
        fy: 718.856,
        cx: 607.1928,
        cy: 185.2157,
        width: 1241.0,
        height: 376.0,
    }
}

/// A 190°-class Kannala-Brandt fisheye (focal length ~330 px, 1280 x 960).
pub fn fisheye() -> KannalaBrandt {
    KannalaBrandt {
        fx: 330.0,
        fy: 331.0,
        cx: 640.0,
        cy: 480.0,
        k1: 0.02,
        k2: -0.005,
        k3: 0.001,
        k4: -0.0001,
        width: 1280.0,
        height: 960.0,
    }
}

/// One forward-looking KITTI-like pinhole camera, 1.5 m ahead of the motion centre (the rear
/// axle) at 1.6 m height and slightly rotated, so that the arc length is observable from curves.
pub fn pinhole_rig() -> Rig {
    let r = so3_exp(&Vector3::new(0.01, -0.02, 0.015)) * forward_looking();
    Rig::mono(
        Camera::Pinhole(kitti_pinhole()),
        Pose::new(r, Vector3::new(1.5, 0.1, 1.6)),
    )
    .expect("the canned rig is valid")
}

/// Four Kannala-Brandt fisheye cameras looking front, left, back and right (surround view),
/// the side and rear ones tilted down.
pub fn fisheye_rig() -> Rig {
    let mount = |name: &str, yaw: f64, down: f64, x: f64, y: f64, z: f64| RigCamera {
        name: name.into(),
        model: Camera::KannalaBrandt(fisheye()),
        t_vehicle_camera: Pose::new(
            so3_exp(&Vector3::new(0.0, 0.0, yaw))
                * so3_exp(&Vector3::new(0.0, down, 0.0))
                * forward_looking(),
            Vector3::new(x, y, z),
        ),
    };
    let half_pi = std::f64::consts::FRAC_PI_2;
    Rig::new(vec![
        mount("front", 0.0, 0.1, 3.7, 0.0, 0.6),
        mount("left", half_pi, 0.5, 2.0, 1.0, 1.0),
        mount("rear", std::f64::consts::PI, 0.3, -1.0, 0.0, 0.9),
        mount("right", -half_pi, 0.5, 2.0, -1.0, 1.0),
    ])
    .expect("the canned rig is valid")
}

/// Smallest angle (radians, about 5.7°) between a synthetic match's bearing and the baseline
/// in [`synthetic_observations`].
pub const MIN_EPIPOLE_ANGLE: f64 = 0.1;

/// SplitMix64: a tiny deterministic generator, enough for canned data.
#[derive(Clone, Debug)]
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
}

/// A scene point in front of `camera` (camera coordinates at frame k-1).
fn sample_point(camera: &Camera, rng: &mut SplitMix) -> Vector3<f64> {
    match camera {
        Camera::Pinhole(p) => {
            let u = rng.uniform(20.0, p.width - 20.0);
            let v = rng.uniform(20.0, p.height - 20.0);
            let z = rng.uniform(4.0, 40.0);
            Vector3::new((u - p.cx) / p.fx * z, (v - p.cy) / p.fy * z, z)
        }
        _ => {
            let theta = rng.uniform(0.0, 1.3);
            let phi = rng.uniform(-std::f64::consts::PI, std::f64::consts::PI);
            let d = rng.uniform(4.0, 40.0);
            Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ) * d
        }
    }
}

/// Noise-free matches for the vehicle motion `motion` (`T_{k-1,k}`): per camera, `inliers`
/// scene points projected into both frames (bearings are the exact unit vectors, pixels their
/// projections), followed by `off_epipolar` matches whose pixel in frame k is moved by 3 to 30
/// pixels in a random direction (their bearing is unprojected from the moved pixel), so that
/// their residuals are clearly non-zero.
///
/// Matches within [`MIN_EPIPOLE_ANGLE`] of an epipole (the baseline direction) are skipped:
/// there every epipolar residual is a ratio of two small numbers whose rounding noise (not the
/// automatic derivative) breaks finite-difference checks at 1e-6, and they say little about the
/// motion. Fewer matches than asked are returned only if the sampling gives up (100 attempts
/// per match).
///
/// ```
/// use momo_core::{Pose, ResidualMetric, camera_motion};
/// use momo_costs::AnglePlane;
/// use momo_testing::canned;
/// use nalgebra::{Matrix3, Vector3};
///
/// let rig = canned::fisheye_rig();
/// let m = Pose::new(Matrix3::identity(), Vector3::new(1.0, 0.0, 0.0));
/// let obs = canned::synthetic_observations(&rig, &m, 10, 0, 7);
/// for (cam, matches) in rig.cameras().iter().zip(&obs.per_camera) {
///     let prep = AnglePlane.prepare(&cam.model, &camera_motion(&m, &cam.t_vehicle_camera));
///     for o in matches {
///         let mut r = [0.0];
///         AnglePlane.residuals(&prep, o, &mut r);
///         assert!(r[0].abs() < 1e-12);
///     }
/// }
/// ```
pub fn synthetic_observations(
    rig: &Rig,
    motion: &Pose<f64>,
    inliers: usize,
    off_epipolar: usize,
    seed: u64,
) -> FrameObservations {
    let mut rng = SplitMix(seed);
    let mut out = FrameObservations::new(rig.len());
    for (j, cam) in rig.cameras().iter().enumerate() {
        let c = camera_motion(motion, &cam.t_vehicle_camera);
        let c_inv = c.inverse();
        // Baseline direction in frame k-1 (towards the centre at k) and in frame k.
        let base0 = c.translation.try_normalize(0.0);
        let base1 = base0.map(|b| c.rotation.transpose() * b);
        let near_epipole = |f: &Vector3<f64>, b: Option<Vector3<f64>>| {
            b.is_some_and(|b| f.dot(&b).abs() > MIN_EPIPOLE_ANGLE.cos())
        };
        let matches = &mut out.per_camera[j];
        let mut attempts = 0;
        while matches.len() < inliers + off_epipolar
            && attempts < 100 * (inliers + off_epipolar + 1)
        {
            attempts += 1;
            let x0 = sample_point(&cam.model, &mut rng);
            let x1 = c_inv.transform_point(&x0);
            let in_front = match cam.model {
                Camera::Pinhole(_) => x1.z > 0.3,
                _ => x1.norm() > 0.3,
            };
            let (Some(px0), Some(px1)) = (cam.model.project(&x0), cam.model.project(&x1)) else {
                continue;
            };
            if !in_front {
                continue;
            }
            let mut o = Observation {
                px0,
                px1,
                f0: x0.normalize(),
                f1: x1.normalize(),
            };
            if matches.len() >= inliers {
                let a = rng.uniform(-std::f64::consts::PI, std::f64::consts::PI);
                let d = rng.uniform(3.0, 30.0);
                o.px1 += Vector2::new(a.cos(), a.sin()) * d;
                let Some(f1) = cam.model.unproject(&o.px1) else {
                    continue;
                };
                o.f1 = f1;
            }
            if near_epipole(&o.f0, base0) || near_epipole(&o.f1, base1) {
                continue;
            }
            matches.push(o);
        }
    }
    out
}
