//! Metric scale from cross-camera matches (`FORMAT.md` version 5, column `camera_to`).
//!
//! A match between camera i at frame k-1 and camera j at frame k sees the camera motion
//! `C_ij = P_i⁻¹ M P_j`. For a stereo rig `C_ij` contains the baseline, a length the rig knows,
//! so the arc length `l` of `M` is observable from these matches even where the matches of each
//! camera alone (`C_j = P_j⁻¹ M P_j`) only see the direction of travel. [`measure_arc_length`]
//! holds every other parameter of the motion at the value the per-camera matches gave and
//! finds `l` by a one-dimensional robust fit of the cross-camera matches' residuals (the
//! AnglePlane residual: the sine of the angle between `R f1` and the epipolar plane of `t` and
//! `f0`, with `C_ij = [R | t]`), under a Cauchy loss: a grid over `l` (both signs if asked),
//! then golden-section refinement around the best grid point. Its standard deviation is the
//! Gauss-Newton one of the robust fit, with a frame-wide disparity offset marginalised: the
//! second camera of the pair yawed by an unknown `β` (a rectification offset shared by all
//! matches of the frame, which the per-match residual spread does not show), so
//! `σ_l² = σ_r² (I⁻¹)_ll` with `I = Σ w_i [∂r_i/∂l, ∂r_i/∂β]ᵀ[∂r_i/∂l, ∂r_i/∂β]`, `w_i` the
//! Cauchy weights and `σ_r²` the weighted residual variance (the estimate keeps `β = 0`:
//! estimating it per frame moved KITTI 01's t_err from 2.92 to 1.78 % but KITTI 06's from 0.95
//! to 1.24 % and KITTI 00's mean error from -0.5 to -1.8 %). On real data this took the mean
//! (err/σ)² from 60-64 to 19-20 (KITTI 00), 20.4 to 2.4 (KITTI 01), 2.6 to 0.27 (KITTI 06).
//! That is the sigma with the other parameters known; the odometry adds their uncertainty (their covariance from the
//! per-camera solve, propagated through [`refit_arc_length`] along its principal axes), which
//! on simulated stereo data is the larger part.

use momo_core::{CrossObservation, Pose, Rig, cross_camera_motion};

/// The arc length measured from the cross-camera matches of one frame pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossScale {
    /// Arc length `l`, metres (negative: reversing).
    pub arc_length: f64,
    /// Its standard deviation, metres.
    pub sigma: f64,
    /// Cross-camera matches within the inlier angle at `l`.
    pub inliers: usize,
    /// Cross-camera matches used.
    pub matches: usize,
}

/// Fewest cross-camera inliers for a measurement.
pub const MIN_CROSS_INLIERS: usize = 8;

/// The AnglePlane residual of a cross-camera match under `C_ij`: the sine of the angle between
/// `R f1` and the plane of `t` and `f0` (0 if `t` is parallel to `f0`).
fn residual(c: &Pose<f64>, x: &CrossObservation) -> f64 {
    let n = c.translation.cross(&x.obs.f0);
    let nn = n.norm();
    if nn == 0.0 {
        return 0.0;
    }
    (c.rotation * x.obs.f1).dot(&n) / (nn * x.obs.f1.norm())
}

/// `x` with the bearing of its higher-numbered camera (the second camera of a stereo pair)
/// turned by `beta` about that camera's vertical (y) axis.
fn yawed(x: &CrossObservation, beta: f64) -> CrossObservation {
    let (s, c) = beta.sin_cos();
    let r = nalgebra::Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c);
    let mut y = *x;
    if x.camera_to > x.camera {
        y.obs.f1 = r * x.obs.f1;
    } else {
        y.obs.f0 = r * x.obs.f0;
    }
    y
}

