//! Deployment across hosts, emulated with two network namespaces joined by a veth pair: a Zenoh
//! router (configured with `deploy/router.json5`), the launcher with the planner, echo and
//! bridge in namespace A, the processor in namespace B, all clients of the router
//! (`deploy/client.json5`). The mission's detections must arrive complete, and equal those of
//! the closed loop.
//!
//! Needs `ip` (iproute2) and the right to create network namespaces (root or CAP_NET_ADMIN);
//! where they cannot be made the test shows as ignored, saying why (`harness::trials`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Duration;

use harness::netns::{config, two_namespaces};
use harness::pipeline::*;
use harness::trials::Test;

fn processor_on_another_host_behind_a_router() {
    let hosts = two_namespaces();
    let router_ip = hosts.ip_a.clone();
    const H: f64 = 30.0;
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let router_cfg = config(dir.path(), "router.json5", &router_ip, None);
    let client_cfg = config(dir.path(), "client.json5", &router_ip, None);
    let (in_a, in_b) = (hosts.in_a(), hosts.in_b());
    let _router = Service::start_in(
        &in_a,
        "router",
        dir.path(),
        &["router".into(), "-c".into(), router_cfg],
    );
    let _processor = Service::start_in(
        &in_b,
        "processor",
        dir.path(),
        &[
            "process".into(),
            "--frames".into(),
            "zenoh".into(),
            "--scene".into(),
            scene().display().to_string(),
            "--resend-after-s".into(),
            "2".into(),
            "-c".into(),
            client_cfg.clone(),
        ],
    );
    let mut l = Launch::start_in(
        &in_a,
        dir.path(),
        H,
        &[
            "--transport",
            "zenoh",
            "--external",
            "processor",
            "-c",
            &client_cfg,
        ],
    );
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    // the processor ran in the other namespace: the launcher saw it only through the router
    assert!(l
        .named("alive")
        .iter()
        .any(|e| e["role"] == "processor" && e["alive"] == true));
    assert!(!l
        .named("child_started")
        .iter()
        .any(|e| e["role"] == "processor"));
    let bridge = l.log("bridge");
    assert!(
        counter(&bridge, "route counters", "out_forwarded").unwrap() >= 30,
        "{bridge}"
    );
}

fn main() {
    harness::trials::main(&[Test::netns(
        "processor_on_another_host_behind_a_router",
        processor_on_another_host_behind_a_router,
    )]);
}
