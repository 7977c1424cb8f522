//! Python objects to and from JSON text: the mission file's and `summary.json`'s serde forms
//! cross the boundary as JSON through Python's own `json` module, so that a dict has exactly
//! the structure (and the field checks) of the file.

use pyo3::prelude::*;
use pyo3::types::PyString;

/// `json.dumps(obj)`; a `TypeError` names what cannot be encoded.
pub fn dumps(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    let json = obj.py().import("json")?;
    json.call_method1("dumps", (obj,))?.extract::<String>()
}

/// `json.loads(text)`.
pub fn loads<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    let json = py.import("json")?;
    json.call_method1("loads", (PyString::new(py, text),))
}

/// A serde value as a Python object (through JSON text).
pub fn to_py<'py>(py: Python<'py>, value: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("encoding JSON: {e}")))?;
    loads(py, &text)
}
