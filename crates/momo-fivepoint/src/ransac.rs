//! RANSAC around the 5-point solver, cheirality, optional local refinement, and the vehicle
//! motion from a rig.

use crate::decompose::recover_pose;
use crate::solver::solve_five_point;
use crate::vehicle::vehicle_motion_from_camera;
use momo_core::num_dual::DualSVec64;
use momo_core::{
    FrameObservations, Linearization, NormalMatrix, Observation, ParamVec, Pose, Rig, RobustLoss,
    Scalar, Termination, TrivialLoss, essential, so3_exp,
};
use momo_costs::Cauchy;
use momo_solvers::linalg::solve_damped;
use momo_solvers::{LevenbergMarquardt, LmProblem};
use nalgebra::{Matrix3, U1, U5, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;

/// The angular Sampson error of a match under `E`, squared: the first-order approximation of
/// the smallest sum of squared angles by which `f0` and `f1` (unit bearings) must be turned to
/// satisfy `f1ᵀ E f0 = 0`,
///
/// `r² = e² / (|Π₁ E f0|² + |Π₀ Eᵀ f1|²)`, `e = f1ᵀ E f0`, `Π = I - f fᵀ`,
///
/// i.e. `e² / (|E f0|² + |Eᵀ f1|² - 2 e²)`. The spherical counterpart of OpenCV's Sampson
/// distance: with the noise on one bearing only it is `1/√2` of the angle between that bearing
/// and its epipolar plane. Generic so that the refinement differentiates it with num-dual.
/// Infinite where the epipolar planes are undefined (a match on the epipole).
pub fn sampson_angle_sq<T: Scalar>(e: &Matrix3<T>, obs: &Observation) -> T {
    let f0 = obs.f0.map(T::c);
    let f1 = obs.f1.map(T::c);
    let ef0 = e * f0;
    let etf1 = e.transpose() * f1;
    let r = f1.dot(&ef0);
    let den = ef0.norm_squared() + etf1.norm_squared() - r * r * T::c(2.0);
    if den > T::zero() {
        r * r / den
    } else {
        T::c(f64::INFINITY)
    }
}

/// 5-point RANSAC for one calibrated camera, as OpenCV's `findEssentialMat(RANSAC)` followed by
/// `recoverPose`, optionally with a PoseLib-style least-squares refinement on the inliers.
///
/// - A match is an inlier if its angular Sampson error ([`sampson_angle_sq`]) is below
///   `threshold` (radians; the default 1e-3 rad is about 0.7 px at a focal length of 718 px,
///   OpenCV's usual 1 px is 1.4e-3 at that focal length).
/// - Hypotheses are scored by MSAC (sum of `min(r², threshold²)`), ties are impossible in
///   practice; OpenCV counts inliers, which is slightly less accurate with the same hypotheses.
/// - The iteration count adapts to the best inlier ratio `w`:
///   `N = log(1 - confidence) / log(1 - w⁵)`, at most `max_iterations`.
/// - The random stream is `StdRng::seed_from_u64(seed)`: the same input and seed give the same
///   result.
/// - With `refine` (local optimisation of the final hypothesis, as PoseLib's LO-RANSAC does it
///   for every new best), three rounds of: select the matches within 3 thresholds of the
///   current motion, and refine the motion on them ([`refine_motion`]: Levenberg-Marquardt on
///   the angular Sampson errors with a Cauchy loss of scale `threshold`, over the rotation and
///   the translation direction, derivatives by num-dual). Fitting only the matches within the
///   threshold of the (noisy) minimal hypothesis would keep much of its error: the matches
///   that agree with it are selected. The reported inliers are those of the refined motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FivePointRansac {
    /// Inlier threshold on the angular Sampson error, radians.
    pub threshold: f64,
    /// Probability that at least one all-inlier sample is drawn (adaptive stopping).
    pub confidence: f64,
    /// Upper bound on the number of samples.
    pub max_iterations: usize,
    /// Seed of the random sampling.
    pub seed: u64,
    /// Refine the motion by least squares on the inliers (PoseLib's LO-RANSAC does; OpenCV not).
    pub refine: bool,
}

impl Default for FivePointRansac {
    fn default() -> Self {
        Self {
            threshold: 1e-3,
            confidence: 0.999,
            max_iterations: 1000,
            seed: 0,
            refine: false,
        }
    }
}

