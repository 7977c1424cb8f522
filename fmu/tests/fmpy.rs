//! Runs the fmpy test suite (fmu/python-tests) against freshly packaged FMUs.
//!
//! Builds `package-fmu` and `cellsar-planner` (the reference plans) in release mode,
//! packages the FMUs into `<target>/fmu`, then runs `python3 -m pytest fmu/python-tests`.
//! fmpy 0.3.32 and pytest must be installed (`pip install fmpy==0.3.32 pytest`); the test fails
//! loudly without them unless `CELLSAR_SKIP_FMPY=1` is set.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(workspace());
    c
}

fn run(cmd: &mut Command) {
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    assert!(status.success(), "{cmd:?} failed: {status}");
}

#[test]
fn fmpy_test_suite() {
    if std::env::var("CELLSAR_SKIP_FMPY").as_deref() == Ok("1") {
        eprintln!("CELLSAR_SKIP_FMPY=1: fmpy tests skipped");
        return;
    }
    let probe = Command::new("python3")
        .args([
            "-c",
            "import fmpy, pytest, numpy; assert fmpy.__version__ == '0.3.32', fmpy.__version__",
        ])
        .output();
    match probe {
        Ok(o) if o.status.success() => {}
        Ok(o) => panic!(
            "fmpy 0.3.32 / pytest missing or wrong version ({}): run `pip install fmpy==0.3.32 pytest`, or set CELLSAR_SKIP_FMPY=1 to skip",
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Err(e) => panic!("python3 not found ({e}); set CELLSAR_SKIP_FMPY=1 to skip"),
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target"));
    let out = target.join("fmu");
    run(cargo().args([
        "build",
        "--release",
        "-p",
        "pipeline",
        "--bin",
        "cellsar-planner",
    ]));
    run(cargo()
        .args([
            "run",
            "--release",
            "-p",
            "fmu",
            "--bin",
            "package-fmu",
            "--",
            "--out",
        ])
        .arg(&out));
    let planner = target.join("release").join("cellsar-planner");
    run(Command::new("python3")
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(workspace().join("fmu").join("python-tests"))
        .env("CELLSAR_FMU_DIR", &out)
        .env("CELLSAR_PLANNER_BIN", &planner));
}
