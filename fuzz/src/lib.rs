//! # momo-fuzz
//!
//! The bodies of momo's cargo-fuzz targets (`fuzz_targets/*.rs` are one-line wrappers around
//! the functions here, so that the same code also type-checks and runs without libFuzzer).
//! Each function takes arbitrary bytes, feeds them to one public entry point of the library and
//! panics only if a promise of `docs/GUARANTEES.md` is broken:
//!
//! | target | entry point | checked beyond "no panic" |
//! | --- | --- | --- |
//! | `rig_json` | `momo_io::read_rig_from_str` | an accepted rig writes and reads back equal |
//! | `matches_csv` | `momo_io::MatchReader` | contiguous frames, finite unit bearings |
//! | `odometry_csv` | `momo_io::read_odometry_from` | finite non-negative arc lengths |
//! | `kitti_poses` | `momo_io::read_poses_from` | finite orthonormal rotations |
//! | `config_toml`, `config_json` | `momo_vo::Config::from_{toml,json}_str` | an accepted config builds a driver and round-trips through TOML |
//! | `estimator` | `momo_vo::MotionDriver::process` (momo and the 5-point baseline) | every motion finite with an orthonormal rotation |
//! | `sweep_grid` | `momo_sweep::Grid::from_toml_str` | at most `MAX_COMBINATIONS`, counted as many as expanded; each combination's configuration valid or refused with its name, an accepted one round-trips and builds a driver |
//! | `image_header` | `momo_match::image_size_from_bytes`, `momo_match::decode_gray` | an image decodes to the size its header declares (the size check before decoding holds) |
//!
//! Every error a parser returns must name a line (or the whole file) and render as
//! `path[:line]: reason`.
//!
//! ```
//! // Anything goes in; only broken promises panic.
//! momo_fuzz::matches_csv(b"frame,camera,u0,v0,u1,v1\n1,0,1,2,3,4\n1,9,nan,0,0,0\n");
//! momo_fuzz::odometry_csv(b"frame,arc_length\n\xff\xfe");
//! momo_fuzz::rig_json(b"{\"cameras\": []}");
//!
//! // Every configuration of the estimator target is valid.
//! for i in 0..momo_fuzz::ESTIMATOR_CONFIGS.len() as u8 {
//!     let (_, config) = momo_fuzz::estimator_config(i);
//!     momo_vo::Odometry::new(momo_fuzz::estimator_rig(0), config).expect("fits a pinhole rig");
//! }
//! ```

use arbitrary::Arbitrary;
use momo_core::{Camera, FrameObservations, Observation, Pinhole, Pose, Rig, RigCamera};
use momo_io::{IoError, MatchReader, POSE_ORTHONORMAL_TOLERANCE};
use momo_vo::{Config, EstimatorKind, FrameStatus, MotionDriver};
use nalgebra::{Matrix3, Vector2, Vector3};

/// Yielded frame pairs after which [`matches_csv`] stops reading (a row `10000000,...` is valid
/// and yields ten million empty frame pairs, which is correct but makes fuzzing slow).
pub const MAX_FUZZ_FRAMES: usize = 10_000;

/// Largest number of matches per frame pair the [`estimator`] target builds (keeps executions
/// fast).
pub const MAX_FUZZ_MATCHES: usize = 400;

/// The KITTI-like pinhole camera of `FORMAT.md` (`momo_testing::canned::kitti_pinhole`).
pub fn kitti_pinhole() -> Camera {
    Camera::Pinhole(momo_testing::canned::kitti_pinhole())
}

/// A Kannala-Brandt fisheye whose field of view exceeds 180 degrees
/// (`momo_testing::canned::fisheye`).
pub fn wide_fisheye() -> Camera {
    Camera::KannalaBrandt(momo_testing::canned::fisheye())
}

/// A valid but hostile pinhole: a 1 x 1 image with wildly different focal lengths.
pub fn tiny_pinhole() -> Camera {
    Camera::Pinhole(Pinhole {
        fx: 1e-6,
        fy: 1e9,
        cx: 0.5,
        cy: 0.5,
        width: 1.0,
        height: 1.0,
    })
}

/// Camera looking along the vehicle's x axis (`FORMAT.md`'s example mount).
fn forward() -> Matrix3<f64> {
    momo_testing::canned::forward_looking()
}

