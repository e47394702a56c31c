//! The odometry driver: one frame pair's matches in, the vehicle motion and diagnostics out,
//! warm-started from the previous motion (the paper's prior).

use crate::config::{Config, ConfigError, TiltHoldStage};
use crate::trust::{self, Constraint, Reason};
use momo_core::{
    CameraModel, CoreError, FrameEstimator, FrameObservations, FrameSolution, MotionPrior, Pose,
    Rig, SolveRequest, Termination, camera_motion, so3_log,
};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::time::Instant;
use thiserror::Error;

/// Errors of the driver (configuration that does not fit the rig).
#[derive(Debug, Error)]
pub enum VoError {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Model, metric and rig do not fit together.
    #[error(transparent)]
    Core(#[from] CoreError),
}

/// What happened to a frame pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameStatus {
    /// The motion was estimated from the matches.
    Estimated,
    /// Standstill (arc length below the threshold): rotation only, zero translation.
    Standstill,
    /// Too few matches: the previous motion was held.
    NoMatches,
    /// The solver failed (non-finite cost, no step): the previous motion was held.
    SolverFailure,
    /// The matches cannot determine the motion or do not support the estimate (the reason is
    /// in [`FrameDiagnostics::reason`]): the previous motion was held, with infinite standard
    /// deviations.
    Degenerate,
    /// The matches constrain the motion only in part (the reason is in
    /// [`FrameDiagnostics::reason`]): the estimate is kept but flagged, and it does not centre
    /// the next frame's prior.
    Weak,
}

/// Where the frame's arc length (scale) came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScaleSource {
    /// From odometry.csv.
    Odometry,
    /// Estimated from the matches (observable through the rig's lever arm in a curve).
    Estimated,
    /// Not observable in this frame: the last value was held.
    Held,
    /// No odometry, and the rig can never observe scale (every camera in the motion centre,
    /// [`Odometry::scale_observable`] is false): the arc length is
    /// `odometry.initial_arc_length` or the last value odometry gave, so the trajectory's scale
    /// is arbitrary.
    Unobservable,
    /// No odometry, one camera, `odometry.road_scale_frames`: held at the median of the last
    /// frames' arc lengths from the road plane ([`Odometry::road_arc_length`]).
    Road,
}

/// Per-frame diagnostics (one row of `--diagnostics`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameDiagnostics {
    /// Frame index k (the pair k-1, k).
    pub frame: usize,
    /// What happened.
    pub status: FrameStatus,
    /// Where the scale came from.
    pub scale: ScaleSource,
    /// Parameter names of the model.
    pub param_names: Vec<String>,
    /// Final parameters.
    pub params: Vec<f64>,
    /// Standard deviations of the free parameters (NaN for fixed or unknown ones).
    pub param_sigmas: Vec<f64>,
    /// Covariance of the free parameters, row-major (`free x free`), empty if unavailable.
    pub covariance: Vec<f64>,
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    /// Cost at the start of the chosen solve.
    pub initial_cost: f64,
    /// Cost at the end.
    pub final_cost: f64,
    /// Solver iterations (of the chosen solve).
    pub iterations: usize,
    /// Why the solver stopped (`None` when no solve ran).
    pub termination: Option<Termination>,
    /// Matches of the frame pair, all cameras.
    pub matches: usize,
    /// Matches whose residual is within the loss scale.
    pub inliers: usize,
    /// Inliers per camera.
    pub inliers_per_camera: Vec<usize>,
    /// Extra starts tried because the first result looked bad (0 if none).
    pub restarts: usize,
    /// Whether an extra start won.
    pub restart_won: bool,
    /// Compute time of the frame in microseconds.
    pub time_us: f64,
    /// How well the matches constrained the motion (well / weak / degenerate).
    pub constraint: Constraint,
    /// Why the frame is weak or degenerate (`None` if well constrained).
    pub reason: Option<Reason>,
    /// Whether the leave-one-cell-out jackknife of the covariance ran on this frame
    /// ([`trust::TrustOptions::jackknife_support_drop`]).
    #[serde(default)]
    pub jackknife: bool,
    /// The competing motion found by the covariance's check ([`trust::mixture_covariance`]):
    /// its parameters (all of the model's) and its weight `w`; `None` if there was none.
    #[serde(default)]
    pub competing: Option<(Vec<f64>, f64)>,
    /// The clustering of the residuals in the image ([`trust::cell_residual_statistic`]),
    /// divided by its degrees of freedom (about 1 for independent residuals; NaN if not
    /// computed).
    #[serde(default)]
    pub residual_clustering: f64,
    /// The road's alternative that widened the covariance of a frame whose road score dropped
    /// (`trust.road_alternative_weight`, [`trust::alternatives_covariance`]): its parameters
    /// (all of the model's); `None` where there was none.
    #[serde(default)]
    pub road_alternative: Option<Vec<f64>>,
    /// The final stage the neighbourhood guard did not keep, where the stage without the
    /// matches the neighbourhood test (or, on one camera, the guarded under-the-road test) left
    /// out and the stage on the matches it was given turned apart by more than
    /// `odometry.final_fit.neighbour_guard`: the reduced stage's motion where the guard kept
    /// the given matches' stage, the given one's where `final_fit.guard_tilt` kept the reduced
    /// stage (its parameters, all of the model's). It widened the reported covariance
    /// (`trust.guard_alternative_weight`, [`trust::alternatives_covariance`]) where that
    /// weight is positive. `None` (not written) where the two stages did not turn apart.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guard_alternative: Option<Vec<f64>>,
    /// The factor the driver's angular thresholds were scaled by on this frame for the run's
    /// measured noise (`odometry.noise_reference`, [`crate::noise`]): 1 while the noise read so
    /// far lies within `noise_band` times the reference, or with the rule off.
    #[serde(default = "one")]
    pub noise_scale: f64,
    /// This frame's noise reading that entered the run's window of `odometry.noise_frames`
    /// (radians; the final stage's trimmed MAD of the epipolar angles at the reported motion
    /// with the stage's default options, [`crate::separate::noise_sigma`]: it stops at 5 loss
    /// scales, 0.005 rad, whatever the scale in force). `None` (not written) where the frame
    /// was not read: not moving, not `estimated` or a competing motion found before the
    /// report-only rules (a frame only they flag is read), or the rule off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
    /// The final stage's support ([`crate::final_fit`]), with `odometry.report_support` only:
    /// per camera, the indices of the matches the stage refit on (its last pass), counted
    /// among the camera's matches of the frame in input order (matches.csv's rows of that
    /// camera and frame). `None` (not written) where the option is off or where no final stage
    /// refit the frame (standstill, too few matches, the stage off, not estimable or failed:
    /// the reported motion is then the first stage's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub support: Option<Vec<Vec<usize>>>,
}

/// Serde's default of [`FrameDiagnostics::noise_scale`] (diagnostics written before the field).
fn one() -> f64 {
    1.0
}

/// The result of one frame pair.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// Vehicle motion `T_{k-1,k}`.
    pub motion: Pose<f64>,
    /// Diagnostics.
    pub diagnostics: FrameDiagnostics,
}

/// Per-frame decay of the recent frames' best inlier share (half-life about 140 frames): a
/// drop of the support against it triggers the jackknife of the covariance.
const INLIER_SHARE_PEAK_DECAY: f64 = 0.995;

/// The fewest moving frames whose innovations learn a soft prior's standard deviations
/// (`odometry.soft_prior_sigma_learning`); before that, the model's own.
pub const SOFT_SIGMA_MIN_FRAMES: usize = 20;

/// The soft prior's consistency widening (`odometry.soft_prior_consistency_frames`) acts only
/// where none of the last this many frames was flagged `weak` by `competing_motions` or
/// `road_score_drop`: a vehicle followed over many frames pulls the data's side slip
/// persistently, as a drifting direction of travel does, and there the prior protects the
/// estimate (without the wait, on the moving-traffic quick subset's 24 sequences: 14 worse by
/// more than 0.005 in efficiency and 5 better; docs/RESULTS.md §9, twentieth session). The
/// static scenes along KITTI have no such frame. (Waiting also after frames where the
/// separation's two motions merely competed, unflagged, held the family as well but gave up
/// part of the static scenes' gain.)
pub const CONSISTENCY_QUIET_FRAMES: usize = 100;

/// The median of a chi-square variable with one degree of freedom.
const CHI2_1_MEDIAN: f64 = 0.454_936_423_119_572_8;

/// `odometry.tilt_hold_sigma`: the trusted frames' tilts are averaged exponentially over
/// this many frames (the hold's centre: KITTI's per-frame roll and pitch scatter by about
/// 0.002 rad from frame to frame, nearly independently, while a road's grade or a mount's
/// offset moves the centre slowly).
const TILT_HOLD_MEAN_FRAMES: f64 = 10.0;

/// The frame-to-frame odometry: feed it frame pairs in order with [`Odometry::process`].
///
/// Behaviour on degenerate frames (documented in the README and tested):
/// - fewer than `min_matches` matches: the previous motion is held (with the frame's odometry
///   arc length if given), status [`FrameStatus::NoMatches`];
/// - arc length below `standstill_arc_length`: rotation-only residual, zero arc length, status
///   [`FrameStatus::Standstill`]; the first moving frame after it starts straight ahead;
/// - solver failure: the previous motion is held, status [`FrameStatus::SolverFailure`];
/// - a camera whose matches are all outliers is down-weighted by the robust loss, the others
///   carry the estimate (visible in `inliers_per_camera`);
/// - an inlier ratio below `restart_inlier_ratio` times the running average triggers extra
///   starts (yaw offsets around the
///   previous motion, and straight ahead); the lowest cost wins.
#[derive(Debug)]
pub struct Odometry {
    rig: Rig,
    config: Config,
    estimator: Box<dyn FrameEstimator>,
    /// The final stage's estimator where `odometry.final_fit.metric` names its own metric.
    final_estimator: Option<Box<dyn FrameEstimator>>,
    previous: Vec<f64>,
    last_arc_length: Option<f64>,
    /// The last frame pair was a standstill: its motion says nothing about the direction of
    /// travel, so the next moving frame starts straight ahead.
    after_standstill: bool,
    /// The last frame pair was flagged `weak` by two competing motions or the road score's drop
    /// (`trust.after_flag_weight`).
    after_flag: bool,
    /// The yaw `ω_z` of the previous frame's reported motion where that frame was estimated
    /// while moving (`estimated` or `weak`), `None` otherwise (`trust.yaw_change`).
    previous_yaw: Option<f64>,
    /// `trust.side_slip_change`: the centre of the side slip (its mean) and how many frames
    /// fed it.
    side_slip_centre: (f64, usize),
    /// `trust.side_slip_hold`: moving frames left in the hold after a side-slip flag.
    side_slip_hold_left: usize,
    /// `trust.unconfirmed_start`: a frame since the start (or the reset) was reported
    /// `estimated` without a competing motion.
    start_confirmed: bool,
    /// `trust.unconfirmed_start_frames`: so many frames in a row since the start (or the reset)
    /// were reported `estimated` without a competing motion.
    start_settled: bool,
    /// `trust.unconfirmed_start_frames`: the frames in a row reported `estimated` without a
    /// competing motion.
    start_clean: usize,
    /// `trust.unconfirmed_start_distance`: the arc length of the frames in `start_clean`.
    start_clean_distance: f64,
    /// `trust.unconfirmed_start_frames`: a competing motion was found since the start (or the
    /// reset).
    start_contested: bool,
    /// `separate.under_road_guard`: a moving frame since the start (or the reset) where the
    /// separation saw no second motion compete (the separation's own notion of a settled
    /// start, not the trust module's flags).
    separation_settled: bool,
    /// The rotation vector `ω = log R` of the previous frame's reported motion where that frame
    /// was estimated while moving, `None` otherwise (`trust.support_change_share`).
    previous_omega: Option<nalgebra::Vector3<f64>>,
    /// The previous frame fired `trust.support_change_share` (whatever its status).
    support_change_fired: bool,
    /// `trust.contested_yaw_change`'s history.
    contested_yaw: trust::ContestedYaw,
    /// The frame and full parameters of the last competing motion found on a moving frame
    /// (`trust.competing_recheck_frames`).
    last_competing: Option<(usize, Vec<f64>)>,
    /// `odometry.noise_reference`: the recent frames' noise and the angular thresholds as
    /// configured (kept across [`reset`](Self::reset): the noise is the camera's).
    noise: crate::noise::NoiseAdapt,
    scale_observable: bool,
    frame: usize,
    /// Running average of the inlier ratio of estimated frames (`None` before the first).
    inlier_ratio_average: Option<f64>,
    /// The highest inlier share of the recent moving frames, decaying by
    /// [`INLIER_SHARE_PEAK_DECAY`] per frame (the jackknife's trigger).
    inlier_share_peak: Option<f64>,
    /// The motion prior of the next solve: its change-of-motion parts are centred on the
    /// previous frame before each solve (`odometry.rotation_change_sigma`,
    /// `odometry.motion_prior_sigmas`), its soft centre is `soft_center`.
    motion_prior: MotionPrior,
    /// Inverse sigmas of the per-parameter prior (empty: none).
    param_inv_sigma: Vec<f64>,
    /// Inverse sigma of the rotation prior (0: none).
    rotation_inv_sigma: f64,
    /// The previous frame pair was estimated while moving and looked right, so the
    /// change-of-motion prior has a centre. Off on the first frame, after a standstill, after a
    /// frame that held its motion (a prior centred on a guess would pull a sharp turn towards
    /// straight ahead: KITTI 01 turns by 2.5 deg per frame from its first frame) and after a
    /// frame whose inlier ratio fell below `odometry.prior_min_inlier_ratio` of the running
    /// average (a prior centred on a doubtful frame would hold a wrong motion from frame to
    /// frame while the inliers drain slowly: the KITTI 08 trajectory's slow tight turn).
    prior_ready: bool,
    /// `odometry.tilt_hold_sigma`: the running mean of the trusted frames' tilts `(ω_x, ω_y)`
    /// (the frames after which `prior_ready` held; exponential over
    /// [`TILT_HOLD_MEAN_FRAMES`]) and the frames since the last of them (1 on the frame after
    /// it); `None` before any and after a standstill.
    tilt_hold: Option<([f64; 2], usize)>,
    /// `odometry.tilt_hold_stage` `"final"` or `"report"`: this frame's tilt hold (centre,
    /// inverse sigmas), for the final stage's prior ([`Odometry::final_fit`]).
    frame_tilt_hold: Option<(Vec<f64>, Vec<f64>)>,
    /// `odometry.tilt_hold_stage = "report"`: the final stage's refits of this frame with its
    /// tilt hold, each beside the refit without it (the one the frame goes on with).
    held_refits: std::sync::Mutex<Vec<(Vec<f64>, Vec<f64>)>>,
    /// `tilt_hold_stage = "report"`: the previous frame's reported motion where it differs from
    /// the motion the run went on with (its held twin), for the report-only widenings.
    previous_reported: Option<Vec<f64>>,
    /// Consecutive frames, up to the last one, after which `prior_ready` held (estimated,
    /// trusted, no competing motion; `odometry.decide_by_road_trusted_frames`).
    trusted_streak: usize,
    /// The last moving frames' reported tilts `(ω_x, ω_y)` (radians), newest last
    /// (`odometry.decide_by_road_tilt_frames`; empty where `decide_by_road_tilt` is off).
    recent_tilts: std::collections::VecDeque<[f64; 2]>,
    /// The last frames' motions (full parameters, newest last), at most
    /// `odometry.competing_region_continuing_frames`: the references of
    /// `competing_region_continuing`.
    recent_motions: std::collections::VecDeque<Vec<f64>>,
    /// `odometry.road_scale_frames`: the last frames' arc lengths from the road plane
    /// ([`Odometry::road_arc_length`]).
    road_arc_lengths: std::collections::VecDeque<f64>,
    /// `odometry.road_scale_frames`: the road arc lengths rejected in a row by the gate of
    /// [`Odometry::admit_road_arc_length`] (newest last; cleared by an admitted one).
    road_rejected: Vec<f64>,
    /// `odometry.road_scale_frames`: the frame whose road arc length was admitted last.
    road_admitted_frame: usize,
    /// `trust.unconfirmed_scale`: the last admitted road arc length passed the gate only
    /// through its widening for unread frames, and no reading within the plain gate has
    /// followed.
    road_unconfirmed: bool,
    /// Running mean of the soft manifold's prior residuals over the moving frames
    /// (`odometry.soft_prior_centring_frames`; empty if off or the model is hard).
    soft_center: Vec<f64>,
    /// Moving frames that went into `soft_center`.
    soft_count: usize,
    /// The factors `k_i = σ_model / σ_i` of the learnt soft-prior sigmas
    /// (`odometry.soft_prior_sigma_learning`; empty if off or the model is hard; ones until
    /// [`SOFT_SIGMA_MIN_FRAMES`]).
    soft_inv_scale: Vec<f64>,
    /// The recent moving frames' arc lengths and soft-prior innovations `(d_i², v_i)` per
    /// residual, newest last (at most `soft_prior_centring_frames`), see
    /// [`Odometry::soft_prior_sigma`].
    soft_samples: std::collections::VecDeque<(f64, Vec<(f64, f64)>)>,
    /// Moving frames so far (not a standstill, enough matches to solve), and of them those
    /// whose innovations taught the soft prior (pushed to `soft_samples`; not capped): the
    /// learning lag of `odometry.soft_prior_cauchy_taught_share`.
    soft_moving: usize,
    soft_taught: usize,
    /// The displacement jitters `δ_r²` (units of the model's sigma squared times metres
    /// squared) that widen a short step's soft prior ([`arc_widened_inv_scale`]): until the
    /// sigmas are learnt the seed `L²` of `odometry.soft_prior_arc_jitter`
    /// ([`seeded_arc_jitter`]), then the learnt ones of `odometry.soft_prior_arc_learning`
    /// (empty without it).
    soft_arc_jitter: Vec<f64>,
    /// The recent trusted moving frames' data-only estimates of the soft-prior residuals and
    /// their variances `(q_d,r, v_r)`, newest last (at most `odometry.soft_prior_trend_frames`;
    /// empty where it is off): the level that [`trend_shifted_center`] moves the centre to.
    soft_levels: std::collections::VecDeque<Vec<(f64, f64)>>,
    /// This frame's first-stage solution where the final efficient stage replaced it (`None`
    /// otherwise): the soft prior's data view ([`Odometry::soft_data_view`]) needs the solution
    /// whose normal matrix and prior weighting it inverts; the refit weighs the priors in units
    /// of its own noise estimate, so its parameters with the first stage's normal matrix would
    /// understate the data's disagreement with the prior (learnt side slip 1.9 instead of 3.3
    /// in `tests/it/soft_sigma.rs`).
    first_stage: Option<FrameSolution>,
    /// The metric's residual is an angle (radians): `angle_plane`.
    metric_is_angular: bool,
    /// Multi-frame evidence of the motion separation's hypothesis choice (crate::hypotheses).
    hypotheses: crate::hypotheses::HypothesisTracker,
    /// The recent frames' counts of the final stage's learnt parallax cap
    /// (`odometry.final_fit.learnt_parallax_cap`).
    parallax_tally: crate::final_fit::ParallaxTally,
    /// Frames since the last one flagged `weak` by `competing_motions` / `road_score_drop`
    /// (saturating; `usize::MAX` before any): the soft prior's consistency widening waits
    /// [`CONSISTENCY_QUIET_FRAMES`] after one.
    since_competing: usize,
    /// The final stage metric's per-match constants of the current frame's (deduplicated)
    /// matches ([`crate::final_fit::frame_constants`]), once computed in the frame: the soft
    /// prior's conflict test on the stage's support and the stage itself read the same ones
    /// (issue 19: a function of the camera and the match alone, so bit for bit those each would
    /// compute). Cleared at the start of every frame.
    frame_constants: Option<Vec<f64>>,
    /// The final stage's support last found in the current frame on all its (deduplicated)
    /// matches ([`crate::final_fit::support_at`], by the soft prior's conflict test on the
    /// support): the stage reuses it where it starts from the same parameters. Cleared at the
    /// start of every frame.
    frame_stage: Option<crate::final_fit::StageSupport>,
    /// The residual-clustering trigger of the jackknife (`trust.clustering_z`).
    clustering: trust::ClusteringTrigger,
    /// The previous moving frame's covariance before any competing or alternative motion was
    /// added (its frame number, free parameters and the matrix): the floor of the next frame's
    /// (`trust.covariance_memory`).
    covariance_memory: Option<(usize, Vec<usize>, nalgebra::DMatrix<f64>)>,
    /// The report grids' jackknife covariances of the recent moving frames (frame number,
    /// free parameters, one per grid of `trust.report_grids`), newest last: the pool of
    /// `trust.report_pool_frames`.
    report_pool: std::collections::VecDeque<ReportJackknife>,
    /// The solver of the jackknife's undefined cells' full solves where
    /// `trust.jackknife_undefined_max_iterations`, `..._function_tolerance` or
    /// `..._max_step_extrapolation` change it ([`trust::undefined_cell_solver`]).
    undefined_solver: Option<Box<dyn momo_core::Solver>>,
    /// Consecutive moving frames whose separation kept no competing alternative (the
    /// quiet-frame fast path, `odometry.quiet_frames`).
    quiet_streak: usize,
    /// Frames whose separation took the quiet-frame fast path ([`Odometry::quiet_frames_taken`]).
    quiet_taken: usize,
    /// Frames re-solved from the previous motion and frames that took that solution
    /// (`odometry.previous_basin_change`).
    previous_basin_counts: (usize, usize),
    /// The last frame where the previous motion's basin was taken
    /// (`odometry.previous_basin_mono_next_votes`).
    previous_basin_taken_frame: Option<usize>,
    /// Frames where `odometry.competing_regions` voted, and where it took the competing motion.
    competing_region_counts: (usize, usize),
}

