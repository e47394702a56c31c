//! The Cramér-Rao lower bound of each frame pair's rotation from its static matches.
//!
//! Model (the simulator's own): every static match i of camera j observes a scene point `X_i`
//! (camera j coordinates at frame k-1) in both frames, `u_i0 = π_j(X_i)` and
//! `u_i1 = π_j(C_j⁻¹ X_i)` with `C_j = P_j⁻¹ M P_j`, each pixel coordinate with independent
//! Gaussian noise of standard deviation σ (`pixel_noise`). The parameters are the vehicle motion
//! `M = (R, t)`, perturbed as `M(δ) = (exp(ω) R, t + v)` with `δ = (ω, v) ∈ ℝ⁶`, and every point
//! `X_i ∈ ℝ³` as a nuisance. The Fisher information of match i is `J_iᵀ J_i / σ²` with `J_i` the
//! 4×9 Jacobian of both pixels over `(δ, X_i)`; each point is eliminated by its Schur complement
//! (`A_i − B_i C_i⁺ B_iᵀ`), and the reduced 6×6 informations of all matches of all cameras of the
//! rig are summed into one information matrix `F` ([`motion_information`]).
//!
//! When odometry gives the arc length (or the rig has one camera, whose scale is a gauge), the
//! translation is constrained to `‖t‖ = s`: the bound is the constrained CRB
//! `U (Uᵀ F U)⁻¹ Uᵀ` with `U` spanning the 5 directions that keep `‖t‖` (3 rotation directions
//! only at a standstill); otherwise `F⁻¹` ([`rotation_covariance`]). Its upper-left 3×3 block
//! `Σ_ω` is the covariance of the rotation error vector `ω` (radians), whatever frame the error is
//! expressed in: the error angle `‖ω‖` is the angle of `R_gtᵀ R_est` that `momo eval` reports
//! for camera 0 (conjugation by the extrinsic rotation keeps the angle).
//!
//! The per-frame scalar is the **median of the error angle `‖ω‖` for `ω ~ N(0, Σ_ω)`**, in
//! degrees ([`median_error_angle`]): an efficient unbiased estimator's error angle in that frame
//! is below it half of the time, so it compares directly with the median of the per-frame error
//! angles that `momo eval` reports (`eff` = error median / bound median over frames).
//!
//! Jacobians are central finite differences of the camera models' `project` (any
//! [`CameraModel`], pinhole or fisheye), accurate to about 1e-7 relative.

use crate::sim::{MatchLabel, Simulation};
use momo_core::{CameraModel, Pose, Rig, camera_motion, so3_exp};
use nalgebra::{Matrix3, Matrix6, SMatrix, SymmetricEigen, Vector2, Vector3};
use std::fmt::Write as _;
use std::io;
use std::path::Path;

/// The bound of one frame pair.
#[derive(Clone, Debug, PartialEq)]
pub struct RotationBound {
    /// Frame pair `k` (pair `(k-1, k)`).
    pub frame: usize,
    /// Covariance `Σ_ω` of the rotation error vector, rad².
    pub covariance: Matrix3<f64>,
    /// Median of the error angle `‖ω‖` for `ω ~ N(0, Σ_ω)`, degrees.
    pub median_deg: f64,
    /// Static matches that contributed (all cameras).
    pub static_matches: usize,
}

/// The perturbed vehicle motion `M(δ) = (exp(ω) R, t + v)`.
pub fn perturb(motion: &Pose<f64>, delta: &[f64; 6]) -> Pose<f64> {
    let w = Vector3::new(delta[0], delta[1], delta[2]);
    let v = Vector3::new(delta[3], delta[4], delta[5]);
    Pose::new(so3_exp(&w) * motion.rotation, motion.translation + v)
}

/// Both pixels of a point `x0` (camera coordinates at k-1) of camera `t_vehicle_camera` under
/// vehicle motion `motion`; `None` if either projection fails.
pub fn project_pair<C: CameraModel>(
    model: &C,
    t_vehicle_camera: &Pose<f64>,
    motion: &Pose<f64>,
    x0: &Vector3<f64>,
) -> Option<(Vector2<f64>, Vector2<f64>)> {
    let c = camera_motion(motion, t_vehicle_camera);
    let x1 = c.inverse().transform_point(x0);
    Some((model.project(x0)?, model.project(&x1)?))
}

/// The 4×9 Jacobian of `(u0, u1)` over `(δ, X)` at `δ = 0` (central differences).
fn match_jacobian<C: CameraModel>(
    model: &C,
    t_vehicle_camera: &Pose<f64>,
    motion: &Pose<f64>,
    x0: &Vector3<f64>,
) -> Option<SMatrix<f64, 4, 9>> {
    let mut j = SMatrix::<f64, 4, 9>::zeros();
    let hx = 1e-6 * x0.norm().max(1.0);
    for c in 0..9 {
        let eval = |sign: f64| -> Option<(Vector2<f64>, Vector2<f64>)> {
            if c < 6 {
                let mut d = [0.0; 6];
                d[c] = sign * 1e-6;
                project_pair(model, t_vehicle_camera, &perturb(motion, &d), x0)
            } else {
                let mut x = *x0;
                x[c - 6] += sign * hx;
                project_pair(model, t_vehicle_camera, motion, &x)
            }
        };
        let (p0, p1) = eval(1.0)?;
        let (m0, m1) = eval(-1.0)?;
        let h = if c < 6 { 2e-6 } else { 2.0 * hx };
        let d0 = (p0 - m0) / h;
        let d1 = (p1 - m1) / h;
        j[(0, c)] = d0.x;
        j[(1, c)] = d0.y;
        j[(2, c)] = d1.x;
        j[(3, c)] = d1.y;
    }
    j.iter().all(|v| v.is_finite()).then_some(j)
}

