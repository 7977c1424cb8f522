//! Transport tests: typed Zenoh endpoints and iceoryx2 frame services in process, and the
//! real `cellsar-bridge` / tool processes on loopback (ephemeral ports, no multicast,
//! isolated iceoryx2 roots, bounded in time), so that they can run in parallel.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use bridge::envelope::{self, Meta};
use bridge::frame::{self, FrameMeta};
use bridge::iox::{FrameNode, FramePublisherOptions, FrameServiceSpec, IoxEnv};
use bridge::keys;
use bridge::net::{
    FrameSubscribeOptions, NetError, OnFull, PublishOptions, QueryOptions, SubscribeOptions,
    WireFormat,
};
use bridge::zenoh::qos::CongestionControl;
use bridge::zenoh::sample::Locality;
use bridge::zenoh::Wait;
use bridge::{Complex32, Message, MissionId, Refusal, RefusalKind, ZenohNode};
use harness::transport::*;
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
struct PlanRequest {
    mission: String,
    slots: u32,
}
impl Message for PlanRequest {
    const KIND: u16 = 0x7001;
    const NAME: &'static str = "test.plan_request";
    const SCHEMA_VERSION: u16 = 1;
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
struct PlanSummary {
    mission: String,
    energy_j: f64,
    pos_m: Vec<[f64; 2]>,
}
impl Message for PlanSummary {
    const KIND: u16 = 0x7002;
    const NAME: &'static str = "test.plan_summary";
    const SCHEMA_VERSION: u16 = 3;
}

const T: Duration = Duration::from_secs(10);

/// Two peers joined over a Unix socket in `dir`.
fn pair(dir: &std::path::Path, tag: &str) -> (ZenohNode, ZenohNode) {
    let ep = unix_endpoint(dir, &format!("{tag}.sock"));
    let a = ZenohNode::open(
        z_listen(&ep).to_config().unwrap(),
        "test",
        &format!("{tag}-a"),
    )
    .unwrap();
    let b = ZenohNode::open(
        bridge::ZenohArgs::isolated(&[], &[ep]).to_config().unwrap(),
        "test",
        &format!("{tag}-b"),
    )
    .unwrap();
    (a, b)
}

fn summary(i: usize) -> PlanSummary {
    PlanSummary {
        mission: "default".into(),
        energy_j: 1234.5 + i as f64,
        pos_m: vec![[0.1, -2.0], [i as f64, 1e-9]],
    }
}

#[test]
fn typed_pub_sub_binary_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "ps");
    for format in [WireFormat::Bincode, WireFormat::Json] {
        let suffix = format!("plan/{format:?}");
        let key = keys::mission(MissionId(0xabc), &suffix).unwrap();
        let sub = b
            .subscriber::<PlanSummary>(&key, SubscribeOptions::default())
            .unwrap();
        let p = a
            .publisher::<PlanSummary>(
                &key,
                PublishOptions {
                    format,
                    mission_id: MissionId(0xabc),
                    first_seq: 10,
                    ..Default::default()
                },
            )
            .unwrap();
        assert!(p.wait_for_subscribers(T), "no subscriber matched {key}");
        for i in 0..5 {
            assert_eq!(p.put(&summary(i)).unwrap(), 10 + i as u64);
        }
        for i in 0..5 {
            let m = sub.recv_timeout(T).expect("message");
            assert_eq!(m.message, summary(i));
            assert_eq!(m.format, format);
            assert_eq!(m.key, key);
            assert_eq!(m.header.mission_id, MissionId(0xabc));
            assert_eq!(m.header.kind, PlanSummary::KIND);
            assert_eq!(m.header.schema_version, 3);
            assert_eq!(m.header.seq, 10 + i as u64);
        }
        assert!(sub.recv_timeout(Duration::from_millis(100)).is_none());
        let c = sub.counters().snapshot();
        assert_eq!(
            (c.received, c.delivered, c.malformed, c.dropped),
            (5, 5, 0, 0)
        );
        assert_eq!(p.counters().snapshot().sent, 5);
    }
}

#[test]
fn query_reply_errors_and_wrong_kinds() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "q");
    let key = "cellsar/test/plan";
    let q = a
        .queryable::<PlanRequest>(key, SubscribeOptions::default())
        .unwrap();
    let server = std::thread::spawn(move || {
        let mut answered = 0;
        let deadline = Instant::now() + T;
        // 3 good requests answered here + 1 bad one rejected in the Zenoh callback
        while (answered < 3 || q.counters().snapshot().malformed < 1) && Instant::now() < deadline {
            if let Some(inq) = q.recv_timeout(Duration::from_millis(100)) {
                answered += 1;
                if inq.request.slots == 0 {
                    inq.reply_err("slots must be positive").unwrap();
                } else {
                    let rep = PlanSummary {
                        mission: inq.request.mission.clone(),
                        energy_j: f64::from(inq.request.slots),
                        pos_m: vec![],
                    };
                    inq.reply(
                        &rep,
                        Meta {
                            seq: inq.header.seq,
                            ..Meta::default()
                        },
                    )
                    .unwrap();
                }
            }
        }
        (answered, q.counters().snapshot())
    });
    let opts = QueryOptions {
        timeout: Duration::from_secs(5),
        ..Default::default()
    };
    let req = PlanRequest {
        mission: "m".into(),
        slots: 30,
    };
    let deadline = Instant::now() + T;
    let rep = loop {
        match b.query_one::<PlanRequest, PlanSummary>(key, &req, &opts) {
            Ok(r) => break r,
            Err(NetError::NoReply { .. }) if Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => panic!("{e}"),
        }
    };
    assert_eq!(rep.message.energy_j, 30.0);
    assert_eq!(rep.format, WireFormat::Bincode);

    let json = QueryOptions {
        format: WireFormat::Json,
        ..opts
    };
    let err = b
        .query_one::<PlanRequest, PlanSummary>(
            key,
            &PlanRequest {
                mission: "m".into(),
                slots: 0,
            },
            &json,
        )
        .unwrap_err();
    assert!(err.to_string().contains("slots must be positive"), "{err}");

    // a reply of the wrong kind is reported with both kinds named
    let err = b
        .query_one::<PlanRequest, PlanRequest>(key, &req, &json)
        .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("test.plan_request") && msg.contains(&PlanSummary::KIND.to_string()),
        "{msg}"
    );

    // a request of the wrong kind is refused by the queryable itself (a typed bad_request,
    // in the request's format, naming the kinds) and counted
    for o in [&opts, &json] {
        match b
            .query_one::<PlanSummary, PlanSummary>(key, &summary(0), o)
            .unwrap_err()
        {
            NetError::Refused { key: k, refusal } => {
                assert_eq!(k, key);
                assert_eq!(refusal.kind, RefusalKind::BadRequest);
                assert!(
                    refusal.message.starts_with("bad request: ")
                        && refusal.message.contains("test.plan_request"),
                    "{refusal:?}"
                );
            }
            e => panic!("{:?}: {e:?}", o.format),
        }
    }
    let (answered, c) = server.join().unwrap();
    assert_eq!(answered, 3);
    assert_eq!(c.malformed, 2);
}

