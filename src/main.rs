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
        Command::ImportKitti {
            dir,
            out_dir,
            stereo,
            matches,
            seed,
        } => import_kitti(&dir, &out_dir, stereo, matches, seed),
        Command::Eval { gt, est, json } => eval(&gt, &est, json),
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
