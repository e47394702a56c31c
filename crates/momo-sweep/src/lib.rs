//! # momo-sweep
//!
//! Which model, metric, loss, scale and solver works best on which data, and how fast: a
//! *sweep* runs every combination of a [`Grid`] (read from TOML: lists of models, metrics,
//! losses, loss scales, solvers and matches per frame) on every sequence, and scores each run
//! against the sequence's ground truth with `momo-eval`.
//!
//! - [`Grid::combinations`] and [`Plan`] expand a grid deterministically into jobs
//!   (combination x sequence); job `i` is combination `i / S` on sequence `i % S`.
//! - [`Shard`] (`--shard I/N`) is a deterministic, disjoint slice of the jobs (round robin), so
//!   N copies of one command (a batch scheduler's job array) run a large sweep; [`merge`] joins
//!   their CSV files and checks that they come from the same grid and that no job is missing or
//!   duplicated.
//! - [`run_jobs`] runs jobs in parallel on a rayon pool; a combination that fails on a sequence
//!   (an error, or a panic, caught) becomes a row with the error text, the sweep goes on.
//! - [`write_outputs`] writes `results.csv` (one [`Row`] per job, columns [`COLUMNS`]) and
//!   `summary.md` (per sequence, ranked, the best combination named, the default configuration's
//!   rank), both atomically.
//!
//! ```
//! use momo_sweep::{Grid, Plan, RunOptions, Shard, Status, run_jobs};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let grid = Grid::from_toml_str(
//!     r#"
//!     models = ["soft_single_track", "single_track_2d"]
//!     metrics = ["angle_plane"]
//!     losses = ["cauchy", "trivial"]
//!     loss_scales = [0.001, 0.002]
//!     solvers = ["levenberg_marquardt"]
//!     matches = [60]
//!     "#,
//!     "grid.toml",
//! )?;
//! // 2 models x (cauchy at 2 scales + trivial without scale) = 6 combinations.
//! assert_eq!(grid.combinations().len(), 6);
//!
//! // A short simulated drive with ground truth.
//! let cfg = momo_sim::SimConfig { frames: 12, ..momo_sim::SimConfig::outliers() };
//! let seq = momo_sim::simulate(&cfg)?.sequence;
//! let plan = Plan::new(&grid, &["sim".to_string()])?;
//! assert!(plan.default_combination.is_some()); // soft_single_track / angle_plane / cauchy 0.001 / LM
//!
//! // The first of two shards, then the second: disjoint, and together every job.
//! let first: Shard = "1/2".parse()?;
//! let second: Shard = "2/2".parse()?;
//! let opts = |shard| RunOptions { shard: Some(shard), threads: Some(1), quiet: true };
//! let mut rows = run_jobs(&grid, &plan, &[seq.clone()], &plan.jobs_of(Some(first)), &opts(first))?;
//! rows.extend(run_jobs(&grid, &plan, &[seq], &plan.jobs_of(Some(second)), &opts(second))?);
//! assert_eq!(rows.len(), plan.jobs());
//! assert!(rows.iter().all(|r| r.status == Status::Ok && r.rot_median_deg.is_some()));
//! # Ok(())
//! # }
//! ```

pub mod cli;
mod error;
pub mod grid;
pub mod plan;
pub mod results;
pub mod run;
pub mod summary;

pub use error::SweepError;
pub use grid::{
    AxisEntry, Combination, Grid, LossScales, MAX_COMBINATIONS, MAX_GRID_BYTES, MatchCount,
};
pub use plan::{Job, Plan, Shard};
pub use results::{COLUMNS, RankBy, Row, Status, TIMING_COLUMNS, merge, read_csv, write_csv};
pub use run::{RunOptions, load_sequence, run_job, run_jobs, run_sweep, sequence_name, subsample};
pub use summary::{SummaryOptions, summary_markdown};

use momo_io::{AtomicFile, IoError};
use std::io::Write as _;
use std::path::Path;

/// The results table's file name in an output directory.
pub const RESULTS_CSV: &str = "results.csv";
/// The summary's file name in an output directory.
pub const SUMMARY_MD: &str = "summary.md";

/// Writes `dir/results.csv` and `dir/summary.md` (the directory is created), each atomically.
pub fn write_outputs(dir: &Path, rows: &[Row], options: &SummaryOptions) -> Result<(), SweepError> {
    std::fs::create_dir_all(dir).map_err(|e| SweepError::Output(IoError::io(dir, e)))?;
    write_csv(&dir.join(RESULTS_CSV), rows)?;
    let path = dir.join(SUMMARY_MD);
    let mut file = AtomicFile::create(&path).map_err(SweepError::Output)?;
    file.writer()
        .write_all(summary_markdown(rows, options).as_bytes())
        .map_err(|e| SweepError::Output(IoError::io(&path, e)))?;
    file.commit().map_err(SweepError::Output)
}
