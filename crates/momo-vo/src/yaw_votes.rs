//! Yaw votes: one-point yaw hypotheses of the matches, for the motion separation's candidates
//! ([`crate::separate::SeparateOptions::yaw_votes`]).
//!
//! Every motion of a frame is looked for near the previous frame's motion turned about the
//! vehicle's vertical axis by an offset `δ` on a grid: `R(δ) = R_z(δ) R`, `t(δ) = R_z(δ) t`
//! ([`turned`], the turn the odometry's restarts apply, `odometry.restart_yaw_offsets`). Each
//! match votes for the offset of least epipolar angle ([`crate::separate::epipolar_angles`])
//! where that angle is within the support threshold and the match is *informative*: its angle
//! varies by more than a margin over the grid (a match near the focus of expansion, or a far
//! point, fits every offset and votes for none). This is the histogram voting of one-point
//! RANSAC for planar motion (Scaramuzza, "1-Point-RANSAC Structure from Motion for
//! Vehicle-Mounted Cameras by Exploiting Non-holonomic Constraints", IJCV 2011), here over the
//! offset of a full motion, so that it needs nothing of the motion model but
//! [`FrameEstimator::params_from_motion`].
//!
//! The votes, summed over a window, have a mode per motion that the informative matches
//! follow: at the start of a turn the static world's matches vote for a larger yaw than a bus
//! driving ahead, whose matches outnumber them. The separation re-solves the turned motion of
//! each mode on its support, as one more candidate (docs/RESULTS.md, thirty-ninth session).

use momo_core::{FrameEstimator, FrameObservations, Pose, Rig};
use nalgebra::Matrix3;

/// Options of the votes (plain data; [`crate::separate::SeparateOptions`] holds them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawVoteOptions {
    /// Offsets `δ` of the grid: `-range ..= range` (radians).
    pub range: f64,
    /// The grid's step (radians).
    pub step: f64,
    /// A match votes only where its epipolar angle varies by more than this over the grid
    /// (radians).
    pub informative: f64,
    /// A match votes only where its least epipolar angle is below this (radians; the
    /// separation's support threshold).
    pub threshold: f64,
    /// The half-width (grid steps) of the window the votes are summed over.
    pub window: usize,
    /// The least windowed votes of a mode.
    pub min_votes: usize,
    /// Modes closer than this many grid steps to a stronger one are not modes.
    pub separation: usize,
}

/// A mode of the votes: the offset `δ` (radians, from the previous motion's yaw) and its
/// windowed votes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawMode {
    /// The offset of the grid point.
    pub offset: f64,
    /// The votes summed over the window around it.
    pub votes: usize,
}

/// `params`' motion turned about the vehicle's vertical axis by `dy` (radians): the rotation
/// and the translation pre-multiplied by `R_z(dy)`; the arc length (where the model has one)
/// kept at `params`'. `None` where the model cannot represent the turned motion.
pub fn turned(estimator: &dyn FrameEstimator, params: &[f64], dy: f64) -> Option<Vec<f64>> {
    let base = estimator.motion(params);
    let (s, c) = dy.sin_cos();
    let rz = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
    let m = Pose::new(rz * base.rotation, rz * base.translation);
    let mut p = estimator.params_from_motion(&m)?;
    if let Some(i) = estimator.arc_length_index() {
        p[i] = *params.get(i)?;
    }
    Some(p)
}

/// The grid's offsets: `-range ..= range` in steps of `step` (0 alone where `step <= 0`).
fn grid(opts: &YawVoteOptions) -> Vec<f64> {
    if !(opts.step > 0.0 && opts.range > 0.0) {
        return vec![0.0];
    }
    // The small margin keeps a range that is a whole number of steps in degrees (3 deg in
    // 0.1 deg steps) at that number despite the rounding of the radians.
    let k = (opts.range / opts.step + 1e-9).floor() as i64;
    (-k..=k).map(|i| i as f64 * opts.step).collect()
}

/// The votes of the matches `mask` (all where `None`) per grid offset, and the offsets.
pub fn votes(
    rig: &Rig,
    estimator: &dyn FrameEstimator,
    obs: &FrameObservations,
    previous: &[f64],
    mask: Option<&[Vec<bool>]>,
    opts: &YawVoteOptions,
) -> (Vec<f64>, Vec<usize>) {
    let offsets = grid(opts);
    let angles: Vec<Option<Vec<Vec<f64>>>> = offsets
        .iter()
        .map(|&dy| {
            turned(estimator, previous, dy)
                .map(|p| crate::separate::epipolar_angles(rig, &estimator.motion(&p), obs))
        })
        .collect();
    let mut hist = vec![0usize; offsets.len()];
    for (c, matches) in obs.per_camera.iter().enumerate() {
        for i in 0..matches.len() {
            if mask.is_some_and(|m| !m.get(c).and_then(|m| m.get(i)).copied().unwrap_or(false)) {
                continue;
            }
            let (mut lo, mut hi, mut arg) = (f64::INFINITY, f64::NEG_INFINITY, None);
            for (g, a) in angles.iter().enumerate() {
                let Some(x) = a.as_ref().and_then(|a| a.get(c)?.get(i).copied()) else {
                    continue;
                };
                if x < lo {
                    lo = x;
                    arg = Some(g);
                }
                hi = hi.max(x);
            }
            if let Some(g) = arg
                && lo < opts.threshold
                && hi - lo > opts.informative
            {
                hist[g] += 1;
            }
        }
    }
    (offsets, hist)
}

