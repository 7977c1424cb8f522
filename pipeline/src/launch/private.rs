//! The private local mesh: a per-run directory of Unix sockets that only the user who
//! started the run may enter.
//!
//! The launcher's own mesh (no Zenoh flag, or `--router`) is not on TCP, which every local
//! user may connect to, but on Zenoh's Unix-socket link (`unixsock-stream/PATH`) with every
//! socket in one directory created mode 0700: another user's process cannot reach a socket in
//! it (connecting needs search permission on the directory), so it can neither read nor
//! inject anything. The directory is removed at the end of the run.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The Zenoh endpoint of the Unix socket at `path`.
pub(super) fn unix_endpoint(path: &Path) -> String {
    format!("unixsock-stream/{}", path.display())
}

/// The socket of the private mesh's hub (the launcher, or its router child).
pub(super) fn hub_socket(dir: &Path) -> String {
    unix_endpoint(&dir.join("hub.sock"))
}

/// The per-run directory of the private mesh's Unix sockets: created mode 0700 (only the user
/// who started the run can enter it, so only their processes can connect to its sockets)
/// under `$XDG_RUNTIME_DIR` when that is set, else the temporary directory; removed with
/// everything in it when dropped.
pub struct PrivateDir {
    dir: tempfile::TempDir,
}

/// Longest Unix socket path Linux takes (`sun_path` is 108 bytes with its NUL).
const MAX_SOCKET_PATH_BYTES: usize = 107;

impl PrivateDir {
    /// Creates the directory (see [`PrivateDir`]).
    pub fn create() -> Result<Self> {
        let base = std::env::var_os("XDG_RUNTIME_DIR")
            .map(PathBuf::from)
            .filter(|d| d.is_dir())
            .unwrap_or_else(std::env::temp_dir);
        Self::create_in(&base)
    }

    fn create_in(base: &Path) -> Result<Self> {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::Builder::new()
            .prefix("cellsar-mesh-")
            .permissions(std::fs::Permissions::from_mode(0o700))
            .tempdir_in(base)
            .with_context(|| {
                format!(
                    "creating the private mesh's directory in {}",
                    base.display()
                )
            })?;
        // the longest socket name the run gives: a child's, e.g. processor-12.sock
        let longest = dir.path().join("processor-0000.sock");
        if longest.as_os_str().len() > MAX_SOCKET_PATH_BYTES {
            anyhow::bail!(
                "{}: too long a directory for the private mesh's Unix sockets (at most {} \
                 bytes in a socket's path); set XDG_RUNTIME_DIR or TMPDIR to a shorter one",
                base.display(),
                MAX_SOCKET_PATH_BYTES
            );
        }
        Ok(PrivateDir { dir })
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn the_directory_is_private_and_removed_when_dropped() {
        let base = tempfile::tempdir().unwrap();
        let d = PrivateDir::create_in(base.path()).unwrap();
        let path = d.path().to_path_buf();
        assert!(path.starts_with(base.path()));
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o700, "{mode:o}");
        std::fs::write(path.join("hub.sock"), b"").unwrap();
        assert_eq!(
            hub_socket(&path),
            format!("unixsock-stream/{}/hub.sock", path.display())
        );
        drop(d);
        assert!(!path.exists());
    }

    #[test]
    fn a_base_too_long_for_socket_paths_is_named() {
        let base = tempfile::tempdir().unwrap();
        let deep = base.path().join("d".repeat(100));
        std::fs::create_dir(&deep).unwrap();
        let e = PrivateDir::create_in(&deep).err().unwrap().to_string();
        assert!(
            e.contains("too long") && e.contains("XDG_RUNTIME_DIR"),
            "{e}"
        );
        // nothing left behind
        assert_eq!(std::fs::read_dir(&deep).unwrap().count(), 0);
    }
}
