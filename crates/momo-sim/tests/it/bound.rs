//! Monte-Carlo check of the Cramér-Rao bound (`momo_sim::bound`): the maximum-likelihood
//! estimate (two-view bundle adjustment: Gauss-Newton over the motion and every point, trivial
//! loss, on the static matches) of many noisy copies of one frame pair has a median rotation
//! error within 10 % of the bound's median.

use momo_core::{CameraModel, Pose, camera_motion, so3_log};
use momo_sim::bound::{frame_bound, perturb, project_pair};
use momo_sim::{MatchLabel, RigPreset, SimConfig, simulate};
use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, Vector2, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

struct Match {
    camera: usize,
    x_true: Vector3<f64>,
    u0: Vector2<f64>,
    u1: Vector2<f64>,
}

/// Directions of the motion update: rotation (3) plus translation orthogonal to t (2) when the
/// arc length is fixed.
fn basis(t: &Vector3<f64>, fix: bool) -> Vec<[f64; 6]> {
    let mut cols: Vec<[f64; 6]> = (0..3)
        .map(|i| {
            let mut c = [0.0; 6];
            c[i] = 1.0;
            c
        })
        .collect();
    if fix {
        let tn = t.normalize();
        let a = if tn.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let b1 = tn.cross(&a).normalize();
        let b2 = tn.cross(&b1);
        for b in [b1, b2] {
            cols.push([0.0, 0.0, 0.0, b.x, b.y, b.z]);
        }
    } else {
        for i in 3..6 {
            let mut c = [0.0; 6];
            c[i] = 1.0;
            cols.push(c);
        }
    }
    cols
}

/// ML estimate of the motion (pinhole cameras): Gauss-Newton on all reprojection residuals, points eliminated by
/// the Schur complement each iteration; started at the truth.
fn ml_estimate(
    rig: &momo_core::Rig,
    truth: &Pose<f64>,
    matches: &[Match],
    fix: bool,
) -> Option<Pose<f64>> {
    let s = truth.translation.norm();
    let mut m = *truth;
    let mut xs: Vec<Vector3<f64>> = matches
        .iter()
        .map(|o| Vector3::new(o.x_true.x, o.x_true.y, 1.0) / o.x_true.z)
        .collect();
    for _ in 0..8 {
        let dirs = basis(&m.translation, fix);
        let p = dirs.len();
        let mut h = DMatrix::<f64>::zeros(p, p);
        let mut g = DVector::<f64>::zeros(p);
        let mut per_point = Vec::with_capacity(matches.len());
        for (o, x) in matches.iter().zip(&xs) {
            let cam = &rig.cameras()[o.camera];
            // Inverse-depth point (α, β, ρ): X = (α, β, 1) / ρ, projected homogeneously so that
            // far points whose ρ the noise pushes through zero stay defined.
            let pix = |m: &Pose<f64>, x: &Vector3<f64>| {
                let c = camera_motion(m, &cam.t_vehicle_camera);
                let h0 = Vector3::new(x.x, x.y, 1.0);
                let h1 = c.rotation.transpose() * (h0 - x.z * c.translation);
                let a = cam.model.project(&h0)?;
                let b = cam.model.project(&h1)?;
                Some(SMatrix::<f64, 4, 1>::new(a.x, a.y, b.x, b.y))
            };
            let r = pix(&m, x)? - SMatrix::<f64, 4, 1>::new(o.u0.x, o.u0.y, o.u1.x, o.u1.y);
            let mut jd = DMatrix::<f64>::zeros(4, p);
            for (c, d) in dirs.iter().enumerate() {
                let e = 1e-7;
                let dp: [f64; 6] = d.map(|v| v * e);
                let dm: [f64; 6] = d.map(|v| -v * e);
                let col = (pix(&perturb(&m, &dp), x)? - pix(&perturb(&m, &dm), x)?) / (2.0 * e);
                jd.column_mut(c).copy_from(&col);
            }
            let mut jx = SMatrix::<f64, 4, 3>::zeros();
            let hx = 1e-7;
            for c in 0..3 {
                let mut xp = *x;
                let mut xm = *x;
                xp[c] += hx;
                xm[c] -= hx;
                jx.set_column(c, &((pix(&m, &xp)? - pix(&m, &xm)?) / (2.0 * hx)));
            }
            let jx = DMatrix::from_column_slice(4, 3, jx.as_slice());
            let r = DVector::from_column_slice(r.as_slice());
            let c = (jx.transpose() * &jx).try_inverse()?;
            let b = jd.transpose() * &jx;
            h += jd.transpose() * &jd - &b * &c * b.transpose();
            g += jd.transpose() * &r - &b * &c * (jx.transpose() * &r);
            per_point.push((jd, jx, r, c));
        }
        let step = -h.cholesky()?.solve(&g);
        let mut delta = [0.0; 6];
        for (c, d) in dirs.iter().enumerate() {
            for i in 0..6 {
                delta[i] += step[c] * d[i];
            }
        }
        m = perturb(&m, &delta);
        if fix {
            m = Pose::new(m.rotation, m.translation.normalize() * s);
        }
        for ((jd, jx, r, c), x) in per_point.iter().zip(xs.iter_mut()) {
            let dx = -(c * (jx.transpose() * (r + jd * &step)));
            *x += Vector3::new(dx[0], dx[1], dx[2]);
        }
        if step.norm() < 1e-12 {
            break;
        }
    }
    Some(m)
}

