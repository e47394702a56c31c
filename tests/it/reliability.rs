//! Reliability of the `momo` process (issue 16): no input is ever overwritten, no output is
//! left half-written or behind on any error or signal, unwritable standard streams end cleanly,
//! and oversized inputs are refused early. Every test runs the built binary.

use crate::common;

use common::{assert_exit, momo, momo_limited, out, stderr};
use momo::sim::{SimConfig, simulate};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// A small simulated sequence (10 frames) with odometry and ground truth.
fn sequence(dir: &Path) {
    let mut cfg = SimConfig::clean_pinhole();
    cfg.frames = 10;
    cfg.matches_per_camera = 60;
    simulate(&cfg)
        .expect("simulates")
        .write(dir)
        .expect("writes");
}

/// Every file in a directory (name and content), to prove nothing changed.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| {
            let p = e.expect("entry").path();
            let data = std::fs::read(&p).unwrap_or_default();
            (p, data)
        })
        .collect();
    v.sort();
    v
}

fn assert_refused(o: &Output, what: &str) {
    assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(o));
    assert!(
        stderr(o).contains("refused as an output"),
        "{what}: {}",
        stderr(o)
    );
}

#[test]
fn outputs_that_are_inputs_are_refused_and_nothing_is_touched() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    std::fs::create_dir(tmp.path().join("links")).expect("mkdir");
    std::os::unix::fs::symlink(seq.join("matches.csv"), tmp.path().join("links/sym.csv"))
        .expect("symlink");
    std::fs::hard_link(seq.join("rig.json"), tmp.path().join("links/hard.json")).expect("link");
    let before = snapshot(&seq);
    let spellings = [
        seq.join("matches.csv"),
        seq.join("rig.json"),
        seq.join("odometry.csv"),
        seq.join("poses.txt"),
        seq.join(".").join("matches.csv"),
        tmp.path().join("seq/../seq/odometry.csv"),
        tmp.path().join("links/sym.csv"),
        tmp.path().join("links/hard.json"),
    ];
    for target in &spellings {
        let o = out(momo().arg("run").arg(&seq).arg("-o").arg(target).arg("-q"));
        assert_refused(&o, &target.display().to_string());
        let o = out(momo()
            .arg("run")
            .arg(&seq)
            .arg("-o")
            .arg(tmp.path().join("p.txt"))
            .arg("-d")
            .arg(target)
            .arg("-q"));
        assert_refused(&o, &target.display().to_string());
        // calibrate writes a rig: the same protection.
        let o = out(momo()
            .arg("calibrate")
            .arg(&seq)
            .arg("-o")
            .arg(target)
            .arg("-q"));
        assert_refused(&o, &target.display().to_string());
    }
    // The configuration is an input too.
    let cfg = tmp.path().join("c.toml");
    std::fs::write(&cfg, "").expect("write");
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-c")
        .arg(&cfg)
        .arg("-o")
        .arg(&cfg));
    assert_refused(&o, "config");
    assert_eq!(std::fs::read(&cfg).expect("read"), b"");
    assert_eq!(snapshot(&seq), before, "the sequence is untouched");
    assert!(!tmp.path().join("p.txt").exists(), "no output was written");
}

#[test]
fn an_output_given_twice_is_refused() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let a = tmp.path().join("same.txt");
    let b = tmp.path().join("seq/../same.txt");
    for (o1, o2) in [(&a, &a), (&a, &b)] {
        let o = out(momo()
            .arg("run")
            .arg(&seq)
            .arg("-o")
            .arg(o1)
            .arg("-d")
            .arg(o2)
            .arg("-q"));
        assert_refused(&o, "twice");
        assert!(stderr(&o).contains("given twice"), "{}", stderr(&o));
        assert!(!a.exists());
    }
    // Also when the file exists already: it keeps its content.
    std::fs::write(&a, "keep").expect("write");
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-o")
        .arg(&a)
        .arg("-d")
        .arg(&b)
        .arg("-q"));
    assert_refused(&o, "twice, existing");
    assert_eq!(std::fs::read_to_string(&a).expect("read"), "keep");
}

