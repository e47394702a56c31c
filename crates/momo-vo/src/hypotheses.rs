//! Multi-frame choice between two competing motions (issue 14): the static world against a
//! large moving object, as an optional part of the motion separation
//! (`[odometry.separate.hypotheses]`, off by default; see [`crate::separate`]).
//!
//! When the separation finds two motions with large support (A, the frame's solve, continuing
//! the previous frame's track through the warm start and the rotation prior; B, fitted to the
//! rest), the per-frame cues (support, positive depth, image cells, plausibility) cannot tell
//! them apart: a vehicle ahead moving with the ego car holds most matches, and its apparent
//! motion (its lateral drift seen as a yaw) is itself a plausible vehicle motion.
//!
//! The cue used here is **odometry consistency through parallax**. When the vehicle moved (the
//! odometry arc length, or the estimated one, is at least [`HypothesesOptions::min_arc_length`]),
//! the static world seen under the true motion shows translation parallax: once the rotation is
//! removed, a match's bearing moves away from the epipole (the focus of expansion), by an angle
//! that grows with the arc length and shrinks with the depth. An object moving with the ego car
//! shows no parallax at all: the motion that explains it is (nearly) a pure rotation, and under
//! it its matches, and the far static points it also fits, stay where the rotation puts them.
//! So each motion is scored by its **parallax support** `P(H)`: the matches of its support whose
//! derotated bearing moved away from its epipole (positive depth) by at least
//! [`HypothesesOptions::parallax`] radians,
//! `p = ((f0 × R f1) · (t × f0)) / ‖t × f0‖`, with `(R, t)` the camera motion (the pose of the
//! camera at frame k in the camera at frame k-1) and `f0`, `f1` the unit bearings.
//!
//! A zero-flow object has no parallax, but a bus in stop-and-go traffic or an oncoming car
//! does, and then the parallax support does not choose. The stronger form of the same cue is
//! **the ground at the odometry's scale** ([`HypothesesOptions::ground`], on by default): with
//! the motion's translation at the odometry arc length, each parallax match of a motion's
//! support is triangulated (depth `z0` in the camera at frame k-1 from
//! `z0 f0 = z1 R f1 + t`) and counted in its **ground support** if the point lies on the road
//! plane, `z = ground_z` in the vehicle frame (the rig's mount heights put the road at
//! `z = 0` in the simulator and in `momo import-kitti`), within
//! `max(ground_tolerance, 2 h σ / p)` (`h` the camera's height above the road, `σ`
//! [`HypothesesOptions::noise_angle`], `p` the match's parallax angle: the height error of a
//! triangulated road point). The true motion puts the road where the mount says it is; the
//! motion of an object, scaled by the ego car's arc length, puts its points at wrong depths
//! and its support has (almost) no road points (simulated KITTI 00 seed 2, frames 1-116:
//! 19-52 road points under the true motion, 0-11 under the locked-in one).
//!
//! **Over frames**, the evidence that B beats A, `e = (P(B) - P(A)) / (P(A) + P(B))`, is
//! accumulated with a decay: `D_k = decay · D_{k-1} + e_k` (frames without competition only
//! decay it); B replaces A when `D_k` exceeds [`HypothesesOptions::margin`], and the evidence
//! restarts at zero after a switch (the chosen track becomes the continued one). A decay of 0
//! is a per-frame choice; a decay near 1 needs consistent evidence over several frames.
//!
//! What the simulator's data allows (momo-sim `moving_traffic`): odometry arc lengths are given
//! (exact by default), so the parallax cue applies; matches are drawn independently per frame
//! pair (no tracks), so match persistence and epipolar consistency over two frame gaps cannot
//! be used on it.

use momo_core::{FrameObservations, Pose, Rig, camera_motion};
use serde::{Deserialize, Serialize};

/// Largest [`HypothesesOptions::ground_pitch`] accepted, radians (11.5°): a camera mounted
/// further off its nominal pitch has the wrong rig.
pub const MAX_GROUND_PITCH: f64 = 0.2;