/// Pseudo-inverse of a symmetric positive semi-definite 3×3 matrix (eigenvalues below `1e-9`
/// of the largest count as zero: a point direction the pixels do not see, e.g. depth at a
/// standstill).
fn pinv3(c: &Matrix3<f64>) -> Matrix3<f64> {
    let e = SymmetricEigen::new(*c);
    let max = e.eigenvalues.amax();
    let mut out = Matrix3::zeros();
    for i in 0..3 {
        let l = e.eigenvalues[i];
        if l > 1e-9 * max && l > 0.0 {
            let v = e.eigenvectors.column(i);
            out += v * v.transpose() / l;
        }
    }
    out
}

/// The Fisher information of the vehicle motion `δ = (ω, v)` from static points, for unit pixel
/// noise (divide by σ² for noise σ), with every point eliminated by its Schur complement.
/// `points` are `(camera id, X in camera coordinates at k-1)`; points of unknown cameras or that
/// do not project are skipped. Returns the information and the number of points used.
pub fn motion_information(
    rig: &Rig,
    motion: &Pose<f64>,
    points: impl IntoIterator<Item = (usize, Vector3<f64>)>,
) -> (Matrix6<f64>, usize) {
    let mut info = Matrix6::zeros();
    let mut used = 0;
    for (j, x0) in points {
        let Some(cam) = rig.cameras().get(j) else {
            continue;
        };
        let Some(jac) = match_jacobian(&cam.model, &cam.t_vehicle_camera, motion, &x0) else {
            continue;
        };
        let jd = jac.fixed_columns::<6>(0);
        let jx = jac.fixed_columns::<3>(6);
        let a = jd.transpose() * jd;
        let b = jd.transpose() * jx;
        let c = jx.transpose() * jx;
        info += a - b * pinv3(&c) * b.transpose();
        used += 1;
    }
    (0.5 * (info + info.transpose()), used)
}

/// The covariance bound `Σ_ω` (3×3, rad² for unit pixel noise) of the rotation from a motion
/// information `info`: constrained to `‖t‖` fixed if `fix_arc_length` (see the module doc),
/// `info⁻¹` otherwise. `None` if the (constrained) information is singular.
pub fn rotation_covariance(
    info: &Matrix6<f64>,
    motion: &Pose<f64>,
    fix_arc_length: bool,
) -> Option<Matrix3<f64>> {
    let t = motion.translation;
    let cols: Vec<nalgebra::Vector6<f64>> = if !fix_arc_length {
        (0..6)
            .map(|i| nalgebra::Vector6::ith_axis(i).into_inner())
            .collect()
    } else {
        let mut cols: Vec<nalgebra::Vector6<f64>> = (0..3)
            .map(|i| nalgebra::Vector6::ith_axis(i).into_inner())
            .collect();
        if t.norm() > 1e-9 {
            // Two directions orthogonal to t.
            let tn = t.normalize();
            let a = if tn.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let b1 = tn.cross(&a).normalize();
            let b2 = tn.cross(&b1);
            for b in [b1, b2] {
                cols.push(nalgebra::Vector6::new(0.0, 0.0, 0.0, b.x, b.y, b.z));
            }
        }
        cols
    };
    let u = nalgebra::DMatrix::from_fn(6, cols.len(), |r, c| cols[c][r]);
    let f = nalgebra::DMatrix::from_column_slice(6, 6, info.as_slice());
    let reduced = u.transpose() * &f * &u;
    let scale = reduced.diagonal().amax();
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    // Reject numerically singular informations (condition number beyond 1e12).
    let eig = SymmetricEigen::new(reduced.clone());
    if eig.eigenvalues.min() <= 1e-12 * eig.eigenvalues.max() {
        return None;
    }
    let inv = reduced.cholesky()?.inverse();
    let cov = &u * inv * u.transpose();
    Some(cov.fixed_view::<3, 3>(0, 0).into_owned())
}

/// `erf(x)` with a fractional error below 1.2e-7 (Numerical Recipes' Chebyshev fit of erfc).
fn erf(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 { 1.0 - erfc } else { erfc - 1.0 }
}

/// CDF of the chi distribution with 3 degrees of freedom (the norm of a standard normal 3-vector).
fn chi3_cdf(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    (erf(x / std::f64::consts::SQRT_2)
        - (2.0 / std::f64::consts::PI).sqrt() * x * (-0.5 * x * x).exp())
    .clamp(0.0, 1.0)
}

