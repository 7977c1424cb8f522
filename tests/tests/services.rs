//! The services without the launcher: started in different orders, some joining after the plan
//! was published; a client (this test) asks for the plan and collects the results, which must
//! be those of the closed loop.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use bridge::net::{QueryOptions, SubscribeOptions, WireFormat};
use bridge::zenoh::bytes::Encoding;
use bridge::zenoh::Wait;
use bridge::{DecodeLimits, NetError, ZenohArgs, ZenohNode};
use harness::memory::{Baseline, MIB};
use harness::pipeline::*;
use pipeline::collect::Collector;
use pipeline::protocol::keys::{self as pkeys, PLAN as PLAN_KEY};
use pipeline::protocol::{ApertureDetections, ApertureImage, MissionMetrics};
use pipeline::protocol::{Plan, PlanRequest, MAX_PLAN_BYTES};
use pipeline::services::process::MissionContext;

const H: f64 = 20.0;

struct World {
    dir: tempfile::TempDir,
    hub: String,
    iox: Vec<String>,
}

impl World {
    fn new() -> World {
        let dir = tempfile::tempdir().unwrap();
        let hub = format!("tcp/127.0.0.1:{}", free_port());
        let iox = vec![
            "--iox-root".to_string(),
            dir.path().join("iox").display().to_string(),
            "--iox-prefix".to_string(),
            format!("sv{}_{}_", std::process::id(), free_port()),
        ];
        World { dir, hub, iox }
    }

    /// The iceoryx2 prefix of this world's services (unique per test).
    fn prefix(&self) -> &str {
        &self.iox[3]
    }

    fn zenoh(&self) -> Vec<String> {
        ZenohArgs::isolated(
            &["tcp/127.0.0.1:0".to_string()],
            std::slice::from_ref(&self.hub),
        )
        .to_cli_args()
    }

    fn start(&self, role: &str) -> Service {
        self.start_with(role, &[])
    }

    /// Starts `role` with `extra` flags after the usual ones.
    fn start_with(&self, role: &str, extra: &[&str]) -> Service {
        let mut a: Vec<String> = match role {
            "planner" => vec!["planner".into()],
            "echo" => vec![
                "echo".into(),
                "--scene".into(),
                scene().display().to_string(),
            ],
            _ => vec![
                "process".into(),
                "--scene".into(),
                scene().display().to_string(),
                "--resend-after-s".into(),
                "2".into(),
            ],
        };
        a.extend(self.zenoh());
        if role != "planner" {
            a.extend(self.iox.clone());
        }
        a.extend(extra.iter().map(|s| s.to_string()));
        Service::start(role, self.dir.path(), &a)
    }
}

/// iceoryx2 keeps a node-management file per prefix in /dev/shm that outlives the services
/// (one per test, and the next test's prefix differs, so the stale-resource clean-up at start
/// never sees it): remove this world's files when the test ends.
impl Drop for World {
    fn drop(&mut self) {
        let prefix = self.prefix().to_string();
        if let Ok(entries) = std::fs::read_dir("/dev/shm") {
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().starts_with(&prefix) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
    }
}

/// The client: hub of the mesh, asks for the plan, collects the results.
struct Client {
    node: ZenohNode,
}

impl Client {
    fn new(w: &World) -> Client {
        let z = ZenohArgs::isolated(std::slice::from_ref(&w.hub), &[]);
        Client {
            node: ZenohNode::open(z.to_config().unwrap(), "client", "test").unwrap(),
        }
    }

