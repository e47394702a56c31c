//! Importing real KITTI matches into a `FORMAT.md` sequence.
//!
//! [`import_l1avgvo`] reads the sparse 4-view stereo matches that German Ros' "Coarse
//! L1-averaging stereo odometry" demo ships for KITTI odometry sequence 00 (repository
//! `l1avgvo`, BMVC 2013), with its calibration and the KITTI ground truth:
//!
//! ```text
//! DIR/
//!   calib.txt                 `f cu cv B`: focal length (px), principal point (px), baseline (m)
//!   poses*.txt                optional: KITTI ground truth of camera 0 (`poses.txt`, or one file
//!                             whose name starts with `poses` and ends in `.txt`)
//!   seq00_part1/              the frame pairs (any one sub-folder holding `0_to_1.txt`, or DIR)
//!     0_to_1.txt              one match per line:
//!     1_to_2.txt              u_left_prev v_left_prev u_right_prev v_right_prev
//!     ...                     u_left_cur v_left_cur u_right_cur v_right_cur score
//! ```
//!
//! - File `i_to_{i+1}.txt` becomes frame `k = i + 1` (frame pair `(k-1, k)`). Lines without
//!   exactly 9 whitespace-separated fields are skipped (the original data has 4 malformed
//!   lines); a 9-field line with a field that is not a finite number is an input error.
//! - The rig is a KITTI pinhole camera (`f, cu, cv` from `calib.txt`, 1241 x 376 pixels)
//!   mounted as in `FORMAT.md`'s example ([`kitti_mount`]: 1.0 m ahead of the motion centre,
//!   1.65 m up, looking forward). With [`KittiImport::stereo`] a second camera with the same
//!   rotation sits `B` metres to the right (vehicle `y = -B`); each 4-view match then gives one
//!   match of camera 0 (left) and one of camera 1 (right).
//! - With a ground-truth file the sequence has as many frames as it has poses (pairs beyond the
//!   last pose are ignored; KITTI 00's 301 poses give 301 frames, so `300_to_301.txt` is not
//!   used), `ground_truth` is set, and `arc_lengths` holds the arc length travelled by the
//!   vehicle's motion centre ([`vehicle_arc_length`]). Without it the sequence has one frame
//!   more than there are pair files and neither ground truth nor arc lengths.
//! - With [`KittiImport::cross_camera`] (and `stereo`) each chosen 4-view match also gives two
//!   cross-camera matches, left(k-1)-right(k) and right(k-1)-left(k)
//!   ([`FrameObservations::cross_camera`]), from which the odometry measures the arc length.
//! - Matches with a pixel outside the image (of either camera used) are dropped. Pixels are
//!   integers in the source and are kept as they are.
//! - [`KittiImport::matches_per_frame`] sub-samples each frame pair to at most `N` matches
//!   *per camera*, spread over the image ([`select_spread`]): the left image at frame `k-1` is
//!   cut into a grid of about `N` cells, each cell gives at most one match per round, the cells
//!   are visited in a random order, and rounds repeat until `N` matches are chosen or none are
//!   left. The choice is random but deterministic: it depends only on
//!   [`KittiImport::seed`] and the frame number. The source's `score` column is not used.
//!
//! Only the file reading is specific to `l1avgvo`; [`kitti_rig`], [`vehicle_motion`] and
//! [`vehicle_arc_length`] serve any KITTI import.

use crate::error::{IoError, IoErrorKind};
use crate::text::{LineReader, parse_f64};
use momo_core::{
    Camera, CameraModel, CrossObservation, FrameObservations, Observation, Pinhole, Pose, Rig,
    RigCamera, sinc, so3_log,
};
use nalgebra::{Matrix3, Vector2, Vector3};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// Image width of the KITTI odometry cameras, pixels.
pub const KITTI_WIDTH: f64 = 1241.0;
/// Image height of the KITTI odometry cameras, pixels.
pub const KITTI_HEIGHT: f64 = 376.0;
/// The calibration file of an `l1avgvo` data folder: `f cu cv B`.
pub const CALIB_FILE: &str = "calib.txt";
/// The first frame-pair file, used to find the folder of frame pairs.
const FIRST_PAIR: &str = "0_to_1.txt";

