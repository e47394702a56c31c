//! Motion separation: tell the static world from large moving objects (issue 14), as an
//! optional stage after each frame's solve (`odometry.separate`, off by default).
//!
//! Given the frame's solution A (the usual robust solve):
//! 1. **Support**: every match's epipolar angle under A (the mean of the angles of `f1` from the
//!    epipolar plane of `f0` and of `f0` from that of `f1`, radians); A's support are the
//!    matches below [`SeparateOptions::threshold`].
//! 2. **Sequential fitting**: if at least [`SeparateOptions::min_fraction`] of the matches lie
//!    outside A's support, a second motion B is fitted to them alone (starts: straight ahead, the
//!    frame's start and the restart yaw offsets; the lowest cost wins) and its support is scored
//!    on all matches.
//! 3. **Choice by vehicle plausibility, then spatial support**: the two motions *compete* when
//!    B's support holds at least `min_fraction` of the matches. If the model is soft (it has
//!    prior residuals, e.g. `soft_single_track`'s side slip and climb in units of their sigmas)
//!    and the two motions' squared distances to the soft prior's centre (learnt over the
//!    trusted frames) differ by more than [`SeparateOptions::plausibility_margin`], the more
//!    plausible one wins: the apparent motion of a vehicle ahead or a crossing truck is rarely
//!    one the ego vehicle can make. Otherwise each motion's support is counted in image cells
//!    (a [`SeparateOptions::grid`] grid per camera, a cell counts if it holds at least one
//!    supporting match) so that a compact object cannot outweigh a spread-out static scene; B
//!    replaces A if it covers more cells.
//!    With [`SeparateOptions::hypotheses`] set, the choice is made over frames by the
//!    parallax of each motion's support instead ([`crate::hypotheses`]; the rule above decides
//!    only when that cue does not apply).
//! 4. **Final efficient stage**: the chosen motion is re-solved on its support alone with plain
//!    least squares (the trivial loss), the maximum-likelihood estimate of the static matches
//!    under Gaussian noise ([`SeparateOptions::final_robust`]: the frame's robust loss instead).
//!    With [`SeparateOptions::under_road`] (and odometry) the support first loses the matches
//!    that lie under the road ([`crate::hypotheses::under_road_mask`]): objects moving with the
//!    ego vehicle fit the static motion like points at infinity, but a static point below the
//!    horizon is no farther than the road.

use crate::hypotheses::{
    HypothesesOptions, Hypothesis, HypothesisTracker, MatchMemory, TiltReference, UnderRoad,
    ground_mask, score, under_road_mask,
};
use momo_core::{
    FrameEstimator, FrameObservations, FrameSolution, MotionPrior, Pose, RobustLoss, SolveRequest,
    Solver, TrivialLoss, camera_motion, essential,
};
use momo_core::{Rig, Termination};
use serde::{Deserialize, Serialize};

/// Options of the motion separation (`[odometry.separate]` in the TOML config). A config
/// section deserializes over [`SeparateOptions::competition_over_time`] (the default
/// configuration's separation): the fields it omits keep that separation's values, not
/// [`SeparateOptions::default`]'s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    default = "SeparateOptions::competition_over_time",
    deny_unknown_fields
)]
pub struct SeparateOptions {
    /// Run the separation (false: the frame's solve and `[odometry.final_fit]` alone, as
    /// before 2026-11-28).
    pub enabled: bool,
    /// Support threshold on the epipolar angle, radians (0.003 ≈ 2.2 px at f = 718 px).
    pub threshold: f64,
    /// Fit a second motion when at least this fraction of the matches lies outside the first
    /// motion's support; the motions compete when the second one's support is that large.
    pub min_fraction: f64,
    /// Cells per camera image (columns, rows) of the spatial support.
    pub grid: (usize, usize),
    /// Run the final least-squares stage on the chosen support.
    pub final_stage: bool,
    /// The final stage keeps the frame's robust loss (on the chosen support) instead of plain
    /// least squares: real matches have heavier tails than the simulator's Gaussian noise.
    pub final_robust: bool,
    /// Fit and choose between two motions (off: only the final stage on A's support).
    pub second_motion: bool,
    /// Soft models: the more plausible motion wins when the two motions' squared distances to
    /// the soft prior's centre (sum of squared prior residuals, in sigma units) differ by more
    /// than this; a negative value turns the plausibility test off (cells only).
    pub plausibility_margin: f64,
    /// The multi-frame choice between the two motions by their parallax
    /// ([`crate::hypotheses`], `[odometry.separate.hypotheses]`); none by default.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hypotheses: Option<HypothesesOptions>,
    /// Spatial plausibility of a switch: the alternative replaces A only if its support covers
    /// at least this fraction of the image cells ([`SeparateOptions::grid`]) A's support
    /// covers (0: no such test). A compact object cannot be the static world.
    pub min_cell_ratio: f64,
    /// When two motions competed, the final stage leaves out the matches the rejected motion
    /// also explains (object points near the focus of expansion fit the static motion within
    /// the threshold and bias it); not applied if fewer than half of the chosen support remain.
    pub final_exclusive: bool,
    /// Run the final stage only in frames where two motions competed (elsewhere the frame's
    /// solve stands): on static scenes the support's threshold cuts the noise tail of the
    /// static matches (wide-angle cameras, heavy outliers) and costs efficiency.
    pub final_competing_only: bool,
    /// Passes of the final stage: each later pass re-selects the support under the previous
    /// pass's motion (at least 1).
    pub final_passes: usize,
    /// On one camera, the final stage leaves out the matches "under the road" (0: off): seen
    /// below the horizon, with an inverse range (triangulated under the chosen motion at the
    /// odometry's scale) smaller than the road plane allows by more than this many standard
    /// deviations of its parallax noise ([`crate::hypotheses::under_road_mask`]): objects
    /// moving with the ego vehicle, which fit the static motion like points at infinity. Needs
    /// odometry; not applied if fewer than half of the matches it would test remain. With
    /// [`SeparateOptions::final_fit`] (the default's stage) the test runs on the matches the
    /// stage is given (the chosen support where two motions competed, else all, after the
    /// image-region cap), at the chosen motion, and on one camera guarded
    /// ([`SeparateOptions::under_road_guard`]). 0 in [`SeparateOptions::default`], 3 in
    /// [`SeparateOptions::competition_over_time`] since the sixty-fourth session (moving-traffic
    /// family, 1 px, eight sets of 60-120 sequences: frames above 1 deg 17 -> 12, all flagged;
    /// mean efficiency 0.3-1.2 % better on each set; docs/RESULTS.md, sixty-fourth session).
    /// Unguarded (the
    /// sixty-third session) it raised frames above 1 deg (grid 0 -> 1, dev 2 -> 7: a lock-in
    /// prolonged).
    pub under_road: f64,
    /// [`SeparateOptions::under_road`] on a rig of several cameras
    /// ([`SeparateOptions::under_road_factor`]; 0: off). 0 in [`SeparateOptions::default`], 3
    /// in [`SeparateOptions::competition_over_time`] since the sixty-third session: the
    /// surround rig's side and rear cameras see the vehicles that move with the ego vehicle
    /// away from their focus of expansion, where the test has power (rig with traffic, 180
    /// sequences at 1 px: frames above 1 deg 4 -> 0, median efficiency 1.330 / 1.385 / 1.335 /
    /// 1.380 -> 1.320 / 1.385 / 1.330 / 1.360, 98 sequences better and 52 worse).
    pub under_road_rig: f64,
    /// On one camera the under-the-road test ([`SeparateOptions::under_road`]) is guarded
    /// (default true since the sixty-fourth session; a rig's test is not): it acts only after
    /// a moving frame of the run whose separation saw no second motion compete (the
    /// separation's own reading of a settled start, not the trust module's flags), and it is
    /// one of the final stage's
    /// support tests that `odometry.final_fit.neighbour_guard` checks: where the stage without
    /// the matches they leave out turns more than that angle from the stage on the matches the
    /// separation handed it, the frame keeps the latter. Under a motion locked onto a vehicle
    /// the test takes the static road out and holds the lock (unguarded, `under_road = 3`:
    /// moving-traffic dev 2 -> 7 frames above 1 deg, grid 0 -> 1 at a run's start); guarded,
    /// dev / grid / hold-out have 0 / 0 / 0 (2 / 0 / 0 without the test; docs/RESULTS.md,
    /// sixty-fourth session).
    pub under_road_guard: bool,
    /// The bearing noise (radians) of the under-the-road test.
    pub under_road_noise: f64,
    /// The road's slope margin (radians) of the under-the-road test: the road may descend
    /// away from the vehicle by this much.
    pub under_road_slope: f64,
    /// The support threshold in units of the frame's noise `σ̂` instead of the fixed
    /// [`SeparateOptions::threshold`] (0: the fixed one). `σ̂ = 1.4826 · median` of the
    /// epipolar angles under A, trimmed as the final stage trims its residuals
    /// ([`crate::final_fit::estimate_sigma`]): a fixed angle is below the noise of some rigs
    /// (0.003 rad is 1 px at f = 330 px), and the noise tail of a static scene then looks like a
    /// second motion.
    pub threshold_sigmas: f64,
    /// A second motion competes only if at least `min_fraction` of the matches are its *own*:
    /// in its support and at least this many `σ̂` from A (epipolar angle under A; 0: counted
    /// over all matches, the support of B may then be A's noise tail).
    pub distinct_sigmas: f64,
    /// The final stage is the default's efficient stage (`[odometry.final_fit]`, its metric,
    /// noise estimate and motion prior) instead of the separation's own: in a frame where two
    /// motions competed it refits the chosen motion on the chosen support only; elsewhere it
    /// runs as without the separation (the separation's own final stage is then skipped).
    pub final_fit: bool,
    /// A second motion competes only if its own matches (in its support, outside A's) are
    /// spatially coherent: they hold at least this share of all the matches in the image cells
    /// ([`SeparateOptions::grid`]) they occupy (0: no such test). An object, or the static
    /// world around a locked-in object, fills its cells; the noise tail of a static scene
    /// (matches just outside A's support, wherever the noise is largest) is a minority in
    /// every cell.
    pub coherence: f64,
    /// A second motion competes only if A keeps at least `min_fraction` of the matches as its
    /// own too (in A's support, outside the second motion's): two motions exclude each other's
    /// matches, while a motion fitted to A's noise tail is A perturbed and explains nearly all
    /// of A's support.
    pub mutual: bool,
    /// With [`SeparateOptions::final_fit`], a frame where two motions competed still gets the
    /// separation's own final stage (on the chosen support, without the motion prior); only
    /// the other frames get `[odometry.final_fit]`.
    pub final_own_when_competing: bool,
    /// Per-match memory across frames by image position ([`crate::hypotheses::MatchMemory`]):
    /// the previous frame pair's second-image matches are labelled static (in the chosen
    /// motion's support) or other; the current pair's first-image matches take the label of
    /// their nearest previous match in the same camera within this many pixels (0: off). A
    /// motion fitted to the remembered-static matches is one more alternative to A.
    pub memory_radius: f64,
    /// With the memory, the final stage of a competing frame leaves out the remembered-other
    /// matches (not applied if fewer than half of the support remain).
    pub memory_exclude: bool,
    /// With [`SeparateOptions::memory_exclude`] and [`SeparateOptions::final_fit`], the final
    /// stage of a frame where no second motion competed leaves out the remembered-other
    /// matches too (not applied if fewer than half of the matches remain): on the rig with
    /// traffic all around, objects whose flow fits the static epipolar geometry pass the final
    /// stage's residual test and sit in its support (docs/RESULTS.md §9, twenty-eighth
    /// session, support42). false (the default): such a frame's final stage runs on all
    /// matches.
    pub memory_exclude_quiet: bool,
    /// Competition over time (0: off; needs [`SeparateOptions::memory_radius`]): a second
    /// motion competes only if the split of the matches between it and A persists from the
    /// previous frame pair, i.e. its [`persistence`] (how far the memory's static / other
    /// labels follow the split) is at least this (0 to 1). An object stays "other" in the
    /// memory over consecutive frames; the noise tail of a static rig is re-drawn every frame
    /// and its labels follow no split. Without a memory (the first frame, after a reset) no
    /// second motion competes.
    pub persistence: f64,
    /// The match memory labels the matches by the frame's *final* motion (after
    /// `[odometry.final_fit]`; static: within [`SeparateOptions::threshold`] of it) instead of
    /// the chosen motion's first-stage support: a first stage biased the same way in
    /// consecutive frames (near points off its direction of travel) leaves the same matches
    /// outside its support frame after frame, which [`SeparateOptions::persistence`] would take
    /// for an object; the final motion explains them.
    pub memory_final: bool,
    /// With [`SeparateOptions::persistence`] (no effect where that is 0): an alternative whose split the memory does not
    /// follow that far still competes if its *own* matches (in its support, outside A's) hold
    /// at least this share of all the frame's matches and its persistence is at least
    /// [`SeparateOptions::own_persistence`] (0: off; 0.1 in
    /// [`SeparateOptions::competition_over_time`], the default configuration's). A motion fitted to a
    /// static scene's noise tail explains only a part of the matches outside A's support (at
    /// most 7-8 % of the matches on the fisheye rig and with 30 % mismatches along KITTI 00),
    /// an object holding 30-70 % of the matches often more. Not everywhere: with 30 %
    /// mismatches along KITTI 08 such motions reach 21 % (docs/RESULTS.md §9, eleventh
    /// session), hence the persistence floor.
    pub own_share: f64,
    /// The persistence an alternative needs where its own matches hold at least
    /// [`SeparateOptions::own_share`] of the matches (instead of
    /// [`SeparateOptions::persistence`]; 0: none, and then such an alternative competes even
    /// without a memory).
    pub own_persistence: f64,
    /// Image-region balance of the final stage (0: off; needs [`SeparateOptions::final_fit`]):
    /// the matches handed to `[odometry.final_fit]` (all of them, or the chosen support where
    /// two motions competed) keep at most `ceil(cell_cap · m)` matches per image cell
    /// ([`SeparateOptions::cell_cap_grid`] per camera, frame k-1 pixels), `m` the median count
    /// of the camera's occupied cells, at least [`CELL_CAP_MIN`] ([`cell_capped`]). A compact
    /// object near the focus of expansion fits the static motion's epipolar geometry like
    /// far points and, holding half the matches, biases the rotation; a spread-out static
    /// scene has few cells far above its median. 2 in
    /// [`SeparateOptions::competition_over_time`] (the default configuration's) since the
    /// twelfth session; 0 in [`SeparateOptions::default`].
    pub cell_cap: f64,
    /// On a rig of several cameras the cap's factor is `cell_cap · cell_cap_rig_scale`
    /// ([`SeparateOptions::cell_cap_factor`]), where the gate
    /// ([`SeparateOptions::cell_cap_min_share`]) still reads the cap at `cell_cap`
    /// ([`gated_cap`]); positive; 1 in [`SeparateOptions::default`], 0.5 in
    /// [`SeparateOptions::competition_over_time`] since the sixty-first session. A surround
    /// rig's fisheye cells hold few static matches each (1.3 per occupied cell on two rig
    /// sequences with traffic, against 1.5-2.2 for the single KITTI-like camera), so the cap at
    /// 2 x the median (4 there) left the vehicles' dense cells much of their weight; at half
    /// the factor (2 there) 166 of 180 rig traffic sequences measured better
    /// (docs/RESULTS.md §9, sixty-first session).
    pub cell_cap_rig_scale: f64,
    /// The grid (columns, rows) per camera image of [`SeparateOptions::cell_cap`].
    pub cell_cap_grid: (usize, usize),
    /// With [`SeparateOptions::cell_cap`], the frame's first motion A is also re-solved on the
    /// capped matches (from A, the frame's loss and motion prior) before the separation
    /// computes its supports and the match memory: the objects near the focus of expansion
    /// then bias neither the support nor the labels. A keeps its inlier mask, cost and normal
    /// matrix (they index and describe all matches).
    pub cell_cap_first: bool,
    /// [`SeparateOptions::cell_cap`] acts only in a frame where the cap would leave out at
    /// least this share of the matches it is applied to (0: in every frame). Static scenes
    /// are spread out: the cap at 2 leaves out at most 15 % of a frame's matches on the
    /// simulated static scenarios and 2 % on real KITTI 00, against a median 37 % on the
    /// moving-traffic family (docs/RESULTS.md §9, twelfth session).
    pub cell_cap_min_share: f64,
    /// Competition by the ground cue (0: off; needs [`SeparateOptions::persistence`] and the
    /// multi-frame choice, [`SeparateOptions::hypotheses`]): an alternative whose split the
    /// memory does not follow (its [`persistence`] below what
    /// [`SeparateOptions::persistence`] / [`SeparateOptions::own_persistence`] ask) still
    /// competes if its own matches (in its support, outside A's) hold at least
    /// [`SeparateOptions::own_share`] of the frame's matches and its score of the multi-frame
    /// choice ([`crate::hypotheses::score`]: the image cells of its road points with the
    /// default's `spread_grid`) is at least [`SeparateOptions::ground_admit_min`] and at least
    /// this factor times A's. A bus driving with the ego vehicle fits the static motion near
    /// the focus of expansion: the memory of a frame solved right labels it static, so where
    /// the next frame's first motion A follows the bus, the split between A and the static
    /// motion does not persist in the memory and competition over time rejects the static
    /// motion, whose road is spread over the lower image while the bus hides the road from A
    /// (docs/RESULTS.md §9, fifteenth session). 2 in
    /// [`SeparateOptions::competition_over_time`] (the default configuration's) since the
    /// fifteenth session; 0 in [`SeparateOptions::default`].
    pub ground_admit: f64,
    /// The least score (image cells) of an alternative admitted by
    /// [`SeparateOptions::ground_admit`].
    pub ground_admit_min: usize,
    /// The least share of the frame's matches that an alternative's own matches (in its
    /// support, outside A's) must hold to be admitted by [`SeparateOptions::ground_admit`]
    /// (0: [`SeparateOptions::own_share`], as before this option). A slow pull's static
    /// motion C or M can have a clear ground score (15-24 cells against A's 1-6) with only
    /// 24-29 own matches of 300 (docs/RESULTS.md §9, seventeenth session). Off (0) by default.
    pub ground_admit_own_share: f64,
    /// The second motion B is solved from one start first, the one of least cost `½ Σ ρ(|r|²)`
    /// on the matches outside A's support (one evaluation per start), and from the other
    /// starts only if that solve fails or its support fails the tests (then, as without this
    /// option, the lowest final cost over all starts wins). Off by default: B's lowest cost
    /// over the starts decides which local minimum B is; measured in docs/RESULTS.md §8
    /// (sixteenth session, rig30).
    pub candidate_one_start: bool,
    /// B screened from one start (0: off; in `(0, 1]`; needs
    /// [`SeparateOptions::persistence`]): B is solved first from the start of least cost
    /// `½ Σ ρ(|r|²)` on the matches outside A's support (one evaluation per start), and where
    /// that B's support is far from being kept by competition over time, the other starts are
    /// not solved and B is no alternative. "Far" is the test of competition over time with
    /// every threshold times this factor: persistence below `f · persistence`, and either its
    /// own matches (in its support, outside A's) below `f · own_share` of the frame's or its
    /// persistence below `f · own_persistence` with its ground score (where `ground_admit` is
    /// on) below `f · ground_admit_min` or `f · ground_admit` times A's. Elsewhere (the screened
    /// B near being kept, or its solve failed) B is solved from every start as without the
    /// option (the first solve reused), so the estimate differs from the default's only where
    /// the start of least cost gives a B far from being kept and another start one that is
    /// kept. On a static rig B is fitted to the noise tail every frame and rejected
    /// (docs/RESULTS.md §8, sixteenth session, rig30); an object's B is near or above the
    /// thresholds. Off by default: measured in docs/RESULTS.md §8 (seventeenth session,
    /// speed31), `f = 0.5` takes a third of the rigs' instructions (callgrind, whole process:
    /// fisheye 28.5 -> 19.0, wide-angle 22.3 -> 15.8 M per pair; seed 1 byte-identical) but
    /// moves lock-ins on the moving-traffic grid (120 sequences: 48 -> 52 frames above 1 deg,
    /// mean eff 1.3128 -> 1.3142); `f = 0.25` saves nothing on the rigs (B's own matches reach
    /// a quarter of `own_share`, and the ground test's thresholds scale with it).
    pub candidate_screen: f64,
    /// The most iterations of the alternatives' solves (B, C and M; 0: the solver's
    /// `max_iterations`): they are solved for their support, which a pose short of the
    /// optimum already gives. Applied where the configured solver has `max_iterations`
    /// (Levenberg-Marquardt). Off by default; measured in docs/RESULTS.md §8 (sixteenth
    /// session, rig30).
    pub candidate_max_iterations: usize,
    /// The function tolerance of the alternatives' solves (B, C and M; 0: the solver's
    /// `function_tolerance`, which a larger value replaces): see
    /// [`SeparateOptions::candidate_max_iterations`]. Off by default.
    pub candidate_function_tolerance: f64,
    /// The longest step lengthening of the alternatives' solves (B, C and M; 0: the solver's
    /// [`max_step_extrapolation`](momo_solvers::LevenbergMarquardt::max_step_extrapolation),
    /// which a larger value replaces; at least 1 otherwise): after an accepted step `s` the
    /// next trial is `t δ`, `t = κ_m / κ` clamped to `[1, this]`, with `κ_m = sᵀHs` the Gauss-
    /// Newton model's curvature along `s` and `κ = 2 (c' − c − gᵀs)` the cost's own (the
    /// minimum along `δ` of a quadratic with the measured curvature). B is a robust fit of
    /// the matches outside A's support, on a static scene their noise tail, where the Cauchy
    /// loss is flat and the iteratively re-weighted steps converge linearly (20-26 iterations
    /// per start on the rigs, docs/RESULTS.md "Speed", twentieth session, rig34): the model
    /// overestimates the curvature and a lengthened step covers several of them. Off by
    /// default: it moves B's iterates, hence which local minimum is of least cost in some
    /// frames; measured in docs/RESULTS.md ("Speed", twenty-first session, rigB35).
    pub candidate_max_step_extrapolation: f64,
    /// The memory's vote in the multi-frame choice (0: off; needs
    /// [`SeparateOptions::memory_radius`] and [`SeparateOptions::hypotheses`]): where the
    /// ground scores of A and the best alternative B ([`crate::hypotheses::score`], `s_A`,
    /// `s_B`) are not decisive — neither is at least [`SeparateOptions::ground_admit_min`] and
    /// at least [`SeparateOptions::memory_vote_ground`] times the other — and both supports
    /// hold at least [`SeparateOptions::memory_vote_min`] matches the memory labels, B
    /// replaces A also where the ground does not choose it if the remembered-static shares
    /// `f = static / (static + other)` of the supports differ by `f_B - f_A >= memory_vote` and
    /// B's own matches (in its support, outside A's) hold [`SeparateOptions::own_share`] of
    /// the frame's (M, the previous motion re-solved on the remembered-static matches, is
    /// remembered-static by construction and its support mostly A's). A first motion that
    /// follows a co-moving bus has a support the memory of a frame solved right labels mostly
    /// other, while the static motion's road is hidden: both ground scores are a few cells
    /// (e.g. 0 against 9, below the choice's `min_matches`, or 4 against 4). The vote only
    /// adds switches: keeping A by the memory against the ground's switch (measured too) held
    /// lock-ins the memory had learnt (docs/RESULTS.md §9, sixteenth session). 0.3 in
    /// [`SeparateOptions::competition_over_time`] (the default's separation, since the
    /// sixteenth session: moving-traffic grid 55 -> 48 frames above 1 deg, fresh seeds 11-15
    /// 59 -> 41, no sequence of those with more; the static scenarios and real KITTI 00
    /// byte-identical), 0 (off) in [`SeparateOptions::default`].
    pub memory_vote: f64,
    /// The ratio of ground scores above which the ground decides alone, for
    /// [`SeparateOptions::memory_vote`].
    pub memory_vote_ground: f64,
    /// The least number of labelled matches in each support for
    /// [`SeparateOptions::memory_vote`].
    pub memory_vote_min: usize,
    /// Offer the road track T ([`crate::road_track`]) as a further alternative (needs
    /// [`SeparateOptions::hypotheses`] and odometry, as C): the motion re-solved on the matches
    /// its start puts on the road, started from the previous frame's T where T's road score
    /// beat the chosen motion's, so that a slow pull of the chosen motion (a lead vehicle or a
    /// bus it follows part of the way) does not carry it. T competes as C does. Off by
    /// default; measured in docs/RESULTS.md §9 (seventeenth session, pull31).
    pub road_track: bool,
    /// Flag a frame `weak` / `road_score_drop` where its chosen motion's road score
    /// ([`crate::hypotheses::score`]) is at most this fraction of the median of the last 20
    /// frames' (0: off; needs [`SeparateOptions::hypotheses`]; [`crate::ground_drop`]): a
    /// motion that follows a vehicle ahead puts few road points on the road. As any weak frame
    /// it does not centre the next frame's prior. Off by default; measured in
    /// docs/RESULTS.md §9 (seventeenth session, pull31).
    pub ground_drop: f64,
    /// The least median road score (image cells) of the recent frames for
    /// [`SeparateOptions::ground_drop`]: a scene without a visible road is never flagged.
    pub ground_drop_min: usize,
    /// Offer a second B, the local minimum with the most road (needs
    /// [`SeparateOptions::hypotheses`]): of B's solutions from its starts (each a local minimum
    /// of `½ Σ ρ(|r|²)` on the matches outside A's support), besides the one of least cost,
    /// the one whose support (where it passes B's tests) has the highest score of the
    /// multi-frame choice ([`crate::hypotheses::score`]: the image cells of its road points),
    /// if that score exceeds A's and the least-cost B's (a local minimum with less road than A
    /// is no static world that A missed). The solves are B's own (no further solve).
    /// Where A follows a lead vehicle or a bus, the matches outside A's support are the rest
    /// of the static world *and* another object; the object's tighter cluster has the lower
    /// cost, the static world the road: in 7 of the 9 grid frames above 1 deg where no
    /// candidate was within 1 deg, another start's B was (docs/RESULTS.md §9, eighteenth
    /// session, cand32). It competes as B does. Off here; on in the default separation
    /// ([`SeparateOptions::competition_over_time`], since the eighteenth session: grid 33 -> 17
    /// frames above 1 deg, hold-out 27 -> 15, the static scenes and real KITTI 00
    /// byte-identical, +1.4 % instructions on the family).
    pub candidate_by_road: bool,
    /// B is fitted to the matches outside A's support that the match memory does not
    /// remember as the other motion (with [`SeparateOptions::memory_radius`]; where at least
    /// 12 remain): the previous frame's object is left out of B's fit, so that B does not
    /// converge to it again. B's support is still scored on all matches. Off by default.
    pub candidate_forget_other: bool,
    /// B's starts are solved on at most this many (`K`) of the matches outside A's support (0: all
    /// of them): a spread subsample, the `i`-th of the `m` matches B is fitted to (in the frame's
    /// order, camera by camera) kept where `i K mod m < K`, K evenly spaced ones. B's solutions
    /// (their costs, hence which one is least, and their supports on all matches, hence the road
    /// scores of [`SeparateOptions::candidate_by_road`]) are those of the subsample; the least-cost
    /// B and the local minimum with the most road, where they go on to the tests, are then solved
    /// again on all the matches outside A's support, each started from its subsample solution
    /// (which stands where that solve fails), and tested again. A linearisation of B's solves costs
    /// about `K / m` of one on all of them, plus the rig's per-camera set-up. Off by default: it
    /// changes which local minimum B is where the subsample's costs rank the starts otherwise, and
    /// the final B's digits everywhere; measured in docs/RESULTS.md ("Speed", twentieth session,
    /// rig34).
    pub candidate_subsample: usize,
    /// The second motion B's solves keep the frame prior's learnt soft part where the learnt
    /// centre is more than this many model sigmas (`T`) from the model's 0 (0: off). B is solved
    /// without the frame's motion prior (it may be another object's motion): a soft model's
    /// prior then falls back to its model centre 0 at the model's sigma. Where the odometry has
    /// learnt that the vehicle's motion sits elsewhere (KITTI 08's slow start: the ground
    /// truth's chord climbs by about 0.2 rad, 18 model sigmas, relative to a level body), every
    /// B is pinned near climb 0 (dev3 08 s46: no candidate within 0.5 deg of the static
    /// matches' motion while a vehicle held the first motion). With `T > 0`, where any residual listed in
    /// [`SeparateOptions::second_soft_prior_residuals`] has a learnt centre `|c_i| > T`
    /// ([`MotionPrior::soft_center`], model sigma units), B's solves (its starts and, with
    /// [`SeparateOptions::candidate_subsample`], its refit) take the frame prior's soft centre,
    /// learnt sigmas, Cauchy scales and unit, and still no per-parameter or rotation-change prior
    /// ([`second_motion_prior`]). The other candidates (the road's alternative, the static-label
    /// motion, the predictions) stay without a prior. Off here; 1 in
    /// [`SeparateOptions::competition_over_time`] (the default's separation, since the
    /// thirty-eighth session); measured in docs/RESULTS.md §9 (thirty-eighth session, softb52).
    pub second_soft_prior: f64,
    /// The soft prior residuals whose learnt centre [`SeparateOptions::second_soft_prior`]
    /// tests (indices into [`momo_core::Manifold::prior_residuals`]; `[1]`, the soft single
    /// track's climb; an index the model does not have is never met).
    pub second_soft_prior_residuals: Vec<usize>,
    /// The frame's match count (over all cameras) `N` at which the separation's evidence counts
    /// hold as written (0: always as written): in a frame with `n < N` matches,
    /// [`SeparateOptions::ground_admit_min`] (the ground cue's least road score, in image cells),
    /// [`SeparateOptions::memory_vote_min`] and [`HypothesesOptions::track_min_labelled`] (the
    /// least labelled matches of the memory's tests) and [`HypothesesOptions::min_matches`] (the
    /// least road score of the road's tests in the multi-frame choice) are scaled by `n / N`
    /// (rounded up, at least 1; [`SeparateOptions::for_matches`]). Road cells and labelled
    /// matches shrink with the frame's matches, so counts chosen on 300-match frames shut the
    /// road and the memory out of the choice in a frame of 100 (a bus crossing at constant flow,
    /// 60 of 100 matches, then passes for a yaw). The two gates that decide whether a scene
    /// shows a road at all stay as written: [`SeparateOptions::ground_drop_min`] and the road
    /// guard's [`HypothesesOptions::road_visible_min`] (`min_matches` as written); scaled, a
    /// scene without a road (matches on the horizon row, random scene points) passes them by
    /// chance, and `ground_drop` or the road guard act there (four of `momo-vo`'s integration
    /// tests fail). 0 (off) in [`SeparateOptions::default`], 300 in
    /// [`SeparateOptions::competition_over_time`] (the default's separation, since the
    /// thirty-fifth session: the frames those counts were chosen on hold 300 matches, so they
    /// and every frame with more are solved as before; `min_matches` scaled too since the
    /// thirty-sixth); measured in docs/RESULTS.md §9 (thirty-fifth session, scale49, and
    /// thirty-sixth, scale50).
    pub count_reference: usize,
    /// Candidates from the matches' yaw votes ([`crate::yaw_votes`]; 0: off, else the most
    /// modes used): the previous frame's motion turned about the vehicle's vertical axis by
    /// each offset `δ` of a grid ([`SeparateOptions::yaw_votes_range`],
    /// [`SeparateOptions::yaw_votes_step`]); every match votes for the offset of its least
    /// epipolar angle where that is below [`SeparateOptions::threshold`] and its angle varies
    /// by more than [`SeparateOptions::yaw_votes_informative`] over the grid; the votes are
    /// summed over ±2 grid steps. Each of the strongest modes with at least
    /// [`SeparateOptions::yaw_votes_min`] votes (at least 5 steps from a stronger one kept, and
    /// more than 3 steps from A's own yaw offset) gives one alternative: its turned motion
    /// re-solved (robust loss, without the motion prior) on its support, kept where it is
    /// *distinct* from A as C and M are (its own matches, outside A's support, at least a third
    /// of `min_fraction`'s count, and its support at least that count). It then competes as every
    /// alternative does. At the start of a turn behind a bus or a cut-in car the objects hold
    /// most of the matches and the sequential fit B (on the matches outside A's support) lands
    /// on them or between the motions; the static world's informative matches still vote
    /// together, for a larger yaw. Solved only where an alternative could still be kept (the
    /// same pre-tests as B's). 0 (off) in [`SeparateOptions::default`], 3 in
    /// [`SeparateOptions::competition_over_time`] (the default's separation: 2 since the
    /// thirty-ninth session, with [`HypothesesOptions::yaw_history_final`], 3 since the
    /// fortieth, where a turn's static mode was the third strongest); measured in
    /// docs/RESULTS.md §9 (thirty-ninth session, votes53; fortieth, votes55).
    pub yaw_votes: usize,
    /// The grid's half-range (radians; 3 deg).
    pub yaw_votes_range: f64,
    /// The grid's step (radians; 0.1 deg).
    pub yaw_votes_step: f64,
    /// The least variation of a match's epipolar angle over the grid for it to vote (radians):
    /// a match near the focus of expansion or on a far point fits every offset.
    pub yaw_votes_informative: f64,
    /// The least votes (summed over the window) of a mode; not scaled by
    /// [`SeparateOptions::count_reference`].
    pub yaw_votes_min: usize,
}

