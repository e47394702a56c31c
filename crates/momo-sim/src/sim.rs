//! The simulator: a drive ([`generate_drive`]), a scene, and per frame pair and camera a set of
//! matches with noise, outliers, blinded cameras and an optional independently moving object.
//!
//! Per frame pair `k` and camera `j` with extrinsic `P_j` and vehicle motion
//! `M = T_{k-1,k} = V_{k-1}⁻¹ V_k`, the camera motion is `C_j = P_j⁻¹ M P_j`. A match is made by
//! sampling a pixel uniformly in the image at frame k-1, unprojecting it, giving it a depth from
//! the scene ([`SceneConfig`]: the ground plane z = 0 where the ray hits it within
//! `ground_range`, otherwise a facade or, with probability `far_fraction`, a far point), moving
//! the point into camera j at frame k (`X_k = C_j⁻¹ X_{k-1}`), and keeping it if it projects into
//! the image (and, for fisheyes, back onto the same ray). Both pixels then get Gaussian noise of
//! `pixel_noise` pixels; finally exactly `round(outlier_ratio · n)` of the camera's matches get a
//! wrong pixel in frame k (within `near_outlier_radius` of the true one with probability
//! `near_outlier_fraction`, anywhere in the image otherwise).
//!
//! Determinism: the drive uses `StdRng::seed_from_u64(seed)`, each (frame pair, camera) its own
//! `StdRng` seeded from a hash of `(seed, k, j)`. The same configuration gives the same
//! simulation bit for bit (with the same `rand` version), and a longer simulation starts with the
//! frames of a shorter one.

use crate::drive::{Drive, DriveConfig, generate_drive};
use crate::rigs::RigPreset;
use crate::traffic::{CameraTraffic, TrafficConfig, generate_traffic_along};
use momo_core::{CameraModel, FrameObservations, Observation, Pose, Rig, RigCamera, camera_motion};
use momo_io::{IoError, MAX_FRAME, Sequence, write_sequence};
use nalgebra::{Vector2, Vector3};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use std::ops::Range;
use std::path::Path;
use thiserror::Error;

/// Largest `matches_per_camera` accepted.
pub const MAX_MATCHES_PER_CAMERA: usize = 100_000;

/// An invalid [`SimConfig`].
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    /// A parameter out of range; the message names it.
    #[error("invalid simulation config: {0}")]
    InvalidConfig(String),
}

/// Where scene points lie.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneConfig {
    /// A ray that hits the ground plane z = 0 within this horizontal distance (metres from the
    /// camera) sees the ground.
    pub ground_range: f64,
    /// Other rays see a facade at a distance uniform in this range (metres along the ray) ...
    pub facade_range: (f64, f64),
    /// ... or, with probability [`far_fraction`](Self::far_fraction), a far point in this range.
    pub far_range: (f64, f64),
    /// Probability of a far point for rays that miss the ground.
    pub far_fraction: f64,
}

impl Default for SceneConfig {
    fn default() -> Self {
        Self {
            ground_range: 80.0,
            facade_range: (5.0, 40.0),
            far_range: (50.0, 300.0),
            far_fraction: 0.15,
        }
    }
}

/// What a blinded camera delivers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlindMode {
    /// No matches at all (a covered lens, a dropped frame).
    Absent,
    /// Only wrong matches: both pixels random (glare, rain on the lens).
    Outliers,
}

/// A camera blinded for a range of frame pairs.
#[derive(Clone, Debug, PartialEq)]
pub struct Blinding {
    /// Camera id.
    pub camera: usize,
    /// Frame pairs `k` (pair `(k-1, k)`) affected.
    pub frames: Range<usize>,
    /// Absent or all outliers.
    pub mode: BlindMode,
}

/// A rigid object that moves independently of the static scene, seen by one camera.
#[derive(Clone, Debug, PartialEq)]
pub struct MovingObject {
    /// Camera id.
    pub camera: usize,
    /// Frame pairs affected.
    pub frames: Range<usize>,
    /// Fraction of the camera's matches on the object.
    pub fraction: f64,
    /// Image region of the object, fractions of width and height: `[u_min, v_min, u_max, v_max]`.
    pub region: [f64; 4],
    /// Distance of the object points along the ray, metres.
    pub depth_range: (f64, f64),
    /// Motion of object points per frame pair in vehicle coordinates: a point at `X` in the
    /// vehicle frame at k-1 is at `relative_motion · X` in the vehicle frame at k. The identity
    /// is an object moving with the vehicle (zero flow: a truck ahead at the same speed).
    pub relative_motion: Pose<f64>,
}

impl MovingObject {
    /// An object moving with the vehicle (zero flow) covering the centre-bottom of the image.
    pub fn following(camera: usize, frames: Range<usize>, fraction: f64) -> Self {
        Self {
            camera,
            frames,
            fraction,
            region: [0.3, 0.35, 0.75, 0.95],
            depth_range: (6.0, 15.0),
            relative_motion: Pose::identity(),
        }
    }
}

/// What a simulated match really is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatchLabel {
    /// A static scene point with pixel noise only.
    Inlier,
    /// A wrong pixel in frame k.
    Outlier,
    /// A point on the [`MovingObject`].
    MovingObject,
    /// A random match of a camera blinded with [`BlindMode::Outliers`].
    Blinded,
}