fn rig_of(cameras: Vec<(Camera, Vector3<f64>, Matrix3<f64>)>) -> Rig {
    let cameras = cameras
        .into_iter()
        .enumerate()
        .map(|(i, (model, t, r))| RigCamera {
            name: format!("cam{i}"),
            model,
            t_vehicle_camera: Pose::new(r, t),
        })
        .collect();
    match Rig::new(cameras) {
        Ok(r) => r,
        Err(e) => panic!("the fuzz rigs are valid: {e}"),
    }
}

/// The rig the `matches_csv` target reads with: camera 0 [`kitti_pinhole`], camera 1
/// [`wide_fisheye`], camera 2 [`tiny_pinhole`]. `crates/momo-io/tests/it/regressions.rs` replays
/// crashers with the same rig.
pub fn matches_rig() -> Rig {
    let z = Vector3::zeros();
    rig_of(vec![
        (kitti_pinhole(), Vector3::new(1.0, 0.0, 1.65), forward()),
        (wide_fisheye(), z, forward()),
        (tiny_pinhole(), z, forward()),
    ])
}

/// The rigs the `estimator` target chooses from: a pinhole ahead of the motion centre, a
/// pinhole in the motion centre (scale unobservable), and a pinhole plus a rear-looking
/// fisheye.
pub fn estimator_rig(choice: u8) -> Rig {
    let ahead = Vector3::new(1.5, 0.1, 1.6);
    let back = Matrix3::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0) * forward();
    match choice % 3 {
        0 => rig_of(vec![(kitti_pinhole(), ahead, forward())]),
        1 => rig_of(vec![(kitti_pinhole(), Vector3::zeros(), forward())]),
        _ => rig_of(vec![
            (kitti_pinhole(), ahead, forward()),
            (wide_fisheye(), Vector3::new(-1.0, 0.0, 0.9), back),
        ]),
    }
}

/// Configurations of the `estimator` target: (estimator, model, metric, loss, solver, extra
/// TOML for the `[odometry]` section).
pub const ESTIMATOR_CONFIGS: &[(EstimatorKind, &str, &str, &str, &str, &str)] = &[
    (
        EstimatorKind::Momo,
        "se3",
        "angle_plane",
        "type = \"cauchy\"\nscale = 0.001",
        "levenberg_marquardt",
        "",
    ),
    (
        EstimatorKind::Momo,
        "single_track_2d",
        "angle_plane",
        "type = \"huber\"\nscale = 0.002",
        "dogleg",
        "",
    ),
    (
        EstimatorKind::Momo,
        "single_track_3d",
        "sampson",
        "type = \"tukey\"\nscale = 2.0",
        "gauss_newton",
        "",
    ),
    (
        EstimatorKind::Momo,
        "se3",
        "geo_line",
        "type = \"cauchy\"\nscale = 1.0",
        "levenberg_marquardt",
        "",
    ),
    (
        EstimatorKind::Momo,
        "se3",
        "angle_plane",
        "type = \"trivial\"",
        "levenberg_marquardt",
        // The trivial loss has no scale for the rotation prior: off (issue 15 rejects it).
        "min_matches = 0\nstandstill_arc_length = 0.0\nestimate_scale = false\n\
         rotation_change_sigma = 0.0",
    ),
    (
        EstimatorKind::FivePoint,
        "se3",
        "angle_plane",
        "type = \"cauchy\"\nscale = 0.001",
        "levenberg_marquardt",
        "",
    ),
    (
        EstimatorKind::FivePointRefined,
        "se3",
        "angle_plane",
        "type = \"cauchy\"\nscale = 0.001",
        "levenberg_marquardt",
        "",
    ),
];

/// The configuration `i` of [`ESTIMATOR_CONFIGS`] (modulo its length).
pub fn estimator_config(i: u8) -> (EstimatorKind, Config) {
    let (kind, model, metric, loss, solver, odometry) =
        ESTIMATOR_CONFIGS[usize::from(i) % ESTIMATOR_CONFIGS.len()];
    let toml = format!(
        "[model]\ntype = \"{model}\"\n[metric]\ntype = \"{metric}\"\n[loss]\n{loss}\n\
         [solver]\ntype = \"{solver}\"\n[odometry]\n{odometry}\n"
    );
    match Config::from_toml_str(&toml, "fuzz.toml") {
        Ok(c) => (kind, c),
        Err(e) => panic!("the fuzz configurations are valid: {e}\n{toml}"),
    }
}