/// A queryable whose request queue is full refuses the next request itself with a typed
/// `busy` refusal (schema version 2), counted as dropped; an empty request is a typed
/// `bad_request`.
#[test]
fn full_request_queue_is_a_busy_refusal() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "busy");
    let key = "cellsar/test/busy";
    let q = a
        .queryable::<PlanRequest>(
            key,
            SubscribeOptions {
                capacity: 1,
                ..SubscribeOptions::default()
            },
        )
        .unwrap();
    let req = PlanRequest {
        mission: "m".into(),
        slots: 1,
    };
    let opts = QueryOptions {
        timeout: Duration::from_secs(5),
        ..Default::default()
    };
    // the first request fills the queue (nobody takes it) and waits; the next one is refused
    // (asked again until the peers see each other: a query without a route ends unanswered)
    let mut first: Option<bridge::PendingQuery<PlanSummary>> = None;
    wait_until("the queue filled", T, || {
        let ended = first
            .as_mut()
            .is_none_or(|f| f.poll(Duration::from_millis(50)).is_some());
        if q.counters().snapshot().delivered == 1 {
            return true;
        }
        if ended {
            first = Some(
                b.start_query::<PlanRequest, PlanSummary>(key, &req, &opts)
                    .unwrap(),
            );
        }
        false
    });
    for format in [WireFormat::Bincode, WireFormat::Json] {
        let e = b
            .query_one::<PlanRequest, PlanSummary>(key, &req, &QueryOptions { format, ..opts })
            .unwrap_err();
        match &e {
            NetError::Refused { key: k, refusal } => {
                assert_eq!(k, key);
                assert_eq!(refusal.kind, RefusalKind::Busy, "{format:?}");
                assert!(refusal.message.contains("queue full"), "{refusal:?}");
            }
            e => panic!("{format:?}: {e:?}"),
        }
        assert!(e.to_string().contains("busy"), "{e}");
    }
    assert_eq!(q.counters().snapshot().dropped, 2);
    // the queued one is still answered
    let inq = q.recv_timeout(T).expect("the queued request");
    inq.reply(
        &PlanSummary {
            mission: "m".into(),
            energy_j: 1.0,
            pos_m: vec![],
        },
        Meta::default(),
    )
    .unwrap();
    drop(inq);
    let mut first = first.unwrap();
    let got = loop {
        if let Some(r) = first.poll(Duration::from_millis(100)) {
            break r.unwrap();
        }
    };
    assert_eq!(got.message.energy_j, 1.0);
    // a request without a payload: a typed bad_request naming the expected message
    let replies = b.session().get(key).timeout(T).wait().unwrap();
    let reply = replies.recv().expect("a reply");
    let err = reply.result().expect_err("an error reply");
    match bridge::net::decode_error_reply(
        key,
        &err.payload().to_bytes(),
        WireFormat::of(err.encoding()),
        &Default::default(),
    ) {
        NetError::Refused { refusal, .. } => {
            assert_eq!(refusal.kind, RefusalKind::BadRequest);
            assert!(
                refusal.message.contains("empty request")
                    && refusal.message.contains("test.plan_request"),
                "{refusal:?}"
            );
        }
        e => panic!("{e:?}"),
    }
}

/// A session that cannot open (a client whose router is not there, waiting for it as
/// `pipeline/deploy/client.json5` does) is given up within a moment once the stop flag is
/// set, and a description of what it waited for is at hand; without the flag it still
/// waits.
#[test]
fn opening_a_session_stops_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("client.json5");
    let port = free_port();
    std::fs::write(
        &cfg,
        bridge::zconfig::waiting_client_json5(&format!("tcp/127.0.0.1:{port}")),
    )
    .unwrap();
    let config = bridge::ZenohArgs {
        config: Some(cfg),
        ..Default::default()
    }
    .to_config()
    .unwrap();
    assert_eq!(
        bridge::zconfig::describe(&config),
        format!("mode client, connect [tcp/127.0.0.1:{port}], listen []")
    );
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let setter = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(1500));
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
            Instant::now()
        })
    };
    let opened = ZenohNode::open_until(config, "test", "waits", &stop).unwrap();
    let stopped_at = setter.join().unwrap();
    assert!(opened.is_none(), "no router, yet a session opened");
    assert!(
        stopped_at.elapsed() < Duration::from_millis(500),
        "open_until returned {:?} after the stop",
        stopped_at.elapsed()
    );
    // a stop that is already set returns at once
    let t = Instant::now();
    let config = z_connect(&format!("tcp/127.0.0.1:{port}"))
        .to_config()
        .unwrap();
    assert!(ZenohNode::open_until(config, "test", "w2", &stop)
        .unwrap()
        .is_none());
    assert!(
        t.elapsed() < Duration::from_millis(500),
        "{:?}",
        t.elapsed()
    );
    // a session that opens is returned as usual, and a bad name is refused before anything
    let go = std::sync::atomic::AtomicBool::new(false);
    let node = ZenohNode::open_until(
        z_listen("tcp/127.0.0.1:0").to_config().unwrap(),
        "test",
        "opens",
        &go,
    )
    .unwrap()
    .expect("a session");
    node.close().unwrap();
    assert!(ZenohNode::open_until(
        z_listen("tcp/127.0.0.1:0").to_config().unwrap(),
        "test",
        "a/b",
        &go
    )
    .is_err());
}

/// A failed open names what was being opened (mode and endpoints), not an empty key.
#[test]
fn a_failed_open_names_the_session() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let ep = format!("tcp/127.0.0.1:{}", taken.local_addr().unwrap().port());
    let e = ZenohNode::open(z_listen(&ep).to_config().unwrap(), "test", "taken").unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with(&format!(
            "opening the Zenoh session (mode peer, connect [], listen [{ep}]) failed: "
        )),
        "{msg}"
    );
    assert!(!msg.contains("\"\""), "{msg}");
}

/// A queryable's typed refusal reaches the querier as `NetError::Refused` with its kind and
/// message, in both formats (and as `poll` returns it); a plain-text error reply (an older
/// or foreign queryable) stays `NetError::Remote`, naming the key.
#[test]
fn typed_refusals_are_decoded_and_plain_errors_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "rf");
    let key = "cellsar/test/refuse";
    let q = a
        .queryable::<PlanRequest>(key, SubscribeOptions::default())
        .unwrap();
    let server = std::thread::spawn(move || {
        let deadline = Instant::now() + T;
        let mut answered = 0;
        while answered < 4 && Instant::now() < deadline {
            if let Some(inq) = q.recv_timeout(Duration::from_millis(100)) {
                let r = match inq.request.slots {
                    1 => inq.refuse(&Refusal::new(
                        RefusalKind::Infeasible,
                        "mission cannot be flown: slot 23",
                    )),
                    2 => inq.refuse(&Refusal::new(
                        RefusalKind::BadRequest,
                        "options.tolerance: -1 must be > 0",
                    )),
                    _ => inq.reply_err("planning failed"),
                };
                r.unwrap();
                answered += 1;
            }
        }
        answered
    });
    let ask = |slots: u32, format: WireFormat| {
        let req = PlanRequest {
            mission: "m".into(),
            slots,
        };
        let opts = QueryOptions {
            timeout: Duration::from_secs(5),
            format,
            ..Default::default()
        };
        let deadline = Instant::now() + T;
        loop {
            match b.query_one::<PlanRequest, PlanSummary>(key, &req, &opts) {
                Err(NetError::NoReply { .. }) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(50))
                }
                r => break r.unwrap_err(),
            }
        }
    };
    match ask(1, WireFormat::Bincode) {
        NetError::Refused { key: k, refusal } => {
            assert_eq!(k, key);
            assert_eq!(refusal.kind, RefusalKind::Infeasible);
            assert_eq!(refusal.message, "mission cannot be flown: slot 23");
        }
        e => panic!("{e:?}"),
    }
    let e = ask(2, WireFormat::Json);
    assert!(
        matches!(&e, NetError::Refused { refusal, .. } if refusal.kind == RefusalKind::BadRequest),
        "{e:?}"
    );
    assert!(
        e.to_string().contains("bad_request") && e.to_string().contains("options.tolerance"),
        "{e}"
    );
    for format in [WireFormat::Bincode, WireFormat::Json] {
        match ask(3, format) {
            NetError::Remote { key: k, message } => {
                assert_eq!(k, key);
                assert_eq!(message, "planning failed");
            }
            e => panic!("{format:?}: {e:?}"),
        }
    }
    assert_eq!(server.join().unwrap(), 4);
}

