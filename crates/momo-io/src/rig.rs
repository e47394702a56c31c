//! `rig.json`: the cameras of a sequence (`FORMAT.md`, section "rig.json").
//!
//! The structure is parsed with serde (so syntax errors, missing and unknown fields and unknown
//! `model.type` values come with serde_json's line and column); each camera's `model` and
//! `T_vehicle_camera` are then checked semantically (positive focal lengths and image sizes,
//! parameter ranges of the wide-angle models, a
//! 4x4 matrix with bottom row `0 0 0 1` and an orthonormal rotation with determinant +1 within
//! [`ORTHONORMAL_TOLERANCE`]) and errors point at the line where that value starts.

use crate::atomic::{put, stage_atomic};
use crate::error::{IoError, IoErrorKind, quote};
use crate::text::Exact;
use momo_core::rig::ORTHONORMAL_TOLERANCE;
use momo_core::{Camera, Pose, Rig, RigCamera};
use nalgebra::Matrix4;
use serde::Deserialize;
use serde_json::value::RawValue;
use std::io::Read;
use std::path::Path;

/// Largest `rig.json` accepted (16 MiB); a rig is a few hundred bytes per camera.
pub const MAX_RIG_BYTES: usize = 16 << 20;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigFile<'a> {
    #[serde(borrow)]
    cameras: &'a RawValue,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile<'a> {
    #[serde(default)]
    name: Option<String>,
    #[serde(borrow)]
    model: &'a RawValue,
    #[serde(borrow, rename = "T_vehicle_camera")]
    t_vehicle_camera: &'a RawValue,
}

/// A position in the text: 1-based line and column.
#[derive(Clone, Copy)]
struct Pos {
    line: usize,
    column: usize,
}

impl Pos {
    const START: Pos = Pos { line: 1, column: 1 };
}

/// The line starts of a text, to find the position of a slice in O(log lines). (Counting the
/// newlines before each camera from the start of the file made parsing quadratic in the
/// number of cameras: 8,000 cameras took 20 s.)
struct Lines<'a> {
    text: &'a str,
    /// Byte offset of every line's first byte (line 1 at 0).
    starts: Vec<usize>,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i + 1),
        );
        Self { text, starts }
    }

    /// Where `sub` (a slice of the text) starts.
    fn of(&self, sub: &str) -> Pos {
        let offset = (sub.as_ptr() as usize)
            .checked_sub(self.text.as_ptr() as usize)
            .filter(|&o| o <= self.text.len())
            .unwrap_or(0);
        // The last line start at or before `offset`.
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        let line_start = self.starts.get(line - 1).copied().unwrap_or(0);
        Pos {
            line,
            column: 1 + offset - line_start,
        }
    }
}

/// Parses `sub` (a slice of the file starting at `base`) and maps serde_json's error position to
/// the file.
fn parse_at<'a, T: Deserialize<'a>>(sub: &'a str, base: Pos, path: &Path) -> Result<T, IoError> {
    serde_json::from_str(sub).map_err(|e| {
        let line = base.line + e.line().saturating_sub(1);
        let column = if e.line() <= 1 {
            base.column + e.column().saturating_sub(1)
        } else {
            e.column()
        };
        let mut message = e.to_string();
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        if let Some(m) = message.strip_suffix(&suffix) {
            message = m.to_owned();
        }
        let message = shorten_quoted(&message);
        IoError::at(path, line.max(1), IoErrorKind::Json { column, message })
    })
}

/// Longest serde_json message kept in an error (characters); the rest is cut.
const MAX_JSON_MESSAGE_CHARS: usize = 300;

/// Shortens the file's text that serde_json quotes in a message (`` `name` `` and `"value"`)
/// to 40 characters each, and the whole message to [`MAX_JSON_MESSAGE_CHARS`], so that a huge
/// key or string gives a short error (found by fuzzing: an unknown field of 2,000 characters
/// was echoed whole; a key that itself holds backticks defeats the quote matching, hence the
/// overall cut).
fn shorten_quoted(message: &str) -> String {
    let mut out = message.to_owned();
    for delimiter in ['`', '"'] {
        out = out
            .split(delimiter)
            .enumerate()
            .map(|(i, part)| {
                if i % 2 == 1 {
                    quote(part)
                } else {
                    part.to_owned()
                }
            })
            .collect::<Vec<_>>()
            .join(&delimiter.to_string());
    }
    if out.chars().count() > MAX_JSON_MESSAGE_CHARS {
        out = out.chars().take(MAX_JSON_MESSAGE_CHARS).collect();
        out.push('…');
    }
    out
}

