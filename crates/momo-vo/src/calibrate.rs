//! Mount self-calibration: the rotation of the whole rig relative to the vehicle, estimated
//! jointly over many frame pairs (`momo calibrate`, `momo run --calibrate-mount`).
//!
//! A small error in the camera-to-vehicle rotation moves the direction of travel in the image
//! by a constant angle. A single-track model cannot follow it (it has no side slip or climb),
//! so every frame pays for the bias. The correction is a rotation `δ ∈ R³` (axis-angle, vehicle
//! frame) of the rig about a pivot `c` (camera 0's centre):
//!
//! `Q(δ) = T(c) · Rot(exp(δ)) · T(−c)`, corrected extrinsics `P_j' = Q P_j`,
//!
//! so the camera motions are `C_j' = P_j⁻¹ Q⁻¹ M Q P_j`. [`Mounted`] wraps a motion model so
//! that its motion is `Q(δ)⁻¹ M(p) Q(δ)` with `δ` three extra parameters: the existing
//! [`momo_core::Problem`] then differentiates with respect to the mount too.
//!
//! The joint problem over K frame pairs has per-frame parameters `p_k` (arc length held at the
//! odometry value) and the shared `δ`:
//!
//! `min_{p_1..p_K, δ} Σ_k ½ Σ_i ρ(|r_ki(p_k, δ)|²)`.
//!
//! It is solved by momo-solvers' Levenberg-Marquardt (the same algorithm as every frame's solve,
//! through [`LmProblem`]) on the Schur complement (the bundle-adjustment
//! "reduced camera system" with the roles swapped): each frame's robustified normal equations
//! `[H_pp H_pδ; H_δp H_δδ]`, `[g_p; g_δ]` are reduced to
//! `S = Σ_k (H_δδ − H_δp H_pp⁻¹ H_pδ)`, `b = Σ_k (g_δ − H_δp H_pp⁻¹ g_p)`; the 3x3 damped system
//! gives `Δδ`, and each frame's step follows by back-substitution
//! `Δp_k = −H_pp⁻¹ (g_p + H_pδ Δδ)`. The frames are linearised in parallel (rayon).
//! The covariance of `δ` is the Gauss-Newton one, `σ² S⁻¹` at the solution, with `σ²` from the
//! final cost as the odometry's (`2 cost / (m − n)`, m inliers, n free parameters).
//!
//! This is a batch (two-pass) calibration: `momo run --calibrate-mount` calibrates on the
//! sequence first, then runs the odometry with the corrected rig. It is not online filtering.

use crate::config::Config;
use momo_core::num_dual::DualSVec64;
use momo_core::{
    CoreError, DynManifold, ErasedScalar, FrameObservations, MAX_PARAMS, MetricSpec, ModelSpec,
    Pose, Rig, RigCamera, RuntimeManifold, Scalar, SolveRequest, Termination, so3_exp,
};
use momo_solvers::{LevenbergMarquardt, LmProblem};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;
use thiserror::Error;

/// Why a mount calibration failed.
#[derive(Debug, Error)]
pub enum CalibrationError {
    /// No frame pairs were given.
    #[error("mount calibration: no frame pairs")]
    NoFrames,
    /// The motion model cannot calibrate the mount.
    #[error("mount calibration: model `{model}` cannot be used: {reason}")]
    UnsupportedModel {
        /// The model's type tag.
        model: String,
        /// Why not.
        reason: String,
    },
    /// Every frame pair was skipped.
    #[error(
        "mount calibration: no usable frame pairs ({} without enough matches, {} at standstill, \
         {} whose start solve failed, {} degenerate: repeated matches, matches in a small \
         region, too little flow or parallax)",
        skipped.no_matches, skipped.standstill, skipped.failed, skipped.degenerate
    )]
    NoUsableFrames {
        /// How many were skipped, and why.
        skipped: SkippedFrames,
    },
    /// The matches do not observe the mount: a free component's standard deviation is zero
    /// (no residual left), not finite, or above [`MAX_MOUNT_SIGMA_DEG`].
    #[error("mount calibration: the matches cannot observe the mount: {reason}")]
    Unobservable {
        /// Which component, and its sigma.
        reason: String,
    },
    /// The rig, model and metric do not fit (e.g. a metric that does not support a camera).
    #[error(transparent)]
    Core(#[from] CoreError),
}

/// The rig correction `Q(δ) = T(c) · Rot(exp(δ)) · T(−c)`: a rotation by the axis-angle `δ`
/// (vehicle frame) about the pivot `c`; as a pose `[exp(δ) | c − exp(δ) c]`.
pub fn mount_correction<T: Scalar>(delta: &Vector3<T>, pivot: &Vector3<f64>) -> Pose<T> {
    let r = so3_exp(delta);
    let c = pivot.map(T::c);
    let t = c - r * c;
    Pose::new(r, t)
}

/// The names of the three mount angles, appended to a model's parameters.
const MOUNT_PARAMS: [&str; 3] = ["mount_x", "mount_y", "mount_z"];

/// Any motion model with the mount correction as three extra parameters:
/// `motion(p, δ) = Q(δ)⁻¹ · M(p) · Q(δ)` ([`mount_correction`]), so that with the nominal rig
/// `P_j` the camera motions are those of the corrected rig `Q(δ) P_j`. A
/// [`RuntimeManifold`], so any registered metric builds an estimator of it.
#[derive(Debug)]
pub struct Mounted {
    /// The vehicle motion model.
    pub model: Box<dyn DynManifold>,
    /// The pivot `c` of the correction (camera 0's centre in the vehicle frame).
    pub pivot: Vector3<f64>,
    /// The model's parameters followed by `mount_x`, `mount_y`, `mount_z`.
    params: Vec<&'static str>,
}