impl Odometry {
    /// A driver for a rig and a configuration.
    pub fn new(rig: Rig, config: Config) -> Result<Self, VoError> {
        config.validate_for_rig(&rig)?;
        let estimator = config.model.build(config.metric.as_ref())?;
        let final_estimator = match config
            .odometry
            .final_fit
            .resolved_metric_spec_for_rig(config.metric.as_ref(), &rig)
        {
            Ok(Some(m)) => Some(config.model.build(m.as_ref())?),
            Ok(None) => None,
            Err(reason) => {
                return Err(VoError::Config(ConfigError::Invalid {
                    path: config.source_name().into(),
                    reason,
                }));
            }
        };
        let undefined_solver = trust::undefined_cell_solver(config.solver.as_ref(), &config.trust);
        let observable = estimator.observable(&rig);
        let scale_observable = estimator.arc_length_index().is_some_and(|i| observable[i]);
        let previous = estimator.initial_params(config.odometry.initial_arc_length);
        let names = estimator.param_names();
        let mut inv_sigma = vec![0.0; names.len()];
        for (name, sigma) in &config.odometry.motion_prior_sigmas {
            let Some(i) = names.iter().position(|n| n == name) else {
                return Err(VoError::Config(ConfigError::Invalid {
                    path: config.source_name().into(),
                    reason: format!(
                        "odometry.motion_prior_sigmas: the model has no parameter `{name}` \
                         (it has {})",
                        names.join(", ")
                    ),
                }));
            };
            inv_sigma[i] = 1.0 / sigma;
        }
        let config_metric_is_angular = serde_json::to_value(&config.metric)
            .ok()
            .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(str::to_string))
            .is_some_and(|t| t == "angle_plane" || t == "angle_plane_ml");
        let has_params = inv_sigma.iter().any(|w| *w != 0.0);
        let sigma_w = config.odometry.rotation_change_sigma;
        let loss_scale = config.loss.scale();
        let soft_center = if config.odometry.soft_prior_centring_frames > 0 {
            estimator.prior_residuals(&previous)
        } else {
            Vec::new()
        };
        let soft_inv_scale = if config.odometry.soft_prior_sigma_learning {
            vec![1.0; soft_center.len()]
        } else {
            Vec::new()
        };
        let soft_arc_jitter = seeded_arc_jitter(&config.odometry, soft_inv_scale.len());
        let noise = crate::noise::NoiseAdapt::new(&config);
        Ok(Self {
            rig,
            config,
            estimator,
            final_estimator,
            previous,
            last_arc_length: None,
            after_standstill: false,
            after_flag: false,
            previous_yaw: None,
            side_slip_centre: (0.0, 0),
            side_slip_hold_left: 0,
            start_confirmed: false,
            start_settled: false,
            start_clean: 0,
            start_clean_distance: 0.0,
            start_contested: false,
            separation_settled: false,
            previous_omega: None,
            support_change_fired: false,
            contested_yaw: trust::ContestedYaw::default(),
            last_competing: None,
            noise,
            scale_observable,
            frame: 0,
            inlier_ratio_average: None,
            inlier_share_peak: None,
            motion_prior: MotionPrior {
                scale: loss_scale,
                ..MotionPrior::default()
            },
            param_inv_sigma: if has_params { inv_sigma } else { Vec::new() },
            rotation_inv_sigma: if sigma_w > 0.0 { 1.0 / sigma_w } else { 0.0 },
            prior_ready: false,
            tilt_hold: None,
            frame_tilt_hold: None,
            held_refits: std::sync::Mutex::new(Vec::new()),
            previous_reported: None,
            trusted_streak: 0,
            recent_tilts: std::collections::VecDeque::new(),
            recent_motions: std::collections::VecDeque::new(),
            road_arc_lengths: std::collections::VecDeque::new(),
            road_rejected: Vec::new(),
            road_admitted_frame: 0,
            road_unconfirmed: false,
            soft_center,
            soft_count: 0,
            soft_inv_scale,
            soft_samples: Default::default(),
            soft_moving: 0,
            soft_taught: 0,
            soft_arc_jitter,
            soft_levels: Default::default(),
            first_stage: None,
            metric_is_angular: config_metric_is_angular,
            hypotheses: Default::default(),
            parallax_tally: Default::default(),
            since_competing: usize::MAX,
            frame_constants: None,
            frame_stage: None,
            clustering: Default::default(),
            covariance_memory: None,
            report_pool: Default::default(),
            undefined_solver,
            quiet_streak: 0,
            quiet_taken: 0,
            previous_basin_counts: (0, 0),
            previous_basin_taken_frame: None,
            competing_region_counts: (0, 0),
        })
    }

    /// The running mean of the soft manifold's prior residuals (the centre of its prior; empty
    /// unless `odometry.soft_prior_centring_frames` is on and the model is soft). For
    /// `soft_single_track`: the mean side slip and climb in units of their sigmas.
    pub fn soft_prior_center(&self) -> &[f64] {
        &self.soft_center
    }

    /// The soft manifold's prior standard deviations in use, in units of the model's
    /// (`soft_single_track`: side slip, climb): learnt from the data with
    /// `odometry.soft_prior_sigma_learning` (empirical Bayes), else empty.
    ///
    /// In a linear-Gaussian model with a prior `N(c, σ²)` on a function `q` of the
    /// parameters, the estimate `q̂` lies between the data's own `q_d` (variance `v_d`) and
    /// `c`: the cost's stationarity gives `q_d = q̂ + J_q H_d⁻¹ J_qᵀ s² k² (q̂ − c)`, with `H_d`
    /// the normal matrix without the soft prior (the cost's units, `½ Σ r² + ½ s² Σ k² (q − c)²`,
    /// `s` the prior's unit, `k = 1/σ`) and `J_q = ∂q/∂p`; `v_d = J_q Σ_d J_qᵀ` with `Σ_d` the
    /// calibrated covariance without the soft prior ([`trust::calibrated_covariance`]).
    /// Each frame's innovation `d = q_d − c` then has `E[d²] = σ_true² + v_d`. Over the recent
    /// trusted moving frames (those that centre the prior, at least
    /// [`SOFT_SIGMA_MIN_FRAMES`]), `σ_true²` is the robust (median) solution of
    /// `median_j d_j² / (σ_true² + v_j) = χ²₁ median` (frames where an object pulls the data
    /// do not inflate it), and `σ = clamp(f · σ_true, 1, odometry.soft_prior_sigma_max)` with
    /// `f = odometry.soft_prior_sigma_factor`.
    pub fn soft_prior_sigma(&self) -> Vec<f64> {
        self.soft_inv_scale.iter().map(|k| 1.0 / k).collect()
    }

    /// The soft prior's factors of the current frame: the learnt ones
    /// ([`Odometry::soft_prior_sigma`]), times `√w` where the Student-t prior reweighted them
    /// (`odometry.soft_prior_student_nu`).
    fn frame_soft_inv_scale(&self) -> &[f64] {
        if self.motion_prior.soft_inv_scale.len() == self.soft_inv_scale.len() {
            &self.motion_prior.soft_inv_scale
        } else {
            &self.soft_inv_scale
        }
    }

    /// The Student-t soft prior (`odometry.soft_prior_student_nu`): iteratively reweighted,
    /// `k_r √w_r` with `w_r = 1 / (1 + (k_r (q̂_r − c_r))² / ν)` at the solution, solved again
    /// from it while some factor changes by more than 5 % (at most 3 times). Only once the
    /// sigmas are learnt (before, the model's sigma is a guess, not a scale).
    fn student_soft_prior(
        &mut self,
        obs: &FrameObservations,
        sol: FrameSolution,
        fixed: &[bool],
    ) -> FrameSolution {
        let nu = self.config.odometry.soft_prior_student_nu;
        if !(nu > 0.0)
            || self.soft_inv_scale.is_empty()
            || self.soft_samples.len() < SOFT_SIGMA_MIN_FRAMES
        {
            return sol;
        }
        let mut sol = sol;
        for _ in 0..3 {
            let q = self.estimator.prior_residuals(&sol.params);
            if q.len() != self.soft_inv_scale.len() {
                return sol;
            }
            let c = &self.motion_prior.soft_center;
            let target: Vec<f64> = self
                .soft_inv_scale
                .iter()
                .enumerate()
                .map(|(r, k)| {
                    let z = k * (q[r] - c.get(r).copied().unwrap_or(0.0));
                    k * (1.0 / (1.0 + z * z / nu)).sqrt()
                })
                .collect();
            let current = self.frame_soft_inv_scale().to_vec();
            let changed = target
                .iter()
                .zip(&current)
                .any(|(t, c)| (t - c).abs() > 0.05 * c.abs());
            if !changed || target.iter().any(|t| !t.is_finite()) {
                return sol;
            }
            match self.solve_with_soft_inv_scale(obs, &sol.params, fixed, target, current) {
                Some(s2) => sol = s2,
                None => return sol,
            }
        }
        sol
    }

    /// The frame solved again from `params` with the soft prior's factors `target`; where that
    /// solve fails, the factors go back to `current` and `None` is returned (the re-solves of
    /// [`Odometry::student_soft_prior`] and [`Odometry::conflict_widened_soft_prior`]).
    fn solve_with_soft_inv_scale(
        &mut self,
        obs: &FrameObservations,
        params: &[f64],
        fixed: &[bool],
        target: Vec<f64>,
        current: Vec<f64>,
    ) -> Option<FrameSolution> {
        self.motion_prior.soft_inv_scale = target;
        let sol = self.solve_once(obs, params, fixed, false);
        if sol.is_none() {
            self.motion_prior.soft_inv_scale = current;
        }
        sol
    }

    /// The soft prior widened by the frame's own prior-data conflict
    /// (`odometry.soft_prior_conflict_widening = T`): from the data's view of the solution
    /// ([`Odometry::soft_data_view`]: innovation `d_r = q_d,r − c_r`, data variance `v_r`),
    /// each residual with `d_r² / (σ_r² + v_r) > T` (`σ_r = 1 / k_r` the frame's width) gets
    /// `σ_r'² = d_r² − v_r`, the maximum of the one-sample marginal likelihood
    /// `N(d_r; 0, σ² + v_r)` over `σ²`, and the frame is solved again from its solution; at
    /// most twice (the view moves with the solution). Only the residuals listed in
    /// `odometry.soft_prior_conflict_residuals` (all where empty). Unchanged where the data
    /// agree with the prior, the model has no soft prior, or the option is off. With
    /// `odometry.soft_prior_conflict_on_support` the view is that of the frame solved on the
    /// final stage's support only ([`Odometry::support_solution`]).
    fn conflict_widened_soft_prior(
        &mut self,
        obs: &FrameObservations,
        sol: FrameSolution,
        fixed: &[bool],
    ) -> FrameSolution {
        let limit = self.config.odometry.soft_prior_conflict_widening;
        if !(limit > 0.0)
            || self.soft_inv_scale.is_empty()
            || (self.config.odometry.soft_prior_conflict_after_trusted && !self.prior_ready)
        {
            return sol;
        }
        let only = self.config.odometry.soft_prior_conflict_residuals.clone();
        let on_support = self.config.odometry.soft_prior_conflict_on_support;
        let mut sol = sol;
        for _ in 0..2 {
            let tested = if on_support {
                self.compute_frame_constants(obs, &sol.params, fixed);
                let (solved, stage) = self.support_solution(obs, &sol, fixed);
                self.frame_stage = Some(stage);
                match solved {
                    Some(s) => s,
                    None => return sol,
                }
            } else {
                sol.clone()
            };
            let Some(view) = self.soft_data_view(&tested).filter(|v| v.centred) else {
                return sol;
            };
            let current = self.frame_soft_inv_scale().to_vec();
            let mut changed = false;
            let target: Vec<f64> = current
                .iter()
                .enumerate()
                .map(|(r, &k)| {
                    let (d2, v) = ((view.q_d[r] - view.c[r]).powi(2), view.v[(r, r)].max(0.0));
                    let sigma2 = 1.0 / (k * k);
                    let widened = d2 - v;
                    let chosen = only.is_empty() || only.contains(&r);
                    if chosen
                        && d2 / (sigma2 + v) > limit
                        && widened > sigma2
                        && widened.is_finite()
                    {
                        changed = true;
                        1.0 / widened.sqrt()
                    } else {
                        k
                    }
                })
                .collect();
            if !changed || target.iter().any(|t| !(t.is_finite() && *t > 0.0)) {
                return sol;
            }
            match self.solve_with_soft_inv_scale(obs, &sol.params, fixed, target, current) {
                Some(s2) => sol = s2,
                None => return sol,
            }
        }
        sol
    }

    /// The frame solved from `sol` on the matches of the final stage's support at `sol`
    /// ([`crate::final_fit::support`]: within `inlier_sigmas · σ̂`, in front of both cameras,
    /// under the parallax cap), with the first stage's loss and the frame's priors: the data
    /// of the soft prior's conflict test without the mismatches and a moving object's matches
    /// that the first stage's robust loss only down-weights. `None` where the stage would not
    /// refit or the solve fails.
    /// Also the support found, for the final stage ([`Odometry::frame_stage`]).
    fn support_solution(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
    ) -> (Option<FrameSolution>, crate::final_fit::StageSupport) {
        let mut ctx = self.final_fit_context(fixed, false);
        ctx.constants = self.frame_constants.as_deref();
        let stage =
            crate::final_fit::support_at(&ctx, &self.config.odometry.final_fit, obs, &sol.params);
        let solved = stage
            .core()
            .and_then(|core| self.solve_once(core, &sol.params, fixed, false));
        (solved, stage)
    }

    /// Computes [`Odometry::frame_constants`] of the frame's matches `obs` unless the frame
    /// already has them (`from` and `fixed`: the request's parameters, which the constants do
    /// not depend on).
    fn compute_frame_constants(&mut self, obs: &FrameObservations, from: &[f64], fixed: &[bool]) {
        if self.frame_constants.is_none() {
            let ctx = self.final_fit_context(fixed, false);
            let constants = crate::final_fit::frame_constants(&ctx, obs, from);
            self.frame_constants = Some(constants);
        }
    }

    /// The final stage's estimator (the model's own where the stage has no metric of its own).
    fn final_fit_estimator(&self) -> &dyn FrameEstimator {
        self.final_estimator
            .as_deref()
            .unwrap_or(self.estimator.as_ref())
    }

    /// The final efficient stage's context: the final stage's estimator (the model's own where
    /// the stage has no metric of its own), the frame's loss, solver and motion prior.
    fn final_fit_context<'a>(
        &'a self,
        fixed: &'a [bool],
        competing: bool,
    ) -> crate::final_fit::FinalFitContext<'a> {
        crate::final_fit::FinalFitContext {
            rig: &self.rig,
            estimator: self
                .final_estimator
                .as_deref()
                .unwrap_or(self.estimator.as_ref()),
            loss: self.config.loss.as_ref(),
            solver: self.config.solver.as_ref(),
            fixed,
            motion_prior: &self.motion_prior,
            competing,
            constants: None,
            stage: None,
            tally: (self.config.odometry.final_fit.learnt_parallax_cap > 0.0
                || self.config.odometry.final_fit.learnt_cauchy_max > 0.0
                || self.config.odometry.final_fit.learnt_least_squares_share > 0.0)
                .then_some(&self.parallax_tally),
        }
    }

    /// `odometry.final_fit.guard_tilt`: whether the neighbourhood guard keeps the reduced stage
    /// (rotation `reduced`) over the given matches' stage (rotation `given`), against the
    /// trusted frames' running mean tilt where a trusted frame lies within `tilt_hold_frames`
    /// ([`crate::final_fit::guard_tilt_keeps_reduced`]).
    fn guard_tilt_keeps_reduced(
        &self,
        given: &nalgebra::Matrix3<f64>,
        reduced: &nalgebra::Matrix3<f64>,
    ) -> bool {
        let o = &self.config.odometry;
        let trusted = self
            .tilt_hold
            .filter(|(_, n)| *n <= o.tilt_hold_frames)
            .map(|(t, _)| t);
        crate::final_fit::guard_tilt_keeps_reduced(o.final_fit.guard_tilt, trusted, given, reduced)
    }

    /// `odometry.tilt_hold_sigma`: the per-parameter prior (centre, inverse sigmas; full
    /// vectors) of a frame whose change-of-motion prior has no centre: `rot_x` and `rot_y`
    /// held at the trusted frames' running mean tilt with standard deviation
    /// `tilt_hold_sigma`, at most `tilt_hold_frames` after the last trusted frame; the other
    /// parameters free (inverse sigma 0, centre 0). None where the hold is off, no trusted
    /// frame is recent, or the model has no `rot_x` / `rot_y`.
    fn tilt_hold_prior(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        let o = &self.config.odometry;
        let (tilt, n) = self.tilt_hold?;
        if !(o.tilt_hold_sigma > 0.0) || n > o.tilt_hold_frames {
            return None;
        }
        let names = self.estimator.param_names();
        let ix = names.iter().position(|s| *s == "rot_x")?;
        let iy = names.iter().position(|s| *s == "rot_y")?;
        let mut center = vec![0.0; names.len()];
        let mut inv_sigma = vec![0.0; names.len()];
        let w = 1.0 / o.tilt_hold_sigma;
        for (i, t) in [(ix, tilt[0]), (iy, tilt[1])] {
            *center.get_mut(i)? = t;
            *inv_sigma.get_mut(i)? = w;
        }
        Some((center, inv_sigma))
    }

    /// The soft prior's residuals at `params` and their Jacobian over the free parameters
    /// `free` (central differences; units of the model's sigmas).
    fn soft_jacobian(&self, params: &[f64], free: &[usize]) -> (Vec<f64>, nalgebra::DMatrix<f64>) {
        let q0 = self.estimator.prior_residuals(params);
        let mut jq = nalgebra::DMatrix::zeros(q0.len(), free.len());
        for (a, &f) in free.iter().enumerate() {
            let h = 1e-6 * (1.0 + params[f].abs());
            let (mut p, mut m) = (params.to_vec(), params.to_vec());
            p[f] += h;
            m[f] -= h;
            let (qp, qm) = (
                self.estimator.prior_residuals(&p),
                self.estimator.prior_residuals(&m),
            );
            for r in 0..q0.len() {
                jq[(r, a)] = (qp[r] - qm[r]) / (2.0 * h);
            }
        }
        (q0, jq)
    }

    /// `Jᵀ K² J` of the soft prior at the current factors `K` ([`Odometry::soft_prior_sigma`]).
    fn soft_information(&self, jq: &nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64> {
        let mut kj = jq.clone();
        for (r, k) in self
            .frame_soft_inv_scale()
            .iter()
            .enumerate()
            .take(kj.nrows())
        {
            kj.row_mut(r).scale_mut(*k);
        }
        kj.transpose() * kj
    }

    /// The prior's unit `s` and the soft prior's residuals `q̂` with their Jacobian over the
    /// free parameters at the solution; `None` without a prior unit or a soft prior.
    fn soft_prior_terms(
        &self,
        sol: &FrameSolution,
    ) -> Option<(f64, Vec<f64>, nalgebra::DMatrix<f64>)> {
        let s = self.motion_prior.scale;
        if !(s.is_finite() && s > 0.0) {
            return None;
        }
        let (q, jq) = self.soft_jacobian(&sol.params, &sol.free);
        (!q.is_empty()).then_some((s, q, jq))
    }

    /// The data's own view of the soft prior's residuals at the solution
    /// ([`Odometry::soft_prior_sigma`] has the notation): the residuals `q̂`, the centre `c`
    /// (zeros where the motion prior has none of their length) and whether it was the motion
    /// prior's, the shift `b = H_d⁻¹ J_qᵀ s² K² (q̂ − c)` of the free parameters that the prior
    /// causes, `q_d = q̂ + J_q b` and the data's covariance of `q`, `J_q Σ_d J_qᵀ`. `None` for a
    /// model without a soft prior, without a prior unit, or without a calibrated covariance.
    fn soft_data_view(&self, sol: &FrameSolution) -> Option<SoftDataView> {
        let (s, q, jq) = self.soft_prior_terms(sol)?;
        let centred = self.motion_prior.soft_center.len() == q.len();
        let c = if centred {
            self.motion_prior.soft_center.clone()
        } else {
            vec![0.0; q.len()]
        };
        let mut inp = self.covariance_inputs(sol);
        inp.normal -= self.soft_information(&jq) * (s * s);
        let h_d = (&inp.normal + inp.normal.transpose()) * 0.5;
        let a = trust::invert_information(&h_d);
        let (info, _) = trust::calibrated_information(&inp)?;
        let cov_d = trust::invert_information(&info);
        let k = |r: usize| self.frame_soft_inv_scale().get(r).copied().unwrap_or(1.0);
        let pull: nalgebra::DVector<f64> = nalgebra::DVector::from_iterator(
            q.len(),
            (0..q.len()).map(|r| s * s * k(r) * k(r) * (q[r] - c[r])),
        );
        let shift = &a * (jq.transpose() * pull);
        let q_d = nalgebra::DVector::from_column_slice(&q) + &jq * &shift;
        let v = &jq * cov_d * jq.transpose();
        Some(SoftDataView {
            c,
            centred,
            shift,
            q_d,
            v,
        })
    }

    /// This frame's soft-prior innovations `(d_i², v_i)` ([`Odometry::soft_prior_sigma`]), if
    /// the data determine every residual. `view`: the frame's data view of `sol`, computed
    /// here if no one has yet ([`SoftView`]).
    fn soft_innovation(&self, sol: &FrameSolution, view: &SoftView) -> Option<Vec<(f64, f64)>> {
        let view = view
            .get_or_init(|| self.soft_data_view(sol))
            .as_ref()
            .filter(|v| v.centred)?;
        let out: Vec<(f64, f64)> = (0..view.c.len())
            .map(|r| ((view.q_d[r] - view.c[r]).powi(2), view.v[(r, r)]))
            .collect();
        out.iter()
            .all(|(d2, v)| d2.is_finite() && v.is_finite() && *v >= 0.0)
            .then_some(out)
    }

    /// This frame's data-only estimates of the soft-prior residuals and their variances
    /// `(q_d,r, v_r)` ([`Odometry::soft_prior_sigma`] has the notation), if the data determine
    /// every residual: the samples of `odometry.soft_prior_trend_frames`
    /// ([`trend_shifted_center`]). `view` as in [`Odometry::soft_innovation`].
    fn soft_level(&self, sol: &FrameSolution, view: &SoftView) -> Option<Vec<(f64, f64)>> {
        let view = view
            .get_or_init(|| self.soft_data_view(sol))
            .as_ref()
            .filter(|v| v.centred)?;
        let out: Vec<(f64, f64)> = (0..view.c.len())
            .map(|r| (view.q_d[r], view.v[(r, r)]))
            .collect();
        out.iter()
            .all(|(q, v)| q.is_finite() && v.is_finite() && *v >= 0.0)
            .then_some(out)
    }

    /// The shift `b` of the free parameters that the soft prior causes
    /// ([`Odometry::soft_prior_sigma`] has the notation), if some prior residual's innovation
    /// exceeds `trust.prior_conflict_chi2`: `d_r² / (σ_r² + v_r)` with `σ_r` the prior's
    /// standard deviation in use and `v_r` the data's variance of `q_r`. `None` where the data
    /// agree with the prior, the model has no soft prior, or the check is off.
    ///
    /// Where the final stage replaced the first stage's solution (`first_stage`), the view is
    /// the first stage's and the shift is that of the final estimate from the data's own
    /// estimate `p̂₁ + b₁`: `b = b₁ + p̂₁ − p̂`.
    ///
    /// `shared`: the frame's data view of `first_stage` (else of `sol`), computed here if no one
    /// has yet ([`SoftView`]); used where the view is of that solution.
    fn prior_conflict_shift(
        &self,
        sol: &FrameSolution,
        shared: Option<&SoftView>,
    ) -> Option<nalgebra::DVector<f64>> {
        let limit = self.config.trust.prior_conflict_chi2;
        if !(limit > 0.0) {
            return None;
        }
        let first = self.first_stage.as_ref().filter(|f| f.free == sol.free);
        let at = first.unwrap_or(sol);
        let own;
        let view = match shared.filter(|_| first.is_some() || self.first_stage.is_none()) {
            Some(cell) => cell.get_or_init(|| self.soft_data_view(at)).as_ref()?,
            None => {
                own = self.soft_data_view(at)?;
                &own
            }
        };
        let mut shift = view.shift.clone();
        if let Some(f) = first {
            for (j, &i) in sol.free.iter().enumerate().take(shift.len()) {
                shift[j] += f.params[i] - sol.params[i];
            }
        }
        let k = |r: usize| self.soft_inv_scale.get(r).copied().unwrap_or(1.0);
        let conflict = (0..view.c.len()).any(|r| {
            let sigma = 1.0 / k(r);
            let z = (view.q_d[r] - view.c[r]).powi(2) / (sigma * sigma + view.v[(r, r)].max(0.0));
            z.is_finite() && z > limit
        });
        (conflict && shift.iter().all(|v| v.is_finite())).then_some(shift)
    }

    /// The mean-square spread `τ_r²(s)` of each soft-prior residual around its centre at arc
    /// length `s` ([`Odometry::soft_prior_sigma`] has the notation; units of the model's
    /// sigmas): the least-squares fit `d_j² − v_j ≈ a_r + b_r / s_j²` (`a_r, b_r ≥ 0`) over the
    /// recent trusted moving frames, evaluated at `s` (`b_r` holds a sideways / vertical
    /// *displacement* jitter, whose angle grows as the step shortens: the KITTI ground truth's
    /// slow frames). `None` before [`SOFT_SIGMA_MIN_FRAMES`] frames.
    fn soft_prior_spread(&self, arc: f64) -> Option<Vec<f64>> {
        if self.soft_samples.len() < SOFT_SIGMA_MIN_FRAMES {
            return None;
        }
        let n = self.soft_inv_scale.len();
        let tau2: Vec<f64> = (0..n)
            .map(|r| {
                let pts: Vec<(f64, f64)> = self
                    .soft_samples
                    .iter()
                    .filter_map(|(s, f)| {
                        let (d2, v) = f.get(r)?;
                        let x = if self.config.trust.prior_spread_arc && *s > 0.0 {
                            1.0 / (s * s)
                        } else {
                            0.0
                        };
                        Some((x, d2 - v))
                    })
                    .collect();
                let (a, b) = nonnegative_line_fit(&pts);
                let x = if self.config.trust.prior_spread_arc && arc > 0.0 {
                    1.0 / (arc * arc)
                } else {
                    0.0
                };
                (a + b * x).max(0.0)
            })
            .collect();
        tau2.iter().all(|t| t.is_finite()).then_some(tau2)
    }

    /// With `trust.prior_spread_covariance`, before the soft prior's spread is learnt (fewer
    /// than [`SOFT_SIGMA_MIN_FRAMES`] trusted moving frames): the calibrated covariance without
    /// the soft prior's information (the width the estimate uses is the model's guess, not yet
    /// the data's). `None` otherwise.
    fn unlearnt_prior_covariance(
        &self,
        sol: &FrameSolution,
        adjust: &dyn Fn(&mut trust::CovarianceInputs),
    ) -> Option<nalgebra::DMatrix<f64>> {
        if !self.config.trust.prior_spread_covariance
            || self.soft_inv_scale.is_empty()
            || self.soft_samples.len() >= SOFT_SIGMA_MIN_FRAMES
        {
            return None;
        }
        let (s, _, jq) = self.soft_prior_terms(sol)?;
        let mut inp = self.covariance_inputs(sol);
        adjust(&mut inp);
        inp.normal -= self.soft_information(&jq) * (s * s);
        trust::calibrated_covariance(&inp)
    }

    /// The covariance the reported one adds where the soft prior's true spread exceeds the
    /// width the estimate uses (`trust.prior_spread_covariance`): the estimate's error holds
    /// `Σ Σ_r λ_r j_rᵀ (c_r − q_r)`, so with `E[(q_r − c_r)²] = τ_r²`
    /// ([`Odometry::soft_prior_spread`]) its covariance is
    /// `Σ (I_d + Σ_r λ_r² τ_r² j_rᵀ j_r) Σ = Σ + Σ_r (λ_r² τ_r² − λ_r) u_r u_rᵀ`, with
    /// `Σ` the calibrated posterior covariance (`Σ⁻¹ = I_d + Σ_r λ_r j_rᵀ j_r`),
    /// `λ_r = s² k_r² / σ̂²` the prior's weight in that information (`σ̂²` the residual variance
    /// of [`trust::calibrated_information`]), `j_r = ∂q_r/∂p` and `u_r = Σ j_rᵀ`. Only the
    /// residuals with `λ_r τ_r² > 1` add. `None` if off, not learnt yet, or not defined.
    fn prior_spread_widening(&self, sol: &FrameSolution) -> Option<nalgebra::DMatrix<f64>> {
        if !self.config.trust.prior_spread_covariance || self.soft_inv_scale.is_empty() {
            return None;
        }
        let arc = self
            .estimator
            .arc_length_index()
            .map_or(f64::NAN, |i| sol.params[i].abs());
        let tau2 = self.soft_prior_spread(arc)?;
        let s = self.motion_prior.scale;
        if !(s.is_finite() && s > 0.0) {
            return None;
        }
        let (q, jq) = self.soft_jacobian(&sol.params, &sol.free);
        if q.len() != tau2.len() {
            return None;
        }
        let (info, sigma2) = trust::calibrated_information(&self.covariance_inputs(sol))?;
        let cov = trust::invert_information(&info);
        if cov.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let n = cov.nrows();
        let mut extra = nalgebra::DMatrix::zeros(n, n);
        for (r, t2) in tau2.iter().enumerate() {
            let k = self.frame_soft_inv_scale()[r];
            let lambda = s * s * k * k / sigma2;
            let excess = lambda * lambda * t2 - lambda;
            if excess > 0.0 && excess.is_finite() {
                let u = &cov * jq.row(r).transpose();
                extra += &u * u.transpose() * excess;
            }
        }
        Some(extra)
    }

    /// Re-learns the soft prior's factors from the recent innovations
    /// ([`Odometry::soft_prior_sigma`]).
    fn learn_soft_sigma(&mut self) {
        let max = self.config.odometry.soft_prior_sigma_max.max(1.0);
        let factor = self.config.odometry.soft_prior_sigma_factor;
        if self.soft_samples.len() < SOFT_SIGMA_MIN_FRAMES || !(factor > 0.0) {
            return;
        }
        let arc_learning = self.config.odometry.soft_prior_arc_learning;
        if arc_learning {
            self.soft_arc_jitter = vec![0.0; self.soft_inv_scale.len()];
        } else {
            // The seed (`soft_prior_arc_jitter`) holds until the sigmas are learnt.
            self.soft_arc_jitter.clear();
        }
        for (r, k) in self.soft_inv_scale.iter_mut().enumerate() {
            // With `soft_prior_arc_learning`: the jitter `δ_r²`, the slope of `d² − v` over
            // `1 / s²`; its share `δ_r² / s²` then adds to each frame's `v`.
            let jitter = if arc_learning {
                let pts: Vec<(f64, f64)> = self
                    .soft_samples
                    .iter()
                    .filter(|(s, _)| s.is_finite() && *s > 0.0)
                    .filter_map(|(s, f)| f.get(r).map(|(d2, v)| (1.0 / (s * s), d2 - v)))
                    .collect();
                let (_, b) = nonnegative_line_fit(&pts);
                if b.is_finite() { b } else { 0.0 }
            } else {
                0.0
            };
            if let Some(j) = self.soft_arc_jitter.get_mut(r) {
                *j = jitter;
            }
            let samples: Vec<(f64, f64)> = self
                .soft_samples
                .iter()
                .filter_map(|(s, f)| {
                    f.get(r).map(|(d2, v)| {
                        let extra = if jitter > 0.0 && s.is_finite() && *s > 0.0 {
                            jitter / (s * s)
                        } else {
                            0.0
                        };
                        (*d2, v + extra)
                    })
                })
                .collect();
            // median_j d_j² / (σ² + v_j), decreasing in σ².
            let median_ratio = |s2: f64| {
                let mut z: Vec<f64> = samples.iter().map(|(d2, v)| d2 / (s2 + v)).collect();
                z.sort_by(f64::total_cmp);
                z.get(z.len() / 2).copied().unwrap_or(0.0)
            };
            // σ_true² within [1, max²] / f².
            let (mut lo, mut hi) = (1.0 / (factor * factor), max * max / (factor * factor));
            let s2 = if median_ratio(lo) <= CHI2_1_MEDIAN {
                lo
            } else if median_ratio(hi) >= CHI2_1_MEDIAN {
                hi
            } else {
                for _ in 0..40 {
                    let mid = (lo * hi).sqrt();
                    if median_ratio(mid) > CHI2_1_MEDIAN {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                (lo * hi).sqrt()
            };
            *k = 1.0 / (factor * s2.sqrt()).clamp(1.0, max);
        }
    }

    /// The rig.
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The type-erased estimator (model and metric).
    pub fn estimator(&self) -> &dyn FrameEstimator {
        self.estimator.as_ref()
    }

    /// Whether the rig lets the arc length be estimated without odometry.
    pub fn scale_observable(&self) -> bool {
        self.scale_observable
    }

    /// The parameters of the previous frame (the warm start of the next).
    pub fn previous_params(&self) -> &[f64] {
        &self.previous
    }

    /// The factor the angular thresholds are scaled by for the run's noise
    /// (`odometry.noise_reference`, [`crate::noise`]): 1 at or below the reference noise.
    pub fn noise_scale(&self) -> f64 {
        self.noise.scale()
    }

    /// Forgets every frame seen: the driver is as [`Odometry::new`] left it, except that the
    /// next frame starts from `previous` (a full parameter vector of the model) when given and
    /// of the right length, and that the noise learnt for `odometry.noise_reference` (the
    /// camera's, not the run's) and the thresholds scaled to it stay. No change-of-motion prior
    /// is active for that frame (it has no estimated predecessor). Used by [`crate::batch`] to
    /// estimate independent frame pairs.
    pub fn reset(&mut self, previous: Option<&[f64]>) {
        let n = self.estimator.param_names().len();
        self.previous = match previous {
            Some(p) if p.len() == n => p.to_vec(),
            _ => self
                .estimator
                .initial_params(self.config.odometry.initial_arc_length),
        };
        self.last_arc_length = None;
        self.after_standstill = false;
        self.after_flag = false;
        self.previous_yaw = None;
        self.side_slip_centre = (0.0, 0);
        self.side_slip_hold_left = 0;
        self.start_confirmed = false;
        self.start_settled = false;
        self.start_clean = 0;
        self.start_clean_distance = 0.0;
        self.start_contested = false;
        self.separation_settled = false;
        self.previous_omega = None;
        self.support_change_fired = false;
        self.contested_yaw = trust::ContestedYaw::default();
        self.last_competing = None;
        self.frame = 0;
        self.inlier_ratio_average = None;
        self.inlier_share_peak = None;
        self.prior_ready = false;
        self.tilt_hold = None;
        self.frame_tilt_hold = None;
        if let Ok(refits) = self.held_refits.get_mut() {
            refits.clear();
        }
        self.previous_reported = None;
        self.trusted_streak = 0;
        self.recent_tilts.clear();
        self.recent_motions.clear();
        self.road_arc_lengths.clear();
        self.road_rejected.clear();
        self.road_admitted_frame = 0;
        self.road_unconfirmed = false;
        self.soft_center = if self.config.odometry.soft_prior_centring_frames > 0 {
            let neutral = self
                .estimator
                .initial_params(self.config.odometry.initial_arc_length);
            self.estimator.prior_residuals(&neutral)
        } else {
            Vec::new()
        };
        self.soft_count = 0;
        self.soft_inv_scale = if self.config.odometry.soft_prior_sigma_learning {
            vec![1.0; self.soft_center.len()]
        } else {
            Vec::new()
        };
        self.soft_samples.clear();
        self.soft_moving = 0;
        self.soft_taught = 0;
        self.soft_levels.clear();
        self.soft_arc_jitter = seeded_arc_jitter(&self.config.odometry, self.soft_inv_scale.len());
        self.hypotheses.reset();
        self.parallax_tally = Default::default();
        self.since_competing = usize::MAX;
        self.frame_constants = None;
        self.frame_stage = None;
        self.clustering = Default::default();
        self.covariance_memory = None;
        self.report_pool.clear();
        self.quiet_streak = 0;
        self.quiet_taken = 0;
        self.previous_basin_counts = (0, 0);
        self.previous_basin_taken_frame = None;
        self.competing_region_counts = (0, 0);
    }

    /// How many frames so far took the separation's quiet-frame fast path
    /// ([`OdometryOptions::quiet_frames`](crate::config::OdometryOptions::quiet_frames)).
    pub fn quiet_frames_taken(&self) -> usize {
        self.quiet_taken
    }

    /// How many frames so far were solved again from the previous frame's motion, and how many
    /// of them took that solution (`odometry.previous_basin_change`).
    pub fn previous_basin_counts(&self) -> (usize, usize) {
        self.previous_basin_counts
    }

    /// Since the last reset: the frames where `odometry.competing_regions` voted (a single
    /// camera with a competing motion) and those where it took the competing motion.
    pub fn competing_region_counts(&self) -> (usize, usize) {
        self.competing_region_counts
    }

    /// Estimates the motion of the next frame pair from its matches and, if known, the arc
    /// length travelled (odometry).
    pub fn process(&mut self, obs: &FrameObservations, arc_length: Option<f64>) -> FrameResult {
        let start = Instant::now();
        // Repeated matches count once.
        let (unique, repeated) = trust::deduped(obs);
        let obs = &*unique;
        self.frame += 1;
        self.frame_constants = None;
        self.frame_stage = None;
        let arc_index = self.estimator.arc_length_index();
        let n_params = self.estimator.param_names().len();
        let arc_length =
            arc_length.filter(|l| l.is_finite() && l.abs() <= crate::config::MAX_ARC_LENGTH);

        let mut init = self.previous.clone();
        let mut fixed = vec![false; n_params];
        // Cross-camera matches measure the arc length (crate::stereo_scale): solve with the
        // last arc length held, then measure it and solve again.
        let cross_scale = arc_length.is_none()
            && arc_index.is_some()
            && self.config.odometry.estimate_scale
            && obs.cross_camera.len() >= crate::stereo_scale::MIN_CROSS_INLIERS;
        // `odometry.road_scale_initial_metric`, before the first road arc length.
        let initial_metric = self.road_scale_on()
            && self.config.odometry.road_scale_initial_metric
            && self.road_arc_lengths.is_empty();
        let scale = match (arc_index, arc_length) {
            (Some(i), Some(l)) => {
                init[i] = l;
                fixed[i] = true;
                ScaleSource::Odometry
            }
            (Some(i), None) if cross_scale => {
                fixed[i] = true;
                ScaleSource::Estimated
            }
            (Some(i), None)
                if self.road_scale_on()
                    && let Some(l) = self.road_held() =>
            {
                // `odometry.road_scale_frames`: the median of the last frames' road arc
                // lengths, held for the solve (until there is one, the arc length is held as
                // metric, `road_scale_initial_metric`, or estimated or held as without the
                // option).
                fixed[i] = true;
                init[i] = l;
                ScaleSource::Road
            }
            (Some(i), None)
                if initial_metric
                    && self.scale_observable
                    && self.config.odometry.estimate_scale =>
            {
                // `odometry.road_scale_initial_metric`: before the first road arc length, the
                // last one held (`initial_arc_length` at the start), as metric.
                fixed[i] = true;
                ScaleSource::Held
            }
            (Some(i), None) => {
                if !self.scale_observable {
                    fixed[i] = true;
                    ScaleSource::Unobservable
                } else if !self.config.odometry.estimate_scale {
                    fixed[i] = true;
                    ScaleSource::Held
                } else {
                    ScaleSource::Estimated
                }
            }
            (None, _) => ScaleSource::Estimated,
        };
        // `odometry.road_scale_metric`: the road's held arc length is the separation's metric
        // arc length, as odometry.csv's is; `road_scale_initial_metric`: so is the arc length
        // held before the first one.
        let metric_arc_length = match (arc_index, scale) {
            (Some(i), ScaleSource::Road) if self.config.odometry.road_scale_metric => Some(init[i]),
            (Some(i), ScaleSource::Held) if initial_metric => Some(init[i]),
            _ => arc_length,
        };
        let standstill = arc_index.is_some_and(|i| {
            init[i].abs() < self.config.odometry.standstill_arc_length && fixed[i]
        });
        if standstill && self.config.odometry.standstill_at_rest {
            // `odometry.standstill_at_rest`: a standing vehicle does not turn.
            init = self.estimator.initial_params(0.0);
        } else if standstill && let Some(i) = arc_index {
            init[i] = 0.0;
        } else if self.after_standstill {
            // Moving off: the held direction of travel is arbitrary (it was not observable at
            // the standstill), and a start that points sideways can settle in a wrong basin
            // that the warm start then carries on (seen on KITTI 00's stops).
            let mut ahead = self
                .estimator
                .initial_params(arc_index.map_or(1.0, |i| init[i]));
            if let Some(i) = arc_index {
                ahead[i] = init[i];
            }
            init = ahead;
        }

        let matches = obs.len();
        let mut diag = FrameDiagnostics {
            frame: self.frame,
            status: FrameStatus::Estimated,
            scale,
            param_names: self
                .estimator
                .param_names()
                .iter()
                .map(|s| s.to_string())
                .collect(),
            params: init.clone(),
            param_sigmas: vec![f64::NAN; n_params],
            covariance: Vec::new(),
            free: Vec::new(),
            initial_cost: f64::NAN,
            final_cost: f64::NAN,
            iterations: 0,
            termination: None,
            matches,
            inliers: 0,
            inliers_per_camera: vec![0; self.rig.len()],
            restarts: 0,
            restart_won: false,
            time_us: 0.0,
            constraint: Constraint::Well,
            reason: None,
            jackknife: false,
            competing: None,
            residual_clustering: f64::NAN,
            road_alternative: None,
            guard_alternative: None,
            noise_scale: self.noise.scale(),
            noise: None,
            support: None,
        };

        {
            // Slow frames see the direction of travel and the yaw only together (a short
            // baseline): their errors are correlated from frame to frame, and a prior centred
            // on the previous one carries them on.
            let fast = arc_index
                .is_none_or(|i| init[i].abs() >= self.config.odometry.prior_min_arc_length);
            let use_prior = self.prior_ready && fast;
            let mut tilt_hold = if use_prior {
                None
            } else {
                self.tilt_hold_prior()
            };
            self.frame_tilt_hold = None;
            if let Ok(refits) = self.held_refits.get_mut() {
                refits.clear();
            }
            if self.config.odometry.tilt_hold_stage != TiltHoldStage::Solves {
                self.frame_tilt_hold = tilt_hold.take();
            }
            let consistency = consistency_acts(self.since_competing, &self.config.odometry);
            let prior = &mut self.motion_prior;
            if use_prior && !self.param_inv_sigma.is_empty() {
                prior.center.clone_from(&init);
                prior.inv_sigma.clone_from(&self.param_inv_sigma);
            } else if let Some((center, inv_sigma)) = tilt_hold {
                prior.center = center;
                prior.inv_sigma = inv_sigma;
            } else {
                prior.center.clear();
                prior.inv_sigma.clear();
            }
            if use_prior && self.rotation_inv_sigma > 0.0 {
                let w = so3_log(&self.estimator.motion(&init).rotation);
                prior.rotation_center = [w.x, w.y, w.z];
                prior.rotation_inv_sigma = self.rotation_inv_sigma;
            } else {
                prior.rotation_inv_sigma = 0.0;
            }
            prior.soft_center.clone_from(&self.soft_center);
            prior.soft_inv_scale.clone_from(&self.soft_inv_scale);
            prior.soft_cauchy = soft_cauchy_scales(
                &self.config.odometry,
                self.estimator.prior_residuals(&init).len(),
                self.soft_samples.len() >= SOFT_SIGMA_MIN_FRAMES,
                (self.soft_moving, self.soft_taught),
                self.rig.len(),
            );
            if let Some(i) = arc_index {
                arc_widened_inv_scale(&mut prior.soft_inv_scale, &self.soft_arc_jitter, init[i]);
            }
            if consistency {
                consistency_widened_inv_scale(
                    &mut prior.soft_inv_scale,
                    &self.soft_samples,
                    &self.config.odometry,
                );
                trend_shifted_center(
                    &mut prior.soft_center,
                    &mut prior.soft_inv_scale,
                    &self.soft_levels,
                    &self.config.odometry,
                );
            }
        }
        let enough = matches >= self.config.odometry.min_matches.max(1);
        let verdict = if !enough && repeated > 0 {
            Some((Constraint::Degenerate, Reason::RepeatedMatches))
        } else if enough && !standstill {
            trust::before_solve(&self.config.trust, &self.rig, obs, true)
        } else {
            None
        };
        if let Some((c, r)) = verdict {
            diag.constraint = c;
            diag.reason = Some(r);
        }
        // A weak frame: the priors yield to its weak but consistent evidence.
        let unit = self.config.loss.scale();
        self.motion_prior.scale = match verdict {
            Some((Constraint::Weak, _)) => unit * self.config.trust.weak_prior_factor,
            _ => unit,
        };
        if verdict.is_some_and(|(_, r)| r == Reason::LittleFlow)
            && let Some(i) = arc_index
            && diag.scale == ScaleSource::Estimated
        {
            // No flow, no direction of travel and no scale: hold the last arc length.
            fixed[i] = true;
            diag.scale = ScaleSource::Held;
        }
        // The matches the standstill's solve read, where it read a subset.
        let mut at_rest_read = None;
        let result = if !enough {
            diag.status = if repeated > 0 {
                FrameStatus::Degenerate
            } else {
                FrameStatus::NoMatches
            };
            None
        } else if diag.constraint == Constraint::Degenerate {
            diag.status = FrameStatus::Degenerate;
            None
        } else {
            let sol = if standstill && self.config.odometry.standstill_at_rest {
                self.solve_at_rest(obs, &init, &fixed, &mut diag)
                    .map(|(sol, read)| {
                        at_rest_read = read;
                        sol
                    })
            } else {
                self.solve_with_restarts(obs, &init, &fixed, standstill, &mut diag)
            };
            let sol = match sol {
                Some(sol) if !standstill => {
                    let sol = self.student_soft_prior(obs, sol, &fixed);
                    Some(self.conflict_widened_soft_prior(obs, sol, &fixed))
                }
                other => other,
            };
            match sol {
                Some(sol) if !standstill => match self.after_solve(obs, &sol) {
                    Some(reason) => {
                        diag.status = FrameStatus::Degenerate;
                        diag.constraint = Constraint::Degenerate;
                        diag.reason = Some(reason);
                        self.fill_diagnostics(
                            obs,
                            &sol,
                            false,
                            (false, false),
                            None,
                            None,
                            None,
                            &mut diag,
                        );
                        None
                    }
                    None => Some(sol),
                },
                other => other,
            }
        };
        // Motion separation (issue 14, crate::separate; competition over time by default).
        // What follows the separation (`separate.final_fit`: the final stage on all matches
        // or on the chosen motion's support).
        let mut next_stage = crate::separate::NextStage::FinalFit;
        // The matches the under-the-road test leaves out of the final stage's
        // (`separate.under_road`, `under_road_rig`), at the separation's chosen motion.
        let mut road_out = None;
        // The chosen motion's road score dropped (`separate.ground_drop`).
        let mut ground_drop = false;
        // Only against `ground_drop_min` scaled to the frame's matches (`trust.road_drop_scaled`).
        let mut ground_drop_scaled = false;
        // Only the road prediction competed and may keep the prior (`predict_by_road_prior`).
        let mut prior_kept = false;
        // A rule replaced a motion that a vehicle pulled away (`SeparationOutcome::pulled`):
        // starts `trust.side_slip_hold`'s hold.
        let mut pulled = false;
        let (result, competing) = match (
            result,
            self.config.odometry.separate.as_ref().filter(|s| s.enabled),
        ) {
            (Some(sol), Some(opts)) if !standstill => {
                let mut starts = vec![init.clone()];
                starts.extend(self.restart_points(&init));
                let ctx = crate::separate::SolveContext {
                    rig: &self.rig,
                    estimator: self.estimator.as_ref(),
                    loss: self.config.loss.as_ref(),
                    solver: self.config.solver.as_ref(),
                    fixed: &fixed,
                    motion_prior: Some(&self.motion_prior),
                };
                // The count thresholds scaled to the frame's matches (`count_reference`).
                let scaled = opts.for_matches(obs.len());
                let opts: &crate::separate::SeparateOptions = &scaled;
                // The quiet-frame fast path (`odometry.quiet_frames`): no alternative solves.
                let quiet_opts;
                let quiet = self.quiet(obs, &sol, opts);
                self.quiet_taken += usize::from(quiet);
                let opts = if quiet {
                    quiet_opts = crate::separate::SeparateOptions {
                        second_motion: false,
                        ..opts.clone()
                    };
                    &quiet_opts
                } else {
                    opts
                };
                let (sol, o, next) = crate::separate::separate(
                    &ctx,
                    opts,
                    obs,
                    sol,
                    &starts,
                    &mut self.hypotheses,
                    metric_arc_length,
                );
                // Guarded (one camera, `under_road_guard`): not before a frame whose
                // separation saw no second motion compete, and with the neighbourhood test
                // under `neighbour_guard`; else the stage is handed the matches without them.
                let guarded = self.rig.len() == 1 && opts.under_road_guard;
                let out = (!guarded || self.separation_settled)
                    .then(|| next.given(obs))
                    .flatten()
                    .and_then(|given| {
                        crate::separate::under_road_left_out(
                            &self.rig,
                            &self.estimator.motion(&sol.params),
                            obs,
                            &given,
                            opts,
                            metric_arc_length.is_some(),
                        )
                        .map(|out| (given, out))
                    });
                next_stage = match out {
                    Some((_, out)) if guarded => {
                        road_out = Some(out);
                        next
                    }
                    Some((given, out)) => crate::separate::NextStage::FinalFitOn(
                        crate::separate::and(&given, &crate::separate::not(&out)),
                    ),
                    None => next,
                };
                ground_drop = o.ground_drop;
                ground_drop_scaled = o.ground_drop_scaled;
                prior_kept = o.prior_kept;
                pulled = o.pulled;
                self.separation_settled |= !o.competing;
                self.quiet_streak = if o.competing {
                    0
                } else {
                    self.quiet_streak + 1
                };
                (Some(sol), o.competing)
            }
            (r, _) => {
                self.quiet_streak = 0;
                (r, false)
            }
        };

        // Whether this frame may centre the next frame's change-of-motion prior.
        let mut trusted = false;
        // Its soft-prior innovations (odometry.soft_prior_sigma_learning).
        let mut soft_sample = None;
        // Its data-only level of the soft-prior residuals (odometry.soft_prior_trend_frames).
        let mut soft_level = None;
        // The alternatives the reported covariance is widened by about the frame's solution
        // (`tilt_hold_stage = "report"` moves those terms to the held twin it reports).
        // `trust.ill_conditioned_refit` gave this frame's report its covariance (the frame
        // does not confirm a contested start: `trust.unconfirmed_start`).
        let mut refit_fallback = false;
        let mut widened = Widened::default();
        // The reduced stage's motion where `neighbour_guard` kept the given matches' stage
        // (`trust.guard_alternative_weight`).
        let mut guard_alternative: Option<Vec<f64>> = None;
        let params = match result {
            Some(sol) => {
                if standstill {
                    diag.status = FrameStatus::Standstill;
                }
                // Scale: accept an estimated arc length only where it is well determined.
                let mut sol = sol;
                let mut cross_sigma = None;
                if cross_scale
                    && !standstill
                    && let Some(i) = arc_index
                {
                    match self.measure_cross_scale(obs, &sol.params, i) {
                        Some(m) => {
                            let mut at = sol.params.clone();
                            at[i] = m.arc_length;
                            if let Some(s2) = self.solve_once(obs, &at, &fixed, false) {
                                sol = s2;
                            } else {
                                sol.params[i] = m.arc_length;
                            }
                            cross_sigma = Some(self.cross_scale_sigma(obs, &sol, i, &m));
                        }
                        None => diag.scale = ScaleSource::Held,
                    }
                }
                if scale == ScaleSource::Estimated
                    && !cross_scale
                    && let Some(i) = arc_index
                    && !self.scale_ok(&sol, i)
                {
                    diag.scale = ScaleSource::Held;
                    let mut held_init = sol.params.clone();
                    held_init[i] = self.last_arc_length.unwrap_or(self.previous[i]);
                    let mut held_fixed = fixed.clone();
                    held_fixed[i] = true;
                    if let Some(s2) = self.solve_once(obs, &held_init, &held_fixed, false) {
                        sol = s2;
                    } else {
                        sol.params[i] = held_init[i];
                    }
                }
                self.first_stage = None;
                if !standstill && next_stage != crate::separate::NextStage::Done {
                    let first = self.config.odometry.final_fit.enabled.then(|| sol.clone());
                    // The first stage's solution for the re-admission (`final_fit.readmit_share`).
                    let before_stage = self.readmit_on().then(|| sol.clone());
                    // The support's neighbourhood test (`final_fit.neighbour_share`); with
                    // `neighbour_guard`, the matches it was given and the stage's start.
                    let reduced = self.neighbour_stage(
                        obs,
                        &next_stage,
                        road_out.as_deref(),
                        &sol.params,
                        &fixed,
                        diag.scale,
                        competing,
                    );
                    let guard = (reduced.is_some()
                        && self.config.odometry.final_fit.neighbour_guard > 0.0)
                        .then(|| (next_stage.clone(), sol.clone()));
                    let mut next_stage = reduced.unwrap_or(next_stage);
                    let (mut tally, mut support);
                    (sol, tally, support) = match &next_stage {
                        crate::separate::NextStage::FinalFitOn(mask) => {
                            let chosen = crate::separate::subset(obs, mask);
                            // The kept matches' constants, where the frame has them already.
                            let m = self.final_fit_estimator().match_constant_count();
                            let constants = self
                                .frame_constants
                                .as_deref()
                                .and_then(|c| subset_constants(c, m, mask));
                            let (sol, tally, kept) = self.final_fit(
                                &chosen,
                                sol,
                                &fixed,
                                diag.scale,
                                competing,
                                constants.as_deref(),
                                None,
                            );
                            // The support's membership among all the frame's matches.
                            (sol, tally, kept.map(|k| superset_mask(mask, &k)))
                        }
                        _ => {
                            if self.config.odometry.final_fit.enabled {
                                self.compute_frame_constants(obs, &sol.params, &fixed);
                            }
                            let constants = self.frame_constants.as_deref();
                            let stage = self.frame_stage.as_ref();
                            self.final_fit(
                                obs, sol, &fixed, diag.scale, competing, constants, stage,
                            )
                        }
                    };
                    // `neighbour_guard`: the stage on the matches the test was given, where the
                    // reduced stage's rotation moved away from it (then the given matches are
                    // the stage's, for the re-admission too).
                    if let Some((given, start)) = guard {
                        let (alt, alt_tally, alt_support) =
                            self.guard_stage(obs, &given, start, &fixed, diag.scale, competing);
                        let ra = self.estimator.motion(&alt.params).rotation;
                        let rb = self.estimator.motion(&sol.params).rotation;
                        let apart = so3_log(&(ra.transpose() * rb)).norm()
                            > self.config.odometry.final_fit.neighbour_guard;
                        if apart && !self.guard_tilt_keeps_reduced(&ra, &rb) {
                            guard_alternative = Some(sol.params.clone());
                            (sol, tally, support) = (alt, alt_tally, alt_support);
                            next_stage = given;
                        } else if apart {
                            // `guard_tilt` kept the reduced stage: the given one is the other.
                            guard_alternative = Some(alt.params);
                        }
                    }
                    // Re-admission at the final motion (`final_fit.readmit_share`).
                    if let Some(before) = before_stage
                        && let Some(again) = self.readmit_stage(
                            obs,
                            &next_stage,
                            before,
                            &sol.params,
                            &fixed,
                            diag.scale,
                            competing,
                        )
                    {
                        (sol, tally, support) = again;
                    }
                    // The previous motion's basin on a rig (`odometry.previous_basin_change`):
                    // where it is taken, its stage's parallax tally and support are the frame's.
                    if let Some((alt, alt_tally, alt_support, taken)) =
                        self.previous_basin(obs, &sol, &fixed, diag.scale, competing)
                    {
                        self.previous_basin_counts.0 += 1;
                        if taken {
                            self.previous_basin_counts.1 += 1;
                            self.previous_basin_taken_frame = Some(self.frame);
                            if self.config.odometry.previous_basin_handoff {
                                self.previous_basin_handoff(obs, &alt.params);
                            }
                            (sol, tally, support) = (alt, alt_tally, alt_support);
                        }
                    }
                    if let Some(t) = tally {
                        self.parallax_tally.add(&t);
                    }
                    if self.config.odometry.report_support {
                        diag.support = support.map(|k| support_indices(&k));
                    }
                    self.first_stage = first.filter(|f| f.params != sol.params);
                }
                // The match memory of the frame's final motion (`separate.memory_final`).
                if !standstill
                    && let Some(opts) = self.config.odometry.separate.as_ref()
                    && opts.enabled
                    && opts.memory_final
                    && opts.memory_radius > 0.0
                {
                    let support = crate::separate::epipolar_within(
                        &self.rig,
                        &self.estimator.motion(&sol.params),
                        obs,
                        opts.threshold,
                    );
                    self.hypotheses.memory = crate::hypotheses::MatchMemory::record(obs, &support);
                }
                // The jackknife (a dozen solves) only where the support dropped against the
                // recent frames' best (or on every frame with `jackknife_support_drop >= 1`).
                let share = sol.inliers() as f64 / matches.max(1) as f64;
                let drop = self.config.trust.jackknife_support_drop;
                let mut jackknife =
                    drop >= 1.0 || self.inlier_share_peak.is_none_or(|p| share < drop * p);
                // And on the frames where the residuals cluster in the image (a rigid object in
                // a compromise motion), with the half-image grids too.
                let mut clustered = false;
                // The statistic and the competing-motions mask share one pass over the matches.
                let mut outside = None;
                if !standstill {
                    let t = &self.config.trust;
                    let (stat, mask) = trust::residual_statistic_and_outside(
                        &self.rig,
                        &self.estimator.motion(&sol.params),
                        obs,
                        (t.clustering_grid[0], t.clustering_grid[1]),
                        t.competing_threshold,
                    );
                    outside = Some(mask);
                    diag.residual_clustering = stat.map_or(f64::NAN, |(t, c)| t / c as f64);
                    clustered = self.clustering.observe(t, stat);
                    jackknife |= clustered;
                }
                // The soft prior's data view of the first stage's solution (else of `sol`): the
                // conflict check of the covariance and the innovation below share it.
                let soft_view = SoftView::new();
                // The previous frame's covariance, decayed (`trust.covariance_memory`).
                let floor = if standstill {
                    None
                } else {
                    self.covariance_floor(&sol)
                };
                let (base, report_jackknife, fallback) = self.fill_diagnostics(
                    obs,
                    &sol,
                    !standstill,
                    (jackknife, clustered),
                    outside,
                    Some(&soft_view),
                    floor.as_ref(),
                    &mut diag,
                );
                refit_fallback = fallback;
                // The competing motion's mixture (`fill_diagnostics` adds it wherever the frame
                // has a covariance).
                if let Some((b, w)) = &diag.competing
                    && !diag.covariance.is_empty()
                {
                    widened.add(&sol.params, [b.as_slice()], w * (1.0 - w));
                }
                if standstill
                    && self.config.odometry.standstill_jackknife
                    && self.config.odometry.standstill_at_rest
                {
                    let read = at_rest_read.as_ref().unwrap_or(obs);
                    self.widen_standstill_by_jackknife(read, &sol, &fixed, &mut diag);
                }
                if !standstill && self.config.trust.covariance_memory > 0.0 {
                    self.covariance_memory = base.map(|c| (self.frame, sol.free.clone(), c));
                }
                let pool = self.config.trust.report_pool_frames;
                if !standstill && pool > 1 && report_jackknife.iter().any(Option::is_some) {
                    self.report_pool
                        .push_back((self.frame, sol.free.clone(), report_jackknife));
                    while self.report_pool.len() >= pool {
                        self.report_pool.pop_front();
                    }
                }
                if !standstill && !self.soft_inv_scale.is_empty() {
                    soft_sample =
                        self.soft_innovation(self.first_stage.as_ref().unwrap_or(&sol), &soft_view);
                    if self.config.odometry.soft_prior_trend_frames > 0 {
                        soft_level =
                            self.soft_level(self.first_stage.as_ref().unwrap_or(&sol), &soft_view);
                    }
                }
                if !standstill {
                    self.inlier_share_peak = Some(match self.inlier_share_peak {
                        Some(p) => share.max(INLIER_SHARE_PEAK_DECAY * p),
                        None => share,
                    });
                }
                if let (Some(i), Some(sigma)) = (arc_index, cross_sigma) {
                    diag.param_sigmas[i] = sigma;
                } else if let Some(i) = arc_index
                    && diag.scale == ScaleSource::Estimated
                {
                    // The soft prior at its own strength (see estimated_arc_length_sigma).
                    let sigma = self.estimated_arc_length_sigma(&sol, i);
                    diag.param_sigmas[i] = diag.param_sigmas[i].max(sigma);
                }
                if ground_drop && diag.constraint == Constraint::Well {
                    diag.constraint = Constraint::Weak;
                    diag.reason = Some(Reason::RoadScoreDrop);
                }
                // The road's alternatives in the covariance (`trust.road_alternative_weight`),
                // and the road's alternative as a candidate of `odometry.decide_by_road`: found
                // whatever the weight, so that the weight widens only the reported covariance.
                let mut road_candidate = None;
                if ground_drop && !standstill {
                    road_candidate = self.widen_by_road_alternative(
                        obs,
                        &init,
                        &fixed,
                        (&sol.free, &sol.params),
                        &mut diag,
                        &mut widened,
                    );
                }
                if diag.constraint == Constraint::Weak {
                    diag.status = FrameStatus::Weak;
                }
                // The previous motion in the covariance of an estimated frame after a flagged
                // one (`trust.after_flag_weight`).
                if self.after_flag
                    && !standstill
                    && diag.status == FrameStatus::Estimated
                    && self.config.trust.after_flag_weight > 0.0
                {
                    // And the previous frame's reported motion, where its tilt was held.
                    let previous: Vec<&[f64]> = std::iter::once(init.as_slice())
                        .chain(self.previous_reported.as_deref())
                        .collect();
                    let w = self.config.trust.after_flag_weight;
                    widened.widen(&previous, w, &sol.free, &sol.params, &mut diag);
                }
                // The neighbourhood guard's reduced stage (`trust.guard_alternative_weight`).
                let w = self.config.trust.guard_alternative_weight;
                // (Set only by a moving frame's final stage.)
                if let Some(r) = guard_alternative.as_deref()
                    && w > 0.0
                {
                    widened.widen(&[r], w, &sol.free, &sol.params, &mut diag);
                }
                diag.guard_alternative = guard_alternative;
                // Standstill frames score another residual (rotation only): they do not count
                // towards the running inlier ratio of the moving frames.
                if !standstill {
                    let ratio = sol.inliers() as f64 / matches.max(1) as f64;
                    trusted = self
                        .inlier_ratio_average
                        .is_none_or(|a| ratio >= self.config.odometry.prior_min_inlier_ratio * a);
                    self.inlier_ratio_average = Some(match self.inlier_ratio_average {
                        Some(a) => 0.9 * a + 0.1 * ratio,
                        None => ratio,
                    });
                }
                // `odometry.competing_regions`: the competing motion voted by image regions.
                let mut region_taken = false;
                if !standstill
                    && let Some((alt, taken)) = self.competing_region(
                        obs,
                        &sol,
                        &fixed,
                        diag.scale,
                        competing,
                        diag.competing.as_ref(),
                    )
                {
                    self.competing_region_counts.0 += 1;
                    if taken {
                        self.competing_region_counts.1 += 1;
                        sol = alt;
                        region_taken = true;
                    }
                }
                let mut params = sol.params;
                // `odometry.decide_by_road`: a doubted frame decided by its alternatives' road
                // scores.
                if self.config.odometry.decide_by_road > 0
                    && !region_taken
                    && !standstill
                    && diag.status == FrameStatus::Weak
                    && (diag.competing.is_some() || road_candidate.is_some())
                {
                    let mut previous = init.clone();
                    if let Some(i) = arc_index {
                        previous[i] = params[i];
                    }
                    let alternatives: Vec<Vec<f64>> = diag
                        .competing
                        .iter()
                        .map(|c| c.0.clone())
                        .chain(road_candidate)
                        .chain(Some(previous).filter(|p| self.previous_competes(p, &params)))
                        .collect();
                    if let Some(p) = self.decide_by_road(obs, &params, alternatives.clone()) {
                        // The reported covariance, widened about the chosen motion, is widened
                        // about the replacement too by the motions it was chosen among (the
                        // first choice among them), `trust.road_alternative_weight` each, so
                        // that the report covers them from where the frame now is.
                        let mut others: Vec<&[f64]> = vec![params.as_slice()];
                        others.extend(alternatives.iter().map(Vec::as_slice));
                        let w = self.config.trust.road_alternative_weight;
                        widened.widen(&others, w, &sol.free, &p, &mut diag);
                        params = p;
                    }
                }
                params
            }
            None => {
                if diag.status == FrameStatus::Estimated {
                    diag.status = FrameStatus::SolverFailure;
                }
                // Hold the previous motion, with this frame's arc length if known.
                let mut held = self.previous.clone();
                if let (Some(i), Some(l)) = (arc_index, arc_length) {
                    held[i] = if standstill { 0.0 } else { l };
                }
                if diag.scale == ScaleSource::Estimated {
                    diag.scale = ScaleSource::Held;
                }
                if diag.status == FrameStatus::Degenerate {
                    // Nothing was learnt from the matches: no confidence at all.
                    for k in (0..n_params).filter(|&k| !fixed[k]) {
                        diag.param_sigmas[k] = f64::INFINITY;
                    }
                    diag.covariance.clear();
                }
                held
            }
        };

        // `odometry.tilt_hold_stage = "report"`: the frame reports the held twin of its motion
        // where that is one of the final stage's refits; every report-only rule below reads the
        // reported motion (and the covariance is widened about it, below), the run's state the
        // motion without the hold.
        let report = self
            .take_held_refit(&params, standstill)
            .unwrap_or_else(|| params.clone());
        // `trust.competing_recheck_frames`: the competing-motions check once more from more
        // starts (report only: applied below, after the frame's state).
        let recheck = self.competing_recheck(obs, &params, standstill, &diag);
        if let Some(i) = arc_index
            && params[i].abs() > self.config.odometry.standstill_arc_length
        {
            self.last_arc_length = Some(params[i]);
        }
        if self.config.odometry.decide_by_road_tilt && !standstill {
            let w = so3_log(&self.estimator.motion(&params).rotation);
            self.recent_tilts.push_back([w.x, w.y]);
            while self.recent_tilts.len() > self.config.odometry.decide_by_road_tilt_frames.max(1) {
                self.recent_tilts.pop_front();
            }
        }
        self.after_standstill = standstill;
        self.after_flag = diag.status == FrameStatus::Weak
            && matches!(
                diag.reason,
                Some(Reason::CompetingMotions | Reason::RoadScoreDrop)
            );
        // A frame where two motions competed does not centre the next frame's prior, unless
        // only the road prediction did and `predict_by_road_prior` keeps it.
        self.prior_ready =
            diag.status == FrameStatus::Estimated && trusted && (!competing || prior_kept);
        if standstill {
            self.tilt_hold = None;
        } else if self.prior_ready {
            let w = so3_log(&self.estimator.motion(&params).rotation);
            let mean = match self.tilt_hold {
                Some((m, _)) => {
                    let a = 1.0 / TILT_HOLD_MEAN_FRAMES;
                    [m[0] + a * (w.x - m[0]), m[1] + a * (w.y - m[1])]
                }
                None => [w.x, w.y],
            };
            self.tilt_hold = Some((mean, 1));
        } else if let Some((_, n)) = self.tilt_hold.as_mut() {
            *n = n.saturating_add(1);
        }
        self.trusted_streak = if self.prior_ready {
            self.trusted_streak.saturating_add(1)
        } else {
            0
        };
        if self.after_flag {
            self.parallax_tally.mark_flagged();
        }
        self.since_competing = if self.after_flag {
            0
        } else {
            self.since_competing.saturating_add(1)
        };
        let n = self.config.odometry.soft_prior_centring_frames;
        // `soft_prior_learn_competing`: the soft prior also learns from the trusted frames where
        // two motions competed.
        let soft_ready = self.prior_ready
            || (self.config.odometry.soft_prior_learn_competing
                && trusted
                && (diag.status == FrameStatus::Estimated
                    || (diag.status == FrameStatus::Weak
                        && diag.reason == Some(Reason::CompetingMotions))));
        if soft_ready && n > 0 && !self.soft_center.is_empty() {
            // A cumulative mean over the first n moving frames, then exponential with n frames.
            self.soft_count += 1;
            let alpha = 1.0 / self.soft_count.min(n) as f64;
            let q = self.estimator.prior_residuals(&params);
            for (c, q) in self.soft_center.iter_mut().zip(q) {
                *c += alpha * (q - *c);
            }
            if let Some(level) = soft_level {
                self.soft_levels.push_back(level);
                while self.soft_levels.len() > self.config.odometry.soft_prior_trend_frames {
                    self.soft_levels.pop_front();
                }
            }
            if let Some(sample) = soft_sample {
                let arc = arc_index.map_or(f64::NAN, |i| params[i].abs());
                self.soft_samples.push_back((arc, sample));
                self.soft_taught += 1;
                while self.soft_samples.len() > n {
                    self.soft_samples.pop_front();
                }
                self.learn_soft_sigma();
            }
        }
        if !standstill && enough {
            self.soft_moving += 1;
        }
        // The frame as the solve and the separation left it, before any report-only rule: the
        // run's noise reading follows it, so that no report-only flag moves a later pose.
        let unflagged = diag.status == FrameStatus::Estimated && diag.competing.is_none();
        // `separate.hypotheses.yaw_history_final`: the yaw history holds the reported motion,
        // with its yaw sigma before the report-only rules (the recheck's mixture widens it).
        if !standstill
            && let Some(h) = self
                .config
                .odometry
                .separate
                .as_ref()
                .filter(|s| s.enabled)
                .and_then(|s| s.hypotheses())
                .filter(|h| h.yaw_history_final)
        {
            let yaw = so3_log(&self.estimator.motion(&params).rotation).z;
            self.hypotheses.set_last_yaw(h, yaw);
            let (m0, k) = h.yaw_history_slow_margin;
            if m0 > 0.0 && k > 0.0 {
                let sigma = self.yaw_sigma(&params, &diag).unwrap_or(f64::NAN);
                self.hypotheses.set_last_yaw_sigma(sigma);
            }
        }
        // `tilt_hold_stage = "report"`, after the state above: the covariance's widenings about
        // the solution are moved to the held twin the frame reports.
        if report != params {
            let d = &mut diag;
            widened.recentre(
                &params,
                &report,
                &d.free,
                &mut d.covariance,
                &mut d.param_sigmas,
            );
        }
        // The yaw's change against the previous frame's reported motion (`trust.yaw_change`):
        // after the state above, so that it changes the report only.
        let motion = self.estimator.motion(&params);
        let reported = self.estimator.motion(&report);
        let moving = !standstill
            && matches!(diag.status, FrameStatus::Estimated | FrameStatus::Weak)
            && diag.covariance.len() == diag.free.len().pow(2);
        // The reported rotation vector, once, where a rule below reads it.
        let t = &self.config.trust;
        let omega =
            (t.support_change_share > 0.0 || t.yaw_change > 0.0 || t.contested_yaw_change > 0.0)
                .then(|| momo_core::so3_log(&reported.rotation));
        // A small support with a jump of the yaw or the tilt (`trust.support_change_share`),
        // report only; before `yaw_change`, so that a frame it flags keeps this reason.
        if let (true, Some(omega)) = (self.config.trust.support_change_share > 0.0, omega) {
            let fired = moving
                && self
                    .previous_omega
                    .is_some_and(|p| self.support_change_fires(omega - p, &diag));
            if fired {
                flag_weak_report_only(&mut diag, Reason::SupportChange);
            }
            self.support_change_fired = fired;
            self.previous_omega = moving.then_some(omega);
        }
        if let (true, Some(omega)) = (self.config.trust.yaw_change > 0.0, omega) {
            let yaw = omega.z;
            if moving && let Some(previous_yaw) = self.previous_yaw {
                self.flag_yaw_change(yaw - previous_yaw, &report, &mut diag);
            }
            self.previous_yaw = moving.then_some(yaw);
        }
        // The competing motion found by the recheck, report only: the mixture's covariance and,
        // where it dominates, the flag.
        if let Some((b, w, false)) = &recheck {
            apply_recheck(&report, b, *w, &mut diag);
        }
        // The direction of travel left the vehicle's (`trust.side_slip_change`), report only.
        let slip = moving.then(|| side_slip(&reported)).flatten();
        // `trust.side_slip_hold`: for so many moving frames after a jump, half the jump is one;
        // flagged at the end: every rule and the centre read the frame as without it (a centre
        // without the held frames moved later jumps' flags, sixty-seventh session).
        let t = &self.config.trust;
        let jumps = slip.is_some_and(|slip| side_slip_jumps(t, self.side_slip_centre, slip, 1.0));
        let held = !jumps
            && self.side_slip_hold_left > 0
            && slip.is_some_and(|slip| {
                side_slip_jumps(
                    t,
                    self.side_slip_centre,
                    slip,
                    trust::SIDE_SLIP_HOLD_FRACTION,
                )
            });
        if jumps {
            flag_weak_report_only(&mut diag, Reason::SideSlip);
        }
        // A frame whose first motion a vehicle pulled away starts the hold as a flagged one
        // does: the vehicle is still there.
        self.side_slip_hold_left =
            match (jumps || (pulled && t.side_slip_hold_pulled), slip.is_some()) {
                (true, _) => t.side_slip_hold,
                (false, true) => self.side_slip_hold_left.saturating_sub(1),
                (false, false) => 0,
            };
        // Too small a support for the static scene (`trust.min_inlier_share`), report only.
        let share = self.config.trust.min_inlier_share;
        if moving && diag.matches > 0 && (diag.inliers as f64) < share * diag.matches as f64 {
            flag_weak_report_only(&mut diag, Reason::LowSupport);
        }
        // An estimated frame reports a finite covariance, or says that it has none
        // (`ill_conditioned`, infinite sigmas), report only: after the state above.
        flag_ill_conditioned(&mut diag);
        // `trust.side_slip_change`'s centre learns from the frames reported `estimated` without
        // a competing motion.
        if let Some((beta, _)) = slip
            && diag.status == FrameStatus::Estimated
            && diag.competing.is_none()
            && !refit_fallback
        {
            let (mean, n) = &mut self.side_slip_centre;
            *n += 1;
            *mean += (beta - *mean) / (*n).min(crate::trust::SIDE_SLIP_CENTRE_FRAMES) as f64;
        }
        // `trust.unconfirmed_scale`: the state of the arc length this frame was solved with.
        let unconfirmed = self.road_unconfirmed;
        // `odometry.road_scale_frames`: this frame's arc length from the road plane.
        if self.road_scale_on()
            && arc_length.is_none()
            && !standstill
            && matches!(diag.status, FrameStatus::Estimated | FrameStatus::Weak)
            && let Some(i) = arc_index
            && let Some(reading) = self.road_arc_length(obs, &params, i)
        {
            self.admit_road_arc_length(reading);
        }
        // Report only (after the frame's state): `trust.stale_scale_frames`, the road's arc
        // length not measured again for so many frames; `trust.unconfirmed_scale`, the held
        // road arc length jumped through the widened gate and was not confirmed since.
        let stale = self.config.trust.stale_scale_frames;
        if diag.scale == ScaleSource::Road
            && !standstill
            && ((stale > 0 && self.frames_since_road_admitted() >= stale)
                || (self.config.trust.unconfirmed_scale && unconfirmed))
        {
            flag_weak_report_only(&mut diag, Reason::StaleScale);
        }
        // Two motions compete before the run confirmed one (`trust.unconfirmed_start`), report
        // only: the last flag (a frame flagged for another reason keeps it), after the recheck,
        // which may name the second motion. The first frame reported `estimated` without a
        // competing motion confirms the run.
        if self.config.trust.unconfirmed_start && !self.start_confirmed && diag.competing.is_some()
        {
            flag_weak_report_only(&mut diag, Reason::UnconfirmedStart);
        }
        self.start_confirmed |=
            diag.status == FrameStatus::Estimated && diag.competing.is_none() && !refit_fallback;
        // `odometry.noise_reference`: the angular thresholds follow the run's noise, read off
        // the frames `estimated` without a competing motion before the report-only rules (from
        // the next frame on).
        if moving && self.config.odometry.noise_reference > 0.0 && unflagged {
            let angles = crate::separate::epipolar_angles(&self.rig, &motion, obs);
            if let Some(sigma) = crate::separate::noise_sigma(&angles, self.config.loss.scale()) {
                if self.noise.observe(sigma, &mut self.config) {
                    diag.noise = Some(sigma);
                }
            }
        }
        // `trust.start_own_noise`'s second motion, report only: after the frame's state (the
        // start's confirmation and the noise reading are the ones without it).
        if let Some((b, w, true)) = &recheck {
            apply_recheck(&report, b, *w, &mut diag);
        }
        // A jump of the yaw where two motions compete (`trust.contested_yaw_change`), report
        // only: the last flag, once every competing motion of the frame is known.
        let frame = omega.filter(|_| moving).map(|omega| trust::YawFrame {
            yaw: omega.z,
            noise_scale: diag.noise_scale,
            competing: diag.competing.is_some(),
            doubted: diag.status != FrameStatus::Estimated,
            params: &report,
        });
        if let Some(before) = self.contested_yaw.step(&self.config.trust, frame)
            && diag.status == FrameStatus::Estimated
        {
            flag_weak_report_only(&mut diag, Reason::YawChange);
            let free = diag.free.clone();
            let w = self.config.trust.yaw_change_weight;
            Self::widen_by_alternatives_at(&[&before], w, &free, &report, &mut diag);
        }
        // `trust.side_slip_hold`'s flag, report only.
        if held {
            flag_weak_report_only(&mut diag, Reason::SideSlip);
        }
        // `trust.unconfirmed_start_frames`, report only: the last flag, on the frame as every
        // other rule reports it.
        if self.config.trust.unconfirmed_start
            && (self.config.trust.unconfirmed_start_frames > 1
                || self.config.trust.unconfirmed_start_distance > 0.0)
        {
            let unsettled = !self.start_settled;
            let clean = diag.status == FrameStatus::Estimated
                && diag.competing.is_none()
                && !refit_fallback;
            self.start_clean = if clean { self.start_clean + 1 } else { 0 };
            let arc = arc_index.map_or(0.0, |i| report[i].abs());
            self.start_clean_distance = if clean {
                self.start_clean_distance + arc
            } else {
                0.0
            };
            self.start_contested |= diag.competing.is_some();
            // A model without an arc length (rotation only): the frame count alone.
            let travelled = arc_index.is_none()
                || self.start_clean_distance >= self.config.trust.unconfirmed_start_distance;
            self.start_settled |=
                self.start_clean >= self.config.trust.unconfirmed_start_frames && travelled;
            if unsettled
                && (diag.competing.is_some()
                    || (clean && self.start_contested && !self.start_settled))
            {
                flag_weak_report_only(&mut diag, Reason::UnconfirmedStart);
            }
        }
        // The road score's drop on a frame with few matches (`trust.road_drop_scaled`), report
        // only and the last flag (no other rule's state reads it): flagged as
        // `road_score_drop`, the covariance widened about the reported motion by the road's
        // alternatives as where the drop flags the frame in the run.
        if self.config.trust.road_drop_scaled
            && ground_drop_scaled
            && metric_arc_length.is_some()
            && moving
            && diag.status == FrameStatus::Estimated
        {
            flag_weak_report_only(&mut diag, Reason::RoadScoreDrop);
            if self.config.trust.road_alternative_weight > 0.0 {
                let free = diag.free.clone();
                let about = (free.as_slice(), report.as_slice());
                self.widen_by_road_alternative(obs, &init, &fixed, about, &mut diag, &mut widened);
            }
        }
        self.previous_reported = (report != params).then(|| report.clone());
        diag.params = report;
        // The warm start keeps the last moving arc length so that the next frame's start is sane.
        self.previous = params;
        if let (Some(i), Some(l)) = (arc_index, self.last_arc_length)
            && self.previous[i].abs() <= self.config.odometry.standstill_arc_length
        {
            self.previous[i] = l;
        }
        // `competing_region_continuing`'s references: the last frames' motions (kept only
        // where the test looks back over more than the previous frame).
        let keep = self.config.odometry.competing_region_continuing_frames;
        if keep > 1 {
            self.recent_motions.push_back(self.previous.clone());
            while self.recent_motions.len() > keep {
                self.recent_motions.pop_front();
            }
        }
        diag.time_us = start.elapsed().as_secs_f64() * 1e6;
        FrameResult {
            motion: reported,
            diagnostics: diag,
        }
    }

    /// `odometry.tilt_hold_stage = "report"`: the final stage's held twin of the frame's motion
    /// `params`, where `params` is one of this frame's refits (none on a standstill); the
    /// frame's list of refits is emptied.
    fn take_held_refit(&mut self, params: &[f64], standstill: bool) -> Option<Vec<f64>> {
        let refits = std::mem::take(self.held_refits.get_mut().ok()?);
        if standstill {
            return None;
        }
        refits
            .into_iter()
            .find_map(|(free, held)| (free == params && held != params).then_some(held))
    }

    /// Adds a frame's road arc length to the history of `odometry.road_scale_frames` unless it
    /// leaves the gate's reference (the median of the last [`ROAD_SCALE_GATE_FRAMES`] admitted
    /// ones) by more than [`ROAD_SCALE_GATE`] (relative) and [`ROAD_SCALE_GATE_METRES`]: a
    /// vehicle does not change its speed that much from one frame to the next, but a lead
    /// vehicle that moves with the ego vehicle stands on a "road" of its own at a fraction of
    /// the ego motion's scale (its motion relative to the camera is the difference of the two)
    /// and can hold more road matches than the road itself where it covers it. A rejected
    /// reading whose frame still counts at least [`ROAD_SCALE_HELD_SUPPORT`] of its road
    /// matches at the reference ([`RoadReading::held_count`]) speaks for the reference and is
    /// dropped. The others are kept, and [`ROAD_SCALE_RESETS`] of them in a row restart the
    /// history from them: a wrong start (a drive's first readings taken under a lead vehicle's
    /// motion) must not be held where the frames find no road at it.
    fn admit_road_arc_length(&mut self, reading: RoadReading) {
        let l = reading.arc_length;
        let held = self.road_gate_reference();
        // Frames since the last admitted one, this one excluded.
        let stale = self.frames_since_road_admitted().saturating_sub(1) as f64;
        let gate = |h: f64, widening: f64| {
            (l - h).abs() <= (ROAD_SCALE_GATE * h).max(ROAD_SCALE_GATE_METRES) + widening
        };
        let admit = held.is_none_or(|h| gate(h, ROAD_SCALE_GATE_METRES_PER_FRAME * stale));
        if admit {
            self.road_unconfirmed = held.is_some_and(|h| !gate(h, 0.0));
            self.road_admitted_frame = self.frame;
            self.road_rejected.clear();
            self.road_arc_lengths.push_back(l);
        } else {
            if reading.held_count as f64 >= ROAD_SCALE_HELD_SUPPORT * reading.count as f64 {
                return;
            }
            self.road_rejected.push(l);
            if self.road_rejected.len() < ROAD_SCALE_RESETS {
                return;
            }
            self.road_arc_lengths = self.road_rejected.drain(..).collect();
            self.road_admitted_frame = self.frame;
            self.road_unconfirmed = false;
        }
        while self.road_arc_lengths.len() > self.road_kept() {
            self.road_arc_lengths.pop_front();
        }
    }

    /// How many admitted road arc lengths are kept: the held one's `odometry.road_scale_frames`
    /// and the gate's [`ROAD_SCALE_GATE_FRAMES`].
    fn road_kept(&self) -> usize {
        self.config
            .odometry
            .road_scale_frames
            .max(ROAD_SCALE_GATE_FRAMES)
    }

    /// The held road arc length (`odometry.road_scale_frames`): the median of the last so many
    /// admitted ones.
    fn road_held(&self) -> Option<f64> {
        self.road_median_of_last(self.config.odometry.road_scale_frames)
    }

    /// The reference of [`Odometry::admit_road_arc_length`]'s gate: the median of the last
    /// [`ROAD_SCALE_GATE_FRAMES`] admitted road arc lengths.
    fn road_gate_reference(&self) -> Option<f64> {
        self.road_median_of_last(ROAD_SCALE_GATE_FRAMES)
    }

    /// The median of the last `k` admitted road arc lengths (of all of them where fewer).
    fn road_median_of_last(&self, k: usize) -> Option<f64> {
        let n = self.road_arc_lengths.len();
        crate::stats::median(self.road_arc_lengths.iter().skip(n - k.min(n)).copied())
    }

    /// Frames since the last admitted road arc length (`odometry.road_scale_frames`), this one
    /// included.
    fn frames_since_road_admitted(&self) -> usize {
        self.frame.saturating_sub(self.road_admitted_frame)
    }

    /// Whether `odometry.road_scale_frames` applies: on, and a single camera (no cross-camera
    /// matches to measure the scale with).
    fn road_scale_on(&self) -> bool {
        self.config.odometry.road_scale_frames > 0 && self.rig.len() == 1
    }

    /// The arc length at which the static world of the motion `params` stands on the road
    /// (`odometry.road_scale_frames`): the matches within the separation's threshold of its
    /// epipolar geometry are triangulated under `params` with the arc length (parameter
    /// `arc_index`) on a log grid of 0.05-5 m (steps of 2 %); each arc length counts the
    /// matches on the road plane ([`crate::hypotheses::ground_support`]: the camera's height is
    /// known, so the road's depth fixes the scale; [`crate::hypotheses::ground_support_over`]
    /// counts all arc lengths at once, testing each match only near the arc length that puts it
    /// on the road). The answer is the geometric mean of the
    /// contiguous run of arc lengths around the best count that count at least 80 % of it.
    /// `None` where the best count is below [`ROAD_SCALE_MIN_MATCHES`], or without the
    /// separation's hypotheses.
    fn road_arc_length(
        &self,
        obs: &FrameObservations,
        params: &[f64],
        arc_index: usize,
    ) -> Option<RoadReading> {
        let (h, support) = self.road_support(obs, &self.estimator.motion(params))?;
        const STEP: f64 = 1.02;
        let (lo, hi) = (0.05_f64, 5.0_f64);
        let steps = ((hi / lo).ln() / STEP.ln()).ceil() as usize;
        let mut at = params.to_vec();
        let arc_lengths: Vec<f64> = (0..=steps).map(|k| lo * STEP.powi(k as i32)).collect();
        let motions: Vec<_> = arc_lengths
            .iter()
            .map(|l| {
                at[arc_index] = *l;
                self.estimator.motion(&at)
            })
            .collect();
        let counts = crate::hypotheses::ground_support_over(
            &self.rig,
            &arc_lengths,
            &motions,
            obs,
            &support,
            h,
        );
        let arc_length =
            crate::hypotheses::road_arc_length(&arc_lengths, &counts, ROAD_SCALE_MIN_MATCHES)?;
        // The road's count at the gate's reference (the most at the grid's arc lengths within
        // two steps of it: the road's plateau is a few steps wide).
        let held_count = self
            .road_gate_reference()
            .map(|h| {
                arc_lengths
                    .iter()
                    .zip(&counts)
                    .filter(|(l, _)| (*l / h).ln().abs() <= 2.0 * STEP.ln() + 1e-9)
                    .map(|(_, c)| *c)
                    .max()
                    .unwrap_or(0)
            })
            .unwrap_or(0);
        Some(RoadReading {
            arc_length,
            count: counts.iter().copied().max().unwrap_or(0),
            held_count,
        })
    }

    /// The motion separation's options (`odometry.separate`); `None` where it is off.
    fn separation(&self) -> Option<&crate::separate::SeparateOptions> {
        self.config.odometry.separate.as_ref().filter(|s| s.enabled)
    }

    /// The separation's hypotheses options and the support its road cues read under `motion`
    /// (the matches within the separation's threshold of its epipolar geometry); `None` where
    /// the separation or its hypotheses are off.
    fn road_support(
        &self,
        obs: &FrameObservations,
        motion: &Pose<f64>,
    ) -> Option<(&crate::hypotheses::HypothesesOptions, Vec<Vec<bool>>)> {
        let opts = self.separation()?;
        let h = opts.hypotheses()?;
        Some((
            h,
            crate::separate::epipolar_within(&self.rig, motion, obs, opts.threshold),
        ))
    }

    /// The separation's road score of `params` ([`crate::hypotheses::score`]) on its own
    /// support (the matches within the separation's threshold of its epipolar geometry), with
    /// that support; `None` where the separation or its hypotheses are off.
    fn road_score_of(
        &self,
        obs: &FrameObservations,
        params: &[f64],
    ) -> Option<(usize, Vec<Vec<bool>>)> {
        let motion = self.estimator.motion(params);
        let (h, support) = self.road_support(obs, &motion)?;
        Some((
            crate::hypotheses::score(h, &self.rig, &motion, obs, &support),
            support,
        ))
    }

    /// `odometry.decide_by_road_tilt_trusted`: whether the previous motion `previous` competes
    /// with the chosen one (`chosen`) in `decide_by_road`. After a frame that did not centre the
    /// prior, not where `final_fit.guard_tilt` would keep `chosen` over it (its tilt lies beyond
    /// the margin from the trusted frames' running mean tilt and the chosen motion's within
    /// it); otherwise always.
    fn previous_competes(&self, previous: &[f64], chosen: &[f64]) -> bool {
        if !self.config.odometry.decide_by_road_tilt_trusted || self.prior_ready {
            return true;
        }
        let (p, c) = (
            self.estimator.motion(previous),
            self.estimator.motion(chosen),
        );
        !self.guard_tilt_keeps_reduced(&p.rotation, &c.rotation)
    }

    /// `odometry.decide_by_road`: the alternative whose road score exceeds the chosen motion's
    /// by at least the option's margin (the best of them, [`pick_by_road`]), with the match
    /// memory, the tilt, yaw and road history of the separation moved to it; `None` where the
    /// chosen motion stays.
    fn decide_by_road(
        &mut self,
        obs: &FrameObservations,
        chosen: &[f64],
        alternatives: Vec<Vec<f64>>,
    ) -> Option<Vec<f64>> {
        let (base, _) = self.road_score_of(obs, chosen)?;
        let arc_index = self.estimator.arc_length_index();
        let yaw = |p: &[f64]| so3_log(&self.estimator.motion(p).rotation).z;
        let o = &self.config.odometry;
        // `decide_by_road_continuing`: the chosen motion's yaw distance to the previous frame's,
        // where the recent history is trusted (`decide_by_road_trusted_frames`).
        let reach = (o.decide_by_road_continuing
            && self.trusted_streak >= o.decide_by_road_trusted_frames)
            .then(|| {
                (
                    yaw(&self.previous),
                    (yaw(chosen) - yaw(&self.previous)).abs(),
                )
            });
        // `decide_by_road_tilt`: the tilt's distance to the recent frames' (the norm's or the
        // vector's), and the chosen motion's.
        let tilt_reference = (o.decide_by_road_tilt && !self.recent_tilts.is_empty()).then(|| {
            let x = crate::stats::median(self.recent_tilts.iter().map(|t| t[0])).unwrap_or(0.0);
            let y = crate::stats::median(self.recent_tilts.iter().map(|t| t[1])).unwrap_or(0.0);
            let norm = crate::stats::median(self.recent_tilts.iter().map(|t| t[0].hypot(t[1])))
                .unwrap_or(0.0);
            (x, y, norm)
        });
        let vector = o.decide_by_road_tilt_vector;
        let tilt_distance = |p: &[f64]| {
            tilt_reference.map(|(x, y, norm)| {
                let w = so3_log(&self.estimator.motion(p).rotation);
                if vector {
                    (w.x - x).hypot(w.y - y)
                } else {
                    (w.x.hypot(w.y) - norm).abs()
                }
            })
        };
        let tilt_reach = tilt_distance(chosen);
        // `decide_by_road_yaw_jump`: the previous frame's yaw and the chosen motion's.
        let (yaw_previous, yaw_chosen) = (yaw(&self.previous), yaw(chosen));
        let scored: Vec<_> = alternatives
            .into_iter()
            .filter(|a| a.len() == chosen.len() && a.iter().all(|x| x.is_finite()))
            .filter(|a| reach.is_none_or(|(y0, d)| (yaw(a) - y0).abs() <= d))
            .filter(|a| {
                within_yaw_jump(yaw_previous, yaw_chosen, yaw(a), o.decide_by_road_yaw_jump)
            })
            .filter(|a| tilt_reach.is_none_or(|d| tilt_distance(a).is_none_or(|e| e <= d)))
            .map(|mut a| {
                // The frame's own arc length (held or measured) for every alternative.
                if let Some(i) = arc_index {
                    a[i] = chosen[i];
                }
                a
            })
            .filter_map(|a| self.road_score_of(obs, &a).map(|(s, sup)| (a, s, sup)))
            .collect();
        // `decide_by_road_yaw_margin`: beyond the margin only a decisive road score replaces.
        let decisive = self.decisive_road(obs.len());
        let margin = o.decide_by_road_yaw_margin;
        let scored: Vec<_> = scored
            .into_iter()
            .filter(|(a, s, _)| {
                within_yaw_jump(yaw_previous, yaw_chosen, yaw(a), margin)
                    || decisive.is_none_or(|d| road_decisive(*s, base, d))
            })
            .collect();
        let scores: Vec<usize> = scored.iter().map(|x| x.1).collect();
        let best = pick_by_road(base, &scores, self.config.odometry.decide_by_road)?;
        let (params, score, support) = scored.into_iter().nth(best)?;
        let keep_memory = self.config.odometry.decide_by_road_keep_memory;
        self.hand_off_separation(obs, &params, score, &support, !keep_memory);
        Some(params)
    }

    /// The separation's decisive road score for a frame of `matches` matches: its least road
    /// score (`separate.ground_admit_min`, scaled by `separate.count_reference`) and its ratio
    /// to the chosen motion's (`separate.ground_admit`); `None` where the separation is off.
    fn decisive_road(&self, matches: usize) -> Option<(usize, f64)> {
        let scaled = self.separation()?.for_matches(matches);
        Some((scaled.ground_admit_min, scaled.ground_admit))
    }

    /// The separation's match memory (where `memory`) and its tilt, yaw and road history moved
    /// to `params`, a motion that replaced the frame's choice with road score `score` on its
    /// epipolar `support` (`decide_by_road`, `previous_basin_handoff`); nothing where the
    /// separation or its hypotheses are off.
    fn hand_off_separation(
        &mut self,
        obs: &FrameObservations,
        params: &[f64],
        score: usize,
        support: &[Vec<bool>],
        memory: bool,
    ) {
        if let Some(opts) = self.config.odometry.separate.as_ref() {
            if memory && opts.memory_radius > 0.0 {
                self.hypotheses.memory = crate::hypotheses::MatchMemory::record(obs, support);
            }
            if let Some(h) = opts.hypotheses() {
                let motion = self.estimator.motion(params);
                let tilt = crate::hypotheses::tilt(&motion);
                let yaw = so3_log(&motion.rotation).z;
                self.hypotheses.replace_last(h, tilt, yaw, score);
            }
        }
    }

    /// Whether the separation of this frame may skip its alternative solves
    /// ([`OdometryOptions::quiet_frames`](crate::config::OdometryOptions::quiet_frames)): the
    /// last `quiet_frames` moving frames kept no competing alternative, no recent frame fired
    /// the residual-clustering test, and on the first stage's solution `first` the inlier share
    /// is at least [`QUIET_SUPPORT_DROP`](crate::config::QUIET_SUPPORT_DROP) times the recent
    /// best, the residual-clustering test ([`trust::clustering_fires`]) does not fire, and the
    /// match memory's "other" share among the labelled matches outside the solution's support
    /// exceeds the memory's own by at most `quiet_other_share` ([`quiet_memory`]).
    fn quiet(
        &self,
        obs: &FrameObservations,
        first: &FrameSolution,
        opts: &crate::separate::SeparateOptions,
    ) -> bool {
        let o = &self.config.odometry;
        if o.quiet_frames == 0 || self.quiet_streak < o.quiet_frames || self.clustering.active() {
            return false;
        }
        let share = first.inliers() as f64 / obs.len().max(1) as f64;
        if self
            .inlier_share_peak
            .is_none_or(|p| share < crate::config::QUIET_SUPPORT_DROP * p)
        {
            return false;
        }
        let t = &self.config.trust;
        let (stat, outside) = trust::residual_statistic_and_outside(
            &self.rig,
            &self.estimator.motion(&first.params),
            obs,
            (t.clustering_grid[0], t.clustering_grid[1]),
            opts.threshold,
        );
        if trust::clustering_fires(t, stat) {
            return false;
        }
        if opts.memory_radius <= 0.0 {
            return true;
        }
        if self.hypotheses.memory.is_empty() {
            return false;
        }
        // Only the matches outside the support are looked up (the lookup is a tenth of a
        // static frame's instructions), and none where too few to show anything.
        if outside.iter().flatten().filter(|x| **x).count() < QUIET_MIN_LABELLED {
            return true;
        }
        let rest = crate::separate::subset(obs, &outside);
        let Some(labels) = self.hypotheses.memory.labels(&rest, opts.memory_radius) else {
            return false;
        };
        quiet_memory(&labels, self.hypotheses.memory.other_share()) <= o.quiet_other_share
    }

    /// The checks after a solve (`crate::trust`): a rotation no vehicle makes, no or too few
    /// inliers, inliers in a small region.
    fn after_solve(&self, obs: &FrameObservations, sol: &FrameSolution) -> Option<Reason> {
        let t = &self.config.trust;
        let motion = self.estimator.motion(&sol.params);
        if so3_log(&motion.rotation).norm() > t.max_rotation {
            return Some(Reason::ImplausibleRotation);
        }
        let inliers = sol.inliers();
        if inliers == 0 {
            return Some(Reason::NoInliers);
        }
        if inliers < t.min_inliers {
            return Some(Reason::TooFewInliers);
        }
        // Where the inliers are. With an angular metric at its loss scale, the solver's own
        // inliers (its residual is the angle to the epipolar plane): no second pass.
        let in_rig = self.rig_matches(obs);
        if self.metric_is_angular
            && self.inlier_angle() == self.config.loss.scale()
            && sol.inlier_mask.len() == in_rig
        {
            let s = trust::spread_of_mask(&self.rig, obs, &sol.inlier_mask);
            return s
                .filter(|s| s.extent < t.min_extent)
                .map(|_| Reason::InliersInSmallRegion);
        }
        let threshold = self.inlier_angle();
        let cams: Vec<Option<Pose<f64>>> = self
            .rig
            .cameras()
            .iter()
            .map(|c| {
                let m = camera_motion(&motion, &c.t_vehicle_camera);
                (m.translation.norm() > 1e-9).then_some(m)
            })
            .collect();
        let is_inlier = |j: usize, i: usize| {
            let (Some(Some(c)), Some(o)) = (cams.get(j), obs.per_camera[j].get(i)) else {
                return true;
            };
            let n = c.translation.cross(&(c.rotation * o.f1));
            let nn = n.norm();
            nn == 0.0 || (o.f0.dot(&n) / (nn * o.f0.norm())).abs() <= threshold
        };
        if let Some(s) = trust::spread(&self.rig, obs, is_inlier)
            && s.extent < t.min_extent
        {
            return Some(Reason::InliersInSmallRegion);
        }
        None
    }

    /// The angle (radians) within which a match counts as an inlier for the spread check: the
    /// loss scale for `angle_plane`, else 2 px at a 700 px focal length.
    fn inlier_angle(&self) -> f64 {
        let s = self.config.loss.scale();
        if s.is_finite() && s < 0.5 && self.metric_is_angular {
            s
        } else {
            3e-3
        }
    }

    /// The arc length measured from the frame's cross-camera matches with every other
    /// parameter at `params` ([`crate::stereo_scale`]), if it is well determined (relative
    /// sigma within `odometry.max_relative_scale_sigma`, above the standstill threshold, within
    /// `odometry.max_arc_length_ratio` of the last arc length).
    fn measure_cross_scale(
        &self,
        obs: &FrameObservations,
        params: &[f64],
        arc_index: usize,
    ) -> Option<crate::stereo_scale::CrossScale> {
        let last = self.last_arc_length.unwrap_or(self.previous[arc_index]);
        let max = (20.0 * last.abs().max(1.0)).min(crate::config::MAX_ARC_LENGTH);
        let m = crate::stereo_scale::measure_arc_length(
            &self.rig,
            &obs.cross_camera,
            |l| {
                let mut p = params.to_vec();
                p[arc_index] = l;
                self.estimator.motion(&p)
            },
            self.inlier_angle(),
            max,
            true,
        )?;
        let l = m.arc_length.abs();
        let ratio = self.config.odometry.max_arc_length_ratio;
        let plausible = self
            .last_arc_length
            .map(f64::abs)
            .is_none_or(|last| l <= ratio * last && l * ratio >= last);
        (l > self.config.odometry.standstill_arc_length
            && plausible
            && m.sigma <= self.config.odometry.max_relative_scale_sigma * l)
            .then_some(m)
    }

    /// The standard deviation of the arc length measured from cross-camera matches: the fit's
    /// own (other parameters known) and the other parameters' uncertainty (their calibrated
    /// covariance at `sol`, propagated through a refit along each principal axis).
    fn cross_scale_sigma(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        arc_index: usize,
        m: &crate::stereo_scale::CrossScale,
    ) -> f64 {
        let Some(cov) = self.covariance(sol) else {
            return f64::INFINITY;
        };
        let l = sol.params[arc_index];
        let eig = cov.symmetric_eigen();
        let mut var = m.sigma * m.sigma;
        let half = 0.5 * l.abs().max(m.arc_length.abs());
        let (lo, hi) = (l.min(m.arc_length) - half, l.max(m.arc_length) + half);
        for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
            if !(lambda > 0.0) {
                continue;
            }
            let step = eig.eigenvectors.column(k) * lambda.sqrt();
            let refit = |sign: f64| {
                let mut p = sol.params.clone();
                for (a, &f) in sol.free.iter().enumerate() {
                    p[f] += sign * step[a];
                }
                crate::stereo_scale::refit_arc_length(
                    &self.rig,
                    &obs.cross_camera,
                    |l| {
                        let mut q = p.clone();
                        q[arc_index] = l;
                        self.estimator.motion(&q)
                    },
                    self.inlier_angle(),
                    lo,
                    hi,
                )
            };
            let d = 0.5 * (refit(1.0) - refit(-1.0));
            var += d * d;
        }
        var.sqrt()
    }

    /// The standard deviation of an arc length estimated from the per-camera matches (no
    /// cross-camera matches: a mono rig's lever arm in a curve). As the calibrated covariance
    /// ([`trust::calibrated_covariance`]), except that a soft model's prior (side slip, climb)
    /// keeps its own strength: the calibrated covariance divides the whole normal matrix by the
    /// residual variance `σ²`, which also scales the soft prior's information `s² JᵀJ` by
    /// `(s/σ)²` (about 10x on KITTI) although the prior is no measurement. A mono rig's arc
    /// length is observed only through that prior (with a free direction of travel its
    /// information is zero), so there the inflated prior made a guess look measured: KITTI 01,
    /// mono, without odometry, 41 frames `estimated` at sigmas of 4-20 % with errors up to
    /// -78 % (the prior's centre drifts with the estimates,
    /// `odometry.soft_prior_centring_frames`). Infinite if the information does not determine
    /// the arc length.
    fn estimated_arc_length_sigma(&self, sol: &FrameSolution, arc_index: usize) -> f64 {
        let Some(k) = sol.free.iter().position(|&f| f == arc_index) else {
            return f64::INFINITY;
        };
        let mut inp = self.covariance_inputs(sol);
        // The soft prior's residuals (units of their sigmas) and their Jacobian over the free
        // parameters; its information at the learnt sigmas, if any.
        let (q0, jq) = self.soft_jacobian(&sol.params, &sol.free);
        let jtj = self.soft_information(&jq);
        let s = self.motion_prior.scale;
        if q0.is_empty() || !(s.is_finite() && s > 0.0) {
            return self
                .covariance(sol)
                .map_or(f64::INFINITY, |c| c[(k, k)].max(0.0).sqrt());
        }
        inp.normal -= &jtj * (s * s);
        let Some((mut info, _)) = trust::calibrated_information(&inp) else {
            return f64::INFINITY;
        };
        info += jtj;
        let info = (&info + info.transpose()) * 0.5;
        // The arc length's variance: the inverse's diagonal entry (Schur complement), infinite
        // where the information is singular in a direction that moves the arc length.
        trust::invert_information(&info)[(k, k)].max(0.0).sqrt()
    }

    fn scale_ok(&self, sol: &FrameSolution, arc_index: usize) -> bool {
        let l = sol.params[arc_index].abs();
        let sigma = self.estimated_arc_length_sigma(sol, arc_index);
        // Vehicle dynamics: the arc length cannot jump by more than a factor from one frame to
        // the next. Zero flow fits any translation, and an estimate that ran off along that
        // valley (100 m per frame at a standstill) can come with a small formal sigma.
        let ratio = self.config.odometry.max_arc_length_ratio;
        let plausible = self
            .last_arc_length
            .map(f64::abs)
            .is_none_or(|last| l <= ratio * last && l * ratio >= last);
        l > self.config.odometry.standstill_arc_length
            && l.is_finite()
            && plausible
            && sigma <= self.config.odometry.max_relative_scale_sigma * l
    }

    fn solve_once(
        &self,
        obs: &FrameObservations,
        init: &[f64],
        fixed: &[bool],
        rotation_only: bool,
    ) -> Option<FrameSolution> {
        self.solve_once_with(obs, init, fixed, rotation_only, self.config.solver.as_ref())
    }

    /// [`solve_once`](Self::solve_once) with another solver (the same loss, priors and
    /// refinement stage).
    fn solve_once_with(
        &self,
        obs: &FrameObservations,
        init: &[f64],
        fixed: &[bool],
        rotation_only: bool,
        solver: &dyn momo_core::Solver,
    ) -> Option<FrameSolution> {
        let req = SolveRequest {
            rig: &self.rig,
            observations: obs,
            loss: self.config.loss.as_ref(),
            solver,
            initial: init,
            fixed,
            rotation_only,
            motion_prior: Some(&self.motion_prior),
        };
        let usable = |sol: &FrameSolution| {
            sol.report.termination != Termination::NumericalFailure
                && sol.params.iter().all(|p| p.is_finite())
                && sol.report.final_cost.is_finite()
        };
        let sol = self.estimator.solve(&req).ok().filter(usable)?;
        let Some(refine) = self.config.refine_loss.as_deref() else {
            return Some(sol);
        };
        // The second stage: the refinement loss, started at the first stage's solution (costs
        // and inliers are then the refinement loss's); the first stage's answer is kept only
        // if the refinement fails.
        let req = SolveRequest {
            loss: refine,
            initial: &sol.params,
            ..req
        };
        match self.estimator.solve(&req).ok().filter(usable) {
            Some(mut refined) => {
                refined.report.iterations += sol.report.iterations;
                Some(refined)
            }
            None => Some(sol),
        }
    }

    /// The final efficient stage ([`crate::final_fit`], `odometry.final_fit`), with the arc
    /// length held where the frame holds it. `competing`: two motions competed in the frame's
    /// motion separation. Also the frame's counts of the learnt parallax cap
    /// ([`crate::final_fit::refit_tallied`]).
    fn final_fit(
        &self,
        obs: &FrameObservations,
        sol: FrameSolution,
        fixed: &[bool],
        scale: ScaleSource,
        competing: bool,
        constants: Option<&[f64]>,
        stage: Option<&crate::final_fit::StageSupport>,
    ) -> (
        FrameSolution,
        Option<crate::final_fit::ParallaxTally>,
        crate::final_fit::SupportMask,
    ) {
        let opts = &self.config.odometry.final_fit;
        if !opts.enabled {
            return (sol, None, None);
        }
        let fixed = self.stage_fixed(fixed, scale);
        let mut ctx = self.final_fit_context(&fixed, competing);
        ctx.constants = constants;
        ctx.stage = stage;
        // `odometry.tilt_hold_stage = "final"`: the frame's tilt hold in this stage's prior only.
        let stage_hold = self.frame_hold_prior(TiltHoldStage::Final);
        if let Some(held) = &stage_hold {
            ctx.motion_prior = held;
        }
        // `"report"`: the same refit once more with the hold, kept beside it for the report.
        let report_hold = self.frame_hold_prior(TiltHoldStage::Report);
        let start = report_hold.as_ref().map(|_| sol.clone());
        let out = crate::final_fit::refit_supported(&ctx, opts, obs, sol);
        if let (Some(held), Some(start)) = (&report_hold, start) {
            ctx.motion_prior = held;
            let (fin, _, _) = crate::final_fit::refit_supported(&ctx, opts, obs, start);
            if let Ok(mut refits) = self.held_refits.lock() {
                refits.push((out.0.params.clone(), fin.params));
            }
        }
        out
    }

    /// The final stage's motion prior with this frame's tilt hold, where the hold acts on the
    /// frame and `odometry.tilt_hold_stage` is `stage`.
    fn frame_hold_prior(&self, stage: TiltHoldStage) -> Option<MotionPrior> {
        if self.config.odometry.tilt_hold_stage != stage {
            return None;
        }
        let (center, inv_sigma) = self.frame_tilt_hold.as_ref()?;
        Some(MotionPrior {
            center: center.clone(),
            inv_sigma: inv_sigma.clone(),
            ..self.motion_prior.clone()
        })
    }

    /// The previous motion's basin on a rig (`odometry.previous_basin_change`, 1 deg by default, off at 0): where
    /// the final stage's rotation `R` differs from the previous frame's `R_prev` by more than
    /// the option (`|log(R_prevᵀ R)|`), on a rig of at least two cameras, the frame is solved
    /// again from the previous frame's motion (its arc length the frame's) by the final stage
    /// (the first stage slides into an object's basin from there); that solution is returned
    /// with its stage's parallax tally and support (the frame's where it is taken) and
    /// whether the cameras vote for it
    /// ([`basin_vote`] over the matches within `previous_basin_band` of the epipolar planes,
    /// [`crate::separate::epipolar_at_least`]). Spatial support, counted per camera: the static
    /// world is seen by every camera and fits the true motion tightly in each, a compact object
    /// only in one or two (docs/RESULTS.md §9, twenty-ninth session, rigslow43).
    ///
    /// On a single camera (`odometry.previous_basin_regions`, off by default) the voters are
    /// the cells of a coarse grid over the image ([`basin_cell_counts`]), triggered by
    /// `previous_basin_mono_change` with margin `previous_basin_mono_votes` and band
    /// `previous_basin_mono_band` (thirtieth session, monobasin44).
    fn previous_basin(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
        scale: ScaleSource,
        competing: bool,
    ) -> Option<(
        FrameSolution,
        Option<crate::final_fit::ParallaxTally>,
        crate::final_fit::SupportMask,
        bool,
    )> {
        let o = &self.config.odometry;
        let regions = (o.previous_basin_regions[0], o.previous_basin_regions[1]);
        let mono = self.rig.len() < 2;
        let (change, votes) = if mono {
            if regions.0 * regions.1 == 0 {
                return None;
            }
            (
                if o.previous_basin_mono_change > 0.0 {
                    o.previous_basin_mono_change
                } else {
                    o.previous_basin_change
                },
                if o.previous_basin_mono_next_votes > 0
                    && self
                        .previous_basin_taken_frame
                        .is_some_and(|f| f + 1 == self.frame)
                {
                    o.previous_basin_mono_next_votes
                } else if o.previous_basin_mono_votes > 0 {
                    o.previous_basin_mono_votes
                } else {
                    o.previous_basin_votes
                },
            )
        } else {
            (o.previous_basin_change, o.previous_basin_votes)
        };
        if change <= 0.0 {
            return None;
        }
        let r_prev = self.estimator.motion(&self.previous).rotation;
        let r = self.estimator.motion(&sol.params).rotation;
        if so3_log(&(r_prev.transpose() * r)).norm() <= change {
            return None;
        }
        let mut start = self.previous.clone();
        if let Some(i) = self.estimator.arc_length_index() {
            start[i] = sol.params[i];
        }
        // The final stage from the previous motion (the first stage would slide into the
        // object's basin from there: measured on the cut, RESULTS).
        let mut from = sol.clone();
        from.params = start;
        let (alt, tally, support) = self.final_fit(obs, from, fixed, scale, competing, None, None);
        let band = if mono && o.previous_basin_mono_band > 0.0 {
            o.previous_basin_mono_band
        } else {
            o.previous_basin_band
        };
        let inside = |params: &[f64]| -> Vec<usize> {
            if mono {
                self.cells_within(obs, params, band, regions)
            } else {
                crate::separate::epipolar_at_least(
                    &self.rig,
                    &self.estimator.motion(params),
                    obs,
                    band,
                )
                .iter()
                .map(|cam| cam.iter().filter(|outside| !**outside).count())
                .collect()
            }
        };
        let taken = basin_vote(&inside(&sol.params), &inside(&alt.params), votes);
        Some((alt, tally, support, taken))
    }

    /// `odometry.competing_regions`: on a single camera, the frame's competing motion
    /// (`competing`: its full parameters and weight, [`FrameDiagnostics::competing`]) voted
    /// against the frame's solution by the cells of a coarse image grid
    /// ([`basin_cell_counts`], [`basin_vote`]; band `competing_region_band`, margin
    /// `competing_region_votes`): the solution to keep where the cells vote for the competing
    /// motion (with `competing_region_refit` the final stage run again from it) and whether
    /// the cells voted for it; `None` where it does not vote (off, a rig, no competing motion).
    /// A compact object that holds most of the matches covers few cells, the static world many
    /// (docs/RESULTS.md §9, thirty-first session, cutin45).
    fn competing_region(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
        scale: ScaleSource,
        competing: bool,
        alternative: Option<&(Vec<f64>, f64)>,
    ) -> Option<(FrameSolution, bool)> {
        let o = &self.config.odometry;
        let grid = (o.competing_regions[0], o.competing_regions[1]);
        if grid.0 * grid.1 == 0 || self.rig.len() >= 2 {
            return None;
        }
        let (params, _) = alternative?;
        let inside = |p: &[f64]| self.cells_within(obs, p, o.competing_region_band, grid);
        let here = inside(&sol.params);
        // `competing_region_concentration`: the frame's support in its fullest third of cells.
        let concentration = o.competing_region_concentration;
        if concentration > 0.0 {
            let mut sorted = here.clone();
            sorted.sort_unstable_by(|a, b| b.cmp(a));
            let top: usize = sorted[..sorted.len().div_ceil(3)].iter().sum();
            let all: usize = sorted.iter().sum();
            if (top as f64) < concentration * all as f64 {
                return Some((sol.clone(), false));
            }
        }
        // `competing_region_continuing`: the competing motion's rotation closer than the frame's
        // own to the previous frame's (`competing_region_continuing_frames = K`: to at least one
        // of the last `K` frames').
        let rotation = |p: &[f64]| self.estimator.motion(p).rotation;
        let (own, other) = (rotation(&sol.params), rotation(params));
        if o.competing_region_continuing {
            let references: Vec<Matrix3<f64>> = if o.competing_region_continuing_frames > 1 {
                self.recent_motions.iter().map(|m| rotation(m)).collect()
            } else {
                vec![rotation(&self.previous)]
            };
            if !continues_any(&references, &own, &other) {
                return Some((sol.clone(), false));
            }
        }
        // `competing_region_yaw_ratio`: the two motions differ mainly in yaw.
        if o.competing_region_yaw_ratio > 0.0
            && !yaw_dominant(&own, &other, o.competing_region_yaw_ratio)
        {
            return Some((sol.clone(), false));
        }
        let refit = o.competing_region_refit.then(|| {
            let mut from = sol.clone();
            from.params = params.clone();
            self.final_fit(obs, from, fixed, scale, competing, None, None)
                .0
        });
        let candidate = refit.as_ref().map_or(params, |s| &s.params);
        let there = inside(candidate);
        let taken = basin_vote(&here, &there, o.competing_region_votes);
        let chosen = refit.unwrap_or_else(|| {
            let mut s = sol.clone();
            s.params = params.clone();
            s
        });
        Some((chosen, taken))
    }

    /// Per cell of a `grid` (columns, rows) over the image, the matches within `band`
    /// (radians of epipolar angle) of the epipolar planes at the motion `params`
    /// ([`basin_cell_counts`] of [`crate::separate::epipolar_at_least`]): the voters of the
    /// region votes (`previous_basin_regions`, `competing_regions`).
    fn cells_within(
        &self,
        obs: &FrameObservations,
        params: &[f64],
        band: f64,
        grid: (usize, usize),
    ) -> Vec<usize> {
        let within = crate::separate::epipolar_at_least(
            &self.rig,
            &self.estimator.motion(params),
            obs,
            band,
        );
        basin_cell_counts(&self.rig, obs, &within, grid)
    }

    /// `odometry.previous_basin_handoff`: the separation's match memory and its tilt, yaw and
    /// road history moved to the previous motion's basin where it was taken (as
    /// `decide_by_road` does for its alternative); nothing where the separation or its
    /// hypotheses are off.
    fn previous_basin_handoff(&mut self, obs: &FrameObservations, params: &[f64]) {
        if let Some((score, support)) = self.road_score_of(obs, params) {
            self.hand_off_separation(obs, params, score, &support, true);
        }
    }

    /// The final stage's fixed parameters: the frame's `fixed`, and the arc length where the
    /// frame holds it (`scale` not [`ScaleSource::Estimated`]).
    fn stage_fixed(&self, fixed: &[bool], scale: ScaleSource) -> Vec<bool> {
        let mut fixed = fixed.to_vec();
        if let Some(i) = self.estimator.arc_length_index()
            && scale != ScaleSource::Estimated
        {
            fixed[i] = true;
        }
        fixed
    }

    /// The final stage's matches after the support's tests: the matches `next` hands the stage
    /// less `road_out` (the under-the-road test's, [`crate::separate::under_road_left_out`]),
    /// then less the support's members whose neighbours are mostly outside it (at `from`; the
    /// neighbourhood test, `odometry.final_fit.neighbour_share`,
    /// [`crate::final_fit::neighbour_kept`], on a rig of at least `neighbour_min_cameras`
    /// cameras, by default one; not where it would leave fewer than half), as
    /// [`crate::separate::NextStage::FinalFitOn`]; `None` where neither test leaves anything
    /// out. Where one does, `neighbour_guard` compares the stage on these matches with the
    /// stage on those `next` hands it.
    #[allow(clippy::too_many_arguments)]
    fn neighbour_stage(
        &self,
        obs: &FrameObservations,
        next: &crate::separate::NextStage,
        road_out: Option<&[Vec<bool>]>,
        from: &[f64],
        fixed: &[bool],
        scale: ScaleSource,
        competing: bool,
    ) -> Option<crate::separate::NextStage> {
        let opts = &self.config.odometry.final_fit;
        let n = |m: &[Vec<bool>]| m.iter().flatten().filter(|k| **k).count();
        let handed = next.given(obs)?;
        let given = road_out.map_or_else(
            || handed.clone(),
            |out| crate::separate::and(&handed, &crate::separate::not(out)),
        );
        let neighbours = || {
            if !(opts.enabled
                && opts.neighbour_share > 0.0
                && self.rig.len() >= opts.neighbour_min_cameras)
            {
                return None;
            }
            let fixed = self.stage_fixed(fixed, scale);
            let ctx = self.final_fit_context(&fixed, competing);
            let chosen = crate::separate::subset(obs, &given);
            let kept = crate::final_fit::support_mask(&ctx, opts, &chosen, from)?;
            let support = superset_mask(&given, &kept);
            let reduced = crate::final_fit::neighbour_kept(
                obs,
                &given,
                &support,
                opts.neighbour_count,
                opts.neighbour_share,
            );
            let (before, after) = (n(&given), n(&reduced));
            (after < before && 2 * after >= before).then_some(reduced)
        };
        let reduced = neighbours().unwrap_or_else(|| given.clone());
        (n(&reduced) < n(&handed)).then_some(crate::separate::NextStage::FinalFitOn(reduced))
    }

    /// The final stage on the matches `given` handed the neighbourhood test, from `start`
    /// (`odometry.final_fit.neighbour_guard`): its solution, parallax tally and support among
    /// all the frame's matches. The stage computes its match constants and first support
    /// itself (no cached ones, as in [`Self::previous_basin`]): those caches save work only.
    fn guard_stage(
        &self,
        obs: &FrameObservations,
        given: &crate::separate::NextStage,
        start: FrameSolution,
        fixed: &[bool],
        scale: ScaleSource,
        competing: bool,
    ) -> (
        FrameSolution,
        Option<crate::final_fit::ParallaxTally>,
        crate::final_fit::SupportMask,
    ) {
        let mask = given.given(obs).unwrap_or_default();
        let chosen = crate::separate::subset(obs, &mask);
        let (sol, tally, kept) =
            self.final_fit(&chosen, start, fixed, scale, competing, None, None);
        (sol, tally, kept.map(|k| superset_mask(&mask, &k)))
    }

    /// Whether the re-admission (`odometry.final_fit.readmit_share`) is on: a rig of several
    /// cameras, the final stage on, and (with `readmit_skip_cauchy`) no Cauchy climb scales in
    /// the frame's motion prior.
    fn readmit_on(&self) -> bool {
        let opts = &self.config.odometry.final_fit;
        opts.enabled
            && opts.readmit_share > 0.0
            && self.rig.len() > 1
            && (!opts.readmit_skip_cauchy || self.motion_prior.soft_cauchy.is_empty())
    }

    /// The re-admission (`odometry.final_fit.readmit_share`, [`crate::final_fit::readmit_kept`])
    /// on a rig of several cameras: the matches `next` handed the final stage plus those left
    /// out that pass the stage's tests at its final motion `at` among passing neighbours; the
    /// stage again on them from the first stage's solution `before` (the same
    /// [`Self::final_fit`]), with its support among all the frame's matches. `None` where it is
    /// off, re-admits nothing, or the stage was handed every match.
    #[allow(clippy::too_many_arguments)]
    fn readmit_stage(
        &self,
        obs: &FrameObservations,
        next: &crate::separate::NextStage,
        before: FrameSolution,
        at: &[f64],
        fixed: &[bool],
        scale: ScaleSource,
        competing: bool,
    ) -> Option<(
        FrameSolution,
        Option<crate::final_fit::ParallaxTally>,
        crate::final_fit::SupportMask,
    )> {
        if !self.readmit_on() {
            return None;
        }
        let crate::separate::NextStage::FinalFitOn(given) = next else {
            return None;
        };
        let opts = &self.config.odometry.final_fit;
        let stage_fixed = self.stage_fixed(fixed, scale);
        let ctx = self.final_fit_context(&stage_fixed, competing);
        let passing: Vec<Vec<bool>> = crate::final_fit::passing_at(&ctx, opts, obs, given, at)?
            .into_iter()
            .map(|c| c.into_iter().map(|(ok, _)| ok).collect())
            .collect();
        let mask = crate::final_fit::readmit_kept(
            obs,
            given,
            &passing,
            opts.readmit_count,
            opts.readmit_share,
        );
        if mask == *given {
            return None;
        }
        let chosen = crate::separate::subset(obs, &mask);
        let m = self.final_fit_estimator().match_constant_count();
        let constants = self
            .frame_constants
            .as_deref()
            .and_then(|c| subset_constants(c, m, &mask));
        let (sol, tally, kept) = self.final_fit(
            &chosen,
            before,
            fixed,
            scale,
            competing,
            constants.as_deref(),
            None,
        );
        Some((sol, tally, kept.map(|k| superset_mask(&mask, &k))))
    }

    /// The standstill's rotation-only solve with `odometry.standstill_at_rest`: from `init`
    /// (no rotation) on the matches that do not move (`odometry.standstill_still_angle`) where
    /// there are enough of them (capped per image cell with `odometry.standstill_cell_cap`),
    /// else on all matches; the restarts only where that fails. Returns the solution and the
    /// matches it read where they are not all of the frame's.
    fn solve_at_rest(
        &self,
        obs: &FrameObservations,
        init: &[f64],
        fixed: &[bool],
        diag: &mut FrameDiagnostics,
    ) -> Option<(FrameSolution, Option<FrameObservations>)> {
        let opts = &self.config.odometry;
        let cut = opts.standstill_still_angle;
        if cut > 0.0 {
            let sin = cut.sin();
            let mut still: Vec<Vec<bool>> = obs
                .per_camera
                .iter()
                .map(|ms| ms.iter().map(|o| o.f0.cross(&o.f1).norm() < sin).collect())
                .collect();
            let n = still.iter().flatten().filter(|s| **s).count();
            if n >= 12 && 10 * n >= obs.len() {
                if opts.standstill_cell_cap > 0.0 {
                    let grid = opts.separate.as_ref().map_or((16, 8), |s| s.cell_cap_grid);
                    still = crate::separate::cell_capped(
                        &self.rig,
                        obs,
                        &still,
                        grid,
                        opts.standstill_cell_cap,
                    );
                }
                // (All of them: the frame's own.)
                let read = (!still.iter().flatten().all(|s| *s))
                    .then(|| crate::separate::subset(obs, &still));
                if let Some(sol) = self.solve_once(read.as_ref().unwrap_or(obs), init, fixed, true)
                {
                    return Some((sol, read));
                }
            }
        }
        // All matches; the restarts only where that solve fails (it is then repeated once as
        // their first start, and fails again).
        self.solve_once(obs, init, fixed, true)
            .or_else(|| self.solve_with_restarts(obs, init, fixed, true, diag))
            .map(|sol| (sol, None))
    }

    /// The standstill's leave-one-cell-out jackknife (`odometry.standstill_jackknife`): the
    /// rotation-only solve repeated without each cell of every `[trust] jackknife_grids` grid
    /// on the matches `read` it read, from its solution; the reported covariance widened where
    /// that jackknife's is wider ([`trust::widen`], `trust.jackknife_min_ratio`).
    fn widen_standstill_by_jackknife(
        &self,
        read: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
        diag: &mut FrameDiagnostics,
    ) {
        let k = sol.free.len();
        if k == 0 || diag.covariance.len() != k * k {
            return;
        }
        let t = &self.config.trust;
        let before = nalgebra::DMatrix::from_row_slice(k, k, &diag.covariance);
        let mut cov = before.clone();
        for &[gx, gy] in &t.jackknife_grids {
            let samples: Vec<Vec<f64>> = trust::leave_one_cell_out(&self.rig, read, (gx, gy))
                .iter()
                .filter_map(|o| self.solve_once(o, &sol.params, fixed, true))
                .map(|s| sol.free.iter().map(|&i| s.params[i]).collect())
                .collect();
            if let Some(j) = trust::jackknife_covariance(&samples) {
                cov = trust::widen(&cov, &j, t.jackknife_min_ratio);
            }
        }
        report_widened(&before, cov, &sol.free, diag);
    }

    fn solve_with_restarts(
        &self,
        obs: &FrameObservations,
        init: &[f64],
        fixed: &[bool],
        standstill: bool,
        diag: &mut FrameDiagnostics,
    ) -> Option<FrameSolution> {
        let first = self.solve_once(obs, init, fixed, standstill);
        let ratio = |s: &FrameSolution| s.inliers() as f64 / obs.len().max(1) as f64;
        let threshold =
            self.config.odometry.restart_inlier_ratio * self.inlier_ratio_average.unwrap_or(0.0);
        if first.as_ref().is_some_and(|s| ratio(s) >= threshold) {
            return first;
        }
        // The result looks bad: try more starts and keep the lowest cost.
        let mut best = first;
        for start in self.restart_points(init) {
            diag.restarts += 1;
            let Some(sol) = self.solve_once(obs, &start, fixed, standstill) else {
                continue;
            };
            let better = best
                .as_ref()
                .is_none_or(|b| sol.report.final_cost < b.report.final_cost * (1.0 - 1e-9));
            if better {
                best = Some(sol);
                diag.restart_won = true;
            }
        }
        best
    }

    /// Extra starts: straight ahead, and the previous motion turned by the configured yaw
    /// offsets (where the model can express a motion in closed form).
    fn restart_points(&self, init: &[f64]) -> Vec<Vec<f64>> {
        let arc = self.estimator.arc_length_index().map_or(1.0, |i| init[i]);
        let mut starts = vec![self.estimator.initial_params(arc)];
        // The previous motion turned, its (possibly fixed) arc length kept.
        starts.extend(
            self.config
                .odometry
                .restart_yaw_offsets
                .iter()
                .filter_map(|&dy| crate::yaw_votes::turned(self.estimator.as_ref(), init, dy)),
        );
        starts
    }

    /// The road's alternative of a frame whose chosen motion's road score dropped
    /// (`odometry.separate.ground_drop`): the previous frame's motion `previous` (the frame's
    /// start, its arc length held where odometry gives it) re-solved without the motion prior
    /// on the matches it puts on the road ([`crate::hypotheses::ground_mask`]; the separation's
    /// continued track of the static world). `None` without the multi-frame choice's options,
    /// with fewer than 12 road matches, or where the solve fails.
    fn road_alternative(
        &self,
        obs: &FrameObservations,
        previous: &[f64],
        fixed: &[bool],
    ) -> Option<FrameSolution> {
        let h = self.separation()?.hypotheses()?;
        let all: Vec<Vec<bool>> = obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
        let road = crate::hypotheses::ground_mask(
            &self.rig,
            &self.estimator.motion(previous),
            obs,
            &all,
            h,
        );
        if road.iter().flatten().filter(|r| **r).count() < 12 {
            return None;
        }
        let ctx = crate::separate::SolveContext {
            rig: &self.rig,
            estimator: self.estimator.as_ref(),
            loss: self.config.loss.as_ref(),
            solver: self.config.solver.as_ref(),
            fixed,
            motion_prior: None,
        };
        ctx.solve(
            &crate::separate::subset(obs, &road),
            previous,
            self.config.loss.as_ref(),
            false,
        )
    }

    /// Widens the reported covariance of a frame whose road score dropped by its road's
    /// alternatives (`trust.road_alternative_weight` `w`) about the estimate `about` (`free`
    /// its free parameters): `Σ + w (d_c d_cᵀ + d_p d_pᵀ)`, `d_c` the road's alternative
    /// ([`Odometry::road_alternative`], where there is one) less the estimate, `d_p` the
    /// previous frame's motion `previous` less the estimate ([`Widened::widen`]). Nothing where
    /// the weight is 0.
    ///
    /// Returns the road's alternative's parameters where `odometry.decide_by_road` is to see
    /// them: where the frame's covariance can be widened (a free parameter, a covariance), as
    /// at weight 1, whatever the weight (the weight changes the report only, not the choice).
    fn widen_by_road_alternative(
        &self,
        obs: &FrameObservations,
        previous: &[f64],
        fixed: &[bool],
        (free, about): (&[usize], &[f64]),
        diag: &mut FrameDiagnostics,
        widened: &mut Widened,
    ) -> Option<Vec<f64>> {
        let w = self.config.trust.road_alternative_weight;
        let k = free.len();
        let widenable = k > 0 && diag.covariance.len() == k * k;
        if !(w > 0.0 || (self.config.odometry.decide_by_road > 0 && widenable)) {
            return None;
        }
        let c = self
            .road_alternative(obs, previous, fixed)
            .map(|c| c.params);
        let mut alternatives = vec![previous];
        alternatives.extend(c.as_deref());
        if widened.widen(&alternatives, w, free, about, diag) {
            diag.road_alternative = c.clone();
        }
        c.filter(|_| widenable)
    }

    /// Whether `trust.support_change_share` fires on a moving frame whose rotation vector
    /// changed by `change` (`ω − ω_prev`, vehicle frame) from the previous moving frame's: its
    /// inlier share `n_in / n` below `s` with `|Δω_z|` above `support_change_yaw` or
    /// `|(Δω_x, Δω_y)|` above `support_change_tilt` (where set), or below
    /// `support_change_hold_share` right after a frame where it fired.
    fn support_change_fires(
        &self,
        change: nalgebra::Vector3<f64>,
        diag: &FrameDiagnostics,
    ) -> bool {
        let t = &self.config.trust;
        if diag.matches == 0 {
            return false;
        }
        let share = diag.inliers as f64 / diag.matches as f64;
        let jump = change.z.abs() > t.support_change_yaw
            || (t.support_change_tilt > 0.0 && change.x.hypot(change.y) > t.support_change_tilt);
        (share < t.support_change_share && jump)
            || (self.support_change_fired && share < t.support_change_hold_share)
    }

    /// The standard deviation (radians) of the yaw `ω_z` of the motion `params` under the
    /// frame's reported covariance (over `diag.free`): `√(gᵀ Σ g)` with `g` the yaw's gradient by
    /// central differences, so any motion model has one. `None` where the frame reports no
    /// finite covariance.
    fn yaw_sigma(&self, params: &[f64], diag: &FrameDiagnostics) -> Option<f64> {
        let k = diag.free.len();
        if k == 0 || diag.covariance.len() != k * k {
            return None;
        }
        let yaw = |p: &[f64]| so3_log(&self.estimator.motion(p).rotation).z;
        const STEP: f64 = 1e-6;
        let g: Vec<f64> = diag
            .free
            .iter()
            .map(|&i| {
                let (mut hi, mut lo) = (params.to_vec(), params.to_vec());
                hi[i] += STEP;
                lo[i] -= STEP;
                (yaw(&hi) - yaw(&lo)) / (2.0 * STEP)
            })
            .collect();
        let mut v = 0.0;
        for (a, ga) in g.iter().enumerate() {
            for (b, gb) in g.iter().enumerate() {
                v += ga * diag.covariance[a * k + b] * gb;
            }
        }
        (v.is_finite() && v >= 0.0).then(|| v.sqrt())
    }

    /// The yaw's change against the previous frame's reported motion
    /// (`trust.yaw_change` `J`, `trust.yaw_change_weight` `w`): where the change
    /// `|Δω_z| = |ω_z − ω_z,prev|` exceeds `J` (a car's yaw rate changes smoothly, so one of
    /// the two frames is wrong), the frame is
    /// flagged `weak` / `yaw_change` if it was `estimated`, and its reported covariance adds
    /// the previous frame's motion `p` as an alternative, `Σ + w d dᵀ`, `d = p − a`. Called
    /// after the frame's state is updated: the next frame's prior, the after-flag widening
    /// and the separation's history see the frame as it was, so no pose changes.
    fn flag_yaw_change(&self, change: f64, params: &[f64], diag: &mut FrameDiagnostics) {
        let t = &self.config.trust;
        if t.yaw_change <= 0.0 || !(change.abs() > t.yaw_change) {
            return;
        }
        flag_weak_report_only(diag, Reason::YawChange);
        let free = diag.free.clone();
        // The previous frame's reported motion (its held twin where `tilt_hold_stage =
        // "report"` reported one).
        let previous = self.previous_reported.as_ref().unwrap_or(&self.previous);
        Self::widen_by_alternatives_at(&[previous], t.yaw_change_weight, &free, params, diag);
    }

    /// Widens the reported covariance by alternatives to the estimate `params` (each all of the
    /// model's parameters; `free` the free ones) with weight `w`
    /// ([`trust::alternatives_covariance`] over the free parameters): `Σ + w Σ_j d_j d_jᵀ`; the
    /// sigmas grow by the same variances. Returns whether it did (not where `w` is 0 or the
    /// frame has no covariance).
    fn widen_by_alternatives_at(
        alternatives: &[&[f64]],
        w: f64,
        free_params: &[usize],
        params: &[f64],
        diag: &mut FrameDiagnostics,
    ) -> bool {
        let k = free_params.len();
        if w <= 0.0 || k == 0 || diag.covariance.len() != k * k {
            return false;
        }
        let free = |p: &[f64]| -> Vec<f64> {
            free_params
                .iter()
                .map(|&i| p.get(i).copied().unwrap_or(f64::NAN))
                .collect()
        };
        let a = free(params);
        let alternatives: Vec<Vec<f64>> = alternatives.iter().map(|p| free(p)).collect();
        let alternatives: Vec<&[f64]> = alternatives.iter().map(Vec::as_slice).collect();
        let cov = nalgebra::DMatrix::from_row_slice(k, k, &diag.covariance);
        let wide = trust::alternatives_covariance(&cov, &a, &alternatives, w);
        report_widened(&cov, wide, free_params, diag);
        true
    }

    /// The calibrated covariance of the free parameters ([`trust::calibrated_covariance`]).
    fn covariance(&self, sol: &FrameSolution) -> Option<nalgebra::DMatrix<f64>> {
        trust::calibrated_covariance(&self.covariance_inputs(sol))
    }

    /// The reported covariance: the calibrated one, widened where the leave-one-cell-out
    /// jackknife is wider ([`trust::jackknife_covariance`], `trust.jackknife_grid`).
    ///
    /// Returns that covariance and the one to report, which the grids of
    /// `trust.report_grids` widen further (the first is the one the competing-motions test
    /// reads, so that those grids do not change a status), and this frame's jackknife
    /// covariance of each report grid (`None` where it is not defined; empty where the
    /// jackknife did not run), which `trust.report_pool_frames` pools over frames.
    fn reported_covariance(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        jackknife: bool,
        clustered: bool,
        soft_view: Option<&SoftView>,
    ) -> Option<(
        nalgebra::DMatrix<f64>,
        nalgebra::DMatrix<f64>,
        GridJackknives,
    )> {
        let n_params = self.estimator.param_names().len();
        let fixed: Vec<bool> = (0..n_params).map(|i| !sol.free.contains(&i)).collect();
        let n = sol.free.len();
        // The covariance before the widenings, from the first stage's inputs as `adjust` leaves
        // them.
        let base = |adjust: &dyn Fn(&mut trust::CovarianceInputs)| match self
            .unlearnt_prior_covariance(sol, adjust)
        {
            Some(c) => Some(c),
            None => {
                let mut inp = self.covariance_inputs(sol);
                adjust(&mut inp);
                trust::calibrated_covariance(&inp)
            }
        };
        let mut cov = base(&|_| {})?;
        // `trust.report_covariance`: the reported covariance's own chain from its own start,
        // through the same widenings (report only: `cov` stays the status tests' and the
        // jackknife's).
        // (With `trust.prior_spread_covariance` before the soft prior is learnt, the soft
        // prior's information is taken out of the refit's normal matrix in the first stage's
        // units.)
        let refit = || {
            sol.refit_curvature.as_ref().and_then(|r| {
                base(&|inp| {
                    let (normal, cost, support) = r;
                    inp.normal = normal.view((0, 0), (n, n)).into_owned();
                    inp.cost = *cost;
                    inp.inliers = *support;
                })
            })
        };
        let mut rep = match self.config.trust.report_covariance {
            trust::ReportCovariance::FirstStage => None,
            trust::ReportCovariance::Sandwich => self
                .sandwich_sigma2(obs, sol, &fixed)
                .and_then(|s2| base(&|inp| inp.sigma2 = Some(s2))),
            trust::ReportCovariance::Refit => refit(),
        }
        .filter(|c| c.shape() == cov.shape());
        // `trust.ill_conditioned_refit`: a first-stage covariance with an unconstrained
        // direction, where the final stage's own curvature constrains every direction.
        if rep.is_none() && self.config.trust.ill_conditioned_refit && !all_finite(&cov) {
            rep = refit().filter(|c| c.shape() == cov.shape() && all_finite(c));
        }
        // Every widening below acts on both chains alike.
        let both =
            |cov: &mut nalgebra::DMatrix<f64>,
             rep: &mut Option<nalgebra::DMatrix<f64>>,
             f: &dyn Fn(&nalgebra::DMatrix<f64>) -> nalgebra::DMatrix<f64>| {
                if let Some(r) = rep.as_mut() {
                    *r = f(r);
                }
                *cov = f(cov);
            };
        // Where the data contradict the soft prior, its pull on the estimate is an error the
        // posterior covariance does not hold: add it (`trust.prior_conflict_chi2`).
        if let Some(b) = self.prior_conflict_shift(sol, soft_view)
            && b.len() == cov.nrows()
        {
            let bb = &b * b.transpose();
            both(&mut cov, &mut rep, &|c| c + &bb);
        }
        // Where the true slip is heavy-tailed, the prior at its learnt (median) width is
        // over-confident: hold it at the mean-square spread (`trust.prior_spread_covariance`).
        if let Some(w) = self.prior_spread_widening(sol)
            && w.nrows() == cov.nrows()
        {
            both(&mut cov, &mut rep, &|c| c + &w);
        }
        if !jackknife {
            let reported = rep.unwrap_or_else(|| cov.clone());
            return Some((cov, reported, Vec::new()));
        }
        let t = &self.config.trust;
        let extra: &[[usize; 2]] = if clustered { &t.clustering_grids } else { &[] };
        // The one-linearisation jackknife: the frame's exact Hessian and gradient and every
        // grid's cells' data terms, in one pass over the matches; the report-only grids last.
        let grids: Vec<(usize, usize)> = t
            .jackknife_grids
            .iter()
            .chain(extra)
            .chain(&t.report_grids)
            .map(|&[gx, gy]| (gx, gy))
            .collect();
        let status_grids = grids.len() - t.report_grids.len();
        let mut status_cov = None;
        let mut report_jackknife = Vec::with_capacity(t.report_grids.len());
        // (No grid: nothing to linearise.)
        let frame = if t.jackknife_influence && !grids.is_empty() {
            self.influence_frame(obs, sol, &fixed, &grids)
        } else {
            None
        };
        for (k, &(gx, gy)) in grids.iter().enumerate() {
            if k == status_grids {
                status_cov = Some(cov.clone());
            }
            let samples: Vec<Vec<f64>> = match &frame {
                Some(f) => self.influence_samples(
                    f,
                    k,
                    obs,
                    sol,
                    &fixed,
                    &cov,
                    (gx, gy),
                    k >= status_grids,
                ),
                None => trust::leave_one_cell_out(&self.rig, obs, (gx, gy))
                    .iter()
                    .filter_map(|o| self.jackknife_sample(o, sol, &fixed))
                    .collect(),
            };
            let j = trust::jackknife_covariance(&samples);
            if k < status_grids {
                if let Some(j) = j {
                    both(&mut cov, &mut rep, &|c| {
                        trust::widen(c, &j, t.jackknife_min_ratio)
                    });
                }
                continue;
            }
            // A report grid: its jackknife, pooled with the recent frames' where
            // `trust.report_pool_frames` asks for it.
            let pooled = if t.report_pool_frames > 1 {
                if t.report_pool_own
                    && let Some(j) = j.as_ref()
                {
                    both(&mut cov, &mut rep, &|c| {
                        trust::widen(c, j, t.report_min_ratio)
                    });
                }
                self.pooled_report_jackknife(k - status_grids, sol, j.as_ref(), &cov)
            } else {
                j.clone()
            };
            if let Some(p) = pooled {
                both(&mut cov, &mut rep, &|c| {
                    trust::widen(c, &p, t.report_min_ratio)
                });
            }
            report_jackknife.push(j);
        }
        let status = status_cov.unwrap_or_else(|| cov.clone());
        Some((status, rep.unwrap_or(cov), report_jackknife))
    }

    /// The mean of the report grid `index`'s jackknife covariance over this frame's (`own`)
    /// and the pooled recent frames' (`trust.report_pool_frames` `m`: those up to `m - 1`
    /// frames back with the same free parameters and a defined covariance of that grid):
    /// `J̄ = (1/n) Σ_j J_j`, without the `trust.report_pool_trim` widest against `cov` (by
    /// `tr(Σ⁻¹ J)`) where more are pooled. `None` where none is defined.
    fn pooled_report_jackknife(
        &self,
        index: usize,
        sol: &FrameSolution,
        own: Option<&nalgebra::DMatrix<f64>>,
        cov: &nalgebra::DMatrix<f64>,
    ) -> Option<nalgebra::DMatrix<f64>> {
        let m = self.config.trust.report_pool_frames;
        let recent = self
            .report_pool
            .iter()
            .filter(|(frame, free, _)| {
                *frame < self.frame && self.frame - *frame < m && *free == sol.free
            })
            .filter_map(|(_, _, js)| js.get(index).and_then(Option::as_ref));
        let mut pool: Vec<&nalgebra::DMatrix<f64>> = own.into_iter().chain(recent).collect();
        let trim = self.config.trust.report_pool_trim;
        if trim > 0 && pool.len() > trim {
            // The widest against `cov`: tr(Σ⁻¹ J) (where Σ is not invertible, no trim).
            if let Some(inv) = cov.clone().try_inverse() {
                let width = |j: &nalgebra::DMatrix<f64>| -> f64 {
                    if j.shape() == inv.shape() {
                        (&inv * j).trace()
                    } else {
                        f64::INFINITY
                    }
                };
                pool.sort_by(|a, b| width(a).total_cmp(&width(b)));
                pool.truncate(pool.len() - trim);
            }
        }
        let mut sum: Option<nalgebra::DMatrix<f64>> = None;
        let mut n = 0usize;
        for j in pool {
            match sum.as_mut() {
                Some(s) if s.shape() == j.shape() => *s += j,
                Some(_) => continue,
                None => sum = Some(j.clone()),
            }
            n += 1;
        }
        sum.map(|s| s / n as f64)
    }

    /// One leave-one-cell-out re-estimate of the jackknife (its free parameters) from the
    /// matches `obs` without one cell: `trust.jackknife_steps` Gauss-Newton steps from the
    /// frame's solution, each one linearisation of the same cost the solver minimised (loss,
    /// priors), or a full solve where it is 0. `None` where a step is not defined (the normal
    /// matrix not positive definite, a non-finite point).
    fn jackknife_sample(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
    ) -> Option<Vec<f64>> {
        self.jackknife_steps_sample(obs, sol, fixed, self.config.trust.jackknife_steps)
    }

    /// [`jackknife_sample`](Self::jackknife_sample) with `steps` Gauss-Newton steps (0: a full
    /// solve).
    fn jackknife_steps_sample(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
        steps: usize,
    ) -> Option<Vec<f64>> {
        if steps == 0 {
            let s = self.solve_once(obs, &sol.params, fixed, false)?;
            return Some(sol.free.iter().map(|&i| s.params[i]).collect());
        }
        let req = SolveRequest {
            rig: &self.rig,
            observations: obs,
            // The stage whose minimum the frame's solution is.
            loss: self.solution_loss(),
            solver: self.config.solver.as_ref(),
            initial: &sol.params,
            fixed,
            rotation_only: false,
            motion_prior: Some(&self.motion_prior),
        };
        let n = sol.free.len();
        let mut params = sol.params.clone();
        for _ in 0..steps {
            let lin = self.estimator.linearize(&req, &params).ok()?;
            let step =
                momo_core::solve_normal_equations(&lin.hessian, &lin.gradient, n, 0.0, false)?;
            for (k, &i) in sol.free.iter().enumerate() {
                params[i] += step[k];
            }
        }
        let out: Vec<f64> = sol.free.iter().map(|&i| params[i]).collect();
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// The request whose minimum the frame's solution is (the refinement stage's loss where
    /// there is one), on `obs`.
    fn stage_request<'a>(
        &'a self,
        obs: &'a FrameObservations,
        loss: &'a dyn momo_core::RobustLoss,
        sol: &'a FrameSolution,
        fixed: &'a [bool],
    ) -> SolveRequest<'a> {
        SolveRequest {
            rig: &self.rig,
            observations: obs,
            loss,
            solver: self.config.solver.as_ref(),
            initial: &sol.params,
            fixed,
            rotation_only: false,
            motion_prior: Some(&self.motion_prior),
        }
    }

    /// The number of matches of the rig's cameras (the matches a stage's per-match terms and
    /// masks index).
    fn rig_matches(&self, obs: &FrameObservations) -> usize {
        obs.per_camera
            .iter()
            .take(self.rig.len())
            .map(Vec::len)
            .sum()
    }

    /// The loss whose minimum the frame's solution is (`refine_loss` where set, else `loss`).
    fn solution_loss(&self) -> &dyn momo_core::RobustLoss {
        self.config
            .refine_loss
            .as_deref()
            .unwrap_or(self.config.loss.as_ref())
    }

    /// The prior terms' linearisation alone at the solution (no match), with `loss`.
    fn prior_linearization(
        &self,
        obs: &FrameObservations,
        loss: &dyn momo_core::RobustLoss,
        sol: &FrameSolution,
        fixed: &[bool],
    ) -> Option<momo_core::Linearization> {
        let empty = FrameObservations {
            per_camera: vec![Vec::new(); obs.per_camera.len()],
            cross_camera: Vec::new(),
        };
        self.estimator
            .linearize(&self.stage_request(&empty, loss, sol, fixed), &sol.params)
            .ok()
    }

    /// The frame's part of the one-linearisation jackknife
    /// ([`trust::TrustOptions::jackknife_influence`]) for the cells of `grids`: the prior
    /// terms' linearisation alone (no match), then in one pass over the matches
    /// ([`momo_core::FrameEstimator::exact_data_terms_by_group`]) the frame's exact robust
    /// Hessian and gradient at the solution and every grid's cells' data terms. `None` where
    /// a linearisation fails or the estimator cannot give them.
    fn influence_frame(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
        grids: &[(usize, usize)],
    ) -> Option<InfluenceFrame> {
        let loss = self.solution_loss();
        let prior = self.prior_linearization(obs, loss, sol, fixed)?;
        let labels: Vec<(Vec<usize>, usize)> = grids
            .iter()
            .map(|&g| trust::cell_labels(&self.rig, obs, g))
            .collect();
        let labellings: Vec<(&[usize], usize)> =
            labels.iter().map(|(l, n)| (l.as_slice(), *n)).collect();
        let data = self
            .estimator
            .exact_data_terms_by_group(
                &self.stage_request(obs, loss, sol, fixed),
                &sol.params,
                &labellings,
            )
            .ok()??;
        Some(InfluenceFrame {
            hessian: data.total.hessian + prior.hessian,
            gradient: data.total.gradient + prior.gradient,
            cells: data.groups,
        })
    }

    /// The leave-one-cell-out re-estimates of one `grid` (the `index`-th of the frame's
    /// [`InfluenceFrame::cells`]) from the frame's linearisation ([`trust::influence_step`]);
    /// cells whose step is not defined, and the `trust.jackknife_solves` cells that move
    /// farthest under `cov`, get a full solve. `report`: a grid of `trust.report_grids`.
    #[allow(clippy::too_many_arguments)]
    fn influence_samples(
        &self,
        frame: &InfluenceFrame,
        index: usize,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
        cov: &nalgebra::DMatrix<f64>,
        grid: (usize, usize),
        report: bool,
    ) -> Vec<Vec<f64>> {
        let n = sol.free.len();
        let theta: Vec<f64> = sol.free.iter().map(|&i| sol.params[i]).collect();
        let mut samples: Vec<Option<Vec<f64>>> = frame
            .cells
            .get(index)
            .map(Vec::as_slice)
            .unwrap_or_default()
            .iter()
            .map(|c| {
                // The cell's data terms (its exact robust Hessian and gradient).
                trust::influence_step(
                    &theta,
                    (&frame.hessian, &frame.gradient),
                    (&c.hessian, &c.gradient),
                    n,
                )
            })
            .collect();
        // The cells to solve in full: undefined steps, and the farthest steps.
        let info = cov.clone().try_inverse();
        let distance = |s: &Vec<f64>| match &info {
            Some(info) if info.iter().all(|v| v.is_finite()) => {
                let d =
                    nalgebra::DVector::from_iterator(n, s.iter().zip(&theta).map(|(a, b)| a - b));
                (d.transpose() * info * &d)[(0, 0)]
            }
            _ => 0.0,
        };
        let mut order: Vec<(usize, f64)> = samples
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.as_ref().map(|s| (k, distance(s))))
            .collect();
        order.sort_by(|a, b| b.1.total_cmp(&a.1));
        let mut solve: Vec<usize> = (0..samples.len())
            .filter(|&k| samples[k].is_none())
            .collect();
        solve.extend(
            order
                .iter()
                .take(self.config.trust.jackknife_solves)
                .map(|&(k, _)| k),
        );
        if !solve.is_empty() {
            // Only the cells solved in full are built.
            let without = trust::leave_cells_out(&self.rig, obs, grid, |k| solve.contains(&k));
            let steps = self.config.trust.jackknife_undefined_steps;
            for k in solve {
                if let Some(Some(o)) = without.get(k) {
                    // An undefined step: `trust.jackknife_undefined_steps` Gauss-Newton steps
                    // where set (a full solve where one of them is undefined too).
                    if samples[k].is_none() && steps > 0 {
                        samples[k] = self.jackknife_steps_sample(o, sol, fixed, steps);
                        if samples[k].is_some() {
                            continue;
                        }
                    }
                    samples[k] = self
                        .solve_once_with(
                            o,
                            &sol.params,
                            fixed,
                            false,
                            self.undefined_solver
                                .as_deref()
                                .filter(|_| {
                                    report || !self.config.trust.jackknife_undefined_report_only
                                })
                                .unwrap_or(self.config.solver.as_ref()),
                        )
                        .map(|s| sol.free.iter().map(|&i| s.params[i]).collect());
                }
            }
        }
        samples.into_iter().flatten().collect()
    }

    /// A second motion that explains at least `trust.competing_min_fraction` of the matches
    /// outside the estimate's support (fitted to them from the previous frame's motion and
    /// straight ahead): its free parameters and its weight `w` (its support's share of the two
    /// supports). `outside` is the mask of the matches outside the support
    /// ([`separate::epipolar_at_least`](crate::separate::epipolar_at_least)) if the caller has
    /// it already ([`trust::residual_statistic_and_outside`]).
    fn competing_motion(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        outside: Option<Vec<Vec<bool>>>,
    ) -> Option<(Vec<f64>, f64)> {
        let threshold = self.config.trust.competing_threshold;
        self.competing_motion_from(obs, &sol.params, &sol.free, outside, None, threshold)
    }

    /// [`Odometry::competing_motion`] of the motion `params` (free parameters `free`), fitted
    /// from `extra_starts` where given (full parameter vectors) instead of from the previous
    /// frame's motion and straight ahead, with the epipolar `threshold` (radians) in place of
    /// `trust.competing_threshold`.
    fn competing_motion_from(
        &self,
        obs: &FrameObservations,
        params: &[f64],
        free: &[usize],
        outside: Option<Vec<Vec<bool>>>,
        extra_starts: Option<Vec<Vec<f64>>>,
        threshold: f64,
    ) -> Option<(Vec<f64>, f64)> {
        let t = &self.config.trust;
        let n = obs.len();
        if t.competing_min_fraction <= 0.0 || n == 0 {
            return None;
        }
        let min_n = ((t.competing_min_fraction * n as f64).ceil() as usize).max(12);
        let angles = |params: &[f64]| {
            crate::separate::epipolar_angles(&self.rig, &self.estimator.motion(params), obs)
        };
        let outside = outside.unwrap_or_else(|| {
            crate::separate::epipolar_at_least(
                &self.rig,
                &self.estimator.motion(params),
                obs,
                threshold,
            )
        });
        let n_out = outside.iter().flatten().filter(|k| **k).count();
        if n_out < min_n {
            return None;
        }
        let mut rest = crate::separate::subset(obs, &outside);
        rest.cross_camera.clear();
        let cap = t.competing_fit_matches;
        if cap > 0 && n_out > cap {
            // Every k-th of the outside matches (the support is counted over all of them).
            let mut k = 0usize;
            for m in &mut rest.per_camera {
                m.retain(|_| {
                    k += 1;
                    (k - 1) * cap / n_out != k * cap / n_out
                });
            }
        }
        let n_params = self.estimator.param_names().len();
        let fixed: Vec<bool> = (0..n_params).map(|i| !free.contains(&i)).collect();
        let starts = match extra_starts {
            Some(starts) => starts,
            None => {
                let mut ahead = self
                    .estimator
                    .initial_params(self.estimator.arc_length_index().map_or(1.0, |i| params[i]));
                if let Some(i) = self.estimator.arc_length_index() {
                    ahead[i] = params[i];
                }
                let mut previous = self.previous.clone();
                if let Some(i) = self.estimator.arc_length_index() {
                    previous[i] = params[i];
                }
                vec![previous, ahead]
            }
        };
        let b = starts
            .iter()
            .filter_map(|s| self.solve_once(&rest, s, &fixed, false))
            .min_by(|x, y| x.report.final_cost.total_cmp(&y.report.final_cost))?;
        let in_b = angles(&b.params)
            .iter()
            .zip(&outside)
            .map(|(c, o)| {
                c.iter()
                    .zip(o)
                    .filter(|(x, o)| **o && **x < threshold)
                    .count()
            })
            .sum::<usize>();
        if in_b < min_n {
            return None;
        }
        let in_a = n - n_out;
        let w = in_b as f64 / (in_a + in_b) as f64;
        Some((free.iter().map(|&i| b.params[i]).collect(), w))
    }

    /// `trust.start_own_noise` is in force: on, with `odometry.noise_reference`, and the run's
    /// noise not read yet.
    fn start_own_noise(&self) -> bool {
        self.config.trust.start_own_noise
            && self.config.odometry.noise_reference > 0.0
            && !self.noise.is_read(&self.config)
    }

    /// `trust.competing_recheck_frames`: on a moving frame reported `estimated` without a
    /// competing motion, the competing-motions check at the reported motion `params` once more,
    /// fitted from the last competing motion of the previous `K` frames (this frame's arc
    /// length) and from the previous frame's motion turned by `odometry.restart_yaw_offsets`.
    /// Then, with `trust.start_own_noise` in force, once more at the frame's own noise (see
    /// [`trust::TrustOptions::start_own_noise`]). Returns the competitor's free parameters,
    /// its weight and whether the start's rule found it; records every moving frame's competing
    /// motion (the check's or this one's, not the start rule's) for the next frames. `None`
    /// where off.
    fn competing_recheck(
        &mut self,
        obs: &FrameObservations,
        params: &[f64],
        standstill: bool,
        diag: &FrameDiagnostics,
    ) -> Option<(Vec<f64>, f64, bool)> {
        let k = self.config.trust.competing_recheck_frames;
        if k == 0 || standstill {
            return None;
        }
        let found = diag.competing.as_ref().map(|c| c.0.clone());
        let max_matches = self.config.trust.competing_recheck_max_matches;
        let sized = max_matches == 0 || obs.len() <= max_matches;
        let checkable = diag.status == FrameStatus::Estimated
            && found.is_none()
            && !diag.free.is_empty()
            && diag.covariance.len() == diag.free.len().pow(2)
            && diag.covariance.iter().all(|v| v.is_finite());
        // `trust.start_own_noise`: the frame's own noise over the reference (1 where the rule
        // is not in force or the frame reads within `noise_band`).
        let own = if checkable && self.start_own_noise() {
            let angles =
                crate::separate::epipolar_angles(&self.rig, &self.estimator.motion(params), obs);
            crate::separate::noise_sigma(&angles, self.config.loss.scale()).map_or(1.0, |s| {
                crate::noise::NoiseAdapt::frame_scale(s, &self.config)
            })
        } else {
            1.0
        };
        let eligible = checkable && (sized || own > 1.0);
        let mut result = None;
        if eligible {
            let arc = self.estimator.arc_length_index();
            let with_arc = |mut p: Vec<f64>| {
                if let Some(i) = arc {
                    p[i] = params[i];
                }
                p
            };
            let mut starts: Vec<Vec<f64>> = self
                .last_competing
                .as_ref()
                .filter(|(f, p)| self.frame.saturating_sub(*f) <= k && p.len() == params.len())
                .map(|(_, p)| with_arc(p.clone()))
                .into_iter()
                .collect();
            // The previous motion turned by the restart offsets (not straight ahead, which
            // the check above tried already).
            let previous = with_arc(self.previous.clone());
            starts.extend(self.restart_points(&previous).into_iter().skip(1));
            let threshold = self.config.trust.competing_threshold;
            let fit = |starts: Vec<Vec<f64>>, t: f64, start: bool| {
                self.competing_motion_from(obs, params, &diag.free, None, Some(starts), t)
                    .map(|(b, w)| (b, w, start))
            };
            if sized && !starts.is_empty() {
                result = fit(starts.clone(), threshold, false);
            }
            // `trust.start_own_noise`: at the frame's own noise, from the check's starts too
            // (the previous motion and straight ahead), on a frame of any size.
            if result.is_none() && own > 1.0 {
                let ahead = with_arc(self.estimator.initial_params(1.0));
                starts.insert(0, ahead);
                starts.insert(0, previous);
                result = fit(starts, own * threshold, true);
            }
        }
        let recorded = found.or_else(|| {
            // Not the start rule's: the later rechecks, which the start's confirmation follows,
            // start from what they would without it.
            result
                .as_ref()
                .filter(|(_, _, start)| !start)
                .map(|(b, _, _)| with_free(params, &diag.free, b))
        });
        if let Some(p) = recorded {
            self.last_competing = Some((self.frame, p));
        }
        result
    }

    /// The inputs of [`trust::calibrated_covariance`] for a solution.
    fn covariance_inputs(&self, sol: &FrameSolution) -> trust::CovarianceInputs {
        let n = sol.free.len();
        let names = self.estimator.param_names();
        let pos = |name: &str| {
            let i = names.iter().position(|p| *p == name)?;
            sol.free.iter().position(|&f| f == i)
        };
        let rotation = match (pos("rot_x"), pos("rot_y"), pos("rot_z")) {
            (Some(a), Some(b), Some(c)) => Some([a, b, c]),
            _ => None,
        };
        let scale = self.config.loss.scale();
        trust::CovarianceInputs {
            normal: sol.report.normal_matrix.view((0, 0), (n, n)).into_owned(),
            cost: sol.report.final_cost,
            inliers: sol.inliers(),
            rotation,
            prior_inv_sigma: self.motion_prior.rotation_inv_sigma,
            prior_scale: self.motion_prior.scale,
            sigma_floor: if scale.is_finite() { 0.05 * scale } else { 0.0 },
            sigma2: None,
        }
    }

    /// The residual variance of `trust.report_covariance = "sandwich"` at the solution
    /// ([`trust::sandwich_sigma2`]): the data terms' exact robust Hessian and every match's
    /// gradient in one pass ([`momo_core::FrameEstimator::exact_data_terms_by_group`], each
    /// match its own group), the Gauss-Newton normal matrix of the data terms as the solver's
    /// linearisation with the matches less the one without. `None` where a linearisation
    /// fails or the estimator cannot give them.
    fn sandwich_sigma2(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        fixed: &[bool],
    ) -> Option<f64> {
        let loss = self.solution_loss();
        let m = self.rig_matches(obs);
        let labels: Vec<usize> = (0..m).collect();
        let request = self.stage_request(obs, loss, sol, fixed);
        let data = self
            .estimator
            .exact_data_terms_by_group(&request, &sol.params, &[(labels.as_slice(), m)])
            .ok()??;
        let with = self.estimator.linearize(&request, &sol.params).ok()?;
        let prior = self.prior_linearization(obs, loss, sol, fixed)?;
        let n = sol.free.len();
        let exact = data.total.hessian.view((0, 0), (n, n)).into_owned();
        let normal = (with.hessian - prior.hessian)
            .view((0, 0), (n, n))
            .into_owned();
        let gradients: Vec<nalgebra::DVector<f64>> = data
            .groups
            .first()?
            .iter()
            .map(|l| l.gradient.rows(0, n).into_owned())
            .collect();
        trust::sandwich_sigma2(&exact, &normal, &gradients, sol.inliers())
    }

    /// Fills the solve's diagnostics and the reported covariance. On a moving frame
    /// (`moving`) a competing motion widens it ([`trust::mixture_covariance`]), and the
    /// leave-one-cell-out jackknife does where `jackknife` (the support dropped, see
    /// [`trust::TrustOptions::jackknife_support_drop`]) or a competing motion was found.
    /// `soft_view`: the frame's shared soft-prior data view ([`SoftView`]), if any. `floor`:
    /// the previous frame's decayed covariance (`trust.covariance_memory`). Returns the
    /// covariance before the competing motions' mixture where `trust.covariance_memory` is on
    /// (the next frame's floor), else `None`.
    #[allow(clippy::too_many_arguments)]
    fn fill_diagnostics(
        &self,
        obs: &FrameObservations,
        sol: &FrameSolution,
        moving: bool,
        jackknife: (bool, bool),
        outside: Option<Vec<Vec<bool>>>,
        soft_view: Option<&SoftView>,
        floor: Option<&nalgebra::DMatrix<f64>>,
        diag: &mut FrameDiagnostics,
    ) -> (Option<nalgebra::DMatrix<f64>>, GridJackknives, bool) {
        diag.initial_cost = sol.report.initial_cost;
        diag.final_cost = sol.report.final_cost;
        diag.iterations = sol.report.iterations;
        diag.termination = Some(sol.report.termination);
        diag.inliers = sol.inliers();
        diag.inliers_per_camera = sol.inliers_per_camera.clone();
        diag.free = sol.free.clone();
        let competing = if moving {
            self.competing_motion(obs, sol, outside)
        } else {
            None
        };
        diag.jackknife = moving && (jackknife.0 || competing.is_some());
        let (status_cov, mut reported, report_jackknife) = match self.reported_covariance(
            obs,
            sol,
            diag.jackknife,
            moving && jackknife.1,
            soft_view,
        ) {
            Some((s, r, j)) => (Some(s), Some(r), j),
            None => (None, None, Vec::new()),
        };
        // The report's covariance is finite where the first stage's is not: its own start
        // (`trust.ill_conditioned_refit`, or a `trust.report_covariance` other than
        // `first_stage`) constrained what the first stage did not.
        let refit_fallback = status_cov.as_ref().is_some_and(|c| !all_finite(c))
            && reported.as_ref().is_some_and(all_finite);
        if let Some((b, w)) = &competing {
            diag.competing = Some((with_free(&sol.params, &sol.free, b), *w));
        }
        if let Some(cov) = status_cov.as_ref()
            && let Some((b, w)) = &competing
        {
            let a: Vec<f64> = sol.free.iter().map(|&i| sol.params[i]).collect();
            // A frame whose covariance the two motions' difference dominates is flagged
            // (`weak`, `competing_motions`): it keeps its estimate and does not centre the next
            // frame's prior. Frames where the difference stays within the (jackknife-widened)
            // covariance keep `estimated`.
            if trust::mixture_dominates(cov, &a, b, *w) && diag.constraint == Constraint::Well {
                diag.constraint = Constraint::Weak;
                diag.reason = Some(Reason::CompetingMotions);
            }
        }
        // The floor from the previous frame (`trust.covariance_memory`), after the test above:
        // the status and so the poses do not depend on it.
        if let (Some(cov), Some(floor)) = (reported.as_mut(), floor) {
            *cov = trust::widen(cov, floor, 1.0);
        }
        // The covariance before the competing motions' mixture, kept only for
        // `trust.covariance_memory`.
        let base = if self.config.trust.covariance_memory > 0.0 {
            reported.clone()
        } else {
            None
        };
        if let Some(cov) = reported.as_mut()
            && let Some((b, w)) = competing
        {
            let a: Vec<f64> = sol.free.iter().map(|&i| sol.params[i]).collect();
            *cov = trust::mixture_covariance(cov, &a, &b, w);
        }
        if let Some(cov) = reported {
            for (k, &i) in sol.free.iter().enumerate() {
                diag.param_sigmas[i] = cov[(k, k)].max(0.0).sqrt();
            }
            diag.covariance = cov.transpose().iter().copied().collect();
        }
        (base, report_jackknife, refit_fallback)
    }

    /// The floor of this frame's reported covariance (`trust.covariance_memory` `ρ`): `ρ Σ'`
    /// with `Σ'` the previous frame's covariance before competing or alternative motions were
    /// added (itself floored), where that frame was the previous one and had the same free
    /// parameters; `None` otherwise or where `ρ` is 0.
    fn covariance_floor(&self, sol: &FrameSolution) -> Option<nalgebra::DMatrix<f64>> {
        let rho = self.config.trust.covariance_memory;
        match &self.covariance_memory {
            Some((frame, free, m))
                if rho > 0.0 && *frame + 1 == self.frame && *free == sol.free =>
            {
                Some(m * rho)
            }
            _ => None,
        }
    }
}

