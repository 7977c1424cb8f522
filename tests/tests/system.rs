//! The launcher end to end: the same outputs as `closed-loop` over iceoryx2 and over Zenoh
//! through the bridge, clean stops, named errors and their exit codes, a child that keeps
//! failing, the plan timeout.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::ffi::OsString;
use std::process::Command;
use std::time::Duration;

use harness::pipeline::*;

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
    // the per-window resolution cell of the plan (the default best effort) is reported beside
    // each detection, and beside it the least-energy plan's
    let md = std::fs::read_to_string(l.out.join("report.md")).unwrap();
    assert!(
        md.contains("| cell/m | least-energy plan's cell/m |"),
        "{md}"
    );
    for ap in 0..3 {
        let row = md
            .lines()
            .find(|r| r.starts_with(&format!("| {ap} | ")))
            .unwrap_or_else(|| panic!("no row for aperture {ap}:\n{md}"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!(cells.len(), 9, "{row}");
        for k in [6, 7] {
            let width: f64 = cells[k].split(' ').next().unwrap().parse().unwrap();
            assert!(width > 0.0 && width.is_finite(), "{row}");
        }
    }
    // the state directory is removed after a complete run
    assert!(!l.out.join(".state").exists());
    // the run's iceoryx2 prefix: the launcher's pid and a random part; nothing of it is left
    let iox: Vec<String> = serde_json::from_value(l.named("network")[0]["iox"].clone()).unwrap();
    let prefix = &iox[iox.iter().position(|a| a == "--iox-prefix").unwrap() + 1];
    let random = prefix
        .strip_prefix(&format!("cs{}x", l.child.id()))
        .and_then(|r| r.strip_suffix('_'))
        .unwrap_or_else(|| panic!("{prefix}"));
    assert!(
        random.len() == 8 && random.bytes().all(|b| b.is_ascii_hexdigit()),
        "{prefix}"
    );
    assert!(shm_files(prefix).is_empty());
}

/// A scene with ground clutter: the echo synthesises each aperture's patch of ground as
/// `closed-loop` does (the images would differ if it left the clutter out).
#[test]
fn run_with_ground_clutter_matches_closed_loop() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("clutter-scene.toml");
    let mut text = std::fs::read_to_string(harness::pipeline::scene()).unwrap();
    text.push_str(
        "\n[clutter]\nenabled = true\nterrain = \"farmland\"\nscatterers_per_cell = 4.0\n",
    );
    std::fs::write(&scene, text).unwrap();
    let m = planner::Mission::from_path(&mission()).unwrap();
    let m = radar_sim::run::shorten(&m, H).unwrap();
    let reference = dir.path().join("closed-loop");
    closed_loop(&m, &scene, &reference);
    // the clutter is in the reference: its images are not those of the scene without it
    let plain = harness::pipeline::reference(H);
    let name = "processed/images/aperture_000.npy";
    assert_ne!(
        std::fs::read(reference.join(name)).unwrap(),
        std::fs::read(plain.join(name)).unwrap(),
        "{name}: the clutter changed nothing"
    );
    let mut l = Launch::start_files_in(&[], &mission(), &scene, dir.path(), H, &[]);
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
}

