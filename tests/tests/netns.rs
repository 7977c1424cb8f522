//! Deployment across hosts, emulated with two network namespaces joined by a veth pair: a Zenoh
//! router (configured with `deploy/router.json5`), the launcher with the planner, echo and
//! bridge in namespace A, the processor in namespace B, all clients of the router
//! (`deploy/client.json5`). The mission's detections must arrive complete, and equal those of
//! the closed loop.
//!
//! Needs `ip` (iproute2) and the right to create network namespaces (root or CAP_NET_ADMIN);
//! the test is skipped, saying why, only when `ip netns add` is refused for lack of permission.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use harness::pipeline::*;

struct Netns {
    names: Vec<String>,
}

impl Drop for Netns {
    fn drop(&mut self) {
        for n in &self.names {
            let _ = Command::new("ip").args(["netns", "del", n]).status();
        }
    }
}

fn ip(args: &[&str]) {
    let o = Command::new("ip").args(args).output().expect("running ip");
    assert!(
        o.status.success(),
        "ip {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Two namespaces joined by veth, addresses 10.X.Y.1 (A) and 10.X.Y.2 (B); None (with the
/// reason printed) when namespaces may not be created here.
fn two_namespaces() -> Option<(Netns, String, String, String)> {
    let pid = std::process::id();
    let (a, b) = (format!("csa{pid}"), format!("csb{pid}"));
    let o = match Command::new("ip").args(["netns", "add", &a]).output() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("SKIPPED: cannot run `ip` ({e}); install iproute2");
            return None;
        }
    };
    if !o.status.success() {
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        if err.contains("Permission denied") || err.contains("Operation not permitted") {
            eprintln!(
                "SKIPPED: `ip netns add` is not permitted here ({})",
                err.trim()
            );
            return None;
        }
        panic!("ip netns add {a}: {err}");
    }
    let ns = Netns {
        names: vec![a.clone(), b.clone()],
    };
    ip(&["netns", "add", &b]);
    let (va, vb) = (format!("cva{pid}"), format!("cvb{pid}"));
    ip(&["link", "add", &va, "type", "veth", "peer", "name", &vb]);
    ip(&["link", "set", &va, "netns", &a]);
    ip(&["link", "set", &vb, "netns", &b]);
    let net = format!("10.{}.{}", 100 + pid % 100, (pid / 100) % 250);
    let (ha, hb) = (format!("{net}.1"), format!("{net}.2"));
    ip(&["-n", &a, "addr", "add", &format!("{ha}/24"), "dev", &va]);
    ip(&["-n", &b, "addr", "add", &format!("{hb}/24"), "dev", &vb]);
    for (n, v) in [(&a, &va), (&b, &vb)] {
        ip(&["-n", n, "link", "set", v, "up"]);
        ip(&["-n", n, "link", "set", "lo", "up"]);
    }
    Some((ns, a, b, ha))
}

/// A deployment config of `deploy/` with the router address replaced.
fn config(dir: &Path, name: &str, router: &str) -> String {
    let text = std::fs::read_to_string(root().join("pipeline/deploy").join(name)).unwrap();
    assert!(
        text.contains("192.168.1.10"),
        "{name} lost its example address"
    );
    let p = dir.join(name);
    std::fs::write(&p, text.replace("192.168.1.10", router)).unwrap();
    p.display().to_string()
}

#[test]
fn processor_on_another_host_behind_a_router() {
    let Some((_ns, a, b, router_ip)) = two_namespaces() else {
        return;
    };
    const H: f64 = 30.0;
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let router_cfg = config(dir.path(), "router.json5", &router_ip);
    let client_cfg = config(dir.path(), "client.json5", &router_ip);
    let in_a = ["ip", "netns", "exec", a.as_str()];
    let in_b = ["ip", "netns", "exec", b.as_str()];
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