/// Options of the multi-frame hypothesis choice (`[odometry.separate.hypotheses]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HypothesesOptions {
    /// Use the multi-frame choice (false: as if `[odometry.separate.hypotheses]` were absent;
    /// the way a TOML section turns off the default separation's choice).
    pub enabled: bool,
    /// Least derotated parallax angle (radians) of a match counted in a motion's parallax
    /// support (0.004 ≈ 2.9 px at f = 718 px, about 2 sigma of the derotated angle at 1 px).
    pub parallax: f64,
    /// The cue applies only when the frame's arc length (odometry if given, else the solved
    /// one) is at least this (metres): without translation there is no parallax.
    pub min_arc_length: f64,
    /// The cue decides only when the two motions' parallax supports hold at least this many
    /// matches together (otherwise the separation's own rule decides).
    pub min_matches: usize,
    /// Decay of the accumulated evidence from one frame to the next, in [0, 1).
    pub decay: f64,
    /// B replaces A when the accumulated evidence exceeds this.
    pub margin: f64,
    /// Choose by the ground support (see the module doc) instead of the parallax support.
    pub ground: bool,
    /// Height of the road in the vehicle frame, metres (0: the vehicle origin on the road).
    pub ground_z: f64,
    /// Pitch of the road against the vehicle frame, radians: below each camera the road
    /// rises ahead by `tan(ground_pitch)` per metre of `x`, `z = ground_z + tan(ground_pitch)
    /// (x - x_c)` (`x_c` the camera's). A camera pitched nose down by `θ` against its nominal
    /// mount sees the road rise by `θ` in the nominal vehicle frame: `momo calibrate`'s pitch
    /// (`odometry.road_scale_mount` sets it from the sequence's calibration). 0: the
    /// road is the vehicle frame's x-y plane.
    pub ground_pitch: f64,
    /// Least height tolerance of a road point, metres.
    pub ground_tolerance: f64,
    /// Standard deviation of a bearing's angle (radians; 1 px at f = 718 px is 0.0014), for
    /// the height tolerance of triangulated road points.
    pub noise_angle: f64,
    /// Score a motion by the **spread** of its ground (or parallax) support instead of its
    /// count: the image cells (columns, rows per camera, frame k-1 pixels) holding at least
    /// one of its road points. Object points low in the image can land near the road plane
    /// under the object's motion, but they are compact; the road of the static world spreads
    /// over the lower image. None (default): the count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spread_grid: Option<(usize, usize)>,
    /// Evidence over the run of competing frames by **track** (0: off, the per-frame choice
    /// of the decay/margin above). A lock-in on a moving object lasts 3-30 frames in which A
    /// and B swap roles (A follows the object in one frame, the static world in the next), so
    /// the evidence "B beats A" of [`HypothesesOptions::decay`] does not add up over the run.
    /// Here the match memory tells which of A and B continues the previous frame's chosen
    /// motion (the track whose support the memory labels static): the one whose support's
    /// remembered-static share `f = static / (static + other)` exceeds the other's by at least
    /// [`HypothesesOptions::track_identity`], the one at least one half, the other below it
    /// (both supports with at least [`HypothesesOptions::track_min_labelled`] labelled
    /// matches; two motions of the static world, one a purer subset of the other, or two fits
    /// of a static scene's noise are not two tracks: without that rule a clean and an outliers
    /// sequence along KITTI 08 took such a motion, 0.34 -> 0.99 and 0.54 -> 0.97 deg,
    /// docs/RESULTS.md §9, seventeenth session). Each track's score is then
    /// summed over the run with this decay, `T_k = track_decay · T_{k-1} + s_k` (`s_k` the
    /// frame's [`score`] of the candidate continuing it; frames without competition only decay
    /// both sums), and B replaces A when
    /// `(T_B − T_A) / (T_A + T_B) > margin` with `T_A + T_B >= min_matches`. Where the memory
    /// does not tell the tracks apart (or nothing is remembered) the run restarts from this
    /// frame's scores. In [0, 1).
    pub track_decay: f64,
    /// Least difference of the remembered-static shares that identifies the tracks
    /// ([`HypothesesOptions::track_decay`]), in (0, 1].
    pub track_identity: f64,
    /// Least labelled matches of each support for the identification
    /// ([`HypothesesOptions::track_decay`]).
    pub track_min_labelled: usize,
    /// A switch away from the continued track must hold against that track's sum (0: off;
    /// needs [`HypothesesOptions::track_decay`]). Where the match memory says A continues the
    /// previous frame's chosen track, B replaces A only if, besides the sums' test, its own
    /// score in this frame exceeds this factor times A's track sum,
    /// `s_B > track_hold · T_A` with `T_A = track_decay · T_{k-1} + s_A`: the other track's sum
    /// (which a co-moving bus builds up while it is the rejected alternative) does not lend B
    /// the evidence to leave a track held over the run. On the moving-traffic grid's frames
    /// where A continued the track and B's sum won (17, docs/RESULTS.md §9, eighteenth
    /// session), the four wrong switches (a bus at `s_B / T_A` = 0.39-0.76) and none of the
    /// right ones (at least 1.35, outside the flip-flops that those wrong switches start) fall
    /// below 1. Off by default: alone it gives grid 33 -> 28 frames above 1 deg and hold-out
    /// 27 -> 22, no sequence with more (switch32), but beside the default's
    /// `candidate_by_road` (since the eighteenth session) it gives grid 17 -> 21 (a bus that
    /// gets through at 06 s2 281 is held for 11 frames, up to 5.7 deg) and hold-out 15 -> 13
    /// (docs/RESULTS.md §9, eighteenth session, lead). Sensitive: a bus that gets through is
    /// held too (0.8 alone: grid 39), and a larger factor holds off right switches (1.25
    /// alone: hold-out 24, one sequence +2).
    pub track_hold: f64,
    /// A switch away from the continued track needs B's road to span the road's depths (0:
    /// off; needs [`HypothesesOptions::track_decay`]). Where the match memory says A continues
    /// the previous frame's chosen track, and the tracks' sums exist (a frame since the start or
    /// a reset had two motions compete: before, the memory's track is whatever the lone solves
    /// followed, which may have jumped onto an object, hold-out 07 s11 frame 8), B replaces A
    /// only if its road support (the matches of
    /// [`ground_mask`]) spans a depth ratio `Z_max / Z_min` of at least this factor, `Z` the
    /// depth along the camera's optical axis of each triangulated road point
    /// ([`road_depth_span`]). The static world's road under the true motion is seen from the
    /// near field to the far one; the lower part of a vehicle that the vehicle's own motion
    /// (scaled by the ego arc length) puts on the road plane lies at about one distance,
    /// `Z = h f / (v − c_y)` over a narrow band of image rows (a road-coloured object). On the
    /// moving-traffic grid's 16 switches of this kind (docs/RESULTS.md §9, nineteenth session,
    /// choice33) the 7 to a motion at least 0.1 deg worse than A had spans 1.7-3.0, the 9 better
    /// ones 3.8-8.4 (where the memory does not tell the tracks apart, or says B continues, right
    /// switches with spans below 3 are common: an occluded near road). Off in
    /// `HypothesesOptions::default()`; 3.4 in the default separation
    /// (`SeparateOptions::competition_over_time`, since the nineteenth session: moving-traffic
    /// grid 17 -> 10 frames above 1 deg, hold-out 15 -> 6, no sequence with more; 3.0 and 4.0
    /// give 10 on the grid, 6 and 7 on the hold-out). A config file's
    /// `[odometry.separate.hypotheses]` section gets 0 unless it writes it.
    pub road_span: f64,
    /// [`HypothesesOptions::road_span`] holds the continued track only once the road has
    /// vouched for a track (fifty-fifth session): since the start (or a reset of the driver) a
    /// chosen track's decayed road-score sum has reached [`HypothesesOptions::min_matches`].
    /// Before that the continued track is the first frame's solve, chosen on no evidence, and at
    /// a drive's start the static road's depth span is narrow: a road point straight ahead
    /// moves by a parallax of about `s h / Z²` after a forward step `s` (`h` the camera's
    /// height), so at `s = 0.17 m` it reaches [`HypothesesOptions::parallax`] only within
    /// about 8 m (points to the side farther out), while a
    /// bus holding 60 % of the matches wins the first solve. Off in
    /// `HypothesesOptions::default()`.
    pub road_span_vouched: bool,
    /// Vehicle-model plausibility of the choice (radians; 0: off; twentieth session, frames34):
    /// a car's frame-to-frame motion hardly rolls or pitches, so an alternative whose [`tilt`]
    /// (the roll and pitch part of its rotation, `√(ω_x² + ω_y²)` of `ω = log R` in the vehicle
    /// frame) exceeds A's by more than this does not replace A, whatever the road scores and
    /// the memory say: the apparent motion of an object, or a fit to the noise, rolls or
    /// pitches where the ego vehicle cannot. On the moving-traffic grid (docs/RESULTS.md §9,
    /// twentieth session, frames34) A's tilt is below 0.62 deg in 99 % of the frames where A
    /// is within 0.2 deg of the truth; of main's switches, the three to an alternative tilted
    /// more than 0.57 deg (0.01 rad) beyond A were all wrong (0.67-0.83 deg beyond A; the right
    /// switches at most 0.53 deg beyond). Off in `HypothesesOptions::default()`; the default
    /// configuration (`SeparateOptions::competition_over_time`) sets 0.01 since the twentieth
    /// session (grid 10 -> 7 frames above 1 deg, seeds 11-15 and 16-20 none worse; static scenes,
    /// built-in drive and real KITTI 00 byte-identical). A config file's
    /// `[odometry.separate.hypotheses]` section gets 0 unless it writes it.
    pub tilt_margin: f64,
    /// With [`HypothesesOptions::tilt_margin`]: the converse — where A's tilt exceeds an
    /// alternative's by more than the margin (among the alternatives formed this frame,
    /// before competition over time, where one could be kept at all), the one with the
    /// highest positive road score among those replaces A, whatever competition over time
    /// and the tracks' sums say. Off in `HypothesesOptions::default()` (measured in
    /// docs/RESULTS.md §9, twentieth session, frames34); the default configuration
    /// (`SeparateOptions::competition_over_time`) sets it since the twenty-first session, gated
    /// by [`HypothesesOptions::tilt_reference_frames`] `= 1`. A config file's
    /// `[odometry.separate.hypotheses]` section gets false unless it writes it.
    pub tilt_replace: bool,
    /// With [`HypothesesOptions::tilt_replace`]: the converse's own test applied to its
    /// replacement — among the alternatives flatter than A by the margin, only those within
    /// [`HypothesesOptions::tilt_margin`] of the flattest of them compete (the highest positive
    /// road score among those replaces A). Without it a replacement tilted more than another
    /// qualifying alternative by the margin can win on one more road match, and the rule would
    /// then reject its own choice (seventy-seventh session: `conf3` 08 s87 frame 78 chose a
    /// 1.08°-pitched bus fit, road score 13, over the static world's 0.10° fit, road score 12;
    /// the lock-in it started reached 1.04° at frame 80). See
    /// [`HypothesesOptions::flattest_within_margin`]. Off in `HypothesesOptions::default()`;
    /// a config file's `[odometry.separate.hypotheses]` section gets false unless it writes it.
    pub tilt_replace_flattest: bool,
    /// Odometry consistency of the yaw (in standard deviations of the rotation prior; 0: off;
    /// twenty-first session, yaw35): where the motion prior is active (the previous frame was
    /// estimated, trusted and had no competing motion: `odometry.rotation_change_sigma`, the
    /// prior `ω ~ N(ω_prev, σ² I)` on the rotation vector `ω = log R` of the vehicle motion),
    /// A's yaw `ω_z` lies more than `k σ` from the prior's centre (a jump of A onto another
    /// motion: `|ω_z(A) − ω_z,prev| / σ > k`) and an alternative formed this frame (before
    /// competition over time, where one could be kept at all) lies within `k σ / 2` of it,
    /// the one with the highest positive road score among those replaces A, whatever
    /// competition over time and the tracks' sums say. A trusted frame's successor cannot turn
    /// by many σ more than it did, while a lead vehicle or a bus that fills the image turns
    /// it at once (at start-up no competing motion has been seen, and the right alternative's
    /// matches are remembered static: competition over time rejects it as A's noise tail).
    /// Off in `HypothesesOptions::default()`; the default configuration
    /// (`SeparateOptions::competition_over_time`) sets 7 since the twenty-first session (7 σ =
    /// 0.8 deg at `σ = 0.002`; moving-traffic grid 7 -> 6 frames above 1 deg, seeds 11-15 6 ->
    /// 4, no sequence with more; the static scenes, the built-in drive and real KITTI 00
    /// byte-identical; docs/RESULTS.md §9, twenty-first session, yaw35). A config file's
    /// `[odometry.separate.hypotheses]` section gets 0 unless it writes it.
    pub yaw_jump: f64,
    /// The gate of [`HypothesesOptions::tilt_replace`] by the run's recent history (frames;
    /// 0: off, the converse as without it; twenty-first session, tilt35): A is replaced only
    /// where its tilt also exceeds a reference tilt of the last `K` frames' chosen motions
    /// ([`HypothesisTracker::tilt_reference`], [`HypothesesOptions::tilt_reference`]) by
    /// [`HypothesesOptions::tilt_reference_margin`], and never where the ordinary choice
    /// switched to an alternative that passes the same test (the one it meets: the highest
    /// road score's, or since the fifty-second session the one
    /// [`HypothesesOptions::yaw_history_tie`] picks). A car's roll and pitch rates
    /// change smoothly from frame to frame (a road's grade and camber vary over tens of
    /// metres), so a true tilt rises from the previous frames' tilts while a fit to an object's
    /// motion or to the noise jumps away from them. Before `K` frames have been recorded the
    /// reference is over those there are; with none the gate does not open. Off in
    /// `HypothesesOptions::default()`; the default configuration
    /// (`SeparateOptions::competition_over_time`) sets `K = 1` (the previous frame) with
    /// `tilt_reference_margin = 0.01` since the twenty-first session (moving-traffic grid 7 -> 4
    /// frames above 1 deg; seeds 11-15, the static scenes along KITTI, the built-in drive and
    /// real KITTI 00 byte-identical; seeds 16-20 one frame changed, 0.68 -> 0.21 deg;
    /// docs/RESULTS.md §9, twenty-first session, tilt35), and `K = 3` with
    /// `tilt_reference = "minimum"` where a frame among them had two motions compete
    /// ([`HypothesesOptions::tilt_reference_contested`]) since the seventy-eighth session. A
    /// config file's `[odometry.separate.hypotheses]` section gets 0 unless it writes it.
    pub tilt_reference_frames: usize,
    /// The margin (radians) by which A's tilt must exceed the history's reference tilt for
    /// [`HypothesesOptions::tilt_reference_frames`] to let the converse replace A.
    pub tilt_reference_margin: f64,
    /// Odometry consistency of the yaw over the run's recent frames (frames; 0: off;
    /// twenty-second session, curve36): the reference yaw is the median of the last `K` frames'
    /// chosen motions' yaws `ω_z` (`ω = log R` of the vehicle motion, the separation's choice
    /// before the final stage; [`HypothesisTracker::yaw_reference`]), whether or not those
    /// frames were trusted or had competing motions (the rotation prior of
    /// [`HypothesesOptions::yaw_jump`] is off after every frame where two motions competed, so
    /// through a curve behind a lead car it never acts). With
    /// [`HypothesesOptions::yaw_history_margin`] `= m`: (1) the ordinary choice's switch to an
    /// alternative whose yaw lies more than `m` from the reference does not happen where A's lies
    /// within `m` of it, unless the ground cue is decisive (the alternative's road score is at
    /// least `odometry.separate.ground_admit_min` and `ground_admit` times A's: an A that drifted
    /// onto an object by a few tenths of a degree per frame carries the history with it); (2)
    /// with [`HypothesesOptions::yaw_history_replace`], where A's yaw lies more than `m` from
    /// it, the alternative with the highest positive road score among those formed this frame
    /// (before competition over time, where one could be kept at all) within `m` of it replaces
    /// A. A car's yaw rate changes smoothly (`Δω_z = v Δκ Δt` with the
    /// curvature `κ` of a road varying over tens of metres: along KITTI 00-10's ground truth
    /// the per-frame yaw changes by at most a few tenths of a degree from one frame to the
    /// next), while a lead car that follows the ego through a curve at a constant gap looks
    /// almost like a motion without rotation: a switch onto it, or an A locked onto it, jumps
    /// by the whole turn. Before any frame was recorded the rule does not act. Off in
    /// `HypothesesOptions::default()`; the default configuration
    /// (`SeparateOptions::competition_over_time`) sets `K = 1` (the previous frame), `m =
    /// 0.01745` (1 deg) with the replacement since the twenty-second session (moving-traffic
    /// grid 6 -> 3 frames above 1 deg, seeds 11-15 4 -> 4 and 16-20 9 -> 8 with no sequence
    /// with more, development seeds 21-30 14 -> 10; the static scenes along KITTI, the built-in
    /// drive and real KITTI 00 byte-identical; docs/RESULTS.md §9, twenty-second session,
    /// curve36). A config file's `[odometry.separate.hypotheses]` section gets 0 unless it
    /// writes it.
    pub yaw_history_frames: usize,
    /// The margin `m` (radians) of [`HypothesesOptions::yaw_history_frames`].
    pub yaw_history_margin: f64,
    /// The ordinary choice's near tie broken by the yaw history (0: off; fifty-first session,
    /// tie66): where the alternative with the highest road score ([`score`]) lies more than
    /// half the yaw margin ([`HypothesisTracker::yaw_margin`]) from the recent frames'
    /// reference yaw ([`HypothesisTracker::yaw_reference`]), the highest-scoring alternative
    /// within half the margin whose road score is at least this share of the top one's is the
    /// one that competes with A instead. Two motions whose road scores differ by a cell or two
    /// are not told apart by the road (the lower half of a vehicle that its own motion puts on
    /// the road plane earns a few cells), while a car's yaw changes by a few tenths of a degree
    /// from one frame to the next. Unlike the veto of
    /// [`HypothesesOptions::yaw_history_frames`] the rule never keeps A: it only picks which
    /// alternative A meets, so it cannot hold a lock-in whose history is the object's where the
    /// static world's road outscores the alternatives near that history. Off in
    /// `HypothesesOptions::default()`; the default configuration sets 0.8.
    pub yaw_history_tie: f64,
    /// The margin of [`HypothesesOptions::yaw_history_frames`] for a slow vehicle, `(m₀, k)`:
    /// with the frame's arc length `s` (metres, from odometry) and `σ` the largest standard
    /// deviation of the history's reported yaws (each frame's covariance on `ω_z`) the margin is
    /// `min(m, √((m₀ + k·s)² + (3σ)²))` (radians; `k` in radians per metre). A car's yaw per
    /// frame changes by `Δω_z ≈ s·Δκ + κ·Δs`: the curvature `κ` follows the steering, which
    /// turns at a limited rate, so the slower the car the less its yaw per frame can change
    /// from one frame to the next. Along KITTI 00-10's ground truth it changes by at most
    /// 0.26 deg where `s < 0.1 m` and 0.39 deg where `s < 0.2 m`, against 99.9th percentiles
    /// of 0.4-0.76 deg (maxima 1.1-2.5 deg) at 0.3-1 m per frame, where the turns at junctions
    /// are. At a drive's start behind a bus the
    /// bus's motion is a jump of half a degree that the fixed `m` lets through; where the
    /// history itself is uncertain (a frame with competing motions reports a yaw sigma of a
    /// degree or more) the `3σ` term gives the fixed margin back, so a history that is not
    /// known to be right is not held. Needs [`HypothesesOptions::yaw_history_final`] (the
    /// reported yaws carry the sigmas; without it none is known). `(0, 0)` in
    /// `HypothesesOptions::default()` (a written `[odometry.separate.hypotheses]` section gets
    /// it unless it sets it); either part 0 turns it off, as does a frame without arc length.
    /// `(0.00436, 0.01745)` (0.25 deg + 1 deg per metre) in the default configuration since the
    /// forty-fourth session (docs/RESULTS.md, slow59).
    pub yaw_history_slow_margin: (f64, f64),
    /// The replacement of an A whose yaw jumped from the recent frames' by an alternative that
    /// continues them ([`HypothesesOptions::yaw_history_frames`]).
    pub yaw_history_replace: bool,
    /// The yaw history of [`HypothesesOptions::yaw_history_frames`] holds each frame's
    /// *reported* motion (after the final stage and the driver's later choices:
    /// `odometry.decide_by_road`, the previous-basin and competing-region rules; the odometry
    /// replaces the last recorded yaw, [`HypothesisTracker::set_last_yaw`]) instead of the
    /// separation's chosen motion. Where the separation keeps an A that follows a cut-in car
    /// and the final stage (under the rotation prior) still reports the static world's motion,
    /// the history otherwise carries the object's yaw into the next frame, and an A that stays
    /// on the object does not jump from it. Off in `HypothesesOptions::default()` (so a
    /// written `[odometry.separate.hypotheses]` section gets false unless it sets it); on in the
    /// default configuration (`SeparateOptions::competition_over_time`) since the thirty-ninth
    /// session, with `odometry.separate.yaw_votes` (docs/RESULTS.md §9, thirty-ninth session,
    /// votes53).
    pub yaw_history_final: bool,
    /// The statistic of the recent tilts ([`HypothesesOptions::tilt_reference_frames`]):
    /// their median (`"median"`, default; `K = 1`: the previous frame's) or their minimum
    /// (`"minimum"`).
    pub tilt_reference: TiltReference,
    /// The reference over [`HypothesesOptions::tilt_reference_frames`] frames only where two
    /// motions competed (the separation's `competing`) on one of those frames; elsewhere the
    /// previous frame's tilt (seventy-eighth session; off in `HypothesesOptions::default()`,
    /// on in the default configuration with `tilt_reference_frames = 3`, `tilt_reference =
    /// "minimum"`). The minimum over a few frames meets a lock-in whose tilt ramps onto an
    /// object by less than the margin per frame (a bus filling the image's left half along
    /// KITTI 10, seed 86, frames 223-225: roll 0.007 -> 0.016 -> 0.022 rad, 1.08 deg off), and
    /// such a ramp needs an object that competes; where nothing competed the truth's own tilt
    /// change over a few frames is met against the previous frame alone (a static scene with
    /// 30 % mismatches along KITTI 00, seed 2, frame 118: the minimum of three frames let a
    /// flatter alternative of 8 matches replace a correct motion, 0.04 -> 0.47 deg).
    pub tilt_reference_contested: bool,
    /// With [`HypothesesOptions::tilt_replace`]: a flatter alternative also qualifies for the
    /// converse without a positive road score where the ground cue does not apply between A
    /// and it — their road scores sum below [`HypothesesOptions::min_matches`], the same test
    /// by which [`HypothesisTracker::choose`] leaves a frame to the other rules (twenty-second
    /// session, grid36). The positive road score stands for "the static world's motion puts
    /// matches on the road"; where A too has lost the road the scores cannot tell the static
    /// world from an object, and the vehicle model (A's tilt jumped, the alternative's did not)
    /// decides. An alternative with a positive score still comes first (the highest score
    /// wins; the first of equal scores). Off (`false`; measured in docs/RESULTS.md §9,
    /// twenty-second session, grid36).
    pub tilt_replace_roadless: bool,
    /// With [`HypothesesOptions::tilt_reference_frames`]: where A's road score is below
    /// [`HypothesesOptions::min_matches`] (the road does not vouch for A's tilt), the
    /// reference of the gate is the minimum of the last `K'` frames' recorded tilts instead
    /// (frames; 0: off; twenty-second session, grid36). A true tilt (a road's grade or camber)
    /// keeps the road under the motion; a fit to an object loses it, and after one such frame
    /// the previous frame's tilt is itself the wrong one, which the minimum over a few frames
    /// looks past. Where A keeps its road the one-frame reference stays (a static scene's true
    /// tilt jumps 0.78 deg above the minimum of three frames: docs/RESULTS.md §9,
    /// twenty-first session, tilt35). Off in `HypothesesOptions::default()`; the default
    /// configuration (`SeparateOptions::competition_over_time`) sets `K' = 3` since the
    /// twenty-second session (moving-traffic grid 6 -> 5 frames above 1 deg; seeds 11-15, the
    /// development seeds 21-50, the static scenes along KITTI, the built-in drive and real
    /// KITTI 00 byte-identical; seeds 16-20 one frame changed, 0.99 -> 0.21 deg; docs/RESULTS.md
    /// §9, twenty-second session, grid36). A config file's `[odometry.separate.hypotheses]`
    /// section gets 0 unless it writes it.
    pub tilt_weak_road_frames: usize,
    /// The motion prior's prediction where no formed motion continues the yaw (radians; 0:
    /// off; twenty-third session, tail37). With [`HypothesesOptions::yaw_history_frames`]:
    /// where A's yaw `ω_z(A)` lies more than this margin `J` from the recent frames' reference
    /// `r` ([`HypothesisTracker::yaw_reference`]), A's road score is below
    /// [`HypothesesOptions::min_matches`] (the road does not vouch for it) and none of the
    /// rules that replace A (the tilt's converse, [`HypothesesOptions::yaw_jump`],
    /// [`HypothesesOptions::yaw_history_replace`]) found an alternative, the previous frame's
    /// motion (the constant-velocity prediction `M_t = M_{t-1}`, the first start) is re-solved
    /// on the matches it explains (epipolar angle below the separation's threshold; at least
    /// 12) and, where the re-solved motion's yaw lies within
    /// [`HypothesesOptions::yaw_history_margin`] of `r`, it replaces A. A car's yaw rate
    /// changes by a few tenths of a degree from one frame to the next (`Δω_z = v Δκ Δt`); an
    /// A that jumps by degrees with no road under it is an object filling the view (a lead
    /// car whose static background is hidden), and where no fitted alternative continues the
    /// run the prediction's own support is the static world's. The test of A's road does not
    /// tell an object from a scene without road: there every yaw jump beyond `J` is replaced
    /// (with `J = 1 deg` and the hold eight of `momo-vo`'s integration tests fail, e.g. a sharp
    /// turn after straight driving): hence the road guard,
    /// [`HypothesesOptions::yaw_history_predict_road_frames`]. Off here (`0`; measured in
    /// docs/RESULTS.md §9, twenty-third session, tail37); `0.01745` with the hold and the
    /// guard in [`crate::separate::SeparateOptions::competition_over_time`] since the
    /// twenty-fourth session (tail38).
    pub yaw_history_predict: f64,
    /// With [`HypothesesOptions::yaw_history_predict`]: where the re-solve is not possible
    /// (fewer than 12 matches explained by the prediction), fails or jumps too, the prediction
    /// itself (the previous frame's motion, unsolved) replaces A. Off (`false`).
    pub yaw_history_predict_hold: bool,
    /// The road-support guard of [`HypothesesOptions::yaw_history_predict`] (frames; 0: off,
    /// the prediction acts wherever A has no road; twenty-fourth session, tail38): the
    /// prediction acts only where the median of the last `K` frames' chosen motions' road
    /// scores ([`score`], recorded by [`HypothesisTracker::record_road`]) is at least
    /// [`HypothesesOptions::min_matches`] — A *lost* the road the recent frames' motions had
    /// ([`HypothesisTracker::road_lost`]) — and A's own road score is at most
    /// [`HypothesesOptions::yaw_history_predict_road_drop`] times that median. A lead car that
    /// hides the static background takes the road out of A's support from one frame to the
    /// next; in a scene without a visible road (every chosen motion's score below
    /// `min_matches`), or where the road score only scatters about `min_matches` (a true
    /// sharp turn among random scene points), a yaw jump is a true turn and A stays. Off
    /// (`0`).
    pub yaw_history_predict_road_frames: usize,
    /// With [`HypothesesOptions::yaw_history_predict_road_frames`] `= K`: the drop ratio `q`
    /// of A's road score `s_A` against the median `m` of the last `K` frames' (`s_A <= q m`;
    /// in `(0, 1]`; `0.4`, the ratio of `odometry.separate.ground_drop`'s flag).
    pub yaw_history_predict_road_drop: f64,
    /// With [`HypothesesOptions::yaw_history_predict`]: the prediction is also formed where
    /// A's tilt jumps from the recent frames' (the gate of the tilt's converse,
    /// [`HypothesisTracker::tilt_jumps_given_road`] with A's road weak) instead of its yaw,
    /// and it replaces A only where its own tilt does not jump either. Off (`false`).
    pub tilt_predict: bool,
    /// The prediction chosen by its own road evidence (radians; 0: off; twenty-fifth
    /// session, tail39). With [`HypothesesOptions::yaw_history_frames`]: let `X` be the motion
    /// the rules leave for this frame (the alternative that the tilt's converse,
    /// [`HypothesesOptions::yaw_jump`], [`HypothesesOptions::yaw_history_replace`] or
    /// [`HypothesesOptions::yaw_history_predict`] chose to replace A; A where none did).
    /// Where `X`'s yaw lies more than this margin `J'` from the recent frames' reference `r`
    /// ([`HypothesisTracker::yaw_reference`]) or its tilt jumps from the recent frames'
    /// ([`HypothesisTracker::tilt_jumps_given_road`], its road weak), and `X`'s road score
    /// `s_X` ([`score`]) is below [`HypothesesOptions::min_matches`], the previous frame's
    /// motion (the constant-velocity prediction `M_t = M_{t-1}`) re-solved on the matches it
    /// explains, `P`, replaces `X` where `P` continues the history (its yaw within
    /// [`HypothesesOptions::yaw_history_margin`] of `r`, its tilt not jumping) and the road
    /// vouches for it: `s_P >= min_matches` and `s_P > ρ · max(s_X, s_alt)` over every
    /// alternative formed this frame (`ρ` [`HypothesesOptions::predict_by_road_ratio`]). The
    /// rules above take an alternative because its yaw stays within a 1-deg margin, or keep
    /// A because its jump stays below it; this one asks the two motions' own evidence — the
    /// static road that the ego motion puts under its matches — where the chosen one jumps
    /// by more than a car's yaw rate changes (`Δω_z = v Δκ Δt`, a few tenths of a degree) and
    /// has no road under it. Off here (`0`); the default configuration
    /// ([`crate::separate::SeparateOptions::competition_over_time`]) sets `0.00873` (0.5 deg)
    /// since the twenty-sixth session.
    pub predict_by_road: f64,
    /// With [`HypothesesOptions::predict_by_road`]: the ratio `ρ` by which the re-solved
    /// prediction's road score must exceed the chosen motion's and every alternative's
    /// (`s_P > ρ · max(s_X, s_alt)`; at least 1; `1.0`).
    pub predict_by_road_ratio: f64,
    /// With [`HypothesesOptions::predict_by_road`]: where the re-solved prediction `P`
    /// replaced the motion and nothing else competed in the frame (no alternative kept by
    /// competition over time, no other rule replaced A), the frame does not switch the next
    /// frame's change-of-motion prior off ([`crate::separate::SeparationOutcome::prior_kept`]):
    /// `P` continues the run by construction (its yaw within the history's margin, its tilt
    /// not jumping, the road under it), so it may centre the next frame's rotation prior as an
    /// unopposed frame does. The final stage still runs on `P`'s support, and the trust's own
    /// tests (status, inlier ratio) still decide. Off (`false`: such a frame is reported as
    /// one with competing motions, as the other rules' replacements are; twenty-sixth
    /// session, road40).
    pub predict_by_road_prior: bool,
    /// With [`HypothesesOptions::predict_by_road`]: the alternatives formed this frame that
    /// continue the history (yaw within `J'` of `r`, the margin by which `X` jumped; tilt not
    /// jumping) are candidates
    /// beside `P`: of `P` and those (`C`, `P` first), the one with the highest road score
    /// `s_C` replaces `X` where `s_C >= min_matches` and `s_C > ρ · max(s_X, s_alt)` over the
    /// alternatives that do not continue the history. Where the road rule fires because `X`
    /// jumped without road, the right motion is sometimes formed as an alternative (the
    /// static world's own fit, more road than the prediction) while `P` loses to it; the
    /// same road evidence then picks it. Off (`false`: `P` only, against every alternative;
    /// twenty-seventh session, tail41).
    pub predict_by_road_alternatives: bool,
    /// With [`HypothesesOptions::predict_by_road`]: vehicle-model plausibility of the
    /// direction of travel (in the model's own standard deviations; 0: off; seventieth
    /// session, slip85). Where the motion the rules leave, `X`, jumped by more than `J'` (as
    /// for the road rule) and the model's first prior residual at `X` (the soft single-track
    /// model's side slip `(heading − ω_z / 2) / σ_slip`, [`momo_core::Manifold::prior_residuals`];
    /// a model without prior residuals never qualifies) exceeds `k` in magnitude, the
    /// re-solved prediction `P` (which continues the history, as for the road rule) replaces
    /// `X` where its own residual is at most `k` and its road score is at least `X`'s and every
    /// alternative's, ties included, whether or not `X`'s own road reaches `min_matches`. A
    /// lead vehicle that follows the ego car through a curve explains a motion that turns less
    /// than the car and slides sideways to make up for it (at 1.2 m per frame 6-9 deg of side
    /// slip), which no car drives at speed, while the road cue ties (the lower half of the
    /// vehicle earns cells too). Not read with [`HypothesesOptions::predict_by_road_alternatives`].
    /// Off in `HypothesesOptions::default()`; the default
    /// configuration ([`crate::separate::SeparateOptions::competition_over_time`]) sets 6
    /// (0.06 rad with the soft single-track model's default sigma: along the KITTI
    /// trajectories 99.9 % of the frames estimated within 0.15 deg slide by less than 0.047 rad
    /// at 0.6 m per frame or more; docs/RESULTS.md §9, seventieth session, slip85).
    pub predict_by_slip: f64,
    /// With [`HypothesesOptions::predict_by_slip`]: where `X` slides by more than `k`, the
    /// alternatives formed this frame that continue the history (yaw within `J'` of `r`, tilt
    /// not jumping) and slide by at most `k` compete with `P` (itself sliding by at most `k`):
    /// the one with the highest road score (`P` first among equals) replaces `X` where that
    /// score is at least `X`'s and every other alternative's. At a lead vehicle's slide the
    /// static world's own fit is sometimes formed as an alternative with more road than the
    /// prediction, and the plain rule (the prediction against every alternative) then does
    /// not act. Off in `HypothesesOptions::default()` (`false`: `P` only); the default
    /// configuration ([`crate::separate::SeparateOptions::competition_over_time`]) sets it
    /// (docs/RESULTS.md §9, seventy-first session, slip86).
    pub predict_by_slip_alternatives: bool,
    /// The least median road score of the recent frames at which a scene shows a road at all,
    /// for [`HypothesisTracker::road_lost`] (`None`: [`HypothesesOptions::min_matches`]). Set
    /// only by [`crate::separate::SeparateOptions::for_matches`], which scales `min_matches`
    /// to the frame's matches but keeps this gate as written: scaled, a scene without a road
    /// reaches it by chance. Not a config field.
    #[serde(skip)]
    pub road_visible_min: Option<usize>,
}

