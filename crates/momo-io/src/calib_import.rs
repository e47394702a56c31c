//! Calibration import (`momo rig import`): a `rig.json` from the calibration files of OpenCV,
//! ROS and Kalibr.
//!
//! Three formats are recognised by their keys:
//!
//! - **OpenCV FileStorage YAML** (what `cv::FileStorage` and OpenCV's calibration sample write):
//!   a `%YAML:1.0` header, `camera_matrix` and `distortion_coefficients` as `!!opencv-matrix`
//!   maps (`rows`, `cols`, `dt`, `data`), `image_width`, `image_height`.
//! - **ROS `camera_info` YAML** (`camera_calibration_parsers`): the same keys as plain maps plus
//!   `distortion_model` (`plumb_bob`, `rational_polynomial` with zero extra terms,
//!   `equidistant`); also the message form (`width`, `height`, `distortion_model`, `D`, `K`).
//! - **Kalibr camchain YAML**: `cam0` … `camN`, each with `camera_model` (`pinhole`, `omni`,
//!   `ds`, `eucm` with β = 1), `intrinsics`, `distortion_model` (`radtan`, `equidistant`,
//!   `none`), `distortion_coeffs`, `resolution`, and from `cam1` on `T_cn_cnm1`, the transform
//!   of points from camera n-1 into camera n.
//!
//! Distortion maps to the models of `docs/CAMERAS.md`: radtan (4 or 5 coefficients `k1 k2 p1
//! p2 [k3]`) to [`Radtan`], equidistant (`k1..k4`) to [`KannalaBrandt`], none (or all zero) to
//! [`Pinhole`], Kalibr `omni` to [`Unified`], `ds` to [`DoubleSphere`].
//!
//! **Mount convention.** Calibration files know nothing of the vehicle: the caller gives
//! `T_vehicle_camera` of camera 0 (`mount`, vehicle frame x forward, y left, z up; camera x
//! right, y down, z forward, as in `FORMAT.md`). Camera n is placed by the chain:
//! `T_vehicle_cam(n) = T_vehicle_cam(n-1) · T_cn_cnm1⁻¹`. [`parse_mount`] reads the option text.
//!
//! Every error is an [`IoError`] `path:line: reason` pointing at the offending YAML value.

use crate::error::{IoError, IoErrorKind};
use crate::rig::{check_camera, write_rig};
use momo_core::{
    Camera, DoubleSphere, KannalaBrandt, Pinhole, Pose, Radtan, Rig, RigCamera, Unified,
};
use nalgebra::{Matrix3, Matrix4, Vector3};
use std::path::Path;
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// Largest calibration file accepted (1 MiB).
pub const MAX_CALIBRATION_BYTES: usize = 1 << 20;

/// Tolerance on the orthonormality of Kalibr's `T_cn_cnm1` rotations (Kalibr prints 16
/// digits; hand-edited files with 6 to 8 digits pass).
pub const CHAIN_ORTHONORMAL_TOLERANCE: f64 = 1e-6;

/// The calibration file formats [`import_calibration`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalibrationFormat {
    /// OpenCV FileStorage YAML (`!!opencv-matrix`).
    OpenCv,
    /// ROS `camera_info` YAML (camera_calibration_parsers or the message form).
    RosCameraInfo,
    /// Kalibr camchain YAML (`cam0` … `camN`).
    Kalibr,
}

impl std::fmt::Display for CalibrationFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CalibrationFormat::OpenCv => "OpenCV FileStorage YAML",
            CalibrationFormat::RosCameraInfo => "ROS camera_info YAML",
            CalibrationFormat::Kalibr => "Kalibr camchain YAML",
        })
    }
}

/// A YAML value with the 1-based line where it starts.
#[derive(Clone, Debug)]
struct Node {
    line: usize,
    value: Value,
}

#[derive(Clone, Debug)]
enum Value {
    Scalar(String),
    Seq(Vec<Node>),
    Map(Vec<(String, Node)>),
}