#[test]
fn fifo_device_and_directory_outputs_are_refused() {
    use std::os::unix::fs::FileTypeExt;
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let fifo = tmp.path().join("fifo");
    let made = Command::new("mkfifo").arg(&fifo).status();
    let dir = tmp.path().join("adir");
    std::fs::create_dir(&dir).expect("mkdir");
    let mut targets = vec![dir.clone(), PathBuf::from("/dev/null")];
    if made.is_ok_and(|s| s.success()) {
        targets.push(fifo.clone());
    } else {
        eprintln!("mkfifo not available: FIFO case skipped");
    }
    for t in &targets {
        let o = out(momo().arg("run").arg(&seq).arg("-o").arg(t).arg("-q"));
        assert_refused(&o, &t.display().to_string());
        // As diagnostics: the poses must not be left behind either (was: exit 1, p.txt left).
        let p = tmp.path().join("p.txt");
        let o = out(momo()
            .arg("run")
            .arg(&seq)
            .arg("-o")
            .arg(&p)
            .arg("-d")
            .arg(t)
            .arg("-q"));
        assert_refused(&o, &t.display().to_string());
        assert!(!p.exists(), "p.txt left behind with -d {}", t.display());
    }
    if fifo.exists() {
        let meta = std::fs::symlink_metadata(&fifo).expect("fifo");
        assert!(meta.file_type().is_fifo(), "the FIFO is still a FIFO");
    }
    assert!(
        std::fs::symlink_metadata("/dev/null")
            .expect("dev null")
            .file_type()
            .is_char_device()
    );
    assert!(dir.is_dir());
}

#[test]
fn a_missing_output_directory_is_an_input_error() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-o")
        .arg(tmp.path().join("no/such/dir/p.txt"))
        .arg("-q"));
    assert_refused(&o, "missing dir");
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
}

#[test]
fn a_254_character_output_name_works() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let name = format!("{}.txt", "p".repeat(250));
    assert_eq!(name.len(), 254);
    let target = tmp.path().join(&name);
    let o = out(momo().arg("run").arg(&seq).arg("-o").arg(&target).arg("-q"));
    assert_exit(&o, 0, &[]);
    assert_eq!(
        momo::io::read_poses(&target).expect("poses").len(),
        10,
        "one pose per frame"
    );
}

/// No temporary file (`.NAME.XXXXXX.tmp`) in a directory.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .expect("dir")
        .filter_map(|e| {
            let n = e.ok()?.file_name().to_string_lossy().into_owned();
            (n.ends_with(".tmp") || n.ends_with(".bak")).then_some(n)
        })
        .collect()
}

/// How many temporary outputs process `pid` holds open in `dir`: named ones (`.NAME.*.tmp`)
/// and, on Linux, anonymous ones (`O_TMPFILE`, which `/proc/PID/fd` shows as
/// `DIR/#INODE (deleted)`).
fn open_temporaries(pid: u32, dir: &Path) -> usize {
    let named = temporaries(dir).len();
    let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) else {
        return named;
    };
    let dir = std::fs::canonicalize(dir).expect("canonical");
    let anonymous = fds
        .filter_map(|e| std::fs::read_link(e.ok()?.path()).ok())
        .filter(|target| {
            target.parent() == Some(dir.as_path())
                && target.to_string_lossy().ends_with(" (deleted)")
        })
        .count();
    named + anonymous
}

