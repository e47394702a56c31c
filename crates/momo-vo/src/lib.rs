//! # momo-vo
//!
//! The odometry driver of momo: feed frame pairs' matches to an [`Odometry`] and get the
//! vehicle motion `T_{k-1,k}` with per-frame diagnostics (parameters, cost, iterations,
//! termination, inliers, covariance, time), warm-started from the previous motion. A SLAM
//! system calls it frame by frame for a pose prior; `momo run` is a thin shell over it.
//!
//! ```
//! use momo_vo::{Config, Odometry};
//! use momo_core::{Camera, FrameObservations, Pinhole, Pose, Rig};
//! use nalgebra::{Matrix3, Vector3};
//!
//! let cam = Camera::Pinhole(Pinhole { fx: 700.0, fy: 700.0, cx: 620.0, cy: 188.0, width: 1241.0, height: 376.0 });
//! let p = Pose::new(Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0), Vector3::new(1.0, 0.0, 1.65));
//! let rig = Rig::mono(cam, p).expect("valid rig");
//! let mut vo = Odometry::new(rig, Config::default()).expect("valid config");
//! // A frame pair without matches holds the previous motion and says so.
//! let r = vo.process(&FrameObservations::new(1), Some(0.8));
//! assert_eq!(r.diagnostics.status, momo_vo::FrameStatus::NoMatches);
//! assert!((r.motion.translation.x - 0.8).abs() < 1e-9);
//! ```

pub mod baseline;
pub mod batch;
pub mod calibrate;
pub mod config;
pub mod final_fit;
pub mod ground_drop;
pub mod hypotheses;
pub mod noise;
pub mod odometry;
pub mod pipeline;
mod road_track;
pub mod separate;
mod stats;
pub mod stereo_scale;
pub mod trust;
pub mod yaw_votes;

pub use baseline::{FivePointBaseline, MotionDriver};
pub use batch::{BatchError, FramePair, estimate_batch};
pub use calibrate::{
    CalibrationError, MountCalibration, MountEstimate, MountModel, Mounted, SkippedFrames,
    calibrate_mount, calibrate_sequence,
};
pub use config::{
    Config, ConfigError, FivePointOptions, MAX_CONFIG_BYTES, OdometryOptions, Origin,
    RoadScaleMount, TiltHoldStage,
};
pub use odometry::{
    FrameDiagnostics, FrameResult, FrameStatus, Odometry, ScaleSource, Trajectory, VoError,
};
pub use pipeline::{
    DiagnosticsWriter, EstimatorKind, RoadMount, RunError, RunOptions, RunSummary, driver,
    road_scale_setup, run_in_memory, run_loop, run_sequence,
};
pub use trust::{Constraint, Reason, TrustOptions};
