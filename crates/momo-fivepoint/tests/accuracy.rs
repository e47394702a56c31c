//! Accuracy of the 5-point solver and of RANSAC against known motions.
//!
//! Run with `--nocapture` to see the measured error statistics.

use momo_core::{
    Camera, FrameObservations, Manifold, Observation, Pose, Rig, camera_motion, essential, so3_exp,
    so3_log,
};
use momo_fivepoint::{FivePointRansac, solve_five_point};
use momo_models::{Se3, SingleTrack2d};
use momo_testing::canned;
use nalgebra::{Matrix3, Vector2, Vector3};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Distance between two essential matrices up to scale and sign.
fn e_distance(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let (a, b) = (a.normalize(), b.normalize());
    (a - b).amax().min((a + b).amax())
}

fn rotation_error_deg(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    so3_log(&(a.transpose() * b)).norm().to_degrees()
}

fn direction_error_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.normalize()
        .dot(&b.normalize())
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Bearings of 5 random points seen from a camera motion `c`.
fn bearings(c: &Pose<f64>, points: &[Vector3<f64>]) -> ([Vector3<f64>; 5], [Vector3<f64>; 5]) {
    let c_inv = c.inverse();
    let f0 = std::array::from_fn(|i| points[i].normalize());
    let f1 = std::array::from_fn(|i| c_inv.transform_point(&points[i]).normalize());
    (f0, f1)
}

fn vec3(s: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-s..s, -s..s, -s..s).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

/// The smallest singular value of the Jacobian of the 5 epipolar residuals `f1ᵀ E f0` (unit
/// Frobenius `E`) with respect to the motion's 5 degrees of freedom (rotation, translation
/// direction), by central differences: how well the 5 correspondences pin the motion down.
/// The solver's error on noise-free data is rounding divided by this (measured on 200,000
/// samples: error × conditioning below 2.5e-16 for 99.99 % of them).
fn conditioning(c: &Pose<f64>, f0: &[Vector3<f64>; 5], f1: &[Vector3<f64>; 5]) -> f64 {
    let residuals = |c: &Pose<f64>| -> [f64; 5] {
        let e = essential(c).normalize();
        std::array::from_fn(|k| (f1[k].transpose() * e * f0[k])[0])
    };
    let t = c.translation.normalize();
    let a = if t.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = t.cross(&a).normalize();
    let v = t.cross(&u);
    let h = 1e-6;
    let perturbed = |d: usize, s: f64| {
        let mut w = Vector3::zeros();
        let mut dir = t;
        match d {
            0..3 => w[d] = s,
            3 => dir += s * u,
            _ => dir += s * v,
        }
        Pose::new(c.rotation * so3_exp(&w), dir * c.translation.norm())
    };
    let mut j = nalgebra::SMatrix::<f64, 5, 5>::zeros();
    for d in 0..5 {
        let (p, m) = (residuals(&perturbed(d, h)), residuals(&perturbed(d, -h)));
        for k in 0..5 {
            j[(k, d)] = (p[k] - m[k]) / (2.0 * h);
        }
    }
    j.singular_values().min()
}

