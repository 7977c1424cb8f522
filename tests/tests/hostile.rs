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

#[test]
fn a_hostile_peer_of_every_kind_leaves_the_run_exact_and_bounded() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // no echo yet: the mission waits while the forger works
    let mut l = Launch::start(d, H, &["--external", "echo"]);
    let net = l.event("network", Duration::from_secs(60));
    let listen: Vec<String> = serde_json::from_value(net["launcher"].clone()).unwrap();
    let hub = listen
        .iter()
        .find(|a| a.starts_with("unixsock-stream/"))
        .unwrap_or_else(|| panic!("the launcher listens on no Unix socket: {listen:?}"))
        .clone();
    l.event("planned", Duration::from_secs(120));
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
    let deadline = started + Duration::from_secs(FORGE_S + 120);
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
    let st = l.finish(Duration::from_secs(300));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    assert!(echo.stop(Duration::from_secs(20)).success());
    // the echo, started by hand, outlived the launcher's clean-up of the run's segments
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
    let p = l.pipeline_json();
    eprintln!("collector: {}", p["collector"]);
    eprintln!("hostile suite: {:.1} s", started.elapsed().as_secs_f64());
}
