//! Rotation NEES on the simulated scenarios: is the per-frame rotation covariance calibrated?
//!
//! For every scenario and seed, simulates a drive (`momo_sim`), runs the default odometry and,
//! for each frame pair whose status is `estimated` or `weak`, computes the normalised
//! estimation error squared of the rotation vector, `NEES = δwᵀ Σ_ww⁻¹ δw` with
//! `δw = log(R_trueᵀ R_est)`, and `Σ_ww = J Σ Jᵀ` the reported covariance of the free parameters
//! carried to the rotation by `J = ∂ log(R(p̂)ᵀ R(p)) / ∂p` (central differences of the model's
//! motion; for `se3`, whose first three parameters are a rotation vector, `J ≈ [I 0]`), so any
//! model can be scored (the default is `soft_single_track`). If the covariance is right,
//! NEES follows chi-square with 3 degrees of freedom: mean 3, 95 % of frames below 7.815.
//!
//! Frames whose rotation covariance has an infinite direction (nothing constrains it) score
//! NEES 0. Standstill, degenerate and held frames are not scored (column "not scored").
//!
//! Usage: `cargo run --release -p momo-vo --example nees [FRAMES] [SEEDS...]`
//! (default 100 frames, seeds 1 2 3); `MOMO_NEES_CONFIG=cfg.toml` scores another configuration;
//! `MOMO_NEES_SCENARIOS=a,b` scores these scenarios (any `momo simulate --scenario`, e.g.
//! `moving_traffic`) instead of the default six;
//! `MOMO_NEES_TRAJECTORY=poses.txt` drives every scenario along a KITTI poses file (e.g. a KITTI
//! ground truth, as `momo simulate --trajectory`) instead of the built-in drive.
//! Prints one Markdown row per scenario.

use momo_core::{FrameEstimator, so3_log};
use momo_sim::{SimConfig, simulate};
use momo_vo::{Config, FrameStatus, Odometry};
use nalgebra::{DMatrix, Matrix3, Vector3};

/// The default configuration, or the TOML file named by `MOMO_NEES_CONFIG`.
fn config() -> Config {
    let Ok(path) = std::env::var("MOMO_NEES_CONFIG") else {
        return Config::default();
    };
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        eprintln!("nees: {path}: {e}");
        std::process::exit(2)
    });
    Config::from_toml_str(&text, &path).unwrap_or_else(|e| {
        eprintln!("nees: {e}");
        std::process::exit(2)
    })
}

