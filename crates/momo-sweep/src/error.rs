//! The errors of a sweep.

use momo_io::IoError;
use thiserror::Error;

/// Why a sweep or a merge failed. A combination that fails on a sequence is *not* an error of
/// the sweep: it becomes a result row with its error text ([`crate::Row::error`]).
#[derive(Debug, Error)]
pub enum SweepError {
    /// A file could not be read.
    #[error("{path}: {error}")]
    Read {
        /// The file.
        path: String,
        /// The cause (not a `source`: the message already quotes it once).
        error: std::io::Error,
    },
    /// The grid file is malformed or names something unknown.
    #[error("{path}:{line}: {reason}")]
    Grid {
        /// The grid file (or the name given to [`crate::Grid::from_toml_str`]).
        path: String,
        /// 1-based line of the problem (1 if unknown).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A sequence directory could not be read (`file:line: reason`).
    #[error(transparent)]
    Sequence(IoError),
    /// The sequences or options do not fit the sweep (no ground truth, duplicate names, a bad
    /// `--shard`).
    #[error("{0}")]
    Input(String),
    /// A results CSV (a shard's output given to merge) is malformed.
    #[error("{path}:{line}: {reason}")]
    Results {
        /// The CSV file.
        path: String,
        /// 1-based line of the problem.
        line: u64,
        /// What is wrong.
        reason: String,
    },
    /// The shards given to merge do not make up one sweep (different grids, missing or
    /// duplicate jobs).
    #[error("merge: {0}")]
    Merge(String),
    /// An output file could not be written.
    #[error(transparent)]
    Output(IoError),
    /// The worker threads could not be started.
    #[error("cannot start the worker threads: {0}")]
    Threads(String),
}

impl SweepError {
    /// Whether the error is the user's input (exit code 2 in the CLI) rather than the machine's.
    pub fn is_input(&self) -> bool {
        !matches!(self, SweepError::Output(_) | SweepError::Threads(_))
    }
}
