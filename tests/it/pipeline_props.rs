//! Property tests of the whole pipeline (`docs/GUARANTEES.md`, "valid input"): for random valid
//! rigs (pinhole and fisheye, 1-4 cameras, random mounts including the motion centre) and random
//! simulated sequences (noise, outliers, stops, blinded cameras, a moving object, with or
//! without odometry), written in the `FORMAT.md` layout and run by the `momo run` binary, the
//! run
//! - exits successfully (no panic; exit 3 when most frame pairs were held, with its warning),
//! - writes exactly one pose per frame (and one diagnostics row per frame pair),
//! - every pose finite with an orthonormal rotation (the reader's 1e-6 check, and 1e-9 here).
//!
//! And for malformed input (`docs/GUARANTEES.md`, "malformed input"): binary garbage and a line
//! longer than 1 MiB make `momo run` exit with code 2 and a `file:line: reason` message, leaving
//! no output file.

use momo::core::{Camera, KannalaBrandt, Pinhole, Rig, RigCamera};
use momo::sim::{BlindMode, Blinding, MovingObject, RigPreset, SimConfig, camera_mount, simulate};
use nalgebra::Vector3;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh directory under the system's temporary directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Self {
        static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let d = std::env::temp_dir().join(format!(
            "momo-props-{}-{}",
            std::process::id(),
            N.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&d).expect("temp dir");
        Self(d)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn camera_strategy() -> impl Strategy<Value = Camera> {
    prop_oneof![
        (
            300.0..1200.0f64,
            0.8..1.25f64,
            320.0..1600.0f64,
            0.3..1.0f64
        )
            .prop_map(|(f, aspect, w, hw)| {
                let h = (w * hw).round();
                Camera::Pinhole(Pinhole {
                    fx: f,
                    fy: f * aspect,
                    cx: w / 2.0,
                    cy: h / 2.0,
                    width: w,
                    height: h,
                })
            }),
        (250.0..400.0f64, -0.02..0.03f64).prop_map(|(f, k1)| {
            Camera::KannalaBrandt(KannalaBrandt {
                fx: f,
                fy: f,
                cx: 640.0,
                cy: 480.0,
                k1,
                k2: -0.005,
                k3: 0.001,
                k4: -0.0001,
                width: 1280.0,
                height: 960.0,
            })
        }),
    ]
}

/// A camera mounted anywhere within a car's outline (or exactly in the motion centre), looking
/// in any horizontal direction, tilted down by up to 30 degrees.
fn rig_camera_strategy() -> impl Strategy<Value = RigCamera> {
    (
        camera_strategy(),
        prop_oneof![
            1 => Just(Vector3::zeros()),
            3 => (-1.0..4.0f64, -1.0..1.0f64, 0.5..2.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z)),
        ],
        -std::f64::consts::PI..std::f64::consts::PI,
        0.0..0.5f64,
    )
        .prop_map(|(model, position, yaw, pitch)| RigCamera {
            name: "cam".into(),
            model,
            t_vehicle_camera: camera_mount(position, yaw, pitch),
        })
}

fn rig_strategy() -> impl Strategy<Value = Rig> {
    prop_oneof![
        Just(momo::sim::kitti_mono()),
        Just(momo::sim::kitti_stereo()),
        Just(momo::sim::surround_fisheye()),
        prop::collection::vec(rig_camera_strategy(), 1..=3).prop_map(|cams| {
            let cams = cams
                .into_iter()
                .enumerate()
                .map(|(i, c)| RigCamera {
                    name: format!("cam{i}"),
                    ..c
                })
                .collect();
            Rig::new(cams).expect("camera_mount gives orthonormal rotations")
        }),
    ]
}

/// Estimator and configuration choices: `--estimator`, and a configuration file (empty: the
/// default). The metric must fit every camera: `geo_line` and `sampson` need pinhole cameras, so
/// only `angle_plane` is drawn.
const CONFIGS: &[(&str, &str)] = &[
    ("momo", ""),
    (
        "momo",
        "[model]\ntype = \"single_track_2d\"\n[metric]\ntype = \"angle_plane\"\n\
         [loss]\ntype = \"cauchy\"\nscale = 0.002\n[solver]\ntype = \"dogleg\"\n",
    ),
    (
        "momo",
        "[model]\ntype = \"single_track_3d\"\n[metric]\ntype = \"angle_plane\"\n\
         [loss]\ntype = \"huber\"\nscale = 0.002\n[solver]\ntype = \"gauss_newton\"\n",
    ),
    ("five-point", ""),
];