impl Default for SeparateOptions {
    fn default() -> Self {
        Self {
            enabled: true,
            threshold: 0.003,
            min_fraction: 0.15,
            grid: (8, 4),
            final_stage: true,
            final_robust: false,
            second_motion: true,
            plausibility_margin: -1.0,
            hypotheses: None,
            min_cell_ratio: 0.0,
            final_exclusive: false,
            final_competing_only: false,
            final_passes: 1,
            under_road: 0.0,
            under_road_rig: 0.0,
            under_road_guard: true,
            under_road_noise: 0.0014,
            under_road_slope: 0.02,
            threshold_sigmas: 0.0,
            distinct_sigmas: 0.0,
            final_fit: false,
            coherence: 0.0,
            mutual: false,
            final_own_when_competing: false,
            memory_radius: 0.0,
            memory_exclude: false,
            memory_exclude_quiet: false,
            persistence: 0.0,
            memory_final: false,
            own_share: 0.0,
            own_persistence: 0.0,
            cell_cap: 0.0,
            cell_cap_rig_scale: 1.0,
            cell_cap_grid: (16, 8),
            cell_cap_first: false,
            cell_cap_min_share: 0.2,
            ground_admit: 0.0,
            ground_admit_min: 12,
            ground_admit_own_share: 0.0,
            candidate_one_start: false,
            candidate_screen: 0.0,
            candidate_max_iterations: 0,
            candidate_function_tolerance: 0.0,
            candidate_max_step_extrapolation: 0.0,
            memory_vote: 0.0,
            memory_vote_ground: 1.5,
            memory_vote_min: 20,
            road_track: false,
            ground_drop: 0.0,
            ground_drop_min: 8,
            candidate_by_road: false,
            candidate_forget_other: false,
            candidate_subsample: 0,
            second_soft_prior: 0.0,
            second_soft_prior_residuals: vec![1],
            count_reference: 0,
            yaw_votes: 0,
            yaw_votes_range: 3f64.to_radians(),
            yaw_votes_step: 0.1f64.to_radians(),
            yaw_votes_informative: 0.008,
            yaw_votes_min: 12,
        }
    }
}

impl SeparateOptions {
    /// The under-the-road test's threshold in sigmas on a rig of `cameras` cameras:
    /// [`SeparateOptions::under_road`] on one camera, [`SeparateOptions::under_road_rig`] on
    /// several; 0: no test.
    pub fn under_road_factor(&self, cameras: usize) -> f64 {
        if cameras > 1 {
            self.under_road_rig
        } else {
            self.under_road
        }
    }

    /// The factor of the image-region cap ([`SeparateOptions::cell_cap`], [`cell_capped`]) on
    /// a rig of `cameras` cameras: `cell_cap` on one camera, `cell_cap ·
    /// cell_cap_rig_scale` on several; 0: no cap.
    pub fn cell_cap_factor(&self, cameras: usize) -> f64 {
        if cameras > 1 {
            self.cell_cap * self.cell_cap_rig_scale
        } else {
            self.cell_cap
        }
    }

    /// The separation of the default configuration (`[odometry.separate]` when the config
    /// file has no such section; since 2026-11-28): the multi-frame choice by the spread of
    /// the ground support (`hypotheses.spread_grid = [16, 8]`), the robust loss, the default's
    /// final efficient stage (`final_fit`), the match memory at 20 px with its exclusion, and
    /// competition over time (`persistence = 0.4`, or 0.2 where the alternative's own matches
    /// hold at least a tenth of the frame's: `own_share = 0.1`, `own_persistence = 0.2`, since
    /// the eleventh session): a frame whose second motion does not persist in the memory is
    /// solved exactly as without the separation. Since the twelfth session the matches are
    /// balanced over image regions where they cluster (`cell_cap = 2`, `cell_cap_first`,
    /// gated by `cell_cap_min_share = 0.2`): a frame whose matches are spread out is solved as
    /// before; since the sixty-first session a rig of several cameras caps at half that factor
    /// where the gate passes (`cell_cap_rig_scale = 0.5`). Since the fifteenth session a second motion that fails competition over time
    /// still competes where its ground score is at least twice A's (`ground_admit = 2`,
    /// `ground_admit_min = 12`). Since the sixteenth session the match memory's
    /// remembered-static shares may also switch to the alternative where neither ground score
    /// is decisive (`memory_vote = 0.3`). Since the seventeenth session the ground scores are
    /// summed over a lock-in's run by track (`hypotheses.track_decay = 0.7`), the ground cue
    /// admits an alternative with 5 % own matches (`ground_admit_own_share = 0.05`), and a
    /// frame whose chosen motion's road score drops to 0.4 of the recent median is flagged
    /// weak (`ground_drop = 0.4`; docs/RESULTS.md §9, seventeenth session, lead). Since the
    /// eighteenth session B's local minimum with the most road competes beside the least-cost one
    /// (`candidate_by_road`; docs/RESULTS.md §9, eighteenth session, cand32 and lead). Since the
    /// nineteenth session a switch away from the track the memory says continues needs B's road
    /// to span the road's depths (`hypotheses.road_span = 3.4`; docs/RESULTS.md §9, nineteenth
    /// session, choice33). Since the twentieth session an alternative that rolls or pitches more
    /// than 0.01 rad beyond A does not replace A (`hypotheses.tilt_margin = 0.01`, vehicle-model
    /// plausibility; docs/RESULTS.md §9, twentieth session, frames34 and lead). Since the
    /// twenty-first session the converse too, where A's tilt jumps by 0.01 rad from the
    /// previous frame's (`hypotheses.tilt_replace`, `tilt_reference_frames = 1`,
    /// `tilt_reference_margin = 0.01`; docs/RESULTS.md §9, twenty-first session, tilt35), and an
    /// A that jumps more than 7 σ of the rotation prior away from the trusted previous motion's
    /// yaw is replaced by an alternative within 3.5 σ of it (`hypotheses.yaw_jump = 7`;
    /// docs/RESULTS.md §9, twenty-first session, yaw35). Since the twenty-second session the
    /// yaw is also held to the previous frame's chosen yaw whether that frame competed or not:
    /// a switch that jumps by more than 1 deg from it, where A does not, needs a decisive ground
    /// cue, and an A that jumped is replaced by an alternative within 1 deg of it
    /// (`hypotheses.yaw_history_frames = 1`, `yaw_history_margin = 0.01745`,
    /// `yaw_history_replace`; docs/RESULTS.md §9, twenty-second session, curve36), and the
    /// converse's gate measures the jump from the minimum of the last three frames' tilts
    /// where A's road score is below `min_matches` (`hypotheses.tilt_weak_road_frames = 3`;
    /// docs/RESULTS.md §9, twenty-second session, grid36). Since the twenty-fourth session
    /// an A that jumps by more than 1 deg from that yaw where no rule found an alternative and
    /// A lost the road the last ten frames had (A's road score at most 0.4 of their median,
    /// that median at least `min_matches`) is replaced by the previous motion re-solved on its
    /// support, or held to it (`hypotheses.yaw_history_predict = 0.01745`,
    /// `yaw_history_predict_hold`, `yaw_history_predict_road_frames = 10`; docs/RESULTS.md §9,
    /// twenty-fourth session, tail38). Since the twenty-sixth session a chosen motion whose
    /// yaw jumps by more than 0.5 deg (or whose tilt jumps) without road is replaced by the
    /// previous motion re-solved on its support where that prediction's own road score beats
    /// the choice's and every alternative's (`hypotheses.predict_by_road = 0.00873`;
    /// docs/RESULTS.md §9, twenty-fifth session, tail39, and twenty-sixth, road40); since the
    /// seventieth session also where the chosen motion slides sideways by more than 6 of the
    /// model's slip sigmas and the prediction, which does not, has at least as much road
    /// (`hypotheses.predict_by_slip = 6`; docs/RESULTS.md §9, seventieth session, slip85), and
    /// since the seventy-first an alternative that continues the yaw history without sliding
    /// competes with that prediction by road (`hypotheses.predict_by_slip_alternatives`;
    /// docs/RESULTS.md §9, seventy-first session, slip86). Since the
    /// thirty-fifth session the ground cue's, the memory's and (since the thirty-sixth) the
    /// road tests' counts shrink in a frame with fewer than 300 matches (`count_reference =
    /// 300`; docs/RESULTS.md §9, thirty-fifth session, scale49, and thirty-sixth, scale50).
    /// Since the fifty-first session the ordinary choice's near tie of road scores goes to the
    /// alternative that continues the yaw history (`hypotheses.yaw_history_tie = 0.8`;
    /// docs/RESULTS.md §9, fifty-first session, tie66). Since the fifty-fifth session the
    /// road's depth-span hold waits until the road has vouched for a track
    /// (`hypotheses.road_span_vouched = true`; docs/RESULTS.md §9, fifty-fifth session,
    /// vouch70). A
    /// config file's `[odometry.separate]` section starts from it: the fields it omits keep
    /// these values (since the eleventh session; before, they took
    /// [`SeparateOptions::default`], the bare separation). Measured in docs/RESULTS.md §9
    /// (tenth session, sep25).
    pub fn competition_over_time() -> Self {
        Self {
            final_robust: true,
            final_fit: true,
            memory_radius: 20.0,
            memory_exclude: true,
            memory_exclude_quiet: false,
            persistence: 0.4,
            own_share: 0.1,
            own_persistence: 0.2,
            cell_cap: 2.0,
            cell_cap_rig_scale: 0.5,
            under_road: 3.0,
            under_road_rig: 3.0,
            cell_cap_first: true,
            ground_admit: 2.0,
            memory_vote: 0.3,
            ground_admit_own_share: 0.05,
            ground_drop: 0.4,
            candidate_by_road: true,
            second_soft_prior: 1.0,
            count_reference: 300,
            yaw_votes: 3,
            hypotheses: Some(HypothesesOptions {
                spread_grid: Some((16, 8)),
                track_decay: 0.7,
                road_span: 3.4,
                road_span_vouched: true,
                tilt_margin: 0.01,
                yaw_jump: 7.0,
                tilt_replace: true,
                tilt_replace_flattest: true,
                tilt_reference_frames: 3,
                tilt_reference: TiltReference::Minimum,
                tilt_reference_contested: true,
                tilt_reference_margin: 0.01,
                yaw_history_frames: 1,
                yaw_history_margin: 0.01745,
                yaw_history_tie: 0.8,
                yaw_history_slow_margin: (0.00436, 0.01745),
                yaw_history_replace: true,
                yaw_history_final: true,
                tilt_weak_road_frames: 3,
                yaw_history_predict: 0.01745,
                yaw_history_predict_hold: true,
                yaw_history_predict_road_frames: 10,
                predict_by_road: 0.00873,
                predict_by_slip: 6.0,
                predict_by_slip_alternatives: true,
                ..HypothesesOptions::default()
            }),
            ..Self::default()
        }
    }

    /// The own-match share [`SeparateOptions::ground_admit`] asks for:
    /// [`SeparateOptions::ground_admit_own_share`], or [`SeparateOptions::own_share`] where
    /// that is 0.
    fn ground_admit_share(&self) -> f64 {
        if self.ground_admit_own_share > 0.0 {
            self.ground_admit_own_share
        } else {
            self.own_share
        }
    }

    /// These options for a frame of `matches` matches over all cameras: with
    /// [`SeparateOptions::count_reference`] `N > matches`, the four counts it names scaled
    /// by `matches / N` (rounded up, at least 1) and the road guard's gate
    /// ([`HypothesesOptions::road_visible_min`]) held at `min_matches` as written; otherwise
    /// these options unchanged.
    pub fn for_matches(&self, matches: usize) -> std::borrow::Cow<'_, Self> {
        let reference = self.count_reference;
        if reference == 0 || matches >= reference {
            return std::borrow::Cow::Borrowed(self);
        }
        let scale = |t: usize| self.count_scaled(t, matches);
        let mut o = self.clone();
        o.ground_admit_min = scale(o.ground_admit_min);
        o.memory_vote_min = scale(o.memory_vote_min);
        if let Some(h) = o.hypotheses.as_mut() {
            h.road_visible_min = Some(h.road_visible_min.unwrap_or(h.min_matches));
            h.min_matches = scale(h.min_matches);
            h.track_min_labelled = scale(h.track_min_labelled);
        }
        std::borrow::Cow::Owned(o)
    }

    /// The count `t` scaled to a frame of `matches` matches as [`SeparateOptions::for_matches`]
    /// scales its counts: `ceil(t · matches / N)`, at least 1, with
    /// [`SeparateOptions::count_reference`] `N > matches`; `t` otherwise.
    pub fn count_scaled(&self, t: usize, matches: usize) -> usize {
        let reference = self.count_reference;
        if reference == 0 || matches >= reference {
            return t;
        }
        (t * matches).div_ceil(reference).max(1)
    }

    /// The multi-frame choice's options where it is on ([`HypothesesOptions::enabled`]).
    pub fn hypotheses(&self) -> Option<&HypothesesOptions> {
        self.hypotheses.as_ref().filter(|h| h.enabled)
    }

    /// Checks the options; the message names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.threshold.is_finite() && self.threshold > 0.0) {
            return Err("odometry.separate.threshold must be a positive number".into());
        }
        if !(0.0..=1.0).contains(&self.min_fraction) {
            return Err("odometry.separate.min_fraction must be in [0, 1]".into());
        }
        if self.plausibility_margin.is_nan() {
            return Err("odometry.separate.plausibility_margin must be a number".into());
        }
        let cells = self.grid.0.checked_mul(self.grid.1);
        if self.grid.0 == 0 || self.grid.1 == 0 || cells.is_none_or(|c| c > 10_000) {
            return Err("odometry.separate.grid must be (columns, rows), 1 to 10000 cells".into());
        }
        if !(self.min_cell_ratio.is_finite() && self.min_cell_ratio >= 0.0) {
            return Err("odometry.separate.min_cell_ratio must be a non-negative number".into());
        }
        if !(1..=10).contains(&self.final_passes) {
            return Err("odometry.separate.final_passes must be 1 to 10".into());
        }
        if !(self.under_road.is_finite() && self.under_road >= 0.0) {
            return Err("odometry.separate.under_road must be a non-negative number".into());
        }
        if !(self.under_road_rig.is_finite() && self.under_road_rig >= 0.0) {
            return Err("odometry.separate.under_road_rig must be a non-negative number".into());
        }
        if !(self.under_road_noise.is_finite() && self.under_road_noise > 0.0) {
            return Err("odometry.separate.under_road_noise must be a positive number".into());
        }
        if !(self.under_road_slope.is_finite() && self.under_road_slope.abs() < 1.0) {
            return Err("odometry.separate.under_road_slope must be in (-1, 1)".into());
        }
        if !(0.0..=1.0).contains(&self.coherence) {
            return Err("odometry.separate.coherence must be in [0, 1]".into());
        }
        for (name, v) in [
            ("threshold_sigmas", self.threshold_sigmas),
            ("distinct_sigmas", self.distinct_sigmas),
            ("memory_radius", self.memory_radius),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!(
                    "odometry.separate.{name} must be a non-negative number"
                ));
            }
        }
        if !(0.0..=1.0).contains(&self.own_persistence) {
            return Err("odometry.separate.own_persistence must be in [0, 1]".into());
        }
        if !(0.0..=1.0).contains(&self.own_share) {
            return Err("odometry.separate.own_share must be in [0, 1]".into());
        }
        if !(0.0..=1.0).contains(&self.ground_admit_own_share) {
            return Err("odometry.separate.ground_admit_own_share must be in [0, 1]".into());
        }
        if !(self.cell_cap.is_finite() && self.cell_cap >= 0.0) {
            return Err("odometry.separate.cell_cap must be a non-negative number".into());
        }
        if !(self.cell_cap_rig_scale.is_finite() && self.cell_cap_rig_scale > 0.0) {
            return Err("odometry.separate.cell_cap_rig_scale must be a positive number".into());
        }
        let cap_cells = self.cell_cap_grid.0.checked_mul(self.cell_cap_grid.1);
        if self.cell_cap_grid.0 == 0
            || self.cell_cap_grid.1 == 0
            || cap_cells.is_none_or(|c| c > 10_000)
        {
            return Err(
                "odometry.separate.cell_cap_grid must be (columns, rows), 1 to 10000 cells".into(),
            );
        }
        if !(0.0..=1.0).contains(&self.cell_cap_min_share) {
            return Err("odometry.separate.cell_cap_min_share must be in [0, 1]".into());
        }
        if !(self.ground_admit.is_finite() && self.ground_admit >= 0.0) {
            return Err("odometry.separate.ground_admit must be a non-negative number".into());
        }
        if !(self.candidate_function_tolerance.is_finite()
            && self.candidate_function_tolerance >= 0.0)
        {
            return Err(
                "odometry.separate.candidate_function_tolerance must be a non-negative number"
                    .into(),
            );
        }
        if !(self.candidate_max_step_extrapolation == 0.0
            || (self.candidate_max_step_extrapolation.is_finite()
                && self.candidate_max_step_extrapolation >= 1.0))
        {
            return Err(
                "odometry.separate.candidate_max_step_extrapolation must be 0 (off) or a finite number of at least 1"
                    .into(),
            );
        }
        if !(0.0..=1.0).contains(&self.candidate_screen) {
            return Err("odometry.separate.candidate_screen must be in [0, 1]".into());
        }
        if (1..12).contains(&self.candidate_subsample) {
            return Err(
                "odometry.separate.candidate_subsample must be 0 (off) or at least 12".into(),
            );
        }
        if !(self.second_soft_prior.is_finite() && self.second_soft_prior >= 0.0) {
            return Err(
                "odometry.separate.second_soft_prior must be 0 (off) or a positive number".into(),
            );
        }
        if !(self.yaw_votes_range.is_finite()
            && self.yaw_votes_range > 0.0
            && self.yaw_votes_range <= std::f64::consts::FRAC_PI_2)
        {
            return Err("odometry.separate.yaw_votes_range must be in (0, pi/2] radians".into());
        }
        if !(self.yaw_votes_step.is_finite()
            && self.yaw_votes_step > 0.0
            && self.yaw_votes_range / self.yaw_votes_step <= 1000.0)
        {
            return Err(
                "odometry.separate.yaw_votes_step must be positive, at least yaw_votes_range / 1000"
                    .into(),
            );
        }
        if !(self.yaw_votes_informative.is_finite() && self.yaw_votes_informative >= 0.0) {
            return Err(
                "odometry.separate.yaw_votes_informative must be a non-negative number".into(),
            );
        }
        if !(0.0..=1.0).contains(&self.memory_vote) {
            return Err("odometry.separate.memory_vote must be in [0, 1]".into());
        }
        if !(self.memory_vote_ground.is_finite() && self.memory_vote_ground >= 1.0) {
            return Err("odometry.separate.memory_vote_ground must be a number >= 1".into());
        }
        if !(0.0..=1.0).contains(&self.persistence) {
            return Err("odometry.separate.persistence must be in [0, 1]".into());
        }
        if !(self.ground_drop.is_finite() && (0.0..1.0).contains(&self.ground_drop)) {
            return Err("odometry.separate.ground_drop must be in [0, 1)".into());
        }
        if self.persistence > 0.0 && self.memory_radius <= 0.0 {
            return Err(
                "odometry.separate.persistence needs the match memory (memory_radius > 0)".into(),
            );
        }
        if let Some(h) = &self.hypotheses {
            h.validate()?;
        }
        Ok(())
    }
}

/// What the separation did in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SeparationOutcome {
    /// Two motions with large support competed.
    pub competing: bool,
    /// The second motion was chosen over the first.
    pub switched: bool,
    /// The chosen motion's road score dropped ([`SeparateOptions::ground_drop`]).
    pub ground_drop: bool,
    /// On a frame with fewer matches than [`SeparateOptions::count_reference`], the road
    /// score dropped against [`SeparateOptions::ground_drop_min`] scaled to the frame's
    /// matches ([`SeparateOptions::count_scaled`]) though not against it as written: the
    /// report-only flag `trust.road_drop_scaled` reads it (the run does not).
    pub ground_drop_scaled: bool,
    /// The re-solved prediction replaced the motion the rules left
    /// ([`crate::hypotheses::HypothesesOptions::predict_by_road`]).
    pub road_predicted: bool,
    /// A rule of the multi-frame choice replaced the first motion because it left the recent
    /// frames' motion (its yaw jumped: [`crate::hypotheses::HypothesesOptions::yaw_jump`],
    /// `yaw_history_replace`, `yaw_history_predict`, `predict_by_road`; or it slid:
    /// `predict_by_slip`): a vehicle pulled the choice away, as where
    /// `trust.side_slip_change` flags a reported motion, and `trust.side_slip_hold` starts its
    /// hold (the vehicle is still there in the next frames).
    pub pulled: bool,
    /// The frame is `competing` only because the re-solved prediction replaced the motion,
    /// and [`crate::hypotheses::HypothesesOptions::predict_by_road_prior`] lets it centre the
    /// next frame's change-of-motion prior all the same.
    pub prior_kept: bool,
}

/// The sines of a match's two one-sided epipolar angles under the essential matrix `e`
/// (`|f1ᵀ E f0|` over `|E f0|` and over `|Eᵀ f1|`, at most 1); `None` where an epipolar line is
/// undefined (the angle is then taken as 0).
fn one_sided_sines(e: &nalgebra::Matrix3<f64>, o: &momo_core::Observation) -> Option<(f64, f64)> {
    let n0 = e * o.f0;
    let n1 = e.transpose() * o.f1;
    let c = o.f1.dot(&n0).abs();
    let (a, b) = (n0.norm(), n1.norm());
    (a >= 1e-15 && b >= 1e-15).then(|| ((c / a).min(1.0), (c / b).min(1.0)))
}

/// Epipolar angles (radians) of every match (per camera, in order) under a vehicle motion.
pub fn epipolar_angles(rig: &Rig, motion: &Pose<f64>, obs: &FrameObservations) -> Vec<Vec<f64>> {
    per_match_sines(rig, motion, obs, |sines| {
        sines.map_or(0.0, |(u, v)| 0.5 * (u.asin() + v.asin()))
    })
}

/// `f` of every match's [`one_sided_sines`] under a vehicle motion, per camera, in order.
fn per_match_sines<T>(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    f: impl Fn(Option<(f64, f64)>) -> T,
) -> Vec<Vec<T>> {
    rig.cameras()
        .iter()
        .zip(&obs.per_camera)
        .map(|(cam, matches)| {
            let e = essential(&camera_motion(motion, &cam.t_vehicle_camera));
            matches.iter().map(|o| f(one_sided_sines(&e, o))).collect()
        })
        .collect()
}

/// Whether each match's epipolar angle ([`epipolar_angles`]) is at least `threshold`
/// (radians): the same answer as `epipolar_angles(..)[j][i] >= threshold`, without the two
/// `asin` of a match whose two one-sided sines are both clearly below or both clearly above
/// `sin(threshold)` (most matches; the competing-motions check runs it on every frame).
pub fn epipolar_at_least(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    threshold: f64,
) -> Vec<Vec<bool>> {
    per_match_sines(rig, motion, obs, angle_at_least(threshold))
}

/// The matches within `threshold` (radians) of `motion`'s epipolar geometry: the complement of
/// [`epipolar_at_least`] (the support that the match memory records and the road cues read).
pub fn epipolar_within(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    threshold: f64,
) -> Vec<Vec<bool>> {
    let at_least = angle_at_least(threshold);
    per_match_sines(rig, motion, obs, |sines| !at_least(sines))
}

/// The decision of [`epipolar_at_least`] for one match from its [`one_sided_sines`]: whether
/// its epipolar angle is at least `threshold` (radians), without the two `asin` where both
/// sines are clearly on one side of `sin(threshold)`.
pub(crate) fn angle_at_least(threshold: f64) -> impl Fn(Option<(f64, f64)>) -> bool {
    // A relative margin far above the rounding of `sin` and `asin`; outside (0, 1.5) rad, or
    // between the bounds, the angle itself decides.
    let shortcut = threshold > 0.0 && threshold < 1.5;
    let s = threshold.sin();
    let (lo, hi) = (s * (1.0 - 1e-9), s * (1.0 + 1e-9));
    move |sines| {
        let Some((u, v)) = sines else {
            return 0.0 >= threshold;
        };
        if shortcut && u < lo && v < lo {
            return false;
        }
        if shortcut && u > hi && v > hi {
            return true;
        }
        0.5 * (u.asin() + v.asin()) >= threshold
    }
}

/// What follows the separation in the odometry ([`SeparateOptions::final_fit`]).
#[derive(Clone, Debug, PartialEq)]
pub enum NextStage {
    /// Nothing: the separation's own final stage ran (or none is configured).
    Done,
    /// `[odometry.final_fit]` on all matches, as without the separation.
    FinalFit,
    /// `[odometry.final_fit]` on these matches only (the chosen motion's support).
    FinalFitOn(Vec<Vec<bool>>),
}

impl NextStage {
    /// The matches the final stage is handed (per camera, per match of `obs`): all of them
    /// for [`NextStage::FinalFit`], the mask for [`NextStage::FinalFitOn`]; None for
    /// [`NextStage::Done`].
    pub fn given(&self, obs: &FrameObservations) -> Option<Vec<Vec<bool>>> {
        match self {
            Self::Done => None,
            Self::FinalFit => Some(obs.per_camera.iter().map(|m| vec![true; m.len()]).collect()),
            Self::FinalFitOn(m) => Some(m.clone()),
        }
    }
}

/// A candidate motion and its support (per camera, per match).
type Candidate = (FrameSolution, Vec<Vec<bool>>);

/// The matches where `mask` holds (per camera, per match; the cross-camera matches kept).
pub(crate) fn subset(obs: &FrameObservations, mask: &[Vec<bool>]) -> FrameObservations {
    FrameObservations {
        per_camera: obs
            .per_camera
            .iter()
            .zip(mask)
            .map(|(m, k)| {
                m.iter()
                    .zip(k)
                    .filter(|(_, k)| **k)
                    .map(|(o, _)| *o)
                    .collect()
            })
            .collect(),
        cross_camera: obs.cross_camera.clone(),
    }
}

/// Image cells holding at least one match of `mask` (frame k-1 pixels), over all cameras.
pub(crate) fn cells(
    rig: &Rig,
    obs: &FrameObservations,
    mask: &[Vec<bool>],
    grid: (usize, usize),
) -> usize {
    use momo_core::CameraModel;
    let mut total = 0;
    for ((cam, m), k) in rig.cameras().iter().zip(&obs.per_camera).zip(mask) {
        let (w, h) = cam.model.size();
        let mut seen = vec![false; grid.0 * grid.1];
        for (o, _) in m.iter().zip(k).filter(|(_, k)| **k) {
            let cx = ((o.px0.x / w.max(1.0)) * grid.0 as f64).clamp(0.0, grid.0 as f64 - 1.0);
            let cy = ((o.px0.y / h.max(1.0)) * grid.1 as f64).clamp(0.0, grid.1 as f64 - 1.0);
            seen[cy as usize * grid.0 + cx as usize] = true;
        }
        total += seen.iter().filter(|s| **s).count();
    }
    total
}

/// The share the matches of `mask` hold among all the matches of the image cells (frame k-1
/// pixels, `grid` per camera) they occupy, pooled over those cells; 0 if `mask` is empty.
pub fn cell_share(
    rig: &Rig,
    obs: &FrameObservations,
    mask: &[Vec<bool>],
    grid: (usize, usize),
) -> f64 {
    use momo_core::CameraModel;
    let (mut own, mut all) = (0usize, 0usize);
    for ((cam, m), k) in rig.cameras().iter().zip(&obs.per_camera).zip(mask) {
        let (w, h) = cam.model.size();
        let mut cells = vec![(0usize, 0usize); grid.0 * grid.1];
        for (o, k) in m.iter().zip(k) {
            let cx = ((o.px0.x / w.max(1.0)) * grid.0 as f64).clamp(0.0, grid.0 as f64 - 1.0);
            let cy = ((o.px0.y / h.max(1.0)) * grid.1 as f64).clamp(0.0, grid.1 as f64 - 1.0);
            let c = &mut cells[cy as usize * grid.0 + cx as usize];
            c.0 += usize::from(*k);
            c.1 += 1;
        }
        for (o, a) in cells.into_iter().filter(|c| c.0 > 0) {
            own += o;
            all += a;
        }
    }
    if all == 0 {
        0.0
    } else {
        own as f64 / all as f64
    }
}