/// Checks an error message: `path:line: reason` or `path: reason`, with a non-empty reason.
fn check_error(e: &IoError, path: &str) {
    let text = e.to_string();
    let prefix = match e.line {
        Some(l) => {
            assert!(l >= 1, "line numbers are 1-based: {text}");
            format!("{path}:{l}: ")
        }
        None => format!("{path}: "),
    };
    assert!(text.starts_with(&prefix), "`{text}` starts with `{prefix}`");
    assert!(text.len() > prefix.len(), "empty reason: {text}");
    assert!(
        text.len() < 2000,
        "error messages stay short: {} bytes",
        text.len()
    );
}

fn assert_unit(v: &Vector3<f64>, what: &str) {
    assert!(
        v.iter().all(|x| x.is_finite()) && (v.norm() - 1.0).abs() < 1e-9,
        "{what} {v} is not a finite unit vector"
    );
}

/// `rig.json`: parse; an accepted rig must write and read back to the same rig.
pub fn rig_json(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match momo_io::read_rig_from_str(text, "rig.json") {
        Err(e) => check_error(&e, "rig.json"),
        Ok(rig) => {
            assert!(!rig.is_empty());
            for c in rig.cameras() {
                assert!(c.t_vehicle_camera.orthonormality_error() <= 1e-6);
            }
            let json = match momo_io::rig_to_json(&rig) {
                Ok(j) => j,
                Err(e) => panic!("an accepted rig can be written: {e}"),
            };
            match momo_io::read_rig_from_str(&json, "back.json") {
                Ok(back) => assert_eq!(back, rig, "rig round trip"),
                Err(e) => panic!("a written rig reads back: {e}\n{json}"),
            }
        }
    }
}

/// `matches.csv` with [`matches_rig`]: frame pairs come contiguously from 1, each with one list
/// per camera, every bearing a finite unit vector and every pixel finite.
pub fn matches_csv(data: &[u8]) {
    let rig = matches_rig();
    let reader = match MatchReader::new(data, &rig, "matches.csv") {
        Ok(r) => r,
        Err(e) => return check_error(&e, "matches.csv"),
    };
    let mut expect = 1;
    for item in reader.take(MAX_FUZZ_FRAMES) {
        match item {
            Err(e) => return check_error(&e, "matches.csv"),
            Ok((k, obs)) => {
                assert_eq!(k, expect, "contiguous frame pairs");
                expect += 1;
                assert_eq!(obs.per_camera.len(), rig.len());
                for o in obs.per_camera.iter().flatten() {
                    assert_unit(&o.f0, "f0");
                    assert_unit(&o.f1, "f1");
                    assert!(o.px0.iter().chain(o.px1.iter()).all(|v| v.is_finite()));
                }
            }
        }
    }
}

/// `odometry.csv`: `v[0]` is `None`, every arc length finite and within
/// ±[`momo_io::odometry::MAX_ARC_LENGTH`] (negative ones, reversing, since format version 5); the rows
/// (`read_odometry_rows_from`, what `momo run` holds) are exactly the dense reader's entries.
pub fn odometry_csv(data: &[u8]) {
    let rows = momo_io::read_odometry_rows_from(data, "odometry.csv");
    match momo_io::read_odometry_from(data, "odometry.csv") {
        Err(e) => {
            check_error(&e, "odometry.csv");
            assert_eq!(rows.err().map(|r| r.to_string()), Some(e.to_string()));
        }
        Ok(v) => {
            assert!(!v.is_empty() && v[0].is_none());
            assert!(v.len() <= momo_io::MAX_FRAME + 1);
            assert!(
                v.iter()
                    .flatten()
                    .all(|l| l.is_finite() && l.abs() <= momo_io::odometry::MAX_ARC_LENGTH)
            );
            let dense: Vec<(usize, f64)> = v
                .iter()
                .enumerate()
                .filter_map(|(k, l)| l.map(|l| (k, l)))
                .collect();
            assert_eq!(rows.ok(), Some(dense));
        }
    }
}

/// KITTI poses: finite, with rotations orthonormal within the tolerance.
pub fn kitti_poses(data: &[u8]) {
    match momo_io::read_poses_from(data, "poses.txt") {
        Err(e) => check_error(&e, "poses.txt"),
        Ok(poses) => {
            for p in poses {
                assert!(p.orthonormality_error() <= POSE_ORTHONORMAL_TOLERANCE);
                assert!(p.translation.iter().all(|v| v.is_finite()));
            }
        }
    }
}

