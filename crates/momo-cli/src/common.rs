//! What every command shares: the failure classes and their exit codes, progress bars,
//! configuration loading.

use indicatif::{ProgressBar, ProgressStyle};
use momo_vo::Config;
use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

/// Input errors exit with 2, everything else with 1; a closed standard output with 141.
pub(crate) enum Failure {
    /// Bad input: a file, an option, a configuration.
    Input(anyhow::Error),
    /// Anything else: writing an output, an internal error.
    Other(anyhow::Error),
    /// The run finished and wrote its outputs, but more than `trust.max_failed_share` of its
    /// frame pairs failed or held their motion: exit code 3.
    Untrusted(anyhow::Error),
    /// Standard output is a closed pipe (the reader stopped reading, e.g. `| head`): the
    /// command ends quietly with [`EXIT_BROKEN_PIPE`].
    BrokenPipe,
}

/// Exit code when standard output is a closed pipe: 141 = 128 + SIGPIPE, what a shell reports
/// for a program that SIGPIPE ended (`yes | head -1` under `set -o pipefail`).
pub(crate) const EXIT_BROKEN_PIPE: u8 = 141;
/// Exit code after SIGINT (Ctrl-C): 128 + 2.
pub(crate) const EXIT_SIGINT: u8 = 130;
/// Exit code after SIGTERM: 128 + 15.
pub(crate) const EXIT_SIGTERM: u8 = 143;

/// Writes to standard output and flushes; a closed pipe is [`Failure::BrokenPipe`], any other
/// error (e.g. a full disk) a [`Failure::Other`] with a message. Used by [`out!`] and
/// [`outln!`] instead of `print!` / `println!`, which panic.
pub(crate) fn write_out(args: std::fmt::Arguments<'_>, newline: bool) -> Result<(), Failure> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_fmt(args)
        .and_then(|()| {
            if newline {
                out.write_all(b"\n")
            } else {
                Ok(())
            }
        })
        .and_then(|()| out.flush())
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                Failure::BrokenPipe
            } else {
                Failure::Other(anyhow::anyhow!("cannot write to standard output: {e}"))
            }
        })
}

/// Writes a note to standard error, best effort: notes (summaries, "wrote X") are not the
/// command's product, so an unwritable standard error does not fail the command (and never
/// panics, as `eprintln!` does).
pub(crate) fn write_note(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.write_all(b"\n"));
}

/// `print!` that returns `Err(Failure)` from the enclosing function when standard output
/// cannot be written.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::common::write_out(::std::format_args!($($arg)*), false)?
    };
}

/// `println!` that returns `Err(Failure)` from the enclosing function when standard output
/// cannot be written.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::common::write_out(::std::format_args!($($arg)*), true)?
    };
}

/// `eprintln!` that never panics (best effort, see [`write_note`]).
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::common::write_note(::std::format_args!($($arg)*))
    };
}

/// Installs (once per process) the SIGINT / SIGTERM handler: it removes every temporary output
/// file and every output directory created but not finished
/// ([`momo_io::remove_temporaries`]), then exits with 130 (SIGINT) or 143 (SIGTERM).
pub(crate) fn install_signal_cleanup() {
    static INSTALLED: std::sync::OnceLock<()> = std::sync::OnceLock::new();
    INSTALLED.get_or_init(|| {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) else {
            return;
        };
        let _ = std::thread::Builder::new()
            .name("momo-signals".into())
            .spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    momo_io::remove_temporaries();
                    let code = if sig == SIGINT {
                        EXIT_SIGINT
                    } else {
                        EXIT_SIGTERM
                    };
                    std::process::exit(i32::from(code));
                }
            });
    });
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
            note!(
                "momo: error: {}",
                crate::common::clean_message(&format!("{e:#}"))
            );
            ExitCode::from(2)
        }
        Err(Failure::Other(e)) => {
            note!(
                "momo: error: {}",
                crate::common::clean_message(&format!("{e:#}"))
            );
            ExitCode::from(1)
        }
        Err(Failure::BrokenPipe) => ExitCode::from(EXIT_BROKEN_PIPE),
        Err(Failure::Untrusted(e)) => {
            note!("momo: warning: {e:#}");
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

/// An error message made safe for a terminal: control characters (escape sequences, carriage
/// returns, ...) are shown escaped (`\u{1b}`), runs of more than 24 digits are cut (`1234…`),
/// and a message that repeats its last part (an OS error quoted twice by a chain of causes)
/// loses the repetition.
pub(crate) fn clean_message(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut digits = 0usize;
    for c in msg.chars() {
        if c.is_ascii_digit() {
            digits += 1;
            if digits == 25 {
                out.push('…');
            }
            if digits > 24 {
                continue;
            }
        } else {
            digits = 0;
        }
        if c.is_control() && c != '\n' && c != '\t' {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
    }
    // "X: E: E" (the same cause twice at the end of the chain) -> "X: E".
    if let Some((head, last)) = out.rsplit_once(": ")
        && !last.is_empty()
        && head.ends_with(&format!(": {last}"))
    {
        return head.to_string();
    }
    out
}

/// Refuses outputs that are inputs, duplicates, non-regular files or in missing directories
/// ([`momo_io::check_outputs`]): an input error, before anything is read or written.
pub(crate) fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<(), Failure> {
    momo_io::check_outputs(inputs, outputs).map_err(Failure::input)
}

/// The files of a sequence directory that `momo run` reads (and the ground truth beside them):
/// no output may replace them.
pub(crate) fn sequence_files(dir: &Path) -> Vec<std::path::PathBuf> {
    use momo_io::files;
    [files::RIG, files::MATCHES, files::ODOMETRY, files::POSES]
        .iter()
        .map(|f| dir.join(f))
        .collect()
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
