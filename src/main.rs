//! The `momo` command-line tool: a thin shell over the momo library crates.

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use momo_io::kitti::{KittiImport, import_l1avgvo};
use momo_vo::{Config, RunError, RunOptions};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod demo;

/// momo: frame-to-frame vehicle motion from sparse feature matches of one or more cameras, by
/// robust non-linear least squares on motion manifolds ("Momo: Monocular Motion Estimation on
/// Manifolds").
#[derive(Parser, Debug)]
#[command(name = "momo", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Estimate the trajectory of a sequence directory (FORMAT.md: rig.json, matches.csv,
    /// optional odometry.csv) and write camera 0's poses in the KITTI format.
    Run {
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
        /// Reads the whole sequence into memory; --diagnostics is then written as JSON lines.
        #[arg(long)]
        calibrate_mount: bool,
        /// The model of the mount calibration (with --calibrate-mount).
        #[arg(long, value_enum, default_value_t = MountModelArg::SingleTrack3d)]
        mount_model: MountModelArg,
        /// Calibrate on the first N frame pairs only (with --calibrate-mount; default: all).
        #[arg(long)]
        mount_frames: Option<usize>,
    },
    /// Estimate the rig's mount rotation relative to the vehicle jointly over the frame pairs
    /// of a sequence (robust Levenberg-Marquardt on a single-track model, Schur complement over
    /// the shared mount) and write the corrected rig.json.
    Calibrate {
        /// The sequence directory (FORMAT.md; odometry.csv recommended: arc lengths are held).
        seq: PathBuf,
        /// Output rig file (rig.json of FORMAT.md), written atomically.
        #[arg(short, long)]
        output: PathBuf,
        /// Estimator configuration (loss, metric, solver of the per-frame starts, degenerate
        /// frame thresholds); see `momo config`. Its model is not used: see --model.
        #[arg(short, long)]
        config: Option<PathBuf>,
        /// The motion model of the calibration.
        #[arg(long, value_enum, default_value_t = MountModelArg::SingleTrack3d)]
        model: MountModelArg,
        /// Use the first N frame pairs only (default: all).
        #[arg(long)]
        frames: Option<usize>,
        /// Estimate the mount's roll even with single_track_3d (which observes it poorly:
        /// by default it is held at zero there and estimated with single_track_2d).
        #[arg(long)]
        estimate_roll: bool,
        /// Print nothing but errors.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Print the default configuration as a commented TOML file.
    Config,
    /// Write a simulated sequence (FORMAT.md, with poses.txt ground truth) to a directory.
    Simulate {
        /// Scenario: clean_pinhole, outliers (30 %, 1 px), moving_object, fisheye_surround,
        /// sparse_outliers (100 matches, 30 %), very_sparse (40 matches), highway (25-30 m/s).
        #[arg(long, default_value = "clean_pinhole")]
        scenario: String,
        /// Drive along the camera-0 poses of this KITTI poses file (e.g. a KITTI ground truth)
        /// instead of a generated drive; the vehicle poses are P0 · C_k · P0⁻¹ with P0 the
        /// scenario rig's camera 0. At most --frames frames.
        #[arg(long)]
        trajectory: Option<PathBuf>,
        /// Number of frames.
        #[arg(long, default_value_t = 400)]
        frames: usize,
        /// Random seed (the output is deterministic for a seed).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Matches per camera and frame pair (default: the scenario's).
        #[arg(long)]
        matches: Option<usize>,
        /// Output directory (created).
        out_dir: PathBuf,
    },
    /// Import the real KITTI 00 stereo matches of the `l1avgvo` demo (calib.txt, poses*.txt,
    /// a folder of `i_to_{i+1}.txt` files) as a sequence directory (FORMAT.md, with poses.txt
    /// ground truth and odometry.csv arc lengths from it).
    ImportKitti {
        /// The data folder (holding calib.txt).
        dir: PathBuf,
        /// Output sequence directory (created).
        out_dir: PathBuf,
        /// A stereo rig (left = camera 0, right = camera 1) instead of the left camera only.
        #[arg(long)]
        stereo: bool,
        /// Keep at most this many matches per frame pair and camera, spread over the image
        /// (default: all).
        #[arg(long)]
        matches: Option<usize>,
        /// Seed of the sub-sampling (the output is deterministic for a seed).
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Score estimated trajectories against ground truth (KITTI pose files, camera 0): KITTI
    /// devkit t_err / r_err and the frame-to-frame rotation errors.
    Eval {
        /// Ground-truth poses (KITTI format).
        #[arg(long)]
        gt: PathBuf,
        /// Estimated poses (KITTI format, as many lines as the ground truth); repeat for several.
        #[arg(long = "est", required = true)]
        est: Vec<PathBuf>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Draw figures as PNG or SVG (chosen by the output file's extension): trajectories,
    /// frame-to-frame rotation errors, the cost landscape of a frame.
    Plot {
        #[command(subcommand)]
        figure: PlotCommand,
    },
    /// Run every combination of a grid (models x metrics x losses x scales x solvers x matches)
    /// on every sequence in parallel, score each against the ground truth and write
    /// results.csv and summary.md; `--shard I/N` runs one slice, `momo sweep merge` joins them.
    Sweep(momo_sweep::cli::SweepArgs),
    /// Detect and match features in image sequences (PNG/JPEG, one folder per camera in the
    /// rig's order, files in name order) and write a sequence directory: matches.csv
    /// (FORMAT.md), a copy of the rig file as rig.json, and with --odometry a copy of it as
    /// odometry.csv, so that `momo run SEQ_DIR` follows.
    Match {
        /// Image folders, one per camera of the rig.
        #[arg(required = true)]
        images: Vec<PathBuf>,
        /// The rig (rig.json of FORMAT.md); image sizes must match its cameras.
        #[arg(long)]
        rig: PathBuf,
        /// odometry.csv (arc lengths) to copy into the sequence directory.
        #[arg(long)]
        odometry: Option<PathBuf>,
        /// Output sequence directory (created).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        front: FrontEndArgs,
        /// No progress bar and no summary on stderr.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Visual odometry from images in one streaming pass: match consecutive frames and
    /// estimate the motion frame by frame; writes camera 0's trajectory (KITTI format, one line
    /// per image frame).
    Vo {
        /// Image folders, one per camera of the rig.
        #[arg(required = true)]
        images: Vec<PathBuf>,
        /// The rig (rig.json of FORMAT.md); image sizes must match its cameras.
        #[arg(long)]
        rig: PathBuf,
        /// Arc lengths per frame pair (odometry.csv of FORMAT.md): fixes the scale.
        #[arg(long)]
        odometry: Option<PathBuf>,
        /// Output trajectory (KITTI format), written atomically.
        #[arg(short, long)]
        output: PathBuf,
        /// Estimator configuration (TOML, or JSON if the name ends in .json); see `momo config`.
        #[arg(short, long)]
        config: Option<PathBuf>,
        /// The estimator (as for `momo run`).
        #[arg(long, value_enum, default_value_t = EstimatorArg::Momo)]
        estimator: EstimatorArg,
        #[command(flatten)]
        front: FrontEndArgs,
        /// No progress bar and no summary on stderr.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Simulate a drive (no data needed), run the estimator on it and print how close the
    /// result is to the truth.
    Demo {
        /// Number of frames of the simulated drive.
        #[arg(long, default_value_t = 400)]
        frames: usize,
        /// Random seed of the simulation.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// No progress bar.
        #[arg(short, long)]
        quiet: bool,
    },
}

/// The figures of `momo plot`.
#[derive(Subcommand, Debug)]
enum PlotCommand {
    /// Trajectories seen from above (x against z of camera 0's position): the ground truth and
    /// each estimate, named by file in the legend.
    Trajectory {
        /// Ground-truth poses (KITTI format).
        #[arg(long)]
        gt: PathBuf,
        /// Estimated poses (KITTI format); repeat for several.
        #[arg(long = "est")]
        est: Vec<PathBuf>,
        /// Output image: .png or .svg (written atomically).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// The frame-to-frame rotation error (degrees) of each estimate over the path length along
    /// the ground truth (upper panel) and over the speed (lower panel).
    Errors {
        /// Ground-truth poses (KITTI format).
        #[arg(long)]
        gt: PathBuf,
        /// Estimated poses (KITTI format, as many lines as the ground truth); repeat for several.
        #[arg(long = "est", required = true)]
        est: Vec<PathBuf>,
        /// Output image: .png or .svg (written atomically).
        #[arg(short, long)]
        output: PathBuf,
        /// Frame rate in Hz (speed = displacement per frame × frame rate).
        #[arg(long, default_value_t = 10.0)]
        frame_rate: f64,
    },
    /// The cost of one frame pair over a grid of yaw × arc length around its estimate, as a
    /// heat map with the minimum marked. Uses the configuration's model if it has `yaw` and
    /// `arc_length` parameters, `single_track_2d` otherwise.
    Landscape {
        /// The sequence directory.
        seq: PathBuf,
        /// The frame pair k = (k-1, k) (the odometry runs over frames 1..=k first).
        #[arg(long)]
        frame: usize,
        /// Output image: .png or .svg (written atomically).
        #[arg(short, long)]
        output: PathBuf,
        /// Estimator configuration (TOML, or JSON if the name ends in .json); see `momo config`.
        #[arg(short, long)]
        config: Option<PathBuf>,
        /// Half-width of the yaw axis around the estimate, degrees.
        #[arg(long, default_value_t = 2.0)]
        range_yaw: f64,
        /// Half-width of the arc-length axis around the estimate, metres.
        #[arg(long, default_value_t = 0.5)]
        range_arc: f64,
        /// Grid points per axis.
        #[arg(long, default_value_t = 81)]
        steps: usize,
    },
}

/// Options of the feature front end (`momo match`, `momo vo`).
#[derive(clap::Args, Debug, Clone, Copy)]
struct FrontEndArgs {
    /// Matches per frame pair and camera, spread over the image by bucketing.
    #[arg(long, default_value_t = 200)]
    matches: usize,
    /// Gamma correction of every image (out = 255 (in/255)^(1/gamma)); none by default.
    #[arg(long)]
    gamma: Option<f64>,
    /// Largest horizontal flow searched, pixels.
    #[arg(long, default_value_t = 200)]
    max_flow_u: u32,
    /// Largest vertical flow searched, pixels.
    #[arg(long, default_value_t = 100)]
    max_flow_v: u32,
    /// Non-maximum suppression radius of the blob and corner detector, pixels.
    #[arg(long, default_value_t = 5)]
    nms_radius: usize,
    /// Minimum filter response of a feature.
    #[arg(long, default_value_t = 50)]
    threshold: i32,
}

impl From<FrontEndArgs> for momo_match::FrontEndOptions {
    fn from(a: FrontEndArgs) -> Self {
        let d = momo_match::MatchOptions::default();
        Self {
            matching: momo_match::MatchOptions {
                matches_per_frame: a.matches,
                max_flow_u: a.max_flow_u,
                max_flow_v: a.max_flow_v,
                detector: momo_match::DetectorOptions {
                    nms_radius: a.nms_radius,
                    threshold: a.threshold,
                },
                ..d
            },
            gamma: a.gamma,
        }
    }
}

/// Maps a front-end error: bad input exits with 2, failed writes with 1.
fn match_failure(e: momo_match::MatchError) -> Failure {
    if e.is_input() {
        Failure::Input(e.into())
    } else {
        Failure::Other(e.into())
    }
}

/// `momo match`.
fn match_cmd(
    images: &[PathBuf],
    rig: &Path,
    odometry: Option<&Path>,
    output: &Path,
    front: FrontEndArgs,
    quiet: bool,
) -> Result<(), Failure> {
    let bar = progress_bar(quiet, None);
    let started = std::time::Instant::now();
    let stats =
        momo_match::match_to_sequence(images, rig, output, odometry, &front.into(), |_| bar.inc(1))
            .map_err(match_failure)?;
    bar.finish_and_clear();
    if !quiet {
        eprintln!(
            "momo: {} frames, {} matches in {:.2} s ({:.1} ms/frame matching, {:.1} ms/frame decoding); wrote {}",
            stats.frames,
            stats.matches,
            started.elapsed().as_secs_f64(),
            stats.match_ms_per_frame(),
            stats.decode_ms_per_frame(),
            output.display()
        );
    }
    Ok(())
}

/// `momo vo`.
fn vo_cmd(
    run: momo_match::VoRun,
    config: Option<PathBuf>,
    front: FrontEndArgs,
    quiet: bool,
) -> Result<(), Failure> {
    let config = match &config {
        Some(p) => Config::from_file(p).map_err(|e| Failure::Input(e.into()))?,
        None => Config::default(),
    };
    let frames = momo_match::ImageSequence::open(&run.folders)
        .map_err(match_failure)?
        .len();
    let bar = progress_bar(quiet, Some(frames.saturating_sub(1) as u64));
    let started = std::time::Instant::now();
    let summary = momo_match::vo_from_images(&run, config, &front.into(), |_| bar.inc(1))
        .map_err(match_failure)?;
    bar.finish_and_clear();
    if !quiet {
        let f = summary.front_end;
        eprintln!(
            "momo: {} frames in {:.2} s ({:.1} ms/frame matching, {:.1} ms/frame decoding, {:.1} µs/frame estimating): {} estimated, {} not; {} matches; wrote {}",
            summary.poses,
            started.elapsed().as_secs_f64(),
            f.match_ms_per_frame(),
            f.decode_ms_per_frame(),
            1e6 * summary.estimate_seconds / (summary.poses.max(2) - 1) as f64,
            summary.estimated,
            summary.not_estimated,
            f.matches,
            run.output.display()
        );
    }
    Ok(())
}

/// The `--estimator` choices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum EstimatorArg {
    /// Robust least squares on the configured motion manifold.
    Momo,
    /// The 5-point RANSAC baseline.
    FivePoint,
    /// The 5-point RANSAC baseline with LO-RANSAC-style refinement of the final hypothesis.
    FivePointRefined,
}

impl From<EstimatorArg> for momo_vo::EstimatorKind {
    fn from(e: EstimatorArg) -> Self {
        match e {
            EstimatorArg::Momo => momo_vo::EstimatorKind::Momo,
            EstimatorArg::FivePoint => momo_vo::EstimatorKind::FivePoint,
            EstimatorArg::FivePointRefined => momo_vo::EstimatorKind::FivePointRefined,
        }
    }
}

/// The `--model` choices of the mount calibration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum MountModelArg {
    /// The single-track model on a tilted plane (yaw, arc length, pitch, roll).
    #[value(name = "single_track_3d")]
    SingleTrack3d,
    /// The planar single-track model (yaw, arc length).
    #[value(name = "single_track_2d")]
    SingleTrack2d,
}

impl From<MountModelArg> for momo_vo::MountModel {
    fn from(m: MountModelArg) -> Self {
        match m {
            MountModelArg::SingleTrack3d => momo_vo::MountModel::default(),
            MountModelArg::SingleTrack2d => momo_vo::MountModel::SingleTrack2d,
        }
    }
}

/// Input errors exit with 2, everything else with 1.
enum Failure {
    Input(anyhow::Error),
    Other(anyhow::Error),
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

fn progress_bar(quiet: bool, len: Option<u64>) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    match len {
        Some(n) => ProgressBar::new(n).with_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames {per_sec} eta {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        ),
        None => ProgressBar::new_spinner().with_style(
            ProgressStyle::with_template("{spinner} {pos} frames {per_sec}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        ),
    }
}

/// Reads a configuration file, or the default.
fn load_config(config: Option<&Path>) -> Result<Config, Failure> {
    match config {
        Some(p) => Config::from_file(p).map_err(|e| Failure::Input(e.into())),
        None => Ok(Config::default()),
    }
}

/// Calibrates the mount of a sequence in memory; prints the estimate unless `quiet`.
fn calibrate_mount(
    sequence: &momo_io::Sequence,
    config: &Config,
    options: &momo_vo::MountCalibration,
    quiet: bool,
) -> Result<momo_vo::MountEstimate, Failure> {
    let started = std::time::Instant::now();
    // Every calibration error is about the input (sequence, configuration, options).
    let est = momo_vo::calibrate_sequence(sequence, config, options)
        .map_err(|e| Failure::Input(e.into()))?;
    if !quiet {
        print_mount_estimate(&est, started.elapsed().as_secs_f64());
    }
    Ok(est)
}

/// Prints a mount estimate: a summary on stderr, the angles on stdout.
fn print_mount_estimate(est: &momo_vo::MountEstimate, seconds: f64) {
    let term = serde_json::to_string(&est.termination).unwrap_or_default();
    eprintln!(
        "momo: mount calibration with {} over {} frame pairs ({} skipped: {} without matches, {} standstill, {} failed) in {:.2} s: {} iterations ({}), cost {:.6e} -> {:.6e}",
        est.model.name(),
        est.frames_used,
        est.skipped.total(),
        est.skipped.no_matches,
        est.skipped.standstill,
        est.skipped.failed,
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
    println!(
        "mount correction, degrees (rotation of the rig about camera 0, vehicle frame x forward, y left, z up; \u{b1} 1 sigma):"
    );
    println!("  roll  (about x) {:+.4} \u{b1} {:.4}{held}", d.x, s.x);
    println!(
        "  pitch (about y) {:+.4} \u{b1} {:.4}  (positive: cameras nose down)",
        d.y, s.y
    );
    println!(
        "  yaw   (about z) {:+.4} \u{b1} {:.4}  (positive: cameras turned left)",
        d.z, s.z
    );
    println!(
        "the direction of travel lies {:.4} deg {} and {:.4} deg {} of where the nominal rig puts it",
        left.abs(),
        if left >= 0.0 { "left" } else { "right" },
        up.abs(),
        if up >= 0.0 { "above" } else { "below" }
    );
    println!(
        "delta_deg {:.6} {:.6} {:.6} sigma_deg {:.6} {:.6} {:.6}",
        d.x, d.y, d.z, s.x, s.y, s.z
    );
}

/// `momo calibrate`.
fn calibrate(
    seq: &Path,
    output: &Path,
    config: Option<&Path>,
    options: &momo_vo::MountCalibration,
    quiet: bool,
) -> Result<(), Failure> {
    let config = load_config(config)?;
    let sequence = momo_io::read_sequence(seq).map_err(|e| Failure::Input(e.into()))?;
    let est = calibrate_mount(&sequence, &config, options, quiet)?;
    momo_io::write_rig(output, &est.corrected_rig).map_err(|e| Failure::Other(e.into()))?;
    if !quiet {
        eprintln!("momo: wrote {}", output.display());
    }
    Ok(())
}

/// `momo run --calibrate-mount`: calibrate on the sequence, then run it with the corrected rig
/// (in memory: the calibration needs every frame anyway).
fn run_calibrated(
    seq: &Path,
    output: &Path,
    config: Config,
    diagnostics: Option<&Path>,
    quiet: bool,
    estimator: momo_vo::EstimatorKind,
    options: &momo_vo::MountCalibration,
) -> Result<(), Failure> {
    if let Some(d) = diagnostics
        && d.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"))
    {
        return Err(Failure::Input(anyhow::anyhow!(
            "{}: with --calibrate-mount the diagnostics are written as JSON lines; give a name not ending in .csv",
            d.display()
        )));
    }
    let mut sequence = momo_io::read_sequence(seq).map_err(|e| Failure::Input(e.into()))?;
    let est = calibrate_mount(&sequence, &config, options, quiet)?;
    sequence.rig = est.corrected_rig;
    let bar = progress_bar(quiet, Some(sequence.num_frames().saturating_sub(1) as u64));
    let started = std::time::Instant::now();
    let (poses, diags) = momo_vo::run_in_memory(&sequence, estimator, config, |_| bar.inc(1))
        .map_err(|e| Failure::Input(e.into()))?;
    bar.finish_and_clear();
    momo_io::write_poses(output, &poses).map_err(|e| Failure::Other(e.into()))?;
    if let Some(path) = diagnostics {
        let mut text = String::new();
        for d in &diags {
            let line = serde_json::to_string(d).map_err(|e| Failure::Other(e.into()))?;
            text.push_str(&line);
            text.push('\n');
        }
        let mut file = momo_io::AtomicFile::create(path).map_err(|e| Failure::Other(e.into()))?;
        std::io::Write::write_all(file.writer(), text.as_bytes())
            .map_err(|e| Failure::Other(file.err(e).into()))?;
        file.commit().map_err(|e| Failure::Other(e.into()))?;
    }
    if !quiet {
        let count = |s: momo_vo::FrameStatus| diags.iter().filter(|d| d.status == s).count();
        let compute: f64 = diags.iter().map(|d| d.time_us).sum();
        eprintln!(
            "momo: {} frames in {:.2} s ({:.1} µs/frame estimating) with the calibrated rig: {} estimated, {} standstill, {} without matches, {} solver failures, {} restarts won; wrote {}",
            poses.len(),
            started.elapsed().as_secs_f64(),
            compute / diags.len().max(1) as f64,
            count(momo_vo::FrameStatus::Estimated),
            count(momo_vo::FrameStatus::Standstill),
            count(momo_vo::FrameStatus::NoMatches),
            count(momo_vo::FrameStatus::SolverFailure),
            diags.iter().filter(|d| d.restart_won).count(),
            output.display()
        );
    }
    Ok(())
}

fn run(
    seq: PathBuf,
    output: PathBuf,
    config: Option<PathBuf>,
    diagnostics: Option<PathBuf>,
    quiet: bool,
    estimator: momo_vo::EstimatorKind,
    mount: Option<momo_vo::MountCalibration>,
) -> Result<(), Failure> {
    let config = load_config(config.as_deref())?;
    if let Some(options) = mount {
        return run_calibrated(
            &seq,
            &output,
            config,
            diagnostics.as_deref(),
            quiet,
            estimator,
            &options,
        );
    }
    let bar = progress_bar(quiet, None);
    let options = RunOptions {
        estimator,
        output,
        diagnostics,
    };
    let started = std::time::Instant::now();
    let summary =
        momo_vo::run_sequence(&seq, config, &options, |_| bar.inc(1)).map_err(|e| match e {
            RunError::Input(e) => Failure::Input(e.into()),
            RunError::Vo(e) => Failure::Input(e.into()),
            RunError::Output(e) => Failure::Other(e.into()),
        })?;
    bar.finish_and_clear();
    if !quiet {
        let wall = started.elapsed().as_secs_f64();
        eprintln!(
            "momo: {} frames in {:.2} s ({:.1} µs/frame estimating): {} estimated, {} standstill, {} without matches, {} solver failures, {} restarts won; wrote {}",
            summary.frames,
            wall,
            1e6 * summary.compute_seconds / (summary.frames.max(2) - 1) as f64,
            summary.estimated,
            summary.standstill,
            summary.no_matches,
            summary.solver_failures,
            summary.restarts_won,
            options.output.display()
        );
    }
    Ok(())
}

fn simulate(
    scenario: &str,
    trajectory: Option<&Path>,
    frames: usize,
    seed: u64,
    matches: Option<usize>,
    out_dir: &std::path::Path,
) -> Result<(), Failure> {
    use momo_sim::SimConfig;
    let Some(mut cfg) = SimConfig::scenario(scenario) else {
        return Err(Failure::Input(anyhow::anyhow!(
            "unknown scenario `{scenario}` ({})",
            SimConfig::SCENARIOS.join(", ")
        )));
    };
    if let Some(path) = trajectory {
        let poses = momo_io::read_poses(path).map_err(|e| Failure::Input(e.into()))?;
        if poses.is_empty() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: no poses",
                path.display()
            )));
        }
        cfg.camera_trajectory = Some(poses);
    }
    cfg.frames = frames;
    cfg.seed = seed;
    if let Some(m) = matches {
        cfg.matches_per_camera = m;
    }
    let sim = momo_sim::simulate(&cfg).map_err(|e| Failure::Input(e.into()))?;
    sim.write(out_dir).map_err(|e| Failure::Other(e.into()))?;
    Ok(())
}

fn import_kitti(
    dir: &Path,
    out_dir: &Path,
    stereo: bool,
    matches: Option<usize>,
    seed: u64,
) -> Result<(), Failure> {
    if matches == Some(0) {
        return Err(Failure::Input(anyhow::anyhow!(
            "--matches must be at least 1"
        )));
    }
    let options = KittiImport {
        stereo,
        matches_per_frame: matches,
        seed,
    };
    let seq = import_l1avgvo(dir, &options).map_err(|e| Failure::Input(e.into()))?;
    momo_io::write_sequence(out_dir, &seq).map_err(|e| Failure::Other(e.into()))?;
    eprintln!(
        "momo: imported {} frames, {} camera(s), {} matches{}; wrote {}",
        seq.num_frames(),
        seq.rig.len(),
        seq.num_matches(),
        if seq.ground_truth.is_some() {
            " with ground truth and arc lengths"
        } else {
            ""
        },
        out_dir.display()
    );
    Ok(())
}

/// The scores of one estimate (`momo eval --json`).
#[derive(serde::Serialize)]
struct EvalRow {
    path: PathBuf,
    #[serde(flatten)]
    scores: momo_eval::Evaluation,
}

fn eval(gt: &Path, estimates: &[PathBuf], json: bool) -> Result<(), Failure> {
    let ground_truth = momo_io::read_poses(gt).map_err(|e| Failure::Input(e.into()))?;
    let mut rows = Vec::with_capacity(estimates.len());
    for path in estimates {
        let est = momo_io::read_poses(path).map_err(|e| Failure::Input(e.into()))?;
        if est.len() != ground_truth.len() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: {} poses, but the ground truth {} has {}",
                path.display(),
                est.len(),
                gt.display(),
                ground_truth.len()
            )));
        }
        rows.push(EvalRow {
            path: path.clone(),
            scores: momo_eval::evaluate(&ground_truth, &est),
        });
    }
    if json {
        let doc = serde_json::json!({
            "ground_truth": gt,
            "frames": ground_truth.len(),
            "estimates": rows,
        });
        println!("{doc}");
        return Ok(());
    }
    println!(
        "{} frames; frame-to-frame rotation errors in degrees; KITTI devkit t_err in %, r_err in deg/100 m (\"-\": path shorter than 100 m)",
        ground_truth.len()
    );
    println!(
        "{:>8} {:>8} {:>8} {:>8} {:>8} {:>5}  estimate",
        "t_err", "r_err", "median", "p95", "max", ">1deg"
    );
    for row in &rows {
        let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
        let (t, r) = (
            fmt(row.scores.t_err_percent),
            fmt(row.scores.r_err_deg_per_100m),
        );
        let s = &row.scores.rotation_deg;
        println!(
            "{t:>8} {r:>8} {:>8.4} {:>8.4} {:>8.4} {:>5}  {}",
            s.median,
            s.p95,
            s.max,
            s.above_one,
            row.path.display()
        );
    }
    Ok(())
}