/// Everything the simulator needs.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// Number of frames (poses); the frame pairs are `1..frames`.
    pub frames: usize,
    /// Seed of all random choices.
    pub seed: u64,
    /// Matches per camera and frame pair (fewer if the scene does not allow them).
    pub matches_per_camera: usize,
    /// Standard deviation of the Gaussian noise on each pixel coordinate, pixels.
    pub pixel_noise: f64,
    /// Fraction of each camera's matches replaced by outliers, in `[0, 1]`.
    pub outlier_ratio: f64,
    /// Fraction of the outliers placed near the true pixel (the rest: anywhere).
    pub near_outlier_fraction: f64,
    /// "Near" means within this many pixels in u and v (60 by default).
    pub near_outlier_radius: f64,
    /// The rig.
    pub rig: RigPreset,
    /// Whether the drive includes stops (standstill frames).
    pub stops: bool,
    /// The drive generator.
    pub drive: DriveConfig,
    /// The scene.
    pub scene: SceneConfig,
    /// Blinded cameras.
    pub blinded: Vec<Blinding>,
    /// An optional independently moving object.
    pub moving_object: Option<MovingObject>,
    /// Optional moving traffic around the ego vehicle ([`crate::traffic`]).
    pub traffic: Option<TrafficConfig>,
    /// Whether the sequence gets `odometry.csv` arc lengths.
    pub odometry: bool,
    /// Relative standard deviation of the odometry arc lengths (0: exact).
    pub odometry_noise: f64,
    /// Drive along these camera-0 poses (KITTI camera poses `T_cam0(0)_cam0(k)`, e.g. a KITTI
    /// ground-truth file) instead of a generated drive: the vehicle poses are
    /// `V_k = P0 · C_k · P0⁻¹` ([`vehicle_poses_from_camera_poses`]) with `P0` the rig's
    /// camera 0, relative to the first; `drive` then only gives the frame rate (speeds), and
    /// `stops` is ignored. The simulation has `min(frames, len)` frames.
    pub camera_trajectory: Option<Vec<Pose<f64>>>,
    /// The mount `T_vehicle_camera` of the camera whose poses `camera_trajectory` gives, when it
    /// is not the rig's camera 0: the vehicle poses are then `V_k = P · C_k · P⁻¹` with this `P`
    /// (the ground truth is still camera 0's). A KITTI trajectory is the motion of a level,
    /// forward-looking camera; driven with the mount of a camera tilted down (the surround
    /// fisheye's front camera, 10°) as `P`, the vehicle would sink along its path at that angle.
    /// `None` (the default): the rig's camera 0.
    pub trajectory_mount: Option<Pose<f64>>,
    /// The share, in `[0, 1]`, of a frame pair's static matches that continue a static match of
    /// the previous pair, as a feature tracker (KLT) reports them: the same scene point, whose
    /// pixel in frame `k-1` is the previous pair's pixel in frame `k-1` (its noise included),
    /// while it stays in view, unoccluded and in front. 0 (the default): every static match is a new point (no tracks; the match memory
    /// then finds few neighbours among the static matches). Objects' matches are drawn as
    /// before (`momo simulate --static-tracks`).
    pub static_tracks: f64,
}

impl Default for SimConfig {
    /// 100 frames of the KITTI mono rig, 300 matches, σ = 0.5 px, 10% outliers, no stops,
    /// exact odometry.
    fn default() -> Self {
        Self {
            frames: 100,
            seed: 0,
            matches_per_camera: 300,
            pixel_noise: 0.5,
            outlier_ratio: 0.1,
            near_outlier_fraction: 0.5,
            near_outlier_radius: 60.0,
            rig: RigPreset::KittiMono,
            stops: false,
            drive: DriveConfig::default(),
            scene: SceneConfig::default(),
            blinded: Vec::new(),
            moving_object: None,
            traffic: None,
            odometry: true,
            odometry_noise: 0.0,
            camera_trajectory: None,
            trajectory_mount: None,
            static_tracks: 0.0,
        }
    }
}

impl SimConfig {
    /// The names of all presets, as [`SimConfig::scenario`] and `momo simulate --scenario`
    /// take them.
    pub const SCENARIOS: &[&str] = &[
        "clean_pinhole",
        "outliers",
        "moving_object",
        "moving_traffic",
        "moving_traffic_surround",
        "moving_traffic_surround_blind",
        "fisheye_surround",
        "sparse_outliers",
        "very_sparse",
        "highway",
        "radtan_mono",
        "wide_angle_surround",
    ];

    /// The preset of a name in [`SimConfig::SCENARIOS`]; `None` for any other name.
    ///
    /// ```
    /// use momo_sim::SimConfig;
    ///
    /// for name in SimConfig::SCENARIOS {
    ///     assert!(SimConfig::scenario(name).is_some());
    /// }
    /// assert_eq!(SimConfig::scenario("highway"), Some(SimConfig::highway()));
    /// assert_eq!(SimConfig::scenario("moon_landing"), None);
    /// ```
    pub fn scenario(name: &str) -> Option<Self> {
        Some(match name {
            "clean_pinhole" => Self::clean_pinhole(),
            "outliers" => Self::outliers(),
            "moving_object" => Self::moving_object(),
            "moving_traffic" => Self::moving_traffic(),
            "moving_traffic_surround" => Self::moving_traffic_surround(),
            "moving_traffic_surround_blind" => Self::moving_traffic_surround_blind(),
            "fisheye_surround" => Self::fisheye_surround(),
            "sparse_outliers" => Self::sparse_outliers(),
            "very_sparse" => Self::very_sparse(),
            "highway" => Self::highway(),
            _ => return crate::camera_scenarios::camera_scenario(name),
        })
    }

    /// KITTI mono rig, σ = 0.5 px, no outliers.
    pub fn clean_pinhole() -> Self {
        Self {
            outlier_ratio: 0.0,
            ..Self::default()
        }
    }

    /// KITTI mono rig, σ = 1 px, 30% outliers.
    pub fn outliers() -> Self {
        Self {
            pixel_noise: 1.0,
            outlier_ratio: 0.3,
            ..Self::default()
        }
    }

