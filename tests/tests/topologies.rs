//! Every Zenoh topology `cellsar run` accepts forms one mesh and ends with the closed loop's
//! outputs: a launcher that is a client of a `cellsar router` started first, a `-c`
//! configuration file, a router launcher; the combinations that cannot form one are refused
//! before anything starts; a launcher or service that waits for a peer says what it waits for
//! and on which endpoints, and the launcher gives up after `--peer-timeout-s`; a processor that
//! joins 10 s after the plan was published gets it, on the same host and across a router; a
//! peer launcher given `-e` without `-l`; multicast scouting, off unless asked for: a
//! standalone service without endpoints is found (and finds a router) only with
//! `--multicast-scouting`, and a client launcher without `-e` finds its router by scouting (in
//! a network namespace of the test's own, so that the multicast reaches nothing else).
//! (The launcher's own mesh and `-l` with scouting off: `system.rs`; `--router` with a
//! `kill -9` of the processor: `reliability.rs`.)

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::ffi::OsString;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use harness::netns::multicast_host;
use harness::pipeline::*;
use harness::trials::Test;

/// 3 apertures of the small scene.
const H: f64 = 30.0;

fn run_args(dir: &Path, extra: &[&str]) -> Vec<OsString> {
    let mut a: Vec<OsString> = vec!["run".into(), mission().into(), "--scene".into()];
    a.push(scene().into());
    a.push("--out".into());
    a.push(dir.join("out").into());
    a.extend(["--horizon-s", "30"].iter().map(OsString::from));
    a.extend(extra.iter().map(OsString::from));
    a
}

/// A `cellsar router` listening on a free loopback port; its endpoint.
fn router(dir: &Path) -> (Service, String) {
    let ep = format!("tcp/127.0.0.1:{}", free_port());
    let r = Service::start("router", dir, &["router".into(), "-l".into(), ep.clone()]);
    wait_for_log(&r, "router running", Duration::from_secs(30));
    (r, ep)
}

fn wait_for_log(s: &Service, needle: &str, timeout: Duration) {
    let deadline = Instant::now() + timeout;
    while !s.log_text().contains(needle) {
        assert!(
            Instant::now() < deadline,
            "{}: no {needle:?} within {timeout:?}:\n{}",
            s.name,
            s.log_text()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The children's Zenoh flags the launcher reported.
fn children_flags(l: &mut Launch) -> Vec<String> {
    let net = l.event("network", Duration::from_secs(60));
    serde_json::from_value(net["children"].clone()).unwrap()
}

fn has_pair(flags: &[String], a: &str, b: &str) -> bool {
    flags.windows(2).any(|w| w[0] == a && w[1] == b)
}

fn finish_as_reference(l: &mut Launch) {
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference(H));
}

/// A `cellsar router` started first, and `cellsar run -m client -e ROUTER`: the launcher and
/// every child are clients of that router.
fn clients_of_a_router_started_first() {
    let dir = tempfile::tempdir().unwrap();
    let (_router, ep) = router(dir.path());
    let mut l = Launch::start(dir.path(), H, &["-m", "client", "-e", &ep]);
    let children = children_flags(&mut l);
    assert!(
        has_pair(&children, "--mode", "client") && has_pair(&children, "--connect", &ep),
        "{children:?}"
    );
    finish_as_reference(&mut l);
}

/// `-c FILE` with a listen endpoint and scouting off: the launcher listens there, the
/// children get the same file with that endpoint as one to connect to.
fn a_configuration_file_with_a_listen_endpoint() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let file = dir.path().join("zenoh.json5");
    std::fs::write(
        &file,
        format!(
            "{{ mode: 'peer', listen: {{ endpoints: ['tcp/0.0.0.0:{port}'] }}, \
             scouting: {{ multicast: {{ enabled: false }} }} }}"
        ),
    )
    .unwrap();
    let mut l = Launch::start(dir.path(), H, &["-c", file.to_str().unwrap()]);
    let children = children_flags(&mut l);
    assert!(
        has_pair(&children, "--config", file.to_str().unwrap())
            && has_pair(&children, "--connect", &format!("tcp/127.0.0.1:{port}")),
        "{children:?}"
    );
    finish_as_reference(&mut l);
}

/// A router launcher (`-m router`, no endpoint given): it listens on a free loopback port
/// and every child, a peer, connects to it; no multicast needed.
fn a_router_launcher_is_the_hub_of_its_children() {
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["-m", "router", "--no-multicast-scouting"]);
    let children = children_flags(&mut l);
    assert!(
        has_pair(&children, "--mode", "peer")
            && children
                .windows(2)
                .any(|w| w[0] == "--connect" && w[1].starts_with("tcp/127.0.0.1:")),
        "{children:?}"
    );
    finish_as_reference(&mut l);
}

