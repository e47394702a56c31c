//! Rotation NEES on the simulated scenarios: is the per-frame rotation covariance calibrated?
//!
//! For every scenario and seed, simulates a drive (`momo_sim`), runs the default odometry and,
//! for each frame pair whose status is `estimated` or `weak`, computes the normalised
//! estimation error squared of the rotation vector, `NEES = δwᵀ Σ_ww⁻¹ δw` with
//! `δw = w_est - w_true` (the first three parameters of `se3`). If the covariance is right,
//! NEES follows chi-square with 3 degrees of freedom: mean 3, 95 % of frames below 7.815.
//!
//! Frames whose rotation covariance has an infinite direction (nothing constrains it) score
//! NEES 0. Standstill, degenerate and held frames are not scored (column "not scored").
//!
//! Usage: `cargo run --release -p momo-vo --example nees [FRAMES] [SEEDS...]`
//! (default 100 frames, seeds 1 2 3). Prints one Markdown row per scenario.

use momo_core::so3_log;
use momo_sim::{SimConfig, simulate};
use momo_vo::{Config, FrameStatus, Odometry};
use nalgebra::{Matrix3, Vector3};

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
    let scenarios = [
        "clean_pinhole",
        "outliers",
        "sparse_outliers",
        "very_sparse",
        "moving_object",
        "fisheye_surround",
    ];
    println!(
        "| scenario | frames scored | not scored | mean NEES | median NEES | inside 95 % chi2(3) | mean NEES per seed |"
    );
    println!("|---|---|---|---|---|---|---|");
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
            let sim = match simulate(&cfg) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("nees: {name} seed {seed}: {e}");
                    std::process::exit(1);
                }
            };
            let seq = &sim.sequence;
            let mut vo = match Odometry::new(seq.rig.clone(), Config::default()) {
                Ok(v) => v,
                Err(e) => {
                    eprintln!("nees: {e}");
                    std::process::exit(1);
                }
            };
            let mut nees_seed = Vec::new();
            for k in 1..seq.num_frames() {
                let arc = seq
                    .arc_lengths
                    .as_ref()
                    .and_then(|a| a.get(k).copied().flatten());
                let r = vo.process(&seq.frames[k], arc);
                let d = &r.diagnostics;
                if !matches!(d.status, FrameStatus::Estimated | FrameStatus::Weak) {
                    held += 1;
                    continue;
                }
                let Some(nees) = rotation_nees(d, &sim.vehicle_motions[k].rotation, &r.motion)
                else {
                    held += 1;
                    continue;
                };
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

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// NEES of the rotation: the error `log(R_trueᵀ R_est)` (a small rotation vector, the
/// difference of the rotation parameters to first order) against the rotation block of the
/// reported covariance.
fn rotation_nees(
    d: &momo_vo::FrameDiagnostics,
    truth: &Matrix3<f64>,
    est: &momo_core::Pose<f64>,
) -> Option<f64> {
    let n = d.free.len();
    let pos: Vec<usize> = (0..3)
        .map(|i| d.free.iter().position(|&f| f == i))
        .collect::<Option<_>>()?;
    if d.covariance.len() != n * n {
        return None;
    }
    let cov = Matrix3::from_fn(|r, c| d.covariance[pos[r] * n + pos[c]]);
    if cov.iter().any(|v| v.is_infinite()) {
        // An unconstrained rotation direction: infinite sigma, no error is surprising.
        return Some(0.0);
    }
    let inv = cov.try_inverse()?;
    // Rotation parameters are a rotation vector w with R = exp(w): for small errors
    // w_est - w_true ≈ log(R_trueᵀ R_est) expressed in the same frame.
    let e: Vector3<f64> = so3_log(&(truth.transpose() * est.rotation));
    Some((e.transpose() * inv * e)[(0, 0)])
}
