//! The final efficient stage (issue 14): after each frame's robust solve, estimate the noise of
//! the static matches from their residuals and refit on them with a loss scaled to that noise.
//!
//! Why: the first stage's Cauchy scale `b` (0.001 rad by default) is chosen for robustness on
//! real data, not for the noise of the frame. Where the angular noise `σ` of a residual is
//! larger than `b` (a 0.5 px fisheye at f = 330 px, or 1 px at f = 718 px: `σ ≈ 0.002` rad),
//! Cauchy at `b ≈ σ / 2` down-weights most good matches and the estimate loses efficiency
//! (error median 1.3-1.6x the Cramér-Rao bound, docs/RESULTS.md §9).
//!
//! The stage, given the first stage's solution `p₀` and its residual norms `|r_i|`:
//! 1. **Noise**: `σ̂ = 1.4826 · median |r_i|` over the matches with `|r_i| < start_scales · b`
//!    (the first stage's inliers, widened: a large moving object, far from the static motion,
//!    is left out), then trimmed twice more at `inlier_sigmas · σ̂` (the median of a
//!    half-normal truncated at 3σ is 0.4 % below the untruncated one: not corrected). `σ̂` is
//!    clamped to `[min_scale_ratio · b, max_scale_ratio · b]`.
//! 2. **Support**: the matches with `|r_i| < inlier_sigmas · σ̂` whose point lies in front of
//!    both cameras under `p₀`, within `cheirality_sigmas · σ̂` of parallax ([`cheiral`]). Why
//!    the second test: a mismatch whose wrong pixel lands near its epipolar line has a small
//!    residual, but usually a large parallax (a near point, 3-4 deg against the inliers' 1 deg
//!    on the simulated `outliers` scenario), so a residual of up to 3 σ̂ moves the estimate
//!    far; about 5 such mismatches per frame pair (of 90) cost that scenario 20-30 % of
//!    efficiency, and half of them put their point behind a camera (docs/RESULTS.md §9, ninth
//!    session).
//! 3. **Refit** from `p₀` on the support alone, with Cauchy at `cauchy_sigmas · σ̂` (0: plain
//!    least squares, the maximum-likelihood estimate under Gaussian noise), the frame's motion
//!    prior in units of `σ̂` (`prior_in_sigma`: the priors then weigh as the data's own noise
//!    says, the maximum-likelihood weighting) or of `b`.
//!
//! The refit replaces the frame's solution (parameters, report, inliers = the support per
//! camera) only if it converged to finite numbers; otherwise the first stage's stays. With
//! `first_stage_covariance` (default) the reported covariance, cost and inliers stay the first
//! stage's (only the parameters are the refit's): the refit's own curvature on its trimmed
//! support was over-confident (rotation NEES, docs/RESULTS.md §9).

use momo_core::{
    FrameEstimator, FrameObservations, FrameSolution, MetricSpec, MotionPrior, RobustLoss,
    SolveRequest, Solver, Termination, TrivialLoss,
};
use serde::{Deserialize, Serialize};

/// `1 / Φ⁻¹(3/4)`: the standard deviation of a Gaussian over the median of its absolute value.
pub const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Fewest matches in the support for a refit (fewer: the first stage's solution stays).
pub const MIN_SUPPORT: usize = 8;

/// The default of [`FinalFitOptions::neighbour_guard`]: 0.1 deg in radians (forty-first
/// session, nbmono56: chosen on four sequences among 0.1, 0.2 and 0.4 deg; default since the
/// forty-second).
pub const NEIGHBOUR_GUARD_DEFAULT: f64 = 0.001_745_33;

/// Options of the final stage (`[odometry.final_fit]` in the TOML config).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FinalFitOptions {
    /// Run the stage (on by default).
    pub enabled: bool,
    /// The noise is first estimated on the matches within this many first-stage loss scales.
    pub start_scales: f64,
    /// The support: matches within this many estimated noise sigmas `σ̂`.
    pub inlier_sigmas: f64,
    /// Cauchy scale of the refit in units of `σ̂`; 0: plain least squares on the support. The
    /// default, 2.4 (Cauchy's 95 % asymptotic efficiency under Gaussian noise), keeps the real
    /// KITTI 00 medians (heavier tails than the simulator's) where plain least squares raised
    /// them by 2-7 % (docs/RESULTS.md §9).
    pub cauchy_sigmas: f64,
    /// Weigh the motion prior in units of `σ̂` (the data's noise) instead of the first stage's
    /// loss scale (but see `prior_min_scales`).
    pub prior_in_sigma: bool,
    /// With `prior_in_sigma`, the prior's unit is `max(σ̂, prior_min_scales · b)`: the refit
    /// may strengthen the priors where the data are noisier than the first stage's loss scale
    /// `b`, but not weaken them below the first stage's weighting. Default 1. Why: on real KITTI
    /// 00, `σ̂ ≈ 0.6 b` (the spread of the residuals), but the rotation prior's and the soft
    /// manifold's sigmas were chosen with the unit `b` and the matches carry errors the spread
    /// does not show (calibration, the ground truth's own); the unit `σ̂` made the priors 2.8x
    /// weaker than in the first stage and raised the stereo200 median by 3.8 % (docs/RESULTS.md
    /// §9, fifth session). 0: the unit is `σ̂` alone.
    pub prior_min_scales: f64,
    /// `σ̂` is at least this fraction of the first stage's loss scale (noise-free data).
    pub min_scale_ratio: f64,
    /// `σ̂` is at most this multiple of the first stage's loss scale.
    pub max_scale_ratio: f64,
    /// Report the first stage's covariance (its normal matrix, cost and inliers) with the
    /// refit's parameters, instead of the refit's curvature on its trimmed support (which is
    /// over-confident: it ignores the spread of the first stage's choice of support and the
    /// trimming). Default true.
    pub first_stage_covariance: bool,
    /// Passes of noise estimate, support and refit, each from the previous pass's solution
    /// (default 1).
    pub passes: usize,
    /// The support's cheirality test ([`cheiral`]): a match whose point lies behind either
    /// camera by more than this many `σ̂` of parallax (its displacement along the epipolar
    /// line points away from the epipole) is left out of the support, whatever its residual.
    /// 0: no test. Default 3 (the support's own cut): on 30 % mismatches it lowers the median
    /// error / Cramér-Rao bound from 1.18 to 0.96 on the built-in drive (seeds 1-8, per seed
    /// 0.85-1.00) and from 1.11-1.50 to 0.87-1.30 along the eleven KITTI trajectories (seed 1;
    /// 1.12-1.26 on 00, 02, 08 with seeds 2-3); clean data and real KITTI 00 hardly change
    /// (docs/RESULTS.md §9, ninth session).
    pub cheirality_sigmas: f64,
    /// The residual metric of the stage, by its registered type tag (e.g. `"angle_plane_ml"`,
    /// [`momo_core::register_metric!`]); none (the default): the metric the first stage's
    /// metric names for a final stage ([`MetricSpec::final_stage_metric`]: `angle_plane` names
    /// `angle_plane_ml`), else the first stage's metric itself. The
    /// noise `σ̂`, the support and the refit are all in this metric, so only the final stage
    /// pays for a costlier one. Its residuals must be in the first stage's units (the clamps
    /// and `start_scales` are in units of the first stage's loss scale `b`): `angle_plane_ml`
    /// after `angle_plane` (both radians).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub metric: Option<String>,
    /// The refit as a one-step estimator: one damped Gauss-Newton step from the first stage's
    /// solution (Levenberg-Marquardt with its default options and `max_linearizations = 1`:
    /// the start's linearisation and the step's cost; a step that does not decrease the cost
    /// falls back to linearised trials), instead of iterating the refit to convergence with
    /// the configured solver. Saves one linearisation of the stage's metric per frame; the
    /// poses move by the omitted steps. Default false (docs/RESULTS.md, "Speed", eleventh
    /// session).
    pub one_step: bool,
    /// The support leaves out a match whose parallax (the angle between its two rays under the
    /// first stage's rotation, [`parallax`]) exceeds this multiple of the median parallax of
    /// the support (after the residual and cheirality tests). A mismatch whose wrong pixel
    /// lands near its epipolar line in front of both cameras is a point at a wrong depth,
    /// usually near: a large parallax and with it a large leverage on the direction of
    /// travel. 0: no cap (the default).
    pub parallax_cap: f64,
    /// With `parallax_cap`: the median is each camera's own (over that camera's matches that
    /// pass the residual and cheirality tests; no cap in a camera with fewer than
    /// [`MIN_SUPPORT`] of them) instead of one over the rig. A side or rear camera of a rig
    /// sees parallaxes far from the front camera's, so one median over all cameras caps the
    /// wrong matches there. Default true.
    pub parallax_cap_per_camera: bool,
    /// With `parallax_cap`: the cap also acts on frames where two motions competed in the
    /// motion separation ([`crate::separate`]). Default false: there the support is the
    /// chosen motion's, and a moving object's near-zero parallaxes pull the median down
    /// (docs/RESULTS.md §9, thirteenth session: the cap cost the moving-traffic family).
    pub parallax_cap_competing: bool,
    /// With `parallax_cap`: the cap acts only where the residual and cheirality tests leave
    /// out at least this share of the frame's matches (0: always). The near mismatches that
    /// pass both tests are a share of all mismatches, so a frame without a tail outside the
    /// support has few of them, and a cap there only drops true matches with a large parallax
    /// (the near points of a wide-angle rig's side cameras). Default 0.1.
    pub parallax_cap_min_outside: f64,
    /// With `parallax_cap`: cap each match's baseline over distance
    /// ([`baseline_over_distance`], `sin θ / sin α`: the parallax `θ` over the sine of its ray's
    /// angle `α` to the direction of travel) instead of its parallax. A true point's parallax
    /// is `|t| sin α / λ₁`, so a wide-angle camera's rays near its epipole have a small one and
    /// those across it a large one at the same distance; the ratio is the point's inverse
    /// distance times the baseline whatever its direction. Default false.
    pub parallax_cap_inverse_distance: bool,
    /// A parallax cap learnt from the sequence's own mismatches (0: off; else the share `s`;
    /// 0.4 by default since the eighteenth session, docs/RESULTS.md §9, lead: static scenes
    /// along KITTI above 1.15 x the bound 5 -> 3 of 66, mean eff 1.0165 -> 1.0097, the
    /// moving-traffic grid's scores unchanged, real KITTI 00 byte-identical). Per camera, over
    /// the recent frames (counts decaying by [`PARALLAX_TALLY_DECAY`] per frame): `S_k`, the support's matches, and `B_k`, the matches
    /// of the band next to it (`inlier_sigmas · σ̂ <= |r| < 2 · inlier_sigmas · σ̂`, in front of
    /// both cameras), by half-octave bins `k` of the parallax over the support's median in that
    /// camera and frame ([`ParallaxTally`]). Mismatches near their epipolar line spread their
    /// residuals over the support and the band alike (a density about flat in `|r|` near 0,
    /// docs/RESULTS.md §9, eighteenth session), true matches hardly reach the band, so
    /// `B_k / S_k` estimates the share of mismatches among the support's matches of bin `k`.
    /// The support leaves out the matches from the lowest bin (at or above four times the
    /// median) whose tail (the bin and those above) has `Σ B >= s · Σ S`. Where a camera's
    /// true matches have large parallaxes (a wide-angle rig's side cameras) the band's share
    /// stays low and nothing is capped. Not
    /// on frames where two motions competed (as `parallax_cap_competing` is off).
    pub learnt_parallax_cap: f64,
    /// A Cauchy scale of the refit learnt from the recent frames' residual tails (0: off, the
    /// default; else the largest scale, in units of `σ̂`). Per frame, at the first stage's
    /// solution, the matches with `|r| < 2 σ̂` and those with `2 σ̂ <= |r| < 3 σ̂` are counted
    /// (decayed sums by [`PARALLAX_TALLY_DECAY`] per frame, [`ParallaxTally`]); their share
    /// `q = band / (core + band)` fixes the degrees of freedom `ν` of a Student-t noise model
    /// whose `σ̂` (this stage's trimmed MAD) and `q` match ([`learnt_cauchy_sigmas`]: Gaussian
    /// `q = 0.0435`, `ν = 6` `q = 0.0639`, `ν = 3` `q = 0.0773`), and the refit's Cauchy scale
    /// is that model's maximum-likelihood one, `c = √ν · s` (the Student-t's negative
    /// log-likelihood `(ν + 1)/2 · ln(1 + r² / (ν s²))` has the Cauchy weight `1 / (1 + r² /
    /// c²)`), clamped to `[cauchy_sigmas, learnt_cauchy_max] · σ̂`. Why: the fixed `cauchy_sigmas =
    /// 2.4` is the Student-t ML scale for `ν ≈ 6`, right for the real KITTI 00 residuals (`q =
    /// 0.075-0.083`: `ν ≈ 2.5-3.5`, clamped up to 2.4, the same refit) but not for the
    /// simulated Gaussian pixel noise (`q = 0.047-0.049`), where along the KITTI trajectories
    /// (whose direction of travel drifts off the soft prior) plain least squares lowers the
    /// error median by 3-5 %: Cauchy's weights (0.87 on average at 2.4 σ̂) weaken the data
    /// against the biased priors. Not on frames where two motions competed nor within
    /// [`CAUCHY_QUIET_FRAMES`] frames after one (their tails are an object's matches), and only
    /// after [`CAUCHY_TALLY_MIN`] counted matches (before: `cauchy_sigmas`). Measured with 6
    /// (docs/RESULTS.md §9, nineteenth session): the 66 static sequences along KITTI above
    /// 1.15 x the bound 5 -> 3, mean eff 1.0096 -> 0.9976 (43 better, 6 worse by up to 0.024),
    /// real KITTI 00 byte-identical, the moving-traffic grid 17 -> 17 frames above 1 deg and
    /// its hold-out 15 -> 16; off then for the six worse sequences. **6 by default since the
    /// twenty-first session**, with `learnt_never_after_flag` and the soft prior's consistency
    /// widening (`odometry.soft_prior_consistency_frames = 10`, stopped at the first flagged
    /// frame): the 66 static sequences above 1.15 x the bound 5 -> 2, mean eff 1.0096 -> 0.99,
    /// fresh static seeds 4-6 4 -> 0; the moving-traffic sets hold (docs/RESULTS.md §9,
    /// twenty-first session, static35 and lead).
    pub learnt_cauchy_max: f64,
    /// The refit's loss chosen by the recent frames' residual tails (0: off, the default; else
    /// the largest tail share `q_LS`): where the share `q = band / (core + band)` of the
    /// learnt Cauchy scale's counts (`learnt_cauchy_max`: the matches within `2 σ̂` and within
    /// `2-3 σ̂` of the first stage's solution, decayed by [`PARALLAX_TALLY_DECAY`] per frame,
    /// after [`CAUCHY_TALLY_MIN`] counted matches, not on frames where two motions competed
    /// nor within [`CAUCHY_QUIET_FRAMES`] after one) is at most `q_LS`, the refit is plain
    /// least squares; elsewhere its Cauchy loss (`cauchy_sigmas`, or the learnt scale).
    /// Least squares is the maximum-likelihood refit for Gaussian residuals (`q = 0.0435`);
    /// the default Cauchy scale 2.4 σ̂ is the Student-t one for `ν ≈ 6` (`q ≈ 0.064`,
    /// [`learnt_cauchy_sigmas`]), so a share below that says the tails are lighter than the
    /// loss assumes. The simulator's Gaussian pixels give `q = 0.047-0.049` (the residuals of
    /// matches of different depths and angles are a scale mixture, slightly heavier than one
    /// Gaussian), real KITTI 00 `q = 0.075-0.083`: a threshold between them keeps KITTI 00's
    /// refit as it is. The recent frames' counts rather than the frame's own: one frame's few
    /// hundred matches know `q` to about ±0.012 (`√(q (1 − q) / n)`), not enough to tell the
    /// two apart frame by frame. Plain least squares on every frame took the static scenes
    /// along KITTI from mean eff 1.0096 to 0.9953 but cost real KITTI 00 1.2-2.6 %
    /// (docs/RESULTS.md §9, nineteenth session).
    pub learnt_least_squares_share: f64,
    /// With `learnt_cauchy_max` or `learnt_least_squares_share`: the learnt loss stops for the
    /// rest of the sequence at the first frame flagged `weak` by `competing_motions` or
    /// `road_score_drop` ([`ParallaxTally::mark_flagged`]), on top of the wait after frames
    /// where two motions competed. Where the separation has once seen a second motion, a
    /// later quiet stretch is no evidence that no object is near, and estimates the learnt
    /// loss moves there change the separation's later choices (the moving-traffic hold-out's
    /// 08 s11 1 -> 2 frames above 1 deg with `learnt_cauchy_max = 6`; docs/RESULTS.md §9,
    /// twenty-first session). The static scenes along KITTI are never flagged. Default true
    /// since the twenty-first session (false before).
    pub learnt_never_after_flag: bool,
    /// The support's neighbourhood test ([`neighbour_kept`]; 0: off; default 0.375 since the
    /// twenty-eighth session on a rig of several cameras, since the forty-second on one camera
    /// too): a match of the support whose `neighbour_count` nearest matches of
    /// the same camera (first-image pixels, all the frame's matches) lie in the support less
    /// often than this share is left out, and the stage runs again on the rest. An object's
    /// matches cluster in the image; those whose flow happens to fit the static epipolar
    /// geometry pass the residual test while their neighbours on the same object do not
    /// (docs/RESULTS.md §9, twenty-eighth session, support42). Not applied where fewer than
    /// half of the matches the stage was given would remain, nor on a rig of fewer than
    /// `neighbour_min_cameras` cameras (by default 1: every rig).
    pub neighbour_share: f64,
    /// The neighbours counted by `neighbour_share` (default 8).
    pub neighbour_count: usize,
    /// The fewest cameras a rig needs for `neighbour_share` to apply (at least 1; default 1
    /// since the forty-second session, 2 before: a rig of several cameras). On one camera the
    /// test alone takes the mono moving-traffic family's median efficiency from 1.23-1.35 to
    /// 1.04-1.13 per set, but lets a car's motion hold on for a few more frames (frames above
    /// 1 deg 2 -> 16 over 600 sequences, 10 of them in one; forty-first session, nbmono56);
    /// with `neighbour_guard` at its default the frames above 1 deg are as many as without the
    /// test over 840 sequences (5 and 5) at median efficiencies 1.06-1.18 (docs/RESULTS.md §9,
    /// forty-second session, nbdef57).
    pub neighbour_min_cameras: usize,
    /// Where the neighbourhood test (or, on one camera, the guarded under-the-road test,
    /// `separate.under_road_guard`) changed the final stage's matches, the stage runs on the
    /// matches it was given too, and the frame keeps that run where the two motions' rotations
    /// differ by more than this angle (radians; 0: off; default 0.001745, 0.1 deg, since the
    /// forty-second session, 0 before). A test that took the
    /// static anchor of a region out lets a car's motion win the reduced stage; the guard
    /// keeps most of the test's gain on one camera (forty-first session, nbmono56:
    /// `neighbour_min_cameras = 1` with 0.001745, 0.1 deg: frames above 1 deg 16 -> 4 on the
    /// six mono 300-match sets, median efficiency 1.075-1.18; docs/RESULTS.md §9). Costs a
    /// second solve of the stage in every frame the test changed. Where it keeps that run, the
    /// given matches are the stage's for the re-admission too. On the surround-rig traffic
    /// sets (180 sequences) it changes the mean efficiency by at most 0.0007 and no frame
    /// above 1 deg (forty-second session, nbdef57).
    pub neighbour_guard: f64,
    /// With [`FinalFitOptions::neighbour_guard`]: the guard does not keep the given matches'
    /// stage where its tilt (roll and pitch, `(ω_x, ω_y)` of the vehicle-frame rotation) lies
    /// more than this angle from the trusted frames' running mean tilt (the one
    /// `odometry.tilt_hold_sigma` holds to, within `tilt_hold_frames` of the last trusted
    /// frame) while the reduced stage's lies within it (radians; 0: off; default 0.01 since the
    /// seventy-ninth session). A vehicle does not roll or pitch half a degree away from its
    /// recent trusted frames; the guard cannot tell which stage is right, the vehicle model
    /// can. On the five 1-px moving-traffic sets (600 sequences) frames above 1 deg stay 3 (one
    /// gone, one new at 1.02 deg, flagged) with lower error sums on every set; 2 px 304 -> 301,
    /// 3 px 149 -> 146; static scenes and real KITTI 00 unchanged (docs/RESULTS.md, seventy-ninth
    /// session).
    pub guard_tilt: f64,
    /// Re-admission on a rig of several cameras ([`readmit_kept`]; 0.5 by default since the
    /// twenty-ninth session, 0: off): after the final stage, a match that the separation's mask (or the neighbourhood test) did not
    /// hand to it is added where, at the stage's final motion, its residual is within
    /// `inlier_sigmas · σ̂` (`σ̂` of the matches the stage was given), its point is in front of
    /// both cameras ([`cheiral`]) and at least this share of its `readmit_count` nearest
    /// matches of the same camera (first-image pixels, all the frame's matches) pass the same
    /// test among the given ones (the converse of `neighbour_share`); the stage then runs once
    /// more, from the first stage's solution, on the given matches plus the re-admitted ones.
    /// The support on a surround rig in traffic leaves about a fifth of the static matches
    /// out; most never reach the stage (docs/RESULTS.md §9, twenty-ninth session, readmit43).
    /// One camera: no effect.
    pub readmit_share: f64,
    /// The neighbours counted by `readmit_share` (default 8).
    pub readmit_count: usize,
    /// With `readmit_share`: not on the frames whose motion prior has the Cauchy climb scales
    /// (`odometry.soft_prior_cauchy` and its gates: the rig's slow start before the soft prior
    /// has learnt), where the stage's final motion, whose support the re-admission widens, is
    /// the least certain (default true since the twenty-ninth session; false: on every frame).
    pub readmit_skip_cauchy: bool,
    /// The stage's `angle_plane_ml` with one reference focal length for the whole rig, the
    /// mean of its cameras' ([`momo_costs::AnglePlaneMlRig`], registered as
    /// `angle_plane_ml_rig`), instead of each camera's own. `angle_plane_ml` converts each
    /// camera's noise-normalised residual to radians with that camera's `√2 / fₚₓ`, so on a rig
    /// whose cameras differ in focal length the refit weighs camera `j` by `(f_ref / f_j)²`
    /// against the maximum-likelihood weights (`wide_angle_surround`: the double sphere
    /// cameras, fx = 300, 3.5 times the unified ones, fx = 560). Identical on a single camera
    /// and on a rig whose cameras share a focal length (every other scenario and KITTI), bit for
    /// bit. Acts only where the stage's metric resolves to `angle_plane_ml`. Default true
    /// since the twenty-seventh session (docs/RESULTS.md §9, twenty-seventh session, static41).
    pub ml_rig_reference: bool,
}

