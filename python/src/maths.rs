//! `cellsar.evaluate`, `cellsar.dmin` and `cellsar.power_w`: the planner's models on their own.

use numpy::{AllowTypeChange, IntoPyArray, PyArrayLike1, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use planner::dmin::{expected_dmin_m, expected_dmin_monte_carlo_m, CdfForm};
use planner::PowerModel;

use crate::columns;
use crate::json;
use crate::mission::PyMission;
use crate::plan::trajectory_from_xy;

/// Evaluates a path of `mission` on the exact geometry.
///
/// `x_m`, `y_m`: one point per slot end (the mission's start is prepended), or `slots + 1`
/// points whose first is the start. Returns a dict with the keys of `cellsar-planner evaluate`
/// (`energy_j`, `feasible`, `violations`, ...) and `columns`: the trajectory columns of the
/// path (those of a plan's `trajectory.csv`) as arrays.
#[pyfunction]
pub fn evaluate<'py>(
    py: Python<'py>,
    mission: PyRef<'py, PyMission>,
    x_m: PyArrayLike1<'py, f64, AllowTypeChange>,
    y_m: PyArrayLike1<'py, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = mission.inner.clone();
    let x = x_m.as_array().to_vec();
    let y = y_m.as_array().to_vec();
    let tr = trajectory_from_xy(&m, &x, &y, "evaluate")?;
    let ev = py.detach(|| planner::evaluate(&m, &tr));
    let d = PyDict::new(py);
    d.set_item("energy_j", ev.energy_j)?;
    d.set_item("feasible", ev.is_feasible())?;
    d.set_item("violations", json::to_py(py, &ev.violations)?)?;
    d.set_item("min_speed_mps", ev.min_speed_mps)?;
    d.set_item("max_speed_mps", ev.max_speed_mps)?;
    d.set_item("length_m", ev.length_m)?;
    d.set_item("slots_out_of_view", ev.slots_out_of_view)?;
    d.set_item("slots_unresolved_general", ev.slots_unresolved)?;
    d.set_item("slots_blind", ev.slots_blind)?;
    let cols = PyDict::new(py);
    for name in columns::names() {
        if let Some(v) = columns::column(name, &ev, tr.start_m) {
            cols.set_item(name, v.into_pyarray(py))?;
        }
    }
    d.set_item("columns", cols)?;
    Ok(d)
}

/// Expected least distance E[d_min] from a designated object to the other `objects - 1` in a
/// disk of radius `radius_m`, m.
///
/// `method`: `exact` (the correct CDF), `printed` (the paper's CDF as printed) or
/// `monte_carlo` (`trials` draws from `seed`; the mean).
#[pyfunction]
#[pyo3(signature = (radius_m, objects, method = "exact", trials = 2000, seed = 1))]
pub fn dmin(
    py: Python<'_>,
    radius_m: f64,
    objects: u64,
    method: &str,
    trials: u32,
    seed: u64,
) -> PyResult<f64> {
    let bad = |e: planner::dmin::DminError| PyValueError::new_err(e.to_string());
    match method {
        "exact" => py
            .detach(|| expected_dmin_m(radius_m, objects, CdfForm::Correct))
            .map_err(bad),
        "printed" => py
            .detach(|| expected_dmin_m(radius_m, objects, CdfForm::AsPrinted))
            .map_err(bad),
        "monte_carlo" => py
            .detach(|| expected_dmin_monte_carlo_m(radius_m, objects, trials, seed))
            .map(|(mean, _)| mean)
            .map_err(bad),
        _ => Err(PyValueError::new_err(format!(
            "unknown method `{method}`; expected one of: exact, printed, monte_carlo"
        ))),
    }
}

/// Rotary-wing propulsion power P(V), W, at `speed_mps` (a number or an array of any shape),
/// with the parameters of `mission` (the default parameters when None).
#[pyfunction]
#[pyo3(signature = (speed_mps, mission = None))]
pub fn power_w<'py>(
    py: Python<'py>,
    speed_mps: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    mission: Option<PyRef<'py, PyMission>>,
) -> PyResult<Bound<'py, PyAny>> {
    let model = match &mission {
        Some(m) => PowerModel::new(m.inner.params()),
        None => PowerModel::new(&planner::Params::default()),
    };
    let v = speed_mps.as_array();
    if v.ndim() == 0 {
        let s = v.iter().next().copied().unwrap_or(f64::NAN);
        return Ok(model.power_w(s).into_pyobject(py)?.into_any());
    }
    Ok(v.mapv(|s| model.power_w(s)).into_pyarray(py).into_any())
}
