//! The road track (issue 14, the slow pulls; [`crate::separate::SeparateOptions::road_track`]):
//! an alternative motion T for the separation that a slow pull of the chosen motion does not
//! carry along.
//!
//! In a *slow pull* a lead vehicle or a bus moving with the ego vehicle holds most of the
//! matches, and the first motion A follows it part of the way: A's error grows by a few tenths
//! of a degree per frame (e.g. 0.45 -> 1.17 deg over seven frames). The separation's
//! alternatives all start from the previous frame's chosen motion and are solved on matches
//! that motion labels: the second motion B on the matches outside A's support, C on the
//! matches the previous motion puts on the road, M on the matches the memory (of the previous
//! chosen support) remembers static. Once the chosen motion has drifted, the road mask and the
//! memory are the drifted motion's, and every alternative is pulled with it.
//!
//! T is C's construction — the motion re-solved on the matches whose triangulated point lies
//! on the road plane ([`crate::hypotheses::ground_mask`]) — but chained on itself: it starts
//! from the previous frame's T (with this frame's fixed parameters, e.g. the odometry arc
//! length) wherever the previous frame formed one whose road (ground) score
//! ([`crate::hypotheses::score`]) was higher than the chosen motion's; otherwise from the
//! previous chosen motion (T is then C). The road is static and seen by every frame, while a
//! vehicle ahead does not triangulate onto it, so the chain follows the static world while the
//! chosen motion is pulled. T then competes as C does (the distinct test, competition over time
//! and the multi-frame choice).

use crate::hypotheses::{HypothesesOptions, ground_mask, score};
use crate::separate::{SolveContext, subset};
use momo_core::{FrameObservations, FrameSolution};

/// The start of T: the previous frame's T `track` with the frame's fixed parameters (those
/// `ctx.fixed` marks, e.g. the odometry arc length) from `previous` (the frame's start), or
/// `previous` itself where there is no track or it does not fit the model.
pub(crate) fn start(ctx: &SolveContext<'_>, previous: &[f64], track: Option<&[f64]>) -> Vec<f64> {
    match track {
        Some(t) if t.len() == previous.len() && t.iter().all(|p| p.is_finite()) => t
            .iter()
            .zip(previous)
            .zip(ctx.fixed.iter().chain(std::iter::repeat(&false)))
            .map(|((t, p), fixed)| if *fixed { *p } else { *t })
            .collect(),
        _ => previous.to_vec(),
    }
}

/// T of the frame: the motion solved from `start` on the matches that `start` puts on the road
/// (at least 12 of them), with the frame's robust loss and no motion prior (as C); `None` where
/// there are fewer road matches or the solve fails.
pub(crate) fn solve(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    obs: &FrameObservations,
    start: &[f64],
) -> Option<FrameSolution> {
    let all: Vec<Vec<bool>> = obs.per_camera.iter().map(|m| vec![true; m.len()]).collect();
    let road = ground_mask(ctx.rig, &ctx.estimator.motion(start), obs, &all, h);
    if road.iter().flatten().filter(|r| **r).count() < 12 {
        return None;
    }
    ctx.solve(&subset(obs, &road), start, ctx.loss, false)
}

/// What the next frame's T starts from: T's parameters if T's road score on its support
/// exceeds the chosen motion's on its own, else `None` (the next T starts from the chosen
/// motion, as C does).
pub(crate) fn next(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    obs: &FrameObservations,
    t: (&[f64], &[Vec<bool>]),
    chosen: (&[f64], &[Vec<bool>]),
) -> Option<Vec<f64>> {
    let s_t = score(h, ctx.rig, &ctx.estimator.motion(t.0), obs, t.1);
    let s_c = score(h, ctx.rig, &ctx.estimator.motion(chosen.0), obs, chosen.1);
    (s_t > s_c).then(|| t.0.to_vec())
}

/// Whether T, rejected by competition over time, still competes: its road score on its support
/// is at least `min` and at least `ratio` times A's (`ratio > 0`). This is
/// [`crate::separate::SeparateOptions::ground_admit`]'s test without its own-share condition:
/// in a slow pull A's support holds most static matches too (a yaw error of about a degree
/// moves few epipolar angles past the threshold), so T owns few matches (e.g. 20 of 300), and
/// the memory, learnt from the pulled motions, does not follow the split.
pub(crate) fn admitted(
    ctx: &SolveContext<'_>,
    h: &HypothesesOptions,
    obs: &FrameObservations,
    (min, ratio): (usize, f64),
    t: (&[f64], &[Vec<bool>]),
    a: (&[f64], &[Vec<bool>]),
) -> bool {
    if ratio <= 0.0 {
        return false;
    }
    let s_t = score(h, ctx.rig, &ctx.estimator.motion(t.0), obs, t.1);
    s_t >= min
        && s_t as f64 >= ratio * score(h, ctx.rig, &ctx.estimator.motion(a.0), obs, a.1) as f64
}
