//! `momo demo`: simulate drives with the built-in simulator, run the default estimator on them
//! and print how close the result is to the truth. Needs no data.

use indicatif::{ProgressBar, ProgressStyle};
use momo_sim::{SimConfig, simulate};
use momo_vo::{Config, EstimatorKind, FrameStatus};
use std::io::IsTerminal;

/// The arguments of `momo demo`.
#[derive(clap::Args, Debug)]
pub(crate) struct DemoArgs {
    /// Number of frames of the simulated drive.
    #[arg(long, default_value_t = 400)]
    frames: usize,
    /// Random seed of the simulation.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

/// `momo demo`.
pub(crate) fn demo(args: DemoArgs) -> Result<(), crate::common::Failure> {
    run_demo(args.frames, args.seed, args.quiet)
}

/// Runs the demo scenarios.
fn run_demo(frames: usize, seed: u64, quiet: bool) -> Result<(), crate::common::Failure> {
    let failed = |e: anyhow::Error| crate::common::Failure::other(e.context("demo failed"));
    let frames = frames.max(2);
    let scenarios: [(&str, SimConfig); 3] = [
        ("pinhole, clean", SimConfig::clean_pinhole()),
        ("pinhole, 30% outliers", SimConfig::outliers()),
        (
            "4 fisheye cameras, one blinded",
            SimConfig::fisheye_surround(),
        ),
    ];
    outln!(
        "momo demo: {frames} frames per scenario, seed {seed}, default configuration (momo config)"
    );
    outln!(
        "{:<42} {:>9} {:>9} {:>9} {:>6} {:>9} {:>11} {:>9}",
        "scenario",
        "rot med",
        "rot p95",
        "rot max",
        ">1deg",
        "t_err %",
        "r_err d/100m",
        "us/frame"
    );
    for (name, mut sim) in scenarios {
        sim.frames = frames;
        sim.seed = seed;
        let simulation = simulate(&sim).map_err(|e| failed(e.into()))?;
        let seq = &simulation.sequence;
        let bar = if quiet || !std::io::stderr().is_terminal() {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(3 * seq.num_frames().saturating_sub(1) as u64).with_style(
                ProgressStyle::with_template("{msg:>32} {bar:40} {pos}/{len} {per_sec}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            )
        };
        bar.set_message(name);
        let gt = seq
            .ground_truth
            .as_ref()
            .ok_or_else(|| failed(anyhow::anyhow!("the simulation has no ground truth")))?;
        for (label, kind) in [
            ("momo", EstimatorKind::Momo),
            ("5-point", EstimatorKind::FivePoint),
            ("5-point LO", EstimatorKind::FivePointRefined),
        ] {
            let (poses, diags) =
                momo_vo::run_in_memory(seq, kind, Config::default(), |_| bar.inc(1))
                    .map_err(|e| failed(e.into()))?;
            let name = format!("{name} [{label}]");
            let scores = momo_eval::evaluate(gt, &poses);
            let rot = scores.rotation_deg;
            let us = diags.iter().map(|d| d.time_us).sum::<f64>() / diags.len().max(1) as f64;
            let held = diags
                .iter()
                .filter(|d| d.status == FrameStatus::NoMatches)
                .count();
            let row = format!(
                "{:<42} {:>9.4} {:>9.4} {:>9.4} {:>6} {:>9} {:>11} {:>9.1}{}",
                name,
                rot.median,
                rot.p95,
                rot.max,
                rot.above_one,
                scores
                    .t_err_percent
                    .map_or("-".into(), |t| format!("{t:.3}")),
                scores
                    .r_err_deg_per_100m
                    .map_or("-".into(), |r| format!("{r:.4}")),
                us,
                if held > 0 {
                    format!("  ({held} frames held)")
                } else {
                    String::new()
                }
            );
            // The bar is drawn on stderr below the table: hide it while a row is printed.
            bar.suspend(|| -> Result<(), crate::common::Failure> {
                outln!("{row}");
                Ok(())
            })?;
        }
        bar.finish_and_clear();
    }
    outln!(
        "rot: frame-to-frame rotation error of camera 0 in degrees; t_err, r_err: KITTI devkit metric."
    );
    Ok(())
}
