//! The `momo` command-line tool: the command line of `momo-cli` (a library, so that a
//! researcher's binary can register its own models and metrics and hand over to it).

fn main() -> std::process::ExitCode {
    momo_cli::main()
}