impl Mounted {
    /// Wraps a model.
    pub fn new(model: Box<dyn DynManifold>, pivot: Vector3<f64>) -> Self {
        let mut params = model.params().to_vec();
        params.extend(MOUNT_PARAMS);
        Self {
            model,
            pivot,
            params,
        }
    }
}

impl RuntimeManifold for Mounted {
    fn params(&self) -> &[&'static str] {
        &self.params
    }
    fn arc_length_index(&self) -> Option<usize> {
        self.model.arc_length_index()
    }
    fn prior_residual_count(&self) -> usize {
        self.model.prior_residual_count()
    }
    #[inline]
    fn motion<T: ErasedScalar>(&self, p: &[T]) -> Pose<T> {
        let n = self.model.params().len();
        let m = T::motion(self.model.as_ref(), &p[..n]);
        let q = mount_correction(&Vector3::new(p[n], p[n + 1], p[n + 2]), &self.pivot);
        q.inverse().compose(&m.compose(&q))
    }
    fn prior_residuals<T: ErasedScalar>(&self, p: &[T], out: &mut [T]) {
        T::prior_residuals(self.model.as_ref(), &p[..self.model.params().len()], out)
    }
    fn initial_params(&self, arc_length: f64) -> Vec<f64> {
        let mut p = self.model.initial_params(arc_length);
        p.extend([0.0; 3]);
        p
    }
    fn params_from_motion(&self, _motion: &Pose<f64>) -> Option<Vec<f64>> {
        None
    }
    fn observable(&self, rig: &Rig) -> Vec<bool> {
        let mut o = self.model.observable(rig);
        o.extend([true; 3]);
        o
    }
}

/// The model the mount is calibrated with: any registered motion model that can see the mount
/// (kept as its configuration, so that it is rebuilt for every use).
#[derive(Clone, Debug, PartialEq)]
pub struct MountModel {
    /// The model's configuration (`{"type": ..., ...}`).
    spec: serde_json::Value,
    /// Its type tag.
    name: String,
}

impl Default for MountModel {
    /// `single_track_3d`.
    fn default() -> Self {
        Self {
            spec: serde_json::json!({"type": "single_track_3d"}),
            name: "single_track_3d".into(),
        }
    }
}

impl MountModel {
    /// The registered model of this type tag with its default parameters
    /// (`single_track_3d`, `single_track_2d`, or a researcher's registered model).
    pub fn named(type_tag: &str) -> Result<Self, CalibrationError> {
        let spec = serde_json::json!({ "type": type_tag });
        let model: Box<dyn ModelSpec> = serde_json::from_value(spec.clone()).map_err(|e| {
            CalibrationError::UnsupportedModel {
                model: type_tag.into(),
                reason: format!("not a registered model with default parameters ({e})"),
            }
        })?;
        Self::from_spec(model.as_ref())
    }

    /// The model of a configuration's `[model]`, if it can calibrate the mount
    /// ([`Self::check`]); a [`CalibrationError::UnsupportedModel`] otherwise.
    pub fn from_spec(spec: &dyn ModelSpec) -> Result<Self, CalibrationError> {
        let name = spec.typetag_name().to_string();
        let value = serde_json::to_value(spec).map_err(|e| CalibrationError::UnsupportedModel {
            model: name.clone(),
            reason: format!("its configuration cannot be stored ({e})"),
        })?;
        let model = Self { spec: value, name };
        model.check()?;
        Ok(model)
    }

    /// The model's configuration.
    pub fn spec(&self) -> Result<Box<dyn ModelSpec>, CalibrationError> {
        serde_json::from_value(self.spec.clone()).map_err(|e| CalibrationError::UnsupportedModel {
            model: self.name.clone(),
            reason: e.to_string(),
        })
    }

    /// The model's type tag.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether the model can see the mount: its parameters plus the three mount angles fit
    /// [`MAX_PARAMS`], and no change of its own parameters reproduces what a mount rotation
    /// does to the motion. The second is checked by automatic differentiation at a gentle
    /// curve (yaw 0.02 rad, 1 m: the model's closed-form parameters of that motion, or, without
    /// them, its neutral start with every parameter but the arc length moved by 0.02 · i / n): the Jacobian of the motion (rotation vector and translation) with
    /// respect to the model's parameters and the mount's yaw and pitch must have full column
    /// rank. A model that expresses every rigid motion (`se3`) fails both.
    pub fn check(&self) -> Result<(), CalibrationError> {
        let model = self.spec()?.manifold();
        let np = model.params().len();
        let refuse = |reason: String| {
            Err(CalibrationError::UnsupportedModel {
                model: self.name.clone(),
                reason,
            })
        };
        if np + 3 > MAX_PARAMS {
            return refuse(format!(
                "it has {np} parameters; with the 3 mount angles that is more than {MAX_PARAMS}, \
                 and a model this general (e.g. se3, which expresses every rigid motion) fits a \
                 rotated mount as well as the true one: use single_track_3d or single_track_2d"
            ));
        }
        let curve = so3_exp(&Vector3::new(0.0, 0.0, 0.02));
        let motion = Pose::new(curve, Vector3::new(1.0, 0.01, 0.0));
        let arc = model.arc_length_index();
        let p = model
            .params_from_motion(&motion)
            .filter(|p| p.len() == np)
            .unwrap_or_else(|| {
                // A generic point near the neutral start: every other parameter a little off.
                let mut p = model.initial_params(1.0);
                for (i, v) in p.iter_mut().enumerate() {
                    if Some(i) != arc {
                        *v += 0.02 * (i + 1) as f64 / np as f64;
                    }
                }
                p
            });
        let mounted = Mounted::new(model, Vector3::new(1.0, 0.0, 1.5));
        // Columns: the model's parameters, then the mount's pitch (y) and yaw (z).
        let cols: Vec<usize> = (0..np).chain([np + 1, np + 2]).collect();
        let mut x = [DualSVec64::<8>::from_re(0.0); MAX_PARAMS];
        for i in 0..np + 3 {
            let v = if i < np { p[i] } else { 0.0 };
            x[i] = DualSVec64::from_re(v);
        }
        for (k, &i) in cols.iter().enumerate() {
            x[i] = x[i].derivative(k);
        }
        let m = RuntimeManifold::motion(&mounted, &x[..np + 3]);
        let w = momo_core::so3_log(&m.rotation);
        let rows: Vec<DualSVec64<8>> = w.iter().chain(m.translation.iter()).copied().collect();
        let jac = DMatrix::from_fn(6, cols.len(), |r, c| {
            rows[r].eps.0.as_ref().map_or(0.0, |e| e[c])
        });
        let sv = jac.singular_values();
        let largest = sv.max();
        let rank = sv.iter().filter(|v| **v > 1e-9 * largest.max(1.0)).count();
        if rank < cols.len() {
            return refuse(format!(
                "the mount is not observable with it: its own parameters reproduce what a mount \
                 rotation does to the motion (Jacobian rank {rank} of {}); use a model that \
                 constrains the direction of travel, such as single_track_3d",
                cols.len()
            ));
        }
        Ok(())
    }