/// The result of [`FivePointRansac::estimate_camera_motion`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FivePointResult {
    /// The camera motion `C = [R | t]` (pose of the camera at frame k in the camera at k-1)
    /// with unit translation.
    pub motion: Pose<f64>,
    /// Number of inliers of the final motion.
    pub inliers: usize,
    /// Number of RANSAC samples drawn.
    pub iterations: usize,
}

/// The refinement fits the matches within this multiple of the threshold (LO-RANSAC's wider
/// inner threshold: fitting only the matches within the threshold of a biased hypothesis keeps
/// the bias).
const LO_THRESHOLD_FACTOR: f64 = 3.0;
/// Scale of the refinement's Cauchy loss, in thresholds.
const LO_LOSS_FACTOR: f64 = 1.0;
/// Rounds of (re-select, refine).
const LO_ROUNDS: usize = 3;

/// Minimal number of matches.
pub const MIN_MATCHES: usize = 5;

fn usable(o: &Observation) -> bool {
    let ok = |f: &Vector3<f64>| f.iter().all(|v| v.is_finite()) && f.norm_squared() > 0.0;
    ok(&o.f0) && ok(&o.f1)
}

impl FivePointRansac {
    /// Number of samples needed for the inlier ratio `w` (at least 1).
    fn needed_iterations(&self, w: f64) -> usize {
        let p = w.powi(MIN_MATCHES as i32);
        if p >= 1.0 {
            return 1;
        }
        let conf = self.confidence.clamp(0.0, 1.0 - 1e-15);
        let n = (1.0 - conf).ln() / (1.0 - p).ln();
        if n.is_finite() && n >= 0.0 {
            (n.ceil() as usize).max(1)
        } else {
            usize::MAX
        }
    }

    fn msac_score(&self, e: &Matrix3<f64>, obs: &[&Observation]) -> (f64, usize) {
        let t2 = self.threshold * self.threshold;
        let mut score = 0.0;
        let mut n = 0;
        for o in obs {
            let r2 = sampson_angle_sq(e, o);
            if r2 < t2 {
                score += r2;
                n += 1;
            } else {
                score += t2;
            }
        }
        (score, n)
    }

    fn inliers<'a>(&self, e: &Matrix3<f64>, obs: &[&'a Observation]) -> Vec<&'a Observation> {
        let t2 = self.threshold * self.threshold;
        obs.iter()
            .copied()
            .filter(|o| sampson_angle_sq(e, o) < t2)
            .collect()
    }

    /// The camera motion (unit translation) of one camera's matches; `None` with fewer than 5
    /// usable matches (finite, non-zero bearings), for degenerate input (no sample has a
    /// solution, e.g. all matches identical), or if no candidate passes the cheirality test.
    pub fn estimate_camera_motion(&self, obs: &[Observation]) -> Option<FivePointResult> {
        let obs: Vec<&Observation> = obs.iter().filter(|o| usable(o)).collect();
        let n = obs.len();
        if n < MIN_MATCHES {
            return None;
        }
        let mut rng = StdRng::seed_from_u64(self.seed);
        let mut best: Option<(Matrix3<f64>, f64, usize)> = None;
        let mut needed = self.max_iterations;
        let mut iterations = 0;
        while iterations < needed.min(self.max_iterations) {
            iterations += 1;
            let sample = rand::seq::index::sample(&mut rng, n, MIN_MATCHES);
            let f0: [Vector3<f64>; 5] = std::array::from_fn(|i| obs[sample.index(i)].f0);
            let f1: [Vector3<f64>; 5] = std::array::from_fn(|i| obs[sample.index(i)].f1);
            for e in solve_five_point(&f0, &f1) {
                let (score, count) = self.msac_score(&e, &obs);
                if best.as_ref().is_none_or(|(_, s, _)| score < *s) {
                    best = Some((e, score, count));
                    needed = self.needed_iterations(count as f64 / n as f64);
                }
            }
        }
        let (e, _, _) = best?;
        let inliers = self.inliers(&e, &obs);
        if inliers.len() < MIN_MATCHES {
            return None;
        }
        let (mut motion, _) = recover_pose(&e, inliers.iter().copied())?;
        let mut count = inliers.len();
        if self.refine {
            let wide = FivePointRansac {
                threshold: self.threshold * LO_THRESHOLD_FACTOR,
                ..*self
            };
            for _ in 0..LO_ROUNDS {
                let set = wide.inliers(&essential(&motion), &obs);
                if set.len() < MIN_MATCHES {
                    break;
                }
                motion = refine_motion(&motion, &set, self.threshold * LO_LOSS_FACTOR, 20);
            }
            let final_inliers = self.inliers(&essential(&motion), &obs);
            count = final_inliers.len();
        }
        Some(FivePointResult {
            motion,
            inliers: count,
            iterations,
        })
    }

    /// The vehicle motion `M = P C P⁻¹` (`P = T_vehicle_camera`) from the matches of the camera
    /// with the most matches (the lowest id on a tie, so camera 0 for equal counts), and the
    /// camera result.
    ///
    /// The scale of the camera translation is chosen so that the vehicle's chord `|t_M|` equals
    /// the chord of a circular arc of length `arc_length` turning by the rotation angle `θ` of
    /// `M`: `|t_M| = |l| sin(θ/2) / (θ/2)` (the convention of `momo_models::Se3`); see
    /// [`vehicle_motion_from_camera`]. With `arc_length == Some(0.0)` only the rotation is
    /// returned (zero translation); with `None` the chord is 1 (a unit-length vehicle
    /// translation: the direction only). `None` as for
    /// [`estimate_camera_motion`](Self::estimate_camera_motion), or for a camera id outside
    /// the rig.
    pub fn estimate_vehicle_motion(
        &self,
        rig: &Rig,
        frame: &FrameObservations,
        arc_length: Option<f64>,
    ) -> Option<(Pose<f64>, FivePointResult)> {
        let (cam, matches) = frame
            .per_camera
            .iter()
            .enumerate()
            .take(rig.len())
            .rev()
            .max_by_key(|(_, m)| m.len())?;
        let camera = rig.cameras().get(cam)?;
        let result = self.estimate_camera_motion(matches)?;
        let m = vehicle_motion_from_camera(&result.motion, &camera.t_vehicle_camera, arc_length)?;
        Some((m, result))
    }
}

