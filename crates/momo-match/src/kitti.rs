//! Rigs and arc lengths for KITTI image sequences (the folders of the KITTI odometry benchmark:
//! `image_0/`, `image_1/`, `calib.txt` with `P0: ...` / `P1: ...` projection matrices, and the
//! ground truth `poses.txt`).
//!
//! - [`read_kitti_projections`] reads the `P0`/`P1` lines (12 numbers each, row-major 3x4):
//!   `fx = P[0]`, `cx = P[2]`, `fy = P[5]`, `cy = P[6]`; the stereo baseline is
//!   `-P1[3] / P1[0]` metres (the right camera sits that far to the right of the left one).
//! - [`kitti_image_rig`] mounts the left camera as [`momo_io::kitti::kitti_mount`] (1.0 m ahead
//!   of the motion centre, 1.65 m up, looking forward) with the image size of the sequence
//!   (KITTI 04-10 are 1226x370, 00-02 1241x376), and the right camera beside it.
//! - [`arc_lengths_from_poses`] gives `odometry.csv` arc lengths from the camera-0 ground truth
//!   ([`momo_io::kitti::vehicle_motion`], [`momo_io::kitti::vehicle_arc_length`]).

use momo_core::{Camera, Pinhole, Pose, Rig, RigCamera};
use momo_io::kitti::{kitti_mount, vehicle_arc_length, vehicle_motion};
use momo_io::{IoError, IoErrorKind};
use nalgebra::Vector3;
use std::path::Path;

/// The pinhole intrinsics of the left camera and the stereo baseline of a KITTI `calib.txt`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KittiProjections {
    /// Focal length in u, pixels.
    pub fx: f64,
    /// Focal length in v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
    /// Stereo baseline from `P1`, metres (`None` without a `P1` line).
    pub baseline: Option<f64>,
}

/// Reads the `P0:` and (optional) `P1:` lines of a KITTI `calib.txt`; other lines (`P2`, `P3`,
/// `Tr`) are ignored. Errors name the file and line.
pub fn read_kitti_projections(path: &Path) -> Result<KittiProjections, IoError> {
    let text = std::fs::read_to_string(path).map_err(|e| IoError::io(path, e))?;
    let mut p0: Option<[f64; 12]> = None;
    let mut p1: Option<[f64; 12]> = None;
    for (no, line) in text.lines().enumerate() {
        let line_no = no + 1;
        let Some((key, rest)) = line.split_once(':') else {
            if line.trim().is_empty() {
                continue;
            }
            return Err(IoError::at(
                path,
                line_no,
                IoErrorKind::InvalidData("expected `NAME: 12 numbers`".into()),
            ));
        };
        let slot = match key.trim() {
            "P0" => &mut p0,
            "P1" => &mut p1,
            _ => continue,
        };
        let fields: Vec<&str> = rest.split_whitespace().collect();
        if fields.len() != 12 {
            return Err(IoError::at(
                path,
                line_no,
                IoErrorKind::FieldCount {
                    expected: 12,
                    found: fields.len(),
                },
            ));
        }
        let mut m = [0.0; 12];
        for (i, f) in fields.iter().enumerate() {
            m[i] = f
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    IoError::at(
                        path,
                        line_no,
                        IoErrorKind::InvalidData(format!(
                            "{} entry {}: `{f}` is not a finite number",
                            key.trim(),
                            i + 1
                        )),
                    )
                })?;
        }
        *slot = Some(m);
    }
    let p0 =
        p0.ok_or_else(|| IoError::file(path, IoErrorKind::InvalidData("no `P0:` line".into())))?;
    if !(p0[0] > 0.0 && p0[5] > 0.0) {
        return Err(IoError::file(
            path,
            IoErrorKind::InvalidCamera {
                camera: 0,
                reason: format!(
                    "focal lengths must be positive, found {} and {}",
                    p0[0], p0[5]
                ),
            },
        ));
    }
    Ok(KittiProjections {
        fx: p0[0],
        fy: p0[5],
        cx: p0[2],
        cy: p0[6],
        baseline: p1.filter(|p| p[0] != 0.0).map(|p| -p[3] / p[0]),
    })
}