/// The true `E` and the closest solution's distance to it (up to scale and sign), for exact
/// bearings of `points` under the camera motion `c`; also the sample's [`conditioning`].
fn solve_exact(c: &Pose<f64>, points: &[Vector3<f64>]) -> (Vec<Matrix3<f64>>, f64, f64) {
    let (f0, f1) = bearings(c, points);
    let solutions = solve_five_point(&f0, &f1);
    let truth = essential(c);
    let best = solutions
        .iter()
        .map(|e| e_distance(e, &truth))
        .fold(f64::INFINITY, f64::min);
    (solutions, best, conditioning(c, &f0, &f1))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    /// On exactly 5 noise-free correspondences every solution satisfies the 5 constraints and
    /// the cubic constraints, and, where the sample pins the motion down (conditioning at
    /// least 1e-3, 83 % of these samples), one solution is the true `E` within 1e-8 (up to
    /// scale and sign), in the convention of `momo_core::essential`. Below that the error
    /// grows as rounding over the conditioning (a CI run drew 5.2e-7 at w = 0); how often the
    /// truth is missed at all is `minimal_solver_miss_rate_on_general_motions`.
    #[test]
    fn minimal_solver_recovers_the_true_essential_matrix(
        w in vec3(0.5),
        t in vec3(1.0).prop_filter("non-zero translation", |t| t.norm() > 0.1),
        pts in proptest::collection::vec((-1.0..1.0f64, -0.7..0.7f64, 2.0..30.0f64), 5),
    ) {
        let c = Pose::new(so3_exp(&w), t);
        let points: Vec<Vector3<f64>> =
            pts.iter().map(|(x, y, z)| Vector3::new(x * z, y * z, *z)).collect();
        let (f0, f1) = bearings(&c, &points);
        let (solutions, best, conditioning) = solve_exact(&c, &points);
        prop_assert!(!solutions.is_empty());
        if conditioning >= 1e-3 {
            prop_assert!(best < 1e-8, "best distance {best:e} of {} solutions", solutions.len());
        }
        for e in &solutions {
            for k in 0..5 {
                prop_assert!((f1[k].transpose() * e * f0[k])[0].abs() < 1e-9);
            }
            prop_assert!(e.determinant().abs() < 1e-9);
            let cubic = 2.0 * e * e.transpose() * e - (e * e.transpose()).trace() * e;
            prop_assert!(cubic.amax() < 1e-8, "cubic constraint {:e}", cubic.amax());
        }
    }
}

/// Five points 2-30 m ahead in a 90 x 70 deg view (the proptest's generator), drawn from `rng`.
fn random_points(rng: &mut StdRng) -> Vec<Vector3<f64>> {
    (0..5)
        .map(|_| {
            let z = rng.random_range(2.0..30.0);
            Vector3::new(
                rng.random_range(-1.0..1.0) * z,
                rng.random_range(-0.7..0.7) * z,
                z,
            )
        })
        .collect()
}

/// How often the solver misses the true `E` (no solution within 1e-8) on the proptest's
/// general motions, over 20,000 fixed samples. Measured on 200,000: 3 misses (all with
/// conditioning below 1.5e-4), 13 before the SVD fallback for the eigenvector.
#[test]
fn minimal_solver_miss_rate_on_general_motions() {
    let mut rng = StdRng::seed_from_u64(2026);
    let (mut tried, mut missed) = (0, 0);
    while tried < 20_000 {
        let mut r = |s: f64| rng.random_range(-s..s);
        let w = Vector3::new(r(0.5), r(0.5), r(0.5));
        let t = Vector3::new(r(1.0), r(1.0), r(1.0));
        if t.norm() <= 0.1 {
            continue;
        }
        let points = random_points(&mut rng);
        let (_, best, _) = solve_exact(&Pose::new(so3_exp(&w), t), &points);
        tried += 1;
        if !(best < 1e-8) {
            missed += 1;
        }
    }
    eprintln!("minimal solver on general motions: missed {missed} of {tried}");
    assert!(missed <= 2, "missed {missed} of {tried}");
}

