//! `cellsar.plan` and `cellsar.Plan`: a planning run and its result.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::{AllowTypeChange, PyArray1, PyArrayLike1};
use pyo3::exceptions::{PyAttributeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use planner::evaluate::{Dynamics, ResolutionMode};
use planner::{PlanOptions, PlanResult, Scheme, Summary, Trajectory};

use crate::columns;
use crate::errors::PlanError;
use crate::json;
use crate::mission::PyMission;
use crate::run::plan_detached;

/// A plan: the trajectory's columns (those of the CLI's `trajectory.csv`) as NumPy arrays,
/// `summary` (the keys of `summary.json`), `to_csv(path)` and `to_pandas()`.
///
/// Every column is an attribute: `plan.t_s`, `plan.x_m`, `plan.energy_j`, ... with one row for
/// the start at t = 0 (undefined values `nan`) and one per slot.
#[pyclass(frozen, name = "Plan", module = "cellsar")]
pub struct PyPlan {
    pub(crate) mission: PyMission,
    pub(crate) result: Arc<PlanResult>,
}

impl PyPlan {
    fn column_vec(&self, name: &str) -> Option<Vec<f64>> {
        columns::column(
            name,
            &self.result.evaluation,
            self.result.trajectory.start_m,
        )
    }
}

#[pymethods]
impl PyPlan {
    /// The mission this plan is for.
    #[getter]
    fn mission(&self) -> PyMission {
        self.mission.clone()
    }

    /// The column names, in the order of `trajectory.csv`.
    #[getter]
    fn columns(&self) -> Vec<&'static str> {
        columns::names().collect()
    }

    /// One column by name, as a float64 array of `slots + 1` rows.
    fn column<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.column_vec(name)
            .map(|v| PyArray1::from_vec(py, v))
            .ok_or_else(|| PyValueError::new_err(format!("no column `{name}` in a plan")))
    }

    /// True propulsion energy on the exact geometry, J (`summary["energy_j"]`).
    #[getter]
    fn total_energy_j(&self) -> f64 {
        self.result.evaluation.energy_j
    }

    /// Whether the plan meets every constraint on the exact geometry
    /// (`summary["feasible"]`).
    #[getter]
    fn feasible(&self) -> bool {
        self.result
            .evaluation
            .is_feasible_for(self.result.resolution)
            && self.result.evaluation.meets(self.result.dynamics)
    }

    /// The scheme's name.
    #[getter]
    fn scheme(&self) -> &'static str {
        self.result.scheme.name()
    }

    /// The resolution requirement the plan was made for: `"general"` (the general cell, a best
    /// effort unless `strict_resolution`) or `"paper"` (the least-energy plan)
    /// (`summary["resolution"]`).
    #[getter]
    fn resolution(&self) -> &'static str {
        self.result.resolution.name()
    }

    /// `summary.json` as a dict (the same keys, `init_replaced` included when a given start
    /// was replaced).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let value = summary_value(&self.mission.inner, &self.result)
            .map_err(|e| PlanError::new_err(format!("encoding the summary: {e}")))?;
        json::to_py(py, &value)
    }

    /// Every iteration's record (a list of dicts: iteration, objective, true_energy_j, ...).
    #[getter]
    fn records<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json::to_py(py, &self.result.records)
    }

    /// Writes `trajectory.csv` (byte for byte what `cellsar-planner plan` writes), atomically.
    fn to_csv(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let text = planner::summary::trajectory_csv(&self.result).map_err(|e| {
            crate::errors::PlanError::new_err(format!("writing trajectory.csv: {e}"))
        })?;
        py.detach(|| crate::files::write_atomic(&path, text.as_bytes()))
    }

    /// The columns as a dict of arrays.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for name in columns::names() {
            if let Some(v) = self.column_vec(name) {
                d.set_item(name, PyArray1::from_vec(py, v))?;
            }
        }
        Ok(d)
    }

    /// The columns as a `pandas.DataFrame` (needs pandas).
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pandas = py.import("pandas").map_err(|e| {
            pyo3::exceptions::PyImportError::new_err(format!(
                "Plan.to_pandas needs pandas (pip install pandas): {e}"
            ))
        })?;
        pandas.call_method1("DataFrame", (self.to_dict(py)?,))
    }

    /// A column by name (`plan.x_m`).
    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.column_vec(name)
            .map(|v| PyArray1::from_vec(py, v))
            .ok_or_else(|| {
                PyAttributeError::new_err(format!("'Plan' object has no attribute '{name}'"))
            })
    }

    fn __len__(&self) -> usize {
        self.result.evaluation.slots.len() + 1
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan(mission={:?}, scheme={}, energy_j={:.3}, feasible={}, iterations={})",
            self.mission.inner.name(),
            self.result.scheme,
            self.result.evaluation.energy_j,
            self.feasible(),
            self.result.iterations
        )
    }
}

/// `summary.json`'s value: the summary, plus `init_replaced` when a given start was replaced
/// (as the CLI writes it).
fn summary_value(
    mission: &planner::Mission,
    result: &PlanResult,
) -> Result<serde_json::Value, serde_json::Error> {
    let mut value = serde_json::to_value(Summary::new(mission, result))?;
    if let (Some(reason), Some(map)) = (&result.init_replaced, value.as_object_mut()) {
        map.insert(
            "init_replaced".to_string(),
            serde_json::Value::String(reason.clone()),
        );
    }
    Ok(value)
}

/// Parses one of a closed set of names with the enum's own `FromStr` (the planner's strum
/// names); the error lists the names.
fn parse_named<T: Copy + std::str::FromStr>(
    s: &str,
    all: &[T],
    name: fn(T) -> &'static str,
    what: &str,
) -> PyResult<T> {
    s.parse::<T>().map_err(|_| {
        let names: Vec<&str> = all.iter().map(|&v| name(v)).collect();
        PyValueError::new_err(format!(
            "unknown {what} `{s}`; expected one of: {}",
            names.join(", ")
        ))
    })
}