/// An accepted configuration builds a driver (or says why it does not fit the rig), and its
/// commented TOML parses back.
fn check_config(parsed: Result<Config, momo_vo::ConfigError>, name: &str) {
    let config = match parsed {
        Err(e) => {
            let text = e.to_string();
            assert!(text.starts_with(name), "`{text}` names `{name}`");
            return;
        }
        Ok(c) => c,
    };
    let toml = config.to_commented_toml();
    if let Err(e) = Config::from_toml_str(&toml, "back.toml") {
        panic!("an accepted configuration prints as TOML that parses back: {e}\n{toml}");
    }
    let rig = estimator_rig(0);
    if let Ok(mut driver) = momo_vo::driver(EstimatorKind::Momo, &rig, config) {
        // One frame without matches: must hold a finite motion.
        let r = driver.process(&FrameObservations::new(rig.len()), Some(1.0));
        assert_motion(&r.motion);
    }
}

/// A configuration as TOML.
pub fn config_toml(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        check_config(Config::from_toml_str(text, "config.toml"), "config.toml");
    }
}

/// A configuration as JSON.
pub fn config_json(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        check_config(Config::from_json_str(text, "config.json"), "config.json");
    }
}

fn assert_motion(m: &Pose<f64>) {
    assert!(
        m.rotation
            .iter()
            .chain(m.translation.iter())
            .all(|v| v.is_finite()),
        "non-finite motion {m:?}"
    );
    let e = m.orthonormality_error();
    assert!(e < 1e-6, "rotation not orthonormal (error {e:e}): {m:?}");
}

/// The estimator's input: which rig and configuration, and a few frame pairs.
#[derive(Arbitrary, Debug)]
pub struct EstimatorInput {
    /// Index into [`estimator_rig`].
    pub rig: u8,
    /// Index into [`ESTIMATOR_CONFIGS`].
    pub config: u8,
    /// Give the driver one more (ignored) list than the rig has cameras.
    pub extra_list: bool,
    /// The frame pairs, in order.
    pub frames: Vec<FrameInput>,
}

/// One frame pair of an [`EstimatorInput`].
#[derive(Arbitrary, Debug)]
pub struct FrameInput {
    /// The odometry arc length, any `f64` (NaN, negative and infinite included).
    pub arc_length: Option<f64>,
    /// The matches.
    pub matches: Vec<MatchInput>,
    /// The match list is repeated `1 + repeat % 8` times (duplicated matches).
    pub repeat: u8,
}

/// One match of a [`FrameInput`].
#[derive(Arbitrary, Debug)]
pub enum MatchInput {
    /// A match as the reader makes it: pixels inside the image, bearings by the camera model,
    /// a flow of up to ±127 px.
    Pixels {
        /// Camera id (modulo the number of cameras).
        camera: u8,
        /// Pixel in frame k-1, as a fraction of the image (`u16::MAX` = far border).
        uv: (u16, u16),
        /// Flow to frame k in pixels.
        flow: (i8, i8),
    },
    /// Raw numbers that the reader would never produce: any bearings, NaN and infinity
    /// included.
    Raw {
        /// Camera id (modulo the number of cameras).
        camera: u8,
        /// Pixels.
        px: [f64; 4],
        /// Bearing in frame k-1.
        f0: [f64; 3],
        /// Bearing in frame k.
        f1: [f64; 3],
    },
}

/// Builds the driver's frame pair from a [`FrameInput`].
fn observations(rig: &Rig, frame: &FrameInput, lists: usize) -> FrameObservations {
    let mut obs = FrameObservations::new(lists);
    let n = rig.len();
    for m in frame.matches.iter().take(MAX_FUZZ_MATCHES) {
        match *m {
            MatchInput::Pixels { camera, uv, flow } => {
                let j = usize::from(camera) % n;
                let cam = rig.cameras()[j].model;
                let (w, h) = momo_core::CameraModel::size(&cam);
                let px0 = Vector2::new(
                    f64::from(uv.0) / f64::from(u16::MAX) * (w - 1.0),
                    f64::from(uv.1) / f64::from(u16::MAX) * (h - 1.0),
                );
                let px1 = px0 + Vector2::new(f64::from(flow.0), f64::from(flow.1));
                if let Some(o) = Observation::new(&cam, px0, px1) {
                    obs.per_camera[j].push(o);
                }
            }
            MatchInput::Raw { camera, px, f0, f1 } => {
                let j = usize::from(camera) % lists;
                obs.per_camera[j].push(Observation {
                    px0: Vector2::new(px[0], px[1]),
                    px1: Vector2::new(px[2], px[3]),
                    f0: Vector3::from(f0),
                    f1: Vector3::from(f1),
                });
            }
        }
    }
    let copies = 1 + usize::from(frame.repeat % 8);
    for list in &mut obs.per_camera {
        let original = list.clone();
        for _ in 1..copies {
            if list.len() + original.len() > MAX_FUZZ_MATCHES {
                break;
            }
            list.extend_from_slice(&original);
        }
    }
    obs
}