/// Squared distance (sigma units, the learnt sigmas if any: `MotionPrior::soft_inv_scale`) of a
/// soft model's prior residuals to the soft prior's centre; `None` for a hard model (no prior
/// residuals) or without a centre.
fn implausibility(ctx: &SolveContext<'_>, params: &[f64]) -> Option<f64> {
    let prior = ctx.motion_prior?;
    let center = &prior.soft_center;
    let q = ctx.estimator.prior_residuals(params);
    if q.is_empty() || q.len() != center.len() {
        return None;
    }
    let k = |r: usize| prior.soft_inv_scale.get(r).copied().unwrap_or(1.0);
    let d: f64 = q
        .iter()
        .zip(center)
        .enumerate()
        .map(|(r, (q, c))| (k(r) * (q - c)).powi(2))
        .sum();
    d.is_finite().then_some(d)
}

/// The motion prior of the second motion B's solves ([`SeparateOptions::second_soft_prior`]):
/// the frame prior's learnt soft part (centre, learnt sigmas, Cauchy scales, unit; no
/// per-parameter and no rotation-change prior) where a listed residual's learnt centre is more
/// than `second_soft_prior` model sigmas from 0; `None` (B solved without a prior, as before
/// the thirty-eighth session) where the option is off, the frame has no prior or no learnt
/// centre, or every listed centre is within the threshold.
pub fn second_motion_prior(
    prior: Option<&MotionPrior>,
    opts: &SeparateOptions,
) -> Option<MotionPrior> {
    let prior = prior?;
    let far = opts
        .second_soft_prior_residuals
        .iter()
        .filter_map(|&r| prior.soft_center.get(r))
        .any(|c| c.abs() > opts.second_soft_prior);
    (opts.second_soft_prior > 0.0 && far).then(|| MotionPrior {
        soft_center: prior.soft_center.clone(),
        soft_inv_scale: prior.soft_inv_scale.clone(),
        soft_cauchy: prior.soft_cauchy.clone(),
        scale: prior.scale,
        ..MotionPrior::default()
    })
}

fn count(mask: &[Vec<bool>]) -> usize {
    mask.iter().flatten().filter(|k| **k).count()
}

/// Everything one solve needs besides the matches and the start.
pub struct SolveContext<'a> {
    /// The rig.
    pub rig: &'a Rig,
    /// The frame estimator (model and metric).
    pub estimator: &'a dyn FrameEstimator,
    /// The robust loss of the usual solve.
    pub loss: &'a dyn RobustLoss,
    /// The solver.
    pub solver: &'a dyn Solver,
    /// Fixed parameters (e.g. the odometry arc length).
    pub fixed: &'a [bool],
    /// The motion prior of the frame (used by the second motion's fit and the final stage).
    pub motion_prior: Option<&'a MotionPrior>,
}

impl SolveContext<'_> {
    /// The cost `½ Σ ρ(|r|²)` of the matches `obs` at `params` under `loss` (no motion prior),
    /// if finite.
    fn cost(&self, obs: &FrameObservations, params: &[f64], loss: &dyn RobustLoss) -> Option<f64> {
        let req = SolveRequest {
            rig: self.rig,
            observations: obs,
            loss,
            solver: self.solver,
            initial: params,
            fixed: self.fixed,
            rotation_only: false,
            motion_prior: None,
        };
        self.estimator
            .cost(&req, params)
            .ok()
            .filter(|c| c.is_finite())
    }

    pub(crate) fn solve(
        &self,
        obs: &FrameObservations,
        init: &[f64],
        loss: &dyn RobustLoss,
        prior: bool,
    ) -> Option<FrameSolution> {
        let prior = if prior { self.motion_prior } else { None };
        self.solve_with_prior(obs, init, loss, prior)
    }

    /// [`SolveContext::solve`] under the motion prior `prior` (`None`: none).
    pub(crate) fn solve_with_prior(
        &self,
        obs: &FrameObservations,
        init: &[f64],
        loss: &dyn RobustLoss,
        prior: Option<&MotionPrior>,
    ) -> Option<FrameSolution> {
        let req = SolveRequest {
            rig: self.rig,
            observations: obs,
            loss,
            solver: self.solver,
            initial: init,
            fixed: self.fixed,
            rotation_only: false,
            motion_prior: prior,
        };
        self.estimator.solve(&req).ok().filter(|s| {
            s.report.termination != Termination::NumericalFailure
                && s.params.iter().all(|p| p.is_finite())
                && s.report.final_cost.is_finite()
        })
    }
}

/// The separation stage (see the module doc): returns the frame's solution (A, or the second
/// motion, after the final stage), what happened, and what is to follow: with
/// [`SeparateOptions::final_fit`], the default's final stage on all matches or on the chosen
/// support (the separation's own final stage is then skipped). `starts` are the second
/// motion's starts; `tracker` keeps the multi-frame evidence of
/// [`SeparateOptions::hypotheses`] and the match memory, and `arc_length` is the frame's
/// odometry arc length if known.
pub fn separate(
    ctx: &SolveContext<'_>,
    opts: &SeparateOptions,
    obs: &FrameObservations,
    first: FrameSolution,
    starts: &[Vec<f64>],
    tracker: &mut HypothesisTracker,
    arc_length: Option<f64>,
) -> (FrameSolution, SeparationOutcome, NextStage) {
    separate_with(ctx, opts, obs, first, starts, tracker, arc_length, true)
}

/// [`separate`], with (`pretests`) or without the exact pre-tests that skip the solves of
/// alternatives that could not be kept ([`retain_possible`]; the same outcome either way:
/// `pretests = false` is the reference of the tests).
#[allow(clippy::too_many_arguments)]
fn separate_with(
    ctx: &SolveContext<'_>,
    opts: &SeparateOptions,
    obs: &FrameObservations,
    first: FrameSolution,
    starts: &[Vec<f64>],
    tracker: &mut HypothesisTracker,
    arc_length: Option<f64>,
    pretests: bool,
) -> (FrameSolution, SeparationOutcome, NextStage) {
    tracker.arc_length = arc_length;
    let n = obs.len();
    let mut outcome = SeparationOutcome::default();
    // All matches capped per image cell (`cell_cap`): computed once, for A's re-solve
    // (`cell_cap_first`) and the final stage on all matches (`final_fit`).
    // `None` where the gate (`cell_cap_min_share`) passes over the frame.
    let cap_on = opts.cell_cap > 0.0 && (opts.cell_cap_first || opts.final_fit);
    let all_capped = cap_on
        .then(|| {
            let all: Vec<Vec<bool>> = obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
            gated_cap(ctx.rig, obs, &all, opts)
        })
        .flatten();
    // A re-solved on the capped matches (`cell_cap_first`).
    let first = if let Some(capped) = all_capped.as_ref().filter(|_| opts.cell_cap_first) {
        match (count(capped) >= 12)
            .then(|| ctx.solve(&subset(obs, capped), &first.params, ctx.loss, true))
            .flatten()
        {
            Some(mut a) => {
                a.inlier_mask = first.inlier_mask;
                a.inliers_per_camera = first.inliers_per_camera;
                a.report.normal_matrix = first.report.normal_matrix;
                a.report.final_cost = first.report.final_cost;
                a
            }
            None => first,
        }
    } else {
        first
    };
    let angles_a = epipolar_angles(ctx.rig, &ctx.estimator.motion(&first.params), obs);
    // The frame's noise (`threshold_sigmas`, `distinct_sigmas`).
    let sigma = (opts.threshold_sigmas > 0.0 || opts.distinct_sigmas > 0.0)
        .then(|| noise_sigma(&angles_a, ctx.loss.scale()))
        .flatten();
    let threshold = match sigma {
        Some(s) if opts.threshold_sigmas > 0.0 => opts.threshold_sigmas * s,
        _ => opts.threshold,
    };
    // An alternative's support: the matches whose epipolar angle is below `threshold`
    // (`x < t` is `!(x >= t)`: the angles are never NaN), without the two `asin` of a match
    // whose one-sided sines both lie clearly on one side of `sin(t)` ([`angle_at_least`]).
    let support = |params: &[f64]| -> Vec<Vec<bool>> {
        let at_least = angle_at_least(threshold);
        per_match_sines(ctx.rig, &ctx.estimator.motion(params), obs, |s| {
            !at_least(s)
        })
    };
    // The matches an alternative may count as its own: far from A (`distinct_sigmas`) or all.
    let own: Option<Vec<Vec<bool>>> = match sigma {
        Some(s) if opts.distinct_sigmas > 0.0 => Some(
            angles_a
                .iter()
                .map(|a| a.iter().map(|x| *x >= opts.distinct_sigmas * s).collect())
                .collect(),
        ),
        _ => None,
    };
    let own_count = |mask: &[Vec<bool>]| -> usize {
        match &own {
            Some(o) => count(&and(mask, o)),
            None => count(mask),
        }
    };
    let min_n = ((opts.min_fraction * n as f64).ceil() as usize).max(12);
    // The spatial coherence of an alternative's own matches (`coherence`).
    let coherent = |sup: &[Vec<bool>], a: &[Vec<bool>]| -> bool {
        (opts.coherence <= 0.0
            || cell_share(ctx.rig, obs, &and(sup, &not(a)), opts.grid) >= opts.coherence)
            && (!opts.mutual || count(&and(a, &not(sup))) >= min_n)
    };
    let sup_a: Vec<Vec<bool>> = angles_a
        .iter()
        .map(|a| a.iter().map(|x| *x < threshold).collect())
        .collect();
    let mut chosen = (first, sup_a);
    // The memory's labels of this frame's matches (`memory_radius`).
    let labels = (opts.memory_radius > 0.0)
        .then(|| tracker.memory.labels(obs, opts.memory_radius))
        .flatten();
    // The alternatives to A: B, fitted to the matches outside A's support, and (with
    // `hypotheses` and odometry) C, the previous frame's motion (the first start) re-solved on
    // the matches it puts on the road: the continued track of the static world.
    let mut alternatives: Vec<Candidate> = Vec::new();
    // Exact pre-tests: the alternatives are solved only where one could still be kept.
    let rest_n = n - count(&chosen.1);
    let admissible = opts.second_motion
        && (!pretests || retain_possible(ctx, opts, obs, labels.as_deref(), &chosen, rest_n));
    // The candidates' solver (`candidate_max_iterations`, `candidate_function_tolerance`).
    let candidate = admissible
        .then(|| candidate_solver(ctx.solver, opts))
        .flatten();
    let cctx = SolveContext {
        rig: ctx.rig,
        estimator: ctx.estimator,
        loss: ctx.loss,
        solver: candidate.as_deref().unwrap_or(ctx.solver),
        fixed: ctx.fixed,
        motion_prior: ctx.motion_prior,
    };
    // `distinct` needs this many own matches, all outside A's support (C and M).
    let distinct_possible = !pretests || rest_n >= (min_n / 3).max(12);
    if admissible && rest_n >= min_n {
        let rest_mask: Vec<Vec<bool>> = chosen
            .1
            .iter()
            .map(|m| m.iter().map(|k| !k).collect())
            .collect();
        // `candidate_forget_other`: B's fit leaves out the remembered-other matches.
        let rest_mask = match labels.as_deref().filter(|_| opts.candidate_forget_other) {
            Some(l) => {
                let kept = and(&rest_mask, &not(&label_mask(l, false)));
                if count(&kept) >= 12 { kept } else { rest_mask }
            }
            None => rest_mask,
        };
        let rest = subset(obs, &rest_mask);
        // `candidate_subsample`: B's starts are solved on a spread subsample of `rest`.
        let sub = (opts.candidate_subsample > 0 && count(&rest_mask) > opts.candidate_subsample)
            .then(|| subset(obs, &spread_subsample(&rest_mask, opts.candidate_subsample)));
        let b_obs = sub.as_ref().unwrap_or(&rest);
        // `second_soft_prior`: B's solves under the frame prior's learnt soft part, or none.
        let b_prior = second_motion_prior(ctx.motion_prior, opts);
        // A B of the subsample re-solved on all of `rest` from its solution (the subsample's
        // solution where that fails); B itself without the subsample.
        let refit = |b: FrameSolution| -> FrameSolution {
            if sub.is_none() {
                return b;
            }
            cctx.solve_with_prior(&rest, &b.params, ctx.loss, b_prior.as_ref())
                .unwrap_or(b)
        };
        // B's support where it passes the tests.
        let tested = |b: &FrameSolution| -> Option<Vec<Vec<bool>>> {
            let sup_b = support(&b.params);
            (own_count(&sup_b) >= min_n && coherent(&sup_b, &chosen.1)).then_some(sup_b)
        };
        // `candidate_one_start` / `candidate_screen`: B from the start of least cost first.
        let mut first_try: Option<(usize, Option<FrameSolution>)> = None;
        let mut done = false;
        let screen = opts.candidate_screen > 0.0 && opts.persistence > 0.0;
        if (opts.candidate_one_start || screen)
            && starts.len() > 1
            && let Some(i) = starts
                .iter()
                .enumerate()
                .filter_map(|(i, s)| ctx.cost(b_obs, s, ctx.loss).map(|c| (i, c)))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .map(|(i, _)| i)
        {
            let sol = cctx.solve_with_prior(b_obs, &starts[i], ctx.loss, b_prior.as_ref());
            // `candidate_screen`: a B far from being kept ends the search.
            let far = screen
                && sol.as_ref().is_some_and(|b| {
                    let sup_b = support(&b.params);
                    !near_kept(
                        ctx,
                        opts,
                        obs,
                        labels.as_deref(),
                        &chosen,
                        (b, &sup_b),
                        opts.candidate_screen,
                    )
                });
            if far {
                done = true;
            } else if opts.candidate_one_start
                && let Some(b) = sol.clone().map(&refit)
                && let Some(sup_b) = tested(&b)
            {
                alternatives.push((b, sup_b));
                done = true;
            } else {
                first_try = Some((i, sol));
            }
        }
        if !done {
            // B's local minima, one per start that converged; B is the first of least cost.
            let mut sols: Vec<FrameSolution> = Vec::new();
            for (i, s) in starts.iter().enumerate() {
                let sol = match &mut first_try {
                    Some((j, sol)) if *j == i => sol.take(),
                    _ => cctx.solve_with_prior(b_obs, s, ctx.loss, b_prior.as_ref()),
                };
                sols.extend(sol);
            }
            let mut best_i: Option<usize> = None;
            for (i, sol) in sols.iter().enumerate() {
                if best_i.is_none_or(|b| sol.report.final_cost < sols[b].report.final_cost) {
                    best_i = Some(i);
                }
            }
            // `candidate_by_road`: the other local minima, for their road scores.
            let by_road = opts.hypotheses().filter(|_| opts.candidate_by_road);
            let best = best_i.map(|i| refit(sols.remove(i)));
            let others = if by_road.is_some() { sols } else { Vec::new() };
            let road_score = |b: &FrameSolution, sup: &[Vec<bool>]| -> usize {
                by_road.map_or(0, |h| {
                    score(h, ctx.rig, &ctx.estimator.motion(&b.params), obs, sup)
                })
            };
            // The road score a further B must exceed: A's and the least-cost B's (where that
            // passes B's tests).
            let mut floor = if others.is_empty() {
                0
            } else {
                road_score(&chosen.0, &chosen.1)
            };
            if let Some(b) = best
                && let Some(sup_b) = tested(&b)
            {
                if !others.is_empty() {
                    floor = floor.max(road_score(&b, &sup_b));
                }
                alternatives.push((b, sup_b));
            }
            // The local minimum with the most road, where it has more than A and the least-cost
            // B (the first of equal scores, in the order of the starts).
            let mut road_best: Option<(usize, Candidate)> = None;
            for b in others {
                if let Some(sup_b) = tested(&b) {
                    let s = road_score(&b, &sup_b);
                    if s > floor && road_best.as_ref().is_none_or(|r| s > r.0) {
                        road_best = Some((s, (b, sup_b)));
                    }
                }
            }
            if let Some((_, c)) = road_best {
                if sub.is_none() {
                    alternatives.push(c);
                } else {
                    // Re-solved on all of `rest`, and tested again.
                    let b = refit(c.0);
                    if let Some(sup_b) = tested(&b) {
                        alternatives.push((b, sup_b));
                    }
                }
            }
        }
    }
    // A distinct motion: it explains a third of `min_n` matches A does not (of its own ones),
    // spatially coherent ones.
    let distinct = |sup: &[Vec<bool>], a: &[Vec<bool>]| -> bool {
        own_count(&and(sup, &not(a))) >= (min_n / 3).max(12)
            && count(sup) >= min_n
            && coherent(sup, a)
    };
    if admissible
        && distinct_possible
        && let Some(h) = opts.hypotheses()
        && arc_length.is_some()
        && let Some(previous) = starts.first()
    {
        let all: Vec<Vec<bool>> = obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
        let road = ground_mask(ctx.rig, &ctx.estimator.motion(previous), obs, &all, h);
        if count(&road) >= 12
            && let Some(c) = cctx.solve(&subset(obs, &road), previous, ctx.loss, false)
        {
            let sup_c = support(&c.params);
            if distinct(&sup_c, &chosen.1) {
                alternatives.push((c, sup_c));
            }
        }
    }
    // M: the previous frame's motion re-solved on the remembered-static matches, where the
    // memory remembers another motion among A's support.
    if admissible
        && distinct_possible
        && let Some(labels) = &labels
        && let Some(previous) = starts.first()
    {
        let (stat, other) = (label_mask(labels, true), label_mask(labels, false));
        if count(&stat) >= min_n
            && count(&and(&other, &chosen.1)) >= (min_n / 3).max(12)
            && let Some(m) = cctx.solve(&subset(obs, &stat), previous, ctx.loss, false)
        {
            let sup_m = support(&m.params);
            if distinct(&sup_m, &chosen.1) {
                alternatives.push((m, sup_m));
            }
        }
    }
    // V: the modes of the matches' yaw votes (`yaw_votes`), each turned motion re-solved on
    // its support.
    if opts.yaw_votes > 0
        && admissible
        && distinct_possible
        && let Some(previous) = starts.first()
    {
        let vopts = crate::yaw_votes::YawVoteOptions {
            range: opts.yaw_votes_range,
            step: opts.yaw_votes_step,
            informative: opts.yaw_votes_informative,
            threshold,
            window: 2,
            min_votes: opts.yaw_votes_min,
            separation: 5,
        };
        let (offsets, hist) =
            crate::yaw_votes::votes(ctx.rig, ctx.estimator, obs, previous, None, &vopts);
        // A's own yaw offset: a mode there is A.
        let yaw_a = yaw_of(ctx, &chosen.0.params) - yaw_of(ctx, previous);
        let modes = crate::yaw_votes::modes(&offsets, &hist, &vopts, |x| {
            (x - yaw_a).abs() < 3.0 * vopts.step
        });
        for mode in modes.into_iter().take(opts.yaw_votes) {
            let Some(start) = crate::yaw_votes::turned(ctx.estimator, previous, mode.offset) else {
                continue;
            };
            let sup0 = support(&start);
            if count(&sup0) >= 12
                && let Some(v) = cctx.solve(&subset(obs, &sup0), &start, ctx.loss, false)
            {
                let sup_v = support(&v.params);
                if distinct(&sup_v, &chosen.1) {
                    alternatives.push((v, sup_v));
                }
            }
        }
    }
    // T: the road track (`road_track`).
    let mut road_t: Option<Candidate> = None;
    if opts.road_track
        && admissible
        && distinct_possible
        && let Some(h) = opts.hypotheses()
        && arc_length.is_some()
        && let Some(previous) = starts.first()
    {
        let start = crate::road_track::start(ctx, previous, tracker.road_track.as_deref());
        if let Some(t) = crate::road_track::solve(&cctx, h, obs, &start) {
            let sup_t = support(&t.params);
            if distinct(&sup_t, &chosen.1) {
                alternatives.push((t.clone(), sup_t.clone()));
            }
            road_t = Some((t, sup_t));
        }
    }
    // Vehicle-model plausibility (`hypotheses.tilt_replace`): where A rolls or pitches more
    // than an alternative by `tilt_margin`, the alternative with the highest road score among
    // those (a positive one: the static world's motion puts matches on the road) replaces A
    // whatever competition over time says. Only where an alternative could be kept at all
    // (`retain_possible`, also without the pre-tests: the outcome does not depend on them).
    let tilt_margin = opts.hypotheses().map_or(0.0, |h| h.tilt_margin);
    // The alternatives that replace A whatever competition over time says: `tilt_replace`
    // (`tilted_a`) and `yaw_jump` (`jumped_a`; odometry consistency of the yaw: A jumped away
    // from the trusted previous motion while an alternative continues it).
    let mut tilted_a: Option<Candidate> = None;
    let mut jumped_a: Option<Candidate> = None;
    // `yaw_history_replace` (`turned_a`): A's yaw jumped from the recent frames' while an
    // alternative continues them.
    let mut turned_a: Option<Candidate> = None;
    // `tilt_weak_road_frames`: A's road score is below `min_matches` (the gate's reference is
    // then the minimum over more frames).
    let mut weak_road_a = false;
    if let Some(h) = opts.hypotheses()
        && ((tilt_margin > 0.0 && h.tilt_replace)
            || h.yaw_jump > 0.0
            || (h.yaw_history_frames > 0 && h.yaw_history_replace))
        && !alternatives.is_empty()
        && (pretests || retain_possible(ctx, opts, obs, labels.as_deref(), &chosen, rest_n))
    {
        let motion_a = ctx.estimator.motion(&chosen.0.params);
        let tilt_a = crate::hypotheses::tilt(&motion_a);
        // A's road score, where `tilt_weak_road_frames` or `tilt_replace_roadless` asks.
        let score_a = (tilt_margin > 0.0
            && h.tilt_replace
            && (h.tilt_weak_road_frames > 0 || h.tilt_replace_roadless))
            .then(|| score(h, ctx.rig, &motion_a, obs, &chosen.1));
        weak_road_a = score_a.is_some_and(|s| s < h.min_matches);
        // `tilt_reference_frames`: A's tilt also jumps from the recent frames'.
        if tilt_margin > 0.0
            && h.tilt_replace
            && (h.tilt_reference_frames == 0
                || tracker.tilt_jumps_given_road(h, tilt_a, weak_road_a))
        {
            let qualified = alternatives
                .iter()
                .filter_map(|alt| {
                    let m = ctx.estimator.motion(&alt.0.params);
                    let t = crate::hypotheses::tilt(&m);
                    (t.is_finite() && t < tilt_a - tilt_margin)
                        .then(|| (score(h, ctx.rig, &m, obs, &alt.1), alt, t))
                })
                // `tilt_replace_roadless`: also without road where the ground cue does not
                // apply between A and it.
                .filter(|(s, _, _)| HypothesisTracker::converse_qualifies(h, *s, score_a))
                .collect();
            // `tilt_replace_flattest`: the converse's test applied to its replacement too.
            tilted_a = first_highest(
                h.flattest_within_margin(qualified)
                    .map(|(s, alt, _)| (s, alt)),
            );
        }
        if h.yaw_jump > 0.0 {
            jumped_a = yaw_jump_replacement(ctx, h, obs, &chosen, &alternatives);
        }
        if h.yaw_history_replace {
            turned_a = yaw_history_replacement(ctx, h, tracker, obs, &chosen, &alternatives);
        }
    }
    // `yaw_history_predict` (`predicted_a`): A's yaw jumped from the recent frames' without
    // road while no rule found an alternative; the previous motion re-solved on its support.
    let predicted_a = (tilted_a.is_none() && jumped_a.is_none() && turned_a.is_none())
        .then(|| {
            let previous = starts.first()?;
            let h = opts.hypotheses()?;
            yaw_history_prediction(ctx, h, tracker, obs, &chosen, previous, &support)
        })
        .flatten();
    // `predict_by_road` (`road_predicted`): the motion the rules leave jumped without road,
    // while the previous motion re-solved on its support has the road.
    let road_predicted = opts
        .hypotheses()
        .filter(|h| h.predict_by_road > 0.0)
        .and_then(|h| {
            let x = tilted_a
                .as_ref()
                .or(jumped_a.as_ref())
                .or(turned_a.as_ref())
                .or(predicted_a.as_ref())
                .unwrap_or(&chosen);
            road_prediction(
                ctx,
                h,
                tracker,
                obs,
                x,
                &alternatives,
                starts.first()?,
                &support,
            )
        });
    // Competition over time (`persistence`): an alternative whose split from A the memory
    // does not follow is A's noise tail, not a second motion.
    if opts.persistence > 0.0 {
        // A's score of the multi-frame choice, for `ground_admit` (computed once, if asked).
        let mut score_a: Option<usize> = None;
        alternatives.retain(|alt| {
            let p = labels
                .as_ref()
                .map_or(0.0, |l| persistence(l, &alt.1, &chosen.1));
            let own = count(&and(&alt.1, &not(&chosen.1))) as f64;
            let own_share_met = opts.own_share > 0.0 && own >= opts.own_share * n as f64;
            if p >= opts.persistence || (own_share_met && p >= opts.own_persistence) {
                return true;
            }
            // Competition by the ground cue (`ground_admit`).
            let ga_share = opts.ground_admit_share();
            let Some(h) = opts.hypotheses().filter(|_| {
                opts.ground_admit > 0.0 && ga_share > 0.0 && own >= ga_share * n as f64
            }) else {
                return false;
            };
            let s = score(
                h,
                ctx.rig,
                &ctx.estimator.motion(&alt.0.params),
                obs,
                &alt.1,
            );
            let sa = *score_a.get_or_insert_with(|| {
                score(
                    h,
                    ctx.rig,
                    &ctx.estimator.motion(&chosen.0.params),
                    obs,
                    &chosen.1,
                )
            });
            s >= opts.ground_admit_min && s as f64 >= opts.ground_admit * sa as f64
        });
    }
    // T where competition over time rejected it: admitted by its road score (`road_track`).
    if let Some((t, sup_t)) = &road_t
        && let Some(h) = opts.hypotheses()
        && opts.persistence > 0.0
        && distinct(sup_t, &chosen.1)
        && !alternatives.iter().any(|alt| alt.0.params == t.params)
        && crate::road_track::admitted(
            ctx,
            h,
            obs,
            (opts.ground_admit_min, opts.ground_admit),
            (&t.params, sup_t),
            (&chosen.0.params, &chosen.1),
        )
    {
        alternatives.push((t.clone(), sup_t.clone()));
    }
    // Whether anything but the road prediction competed (`predict_by_road_prior`).
    let others_competed = !alternatives.is_empty()
        || tilted_a.is_some()
        || jumped_a.is_some()
        || turned_a.is_some()
        || predicted_a.is_some();
    outcome.competing = others_competed || road_predicted.is_some();
    outcome.road_predicted = road_predicted.is_some();
    // (A replacement by `predict_by_slip` is one by `road_prediction`.)
    outcome.pulled = jumped_a.is_some()
        || turned_a.is_some()
        || predicted_a.is_some()
        || road_predicted.is_some();
    outcome.prior_kept = prior_kept(opts.hypotheses(), road_predicted.is_some(), others_competed);
    // Whether the alternative `b` may replace `a` by the spatial plausibility of its support.
    let spread_ok = |b: &[Vec<bool>], a: &[Vec<bool>]| {
        opts.min_cell_ratio <= 0.0
            || cells(ctx.rig, obs, b, opts.grid) as f64
                >= opts.min_cell_ratio * cells(ctx.rig, obs, a, opts.grid) as f64
    };
    // The support of the motion not chosen (for `final_exclusive`).
    let mut other: Option<Vec<Vec<bool>>> = None;
    if let Some(h) = opts.hypotheses()
        && (!alternatives.is_empty()
            || tilted_a.is_some()
            || jumped_a.is_some()
            || turned_a.is_some()
            || predicted_a.is_some()
            || road_predicted.is_some())
    {
        // The alternative with the most ground (or parallax) support against A, over frames.
        let metric = arc_length.is_some();
        let motion_a = ctx.estimator.motion(&chosen.0.params);
        let arc = arc_length.map_or(motion_a.translation.norm(), f64::abs);
        let mut scored: Vec<(usize, Candidate)> = alternatives
            .into_iter()
            .map(|alt| {
                let m = ctx.estimator.motion(&alt.0.params);
                (score(h, ctx.rig, &m, obs, &alt.1), alt)
            })
            .collect();
        scored.sort_by_key(|(s, _)| std::cmp::Reverse(*s));
        let a = Hypothesis {
            motion: motion_a,
            support: &chosen.1,
        };
        // The ordinary choice: whether `best` (road score `score_b`) replaces A by the tracks'
        // sums or the memory's vote (`tracker` keeps the choice's state).
        let ordinary = |tracker: &mut HypothesisTracker, score_b: usize, best: &Candidate| {
            let b = Hypothesis {
                motion: ctx.estimator.motion(&best.0.params),
                support: &best.1,
            };
            // Which of A and B continues the previous frame's chosen track (`track_decay`).
            let b_continues = labels
                .as_ref()
                .filter(|_| h.track_decay > 0.0)
                .and_then(|l| {
                    let fa = static_share(l, &chosen.1, h.track_min_labelled)?;
                    let fb = static_share(l, &best.1, h.track_min_labelled)?;
                    // The chosen track's support is remembered mostly static, the other's
                    // mostly other: two motions of the static world (one a purer subset of the
                    // other), or two fits of a static scene's noise, are not two tracks.
                    let split = |hi: f64, lo: f64| {
                        hi - lo >= h.track_identity
                            && hi >= TRACK_SPLIT_SHARE
                            && lo < TRACK_SPLIT_SHARE
                    };
                    if split(fa, fb) {
                        Some(false)
                    } else if split(fb, fa) {
                        Some(true)
                    } else {
                        None
                    }
                });
            let ground_choice =
                tracker.choose(h, ctx.rig, obs, arc, metric, &a, &b, b_continues) == Some(true);
            // The memory's vote where the ground scores are not decisive (`memory_vote`).
            let vote = !ground_choice
                && opts.memory_vote > 0.0
                && arc.is_finite()
                && arc >= h.min_arc_length
                && (metric || !h.ground)
                && labels.as_ref().is_some_and(|l| {
                    let score_a = score(h, ctx.rig, &a.motion, obs, a.support);
                    memory_vote(opts, l, (score_a, &chosen.1), (score_b, &best.1))
                });
            // `tilt_margin`: a B that rolls or pitches more than A by the margin does not
            // replace A.
            let tilted_b = tilt_margin > 0.0
                && crate::hypotheses::tilt(&b.motion)
                    > crate::hypotheses::tilt(&a.motion) + tilt_margin;
            (ground_choice || vote) && !tilted_b
        };
        // `yaw_history_tie`: the alternative the ordinary choice meets (index into `scored`).
        let tie = history_tie(h, tracker, &scored, |c| yaw_of(ctx, &c.0.params));
        // `tilt_reference_frames`: the ordinary choice's switch to that alternative, where its
        // tilt does not jump from the recent frames', stands (decided on a copy of the state).
        let tilted_a = tilted_a.filter(|_| {
            h.tilt_reference_frames == 0
                || scored.get(tie).is_none_or(|(s, best)| {
                    let tilt_b = crate::hypotheses::tilt(&ctx.estimator.motion(&best.0.params));
                    tracker.tilt_jumps_given_road(h, tilt_b, weak_road_a)
                        || !spread_ok(&best.1, &chosen.1)
                        || !ordinary(&mut tracker.clone(), *s, best)
                })
        });
        // `tilt_replace` / `yaw_jump`: A tilted beyond an alternative (first), or jumped away
        // from the trusted previous motion, is replaced by it.
        // `predict_by_road`: the re-solved prediction replaces whatever they chose.
        let forced_alt = road_predicted
            .or(tilted_a)
            .or(jumped_a)
            .or(turned_a)
            .or(predicted_a);
        let forced = forced_alt.is_some();
        let (score_b, best) = match forced_alt {
            Some(alt) => {
                let m = ctx.estimator.motion(&alt.0.params);
                (score(h, ctx.rig, &m, obs, &alt.1), alt)
            }
            None => scored.swap_remove(tie),
        };
        let switch = ordinary(tracker, score_b, &best);
        // `yaw_history_frames`: the ordinary choice does not switch to a yaw jump away from
        // the recent frames' where A continues them.
        let switch = switch
            && !yaw_history_vetoes(
                ctx,
                h,
                tracker,
                (&chosen, &best),
                (opts.ground_admit_min, opts.ground_admit),
                || score(h, ctx.rig, &a.motion, obs, &chosen.1),
                score_b,
            );
        if (forced || switch) && spread_ok(&best.1, &chosen.1) {
            outcome.switched = true;
            other = Some(std::mem::replace(&mut chosen, best).1);
        } else {
            other = Some(best.1);
        }
        tracker.settle(outcome.switched);
    } else if let Some(b) = alternatives.pop() {
        let (pa, pb) = (
            implausibility(ctx, &chosen.0.params),
            implausibility(ctx, &b.0.params),
        );
        let switch = match (pa, pb) {
            (Some(pa), Some(pb))
                if opts.plausibility_margin >= 0.0
                    && (pa - pb).abs() > opts.plausibility_margin =>
            {
                pb < pa
            }
            _ => cells(ctx.rig, obs, &b.1, opts.grid) > cells(ctx.rig, obs, &chosen.1, opts.grid),
        };
        if switch && spread_ok(&b.1, &chosen.1) {
            outcome.switched = true;
            other = Some(std::mem::replace(&mut chosen, b).1);
        } else {
            other = Some(b.1);
        }
    }
    if !outcome.competing
        && let Some(h) = opts.hypotheses()
    {
        tracker.idle(h);
    }
    if opts.road_track {
        tracker.road_track = road_t.zip(opts.hypotheses()).and_then(|((t, sup_t), h)| {
            crate::road_track::next(
                ctx,
                h,
                obs,
                (&t.params, &sup_t),
                (&chosen.0.params, &chosen.1),
            )
        });
    }
    if opts.memory_radius > 0.0 {
        tracker.memory = MatchMemory::record(obs, &chosen.1);
    }
    if let Some(h) = opts.hypotheses() {
        let t = crate::hypotheses::tilt(&ctx.estimator.motion(&chosen.0.params));
        tracker.record_tilt(h, t);
        tracker.record_contested(h, outcome.competing);
        let yaw = momo_core::so3_log(&ctx.estimator.motion(&chosen.0.params).rotation).z;
        tracker.record_yaw(h, yaw);
    }
    // The chosen motion's road score, for `ground_drop` and the road guard of
    // `yaw_history_predict` (computed once).
    if let Some(h) = opts
        .hypotheses()
        .filter(|h| opts.ground_drop > 0.0 || h.yaw_history_predict_road_frames > 0)
    {
        let s = score(
            h,
            ctx.rig,
            &ctx.estimator.motion(&chosen.0.params),
            obs,
            &chosen.1,
        );
        tracker.record_road(h, s);
        if opts.ground_drop > 0.0 {
            let scaled = opts.count_scaled(opts.ground_drop_min, obs.len());
            outcome.ground_drop_scaled = scaled < opts.ground_drop_min
                && crate::ground_drop::fires(&tracker.ground_scores, s, opts.ground_drop, scaled);
            outcome.ground_drop = crate::ground_drop::observe(
                &mut tracker.ground_scores,
                s,
                opts.ground_drop,
                opts.ground_drop_min,
            );
        }
    }
    let (mut sol, mut mask) = chosen;
    // The remembered-other matches (`memory_exclude`).
    let forgotten = |mask: Vec<Vec<bool>>| -> Vec<Vec<bool>> {
        let Some(labels) = labels.as_ref().filter(|_| opts.memory_exclude) else {
            return mask;
        };
        let kept = and(&mask, &not(&label_mask(labels, false)));
        if 2 * count(&kept) >= count(&mask) {
            kept
        } else {
            mask
        }
    };
    // Leaves out the matches under the road (`under_road` on one camera, `under_road_rig` on
    // several; a test that would leave fewer than half leaves none).
    let road = |mask: Vec<Vec<bool>>, params: &[f64]| -> Vec<Vec<bool>> {
        let motion = ctx.estimator.motion(params);
        match under_road_left_out(ctx.rig, &motion, obs, &mask, opts, arc_length.is_some()) {
            Some(out) => and(&mask, &not(&out)),
            None => mask,
        }
    };
    if opts.final_fit && !(opts.final_own_when_competing && outcome.competing) {
        // The default's final stage runs after this: on the chosen support where two motions
        // competed, as without the separation elsewhere.
        let next = if outcome.competing {
            NextStage::FinalFitOn(forgotten(mask))
        } else if opts.memory_exclude_quiet {
            // The remembered-other matches left out of all (`memory_exclude_quiet`).
            let all: Vec<Vec<bool>> = obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
            let total = count(&all);
            let kept = forgotten(all);
            if count(&kept) < total {
                NextStage::FinalFitOn(kept)
            } else {
                NextStage::FinalFit
            }
        } else {
            NextStage::FinalFit
        };
        // Image-region balance of the final stage (`cell_cap`).
        let next = if cap_on {
            let (base, capped) = match next {
                NextStage::FinalFitOn(m) => {
                    let capped = gated_cap(ctx.rig, obs, &m, opts);
                    (m, capped)
                }
                _ => {
                    let all = obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
                    (all, all_capped)
                }
            };
            let before = count(&base);
            match (capped.filter(|c| count(c) < before), before == n) {
                (Some(capped), _) => NextStage::FinalFitOn(capped),
                (None, true) => NextStage::FinalFit,
                (None, false) => NextStage::FinalFitOn(base),
            }
        } else {
            next
        };
        // The matches under the road (`under_road`, `under_road_rig`) leave the stage in the
        // odometry, with its other support tests ([`under_road_left_out`]).
        return (sol, outcome, next);
    }
    if !opts.final_stage || (opts.final_competing_only && !outcome.competing) {
        return (sol, outcome, NextStage::Done);
    }
    // Leaves out the rejected motion's support (`final_exclusive`).
    let exclusive = |mask: Vec<Vec<bool>>| -> Vec<Vec<bool>> {
        let Some(other) = other.as_ref().filter(|_| opts.final_exclusive) else {
            return mask;
        };
        let only = and(&mask, &not(other));
        if 2 * count(&only) >= count(&mask) {
            only
        } else {
            mask
        }
    };
    let loss: &dyn RobustLoss = if opts.final_robust {
        ctx.loss
    } else {
        &TrivialLoss
    };
    for pass in 0..opts.final_passes.max(1) {
        if pass > 0 {
            mask = support(&sol.params);
        }
        mask = exclusive(mask);
        mask = road(mask, &sol.params);
        if outcome.competing {
            mask = forgotten(mask);
        }
        if count(&mask) < 8 {
            break;
        }
        match ctx.solve(&subset(obs, &mask), &sol.params, loss, !outcome.competing) {
            Some(fin) => sol = fin,
            None => break,
        }
    }
    (sol, outcome, NextStage::Done)
}