/// The rank-one widenings of a frame's reported covariance: each term an estimate `a` it was
/// added about, an alternative `c` (both all of the model's parameters) and a weight `w`, the
/// term `w (c − a)(c − a)ᵀ` over the free parameters (a competing motion's mixture at
/// `w (1 − w)`, [`trust::mixture_covariance`]; the road's alternatives, the previous motion
/// after a flag and `decide_by_road`'s candidates, [`trust::alternatives_covariance`]).
#[derive(Default)]
struct Widened {
    terms: Vec<(Vec<f64>, Vec<f64>, f64)>,
}

impl Widened {
    /// Records the terms of `alternatives` with weight `w` about `about`.
    fn add<'a>(
        &mut self,
        about: &[f64],
        alternatives: impl IntoIterator<Item = &'a [f64]>,
        w: f64,
    ) {
        for c in alternatives {
            self.terms.push((about.to_vec(), c.to_vec(), w));
        }
    }

    /// Widens the reported covariance by `alternatives` with weight `w` about `about`
    /// ([`Odometry::widen_by_alternatives_at`]) and records the terms where it did; returns
    /// whether it did.
    fn widen(
        &mut self,
        alternatives: &[&[f64]],
        w: f64,
        free: &[usize],
        about: &[f64],
        diag: &mut FrameDiagnostics,
    ) -> bool {
        let done = Odometry::widen_by_alternatives_at(alternatives, w, free, about, diag);
        if done {
            self.add(about, alternatives.iter().copied(), w);
        }
        done
    }

    /// Moves the widenings added about `from` to `to` (`odometry.tilt_hold_stage = "report"`:
    /// the frame reports the held twin `to` of its motion `from`): `Σ' = Σ + Σ_j w_j (d_j d_jᵀ
    /// − e_j e_jᵀ)` over those terms, `d_j = c_j − to`, `e_j = c_j − from`, the same covariance
    /// as had they been added about `to`; the sigmas (of all parameters) change by the same
    /// variances. `covariance`: row-major over the free parameters `free`. Terms added about
    /// another motion stay; nothing where the frame has no finite covariance.
    fn recentre(
        &self,
        from: &[f64],
        to: &[f64],
        free_params: &[usize],
        covariance: &mut Vec<f64>,
        sigmas: &mut [f64],
    ) {
        let k = free_params.len();
        if !self.terms.iter().any(|(a, _, _)| a == from)
            || k == 0
            || covariance.len() != k * k
            || covariance.iter().any(|v| !v.is_finite())
        {
            return;
        }
        let free = |p: &[f64]| -> Vec<f64> {
            free_params
                .iter()
                .map(|&i| p.get(i).copied().unwrap_or(f64::NAN))
                .collect()
        };
        let (a, b) = (free(from), free(to));
        let cov = nalgebra::DMatrix::from_row_slice(k, k, covariance);
        let mut wide = cov.clone();
        for (_, c, w) in self.terms.iter().filter(|(a, _, _)| a == from) {
            let c = free(c);
            let d = nalgebra::DVector::from_iterator(k, c.iter().zip(&b).map(|(c, b)| c - b));
            let e = nalgebra::DVector::from_iterator(k, c.iter().zip(&a).map(|(c, a)| c - a));
            if d.iter().chain(e.iter()).all(|v| v.is_finite()) {
                wide += (&d * d.transpose() - &e * e.transpose()) * *w;
            }
        }
        for (j, &i) in free_params.iter().enumerate() {
            let change = wide[(j, j)] - cov[(j, j)];
            if let Some(s) = sigmas.get_mut(i) {
                *s = (s.powi(2) + change).max(0.0).sqrt();
            }
        }
        *covariance = wide.transpose().iter().copied().collect();
    }
}

