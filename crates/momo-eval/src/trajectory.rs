//! Absolute and relative trajectory errors as evo computes them (`evo_ape`, `evo_rpe`):
//!
//! - [`umeyama`]: the least-squares similarity (or rigid motion) mapping the estimated positions
//!   onto the ground-truth positions (Umeyama 1991), as `evo`'s `umeyama_alignment`;
//! - [`ate`]: the absolute trajectory error, the distance between ground-truth and aligned
//!   estimated positions per frame, with [`Alignment::None`], [`Alignment::Se3`] or
//!   [`Alignment::Sim3`];
//! - [`rpe`]: the relative pose error `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` over frame pairs
//!   `(i, j)` at a distance `delta` in frames or metres of path (evo's default,
//!   non-overlapping pairs), its translation norm and rotation angle;
//! - [`Stats`]: RMSE, mean, median, standard deviation, min, max and sum of squares, as evo
//!   reports them.

use momo_core::{Pose, so3_log};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// Statistics of an error list, with evo's definitions (`std` is the population standard
/// deviation, `median` the mean of the two middle values for an even count).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub median: f64,
    /// Population standard deviation.
    pub std: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
    /// Sum of squares.
    pub sse: f64,
}

impl Stats {
    /// The statistics of `values` (all NaN when empty).
    pub fn from_values(values: &[f64]) -> Self {
        let n = values.len();
        if n == 0 {
            return Self {
                count: 0,
                rmse: f64::NAN,
                mean: f64::NAN,
                median: f64::NAN,
                std: f64::NAN,
                min: f64::NAN,
                max: f64::NAN,
                sse: f64::NAN,
            };
        }
        let nf = n as f64;
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let sse: f64 = values.iter().map(|x| x * x).sum();
        let mean = values.iter().sum::<f64>() / nf;
        let var = values.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / nf;
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Self {
            count: n,
            rmse: (sse / nf).sqrt(),
            mean,
            median,
            std: var.sqrt(),
            min: v[0],
            max: v[n - 1],
            sse,
        }
    }
}

/// A similarity transform `x ↦ s R x + t` (`s = 1` for a rigid motion).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Similarity {
    /// Rotation `R`.
    pub rotation: Matrix3<f64>,
    /// Translation `t`.
    pub translation: Vector3<f64>,
    /// Scale `s`.
    pub scale: f64,
}

impl Similarity {
    /// The identity.
    pub fn identity() -> Self {
        Self {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            scale: 1.0,
        }
    }

    /// Applies the transform to a point.
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * (self.scale * p) + self.translation
    }

    /// Applies the transform to a pose: the position as [`apply`](Self::apply), the
    /// orientation rotated by `R`.
    pub fn apply_pose(&self, p: &Pose<f64>) -> Pose<f64> {
        Pose::new(self.rotation * p.rotation, self.apply(&p.translation))
    }
}

/// The alignment applied to the estimate before the absolute error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Alignment {
    /// None: the estimate as given (both start at the identity in the KITTI convention).
    None,
    /// Rigid motion (SE(3), Umeyama without scale; `evo_ape -a`).
    Se3,
    /// Similarity (Sim(3), Umeyama with scale; `evo_ape -as`): for monocular estimates.
    Sim3,
}

/// The transform `x ↦ s R x + t` minimising `Σ |y_i - (s R x_i + t)|²` (Umeyama 1991), with
/// `s = 1` unless `with_scale`. `None` with fewer than two points, different lengths or a
/// degenerate (all equal) `x`.
pub fn umeyama(x: &[Vector3<f64>], y: &[Vector3<f64>], with_scale: bool) -> Option<Similarity> {
    let n = x.len();
    if n < 2 || y.len() != n {
        return None;
    }
    let nf = n as f64;
    let mean_x = x.iter().sum::<Vector3<f64>>() / nf;
    let mean_y = y.iter().sum::<Vector3<f64>>() / nf;
    let sigma_x = x.iter().map(|p| (p - mean_x).norm_squared()).sum::<f64>() / nf;
    if sigma_x <= 0.0 || !sigma_x.is_finite() {
        return None;
    }
    let mut cov = Matrix3::zeros();
    for (px, py) in x.iter().zip(y) {
        cov += (py - mean_y) * (px - mean_x).transpose();
    }
    cov /= nf;
    let svd = cov.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let mut s = Matrix3::identity();
    if u.determinant() * v_t.determinant() < 0.0 {
        s[(2, 2)] = -1.0;
    }
    let rotation = u * s * v_t;
    let scale = if with_scale {
        (Matrix3::from_diagonal(&svd.singular_values) * s).trace() / sigma_x
    } else {
        1.0
    };
    let translation = mean_y - scale * (rotation * mean_x);
    Some(Similarity {
        rotation,
        translation,
        scale,
    })
}