/// Measures the arc length from `cross` (see the [module docs](self)). `motion_of(l)` is the
/// vehicle motion with arc length `l` and every other parameter held; `inlier_angle` (radians)
/// is the Cauchy scale and the inlier threshold; the search covers `|l|` up to `max_arc_length`
/// (and `l <= 0` only if `signed`). `None` with fewer than [`MIN_CROSS_INLIERS`] inliers, a
/// minimum at the end of the search range, or a non-finite result.
pub fn measure_arc_length(
    rig: &Rig,
    cross: &[CrossObservation],
    motion_of: impl Fn(f64) -> Pose<f64>,
    inlier_angle: f64,
    max_arc_length: f64,
    signed: bool,
) -> Option<CrossScale> {
    let cams = rig.cameras();
    let usable: Vec<&CrossObservation> = cross
        .iter()
        .filter(|x| x.camera < cams.len() && x.camera_to < cams.len())
        .collect();
    if usable.len() < MIN_CROSS_INLIERS || !(inlier_angle > 0.0) || !(max_arc_length > 0.0) {
        return None;
    }
    let b2 = inlier_angle * inlier_angle;
    let residuals = |l: f64, out: &mut Vec<f64>| {
        out.clear();
        let m = motion_of(l);
        for x in &usable {
            let c = cross_camera_motion(
                &m,
                &cams[x.camera].t_vehicle_camera,
                &cams[x.camera_to].t_vehicle_camera,
            );
            out.push(residual(&c, x));
        }
    };
    let mut r = Vec::with_capacity(usable.len());
    let mut cost = |l: f64| {
        residuals(l, &mut r);
        r.iter().map(|v| b2 * (v * v / b2).ln_1p()).sum::<f64>()
    };
    // The grid: 0 and a geometric ladder from 1 cm up to max_arc_length (both signs if asked).
    let steps = 80;
    let lo: f64 = 0.01_f64.min(max_arc_length);
    let ratio = (max_arc_length / lo).powf(1.0 / steps as f64);
    let mut grid: Vec<f64> = (0..=steps).map(|s| lo * ratio.powi(s)).collect();
    if signed {
        let neg: Vec<f64> = grid.iter().rev().map(|l| -l).collect();
        grid = neg.into_iter().chain([0.0]).chain(grid).collect();
    } else {
        grid.insert(0, 0.0);
    }
    let costs: Vec<f64> = grid.iter().map(|&l| cost(l)).collect();
    let best = costs
        .iter()
        .enumerate()
        .filter(|(_, c)| c.is_finite())
        .min_by(|a, b| a.1.total_cmp(b.1))?
        .0;
    if best == 0 || best + 1 == grid.len() {
        return None;
    }
    let l = golden(&mut cost, grid[best - 1], grid[best + 1]);
    // Gauss-Newton standard deviation of the robust fit.
    let h = 1e-4 * (1.0 + l.abs());
    let (mut r0, mut rp, mut rm) = (Vec::new(), Vec::new(), Vec::new());
    residuals(l, &mut r0);
    residuals(l + h, &mut rp);
    residuals(l - h, &mut rm);
    let (mut info, mut wsum, mut wr2) = (0.0, 0.0, 0.0);
    let mut inliers = 0;
    for k in 0..r0.len() {
        let w = 1.0 / (1.0 + r0[k] * r0[k] / b2);
        let dr = (rp[k] - rm[k]) / (2.0 * h);
        info += w * dr * dr;
        wsum += w;
        wr2 += w * r0[k] * r0[k];
        if r0[k].abs() <= inlier_angle {
            inliers += 1;
        }
    }
    if inliers < MIN_CROSS_INLIERS || !(info > 0.0) || wsum <= 1.0 {
        return None;
    }
    let sigma_r2 = wr2 / (wsum - 1.0);
    let sigma = {
        // A disparity offset shared by all matches of the frame (rectification, calibration):
        // the second camera yawed by `beta` about its vertical axis. Its uncertainty is
        // marginalised (beta free in the information matrix); the estimate keeps beta = 0.
        let hb = 1e-5;
        let m = motion_of(l);
        let (mut ill, mut ilb, mut ibb) = (0.0, 0.0, 0.0);
        for (k, x) in usable.iter().enumerate() {
            let c = cross_camera_motion(
                &m,
                &cams[x.camera].t_vehicle_camera,
                &cams[x.camera_to].t_vehicle_camera,
            );
            let rb = |b: f64| residual(&c, &yawed(x, b));
            let db = (rb(hb) - rb(-hb)) / (2.0 * hb);
            let w = 1.0 / (1.0 + r0[k] * r0[k] / b2);
            let dl = (rp[k] - rm[k]) / (2.0 * h);
            ill += w * dl * dl;
            ilb += w * dl * db;
            ibb += w * db * db;
        }
        let det = ill * ibb - ilb * ilb;
        if !(ibb > 0.0) {
            // The offset moves no residual: the one-dimensional sigma.
            (sigma_r2 / info).sqrt()
        } else if det > 1e-12 * ill * ibb {
            (sigma_r2 * ibb / det).sqrt()
        } else {
            // The offset and the arc length cannot be told apart.
            f64::INFINITY
        }
    };
    (l.is_finite() && sigma.is_finite()).then_some(CrossScale {
        arc_length: l,
        sigma,
        inliers,
        matches: usable.len(),
    })
}

/// The robust fit of [`measure_arc_length`] restricted to `lo..=hi` (golden-section search
/// only, no grid): how the arc length moves when the other parameters move, for propagating
/// their uncertainty.
pub fn refit_arc_length(
    rig: &Rig,
    cross: &[CrossObservation],
    motion_of: impl Fn(f64) -> Pose<f64>,
    inlier_angle: f64,
    lo: f64,
    hi: f64,
) -> f64 {
    let cams = rig.cameras();
    let b2 = inlier_angle * inlier_angle;
    let mut cost = |l: f64| {
        let m = motion_of(l);
        cross
            .iter()
            .filter(|x| x.camera < cams.len() && x.camera_to < cams.len())
            .map(|x| {
                let c = cross_camera_motion(
                    &m,
                    &cams[x.camera].t_vehicle_camera,
                    &cams[x.camera_to].t_vehicle_camera,
                );
                let r = residual(&c, x);
                b2 * (r * r / b2).ln_1p()
            })
            .sum::<f64>()
    };
    golden(&mut cost, lo, hi)
}

/// Golden-section search for the minimum of `cost` in `a..=b`.
fn golden(cost: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> f64 {
    let (mut a, mut b) = (a, b);
    let g = 0.5 * (5.0_f64.sqrt() - 1.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (cost(c), cost(d));
    for _ in 0..60 {
        if (b - a).abs() <= 1e-6 * (1.0 + a.abs().max(b.abs())) {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = cost(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = cost(d);
        }
    }
    0.5 * (a + b)
}