/// Builds [`Node`]s from the parser's events.
#[derive(Default)]
struct Builder {
    /// Open collections: the node under construction and, for maps, a pending key.
    stack: Vec<(Node, Option<String>)>,
    root: Option<Node>,
    error: Option<(usize, String)>,
}

impl Builder {
    fn push(&mut self, node: Node) {
        let Some((parent, key)) = self.stack.last_mut() else {
            if self.root.is_none() {
                self.root = Some(node);
            }
            return;
        };
        match &mut parent.value {
            Value::Seq(items) => items.push(node),
            Value::Map(entries) => match key.take() {
                Some(k) => entries.push((k, node)),
                None => match node.value {
                    Value::Scalar(s) => *key = Some(s),
                    _ => {
                        self.error
                            .get_or_insert((node.line, "a map key must be a plain value".into()));
                    }
                },
            },
            Value::Scalar(_) => {}
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        let line = mark.line().max(1);
        match ev {
            Event::Scalar(s, ..) => self.push(Node {
                line,
                value: Value::Scalar(s),
            }),
            Event::SequenceStart(..) => self.stack.push((
                Node {
                    line,
                    value: Value::Seq(Vec::new()),
                },
                None,
            )),
            Event::MappingStart(..) => self.stack.push((
                Node {
                    line,
                    value: Value::Map(Vec::new()),
                },
                None,
            )),
            Event::SequenceEnd | Event::MappingEnd => {
                if let Some((node, _)) = self.stack.pop() {
                    self.push(node);
                }
            }
            Event::Alias(_) => {
                self.error
                    .get_or_insert((line, "YAML aliases are not supported here".into()));
            }
            _ => {}
        }
    }
}

/// Parses YAML (the first document) into a tree with line numbers. OpenCV's `%YAML:1.0` header
/// (not valid YAML 1.2) is blanked first, keeping the line count.
fn parse_yaml(text: &str, path: &Path) -> Result<Node, IoError> {
    let text = match text.strip_prefix("%YAML:") {
        Some(rest) => {
            let end = rest.find('\n').unwrap_or(rest.len());
            format!("{}{}", " ".repeat("%YAML:".len() + end), &rest[end..])
        }
        None => text.to_owned(),
    };
    let mut builder = Builder::default();
    let mut parser = Parser::new_from_str(&text);
    parser.load(&mut builder, false).map_err(|e| {
        calib(
            path,
            e.marker().line().max(1),
            format!("not valid YAML: {}", e.info()),
        )
    })?;
    if let Some((line, reason)) = builder.error {
        return Err(calib(path, line, reason));
    }
    builder
        .root
        .ok_or_else(|| calib(path, 1, "empty file: expected a YAML calibration".into()))
}

fn calib(path: &Path, line: usize, reason: String) -> IoError {
    IoError::at(path, line, IoErrorKind::Calibration(reason))
}

/// Typed access to the tree, with errors at the right line.
struct Doc<'a> {
    path: &'a Path,
}