/// `query_one` returns as soon as the first good reply arrives: a second queryable that
/// holds the query without answering does not make it wait for the query's timeout.
#[test]
fn query_one_returns_at_the_first_good_reply() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "q1");
    let key = "cellsar/test/first";
    let q = a
        .queryable::<PlanRequest>(key, SubscribeOptions::default())
        .unwrap();
    // a queryable that keeps every query open (never answers) until the test ends
    let held = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let h = held.clone();
    let _silent = a
        .session()
        .declare_queryable(key)
        .callback(move |query: bridge::zenoh::query::Query| h.lock().unwrap().push(query))
        .wait()
        .unwrap();
    let server = std::thread::spawn(move || {
        let deadline = Instant::now() + T + T;
        while Instant::now() < deadline {
            if let Some(inq) = q.recv_timeout(Duration::from_millis(100)) {
                let rep = PlanSummary {
                    mission: inq.request.mission.clone(),
                    energy_j: f64::from(inq.request.slots),
                    pos_m: vec![],
                };
                inq.reply(&rep, Meta::default()).unwrap();
                if inq.request.slots == 2 {
                    return;
                }
            }
        }
    });
    let mut opts = QueryOptions {
        timeout: Duration::from_secs(1),
        target: bridge::zenoh::query::QueryTarget::All,
        ..Default::default()
    };
    // until both queryables are known to the querier
    let deadline = Instant::now() + T;
    let req = |slots| PlanRequest {
        mission: "m".into(),
        slots,
    };
    loop {
        let answered = b
            .query_one::<PlanRequest, PlanSummary>(key, &req(1), &opts)
            .is_ok();
        if answered && !held.lock().unwrap().is_empty() {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the queryables were never reached"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    opts.timeout = Duration::from_secs(20);
    let t = Instant::now();
    let rep = b
        .query_one::<PlanRequest, PlanSummary>(key, &req(2), &opts)
        .unwrap();
    assert_eq!(rep.message.energy_j, 2.0);
    assert!(
        t.elapsed() < Duration::from_secs(10),
        "query_one waited {:?} for the silent queryable",
        t.elapsed()
    );
    // the silent queryable's callback may run just after the good reply came back
    wait_until("the silent queryable's second query", T, || {
        held.lock().unwrap().len() >= 2
    });
    let held_now = held.lock().unwrap().len();
    assert!(held_now >= 2, "the silent queryable saw {held_now} queries");
    server.join().unwrap();
    held.lock().unwrap().clear();
}

/// A query started with `start_query` is polled a little at a time (the caller can stop
/// waiting at any moment, e.g. on SIGINT), answers when the queryable replies, and says
/// `NoReply` once its timeout passed without an answer.
#[test]
fn pending_query_is_polled_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "pq");
    let key = "cellsar/test/pending";
    let q = a
        .queryable::<PlanRequest>(key, SubscribeOptions::default())
        .unwrap();
    let opts = QueryOptions {
        timeout: Duration::from_secs(30),
        ..Default::default()
    };
    let deadline = Instant::now() + T;
    // until the queryable is known: a query that reached it stays open (no answer yet)
    let mut attempt = 0u32;
    let (mut pending, inq) = 'found: loop {
        attempt += 1;
        assert!(Instant::now() < deadline, "the queryable was never reached");
        let req = PlanRequest {
            mission: "m".into(),
            slots: attempt,
        };
        let p = b
            .start_query::<PlanRequest, PlanSummary>(key, &req, &opts)
            .unwrap();
        while let Some(inq) = q.recv_timeout(Duration::from_millis(200)) {
            if inq.request.slots == attempt {
                break 'found (p, inq);
            }
        }
    };
    for _ in 0..5 {
        let t = Instant::now();
        assert!(pending.poll(Duration::from_millis(50)).is_none());
        assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    }
    inq.reply(
        &PlanSummary {
            mission: "m".into(),
            energy_j: 7.0,
            pos_m: vec![],
        },
        Meta::default(),
    )
    .unwrap();
    drop(inq);
    let got = loop {
        if let Some(r) = pending.poll(Duration::from_millis(50)) {
            break r;
        }
        assert!(Instant::now() < deadline, "no answer");
    };
    assert_eq!(got.unwrap().message.energy_j, 7.0);
    // nobody answers this key: NoReply once the timeout passed
    let mut none = b
        .start_query::<PlanRequest, PlanSummary>(
            "cellsar/test/nobody",
            &PlanRequest {
                mission: "m".into(),
                slots: 1,
            },
            &QueryOptions {
                timeout: Duration::from_millis(300),
                ..Default::default()
            },
        )
        .unwrap();
    let r = loop {
        if let Some(r) = none.poll(Duration::from_millis(50)) {
            break r;
        }
        assert!(Instant::now() < deadline, "the query never ended");
    };
    assert!(matches!(r, Err(NetError::NoReply { .. })), "{r:?}");
}

#[test]
fn liveliness_tokens_come_and_go() {
    let dir = tempfile::tempdir().unwrap();
    let ep = unix_endpoint(dir.path(), "live.sock");
    let watcher_node =
        ZenohNode::open(z_listen(&ep).to_config().unwrap(), "watcher", "w1").unwrap();
    let w = watcher_node.watch_liveliness(keys::ALIVE_ALL).unwrap();
    assert!(w.wait_for("cellsar/alive/watcher/w1", true, T));
    let other = ZenohNode::open(
        bridge::ZenohArgs::isolated(&[], &[ep]).to_config().unwrap(),
        "planner",
        "p7",
    )
    .unwrap();
    assert!(w.wait_for("cellsar/alive/planner/p7", true, T));
    let alive = watcher_node
        .alive_now("cellsar/alive/planner/*", Duration::from_secs(2))
        .unwrap();
    assert_eq!(alive, vec!["cellsar/alive/planner/p7".to_string()]);
    other.close().unwrap();
    assert!(
        w.wait_for("cellsar/alive/planner/p7", false, T),
        "loss not reported"
    );
    assert!(w.alive().contains("cellsar/alive/watcher/w1"));
    assert!(ZenohNode::open(
        bridge::ZenohArgs::default().to_config().unwrap(),
        "bad/role",
        "x"
    )
    .is_err());
}

