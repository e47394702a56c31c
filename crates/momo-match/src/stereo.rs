//! Cross-camera matches of a rectified stereo pair (`FORMAT.md` version 5, column `camera_to`):
//! the source of metric scale for `momo vo` and `momo match` on a stereo rig.
//!
//! For each match of camera `i` between frames k-1 and k (the per-camera [`Match`]es of the
//! [`crate::FrameMatcher`]), the pixel of the same scene point in camera `j` at frame k is
//! found in two steps:
//!
//! 1. *Epipolar-row stereo match* at frame k: camera i's descriptor at the match's frame-k
//!    pixel (rounded) is compared (SAD) with camera j's descriptors along the same row, over the
//!    disparities of points between [`StereoOptions::min_depth`] and infinity (`d = f b / Z`,
//!    `b` the baseline along the row). The best must be unique (its SAD at most
//!    [`StereoOptions::uniqueness`] times the best SAD more than two pixels away) and pass the
//!    circular check (searched back along camera i's row, it lands within one pixel).
//! 2. *KLT*: camera i's patch at frame k-1 (the match's integer pixel) is aligned with camera
//!    j's image at frame k from that start ([`refine_match`], forward-backward checked), so the
//!    cross-camera match `(i at k-1, j at k)` is as precise as the per-camera ones. It is kept
//!    if the frame-k end stays on camera i's row (within [`StereoOptions::max_row_error`]) and
//!    inside the disparity range.
//!
//! Only *rectified* pairs are matched ([`rectified_pairs`]): two pinhole cameras of the same size
//! and focal lengths and principal row, the same orientation, and the second camera's centre on
//! the first one's x axis (KITTI's `image_0` / `image_1`). Both directions are used: `(0, 1)`
//! gives left(k-1)-right(k) and `(1, 0)` right(k-1)-left(k), as `momo import-kitti --stereo`
//! writes them from the 4-view matches.

use crate::features::{BORDER, FrameFeatures, sad};
use crate::matcher::Match;
use crate::refine::{KltOptions, refine_match};
use momo_core::{CrossObservation, Observation, Rig};
use nalgebra::Vector2;

/// Options of the stereo (cross-camera) matching.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoOptions {
    /// Nearest depth searched, metres (sets the largest disparity `f b / min_depth`).
    pub min_depth: f64,
    /// Largest disparity searched, pixels, whatever `min_depth` gives.
    pub max_disparity: u32,
    /// Smallest disparity kept, pixels. A fixed sub-pixel error `δ` of the disparity
    /// (rectification, calibration) becomes a relative error `δ / d` of the metric scale, so
    /// far points (small `d`) are dropped. On the real KITTI 01 snippet (highway, ground truth
    /// rotation held) the cross-camera matches alone put the arc length 15.6 % too long from
    /// `d < 10`, 6.5 % from `10 <= d < 25` and 1.1 % from `d >= 25` px (KITTI 06: 1.9 %,
    /// 0.4 %, -0.5 %); 20 px on KITTI is a depth of about 19 m.
    pub min_disparity: f64,
    /// Largest accepted SAD of two 32-byte descriptors.
    pub max_sad: u32,
    /// The best SAD must be at most this fraction of the best one more than two pixels away.
    pub uniqueness: f64,
    /// Largest row difference of the two frame-k ends after the KLT, pixels.
    pub max_row_error: f64,
    /// The KLT alignment of frame k-1's patch with the other camera's frame k.
    pub klt: KltOptions,
}

impl Default for StereoOptions {
    fn default() -> Self {
        Self {
            min_depth: 2.0,
            max_disparity: 256,
            min_disparity: 20.0,
            max_sad: 32 * 40,
            uniqueness: 0.8,
            max_row_error: 1.0,
            klt: KltOptions::default(),
        }
    }
}

