//! End-to-end tests of the `momo` binary: simulated sequences written in the FORMAT.md layout,
//! `momo run` as a process, and every class of bad input.

use momo::eval::{ErrorSummary, frame_to_frame_rotation_errors};
use momo::sim::{SimConfig, simulate};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn momo() -> Command {
    Command::new(env!("CARGO_BIN_EXE_momo"))
}

fn run(seq: &Path, out: &Path, extra: &[&str]) -> Output {
    momo()
        .arg("run")
        .arg(seq)
        .arg("--output")
        .arg(out)
        .arg("--quiet")
        .args(extra)
        .output()
        .expect("momo starts")
}

fn write_sim(dir: &Path, cfg: &SimConfig) -> momo::sim::Simulation {
    let sim = simulate(cfg).expect("valid simulation");
    sim.write(dir).expect("writes");
    sim
}

fn check_against_truth(sim: &momo::sim::Simulation, out: &Path, max_median_deg: f64, max_deg: f64) {
    let est = momo::io::read_poses(out).expect("momo writes valid poses");
    let gt = sim
        .sequence
        .ground_truth
        .as_ref()
        .expect("simulation has ground truth");
    assert_eq!(est.len(), sim.sequence.num_frames(), "one pose per frame");
    assert!((est[0].rotation - nalgebra::Matrix3::identity()).amax() < 1e-12);
    let s = ErrorSummary::from_values(&frame_to_frame_rotation_errors(gt, &est));
    eprintln!(
        "rotation error: median {:.4} p95 {:.4} max {:.4}",
        s.median, s.p95, s.max
    );
    assert!(s.median < max_median_deg, "median {}", s.median);
    assert!(s.max < max_deg, "max {}", s.max);
    // Translation: with odometry the end point is close (scale known, heading accurate).
    let (a, b) = (est.last().expect("poses"), gt.last().expect("poses"));
    let dist: f64 = sim.sequence.arc_lengths.iter().flatten().flatten().sum();
    let end_err = (a.translation - b.translation).norm();
    eprintln!("end point error {end_err:.3} m over {dist:.1} m");
    assert!(
        end_err < 0.02 * dist.max(1.0),
        "end point error {end_err} over {dist} m"
    );
}