/// 10,000 malformed payloads at a typed subscriber, interleaved with good ones: none crashes
/// it, each bad one is counted once, every good one is delivered.
#[test]
fn typed_subscriber_counts_10k_malformed() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "flood");
    let key = "cellsar/test/flood";
    let sub = b
        .subscriber::<PlanSummary>(
            key,
            SubscribeOptions {
                capacity: 20_000,
                ..Default::default()
            },
        )
        .unwrap();
    // lossless, so that every one of the 10,000 arrives (Zenoh's default is to drop)
    let raw = a
        .session()
        .declare_publisher(key)
        .congestion_control(CongestionControl::Block)
        .wait()
        .unwrap();
    let good = a
        .publisher::<PlanSummary>(key, PublishOptions::default())
        .unwrap();
    // wait for the route
    wait_until("subscriber match", T, || {
        raw.matching_status()
            .wait()
            .map(|m| m.matching())
            .unwrap_or(false)
    });
    let valid = envelope::encode(&summary(1), Meta::default()).unwrap();
    let wrong_kind = envelope::encode(
        &PlanRequest {
            mission: "x".into(),
            slots: 1,
        },
        Meta::default(),
    )
    .unwrap();
    let mut rng: u64 = 42;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let mut good_sent = 0;
    for i in 0..10_000u32 {
        let p: Vec<u8> = match i % 4 {
            0 => (0..next() % 100).map(|_| next() as u8).collect(),
            1 => {
                let mut v = valid.clone();
                let pos = 40 + (next() as usize) % (v.len() - 40); // body_len or body: always caught
                v[pos] ^= 1 << (next() % 8);
                v
            }
            2 => wrong_kind.clone(),
            _ => {
                let mut v = valid.clone();
                v[40..48].copy_from_slice(&(1u64 << 40).to_le_bytes()); // claims 1 TiB
                v
            }
        };
        raw.put(p).wait().unwrap();
        if i % 1000 == 0 {
            good.put(&summary(i as usize)).unwrap();
            good_sent += 1;
        }
    }
    wait_until("all payloads counted", T, || {
        sub.counters().snapshot().received == 10_000 + good_sent
    });
    let c = sub.counters().snapshot();
    assert_eq!(c.malformed, 10_000);
    assert_eq!(c.delivered, good_sent);
    let mut n = 0;
    while let Some(m) = sub.try_recv() {
        assert_eq!(m.message.mission, "default");
        n += 1;
    }
    assert_eq!(n, good_sent);
}

#[test]
fn full_queue_drops_and_counts() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "full");
    let key = "cellsar/test/full";
    let sub = b
        .subscriber::<PlanSummary>(
            key,
            SubscribeOptions {
                capacity: 3,
                on_full: OnFull::Drop,
                ..Default::default()
            },
        )
        .unwrap();
    let p = a
        .publisher::<PlanSummary>(key, PublishOptions::default())
        .unwrap();
    let c = fifty_more(&p, &sub);
    assert_eq!(c.delivered, 3, "queue of 3, never drained");
    assert_eq!(c.dropped, c.received - 3);
}

/// Once `sub` receives from `p`, 50 more messages, counted; the counters after a pause for
/// any late delivery.
fn fifty_more(
    p: &bridge::net::TypedPublisher<PlanSummary>,
    sub: &bridge::net::TypedSubscriber<PlanSummary>,
) -> bridge::CounterSnapshot {
    wait_until("first message", T, || {
        p.put(&summary(0)).unwrap();
        sub.counters().snapshot().received > 0
    });
    let before = sub.counters().snapshot().received;
    for i in 0..50 {
        p.put(&summary(i)).unwrap();
    }
    // 30 s, not T: on a machine loaded by other runs, counting the 50 once took over 10 s
    wait_until("all counted", Duration::from_secs(30), || {
        sub.counters().snapshot().received >= before + 50
    });
    std::thread::sleep(Duration::from_millis(100));
    sub.counters().snapshot()
}

/// A queue is bounded by wire bytes as well as by count: with room for 1000 messages but a
/// byte budget of about three, three are queued and the rest dropped and counted; taking
/// them gives the budget back.
#[test]
fn queue_byte_budget_drops_and_counts() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "bytes");
    let key = "cellsar/test/bytes";
    let p = a
        .publisher::<PlanSummary>(key, PublishOptions::default())
        .unwrap();
    // the wire size of one message, measured on a probe subscriber
    let probe = b
        .subscriber::<PlanSummary>(key, SubscribeOptions::default())
        .unwrap();
    wait_until("probe message", T, || {
        p.put(&summary(0)).unwrap();
        probe.counters().snapshot().received > 0
    });
    let one = probe.counters().snapshot().bytes_in as usize
        / probe.counters().snapshot().received as usize;
    drop(probe);
    let sub = b
        .subscriber::<PlanSummary>(
            key,
            SubscribeOptions {
                capacity: 1000,
                max_queued_bytes: 3 * one + one / 2,
                ..Default::default()
            },
        )
        .unwrap();
    let c = fifty_more(&p, &sub);
    assert_eq!(c.delivered, 3, "budget of three messages, never drained");
    assert_eq!(c.dropped, c.received - 3);
    assert_eq!(sub.queued_bytes(), 3 * one);
    // taking the messages gives the budget back, and new ones fit again
    for _ in 0..3 {
        assert!(sub.try_recv().is_some());
    }
    assert_eq!(sub.queued_bytes(), 0);
    wait_until("a message after draining", T, || {
        p.put(&summary(1)).unwrap();
        sub.counters().snapshot().delivered > 3
    });
}

#[test]
fn frames_over_zenoh_are_fragmented_and_reassembled() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = pair(dir.path(), "zf");
    let key = "cellsar/test/iq";
    let sub = b
        .frame_subscriber(
            key,
            FrameSubscribeOptions {
                on_full: OnFull::Block,
                ..Default::default()
            },
        )
        .unwrap();
    let p = a
        .frame_publisher(key, CongestionControl::Block, Locality::Any)
        .unwrap();
    wait_until("match", T, || p.has_remote_subscribers());
    // 3 MiB: many Zenoh fragments
    let samples: Vec<Complex32> = (0..(3 << 20) / 8)
        .map(|i| Complex32::new(i as f32, 0.5))
        .collect();
    let payload = frame::samples_as_bytes(&samples);
    let h = FrameMeta::iq(MissionId(3), 7, 0, 3, (samples.len() / 3) as u32)
        .header(Some(frame::checksum(payload)))
        .unwrap();
    p.put(&h, payload).unwrap();
    let f = sub.recv_timeout(T).expect("frame");
    assert_eq!(f.header, h);
    assert_eq!(f.samples().unwrap(), &samples[..]);
    // a corrupted sample is caught by the CRC
    let mut wire = frame::encode_wire(&h, payload).unwrap();
    let last = wire.len() - 3;
    wire[last] ^= 0x10;
    p.put_raw(wire).unwrap();
    // the CRC is checked when the frame is taken: the corrupt one is skipped and counted
    p.put(&h, payload).unwrap();
    let f = sub
        .recv_frame_timeout(T)
        .expect("the good frame after the corrupt one");
    assert_eq!(f.payload_chunks().concat(), payload);
    let c = sub.counters().snapshot();
    assert_eq!((c.received, c.malformed, c.delivered), (3, 1, 2));
}