/// The KITTI rig for images of `width x height` pixels: camera 0 (left) at
/// [`kitti_mount`]; with `stereo` camera 1 (right) with the same rotation and intrinsics,
/// `baseline` metres to the right (vehicle `y = -baseline`). Fails without a positive baseline
/// for a stereo rig; `path` names the calibration in errors.
pub fn kitti_image_rig(
    calib: &KittiProjections,
    width: u32,
    height: u32,
    stereo: bool,
    path: &Path,
) -> Result<Rig, IoError> {
    let model = Camera::Pinhole(Pinhole {
        fx: calib.fx,
        fy: calib.fy,
        cx: calib.cx,
        cy: calib.cy,
        width: f64::from(width),
        height: f64::from(height),
    });
    let left = kitti_mount();
    let mut cameras = vec![RigCamera {
        name: "cam0".into(),
        model,
        t_vehicle_camera: left,
    }];
    if stereo {
        let b = calib.baseline.filter(|b| *b > 0.0).ok_or_else(|| {
            IoError::file(
                path,
                IoErrorKind::InvalidCamera {
                    camera: 1,
                    reason: format!(
                        "a stereo rig needs a positive baseline from `P1:`, found {:?}",
                        calib.baseline
                    ),
                },
            )
        })?;
        cameras.push(RigCamera {
            name: "cam1".into(),
            model,
            t_vehicle_camera: Pose::new(
                left.rotation,
                left.translation + Vector3::new(0.0, -b, 0.0),
            ),
        });
    }
    Rig::new(cameras).map_err(|e| IoError::file(path, IoErrorKind::Rig(e)))
}

/// `odometry.csv` arc lengths from camera-0 ground-truth poses (`T_cam0(0)_cam0(k)`) and the
/// camera's mount: `v[0] = None`, `v[k]` the arc length of the vehicle motion `(k-1, k)`.
pub fn arc_lengths_from_poses(
    poses: &[Pose<f64>],
    t_vehicle_camera: &Pose<f64>,
) -> Vec<Option<f64>> {
    let mut out = Vec::with_capacity(poses.len().max(1));
    out.push(None);
    for w in poses.windows(2) {
        out.push(Some(vehicle_arc_length(&vehicle_motion(
            &w[0],
            &w[1],
            t_vehicle_camera,
        ))));
    }
    out
}

/// What [`import_kitti_sequence`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct KittiSequenceImport {
    /// Number of image frames.
    pub frames: usize,
    /// Number of cameras of the rig (1 or 2).
    pub cameras: usize,
    /// Ground-truth poses written to `poses.txt` (and arc lengths to `odometry.csv`).
    pub ground_truth: bool,
    /// Timestamps written to `times.txt`.
    pub timestamps: bool,
}

/// True if `dir` looks like a KITTI odometry sequence folder (`calib.txt` and `image_0/`).
pub fn is_kitti_sequence_folder(dir: &Path) -> bool {
    dir.join("calib.txt").is_file() && dir.join("image_0").is_dir()
}