impl Doc<'_> {
    fn err(&self, line: usize, reason: impl Into<String>) -> IoError {
        calib(self.path, line, reason.into())
    }

    fn map<'n>(&self, node: &'n Node, what: &str) -> Result<&'n [(String, Node)], IoError> {
        match &node.value {
            Value::Map(m) => Ok(m),
            _ => Err(self.err(node.line, format!("{what} must be a map"))),
        }
    }

    fn get<'n>(&self, map: &'n Node, key: &str) -> Option<&'n Node> {
        match &map.value {
            Value::Map(m) => m.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    fn require<'n>(&self, map: &'n Node, key: &str, ctx: &str) -> Result<&'n Node, IoError> {
        self.get(map, key)
            .ok_or_else(|| self.err(map.line, format!("{ctx}missing key `{key}`")))
    }

    fn number(&self, node: &Node, what: &str) -> Result<f64, IoError> {
        match &node.value {
            Value::Scalar(s) => {
                let v: f64 = s.trim().parse().map_err(|_| {
                    self.err(
                        node.line,
                        format!(
                            "`{what}`: cannot parse `{}` as a number",
                            crate::error::quote(s)
                        ),
                    )
                })?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(self.err(node.line, format!("`{what}` is not finite ({v})")))
                }
            }
            _ => Err(self.err(node.line, format!("`{what}` must be a number"))),
        }
    }

    fn text<'n>(&self, node: &'n Node, what: &str) -> Result<&'n str, IoError> {
        match &node.value {
            Value::Scalar(s) => Ok(s),
            _ => Err(self.err(node.line, format!("`{what}` must be a plain value"))),
        }
    }

    fn numbers(&self, node: &Node, what: &str) -> Result<Vec<f64>, IoError> {
        match &node.value {
            Value::Seq(items) => items.iter().map(|n| self.number(n, what)).collect(),
            _ => Err(self.err(node.line, format!("`{what}` must be a list of numbers"))),
        }
    }

    /// A matrix given as a map `rows`, `cols`, `data` (OpenCV and ROS) or as a flat list:
    /// rows, columns, the values and the line of the values.
    fn matrix(&self, node: &Node, what: &str) -> Result<(usize, usize, Vec<f64>, usize), IoError> {
        if let Value::Seq(_) = node.value {
            let data = self.numbers(node, what)?;
            return Ok((1, data.len(), data, node.line));
        }
        self.map(node, &format!("`{what}`"))?;
        let ctx = format!("`{what}`: ");
        let dim = |key: &str| -> Result<usize, IoError> {
            let n = self.require(node, key, &ctx)?;
            let v = self.number(n, &format!("{what}.{key}"))?;
            if v >= 0.0 && v.fract() == 0.0 && v <= 64.0 {
                Ok(v as usize)
            } else {
                Err(self.err(
                    n.line,
                    format!("`{what}.{key}` must be a small whole number"),
                ))
            }
        };
        let (rows, cols) = (dim("rows")?, dim("cols")?);
        let data_node = self.require(node, "data", &ctx)?;
        let data = self.numbers(data_node, &format!("{what}.data"))?;
        if data.len() != rows * cols {
            return Err(self.err(
                data_node.line,
                format!(
                    "`{what}.data` has {} values, expected rows x cols = {rows} x {cols}",
                    data.len()
                ),
            ));
        }
        Ok((rows, cols, data, data_node.line))
    }

    fn whole(&self, node: &Node, what: &str) -> Result<f64, IoError> {
        let v = self.number(node, what)?;
        if v > 0.0 && v.fract() == 0.0 {
            Ok(v)
        } else {
            Err(self.err(
                node.line,
                format!("`{what}` must be a positive whole number, found {v}"),
            ))
        }
    }
}

/// Parses the `--mount` option: `x,y,z[,yaw_deg[,pitch_down_deg]]` (camera position in the
/// vehicle frame in metres, heading about the vehicle z axis in degrees: 0 forward, 90 left,
/// 180 backward, -90 right; downward tilt in degrees), or 16 comma-separated numbers, the 4x4
/// `T_vehicle_camera` row by row. Without the option a forward-looking level camera at the
/// vehicle origin is assumed (`x,y,z` = `0,0,0`).
pub fn parse_mount(text: &str) -> Result<Pose<f64>, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("--mount: cannot parse `{}` as a finite number", s.trim()))
        })
        .collect::<Result<_, _>>()?;
    match values.len() {
        3..=5 => {
            let yaw = values.get(3).copied().unwrap_or(0.0).to_radians();
            let pitch = values.get(4).copied().unwrap_or(0.0).to_radians();
            Ok(mount_pose(
                Vector3::new(values[0], values[1], values[2]),
                yaw,
                pitch,
            ))
        }
        16 => {
            let m = Matrix4::from_row_slice(&values);
            let pose = Pose::from_homogeneous(&m);
            let bottom_ok =
                (m.fixed_view::<1, 4>(3, 0) - nalgebra::RowVector4::new(0.0, 0.0, 0.0, 1.0)).amax()
                    <= momo_core::rig::ORTHONORMAL_TOLERANCE;
            if !bottom_ok || pose.orthonormality_error() > momo_core::rig::ORTHONORMAL_TOLERANCE {
                return Err(
                    "--mount: the 4x4 matrix must have an orthonormal rotation with \
                            determinant +1 and bottom row 0 0 0 1"
                        .into(),
                );
            }
            Ok(pose)
        }
        n => Err(format!(
            "--mount: expected x,y,z[,yaw_deg[,pitch_down_deg]] or 16 numbers (T_vehicle_camera \
             row by row), found {n} numbers"
        )),
    }
}

