//! The fmpy test suite (`tests/python/fmu`) against freshly packaged FMUs: `package-fmu`
//! packages the FMI 2.0 and 3.0 FMUs from the FMU library of this build (no second build) into
//! `<target>/fmu`, then pytest runs with fmpy 0.3.32 in the test environment
//! ([`harness::python`]). The reference plans come from the `cellsar-planner` binary of this
//! build.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

use harness::{bin, profile_dir, pytest, root, run, target_dir};

#[test]
fn fmpy_test_suite() {
    let out = target_dir().join("fmu");
    // the cdylib `cargo test` built for the fmu crate's own tests
    let lib = profile_dir().join("deps").join("libfmu.so");
    assert!(lib.is_file(), "{} not built", lib.display());
    run(Command::new(bin("package-fmu"))
        .arg("--lib")
        .arg(&lib)
        .arg("--out")
        .arg(&out));
    pytest(
        &root().join("tests/python/fmu"),
        &[
            ("CELLSAR_FMU_DIR", &out),
            ("CELLSAR_PLANNER_BIN", &bin("cellsar-planner")),
        ],
    );
}
