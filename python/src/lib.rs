//! The native part of the `cellsar` Python package (`cellsar._cellsar`): the planner, the
//! exact-geometry evaluator and the radar chain of the Rust libraries `planner` and
//! `radar-sim`, with NumPy arrays and Python exceptions. The Python package (`cellsar/`) adds
//! the documented signatures and the type stubs.

mod columns;
mod errors;
mod files;
mod json;
mod maths;
mod mission;
mod plan;
mod radar;
mod run;
mod workers;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _cellsar(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_class::<mission::PyMission>()?;
    m.add_class::<plan::PyPlan>()?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(maths::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(maths::dmin, m)?)?;
    m.add_function(wrap_pyfunction!(maths::power_w, m)?)?;
    let radar = PyModule::new(py, "radar")?;
    radar::register(&radar)?;
    m.add_submodule(&radar)?;
    m.add("MissionError", py.get_type::<errors::MissionError>())?;
    m.add("PlanError", py.get_type::<errors::PlanError>())?;
    m.add(
        "InfeasibleMission",
        py.get_type::<errors::InfeasibleMission>(),
    )?;
    m.add("PlanNotFound", py.get_type::<errors::PlanNotFound>())?;
    m.add("RadarError", py.get_type::<errors::RadarError>())?;
    Ok(())
}