/// A rectified ordered camera pair `(from, to)` of a rig.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StereoPair {
    /// Camera `i`: the frame-k-1 end of a cross-camera match.
    pub from: usize,
    /// Camera `j`: the frame-k end.
    pub to: usize,
    /// `+1` if a point appears at a smaller column in `to` than in `from` (`to` sits to the
    /// right of `from`), `-1` otherwise.
    pub direction: i32,
    /// `cx_from - cx_to`, pixels: the disparity of a point at infinity.
    pub offset: f64,
    /// Largest disparity searched, pixels.
    pub max_disparity: u32,
}

/// Relative tolerance on the focal lengths of a rectified pair and on the baseline's
/// components off the row direction.
const RECTIFIED_TOLERANCE: f64 = 1e-3;

/// The rectified ordered pairs of `rig` (see the [module docs](self)), both directions.
pub fn rectified_pairs(rig: &Rig, options: &StereoOptions) -> Vec<StereoPair> {
    let cams = rig.cameras();
    let mut pairs = Vec::new();
    for (i, ci) in cams.iter().enumerate() {
        for (j, cj) in cams.iter().enumerate() {
            if i == j {
                continue;
            }
            let (Some(a), Some(b)) = (ci.model.as_pinhole(), cj.model.as_pinhole()) else {
                continue;
            };
            let rel = ci.t_vehicle_camera.inverse().compose(&cj.t_vehicle_camera);
            let rot_err = (rel.rotation - nalgebra::Matrix3::identity()).norm();
            let t = rel.translation;
            let same = |x: f64, y: f64| (x - y).abs() <= RECTIFIED_TOLERANCE * x.abs().max(1.0);
            let rectified = same(a.fx, b.fx)
                && same(a.fy, b.fy)
                && (a.cy - b.cy).abs() <= 0.05
                && a.width == b.width
                && a.height == b.height
                && rot_err <= RECTIFIED_TOLERANCE
                && t.x.abs() > 0.0
                && t.y.hypot(t.z) <= RECTIFIED_TOLERANCE * t.x.abs();
            if !rectified || !(options.min_depth > 0.0) {
                continue;
            }
            let d = (a.fx * t.x.abs() / options.min_depth).ceil();
            let max_disparity = d.min(f64::from(options.max_disparity)).min(a.width) as u32;
            pairs.push(StereoPair {
                from: i,
                to: j,
                direction: if t.x > 0.0 { 1 } else { -1 },
                offset: a.cx - b.cx,
                max_disparity,
            });
        }
    }
    pairs
}

/// The best and second best (more than two pixels away) SAD of `desc` along row `v` of
/// `frame`, at columns `u0 + sign * s`, `s` in `0..=max`: `(column, best, second)`.
fn row_search(
    frame: &FrameFeatures,
    desc: &crate::features::Descriptor,
    u0: i64,
    v: usize,
    sign: i64,
    max: u32,
) -> Option<(usize, u32, u32)> {
    let (lo, hi) = (BORDER as i64, (frame.width - BORDER) as i64);
    let mut scores: Vec<(usize, u32)> = Vec::with_capacity(max as usize + 1);
    for s in 0..=i64::from(max) {
        let u = u0 + sign * s;
        if u < lo || u >= hi {
            continue;
        }
        let u = u as usize;
        scores.push((u, sad(desc, &frame.descriptor_at(u, v))));
    }
    let &(best_u, best) = scores.iter().min_by_key(|(u, s)| (*s, *u))?;
    let second = scores
        .iter()
        .filter(|(u, _)| u.abs_diff(best_u) > 2)
        .map(|(_, s)| *s)
        .min()
        .unwrap_or(u32::MAX);
    Some((best_u, best, second))
}