/// The 95 % quantile of chi-square with 3 degrees of freedom.
const CHI2_3_95: f64 = 7.814_727_903_251_178;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(100);
    let seeds: Vec<u64> = if args.len() > 1 {
        args[1..].iter().filter_map(|a| a.parse().ok()).collect()
    } else {
        vec![1, 2, 3]
    };
    // `MOMO_NEES_FRAMES=scenario`: one line per scored frame of that scenario.
    let verbose = std::env::var("MOMO_NEES_FRAMES").ok();
    // `MOMO_NEES_SCENARIOS=a,b`: these scenarios (any of `momo simulate`'s, e.g. the
    // moving_traffic family) instead of the six static-world ones and moving_object.
    let only = std::env::var("MOMO_NEES_SCENARIOS").ok();
    let default_scenarios = [
        "clean_pinhole",
        "outliers",
        "sparse_outliers",
        "very_sparse",
        "moving_object",
        "fisheye_surround",
    ];
    let scenarios: Vec<&str> = match only.as_deref() {
        Some(list) => list
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect(),
        None => default_scenarios.to_vec(),
    };
    println!(
        "| scenario | frames scored | not scored | mean NEES | median NEES | inside 95 % chi2(3) | mean NEES per seed |"
    );
    println!("|---|---|---|---|---|---|---|");
    let trajectory = std::env::var("MOMO_NEES_TRAJECTORY").ok().map(|path| {
        momo_io::read_poses(std::path::Path::new(&path)).unwrap_or_else(|e| {
            eprintln!("nees: {e}");
            std::process::exit(2)
        })
    });
    for name in scenarios {
        let mut all = Vec::new();
        let mut held = 0usize;
        let mut per_seed = Vec::new();
        for &seed in &seeds {
            let Some(mut cfg) = SimConfig::scenario(name) else {
                eprintln!("nees: unknown scenario {name}");
                std::process::exit(2);
            };
            cfg.frames = frames;
            cfg.seed = seed;
            cfg.camera_trajectory.clone_from(&trajectory);
            let sim = match simulate(&cfg) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("nees: {name} seed {seed}: {e}");
                    std::process::exit(1);
                }
            };
            let seq = &sim.sequence;
            let mut vo = match Odometry::new(seq.rig.clone(), config()) {
                Ok(v) => v,
                Err(e) => {
                    eprintln!("nees: {e}");
                    std::process::exit(1);
                }
            };
            // With `MOMO_NEES_FRAMES`: the classical covariance alongside (no jackknife, no
            // competing motion: the same estimates), to show what the widening did.
            let mut classical = verbose.as_deref().filter(|v| *v == name).and_then(|_| {
                let mut c = config();
                c.trust.jackknife_grids.clear();
                c.trust.clustering_grids.clear();
                c.trust.report_grids.clear();
                c.trust.clustering_z = 0.0;
                c.trust.competing_min_fraction = 0.0;
                Odometry::new(seq.rig.clone(), c).ok()
            });
            let mut nees_seed = Vec::new();
            for k in 1..seq.num_frames() {
                let arc = seq.arc_length(k);
                let r = vo.process(&seq.frames[k], arc);
                let nees_classical = classical.as_mut().and_then(|c| {
                    let rc = c.process(&seq.frames[k], arc);
                    rotation_nees(
                        c.estimator(),
                        &rc.diagnostics,
                        &sim.vehicle_motions[k].rotation,
                        &rc.motion,
                    )
                });
                let d = &r.diagnostics;
                if !matches!(d.status, FrameStatus::Estimated | FrameStatus::Weak) {
                    held += 1;
                    continue;
                }
                let Some(nees) = rotation_nees(
                    vo.estimator(),
                    d,
                    &sim.vehicle_motions[k].rotation,
                    &r.motion,
                ) else {
                    held += 1;
                    continue;
                };
                if verbose.as_deref() == Some(name) {
                    print_frame(
                        &sim,
                        (k, seed),
                        d,
                        &r.motion,
                        (nees, nees_classical.unwrap_or(f64::NAN)),
                        vo.rig(),
                        (vo.estimator(), &vo.soft_prior_sigma()),
                    );
                }
                nees_seed.push(nees);
            }
            per_seed.push(mean(&nees_seed));
            all.extend(nees_seed);
        }
        let inside = all.iter().filter(|n| **n <= CHI2_3_95).count() as f64 / all.len() as f64;
        let mut sorted = all.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
        println!(
            "| {name} | {} | {held} | {:.2} | {:.2} | {:.1} % | {} |",
            all.len(),
            mean(&all),
            median,
            100.0 * inside,
            per_seed
                .iter()
                .map(|m| format!("{m:.2}"))
                .collect::<Vec<_>>()
                .join(" / ")
        );
    }
}