    /// Whether the mount's roll is estimated by default: when the model has no `pitch` or
    /// `roll` parameter of its own.
    ///
    /// `single_track_2d` has none, and a rolled mount tilts the yaw axis, which the planar
    /// model cannot follow. `single_track_3d` has both: its per-frame pitch change absorbs the
    /// tilt (pitch ≈ yaw · roll), so the roll's standard deviation is about 1.5° on 80
    /// simulated frames against 0.03-0.05° for yaw and pitch; the roll is then held at zero.
    pub fn observes_roll(&self) -> bool {
        self.spec()
            .map(|s| {
                !s.manifold()
                    .params()
                    .iter()
                    .any(|n| *n == "pitch" || *n == "roll")
            })
            .unwrap_or(false)
    }
}

/// Options of the mount calibration (the loss, metric, solver and degenerate-frame thresholds
/// come from the momo [`Config`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MountCalibration {
    /// The model; `None`: the configuration's model (which must be a single-track model).
    pub model: Option<MountModel>,
    /// Use only the first this many frame pairs (`None`: all).
    pub frames: Option<usize>,
    /// Most Levenberg-Marquardt iterations of the joint solve (accepted or rejected steps).
    pub max_iterations: usize,
    /// Stop when the Gauss-Newton model predicts that at most this fraction of the cost can
    /// still be gained ([`LevenbergMarquardt::function_tolerance`]).
    pub cost_tolerance: f64,
    /// Stop when the joint step (every frame's and the mount's) is at most
    /// `step_tolerance · (|x| + step_tolerance)` ([`LevenbergMarquardt::parameter_tolerance`]).
    pub step_tolerance: f64,
    /// Estimate the mount's roll (about the vehicle's x axis)? `None`: the model's default
    /// ([`MountModel::observes_roll`]); otherwise the roll correction is held at zero.
    pub estimate_roll: Option<bool>,
    /// Bootstrap replicas of the covariance (0 or 1: the Gauss-Newton covariance alone; one
    /// replica cannot give a covariance). Each
    /// replica resamples every frame pair's matches with replacement and calibrates again;
    /// the reported covariance is the larger (by trace) of the Gauss-Newton one and the
    /// replicas' sample covariance (see [`MountEstimate::covariance`]).
    pub bootstrap: usize,
}

impl Default for MountCalibration {
    fn default() -> Self {
        Self {
            model: Some(MountModel::default()),
            frames: None,
            max_iterations: 50,
            cost_tolerance: 1e-10,
            step_tolerance: 1e-9,
            estimate_roll: None,
            bootstrap: DEFAULT_BOOTSTRAP,
        }
    }
}

/// Bootstrap replicas of [`MountCalibration::default`]: enough for a standard deviation good
/// to about 13 % (`1/√(2(B−1))`); a calibration costs about `B + 1` joint solves.
pub const DEFAULT_BOOTSTRAP: usize = 30;

impl MountCalibration {
    /// Sets the model.
    pub fn with_model(mut self, model: Option<MountModel>) -> Self {
        self.model = model;
        self
    }

    /// Uses only the first `frames` frame pairs.
    pub fn with_frames(mut self, frames: Option<usize>) -> Self {
        self.frames = frames;
        self
    }

    /// Estimates the roll of the mount (`Some(true)`), holds it at zero (`Some(false)`) or does
    /// what the model observes (`None`).
    pub fn with_roll(mut self, estimate_roll: Option<bool>) -> Self {
        self.estimate_roll = estimate_roll;
        self
    }

    /// Sets the iteration limit.
    pub fn with_max_iterations(mut self, max_iterations: usize) -> Self {
        self.max_iterations = max_iterations;
        self
    }

    /// Sets the number of bootstrap replicas of the covariance (0: Gauss-Newton only).
    pub fn with_bootstrap(mut self, replicas: usize) -> Self {
        self.bootstrap = replicas;
        self
    }
}

/// Frame pairs left out of the calibration, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SkippedFrames {
    /// Fewer matches than `odometry.min_matches`.
    pub no_matches: usize,
    /// Arc length below `odometry.standstill_arc_length` (the direction of travel is undefined).
    pub standstill: usize,
    /// The per-frame start solve failed (non-finite cost or parameters).
    pub failed: usize,
    /// Degenerate matches (`crate::trust`): fewer than `odometry.min_matches` distinct
    /// matches, matches in a small region (`trust.min_extent`), too little flow
    /// (`trust.min_flow`) or too little parallax ([`MIN_MOUNT_PARALLAX`]).
    pub degenerate: usize,
}

impl SkippedFrames {
    /// All skipped frame pairs.
    pub fn total(&self) -> usize {
        self.no_matches + self.standstill + self.failed + self.degenerate
    }
}

