//! The `momo sweep` command line (clap), kept here so that the binary needs one variant and one
//! call: `Command::Sweep(args) => momo_sweep::cli::main(args)`.

use crate::error::SweepError;
use crate::grid::Grid;
use crate::plan::Shard;
use crate::results::{RankBy, merge};
use crate::run::{RunOptions, run_sweep};
use crate::summary::SummaryOptions;
use crate::write_outputs;
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// `momo sweep --grid GRID.toml --sequences DIR... --output OUT_DIR [--shard I/N] [--jobs N]`,
/// or `momo sweep merge SHARD.csv... --output OUT_DIR`.
#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    /// `merge`: join the results of several shards.
    #[command(subcommand)]
    pub command: Option<SweepCommand>,
    /// The grid (TOML): lists of models, metrics, losses, loss_scales, solvers, matches;
    /// see examples/grids/.
    #[arg(long, required = true)]
    pub grid: Option<PathBuf>,
    /// Sequence directories (FORMAT.md, with poses.txt ground truth); results are keyed by
    /// directory name.
    #[arg(long, required = true, num_args = 1..)]
    pub sequences: Vec<PathBuf>,
    /// Output directory (created): results.csv (one row per job) and summary.md, both written
    /// atomically.
    #[arg(short, long, required = true)]
    pub output: Option<PathBuf>,
    /// Run only the I-th of N disjoint slices of the jobs (1-based, e.g. 3/8); join the slices
    /// with `momo sweep merge`.
    #[arg(long)]
    pub shard: Option<String>,
    /// Worker threads (default: one per core).
    #[arg(short, long)]
    pub jobs: Option<usize>,
    /// The summary's ranking criterion.
    #[arg(long, value_enum, default_value_t = RankBy::RotMean)]
    pub rank_by: RankBy,
    /// Show at most this many combinations per sequence in summary.md (all are in the CSV).
    #[arg(long)]
    pub top: Option<usize>,
    /// No progress bar and no summary line on stderr.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Subcommands of `momo sweep`.
#[derive(Subcommand, Debug)]
pub enum SweepCommand {
    /// Join the results.csv files of the shards of one sweep into one results.csv and
    /// summary.md; fails if they come from different grids or a job is missing or duplicated.
    Merge {
        /// The shards' results.csv files.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Output directory (created).
        #[arg(short, long)]
        output: PathBuf,
        /// The summary's ranking criterion.
        #[arg(long, value_enum, default_value_t = RankBy::RotMean)]
        rank_by: RankBy,
        /// Show at most this many combinations per sequence in summary.md.
        #[arg(long)]
        top: Option<usize>,
        /// No summary line on stderr.
        #[arg(short, long)]
        quiet: bool,
    },
}

/// Runs `momo sweep` or `momo sweep merge`.
pub fn main(args: SweepArgs) -> Result<(), SweepError> {
    if let Some(SweepCommand::Merge {
        shards,
        output,
        rank_by,
        top,
        quiet,
    }) = args.command
    {
        let rows = merge(&shards)?;
        write_outputs(&output, &rows, &SummaryOptions { rank_by, top })?;
        if !quiet {
            eprintln!(
                "momo: merged {} jobs from {} file(s); wrote {}",
                rows.len(),
                shards.len(),
                output.display()
            );
        }
        return Ok(());
    }
    let missing = |what: &str| SweepError::Input(format!("momo sweep: {what} is required"));
    let grid_path = args.grid.ok_or_else(|| missing("--grid"))?;
    let output = args.output.ok_or_else(|| missing("--output"))?;
    if args.jobs == Some(0) {
        return Err(SweepError::Input("--jobs must be at least 1".into()));
    }
    let shard = args.shard.as_deref().map(str::parse::<Shard>).transpose()?;
    let grid = Grid::from_file(&grid_path)?;
    let options = RunOptions {
        shard,
        threads: args.jobs,
        quiet: args.quiet,
    };
    let started = std::time::Instant::now();
    let (plan, rows) = run_sweep(&grid, &args.sequences, &options)?;
    write_outputs(
        &output,
        &rows,
        &SummaryOptions {
            rank_by: args.rank_by,
            top: args.top,
        },
    )?;
    if !args.quiet {
        let failed = rows
            .iter()
            .filter(|r| r.status != crate::Status::Ok)
            .count();
        eprintln!(
            "momo: {} of {} jobs ({} combinations x {} sequences){} in {:.1} s, {failed} failed; wrote {}",
            rows.len(),
            plan.jobs(),
            plan.combinations.len(),
            plan.sequences.len(),
            shard.map_or(String::new(), |s| format!(", shard {s}")),
            started.elapsed().as_secs_f64(),
            output.display()
        );
    }
    Ok(())
}