/// The column of camera `to`'s frame-k pixel on row `v` that matches camera `from`'s frame-k
/// pixel `(u, v)` (the epipolar-row stereo match of the [module docs](self)), if it is unique
/// and passes the circular check.
pub fn stereo_column(
    pair: &StereoPair,
    cur_from: &FrameFeatures,
    cur_to: &FrameFeatures,
    u: usize,
    v: usize,
    options: &StereoOptions,
) -> Option<usize> {
    let inside = |f: &FrameFeatures| {
        f.width > 2 * BORDER
            && f.height > 2 * BORDER
            && u >= BORDER
            && v >= BORDER
            && u < f.width - BORDER
            && v < f.height - BORDER
    };
    if !inside(cur_from) || !inside(cur_to) {
        return None;
    }
    let sign = i64::from(pair.direction);
    // Column of a point at infinity in `to`.
    let start = u as i64 - pair.offset.round() as i64;
    let desc = cur_from.descriptor_at(u, v);
    let (uj, best, second) = row_search(cur_to, &desc, start, v, -sign, pair.max_disparity)?;
    if best > options.max_sad || f64::from(best) > options.uniqueness * f64::from(second) {
        return None;
    }
    // Circular check: back along `from`'s row.
    let back = cur_to.descriptor_at(uj, v);
    let start_back = uj as i64 + pair.offset.round() as i64;
    let (ui, _, _) = row_search(cur_from, &back, start_back, v, sign, pair.max_disparity)?;
    (ui.abs_diff(u) <= 1).then_some(uj)
}

/// The cross-camera matches `(pair.from at k-1, pair.to at k)` of one frame pair, from camera
/// `pair.from`'s matches `temporal` of `(k-1, k)` (see the [module docs](self)). `prev_from`,
/// `cur_from`: camera `from`'s features at k-1 and k; `cur_to`: camera `to`'s at k.
pub fn cross_matches(
    pair: &StereoPair,
    prev_from: &FrameFeatures,
    cur_from: &FrameFeatures,
    cur_to: &FrameFeatures,
    temporal: &[Match],
    options: &StereoOptions,
) -> Vec<Match> {
    if prev_from.plane().px.is_empty() || cur_to.plane().px.is_empty() {
        return Vec::new();
    }
    let sign = f64::from(pair.direction);
    temporal
        .iter()
        .filter_map(|m| {
            if !(m.u0 >= 0.0 && m.v0 >= 0.0 && m.u1 >= 0.0 && m.v1 >= 0.0) {
                return None;
            }
            let (u1, v1) = (m.u1.round() as usize, m.v1.round() as usize);
            let uj = stereo_column(pair, cur_from, cur_to, u1, v1, options)?;
            let p0 = (m.u0.round() as usize, m.v0.round() as usize);
            let [u0, v0, ur, vr] = refine_match(
                prev_from.plane(),
                cur_to.plane(),
                p0,
                (uj, v1),
                &options.klt,
            )?;
            let disparity = sign * (m.u1 - ur) - pair.offset * sign;
            let ok = (vr - m.v1).abs() <= options.max_row_error
                && disparity >= options.min_disparity.max(-1.0)
                && disparity <= f64::from(pair.max_disparity) + 1.0;
            ok.then_some(Match {
                u0,
                v0,
                u1: ur,
                v1: vr,
                sad: m.sad,
            })
        })
        .collect()
}