type D5 = DualSVec64<5>;

/// The motion `[R0 exp(w) | normalize(t0 + a u + b v)]` for the 5 parameters `(w, a, b)`,
/// `u`, `v` an orthonormal basis of the plane orthogonal to `t0`.
fn perturbed<T: Scalar>(base: &Pose<f64>, basis: &[Vector3<f64>; 2], p: &[T; 5]) -> Pose<T> {
    let w = Vector3::new(p[0], p[1], p[2]);
    let r = base.rotation.map(T::c) * so3_exp(&w);
    let t = base.translation.map(T::c) + basis[0].map(T::c) * p[3] + basis[1].map(T::c) * p[4];
    let t = t / t.norm();
    Pose::new(r, t)
}

fn tangent_basis(t: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let a = if t.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = t.cross(&a).normalize();
    let v = t.cross(&u).normalize();
    [u, v]
}

/// The refinement of [`refine_motion`] as a Levenberg-Marquardt problem ([`LmProblem`]): the
/// point is a camera motion with unit translation, a step `(w, a, b)` moves it by
/// [`perturbed`] in the tangent basis of its own translation, and the cost is
/// `½ Σ ρ(rᵢ²)` with `rᵢ²` the squared angular Sampson errors. The normal equations are those of
/// iteratively reweighted least squares (weights `ρ'(rᵢ²)`), the Jacobian of `rᵢ` by num-dual.
struct Refinement<'a, 'o> {
    obs: &'a [&'o Observation],
    loss: &'a dyn RobustLoss,
}

impl LmProblem for Refinement<'_, '_> {
    type Point = Pose<f64>;
    type Lin = Linearization;
    type Step = ParamVec;

    fn linearize(&self, x: &Pose<f64>) -> Linearization {
        let basis = tangent_basis(&x.translation);
        let p: [D5; 5] = std::array::from_fn(|i| D5::from_re(0.0).derivative(i));
        let e = essential(&perturbed(x, &basis, &p));
        let mut lin = Linearization {
            cost: 0.0,
            gradient: ParamVec::zeros(),
            hessian: NormalMatrix::zeros(),
        };
        for o in self.obs {
            let r2 = sampson_angle_sq(&e, o);
            lin.cost += 0.5 * self.loss.evaluate(r2.re)[0];
            if !(r2.re > 0.0) || !r2.re.is_finite() {
                continue;
            }
            // r = sqrt(r²): dr = d(r²) / (2 r).
            let r = r2.re.sqrt();
            let g = r2.eps.unwrap_generic(U5, U1) / (2.0 * r);
            let w = self.loss.weights(r2.re)[0];
            for i in 0..5 {
                lin.gradient[i] += g[i] * r * w;
                for j in 0..5 {
                    lin.hessian[(i, j)] += g[i] * g[j] * w;
                }
            }
        }
        lin
    }

