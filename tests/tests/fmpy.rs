//! The fmpy test suite (`tests/python/fmu`) against freshly packaged FMUs: packages the FMI 2.0
//! and 3.0 FMUs in release mode into `<target>/fmu` (`package-fmu`), then runs pytest with
//! fmpy 0.3.32 in the test environment ([`harness::python`]). The reference plans come from
//! the `cellsar-planner` binary of this build.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

use harness::{bin, pytest, root, run, target_dir};

#[test]
fn fmpy_test_suite() {
    let out = target_dir().join("fmu");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // a release build: its own target/release lock, so no wait on this debug build
    run(Command::new(cargo)
        .current_dir(root())
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
    pytest(
        &root().join("tests/python/fmu"),
        &[
            ("CELLSAR_FMU_DIR", &out),
            ("CELLSAR_PLANNER_BIN", &bin("cellsar-planner")),
        ],
    );
}
