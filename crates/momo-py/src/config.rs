//! `momo.Config`: the estimator configuration of `momo run` (`momo config` prints the default).

use crate::convert::{json_to_py, py_to_json};
use crate::errors::{ConfigError, config_error};
use momo_vo::Config;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use serde_json::Value;

/// Sections replaced by a type tag (`"cauchy"`) or a dict (`{"type": "cauchy", "scale": 0.002}`;
/// a dict without `type`, or with the current one, changes only the keys it gives).
const TAGGED: &[&str] = &["model", "metric", "loss", "solver", "refine_loss"];
/// Sections whose keys are merged.
const PLAIN: &[&str] = &["odometry", "five_point"];

/// The estimator configuration: motion model, residual metric, robust loss, solver, the odometry
/// driver's options and the 5-point baseline's options (`momo config` prints the default with
/// comments).
///
/// `Config(**sections)` starts from the default and changes the sections given: a tagged
/// section (`model`, `metric`, `loss`, `solver`, `refine_loss`) by its type name
/// (`loss="huber"`) or a dict (`loss={"type": "cauchy", "scale": 0.002}`; without `type` only
/// the keys given change), `odometry` and `five_point` by a dict of the keys to change;
/// `refine_loss=None` removes the second loss. Unknown sections or keys raise `ConfigError`.
#[pyclass(module = "momo", name = "Config", frozen)]
pub struct PyConfig {
    /// The configuration.
    pub inner: Config,
}

impl PyConfig {
    /// A copy of the configuration (through its serialised value: every float keeps its bits).
    pub fn to_config(&self) -> PyResult<Config> {
        clone_config(&self.inner)
    }
}

/// A copy of a configuration (the type is not `Clone`: its parts are trait objects).
pub fn clone_config(c: &Config) -> PyResult<Config> {
    let v = serde_json::to_value(c)
        .map_err(|e| ConfigError::new_err(format!("cannot serialise the configuration: {e}")))?;
    from_value(v, "<copy>")
}

/// A configuration from a JSON value, validated; `name` goes into messages.
pub fn from_value(v: Value, name: &str) -> PyResult<Config> {
    let c: Config =
        serde_json::from_value(v).map_err(|e| ConfigError::new_err(format!("{name}: {e}")))?;
    c.validate(name).map_err(|e| config_error(&e))?;
    Ok(c)
}

/// The default configuration changed by keyword sections (see [`PyConfig`]).
pub fn from_sections(kwargs: Option<&Bound<'_, PyDict>>, name: &str) -> PyResult<Config> {
    let mut v = serde_json::to_value(Config::default())
        .map_err(|e| ConfigError::new_err(format!("cannot serialise the default: {e}")))?;
    if let Some(kwargs) = kwargs {
        for (k, val) in kwargs.iter() {
            let key: String = k.extract()?;
            apply_section(&mut v, &key, &val, name)?;
        }
    }
    from_value(v, name)
}

/// Applies one keyword section to a configuration value.
pub fn apply_section(v: &mut Value, key: &str, val: &Bound<'_, PyAny>, name: &str) -> PyResult<()> {
    let Value::Object(root) = v else {
        return Err(ConfigError::new_err("the configuration is not a table"));
    };
    if TAGGED.contains(&key) {
        if val.is_none() {
            if key == "refine_loss" {
                root.remove(key);
                return Ok(());
            }
            return Err(ConfigError::new_err(format!(
                "{name}: `{key}` cannot be None"
            )));
        }
        let new = if let Ok(s) = val.cast::<PyString>() {
            let mut m = serde_json::Map::new();
            m.insert("type".into(), Value::String(s.extract::<String>()?));
            Value::Object(m)
        } else {
            py_to_json(val)?
        };
        let Value::Object(new) = new else {
            return Err(ConfigError::new_err(format!(
                "{name}: `{key}` must be a type name (str) or a dict"
            )));
        };
        let current = root.get(key).and_then(|c| c.get("type")).cloned();
        let same_type = match new.get("type") {
            None => true,
            Some(t) => Some(t) == current.as_ref(),
        };
        match root.get_mut(key) {
            Some(Value::Object(cur)) if same_type => {
                for (k, x) in new {
                    cur.insert(k, x);
                }
            }
            _ => {
                if !new.contains_key("type") {
                    return Err(ConfigError::new_err(format!(
                        "{name}: `{key}` needs a `type`"
                    )));
                }
                root.insert(key.to_string(), Value::Object(new));
            }
        }
        Ok(())
    } else if PLAIN.contains(&key) {
        let Value::Object(new) = py_to_json(val)? else {
            return Err(ConfigError::new_err(format!(
                "{name}: `{key}` must be a dict of options"
            )));
        };
        let section = root
            .entry(key.to_string())
            .or_insert_with(|| Value::Object(Default::default()));
        if let Value::Object(cur) = section {
            for (k, x) in new {
                cur.insert(k, x);
            }
        }
        Ok(())
    } else {
        Err(ConfigError::new_err(format!(
            "{name}: unknown section `{key}` (expected one of model, metric, loss, solver, refine_loss, odometry, five_point)"
        )))
    }
}