/// Combinations that cannot form a mesh are refused before anything starts: exit 2, the
/// flag (or the file) named, no output directory.
fn combinations_that_cannot_form_a_mesh_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let port0 = dir.path().join("port0.json5");
    std::fs::write(
        &port0,
        "{ mode: 'peer', listen: { endpoints: ['tcp/127.0.0.1:0'] } }",
    )
    .unwrap();
    let lonely = dir.path().join("lonely-client.json5");
    std::fs::write(
        &lonely,
        "{ mode: 'client', scouting: { multicast: { enabled: false } } }",
    )
    .unwrap();
    let port0 = port0.to_str().unwrap();
    let lonely = lonely.to_str().unwrap();
    for (flags, named) in [
        (vec!["-c", port0], vec![port0, "port 0"]),
        (
            vec!["--router", "-l", "tcp/127.0.0.1:7447"],
            vec!["--router", "-l tcp/127.0.0.1:7447"],
        ),
        (vec!["--router", "-c", port0], vec!["--router", "-c "]),
        (
            vec!["-m", "client", "--no-multicast-scouting"],
            vec!["-m client", "-e ROUTER"],
        ),
        (vec!["-c", lonely], vec![lonely, "-e ROUTER"]),
        // multicast scouting is off unless asked for: a client without -e has no router
        (
            vec!["-m", "client"],
            vec!["-m client", "--multicast-scouting"],
        ),
        (
            vec!["--router", "--multicast-scouting"],
            vec!["--router with --multicast-scouting"],
        ),
    ] {
        let o = Command::new(exe())
            .args(run_args(dir.path(), &flags))
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {e}");
        for n in named {
            assert!(e.contains(n), "{flags:?}: {n:?} in {e}");
        }
        assert!(!dir.path().join("out").exists(), "{flags:?}");
    }
}

/// A client launcher whose router is not there says within 5 s what it waits for, naming the
/// endpoint, and gives up after `--peer-timeout-s` (exit 1), nothing left behind.
fn a_launcher_without_its_router_gives_up_after_the_peer_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let ep = format!("tcp/127.0.0.1:{}", free_port());
    let e = cellsar_bounded(
        &run_args(
            dir.path(),
            &["-m", "client", "-e", &ep, "--peer-timeout-s", "4"],
        ),
        dir.path(),
        Duration::from_secs(60),
        |_| {},
    );
    assert_eq!(e.code, Some(1), "{}", e.stderr);
    assert!(
        e.elapsed >= Duration::from_secs(4) && e.elapsed < Duration::from_secs(20),
        "gave up after {:?}",
        e.elapsed
    );
    for needle in [
        "waiting for the Zenoh session to open",
        "--peer-timeout-s 4 s",
        &format!("connect [{ep}]"),
    ] {
        assert!(e.stderr.contains(needle), "{needle:?} in\n{}", e.stderr);
    }
    assert!(shm_files(&format!("cs{}x", e.pid)).is_empty());
}

/// A launcher whose `--external processor` never comes gives up waiting for it after
/// `--peer-timeout-s` (exit 1), naming the role and the session's endpoints.
fn a_launcher_gives_up_on_a_processor_that_never_comes() {
    let dir = tempfile::tempdir().unwrap();
    let e = cellsar_bounded(
        &run_args(
            dir.path(),
            &["--external", "processor", "--peer-timeout-s", "3"],
        ),
        dir.path(),
        Duration::from_secs(120),
        |_| {},
    );
    assert_eq!(e.code, Some(1), "{}", e.stderr);
    for needle in [
        "waiting for the processor to announce itself",
        "gave up waiting for the processor",
        "--peer-timeout-s 3 s",
        "mode peer, connect [], listen [unixsock-stream/",
    ] {
        assert!(e.stderr.contains(needle), "{needle:?} in\n{}", e.stderr);
    }
    assert!(shm_files(&format!("cs{}x", e.pid)).is_empty());
}

