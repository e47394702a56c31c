//! # momo-fivepoint
//!
//! A classical baseline for momo: 5-point RANSAC relative pose of one calibrated camera, as
//! OpenCV's `findEssentialMat(RANSAC)` + `recoverPose` (and, with
//! [`FivePointRansac::refine`], PoseLib's LO-RANSAC-style least-squares refinement), converted
//! to the vehicle motion through the camera's extrinsic and scaled by the odometry arc length.
//!
//! - [`solve_five_point`]: the minimal solver (Stewénius' action-matrix form of Nistér's
//!   5-point algorithm) on unit bearing vectors, up to 10 essential matrices;
//! - [`decompose_essential`], [`recover_pose`]: the 4 `(R, t)` candidates and the cheirality
//!   test (midpoint triangulation in front of both cameras);
//! - [`FivePointRansac`]: adaptive RANSAC with an angular Sampson threshold
//!   ([`sampson_angle_sq`]), deterministic for a seed;
//! - [`vehicle_motion_from_camera`]: `M = P C P⁻¹` with the camera translation scaled so that
//!   the vehicle's chord matches the arc length.
//!
//! Conventions (`DESIGN.md`): the camera motion `C = [R | t]` is the pose of the camera at
//! frame k in the camera at k-1; bearings satisfy `f1ᵀ E f0 = 0` with `E = Rᵀ [t]ₓ`
//! ([`momo_core::essential`]). Unlike momo's estimator, this baseline uses no motion model, no
//! warm start and no robust loss: it is the reference momo is compared against.
//!
//! ```
//! use momo_core::{Manifold, Pose};
//! use momo_testing::canned;
//! use momo_fivepoint::FivePointRansac;
//! use momo_models::SingleTrack2d;
//!
//! let rig = canned::pinhole_rig(); // one camera, 1.5 m ahead of the motion centre
//! let truth = SingleTrack2d.motion(&[0.05, 1.2]); // yaw 0.05 rad, arc length 1.2 m
//! // 100 exact matches and 30 outliers.
//! let frame = canned::synthetic_observations(&rig, &truth, 100, 30, 42);
//! let ransac = FivePointRansac::default();
//! let (m, result) = ransac.estimate_vehicle_motion(&rig, &frame, Some(1.2)).unwrap();
//! assert!(result.inliers >= 100);
//! assert!((m.rotation - truth.rotation).amax() < 1e-6);
//! assert!((m.translation - truth.translation).amax() < 1e-5);
//! ```

mod decompose;
mod ransac;
mod solver;
mod vehicle;

pub use decompose::{count_in_front, decompose_essential, recover_pose, triangulate_depths};
pub use ransac::{FivePointRansac, FivePointResult, MIN_MATCHES, refine_motion, sampson_angle_sq};
pub use solver::{DEGENERACY_RATIO, solve_five_point};
pub use vehicle::{half_angle_sinc, vehicle_motion_from_camera};
