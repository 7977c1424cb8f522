//! The hostile-peer suite on the plain local mesh (`cellsar run`'s private mesh of Unix
//! sockets, joined by a peer of the same user: the strongest position a peer has without
//! the router's access control). While the mission waits for its echo, a forger publishes
//! well-formed but wrong messages of every type the launcher and the services take, and
//! floods: a failed processor status, detections, images and metrics under an instance of its
//! own, a malformed image under the live processor's instance, plans of hundreds of distinct
//! missions (each under its own, correct id: more than any plan cache keeps and than the
//! processor's `--max-missions`), a plan published under an id its content does not give,
//! forged answers to plan requests, and every round requests to publish every aperture again,
//! requests to the echo for an aperture out of range and lookups of plans nobody made. The
//! peak resident memory of the planner, the processor and the launcher stays within a bound
//! derived from their caps; then the echo starts and the run ends with the closed loop's
//! outputs and exit 0.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use harness::memory::{Baseline, MIB};
use harness::pipeline::*;
use serde_json::Value;

const H: f64 = 30.0;

/// Plans of distinct missions the forger publishes: far more than a plan cache keeps (128),
/// and more bytes (encoded alone) than [`peak_bound`] allows.
const FLOOD_PLANS: u32 = 4000;

/// Plans a plan cache keeps.
const CACHE_PLANS: u64 = pipeline::services::plan::MAX_HELD_PLANS as u64;

/// How much more a service may hold at its peak under the forger than before, for plans of
/// `plan_bytes` encoded: a full plan cache of [`CACHE_PLANS`], each plan decoded at most 4
/// times its encoded size, plus 64 MiB for Zenoh's buffers, the allocator's slack and the
/// processor's missions (at most `--max-missions`, 16; the floods' messages are small).
/// Measured (4000 plans of 30 KB, 15 s of forgeries): +0 MiB (planner), +30 MiB (processor),
/// +7 to +13 MiB (launcher), against a bound of 79 MiB; the plans alone are 118 MiB encoded.
fn peak_bound(plan_bytes: u64) -> u64 {
    64 * MIB + CACHE_PLANS * 4 * plan_bytes
}

/// Seconds the forger forges.
const FORGE_S: u64 = 15;

/// The report line (JSON) a tool printed last in `log`.
fn report_of(log: &str) -> Value {
    let line = log
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .unwrap_or_else(|| panic!("no report in:\n{log}"));
    serde_json::from_str(line).unwrap()
}

/// Rounds of forgeries the forger does at least for the run's mission, past its
/// `--duration-s` if need be (a loaded machine can spend all of it on the flood before the
/// first round).
const MIN_ROUNDS: u64 = 20;

/// The longest a run, or one of its steps, may take in these tests: generous enough for a
/// debug build on a 2-core machine at load 10 (the run alone takes about 45 s on an idle one).
const LOADED: Duration = Duration::from_secs(900);

/// Waits for the forger to exit (at most `forge_s` + [`LOADED`]), asserts it succeeded and
/// gives its report.
fn forger_report(forger: &mut Service, forge_s: u64) -> Value {
    let deadline = Instant::now() + Duration::from_secs(forge_s) + LOADED;
    let st = loop {
        if let Some(st) = forger.child.try_wait().unwrap() {
            break st;
        }
        assert!(Instant::now() < deadline, "{}", forger.log_text());
        std::thread::sleep(Duration::from_millis(100));
    };
    let log = forger.log_text();
    assert!(st.success(), "{st:?}\n{log}");
    let r = report_of(&log);
    eprintln!("forger: {r}");
    r
}

