//! Two `cellsar run`s on one host at the same time, each on its private mesh, do not see each
//! other: both end with the closed loop's outputs, and neither's event log or `pipeline.json`
//! names the other's mission, launcher, mesh or iceoryx2 prefix.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Duration;

use harness::pipeline::*;
use serde_json::Value;

/// Run A's horizon; run B's is [`H_B`], so that the two missions (and their ids) differ.
const H_A: f64 = 30.0;
const H_B: f64 = 20.0;

/// The value of `flag` in the list `key` (`launcher`, `children`, `iox`) of a `network` event.
fn flag_of(net: &Value, key: &str, flag: &str) -> String {
    let args: Vec<String> = serde_json::from_value(net[key].clone()).unwrap();
    let i = args
        .iter()
        .position(|a| a == flag)
        .unwrap_or_else(|| panic!("no {flag} in {key}: {args:?}"));
    args[i + 1].clone()
}

/// What marks a run: its mission id, its launcher's instance, its mesh directory and its
/// iceoryx2 prefix.
fn marks(l: &Launch) -> Vec<String> {
    let net = &l.named("network")[0];
    let hub = flag_of(net, "launcher", "--listen");
    let mesh = hub
        .strip_prefix("unixsock-stream/")
        .and_then(|p| p.strip_suffix("/hub.sock"))
        .unwrap_or_else(|| panic!("not a socket of a mesh directory: {hub}"))
        .to_string();
    vec![
        l.pipeline_json()["mission_id"]
            .as_str()
            .unwrap()
            .to_string(),
        format!("launcher-{}", l.child.id()),
        mesh,
        flag_of(net, "iox", "--iox-prefix"),
    ]
}

/// Checks that run `l` saw only its own processes (every liveliness token its own launcher's or
/// one of its roles', every service's status of its own mission, nothing refused or foreign)
/// and that nothing of it names `other`'s marks.
fn saw_only_itself(name: &str, l: &Launch, other: &[String]) {
    let p = l.pipeline_json();
    let own = format!("launcher-{}", l.child.id());
    for e in l.named("alive") {
        let instance = e["instance"].as_str().unwrap();
        assert!(
            instance == own || ["planner", "echo", "processor"].contains(&instance),
            "{name} saw {e}"
        );
    }
    for (role, s) in p["services"].as_object().unwrap() {
        assert_eq!(s["mission_id"], p["mission_id"], "{name}: {role} {s}");
    }
    let c = &p["collector"];
    for key in [
        "foreign",
        "refused_senders",
        "duplicates",
        "malformed",
        "refused_plans",
    ] {
        assert_eq!(c[key], 0, "{name}: {key} in {c}");
    }
    let events: Vec<String> = l.seen.iter().map(Value::to_string).collect();
    let text = format!("{p}\n{}", events.join("\n"));
    for m in other {
        assert!(
            !text.contains(m.as_str()),
            "{name} names {m} of the other run"
        );
    }
}

/// Run A plans and waits for its echo (started by hand later) while run B, started meanwhile,
/// runs to its end; then A's echo comes and A ends too. Had the runs shared a mesh, B's
/// liveliness tokens, statuses and results (another mission's) would reach A's launcher,
/// and A's would reach B's.
/// The TCP and UDP sockets of process `pid` that listen or are bound unconnected (the
/// `local address:port` of each, hexadecimal as `/proc/net/*` gives it).
fn inet_listeners(pid: u32) -> Vec<String> {
    let inodes: Vec<String> = std::fs::read_dir(format!("/proc/{pid}/fd"))
        .unwrap()
        .flatten()
        .filter_map(|e| std::fs::read_link(e.path()).ok())
        .filter_map(|l| {
            let l = l.to_string_lossy().to_string();
            l.strip_prefix("socket:[")
                .and_then(|r| r.strip_suffix(']'))
                .map(str::to_string)
        })
        .collect();
    let mut found = Vec::new();
    // TCP LISTEN is state 0A; a bound UDP socket without a peer is 07
    for (table, state) in [("tcp", "0A"), ("tcp6", "0A"), ("udp", "07"), ("udp6", "07")] {
        let text = std::fs::read_to_string(format!("/proc/{pid}/net/{table}")).unwrap_or_default();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split_whitespace().collect();
            if f.len() > 9 && f[3] == state && inodes.iter().any(|i| i == f[9]) {
                found.push(format!("{table} {}", f[1]));
            }
        }
    }
    found
}

#[test]
fn two_runs_on_one_host_do_not_see_each_other() {
    let (ref_a, ref_b) = (reference(H_A), reference(H_B));
    let (dir_a, dir_b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    // A waits for its echo up to 180 s (B runs meanwhile, on a loaded machine too)
    let mut a = Launch::start(
        dir_a.path(),
        H_A,
        &["--external", "echo", "--peer-timeout-s", "180"],
    );
    let net_a = a.event("network", Duration::from_secs(60));
    a.event("planned", Duration::from_secs(120));
    // the private mesh is Unix sockets only: no process of A listens on TCP or UDP
    for (who, pid) in [
        ("launcher", a.child.id()),
        ("planner", a.pid("planner")),
        ("processor", a.pid("processor")),
    ] {
        let inet = inet_listeners(pid);
        assert!(inet.is_empty(), "A's {who} listens on {inet:?}");
    }
    let mut b = Launch::start(dir_b.path(), H_B, &[]);
    let st = b.finish(Duration::from_secs(240));
    assert!(st.success(), "B: {st:?}\n{}", b.stderr_tail());
    // A was up all along, its mission still waiting for its echo
    assert!(a.child.try_wait().unwrap().is_none(), "{}", a.stderr_tail());
    assert!(a.named("aperture").is_empty(), "{:?}", a.seen);
    let mut echo = Service::start("echo", dir_a.path(), &echo_args(&net_a));
    let st = a.finish(Duration::from_secs(240));
    assert!(st.success(), "A: {st:?}\n{}", a.stderr_tail());
    assert!(echo.stop(Duration::from_secs(20)).success());
    assert_same_as_reference(&a.out, &ref_a);
    assert_same_as_reference(&b.out, &ref_b);
    let (marks_a, marks_b) = (marks(&a), marks(&b));
    for k in 0..marks_a.len() {
        assert_ne!(marks_a[k], marks_b[k]);
    }
    saw_only_itself("A", &a, &marks_b);
    saw_only_itself("B", &b, &marks_a);
    // each run's mesh directory is gone; nothing of B is left in /dev/shm (A's echo, started
    // by hand, may leave its segments after A's launcher cleaned up: removed here)
    for m in [&marks_a, &marks_b] {
        assert!(!std::path::Path::new(&m[2]).exists(), "{}", m[2]);
    }
    for f in shm_files(&marks_a[3]) {
        let _ = std::fs::remove_file(format!("/dev/shm/{f}"));
    }
    assert!(shm_files(&marks_b[3]).is_empty());
}