#[test]
fn pinhole_sequence_end_to_end() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let mut cfg = SimConfig::outliers();
    cfg.frames = 60;
    cfg.seed = 3;
    let sim = write_sim(&seq, &cfg);
    let out = tmp.path().join("poses.txt");
    let diag = tmp.path().join("diag.csv");
    let o = run(&seq, &out, &["--diagnostics", diag.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_against_truth(&sim, &out, 0.1, 0.5);
    let rows = std::fs::read_to_string(&diag).expect("diagnostics written");
    assert_eq!(rows.lines().count(), 60, "header + one row per frame pair");
    assert!(
        rows.lines()
            .next()
            .expect("header")
            .starts_with("frame,status,scale")
    );
}

#[test]
fn fisheye_rig_with_blinded_camera_end_to_end() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let mut cfg = SimConfig::fisheye_surround();
    cfg.frames = 80; // camera 2 has no matches for frame pairs 40..70
    let sim = write_sim(&seq, &cfg);
    let out = tmp.path().join("poses.txt");
    let diag = tmp.path().join("diag.jsonl");
    let o = run(&seq, &out, &["--diagnostics", diag.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_against_truth(&sim, &out, 0.05, 0.5);
    let text = std::fs::read_to_string(&diag).expect("diagnostics written");
    let rows: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect();
    assert_eq!(rows.len(), 79);
    // During the blinded stretch camera 2 has no inliers; the others carry the estimate.
    let r = &rows[49];
    assert_eq!(r["frame"], 50);
    assert_eq!(r["inliers_per_camera"][2], 0);
    assert!(r["inliers_per_camera"][0].as_u64().expect("count") > 50);
}

#[test]
fn run_without_odometry_reads_the_scale_off_the_road_or_holds_it_and_says_which() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let mut cfg = SimConfig::clean_pinhole();
    cfg.frames = 30;
    write_sim(&seq, &cfg);
    std::fs::remove_file(seq.join("odometry.csv")).expect("odometry written by the simulator");
    let off = tmp.path().join("off.toml");
    std::fs::write(&off, "[odometry]\nroad_scale_frames = 0\n").expect("write");
    let out = tmp.path().join("poses.txt");
    let diag = tmp.path().join("diag.csv");
    // The scale column of each frame, with the given extra arguments.
    let scales = |extra: &[&str]| -> Vec<String> {
        let mut args = vec!["--diagnostics", diag.to_str().expect("utf8")];
        args.extend_from_slice(extra);
        let o = run(&seq, &out, &args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(momo::io::read_poses(&out).expect("poses").len(), 30);
        let text = std::fs::read_to_string(&diag).expect("diag");
        text.lines()
            .skip(1)
            .map(|line| line.split(',').nth(2).expect("scale column").to_string())
            .collect()
    };
    // The default: the road plane gives the arc length from the first frame that reads it on.
    let by_road = scales(&[]);
    assert!(
        by_road[0] == "estimated" || by_road[0] == "held",
        "{by_road:?}"
    );
    assert!(by_road[9..].iter().all(|s| s == "road"), "{by_road:?}");
    // Off: estimated through the lever arm, or held.
    for scale in scales(&["--config", off.to_str().expect("utf8")]) {
        assert!(scale == "estimated" || scale == "held", "{scale}");
    }
}

#[test]
fn config_prints_and_parses_back() {
    let tmp = tempfile::tempdir().expect("tmp");
    let o = momo().arg("config").output().expect("runs");
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).expect("utf8");
    assert!(text.contains("# Motion model"));
    let path = tmp.path().join("c.toml");
    std::fs::write(&path, &text).expect("write");
    let cfg = momo::vo::Config::from_file(&path).expect("the printed default parses back");
    assert_eq!(cfg.to_commented_toml(), text);

    // A JSON configuration and a broken one.
    let seq = tmp.path().join("seq");
    let mut sc = SimConfig::clean_pinhole();
    sc.frames = 5;
    write_sim(&seq, &sc);
    let json = tmp.path().join("c.json");
    std::fs::write(
        &json,
        r#"{"model":{"type":"single_track_2d"},"metric":{"type":"geo_line"},"loss":{"type":"huber","scale":1.0},"solver":{"type":"gauss_newton"}}"#,
    )
    .expect("write");
    let out = tmp.path().join("p.txt");
    let o = run(&seq, &out, &["--config", json.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, "[model]\ntype = \"no_such_model\"\n").expect("write");
    let out2 = tmp.path().join("p2.txt");
    let o = run(&seq, &out2, &["--config", bad.to_str().expect("utf8")]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.toml:"), "{err}");
    assert!(!out2.exists());
}

/// A small valid sequence to break in one way per test.
fn valid_sequence(dir: &Path) -> PathBuf {
    let seq = dir.join("seq");
    let mut cfg = SimConfig::clean_pinhole();
    cfg.frames = 6;
    cfg.matches_per_camera = 20;
    write_sim(&seq, &cfg);
    seq
}

fn replace_line(path: &Path, line: usize, text: &str) {
    let content = std::fs::read_to_string(path).expect("read");
    let mut lines: Vec<String> = content.lines().map(String::from).collect();
    lines[line - 1] = text.to_string();
    std::fs::write(path, lines.join("\n") + "\n").expect("write");
}

/// Runs `momo run` on a broken sequence: exit code 2, `file:line: reason`, no output file.
fn expect_input_error(seq: &Path, file: &str, line: Option<usize>, reason: &str) {
    let out = seq.parent().expect("parent").join("out.txt");
    let o = run(seq, &out, &[]);
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{err}");
    let location = match line {
        Some(l) => format!("{file}:{l}:"),
        None => format!("{file}:"),
    };
    assert!(err.contains(&location), "expected `{location}` in: {err}");
    assert!(
        err.to_lowercase().contains(reason),
        "expected `{reason}` in: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists(), "no output file on error");
    let leftovers: Vec<_> = std::fs::read_dir(seq.parent().expect("parent"))
        .expect("dir")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("out.txt"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn missing_files() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    std::fs::remove_file(seq.join("matches.csv")).expect("rm");
    expect_input_error(&seq, "matches.csv", None, "");
    std::fs::remove_file(seq.join("rig.json")).expect("rm");
    expect_input_error(&seq, "rig.json", None, "");
}

#[test]
fn missing_column() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    let m = seq.join("matches.csv");
    let text = std::fs::read_to_string(&m).expect("read");
    let fixed: Vec<String> = text
        .lines()
        .map(|l| l.rsplit_once(',').map_or(l, |(a, _)| a).to_string())
        .collect();
    std::fs::write(&m, fixed.join("\n")).expect("write");
    expect_input_error(&seq, "matches.csv", Some(1), "v1");
}

#[test]
fn non_finite_number() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    replace_line(&seq.join("matches.csv"), 3, "1,0,NaN,100,101,100");
    expect_input_error(&seq, "matches.csv", Some(3), "finite");
}

#[test]
fn unknown_camera_id() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    replace_line(&seq.join("matches.csv"), 4, "1,3,100,100,101,100");
    expect_input_error(&seq, "matches.csv", Some(4), "camera");
}

#[test]
fn frames_out_of_order() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    let m = seq.join("matches.csv");
    let n = std::fs::read_to_string(&m).expect("read").lines().count();
    replace_line(&m, n, "1,0,100,100,101,100");
    expect_input_error(&seq, "matches.csv", Some(n), "order");
}

#[test]
fn pixel_far_outside_the_image() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    replace_line(&seq.join("matches.csv"), 2, "1,0,5000,100,101,100");
    expect_input_error(&seq, "matches.csv", Some(2), "outside");
}