/// `momo run` on a sequence whose matches.csv is a FIFO that this test holds open: the run
/// has created its temporary outputs and waits for more rows when the signal arrives.
/// `expected`: the exit code, or (negative) the signal that killed the process.
fn signal_during_run(signal: &str, expected: i32) {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let matches = std::fs::read_to_string(seq.join("matches.csv")).expect("read");
    std::fs::remove_file(seq.join("matches.csv")).expect("rm");
    let ok = Command::new("mkfifo")
        .arg(seq.join("matches.csv"))
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!("mkfifo not available: skipped");
        return;
    }
    let outdir = tmp.path().join("out");
    std::fs::create_dir(&outdir).expect("mkdir");
    let mut child = momo()
        .arg("run")
        .arg(&seq)
        .arg("-o")
        .arg(outdir.join("p.txt"))
        .arg("-d")
        .arg(outdir.join("d.csv"))
        .arg("-q")
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    // Opening the FIFO for writing waits for momo to open it for reading.
    let mut fifo = std::fs::OpenOptions::new()
        .write(true)
        .open(seq.join("matches.csv"))
        .expect("fifo");
    // The header and the rows of the first frame pairs, then nothing: momo waits.
    let half: String = matches
        .lines()
        .take(100)
        .map(|l| format!("{l}\n"))
        .collect();
    fifo.write_all(half.as_bytes()).expect("write");
    fifo.flush().expect("flush");
    let start = std::time::Instant::now();
    while open_temporaries(child.id(), &outdir) < 2 {
        assert!(
            start.elapsed().as_secs() < 60,
            "no temporary files appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let pid = child.id().to_string();
    let killed = Command::new("kill")
        .arg(format!("-{signal}"))
        .arg(&pid)
        .status()
        .expect("kill");
    assert!(killed.success());
    let status = child.wait().expect("wait");
    drop(fifo);
    if expected < 0 {
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(-expected), "killed by SIG{signal}");
    } else {
        assert_eq!(status.code(), Some(expected), "exit code after SIG{signal}");
    }
    assert_eq!(
        temporaries(&outdir),
        Vec::<String>::new(),
        "temporaries removed"
    );
    assert!(!outdir.join("p.txt").exists() && !outdir.join("d.csv").exists());
    let left: Vec<_> = std::fs::read_dir(&outdir).expect("dir").collect();
    assert!(left.is_empty(), "left in the output directory: {left:?}");
}

#[test]
fn sigterm_removes_temporary_files_and_exits_143() {
    signal_during_run("TERM", 143);
}

#[test]
fn sigint_removes_temporary_files_and_exits_130() {
    signal_during_run("INT", 130);
}

#[test]
#[cfg(target_os = "linux")]
fn sigkill_mid_write_leaves_no_file() {
    // SIGKILL cannot be caught: nothing of momo runs after it. The temporary outputs are
    // anonymous (O_TMPFILE) until the commit, so the kernel drops them with the process.
    signal_during_run("KILL", -9);
}

#[test]
fn simulate_and_import_refuse_a_non_empty_directory_without_force() {
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path().join("sim");
    std::fs::create_dir(&dir).expect("mkdir");
    std::fs::write(dir.join("rig.json"), "mine").expect("write");
    let o = out(momo().args(["simulate", "--frames", "5"]).arg(&dir));
    assert_refused(&o, "non-empty");
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(dir.join("rig.json")).expect("r"),
        "mine"
    );
    let o = out(momo()
        .args(["simulate", "--frames", "5", "--force"])
        .arg(&dir));
    assert_exit(&o, 0, &[]);
    assert!(momo::io::read_sequence(&dir).is_ok());
    // A file as the output directory.
    let file = tmp.path().join("file");
    std::fs::write(&file, "x").expect("write");
    let o = out(momo().args(["simulate", "--frames", "5"]).arg(&file));
    assert_refused(&o, "file as directory");
    // import-kitti too (its input is checked after the directory, so any input will do).
    let o = out(momo().arg("import-kitti").arg(tmp.path()).arg(&dir));
    assert_exit(&o, 2, &[]);
}

#[test]
fn a_failed_simulate_leaves_no_directory() {
    let tmp = tempfile::tempdir().expect("tmp");
    let traj = tmp.path().join("traj.txt");
    // Two poses 1e201 m apart: valid syntax, the simulation's pixels overflow.
    std::fs::write(
        &traj,
        "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1e201 0 1 0 0 0 0 1 1e201\n1 0 0 2e201 0 1 0 0 0 0 1 2e201\n",
    )
    .expect("write");
    let dir = tmp.path().join("new/sim");
    let o = out(momo()
        .args(["simulate", "--frames", "3", "--trajectory"])
        .arg(&traj)
        .arg(&dir));
    assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_ne!(o.status.code(), Some(101), "{}", stderr(&o));
    assert!(
        !tmp.path().join("new").exists(),
        "created directories removed"
    );
    // Into an existing empty directory: it stays, empty.
    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).expect("mkdir");
    let o = out(momo()
        .args(["simulate", "--frames", "3", "--trajectory"])
        .arg(&traj)
        .arg(&empty));
    assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(&empty).expect("dir").count(), 0);
}

