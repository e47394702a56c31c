//! `momo run`.

use crate::calibrate::calibrate_mount;
use crate::common::{
    EstimatorArg, Failure, check_outputs, load_config, mount_model, progress_bar, sequence_files,
};
use crate::trajfmt::OutputFormat;
use momo_vo::{RunError, RunOptions};
use std::path::{Path, PathBuf};

/// The arguments of `momo run`.
#[derive(clap::Args, Debug)]
#[command(
    after_help = "Example:\n  momo simulate sim && momo run sim -o est.txt && momo eval --gt sim/poses.txt --est est.txt"
)]
pub(crate) struct RunArgs {
    /// The sequence directory.
    seq: PathBuf,
    /// Output file: one KITTI pose line per frame (camera 0, first frame = identity).
    /// Written atomically: on any error no file is left behind.
    #[arg(short, long)]
    output: PathBuf,
    /// Estimator configuration (TOML, or JSON if the name ends in .json); see `momo config`.
    /// Default: the built-in configuration printed by `momo config`.
    #[arg(short, long)]
    config: Option<PathBuf>,
    /// Write per-frame diagnostics (parameters, cost, iterations, termination, inliers,
    /// covariance, time, status, scale source): CSV if the name ends in .csv, JSON lines
    /// otherwise.
    #[arg(short, long)]
    diagnostics: Option<PathBuf>,
    /// No progress bar and no summary on stderr.
    #[arg(short, long)]
    quiet: bool,
    /// The estimator: `momo` (robust least squares on the configured motion manifold),
    /// `five-point` (the 5-point RANSAC baseline, OpenCV style, scaled by odometry; options
    /// in the configuration's `[five_point]`) or `five-point-refined` (the same with
    /// LO-RANSAC-style refinement, PoseLib style).
    #[arg(long, value_enum, default_value_t = EstimatorArg::Momo)]
    estimator: EstimatorArg,
    /// Calibrate the rig's mount rotation on the sequence first (as `momo calibrate`),
    /// then run with the corrected rig: two passes over the sequence, not online filtering.
    /// The calibration reads the whole sequence into memory.
    #[arg(long)]
    calibrate_mount: bool,
    /// The model of the mount calibration (with --calibrate-mount): the type tag of any
    /// registered model that can see the mount (single_track_3d, single_track_2d, or your own).
    #[arg(long, default_value = "single_track_3d")]
    mount_model: String,
    /// Calibrate on the first N frame pairs only (with --calibrate-mount; default: all).
    #[arg(long)]
    mount_frames: Option<usize>,
    /// Output format: kitti, or tum (timestamps from SEQ/times.txt, which is read and checked
    /// whenever present).
    #[arg(long, value_enum, default_value = "kitti")]
    format: OutputFormat,
}

/// `momo run`.
pub(crate) fn run(args: RunArgs) -> Result<(), Failure> {
    // Outputs are checked before anything is read: an output that is an input (any spelling
    // or link of it), given twice, a directory / FIFO / device or in a missing directory.
    let mut inputs = sequence_files(&args.seq);
    inputs.extend(args.config.clone());
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    let mut outputs = vec![args.output.as_path()];
    outputs.extend(args.diagnostics.as_deref());
    check_outputs(&inputs, &outputs)?;
    let config = load_config(args.config.as_deref())?;
    let estimator = args.estimator.into();
    let times =
        crate::trajfmt::check_times(args.format, &args.seq.join(momo_io::files::TIMES), None)?;
    // With --calibrate-mount the mount is calibrated on the sequence first (a pass over its
    // frame pairs with matches, held in memory), then the run streams the sequence with the corrected rig.
    let rig = if args.calibrate_mount {
        let options = momo_vo::MountCalibration::default()
            .with_model(Some(mount_model(&args.mount_model)?))
            .with_frames(args.mount_frames);
        let sequence = momo_io::read_sparse_sequence(&args.seq).map_err(Failure::input)?;
        Some(calibrate_mount(&sequence, &config, &options, args.quiet)?.corrected_rig)
    } else {
        None
    };
    let quiet = args.quiet;
    let bar = progress_bar(quiet, frame_pairs(&args.seq));
    let options = RunOptions {
        estimator,
        output: args.output,
        diagnostics: args.diagnostics,
        rig,
    };
    let started = std::time::Instant::now();
    let max_failed_share = config.trust.max_failed_share;
    let summary = momo_vo::run_sequence(&args.seq, config, &options, |_| bar.inc(1)).map_err(
        |e| match e {
            RunError::Input(e) => Failure::input(e),
            RunError::Vo(e) => Failure::input(e),
            RunError::Output(e) => Failure::other(e),
            e @ RunError::RigMismatch { .. } => Failure::other(e),
        },
    )?;
    bar.finish_and_clear();
    crate::trajfmt::finish(args.format, &options.output, times.as_deref())?;
    if !quiet {
        print_summary(&summary, started.elapsed(), &options.output);
    }
    untrusted(&summary, max_failed_share)
}