/// The alternative that replaces A by the odometry consistency of the yaw
/// ([`HypothesesOptions::yaw_jump`] `= k`): with the rotation prior active (`σ = 1 /
/// rotation_inv_sigma`, centre `c` the trusted previous frame's rotation vector), where A's yaw
/// deviates by `|ω_z(A) − c_z| > k σ`, the alternative with the highest positive road score
/// ([`score`]; the first of equal ones) among those with `|ω_z(X) − c_z| <= k σ / 2`. None
/// where the prior is off or no alternative qualifies.
fn yaw_jump_replacement(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    obs: &FrameObservations,
    chosen: &Candidate,
    alternatives: &[Candidate],
) -> Option<Candidate> {
    let prior = ctx
        .motion_prior
        .filter(|p| p.rotation_inv_sigma > 0.0 && p.rotation_inv_sigma.is_finite())?;
    let k = h.yaw_jump;
    // The yaw's deviation from the prior's centre, in the prior's standard deviations.
    let deviation = |params: &[f64]| {
        (yaw_of(ctx, params) - prior.rotation_center[2]).abs() * prior.rotation_inv_sigma
    };
    // `!(x <= k)`: a NaN deviation counts as a jump of A and disqualifies an alternative.
    if deviation(&chosen.0.params) <= k {
        return None;
    }
    let qualified = alternatives
        .iter()
        .filter(|alt| deviation(&alt.0.params) <= 0.5 * k)
        .map(|alt| (road_score(ctx, h, obs, alt), alt))
        .filter(|(s, _)| *s > 0);
    first_highest(qualified)
}

/// The road score ([`score`]) of a candidate's motion over its support.
fn road_score(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    obs: &FrameObservations,
    c: &Candidate,
) -> usize {
    score(h, ctx.rig, &ctx.estimator.motion(&c.0.params), obs, &c.1)
}

/// The candidate of the highest score among `scored`, the first of equal ones: the rules that
/// replace A (the tilt's converse, `yaw_jump`, `yaw_history_replace`) pick their alternative so.
fn first_highest<'a>(
    scored: impl DoubleEndedIterator<Item = (usize, &'a Candidate)>,
) -> Option<Candidate> {
    // `max_by_key` keeps the last of equal keys: over the reversed order, the first.
    scored.rev().max_by_key(|(s, _)| *s).map(|(_, c)| c.clone())
}

/// The yaw `ω_z` of a candidate's motion (`ω = log R`, vehicle frame).
fn yaw_of(ctx: &SolveContext<'_>, params: &[f64]) -> f64 {
    momo_core::so3_log(&ctx.estimator.motion(params).rotation).z
}

/// The index (into `scored`, sorted by road score, highest first) of the alternative that
/// competes with A in the ordinary choice ([`HypothesesOptions::yaw_history_tie`] `= q`): 0,
/// unless the first one's yaw lies more than half the yaw margin `m`
/// ([`HypothesisTracker::yaw_margin`]) from the recent frames' reference yaw `r`
/// ([`HypothesisTracker::yaw_reference`]; a NaN yaw does); then the first one with
/// `|ω_z − r| <= m / 2` and a road score of at least `q` times the first one's, where there is
/// one. 0 with the rule off, before any frame was recorded, or for fewer than two alternatives.
fn history_tie<C>(
    h: &HypothesesOptions,
    tracker: &HypothesisTracker,
    scored: &[(usize, C)],
    yaw: impl Fn(&C) -> f64,
) -> usize {
    let (Some(r), Some((top, first))) = (tracker.yaw_reference(), scored.first()) else {
        return 0;
    };
    if !(h.yaw_history_tie > 0.0 && h.yaw_history_frames > 0 && scored.len() > 1) {
        return 0;
    }
    let half = 0.5 * tracker.yaw_margin(h);
    let near = |c: &C| (yaw(c) - r).abs() <= half;
    if near(first) {
        return 0;
    }
    scored
        .iter()
        .position(|(s, c)| *s as f64 >= h.yaw_history_tie * *top as f64 && near(c))
        .unwrap_or(0)
}

/// Whether [`HypothesesOptions::yaw_history_frames`] stops the ordinary choice's switch from
/// A (`chosen`) to `best`: `|ω_z(B) − r| > m` while `|ω_z(A) − r| <= m`, `r` the recent frames'
/// reference yaw ([`HypothesisTracker::yaw_reference`]), `m`
/// [`HypothesesOptions::yaw_history_margin`], unless the ground cue is decisive: B's road score
/// `s_B` ([`score`]) is at least `ground = (min, ratio)` ([`SeparateOptions::ground_admit_min`],
/// [`SeparateOptions::ground_admit`]): `s_B >= min` and `s_B >= ratio · s_A` (`score_a`, computed
/// only if asked). A that drifted onto an object a few tenths of a degree per frame carries
/// the history with it; the static world's road then outweighs it. False with the rule off
/// or before any frame was recorded.
fn yaw_history_vetoes(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    tracker: &HypothesisTracker,
    (chosen, best): (&Candidate, &Candidate),
    (min, ratio): (usize, f64),
    score_a: impl FnOnce() -> usize,
    score_b: usize,
) -> bool {
    h.yaw_history_frames > 0
        && tracker.yaw_jumps(h, yaw_of(ctx, &best.0.params))
        && !tracker.yaw_jumps(h, yaw_of(ctx, &chosen.0.params))
        && !(score_b >= min && score_b as f64 >= ratio * score_a() as f64)
}

/// The alternative that replaces A by the odometry consistency of the yaw over the recent
/// frames ([`HypothesesOptions::yaw_history_replace`]): where `|ω_z(A) − r| > m` (`r`, `m` as
/// in [`yaw_history_vetoes`]), the alternative with the highest positive road score
/// ([`score`]; the first of equal ones) among those with `|ω_z(X) − r| <= m`. None with the
/// rule or `yaw_history_replace` off, before any frame was recorded, or where no alternative
/// qualifies.
fn yaw_history_replacement(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    tracker: &HypothesisTracker,
    obs: &FrameObservations,
    chosen: &Candidate,
    alternatives: &[Candidate],
) -> Option<Candidate> {
    if !(h.yaw_history_replace
        && h.yaw_history_frames > 0
        && tracker.yaw_jumps(h, yaw_of(ctx, &chosen.0.params)))
    {
        return None;
    }
    let qualified = alternatives
        .iter()
        .filter(|alt| !tracker.yaw_jumps(h, yaw_of(ctx, &alt.0.params)))
        .map(|alt| (road_score(ctx, h, obs, alt), alt))
        .filter(|(s, _)| *s > 0);
    first_highest(qualified)
}

/// The previous frame's motion re-solved on its support where A's yaw jumped without road
/// ([`HypothesesOptions::yaw_history_predict`] `= J`): where `|ω_z(A) − r| > J` (`r` the
/// recent frames' reference yaw, [`HypothesisTracker::yaw_reference`]; a NaN yaw counts as a
/// jump) and A's road score ([`score`]) is below [`HypothesesOptions::min_matches`], the
/// previous motion `previous` (the constant-velocity prediction) is re-solved, without the
/// rotation prior, on the matches it explains (`support`, at least 12 of them); the result
/// with its own support, where its yaw lies within
/// [`HypothesesOptions::yaw_history_margin`] of `r`; with
/// [`HypothesesOptions::yaw_history_predict_hold`] the prediction itself where that is not
/// possible. With [`HypothesesOptions::tilt_predict`] A also qualifies where its tilt jumps
/// ([`HypothesisTracker::tilt_jumps_given_road`], the road weak) and the re-solved motion
/// must not jump in tilt either. With [`HypothesesOptions::yaw_history_predict_road_frames`]
/// only where A lost the road the recent frames' chosen motions had
/// ([`HypothesisTracker::road_lost`]).
/// None with the rule off, before any frame was recorded, or where A does not qualify and
/// nothing is held.
fn yaw_history_prediction(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    tracker: &HypothesisTracker,
    obs: &FrameObservations,
    chosen: &Candidate,
    previous: &[f64],
    support: &dyn Fn(&[f64]) -> Vec<Vec<bool>>,
) -> Option<Candidate> {
    if !(h.yaw_history_predict > 0.0 && h.yaw_history_frames > 0) {
        return None;
    }
    let r = tracker.yaw_reference()?;
    // `tilt_predict`: the tilt's jump from the recent frames' (A's road is weak here).
    let tilt_jumps = |params: &[f64]| {
        h.tilt_predict
            && tracker.tilt_jumps_given_road(
                h,
                crate::hypotheses::tilt(&ctx.estimator.motion(params)),
                true,
            )
    };
    // `!(x <= J)`: a NaN yaw counts as a jump.
    if (yaw_of(ctx, &chosen.0.params) - r).abs() <= h.yaw_history_predict
        && !tilt_jumps(&chosen.0.params)
    {
        return None;
    }
    // `yaw_history_predict_road_frames`: only where A lost the road the recent frames had.
    let score_a = road_score(ctx, h, obs, chosen);
    if score_a >= h.min_matches || !tracker.road_lost(h, score_a) {
        return None;
    }
    let sup_p = support(previous);
    let solved = (count(&sup_p) >= 12)
        .then(|| ctx.solve(&subset(obs, &sup_p), previous, ctx.loss, false))
        .flatten()
        .filter(|p| !tracker.yaw_jumps(h, yaw_of(ctx, &p.params)) && !tilt_jumps(&p.params));
    if let Some(p) = solved {
        let sup = support(&p.params);
        return Some((p, sup));
    }
    if !h.yaw_history_predict_hold {
        return None;
    }
    // The prediction itself: A's solution moved to the previous motion (A's normal matrix
    // stays, the final stage refits it on the prediction's support).
    let mut p = chosen.0.clone();
    p.params = previous.to_vec();
    for (k, &i) in p.free.iter().enumerate() {
        if let (Some(x), Some(v)) = (p.report.x.get_mut(k), previous.get(i)) {
            *x = *v;
        }
    }
    Some((p, sup_p))
}

/// The model's first prior residual at `params` in magnitude, in its own standard deviations
/// (the soft single-track model's side slip `(heading − ω_z / 2) / σ_slip`; 0 for a model
/// without prior residuals).
fn slip_residual(ctx: &SolveContext<'_>, params: &[f64]) -> f64 {
    (ctx.estimator.prior_residuals(params).first()).map_or(0.0, |q| q.abs())
}

/// The previous frame's motion re-solved on its support, chosen by its own road evidence
/// ([`HypothesesOptions::predict_by_road`] `= J'`): where `x` (the motion the rules leave:
/// an alternative a rule chose to replace A, else A) has `|ω_z(x) − r| > J'` (`r` the recent
/// frames' reference yaw, [`HypothesisTracker::yaw_reference`]; a NaN yaw counts as a jump)
/// or a tilt that jumps ([`HypothesisTracker::tilt_jumps_given_road`], its road weak), and a
/// road score `s_x` ([`score`]) below [`HypothesesOptions::min_matches`], the previous motion
/// `previous` (the constant-velocity prediction) is re-solved, without the rotation prior, on
/// the matches it explains (`support`, at least 12): the result `P` with its own support,
/// where its yaw lies within [`HypothesesOptions::yaw_history_margin`] of `r`, its tilt does
/// not jump (against the least of the recent frames' tilts where
/// [`HypothesesOptions::tilt_weak_road_frames`] is set), `s_P >= min_matches` and `s_P > ρ · max(s_x, s_alt)` for every alternative
/// formed this frame (`ρ` [`HypothesesOptions::predict_by_road_ratio`]). None with the rule
/// off, before any frame was recorded, or where `x` does not qualify or `P` is not vouched for.
#[allow(clippy::too_many_arguments)]
fn road_prediction(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    tracker: &HypothesisTracker,
    obs: &FrameObservations,
    x: &Candidate,
    alternatives: &[Candidate],
    previous: &[f64],
    support: &dyn Fn(&[f64]) -> Vec<Vec<bool>>,
) -> Option<Candidate> {
    if !(h.predict_by_road > 0.0 && h.yaw_history_frames > 0) {
        return None;
    }
    let r = tracker.yaw_reference()?;
    let tilt_of = |params: &[f64]| crate::hypotheses::tilt(&ctx.estimator.motion(params));
    // `!(x <= J')`: a NaN yaw counts as a jump. (The jump first: it costs no road score.)
    let jumps = !((yaw_of(ctx, &x.0.params) - r).abs() <= h.predict_by_road)
        || tracker.tilt_jumps_given_road(h, tilt_of(&x.0.params), true);
    if !jumps {
        return None;
    }
    let score_x = road_score(ctx, h, obs, x);
    // `predict_by_slip` (the prediction alone, not with `predict_by_road_alternatives`): `X`,
    // which jumped, slides by more than `k` of the model's slip sigmas.
    let slip = |params: &[f64]| slip_residual(ctx, params);
    let slipping = h.predict_by_slip > 0.0
        && !h.predict_by_road_alternatives
        && slip(&x.0.params) > h.predict_by_slip;
    if score_x >= h.min_matches && !slipping {
        return None;
    }
    // Its tilt against the least of the recent frames' (`tilt_weak_road_frames`, as for a
    // motion without road): a prediction that carries the previous frame's tilt error is no
    // continuation of the run.
    let continues = |params: &[f64]| {
        !tracker.yaw_jumps(h, yaw_of(ctx, params))
            && !tracker.tilt_jumps_given_road(h, tilt_of(params), true)
    };
    let sup_p = support(previous);
    let p = (count(&sup_p) >= 12)
        .then(|| ctx.solve(&subset(obs, &sup_p), previous, ctx.loss, false))
        .flatten()
        .filter(|p| continues(&p.params))
        .map(|p| {
            let sup = support(&p.params);
            let c = (p, sup);
            (road_score(ctx, h, obs, &c), c)
        });
    let scores: Vec<usize> = alternatives
        .iter()
        .map(|alt| road_score(ctx, h, obs, alt))
        .collect();
    // The contest of `predict_by_road_alternatives` and `predict_by_slip_alternatives`: of
    // `P` and the alternatives (not `X` itself) that continue the history within `J'` of `r`
    // (not the wider margin `P` may use: an alternative that moved as far as `X` did is no
    // continuation, as a bus 0.8 deg off with its road-coloured lower part would be), those
    // that pass `keep`, the one with the highest road score (`P` first of equals), with that
    // score and the highest of `X`'s and the other alternatives' scores, which it must beat.
    let contest = |keep: &dyn Fn(&[f64]) -> bool| -> Option<(usize, Candidate, usize)> {
        let mut beat = score_x;
        let mut entrants: Vec<(usize, &Candidate)> = p
            .iter()
            .filter(|(_, c)| keep(&c.0.params))
            .map(|(s, c)| (*s, c))
            .collect();
        for (alt, &s) in alternatives.iter().zip(&scores) {
            if alt.0.params == x.0.params {
                continue;
            }
            if (yaw_of(ctx, &alt.0.params) - r).abs() <= h.predict_by_road
                && continues(&alt.0.params)
                && keep(&alt.0.params)
            {
                entrants.push((s, alt));
            } else {
                beat = beat.max(s);
            }
        }
        // `max_by_key` keeps the last of equal keys: over the reversed order, the first.
        let (s, c) = entrants.into_iter().rev().max_by_key(|(s, _)| *s)?;
        Some((s, c.clone(), beat))
    };
    if h.predict_by_road_alternatives {
        let (score_c, c, beat) = contest(&|_| true)?;
        return (score_c >= h.min_matches
            && score_c as f64 > h.predict_by_road_ratio * beat as f64)
            .then_some(c);
    }
    if let Some((score_p, c)) = &p {
        let best_other = scores.iter().copied().fold(score_x, usize::max);
        let by_road = score_x < h.min_matches
            && *score_p >= h.min_matches
            && *score_p as f64 > h.predict_by_road_ratio * best_other as f64;
        // `predict_by_slip`: `X` slides sideways as no car does, `P` does not, and the road
        // does not speak against `P` (ties included).
        let by_slip = slipping
            && !h.predict_by_slip_alternatives
            && slip(&c.0.params) <= h.predict_by_slip
            && *score_p >= best_other;
        if by_road || by_slip {
            return Some(c.clone());
        }
    }
    // `predict_by_slip_alternatives`: the entrants that do not slide; the best replaces `X`
    // where its road is at least `X`'s and every other alternative's.
    if !(slipping && h.predict_by_slip_alternatives) {
        return None;
    }
    let (score_c, c, beat) = contest(&|params: &[f64]| slip(params) <= h.predict_by_slip)?;
    (score_c >= beat).then_some(c)
}

/// Whether a frame keeps the next frame's change-of-motion prior although the separation
/// reports it `competing` ([`HypothesesOptions::predict_by_road_prior`]): only where the
/// re-solved prediction replaced the motion (`road_predicted`) and nothing else competed
/// (`others_competed`: an alternative kept by competition over time, or another rule's
/// replacement of A).
fn prior_kept(h: Option<&HypothesesOptions>, road_predicted: bool, others_competed: bool) -> bool {
    road_predicted && !others_competed && h.is_some_and(|h| h.predict_by_road_prior)
}

/// `k` of the `m` matches of `mask` (all of them where `m <= k`), evenly spaced in the frame's
/// order (camera by camera): the `i`-th match of `mask` (from 0) is kept where `i k mod m < k`
/// ([`SeparateOptions::candidate_subsample`]).
fn spread_subsample(mask: &[Vec<bool>], k: usize) -> Vec<Vec<bool>> {
    let m = count(mask);
    let mut i = 0usize;
    mask.iter()
        .map(|c| {
            c.iter()
                .map(|&r| {
                    let keep = r && (m <= k || (i * k) % m < k);
                    i += usize::from(r);
                    keep
                })
                .collect()
        })
        .collect()
}

/// The solver of the alternatives B, C and M: the frame's `solver` with
/// [`SeparateOptions::candidate_max_iterations`],
/// [`SeparateOptions::candidate_function_tolerance`] and
/// [`SeparateOptions::candidate_max_step_extrapolation`] applied to its `max_iterations`,
/// `function_tolerance` and `max_step_extrapolation` (where its configuration has them; e.g.
/// Levenberg-Marquardt's); `None` where no option is set or nothing changes (the frame's
/// solver then solves them).
fn candidate_solver(solver: &dyn Solver, opts: &SeparateOptions) -> Option<Box<dyn Solver>> {
    crate::config::solver_with_limits(
        solver,
        opts.candidate_max_iterations,
        opts.candidate_function_tolerance,
        opts.candidate_max_step_extrapolation,
    )
}

/// Whether competition over time ([`SeparateOptions::persistence`]; always where that is 0)
/// could keep *any* alternative to A (`chosen`: A and its support; `rest_n` matches outside
/// that support), decided before an alternative is solved: the alternatives have no other
/// use, so where this is false the separation skips their solves and its outcome is the
/// same. An alternative `x` is kept only if
/// - its persistence is at least [`SeparateOptions::persistence`], and it is at most
///   [`persistence_bound`]; or
/// - its own matches (in `x`, outside A's support, so at most `rest_n`) hold at least
///   [`SeparateOptions::own_share`] of the `n` matches and its persistence is at least
///   [`SeparateOptions::own_persistence`]; or
/// - (`ground_admit`) its own matches hold at least the share
///   [`SeparateOptions::ground_admit_own_share`] (or `own_share`) of the `n` matches and its
///   score is at least [`SeparateOptions::ground_admit_min`] and `ground_admit` times A's, its
///   score being at most [`score_bound`].
fn retain_possible(
    ctx: &SolveContext<'_>,
    opts: &SeparateOptions,
    obs: &FrameObservations,
    labels: Option<&[Vec<Option<bool>>]>,
    chosen: &Candidate,
    rest_n: usize,
) -> bool {
    if opts.persistence <= 0.0 {
        return true;
    }
    let n = obs.len();
    let p_max = labels.map_or(0.0, |l| persistence_bound(l, &chosen.1));
    if p_max >= opts.persistence {
        return true;
    }
    let own_share_possible = opts.own_share > 0.0 && rest_n as f64 >= opts.own_share * n as f64;
    if own_share_possible && p_max >= opts.own_persistence {
        return true;
    }
    let ga_share = opts.ground_admit_share();
    if !(ga_share > 0.0 && rest_n as f64 >= ga_share * n as f64) {
        return false;
    }
    let Some(h) = opts.hypotheses().filter(|_| opts.ground_admit > 0.0) else {
        return false;
    };
    let s_max = score_bound(h, ctx.rig, obs);
    if s_max < opts.ground_admit_min {
        return false;
    }
    let sa = score(
        h,
        ctx.rig,
        &ctx.estimator.motion(&chosen.0.params),
        obs,
        &chosen.1,
    );
    s_max as f64 >= opts.ground_admit * sa as f64
}

/// Whether competition over time ([`SeparateOptions::persistence`]) could keep the
/// alternative `alt` (a solution and its support `x`) against A (`chosen`) with each of its
/// thresholds times `f` ([`SeparateOptions::candidate_screen`]; `f = 1`: its own test): its
/// persistence is at least `f · persistence`, or its own matches (in `x`, outside A's support)
/// hold at least `f · own_share` of the `n` matches and either its persistence is at least
/// `f · own_persistence` or (`ground_admit`) its score is at least `f · ground_admit_min` and
/// `f · ground_admit` times A's. Always true where `persistence` is 0.
fn near_kept(
    ctx: &SolveContext<'_>,
    opts: &SeparateOptions,
    obs: &FrameObservations,
    labels: Option<&[Vec<Option<bool>>]>,
    chosen: &Candidate,
    (alt, x): (&FrameSolution, &[Vec<bool>]),
    f: f64,
) -> bool {
    if opts.persistence <= 0.0 {
        return true;
    }
    let n = obs.len();
    let p = labels.map_or(0.0, |l| persistence(l, x, &chosen.1));
    let own_met = opts.own_share > 0.0
        && count(&and(x, &not(&chosen.1))) as f64 >= f * opts.own_share * n as f64;
    if p >= f * opts.persistence || (own_met && p >= f * opts.own_persistence) {
        return true;
    }
    let Some(h) = opts
        .hypotheses()
        .filter(|_| opts.ground_admit > 0.0 && own_met)
    else {
        return false;
    };
    let s = score(h, ctx.rig, &ctx.estimator.motion(&alt.params), obs, x) as f64;
    let sa = score(
        h,
        ctx.rig,
        &ctx.estimator.motion(&chosen.0.params),
        obs,
        &chosen.1,
    ) as f64;
    s >= f * opts.ground_admit_min as f64 && s >= f * opts.ground_admit * sa
}