#[test]
fn a_failed_match_leaves_no_directory() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let images = tmp.path().join("images");
    std::fs::create_dir(&images).expect("mkdir");
    std::fs::write(images.join("000000.png"), "not a png").expect("write");
    std::fs::write(images.join("000001.png"), "not a png").expect("write");
    let dir = tmp.path().join("matched");
    let o = out(momo()
        .arg("match")
        .arg(&images)
        .arg("--rig")
        .arg(seq.join("rig.json"))
        .arg("-o")
        .arg(&dir)
        .arg("-q"));
    assert_exit(&o, 2, &[]);
    assert!(!dir.exists(), "the created output directory is removed");
}

#[test]
fn a_closed_pipe_ends_quietly_with_141() {
    for args in [&["config"][..], &["demo", "--frames", "3", "--quiet"][..]] {
        // The pipe's read end is closed before the child starts, so its first write fails
        // whatever the scheduling (closing it after the spawn raced with a child whose whole
        // output fits in the pipe's buffer: `config` writes 8 KB).
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        let o = momo()
            .args(args)
            .stdout(writer)
            .stderr(Stdio::piped())
            .output()
            .expect("run");
        assert_eq!(o.status.code(), Some(141), "{args:?}: {}", stderr(&o));
        assert_eq!(stderr(&o), "", "{args:?}: quiet");
    }
}

#[test]
fn a_full_standard_output_is_an_error_not_a_panic() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("/dev/full not available: skipped");
        return;
    };
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let gt = seq.join("poses.txt");
    let cases: Vec<Vec<std::ffi::OsString>> = vec![
        vec!["config".into()],
        vec![
            "eval".into(),
            "--gt".into(),
            gt.clone().into(),
            "--est".into(),
            gt.clone().into(),
        ],
        vec![
            "calibrate".into(),
            seq.clone().into(),
            "-o".into(),
            tmp.path().join("rig.json").into(),
        ],
    ];
    for args in cases {
        let o = out(momo().args(&args).stdout(full.try_clone().expect("dup")));
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("cannot write to standard output"),
            "{args:?}: {}",
            stderr(&o)
        );
    }
    // Standard error full after the poses were written: the poses stand, no panic.
    let p = tmp.path().join("p.txt");
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-o")
        .arg(&p)
        .stderr(full.try_clone().expect("dup")));
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(momo::io::read_poses(&p).expect("poses").len(), 10);
}

#[test]
fn a_dangling_odometry_link_is_an_error() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    std::fs::remove_file(seq.join("odometry.csv")).expect("rm");
    std::os::unix::fs::symlink(tmp.path().join("gone.csv"), seq.join("odometry.csv"))
        .expect("symlink");
    let p = tmp.path().join("p.txt");
    let o = out(momo().arg("run").arg(&seq).arg("-o").arg(&p).arg("-q"));
    assert_exit(&o, 2, &["odometry.csv: a symbolic link"]);
    assert!(!p.exists());
    let o = out(momo()
        .arg("calibrate")
        .arg(&seq)
        .arg("-o")
        .arg(&p)
        .arg("-q"));
    assert_exit(&o, 2, &[]);
}

#[test]
fn eval_needs_two_poses() {
    let tmp = tempfile::tempdir().expect("tmp");
    let one = tmp.path().join("one.txt");
    std::fs::write(&one, "1 0 0 0 0 1 0 0 0 0 1 0\n").expect("write");
    let empty = tmp.path().join("empty.txt");
    std::fs::write(&empty, "").expect("write");
    for f in [&one, &empty] {
        let o = out(momo().arg("eval").arg("--gt").arg(f).arg("--est").arg(f));
        assert_exit(&o, 2, &["at least 2"]);
        assert!(!String::from_utf8_lossy(&o.stdout).contains("NaN"));
    }
}

#[test]
fn a_negative_frame_rate_is_parsed_and_rejected() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let gt = seq.join("poses.txt");
    let o = out(momo()
        .args(["plot", "errors", "--gt"])
        .arg(&gt)
        .arg("--est")
        .arg(&gt)
        .arg("-o")
        .arg(tmp.path().join("e.svg"))
        .args(["--frame-rate", "-10"]));
    assert_exit(&o, 2, &["--frame-rate must be a positive number"]);
}

