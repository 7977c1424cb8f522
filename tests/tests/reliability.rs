//! Reliability with the real processes: kill -9 of each process mid-mission, a frozen
//! subscriber, 10,000 malformed or oversized payloads on every subscribed key and messages
//! above Zenoh's reassembly limit, with the flooded processes' peak resident memory bounded.
//! Each run must end with exactly the outputs of the closed loop (no aperture lost or
//! duplicated).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use bridge::net::QueryOptions;
use bridge::zconfig::DEFAULT_MAX_MESSAGE_BYTES;
use bridge::zenoh::bytes::{Encoding, ZBytes};
use bridge::zenoh::qos::CongestionControl;
use bridge::zenoh::query::QueryTarget;
use bridge::zenoh::Wait;
use bridge::{MissionId, ZenohArgs, ZenohNode};
use harness::memory::Baseline;
use harness::pipeline::*;
use pipeline::protocol::keys as pkeys;
use pipeline::protocol::{ApertureRequest, RequestAck};
use serde_json::Value;

/// 6 apertures of the small scene.
const H: f64 = 60.0;

/// The run (started with `--strict`) exits 0 when every landmark in view was detected, else 4.
fn expect_exit(l: &mut Launch, reference: &std::path::Path) {
    let st = l.finish(Duration::from_secs(240));
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(reference.join("report.json")).unwrap())
            .unwrap();
    let want = if report["all_in_view_detected"] == true {
        0
    } else {
        4
    };
    assert_eq!(st.code(), Some(want), "{}", l.stderr_tail());
    assert_same_as_reference(&l.out, reference);
}

/// Kills `role` with SIGKILL once the first aperture is in, checks that the others kept
/// running, that liveliness reported the loss, that the role was restarted and that the run
/// completes with the closed loop's outputs, leaving none of its iceoryx2 frame files (which
/// existed when the role was killed, once frames flowed) in `/dev/shm`.
fn kill_mid_mission(role: &str, extra: &[&str]) -> Launch {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["--window", "1", "--strict"];
    args.extend_from_slice(extra);
    let mut l = Launch::start(dir.path(), H, &args);
    let net = l.event("network", Duration::from_secs(60));
    let iox: Vec<String> = serde_json::from_value(net["iox"].clone()).unwrap();
    let prefix = iox[iox.iter().position(|a| a == "--iox-prefix").unwrap() + 1].clone();
    l.event("planned", Duration::from_secs(120));
    if role != "planner" {
        l.wait_for("the first aperture", Duration::from_secs(120), |e| {
            e["event"] == "aperture" && e["done"] == 1
        });
        assert!(
            !shm_files(&prefix).is_empty(),
            "no frame files while imaging"
        );
    }
    let victim = l.pid(role);
    let others: Vec<(String, u32)> = ["planner", "echo", "processor", "bridge", "router"]
        .iter()
        .filter(|r| **r != role)
        .filter(|r| {
            l.seen
                .iter()
                .any(|e| e["event"] == "child_started" && e["role"] == **r)
        })
        .map(|r| (r.to_string(), l.pid(r)))
        .collect();
    signal(victim, Signal::SIGKILL);
    l.wait_for("the liveliness loss", Duration::from_secs(60), |e| {
        e["event"] == "alive" && e["role"] == role && e["alive"] == false
    });
    l.wait_for("the restart", Duration::from_secs(60), |e| {
        e["event"] == "child_restarted" && e["role"] == role
    });
    // the others were not restarted: still the same processes
    for (r, pid) in &others {
        assert_eq!(l.pid(r), *pid, "{r} was restarted too");
        assert!(
            running(*pid) || l.child.try_wait().unwrap().is_some(),
            "{r} died"
        );
    }
    expect_exit(&mut l, &reference);
    let left = shm_files(&prefix);
    assert!(left.is_empty(), "{role} killed: left {left:?}");
    let exits: Vec<Value> = l.named("child_exited");
    assert_eq!(exits.len(), 1, "{exits:?}");
    assert!(exits[0]["status"].as_str().unwrap().contains("signal 9"));
    // keep the directory alive for the caller's checks
    std::mem::forget(dir);
    l
}

#[test]
fn kill9_planner() {
    let l = kill_mid_mission("planner", &[]);
    // the restarted planner has the plan from its state directory
    assert!(
        l.log("planner").contains("plans restored"),
        "{}",
        l.log("planner")
    );
}