fn momo_run(seq: &Path, out: &Path, extra: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_momo"))
        .arg("run")
        .arg(seq)
        .arg("--output")
        .arg(out)
        .arg("--quiet")
        .args(extra)
        .output()
        .expect("momo starts")
}

#[derive(Debug, Clone)]
struct Case {
    rig: Rig,
    sim: SimConfig,
    config: usize,
}

fn case_strategy() -> impl Strategy<Value = Case> {
    (
        rig_strategy(),
        (
            2usize..14,
            any::<u64>(),
            0usize..80,
            0.0..1.5f64,
            0.0..0.5f64,
        ),
        (any::<bool>(), any::<bool>(), 0.0..0.1f64),
        (
            prop::option::of((0usize..4, 1usize..10, any::<bool>())),
            any::<bool>(),
        ),
        0..CONFIGS.len(),
    )
        .prop_map(
            |(
                rig,
                (frames, seed, matches, noise, outliers),
                (stops, odometry, odo_noise),
                (blind, moving),
                config,
            )| {
                let n = rig.len();
                let blinded = blind
                    .map(|(cam, len, absent)| Blinding {
                        camera: cam % n,
                        frames: 1..1 + len,
                        mode: if absent {
                            BlindMode::Absent
                        } else {
                            BlindMode::Outliers
                        },
                    })
                    .into_iter()
                    .collect();
                let sim = SimConfig {
                    frames,
                    seed,
                    matches_per_camera: matches,
                    pixel_noise: noise,
                    outlier_ratio: outliers,
                    rig: RigPreset::Custom(rig.clone()),
                    stops,
                    odometry,
                    odometry_noise: odo_noise,
                    blinded,
                    moving_object: moving.then(|| MovingObject::following(0, 1..frames, 0.4)),
                    ..SimConfig::default()
                };
                Case { rig, sim, config }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn momo_run_writes_one_finite_orthonormal_pose_per_frame(case in case_strategy()) {
        let sim = simulate(&case.sim).expect("a valid simulation");
        let dir = TempDir::new();
        let seq = dir.0.join("seq");
        sim.write(&seq).expect("writes the sequence");
        let (estimator, toml) = CONFIGS[case.config];
        let config = dir.0.join("config.toml");
        std::fs::write(&config, toml).expect("writes the configuration");
        let (out, diag) = (dir.0.join("poses.txt"), dir.0.join("diag.jsonl"));
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "--estimator".as_ref(), estimator.as_ref(),
            "--diagnostics".as_ref(), diag.as_os_str(),
        ];
        if !toml.is_empty() {
            args.extend(["--config".as_ref(), config.as_os_str()]);
        }
        let o = momo_run(&seq, &out, &args);
        // Exit 0, or 3 when most frame pairs of a random sequence failed or held their motion
        // (the run still writes every pose, and says so on stderr).
        let stderr = String::from_utf8_lossy(&o.stderr);
        prop_assert!(
            o.status.success() || (o.status.code() == Some(3) && stderr.contains("not trustworthy")),
            "{:?}: {}", o.status, stderr
        );
        // Frames as the format defines them (trailing frame pairs with neither a match nor an
        // arc length are not representable, see `momo_io::write_sequence`).
        let n = momo::io::read_sequence(&seq).expect("reads back").num_frames();
        prop_assert!(n <= sim.sequence.num_frames());
        let poses = momo::io::read_poses(&out).expect("the output reads back (finite, orthonormal within 1e-6)");
        prop_assert_eq!(poses.len(), n, "one pose per frame ({} cameras)", case.rig.len());
        prop_assert!((poses[0].rotation - nalgebra::Matrix3::identity()).amax() < 1e-12);
        for (k, p) in poses.iter().enumerate() {
            prop_assert!(p.translation.iter().all(|v| v.is_finite()), "frame {}", k);
            prop_assert!(p.orthonormality_error() < 1e-9, "frame {}: {:e}", k, p.orthonormality_error());
        }
        let diag = std::fs::read_to_string(&diag).expect("diagnostics");
        prop_assert_eq!(diag.lines().count(), n - 1);
    }
}

/// A valid sequence to spoil: 5 frames of the KITTI mono rig.
fn valid_sequence(dir: &Path) -> PathBuf {
    let seq = dir.join("seq");
    let cfg = SimConfig {
        frames: 5,
        matches_per_camera: 50,
        ..SimConfig::default()
    };
    simulate(&cfg).expect("valid").write(&seq).expect("writes");
    seq
}

/// `momo run` fails with exit code 2, `momo: error: <seq>/<file>:<line>: <reason>` on stderr, and
/// no output file.
fn expect_input_error(seq: &Path, file: &str, line: usize, reason: &str) {
    let out = seq.parent().expect("has a parent").join("poses.txt");
    let o = momo_run(seq, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    let expected = format!("{}:{line}: {reason}", seq.join(file).display());
    assert!(stderr.contains(&expected), "`{stderr}` lacks `{expected}`");
    assert!(
        stderr.len() < 1000,
        "a short message, not the input: {} bytes",
        stderr.len()
    );
    assert!(!out.exists(), "no output on error");
}

/// Deterministic binary garbage (bytes of a xorshift generator), with some newlines.
fn garbage(len: usize) -> Vec<u8> {
    let mut x = 0x2545_F491_4F6C_DD1D_u64;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 56) as u8
        })
        .collect()
}

