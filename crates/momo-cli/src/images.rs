//! `momo match` and `momo vo`: the image front end.

use crate::common::{EstimatorArg, Failure, load_config, progress_bar};
use crate::trajfmt::OutputFormat;
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
    /// Threads of the front end (cameras, image rows, matches); 0: all cores. The matches do
    /// not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// No KLT refinement of the matches (the detector's sub-pixel vertices instead, as before
    /// 2026-11-24).
    #[arg(long)]
    no_klt: bool,
    /// Search the whole --max-flow window for every match (no prediction from the last frame
    /// pair's flow; slower).
    #[arg(long)]
    no_flow_prior: bool,
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
                threads: a.threads,
                klt: if a.no_klt { None } else { d.klt },
                prior_margin: if a.no_flow_prior {
                    None
                } else {
                    d.prior_margin
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
#[command(after_help = "Examples:\n  \
    momo vo seq06 -o est.txt            (a directory made by `momo import-kitti`)\n  \
    momo vo seq06 -o est.txt -d diag.csv  (with each frame's status and covariance)\n  \
    momo vo image_0 image_1 --rig rig.json --odometry odometry.csv -o est.txt")]
pub(crate) struct VoArgs {
    /// Image folders, one per camera of the rig; or one sequence directory made by `momo
    /// import-kitti` (rig.json, image_0/, ..., optional odometry.csv and times.txt).
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// The rig (rig.json of docs/FORMAT.md); image sizes must match its cameras. Default:
    /// DIR/rig.json of a sequence directory.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// Arc lengths per frame pair (odometry.csv of docs/FORMAT.md): fixes the scale. Default:
    /// DIR/odometry.csv of a sequence directory, if present.
    #[arg(long)]
    odometry: Option<PathBuf>,
    /// Output trajectory, written atomically.
    #[arg(short, long)]
    output: PathBuf,
    /// Write per-frame diagnostics (status and reason, covariance, parameters, inliers, cost,
    /// time, scale source), as `momo run --diagnostics`: CSV if the name ends in .csv, JSON
    /// lines otherwise. Written with the trajectory: both or neither.
    #[arg(short, long)]
    diagnostics: Option<PathBuf>,
    /// Output format: kitti, or tum (timestamps from --times).
    #[arg(long, value_enum, default_value = "kitti")]
    format: OutputFormat,
    /// Timestamps, one per image (KITTI times.txt). Default: DIR/times.txt of a sequence
    /// directory.
    #[arg(long)]
    times: Option<PathBuf>,
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
    let (folders, rig, odometry, times) = vo_inputs(&args)?;
    let mut inputs = vec![rig.clone()];
    inputs.extend(odometry.clone());
    inputs.extend(args.config.clone());
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    let mut outputs = vec![args.output.as_path()];
    outputs.extend(args.diagnostics.as_deref());
    crate::common::check_outputs(&inputs, &outputs)?;
    let config = load_config(args.config.as_deref())?;
    let run = momo_match::VoRun {
        folders,
        rig,
        odometry,
        output: args.output,
        diagnostics: args.diagnostics,
        estimator: args.estimator.into(),
    };
    let frames = momo_match::ImageSequence::open(&run.folders)
        .map_err(match_failure)?
        .len();
    let times = match &times {
        Some(t) => crate::trajfmt::check_times(args.format, t, Some(frames))?,
        None if args.format == OutputFormat::Tum => {
            return Err(Failure::Input(anyhow::anyhow!(
                "--format tum needs timestamps: --times FILE (KITTI's times.txt)"
            )));
        }
        None => None,
    };
    let bar = progress_bar(quiet, Some(frames.saturating_sub(1) as u64));
    let started = std::time::Instant::now();
    let max_failed_share = config.trust.max_failed_share;
    let summary = momo_match::vo_from_images(&run, config, &args.front.into(), |_| bar.inc(1))
        .map_err(match_failure)?;
    bar.finish_and_clear();
    crate::trajfmt::finish(args.format, &run.output, times.as_deref())?;
    if !quiet {
        let f = summary.front_end;
        note!(
            "momo: front end: {:.1} ms/frame matching, {:.1} ms/frame decoding, {} matches",
            f.match_ms_per_frame(),
            f.decode_ms_per_frame(),
            f.matches
        );
        crate::run::print_summary(&summary.run, started.elapsed(), &run.output);
    }
    crate::run::untrusted(&summary.run, max_failed_share)
}

/// The image folders, rig, odometry and timestamps of `momo vo`: as given, or from one sequence
/// directory (rig.json, image_0/, ..., odometry.csv and times.txt when present).
#[allow(clippy::type_complexity)]
fn vo_inputs(
    args: &VoArgs,
) -> Result<(Vec<PathBuf>, PathBuf, Option<PathBuf>, Option<PathBuf>), Failure> {
    if let ([dir], None) = (args.images.as_slice(), &args.rig) {
        let rig_path = dir.join(momo_io::files::RIG);
        if !rig_path.is_file() {
            return Err(Failure::Input(anyhow::anyhow!(
                "{}: no rig.json; give --rig RIG with image folders, or a directory made by `momo import-kitti`",
                dir.display()
            )));
        }
        let rig = momo_io::read_rig(&rig_path).map_err(Failure::input)?;
        let folders = momo_match::kitti::sequence_image_folders(dir, rig.len());
        let optional = |name: &str| Some(dir.join(name)).filter(|p| p.is_file());
        let odometry = args
            .odometry
            .clone()
            .or_else(|| optional(momo_io::files::ODOMETRY));
        let times = args
            .times
            .clone()
            .or_else(|| optional(momo_io::files::TIMES));
        return Ok((folders, rig_path, odometry, times));
    }
    let Some(rig) = args.rig.clone() else {
        return Err(Failure::Input(anyhow::anyhow!(
            "--rig RIG is needed with image folders (or give one directory made by `momo import-kitti`)"
        )));
    };
    Ok((
        args.images.clone(),
        rig,
        args.odometry.clone(),
        args.times.clone(),
    ))
}