// ----------------------------------------------------------------------------------------
// iceoryx2 in process

fn spec(name: &str, max: usize) -> FrameServiceSpec {
    FrameServiceSpec::new(name, max)
}

#[test]
fn iox_frames_roundtrip_with_header() {
    let iso = Iso::new("rt");
    let env = iso.env();
    let (node, _) = FrameNode::new(&env, "rt").unwrap();
    let s = spec("cellsar/test/echo", 1 << 16);
    let sub = node.subscriber(&s).unwrap();
    let p = node
        .publisher(&s, FramePublisherOptions::default())
        .unwrap();
    assert_eq!(p.subscriber_count(), 1);
    let samples: Vec<Complex32> = (0..1024).map(|i| Complex32::new(i as f32, -1.0)).collect();
    let meta = FrameMeta::iq(MissionId(9), 0, 5_000, 4, 256);
    let r = p.send_samples(&meta, &samples).unwrap();
    assert_eq!(r.delivered, 1);
    let f = sub.receive_timeout(T).unwrap().expect("frame");
    assert_eq!(f.header().shape, [4, 256]);
    assert_eq!(f.header().mission(), MissionId(9));
    assert_eq!(f.header().mission_time_ns, 5_000);
    assert!(f.header().has_checksum());
    f.verify_checksum().unwrap();
    assert_eq!(f.samples().unwrap(), &samples[..]);
    assert_eq!(f.origin(), p.id());
    drop(f);
    // in-place fill
    p.send_with(&FrameMeta::iq(MissionId(9), 1, 0, 1, 4), |buf| {
        let s = frame::bytes_as_samples_mut(buf).unwrap();
        s[2] = Complex32::new(7.0, 8.0);
    })
    .unwrap();
    let f = sub.receive_timeout(T).unwrap().expect("frame");
    assert_eq!(f.samples().unwrap()[2], Complex32::new(7.0, 8.0));
    f.verify_checksum().unwrap();
    // too large a frame is refused, naming the limit
    let big = vec![Complex32::new(0.0, 0.0); (1 << 16) / 8 + 1];
    let e = p
        .send_samples(
            &FrameMeta::iq(MissionId(9), 2, 0, 1, big.len() as u32),
            &big,
        )
        .unwrap_err();
    assert!(e.to_string().contains("65536"), "{e}");
    // shape that disagrees with the payload
    let e = p
        .send_samples(&FrameMeta::iq(MissionId(9), 2, 0, 2, 2), &samples[..3])
        .unwrap_err();
    assert!(
        e.to_string().contains("payload_len") || e.to_string().contains("shape"),
        "{e}"
    );
}

#[test]
fn iox_spec_validation_and_sizing() {
    let s = spec("cellsar/x/echo", 32 << 20);
    assert_eq!(s.samples_per_publisher(), 4 * (2 + 1) + 1);
    assert!(s.shm_bytes_per_publisher() < 500 << 20);
    let mut bad = s.clone();
    bad.max_subscribers = 0;
    assert!(bad
        .validate()
        .unwrap_err()
        .to_string()
        .contains("max_subscribers"));
    let mut bad = s.clone();
    bad.history = 5;
    assert!(bad.validate().unwrap_err().to_string().contains("history"));
    let mut bad = s;
    bad.name = String::new();
    assert!(bad.validate().unwrap_err().to_string().contains("name"));
}

#[test]
fn iox_full_buffer_skips_and_counts_instead_of_blocking() {
    let iso = Iso::new("full");
    let (node, _) = FrameNode::new(&iso.env(), "full").unwrap();
    let s = spec("cellsar/test/full", 4096);
    let sub = node.subscriber(&s).unwrap(); // buffer 2, not read during the burst
    let p = node
        .publisher(&s, FramePublisherOptions::default())
        .unwrap();
    // a subscriber's end of the connection is established by its first receive
    assert!(sub.receive().unwrap().is_none());
    let data = vec![1u8; 4096];
    let t0 = Instant::now();
    let mut skipped = 0;
    for seq in 0..10 {
        let m = FrameMeta::bytes(1, MissionId(1), seq, data.len()).unwrap();
        skipped += p.send_bytes(&m, &data).unwrap().skipped_full;
    }
    assert!(t0.elapsed() < Duration::from_secs(2), "publisher stalled");
    assert_eq!(skipped, 8);
    assert_eq!(p.counters().snapshot().dropped, 8);
    let a = sub.receive().unwrap().unwrap().header().seq;
    let b = sub.receive().unwrap().unwrap().header().seq;
    assert_eq!((a, b), (0, 1), "the oldest frames stay queued");
    assert!(sub.receive().unwrap().is_none());
    let m = FrameMeta::bytes(1, MissionId(1), 10, data.len()).unwrap();
    p.send_bytes(&m, &data).unwrap();
    assert_eq!(sub.receive().unwrap().unwrap().header().seq, 10);
    assert_eq!(sub.missed(), 8, "the gap 2..=9 is seen by the subscriber");
}

#[test]
fn iox_isolated_environments_do_not_see_each_other() {
    let a = Iso::new("isoa");
    let b = Iso::new("isob");
    let (na, _) = FrameNode::new(&a.env(), "a").unwrap();
    let (nb, _) = FrameNode::new(&b.env(), "b").unwrap();
    let s = spec("cellsar/test/same-name", 1024);
    let sub_b = nb.subscriber(&s).unwrap();
    let sub_a = na.subscriber(&s).unwrap();
    let p = na.publisher(&s, FramePublisherOptions::default()).unwrap();
    assert_eq!(p.subscriber_count(), 1);
    p.send_bytes(&FrameMeta::bytes(1, MissionId(0), 0, 8).unwrap(), &[0u8; 8])
        .unwrap();
    assert!(sub_a.receive_timeout(T).unwrap().is_some());
    assert!(sub_b
        .receive_timeout(Duration::from_millis(200))
        .unwrap()
        .is_none());
}

/// The shared-memory files of a frame service (the segment that carries the frames, the
/// connections, events and service state iceoryx2 makes in `/dev/shm` under the run's prefix)
/// can be read and written by their owner only: another user on the host can neither read the
/// IQ nor write into it. The one exception is iceoryx2's node counter of the domain
/// (`node.<version>.global_mgmt`, one `u32` that numbers the nodes), which iceoryx2 creates
/// world-writable on purpose (`enable_global_access`); a node's id also holds its process id.
#[test]
fn iox_shared_memory_files_are_private_to_their_user() {
    use std::os::unix::fs::PermissionsExt;
    let iso = Iso::new("mode");
    let (node, _) = FrameNode::new(&iso.env(), "mode").unwrap();
    let s = spec("cellsar/test/mode", 1024);
    let sub = node.subscriber(&s).unwrap();
    let p = node
        .publisher(&s, FramePublisherOptions::default())
        .unwrap();
    p.send_bytes(&FrameMeta::bytes(1, MissionId(0), 0, 8).unwrap(), &[0u8; 8])
        .unwrap();
    assert!(sub.receive_timeout(T).unwrap().is_some());
    let files = harness::pipeline::shm_files(&iso.prefix);
    assert!(
        !files.is_empty(),
        "no /dev/shm file with prefix {}",
        iso.prefix
    );
    let modes: Vec<(String, u32)> = files
        .iter()
        .map(|f| {
            let m = std::fs::metadata(format!("/dev/shm/{f}")).unwrap();
            (f.clone(), m.permissions().mode() & 0o777)
        })
        .collect();
    eprintln!("{modes:?}");
    assert!(
        modes.iter().any(|(f, _)| f.ends_with(".data")),
        "no frame segment among {modes:?}"
    );
    for (f, mode) in &modes {
        if f.ends_with(".global_mgmt") {
            let len = std::fs::metadata(format!("/dev/shm/{f}")).unwrap().len();
            assert!(
                len <= 4096,
                "/dev/shm/{f}: {len} bytes, more than a node counter"
            );
            continue;
        }
        assert_eq!(mode & 0o077, 0, "/dev/shm/{f} has mode {mode:o}");
    }
}

