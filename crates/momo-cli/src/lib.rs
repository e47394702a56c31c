//! The `momo` command line as a library.
//!
//! The `momo` binary is `fn main() -> ExitCode { momo_cli::main() }`. A researcher's binary is
//! the same few lines: it links the crate that registers their motion model or residual metric
//! (`register_model!` / `register_metric!`, by type name) and hands over to [`main`] or
//! [`main_from`], and every command (`run`, `sweep`, `calibrate`, `eval`, `plot`, ...) then
//! accepts their types by name in configurations and grids.
//!
//! Exit codes: 0 the command did what was asked; 1 a failure that is not the input's (writing
//! an output, an internal error); 2 bad input (a file, an option, a configuration, an output
//! that is also an input or cannot be written safely); 3 a run that wrote its outputs but in
//! which more than `trust.max_failed_share` of the frame pairs failed or held their motion;
//! 130 / 143 interrupted by SIGINT /
//! SIGTERM (temporary files and output directories created so far are removed first); 141
//! standard output is a closed pipe (`momo demo | head`), nothing printed.

use clap::{Parser, Subcommand};
use std::ffi::OsString;
use std::process::ExitCode;

#[macro_use]
mod common;
mod calibrate;
mod demo;
mod eval;
mod images;
mod import;
mod plot;
mod rig;
mod run;
mod simulate;
mod trajfmt;

use common::Failure;

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
    /// Estimate the trajectory of a sequence directory (docs/FORMAT.md: rig.json, matches.csv,
    /// optional odometry.csv) and write camera 0's poses in the KITTI format.
    Run(run::RunArgs),
    /// Estimate the rig's mount rotation relative to the vehicle jointly over the frame pairs
    /// of a sequence (robust Levenberg-Marquardt on a single-track model, Schur complement over
    /// the shared mount) and write the corrected rig.json.
    #[command(after_help = "Example:\n  momo calibrate seq -o seq/rig_calibrated.json")]
    Calibrate(calibrate::CalibrateArgs),
    /// Print the default configuration as a commented TOML file.
    #[command(
        after_help = "Example:\n  momo config > my.toml   (keep only the sections you change: the others take their defaults)"
    )]
    Config {
        /// Accepted for symmetry (config prints only the file).
        #[arg(short, long)]
        quiet: bool,
    },
    /// Write a simulated sequence (docs/FORMAT.md, with poses.txt ground truth) to a directory.
    #[command(after_help = "Example:\n  momo simulate --scenario outliers --frames 200 sim")]
    Simulate(simulate::SimulateArgs),
    /// Import the real KITTI 00 stereo matches of the `l1avgvo` demo (calib.txt, poses*.txt,
    /// a folder of `i_to_{i+1}.txt` files) as a sequence directory (docs/FORMAT.md, with
    /// poses.txt ground truth and odometry.csv arc lengths from it).
    ImportKitti(import::ImportKittiArgs),
    /// Score estimated trajectories against ground truth (KITTI pose files, camera 0): KITTI
    /// devkit t_err / r_err and the frame-to-frame rotation errors.
    Eval(eval::EvalArgs),
    /// Draw figures as PNG or SVG (chosen by the output file's extension): trajectories,
    /// frame-to-frame rotation errors, the cost landscape of a frame.
    #[command(
        after_help = "Example:\n  momo plot trajectory --gt sim/poses.txt --est est.txt -o trajectory.png"
    )]
    Plot {
        #[command(subcommand)]
        figure: plot::PlotCommand,
    },
    /// Run every combination of a grid (models x metrics x losses x scales x solvers x matches)
    /// on every sequence in parallel, score each against the ground truth and write
    /// results.csv and summary.md; `--shard I/N` runs one slice, `momo sweep merge` joins them.
    #[command(
        after_help = "Example:\n  momo sweep --grid grid.toml --sequences sim --output sweep_out"
    )]
    Sweep(momo_sweep::cli::SweepArgs),
    /// Detect and match features in image sequences (PNG/JPEG, one folder per camera in the
    /// rig's order, files in name order) and write a sequence directory: matches.csv
    /// (docs/FORMAT.md), a copy of the rig file as rig.json, and with --odometry a copy of it
    /// as odometry.csv, so that `momo run SEQ_DIR` follows.
    #[command(
        after_help = "Example:\n  momo match image_0 --rig rig.json --odometry odometry.csv -o seq && momo run seq -o est.txt"
    )]
    Match(images::MatchArgs),
    /// Visual odometry from images in one streaming pass: match consecutive frames and
    /// estimate the motion frame by frame; writes camera 0's trajectory (KITTI format, one line
    /// per image frame).
    Vo(images::VoArgs),
    /// Simulate a drive (no data needed), run the estimator on it and print how close the
    /// result is to the truth.
    #[command(after_help = "Example:\n  momo demo --frames 200")]
    Demo(demo::DemoArgs),
    /// Rig files: `momo rig import` writes rig.json from an OpenCV, ROS or Kalibr calibration.
    Rig {
        #[command(subcommand)]
        command: rig::RigCommand,
    },
}

/// Runs the `momo` command line on the process's arguments and returns its exit code.
pub fn main() -> ExitCode {
    main_from(std::env::args_os())
}

/// Runs the `momo` command line on `args` (the first item is the program name, as in
/// `std::env::args_os()`) and returns its exit code: 0 success, 1 a failure that is not the
/// input's, 2 bad input or usage.
pub fn main_from<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to stdout with exit 0, usage errors to stderr with exit 2.
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
        }
    };
    common::install_signal_cleanup();
    let result = match cli.command {
        Command::Run(args) => run::run(args),
        Command::Calibrate(args) => calibrate::calibrate(args),
        Command::Config { .. } => (|| {
            out!("{}", momo_vo::Config::default().to_commented_toml());
            Ok(())
        })(),
        Command::Simulate(args) => simulate::simulate(args),
        Command::ImportKitti(args) => import::import_kitti(args),
        Command::Eval(args) => eval::eval(args),
        Command::Plot { figure } => plot::plot(figure),
        Command::Sweep(args) => momo_sweep::cli::main(args).map_err(|e| {
            if e.is_input() {
                Failure::Input(e.into())
            } else {
                Failure::Other(e.into())
            }
        }),
        Command::Match(args) => images::match_cmd(args),
        Command::Vo(args) => images::vo_cmd(args),
        Command::Demo(args) => demo::demo(args),
        Command::Rig { command } => rig::rig(command),
    };
    common::exit_code(result)
}