impl Default for FinalFitOptions {
    fn default() -> Self {
        Self {
            // On by default since the eighth session: with `first_stage_covariance` (the NEES
            // holds) and the maximum-likelihood metric `angle_plane_ml` after `angle_plane`
            // (`MetricSpec::final_stage_metric`) it lowers the error / Cramér-Rao bound on
            // every simulated scenario, on the built-in drive and along the eleven KITTI
            // trajectories, and keeps the real KITTI 00 medians within 2.2 % (docs/RESULTS.md
            // §9, eighth session). Off before: its own covariance was over-confident, and with
            // `angle_plane` alone stereo200 rose by 3.8 %.
            enabled: true,
            start_scales: 5.0,
            inlier_sigmas: 3.0,
            cauchy_sigmas: 2.4,
            prior_in_sigma: true,
            prior_min_scales: 1.0,
            min_scale_ratio: 0.1,
            max_scale_ratio: 5.0,
            first_stage_covariance: true,
            passes: 1,
            cheirality_sigmas: 3.0,
            metric: None,
            one_step: false,
            parallax_cap: 0.0,
            parallax_cap_per_camera: true,
            parallax_cap_competing: false,
            parallax_cap_min_outside: 0.1,
            parallax_cap_inverse_distance: false,
            learnt_parallax_cap: 0.4,
            // Since the twenty-first session (with `learnt_never_after_flag` and the soft
            // prior's consistency widening; docs/RESULTS.md §9, twenty-first session, lead).
            learnt_cauchy_max: 6.0,
            learnt_least_squares_share: 0.0,
            learnt_never_after_flag: true,
            // Since the twenty-eighth session (docs/RESULTS.md §9, twenty-eighth session,
            // support42 and lead): no effect on a single camera.
            neighbour_share: 0.375,
            neighbour_count: 8,
            neighbour_min_cameras: 1,
            neighbour_guard: NEIGHBOUR_GUARD_DEFAULT,
            guard_tilt: 0.01,
            // Since the twenty-ninth session (docs/RESULTS.md §9, twenty-ninth session,
            // readmit43 and lead): no effect on a single camera.
            readmit_share: 0.5,
            readmit_count: 8,
            readmit_skip_cauchy: true,
            // Since the twenty-seventh session (docs/RESULTS.md §9, twenty-seventh session,
            // static41 and lead): bit-identical wherever the cameras share a focal length.
            ml_rig_reference: true,
        }
    }
}

impl FinalFitOptions {
    /// The stage's own metric (`metric`), built through the registry; `Ok(None)` without one.
    /// Errors name the unknown type tag (and the registered ones).
    pub fn metric_spec(&self) -> Result<Option<Box<dyn MetricSpec>>, String> {
        let Some(name) = &self.metric else {
            return Ok(None);
        };
        serde_json::from_value::<Box<dyn MetricSpec>>(serde_json::json!({ "type": name }))
            .map(Some)
            .map_err(|e| format!("odometry.final_fit.metric: `{name}`: {e}"))
    }

    /// The stage's metric after a first stage with `first`: `metric` if set, else the one
    /// `first` names for its final stage ([`MetricSpec::final_stage_metric`]); `Ok(None)`:
    /// the first stage's metric itself.
    pub fn resolved_metric_spec(
        &self,
        first: &dyn MetricSpec,
    ) -> Result<Option<Box<dyn MetricSpec>>, String> {
        if self.metric.is_some() {
            return self.metric_spec();
        }
        let Some(name) = first.final_stage_metric() else {
            return Ok(None);
        };
        serde_json::from_value::<Box<dyn MetricSpec>>(serde_json::json!({ "type": name }))
            .map(Some)
            .map_err(|e| {
                format!("odometry.final_fit: the first stage's final-stage metric `{name}`: {e}")
            })
    }

    /// [`FinalFitOptions::resolved_metric_spec`] for a rig: with `ml_rig_reference`, a stage
    /// metric that resolves to `angle_plane_ml` becomes
    /// [`momo_costs::AnglePlaneMlRig::for_rig`] (the rig's mean focal length as its reference).
    pub fn resolved_metric_spec_for_rig(
        &self,
        first: &dyn MetricSpec,
        rig: &momo_core::Rig,
    ) -> Result<Option<Box<dyn MetricSpec>>, String> {
        let spec = self.resolved_metric_spec(first)?;
        let name = self.metric.as_deref().or(first.final_stage_metric());
        if !(self.ml_rig_reference && name == Some("angle_plane_ml")) {
            return Ok(spec);
        }
        Ok(match momo_costs::AnglePlaneMlRig::for_rig(rig) {
            Some(m) => Some(Box::new(m)),
            None => spec,
        })
    }

    /// Checks the options; the message names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        self.metric_spec()?;
        let positive = [
            ("start_scales", self.start_scales),
            ("inlier_sigmas", self.inlier_sigmas),
            ("min_scale_ratio", self.min_scale_ratio),
            ("max_scale_ratio", self.max_scale_ratio),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "odometry.final_fit.{name} must be a positive number, found {v}"
                ));
            }
        }
        if !(self.prior_min_scales.is_finite() && self.prior_min_scales >= 0.0) {
            return Err(format!(
                "odometry.final_fit.prior_min_scales must be a number >= 0, found {}",
                self.prior_min_scales
            ));
        }
        if self.passes == 0 {
            return Err("odometry.final_fit.passes must be at least 1".into());
        }
        if !(self.cheirality_sigmas.is_finite() && self.cheirality_sigmas >= 0.0) {
            return Err(format!(
                "odometry.final_fit.cheirality_sigmas must be a number >= 0, found {}",
                self.cheirality_sigmas
            ));
        }
        if !(self.parallax_cap.is_finite() && self.parallax_cap >= 0.0) {
            return Err(format!(
                "odometry.final_fit.parallax_cap must be a number >= 0, found {}",
                self.parallax_cap
            ));
        }
        if !(self.learnt_cauchy_max.is_finite() && self.learnt_cauchy_max >= 0.0) {
            return Err(format!(
                "odometry.final_fit.learnt_cauchy_max must be a number >= 0, found {}",
                self.learnt_cauchy_max
            ));
        }
        if !(0.0..1.0).contains(&self.learnt_least_squares_share) {
            return Err(format!(
                "odometry.final_fit.learnt_least_squares_share must be within [0, 1), found {}",
                self.learnt_least_squares_share
            ));
        }
        if !(self.learnt_parallax_cap.is_finite() && self.learnt_parallax_cap >= 0.0) {
            return Err(format!(
                "odometry.final_fit.learnt_parallax_cap must be a number >= 0, found {}",
                self.learnt_parallax_cap
            ));
        }
        if !(0.0..=1.0).contains(&self.parallax_cap_min_outside) {
            return Err(format!(
                "odometry.final_fit.parallax_cap_min_outside must be within [0, 1], found {}",
                self.parallax_cap_min_outside
            ));
        }
        if !(0.0..=1.0).contains(&self.neighbour_share) {
            return Err(format!(
                "odometry.final_fit.neighbour_share must be within [0, 1], found {}",
                self.neighbour_share
            ));
        }
        if self.neighbour_share > 0.0 && self.neighbour_count == 0 {
            return Err("odometry.final_fit.neighbour_count must be at least 1".into());
        }
        if self.neighbour_min_cameras == 0 {
            return Err("odometry.final_fit.neighbour_min_cameras must be at least 1".into());
        }
        if !(self.guard_tilt.is_finite() && self.guard_tilt >= 0.0) {
            return Err(format!(
                "odometry.final_fit.guard_tilt must be a finite angle >= 0, found {}",
                self.guard_tilt
            ));
        }
        if !(self.neighbour_guard.is_finite() && self.neighbour_guard >= 0.0) {
            return Err(format!(
                "odometry.final_fit.neighbour_guard must be a finite angle >= 0, found {}",
                self.neighbour_guard
            ));
        }
        if !(0.0..=1.0).contains(&self.readmit_share) {
            return Err(format!(
                "odometry.final_fit.readmit_share must be within [0, 1], found {}",
                self.readmit_share
            ));
        }
        if self.readmit_share > 0.0 && self.readmit_count == 0 {
            return Err("odometry.final_fit.readmit_count must be at least 1".into());
        }
        if !(self.cauchy_sigmas.is_finite() && self.cauchy_sigmas >= 0.0) {
            return Err(format!(
                "odometry.final_fit.cauchy_sigmas must be a number >= 0, found {}",
                self.cauchy_sigmas
            ));
        }
        if self.min_scale_ratio > self.max_scale_ratio {
            return Err(
                "odometry.final_fit.min_scale_ratio must not exceed max_scale_ratio".into(),
            );
        }
        Ok(())
    }
}