#[test]
fn binary_garbage_is_reported_with_file_line_and_reason() {
    let tmp = TempDir::new();
    let seq = valid_sequence(&tmp.0);
    // A valid header, then 64 KiB of garbage from line 2 on: invalid UTF-8 on the first line of
    // garbage (the generator's first bytes hold no newline and are not UTF-8).
    let mut bytes = b"frame,camera,u0,v0,u1,v1\n".to_vec();
    let g = garbage(65536);
    let first_line_end = g.iter().position(|&b| b == b'\n').unwrap_or(g.len());
    assert!(std::str::from_utf8(&g[..first_line_end]).is_err());
    bytes.extend_from_slice(&g);
    std::fs::write(seq.join("matches.csv"), &bytes).expect("writes");
    expect_input_error(&seq, "matches.csv", 2, "invalid UTF-8");
    // Garbage in place of the whole file: the header line is rejected.
    std::fs::write(seq.join("matches.csv"), garbage(65536)).expect("writes");
    expect_input_error(&seq, "matches.csv", 1, "invalid UTF-8");

    let seq = valid_sequence(&tmp.0.join("b"));
    std::fs::write(seq.join("odometry.csv"), garbage(4096)).expect("writes");
    expect_input_error(&seq, "odometry.csv", 1, "invalid UTF-8");

    let seq = valid_sequence(&tmp.0.join("c"));
    std::fs::write(seq.join("rig.json"), garbage(4096)).expect("writes");
    expect_input_error(&seq, "rig.json", 1, "invalid UTF-8");
    // Printable garbage in rig.json: a JSON syntax error with line and column.
    std::fs::write(
        seq.join("rig.json"),
        "{\"cameras\": [\n  {\"model\": ~~~}]}",
    )
    .expect("writes");
    expect_input_error(&seq, "rig.json", 2, "expected value (column 13)");
}

#[test]
fn a_line_longer_than_one_mebibyte_is_reported_without_reading_it_whole() {
    let tmp = TempDir::new();
    let seq = valid_sequence(&tmp.0);
    let limit = momo::io::MAX_LINE_BYTES;
    assert_eq!(limit, 1 << 20);
    // Line 3 is 1 MiB + 1 of digits (no newline for 2 MiB).
    let mut text = String::from("frame,camera,u0,v0,u1,v1\n1,0,600,180,601,181\n1,0,600,180,601,");
    text.push_str(&"1".repeat(2 * limit));
    text.push('\n');
    std::fs::write(seq.join("matches.csv"), &text).expect("writes");
    expect_input_error(
        &seq,
        "matches.csv",
        3,
        &format!("longer than {limit} bytes"),
    );

    let seq = valid_sequence(&tmp.0.join("b"));
    let mut text = String::from("frame,arc_length\n1,");
    text.push_str(&"0".repeat(limit));
    std::fs::write(seq.join("odometry.csv"), &text).expect("writes");
    expect_input_error(
        &seq,
        "odometry.csv",
        2,
        &format!("longer than {limit} bytes"),
    );
}