/// A free-altitude mission: the planner service plans an altitude per slot, the echo and the
/// processor fly it, and the run ends with the outputs of `cellsar-radar-sim closed-loop`
/// (which flies the profile), the plan's varying `z_m` included.
#[test]
fn a_free_altitude_mission_runs_at_its_planned_altitudes() {
    let dir = tempfile::tempdir().unwrap();
    let mission = harness::root().join("missions/default-30m-free-altitude.toml");
    let reference = dir.path().join("closed-loop");
    let st = Command::new(harness::bin("cellsar-radar-sim"))
        .arg("closed-loop")
        .arg(&mission)
        .arg("--scene")
        .arg(scene())
        .arg("--out")
        .arg(&reference)
        .args(["--horizon-s", &H.to_string()])
        .status()
        .unwrap();
    assert!(st.success(), "closed-loop: {st:?}");
    // the plan flies more than one altitude
    let csv = std::fs::read_to_string(reference.join("plan/trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "z_m").unwrap();
    let z: Vec<f64> = lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect();
    let (lo, hi) = z
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    // (the first 30 s climb by 0.8 m: a profile, not one altitude, is what the run must fly)
    assert!(hi - lo > 0.5, "z_m from {lo} to {hi} m");
    let mut l = Launch::start_files_in(&[], &mission, &scene(), dir.path(), H, &[]);
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
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

/// A user-given listen endpoint with multicast scouting off: the children connect to the
/// launcher's endpoint (they were started with no endpoint at all and never met it) and the run
/// ends with the same outputs as `closed-loop`.
#[test]
fn listen_endpoint_without_scouting_forms_the_mesh() {
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let ep = format!("tcp/127.0.0.1:{}", free_port());
    let mut l = Launch::start(dir.path(), H, &["-l", &ep, "--no-multicast-scouting"]);
    let net = l.event("network", Duration::from_secs(60));
    let children: Vec<String> = serde_json::from_value(net["children"].clone()).unwrap();
    assert!(
        children
            .windows(2)
            .any(|w| w[0] == "--connect" && w[1] == ep),
        "{children:?}"
    );
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
}

/// Listen flags the children could not be pointed at are refused before anything starts.
#[test]
fn listen_endpoints_children_cannot_reach_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (flags, named) in [
        (vec!["-l", "tcp/127.0.0.1:0"], "port 0"),
        (
            vec![
                "-m",
                "client",
                "-e",
                "tcp/127.0.0.1:9",
                "-l",
                "tcp/127.0.0.1:7447",
            ],
            "-m client",
        ),
    ] {
        let o = Command::new(exe())
            .args(run_args(dir.path(), "out", &flags))
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {e}");
        assert!(
            e.contains("--listen") && e.contains(named),
            "{flags:?}: {e}"
        );
    }
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
    signal(l.child.id(), Signal::SIGINT);
    let st = l.finish(Duration::from_secs(60));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    // the event log says so, once, before the children are stopped
    let interrupted = l.named("interrupted");
    assert_eq!(interrupted.len(), 1, "{interrupted:?}");
    let at = |name: &str| l.seen.iter().position(|e| e["event"] == name);
    assert!(
        at("interrupted") < at("child_stopped"),
        "{:?}",
        l.seen
            .iter()
            .filter(|e| e["event"] != "status")
            .collect::<Vec<_>>()
    );
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

/// SIGINT while the launcher still tries to open its Zenoh session (here its `-l` endpoint is
/// taken, so the open is retried) ends the run as interrupted too: exit 130, an "interrupted"
/// event, the same clean-up as any other run (nothing left in /dev/shm).
#[test]
fn sigint_while_the_zenoh_session_opens_is_an_interrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let ep = format!("tcp/127.0.0.1:{}", taken.local_addr().unwrap().port());
    let mut l = Launch::start(dir.path(), H, &["-l", &ep, "--no-multicast-scouting"]);
    l.event("network", Duration::from_secs(60));
    std::thread::sleep(Duration::from_millis(500));
    signal(l.child.id(), Signal::SIGINT);
    let st = l.finish(Duration::from_secs(60));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    assert!(
        l.stderr_tail().contains("interrupted"),
        "{}",
        l.stderr_tail()
    );
    assert_eq!(l.named("interrupted").len(), 1, "{:?}", l.seen);
    assert!(l.named("child_started").is_empty(), "{:?}", l.seen);
    assert!(shm_files(&format!("cs{}x", l.child.id())).is_empty());
    drop(taken);
}

#[test]
fn a_child_that_keeps_failing_stops_the_run() {
    let dir = tempfile::tempdir().unwrap();
    // the planner cannot create its state directory (a file is in the way): it fails at
    // start, every time (the inputs themselves are fine, so the launcher starts it)
    let blocker = dir.path().join("out/.state/planner");
    std::fs::create_dir_all(blocker.parent().unwrap()).unwrap();
    std::fs::write(&blocker, "not a directory").unwrap();
    let mut l = Launch::start(dir.path(), H, &["--max-restarts", "2"]);
    let st = l.finish(Duration::from_secs(120));
    assert_eq!(st.code(), Some(1));
    // the whole stderr, not its tail: the message is what counts, wherever it is
    let err = l.stderr_text();
    assert!(
        err.contains("failed 3 times") && err.contains("giving up"),
        "{err}"
    );
    let exits = l.named("child_exited");
    assert!(exits.len() >= 3, "{exits:?}");
    for e in l.named("child_started") {
        assert!(!running(e["pid"].as_u64().unwrap() as u32));
    }
    assert!(
        l.log("planner").contains(".state/planner"),
        "{}",
        l.log("planner")
    );
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
    assert_eq!(o.status.code(), Some(2), "bad input");
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
    assert_eq!(o.status.code(), Some(2), "bad input");
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

/// Every option a child would refuse, and the Zenoh and iceoryx2 flags, are checked before
/// anything starts: exit code 2 (bad input), one line naming the option, no panic, no output
/// directory, nothing left in /dev/shm.
#[test]
fn bad_options_exit_2_before_anything_starts() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing-iceoryx2.toml");
    let missing = missing.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--timeout-s", "nan"], "--timeout-s"),
        (vec!["--timeout-s=-1"], "--timeout-s"),
        (vec!["--plan-timeout-s", "inf"], "--plan-timeout-s"),
        (vec!["--resend-after-s", "0"], "--resend-after-s"),
        (vec!["--window", "0"], "--window"),
        (vec!["--max-frame-bytes", "100"], "--max-frame-bytes"),
        (vec!["--max-frame-bytes", "0"], "--max-frame-bytes"),
        (vec!["--child-log", "=["], "--child-log"),
        (vec!["--iox-config", missing], "--iox-config"),
        (vec!["-e", "garbage"], "--connect garbage"),
        (vec!["-l", "garbage"], "--listen garbage"),
    ];
    for (i, (extra, needle)) in cases.iter().enumerate() {
        let out = format!("out{i}");
        let e = cellsar_bounded(
            &run_args(dir.path(), &out, extra),
            dir.path(),
            Duration::from_secs(60),
            |_| {},
        );
        assert_eq!(e.code, Some(2), "{extra:?}: {}", e.stderr);
        assert!(e.stderr.contains(needle), "{extra:?}: {}", e.stderr);
        for noise in ["panicked", "backtrace", ".rs:", "Message {", ".cargo"] {
            assert!(
                !e.stderr.contains(noise),
                "{extra:?}: {noise:?} in {}",
                e.stderr
            );
        }
        assert_eq!(
            e.stderr.lines().filter(|l| l.contains(needle)).count(),
            1,
            "{extra:?}: printed once: {}",
            e.stderr
        );
        assert!(
            !dir.path().join(&out).exists(),
            "{extra:?}: something started"
        );
        let left = shm_files(&format!("cs{}x", e.pid));
        assert!(left.is_empty(), "{extra:?}: left in /dev/shm: {left:?}");
    }
}

/// A mission that cannot be flown exits with code 3, naming the slot, before anything starts.
#[test]
fn an_infeasible_mission_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("far.toml");
    std::fs::write(
        &m,
        "name = \"unreachable\"\n[params]\nhorizon_s = 20\nstart_m = [-1000.0, 0.0]\n\
         [landmarks]\npoints = [{ x_m = 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }, \
         { x_m = 50000.0, y_m = 0.0, from_s = 10.0, to_s = 20.0 }]\n",
    )
    .unwrap();
    let args: Vec<OsString> = vec![
        "run".into(),
        m.into(),
        "--scene".into(),
        scene().into(),
        "--out".into(),
        dir.path().join("out").into(),
    ];
    let e = cellsar_bounded(&args, dir.path(), Duration::from_secs(60), |_| {});
    assert_eq!(e.code, Some(3), "{}", e.stderr);
    assert!(
        e.stderr.contains("cannot be flown") && e.stderr.contains("slot"),
        "{}",
        e.stderr
    );
    assert!(!dir.path().join("out").exists());
}