/// The median of `v` (reordered in place): the element of rank `len / 2` (the upper of the two
/// middle ones of an even count); `None` if empty.
pub(crate) fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m)
}

/// The noise `σ̂` of the residual norms `norms` (step 1 of the module doc) for a first-stage
/// loss scale `scale`; `None` if no residual lies within `start_scales · scale`.
///
/// The finite norms are sorted once; each of the three trimmed sets is then a prefix of them
/// (`r < cut`), whose median (the element of rank `len / 2`, as `median` selects it) is read
/// off directly: the same `σ̂` as selecting each set's median anew, for one sort.
pub fn estimate_sigma(norms: &[f64], scale: f64, opts: &FinalFitOptions) -> Option<f64> {
    let lo = opts.min_scale_ratio * scale;
    let hi = opts.max_scale_ratio * scale;
    let mut cut = opts.start_scales * scale;
    // Sorted by `f64::total_cmp` as the integers that order compares (issue 19: an integer
    // sort; the key is an involution of the bits, so the values come back unchanged).
    let mut keys: Vec<i64> = norms
        .iter()
        .filter(|r| r.is_finite())
        .map(|r| total_order_key(*r))
        .collect();
    keys.sort_unstable();
    let sorted: Vec<f64> = keys
        .iter()
        .map(|k| f64::from_bits(total_order_key_inverse(*k)))
        .collect();
    let mut sigma = None;
    for _ in 0..3 {
        let inside = &sorted[..sorted.partition_point(|r| *r < cut)];
        let m = *inside
            .get(inside.len() / 2)
            .filter(|_| !inside.is_empty())?;
        let s = (MAD_TO_SIGMA * m).clamp(lo, hi);
        sigma = Some(s);
        cut = opts.inlier_sigmas * s;
    }
    sigma
}

/// The integer whose order is `f64::total_cmp`'s on the bits of `x` (the transform the
/// standard library's `total_cmp` compares: negative values' magnitude bits flipped).
#[inline]
fn total_order_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ ((((b >> 63) as u64) >> 1) as i64)
}

/// The bits of the `f64` whose [`total_order_key`] is `k` (the transform is its own inverse:
/// it keeps the sign bit that selects it).
#[inline]
fn total_order_key_inverse(k: i64) -> u64 {
    (k ^ ((((k >> 63) as u64) >> 1) as i64)) as u64
}

/// Whether a match's point lies in front of both cameras, within `tolerance` (radians of
/// parallax), under the camera motion `c` (camera at k in camera at k-1: `X₀ = R X₁ + t`).
///
/// With `g = R f₁`, a point `λ₀ f₀ = t + λ₁ g` has `λ₀ (f₀ · u) = t · u` for `u` the unit vector
/// orthogonal to `g` in the plane of `g` and `t`, towards `t`, and `λ₁ (g · u') = −t · u'` for `u'`
/// orthogonal to `f₀` towards `t`; `t · u, t · u' ≥ 0`, so both depths are positive iff
/// `f₀ · u > 0` and `g · u' < 0`: seen from frame k-1 the point lies between its frame-k ray and
/// the epipole. Both are the parallax (the angle between `f₀` and `g`, projected on the
/// epipolar plane) with a sign; noise of `σ` per ray moves them by about `√2 σ`, so the test
/// is `f₀ · u > −tolerance` and `−g · u' > −tolerance`. A point at the epipole, or no
/// translation, passes (no parallax to test).
pub fn cheiral(
    c: &momo_core::Pose<f64>,
    f0: &nalgebra::Vector3<f64>,
    f1: &nalgebra::Vector3<f64>,
    tolerance: f64,
) -> bool {
    let t = c.translation;
    let tn = t.norm();
    if !(tn > 1e-12) {
        return true;
    }
    let t = t / tn;
    let g = c.rotation * f1;
    let toward = |from: &nalgebra::Vector3<f64>| {
        let u = t - from * t.dot(from);
        let n = u.norm();
        (n > 1e-12).then(|| u / n)
    };
    let (Some(u), Some(u1)) = (toward(&g), toward(f0)) else {
        return true;
    };
    f0.dot(&u) > -tolerance && -g.dot(&u1) > -tolerance
}

/// The parallax of a match under the camera motion `c`: the angle (radians) between its
/// frame-(k-1) ray `f₀` and its frame-k ray rotated into frame k-1, `R f₁`.
pub fn parallax(
    c: &momo_core::Pose<f64>,
    f0: &nalgebra::Vector3<f64>,
    f1: &nalgebra::Vector3<f64>,
) -> f64 {
    let g = c.rotation * f1;
    f0.cross(&g).norm().atan2(f0.dot(&g))
}

/// A match's baseline over its distance under the camera motion `c` (`X₀ = R X₁ + t`): by the
/// sine rule in the triangle of the two camera centres and the point, `|t| / λ₁ = sin θ / sin α`
/// with `θ` the parallax ([`parallax`]) and `α` the angle between the frame-(k-1) ray `f₀` and
/// `t`. `sin α` is floored at [`MIN_EPIPOLE_SINE`] (a ray at the epipole has no parallax to
/// measure, only noise); 0 without translation.
pub fn baseline_over_distance(
    c: &momo_core::Pose<f64>,
    f0: &nalgebra::Vector3<f64>,
    f1: &nalgebra::Vector3<f64>,
) -> f64 {
    let t = c.translation;
    let (tn, f0n) = (t.norm(), f0.norm());
    if !(tn > 1e-12 && f0n > 0.0) {
        return 0.0;
    }
    let sin_alpha = f0.cross(&t).norm() / (f0n * tn);
    parallax(c, f0, f1).sin().abs() / sin_alpha.max(MIN_EPIPOLE_SINE)
}

/// The floor of `sin α` in [`baseline_over_distance`] (about 0.6 deg from the epipole).
pub const MIN_EPIPOLE_SINE: f64 = 0.01;

/// Decay per frame of [`ParallaxTally`]'s counts (a memory of about 100 frames).
pub const PARALLAX_TALLY_DECAY: f64 = 0.99;
/// Half-octave bins of [`ParallaxTally`], from four times the support's median parallax (the
/// inliers' 99 % quantile on the simulated KITTI-like scenes, 4.3x); the last holds everything
/// from `2^8.5` times the median up.
pub const PARALLAX_TALLY_BINS: usize = 14;
/// Fewest (decayed) support matches in a tail of [`ParallaxTally`]'s bins for its share to
/// count (also a warm-up: no cap before the recent frames have seen that many).
pub const PARALLAX_TALLY_MIN: f64 = 20.0;

/// The counts of the learnt parallax cap (`learnt_parallax_cap`): per camera and half-octave
/// bin `k` of the parallax `θ` over the support's median `m` (`2^(2 + k/2) <= θ / m <
/// 2^(2 + (k+1)/2)`; below `4 m` no bin), the support's matches `S_k` and the band's `B_k`
/// (within one to two `inlier_sigmas · σ̂`, in front of both cameras). One frame's counts, or
/// the decayed sums over the recent frames ([`ParallaxTally::add`]).
///
/// With `learnt_cauchy_max` it also holds the residual-tail counts of the learnt Cauchy scale:
/// the matches within `2 σ̂` and those within `2-3 σ̂` of the first stage's solution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParallaxTally {
    /// Per camera, per bin: (support, band).
    per_camera: Vec<[(f64, f64); PARALLAX_TALLY_BINS]>,
    /// All cameras: (matches with `|r| < 2 σ̂`, matches with `2 σ̂ <= |r| < 3 σ̂`).
    tail: (f64, f64),
    /// Frames where two motions competed (decayed): the learnt Cauchy scale waits
    /// [`CAUCHY_QUIET_FRAMES`] frames after one.
    competing: f64,
    /// A frame flagged `competing_motions` / `road_score_drop` has occurred
    /// (`learnt_never_after_flag`).
    flagged: bool,
}

/// The learnt Cauchy scale (`learnt_cauchy_max`) acts only where no frame of the last this
/// many had two competing motions (the decayed count of such frames below
/// `PARALLAX_TALLY_DECAY^CAUCHY_QUIET_FRAMES`; at exactly that many frames the rounding of
/// the decayed sum decides): next to a moving object the support's tails
/// are the object's matches, not the noise's, and a wider scale lets them pull.
pub const CAUCHY_QUIET_FRAMES: i32 = 100;

/// Fewest (decayed) matches within `3 σ̂` in [`ParallaxTally`]'s residual-tail counts for the
/// learnt Cauchy scale (`learnt_cauchy_max`) to act: about ten frames of 200 matches, so that
/// the share `q` is known to about ±0.005 (a standard deviation `√(q (1 − q) / n)`).
pub const CAUCHY_TALLY_MIN: f64 = 2000.0;

/// `(q, c)` pairs of the Student-t noise model behind [`learnt_cauchy_sigmas`], by degrees of
/// freedom `ν` = 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10, 12, 15, 20, 30, 50, 100 (`q` falling): for a
/// Student-t of unit scale, `σ̂` is the final stage's estimator in the limit of many matches
/// (`1.4826 · MAD`, then twice `1.4826 ·` the median of `|r| < 3 σ̂`), `q = (F(3σ̂) − F(2σ̂)) /
/// F(3σ̂)` (`F` the CDF of `|r|`, Simpson's rule on 4000 intervals) and `c = √ν / σ̂` the
/// maximum-likelihood Cauchy scale in units of `σ̂`. The Gaussian limit (`ν → ∞`) is `q =
/// 0.04354`, `c = ∞`.
const STUDENT_TAIL: [(f64, f64); 15] = [
    (0.09307, 1.112),
    (0.08647, 1.303),
    (0.08133, 1.472),
    (0.07725, 1.626),
    (0.07122, 1.900),
    (0.06699, 2.142),
    (0.06387, 2.361),
    (0.05958, 2.750),
    (0.05678, 3.091),
    (0.05481, 3.400),
    (0.05275, 3.816),
    (0.05059, 4.425),
    (0.04834, 5.444),
    (0.04647, 7.054),
    (0.04503, 10.004),
];

/// The Gaussian limit of [`STUDENT_TAIL`]'s `q`.
const GAUSSIAN_TAIL: f64 = 0.04354;

/// The maximum-likelihood Cauchy scale, in units of `σ̂`, of the Student-t noise whose share of
/// residuals within `2-3 σ̂` among those within `3 σ̂` is `q` ([`STUDENT_TAIL`], `1 / c`
/// interpolated linearly in `q`; infinity at or below the Gaussian's share, the heaviest
/// tabulated tail's scale above it).
pub fn learnt_cauchy_sigmas(q: f64) -> f64 {
    if !(q > GAUSSIAN_TAIL) {
        return f64::INFINITY;
    }
    let mut prev = (GAUSSIAN_TAIL, f64::INFINITY);
    for &(qk, ck) in STUDENT_TAIL.iter().rev() {
        if q <= qk {
            let t = (q - prev.0) / (qk - prev.0);
            let inv = (1.0 - t) / prev.1 + t / ck;
            return 1.0 / inv;
        }
        prev = (qk, ck);
    }
    STUDENT_TAIL[0].1
}

impl ParallaxTally {
    /// The bin of a parallax `rel` times the median; `None` below four times the median (or
    /// NaN).
    fn bin(rel: f64) -> Option<usize> {
        if !(rel >= 4.0) {
            return None;
        }
        let k = (2.0 * rel.log2()).floor() - 4.0;
        Some((k.max(0.0) as usize).min(PARALLAX_TALLY_BINS - 1))
    }

    /// Counts one match of camera `camera` at `rel` times the median: in the support
    /// (`support`) or the band.
    fn count(&mut self, camera: usize, rel: f64, support: bool) {
        let Some(k) = Self::bin(rel) else {
            return;
        };
        if self.per_camera.len() <= camera {
            self.per_camera
                .resize(camera + 1, [(0.0, 0.0); PARALLAX_TALLY_BINS]);
        }
        let c = &mut self.per_camera[camera][k];
        if support {
            c.0 += 1.0;
        } else {
            c.1 += 1.0;
        }
    }

    /// The cap of camera `camera` in units of its support's median parallax: the lower edge
    /// `2^(2 + k/2)` of the lowest bin `k` whose tail (bins `k` and up) has `Σ S >=
    /// PARALLAX_TALLY_MIN` and `Σ B >= share · Σ S` (an empty bin right below a qualifying tail
    /// qualifies too: the same sums); infinity where there is none.
    pub fn limit(&self, camera: usize, share: f64) -> f64 {
        let Some(bins) = self.per_camera.get(camera) else {
            return f64::INFINITY;
        };
        // The tails' sums, from the top bin down.
        let (mut s, mut b) = (0.0, 0.0);
        let mut lowest = None;
        for (k, (sk, bk)) in bins.iter().enumerate().rev() {
            s += sk;
            b += bk;
            if s >= PARALLAX_TALLY_MIN && b >= share * s {
                lowest = Some(k);
            }
        }
        lowest.map_or(f64::INFINITY, |k| 2f64.powf(2.0 + k as f64 / 2.0))
    }

    /// The learnt Cauchy scale (`learnt_cauchy_max`) in units of `σ̂`: the residual-tail
    /// share's [`learnt_cauchy_sigmas`] clamped to `[min, max]`; `None` before
    /// [`CAUCHY_TALLY_MIN`] matches are counted.
    pub fn cauchy_sigmas(&self, min: f64, max: f64) -> Option<f64> {
        self.tail_share()
            .map(|q| learnt_cauchy_sigmas(q).clamp(min, max.max(min)))
    }