/// Maps a plotting error: bad data or options are input errors, drawing and writing are not.
fn plot_failure(e: momo_plot::PlotError) -> Failure {
    use momo_plot::PlotError;
    match e {
        PlotError::Format(_) | PlotError::Input(_) | PlotError::Vo(_) | PlotError::Core(_) => {
            Failure::Input(e.into())
        }
        PlotError::Draw(_) | PlotError::Io(_) => Failure::Other(e.into()),
    }
}

/// An estimate's file name and its poses.
type NamedPoses = (String, Vec<momo_core::Pose<f64>>);

/// Reads the ground truth and the estimates; with `same_length`, every estimate must have as
/// many poses as the ground truth.
fn read_trajectories(
    gt: &Path,
    est: &[PathBuf],
    same_length: bool,
) -> Result<(Vec<momo_core::Pose<f64>>, Vec<NamedPoses>), Failure> {
    let ground_truth = momo_io::read_poses(gt).map_err(|e| Failure::Input(e.into()))?;
    let mut estimates = Vec::with_capacity(est.len());
    for path in est {
        let poses = momo_io::read_poses(path).map_err(|e| Failure::Input(e.into()))?;
        if same_length && poses.len() != ground_truth.len() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: {} poses, but the ground truth {} has {}",
                path.display(),
                poses.len(),
                gt.display(),
                ground_truth.len()
            )));
        }
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        estimates.push((name, poses));
    }
    Ok((ground_truth, estimates))
}

