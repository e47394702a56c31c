//! Process-level test scaffolding shared by the integration tests that run the `momo` binary
//! (`use crate::common;`): spawn it, collect its output, assert its exit code and message.
// Not every part is used by every build of the tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The shared data folder: `$MOMO_DATA`, default `../shared/data` beside the repository (tests
/// that read it skip with a message where what they need is absent).
pub fn shared_data() -> PathBuf {
    std::env::var_os("MOMO_DATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"),
        PathBuf::from,
    )
}

/// The `momo` binary of this build.
pub fn momo() -> Command {
    Command::new(env!("CARGO_BIN_EXE_momo"))
}

/// `momo` under an address-space limit (`ulimit -v`, kB).
pub fn momo_limited(kb: usize) -> Command {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!("ulimit -v {kb} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_momo"));
    c
}

/// Runs `cmd` to its end and returns what it printed.
pub fn out(cmd: &mut Command) -> Output {
    cmd.output().expect("momo starts")
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts the exit code and that standard error contains every one of `messages`
/// (on failure, standard error is shown).
#[track_caller]
pub fn assert_exit(o: &Output, code: i32, messages: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "{err}");
    for m in messages {
        assert!(err.contains(m), "expected `{m}` in: {err}");
    }
}
