//! Conversions between Python/numpy values and momo's types: JSON-like values (exact: no text
//! round trip, so a float keeps every bit), poses as 4x4 arrays, matches as (N, 4) arrays.

use crate::errors::MatchError;
use momo_core::{Camera, CameraModel, FrameObservations, Observation, Pose, Rig};
use momo_io::{IoErrorKind, PIXEL_MARGIN_FRACTION};
use nalgebra::{Matrix4, Vector2};
use numpy::ndarray::{Array2, Array3, ArrayView2};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::Value;

/// A Python value (None, bool, int, float, str, dict with str keys, list, tuple, or anything
/// with numpy's `tolist()`) as a JSON value. Floats are carried as `f64`, bit for bit.
pub fn py_to_json(obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    if obj.is_none() {
        return Ok(Value::Null);
    }
    if obj.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(obj.extract::<bool>()?));
    }
    if obj.is_instance_of::<PyInt>() {
        if let Ok(v) = obj.extract::<i64>() {
            return Ok(Value::from(v));
        }
        return Ok(Value::from(obj.extract::<u64>()?));
    }
    if obj.is_instance_of::<PyFloat>() {
        let v = obj.extract::<f64>()?;
        return serde_json::Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| PyTypeError::new_err(format!("a non-finite number ({v})")));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::String(s.extract::<String>()?));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err(format!("a dict key that is not a str: {k}")))?;
            map.insert(key, py_to_json(&v)?);
        }
        return Ok(Value::Object(map));
    }
    if let Ok(l) = obj.cast::<PyList>() {
        return l.iter().map(|v| py_to_json(&v)).collect();
    }
    if let Ok(t) = obj.cast::<PyTuple>() {
        return t.iter().map(|v| py_to_json(&v)).collect();
    }
    if obj.hasattr("tolist")? {
        return py_to_json(&obj.call_method0("tolist")?);
    }
    Err(PyTypeError::new_err(format!(
        "cannot convert a {} to a configuration value",
        obj.get_type().name()?
    )))
}

/// A JSON value as a Python value (dict, list, str, int, float, bool, None).
pub fn json_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) => {
            if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else {
                PyFloat::new(py, n.as_f64().unwrap_or(f64::NAN)).into_any()
            }
        }
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| json_to_py(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// A pose as a row-major 4x4 array.
pub fn pose_to_array(p: &Pose<f64>) -> Array2<f64> {
    let m = p.to_homogeneous();
    Array2::from_shape_fn((4, 4), |(r, c)| m[(r, c)])
}

/// A pose as a 4x4 numpy array.
pub fn pose_to_py<'py>(py: Python<'py>, p: &Pose<f64>) -> Bound<'py, PyArray2<f64>> {
    pose_to_array(p).into_pyarray(py)
}

/// Poses as an (N, 4, 4) numpy array.
pub fn poses_to_py<'py>(py: Python<'py>, poses: &[Pose<f64>]) -> Bound<'py, PyArray3<f64>> {
    let mut a = Array3::<f64>::zeros((poses.len(), 4, 4));
    for (k, p) in poses.iter().enumerate() {
        let m = p.to_homogeneous();
        for r in 0..4 {
            for c in 0..4 {
                a[(k, r, c)] = m[(r, c)];
            }
        }
    }
    a.into_pyarray(py)
}

/// `obj` as a float64 numpy array (as is if it already is one, else through `numpy.asarray`).
pub fn as_f64_array<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    np.call_method1("asarray", (obj, np.getattr("float64")?))
}

/// A pose from a 4x4 (or 3x4) array-like; `what` names it in messages.
pub fn pose_from_py(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Pose<f64>> {
    let arr = as_f64_array(obj)?;
    let arr: PyReadonlyArray2<'_, f64> = arr.extract().map_err(|_| {
        PyTypeError::new_err(format!("{what}: expected a 4x4 (or 3x4) array of floats"))
    })?;
    pose_from_view(&arr.as_array(), what).map_err(PyTypeError::new_err)
}