/// `--plan-timeout-s` also bounds the wait for a planner that never appears (here an
/// `--external` one that is not running): exit 1 naming the option, soon after the timeout.
#[test]
fn plan_timeout_covers_waiting_for_the_planner() {
    let dir = tempfile::tempdir().unwrap();
    let e = cellsar_bounded(
        &run_args(
            dir.path(),
            "out",
            &["--external", "planner", "--plan-timeout-s", "2"],
        ),
        dir.path(),
        Duration::from_secs(60),
        |_| {},
    );
    assert_eq!(e.code, Some(1), "{}", e.stderr);
    assert!(e.stderr.contains("--plan-timeout-s 2"), "{}", e.stderr);
    assert!(e.elapsed < Duration::from_secs(30), "took {:?}", e.elapsed);
    assert!(shm_files(&format!("cs{}x", e.pid)).is_empty());
}

/// SIGINT while the launcher waits for a planner exits 130, like SIGINT while imaging.
#[test]
fn sigint_while_waiting_for_the_planner_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    let logs = dir.path().join("out/logs");
    let e = cellsar_bounded(
        &run_args(
            dir.path(),
            "out",
            &["--external", "planner", "--plan-timeout-s", "600"],
        ),
        dir.path(),
        Duration::from_secs(90),
        move |pid| {
            std::thread::spawn(move || {
                // once the children run (the launcher is then waiting for the planner)
                let deadline = std::time::Instant::now() + Duration::from_secs(60);
                while !logs.join("processor.log").exists() && std::time::Instant::now() < deadline {
                    std::thread::sleep(Duration::from_millis(50));
                }
                std::thread::sleep(Duration::from_millis(500));
                signal(pid, Signal::SIGINT);
            });
        },
    );
    assert_eq!(e.code, Some(130), "{}", e.stderr);
    assert!(e.stderr.contains("interrupted"), "{}", e.stderr);
    assert!(shm_files(&format!("cs{}x", e.pid)).is_empty());
}