/// The same on vehicle-like motions seen by the canned KITTI-like pinhole camera (narrow field
/// of view, mostly forward translation): the harder-conditioned case. Five random points of
/// such a view are sometimes nearly degenerate and the solver then misses the true solution;
/// RANSAC tolerates that, so this test measures the miss rate over 1,000 fixed samples and
/// bounds it (measured: see the printed rate).
#[test]
fn minimal_solver_on_vehicle_motions() {
    use rand::{Rng, SeedableRng};
    let rig = canned::pinhole_rig();
    let mut rng = StdRng::seed_from_u64(42);
    let (mut tried, mut missed) = (0, 0);
    for seed in 0..1000u64 {
        let yaw = rng.random_range(-0.15..0.15);
        let l = rng.random_range(0.2..2.0);
        let pitch = rng.random_range(-0.02..0.02);
        let climb = rng.random_range(-0.03..0.03);
        let m = Se3.motion(&[0.0, pitch, yaw, 0.5 * yaw, climb, l]);
        let c = camera_motion(&m, &rig.cameras()[0].t_vehicle_camera);
        let frame = canned::synthetic_observations(&rig, &m, 5, 0, seed);
        let obs = &frame.per_camera[0];
        if obs.len() != 5 {
            continue;
        }
        let f0 = std::array::from_fn(|i| obs[i].f0);
        let f1 = std::array::from_fn(|i| obs[i].f1);
        let truth = essential(&c);
        let best = solve_five_point(&f0, &f1)
            .iter()
            .map(|e| e_distance(e, &truth))
            .fold(f64::INFINITY, f64::min);
        tried += 1;
        if !(best < 1e-8) {
            missed += 1;
        }
    }
    let rate = missed as f64 / tried as f64;
    eprintln!(
        "minimal solver on vehicle motions: missed {missed} of {tried} ({:.2} %)",
        100.0 * rate
    );
    assert!(tried > 900);
    assert!(rate < 0.01, "miss rate {rate}");
}

/// A standard normal sample (Box-Muller).
fn gauss(rng: &mut StdRng) -> f64 {
    let u1: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// `inliers` exact matches with Gaussian pixel noise `sigma` on all four coordinates, plus
/// `outliers` off-epipolar matches (3 to 30 px), of camera 0.
fn noisy_matches(
    rig: &Rig,
    motion: &Pose<f64>,
    inliers: usize,
    outliers: usize,
    sigma: f64,
    seed: u64,
) -> Vec<Observation> {
    let frame = canned::synthetic_observations(rig, motion, inliers, outliers, seed);
    let camera: &Camera = &rig.cameras()[0].model;
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed);
    frame.per_camera[0]
        .iter()
        .filter_map(|o| {
            let n0 = Vector2::new(gauss(&mut rng), gauss(&mut rng)) * sigma;
            let n1 = Vector2::new(gauss(&mut rng), gauss(&mut rng)) * sigma;
            Observation::new(camera, o.px0 + n0, o.px1 + n1)
        })
        .collect()
}

/// Vehicle motions: planar single-track curves and general Se3 motions.
fn test_motions(count: usize, seed: u64) -> Vec<Pose<f64>> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count)
        .map(|i| {
            let yaw = rng.random_range(-0.1..0.1);
            let l = rng.random_range(0.5..1.5);
            if i % 2 == 0 {
                SingleTrack2d.motion(&[yaw, l])
            } else {
                let pitch = rng.random_range(-0.01..0.01);
                let roll = rng.random_range(-0.01..0.01);
                let heading = 0.5 * yaw + rng.random_range(-0.02..0.02);
                let climb = rng.random_range(-0.02..0.02);
                Se3.motion(&[roll, pitch, yaw, heading, climb, l])
            }
        })
        .collect()
}

struct Stats {
    rot: Vec<f64>,
    dir: Vec<f64>,
}

impl Stats {
    fn report(&mut self, name: &str) -> (f64, f64) {
        let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let (rm, dm) = (max(&self.rot), max(&self.dir));
        eprintln!(
            "{name}: rotation error median {:.4} deg, max {rm:.4} deg; translation direction \
             error median {:.3} deg, max {dm:.3} deg ({} runs)",
            median(&mut self.rot),
            median(&mut self.dir),
            self.rot.len()
        );
        (rm, dm)
    }
}

