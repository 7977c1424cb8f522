//! The Python `eclipse-zenoh` client tests (`tests/python/pipeline`) against the `cellsar`
//! binary of this build: the JSON side of the wire format, read by a non-Rust client. The
//! Python packages come from the test environment ([`harness::python`]).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use harness::{bin, pytest, root};

#[test]
fn pipeline_python_client() {
    pytest(
        &root().join("tests/python/pipeline"),
        &[("CELLSAR_BIN", &bin("cellsar"))],
    );
}