/// The reference tilt of the recent frames ([`HypothesesOptions::tilt_reference`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TiltReference {
    /// The median of the last frames' tilts (the mean of the middle two for an even count).
    #[default]
    Median,
    /// The least of the last frames' tilts.
    Minimum,
}

impl Default for HypothesesOptions {
    fn default() -> Self {
        Self {
            enabled: true,
            parallax: 0.004,
            min_arc_length: 0.1,
            min_matches: 10,
            decay: 0.0,
            margin: 0.0,
            ground: true,
            ground_z: 0.0,
            ground_pitch: 0.0,
            ground_tolerance: 0.08,
            noise_angle: 0.0014,
            spread_grid: None,
            track_decay: 0.0,
            track_identity: 0.2,
            track_min_labelled: 20,
            track_hold: 0.0,
            road_span: 0.0,
            road_span_vouched: false,
            tilt_margin: 0.0,
            tilt_replace: false,
            tilt_replace_flattest: false,
            yaw_jump: 0.0,
            tilt_reference_frames: 0,
            tilt_reference_margin: 0.0,
            tilt_reference: TiltReference::Median,
            tilt_reference_contested: false,
            yaw_history_frames: 0,
            yaw_history_margin: 0.0,
            yaw_history_tie: 0.0,
            yaw_history_slow_margin: (0.0, 0.0),
            yaw_history_replace: false,
            yaw_history_final: false,
            tilt_replace_roadless: false,
            tilt_weak_road_frames: 0,
            yaw_history_predict: 0.0,
            yaw_history_predict_hold: false,
            yaw_history_predict_road_frames: 0,
            yaw_history_predict_road_drop: 0.4,
            tilt_predict: false,
            predict_by_road: 0.0,
            predict_by_road_ratio: 1.0,
            predict_by_road_prior: false,
            predict_by_road_alternatives: false,
            predict_by_slip: 0.0,
            predict_by_slip_alternatives: false,
            road_visible_min: None,
        }
    }
}

impl HypothesesOptions {
    /// The converse's candidates ([`HypothesesOptions::tilt_replace`]) that may replace A:
    /// `(road score, candidate, tilt)` of the alternatives flatter than A by the margin, all of
    /// them, or with [`HypothesesOptions::tilt_replace_flattest`] only those whose tilt is
    /// within [`HypothesesOptions::tilt_margin`] of the flattest one's (order kept).
    ///
    /// ```
    /// use momo_vo::hypotheses::HypothesesOptions;
    ///
    /// let on = HypothesesOptions { tilt_margin: 0.01, tilt_replace: true, tilt_replace_flattest: true, ..Default::default() };
    /// // A bus fit pitched 0.019 rad with one more road match than the static world's 0.002.
    /// let q = vec![(13, "bus", 0.019), (12, "static", 0.002), (3, "other", 0.011)];
    /// let kept: Vec<_> = on.flattest_within_margin(q.clone()).map(|(_, c, _)| c).collect();
    /// assert_eq!(kept, ["static", "other"]);
    /// let off = HypothesesOptions { tilt_replace_flattest: false, ..on };
    /// assert_eq!(off.flattest_within_margin(q).count(), 3);
    /// ```
    pub fn flattest_within_margin<T>(
        &self,
        qualified: Vec<(usize, T, f64)>,
    ) -> impl DoubleEndedIterator<Item = (usize, T, f64)> {
        let flattest = qualified.iter().map(|q| q.2).fold(f64::INFINITY, f64::min);
        let bound = if self.tilt_replace_flattest {
            flattest + self.tilt_margin
        } else {
            f64::INFINITY
        };
        qualified.into_iter().filter(move |q| q.2 <= bound)
    }

    /// Checks the options; the message names the first bad one.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.parallax.is_finite() && self.parallax > 0.0) {
            return Err("odometry.separate.hypotheses.parallax must be a positive number".into());
        }
        if !(self.min_arc_length.is_finite() && self.min_arc_length >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.min_arc_length must be a non-negative number".into(),
            );
        }
        if !(0.0..1.0).contains(&self.decay) {
            return Err("odometry.separate.hypotheses.decay must be in [0, 1)".into());
        }
        if !self.ground_z.is_finite() {
            return Err("odometry.separate.hypotheses.ground_z must be a finite number".into());
        }
        if !(self.ground_pitch.is_finite() && self.ground_pitch.abs() <= MAX_GROUND_PITCH) {
            return Err(format!(
                "odometry.separate.hypotheses.ground_pitch must be within ±{MAX_GROUND_PITCH} rad"
            ));
        }
        if !(self.ground_tolerance.is_finite() && self.ground_tolerance > 0.0) {
            return Err(
                "odometry.separate.hypotheses.ground_tolerance must be a positive number".into(),
            );
        }
        if !(self.noise_angle.is_finite() && self.noise_angle >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.noise_angle must be a non-negative number".into(),
            );
        }
        if let Some((c, r)) = self.spread_grid
            && (c == 0 || r == 0 || c.checked_mul(r).is_none_or(|n| n > 10_000))
        {
            return Err(
                "odometry.separate.hypotheses.spread_grid must be (columns, rows), 1 to 10000 cells"
                    .into(),
            );
        }
        if !self.margin.is_finite() {
            return Err("odometry.separate.hypotheses.margin must be a finite number".into());
        }
        if !(0.0..1.0).contains(&self.track_decay) {
            return Err("odometry.separate.hypotheses.track_decay must be in [0, 1)".into());
        }
        if !(self.track_identity > 0.0 && self.track_identity <= 1.0) {
            return Err("odometry.separate.hypotheses.track_identity must be in (0, 1]".into());
        }
        if !(self.road_span.is_finite() && self.road_span >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.road_span must be a finite number >= 0".into(),
            );
        }
        if !(self.tilt_margin.is_finite() && self.tilt_margin >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.tilt_margin must be a finite number >= 0".into(),
            );
        }
        if !(self.yaw_jump.is_finite() && self.yaw_jump >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.yaw_jump must be a finite number >= 0".into(),
            );
        }
        if !(self.yaw_history_predict.is_finite() && self.yaw_history_predict >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.yaw_history_predict must be a finite number >= 0"
                    .into(),
            );
        }
        if !(self.predict_by_road.is_finite() && self.predict_by_road >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.predict_by_road must be a finite number >= 0".into(),
            );
        }
        if !(self.predict_by_slip.is_finite() && self.predict_by_slip >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.predict_by_slip must be a finite number >= 0".into(),
            );
        }
        if !(self.predict_by_road_ratio.is_finite() && self.predict_by_road_ratio >= 1.0) {
            return Err(
                "odometry.separate.hypotheses.predict_by_road_ratio must be a finite number >= 1"
                    .into(),
            );
        }
        if !(self.yaw_history_margin.is_finite() && self.yaw_history_margin >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.yaw_history_margin must be a finite number >= 0"
                    .into(),
            );
        }
        if !(self.yaw_history_tie.is_finite() && (0.0..=1.0).contains(&self.yaw_history_tie)) {
            return Err(
                "odometry.separate.hypotheses.yaw_history_tie must be a number in [0, 1]".into(),
            );
        }
        let (m0, k) = self.yaw_history_slow_margin;
        if !(m0.is_finite() && m0 >= 0.0 && k.is_finite() && k >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.yaw_history_slow_margin must be two finite numbers >= 0"
                    .into(),
            );
        }
        if !(self.tilt_reference_margin.is_finite() && self.tilt_reference_margin >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.tilt_reference_margin must be a finite number >= 0"
                    .into(),
            );
        }
        if self.tilt_weak_road_frames > 1000 {
            return Err(
                "odometry.separate.hypotheses.tilt_weak_road_frames must be at most 1000".into(),
            );
        }
        if self.yaw_history_predict_road_frames > 1000 {
            return Err(
                "odometry.separate.hypotheses.yaw_history_predict_road_frames must be at most 1000"
                    .into(),
            );
        }
        if !(self.yaw_history_predict_road_drop > 0.0 && self.yaw_history_predict_road_drop <= 1.0)
        {
            return Err(
                "odometry.separate.hypotheses.yaw_history_predict_road_drop must be in (0, 1]"
                    .into(),
            );
        }
        if self.tilt_reference_frames > 1000 {
            return Err(
                "odometry.separate.hypotheses.tilt_reference_frames must be at most 1000".into(),
            );
        }
        if !(self.track_hold.is_finite() && self.track_hold >= 0.0) {
            return Err(
                "odometry.separate.hypotheses.track_hold must be a finite number >= 0".into(),
            );
        }
        Ok(())
    }
}

/// One competing motion: the vehicle motion and its support mask (per camera, per match).
pub struct Hypothesis<'a> {
    /// The vehicle motion.
    pub motion: Pose<f64>,
    /// Its support (per camera, per match).
    pub support: &'a [Vec<bool>],
}

/// The reference yaw's standard deviations added (in quadrature) to the dynamic part of
/// [`HypothesesOptions::yaw_history_slow_margin`].
const SLOW_MARGIN_SIGMAS: f64 = 3.0;

/// The state of the multi-frame choice (the accumulated evidence), kept by the odometry driver.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HypothesisTracker {
    /// Accumulated evidence that the alternative motion beats the continued one.
    evidence: f64,
    /// [`HypothesesOptions::track_decay`]: the decayed score sums over the run of (the
    /// previous frame's chosen track, its other track).
    run: Option<(f64, f64)>,
    /// This frame's sums of (A's track, B's track), kept by [`HypothesisTracker::choose`] until
    /// [`HypothesisTracker::settle`] knows the frame's choice.
    pending: Option<(f64, f64)>,
    /// Whether a chosen track's road-score sum has reached `min_matches` since the start
    /// ([`HypothesesOptions::road_span_vouched`]).
    vouched: bool,
    /// The previous frame pair's labelled matches (`odometry.separate.memory_radius`).
    pub memory: MatchMemory,
    /// The road track's start for the next frame (`odometry.separate.road_track`,
    /// [`crate::road_track`]); `None`: the previous chosen motion.
    pub road_track: Option<Vec<f64>>,
    /// The recent frames' chosen motions' road scores (`odometry.separate.ground_drop`,
    /// [`crate::ground_drop`]).
    pub ground_scores: std::collections::VecDeque<usize>,
    /// The recent frames' chosen motions' tilts, newest last
    /// ([`HypothesesOptions::tilt_reference_frames`]).
    tilts: std::collections::VecDeque<f64>,
    /// Whether two motions competed on each of the recent frames, newest last
    /// ([`HypothesesOptions::tilt_reference_contested`]).
    contested: std::collections::VecDeque<bool>,
    /// The recent frames' chosen motions' yaws, newest last
    /// ([`HypothesesOptions::yaw_history_frames`]), each with its standard deviation where
    /// known ([`HypothesisTracker::set_last_yaw_sigma`]).
    yaws: std::collections::VecDeque<(f64, Option<f64>)>,
    /// The recent frames' chosen motions' road scores, newest last
    /// ([`HypothesesOptions::yaw_history_predict_road_frames`]).
    road_scores: std::collections::VecDeque<usize>,
    /// The current frame's arc length (metres, from odometry), for
    /// [`HypothesesOptions::yaw_history_slow_margin`]; set by [`crate::separate::separate`].
    pub arc_length: Option<f64>,
}

/// Per-match memory across frames by image position (issue 14): the second-image pixels
/// (image k) of the previous frame pair's matches, per camera, each labelled static (in the
/// chosen motion's support) or other. The current pair's first-image pixels are in the same
/// image k, so a current match takes the label of its nearest previous match in the same camera
/// ([`MatchMemory::labels`]). On real data a track shares the feature; on the simulator's
/// (matches drawn anew per frame pair) the objects are spatially coherent, so the nearest
/// neighbour in the image usually belongs to the same object or to the static world.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MatchMemory {
    /// Per camera: (column, row) of the previous pair's second-image pixel, and static.
    per_camera: Vec<Vec<(f64, f64, bool)>>,
}

impl MatchMemory {
    /// The memory of a frame pair's matches labelled by `is_static` (per camera, per match).
    pub fn record(obs: &FrameObservations, is_static: &[Vec<bool>]) -> Self {
        Self {
            per_camera: obs
                .per_camera
                .iter()
                .zip(is_static)
                .map(|(m, s)| {
                    m.iter()
                        .zip(s)
                        .map(|(o, s)| (o.px1.x, o.px1.y, *s))
                        .collect()
                })
                .collect(),
        }
    }

    /// Whether nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.per_camera.iter().all(Vec::is_empty)
    }

    /// The share of the remembered matches labelled other (not static); 0 where nothing is
    /// remembered.
    pub fn other_share(&self) -> f64 {
        let (n, other) = self
            .per_camera
            .iter()
            .flatten()
            .fold((0usize, 0usize), |(n, o), p| (n + 1, o + usize::from(!p.2)));
        if n == 0 { 0.0 } else { other as f64 / n as f64 }
    }

    /// The label (`Some(true)`: static) of each match of `obs` (per camera, per match): that of
    /// the nearest remembered match of the same camera to its first-image pixel, if one lies
    /// within `radius` pixels; `None` elsewhere. `None` overall if nothing is remembered or the
    /// camera count differs.
    pub fn labels(&self, obs: &FrameObservations, radius: f64) -> Option<Vec<Vec<Option<bool>>>> {
        if self.is_empty()
            || self.per_camera.len() != obs.per_camera.len()
            || !(radius.is_finite() && radius > 0.0)
        {
            return None;
        }
        let mut grid = CellGrid::default();
        Some(
            self.per_camera
                .iter()
                .zip(&obs.per_camera)
                .map(|(prev, cur)| {
                    // Cells of `radius` pixels: the nearest neighbour within `radius` lies in
                    // the 3 x 3 cells around a point's own.
                    grid.fill(prev, radius);
                    cur.iter()
                        .map(|o| grid.nearest(prev, o.px0.x, o.px0.y, radius))
                        .collect()
                })
                .collect(),
        )
    }
}

/// The cell of a pixel in the match memory's grid of `radius`-pixel cells (the float-to-integer
/// cast saturates: far-off pixels share the extreme cells).
fn cell_key(x: f64, y: f64, radius: f64) -> (i64, i64) {
    (floor_i64(x / radius), floor_i64(y / radius))
}