/// A publisher process killed with SIGKILL leaves its port registered; the next node removes
/// it, so the service admits a full set of publishers again.
#[test]
fn iox_stale_resources_of_killed_process_are_cleaned() {
    let iso = Iso::new("stale");
    let dir = tempfile::tempdir().unwrap();
    let s = spec("cellsar/test/stale", 4096);
    let mut args = vec![
        s_("iox-pub"),
        s_("--service"),
        s.name.clone(),
        s_("--max-frame-bytes"),
        s.max_payload_bytes.to_string(),
    ];
    args.extend(iso.args());
    args.extend([
        s_("--frames"),
        s_("100000"),
        s_("--frame-bytes"),
        s_("4096"),
        s_("--rate-hz"),
        s_("10"),
        s_("--wait-subscribers"),
        s_("0"),
    ]);
    let mut child = Proc::spawn("iox-pub", &bench_exe(), &args, dir.path(), "warn");
    child.ready();
    child.signal(Signal::SIGKILL);
    child.wait(T);
    let (node, report) = FrameNode::new(&iso.env(), "after-kill").unwrap();
    assert!(report.cleaned >= 1, "no dead node cleaned: {report:?}");
    // max_publishers = 2: both slots must be free again
    let p1 = node
        .publisher(&s, FramePublisherOptions::default())
        .unwrap();
    let p2 = node
        .publisher(&s, FramePublisherOptions::default())
        .unwrap();
    assert_ne!(p1.id(), p2.id());
    assert!(node
        .publisher(&s, FramePublisherOptions::default())
        .is_err());
}

fn s_(v: &str) -> String {
    v.to_string()
}

// ----------------------------------------------------------------------------------------
// processes

/// A frozen (SIGSTOP) subscriber process does not slow the publisher process down; what it
/// misses is counted on both sides and adds up.
#[test]
fn frozen_subscriber_does_not_stall_publisher() {
    let iso = Iso::new("frozen");
    let dir = tempfile::tempdir().unwrap();
    let n: u64 = 300;
    let rate = 200.0;
    let mut svc = vec![
        s("--service"),
        s("cellsar/test/frozen"),
        s("--max-frame-bytes"),
        s("65536"),
    ];
    svc.extend(iso.args());
    let mut sub_args = vec![s("iox-sub")];
    sub_args.extend(svc.clone());
    sub_args.extend([
        s("--frames"),
        n.to_string(),
        s("--idle-s"),
        s("1"),
        s("--timeout-s"),
        s("30"),
        s("--verify"),
    ]);
    let mut sub = Proc::spawn("iox-sub", &bench_exe(), &sub_args, dir.path(), "warn");
    sub.ready();
    let mut pub_args = vec![s("iox-pub")];
    pub_args.extend(svc);
    pub_args.extend([
        s("--frames"),
        n.to_string(),
        s("--frame-bytes"),
        s("65536"),
        s("--rate-hz"),
        rate.to_string(),
    ]);
    let mut publ = Proc::spawn("iox-pub", &bench_exe(), &pub_args, dir.path(), "warn");
    publ.ready();
    std::thread::sleep(Duration::from_millis(300));
    sub.signal(Signal::SIGSTOP);
    let tx = publ.report(Duration::from_secs(30));
    sub.signal(Signal::SIGCONT);
    let rx = sub.report(Duration::from_secs(30));
    let nominal = n as f64 / rate;
    let elapsed = tx["elapsed_s"].as_f64().unwrap();
    assert!(
        elapsed < nominal + 1.0,
        "publisher stalled: {elapsed} s for nominal {nominal} s"
    );
    assert_eq!(tx["frames"], n);
    let dropped = tx["dropped"].as_u64().unwrap();
    let got = rx["frames"].as_u64().unwrap();
    assert!(
        dropped > 100,
        "a subscriber frozen for ~1 s must miss frames: {tx}"
    );
    assert_eq!(
        got + dropped,
        n,
        "every frame either delivered or counted as dropped: {tx} {rx}"
    );
    let last = rx["last_seq"].as_u64().unwrap();
    let missed = rx["missed"].as_u64().unwrap();
    assert_eq!(
        missed + (n - 1 - last),
        dropped,
        "subscriber-side gaps add up: {rx}"
    );
    assert_eq!(rx["checksum_errors"], 0);
}

fn bridge_args(instance: &str, route: &str, iso: &Iso, zenoh: &[String]) -> Vec<String> {
    let mut a = vec![
        s("--instance"),
        s(instance),
        s("--service"),
        s(route),
        s("--max-frame-bytes"),
        s("262144"),
        s("--stats-interval-s"),
        s("1"),
    ];
    a.extend(iso.args());
    a.extend(zenoh.iter().cloned());
    a
}

fn iox_tool(tool: &str, service: &str, iso: &Iso, extra: &[String]) -> Vec<String> {
    let mut a = vec![
        s(tool),
        s("--service"),
        s(service),
        s("--max-frame-bytes"),
        s("262144"),
    ];
    a.extend(iso.args());
    a.extend(extra.iter().cloned());
    a
}

/// Waits until bridge `instance` has its route up and a remote subscriber on `key` (its
/// liveliness token is visible from a probe connected to `endpoint`).
fn wait_route(probe: &ZenohNode, instance: &str, key: &str) {
    let sel = format!("cellsar/bridged/{instance}/{key}");
    wait_until(&sel, Duration::from_secs(20), || {
        !probe
            .alive_now(&sel, Duration::from_millis(300))
            .unwrap()
            .is_empty()
    });
}

fn query_stats(probe: &ZenohNode, instance: &str) -> serde_json::Value {
    let key = keys::bridge_stats(instance).unwrap();
    let replies = probe
        .session()
        .get(&key)
        .timeout(Duration::from_secs(3))
        .wait()
        .unwrap();
    let r = replies.recv().expect("stats reply");
    let sample = r.result().expect("ok reply");
    assert!(sample
        .encoding()
        .to_string()
        .starts_with("application/json"));
    serde_json::from_slice(&sample.payload().to_bytes()).unwrap()
}