/// Reports `wide`, a widening of the frame's reported covariance `cov` over the free parameters
/// `free`: the covariance (row by row) and each sigma grown by the variance added on its
/// diagonal (the sigmas may already hold more than `cov`, e.g. an arc length's own sigma).
fn report_widened(
    cov: &nalgebra::DMatrix<f64>,
    wide: nalgebra::DMatrix<f64>,
    free: &[usize],
    diag: &mut FrameDiagnostics,
) {
    for (j, &i) in free.iter().enumerate() {
        let added = (wide[(j, j)] - cov[(j, j)]).max(0.0);
        diag.param_sigmas[i] = (diag.param_sigmas[i].powi(2) + added).sqrt();
    }
    diag.covariance = wide.transpose().iter().copied().collect();
}

/// The fewest road matches of [`Odometry::road_arc_length`]'s best arc length.
const ROAD_SCALE_MIN_MATCHES: usize = 12;

/// [`Odometry::admit_road_arc_length`]: a road arc length further than this fraction of the held
/// one from it (and further than [`ROAD_SCALE_GATE_METRES`]) is rejected.
const ROAD_SCALE_GATE: f64 = 0.3;

/// [`Odometry::admit_road_arc_length`]: the gate's floor in metres (slow frames: a start from
/// rest doubles the arc length within a few frames).
const ROAD_SCALE_GATE_METRES: f64 = 0.1;