/// One scored frame: error of the rotation (deg), NEES with the reported and the classical
/// covariance, inliers, the object's share of the matches and of the inliers (from the
/// simulator's labels: diagnostics only), the share of matches outside the estimate's support
/// (epipolar angle above 3e-3 rad) under the estimate and under the truth, whether the
/// jackknife ran, and the competing motion (its weight and its rotation's distance to the
/// truth and to the estimate, deg).
fn print_frame(
    sim: &momo_sim::Simulation,
    (k, seed): (usize, u64),
    d: &momo_vo::FrameDiagnostics,
    est: &momo_core::Pose<f64>,
    (nees, nees_classical): (f64, f64),
    rig: &momo_core::Rig,
    (model, soft_sigma): (&dyn FrameEstimator, &[f64]),
) {
    let truth = &sim.vehicle_motions[k];
    let e = so3_log(&(truth.rotation.transpose() * est.rotation));
    let turn = so3_log(&truth.rotation).norm().to_degrees();
    let obs = &sim.sequence.frames[k];
    let angles = momo_vo::separate::epipolar_angles(rig, est, obs);
    let true_angles = momo_vo::separate::epipolar_angles(rig, truth, obs);
    let (mut n, mut obj, mut obj_in, mut outside, mut static_out_true) = (0, 0, 0, 0, 0);
    for (j, labels) in sim.labels[k].iter().enumerate() {
        for (i, l) in labels.iter().enumerate() {
            n += 1;
            let a = angles[j][i];
            let is_obj = *l == momo_sim::MatchLabel::MovingObject;
            obj += usize::from(is_obj);
            obj_in += usize::from(is_obj && a < 1e-3);
            outside += usize::from(a > 3e-3);
            static_out_true += usize::from(true_angles[j][i] > 3e-3);
        }
    }
    let competing = match &d.competing {
        Some((p, w)) => {
            let r = model.motion(p).rotation;
            format!(
                "w {w:.2} to_truth {:.3} to_est {:.3}",
                so3_log(&(truth.rotation.transpose() * r))
                    .norm()
                    .to_degrees(),
                so3_log(&(est.rotation.transpose() * r)).norm().to_degrees()
            )
        }
        None => "-".into(),
    };
    let arc = model.arc_length_index().map_or(f64::NAN, |i| d.params[i]);
    println!(
        "seed {seed} k {k:3} arc {arc:.3} soft_sigma {soft_sigma:.2?} turn {turn:.2} err {:.3} nees {nees:8.2} classical {nees_classical:8.2} \
         inl {}/{} obj {obj} obj_in {obj_in} out_est {outside} out_true {static_out_true} \
         {:?} jk {} clu {:.2} comp {competing}",
        e.norm().to_degrees(),
        d.inliers,
        n,
        d.status,
        u8::from(d.jackknife),
        d.residual_clustering,
    );
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// NEES of the rotation: the error `log(R_trueᵀ R_est)` (a small rotation vector on the right
/// of the estimate) against the reported covariance of the free parameters carried to that
/// rotation vector, `J Σ Jᵀ` with `J = ∂ log(R(p̂)ᵀ R(p)) / ∂p` by central differences.
fn rotation_nees(
    model: &dyn FrameEstimator,
    d: &momo_vo::FrameDiagnostics,
    truth: &Matrix3<f64>,
    est: &momo_core::Pose<f64>,
) -> Option<f64> {
    let n = d.free.len();
    if n == 0 || d.covariance.len() != n * n || d.params.len() != model.param_names().len() {
        return None;
    }
    let cov = DMatrix::from_row_slice(n, n, &d.covariance);
    if cov.iter().any(|v| v.is_infinite()) {
        // An unconstrained direction: infinite sigma, no error is surprising.
        return Some(0.0);
    }
    let r0 = model.motion(&d.params).rotation;
    let mut jac = DMatrix::zeros(3, n);
    let h = 1e-6;
    for (c, &i) in d.free.iter().enumerate() {
        let (mut plus, mut minus) = (d.params.clone(), d.params.clone());
        plus[i] += h;
        minus[i] -= h;
        let wp = so3_log(&(r0.transpose() * model.motion(&plus).rotation));
        let wm = so3_log(&(r0.transpose() * model.motion(&minus).rotation));
        jac.set_column(c, &((wp - wm) / (2.0 * h)));
    }
    let cw = &jac * cov * jac.transpose();
    let inv = Matrix3::from_fn(|r, c| cw[(r, c)]).try_inverse()?;
    let e: Vector3<f64> = so3_log(&(truth.transpose() * est.rotation));
    Some((e.transpose() * inv * e)[(0, 0)])
}