fn ransac_accuracy(refine: bool) -> (f64, f64) {
    let rig = canned::pinhole_rig();
    let p = rig.cameras()[0].t_vehicle_camera;
    let ransac = FivePointRansac {
        refine,
        ..FivePointRansac::default()
    };
    let mut stats = Stats {
        rot: Vec::new(),
        dir: Vec::new(),
    };
    let mut iterations = Vec::new();
    for (k, m) in test_motions(20, 7).iter().enumerate() {
        // 140 inliers with 0.5 px noise, 60 outliers: 30 %.
        let obs = noisy_matches(&rig, m, 140, 60, 0.5, 100 + k as u64);
        let c = camera_motion(m, &p);
        let r = ransac.estimate_camera_motion(&obs).expect("a motion");
        assert!(r.inliers >= 90 && r.inliers <= 150, "inliers {}", r.inliers);
        iterations.push(r.iterations);
        stats
            .rot
            .push(rotation_error_deg(&r.motion.rotation, &c.rotation));
        stats
            .dir
            .push(direction_error_deg(&r.motion.translation, &c.translation));
    }
    eprintln!("refine = {refine}: RANSAC iterations {iterations:?}");
    stats.report(if refine {
        "5-point RANSAC + LO refinement"
    } else {
        "5-point RANSAC"
    })
}

/// OpenCV-like (no refinement): the motion of the best minimal sample. Its accuracy is that of
/// 5 noisy matches, measured median 0.11 deg / 1.2 deg, worst 0.18 deg / 4.2 deg over 20
/// frames, so the 0.1 deg / 2 deg target is met with `refine` only (next test).
#[test]
fn ransac_with_outliers_and_noise_is_accurate() {
    let (rot, dir) = ransac_accuracy(false);
    assert!(rot < 0.25, "rotation error {rot} deg");
    assert!(dir < 5.0, "translation direction error {dir} deg");
}

#[test]
fn refined_ransac_with_outliers_and_noise_is_accurate() {
    let (rot, dir) = ransac_accuracy(true);
    assert!(rot < 0.1, "rotation error {rot} deg");
    assert!(dir < 2.0, "translation direction error {dir} deg");
}

#[test]
fn noise_free_vehicle_motion_with_arc_length_is_the_truth() {
    let rig = canned::pinhole_rig();
    for (k, m) in test_motions(10, 3).iter().enumerate() {
        let frame = canned::synthetic_observations(&rig, m, 60, 20, k as u64);
        let arc = Se3.params_from_motion(m).expect("params")[5];
        // Without refinement the best minimal sample is exact. The refinement is a (Cauchy-robust)
        // fit to all matches within 3 thresholds, and now and then an "off-epipolar" match of
        // the canned data is moved nearly along its epipolar line and is among them: it pulls
        // the fit by up to ~1e-5 (as any real match near the threshold would).
        for (refine, tol) in [(false, 1e-7), (true, 1e-3)] {
            let ransac = FivePointRansac {
                refine,
                seed: k as u64,
                ..FivePointRansac::default()
            };
            let (v, r) = ransac
                .estimate_vehicle_motion(&rig, &frame, Some(arc))
                .expect("a motion");
            assert!(r.inliers >= 60);
            assert!(
                (v.rotation - m.rotation).amax() < tol,
                "{k}: {v:?} vs {m:?}"
            );
            assert!(
                (v.translation - m.translation).amax() < 10.0 * tol,
                "{k}: {v:?} vs {m:?}"
            );
        }
    }
}

#[test]
fn fisheye_rig_uses_the_camera_with_most_matches() {
    let rig = canned::fisheye_rig();
    let m = SingleTrack2d.motion(&[0.08, 1.1]);
    let mut frame = canned::synthetic_observations(&rig, &m, 40, 10, 9);
    frame.per_camera[0].truncate(3); // too few in camera 0
    frame.per_camera[1].truncate(20);
    let (v, _) = FivePointRansac::default()
        .estimate_vehicle_motion(&rig, &frame, Some(1.1))
        .expect("a motion");
    assert!((v.rotation - m.rotation).amax() < 1e-7);
    assert!((v.translation - m.translation).amax() < 1e-6);
}