    fn wait_alive(&self, role: &str) {
        let deadline = Instant::now() + Duration::from_secs(60);
        while self
            .node
            .alive_now(
                &format!("cellsar/alive/{role}/*"),
                Duration::from_millis(300),
            )
            .unwrap()
            .is_empty()
        {
            assert!(Instant::now() < deadline, "{role} never came up");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    fn plan(&self) -> Plan {
        self.plan_named(None)
    }

    /// The plan of the short mission, renamed `name` (another mission id) if given.
    fn plan_named(&self, name: Option<&str>) -> Plan {
        let m = planner::Mission::from_path(&mission()).unwrap();
        let m = radar_sim::run::shorten(&m, H).unwrap();
        let mut file = m.to_file_struct();
        if let Some(n) = name {
            file.name = Some(n.to_string());
        }
        // the launcher's default resolution, as the reference closed loop plans
        let req = PlanRequest {
            mission: file,
            options: pipeline::protocol::PlanRequestOptions {
                resolution: Some(planner::DEFAULT_RESOLUTION),
                ..Default::default()
            },
        };
        let opts = QueryOptions {
            timeout: Duration::from_secs(120),
            limits: DecodeLimits {
                max_body_bytes: MAX_PLAN_BYTES,
                verify_crc: true,
            },
            ..QueryOptions::default()
        };
        // a planner's liveliness token is declared when its session opens, before its
        // queryable: until that is declared a query finds nobody (NoReply at once), so ask
        // again, as the launcher does
        let deadline = Instant::now() + Duration::from_secs(120);
        loop {
            match self
                .node
                .query_one::<PlanRequest, Plan>(PLAN_KEY, &req, &opts)
            {
                Ok(reply) => return reply.message,
                Err(NetError::NoReply { .. }) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(50));
                }
                Err(e) => panic!("asking for the plan: {e}"),
            }
        }
    }
}

/// Collects the mission's results into `out` and checks them against the closed loop; stops
/// the services and hands them back (for their logs).
fn collect_and_check(c: &Client, plan: &Plan, out: &Path, started: Vec<Service>) -> Vec<Service> {
    let det = c
        .node
        .subscriber::<ApertureDetections>(pkeys::ALL_DETECTIONS, SubscribeOptions::default())
        .unwrap();
    let img = c
        .node
        .subscriber::<ApertureImage>(pkeys::ALL_IMAGES, SubscribeOptions::default())
        .unwrap();
    let met = c
        .node
        .subscriber::<MissionMetrics>(pkeys::ALL_METRICS, SubscribeOptions::default())
        .unwrap();
    let ctx = MissionContext::new(
        &Arc::new(plan.clone()),
        &radar_sim::config::SceneFile::from_path(&scene()).unwrap(),
        pipeline::services::radar::DEFAULT_MAX_FRAME_BYTES,
    )
    .unwrap();
    let mut col = Collector::new(plan.mission_id, ctx.apertures.len(), out).unwrap();
    let deadline = Instant::now() + Duration::from_secs(180);
    let mut last_ask = Instant::now();
    while !col.complete() {
        assert!(
            Instant::now() < deadline,
            "incomplete: missing {:?}",
            col.missing()
        );
        while let Some(d) = det.try_recv() {
            col.add_detections(d.message);
        }
        while let Some(i) = img.try_recv() {
            col.add_image(&i.message).unwrap();
        }
        while let Some(m) = met.try_recv() {
            col.add_metrics(m.message);
        }
        // results published before this client subscribed: ask for them again
        if last_ask.elapsed() > Duration::from_secs(3) {
            last_ask = Instant::now();
            let req = pipeline::protocol::ResultRequest {
                mission_id: plan.mission_id,
                apertures: col.missing(),
                metrics: !col.has_metrics(),
            };
            let _ = c.node.query_one::<_, pipeline::protocol::ResultAck>(
                &pkeys::results(plan.mission_id).unwrap(),
                &req,
                &QueryOptions::default(),
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    col.write().unwrap();
    let reference = reference(H);
    for (a, b) in [
        ("detections.csv", "processed/detections.csv"),
        ("detections.json", "processed/detections.json"),
        ("metrics.json", "processed/metrics.json"),
    ] {
        assert_eq!(
            std::fs::read_to_string(out.join(a)).unwrap(),
            std::fs::read_to_string(reference.join(b)).unwrap(),
            "{a}"
        );
    }
    let mut started = started;
    for s in &mut started {
        assert!(
            s.stop(Duration::from_secs(20)).success(),
            "{}",
            s.log_text()
        );
        assert!(s.log_text().contains("final_counters=true"));
    }
    started
}

#[test]
fn processor_echo_planner_then_request() {
    let w = World::new();
    let c = Client::new(&w);
    let p = w.start("processor");
    let e = w.start("echo");
    let pl = w.start("planner");
    for r in ["processor", "echo", "planner"] {
        c.wait_alive(r);
    }
    let plan = c.plan();
    collect_and_check(&c, &plan, &w.dir.path().join("out"), vec![p, e, pl]);
}

#[test]
fn echo_and_processor_join_after_the_plan() {
    let w = World::new();
    let c = Client::new(&w);
    let pl = w.start("planner");
    c.wait_alive("planner");
    // planned and published with nobody listening
    let plan = c.plan();
    let e = w.start("echo");
    c.wait_alive("echo");
    let p = w.start("processor");
    collect_and_check(&c, &plan, &w.dir.path().join("out"), vec![p, e, pl]);
}

#[test]
fn late_echo_and_a_json_client() {
    let w = World::new();
    let c = Client::new(&w);
    let pl = w.start("planner");
    let p = w.start("processor");
    c.wait_alive("planner");
    c.wait_alive("processor");
    // a client without Rust: the request as JSON, the reply as JSON
    let m = planner::Mission::from_path(&mission()).unwrap();
    let m = radar_sim::run::shorten(&m, H).unwrap();
    // the options of the Rust client's request below, so that both ask for the same plan
    let body = serde_json::json!({"mission": m.to_file_struct(),
        "options": {"resolution": planner::DEFAULT_RESOLUTION}});
    let req = serde_json::json!({"kind": 0x0101, "schema_version": 2, "mission_id": "0000000000000000",
        "seq": 0, "time_unix_ns": 0, "body": body});
    let replies = c
        .node
        .session()
        .get(PLAN_KEY)
        .payload(serde_json::to_vec(&req).unwrap())
        .encoding(WireFormat::Json.encoding::<PlanRequest>())
        .timeout(Duration::from_secs(120))
        .wait()
        .unwrap();
    let reply = replies.recv().unwrap();
    let sample = reply.result().unwrap();
    assert!(sample
        .encoding()
        .to_string()
        .starts_with(Encoding::APPLICATION_JSON.to_string().as_str()));
    let v: serde_json::Value = serde_json::from_slice(&sample.payload().to_bytes()).unwrap();
    assert_eq!(v["kind_name"], "planner.plan");
    let id = v["body"]["mission_id"].as_str().unwrap().to_string();
    // best-effort options that the plan would ignore are refused, with the library's message
    // (planner::PlanOptions::check_best_effort) naming the request's field
    let bad = serde_json::json!({"kind": 0x0101, "schema_version": 2,
        "mission_id": "0000000000000000", "seq": 1, "time_unix_ns": 0,
        "body": {"mission": m.to_file_struct(),
                 "options": {"resolution": "paper", "strict_resolution": true}}});
    let replies = c
        .node
        .session()
        .get(PLAN_KEY)
        .payload(serde_json::to_vec(&bad).unwrap())
        .encoding(WireFormat::Json.encoding::<PlanRequest>())
        .timeout(Duration::from_secs(60))
        .wait()
        .unwrap();
    let refusal = replies.recv().unwrap();
    let refusal = refusal.result().map(|_| ()).unwrap_err();
    let r: serde_json::Value = serde_json::from_slice(&refusal.payload().to_bytes()).unwrap();
    assert_eq!(r["body"]["kind"], "bad_request", "{r}");
    assert_eq!(
        r["body"]["message"],
        "options.strict_resolution applies to resolution general only, not to paper",
        "{r}"
    );
    // the same plan in binary form for this (Rust) client
    let plan = c.plan();
    assert_eq!(plan.mission_id.to_string(), id);
    // the processor waits for an echo (its requests fail) until one joins
    std::thread::sleep(Duration::from_secs(2));
    let e = w.start("echo");
    collect_and_check(&c, &plan, &w.dir.path().join("out"), vec![p, e, pl]);
}

// Hostile or broken peers: bounded work, nothing lost.

/// Waits (at most 60 s) until `s`'s log holds `n` lines containing `marker`.
fn wait_log_lines(s: &Service, marker: &str, n: usize) {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let got = s.log_text().lines().filter(|l| l.contains(marker)).count();
        if got >= n {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "{got} of {n} lines with {marker:?}:\n{}",
            s.log_text()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// How much more the processor may hold at its peak during
/// [`plan_and_request_floods_are_bounded`] than before it: its session's buffers, the two
/// missions it keeps (waiting for their echo, each holds little: measured +20 MiB in all, and
/// +21 MiB with five missions held) and one request of 100 000 apertures with its answer. A
/// regression that keeps requests, answers or refused missions without bound exceeds it.
const FLOOD_PEAK_BOUND: u64 = 64 * MIB;

/// A peer that makes the planner publish plan after plan cannot make the processor or the echo
/// take on any mission nobody asked for, nor hold more than `--max-missions` of those asked
/// for; a result request cannot make the processor answer or publish more than the mission
/// has.
#[test]
fn plan_and_request_floods_are_bounded() {
    let w = World::new();
    let c = Client::new(&w);
    let pl = w.start("planner");
    let mut p = w.start_with("processor", &["--max-missions", "2"]);
    c.wait_alive("planner");
    c.wait_alive("processor");
    let memory = Baseline::take(p.child.id());
    let plans: Vec<Plan> = (0..5)
        .map(|i| c.plan_named(Some(&format!("flood-{i}"))))
        .collect();
    let ids: std::collections::BTreeSet<_> = plans.iter().map(|p| p.mission_id).collect();
    assert_eq!(ids.len(), 5, "five distinct missions");
    let settled = |s: &Service| {
        s.log_text()
            .lines()
            .filter(|l| l.contains("plan received") || l.contains("plan refused"))
            .count()
    };
    // published, but asked for by nobody: taken on by nobody
    std::thread::sleep(Duration::from_secs(1));
    assert_eq!(settled(&p), 0, "{}", p.log_text());

    let ask = |id, apertures: Vec<u32>, metrics: bool| {
        c.node
            .query_one::<_, pipeline::protocol::ResultAck>(
                &pkeys::results(id).unwrap(),
                &pipeline::protocol::ResultRequest {
                    mission_id: id,
                    apertures,
                    metrics,
                },
                &QueryOptions {
                    timeout: Duration::from_secs(10),
                    ..QueryOptions::default()
                },
            )
            .unwrap()
            .message
    };
    // asked for one after the other (no echo): the first two missions stay in progress, the
    // other three are refused
    for (i, plan) in plans.iter().enumerate() {
        ask(plan.mission_id, Vec::new(), false);
        let deadline = Instant::now() + Duration::from_secs(30);
        while settled(&p) <= i {
            assert!(Instant::now() < deadline, "{}", p.log_text());
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    wait_log_lines(&p, "plan refused", 3);

    // duplicated apertures: answered once; an unknown mission: the answer stays bounded
    let held = plans[0].mission_id;
    let ack = ask(held, vec![0; 100_000], true);
    assert_eq!(ack.missing, vec![0], "duplicates asked once");
    assert!(ack.republished.is_empty() && !ack.metrics);
    // (asked for again: refused again, a fourth time)
    let refused = plans[4].mission_id;
    let ack = ask(refused, (0..100_000).collect(), true);
    assert_eq!(
        ack.missing.len(),
        4096,
        "an unknown mission's answer is capped"
    );
    wait_log_lines(&p, "plan refused", 4);
    // what the flood made the processor hold at its peak: the two missions it keeps, and one
    // request of 100 000 apertures (400 kB) with its answer
    memory.assert_peak_within(
        FLOOD_PEAK_BOUND,
        "the processor after five plans and two requests of 100 000 apertures",
    );

    assert!(
        p.stop(Duration::from_secs(20)).success(),
        "{}",
        p.log_text()
    );
    let log = p.log_text();
    assert_eq!(
        counter(&log, "final_counters=true", "plans_refused"),
        Some(4),
        "{log}"
    );
    assert_eq!(
        counter(&log, "final_counters=true", "evicted"),
        Some(0),
        "{log}"
    );
    assert_eq!(
        counter(&log, "final_counters=true", "republished"),
        Some(0),
        "{log}"
    );

    // an echo that joins now takes on none of the five plans until asked; asked for each (an
    // aperture out of range: refused, nothing queued), it keeps the two it took last
    let mut e = w.start_with("echo", &["--max-missions", "2"]);
    e.wait_for_log("echo ready", Duration::from_secs(60));
    c.wait_alive("echo");
    assert_eq!(settled(&e), 0, "{}", e.log_text());
    for plan in &plans {
        let r = c.node.query_one::<_, pipeline::protocol::RequestAck>(
            &pkeys::echo_request(plan.mission_id).unwrap(),
            &pipeline::protocol::ApertureRequest {
                mission_id: plan.mission_id,
                aperture: 1_000_000,
                look: None,
                frame_pulses: 1,
                scene_digest: 0,
                requester: "test".into(),
            },
            &QueryOptions {
                timeout: Duration::from_secs(10),
                ..QueryOptions::default()
            },
        );
        let err = r.expect_err("an aperture out of range is refused");
        assert!(err.to_string().contains("does not exist"), "{err}");
    }
    wait_log_lines(&e, "mission let go", 3);
    assert!(
        e.stop(Duration::from_secs(20)).success(),
        "{}",
        e.log_text()
    );
    let log = e.log_text();
    assert_eq!(
        counter(&log, "final_counters=true", "evicted"),
        Some(3),
        "{log}"
    );
    assert_eq!(
        counter(&log, "final_counters=true", "plans_refused"),
        Some(0),
        "{log}"
    );
    drop(pl);
}

/// A processor whose state directory cannot be written (here: a file stands where the
/// directory should be) says so, and still processes and publishes every aperture.
#[test]
fn a_processor_that_cannot_save_its_state_keeps_serving() {
    let w = World::new();
    let c = Client::new(&w);
    let blocked = w.dir.path().join("state-is-a-file");
    std::fs::write(&blocked, b"not a directory").unwrap();
    let blocked = blocked.display().to_string();
    let p = w.start_with("processor", &["--state-dir", &blocked]);
    let e = w.start("echo");
    let pl = w.start("planner");
    for r in ["processor", "echo", "planner"] {
        c.wait_alive(r);
    }
    let plan = c.plan();
    let stopped = collect_and_check(&c, &plan, &w.dir.path().join("out"), vec![p, e, pl]);
    let log = stopped[0].log_text();
    assert!(log.contains("not saved to the state directory"), "{log}");
    let errors = counter(&log, "final_counters=true", "state_errors").unwrap();
    assert!(errors >= 1, "{log}");
    assert_eq!(
        counter(&log, "final_counters=true", "missions"),
        Some(1),
        "{log}"
    );
}