/// The result of a mount calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct MountEstimate {
    /// The model used.
    pub model: MountModel,
    /// The correction `δ` (axis-angle in the vehicle frame, radians): the corrected extrinsics
    /// are `Q(δ) P_j` ([`mount_correction`]).
    pub delta: Vector3<f64>,
    /// Standard deviations of `δ` (radians), from [`Self::covariance`]; 0 for a component held
    /// at zero (the roll, see [`MountCalibration::estimate_roll`]).
    pub sigma: Vector3<f64>,
    /// The covariance of `δ` (zero rows and columns for held components, NaN if `S` is
    /// singular): the Gauss-Newton one, `σ² S⁻¹`, or, with bootstrap replicas
    /// ([`MountCalibration::bootstrap`]), the replicas' sample covariance where its trace is
    /// the larger. The curvature alone is over-confident where the frame pairs see the
    /// direction of travel weakly (noise large against the parallax): on 8 simulated frame
    /// pairs x 40 matches at 30 m with 1 px noise the mean squared z-score of the yaw and pitch
    /// was 27 with `σ² S⁻¹` and 0.46 with 30 replicas (docs/RESULTS.md, mount calibration).
    pub covariance: Matrix3<f64>,
    /// Bootstrap replicas that calibrated successfully (0: the covariance is `σ² S⁻¹`).
    pub replicas: usize,
    /// Whether the roll `δ_x` was estimated (otherwise it is held at zero).
    pub roll_estimated: bool,
    /// The pivot `c` (camera 0's centre in the vehicle frame).
    pub pivot: Vector3<f64>,
    /// The rig with corrected extrinsics.
    pub corrected_rig: Rig,
    /// Levenberg-Marquardt iterations of the joint solve.
    pub iterations: usize,
    /// Why the joint solve stopped.
    pub termination: Termination,
    /// Total cost with the nominal rig (each frame solved on its own).
    pub cost_before: f64,
    /// Total cost at the joint solution.
    pub cost_after: f64,
    /// Frame pairs used.
    pub frames_used: usize,
    /// Frame pairs skipped, by reason.
    pub skipped: SkippedFrames,
}

impl MountEstimate {
    /// Where the direction of travel (the vehicle's x axis) lies in the *nominal* vehicle frame,
    /// `exp(δ)ᵀ x̂`, as (left, up) angles in degrees: what the nominal rig got wrong.
    pub fn travel_direction_deg(&self) -> (f64, f64) {
        let d = so3_exp(&self.delta).transpose() * Vector3::x();
        (
            d.y.atan2(d.x).to_degrees(),
            d.z.atan2(d.x.hypot(d.y)).to_degrees(),
        )
    }
}

/// The rig with every extrinsic corrected: `P_j' = Q(δ) P_j` about camera 0's centre.
pub fn corrected_rig(rig: &Rig, delta: &Vector3<f64>) -> Result<Rig, CoreError> {
    let pivot = rig.cameras()[0].t_vehicle_camera.translation;
    let q = mount_correction(delta, &pivot);
    Rig::new(
        rig.cameras()
            .iter()
            .map(|c| RigCamera {
                t_vehicle_camera: q.compose(&c.t_vehicle_camera),
                ..c.clone()
            })
            .collect(),
    )
}

/// Calibrates the mount of a sequence's rig over its frame pairs `1..num_frames`, as
/// [`calibrate_mount`] does over the dense frames. Only the frame pairs with matches are
/// visited (the others are counted as skipped), so that sparse frame numbers cost no memory.
pub fn calibrate_sequence(
    sequence: &momo_io::SparseSequence,
    config: &Config,
    options: &MountCalibration,
) -> Result<MountEstimate, CalibrationError> {
    let frames: Vec<FramePair<'_>> = sequence
        .frames
        .iter()
        .map(|(k, obs)| (k - 1, obs, sequence.arc_length(*k)))
        .collect();
    let total = sequence.num_frames.saturating_sub(1);
    calibrate_frames(&sequence.rig, &frames, total, config, options)
}

/// Calibrates the rig's mount rotation jointly over frame pairs.
///
/// `frames[i]` are the matches of one frame pair and `arc_lengths[i]` its odometry arc length
/// (held fixed; without one the previous frame's, or `odometry.initial_arc_length`, is held).
/// Frame pairs with fewer than `odometry.min_matches` matches, at standstill, or whose start
/// solve fails are skipped and counted. Loss, metric and solver (for the per-frame starts) come
/// from `config`.
pub fn calibrate_mount(
    rig: &Rig,
    frames: &[FrameObservations],
    arc_lengths: Option<&[Option<f64>]>,
    config: &Config,
    options: &MountCalibration,
) -> Result<MountEstimate, CalibrationError> {
    let pairs: Vec<FramePair<'_>> = frames
        .iter()
        .enumerate()
        .filter(|(_, obs)| !obs.is_empty())
        .map(|(i, obs)| {
            let arc = arc_lengths.and_then(|a| a.get(i).copied().flatten());
            (i, obs, arc)
        })
        .collect();
    calibrate_frames(rig, &pairs, frames.len(), config, options)
}

/// One frame pair given to the calibration: its index `i` among the frame pairs (frame pair
/// `(i, i+1)`), its matches and its odometry arc length.
pub(crate) type FramePair<'a> = (usize, &'a FrameObservations, Option<f64>);