#[pymethods]
impl PyConfig {
    /// The default configuration changed by keyword sections, e.g.
    /// `Config(model="single_track_3d", loss={"scale": 0.002}, odometry={"min_matches": 12})`.
    #[new]
    #[pyo3(signature = (**sections))]
    fn new(sections: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        Ok(Self {
            inner: from_sections(sections, "<Config>")?,
        })
    }

    /// The built-in default (what `momo config` prints).
    #[staticmethod]
    fn default() -> Self {
        Self {
            inner: Config::default(),
        }
    }

    /// Parses TOML text (the format of `momo config`); `name` is used in messages
    /// (`name:line: reason`).
    #[staticmethod]
    #[pyo3(signature = (text, name = "<toml>"))]
    fn from_toml(text: &str, name: &str) -> PyResult<Self> {
        Config::from_toml_str(text, name)
            .map(|inner| Self { inner })
            .map_err(|e| config_error(&e))
    }

    /// Parses JSON text; `name` is used in messages (`name:line: reason`).
    #[staticmethod]
    #[pyo3(signature = (text, name = "<json>"))]
    fn from_json(text: &str, name: &str) -> PyResult<Self> {
        Config::from_json_str(text, name)
            .map(|inner| Self { inner })
            .map_err(|e| config_error(&e))
    }

    /// Reads a configuration file as `momo run --config` does (JSON if the name ends in
    /// `.json`, TOML otherwise).
    #[staticmethod]
    fn from_file(path: std::path::PathBuf) -> PyResult<Self> {
        Config::from_file(&path)
            .map(|inner| Self { inner })
            .map_err(|e| config_error(&e))
    }

    /// A configuration from a dict (as [`to_dict`](Self::to_dict) gives); all sections but
    /// model, metric, loss and solver may be left out.
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        Ok(Self {
            inner: from_value(py_to_json(d.as_any())?, "<dict>")?,
        })
    }

    /// The configuration as commented TOML (what `momo config` prints for the default);
    /// `Config.from_toml(c.to_toml()) == c`.
    fn to_toml(&self) -> String {
        self.inner.to_commented_toml()
    }

    /// The configuration as JSON text.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.inner)
            .map_err(|e| ConfigError::new_err(format!("cannot serialise: {e}")))
    }

    /// The configuration as a dict of sections; `Config.from_dict(c.to_dict()) == c`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = serde_json::to_value(&self.inner)
            .map_err(|e| ConfigError::new_err(format!("cannot serialise: {e}")))?;
        json_to_py(py, &v)
    }

    /// A copy with some sections changed (the keywords of `Config(...)`).
    #[pyo3(signature = (**sections))]
    fn replace(&self, sections: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut v = serde_json::to_value(&self.inner)
            .map_err(|e| ConfigError::new_err(format!("cannot serialise: {e}")))?;
        if let Some(sections) = sections {
            for (k, val) in sections.iter() {
                let key: String = k.extract()?;
                apply_section(&mut v, &key, &val, "<Config.replace>")?;
            }
        }
        Ok(Self {
            inner: from_value(v, "<Config.replace>")?,
        })
    }

    /// The model's type name (`"se3"`, `"single_track_2d"`, `"single_track_3d"`).
    #[getter]
    fn model(&self) -> PyResult<String> {
        type_name(&self.inner, "model")
    }

    /// The metric's type name.
    #[getter]
    fn metric(&self) -> PyResult<String> {
        type_name(&self.inner, "metric")
    }

    /// The loss's type name.
    #[getter]
    fn loss(&self) -> PyResult<String> {
        type_name(&self.inner, "loss")
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let Ok(other) = other.cast::<PyConfig>() else {
            return Ok(false);
        };
        let a = serde_json::to_value(&self.inner).ok();
        let b = serde_json::to_value(&other.get().inner).ok();
        Ok(a.is_some() && a == b)
    }

    fn __repr__(&self) -> String {
        let v = serde_json::to_value(&self.inner).unwrap_or(Value::Null);
        let part = |k: &str| v.get(k).map(Value::to_string).unwrap_or_default();
        format!(
            "Config(model={}, metric={}, loss={}, solver={})",
            part("model"),
            part("metric"),
            part("loss"),
            part("solver")
        )
    }
}

fn type_name(c: &Config, section: &str) -> PyResult<String> {
    let v = serde_json::to_value(c)
        .map_err(|e| ConfigError::new_err(format!("cannot serialise: {e}")))?;
    Ok(v.get(section)
        .and_then(|s| s.get("type"))
        .and_then(Value::as_str)
        .unwrap_or_default()
        .to_string())
}
