//! # momo-eval
//!
//! Scores an estimated trajectory against ground truth, both as camera-0 poses in the KITTI
//! format (`FORMAT.md`):
//! - [`kitti_errors`]: the KITTI odometry devkit metric (`evaluate_odometry.cpp`): translational
//!   error in % and rotational error in deg/m, averaged over all sub-sequences of 100, 200, ...,
//!   800 m starting every 10 frames;
//! - [`frame_to_frame_rotation_errors`] and [`ErrorSummary`]: the rotation error of every
//!   frame-to-frame motion (mean, median, 95th percentile, max, count above 1 degree);
//! - [`ate`] and [`rpe`] (module [`trajectory`]): the absolute trajectory error after SE(3) or
//!   Sim(3) alignment (Umeyama) and the relative pose error at a delta in frames or metres,
//!   with the definitions of evo's `evo_ape` and `evo_rpe` (equal to 1e-6 on the fixtures of
//!   `tests/it/evo.rs`); [`Report`] gathers all of them for `momo eval`.
//!
//! ```
//! use momo_core::Pose;
//! use momo_eval::{ErrorSummary, frame_to_frame_rotation_errors};
//! use nalgebra::{Matrix3, Vector3};
//!
//! let gt: Vec<Pose<f64>> = (0..5).map(|k| Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, k as f64))).collect();
//! let errors = frame_to_frame_rotation_errors(&gt, &gt);
//! let s = ErrorSummary::from_values(&errors);
//! assert_eq!(s.count, 4);
//! assert!(s.max < 1e-9);
//! ```

use momo_core::{Pose, so3_log};
use serde::Serialize;

pub mod trajectory;

pub use trajectory::{Alignment, Ate, Delta, Rpe, Similarity, Stats, ate, rpe, rpe_pairs, umeyama};

/// The sub-sequence lengths of the KITTI devkit, metres.
pub const KITTI_LENGTHS: [f64; 8] = [100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0];

/// One sub-sequence error of the devkit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SegmentError {
    /// First frame of the sub-sequence.
    pub first_frame: usize,
    /// Rotational error per metre (rad/m).
    pub r_err: f64,
    /// Translational error per metre (m/m).
    pub t_err: f64,
    /// Sub-sequence length (m).
    pub length: f64,
    /// Mean speed over the sub-sequence (m/s at 10 Hz).
    pub speed: f64,
}

/// The devkit's averages.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KittiErrors {
    /// Every sub-sequence error.
    pub segments: Vec<SegmentError>,
    /// Mean translational error in percent.
    pub t_err_percent: f64,
    /// Mean rotational error in degrees per 100 m.
    pub r_err_deg_per_100m: f64,
    /// Per length (m): (length, t_err %, r_err deg/100 m, count).
    pub per_length: Vec<(f64, f64, f64, usize)>,
    /// Per speed as the devkit bins it (segments within 2 m/s of 2, 4, ..., 24 m/s):
    /// (speed, t_err %, r_err deg/100 m, count); empty bins are left out.
    pub per_speed: Vec<(f64, f64, f64, usize)>,
}

fn trajectory_distances(poses: &[Pose<f64>]) -> Vec<f64> {
    let mut d = Vec::with_capacity(poses.len());
    let mut acc = 0.0;
    for (i, p) in poses.iter().enumerate() {
        if i > 0 {
            acc += (p.translation - poses[i - 1].translation).norm();
        }
        d.push(acc);
    }
    d
}

/// Rotation angle of a pose as the devkit computes it: `acos(clamp((tr R - 1) / 2))`.
fn devkit_rotation_error(p: &Pose<f64>) -> f64 {
    (0.5 * (p.rotation.trace() - 1.0)).clamp(-1.0, 1.0).acos()
}