/// Two "hosts" (isolated iceoryx2 environments), a bridge on each forwarding the same
/// service both ways: each side's consumer gets exactly the frames of both producers, once;
/// nothing loops (bridge b re-publishes inline, bridge a through its queue). Both bridges then stop cleanly on SIGTERM / SIGINT with their counters logged.
#[test]
fn bridges_forward_both_ways_without_loops() {
    let ha = Iso::new("ha");
    let hb = Iso::new("hb");
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let listen = vec![
        s("--no-multicast-scouting"),
        s("-l"),
        format!("tcp/127.0.0.1:{port}"),
    ];
    let connect = vec![
        s("--no-multicast-scouting"),
        s("-e"),
        format!("tcp/127.0.0.1:{port}"),
        s("-m"),
        s("peer"),
    ];
    let service = "cellsar/test/echo";
    let key = "cellsar/test/echo";
    // bridge b re-publishes in Zenoh's callback, bridge a from its queue thread: both modes
    let mut bb = Proc::spawn(
        "bridge-b",
        &bridge_exe(),
        &[
            bridge_args("b", service, &hb, &listen),
            vec![s("--inbound-queue"), s("0")],
        ]
        .concat(),
        dir.path(),
        "info",
    );
    let mut ba = Proc::spawn(
        "bridge-a",
        &bridge_exe(),
        &bridge_args("a", service, &ha, &connect),
        dir.path(),
        "info",
    );
    let probe = ZenohNode::open(
        z_connect(&format!("tcp/127.0.0.1:{port}"))
            .to_config()
            .unwrap(),
        "test",
        "probe",
    )
    .unwrap();
    wait_route(&probe, "a", key);
    wait_route(&probe, "b", key);
    // each bridge's to-Zenoh side sees the other's subscriber: nothing sent is unmatched
    for b in ["a", "b"] {
        wait_until("remote subscriber matched", Duration::from_secs(20), || {
            query_stats(&probe, b)["body"]["routes"][0]["remote_subscribers"] == true
        });
    }
    let (na, nb) = (20u64, 15u64);
    let rx_args = [
        s("--frames"),
        (na + nb).to_string(),
        s("--idle-s"),
        s("2"),
        s("--timeout-s"),
        s("40"),
        s("--verify"),
    ];
    let mut sub_a = Proc::spawn(
        "sub-a",
        &bench_exe(),
        &iox_tool("iox-sub", service, &ha, &rx_args),
        dir.path(),
        "warn",
    );
    let mut sub_b = Proc::spawn(
        "sub-b",
        &bench_exe(),
        &iox_tool("iox-sub", service, &hb, &rx_args),
        dir.path(),
        "warn",
    );
    sub_a.ready();
    sub_b.ready();
    // each producer waits for its local consumer + its bridge
    let tx = |n: u64| {
        [
            s("--frames"),
            n.to_string(),
            s("--frame-bytes"),
            s("65536"),
            s("--rate-hz"),
            s("50"),
            s("--wait-subscribers"),
            s("2"),
        ]
    };
    let mut pa = Proc::spawn(
        "pub-a",
        &bench_exe(),
        &iox_tool("iox-pub", service, &ha, &tx(na)),
        dir.path(),
        "warn",
    );
    let mut pb = Proc::spawn(
        "pub-b",
        &bench_exe(),
        &iox_tool("iox-pub", service, &hb, &tx(nb)),
        dir.path(),
        "warn",
    );
    pa.ready();
    pb.ready();
    let ta = pa.report(Duration::from_secs(30));
    let tb = pb.report(Duration::from_secs(30));
    assert_eq!(ta["dropped"], 0, "{ta}");
    assert_eq!(tb["dropped"], 0, "{tb}");
    let ra = sub_a.report(Duration::from_secs(40));
    let rb = sub_b.report(Duration::from_secs(40));
    for r in [&ra, &rb] {
        assert_eq!(
            r["frames"],
            na + nb,
            "exactly both producers' frames: {r}\nstats a: {}\nstats b: {}",
            query_stats(&probe, "a"),
            query_stats(&probe, "b")
        );
        assert_eq!(r["duplicates"], 0, "{r}");
        assert_eq!(r["missed"], 0, "{r}");
        assert_eq!(r["checksum_errors"], 0, "{r}");
    }
    let sa = query_stats(&probe, "a");
    assert_eq!(sa["kind_name"], "bridge.stats");
    let route = &sa["body"]["routes"][0];
    assert_eq!(route["to_zenoh"]["forwarded"], na);
    assert_eq!(route["from_zenoh"]["forwarded"], nb);
    assert_eq!(
        route["to_zenoh"]["received"], na,
        "the bridge never re-sends what it received: {route}"
    );
    // liveliness reports the bridge's loss on SIGTERM, exit code 0, final counters logged
    let watch = probe.watch_liveliness("cellsar/alive/bridge/*").unwrap();
    assert!(watch.wait_for("cellsar/alive/bridge/a", true, T));
    ba.signal(Signal::SIGTERM);
    assert!(ba.wait(T).success(), "{}", ba.stderr_tail());
    assert!(watch.wait_for("cellsar/alive/bridge/a", false, T));
    bb.signal(Signal::SIGINT);
    assert!(bb.wait(T).success(), "{}", bb.stderr_tail());
    for b in [&ba, &bb] {
        let log = b.stderr();
        assert!(log.contains("final_counters=true"), "{}", b.stderr_tail());
    }
}

/// 10,000 malformed and oversized payloads on a bridged key: the bridge neither crashes nor
/// forwards any of them, counts each exactly once, logs each (WARN, rate-limited, the rest at
/// DEBUG), and still forwards a good frame afterwards. Zenoh configured from a JSON5 file.
#[test]
fn bridge_survives_10k_malformed_payloads() {
    let hb = Iso::new("flood");
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let cfg = dir.path().join("zenoh.json5");
    std::fs::write(
        &cfg,
        format!("{{ mode: 'peer', listen: {{ endpoints: ['tcp/127.0.0.1:{port}'] }}, scouting: {{ multicast: {{ enabled: false }} }} }}"),
    )
    .unwrap();
    let key = "cellsar/test/flood";
    let mut bb = Proc::spawn(
        "bridge",
        &bridge_exe(),
        &bridge_args(
            "f",
            &format!("cellsar/test/flood={key}@in"),
            &hb,
            // inline mode: every payload is checked inside Zenoh's callback
            &[
                s("-c"),
                cfg.display().to_string(),
                s("--inbound-queue"),
                s("0"),
            ],
        ),
        dir.path(),
        "info,bridge=debug",
    );
    let ep = format!("tcp/127.0.0.1:{port}");
    let probe = ZenohNode::open(z_connect(&ep).to_config().unwrap(), "test", "probe-f").unwrap();
    wait_route(&probe, "f", key);
    let mut sub = Proc::spawn(
        "sub",
        &bench_exe(),
        &iox_tool(
            "iox-sub",
            "cellsar/test/flood",
            &hb,
            &[
                s("--frames"),
                s("1"),
                s("--timeout-s"),
                s("60"),
                s("--verify"),
            ],
        ),
        dir.path(),
        "warn",
    );
    sub.ready();
    let zargs = [s("--no-multicast-scouting"), s("-e"), ep.clone()];
    let mut flood_args = vec![
        s("z-flood"),
        s("--key"),
        s(key),
        s("--count"),
        s("10000"),
        s("--max-frame-bytes"),
        s("262144"),
        s("--wait-matching"),
    ];
    flood_args.extend(zargs.iter().cloned());
    let mut flood = Proc::spawn("z-flood", &bench_exe(), &flood_args, dir.path(), "warn");
    flood.ready();
    let fr = flood.report(Duration::from_secs(60));
    assert_eq!(fr["sent"], 10_000);
    wait_until("all 10k counted", Duration::from_secs(30), || {
        query_stats(&probe, "f")["body"]["routes"][0]["from_zenoh"]["received"] == 10_000
    });
    let st = query_stats(&probe, "f");
    let r = &st["body"]["routes"][0]["from_zenoh"];
    assert_eq!(r["malformed"], 10_000, "{r}");
    assert_eq!(r["forwarded"], 0, "{r}");
    assert!(bb.is_running());
    // a good frame still goes through
    let mut zp = vec![
        s("z-pub"),
        s("--key"),
        s(key),
        s("--frames"),
        s("1"),
        s("--frame-bytes"),
        s("4096"),
        s("--wait-matching"),
    ];
    zp.extend(zargs.iter().cloned());
    let mut good = Proc::spawn("z-pub", &bench_exe(), &zp, dir.path(), "warn");
    good.ready();
    good.report(Duration::from_secs(30));
    let rx = sub.report(Duration::from_secs(30));
    assert_eq!(rx["frames"], 1, "{rx}");
    assert_eq!(rx["checksum_errors"], 0);
    bb.signal(Signal::SIGTERM);
    assert!(bb.wait(T).success());
    // every rejected payload is in the log: at WARN (rate-limited) or DEBUG
    let log = bb.stderr();
    let logged = log
        .lines()
        .filter(|l| l.contains("rejected payload source="))
        .count();
    assert_eq!(logged, 10_000, "each malformed payload logged once");
    assert!(log.contains("more rejected payloads were logged at DEBUG only"));
}

