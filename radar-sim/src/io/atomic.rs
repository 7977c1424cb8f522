//! Atomic output files: every file the library writes is written to a unique temporary file in
//! its directory, flushed, synced and renamed over the target, so that a reader never sees a
//! partial file and a failed write (a full disk) leaves the previous file, if any, in place.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

use crate::error::{RadarError, Result};

/// An output file being written: a temporary file beside `path`, renamed over it by
/// [`AtomicFile::commit`]. Dropped without a commit, the temporary file is removed and `path`
/// is left as it was.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    out: BufWriter<NamedTempFile>,
}

impl AtomicFile {
    /// Creates the temporary file in `path`'s directory (with the permissions that
    /// `File::create` would give: 0o666 less the umask).
    pub fn create(path: &Path) -> Result<Self> {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let prefix = format!(".{name}.");
        let mut b = tempfile::Builder::new();
        b.prefix(&prefix).suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            b.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let tmp = b.tempfile_in(dir).map_err(|e| RadarError::io(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            out: BufWriter::with_capacity(1 << 16, tmp),
        })
    }

    /// The target path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// [`RadarError::Io`] naming the target file.
    pub fn error(&self, e: std::io::Error) -> RadarError {
        RadarError::io(&self.path, e)
    }

    /// Flushes, syncs the data to disk and renames the temporary file over the target.
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        let tmp = self
            .out
            .into_inner()
            .map_err(|e| RadarError::io(&path, e.into_error()))?;
        tmp.as_file()
            .sync_all()
            .map_err(|e| RadarError::io(&path, e))?;
        tmp.persist(&path)
            .map_err(|e| RadarError::io(&path, e.error))?;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.out.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.out.write_all(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Writes `path` atomically with `fill`, which writes the content; an error of `fill` or of
/// the commit leaves `path` untouched.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut AtomicFile) -> Result<()>) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    fill(&mut f)?;
    f.commit()
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |f| f.write_all(bytes).map_err(|e| f.error(e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_whole_files_and_leaves_no_temporary_behind() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_bytes(&p, b"first").unwrap();
        write_bytes(&p, b"second").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        // a failing fill leaves the old content and no temporary file
        let e = write_atomic(&p, |f| {
            f.write_all(b"partial").unwrap();
            Err(RadarError::format("x", "y", "z"))
        })
        .unwrap_err();
        assert!(matches!(e, RadarError::Format { .. }));
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("a.txt")]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode();
            // as File::create: readable by others unless the umask says otherwise
            assert_ne!(mode & 0o600, 0, "{mode:o}");
        }
    }

    /// A failed create, write, sync or rename (a full disk, a missing directory) is an output
    /// error naming the target file.
    #[test]
    fn write_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("missing").join("a.txt");
        let e = write_bytes(&p, b"x").unwrap_err();
        assert!(matches!(e, RadarError::Io { .. }), "{e:?}");
        assert!(e.to_string().contains("a.txt"), "{e}");
        assert!(!e.is_bad_input());
    }
}
