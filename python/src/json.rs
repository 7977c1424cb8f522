//! Python objects to and from JSON text: the mission file's and `summary.json`'s serde forms
//! cross the boundary as JSON through Python's own `json` module, so that a dict has exactly
//! the structure (and the field checks) of the file.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyList, PyString};

/// `json.dumps(obj)`; the error names a value JSON cannot hold (NaN, infinity: the first one's
/// path, `params.d_min_m`) or cannot encode.
pub fn dumps(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Some((path, value)) = first_non_finite(obj, "") {
        return Err(PyValueError::new_err(format!(
            "`{path}` = {value}: must be a finite number"
        )));
    }
    let json = obj.py().import("json")?;
    json.call_method1("dumps", (obj,))?.extract::<String>()
}

/// The dotted path and value of the first NaN or infinite float in nested dicts and lists.
fn first_non_finite(obj: &Bound<'_, PyAny>, path: &str) -> Option<(String, f64)> {
    let join = |key: String| {
        if path.is_empty() {
            key
        } else {
            format!("{path}.{key}")
        }
    };
    if let Ok(d) = obj.cast::<PyDict>() {
        return d.iter().find_map(|(k, v)| {
            let key = k.str().map(|s| s.to_string()).unwrap_or_default();
            first_non_finite(&v, &join(key))
        });
    }
    if let Ok(l) = obj.cast::<PyList>() {
        return l
            .iter()
            .enumerate()
            .find_map(|(i, v)| first_non_finite(&v, &format!("{path}[{i}]")));
    }
    if let Ok(f) = obj.cast::<PyFloat>() {
        let v = f.value();
        return (!v.is_finite()).then(|| (path.to_string(), v));
    }
    None
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

/// Deserialises JSON text made from a Python object; the error names the path of the field that
/// does not fit (`params.horizon_s: invalid type: string "a", expected f64`).
pub fn from_text<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, String> {
    let mut de = serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        // serde_json appends " at line 1 column N", meaningless for a dict
        let message = inner.to_string();
        let message = message
            .rsplit_once(" at line ")
            .map_or(message.as_str(), |(m, _)| m)
            .to_string();
        if path.is_empty() || path == "." {
            message
        } else {
            format!("`{path}`: {message}")
        }
    })
}