/// `q.floor() as i64` without the library call `floor` (the baseline x86-64 target has no
/// rounding instruction; issue 19): the cast truncates toward zero and saturates (NaN: 0), one
/// less where that rounded a negative non-integer up. Where the cast saturates at `i64::MIN`
/// (`q < -2^63`) the subtraction saturates too; wherever the cast is exact, `t as f64` is too
/// (`|t| < 2^53`, or `q` an integer), so the comparison is exact.
#[inline]
fn floor_i64(q: f64) -> i64 {
    let t = q as i64;
    if (t as f64) > q {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// Cells larger than this (and than [`DENSE_CELLS_PER_POINT`] per remembered match) over the
/// remembered matches' bounding box are looked up in a sorted list instead of a dense grid.
const DENSE_MIN_CELLS: u64 = 4096;
/// See [`DENSE_MIN_CELLS`].
const DENSE_CELLS_PER_POINT: u64 = 16;

/// The remembered matches of one camera bucketed by cell (issue 19: a flat grid built per
/// frame by a counting sort, in place of a hash map of cells). Within a cell the matches keep
/// their order, and [`CellGrid::nearest`] visits the 3 x 3 cells in the same order as the hash
/// map it replaces (column offset outer, row offset inner, wrapping like the release build's
/// `i64` addition), so ties between equally near matches are broken the same way.
#[derive(Default)]
struct CellGrid {
    /// The remembered matches' indices ordered by cell (and by index within a cell).
    order: Vec<u32>,
    /// Dense grid: `start[c]..start[c + 1]` is cell `c`'s range of `order`, cells numbered
    /// column-major over the bounding box `[min.0, min.0 + cols) x [min.1, min.1 + rows)`.
    start: Vec<u32>,
    /// The bounding box's lowest cell.
    min: (i64, i64),
    /// The bounding box's columns and rows (0 when nothing is remembered).
    cols: u64,
    /// See `cols`.
    rows: u64,
    /// Sparse fallback (a bounding box too large for a dense grid): the cell of each entry of
    /// `order`, sorted.
    keys: Vec<(i64, i64)>,
    /// Whether the sparse fallback holds the matches.
    sparse: bool,
    /// Scratch of [`CellGrid::fill`]: each finite remembered match's cell and index, its cell
    /// computed once.
    points: Vec<((i64, i64), u32)>,
}

impl CellGrid {
    /// Buckets the finite second-image pixels of `prev` into cells of `radius` pixels.
    fn fill(&mut self, prev: &[(f64, f64, bool)], radius: f64) {
        self.order.clear();
        self.start.clear();
        self.keys.clear();
        self.cols = 0;
        self.rows = 0;
        self.sparse = false;
        self.points.clear();
        self.points.extend(
            prev.iter()
                .enumerate()
                .filter(|(_, p)| p.0.is_finite() && p.1.is_finite())
                .map(|(i, p)| (cell_key(p.0, p.1, radius), i as u32)),
        );
        let mut bounds: Option<((i64, i64), (i64, i64))> = None;
        let n = self.points.len() as u64;
        for &(k, _) in &self.points {
            bounds = Some(match bounds {
                None => (k, k),
                Some((lo, hi)) => (
                    (lo.0.min(k.0), lo.1.min(k.1)),
                    (hi.0.max(k.0), hi.1.max(k.1)),
                ),
            });
        }
        let Some((lo, hi)) = bounds else { return };
        // Widths in i128: the saturated extremes span the whole i64 range.
        let cols = (i128::from(hi.0) - i128::from(lo.0) + 1) as u128;
        let rows = (i128::from(hi.1) - i128::from(lo.1) + 1) as u128;
        let limit = DENSE_MIN_CELLS.max(DENSE_CELLS_PER_POINT * n);
        if prev.len() >= u32::MAX as usize || cols.saturating_mul(rows) > u128::from(limit) {
            // Sparse: sort by cell, then index (the same order within a cell).
            self.sparse = true;
            self.points.sort_unstable();
            self.keys.extend(self.points.iter().map(|e| e.0));
            self.order.extend(self.points.iter().map(|e| e.1));
            return;
        }
        // Dense: counting sort of the indices by cell.
        self.min = lo;
        self.cols = cols as u64;
        self.rows = rows as u64;
        let cells = (cols * rows) as usize;
        self.start.resize(cells + 1, 0);
        let cell = |k: (i64, i64), rows: u64| -> usize {
            ((k.0.wrapping_sub(lo.0) as u64) * rows + (k.1.wrapping_sub(lo.1) as u64)) as usize
        };
        for &(k, _) in &self.points {
            self.start[cell(k, self.rows) + 1] += 1;
        }
        for c in 0..cells {
            self.start[c + 1] += self.start[c];
        }
        self.order.resize(n as usize, 0);
        // `start[c]` is advanced as cell `c` fills; shifted back afterwards.
        for &(k, i) in &self.points {
            let c = cell(k, self.rows);
            self.order[self.start[c] as usize] = i;
            self.start[c] += 1;
        }
        for c in (1..=cells).rev() {
            self.start[c] = self.start[c - 1];
        }
        self.start[0] = 0;
    }

    /// The remembered indices in cell `k`, in index order.
    fn cell(&self, k: (i64, i64)) -> &[u32] {
        if self.sparse {
            let a = self.keys.partition_point(|e| *e < k);
            let b = a + self.keys[a..].partition_point(|e| *e == k);
            return &self.order[a..b];
        }
        let (dx, dy) = (
            i128::from(k.0) - i128::from(self.min.0),
            i128::from(k.1) - i128::from(self.min.1),
        );
        if dx < 0 || dy < 0 || dx >= i128::from(self.cols) || dy >= i128::from(self.rows) {
            return &[];
        }
        let c = (dx as u64 * self.rows + dy as u64) as usize;
        &self.order[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// The label of the nearest remembered match (of `prev`, as filled) within `radius` pixels
    /// of `(x, y)`; of equally near ones the first visited.
    fn nearest(&self, prev: &[(f64, f64, bool)], x: f64, y: f64, radius: f64) -> Option<bool> {
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let (kx, ky) = cell_key(x, y, radius);
        let mut best: Option<(f64, bool)> = None;
        let mut visit = |ids: &[u32]| {
            for &i in ids {
                let p = prev[i as usize];
                let d = (p.0 - x).powi(2) + (p.1 - y).powi(2);
                if d <= radius * radius && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, p.2));
                }
            }
        };
        for dx in -1..=1_i64 {
            let cx = kx.wrapping_add(dx);
            match self.column_run(cx, ky) {
                // The three cells of the column in one run of `order`, in the same order.
                Some(ids) => visit(ids),
                None => {
                    for dy in -1..=1_i64 {
                        visit(self.cell((cx, ky.wrapping_add(dy))));
                    }
                }
            }
        }
        best.map(|(_, s)| s)
    }

    /// Dense grid only, rows `ky - 1 ..= ky + 1` not wrapping around `i64`: the remembered
    /// indices of the cells `(cx, ky - 1)`, `(cx, ky)`, `(cx, ky + 1)` as one slice of `order`
    /// (cells are numbered column-major, so a column's consecutive rows are consecutive ranges:
    /// the slice visits them in the order of three [`CellGrid::cell`] calls); `None` where the
    /// cells must be looked up one by one (sparse grid, wrapping rows).
    #[inline]
    fn column_run(&self, cx: i64, ky: i64) -> Option<&[u32]> {
        if self.sparse || ky == i64::MIN || ky == i64::MAX {
            return None;
        }
        // In range of the dense box: `rows` and `cols` are at most `u32::MAX`-ish (the grid
        // holds at most `DENSE_CELLS_PER_POINT` cells per match), so these fit in `i128`.
        let dx = i128::from(cx) - i128::from(self.min.0);
        if dx < 0 || dx >= i128::from(self.cols) {
            return Some(&[]);
        }
        let rows = i128::from(self.rows);
        let lo = (i128::from(ky) - 1 - i128::from(self.min.1)).max(0);
        let hi = (i128::from(ky) + 2 - i128::from(self.min.1)).min(rows);
        if lo >= hi {
            return Some(&[]);
        }
        let base = dx as usize * self.rows as usize;
        let (a, b) = (base + lo as usize, base + hi as usize);
        Some(&self.order[self.start[a] as usize..self.start[b] as usize])
    }
}

/// The parallax support of a motion (see the module doc): the matches of `support` whose
/// derotated bearing moved away from the motion's epipole by at least `min_angle` radians.
/// Matches of cameras whose translation is (numerically) zero do not count.
pub fn parallax_support(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    min_angle: f64,
) -> usize {
    parallax_mask(rig, motion, obs, support, min_angle)
        .iter()
        .flatten()
        .filter(|p| **p)
        .count()
}

/// The matches of [`parallax_support`] as a mask (per camera, per match).
pub fn parallax_mask(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    min_angle: f64,
) -> Vec<Vec<bool>> {
    let mut out: Vec<Vec<bool>> = obs
        .per_camera
        .iter()
        .map(|m| vec![false; m.len()])
        .collect();
    for (((cam, matches), mask), out) in rig
        .cameras()
        .iter()
        .zip(&obs.per_camera)
        .zip(support)
        .zip(&mut out)
    {
        let c = camera_motion(motion, &cam.t_vehicle_camera);
        let t = c.translation;
        let tn = t.norm();
        if !(tn > 1e-12) {
            continue;
        }
        let t = t / tn;
        for ((o, _), p_out) in matches
            .iter()
            .zip(mask)
            .zip(out.iter_mut())
            .filter(|((_, k), _)| **k)
        {
            let rf1 = c.rotation * o.f1;
            let away = t.cross(&o.f0);
            let a = away.norm();
            if a < 1e-9 {
                continue;
            }
            let p = o.f0.cross(&rf1).dot(&away) / a;
            *p_out = p >= min_angle;
        }
    }
    out
}

/// The ground support of a motion (see the module doc): the matches of `support` with at least
/// `opts.parallax / 2` radians of parallax whose triangulated point (the motion's translation
/// taken at its scale, i.e. the odometry arc length) lies on the road plane `z = opts.ground_z`
/// of the vehicle frame at frame k-1. Cameras less than 0.2 m above the road do not count.
pub fn ground_support(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    opts: &HypothesesOptions,
) -> usize {
    ground_mask(rig, motion, obs, support, opts)
        .iter()
        .flatten()
        .filter(|g| **g)
        .count()
}

/// The matches of [`ground_support`] as a mask (per camera, per match).
pub fn ground_mask(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    opts: &HypothesesOptions,
) -> Vec<Vec<bool>> {
    road_mask(
        rig,
        motion,
        obs,
        support,
        (opts.ground_z, opts.ground_pitch, 1e-9),
        |cam, o| road_point(cam, o, opts).is_some(),
    )
}

/// [`ground_support`] of each of `motions`, the motions of one model at the increasing arc
/// lengths `arc_lengths` (the same length): equal to calling it once per motion, at a fraction
/// of the cost where the motions share their rotation and their translation is affine in the
/// arc length (`t(l) = t₀ + l u`, every model whose rotation does not depend on the arc length).
/// Then a camera's translation is affine in `l` too, and so is a match's triangulated height
/// above the road (its range `z0` is linear in the camera's translation): the height can lie
/// within the tolerance of [`ground_mask`] (at most `max(ground_tolerance, 4 h σ / parallax)`,
/// below `h / 2`) only on one interval of arc lengths, and the exact test runs only at the arc
/// lengths in it (one more on either side against rounding). Motions that are not of that form
/// take the test at every arc length.
pub fn ground_support_over(
    rig: &Rig,
    arc_lengths: &[f64],
    motions: &[Pose<f64>],
    obs: &FrameObservations,
    support: &[Vec<bool>],
    opts: &HypothesesOptions,
) -> Vec<usize> {
    let every = || {
        motions
            .iter()
            .map(|m| ground_support(rig, m, obs, support, opts))
            .collect::<Vec<_>>()
    };
    let n = motions.len();
    if n < 3 || arc_lengths.len() != n {
        return every();
    }
    let (l0, l1) = (arc_lengths[0], arc_lengths[n - 1]);
    let (m0, m1) = (&motions[0], &motions[n - 1]);
    if !(l1 > l0) {
        return every();
    }
    let u = (m1.translation - m0.translation) / (l1 - l0);
    let t0 = m0.translation - u * l0;
    let affine = arc_lengths.iter().zip(motions).all(|(l, m)| {
        m.rotation == m0.rotation
            && (m.translation - (t0 + u * *l)).norm() <= 1e-9 * (1.0 + m.translation.norm())
    });
    if !affine {
        return every();
    }
    let mut counts = vec![0_usize; n];
    for ((cam, matches), mask) in rig.cameras().iter().zip(&obs.per_camera).zip(support) {
        let mount = &cam.t_vehicle_camera;
        let height = mount.translation.z - opts.ground_z;
        if !(height > 0.2) {
            continue;
        }
        // The camera's motion at each arc length, and its translation's affine form.
        let tan_pitch = opts.ground_pitch.tan();
        let cams: Vec<Option<RoadCamera<'_>>> = motions
            .iter()
            .map(|m| RoadCamera::under(m, mount, height, tan_pitch, 1e-9))
            .collect();
        let c0 = camera_motion(&Pose::new(m0.rotation, t0), mount);
        let cu = mount.rotation.transpose() * u;
        let rotation = c0.rotation;
        let reach = if opts.parallax > 0.0 {
            opts.ground_tolerance
                .max(4.0 * height * opts.noise_angle / opts.parallax)
                .min(0.5 * height)
        } else {
            0.5 * height
        };
        for (o, _) in matches.iter().zip(mask).filter(|(_, k)| **k) {
            // The height above the road at arc length l, z(l) = a + b l (see road_point).
            let rf1 = rotation * o.f1;
            let a12 = -o.f0.dot(&rf1);
            let det = 1.0 - a12 * a12;
            if det.abs() < 1e-12 {
                continue;
            }
            let w = (o.f0 + rf1 * a12) / det;
            // The bearing's rise above the (pitched) road per unit range.
            let v = mount.rotation * o.f0;
            let up = v.z - tan_pitch * v.x;
            let a = up * w.dot(&c0.translation) + mount.translation.z - opts.ground_z;
            let b = up * w.dot(&cu);
            // |a + b l| < reach.
            let (lo, hi) = if b.abs() > 0.0 {
                let (x, y) = ((-reach - a) / b, (reach - a) / b);
                (x.min(y), x.max(y))
            } else if a.abs() < reach {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                continue;
            };
            let first = arc_lengths.partition_point(|l| *l < lo).saturating_sub(1);
            let last = arc_lengths.partition_point(|l| *l <= hi).min(n - 1);
            for k in first..=last {
                if let Some(cam) = &cams[k]
                    && road_point(cam, o, opts).is_some()
                {
                    counts[k] += 1;
                }
            }
        }
    }
    counts
}

/// The arc length at which the road's counts `counts` (of [`ground_support_over`] at the
/// increasing `arc_lengths`) put the road (`odometry.road_scale_frames`): the geometric mean of
/// the contiguous run of arc lengths around the best count (the shortest of equal ones) that
/// count at least 80 % of it. `None` where the best count is below `min_matches`.
pub fn road_arc_length(arc_lengths: &[f64], counts: &[usize], min_matches: usize) -> Option<f64> {
    let (best, &top) = counts
        .iter()
        .enumerate()
        .max_by_key(|(k, c)| (**c, std::cmp::Reverse(*k)))?;
    if top < min_matches || arc_lengths.len() != counts.len() {
        return None;
    }
    let near = |k: &usize| 5 * counts[*k] >= 4 * top;
    let first = (0..=best).rev().take_while(near).last().unwrap_or(best);
    let last = (best..counts.len()).take_while(near).last().unwrap_or(best);
    Some((arc_lengths[first] * arc_lengths[last]).sqrt())
}

/// The range `z0` (along the unit bearing `f0`, metres at the motion's scale) of a match
/// triangulated under the camera's motion if it is a road point of [`ground_mask`]: at least
/// `opts.parallax / 2` radians of derotated parallax, in front of the camera, and on the road
/// plane `z = opts.ground_z` of the vehicle frame within `max(ground_tolerance, 2 h σ / p)`.
fn road_point(
    cam: &RoadCamera<'_>,
    o: &momo_core::Observation,
    opts: &HypothesesOptions,
) -> Option<f64> {
    let (c, t, p_vc, height) = (&cam.motion, &cam.motion.translation, cam.mount, cam.height);
    let rf1 = c.rotation * o.f1;
    let away = cam.direction.cross(&o.f0);
    let a = away.norm();
    if a < 1e-9 {
        return None;
    }
    let p = o.f0.cross(&rf1).dot(&away) / a;
    if p < 0.5 * opts.parallax {
        return None;
    }
    // z0 f0 - z1 R f1 = t in the least-squares sense (2 x 2 normal equations).
    let (a11, a12, a22) = (1.0, -o.f0.dot(&rf1), 1.0);
    let (b1, b2) = (o.f0.dot(t), -rf1.dot(t));
    let det = a11 * a22 - a12 * a12;
    if det.abs() < 1e-12 {
        return None;
    }
    let z0 = (b1 * a22 - a12 * b2) / det;
    if !(z0 > 0.0) {
        return None;
    }
    let x_v = p_vc.rotation * (o.f0 * z0) + p_vc.translation;
    let above = x_v.z - opts.ground_z - cam.tan_pitch * (x_v.x - p_vc.translation.x);
    let tol = opts
        .ground_tolerance
        .max(2.0 * height * opts.noise_angle / p);
    (tol < 0.5 * height && above.abs() < tol).then_some(z0)
}

/// The tilt of a vehicle-frame motion ([`HypothesesOptions::tilt_margin`]): the norm of the
/// roll and pitch components `(ω_x, ω_y)` of its rotation vector `ω = log R` (radians; vehicle
/// frame x forward, y left, z up, so the yaw `ω_z` is left out).
pub fn tilt(motion: &Pose<f64>) -> f64 {
    let w = momo_core::so3_log(&motion.rotation);
    w.x.hypot(w.y)
}

/// The depth span of a motion's road support ([`HypothesesOptions::road_span`]): over the
/// matches of [`ground_mask`], the ratio `Z_max / Z_min` of the triangulated road points'
/// depths along their camera's optical axis, `Z = z0 f0_z` (`z0` the range along the unit
/// bearing `f0`; bearings at or behind the image plane, `f0_z <= 0`, do not count). On a flat
/// road seen by a pinhole camera with a level optical axis, `Z = h f / (v − c_y)` (`h` the
/// camera's height, `v` the image row): the span is the ratio of the rows' distances below the
/// horizon. None with fewer than two such points.
pub fn road_depth_span(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    opts: &HypothesesOptions,
) -> Option<f64> {
    let (mut lo, mut hi, mut n) = (f64::INFINITY, 0.0_f64, 0_usize);
    road_mask(
        rig,
        motion,
        obs,
        support,
        (opts.ground_z, opts.ground_pitch, 1e-9),
        |cam, o| {
            let z = road_point(cam, o, opts).map(|z0| z0 * o.f0.z / o.f0.norm());
            if let Some(z) = z.filter(|z| *z > 0.0) {
                lo = lo.min(z);
                hi = hi.max(z);
                n += 1;
            }
            false
        },
    );
    (n >= 2).then(|| hi / lo)
}

/// A camera of [`road_mask`]: its mount, its motion, the unit direction and length of its
/// translation, its height above the road and the road's rise per metre ahead
/// ([`HypothesesOptions::ground_pitch`]).
struct RoadCamera<'a> {
    mount: &'a Pose<f64>,
    motion: Pose<f64>,
    direction: nalgebra::Vector3<f64>,
    travel: f64,
    height: f64,
    tan_pitch: f64,
}

impl<'a> RoadCamera<'a> {
    /// The camera at `mount`, `height` above a road that rises by `tan_pitch` per metre
    /// ahead, under the vehicle motion `motion`; `None` where it moved no more than
    /// `min_travel` (metres).
    fn under(
        motion: &Pose<f64>,
        mount: &'a Pose<f64>,
        height: f64,
        tan_pitch: f64,
        min_travel: f64,
    ) -> Option<Self> {
        let c = camera_motion(motion, mount);
        let travel = c.translation.norm();
        (travel > min_travel).then(|| RoadCamera {
            mount,
            direction: c.translation / travel,
            motion: c,
            travel,
            height,
            tan_pitch,
        })
    }
}

/// The mask (per camera, per match) of the supported matches for which `test` holds, on the
/// cameras more than 0.2 m above the road (`ground_z`, pitched by `ground_pitch`) that moved
/// more than `min_travel` (metres) under `motion`; every other match is `false`.
fn road_mask(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    (ground_z, ground_pitch, min_travel): (f64, f64, f64),
    mut test: impl FnMut(&RoadCamera<'_>, &momo_core::Observation) -> bool,
) -> Vec<Vec<bool>> {
    let mut out: Vec<Vec<bool>> = obs
        .per_camera
        .iter()
        .map(|m| vec![false; m.len()])
        .collect();
    for (((cam, matches), mask), out) in rig
        .cameras()
        .iter()
        .zip(&obs.per_camera)
        .zip(support)
        .zip(&mut out)
    {
        let mount = &cam.t_vehicle_camera;
        let height = mount.translation.z - ground_z;
        if !(height > 0.2) {
            continue;
        }
        let Some(road) = RoadCamera::under(motion, mount, height, ground_pitch.tan(), min_travel)
        else {
            continue;
        };
        for ((o, _), flag) in matches
            .iter()
            .zip(mask)
            .zip(out.iter_mut())
            .filter(|((_, k), _)| **k)
        {
            *flag = test(&road, o);
        }
    }
    out
}

/// The parameters of [`under_road_mask`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnderRoad {
    /// Height of the road in the vehicle frame, metres.
    pub ground_z: f64,
    /// Pitch of the road against the vehicle frame, radians
    /// ([`HypothesesOptions::ground_pitch`]).
    pub ground_pitch: f64,
    /// Standard deviation of a bearing's angle, radians.
    pub noise_angle: f64,
    /// A match is flagged when its inverse range falls short of the road's by more than this
    /// many standard deviations of its parallax noise.
    pub sigmas: f64,
    /// The road may descend away from the vehicle by this slope (radians): the bound on a
    /// ray's range is that of a road tilted down by it.
    pub slope: f64,
}