    /// The four-camera fisheye rig, 200 matches per camera, σ = 0.5 px, 10% outliers, stops,
    /// and the left camera (id 2) blinded (no matches) for frame pairs 40..70. Along a KITTI
    /// trajectory the vehicle drives as the KITTI mono rig's does (`trajectory_mount`, as
    /// [`Self::moving_traffic_surround`]): the front fisheye is tilted 10° down, and with its own
    /// mount the level trajectory would make the vehicle sink along its path.
    pub fn fisheye_surround() -> Self {
        Self {
            rig: RigPreset::SurroundFisheye,
            matches_per_camera: 200,
            stops: true,
            blinded: vec![Blinding {
                camera: 2,
                frames: 40..70,
                mode: BlindMode::Absent,
            }],
            trajectory_mount: Some(crate::rigs::kitti_mono().cameras()[0].t_vehicle_camera),
            ..Self::default()
        }
    }

    /// KITTI mono rig, clean matches, and an object moving with the vehicle (zero flow) that
    /// covers 45% of the matches in frame pairs 30..60.
    pub fn moving_object() -> Self {
        Self {
            outlier_ratio: 0.0,
            moving_object: Some(MovingObject::following(0, 30..60, 0.45)),
            ..Self::default()
        }
    }

    /// The hard moving-traffic family ([`crate::traffic`]): KITTI mono rig, 300 matches,
    /// σ = 1 px, 5 % outliers, lead vehicles at 5 to 40 m with lateral drift, a close bus,
    /// cut-ins, oncoming cars and crossing trucks holding 30 to 70 % of the matches when
    /// visible. Vary `seed` and drive it along real trajectories (`camera_trajectory`).
    pub fn moving_traffic() -> Self {
        Self {
            pixel_noise: 1.0,
            outlier_ratio: 0.05,
            traffic: Some(TrafficConfig::default()),
            ..Self::default()
        }
    }

    /// The moving-traffic family on the four-camera fisheye rig of [`Self::fisheye_surround`]
    /// (200 matches per camera, σ = 0.5 px, 10 % outliers, no blinded camera, no stops): the
    /// traffic of [`Self::moving_traffic`] (the objects ahead: lead vehicles, a close bus,
    /// cut-ins, oncoming cars, crossing trucks) plus the traffic around the vehicle
    /// ([`TrafficConfig::surround`]: followers, overtaking cars, some cutting in, overtaken
    /// vehicles, vehicles alongside), every object seen by every camera it is visible in, each
    /// holding its share of that camera's 30 to 70 % object matches. Along a KITTI trajectory
    /// the vehicle drives as the KITTI mono rig's does (`trajectory_mount`: the trajectory is
    /// the level forward camera's); the ground truth is the front camera's.
    pub fn moving_traffic_surround() -> Self {
        Self {
            rig: RigPreset::SurroundFisheye,
            matches_per_camera: 200,
            traffic: Some(TrafficConfig {
                surround: true,
                ..TrafficConfig::default()
            }),
            trajectory_mount: Some(crate::rigs::kitti_mono().cameras()[0].t_vehicle_camera),
            ..Self::default()
        }
    }

    /// [`Self::moving_traffic_surround`] with blinded cameras: the front camera (0) delivers no
    /// matches in frame pairs 150..250 (a covered lens: the traffic ahead is seen only by the
    /// side cameras), and the right camera (3) only wrong matches in 300..350 (glare).
    pub fn moving_traffic_surround_blind() -> Self {
        Self {
            blinded: vec![
                Blinding {
                    camera: 0,
                    frames: 150..250,
                    mode: BlindMode::Absent,
                },
                Blinding {
                    camera: 3,
                    frames: 300..350,
                    mode: BlindMode::Outliers,
                },
            ],
            ..Self::moving_traffic_surround()
        }
    }

    /// KITTI mono rig, only 100 matches per frame pair, σ = 1 px, 30% outliers.
    pub fn sparse_outliers() -> Self {
        Self {
            matches_per_camera: 100,
            pixel_noise: 1.0,
            outlier_ratio: 0.3,
            ..Self::default()
        }
    }

    /// KITTI mono rig, only 40 matches per frame pair, σ = 0.5 px, 10% outliers.
    pub fn very_sparse() -> Self {
        Self {
            matches_per_camera: 40,
            ..Self::default()
        }
    }

    /// KITTI mono rig on a motorway: 25 to 30 m/s (2.5 to 3 m per frame), gentle curves
    /// (lateral acceleration at most 1 m/s², radii of 600 m and more at speed), no stops; the
    /// scene is open (facades 10 to 80 m away, more far points). σ = 0.5 px, 10% outliers.
    pub fn highway() -> Self {
        Self {
            drive: DriveConfig {
                initial_speed: 27.0,
                min_cruise_speed: 25.0,
                max_speed: 30.0,
                max_acceleration: 1.0,
                max_deceleration: 1.5,
                max_jerk: 1.0,
                max_yaw_rate: 0.05,
                max_lateral_acceleration: 1.0,
                curvature_rate: 0.001,
                ..DriveConfig::default()
            },
            scene: SceneConfig {
                ground_range: 80.0,
                facade_range: (10.0, 80.0),
                far_range: (80.0, 400.0),
                far_fraction: 0.3,
            },
            ..Self::default()
        }
    }