/// A rejected camera model: the offending field (to point at its line) and the reason.
pub(crate) struct CameraFault {
    /// The field of the model, as `rig.json` names it.
    pub field: &'static str,
    /// What is wrong.
    pub reason: String,
}

/// Checks intrinsics: positive finite focal lengths and image size, finite other parameters,
/// and the parameter ranges of the wide-angle models (`docs/CAMERAS.md`): double sphere
/// `−1 < xi < 1`, `0 ≤ alpha ≤ 1`; unified `xi ≥ 0`.
pub(crate) fn check_camera(model: &Camera) -> Result<(), CameraFault> {
    let (fx, fy, width, height, others): (f64, f64, f64, f64, Vec<(&'static str, f64)>) =
        match model {
            Camera::Pinhole(p) => (
                p.fx,
                p.fy,
                p.width,
                p.height,
                vec![("cx", p.cx), ("cy", p.cy)],
            ),
            Camera::KannalaBrandt(k) => (
                k.fx,
                k.fy,
                k.width,
                k.height,
                vec![
                    ("cx", k.cx),
                    ("cy", k.cy),
                    ("k1", k.k1),
                    ("k2", k.k2),
                    ("k3", k.k3),
                    ("k4", k.k4),
                ],
            ),
            Camera::Radtan(r) => (
                r.fx,
                r.fy,
                r.width,
                r.height,
                vec![
                    ("cx", r.cx),
                    ("cy", r.cy),
                    ("k1", r.k1),
                    ("k2", r.k2),
                    ("p1", r.p1),
                    ("p2", r.p2),
                    ("k3", r.k3),
                ],
            ),
            Camera::DoubleSphere(d) => (
                d.fx,
                d.fy,
                d.width,
                d.height,
                vec![("cx", d.cx), ("cy", d.cy), ("xi", d.xi), ("alpha", d.alpha)],
            ),
            Camera::Unified(u) => (
                u.fx,
                u.fy,
                u.width,
                u.height,
                vec![("cx", u.cx), ("cy", u.cy), ("xi", u.xi)],
            ),
        };
    let fault = |field: &'static str, reason: String| Err(CameraFault { field, reason });
    for (name, v) in [("fx", fx), ("fy", fy), ("width", width), ("height", height)] {
        if !(v.is_finite() && v > 0.0) {
            return fault(
                name,
                format!("`{name}` must be a positive number, found {v}"),
            );
        }
    }
    for &(name, v) in &others {
        if !v.is_finite() {
            return fault(name, format!("`{name}` must be finite, found {v}"));
        }
    }
    match model {
        Camera::DoubleSphere(d) => {
            if !(d.xi > -1.0 && d.xi < 1.0) {
                return fault(
                    "xi",
                    format!(
                        "double_sphere `xi` must lie in (-1, 1) (the first sphere's centre inside \
                         the second), found {}",
                        d.xi
                    ),
                );
            }
            if !(0.0..=1.0).contains(&d.alpha) {
                return fault(
                    "alpha",
                    format!(
                        "double_sphere `alpha` must lie in [0, 1], found {}",
                        d.alpha
                    ),
                );
            }
        }
        Camera::Unified(u) if u.xi < 0.0 => {
            return fault("xi", format!("unified `xi` must be >= 0, found {}", u.xi));
        }
        _ => {}
    }
    check_ranges(model, fx, fy, width, height, &others)
}

/// Largest image side accepted, pixels (the largest sensors have ~20,000 px a side).
pub const MAX_IMAGE_SIDE: f64 = 100_000.0;
/// Focal lengths are accepted within `[s / FOCAL_RANGE, s · FOCAL_RANGE]` of the larger image
/// side `s`: from a field of view near 180° to a telescope's 0.06°.
pub const FOCAL_RANGE: f64 = 1000.0;
/// Largest distance of a camera from the motion centre, metres (a lever arm of a road vehicle is
/// a few metres; 1 km is generous).
pub const MAX_LEVER_ARM: f64 = 1000.0;
/// Largest magnitude of a Kannala-Brandt coefficient.
pub const MAX_KB_COEFFICIENT: f64 = 100.0;

/// A number for a message: at most ~12 significant digits (a 444-digit literal stays short).
fn short_number(v: f64) -> String {
    let s = format!("{v}");
    if s.len() > 20 { format!("{v:.6e}") } else { s }
}

/// The physical ranges (`FORMAT.md`, "Value ranges"): image size within
/// `1..=`[`MAX_IMAGE_SIDE`], focal lengths within [`FOCAL_RANGE`] of the image size, the
/// principal point within one image size of the image, Kannala-Brandt coefficients within
/// ±[`MAX_KB_COEFFICIENT`] and a projection that does not fold back (`d'(θ) > 0`) for every
/// angle up to the image's corners or 90°, whichever is less.
fn check_ranges(
    model: &Camera,
    fx: f64,
    fy: f64,
    width: f64,
    height: f64,
    others: &[(&'static str, f64)],
) -> Result<(), CameraFault> {
    let fault = |field: &'static str, reason: String| Err(CameraFault { field, reason });
    for (name, v) in [("width", width), ("height", height)] {
        if !(1.0..=MAX_IMAGE_SIDE).contains(&v) {
            return fault(
                name,
                format!(
                    "`{name}` must be within 1..={MAX_IMAGE_SIDE} pixels, found {}",
                    short_number(v)
                ),
            );
        }
    }
    let side = width.max(height);
    let (lo, hi) = (side / FOCAL_RANGE, side * FOCAL_RANGE);
    for (name, v) in [("fx", fx), ("fy", fy)] {
        if !(lo..=hi).contains(&v) {
            return fault(
                name,
                format!(
                    "`{name}` = {} pixels is outside {lo}..={hi} (1/{FOCAL_RANGE} to \
                     {FOCAL_RANGE} times the larger image side)",
                    short_number(v)
                ),
            );
        }
    }
    let get = |n: &str| others.iter().find(|(k, _)| *k == n).map(|(_, v)| *v);
    let (cx, cy) = (get("cx").unwrap_or(0.0), get("cy").unwrap_or(0.0));
    for (name, v, size) in [("cx", cx, width), ("cy", cy, height)] {
        if !(-size..=2.0 * size).contains(&v) {
            return fault(
                name,
                format!(
                    "`{name}` = {} is more than one image size ({size} px) outside the image",
                    short_number(v)
                ),
            );
        }
    }
    if let Camera::KannalaBrandt(k) = model {
        for (name, v) in [("k1", k.k1), ("k2", k.k2), ("k3", k.k3), ("k4", k.k4)] {
            if v.abs() > MAX_KB_COEFFICIENT {
                return fault(
                    name,
                    format!(
                        "`{name}` = {} is outside ±{MAX_KB_COEFFICIENT}",
                        short_number(v)
                    ),
                );
            }
        }
        // d(θ) must increase up to the farthest image corner or up to 90° off-axis, whichever
        // comes first (a fisheye's image circle may end inside the image; any lens is
        // monotonic over a hemisphere).
        let corner = [(0.0, 0.0), (width, 0.0), (0.0, height), (width, height)]
            .iter()
            .map(|&(u, v)| ((u - cx) / fx).hypot((v - cy) / fy))
            .fold(0.0, f64::max);
        const STEPS: usize = 1000;
        for i in 1..=STEPS {
            let theta = std::f64::consts::FRAC_PI_2 * i as f64 / STEPS as f64;
            let t2 = theta * theta;
            let d = theta * (1.0 + t2 * (k.k1 + t2 * (k.k2 + t2 * (k.k3 + t2 * k.k4))));
            let dd =
                1.0 + t2 * (3.0 * k.k1 + t2 * (5.0 * k.k2 + t2 * (7.0 * k.k3 + t2 * 9.0 * k.k4)));
            if !(dd > 0.0) {
                return fault(
                    "k1",
                    format!(
                        "the Kannala-Brandt projection folds back at {:.1}° off-axis \
                         (d'(θ) <= 0) inside the image: check k1..k4",
                        theta.to_degrees()
                    ),
                );
            }
            if d >= corner {
                break;
            }
        }
    }
    Ok(())
}

/// The 1-based line of `"field"` inside a model's JSON text starting at `base`, or `base`'s line
/// when the key is not found.
fn field_line(model_text: &str, base: Pos, field: &str) -> usize {
    model_text
        .find(&format!("\"{field}\""))
        .map_or(base.line, |i| {
            base.line + model_text[..i].bytes().filter(|&b| b == b'\n').count()
        })
}

/// Checks a 4x4 `T_vehicle_camera` (rows of the file) and returns the pose.
fn extrinsic(rows: &[Vec<f64>], camera: usize) -> Result<Pose<f64>, IoErrorKind> {
    let bad = |reason: String| IoErrorKind::BadExtrinsic { camera, reason };
    if rows.len() != 4 {
        return Err(bad(format!("found {} rows", rows.len())));
    }
    let mut m = Matrix4::zeros();
    for (i, row) in rows.iter().enumerate() {
        if row.len() != 4 {
            return Err(bad(format!("row {i} has {} entries", row.len())));
        }
        for (j, &v) in row.iter().enumerate() {
            if !v.is_finite() {
                return Err(bad(format!("entry ({i}, {j}) is not finite")));
            }
            m[(i, j)] = v;
        }
    }
    let bottom = [0.0, 0.0, 0.0, 1.0];
    if (0..4).any(|j| (m[(3, j)] - bottom[j]).abs() > ORTHONORMAL_TOLERANCE) {
        return Err(bad(format!(
            "bottom row is [{}, {}, {}, {}]",
            m[(3, 0)],
            m[(3, 1)],
            m[(3, 2)],
            m[(3, 3)]
        )));
    }
    let pose = Pose::from_homogeneous(&m);
    let error = pose.orthonormality_error();
    if error.is_nan() || error > ORTHONORMAL_TOLERANCE {
        return Err(IoErrorKind::ExtrinsicNotOrthonormal {
            camera,
            error,
            tolerance: ORTHONORMAL_TOLERANCE,
        });
    }
    let lever = pose.translation.norm();
    if lever > MAX_LEVER_ARM {
        return Err(IoErrorKind::InvalidCamera {
            camera,
            reason: format!(
                "T_vehicle_camera puts the camera {} m from the motion centre; at most \
                 {MAX_LEVER_ARM} m is accepted",
                short_number(lever)
            ),
        });
    }
    // What the tolerance accepts is re-orthonormalised (the nearest rotation, by SVD), so that
    // every pose computed from it is orthonormal to rounding. A rotation orthonormal to
    // rounding already is kept bit for bit (the writer's output reads back exactly).
    if error <= 1e-12 {
        return Ok(pose);
    }
    let svd = pose.rotation.svd(true, true);
    let rotation = match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => u * v_t,
        _ => pose.rotation,
    };
    Ok(Pose::new(rotation, pose.translation))
}

/// Parses the text of a `rig.json`; `path` only names the file in errors.
pub fn read_rig_from_str(text: &str, path: impl AsRef<Path>) -> Result<Rig, IoError> {
    let path = path.as_ref();
    // A UTF-8 byte order mark (written by some Windows editors) is skipped, as in the CSV files.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let trimmed = text.trim_start();
    if !trimmed.is_empty() && !trimmed.starts_with('{') {
        let line = 1 + text[..text.len() - trimmed.len()].matches('\n').count();
        let first: String = trimmed
            .lines()
            .next()
            .unwrap_or("")
            .chars()
            .take(30)
            .collect();
        return Err(IoError::at(
            path,
            line,
            IoErrorKind::Invalid(format!(
                "not JSON: expected a JSON rig file (`{{\"cameras\": [...]}}`, docs/FORMAT.md), found `{first}`; \
                 a KITTI calib.txt is turned into rig.json by `momo import-kitti`"
            )),
        ));
    }
    let lines = Lines::new(text);
    let file: RigFile = parse_at(text, Pos::START, path)?;
    let list_pos = lines.of(file.cameras.get());
    let list: Vec<&RawValue> = parse_at(file.cameras.get(), list_pos, path)?;
    if list.is_empty() {
        return Err(IoError::at(path, list_pos.line, IoErrorKind::EmptyRig));
    }
    let mut cameras = Vec::with_capacity(list.len());
    for (i, raw) in list.iter().enumerate() {
        let raw = raw.get();
        let cam: CameraFile = parse_at(raw, lines.of(raw), path)?;
        let model_pos = lines.of(cam.model.get());
        let model: Camera = parse_at(cam.model.get(), model_pos, path)?;
        check_camera(&model).map_err(|f| {
            IoError::at(
                path,
                field_line(cam.model.get(), model_pos, f.field),
                IoErrorKind::InvalidCamera {
                    camera: i,
                    reason: f.reason,
                },
            )
        })?;
        let t_pos = lines.of(cam.t_vehicle_camera.get());
        let rows: Vec<Vec<f64>> = parse_at(cam.t_vehicle_camera.get(), t_pos, path)?;
        let t_vehicle_camera = extrinsic(&rows, i).map_err(|k| IoError::at(path, t_pos.line, k))?;
        cameras.push(RigCamera {
            name: cam.name.unwrap_or_else(|| format!("cam{i}")),
            model,
            t_vehicle_camera,
        });
    }
    Rig::new(cameras).map_err(|e| IoError::file(path, IoErrorKind::Rig(e)))
}

/// Reads `rig.json` (at most [`MAX_RIG_BYTES`]).
pub fn read_rig(path: impl AsRef<Path>) -> Result<Rig, IoError> {
    let path = path.as_ref();
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut bytes = Vec::new();
    file.take(MAX_RIG_BYTES as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| IoError::io(path, e))?;
    if bytes.len() > MAX_RIG_BYTES {
        return Err(IoError::file(
            path,
            IoErrorKind::TooLong {
                limit: MAX_RIG_BYTES,
            },
        ));
    }
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        IoError::at(path, line, IoErrorKind::InvalidUtf8)
    })?;
    read_rig_from_str(text, path)
}

/// The `rig.json` text of a rig, in the layout of `FORMAT.md` (one matrix row per line). Numbers
/// are printed so that they parse back to the same bits.
pub fn rig_to_json(rig: &Rig) -> Result<String, IoErrorKind> {
    use std::fmt::Write as _;
    let mut s = String::from("{\n  \"cameras\": [\n");
    for (i, c) in rig.cameras().iter().enumerate() {
        check_camera(&c.model).map_err(|f| IoErrorKind::InvalidCamera {
            camera: i,
            reason: f.reason,
        })?;
        let m = c.t_vehicle_camera.to_homogeneous();
        if m.iter().any(|v| !v.is_finite()) {
            return Err(IoErrorKind::BadExtrinsic {
                camera: i,
                reason: "not finite".into(),
            });
        }
        let json = |e: serde_json::Error| IoErrorKind::InvalidData(e.to_string());
        let name = serde_json::to_string(&c.name).map_err(json)?;
        let model = serde_json::to_string(&c.model).map_err(json)?;
        let rows: Vec<String> = (0..4)
            .map(|r| {
                let v: Vec<String> = (0..4).map(|k| json_number(m[(r, k)])).collect();
                format!("[{}]", v.join(", "))
            })
            .collect();
        let indent = " ".repeat("      \"T_vehicle_camera\": [".len());
        // Writing to a String cannot fail.
        let _ = write!(
            s,
            "    {{\n      \"name\": {name},\n      \"model\": {model},\n      \"T_vehicle_camera\": [{}]\n    }}{}\n",
            rows.join(&format!(",\n{indent}")),
            if i + 1 < rig.len() { "," } else { "" }
        );
    }
    s.push_str("  ]\n}\n");
    Ok(s)
}

/// A JSON number that parses back to the same (finite) `f64`: `Exact` prints forms such as
/// `1`, `-0`, `12.5`, `1e-7`, all valid JSON.
fn json_number(v: f64) -> String {
    Exact(v).to_string()
}

/// Writes `rig.json` atomically. Fails (writing nothing) on intrinsics or extrinsics that the
/// reader would reject.
pub fn write_rig(path: impl AsRef<Path>, rig: &Rig) -> Result<(), IoError> {
    stage_rig(path.as_ref(), rig)?.commit()
}

/// [`write_rig`] without the commit.
pub(crate) fn stage_rig(path: &Path, rig: &Rig) -> Result<crate::AtomicFile, IoError> {
    let text = rig_to_json(rig).map_err(|k| IoError::file(path, k))?;
    stage_atomic(path, |f| put!(f, "{text}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_text_in_messages_is_shortened() {
        let long = "x".repeat(100);
        let m = shorten_quoted(&format!("unknown field `{long}`, expected `cameras`"));
        assert_eq!(
            m,
            format!("unknown field `{}…`, expected `cameras`", "x".repeat(40))
        );
        let m = shorten_quoted(&format!("invalid type: string \"{long}\", expected f64"));
        assert_eq!(
            m,
            format!("invalid type: string \"{}…\", expected f64", "x".repeat(40))
        );
        assert_eq!(shorten_quoted("no quotes"), "no quotes");
        // Quotes inside the quoted text: still short.
        let m = shorten_quoted(&format!(
            "unknown field `a{long}`b`{long}`, expected `cameras`"
        ));
        assert!(m.chars().count() <= MAX_JSON_MESSAGE_CHARS + 1, "{m}");
    }

    #[test]
    fn positions_map_to_the_file() {
        let text = "{\n  \"a\": [1,\n 2]\n}";
        let sub = &text[text.find('[').unwrap()..];
        let p = Lines::new(text).of(sub);
        assert_eq!(Lines::new(text).of(text).line, 1);
        let last = &text[text.len() - 1..];
        assert_eq!(
            (
                Lines::new(text).of(last).line,
                Lines::new(text).of(last).column
            ),
            (4, 1)
        );
        assert_eq!((p.line, p.column), (2, 8));
    }
}