/// The matches of `support` that cannot be static points on or above the road (issue 14): a
/// static point seen below the horizon lies no farther than the road plane `z = ground_z` of
/// the vehicle frame at frame k-1 allows along its ray (`h / (sin α - slope)`, `h` the camera's
/// height above the road, `α` the ray's angle below the horizon). Its inverse range from the
/// derotated parallax under `motion` (metric: the motion's translation at the odometry arc
/// length), `1/z0 = p / (‖t‖ sin θ)` (`θ` the angle between the bearing and the translation),
/// has the standard deviation `√2 σ / (‖t‖ sin θ)` (`σ` the bearing noise on both bearings); a
/// match whose inverse range is below the road's by more than `sigmas` of them is flagged: an
/// object moving with the ego vehicle (no parallax, so an infinite range below the horizon),
/// or a mismatch. Rays at or above the horizon (within the slope) and cameras less than 0.2 m
/// above the road are never flagged.
pub fn under_road_mask(
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
    opts: &UnderRoad,
) -> Vec<Vec<bool>> {
    road_mask(
        rig,
        motion,
        obs,
        support,
        (opts.ground_z, opts.ground_pitch, 1e-6),
        |cam, o| {
            // Sine of the ray's angle below the (pitched) road's horizon, less the slope
            // margin: the road lies `h / down` along the ray.
            let v = cam.mount.rotation * o.f0;
            let down = -(v.z - cam.tan_pitch * v.x) / o.f0.norm() - opts.slope;
            if !(down > 1e-6) {
                return false;
            }
            let away = cam.direction.cross(&o.f0);
            let a = away.norm();
            let rf1 = cam.motion.rotation * o.f1;
            // The sine of the angle at frame k between the ray and the translation: by the law
            // of sines the parallax over it is the range from frame k-1 (over the bearing's
            // own angle it would be the range from frame k, which a camera moving away from
            // the scene, a rear one, reads far larger).
            let a1 = cam.direction.cross(&rf1).norm();
            if a < 1e-9 || a1 < 1e-9 {
                return false;
            }
            let p = o.f0.cross(&rf1).dot(&away) / a;
            let inverse = p / (cam.travel * a1);
            let sigma = std::f64::consts::SQRT_2 * opts.noise_angle / (cam.travel * a1);
            down / cam.height - inverse > opts.sigmas * sigma
        },
    )
}

/// A motion's score for the choice: its ground support if [`HypothesesOptions::ground`], else
/// its parallax support; with [`HypothesesOptions::spread_grid`] the image cells that support
/// covers rather than its count.
pub fn score(
    opts: &HypothesesOptions,
    rig: &Rig,
    motion: &Pose<f64>,
    obs: &FrameObservations,
    support: &[Vec<bool>],
) -> usize {
    match (opts.ground, opts.spread_grid) {
        (true, None) => ground_support(rig, motion, obs, support, opts),
        (false, None) => parallax_support(rig, motion, obs, support, opts.parallax),
        (ground, Some(grid)) => {
            let mask = if ground {
                ground_mask(rig, motion, obs, support, opts)
            } else {
                parallax_mask(rig, motion, obs, support, opts.parallax)
            };
            crate::separate::cells(rig, obs, &mask, grid)
        }
    }
}

impl HypothesisTracker {
    /// A frame without two competing motions: the evidence decays.
    pub fn idle(&mut self, opts: &HypothesesOptions) {
        self.evidence *= opts.decay;
        let d = opts.track_decay;
        self.run = self.run.map(|(c, o)| (d * c, d * o));
        self.pending = None;
    }

    /// Forgets the evidence, the match memory and the recent frames' histories (a reset of the
    /// driver).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Replaces the last recorded tilt, yaw and road score by those of the motion that replaced
    /// the frame's choice after the separation (`odometry.decide_by_road`); each only where one
    /// was recorded.
    pub(crate) fn replace_last(
        &mut self,
        opts: &HypothesesOptions,
        tilt: f64,
        yaw: f64,
        road: usize,
    ) {
        if self.tilts.pop_back().is_some() {
            self.record_tilt(opts, tilt);
        }
        if self.yaws.pop_back().is_some() {
            self.record_yaw(opts, yaw);
        }
        if self.road_scores.pop_back().is_some() {
            self.record_road(opts, road);
        }
    }

    /// Records a frame's chosen motion's [`tilt`], keeping the last
    /// [`HypothesesOptions::tilt_reference_frames`] (nothing where that is 0; a non-finite
    /// tilt is not recorded).
    pub fn record_tilt(&mut self, opts: &HypothesesOptions, tilt: f64) {
        let k = opts.tilt_reference_frames.max(opts.tilt_weak_road_frames);
        if k == 0 || !tilt.is_finite() {
            return;
        }
        self.tilts.push_back(tilt);
        while self.tilts.len() > k {
            self.tilts.pop_front();
        }
    }

    /// Records whether two motions competed on a frame (the separation's `competing`), keeping
    /// the last [`HypothesesOptions::tilt_reference_frames`] (nothing unless
    /// [`HypothesesOptions::tilt_reference_contested`]).
    pub fn record_contested(&mut self, opts: &HypothesesOptions, competing: bool) {
        if !opts.tilt_reference_contested || opts.tilt_reference_frames == 0 {
            return;
        }
        self.contested.push_back(competing);
        while self.contested.len() > opts.tilt_reference_frames {
            self.contested.pop_front();
        }
    }

    /// The reference tilt of the recorded frames ([`HypothesesOptions::tilt_reference`]):
    /// their median or their minimum; `None` before any frame was recorded. With
    /// [`HypothesesOptions::tilt_reference_contested`] the previous frame's tilt where no
    /// recorded frame had two motions compete.
    pub fn tilt_reference(&self, opts: &HypothesesOptions) -> Option<f64> {
        // The last `K` of the recorded tilts (more are kept for `tilt_weak_road_frames`).
        let contested = !opts.tilt_reference_contested || self.contested.contains(&true);
        let frames = if contested {
            opts.tilt_reference_frames
        } else {
            opts.tilt_reference_frames.min(1)
        };
        let k = frames.min(self.tilts.len());
        let tilts = self.tilts.iter().skip(self.tilts.len() - k).copied();
        match opts.tilt_reference {
            TiltReference::Minimum => crate::stats::minimum(tilts),
            TiltReference::Median => crate::stats::median(tilts),
        }
    }

    /// Records a frame's chosen motion's yaw `ω_z`, keeping the last
    /// [`HypothesesOptions::yaw_history_frames`] (nothing where that is 0; a non-finite yaw is
    /// not recorded).
    pub fn record_yaw(&mut self, opts: &HypothesesOptions, yaw: f64) {
        let k = opts.yaw_history_frames;
        if k == 0 || !yaw.is_finite() {
            return;
        }
        self.yaws.push_back((yaw, None));
        while self.yaws.len() > k {
            self.yaws.pop_front();
        }
    }

    /// Sets the standard deviation (radians) of the last recorded yaw: the frame's reported
    /// covariance propagated to `ω_z`, for [`HypothesesOptions::yaw_history_slow_margin`].
    /// A yaw recorded without one (or with a non-finite one) has an unknown sigma, and the
    /// slow margin does not apply while it is in the history.
    pub fn set_last_yaw_sigma(&mut self, sigma: f64) {
        if let Some((_, s)) = self.yaws.back_mut() {
            *s = sigma.is_finite().then_some(sigma);
        }
    }

    /// Replaces the last recorded yaw ([`HypothesisTracker::record_yaw`]) by `yaw`
    /// ([`HypothesesOptions::yaw_history_final`]: the frame's reported motion's yaw); nothing
    /// where no yaw is recorded or `yaw` is not finite. In a frame where the separation recorded
    /// no yaw of its own the previous frame's entry is the one replaced: with
    /// `yaw_history_frames = 1` (the default) that is the same as recording the frame's yaw.
    pub fn set_last_yaw(&mut self, opts: &HypothesesOptions, yaw: f64) {
        if yaw.is_finite() && self.yaws.pop_back().is_some() {
            self.record_yaw(opts, yaw);
        }
    }

    /// Records a frame's chosen motion's road score ([`score`]), keeping the last
    /// [`HypothesesOptions::yaw_history_predict_road_frames`] (nothing where that is 0).
    pub fn record_road(&mut self, opts: &HypothesesOptions, score: usize) {
        let k = opts.yaw_history_predict_road_frames;
        if k == 0 {
            return;
        }
        self.road_scores.push_back(score);
        while self.road_scores.len() > k {
            self.road_scores.pop_front();
        }
    }

    /// Whether A, of road score `score_a`, lost the road the recent frames' chosen motions had
    /// ([`HypothesesOptions::yaw_history_predict_road_frames`] `= K`): the median `m` of the
    /// last `K` recorded road scores is at least [`HypothesesOptions::min_matches`] and
    /// `score_a <= q m` (`q` [`HypothesesOptions::yaw_history_predict_road_drop`]). True with
    /// the guard off (`K = 0`); false before any frame was recorded.
    pub fn road_lost(&self, opts: &HypothesesOptions, score_a: usize) -> bool {
        opts.yaw_history_predict_road_frames == 0
            || crate::ground_drop::dropped(
                self.road_scores.iter().copied(),
                score_a,
                opts.yaw_history_predict_road_drop,
                opts.road_visible_min.unwrap_or(opts.min_matches),
            )
    }

    /// The reference yaw of the recorded frames ([`HypothesesOptions::yaw_history_frames`]):
    /// their median (the mean of the middle two for an even count); `None` before any frame
    /// was recorded.
    pub fn yaw_reference(&self) -> Option<f64> {
        crate::stats::median(self.yaws.iter().map(|(y, _)| *y))
    }

    /// Whether a motion of yaw `yaw` lies more than [`HypothesesOptions::yaw_history_margin`]
    /// from the recent frames' reference yaw ([`HypothesisTracker::yaw_reference`]; a NaN yaw
    /// does); false before any frame was recorded or with the rule off.
    pub fn yaw_jumps(&self, opts: &HypothesesOptions, yaw: f64) -> bool {
        let margin = self.yaw_margin(opts);
        opts.yaw_history_frames > 0
            && self
                .yaw_reference()
                .is_some_and(|r| !((yaw - r).abs() <= margin))
    }

    /// The margin of [`HypothesisTracker::yaw_jumps`] in the current frame:
    /// [`HypothesesOptions::yaw_history_margin`], or less for a slow vehicle
    /// ([`HypothesesOptions::yaw_history_slow_margin`]).
    pub fn yaw_margin(&self, opts: &HypothesesOptions) -> f64 {
        let (m0, k) = opts.yaw_history_slow_margin;
        // The history's least certain yaw; an unknown one turns the slow margin off.
        let sigma = self
            .yaws
            .iter()
            .try_fold(0.0_f64, |a, (_, s)| s.map(|s| a.max(s)));
        match (self.arc_length, sigma) {
            (Some(s), Some(sigma)) if m0 > 0.0 && k > 0.0 && s.is_finite() && s >= 0.0 => {
                let dynamic = m0 + k * s;
                let reference = SLOW_MARGIN_SIGMAS * sigma;
                opts.yaw_history_margin
                    .min((dynamic * dynamic + reference * reference).sqrt())
            }
            _ => opts.yaw_history_margin,
        }
    }

    /// Whether a motion of tilt `tilt` rises more than
    /// [`HypothesesOptions::tilt_reference_margin`] above the recent frames' reference tilt
    /// ([`HypothesisTracker::tilt_reference`]); false before any frame was recorded.
    pub fn tilt_jumps(&self, opts: &HypothesesOptions, tilt: f64) -> bool {
        self.tilt_reference(opts)
            .is_some_and(|r| tilt > r + opts.tilt_reference_margin)
    }

    /// Whether an alternative flatter than A by [`HypothesesOptions::tilt_margin`], with road
    /// score `score` ([`score`]), may replace A in the converse
    /// ([`HypothesesOptions::tilt_replace`]): a positive road score (the static world's motion
    /// puts matches on the road), or, with [`HypothesesOptions::tilt_replace_roadless`], A's
    /// road score `score_a` and `score` summing below [`HypothesesOptions::min_matches`] (the
    /// ground cue does not apply, as in [`HypothesisTracker::choose`]; `None`: not computed).
    pub fn converse_qualifies(
        opts: &HypothesesOptions,
        score: usize,
        score_a: Option<usize>,
    ) -> bool {
        score > 0
            || (opts.tilt_replace_roadless
                && score_a.is_some_and(|sa| sa + score < opts.min_matches.max(1)))
    }

    /// [`HypothesisTracker::tilt_jumps`], where A's road is `weak` (its road score below
    /// [`HypothesesOptions::min_matches`]) against the minimum of the last
    /// [`HypothesesOptions::tilt_weak_road_frames`] recorded tilts instead (where that is
    /// set; false before any frame was recorded).
    pub fn tilt_jumps_given_road(&self, opts: &HypothesesOptions, tilt: f64, weak: bool) -> bool {
        let k = opts.tilt_weak_road_frames.min(self.tilts.len());
        if !(weak && opts.tilt_weak_road_frames > 0) {
            return self.tilt_jumps(opts, tilt);
        }
        crate::stats::minimum(self.tilts.iter().skip(self.tilts.len() - k).copied())
            .is_some_and(|r| tilt > r + opts.tilt_reference_margin)
    }

    /// The frame's choice after [`HypothesisTracker::choose`] (`switched`: B replaced A, by
    /// whatever rule): the run's sums follow the tracks
    /// ([`HypothesesOptions::track_decay`]; nothing to do where it is off or the cue did not
    /// apply).
    pub fn settle(&mut self, switched: bool) {
        if let Some((ta, tb)) = self.pending.take() {
            self.run = Some(if switched { (tb, ta) } else { (ta, tb) });
        }
    }