    fn cost(&self, x: &Pose<f64>) -> f64 {
        let e = essential(x);
        let rho = |o: &&Observation| 0.5 * self.loss.rho(sampson_angle_sq(&e, o));
        self.obs.iter().map(rho).sum()
    }

    fn lin_cost(&self, lin: &Linearization) -> f64 {
        lin.cost
    }

    fn is_finite(&self, lin: &Linearization) -> bool {
        lin.cost.is_finite()
            && lin.gradient.iter().all(|v| v.is_finite())
            && lin.hessian.iter().all(|v| v.is_finite())
    }

    fn gradient_max_norm(&self, lin: &Linearization) -> f64 {
        lin.gradient.amax()
    }

    fn solve_damped(&self, lin: &Linearization, lambda: f64, scaled: bool) -> Option<ParamVec> {
        solve_damped(&lin.hessian, &lin.gradient, 5, lambda, scaled).map(|(x, _)| x)
    }

    fn predicted_decrease(&self, lin: &Linearization, step: &ParamVec) -> f64 {
        -(lin.gradient.dot(step) + 0.5 * step.dot(&(lin.hessian * step)))
    }

    fn step_is_small(&self, step: &ParamVec, _x: &Pose<f64>, tol: f64) -> bool {
        // The step is a local perturbation of a rotation and a unit vector: |x| is 1.
        step.norm() <= tol * (1.0 + tol)
    }

    fn retract(&self, x: &Pose<f64>, step: &ParamVec) -> Pose<f64> {
        let basis = tangent_basis(&x.translation);
        perturbed(x, &basis, &[step[0], step[1], step[2], step[3], step[4]])
    }
}

/// Levenberg-Marquardt (momo-solvers' [`LevenbergMarquardt`], at most `max_iterations` trial
/// steps) on `½ Σ ρ(r²)` (`r` the angular Sampson errors, [`sampson_angle_sq`]; `ρ` the Cauchy
/// loss `b² ln(1 + r²/b²)` with scale `b = loss_scale`, or plain least squares for a scale that
/// is not finite and positive) over the rotation and the translation direction of a camera
/// motion (unit translation), starting from `motion`. The robust loss enters through IRLS
/// weights `ρ' = 1 / (1 + r²/b²)`. Returns the start if it cannot improve.
pub fn refine_motion(
    motion: &Pose<f64>,
    obs: &[&Observation],
    loss_scale: f64,
    max_iterations: usize,
) -> Pose<f64> {
    let Some(t0) = motion.translation.try_normalize(0.0) else {
        return *motion;
    };
    let cauchy;
    let loss: &dyn RobustLoss = if loss_scale.is_finite() && loss_scale > 0.0 {
        cauchy = Cauchy::new(loss_scale);
        &cauchy
    } else {
        &TrivialLoss
    };
    let problem = Refinement { obs, loss };
    let lm = LevenbergMarquardt::default()
        .with_max_iterations(max_iterations)
        .with_function_tolerance(1e-10);
    let run = lm.minimize(&problem, Pose::new(motion.rotation, t0));
    if run.termination == Termination::NumericalFailure && run.iterations == 0 {
        return *motion;
    }
    run.x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn needed_iterations_matches_the_formula() {
        let r = FivePointRansac::default();
        assert_eq!(r.needed_iterations(1.0), 1);
        // w = 0.5: log(0.001) / log(1 - 1/32) = 217.6.
        assert_eq!(r.needed_iterations(0.5), 218);
        assert_eq!(r.needed_iterations(0.0), usize::MAX);
    }

    #[test]
    fn fewer_than_five_or_identical_matches_give_none() {
        let f = Vector3::new(0.1, -0.2, 1.0).normalize();
        let o = Observation {
            px0: Default::default(),
            px1: Default::default(),
            f0: f,
            f1: f,
        };
        let r = FivePointRansac::default();
        assert!(r.estimate_camera_motion(&[]).is_none());
        assert!(r.estimate_camera_motion(&[o; 4]).is_none());
        assert!(r.estimate_camera_motion(&[o; 50]).is_none());
        let nan = Observation {
            f0: Vector3::new(f64::NAN, 0.0, 1.0),
            ..o
        };
        assert!(r.estimate_camera_motion(&[nan; 50]).is_none());
    }
}