    /// Checks every parameter; the message names the first bad one.
    pub fn validate(&self, rig: &Rig) -> Result<(), SimError> {
        let bad = |m: String| Err(SimError::InvalidConfig(m));
        if self.frames == 0 || self.frames > MAX_FRAME + 1 {
            return bad(format!(
                "frames must be in 1..={}, found {}",
                MAX_FRAME + 1,
                self.frames
            ));
        }
        if self.matches_per_camera > MAX_MATCHES_PER_CAMERA {
            return bad(format!(
                "matches_per_camera must be at most {MAX_MATCHES_PER_CAMERA}, found {}",
                self.matches_per_camera
            ));
        }
        if !(self.pixel_noise.is_finite() && self.pixel_noise >= 0.0) {
            return bad(format!(
                "pixel_noise must be a non-negative number, found {}",
                self.pixel_noise
            ));
        }
        for (name, v) in [
            ("outlier_ratio", self.outlier_ratio),
            ("near_outlier_fraction", self.near_outlier_fraction),
            ("scene.far_fraction", self.scene.far_fraction),
            ("static_tracks", self.static_tracks),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(format!("{name} must be in [0, 1], found {v}"));
            }
        }
        if !(self.near_outlier_radius.is_finite() && self.near_outlier_radius > 0.0) {
            return bad("near_outlier_radius must be a positive number".into());
        }
        if !(self.odometry_noise.is_finite() && self.odometry_noise >= 0.0) {
            return bad("odometry_noise must be a non-negative number".into());
        }
        if !(self.scene.ground_range.is_finite() && self.scene.ground_range >= 0.0) {
            return bad("scene.ground_range must be a non-negative number".into());
        }
        for (name, (lo, hi)) in [
            ("scene.facade_range", self.scene.facade_range),
            ("scene.far_range", self.scene.far_range),
        ] {
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return bad(format!("{name} must be (min, max) with 0 < min <= max"));
            }
        }
        self.drive.validate().map_err(SimError::InvalidConfig)?;
        if let Some(m) = &self.trajectory_mount {
            if m.to_homogeneous().iter().any(|v| !v.is_finite()) || m.orthonormality_error() > 1e-6
            {
                return bad("trajectory_mount must be a finite rigid motion".into());
            }
        }
        if let Some(t) = &self.camera_trajectory {
            if t.is_empty() {
                return bad("camera_trajectory must hold at least one pose".into());
            }
            if let Some(k) = t.iter().position(|p| {
                p.to_homogeneous().iter().any(|v| !v.is_finite()) || p.orthonormality_error() > 1e-6
            }) {
                return bad(format!(
                    "camera_trajectory pose {k} is not a finite rigid motion"
                ));
            }
        }
        for b in &self.blinded {
            if b.camera >= rig.len() {
                return bad(format!(
                    "blinded camera {} does not exist (the rig has {})",
                    b.camera,
                    rig.len()
                ));
            }
        }
        if let Some(o) = &self.moving_object {
            if o.camera >= rig.len() {
                return bad(format!(
                    "moving_object camera {} does not exist (the rig has {})",
                    o.camera,
                    rig.len()
                ));
            }
            if !(0.0..=1.0).contains(&o.fraction) {
                return bad("moving_object.fraction must be in [0, 1]".into());
            }
            let [u0, v0, u1, v1] = o.region;
            if !(0.0 <= u0 && u0 < u1 && u1 <= 1.0 && 0.0 <= v0 && v0 < v1 && v1 <= 1.0) {
                return bad(
                    "moving_object.region must be [u_min, v_min, u_max, v_max] within [0, 1]"
                        .into(),
                );
            }
            let (lo, hi) = o.depth_range;
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return bad(
                    "moving_object.depth_range must be (min, max) with 0 < min <= max".into(),
                );
            }
            let m = o.relative_motion.to_homogeneous();
            if m.iter().any(|v| !v.is_finite()) || o.relative_motion.orthonormality_error() > 1e-6 {
                return bad("moving_object.relative_motion must be a finite rigid motion".into());
            }
        }
        if let Some(t) = &self.traffic {
            let (lo, hi) = t.fraction;
            if !(0.0 <= lo && lo <= hi && hi <= 1.0) {
                return bad("traffic.fraction must be (min, max) with 0 <= min <= max <= 1".into());
            }
            if !(t.min_area_px.is_finite() && t.min_area_px >= 0.0) {
                return bad("traffic.min_area_px must be a non-negative number".into());
            }
        }
        Ok(())
    }
}

/// The result of [`simulate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// The sequence as `momo` reads it: `arc_lengths` (if `odometry`) and `ground_truth` are
    /// filled; `ground_truth[k] = T_cam0(0)_cam0(k) = P0⁻¹ V0⁻¹ V_k P0` (identity at k = 0).
    pub sequence: Sequence,
    /// Vehicle poses `V_k` in the world frame; `V_0` is the identity.
    pub vehicle_poses: Vec<Pose<f64>>,
    /// `vehicle_motions[k] = T_{k-1,k} = V_{k-1}⁻¹ V_k`; index 0 is the identity.
    pub vehicle_motions: Vec<Pose<f64>>,
    /// Speed at each frame, m/s.
    pub speeds: Vec<f64>,
    /// Exact arc lengths per frame pair (index 0: 0), whatever `odometry_noise` says.
    pub true_arc_lengths: Vec<f64>,
    /// `labels[k][j][i]`: what match i of camera j in frame pair k is (parallel to
    /// `sequence.frames`).
    pub labels: Vec<Vec<Vec<MatchLabel>>>,
    /// `static_points[k][j][i]`: the noise-free scene point of match i of camera j in frame pair
    /// k, in camera j coordinates at frame k-1, for static matches ([`MatchLabel::Inlier`]);
    /// `None` for every other label. What [`crate::bound`] needs.
    pub static_points: Vec<Vec<Vec<Option<Vector3<f64>>>>>,
    /// `objects[k][j][i]`: the traffic object ([`SimConfig::traffic`]) whose point match i of
    /// camera j in frame pair k is, as an index into [`Simulation::object_kinds`]; `None` for
    /// every match that is not on a traffic object (static points, outliers, the scripted
    /// [`MovingObject`]). Parallel to `labels`; `labels.csv`'s `object` column.
    pub objects: Vec<Vec<Vec<Option<usize>>>>,
    /// The kind of each traffic object (`lead`, `bus`, `cut_in`, `oncoming`, `crossing`), by the
    /// index of [`Simulation::objects`]; empty without traffic.
    pub object_kinds: Vec<&'static str>,
}