/// Options of [`import_l1avgvo`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KittiImport {
    /// Two cameras (left = camera 0, right = camera 1) instead of the left camera only.
    pub stereo: bool,
    /// Keep at most this many matches per frame pair and camera, spread over the image;
    /// `None` keeps all of them.
    pub matches_per_frame: Option<usize>,
    /// Seed of the (deterministic) sub-sampling.
    pub seed: u64,
    /// With [`stereo`](Self::stereo): also write each chosen 4-view match's two cross-camera
    /// matches (`FORMAT.md` version 5, column `camera_to`): left at `k-1` with right at `k`
    /// (camera 0 to 1) and right at `k-1` with left at `k` (camera 1 to 0). They carry the
    /// metric scale (the baseline) when no odometry is given.
    pub cross_camera: bool,
}

/// The calibration of `calib.txt`: `f cu cv B`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KittiCalib {
    /// Focal length, pixels (`fx = fy`).
    pub focal: f64,
    /// Principal point u, pixels.
    pub cu: f64,
    /// Principal point v, pixels.
    pub cv: f64,
    /// Stereo baseline, metres (the right camera is this far to the right of the left one).
    pub baseline: f64,
}

impl KittiCalib {
    /// The pinhole model of both (rectified) cameras, 1241 x 376 pixels.
    pub fn camera(&self) -> Camera {
        Camera::Pinhole(Pinhole {
            fx: self.focal,
            fy: self.focal,
            cx: self.cu,
            cy: self.cv,
            width: KITTI_WIDTH,
            height: KITTI_HEIGHT,
        })
    }
}

/// Reads `calib.txt`: four numbers `f cu cv B` separated by whitespace (any line breaks).
/// The focal length must be positive; the baseline must be positive for a stereo rig (checked by
/// [`kitti_rig`]).
pub fn read_kitti_calib(path: &Path) -> Result<KittiCalib, IoError> {
    let text = std::fs::read_to_string(path).map_err(|e| IoError::io(path, e))?;
    let fields: Vec<&str> = text.split_whitespace().collect();
    if fields.len() != 4 {
        return Err(IoError::file(
            path,
            IoErrorKind::FieldCount {
                expected: 4,
                found: fields.len(),
            },
        ));
    }
    let mut v = [0.0; 4];
    for (i, (name, text)) in ["f", "cu", "cv", "B"].iter().zip(&fields).enumerate() {
        v[i] = parse_f64(name, text).map_err(|k| IoError::file(path, k))?;
    }
    if v[0] <= 0.0 {
        return Err(IoError::file(
            path,
            IoErrorKind::InvalidCamera {
                camera: 0,
                reason: format!("focal length must be positive, found {}", v[0]),
            },
        ));
    }
    Ok(KittiCalib {
        focal: v[0],
        cu: v[1],
        cv: v[2],
        baseline: v[3],
    })
}

/// `FORMAT.md`'s example mount of a forward-looking camera: 1.0 m ahead of the motion centre,
/// 1.65 m up, camera z = vehicle x, camera x = vehicle -y, camera y = vehicle -z:
/// `T_vehicle_camera = [[0,0,1,1.0],[-1,0,0,0],[0,-1,0,1.65],[0,0,0,1]]`.
pub fn kitti_mount() -> Pose<f64> {
    Pose::new(
        Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
        Vector3::new(1.0, 0.0, 1.65),
    )
}

/// The KITTI rig: camera 0 (left) at [`kitti_mount`]; with `stereo` camera 1 (right) with the
/// same rotation, `calib.baseline` metres to the right (vehicle `y = -B`). Fails on a
/// non-positive baseline for a stereo rig.
pub fn kitti_rig(calib: &KittiCalib, stereo: bool) -> Result<Rig, IoErrorKind> {
    let model = calib.camera();
    let left = kitti_mount();
    let mut cameras = vec![RigCamera {
        name: "cam0".into(),
        model,
        t_vehicle_camera: left,
    }];
    if stereo {
        if !(calib.baseline > 0.0) {
            return Err(IoErrorKind::InvalidCamera {
                camera: 1,
                reason: format!("stereo baseline must be positive, found {}", calib.baseline),
            });
        }
        let right = Pose::new(
            left.rotation,
            left.translation + Vector3::new(0.0, -calib.baseline, 0.0),
        );
        cameras.push(RigCamera {
            name: "cam1".into(),
            model,
            t_vehicle_camera: right,
        });
    }
    Rig::new(cameras).map_err(IoErrorKind::Rig)
}