fn monte_carlo(cfg: SimConfig, k: usize, trials: usize) -> (f64, f64) {
    let sigma = cfg.pixel_noise;
    let sim = simulate(&cfg).expect("valid config");
    let bound = frame_bound(&sim, k, sigma).expect("bound defined");
    let rig = &sim.sequence.rig;
    let truth = sim.vehicle_motions[k];
    let fix = sim.sequence.arc_lengths.is_some() || rig.len() == 1;
    let mut rng = StdRng::seed_from_u64(7);
    let mut errors = Vec::with_capacity(trials);
    let points: Vec<(usize, Vector3<f64>)> = sim.static_points[k]
        .iter()
        .enumerate()
        .flat_map(|(j, pts)| {
            pts.iter()
                .zip(&sim.labels[k][j])
                .filter(|(_, l)| **l == MatchLabel::Inlier)
                .filter_map(move |(p, _)| p.map(|x| (j, x)))
        })
        .collect();
    assert_eq!(points.len(), bound.static_matches);
    for _ in 0..trials {
        let matches: Vec<Match> = points
            .iter()
            .map(|&(j, x)| {
                let cam = &rig.cameras()[j];
                let (u0, u1) = project_pair(&cam.model, &cam.t_vehicle_camera, &truth, &x)
                    .expect("the simulator's points project");
                let mut noise = || {
                    let a: f64 = rng.sample(StandardNormal);
                    let b: f64 = rng.sample(StandardNormal);
                    Vector2::new(a, b) * sigma
                };
                Match {
                    camera: j,
                    x_true: x,
                    u0: u0 + noise(),
                    u1: u1 + noise(),
                }
            })
            .collect();
        let est = ml_estimate(rig, &truth, &matches, fix).expect("ML converges");
        let err: Matrix3<f64> = truth.rotation.transpose() * est.rotation;
        errors.push(so3_log(&err).norm().to_degrees());
    }
    errors.sort_by(f64::total_cmp);
    eprintln!(
        "{} static matches; ML median {:.5} deg, bound {:.5} deg",
        points.len(),
        errors[trials / 2],
        bound.median_deg
    );
    (errors[trials / 2], bound.median_deg)
}

#[test]
fn ml_reaches_the_bound_mono_with_odometry() {
    let cfg = SimConfig {
        frames: 12,
        seed: 3,
        matches_per_camera: 150,
        pixel_noise: 1.0,
        outlier_ratio: 0.0,
        ..SimConfig::default()
    };
    let (mc, bound) = monte_carlo(cfg, 9, 300);
    assert!(
        (mc / bound - 1.0).abs() < 0.10,
        "Monte-Carlo ML median {mc:.5} deg vs bound {bound:.5} deg"
    );
}

#[test]
fn ml_reaches_the_bound_stereo() {
    let cfg = SimConfig {
        frames: 8,
        seed: 11,
        matches_per_camera: 80,
        pixel_noise: 0.5,
        outlier_ratio: 0.0,
        rig: RigPreset::KittiStereo,
        ..SimConfig::default()
    };
    let (mc, bound) = monte_carlo(cfg, 5, 300);
    assert!(
        (mc / bound - 1.0).abs() < 0.10,
        "Monte-Carlo ML median {mc:.5} deg vs bound {bound:.5} deg"
    );
}

#[test]
fn moving_traffic_objects_hold_30_to_70_percent_of_the_matches() {
    for seed in [1, 2] {
        let cfg = SimConfig {
            frames: 120,
            seed,
            ..SimConfig::moving_traffic()
        };
        let sim = simulate(&cfg).expect("valid config");
        assert_eq!(sim, simulate(&cfg).expect("valid config"), "deterministic");
        let mut with_objects = 0;
        for k in 1..sim.labels.len() {
            let l = &sim.labels[k][0];
            let on_object = l.iter().filter(|x| **x == MatchLabel::MovingObject).count();
            let static_ = l.iter().filter(|x| **x == MatchLabel::Inlier).count();
            assert!(
                static_ >= 40,
                "seed {seed} frame {k}: {static_} static matches"
            );
            if on_object > 0 {
                with_objects += 1;
                // Of the matches before outliers replace 5 % of them.
                let f = on_object as f64 / (on_object + static_) as f64;
                assert!((0.2..=0.75).contains(&f), "seed {seed} frame {k}: {f}");
            }
            // Static points carry no object labels and vice versa.
            for (p, lab) in sim.static_points[k][0].iter().zip(l) {
                assert_eq!(p.is_some(), *lab == MatchLabel::Inlier);
            }
        }
        assert!(
            with_objects >= 60,
            "seed {seed}: objects in {with_objects} of 119 pairs"
        );
    }
}
