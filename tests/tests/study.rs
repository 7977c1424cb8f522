//! Studies (`cellsar-study`, the `cellsar.study` Python module on Dask distributed): the
//! package is built and installed into the test environment ([`harness::python`]) as
//! `tests/tests/python_package.rs` does, then the pytest suite `tests/python/study` runs: study
//! files refused naming the field, a local cluster of two worker processes, a study interrupted
//! and resumed, a scheduler and two workers started as separate processes with one of them
//! killed in the middle of the study.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

use harness::{pytest, root, run, target_dir};

/// `pip install ./python` into the test environment (with its `cellsar-study` console script),
/// with maturin (from the environment) as the build backend, in the debug profile.
fn install_package() {
    let python = harness::python();
    let venv_bin = python
        .parent()
        .expect("the venv's bin directory")
        .to_path_buf();
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![venv_bin];
    paths.extend(std::env::split_paths(&path));
    run(Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "--no-build-isolation",
            "--force-reinstall",
            "--no-deps",
        ])
        .arg(root().join("python"))
        .env("PATH", std::env::join_paths(paths).expect("PATH"))
        .env("CARGO_TARGET_DIR", target_dir().join("python-package"))
        .env("MATURIN_PEP517_ARGS", "--profile dev"));
}

#[test]
fn studies_on_dask() {
    install_package();
    pytest(&root().join("tests/python/study"), &[]);
}
