//! `momo plot`.

use crate::common::{Failure, load_config};
use std::path::{Path, PathBuf};

/// The figures of `momo plot`.
#[derive(clap::Subcommand, Debug)]
pub(crate) enum PlotCommand {
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
        /// Frame rate in Hz (speed = displacement per frame × frame rate), in (0, 10000].
        #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
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

/// Maps a plotting error: bad data or options are input errors, drawing and writing are not.
fn plot_failure(e: momo_plot::PlotError) -> Failure {
    use momo_plot::PlotError;
    match e {
        PlotError::Format(_) | PlotError::Input(_) | PlotError::Vo(_) | PlotError::Core(_) => {
            Failure::input(e)
        }
        PlotError::Draw(_) | PlotError::Io(_) => Failure::other(e),
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
    let ground_truth = momo_io::read_poses(gt).map_err(Failure::input)?;
    let mut estimates = Vec::with_capacity(est.len());
    for path in est {
        let poses = momo_io::read_poses(path).map_err(Failure::input)?;
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

pub(crate) fn plot(figure: PlotCommand) -> Result<(), Failure> {
    // The format is checked before any input is read.
    let output = match &figure {
        PlotCommand::Trajectory { output, .. }
        | PlotCommand::Errors { output, .. }
        | PlotCommand::Landscape { output, .. } => output.clone(),
    };
    momo_plot::Format::from_path(&output).map_err(plot_failure)?;
    let mut inputs: Vec<PathBuf> = match &figure {
        PlotCommand::Trajectory { gt, est, .. } | PlotCommand::Errors { gt, est, .. } => {
            std::iter::once(gt.clone())
                .chain(est.iter().cloned())
                .collect()
        }
        PlotCommand::Landscape { seq, config, .. } => {
            let mut v = crate::common::sequence_files(seq);
            v.extend(config.clone());
            v
        }
    };
    inputs.dedup();
    let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
    crate::common::check_outputs(&inputs, &[output.as_path()])?;
    if let PlotCommand::Errors { frame_rate, .. } = &figure
        && !(frame_rate.is_finite() && *frame_rate > 0.0 && *frame_rate <= 10_000.0)
    {
        return Err(Failure::Input(anyhow::anyhow!(
            "--frame-rate must be a positive number of Hz up to 10000, found {frame_rate}"
        )));
    }
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
            let config = load_config(config.as_deref())?;
            let sequence = momo_io::read_sparse_sequence(&seq).map_err(Failure::input)?;
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
                note!(
                    "momo: frame {frame}: estimate yaw {ey:.4} deg, arc length {ea:.4} m; grid minimum yaw {yaw:.4} deg, arc length {arc:.4} m, cost {cost:.6e}"
                );
            }
        }
    }
    if !momo_plot::font_available() {
        note!(
            "momo: warning: no TrueType font found (set MOMO_PLOT_FONT to a .ttf file): drew without text"
        );
    }
    note!("momo: wrote {}", output.display());
    Ok(())
}