/// A pose from a 4x4 or 3x4 view (the last row of a 4x4 is not checked).
pub fn pose_from_view(a: &ArrayView2<'_, f64>, what: &str) -> Result<Pose<f64>, String> {
    let (rows, cols) = a.dim();
    if !((rows == 4 || rows == 3) && cols == 4) {
        return Err(format!(
            "{what}: expected a 4x4 (or 3x4) array, got shape ({rows}, {cols})"
        ));
    }
    if a.iter().any(|v| !v.is_finite()) {
        return Err(format!("{what}: non-finite entries"));
    }
    let mut m = Matrix4::identity();
    for r in 0..3 {
        for c in 0..4 {
            m[(r, c)] = a[(r, c)];
        }
    }
    Ok(Pose::from_homogeneous(&m))
}

/// Poses from an (N, 4, 4), (N, 3, 4) or (N, 12) array-like (KITTI rows) or a list of 4x4s;
/// each rotation must be orthonormal (the tolerance of `FORMAT.md`'s poses files).
pub fn poses_from_py(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<Vec<Pose<f64>>> {
    let arr = as_f64_array(obj)?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let arr = match shape.as_slice() {
        [n, 12] => arr.call_method1("reshape", ((*n, 3usize, 4usize),))?,
        [_, 3 | 4, 4] => arr,
        [0] => return Ok(Vec::new()),
        _ => {
            return Err(input_err(
                py,
                format!(
                    "{what}: expected an (N, 4, 4), (N, 3, 4) or (N, 12) array, got shape {shape:?}"
                ),
            ));
        }
    };
    let arr: numpy::PyReadonlyArray3<'_, f64> = arr.extract()?;
    let view = arr.as_array();
    let mut poses = Vec::with_capacity(view.dim().0);
    for (k, m) in view.outer_iter().enumerate() {
        let p = pose_from_view(&m, &format!("{what}[{k}]")).map_err(|e| input_err(py, e))?;
        let e = p.orthonormality_error();
        if !(e <= momo_io::POSE_ORTHONORMAL_TOLERANCE) {
            return Err(input_err(
                py,
                format!(
                    "{what}[{k}]: the rotation is not orthonormal (error {e:.2e} > {:e})",
                    momo_io::POSE_ORTHONORMAL_TOLERANCE
                ),
            ));
        }
        poses.push(p);
    }
    Ok(poses)
}

fn input_err(py: Python<'_>, message: String) -> PyErr {
    crate::errors::input_error_at(py, message, None, None)
}

/// Fills `obs` with the matches of one frame pair: a sequence with one entry per camera of the
/// rig, each an (N, 4) array-like of pixels `(u0, v0, u1, v1)` or `None` (no matches). Every
/// pixel is checked as `matches.csv`'s reader checks it (finite, within
/// [`PIXEL_MARGIN_FRACTION`] of the image, unprojectable), and unprojected by the camera model
/// as the reader does, so the same pixels give the same bearings bit for bit.
pub fn fill_observations(
    rig: &Rig,
    matches: &Bound<'_, PyAny>,
    obs: &mut FrameObservations,
) -> PyResult<()> {
    let n = rig.len();
    obs.per_camera.resize_with(n, Vec::new);
    obs.clear();
    if matches.is_instance_of::<PyString>() || matches.is_instance_of::<PyDict>() {
        return Err(MatchError::new_err(format!(
            "matches must be a list with one (N, 4) array per camera ({n}), not a {}",
            matches.get_type().name()?
        )));
    }
    let len = matches.len().map_err(|_| {
        MatchError::new_err(format!(
            "matches must be a list with one (N, 4) array per camera ({n})"
        ))
    })?;
    if len != n {
        return Err(MatchError::new_err(format!(
            "matches has {len} entries, but the rig has {n} camera(s): give one (N, 4) array (or None) per camera"
        )));
    }
    for (j, (cam, list)) in rig
        .cameras()
        .iter()
        .zip(obs.per_camera.iter_mut())
        .enumerate()
    {
        let item = matches.get_item(j)?;
        if item.is_none() {
            continue;
        }
        let converted;
        let arr: PyReadonlyArray2<'_, f64> = match item.extract() {
            Ok(a) => a,
            Err(_) => {
                converted = as_f64_array(&item).map_err(|e| {
                    MatchError::new_err(format!("matches[{j}]: not an array of numbers ({e})"))
                })?;
                let size: usize = converted.getattr("size")?.extract()?;
                if size == 0 {
                    continue;
                }
                converted.extract().map_err(|_| {
                    let shape = converted
                        .getattr("shape")
                        .map(|s| s.to_string())
                        .unwrap_or_default();
                    MatchError::new_err(format!(
                        "matches[{j}]: expected an (N, 4) array, got shape {shape}"
                    ))
                })?
            }
        };
        let view = arr.as_array();
        if view.is_empty() {
            continue;
        }
        if view.ncols() != 4 {
            return Err(MatchError::new_err(format!(
                "matches[{j}]: expected an (N, 4) array (u0, v0, u1, v1), got shape ({}, {})",
                view.nrows(),
                view.ncols()
            )));
        }
        list.reserve(view.nrows());
        let margin = pixel_margin(&cam.model);
        for (i, row) in view.rows().into_iter().enumerate() {
            let px0 = Vector2::new(row[0], row[1]);
            let px1 = Vector2::new(row[2], row[3]);
            if row.iter().any(|v| !v.is_finite()) {
                return Err(MatchError::new_err(format!(
                    "matches[{j}] row {i}: non-finite pixel ({}, {}, {}, {})",
                    row[0], row[1], row[2], row[3]
                )));
            }
            let f0 = check_pixel(&cam.model, margin, j, "u0,v0", px0)
                .map_err(|e| MatchError::new_err(format!("matches[{j}] row {i}: {e}")))?;
            let f1 = check_pixel(&cam.model, margin, j, "u1,v1", px1)
                .map_err(|e| MatchError::new_err(format!("matches[{j}] row {i}: {e}")))?;
            list.push(Observation { px0, px1, f0, f1 });
        }
    }
    Ok(())
}

