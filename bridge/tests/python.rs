//! Runs the Python `eclipse-zenoh` client tests (`bridge/tests/python`) against the freshly built
//! `cellsar-bridge` binary: the JSON side of the wire format, read by a non-Rust client.
//!
//! Needs `pip install eclipse-zenoh==1.10.2 pytest` (`.ci/requirements.txt`); the test fails
//! loudly without them unless `CELLSAR_SKIP_PYTHON=1` is set.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

#[test]
fn bridge_python_client() {
    if std::env::var("CELLSAR_SKIP_PYTHON").as_deref() == Ok("1") {
        eprintln!("CELLSAR_SKIP_PYTHON=1: Python client tests skipped");
        return;
    }
    let probe = Command::new("python3")
        .args([
            "-c",
            "import zenoh, pytest, importlib.metadata as m; v = m.version('eclipse-zenoh'); assert v.startswith('1.10'), v",
        ])
        .output();
    match probe {
        Ok(o) if o.status.success() => {}
        Ok(o) => panic!(
            "eclipse-zenoh 1.10 / pytest missing ({}): run `pip install eclipse-zenoh==1.10.2 pytest`, or set CELLSAR_SKIP_PYTHON=1 to skip",
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Err(e) => panic!("python3 not found ({e}); set CELLSAR_SKIP_PYTHON=1 to skip"),
    }
    let status = Command::new("python3")
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(workspace().join("bridge/tests/python"))
        .env("CELLSAR_BRIDGE_BIN", env!("CARGO_BIN_EXE_cellsar-bridge"))
        .current_dir(workspace())
        .status()
        .expect("run pytest");
    assert!(
        status.success(),
        "pytest bridge/tests/python failed: {status}"
    );
}