/// [`calibrate_mount`] over the frame pairs with matches (`i` increasing) of `total` frame
/// pairs; the ones not listed have no matches.
pub(crate) fn calibrate_frames(
    rig: &Rig,
    frames: &[FramePair<'_>],
    total: usize,
    config: &Config,
    options: &MountCalibration,
) -> Result<MountEstimate, CalibrationError> {
    if total == 0 {
        return Err(CalibrationError::NoFrames);
    }
    let model = match &options.model {
        Some(m) => {
            m.check()?;
            m.clone()
        }
        None => MountModel::from_spec(config.model.as_ref())?,
    };
    let mut est = calibrate_with(
        model.clone(),
        config.metric.as_ref(),
        rig,
        frames,
        total,
        config,
        options,
    )?;
    if options.bootstrap > 1 && est.covariance.iter().all(|v| v.is_finite()) {
        bootstrap_covariance(&mut est, model, rig, frames, total, config, options)?;
    }
    check_observable(&est)?;
    Ok(est)
}

/// Replaces `est`'s covariance by the bootstrap one where that is the larger (by trace):
/// `options.bootstrap` replicas, each resampling every frame pair's matches (per camera, with
/// replacement, deterministic) and calibrating again; replicas that fail are left out. With
/// fewer than half succeeding the estimate does not survive resampling:
/// [`CalibrationError::Unobservable`].
fn bootstrap_covariance(
    est: &mut MountEstimate,
    model: MountModel,
    rig: &Rig,
    frames: &[FramePair<'_>],
    total: usize,
    config: &Config,
    options: &MountCalibration,
) -> Result<(), CalibrationError> {
    let replica_options = MountCalibration {
        bootstrap: 0,
        ..options.clone()
    };
    let deltas: Vec<Vector3<f64>> = (0..options.bootstrap)
        .into_par_iter()
        .filter_map(|b| {
            let resampled: Vec<FrameObservations> = frames
                .iter()
                .map(|(i, obs, _)| resample(obs, b as u64, *i as u64))
                .collect();
            let pairs: Vec<FramePair<'_>> = frames
                .iter()
                .zip(&resampled)
                .map(|((i, _, arc), obs)| (*i, obs, *arc))
                .collect();
            calibrate_with(
                model.clone(),
                config.metric.as_ref(),
                rig,
                &pairs,
                total,
                config,
                &replica_options,
            )
            .ok()
            .map(|e| e.delta)
        })
        .collect();
    let n = deltas.len();
    if 2 * n < options.bootstrap || n < 2 {
        return Err(CalibrationError::Unobservable {
            reason: format!(
                "the estimate does not survive resampling: {n} of {} bootstrap replicas \
                 calibrated; {} frame pairs used",
                options.bootstrap, est.frames_used
            ),
        });
    }
    let mean = deltas.iter().fold(Vector3::zeros(), |a, d| a + d) / n as f64;
    let boot = deltas.iter().fold(Matrix3::zeros(), |a, d| {
        a + (d - mean) * (d - mean).transpose()
    }) / (n - 1) as f64;
    est.replicas = n;
    if boot.trace() > est.covariance.trace() {
        est.covariance = boot;
        est.sigma = Vector3::from_fn(|i, _| boot[(i, i)].max(0.0).sqrt());
    }
    Ok(())
}

/// One bootstrap replica of a frame pair: as many matches per camera, drawn with replacement
/// by a deterministic hash of (replica, frame pair, draw) (SplitMix64's finaliser).
fn resample(obs: &FrameObservations, replica: u64, frame: u64) -> FrameObservations {
    let mut out = FrameObservations::new(obs.per_camera.len());
    let mut draw = 0u64;
    for (list, dst) in obs.per_camera.iter().zip(out.per_camera.iter_mut()) {
        for _ in 0..list.len() {
            let mut z = (replica << 40 ^ frame << 20 ^ draw).wrapping_add(0x9E37_79B9_7F4A_7C15);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            draw += 1;
            dst.push(list[(z % list.len() as u64) as usize]);
        }
    }
    out
}

/// The largest standard deviation of a mount component (degrees) that `calibrate_mount`
/// accepts: above it the matches do not observe the mount and the estimate is refused (mount
/// errors worth correcting are a few degrees; `single_track_3d` with the roll estimated gives
/// about 1.1 deg for the roll on the simulated test drive).
pub const MAX_MOUNT_SIGMA_DEG: f64 = 3.0;

/// The smallest median parallax (radians: the angle between `f0` and `R f1` after the start
/// solve's rotation `R` is removed) of a frame pair used by the mount calibration. Below it
/// the flow is the rotation's alone (a far scene, a turn on the spot), the direction of travel
/// and with it the mount are not seen, and the frame pair is skipped as degenerate (2e-3 rad
/// is 1.4 px at a 700 px focal length; a car at 1 m per frame sees 0.025 to 0.25 rad at 4 to
/// 40 m).
pub const MIN_MOUNT_PARALLAX: f64 = 2e-3;

/// The median over all matches of the angle between `f0` and `R_j f1` (camera j's rotation
/// under `motion` removed): the parallax the translation leaves.
fn median_parallax(rig: &Rig, obs: &FrameObservations, motion: &Pose<f64>) -> Option<f64> {
    let mut angles = Vec::with_capacity(obs.len());
    for (cam, list) in rig.cameras().iter().zip(&obs.per_camera) {
        let c = momo_core::camera_motion(motion, &cam.t_vehicle_camera);
        for o in list {
            let g = c.rotation * o.f1;
            angles.push(o.f0.cross(&g).norm().atan2(o.f0.dot(&g)));
        }
    }
    if angles.is_empty() {
        return None;
    }
    let mid = angles.len() / 2;
    let (_, m, _) = angles.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

/// Refuses an estimate whose free components are not observed (see
/// [`CalibrationError::Unobservable`]).
fn check_observable(est: &MountEstimate) -> Result<(), CalibrationError> {
    let names = ["roll", "pitch", "yaw"];
    for (i, name) in names.iter().enumerate() {
        if i == 0 && !est.roll_estimated {
            continue;
        }
        let sigma = est.sigma[i].to_degrees();
        let reason = if !sigma.is_finite() || est.covariance[(i, i)].is_nan() {
            format!("the {name} is not determined (singular information)")
        } else if sigma == 0.0 {
            format!(
                "the {name} has a standard deviation of exactly 0 (the cost is {:.3e}: the \
                 matches leave no residual to measure noise against)",
                est.cost_after
            )
        } else if sigma > MAX_MOUNT_SIGMA_DEG {
            format!(
                "the {name}'s standard deviation is {sigma:.3} deg (more than \
                 {MAX_MOUNT_SIGMA_DEG} deg)"
            )
        } else {
            continue;
        };
        return Err(CalibrationError::Unobservable {
            reason: format!(
                "{reason}; {} frame pairs used, {} skipped ({} degenerate)",
                est.frames_used,
                est.skipped.total(),
                est.skipped.degenerate
            ),
        });
    }
    Ok(())
}

/// The solve request of one frame pair of the joint problem (its fixed parameters, no prior).
fn frame_request<'r>(rig: &'r Rig, config: &'r Config, s: &'r FrameState<'_>) -> SolveRequest<'r> {
    SolveRequest {
        rig,
        observations: s.obs,
        loss: config.loss.as_ref(),
        solver: config.solver.as_ref(),
        initial: &[],
        fixed: &s.fixed,
        rotation_only: false,
        motion_prior: None,
    }
}

/// One frame pair of the joint problem.
struct FrameState<'a> {
    obs: &'a FrameObservations,
    /// The model's full parameter vector.
    params: Vec<f64>,
    /// Fixed flags of the mounted model's full vector (the mount is always free).
    fixed: Vec<bool>,
}

/// One frame's normal equations split into model and mount blocks (model's free parameters
/// first, then the free mount angles).
struct FrameBlocks {
    cost: f64,
    h_pp: DMatrix<f64>,
    h_pd: DMatrix<f64>,
    h_dd: DMatrix<f64>,
    g_p: DVector<f64>,
    g_d: DVector<f64>,
}

/// The per-frame part of the elimination at damping `lambda`: `Y = A⁻¹ H_pδ`, `z = A⁻¹ g_p`
/// with `A = H_pp + λ diag(H_pp)`.
struct Eliminated {
    y: DMatrix<f64>,
    z: DVector<f64>,
}

fn full_vector(params: &[f64], delta: &Vector3<f64>) -> Vec<f64> {
    let mut p = params.to_vec();
    p.extend(delta.iter());
    p
}

fn calibrate_with(
    which: MountModel,
    metric: &dyn MetricSpec,
    rig: &Rig,
    frames: &[FramePair<'_>],
    total: usize,
    config: &Config,
    options: &MountCalibration,
) -> Result<MountEstimate, CalibrationError> {
    let spec = which.spec()?;
    let estimator = metric.estimator(spec.manifold());
    let model = estimator.model();
    let roll = options.estimate_roll.unwrap_or(which.observes_roll());
    // Free mount components (indices into δ) and their count.
    let mount_free: Vec<usize> = if roll { vec![0, 1, 2] } else { vec![1, 2] };
    let nd = mount_free.len();
    let loss = config.loss.as_ref();
    let odo = &config.odometry;
    let np = model.params().len();
    let arc_index = model.arc_length_index();
    let limit = options.frames.unwrap_or(total).min(total);
    if limit == 0 {
        return Err(CalibrationError::NoFrames);
    }

    // --- per-frame starts with the nominal rig (warm-started like the odometry) -------------
    let mut skipped = SkippedFrames::default();
    let mut states: Vec<FrameState<'_>> = Vec::new();
    let mut previous = model.initial_params(odo.initial_arc_length);
    let mut cost_before = 0.0;
    // Frame pairs not in `frames` have no matches.
    let listed = frames.iter().take_while(|(i, ..)| *i < limit).count();
    skipped.no_matches += limit - listed;
    for &(_, obs, arc) in &frames[..listed] {
        let arc = arc.filter(|l| l.is_finite() && *l >= 0.0);
        if obs.len() < odo.min_matches.max(1) {
            skipped.no_matches += 1;
            continue;
        }
        // Matches that cannot determine a motion say nothing about the mount either.
        let mut unique = obs.clone();
        crate::trust::dedupe(&mut unique);
        let degenerate = unique.len() < odo.min_matches.max(1)
            || crate::trust::before_solve(&config.trust, rig, &unique, true).is_some_and(
                |(c, r)| {
                    c == crate::trust::Constraint::Degenerate
                        || r == crate::trust::Reason::LittleFlow
                },
            );
        if degenerate {
            skipped.degenerate += 1;
            continue;
        }
        let mut fixed = vec![false; np];
        let mut init = previous.clone();
        if let Some(a) = arc_index {
            fixed[a] = true;
            let l = arc.unwrap_or(init[a]);
            if l < odo.standstill_arc_length {
                skipped.standstill += 1;
                continue;
            }
            init[a] = l;
        }
        let mut best: Option<(f64, Vec<f64>)> = None;
        let mut starts = vec![init.clone()];
        let straight = arc_index.map_or_else(
            || model.initial_params(odo.initial_arc_length),
            |a| model.initial_params(init[a]),
        );
        if straight != init {
            starts.push(straight);
        }
        for start in starts {
            let request = SolveRequest {
                rig,
                observations: obs,
                loss,
                solver: config.solver.as_ref(),
                initial: &start,
                fixed: &fixed,
                rotation_only: false,
                motion_prior: None,
            };
            let solution = estimator.solve(&request)?;
            let (report, params) = (solution.report, solution.params);
            let ok = report.termination != Termination::NumericalFailure
                && report.final_cost.is_finite()
                && params.iter().all(|v| v.is_finite());
            if ok && best.as_ref().is_none_or(|(c, _)| report.final_cost < *c) {
                best = Some((report.final_cost, params));
            }
        }
        let Some((cost, params)) = best else {
            skipped.failed += 1;
            continue;
        };
        if median_parallax(rig, obs, &model.motion_of(&params))
            .is_none_or(|p| p < MIN_MOUNT_PARALLAX)
        {
            skipped.degenerate += 1;
            continue;
        }
        cost_before += cost;
        previous.clone_from(&params);
        let mut mounted_fixed = fixed;
        mounted_fixed.extend([!roll, false, false]);
        states.push(FrameState {
            obs,
            params,
            fixed: mounted_fixed,
        });
    }
    if states.is_empty() {
        return Err(CalibrationError::NoUsableFrames { skipped });
    }

    // --- joint Levenberg-Marquardt on the Schur complement ----------------------------------
    let pivot = rig.cameras()[0].t_vehicle_camera.translation;
    let mounted = metric.estimator(Box::new(Mounted::new(spec.manifold(), pivot)));
    let joint = Joint {
        states: &states,
        estimator: mounted.as_ref(),
        rig,
        config,
        np,
        mount_free: &mount_free,
        error: std::sync::Mutex::new(None),
    };
    let start = JointPoint {
        params: states.iter().map(|s| s.params.clone()).collect(),
        delta: Vector3::zeros(),
    };
    let lm = LevenbergMarquardt::default()
        .with_max_iterations(options.max_iterations)
        .with_function_tolerance(options.cost_tolerance)
        .with_parameter_tolerance(options.step_tolerance);
    let run = lm.minimize(&joint, start);
    if let Some(e) = joint.error.into_inner().ok().flatten() {
        return Err(e.into());
    }
    let (delta, blocks, cost) = (run.x.delta, run.lin.blocks, run.lin.cost);
    for (s, p) in states.iter_mut().zip(run.x.params) {
        s.params = p;
    }
    let (iterations, termination) = (run.iterations, run.termination);

    // --- covariance of δ: σ² S⁻¹ (undamped) ------------------------------------------------
    let mut inliers = 0usize;
    let mut free_total = nd;
    for s in &states {
        let full = full_vector(&s.params, &delta);
        inliers += mounted
            .inliers(&frame_request(rig, config, s), &full)?
            .iter()
            .sum::<usize>();
        free_total += s.fixed.iter().filter(|f| !**f).count() - nd;
    }
    let dof = inliers.saturating_sub(free_total).max(1);
    let sigma2 = 2.0 * cost / dof as f64;
    let mut covariance = Matrix3::zeros();
    match reduced_system(&blocks, nd, 0.0).and_then(|(s, _, _)| s.try_inverse()) {
        Some(inv) => {
            for (a, &i) in mount_free.iter().enumerate() {
                for (b, &j) in mount_free.iter().enumerate() {
                    covariance[(i, j)] = inv[(a, b)] * sigma2;
                }
            }
        }
        None => covariance.fill(f64::NAN),
    }
    let sigma = Vector3::from_fn(|i, _| covariance[(i, i)].max(0.0).sqrt());

    Ok(MountEstimate {
        model: which,
        delta,
        sigma,
        covariance,
        roll_estimated: roll,
        pivot,
        corrected_rig: corrected_rig(rig, &delta)?,
        iterations,
        termination,
        cost_before,
        cost_after: cost,
        replicas: 0,
        frames_used: states.len(),
        skipped,
    })
}

/// The joint problem's unknowns: every frame's model parameters and the mount correction.
#[derive(Clone)]
struct JointPoint {
    params: Vec<Vec<f64>>,
    delta: Vector3<f64>,
}

/// The joint problem's linearisation: each frame's blocks and the total cost.
struct JointLin {
    blocks: Vec<FrameBlocks>,
    cost: f64,
}

/// A step of the joint problem: the free mount angles' step and each frame's free parameters'.
struct JointStep {
    mount: DVector<f64>,
    frames: Vec<DVector<f64>>,
}

/// The joint calibration problem as Levenberg-Marquardt ([`LmProblem`]) sees it: the frames are
/// linearised in parallel, the damped system is solved by the Schur complement
/// ([`schur_step`]). The first error of an evaluation is kept in `error` (the evaluation then
/// reads as not finite and the solver stops); the caller reports it.
struct Joint<'s, 'a> {
    states: &'s [FrameState<'a>],
    estimator: &'s dyn momo_core::FrameEstimator,
    rig: &'s Rig,
    config: &'s Config,
    np: usize,
    mount_free: &'s [usize],
    error: std::sync::Mutex<Option<CoreError>>,
}

impl Joint<'_, '_> {
    fn keep<T>(&self, r: Result<T, CoreError>) -> Option<T> {
        r.map_err(|e| {
            if let Ok(mut slot) = self.error.lock() {
                slot.get_or_insert(e);
            }
        })
        .ok()
    }

    fn frame_blocks(
        &self,
        s: &FrameState<'_>,
        params: &[f64],
        delta: &Vector3<f64>,
    ) -> Result<FrameBlocks, CoreError> {
        let nd = self.mount_free.len();
        let full = full_vector(params, delta);
        let lin = self
            .estimator
            .linearize(&frame_request(self.rig, self.config, s), &full)?;
        let n = s.fixed.iter().filter(|f| !**f).count();
        let m = n - nd;
        let h = &lin.hessian;
        Ok(FrameBlocks {
            cost: lin.cost,
            h_pp: DMatrix::from_fn(m, m, |r, c| h[(r, c)]),
            h_pd: DMatrix::from_fn(m, nd, |r, c| h[(r, m + c)]),
            h_dd: DMatrix::from_fn(nd, nd, |r, c| h[(m + r, m + c)]),
            g_p: DVector::from_fn(m, |r, _| lin.gradient[r]),
            g_d: DVector::from_fn(nd, |r, _| lin.gradient[m + r]),
        })
    }
}

impl LmProblem for Joint<'_, '_> {
    type Point = JointPoint;
    type Lin = JointLin;
    type Step = JointStep;

    fn linearize(&self, x: &JointPoint) -> JointLin {
        let blocks = self.states.par_iter().zip(x.params.par_iter());
        let blocks = blocks
            .map(|(s, p)| self.frame_blocks(s, p, &x.delta))
            .collect::<Result<Vec<_>, _>>();
        match self.keep(blocks) {
            Some(blocks) => JointLin {
                cost: blocks.iter().map(|b| b.cost).sum(),
                blocks,
            },
            None => JointLin {
                blocks: Vec::new(),
                cost: f64::NAN,
            },
        }
    }

    fn cost(&self, x: &JointPoint) -> f64 {
        let costs = self.states.par_iter().zip(x.params.par_iter());
        let costs = costs
            .map(|(s, p)| {
                let request = frame_request(self.rig, self.config, s);
                self.estimator.cost(&request, &full_vector(p, &x.delta))
            })
            .collect::<Result<Vec<_>, _>>();
        self.keep(costs).map_or(f64::NAN, |c| c.iter().sum())
    }

    fn lin_cost(&self, lin: &JointLin) -> f64 {
        lin.cost
    }

    fn is_finite(&self, lin: &JointLin) -> bool {
        let finite = |m: &[f64]| m.iter().all(|v| v.is_finite());
        lin.cost.is_finite()
            && lin.blocks.iter().all(|b| {
                finite(b.h_pp.as_slice())
                    && finite(b.h_pd.as_slice())
                    && finite(b.h_dd.as_slice())
                    && finite(b.g_p.as_slice())
                    && finite(b.g_d.as_slice())
            })
    }

    fn gradient_max_norm(&self, lin: &JointLin) -> f64 {
        let nd = self.mount_free.len();
        let mut g_d = DVector::zeros(nd);
        let mut m = 0.0_f64;
        for b in &lin.blocks {
            g_d += &b.g_d;
            m = m.max(b.g_p.amax());
        }
        m.max(g_d.amax())
    }

    /// The damping is Marquardt's (scaled by the diagonal) for every `λ`; with `λ = 0` scaled
    /// and unscaled coincide.
    fn solve_damped(&self, lin: &JointLin, lambda: f64, _scaled: bool) -> Option<JointStep> {
        schur_step(&lin.blocks, self.mount_free.len(), lambda)
            .map(|(mount, frames)| JointStep { mount, frames })
    }

    fn predicted_decrease(&self, lin: &JointLin, step: &JointStep) -> f64 {
        let dd = &step.mount;
        let mut linear = 0.0;
        let mut quadratic = 0.0;
        for (b, dp) in lin.blocks.iter().zip(&step.frames) {
            linear += b.g_p.dot(dp) + b.g_d.dot(dd);
            quadratic +=
                dp.dot(&(&b.h_pp * dp)) + 2.0 * dp.dot(&(&b.h_pd * dd)) + dd.dot(&(&b.h_dd * dd));
        }
        -(linear + 0.5 * quadratic)
    }

    fn step_is_small(&self, step: &JointStep, x: &JointPoint, tol: f64) -> bool {
        let step_sq =
            step.mount.norm_squared() + step.frames.iter().map(|d| d.norm_squared()).sum::<f64>();
        let x_sq = x.delta.norm_squared() + x.params.iter().flatten().map(|v| v * v).sum::<f64>();
        step_sq.sqrt() <= tol * (x_sq.sqrt() + tol)
    }

    fn retract(&self, x: &JointPoint, step: &JointStep) -> JointPoint {
        let mut delta = x.delta;
        for (k, &i) in self.mount_free.iter().enumerate() {
            delta[i] += step.mount[k];
        }
        let params = self
            .states
            .iter()
            .zip(&x.params)
            .zip(&step.frames)
            .map(|((s, p), dp)| {
                let mut p = p.clone();
                let free = s.fixed[..self.np].iter().enumerate().filter(|(_, f)| !**f);
                for ((i, _), d) in free.zip(dp.iter()) {
                    p[i] += d;
                }
                p
            })
            .collect();
        JointPoint { params, delta }
    }
}

/// The reduced (Schur complement) system at damping `lambda`: `S`, `b` and each frame's
/// eliminated blocks; `None` if a frame's block is not positive definite.
fn reduced_system(
    blocks: &[FrameBlocks],
    nd: usize,
    lambda: f64,
) -> Option<(DMatrix<f64>, DVector<f64>, Vec<Eliminated>)> {
    let mut s = DMatrix::zeros(nd, nd);
    let mut b = DVector::zeros(nd);
    let mut elim = Vec::with_capacity(blocks.len());
    for f in blocks {
        let m = f.h_pp.nrows();
        let mut a = f.h_pp.clone();
        for i in 0..m {
            a[(i, i)] += lambda * a[(i, i)].max(1e-12) + 1e-30;
        }
        let chol = a.cholesky()?;
        let y = chol.solve(&f.h_pd);
        let z = chol.solve(&f.g_p);
        let hdp = f.h_pd.transpose();
        s += &f.h_dd - &hdp * &y;
        b += &f.g_d - &hdp * &z;
        elim.push(Eliminated { y, z });
    }
    Some((s, b, elim))
}

/// One damped Levenberg-Marquardt step of the joint problem: the mount step and each frame's
/// step (over its free model parameters).
fn schur_step(
    blocks: &[FrameBlocks],
    nd: usize,
    lambda: f64,
) -> Option<(DVector<f64>, Vec<DVector<f64>>)> {
    let (mut s, b, elim) = reduced_system(blocks, nd, lambda)?;
    let mut diag = DVector::zeros(nd);
    for f in blocks {
        diag += f.h_dd.diagonal();
    }
    for i in 0..nd {
        s[(i, i)] += lambda * diag[i].max(1e-12);
    }
    let step_d = -s.cholesky()?.solve(&b);
    if !step_d.iter().all(|v| v.is_finite()) {
        return None;
    }
    let steps = elim
        .iter()
        .map(|e| -(&e.z + &e.y * &step_d))
        .collect::<Vec<_>>();
    steps
        .iter()
        .all(|d| d.iter().all(|v| v.is_finite()))
        .then_some((step_d, steps))
}
