//! The 5-point RANSAC baseline behind the same driver interface as momo's estimator, so that
//! every comparison runs with one command (`momo run --estimator five-point`).

use crate::odometry::{FrameDiagnostics, FrameResult, FrameStatus, Odometry, ScaleSource};
use momo_core::{FrameObservations, Pose, Rig, so3_log};
use momo_fivepoint::FivePointRansac;
use std::time::Instant;

/// Something that turns one frame pair's matches (and the odometry arc length, if known) into
/// the vehicle motion with diagnostics: momo's [`Odometry`] or the [`FivePointBaseline`].
pub trait MotionDriver {
    /// Processes the next frame pair.
    fn process(&mut self, obs: &FrameObservations, arc_length: Option<f64>) -> FrameResult;
}

impl MotionDriver for Odometry {
    fn process(&mut self, obs: &FrameObservations, arc_length: Option<f64>) -> FrameResult {
        Odometry::process(self, obs, arc_length)
    }
}

/// Nistér's 5-point solver in RANSAC with the cheirality check (as OpenCV's findEssentialMat +
/// recoverPose), on the camera with the most matches, the translation scaled by the odometry
/// arc length. Without a consensus (fewer than 5 matches, degenerate samples) the previous
/// motion is held (`no_matches` / `solver_failure`). Without odometry the last arc length is
/// held (the 5-point cannot observe scale).
#[derive(Debug)]
pub struct FivePointBaseline {
    rig: Rig,
    ransac: FivePointRansac,
    previous: Pose<f64>,
    last_arc_length: f64,
    frame: usize,
}

/// The parameter names of the baseline's diagnostics: the rotation vector and translation of the
/// vehicle motion.
const BASELINE_PARAMS: [&str; 6] = ["rot_x", "rot_y", "rot_z", "t_x", "t_y", "t_z"];

impl FivePointBaseline {
    /// A baseline for a rig with the given RANSAC options.
    pub fn new(rig: Rig, ransac: FivePointRansac) -> Self {
        Self {
            rig,
            ransac,
            previous: Pose::identity(),
            last_arc_length: 1.0,
            frame: 0,
        }
    }
}

impl MotionDriver for FivePointBaseline {
    fn process(&mut self, obs: &FrameObservations, arc_length: Option<f64>) -> FrameResult {
        let start = Instant::now();
        self.frame += 1;
        let arc = arc_length.filter(|l| l.is_finite() && *l >= 0.0);
        let scale = if arc.is_some() {
            ScaleSource::Odometry
        } else {
            ScaleSource::Held
        };
        let l = arc.unwrap_or(self.last_arc_length);
        let estimate = if obs.len() < 5 {
            None
        } else {
            self.ransac.estimate_vehicle_motion(&self.rig, obs, Some(l))
        };
        let (motion, status, inliers, iterations) = match estimate {
            Some((m, r))
                if m.rotation
                    .iter()
                    .chain(m.translation.iter())
                    .all(|v| v.is_finite()) =>
            {
                (m, FrameStatus::Estimated, r.inliers, r.iterations)
            }
            _ => {
                let status = if obs.len() < 5 {
                    FrameStatus::NoMatches
                } else {
                    FrameStatus::SolverFailure
                };
                // Hold the previous motion, rescaled to this frame's arc length.
                let mut m = self.previous;
                let n = m.translation.norm();
                if n > 1e-12 {
                    m.translation *= l / n;
                }
                (m, status, 0, 0)
            }
        };
        if l > 0.0 {
            self.last_arc_length = l;
        }
        self.previous = motion;
        let w = so3_log(&motion.rotation);
        let params = vec![
            w.x,
            w.y,
            w.z,
            motion.translation.x,
            motion.translation.y,
            motion.translation.z,
        ];
        let diagnostics = FrameDiagnostics {
            frame: self.frame,
            status,
            scale,
            param_names: BASELINE_PARAMS.iter().map(|s| s.to_string()).collect(),
            params,
            param_sigmas: vec![f64::NAN; 6],
            covariance: Vec::new(),
            free: Vec::new(),
            initial_cost: f64::NAN,
            final_cost: f64::NAN,
            iterations,
            termination: None,
            matches: obs.len(),
            inliers,
            inliers_per_camera: Vec::new(),
            restarts: 0,
            restart_won: false,
            time_us: start.elapsed().as_secs_f64() * 1e6,
            constraint: crate::trust::Constraint::Well,
            reason: None,
            jackknife: false,
            competing: None,
            residual_clustering: f64::NAN,
            road_alternative: None,
            guard_alternative: None,
            noise_scale: 1.0,
            noise: None,
            support: None,
        };
        FrameResult {
            motion,
            diagnostics,
        }
    }
}