impl Simulation {
    /// The true camera motion `C_j = P_j⁻¹ T_{k-1,k} P_j` of camera `j` in frame pair `k`
    /// (identity if either index is out of range).
    pub fn camera_motion(&self, k: usize, j: usize) -> Pose<f64> {
        match (
            self.vehicle_motions.get(k),
            self.sequence.rig.cameras().get(j),
        ) {
            (Some(m), Some(c)) => camera_motion(m, &c.t_vehicle_camera),
            _ => Pose::identity(),
        }
    }

    /// Writes the sequence directory (`FORMAT.md`).
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<(), IoError> {
        write_sequence(dir, &self.sequence)
    }
}

/// SplitMix64: decorrelates seeds.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn uniform(rng: &mut StdRng, (lo, hi): (f64, f64)) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// A uniformly random pixel inside the image (pixel centres from 0 to size - 1).
fn random_pixel(rng: &mut StdRng, (w, h): (f64, f64)) -> Vector2<f64> {
    Vector2::new(
        rng.random::<f64>() * (w - 1.0).max(0.0),
        rng.random::<f64>() * (h - 1.0).max(0.0),
    )
}

fn gaussian(rng: &mut StdRng, sigma: f64) -> Vector2<f64> {
    let x: f64 = rng.sample(StandardNormal);
    let y: f64 = rng.sample(StandardNormal);
    Vector2::new(x, y) * sigma
}

/// Distance along the unit ray `b` (camera frame) to the scene.
fn scene_range(rng: &mut StdRng, scene: &SceneConfig, mount: &Pose<f64>, b: &Vector3<f64>) -> f64 {
    let origin = mount.translation;
    let d = mount.rotation * b;
    if origin.z > 0.0 && d.z < -1e-9 {
        let lambda = -origin.z / d.z;
        if lambda * d.xy().norm() <= scene.ground_range {
            return lambda;
        }
    }
    if rng.random_bool(scene.far_fraction) {
        uniform(rng, scene.far_range)
    } else {
        uniform(rng, scene.facade_range)
    }
}

/// The matches of one camera and frame pair, their labels, the static points and the traffic
/// object of each match.
type Generated = (
    Vec<Observation>,
    Vec<MatchLabel>,
    Vec<Option<Vector3<f64>>>,
    Vec<Option<usize>>,
);

/// A static match of the previous frame pair that the next may continue
/// ([`SimConfig::static_tracks`]): its noisy pixel in the shared frame and the point in that
/// frame's camera coordinates.
struct Track {
    px: Vector2<f64>,
    point: Vector3<f64>,
}

/// One camera of one frame pair.
struct CameraFrame<'a> {
    cfg: &'a SimConfig,
    camera: &'a RigCamera,
    /// Static points: camera coordinates at k-1 to camera coordinates at k (`C⁻¹`).
    static_motion: Pose<f64>,
    /// Object points, if the object is in view: the same for the object, and its region.
    object: Option<(Pose<f64>, &'a MovingObject)>,
    /// Traffic seen by this camera.
    traffic: Option<CameraTraffic>,
}

/// What a match is made of.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Static,
    Object,
    /// Visible traffic object i of [`CameraTraffic::objects`].
    Traffic(usize),
}