    /// Chooses between the continued motion `a` and the alternative `b` of a frame with arc
    /// length `arc_length` (metres; odometry's or the solved one; `metric`: the motions'
    /// translations are at metric scale, i.e. odometry gave the arc length): `Some(true)` if `b`
    /// replaces `a`, `Some(false)` if `a` stays, `None` if the cue does not apply (too little
    /// translation or support, or the ground cue without metric scale; the evidence then only
    /// decays). With [`HypothesesOptions::track_decay`], `b_continues`: whether the memory
    /// says B continues the previous frame's chosen track (`Some(false)`: A does; `None`: it
    /// does not tell), and the choice is by the tracks' sums over the run; call
    /// [`HypothesisTracker::settle`] with the frame's final choice after it.
    #[allow(clippy::too_many_arguments)]
    pub fn choose(
        &mut self,
        opts: &HypothesesOptions,
        rig: &Rig,
        obs: &FrameObservations,
        arc_length: f64,
        metric: bool,
        a: &Hypothesis<'_>,
        b: &Hypothesis<'_>,
        b_continues: Option<bool>,
    ) -> Option<bool> {
        if !(arc_length.is_finite() && arc_length >= opts.min_arc_length)
            || (opts.ground && !metric)
        {
            self.idle(opts);
            return None;
        }
        let pa = score(opts, rig, &a.motion, obs, a.support);
        let pb = score(opts, rig, &b.motion, obs, b.support);
        if opts.track_decay > 0.0 {
            let d = opts.track_decay;
            if self
                .run
                .is_some_and(|(c, _)| c >= opts.min_matches.max(1) as f64)
            {
                self.vouched = true;
            }
            let (ta, tb) = match (self.run, b_continues) {
                (Some((c, o)), Some(false)) => (d * c + pa as f64, d * o + pb as f64),
                (Some((c, o)), Some(true)) => (d * o + pa as f64, d * c + pb as f64),
                _ => (pa as f64, pb as f64),
            };
            self.pending = Some((ta, tb));
            if ta + tb < opts.min_matches.max(1) as f64 {
                return None;
            }
            // `track_hold`: leaving the continued track needs B's own score above its sum.
            let held = opts.track_hold > 0.0
                && b_continues == Some(false)
                && self.run.is_some()
                && pb as f64 <= opts.track_hold * ta;
            let switch = !held && (tb - ta) / (ta + tb) > opts.margin;
            // `road_span`: leaving the continued track needs B's road to span the depths.
            let narrow = switch
                && opts.road_span > 0.0
                && (self.vouched || !opts.road_span_vouched)
                && b_continues == Some(false)
                && self.run.is_some()
                && road_depth_span(rig, &b.motion, obs, b.support, opts)
                    .is_some_and(|s| s < opts.road_span);
            return Some(switch && !narrow);
        }
        if pa + pb < opts.min_matches.max(1) {
            self.idle(opts);
            return None;
        }
        let e = (pb as f64 - pa as f64) / (pa + pb) as f64;
        self.evidence = opts.decay * self.evidence + e;
        if self.evidence > opts.margin {
            self.evidence = 0.0;
            Some(true)
        } else {
            Some(false)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::Observation;
    use nalgebra::{Matrix3, Vector2, Vector3};

    fn rig() -> Rig {
        let cam = momo_core::Camera::Pinhole(momo_core::Pinhole {
            fx: 718.0,
            fy: 718.0,
            cx: 607.0,
            cy: 185.0,
            width: 1241.0,
            height: 376.0,
        });
        Rig::mono(cam, Pose::identity()).unwrap()
    }

    fn obs_of(points: &[Vector3<f64>], cam_motion: &Pose<f64>) -> FrameObservations {
        // Camera motion C: X0 = R X1 + t, so X1 = R^T (X0 - t).
        let per: Vec<Observation> = points
            .iter()
            .map(|x0| {
                let x1 = cam_motion.rotation.transpose() * (x0 - cam_motion.translation);
                Observation {
                    f0: x0.normalize(),
                    f1: x1.normalize(),
                    px0: Vector2::zeros(),
                    px1: Vector2::zeros(),
                }
            })
            .collect();
        FrameObservations {
            per_camera: vec![per],
            cross_camera: Vec::new(),
        }
    }

    #[test]
    fn static_world_has_parallax_and_a_zero_flow_object_has_none() {
        let rig = rig();
        // Camera looks along +z; drive 1 m forward with a small yaw.
        let r = momo_core::so3_exp(&Vector3::new(0.0, 0.01, 0.0));
        let ego = Pose::new(r, Vector3::new(0.0, 0.0, 1.0));
        let near: Vec<Vector3<f64>> = (0..20)
            .map(|i| Vector3::new(-4.0 + 0.4 * i as f64, 1.5, 8.0 + i as f64))
            .collect();
        let obs = obs_of(&near, &ego);
        let all = vec![vec![true; near.len()]];
        assert_eq!(parallax_support(&rig, &ego, &obs, &all, 0.004), 20);
        // The same matches explained by the rotation alone (translation sideways, along a
        // direction that gives no parallax to these bearings): few or none count.
        let object = obs_of(&near, &Pose::new(Matrix3::identity(), Vector3::zeros()));
        let fake = Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(parallax_support(&rig, &fake, &object, &all, 0.004), 0);
        // Backwards parallax (negative depth) does not count.
        let back = Pose::new(r, Vector3::new(0.0, 0.0, -1.0));
        assert_eq!(parallax_support(&rig, &back, &obs, &all, 0.004), 0);
    }

    #[test]
    fn tracker_switches_on_parallax_and_accumulates_with_decay() {
        let rig = rig();
        let r = momo_core::so3_exp(&Vector3::new(0.0, 0.01, 0.0));
        let ego = Pose::new(r, Vector3::new(0.0, 0.0, 1.0));
        let pts: Vec<Vector3<f64>> = (0..20)
            .map(|i| Vector3::new(-4.0 + 0.4 * i as f64, 1.5, 8.0 + i as f64))
            .collect();
        let obs = obs_of(&pts, &ego);
        let all = vec![vec![true; pts.len()]];
        let none = vec![vec![false; pts.len()]];
        let good = Hypothesis {
            motion: ego,
            support: &all,
        };
        let bad = Hypothesis {
            motion: ego,
            support: &none,
        };
        let par = HypothesesOptions {
            ground: false,
            ..HypothesesOptions::default()
        };
        let mut t = HypothesisTracker::default();
        assert_eq!(
            t.choose(&par, &rig, &obs, 1.0, true, &bad, &good, None),
            Some(true)
        );
        assert_eq!(
            t.choose(&par, &rig, &obs, 1.0, true, &good, &bad, None),
            Some(false)
        );
        // Standing still: no cue.
        assert_eq!(
            t.choose(&par, &rig, &obs, 0.0, true, &bad, &good, None),
            None
        );
        // With a margin above one frame's evidence, two consistent frames are needed.
        let slow = HypothesesOptions {
            decay: 0.8,
            margin: 1.5,
            ..par.clone()
        };
        let mut t = HypothesisTracker::default();
        assert_eq!(
            t.choose(&slow, &rig, &obs, 1.0, true, &bad, &good, None),
            Some(false)
        );
        assert_eq!(
            t.choose(&slow, &rig, &obs, 1.0, true, &bad, &good, None),
            Some(true)
        );
        assert_eq!(t.evidence, 0.0, "the evidence restarts after a switch");
    }

    /// The scene of the track tests: 20 points ahead under one ego motion, and the supports of
    /// the first 20, 6, 9 and 0 of them.
    fn track_scene() -> (Rig, Pose<f64>, FrameObservations, [Vec<Vec<bool>>; 4]) {
        let r = momo_core::so3_exp(&Vector3::new(0.0, 0.01, 0.0));
        let ego = Pose::new(r, Vector3::new(0.0, 0.0, 1.0));
        let pts: Vec<Vector3<f64>> = (0..20)
            .map(|i| Vector3::new(-4.0 + 0.4 * i as f64, 1.5, 8.0 + i as f64))
            .collect();
        let obs = obs_of(&pts, &ego);
        let first = |k: usize| vec![(0..pts.len()).map(|i| i < k).collect::<Vec<bool>>()];
        (rig(), ego, obs, [first(20), first(6), first(9), first(0)])
    }

    /// `track_decay`: the tracks' scores add up over the run, so a frame whose alternative
    /// scores higher alone does not switch away from the track that scored higher before; the
    /// sums follow the tracks through a switch; without the memory's identification the run
    /// restarts (the per-frame choice).
    #[test]
    fn track_evidence_sums_each_track_over_the_run() {
        let (rig, ego, obs, [all, few, more, none]) = track_scene();
        let hyp = |support| Hypothesis {
            motion: ego,
            support,
        };
        let per_frame = HypothesesOptions {
            ground: false,
            min_matches: 1,
            ..HypothesesOptions::default()
        };
        let run = HypothesesOptions {
            track_decay: 0.5,
            ..per_frame.clone()
        };
        let s = |m: &[Vec<bool>]| score(&per_frame, &rig, &ego, &obs, m) as f64;
        // The frame that decides alone for the alternative, but not against the run.
        assert!(
            s(&more) > s(&few) && s(&more) - s(&few) < 0.5 * s(&all),
            "the scene's scores"
        );
        let mut t = HypothesisTracker::default();
        assert_eq!(
            t.choose(
                &per_frame,
                &rig,
                &obs,
                1.0,
                true,
                &hyp(&few),
                &hyp(&more),
                None
            ),
            Some(true)
        );
        // Frame 1: B (all) replaces A (none); the run starts from this frame's scores.
        let mut t = HypothesisTracker::default();
        let c = t.choose(&run, &rig, &obs, 1.0, true, &hyp(&none), &hyp(&all), None);
        assert_eq!(c, Some(true));
        t.settle(true);
        assert_eq!(t.run, Some((s(&all), 0.0)));
        // Frame 2: A continues the chosen track, B the other: A's track stays.
        let mut t2 = t.clone();
        let c = t2.choose(
            &run,
            &rig,
            &obs,
            1.0,
            true,
            &hyp(&few),
            &hyp(&more),
            Some(false),
        );
        assert_eq!(c, Some(false));
        t2.settle(false);
        assert_eq!(t2.run, Some((0.5 * s(&all) + s(&few), s(&more))));
        // B continues the chosen track: B replaces A, and the sums swap with the tracks.
        let mut t3 = t.clone();
        let c = t3.choose(
            &run,
            &rig,
            &obs,
            1.0,
            true,
            &hyp(&more),
            &hyp(&few),
            Some(true),
        );
        assert_eq!(c, Some(true));
        t3.settle(true);
        assert_eq!(t3.run, Some((0.5 * s(&all) + s(&few), s(&more))));
        // The memory does not tell the tracks apart: this frame's scores alone.
        let mut t4 = t.clone();
        let c = t4.choose(&run, &rig, &obs, 1.0, true, &hyp(&few), &hyp(&more), None);
        assert_eq!(c, Some(true));
        // A frame without competition decays the run; a reset forgets it.
        let mut t5 = t.clone();
        t5.idle(&run);
        assert_eq!(t5.run, Some((0.5 * s(&all), 0.0)));
        t5.reset();
        assert_eq!(t5.run, None);
    }

    /// [`HypothesesOptions::track_hold`]: where A continues the chosen track, a B whose track
    /// sum wins only by the other track's past (a bus built up while rejected) does not replace
    /// A; a B whose own frame score beats A's track sum does, and so does B without the rule or
    /// where the memory does not tell the tracks apart.
    #[test]
    fn track_hold_keeps_the_continued_track_against_the_other_tracks_past() {
        let (rig, ego, obs, [all, few, more, none]) = track_scene();
        let run = HypothesesOptions {
            ground: false,
            min_matches: 1,
            track_decay: 0.5,
            ..HypothesesOptions::default()
        };
        let hold = HypothesesOptions {
            track_hold: 1.0,
            ..run.clone()
        };
        let s = |m: &[Vec<bool>]| score(&run, &rig, &ego, &obs, m) as f64;
        // Both tracks carry a sum over the run; B's frame score is below A's track sum.
        assert!(s(&more) > s(&few) && s(&more) <= 0.5 * s(&all) + s(&few));
        let state = HypothesisTracker {
            run: Some((s(&all), s(&all))),
            ..HypothesisTracker::default()
        };
        let choose = |opts: &HypothesesOptions, a: &[Vec<bool>], b: &[Vec<bool>], cont| {
            let (a, b) = (
                Hypothesis {
                    motion: ego,
                    support: a,
                },
                Hypothesis {
                    motion: ego,
                    support: b,
                },
            );
            state
                .clone()
                .choose(opts, &rig, &obs, 1.0, true, &a, &b, cont)
        };
        // The sums alone switch (B's track: 0.5 · all + more > 0.5 · all + few).
        assert_eq!(choose(&run, &few, &more, Some(false)), Some(true));
        // Held: B's own score does not beat A's track sum.
        assert_eq!(choose(&hold, &few, &more, Some(false)), Some(false));
        // B's own score beats A's track sum (0.5 · all + 0 < all): it switches.
        assert_eq!(choose(&hold, &none, &all, Some(false)), Some(true));
        // B continues the chosen track, or the memory does not tell: not a switch away.
        assert_eq!(choose(&hold, &few, &more, Some(true)), Some(true));
        assert_eq!(choose(&hold, &few, &more, None), Some(true));
        let bad = HypothesesOptions {
            track_hold: -1.0,
            ..run.clone()
        };
        assert!(bad.validate().unwrap_err().contains("track_hold"));
        let o: HypothesesOptions = toml::from_str("track_hold = 1.0").unwrap();
        assert_eq!(o.track_hold, 1.0);
    }

    /// [`HypothesesOptions::road_span`]: where A continues the chosen track, a B whose road
    /// points lie at about one depth (10-12 m) does not replace it; a B whose road spans 5-30 m
    /// does, and so does the narrow one where the memory does not say A continues.
    #[test]
    fn road_span_holds_a_switch_to_a_road_at_one_depth() {
        let (rig, p_vc) = kitti_mono();
        // Road points (vehicle frame, z = 0) 3 m left and right, from `near` to `far` metres.
        let road = |near: f64, far: f64| -> Vec<Vector3<f64>> {
            (0..20)
                .map(|i| {
                    let x = near + (far - near) * i as f64 / 19.0;
                    let y = if i % 2 == 0 { 3.0 } else { -3.0 };
                    p_vc.rotation.transpose() * (Vector3::new(x, y, 0.0) - p_vc.translation)
                })
                .collect()
        };
        let ego = Pose::new(
            momo_core::so3_exp(&Vector3::new(0.0, 0.0, 0.005)),
            Vector3::new(1.0, 0.0, 0.0),
        );
        let mut pts = road(5.0, 30.0);
        pts.extend(road(10.0, 12.0));
        let obs = obs_of(&pts, &camera_motion(&ego, &p_vc));
        let mask =
            |r: std::ops::Range<usize>| vec![(0..pts.len()).map(|i| r.contains(&i)).collect()];
        let (spread, band, none) = (mask(0..20), mask(20..40), mask(0..0));
        let opts = HypothesesOptions {
            track_decay: 0.7,
            ..HypothesesOptions::default()
        };
        let span = |m: &[Vec<bool>]| road_depth_span(&rig, &ego, &obs, m, &opts).unwrap();
        // Z = x - 1 m (the camera 1 m ahead of the vehicle origin): 4-29 m and 9-11 m (the
        // farthest points' parallax is too small for their height to be told, 2 h σ / p).
        assert!(span(&spread) > 4.0, "{}", span(&spread));
        assert!((span(&band) - 11.0 / 9.0).abs() < 0.05, "{}", span(&band));
        assert_eq!(road_depth_span(&rig, &ego, &obs, &none, &opts), None);
        let held = HypothesesOptions {
            road_span: 3.4,
            ..opts.clone()
        };
        let choose_after = |run, o: &HypothesesOptions, b: &[Vec<bool>], cont| {
            let a = Hypothesis {
                motion: ego,
                support: &none,
            };
            let b = Hypothesis {
                motion: ego,
                support: b,
            };
            HypothesisTracker {
                run,
                ..HypothesisTracker::default()
            }
            .choose(o, &rig, &obs, 1.0, true, &a, &b, cont)
        };
        let choose = |o: &HypothesesOptions, b: &[Vec<bool>], cont| {
            choose_after(Some((0.0, 0.0)), o, b, cont)
        };
        // No run yet (no frame has competed since the start): the memory's track is not held.
        assert_eq!(choose_after(None, &held, &band, Some(false)), Some(true));
        assert_eq!(choose(&opts, &band, Some(false)), Some(true));
        assert_eq!(choose(&held, &band, Some(false)), Some(false));
        assert_eq!(choose(&held, &band, None), Some(true));
        assert_eq!(choose(&held, &band, Some(true)), Some(true));
        assert_eq!(choose(&held, &spread, Some(false)), Some(true));
        // `road_span_vouched`: before a chosen track's road sum has reached `min_matches` the
        // continued track is not held; once one has (the previous frames' run), it is, also
        // where the continued track's sum has decayed since.
        let vouched = HypothesesOptions {
            road_span_vouched: true,
            ..held.clone()
        };
        assert_eq!(choose(&vouched, &band, Some(false)), Some(true));
        assert_eq!(
            choose_after(Some((3.0, 9.0)), &vouched, &band, Some(false)),
            Some(true)
        );
        assert_eq!(
            choose_after(Some((10.0, 0.0)), &vouched, &band, Some(false)),
            Some(false)
        );
        let mut t = HypothesisTracker {
            run: Some((10.0, 0.0)),
            ..HypothesisTracker::default()
        };
        let (a, b) = (
            Hypothesis {
                motion: ego,
                support: &none,
            },
            Hypothesis {
                motion: ego,
                support: &band,
            },
        );
        assert_eq!(
            t.choose(&vouched, &rig, &obs, 1.0, true, &a, &b, Some(false)),
            Some(false)
        );
        t.settle(false);
        t.run = Some((0.5, 0.0));
        assert_eq!(
            t.choose(&vouched, &rig, &obs, 1.0, true, &a, &b, Some(false)),
            Some(false)
        );
        t.reset();
        t.run = Some((0.5, 0.0));
        assert_eq!(
            t.choose(&vouched, &rig, &obs, 1.0, true, &a, &b, Some(false)),
            Some(true)
        );
        let o: HypothesesOptions = toml::from_str("road_span_vouched = true").unwrap();
        assert!(o.road_span_vouched);
        let bad = HypothesesOptions {
            road_span: f64::NAN,
            ..opts.clone()
        };
        assert!(bad.validate().unwrap_err().contains("road_span"));
        let o: HypothesesOptions = toml::from_str("road_span = 3.4").unwrap();
        assert_eq!(o.road_span, 3.4);
    }

    /// [`tilt`]: the roll and pitch part of a vehicle-frame rotation, blind to the yaw;
    /// `tilt_margin` parses and validates.
    #[test]
    fn tilt_is_the_roll_and_pitch_of_the_rotation() {
        let m = |w: Vector3<f64>| Pose::new(momo_core::so3_exp(&w), Vector3::new(1.0, 0.0, 0.0));
        assert!(tilt(&m(Vector3::new(0.0, 0.0, 0.05))) < 1e-12);
        let t = tilt(&m(Vector3::new(0.003, -0.004, 0.02)));
        assert!((t - 0.005).abs() < 1e-9, "{t}");
        // A motion turning 1 deg and pitching 1 deg is tilted by 1 deg, not by its angle.
        let d = 1f64.to_radians();
        let t = tilt(&m(Vector3::new(0.0, d, d)));
        assert!((t - d).abs() < 1e-9, "{t}");
        assert_eq!(HypothesesOptions::default().tilt_margin, 0.0);
        let o: HypothesesOptions = toml::from_str("tilt_margin = 0.01").unwrap();
        assert_eq!(o.tilt_margin, 0.01);
        assert!(o.validate().is_ok());
        let bad = HypothesesOptions {
            tilt_margin: -0.01,
            ..HypothesesOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("tilt_margin"));
    }

    /// [`HypothesisTracker::tilt_jumps`] (`tilt_reference_frames`): a tilt that rises from the
    /// recent frames' (a road's grade) does not jump, one far above their median or minimum
    /// does; the window keeps the last `K` frames; without a recorded frame nothing jumps.
    #[test]
    fn a_tilt_jumps_only_from_the_recent_frames_reference() {
        let d = 1f64.to_radians();
        let opts = |k, how| HypothesesOptions {
            tilt_reference_frames: k,
            tilt_reference_margin: 0.01,
            tilt_reference: how,
            ..HypothesesOptions::default()
        };
        let (med3, min3, prev) = (
            opts(3, TiltReference::Median),
            opts(3, TiltReference::Minimum),
            opts(1, TiltReference::Median),
        );
        let run = |o: &HypothesesOptions, tilts: &[f64]| {
            let mut t = HypothesisTracker::default();
            for &x in tilts {
                t.record_tilt(o, x * d);
            }
            t
        };
        // Nothing recorded: no reference, nothing jumps; off (K = 0) records nothing.
        assert_eq!(HypothesisTracker::default().tilt_reference(&med3), None);
        assert!(!HypothesisTracker::default().tilt_jumps(&med3, 10.0 * d));
        assert_eq!(
            run(&HypothesesOptions::default(), &[0.2]).tilt_reference(&med3),
            None
        );
        // A true pitch rising smoothly (the static scene of 00 s3 118: 0.35 -> 0.89 deg) does
        // not jump from the previous frame (0.57 deg margin); A jumping from 0.16 to 1.41 does.
        let smooth = run(&prev, &[0.1, 0.2, 0.35]);
        assert!((smooth.tilt_reference(&prev).unwrap() - 0.35 * d).abs() < 1e-12);
        assert!(!smooth.tilt_jumps(&prev, 0.89 * d));
        assert!(run(&prev, &[0.2, 0.16]).tilt_jumps(&prev, 1.41 * d));
        // A previous frame already tilted (0.95 deg) hides the jump from it, not from the
        // median of the last three or their minimum.
        let tilted = run(&med3, &[0.9, 0.2, 0.3, 0.95]);
        assert!(!run(&prev, &[0.2, 0.3, 0.95]).tilt_jumps(&prev, 1.40 * d));
        assert!((tilted.tilt_reference(&med3).unwrap() - 0.3 * d).abs() < 1e-12);
        assert!(tilted.tilt_jumps(&med3, 1.40 * d));
        assert!(!tilted.tilt_jumps(&med3, 0.8 * d));
        let tilted = run(&min3, &[0.9, 0.2, 0.3, 0.95]);
        assert!((tilted.tilt_reference(&min3).unwrap() - 0.2 * d).abs() < 1e-12);
        assert!(tilted.tilt_jumps(&min3, 0.8 * d));
        // `tilt_reference_contested`: the minimum of the three only where two motions
        // competed on one of them; otherwise the previous frame's tilt.
        let contested_min3 = HypothesesOptions {
            tilt_reference_contested: true,
            ..min3.clone()
        };
        let run_contested = |competing: &[bool]| {
            let mut t = HypothesisTracker::default();
            for (&x, &c) in [0.9, 0.2, 0.3, 0.95].iter().zip(competing) {
                t.record_tilt(&contested_min3, x * d);
                t.record_contested(&contested_min3, c);
            }
            t
        };
        let quiet = run_contested(&[true, false, false, false]);
        assert!((quiet.tilt_reference(&contested_min3).unwrap() - 0.95 * d).abs() < 1e-12);
        assert!(!quiet.tilt_jumps(&contested_min3, 1.40 * d));
        let ramp = run_contested(&[false, true, false, false]);
        assert!((ramp.tilt_reference(&contested_min3).unwrap() - 0.2 * d).abs() < 1e-12);
        assert!(ramp.tilt_jumps(&contested_min3, 0.8 * d));
        // Nothing is recorded without the option.
        let mut plain = HypothesisTracker::default();
        plain.record_contested(&min3, true);
        assert!(plain.contested.is_empty());
        // An even count: the mean of the middle two; a non-finite tilt is not recorded.
        let four = run(
            &opts(4, TiltReference::Median),
            &[0.1, f64::NAN, 0.4, 0.2, 0.3],
        );
        assert!(
            (four
                .tilt_reference(&opts(4, TiltReference::Median))
                .unwrap()
                - 0.25 * d)
                .abs()
                < 1e-12
        );
        let mut reset = tilted.clone();
        reset.reset();
        assert_eq!(reset.tilt_reference(&min3), None);
        // The options parse and validate.
        let o: HypothesesOptions = toml::from_str(
            "tilt_replace = true\ntilt_reference_frames = 3\ntilt_reference = \"minimum\"\n\
             tilt_reference_margin = 0.01",
        )
        .unwrap();
        assert_eq!(
            (o.tilt_reference_frames, o.tilt_reference),
            (3, TiltReference::Minimum)
        );
        assert!(o.validate().is_ok());
        let bad = HypothesesOptions {
            tilt_reference_margin: f64::INFINITY,
            ..o.clone()
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .contains("tilt_reference_margin")
        );
        assert!(toml::from_str::<HypothesesOptions>("tilt_reference = \"mean\"").is_err());
    }

    /// [`HypothesesOptions::tilt_weak_road_frames`]: where A's road is weak the gate's
    /// reference is the minimum of the last `K'` tilts (08 s9 77: the previous frame already
    /// tilted 0.97 deg, two frames before 0.21), elsewhere the previous frame's; the tracker
    /// keeps `max(K, K')` tilts and the one-frame reference reads only the last.
    #[test]
    fn a_weak_road_measures_the_jump_from_the_minimum_of_more_frames() {
        let d = 1f64.to_radians();
        let opts = |k2| HypothesesOptions {
            tilt_reference_frames: 1,
            tilt_reference_margin: 0.01,
            tilt_weak_road_frames: k2,
            ..HypothesesOptions::default()
        };
        let (off, on) = (opts(0), opts(3));
        let run = |o: &HypothesesOptions, tilts: &[f64]| {
            let mut t = HypothesisTracker::default();
            for &x in tilts {
                t.record_tilt(o, x * d);
            }
            t
        };
        let t = run(&on, &[0.5, 0.21, 0.54, 0.97]);
        assert_eq!(t.tilts.len(), 3);
        assert_eq!(run(&off, &[0.5, 0.21, 0.54, 0.97]).tilts.len(), 1);
        // The one-frame reference is the last tilt whatever is kept.
        assert!((t.tilt_reference(&on).unwrap() - 0.97 * d).abs() < 1e-12);
        // A at 1.41 deg: no jump from 0.97 (0.57 deg margin), a jump from the minimum 0.21
        // where A's road is weak; with a strong road or the option off the previous frame.
        assert!(!t.tilt_jumps_given_road(&on, 1.41 * d, false));
        assert!(t.tilt_jumps_given_road(&on, 1.41 * d, true));
        assert!(!run(&off, &[0.5, 0.21, 0.54, 0.97]).tilt_jumps_given_road(&off, 1.41 * d, true));
        // Not above the minimum by the margin: no jump.
        assert!(!t.tilt_jumps_given_road(&on, 0.7 * d, true));
        // Nothing recorded: nothing jumps.
        assert!(!HypothesisTracker::default().tilt_jumps_given_road(&on, 10.0 * d, true));
        // The converse's qualification: a positive road score always; without road only with
        // `tilt_replace_roadless` where A's and its scores sum below `min_matches` (10).
        let rl = HypothesesOptions {
            tilt_replace_roadless: true,
            ..on.clone()
        };
        assert!(HypothesisTracker::converse_qualifies(&on, 1, None));
        assert!(!HypothesisTracker::converse_qualifies(&on, 0, Some(2)));
        assert!(HypothesisTracker::converse_qualifies(&rl, 0, Some(2)));
        assert!(HypothesisTracker::converse_qualifies(&rl, 0, Some(9)));
        assert!(!HypothesisTracker::converse_qualifies(&rl, 0, Some(10)));
        assert!(!HypothesisTracker::converse_qualifies(&rl, 0, None));
        // Off in `HypothesesOptions::default()`, `K' = 3` in the default configuration;
        // parse and validate.
        let d0 = HypothesesOptions::default();
        assert_eq!(
            (d0.tilt_replace_roadless, d0.tilt_weak_road_frames),
            (false, 0)
        );
        let dc = crate::separate::SeparateOptions::competition_over_time()
            .hypotheses
            .expect("the default choice");
        assert_eq!(
            (dc.tilt_replace_roadless, dc.tilt_weak_road_frames),
            (false, 3)
        );
        let o: HypothesesOptions =
            toml::from_str("tilt_replace_roadless = true\ntilt_weak_road_frames = 3").unwrap();
        assert_eq!(
            (o.tilt_replace_roadless, o.tilt_weak_road_frames),
            (true, 3)
        );
        assert!(o.validate().is_ok());
        let bad = HypothesesOptions {
            tilt_weak_road_frames: 1001,
            ..o
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .contains("tilt_weak_road_frames")
        );
    }

    /// A KITTI pinhole at the KITTI mount: camera 1 m ahead of the motion centre, 1.65 m above
    /// the road, looking forward; the rig and the mount.
    fn kitti_mono() -> (Rig, Pose<f64>) {
        let p_vc = Pose::new(
            Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
            Vector3::new(1.0, 0.0, 1.65),
        );
        (Rig::mono(kitti_camera(), p_vc).unwrap(), p_vc)
    }

    /// The KITTI-like pinhole camera of [`kitti_mono`].
    fn kitti_camera() -> momo_core::Camera {
        momo_core::Camera::Pinhole(momo_core::Pinhole {
            fx: 718.0,
            fy: 718.0,
            cx: 607.0,
            cy: 185.0,
            width: 1241.0,
            height: 376.0,
        })
    }

    /// Twelve points (camera frame of [`kitti_mono`]'s mount `p_vc`) of a car in the next lane,
    /// 6 m ahead, below the horizon: moving with the ego vehicle they keep their place.
    fn car_alongside(p_vc: &Pose<f64>) -> Vec<Vector3<f64>> {
        (0..12)
            .map(|i| {
                let v = Vector3::new(6.0, 1.5 + 0.125 * i as f64, 0.2 + 0.07 * i as f64);
                p_vc.rotation.transpose() * (v - p_vc.translation)
            })
            .collect()
    }

    /// The under-the-road tests' ego motion (1 m ahead, a slight left turn) and test (3
    /// sigmas of a 0.0014 rad bearing noise, the road descending by up to 0.02).
    fn under_road_case() -> (Pose<f64>, UnderRoad) {
        let ego = Pose::new(
            momo_core::so3_exp(&Vector3::new(0.0, 0.0, 0.005)),
            Vector3::new(1.0, 0.0, 0.0),
        );
        let test = UnderRoad {
            ground_z: 0.0,
            ground_pitch: 0.0,
            noise_angle: 0.0014,
            sigmas: 3.0,
            slope: 0.02,
        };
        (ego, test)
    }

    #[test]
    fn the_road_lies_at_the_mount_height_only_under_the_true_motion_at_its_scale() {
        let (rig, p_vc) = kitti_mono();
        // Road points 5-14 m ahead, 2-4 m left and right (vehicle frame, z = 0): near enough
        // for parallax that tells their height.
        let road: Vec<Vector3<f64>> = (0..30)
            .map(|i| {
                let x = 5.0 + 0.3 * i as f64;
                let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (2.0 + 0.066 * i as f64);
                let v = Vector3::new(x, y, 0.0);
                p_vc.rotation.transpose() * (v - p_vc.translation)
            })
            .collect();
        let ego = Pose::new(
            momo_core::so3_exp(&Vector3::new(0.0, 0.0, 0.005)),
            Vector3::new(1.0, 0.0, 0.0),
        );
        let obs = obs_of(&road, &camera_motion(&ego, &p_vc));
        let all = vec![vec![true; road.len()]];
        let opts = HypothesesOptions::default();
        let n = ground_support(&rig, &ego, &obs, &all, &opts);
        assert!(n >= 27, "{n} of 30 road points on the road");
        // The same direction of travel at a third of the arc length: the points rise.
        let short = Pose::new(ego.rotation, ego.translation / 3.0);
        let m = ground_support(&rig, &short, &obs, &all, &opts);
        assert!(
            m <= 3,
            "{m} of 30 road points on the road at the wrong scale"
        );
    }

    /// [`HypothesesOptions::ground_pitch`]: a road that rises 1° ahead of the camera (a camera
    /// pitched nose down by 1° against its nominal mount) is on the road at the true scale
    /// with the pitch given, and read at a longer arc length without it: its far points lie
    /// higher than a level road allows, so a larger scale pushes them down onto it.
    #[test]
    fn a_pitched_road_is_read_at_the_true_scale_with_its_pitch() {
        let (rig, p_vc) = kitti_mono();
        let pitch = 1f64.to_radians();
        let road: Vec<Vector3<f64>> = (0..40)
            .map(|i| {
                let x = 5.0 + 0.6 * i as f64;
                let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (1.0 + 0.05 * i as f64);
                let v = Vector3::new(x, y, pitch.tan() * (x - p_vc.translation.x));
                p_vc.rotation.transpose() * (v - p_vc.translation)
            })
            .collect();
        let ego = Pose::new(Matrix3::identity(), Vector3::new(1.0, 0.0, 0.0));
        let obs = obs_of(&road, &camera_motion(&ego, &p_vc));
        let all = vec![vec![true; road.len()]];
        let arc_lengths: Vec<f64> = (0..=232).map(|k| 0.05 * 1.02_f64.powi(k)).collect();
        let motions: Vec<Pose<f64>> = arc_lengths
            .iter()
            .map(|l| Pose::new(ego.rotation, ego.translation * *l))
            .collect();
        let read = |ground_pitch: f64| -> (Option<f64>, usize) {
            let opts = HypothesesOptions {
                ground_pitch,
                ..HypothesesOptions::default()
            };
            let counts = ground_support_over(&rig, &arc_lengths, &motions, &obs, &all, &opts);
            let top = counts.iter().copied().max().unwrap_or(0);
            (road_arc_length(&arc_lengths, &counts, 12), top)
        };
        let (with, n_with) = read(pitch);
        let (level, _) = read(0.0);
        assert!(
            n_with >= 30,
            "{n_with} of 40 road points on the pitched road"
        );
        let with = with.unwrap_or(f64::NAN);
        let level = level.unwrap_or(f64::NAN);
        assert!(
            (with - 1.0).abs() <= 0.03,
            "arc length with the pitch: {with}"
        );
        assert!(level >= 1.05, "arc length through a level road: {level}");
        // Validated: a pitch beyond the limit is refused.
        let bad = HypothesesOptions {
            ground_pitch: 0.3,
            ..HypothesesOptions::default()
        };
        assert!(bad.validate().is_err());
    }

    proptest::proptest! {
        /// [`ground_support_over`] counts what [`ground_support`] counts at every arc length
        /// (the affine shortcut and the fallback for a rotation that changes with it), on road
        /// points, points above the road and a co-moving object's matches.
        #[test]
        fn ground_support_over_counts_what_ground_support_counts_at_each_arc_length(
            yaw in -0.03_f64..0.03,
            climb in -0.02_f64..0.02,
            travel in 0.2_f64..2.5,
            pitch in -0.03_f64..0.03,
            seed in 0_u64..1000,
        ) {
            let (rig, p_vc) = kitti_mono();
            // The road rises ahead of the camera by `tan(pitch)` per metre.
            let road_z = |x: f64| pitch.tan() * (x - p_vc.translation.x);
            let to_cam = |v: Vector3<f64>| p_vc.rotation.transpose() * (v - p_vc.translation);
            let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let mut uniform = |lo: f64, hi: f64| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                lo + (hi - lo) * ((state >> 11) as f64 / (1u64 << 53) as f64)
            };
            let rotation = momo_core::so3_exp(&Vector3::new(0.0, climb, yaw));
            let direction = Vector3::new(1.0, 0.5 * yaw, climb).normalize();
            let ego = Pose::new(rotation, direction * travel);
            let mut pts = Vec::new();
            for _ in 0..40 {
                // Road (with a little noise in height), facades, points far ahead.
                let x = uniform(4.0, 40.0);
                pts.push(Vector3::new(x, uniform(-6.0, 6.0), road_z(x) + uniform(-0.03, 0.03)));
                pts.push(Vector3::new(uniform(6.0, 60.0), uniform(-9.0, 9.0), uniform(0.3, 6.0)));
            }
            let mut obs = obs_of(&pts.iter().map(|v| to_cam(*v)).collect::<Vec<_>>(), &camera_motion(&ego, &p_vc));
            // A co-moving object: no motion relative to the camera but a little noise.
            let object: Vec<Vector3<f64>> = (0..20)
                .map(|_| to_cam(Vector3::new(uniform(8.0, 15.0), uniform(-1.0, 1.0), uniform(0.0, 2.0))))
                .collect();
            let still = obs_of(&object, &Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, uniform(-0.05, 0.05))));
            obs.per_camera[0].extend(still.per_camera[0].iter().cloned());
            let n = obs.per_camera[0].len();
            let support = vec![(0..n).map(|i| i % 7 != 3).collect::<Vec<bool>>()];
            let opts = HypothesesOptions { ground_pitch: pitch, ..HypothesesOptions::default() };
            let arc_lengths: Vec<f64> = (0..=232).map(|k| 0.05 * 1.02_f64.powi(k)).collect();
            let affine: Vec<Pose<f64>> = arc_lengths.iter().map(|l| Pose::new(rotation, direction * *l)).collect();
            // A model whose rotation grows with the arc length (constant curvature): the fallback.
            let curved: Vec<Pose<f64>> = arc_lengths
                .iter()
                .map(|l| Pose::new(momo_core::so3_exp(&Vector3::new(0.0, climb, yaw * *l / travel)), direction * *l))
                .collect();
            for motions in [&affine, &curved] {
                let each: Vec<usize> = motions.iter().map(|m| ground_support(&rig, m, &obs, &support, &opts)).collect();
                let over = ground_support_over(&rig, &arc_lengths, motions, &obs, &support, &opts);
                proptest::prop_assert_eq!(&over, &each);
            }
            // Not a vacuous comparison: with parallax enough, the road is found.
            if travel >= 0.8 {
                let top = affine.iter().map(|m| ground_support(&rig, m, &obs, &support, &opts)).max();
                proptest::prop_assert!(top.unwrap_or(0) >= 10, "road support {top:?}");
            }
        }
    }

    #[test]
    fn points_moving_with_the_ego_vehicle_lie_under_the_road_static_ones_do_not() {
        let (rig, p_vc) = kitti_mono();
        let to_cam = |v: Vector3<f64>| p_vc.rotation.transpose() * (v - p_vc.translation);
        // Static: road points 5-40 m ahead, a facade's points above and below the horizon.
        let mut pts: Vec<Vector3<f64>> = (0..30)
            .map(|i| {
                let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (2.0 + 0.1 * i as f64);
                to_cam(Vector3::new(5.0 + 1.2 * i as f64, y, 0.0))
            })
            .collect();
        pts.extend((0..10).map(|i| to_cam(Vector3::new(12.0, -6.0, 0.3 * i as f64))));
        let (ego, test) = under_road_case();
        let c = camera_motion(&ego, &p_vc);
        let obs = obs_of(&pts, &c);
        let all = vec![vec![true; pts.len()]];
        let flagged = under_road_mask(&rig, &ego, &obs, &all, &test);
        assert!(
            flagged.iter().flatten().all(|f| !f),
            "static points flagged"
        );
        // A car in the next lane, 6 m ahead, moving with the ego vehicle: its points keep
        // their place in the camera (the object's camera motion is the identity), below the
        // horizon but without parallax.
        let car = car_alongside(&p_vc);
        let moving = obs_of(&car, &Pose::identity());
        let all = vec![vec![true; car.len()]];
        let flagged = under_road_mask(&rig, &ego, &moving, &all, &test);
        assert!(flagged.iter().flatten().all(|f| *f), "{flagged:?}");
        // The same car 20 m straight ahead, near the focus of expansion: a static point there
        // has too little parallax to bound its range, so the test has no power.
        let ahead: Vec<Vector3<f64>> = (0..12)
            .map(|i| {
                to_cam(Vector3::new(
                    20.0,
                    -0.8 + 0.15 * i as f64,
                    0.2 + 0.07 * i as f64,
                ))
            })
            .collect();
        let lead = obs_of(&ahead, &Pose::identity());
        let flagged = under_road_mask(&rig, &ego, &lead, &all, &test);
        assert!(flagged.iter().flatten().all(|f| !f), "{flagged:?}");
        // Only the support is tested; without translation nothing is.
        let none = vec![vec![false; car.len()]];
        let flagged = under_road_mask(&rig, &ego, &moving, &none, &test);
        assert!(flagged.iter().flatten().all(|f| !f));
        let still = Pose::new(ego.rotation, Vector3::zeros());
        let flagged = under_road_mask(&rig, &still, &moving, &all, &test);
        assert!(flagged.iter().flatten().all(|f| !f));
    }

    #[test]
    fn the_separations_road_test_leaves_out_the_flagged_matches_of_its_mask_only() {
        // `separate::under_road_left_out`: 30 road points and 12 points of a car moving with
        // the ego vehicle (as above), the one-camera factor `under_road = 3`.
        let (rig, p_vc) = kitti_mono();
        let to_cam = |v: Vector3<f64>| p_vc.rotation.transpose() * (v - p_vc.translation);
        let (ego, _) = under_road_case();
        let c = camera_motion(&ego, &p_vc);
        let road: Vec<Vector3<f64>> = (0..30)
            .map(|i| {
                let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (2.0 + 0.1 * i as f64);
                to_cam(Vector3::new(5.0 + 1.2 * i as f64, y, 0.0))
            })
            .collect();
        let car = car_alongside(&p_vc);
        let (static_obs, car_obs) = (obs_of(&road, &c), obs_of(&car, &Pose::identity()));
        let obs = FrameObservations {
            per_camera: vec![
                static_obs.per_camera[0]
                    .iter()
                    .chain(&car_obs.per_camera[0])
                    .copied()
                    .collect(),
            ],
            cross_camera: Vec::new(),
        };
        let opts = crate::separate::SeparateOptions {
            under_road: 3.0,
            ..crate::separate::SeparateOptions::competition_over_time()
        };
        let all = vec![vec![true; 42]];
        let out = crate::separate::under_road_left_out(&rig, &ego, &obs, &all, &opts, true)
            .expect("the car is left out");
        let flagged: Vec<usize> = (0..42).filter(|&i| out[0][i]).collect();
        assert_eq!(flagged, (30..42).collect::<Vec<_>>());
        // Only matches of the mask are left out.
        let mut mask = all.clone();
        mask[0][35] = false;
        let out = crate::separate::under_road_left_out(&rig, &ego, &obs, &mask, &opts, true)
            .expect("the car is left out");
        assert!(!out[0][35] && out[0][34] && out[0][36]);
        // Off: no metric scale, a factor of 0 (the rig's factor on one camera is not read),
        // or a mask that would keep fewer than half (the car and 11 road points).
        assert!(
            crate::separate::under_road_left_out(&rig, &ego, &obs, &all, &opts, false).is_none()
        );
        let off = crate::separate::SeparateOptions {
            under_road: 0.0,
            under_road_rig: 3.0,
            ..opts.clone()
        };
        assert!(crate::separate::under_road_left_out(&rig, &ego, &obs, &all, &off, true).is_none());
        let few: Vec<Vec<bool>> = vec![(0..42).map(|i| !(11..30).contains(&i)).collect()];
        assert!(
            crate::separate::under_road_left_out(&rig, &ego, &obs, &few, &opts, true).is_none()
        );
    }

    #[test]
    fn a_rear_cameras_road_points_are_not_under_the_road() {
        // A camera looking back (optical axis along the vehicle's -x), 1.65 m above the road:
        // under the forward motion its road points recede. The range the test compares with
        // the road's is the one from frame k-1; the one from frame k is larger (5.3 against
        // 6.2 m for a point 5 m behind), which read as "beyond the road" flagged them.
        let p_vc = Pose::new(
            Matrix3::new(0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
            Vector3::new(-0.5, 0.0, 1.65),
        );
        let rig = Rig::mono(kitti_camera(), p_vc).unwrap();
        let to_cam = |v: Vector3<f64>| p_vc.rotation.transpose() * (v - p_vc.translation);
        let road: Vec<Vector3<f64>> = (0..30)
            .map(|i| {
                let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (0.5 + 0.1 * i as f64);
                to_cam(Vector3::new(-5.0 - 0.8 * i as f64, y, 0.0))
            })
            .collect();
        assert!(road.iter().all(|x| x.z > 0.0), "in front of the camera");
        let (ego, test) = under_road_case();
        let obs = obs_of(&road, &camera_motion(&ego, &p_vc));
        let all = vec![vec![true; road.len()]];
        let flagged = under_road_mask(&rig, &ego, &obs, &all, &test);
        assert!(flagged.iter().flatten().all(|f| !f), "{flagged:?}");
        // Points of a car behind that follows at the ego vehicle's speed (no parallax) are.
        let car: Vec<Vector3<f64>> = (0..12)
            .map(|i| {
                to_cam(Vector3::new(
                    -7.0,
                    -1.5 + 0.25 * i as f64,
                    0.3 + 0.05 * i as f64,
                ))
            })
            .collect();
        let follower = obs_of(&car, &Pose::identity());
        let all = vec![vec![true; car.len()]];
        let flagged = under_road_mask(&rig, &ego, &follower, &all, &test);
        assert!(flagged.iter().flatten().all(|f| *f), "{flagged:?}");
    }

    #[test]
    fn the_spread_score_counts_image_cells_not_matches() {
        let p_vc = Pose::new(
            Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
            Vector3::new(1.0, 0.0, 1.65),
        );
        let (fx, cx, cy) = (718.0, 607.0, 185.0);
        let cam = momo_core::Camera::Pinhole(momo_core::Pinhole {
            fx,
            fy: fx,
            cx,
            cy,
            width: 1241.0,
            height: 376.0,
        });
        let rig = Rig::mono(cam, p_vc).unwrap();
        let road: Vec<Vector3<f64>> = (0..30)
            .map(|i| {
                let x = 5.0 + 0.3 * i as f64;
                let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (2.0 + 0.066 * i as f64);
                p_vc.rotation.transpose() * (Vector3::new(x, y, 0.0) - p_vc.translation)
            })
            .collect();
        let ego = Pose::new(
            momo_core::so3_exp(&Vector3::new(0.0, 0.0, 0.005)),
            Vector3::new(1.0, 0.0, 0.0),
        );
        let mut obs = obs_of(&road, &camera_motion(&ego, &p_vc));
        for (o, x) in obs.per_camera[0].iter_mut().zip(&road) {
            o.px0 = Vector2::new(fx * x.x / x.z + cx, fx * x.y / x.z + cy);
        }
        let all = vec![vec![true; road.len()]];
        let count = HypothesesOptions::default();
        let spread = HypothesesOptions {
            spread_grid: Some((16, 8)),
            ..count.clone()
        };
        let n = score(&count, &rig, &ego, &obs, &all);
        let cells = score(&spread, &rig, &ego, &obs, &all);
        let mask = ground_mask(&rig, &ego, &obs, &all, &count);
        assert_eq!(cells, crate::separate::cells(&rig, &obs, &mask, (16, 8)));
        assert!(
            n >= 27 && (4..n).contains(&cells),
            "{n} matches, {cells} cells"
        );
        // The same road points seen in one spot of the image: one cell, the count unchanged.
        for o in &mut obs.per_camera[0] {
            o.px0 = Vector2::new(600.0, 300.0);
        }
        assert_eq!(score(&count, &rig, &ego, &obs, &all), n);
        assert_eq!(score(&spread, &rig, &ego, &obs, &all), 1);
        // The parallax support in cells, too.
        let par = HypothesesOptions {
            ground: false,
            ..spread.clone()
        };
        assert_eq!(score(&par, &rig, &ego, &obs, &all), 1);
    }

    #[test]
    fn options_validate_and_parse() {
        assert!(HypothesesOptions::default().validate().is_ok());
        let d = HypothesesOptions {
            decay: 1.0,
            ..HypothesesOptions::default()
        };
        assert!(d.validate().unwrap_err().contains("decay"));
        let o: HypothesesOptions = toml::from_str("decay = 0.5\nmargin = 0.2").unwrap();
        assert_eq!((o.decay, o.margin), (0.5, 0.2));
        assert!(toml::from_str::<HypothesesOptions>("decays = 0.5").is_err());
        let o: HypothesesOptions = toml::from_str("spread_grid = [16, 8]").unwrap();
        assert_eq!(o.spread_grid, Some((16, 8)));
        let bad = HypothesesOptions {
            spread_grid: Some((0, 8)),
            ..HypothesesOptions::default()
        };
        assert!(bad.validate().unwrap_err().contains("spread_grid"));
        let o: HypothesesOptions =
            toml::from_str("track_decay = 0.5\ntrack_identity = 0.3\ntrack_min_labelled = 10")
                .unwrap();
        assert_eq!(
            (o.track_decay, o.track_identity, o.track_min_labelled),
            (0.5, 0.3, 10)
        );
        for (decay, identity) in [(1.0, 0.2), (-0.1, 0.2), (0.5, 0.0), (0.5, 1.5)] {
            let bad = HypothesesOptions {
                track_decay: decay,
                track_identity: identity,
                ..HypothesesOptions::default()
            };
            assert!(bad.validate().unwrap_err().contains("track_"));
        }
    }

    /// The match memory's labels as computed before issue 19's flat grid: a SipHash map of
    /// `radius`-pixel cells rebuilt per camera (the reference of
    /// `memory_labels_match_the_hash_map_reference`; `wrapping_add` is the release build's
    /// addition, which the test build checks for overflow).
    fn labels_by_hash_map(
        memory: &MatchMemory,
        obs: &FrameObservations,
        radius: f64,
    ) -> Option<Vec<Vec<Option<bool>>>> {
        if memory.is_empty()
            || memory.per_camera.len() != obs.per_camera.len()
            || !(radius.is_finite() && radius > 0.0)
        {
            return None;
        }
        let key = |x: f64, y: f64| ((x / radius).floor() as i64, (y / radius).floor() as i64);
        Some(
            memory
                .per_camera
                .iter()
                .zip(&obs.per_camera)
                .map(|(prev, cur)| {
                    let mut buckets: std::collections::HashMap<(i64, i64), Vec<usize>> =
                        std::collections::HashMap::new();
                    for (i, p) in prev.iter().enumerate() {
                        if p.0.is_finite() && p.1.is_finite() {
                            buckets.entry(key(p.0, p.1)).or_default().push(i);
                        }
                    }
                    cur.iter()
                        .map(|o| {
                            let (x, y) = (o.px0.x, o.px0.y);
                            if !(x.is_finite() && y.is_finite()) {
                                return None;
                            }
                            let (kx, ky) = key(x, y);
                            let mut best: Option<(f64, bool)> = None;
                            for dx in -1..=1_i64 {
                                for dy in -1..=1_i64 {
                                    let cell = (kx.wrapping_add(dx), ky.wrapping_add(dy));
                                    for &i in buckets.get(&cell).into_iter().flatten() {
                                        let p = prev[i];
                                        let d = (p.0 - x).powi(2) + (p.1 - y).powi(2);
                                        if d <= radius * radius && best.is_none_or(|(bd, _)| d < bd)
                                        {
                                            best = Some((d, p.2));
                                        }
                                    }
                                }
                            }
                            best.map(|(_, s)| s)
                        })
                        .collect()
                })
                .collect(),
        )
    }

    /// A pixel coordinate for the memory's property test: mostly inside a KITTI-sized image,
    /// often on a lattice of quarter pixels (exact ties between neighbours, points on cell
    /// borders), sometimes far off (the sparse fallback), saturating or not finite.
    fn pixel() -> impl proptest::strategy::Strategy<Value = f64> {
        use proptest::prelude::*;
        prop_oneof![
            6 => -50.0..1300.0f64,
            6 => (-200..5200_i32).prop_map(|q| f64::from(q) / 4.0),
            1 => prop_oneof![Just(1e6), Just(-3.5e7), Just(4e12)],
            1 => prop_oneof![
                Just(1e300),
                Just(-1e300),
                Just(f64::MAX),
                Just(f64::NAN),
                Just(f64::INFINITY),
                Just(f64::NEG_INFINITY)
            ],
        ]
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]

        /// The flat grid's labels are the hash map's, match for match: the same nearest
        /// neighbour, ties broken the same way, on dense and sparse grids (far-off pixels), empty
        /// cameras, and any radius.
        #[test]
        fn memory_labels_match_the_hash_map_reference(
            prev in proptest::collection::vec(
                proptest::collection::vec((pixel(), pixel(), proptest::bool::ANY), 0..60), 1..4),
            cur in proptest::collection::vec((pixel(), pixel()), 0..60),
            radius in proptest::prop_oneof![
                4 => 0.5..40.0f64,
                1 => proptest::prelude::Just(20.0),
                1 => proptest::prelude::Just(1e-300),
                1 => proptest::prelude::Just(1e200),
            ],
        ) {
            let at = |x: f64, y: f64| Observation {
                f0: Vector3::z(),
                f1: Vector3::z(),
                px0: Vector2::new(x, y),
                px1: Vector2::new(x, y),
            };
            let cams = prev.len();
            let previous = FrameObservations {
                per_camera: prev
                    .iter()
                    .map(|c| c.iter().map(|p| at(p.0, p.1)).collect())
                    .collect(),
                cross_camera: Vec::new(),
            };
            let statics: Vec<Vec<bool>> =
                prev.iter().map(|c| c.iter().map(|p| p.2).collect()).collect();
            let memory = MatchMemory::record(&previous, &statics);
            // The current pair: the same points in every camera, and the previous pixels
            // themselves (exact hits) in camera 0.
            let mut per_camera: Vec<Vec<Observation>> =
                vec![cur.iter().map(|p| at(p.0, p.1)).collect(); cams];
            per_camera[0].extend(prev[0].iter().map(|p| at(p.0, p.1)));
            let current = FrameObservations { per_camera, cross_camera: Vec::new() };
            let flat = memory.labels(&current, radius);
            let reference = labels_by_hash_map(&memory, &current, radius);
            proptest::prop_assert_eq!(flat, reference);
        }
    }

    /// The memory's labels transfer to the nearest previous second-image pixel of the same
    /// camera, within the radius only.
    #[test]
    fn memory_labels_transfer_by_nearest_image_position() {
        let at = |x: f64, y: f64| Observation {
            f0: Vector3::z(),
            f1: Vector3::z(),
            px0: Vector2::new(x, y),
            px1: Vector2::new(x + 3.0, y),
        };
        let obs = |cams: Vec<Vec<Observation>>| FrameObservations {
            per_camera: cams,
            cross_camera: Vec::new(),
        };
        // Previous pair: camera 0 has a static match whose second-image pixel is (103, 100)
        // and an object match at (503, 100); camera 1 one object match at (103, 100).
        let previous = obs(vec![
            vec![at(100.0, 100.0), at(500.0, 100.0)],
            vec![at(100.0, 100.0)],
        ]);
        let memory = MatchMemory::record(&previous, &[vec![true, false], vec![false]]);
        assert!(!memory.is_empty());
        // Current pair: first-image pixels near each, one far from all.
        let current = obs(vec![
            vec![at(108.0, 95.0), at(495.0, 104.0), at(300.0, 100.0)],
            vec![at(110.0, 100.0)],
        ]);
        let labels = memory.labels(&current, 20.0).expect("labels");
        assert_eq!(labels[0], vec![Some(true), Some(false), None]);
        // The same pixel in camera 1 takes camera 1's label, not camera 0's.
        assert_eq!(labels[1], vec![Some(false)]);
        // Within a smaller radius the second match is too far (8.9 px) from its neighbour,
        // the first (7.1 px) is not.
        let labels = memory.labels(&current, 8.0).expect("labels");
        assert_eq!(labels[0], vec![Some(true), None, None]);
        // Of two neighbours, the nearer one decides.
        let two = MatchMemory::record(
            &obs(vec![vec![at(100.0, 100.0), at(110.0, 100.0)], vec![]]),
            &[vec![true, false], vec![]],
        );
        let labels = two
            .labels(&obs(vec![vec![at(110.0, 101.0)], vec![]]), 20.0)
            .expect("labels");
        assert_eq!(labels[0], vec![Some(false)]);
        // Nothing remembered, or another rig: no labels.
        assert!(MatchMemory::default().labels(&current, 20.0).is_none());
        assert!(
            memory
                .labels(&obs(vec![vec![at(1.0, 1.0)]]), 20.0)
                .is_none()
        );
        let mut tracker = HypothesisTracker {
            memory,
            ..Default::default()
        };
        tracker.reset();
        assert!(tracker.memory.is_empty(), "a reset forgets the memory");
    }
    #[test]
    fn the_slow_margin_narrows_the_yaw_history_for_a_slow_certain_history_only() {
        let deg = 1.0_f64.to_radians();
        let h = HypothesesOptions {
            yaw_history_frames: 1,
            yaw_history_margin: deg,
            yaw_history_slow_margin: (0.25 * deg, deg),
            ..HypothesesOptions::default()
        };
        let mut tracker = HypothesisTracker::default();
        tracker.record_yaw(&h, -0.4 * deg);
        tracker.arc_length = Some(0.1);
        // The recorded yaw has no sigma yet: the fixed margin.
        assert_eq!(tracker.yaw_margin(&h), deg);
        assert!(!tracker.yaw_jumps(&h, 0.1 * deg));
        // A certain reference (0.03 deg): the dynamic part `0.25 + 1.0 · 0.1` deg with
        // `3 σ` in quadrature; a half-degree jump at 0.1 m per frame is stopped, a change the
        // car can make is not.
        tracker.set_last_yaw_sigma(0.03 * deg);
        let expected = (0.35_f64.powi(2) + 0.09_f64.powi(2)).sqrt() * deg;
        assert!((tracker.yaw_margin(&h) - expected).abs() < 1e-12);
        assert!(tracker.yaw_jumps(&h, 0.1 * deg));
        assert!(!tracker.yaw_jumps(&h, -0.7 * deg));
        // Faster, the margin widens up to the fixed one.
        tracker.arc_length = Some(2.0);
        assert_eq!(tracker.yaw_margin(&h), deg);
        // An uncertain reference (0.5 deg): `3 σ` alone passes the fixed margin.
        tracker.arc_length = Some(0.1);
        tracker.set_last_yaw_sigma(0.5 * deg);
        assert_eq!(tracker.yaw_margin(&h), deg);
        // Without arc length, with a NaN sigma or with the option off: the fixed margin.
        tracker.set_last_yaw_sigma(0.03 * deg);
        tracker.arc_length = None;
        assert_eq!(tracker.yaw_margin(&h), deg);
        tracker.arc_length = Some(0.1);
        tracker.set_last_yaw_sigma(f64::NAN);
        assert_eq!(tracker.yaw_margin(&h), deg);
        tracker.set_last_yaw_sigma(0.03 * deg);
        let off = HypothesesOptions {
            yaw_history_slow_margin: (0.0, deg),
            ..h.clone()
        };
        assert_eq!(tracker.yaw_margin(&off), deg);
        // A newly recorded yaw has no sigma until it is set.
        tracker.record_yaw(&h, -0.5 * deg);
        assert_eq!(tracker.yaw_margin(&h), deg);
        // The options reject a negative or non-finite part.
        for bad in [(-0.1, 1.0), (0.1, f64::NAN), (f64::INFINITY, 0.0)] {
            let o = HypothesesOptions {
                yaw_history_slow_margin: bad,
                ..h.clone()
            };
            assert!(
                o.validate()
                    .unwrap_err()
                    .contains("yaw_history_slow_margin")
            );
        }
    }
}