/// The KITTI devkit metric of `estimate` against `ground_truth` (same length; `None` if the
/// lengths differ or no sub-sequence of 100 m exists). `frame_rate` is 10 Hz on KITTI.
pub fn kitti_errors(ground_truth: &[Pose<f64>], estimate: &[Pose<f64>]) -> Option<KittiErrors> {
    if ground_truth.len() != estimate.len() || ground_truth.is_empty() {
        return None;
    }
    let dist = trajectory_distances(ground_truth);
    let mut segments = Vec::new();
    for first in (0..ground_truth.len()).step_by(10) {
        for &len in &KITTI_LENGTHS {
            let Some(last) = (first..dist.len()).find(|&i| dist[i] > dist[first] + len) else {
                continue;
            };
            let delta_gt = ground_truth[first].inverse().compose(&ground_truth[last]);
            let delta_est = estimate[first].inverse().compose(&estimate[last]);
            let err = delta_est.inverse().compose(&delta_gt);
            let frames = (last - first + 1) as f64;
            segments.push(SegmentError {
                first_frame: first,
                r_err: devkit_rotation_error(&err) / len,
                t_err: err.translation.norm() / len,
                length: len,
                speed: len / (0.1 * frames),
            });
        }
    }
    if segments.is_empty() {
        return None;
    }
    let n = segments.len() as f64;
    let t_err_percent = 100.0 * segments.iter().map(|s| s.t_err).sum::<f64>() / n;
    let r_err_deg_per_100m = 100.0 * segments.iter().map(|s| s.r_err).sum::<f64>().to_degrees() / n;
    let per_length = KITTI_LENGTHS
        .iter()
        .filter_map(|&len| {
            let s: Vec<_> = segments.iter().filter(|s| s.length == len).collect();
            (!s.is_empty()).then(|| {
                let c = s.len() as f64;
                (
                    len,
                    100.0 * s.iter().map(|e| e.t_err).sum::<f64>() / c,
                    100.0 * s.iter().map(|e| e.r_err).sum::<f64>().to_degrees() / c,
                    s.len(),
                )
            })
        })
        .collect();
    let per_speed = (1..=12)
        .filter_map(|k| {
            let speed = 2.0 * f64::from(k);
            let s: Vec<_> = segments
                .iter()
                .filter(|s| (s.speed - speed).abs() < 2.0)
                .collect();
            (!s.is_empty()).then(|| {
                let c = s.len() as f64;
                (
                    speed,
                    100.0 * s.iter().map(|e| e.t_err).sum::<f64>() / c,
                    100.0 * s.iter().map(|e| e.r_err).sum::<f64>().to_degrees() / c,
                    s.len(),
                )
            })
        })
        .collect();
    Some(KittiErrors {
        segments,
        t_err_percent,
        r_err_deg_per_100m,
        per_length,
        per_speed,
    })
}

/// The rotation error (degrees) of every frame-to-frame motion: the angle of
/// `R_gt(k-1,k)ᵀ R_est(k-1,k)` for k = 1..n (poses are absolute, e.g. camera 0 in frame 0).
pub fn frame_to_frame_rotation_errors(
    ground_truth: &[Pose<f64>],
    estimate: &[Pose<f64>],
) -> Vec<f64> {
    let n = ground_truth.len().min(estimate.len());
    (1..n)
        .map(|k| {
            let g = ground_truth[k - 1].inverse().compose(&ground_truth[k]);
            let e = estimate[k - 1].inverse().compose(&estimate[k]);
            so3_log(&(g.rotation.transpose() * e.rotation))
                .norm()
                .to_degrees()
        })
        .collect()
}

/// Summary statistics of a list of errors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ErrorSummary {
    /// Number of values.
    pub count: usize,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// 95th percentile (nearest rank).
    pub p95: f64,
    /// Maximum.
    pub max: f64,
    /// Values above 1 (degree): gross failures.
    pub above_one: usize,
}

impl ErrorSummary {
    /// Summarises the finite values of a list (NaN are ignored).
    pub fn from_values(values: &[f64]) -> Self {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let pct = |q: f64| {
            if n == 0 {
                f64::NAN
            } else {
                v[((q * n as f64).ceil() as usize).clamp(1, n) - 1]
            }
        };
        Self {
            count: n,
            mean: if n == 0 {
                f64::NAN
            } else {
                v.iter().sum::<f64>() / n as f64
            },
            median: if n == 0 {
                f64::NAN
            } else if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            },
            p95: pct(0.95),
            max: v.last().copied().unwrap_or(f64::NAN),
            above_one: v.iter().filter(|&&x| x > 1.0).count(),
        }
    }
}

