//! The estimator configuration: model, metric, loss and solver named by type tag (typetag), plus
//! the odometry driver's options. Read from TOML or JSON; `momo config` prints the default.

use crate::trust::TrustOptions;
use momo_core::{MetricSpec, ModelSpec, Rig, RobustLoss, Solver};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use thiserror::Error;

/// A configuration error (unreadable file, unknown type tag, bad value).
#[derive(Debug, Error)]
pub enum ConfigError {
    /// The file could not be read (or is larger than [`MAX_CONFIG_BYTES`]).
    #[error("{path}: {error}")]
    Read {
        /// The file.
        path: String,
        /// The cause (not a `source`: the message already quotes it once).
        error: std::io::Error,
    },
    /// The file could not be parsed.
    #[error("{path}:{line}: {reason}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line of the problem (1 if unknown).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A value is out of range.
    #[error("{path}: {reason}")]
    Invalid {
        /// The file (or `<default>`).
        path: String,
        /// What is wrong.
        reason: String,
    },
}

/// The largest configuration file read (1 MiB): `--config /dev/zero` fails at once.
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// The most `odometry.restart_yaw_offsets` (each is one more solve per frame).
pub const MAX_RESTART_OFFSETS: usize = 64;

/// The most iterations of one solve (`solver.max_iterations`): a solve converges in tens; a
/// larger bound only lets a stalled one run for minutes per frame.
pub const MAX_SOLVER_ITERATIONS: u64 = 10_000;

/// The most RANSAC iterations of the 5-point baseline (`five_point.max_iterations`): one
/// million draws find an all-inlier sample at 10 % inliers (w⁵ = 1e-5) with 99.995 %
/// confidence; more only run longer.
pub const MAX_RANSAC_ITERATIONS: usize = 1_000_000;

/// The smallest standard deviation of a motion prior (`odometry.rotation_change_sigma`,
/// `odometry.motion_prior_sigmas`), radians or metres per frame: 1e-6 rad is 0.2 arc seconds,
/// far below what a vehicle's rotation rate holds from one frame to the next; a smaller one
/// makes the prior's weight overflow (1e-300 gives 1e300) and only freezes the motion.
pub const MIN_PRIOR_SIGMA: f64 = 1e-6;