fn plot(figure: PlotCommand) -> Result<(), Failure> {
    // The format is checked before any input is read.
    let output = match &figure {
        PlotCommand::Trajectory { output, .. }
        | PlotCommand::Errors { output, .. }
        | PlotCommand::Landscape { output, .. } => output.clone(),
    };
    momo_plot::Format::from_path(&output).map_err(plot_failure)?;
    match figure {
        PlotCommand::Trajectory { gt, est, output } => {
            let (ground_truth, estimates) = read_trajectories(&gt, &est, false)?;
            let named: Vec<(&str, &[momo_core::Pose<f64>])> = estimates
                .iter()
                .map(|(n, p)| (n.as_str(), p.as_slice()))
                .collect();
            momo_plot::plot_trajectories(&ground_truth, &named, &output).map_err(plot_failure)?;
        }
        PlotCommand::Errors {
            gt,
            est,
            output,
            frame_rate,
        } => {
            let (ground_truth, estimates) = read_trajectories(&gt, &est, true)?;
            let named: Vec<(&str, &[momo_core::Pose<f64>])> = estimates
                .iter()
                .map(|(n, p)| (n.as_str(), p.as_slice()))
                .collect();
            momo_plot::plot_rotation_errors(&ground_truth, &named, frame_rate, &output)
                .map_err(plot_failure)?;
        }
        PlotCommand::Landscape {
            seq,
            frame,
            output,
            config,
            range_yaw,
            range_arc,
            steps,
        } => {
            let config = match &config {
                Some(p) => Config::from_file(p).map_err(|e| Failure::Input(e.into()))?,
                None => Config::default(),
            };
            let sequence = momo_io::read_sequence(&seq).map_err(|e| Failure::Input(e.into()))?;
            let options = momo_plot::LandscapeOptions {
                frame,
                range_yaw_deg: range_yaw,
                range_arc,
                steps,
            };
            let landscape =
                momo_plot::compute_landscape(&sequence, config, &options).map_err(plot_failure)?;
            momo_plot::plot_landscape(&landscape, &output).map_err(plot_failure)?;
            if let Some((yaw, arc, cost)) = landscape.minimum() {
                let (ey, ea) = landscape.estimate_point();
                eprintln!(
                    "momo: frame {frame}: estimate yaw {ey:.4} deg, arc length {ea:.4} m; grid minimum yaw {yaw:.4} deg, arc length {arc:.4} m, cost {cost:.6e}"
                );
            }
        }
    }
    if !momo_plot::font_available() {
        eprintln!(
            "momo: warning: no TrueType font found (set MOMO_PLOT_FONT to a .ttf file): drew without text"
        );
    }
    eprintln!("momo: wrote {}", output.display());
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            seq,
            output,
            config,
            diagnostics,
            quiet,
            estimator,
            calibrate_mount,
            mount_model,
            mount_frames,
        } => run(
            seq,
            output,
            config,
            diagnostics,
            quiet,
            estimator.into(),
            calibrate_mount.then(|| {
                momo_vo::MountCalibration::default()
                    .with_model(Some(mount_model.into()))
                    .with_frames(mount_frames)
            }),
        ),
        Command::Calibrate {
            seq,
            output,
            config,
            model,
            frames,
            estimate_roll,
            quiet,
        } => calibrate(
            &seq,
            &output,
            config.as_deref(),
            &momo_vo::MountCalibration::default()
                .with_model(Some(model.into()))
                .with_frames(frames)
                .with_roll(estimate_roll.then_some(true)),
            quiet,
        ),
        Command::Config => {
            print!("{}", Config::default().to_commented_toml());
            Ok(())
        }
        Command::Simulate {
            scenario,
            trajectory,
            frames,
            seed,
            matches,
            out_dir,
        } => simulate(
            &scenario,
            trajectory.as_deref(),
            frames,
            seed,
            matches,
            &out_dir,
        ),
        Command::ImportKitti {
            dir,
            out_dir,
            stereo,
            matches,
            seed,
        } => import_kitti(&dir, &out_dir, stereo, matches, seed),
        Command::Eval { gt, est, json } => eval(&gt, &est, json),
        Command::Plot { figure } => plot(figure),
        Command::Sweep(args) => momo_sweep::cli::main(args).map_err(|e| {
            if e.is_input() {
                Failure::Input(e.into())
            } else {
                Failure::Other(e.into())
            }
        }),
        Command::Match {
            images,
            rig,
            odometry,
            output,
            front,
            quiet,
        } => match_cmd(&images, &rig, odometry.as_deref(), &output, front, quiet),
        Command::Vo {
            images,
            rig,
            odometry,
            output,
            config,
            estimator,
            front,
            quiet,
        } => vo_cmd(
            momo_match::VoRun {
                folders: images,
                rig,
                odometry,
                output,
                estimator: estimator.into(),
            },
            config,
            front,
            quiet,
        ),
        Command::Demo {
            frames,
            seed,
            quiet,
        } => demo::demo(frames, seed, quiet)
            .context("demo failed")
            .map_err(Failure::Other),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(e)) => {
            eprintln!("momo: error: {e:#}");
            ExitCode::from(2)
        }
        Err(Failure::Other(e)) => {
            eprintln!("momo: error: {e:#}");
            ExitCode::from(1)
        }
    }
}