/// [`Odometry::admit_road_arc_length`]: the gate widens by this many metres for every frame
/// since the last admitted road arc length (a vehicle's speed changes by at most so much per
/// frame: 3 m/s² at 10 Hz).
const ROAD_SCALE_GATE_METRES_PER_FRAME: f64 = 0.03;

/// [`Odometry::admit_road_arc_length`]: this many rejected road arc lengths in a row (those
/// whose frames find no road at the gate's reference) restart the history from them.
const ROAD_SCALE_RESETS: usize = 5;

/// [`Odometry::admit_road_arc_length`]: a rejected road arc length whose frame counts at least
/// this fraction of its road matches at the gate's reference too does not count towards a
/// restart.
const ROAD_SCALE_HELD_SUPPORT: f64 = 0.5;

/// [`Odometry::admit_road_arc_length`]: the gate's reference is the median of this many last
/// admitted road arc lengths, however few `odometry.road_scale_frames` holds: a lead vehicle
/// whose "road" lies 20-30 % below the held one must not pull it down a step per frame.
const ROAD_SCALE_GATE_FRAMES: usize = 5;

/// One frame's reading of `odometry.road_scale_frames` ([`Odometry::road_arc_length`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct RoadReading {
    /// The arc length that puts the most matches on the road (the plateau's geometric mean).
    arc_length: f64,
    /// The road matches counted at the best arc length.
    count: usize,
    /// The road matches counted at the gate's reference
    /// ([`Odometry::road_gate_reference`]; 0 without one).
    held_count: usize,
}