/// The estimator fed arbitrary matches through the public driver interface: every motion is
/// finite with an orthonormal rotation, the diagnostics count the distinct matches, and a frame with
/// fewer than `min_matches` matches is flagged.
pub fn estimator(input: &EstimatorInput) {
    let rig = estimator_rig(input.rig);
    let (kind, config) = estimator_config(input.config);
    let min_matches = config.odometry.min_matches;
    // `geo_line` needs pinhole cameras: on the fisheye rig the driver refuses (an error, as
    // documented), and there is nothing more to run.
    let Ok(mut driver): Result<Box<dyn MotionDriver>, _> = momo_vo::driver(kind, &rig, config)
    else {
        return;
    };
    let lists = rig.len() + usize::from(input.extra_list);
    for frame in input.frames.iter().take(6) {
        let obs = observations(&rig, frame, lists);
        let r = driver.process(&obs, frame.arc_length);
        assert_motion(&r.motion);
        let d = &r.diagnostics;
        // momo counts repeated matches (the same pixels in the same camera) once (issue 15);
        // the 5-point baselines count every match.
        let mut distinct = obs.clone();
        let repeated = momo_vo::trust::dedupe(&mut distinct);
        let expected = match kind {
            EstimatorKind::Momo => obs.len() - repeated,
            _ => obs.len(),
        };
        assert_eq!(d.matches, expected);
        if kind == EstimatorKind::Momo && obs.len() < min_matches.max(1) {
            // Too few matches; when some were repeated, `degenerate` (`repeated_matches`).
            if repeated == 0 {
                assert_eq!(d.status, FrameStatus::NoMatches);
            } else {
                assert!(
                    matches!(d.status, FrameStatus::NoMatches | FrameStatus::Degenerate),
                    "{:?}",
                    d.status
                );
            }
        }
    }
}

/// Largest image (pixels) that [`image_header`] decodes after reading its header (keeps
/// executions fast; the header is read for every input).
pub const MAX_FUZZ_PIXELS: u64 = 1 << 22;

/// Image bytes (PNG or JPEG, recognised by content): the header's size is read without decoding;
/// an image that decodes has exactly that size, so that the check against the rig's size made
/// before decoding (`momo match`, `momo vo`) cannot be bypassed. Errors name the image.
pub fn image_header(data: &[u8]) {
    let name = std::path::Path::new("image.png");
    match momo_match::image_size_from_bytes(data, name) {
        Err(e) => {
            let text = e.to_string();
            assert!(text.starts_with("image.png"), "`{text}` names the image");
        }
        Ok((w, h)) => {
            if u64::from(w) * u64::from(h) <= MAX_FUZZ_PIXELS
                && let Ok(img) = momo_match::decode_gray(data, name)
            {
                assert_eq!(
                    (img.width(), img.height()),
                    (w, h),
                    "the decoded size is the header's"
                );
            }
        }
    }
}

/// Combinations of an accepted grid that [`sweep_grid`] expands and checks (keeps executions
/// fast; the count is checked for every grid).
pub const MAX_FUZZ_COMBINATIONS: usize = 8;

/// A sweep grid (TOML, `momo sweep --grid`): errors name the file and stay short; an accepted
/// grid has at most `momo_sweep::MAX_COMBINATIONS` combinations, counted without expanding
/// them, and expands to exactly that many; each combination's configuration is valid (it
/// round-trips through TOML and builds a driver) or refused naming the combination.
pub fn sweep_grid(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let grid = match momo_sweep::Grid::from_toml_str(text, "grid.toml") {
        Err(e) => {
            let text = e.to_string();
            assert!(text.starts_with("grid.toml"), "`{text}` names the grid");
            assert!(text.len() < 2000, "short error: {} bytes", text.len());
            return;
        }
        Ok(g) => g,
    };
    let n = grid.combination_count();
    assert!(
        n <= momo_sweep::MAX_COMBINATIONS,
        "{n} combinations accepted"
    );
    if n <= 4 * MAX_FUZZ_COMBINATIONS {
        let all = grid.combinations();
        assert_eq!(all.len(), n, "counted as many as expanded");
        for c in all.iter().take(MAX_FUZZ_COMBINATIONS) {
            let label = c.label();
            match c.build_config() {
                Ok(config) => check_config(Ok(config), "combination"),
                Err(e) => assert!(!e.to_string().is_empty(), "{label}: an empty error"),
            }
        }
    }
}

