//! `momo sweep` end to end: the job-array script (`scripts/sweep_array.sh local 2`) runs two
//! shards as separate processes and merges them; the merged table must equal the unsharded
//! sweep's, apart from the measured times. Also the CLI's input errors.

use momo::sim::{SimConfig, simulate};
use std::path::Path;
use std::process::{Command, Output};

fn momo() -> Command {
    Command::new(env!("CARGO_BIN_EXE_momo"))
}

const GRID: &str = r#"
models = ["se3", "single_track_2d"]
metrics = ["angle_plane", "sampson"]
losses = ["cauchy", "trivial"]
solvers = ["levenberg_marquardt", "dogleg"]
matches = [50]

[loss_scales]
angle_plane = [0.002]
sampson = [1.0]
"#;

fn setup(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let grid = dir.join("grid.toml");
    std::fs::write(&grid, GRID).expect("writes grid");
    let seq_a = dir.join("outliers");
    let seq_b = dir.join("moving");
    let a = SimConfig {
        frames: 20,
        matches_per_camera: 80,
        ..SimConfig::outliers()
    };
    let b = SimConfig {
        frames: 20,
        matches_per_camera: 80,
        seed: 3,
        ..SimConfig::moving_object()
    };
    simulate(&a).expect("sim").write(&seq_a).expect("writes");
    simulate(&b).expect("sim").write(&seq_b).expect("writes");
    (grid, seq_a, seq_b)
}

fn check(out: &Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn two_shards_merged_equal_the_unsharded_sweep() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (grid, seq_a, seq_b) = setup(tmp.path());

    let full = tmp.path().join("full");
    let out = momo()
        .args(["sweep", "--quiet", "--jobs", "2", "--grid"])
        .arg(&grid)
        .arg("--sequences")
        .args([&seq_a, &seq_b])
        .arg("--output")
        .arg(&full)
        .output()
        .expect("momo starts");
    check(&out, "momo sweep");

    let array = tmp.path().join("array");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/sweep_array.sh");
    let out = Command::new("bash")
        .arg(&script)
        .args(["local", "2"])
        .arg(&grid)
        .arg(&array)
        .args([&seq_a, &seq_b])
        .env("MOMO", env!("CARGO_BIN_EXE_momo"))
        .env("JOBS", "1")
        .output()
        .expect("bash starts");
    check(&out, "sweep_array.sh local 2");

    let whole = momo_sweep::read_csv(&full.join("results.csv")).expect("unsharded results");
    let merged = momo_sweep::read_csv(&array.join("merged/results.csv")).expect("merged results");
    let shard1 = momo_sweep::read_csv(&array.join("shard-1-of-2/results.csv")).expect("shard 1");
    let shard2 = momo_sweep::read_csv(&array.join("shard-2-of-2/results.csv")).expect("shard 2");

    // 2 models x (angle_plane: cauchy + trivial, sampson: cauchy + trivial) x 2 solvers
    // = 16 combinations, on 2 sequences.
    assert_eq!(whole.len(), 32);
    assert_eq!(shard1.len() + shard2.len(), 32);
    assert!(shard1.iter().all(|r| r.job % 2 == 0));
    assert!(shard2.iter().all(|r| r.job % 2 == 1));
    let strip = |rows: &[momo_sweep::Row]| -> Vec<momo_sweep::Row> {
        rows.iter().map(momo_sweep::Row::without_timings).collect()
    };
    assert_eq!(strip(&merged), strip(&whole));
    assert!(
        whole
            .iter()
            .all(|r| r.status == momo_sweep::Status::Ok && r.us_per_frame.is_some()),
        "every combination runs on a pinhole sequence"
    );
    // The default configuration is not in this grid (scale 0.002), so none is marked.
    assert!(whole.iter().all(|r| !r.is_default));

    let summary = std::fs::read_to_string(array.join("merged/summary.md")).expect("summary");
    assert!(summary.contains("## Best combination per sequence"));
    assert!(summary.contains("| outliers |") && summary.contains("| moving |"));
}

#[test]
fn input_errors_exit_with_2_and_name_the_problem() {
    let tmp = tempfile::tempdir().expect("tmp");
    let (grid, seq_a, _) = setup(tmp.path());
    let sweep = |extra: &[&str], grid: &Path| {
        momo()
            .args(["sweep", "--quiet", "--grid"])
            .arg(grid)
            .arg("--sequences")
            .arg(&seq_a)
            .arg("--output")
            .arg(tmp.path().join("o"))
            .args(extra)
            .output()
            .expect("momo starts")
    };
    let stderr = |o: &Output| String::from_utf8_lossy(&o.stderr).into_owned();

    let o = sweep(&["--shard", "3/2"], &grid);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--shard 3/2"), "{}", stderr(&o));

    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, GRID.replace("\"dogleg\"", "\"dogleggg\"")).expect("writes");
    let o = sweep(&[], &bad);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bad.toml:5:"), "{}", stderr(&o));
    assert!(!tmp.path().join("o").exists(), "no output on error");

    // A shard alone does not merge: the other half of the jobs is missing.
    let o = sweep(&["--shard", "1/2"], &grid);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = momo()
        .args(["sweep", "merge"])
        .arg(tmp.path().join("o/results.csv"))
        .arg("--output")
        .arg(tmp.path().join("m"))
        .output()
        .expect("momo starts");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("jobs missing"), "{}", stderr(&o));
}

/// The sweep's sub-sampling of a full KITTI import equals `momo import-kitti --matches N` with
/// the same seed (so sweep rows are comparable with `scripts/kitti00_eval.sh`).
#[test]
fn sweep_subsampling_equals_the_kitti_import() {
    let data = crate::common::shared_data();
    let dir = data.join("kitti00_stereo_matches_l1avgvo");
    if !dir.join("calib.txt").exists() {
        eprintln!(
            "skipped: no KITTI 00 matches in {} (set MOMO_DATA)",
            data.display()
        );
        return;
    }
    let import = |n: Option<usize>| {
        momo::io::kitti::import_l1avgvo(
            &dir,
            &momo::io::kitti::KittiImport {
                stereo: false,
                matches_per_frame: n,
                seed: 1,
                cross_camera: false,
            },
        )
        .expect("imports")
    };
    let all = import(None);
    let sub = momo_sweep::subsample(&all, momo_sweep::MatchCount::AtMost(200), 1);
    let direct = import(Some(200));
    assert_eq!(sub.num_matches(), direct.num_matches());
    assert_eq!(sub, direct);
}