/// The fewest labelled matches outside the support whose share [`quiet_memory`] reads (the
/// separation's persistence uses the same count).
const QUIET_MIN_LABELLED: usize = 8;

/// The match memory's evidence of another motion outside a solution's support (the quiet-frame
/// fast path, `odometry.quiet_other_share`): the share of the labelled matches outside the
/// support (`labels`, of those matches only) that the memory remembers as another motion's,
/// less the share `remembered` of all remembered matches labelled other; 0 where fewer than
/// [`QUIET_MIN_LABELLED`] are labelled (a handful of labels shows nothing). Random mismatches
/// are remembered as other outside the support as often as anywhere (the simulator draws them
/// anew per frame pair); an object moving against the support is remembered as other outside
/// it.
fn quiet_memory(labels: &[Vec<Option<bool>>], remembered: f64) -> f64 {
    let (labelled, other) = labels
        .iter()
        .flatten()
        .flatten()
        .fold((0usize, 0usize), |(l, o), s| (l + 1, o + usize::from(!s)));
    if labelled < QUIET_MIN_LABELLED {
        return 0.0;
    }
    other as f64 / labelled as f64 - remembered
}

/// One moving frame's entry of the report grids' jackknife pool
/// (`trust.report_pool_frames`): its frame number, free parameters and each report grid's
/// jackknife covariance.
type ReportJackknife = (usize, Vec<usize>, GridJackknives);

/// Each report grid's jackknife covariance of one frame (`None` where it could not be
/// formed), in the order of `trust.report_grids`.
type GridJackknives = Vec<Option<nalgebra::DMatrix<f64>>>;

/// The frame's part of the one-linearisation jackknife (`Odometry::influence_frame`).
struct InfluenceFrame {
    /// The exact robust Hessian of the frame at its solution (data and prior terms).
    hessian: momo_core::NormalMatrix,
    /// The gradient there.
    gradient: momo_core::ParamVec,
    /// Per grid, per cell (in the order of [`trust::cells_alone`]): the cell's data terms,
    /// their exact robust Hessian and gradient at the solution.
    cells: Vec<Vec<momo_core::Linearization>>,
}

/// `odometry.decide_by_road_yaw_jump` (`bound`, radians per frame; 0 off): whether an
/// alternative of yaw `yaw` may replace the chosen motion of yaw `chosen` after a frame whose
/// reported yaw was `previous`: its change of yaw from the previous frame is within the bound,
/// or no larger than the chosen motion's.
pub fn within_yaw_jump(previous: f64, chosen: f64, yaw: f64, bound: f64) -> bool {
    !(bound > 0.0) || (yaw - previous).abs() <= bound.max((chosen - previous).abs())
}

/// `odometry.decide_by_road_yaw_margin`: whether an alternative's road score `score` is
/// decisive against the chosen motion's `base` in the separation's sense (`decisive = (min,
/// ratio)`: `separate.ground_admit_min`, `separate.ground_admit`): at least `min` and at least
/// `ratio` times `base`.
pub fn road_decisive(score: usize, base: usize, (min, ratio): (usize, f64)) -> bool {
    score >= min && score as f64 >= ratio * base as f64
}

/// The choice of `odometry.decide_by_road`: the index of the highest of the alternatives' road
/// `scores` (the first of equal ones) where it is at least `margin` above the chosen motion's
/// `base`; `None` (the chosen motion stays) otherwise or where `margin` is 0.
pub fn pick_by_road(base: usize, scores: &[usize], margin: usize) -> Option<usize> {
    if margin == 0 {
        return None;
    }
    let (i, &best) = scores
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(&a.0)))?;
    base.checked_add(margin)
        .is_some_and(|t| best >= t)
        .then_some(i)
}

/// Accumulates frame-to-frame vehicle motions into the camera-0 trajectory of `FORMAT.md`:
/// `T_cam0(0)_cam0(k) = P0⁻¹ · (M_1 ⋯ M_k) · P0`.
#[derive(Clone, Debug)]
pub struct Trajectory {
    t_vehicle_cam0: Pose<f64>,
    vehicle: Pose<f64>,
}

impl Trajectory {
    /// Starts at the identity for a rig's camera 0.
    pub fn new(rig: &Rig) -> Self {
        Self {
            t_vehicle_cam0: rig.cameras()[0].t_vehicle_camera,
            vehicle: Pose::identity(),
        }
    }

    /// Appends a vehicle motion `T_{k-1,k}` and returns camera 0's pose at k.
    pub fn push(&mut self, motion: &Pose<f64>) -> Pose<f64> {
        self.vehicle = self.vehicle.compose(motion);
        // No re-orthonormalisation: over 4,541 frames the output still passes FORMAT.md's 1e-6
        // orthonormality check when read back (`momo eval` reads it through `read_poses`).
        self.camera0()
    }

    /// Camera 0's current pose in camera 0's frame at frame 0.
    pub fn camera0(&self) -> Pose<f64> {
        self.t_vehicle_cam0
            .inverse()
            .compose(&self.vehicle)
            .compose(&self.t_vehicle_cam0)
    }

    /// The vehicle's current pose in the vehicle frame at frame 0.
    pub fn vehicle(&self) -> Pose<f64> {
        self.vehicle
    }
}

/// The Cauchy scales of the soft prior's `n` residuals ([`momo_core::MotionPrior::soft_cauchy`]):
/// `odometry.soft_prior_cauchy` on those of `odometry.soft_prior_cauchy_residuals` (all where
/// empty), 0 (least squares) on the others; empty where the option is off or the model has no
/// soft prior, and, with `odometry.soft_prior_cauchy_until_learnt`, once the prior's sigmas are
/// `learnt` ([`SOFT_SIGMA_MIN_FRAMES`] trusted moving frames).
///
/// With `odometry.soft_prior_cauchy_taught_share = ρ > 0` (the learning-lag gate), also only
/// where `lag = (moving, taught)` has `moving ≥ odometry.soft_prior_cauchy_after_moving` and
/// `taught < ρ · moving`: the moving frames so far and those that taught the soft prior; and
/// only on a rig of at least `odometry.soft_prior_cauchy_min_cameras` `cameras`.
fn soft_cauchy_scales(
    opts: &crate::config::OdometryOptions,
    n: usize,
    learnt: bool,
    lag: (usize, usize),
    cameras: usize,
) -> Vec<f64> {
    let b = opts.soft_prior_cauchy;
    if !(b > 0.0 && b.is_finite())
        || n == 0
        || (learnt && opts.soft_prior_cauchy_until_learnt)
        || cameras < opts.soft_prior_cauchy_min_cameras
    {
        return Vec::new();
    }
    let rho = opts.soft_prior_cauchy_taught_share;
    let (moving, taught) = lag;
    if rho > 0.0
        && (moving < opts.soft_prior_cauchy_after_moving || taught as f64 >= rho * moving as f64)
    {
        return Vec::new();
    }
    let only = &opts.soft_prior_cauchy_residuals;
    (0..n)
        .map(|r| {
            if only.is_empty() || only.contains(&r) {
                b
            } else {
                0.0
            }
        })
        .collect()
}

/// The region vote's counts of `Odometry::previous_basin` on a single camera
/// (`odometry.previous_basin_regions`): per cell of a `grid` (columns, rows) over each
/// camera's image ([`crate::trust::cell_of`] of the frame-(k-1) pixel), the matches whose
/// epipolar angle is below the band (`outside[j][i]` false), cameras one after the other.
fn basin_cell_counts(
    rig: &Rig,
    obs: &FrameObservations,
    outside: &[Vec<bool>],
    grid: (usize, usize),
) -> Vec<usize> {
    let cells = grid.0.max(1) * grid.1.max(1);
    let mut counts = vec![0usize; cells * obs.per_camera.len()];
    for (j, ((cam, m), out)) in rig
        .cameras()
        .iter()
        .zip(&obs.per_camera)
        .zip(outside)
        .enumerate()
    {
        let size = cam.model.size();
        for (ob, _) in m.iter().zip(out).filter(|(_, o)| !**o) {
            counts[j * cells + crate::trust::cell_of((ob.px0.x, ob.px0.y), size, grid)] += 1;
        }
    }
    counts
}

/// The continuing test of `odometry.competing_region_continuing`: whether the competing
/// motion's rotation `competing` is closer than the frame's own `own` to at least one of the
/// `references` (the last frames' rotations; geodesic distance `|log(R_refᵀ R)|`). False where
/// there is no reference.
fn continues_any(
    references: &[Matrix3<f64>],
    own: &Matrix3<f64>,
    competing: &Matrix3<f64>,
) -> bool {
    references.iter().any(|r| {
        let away = |x: &Matrix3<f64>| so3_log(&(r.transpose() * x)).norm();
        away(competing) < away(own)
    })
}

/// The guard of `odometry.competing_region_yaw_ratio`: whether the rotation between `own` and
/// `competing` (`log(R_ownᵀ R_competing)`, vehicle frame: roll, pitch, yaw) turns mainly about
/// the vertical axis, `|Δψ| ≥ ratio · √(Δφ² + Δθ²)`.
fn yaw_dominant(own: &Matrix3<f64>, competing: &Matrix3<f64>, ratio: f64) -> bool {
    let d = so3_log(&(own.transpose() * competing));
    d[2].abs() >= ratio * d[0].hypot(d[1])
}

/// The cameras' vote of `Odometry::previous_basin`: `alt` wins over `current` (per camera the
/// matches within the band of each motion's epipolar planes) where the cameras that count more
/// matches at `alt` outnumber those that count fewer by at least `votes` (at least 1): the
/// motion that clearly more cameras support, each camera one vote.
fn basin_vote(current: &[usize], alt: &[usize], votes: usize) -> bool {
    let (mut more, mut fewer) = (0usize, 0usize);
    for (c, a) in current.iter().zip(alt) {
        more += usize::from(a > c);
        fewer += usize::from(a < c);
    }
    more >= fewer + votes.max(1)
}

/// The soft prior's factors `k_r` (units of the model's sigma) widened for a step of arc
/// length `arc` by the learnt displacement jitters `jitter` (`δ_r²`,
/// `odometry.soft_prior_arc_learning`): `1 / √(1 / k_r² + δ_r² / s²)`. Unchanged where no
/// jitter is learnt or the arc length is not positive.
fn arc_widened_inv_scale(inv_scale: &mut [f64], jitter: &[f64], arc: f64) {
    let s = arc.abs();
    if !(s.is_finite() && s > 0.0) {
        return;
    }
    for (k, j) in inv_scale.iter_mut().zip(jitter) {
        if *j > 0.0 && *k > 0.0 {
            *k = 1.0 / (1.0 / (*k * *k) + j / (s * s)).sqrt();
        }
    }
}

/// Whether the soft prior's consistency widening (`odometry.soft_prior_consistency_frames`)
/// may act on a frame `since_competing` frames after the last one flagged `competing_motions` /
/// `road_score_drop` (`usize::MAX` before any; it counts up from 0 after one and saturates, so
/// it does not return to `usize::MAX` within any sequence): none within the last
/// [`CONSISTENCY_QUIET_FRAMES`], and with `odometry.soft_prior_consistency_never_after_flag`
/// none since the start.
fn consistency_acts(since_competing: usize, opts: &crate::config::OdometryOptions) -> bool {
    since_competing >= CONSISTENCY_QUIET_FRAMES
        && !(opts.soft_prior_consistency_never_after_flag && since_competing != usize::MAX)
}

/// The soft prior widened where the recent frames' data keep disagreeing with it
/// (`odometry.soft_prior_consistency_frames = K`, `odometry.soft_prior_consistency_limit = T`):
/// for each residual `r` of `odometry.soft_prior_consistency_residuals` (all where empty), over
/// the last `K` innovations `(d_j², v_j)` of `samples` (units of the model's sigma,
/// [`Odometry::soft_prior_sigma`]), the mean normalised innovation
/// `NIS(σ²) = (1/K) Σ_j d_j² / (σ² + v_j)` at the frame's width `σ_r² = 1 / k_r²`; where it
/// exceeds `T`, `k_r = 1 / σ'` with `NIS(σ'²) = 1` (covariance matching: `E[d_j²] = σ_true² +
/// v_j`). `NIS` decreases in `σ²` and `NIS(mean d²) <= 1`, so `σ'²` lies in `[σ_r², mean d²]`
/// (bisection, 60 halvings). With `odometry.soft_prior_consistency_median` the statistic is
/// the robust one of [`Odometry::soft_prior_sigma`], `NIS(σ²) = median_j d_j² / (σ² + v_j)`
/// over the χ²₁ median (`σ'²` in `[σ_r², max d² / χ²₁ median]`): one frame where the data
/// were pulled does not widen it. Unchanged with fewer than `K` samples or `K = 0`.
fn consistency_widened_inv_scale(
    inv_scale: &mut [f64],
    samples: &std::collections::VecDeque<(f64, Vec<(f64, f64)>)>,
    opts: &crate::config::OdometryOptions,
) {
    let frames = opts.soft_prior_consistency_frames;
    if frames == 0 || samples.len() < frames {
        return;
    }
    let only = &opts.soft_prior_consistency_residuals;
    for (r, k) in inv_scale.iter_mut().enumerate() {
        if !(only.is_empty() || only.contains(&r)) || !(*k > 0.0 && k.is_finite()) {
            continue;
        }
        let recent: Vec<(f64, f64)> = samples
            .iter()
            .rev()
            .take(frames)
            .filter_map(|(_, f)| f.get(r).map(|&(d2, v)| (d2, v.max(0.0))))
            .collect();
        if recent.len() < frames {
            continue;
        }
        let median = opts.soft_prior_consistency_median;
        let nis = |s2: f64| {
            if median {
                let mut z: Vec<f64> = recent.iter().map(|(d2, v)| d2 / (s2 + v)).collect();
                z.sort_by(f64::total_cmp);
                z[z.len() / 2] / CHI2_1_MEDIAN
            } else {
                recent.iter().map(|(d2, v)| d2 / (s2 + v)).sum::<f64>() / frames as f64
            }
        };
        let s2 = 1.0 / (*k * *k);
        if !(nis(s2) > opts.soft_prior_consistency_limit) {
            continue;
        }
        // `NIS(top) <= 1`: the mean's `d_j² / (σ² + v_j) <= d_j² / σ²` averages to at most 1
        // at `σ² = mean d²`; every ratio is at most the χ²₁ median at `σ² = max d² / median`.
        let top = if median {
            recent.iter().map(|(d2, _)| *d2).fold(0.0, f64::max) / CHI2_1_MEDIAN
        } else {
            recent.iter().map(|(d2, _)| d2).sum::<f64>() / frames as f64
        };
        let (mut lo, mut hi) = (s2, top.max(s2));
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if nis(mid) > 1.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        if hi.is_finite() && hi > s2 {
            *k = 1.0 / hi.sqrt();
        }
    }
}

/// The soft prior's centre moved to the recent frames' data-only level where they agree on
/// one away from it (`odometry.soft_prior_trend_frames = m`, `odometry.soft_prior_trend_z =
/// z`): per residual `r`, over the last `m` samples `(q_d,j, v_j)` of `levels` (units of the
/// model's sigma), the offset `δ = (1/m) Σ_j q_d,j − c_r` of their mean from the centre has,
/// for independent frames whose true slip spreads by the frame's width `σ_r = 1 / k_r`
/// around the level and whose data add `v_j`, the variance `e² = Σ_j (σ_r² + v_j) / m²`.
/// The centre moves by the gain `g ∈ [0, 1)` times the offset, `c_r + g δ`:
///
/// - soft thresholding (the default): `g = max(0, 1 − z e / |δ|)`, i.e. by `sign(δ) ·
///   max(0, |δ| − z e)` (nothing where the offset is within `z` standard errors, continuous
///   beyond);
/// - `odometry.soft_prior_trend_blend`: `g = max(0, 1 − z² e² / δ²)`. For `z = 1` this is
///   the Kalman gain `P̂ / (P̂ + e²)` of the two estimates of the current level — the centre,
///   whose departure from the level has the variance `P`, estimated by moments from `E δ² =
///   P + e²` as `P̂ = δ² − e²`, and the recent mean with `e²` — i.e. positive-part
///   James–Stein shrinkage of the recent mean towards the centre (Efron & Morris 1973); `z >
///   1` shrinks more. Same threshold `|δ| = z e`, a larger move than the soft threshold's
///   beyond it.
///
/// With `odometry.soft_prior_trend_widen` the moved centre's own uncertainty joins the
/// prior's width: the blend's posterior variance `g e²` of the level (for either gain) is added
/// to `σ_r²`, `k_r ← 1 / √(σ_r² + g e²)`, so a noisy trend (large `e`) pulls the frame less.
/// Unchanged with fewer than `m` samples, `m = 0`, or where a residual's width or samples are
/// not finite.
fn trend_shifted_center(
    center: &mut [f64],
    inv_scale: &mut [f64],
    levels: &std::collections::VecDeque<Vec<(f64, f64)>>,
    opts: &crate::config::OdometryOptions,
) {
    let m = opts.soft_prior_trend_frames;
    if m == 0 || levels.len() < m {
        return;
    }
    let z = opts.soft_prior_trend_z;
    for (r, c) in center.iter_mut().enumerate() {
        let Some(k) = inv_scale.get_mut(r) else {
            continue;
        };
        if !(*k > 0.0 && k.is_finite()) {
            continue;
        }
        let s2 = 1.0 / (*k * *k);
        let (mut sum, mut var) = (0.0, 0.0);
        let mut n = 0usize;
        for f in levels.iter().rev().take(m) {
            if let Some(&(q, v)) = f.get(r) {
                sum += q;
                var += s2 + v.max(0.0);
                n += 1;
            }
        }
        if n < m {
            continue;
        }
        let delta = sum / m as f64 - *c;
        let e = var.sqrt() / m as f64;
        if !(delta.is_finite() && e.is_finite() && delta != 0.0) {
            continue;
        }
        let gain = if opts.soft_prior_trend_blend {
            1.0 - (z * e / delta).powi(2)
        } else {
            1.0 - z * e / delta.abs()
        };
        if gain > 0.0 {
            *c += gain * delta;
            if opts.soft_prior_trend_widen {
                *k = 1.0 / (s2 + gain * e * e).sqrt();
            }
        }
    }
}

/// The soft prior's displacement jitters `δ_r² = L²` (units of the model's sigma squared times
/// metres squared) before any learning, for `n` soft-prior residuals: `L` is
/// `odometry.soft_prior_arc_jitter`, the arc length at which a step's prior is √2 times as
/// wide as the model's (`√(1 + L² / s²)` times at arc length `s`, [`arc_widened_inv_scale`]).
/// Empty where `L` is 0 or the sigmas are not learnt (`soft_prior_sigma_learning` off).
fn seeded_arc_jitter(opts: &crate::config::OdometryOptions, n: usize) -> Vec<f64> {
    let l = opts.soft_prior_arc_jitter;
    if l > 0.0 && l.is_finite() && opts.soft_prior_sigma_learning {
        vec![l * l; n]
    } else {
        Vec::new()
    }
}

/// The least-squares line `y ≈ a + b x` through `(x, y)` with `a, b ≥ 0` (`b = 0` where all
/// `x` coincide); `(0, 0)` for no points.
fn nonnegative_line_fit(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    if pts.is_empty() {
        return (0.0, 0.0);
    }
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let (a, b) = if sxx > 0.0 {
        let b = sxy / sxx;
        (my - b * mx, b)
    } else {
        (my, 0.0)
    };
    if b < 0.0 {
        return (my.max(0.0), 0.0);
    }
    if a < 0.0 {
        // Through the origin.
        let sxx0: f64 = pts.iter().map(|p| p.0 * p.0).sum();
        let sxy0: f64 = pts.iter().map(|p| p.0 * p.1).sum();
        return (
            0.0,
            if sxx0 > 0.0 {
                (sxy0 / sxx0).max(0.0)
            } else {
                0.0
            },
        );
    }
    (a, b)
}

/// A frame's soft-prior data view of its first stage's solution (else of its solution),
/// computed once by whichever of the prior-conflict check and the innovation asks first
/// (`None` inside: not defined there).
type SoftView = std::cell::OnceCell<Option<SoftDataView>>;

/// The data's own view of the soft prior's residuals at a solution
/// ([`Odometry::soft_data_view`]).
struct SoftDataView {
    /// The prior's centre.
    c: Vec<f64>,
    /// Whether `c` is the motion prior's (else zeros).
    centred: bool,
    /// The shift of the free parameters that the prior causes.
    shift: nalgebra::DVector<f64>,
    /// The data's own values of the residuals.
    q_d: nalgebra::DVector<f64>,
    /// The data's covariance of the residuals.
    v: nalgebra::DMatrix<f64>,
}

/// The membership among all matches of a subset's kept matches: `mask` chose the subset
/// (per camera, per match), `kept` marks its kept matches in order (per camera).
fn superset_mask(mask: &[Vec<bool>], kept: &[Vec<bool>]) -> Vec<Vec<bool>> {
    mask.iter()
        .zip(kept.iter().map(Some).chain(std::iter::repeat(None)))
        .map(|(m, k)| {
            let mut inner = k.map(|k| k.iter()).into_iter().flatten();
            m.iter()
                .map(|&chosen| chosen && inner.next().copied().unwrap_or(false))
                .collect()
        })
        .collect()
}

/// Per camera, the indices of the matches where `mask` holds (`odometry.report_support`).
fn support_indices(mask: &[Vec<bool>]) -> Vec<Vec<usize>> {
    mask.iter()
        .map(|m| {
            m.iter()
                .enumerate()
                .filter(|(_, k)| **k)
                .map(|(i, _)| i)
                .collect()
        })
        .collect()
}

/// The per-match constants (`m` per match, camera by camera) of the matches `mask` keeps, in
/// order: those of `crate::separate::subset(obs, mask)` where `constants` are `obs`'s. `None`
/// where `constants` do not cover the mask's matches (or there are none per match).
fn subset_constants(constants: &[f64], m: usize, mask: &[Vec<bool>]) -> Option<Vec<f64>> {
    let n: usize = mask.iter().map(Vec::len).sum();
    if m == 0 || constants.len() != m * n {
        return None;
    }
    Some(
        mask.iter()
            .flatten()
            .zip(constants.chunks_exact(m))
            .filter(|(k, _)| **k)
            .flat_map(|(_, c)| c.iter().copied())
            .collect(),
    )
}

/// `trust.competing_recheck_frames`, report only: the reported covariance of the motion
/// `params` becomes the mixture with the competitor `b` (free parameters, weight `w`),
/// `Σ + w (1 − w) d dᵀ` ([`trust::mixture_covariance`]), the competitor is recorded in the
/// diagnostics' `competing`, and an `estimated` frame whose covariance the mixture term
/// dominates ([`trust::mixture_dominates`]) is flagged `weak` / `competing_motions`.
fn apply_recheck(params: &[f64], b: &[f64], w: f64, diag: &mut FrameDiagnostics) {
    let k = diag.free.len();
    if b.len() != k || diag.covariance.len() != k * k {
        return;
    }
    // The diagnostics keep the covariance row by row (`fill_diagnostics`).
    let cov = nalgebra::DMatrix::from_row_slice(k, k, &diag.covariance);
    let a: Vec<f64> = diag.free.iter().map(|&i| params[i]).collect();
    if trust::mixture_dominates(&cov, &a, b, w) {
        flag_weak_report_only(diag, Reason::CompetingMotions);
    }
    let mixed = trust::mixture_covariance(&cov, &a, b, w);
    for (j, &i) in diag.free.iter().enumerate() {
        if let Some(s) = diag.param_sigmas.get_mut(i) {
            *s = mixed[(j, j)].max(0.0).sqrt();
        }
    }
    diag.covariance = mixed.transpose().iter().copied().collect();
    diag.competing = Some((with_free(params, &diag.free, b), w));
}

/// Whether every entry of a covariance is finite (no unconstrained direction).
fn all_finite(c: &nalgebra::DMatrix<f64>) -> bool {
    c.iter().all(|v| v.is_finite())
}

/// The full parameters `params` with the free ones (indices `free`) replaced by `values`: a
/// competing motion's full vector from its free parameters (the diagnostics' `competing`).
fn with_free(params: &[f64], free: &[usize], values: &[f64]) -> Vec<f64> {
    let mut all = params.to_vec();
    for (&i, v) in free.iter().zip(values) {
        all[i] = *v;
    }
    all
}

/// The side slip of a vehicle motion and its horizontal travel: `β = atan2(t_y, t_x) − ω_z / 2`
/// (`t` the translation, `ω = log R`, vehicle frame; a backward translation read as its
/// reverse, so that reversing is no slip) and `‖(t_x, t_y)‖`; `None` without a horizontal
/// translation.
fn side_slip(motion: &Pose<f64>) -> Option<(f64, f64)> {
    let t = &motion.translation;
    let travel = t.x.hypot(t.y);
    if !(travel > 1e-9) {
        return None;
    }
    let (x, y) = if t.x < 0.0 { (-t.x, -t.y) } else { (t.x, t.y) };
    Some((y.atan2(x) - 0.5 * so3_log(&motion.rotation).z, travel))
}

/// Whether a frame's side slip `(β, travel)` ([`side_slip`]) jumps against the centre
/// `(β̄, n)` (mean and frames that fed it) of `trust.side_slip_change`: `|β − β̄|` above it and
/// `travel · sin|β − β̄|` above `trust.side_slip_lateral`, once `n` reached
/// [`crate::trust::SIDE_SLIP_MIN_FRAMES`]; never with the rule off.
fn side_slip_jumps(
    t: &crate::trust::TrustOptions,
    (centre, n): (f64, usize),
    (beta, travel): (f64, f64),
    fraction: f64,
) -> bool {
    let d = (beta - centre).abs();
    t.side_slip_change > 0.0
        && n >= crate::trust::SIDE_SLIP_MIN_FRAMES
        && d > fraction * t.side_slip_change
        && travel * d.min(std::f64::consts::FRAC_PI_2).sin() > fraction * t.side_slip_lateral
}

/// A report-only flag (`trust.support_change_share`, `trust.yaw_change`,
/// `trust.min_inlier_share`): an `estimated` frame
/// becomes `weak` for `reason`; a frame flagged already keeps its status and reason.
fn flag_weak_report_only(diag: &mut FrameDiagnostics, reason: Reason) {
    if diag.status == FrameStatus::Estimated {
        diag.status = FrameStatus::Weak;
        diag.constraint = Constraint::Weak;
        diag.reason = Some(reason);
    }
}

