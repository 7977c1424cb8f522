//! Writing files atomically (a temporary file in the same directory, renamed over the target),
//! so that a reader never sees half a file.

use std::io::Write;
use std::path::Path;

use pyo3::exceptions::PyOSError;
use pyo3::PyResult;

/// Writes `bytes` to `path` atomically; the error names the file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> PyResult<()> {
    let fail = |e: std::io::Error| PyOSError::new_err(format!("writing {}: {e}", path.display()));
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(fail)?;
    tmp.write_all(bytes).map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}