/// A deterministic mutation of `data` (bit flips, interesting bytes and 32-bit integers,
/// insertions and deletions, repeated chunks, tokens of `dictionary`, splices with `other`),
/// for replaying the targets over a generated corpus without libFuzzer (`tests/corpus.rs`).
/// PNG chunks get their CRCs recomputed, so that mutations reach past the checksum.
pub fn mutate(data: &[u8], other: &[u8], dictionary: &[&[u8]], state: &mut u64) -> Vec<u8> {
    let mut next = || {
        // xorshift64*
        *state ^= *state >> 12;
        *state ^= *state << 25;
        *state ^= *state >> 27;
        state.wrapping_mul(0x2545_F491_4F6C_DD1D)
    };
    let mut out = data.to_vec();
    let rounds = 1 + next() % 4;
    for _ in 0..rounds {
        let len = out.len().max(1);
        let at = (next() % len as u64) as usize;
        match next() % 8 {
            0 if !out.is_empty() => {
                let i = at.min(out.len() - 1);
                out[i] ^= 1 << (next() % 8);
            }
            1 if !out.is_empty() => {
                let i = at.min(out.len() - 1);
                out[i] = [0u8, 0xff, 0x7f, 0x80, b'0', b'9', b'\n', b'"'][(next() % 8) as usize];
            }
            2 if out.len() >= 4 => {
                let i = at.min(out.len() - 4);
                let v: u32 = [0, 1, 0xffff_ffff, 0x7fff_ffff, 20_000, 65_536, 0x8000_0000]
                    [(next() % 7) as usize];
                out[i..i + 4].copy_from_slice(&v.to_be_bytes());
            }
            3 => {
                let b = (next() % 256) as u8;
                out.insert(at.min(out.len()), b);
            }
            4 if !out.is_empty() => {
                let i = at.min(out.len() - 1);
                let n = (1 + next() % 16) as usize;
                out.drain(i..(i + n).min(out.len()));
            }
            5 if !out.is_empty() => {
                let i = at.min(out.len() - 1);
                let n = (1 + next() % 64) as usize;
                let chunk: Vec<u8> = out[i..(i + n).min(out.len())].to_vec();
                let times = 1 + next() % 8;
                for _ in 0..times {
                    let j = (next() % (out.len() as u64 + 1)) as usize;
                    out.splice(j..j, chunk.iter().copied());
                }
            }
            6 if !dictionary.is_empty() => {
                let token = dictionary[(next() % dictionary.len() as u64) as usize];
                out.splice(at.min(out.len())..at.min(out.len()), token.iter().copied());
            }
            _ if !other.is_empty() => {
                let j = (next() % other.len() as u64) as usize;
                out.truncate(at.min(out.len()));
                out.extend_from_slice(&other[j..]);
            }
            _ => {}
        }
        if out.len() > 1 << 16 {
            out.truncate(1 << 16);
        }
    }
    fix_png_crcs(&mut out);
    out
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// Recomputes the CRC of every complete chunk of a PNG (signature, then length, type, data, CRC).
fn fix_png_crcs(data: &mut [u8]) {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if !data.starts_with(SIGNATURE) {
        return;
    }
    let mut i = SIGNATURE.len();
    while i + 12 <= data.len() {
        let len = u32::from_be_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]]) as usize;
        let Some(end) = (i + 8).checked_add(len).filter(|e| e + 4 <= data.len()) else {
            return;
        };
        let crc = crc32(&data[i + 4..end]);
        data[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        i = end + 4;
    }
}

/// The replay of every target over its seeds and a generated mutation corpus, without libFuzzer
/// (`cargo test -p momo-fuzz --lib`, part of `cargo test --workspace`).
#[cfg(test)]
#[path = "../tests/corpus.rs"]
mod corpus;
#[cfg(test)]
extern crate self as momo_fuzz;