/// The median of `‖ω‖` for `ω ~ N(0, cov)` (same unit as `sqrt(cov)`).
///
/// With `ω = Σ^{1/2} y`, `y = s u` (`s ~ χ₃`, `u` uniform on the sphere, independent):
/// `P(‖ω‖ ≤ r) = E_u[F_χ₃(r / ‖Σ^{1/2} u‖)]`, a smooth integrand averaged over 1000 points of a
/// Fibonacci sphere; the median by bisection (relative accuracy about 1e-6).
///
/// ```
/// use momo_sim::bound::median_error_angle;
/// use nalgebra::Matrix3;
/// // Isotropic unit covariance: the median of the chi distribution with 3 dof, 1.5382.
/// let m = median_error_angle(&Matrix3::identity());
/// assert!((m - 1.538_172).abs() < 1e-4, "{m}");
/// ```
pub fn median_error_angle(cov: &Matrix3<f64>) -> f64 {
    let eig = SymmetricEigen::new(0.5 * (cov + cov.transpose()));
    let l = eig.eigenvalues.map(|v| v.max(0.0));
    let lmax = l.max();
    if !(lmax.is_finite() && lmax > 0.0) {
        return if lmax == 0.0 { 0.0 } else { f64::NAN };
    }
    const N: usize = 1000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let scales: Vec<f64> = (0..N)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / N as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            let u = Vector3::new(r * phi.cos(), r * phi.sin(), z);
            (l[0] * u.x * u.x + l[1] * u.y * u.y + l[2] * u.z * u.z).sqrt()
        })
        .collect();
    let cdf = |r: f64| {
        scales
            .iter()
            .map(|&s| if s > 0.0 { chi3_cdf(r / s) } else { 1.0 })
            .sum::<f64>()
            / N as f64
    };
    let (mut lo, mut hi) = (0.0, 3.0 * lmax.sqrt());
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < 0.5 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The bound of frame pair `k` of a simulation with pixel noise `pixel_noise` (the simulator's
/// σ): all static matches of all cameras; the arc length fixed when the sequence has odometry or
/// the rig one camera. `None` for frame 0, frames out of range, and frames whose static matches
/// do not determine the motion.
pub fn frame_bound(sim: &Simulation, k: usize, pixel_noise: f64) -> Option<RotationBound> {
    if k == 0 {
        return None;
    }
    let motion = sim.vehicle_motions.get(k)?;
    let rig = &sim.sequence.rig;
    let points = sim.static_points.get(k)?;
    let labels = sim.labels.get(k)?;
    let iter = points.iter().enumerate().flat_map(|(j, pts)| {
        pts.iter()
            .zip(labels.get(j).into_iter().flatten())
            .filter(|(_, l)| **l == MatchLabel::Inlier)
            .filter_map(move |(p, _)| p.map(|x| (j, x)))
    });
    let (info, used) = motion_information(rig, motion, iter);
    let fix = sim.sequence.arc_lengths.is_some() || rig.len() == 1;
    let cov = rotation_covariance(&info, motion, fix)? * (pixel_noise * pixel_noise);
    Some(RotationBound {
        frame: k,
        median_deg: median_error_angle(&cov).to_degrees(),
        covariance: cov,
        static_matches: used,
    })
}

/// [`frame_bound`] of every frame pair `1..n` (index k-1 holds frame pair k).
pub fn rotation_bounds(sim: &Simulation, pixel_noise: f64) -> Vec<Option<RotationBound>> {
    (1..sim.vehicle_motions.len())
        .map(|k| frame_bound(sim, k, pixel_noise))
        .collect()
}

/// `bound.csv` (`docs/FORMAT.md`): header `frame,rotation_bound_deg,static_matches`, one row per
/// frame pair; an empty bound where it is undefined.
pub fn bound_csv(sim: &Simulation, bounds: &[Option<RotationBound>]) -> String {
    let n_frames = sim.vehicle_motions.len();
    let mut by_frame = vec![None; n_frames];
    for b in bounds.iter().flatten() {
        if let Some(slot) = by_frame.get_mut(b.frame) {
            *slot = Some(b);
        }
    }
    let mut s = String::from("frame,rotation_bound_deg,static_matches\n");
    for (k, b) in by_frame.into_iter().enumerate().skip(1) {
        let n: usize = match b {
            Some(b) => b.static_matches,
            None => sim.labels.get(k).map_or(0, |l| {
                l.iter()
                    .flatten()
                    .filter(|x| **x == MatchLabel::Inlier)
                    .count()
            }),
        };
        let v = b.map_or(String::new(), |b| format!("{:.6e}", b.median_deg));
        let _ = writeln!(s, "{k},{v},{n}");
    }
    s
}

/// Writes `bound.csv` into a sequence directory.
pub fn write_bound_csv(
    dir: impl AsRef<Path>,
    sim: &Simulation,
    bounds: &[Option<RotationBound>],
) -> io::Result<()> {
    std::fs::write(dir.as_ref().join("bound.csv"), bound_csv(sim, bounds))
}
