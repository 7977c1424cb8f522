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
use bridge::{DecodeLimits, ZenohArgs, ZenohNode};
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
        let m = planner::Mission::from_path(&mission()).unwrap();
        let m = radar_sim::run::shorten(&m, H).unwrap();
        let req = PlanRequest {
            mission: m.to_file_struct(),
            options: Default::default(),
        };
        self.node
            .query_one::<PlanRequest, Plan>(
                PLAN_KEY,
                &req,
                &QueryOptions {
                    timeout: Duration::from_secs(120),
                    limits: DecodeLimits {
                        max_body_bytes: MAX_PLAN_BYTES,
                        verify_crc: true,
                    },
                    ..QueryOptions::default()
                },
            )
            .unwrap()
            .message
    }
}

/// Collects the mission's results into `out` and checks them against the closed loop.
fn collect_and_check(c: &Client, plan: &Plan, out: &Path, started: Vec<Service>) {
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
    for mut s in started {
        assert!(
            s.stop(Duration::from_secs(20)).success(),
            "{}",
            s.log_text()
        );
        assert!(s.log_text().contains("final_counters=true"));
    }
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
    let body = serde_json::json!({"mission": m.to_file_struct()});
    let req = serde_json::json!({"kind": 0x0101, "schema_version": 1, "mission_id": "0000000000000000",
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
    // the same plan in binary form for this (Rust) client
    let plan = c.plan();
    assert_eq!(plan.mission_id.to_string(), id);
    // the processor waits for an echo (its requests fail) until one joins
    std::thread::sleep(Duration::from_secs(2));
    let e = w.start("echo");
    collect_and_check(&c, &plan, &w.dir.path().join("out"), vec![p, e, pl]);
}
