//! # momo-sim
//!
//! A deterministic simulator of vehicle drives and the sparse feature matches a camera rig sees
//! on them, producing `FORMAT.md` sequences (a [`momo_io::Sequence`]) with ground truth. Used by
//! `momo demo`, end-to-end tests and `momo simulate`.
//!
//! - Rigs ([`rigs`]): [`kitti_mono`], [`kitti_stereo`], [`surround_fisheye`], or any
//!   [`Rig`](momo_core::Rig) via [`RigPreset::Custom`].
//! - Drives ([`drive`]): 10 Hz single-track kinematics with smooth speed (0 to 30 m/s) and
//!   curvature profiles, yaw-rate and lateral-acceleration limits, optional stops, small pitch and
//!   roll oscillations, optional side slip.
//! - Or a drive along real camera poses ([`SimConfig::camera_trajectory`], e.g. a KITTI
//!   ground-truth file; [`vehicle_poses_from_camera_poses`]).
//! - The Cramér-Rao bound of every frame pair's rotation from its static matches ([`bound`]).
//! - The true label of every match as `labels.csv` ([`labels`]).
//! - Presets by name: [`SimConfig::SCENARIOS`], [`SimConfig::scenario`].
//! - Matches ([`sim`]): uniform pixels, depths from a ground plane / facade / far-point scene,
//!   Gaussian pixel noise, outliers, blinded cameras, an independently moving object; every match
//!   carries a [`MatchLabel`].
//!
//! Vehicle frame x forward, y left, z up; `M = T_{k-1,k} = V_{k-1}⁻¹ V_k`; camera motion
//! `C_j = P_j⁻¹ M P_j` with `P_j = T_vehicle_camera`; ground truth `T_cam0(0)_cam0(k)`.
//!
//! ```
//! use momo_core::essential;
//! use momo_sim::{MatchLabel, SimConfig, simulate};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let cfg = SimConfig { frames: 20, pixel_noise: 0.0, ..SimConfig::outliers() };
//! let sim = simulate(&cfg)?;
//! assert_eq!(sim.sequence.num_frames(), 20);
//! assert_eq!(sim.sequence.ground_truth.as_ref().map(Vec::len), Some(20));
//!
//! // Noise-free inliers satisfy the epipolar constraint of the true camera motion.
//! let e = essential(&sim.camera_motion(5, 0));
//! for (o, label) in sim.sequence.frames[5].per_camera[0].iter().zip(&sim.labels[5][0]) {
//!     if *label == MatchLabel::Inlier {
//!         assert!((o.f1.transpose() * e * o.f0)[0].abs() < 1e-9);
//!     }
//! }
//!
//! // Write it as a sequence directory that `momo run` reads.
//! let dir = tempfile::tempdir()?;
//! sim.write(dir.path())?;
//! assert_eq!(momo_io::read_sequence(dir.path())?, sim.sequence);
//! # Ok(())
//! # }
//! ```

pub mod bound;
pub mod camera_scenarios;
pub mod drive;
pub mod labels;
pub mod rigs;
pub mod sim;
pub mod traffic;

pub use camera_scenarios::{
    double_sphere_camera, radtan_camera, radtan_mono_rig, unified_camera, wide_angle_surround_rig,
};
pub use drive::{Drive, DriveConfig, generate_drive};
pub use rigs::{
    RigPreset, camera_mount, kitti_camera, kitti_mono, kitti_stereo, surround_fisheye,
    surround_fisheye_camera,
};
pub use sim::{
    BlindMode, Blinding, MAX_MATCHES_PER_CAMERA, MatchLabel, MovingObject, SceneConfig, SimConfig,
    SimError, Simulation, along_travel, camera_poses_from_vehicle_poses, simulate,
    vehicle_poses_from_camera_poses,
};
pub use traffic::{
    Traffic, TrafficConfig, TrafficObject, generate_traffic, generate_traffic_along,
};