/// An upper bound of [`persistence`]`(labels, x, a)` over every mask `x`: `x \ a` may be any
/// subset of the matches outside `a`, and `a \ x` any subset of `a`, independently. The share
/// `p(S)` of a subset `S` of a set `T` (`o` remembered-other and `s` remembered-static labelled
/// matches) is the share over all labelled matches if `S` holds fewer than
/// [`PERSISTENCE_MIN_LABELLED`] (`m`) labelled matches, else `j / (i + j)` with `i ≤ s`,
/// `j ≤ o`, `i + j ≥ m`: at most `o / max(m, o)` (all `o`, the fewest static ones) and at least
/// `max(0, m − s) / max(m, s)` (`T` needs `o + s ≥ m`). The bound is the largest difference
/// of the two sides' extremes, computed with the same floating-point operations as
/// [`persistence`] (monotone in each count), so it holds in floating point too.
fn persistence_bound(labels: &[Vec<Option<bool>>], a: &[Vec<bool>]) -> f64 {
    // (labelled, other) inside and outside `a`.
    let (mut inside, mut outside) = ((0usize, 0usize), (0usize, 0usize));
    for (l, a) in labels.iter().zip(a) {
        for (l, a) in l.iter().zip(a) {
            if let Some(s) = l {
                let t = if *a { &mut inside } else { &mut outside };
                t.0 += 1;
                t.1 += usize::from(!s);
            }
        }
    }
    let all = (inside.0 + outside.0, inside.1 + outside.1);
    if all.0 == 0 {
        return 0.0;
    }
    let m = PERSISTENCE_MIN_LABELLED;
    let share = |t: (usize, usize)| t.1 as f64 / t.0 as f64;
    // The least and largest share of a subset of a side (labelled, other).
    let range = |(l, o): (usize, usize)| -> (f64, f64) {
        let s_all = share(all);
        if l < m {
            return (s_all, s_all);
        }
        let s = l - o;
        let hi = share((o.max(m), o));
        let lo = share((s.max(m), m.saturating_sub(s)));
        (lo.min(s_all), hi.max(s_all))
    };
    let (x, a) = (range(outside), range(inside));
    (x.1 - a.0).abs().max((a.1 - x.0).abs())
}

/// An upper bound of [`score`]`(opts, rig, motion, obs, support)` over every motion and
/// support: with [`HypothesesOptions::spread_grid`], the image cells of the matches that can
/// be road points (the ground cue: on a camera more than 0.2 m above the road, with a ray
/// below the horizon: a road point `x_v = R f₀ z₀ + c` with `z₀ > 0` lies within half the
/// camera height `h` of the road, so `(R f₀)_z < −h / (2 z₀) < 0`; a margin of `1e-6 |f₀|`
/// covers the rounding) or of all matches (the parallax cue); without it, the number of
/// matches.
fn score_bound(opts: &HypothesesOptions, rig: &Rig, obs: &FrameObservations) -> usize {
    let Some(grid) = opts.spread_grid else {
        return obs.len();
    };
    let mask: Vec<Vec<bool>> = rig
        .cameras()
        .iter()
        .zip(&obs.per_camera)
        .map(|(cam, m)| {
            let mount = &cam.t_vehicle_camera;
            let road_camera = mount.translation.z - opts.ground_z > 0.2;
            m.iter()
                .map(|o| {
                    !opts.ground
                        || (road_camera && !((mount.rotation * o.f0).z >= 1e-6 * o.f0.norm()))
                })
                .collect()
        })
        .collect();
    cells(rig, obs, &mask, grid)
}

/// The matches of `mask` (per camera, per match of `obs`) that the under-the-road test
/// ([`SeparateOptions::under_road`] on one camera, [`SeparateOptions::under_road_rig`] on a
/// rig; [`crate::hypotheses::under_road_mask`]) leaves out at the vehicle motion `motion`;
/// `None` where the test is off, has no metric scale (`metric`: the odometry's arc length),
/// flags nothing or would leave fewer than half of `mask`.
pub fn under_road_left_out(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    mask: &[Vec<bool>],
    opts: &SeparateOptions,
    metric: bool,
) -> Option<Vec<Vec<bool>>> {
    let sigmas = opts.under_road_factor(rig.len());
    if !(sigmas > 0.0 && metric) {
        return None;
    }
    let (ground_z, ground_pitch) = opts
        .hypotheses()
        .map_or((0.0, 0.0), |h| (h.ground_z, h.ground_pitch));
    let test = UnderRoad {
        ground_z,
        ground_pitch,
        noise_angle: opts.under_road_noise,
        sigmas,
        slope: opts.under_road_slope,
    };
    let out = and(mask, &under_road_mask(rig, motion, obs, mask, &test));
    let left = count(&out);
    (left > 0 && 2 * (count(mask) - left) >= count(mask)).then_some(out)
}

/// The fewest matches [`cell_capped`] keeps in a cell.
pub const CELL_CAP_MIN: usize = 2;

/// The image-region cap of `mask` as the separation applies it (`cell_cap`): the matches kept
/// at the rig's factor ([`SeparateOptions::cell_cap_factor`]; `cell_cap` on one camera) where
/// the gate passes, i.e. where the cap at `cell_cap` leaves out some and at least
/// `cell_cap_min_share` of `mask`'s matches; `None` where it does not. The gate reads
/// `cell_cap` on every rig, so a frame it passes over at `cell_cap` is passed over whatever the
/// rig's factor.
pub fn gated_cap(
    rig: &Rig,
    obs: &FrameObservations,
    mask: &[Vec<bool>],
    opts: &SeparateOptions,
) -> Option<Vec<Vec<bool>>> {
    let gate = cell_capped(rig, obs, mask, opts.cell_cap_grid, opts.cell_cap);
    let given = count(mask);
    let left_out = given.saturating_sub(count(&gate));
    if left_out == 0 || (left_out as f64) < opts.cell_cap_min_share * given as f64 {
        return None;
    }
    let factor = opts.cell_cap_factor(rig.len());
    Some(if factor == opts.cell_cap {
        gate
    } else {
        cell_capped(rig, obs, mask, opts.cell_cap_grid, factor)
    })
}

/// The order in which an over-full cell keeps its matches ([`cell_capped`]): a hash of the
/// match's four pixel coordinates' bits (splitmix64's finaliser), so the kept ones do not depend
/// on the matches' order in the file.
fn cell_cap_hash(o: &momo_core::Observation) -> u64 {
    let mut x = o.px0.x.to_bits() ^ o.px0.y.to_bits().rotate_left(21);
    x ^= o.px1.x.to_bits().rotate_left(42) ^ o.px1.y.to_bits().rotate_left(11);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// `mask` with at most `max(CELL_CAP_MIN, ceil(factor · m))` matches per image cell (frame k-1
/// pixels, `grid` per camera), `m` the median count of the camera's cells that hold a match of
/// `mask`: a cell above the cap keeps the matches that come first in the order of a hash of
/// their pixels (independent of the order of the matches, deterministic). The matches outside
/// `mask` stay out.
pub fn cell_capped(
    rig: &Rig,
    obs: &FrameObservations,
    mask: &[Vec<bool>],
    grid: (usize, usize),
    factor: f64,
) -> Vec<Vec<bool>> {
    use momo_core::CameraModel;
    let cells = grid.0 * grid.1;
    let mut out = Vec::with_capacity(mask.len());
    // Scratch shared by the cameras (issue 19: no vector per cell): each member's (cell,
    // index) in index order, and a counting sort of the members by cell (`start[c]..start[c
    // + 1]` of `order` is cell `c`'s, in index order, as a vector per cell would hold them).
    let mut start = vec![0_usize; cells + 1];
    let mut members: Vec<(usize, usize)> = Vec::new();
    let mut order: Vec<usize> = Vec::new();
    let mut next: Vec<usize> = Vec::new();
    let mut counts: Vec<usize> = Vec::new();
    for ((cam, m), k) in rig.cameras().iter().zip(&obs.per_camera).zip(mask) {
        let size = cam.model.size();
        start.fill(0);
        members.clear();
        for (i, (o, _)) in m.iter().zip(k).enumerate().filter(|(_, (_, k))| **k) {
            // The cell shared with the covariance's jackknife (a NaN pixel: cell 0).
            let c = crate::trust::cell_of((o.px0.x, o.px0.y), size, grid);
            start[c + 1] += 1;
            members.push((c, i));
        }
        counts.clear();
        counts.extend(start[1..].iter().copied().filter(|c| *c > 0));
        let mut keep = k.clone();
        if !counts.is_empty() {
            counts.sort_unstable();
            let median = counts[counts.len() / 2] as f64;
            let cap = ((factor * median).ceil() as usize).max(CELL_CAP_MIN);
            let hash = cell_cap_hash;
            if counts.last().is_some_and(|n| *n > cap) {
                for c in 0..cells {
                    start[c + 1] += start[c];
                }
                order.clear();
                order.resize(members.len(), 0);
                next.clear();
                next.extend_from_slice(&start[..cells]);
                for &(c, i) in &members {
                    order[next[c]] = i;
                    next[c] += 1;
                }
                for c in 0..cells {
                    let cell = &mut order[start[c]..start[c + 1]];
                    if cell.len() > cap {
                        cell.sort_by_key(|i| (hash(&m[*i]), *i));
                        for i in &cell[cap..] {
                            keep[*i] = false;
                        }
                    }
                }
            }
        }
        out.push(keep);
    }
    out
}

/// [`cell_capped`] as it was written first (a vector per cell): the reference of the test
/// `cell_capped_matches_the_vector_per_cell_reference`.
#[cfg(test)]
fn cell_capped_reference(
    rig: &Rig,
    obs: &FrameObservations,
    mask: &[Vec<bool>],
    grid: (usize, usize),
    factor: f64,
) -> Vec<Vec<bool>> {
    use momo_core::CameraModel;
    let mut out = Vec::with_capacity(mask.len());
    for ((cam, m), k) in rig.cameras().iter().zip(&obs.per_camera).zip(mask) {
        let size = cam.model.size();
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); grid.0 * grid.1];
        for (i, (o, _)) in m.iter().zip(k).enumerate().filter(|(_, (_, k))| **k) {
            members[crate::trust::cell_of((o.px0.x, o.px0.y), size, grid)].push(i);
        }
        let mut counts: Vec<usize> = members.iter().map(Vec::len).filter(|c| *c > 0).collect();
        let mut keep = k.clone();
        if !counts.is_empty() {
            counts.sort_unstable();
            let median = counts[counts.len() / 2] as f64;
            let cap = ((factor * median).ceil() as usize).max(CELL_CAP_MIN);
            let hash = cell_cap_hash;
            for cell in members.iter_mut().filter(|c| c.len() > cap) {
                cell.sort_by_key(|i| (hash(&m[*i]), *i));
                for i in &cell[cap..] {
                    keep[*i] = false;
                }
            }
        }
        out.push(keep);
    }
    out
}

/// The frame's noise `σ̂` from the epipolar angles under A, trimmed as the final stage trims
/// its residuals ([`crate::final_fit::estimate_sigma`], its default options, in units of the
/// first stage's loss scale `scale`; a non-finite scale, e.g. plain least squares, starts
/// from 0.003 rad).
pub fn noise_sigma(angles: &[Vec<f64>], scale: f64) -> Option<f64> {
    let scale = if scale.is_finite() && scale > 0.0 {
        scale
    } else {
        0.003
    };
    let all: Vec<f64> = angles.iter().flatten().copied().collect();
    crate::final_fit::estimate_sigma(&all, scale, &crate::final_fit::FinalFitOptions::default())
}

/// Labelled matches a side of the split needs for its own share in [`persistence`].
const PERSISTENCE_MIN_LABELLED: usize = 8;

/// How far the memory's labels (`Some(true)`: static, `Some(false)`: other; per camera, per
/// match) follow the split of the matches between the supports `x` and `a` of two motions:
/// `|p(x \ a) − p(a \ x)|`, where `p(S)` is the share of remembered-other matches among the
/// labelled matches of `S` (the matches only that motion explains). A side with fewer than
/// [`PERSISTENCE_MIN_LABELLED`] labelled matches takes the share over all labelled matches
/// instead. 0 if nothing is labelled. A second motion that persists from the previous frame
/// pair splits the matches as the memory does (its own matches remembered other and A's
/// static, or the reverse after a lock-in): near 1. A motion fitted to a static scene's noise
/// tail splits them by this frame's noise, independent of the previous frame's: near 0.
pub fn persistence(labels: &[Vec<Option<bool>>], x: &[Vec<bool>], a: &[Vec<bool>]) -> f64 {
    // (labelled, other) over the matches where `keep` holds.
    let tally = |keep: &dyn Fn(bool, bool) -> bool| -> (usize, usize) {
        let mut t = (0, 0);
        for ((l, x), a) in labels.iter().zip(x).zip(a) {
            for ((l, x), a) in l.iter().zip(x).zip(a) {
                if let Some(s) = l
                    && keep(*x, *a)
                {
                    t.0 += 1;
                    t.1 += usize::from(!s);
                }
            }
        }
        t
    };
    let all = tally(&|_, _| true);
    if all.0 == 0 {
        return 0.0;
    }
    let share = |t: (usize, usize)| {
        let t = if t.0 >= PERSISTENCE_MIN_LABELLED {
            t
        } else {
            all
        };
        t.1 as f64 / t.0 as f64
    };
    let only_x = tally(&|x, a| x && !a);
    let only_a = tally(&|x, a| a && !x);
    (share(only_x) - share(only_a)).abs()
}

/// Element-wise `a && b` of two masks.
pub(crate) fn and(a: &[Vec<bool>], b: &[Vec<bool>]) -> Vec<Vec<bool>> {
    a.iter()
        .zip(b)
        .map(|(a, b)| a.iter().zip(b).map(|(a, b)| *a && *b).collect())
        .collect()
}

/// Element-wise `!a` of a mask.
pub(crate) fn not(a: &[Vec<bool>]) -> Vec<Vec<bool>> {
    a.iter().map(|m| m.iter().map(|k| !k).collect()).collect()
}

/// The memory's vote for the alternative B against A ([`SeparateOptions::memory_vote`]),
/// each given as (ground score, support): true where the ground scores are not decisive, both
/// supports hold at least [`SeparateOptions::memory_vote_min`] labelled matches, B's
/// remembered-static share exceeds A's by [`SeparateOptions::memory_vote`] and B's own matches
/// hold [`SeparateOptions::own_share`] of the frame's.
pub fn memory_vote(
    opts: &SeparateOptions,
    labels: &[Vec<Option<bool>>],
    a: (usize, &[Vec<bool>]),
    b: (usize, &[Vec<bool>]),
) -> bool {
    let decisive = |x: usize, y: usize| {
        x >= opts.ground_admit_min && x as f64 >= opts.memory_vote_ground * y as f64
    };
    if opts.memory_vote <= 0.0 || decisive(a.0, b.0) || decisive(b.0, a.0) {
        return false;
    }
    let share = |sup: &[Vec<bool>]| static_share(labels, sup, opts.memory_vote_min);
    let (Some(fa), Some(fb)) = (share(a.1), share(b.1)) else {
        return false;
    };
    // B's own matches (in its support, outside A's).
    let own =
        b.1.iter()
            .zip(a.1)
            .map(|(b, a)| b.iter().zip(a).filter(|(b, a)| **b && !**a).count())
            .sum::<usize>();
    let n: usize = labels.iter().map(Vec::len).sum();
    fb - fa >= opts.memory_vote && own as f64 >= opts.own_share * n as f64
}

/// The remembered-static share from which a support may continue the previous frame's chosen
/// motion, and below which it may continue the rejected one
/// ([`HypothesesOptions::track_decay`]).
const TRACK_SPLIT_SHARE: f64 = 0.5;

/// The remembered-static share `static / (static + other)` of the labelled matches in `sup`
/// (labels per camera, per match: `Some(true)` static), where they are at least `min` (and 1).
fn static_share(labels: &[Vec<Option<bool>>], sup: &[Vec<bool>], min: usize) -> Option<f64> {
    let (mut st, mut ot) = (0usize, 0usize);
    for (l, m) in labels.iter().zip(sup) {
        for (l, m) in l.iter().zip(m) {
            match (m, l) {
                (true, Some(true)) => st += 1,
                (true, Some(false)) => ot += 1,
                _ => {}
            }
        }
    }
    (st + ot >= min.max(1)).then(|| st as f64 / (st + ot) as f64)
}