impl CameraFrame<'_> {
    /// Tries once to make an inlier (or an object point); `None` if the point leaves the image.
    /// Also returns the noise-free point in camera coordinates at k-1.
    fn try_match(&self, rng: &mut StdRng, kind: Kind) -> Option<(Observation, Vector3<f64>)> {
        let model = &self.camera.model;
        let (w, h) = model.size();
        let (px0, x0, motion) = match (kind, &self.object, &self.traffic) {
            (Kind::Traffic(i), _, Some(t)) => {
                let v = t.objects.get(i)?;
                let [u0, v0, u1, v1] = v.bbox;
                let px0 = Vector2::new(uniform(rng, (u0, u1)), uniform(rng, (v0, v1)));
                (px0, t.object_point(model, &px0, v.index)?, &v.motion)
            }
            (Kind::Object, Some((motion, obj)), _) => {
                let [u0, v0, u1, v1] = obj.region;
                let px0 = Vector2::new(
                    uniform(rng, (u0 * (w - 1.0), u1 * (w - 1.0))),
                    uniform(rng, (v0 * (h - 1.0), v1 * (h - 1.0))),
                );
                let b0 = model.unproject(&px0)?;
                (px0, b0 * uniform(rng, obj.depth_range), motion)
            }
            _ => {
                let px0 = random_pixel(rng, (w, h));
                if self.occluded(&px0) {
                    return None;
                }
                let b0 = model.unproject(&px0)?;
                let range = scene_range(rng, &self.cfg.scene, &self.camera.t_vehicle_camera, &b0);
                (px0, b0 * range, &self.static_motion)
            }
        };
        let px1 = self.moved_pixel(&x0, motion)?;
        let px0n = px0 + gaussian(rng, self.cfg.pixel_noise);
        let px1n = px1 + gaussian(rng, self.cfg.pixel_noise);
        if !(model.contains(&px0n, 0.0) && model.contains(&px1n, 0.0)) {
            return None;
        }
        Observation::new(model, px0n, px1n).map(|o| (o, x0))
    }

    /// Whether the static scene is hidden at pixel `px` of frame k-1 (a traffic object's box
    /// covers it).
    fn occluded(&self, px: &Vector2<f64>) -> bool {
        self.traffic
            .as_ref()
            .is_some_and(|t| t.occludes(&self.camera.model, px))
    }

    /// The noise-free pixel in frame k of `x0` (camera coordinates at k-1) moved by `motion`;
    /// `None` where the point comes within 0.1 m of the camera or leaves the image.
    fn moved_pixel(&self, x0: &Vector3<f64>, motion: &Pose<f64>) -> Option<Vector2<f64>> {
        let model = &self.camera.model;
        let x1 = motion.transform_point(x0);
        if x1.norm() < 0.1 {
            return None;
        }
        let px1 = model.project(&x1)?;
        if !model.contains(&px1, 0.0) {
            return None;
        }
        // The pixel must map back onto the same ray (fisheye polynomials are not invertible
        // everywhere).
        if model.unproject(&px1)?.dot(&x1.normalize()) < 1.0 - 1e-12 {
            return None;
        }
        Some(px1)
    }

    /// Tries to continue `track` (a static point of the previous pair: its noisy pixel in frame
    /// k-1 and the point in camera coordinates at k-1) into this pair; `None` where it is
    /// occluded, leaves the image or lies behind. Also returns the point at k-1, as
    /// [`CameraFrame::try_match`] does.
    fn try_continue(&self, rng: &mut StdRng, track: &Track) -> Option<(Observation, Vector3<f64>)> {
        let model = &self.camera.model;
        let (px0n, x0) = (track.px, track.point);
        if self.occluded(&px0n) {
            return None;
        }
        let px1 = self.moved_pixel(&x0, &self.static_motion)?;
        let px1n = px1 + gaussian(rng, self.cfg.pixel_noise);
        if !model.contains(&px1n, 0.0) {
            return None;
        }
        Observation::new(model, px0n, px1n).map(|o| (o, x0))
    }

    /// A wrong pixel in frame k for `obs` (keeping its pixel in frame k-1).
    fn outlier(&self, rng: &mut StdRng, obs: &Observation) -> Option<Observation> {
        let model = &self.camera.model;
        let size = model.size();
        let r = self.cfg.near_outlier_radius;
        let min_offset = 3.0 * self.cfg.pixel_noise + 2.0;
        if rng.random_bool(self.cfg.near_outlier_fraction) {
            for _ in 0..20 {
                let offset = Vector2::new(uniform(rng, (-r, r)), uniform(rng, (-r, r)));
                let px1 = obs.px1 + offset;
                if offset.norm() >= min_offset && model.contains(&px1, 0.0) {
                    if let Some(o) = Observation::new(model, obs.px0, px1) {
                        return Some(o);
                    }
                }
            }
        }
        for _ in 0..20 {
            let px1 = random_pixel(rng, size);
            if (px1 - obs.px1).norm() >= min_offset {
                if let Some(o) = Observation::new(model, obs.px0, px1) {
                    return Some(o);
                }
            }
        }
        None
    }

    /// The matches of this camera and frame pair; `tracks` are the previous pair's static
    /// matches that [`SimConfig::static_tracks`] may continue (empty where it is 0).
    fn generate(&self, rng: &mut StdRng, blind: Option<BlindMode>, tracks: &[Track]) -> Generated {
        let n = self.cfg.matches_per_camera;
        let model = &self.camera.model;
        match blind {
            Some(BlindMode::Absent) => return (Vec::new(), Vec::new(), Vec::new(), Vec::new()),
            Some(BlindMode::Outliers) => {
                let obs: Vec<Observation> = (0..n)
                    .filter_map(|_| {
                        let size = model.size();
                        Observation::new(model, random_pixel(rng, size), random_pixel(rng, size))
                    })
                    .collect();
                let labels = vec![MatchLabel::Blinded; obs.len()];
                let points = vec![None; obs.len()];
                let objects = vec![None; obs.len()];
                return (obs, labels, points, objects);
            }
            None => {}
        }
        let n_object = match &self.object {
            Some((_, o)) => (o.fraction * n as f64).round() as usize,
            None => 0,
        };
        let mut kinds: Vec<Kind> = vec![Kind::Object; n_object.min(n)];
        if let Some(t) = &self.traffic {
            for (i, v) in t.objects.iter().enumerate() {
                let m = (v.fraction * n as f64).round() as usize;
                kinds.extend(std::iter::repeat_n(Kind::Traffic(i), m));
            }
        }
        kinds.truncate(n);
        kinds.resize(n, Kind::Static);
        kinds.shuffle(rng);
        // The tracks to continue (`static_tracks`): that share of the static matches, from the
        // previous pair's in a random order, each tried once.
        let mut queue: Vec<&Track> = Vec::new();
        let mut budget = 0usize;
        if self.cfg.static_tracks > 0.0 && !tracks.is_empty() {
            let n_static = kinds.iter().filter(|k| **k == Kind::Static).count();
            budget = (self.cfg.static_tracks * n_static as f64).round() as usize;
            queue = tracks.iter().collect();
            queue.shuffle(rng);
        }
        let mut obs = Vec::with_capacity(n);
        let mut labels = Vec::with_capacity(n);
        let mut points = Vec::with_capacity(n);
        let mut objects = Vec::with_capacity(n);
        for kind in kinds {
            let mut continued = None;
            while kind == Kind::Static && budget > 0 {
                let Some(track) = queue.pop() else { break };
                if let Some(m) = self.try_continue(rng, track) {
                    budget -= 1;
                    continued = Some(m);
                    break;
                }
            }
            for _ in 0..100 {
                if let Some((o, x0)) = continued.take().or_else(|| self.try_match(rng, kind)) {
                    obs.push(o);
                    let on_object = kind != Kind::Static;
                    points.push((!on_object).then_some(x0));
                    objects.push(match (kind, &self.traffic) {
                        (Kind::Traffic(i), Some(t)) => t.objects.get(i).map(|v| v.object),
                        _ => None,
                    });
                    labels.push(if on_object {
                        MatchLabel::MovingObject
                    } else {
                        MatchLabel::Inlier
                    });
                    break;
                }
            }
        }
        let n_out = (self.cfg.outlier_ratio * obs.len() as f64).round() as usize;
        let chosen = rand::seq::index::sample(rng, obs.len(), n_out.min(obs.len()));
        let mut drop = Vec::new();
        for i in chosen.iter() {
            match self.outlier(rng, &obs[i]) {
                Some(o) => {
                    obs[i] = o;
                    labels[i] = MatchLabel::Outlier;
                    points[i] = None;
                    objects[i] = None;
                }
                None => drop.push(i),
            }
        }
        // Matches that could not be turned into outliers (tiny images) are dropped rather than
        // left as unlabeled inliers.
        drop.sort_unstable();
        for i in drop.into_iter().rev() {
            obs.remove(i);
            labels.remove(i);
            points.remove(i);
            objects.remove(i);
        }
        (obs, labels, points, objects)
    }
}