/// The cross-camera observations of `matches` (pixels of camera `pair.from` at k-1 and of
/// `pair.to` at k), unprojected through the rig's cameras; pixels that cannot be unprojected
/// are dropped.
pub fn cross_observations(
    rig: &Rig,
    pair: &StereoPair,
    matches: &[Match],
) -> Vec<CrossObservation> {
    let cams = rig.cameras();
    let (Some(a), Some(b)) = (cams.get(pair.from), cams.get(pair.to)) else {
        return Vec::new();
    };
    matches
        .iter()
        .filter_map(|m| {
            let px0 = Vector2::new(m.u0, m.v0);
            let px1 = Vector2::new(m.u1, m.v1);
            use momo_core::CameraModel;
            Some(CrossObservation {
                camera: pair.from,
                camera_to: pair.to,
                obs: Observation {
                    px0,
                    px1,
                    f0: a.model.unproject(&px0)?,
                    f1: b.model.unproject(&px1)?,
                },
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::DetectorOptions;
    use crate::matcher::{MatchOptions, match_features};
    use crate::synthetic;
    use momo_core::{Camera, Pinhole, Pose, RigCamera};
    use nalgebra::{Matrix3, Vector3};

    fn camera(t: Vector3<f64>) -> RigCamera {
        RigCamera {
            name: "cam".into(),
            model: Camera::Pinhole(Pinhole {
                fx: 500.0,
                fy: 500.0,
                cx: 320.0,
                cy: 240.0,
                width: 640.0,
                height: 480.0,
            }),
            // Looking forward along the vehicle's x axis (camera x = -vehicle y).
            t_vehicle_camera: Pose::new(
                Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
                t,
            ),
        }
    }

    #[test]
    fn rectified_pairs_of_a_stereo_rig_and_none_of_a_toed_in_one() {
        let left = camera(Vector3::new(1.0, 0.0, 1.5));
        let right = camera(Vector3::new(1.0, -0.5, 1.5));
        let rig = Rig::new(vec![left.clone(), right.clone()]).expect("rig");
        let pairs = rectified_pairs(&rig, &StereoOptions::default());
        assert_eq!(pairs.len(), 2);
        assert_eq!((pairs[0].from, pairs[0].to, pairs[0].direction), (0, 1, 1));
        assert_eq!((pairs[1].from, pairs[1].to, pairs[1].direction), (1, 0, -1));
        // 500 px * 0.5 m / 2 m.
        assert_eq!(pairs[0].max_disparity, 125);
        // The right camera turned by 1 degree about its vertical axis: not rectified.
        let mut toed = right;
        let a = 1f64.to_radians();
        let turn = Matrix3::new(a.cos(), 0.0, a.sin(), 0.0, 1.0, 0.0, -a.sin(), 0.0, a.cos());
        toed.t_vehicle_camera.rotation *= turn;
        let rig = Rig::new(vec![left, toed]).expect("rig");
        assert!(rectified_pairs(&rig, &StereoOptions::default()).is_empty());
    }

    /// A fronto-parallel textured plane: the right image is the left one shifted by the
    /// disparity, frame k-1 is frame k shifted by the flow; every cross-camera match must join
    /// `p` in the left image at k-1 with `p + flow - disparity` in the right image at k.
    #[test]
    fn cross_matches_on_a_plane_have_flow_plus_disparity() {
        let (disparity, flow) = (31.0, (-4.0, 2.0));
        let left_k = synthetic::dead_leaves(640, 480, 4000, 3);
        let shift = |du: f64, dv: f64| Matrix3::new(1.0, 0.0, du, 0.0, 1.0, dv, 0.0, 0.0, 1.0);
        let right_k = synthetic::warp(&left_k, &shift(-disparity, 0.0)).expect("warp");
        let left_prev = synthetic::warp(&left_k, &shift(-flow.0, -flow.1)).expect("warp");
        let det = DetectorOptions::default();
        let mut f = [
            FrameFeatures::default(),
            FrameFeatures::default(),
            FrameFeatures::default(),
        ];
        f[0].extract(&left_prev, &det);
        f[1].extract(&left_k, &det);
        f[2].extract(&right_k, &det);
        let temporal = match_features(&f[0], &f[1], &MatchOptions::default());
        assert!(temporal.len() > 100, "{} temporal matches", temporal.len());
        let pair = StereoPair {
            from: 0,
            to: 1,
            direction: 1,
            offset: 0.0,
            max_disparity: 100,
        };
        let options = StereoOptions::default();
        let cross = cross_matches(&pair, &f[0], &f[1], &f[2], &temporal, &options);
        assert!(
            cross.len() * 10 >= temporal.len() * 7,
            "{} cross matches of {}",
            cross.len(),
            temporal.len()
        );
        for m in &cross {
            let (eu, ev) = (m.u0 + flow.0 - disparity, m.v0 + flow.1);
            assert!(
                (m.u1 - eu).hypot(m.v1 - ev) < 0.3,
                "{m:?}: expected ({eu}, {ev})"
            );
        }
        // Far points (disparity below the minimum) are dropped.
        let far = StereoOptions {
            min_disparity: 40.0,
            ..options
        };
        assert!(cross_matches(&pair, &f[0], &f[1], &f[2], &temporal, &far).is_empty());
    }
}