/// The matches the memory labels `label` (static: `true`).
fn label_mask(labels: &[Vec<Option<bool>>], label: bool) -> Vec<Vec<bool>> {
    labels
        .iter()
        .map(|m| m.iter().map(|l| *l == Some(label)).collect())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_validate_and_parse() {
        let d = SeparateOptions::default();
        assert!(d.validate().is_ok());
        assert!(!d.final_robust);
        assert!(
            d.plausibility_margin < 0.0,
            "the plausibility choice is off by default"
        );
        let nan = SeparateOptions {
            plausibility_margin: f64::NAN,
            ..d.clone()
        };
        assert!(nan.validate().unwrap_err().contains("plausibility_margin"));
        let o: SeparateOptions =
            toml::from_str("final_robust = true\nplausibility_margin = 16.0").unwrap();
        assert!(o.final_robust);
        assert_eq!(o.plausibility_margin, 16.0);
        assert!(toml::from_str::<SeparateOptions>("final_robustness = true").is_err());
        let o: SeparateOptions = toml::from_str(
            "min_cell_ratio = 0.5\nfinal_exclusive = true\nfinal_competing_only = true\nfinal_passes = 2",
        )
        .unwrap();
        assert_eq!((o.min_cell_ratio, o.final_passes), (0.5, 2));
        assert!(o.final_exclusive && o.final_competing_only);
        let o: SeparateOptions =
            toml::from_str("under_road = 3.0\nunder_road_slope = 0.05").unwrap();
        assert_eq!((o.under_road, o.under_road_slope), (3.0, 0.05));
        assert!(o.validate().is_ok());
        assert_eq!(SeparateOptions::default().under_road, 0.0, "off by default");
        // One camera reads `under_road`, a rig of several `under_road_rig`; the default's
        // separation tests on both (one camera guarded, since the sixty-fourth session), the
        // bare one nowhere.
        let o: SeparateOptions = toml::from_str("under_road = 3.0\nunder_road_rig = 0.5").unwrap();
        assert_eq!((o.under_road_factor(1), o.under_road_factor(4)), (3.0, 0.5));
        let d = SeparateOptions::competition_over_time();
        assert_eq!((d.under_road_factor(1), d.under_road_factor(2)), (3.0, 3.0));
        assert!(d.under_road_guard);
        let b = SeparateOptions::default();
        assert_eq!((b.under_road_factor(1), b.under_road_factor(2)), (0.0, 0.0));
        for bad in [
            "under_road = -1.0",
            "under_road_rig = -1.0",
            "under_road_rig = nan",
            "under_road_noise = 0.0",
            "under_road_slope = 1.5",
            "min_cell_ratio = -1.0",
            "final_passes = 0",
            "final_passes = 11",
        ] {
            let o: SeparateOptions = toml::from_str(bad).unwrap();
            assert!(o.validate().is_err(), "{bad}");
        }
    }

    /// The counting sort of [`cell_capped`] keeps exactly the matches of the vector per cell
    /// it replaced (issue 19): random pixels clustered in a few cells or spread (pixels
    /// outside the image and NaN pixels included), random masks, grids and factors, one
    /// camera and the four-camera fisheye rig.
    #[test]
    fn cell_capped_matches_the_vector_per_cell_reference() {
        use momo_core::{CameraModel, Observation};
        use nalgebra::Vector2;
        use proptest::prelude::*;
        let rigs = [
            momo_testing::canned::pinhole_rig(),
            momo_testing::canned::fisheye_rig(),
        ];
        let pixel = prop_oneof![
            4 => (0.0..1.0_f64, 0.0..1.0_f64),
            4 => (0.40..0.45_f64, 0.5..0.56_f64),
            1 => (-0.5..1.5_f64, -0.5..1.5_f64),
            1 => Just((f64::NAN, 0.5)),
        ];
        let case = (
            0..2_usize,
            proptest::collection::vec((pixel, any::<bool>(), 0..4_usize), 0..300),
            (1..20_usize, 1..12_usize),
            prop_oneof![Just(1.0), Just(2.0), 0.5..4.0_f64],
        );
        proptest!(ProptestConfig::with_cases(256), |((r, pts, grid, factor) in case)| {
            let rig = &rigs[r];
            let n_cam = rig.len();
            let mut per_camera = vec![Vec::new(); n_cam];
            let mut mask = vec![Vec::new(); n_cam];
            for ((u, v), keep, cam) in pts {
                let j = cam % n_cam;
                let model = &rig.cameras()[j].model;
                let (w, h) = model.size();
                let px = Vector2::new(u * w, v * h);
                // Observation::new needs pixels that unproject; others take a valid pixel's
                // bearings with the raw pixel (cell_of reads px0 alone).
                let mut o = Observation::new(model, Vector2::new(0.5 * w, 0.5 * h), Vector2::new(0.5 * w + 1.0, 0.5 * h))
                    .expect("the centre unprojects");
                o.px0 = px;
                o.px1 = Vector2::new(px.x + 1.0, px.y - 0.5);
                per_camera[j].push(o);
                mask[j].push(keep);
            }
            let obs = FrameObservations { per_camera, cross_camera: Vec::new() };
            prop_assert_eq!(
                cell_capped(rig, &obs, &mask, grid, factor),
                cell_capped_reference(rig, &obs, &mask, grid, factor)
            );
        });
    }

    /// `cell_cap`: a compact cluster of matches is cut to the cap, a spread-out scene (one
    /// match per cell) is kept whole, matches outside the mask stay out, and which matches a
    /// full cell keeps does not depend on the order of the matches.
    #[test]
    fn cell_cap_cuts_a_compact_cluster_and_keeps_a_spread_scene() {
        use momo_core::{CameraModel, Observation};
        use nalgebra::Vector2;
        let rig = momo_testing::canned::pinhole_rig();
        let cam = &rig.cameras()[0];
        let (w, h) = cam.model.size();
        let grid = (16, 8);
        let (cw, ch) = (w / 16.0, h / 8.0);
        let at = |x: f64, y: f64| {
            Observation::new(
                &cam.model,
                Vector2::new(x, y),
                Vector2::new(x + 1.0, y - 0.5),
            )
            .expect("the pixel unprojects")
        };
        // One match at the centre of every cell (the median count is 1), then 40 more in
        // cell (7, 4): a compact object near the image centre.
        let mut matches: Vec<Observation> = (0..8)
            .flat_map(|r| (0..16).map(move |c| (c, r)))
            .map(|(c, r)| at((f64::from(c) + 0.5) * cw, (f64::from(r) + 0.5) * ch))
            .collect();
        let cluster = 4 * 16 + 7;
        for i in 0..40 {
            let (dx, dy) = (f64::from(i % 8) + 0.5, f64::from(i / 8) + 0.5);
            matches.push(at(7.0 * cw + dx * cw / 8.5, 4.0 * ch + dy * ch / 5.5));
        }
        let n = matches.len();
        let frame = |m: Vec<Observation>| FrameObservations {
            per_camera: vec![m],
            cross_camera: Vec::new(),
        };
        let obs = frame(matches.clone());
        let kept = cell_capped(&rig, &obs, &[vec![true; n]], grid, 2.0);
        // The cap is max(2, ceil(2 · 1)) = 2: the cluster's cell keeps 2 of its 41 matches,
        // every other cell its one.
        assert_eq!(count(&kept), 127 + 2);
        assert!((0..128).all(|i| kept[0][i] || i == cluster));
        // A factor of 10 lifts the cap to 10.
        assert_eq!(
            count(&cell_capped(&rig, &obs, &[vec![true; n]], grid, 10.0)),
            127 + 10
        );
        // The spread-out scene alone is kept whole.
        let spread = frame(matches[..128].to_vec());
        assert_eq!(
            cell_capped(&rig, &spread, &[vec![true; 128]], grid, 2.0),
            vec![vec![true; 128]]
        );
        // Matches outside the mask stay out and do not count.
        let mut mask = vec![true; n];
        mask[0] = false;
        mask[130] = false;
        let k = cell_capped(&rig, &obs, &[mask], grid, 2.0);
        assert!(!k[0][0] && !k[0][130]);
        assert_eq!(count(&k), 126 + 2);
        // Order independence: the reversed matches keep the reversed choice.
        let reversed = frame(matches.iter().rev().copied().collect());
        let mut back = cell_capped(&rig, &reversed, &[vec![true; n]], grid, 2.0);
        back[0].reverse();
        assert_eq!(back, kept);
        // Validation.
        for bad in [
            "cell_cap = -1.0",
            "cell_cap_grid = [0, 8]",
            "cell_cap_min_share = 1.5",
            "ground_admit = -1.0",
            "ground_admit = nan",
            "memory_vote = 1.5",
            "memory_vote = -0.1",
            "memory_vote_ground = 0.5",
            "memory_vote_ground = inf",
            "ground_admit_own_share = 1.5",
            "ground_admit_own_share = -0.1",
        ] {
            let o: SeparateOptions = toml::from_str(bad).unwrap();
            assert!(o.validate().is_err(), "{bad}");
        }
    }

    #[test]
    fn a_rig_caps_at_its_own_factor_where_the_gate_at_cell_cap_passes() {
        use momo_core::{CameraModel, Observation};
        use nalgebra::Vector2;
        let rig = momo_testing::canned::fisheye_rig();
        let grid = (16, 8);
        // Per camera two matches in every cell (the median count is 2); in the front camera 40
        // more in one cell: a compact vehicle.
        let scene = |cluster: bool| {
            let per_camera = rig
                .cameras()
                .iter()
                .enumerate()
                .map(|(j, cam)| {
                    let (w, h) = cam.model.size();
                    let (cw, ch) = (w / 16.0, h / 8.0);
                    let at = |x: f64, y: f64| {
                        Observation::new(&cam.model, Vector2::new(x, y), Vector2::new(x + 1.0, y))
                            .expect("the pixel unprojects")
                    };
                    let mut m: Vec<Observation> = (0..8)
                        .flat_map(|r| (0..16).map(move |c| (c, r)))
                        .flat_map(|(c, r)| {
                            let (x, y) = (f64::from(c) * cw, (f64::from(r) + 0.5) * ch);
                            [at(x + 0.3 * cw, y), at(x + 0.7 * cw, y)]
                        })
                        .collect();
                    if cluster && j == 0 {
                        for i in 0..40 {
                            let (dx, dy) = (f64::from(i % 8) + 0.5, f64::from(i / 8) + 0.5);
                            m.push(at(7.0 * cw + dx * cw / 8.5, 4.0 * ch + dy * ch / 5.5));
                        }
                    }
                    m
                })
                .collect();
            FrameObservations {
                per_camera,
                cross_camera: Vec::new(),
            }
        };
        let all = |obs: &FrameObservations| -> Vec<Vec<bool>> {
            obs.per_camera.iter().map(|m| vec![true; m.len()]).collect()
        };
        let opts = SeparateOptions::competition_over_time();
        assert_eq!((opts.cell_cap, opts.cell_cap_rig_scale), (2.0, 0.5));
        assert_eq!(opts.cell_cap_factor(4), 1.0);
        assert_eq!(opts.cell_cap_factor(1), 2.0);
        let obs = scene(true);
        let n = obs.len();
        // The gate reads the cap at cell_cap = 2 (max(2, 2 · 2) = 4 per cell: the cluster's
        // cell keeps 4 of its 42, 38 left out), the rig keeps max(2, 1 · 2) = 2 there.
        assert_eq!(
            count(&cell_capped(&rig, &obs, &all(&obs), grid, 2.0)),
            n - 38
        );
        let passing = SeparateOptions {
            cell_cap_min_share: 38.0 / n as f64,
            ..opts.clone()
        };
        let kept = gated_cap(&rig, &obs, &all(&obs), &passing).expect("the gate passes");
        assert_eq!(count(&kept), n - 40);
        assert_eq!(kept, cell_capped(&rig, &obs, &all(&obs), grid, 1.0));
        // The gate reads 38 left out, not the rig cap's 40.
        let closed = SeparateOptions {
            cell_cap_min_share: 39.0 / n as f64,
            ..opts.clone()
        };
        assert_eq!(gated_cap(&rig, &obs, &all(&obs), &closed), None);
        // Scale 1: the rig's cap is the gate's.
        let one = SeparateOptions {
            cell_cap_rig_scale: 1.0,
            ..passing.clone()
        };
        let kept_one = gated_cap(&rig, &obs, &all(&obs), &one).expect("the gate passes");
        assert_eq!(count(&kept_one), n - 38);
        // A spread-out scene: the cap at cell_cap leaves nothing out, so nothing is capped,
        // though the rig's own cap would cut every cell with a third match.
        let spread = scene(false);
        assert_eq!(gated_cap(&rig, &spread, &all(&spread), &passing), None);
        // One camera: the cap at cell_cap itself.
        let mono = momo_testing::canned::pinhole_rig();
        let cam = &mono.cameras()[0];
        let (w, h) = cam.model.size();
        let one_cam = FrameObservations {
            per_camera: vec![
                (0..60)
                    .map(|i| {
                        let x = if i < 40 {
                            w / 2.0 + f64::from(i) * 0.1
                        } else {
                            f64::from(i) * w / 61.0
                        };
                        Observation::new(
                            &cam.model,
                            Vector2::new(x, h / 2.0),
                            Vector2::new(x + 1.0, h / 2.0),
                        )
                        .expect("the pixel unprojects")
                    })
                    .collect(),
            ],
            cross_camera: Vec::new(),
        };
        let at_cap = cell_capped(&mono, &one_cam, &all(&one_cam), grid, 2.0);
        assert!(60 - count(&at_cap) >= 12, "the gate at 0.2 passes");
        let kept_mono = gated_cap(&mono, &one_cam, &all(&one_cam), &opts).expect("gate passes");
        assert_eq!(kept_mono, at_cap);
        // Validation: the scale is a positive number.
        for bad in [
            "cell_cap_rig_scale = 0.0",
            "cell_cap_rig_scale = -1.0",
            "cell_cap_rig_scale = nan",
        ] {
            let o: SeparateOptions = toml::from_str(bad).unwrap();
            assert!(o.validate().is_err(), "{bad}");
        }
    }

    /// The memory's vote (`memory_vote`): for B only where the ground scores are not
    /// decisive, both supports are labelled enough, B's remembered-static share exceeds A's by
    /// the margin and B holds its own matches.
    #[test]
    fn memory_vote_follows_the_remembered_static_share_where_the_ground_does_not_decide() {
        // 100 matches: 0..50 remembered static, 50..90 remembered other, 90..100 unlabelled.
        let labels = vec![
            (0..100)
                .map(|i| match i {
                    0..50 => Some(true),
                    50..90 => Some(false),
                    _ => None,
                })
                .collect::<Vec<_>>(),
        ];
        let mask = |r: &[std::ops::Range<usize>]| -> Vec<Vec<bool>> {
            vec![(0..100).map(|i| r.iter().any(|r| r.contains(&i))).collect()]
        };
        // S: mostly remembered static (45 of 50 labelled); O: mostly remembered other (40 of
        // 45), each with 35 or more own matches against the other.
        let s = mask(&[0..45, 50..55]);
        let o = mask(&[45..50, 55..95]);
        let opts = SeparateOptions {
            memory_vote: 0.3,
            memory_vote_ground: 1.5,
            ..SeparateOptions::competition_over_time()
        };
        // Ground scores 4 and 7 (not decisive): the memory votes for S against O, never for O.
        assert!(memory_vote(&opts, &labels, (7, &o), (4, &s)));
        assert!(!memory_vote(&opts, &labels, (4, &s), (7, &o)));
        // A decisive ground score (at least 12 cells and 1.5 times the other) decides alone.
        assert!(!memory_vote(&opts, &labels, (12, &o), (8, &s)));
        assert!(!memory_vote(&opts, &labels, (4, &o), (12, &s)));
        assert!(memory_vote(&opts, &labels, (11, &o), (8, &s)));
        // Off, or a margin above the shares' difference (0.9 - 0.11): no vote.
        for v in [0.0, 0.8] {
            let off = SeparateOptions {
                memory_vote: v,
                ..opts.clone()
            };
            assert!(!memory_vote(&off, &labels, (7, &o), (4, &s)), "{v}");
        }
        // Too few labelled matches in a support (O has 45).
        let few = SeparateOptions {
            memory_vote_min: 46,
            ..opts.clone()
        };
        assert!(!memory_vote(&few, &labels, (7, &o), (4, &s)));
        // A remembered-static alternative inside A's support (own matches 5 < 10): no vote
        // for it, though its share is higher; without the own-share test it would get one.
        let inside = mask(&[0..40, 90..95]);
        let a = mask(&[0..40, 50..90]);
        assert!(!memory_vote(&opts, &labels, (4, &a), (7, &inside)));
        let no_own = SeparateOptions {
            own_share: 0.0,
            ..opts.clone()
        };
        assert!(memory_vote(&no_own, &labels, (4, &a), (7, &inside)));
    }

    /// The one-pass statistic and mask of the odometry (`trust::residual_statistic_and_outside`):
    /// the mask is `epipolar_at_least`'s, the statistic `cell_residual_statistic`'s to rounding.
    #[test]
    fn one_pass_statistic_and_mask_match_the_two_passes() {
        for (rig, n) in [
            (momo_testing::canned::fisheye_rig(), 60),
            (momo_testing::canned::pinhole_rig(), 300),
        ] {
            let truth = Pose::new(
                momo_core::so3_exp(&nalgebra::Vector3::new(0.01, -0.02, 0.03)),
                nalgebra::Vector3::new(1.0, 0.05, 0.01),
            );
            let obs = momo_testing::canned::synthetic_observations(&rig, &truth, n, 20, 5);
            let off = Pose::new(
                momo_core::so3_exp(&nalgebra::Vector3::new(0.0, 0.0, 0.035)),
                nalgebra::Vector3::new(1.0, 0.0, 0.0),
            );
            let mut compared = 0;
            for motion in [truth, off] {
                for t in [1e-3, 0.01, 0.05, 0.1] {
                    for grid in [(8, 4), (3, 2)] {
                        let (stat, mask) = crate::trust::residual_statistic_and_outside(
                            &rig, &motion, &obs, grid, t,
                        );
                        assert_eq!(mask, epipolar_at_least(&rig, &motion, &obs, t), "{t}");
                        let want =
                            crate::trust::cell_residual_statistic(&rig, &motion, &obs, grid, t);
                        match (stat, want) {
                            (Some((a, ca)), Some((b, cb))) => {
                                assert_eq!(ca, cb, "cells, threshold {t}");
                                assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}, {t}");
                                compared += 1;
                            }
                            (None, None) => {}
                            other => panic!("threshold {t}: {other:?}"),
                        }
                    }
                }
            }
            assert!(compared >= 8, "only {compared} statistics compared");
        }
    }

    /// The shortcut gives the same mask as the angles, at and around the threshold.
    #[test]
    fn epipolar_at_least_matches_the_angles() {
        let rig = momo_testing::canned::fisheye_rig();
        let truth = Pose::new(
            momo_core::so3_exp(&nalgebra::Vector3::new(0.01, -0.02, 0.03)),
            nalgebra::Vector3::new(1.0, 0.05, 0.01),
        );
        let obs = momo_testing::canned::synthetic_observations(&rig, &truth, 60, 20, 5);
        let off = Pose::new(
            momo_core::so3_exp(&nalgebra::Vector3::new(0.0, 0.0, 0.035)),
            nalgebra::Vector3::new(1.0, 0.0, 0.0),
        );
        for motion in [truth, off] {
            let angles = epipolar_angles(&rig, &motion, &obs);
            let mut thresholds = vec![-1.0, 0.0, 1e-3, 0.01, 0.1, 1.5, 2.0];
            // Exactly at some matches' angles, where only the angle can decide.
            thresholds.extend(angles.iter().flatten().step_by(7).copied());
            for t in thresholds {
                let mask = epipolar_at_least(&rig, &motion, &obs, t);
                let want: Vec<Vec<bool>> = angles
                    .iter()
                    .map(|c| c.iter().map(|x| *x >= t).collect())
                    .collect();
                assert_eq!(mask, want, "threshold {t}");
                // The alternatives' support (`separate_with`) is its negation: `x < t`.
                let below: Vec<Vec<bool>> = angles
                    .iter()
                    .map(|c| c.iter().map(|x| *x < t).collect())
                    .collect();
                let negated: Vec<Vec<bool>> = mask
                    .iter()
                    .map(|c| c.iter().map(|x| !x).collect())
                    .collect();
                assert_eq!(negated, below, "threshold {t}");
            }
        }
    }

    /// Frames of a simulated scenario where the separation finds competing motions, with
    /// `opts`; each frame's A is the default model's solve from straight ahead at the true
    /// arc length.
    fn competing_frames(sim: &momo_sim::Simulation, opts: &SeparateOptions) -> (usize, usize) {
        let config = crate::Config::default();
        let estimator = config.model.build(config.metric.as_ref()).expect("model");
        let rig = &sim.sequence.rig;
        let arc_index = estimator.arc_length_index().expect("arc length");
        let mut fixed = vec![false; estimator.param_names().len()];
        fixed[arc_index] = true;
        let ctx = SolveContext {
            rig,
            estimator: estimator.as_ref(),
            loss: config.loss.as_ref(),
            solver: config.solver.as_ref(),
            fixed: &fixed,
            motion_prior: None,
        };
        let (mut competing, mut frames) = (0, 0);
        let mut tracker = HypothesisTracker::default();
        for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
            let arc = sim.true_arc_lengths[k];
            let start = estimator.initial_params(arc);
            let Some(first) = ctx.solve(obs, &start, ctx.loss, false) else {
                continue;
            };
            let (_, o, _) = separate(&ctx, opts, obs, first, &[start], &mut tracker, Some(arc));
            frames += 1;
            competing += usize::from(o.competing);
        }
        (competing, frames)
    }

    /// A static fisheye rig (0.5 px at f = 330 px: the fixed 0.003 rad support threshold is
    /// about the noise at the image edges) is flagged competing by the fixed threshold alone
    /// (the false competition of docs/RESULTS.md §9), not when a second motion must have its
    /// own matches far from A in units of the frame's noise (`distinct_sigmas`) or spatially
    /// coherent ones (`coherence`). Measured (A solved without prior from straight ahead):
    /// the fixed threshold flags 39 of 39 rig frames, the two tests none. On the first 40
    /// frames of the built-in moving-traffic drive the fixed threshold flags 36 of 39, the two
    /// tests none either: they cost the family its separation (docs/RESULTS.md §9, ninth
    /// session), so they stay off.
    #[test]
    fn a_static_fisheye_rig_frame_is_not_flagged_competing() {
        use momo_sim::{SimConfig, simulate};
        let distinct = SeparateOptions {
            threshold_sigmas: 3.0,
            distinct_sigmas: 4.0,
            ..SeparateOptions::default()
        };
        let coherent = SeparateOptions {
            coherence: 0.35,
            ..SeparateOptions::default()
        };
        let fixed = SeparateOptions::default();
        let rig = simulate(&SimConfig {
            frames: 40,
            seed: 1,
            ..SimConfig::fisheye_surround()
        })
        .expect("simulation");
        let (c_fixed, n) = competing_frames(&rig, &fixed);
        let (c_distinct, n2) = competing_frames(&rig, &distinct);
        let (c_coherent, _) = competing_frames(&rig, &coherent);
        eprintln!(
            "fisheye rig: competing frames fixed {c_fixed}/{n}, distinct {c_distinct}, coherent {c_coherent}"
        );
        assert!(n >= 35 && n2 == n);
        assert!(c_fixed > 0, "the fixed threshold's false competition");
        assert_eq!(c_distinct, 0, "a static rig is one motion");
        assert_eq!(c_coherent, 0, "a static rig is one motion");
        let traffic = simulate(&SimConfig {
            frames: 40,
            seed: 1,
            ..SimConfig::moving_traffic()
        })
        .expect("simulation");
        let (t_fixed, m) = competing_frames(&traffic, &fixed);
        let (t_distinct, _) = competing_frames(&traffic, &distinct);
        let (t_coherent, _) = competing_frames(&traffic, &coherent);
        eprintln!(
            "moving traffic: competing frames fixed {t_fixed}/{m}, distinct {t_distinct}, coherent {t_coherent}"
        );
        assert!(t_fixed >= m / 4, "{t_fixed} of {m}");
        assert!(t_distinct <= t_fixed && t_coherent <= t_fixed);
    }

    /// The persistence statistic: labels that follow the split give 1 (either way round),
    /// labels independent of it 0, a side with too few labelled matches falls back to the
    /// frame's share, nothing labelled gives 0.
    #[test]
    fn persistence_follows_the_memory_split() {
        let n = 40;
        // x explains matches 0..20, a explains 10..40: only-x 0..10, only-a 20..40.
        let x = vec![(0..n).map(|i| i < 20).collect::<Vec<_>>()];
        let a = vec![(0..n).map(|i| i >= 10).collect::<Vec<_>>()];
        let label = |f: &dyn Fn(usize) -> Option<bool>| vec![(0..n).map(f).collect::<Vec<_>>()];
        // The previous frame saw the only-x matches as other, the rest static.
        let follows = label(&|i| Some(i >= 10));
        assert_eq!(persistence(&follows, &x, &a), 1.0);
        // After a lock-in the labels are the reverse: still a persistent split.
        let reverse = label(&|i| Some(i < 10));
        assert_eq!(persistence(&reverse, &x, &a), 1.0);
        // Labels alternating along the matches follow no split.
        let random = label(&|i| Some(i % 2 == 0));
        assert_eq!(persistence(&random, &x, &a), 0.0);
        // Nothing remembered.
        assert_eq!(persistence(&label(&|_| None), &x, &a), 0.0);
        // Only-x has 4 labelled matches (< 8): its share is the frame's (4 other of 24
        // labelled), only-a's 0 of 20.
        let few = label(&|i| match i {
            0..4 => Some(false),
            4..10 => None,
            _ => Some(true),
        });
        let p = persistence(&few, &x, &a);
        assert!((p - 4.0 / 34.0).abs() < 1e-12, "{p}");
        let bad = SeparateOptions {
            persistence: 0.5,
            ..SeparateOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("memory_radius"));
        let ok = SeparateOptions {
            memory_radius: 20.0,
            ..bad
        };
        assert!(ok.validate().is_ok());
    }

    /// Competition over time: with the match memory, a second motion competes only where the
    /// split persists from the previous frame pair. The static fisheye rig's false competition
    /// (its noise tail is re-drawn every frame) goes, the moving-traffic drive keeps some of
    /// its competing frames (measured at 0.25, A solved without prior from straight ahead, seed
    /// 1: rig 39 of 39 -> 0, traffic 36 of 39 -> 7; many of the drive's 36 are its own noise
    /// tail, not an object).
    #[test]
    fn competition_over_time_tells_a_static_rig_from_moving_traffic() {
        use momo_sim::{SimConfig, simulate};
        let memory = SeparateOptions {
            memory_radius: 20.0,
            ..SeparateOptions::default()
        };
        let persistent = SeparateOptions {
            persistence: 0.25,
            ..memory.clone()
        };
        let rig = simulate(&SimConfig {
            frames: 40,
            seed: 1,
            ..SimConfig::fisheye_surround()
        })
        .expect("simulation");
        let (r_memory, n) = competing_frames(&rig, &memory);
        let (r_persistent, _) = competing_frames(&rig, &persistent);
        let traffic = simulate(&SimConfig {
            frames: 40,
            seed: 1,
            ..SimConfig::moving_traffic()
        })
        .expect("simulation");
        let (t_memory, m) = competing_frames(&traffic, &memory);
        let (t_persistent, _) = competing_frames(&traffic, &persistent);
        eprintln!(
            "competing frames: fisheye rig {r_memory}/{n} -> {r_persistent}, moving traffic {t_memory}/{m} -> {t_persistent}"
        );
        assert!(n >= 35 && r_memory > n / 2, "the rig's false competition");
        assert!(r_persistent <= n / 10, "{r_persistent} of {n}");
        assert!(
            t_persistent >= m / 10 && t_persistent > r_persistent + 2,
            "{t_persistent} of {m}"
        );
    }

    /// `own_share`: an alternative the memory does not follow still competes where its own
    /// matches (in its support, outside A's) are a large share of the frame. The fisheye rig's
    /// noise tail never is (its own matches stay below 8 % of the matches); moving traffic's
    /// objects are in more frames than persistence alone keeps.
    #[test]
    fn own_share_keeps_objects_that_the_memory_misses() {
        use momo_sim::{SimConfig, simulate};
        let persistent = SeparateOptions {
            memory_radius: 20.0,
            persistence: 0.4,
            ..SeparateOptions::default()
        };
        let own = SeparateOptions {
            own_share: 0.1,
            ..persistent.clone()
        };
        let rig = simulate(&SimConfig {
            frames: 40,
            seed: 1,
            ..SimConfig::fisheye_surround()
        })
        .expect("simulation");
        let (r_persistent, n) = competing_frames(&rig, &persistent);
        let (r_own, _) = competing_frames(&rig, &own);
        let traffic = simulate(&SimConfig {
            frames: 40,
            seed: 1,
            ..SimConfig::moving_traffic()
        })
        .expect("simulation");
        let (t_persistent, m) = competing_frames(&traffic, &persistent);
        let (t_own, _) = competing_frames(&traffic, &own);
        eprintln!(
            "competing frames: fisheye rig {r_persistent}/{n} -> {r_own}, moving traffic {t_persistent}/{m} -> {t_own}"
        );
        assert!(r_own <= n / 10, "rig: {r_own} of {n}");
        assert!(
            t_own > t_persistent + 2,
            "traffic: {t_persistent} -> {t_own} of {m}"
        );
    }
    /// [`persistence_bound`] is the largest [`persistence`] over every mask `x` (all `2ⁿ` of
    /// them enumerated), so the pre-test that skips a solve by it never skips one competition
    /// over time could keep.
    #[test]
    fn persistence_bound_is_the_largest_persistence() {
        use proptest::prelude::*;
        let labels = proptest::collection::vec(
            prop_oneof![Just(None), Just(Some(true)), Just(Some(false))],
            1..=13,
        );
        let case = labels.prop_flat_map(|l| {
            let n = l.len();
            (Just(l), proptest::collection::vec(any::<bool>(), n))
        });
        proptest!(ProptestConfig::with_cases(200), |((l, a) in case)| {
            let n = l.len();
            let (labels, a) = (vec![l], vec![a]);
            let mut largest = 0.0f64;
            for bits in 0u32..(1 << n) {
                let x = vec![(0..n).map(|i| bits >> i & 1 == 1).collect::<Vec<_>>()];
                largest = largest.max(persistence(&labels, &x, &a));
            }
            prop_assert_eq!(persistence_bound(&labels, &a), largest);
        });
    }

    /// [`score_bound`] bounds the score of every motion and support (the true motion, others
    /// off it and random supports) on simulated frames of a fisheye rig and of moving traffic,
    /// and the ground cue's bound leaves out the cells of rays above the horizon.
    #[test]
    fn score_bound_bounds_every_score() {
        use momo_sim::{SimConfig, simulate};
        let h = HypothesesOptions {
            spread_grid: Some((16, 8)),
            ..HypothesesOptions::default()
        };
        let parallax = HypothesesOptions {
            ground: false,
            ..h.clone()
        };
        let mut below = 0;
        for config in [SimConfig::fisheye_surround(), SimConfig::moving_traffic()] {
            let sim = simulate(&SimConfig {
                frames: 6,
                seed: 3,
                ..config
            })
            .expect("simulation");
            let rig = &sim.sequence.rig;
            let mut rng = 0x2545_f491_4f6c_dd1du64;
            let mut coin = || {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                rng % 3 != 0
            };
            for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
                let truth = sim.vehicle_motions[k];
                let all: Vec<Vec<bool>> =
                    obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
                let random: Vec<Vec<bool>> = obs
                    .per_camera
                    .iter()
                    .map(|m| m.iter().map(|_| coin()).collect())
                    .collect();
                let turned = Pose::new(
                    momo_core::so3_exp(&nalgebra::Vector3::new(0.0, 0.01, 0.05)) * truth.rotation,
                    truth.translation,
                );
                let lifted = Pose::new(
                    truth.rotation,
                    truth.translation + nalgebra::Vector3::new(0.0, 0.3, 0.2),
                );
                for motion in [truth, turned, lifted] {
                    for support in [&all, &random] {
                        for o in [&h, &parallax] {
                            let s = score(o, rig, &motion, obs, support);
                            assert!(s <= score_bound(o, rig, obs), "{s}");
                        }
                    }
                }
                below += usize::from(score_bound(&h, rig, obs) < cells(rig, obs, &all, (16, 8)));
                assert_eq!(
                    score_bound(&parallax, rig, obs),
                    cells(rig, obs, &all, (16, 8))
                );
            }
        }
        assert!(below > 0, "the horizon cut no cell");
    }

    /// A solver that counts its solves.
    #[derive(Debug, Serialize, Deserialize)]
    struct Counting {
        inner: Box<dyn Solver>,
        #[serde(skip)]
        calls: std::sync::atomic::AtomicUsize,
    }

    #[typetag::serde(name = "separate_test_counting")]
    impl Solver for Counting {
        fn solve(
            &self,
            problem: &dyn momo_core::LeastSquares,
            x0: &momo_core::ParamVec,
        ) -> momo_core::SolverReport {
            self.calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.inner.solve(problem, x0)
        }
    }
    /// One clean pinhole frame (seed 1, frame 1) solved with the default's estimator, for the
    /// yaw rules' tests: its solution, supports and the solution turned in yaw.
    struct TurnedFrame {
        sim: momo_sim::Simulation,
        counted: Counted,
        sol: FrameSolution,
        yaw_index: usize,
    }

    impl TurnedFrame {
        fn new() -> Self {
            use momo_sim::{SimConfig, simulate};
            let sim = simulate(&SimConfig {
                frames: 3,
                seed: 1,
                ..SimConfig::clean_pinhole()
            })
            .expect("simulation");
            let counted = Counted::new();
            let estimator = counted.estimator.as_ref();
            let ctx = counted.ctx(&sim.sequence.rig);
            let start = estimator.initial_params(sim.true_arc_lengths[1]);
            let sol = ctx
                .solve(&sim.sequence.frames[1], &start, ctx.loss, false)
                .expect("solve");
            let yaw_index = estimator
                .param_names()
                .iter()
                .position(|n| *n == "rot_z")
                .expect("rot_z");
            Self {
                sim,
                counted,
                sol,
                yaw_index,
            }
        }

        fn rig(&self) -> &Rig {
            &self.sim.sequence.rig
        }

        fn obs(&self) -> &FrameObservations {
            &self.sim.sequence.frames[1]
        }

        /// Every match in (`on`) or out of the support.
        fn support(&self, on: bool) -> Vec<Vec<bool>> {
            self.obs()
                .per_camera
                .iter()
                .map(|m| vec![on; m.len()])
                .collect()
        }

        /// The matches a motion explains: within 0.003 rad of their epipolar plane.
        fn explained(&self, p: &[f64]) -> Vec<Vec<bool>> {
            let motion = self.counted.estimator.motion(p);
            epipolar_angles(self.rig(), &motion, self.obs())
                .into_iter()
                .map(|a| a.into_iter().map(|x| x < 0.003).collect())
                .collect()
        }

        /// The frame's solution turned by `d` radians of yaw, with `support`.
        fn turned(&self, d: f64, support: &[Vec<bool>]) -> Candidate {
            let mut s = self.sol.clone();
            s.params[self.yaw_index] += d;
            (s, support.to_vec())
        }

        /// `predict_by_slip`'s set-up: the options (the slip rule at `k = 6` beside a road rule
        /// that does not act, every motion's road reaching `min_matches` 0), the previous
        /// motion (0.1 deg off the truth), the `heading` parameter's index and a chosen motion
        /// without support that turns 0.8 deg less than the truth and slides 8 deg sideways
        /// (the default soft single-track model's slip sigma is 0.01 rad: 14 sigmas).
        fn slip_case(&self) -> (HypothesesOptions, Vec<f64>, usize, Candidate) {
            let deg = 1.0_f64.to_radians();
            let none = self.support(false);
            let heading = self
                .counted
                .estimator
                .param_names()
                .iter()
                .position(|n| *n == "heading")
                .expect("heading");
            let h = HypothesesOptions {
                yaw_history_frames: 1,
                yaw_history_margin: deg,
                predict_by_road: 0.5 * deg,
                predict_by_slip: 6.0,
                min_matches: 0,
                ..HypothesesOptions::default()
            };
            let mut car = self.turned(-0.8 * deg, &none);
            car.0.params[heading] -= 8.0 * deg;
            (h, self.turned(0.1 * deg, &none).0.params, heading, car)
        }
    }

    /// The default configuration's estimator and loss, a solver that counts its solves, and
    /// the arc length held as the odometry holds it: the set-up of the tests that count the
    /// separation's solves.
    struct Counted {
        config: crate::Config,
        estimator: Box<dyn FrameEstimator>,
        solver: Counting,
        arc_index: usize,
        fixed: Vec<bool>,
    }

    impl Counted {
        fn new() -> Self {
            let config = crate::Config::default();
            let estimator = config.model.build(config.metric.as_ref()).expect("model");
            let solver = Counting {
                inner: serde_json::from_value(serde_json::to_value(&config.solver).expect("json"))
                    .expect("solver"),
                calls: Default::default(),
            };
            let arc_index = estimator.arc_length_index().expect("arc length");
            let mut fixed = vec![false; estimator.param_names().len()];
            fixed[arc_index] = true;
            Self {
                config,
                estimator,
                solver,
                arc_index,
                fixed,
            }
        }

        /// The solve context on `rig` (no motion prior).
        fn ctx<'a>(&'a self, rig: &'a Rig) -> SolveContext<'a> {
            SolveContext {
                rig,
                estimator: self.estimator.as_ref(),
                loss: self.config.loss.as_ref(),
                solver: &self.solver,
                fixed: &self.fixed,
                motion_prior: None,
            }
        }
    }

    /// Simulated drives (a static pinhole scene, its outlier variant, the fisheye rig and
    /// moving traffic) with the default configuration's separation, with and without the
    /// exact pre-tests ([`retain_possible`], C and M's `distinct` bound): every frame's
    /// solution (bit for bit), outcome, next stage and match memory are the same, and the
    /// pre-tests skip solves.
    #[test]
    fn pretests_skip_solves_and_keep_the_outcome() {
        use momo_sim::{SimConfig, simulate};
        use std::sync::atomic::Ordering::Relaxed;
        let default = SeparateOptions::competition_over_time();
        // The default's options set explicitly (the ground cue's own share, the run's track
        // evidence, B's local minimum with the most road), and B without the remembered-other
        // matches (off by default).
        let mut variant = default.clone();
        variant.ground_admit_own_share = 0.05;
        variant.candidate_by_road = true;
        variant.candidate_forget_other = true;
        if let Some(h) = variant.hypotheses.as_mut() {
            h.track_decay = 0.7;
        }
        // The converse of the vehicle-model plausibility without the history's gate.
        let mut tilted = default.clone();
        if let Some(h) = tilted.hypotheses.as_mut() {
            h.tilt_margin = 0.01;
            h.tilt_replace = true;
            h.tilt_reference_frames = 0;
        }
        // The history's gate by the minimum of the last three frames' tilts.
        let mut gated = default.clone();
        if let Some(h) = gated.hypotheses.as_mut() {
            h.tilt_reference_frames = 3;
            h.tilt_reference = crate::hypotheses::TiltReference::Minimum;
            h.tilt_reference_margin = 0.005;
        }
        // The converse without road where the ground cue does not apply, the weak road's
        // reference over three frames.
        let mut weak = default.clone();
        if let Some(h) = weak.hypotheses.as_mut() {
            h.tilt_replace_roadless = true;
            h.tilt_weak_road_frames = 3;
        }
        // The odometry consistency of the yaw at a low k, with the rotation prior at the
        // previous frame's motion below (the other variants have no prior: it never acts).
        let mut jumped = default.clone();
        if let Some(h) = jumped.hypotheses.as_mut() {
            h.yaw_jump = 3.0;
        }
        // The odometry consistency of the yaw over the recent frames at a low margin (0.3 deg),
        // with the replacement.
        let mut turned = default.clone();
        if let Some(h) = turned.hypotheses.as_mut() {
            h.yaw_history_frames = 3;
            h.yaw_history_margin = 0.005;
            h.yaw_history_replace = true;
        }
        let counted = Counted::new();
        let (estimator, solver, arc_index) = (
            counted.estimator.as_ref(),
            &counted.solver,
            counted.arc_index,
        );
        let (mut skipped, mut competing) = (0, 0);
        for (opts, config_sim) in [&default, &variant, &tilted, &gated, &weak, &jumped, &turned]
            .into_iter()
            .flat_map(|o| {
                [
                    SimConfig::clean_pinhole(),
                    SimConfig::outliers(),
                    SimConfig::fisheye_surround(),
                    SimConfig::moving_traffic(),
                ]
                .map(move |c| (o, c))
            })
        {
            let sim = simulate(&SimConfig {
                frames: 30,
                seed: 2,
                ..config_sim
            })
            .expect("simulation");
            let rig = &sim.sequence.rig;
            let ctx = counted.ctx(rig);
            let (mut with, mut without) =
                (HypothesisTracker::default(), HypothesisTracker::default());
            let mut previous = estimator.initial_params(sim.true_arc_lengths[1]);
            for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
                let arc = sim.true_arc_lengths[k];
                previous[arc_index] = arc;
                let starts = vec![previous.clone(), estimator.initial_params(arc)];
                let Some(first) = ctx.solve(obs, &starts[1], ctx.loss, false) else {
                    continue;
                };
                // `yaw_jump`: the rotation prior at the previous frame's motion.
                let w = momo_core::so3_log(&estimator.motion(&previous).rotation);
                let prior = MotionPrior::rotation([w.x, w.y, w.z], 0.002);
                let ctx = SolveContext {
                    motion_prior: std::ptr::eq(opts, &jumped).then_some(&prior),
                    ..counted.ctx(rig)
                };
                let c0 = solver.calls.load(Relaxed);
                let old = separate_with(
                    &ctx,
                    opts,
                    obs,
                    first.clone(),
                    &starts,
                    &mut without,
                    Some(arc),
                    false,
                );
                let c1 = solver.calls.load(Relaxed);
                let new =
                    separate_with(&ctx, opts, obs, first, &starts, &mut with, Some(arc), true);
                let c2 = solver.calls.load(Relaxed);
                assert!(c2 - c1 <= c1 - c0);
                skipped += (c1 - c0) - (c2 - c1);
                assert_eq!(
                    new.0.params.iter().map(|p| p.to_bits()).collect::<Vec<_>>(),
                    old.0.params.iter().map(|p| p.to_bits()).collect::<Vec<_>>(),
                    "frame {k}"
                );
                assert_eq!(
                    new.0.report.final_cost.to_bits(),
                    old.0.report.final_cost.to_bits()
                );
                assert_eq!((new.1, &new.2), (old.1, &old.2), "frame {k}");
                assert_eq!(with, without, "frame {k}");
                competing += usize::from(new.1.competing);
                previous = new.0.params;
            }
        }
        eprintln!("pre-tests: {skipped} solves skipped, {competing} competing frames");
        assert!(skipped > 0, "no solve skipped");
        assert!(
            competing > 0,
            "no competing frame: the kept path is not exercised"
        );
    }
    /// `yaw_jump`: with the rotation prior active, an A whose yaw lies more than `k σ` from
    /// the prior's centre is replaced by the alternative with the highest positive road score
    /// within `k σ / 2` of it; nothing where the prior is off, A stays within `k σ`, no
    /// alternative lies within `k σ / 2` or its road score is 0. The option parses, validates
    /// and is off by default.
    #[test]
    fn yaw_jump_replaces_an_a_that_jumped_away_from_the_trusted_previous_motion() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let estimator = f.counted.estimator.as_ref();
        let plain = f.counted.ctx(rig);
        let (all, none) = (f.support(true), f.support(false));
        let turned = |d: f64, support: &[Vec<bool>]| f.turned(d, support);
        let yaw_of = |c: &Candidate| momo_core::so3_log(&estimator.motion(&c.0.params).rotation).z;
        let sigma = 0.002;
        let w = momo_core::so3_log(&estimator.motion(&sol.params).rotation);
        let prior = MotionPrior::rotation([w.x, w.y, w.z], sigma);
        let ctx = SolveContext {
            motion_prior: Some(&prior),
            ..f.counted.ctx(rig)
        };
        let h = HypothesesOptions {
            yaw_jump: 7.0,
            ..HypothesesOptions::default()
        };
        let (jumped, near, far) = (
            turned(20.0 * sigma, &all),
            turned(0.0, &all),
            turned(5.0 * sigma, &all),
        );
        assert!(((yaw_of(&jumped) - w.z) / sigma - 20.0).abs() < 0.5);
        assert!(((yaw_of(&far) - w.z) / sigma - 5.0).abs() < 0.5);
        assert!(score(&h, rig, &estimator.motion(&near.0.params), obs, &all) > 0);
        let params = |c: Option<Candidate>| c.map(|c| c.0.params);
        // A jumped by 20 σ, the alternative continues the prior: it replaces A (the one within
        // k σ / 2, not the one 5 σ away).
        let got = yaw_jump_replacement(&ctx, &h, obs, &jumped, &[far.clone(), near.clone()]);
        assert_eq!(params(got), Some(near.0.params.clone()));
        // The prior off (the previous frame not trusted or competing): nothing.
        assert!(
            yaw_jump_replacement(&plain, &h, obs, &jumped, std::slice::from_ref(&near)).is_none()
        );
        // A within k σ (5 σ): nothing.
        assert!(yaw_jump_replacement(&ctx, &h, obs, &far, std::slice::from_ref(&near)).is_none());
        // Only an alternative beyond k σ / 2, or one without road score: nothing.
        assert!(yaw_jump_replacement(&ctx, &h, obs, &jumped, std::slice::from_ref(&far)).is_none());
        let roadless = turned(0.0, &none);
        assert!(yaw_jump_replacement(&ctx, &h, obs, &jumped, &[roadless]).is_none());
        // A wider k (25 σ) no longer counts the 20 σ as a jump.
        let wide = HypothesesOptions {
            yaw_jump: 25.0,
            ..h.clone()
        };
        assert!(yaw_jump_replacement(&ctx, &wide, obs, &jumped, &[near]).is_none());
        assert_eq!(HypothesesOptions::default().yaw_jump, 0.0);
        let o: HypothesesOptions = toml::from_str("yaw_jump = 7.0").expect("parses");
        assert_eq!(o.yaw_jump, 7.0);
        assert!(o.validate().is_ok());
        let bad = HypothesesOptions {
            yaw_jump: f64::NAN,
            ..HypothesesOptions::default()
        };
        assert!(bad.validate().expect_err("NaN").contains("yaw_jump"));
    }

    /// `yaw_history_tie`: the numbers of dev2 05 s32 frame 430 (previous yaw 0.0432 rad, the
    /// object's motion 0.0262 with road score 14 against 12 and 11 for two motions near the
    /// history): the near tie goes to the motion that continues the history; a clear lead, a
    /// top motion that itself continues the history, the rule off, or nothing recorded leave
    /// the top one.
    #[test]
    fn yaw_history_tie_prefers_the_motion_that_continues_the_history() {
        let h = HypothesesOptions {
            yaw_history_frames: 1,
            yaw_history_margin: 0.01745,
            yaw_history_tie: 0.8,
            ..HypothesesOptions::default()
        };
        let yaw = |c: &f64| *c;
        let mut tracker = HypothesisTracker::default();
        let scored = [(14, 0.0262), (12, 0.0433), (11, 0.0430)];
        assert_eq!(
            history_tie(&h, &tracker, &scored, yaw),
            0,
            "nothing recorded"
        );
        tracker.record_yaw(&h, 0.0432);
        assert_eq!(history_tie(&h, &tracker, &scored, yaw), 1);
        // 11 < 0.8 x 14: a clear lead stays.
        assert_eq!(
            history_tie(&h, &tracker, &[(14, 0.0262), (11, 0.0433)], yaw),
            0
        );
        // The top one within half the margin (0.0087) of the history stays.
        assert_eq!(
            history_tie(&h, &tracker, &[(14, 0.0350), (13, 0.0433)], yaw),
            0
        );
        // The alternative must itself lie within half the margin.
        assert_eq!(
            history_tie(&h, &tracker, &[(14, 0.0262), (13, 0.0340)], yaw),
            0
        );
        // A NaN top yaw counts as a jump; a NaN alternative never continues.
        assert_eq!(
            history_tie(&h, &tracker, &[(14, f64::NAN), (13, 0.0433)], yaw),
            1
        );
        assert_eq!(
            history_tie(&h, &tracker, &[(14, 0.0262), (13, f64::NAN)], yaw),
            0
        );
        let off = HypothesesOptions {
            yaw_history_tie: 0.0,
            ..h.clone()
        };
        assert_eq!(history_tie(&off, &tracker, &scored, yaw), 0);
        let bad = HypothesesOptions {
            yaw_history_tie: 1.5,
            ..h.clone()
        };
        assert!(bad.validate().expect_err("> 1").contains("yaw_history_tie"));
    }

    /// `yaw_history_frames`: against the median yaw of the recent frames' chosen motions, the
    /// ordinary choice's switch to a B that jumps by more than the margin is stopped where A
    /// continues the history; with `yaw_history_replace`, an A that jumped is replaced by the
    /// best-scoring alternative within the margin. Nothing before a frame was recorded or with
    /// the rule off (the default).
    #[test]
    fn yaw_history_stops_and_replaces_a_jump_away_from_the_recent_frames_yaw() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let estimator = f.counted.estimator.as_ref();
        let ctx = f.counted.ctx(rig);
        let (all, none) = (f.support(true), f.support(false));
        let turned = |d: f64, support: &[Vec<bool>]| f.turned(d, support);
        let w = yaw_of(&ctx, &sol.params);
        let margin = 0.5_f64.to_radians();
        let h = HypothesesOptions {
            yaw_history_frames: 3,
            yaw_history_margin: margin,
            yaw_history_replace: true,
            ..HypothesesOptions::default()
        };
        // A lead car through a curve: 2.5 deg less turn than the static world.
        let (stat, car, near) = (
            turned(0.0, &all),
            turned(-2.5_f64.to_radians(), &all),
            turned(0.3_f64.to_radians(), &all),
        );
        assert!((yaw_of(&ctx, &car.0.params) - w + 2.5_f64.to_radians()).abs() < 0.1 * margin);
        assert!(score(&h, rig, &estimator.motion(&stat.0.params), obs, &all) > 0);
        let params = |c: Option<Candidate>| c.map(|c| c.0.params);
        // The veto with the default's ground cue (12, 2) and road scores `(s_A, s_B)`.
        let veto = |h: &HypothesesOptions,
                    t: &HypothesisTracker,
                    a: &Candidate,
                    b: &Candidate,
                    (sa, sb): (usize, usize)| {
            yaw_history_vetoes(&ctx, h, t, (a, b), (12, 2.0), || sa, sb)
        };
        let mut tracker = HypothesisTracker::default();
        // Nothing recorded yet: the rule does not act.
        assert!(!veto(&h, &tracker, &stat, &car, (7, 11)));
        assert!(
            yaw_history_replacement(&ctx, &h, &tracker, obs, &car, std::slice::from_ref(&stat))
                .is_none()
        );
        // The history: the static world's yaw twice and one frame on the car (the median
        // holds the static world's).
        for y in [w, w - 2.5_f64.to_radians(), w] {
            tracker.record_yaw(&h, y);
        }
        assert!((tracker.yaw_reference().expect("recorded") - w).abs() < 1e-12);
        // The switch from the static A to the car is stopped; not the switch to a B within
        // the margin, nor one from an A that itself jumped.
        assert!(veto(&h, &tracker, &stat, &car, (7, 11)));
        assert!(!veto(&h, &tracker, &stat, &near, (7, 11)));
        assert!(!veto(&h, &tracker, &car, &stat, (7, 11)));
        // A decisive ground cue for B (at least 12 and twice A's road score) is not stopped.
        assert!(!veto(&h, &tracker, &stat, &car, (6, 12)));
        assert!(veto(&h, &tracker, &stat, &car, (7, 12)));
        assert!(veto(&h, &tracker, &stat, &car, (0, 11)));
        // An A on the car is replaced by the alternative within the margin with road score.
        let got =
            yaw_history_replacement(&ctx, &h, &tracker, obs, &car, &[car.clone(), near.clone()]);
        assert_eq!(params(got), Some(near.0.params.clone()));
        assert!(
            yaw_history_replacement(&ctx, &h, &tracker, obs, &stat, std::slice::from_ref(&near))
                .is_none()
        );
        let roadless = turned(0.0, &none);
        assert!(yaw_history_replacement(&ctx, &h, &tracker, obs, &car, &[roadless]).is_none());
        // Without `yaw_history_replace` nothing replaces A; a wider margin (3 deg) sees no jump.
        let no_replace = HypothesesOptions {
            yaw_history_replace: false,
            ..h.clone()
        };
        assert!(
            yaw_history_replacement(
                &ctx,
                &no_replace,
                &tracker,
                obs,
                &car,
                std::slice::from_ref(&near)
            )
            .is_none()
        );
        let wide = HypothesesOptions {
            yaw_history_margin: 3.0_f64.to_radians(),
            ..h.clone()
        };
        assert!(!veto(&wide, &tracker, &stat, &car, (7, 11)));
        assert!(
            yaw_history_replacement(
                &ctx,
                &wide,
                &tracker,
                obs,
                &car,
                std::slice::from_ref(&near)
            )
            .is_none()
        );
        // Only the last K frames count: two more frames on the car move the median onto it.
        for _ in 0..2 {
            tracker.record_yaw(&h, w - 2.5_f64.to_radians());
        }
        assert!(!veto(&h, &tracker, &stat, &car, (7, 11)));
        // Off (the default): nothing recorded, nothing stopped.
        let off = HypothesesOptions::default();
        assert_eq!(off.yaw_history_frames, 0);
        let mut idle = HypothesisTracker::default();
        idle.record_yaw(&off, w);
        assert!(idle.yaw_reference().is_none());
        assert!(!veto(&off, &tracker, &stat, &car, (7, 11)));
        let o: HypothesesOptions = toml::from_str(
            "yaw_history_frames = 3\nyaw_history_margin = 0.0175\nyaw_history_replace = true",
        )
        .expect("parses");
        assert_eq!((o.yaw_history_frames, o.yaw_history_replace), (3, true));
        assert!(o.validate().is_ok());
        let bad = HypothesesOptions {
            yaw_history_margin: f64::NAN,
            ..HypothesesOptions::default()
        };
        assert!(
            bad.validate()
                .expect_err("NaN")
                .contains("yaw_history_margin")
        );
    }

    /// `yaw_history_predict`: an A that jumped by degrees from the recent frames' yaw without
    /// road, where no rule found an alternative, is replaced by the previous motion re-solved
    /// on the matches it explains (its yaw continues the history), or with
    /// `yaw_history_predict_hold` by the prediction itself where the re-solve is not possible;
    /// nothing where A does not jump, has road, or the rule is off; the options parse and
    /// validate.
    #[test]
    fn yaw_history_predict_replaces_a_roadless_jump_by_the_previous_motion() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let estimator = f.counted.estimator.as_ref();
        let ctx = f.counted.ctx(rig);
        let none = f.support(false);
        let w = yaw_of(&ctx, &sol.params);
        let deg = 1.0_f64.to_radians();
        let h = HypothesesOptions {
            yaw_history_frames: 1,
            yaw_history_margin: deg,
            yaw_history_predict: deg,
            ..HypothesesOptions::default()
        };
        let support = |p: &[f64]| f.explained(p);
        // A on an object: 5 deg less turn, no road under its (empty) support.
        let car = f.turned(-5.0 * deg, &none);
        let previous = f.turned(0.2 * deg, &none).0.params;
        let mut tracker = HypothesisTracker::default();
        let predict = |h: &HypothesesOptions, t: &HypothesisTracker, a: &Candidate, p: &[f64]| {
            yaw_history_prediction(&ctx, h, t, obs, a, p, &support)
        };
        // Nothing recorded yet: the rule does not act.
        assert!(predict(&h, &tracker, &car, &previous).is_none());
        tracker.record_yaw(&h, w);
        // The previous motion re-solved on the matches it explains: the static world's.
        let (p, sup_p) = predict(&h, &tracker, &car, &previous).expect("replaced");
        assert!((yaw_of(&ctx, &p.params) - w).abs() < 0.1 * deg);
        assert!(count(&sup_p) >= 12);
        // An A within the margin, or with its road score at least `min_matches` (0 here), or
        // the rule off: nothing.
        let near = f.turned(-0.5 * deg, &none);
        assert!(predict(&h, &tracker, &near, &previous).is_none());
        let roaded = HypothesesOptions {
            min_matches: 0,
            ..h.clone()
        };
        assert!(predict(&roaded, &tracker, &car, &previous).is_none());
        let off = HypothesesOptions {
            yaw_history_predict: 0.0,
            ..h.clone()
        };
        assert!(predict(&off, &tracker, &car, &previous).is_none());
        // A prediction that explains none of the matches: no re-solve; held as it is only with
        // `yaw_history_predict_hold`.
        let lost = f.turned(20.0 * deg, &none).0.params;
        assert!(count(&support(&lost)) < 12);
        assert!(predict(&h, &tracker, &car, &lost).is_none());
        let hold = HypothesesOptions {
            yaw_history_predict_hold: true,
            ..h.clone()
        };
        let (held, _) = predict(&hold, &tracker, &car, &lost).expect("held");
        assert_eq!(held.params, lost);
        // `tilt_predict`: an A whose yaw continues the history but whose tilt jumped (1.5 deg
        // of roll against the recorded flat frame) is replaced too, only with the option.
        let roll = estimator
            .param_names()
            .iter()
            .position(|n| *n == "rot_x")
            .expect("rot_x");
        let mut rolled = f.turned(0.0, &none);
        rolled.0.params[roll] += 1.5 * deg;
        let tilting = HypothesesOptions {
            tilt_reference_frames: 1,
            tilt_reference_margin: 0.01,
            ..h.clone()
        };
        let mut t2 = HypothesisTracker::default();
        t2.record_yaw(&tilting, w);
        t2.record_tilt(
            &tilting,
            crate::hypotheses::tilt(&estimator.motion(&sol.params)),
        );
        assert!(predict(&tilting, &t2, &rolled, &previous).is_none());
        let tilt_on = HypothesesOptions {
            tilt_predict: true,
            ..tilting.clone()
        };
        let (p, _) = predict(&tilt_on, &t2, &rolled, &previous).expect("replaced");
        let tilt_p = crate::hypotheses::tilt(&estimator.motion(&p.params));
        assert!(!t2.tilt_jumps_given_road(&tilt_on, tilt_p, true));
        // The options parse and validate.
        let o: HypothesesOptions = toml::from_str(
            "yaw_history_predict = 0.01745\nyaw_history_predict_hold = true\ntilt_predict = true",
        )
        .expect("parses");
        assert_eq!(
            (
                o.yaw_history_predict,
                o.yaw_history_predict_hold,
                o.tilt_predict
            ),
            (0.01745, true, true)
        );
        assert!(o.validate().is_ok());
        let d = HypothesesOptions::default();
        assert_eq!(
            (
                d.yaw_history_predict,
                d.yaw_history_predict_hold,
                d.tilt_predict
            ),
            (0.0, false, false)
        );
        let bad = HypothesesOptions {
            yaw_history_predict: -1.0,
            ..HypothesesOptions::default()
        };
        assert!(
            bad.validate()
                .expect_err("negative")
                .contains("yaw_history_predict")
        );
    }

    /// `predict_by_road`: a roadless motion that jumped by more than `J'` (but less than the
    /// 1-deg margin of the older rules) is replaced by the previous motion re-solved on its
    /// support where that has the road; not where an alternative has as much road, where the
    /// chosen motion has road itself or stays within `J'`, with the rule off, before any frame
    /// was recorded, or where the ratio asks for more; the options parse and validate.
    #[test]
    fn predict_by_road_replaces_a_roadless_jump_by_the_prediction_with_road() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let ctx = f.counted.ctx(rig);
        let none = f.support(false);
        let w = yaw_of(&ctx, &sol.params);
        let deg = 1.0_f64.to_radians();
        let support = |p: &[f64]| f.explained(p);
        let previous = f.turned(0.1 * deg, &none).0.params;
        // The road score of the static world's motion on the matches it explains.
        let truth = (sol.clone(), support(&sol.params));
        let base = HypothesesOptions::default();
        let s_truth = road_score(&ctx, &base, obs, &truth);
        assert!(s_truth >= 4, "the clean scene has road: {s_truth}");
        let h = HypothesesOptions {
            yaw_history_frames: 1,
            yaw_history_margin: deg,
            predict_by_road: 0.5 * deg,
            min_matches: s_truth / 2,
            ..HypothesesOptions::default()
        };
        // The chosen motion on an object: 0.8 deg less turn (within the older rules' 1-deg
        // margin), no road under its (empty) support.
        let car = f.turned(-0.8 * deg, &none);
        assert_eq!(road_score(&ctx, &h, obs, &car), 0);
        let mut tracker = HypothesisTracker::default();
        let predict =
            |h: &HypothesesOptions, t: &HypothesisTracker, x: &Candidate, alts: &[Candidate]| {
                road_prediction(&ctx, h, t, obs, x, alts, &previous, &support)
            };
        // Nothing recorded yet: the rule does not act.
        assert!(predict(&h, &tracker, &car, &[]).is_none());
        tracker.record_yaw(&h, w);
        // The previous motion re-solved on the matches it explains: the static world's, with
        // its road.
        let (p, sup_p) = predict(&h, &tracker, &car, &[]).expect("replaced");
        assert!((yaw_of(&ctx, &p.params) - w).abs() < 0.1 * deg);
        assert!(road_score(&ctx, &h, obs, &(p.clone(), sup_p.clone())) >= h.min_matches);
        // An alternative with at least as much road: the prediction's evidence does not
        // exceed it, the rules' choice stands.
        let all = (sol.clone(), f.support(true));
        assert!(road_score(&ctx, &h, obs, &all) >= road_score(&ctx, &h, obs, &(p, sup_p)));
        assert!(predict(&h, &tracker, &car, std::slice::from_ref(&all)).is_none());
        // A roadless alternative does not stop it.
        let other = f.turned(3.0 * deg, &none);
        assert!(predict(&h, &tracker, &car, std::slice::from_ref(&other)).is_some());
        // A motion within `J'`, one with its own road, the rule off, a ratio the prediction's
        // road does not reach: nothing.
        let near = f.turned(-0.3 * deg, &none);
        assert!(predict(&h, &tracker, &near, &[]).is_none());
        let roaded = HypothesesOptions {
            min_matches: 0,
            ..h.clone()
        };
        assert!(predict(&roaded, &tracker, &car, &[]).is_none());
        let off = HypothesesOptions {
            predict_by_road: 0.0,
            ..h.clone()
        };
        assert!(predict(&off, &tracker, &car, &[]).is_none());
        let no_history = HypothesesOptions {
            yaw_history_frames: 0,
            ..h.clone()
        };
        assert!(predict(&no_history, &tracker, &car, &[]).is_none());
        // `ρ`: against a roadless `X` (0) any road exceeds `ρ · 0`; against an alternative
        // with half the prediction's road, `ρ = 3` asks for more than it has.
        let half = HypothesesOptions {
            min_matches: 1,
            predict_by_road_ratio: 3.0,
            ..h.clone()
        };
        assert!(predict(&half, &tracker, &car, &[]).is_some());
        let weaker = (sol.clone(), {
            // Half of the truth's support, taken in the frame's order.
            let mut k = 0usize;
            support(&sol.params)
                .into_iter()
                .map(|c| {
                    c.into_iter()
                        .map(|x| {
                            k += usize::from(x);
                            x && k % 2 == 0
                        })
                        .collect()
                })
                .collect::<Vec<Vec<bool>>>()
        });
        let s_weaker = road_score(&ctx, &half, obs, &weaker);
        assert!(s_weaker > 0);
        let p_half = predict(&half, &tracker, &car, &[]).expect("replaced");
        let s_p = road_score(&ctx, &half, obs, &p_half);
        let ratio_met = s_p as f64 > 3.0 * s_weaker as f64;
        assert_eq!(
            predict(&half, &tracker, &car, std::slice::from_ref(&weaker)).is_some(),
            ratio_met
        );
        let one = HypothesesOptions {
            predict_by_road_ratio: 1.0,
            ..half.clone()
        };
        assert_eq!(
            predict(&one, &tracker, &car, std::slice::from_ref(&weaker)).is_some(),
            s_p > s_weaker
        );
        // The options parse and validate; off by default.
        let o: HypothesesOptions =
            toml::from_str("predict_by_road = 0.00873\npredict_by_road_ratio = 1.5")
                .expect("parses");
        assert_eq!((o.predict_by_road, o.predict_by_road_ratio), (0.00873, 1.5));
        assert!(o.validate().is_ok());
        let d = HypothesesOptions::default();
        assert_eq!((d.predict_by_road, d.predict_by_road_ratio), (0.0, 1.0));
        for j in [-1.0, f64::NAN] {
            let bad = HypothesesOptions {
                predict_by_road: j,
                ..HypothesesOptions::default()
            };
            assert!(bad.validate().expect_err("bad").contains("predict_by_road"));
        }
        for q in [0.5, f64::INFINITY] {
            let bad = HypothesesOptions {
                predict_by_road_ratio: q,
                ..HypothesesOptions::default()
            };
            assert!(
                bad.validate()
                    .expect_err("bad ratio")
                    .contains("predict_by_road_ratio")
            );
        }
    }

    /// `predict_by_slip`: a motion that jumped by more than `J'` and slides sideways by more
    /// than `k` of the model's slip sigmas is replaced by the re-solved prediction even where
    /// its own road reaches `min_matches` (where the road rule does not act), if the
    /// prediction's road is at least its; not a motion that jumped without sliding, not with
    /// the option off; the option parses and validates.
    #[test]
    fn predict_by_slip_replaces_a_sliding_jump_by_the_prediction() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let estimator = f.counted.estimator.as_ref();
        let ctx = f.counted.ctx(rig);
        let none = f.support(false);
        let deg = 1.0_f64.to_radians();
        let support = |p: &[f64]| f.explained(p);
        // A road rule that does not act: every motion's road reaches `min_matches` (0).
        let (h, previous, _, car) = f.slip_case();
        let mut tracker = HypothesisTracker::default();
        tracker.record_yaw(&h, yaw_of(&ctx, &sol.params));
        let predict = |h: &HypothesesOptions, x: &Candidate| {
            road_prediction(&ctx, h, &tracker, obs, x, &[], &previous, &support)
        };
        // The chosen motion turns 0.8 deg less and slides 8 deg sideways.
        let q = estimator.prior_residuals(&car.0.params)[0].abs();
        assert!(q > 10.0, "the car slides: {q}");
        let (p, _) = predict(&h, &car).expect("replaced");
        assert!((yaw_of(&ctx, &p.params) - yaw_of(&ctx, &sol.params)).abs() < 0.1 * deg);
        assert!(estimator.prior_residuals(&p.params)[0].abs() <= h.predict_by_slip);
        // The same jump without the slide, a slide below `k`, the option off: nothing.
        let straight = f.turned(-0.8 * deg, &none);
        assert!(predict(&h, &straight).is_none());
        let wide = HypothesesOptions {
            predict_by_slip: q + 1.0,
            ..h.clone()
        };
        assert!(predict(&wide, &car).is_none());
        let off = HypothesesOptions {
            predict_by_slip: 0.0,
            ..h.clone()
        };
        assert!(predict(&off, &car).is_none());
        // Parses, validates, off by default.
        let o: HypothesesOptions = toml::from_str("predict_by_slip = 6.0").expect("parses");
        assert_eq!(o.predict_by_slip, 6.0);
        assert!(o.validate().is_ok());
        assert_eq!(HypothesesOptions::default().predict_by_slip, 0.0);
        for k in [-1.0, f64::NAN, f64::INFINITY] {
            let bad = HypothesesOptions {
                predict_by_slip: k,
                ..HypothesesOptions::default()
            };
            assert!(bad.validate().expect_err("bad").contains("predict_by_slip"));
        }
    }

    /// `predict_by_slip_alternatives`: where `X` slides, an alternative that continues the
    /// history without sliding (here the static world's motion on every match, more road than
    /// the prediction) competes with the prediction by road: off, the prediction loses to it
    /// and nothing replaces `X`; on, it replaces `X`; a sliding alternative does not compete
    /// (the prediction, with more road, replaces `X`); an alternative that jumped as far as `X`
    /// is what the prediction must beat; a motion that does not slide is left to the road rule.
    #[test]
    fn predict_by_slip_alternatives_lets_a_steady_alternative_replace_a_sliding_jump() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let estimator = f.counted.estimator.as_ref();
        let ctx = f.counted.ctx(rig);
        let none = f.support(false);
        let deg = 1.0_f64.to_radians();
        let support = |p: &[f64]| f.explained(p);
        let (plain, previous, heading, car) = f.slip_case();
        let on = HypothesesOptions {
            predict_by_slip_alternatives: true,
            ..plain.clone()
        };
        let mut tracker = HypothesisTracker::default();
        tracker.record_yaw(&plain, yaw_of(&ctx, &sol.params));
        let predict = |h: &HypothesesOptions, x: &Candidate, alts: &[Candidate]| {
            road_prediction(&ctx, h, &tracker, obs, x, alts, &previous, &support)
        };
        assert!(estimator.prior_residuals(&car.0.params)[0].abs() > 10.0);
        // The static world's motion on every match: more road than the prediction's support.
        let world = (sol.clone(), f.support(true));
        assert!(estimator.prior_residuals(&sol.params)[0].abs() <= plain.predict_by_slip);
        let p = predict(&plain, &car, &[]).expect("the prediction alone replaces X");
        let (s_p, s_world) = (
            road_score(&ctx, &plain, obs, &p),
            road_score(&ctx, &plain, obs, &world),
        );
        assert!(
            s_world > s_p,
            "the world's road {s_world} above the prediction's {s_p}"
        );
        let alts = std::slice::from_ref(&world);
        assert!(predict(&plain, &car, alts).is_none());
        let (w, _) = predict(&on, &car, alts).expect("the world replaces X");
        assert_eq!(w.params, sol.params);
        // The same alternative sliding does not compete (the prediction, with more road than
        // it, replaces `X`); an alternative that jumped as far as `X` does not either, and the
        // prediction must reach its road.
        let mut sliding = world.clone();
        sliding.0.params[heading] -= 8.0 * deg;
        let (q, _) = predict(&on, &car, std::slice::from_ref(&sliding)).expect("the prediction");
        assert_eq!(q.params, p.0.params);
        let jumped = f.turned(3.0 * deg, &f.support(true));
        let s_jumped = road_score(&ctx, &plain, obs, &jumped);
        assert_eq!(
            predict(&on, &car, std::slice::from_ref(&jumped)).map(|(c, _)| c.params),
            (s_p >= s_jumped).then(|| p.0.params.clone())
        );
        // `X` that does not slide: the slip rule does not act (its road reaches `min_matches`).
        let straight = f.turned(-0.8 * deg, &none);
        assert!(predict(&on, &straight, alts).is_none());
        // Parses; off by default.
        let o: HypothesesOptions =
            toml::from_str("predict_by_slip = 6.0\npredict_by_slip_alternatives = true")
                .expect("parses");
        assert!(o.predict_by_slip_alternatives && o.validate().is_ok());
        assert!(!HypothesesOptions::default().predict_by_slip_alternatives);
    }

    /// `predict_by_road_alternatives`: an alternative that continues the history (here the
    /// static world's motion on every match) competes with the prediction by road: off, its
    /// road stops the prediction; on, the continuing candidate with the most road replaces
    /// the roadless jump. An alternative that does not continue the history (3 deg off the
    /// reference) is what the best continuing one must beat, and `X` itself is no candidate.
    #[test]
    fn predict_by_road_alternatives_let_a_continuing_alternative_win_by_road() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let ctx = f.counted.ctx(rig);
        let none = f.support(false);
        let w = yaw_of(&ctx, &sol.params);
        let deg = 1.0_f64.to_radians();
        let support = |p: &[f64]| f.explained(p);
        let previous = f.turned(0.1 * deg, &none).0.params;
        let truth = (sol.clone(), support(&sol.params));
        let s_truth = road_score(&ctx, &HypothesesOptions::default(), obs, &truth);
        let off = HypothesesOptions {
            yaw_history_frames: 1,
            yaw_history_margin: deg,
            predict_by_road: 0.5 * deg,
            min_matches: s_truth / 2,
            ..HypothesesOptions::default()
        };
        let on = HypothesesOptions {
            predict_by_road_alternatives: true,
            ..off.clone()
        };
        let car = f.turned(-0.8 * deg, &none);
        let mut tracker = HypothesisTracker::default();
        let predict =
            |h: &HypothesesOptions, t: &HypothesisTracker, x: &Candidate, alts: &[Candidate]| {
                road_prediction(&ctx, h, t, obs, x, alts, &previous, &support)
            };
        assert!(
            predict(&on, &tracker, &car, &[]).is_none(),
            "nothing recorded"
        );
        tracker.record_yaw(&on, w);
        // Without alternatives the option changes nothing: `P` replaces the jump.
        let p_off = predict(&off, &tracker, &car, &[]).expect("P");
        let p_on = predict(&on, &tracker, &car, &[]).expect("P");
        assert_eq!(p_off.0.params, p_on.0.params);
        let s_p = road_score(&ctx, &on, obs, &p_on);
        // The static world's motion on every match: it continues the history and has at
        // least the prediction's road. Off it stops `P`; on, the one with more road replaces
        // `X` (`P` first of equal ones).
        let all = (sol.clone(), f.support(true));
        let s_all = road_score(&ctx, &on, obs, &all);
        assert!(s_all >= s_p && s_all >= on.min_matches, "{s_all} {s_p}");
        assert!(predict(&off, &tracker, &car, std::slice::from_ref(&all)).is_none());
        let c = predict(&on, &tracker, &car, std::slice::from_ref(&all)).expect("replaced");
        let want = if s_all > s_p {
            &all.0.params
        } else {
            &p_on.0.params
        };
        assert_eq!(&c.0.params, want);
        // `X` among the alternatives is no candidate of its own.
        let c = predict(&on, &tracker, &car, &[car.clone(), all.clone()]).expect("replaced");
        assert_eq!(&c.0.params, want);
        // An alternative 3 deg off the reference does not continue: the best continuing
        // candidate must beat its road.
        let far = f.turned(3.0 * deg, &f.support(true));
        assert!(tracker.yaw_jumps(&on, yaw_of(&ctx, &far.0.params)));
        let s_far = road_score(&ctx, &on, obs, &far);
        assert_eq!(
            predict(&on, &tracker, &car, &[far.clone(), all.clone()]).is_some(),
            s_all.max(s_p) > s_far
        );
        // An alternative 0.8 deg off the reference (within the 1-deg margin, beyond `J'`)
        // moved as far as `X` did: no candidate, only what the best must beat.
        let bus = f.turned(0.8 * deg, &f.support(true));
        assert!(!tracker.yaw_jumps(&on, yaw_of(&ctx, &bus.0.params)));
        let s_bus = road_score(&ctx, &on, obs, &bus);
        let c = predict(&on, &tracker, &car, std::slice::from_ref(&bus));
        assert_eq!(c.is_some(), s_p > s_bus);
        assert!(c.is_none_or(|c| c.0.params == p_on.0.params));
        // The history 0.8 deg beside the static world's yaw: the static world's motion on
        // every match lies beyond `J'` of it and does not continue; its road (more than the
        // prediction's, which stays within the 1-deg margin) stops the replacement, and
        // without it the prediction replaces the jump.
        let mut shifted = HypothesisTracker::default();
        shifted.record_yaw(&on, w + 0.8 * deg);
        let car2 = f.turned(1.4 * deg, &none);
        let c = predict(&on, &shifted, &car2, &[]).expect("P continues within the margin");
        let s_c = road_score(&ctx, &on, obs, &c);
        assert!(s_all > s_c, "{s_all} {s_c}");
        assert!(predict(&on, &shifted, &car2, std::slice::from_ref(&all)).is_none());
        assert!(predict(&off, &shifted, &car2, std::slice::from_ref(&all)).is_none());
        // A ratio the best continuing road does not reach against a non-continuing one with
        // road: nothing; and a roadless continuing alternative alone does not beat `P`.
        let demanding = HypothesesOptions {
            predict_by_road_ratio: 1e6,
            ..on.clone()
        };
        let weak_far = (far.0.clone(), support(&far.0.params));
        let s_weak_far = road_score(&ctx, &on, obs, &weak_far);
        assert_eq!(
            predict(&demanding, &tracker, &car, &[weak_far, all.clone()]).is_some(),
            s_weak_far == 0
        );
        let roadless = f.turned(0.2 * deg, &none);
        let c = predict(&on, &tracker, &car, std::slice::from_ref(&roadless)).expect("P");
        assert_eq!(c.0.params, p_on.0.params);
        // Parses; off by default.
        assert!(!HypothesesOptions::default().predict_by_road_alternatives);
        let o: HypothesesOptions =
            toml::from_str("predict_by_road = 0.00873\npredict_by_road_alternatives = true")
                .expect("parse");
        assert!(o.predict_by_road_alternatives && o.validate().is_ok());
        eprintln!("s_p {s_p} s_all {s_all} s_far {s_far} s_bus {s_bus} s_weak_far {s_weak_far}");
    }

    /// `predict_by_road_prior`: a frame whose motion the road prediction replaced keeps the
    /// next frame's prior only with the option on and only where nothing else competed; off
    /// by default; it parses.
    #[test]
    fn predict_by_road_prior_keeps_the_prior_only_where_only_the_prediction_competed() {
        let off = HypothesesOptions {
            predict_by_road: 0.00873,
            ..HypothesesOptions::default()
        };
        assert!(!off.predict_by_road_prior);
        let on = HypothesesOptions {
            predict_by_road_prior: true,
            ..off.clone()
        };
        // Off (the default): the replaced frame is an ordinary competing frame.
        assert!(!prior_kept(Some(&off), true, false));
        // On: kept where only the prediction competed ...
        assert!(prior_kept(Some(&on), true, false));
        // ... not where an alternative or another rule competed too, not where the
        // prediction did not act, not without the hypotheses.
        assert!(!prior_kept(Some(&on), true, true));
        assert!(!prior_kept(Some(&on), false, false));
        assert!(!prior_kept(Some(&on), false, true));
        assert!(!prior_kept(None, true, false));
        let o: HypothesesOptions =
            toml::from_str("predict_by_road = 0.00873\npredict_by_road_prior = true")
                .expect("parses");
        assert!(o.predict_by_road_prior && o.validate().is_ok());
    }

    /// `yaw_history_predict_road_frames`: the prediction replaces a roadless A that jumped
    /// only where the recent frames' chosen motions had road (A lost it: the median of their
    /// road scores at least `min_matches`), never in a scene without road (every recorded
    /// score below it), nor before a score was recorded; the option parses and validates.
    #[test]
    fn yaw_history_predict_road_guard_acts_where_the_road_was_lost_only() {
        let f = TurnedFrame::new();
        let (rig, obs, sol) = (f.rig(), f.obs(), &f.sol);
        let ctx = f.counted.ctx(rig);
        let none = f.support(false);
        let w = yaw_of(&ctx, &sol.params);
        let deg = 1.0_f64.to_radians();
        let h = HypothesesOptions {
            yaw_history_frames: 1,
            yaw_history_margin: deg,
            yaw_history_predict: deg,
            yaw_history_predict_hold: true,
            yaw_history_predict_road_frames: 3,
            ..HypothesesOptions::default()
        };
        let support = |p: &[f64]| f.explained(p);
        // A on an object (or a true sharp turn): 5 deg from the recorded yaw, no road under
        // its support (score 0 < `min_matches` = 10).
        let car = f.turned(-5.0 * deg, &none);
        assert!(road_score(&ctx, &h, obs, &car) < h.min_matches);
        let previous = f.turned(0.2 * deg, &none).0.params;
        let predict = |t: &HypothesisTracker| {
            yaw_history_prediction(&ctx, &h, t, obs, &car, &previous, &support)
        };
        let tracker_with = |scores: &[usize]| {
            let mut t = HypothesisTracker::default();
            t.record_yaw(&h, w);
            for &s in scores {
                t.record_road(&h, s);
            }
            t
        };
        // No road score recorded yet: the guard holds A.
        assert!(predict(&tracker_with(&[])).is_none());
        // Road lost: the recent frames' motions had 12-20 cells of road, A has none.
        let (p, _) = predict(&tracker_with(&[15, 20, 12])).expect("road lost: replaced");
        assert!((yaw_of(&ctx, &p.params) - w).abs() < 0.1 * deg);
        // Never road: a scene without a visible road keeps A (a true turn).
        assert!(predict(&tracker_with(&[0, 0, 0])).is_none());
        assert!(predict(&tracker_with(&[3, 9, 2])).is_none());
        // The median of the last 3: one frame with road among roadless ones is not enough,
        // two are; older scores fall out of the window.
        assert!(predict(&tracker_with(&[20, 0, 0])).is_none());
        assert!(predict(&tracker_with(&[20, 0, 20])).is_some());
        assert!(predict(&tracker_with(&[20, 20, 20, 0, 0, 0])).is_none());
        assert!(predict(&tracker_with(&[0, 0, 0, 20, 20])).is_some());
        // The drop: A's score must be at most `q = 0.4` of the recent median (`min_matches` 2:
        // 1 <= 0.4 * 4 is a loss, 2 is not; a median of 1 is no road).
        let f_tracker = |h: &HypothesesOptions, scores: &[usize]| {
            let mut t = HypothesisTracker::default();
            for &s in scores {
                t.record_road(h, s);
            }
            t
        };
        let low = HypothesesOptions {
            min_matches: 2,
            ..h.clone()
        };
        assert!(f_tracker(&low, &[4, 4, 4]).road_lost(&low, 1));
        assert!(!f_tracker(&low, &[4, 4, 4]).road_lost(&low, 2));
        assert!(!f_tracker(&low, &[1, 1, 1]).road_lost(&low, 0));
        // The sharp turn of `degenerate::a_sharp_turn_after_straight_driving_is_found`: A's 8
        // against the recent 10 (scores 7-14) is no loss; 4 is.
        let ten = HypothesesOptions {
            min_matches: 10,
            ..h.clone()
        };
        assert!(!f_tracker(&ten, &[8, 10, 10, 14, 7]).road_lost(&ten, 8));
        assert!(f_tracker(&ten, &[8, 10, 10, 14, 7]).road_lost(&ten, 4));
        // The guard off: A without road is replaced whatever was recorded (tail37's rule).
        let unguarded = HypothesesOptions {
            yaw_history_predict_road_frames: 0,
            ..h.clone()
        };
        let mut t = HypothesisTracker::default();
        t.record_yaw(&unguarded, w);
        t.record_road(&unguarded, 20);
        assert!(t.road_lost(&unguarded, 20));
        assert!(
            yaw_history_prediction(&ctx, &unguarded, &t, obs, &car, &previous, &support).is_some()
        );
        // The option parses and validates; off by default.
        let o: HypothesesOptions = toml::from_str(
            "yaw_history_predict_road_frames = 5\nyaw_history_predict_road_drop = 0.5",
        )
        .expect("parses");
        assert_eq!(
            (
                o.yaw_history_predict_road_frames,
                o.yaw_history_predict_road_drop
            ),
            (5, 0.5)
        );
        assert!(o.validate().is_ok());
        let d = HypothesesOptions::default();
        assert_eq!(
            (
                d.yaw_history_predict_road_frames,
                d.yaw_history_predict_road_drop
            ),
            (0, 0.4)
        );
        for q in [0.0, -0.1, 1.1, f64::NAN] {
            let bad = HypothesesOptions {
                yaw_history_predict_road_drop: q,
                ..HypothesesOptions::default()
            };
            assert!(
                bad.validate()
                    .expect_err("bad ratio")
                    .contains("yaw_history_predict_road_drop")
            );
        }
        let bad = HypothesesOptions {
            yaw_history_predict_road_frames: 1001,
            ..HypothesesOptions::default()
        };
        assert!(
            bad.validate()
                .expect_err("too many")
                .contains("yaw_history_predict_road_frames")
        );
    }

    /// The alternatives' solver: the frame's Levenberg-Marquardt with the capped iterations
    /// and the looser function tolerance, none where the options are off or change nothing;
    /// the options parse and validate.
    #[test]
    fn candidate_solver_caps_the_iterations_and_loosens_the_tolerance() {
        let config = crate::Config::default();
        let solver = config.solver.as_ref();
        let json = |s: &dyn Solver| serde_json::to_value(s).expect("json");
        let base = json(solver);
        let off = SeparateOptions::competition_over_time();
        assert!(candidate_solver(solver, &off).is_none());
        let o: SeparateOptions = toml::from_str(
            "candidate_max_iterations = 8\ncandidate_function_tolerance = 0.001\ncandidate_one_start = true",
        )
        .expect("toml");
        assert!(o.validate().is_ok() && o.candidate_one_start);
        let c = json(
            candidate_solver(solver, &o)
                .expect("a candidate solver")
                .as_ref(),
        );
        assert_eq!(c["max_iterations"], 8);
        assert_eq!(c["function_tolerance"], 0.001);
        for key in [
            "type",
            "gradient_tolerance",
            "initial_lambda",
            "max_linearizations",
        ] {
            assert_eq!(c[key], base[key], "{key}");
        }
        // A cap above the solver's own and a tolerance below it change nothing.
        let loose: SeparateOptions =
            toml::from_str("candidate_max_iterations = 1000\ncandidate_function_tolerance = 1e-12")
                .expect("toml");
        assert!(candidate_solver(solver, &loose).is_none());
        let bad: SeparateOptions =
            toml::from_str("candidate_function_tolerance = -1.0").expect("toml");
        assert!(
            bad.validate()
                .unwrap_err()
                .contains("candidate_function_tolerance")
        );
        // `candidate_max_step_extrapolation`: the lengthening alone, the rest the solver's.
        let ext: SeparateOptions =
            toml::from_str("candidate_max_step_extrapolation = 2.0").expect("toml");
        assert!(ext.validate().is_ok());
        let c = json(
            candidate_solver(solver, &ext)
                .expect("a candidate solver")
                .as_ref(),
        );
        assert_eq!(c["max_step_extrapolation"], 2.0);
        assert_ne!(base["max_step_extrapolation"], 2.0);
        for key in ["max_iterations", "function_tolerance", "initial_lambda"] {
            assert_eq!(c[key], base[key], "{key}");
        }
        // The solver's own value changes nothing; below 1 (but 0) or not finite is an error.
        let own: SeparateOptions = toml::from_str(&format!(
            "candidate_max_step_extrapolation = {}",
            base["max_step_extrapolation"]
        ))
        .expect("toml");
        assert!(candidate_solver(solver, &own).is_none());
        for v in ["0.5", "inf", "-1.0"] {
            let bad: SeparateOptions =
                toml::from_str(&format!("candidate_max_step_extrapolation = {v}")).expect("toml");
            assert!(
                bad.validate()
                    .unwrap_err()
                    .contains("candidate_max_step_extrapolation"),
                "{v}"
            );
        }
    }

    /// `candidate_one_start` on the static fisheye rig (B fitted every frame, 6 starts): far
    /// fewer solves than from every start. The yaw votes' alternatives (`yaw_votes`) are off:
    /// the test counts B's (with them on, 80 solves from every start and 40 from one were
    /// measured, no longer below half).
    #[test]
    fn one_start_solves_b_once_where_it_passes() {
        use momo_sim::{SimConfig, simulate};
        use std::sync::atomic::Ordering::Relaxed;
        let sim = simulate(&SimConfig {
            frames: 12,
            seed: 1,
            ..SimConfig::fisheye_surround()
        })
        .expect("simulation");
        let counted = Counted::new();
        let (estimator, solver, arc_index) = (
            counted.estimator.as_ref(),
            &counted.solver,
            counted.arc_index,
        );
        let ctx = counted.ctx(&sim.sequence.rig);
        let every = SeparateOptions {
            yaw_votes: 0,
            ..SeparateOptions::competition_over_time()
        };
        let one = SeparateOptions {
            candidate_one_start: true,
            ..every.clone()
        };
        let calls = [&every, &one].map(|opts| {
            let mut calls = 0;
            let mut tracker = HypothesisTracker::default();
            for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
                let arc = sim.true_arc_lengths[k];
                let straight = estimator.initial_params(arc);
                let starts: Vec<Vec<f64>> = [-0.1, -0.03, 0.0, 0.03, 0.1]
                    .iter()
                    .map(|dy| {
                        let mut s = straight.clone();
                        if let Some(p) = estimator.params_from_motion(&Pose::new(
                            momo_core::so3_exp(&nalgebra::Vector3::new(0.0, 0.0, *dy)),
                            estimator.motion(&straight).translation,
                        )) {
                            s = p;
                            s[arc_index] = arc;
                        }
                        s
                    })
                    .collect();
                let Some(first) = ctx.solve(obs, &straight, ctx.loss, false) else {
                    continue;
                };
                let c0 = solver.calls.load(Relaxed);
                separate(&ctx, opts, obs, first, &starts, &mut tracker, Some(arc));
                calls += solver.calls.load(Relaxed) - c0;
            }
            calls
        });
        eprintln!(
            "separation solves over 11 fisheye pairs: every start {}, one start {}",
            calls[0], calls[1]
        );
        assert!(calls[0] >= 11 * 5, "B from every start: {}", calls[0]);
        assert!(2 * calls[1] < calls[0], "{calls:?}");
    }

    /// `candidate_by_road` takes B's other local minima from B's own solves: on a moving-traffic
    /// drive every frame (from the same tracker state) makes as many solves with the option as
    /// without, and in some frame the alternative it offers changes the outcome.
    #[test]
    fn by_road_adds_no_solve() {
        use momo_sim::{SimConfig, simulate};
        use std::sync::atomic::Ordering::Relaxed;
        let on = SeparateOptions::competition_over_time();
        assert!(on.candidate_by_road, "the default separation offers it");
        let off = SeparateOptions {
            candidate_by_road: false,
            ..on.clone()
        };
        let counted = Counted::new();
        let (estimator, solver, arc_index) = (
            counted.estimator.as_ref(),
            &counted.solver,
            counted.arc_index,
        );
        let sim = simulate(&SimConfig {
            frames: 120,
            seed: 2,
            ..SimConfig::moving_traffic()
        })
        .expect("simulation");
        let rig = &sim.sequence.rig;
        let ctx = counted.ctx(rig);
        let mut tracker = HypothesisTracker::default();
        let mut previous = estimator.initial_params(sim.true_arc_lengths[1]);
        let mut changed = 0;
        for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
            let arc = sim.true_arc_lengths[k];
            previous[arc_index] = arc;
            let starts = vec![previous.clone(), estimator.initial_params(arc)];
            let Some(first) = ctx.solve(obs, &starts[0], ctx.loss, false) else {
                continue;
            };
            let mut t_on = tracker.clone();
            let c0 = solver.calls.load(Relaxed);
            let a = separate(
                &ctx,
                &off,
                obs,
                first.clone(),
                &starts,
                &mut tracker,
                Some(arc),
            );
            let c1 = solver.calls.load(Relaxed);
            let b = separate(&ctx, &on, obs, first, &starts, &mut t_on, Some(arc));
            let c2 = solver.calls.load(Relaxed);
            assert_eq!(c2 - c1, c1 - c0, "frame {k}");
            changed += usize::from(a.0.params != b.0.params || a.1 != b.1);
            previous = a.0.params;
        }
        assert!(changed > 0, "the option changed no frame");
    }

    /// The spread subsample keeps `k` of the mask's `m` matches (all where `m <= k`), none
    /// outside the mask, with gaps of at most `ceil(m / k)` between kept ones in the frame's
    /// order.
    #[test]
    fn spread_subsample_keeps_k_evenly_spaced_matches_of_the_mask() {
        for (sizes, k) in [
            (vec![7, 0, 13, 5], 4),
            (vec![100, 60, 1], 48),
            (vec![3, 4], 12),
        ] {
            let mask: Vec<Vec<bool>> = sizes
                .iter()
                .enumerate()
                .map(|(c, &n)| (0..n).map(|i| (i + c) % 3 != 1).collect())
                .collect();
            let m = count(&mask);
            let sub = spread_subsample(&mask, k);
            assert_eq!(count(&sub), m.min(k), "{sizes:?} {k}");
            let (mut last, mut i, mut gap) = (None::<usize>, 0usize, 0usize);
            for (c, s) in mask.iter().zip(&sub) {
                for (&r, &kept) in c.iter().zip(s) {
                    assert!(r || !kept, "kept outside the mask");
                    if r {
                        if kept {
                            gap = gap.max(last.map_or(i, |l| i - l));
                            last = Some(i);
                        }
                        i += 1;
                    }
                }
            }
            assert!(gap <= m.div_ceil(k), "{sizes:?} {k}: gap {gap}");
        }
    }

    /// `second_soft_prior`: B's prior is the frame prior's learnt soft part where a listed
    /// residual's learnt centre is beyond the threshold, and no prior otherwise.
    #[test]
    fn second_motion_prior_keeps_the_learnt_soft_part_only_beyond_the_threshold() {
        let level = MotionPrior {
            center: vec![0.0; 6],
            inv_sigma: vec![10.0; 6],
            rotation_center: [0.001, 0.002, 0.003],
            rotation_inv_sigma: 57.0,
            soft_center: vec![3.0, 0.5],
            soft_inv_scale: vec![1.0, 0.1],
            soft_cauchy: vec![0.0, 5.0],
            scale: 0.002,
        };
        let on = SeparateOptions::competition_over_time();
        assert_eq!(on.second_soft_prior, 1.0);
        assert_eq!(on.second_soft_prior_residuals, vec![1]);
        // The climb's learnt centre (residual 1) is within 1 model sigma: no prior, although
        // the side slip's (residual 0, not listed) is 3 sigmas out.
        assert!(second_motion_prior(Some(&level), &on).is_none());
        let climbing = MotionPrior {
            soft_center: vec![0.2, -18.0],
            ..level.clone()
        };
        let b = second_motion_prior(Some(&climbing), &on).expect("beyond the threshold");
        assert_eq!(b.soft_center, climbing.soft_center);
        assert_eq!(b.soft_inv_scale, climbing.soft_inv_scale);
        assert_eq!(b.soft_cauchy, climbing.soft_cauchy);
        assert_eq!(b.scale, climbing.scale);
        // No per-parameter and no rotation-change prior: B may be another object's motion.
        assert!(b.center.is_empty() && b.inv_sigma.is_empty() && b.rotation_inv_sigma == 0.0);
        // Off, without a frame prior, without a learnt centre, or where every listed residual
        // is within the threshold (0: 0.2) or absent (7): no prior, as before the option.
        let off = SeparateOptions::default();
        assert_eq!(off.second_soft_prior, 0.0);
        assert!(second_motion_prior(Some(&climbing), &off).is_none());
        assert!(second_motion_prior(None, &on).is_none());
        let unlearnt = MotionPrior {
            soft_center: Vec::new(),
            ..climbing.clone()
        };
        assert!(second_motion_prior(Some(&unlearnt), &on).is_none());
        let elsewhere = SeparateOptions {
            second_soft_prior_residuals: vec![0, 7],
            ..on.clone()
        };
        assert!(second_motion_prior(Some(&climbing), &elsewhere).is_none());
        // Read from a config's section, and refused where negative or not finite.
        let o: SeparateOptions = toml::from_str("second_soft_prior = 2.5").expect("toml");
        assert!(o.validate().is_ok() && o.second_soft_prior == 2.5);
        let bad: SeparateOptions = toml::from_str("second_soft_prior = -1.0").expect("toml");
        assert!(bad.validate().unwrap_err().contains("second_soft_prior"));
    }

    /// `count_reference`: below the reference the four evidence counts shrink with the
    /// frame's matches (rounded up, never below 1) and the two road-visibility gates do not;
    /// at or above it, or with the option off, the options are the same object, untouched.
    /// `yaw_votes` and `yaw_history_final`: on in the default's separation (3 modes), off in
    /// the bare one; the grid's options are checked.
    #[test]
    fn yaw_votes_options_default_and_validate() {
        let on = SeparateOptions::competition_over_time();
        assert_eq!(on.yaw_votes, 3);
        assert!(on.hypotheses().is_some_and(|h| h.yaw_history_final));
        assert!(on.validate().is_ok());
        assert_eq!(SeparateOptions::default().yaw_votes, 0);
        assert!(!HypothesesOptions::default().yaw_history_final);
        for (bad, name) in [
            (
                SeparateOptions {
                    yaw_votes_range: 0.0,
                    ..on.clone()
                },
                "yaw_votes_range",
            ),
            (
                SeparateOptions {
                    yaw_votes_range: 2.0,
                    ..on.clone()
                },
                "yaw_votes_range",
            ),
            (
                SeparateOptions {
                    yaw_votes_step: 1e-6,
                    ..on.clone()
                },
                "yaw_votes_step",
            ),
            (
                SeparateOptions {
                    yaw_votes_informative: f64::NAN,
                    ..on.clone()
                },
                "yaw_votes_informative",
            ),
        ] {
            assert!(bad.validate().unwrap_err().contains(name), "{name}");
        }
    }

    #[test]
    fn count_thresholds_scale_with_the_frames_matches() {
        let bare = SeparateOptions::default();
        assert!(matches!(
            bare.for_matches(10),
            std::borrow::Cow::Borrowed(_)
        ));
        let off: SeparateOptions = toml::from_str("count_reference = 0").expect("toml");
        assert!(matches!(off.for_matches(10), std::borrow::Cow::Borrowed(_)));
        let o: SeparateOptions = toml::from_str("").expect("toml");
        assert_eq!(o, SeparateOptions::competition_over_time());
        assert_eq!(o.count_reference, 300);
        for n in [300, 301, 5000] {
            assert!(
                matches!(o.for_matches(n), std::borrow::Cow::Borrowed(_)),
                "{n}"
            );
        }
        let counts = |s: &SeparateOptions| {
            let h = s.hypotheses.as_ref().expect("hypotheses");
            [
                s.ground_admit_min,
                s.memory_vote_min,
                s.ground_drop_min,
                h.min_matches,
                h.track_min_labelled,
            ]
        };
        assert_eq!(counts(&o), [12, 20, 8, 10, 20]);
        assert_eq!(counts(&o.for_matches(150)), [6, 10, 8, 5, 10]);
        assert_eq!(counts(&o.for_matches(100)), [4, 7, 8, 4, 7]);
        assert_eq!(counts(&o.for_matches(1)), [1, 1, 8, 1, 1]);
        let road_gate =
            |s: &SeparateOptions| s.hypotheses.as_ref().and_then(|h| h.road_visible_min);
        assert_eq!(road_gate(&o), None);
        assert_eq!(road_gate(&o.for_matches(100)), Some(10));
        assert_eq!(road_gate(&o.for_matches(1)), Some(10));
        let mut back = o.for_matches(100).into_owned();
        back.ground_admit_min = 12;
        back.memory_vote_min = 20;
        if let Some(h) = back.hypotheses.as_mut() {
            h.min_matches = 10;
            h.track_min_labelled = 20;
            h.road_visible_min = None;
        }
        assert_eq!(back, o, "nothing else changes");
    }

    /// `candidate_subsample`: larger than every set of matches outside A's support, the
    /// separation is the default's bit for bit with the same solves; at 48 on the fisheye rig
    /// (about 150 matches outside A's support) B is solved from every start on the subsample
    /// and the least-cost B re-solved on all of them: at most two more solves per frame.
    #[test]
    fn subsample_is_the_default_where_it_keeps_every_match() {
        use momo_sim::{SimConfig, simulate};
        use std::sync::atomic::Ordering::Relaxed;
        let o: SeparateOptions = toml::from_str("candidate_subsample = 48").expect("toml");
        assert!(o.validate().is_ok() && o.candidate_subsample == 48);
        let bad: SeparateOptions = toml::from_str("candidate_subsample = 5").expect("toml");
        assert!(bad.validate().unwrap_err().contains("candidate_subsample"));
        let sim = simulate(&SimConfig {
            frames: 8,
            seed: 1,
            ..SimConfig::fisheye_surround()
        })
        .expect("simulation");
        let counted = Counted::new();
        let (estimator, solver) = (counted.estimator.as_ref(), &counted.solver);
        let ctx = counted.ctx(&sim.sequence.rig);
        let every = SeparateOptions::competition_over_time();
        let all = SeparateOptions {
            candidate_subsample: 100_000,
            ..every.clone()
        };
        let sub = SeparateOptions {
            candidate_subsample: 48,
            ..every.clone()
        };
        let mut trackers = [
            HypothesisTracker::default(),
            HypothesisTracker::default(),
            HypothesisTracker::default(),
        ];
        let (mut frames, mut calls) = (0, [0usize; 3]);
        for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
            let arc = sim.true_arc_lengths[k];
            let straight = estimator.initial_params(arc);
            let starts = vec![straight.clone()];
            let Some(first) = ctx.solve(obs, &straight, ctx.loss, false) else {
                continue;
            };
            frames += 1;
            let mut out = Vec::new();
            for (i, opts) in [&every, &all, &sub].into_iter().enumerate() {
                let c0 = solver.calls.load(Relaxed);
                out.push(separate(
                    &ctx,
                    opts,
                    obs,
                    first.clone(),
                    &starts,
                    &mut trackers[i],
                    Some(arc),
                ));
                calls[i] += solver.calls.load(Relaxed) - c0;
            }
            assert_eq!(
                out[1]
                    .0
                    .params
                    .iter()
                    .map(|p| p.to_bits())
                    .collect::<Vec<_>>(),
                out[0]
                    .0
                    .params
                    .iter()
                    .map(|p| p.to_bits())
                    .collect::<Vec<_>>(),
                "frame {k}"
            );
            assert_eq!((out[1].1, &out[1].2), (out[0].1, &out[0].2), "frame {k}");
            assert_eq!(trackers[1], trackers[0], "frame {k}");
        }
        assert!(frames >= 5, "{frames} frames");
        assert_eq!(calls[1], calls[0]);
        assert!(
            calls[2] > calls[0] && calls[2] <= calls[0] + 2 * frames,
            "{calls:?} over {frames} frames"
        );
    }

    /// `candidate_screen` on the static fisheye rig (B fitted every frame from 6 starts and
    /// rejected by competition over time): the screened B ends the search, far fewer solves,
    /// and every frame's solution (bit for bit), outcome, next stage and match memory are the
    /// default's; the option parses and validates.
    #[test]
    fn screen_solves_b_once_where_it_is_far_from_kept() {
        use momo_sim::{SimConfig, simulate};
        use std::sync::atomic::Ordering::Relaxed;
        let o: SeparateOptions = toml::from_str("candidate_screen = 0.5").expect("toml");
        assert!(o.validate().is_ok() && o.candidate_screen == 0.5);
        let bad: SeparateOptions = toml::from_str("candidate_screen = 1.5").expect("toml");
        assert!(bad.validate().unwrap_err().contains("candidate_screen"));
        let sim = simulate(&SimConfig {
            frames: 12,
            seed: 1,
            ..SimConfig::fisheye_surround()
        })
        .expect("simulation");
        let counted = Counted::new();
        let (estimator, solver, arc_index) = (
            counted.estimator.as_ref(),
            &counted.solver,
            counted.arc_index,
        );
        let ctx = counted.ctx(&sim.sequence.rig);
        let every = SeparateOptions::competition_over_time();
        let screened = SeparateOptions {
            candidate_screen: 1.0,
            ..every.clone()
        };
        let (mut with, mut without) = (HypothesisTracker::default(), HypothesisTracker::default());
        let (mut calls_every, mut calls_screened) = (0, 0);
        for (k, obs) in sim.sequence.frames.iter().enumerate().skip(1) {
            let arc = sim.true_arc_lengths[k];
            let straight = estimator.initial_params(arc);
            let starts: Vec<Vec<f64>> = [0.0, -0.1, -0.03, 0.03, 0.1]
                .iter()
                .map(|dy| {
                    let mut s = straight.clone();
                    if let Some(p) = estimator.params_from_motion(&Pose::new(
                        momo_core::so3_exp(&nalgebra::Vector3::new(0.0, 0.0, *dy)),
                        estimator.motion(&straight).translation,
                    )) {
                        s = p;
                        s[arc_index] = arc;
                    }
                    s
                })
                .collect();
            let Some(first) = ctx.solve(obs, &straight, ctx.loss, false) else {
                continue;
            };
            let c0 = solver.calls.load(Relaxed);
            let old = separate(
                &ctx,
                &every,
                obs,
                first.clone(),
                &starts,
                &mut without,
                Some(arc),
            );
            let c1 = solver.calls.load(Relaxed);
            let new = separate(&ctx, &screened, obs, first, &starts, &mut with, Some(arc));
            let c2 = solver.calls.load(Relaxed);
            calls_every += c1 - c0;
            calls_screened += c2 - c1;
            assert_eq!(
                new.0.params.iter().map(|p| p.to_bits()).collect::<Vec<_>>(),
                old.0.params.iter().map(|p| p.to_bits()).collect::<Vec<_>>(),
                "frame {k}"
            );
            assert_eq!((new.1, &new.2), (old.1, &old.2), "frame {k}");
            assert_eq!(with, without, "frame {k}");
        }
        eprintln!(
            "separation solves over 11 fisheye pairs: every start {calls_every}, screened {calls_screened}"
        );
        assert!(calls_every >= 10 * 5, "B from every start: {calls_every}");
        assert!(
            2 * calls_screened < calls_every,
            "{calls_screened} of {calls_every}"
        );
    }
}