/// The vehicle motion between two camera poses of a ground truth (`T_cam0(0)_cam0(k)`):
/// `M = P · (C_prev⁻¹ C_cur) · P⁻¹` with `P = T_vehicle_camera` of the camera, the inverse of
/// `C = P⁻¹ M P` (`DESIGN.md`). `M` is the pose of the vehicle at the later frame in the vehicle
/// frame of the earlier one.
pub fn vehicle_motion(
    camera_prev: &Pose<f64>,
    camera_cur: &Pose<f64>,
    t_vehicle_camera: &Pose<f64>,
) -> Pose<f64> {
    let c = camera_prev.inverse().compose(camera_cur);
    t_vehicle_camera
        .compose(&c)
        .compose(&t_vehicle_camera.inverse())
}

/// The arc length travelled by the motion centre during the vehicle motion `m`, assuming it
/// moves on a circular arc (constant curvature, the single-track model): with chord `|t(M)|`
/// and rotation angle `γ` of `M`, the arc of radius `r` has chord `2 r sin(γ/2)` and length
/// `r γ`, hence `l = |t(M)| / sinc(γ/2)` with `sinc(x) = sin(x)/x` (`l = |t|` for straight
/// motion).
pub fn vehicle_arc_length(m: &Pose<f64>) -> f64 {
    let gamma = so3_log(&m.rotation).norm();
    m.translation.norm() / sinc(0.5 * gamma)
}

/// One line of an `l1avgvo` pair file: a scene point in the left and right images of frames
/// `k-1` (`prev`) and `k` (`cur`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Match4 {
    left_prev: Vector2<f64>,
    right_prev: Vector2<f64>,
    left_cur: Vector2<f64>,
    right_cur: Vector2<f64>,
}

/// Reads a pair file, skipping lines without exactly 9 fields (the `score` is read and
/// checked but not kept).
fn read_pair_file(path: &Path) -> Result<Vec<Match4>, IoError> {
    const NAMES: [&str; 9] = [
        "u_left_prev",
        "v_left_prev",
        "u_right_prev",
        "v_right_prev",
        "u_left_cur",
        "v_left_cur",
        "u_right_cur",
        "v_right_cur",
        "score",
    ];
    let file = File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut lines = LineReader::new(BufReader::new(file));
    let mut out = Vec::new();
    loop {
        let line_no = lines.line() + 1;
        let line = match lines.next_line() {
            Ok(Some(l)) => l,
            Ok(None) => break,
            Err(k) => return Err(IoError::at(path, line_no, k)),
        };
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.len() != NAMES.len() {
            continue;
        }
        let mut v = [0.0; 9];
        for (i, (name, text)) in NAMES.iter().zip(&fields).enumerate() {
            v[i] = parse_f64(name, text).map_err(|k| IoError::at(path, line_no, k))?;
        }
        out.push(Match4 {
            left_prev: Vector2::new(v[0], v[1]),
            right_prev: Vector2::new(v[2], v[3]),
            left_cur: Vector2::new(v[4], v[5]),
            right_cur: Vector2::new(v[6], v[7]),
        });
    }
    Ok(out)
}

/// A small deterministic generator (SplitMix64): the sub-sampling must not depend on a
/// random-number crate's version.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n > 0`), by the multiply-shift method.
    fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u64()) * n as u128) >> 64) as usize
    }

    fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i + 1);
            v.swap(i, j);
        }
    }
}

/// Chooses at most `n` of `points` (pixels in a `width x height` image), spread over the image,
/// and returns their indices in increasing order. The image is cut into a grid of about `n`
/// cells with roughly square cells; in each round every non-empty cell, visited in a random
/// order, gives one of its points not chosen yet (at random); rounds repeat until `n` points are
/// chosen or none are left. So if there are at least `n` non-empty cells, no cell gives two
/// points. The result depends only on the inputs and `seed`.
pub fn select_spread(
    points: &[Vector2<f64>],
    n: usize,
    width: f64,
    height: f64,
    seed: u64,
) -> Vec<usize> {
    if n >= points.len() {
        return (0..points.len()).collect();
    }
    if n == 0 {
        return Vec::new();
    }
    let cols = ((n as f64 * width / height).sqrt().round() as usize).max(1);
    let rows = n.div_ceil(cols).max(1);
    let cell = |x: f64, size: f64, count: usize| {
        let c = ((x + 0.5) / size * count as f64).floor();
        if c.is_finite() {
            (c.max(0.0) as usize).min(count - 1)
        } else {
            0
        }
    };
    let mut buckets: Vec<Vec<usize>> = vec![Vec::new(); cols * rows];
    for (i, p) in points.iter().enumerate() {
        buckets[cell(p.y, height, rows) * cols + cell(p.x, width, cols)].push(i);
    }
    let mut rng = SplitMix64(seed);
    buckets.retain(|b| !b.is_empty());
    for b in &mut buckets {
        rng.shuffle(b);
    }
    let mut chosen = Vec::with_capacity(n);
    let mut order: Vec<usize> = (0..buckets.len()).collect();
    let mut round = 0;
    while chosen.len() < n {
        order.retain(|&c| buckets[c].len() > round);
        if order.is_empty() {
            break;
        }
        rng.shuffle(&mut order);
        for &c in &order {
            if chosen.len() == n {
                break;
            }
            chosen.push(buckets[c][round]);
        }
        round += 1;
    }
    chosen.sort_unstable();
    chosen
}