/// The modes of the votes ([`votes`]): the local maxima of the sums over the window
/// ([`YawVoteOptions::window`] steps either side; the last grid point of a plateau) with at
/// least [`YawVoteOptions::min_votes`], strongest first (the smaller offset first among equal
/// sums), without those where `exclude(offset)` holds, each at least
/// [`YawVoteOptions::separation`] grid steps from every stronger one kept.
pub fn modes(
    offsets: &[f64],
    hist: &[usize],
    opts: &YawVoteOptions,
    exclude: impl Fn(f64) -> bool,
) -> Vec<YawMode> {
    let n = hist.len().min(offsets.len());
    let w = opts.window;
    let sums: Vec<usize> = (0..n)
        .map(|g| hist[g.saturating_sub(w)..(g + w + 1).min(n)].iter().sum())
        .collect();
    let mut peaks: Vec<usize> = (0..n)
        .filter(|&g| {
            sums[g] >= opts.min_votes
                && sums[g] > 0
                && (g == 0 || sums[g] >= sums[g - 1])
                && (g + 1 == n || sums[g] > sums[g + 1])
        })
        .collect();
    // A stable sort: among equal sums the smaller offset stays first.
    peaks.sort_by(|&a, &b| sums[b].cmp(&sums[a]));
    let mut kept: Vec<usize> = Vec::new();
    for g in peaks {
        if !exclude(offsets[g]) && kept.iter().all(|&k| k.abs_diff(g) >= opts.separation) {
            kept.push(g);
        }
    }
    kept.into_iter()
        .map(|g| YawMode {
            offset: offsets[g],
            votes: sums[g],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> YawVoteOptions {
        YawVoteOptions {
            range: 3f64.to_radians(),
            step: 0.1f64.to_radians(),
            informative: 0.008,
            threshold: 0.003,
            window: 2,
            min_votes: 12,
            separation: 5,
        }
    }

    #[test]
    fn modes_are_the_windowed_peaks_strongest_first_and_apart() {
        let o = opts();
        let offsets: Vec<f64> = (0..21).map(f64::from).collect();
        let mut hist = vec![0usize; 21];
        // Window sums (±2 steps): a cluster at 4-6 sums 21 at 4, 5 and 6 (the plateau's last
        // point is the mode); 13 votes at 18 sums 13 at 16-20 (the grid's end is
        // the plateau's last point); one of 3 at 0 stays below `min_votes`.
        hist[4] = 6;
        hist[5] = 10;
        hist[6] = 5;
        hist[18] = 13;
        hist[0] = 3;
        let m = modes(&offsets, &hist, &o, |_| false);
        assert_eq!(m.len(), 2, "{m:?}");
        assert_eq!((m[0].offset, m[0].votes), (6.0, 21));
        assert_eq!((m[1].offset, m[1].votes), (20.0, 13));
        hist[11] = 12;
        let m = modes(&offsets, &hist, &o, |_| false);
        assert_eq!(
            m.iter().map(|m| m.offset).collect::<Vec<_>>(),
            vec![6.0, 20.0, 13.0]
        );
        let m = modes(&offsets, &hist, &o, |x| x == 6.0);
        assert_eq!(
            m.iter().map(|m| m.offset).collect::<Vec<_>>(),
            vec![20.0, 13.0]
        );
        // Nothing reaches the least votes: no mode.
        let few = YawVoteOptions {
            min_votes: 100,
            ..o
        };
        assert!(modes(&offsets, &hist, &few, |_| false).is_empty());
    }

    #[test]
    fn a_weaker_peak_near_a_stronger_one_is_no_mode_unless_that_one_is_excluded() {
        let o = YawVoteOptions {
            window: 0,
            min_votes: 5,
            ..opts()
        };
        let offsets: Vec<f64> = (0..21).map(f64::from).collect();
        let mut hist = vec![0usize; 21];
        hist[5] = 10;
        hist[8] = 9;
        hist[15] = 13;
        let at = |m: Vec<YawMode>| m.iter().map(|m| m.offset).collect::<Vec<_>>();
        assert_eq!(at(modes(&offsets, &hist, &o, |_| false)), vec![15.0, 5.0]);
        assert_eq!(
            at(modes(&offsets, &hist, &o, |x| x == 5.0)),
            vec![15.0, 8.0]
        );
    }

    #[test]
    fn the_grid_is_symmetric_and_degenerate_steps_give_the_previous_motion_only() {
        let o = opts();
        let g = grid(&o);
        assert_eq!(g.len(), 61);
        assert!((g[0] + g[60]).abs() < 1e-15 && g[30] == 0.0);
        assert_eq!(grid(&YawVoteOptions { step: 0.0, ..o }), vec![0.0]);
        assert_eq!(grid(&YawVoteOptions { range: -1.0, ..o }), vec![0.0]);
    }

    /// A frame at the start of a left turn (the static world's yaw 1.4 deg) behind a bus that
    /// drives straight on (yaw 0) and holds 150 of the 210 matches: from the previous motion
    /// (yaw 0.5 deg) the votes have a mode near each motion's offset (+0.9 and -0.5 deg), and
    /// the turned motion of a mode is the previous one turned by its offset.
    #[test]
    fn the_votes_have_a_mode_per_motion_where_an_object_holds_most_matches() {
        use momo_core::{Observation, Pose, camera_motion, so3_log};
        use nalgebra::{Vector2, Vector3};
        let rig = momo_testing::canned::pinhole_rig();
        let config = crate::Config::default();
        let estimator = config.model.build(config.metric.as_ref()).expect("model");
        let drive = |yaw_deg: f64| {
            let y = yaw_deg.to_radians();
            let (s, c) = y.sin_cos();
            let r = nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
            let h = 0.5 * y;
            Pose::new(r, Vector3::new(h.cos(), h.sin(), 0.0))
        };
        let t_vc = rig.cameras()[0].t_vehicle_camera;
        // Vehicle-frame points of frame k-1, observed in frame k after the vehicle motion `m`
        // (a point moving with the bus: the vehicle's motion relative to it).
        let observe = |m: &Pose<f64>, p: Vector3<f64>| {
            let c = camera_motion(m, &t_vc);
            let inv = t_vc.inverse();
            let p0 = inv.rotation * p + inv.translation;
            let p1 = c.rotation.transpose() * (p0 - c.translation);
            Observation {
                px0: Vector2::zeros(),
                px1: Vector2::zeros(),
                f0: p0.normalize(),
                f1: p1.normalize(),
            }
        };
        let static_m = drive(1.4);
        let bus_m = drive(0.0);
        let mut matches = Vec::new();
        for i in 0..60 {
            let (a, b) = (f64::from(i % 10), f64::from(i / 10));
            // Spread over the scene ahead: 8-38 m, 12 m either side, from the road to 3 m up.
            let p = Vector3::new(8.0 + 3.0 * a, -12.0 + 2.4 * a + 0.7 * b, -1.5 + 0.8 * b);
            matches.push(observe(&static_m, p));
        }
        for i in 0..150 {
            let (a, b) = (f64::from(i % 15), f64::from(i / 15));
            // The bus's back, 12 m ahead: 2.5 m wide, 3 m high.
            let p = Vector3::new(12.0 + 0.02 * a, -1.25 + a * 2.5 / 14.0, -0.3 + b * 0.3);
            matches.push(observe(&bus_m, p));
        }
        let obs = FrameObservations {
            per_camera: vec![matches],
            cross_camera: Vec::new(),
        };
        let previous = estimator
            .params_from_motion(&drive(0.5))
            .expect("the model represents a planar motion");
        // The convention: the static world's motion explains its matches exactly.
        let p_static = estimator.params_from_motion(&static_m).expect("planar");
        let a = crate::separate::epipolar_angles(&rig, &estimator.motion(&p_static), &obs);
        assert!(a[0][..60].iter().all(|x| *x < 1e-9), "{:?}", &a[0][..5]);
        let o = opts();
        let (offsets, hist) = votes(&rig, estimator.as_ref(), &obs, &previous, None, &o);
        let m = modes(&offsets, &hist, &o, |_| false);
        let near = |deg: f64| {
            m.iter()
                .any(|m| (m.offset - deg.to_radians()).abs() <= 0.3f64.to_radians())
        };
        assert!(near(0.9) && near(-0.5), "{m:?}");
        // The bus's mode is the stronger one.
        assert!(
            (m[0].offset + 0.5f64.to_radians()).abs() <= 0.3f64.to_radians(),
            "{m:?}"
        );
        // Masked to the static matches, only the static mode is left.
        let mask = vec![(0..210).map(|i| i < 60).collect::<Vec<_>>()];
        let (_, hs) = votes(&rig, estimator.as_ref(), &obs, &previous, Some(&mask), &o);
        let ms = modes(&offsets, &hs, &o, |_| false);
        assert_eq!(ms.len(), 1, "{ms:?}");
        assert!((ms[0].offset - 0.9f64.to_radians()).abs() <= 0.3f64.to_radians());
        // `turned`: the previous motion's yaw plus the offset, its arc length kept.
        let t = turned(estimator.as_ref(), &previous, ms[0].offset).expect("turned");
        let yaw = |p: &[f64]| so3_log(&estimator.motion(p).rotation).z;
        assert!((yaw(&t) - yaw(&previous) - ms[0].offset).abs() < 1e-12);
        if let Some(i) = estimator.arc_length_index() {
            assert_eq!(t[i], previous[i]);
        }
    }
}