/// Options of the odometry driver (everything that is not model, metric, loss or solver).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OdometryOptions {
    /// Below this arc length (metres per frame) the vehicle is at standstill: only the rotation
    /// is estimated (rotation-only residual), the translation is zero.
    pub standstill_arc_length: f64,
    /// A standing vehicle does not turn: at a standstill the rotation-only solve starts at no
    /// rotation (the model's start with zero arc length, not the previous motion) and tries the
    /// restarts ([`OdometryOptions::restart_yaw_offsets`]) only where that solve fails. At a
    /// standstill the static world's matches do not move in the image, while a passing bus or
    /// crossing truck moves like a rotation of the camera; the restarts found that motion and
    /// kept it where it holds more matches than the static scene (their lowest cost wins).
    /// With [`OdometryOptions::standstill_still_angle`] the solve reads only the matches that
    /// do not move. False: the previous motion as the start, all matches, and the restarts
    /// where the inlier share is low, as for a moving frame.
    pub standstill_at_rest: bool,
    /// With [`OdometryOptions::standstill_at_rest`]: the standstill's rotation is solved on the
    /// matches whose bearings turn by less than this angle (radians) between the two frames,
    /// where there are at least 12 of them and a tenth of the frame's (0: all matches). A
    /// standing vehicle's static scene moves by the noise alone, and by the little the body
    /// rocks; a bus passing at 8 px per frame (0.011 rad at f = 718 px) pulls the robust fit of
    /// all matches towards its flow, with a small formal sigma.
    pub standstill_still_angle: f64,
    /// With [`OdometryOptions::standstill_at_rest`]: image-region balance of the standstill's
    /// still matches (0: off): at most `max(2, ceil(c · m))` of them per image cell (the
    /// `[odometry.separate] cell_cap_grid`, 16 x 8 by default), `m` the median count of the
    /// occupied cells ([`crate::separate::cell_capped`]). A lead car that stands or creeps in
    /// front of a standing vehicle holds most of the still matches in a few cells; its lateral
    /// drift moves them like a yaw of the camera.
    pub standstill_cell_cap: f64,
    /// With [`OdometryOptions::standstill_at_rest`]: the standstill's reported covariance is
    /// widened where the leave-one-cell-out jackknife of its rotation-only solve on the
    /// matches it read is wider (`[trust] jackknife_grids`, `jackknife_min_ratio`), as a moving
    /// frame's is where its support drops: an object inside the still cut biases the solve by
    /// more than its formal covariance.
    pub standstill_jackknife: bool,
    /// On a single camera without odometry.csv (its matches observe the scale at most weakly,
    /// through the lever arm in curves), the arc length held for each frame is the median of the
    /// last this many admitted arc lengths from the road plane (`Odometry::road_arc_length`:
    /// the arc length at which most of the motion's static matches stand on the road at the
    /// camera's known height), read off estimated and weak moving frames; a road arc length
    /// that leaves the median of the last five admitted ones by more than 30 % and 0.1 m (plus
    /// 0.03 m per frame since the last admitted one) is not admitted unless five in a row are
    /// not, each in a frame that counts under half its road matches at that median
    /// (`Odometry::admit_road_arc_length`: a lead vehicle's "road", and a drive's start read
    /// under a lead vehicle's motion; docs/RESULTS.md, forty-ninth session). Until there is
    /// one, the arc length is held as metric (`road_scale_initial_metric`), or estimated or held
    /// as with 0 (off) without that option. The separation's road cues read the road at the
    /// motion's metric scale; a wrong scale by 20 % makes them pick a lead vehicle's motion. Default 1 since the forty-sixth session (docs/RESULTS.md): the last
    /// admitted one, which follows braking and starts that a longer median lags behind.
    pub road_scale_frames: usize,
    /// With `road_scale_frames`, the separation takes the held road arc length as the frame's
    /// metric arc length, as it takes odometry.csv's: the cues that need the metric scale (the
    /// road candidate, the road track, the under-road mask, the metric road score and the slow
    /// yaw margin) run, where without it they are off for want of odometry. A road arc length
    /// 10 % off leaves them right (docs/RESULTS.md, forty-fifth session: odometry.csv scaled by
    /// 0.9 and 1.1). Default true since the forty-seventh session (docs/RESULTS.md).
    pub road_scale_metric: bool,
    /// With `road_scale_frames`, before the first road arc length is admitted, the held arc
    /// length (`initial_arc_length` at the start, 1 m per frame) is the separation's metric arc
    /// length too. Where it would be estimated from the lever arm (`estimate_scale`, a camera
    /// off the motion centre) it is held instead; a camera in the motion centre holds it as
    /// before (`unobservable`, not metric). At a drive's start the motion that the road is read
    /// under is not known to be the static world's yet: without the metric cues a lead
    /// vehicle's motion wins the first frames and its "road" is read (docs/RESULTS.md,
    /// forty-seventh session). Default true since the forty-seventh session.
    pub road_scale_initial_metric: bool,
    /// With `road_scale_frames`, a run over a whole sequence (`momo run`, `momo vo`, the Python
    /// module's `run`, `momo_vo::run_sequence` / `run_in_memory`, the sweep) first calibrates
    /// the camera's mount rotation on its first `momo_vo::pipeline::ROAD_MOUNT_FRAMES` frame
    /// pairs (`momo calibrate`'s joint single-track calibration of
    /// pitch and yaw, without its bootstrap; `momo_vo::RoadMount`). The road's arc length reads
    /// the road's depth through the mount: a camera pitched 1° nose down against its nominal
    /// mount reads it 11-13 % long on the built-in drive (seeds 1-8, 200 frames; 0.99-1.00 of
    /// the true one calibrated), and real KITTI 00 / 01 / 06 without
    /// odometry.csv read it 1.06 / 1.10 / 1.17 of the true one through the nominal level rig
    /// (docs/RESULTS.md, forty-eighth session). `road`: the calibrated pitch becomes the road's
    /// (`separate.hypotheses.ground_pitch`), the motion model keeps the rig as given; `rig`:
    /// the run uses the corrected rig (as `momo run --calibrate-mount`); `nominal`: no
    /// calibration. Where the calibration fails (no frame pair that moves, a mount the matches
    /// cannot observe) the run keeps the rig as given and says so. The per-frame API
    /// (`Odometry::process`) cannot look ahead: calibrate with `momo_vo::calibrate_mount` first.
    pub road_scale_mount: RoadScaleMount,
    /// Frames with fewer matches (all cameras) hold the previous motion.
    pub min_matches: usize,
    /// Arc length assumed before any is known when there is no odometry (metres per frame).
    pub initial_arc_length: f64,
    /// Estimate the arc length where the rig makes it observable and odometry is absent.
    pub estimate_scale: bool,
    /// An estimated arc length is accepted if its standard deviation is below this fraction of
    /// its value (and it passes `max_arc_length_ratio`); otherwise the last value is held.
    pub max_relative_scale_sigma: f64,
    /// An estimated arc length more than this factor above or below the last one is not
    /// accepted (vehicle dynamics; the last value is held). Applies once an arc length is known.
    pub max_arc_length_ratio: f64,
    /// Try more starts when a frame's inlier ratio falls below this fraction of the running
    /// average inlier ratio of the recent frames (a result that "looks bad").
    pub restart_inlier_ratio: f64,
    /// Yaw offsets (radians) of the extra starts around the previous motion.
    pub restart_yaw_offsets: Vec<f64>,
    /// The rotation prior (vehicle dynamics), for every model: the standard deviation of the
    /// change of the vehicle's rotation vector from one frame to the next (radians per frame;
    /// it bounds the change of yaw, pitch and roll rates), a Gaussian cost term centred on the
    /// previous frame's rotation ([`momo_core::MotionPrior`]). 0: none, the previous motion is
    /// only the start. The default, 0.002 rad (0.11 deg) per frame, is what the measurements
    /// on KITTI 00 and the simulated scenarios chose (docs/RESULTS.md).
    pub rotation_change_sigma: f64,
    /// The change-of-motion prior is centred on the previous frame only if that frame's inlier
    /// ratio was at least this fraction of the running average (otherwise the next frame is
    /// solved without it): a prior centred on a doubtful frame holds a wrong motion from frame
    /// to frame. 0: always centred on an estimated moving frame.
    pub prior_min_inlier_ratio: f64,
    /// The change-of-motion prior applies only to frames whose arc length (metres per frame)
    /// is at least this: on slow frames the direction of travel and the yaw are seen only
    /// together, their errors run on from frame to frame, and a prior centred on the previous
    /// frame carries them on (simulated KITTI 07 and 08 drives, docs/RESULTS.md). 0: always.
    pub prior_min_arc_length: f64,
    /// The tilt hold: where the change-of-motion prior has no centre because the frames since
    /// the last trusted one (estimated, its inlier ratio within `prior_min_inlier_ratio`, no
    /// competing motion: the frames that centre that prior) were doubted, a Gaussian prior on
    /// the tilt parameters `rot_x` and `rot_y` (roll and pitch of the vehicle's rotation
    /// vector) centred on the trusted frames' running mean, with standard deviation
    /// `tilt_hold_sigma` radians, up to `tilt_hold_frames` frames after the last trusted one
    /// (none after a standstill). A frame whose static matches are few or far sees its tilt only
    /// together with its direction of travel; where objects hold most matches its tilt error
    /// reaches 1-1.5 deg with a roll or pitch sigma of 0.6-2 deg while the vehicle's own tilt
    /// changes by tenths of a degree per frame. 0.003 (the default since the seventy-fourth
    /// session; the ground truth's scatter) in the report only (`tilt_hold_stage`, the default)
    /// took frames above 1 deg 5 -> 3 at 1 px and 333 -> 304 at 2 px (docs/RESULTS.md,
    /// seventy-third and seventy-fourth sessions); in every solve it helped on some sets and
    /// hurt on others, as it also moves the separation's choice between motions (seventy-second
    /// session). 0: off. Models without `rot_x` / `rot_y` parameters are not affected.
    pub tilt_hold_sigma: f64,
    /// With `tilt_hold_sigma`: the most frames after the last trusted one the hold applies to.
    pub tilt_hold_frames: usize,
    /// With `tilt_hold_sigma`: where the hold acts ([`TiltHoldStage`]).
    pub tilt_hold_stage: TiltHoldStage,
    /// Motion separation after each frame's solve ([`crate::separate`]); by default
    /// [`SeparateOptions::competition_over_time`](crate::separate::SeparateOptions::competition_over_time)
    /// (since 2026-11-28; `enabled = false` turns it off). A config file's
    /// `[odometry.separate]` section starts from it: the fields the section omits keep its
    /// values (a `[odometry.separate.hypotheses]` section replaces its multi-frame choice as a
    /// whole; `hypotheses.enabled = false` turns that choice off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub separate: Option<crate::separate::SeparateOptions>,
    /// The final efficient stage after each moving frame's solve ([`crate::final_fit`]: the
    /// noise estimated from the residuals, a refit on the matches within a few sigmas); on by
    /// default. Where `separate` is set it runs only with `separate.final_fit` (on the chosen
    /// motion's support in a frame where two motions competed); otherwise the separation's
    /// own final stage replaces it.
    pub final_fit: crate::final_fit::FinalFitOptions,
    /// Centre a soft manifold's prior (`soft_single_track`'s side slip and climb) on its
    /// running mean over this many recent moving frames, so that a constant offset (a camera
    /// mount a few tenths of a degree off nominal) is learnt online instead of pulling every
    /// frame; 0: centred on zero; the default, 100, since 2026-11-24. No effect on hard models. Measured
    /// (docs/RESULTS.md): on KITTI 00 it lowers the soft model's r_err and t_err, on the
    /// simulated drives (nominal mount) it follows the estimates' own bias and raises t_err.
    pub soft_prior_centring_frames: usize,
    /// Learn a soft manifold's prior standard deviations (side slip, climb) from the data, as
    /// its centre is learnt (empirical Bayes over the same recent moving frames, at least
    /// [`SOFT_SIGMA_MIN_FRAMES`](crate::odometry::SOFT_SIGMA_MIN_FRAMES) of them): each
    /// residual's `σ` becomes the robust estimate of the true slip's spread, clamped to
    /// `[σ_model, soft_prior_sigma_max · σ_model]` after multiplication by
    /// `soft_prior_sigma_factor` ([`crate::Odometry::soft_prior_sigma`]).
    /// Needs `soft_prior_centring_frames > 0`. No effect on hard models. On by default since
    /// 2026-11-25 (docs/RESULTS.md §9, seventh session): along the KITTI ground-truth
    /// trajectories (simulated, their direction of travel jitters) it lowers the clean
    /// scenario's efficiency ratio from 1.48 / 2.34 to 1.26 / 1.23 (00 / 08); on the built-in
    /// drive and on the real KITTI 00 matches it learns the model's own sigmas (no change).
    pub soft_prior_sigma_learning: bool,
    /// The largest learnt soft-prior standard deviation, in units of the model's `σ`
    /// (`soft_prior_sigma_learning`); at least 1.
    pub soft_prior_sigma_max: f64,
    /// The learnt soft-prior standard deviation is this multiple of the estimated spread of the
    /// true slip (`soft_prior_sigma_learning`; > 0): the prior is a nuisance for the rotation,
    /// so a wider one trades a little variance for less bias where the slip is heavy-tailed.
    pub soft_prior_sigma_factor: f64,
    /// Degrees of freedom `ν` of a Student-t soft prior (0: Gaussian, the default): once the
    /// sigmas are learnt (`soft_prior_sigma_learning`), each frame's soft-prior residuals are
    /// reweighted by `w = 1 / (1 + z² / ν)`, `z = (q̂ − c) / σ` at the solution, and the frame
    /// solved again from its solution (at most 3 times): the prior yields on the frames in the
    /// slip's tails and keeps its pull on the typical ones (`ν = 1`: Cauchy).
    pub soft_prior_student_nu: f64,
    /// Learn, besides each soft-prior standard deviation `σ_r` (`soft_prior_sigma_learning`),
    /// a sideways / vertical *displacement* jitter `δ_r` that widens the prior of a short step:
    /// the frame's prior standard deviation is `√(σ_r² + δ_r² / s²)` at arc length `s`, with
    /// `δ_r²` the non-negative least-squares slope of the innovations' excess `d² − v` over
    /// `1 / s²` on the learning window ([`crate::Odometry::soft_prior_sigma`]). Where the
    /// motion's direction jitters by centimetres (the KITTI ground truth's slow frames) a short
    /// step's prior yields; where it does not (real matches, the built-in drive), `δ_r ≈ 0`.
    /// Default false.
    pub soft_prior_arc_learning: bool,
    /// The soft prior's displacement jitter before any learning, as an arc length `L`
    /// (metres; 0: none, the default): until the soft-prior sigmas are learnt
    /// (`soft_prior_sigma_learning`, [`crate::odometry::SOFT_SIGMA_MIN_FRAMES`] trusted moving
    /// frames) each frame's prior standard deviation is `σ √(1 + L² / s²)` at arc length `s`
    /// (a sideways / vertical displacement jitter `δ = L σ`: `L = 0.5` m with the model's
    /// `σ = 0.01` rad is 5 mm), so a short step's direction may yield from the first frame
    /// on; then the learnt jitter of `soft_prior_arc_learning` takes over (none without it).
    pub soft_prior_arc_jitter: f64,
    /// Let the soft manifold's prior learn (its centre, `soft_prior_centring_frames`; its sigmas,
    /// `soft_prior_sigma_learning`; its level, `soft_prior_trend_frames`) also from the trusted
    /// moving frames where two motions competed (reported `estimated`, or `weak` for
    /// `competing_motions`); by default (false) only frames reported `estimated` where no second
    /// motion competed teach it. With a surround rig in traffic nearly every frame competes (a
    /// fisheye sees some vehicle almost always), so the prior keeps the model's centre and
    /// sigmas where the direction of travel is far from them (the KITTI 08 ground truth's slow
    /// start, whose chord climbs by 0.3-1.5 rad) and co-moving vehicles pull the rotation
    /// instead (docs/RESULTS.md §9, twenty-sixth session, riglock40). The change-of-motion
    /// prior's centring is not affected. Off by default.
    pub soft_prior_learn_competing: bool,
    /// A Cauchy loss on the soft prior's residuals listed in `soft_prior_cauchy_residuals`, at
    /// this scale in units of each residual's frame sigma (0: least squares; default 5, gated by
    /// `soft_prior_cauchy_until_learnt`, `soft_prior_cauchy_taught_share` and
    /// `soft_prior_cauchy_min_cameras`, so by default it acts only on a starved surround rig):
    /// `½ s² b² ln(1 + z² / b²)` with `z = k (q − c)` ([`momo_core::MotionPrior::soft_cauchy`]),
    /// from the first frame on. Quadratic for `|z| ≪ b`, so a small slip is held as before;
    /// far out its pull is bounded, so that where the static scene backs a direction of travel
    /// tens of sigmas away (KITTI 08's ground-truth chord climbing by 0.4-1.5 rad at 0.2-0.5 m
    /// per frame with a level body) the data win instead of co-moving vehicles
    /// (docs/RESULTS.md §9, twenty-seventh session, rigclimb41).
    pub soft_prior_cauchy: f64,
    /// The soft-prior residuals that `soft_prior_cauchy` makes robust, by index in the model's
    /// prior residuals (`soft_single_track`: 0 side slip, 1 climb); empty: all; default `[1]`
    /// (the climb: a moving object pulls the side slip, where the prior protects the estimate).
    pub soft_prior_cauchy_residuals: Vec<usize>,
    /// Apply `soft_prior_cauchy` only while the soft prior's sigmas are not learnt, i.e. while
    /// fewer than [`SOFT_SIGMA_MIN_FRAMES`](crate::odometry::SOFT_SIGMA_MIN_FRAMES) trusted
    /// moving frames have taught it (true, the default; false: from the first frame on). Once learnt,
    /// the prior's centre and sigmas are the data's own and the climb is least squares again
    /// (the mono family learns early and its learnt prior is right at KITTI 08's slow start;
    /// the surround rig in traffic rarely learns: docs/RESULTS.md §9, twenty-seventh session,
    /// gate41).
    pub soft_prior_cauchy_until_learnt: bool,
    /// Gate `soft_prior_cauchy` by the soft prior's learning lag (default 0.5; 0: off): the
    /// Cauchy loss applies to a frame only where at least `soft_prior_cauchy_after_moving`
    /// moving frames came before it and fewer than this share `ρ` of them taught the soft prior
    /// (`taught < ρ · moving`). A single-camera run teaches the prior on nearly every moving
    /// frame and keeps it least squares; the surround rig in traffic, whose frames nearly all
    /// compete with some vehicle, teaches it on few and gets the bounded climb pull at KITTI
    /// 08's slow start (docs/RESULTS.md §9, twenty-eighth session, climbgate42). Combines with
    /// `soft_prior_cauchy_until_learnt` (both must hold). No effect when `soft_prior_cauchy = 0`.
    pub soft_prior_cauchy_taught_share: f64,
    /// The fewest moving frames before `soft_prior_cauchy_taught_share` may open the Cauchy
    /// loss (default 5): the first frames' share says nothing yet.
    pub soft_prior_cauchy_after_moving: usize,
    /// Apply `soft_prior_cauchy` only on a rig of at least this many cameras (default 2; 1: any
    /// rig). A structural gate: the learning lag of `soft_prior_cauchy_taught_share` alone does
    /// not separate the surround rig from a single camera that meets a vehicle at its start
    /// (at `ρ = 0.5` the lag opens on 124 of the mono family's 300 development sequences, at
    /// `ρ = 0.2` on 62; docs/RESULTS.md §9, twenty-eighth session, climbgate42).
    pub soft_prior_cauchy_min_cameras: usize,
    /// The previous motion's basin on a rig (radians; 0.01745 = 1 deg by default since the
    /// twenty-ninth session, 0: off): where the final stage's rotation differs from the previous
    /// frame's by more than this angle, on a rig of at least two cameras, the final stage solves
    /// the frame again from the previous frame's motion (the first stage would slide into an
    /// object's basin from there) and that solution is kept where the cameras vote for it: per
    /// camera, the matches within `previous_basin_band` of the epipolar planes
    /// ([`crate::separate::epipolar_at_least`]) are counted at both motions, and the cameras
    /// that count more at the alternative must outnumber those that count fewer by
    /// `previous_basin_votes`. A compact object seen by one to three cameras (a bus, a follower
    /// at 0.3-0.5 m per frame) can pull the estimate into a compromise that a robust cost over
    /// all matches prefers; the static world, seen by every camera, fits the truth tightly in
    /// each (docs/RESULTS.md §9, twenty-ninth session, rigslow43). A single camera: no effect.
    pub previous_basin_change: f64,
    /// The band of `previous_basin_change`'s per-camera vote (radians of epipolar angle,
    /// default 0.0014: the simulated noise's scale).
    pub previous_basin_band: f64,
    /// The margin of `previous_basin_change`'s vote (default 2, at least 1): the cameras that
    /// count more matches within the band at the alternative must outnumber those that count
    /// fewer by at least this many (on four cameras: 3 to 1, or 2 to 0).
    pub previous_basin_votes: usize,
    /// The previous motion's basin on a single camera, voted by image regions (`[cols, rows]`
    /// of a coarse grid over the image, `[0, 0]`: off; default `[3, 2]` since the
    /// thirty-first session; a rig keeps its camera vote): a single camera has no cameras to vote, but a compact object (a lead car, a bus)
    /// covers few cells of the image while the static world is spread over it. Where the final
    /// stage's rotation differs from the previous frame's by more than
    /// `previous_basin_mono_change`, the final stage solves the frame again from the previous
    /// frame's motion (as `previous_basin_change` on a rig) and that solution is kept where the
    /// cells vote for it: per cell ([`crate::trust::cell_of`], the frame-(k-1) pixel) the
    /// matches within `previous_basin_band` of the epipolar planes at both motions, each cell
    /// one vote, margin `previous_basin_mono_votes` (docs/RESULTS.md §9, thirtieth session,
    /// monobasin44).
    pub previous_basin_regions: [usize; 2],
    /// The rotation change that triggers `previous_basin_regions` on a single camera (radians,
    /// 0: `previous_basin_change`'s; default 0.01309, 0.75 deg).
    pub previous_basin_mono_change: f64,
    /// The margin of `previous_basin_regions`' vote (0: `previous_basin_votes`'s; default 3):
    /// the cells that count more matches within the band at the alternative must outnumber
    /// those that count fewer by at least this many.
    pub previous_basin_mono_votes: usize,
    /// The band of `previous_basin_regions`' per-cell count (radians of epipolar angle, 0:
    /// `previous_basin_band`'s; default 0.0028).
    pub previous_basin_mono_band: f64,
    /// The region vote's margin on the frame right after a frame where it took the previous
    /// motion's basin (0: `previous_basin_mono_votes`'s, the default). After a taken
    /// alternative at KITTI 08's slow start the next frame's own solution can slide along the
    /// pitch–climb ridge of a weak-parallax frame while the alternative from the taken motion
    /// stays on the static world; a smaller margin there re-checks the next frame against
    /// the taken history (docs/RESULTS.md §9, thirty-first session, slow45).
    pub previous_basin_mono_next_votes: usize,
    /// Where the previous motion's basin is taken (rig or region vote), move the separation's
    /// match memory and its tilt, yaw and road history to it, as `decide_by_road` does
    /// (default false: the rig's behaviour of the twenty-ninth session).
    pub previous_basin_handoff: bool,
    /// The competing motion voted by image regions on a single camera (`[cols, rows]` of a
    /// coarse grid over the image, default `[3, 2]` since the thirty-third session, `[0, 0]`:
    /// off; a rig is never touched): where
    /// the covariance's check found a competing motion ([`FrameDiagnostics::competing`]), its
    /// motion replaces the frame's where the cells of the grid vote for it as in
    /// `previous_basin_regions` (per cell the matches within `competing_region_band` of the
    /// epipolar planes at both motions, each cell one vote, margin `competing_region_votes`).
    /// A cut-in car that holds most of the matches at low speed covers two cells of a 3x2
    /// grid, the static world all six: the estimate that follows the car is the majority of
    /// matches but the minority of cells (docs/RESULTS.md §9, thirty-first session, cutin45).
    ///
    /// [`FrameDiagnostics::competing`]: crate::odometry::FrameDiagnostics::competing
    pub competing_regions: [usize; 2],
    /// The margin of `competing_regions`' vote (default 2, at least 1).
    pub competing_region_votes: usize,
    /// The band of `competing_regions`' per-cell count (radians of epipolar angle; default
    /// 0.0028).
    pub competing_region_band: f64,
    /// Where `competing_regions` takes the competing motion, run the final stage again from it
    /// and keep that solution (default false: the competing motion as fitted to the matches
    /// outside the estimate's support).
    pub competing_region_refit: bool,
    /// `competing_regions` votes only where the frame's own motion is concentrated in the
    /// image: the share of its matches within the band that lie in its fullest third of the
    /// cells (`ceil(cells / 3)`) is at least this (default 0.85; 0: no such guard; a compact
    /// object holds most of its support, the static world spreads over the image).
    pub competing_region_concentration: f64,
    /// `competing_regions` takes the competing motion only where its rotation is closer to the
    /// previous frame's than the frame's own (default true): the static world's motion
    /// continues the history where the estimate jumped to a cut-in car's, while a bus that
    /// covers most of the image moves far from it.
    pub competing_region_continuing: bool,
    /// The frames `competing_region_continuing` looks back to (default 3; 1: the previous
    /// frame only; 0 counts as 1): the competing motion passes where its rotation is closer than the
    /// frame's own to at least one of the last `K` frames' motions. After a cut-in car took the
    /// majority, one frame whose estimate is neither the car's nor the static world's
    /// (dev2 03 s34 frame 74) would otherwise make the next frames' static motion look like a
    /// jump; a bus whose motion is far from every recent frame's is still refused
    /// (docs/RESULTS.md, thirty-second session, cutin46).
    pub competing_region_continuing_frames: usize,
    /// `competing_regions` takes the competing motion only where the two motions differ mainly
    /// in yaw: `|Δψ| ≥ r · √(Δφ² + Δθ²)` for the rotation between them
    /// (`log(R_ownᵀ R_competing)` in the vehicle frame: roll `Δφ`, pitch `Δθ`, yaw `Δψ`;
    /// default 1; 0: no such guard). Traffic moves in the road plane, so the motion of a cut-in
    /// car or a lead vehicle differs from the static world's in yaw and heading; two motions
    /// that differ mainly in pitch are the two ends of the pitch–climb ridge of a slow,
    /// steep start (KITTI 08's first 100 frames), which no region count tells apart
    /// (docs/RESULTS.md, thirty-third session).
    pub competing_region_yaw_ratio: f64,
    /// Widen a frame's soft prior where its own data conflict with it (0: off, the default):
    /// where the data's view of a soft-prior residual ([`crate::Odometry::soft_prior_sigma`]
    /// has the notation: innovation `d_r = q_d,r − c_r`, data variance `v_r`) gives
    /// `d_r² / (σ_r² + v_r)` above this χ²₁ threshold, the frame uses `σ_r'² = d_r² − v_r`
    /// (the one-sample type-II maximum-likelihood prior variance) and is solved again from its
    /// solution (at most twice), before and after the sigmas are learnt. The prior yields where
    /// the data disagree with it beyond their own noise (the KITTI ground truth's slow frames,
    /// whose direction of travel drifts away from the centre by tens of prior sigmas). Default
    /// 4 (since the seventeenth session, with `soft_prior_conflict_residuals = [1]`, the
    /// climb, `soft_prior_conflict_on_support` and `soft_prior_conflict_after_trusted`;
    /// docs/RESULTS.md §9, seventeenth session, lead); 0 turns it off. Measured before
    /// (sixteenth session): `2` on the climb, tested on all matches, lowers outliers along
    /// KITTI 08 but costs 00 and part of the moving-traffic family; on both residuals it
    /// breaks the family (an object pulls the side slip). A model without a soft prior
    /// ignores it.
    pub soft_prior_conflict_widening: f64,
    /// The soft-prior residuals that `soft_prior_conflict_widening` may widen, by index in the
    /// model's prior residuals (`soft_single_track`: 0 side slip, 1 climb); empty: all;
    /// default `[1]`. `[1]` widens only the climb: a vertical drift of the ground truth (KITTI
    /// 08's first 100 frames: 16-29 cm per frame, up to 1.5 rad at 0.2 m steps) conflicts there,
    /// whereas a moving object pulls the side slip, where the prior protects the estimate.
    pub soft_prior_conflict_residuals: Vec<usize>,
    /// With `soft_prior_conflict_widening`: test the conflict on the frame solved on the final
    /// stage's support only (the matches within `final_fit.inlier_sigmas` of the noise, in
    /// front of both cameras, under the parallax cap; [`crate::final_fit::support`]) instead
    /// of on all matches, so that mismatches and a moving object's matches, which the first
    /// stage's robust loss only down-weights, cannot trip it; the widened prior then applies
    /// to the frame's solve on all its matches as without it. One more solve per frame.
    /// Default true since the seventeenth session (lead, with the memory-track options;
    /// docs/RESULTS.md §9). Measured alone (docs/RESULTS.md §9, seventeenth session) with
    /// `soft_prior_conflict_widening = 4` on the climb and `soft_prior_conflict_after_trusted`,
    /// 8 -> 5 of the 66 static sequences along KITTI above 1.15 x the bound and the
    /// moving-traffic grid 48 -> 46 frames above 1 deg, but 4 static sequences worse by up to
    /// 0.015 and one hold-out sequence 2.28 -> 2.41 x the bound.
    pub soft_prior_conflict_on_support: bool,
    /// With `soft_prior_conflict_widening`: widen only where the previous frame centred the
    /// change-of-motion prior (estimated, trusted, no competing motions): an object that
    /// persists over frames does not widen the prior of its frames. Default true since the
    /// seventeenth session.
    pub soft_prior_conflict_after_trusted: bool,
    /// Widen the soft prior where the recent frames' data keep disagreeing with it (0: off;
    /// else the number of frames `K`; default 10 since the twenty-first session, with
    /// `soft_prior_consistency_never_after_flag` and `final_fit.learnt_cauchy_max = 6`): before each frame's solve, over the last
    /// `K` trusted moving frames' innovations `(d_j², v_j)` ([`crate::Odometry::soft_prior_sigma`]
    /// has the notation: `d_j = q_d,j − c`, the data-only estimate against the prior's centre,
    /// `v_j` its variance), a residual whose mean normalised innovation
    /// `NIS = (1/K) Σ_j d_j² / (σ_r² + v_j)` exceeds `soft_prior_consistency_limit` gets the
    /// width `σ_r'` that makes it 1 (covariance matching of the adaptive Kalman filter:
    /// `E[d²] = σ_true² + v`; `NIS` is decreasing in `σ²`, solved by bisection on
    /// `[σ_r², mean d²]`). Where the data agree with the prior (`NIS ≈ 1`) the width stays.
    /// Only the residuals of `soft_prior_consistency_residuals`. The innovations are those of
    /// the frames that centre the prior (estimated, trusted, no competing motions), so a frame
    /// where an object pulled the data does not count, and none within
    /// [`CONSISTENCY_QUIET_FRAMES`](crate::odometry::CONSISTENCY_QUIET_FRAMES) frames after one
    /// flagged `competing_motions` / `road_score_drop`. A model without a soft prior ignores
    /// it. Measured (docs/RESULTS.md §9, twentieth session, static34) with `K = 10`, `T = 2`:
    /// the 66 static sequences along KITTI above 1.15 x the bound 5 -> 2, mean eff 1.0096 ->
    /// 1.0028 (21 better, 9 worse by up to 0.016), fresh seeds 4-6 4 -> 0; real KITTI 00 within
    /// 0.3 %; the moving-traffic hold-out 6 -> 8 frames above 1 deg (trust gap 0 -> 1): off
    /// then. Stopped at the first flagged frame (`soft_prior_consistency_never_after_flag`) the
    /// hold-out holds (docs/RESULTS.md §9, twenty-first session, static35 and lead).
    pub soft_prior_consistency_frames: usize,
    /// The soft-prior residuals that `soft_prior_consistency_frames` may widen, by index in the
    /// model's prior residuals (`soft_single_track`: 0 side slip, 1 climb); empty (the
    /// default): all.
    pub soft_prior_consistency_residuals: Vec<usize>,
    /// With `soft_prior_consistency_frames`: the robust statistic, the median of the recent
    /// frames' `d_j² / (σ_r² + v_j)` over the χ²₁ median (0.455), instead of their mean (a
    /// single frame where an object pulled the data does not widen the prior; the width then
    /// makes the median 0.455). Default false.
    pub soft_prior_consistency_median: bool,
    /// The mean normalised innovation above which `soft_prior_consistency_frames` widens the
    /// soft prior (> 0; default 2: for `K = 10` frames of Gaussian innovations at the prior's
    /// width, the mean of ten χ²₁ exceeds 2 with probability 3 %).
    pub soft_prior_consistency_limit: f64,
    /// With `soft_prior_consistency_frames`: the widening stops for the rest of the sequence
    /// at the first frame flagged `weak` by `competing_motions` or `road_score_drop`, instead
    /// of waiting [`CONSISTENCY_QUIET_FRAMES`](crate::odometry::CONSISTENCY_QUIET_FRAMES)
    /// frames after each. Where the separation has once seen a second motion, a later stretch
    /// of unflagged frames is no evidence that no object is followed: on the moving-traffic
    /// hold-out (seeds 11-15) the widening acted only in 08 s11's frames 238-271, its one
    /// stretch of 100 unflagged frames, and the estimates it moved changed the separation's
    /// later choices (frames 379 and 396 above 1 deg; docs/RESULTS.md §9, twentieth session,
    /// static34). With the gate the hold-out keeps main's 6 frames and the grid its 7; on the
    /// 66 static sequences along KITTI (never flagged by the default) only clean 08 s3 changes,
    /// where the widening itself led to a `road_score_drop` flag at frame 28 (1.117 -> 1.152 x
    /// the bound; docs/RESULTS.md §9, twenty-first session, static35). Default true since the
    /// twenty-first session (false before).
    pub soft_prior_consistency_never_after_flag: bool,
    /// Move the soft prior's centre to the recent frames' level where their data agree on one
    /// away from it (0: off; else the number of frames `m`; default 10, with
    /// `soft_prior_trend_blend` and `soft_prior_trend_widen` since the twenty-third session): a slip that changes
    /// over tens of frames (a climb that steepens, a drive that drifts sideways at low speed)
    /// is followed instead of pulled towards the long mean of `soft_prior_centring_frames`.
    /// Before each frame's solve, per soft-prior residual `r`, over the last `m` trusted moving
    /// frames' data-only estimates `q_d,j` with variances `v_j` ([`crate::Odometry::soft_prior_sigma`]
    /// has the notation; `q_d` does not depend on the centre in the linearisation), the
    /// level's offset `δ = (1/m) Σ_j q_d,j − c_r` against the centre `c_r` has the standard
    /// error `e = √(Σ_j (σ_r² + v_j)) / m` (`σ_r` the frame's width: the true slip's spread
    /// around the level plus the data's noise, independent frames); the centre moves by the
    /// soft-thresholded offset `sign(δ) · max(0, |δ| − z e)` with `z =
    /// soft_prior_trend_z` (a one-sided test at `z`: a centre the data agree with stays, a
    /// clear offset is followed up to `z e`). The same gate as `soft_prior_consistency_frames`
    /// (not within [`CONSISTENCY_QUIET_FRAMES`](crate::odometry::CONSISTENCY_QUIET_FRAMES)
    /// frames after a frame flagged `competing_motions` / `road_score_drop`, never after one
    /// with `soft_prior_consistency_never_after_flag`): a vehicle followed for many frames
    /// pulls the data's side slip as consistently as a slope. A model without a soft prior
    /// ignores it. Measured (docs/RESULTS.md §9, twenty-second session, static36) with `m = 10`,
    /// `z = 1`: the 66 static sequences along KITTI above 1.15 x the bound 2 -> 1, mean eff
    /// 0.9924 -> 0.9790 (37 better, 6 worse by up to 0.014), fresh seeds 4-6 0.9950 -> 0.9818;
    /// built-in drive, real KITTI 00 (within 0.6 %), the family's hold-out and fresh seeds hold;
    /// the grid 6 -> 2 frames above 1 deg but its median eff 1.278 -> 1.288; along a drive
    /// whose slip turns within about 20 frames (`tests/it/final_fit.rs`) `m = 10` lags it (+1-2
    /// % median rotation error) where `m = 20` gains 0.5-1.4 %: it stayed off then. The default
    /// since the twenty-third session is `m = 10`, `z = 1` with the blend and the widening (see
    /// `soft_prior_trend_blend`).
    pub soft_prior_trend_frames: usize,
    /// The threshold `z` of `soft_prior_trend_frames` in standard errors of the recent level
    /// (> 0; default 1 since the twenty-third session, 2 before).
    pub soft_prior_trend_z: f64,
    /// With `soft_prior_trend_frames`: move the centre by the Kalman gain of the two estimates
    /// of the current level instead of soft thresholding — the centre, whose departure from
    /// the level has the variance `P` (by moments, `E δ² = P + e²`), and the recent mean with
    /// `e²`: `c + g δ`, `g = max(0, 1 − z² e² / δ²)` (positive-part James–Stein shrinkage
    /// towards the centre; `z` as in `soft_prior_trend_z`, the same threshold `|δ| = z e`
    /// below which nothing moves, and beyond it a larger move than the soft threshold's `g =
    /// 1 − z e / |δ|`). Default true (twenty-third session). Measured with `soft_prior_trend_widen` (docs/RESULTS.md
    /// §9, twenty-third session, static37), `m = 10`, `z = 1`: the 66 static sequences along
    /// KITTI above 1.15 x the bound 2 -> 0, mean eff 0.9924 -> 0.9784 (38 better, 7 worse by
    /// 0.005-0.020; `z = 0.98` against `z = 1.02` alone moves 8 / 8 by that much), fresh seeds
    /// 4-6 0.9950 -> 0.9752; the family's frames above 1 deg and median / max eff hold (grid
    /// median 1.2781 -> 1.2769), trust gap 0, built-in drive unchanged; but real KITTI 00's
    /// median rotation error rises by up to 1.8 % (mono300; 1.4 % without the widening) and the
    /// drifting drive of `tests/it/final_fit.rs` by 1-3 %. Made the default by the lead: the
    /// issue's regression check on real KITTI 00 is 3 %, and the simulated scenes with their
    /// bound, not the ground-truth-limited KITTI 00, rank estimators (docs/RESULTS.md §9,
    /// twenty-third session, lead).
    pub soft_prior_trend_blend: bool,
    /// With `soft_prior_trend_frames`: the moved centre's own uncertainty widens the soft
    /// prior, `σ_r² ← σ_r² + g e²` (the level's posterior variance for the gain `g` in use),
    /// so a trend measured on noisy frames pulls the frame less than one measured on clean
    /// frames. With `m = 10` the widening is at most `e² ≈ (σ_r² + v) / 10`: by itself it
    /// changes little (soft threshold, `z = 1`, on the 66 static sequences: mean eff 0.9790 ->
    /// 0.9798, outliers 08 s1 1.184 -> 1.159; docs/RESULTS.md §9, twenty-third session). Default
    /// true (twenty-third session; with the blend it takes outliers 08 s1 from 1.167 to 1.143).
    pub soft_prior_trend_widen: bool,
    /// The per-parameter motion prior: for each named model parameter, the standard deviation
    /// of its change from one frame to the next (radians or metres per frame), as a Gaussian
    /// cost term centred on the previous frame's parameters ([`momo_core::MotionPrior`]), in
    /// addition to `rotation_change_sigma`. Names depend on the model (an unknown name is an
    /// error). Empty (the default): none.
    pub motion_prior_sigmas: BTreeMap<String, f64>,
    /// The quiet-frame fast path of the motion separation (issue 19): after this many
    /// consecutive moving frames on which no alternative motion competed, a frame whose
    /// evidence shows one motion is separated without solving the alternatives B, C and M
    /// (`[odometry.separate] second_motion` off for that frame: the match memory, the road
    /// scores and the final stage run as on any frame without a competing alternative, so the
    /// frame's estimate is bit-identical wherever the full separation would not have kept an
    /// alternative). The frame stays watched: the full separation runs where the match memory
    /// remembers another motion's matches outside the first stage's support (the share of the
    /// labelled matches outside it remembered as other exceeds the share of all remembered
    /// matches by more than `quiet_other_share`), where the first stage's residuals cluster
    /// in the image (the trust section's cell statistic above `trust.clustering_z`, or within
    /// `trust.clustering_frames` of a frame where it was), or where the first stage's inlier
    /// share fell below [`QUIET_SUPPORT_DROP`] of the recent frames' best. 0 (the default):
    /// off; `configs/fast.toml` sets 10 (with `quiet_other_share = 0.05`). Measured in
    /// docs/RESULTS.md ("Speed", eighteenth session): a fifth to a third of the whole process
    /// on the four-camera rigs with the same estimates, nothing saved on one pinhole camera
    /// (1-3 % for the checks), the moving-traffic grid's frames above 1 deg 33 -> 33 and the
    /// hold-out's 27 -> 28 with the preset.
    pub quiet_frames: usize,
    /// With `quiet_frames`: the largest excess of the match memory's "other" share among the
    /// matches outside the first stage's support (the separation's threshold) over its share
    /// among all remembered matches on a quiet frame (random mismatches are remembered as
    /// other outside the support as often as anywhere, an object moving against the support
    /// more often). Default 0.1.
    pub quiet_other_share: f64,
    /// Decide a doubted frame by its alternatives' road scores (docs/RESULTS.md, twenty-ninth
    /// session, monotail43): on a frame flagged `weak` that carries a competing motion or a
    /// road alternative, the chosen motion, the competing motion, the road alternative and the
    /// previous frame's motion (this frame's arc length) are scored by the separation's road
    /// score ([`crate::hypotheses::score`], on each motion's own epipolar support at the
    /// separation's threshold); the best replaces the chosen motion where its score exceeds
    /// the chosen one's by at least this many (cells or matches, as the score counts). The
    /// frame stays flagged and keeps the chosen motion's covariance. 0: off; default 3 since the
    /// thirty-first session (with `decide_by_road_tilt`).
    pub decide_by_road: usize,
    /// With `decide_by_road`: only the alternatives whose yaw `ω_z` lies at least as close to
    /// the previous frame's as the chosen motion's compete (a vehicle's motion that leaves the
    /// run's turn is no candidate). false (the default): every alternative competes.
    pub decide_by_road_continuing: bool,
    /// With `decide_by_road_continuing`: the yaw test applies only where each of the last this
    /// many frames was trusted (status `estimated`, no competing motion, its inlier ratio
    /// within `prior_min_inlier_ratio` of the running average: the frames that centre the
    /// change-of-motion prior), so a history that is itself doubted (a lock-in) does not
    /// protect itself; after a doubted frame every alternative competes. 0 (the default): the
    /// yaw test applies on every frame (as `decide_by_road_continuing` alone).
    pub decide_by_road_trusted_frames: usize,
    /// With `decide_by_road`: the vehicle model's bound on the change of yaw `ω_z` from one
    /// frame to the next (radians per frame pair). An alternative whose yaw lies more than
    /// this from the previous frame's reported yaw, and further from it than the chosen
    /// motion's, does not compete: a car does not leave a turn of 3 deg per frame for a
    /// straight line within one frame, a lead vehicle's motion seen from it does
    /// (docs/RESULTS.md, fiftieth session). `decide_by_road_continuing` is the bound at 0.
    /// Default 0.03 (1.7 deg) since the fiftieth session: over twice the largest change of
    /// yaw between consecutive frames of the KITTI 00-10 ground truth at 10 Hz (0.013 rad, on
    /// 02 and 05; 00's single 0.043 at frame 2980 follows three frames of one held yaw rate,
    /// a step of its poses rather than of the car); at another frame rate scale it with the
    /// frame interval. 0: off.
    pub decide_by_road_yaw_jump: f64,
    /// With `decide_by_road`: the separation's yaw-history margin applied to its replacements
    /// too (radians per frame pair; 0: off). An alternative whose yaw lies more than this from
    /// the previous frame's reported yaw, and further from it than the chosen motion's,
    /// replaces the chosen motion only where its road score is decisive in the separation's
    /// sense: at least `separate.ground_admit_min` (scaled to the frame's matches by
    /// `separate.count_reference`) and at least `separate.ground_admit` times the chosen
    /// motion's. The separation's ordinary choice lets such a switch through on the same
    /// terms only (`hypotheses.yaw_history_margin`, 1 deg); without this bound
    /// `decide_by_road` lets any switch within `decide_by_road_yaw_jump` (1.7 deg) through
    /// on a margin of `decide_by_road` road cells. Default 0.01745 (1 deg, the separation's
    /// margin) since the sixty-ninth session (docs/RESULTS.md, sixty-ninth session).
    pub decide_by_road_yaw_margin: f64,
    /// With `decide_by_road`: only the alternatives whose tilt ([`crate::hypotheses::tilt`],
    /// the norm of roll and pitch) lies at least as close to the previous frame's reported
    /// motion's tilt as the chosen motion's compete (a tilt that leaves the run's tilt is no
    /// candidate; the previous motion itself competes, but see `decide_by_road_tilt_trusted`).
    /// Default true since the thirty-first session (docs/RESULTS.md, thirtieth session, dbr44);
    /// false: no tilt test.
    pub decide_by_road_tilt: bool,
    /// With `decide_by_road_tilt`: the tilt compared as the vector `(ω_x, ω_y)` (roll and
    /// pitch; the distance of the vectors) instead of its norm. false (the default): the norm.
    pub decide_by_road_tilt_vector: bool,
    /// With `decide_by_road_tilt`: the reference is the median (per component for the vector)
    /// of the last this many moving frames' reported tilts; above 1 the previous motion
    /// competes under the same test. Default 1 (the previous frame's).
    pub decide_by_road_tilt_frames: usize,
    /// With `decide_by_road`: where the previous moving frame did not centre the prior
    /// (flagged, competing or with a low inlier ratio), the previous motion does not compete
    /// where its tilt `(ω_x, ω_y)` lies more than `final_fit.guard_tilt` from the trusted
    /// frames' running mean tilt (the one `tilt_hold_sigma` holds to, within
    /// `tilt_hold_frames` of the last trusted frame) and the frame's own motion's within it
    /// ([`crate::final_fit::guard_tilt_keeps_reduced`]): a doubted frame's rolled motion is not
    /// taken back by road score. Default true since the eightieth session (docs/RESULTS.md);
    /// false: the previous motion always competes.
    pub decide_by_road_tilt_trusted: bool,
    /// With `decide_by_road`: a replacement moves the separation's tilt, yaw and road history
    /// but not its match memory. false (the default): the memory moves to the replacement's
    /// support too.
    pub decide_by_road_keep_memory: bool,
    /// Write the final stage's support into the diagnostics (`support` of each frame's row:
    /// per camera, the indices of the matches the final stage refit on, counted among that
    /// camera's rows of the frame in matches.csv's order). An analysis aid: it changes no
    /// estimate. false (the default): the field is not written (byte-identical diagnostics).
    pub report_support: bool,
    /// The noise (radians of epipolar angle) at which the driver's angular thresholds are
    /// stated ([`crate::noise`]): `odometry.standstill_still_angle`, the `previous_basin` and
    /// `competing_region` bands, `separate.threshold`, `separate.under_road_noise`,
    /// `separate.hypotheses.noise_angle` and `trust.competing_threshold` scale with the median
    /// noise of the last `noise_frames` frames reported `estimated` over this, where that ratio
    /// exceeds `noise_band` (never below 1). 0: off (the thresholds as written). The default,
    /// 0.0019, is the median noise measured at 1 px on the simulated KITTI camera; the
    /// defaults of `noise_frames` (20) and `noise_band` (1.4) lie between the largest 20-frame
    /// median measured at 1 px (1.23 times it, the moving-traffic hold-out seeds) and the
    /// smallest at 2 px (1.58 times). A model misfit reads as noise too: KITTI 08's climbing
    /// start with 40-100 matches reads up to 2.6 times it at 1 px (docs/RESULTS.md).
    pub noise_reference: f64,
    /// How many recent frames' noise the scale of [`noise_reference`](Self::noise_reference)
    /// is the median of.
    pub noise_frames: usize,
    /// How many frames' noise must be read before the scale of
    /// [`noise_reference`](Self::noise_reference) takes effect (at most `noise_frames`; until
    /// then the thresholds are as written). 3 (sixty-sixth session; half the window, 10, before):
    /// a run that starts among traffic at 2-3 px reports few frames `estimated` without a
    /// competing motion, so at 3 px the scale took effect only at frame 79 (median over the
    /// development seeds at 3 px; 124 at the 90th percentile), and until then its thresholds
    /// sat at one noise sigma. At 1 px the median of the first three readings exceeds
    /// `noise_band` only where a model misfit reads as noise (KITTI 08's climbing start).
    pub noise_start_frames: usize,
    /// The ratio (at least 1) up to which the thresholds stay as written.
    pub noise_band: f64,
    /// With [`noise_reference`](Self::noise_reference): the upper clamp of the final stage's
    /// noise estimate, `final_fit.max_scale_ratio` (in first-stage loss scales, stated for the
    /// same noise), scales with the thresholds; its start window (`start_scales`) does not.
    /// Without it the stage's noise estimate stops at 5 loss scales (0.005 rad): 2 px through
    /// a fisheye of f = 330 px reads 0.0086, and the stage then trims and down-weights good
    /// static matches. Scaling the start window too measured worse on moving traffic at 3 px
    /// (docs/RESULTS.md, sixtieth session).
    pub noise_final_fit: bool,
}