/// The scores of one estimate against ground truth (what `momo eval` prints).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Evaluation {
    /// KITTI devkit translational error in percent (`None`: path shorter than 100 m).
    pub t_err_percent: Option<f64>,
    /// KITTI devkit rotational error in degrees per 100 m (`None`: path shorter than 100 m).
    pub r_err_deg_per_100m: Option<f64>,
    /// Frame-to-frame rotation errors in degrees.
    pub rotation_deg: ErrorSummary,
    /// Median over frame pairs of the Cramér-Rao bound of the rotation error angle (degrees,
    /// `bound.csv` of a simulated sequence); `None` without a bound.
    pub bound_deg: Option<f64>,
    /// Efficiency `rotation_deg.median / bound_deg` (1 = at the bound); `None` without a bound.
    pub efficiency: Option<f64>,
}

/// Scores `estimate` against `ground_truth` (same length, camera-0 poses).
pub fn evaluate(ground_truth: &[Pose<f64>], estimate: &[Pose<f64>]) -> Evaluation {
    let kitti = kitti_errors(ground_truth, estimate);
    Evaluation {
        t_err_percent: kitti.as_ref().map(|k| k.t_err_percent),
        r_err_deg_per_100m: kitti.as_ref().map(|k| k.r_err_deg_per_100m),
        rotation_deg: ErrorSummary::from_values(&frame_to_frame_rotation_errors(
            ground_truth,
            estimate,
        )),
        bound_deg: None,
        efficiency: None,
    }
}

/// [`evaluate`] plus the bound and the efficiency: `bounds[k]` is frame pair k's bound in
/// degrees ([`parse_bound_csv`]); the bound is the median of the defined ones (frame pairs
/// `1..n` of the ground truth), the efficiency the error median over it.
pub fn evaluate_with_bound(
    ground_truth: &[Pose<f64>],
    estimate: &[Pose<f64>],
    bounds: &[Option<f64>],
) -> Evaluation {
    let mut e = evaluate(ground_truth, estimate);
    let defined: Vec<f64> = bounds
        .iter()
        .take(ground_truth.len())
        .skip(1)
        .flatten()
        .copied()
        .collect();
    if !defined.is_empty() {
        let b = ErrorSummary::from_values(&defined).median;
        e.bound_deg = Some(b);
        e.efficiency = (b > 0.0).then(|| e.rotation_deg.median / b);
    }
    e
}

/// A malformed `bound.csv` line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {reason}")]
pub struct BoundCsvError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong.
    pub reason: String,
}

/// Parses `bound.csv` (`docs/FORMAT.md`, version 3): header
/// `frame,rotation_bound_deg[,...]`, then `k,bound[,...]` rows with an empty bound where it is
/// undefined. Returns `bounds[k]` for k = 0..=max frame (`None` where no row or no value).
///
/// ```
/// let b = momo_eval::parse_bound_csv("frame,rotation_bound_deg,static_matches\n1,0.04,150\n2,,3\n")?;
/// assert_eq!(b, vec![None, Some(0.04), None]);
/// assert!(momo_eval::parse_bound_csv("frame,rotation_bound_deg\n1,-2\n").is_err());
/// # Ok::<(), momo_eval::BoundCsvError>(())
/// ```
pub fn parse_bound_csv(text: &str) -> Result<Vec<Option<f64>>, BoundCsvError> {
    let err = |line: usize, reason: String| BoundCsvError { line, reason };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim().starts_with("frame,rotation_bound_deg") => {}
        _ => {
            return Err(err(
                1,
                "expected the header `frame,rotation_bound_deg,...`".into(),
            ));
        }
    }
    let mut out: Vec<Option<f64>> = Vec::new();
    for (i, line) in lines {
        let line_no = i + 1;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let mut fields = line.split(',');
        let frame: usize = fields
            .next()
            .and_then(|f| f.trim().parse().ok())
            .ok_or_else(|| err(line_no, "frame is not a non-negative integer".into()))?;
        if frame > 10_000_000 {
            return Err(err(line_no, format!("frame {frame} is too large")));
        }
        let value = match fields.next().map(str::trim) {
            None => return Err(err(line_no, "missing rotation_bound_deg".into())),
            Some("") => None,
            Some(v) => match v.parse::<f64>() {
                Ok(x) if x.is_finite() && x >= 0.0 => Some(x),
                _ => {
                    return Err(err(
                        line_no,
                        format!("rotation_bound_deg `{v}` is not a non-negative number"),
                    ));
                }
            },
        };
        if out.len() <= frame {
            out.resize(frame + 1, None);
        }
        out[frame] = value;
    }
    Ok(out)
}