    /// The residual-tail share `q = band / (core + band)` of the recent frames (the matches
    /// within `2-3 σ̂` among those within `3 σ̂`); `None` before [`CAUCHY_TALLY_MIN`] matches
    /// are counted and within [`CAUCHY_QUIET_FRAMES`] frames after one where two motions
    /// competed.
    pub fn tail_share(&self) -> Option<f64> {
        let (core, band) = self.tail;
        if !(core + band >= CAUCHY_TALLY_MIN)
            || self.competing >= PARALLAX_TALLY_DECAY.powi(CAUCHY_QUIET_FRAMES)
        {
            return None;
        }
        Some(band / (core + band))
    }

    /// Marks that a frame was flagged `weak` by `competing_motions` or `road_score_drop`: with
    /// `learnt_never_after_flag` the learnt loss stops from here on.
    pub fn mark_flagged(&mut self) {
        self.flagged = true;
    }

    /// Whether [`ParallaxTally::mark_flagged`] was called.
    pub fn flagged(&self) -> bool {
        self.flagged
    }

    /// Decays the sums by [`PARALLAX_TALLY_DECAY`] and adds a frame's counts.
    pub fn add(&mut self, frame: &ParallaxTally) {
        self.tail.0 = PARALLAX_TALLY_DECAY * self.tail.0 + frame.tail.0;
        self.tail.1 = PARALLAX_TALLY_DECAY * self.tail.1 + frame.tail.1;
        self.competing = PARALLAX_TALLY_DECAY * self.competing + frame.competing;
        if frame.competing > 0.0 {
            // A frame where two motions competed counts for the learnt Cauchy scale's wait
            // only: the learnt parallax cap's counts skip it (as without that scale).
            return;
        }
        if self.per_camera.len() < frame.per_camera.len() {
            self.per_camera
                .resize(frame.per_camera.len(), [(0.0, 0.0); PARALLAX_TALLY_BINS]);
        }
        for (j, bins) in self.per_camera.iter_mut().enumerate() {
            for (k, c) in bins.iter_mut().enumerate() {
                let (s, b) = frame.per_camera.get(j).map_or((0.0, 0.0), |f| f[k]);
                c.0 = PARALLAX_TALLY_DECAY * c.0 + s;
                c.1 = PARALLAX_TALLY_DECAY * c.1 + b;
            }
        }
    }
}

/// What the final stage needs besides the matches and the first stage's solution.
pub struct FinalFitContext<'a> {
    /// The rig.
    pub rig: &'a momo_core::Rig,
    /// The frame estimator of the stage (the model with the stage's metric).
    pub estimator: &'a dyn FrameEstimator,
    /// The first stage's loss (its scale `b` is the unit of the clamps).
    pub loss: &'a dyn RobustLoss,
    /// The solver.
    pub solver: &'a dyn Solver,
    /// Fixed parameters (e.g. the odometry arc length).
    pub fixed: &'a [bool],
    /// The frame's motion prior.
    pub motion_prior: &'a MotionPrior,
    /// Two motions competed in this frame's motion separation (`parallax_cap_competing`).
    pub competing: bool,
    /// The recent frames' counts of the learnt parallax cap (`learnt_parallax_cap`); `None`:
    /// no learnt cap.
    pub tally: Option<&'a ParallaxTally>,
    /// The stage metric's per-match constants of the matches the stage is given
    /// ([`frame_constants`], or those of a subset's kept matches in order), where the caller
    /// has them already (issue 19: computed once per frame); `None`: computed here.
    pub constants: Option<&'a [f64]>,
    /// The stage's support found earlier in the frame on the same matches ([`support_at`]):
    /// the first pass reuses it where it starts from the same parameters (bit for bit) and
    /// `competing` is the same (issue 19; the support is a function of the matches, the
    /// parameters, the options and the counts of the learnt cap alone). `None`: found here.
    pub stage: Option<&'a StageSupport>,
}

/// The stage's support at a point ([`support_at`]), with the point it was found at.
#[derive(Clone, Debug)]
pub struct StageSupport {
    /// The parameters it was found at.
    from: Vec<f64>,
    /// [`FinalFitContext::competing`] when it was found.
    competing: bool,
    /// [`stage_support`]'s result.
    found: Option<Kept>,
}

/// [`stage_support`]'s result: the matches kept, their constants, `σ̂`, the learnt cap's counts,
/// and the kept matches' membership among the given ones (per camera, per match).
type Kept = (
    FrameObservations,
    Vec<f64>,
    f64,
    Option<ParallaxTally>,
    Vec<Vec<bool>>,
);

impl StageSupport {
    /// The matches kept ([`support`]); `None` where the stage would not refit.
    pub fn core(&self) -> Option<&FrameObservations> {
        self.found.as_ref().map(|k| &k.0)
    }
}

/// The stage metric's per-match constants of `obs` ([`FrameEstimator::match_constants`]: a
/// function of each match and its camera alone, not of `from`).
pub fn frame_constants(
    ctx: &FinalFitContext<'_>,
    obs: &FrameObservations,
    from: &[f64],
) -> Vec<f64> {
    ctx.estimator.match_constants(&ctx.request(obs, from))
}

/// The parallax cap (`parallax_cap`) over the matches `passing` (membership, parallax):
/// `cap` times the median parallax of the members; no cap (infinity) with fewer than `min`
/// members.
fn parallax_limit<'a>(passing: impl Iterator<Item = &'a (bool, f64)>, cap: f64, min: usize) -> f64 {
    let mut kept: Vec<f64> = passing.filter(|(ok, _)| *ok).map(|(_, p)| *p).collect();
    if kept.len() < min {
        return f64::INFINITY;
    }
    median(&mut kept).map_or(f64::INFINITY, |m| cap * m)
}

/// The final stage (module doc): the refit solution, or `first` unchanged where the noise
/// cannot be estimated, the support is too small or the refit fails. With `passes` > 1 the
/// noise, support and refit are repeated from the previous pass's solution (its residuals are
/// those of an efficient fit, not of the first stage's robust one).
pub fn refit(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    first: FrameSolution,
) -> FrameSolution {
    refit_tallied(ctx, opts, obs, first).0
}

/// [`refit`], and the frame's counts of the learnt parallax cap (`learnt_parallax_cap`; at the
/// first pass's support; `None` where it is off, on a frame where two motions competed, or
/// where the stage did not refit) for the caller to add to its [`ParallaxTally`].
pub fn refit_tallied(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    first: FrameSolution,
) -> (FrameSolution, Option<ParallaxTally>) {
    let (fin, tally, _) = refit_supported(ctx, opts, obs, first);
    (fin, tally)
}

/// The stage's support membership: per camera, per match of the matches the stage was given,
/// whether the (last) refit used it; `None` where the stage did not refit.
pub type SupportMask = Option<Vec<Vec<bool>>>;

/// [`refit_tallied`], and the support of the last pass that refit ([`SupportMask`]: the
/// matches within `inlier_sigmas · σ̂` under the caps, steps 1 and 2 of the module doc), for
/// `odometry.report_support`.
pub fn refit_supported(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    first: FrameSolution,
) -> (FrameSolution, Option<ParallaxTally>, SupportMask) {
    // The stage metric's per-match constants of every match, computed once for every pass:
    // the residual norms on all matches and each refit on its support read them.
    let owned;
    let constants = match ctx.constants {
        Some(c) => c,
        None => {
            owned = frame_constants(ctx, obs, &first.params);
            &owned[..]
        }
    };
    let mut best: Option<FrameSolution> = None;
    let mut tally = None;
    let mut mask = None;
    for _ in 0..opts.passes.max(1) {
        let from = best.as_ref().map_or(&first.params, |b| &b.params);
        match refit_once(ctx, opts, obs, constants, from) {
            Some((mut fin, support, frame_tally, kept)) => {
                if best.is_none() {
                    tally = frame_tally;
                }
                mask = Some(kept);
                fin.report.iterations += best
                    .as_ref()
                    .map_or(first.report.iterations, |b| b.report.iterations);
                fin.inliers_per_camera = support;
                best = Some(fin);
            }
            None => break,
        }
    }
    let Some(mut fin) = best else {
        return (first, None, None);
    };
    if opts.first_stage_covariance {
        // The covariance (and the inlier count and mask, which index all matches) of the
        // first stage: see `FinalFitOptions::first_stage_covariance`.
        fin.refit_curvature = Some((
            fin.report.normal_matrix,
            fin.report.final_cost,
            fin.inliers(),
        ));
        fin.report.normal_matrix = first.report.normal_matrix;
        fin.report.final_cost = first.report.final_cost;
        fin.inliers_per_camera = first.inliers_per_camera;
        fin.inlier_mask = first.inlier_mask;
    }
    (fin, tally, mask)
}

impl<'a> FinalFitContext<'a> {
    /// The request of the first stage's loss and prior on `obs`, from `from`.
    fn request<'b>(&'b self, obs: &'b FrameObservations, from: &'b [f64]) -> SolveRequest<'b> {
        SolveRequest {
            rig: self.rig,
            observations: obs,
            loss: self.loss,
            solver: self.solver,
            initial: from,
            fixed: self.fixed,
            rotation_only: false,
            motion_prior: Some(self.motion_prior),
        }
    }
}

/// [`refit_once`]'s result: the refit solution, its support size per camera, the learnt cap's
/// counts and the support's membership among the given matches.
type Pass = (
    FrameSolution,
    Vec<usize>,
    Option<ParallaxTally>,
    Vec<Vec<bool>>,
);

/// One pass of the stage from the parameters `from`: the refit solution, its support size
/// per camera, the learnt cap's counts and the support's membership among `obs`, or `None`
/// (noise not estimable, support too small, refit failed). `constants`:
/// the stage metric's per-match constants of `obs` ([`FrameEstimator::match_constants`]; empty:
/// each problem computes its own).
fn refit_once(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    constants: &[f64],
    from: &[f64],
) -> Option<Pass> {
    let scale = ctx.loss.scale();
    // The support found at the start is read in place (no copy of its matches and constants).
    let found;
    let (core, core_constants, sigma, tally, kept) = match ctx
        .stage
        .filter(|s| s.competing == ctx.competing && s.from == from)
    {
        Some(s) => {
            let (core, constants, sigma, tally, kept) = s.found.as_ref()?;
            (core, &constants[..], *sigma, tally.clone(), kept)
        }
        None => {
            let (core, constants, sigma, tally, kept) =
                stage_support(ctx, opts, obs, constants, from)?;
            found = (core, constants, kept);
            (&found.0, &found.1[..], sigma, tally, &found.2)
        }
    };
    let req = ctx.request(obs, from);
    let cauchy;
    // The learnt scale (`learnt_cauchy_max`) from the recent frames' residual tails.
    let stopped = |t: &ParallaxTally| opts.learnt_never_after_flag && t.flagged();
    let learnt = match ctx.tally {
        Some(t) if opts.learnt_cauchy_max > 0.0 && !ctx.competing && !stopped(t) => {
            t.cauchy_sigmas(opts.cauchy_sigmas, opts.learnt_cauchy_max)
        }
        _ => None,
    };
    // The loss chosen by the recent residual tails (`learnt_least_squares_share`).
    let gaussian = match ctx.tally {
        Some(t) if opts.learnt_least_squares_share > 0.0 && !ctx.competing && !stopped(t) => t
            .tail_share()
            .is_some_and(|q| q <= opts.learnt_least_squares_share),
        _ => false,
    };
    let loss: &dyn RobustLoss = if opts.cauchy_sigmas > 0.0 && !gaussian {
        cauchy = momo_costs::Cauchy::new(learnt.unwrap_or(opts.cauchy_sigmas) * sigma);
        &cauchy
    } else {
        &TrivialLoss
    };
    let mut prior = ctx.motion_prior.clone();
    prior.scale = if opts.prior_in_sigma {
        // The first stage's weighting of the priors relative to its loss scale carries over:
        // a weak frame's priors (`trust.weak_prior_factor`) stay weak in the refit.
        let relative = if prior.scale > 0.0 {
            prior.scale / scale
        } else {
            1.0
        };
        sigma.max(opts.prior_min_scales * scale) * relative
    } else if prior.scale > 0.0 {
        prior.scale
    } else {
        scale
    };
    let one_step;
    let solver: &dyn Solver = if opts.one_step {
        one_step = momo_solvers::LevenbergMarquardt::default().with_max_linearizations(1);
        &one_step
    } else {
        ctx.solver
    };
    let req = SolveRequest {
        observations: core,
        loss,
        motion_prior: Some(&prior),
        solver,
        ..req
    };
    match ctx.estimator.solve_with_constants(&req, core_constants) {
        Ok(fin)
            if fin.report.termination != Termination::NumericalFailure
                && fin.params.iter().all(|p| p.is_finite())
                && fin.report.final_cost.is_finite() =>
        {
            let support = core.per_camera.iter().map(Vec::len).collect();
            Some((fin, support, tally, kept.clone()))
        }
        _ => None,
    }
}