#[test]
fn config_files_are_capped_and_unknown_solver_keys_rejected() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let p = tmp.path().join("p.txt");
    // /dev/zero: refused after 1 MiB, not read until memory runs out.
    let started = std::time::Instant::now();
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .args(["-c", "/dev/zero", "-o"])
        .arg(&p));
    assert_exit(&o, 2, &["/dev/zero: larger than 1048576 bytes"]);
    assert!(started.elapsed().as_secs() < 30);
    // A misspelt solver option is an error naming the file and the line.
    let cfg = tmp.path().join("typo.toml");
    std::fs::write(
        &cfg,
        "[solver]\ntype = \"levenberg_marquardt\"\nmax_iteratons = 0\n",
    )
    .expect("write");
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-c")
        .arg(&cfg)
        .arg("-o")
        .arg(&p));
    assert_exit(&o, 2, &["typo.toml:", "max_iteratons"]);
    // A missing file: the OS error once.
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-c")
        .arg(tmp.path().join("none.toml"))
        .arg("-o")
        .arg(&p));
    assert_exit(&o, 2, &[]);
    assert_eq!(
        stderr(&o).matches("No such file").count(),
        1,
        "{}",
        stderr(&o)
    );
    assert!(!p.exists());
}

#[test]
fn a_huge_sweep_grid_is_counted_not_expanded() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let scales: Vec<String> = (1..=3000).map(|i| format!("{}", i as f64 * 1e-4)).collect();
    let matches: Vec<String> = (1..=3000).map(|i| i.to_string()).collect();
    let grid = tmp.path().join("grid.toml");
    std::fs::write(
        &grid,
        format!(
            "models = [\"se3\"]\nmetrics = [\"angle_plane\"]\nlosses = [\"cauchy\"]\n\
             solvers = [\"levenberg_marquardt\"]\nmatches = [{}]\nloss_scales = [{}]\n",
            matches.join(", "),
            scales.join(", ")
        ),
    )
    .expect("write");
    let started = std::time::Instant::now();
    let o = out(momo()
        .arg("sweep")
        .arg("--grid")
        .arg(&grid)
        .arg("--sequences")
        .arg(&seq)
        .arg("--output")
        .arg(tmp.path().join("out"))
        .arg("--quiet"));
    assert_exit(&o, 2, &["9000000 combinations"]);
    assert!(started.elapsed().as_secs() < 60);
}

