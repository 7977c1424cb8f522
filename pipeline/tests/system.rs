//! The launcher end to end: the same outputs as `closed-loop` over iceoryx2 and over Zenoh
//! through the bridge, clean stops, named errors, a child that keeps failing.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::process::Command;
use std::time::Duration;

use common::*;

const H: f64 = 30.0;

#[test]
fn run_over_iceoryx2_matches_closed_loop() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &[]);
    let planned = l.event("planned", Duration::from_secs(60));
    assert_eq!(planned["apertures"], 3);
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    // liveliness of every role was seen, every child stopped cleanly at the end
    for role in ["planner", "echo", "processor"] {
        assert!(
            l.named("alive")
                .iter()
                .any(|e| e["role"] == role && e["alive"] == true),
            "{role} never announced itself"
        );
        let stopped: Vec<_> = l.named("child_stopped");
        assert!(
            stopped
                .iter()
                .any(|e| e["role"] == role && e["status"] == "exit code 0"),
            "{role} did not stop cleanly: {stopped:?}"
        );
        assert!(
            l.log(role).contains("final_counters=true"),
            "{role} logged no final counters"
        );
    }
    let p = l.pipeline_json();
    assert_eq!(p["apertures"], 3);
    assert_eq!(p["collector"]["duplicates"], 0);
    assert!(p["wall_s"].as_f64().unwrap() > 0.0);
    assert!(std::fs::read_to_string(l.out.join("report.md"))
        .unwrap()
        .contains("every landmark in view detected: yes"));
    // the per-window resolution cell of the plan is reported beside each detection
    let md = std::fs::read_to_string(l.out.join("report.md")).unwrap();
    assert!(md.contains("| cell/m |"), "{md}");
    for ap in 0..3 {
        let row = md
            .lines()
            .find(|r| r.starts_with(&format!("| {ap} | ")))
            .unwrap_or_else(|| panic!("no row for aperture {ap}:\n{md}"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!(cells.len(), 8, "{row}");
        let width: f64 = cells[6].split(' ').next().unwrap().parse().unwrap();
        assert!(width > 0.0 && width.is_finite(), "{row}");
    }
    // the state directory is removed after a complete run
    assert!(!l.out.join(".state").exists());
}

#[test]
fn run_over_zenoh_through_the_bridge_matches_closed_loop() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["--transport", "zenoh"]);
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    assert!(l
        .named("child_started")
        .iter()
        .any(|e| e["role"] == "bridge"));
    let bridge = l.log("bridge");
    let forwarded = counter(&bridge, "route counters", "out_forwarded").unwrap();
    // 3 apertures of 10 frames, plus the look asked for again for the resolution
    assert!(
        forwarded >= 30,
        "bridge forwarded {forwarded} frames\n{bridge}"
    );
    let proc = l.log("processor");
    assert_eq!(
        counter(&proc, "processor stopping", "bad"),
        Some(0),
        "{proc}"
    );
}

#[test]
fn sigint_stops_every_child() {
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), 200.0, &[]);
    l.event("planned", Duration::from_secs(120));
    let pids: Vec<u32> = ["planner", "echo", "processor"]
        .iter()
        .map(|r| l.pid(r))
        .collect();
    signal(l.child.id(), "INT");
    let st = l.finish(Duration::from_secs(60));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    for p in pids {
        assert!(
            !running(p),
            "child {p} still running after the launcher stopped"
        );
    }
    for role in ["planner", "echo", "processor"] {
        assert!(
            l.log(role).contains("final_counters=true"),
            "{role}: {}",
            l.log(role)
        );
    }
    // what had arrived is written; the state is kept for a later run
    assert!(l.out.join("detections.csv").exists());
    assert!(l.out.join(".state").exists());
}

#[test]
fn a_child_that_keeps_failing_stops_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("missing-iceoryx2.toml");
    let mut l = Launch::start(
        dir.path(),
        H,
        &["--max-restarts", "2", "--iox-config", bad.to_str().unwrap()],
    );
    let st = l.finish(Duration::from_secs(120));
    assert_eq!(st.code(), Some(1));
    let err = l.stderr_tail();
    assert!(
        err.contains("failed 3 times") && err.contains("giving up"),
        "{err}"
    );
    let exits = l.named("child_exited");
    assert!(exits.len() >= 3, "{exits:?}");
    for e in l.named("child_started") {
        assert!(!running(e["pid"].as_u64().unwrap() as u32));
    }
    assert!(l.log("echo").contains("missing-iceoryx2.toml"));
}

#[test]
fn bad_inputs_are_named_before_anything_starts() {
    let dir = tempfile::tempdir().unwrap();
    let bad_scene = dir.path().join("bad.toml");
    std::fs::write(&bad_scene, "[radar]\nprf_hz = -5\n").unwrap();
    let o = Command::new(exe())
        .args(["run"])
        .arg(mission())
        .arg("--scene")
        .arg(&bad_scene)
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("radar.prf_hz"), "{e}");
    assert!(!dir.path().join("out/logs").exists());

    let o = Command::new(exe())
        .args(["run", "/nonexistent/mission.toml", "--scene"])
        .arg(scene())
        .arg("--out")
        .arg(dir.path().join("out2"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(e.contains("/nonexistent/mission.toml"), "{e}");

    let o = Command::new(exe())
        .args(["run"])
        .arg(mission())
        .arg("--scene")
        .arg(scene())
        .arg("--out")
        .arg(dir.path().join("out3"))
        .args(["--horizon-s", "5"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("horizon"), "{e}");

    let o = Command::new(exe())
        .args(["router", "--instance", "r"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("-l ENDPOINT"), "{e}");
}
