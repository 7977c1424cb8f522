//! A client of the shipped TLS deployment (`pipeline/deploy/tls/`) whose certificate the
//! router refuses keeps trying, as `connect.timeout_ms: -1` and `exit_on_failure: false`
//! promise: it stays up, says what it waits for, is refused again and again, and stops on
//! SIGTERM with exit code 0. The same file with the deployment's certificate opens its
//! session (so the refusal is the certificate's). On loopback, with `cellsar certs`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use harness::free_port;
use harness::pipeline::*;

/// How long the refused client may take to be refused three times, at most (Zenoh tries
/// again after 1, 2 and 4 s: about 3 s).
const WATCH_S: u64 = 60;

/// `cellsar certs --out DIR`: a CA of its own and every role's certificate.
fn certs(dir: &Path) {
    let o = Command::new(exe())
        .args(["certs", "--out"])
        .arg(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The shipped `pipeline/deploy/tls/<file>` written to `dir`, the router's address
/// `127.0.0.1:port`, the CA certificate `ca`, the other files from `own`.
fn shipped(dir: &Path, file: &str, port: u16, ca: &Path, own: &Path) -> String {
    let text = std::fs::read_to_string(root().join("pipeline/deploy/tls").join(file)).unwrap();
    let client = file != "router.json5";
    for must in ["tls/192.168.1.10:7447", "/etc/cellsar/certs/ca.pem"] {
        assert!(text.contains(must), "{file}: {must}");
    }
    // the promise under test: a client waits for its router, whatever the router says
    assert!(
        !client || (text.contains("timeout_ms: -1") && text.contains("exit_on_failure: false")),
        "{file}"
    );
    let text = text
        .replace("192.168.1.10:7447", &format!("127.0.0.1:{port}"))
        .replace("/etc/cellsar/certs/ca.pem", &ca.display().to_string())
        .replace("/etc/cellsar/certs/", &format!("{}/", own.display()));
    let path = dir.join(format!(
        "{}-{file}",
        own.file_name().unwrap().to_string_lossy()
    ));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn a_client_whose_certificate_the_router_refuses_keeps_trying() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (good, other) = (d.join("certs"), d.join("other-ca"));
    certs(&good);
    certs(&other);
    let ca = good.join("ca.pem");
    let port = free_port();
    let router_cfg = shipped(d, "router.json5", port, &ca, &good);
    let router = Service::start("router", d, &["router".into(), "-c".into(), router_cfg]);
    // the planner's file with a certificate of another CA: the router refuses it
    let refused_cfg = shipped(d, "planner.json5", port, &ca, &other);
    let mut refused = Service::start("refused", d, &["planner".into(), "-c".into(), refused_cfg]);
    let started = Instant::now();
    let refusals = || {
        router
            .log_text()
            .matches("invalid peer certificate: BadSignature")
            .count()
    };
    // refused three times (it tried again, twice), never exiting meanwhile
    while refusals() < 3 {
        assert!(
            refused.child.try_wait().unwrap().is_none(),
            "the refused client exited:\n{}",
            refused.log_text()
        );
        assert!(
            started.elapsed() < Duration::from_secs(WATCH_S),
            "{} refusals in {WATCH_S} s:\n{}",
            refusals(),
            router.log_text()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    refused.wait_for_log(
        "waiting for the Zenoh session to open",
        Duration::from_secs(30),
    );
    let log = refused.log_text();
    assert!(
        log.contains("waiting for the Zenoh session to open")
            && log.contains(&format!("connect [tls/127.0.0.1:{port}]")),
        "{log}"
    );
    assert!(!log.contains("plan service ready"), "{log}");
    // the same file with the deployment's certificate: the session opens
    let good_cfg = shipped(d, "planner.json5", port, &ca, &good);
    let mut accepted = Service::start("accepted", d, &["planner".into(), "-c".into(), good_cfg]);
    accepted.wait_for_log("plan service ready", Duration::from_secs(30));
    assert_eq!(accepted.stop(Duration::from_secs(20)).code(), Some(0));
    // still trying; SIGTERM stops it at once, exit code 0
    assert!(refused.child.try_wait().unwrap().is_none());
    let stopping = Instant::now();
    assert_eq!(
        refused.stop(Duration::from_secs(10)).code(),
        Some(0),
        "{}",
        refused.log_text()
    );
    assert!(stopping.elapsed() < Duration::from_secs(5));
    eprintln!(
        "{} refusals of the client in {:.1} s",
        refusals(),
        started.elapsed().as_secs_f64()
    );
}