/// The summary of a run on stderr (`momo run`, `momo vo`): frames, statuses, scale sources.
pub(crate) fn print_summary(
    summary: &momo_vo::RunSummary,
    wall: std::time::Duration,
    output: &Path,
) {
    note!(
        "momo: {} frames in {:.2} s ({:.1} µs/frame estimating): {} estimated, {} standstill, {} without matches, {} solver failures, {} restarts won; wrote {}",
        summary.frames,
        wall.as_secs_f64(),
        1e6 * summary.compute_seconds / (summary.frames.max(2) - 1) as f64,
        summary.estimated,
        summary.standstill,
        summary.no_matches,
        summary.solver_failures,
        summary.restarts_won,
        output.display()
    );
    note!(
        "momo: trust: {} degenerate (motion held), {} weak (flagged); scale: {} from odometry, {} estimated, {} from the road, {} held, {} unobservable",
        summary.degenerate,
        summary.weak,
        summary.scale_odometry,
        summary.scale_estimated,
        summary.scale_road,
        summary.scale_held,
        summary.scale_unobservable
    );
    match &summary.road_mount {
        momo_vo::RoadMount::Calibrated(d) => {
            let d = d.map(f64::to_degrees);
            note!(
                "momo: no odometry.csv: the mount was calibrated on the first frame pairs for the road's arc length (odometry.road_scale_mount): roll {:+.3}, pitch {:+.3}, yaw {:+.3} deg",
                d.x,
                d.y,
                d.z
            );
        }
        momo_vo::RoadMount::Failed(why) => note!(
            "momo: warning: no odometry.csv, and the mount could not be calibrated for the road's arc length ({why}): the road is read through the rig as given"
        ),
        momo_vo::RoadMount::NotRun => {}
    }
    if summary.scale_never_measured() {
        note!(
            "momo: warning: the scale was never measured (no odometry.csv, no frame where the rig made it observable and none read off the road): the trajectory's scale is arbitrary"
        );
    }
}

/// Exit code 3 (with a warning) when more than `max_share` of the frame pairs failed,
/// were degenerate or held their motion for lack of matches.
pub(crate) fn untrusted(summary: &momo_vo::RunSummary, max_share: f64) -> Result<(), Failure> {
    let share = summary.failed_share();
    if share > max_share {
        return Err(Failure::Untrusted(anyhow::anyhow!(
            "{} of {} frame pairs ({:.0} %) failed or held their motion, more than \
             trust.max_failed_share = {:.0} %: the trajectory is not trustworthy (exit code 3)",
            summary.failed_or_held(),
            summary.frames.saturating_sub(1),
            100.0 * share,
            100.0 * max_share
        )));
    }
    Ok(())
}

/// The number of frame pairs of a sequence, from the last lines of matches.csv and
/// odometry.csv (for the progress bar's total and ETA; `None` if unreadable).
fn frame_pairs(seq: &Path) -> Option<u64> {
    use std::io::{Read, Seek, SeekFrom};
    let last_frame = |name: &str| -> Option<u64> {
        // Regular files only: opening a FIFO here would consume (or break) the stream that
        // the run reads next.
        if !std::fs::metadata(seq.join(name)).ok()?.is_file() {
            return None;
        }
        let mut f = std::fs::File::open(seq.join(name)).ok()?;
        let len = f.metadata().ok()?.len();
        f.seek(SeekFrom::Start(len.saturating_sub(4096))).ok()?;
        let mut tail = String::new();
        f.read_to_string(&mut tail).ok()?;
        let line = tail.lines().rev().find(|l| !l.trim().is_empty())?;
        let first = line.split(',').next()?.trim();
        first
            .parse::<u64>()
            .ok()
            .or_else(|| first.parse::<f64>().ok().map(|v| v as u64))
    };
    let n = last_frame(momo_io::files::MATCHES).max(last_frame(momo_io::files::ODOMETRY))?;
    Some(n)
}