/// Everything `momo eval` reports for one estimate: ATE after SE(3) and Sim(3) alignment, RPE
/// at one delta, the KITTI devkit (when the path has 100 m) and the frame-to-frame rotation
/// errors.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    /// ATE after rigid alignment (`None`: fewer than 2 frames or a standing estimate).
    pub ate_se3: Option<Ate>,
    /// ATE after similarity alignment.
    pub ate_sim3: Option<Ate>,
    /// RPE at the chosen delta (`None`: no pair at that delta).
    pub rpe: Option<Rpe>,
    /// The KITTI devkit (`None`: path shorter than 100 m).
    pub kitti: Option<KittiErrors>,
    /// Frame-to-frame rotation errors in degrees.
    pub rotation_deg: ErrorSummary,
}

/// Scores `estimate` against `ground_truth` (same length, frame k with frame k) with every
/// metric; `delta` is the RPE's.
pub fn report(ground_truth: &[Pose<f64>], estimate: &[Pose<f64>], delta: Delta) -> Report {
    Report {
        ate_se3: ate(ground_truth, estimate, Alignment::Se3),
        ate_sim3: ate(ground_truth, estimate, Alignment::Sim3),
        rpe: rpe(ground_truth, estimate, delta),
        kitti: kitti_errors(ground_truth, estimate),
        rotation_deg: ErrorSummary::from_values(&frame_to_frame_rotation_errors(
            ground_truth,
            estimate,
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::so3_exp;
    use nalgebra::{Matrix3, Vector3};

    fn straight(n: usize, step: f64) -> Vec<Pose<f64>> {
        (0..n)
            .map(|k| Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, k as f64 * step)))
            .collect()
    }

    #[test]
    fn perfect_estimate_has_zero_error() {
        let gt = straight(400, 1.0);
        let e = kitti_errors(&gt, &gt).expect("long enough");
        assert!(e.t_err_percent < 1e-12 && e.r_err_deg_per_100m < 1e-9);
        assert_eq!(e.per_length.len(), 3); // 100, 200, 300 m fit in 399 m
    }

    #[test]
    fn scaled_estimate_has_the_scale_error() {
        let gt = straight(400, 1.0);
        let est = straight(400, 1.01);
        let e = kitti_errors(&gt, &est).expect("long enough");
        // A 1 % scale error; segments end at the first frame *beyond* the length, so slightly
        // more than 1 m per 100 m.
        assert!((e.t_err_percent - 1.0).abs() < 0.02, "{}", e.t_err_percent);
    }

    #[test]
    fn frame_to_frame_rotation_error_sees_a_yaw_bias() {
        let gt = straight(10, 1.0);
        let mut est = gt.clone();
        let r = so3_exp(&Vector3::new(0.0, 0.01_f64.to_radians(), 0.0));
        for k in 1..10 {
            let step = Pose::new(r, Vector3::new(0.0, 0.0, 1.0));
            est[k] = est[k - 1].compose(&step);
        }
        let s = ErrorSummary::from_values(&frame_to_frame_rotation_errors(&gt, &est));
        assert!((s.median - 0.01).abs() < 1e-9);
        assert_eq!(s.above_one, 0);
    }

    #[test]
    fn summary_percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = ErrorSummary::from_values(&v);
        assert_eq!(s.p95, 95.0);
        assert_eq!(s.median, 50.5);
        assert_eq!(s.above_one, 99);
    }
}