/// A bridge started before its router (a client config whose router is not there, as
/// `pipeline/deploy/client.json5` with `connect.timeout_ms: -1`) says what it waits for and
/// stops at once on SIGINT or SIGTERM, exit code 0, like a running bridge.
#[test]
fn bridge_waiting_for_its_router_stops_on_signals() {
    let dir = tempfile::tempdir().unwrap();
    let iso = Iso::new("norouter");
    let cfg = dir.path().join("client.json5");
    let port = free_port();
    std::fs::write(
        &cfg,
        bridge::zconfig::waiting_client_json5(&format!("tcp/127.0.0.1:{port}")),
    )
    .unwrap();
    for sig in [Signal::SIGINT, Signal::SIGTERM] {
        let mut a = vec![
            s("--service"),
            s("cellsar/0123456789abcdef/echo@out"),
            s("-c"),
            cfg.display().to_string(),
        ];
        a.extend(iso.args());
        // no RUST_LOG: the bridge's default level shows that it waits
        let mut p = Proc::spawn_with_env(
            &format!("bridge-{sig}"),
            &bridge_exe(),
            &a,
            dir.path(),
            None,
        );
        wait_until("the bridge says that it waits", T, || {
            p.stderr().contains("waiting for the Zenoh session")
        });
        assert!(p.is_running(), "{}", p.stderr_tail());
        assert!(
            p.stderr()
                .contains(&format!("connect [tcp/127.0.0.1:{port}]")),
            "{}",
            p.stderr_tail()
        );
        p.signal(sig);
        let t = Instant::now();
        let st = p.wait(T);
        assert!(
            t.elapsed() < Duration::from_secs(3),
            "SIG{sig}: exit took {:?}",
            t.elapsed()
        );
        assert_eq!(st.code(), Some(0), "SIG{sig}: {}", p.stderr_tail());
        assert!(
            p.stderr()
                .contains("stopped before the Zenoh session opened"),
            "{}",
            p.stderr_tail()
        );
    }
}

/// A bridge with a bad route or an unusable Zenoh flag fails at start (exit code 2: bad input)
/// with one clean line naming it (no Debug output, no source paths of Zenoh).
#[test]
fn bridge_rejects_bad_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let iso = Iso::new("badcfg");
    for (args, needle) in [
        (vec![s("--service"), s("x=a/*")], "a/*"),
        (vec![s("--service"), s("x@sideways")], "sideways"),
        (
            vec![s("--service"), s("x"), s("-l"), s("nonsense")],
            "--listen",
        ),
        (
            vec![s("--service"), s("x"), s("--instance"), s("a/b")],
            "instance",
        ),
        (
            vec![s("--service"), s("x"), s("-e"), s("garbage")],
            "--connect garbage",
        ),
    ] {
        let mut a = args.clone();
        a.extend(iso.args());
        let mut p = Proc::spawn("bridge-bad", &bridge_exe(), &a, dir.path(), "warn");
        let st = p.wait(T);
        assert_eq!(st.code(), Some(2), "{args:?}");
        let err = p.stderr();
        assert!(err.contains(needle), "{args:?}: {}", p.stderr_tail());
        for noise in [".rs:", "Message {", "Json5Err", ".cargo"] {
            assert!(!err.contains(noise), "{args:?}: {noise:?} in {err}");
        }
        // printed once (not also through tracing), each cause once
        let lines: Vec<&str> = err.lines().filter(|l| l.contains(needle)).collect();
        assert_eq!(lines.len(), 1, "{args:?}: {err}");
        assert!(lines[0].starts_with("error: "), "{}", lines[0]);
        let parts: Vec<&str> = lines[0].split(": ").collect();
        for (i, part) in parts.iter().enumerate() {
            assert!(
                !parts[i + 1..].contains(part),
                "cause repeated: {}",
                lines[0]
            );
        }
    }
    // a number of seconds that is not one: refused by name before anything starts
    for bad in ["nan", "-1", "0"] {
        let mut a = vec![s("--service"), s("x"), format!("--stats-interval-s={bad}")];
        a.extend(iso.args());
        let mut p = Proc::spawn("bridge-bad", &bridge_exe(), &a, dir.path(), "warn");
        let st = p.wait(T);
        assert_eq!(st.code(), Some(2), "{bad}: {}", p.stderr_tail());
        assert!(
            p.stderr().contains("--stats-interval-s"),
            "{}",
            p.stderr_tail()
        );
        assert!(!p.stderr().contains("panicked"), "{}", p.stderr_tail());
    }
    let _ = IoxEnv::default_env();
}

/// The benchmark of what TLS costs the bridge (BENCHMARKS.md) runs under the deployment's
/// rules: bridge B serves with the router's certificate, the others are clients with role
/// certificates and no plain listener. A short run of every network path delivers every frame.
#[test]
fn the_tls_benchmark_runs_and_delivers_every_frame() {
    assert!(
        bridge_exe().exists(),
        "cellsar-bridge is built next to the bench"
    );
    let out = std::process::Command::new(bench_exe())
        .args([
            "bench",
            "--sizes-mib",
            "1",
            "--frames",
            "3",
            "--repeats",
            "1",
            "--tls",
            "--only-network",
        ])
        .env("RUST_LOG", "warn")
        .output()
        .expect("run cellsar-bridge-bench");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "bench --tls failed: {}\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    for path in ["zenoh", "bridge", "bridge-tls"] {
        for mode in ["latency", "throughput"] {
            let row = stdout
                .lines()
                .find(|l| l.starts_with(&format!("| {path} | {mode} |")))
                .unwrap_or_else(|| panic!("no {path} {mode} row in:\n{stdout}"));
            assert!(row.contains("| 3/3 |"), "{path} {mode} lost frames: {row}");
        }
    }
}