/// The folder holding the frame pairs: `dir` itself if it has `0_to_1.txt`, else its one
/// sub-folder that has.
fn pair_folder(dir: &Path) -> Result<PathBuf, IoError> {
    if dir.join(FIRST_PAIR).is_file() {
        return Ok(dir.to_path_buf());
    }
    let entries = std::fs::read_dir(dir).map_err(|e| IoError::io(dir, e))?;
    let mut found = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| IoError::io(dir, e))?.path();
        if path.join(FIRST_PAIR).is_file() {
            found.push(path);
        }
    }
    found.sort();
    match found.len() {
        0 => Err(IoError::file(dir.join(FIRST_PAIR), IoErrorKind::NotFound)),
        1 => Ok(found.swap_remove(0)),
        _ => Err(IoError::file(
            dir,
            IoErrorKind::Io(std::io::Error::other(format!(
                "several folders hold frame pairs ({}); pass one of them",
                found
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
        )),
    }
}

/// The number of pair files `0_to_1.txt, 1_to_2.txt, ...` in `folder`; a gap (a file beyond a
/// missing one) is an error naming the missing file.
fn count_pairs(folder: &Path) -> Result<usize, IoError> {
    let entries = std::fs::read_dir(folder).map_err(|e| IoError::io(folder, e))?;
    let mut firsts = Vec::new();
    for entry in entries {
        let name = entry.map_err(|e| IoError::io(folder, e))?.file_name();
        let Some(stem) = name.to_str().and_then(|n| n.strip_suffix(".txt")) else {
            continue;
        };
        let Some((a, b)) = stem.split_once("_to_") else {
            continue;
        };
        if let (Ok(a), Ok(b)) = (a.parse::<usize>(), b.parse::<usize>()) {
            if b == a + 1 {
                firsts.push(a);
            }
        }
    }
    firsts.sort_unstable();
    firsts.dedup();
    for (expected, &i) in firsts.iter().enumerate() {
        if i != expected {
            return Err(IoError::file(
                folder.join(pair_name(expected)),
                IoErrorKind::NotFound,
            ));
        }
    }
    Ok(firsts.len())
}

fn pair_name(i: usize) -> String {
    format!("{i}_to_{}.txt", i + 1)
}

/// The ground-truth file of `dir`: `poses.txt`, else the one `poses*.txt`; `None` if there is
/// none.
fn poses_file(dir: &Path) -> Result<Option<PathBuf>, IoError> {
    let plain = dir.join("poses.txt");
    if plain.is_file() {
        return Ok(Some(plain));
    }
    let entries = std::fs::read_dir(dir).map_err(|e| IoError::io(dir, e))?;
    let mut found = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| IoError::io(dir, e))?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.starts_with("poses") && name.ends_with(".txt") && path.is_file() {
            found.push(path);
        }
    }
    found.sort();
    match found.len() {
        0 => Ok(None),
        1 => Ok(found.pop()),
        _ => Err(IoError::file(
            dir,
            IoErrorKind::Io(std::io::Error::other(
                "several poses*.txt files; keep one (or name it poses.txt)",
            )),
        )),
    }
}

/// Seed of frame `k`'s sub-sampling, so that a frame's choice does not depend on the others.
fn frame_seed(seed: u64, k: usize) -> u64 {
    SplitMix64(seed ^ (k as u64).wrapping_mul(0xD1B5_4A32_D192_ED03)).next_u64()
}

