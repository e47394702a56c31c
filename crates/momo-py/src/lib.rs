//! # momo-py
//!
//! The Python bindings of momo: the extension module `momo._momo`, re-exported by the Python
//! package `momo` (`python/momo/__init__.py`). Built with maturin (`pyproject.toml`); numpy
//! arrays in and out, in the manner of PoseLib and pycolmap.
//!
//! - [`config::PyConfig`] (`momo.Config`): the estimator configuration of `momo run`.
//! - [`rig::PyRig`] (`momo.Rig`): the cameras, from `rig.json` or from arrays.
//! - [`odometry::PyOdometry`] (`momo.Odometry`): `process(matches, arc_length)` per frame pair,
//!   the GIL released while it estimates; [`odometry::estimate`] for one frame pair without state.
//! - [`sequence`]: `momo.run`, `momo.simulate`, `momo.evaluate`, `momo.read_poses`,
//!   `momo.Sequence`.
//!
//! Errors are Python exceptions deriving from `momo.MomoError` carrying momo's message
//! (`file:line: reason` for files); see [`errors`]. The tests are pytest's (`python/tests`, run by
//! `scripts/python_test.sh`); `docs/PYTHON.md` is the guide.

pub mod config;
pub mod convert;
pub mod errors;
pub mod odometry;
pub mod rig;
pub mod sequence;

use pyo3::prelude::*;

/// The extension module `momo._momo`.
#[pymodule]
fn _momo(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MomoError", py.get_type::<errors::MomoError>())?;
    m.add("InputError", py.get_type::<errors::InputError>())?;
    m.add("ConfigError", py.get_type::<errors::ConfigError>())?;
    m.add("RigError", py.get_type::<errors::RigError>())?;
    m.add("MatchError", py.get_type::<errors::MatchError>())?;
    m.add("EstimationError", py.get_type::<errors::EstimationError>())?;
    m.add("SimulationError", py.get_type::<errors::SimulationError>())?;
    m.add_class::<config::PyConfig>()?;
    m.add_class::<rig::PyRig>()?;
    m.add_class::<odometry::PyOdometry>()?;
    m.add_class::<odometry::PyDiagnostics>()?;
    m.add_class::<sequence::PySequence>()?;
    m.add_function(wrap_pyfunction!(odometry::estimate, m)?)?;
    m.add_function(wrap_pyfunction!(odometry::native_process_loop, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::run, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::read_poses, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::scenarios, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