/// The final stage's support (steps 1 and 2 of the module doc, with the parallax caps) at the
/// parameters `from`: the matches kept, their per-match constants (empty where `constants`
/// does not cover `obs`), the noise `σ̂` and, with `learnt_parallax_cap`, the frame's counts
/// for [`ParallaxTally`] (before its cap); `None` where the noise cannot be estimated or
/// fewer than [`MIN_SUPPORT`] matches are kept. Also the kept matches' membership among `obs`.
fn stage_support(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    constants: &[f64],
    from: &[f64],
) -> Option<Kept> {
    let scale = ctx.loss.scale();
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let req = ctx.request(obs, from);
    let norms = ctx
        .estimator
        .residual_norms_with_constants(&req, from, constants)
        .ok()?;
    if norms.len() != obs.per_camera.len()
        || norms
            .iter()
            .zip(&obs.per_camera)
            .any(|(n, o)| n.len() != o.len())
    {
        return None;
    }
    let all: Vec<f64> = norms.iter().flatten().copied().collect();
    let sigma = estimate_sigma(&all, scale, opts)?;
    let cut = opts.inlier_sigmas * sigma;
    let motion = ctx.estimator.motion(from);
    let tolerance = opts.cheirality_sigmas * sigma;
    // The support's per-match constants: those of the matches it keeps, in order (the norms
    // cover the rig's cameras in camera order, as the constants do).
    let m = ctx.estimator.match_constant_count();
    let share = m > 0 && constants.len() == m * norms.iter().map(Vec::len).sum::<usize>();
    let mut core_constants = Vec::with_capacity(if share { constants.len() } else { 0 });
    // Per camera: each match's membership by residual and cheirality, and its parallax (only
    // where `parallax_cap` asks for it; 0 otherwise, which no limit excludes).
    let with_parallax = opts.parallax_cap > 0.0 && (opts.parallax_cap_competing || !ctx.competing);
    let passing: Vec<Vec<(bool, f64)>> = obs
        .per_camera
        .iter()
        .zip(&norms)
        .zip(ctx.rig.cameras())
        .map(|((ms, n), cam)| {
            let c = momo_core::camera_motion(&motion, &cam.t_vehicle_camera);
            ms.iter()
                .zip(n)
                .map(|(o, r)| {
                    let ok = *r < cut
                        && (opts.cheirality_sigmas <= 0.0 || cheiral(&c, &o.f0, &o.f1, tolerance));
                    let par = if with_parallax && opts.parallax_cap_inverse_distance {
                        baseline_over_distance(&c, &o.f0, &o.f1)
                    } else if with_parallax {
                        parallax(&c, &o.f0, &o.f1)
                    } else {
                        0.0
                    };
                    (ok, par)
                })
                .collect()
        })
        .collect();
    // The cap acts only where the residual and cheirality tests leave out a tail
    // (`parallax_cap_min_outside`); counted only where the cap is on.
    let tail = || {
        let total: usize = passing.iter().map(Vec::len).sum();
        let outside = passing.iter().flatten().filter(|(ok, _)| !*ok).count();
        outside as f64 >= opts.parallax_cap_min_outside * total as f64
    };
    let limits: Vec<f64> = if !(with_parallax && tail()) {
        vec![f64::INFINITY; passing.len()]
    } else if opts.parallax_cap_per_camera {
        passing
            .iter()
            .map(|p| parallax_limit(p.iter(), opts.parallax_cap, MIN_SUPPORT))
            .collect()
    } else {
        let limit = parallax_limit(passing.iter().flatten(), opts.parallax_cap, 1);
        vec![limit; passing.len()]
    };
    // The learnt cap (`learnt_parallax_cap`): each camera's parallaxes over its support's
    // median, the frame's counts, and the limit the recent frames' counts set.
    let learnt = (opts.learnt_parallax_cap > 0.0 && !ctx.competing)
        .then(|| learnt_parallaxes(ctx, obs, &norms, &motion, &passing, cut, tolerance));
    let tails = opts.learnt_cauchy_max > 0.0 || opts.learnt_least_squares_share > 0.0;
    let tally = (learnt.is_some() || tails).then(|| {
        let mut t = ParallaxTally::default();
        for (j, cam) in learnt.iter().flatten().enumerate() {
            for (r, support) in cam.iter().flatten() {
                t.count(j, *r, *support);
            }
        }
        if tails && ctx.competing {
            t.competing = 1.0;
        } else if tails {
            for r in &all {
                if *r < 2.0 * sigma {
                    t.tail.0 += 1.0;
                } else if *r < 3.0 * sigma {
                    t.tail.1 += 1.0;
                }
            }
        }
        t
    });
    let learnt_limits: Vec<f64> = (0..passing.len())
        .map(|j| match (learnt.as_ref(), ctx.tally) {
            (Some(_), Some(t)) => t.limit(j, opts.learnt_parallax_cap),
            _ => f64::INFINITY,
        })
        .collect();
    let mut k = 0;
    let mut members: Vec<Vec<bool>> = Vec::with_capacity(obs.per_camera.len());
    let core = FrameObservations {
        per_camera: obs
            .per_camera
            .iter()
            .zip(&passing)
            .zip(&limits)
            .enumerate()
            .map(|(j, ((ms, pass), limit))| {
                let mut kept = Vec::with_capacity(ms.len());
                let mut member = Vec::with_capacity(ms.len());
                for (i, (o, (ok, par))) in ms.iter().zip(pass).enumerate() {
                    let rel = learnt
                        .as_ref()
                        .and_then(|l| l[j][i])
                        .map_or(0.0, |(r, _)| r);
                    let keep = *ok && !(*par > *limit) && !(rel >= learnt_limits[j]);
                    if keep {
                        kept.push(*o);
                        if share {
                            core_constants.extend_from_slice(&constants[k * m..(k + 1) * m]);
                        }
                    }
                    member.push(keep);
                    k += 1;
                }
                members.push(member);
                kept
            })
            .collect(),
        cross_camera: obs.cross_camera.clone(),
    };
    if core.len() < MIN_SUPPORT {
        return None;
    }
    Some((core, core_constants, sigma, tally, members))
}

/// Per camera, per match of `obs`: for the support's matches (`passing`) and the band's
/// (`cut <= |r| < 2 cut`, in front of both cameras within `tolerance`), the parallax
/// ([`parallax`]) under `motion` over the median parallax of the camera's support, and whether
/// the match is in the support; `None` for the others (and in a camera with fewer than
/// [`MIN_SUPPORT`] support matches, or a zero median).
fn learnt_parallaxes(
    ctx: &FinalFitContext<'_>,
    obs: &FrameObservations,
    norms: &[Vec<f64>],
    motion: &momo_core::Pose<f64>,
    passing: &[Vec<(bool, f64)>],
    cut: f64,
    tolerance: f64,
) -> Vec<Vec<Option<(f64, bool)>>> {
    obs.per_camera
        .iter()
        .zip(norms)
        .zip(passing)
        .zip(ctx.rig.cameras())
        .map(|(((ms, n), pass), cam)| {
            let c = momo_core::camera_motion(motion, &cam.t_vehicle_camera);
            let par: Vec<Option<(f64, bool)>> = ms
                .iter()
                .zip(n)
                .zip(pass)
                .map(|((o, r), (ok, _))| {
                    let band =
                        !*ok && *r >= cut && *r < 2.0 * cut && cheiral(&c, &o.f0, &o.f1, tolerance);
                    (*ok || band).then(|| (parallax(&c, &o.f0, &o.f1), *ok))
                })
                .collect();
            let mut support: Vec<f64> = par.iter().flatten().filter(|p| p.1).map(|p| p.0).collect();
            let m = if support.len() >= MIN_SUPPORT {
                median(&mut support).unwrap_or(0.0)
            } else {
                0.0
            };
            if !(m > 0.0) {
                return vec![None; ms.len()];
            }
            par.into_iter()
                .map(|p| p.map(|(x, s)| (x / m, s)))
                .collect()
        })
        .collect()
}

/// The matches of `obs` that the final stage would refit on from the parameters `from`
/// ([`stage_support`]: within `inlier_sigmas · σ̂` in the stage's metric, in front of both
/// cameras, under the parallax cap); `None` where the stage would not refit (noise not
/// estimable, support smaller than [`MIN_SUPPORT`]). Mismatches and a moving object's matches
/// far from the motion `from` are left out: the soft prior's conflict test
/// (`odometry.soft_prior_conflict_on_support`) reads the data there.
pub fn support(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    from: &[f64],
) -> Option<FrameObservations> {
    support_at(ctx, opts, obs, from)
        .found
        .map(|(core, _, _, _, _)| core)
}

/// The membership of [`support`]'s matches among `obs` (per camera, per match); `None` where
/// the stage would not refit.
pub fn support_mask(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    from: &[f64],
) -> Option<Vec<Vec<bool>>> {
    support_at(ctx, opts, obs, from)
        .found
        .map(|(_, _, _, _, mask)| mask)
}

/// The neighbourhood test (`neighbour_share`): of the matches `given` (per camera, per match of
/// `obs`), those kept, i.e. all but the members of `support` (a subset of `given`) whose `count`
/// nearest other matches of the same camera (by first-image pixel, among all of `obs`'s) are
/// members of `support` less often than `share`. A camera with at most `count` matches keeps
/// its own.
pub fn neighbour_kept(
    obs: &FrameObservations,
    given: &[Vec<bool>],
    support: &[Vec<bool>],
    count: usize,
    share: f64,
) -> Vec<Vec<bool>> {
    obs.per_camera
        .iter()
        .zip(given)
        .zip(support)
        .map(|((ms, g), s)| {
            let n = ms.len();
            if n <= count || count == 0 {
                return g.clone();
            }
            let near = PixelNeighbours::new(ms);
            let mut d: Vec<(f64, usize)> = Vec::with_capacity(n);
            (0..n)
                .map(|i| {
                    if !(g[i] && s[i]) {
                        return g[i];
                    }
                    let members = near.members(i, count, |j| s[j], &mut d);
                    members as f64 >= share * count as f64
                })
                .collect()
        })
        .collect()
}

/// The nearest other matches of one camera's match by first-image pixel, for the count both
/// [`neighbour_kept`] and [`readmit_kept`] test. "Nearest" orders by squared pixel distance
/// ([`pixel_distance2`]) and then by index, so ties (equal distances, common with integer
/// pixels) have one answer.
///
/// A sweep over the matches sorted by first-image `x`: the `count` matches nearest in `x` (from
/// both sides), then each side outwards until `dx²` alone exceeds the `count`-th best squared
/// distance so far. Floating-point subtraction and squaring are
/// monotone, so no match past a closed side can be nearer: the answer is the exhaustive scan's
/// ([`nearest_members_exhaustive`], which a camera with a non-finite pixel falls back to), at
/// the cost of the matches in a strip about twice the `count`-th distance wide instead of all
/// of them.
struct PixelNeighbours<'a> {
    ms: &'a [momo_core::Observation],
    /// The matches by first-image `x` (then index); `None` where a pixel is not finite.
    sorted: Option<ByX>,
}

/// A camera's matches sorted by first-image `x` (then index), for [`PixelNeighbours`].
struct ByX {
    /// First-image pixel and index of each match, in `x` order.
    pixels: Vec<(nalgebra::Vector2<f64>, usize)>,
    /// Each match's place in `pixels`.
    place: Vec<usize>,
}

/// The squared distance between two first-image pixels, as both neighbour searches compute it.
fn pixel_distance2(a: &nalgebra::Vector2<f64>, b: &nalgebra::Vector2<f64>) -> f64 {
    let (dx, dy) = (a.x - b.x, a.y - b.y);
    dx * dx + dy * dy
}

impl<'a> PixelNeighbours<'a> {
    fn new(ms: &'a [momo_core::Observation]) -> Self {
        let finite = ms
            .iter()
            .all(|o| o.px0.x.is_finite() && o.px0.y.is_finite());
        let sorted = finite.then(|| {
            let mut pixels: Vec<_> = ms.iter().enumerate().map(|(j, o)| (o.px0, j)).collect();
            pixels.sort_unstable_by(|a, b| a.0.x.total_cmp(&b.0.x).then(a.1.cmp(&b.1)));
            let mut place = vec![0; ms.len()];
            for (k, &(_, j)) in pixels.iter().enumerate() {
                place[j] = k;
            }
            ByX { pixels, place }
        });
        Self { ms, sorted }
    }

    /// How many of match `i`'s `count` nearest other matches satisfy `member`. `best` is
    /// scratch space reused across matches; `count` must be in `1..ms.len()`.
    fn members(
        &self,
        i: usize,
        count: usize,
        member: impl Fn(usize) -> bool,
        best: &mut Vec<(f64, usize)>,
    ) -> usize {
        let ms = self.ms;
        let Some(ByX { pixels, place }) = &self.sorted else {
            return nearest_members_exhaustive(ms, i, count, member, best);
        };
        debug_assert!(
            (1..ms.len()).contains(&count),
            "count {count} of {}",
            ms.len()
        );
        let p = ms[i].px0;
        // `best`: the `count` nearest so far, ascending by (squared distance, index); places
        // not filled yet hold an infinite distance.
        best.clear();
        best.resize(count, (f64::INFINITY, usize::MAX));
        let offer = |best: &mut [(f64, usize)], k: usize| {
            let (q, j) = pixels[k];
            let d = pixel_distance2(&q, &p);
            let nearer = |w: (f64, usize)| d < w.0 || (d == w.0 && j < w.1);
            let mut at = best.len() - 1;
            if !nearer(best[at]) {
                return;
            }
            while at > 0 && nearer(best[at - 1]) {
                best[at] = best[at - 1];
                at -= 1;
            }
            best[at] = (d, j);
        };
        // The first `count` by `dx` from both sides, then each side on its own until `dx²`
        // passes the bound (the loops' branches are then mostly predictable).
        let (mut left, mut right) = (place[i], place[i] + 1);
        for _ in 0..count {
            let dl = if left > 0 {
                p.x - pixels[left - 1].0.x
            } else {
                f64::INFINITY
            };
            let dr = if right < pixels.len() {
                pixels[right].0.x - p.x
            } else {
                f64::INFINITY
            };
            if dr < dl {
                offer(best, right);
                right += 1;
            } else {
                left -= 1;
                offer(best, left);
            }
        }
        let last = count - 1;
        while right < pixels.len() {
            let dx = pixels[right].0.x - p.x;
            if dx * dx > best[last].0 {
                break;
            }
            offer(best, right);
            right += 1;
        }
        while left > 0 {
            let dx = p.x - pixels[left - 1].0.x;
            if dx * dx > best[last].0 {
                break;
            }
            left -= 1;
            offer(best, left);
        }
        best.iter().filter(|(_, j)| member(*j)).count()
    }
}

/// How many of match `i`'s `count` nearest other matches of its camera `ms` satisfy `member`,
/// by scanning them all: the reference [`PixelNeighbours`] must equal, and its fallback where a
/// pixel is not finite. `d` is scratch space; `count` must be in `1..ms.len()`.
fn nearest_members_exhaustive(
    ms: &[momo_core::Observation],
    i: usize,
    count: usize,
    member: impl Fn(usize) -> bool,
    d: &mut Vec<(f64, usize)>,
) -> usize {
    d.clear();
    d.extend(
        ms.iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(j, o)| (pixel_distance2(&o.px0, &ms[i].px0), j)),
    );
    d.select_nth_unstable_by(count - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    d[..count].iter().filter(|(_, j)| member(*j)).count()
}

/// Per camera, per match of `obs`, at the parameters `from`: whether the match passes the
/// stage's residual and cheirality tests (step 2 of the module doc, without the parallax caps)
/// with `σ̂` estimated over the matches `given` alone (step 1), and its residual in units of
/// that `σ̂`; `None` where the noise cannot be estimated. What [`readmit_kept`] reads.
pub fn passing_at(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    given: &[Vec<bool>],
    from: &[f64],
) -> Option<Vec<Vec<(bool, f64)>>> {
    let scale = ctx.loss.scale();
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let owned;
    let constants = match ctx.constants {
        Some(c) => c,
        None => {
            owned = frame_constants(ctx, obs, from);
            &owned[..]
        }
    };
    let req = ctx.request(obs, from);
    let norms = ctx
        .estimator
        .residual_norms_with_constants(&req, from, constants)
        .ok()?;
    if norms.len() != obs.per_camera.len()
        || given.len() != obs.per_camera.len()
        || norms
            .iter()
            .zip(&obs.per_camera)
            .zip(given)
            .any(|((n, o), g)| n.len() != o.len() || g.len() != o.len())
    {
        return None;
    }
    let inside: Vec<f64> = norms
        .iter()
        .zip(given)
        .flat_map(|(n, g)| n.iter().zip(g).filter(|(_, g)| **g).map(|(r, _)| *r))
        .collect();
    let sigma = estimate_sigma(&inside, scale, opts)?;
    let cut = opts.inlier_sigmas * sigma;
    let motion = ctx.estimator.motion(from);
    let tolerance = opts.cheirality_sigmas * sigma;
    Some(
        obs.per_camera
            .iter()
            .zip(&norms)
            .zip(ctx.rig.cameras())
            .map(|((ms, n), cam)| {
                let c = momo_core::camera_motion(&motion, &cam.t_vehicle_camera);
                ms.iter()
                    .zip(n)
                    .map(|(o, r)| {
                        let ok = *r < cut
                            && (opts.cheirality_sigmas <= 0.0
                                || cheiral(&c, &o.f0, &o.f1, tolerance));
                        (ok, r / sigma)
                    })
                    .collect()
            })
            .collect(),
    )
}

