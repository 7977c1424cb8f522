//! The `cellsar` Python package (`python/`): built with maturin and installed into the test
//! environment ([`harness::python`]) by `pip install ./python`, then its pytest suite
//! (`python/tests`) runs against the `cellsar-planner` binary of this build: plans through the
//! package equal the CLI's, errors, evaluation, the GIL and Ctrl-C.
//!
//! The package is built in the debug profile, in `target/python-package` (its own workspace,
//! see the root Cargo.toml), so that a rebuild after a change is incremental; pip reinstalls the
//! wheel every run (a few seconds when nothing changed).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

use harness::{bin, pytest, root, run, target_dir};

/// `pip install ./python` into the test environment, with maturin (from the environment) as the
/// build backend.
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
fn python_package() {
    install_package();
    pytest(
        &root().join("python/tests"),
        &[("CELLSAR_PLANNER", &bin("cellsar-planner"))],
    );
}
