//! Studies (`cellsar-study`, the `cellsar.study` Python module on Dask distributed): the
//! package is built and installed into the test environment ([`harness::python`]) as
//! `tests/tests/python_package.rs` does, then the pytest suite `tests/python/study` runs: study
//! files refused naming the field, a local cluster of two worker processes, a study interrupted
//! and resumed, a scheduler and two workers started as separate processes with one of them
//! killed in the middle of the study.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use harness::{install_python_package, pytest, root};

#[test]
fn studies_on_dask() {
    install_python_package();
    pytest(&root().join("tests/python/study"), &[]);
}