/// Removes the iceoryx2 segments of the run of `net` (its `network` event) that the echo,
/// started by hand, left after the launcher's clean-up.
fn remove_echo_segments(net: &Value) {
    let iox: Vec<&str> = net["iox"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    if let Some(prefix) = iox
        .windows(2)
        .find(|w| w[0] == "--iox-prefix")
        .map(|w| w[1])
    {
        for f in shm_files(prefix) {
            let _ = std::fs::remove_file(format!("/dev/shm/{f}"));
        }
    }
}

/// The launcher's Unix socket endpoint, from its `network` event.
fn hub_of(net: &Value) -> String {
    let listen: Vec<String> = serde_json::from_value(net["launcher"].clone()).unwrap();
    listen
        .iter()
        .find(|a| a.starts_with("unixsock-stream/"))
        .unwrap_or_else(|| panic!("the launcher listens on no Unix socket: {listen:?}"))
        .clone()
}

#[test]
fn a_hostile_peer_of_every_kind_leaves_the_run_exact_and_bounded() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // no echo yet: the mission waits while the forger works
    let timeout = LOADED.as_secs().to_string();
    let mut l = Launch::start(
        d,
        H,
        &[
            "--external",
            "echo",
            "--timeout-s",
            &timeout,
            "--peer-timeout-s",
            &timeout,
        ],
    );
    let net = l.event("network", LOADED);
    let hub = hub_of(&net);
    // the forger is told the mission (besides learning it), and forges for it at least
    // MIN_ROUNDS rounds however long its flood takes: the event, not a time, is waited for
    let planned = l.event("planned", LOADED);
    let mission = planned["mission_id"].as_str().unwrap().to_string();
    let before: Vec<(&str, Baseline)> = vec![
        ("planner", Baseline::take(l.pid("planner"))),
        ("processor", Baseline::take(l.pid("processor"))),
        ("launcher", Baseline::take(l.child.id())),
    ];
    let template = reference.join("processed/metrics.json");
    let args: Vec<String> = [
        "forge",
        "--duration-s",
        &FORGE_S.to_string(),
        "--interval-ms",
        "20",
        "--forge-results",
        "--metrics-template",
        &template.display().to_string(),
        "--malformed-images",
        "--forge-plans",
        "--flood-plans",
        &FLOOD_PLANS.to_string(),
        "--flood-queries",
        "--mission",
        &mission,
        "--min-rounds",
        &MIN_ROUNDS.to_string(),
        "-m",
        "client",
        "-e",
        &hub,
        "--no-multicast-scouting",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let started = Instant::now();
    let mut forger = Service::start_exe_in(
        &[],
        &harness::bin("cellsar-bridge-bench"),
        "forger",
        d,
        &args,
    );
    let r = forger_report(&mut forger, FORGE_S);
    assert!(
        r["missions"].as_u64().unwrap() >= 1,
        "the forger saw no mission: {r}"
    );
    assert!(r["rounds"].as_u64().unwrap() >= MIN_ROUNDS, "{r}");
    assert_eq!(r["flood"]["plans"], FLOOD_PLANS, "{r}");
    assert!(r["flood"]["queries"].as_u64().unwrap() > 0, "{r}");
    for kind in ["statuses", "detections", "images", "metrics", "plans"] {
        assert!(r[kind].as_u64().unwrap() > 0, "{kind}: {r}");
    }
    let plan_bytes = r["flood"]["plan_bytes"].as_u64().unwrap();
    let bound = peak_bound(plan_bytes);
    // a service that kept every plan would pass the bound
    assert!(u64::from(FLOOD_PLANS) * plan_bytes > bound, "{r}");
    for (role, b) in &before {
        b.assert_peak_within(
            bound,
            &format!("the {role} under a hostile peer ({plan_bytes} B per plan)"),
        );
    }
    // now the echo: the run completes with the closed loop's outputs
    let ea = echo_args(&net);
    let mut echo = Service::start("echo", d, &ea);
    let st = l.finish(LOADED);
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    assert!(echo.stop(Duration::from_secs(20)).success());
    remove_echo_segments(&net);
    let p = l.pipeline_json();
    eprintln!("collector: {}", p["collector"]);
    // the forgeries reached the launcher and were refused there: the forged status,
    // detections, images and metrics as another sender's, the malformed image as malformed
    let c = &p["collector"];
    for key in ["refused_senders", "foreign", "malformed"] {
        assert!(c[key].as_u64().unwrap() > 0, "{key}: {c}");
    }
    for kind in ["status", "detections", "images", "metrics"] {
        assert!(
            c["refused_by_kind"][kind].as_u64().unwrap() > 0,
            "{kind}: {c}"
        );
    }
    // the flooded plans reached the processor (its plan subscription) but it took on none of
    // them: no plan refused at --max-missions, no mission let go for them
    let log = l.log("processor");
    for key in ["plans_refused", "evicted"] {
        assert_eq!(
            counter(&log, "processor stopping", key),
            Some(0),
            "processor {key}:\n{log}"
        );
    }
    eprintln!("hostile suite: {:.1} s", started.elapsed().as_secs_f64());
}

/// Plan requests the forger may send (it sends them for [`PLAN_FLOOD_S`], 48 in flight).
const FLOOD_PLAN_REQUESTS: u32 = 1_000_000;

/// Seconds the forger floods the planner with plan requests: long enough that the launcher's
/// request, served in turn, is planned while the flood still runs even on a loaded machine
/// (11.4 s beside two CPU hogs).
const PLAN_FLOOD_S: u64 = 30;

/// How much more the planner may hold at its peak under the flood of plan requests than when
/// it started: its request queue (16 small requests), a full plan cache of the flood's small
/// plans ([`CACHE_PLANS`] of at most 64 KiB encoded, 4 times that decoded) and 64 MiB for
/// Zenoh's buffers and the allocator's slack.
const PLAN_FLOOD_BOUND: u64 = 64 * MIB + CACHE_PLANS * 4 * 64 * 1024;

/// A peer floods the planner with plan requests of distinct, well-formed missions (each a
/// real planning job; far more at once than its request queue takes, so that most are
/// refused as busy) from before the planner starts, the processor up: the planner serves the
/// launcher's request in turn with the flood's (one queued request per requester), the plans
/// it makes for the flood are taken on by neither the processor nor the echo (they take on
/// only the missions asked for: no plan refused at `--max-missions`, no mission let go), the
/// run ends with the closed loop's outputs and exit 0 (the echo joining once the flood ended,
/// the planner then holding the flood's plans), and the planner's, the processor's and the
/// echo's memory stays bounded.
#[test]
fn a_peer_flooding_the_planner_with_plan_requests_leaves_the_run_exact() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut l = Launch::start(
        d,
        H,
        &[
            "--external",
            "planner",
            "--external",
            "echo",
            "--external",
            "processor",
        ],
    );
    let net = l.event("network", Duration::from_secs(60));
    let hub = hub_of(&net);
    // the processor is up all along (by hand, so that its memory can be read at the end of
    // the flood); no echo yet: the mission waits while the flood goes on, and the launcher,
    // the hub of the mesh, with it
    let mut pa = echo_args(&net);
    pa[0] = "process".to_string();
    let mut processor = Service::start("processor", d, &pa);
    processor.wait_for_log("processor ready", Duration::from_secs(60));
    let processor_mem = Baseline::take(processor.child.id());
    let args: Vec<String> = [
        "forge",
        "--duration-s",
        &PLAN_FLOOD_S.to_string(),
        "--flood-plan-requests",
        &FLOOD_PLAN_REQUESTS.to_string(),
        "-m",
        "client",
        "-e",
        &hub,
        "--no-multicast-scouting",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let started = Instant::now();
    let mut forger = Service::start_exe_in(
        &[],
        &harness::bin("cellsar-bridge-bench"),
        "forger",
        d,
        &args,
    );
    forger.wait_for_log("READY", Duration::from_secs(60));
    // the planner starts into the flood, as the launcher's children join its network
    let mut pa = vec!["planner".to_string()];
    pa.extend(
        net["children"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string()),
    );
    let mut planner = Service::start("planner", d, &pa);
    planner.wait_for_log("plan service ready", Duration::from_secs(60));
    let before = Baseline::take(planner.child.id());
    let planner_up = Instant::now();
    let planned = l.event("planned", Duration::from_secs(PLAN_FLOOD_S + 120));
    let planned_s = planner_up.elapsed().as_secs_f64();
    eprintln!("planned {planned_s:.1} s after the planner was up, in the flood: {planned}");
    let r = forger_report(&mut forger, PLAN_FLOOD_S);
    let q = &r["flood"]["plan_requests"];
    // the flood kept the planner's queue full, and the planner worked through some of it
    assert!(q["busy"].as_u64().unwrap() > 0, "{r}");
    let flood_planned = q["planned"].as_u64().unwrap();
    assert!(flood_planned > 0, "{r}");
    // served in turn: the launcher's request waited for the flood's plan in progress and the one
    // queued before it (each a few seconds), not for the flood to end: it is planned while the
    // flood still runs (a fraction of the flood's length would be a time, not an order)
    assert!(
        planned_s < PLAN_FLOOD_S as f64,
        "planned {planned_s:.1} s after the planner was up, in a {PLAN_FLOOD_S} s flood"
    );
    before.assert_peak_within(
        PLAN_FLOOD_BOUND,
        "the planner under a flood of plan requests",
    );
    processor_mem.assert_peak_within(
        PLAN_FLOOD_BOUND,
        "the processor while the planner published the flood's plans",
    );
    // the echo joins now, the planner holding the flood's plans
    let mut echo = Service::start("echo", d, &echo_args(&net));
    echo.wait_for_log("echo ready", Duration::from_secs(60));
    let echo_mem = Baseline::take(echo.child.id());
    let st = l.finish(Duration::from_secs(300));
    echo_mem.assert_peak_within(
        PLAN_FLOOD_BOUND,
        "the echo joining a planner that holds the flood's plans",
    );
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    for s in [&mut echo, &mut processor, &mut planner] {
        assert!(
            s.stop(Duration::from_secs(20)).success(),
            "{}",
            s.log_text()
        );
    }
    remove_echo_segments(&net);
    // the flood's plans were published (the forger got them) but taken on by nobody else
    let (p, e, pl) = (processor.log_text(), echo.log_text(), planner.log_text());
    for (who, log, marker) in [
        ("processor", &p, "processor stopping"),
        ("echo", &e, "echo stopping"),
    ] {
        for key in ["plans_refused", "evicted"] {
            assert_eq!(counter(log, marker, key), Some(0), "{who} {key}:\n{log}");
        }
        let taken = log.lines().filter(|l| l.contains("plan received")).count();
        assert_eq!(taken, 1, "{who} took on only the run's mission:\n{log}");
    }
    let busy = counter(&pl, "plan service stopping", "busy").unwrap();
    let plans = counter(&pl, "plan service stopping", "plans").unwrap();
    assert!(
        busy > 0 && plans > flood_planned,
        "busy {busy}, plans {plans}:\n{pl}"
    );
    // the launcher's request held a place of its own in the planner's queue: never refused as
    // busy, so never asked again
    let retries = l.named("plan_retry");
    assert!(
        retries.is_empty(),
        "the launcher was answered busy {} times: {retries:?}",
        retries.len()
    );
    eprintln!("planner: {plans} plans, {busy} requests refused as busy");
    let end = l.seen.last().cloned().unwrap_or_default();
    eprintln!("the run ended at {} s: {end}", end["t_s"]);
    eprintln!(
        "plan-request flood suite: {:.1} s",
        started.elapsed().as_secs_f64()
    );
}

/// Seconds [`a_planner_busy_for_seconds_is_asked_until_it_plans`]'s planner answers busy.
const BUSY_S: f64 = 6.0;

/// A planner that answers every request as busy for [`BUSY_S`] (far longer than the 1 s
/// that the launcher's `--max-restarts 1` allowed a busy planner, asked 500 ms apart, when
/// busy answers counted as failures): the launcher asks again after bounded, jittered pauses
/// until it plans, then the run ends with the closed loop's outputs and exit 0. The request
/// names the launcher (`?requester=`), which is what the planner serves requesters in turn by.
#[test]
fn a_planner_busy_for_seconds_is_asked_until_it_plans() {
    use bridge::net::SubscribeOptions;
    use bridge::{Refusal, RefusalKind};
    use pipeline::protocol::{keys, PlanRequest};
    use pipeline::services::plan::{plan_request, PlanCache, REQUESTER_PARAMETER};

    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut l = Launch::start(d, H, &["--external", "planner", "--max-restarts", "1"]);
    let net = l.event("network", Duration::from_secs(60));
    let z = bridge::ZenohArgs::isolated(&[], &[hub_of(&net)]);
    let node = bridge::ZenohNode::open(z.to_config().unwrap(), "planner", "busy").unwrap();
    // the plan is looked up here by the processor and the echo, as a planner's would be
    let cache = PlanCache::new(&node, None).unwrap();
    let requests = node
        .queryable::<PlanRequest>(keys::PLAN, SubscribeOptions::default())
        .unwrap();
    let started = Instant::now();
    let mut busy = 0;
    let mut requester = None;
    loop {
        assert!(started.elapsed() < Duration::from_secs(120), "no request");
        let Some(q) = requests.recv_timeout(Duration::from_millis(200)) else {
            continue;
        };
        requester = requester.or(q.parameter(REQUESTER_PARAMETER).map(str::to_string));
        if started.elapsed().as_secs_f64() < BUSY_S {
            q.refuse(&Refusal::new(
                RefusalKind::Busy,
                "server busy: request queue full",
            ))
            .unwrap();
            busy += 1;
            continue;
        }
        let plan = plan_request(&q.request, "busy", &mut planner::NoObserver).unwrap();
        let meta = bridge::Meta {
            mission_id: plan.mission_id,
            ..bridge::Meta::default()
        };
        cache.insert(std::sync::Arc::new(plan.clone())).unwrap();
        q.reply(&plan, meta).unwrap();
        break;
    }
    let st = l.finish(Duration::from_secs(300));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    let requester = requester.expect("the request names no requester");
    assert!(
        !requester.is_empty() && requester.chars().all(|c| c.is_ascii_hexdigit()),
        "a Zenoh session id: {requester}"
    );
    // one retry event per busy answer, paused 50 ms to 1.6 s (plus the run's loop) apart, and
    // not all alike
    let retries = l.named("plan_retry");
    assert_eq!(retries.len(), busy, "{retries:?}");
    assert!(busy >= 6, "{busy} busy answers in {BUSY_S} s");
    let t: Vec<f64> = retries.iter().map(|e| e["t_s"].as_f64().unwrap()).collect();
    let gaps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(
        gaps.iter().all(|g| (0.04..2.0).contains(g)),
        "pauses {gaps:?}"
    );
    let longest = gaps.iter().cloned().fold(0.0, f64::max);
    assert!(
        longest >= 0.5 && gaps.windows(2).any(|w| (w[0] - w[1]).abs() > 0.01),
        "pauses {gaps:?}"
    );
    eprintln!("{busy} busy answers; pauses {gaps:.2?}");
    node.close().unwrap();
}