/// Re-admission (`readmit_share`): the matches `given` (per camera, per match of `obs`) plus
/// those not given that pass (`passing`, [`passing_at`]'s membership at the stage's final
/// motion) and whose `count` nearest other matches of the same camera (by first-image pixel,
/// among all of `obs`'s) are given and passing at least `share` of the time: a static match
/// that the separation's mask left out among static neighbours, where an object's matches
/// that fit the static motion by chance have object neighbours that do not (the converse of
/// [`neighbour_kept`]). A camera with at most `count` matches keeps its given ones.
pub fn readmit_kept(
    obs: &FrameObservations,
    given: &[Vec<bool>],
    passing: &[Vec<bool>],
    count: usize,
    share: f64,
) -> Vec<Vec<bool>> {
    obs.per_camera
        .iter()
        .zip(given)
        .zip(passing)
        .map(|((ms, g), p)| {
            let n = ms.len();
            if n <= count || count == 0 || share <= 0.0 {
                return g.clone();
            }
            let member = |j: usize| g[j] && p[j];
            let near = PixelNeighbours::new(ms);
            let mut d: Vec<(f64, usize)> = Vec::with_capacity(n);
            (0..n)
                .map(|i| {
                    if g[i] || !p[i] {
                        return g[i];
                    }
                    let members = near.members(i, count, member, &mut d);
                    members as f64 >= share * count as f64
                })
                .collect()
        })
        .collect()
}

/// [`support`], kept for the stage itself ([`FinalFitContext::stage`]).
pub fn support_at(
    ctx: &FinalFitContext<'_>,
    opts: &FinalFitOptions,
    obs: &FrameObservations,
    from: &[f64],
) -> StageSupport {
    let owned;
    let constants = match ctx.constants {
        Some(c) => c,
        None => {
            owned = frame_constants(ctx, obs, from);
            &owned[..]
        }
    };
    StageSupport {
        from: from.to_vec(),
        competing: ctx.competing,
        found: stage_support(ctx, opts, obs, constants, from),
    }
}

