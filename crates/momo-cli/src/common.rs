//! What every command shares: the failure classes and their exit codes, progress bars,
//! configuration loading.

use indicatif::{ProgressBar, ProgressStyle};
use momo_vo::Config;
use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

/// Input errors exit with 2, everything else with 1.
pub(crate) enum Failure {
    /// Bad input: a file, an option, a configuration.
    Input(anyhow::Error),
    /// Anything else: writing an output, an internal error.
    Other(anyhow::Error),
    /// The run finished and wrote its outputs, but more than `trust.max_failed_share` of its
    /// frame pairs failed or held their motion: exit code 3.
    Untrusted(anyhow::Error),
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

impl Failure {
    /// An input failure from any error.
    pub(crate) fn input(e: impl Into<anyhow::Error>) -> Self {
        Failure::Input(e.into())
    }

    /// A non-input failure from any error.
    pub(crate) fn other(e: impl Into<anyhow::Error>) -> Self {
        Failure::Other(e.into())
    }
}

/// Reports a command's failure on stderr and maps it to the process's exit code.
pub(crate) fn exit_code(result: Result<(), Failure>) -> ExitCode {
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
        Err(Failure::Untrusted(e)) => {
            eprintln!("momo: warning: {e:#}");
            ExitCode::from(3)
        }
    }
}

/// A progress bar on stderr (hidden when `quiet` or when stderr is not a terminal): a bar with
/// total and ETA when the count is known, a spinner otherwise.
pub(crate) fn progress_bar(quiet: bool, len: Option<u64>) -> ProgressBar {
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
pub(crate) fn load_config(config: Option<&Path>) -> Result<Config, Failure> {
    match config {
        Some(p) => Config::from_file(p).map_err(Failure::input),
        None => Ok(Config::default()),
    }
}

/// The `--estimator` choices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum EstimatorArg {
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

/// The mount calibration's model from its type tag (`--model`, `--mount-model`): any
/// registered model that can see the mount.
pub(crate) fn mount_model(type_tag: &str) -> Result<momo_vo::MountModel, Failure> {
    momo_vo::MountModel::named(type_tag).map_err(Failure::input)
}
