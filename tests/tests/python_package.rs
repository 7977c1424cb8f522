//! The `cellsar` Python package (`python/`): built with maturin and installed into the test
//! environment ([`harness::python`]) by `pip install ./python`, then its pytest suite
//! (`python/tests`) runs against the `cellsar-planner` binary of this build: plans through the
//! package equal the CLI's, errors, evaluation, the GIL and Ctrl-C.
//!
//! The package is built in the debug profile, in `target/python-package` (its own workspace,
//! see the root Cargo.toml), so that a rebuild after a change is incremental; pip reinstalls the
//! wheel every run (a few seconds when nothing changed).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use harness::{bin, install_python_package, pytest, root};

#[test]
fn python_package() {
    install_python_package();
    pytest(
        &root().join("python/tests"),
        &[("CELLSAR_PLANNER", &bin("cellsar-planner"))],
    );
}