/// With [`OdometryOptions::quiet_frames`]: a frame whose first-stage inlier share is below this
/// factor times the recent frames' best (the jackknife's decaying peak) runs the full
/// separation (a support drop: a new object or a compromise motion).
pub const QUIET_SUPPORT_DROP: f64 = 0.9;

/// `odometry.tilt_hold_stage`: where the tilt hold (`odometry.tilt_hold_sigma`) acts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TiltHoldStage {
    /// In every solve of the frame: it also moves the motion separation's choice between
    /// motions, and through the run's state (warm start, histories, match memory, the priors'
    /// centres) later frames.
    Solves,
    /// In the final stage's refits ([`crate::final_fit`]) only, after the separation has chosen;
    /// the run's state reads the held motion, so later frames still move.
    Final,
    /// In the report only: the final stage's refits are run once more with the hold, and the
    /// frame reports the held refit of the motion it goes on with. Its reported covariance is
    /// widened about the held refit (competing motions, the road's alternatives, the previous
    /// reported motion after a flag), and the report-only trust rules read it. The run's state
    /// reads the motion without it, so no other frame's motion moves. Where the frame's motion
    /// is not a final-stage refit (a rule replaced it afterwards), nothing is held.
    #[default]
    Report,
}

/// `odometry.road_scale_mount`: what a run over a whole sequence without odometry.csv does with
/// the mount before the road gives the scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RoadScaleMount {
    /// No calibration: the road is read through the rig as given.
    Nominal,
    /// The mount is calibrated on the sequence and its pitch given to the road
    /// (`separate.hypotheses.ground_pitch`); the motion model keeps the rig as given.
    #[default]
    Road,
    /// The mount is calibrated on the sequence and the run uses the corrected rig.
    Rig,
}