/// Sub-samples frame pair `k`'s matches to at most `n` per camera, spread over each camera's
/// image by [`select_spread`] on the pixels in frame `k-1`, deterministically from `seed` and
/// `k` (cameras beyond `rig` keep their matches). Camera 0 is chosen exactly as
/// [`import_l1avgvo`] chooses with [`KittiImport::matches_per_frame`] and the same seed, so
/// sub-sampling a mono import of all matches gives the matches of an import with `n`.
pub fn subsample_frame(
    frame: &FrameObservations,
    rig: &Rig,
    n: usize,
    seed: u64,
    k: usize,
) -> FrameObservations {
    let mut out = frame.clone();
    for (j, (list, cam)) in out.per_camera.iter_mut().zip(rig.cameras()).enumerate() {
        let (width, height) = cam.model.size();
        let px: Vec<Vector2<f64>> = list.iter().map(|o| o.px0).collect();
        let camera_seed = seed.wrapping_add((j as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let chosen = select_spread(&px, n, width, height, frame_seed(camera_seed, k));
        *list = chosen.into_iter().map(|i| list[i]).collect();
    }
    out
}

/// Imports an `l1avgvo` data folder (see the [module docs](self)) as a sequence: rig,
/// matches (sub-sampled per [`KittiImport`]), and, if the folder has a ground-truth file, the
/// ground truth (camera 0) and the arc lengths of the motion centre. Errors name the file (and
/// line) at fault.
pub fn import_l1avgvo(dir: &Path, options: &KittiImport) -> Result<crate::Sequence, IoError> {
    let calib_path = dir.join(CALIB_FILE);
    let calib = read_kitti_calib(&calib_path)?;
    let rig = kitti_rig(&calib, options.stereo).map_err(|k| IoError::file(&calib_path, k))?;
    let folder = pair_folder(dir)?;
    let pairs = count_pairs(&folder)?;
    let ground_truth = match poses_file(dir)? {
        Some(p) => {
            let poses = crate::read_poses(&p)?;
            if poses.is_empty() {
                return Err(IoError::file(
                    &p,
                    IoErrorKind::Io(std::io::Error::other("no poses")),
                ));
            }
            Some(poses)
        }
        None => None,
    };
    let num_frames = match &ground_truth {
        Some(gt) => gt.len().min(pairs + 1),
        None => pairs + 1,
    };
    let camera = calib.camera();
    let cams = rig.len();
    let mut frames = vec![FrameObservations::new(cams)];
    for k in 1..num_frames {
        let path = folder.join(pair_name(k - 1));
        let all = read_pair_file(&path)?;
        let inside = |p: &Vector2<f64>| camera.contains(p, 0.0);
        let usable: Vec<Match4> = all
            .into_iter()
            .filter(|m| {
                inside(&m.left_prev)
                    && inside(&m.left_cur)
                    && (!options.stereo || (inside(&m.right_prev) && inside(&m.right_cur)))
            })
            .collect();
        let chosen: Vec<usize> = match options.matches_per_frame {
            Some(n) => {
                let px: Vec<Vector2<f64>> = usable.iter().map(|m| m.left_prev).collect();
                select_spread(
                    &px,
                    n,
                    KITTI_WIDTH,
                    KITTI_HEIGHT,
                    frame_seed(options.seed, k),
                )
            }
            None => (0..usable.len()).collect(),
        };
        let mut obs = FrameObservations::new(cams);
        for &i in &chosen {
            let m = &usable[i];
            let (Some(left), right) = (
                Observation::new(&camera, m.left_prev, m.left_cur),
                Observation::new(&camera, m.right_prev, m.right_cur),
            ) else {
                continue;
            };
            if options.stereo {
                let Some(right) = right else { continue };
                obs.per_camera[1].push(right);
                if options.cross_camera {
                    let cross = |camera, camera_to, f0, f1, px0, px1| CrossObservation {
                        camera,
                        camera_to,
                        obs: Observation { px0, px1, f0, f1 },
                    };
                    obs.cross_camera
                        .push(cross(0, 1, left.f0, right.f1, left.px0, right.px1));
                    obs.cross_camera
                        .push(cross(1, 0, right.f0, left.f1, right.px0, left.px1));
                }
            }
            obs.per_camera[0].push(left);
        }
        frames.push(obs);
    }
    let (ground_truth, arc_lengths) = match ground_truth {
        Some(mut gt) => {
            gt.truncate(num_frames);
            let mount = kitti_mount();
            let mut arcs = vec![None];
            arcs.extend(
                gt.windows(2)
                    .map(|w| Some(vehicle_arc_length(&vehicle_motion(&w[0], &w[1], &mount)))),
            );
            (Some(gt), Some(arcs))
        }
        None => (None, None),
    };
    Ok(crate::Sequence {
        rig,
        frames,
        arc_lengths,
        ground_truth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use momo_core::{essential, so3_exp};
    use std::fmt::Write as _;

    /// The shared data folder, or `None` (tests then print SKIPPED and pass).
    fn data_dir() -> Option<PathBuf> {
        let base = std::env::var_os("MOMO_DATA").map_or_else(
            || Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
            PathBuf::from,
        );
        let dir = base.join("kitti00_stereo_matches_l1avgvo");
        dir.join(CALIB_FILE).is_file().then_some(dir)
    }

    macro_rules! data_or_skip {
        () => {
            match data_dir() {
                Some(d) => d,
                None => {
                    eprintln!(
                        "SKIPPED: KITTI 00 l1avgvo matches not found (set MOMO_DATA to the folder holding kitti00_stereo_matches_l1avgvo)"
                    );
                    return;
                }
            }
        };
    }

    /// `|f1ᵀ E f0| / |E f0|` (the AnglePlane residual) of every match under camera motion `c`.
    fn epipolar_residuals(obs: &[Observation], c: &Pose<f64>) -> Vec<f64> {
        let e = essential(c);
        obs.iter()
            .map(|o| {
                let ef0 = e * o.f0;
                (o.f1.dot(&ef0) / ef0.norm()).abs()
            })
            .collect()
    }

    fn median(mut v: Vec<f64>) -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    }

    #[test]
    fn real_kitti00_mono_import() {
        let dir = data_or_skip!();
        let n = 150;
        let all = import_l1avgvo(&dir, &KittiImport::default()).expect("import all");
        let seq = import_l1avgvo(
            &dir,
            &KittiImport {
                stereo: false,
                matches_per_frame: Some(n),
                seed: 7,
                cross_camera: false,
            },
        )
        .expect("import");
        assert_eq!(seq.frames.len(), 301);
        assert_eq!(seq.num_frames(), 301);
        assert_eq!(seq.rig.len(), 1);
        let gt = seq.ground_truth.as_ref().expect("ground truth");
        assert_eq!(gt.len(), 301);
        let arcs = seq.arc_lengths.as_ref().expect("arc lengths");
        assert_eq!(arcs.len(), 301);
        assert!(seq.frames[0].is_empty());
        let mut medians = Vec::new();
        for k in 1..301 {
            let available = all.frames[k].per_camera[0].len();
            assert!(available > n, "frame {k}: only {available} matches");
            assert_eq!(seq.frames[k].per_camera[0].len(), n.min(available));
            // Arc length of the motion centre vs. the camera's displacement.
            let c = gt[k - 1].inverse().compose(&gt[k]);
            let d = c.translation.norm();
            let l = arcs[k].expect("arc length");
            assert!(
                (l - d).abs() < 0.1 * d,
                "frame {k}: arc {l} vs displacement {d}"
            );
            medians.push(median(epipolar_residuals(&seq.frames[k].per_camera[0], &c)));
        }
        let overall = median(medians.clone());
        let worst = medians.iter().copied().fold(0.0, f64::max);
        eprintln!("median epipolar residual {overall:.2e}, worst frame median {worst:.2e}");
        assert!(overall < 0.003, "{overall}");
        let good = medians.iter().filter(|&&m| m < 0.003).count();
        assert!(
            good * 10 >= 9 * medians.len(),
            "{good} of {} frames",
            medians.len()
        );
        // Without sub-sampling, all well-formed lines of the 300 pair files used.
        assert!(all.num_matches() > 600_000, "{}", all.num_matches());
    }

    #[test]
    fn real_kitti00_stereo_import() {
        let dir = data_or_skip!();
        let n = 200;
        let options = KittiImport {
            stereo: true,
            matches_per_frame: Some(n),
            seed: 1,
            cross_camera: true,
        };
        let seq = import_l1avgvo(&dir, &options).expect("import");
        assert_eq!(seq.frames.len(), 301);
        assert_eq!(seq.rig.len(), 2);
        let right = &seq.rig.cameras()[1].t_vehicle_camera;
        assert!((right.translation - Vector3::new(1.0, -0.5372, 1.65)).norm() < 1e-12);
        let gt = seq.ground_truth.as_ref().expect("ground truth");
        let mut res = Vec::new();
        let (mut cross, mut cross_swapped) = (Vec::new(), Vec::new());
        for k in 1..301 {
            let f = &seq.frames[k];
            assert_eq!(f.per_camera[0].len(), n, "frame {k}");
            assert_eq!(f.per_camera[1].len(), n, "frame {k}");
            let m = vehicle_motion(&gt[k - 1], &gt[k], &kitti_mount());
            for (j, cam) in seq.rig.cameras().iter().enumerate() {
                let c = momo_core::camera_motion(&m, &cam.t_vehicle_camera);
                res.extend(epipolar_residuals(&f.per_camera[j], &c));
            }
            // Two cross-camera matches per 4-view match, under C_ij = P_i⁻¹ M P_j; with the
            // cameras swapped (the wrong convention) the residuals are much larger.
            assert_eq!(f.cross_camera.len(), 2 * n, "frame {k}");
            let cams = seq.rig.cameras();
            for x in &f.cross_camera {
                let (pi, pj) = (
                    &cams[x.camera].t_vehicle_camera,
                    &cams[x.camera_to].t_vehicle_camera,
                );
                let c = momo_core::cross_camera_motion(&m, pi, pj);
                cross.extend(epipolar_residuals(&[x.obs], &c));
                let swapped = momo_core::cross_camera_motion(&m, pj, pi);
                cross_swapped.extend(epipolar_residuals(&[x.obs], &swapped));
            }
        }
        let med = median(res);
        eprintln!("stereo: median epipolar residual {med:.2e}");
        assert!(med < 0.003, "{med}");
        let (cross, swapped) = (median(cross), median(cross_swapped));
        eprintln!("cross-camera: median epipolar residual {cross:.2e} (swapped {swapped:.2e})");
        assert!(cross < 0.003, "{cross}");
        assert!(swapped > 3.0 * cross, "{swapped} vs {cross}");
        // Deterministic for a seed.
        let again = import_l1avgvo(&dir, &options).expect("import");
        assert_eq!(again, seq);
    }

    /// A tiny synthetic data folder in the l1avgvo layout, for tests without the real data.
    fn synthetic(dir: &Path, with_poses: bool) {
        std::fs::write(dir.join(CALIB_FILE), "718.856 607.1928 185.2157 0.5372\n").unwrap();
        let pairs = dir.join("seq_x");
        std::fs::create_dir(&pairs).unwrap();
        for i in 0..3 {
            let mut text = String::new();
            for r in 0..40 {
                let u = 10 + 30 * r;
                let v = 20 + 8 * r;
                writeln!(
                    text,
                    "{u} {v} {} {v} {} {} {} {} {}",
                    u - 5,
                    u + 1,
                    v + 1,
                    u - 4,
                    v + 1,
                    r
                )
                .unwrap();
            }
            text.push_str("1 2 3\n");
            text.push_str("5000 10 1 1 1 1 1 1 9\n"); // outside the image: dropped
            std::fs::write(pairs.join(pair_name(i)), text).unwrap();
        }
        if with_poses {
            let mut text = String::new();
            for k in 0..3 {
                writeln!(text, "1 0 0 0 0 1 0 0 0 0 1 {}", 0.8 * k as f64).unwrap();
            }
            std::fs::write(dir.join("poses_00.txt"), text).unwrap();
        }
    }

    #[test]
    fn synthetic_folder_round_trip() {
        let tmp = tempfile::tempdir().unwrap();
        synthetic(tmp.path(), true);
        let seq = import_l1avgvo(tmp.path(), &KittiImport::default()).unwrap();
        // 3 poses -> 3 frames, the third pair file is not used.
        assert_eq!(seq.frames.len(), 3);
        assert_eq!(seq.frames[1].per_camera[0].len(), 40);
        assert_eq!(seq.frames[1].per_camera[0][0].px0, Vector2::new(10.0, 20.0));
        assert_eq!(seq.frames[1].per_camera[0][0].px1, Vector2::new(11.0, 21.0));
        let arcs = seq.arc_lengths.clone().unwrap();
        assert_eq!(arcs[0], None);
        assert!((arcs[1].unwrap() - 0.8).abs() < 1e-12);
        let out = tempfile::tempdir().unwrap();
        crate::write_sequence(out.path(), &seq).unwrap();
        assert_eq!(crate::read_sequence(out.path()).unwrap(), seq);

        let stereo = import_l1avgvo(
            tmp.path(),
            &KittiImport {
                stereo: true,
                matches_per_frame: Some(10),
                seed: 3,
                cross_camera: false,
            },
        )
        .unwrap();
        assert_eq!(stereo.frames[2].per_camera[0].len(), 10);
        assert_eq!(stereo.frames[2].per_camera[1].len(), 10);
        let l = &stereo.frames[2].per_camera[0][0];
        let r = &stereo.frames[2].per_camera[1][0];
        assert_eq!(l.px0.x - 5.0, r.px0.x);

        // Without ground truth: one frame per pair file, plus frame 0.
        let bare = tempfile::tempdir().unwrap();
        synthetic(bare.path(), false);
        let seq = import_l1avgvo(bare.path(), &KittiImport::default()).unwrap();
        assert_eq!(seq.frames.len(), 4);
        assert!(seq.ground_truth.is_none() && seq.arc_lengths.is_none());
    }

    #[test]
    fn errors_name_the_file() {
        let tmp = tempfile::tempdir().unwrap();
        let err = import_l1avgvo(tmp.path(), &KittiImport::default()).unwrap_err();
        assert!(
            err.to_string().ends_with("calib.txt: file not found"),
            "{err}"
        );
        synthetic(tmp.path(), true);
        std::fs::remove_file(tmp.path().join("seq_x").join(pair_name(1))).unwrap();
        let err = import_l1avgvo(tmp.path(), &KittiImport::default()).unwrap_err();
        assert!(
            err.to_string().ends_with("1_to_2.txt: file not found"),
            "{err}"
        );
        std::fs::write(
            tmp.path().join("seq_x").join(pair_name(1)),
            "1 2 3 4 5 6 7 x 9\n",
        )
        .unwrap();
        let err = import_l1avgvo(tmp.path(), &KittiImport::default()).unwrap_err();
        assert!(
            err.to_string().contains("1_to_2.txt:1: `v_right_cur`"),
            "{err}"
        );
        std::fs::write(tmp.path().join(CALIB_FILE), "718 607 185\n").unwrap();
        let err = import_l1avgvo(tmp.path(), &KittiImport::default()).unwrap_err();
        assert!(
            err.to_string().contains("expected 4 fields, found 3"),
            "{err}"
        );
        std::fs::write(tmp.path().join(CALIB_FILE), "718 607 185 0\n").unwrap();
        let options = KittiImport {
            stereo: true,
            ..KittiImport::default()
        };
        let err = import_l1avgvo(tmp.path(), &options).unwrap_err();
        assert!(
            err.to_string().contains("baseline must be positive"),
            "{err}"
        );
    }

    #[test]
    fn selection_is_spread_and_deterministic() {
        // 2000 points, 1500 of them crowded into one corner.
        let mut rng = SplitMix64(5);
        let mut pts = Vec::new();
        for i in 0..2000 {
            let (w, h) = if i < 1500 {
                (100.0, 50.0)
            } else {
                (1241.0, 376.0)
            };
            let u = (rng.next_u64() % 1_000_000) as f64 / 1e6 * w;
            let v = (rng.next_u64() % 1_000_000) as f64 / 1e6 * h;
            pts.push(Vector2::new(u, v));
        }
        let sel = select_spread(&pts, 100, 1241.0, 376.0, 9);
        assert_eq!(sel.len(), 100);
        assert!(sel.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(sel, select_spread(&pts, 100, 1241.0, 376.0, 9));
        assert_ne!(sel, select_spread(&pts, 100, 1241.0, 376.0, 10));
        let in_corner = sel.iter().filter(|&&i| i < 1500).count();
        // The corner covers about 1-2 of ~108 grid cells: a handful of points, not 75 %.
        assert!(in_corner < 10, "{in_corner}");
        assert_eq!(select_spread(&pts, 5000, 1241.0, 376.0, 9).len(), 2000);
        assert!(select_spread(&pts, 0, 1241.0, 376.0, 9).is_empty());
    }

    #[test]
    fn arc_length_of_a_circle() {
        // 1 m ahead of the motion centre: the camera's chord differs, the arc does not.
        let (gamma, l): (f64, f64) = (0.2, 5.0);
        let m = Pose::new(
            so3_exp(&Vector3::new(0.0, 0.0, gamma)),
            Vector3::new(
                l * gamma.sin() / gamma,
                l * (1.0 - gamma.cos()) / gamma,
                0.0,
            ),
        );
        assert!((vehicle_arc_length(&m) - l).abs() < 1e-12);
        let p = kitti_mount();
        let c = momo_core::camera_motion(&m, &p);
        let back = vehicle_motion(&Pose::identity(), &c, &p);
        assert!((back.translation - m.translation).norm() < 1e-12);
        assert!((back.rotation - m.rotation).amax() < 1e-12);
    }
}