/// `--resolution` and `--strict-resolution` reach the planner: under the strict general cell
/// the planner finds no plan of the default mission from its start (docs/user-guide.md,
/// "Refusals and plans not found"), so the run exits 5 naming the resolution (the planner's
/// `not_found` refusal); with the default best effort the same mission is planned (every other
/// test here).
#[test]
fn resolution_general_reaches_the_planner() {
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<OsString> = vec![
        "run".into(),
        mission().into(),
        "--scene".into(),
        scene().into(),
        "--out".into(),
        dir.path().join("out").into(),
        "--horizon-s".into(),
        "30".into(),
        "--strict-resolution".into(),
        "--resolution".into(),
        "general".into(),
    ];
    let e = cellsar_bounded(&args, dir.path(), Duration::from_secs(120), |_| {});
    assert_eq!(e.code, Some(5), "{}", e.stderr);
    assert!(e.stderr.contains("resolution"), "{}", e.stderr);
    assert!(e.stderr.contains("not proven impossible"), "{}", e.stderr);
    // an unknown mode is bad input, named, before anything starts
    let mut bad = args.clone();
    if let Some(last) = bad.last_mut() {
        *last = "fine".into();
    }
    let e = cellsar_bounded(&bad, dir.path(), Duration::from_secs(30), |_| {});
    assert_eq!(e.code, Some(2), "{}", e.stderr);
    assert!(e.stderr.contains("--resolution"), "{}", e.stderr);
    // so is --strict-resolution with the paper's resolution, which would ignore it
    let mut paper = args.clone();
    if let Some(last) = paper.last_mut() {
        *last = "paper".into();
    }
    let e = cellsar_bounded(&paper, dir.path(), Duration::from_secs(30), |_| {});
    assert_eq!(e.code, Some(2), "{}", e.stderr);
    assert!(
        e.stderr
            .contains("--strict-resolution applies to --resolution general only"),
        "{}",
        e.stderr
    );
}

/// A best-effort run (`--resolution general` without `--strict-resolution`) plans, images and
/// says in report.md what resolution it reached: the unresolved windows and slots and the
/// first slot of its plan and of the least-energy plan, and the extra energy, as in
/// plan/summary.json.
#[test]
fn a_best_effort_run_reports_the_resolution_it_reached() {
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["--resolution", "general"]);
    let st = l.finish(Duration::from_secs(300));
    assert_eq!(st.code(), Some(0), "{}", l.stderr_tail());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(l.out.join("plan/summary.json")).unwrap())
            .unwrap();
    let r = &summary["resolution_shortfall"];
    let b = &summary["best_effort"];
    let least = &b["least_energy_shortfall"];
    let first = match r["first_unresolved_slot"].as_u64() {
        Some(k) => format!("slot {k}"),
        None => "none".to_string(),
    };
    let windows = r["windows"].as_array().unwrap().len();
    let expected = format!(
        "- resolution: general, best effort: {} of {windows} windows with a cell wider than \
         d_min (the least-energy plan: {}), {} unresolved slots (the least-energy plan: {}; \
         the first: {first}), for {:.0} J more energy than the least-energy plan's {:.0} J",
        r["unresolved_windows"],
        least["unresolved_windows"],
        r["unresolved_slots"],
        least["unresolved_slots"],
        summary["energy_j"].as_f64().unwrap() - b["least_energy_j"].as_f64().unwrap(),
        b["least_energy_j"].as_f64().unwrap(),
    );
    let report = std::fs::read_to_string(l.out.join("report.md")).unwrap();
    assert!(report.contains(&expected), "{expected}\nnot in\n{report}");
    // the best effort resolves more than the least-energy plan on this mission
    assert!(
        r["unresolved_slots"].as_u64().unwrap() < least["unresolved_slots"].as_u64().unwrap(),
        "{summary}"
    );
    // the report's table puts the least-energy plan's cell beside the plan's
    assert!(report.contains("least-energy plan's cell/m"), "{report}");
}