/// Makes `out` a sequence directory for `momo vo OUT` from a KITTI odometry sequence folder
/// (`calib.txt` with `P0:`/`P1:`, `image_0/`, `image_1/`, optional `times.txt`):
///
/// ```text
/// OUT/rig.json       camera 0 (and with `stereo` camera 1), image size from image_0's first image
/// OUT/image_0 (, image_1)   symbolic links to the image folders (not copies)
/// OUT/poses.txt      the ground truth (from `poses`, else DIR/poses.txt if present)
/// OUT/odometry.csv   arc lengths of the vehicle from that ground truth
/// OUT/times.txt      the timestamps (DIR/times.txt if present; one per image)
/// ```
///
/// Errors name the offending file (and line); the image folders must hold the same number of
/// images, and `poses`/`times.txt` one line per image.
pub fn import_kitti_sequence(
    dir: &Path,
    out: &Path,
    poses: Option<&Path>,
    stereo: bool,
) -> Result<KittiSequenceImport, crate::MatchError> {
    let calib_path = dir.join("calib.txt");
    let calib = read_kitti_projections(&calib_path)?;
    let mut folders = vec![dir.join("image_0")];
    if stereo {
        folders.push(dir.join("image_1"));
    }
    let images = crate::ImageSequence::open(&folders)?;
    let frames = images.len();
    let first = images
        .path(0, 0)
        .ok_or_else(|| crate::MatchError::NoImages {
            path: folders[0].clone(),
        })?;
    let img = crate::load_gray(first)?;
    let rig = kitti_image_rig(&calib, img.width(), img.height(), stereo, &calib_path)?;
    let poses_path = poses
        .map(Path::to_path_buf)
        .or_else(|| Some(dir.join("poses.txt")).filter(|p| p.is_file()));
    let ground_truth = poses_path
        .as_deref()
        .map(|p| {
            let gt = momo_io::read_poses(p)?;
            if gt.len() != frames {
                return Err(IoError::file(
                    p,
                    IoErrorKind::Invalid(format!(
                        "{} poses, but {} has {frames} images; one pose per image is needed",
                        gt.len(),
                        folders[0].display()
                    )),
                ));
            }
            Ok(gt)
        })
        .transpose()?;
    let times_path = dir.join(momo_io::files::TIMES);
    let times = if times_path.is_file() {
        let t = momo_io::read_times(&times_path)?;
        if t.len() != frames {
            return Err(IoError::file(
                &times_path,
                IoErrorKind::Invalid(format!(
                    "{} timestamps, but {} has {frames} images",
                    t.len(),
                    folders[0].display()
                )),
            )
            .into());
        }
        Some(t)
    } else {
        None
    };
    std::fs::create_dir_all(out).map_err(|e| IoError::io(out, e))?;
    momo_io::write_rig(out.join(momo_io::files::RIG), &rig)?;
    for (j, folder) in folders.iter().enumerate() {
        link_folder(folder, &out.join(format!("image_{j}")))?;
    }
    if let Some(gt) = &ground_truth {
        momo_io::write_poses(out.join(momo_io::files::POSES), gt)?;
        let arcs = arc_lengths_from_poses(gt, &kitti_mount());
        momo_io::write_odometry(out.join(momo_io::files::ODOMETRY), &arcs)?;
    }
    if let Some(t) = &times {
        momo_io::write_times(out.join(momo_io::files::TIMES), t)?;
    }
    Ok(KittiSequenceImport {
        frames,
        cameras: rig.len(),
        ground_truth: ground_truth.is_some(),
        timestamps: times.is_some(),
    })
}

/// Links `link` to the folder `target` (absolute), replacing an old link.
fn link_folder(target: &Path, link: &Path) -> Result<(), IoError> {
    let target = std::fs::canonicalize(target).map_err(|e| IoError::io(target, e))?;
    if link.is_symlink() {
        std::fs::remove_file(link).map_err(|e| IoError::io(link, e))?;
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&target, link).map_err(|e| IoError::io(link, e))
    }
    #[cfg(not(unix))]
    {
        let _ = target;
        Err(IoError::file(
            link,
            IoErrorKind::Invalid("linking the image folders needs a Unix system".into()),
        ))
    }
}

/// The image folders of a sequence directory made by [`import_kitti_sequence`]:
/// `DIR/image_0`, `DIR/image_1`, ... one per camera of the rig.
pub fn sequence_image_folders(dir: &Path, cameras: usize) -> Vec<std::path::PathBuf> {
    (0..cameras)
        .map(|j| dir.join(format!("image_{j}")))
        .collect()
}
