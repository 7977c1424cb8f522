//! Services and the launcher started before their Zenoh router: each says what it waits for
//! and stops within a moment of SIGINT or SIGTERM, with its documented exit code, leaving
//! nothing in /dev/shm.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::ffi::OsString;
use std::time::Duration;

use harness::pipeline::*;

/// A Zenoh client configuration file in `dir`, as `deploy/client.json5` (waits for its router:
/// `connect.timeout_ms: -1`), whose router, at an unused loopback port, never comes.
fn client_without_router(dir: &std::path::Path) -> (std::path::PathBuf, std::net::TcpListener) {
    // the router's port stays held by a listener that never answers Zenoh's handshake, so that
    // no other test's process can take it while this one runs (a free port picked and
    // released was once taken by a peer of a test running beside it, and the session opened)
    let held = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = held.local_addr().unwrap().port();
    let file = dir.join("client.json5");
    let text = std::fs::read_to_string(root().join("pipeline/deploy/client.json5"))
        .unwrap()
        .replace("tcp/192.168.1.10:7447", &format!("tcp/127.0.0.1:{port}"));
    assert!(text.contains("timeout_ms: -1"), "{text}");
    std::fs::write(&file, text).unwrap();
    (file, held)
}

/// Sends `sig` to `pid` once `wait` has passed (from a thread of its own).
fn signal_after(pid: u32, sig: Signal, wait: Duration) {
    std::thread::spawn(move || {
        std::thread::sleep(wait);
        signal(pid, sig);
    });
}

/// Every service started before its router (the deployment's client.json5, no router at its
/// address) says what it waits for and stops within a moment of SIGINT, exit code 0, as a
/// running one does: `cellsar planner|echo|process|bridge` (the code of `cellsar-planner
/// serve`, `cellsar-radar-sim echo|process-service`, `cellsar-bridge`).
#[test]
fn services_waiting_for_their_router_stop_on_sigint() {
    services_waiting_for_their_router_stop_on(Signal::SIGINT, "csnorouter_");
}

/// The same with SIGTERM (what a service manager sends): exit code 0 within a moment.
#[test]
fn services_waiting_for_their_router_stop_on_sigterm() {
    services_waiting_for_their_router_stop_on(Signal::SIGTERM, "csnoroutert_");
}

/// Starts each service before its router, sends it `sig` after 3 s, and checks that it said
/// what it waited for and stopped at once, exit code 0; `iox_prefix` is theirs in /dev/shm.
fn services_waiting_for_their_router_stop_on(sig: Signal, iox_prefix: &str) {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, _held) = client_without_router(dir.path());
    let cfg = cfg.to_str().unwrap();
    let scene = scene();
    let scene = scene.to_str().unwrap();
    let iox_root = dir.path().join("iox");
    let iox = [
        "--iox-root",
        iox_root.to_str().unwrap(),
        "--iox-prefix",
        iox_prefix,
    ];
    let roles: Vec<(&str, Vec<&str>)> = vec![
        ("planner", vec!["planner"]),
        ("echo", [&["echo", "--scene", scene][..], &iox].concat()),
        (
            "process",
            [&["process", "--scene", scene][..], &iox].concat(),
        ),
        (
            "bridge",
            [
                &["bridge", "--service", "cellsar/0123456789abcdef/echo@out"][..],
                &iox,
            ]
            .concat(),
        ),
    ];
    let sig_after = Duration::from_millis(3000);
    let ends: Vec<_> = roles
        .into_iter()
        .map(|(role, args)| {
            let args: Vec<OsString> = args
                .iter()
                .copied()
                .chain(["-c", cfg])
                .map(OsString::from)
                .collect();
            let d = dir.path().join(role);
            std::fs::create_dir_all(&d).unwrap();
            std::thread::spawn(move || {
                let e = cellsar_bounded(&args, &d, Duration::from_secs(30), |pid| {
                    signal_after(pid, sig, sig_after)
                });
                (role, e)
            })
        })
        .collect();
    for h in ends {
        let (role, e) = h.join().unwrap();
        assert_eq!(e.code, Some(0), "{role}, {sig}: {}", e.stderr);
        assert!(
            e.elapsed < sig_after + Duration::from_secs(3),
            "{role}: stopped {:?} after the start, {sig} at {sig_after:?}",
            e.elapsed
        );
        // the default log level (no RUST_LOG here) shows what it waited for, and the stop
        for needle in [
            "waiting for the Zenoh session to open",
            "mode client, connect [tcp/127.0.0.1:",
            "stopped before the Zenoh session opened",
        ] {
            assert!(
                e.stderr.contains(needle),
                "{role}: {needle:?} in\n{}",
                e.stderr
            );
        }
    }
    assert!(shm_files(iox_prefix).is_empty());
}

/// The launcher of a deployment (`--external processor -c client.json5`) started before the
/// router stops on SIGINT or SIGTERM within a moment: exit 130, as documented, nothing left
/// behind.
#[test]
fn launcher_waiting_for_its_router_exits_130_on_sigint_or_sigterm() {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, _held) = client_without_router(dir.path());
    let sig_after = Duration::from_millis(3000);
    for sig in [Signal::SIGINT, Signal::SIGTERM] {
        let e = cellsar_bounded(
            &run_args(
                dir.path(),
                "out",
                &[
                    "--transport",
                    "zenoh",
                    "--external",
                    "processor",
                    "-c",
                    cfg.to_str().unwrap(),
                ],
            ),
            dir.path(),
            Duration::from_secs(40),
            |pid| signal_after(pid, sig, sig_after),
        );
        assert_eq!(e.code, Some(130), "{sig}: {}", e.stderr);
        assert!(
            e.elapsed < sig_after + Duration::from_secs(3),
            "stopped {:?} after the start, {sig} at {sig_after:?}:\n{}",
            e.elapsed,
            e.stderr
        );
        assert!(e.stderr.contains("interrupted"), "{sig}: {}", e.stderr);
        assert!(shm_files(&format!("cs{}x", e.pid)).is_empty());
    }
}