#[test]
fn kill9_echo() {
    let l = kill_mid_mission("echo", &[]);
    let p = l.pipeline_json();
    let c = &p["services"]["processor"]["counters"];
    assert!(c["resends"].as_u64().unwrap() >= 1, "{c}");
}

#[test]
fn kill9_processor() {
    let l = kill_mid_mission("processor", &[]);
    let p = l.pipeline_json();
    let c = &p["services"]["processor"]["counters"];
    // the restarted processor resumed from its state directory
    assert!(c["restored"].as_u64().unwrap() >= 1, "{c}");
    assert!(c["apertures"].as_u64().unwrap() <= 5, "{c}");
}

/// `--router` (the launcher and every child clients of a router child) with a `kill -9` of
/// the processor: restarted, it finds the mesh through the router and resumes.
#[test]
fn kill9_processor_behind_the_router() {
    let l = kill_mid_mission("processor", &["--router"]);
    let p = l.pipeline_json();
    let c = &p["services"]["processor"]["counters"];
    assert!(c["restored"].as_u64().unwrap() >= 1, "{c}");
    assert_eq!(p["router"], true);
}

#[test]
fn kill9_bridge() {
    let l = kill_mid_mission("bridge", &["--transport", "zenoh"]);
    let p = l.pipeline_json();
    assert_eq!(p["restarts"]["bridge"], 1);
}

#[test]
fn kill9_router() {
    let l = kill_mid_mission("router", &["--router", "--transport", "zenoh"]);
    let p = l.pipeline_json();
    assert_eq!(p["restarts"]["router"], 1);
    assert_eq!(p["router"], true);
}

#[test]
fn frozen_processor_does_not_stall_the_echo() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    // through a router: the test's session reaches the echo whatever the state of the others
    let mut l = Launch::start(dir.path(), H, &["--router", "--strict"]);
    let z = join(&mut l);
    let node = ZenohNode::open(z.to_config().unwrap(), "tester", "freeze").unwrap();
    let planned = l.event("planned", Duration::from_secs(120));
    let m = MissionId::parse_hex(planned["mission_id"].as_str().unwrap()).unwrap();
    let fp = planned["frame_pulses"].as_u64().unwrap() as u32;
    // the run's scene, whose digest the echo checks in every request
    let scene_digest = radar_sim::config::SceneFile::from_path(&scene())
        .unwrap()
        .digest();
    // the processor is subscribed once it has finished an aperture; freeze it at once (the
    // mission cannot finish while it is frozen; a 60 s mission is otherwise over in about a
    // second, before this session could reach the echo)
    l.wait_for("the first aperture", Duration::from_secs(120), |e| {
        e["event"] == "aperture" && e["done"] == 1
    });
    let proc = l.pid("processor");
    signal(proc, Signal::SIGSTOP);
    wait_sees(&node, "echo", &l);
    let before = l.seen.len();
    // make the echo publish 4 apertures (40 frames) into the frozen reader's full buffer
    let t0 = Instant::now();
    for ap in 0..4 {
        let req = ApertureRequest {
            mission_id: m,
            aperture: ap,
            look: None,
            frame_pulses: fp,
            scene_digest,
            requester: "test".into(),
        };
        let ack = node
            .query_one::<ApertureRequest, RequestAck>(
                &pkeys::echo_request(m).unwrap(),
                &req,
                &QueryOptions {
                    timeout: Duration::from_secs(30),
                    ..QueryOptions::default()
                },
            )
            .unwrap_or_else(|e| panic!("{e} after {:.1} s", t0.elapsed().as_secs_f64()));
        assert_eq!(ack.message.seqs.len(), 10);
    }
    // the echo sends all of them while the reader is frozen: it is not stalled
    let done = l.wait_for(
        "the echo to skip 30 deliveries",
        Duration::from_secs(60),
        |e| {
            e["event"] == "status"
                && e["role"] == "echo"
                && e["counters"]["skipped_full"].as_u64().unwrap_or(0) >= 30
        },
    );
    let sent_s = t0.elapsed().as_secs_f64();
    let skipped = done["counters"]["skipped_full"].as_u64().unwrap();
    assert!(
        skipped >= 30,
        "deliveries skipped while frozen: {skipped}\n{done}"
    );
    assert!(running(proc));
    let _ = before;
    signal(proc, Signal::SIGCONT);
    node.close().unwrap();
    expect_exit(&mut l, &reference);
    eprintln!(
        "echo sent 40 frames in {sent_s:.1} s to a frozen reader, {skipped} deliveries skipped"
    );
    let p = l.pipeline_json();
    let echo = &p["services"]["echo"]["counters"];
    assert!(echo["skipped_full"].as_u64().unwrap() >= skipped, "{echo}");
    assert!(
        counter(&l.log("echo"), "echo stopping", "skipped_full").unwrap() >= skipped,
        "{}",
        l.log("echo")
    );
}