/// The margin in pixels outside the image within which the reader accepts pixels.
fn pixel_margin(model: &Camera) -> f64 {
    let (w, h) = model.size();
    PIXEL_MARGIN_FRACTION * w.max(h)
}

/// As `momo_io`'s reader: within the margin of the image, then unprojected.
fn check_pixel(
    model: &Camera,
    margin: f64,
    camera: usize,
    field: &'static str,
    px: Vector2<f64>,
) -> Result<nalgebra::Vector3<f64>, IoErrorKind> {
    let (u, v) = (px.x, px.y);
    if !model.contains(&px, margin) {
        let (width, height) = model.size();
        return Err(IoErrorKind::PixelOutsideImage {
            field,
            camera,
            u,
            v,
            margin,
            width,
            height,
        });
    }
    model.unproject(&px).ok_or(IoErrorKind::Unprojectable {
        field,
        camera,
        u,
        v,
    })
}

/// One frame pair's matches as a list of (N, 4) arrays, one per camera.
pub fn observations_to_py<'py>(
    py: Python<'py>,
    obs: &FrameObservations,
) -> PyResult<Bound<'py, PyList>> {
    let arrays = obs.per_camera.iter().map(|list| {
        Array2::from_shape_fn((list.len(), 4), |(i, c)| {
            let o = &list[i];
            [o.px0.x, o.px0.y, o.px1.x, o.px1.y][c]
        })
        .into_pyarray(py)
    });
    PyList::new(py, arrays)
}