/// The planner, echo, processor and bridge, started with nobody to talk to, each say within
/// 5 s what they wait for and on which endpoints, and that they wait until stopped.
fn services_say_what_they_wait_for_within_5_s() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene().display().to_string();
    let iox = [
        "--iox-root".to_string(),
        dir.path().join("iox").display().to_string(),
        "--iox-prefix".to_string(),
        format!("cswait{}_", std::process::id()),
    ];
    let zenoh = ["-l", "tcp/127.0.0.1:0", "--no-multicast-scouting"].map(String::from);
    let started = Instant::now();
    let services: Vec<(Service, &str)> = [
        (
            "planner",
            vec!["planner".to_string()],
            "waiting for a plan request on cellsar/plan",
        ),
        (
            "echo",
            [
                &["echo".to_string(), "--scene".into(), scene.clone()][..],
                &iox,
            ]
            .concat(),
            "waiting for a plan (cellsar/*/plan",
        ),
        (
            "processor",
            [&["process".to_string(), "--scene".into(), scene][..], &iox].concat(),
            "waiting for a plan (cellsar/*/plan",
        ),
        (
            "bridge",
            [
                &[
                    "bridge".to_string(),
                    "--service".into(),
                    "cellsar/0123456789abcdef/echo@out".into(),
                ][..],
                &iox,
            ]
            .concat(),
            "waiting for frames on iceoryx2 cellsar/0123456789abcdef/echo",
        ),
    ]
    .into_iter()
    .map(|(name, mut args, needle)| {
        args.extend(zenoh.iter().cloned());
        (Service::start(name, dir.path(), &args), needle)
    })
    .collect();
    for (s, needle) in &services {
        let left = Duration::from_secs(5).saturating_sub(started.elapsed());
        wait_for_log(s, needle, left);
        let log = s.log_text();
        assert!(
            log.contains("mode peer, connect [], listen [tcp/127.0.0.1:0]")
                && log.contains("waits until SIGINT/SIGTERM"),
            "{}:\n{log}",
            s.name
        );
    }
    for (mut s, _) in services {
        assert!(
            s.stop(Duration::from_secs(20)).success(),
            "{}",
            s.log_text()
        );
    }
    let prefix = format!("cswait{}_", std::process::id());
    for f in shm_files(&prefix) {
        let _ = std::fs::remove_file(Path::new("/dev/shm").join(f));
    }
}

/// The processor joins 10 s after the plan was published (the launcher runs everything else;
/// `--external processor`): it takes the plan from the processes that hold it (the plan
/// lookup every process answers) and the run ends with the closed loop's outputs. The
/// launcher says meanwhile that it waits for the processor.
fn late_processor(launcher_zenoh: &[&str], processor_zenoh: &[String], extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let iox_root = dir.path().join("iox").display().to_string();
    let prefix = format!("cslate{}_{}_", std::process::id(), free_port());
    let mut flags: Vec<&str> = vec![
        "--external",
        "processor",
        "--iox-root",
        &iox_root,
        "--iox-prefix",
        &prefix,
    ];
    flags.extend_from_slice(launcher_zenoh);
    flags.extend_from_slice(extra);
    let mut l = Launch::start(dir.path(), H, &flags);
    l.event("planned", Duration::from_secs(120));
    std::thread::sleep(Duration::from_secs(10));
    let mut args: Vec<String> = vec![
        "process".into(),
        "--scene".into(),
        scene().display().to_string(),
        "--resend-after-s".into(),
        "2".into(),
        "--iox-root".into(),
        iox_root.clone(),
        "--iox-prefix".into(),
        prefix.clone(),
    ];
    if extra.contains(&"zenoh") {
        args.extend(["--frames".to_string(), "zenoh".into()]);
    }
    args.extend(processor_zenoh.iter().cloned());
    let mut p = Service::start("processor", dir.path(), &args);
    let waiting = l.wait_for(
        "the launcher waiting for the processor",
        Duration::from_secs(5),
        |e| e["event"] == "waiting" && e["for"].as_str().is_some_and(|w| w.contains("processor")),
    );
    assert!(
        waiting["session"]
            .as_str()
            .is_some_and(|s| s.contains("connect [")),
        "{waiting}"
    );
    finish_as_reference(&mut l);
    assert!(
        p.stop(Duration::from_secs(20)).success(),
        "{}",
        p.log_text()
    );
    assert!(p.log_text().contains("plan received"), "{}", p.log_text());
    for f in shm_files(&prefix) {
        let _ = std::fs::remove_file(Path::new("/dev/shm").join(f));
    }
}

