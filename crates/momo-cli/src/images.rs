//! `momo match` and `momo vo`: the image front end.

use crate::common::{EstimatorArg, Failure, load_config, progress_bar};
use std::path::PathBuf;

/// Options of the feature front end (`momo match`, `momo vo`).
#[derive(clap::Args, Debug, Clone, Copy)]
pub(crate) struct FrontEndArgs {
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
        Failure::input(e)
    } else {
        Failure::other(e)
    }
}

/// The arguments of `momo match`.
#[derive(clap::Args, Debug)]
pub(crate) struct MatchArgs {
    /// Image folders, one per camera of the rig.
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// The rig (rig.json of docs/FORMAT.md); image sizes must match its cameras.
    #[arg(long)]
    rig: PathBuf,
    /// odometry.csv (arc lengths) to copy into the sequence directory.
    #[arg(long)]
    odometry: Option<PathBuf>,
    /// Output sequence directory (created; an existing one must be empty unless --force;
    /// removed again on failure if this created it).
    #[arg(short, long)]
    output: PathBuf,
    /// Write into an existing, non-empty output directory (its files of the same names are
    /// replaced).
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    front: FrontEndArgs,
    /// No progress bar and no summary on stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// The arguments of `momo vo`.
#[derive(clap::Args, Debug)]
pub(crate) struct VoArgs {
    /// Image folders, one per camera of the rig.
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// The rig (rig.json of docs/FORMAT.md); image sizes must match its cameras.
    #[arg(long)]
    rig: PathBuf,
    /// Arc lengths per frame pair (odometry.csv of docs/FORMAT.md): fixes the scale.
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
}

/// `momo match`.
pub(crate) fn match_cmd(args: MatchArgs) -> Result<(), Failure> {
    let (output, quiet) = (&args.output, args.quiet);
    let mut inputs = vec![args.rig.clone()];
    inputs.extend(args.odometry.clone());
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    let written = crate::common::sequence_files(output);
    let written: Vec<&std::path::Path> = written.iter().map(PathBuf::as_path).collect();
    if std::fs::metadata(output).is_ok() {
        crate::common::check_outputs(&inputs, &written)?;
    }
    let dir = momo_io::OutputDir::prepare(output, args.force).map_err(Failure::input)?;
    let bar = progress_bar(quiet, None);
    let started = std::time::Instant::now();
    let stats = momo_match::match_to_sequence(
        &args.images,
        &args.rig,
        output,
        args.odometry.as_deref(),
        &args.front.into(),
        |_| bar.inc(1),
    )
    .map_err(match_failure)?;
    dir.keep();
    bar.finish_and_clear();
    if !quiet {
        note!(
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
pub(crate) fn vo_cmd(args: VoArgs) -> Result<(), Failure> {
    let quiet = args.quiet;
    let mut inputs = vec![args.rig.clone()];
    inputs.extend(args.odometry.clone());
    inputs.extend(args.config.clone());
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    crate::common::check_outputs(&inputs, &[args.output.as_path()])?;
    let config = load_config(args.config.as_deref())?;
    let run = momo_match::VoRun {
        folders: args.images,
        rig: args.rig,
        odometry: args.odometry,
        output: args.output,
        estimator: args.estimator.into(),
    };
    let frames = momo_match::ImageSequence::open(&run.folders)
        .map_err(match_failure)?
        .len();
    let bar = progress_bar(quiet, Some(frames.saturating_sub(1) as u64));
    let started = std::time::Instant::now();
    let summary = momo_match::vo_from_images(&run, config, &args.front.into(), |_| bar.inc(1))
        .map_err(match_failure)?;
    bar.finish_and_clear();
    if !quiet {
        let f = summary.front_end;
        note!(
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
