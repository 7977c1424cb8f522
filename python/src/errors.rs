//! The package's exceptions and the conversion of the Rust libraries' errors into them.

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    cellsar,
    MissionError,
    PyValueError,
    "A mission that cannot be read or built; the message names the file, field or slot."
);
create_exception!(
    cellsar,
    PlanError,
    PyRuntimeError,
    "A plan that failed: the solver, the time limit, or an internal error."
);
create_exception!(
    cellsar,
    InfeasibleMission,
    PlanError,
    "A mission that cannot be flown; `slot` (1-based), `t_s` and `reason` name the first bad slot."
);
create_exception!(
    cellsar,
    PlanNotFound,
    PlanError,
    "No plan meets every constraint, and none is proven impossible; `slot` (1-based), `t_s` and \
     `reason` name the first slot the best plan found violates, `best_energy_j` and \
     `best_violations` (a dict) describe that plan (None when there is none)."
);
create_exception!(
    cellsar,
    RadarError,
    PyValueError,
    "A radar simulation or processing step that failed; the message names the field, pulse or aperture."
);

/// A `planner::MissionError` as `cellsar.MissionError` (its message names the file, field or
/// slot).
pub fn mission_error(e: &planner::MissionError) -> PyErr {
    MissionError::new_err(cellsar_error::error_chain(e))
}

/// A `planner::PlanError` as the matching Python exception: `InfeasibleMission` (with `slot`,
/// `t_s` and `reason`), `ValueError` for a bad option or start, `PlanError` otherwise.
pub fn plan_error(py: Python<'_>, e: &planner::PlanError) -> PyErr {
    let message = cellsar_error::error_chain(e);
    match e {
        planner::PlanError::Infeasible(inf) => {
            let err = InfeasibleMission::new_err(message);
            let value = err.value(py);
            let set = value
                .setattr("slot", inf.slot)
                .and_then(|()| value.setattr("t_s", inf.t_s))
                .and_then(|()| value.setattr("reason", inf.reason.as_str()));
            match set {
                Ok(()) => err,
                Err(e) => e,
            }
        }
        planner::PlanError::NotFound(nf) => {
            let err = PlanNotFound::new_err(message);
            let value = err.value(py);
            let best = nf.best.as_ref();
            let violations = best
                .map(|b| crate::json::to_py(py, &b.evaluation.violations))
                .transpose();
            let set = violations.and_then(|violations| {
                value
                    .setattr("slot", nf.slot)
                    .and_then(|()| value.setattr("t_s", nf.t_s))
                    .and_then(|()| value.setattr("reason", nf.reason.as_str()))
                    .and_then(|()| value.setattr("best_energy_j", best.map(|b| b.evaluation.energy_j)))
                    .and_then(|()| value.setattr("best_violations", violations))
            });
            match set {
                Ok(()) => err,
                Err(e) => e,
            }
        }
        planner::PlanError::InvalidInit(_)
        | planner::PlanError::InvalidOption { .. }
        | planner::PlanError::OptionConflict(_) => PyValueError::new_err(message),
        _ => PlanError::new_err(message),
    }
}

/// A panic caught at the boundary, as `cellsar.PlanError` (no panic crosses into Python).
pub fn panic_error(what: &str, payload: &(dyn std::any::Any + Send)) -> PyErr {
    let text = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string());
    PlanError::new_err(format!("internal error in {what}: {text}"))
}