#[test]
fn too_many_restart_offsets_and_an_endless_font_are_bounded() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let offsets = vec!["0.0"; 100_000];
    let cfg = tmp.path().join("c.toml");
    let default = String::from_utf8(out(momo().arg("config")).stdout).expect("utf8");
    let text: String = default
        .lines()
        .map(|l| {
            if l.starts_with("restart_yaw_offsets") {
                format!("restart_yaw_offsets = [{}]\n", offsets.join(", "))
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert!(
        text.len() > default.len(),
        "the default names restart_yaw_offsets"
    );
    std::fs::write(&cfg, text).expect("write");
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-c")
        .arg(&cfg)
        .arg("-o")
        .arg(tmp.path().join("p.txt")));
    assert_exit(&o, 2, &["restart_yaw_offsets has 100000 entries"]);
    // MOMO_PLOT_FONT=/dev/zero: skipped after 64 MiB instead of read until memory runs out.
    let gt = seq.join("poses.txt");
    let o = out(momo()
        .env("MOMO_PLOT_FONT", "/dev/zero")
        .args(["plot", "trajectory", "--gt"])
        .arg(&gt)
        .arg("--est")
        .arg(&gt)
        .arg("-o")
        .arg(tmp.path().join("t.svg")));
    assert_exit(&o, 0, &[]);
}

/// Rewrites the frame number `from` to `to` in a sequence file (`matches.csv`, `odometry.csv`).
fn renumber(path: &Path, from: usize, to: usize) {
    let text = std::fs::read_to_string(path).expect("read");
    let prefix = format!("{from},");
    let out: String = text
        .lines()
        .map(|l| match l.strip_prefix(&prefix) {
            Some(rest) => format!("{to},{rest}\n"),
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(path, out).expect("write");
}

#[test]
fn sparse_frame_numbers_are_not_expanded_in_memory() {
    // Frames 1-5 of a simulated drive, then its frame 6 renumbered to 10,000,000 (MAX_FRAME).
    // Expanded, the 10 million frame pairs take 800 MB (the calibration was killed by the limit
    // below: "memory allocation failed", SIGABRT); held sparsely, a few MB.
    let tmp = tempfile::tempdir().expect("tmp");
    let compact = tmp.path().join("compact");
    let mut cfg = SimConfig::clean_pinhole();
    cfg.frames = 7;
    cfg.matches_per_camera = 100;
    let sim = simulate(&cfg).expect("simulates");
    sim.write(&compact).expect("writes");
    std::fs::remove_file(compact.join("poses.txt")).expect("rm");
    let sparse = tmp.path().join("sparse");
    std::fs::create_dir(&sparse).expect("mkdir");
    for f in ["rig.json", "matches.csv", "odometry.csv"] {
        std::fs::copy(compact.join(f), sparse.join(f)).expect("copy");
    }
    renumber(&sparse.join("matches.csv"), 6, 10_000_000);
    renumber(&sparse.join("odometry.csv"), 6, 10_000_000);
    let limit_kb = 400_000;

    // The calibration visits the same frame pairs: the same rig, bit for bit.
    let calibrate = |seq: &Path, rig: &Path| {
        let o = out(momo_limited(limit_kb)
            .arg("calibrate")
            .arg(seq)
            .arg("-o")
            .arg(rig)
            .arg("-q"));
        assert_exit(&o, 0, &[]);
        std::fs::read(rig).expect("rig written")
    };
    let from_compact = calibrate(&compact, &tmp.path().join("compact.json"));
    let from_sparse = calibrate(&sparse, &tmp.path().join("sparse.json"));
    assert_eq!(from_sparse, from_compact);

    // The landscape of frame 3 reads the whole sequence and runs frames 1-3.
    let o = out(momo_limited(limit_kb)
        .args(["plot", "landscape"])
        .arg(&sparse)
        .args(["--frame", "3", "--steps", "5", "-o"])
        .arg(tmp.path().join("l.svg")));
    assert_exit(&o, 0, &[]);
    assert!(tmp.path().join("l.svg").exists());
    // A frame pair beyond the sequence is still named with the sequence's true extent.
    let o = out(momo_limited(limit_kb)
        .args(["plot", "landscape"])
        .arg(&sparse)
        .args(["--frame", "10000001", "-o"])
        .arg(tmp.path().join("l2.svg")));
    assert_exit(&o, 2, &["frames 1..=10000000"]);
}

#[test]
fn a_huge_last_frame_in_odometry_csv_is_not_expanded_by_momo_run() {
    // odometry.csv's last frame is 10,000,000 (MAX_FRAME) and matches.csv ends in a bad row:
    // the run streams frames 1-6, then stops at the bad row with exit 2. Held densely (16 bytes
    // per frame), the odometry took 160-320 MB before the first frame and the process was
    // killed by the allocator under the limit below (SIGABRT, exit 134); held as its rows, a
    // debug build runs in under 50 MB of address space.
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let mut cfg = SimConfig::clean_pinhole();
    cfg.frames = 7;
    cfg.matches_per_camera = 100;
    simulate(&cfg)
        .expect("simulates")
        .write(&seq)
        .expect("writes");
    let append = |name: &str, row: &str| {
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(seq.join(name))
            .expect("open");
        writeln!(f, "{row}").expect("append");
    };
    append("odometry.csv", "10000000,1.0");
    append("matches.csv", "garbage");
    let rows = std::fs::read_to_string(seq.join("matches.csv"))
        .expect("read")
        .lines()
        .count();
    let poses = tmp.path().join("p.txt");
    let o = out(momo_limited(100_000)
        .arg("run")
        .arg(&seq)
        .arg("-o")
        .arg(&poses)
        .arg("-q"));
    assert_exit(&o, 2, &[&format!("matches.csv:{rows}:")]);
    assert!(!poses.exists());
}

/// `momo config`'s text with the line starting with `key_line` replaced by `new` (or, when
/// `new` starts with `+`, followed by it); returns the text and the 1-based line of the change.
fn config_with(default: &str, key_line: &str, new: &str) -> (String, usize) {
    let mut line = 0;
    let mut text = String::new();
    for (i, l) in default.lines().enumerate() {
        if line == 0 && l.starts_with(key_line) {
            if let Some(after) = new.strip_prefix('+') {
                text.push_str(&format!("{l}\n{after}\n"));
                line = i + 2;
            } else {
                text.push_str(&format!("{new}\n"));
                line = i + 1;
            }
        } else {
            text.push_str(&format!("{l}\n"));
        }
    }
    assert!(line > 0, "the default configuration has `{key_line}`");
    (text, line)
}

#[test]
fn out_of_range_configuration_values_are_rejected_naming_file_line_and_key() {
    let tmp = tempfile::tempdir().expect("tmp");
    let default = String::from_utf8(out(momo().arg("config")).stdout).expect("utf8");
    let huge = "9223372036854775807";
    // (line of the default to change, the change, the key named, whether the line is exact)
    let cases = [
        (
            "initial_arc_length",
            "initial_arc_length = 1e308".to_string(),
            "odometry.initial_arc_length",
            true,
        ),
        (
            "rotation_change_sigma",
            "rotation_change_sigma = 1e-300".into(),
            "odometry.rotation_change_sigma",
            true,
        ),
        (
            "max_iterations = 50",
            format!("max_iterations = {huge}"),
            "solver.max_iterations",
            true,
        ),
        (
            "max_iterations = 1000",
            format!("max_iterations = {huge}"),
            "five_point.max_iterations",
            true,
        ),
        (
            "threshold = 0.001",
            "threshold = 1e300".into(),
            "five_point.threshold",
            true,
        ),
        (
            "[odometry.motion_prior_sigmas]",
            "+rot_z = 1e-300".into(),
            "odometry.motion_prior_sigmas.rot_z",
            false,
        ),
        // 2^32 x 2^32 cells: the product overflowed (a panic in debug builds, 0 cells in release).
        // (`momo config` prints `[odometry.separate]` since the separation is on by default:
        // its `grid` line is the first that starts with `grid = `.)
        (
            "grid = ",
            "grid = [4294967296, 4294967296]".into(),
            "odometry.separate.grid",
            false,
        ),
    ];
    let path = tmp.path().join("cfg.toml");
    for (key_line, new, key, exact) in &cases {
        let (text, line) = config_with(&default, key_line, new);
        std::fs::write(&path, text).expect("write");
        let e = momo::vo::Config::from_file(&path)
            .expect_err(key)
            .to_string();
        let at = if *exact {
            format!("{}:{line}: ", path.display())
        } else {
            format!("{}:", path.display())
        };
        assert!(e.starts_with(&at) && e.contains(key), "{key}: {e}");
        // The process: exit 2, nothing written.
        let p = tmp.path().join("p.txt");
        let o = out(momo()
            .arg("run")
            .arg(tmp.path().join("none"))
            .arg("-c")
            .arg(&path)
            .arg("-o")
            .arg(&p));
        assert_eq!(o.status.code(), Some(2), "{key}: {}", stderr(&o));
        assert!(stderr(&o).contains(&at), "{key}: {}", stderr(&o));
        assert!(!p.exists());
    }
    // A motion prior on a parameter the model does not have: the file and the line, not
    // `<config>` (the check ran in Odometry::new, which did not know the file).
    let seq = tmp.path().join("seq");
    sequence(&seq);
    let (text, line) = config_with(&default, "[odometry.motion_prior_sigmas]", "+nope = 1.0");
    std::fs::write(&path, text).expect("write");
    let o = out(momo()
        .arg("run")
        .arg(&seq)
        .arg("-c")
        .arg(&path)
        .arg("-o")
        .arg(tmp.path().join("p.txt")));
    assert_exit(&o, 2, &[]);
    let e = stderr(&o);
    assert!(
        e.contains(&format!(
            "{}:{line}: odometry.motion_prior_sigmas: the model has no parameter `nope`",
            path.display()
        )),
        "{e}"
    );
    assert!(!e.contains("<config>"), "{e}");
}

/// A KITTI odometry sequence folder: calib.txt, image_0/ with three 64 x 32 PNGs, times.txt.
fn kitti_folder(dir: &Path) {
    std::fs::create_dir_all(dir.join("image_0")).expect("mkdir");
    std::fs::write(
        dir.join("calib.txt"),
        "P0: 50 0 32 0 0 50 16 0 0 0 1 0\nP1: 50 0 32 -27 0 50 16 0 0 0 1 0\n",
    )
    .expect("calib");
    for k in 0..3 {
        let pixels: Vec<u8> = (0..64 * 32)
            .map(|i| (((i % 64 + 3 * k) * 37 + (i / 64) * 11) % 251) as u8)
            .collect();
        let img = momo_match::GrayImage::from_raw(64, 32, pixels).expect("64 x 32");
        img.save(dir.join(format!("image_0/{k:06}.png")))
            .expect("png");
    }
    std::fs::write(dir.join("times.txt"), "0.0\n0.1\n0.2\n").expect("times");
}

#[test]
fn the_kitti_folder_import_checks_its_output_directory_like_the_other_writers() {
    let tmp = tempfile::tempdir().expect("tmp");
    let kitti = tmp.path().join("kitti/06");
    kitti_folder(&kitti);
    let import = |out_dir: &Path, force: bool| {
        let mut c = momo();
        c.arg("import-kitti").arg(&kitti).arg(out_dir).arg("-q");
        if force {
            c.arg("--force");
        }
        out(&mut c)
    };
    // A new directory: written.
    let fresh = tmp.path().join("fresh");
    let o = import(&fresh, false);
    assert_exit(&o, 0, &[]);
    assert!(fresh.join("rig.json").is_file() && fresh.join("times.txt").is_file());

    // A non-empty directory without --force: refused, untouched; with --force: written.
    let mine = tmp.path().join("mine");
    std::fs::create_dir(&mine).expect("mkdir");
    std::fs::write(mine.join("rig.json"), "mine").expect("write");
    let before = snapshot(&mine);
    let o = import(&mine, false);
    assert_refused(&o, "non-empty");
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    assert_eq!(snapshot(&mine), before);
    let o = import(&mine, true);
    assert_exit(&o, 0, &[]);
    assert!(momo::io::read_rig(mine.join("rig.json")).is_ok());

    // The input folder itself (even with --force, any spelling): refused, nothing written there.
    let before = snapshot(&kitti);
    for spelling in [kitti.clone(), tmp.path().join("kitti/./06/../06")] {
        let o = import(&spelling, true);
        assert_refused(&o, "the input folder");
        assert_eq!(snapshot(&kitti), before);
    }
    // An output that is an input of the import (its times.txt as the output's times.txt).
    let linked = tmp.path().join("linked");
    std::fs::create_dir(&linked).expect("mkdir");
    std::os::unix::fs::symlink(kitti.join("times.txt"), linked.join("times.txt")).expect("ln");
    let o = import(&linked, true);
    assert_refused(&o, "an input");
    assert_eq!(snapshot(&kitti), before);

    // A failed import (a corrupt first image) removes the directory it created.
    std::fs::write(kitti.join("image_0/000000.png"), "not a png").expect("write");
    let failed = tmp.path().join("new/deep");
    let o = import(&failed, false);
    assert_exit(&o, 2, &[]);
    assert!(
        !tmp.path().join("new").exists(),
        "created directories removed"
    );
}

#[cfg(target_os = "linux")]
#[test]
fn an_allocation_failure_mid_run_leaves_no_file() {
    // Frames 1-6 are estimated and their poses written into the (anonymous, O_TMPFILE) output,
    // then the last frame pair holds 3 million matches: reading it needs more address space
    // than the limit allows, the allocator fails and the process aborts (SIGABRT) in the middle
    // of the run. No handler runs on an abort; the output must still leave nothing behind.
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let mut cfg = SimConfig::clean_pinhole();
    cfg.frames = 8;
    cfg.matches_per_camera = 100;
    simulate(&cfg)
        .expect("simulates")
        .write(&seq)
        .expect("writes");
    let text = std::fs::read_to_string(seq.join("matches.csv")).expect("read");
    let last = text.lines().last().expect("a row").to_string();
    let mut f = std::io::BufWriter::new(
        std::fs::OpenOptions::new()
            .append(true)
            .open(seq.join("matches.csv"))
            .expect("open"),
    );
    for _ in 0..3_000_000 {
        writeln!(f, "{last}").expect("append");
    }
    f.flush().expect("flush");
    drop(f);
    let out_dir = tmp.path().join("out");
    std::fs::create_dir(&out_dir).expect("mkdir");
    let o = out(momo_limited(100_000)
        .arg("run")
        .arg(&seq)
        .arg("-o")
        .arg(out_dir.join("p.txt"))
        .arg("-d")
        .arg(out_dir.join("d.csv"))
        .arg("-q"));
    {
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(
            o.status.signal(),
            Some(6),
            "expected an abort on the allocation failure: {:?} {}",
            o.status,
            stderr(&o)
        );
    }
    let left: Vec<_> = std::fs::read_dir(&out_dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}