/// The absolute trajectory error after one alignment.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Ate {
    /// The alignment applied.
    pub alignment: Alignment,
    /// The transform applied to the estimate.
    pub transform: Similarity,
    /// Per frame: `|t_gt(k) - T(t_est(k))|` in metres.
    pub errors: Vec<f64>,
    /// Their statistics.
    pub stats: Stats,
}

/// The absolute trajectory error of `estimate` against `ground_truth` (same length, frame `k`
/// with frame `k`) after `alignment`. `None` if the lengths differ, are below 2, or the
/// alignment is degenerate (an estimate standing still).
pub fn ate(
    ground_truth: &[Pose<f64>],
    estimate: &[Pose<f64>],
    alignment: Alignment,
) -> Option<Ate> {
    if ground_truth.len() != estimate.len() || ground_truth.len() < 2 {
        return None;
    }
    let y: Vec<Vector3<f64>> = ground_truth.iter().map(|p| p.translation).collect();
    let x: Vec<Vector3<f64>> = estimate.iter().map(|p| p.translation).collect();
    let transform = match alignment {
        Alignment::None => Similarity::identity(),
        Alignment::Se3 => umeyama(&x, &y, false)?,
        Alignment::Sim3 => umeyama(&x, &y, true)?,
    };
    let errors: Vec<f64> = x
        .iter()
        .zip(&y)
        .map(|(px, py)| (py - transform.apply(px)).norm())
        .collect();
    let stats = Stats::from_values(&errors);
    Some(Ate {
        alignment,
        transform,
        errors,
        stats,
    })
}

/// The unit of the RPE's `delta`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Delta {
    /// Frames: pairs `(0, d), (d, 2d), ...`.
    Frames(usize),
    /// Metres of path: starting at frame 0, a new pair boundary is set each time the path
    /// since the last boundary reaches `d` (evo's `--delta_unit m`). The path is the
    /// estimate's, as evo's default, or the ground truth's with `from_ground_truth` (evo's
    /// `--pairs_from_reference`).
    Metres {
        /// The distance `d` in metres.
        metres: f64,
        /// Measure the path on the ground truth instead of the estimate.
        from_ground_truth: bool,
    },
}

/// The frame pairs `(i, j)` of the RPE at `delta` (evo's `filter_pairs_by_index` and
/// `filter_pairs_by_path` with `all_pairs = false`) on the poses `path` (see [`Delta`] for
/// which trajectory [`rpe`] passes).
pub fn rpe_pairs(path: &[Pose<f64>], delta: Delta) -> Vec<(usize, usize)> {
    let ids: Vec<usize> = match delta {
        Delta::Frames(0) => return Vec::new(),
        Delta::Frames(d) => (0..path.len()).step_by(d).collect(),
        Delta::Metres { metres: d, .. } => {
            if !(d > 0.0 && d.is_finite()) || path.is_empty() {
                return Vec::new();
            }
            let mut ids = vec![0];
            let mut acc = 0.0;
            for i in 1..path.len() {
                acc += (path[i].translation - path[i - 1].translation).norm();
                if acc >= d {
                    ids.push(i);
                    acc = 0.0;
                }
            }
            ids
        }
    };
    ids.windows(2).map(|w| (w[0], w[1])).collect()
}

/// The relative pose error over frame pairs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Rpe {
    /// The delta.
    pub delta: Delta,
    /// The frame pairs `(i, j)`.
    pub pairs: Vec<(usize, usize)>,
    /// Per pair: the translation norm of `E` in metres.
    pub translation_errors: Vec<f64>,
    /// Per pair: the rotation angle of `E` in degrees.
    pub rotation_errors_deg: Vec<f64>,
    /// Statistics of the translation errors (m).
    pub translation: Stats,
    /// Statistics of the rotation errors (deg).
    pub rotation_deg: Stats,
}

