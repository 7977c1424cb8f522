//! The TLS link under traffic both ways at once.
//!
//! zenoh-link-tls 1.10.2 lets the task that reads a link and the task that writes it use one
//! rustls connection at the same time; rustls allows neither, and the process crashes
//! (SIGSEGV) after seconds to minutes of traffic both ways. `third_party/zenoh-link-tls` is
//! that crate with the stream locked per poll. Two sessions over mutual TLS on loopback, each
//! publishing frames as fast as the link takes them while it receives the other's: both run
//! to the end and exit normally, every frame they took intact (checksums verified).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::time::Duration;

use harness::transport::{bench_exe, free_port, s, Proc};

/// Seconds of traffic both ways.
const DUPLEX_S: u64 = 20;

/// The configuration of one side: `a` listens with the server certificate, `b` connects; each
/// presents its own client certificate of the test CA.
fn config(dir: &Path, certs: &Path, me: &str, port: u16) -> String {
    let listen = if me == "a" {
        vec![format!("tls/127.0.0.1:{port}")]
    } else {
        vec![]
    };
    let connect = if me == "b" {
        vec![format!("tls/127.0.0.1:{port}")]
    } else {
        vec![]
    };
    let p = |f: &str| serde_json::Value::String(certs.join(f).display().to_string());
    let text = format!(
        "{{ mode: 'peer', listen: {{ endpoints: {} }}, connect: {{ endpoints: {} }}, \
         scouting: {{ multicast: {{ enabled: false }} }}, transport: {{ link: {{ tls: {{ \
         root_ca_certificate: {}, listen_private_key: {}, listen_certificate: {}, \
         connect_private_key: {}, connect_certificate: {}, enable_mtls: true, \
         verify_name_on_connect: true, close_link_on_expiration: true }} }} }} }}",
        serde_json::json!(listen),
        serde_json::json!(connect),
        p("ca.pem"),
        p("router.key"),
        p("router.pem"),
        p(&format!("{me}.key")),
        p(&format!("{me}.pem")),
    );
    let path = dir.join(format!("{me}.json5"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn a_tls_link_carrying_frames_both_ways_at_once_survives() {
    let dir = tempfile::tempdir().unwrap();
    let certs = dir.path().join("certs");
    pipeline::certs::make_certs(&pipeline::certs::CertsArgs {
        out: certs.clone(),
        roles: vec![pipeline::certs::ROUTER_ROLE],
        extra_names: vec![s("a"), s("b")],
        hosts: vec![s("127.0.0.1")],
        days: 1,
        force: true,
    })
    .unwrap();
    let port = free_port();
    let duplex = |me: &str, other: &str| -> Proc {
        let args = [
            s("z-duplex"),
            s("--send-key"),
            format!("duplex/{me}"),
            s("--recv-key"),
            format!("duplex/{other}"),
            s("--duration-s"),
            DUPLEX_S.to_string(),
            s("-c"),
            config(dir.path(), &certs, me, port),
        ];
        Proc::spawn(me, &bench_exe(), &args, dir.path(), "warn")
    };
    let mut a = duplex("a", "b");
    let mut b = duplex("b", "a");
    for p in [&a, &b] {
        p.ready();
    }
    let timeout = Duration::from_secs(DUPLEX_S + 40);
    for p in [&mut a, &mut b] {
        let st = p.wait(timeout);
        assert!(
            st.success(),
            "{} ended {st:?} (signal {:?}) after traffic both ways over TLS:\n{}",
            p.name,
            st.signal(),
            p.stderr_tail()
        );
        let r: serde_json::Value = serde_json::from_str(&p.line(Duration::from_secs(1))).unwrap();
        eprintln!("{}: {r}", p.name);
        for k in ["sent", "received"] {
            assert!(r[k].as_u64().unwrap() > 100, "{}: {k}: {r}", p.name);
        }
        for k in ["send_errors", "malformed"] {
            assert_eq!(r[k], 0, "{}: {r}", p.name);
        }
    }
}