/// Worst vehicle translation error (metres) over 10 noisy frames with the arc length given.
fn noisy_vehicle_translation_error(refine: bool) -> f64 {
    let rig = canned::pinhole_rig();
    let mut worst: f64 = 0.0;
    for (k, m) in test_motions(10, 11).iter().enumerate() {
        let obs = noisy_matches(&rig, m, 140, 60, 0.5, 500 + k as u64);
        let frame = FrameObservations {
            per_camera: vec![obs],
            ..Default::default()
        };
        let arc = Se3.params_from_motion(m).expect("params")[5];
        let ransac = FivePointRansac {
            refine,
            ..FivePointRansac::default()
        };
        let (v, _) = ransac
            .estimate_vehicle_motion(&rig, &frame, Some(arc))
            .expect("a motion");
        worst = worst.max((v.translation - m.translation).norm());
    }
    eprintln!("noisy vehicle motion (refine = {refine}): worst translation error {worst:.4} m");
    worst
}

#[test]
fn noisy_vehicle_motion_with_arc_length_is_close() {
    assert!(noisy_vehicle_translation_error(false) < 0.1);
    assert!(noisy_vehicle_translation_error(true) < 0.04);
}

#[test]
fn same_seed_same_result() {
    let rig = canned::pinhole_rig();
    let m = SingleTrack2d.motion(&[0.03, 1.0]);
    let obs = noisy_matches(&rig, &m, 100, 50, 0.5, 1);
    let r = FivePointRansac::default();
    assert_eq!(
        r.estimate_camera_motion(&obs),
        r.estimate_camera_motion(&obs)
    );
}

#[test]
fn degenerate_frames_give_none() {
    let rig = canned::pinhole_rig();
    let r = FivePointRansac::default();
    assert!(
        r.estimate_vehicle_motion(&rig, &FrameObservations::new(1), Some(1.0))
            .is_none()
    );
    assert!(
        r.estimate_vehicle_motion(&rig, &FrameObservations::default(), None)
            .is_none()
    );
    let m = SingleTrack2d.motion(&[0.03, 1.0]);
    let frame = canned::synthetic_observations(&rig, &m, 4, 0, 1);
    assert!(r.estimate_vehicle_motion(&rig, &frame, Some(1.0)).is_none());
    let one = frame.per_camera[0][0];
    let same = FrameObservations {
        per_camera: vec![vec![one; 100]],
        ..Default::default()
    };
    assert!(r.estimate_vehicle_motion(&rig, &same, Some(1.0)).is_none());
}

/// 2000 random motions and point sets: the worst distance of the closest solution to the true
/// `E`, the solution count, and the time per solve (test profile, opt-level 1).
#[test]
fn minimal_solver_statistics() {
    let mut rng = StdRng::seed_from_u64(2024);
    let mut worst: f64 = 0.0;
    let mut total_solutions = 0;
    let runs = 2000;
    let start = std::time::Instant::now();
    for _ in 0..runs {
        let w = Vector3::from_fn(|_, _| rng.random_range(-0.5..0.5));
        let t = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let c = Pose::new(so3_exp(&w), t);
        let points = random_points(&mut rng);
        let (f0, f1) = bearings(&c, &points);
        let solutions = solve_five_point(&f0, &f1);
        total_solutions += solutions.len();
        let truth = essential(&c);
        let best = solutions
            .iter()
            .map(|e| e_distance(e, &truth))
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    let per_call = start.elapsed().as_secs_f64() / runs as f64;
    eprintln!(
        "minimal solver: worst distance to the true E {worst:.2e}, {:.2} real solutions on \
         average, {:.1} us per solve",
        total_solutions as f64 / runs as f64,
        per_call * 1e6
    );
    assert!(worst < 1e-8);
}
