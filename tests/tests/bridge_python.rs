//! The Python `eclipse-zenoh` client tests of the transport (`tests/python/bridge`) against the
//! `cellsar-bridge` binary of this build: the JSON envelope and the bridge's statistics, read by
//! a non-Rust client. The Python packages come from the test environment
//! ([`harness::python`]).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use harness::{bin, pytest, root};

#[test]
fn bridge_python_client() {
    pytest(
        &root().join("tests/python/bridge"),
        &[("CELLSAR_BRIDGE_BIN", &bin("cellsar-bridge"))],
    );
}