fn a_processor_joining_10_s_after_the_plan_on_the_same_host() {
    let hub = format!("tcp/127.0.0.1:{}", free_port());
    let processor = [
        "-e",
        &hub,
        "-l",
        "tcp/127.0.0.1:0",
        "--no-multicast-scouting",
    ]
    .map(String::from);
    late_processor(&["-l", &hub, "--no-multicast-scouting"], &processor, &[]);
}

fn a_processor_joining_10_s_after_the_plan_across_a_router() {
    let dir = tempfile::tempdir().unwrap();
    let (_router, ep) = router(dir.path());
    let processor = ["-m", "client", "-e", &ep].map(String::from);
    late_processor(
        &["-m", "client", "-e", &ep],
        &processor,
        &["--transport", "zenoh"],
    );
}

/// A peer launcher given `-e` and no `-l`: it listens on a free loopback port and every child
/// connects to it and to the `-e` endpoint, here a planner started by hand
/// (`--external planner`), which the launcher and its children reach only through `-e`
/// (multicast scouting is off).
fn a_peer_launcher_given_a_connect_endpoint_and_no_listen_endpoint() {
    let dir = tempfile::tempdir().unwrap();
    let ep = format!("tcp/127.0.0.1:{}", free_port());
    let planner = Service::start(
        "planner",
        dir.path(),
        &["planner".into(), "-l".into(), ep.clone()],
    );
    wait_for_log(
        &planner,
        "waiting for a plan request",
        Duration::from_secs(30),
    );
    let mut l = Launch::start(dir.path(), H, &["-e", &ep, "--external", "planner"]);
    let children = children_flags(&mut l);
    assert!(
        has_pair(&children, "--mode", "peer")
            && has_pair(&children, "--connect", &ep)
            && children
                .windows(2)
                .any(|w| w[0] == "--connect" && w[1] != ep && w[1].starts_with("tcp/127.0.0.1:"))
            && !children.contains(&"--multicast-scouting".to_string()),
        "{children:?}"
    );
    finish_as_reference(&mut l);
    assert!(
        !l.named("child_started")
            .iter()
            .any(|e| e["role"] == "planner"),
        "the planner was external"
    );
}

/// A `cellsar router` that answers multicast scouting (`--multicast-scouting`), in `ns`; its
/// endpoint (given to no one: it is found by scouting).
fn scouting_router(ns: &[&str], dir: &Path) -> Service {
    let ep = format!("tcp/127.0.0.1:{}", free_port());
    let r = Service::start_in(
        ns,
        "router",
        dir,
        &[
            "router".into(),
            "--multicast-scouting".into(),
            "-l".into(),
            ep,
        ],
    );
    wait_for_log(&r, "router running", Duration::from_secs(30));
    r
}