impl Default for OdometryOptions {
    fn default() -> Self {
        Self {
            standstill_arc_length: 0.01,
            standstill_at_rest: true,
            standstill_still_angle: 0.006,
            standstill_cell_cap: 2.0,
            standstill_jackknife: true,
            road_scale_frames: 1,
            road_scale_metric: true,
            road_scale_initial_metric: true,
            road_scale_mount: RoadScaleMount::Road,
            min_matches: 8,
            initial_arc_length: 1.0,
            estimate_scale: true,
            max_relative_scale_sigma: 0.2,
            max_arc_length_ratio: 3.0,
            restart_inlier_ratio: 0.7,
            restart_yaw_offsets: vec![-0.1, -0.03, 0.03, 0.1],
            rotation_change_sigma: 0.002,
            prior_min_inlier_ratio: 0.85,
            prior_min_arc_length: 0.0,
            tilt_hold_sigma: 0.003,
            tilt_hold_frames: 30,
            tilt_hold_stage: TiltHoldStage::Report,
            separate: Some(crate::separate::SeparateOptions::competition_over_time()),
            final_fit: crate::final_fit::FinalFitOptions::default(),
            soft_prior_centring_frames: 100,
            soft_prior_sigma_learning: true,
            soft_prior_sigma_max: 10.0,
            soft_prior_sigma_factor: 1.0,
            soft_prior_student_nu: 0.0,
            soft_prior_arc_learning: false,
            soft_prior_arc_jitter: 0.0,
            soft_prior_learn_competing: false,
            soft_prior_cauchy: 5.0,
            soft_prior_cauchy_residuals: vec![1],
            soft_prior_cauchy_until_learnt: true,
            soft_prior_cauchy_taught_share: 0.5,
            soft_prior_cauchy_after_moving: 5,
            soft_prior_cauchy_min_cameras: 2,
            // Since the twenty-ninth session (docs/RESULTS.md §9, twenty-ninth session,
            // rigslow43 and lead): no effect on a single camera.
            previous_basin_change: 0.01745,
            previous_basin_band: 0.0014,
            previous_basin_votes: 2,
            previous_basin_regions: [3, 2],
            previous_basin_mono_change: 0.01309,
            previous_basin_mono_votes: 3,
            previous_basin_mono_next_votes: 0,
            previous_basin_mono_band: 0.0028,
            previous_basin_handoff: false,
            // Since the thirty-third session (docs/RESULTS.md §9, thirty-third session): the
            // vote with its three guards; no effect on a rig.
            competing_regions: [3, 2],
            competing_region_votes: 2,
            competing_region_band: 0.0028,
            competing_region_refit: false,
            competing_region_concentration: 0.85,
            competing_region_continuing: true,
            competing_region_continuing_frames: 3,
            competing_region_yaw_ratio: 1.0,
            soft_prior_conflict_widening: 4.0,
            soft_prior_conflict_residuals: vec![1],
            soft_prior_conflict_on_support: true,
            soft_prior_conflict_after_trusted: true,
            soft_prior_consistency_frames: 10,
            soft_prior_consistency_residuals: Vec::new(),
            soft_prior_consistency_median: false,
            soft_prior_consistency_limit: 2.0,
            soft_prior_trend_frames: 10,
            soft_prior_trend_z: 1.0,
            soft_prior_trend_blend: true,
            soft_prior_trend_widen: true,
            soft_prior_consistency_never_after_flag: true,
            motion_prior_sigmas: BTreeMap::new(),
            quiet_frames: 0,
            quiet_other_share: 0.1,
            decide_by_road: 3,
            decide_by_road_continuing: false,
            decide_by_road_trusted_frames: 0,
            decide_by_road_yaw_jump: 0.03,
            decide_by_road_yaw_margin: 0.01745,
            decide_by_road_tilt: true,
            decide_by_road_tilt_vector: false,
            decide_by_road_tilt_frames: 1,
            decide_by_road_tilt_trusted: true,
            decide_by_road_keep_memory: false,
            report_support: false,
            noise_reference: 0.0019,
            noise_frames: 20,
            noise_start_frames: 3,
            noise_band: 1.4,
            noise_final_fit: true,
        }
    }
}