/// The relative pose error `E_ij = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` (Q ground truth, P estimate) over
/// the pairs of [`rpe_pairs`]. `None` if the lengths differ or no pair exists.
pub fn rpe(ground_truth: &[Pose<f64>], estimate: &[Pose<f64>], delta: Delta) -> Option<Rpe> {
    if ground_truth.len() != estimate.len() {
        return None;
    }
    let path = match delta {
        Delta::Metres {
            from_ground_truth: false,
            ..
        } => estimate,
        _ => ground_truth,
    };
    let pairs = rpe_pairs(path, delta);
    if pairs.is_empty() {
        return None;
    }
    let (mut te, mut re) = (Vec::new(), Vec::new());
    for &(i, j) in &pairs {
        let q = ground_truth[i].inverse().compose(&ground_truth[j]);
        let p = estimate[i].inverse().compose(&estimate[j]);
        let e = q.inverse().compose(&p);
        te.push(e.translation.norm());
        re.push(so3_log(&e.rotation).norm().to_degrees());
    }
    Some(Rpe {
        delta,
        pairs,
        translation: Stats::from_values(&te),
        rotation_deg: Stats::from_values(&re),
        translation_errors: te,
        rotation_errors_deg: re,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::so3_exp;

    fn wiggle(n: usize) -> Vec<Pose<f64>> {
        (0..n)
            .map(|k| {
                let t = k as f64;
                Pose::new(
                    so3_exp(&Vector3::new(0.01 * t.sin(), 0.05 * t, 0.0)),
                    Vector3::new(t.sin() * 3.0, 0.1 * t.cos(), 2.0 * t),
                )
            })
            .collect()
    }

    #[test]
    fn sim3_alignment_undoes_a_similarity() {
        let gt = wiggle(30);
        let g = Similarity {
            rotation: so3_exp(&Vector3::new(0.3, -0.2, 0.5)),
            translation: Vector3::new(1.0, -2.0, 3.0),
            scale: 0.37,
        };
        let est: Vec<_> = gt.iter().map(|p| g.apply_pose(p)).collect();
        let a = ate(&gt, &est, Alignment::Sim3).expect("aligned");
        assert!(a.stats.max < 1e-9, "{:?}", a.stats);
        assert!((a.transform.scale * g.scale - 1.0).abs() < 1e-9);
        // A rigid alignment cannot undo the scale.
        let r = ate(&gt, &est, Alignment::Se3).expect("aligned");
        assert!(r.stats.rmse > 1.0, "{:?}", r.stats);
    }

    #[test]
    fn rpe_of_a_perfect_estimate_is_zero_and_pairs_follow_evo() {
        let gt = wiggle(11);
        let r = rpe(&gt, &gt, Delta::Frames(3)).expect("pairs");
        assert_eq!(r.pairs, vec![(0, 3), (3, 6), (6, 9)]);
        assert!(r.translation.max < 1e-12 && r.rotation_deg.max < 1e-9);
        assert!(rpe(&gt, &gt, Delta::Frames(0)).is_none());
        // Straight line of 1 m steps: a pair every 2 m from frame 0.
        let line: Vec<_> = (0..7)
            .map(|k| Pose::new(Matrix3::identity(), Vector3::new(0.0, 0.0, k as f64)))
            .collect();
        let d = Delta::Metres {
            metres: 2.0,
            from_ground_truth: true,
        };
        assert_eq!(rpe_pairs(&line, d), vec![(0, 2), (2, 4), (4, 6)]);
    }

    #[test]
    fn stats_match_their_definitions() {
        let s = Stats::from_values(&[3.0, 1.0, 4.0, 2.0]);
        assert_eq!((s.min, s.max, s.median, s.mean), (1.0, 4.0, 2.5, 2.5));
        assert!((s.rmse - 7.5_f64.sqrt()).abs() < 1e-15);
        assert!((s.std - 1.25_f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.sse, 30.0);
    }
}