#[test]
fn non_orthonormal_extrinsic() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    let rig = seq.join("rig.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rig).expect("read")).expect("json");
    v["cameras"][0]["T_vehicle_camera"][0][0] = serde_json::json!(0.5);
    std::fs::write(&rig, serde_json::to_string_pretty(&v).expect("json")).expect("write");
    expect_input_error(&seq, "rig.json", None, "orthonormal");
}

#[test]
fn malformed_odometry() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = valid_sequence(tmp.path());
    replace_line(&seq.join("odometry.csv"), 3, "2,inf");
    expect_input_error(&seq, "odometry.csv", Some(3), "finite");
}

#[test]
fn help_explains_every_option() {
    let o = momo().args(["run", "--help"]).output().expect("runs");
    let text = String::from_utf8_lossy(&o.stdout);
    for opt in ["--output", "--config", "--diagnostics", "--quiet"] {
        assert!(text.contains(opt), "{opt} missing from help");
    }
}

#[test]
fn five_point_baseline_runs_behind_the_same_interface() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    let mut cfg = SimConfig::outliers();
    cfg.frames = 20;
    cfg.seed = 5;
    let sim = write_sim(&seq, &cfg);
    let out = tmp.path().join("poses.txt");
    let o = run(&seq, &out, &["--estimator", "five-point"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let est = momo::io::read_poses(&out).expect("poses");
    let gt = sim.sequence.ground_truth.as_ref().expect("truth");
    assert_eq!(est.len(), 20);
    let s = ErrorSummary::from_values(&frame_to_frame_rotation_errors(gt, &est));
    eprintln!("five-point: median {:.4} max {:.4}", s.median, s.max);
    assert!(s.median < 0.5 && s.above_one == 0, "{s:?}");
}

/// Issue 15: a configuration that cannot work with the rig is rejected before the first frame
/// with `file:line: reason` and exit code 2 (before: geo_line on a fisheye rig failed every
/// frame, exit 0); a run in which more than `trust.max_failed_share` of the frame pairs failed
/// or held their motion ends with a warning and exit code 3.
#[test]
fn trust_rejects_configurations_and_flags_untrusted_runs() {
    let tmp = tempfile::tempdir().expect("tmp");
    let seq = tmp.path().join("seq");
    write_sim(
        &seq,
        &SimConfig {
            frames: 6,
            ..SimConfig::fisheye_surround()
        },
    );
    let cfg = tmp.path().join("cfg.toml");
    std::fs::write(
        &cfg,
        "[model]\ntype = \"se3\"\n[metric]\ntype = \"geo_line\"\n[loss]\ntype = \"cauchy\"\nscale = 1.0\n[solver]\ntype = \"levenberg_marquardt\"\n",
    )
    .expect("writes");
    let out = run(
        &seq,
        &tmp.path().join("est.txt"),
        &["--config", cfg.to_str().expect("utf-8")],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("cfg.toml:4: metric `geo_line`"), "{err}");

    // Every frame pair without matches: held, 100 % > 50 %.
    let empty = tmp.path().join("empty");
    write_sim(
        &empty,
        &SimConfig {
            frames: 6,
            matches_per_camera: 0,
            ..SimConfig::clean_pinhole()
        },
    );
    let out = run(&empty, &tmp.path().join("est2.txt"), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("trust.max_failed_share"), "{err}");
    assert!(
        tmp.path().join("est2.txt").exists(),
        "the outputs are written"
    );
}

#[test]
fn simulate_drives_a_segment_of_a_trajectory_from_its_start_pose() {
    let tmp = tempfile::tempdir().expect("tmp");
    let traj = tmp.path().join("traj.txt");
    // Camera-0 poses 1 m apart along the optical axis, turning 1 deg about the vertical per
    // pose and pitched by 2 deg throughout: `R_k = R_y(k deg) R_x(2 deg)`.
    let axis = |x: f64, y: f64| {
        momo::core::so3_exp(&momo::core::nalgebra::Vector3::new(
            x.to_radians(),
            y.to_radians(),
            0.0,
        ))
    };
    let text: String = (0..8)
        .map(|k| {
            let r = axis(0.0, k as f64) * axis(2.0, 0.0);
            let (x, z) = (0.1 * k as f64, k as f64);
            let row = |i: usize| format!("{} {} {}", r[(i, 0)], r[(i, 1)], r[(i, 2)]);
            format!("{} {x} {} 0 {} {z}\n", row(0), row(1), row(2))
        })
        .collect();
    std::fs::write(&traj, text).expect("write");
    let sim = |dir: &Path, extra: &[&str]| {
        momo()
            .args([
                "simulate",
                "--scenario",
                "clean_pinhole",
                "-q",
                "--trajectory",
            ])
            .arg(&traj)
            .args(extra)
            .arg(dir)
            .output()
            .expect("momo starts")
    };
    let (whole, part) = (tmp.path().join("whole"), tmp.path().join("part"));
    assert!(sim(&whole, &["--frames", "8"]).status.success());
    let o = sim(&part, &["--frames", "4", "--trajectory-start", "3"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = |d: &Path| momo::io::read_poses(d.join("poses.txt")).expect("poses");
    let (whole, part) = (read(&whole), read(&part));
    assert_eq!(part.len(), 4);
    // The segment starts at the origin and moves as the whole drive's poses 3-6 do.
    assert!(part[0].translation.norm() < 1e-9);
    for k in 1..4 {
        let a = part[k - 1].inverse().compose(&part[k]);
        let b = whole[k + 2].inverse().compose(&whole[k + 3]);
        assert!((a.translation - b.translation).norm() < 1e-9, "pose {k}");
        assert!((a.rotation - b.rotation).norm() < 1e-9, "pose {k}");
    }
    // A start that leaves fewer than two poses is an input error naming the file.
    let o = sim(&tmp.path().join("none"), &["--trajectory-start", "7"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("traj.txt") && err.contains("--trajectory-start 7"),
        "{err}"
    );
    assert!(!tmp.path().join("none").exists());
}