/// Runs the simulator. Fails only on an invalid configuration ([`SimConfig::validate`]).
pub fn simulate(cfg: &SimConfig) -> Result<Simulation, SimError> {
    let rig = cfg.rig.rig();
    cfg.validate(&rig)?;
    let n_cams = rig.len();
    let p0 = rig.cameras()[0].t_vehicle_camera;
    // A trajectory longer than the simulated frames continues the traffic's path beyond the
    // last frame (objects ahead follow its curve); the frames' own poses are the same.
    let (drive, later_poses) = match &cfg.camera_trajectory {
        Some(t) => {
            let mount = cfg.trajectory_mount.unwrap_or(p0);
            let mut drive = drive_along(t, &mount, cfg.drive.frame_rate);
            let n = cfg.frames.min(t.len());
            let later = drive.poses.split_off(n);
            drive.arc_lengths.truncate(n);
            drive.speeds.truncate(n);
            (drive, later)
        }
        None => (
            generate_drive(&cfg.drive, cfg.frames, cfg.stops, cfg.seed),
            Vec::new(),
        ),
    };
    let n_frames = drive.poses.len();
    let vehicle_motions: Vec<Pose<f64>> = (0..n_frames).map(|k| drive.motion(k)).collect();
    let traffic = cfg.traffic.as_ref().map(|t| {
        (
            t,
            generate_traffic_along(
                t,
                &drive.poses,
                &drive.arc_lengths,
                &later_poses,
                cfg.drive.frame_rate,
                cfg.seed,
            ),
        )
    });

    let mut frames = vec![FrameObservations::new(n_cams)];
    let mut labels = vec![vec![Vec::new(); n_cams]];
    let mut static_points = vec![vec![Vec::new(); n_cams]];
    let mut objects = vec![vec![Vec::new(); n_cams]];
    // The previous pair's static matches per camera (`static_tracks`; empty where it is 0).
    let mut tracks: Vec<Vec<Track>> = (0..n_cams).map(|_| Vec::new()).collect();
    for k in 1..n_frames {
        let m = &vehicle_motions[k];
        let mut frame = FrameObservations::new(n_cams);
        let mut frame_labels = vec![Vec::new(); n_cams];
        let mut frame_points = vec![Vec::new(); n_cams];
        let mut frame_objects = vec![Vec::new(); n_cams];
        for (j, camera) in rig.cameras().iter().enumerate() {
            let mut rng = StdRng::seed_from_u64(mix(mix(mix(cfg.seed) ^ k as u64) ^ j as u64));
            let p = &camera.t_vehicle_camera;
            let object = cfg
                .moving_object
                .as_ref()
                .filter(|o| o.camera == j && o.frames.contains(&k))
                .map(|o| (p.inverse().compose(&o.relative_motion.compose(p)), o));
            let blind = cfg
                .blinded
                .iter()
                .find(|b| b.camera == j && b.frames.contains(&k))
                .map(|b| b.mode);
            let cf = CameraFrame {
                cfg,
                camera,
                static_motion: camera_motion(m, p).inverse(),
                object,
                traffic: traffic
                    .as_ref()
                    .and_then(|(t, tr)| CameraTraffic::new(t, tr, camera, k)),
            };
            let (obs, lab, pts, objs) = cf.generate(&mut rng, blind, &tracks[j]);
            if cfg.static_tracks > 0.0 {
                // The static matches: those with a scene point (`Simulation::static_points`).
                tracks[j] = obs
                    .iter()
                    .zip(&pts)
                    .filter_map(|(o, x0)| {
                        Some(Track {
                            px: o.px1,
                            point: cf.static_motion.transform_point(x0.as_ref()?),
                        })
                    })
                    .collect();
            }
            frame.per_camera[j] = obs;
            frame_labels[j] = lab;
            frame_points[j] = pts;
            frame_objects[j] = objs;
        }
        frames.push(frame);
        labels.push(frame_labels);
        static_points.push(frame_points);
        objects.push(frame_objects);
    }

    let arc_lengths = cfg.odometry.then(|| {
        let mut rng = StdRng::seed_from_u64(mix(cfg.seed ^ 0x0D0_0E7E5));
        let mut a = vec![None];
        for &s in &drive.arc_lengths[1..] {
            let noise: f64 = rng.sample(StandardNormal);
            a.push(Some((s * (1.0 + cfg.odometry_noise * noise)).max(0.0)));
        }
        a
    });
    let v0_inv = drive.poses[0].inverse();
    let ground_truth = drive
        .poses
        .iter()
        .map(|v| p0.inverse().compose(&v0_inv.compose(v).compose(&p0)))
        .collect();

    Ok(Simulation {
        sequence: Sequence {
            rig,
            frames,
            arc_lengths,
            ground_truth: Some(ground_truth),
        },
        vehicle_poses: drive.poses,
        vehicle_motions,
        speeds: drive.speeds,
        true_arc_lengths: drive.arc_lengths,
        labels,
        static_points,
        objects,
        object_kinds: traffic.as_ref().map_or_else(Vec::new, |(_, tr)| {
            tr.objects.iter().map(|o| o.kind).collect()
        }),
    })
}

