//! The `momo` command-line tool: a thin shell over the momo library crates.

use anyhow::Context;
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use momo_vo::{Config, RunError, RunOptions};
use std::io::IsTerminal;
use std::path::PathBuf;
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
    },
    /// Print the default configuration as a commented TOML file.
    Config,
    /// Write a simulated sequence (FORMAT.md, with poses.txt ground truth) to a directory.
    Simulate {
        /// Scenario: clean_pinhole, outliers (30 %, 1 px), moving_object, fisheye_surround.
        #[arg(long, default_value = "clean_pinhole")]
        scenario: String,
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

fn run(
    seq: PathBuf,
    output: PathBuf,
    config: Option<PathBuf>,
    diagnostics: Option<PathBuf>,
    quiet: bool,
) -> Result<(), Failure> {
    let config = match &config {
        Some(p) => Config::from_file(p).map_err(|e| Failure::Input(e.into()))?,
        None => Config::default(),
    };
    let bar = progress_bar(quiet, None);
    let options = RunOptions {
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
    frames: usize,
    seed: u64,
    matches: Option<usize>,
    out_dir: &std::path::Path,
) -> Result<(), Failure> {
    use momo_sim::SimConfig;
    let mut cfg = match scenario {
        "clean_pinhole" => SimConfig::clean_pinhole(),
        "outliers" => SimConfig::outliers(),
        "moving_object" => SimConfig::moving_object(),
        "fisheye_surround" => SimConfig::fisheye_surround(),
        other => {
            return Err(Failure::Input(anyhow::anyhow!(
                "unknown scenario `{other}` (clean_pinhole, outliers, moving_object, fisheye_surround)"
            )));
        }
    };
    cfg.frames = frames;
    cfg.seed = seed;
    if let Some(m) = matches {
        cfg.matches_per_camera = m;
    }
    let sim = momo_sim::simulate(&cfg).map_err(|e| Failure::Input(e.into()))?;
    sim.write(out_dir).map_err(|e| Failure::Other(e.into()))?;
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
        } => run(seq, output, config, diagnostics, quiet),
        Command::Config => {
            print!("{}", Config::default().to_commented_toml());
            Ok(())
        }
        Command::Simulate {
            scenario,
            frames,
            seed,
            matches,
            out_dir,
        } => simulate(&scenario, frames, seed, matches, &out_dir),
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