/// A trajectory of `mission` from x and y arrays: `slots` rows (the start is the mission's), or
/// `slots + 1` rows whose first is the start (as in `trajectory.csv`).
pub fn trajectory_from_xy(
    mission: &planner::Mission,
    x_m: &[f64],
    y_m: &[f64],
    what: &str,
) -> PyResult<Trajectory> {
    let p = mission.params();
    let slots = mission.slots();
    if x_m.len() != y_m.len() {
        return Err(PyValueError::new_err(format!(
            "{what}: x_m has {} values but y_m has {}",
            x_m.len(),
            y_m.len()
        )));
    }
    let (start_m, skip) = if x_m.len() == slots + 1 {
        ([x_m[0], y_m[0]], 1)
    } else if x_m.len() == slots {
        (p.start_m, 0)
    } else {
        return Err(PyValueError::new_err(format!(
            "{what}: {} points, but the mission has {slots} slots (give {slots}, or {} with the start first)",
            x_m.len(),
            slots + 1
        )));
    };
    if let Some(i) = x_m.iter().chain(y_m).position(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what}: non-finite coordinate at index {}",
            i % x_m.len()
        )));
    }
    Ok(Trajectory {
        slot_s: p.slot_s,
        start_m,
        pos_m: x_m[skip..]
            .iter()
            .zip(&y_m[skip..])
            .map(|(&x, &y)| [x, y])
            .collect(),
    })
}

/// The start given as `init`: a `Plan`, a CSV path (as `cellsar-planner plan --init`), or a
/// pair `(x_m, y_m)` of arrays.
fn init_trajectory(mission: &planner::Mission, init: &Bound<'_, PyAny>) -> PyResult<Trajectory> {
    if let Ok(plan) = init.cast::<PyPlan>() {
        return Ok(plan.get().result.trajectory.clone());
    }
    if let Ok(path) = init.extract::<PathBuf>() {
        let p = mission.params();
        return Trajectory::from_csv_path(
            &path,
            p.slot_s,
            mission.slots(),
            p.start_m,
            p.altitude_m,
        )
        .map_err(|e| PyValueError::new_err(cellsar_error::error_chain(&e)));
    }
    if let Ok(pair) = init.cast::<PyTuple>() {
        if pair.len() == 2 {
            let x: PyArrayLike1<f64, AllowTypeChange> = pair.get_item(0)?.extract()?;
            let y: PyArrayLike1<f64, AllowTypeChange> = pair.get_item(1)?.extract()?;
            let x = x.as_array().to_vec();
            let y = y.as_array().to_vec();
            return trajectory_from_xy(mission, &x, &y, "init");
        }
    }
    Err(PyValueError::new_err(
        "init: expected a Plan, a trajectory CSV path, or a pair (x_m, y_m) of arrays",
    ))
}

/// The options of `cellsar.plan`, as the Python wrapper (`cellsar/__init__.py`) passes them: a
/// dict with every key of its signature.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct PlanArgs<'py> {
    scheme: String,
    resolution: Option<String>,
    strict_resolution: Option<bool>,
    max_extra_energy_pct: Option<f64>,
    init: Option<Bound<'py, PyAny>>,
    max_iterations: Option<usize>,
    time_limit_s: Option<f64>,
    progress: Option<Py<PyAny>>,
    tolerance: Option<f64>,
    dynamics: Option<String>,
}

/// Plans a mission and returns the `Plan` (`cellsar.plan` documents the options).
#[pyfunction]
pub fn plan(py: Python<'_>, mission: PyRef<'_, PyMission>, args: PlanArgs<'_>) -> PyResult<PyPlan> {
    let m = mission.clone();
    let scheme = parse_named(&args.scheme, &Scheme::ALL, Scheme::name, "scheme")?;
    // the library's defaults for the scheme, as the CLI and a plan request on the wire take them
    let defaults = PlanOptions::for_scheme(scheme);
    let options = PlanOptions {
        scheme,
        resolution: match &args.resolution {
            Some(name) => parse_named(
                name,
                &ResolutionMode::ALL,
                ResolutionMode::name,
                "resolution",
            )?,
            None => defaults.resolution,
        },
        strict_resolution: args.strict_resolution.unwrap_or(defaults.strict_resolution),
        max_extra_energy_pct: args.max_extra_energy_pct,
        init: args
            .init
            .as_ref()
            .filter(|i| !i.is_none())
            .map(|i| init_trajectory(&m.inner, i))
            .transpose()?,
        max_iterations: args.max_iterations.unwrap_or(defaults.max_iterations),
        tolerance: args.tolerance.unwrap_or(defaults.tolerance),
        time_limit_s: args.time_limit_s,
        dynamics: match &args.dynamics {
            Some(name) => parse_named(name, &Dynamics::ALL, Dynamics::name, "dynamics")?,
            None => defaults.dynamics,
        },
        // a free-altitude mission gets its altitude per slot (`z_m`, `climb_mps`), as from
        // `cellsar-planner plan`; the schemes other than exact refuse it
        altitude_profile: true,
        ..defaults
    };
    // refused before the mission is planned, with the library's message (a ValueError)
    options
        .validate()
        .map_err(|e| crate::errors::plan_error(py, &e))?;
    let progress = args.progress.filter(|p| !p.is_none(py));
    let result = plan_detached(py, &m.inner, &options, progress)?;
    Ok(PyPlan {
        mission: m,
        result: Arc::new(result),
    })
}