/// A standalone service started without endpoints and without `--multicast-scouting` (here
/// the planner) finds no one and is found by no one on the same host, even by a router and a
/// launcher that scout: the launcher gives up on the planner after `--plan-timeout-s`. With
/// `--multicast-scouting` the same planner finds the router, and the launcher gets its plan.
fn a_standalone_service_scouts_only_when_asked() {
    let (_guard, ns) = multicast_host();
    let ns = ["ip", "netns", "exec", ns.as_str()];
    let dir = tempfile::tempdir().unwrap();
    let _router = scouting_router(&ns, dir.path());
    let launcher = [
        "-m",
        "client",
        "--multicast-scouting",
        "--external",
        "planner",
    ];

    let mut quiet = Service::start_in(&ns, "planner-default", dir.path(), &["planner".into()]);
    wait_for_log(
        &quiet,
        "waiting for a plan request",
        Duration::from_secs(30),
    );
    let first = dir.path().join("without");
    std::fs::create_dir_all(&first).unwrap();
    let mut l = Launch::start_in(
        &ns,
        &first,
        H,
        &[&launcher[..], &["--plan-timeout-s", "8"]].concat(),
    );
    let st = l.finish(Duration::from_secs(120));
    assert_eq!(st.code(), Some(1), "{}", l.stderr_tail());
    assert!(
        l.stderr_tail()
            .contains("no plan within --plan-timeout-s 8 s"),
        "{}",
        l.stderr_tail()
    );
    let log = quiet.log_text();
    assert!(
        log.contains("routers=0 peers=0") && !log.contains("multicast scouting on"),
        "{log}"
    );
    assert!(quiet.stop(Duration::from_secs(20)).success(), "{log}");

    let scouting = Service::start_in(
        &ns,
        "planner-scouting",
        dir.path(),
        &["planner".into(), "--multicast-scouting".into()],
    );
    let second = dir.path().join("with");
    std::fs::create_dir_all(&second).unwrap();
    let mut l = Launch::start_in(&ns, &second, H, &launcher);
    l.event("planned", Duration::from_secs(120));
    assert!(
        scouting.log_text().contains("multicast scouting on"),
        "{}",
        scouting.log_text()
    );
}

/// A `cellsar router` with multicast scouting and `cellsar run -m client --multicast-scouting`
/// without `-e`: the launcher and every child (clients with the same flags) find the router by
/// scouting, and the run ends with the closed loop's outputs.
fn a_client_launcher_finds_its_router_by_multicast_scouting() {
    let (_guard, ns) = multicast_host();
    let ns = ["ip", "netns", "exec", ns.as_str()];
    let dir = tempfile::tempdir().unwrap();
    let _router = scouting_router(&ns, dir.path());
    let mut l = Launch::start_in(
        &ns,
        dir.path(),
        H,
        &["-m", "client", "--multicast-scouting"],
    );
    let children = children_flags(&mut l);
    assert!(
        has_pair(&children, "--mode", "client")
            && children.contains(&"--multicast-scouting".to_string())
            && !children.contains(&"--connect".to_string()),
        "{children:?}"
    );
    finish_as_reference(&mut l);
}

fn main() {
    harness::trials::main(&[
        Test::plain(
            "clients_of_a_router_started_first",
            clients_of_a_router_started_first,
        ),
        Test::plain(
            "a_configuration_file_with_a_listen_endpoint",
            a_configuration_file_with_a_listen_endpoint,
        ),
        Test::plain(
            "a_router_launcher_is_the_hub_of_its_children",
            a_router_launcher_is_the_hub_of_its_children,
        ),
        Test::plain(
            "combinations_that_cannot_form_a_mesh_are_refused",
            combinations_that_cannot_form_a_mesh_are_refused,
        ),
        Test::plain(
            "a_launcher_without_its_router_gives_up_after_the_peer_timeout",
            a_launcher_without_its_router_gives_up_after_the_peer_timeout,
        ),
        Test::plain(
            "a_launcher_gives_up_on_a_processor_that_never_comes",
            a_launcher_gives_up_on_a_processor_that_never_comes,
        ),
        Test::plain(
            "services_say_what_they_wait_for_within_5_s",
            services_say_what_they_wait_for_within_5_s,
        ),
        Test::plain(
            "a_processor_joining_10_s_after_the_plan_on_the_same_host",
            a_processor_joining_10_s_after_the_plan_on_the_same_host,
        ),
        Test::plain(
            "a_processor_joining_10_s_after_the_plan_across_a_router",
            a_processor_joining_10_s_after_the_plan_across_a_router,
        ),
        Test::plain(
            "a_peer_launcher_given_a_connect_endpoint_and_no_listen_endpoint",
            a_peer_launcher_given_a_connect_endpoint_and_no_listen_endpoint,
        ),
        Test::netns(
            "a_standalone_service_scouts_only_when_asked",
            a_standalone_service_scouts_only_when_asked,
        ),
        Test::netns(
            "a_client_launcher_finds_its_router_by_multicast_scouting",
            a_client_launcher_finds_its_router_by_multicast_scouting,
        ),
    ]);
}