/// Options of the 5-point RANSAC baseline (`momo run --estimator five-point`); the fields of
/// [`momo_fivepoint::FivePointRansac`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FivePointOptions {
    /// Inlier threshold on the angular Sampson error, radians (1e-3 ~ 0.7 px at f = 718 px;
    /// OpenCV's usual 1 px is 1.4e-3 there).
    pub threshold: f64,
    /// Probability that at least one all-inlier sample is drawn (adaptive stopping).
    pub confidence: f64,
    /// Upper bound on the number of RANSAC samples.
    pub max_iterations: usize,
    /// Seed of the random sampling (runs are deterministic for a seed).
    pub seed: u64,
    /// Refine the final hypothesis by robust least squares on its inliers (PoseLib's LO-RANSAC
    /// does; OpenCV's findEssentialMat + recoverPose does not).
    pub refine: bool,
}

impl Default for FivePointOptions {
    fn default() -> Self {
        Self::from(&momo_fivepoint::FivePointRansac::default())
    }
}

impl From<&momo_fivepoint::FivePointRansac> for FivePointOptions {
    fn from(r: &momo_fivepoint::FivePointRansac) -> Self {
        Self {
            threshold: r.threshold,
            confidence: r.confidence,
            max_iterations: r.max_iterations,
            seed: r.seed,
            refine: r.refine,
        }
    }
}

impl From<&FivePointOptions> for momo_fivepoint::FivePointRansac {
    fn from(o: &FivePointOptions) -> Self {
        Self {
            threshold: o.threshold,
            confidence: o.confidence,
            max_iterations: o.max_iterations,
            seed: o.seed,
            refine: o.refine,
        }
    }
}

/// The whole configuration of an estimator. Every section is optional in a file: a section
/// left out takes its value from [`Config::default`] (so a file may hold only `[loss]`).
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// The motion model (`type = "se3"`, `"single_track_2d"`, `"single_track_3d"`).
    #[serde(default = "default_model")]
    pub model: Box<dyn ModelSpec>,
    /// The residual metric (`type = "angle_plane"`, `"geo_line"`, `"sampson"`).
    #[serde(default = "default_metric")]
    pub metric: Box<dyn MetricSpec>,
    /// The robust loss and its scale in the metric's units (`type = "cauchy"`, `scale = 0.001`).
    #[serde(default = "default_loss")]
    pub loss: Box<dyn RobustLoss>,
    /// The solver and its options (`type = "levenberg_marquardt"`, ...).
    #[serde(default = "default_solver")]
    pub solver: Box<dyn Solver>,
    /// The odometry driver's options.
    #[serde(default)]
    pub odometry: OdometryOptions,
    /// The 5-point RANSAC baseline's options (used only by `--estimator five-point`).
    #[serde(default)]
    pub five_point: FivePointOptions,
    /// A second loss to refine each frame's solution with, started from it (none by default).
    /// With a redescending loss (`tukey`) the outliers lose all pull once the first, softer
    /// loss has brought the estimate near the answer: graduated non-convexity in two steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine_loss: Option<Box<dyn RobustLoss>>,
    /// What the driver trusts: degeneracy thresholds and the run's failure share
    /// ([`crate::trust`]).
    #[serde(default)]
    pub trust: TrustOptions,
    /// Where the configuration was read from (its name and text), to point errors at a line;
    /// empty for a configuration built in code.
    #[serde(skip)]
    pub origin: Origin,
}

/// The name and text a configuration was read from.
#[derive(Clone, Debug, Default)]
pub struct Origin {
    /// The file name (as given to the parser).
    pub name: Option<String>,
    /// The text.
    pub text: Option<String>,
}

/// The default: `SoftSingleTrack` (Se3's parameters, side slip and climb as priors with sigma
/// 0.01 rad, centred on their running mean over 100 frames) with the arc length from odometry,
/// `AnglePlane`, Cauchy with scale 0.001 rad (0.7 px at KITTI's focal length),
/// Levenberg-Marquardt and the rotation prior. Since 2026-11-24 (issue 14, docs/RESULTS.md
/// §9): efficiency (median error / Cramér-Rao bound, 5 seeds) 0.83-1.14 on clean, highway,
/// very sparse and sparse outliers, 1.33 on the fisheye rig, 1.40 with 30 % outliers (se3
/// before: 1.14-1.60); real KITTI 00 medians 2-7 % below the se3 default's. The final
/// efficient stage ([`crate::final_fit`]) brings the fisheye rig to 1.14 and the outliers to
/// 1.24 but makes the covariance over-confident, so it is off.
///
/// The se3 choice before it:
///
/// Chosen by `scripts/kitti00_eval.sh` on the real KITTI 00 matches (frames 0-300, 200 matches
/// per frame, seeds 1-3, arc length from ground truth): frame-to-frame rotation error median /
/// p95 / max / count above 1 deg, KITTI t_err:
/// - `se3`, Cauchy 0.001: 0.0412 / 0.1245 / 0.269 deg / 0, 1.015 % (the best median and t_err);
/// - `se3`, Cauchy 0.002: 0.0428 / 0.1254 / 0.267 / 0, 1.039 %; 0.0065 (the paper's): 0.0468 /
///   0.1328 / 0.265 / 0, 1.155 %;
/// - `single_track_3d`, Cauchy 0.001: 0.0567 / 0.165 / 0.42 / 0, 2.17 %;
/// - `single_track_2d`, Cauchy 0.001: 0.196 / 0.532 / ~1.4 / 3, 3.3 % (biased on real motion).
///
/// Sampson (0.5 px) and GeoLine (1 px) tie with AnglePlane at 0.001 but take 2-4x the time.
impl Default for Config {
    fn default() -> Self {
        Self {
            model: default_model(),
            metric: default_metric(),
            loss: default_loss(),
            solver: default_solver(),
            odometry: OdometryOptions::default(),
            five_point: FivePointOptions::default(),
            refine_loss: None,
            trust: TrustOptions::default(),
            origin: Origin::default(),
        }
    }
}