/// Waits until `node` sees the liveliness token of `role` (its session is connected and routes
/// to it).
fn wait_sees(node: &ZenohNode, role: &str, l: &Launch) {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let alive = node
            .alive_now(
                &format!("cellsar/alive/{role}/*"),
                Duration::from_millis(500),
            )
            .unwrap_or_default();
        if !alive.is_empty() {
            return;
        }
        if Instant::now() >= deadline {
            let all = node
                .alive_now("cellsar/alive/**", Duration::from_millis(500))
                .unwrap_or_default();
            let info = node.session().info();
            let routers: Vec<String> = info.routers_zid().wait().map(|z| z.to_string()).collect();
            let peers: Vec<String> = info.peers_zid().wait().map(|z| z.to_string()).collect();
            panic!(
                "the test session never saw {role}; tokens it sees: {all:?}; routers {routers:?}, peers {peers:?}\nrouter log:\n{}\necho log:\n{}",
                l.log("router"),
                l.log("echo")
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Zenoh args of a test session joining the launcher's network.
fn join(l: &mut Launch) -> ZenohArgs {
    let net = l.event("network", Duration::from_secs(10));
    let a: Vec<String> = net["children"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    let connect: Vec<String> = a
        .windows(2)
        .filter(|w| w[0] == "--connect")
        .map(|w| w[1].clone())
        .collect();
    ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &connect)
}

const FLOOD: usize = 10_000;

/// Payload `i` of a flood: random bytes, a truncated or forged envelope, JSON garbage, or (a
/// few) an oversized payload.
fn bad_payload(i: usize, kind: u16) -> (Vec<u8>, Encoding) {
    let mut x = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xDEAD_BEEF;
    let mut rnd = |n: usize| -> Vec<u8> {
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect()
    };
    match i % 5 {
        0 if i.is_multiple_of(2500) => (vec![7u8; (16 << 20) + 4096], Encoding::APPLICATION_OCTET_STREAM),
        0 => (rnd(i % 300), Encoding::APPLICATION_OCTET_STREAM),
        1 => {
            // a header that claims the right kind, with a body that is garbage
            let mut h = b"CSAR".to_vec();
            h.push(1);
            h.push(0);
            h.extend_from_slice(&kind.to_le_bytes());
            h.extend_from_slice(&1u16.to_le_bytes());
            h.extend(rnd(40 + i % 50));
            (h, Encoding::APPLICATION_OCTET_STREAM)
        }
        2 => {
            let mut h = b"CSAR".to_vec();
            h.push(1);
            h.extend(rnd(i % 47));
            (h, Encoding::APPLICATION_OCTET_STREAM)
        }
        3 => (
            format!("{{\"kind\": {kind}, \"body\": [{i}").into_bytes(),
            Encoding::APPLICATION_JSON,
        ),
        _ => (
            format!("{{\"kind\": {}, \"schema_version\": 1, \"mission_id\": \"zz\", \"seq\": 1, \"time_unix_ns\": 0, \"body\": {{}}}}", kind ^ 1)
                .into_bytes(),
            Encoding::APPLICATION_JSON,
        ),
    }
}

/// A raw Zenoh publisher on `key` that waits rather than drops when the network is full.
fn blocking_publisher<'a>(node: &'a ZenohNode, key: &str) -> bridge::zenoh::pubsub::Publisher<'a> {
    node.session()
        .declare_publisher(key.to_string())
        .congestion_control(CongestionControl::Block)
        .wait()
        .unwrap()
}

fn flood_put(node: &ZenohNode, key: &str, kind: u16) {
    let p = blocking_publisher(node, key);
    for i in 0..FLOOD {
        let (b, enc) = bad_payload(i, kind);
        p.put(b).encoding(enc).wait().unwrap();
    }
}

/// Size of the messages of [`flood_huge`]: far above Zenoh's reassembly limit
/// (`--zenoh-max-message-bytes`, by default [`DEFAULT_MAX_MESSAGE_BYTES`], 64 MiB + 64 KiB).
const HUGE_BYTES: usize = 512 << 20;

/// Two messages of [`HUGE_BYTES`] on `key`: Zenoh drops each once its fragments pass the
/// reassembly limit, so a receiver holds at most that limit of it. Under Zenoh's own limit
/// (1 GiB) each would be reassembled whole (512 MiB) and, before cellsar's length check,
/// copied once more.
fn flood_huge(node: &ZenohNode, key: &str) {
    let p = blocking_publisher(node, key);
    let huge = ZBytes::from(vec![7u8; HUGE_BYTES]);
    for _ in 0..2 {
        p.put(huge.clone())
            .encoding(Encoding::APPLICATION_OCTET_STREAM)
            .wait()
            .unwrap();
    }
}

/// How much more a flooded process may hold at its peak than before the flood: two messages
/// being reassembled up to Zenoh's limit (its own, and one it passes on: the launcher is the
/// hub of its children's mesh), plus three of the flood's oversized payloads (16 MiB + 4 KiB
/// each: whole in Zenoh's buffers, refused by their length before cellsar copies them, and
/// kept by the allocator a while after). Measured: +31 MiB (planner), +112 MiB (processor),
/// +121 MiB (launcher); without the huge messages +32, +48 and +22 MiB. Well under what one
/// of [`flood_huge`]'s messages alone would cost without the limit.
const FLOOD_PEAK_BOUND: u64 = 2 * DEFAULT_MAX_MESSAGE_BYTES as u64 + 3 * ((16 << 20) + 4096);
const _: () = assert!(FLOOD_PEAK_BOUND < HUGE_BYTES as u64 / 2);

fn flood_get(node: &ZenohNode, key: &str, kind: u16) {
    let mut pending = Vec::new();
    for i in 0..FLOOD {
        let (b, enc) = bad_payload(i, kind);
        let r = node
            .session()
            .get(key.to_string())
            .payload(b)
            .encoding(enc)
            .target(QueryTarget::All)
            .congestion_control(CongestionControl::Block)
            .timeout(Duration::from_secs(20))
            .wait()
            .unwrap();
        pending.push(r);
        if pending.len() >= 200 {
            for r in pending.drain(..) {
                while r.recv().is_ok() {}
            }
        }
    }
    for r in pending.drain(..) {
        while r.recv().is_ok() {}
    }
}

#[test]
fn ten_thousand_malformed_payloads_on_every_key() {
    let reference = reference(30.0);
    let dir = tempfile::tempdir().unwrap();
    // no echo yet: the mission waits while the other services are flooded
    let mut l = Launch::start(
        dir.path(),
        30.0,
        &["--transport", "zenoh", "--external", "echo", "--strict"],
    );
    let z = join(&mut l);
    let planned = l.event("planned", Duration::from_secs(120));
    let m = MissionId::parse_hex(planned["mission_id"].as_str().unwrap()).unwrap();
    let node = ZenohNode::open(z.to_config().unwrap(), "tester", "flood").unwrap();
    for role in ["planner", "processor", "launcher"] {
        wait_sees(&node, role, &l);
    }
    // resident memory before the flood: the peak after it must stay within FLOOD_PEAK_BOUND
    let before: Vec<(&str, Baseline)> = vec![
        ("planner", Baseline::take(l.pid("planner"))),
        ("processor", Baseline::take(l.pid("processor"))),
        ("launcher", Baseline::take(l.child.id())),
    ];
    flood_get(&node, pkeys::PLAN, 0x0101);
    flood_put(&node, &pkeys::plan(m).unwrap(), 0x0102);
    flood_get(&node, &pkeys::plan(m).unwrap(), 0x0103);
    flood_get(&node, &pkeys::results(m).unwrap(), 0x0307);
    flood_put(&node, &pkeys::echo(m).unwrap(), 0x0200);
    flood_put(&node, &pkeys::detections(m).unwrap(), 0x0304);
    flood_put(&node, &pkeys::image(m, 0).unwrap(), 0x0305);
    flood_put(&node, &pkeys::metrics(m).unwrap(), 0x0306);
    flood_put(
        &node,
        &pkeys::status(m, pipeline::protocol::Role::Processor).unwrap(),
        0x0110,
    );
    // messages above Zenoh's reassembly limit, to the processor and to the launcher
    flood_huge(&node, &pkeys::echo(m).unwrap());
    flood_huge(&node, &pkeys::detections(m).unwrap());
    for (role, b) in &before {
        b.assert_peak_within(
            FLOOD_PEAK_BOUND,
            &format!("the {role} flooded with malformed, oversized and huge messages"),
        );
    }
    // now the echo, flooded as soon as it is up (while the mission runs)
    let net = l.event("network", Duration::from_secs(1));
    let ea = echo_args(&net);
    let mut echo = Service::start("echo", dir.path(), &ea);
    // its first status: its loop runs, every endpoint is declared
    l.wait_for("the echo's status", Duration::from_secs(30), |e| {
        e["event"] == "status" && e["role"] == "echo"
    });
    wait_sees(&node, "echo", &l);
    flood_get(&node, &pkeys::echo_request(m).unwrap(), 0x0301);
    flood_put(&node, &pkeys::plan(m).unwrap(), 0x0102);
    flood_get(&node, &pkeys::plan(m).unwrap(), 0x0103);
    expect_exit(&mut l, &reference);
    assert!(echo.stop(Duration::from_secs(20)).success());
    node.close().unwrap();

    let at_least = |log: &str, marker: &str, key: &str, n: u64| {
        let v = counter(log, marker, key).unwrap_or_else(|| panic!("no {key} in\n{log}"));
        assert!(v >= n, "{key} = {v} < {n}");
    };
    let n = FLOOD as u64;
    at_least(
        &l.log("planner"),
        "plan service stopping",
        "malformed",
        2 * n,
    );
    let p = l.log("processor");
    // (the second round on `plan` may outlast the mission, and the processor with it)
    at_least(&p, "processor stopping", "plans_malformed", n);
    at_least(&p, "processor stopping", "result_requests_malformed", n);
    at_least(&p, "processor stopping", "lookups_malformed", n);
    // the malformed frames on the echo key arrived: malformed, not lost in transport (which
    // counts only the mission's own frames, far fewer than the flood)
    at_least(&p, "processor stopping", "frames_malformed", n);
    let lost = counter(&p, "processor stopping", "transport_lost").unwrap();
    assert!(
        lost < n,
        "transport_lost = {lost}: the flood counted as lost"
    );
    let e = echo.log_text();
    at_least(&e, "echo stopping", "requests_malformed", n);
    at_least(&e, "echo stopping", "plans_malformed", n);
    at_least(&e, "echo stopping", "lookups_malformed", n);
    let pj = l.pipeline_json();
    for s in ["detections", "images", "metrics", "status"] {
        let c = &pj["collector"][s];
        assert!(c["malformed"].as_u64().unwrap() >= n, "{s}: {c}");
    }
    // and they were logged (rate-limited WARN lines naming the key)
    assert!(
        p.contains(&pkeys::results(m).unwrap()) && p.contains("WARN"),
        "nothing logged"
    );
}

/// Shared memory: a run removes what it made and what runs whose launcher died left behind,
/// never what belongs to a live user of the same iceoryx2 prefix.
#[test]
fn shared_memory_of_dead_runs_goes_and_of_live_users_stays() {
    let reference = reference(H);
    // a run whose launcher was killed with -9 left a segment (its pid is dead now)
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    let dead = gone.id();
    gone.wait().unwrap();
    let leftover = format!("/dev/shm/cs{dead}_leftover_of_a_killed_run");
    std::fs::write(&leftover, b"x").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["--strict"]);
    expect_exit(&mut l, &reference);
    assert!(
        !std::path::Path::new(&leftover).exists(),
        "the dead run's segment is still there"
    );
    assert!(shm_files(&format!("cs{}x", l.child.id())).is_empty());

    // a user-given prefix may be shared: another live user's segment survives the run
    let prefix = format!("csshared{}_", std::process::id());
    let other = format!("/dev/shm/{prefix}another_live_user");
    std::fs::write(&other, b"x").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("iox");
    let mut l = Launch::start(
        dir.path(),
        H,
        &[
            "--strict",
            "--iox-prefix",
            &prefix,
            "--iox-root",
            root.to_str().unwrap(),
        ],
    );
    expect_exit(&mut l, &reference);
    assert!(
        std::path::Path::new(&other).exists(),
        "another user's segment was removed"
    );
    std::fs::remove_file(&other).unwrap();
    // iceoryx2's per-prefix management segment stays for other users of the prefix; this
    // test's prefix is its own, so it goes
    for f in shm_files(&prefix) {
        let _ = std::fs::remove_file(format!("/dev/shm/{f}"));
    }
}