/// [`FinalFitOptions::guard_tilt`] `= m`: whether the neighbourhood guard keeps the reduced
/// stage (vehicle-frame rotation `reduced`) instead of the given matches' stage (`given`):
/// the given stage's tilt `(ω_x, ω_y)` (of `ω = log R`) lies more than `m` from `trusted`, the
/// trusted frames' running mean tilt, and the reduced stage's within `m` of it. False with
/// `m = 0` or without `trusted`.
///
/// ```
/// use momo_vo::final_fit::guard_tilt_keeps_reduced;
/// use momo_core::so3_exp;
/// use nalgebra::Vector3;
///
/// let rolled = so3_exp(&Vector3::new(0.021, -0.007, 0.011));
/// let level = so3_exp(&Vector3::new(0.001, 0.005, 0.008));
/// assert!(guard_tilt_keeps_reduced(0.01, Some([0.0, 0.0]), &rolled, &level));
/// assert!(!guard_tilt_keeps_reduced(0.01, Some([0.0, 0.0]), &level, &rolled));
/// assert!(!guard_tilt_keeps_reduced(0.0, Some([0.0, 0.0]), &rolled, &level));
/// assert!(!guard_tilt_keeps_reduced(0.01, None, &rolled, &level));
/// ```
pub fn guard_tilt_keeps_reduced(
    m: f64,
    trusted: Option<[f64; 2]>,
    given: &nalgebra::Matrix3<f64>,
    reduced: &nalgebra::Matrix3<f64>,
) -> bool {
    let Some(t) = trusted.filter(|_| m > 0.0) else {
        return false;
    };
    let off = |r: &nalgebra::Matrix3<f64>| {
        let w = momo_core::so3_log(r);
        (w.x - t[0]).hypot(w.y - t[1])
    };
    off(given) > m && off(reduced) <= m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parallax_is_the_angle_between_the_rays_under_the_rotation() {
        let c = momo_core::Pose {
            rotation: *nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), 0.1)
                .matrix(),
            translation: nalgebra::Vector3::new(0.0, 0.0, 1.0),
        };
        let f1 = nalgebra::Vector3::new(0.2, -0.1, 1.0).normalize();
        let g = c.rotation * f1;
        // f₀ = g turned by 0.03 rad about an axis orthogonal to g.
        let axis = nalgebra::Unit::new_normalize(g.cross(&nalgebra::Vector3::x()));
        let f0 = nalgebra::Rotation3::from_axis_angle(&axis, 0.03) * g;
        assert!((parallax(&c, &f0, &f1) - 0.03).abs() < 1e-12);
        assert!(parallax(&c, &g, &f1).abs() < 1e-12);
    }

    #[test]
    fn the_baseline_over_distance_is_the_parallax_over_the_epipole_sine() {
        let rot =
            *nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), 0.05).matrix();
        let t = nalgebra::Vector3::new(0.1, 0.0, 0.8);
        let c = momo_core::Pose {
            rotation: rot,
            translation: t,
        };
        // Points at 12 m from the frame-k camera centre in several directions (near the
        // direction of travel and across it): the parallax differs, |t| / λ₁ does not.
        let mut pars = Vec::new();
        for dir in [
            nalgebra::Vector3::new(0.05, -0.02, 1.0),
            nalgebra::Vector3::new(0.8, 0.1, 1.0),
            nalgebra::Vector3::new(-1.0, 0.3, 0.2),
        ] {
            let x0 = t + dir.normalize() * 12.0;
            let f0 = x0.normalize();
            let f1 = (rot.transpose() * (x0 - t)).normalize();
            let b = baseline_over_distance(&c, &f0, &f1);
            assert!((b - t.norm() / 12.0).abs() < 1e-9, "{b}");
            pars.push(parallax(&c, &f0, &f1));
        }
        assert!(pars[2] > 5.0 * pars[0], "{pars:?}");
        // At the epipole no parallax; without translation 0.
        let f = t.normalize();
        assert!(baseline_over_distance(&c, &f, &(rot.transpose() * f)).abs() < 1e-12);
        let still = momo_core::Pose {
            rotation: rot,
            translation: nalgebra::Vector3::zeros(),
        };
        assert_eq!(baseline_over_distance(&still, &f, &f), 0.0);
    }

    #[test]
    fn the_learnt_cap_is_the_lowest_tail_where_the_band_reaches_the_share() {
        // Half-octave bins from 4x the median: 4 -> bin 0, 5.7 -> 1, 8 -> 2, 3.9 -> none.
        assert_eq!(ParallaxTally::bin(3.9), None);
        assert_eq!(ParallaxTally::bin(f64::NAN), None);
        assert_eq!(ParallaxTally::bin(4.0), Some(0));
        assert_eq!(ParallaxTally::bin(5.7), Some(1));
        assert_eq!(ParallaxTally::bin(8.0), Some(2));
        assert_eq!(ParallaxTally::bin(1e9), Some(PARALLAX_TALLY_BINS - 1));
        // One frame: 30 support matches at 4.5x, 10 at 9x; band 1 at 4.5x, 5 at 9x.
        let mut frame = ParallaxTally::default();
        for _ in 0..30 {
            frame.count(0, 4.5, true);
        }
        for _ in 0..10 {
            frame.count(0, 9.0, true);
        }
        frame.count(0, 4.5, false);
        for _ in 0..5 {
            frame.count(0, 9.0, false);
        }
        // The tail from 8x holds 10 support matches: below the warm-up count, no cap yet.
        assert_eq!(frame.limit(0, 0.4), f64::INFINITY);
        let mut sums = ParallaxTally::default();
        sums.add(&frame);
        sums.add(&frame);
        // Two frames (the first decayed): the tail from 8x holds 19.9 support matches, still
        // no cap; a third frame puts it above 20 (29.7) with a band of 14.9 (>= 0.4 of it): the
        // tail qualifies from 8x, and from the empty bin below it (5.7x: the same sums), so the
        // cap is 2^2.5 = 5.66x. From 4x the share is 17.8 / 118.8 < 0.4: not lower. Another
        // camera: none.
        assert_eq!(sums.limit(0, 0.4), f64::INFINITY);
        sums.add(&frame);
        assert_eq!(sums.limit(0, 0.4), 2f64.powf(2.5));
        assert_eq!(sums.limit(0, 0.8), f64::INFINITY);
        assert_eq!(sums.limit(0, 0.1), 4.0);
        assert_eq!(sums.limit(1, 0.4), f64::INFINITY);
    }

    #[test]
    fn the_learnt_cauchy_scale_follows_the_residual_tail() {
        // The Gaussian share and below: plain least squares (infinite scale); the table's
        // points exactly; between them 1 / c linear in q; beyond the heaviest: its scale.
        assert_eq!(learnt_cauchy_sigmas(GAUSSIAN_TAIL), f64::INFINITY);
        assert_eq!(learnt_cauchy_sigmas(0.03), f64::INFINITY);
        assert_eq!(learnt_cauchy_sigmas(f64::NAN), f64::INFINITY);
        assert!((learnt_cauchy_sigmas(0.06387) - 2.361).abs() < 1e-12);
        assert!((learnt_cauchy_sigmas(0.09307) - 1.112).abs() < 1e-12);
        assert_eq!(learnt_cauchy_sigmas(0.2), 1.112);
        let mid = 1.0 / (0.5 / 2.361 + 0.5 / 2.750);
        assert!((learnt_cauchy_sigmas((0.06387 + 0.05958) / 2.0) - mid).abs() < 1e-12);
        // Just above the Gaussian share: large, finite, falling as the tail grows.
        let near = learnt_cauchy_sigmas(0.0436);
        assert!(near.is_finite() && near > 100.0, "{near}");
        let mut last = f64::INFINITY;
        for i in 0..200 {
            let c = learnt_cauchy_sigmas(0.044 + 0.0003 * f64::from(i));
            assert!(c <= last, "not falling at step {i}: {c} after {last}");
            last = c;
        }
        // The tally: nothing before CAUCHY_TALLY_MIN matches, then the clamp.
        let frame = |core: f64, band: f64| ParallaxTally {
            tail: (core, band),
            ..Default::default()
        };
        let mut sums = ParallaxTally::default();
        sums.add(&frame(1140.0, 60.0));
        assert_eq!(sums.cauchy_sigmas(2.4, 6.0), None);
        sums.add(&frame(1140.0, 60.0));
        // 2388 decayed matches, q = 0.05 (near the simulator's Gaussian pixels, 0.047-0.049):
        // c = 4.65, within the clamp; clamped down to 4.
        let c = sums.cauchy_sigmas(2.4, 6.0).expect("counted");
        assert!(
            (c - learnt_cauchy_sigmas(0.05)).abs() < 1e-9 && c > 4.6 && c < 4.7,
            "{c}"
        );
        assert_eq!(sums.cauchy_sigmas(2.4, 4.0), Some(4.0));
        // q = 0.08 (the real KITTI 00 residuals): the Student-t scale 1.5, clamped up to 2.4.
        let mut heavy = ParallaxTally::default();
        heavy.add(&frame(1840.0, 160.0));
        assert_eq!(heavy.cauchy_sigmas(2.4, 6.0), Some(2.4));
        // A frame where two motions competed: no learnt scale for CAUCHY_QUIET_FRAMES frames,
        // and the learnt parallax cap's counts do not decay on it.
        sums.count(0, 9.0, true);
        let bins = sums.per_camera.clone();
        sums.add(&ParallaxTally {
            competing: 1.0,
            ..Default::default()
        });
        assert_eq!(sums.per_camera, bins);
        assert_eq!(sums.cauchy_sigmas(2.4, 6.0), None);
        for _ in 0..CAUCHY_QUIET_FRAMES - 1 {
            sums.add(&frame(1140.0, 60.0));
        }
        assert_eq!(sums.cauchy_sigmas(2.4, 6.0), None);
        sums.add(&frame(1140.0, 60.0));
        sums.add(&frame(1140.0, 60.0));
        let c = sums.cauchy_sigmas(2.4, 6.0).expect("quiet again");
        assert!((c - learnt_cauchy_sigmas(0.05)).abs() < 1e-9, "{c}");
    }

    #[test]
    fn the_parallax_limit_is_a_multiple_of_the_members_median() {
        // Members 1, 2, 3 (and a non-member at 100): median 2, the cap 8 -> 16.
        let p = [(true, 3.0), (false, 100.0), (true, 1.0), (true, 2.0)];
        assert_eq!(parallax_limit(p.iter(), 8.0, 1), 16.0);
        // Too few members for a camera's own median: no cap.
        assert_eq!(parallax_limit(p.iter(), 8.0, 4), f64::INFINITY);
        assert_eq!(parallax_limit([].iter(), 8.0, 0), f64::INFINITY);
    }

    #[test]
    fn sigma_of_gaussian_residuals_with_outliers() {
        // Half-normal quantiles of σ = 0.002 (deterministic), plus 30 % far outliers.
        let sigma = 0.002;
        let n = 700;
        let mut norms: Vec<f64> = (0..n)
            .map(|i| {
                let p = (i as f64 + 0.5) / n as f64;
                // |N| quantile p: Φ⁻¹((1 + p) / 2), by bisection on erf-free Φ.
                sigma * half_normal_quantile(p)
            })
            .collect();
        norms.extend((0..300).map(|i| 0.02 + 0.001 * i as f64));
        let s = estimate_sigma(&norms, 0.001, &FinalFitOptions::default()).unwrap();
        assert!((s / sigma - 1.0).abs() < 0.03, "σ̂ = {s}");
        // Clamped to [0.1 b, 5 b].
        let tiny = estimate_sigma(&[1e-9; 50], 0.001, &FinalFitOptions::default()).unwrap();
        assert_eq!(tiny, 1e-4);
        assert_eq!(
            estimate_sigma(&[1.0; 5], 0.001, &FinalFitOptions::default()),
            None
        );
    }

    /// The integer key of `estimate_sigma`'s sort orders as `f64::total_cmp` and gives the
    /// bits back (random bits of every sign and exponent, zeros of both signs, infinities,
    /// NaNs, subnormals).
    #[test]
    fn the_total_order_key_orders_as_total_cmp_and_inverts() {
        let mut x: u64 = 987_654_321;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut values: Vec<f64> = vec![
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::from_bits(1),
            -f64::from_bits(1),
            f64::MAX,
            f64::MIN,
        ];
        values.extend((0..4000).map(|_| f64::from_bits(next())));
        for a in &values {
            assert_eq!(total_order_key_inverse(total_order_key(*a)), a.to_bits());
            for b in values.iter().step_by(7) {
                assert_eq!(
                    total_order_key(*a).cmp(&total_order_key(*b)),
                    a.total_cmp(b),
                    "{a:e} {b:e}"
                );
            }
        }
    }

    /// `estimate_sigma` by one sort against the three selections it replaces (each trimmed
    /// set filtered and its median selected anew): the same `σ̂` bit for bit on random norms
    /// with ties, zeros, outliers, NaN and infinities, and the same `None`.
    #[test]
    fn sigma_from_one_sort_matches_three_selections() {
        fn by_selection(norms: &[f64], scale: f64, opts: &FinalFitOptions) -> Option<f64> {
            let lo = opts.min_scale_ratio * scale;
            let hi = opts.max_scale_ratio * scale;
            let mut cut = opts.start_scales * scale;
            let mut sigma = None;
            for _ in 0..3 {
                let mut inside: Vec<f64> = norms
                    .iter()
                    .copied()
                    .filter(|r| r.is_finite() && *r < cut)
                    .collect();
                let s = (MAD_TO_SIGMA * median(&mut inside)?).clamp(lo, hi);
                sigma = Some(s);
                cut = opts.inlier_sigmas * s;
            }
            sigma
        }
        let mut x: u64 = 12345;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let opts = FinalFitOptions::default();
        let (mut some, mut none) = (0, 0);
        for case in 0..2000 {
            let n = (next() * 400.0) as usize;
            let norms: Vec<f64> = (0..n)
                .map(|_| {
                    let u = next();
                    if case % 50 == 0 {
                        return 0.05 + u; // nothing within the first cut
                    }
                    match (next() * 20.0) as usize {
                        0 => f64::NAN,
                        1 => f64::INFINITY,
                        2 => 0.0,
                        3 => 0.001,        // ties at the scale
                        4 | 5 => 0.05 + u, // far outliers
                        _ => 0.002 * u * (1.0 + (case % 7) as f64),
                    }
                })
                .collect();
            let scale = [0.001, 0.0005, 0.004][case % 3];
            let (a, b) = (
                estimate_sigma(&norms, scale, &opts),
                by_selection(&norms, scale, &opts),
            );
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "case {case}");
            if a.is_some() { some += 1 } else { none += 1 }
        }
        assert!(some > 1500 && none >= 40, "{some} {none}");
    }

    /// `metric = "angle_plane_ml"` runs the final stage with that metric: the odometry builds
    /// and runs, the estimate stays at the truth on the canned fisheye rig (noise-free inliers,
    /// 25 % far outliers) as without the option, but is not the same estimate (another
    /// metric's refit); an unknown metric is an error at its line.
    #[test]
    fn the_final_stage_refits_with_its_own_metric() {
        use crate::{Config, Odometry};
        use momo_core::Manifold;
        let truth = [0.002, -0.001, 0.02, 0.01, 0.0, 1.0];
        let rig = momo_testing::canned::fisheye_rig();
        let obs = momo_testing::canned::synthetic_observations(
            &rig,
            &momo_models::Se3.motion(&truth),
            30,
            10,
            3,
        );
        let run = |extra: &str| {
            let text = format!("[odometry.final_fit]\nenabled = true\n{extra}");
            let config = Config::from_toml_str(&text, "ff.toml").unwrap();
            let mut vo = Odometry::new(rig.clone(), config).unwrap();
            let r = vo.process(&obs, Some(1.0));
            vo.estimator().motion(&r.diagnostics.params)
        };
        let (plain, ml) = (
            run("metric = \"angle_plane\"\n"),
            run("metric = \"angle_plane_ml\"\n"),
        );
        let motion = momo_models::Se3.motion(&truth);
        let off = |m: &momo_core::Pose<f64>| {
            momo_core::so3_log(&(m.rotation.transpose() * motion.rotation)).norm()
        };
        assert!(
            off(&plain) < 1e-6 && off(&ml) < 1e-6,
            "{} {}",
            off(&plain),
            off(&ml)
        );
        assert!(ml.rotation != plain.rotation || ml.translation != plain.translation);
        let err = Config::from_toml_str(
            "[odometry.final_fit]\nenabled = true\nmetric = \"nope\"\n",
            "bad.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.starts_with("bad.toml:") && err.contains("nope"),
            "{err}"
        );
    }

    /// `cheiral`: points in front of both cameras pass (also far ones, with noise within the
    /// tolerance); a point behind camera k-1 or behind camera k, with an exact epipolar
    /// residual of zero, fails; without translation everything passes.
    #[test]
    fn the_cheirality_test_tells_points_behind_a_camera() {
        use momo_core::Pose;
        use nalgebra::{Rotation3, Vector3};
        let r = *Rotation3::from_euler_angles(0.002, -0.001, 0.03).matrix();
        let c = Pose::new(r, Vector3::new(0.05, -0.02, 1.0));
        let rt = r.transpose();
        let (mut behind, mut tested) = (0, 0);
        for i in 0..200 {
            let a = i as f64 * 0.61803;
            let dir = Vector3::new(0.6 * a.sin(), 0.3 * (1.7 * a).cos(), 1.0).normalize();
            let depth = 3.0 + 2.0 * (i % 40) as f64;
            // In front: X₀ = λ₀ f₀, X₁ = Rᵀ (X₀ − t).
            let x0 = dir * depth;
            let f1 = (rt * (x0 - c.translation)).normalize();
            assert!(cheiral(&c, &dir, &f1, 0.0), "point {i} in front");
            // Behind camera k-1: the same ray, negative depth.
            let f1b = (rt * (-x0 - c.translation)).normalize();
            // Behind camera k: the frame-k ray reversed.
            let f1c = -f1;
            // (Rays within 0.1 rad of the epipole have too little parallax at 80 m.)
            if dir.angle(&c.translation) < 0.1 {
                continue;
            }
            tested += 2;
            for f in [f1b, f1c] {
                // Both lie on the epipolar plane of (f₀, t): a residual-only test keeps them.
                let plane = c.translation.cross(&(r * f));
                assert!(dir.dot(&plane).abs() < 1e-9 * plane.norm().max(1.0));
                if !cheiral(&c, &dir, &f, 1e-3) {
                    behind += 1;
                }
            }
        }
        assert!(tested > 300, "{tested}");
        assert_eq!(behind, tested, "every point behind a camera is found");
        // A point at infinity with noise: passes within the tolerance.
        let dir = Vector3::new(0.2, -0.1, 1.0).normalize();
        let f1 = (rt * dir + Vector3::new(-2e-4, 1e-4, 0.0)).normalize();
        assert!(cheiral(&c, &dir, &f1, 1e-3));
        // No translation: nothing to test.
        let still = Pose::new(r, Vector3::zeros());
        assert!(cheiral(&still, &dir, &(-dir), 0.0));
    }

    #[test]
    fn the_loss_is_least_squares_where_the_recent_tails_look_gaussian() {
        // `learnt_least_squares_share`: the refit is plain least squares where the recent
        // frames' tail share is at most the threshold, the configured Cauchy refit where it is
        // above, during the warm-up, on a competing frame and within CAUCHY_QUIET_FRAMES after
        // one.
        let (est, rig, obs, from) = noisy_case(false, 7, [0.003, -0.002, 0.001]);
        let loss = momo_costs::Cauchy::new(0.001);
        let solver = momo_solvers::LevenbergMarquardt::default();
        let fixed = [false, false, false, false, false, true];
        let prior = MotionPrior::default();
        let frame = |core: f64, band: f64| ParallaxTally {
            tail: (core, band),
            ..Default::default()
        };
        let tally_of = |frames: &[ParallaxTally]| {
            let mut t = ParallaxTally::default();
            for f in frames {
                t.add(f);
            }
            t
        };
        let light = tally_of(&[frame(1900.0, 100.0), frame(1900.0, 100.0)]);
        let heavy = tally_of(&[frame(1840.0, 160.0), frame(1840.0, 160.0)]);
        let warm_up = tally_of(&[frame(950.0, 50.0)]);
        let mut after_competing = tally_of(&[ParallaxTally {
            competing: 1.0,
            ..Default::default()
        }]);
        after_competing.add(&frame(1900.0, 100.0));
        after_competing.add(&frame(1900.0, 100.0));
        let near =
            |t: &ParallaxTally, q: f64| t.tail_share().is_some_and(|x| (x - q).abs() < 1e-12);
        assert!(near(&light, 0.05) && near(&heavy, 0.08));
        assert_eq!(warm_up.tail_share(), None);
        assert_eq!(after_competing.tail_share(), None);
        let solve = |tally: Option<&ParallaxTally>, competing: bool, opts: &FinalFitOptions| {
            let ctx = FinalFitContext {
                rig: &rig,
                estimator: est.as_ref(),
                loss: &loss,
                solver: &solver,
                fixed: &fixed,
                motion_prior: &prior,
                competing,
                tally,
                constants: None,
                stage: None,
            };
            let (sol, _, _, _) = refit_once(&ctx, opts, &obs, &[], &from).expect("refits");
            format!("{:?}", sol.params)
        };
        // The refit's Cauchy loss without the learnt scale (the default's before the
        // twenty-first session).
        let cauchy = FinalFitOptions {
            learnt_cauchy_max: 0.0,
            learnt_never_after_flag: false,
            ..Default::default()
        };
        let plain = FinalFitOptions {
            cauchy_sigmas: 0.0,
            ..cauchy.clone()
        };
        let chosen = FinalFitOptions {
            learnt_least_squares_share: 0.065,
            ..cauchy.clone()
        };
        let (ls, ca) = (solve(None, false, &plain), solve(None, false, &cauchy));
        assert_ne!(ls, ca, "the case must tell the two losses apart");
        assert_eq!(solve(Some(&light), false, &chosen), ls);
        assert_eq!(solve(Some(&heavy), false, &chosen), ca);
        assert_eq!(solve(Some(&warm_up), false, &chosen), ca);
        assert_eq!(solve(Some(&after_competing), false, &chosen), ca);
        assert_eq!(solve(Some(&light), true, &chosen), ca);
        // At the threshold itself: least squares; off (0): Cauchy.
        let at = FinalFitOptions {
            learnt_least_squares_share: 0.05,
            ..cauchy.clone()
        };
        assert_eq!(solve(Some(&light), false, &at), ls);
        assert_eq!(solve(Some(&light), false, &cauchy), ca);
        // `learnt_never_after_flag`: after a flagged frame, Cauchy for good.
        let mut flagged = light.clone();
        flagged.mark_flagged();
        flagged.add(&frame(1900.0, 100.0));
        let never = FinalFitOptions {
            learnt_never_after_flag: true,
            ..chosen.clone()
        };
        assert_eq!(solve(Some(&flagged), false, &chosen), ls);
        assert_eq!(solve(Some(&flagged), false, &never), ca);
        assert_eq!(solve(Some(&light), false, &never), ls);
        assert!(
            FinalFitOptions {
                learnt_least_squares_share: 1.0,
                ..Default::default()
            }
            .validate()
            .is_err()
        );
    }

    /// Canned matches of a random motion with deterministic bearing noise (about 1e-3 rad) and
    /// the canned outliers: the estimator of the default final stage (`angle_plane_ml`, se3),
    /// the rig, the matches and a start near the truth.
    fn noisy_case(
        fisheye: bool,
        seed: u64,
        w: [f64; 3],
    ) -> (
        Box<dyn FrameEstimator>,
        momo_core::Rig,
        FrameObservations,
        Vec<f64>,
    ) {
        use momo_core::Manifold;
        let truth = [w[0], w[1], 0.02 + w[2], 0.01, 0.0, 1.0];
        let rig = if fisheye {
            momo_testing::canned::fisheye_rig()
        } else {
            momo_testing::canned::pinhole_rig()
        };
        let mut obs = momo_testing::canned::synthetic_observations(
            &rig,
            &momo_models::Se3.motion(&truth),
            40,
            8,
            seed,
        );
        let mut k = seed as f64;
        for o in obs.per_camera.iter_mut().flatten() {
            k += 1.0;
            let n = nalgebra::Vector3::new((k * 0.7).sin(), (k * 1.3).cos(), (k * 2.1).sin());
            o.f1 = (o.f1 + n * 1e-3).normalize();
        }
        let est = momo_core::erase(momo_models::Se3, momo_costs::AnglePlaneMl);
        let from: Vec<f64> = truth
            .iter()
            .enumerate()
            .map(|(i, v)| v + 2e-4 * ((i as f64 + k).sin()))
            .collect();
        (est, rig, obs, from)
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]
        /// The stage metric's per-match constants computed once and shared (the residual norms
        /// on all matches, then the refit on the support: `refit_once` with `constants`) give
        /// the solution of the path where each problem computes its own (`refit_once` with
        /// none, the stage before this was shared) bit for bit: parameters, costs, normal
        /// matrix, iterations, inliers and support, on both canned rigs. And the estimator's
        /// `*_with_constants` methods against its plain ones on a subset of the matches, with
        /// constants of the wrong length an error.
        #[test]
        fn shared_match_constants_are_bit_identical(
            seed in 0u64..10_000,
            fisheye in proptest::bool::ANY,
            w in proptest::array::uniform3(-0.01..0.01f64),
        ) {
            let (est, rig, obs, from) = noisy_case(fisheye, seed, w);
            let loss = momo_costs::Cauchy::new(0.001);
            let solver = momo_solvers::LevenbergMarquardt::default();
            let fixed = [false, false, false, false, false, true];
            let prior = MotionPrior::default();
            let ctx = FinalFitContext {
                rig: &rig,
                estimator: est.as_ref(),
                loss: &loss,
                solver: &solver,
                fixed: &fixed,
                motion_prior: &prior,
                competing: false,
                tally: None,
                constants: None,
                stage: None,
            };
            let req = ctx.request(&obs, &from);
            let constants = est.match_constants(&req);
            proptest::prop_assert_eq!(constants.len(), 18 * obs.len());
            proptest::prop_assert_eq!(est.match_constant_count(), 18);
            let opts = FinalFitOptions::default();
            let shared = refit_once(&ctx, &opts, &obs, &constants, &from);
            let own = refit_once(&ctx, &opts, &obs, &[], &from);
            proptest::prop_assert!(shared.is_some());
            proptest::prop_assert_eq!(format!("{shared:?}"), format!("{own:?}"));
            // The stage given the frame's constants and a support found earlier
            // (`FinalFitContext::constants`, `stage`): bit for bit the stage that finds both
            // itself, whether the support was found at the stage's start (reused) or elsewhere
            // (not used).
            let first = est.solve(&req).unwrap();
            let plain = format!("{:?}", refit_tallied(&ctx, &opts, &obs, first.clone()));
            let at_start = support_at(&ctx, &opts, &obs, &first.params);
            let elsewhere = support_at(&ctx, &opts, &obs, &from);
            for stage in [&at_start, &elsewhere] {
                let given = FinalFitContext {
                    constants: Some(&constants),
                    stage: Some(stage),
                    ..ctx
                };
                let reused = refit_tallied(&given, &opts, &obs, first.clone());
                proptest::prop_assert_eq!(&format!("{reused:?}"), &plain);
            }
            // A support marked as found at the start is what the stage reads (here: none, so
            // the stage keeps the first solution), unless found while `competing` differed.
            let unrefined = format!("{:?}", (first.clone(), None::<ParallaxTally>));
            proptest::prop_assert_ne!(&unrefined, &plain);
            for (competing, expected) in [(false, &unrefined), (true, &plain)] {
                let none = StageSupport {
                    from: first.params.clone(),
                    competing,
                    found: None,
                };
                let given = FinalFitContext {
                    stage: Some(&none),
                    ..ctx
                };
                let out = refit_tallied(&given, &opts, &obs, first.clone());
                proptest::prop_assert_eq!(&format!("{out:?}"), expected);
            }
            // The estimator's methods: norms, and a solve on every match but each third.
            let norms = est.residual_norms(&req, &from).unwrap();
            let with = est.residual_norms_with_constants(&req, &from, &constants).unwrap();
            proptest::prop_assert_eq!(format!("{norms:?}"), format!("{with:?}"));
            let mut sub = FrameObservations::new(rig.len());
            let mut sub_constants = Vec::new();
            let mut k = 0;
            for (j, matches) in obs.per_camera.iter().enumerate() {
                for o in matches {
                    if k % 3 != 0 {
                        sub.per_camera[j].push(*o);
                        sub_constants.extend_from_slice(&constants[18 * k..18 * (k + 1)]);
                    }
                    k += 1;
                }
            }
            let sub_req = SolveRequest { observations: &sub, ..req };
            let plain = est.solve(&sub_req).unwrap();
            let given = est.solve_with_constants(&sub_req, &sub_constants).unwrap();
            proptest::prop_assert_eq!(format!("{plain:?}"), format!("{given:?}"));
            let short = est.solve_with_constants(&sub_req, &sub_constants[1..]);
            proptest::prop_assert!(
                matches!(short, Err(momo_core::CoreError::MatchConstantCount { .. })),
                "{:?}",
                short
            );
        }
    }

    /// `Φ⁻¹((1 + p) / 2)` by bisection on a numerically integrated Gaussian density.
    fn half_normal_quantile(p: f64) -> f64 {
        let cdf = |x: f64| {
            // ∫₀ˣ 2φ(t) dt by Simpson's rule.
            let n = 200;
            let h = x / n as f64;
            let f = |t: f64| 2.0 * (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
            let mut s = f(0.0) + f(x);
            for i in 1..n {
                s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
            }
            s * h / 3.0
        };
        let (mut lo, mut hi) = (0.0, 10.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if cdf(mid) < p { lo = mid } else { hi = mid }
        }
        0.5 * (lo + hi)
    }

    /// A match at pixel `(u, v)` (bearings unused by the neighbourhood test).
    fn at(u: f64, v: f64) -> momo_core::Observation {
        let px = nalgebra::Vector2::new(u, v);
        let f = nalgebra::Vector3::new(u, v, 100.0).normalize();
        momo_core::Observation {
            px0: px,
            px1: px,
            f0: f,
            f1: f,
        }
    }

    #[test]
    fn the_neighbourhood_test_leaves_out_members_among_non_members() {
        // One camera: a 5 x 5 grid of support members (10 px apart) and, 200 px away, a
        // cluster of 9 non-members (an object) with one member in its middle; a second camera
        // with 3 matches (at most `count`: kept as given).
        let mut cam0 = Vec::new();
        let mut member = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                cam0.push(at(10.0 * f64::from(i), 10.0 * f64::from(j)));
                member.push(true);
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                cam0.push(at(200.0 + 5.0 * f64::from(i), 200.0 + 5.0 * f64::from(j)));
                member.push(i == 1 && j == 1);
            }
        }
        let cam1 = vec![at(0.0, 0.0), at(1.0, 0.0), at(2.0, 0.0)];
        let obs = FrameObservations {
            per_camera: vec![cam0, cam1],
            cross_camera: Vec::new(),
        };
        let mut given = vec![vec![true; member.len()], vec![true, false, true]];
        // A member of the grid that was not given stays out.
        given[0][0] = false;
        let mut support = vec![member.clone(), vec![true, false, false]];
        support[0][0] = false;
        let kept = neighbour_kept(&obs, &given, &support, 8, 0.375);
        let middle = 25 + 4;
        assert!(!kept[0][middle], "the object's lone member is left out");
        assert!(!kept[0][0], "a match not given stays out");
        for (i, k) in kept[0].iter().enumerate() {
            if i != middle && i != 0 {
                assert!(
                    *k,
                    "match {i} kept (a grid member, or given but not a member)"
                );
            }
        }
        assert_eq!(
            kept[1], given[1],
            "a camera with at most `count` matches is kept"
        );
        // A share of 0 keeps every given match.
        assert_eq!(neighbour_kept(&obs, &given, &support, 8, 0.0), given);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The sweep over `x` counts the same nearest members as the exhaustive scan, on
        /// scattered sub-pixel matches, on integer pixels with many equal distances and repeated
        /// pixels, and on a compact cluster beside a spread scene; a non-finite pixel falls back
        /// to the scan.
        #[test]
        fn the_pixel_sweep_counts_what_the_exhaustive_scan_counts(
            points in proptest::collection::vec((0.0..1242.0f64, 0.0..375.0f64), 2..120),
            integer in proptest::bool::ANY,
            cluster in 0usize..40,
            members in proptest::collection::vec(proptest::bool::ANY, 160),
            count in 1usize..12,
            nan in proptest::bool::ANY,
        ) {
            let mut ms: Vec<_> = points
                .iter()
                .map(|&(u, v)| if integer { at((u / 40.0).round(), (v / 40.0).round()) } else { at(u, v) })
                .collect();
            ms.extend((0..cluster).map(|k| at(600.0 + (k % 5) as f64, 200.0 + (k / 5) as f64)));
            if nan {
                ms[0].px0.x = f64::NAN;
            }
            let count = count.min(ms.len() - 1);
            let member = |j: usize| members[j % members.len()];
            let near = PixelNeighbours::new(&ms);
            proptest::prop_assert_eq!(near.sorted.is_none(), nan);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for i in 0..ms.len() {
                if nan && i == 0 {
                    continue;
                }
                let swept = near.members(i, count, member, &mut a);
                let scanned = nearest_members_exhaustive(&ms, i, count, member, &mut b);
                proptest::prop_assert_eq!(swept, scanned, "match {}", i);
                if !nan {
                    // The same neighbours, not only as many members.
                    let mut s: Vec<usize> = b[..count].iter().map(|(_, j)| *j).collect();
                    s.sort_unstable();
                    let mut w: Vec<usize> = a.iter().map(|(_, j)| *j).collect();
                    w.sort_unstable();
                    proptest::prop_assert_eq!(w, s, "match {}", i);
                }
            }
        }
    }

    #[test]
    fn the_readmission_adds_passing_matches_among_passing_members() {
        // One camera: a 5 x 5 grid (10 px apart) of given, passing matches; in its middle a
        // match not given that passes (re-admitted) and one not given that does not pass (stays
        // out); 200 px away a cluster of 9 matches not given, all passing but one, whose
        // neighbours are not given (an object that fits the motion by chance: stays out); a
        // second camera with 3 matches (at most `count`: kept as given).
        let mut cam0 = Vec::new();
        let (mut given, mut passing) = (Vec::new(), Vec::new());
        for i in 0..5 {
            for j in 0..5 {
                cam0.push(at(10.0 * f64::from(i), 10.0 * f64::from(j)));
                given.push(true);
                passing.push(true);
            }
        }
        cam0.push(at(15.0, 15.0));
        given.push(false);
        passing.push(true);
        cam0.push(at(25.0, 25.0));
        given.push(false);
        passing.push(false);
        for i in 0..3 {
            for j in 0..3 {
                cam0.push(at(200.0 + 5.0 * f64::from(i), 200.0 + 5.0 * f64::from(j)));
                given.push(false);
                passing.push(!(i == 0 && j == 0));
            }
        }
        // A given match that does not pass stays given (the stage decides on it).
        passing[3] = false;
        let cam1 = vec![at(0.0, 0.0), at(1.0, 0.0), at(2.0, 0.0)];
        let obs = FrameObservations {
            per_camera: vec![cam0, cam1],
            cross_camera: Vec::new(),
        };
        let given = vec![given, vec![true, false, true]];
        let passing = vec![passing, vec![true, true, true]];
        let kept = readmit_kept(&obs, &given, &passing, 8, 0.5);
        assert!(
            kept[0][25],
            "the passing match among passing members is re-admitted"
        );
        assert!(!kept[0][26], "a match that does not pass stays out");
        assert!(
            kept[0][27..].iter().all(|k| !k),
            "the cluster of matches not given stays out"
        );
        assert_eq!(
            &kept[0][..25],
            &given[0][..25],
            "the given matches stay given"
        );
        assert_eq!(kept[1], given[1], "a camera with at most `count` matches");
        // A share of 0 re-admits nothing; a share of 1 needs all 8 nearest to be given and
        // passing, and the middle match's include the one at (25, 25) that is neither.
        assert_eq!(readmit_kept(&obs, &given, &passing, 8, 0.0), given);
        assert!(!readmit_kept(&obs, &given, &passing, 8, 1.0)[0][25]);
    }

    #[test]
    fn options_validate_and_parse() {
        assert!(FinalFitOptions::default().validate().is_ok());
        for share in [-0.1, 1.5, f64::NAN] {
            let bad = FinalFitOptions {
                neighbour_share: share,
                ..FinalFitOptions::default()
            };
            assert!(bad.validate().unwrap_err().contains("neighbour_share"));
        }
        let bad = FinalFitOptions {
            neighbour_share: 0.5,
            neighbour_count: 0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("neighbour_count"));
        let bad = FinalFitOptions {
            neighbour_min_cameras: 0,
            ..FinalFitOptions::default()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .contains("neighbour_min_cameras")
        );
        assert_eq!(FinalFitOptions::default().neighbour_min_cameras, 1);
        for guard in [-0.1, f64::NAN, f64::INFINITY] {
            let bad = FinalFitOptions {
                neighbour_guard: guard,
                ..FinalFitOptions::default()
            };
            assert!(bad.validate().unwrap_err().contains("neighbour_guard"));
        }
        assert_eq!(
            FinalFitOptions::default().neighbour_guard,
            NEIGHBOUR_GUARD_DEFAULT
        );
        for tilt in [-0.01, f64::NAN, f64::INFINITY] {
            let bad = FinalFitOptions {
                guard_tilt: tilt,
                ..FinalFitOptions::default()
            };
            assert!(bad.validate().unwrap_err().contains("guard_tilt"));
        }
        let off: FinalFitOptions = toml::from_str("guard_tilt = 0").unwrap();
        assert_eq!(off.guard_tilt, 0.0);
        let two: FinalFitOptions = toml::from_str("neighbour_min_cameras = 2").unwrap();
        assert_eq!((two.neighbour_min_cameras, two.neighbour_share), (2, 0.375));
        for share in [-0.1, 1.5, f64::NAN] {
            let bad = FinalFitOptions {
                readmit_share: share,
                ..FinalFitOptions::default()
            };
            assert!(bad.validate().unwrap_err().contains("readmit_share"));
        }
        let bad = FinalFitOptions {
            readmit_share: 0.5,
            readmit_count: 0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("readmit_count"));
        // The default since the twenty-ninth session: on, gated by the Cauchy climb prior.
        let d = FinalFitOptions::default();
        assert_eq!(
            (d.readmit_share, d.readmit_count, d.readmit_skip_cauchy),
            (0.5, 8, true)
        );
        let bad = FinalFitOptions {
            inlier_sigmas: 0.0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("inlier_sigmas"));
        let bad = FinalFitOptions {
            prior_min_scales: -1.0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("prior_min_scales"));
        let bad = FinalFitOptions {
            passes: 0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("passes"));
        let o: FinalFitOptions = toml::from_str("prior_min_scales = 0.0\npasses = 2").unwrap();
        assert_eq!((o.prior_min_scales, o.passes), (0.0, 2));
        let bad = FinalFitOptions {
            cheirality_sigmas: -1.0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("cheirality_sigmas"));
        let o: FinalFitOptions = toml::from_str("cauchy_sigmas = 0.0").unwrap();
        assert_eq!(o.cauchy_sigmas, 0.0);
        let bad = FinalFitOptions {
            learnt_parallax_cap: f64::NAN,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("learnt_parallax_cap"));
        let bad = FinalFitOptions {
            learnt_cauchy_max: -1.0,
            ..FinalFitOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("learnt_cauchy_max"));
        let o: FinalFitOptions = toml::from_str("learnt_parallax_cap = 0.4").unwrap();
        assert!(o.learnt_parallax_cap == 0.4 && o.validate().is_ok());
        assert!(!FinalFitOptions::default().one_step);
        let o: FinalFitOptions = toml::from_str("one_step = true").unwrap();
        assert!(o.one_step && o.validate().is_ok());
        assert!(toml::from_str::<FinalFitOptions>("cauchy = 1.0").is_err());
        // The stage's own metric, by registered name.
        let o: FinalFitOptions = toml::from_str("metric = \"angle_plane_ml\"").unwrap();
        assert!(o.validate().is_ok());
        assert!(o.metric_spec().unwrap().is_some());
        assert!(FinalFitOptions::default().metric_spec().unwrap().is_none());
        // Unset, the stage takes the metric the first stage's names for it: angle_plane_ml
        // after angle_plane; after a metric that names none, that metric itself.
        let angle: Box<dyn MetricSpec> =
            serde_json::from_value(serde_json::json!({ "type": "angle_plane" })).unwrap();
        let sampson: Box<dyn MetricSpec> =
            serde_json::from_value(serde_json::json!({ "type": "sampson" })).unwrap();
        let d = FinalFitOptions::default();
        assert!(d.enabled);
        let after_angle = d.resolved_metric_spec(angle.as_ref()).unwrap().unwrap();
        assert_eq!(
            serde_json::to_value(&after_angle).unwrap()["type"],
            "angle_plane_ml"
        );
        assert!(d.resolved_metric_spec(sampson.as_ref()).unwrap().is_none());
        let explicit: FinalFitOptions = toml::from_str("metric = \"angle_plane\"").unwrap();
        let e = explicit
            .resolved_metric_spec(angle.as_ref())
            .unwrap()
            .unwrap();
        assert_eq!(serde_json::to_value(&e).unwrap()["type"], "angle_plane");
        let o: FinalFitOptions = toml::from_str("metric = \"no_such_metric\"").unwrap();
        let e = o.validate().unwrap_err();
        assert!(
            e.contains("final_fit.metric") && e.contains("no_such_metric"),
            "{e}"
        );
    }
}