/// Flags an `estimated` frame whose reported covariance is missing or has a non-finite entry
/// (or a free parameter's sigma is not finite) `weak` with [`Reason::IllConditioned`], its free
/// parameters' sigmas infinite ([`trust::invert_information`] gives an unconstrained direction
/// infinite variance; a frame that says `estimated` must report a finite covariance). Report
/// only: the caller runs it after the frame's state is set.
fn flag_ill_conditioned(diag: &mut FrameDiagnostics) {
    if diag.status != FrameStatus::Estimated {
        return;
    }
    let k = diag.free.len();
    let missing = diag.covariance.len() != k * k
        || diag.covariance.iter().any(|v| !v.is_finite())
        || diag
            .free
            .iter()
            .any(|&i| diag.param_sigmas.get(i).is_none_or(|s| !s.is_finite()));
    if !missing {
        return;
    }
    flag_weak_report_only(diag, Reason::IllConditioned);
    for &i in &diag.free {
        if let Some(s) = diag.param_sigmas.get_mut(i) {
            *s = f64::INFINITY;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Widened::recentre`]: widenings added about `from` (a competing motion's mixture and
    /// two alternatives, over the free parameters 0, 1 and 3 of four) and moved to `to` give the
    /// covariance and sigmas of the same widenings added about `to`; a term added about another
    /// motion stays, and a parameter that is not free keeps its sigma.
    #[test]
    fn recentred_widenings_equal_the_widenings_about_the_new_centre() {
        let free = [0, 1, 3];
        let base = nalgebra::DMatrix::from_row_slice(
            3,
            3,
            &[4e-6, 1e-6, 0.0, 1e-6, 9e-6, -2e-6, 0.0, -2e-6, 1e-4],
        );
        let (from, to) = ([0.01, -0.02, 5.0, 1.2], [0.012, -0.021, 5.0, 1.19]);
        let (b, w) = ([0.02, -0.01, 5.0, 1.3], 0.3);
        let alternatives = [[0.0, 0.0, 5.0, 1.0], [0.015, -0.03, 5.0, 1.25]];
        let at = |p: &[f64]| -> Vec<f64> { free.iter().map(|&i| p[i]).collect() };
        let widen_about = |centre: &[f64]| {
            let a = at(centre);
            let mixed = trust::mixture_covariance(&base, &a, &at(&b), w);
            let alts: Vec<Vec<f64>> = alternatives.iter().map(|c| at(c)).collect();
            let alts: Vec<&[f64]> = alts.iter().map(Vec::as_slice).collect();
            trust::alternatives_covariance(&mixed, &a, &alts, 1.0)
        };
        let mut widened = Widened::default();
        widened.add(&from, [b.as_slice()], w * (1.0 - w));
        widened.add(&from, alternatives.iter().map(|c| c.as_slice()), 1.0);
        // A term about another motion is not moved.
        let other = [0.0, 0.0, 5.0, 1.1];
        widened.add(&other, [alternatives[0].as_slice()], 1.0);
        let extra = |centre: &[f64], cov: nalgebra::DMatrix<f64>| {
            let alt = at(&alternatives[0]);
            trust::alternatives_covariance(&cov, &at(centre), &[alt.as_slice()], 1.0)
        };
        let sigmas_of = |m: &nalgebra::DMatrix<f64>| {
            let mut s = vec![0.5; 4];
            for (j, &i) in free.iter().enumerate() {
                s[i] = m[(j, j)].sqrt();
            }
            s
        };
        let before = extra(&other, widen_about(&from));
        let mut covariance: Vec<f64> = before.transpose().iter().copied().collect();
        let mut sigmas = sigmas_of(&before);
        widened.recentre(&from, &to, &free, &mut covariance, &mut sigmas);
        let expected = extra(&other, widen_about(&to));
        let got = nalgebra::DMatrix::from_row_slice(3, 3, &covariance);
        assert!((&got - &expected).norm() < 1e-15, "{got} vs {expected}");
        for (s, e) in sigmas.iter().zip(sigmas_of(&expected)) {
            assert!((s - e).abs() < 1e-12, "{s} vs {e}");
        }
        assert!(
            (got - &before).norm() > 1e-6,
            "the centre moved the covariance"
        );
    }

    /// [`side_slip`]: a planar arc (translation along half the yaw) has no slip, a sideways
    /// step has a quarter turn less half the yaw, a backward step is read as its reverse, and
    /// no horizontal translation has none; [`side_slip_jumps`] needs both the angle and the
    /// sideways metres, and enough frames in the centre.
    #[test]
    fn side_slip_reads_the_direction_of_travel_against_the_chord() {
        let yaw = 0.04_f64;
        let r = momo_core::so3_exp(&nalgebra::Vector3::new(0.0, 0.0, yaw));
        let along =
            |a: f64, l: f64| Pose::new(r, nalgebra::Vector3::new(l * a.cos(), l * a.sin(), 0.0));
        let (b, travel) = side_slip(&along(0.5 * yaw, 1.5)).expect("moving");
        assert!(
            b.abs() < 1e-12 && (travel - 1.5).abs() < 1e-12,
            "{b} {travel}"
        );
        let (b, _) = side_slip(&along(std::f64::consts::FRAC_PI_2, 1.0)).expect("moving");
        assert!(
            (b - (std::f64::consts::FRAC_PI_2 - 0.5 * yaw)).abs() < 1e-12,
            "{b}"
        );
        let (b, _) = side_slip(&along(std::f64::consts::PI + 0.5 * yaw, 1.0)).expect("moving");
        assert!(b.abs() < 1e-12, "reversing: {b}");
        assert!(side_slip(&Pose::new(r, nalgebra::Vector3::new(0.0, 0.0, 0.3))).is_none());
        let t = crate::trust::TrustOptions::default();
        let n = crate::trust::SIDE_SLIP_MIN_FRAMES;
        // 0.08 rad at 1.5 m: 0.12 m sideways; at 1.0 m only 0.08 m.
        assert!(side_slip_jumps(&t, (0.01, n), (0.09, 1.5), 1.0));
        assert!(!side_slip_jumps(&t, (0.01, n), (0.09, 1.0), 1.0));
        // 0.05 rad at 3 m: 0.15 m sideways, but within the angle.
        assert!(!side_slip_jumps(&t, (0.0, n), (-0.05, 3.0), 1.0));
        assert!(!side_slip_jumps(&t, (0.01, n - 1), (0.09, 1.5), 1.0));
        // In `side_slip_hold`'s hold, half of each: 0.05 rad at 3 m is one, 0.02 rad is not.
        let half = crate::trust::SIDE_SLIP_HOLD_FRACTION;
        assert!(side_slip_jumps(&t, (0.0, n), (-0.05, 3.0), half));
        assert!(!side_slip_jumps(&t, (0.0, n), (-0.02, 3.0), half));
        assert!(!side_slip_jumps(&t, (0.0, n), (-0.05, 0.9), half));
        let off = crate::trust::TrustOptions {
            side_slip_change: 0.0,
            ..t
        };
        assert!(!side_slip_jumps(&off, (0.01, n), (0.09, 1.5), 1.0));
    }

    #[test]
    fn the_consistency_widening_waits_after_a_flagged_frame_or_stops_at_the_first() {
        let mut opts = crate::config::OdometryOptions {
            soft_prior_consistency_frames: 10,
            soft_prior_consistency_never_after_flag: false,
            ..Default::default()
        };
        // Before any flagged frame: on; within CONSISTENCY_QUIET_FRAMES after one: off; after
        // that many: on again, unless `soft_prior_consistency_never_after_flag`.
        assert!(consistency_acts(usize::MAX, &opts));
        assert!(!consistency_acts(0, &opts));
        assert!(!consistency_acts(CONSISTENCY_QUIET_FRAMES - 1, &opts));
        assert!(consistency_acts(CONSISTENCY_QUIET_FRAMES, &opts));
        assert!(consistency_acts(usize::MAX - 1, &opts));
        opts.soft_prior_consistency_never_after_flag = true;
        assert!(consistency_acts(usize::MAX, &opts));
        assert!(!consistency_acts(0, &opts));
        assert!(!consistency_acts(CONSISTENCY_QUIET_FRAMES, &opts));
        assert!(!consistency_acts(usize::MAX - 1, &opts));
    }

    #[test]
    fn the_trend_moves_the_centre_only_by_the_level_beyond_z_standard_errors() {
        // Two residuals at the model's width (k = 1), centre 0, ten frames of data-only
        // levels (q_d, v) in units of the model's sigma; z = 2.
        let mut opts = crate::config::OdometryOptions {
            soft_prior_trend_frames: 10,
            soft_prior_trend_z: 2.0,
            soft_prior_trend_blend: false,
            soft_prior_trend_widen: false,
            ..Default::default()
        };
        let levels = |f: &dyn Fn(usize) -> [(f64, f64); 2]| {
            (0..12)
                .map(|j| f(j).to_vec())
                .collect::<std::collections::VecDeque<_>>()
        };
        // Residual 0 scatters around the centre (mean 0.5 < 2 e = 2 √(10 · 2) / 10 = 0.894),
        // residual 1 sits at 3 with v = 3: e = √(10 · 4) / 10 = 0.632, the centre moves by
        // 3 − 2 · 0.632 = 1.735.
        let l = levels(&|j| [(if j % 2 == 0 { 1.5 } else { -0.5 }, 1.0), (3.0, 3.0)]);
        let mut c = vec![0.0, 0.0];
        trend_shifted_center(&mut c, &mut [1.0, 1.0], &l, &opts);
        assert_eq!(c[0], 0.0);
        let e = (40.0f64).sqrt() / 10.0;
        assert!((c[1] - (3.0 - 2.0 * e)).abs() < 1e-12, "{c:?}");
        // Below the centre: moved down, symmetric.
        let l = levels(&|_| [(0.0, 1.0), (-3.0, 3.0)]);
        let mut c = vec![0.0, 0.0];
        trend_shifted_center(&mut c, &mut [1.0, 1.0], &l, &opts);
        assert!((c[1] + (3.0 - 2.0 * e)).abs() < 1e-12, "{c:?}");
        // Relative to the centre: a centre already at the level stays.
        let l = levels(&|_| [(0.0, 1.0), (3.0, 3.0)]);
        let mut c = vec![0.0, 3.0];
        trend_shifted_center(&mut c, &mut [1.0, 1.0], &l, &opts);
        assert_eq!(c, vec![0.0, 3.0]);
        // The newest ten frames only: two old frames far off before ten at the centre.
        let l = levels(&|j| {
            if j < 2 {
                [(50.0, 0.0); 2]
            } else {
                [(0.0, 1.0); 2]
            }
        });
        let mut c = vec![0.0, 0.0];
        trend_shifted_center(&mut c, &mut [1.0, 1.0], &l, &opts);
        assert_eq!(c, vec![0.0, 0.0]);
        // A wider prior (k = 0.5: σ² = 4) widens the standard error: e = √(10 · 7) / 10, so the
        // same level moves the centre less.
        let l = levels(&|_| [(0.0, 1.0), (3.0, 3.0)]);
        let mut c = vec![0.0, 0.0];
        trend_shifted_center(&mut c, &mut [1.0, 0.5], &l, &opts);
        assert!(
            (c[1] - (3.0 - 2.0 * (70.0f64).sqrt() / 10.0)).abs() < 1e-12,
            "{c:?}"
        );
        // Fewer than m samples, or off: unchanged.
        let short: std::collections::VecDeque<_> = l.iter().take(9).cloned().collect();
        let mut c = vec![0.0, 0.0];
        trend_shifted_center(&mut c, &mut [1.0, 1.0], &short, &opts);
        assert_eq!(c, vec![0.0, 0.0]);
        opts.soft_prior_trend_frames = 0;
        trend_shifted_center(&mut c, &mut [1.0, 1.0], &l, &opts);
        assert_eq!(c, vec![0.0, 0.0]);
    }

    #[test]
    fn the_trend_blend_shrinks_by_the_level_variance_and_widening_adds_its_posterior_variance() {
        // Ten frames at the model's width (k = 1), centre 0. Residual 0 alternates 1.5 / -0.5
        // with v = 1 (δ = 0.5, e² = 10 · 2 / 100 = 0.2); residual 1 sits at 3 with v = 3
        // (δ = 3, e² = 10 · 4 / 100 = 0.4).
        let levels: std::collections::VecDeque<Vec<(f64, f64)>> = (0..10)
            .map(|j| vec![(if j % 2 == 0 { 1.5 } else { -0.5 }, 1.0), (3.0, 3.0)])
            .collect();
        let mut opts = crate::config::OdometryOptions {
            soft_prior_trend_frames: 10,
            soft_prior_trend_z: 1.0,
            soft_prior_trend_blend: true,
            soft_prior_trend_widen: false,
            ..Default::default()
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        // Blend, z = 1: g = 1 − e² / δ², 0.2 for residual 0 and 1 − 0.4 / 9 for residual 1;
        // the widths stay without widening.
        let (mut c, mut k) = (vec![0.0, 0.0], vec![1.0, 1.0]);
        trend_shifted_center(&mut c, &mut k, &levels, &opts);
        let g = [1.0 - 0.2 / 0.25, 1.0 - 0.4 / 9.0];
        assert!(close(c[0], g[0] * 0.5) && close(c[1], g[1] * 3.0), "{c:?}");
        assert_eq!(k, vec![1.0, 1.0]);
        // The blend moves further than the soft threshold beyond the threshold (same z).
        opts.soft_prior_trend_blend = false;
        let (mut cs, mut ks) = (vec![0.0, 0.0], vec![1.0, 1.0]);
        trend_shifted_center(&mut cs, &mut ks, &levels, &opts);
        let gs = 1.0 - 0.4f64.sqrt() / 3.0;
        assert!(close(cs[1], gs * 3.0) && cs[1] < c[1], "{cs:?}");
        // Widening: σ² = 1 + g e² where the centre moved, for either gain.
        opts.soft_prior_trend_widen = true;
        let (mut cs, mut ks) = (vec![0.0, 0.0], vec![1.0, 1.0]);
        trend_shifted_center(&mut cs, &mut ks, &levels, &opts);
        assert!(close(cs[1], gs * 3.0), "{cs:?}");
        assert!(close(ks[1], 1.0 / (1.0 + gs * 0.4).sqrt()), "{ks:?}");
        opts.soft_prior_trend_blend = true;
        let (mut c, mut k) = (vec![0.0, 0.0], vec![1.0, 1.0]);
        trend_shifted_center(&mut c, &mut k, &levels, &opts);
        assert!(close(c[0], g[0] * 0.5) && close(c[1], g[1] * 3.0), "{c:?}");
        assert!(close(k[0], 1.0 / (1.0 + g[0] * 0.2).sqrt()), "{k:?}");
        assert!(close(k[1], 1.0 / (1.0 + g[1] * 0.4).sqrt()), "{k:?}");
        // z = 2: residual 0 (δ² = 0.25 < 4 e² = 0.8) neither moves nor widens.
        opts.soft_prior_trend_z = 2.0;
        let (mut c, mut k) = (vec![0.0, 0.0], vec![1.0, 1.0]);
        trend_shifted_center(&mut c, &mut k, &levels, &opts);
        assert_eq!((c[0], k[0]), (0.0, 1.0));
        let g1 = 1.0 - 4.0 * 0.4 / 9.0;
        assert!(close(c[1], g1 * 3.0), "{c:?}");
        assert!(close(k[1], 1.0 / (1.0 + g1 * 0.4).sqrt()), "{k:?}");
    }

    #[test]
    fn the_consistency_widening_yields_only_where_the_recent_innovations_disagree() {
        // Two residuals at the model's width (k = 1), ten frames of innovations (d², v) in
        // units of the model's sigma.
        let mut opts = crate::config::OdometryOptions {
            soft_prior_consistency_frames: 10,
            soft_prior_consistency_limit: 2.0,
            ..Default::default()
        };
        let samples = |f: &dyn Fn(usize) -> [(f64, f64); 2]| {
            (0..12)
                .map(|j| (1.0, f(j).to_vec()))
                .collect::<std::collections::VecDeque<_>>()
        };
        // Residual 0 agrees (d² = σ² + v: NIS 1), residual 1 keeps disagreeing (d² = 26, v =
        // 1): the width that makes its mean NIS 1 is σ'² = 25.
        let s = samples(&|_| [(2.0, 1.0), (26.0, 1.0)]);
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &s, &opts);
        assert_eq!(k[0], 1.0);
        assert!((k[1] - 0.2).abs() < 1e-9, "{k:?}");
        // The newest ten frames only: two old disagreeing frames before ten agreeing ones.
        let s = samples(&|j| {
            if j < 2 {
                [(2.0, 1.0), (400.0, 0.0)]
            } else {
                [(2.0, 1.0); 2]
            }
        });
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &s, &opts);
        assert_eq!(k, vec![1.0, 1.0]);
        // At the limit (mean NIS 2 = T): unchanged.
        let at = samples(&|_| [(2.0, 1.0), (4.0, 1.0)]);
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &at, &opts);
        assert_eq!(k, vec![1.0, 1.0]);
        // Only the listed residuals; fewer samples than K: unchanged; K = 0: off.
        let s = samples(&|_| [(26.0, 1.0), (26.0, 1.0)]);
        opts.soft_prior_consistency_residuals = vec![1];
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &s, &opts);
        assert_eq!(k[0], 1.0);
        assert!((k[1] - 0.2).abs() < 1e-9, "{k:?}");
        let short: std::collections::VecDeque<_> = s.iter().take(9).cloned().collect();
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &short, &opts);
        assert_eq!(k, vec![1.0, 1.0]);
        opts.soft_prior_consistency_frames = 0;
        consistency_widened_inv_scale(&mut k, &s, &opts);
        assert_eq!(k, vec![1.0, 1.0]);
        // The median statistic: one frame pulled far off does not widen it (the mean does),
        // a persistent disagreement does (median ratio at the χ²₁ median: σ'² = 25 / 0.455 − 1).
        opts.soft_prior_consistency_frames = 10;
        opts.soft_prior_consistency_residuals.clear();
        let one = samples(&|j| [(0.4, 0.0), (if j == 5 { 1000.0 } else { 0.5 }, 0.0)]);
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &one, &opts);
        assert!(k[1] < 0.2, "{k:?}");
        opts.soft_prior_consistency_median = true;
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &one, &opts);
        assert_eq!(k, vec![1.0, 1.0]);
        let s = samples(&|_| [(0.4, 0.0), (26.0, 1.0)]);
        let mut k = vec![1.0, 1.0];
        consistency_widened_inv_scale(&mut k, &s, &opts);
        let expected = 26.0 / CHI2_1_MEDIAN - 1.0;
        assert!(
            (1.0 / (k[1] * k[1]) - expected).abs() < 1e-6 * expected,
            "{k:?}"
        );
        assert_eq!(k[0], 1.0);
    }

    /// The kept matches' constants: the masked rows (`m` per match, camera by camera) in order;
    /// none where the constants do not cover the mask.
    #[test]
    fn subset_constants_keep_the_masked_rows_in_order() {
        let c: Vec<f64> = (0..12).map(f64::from).collect();
        let mask = vec![vec![true, false, false, true], vec![false, true]];
        assert_eq!(
            subset_constants(&c, 2, &mask),
            Some(vec![0.0, 1.0, 6.0, 7.0, 10.0, 11.0])
        );
        assert_eq!(subset_constants(&c[1..], 2, &mask), None);
        assert_eq!(subset_constants(&c, 0, &mask), None);
    }

    #[test]
    fn the_quiet_memory_check_tells_an_object_from_random_mismatches() {
        // The labels of 10 matches outside the support; a fifth of all remembered matches are
        // other. Random mismatches: 2 of 10 other (no excess); an object: all 10 (excess 0.8);
        // 7 labelled (all other): too few to show anything.
        let random: Vec<Vec<Option<bool>>> = vec![(0..10).map(|k| Some(k % 5 != 0)).collect()];
        assert_eq!(quiet_memory(&random, 0.2), 0.0);
        let object: Vec<Vec<Option<bool>>> = vec![vec![Some(false); 10]];
        assert!((quiet_memory(&object, 0.2) - 0.8).abs() < 1e-12);
        let few: Vec<Vec<Option<bool>>> = vec![(0..10).map(|k| (k < 7).then_some(false)).collect()];
        assert_eq!(quiet_memory(&few, 0.2), 0.0);
        assert_eq!(quiet_memory(&[vec![None; 10]], 0.2), 0.0);
    }

    #[test]
    fn quiet_frames_skip_the_alternatives_of_a_static_scene_with_the_same_poses() {
        use momo_sim::{SimConfig, simulate};
        let cfg = SimConfig {
            frames: 41,
            seed: 3,
            ..SimConfig::clean_pinhole()
        };
        let sim = simulate(&cfg).expect("the clean scenario simulates");
        let seq = &sim.sequence;
        let run = |text: &str| {
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            let mut params = Vec::new();
            let mut competing = 0;
            for k in 1..seq.num_frames() {
                let arc = seq.arc_length(k);
                let r = vo.process(&seq.frames[k], arc);
                competing += usize::from(vo.quiet_streak == 0);
                params.push(r.diagnostics.params);
            }
            (params, vo.quiet_frames_taken(), competing)
        };
        let (plain, none, competing) = run("");
        let (quiet, taken, _) = run("[odometry]\nquiet_frames = 3\n");
        assert_eq!(none, 0);
        // No frame of the default kept an alternative, so every quiet frame is the default's.
        assert_eq!(competing, 0);
        assert!(taken >= 20, "{taken} quiet frames of 40");
        assert_eq!(plain, quiet);
    }

    /// `reset` forgets every frame seen (`crate::batch` relies on it): after a reset the
    /// driver repeats a fresh driver's estimates bit for bit, also where state learnt over
    /// the frames acts (the learnt parallax cap's counts on 30 % mismatches, the
    /// residual-clustering trigger).
    #[test]
    fn a_reset_driver_repeats_a_fresh_one() {
        use momo_sim::{SimConfig, simulate};
        let sim = simulate(&SimConfig {
            frames: 151,
            seed: 23,
            ..SimConfig::outliers()
        })
        .expect("the outliers scenario simulates");
        let seq = &sim.sequence;
        let mut vo = Odometry::new(seq.rig.clone(), crate::Config::default()).expect("builds");
        let pass = |vo: &mut Odometry| {
            (1..seq.num_frames())
                .map(|k| {
                    let arc = seq.arc_length(k);
                    vo.process(&seq.frames[k], arc).diagnostics.params
                })
                .collect::<Vec<_>>()
        };
        let fresh = pass(&mut vo);
        vo.reset(None);
        let again = pass(&mut vo);
        assert_eq!(fresh, again);
    }

    #[test]
    fn the_fast_preset_is_the_default_with_the_quiet_frame_path() {
        let fast = crate::Config::from_toml_str(
            include_str!("../../../configs/fast.toml"),
            "configs/fast.toml",
        )
        .expect("the preset parses");
        let mut default = crate::Config::from_toml_str("", "default.toml").expect("parses");
        assert!(fast.odometry.quiet_frames > 0);
        assert!(!fast.trust.jackknife_undefined_report_only);
        default.odometry.quiet_frames = fast.odometry.quiet_frames;
        default.odometry.quiet_other_share = fast.odometry.quiet_other_share;
        default.trust.jackknife_undefined_report_only = false;
        assert_eq!(fast.odometry, default.odometry);
        assert_eq!(fast.trust, default.trust);
    }

    #[test]
    fn the_realtime_preset_is_the_fast_one_with_the_lengthened_steps() {
        // Everything the presets set, serialised whole (solver, model, metric, loss included):
        // nothing else may differ from the default.
        let text = |c: &crate::Config| toml::to_string(c).expect("serialises");
        let realtime = crate::Config::from_toml_str(
            include_str!("../../../configs/realtime.toml"),
            "configs/realtime.toml",
        )
        .expect("the preset parses");
        let fast = crate::Config::from_toml_str(
            include_str!("../../../configs/fast.toml"),
            "configs/fast.toml",
        )
        .expect("the preset parses");
        let mut expected = crate::Config::from_toml_str(
            "[solver]\ntype = \"levenberg_marquardt\"\nmax_step_extrapolation = 2.0\n",
            "expected.toml",
        )
        .expect("parses");
        assert_ne!(text(&realtime), text(&fast));
        expected.odometry = fast.odometry.clone();
        expected.trust = fast.trust.clone();
        assert_eq!(text(&realtime), text(&expected));
    }

    #[test]
    fn a_learnt_jitter_widens_the_soft_prior_of_short_steps_only() {
        // k = 0.5 (σ = 2 model sigmas), δ² = 0.12: at s = 0.2 m σ² = 4 + 3 = 7, at s = 10 m
        // σ² = 4.0012; no jitter or no arc length: unchanged.
        let mut k = vec![0.5, 1.0];
        arc_widened_inv_scale(&mut k, &[0.12, 0.0], 0.2);
        assert!((k[0] - 1.0 / 7f64.sqrt()).abs() < 1e-12, "{k:?}");
        assert_eq!(k[1], 1.0);
        let mut far = vec![0.5];
        arc_widened_inv_scale(&mut far, &[0.12], 10.0);
        assert!((far[0] - 0.5).abs() < 2e-4 && far[0] < 0.5);
        let mut none = vec![0.5];
        arc_widened_inv_scale(&mut none, &[0.12], 0.0);
        assert_eq!(none, [0.5]);
        // The jitter is the slope of the innovations' excess over 1 / s².
        let pts: Vec<(f64, f64)> = [0.3, 0.5, 1.0, 1.5]
            .iter()
            .map(|s: &f64| (1.0 / (s * s), 2.0 + 0.12 / (s * s)))
            .collect();
        let (a, b) = nonnegative_line_fit(&pts);
        assert!((a - 2.0).abs() < 1e-9 && (b - 0.12).abs() < 1e-9);
    }

    #[test]
    fn the_seeded_jitter_widens_short_steps_until_the_sigmas_are_learnt() {
        use momo_sim::{SimConfig, simulate};
        let cfg = SimConfig {
            frames: 61,
            seed: 5,
            ..SimConfig::clean_pinhole()
        };
        let sim = simulate(&cfg).expect("the clean scenario simulates");
        let seq = &sim.sequence;
        let run = |text: &str| {
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            // Per frame: the jitter in use and the frame's soft-prior factors.
            let mut out = Vec::new();
            for k in 1..seq.num_frames() {
                let arc = seq.arc_length(k);
                let jitter = vo.soft_arc_jitter.clone();
                vo.process(&seq.frames[k], arc);
                out.push((jitter, vo.motion_prior.soft_inv_scale.clone(), arc));
            }
            (out, vo.soft_samples.len())
        };
        let (seeded, learnt) = run("[odometry]\nsoft_prior_arc_jitter = 0.5\n");
        let (plain, _) = run("");
        assert!(learnt >= SOFT_SIGMA_MIN_FRAMES, "{learnt} frames learnt");
        // Before learning: δ² = L² = 0.25 on both residuals, and the frame's factors are
        // 1 / √(1 + L² / s²) of the model's (the estimate's arc length, near the truth).
        let (j, k, arc) = &seeded[2];
        assert_eq!(j, &[0.25, 0.25]);
        let s = arc.expect("the scenario has odometry");
        for k in k {
            let want = 1.0 / (1.0 + 0.25 / (s * s)).sqrt();
            assert!(
                (k - want).abs() < 0.05 * want,
                "k {k}, want {want} at s = {s}"
            );
        }
        // Without the seed the factors are the model's.
        assert!(plain[2].1.iter().all(|k| *k == 1.0), "{:?}", plain[2].1);
        // Once learnt (without `soft_prior_arc_learning`) the seed is gone.
        let (j, _, _) = seeded.last().expect("frames");
        assert!(j.is_empty(), "{j:?}");
    }

    /// `soft_prior_learn_competing`: off, only frames reported `estimated` teach the soft prior
    /// (none flagged `weak` for competing motions); on, the surround rig's frames where two
    /// motions competed teach it too, so it learns from more frames.
    #[test]
    fn the_soft_prior_learns_from_competing_frames_only_when_asked() {
        use momo_sim::{SimConfig, simulate};
        let cfg = SimConfig {
            frames: 60,
            seed: 1,
            ..SimConfig::moving_traffic_surround()
        };
        let sim = simulate(&cfg).expect("the rig traffic scenario simulates");
        let seq = &sim.sequence;
        // Per frame: whether the soft prior learnt from it, its status and reason.
        let run = |text: &str| {
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            let mut out = Vec::new();
            for k in 1..seq.num_frames() {
                let before = vo.soft_count;
                let r = vo.process(&seq.frames[k], seq.arc_length(k));
                let d = r.diagnostics;
                out.push((vo.soft_count > before, d.status, d.reason));
            }
            out
        };
        let competing_weak = |&(_, s, r): &(bool, FrameStatus, Option<Reason>)| {
            s == FrameStatus::Weak && r == Some(Reason::CompetingMotions)
        };
        let off = run("");
        let on = run("[odometry]\nsoft_prior_learn_competing = true\n");
        let learnt = |v: &[(bool, FrameStatus, Option<Reason>)]| v.iter().filter(|f| f.0).count();
        // Off: every frame that taught the prior was reported `estimated`, while some frames
        // were flagged for competing motions.
        assert!(
            off.iter()
                .filter(|f| f.0)
                .all(|f| f.1 == FrameStatus::Estimated)
        );
        assert!(off.iter().any(competing_weak), "no frame competed: {off:?}");
        // On: a frame flagged for competing motions taught it, and more frames did.
        assert!(on.iter().any(|f| f.0 && competing_weak(f)), "{on:?}");
        assert!(
            learnt(&on) > learnt(&off),
            "{} <= {}",
            learnt(&on),
            learnt(&off)
        );
    }

    /// `soft_prior_cauchy`: the frame's motion prior carries the Cauchy scale on the listed
    /// soft-prior residuals only (the climb by default), none where the option is off; an
    /// index the model does not have and a negative scale are configuration errors.
    #[test]
    fn the_cauchy_soft_prior_reaches_the_frame_prior_only_when_asked() {
        use momo_sim::{SimConfig, simulate};
        let cfg = SimConfig {
            frames: 6,
            seed: 1,
            ..SimConfig::moving_traffic_surround()
        };
        let sim = simulate(&cfg).expect("the rig traffic scenario simulates");
        let seq = &sim.sequence;
        let run = |text: &str| {
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            for k in 1..seq.num_frames() {
                vo.process(&seq.frames[k], seq.arc_length(k));
            }
            vo.motion_prior.soft_cauchy.clone()
        };
        // The default is the gated Cauchy (b = 5 while unlearnt, where fewer than half of at
        // least 5 moving frames taught the prior, on a rig of two or more cameras).
        let o = crate::Config::default().odometry;
        assert_eq!(
            (
                o.soft_prior_cauchy,
                o.soft_prior_cauchy_until_learnt,
                o.soft_prior_cauchy_taught_share,
                o.soft_prior_cauchy_after_moving,
                o.soft_prior_cauchy_min_cameras
            ),
            (5.0, true, 0.5, 5, 2)
        );
        // Ungated, so that every frame carries the scales.
        const UNGATED: &str = "soft_prior_cauchy_until_learnt = false\nsoft_prior_cauchy_taught_share = 0.0\nsoft_prior_cauchy_min_cameras = 1\n";
        assert!(run("[odometry]\nsoft_prior_cauchy = 0.0\n").is_empty());
        assert_eq!(
            run(&format!("[odometry]\nsoft_prior_cauchy = 3.0\n{UNGATED}")),
            vec![0.0, 3.0]
        );
        assert_eq!(
            run(&format!(
                "[odometry]\nsoft_prior_cauchy = 2.0\nsoft_prior_cauchy_residuals = []\n{UNGATED}"
            )),
            vec![2.0, 2.0]
        );
        let bad = "[odometry]\nsoft_prior_cauchy = 3.0\nsoft_prior_cauchy_residuals = [2]\n";
        let config = crate::Config::from_toml_str(bad, "t.toml").expect("parses");
        assert!(config.validate_for_rig(&seq.rig).is_err());
        assert!(
            crate::Config::from_toml_str("[odometry]\nsoft_prior_cauchy = -1.0\n", "t.toml")
                .is_err()
        );
    }

    /// `soft_prior_cauchy_until_learnt`: the Cauchy scales reach the frame's motion prior while
    /// fewer than `SOFT_SIGMA_MIN_FRAMES` frames have taught the soft prior, and not once it has
    /// learnt its sigmas; without the gate they stay on after learning.
    #[test]
    fn the_gated_cauchy_soft_prior_stops_once_the_sigmas_are_learnt() {
        use momo_sim::{SimConfig, simulate};
        let cfg = SimConfig {
            frames: 61,
            seed: 5,
            ..SimConfig::clean_pinhole()
        };
        let sim = simulate(&cfg).expect("the clean scenario simulates");
        let seq = &sim.sequence;
        // Per frame: whether the sigmas were learnt when the frame's prior was set, its scales.
        let run = |text: &str| {
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            let mut out = Vec::new();
            for k in 1..seq.num_frames() {
                let learnt = vo.soft_samples.len() >= SOFT_SIGMA_MIN_FRAMES;
                vo.process(&seq.frames[k], seq.arc_length(k));
                out.push((learnt, vo.motion_prior.soft_cauchy.clone()));
            }
            out
        };
        // The lag and camera gates off (a single camera), so that only the learning decides.
        let no_lag = "soft_prior_cauchy_taught_share = 0.0\nsoft_prior_cauchy_min_cameras = 1\n";
        let gated = run(&format!(
            "[odometry]\nsoft_prior_cauchy = 3.0\nsoft_prior_cauchy_until_learnt = true\n{no_lag}"
        ));
        let always = run(&format!(
            "[odometry]\nsoft_prior_cauchy = 3.0\nsoft_prior_cauchy_until_learnt = false\n{no_lag}"
        ));
        assert!(gated.iter().any(|f| !f.0), "no frame before learning");
        assert!(gated.iter().any(|f| f.0), "the sigmas were never learnt");
        for (k, (learnt, b)) in gated.iter().enumerate() {
            if *learnt {
                assert!(b.is_empty(), "frame {}: learnt, scales {b:?}", k + 1);
            } else {
                assert_eq!(b, &[0.0, 3.0], "frame {}: not learnt", k + 1);
            }
        }
        assert!(always.iter().all(|f| f.1 == [0.0, 3.0]), "{always:?}");
    }

    /// `soft_prior_cauchy_taught_share` / `_after_moving` / `_min_cameras` at the function: the
    /// scales are on exactly where at least `N0` moving frames came before and fewer than
    /// `ρ` of them taught the prior, on a rig of enough cameras.
    #[test]
    fn the_learning_lag_gate_opens_only_where_teaching_lags() {
        let config = crate::Config::from_toml_str(
            "[odometry]\nsoft_prior_cauchy = 10.0\nsoft_prior_cauchy_taught_share = 0.5\n\
             soft_prior_cauchy_after_moving = 5\nsoft_prior_cauchy_min_cameras = 2\n\
             soft_prior_cauchy_until_learnt = false\n",
            "t.toml",
        )
        .expect("a valid config");
        let o = &config.odometry;
        let on = vec![0.0, 10.0];
        // The state holds: 5 or more moving frames, fewer than half taught, four cameras.
        assert_eq!(soft_cauchy_scales(o, 2, false, (5, 0), 4), on);
        assert_eq!(soft_cauchy_scales(o, 2, false, (10, 4), 4), on);
        assert_eq!(soft_cauchy_scales(o, 2, true, (100, 20), 2), on);
        // It does not: too few moving frames, half or more taught, a single camera.
        assert!(soft_cauchy_scales(o, 2, false, (4, 0), 4).is_empty());
        assert!(soft_cauchy_scales(o, 2, false, (10, 5), 4).is_empty());
        assert!(soft_cauchy_scales(o, 2, false, (10, 9), 4).is_empty());
        assert!(soft_cauchy_scales(o, 2, false, (10, 0), 1).is_empty());
        // Off (ρ = 0, one camera enough): the scales from the first frame on, as before.
        let off = crate::Config::from_toml_str(
            "[odometry]\nsoft_prior_cauchy = 10.0\nsoft_prior_cauchy_taught_share = 0.0\n\
             soft_prior_cauchy_min_cameras = 1\nsoft_prior_cauchy_until_learnt = false\n",
            "t.toml",
        )
        .expect("a valid config");
        assert_eq!(soft_cauchy_scales(&off.odometry, 2, false, (0, 0), 1), on);
        let bad = "[odometry]\nsoft_prior_cauchy_taught_share = 1.5\n";
        assert!(crate::Config::from_toml_str(bad, "t.toml").is_err());
    }

    /// The learning-lag gate in the driver: on the surround rig in traffic (its frames compete
    /// with some vehicle, few teach the soft prior) the Cauchy scales reach the frame's motion
    /// prior, and on every frame exactly where the gate's state held before the frame; on the
    /// same rig in a static scene (every moving frame teaches) and on a single camera in
    /// traffic under `soft_prior_cauchy_min_cameras = 2` never.
    #[test]
    fn the_learning_lag_gate_acts_on_the_starved_rig_only() {
        use momo_sim::{SimConfig, simulate};
        let text = "[odometry]\nsoft_prior_cauchy = 10.0\nsoft_prior_cauchy_taught_share = 0.5\n\
                    soft_prior_cauchy_after_moving = 5\nsoft_prior_cauchy_min_cameras = 2\n";
        // Per frame: whether the gate's state held when the frame's prior was set, its scales.
        let run = |cfg: SimConfig| {
            let sim = simulate(&cfg).expect("the scenario simulates");
            let seq = &sim.sequence;
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            let mut out = Vec::new();
            for k in 1..seq.num_frames() {
                let state = vo.soft_moving >= 5
                    && (vo.soft_taught as f64) < 0.5 * vo.soft_moving as f64
                    && seq.rig.len() >= 2;
                vo.process(&seq.frames[k], seq.arc_length(k));
                out.push((state, vo.motion_prior.soft_cauchy.clone()));
            }
            out
        };
        // Seed 2: a vehicle competes from the start (seeds 1, 2 and 4 lag, 3 and 5-8 teach).
        let rig = run(SimConfig {
            frames: 41,
            seed: 2,
            ..SimConfig::moving_traffic_surround()
        });
        for (k, (state, b)) in rig.iter().enumerate() {
            if *state {
                assert_eq!(b, &[0.0, 10.0], "rig frame {}: the state held", k + 1);
            } else {
                assert!(b.is_empty(), "rig frame {}: no state, scales {b:?}", k + 1);
            }
        }
        assert!(
            rig.iter().any(|f| f.0),
            "the rig in traffic never lagged: {rig:?}"
        );
        let calm = run(SimConfig {
            frames: 41,
            seed: 3,
            stops: false,
            blinded: Vec::new(),
            ..SimConfig::fisheye_surround()
        });
        assert!(calm.iter().all(|f| !f.0 && f.1.is_empty()), "{calm:?}");
        let mono = run(SimConfig {
            frames: 41,
            seed: 3,
            ..SimConfig::moving_traffic()
        });
        assert!(mono.iter().all(|f| !f.0 && f.1.is_empty()), "{mono:?}");
    }

    /// `decide_by_road`'s choice: the best alternative where it beats the chosen motion's road
    /// score by the margin, the first of equal ones; nothing otherwise, without alternatives or
    /// with the option off.
    #[test]
    fn pick_by_road_overturns_only_by_the_margin() {
        assert_eq!(pick_by_road(5, &[7, 9, 3], 3), Some(1));
        assert_eq!(pick_by_road(5, &[7, 6], 3), None);
        assert_eq!(pick_by_road(5, &[8], 3), Some(0));
        assert_eq!(pick_by_road(0, &[4, 4], 3), Some(0));
        assert_eq!(pick_by_road(5, &[], 3), None);
        assert_eq!(pick_by_road(0, &[40], 0), None);
        assert_eq!(pick_by_road(usize::MAX, &[usize::MAX], 1), None);
    }

    /// `decide_by_road_yaw_jump`: a car in a turn of 3 deg per frame does not go straight in
    /// the next frame; an alternative that does (a lead vehicle's motion, docs/RESULTS.md,
    /// fiftieth session) does not compete where the chosen motion continues the turn, and does
    /// where the chosen motion jumped as far, or with the bound off.
    #[test]
    fn decide_by_road_yaw_jump_bounds_the_change_of_yaw() {
        let (previous, chosen, car) = (-0.0536, -0.0424, 0.0086);
        assert!(!within_yaw_jump(previous, chosen, car, 0.03));
        assert!(within_yaw_jump(previous, chosen, car, 0.0));
        assert!(within_yaw_jump(previous, chosen, car, 0.07));
        // Within the bound either way, and a turn that continues.
        assert!(within_yaw_jump(previous, chosen, -0.03, 0.03));
        assert!(within_yaw_jump(previous, chosen, -0.0526, 0.03));
        // A chosen motion that jumped as far (the car's, 0.062 rad): an alternative 0.06 rad
        // from the previous yaw competes; after one that jumped 0.054 rad the car's does not.
        assert!(within_yaw_jump(previous, car, previous + 0.06, 0.03));
        assert!(!within_yaw_jump(previous, 0.0, car, 0.03));
        assert!(!within_yaw_jump(previous, chosen, f64::NAN, 0.03));
        assert!(within_yaw_jump(previous, chosen, car, f64::NAN));
    }

    /// `decide_by_road_yaw_margin`: beyond the margin only a road score that would pass the
    /// separation's own veto replaces (conf3 03 s82 frame 70, a lead car's motion 17 road
    /// cells against the chosen motion's 12, 1.13 deg from the previous frame's yaw: not
    /// decisive; the fiftieth session's 08 s7 frame 495, 8 against 1: below the least
    /// score).
    #[test]
    fn beyond_the_yaw_margin_only_a_decisive_road_replaces() {
        let decisive = (12, 2.0);
        assert!(!road_decisive(17, 12, decisive));
        assert!(!road_decisive(8, 1, decisive));
        assert!(road_decisive(24, 12, decisive));
        assert!(road_decisive(12, 0, decisive));
        assert!(!road_decisive(11, 0, decisive));
        assert!(road_decisive(usize::MAX, usize::MAX / 2, decisive));
        // The margin's own test is `within_yaw_jump`'s: 1.13 deg from the previous frame's yaw
        // while the chosen motion moved 0.13 deg is beyond 1 deg, and within 1.7.
        let (previous, chosen, car) = (-0.68f64, -0.815f64, 0.450f64);
        let (previous, chosen, car) =
            (previous.to_radians(), chosen.to_radians(), car.to_radians());
        assert!(!within_yaw_jump(previous, chosen, car, 0.01745));
        assert!(within_yaw_jump(previous, chosen, car, 0.03));
    }

    /// `decide_by_road` in the driver, a single camera in traffic: off (the default) the
    /// estimates are the default configuration's bit for bit; on, it replaces some frame's
    /// motion, the first frame where the estimates part is flagged `weak` and carries a
    /// competing motion or a road alternative, and its motion has more road than the motion
    /// the option-off run chose there.
    #[test]
    fn decide_by_road_acts_on_a_doubted_frame_only() {
        use momo_sim::{SimConfig, simulate};
        let sim = simulate(&SimConfig {
            frames: 120,
            seed: 2,
            ..SimConfig::moving_traffic()
        })
        .expect("the scenario simulates");
        let seq = &sim.sequence;
        let run = |text: &str| {
            let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            (1..seq.num_frames())
                .map(|k| {
                    let r = vo.process(&seq.frames[k], seq.arc_length(k));
                    let score = vo.road_score_of(&seq.frames[k], &r.diagnostics.params);
                    (r.diagnostics, score.map(|s| s.0))
                })
                .collect::<Vec<_>>()
        };
        // The default since the thirty-first session: on, at a margin of 3, with the tilt guard.
        let default = run("");
        let guarded = run("[odometry]\ndecide_by_road = 3\ndecide_by_road_tilt = true\n");
        for (d, o) in default.iter().zip(&guarded) {
            assert_eq!(d.0.params, o.0.params, "frame {}", d.0.frame);
        }
        let off = run("[odometry]\ndecide_by_road = 0\n");
        let on = run("[odometry]\ndecide_by_road = 3\ndecide_by_road_tilt = false\n");
        let first = on
            .iter()
            .zip(&off)
            .position(|(a, b)| a.0.params != b.0.params)
            .expect("the option acted on some frame");
        let (d, score) = &on[first];
        assert_eq!(d.status, FrameStatus::Weak, "frame {}", d.frame);
        assert!(d.competing.is_some() || d.road_alternative.is_some());
        let (on_score, off_score) = (score.expect("scored"), off[first].1.expect("scored"));
        assert!(on_score >= off_score + 3, "{on_score} against {off_score}");
        let yaw = |p: &[f64]| {
            let config = crate::Config::default();
            let vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
            so3_log(&vo.estimator.motion(p).rotation).z
        };
        // `decide_by_road_continuing` (the yaw bound at 0) and `decide_by_road_yaw_jump` at a
        // bound of 1e-5: the first replacement's yaw lies within the bound of the previous
        // frame's, or no further from it than the motion it replaced.
        for (option, bound) in [
            ("decide_by_road_continuing = true", 0.0),
            ("decide_by_road_yaw_jump = 1e-5", 1e-5_f64),
        ] {
            let bounded = run(&format!(
                "[odometry]\ndecide_by_road = 3\ndecide_by_road_tilt = false\n{option}\n"
            ));
            let first = bounded
                .iter()
                .zip(&off)
                .position(|(a, b)| a.0.params != b.0.params)
                .unwrap_or_else(|| panic!("{option}: no frame replaced"));
            assert!(first > 0);
            let y0 = yaw(&off[first - 1].0.params);
            let (y_on, y_off) = (yaw(&bounded[first].0.params), yaw(&off[first].0.params));
            assert_eq!(bounded[first].0.status, FrameStatus::Weak, "{option}");
            assert!(
                (y_on - y0).abs() <= bound.max((y_off - y0).abs()) + 1e-12,
                "{option}: {y_on} {y_off} against {y0}"
            );
        }
        // `decide_by_road_tilt`: the replacement's tilt is no further from the previous frame's
        // reported tilt than the motion it replaced.
        let tilted = guarded;
        let first = tilted
            .iter()
            .zip(&off)
            .position(|(a, b)| a.0.params != b.0.params)
            .expect("the tilt guard leaves some replacement");
        assert!(first > 0);
        let tilt = |p: &[f64]| {
            let vo = Odometry::new(seq.rig.clone(), crate::Config::default())
                .expect("the odometry builds");
            crate::hypotheses::tilt(&vo.estimator.motion(p))
        };
        let t0 = tilt(&off[first - 1].0.params);
        let (t_on, t_off) = (tilt(&tilted[first].0.params), tilt(&off[first].0.params));
        assert_eq!(tilted[first].0.status, FrameStatus::Weak);
        assert!(
            (t_on - t0).abs() <= (t_off - t0).abs() + 1e-12,
            "{t_on} {t_off} against {t0}"
        );
    }

    #[test]
    fn the_cameras_vote_needs_a_clear_majority() {
        // Four cameras: 3 to 1 and 2 to 0 win at a margin of 2, 2 to 1 and ties do not.
        assert!(basin_vote(&[26, 11, 19, 7], &[16, 16, 20, 9], 2));
        assert!(basin_vote(&[10, 10, 10, 10], &[12, 10, 11, 10], 2));
        assert!(!basin_vote(&[12, 37, 17, 8], &[12, 30, 19, 13], 2));
        assert!(!basin_vote(&[10, 10, 10, 10], &[10, 10, 10, 10], 2));
        assert!(!basin_vote(&[10, 20, 10, 10], &[30, 10, 10, 10], 1));
        // A margin of 1 is the plain majority; 0 counts as 1.
        assert!(basin_vote(&[12, 37, 17, 8], &[12, 30, 19, 13], 1));
        assert!(!basin_vote(&[10, 10], &[10, 10], 0));
        assert!(basin_vote(&[10, 10], &[11, 10], 0));
        // Many more matches in one camera do not outvote the others.
        assert!(!basin_vote(&[10, 10, 10, 10], &[90, 9, 9, 10], 1));
    }

    /// A simulated scenario run under a configuration: each frame's reported parameters and
    /// the previous-basin counts at the end (the previous-basin tests).
    fn basin_run(cfg: momo_sim::SimConfig, text: &str) -> (Vec<Vec<f64>>, (usize, usize)) {
        counted_run(cfg, text, Odometry::previous_basin_counts)
    }

    /// Every frame's motion of a simulated sequence under the configuration `text`, and the
    /// run's `counts` at its end.
    fn counted_run(
        cfg: momo_sim::SimConfig,
        text: &str,
        counts: fn(&Odometry) -> (usize, usize),
    ) -> (Vec<Vec<f64>>, (usize, usize)) {
        let sim = momo_sim::simulate(&cfg).expect("the scenario simulates");
        let seq = &sim.sequence;
        let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
        let mut params = Vec::new();
        for k in 1..seq.num_frames() {
            vo.process(&seq.frames[k], seq.arc_length(k));
            params.push(vo.previous_params().to_vec());
        }
        (params, counts(&vo))
    }

    #[test]
    fn the_previous_basin_leaves_a_single_camera_alone_and_acts_on_a_rig() {
        use momo_sim::SimConfig;
        let run = basin_run;
        // Every frame re-solved (the change threshold far below any frame's rotation change).
        let every = "[odometry]\nprevious_basin_change = 1e-12\n";
        let mono = || SimConfig {
            frames: 31,
            seed: 3,
            ..SimConfig::moving_traffic()
        };
        // The default is on (1 deg, since the twenty-ninth session); "off" writes 0.
        let off_text = "[odometry]\nprevious_basin_change = 0.0\n";
        // A single camera without its region vote (on by default since the thirty-first
        // session) is never re-solved by the rig's rule.
        let mono_every =
            "[odometry]\nprevious_basin_change = 1e-12\nprevious_basin_regions = [0, 0]\n";
        let mono_off = "[odometry]\nprevious_basin_change = 0.0\nprevious_basin_regions = [0, 0]\n";
        assert_eq!(
            crate::Config::default().odometry.previous_basin_change,
            0.01745
        );
        let (off, _) = run(mono(), mono_off);
        let (on, counts) = run(mono(), mono_every);
        assert_eq!(counts, (0, 0), "a single camera is never re-solved");
        assert_eq!(off, on, "a single camera's motions are unchanged");
        let rig = || SimConfig {
            frames: 31,
            seed: 2,
            ..SimConfig::moving_traffic_surround()
        };
        let (off, _) = run(rig(), off_text);
        let (on, counts) = run(rig(), every);
        assert!(
            counts.0 >= 25,
            "the rig's moving frames are re-solved: {counts:?}"
        );
        assert!(counts.1 <= counts.0, "{counts:?}");
        // A solution that is not taken changes nothing: identical motions where none was.
        if counts.1 == 0 {
            assert_eq!(off, on);
        }
        // Above every frame's change the rig is not re-solved and its motions are unchanged.
        let (never, counts) = run(rig(), "[odometry]\nprevious_basin_change = 1.0\n");
        assert_eq!(counts, (0, 0));
        assert_eq!(off, never);
        // The option's range.
        for bad in ["-0.01", "nan"] {
            let text = format!("[odometry]\nprevious_basin_change = {bad}\n");
            assert!(
                crate::Config::from_toml_str(&text, "t.toml").is_err(),
                "{bad}"
            );
        }
    }

    #[test]
    fn the_region_vote_counts_each_cell_once() {
        use momo_core::{Camera, Observation, Pinhole};
        use nalgebra::Vector2;
        let cam = Camera::Pinhole(Pinhole {
            fx: 100.0,
            fy: 100.0,
            cx: 50.0,
            cy: 50.0,
            width: 100.0,
            height: 100.0,
        });
        let rig = Rig::mono(cam, Pose::identity()).expect("a rig");
        let ob = |u: f64, v: f64| {
            Observation::new(&cam, Vector2::new(u, v), Vector2::new(u, v)).expect("a match")
        };
        // Two matches in the top-left cell, one in the bottom-right, one bottom-left (outside).
        let mut obs = FrameObservations::new(1);
        obs.per_camera[0] = vec![
            ob(10.0, 10.0),
            ob(20.0, 30.0),
            ob(90.0, 90.0),
            ob(10.0, 90.0),
        ];
        let outside = vec![vec![false, false, false, true]];
        assert_eq!(
            basin_cell_counts(&rig, &obs, &outside, (2, 2)),
            vec![2, 0, 0, 1]
        );
        assert_eq!(basin_cell_counts(&rig, &obs, &outside, (1, 1)), vec![3]);
        // A compact object's many matches in one cell do not outvote the spread-out world:
        // at the alternative one cell gains 40, three cells lose 2 each.
        let current = [10, 10, 10, 10];
        let alt = [50, 8, 8, 8];
        assert!(!basin_vote(&current, &alt, 1));
        // Three of four cells gaining carry a margin of 2.
        assert!(basin_vote(&current, &[12, 11, 11, 9], 2));
        assert!(!basin_vote(&current, &[12, 11, 11, 9], 3));
    }

    /// The frames (1-based, as `Odometry::frame`) where the previous motion's basin was taken,
    /// and the motions.
    fn basin_taken_frames(cfg: momo_sim::SimConfig, text: &str) -> (Vec<Vec<f64>>, Vec<usize>) {
        let sim = momo_sim::simulate(&cfg).expect("the scenario simulates");
        let seq = &sim.sequence;
        let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
        let (mut params, mut taken) = (Vec::new(), Vec::new());
        for k in 1..seq.num_frames() {
            let before = vo.previous_basin_counts().1;
            vo.process(&seq.frames[k], seq.arc_length(k));
            if vo.previous_basin_counts().1 > before {
                taken.push(k);
            }
            params.push(vo.previous_params().to_vec());
        }
        (params, taken)
    }

    #[test]
    fn the_next_frame_margin_acts_only_right_after_a_taken_basin() {
        use momo_sim::SimConfig;
        let mono = || SimConfig {
            frames: 31,
            seed: 3,
            ..SimConfig::moving_traffic()
        };
        assert_eq!(
            crate::Config::default()
                .odometry
                .previous_basin_mono_next_votes,
            0
        );
        let regions =
            "[odometry]\nprevious_basin_regions = [3, 3]\nprevious_basin_mono_change = 1e-12\n";
        // No frame taken (unreachable margin): the next frame's margin never applies, even at 1.
        let (a, ta) = basin_taken_frames(
            mono(),
            &format!("{regions}previous_basin_mono_votes = 100\n"),
        );
        let (b, tb) = basin_taken_frames(
            mono(),
            &format!(
                "{regions}previous_basin_mono_votes = 100\nprevious_basin_mono_next_votes = 1\n"
            ),
        );
        assert!(ta.is_empty() && tb.is_empty(), "{ta:?} {tb:?}");
        assert_eq!(a, b);
        // A plain majority takes some frames; with an unreachable margin on the frame after a
        // taken one (9 cells), no two consecutive frames are taken.
        let (_, plain) =
            basin_taken_frames(mono(), &format!("{regions}previous_basin_mono_votes = 1\n"));
        assert!(!plain.is_empty());
        let (_, spaced) = basin_taken_frames(
            mono(),
            &format!(
                "{regions}previous_basin_mono_votes = 1\nprevious_basin_mono_next_votes = 100\n"
            ),
        );
        assert!(!spaced.is_empty());
        assert!(
            spaced.windows(2).all(|w| w[1] > w[0] + 1),
            "a frame right after a taken one needs the next margin: {spaced:?}"
        );
        // The same margin on the next frame as on every frame changes nothing.
        let (c, tc) = basin_taken_frames(
            mono(),
            &format!(
                "{regions}previous_basin_mono_votes = 1\nprevious_basin_mono_next_votes = 1\n"
            ),
        );
        let (d, td) =
            basin_taken_frames(mono(), &format!("{regions}previous_basin_mono_votes = 1\n"));
        assert_eq!((c, tc), (d, td));
    }

    #[test]
    fn the_region_vote_acts_on_a_single_camera_only_where_on() {
        use momo_sim::SimConfig;
        let run = basin_run;
        let mono = || SimConfig {
            frames: 31,
            seed: 3,
            ..SimConfig::moving_traffic()
        };
        // On by default since the thirty-first session (3 x 2 cells, margin 3, band 0.0028,
        // trigger 0.75 deg); `[0, 0]` is off: a single camera is then never re-solved even
        // with every frame eligible.
        let o = crate::Config::default().odometry;
        assert_eq!(o.previous_basin_regions, [3, 2]);
        assert_eq!(
            (o.previous_basin_mono_change, o.previous_basin_mono_votes),
            (0.01309, 3)
        );
        assert_eq!(o.previous_basin_mono_band, 0.0028);
        let every =
            "[odometry]\nprevious_basin_regions = [0, 0]\nprevious_basin_mono_change = 1e-12\n";
        let (off, counts) = run(mono(), every);
        assert_eq!(counts, (0, 0));
        // On, every moving frame is re-solved; with an unreachable margin none is taken and
        // the motions are the default's.
        let (on, counts) = run(
            mono(),
            "[odometry]\nprevious_basin_regions = [3, 3]\nprevious_basin_mono_change = 1e-12\nprevious_basin_mono_votes = 100\n",
        );
        assert!(
            counts.0 >= 25,
            "the moving frames are re-solved: {counts:?}"
        );
        assert_eq!(counts.1, 0);
        assert_eq!(off, on);
        // A plain majority of the cells takes some of them.
        let (_, counts) = run(
            mono(),
            "[odometry]\nprevious_basin_regions = [3, 3]\nprevious_basin_mono_change = 1e-12\nprevious_basin_mono_votes = 1\n",
        );
        assert!(counts.1 >= 1 && counts.1 <= counts.0, "{counts:?}");
        // The regions leave a rig's camera vote alone.
        let rig = || SimConfig {
            frames: 31,
            seed: 2,
            ..SimConfig::moving_traffic_surround()
        };
        let (a, ca) = run(rig(), "[odometry]\nprevious_basin_regions = [0, 0]\n");
        let (b, cb) = run(
            rig(),
            "[odometry]\nprevious_basin_regions = [3, 3]\nprevious_basin_mono_change = 1e-12\nprevious_basin_mono_votes = 1\n",
        );
        assert_eq!((a, ca), (b, cb));
        for bad in ["-0.01", "nan"] {
            let text = format!("[odometry]\nprevious_basin_mono_change = {bad}\n");
            assert!(
                crate::Config::from_toml_str(&text, "t.toml").is_err(),
                "{bad}"
            );
        }
    }

    /// `odometry.competing_region_continuing_frames`: the continuing test looks back over the
    /// last `K` frames. dev2 03 s34 in yaw only: the frame before the cut-in's run followed the
    /// static world (a turn, -0.011 rad), one frame ended on neither motion (-0.001), the frame's
    /// own motion is the cut-in car's (+0.006) and the competing one the static world's turn
    /// (-0.016). From the last frame alone the car's motion looks continuing; with the frame
    /// before it the static world's does. A bus's motion far from every reference never passes.
    /// The option defaults to 3 (since the thirty-third session) and the driver keeps `K`
    /// motions.
    #[test]
    fn the_continuing_test_looks_back_over_the_last_frames() {
        let yaw = |z: f64| {
            let (s, c) = z.sin_cos();
            Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
        };
        let (before, neither, car, stat) = (yaw(-0.011), yaw(-0.001), yaw(0.006), yaw(-0.016));
        assert!(!continues_any(&[neither], &car, &stat));
        assert!(continues_any(&[before, neither], &car, &stat));
        assert!(!continues_any(&[], &car, &stat));
        // The bus: the frame's own motion is the static world's, the competing one 4 deg away.
        let bus = yaw(-0.011 + 0.07);
        assert!(!continues_any(
            &[before, neither, yaw(-0.012)],
            &yaw(-0.012),
            &bus
        ));
        assert_eq!(
            crate::Config::default()
                .odometry
                .competing_region_continuing_frames,
            3
        );
        use momo_sim::SimConfig;
        let mono = || SimConfig {
            frames: 21,
            seed: 3,
            ..SimConfig::moving_traffic()
        };
        let text = "[odometry]\ncompeting_region_continuing_frames = 3\n";
        let sim = momo_sim::simulate(&mono()).expect("the scenario simulates");
        let seq = &sim.sequence;
        let config = crate::Config::from_toml_str(text, "t.toml").expect("a valid config");
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("the odometry builds");
        for k in 1..seq.num_frames() {
            vo.process(&seq.frames[k], seq.arc_length(k));
            assert!(vo.recent_motions.len() <= 3);
            assert_eq!(
                vo.recent_motions.back().map(Vec::as_slice),
                Some(vo.previous_params())
            );
        }
        assert_eq!(vo.recent_motions.len(), 3);
    }

    /// `odometry.competing_region_yaw_ratio`: the competing-region vote takes a motion only
    /// where it differs from the frame's own mainly in yaw. The two cases measured in the
    /// thirty-third session (rotation vectors of the soft model, vehicle frame): dev2 03 s34
    /// frame 69, where the frame's own motion is a cut-in car's and the competing one the
    /// static world's turn (yaw differs by 0.017 rad, roll and pitch by 0.008), passes; grid
    /// KITTI 08 s3 frame 87, the two ends of the pitch–climb ridge (pitch differs by 0.018
    /// rad, yaw by 0.005), is refused. Off by default; on a run, an unreachable ratio takes
    /// nothing and keeps the unguarded vote's untaken motions; a negative or NaN ratio is
    /// rejected. The default (since the thirty-third session) is 1.
    #[test]
    fn the_yaw_guard_refuses_motions_that_differ_mainly_in_pitch() {
        use momo_core::so3_exp;
        use nalgebra::Vector3;
        let r = |x: f64, y: f64, z: f64| so3_exp(&Vector3::new(x, y, z));
        let (car, stat) = (r(-0.0081, -0.0010, 0.0064), r(-0.0008, -0.0042, -0.0103));
        assert!(yaw_dominant(&car, &stat, 1.0));
        assert!(yaw_dominant(&stat, &car, 1.0));
        let (held, other) = (r(-0.0035, -0.0168, -0.0061), r(-0.0034, 0.0008, -0.0012));
        assert!(!yaw_dominant(&held, &other, 1.0));
        // The ratio sets the line: the ridge case passes at a quarter.
        assert!(yaw_dominant(&held, &other, 0.25));
        // Pure yaw always passes, pure pitch never (at any positive ratio).
        assert!(yaw_dominant(&r(0.0, 0.0, 0.01), &r(0.0, 0.0, -0.01), 100.0));
        assert!(!yaw_dominant(&r(0.0, 0.01, 0.0), &r(0.0, -0.01, 0.0), 1e-6));
        assert_eq!(
            crate::Config::default().odometry.competing_region_yaw_ratio,
            1.0
        );
        use momo_sim::SimConfig;
        let run = |text: &str| {
            let text = format!(
                "[trust]\ncompeting_min_fraction = 0.02\n[odometry]\ncompeting_regions = [3, 2]\ncompeting_region_votes = 1\ncompeting_region_concentration = 0.0\ncompeting_region_continuing = false\n{text}"
            );
            let cfg = SimConfig {
                frames: 61,
                seed: 3,
                ..SimConfig::moving_traffic()
            };
            counted_run(cfg, &text, Odometry::competing_region_counts)
        };
        let (unguarded, counts) = run("competing_region_yaw_ratio = 0.0\n");
        let (guarded, guarded_counts) = run("competing_region_yaw_ratio = 1e12\n");
        assert_eq!(guarded_counts, (counts.0, 0));
        assert_eq!(counts.1 == 0, unguarded == guarded);
        for bad in ["-0.5", "nan", "inf"] {
            let text = format!("[odometry]\ncompeting_region_yaw_ratio = {bad}\n");
            assert!(
                crate::Config::from_toml_str(&text, "t.toml").is_err(),
                "{bad}"
            );
        }
    }

    /// `odometry.competing_regions` (on by default since the thirty-third session): off
    /// (`[0, 0]`) it never votes; on, it votes on the single camera's frames with a competing
    /// motion; an unreachable margin takes none and keeps the motions of the vote turned off;
    /// on this scene even a plain majority takes none; a rig is never touched; a negative or
    /// NaN band is rejected.
    #[test]
    fn the_competing_region_vote_acts_on_a_single_camera_only_where_on() {
        use momo_sim::SimConfig;
        let run = |cfg: SimConfig, text: &str| {
            // A low competing-motion share, so that the short sequence has competing motions.
            let text = format!("[trust]\ncompeting_min_fraction = 0.02\n{text}");
            counted_run(cfg, &text, Odometry::competing_region_counts)
        };
        let mono = || SimConfig {
            frames: 61,
            seed: 3,
            ..SimConfig::moving_traffic()
        };
        assert_eq!(crate::Config::default().odometry.competing_regions, [3, 2]);
        let (off, counts) = run(mono(), "[odometry]\ncompeting_regions = [0, 0]\n");
        assert_eq!(counts, (0, 0));
        let (on, counts) = run(
            mono(),
            "[odometry]\ncompeting_regions = [3, 2]\ncompeting_region_votes = 100\n",
        );
        assert!(
            counts.0 >= 1,
            "frames with a competing motion vote: {counts:?}"
        );
        assert_eq!(counts.1, 0);
        assert_eq!(off, on);
        let (majority, counts) = run(
            mono(),
            "[odometry]\ncompeting_regions = [3, 2]\ncompeting_region_votes = 1\n",
        );
        // The built-in scene's static world is the majority and spread over the image: even a
        // plain majority of the cells never takes its objects' motions.
        assert!(counts.0 >= 1, "{counts:?}");
        assert_eq!(counts.1, 0);
        assert_eq!(off, majority);
        let rig = || SimConfig {
            frames: 31,
            seed: 2,
            ..SimConfig::moving_traffic_surround()
        };
        let (a, ca) = run(rig(), "[odometry]\ncompeting_regions = [0, 0]\n");
        let (b, cb) = run(
            rig(),
            "[odometry]\ncompeting_regions = [3, 2]\ncompeting_region_votes = 1\n",
        );
        assert_eq!((a, ca), (b, cb));
        assert_eq!(cb, (0, 0));
        // Both guards at their strictest (all of the support in the fullest third of the cells,
        // and closer to the previous motion): a subset of the frames is taken.
        let (guarded, counts) = run(
            mono(),
            "[odometry]\ncompeting_regions = [3, 2]\ncompeting_region_votes = 1\ncompeting_region_concentration = 1.0\ncompeting_region_continuing = true\n",
        );
        assert!(counts.1 <= counts.0, "{counts:?}");
        if counts.1 == 0 {
            assert_eq!(off, guarded);
        }
        for bad in ["-0.01", "1.5", "nan"] {
            let text = format!("[odometry]\ncompeting_region_concentration = {bad}\n");
            assert!(
                crate::Config::from_toml_str(&text, "t.toml").is_err(),
                "{bad}"
            );
        }
        for bad in ["-0.01", "nan"] {
            let text =
                format!("[odometry]\ncompeting_regions = [3, 2]\ncompeting_region_band = {bad}\n");
            assert!(
                crate::Config::from_toml_str(&text, "t.toml").is_err(),
                "{bad}"
            );
        }
    }
    #[test]
    fn the_yaw_sigma_is_the_reported_covariance_on_the_yaw() {
        use momo_sim::{SimConfig, simulate};
        let sim = simulate(&SimConfig {
            frames: 6,
            seed: 5,
            ..SimConfig::outliers()
        })
        .expect("the outliers scenario simulates");
        let seq = &sim.sequence;
        let mut vo = Odometry::new(seq.rig.clone(), crate::Config::default()).expect("builds");
        let mut checked = 0;
        for k in 1..seq.num_frames() {
            let d = vo.process(&seq.frames[k], seq.arc_length(k)).diagnostics;
            // The default model's rotation parameters are `ω = log R` (vehicle frame): the
            // yaw's sigma is `rot_z`'s.
            let z = d.param_names.iter().position(|n| n == "rot_z");
            let (Some(z), Some(sigma)) = (z, vo.yaw_sigma(&d.params, &d)) else {
                continue;
            };
            let reported = d.param_sigmas[z];
            if !reported.is_finite() {
                continue;
            }
            assert!(
                (sigma - reported).abs() <= 1e-4 * reported,
                "{sigma} against {reported}"
            );
            checked += 1;
        }
        assert!(checked >= 4, "{checked} frames checked");
        // No covariance, no sigma.
        let mut d = vo.process(&seq.frames[1], seq.arc_length(1)).diagnostics;
        d.covariance.clear();
        assert!(vo.yaw_sigma(&d.params, &d).is_none());
    }
    /// A standstill frame of `rig`'s camera 0: `still` matches that do not move (the static
    /// world seen by a standing vehicle) and `crossing` ones that move as if the camera had
    /// turned by `yaw` about its vertical axis (a bus passing far ahead), with up to `noise`
    /// px of deterministic noise on the second pixel.
    fn standstill_frame(
        rig: &momo_core::Rig,
        (still, crossing): (usize, usize),
        yaw: f64,
        noise: f64,
    ) -> FrameObservations {
        standstill_frame_in(
            rig,
            (still, crossing),
            [420.0, 400.0, 120.0, 180.0],
            yaw,
            noise,
        )
    }

    /// [`standstill_frame`] with the crossing matches in the image rectangle `[u, width, v,
    /// height]` (pixels).
    fn standstill_frame_in(
        rig: &momo_core::Rig,
        (still, crossing): (usize, usize),
        [u0, w, v0, h]: [f64; 4],
        yaw: f64,
        noise: f64,
    ) -> FrameObservations {
        use momo_core::{CameraModel, Observation};
        let cam = &rig.cameras()[0].model;
        let turn = nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), yaw);
        // Low-discrepancy positions.
        let frac = |x: f64| x - x.floor();
        let per: Vec<Observation> = (0..still + crossing)
            .filter_map(|k| {
                // The crossing matches in their rectangle, the still ones anywhere.
                let (a, b) = (frac(k as f64 * 0.618_034), frac(k as f64 * 0.754_878));
                let (u, v) = if k < still {
                    (50.0 + 1140.0 * a, 40.0 + 290.0 * b)
                } else {
                    (u0 + w * a, v0 + h * b)
                };
                let px0 = nalgebra::Vector2::new(u, v);
                let f0 = cam.unproject(&px0)?;
                let f1 = if k < still { f0 } else { turn * f0 };
                let e =
                    noise * nalgebra::Vector2::new((k as f64 * 1.7).sin(), (k as f64 * 2.3).cos());
                Observation::new(cam, px0, cam.project(&f1)? + e)
            })
            .collect();
        FrameObservations {
            per_camera: vec![per],
            cross_camera: Vec::new(),
        }
    }

    /// The standstill frame `frame` after five moving frames of the clean scenario (the
    /// restarts' inlier average), with `standstill_at_rest` and `standstill_still_angle` as
    /// given: the reported rotation angle and the diagnostics.
    fn at_standstill(
        frame: &FrameObservations,
        at_rest: bool,
        still_angle: f64,
    ) -> (f64, FrameDiagnostics) {
        let (turn, _, d) = at_standstill_with(frame, |c| {
            c.odometry.standstill_at_rest = at_rest;
            c.odometry.standstill_still_angle = still_angle;
        });
        (turn, d)
    }

    /// [`at_standstill`] with the default configuration as `configure` leaves it: the
    /// reported rotation angle, the yaw's reported sigma and the diagnostics.
    fn at_standstill_with(
        frame: &FrameObservations,
        configure: impl FnOnce(&mut crate::Config),
    ) -> (f64, Option<f64>, FrameDiagnostics) {
        use momo_sim::{SimConfig, simulate};
        let sim = simulate(&SimConfig {
            frames: 6,
            seed: 3,
            ..SimConfig::clean_pinhole()
        })
        .expect("the clean scenario simulates");
        let seq = &sim.sequence;
        let mut config = crate::Config::default();
        configure(&mut config);
        let mut vo = Odometry::new(seq.rig.clone(), config).expect("builds");
        for k in 1..seq.num_frames() {
            vo.process(&seq.frames[k], seq.arc_length(k));
        }
        let d = vo.process(frame, Some(0.0)).diagnostics;
        assert_eq!(d.status, FrameStatus::Standstill);
        let motion = vo.estimator.motion(&d.params);
        let sigma = vo.yaw_sigma(&d.params, &d);
        (momo_core::so3_log(&motion.rotation).norm(), sigma, d)
    }

    /// The clean_pinhole scenario (one KITTI-like camera), `frames` frames of seed `seed`.
    fn clean_pinhole_drive(frames: usize, seed: u64) -> momo_sim::Simulation {
        momo_sim::simulate(&momo_sim::SimConfig {
            frames,
            seed,
            ..momo_sim::SimConfig::clean_pinhole()
        })
        .expect("the clean scenario simulates")
    }

    /// The clean_pinhole scenario's rig.
    fn clean_pinhole_rig() -> Rig {
        clean_pinhole_drive(2, momo_sim::SimConfig::clean_pinhole().seed)
            .sequence
            .rig
    }

    #[test]
    fn a_standing_vehicle_at_rest_does_not_follow_a_passing_bus() {
        let rig = clean_pinhole_rig();
        let deg = 1.0_f64.to_radians();
        // A bus with 60 % of the matches moves like a turn of 1.5 deg (19 px).
        let bus = 1.5 * deg;
        let frame = standstill_frame(&rig, (120, 180), bus, 0.3);
        let (turn, d) = at_standstill(&frame, true, 0.006);
        assert!(turn < 0.1 * deg, "{} deg", turn.to_degrees());
        assert_eq!(d.restarts, 0);
        // Without it the restarts find the bus's flow and keep it: it holds more matches.
        let (turn, d) = at_standstill(&frame, false, 0.006);
        assert!(d.restart_won);
        assert!((turn - bus).abs() < 0.1 * deg, "{} deg", turn.to_degrees());
        // A bus closer in flow (0.65 deg, 8 px) and noise of up to 2 px (1.4 px rms, as the
        // flow of 1 px pixel noise): the robust fit of all matches from no rotation is pulled
        // towards it; the still matches alone are not.
        let frame = standstill_frame(&rig, (90, 200), 0.65 * deg, 2.0);
        let (all, _) = at_standstill(&frame, true, 0.0);
        let (still, _) = at_standstill(&frame, true, 0.006);
        assert!(all > 0.2 * deg, "{} deg", all.to_degrees());
        assert!(still < 0.1 * deg, "{} deg", still.to_degrees());
    }

    #[test]
    fn without_odometry_one_camera_reads_its_arc_length_off_the_road() {
        let sim = clean_pinhole_drive(40, 5);
        let seq = &sim.sequence;
        let truth = seq.ground_truth.as_ref().expect("ground truth");
        let run = |frames: usize| {
            let mut config = crate::Config::default();
            config.odometry.road_scale_frames = frames;
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("builds");
            let i = vo.estimator.arc_length_index().expect("an arc length");
            // The held arc length over the true one, from frame 10 (the road's history full).
            let mut ratios: Vec<f64> = (1..seq.num_frames())
                .map(|k| {
                    let d = vo.process(&seq.frames[k], None).diagnostics;
                    if frames > 0 && k >= 10 {
                        assert_eq!(d.scale, ScaleSource::Road, "frame {k}");
                    }
                    let true_arc = truth[k - 1].inverse().compose(&truth[k]).translation.norm();
                    d.params[i] / true_arc
                })
                .skip(9)
                .collect();
            ratios.sort_by(f64::total_cmp);
            (
                ratios[0],
                ratios[ratios.len() / 2],
                ratios[ratios.len() - 1],
            )
        };
        // The default (the last admitted road arc length) and a median of five.
        for frames in [1, 5] {
            let (lo, mid, hi) = run(frames);
            assert!((mid - 1.0).abs() < 0.08, "{frames}: median ratio {mid}");
            assert!(lo > 0.85 && hi < 1.15, "{frames}: ratios {lo}..{hi}");
        }
        // Off, the arc length is the initial one or the weakly observable estimate: not the
        // truth.
        let (_, off, _) = run(0);
        assert!((off - 1.0).abs() > 0.15, "median ratio {off}");
    }

    /// Moving traffic on the built-in drive, `frames` frames of 200 matches of seed `seed`.
    fn traffic_drive(frames: usize, seed: u64) -> momo_sim::Simulation {
        momo_sim::simulate(&momo_sim::SimConfig {
            frames,
            seed,
            matches_per_camera: 200,
            ..momo_sim::SimConfig::moving_traffic()
        })
        .expect("the traffic scenario simulates")
    }

    /// The frames of `sim` whose rotation `config` gets more than 1 deg wrong, without
    /// odometry.csv.
    fn frames_above_1_deg_without_odometry(
        sim: &momo_sim::Simulation,
        config: crate::Config,
    ) -> usize {
        let mut vo = Odometry::new(sim.sequence.rig.clone(), config).expect("builds");
        (1..sim.sequence.num_frames())
            .filter(|&k| {
                let m = vo.process(&sim.sequence.frames[k], None).motion;
                let truth = &sim.vehicle_motions[k];
                so3_log(&(truth.rotation.transpose() * m.rotation)).norm() > 1f64.to_radians()
            })
            .count()
    }

    /// `odometry.road_scale_metric`: without odometry.csv, the separation's cues that need the
    /// metric scale (the road candidate, the road track, the under-road mask) run on the road's
    /// held arc length. Moving traffic on the built-in drive, 80 frames of 200 matches, the
    /// seeds of 1-80 on which the run without them had frames above 1 deg (a scan in the
    /// forty-seventh session with the build before `road_scale_initial_metric`; no seed had
    /// more with them). `road_scale_initial_metric` is on in both runs (the default).
    #[test]
    fn without_odometry_the_road_arc_length_is_metric_for_the_separation() {
        let above_1_deg = |seed: u64, metric: bool| -> usize {
            let mut config = crate::Config::default();
            config.odometry.road_scale_metric = metric;
            frames_above_1_deg_without_odometry(&traffic_drive(80, seed), config)
        };
        let seeds = [11, 46, 60, 62];
        let on: Vec<usize> = seeds.iter().map(|&s| above_1_deg(s, true)).collect();
        let off: Vec<usize> = seeds.iter().map(|&s| above_1_deg(s, false)).collect();
        assert_eq!(on, vec![0; seeds.len()], "with the metric road: {on:?}");
        assert!(off.iter().all(|&n| n > 0), "without: {off:?}");
    }

    /// `odometry.road_scale_initial_metric`: before the first road arc length the held
    /// `initial_arc_length` is metric for the separation, so a drive that starts among traffic
    /// does not follow it from frame 1. Moving traffic on the built-in drive, 30 frames of 200
    /// matches, seed 2: the one of seeds 1-160 on which the two differ (a scan in the
    /// forty-seventh session).
    #[test]
    fn without_odometry_the_start_of_a_drive_holds_the_initial_arc_length_as_metric() {
        let sim = traffic_drive(30, 2);
        let above_1_deg = |initial_metric: bool| -> usize {
            let mut config = crate::Config::default();
            config.odometry.road_scale_initial_metric = initial_metric;
            frames_above_1_deg_without_odometry(&sim, config)
        };
        assert_eq!(above_1_deg(true), 0);
        let off = above_1_deg(false);
        assert!(off > 0, "without: {off}");
    }

    #[test]
    fn without_odometry_a_road_arc_length_not_measured_again_is_flagged_stale() {
        let sim = clean_pinhole_drive(30, 5);
        let seq = &sim.sequence;
        let mount = seq.rig.cameras()[0].t_vehicle_camera.rotation;
        let mut vo = Odometry::new(seq.rig.clone(), crate::Config::default()).expect("builds");
        let stale = vo.config.trust.stale_scale_frames;
        assert!(stale > 0, "on by default");
        // From frame 11 on the road is hidden: only the matches above the horizon are kept.
        let hidden = 11;
        let mut rows = Vec::new();
        for k in 1..seq.num_frames() {
            let mut obs = seq.frames[k].clone();
            if k >= hidden {
                for m in &mut obs.per_camera {
                    m.retain(|o| (mount * o.f0).z > 0.0);
                }
            }
            let d = vo.process(&obs, None).diagnostics;
            assert!(
                k == 1 || d.scale == ScaleSource::Road,
                "frame {k}: {:?}",
                d.scale
            );
            rows.push((k, d.status, d.reason));
        }
        // No frame says `estimated` from the stale-th frame without a road arc length on (the
        // first ones say `road_score_drop`, then `stale_scale` to the end), and none is stale
        // before.
        let first = hidden + stale - 1;
        for &(k, status, reason) in &rows {
            if k < first {
                assert_ne!(reason, Some(Reason::StaleScale), "frame {k}");
            } else {
                assert_eq!(status, FrameStatus::Weak, "frame {k}");
            }
        }
        let last = rows.last().expect("frames");
        assert_eq!(last.2, Some(Reason::StaleScale));
        assert!(
            rows.iter()
                .filter(|r| r.2 == Some(Reason::StaleScale))
                .count()
                >= 5
        );
    }

    /// `trust.unconfirmed_scale`: a frame solved with an unconfirmed road arc length is flagged
    /// `weak` / `stale_scale`, report only (the same motion as with the option off).
    #[test]
    fn without_odometry_a_frame_solved_with_an_unconfirmed_road_arc_length_is_flagged() {
        let sim = clean_pinhole_drive(12, 5);
        let seq = &sim.sequence;
        let run = |flag: bool| {
            let mut config = crate::Config::default();
            config.trust.unconfirmed_scale = flag;
            let mut vo = Odometry::new(seq.rig.clone(), config).expect("builds");
            for k in 1..10 {
                let d = vo.process(&seq.frames[k], None).diagnostics;
                assert_eq!(d.status, FrameStatus::Estimated, "frame {k}");
            }
            assert!(!vo.road_unconfirmed, "a clean drive confirms its road");
            // As if the last road arc length had jumped through the widened gate.
            vo.road_unconfirmed = true;
            vo.process(&seq.frames[10], None)
        };
        let (on, off) = (run(true), run(false));
        assert_eq!(on.diagnostics.scale, ScaleSource::Road);
        assert_eq!(on.diagnostics.status, FrameStatus::Weak);
        assert_eq!(on.diagnostics.reason, Some(Reason::StaleScale));
        assert_eq!(off.diagnostics.status, FrameStatus::Estimated);
        assert_eq!(on.motion, off.motion);
    }

    /// A single camera's odometry holding the median of the last `road_scale_frames` road arc
    /// lengths.
    fn road_vo(road_scale_frames: usize) -> Odometry {
        let mut config = crate::Config::default();
        config.odometry.road_scale_frames = road_scale_frames;
        Odometry::new(clean_pinhole_rig(), config).expect("builds")
    }

    /// One frame's road reading offered to the gate: `count` road matches at `arc_length`,
    /// `held_count` at the gate's reference.
    fn read_road(vo: &mut Odometry, arc_length: f64, count: usize, held_count: usize) {
        vo.frame += 1;
        vo.admit_road_arc_length(RoadReading {
            arc_length,
            count,
            held_count,
        });
    }

    #[test]
    fn the_road_arc_length_gate_rejects_a_lead_vehicles_road_widens_with_time_and_restarts() {
        let mut vo = road_vo(5);
        let held = |vo: &Odometry| vo.road_held();
        // One road arc length per frame.
        let feed = |vo: &mut Odometry, l: f64| read_road(vo, l, 20, 0);
        for l in [1.0, 1.02, 0.98] {
            feed(&mut vo, l);
        }
        assert_eq!(held(&vo), Some(1.0));
        // A lead vehicle's "road" at a fifth of the scale, four frames in a row: rejected.
        for _ in 0..4 {
            feed(&mut vo, 0.2);
        }
        assert_eq!(held(&vo), Some(1.0));
        assert_eq!(vo.road_rejected.len(), 4);
        // The road again: admitted, the rejections forgotten.
        feed(&mut vo, 1.04);
        assert!(vo.road_rejected.is_empty());
        assert_eq!(vo.road_arc_lengths.len(), 4);
        // 0.5 m right after: too far from the held 1 m.
        feed(&mut vo, 0.5);
        assert_eq!(vo.road_rejected.len(), 1);
        // Twenty frames without a road arc length (braking behind a lead vehicle): 0.5 m now
        // fits within the widened gate (0.3 m + 0.03 m per frame).
        vo.frame += 20;
        feed(&mut vo, 0.5);
        assert!(vo.road_rejected.is_empty());
        assert_eq!(vo.road_arc_lengths.back(), Some(&0.5));
        // `ROAD_SCALE_RESETS` rejected in a row, at one new level, in frames that find no road
        // at the held one: the history restarts from them.
        let before = held(&vo).expect("a history");
        for k in 0..ROAD_SCALE_RESETS {
            assert_eq!(held(&vo), Some(before), "rejection {k}");
            feed(&mut vo, 4.0);
        }
        assert_eq!(held(&vo), Some(4.0));
        assert!(vo.road_rejected.is_empty());
    }

    #[test]
    fn a_rejected_road_arc_length_counts_towards_a_restart_only_where_the_held_one_finds_no_road() {
        let mut vo = road_vo(5);
        let held = |vo: &Odometry| vo.road_held();
        let feed = read_road;
        for l in [1.0, 1.02, 0.98] {
            feed(&mut vo, l, 20, 20);
        }
        assert_eq!(held(&vo), Some(1.0));
        // A lead vehicle's "road" at a fifth of the scale for many frames, while the road
        // still counts half of its matches at the held 1 m: the held one stays.
        for k in 0..2 * ROAD_SCALE_RESETS {
            feed(&mut vo, 0.2, 20, 10 + k % 3);
            assert_eq!(held(&vo), Some(1.0), "frame {k}");
            assert!(vo.road_rejected.is_empty());
        }
        // Readings at 0.2 m whose frames find (almost) no road at the held 1 m: the held one
        // was the wrong one, and the history restarts from them.
        for k in 0..ROAD_SCALE_RESETS {
            assert_eq!(held(&vo), Some(1.0), "rejection {k}");
            feed(&mut vo, 0.2, 20, 9);
        }
        assert_eq!(held(&vo), Some(0.2));
        // One supported rejection between unsupported ones neither counts nor clears them.
        feed(&mut vo, 1.0, 20, 2);
        feed(&mut vo, 1.0, 20, 15);
        assert_eq!(vo.road_rejected.len(), 1);
    }

    #[test]
    fn a_road_arc_length_admitted_through_the_widened_gate_is_unconfirmed_until_a_plain_one() {
        let mut vo = road_vo(1);
        for _ in 0..ROAD_SCALE_GATE_FRAMES {
            read_road(&mut vo, 1.0, 20, 20);
            assert!(!vo.road_unconfirmed);
        }
        // Twelve frames read no road; then 0.5 m passes the gate widened by 0.33 m only.
        vo.frame += 12;
        read_road(&mut vo, 0.5, 20, 5);
        assert_eq!(vo.road_held(), Some(0.5));
        assert!(vo.road_unconfirmed);
        // A reading within 30 % of the last five's median (1 m) confirms the road again.
        read_road(&mut vo, 0.9, 20, 20);
        assert_eq!(vo.road_held(), Some(0.9));
        assert!(!vo.road_unconfirmed);
    }

    #[test]
    fn a_lead_vehicles_road_cannot_pull_the_held_arc_length_down_step_by_step() {
        // The default holds the last admitted road arc length alone.
        assert_eq!(crate::Config::default().odometry.road_scale_frames, 1);
        let mut vo = road_vo(1);
        let feed = |vo: &mut Odometry, l: f64| read_road(vo, l, 20, 12);
        for _ in 0..ROAD_SCALE_GATE_FRAMES {
            feed(&mut vo, 1.0);
        }
        // Braking: 0.8 m is within 30 % of the reference and held at once.
        feed(&mut vo, 0.8);
        assert_eq!(vo.road_held(), Some(0.8));
        // 0.62 m is within 30 % of the held 0.8 m but not of the last frames' median (1 m).
        feed(&mut vo, 0.62);
        assert_eq!(vo.road_held(), Some(0.8));
        // Nor does a lead vehicle's road 25 % below every held value get there in steps.
        for l in [0.6, 0.45, 0.34, 0.25] {
            feed(&mut vo, l);
        }
        assert_eq!(vo.road_held(), Some(0.8));
        assert_eq!(vo.road_gate_reference(), Some(1.0));
    }

    #[test]
    fn a_lead_car_creeping_inside_the_still_cut_neither_biases_nor_hides_in_the_covariance() {
        let rig = clean_pinhole_rig();
        let deg = 1.0_f64.to_radians();
        // A lead car in 240 x 100 px ahead holds 200 of 290 matches and drifts sideways like a
        // turn of 0.2 deg (2.5 px): inside the still cut (0.006 rad = 0.34 deg), with up to 1
        // px of noise.
        let frame = standstill_frame_in(
            &rig,
            (90, 200),
            [500.0, 240.0, 150.0, 100.0],
            0.2 * deg,
            1.0,
        );
        let solve = |cap: f64, jackknife: bool| {
            at_standstill_with(&frame, |c| {
                c.odometry.standstill_cell_cap = cap;
                c.odometry.standstill_jackknife = jackknife;
            })
        };
        // The still matches alone: pulled most of the way to the car, with a sigma that
        // puts the truth (no turn) beyond 3 sigma.
        let (turn, sigma, _) = solve(0.0, false);
        let sigma = sigma.expect("a covariance");
        assert!(turn > 0.1 * deg, "{} deg", turn.to_degrees());
        assert!(
            turn > 3.0 * sigma,
            "{} > 3 x {} deg",
            turn.to_degrees(),
            sigma.to_degrees()
        );
        // The jackknife over image cells alone widens the sigma to hold the error.
        let (turn_jk, sigma_jk, _) = solve(0.0, true);
        let sigma_jk = sigma_jk.expect("a covariance");
        assert_eq!(turn_jk, turn);
        assert!(
            turn_jk < 3.0 * sigma_jk,
            "{} < 3 x {} deg",
            turn_jk.to_degrees(),
            sigma_jk.to_degrees()
        );
        // Capped per image cell the car no longer outweighs the static scene.
        let (capped, sigma_c, _) = solve(2.0, true);
        let sigma_c = sigma_c.expect("a covariance");
        assert!(capped < 0.5 * turn, "{} deg", capped.to_degrees());
        assert!(
            capped < 3.0 * sigma_c,
            "{} < 3 x {} deg",
            capped.to_degrees(),
            sigma_c.to_degrees()
        );
    }
}