/// The default `[model]`: `soft_single_track` (side slip and climb sigma 0.01 rad), chosen by
/// efficiency against the Cramér-Rao bound on the simulated scenarios with KITTI 00 as the
/// regression check (issue 14, docs/RESULTS.md §9); `se3` before 2026-11-24.
fn default_model() -> Box<dyn ModelSpec> {
    Box::new(momo_models::SoftSingleTrack::default())
}

/// The default `[metric]`: `angle_plane`.
fn default_metric() -> Box<dyn MetricSpec> {
    Box::new(momo_costs::AnglePlane)
}

/// The default `[loss]`: Cauchy with scale 0.001 rad.
fn default_loss() -> Box<dyn RobustLoss> {
    Box::new(momo_costs::Cauchy::new(0.001))
}

/// The default `[solver]`: Levenberg-Marquardt with its default options.
/// `solver` with its `max_iterations` lowered to `max_iterations` (0: kept), its
/// `function_tolerance` raised to `function_tolerance` (0: kept) and its
/// `max_step_extrapolation` set to `max_step_extrapolation` (0: kept), where its configuration
/// has these fields (Levenberg-Marquardt's); `None` where no limit is set or nothing changes
/// (the caller then uses `solver` itself). The separation's alternatives
/// (`odometry.separate.candidate_*`) and the jackknife's undefined cells
/// (`trust.jackknife_undefined_*`) take their solvers from here.
pub(crate) fn solver_with_limits(
    solver: &dyn Solver,
    max_iterations: usize,
    function_tolerance: f64,
    max_step_extrapolation: f64,
) -> Option<Box<dyn Solver>> {
    if max_iterations == 0 && !(function_tolerance > 0.0) && !(max_step_extrapolation > 0.0) {
        return None;
    }
    let mut v = serde_json::to_value(solver).ok()?;
    let o = v.as_object_mut()?;
    let mut changed = false;
    if max_iterations > 0
        && let Some(m) = o.get_mut("max_iterations")
        && m.as_u64().is_some_and(|m| m > max_iterations as u64)
    {
        *m = (max_iterations as u64).into();
        changed = true;
    }
    if function_tolerance > 0.0
        && let Some(f) = o.get_mut("function_tolerance")
        && f.as_f64().is_some_and(|f| f < function_tolerance)
    {
        *f = function_tolerance.into();
        changed = true;
    }
    if max_step_extrapolation > 0.0
        && let Some(t) = o.get_mut("max_step_extrapolation")
        && t.as_f64() != Some(max_step_extrapolation)
    {
        *t = max_step_extrapolation.into();
        changed = true;
    }
    if !changed {
        return None;
    }
    serde_json::from_value(v).ok()
}

fn default_solver() -> Box<dyn Solver> {
    Box::new(momo_solvers::LevenbergMarquardt::default())
}

/// The largest arc length per frame that any configuration or odometry value may name
/// (metres): 1 km per frame is far beyond any vehicle at any frame rate, so a larger number is
/// a unit or typing error (1e200 m overflows the geometry).
pub const MAX_ARC_LENGTH: f64 = 1000.0;

/// `section.key` names of the solver options, in the order of `solver_problems`' list.
const SOLVER_KEYS: &[&str] = &[
    "solver.max_iterations",
    "solver.function_tolerance",
    "solver.gradient_tolerance",
    "solver.parameter_tolerance",
    "solver.initial_lambda",
    "solver.lambda_increase",
    "solver.lambda_decrease",
    "solver.min_lambda",
    "solver.max_lambda",
    "solver.initial_radius",
    "solver.max_radius",
    "solver.min_radius",
];

/// The `type` tag of a tagged trait object (`""` if it has none).
fn type_tag<T: Serialize + ?Sized>(value: &T) -> String {
    serde_json::to_value(value)
        .ok()
        .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(str::to_string))
        .unwrap_or_default()
}

/// The 1-based line of `section.key` (or of the `[section]` header for a bare `section`) in a
/// TOML or JSON text; `None` if absent.
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    let (section, field) = match key.rsplit_once('.') {
        Some((s, f)) => (s, Some(f)),
        None => (key, None),
    };
    let lines: Vec<&str> = text.lines().collect();
    // TOML: `[section]`; JSON: `"section": {` (the last part of a dotted section).
    let last = section.rsplit('.').next().unwrap_or(section);
    let header = lines.iter().position(|l| {
        let t = l.trim();
        t == format!("[{section}]") || t.starts_with(&format!("\"{last}\""))
    })?;
    let Some(field) = field else {
        return Some(header + 1);
    };
    for (i, l) in lines.iter().enumerate().skip(header + 1) {
        let t = l.trim();
        if t.starts_with('[') && t.ends_with(']') {
            break;
        }
        let name = t
            .split(['=', ':'])
            .next()
            .unwrap_or("")
            .trim()
            .trim_matches('"');
        if name == field {
            return Some(i + 1);
        }
    }
    None
}

/// Comments printed above each section by [`Config::to_commented_toml`].
const SECTION_COMMENTS: &[(&str, &str)] = &[
    (
        "model",
        "# Motion model (the manifold): se3 (rotation + direction of travel + arc length),\n\
         # single_track_2d (yaw, arc length), single_track_3d (yaw, arc length, pitch, roll).\n\
         # With odometry.csv the arc length is fixed per frame.",
    ),
    (
        "metric",
        "# Residual metric: angle_plane (any camera; sine of the angle to the epipolar plane),\n\
         # angle_plane_ml (angle_plane over its pixel-noise std: ML weighting, any camera),\n\
         # geo_line (pinhole; pixel distance to the epipolar lines), sampson (pinhole).",
    ),
    (
        "loss",
        "# Robust loss on the squared residual: cauchy, huber, tukey, trivial.\n\
         # scale is in the metric's units: radians for angle_plane (0.001 ~ 0.7 px at f = 718 px),\n\
         # pixels for geo_line and sampson.",
    ),
    (
        "solver",
        "# Solver: levenberg_marquardt, gauss_newton, dogleg, with their options.",
    ),
    (
        "odometry",
        "# Odometry driver: degenerate frames, scale, restarts and the rotation prior\n\
         # (rotation_change_sigma: how much the rotation may change from one frame to the next,\n\
         # radians per frame, for every model; 0: none) and the centring of a soft model's prior\n\
         # (soft_prior_centring_frames: running mean over that many moving frames; 0: none;\n\
         # soft_prior_sigma_learning: its sigmas learnt from the same frames, at most\n\
         # soft_prior_sigma_max times the model's). standstill_at_rest: at a standstill the\n\
         # rotation is solved from no rotation, without restarts, on the matches that turn by\n\
         # less than standstill_still_angle radians (a standing vehicle does not turn), at most\n\
         # standstill_cell_cap times the median per image cell (a lead car holds many in a few\n\
         # cells), its covariance widened by their leave-one-cell-out jackknife\n\
         # (standstill_jackknife). road_scale_frames: without odometry.csv, one camera holds the\n\
         # median of the last N admitted arc lengths from the road plane (0: off);\n\
         # road_scale_metric: the separation takes it as metric, as odometry.csv's;\n\
         # road_scale_initial_metric: before the first one initial_arc_length is held as metric;\n\
         # road_scale_mount: a run over a whole sequence calibrates the mount first and gives\n\
         # its pitch to the road (road), runs with the corrected rig (rig), or not (nominal).\n\
         # noise_reference: the epipolar-angle noise (radians) the angular thresholds are\n\
         # stated for (1 px at f = 718 px); where the median noise of the last noise_frames\n\
         # estimated frames exceeds noise_band times it, they scale with it (0: off), once\n\
         # noise_start_frames frames are read;\n\
         # noise_final_fit: the final stage's noise clamp (final_fit.max_scale_ratio)\n\
         # scales with them.",
    ),
    (
        "odometry.final_fit",
        "# Final efficient stage: the noise sigma from the residuals (median absolute value),\n\
         # then a refit on the matches within inlier_sigmas sigmas with Cauchy at cauchy_sigmas\n\
         # sigmas (0: least squares) and the priors in units of sigma (prior_in_sigma);\n\
         # metric = \"angle_plane_ml\": refit with that registered metric (default: the first's).",
    ),
    (
        "odometry.separate",
        "# Motion separation (issue 14): a second motion fitted to the matches outside the\n\
         # first's support (threshold, radians) competes only where the match memory\n\
         # (memory_radius, pixels) follows its split from the previous frame pair\n\
         # (persistence, 0 to 1: an object persists, a static scene's noise tail does not;\n\
         # own_persistence where the second motion's own matches hold own_share of the frame);\n\
         # the choice by the ground support's spread (hypotheses), the final stage on the chosen\n\
         # support without the remembered-other matches (final_fit, memory_exclude);\n\
         # cell_cap: at most max(2, ceil(cell_cap x median)) matches per image cell\n\
         # (cell_cap_grid per camera) in the final stage and, with cell_cap_first, in a\n\
         # re-solve of the first motion, where that leaves out cell_cap_min_share of them;\n\
         # on a rig of several cameras the factor is cell_cap x cell_cap_rig_scale;\n\
         # under_road (one camera) / under_road_rig (several; 0: off): the final stage leaves\n\
         # out the matches below the horizon that lie beyond the road plane by this many\n\
         # sigmas of their parallax noise (under_road_noise, radians; needs odometry);\n\
         # under_road_guard: on one camera only after a frame without competition and under\n\
         # final_fit.neighbour_guard;\n\
         # ground_admit: a second motion failing the persistence test still competes if its\n\
         # ground score is at least ground_admit_min and ground_admit times the first's;\n\
         # memory_vote (0: off): where neither ground score is at least ground_admit_min and\n\
         # memory_vote_ground times the other, the alternative replaces the first motion if\n\
         # its support's remembered-static share exceeds the first's by memory_vote (each\n\
         # with memory_vote_min labelled matches, the alternative's own matches own_share).\n\
         # count_reference (0: off): in a frame with fewer matches (all cameras), the counts\n\
         # ground_admit_min, memory_vote_min and the hypotheses' min_matches and\n\
         # track_min_labelled scale with the frame's matches (rounded up, at least 1); the\n\
         # road guard's gate (whether the scene shows a road) keeps min_matches as written.\n\
         # second_soft_prior (0: off): the second motion is solved under the frame prior's\n\
         # learnt soft part (centre, sigmas) where a learnt centre of the residuals\n\
         # second_soft_prior_residuals is more than that many model sigmas from 0.\n\
         # yaw_votes (0: off): that many modes of the matches' one-point yaw votes (the\n\
         # previous motion turned by -yaw_votes_range..yaw_votes_range in yaw_votes_step,\n\
         # radians; informative matches only, yaw_votes_min votes) become alternatives.\n\
         # enabled = false: off. Fields this section omits keep the default's values; a\n\
         # [odometry.separate.hypotheses] section replaces the default's choice as a whole.",
    ),
    (
        "odometry.motion_prior_sigmas",
        "# Per-parameter motion prior: the standard deviation of a named model parameter's change\n\
         # from one frame to the next, e.g. arc_length = 0.1 (metres per frame). Empty: none.",
    ),
    (
        "five_point",
        "# The 5-point RANSAC baseline (`momo run --estimator five-point`), not used by momo.\n\
         # threshold in radians of angular Sampson error; refine = LO-RANSAC-style refinement\n\
         # (`--estimator five-point-refined` sets it).",
    ),
];