/// `T_vehicle_camera` of a camera at `position` looking along heading `yaw` (radians about the
/// vehicle z axis) tilted down by `pitch_down` radians; camera x horizontal to the right.
/// (`momo_sim::camera_mount` is the same construction.)
pub fn mount_pose(position: Vector3<f64>, yaw: f64, pitch_down: f64) -> Pose<f64> {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch_down.sin_cos();
    let z = Vector3::new(cp * cy, cp * sy, -sp);
    let x = Vector3::new(sy, -cy, 0.0);
    let y = z.cross(&x);
    let r = Matrix3::from_columns(&[x, y, z]).map(|v| if v.abs() < 1e-15 { 0.0 } else { v });
    Pose::new(r, position)
}

/// Reads a calibration file (format detected from its keys) and builds the rig with camera 0 at
/// `mount`.
pub fn import_calibration(
    path: impl AsRef<Path>,
    mount: &Pose<f64>,
) -> Result<(Rig, CalibrationFormat), IoError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, e))?;
    if bytes.len() > MAX_CALIBRATION_BYTES {
        return Err(IoError::file(
            path,
            IoErrorKind::TooLong {
                limit: MAX_CALIBRATION_BYTES,
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
    import_calibration_from_str(text, path, mount)
}

/// [`import_calibration`] on text; `path` only names the file in errors.
pub fn import_calibration_from_str(
    text: &str,
    path: impl AsRef<Path>,
    mount: &Pose<f64>,
) -> Result<(Rig, CalibrationFormat), IoError> {
    let path = path.as_ref();
    let root = parse_yaml(text, path)?;
    let doc = Doc { path };
    doc.map(&root, "the calibration file")?;
    let (cameras, format) = if doc.get(&root, "cam0").is_some() {
        (kalibr(&doc, &root, mount)?, CalibrationFormat::Kalibr)
    } else if doc.get(&root, "camera_matrix").is_some() || doc.get(&root, "K").is_some() {
        let format = if text.contains("!!opencv-matrix") || text.starts_with("%YAML:") {
            CalibrationFormat::OpenCv
        } else {
            CalibrationFormat::RosCameraInfo
        };
        let camera = single(&doc, &root)?;
        (
            vec![RigCamera {
                name: "cam0".into(),
                model: camera,
                t_vehicle_camera: *mount,
            }],
            format,
        )
    } else {
        return Err(doc.err(
            root.line,
            "unknown calibration format: expected `camera_matrix` (OpenCV FileStorage or ROS \
             camera_info YAML), `K` (ROS CameraInfo message) or `cam0` (Kalibr camchain)",
        ));
    };
    let rig = Rig::new(cameras).map_err(|e| IoError::file(path, IoErrorKind::Rig(e)))?;
    Ok((rig, format))
}

/// [`import_calibration`] and [`write_rig`] (atomic): the `rig.json` for a calibration file.
pub fn import_to_rig_json(
    input: impl AsRef<Path>,
    output: impl AsRef<Path>,
    mount: &Pose<f64>,
) -> Result<(Rig, CalibrationFormat), IoError> {
    let (rig, format) = import_calibration(input, mount)?;
    write_rig(output, &rig)?;
    Ok((rig, format))
}

/// Checks a built model as `rig.json` would, with the error at `line`.
fn checked(doc: &Doc, camera: Camera, line: usize) -> Result<Camera, IoError> {
    check_camera(&camera).map_err(|f| doc.err(line, f.reason))?;
    Ok(camera)
}

/// One camera of an OpenCV FileStorage or ROS camera_info file.
fn single(doc: &Doc, root: &Node) -> Result<Camera, IoError> {
    let message_form = doc.get(root, "camera_matrix").is_none();
    let (k_key, d_key, w_key, h_key) = if message_form {
        ("K", "D", "width", "height")
    } else {
        (
            "camera_matrix",
            "distortion_coefficients",
            "image_width",
            "image_height",
        )
    };
    let k_node = doc.require(root, k_key, "")?;
    let (rows, cols, k, k_line) = doc.matrix(k_node, k_key)?;
    if rows * cols != 9 || !(rows == 3 || rows == 1) {
        return Err(doc.err(
            k_line,
            format!("`{k_key}` must be 3x3, found {rows}x{cols}"),
        ));
    }
    let (fx, skew, cx, fy, cy) = (k[0], k[1], k[2], k[4], k[5]);
    if skew != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(doc.err(
            k_line,
            format!(
                "`{k_key}` must be [fx 0 cx; 0 fy cy; 0 0 1] (no skew), found {:?}",
                k
            ),
        ));
    }
    let width = doc.whole(doc.require(root, w_key, "")?, w_key)?;
    let height = doc.whole(doc.require(root, h_key, "")?, h_key)?;
    let model_node = doc.get(root, "distortion_model");
    let model = match model_node {
        Some(n) => doc.text(n, "distortion_model")?.to_owned(),
        None => "plumb_bob".to_owned(),
    };
    let (d, d_line) = match doc.get(root, d_key) {
        Some(n) => {
            let (_, _, d, line) = doc.matrix(n, d_key)?;
            (d, line)
        }
        None => (Vec::new(), root.line),
    };
    let pinhole = Pinhole {
        fx,
        fy,
        cx,
        cy,
        width,
        height,
    };
    let camera = distortion(
        doc,
        &pinhole,
        &model,
        &d,
        model_node.map_or(d_line, |n| n.line),
        d_line,
    )?;
    checked(doc, camera, k_line)
}

/// The model of a pinhole camera with distortion `model` (OpenCV/ROS/Kalibr names) and its
/// coefficients.
fn distortion(
    doc: &Doc,
    p: &Pinhole,
    model: &str,
    d: &[f64],
    model_line: usize,
    d_line: usize,
) -> Result<Camera, IoError> {
    let all_zero = |v: &[f64]| v.iter().all(|&x| x == 0.0);
    match model {
        "plumb_bob" | "radtan" | "rational_polynomial" | "radial-tangential" => {
            let extra_ok = match d.len() {
                0 | 4 | 5 => true,
                8 | 12 | 14 => all_zero(&d[5..]),
                _ => false,
            };
            if !extra_ok {
                return Err(doc.err(
                    d_line,
                    format!(
                        "{} distortion coefficients: expected 4 or 5 (k1 k2 p1 p2 [k3]); the \
                         rational and thin-prism terms (8, 12, 14 coefficients) must be zero",
                        d.len()
                    ),
                ));
            }
            if all_zero(d) {
                return Ok(Camera::Pinhole(*p));
            }
            Ok(Camera::Radtan(Radtan {
                fx: p.fx,
                fy: p.fy,
                cx: p.cx,
                cy: p.cy,
                k1: d[0],
                k2: d[1],
                p1: d[2],
                p2: d[3],
                k3: d.get(4).copied().unwrap_or(0.0),
                width: p.width,
                height: p.height,
            }))
        }
        "equidistant" | "fisheye" => {
            if d.len() != 4 {
                return Err(doc.err(
                    d_line,
                    format!(
                        "{} equidistant coefficients: expected 4 (k1 k2 k3 k4)",
                        d.len()
                    ),
                ));
            }
            Ok(Camera::KannalaBrandt(KannalaBrandt {
                fx: p.fx,
                fy: p.fy,
                cx: p.cx,
                cy: p.cy,
                k1: d[0],
                k2: d[1],
                k3: d[2],
                k4: d[3],
                width: p.width,
                height: p.height,
            }))
        }
        "none" => {
            if !all_zero(d) {
                return Err(doc.err(d_line, "distortion model `none` with non-zero coefficients"));
            }
            Ok(Camera::Pinhole(*p))
        }
        other => Err(doc.err(
            model_line,
            format!(
                "distortion model `{}` is not supported: expected plumb_bob/radtan, \
                 rational_polynomial (extra terms zero), equidistant/fisheye or none",
                crate::error::quote(other)
            ),
        )),
    }
}

/// The cameras of a Kalibr camchain.
fn kalibr(doc: &Doc, root: &Node, mount: &Pose<f64>) -> Result<Vec<RigCamera>, IoError> {
    let mut cameras: Vec<RigCamera> = Vec::new();
    for n in 0.. {
        let name = format!("cam{n}");
        let Some(cam) = doc.get(root, &name) else {
            break;
        };
        doc.map(cam, &format!("`{name}`"))?;
        let ctx = format!("`{name}`: ");
        let model_node = doc.require(cam, "camera_model", &ctx)?;
        let camera_model = doc.text(model_node, "camera_model")?;
        let intr_node = doc.require(cam, "intrinsics", &ctx)?;
        let intr = doc.numbers(intr_node, "intrinsics")?;
        let res_node = doc.require(cam, "resolution", &ctx)?;
        let res = doc.numbers(res_node, "resolution")?;
        if res.len() != 2 || res.iter().any(|v| !(*v > 0.0 && v.fract() == 0.0)) {
            return Err(doc.err(
                res_node.line,
                format!("{ctx}`resolution` must be [width, height] in whole pixels"),
            ));
        }
        let (dist_model, dist_line) = match doc.get(cam, "distortion_model") {
            Some(n) => (doc.text(n, "distortion_model")?.to_owned(), n.line),
            None => ("none".to_owned(), cam.line),
        };
        let (d, d_line) = match doc.get(cam, "distortion_coeffs") {
            Some(n) => (doc.numbers(n, "distortion_coeffs")?, n.line),
            None => (Vec::new(), cam.line),
        };
        let expect = |count: usize, layout: &str| -> Result<(), IoError> {
            if intr.len() == count {
                Ok(())
            } else {
                Err(doc.err(
                    intr_node.line,
                    format!(
                        "{ctx}camera_model `{camera_model}` needs {count} intrinsics \
                         [{layout}], found {}",
                        intr.len()
                    ),
                ))
            }
        };
        let no_distortion = |what: &str| -> Result<(), IoError> {
            if dist_model == "none" || d.iter().all(|&v| v == 0.0) {
                Ok(())
            } else {
                Err(doc.err(
                    d_line,
                    format!(
                        "{ctx}{what} with {dist_model} distortion is not supported (only zero \
                         coefficients)"
                    ),
                ))
            }
        };
        let (w, h) = (res[0], res[1]);
        let model = match camera_model {
            "pinhole" => {
                expect(4, "fu, fv, pu, pv")?;
                let p = Pinhole {
                    fx: intr[0],
                    fy: intr[1],
                    cx: intr[2],
                    cy: intr[3],
                    width: w,
                    height: h,
                };
                distortion(doc, &p, &dist_model, &d, dist_line, d_line)?
            }
            "omni" => {
                expect(5, "xi, fu, fv, pu, pv")?;
                no_distortion("omni")?;
                Camera::Unified(Unified {
                    xi: intr[0],
                    fx: intr[1],
                    fy: intr[2],
                    cx: intr[3],
                    cy: intr[4],
                    width: w,
                    height: h,
                })
            }
            "ds" => {
                expect(6, "xi, alpha, fu, fv, pu, pv")?;
                no_distortion("ds")?;
                Camera::DoubleSphere(DoubleSphere {
                    xi: intr[0],
                    alpha: intr[1],
                    fx: intr[2],
                    fy: intr[3],
                    cx: intr[4],
                    cy: intr[5],
                    width: w,
                    height: h,
                })
            }
            "eucm" => {
                expect(6, "alpha, beta, fu, fv, pu, pv")?;
                no_distortion("eucm")?;
                let (alpha, beta) = (intr[0], intr[1]);
                // EUCM with β = 1 is the unified model in α form:
                // α d + (1 − α) Z = (1 − α)(Z + ξ d) with ξ = α / (1 − α).
                if beta != 1.0 || !(0.0..1.0).contains(&alpha) {
                    return Err(doc.err(
                        intr_node.line,
                        format!(
                            "{ctx}eucm is imported only with beta = 1 and 0 <= alpha < 1 (then \
                             it is the unified model); found alpha {alpha}, beta {beta}"
                        ),
                    ));
                }
                Camera::Unified(Unified {
                    xi: alpha / (1.0 - alpha),
                    fx: intr[2] / (1.0 - alpha),
                    fy: intr[3] / (1.0 - alpha),
                    cx: intr[4],
                    cy: intr[5],
                    width: w,
                    height: h,
                })
            }
            other => {
                return Err(doc.err(
                    model_node.line,
                    format!(
                        "{ctx}camera_model `{}` is not supported: expected pinhole, omni, ds or \
                         eucm",
                        crate::error::quote(other)
                    ),
                ));
            }
        };
        let model = checked(doc, model, intr_node.line)?;
        let t_vehicle_camera = match cameras.last() {
            None => *mount,
            Some(prev) => {
                let t_node = doc.require(cam, "T_cn_cnm1", &ctx)?;
                let t = chain_transform(doc, t_node, &name)?;
                prev.t_vehicle_camera.compose(&t.inverse())
            }
        };
        cameras.push(RigCamera {
            name,
            model,
            t_vehicle_camera,
        });
    }
    Ok(cameras)
}

/// Kalibr's `T_cn_cnm1`: four rows of four numbers, bottom row `0 0 0 1`, orthonormal rotation.
fn chain_transform(doc: &Doc, node: &Node, name: &str) -> Result<Pose<f64>, IoError> {
    let bad = |line: usize, why: String| doc.err(line, format!("`{name}.T_cn_cnm1`: {why}"));
    let Value::Seq(rows) = &node.value else {
        return Err(bad(node.line, "must be a list of 4 rows".into()));
    };
    if rows.len() != 4 {
        return Err(bad(
            node.line,
            format!("must have 4 rows, found {}", rows.len()),
        ));
    }
    let mut m = Matrix4::zeros();
    for (i, row) in rows.iter().enumerate() {
        let v = doc.numbers(row, "T_cn_cnm1")?;
        if v.len() != 4 {
            return Err(bad(
                row.line,
                format!("row {i} has {} entries, expected 4", v.len()),
            ));
        }
        for (j, x) in v.into_iter().enumerate() {
            m[(i, j)] = x;
        }
    }
    let bottom = [0.0, 0.0, 0.0, 1.0];
    if (0..4).any(|j| (m[(3, j)] - bottom[j]).abs() > CHAIN_ORTHONORMAL_TOLERANCE) {
        return Err(bad(rows[3].line, "the bottom row must be 0 0 0 1".into()));
    }
    let pose = Pose::from_homogeneous(&m);
    let error = pose.orthonormality_error();
    if !(error <= CHAIN_ORTHONORMAL_TOLERANCE) {
        return Err(bad(
            node.line,
            format!(
                "the rotation is not orthonormal with determinant +1 (error {error:.3e}, \
                 tolerance {CHAIN_ORTHONORMAL_TOLERANCE:e})"
            ),
        ));
    }
    // Re-orthonormalise so that the rig's tighter tolerance holds after chaining.
    let svd = pose.rotation.svd(true, true);
    let rotation = match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => u * v_t,
        _ => pose.rotation,
    };
    Ok(Pose::new(rotation, pose.translation))
}
