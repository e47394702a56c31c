//! `momo.Rig`: the cameras of a vehicle, from `rig.json` or from arrays.

use crate::convert::{json_to_py, pose_from_py, pose_to_py, py_to_json};
use crate::errors::{RigError, input_error};
use momo_core::{Camera, Rig, RigCamera};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// A camera rig: camera models with their intrinsics and each camera's pose in the vehicle
/// frame `T_vehicle_camera` (4x4, camera to vehicle). Camera 0 is the reference camera of
/// trajectories.
///
/// `Rig(cameras)` takes a list of dicts, each with `model` (a dict as in rig.json:
/// `{"type": "pinhole", "fx", "fy", "cx", "cy", "width", "height"}` or
/// `{"type": "kannala_brandt", ... , "k1".."k4"}`), `T_vehicle_camera` (4x4 array-like) and
/// optionally `name`. The rig is checked as rig.json is (`RigError` otherwise).
#[pyclass(module = "momo", name = "Rig", frozen)]
pub struct PyRig {
    /// The rig.
    pub inner: Rig,
}

/// One camera from a dict.
fn camera_from_dict(py: Python<'_>, j: usize, d: &Bound<'_, PyAny>) -> PyResult<RigCamera> {
    let d = d
        .cast::<PyDict>()
        .map_err(|_| RigError::new_err(format!("cameras[{j}]: expected a dict")))?;
    let model = d.get_item("model")?.ok_or_else(|| {
        RigError::new_err(format!(
            "cameras[{j}]: missing `model` (a dict with `type`)"
        ))
    })?;
    let t = d.get_item("T_vehicle_camera")?.ok_or_else(|| {
        RigError::new_err(format!("cameras[{j}]: missing `T_vehicle_camera` (4x4)"))
    })?;
    let name = match d.get_item("name")? {
        Some(n) => n.extract::<String>()?,
        None => format!("cam{j}"),
    };
    for key in d.keys() {
        let k: String = key.extract()?;
        if !["model", "T_vehicle_camera", "name"].contains(&k.as_str()) {
            return Err(RigError::new_err(format!(
                "cameras[{j}]: unknown key `{k}` (expected name, model, T_vehicle_camera)"
            )));
        }
    }
    let model: Camera = serde_json::from_value(py_to_json(&model)?)
        .map_err(|e| RigError::new_err(format!("cameras[{j}].model: {e}")))?;
    let t_vehicle_camera = pose_from_py(&t, &format!("cameras[{j}].T_vehicle_camera"))
        .map_err(|e| RigError::new_err(e.value(py).to_string()))?;
    Ok(RigCamera {
        name,
        model,
        t_vehicle_camera,
    })
}

/// A rig from cameras, checked as rig.json is: the rig's own checks (cameras, orthonormal
/// extrinsics), then the file reader's (intrinsics) on its JSON text.
pub fn rig_from_cameras(cameras: Vec<RigCamera>) -> PyResult<Rig> {
    let rig = Rig::new(cameras).map_err(|e| RigError::new_err(e.to_string()))?;
    let text = momo_io::rig_to_json(&rig).map_err(|e| RigError::new_err(format!("<Rig>: {e}")))?;
    momo_io::read_rig_from_str(&text, "<Rig>").map_err(|e| RigError::new_err(e.to_string()))?;
    Ok(rig)
}

#[pymethods]
impl PyRig {
    /// A rig from a list of camera dicts (see the class docstring).
    #[new]
    fn new(py: Python<'_>, cameras: &Bound<'_, PyAny>) -> PyResult<Self> {
        let list: Vec<Bound<'_, PyAny>> = cameras
            .try_iter()
            .map_err(|_| RigError::new_err("cameras: expected a list of camera dicts"))?
            .collect::<PyResult<_>>()?;
        let cams = list
            .iter()
            .enumerate()
            .map(|(j, d)| camera_from_dict(py, j, d))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(Self {
            inner: rig_from_cameras(cams)?,
        })
    }

    /// A one-camera rig: `model` a dict as in rig.json, `T_vehicle_camera` 4x4.
    #[staticmethod]
    #[pyo3(signature = (model, T_vehicle_camera, name = "cam0"))]
    #[allow(non_snake_case)]
    fn mono(
        py: Python<'_>,
        model: &Bound<'_, PyAny>,
        T_vehicle_camera: &Bound<'_, PyAny>,
        name: &str,
    ) -> PyResult<Self> {
        let d = PyDict::new(py);
        d.set_item("model", model)?;
        d.set_item("T_vehicle_camera", T_vehicle_camera)?;
        d.set_item("name", name)?;
        Ok(Self {
            inner: rig_from_cameras(vec![camera_from_dict(py, 0, d.as_any())?])?,
        })
    }

    /// Reads a rig.json file (`InputError` with `file:line: reason` if it is malformed).
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        momo_io::read_rig(&path)
            .map(|inner| Self { inner })
            .map_err(|e| input_error(py, &e))
    }

    /// Parses rig.json text; `name` is used in messages (`name:line: reason`).
    #[staticmethod]
    #[pyo3(signature = (text, name = "<rig.json>"))]
    fn from_json(py: Python<'_>, text: &str, name: &str) -> PyResult<Self> {
        momo_io::read_rig_from_str(text, name)
            .map(|inner| Self { inner })
            .map_err(|e| input_error(py, &e))
    }

    /// The rig as rig.json text.
    fn to_json(&self) -> PyResult<String> {
        momo_io::rig_to_json(&self.inner).map_err(|e| RigError::new_err(e.to_string()))
    }

    /// Writes rig.json (atomically).
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        momo_io::write_rig(&path, &self.inner).map_err(|e| input_error(py, &e))
    }

    /// The cameras: a list of dicts with `name`, `model` (dict) and `T_vehicle_camera` (4x4).
    #[getter]
    fn cameras<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let items = self
            .inner
            .cameras()
            .iter()
            .map(|c| {
                let d = PyDict::new(py);
                d.set_item("name", &c.name)?;
                let model =
                    serde_json::to_value(c.model).map_err(|e| RigError::new_err(e.to_string()))?;
                d.set_item("model", json_to_py(py, &model)?)?;
                d.set_item("T_vehicle_camera", pose_to_py(py, &c.t_vehicle_camera))?;
                Ok(d)
            })
            .collect::<PyResult<Vec<_>>>()?;
        PyList::new(py, items)
    }

    /// Largest distance of a camera centre from the vehicle origin in metres (scale is
    /// observable from rotation only if it is non-zero).
    #[getter]
    fn max_lever_arm(&self) -> f64 {
        self.inner.max_lever_arm()
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyRig>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }

    fn __repr__(&self) -> String {
        let models: Vec<&str> = self
            .inner
            .cameras()
            .iter()
            .map(|c| match c.model {
                Camera::Pinhole(_) => "pinhole",
                Camera::KannalaBrandt(_) => "kannala_brandt",
                Camera::Radtan(_) => "radtan",
                Camera::DoubleSphere(_) => "double_sphere",
                Camera::Unified(_) => "unified",
            })
            .collect();
        format!("Rig({} camera(s): {})", self.inner.len(), models.join(", "))
    }
}
