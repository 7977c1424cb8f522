//! A hostile peer on the launcher's own mesh (loopback, no authentication): it forges a
//! processor status `{role: "processor", state: "failed"}`, detections of every aperture
//! under an instance name of its own, and an image of aperture 0 whose pixel count is not
//! `nx × ny`, before and during a normal run; it also answers the launcher's plan request at
//! once with a plan of another mission, and publishes that plan under a mission id its content
//! does not give. A malformed image is counted and skipped, never fatal, and the aperture's
//! real image still counts; the forged plan reply is skipped and the planner's taken; the echo
//! and the processor skip the published plan whose id they recompute. The launcher accepts
//! statuses and detections only from the instances that announced themselves in their role
//! (liveliness), so the run neither aborts nor takes a forged result: it completes with the
//! closed loop's detections, and the forgeries are counted as foreign.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Duration;

use harness::pipeline::*;

#[test]
fn forged_status_and_results_neither_abort_a_run_nor_displace_real_results() {
    const H: f64 = 30.0;
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let hub = format!("tcp/127.0.0.1:{}", harness::free_port());
    // the forger listens first and the launcher connects to it, so that the forger is on the
    // mesh before the run plans (a run of this length is over in about 2 s)
    let forger = Service::start_exe_in(
        &[],
        &harness::bin("cellsar-bridge-bench"),
        "forger",
        d,
        &[
            "forge".into(),
            "--duration-s".into(),
            "600".into(),
            "--interval-ms".into(),
            "5".into(),
            "--malformed-images".into(),
            "--forge-plans".into(),
            "-m".into(),
            "peer".into(),
            "-l".into(),
            hub.clone(),
            "--no-multicast-scouting".into(),
        ],
    );
    forger.wait_for_log("READY", Duration::from_secs(60));
    let mut l = Launch::start(d, H, &["-e", &hub, "--no-multicast-scouting"]);
    let st = l.finish(Duration::from_secs(240));
    assert!(
        st.success(),
        "{st:?}\n{}\nforger:\n{}",
        l.stderr_tail(),
        forger.log_text()
    );
    assert_same_as_reference(&l.out, &reference);
    assert!(
        forger.log_text().contains("forging for mission"),
        "{}",
        forger.log_text()
    );
    let p = l.pipeline_json();
    // forged detections arrived and were skipped; so were the forged statuses
    assert!(
        p["collector"]["foreign"].as_u64().unwrap() > 0,
        "{}",
        p["collector"]
    );
    assert!(
        p["collector"]["refused_senders"].as_u64().unwrap()
            > p["collector"]["foreign"].as_u64().unwrap(),
        "{}",
        p["collector"]
    );
    let log = std::fs::read_to_string(d.join("launcher.err")).unwrap();
    assert!(
        log.contains("foreign status skipped"),
        "{}\n{log}",
        p["collector"]
    );
    assert!(log.contains("foreign detections skipped"), "{log}");
    // the malformed images too: counted and logged, the run went on
    assert!(
        p["collector"]["malformed"].as_u64().unwrap() > 0,
        "{}",
        p["collector"]
    );
    assert!(log.contains("malformed image skipped"), "{log}");
    // the forged plan reply was skipped (the run planned the mission it asked for: the
    // reference detections above)
    assert!(
        forger
            .log_text()
            .contains("answered a plan request with a forged plan"),
        "{}",
        forger.log_text()
    );
    assert!(
        p["collector"]["refused_plans"].as_u64().unwrap() >= 1,
        "{}",
        p["collector"]
    );
    assert!(
        log.contains("a plan reply that does not answer the request skipped"),
        "{log}"
    );
    for role in ["echo", "processor"] {
        let child = l.log(role);
        assert!(
            child.contains("plan skipped: its mission id is not its content's"),
            "{role}:\n{child}"
        );
    }
    assert!(!log.contains("gave up the mission"), "{log}");
}
