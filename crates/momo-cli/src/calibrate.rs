//! `momo calibrate` and the mount calibration of `momo run --calibrate-mount`.

use crate::common::{Failure, load_config, mount_model};
use momo_vo::Config;
use std::path::PathBuf;

/// The arguments of `momo calibrate`.
#[derive(clap::Args, Debug)]
pub(crate) struct CalibrateArgs {
    /// The sequence directory (docs/FORMAT.md; odometry.csv recommended: arc lengths are held).
    seq: PathBuf,
    /// Output rig file (rig.json of docs/FORMAT.md), written atomically.
    #[arg(short, long)]
    output: PathBuf,
    /// Estimator configuration (loss, metric, solver of the per-frame starts, degenerate
    /// frame thresholds); see `momo config`. Its model is not used: see --model.
    #[arg(short, long)]
    config: Option<PathBuf>,
    /// The motion model of the calibration: the type tag of any registered model that can see
    /// the mount (single_track_3d, single_track_2d, or your own; se3 cannot).
    #[arg(long, default_value = "single_track_3d")]
    model: String,
    /// Use the first N frame pairs only (default: all).
    #[arg(long)]
    frames: Option<usize>,
    /// Estimate the mount's roll even with single_track_3d (which observes it poorly:
    /// by default it is held at zero there and estimated with single_track_2d).
    #[arg(long)]
    estimate_roll: bool,
    /// Bootstrap replicas of the uncertainty (each resamples every frame pair's matches and
    /// calibrates again; the reported sigma is the larger of theirs and the Gauss-Newton one);
    /// 0 or 1: the Gauss-Newton sigma alone, which is over-confident where the matches see the
    /// direction of travel weakly.
    #[arg(long, default_value_t = momo_vo::calibrate::DEFAULT_BOOTSTRAP)]
    bootstrap: usize,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// `momo calibrate`.
pub(crate) fn calibrate(args: CalibrateArgs) -> Result<(), Failure> {
    let options = momo_vo::MountCalibration::default()
        .with_model(Some(mount_model(&args.model)?))
        .with_frames(args.frames)
        .with_roll(args.estimate_roll.then_some(true))
        .with_bootstrap(args.bootstrap);
    let mut inputs = crate::common::sequence_files(&args.seq);
    inputs.extend(args.config.clone());
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    crate::common::check_outputs(&inputs, &[args.output.as_path()])?;
    let config = load_config(args.config.as_deref())?;
    let sequence = momo_io::read_sparse_sequence(&args.seq).map_err(Failure::input)?;
    let est = calibrate_mount(&sequence, &config, &options, args.quiet)?;
    momo_io::write_rig(&args.output, &est.corrected_rig).map_err(Failure::other)?;
    if !args.quiet {
        note!("momo: wrote {}", args.output.display());
    }
    Ok(())
}

/// Calibrates the mount of a sequence in memory (only its frame pairs with matches); prints the
/// estimate unless `quiet`.
pub(crate) fn calibrate_mount(
    sequence: &momo_io::SparseSequence,
    config: &Config,
    options: &momo_vo::MountCalibration,
    quiet: bool,
) -> Result<momo_vo::MountEstimate, Failure> {
    let started = std::time::Instant::now();
    // Every calibration error is about the input (sequence, configuration, options).
    let est = momo_vo::calibrate_sequence(sequence, config, options).map_err(Failure::input)?;
    if !quiet {
        print_mount_estimate(&est, started.elapsed().as_secs_f64())?;
    }
    Ok(est)
}

/// Prints a mount estimate: a summary on stderr, the angles on stdout.
fn print_mount_estimate(est: &momo_vo::MountEstimate, seconds: f64) -> Result<(), Failure> {
    let term = serde_json::to_string(&est.termination).unwrap_or_default();
    note!(
        "momo: mount calibration with {} over {} frame pairs ({} skipped: {} without matches, {} standstill, {} failed, {} degenerate) in {:.2} s: {} iterations ({}), cost {:.6e} -> {:.6e}",
        est.model.name(),
        est.frames_used,
        est.skipped.total(),
        est.skipped.no_matches,
        est.skipped.standstill,
        est.skipped.failed,
        est.skipped.degenerate,
        seconds,
        est.iterations,
        term.trim_matches('"'),
        est.cost_before,
        est.cost_after
    );
    let d = est.delta.map(f64::to_degrees);
    let s = est.sigma.map(f64::to_degrees);
    let (left, up) = est.travel_direction_deg();
    let held = if est.roll_estimated { "" } else { " (held)" };
    outln!(
        "mount correction, degrees (rotation of the rig about camera 0, vehicle frame x forward, y left, z up; \u{b1} 1 sigma{}):",
        if est.replicas > 0 {
            format!(
                ", sigma from {} bootstrap replicas or the curvature, the larger",
                est.replicas
            )
        } else {
            String::new()
        }
    );
    outln!("  roll  (about x) {:+.4} \u{b1} {:.4}{held}", d.x, s.x);
    outln!(
        "  pitch (about y) {:+.4} \u{b1} {:.4}  (positive: cameras nose down)",
        d.y,
        s.y
    );
    outln!(
        "  yaw   (about z) {:+.4} \u{b1} {:.4}  (positive: cameras turned left)",
        d.z,
        s.z
    );
    outln!(
        "the direction of travel lies {:.4} deg {} and {:.4} deg {} of where the nominal rig puts it",
        left.abs(),
        if left >= 0.0 { "left" } else { "right" },
        up.abs(),
        if up >= 0.0 { "above" } else { "below" }
    );
    outln!(
        "delta_deg {:.6} {:.6} {:.6} sigma_deg {:.6} {:.6} {:.6}",
        d.x,
        d.y,
        d.z,
        s.x,
        s.y,
        s.z
    );
    Ok(())
}
