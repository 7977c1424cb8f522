//! What every service needs from the operating system: stopping on SIGINT/SIGTERM
//! ([`stop_on_signals`]) and replacing a state or output file without ever leaving a torn one
//! ([`write_file_atomic`], [`write_atomic`]).

use std::ffi::OsString;
use std::fs::{File, Permissions};
use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use super::plan::ServiceError;

/// Installs SIGINT and SIGTERM handlers that set the returned flag (services poll it and stop
/// cleanly: liveliness token withdrawn, final counters logged, exit 0). The services open
/// their Zenoh session with [`bridge::ZenohNode::open_until`], so the flag also stops a service that
/// still waits for its router.
pub fn stop_on_signals() -> Result<Arc<AtomicBool>, ServiceError> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, stop.clone())
            .map_err(|error| ServiceError::Signal { signal, error })?;
    }
    Ok(stop)
}

/// Writes `bytes` to `path` so that a reader, or the file after a crash, holds either the old
/// content or all of `bytes`, never a part: into a temporary file with a unique name in the
/// same directory (so that two writers never share it), synced, renamed over `path`, then the
/// directory synced (so that the rename survives a crash). The file gets the mode a plain
/// `std::fs::write` gives a new file (`0o666` less the umask). On failure, no temporary file is
/// left behind and the error names `path` (or its directory, when syncing that failed).
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut prefix = OsString::from(".");
    if let Some(name) = path.file_name() {
        prefix.push(name);
        prefix.push(".");
    }
    let mut tmp = tempfile::Builder::new()
        .prefix(&prefix)
        .suffix(".tmp")
        .permissions(Permissions::from_mode(0o666))
        .tempfile_in(dir)
        .map_err(|e| WriteError::new(path, e))?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.as_file().sync_all())
        .map_err(|e| WriteError::new(path, e))?;
    // on failure, the temporary file is removed when the error drops it
    tmp.persist(path)
        .map_err(|e| WriteError::new(path, e.error))?;
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| WriteError::new(dir, e))
}

/// [`write_file_atomic`] for the services, whose state files fail with a [`ServiceError`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ServiceError> {
    write_file_atomic(path, bytes).map_err(|e| ServiceError::io(&e.path, e.error))
}

/// An atomic write failed: the file (or its directory, when syncing that failed) and the I/O
/// error (in the message, so not also a `source()`).
#[derive(Debug, thiserror::Error)]
#[error("{}: {error}", path.display())]
pub struct WriteError {
    /// The file, or its directory.
    pub path: PathBuf,
    /// The I/O error.
    pub error: std::io::Error,
}

impl WriteError {
    fn new(path: &Path, error: std::io::Error) -> Self {
        Self {
            path: path.to_path_buf(),
            error,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The names in `dir`, sorted.
    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces_the_whole_file_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.plan");
        write_atomic(&path, b"first").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"first");
        write_atomic(&path, b"second, longer").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second, longer");
        assert_eq!(names(dir.path()), ["a.plan"]);
        // the mode of a plain write: what the umask leaves of 0o666
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        std::fs::write(dir.path().join("plain"), b"x").unwrap();
        let plain = std::fs::metadata(dir.path().join("plain"))
            .unwrap()
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(mode, plain);
    }

    #[test]
    fn a_write_into_a_missing_directory_fails_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing").join("metrics.bin");
        let e = write_atomic(&path, b"x").unwrap_err();
        assert!(matches!(e, ServiceError::Io { .. }), "{e:?}");
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );
        assert!(names(dir.path()).is_empty());
    }

    /// A rename that fails (here: `path` is a directory) leaves the old `path` and no
    /// temporary file.
    #[test]
    fn a_failed_rename_leaves_no_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("taken");
        std::fs::create_dir(&path).unwrap();
        let e = write_atomic(&path, b"never seen").unwrap_err();
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );
        assert_eq!(names(dir.path()), ["taken"]);
        assert!(path.is_dir());
    }
}