impl Config {
    /// Parses TOML or JSON (chosen by the extension `.json`, otherwise TOML) from a file.
    /// Files larger than [`MAX_CONFIG_BYTES`] are refused without reading them whole.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        use std::io::Read;
        let read_err = |error| ConfigError::Read {
            path: path.display().to_string(),
            error,
        };
        let file = std::fs::File::open(path).map_err(read_err)?;
        let mut bytes = Vec::new();
        file.take(MAX_CONFIG_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(read_err)?;
        if bytes.len() as u64 > MAX_CONFIG_BYTES {
            return Err(ConfigError::Invalid {
                path: path.display().to_string(),
                reason: format!(
                    "larger than {MAX_CONFIG_BYTES} bytes (a configuration is a few kB)"
                ),
            });
        }
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
        let text = String::from_utf8(bytes.to_vec()).map_err(|_| ConfigError::Invalid {
            path: path.display().to_string(),
            reason: "invalid UTF-8".into(),
        })?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let name = path.display().to_string();
        let config = if is_json {
            Self::from_json_str(&text, &name)?
        } else {
            Self::from_toml_str(&text, &name)?
        };
        Ok(config)
    }

    /// Parses a TOML configuration; `name` is used in messages.
    pub fn from_toml_str(text: &str, name: &str) -> Result<Self, ConfigError> {
        let mut config: Config = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
                .unwrap_or(1);
            ConfigError::Parse {
                path: name.into(),
                line,
                reason: e.message().trim().to_string(),
            }
        })?;
        config.origin = Origin {
            name: Some(name.into()),
            text: Some(text.into()),
        };
        config.validate(name)?;
        Ok(config)
    }

    /// Parses a JSON configuration; `name` is used in messages.
    pub fn from_json_str(text: &str, name: &str) -> Result<Self, ConfigError> {
        let mut config: Config = serde_json::from_str(text).map_err(|e| ConfigError::Parse {
            path: name.into(),
            line: e.line().max(1),
            reason: e.to_string(),
        })?;
        config.origin = Origin {
            name: Some(name.into()),
            text: Some(text.into()),
        };
        config.validate(name)?;
        Ok(config)
    }

    /// The name the configuration was read from (`<config>` if built in code).
    pub fn source_name(&self) -> &str {
        self.origin.name.as_deref().unwrap_or("<config>")
    }

    /// Checks value ranges that the types cannot express and parts that cannot work together
    /// (before the first frame). `name` names the source in errors; when the configuration was
    /// read from text, the error points at the line of the offending key (`file:line: reason`).
    pub fn validate(&self, name: &str) -> Result<(), ConfigError> {
        match self.problems().into_iter().next() {
            None => Ok(()),
            Some((keys, reason)) => Err(self.error_at(name, &keys, reason)),
        }
    }

    /// Checks that the configuration works with `rig` (e.g. a pixel metric that needs pinhole
    /// cameras), then [`validate`](Self::validate). Errors name [`source_name`](Self::source_name)
    /// and the line of the offending key.
    pub fn validate_for_rig(&self, rig: &Rig) -> Result<(), ConfigError> {
        let name = self.source_name().to_string();
        self.validate(&name)?;
        let manifold = self.model.manifold();
        let params = manifold.params();
        if let Some(unknown) = self
            .odometry
            .motion_prior_sigmas
            .keys()
            .find(|k| !params.contains(&k.as_str()))
        {
            let key = format!("odometry.motion_prior_sigmas.{unknown}");
            return Err(self.error_at(
                &name,
                &[&key, "odometry.motion_prior_sigmas"],
                format!(
                    "odometry.motion_prior_sigmas: the model has no parameter `{unknown}` (it \
                     has {})",
                    params.join(", ")
                ),
            ));
        }
        // A model without a soft prior ignores the conflict widening (and its residual list).
        let count = manifold.prior_residual_count();
        if let Some(bad) = self
            .odometry
            .soft_prior_conflict_residuals
            .iter()
            .find(|&&r| count > 0 && self.odometry.soft_prior_conflict_widening > 0.0 && r >= count)
        {
            return Err(self.error_at(
                &name,
                &["odometry.soft_prior_conflict_residuals"],
                format!(
                    "odometry.soft_prior_conflict_residuals: the model has {count} soft-prior \
                     residuals, no index {bad}"
                ),
            ));
        }
        if let Some(bad) = self
            .odometry
            .soft_prior_cauchy_residuals
            .iter()
            .find(|&&r| count > 0 && self.odometry.soft_prior_cauchy > 0.0 && r >= count)
        {
            return Err(self.error_at(
                &name,
                &["odometry.soft_prior_cauchy_residuals"],
                format!(
                    "odometry.soft_prior_cauchy_residuals: the model has {count} soft-prior \
                     residuals, no index {bad}"
                ),
            ));
        }
        if let Some(bad) = self
            .odometry
            .soft_prior_consistency_residuals
            .iter()
            .find(|&&r| count > 0 && self.odometry.soft_prior_consistency_frames > 0 && r >= count)
        {
            return Err(self.error_at(
                &name,
                &["odometry.soft_prior_consistency_residuals"],
                format!(
                    "odometry.soft_prior_consistency_residuals: the model has {count} soft-prior \
                     residuals, no index {bad}"
                ),
            ));
        }
        let metric = type_tag(&self.metric);
        if metric == "geo_line"
            && let Some((j, _)) = rig
                .cameras()
                .iter()
                .enumerate()
                .find(|(_, c)| c.model.as_pinhole().is_none())
        {
            return Err(self.error_at(
                &name,
                &["metric.type"],
                format!(
                    "metric `geo_line` measures pixel distances to epipolar lines and needs \
                     pinhole cameras, but camera {j} of the rig is not a pinhole; use \
                     `angle_plane` (any camera) or `sampson`"
                ),
            ));
        }
        Ok(())
    }

    /// An error at the line of the first of `keys` (`section.key`) found in the source text.
    fn error_at(&self, name: &str, keys: &[&str], reason: String) -> ConfigError {
        match self.origin.text.as_deref() {
            Some(text) => ConfigError::Parse {
                path: name.into(),
                line: keys
                    .iter()
                    .find_map(|k| line_of_key(text, k))
                    .or_else(|| {
                        keys.iter()
                            .find_map(|k| line_of_key(text, k.split('.').next().unwrap_or(k)))
                    })
                    .unwrap_or(1),
                reason,
            },
            None => ConfigError::Invalid {
                path: name.into(),
                reason,
            },
        }
    }

    /// Every problem found: the keys it concerns (the first one found in the text names the
    /// line) and the reason.
    fn problems(&self) -> Vec<(Vec<&'static str>, String)> {
        let mut out: Vec<(Vec<&'static str>, String)> = Vec::new();
        let mut bad = |keys: &[&'static str], reason: String| out.push((keys.to_vec(), reason));
        let o = &self.odometry;
        let metric = type_tag(&self.metric);
        // The loss scale is in the metric's units: radians for angle_plane, pixels otherwise.
        let (lo, hi, unit) = match metric.as_str() {
            "angle_plane" | "angle_plane_ml" => (1e-7, 0.5, "rad"),
            "geo_line" | "sampson" | "focal_scaled" => (1e-4, 1e3, "px"),
            _ => (1e-9, 1e6, "metric units"),
        };
        for (section, loss) in std::iter::once(("loss", &self.loss))
            .chain(self.refine_loss.as_ref().map(|l| ("refine_loss", l)))
        {
            let key: &'static str = if section == "loss" {
                "loss.scale"
            } else {
                "refine_loss.scale"
            };
            let ty: &'static str = if section == "loss" {
                "loss.type"
            } else {
                "refine_loss.type"
            };
            let scale = loss.scale();
            if type_tag(loss) == "trivial" {
                if section == "loss" && o.rotation_change_sigma > 0.0 {
                    bad(
                        &[ty, "odometry.rotation_change_sigma"],
                        format!(
                            "loss `trivial` has no scale, but the rotation prior \
                             (odometry.rotation_change_sigma = {}) is measured in units of the \
                             loss scale; use a robust loss (cauchy, huber, tukey) or set \
                             odometry.rotation_change_sigma = 0",
                            o.rotation_change_sigma
                        ),
                    );
                }
                continue;
            }
            if !(scale.is_finite() && scale >= lo && scale <= hi) {
                bad(
                    &[key, ty],
                    format!(
                        "{section} scale {scale} is outside the sane range {lo}..={hi} {unit} \
                         for metric `{metric}`"
                    ),
                );
            }
        }
        self.solver_problems(&mut bad);
        let finite_nonneg = |v: f64| v >= 0.0 && v.is_finite();
        if !(finite_nonneg(o.standstill_still_angle) && o.standstill_still_angle < 1.0) {
            bad(
                &["odometry.standstill_still_angle"],
                "odometry.standstill_still_angle must be a finite angle in 0..1 rad".into(),
            );
        }
        if !finite_nonneg(o.noise_reference) || o.noise_reference >= 1.0 {
            bad(
                &["odometry.noise_reference"],
                "odometry.noise_reference must be a finite angle in 0..1 rad (0: off)".into(),
            );
        }
        if !(o.noise_band.is_finite() && o.noise_band >= 1.0) {
            bad(
                &["odometry.noise_band"],
                "odometry.noise_band must be a finite ratio of at least 1".into(),
            );
        }
        if o.noise_frames == 0 {
            bad(
                &["odometry.noise_frames"],
                "odometry.noise_frames must be at least 1".into(),
            );
        }
        if o.noise_start_frames == 0 {
            bad(
                &["odometry.noise_start_frames"],
                "odometry.noise_start_frames must be at least 1".into(),
            );
        }
        if !finite_nonneg(o.standstill_cell_cap) {
            bad(
                &["odometry.standstill_cell_cap"],
                "odometry.standstill_cell_cap must be a finite factor >= 0 (0: off)".into(),
            );
        }
        if !(finite_nonneg(o.standstill_arc_length) && o.standstill_arc_length <= MAX_ARC_LENGTH) {
            bad(
                &["odometry.standstill_arc_length"],
                format!("odometry.standstill_arc_length must be within 0..={MAX_ARC_LENGTH} m"),
            );
        }
        if !(o.initial_arc_length > 0.0 && o.initial_arc_length <= MAX_ARC_LENGTH) {
            bad(
                &["odometry.initial_arc_length"],
                format!(
                    "odometry.initial_arc_length must be within (0, {MAX_ARC_LENGTH}] m per \
                     frame, got {}",
                    o.initial_arc_length
                ),
            );
        }
        if o.initial_arc_length <= o.standstill_arc_length {
            bad(
                &[
                    "odometry.initial_arc_length",
                    "odometry.standstill_arc_length",
                ],
                "odometry.initial_arc_length must be above odometry.standstill_arc_length \
                 (otherwise every frame without odometry is a standstill)"
                    .into(),
            );
        }
        if !(o.max_relative_scale_sigma > 0.0 && o.max_relative_scale_sigma.is_finite()) {
            bad(
                &["odometry.max_relative_scale_sigma"],
                "odometry.max_relative_scale_sigma must be finite and > 0".into(),
            );
        }
        if !(o.max_arc_length_ratio > 1.0 && o.max_arc_length_ratio.is_finite()) {
            bad(
                &["odometry.max_arc_length_ratio"],
                "odometry.max_arc_length_ratio must be finite and above 1".into(),
            );
        }
        if !(o.soft_prior_sigma_factor.is_finite() && o.soft_prior_sigma_factor > 0.0) {
            bad(
                &["odometry.soft_prior_sigma_factor"],
                format!(
                    "odometry.soft_prior_sigma_factor must be finite and > 0, got {}",
                    o.soft_prior_sigma_factor
                ),
            );
        }
        if !(o.soft_prior_student_nu.is_finite() && o.soft_prior_student_nu >= 0.0) {
            bad(
                &["odometry.soft_prior_student_nu"],
                format!(
                    "odometry.soft_prior_student_nu must be finite and at least 0, got {}",
                    o.soft_prior_student_nu
                ),
            );
        }
        if !(o.soft_prior_cauchy.is_finite() && o.soft_prior_cauchy >= 0.0) {
            bad(
                &["odometry.soft_prior_cauchy"],
                format!(
                    "odometry.soft_prior_cauchy must be finite and at least 0, got {}",
                    o.soft_prior_cauchy
                ),
            );
        }
        for (key, v) in [
            ("odometry.previous_basin_change", o.previous_basin_change),
            ("odometry.previous_basin_band", o.previous_basin_band),
            (
                "odometry.previous_basin_mono_change",
                o.previous_basin_mono_change,
            ),
            (
                "odometry.previous_basin_mono_band",
                o.previous_basin_mono_band,
            ),
            ("odometry.competing_region_band", o.competing_region_band),
            (
                "odometry.competing_region_yaw_ratio",
                o.competing_region_yaw_ratio,
            ),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                bad(
                    &[key],
                    format!("{key} must be finite and at least 0, got {v}"),
                );
            }
        }
        for (key, v) in [
            (
                "odometry.competing_region_concentration",
                o.competing_region_concentration,
            ),
            (
                "odometry.soft_prior_cauchy_taught_share",
                o.soft_prior_cauchy_taught_share,
            ),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                bad(&[key], format!("{key} must be within [0, 1], got {v}"));
            }
        }
        if !(o.soft_prior_arc_jitter.is_finite() && o.soft_prior_arc_jitter >= 0.0) {
            bad(
                &["odometry.soft_prior_arc_jitter"],
                format!(
                    "odometry.soft_prior_arc_jitter must be finite and at least 0, got {}",
                    o.soft_prior_arc_jitter
                ),
            );
        }
        if !(o.soft_prior_conflict_widening.is_finite() && o.soft_prior_conflict_widening >= 0.0) {
            bad(
                &["odometry.soft_prior_conflict_widening"],
                format!(
                    "odometry.soft_prior_conflict_widening must be finite and at least 0, got {}",
                    o.soft_prior_conflict_widening
                ),
            );
        }
        if !(o.soft_prior_consistency_limit.is_finite() && o.soft_prior_consistency_limit > 0.0) {
            bad(
                &["odometry.soft_prior_consistency_limit"],
                format!(
                    "odometry.soft_prior_consistency_limit must be finite and > 0, got {}",
                    o.soft_prior_consistency_limit
                ),
            );
        }
        if !(o.soft_prior_trend_z.is_finite() && o.soft_prior_trend_z > 0.0) {
            bad(
                &["odometry.soft_prior_trend_z"],
                format!(
                    "odometry.soft_prior_trend_z must be finite and > 0, got {}",
                    o.soft_prior_trend_z
                ),
            );
        }
        if !(o.soft_prior_sigma_max.is_finite() && o.soft_prior_sigma_max >= 1.0) {
            bad(
                &["odometry.soft_prior_sigma_max"],
                format!(
                    "odometry.soft_prior_sigma_max must be finite and at least 1, got {}",
                    o.soft_prior_sigma_max
                ),
            );
        }
        if !(o.decide_by_road_yaw_jump.is_finite() && o.decide_by_road_yaw_jump >= 0.0) {
            bad(
                &["odometry.decide_by_road_yaw_jump"],
                format!(
                    "odometry.decide_by_road_yaw_jump must be finite and non-negative, got {}",
                    o.decide_by_road_yaw_jump
                ),
            );
        }
        if !(o.decide_by_road_yaw_margin.is_finite() && o.decide_by_road_yaw_margin >= 0.0) {
            bad(
                &["odometry.decide_by_road_yaw_margin"],
                format!(
                    "odometry.decide_by_road_yaw_margin must be finite and non-negative, got {}",
                    o.decide_by_road_yaw_margin
                ),
            );
        }
        if !(0.0..=1.0).contains(&o.quiet_other_share) {
            bad(
                &["odometry.quiet_other_share"],
                format!(
                    "odometry.quiet_other_share must be within 0..=1, got {}",
                    o.quiet_other_share
                ),
            );
        }
        if !(0.0..=1.0).contains(&o.restart_inlier_ratio) {
            bad(
                &["odometry.restart_inlier_ratio"],
                "odometry.restart_inlier_ratio must be within 0..=1".into(),
            );
        }
        if o.restart_yaw_offsets
            .iter()
            .any(|v| !(v.is_finite() && v.abs() <= std::f64::consts::PI))
        {
            bad(
                &["odometry.restart_yaw_offsets"],
                "odometry.restart_yaw_offsets must be finite radians within -pi..=pi".into(),
            );
        }
        if let Some(Err(reason)) = o.separate.as_ref().map(|s| s.validate()) {
            bad(&["odometry.separate"], reason);
        }
        if let Err(reason) = o.final_fit.validate() {
            bad(&["odometry.final_fit"], reason);
        }
        // Every offset is one more solve per frame: 100,000 ran for minutes per frame.
        if o.restart_yaw_offsets.len() > MAX_RESTART_OFFSETS {
            bad(
                &["odometry.restart_yaw_offsets"],
                format!(
                    "odometry.restart_yaw_offsets has {} entries; at most {MAX_RESTART_OFFSETS}",
                    o.restart_yaw_offsets.len()
                ),
            );
        }
        if !finite_nonneg(o.tilt_hold_sigma) {
            bad(
                &["odometry.tilt_hold_sigma"],
                "odometry.tilt_hold_sigma must be finite and >= 0 (0: off)".into(),
            );
        }
        if !finite_nonneg(o.prior_min_arc_length) {
            bad(
                &["odometry.prior_min_arc_length"],
                "odometry.prior_min_arc_length must be finite and >= 0".into(),
            );
        }
        if !(0.0..=1.0).contains(&o.prior_min_inlier_ratio) {
            bad(
                &["odometry.prior_min_inlier_ratio"],
                "odometry.prior_min_inlier_ratio must be within 0..=1".into(),
            );
        }
        let sigma = o.rotation_change_sigma;
        if !(sigma == 0.0 || (MIN_PRIOR_SIGMA..=1.0).contains(&sigma)) {
            bad(
                &["odometry.rotation_change_sigma"],
                format!(
                    "odometry.rotation_change_sigma must be 0 (none) or within \
                     {MIN_PRIOR_SIGMA}..=1 rad per frame, got {sigma}"
                ),
            );
        }
        if let Some((name, s)) = o
            .motion_prior_sigmas
            .iter()
            .find(|(_, s)| !(MIN_PRIOR_SIGMA..=MAX_ARC_LENGTH).contains(*s))
        {
            bad(
                &["odometry.motion_prior_sigmas"],
                format!(
                    "odometry.motion_prior_sigmas.{name} must be within \
                     {MIN_PRIOR_SIGMA}..={MAX_ARC_LENGTH} (radians or metres per frame), got {s}"
                ),
            );
        }
        let f = &self.five_point;
        if !(f.threshold > 0.0 && f.threshold <= 0.5) {
            bad(
                &["five_point.threshold"],
                format!(
                    "five_point.threshold must be within (0, 0.5] rad of angular Sampson error, \
                     got {}",
                    f.threshold
                ),
            );
        }
        if !(f.confidence > 0.0 && f.confidence < 1.0) {
            bad(
                &["five_point.confidence"],
                "five_point.confidence must be within (0, 1)".into(),
            );
        }
        if !(1..=MAX_RANSAC_ITERATIONS).contains(&f.max_iterations) {
            bad(
                &["five_point.max_iterations"],
                format!(
                    "five_point.max_iterations must be within 1..={MAX_RANSAC_ITERATIONS}, got {}",
                    f.max_iterations
                ),
            );
        }
        for (keys, reason) in self.trust.problems() {
            bad(&keys, reason);
        }
        out
    }

    /// Solver options, whatever the solver: every number finite and >= 0,
    /// `max_iterations >= 1`, each `min_x <= max_x`, growth factors above 1.
    fn solver_problems(&self, bad: &mut impl FnMut(&[&'static str], String)) {
        let Ok(serde_json::Value::Object(map)) = serde_json::to_value(&self.solver) else {
            return;
        };
        // Keys must be `'static` for the line lookup: leak-free by matching known names.
        let key_of = |k: &str| -> &'static str {
            const KNOWN: &[&str] = &[
                "max_iterations",
                "function_tolerance",
                "gradient_tolerance",
                "parameter_tolerance",
                "initial_lambda",
                "lambda_increase",
                "lambda_decrease",
                "min_lambda",
                "max_lambda",
                "initial_radius",
                "max_radius",
                "min_radius",
            ];
            KNOWN
                .iter()
                .position(|n| *n == k)
                .map_or("solver", |i| SOLVER_KEYS[i])
        };
        for (k, v) in &map {
            let Some(x) = v.as_f64() else { continue };
            if !(x.is_finite() && x >= 0.0) {
                bad(
                    &[key_of(k), "solver"],
                    format!("solver.{k} must be finite and >= 0, got {v}"),
                );
            }
            if k == "max_iterations" && x < 1.0 {
                bad(
                    &[key_of(k), "solver"],
                    "solver.max_iterations must be at least 1 (0 would return the start as the \
                     answer)"
                        .into(),
                );
            }
            if k == "max_iterations" && x > MAX_SOLVER_ITERATIONS as f64 {
                bad(
                    &[key_of(k), "solver"],
                    format!(
                        "solver.max_iterations must be at most {MAX_SOLVER_ITERATIONS}, got {v}"
                    ),
                );
            }
            if (k.ends_with("_increase") || k.ends_with("_decrease")) && !(x > 1.0) {
                bad(
                    &[key_of(k), "solver"],
                    format!("solver.{k} must be above 1, got {v}"),
                );
            }
            if let Some(rest) = k.strip_prefix("min_")
                && let Some(hi) = map.get(&format!("max_{rest}")).and_then(|h| h.as_f64())
                && x > hi
            {
                bad(
                    &[key_of(k), "solver"],
                    format!("solver.{k} ({x}) must not exceed solver.max_{rest} ({hi})"),
                );
            }
        }
    }

    /// The configuration as TOML with a comment above each section.
    pub fn to_commented_toml(&self) -> String {
        let plain = toml::to_string(self).unwrap_or_else(|e| format!("# cannot serialise: {e}\n"));
        let mut out = String::from(
            "# momo estimator configuration (TOML). Pass it with `momo run --config FILE`.\n\
             # Every section is tagged by `type`; unknown fields are rejected.\n",
        );
        for line in plain.lines() {
            let header = line
                .trim()
                .strip_prefix('[')
                .and_then(|l| l.strip_suffix(']'));
            if let Some((_, comment)) =
                header.and_then(|h| SECTION_COMMENTS.iter().find(|(s, _)| *s == h))
            {
                out.push('\n');
                out.push_str(comment);
                out.push('\n');
            }
            out.push_str(line);
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod partial_tests {
    use super::Config;

    #[test]
    fn sections_left_out_take_their_defaults() {
        let c = Config::from_toml_str("[loss]\ntype = \"huber\"\nscale = 0.002\n", "p.toml")
            .expect("a partial configuration");
        let d = Config::default();
        let json = |v: &Config| serde_json::to_value(v).expect("serialisable");
        let (c, d) = (json(&c), json(&d));
        assert_eq!(c["loss"]["type"], "huber");
        assert_ne!(c["loss"], d["loss"]);
        for section in ["model", "metric", "solver", "odometry", "five_point"] {
            assert_eq!(c[section], d[section], "{section}");
        }
        let empty = Config::from_toml_str("", "e.toml").expect("empty configuration");
        assert_eq!(json(&empty), d);
        let e = Config::from_json_str("{\"metric\": {\"type\": \"sampson\"}}", "m.json")
            .expect("partial JSON");
        assert_eq!(json(&e)["metric"]["type"], "sampson");
        assert_eq!(json(&e)["model"], d["model"]);
    }

    #[test]
    fn a_partial_separate_section_keeps_competition_over_time() {
        use crate::separate::SeparateOptions;
        let c = Config::from_toml_str("[odometry.separate]\nthreshold = 0.002\n", "s.toml")
            .expect("a partial separate section");
        let s = c.odometry.separate.expect("the section is read");
        let expected = SeparateOptions {
            threshold: 0.002,
            ..SeparateOptions::competition_over_time()
        };
        assert_eq!(s, expected);
        assert_eq!(s.persistence, 0.4);
        assert!(s.final_fit && s.memory_exclude && s.memory_radius == 20.0);
        assert!(
            s.hypotheses()
                .is_some_and(|h| h.spread_grid == Some((16, 8)))
        );
        // Unknown keys are still refused, and the bare separation is reachable field by field.
        assert!(
            Config::from_toml_str("[odometry.separate]\npersistance = 0.4\n", "u.toml").is_err()
        );
        let bare = Config::from_toml_str(
            "[odometry.separate]\nfinal_robust = false\nfinal_fit = false\nmemory_radius = 0.0\n\
             memory_exclude = false\npersistence = 0.0\nown_share = 0.0\n\
             own_persistence = 0.0\ncell_cap = 0.0\ncell_cap_rig_scale = 1.0\ncell_cap_first = false\n\
             under_road = 0.0\nunder_road_rig = 0.0\n\
             ground_admit = 0.0\nmemory_vote = 0.0\nground_admit_own_share = 0.0\n\
             ground_drop = 0.0\ncandidate_by_road = false\ncount_reference = 0\n\
             second_soft_prior = 0.0\nyaw_votes = 0\n\
             [odometry.separate.hypotheses]\nenabled = false\n",
            "b.toml",
        )
        .expect("the bare separation");
        let bare = bare.odometry.separate.expect("the section is read");
        assert!(bare.hypotheses().is_none());
        let mut plain = bare.clone();
        plain.hypotheses = None;
        assert_eq!(plain, SeparateOptions::default());
    }
}