/// Camera poses turned so that the camera looks along its travel: every pose `C_k` becomes
/// `C_k · R_x(θ)`, `θ` the median over the consecutive pairs that move more than 0.3 m of the
/// travel's elevation above the optical axis, `atan2(-t_y, t_z)` of the relative translation in
/// the camera at k-1 (KITTI camera frame: x right, y down, z forward). Returns the poses and
/// `θ` (0 where no pair moves that much).
///
/// A real camera is mounted a little off the direction of travel: the KITTI camera looks about
/// 1° down against it (+0.98° on sequence 00, −0.39° on 03). Driven as a level camera
/// ([`vehicle_poses_from_camera_poses`]), such a trajectory makes the simulated vehicle travel
/// that far above its own road plane (the scene's ground is the vehicle's `z = 0` at each
/// frame); turned first, the vehicle travels along its road, as a real one does, and the
/// rig's camera looks along the travel (`momo simulate --trajectory-along-travel`;
/// docs/RESULTS.md, forty-eighth session).
///
/// ```
/// use momo_core::{Pose, so3_exp};
/// use momo_sim::along_travel;
/// use nalgebra::Vector3;
///
/// // A camera pitched 1° nose down (about its x axis) driving straight along the world's z.
/// let pitch = so3_exp(&Vector3::new(-1f64.to_radians(), 0.0, 0.0));
/// let c: Vec<Pose<f64>> = (0..5)
///     .map(|k| Pose::new(pitch, Vector3::new(0.0, 0.0, k as f64)))
///     .collect();
/// let (turned, theta) = along_travel(&c);
/// assert!((theta.to_degrees() - 1.0).abs() < 1e-9);
/// let t = turned[0].inverse().compose(&turned[1]).translation;
/// assert!(t.y.abs() < 1e-12 && (t.z - 1.0).abs() < 1e-12);
/// ```
pub fn along_travel(camera_poses: &[Pose<f64>]) -> (Vec<Pose<f64>>, f64) {
    let mut elevations: Vec<f64> = camera_poses
        .windows(2)
        .map(|w| w[0].inverse().compose(&w[1]).translation)
        .filter(|t| t.norm() > 0.3)
        .map(|t| (-t.y).atan2(t.z))
        .collect();
    elevations.sort_by(f64::total_cmp);
    let n = elevations.len();
    let theta = match n {
        0 => 0.0,
        _ if n % 2 == 1 => elevations[n / 2],
        _ => 0.5 * (elevations[n / 2 - 1] + elevations[n / 2]),
    };
    let turn = Pose::new(
        momo_core::so3_exp(&Vector3::new(theta, 0.0, 0.0)),
        Vector3::zeros(),
    );
    (
        camera_poses.iter().map(|c| c.compose(&turn)).collect(),
        theta,
    )
}

/// The vehicle poses of camera-0 poses: `V_k = P0 · C_k · P0⁻¹` with `P0 = T_vehicle_camera` of
/// camera 0 (the inverse of the ground truth's `C_k = P0⁻¹ V_k P0`).
///
/// ```
/// use momo_core::Pose;
/// use momo_sim::{camera_poses_from_vehicle_poses, kitti_mono, vehicle_poses_from_camera_poses};
/// use nalgebra::{Matrix3, Vector3};
///
/// let p0 = kitti_mono().cameras()[0].t_vehicle_camera;
/// // Camera 0 one metre forward along its optical axis (z): the vehicle one metre along x.
/// let c = [Pose::identity(), Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, 1.0))];
/// let v = vehicle_poses_from_camera_poses(&c, &p0);
/// assert!((v[1].translation - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
/// let back = camera_poses_from_vehicle_poses(&v, &p0);
/// assert!((back[1].translation - c[1].translation).norm() < 1e-12);
/// ```
pub fn vehicle_poses_from_camera_poses(
    camera_poses: &[Pose<f64>],
    t_vehicle_camera0: &Pose<f64>,
) -> Vec<Pose<f64>> {
    let p0_inv = t_vehicle_camera0.inverse();
    camera_poses
        .iter()
        .map(|c| t_vehicle_camera0.compose(&c.compose(&p0_inv)))
        .collect()
}

/// The camera-0 poses of vehicle poses: `C_k = P0⁻¹ · V_k · P0` (the inverse of
/// [`vehicle_poses_from_camera_poses`]).
pub fn camera_poses_from_vehicle_poses(
    vehicle_poses: &[Pose<f64>],
    t_vehicle_camera0: &Pose<f64>,
) -> Vec<Pose<f64>> {
    let p0_inv = t_vehicle_camera0.inverse();
    vehicle_poses
        .iter()
        .map(|v| p0_inv.compose(&v.compose(t_vehicle_camera0)))
        .collect()
}

/// A drive along given camera-0 poses: vehicle poses relative to the first, arc lengths the
/// distances between consecutive motion centres (chords), speeds those times the frame rate.
fn drive_along(camera_poses: &[Pose<f64>], p0: &Pose<f64>, frame_rate: f64) -> Drive {
    let vehicle = vehicle_poses_from_camera_poses(camera_poses, p0);
    let v0_inv = vehicle.first().map_or_else(Pose::identity, Pose::inverse);
    let poses: Vec<Pose<f64>> = vehicle.iter().map(|v| v0_inv.compose(v)).collect();
    let mut arc_lengths = vec![0.0];
    arc_lengths.extend(
        poses
            .windows(2)
            .map(|w| (w[1].translation - w[0].translation).norm()),
    );
    let speeds = arc_lengths.iter().map(|s| s * frame_rate).collect();
    Drive {
        poses,
        arc_lengths,
        speeds,
    }
}
