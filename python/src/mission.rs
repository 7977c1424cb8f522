//! `cellsar.Mission`: a validated mission (parameters and landmark schedule), read-only.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::PyArray1;
use pyo3::exceptions::PyAttributeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::errors::{mission_error, MissionError};
use crate::json;

/// A validated mission: parameters and a landmark schedule with one optional landmark per slot.
///
/// Build one with `Mission.from_file(path)`, `Mission.from_dict(d)` (the mission file's
/// structure) or `Mission.default(spacing_m=30.0, **params)`. Every parameter of the resolved
/// set is a read-only attribute (`mission.horizon_s`, `mission.start_m`, ...).
#[pyclass(frozen, name = "Mission", module = "cellsar")]
#[derive(Clone)]
pub struct PyMission {
    /// The mission (shared with the plans made from it).
    pub inner: Arc<planner::Mission>,
}

impl PyMission {
    fn wrap(m: planner::Mission) -> Self {
        Self { inner: Arc::new(m) }
    }
}

/// Builds a mission from the JSON text of a mission file's structure; `what` names the source
/// in messages.
fn from_json(text: &str, what: &str) -> PyResult<PyMission> {
    let file: planner::MissionFile = json::from_text(text)
        .map_err(|message| MissionError::new_err(format!("{what}: {message}")))?;
    planner::Mission::from_file_struct(&file)
        .map(PyMission::wrap)
        .map_err(|e| mission_error(&e))
}

#[pymethods]
impl PyMission {
    /// Reads a mission file: `.json` as JSON, anything else as TOML.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        py.detach(|| planner::Mission::from_path(&path))
            .map(Self::wrap)
            .map_err(|e| mission_error(&e))
    }

    /// Builds a mission from a dict with the mission file's structure:
    /// `{"name": ..., "params": {...}, "landmarks": {"preset": "default", "spacing_m": 30}}`.
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyAny>) -> PyResult<Self> {
        if !d.is_instance_of::<PyDict>() {
            return Err(MissionError::new_err(format!(
                "mission dict: expected a dict, got {}",
                d.get_type().name()?
            )));
        }
        let text =
            json::dumps(d).map_err(|e| MissionError::new_err(format!("mission dict: {e}")))?;
        from_json(&text, "mission dict")
    }

    /// The paper's default mission (three landmarks `spacing_m` apart) with any parameter
    /// overridden by keyword, e.g. `Mission.default(60.0, horizon_s=200.0)`.
    #[staticmethod]
    #[pyo3(signature = (spacing_m = 30.0, **params))]
    fn default(
        py: Python<'_>,
        spacing_m: f64,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let d = PyDict::new(py);
        let landmarks = PyDict::new(py);
        landmarks.set_item("preset", "default")?;
        landmarks.set_item("spacing_m", spacing_m)?;
        d.set_item("landmarks", landmarks)?;
        d.set_item("params", params.cloned().unwrap_or_else(|| PyDict::new(py)))?;
        let text = json::dumps(d.as_any())
            .map_err(|e| MissionError::new_err(format!("Mission.default: {e}")))?;
        from_json(&text, "Mission.default")
    }

    /// The same mission with some parameters changed (re-validated), e.g.
    /// `mission.with_params(d_min_m=2.0)`; `max_jerk_mps3=None` drops a jerk limit.
    #[pyo3(signature = (**params))]
    fn with_params(&self, params: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut p = self.inner.params().clone();
        if let Some(params) = params {
            for (k, v) in params.iter() {
                let name: String = k.extract()?;
                match name.as_str() {
                    "start_m" => p.start_m = point(&name, &v)?,
                    "bs_m" => p.bs_m = point(&name, &v)?,
                    // optional: None (no jerk limit) or a number
                    "max_jerk_mps3" => {
                        p.max_jerk_mps3 = v.extract::<Option<f64>>().map_err(|_| {
                            MissionError::new_err(format!(
                                "parameter `{name}`: expected a number or None (no jerk limit)"
                            ))
                        })?
                    }
                    _ => {
                        let value: f64 = v.extract().map_err(|_| {
                            MissionError::new_err(format!("parameter `{name}`: expected a number"))
                        })?;
                        p.set_by_name(&name, value)
                            .map_err(|e| MissionError::new_err(e.to_string()))?;
                    }
                }
            }
        }
        self.inner
            .with_params(p)
            .map(Self::wrap)
            .map_err(|e| mission_error(&e))
    }

    /// The mission's name (as in reports and `summary["mission"]`).
    #[getter]
    fn name(&self) -> &str {
        self.inner.name()
    }

    /// Number of slots.
    #[getter]
    fn slots(&self) -> usize {
        self.inner.slots()
    }

    /// The resolved parameters, as a dict (a copy).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_py(py, self.inner.params())
    }

    /// The landmark windows: a list of dicts `{x_m, y_m, from_s, to_s}`.
    #[getter]
    fn landmarks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_py(py, &self.inner.schedule().landmarks)
    }

    /// For each slot 1..T, the index of its landmark in `landmarks`, or -1.
    #[getter]
    fn slot_landmark<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self
            .inner
            .schedule()
            .slot_landmark
            .iter()
            .map(|l| l.map_or(-1, |i| i64::try_from(i).unwrap_or(i64::MAX)))
            .collect();
        PyArray1::from_vec(py, v)
    }

    /// The mission file's structure, as a dict (`Mission.from_dict` reads it back).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_py(py, &self.inner.to_file_struct())
    }

    /// The mission as TOML text (what `cellsar-planner plan` writes as `mission.toml`).
    fn to_toml(&self) -> PyResult<String> {
        self.inner
            .to_file_struct()
            .to_toml_string()
            .map_err(MissionError::new_err)
    }

    /// A parameter by name (`mission.horizon_s`).
    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let p = self.inner.params();
        match name {
            "start_m" => Ok(PyList::new(py, p.start_m)?.into_any()),
            "bs_m" => Ok(PyList::new(py, p.bs_m)?.into_any()),
            _ => match p.get_by_name(name) {
                Some(v) => Ok(v.into_pyobject(py)?.into_any()),
                None => Err(PyAttributeError::new_err(format!(
                    "'Mission' object has no attribute '{name}'"
                ))),
            },
        }
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyMission>()
            .is_ok_and(|o| *o.get().inner == *self.inner)
    }

    fn __repr__(&self) -> String {
        format!(
            "Mission(name={:?}, slots={}, landmarks={})",
            self.inner.name(),
            self.inner.slots(),
            self.inner.schedule().landmarks.len()
        )
    }
}

/// A point `[x, y]` given for the parameter `name`.
fn point(name: &str, v: &Bound<'_, PyAny>) -> PyResult<[f64; 2]> {
    let xy: Vec<f64> = v
        .extract()
        .map_err(|_| MissionError::new_err(format!("parameter `{name}`: expected [x, y] in m")))?;
    <[f64; 2]>::try_from(xy.as_slice())
        .map_err(|_| MissionError::new_err(format!("parameter `{name}`: expected [x, y] in m")))
}
