//! A hostile peer on the launcher's own mesh (loopback, no authentication): it forges a
//! processor status `{role: "processor", state: "failed"}`, detections of every aperture,
//! well-formed images of every aperture and the mission's metrics with another `pd` (agreeing
//! with the real detections: the closed loop's, the same mission's), all under an instance name
//! of its own, and an image of aperture 0 whose pixel count is not `nx × ny` under the live
//! processor's instance, before and during a normal run; it also answers the launcher's plan
//! request at once with a plan of another mission, and publishes that plan under a mission id
//! its content does not give. A malformed image is counted and skipped, never fatal, and the
//! aperture's real image still counts; the forged plan reply is skipped and the planner's taken;
//! the echo and the processor skip the published plan whose id they recompute. The launcher
//! accepts statuses, detections, images and metrics only from the instances that announced
//! themselves in their role (liveliness), so the run neither aborts nor takes a forged result:
//! it completes with the closed loop's detections, images and metrics, and the forgeries are
//! counted as foreign. The same holds when the forger announces itself alive as another role
//! (the echo) under the instance name its forgeries claim. A forger that answers the lookups
//! of the run's plan with a changed plan under the run's id is skipped by the echo and the
//! processor. The file has its own runner (`harness = false`): the test that starts a process
//! as another user shows as ignored where the machine lacks root or `setpriv`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::Duration;

use harness::pipeline::*;

const H: f64 = 30.0;

/// Starts a forger in `d` (forging every 5 ms for up to 600 s, with `extra` flags) listening
/// on a loopback endpoint, and a run of [`H`] s that connects to it; returns both once the
/// run ended, after checking that it succeeded with the reference outputs, and the launcher's
/// log.
fn run_against_forger(d: &std::path::Path, extra: &[&str]) -> (Service, Launch, String) {
    let reference = reference(H);
    let hub = format!("tcp/127.0.0.1:{}", harness::free_port());
    let template = reference.join("processed/metrics.json");
    let mut args: Vec<String> = [
        "forge",
        "--duration-s",
        "600",
        "--interval-ms",
        "5",
        "--forge-results",
        "--metrics-template",
        &template.display().to_string(),
        "-m",
        "peer",
        "-l",
        &hub,
        "--no-multicast-scouting",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.extend(extra.iter().map(|s| s.to_string()));
    // the forger listens first and the launcher connects to it, so that the forger is on the
    // mesh before the run plans (a run of this length is over in about 2 s)
    let forger = Service::start_exe_in(
        &[],
        &harness::bin("cellsar-bridge-bench"),
        "forger",
        d,
        &args,
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
    // neither the forged images nor the forged metrics displaced the real ones
    assert_same_as_reference(&l.out, &reference);
    let log = std::fs::read_to_string(d.join("launcher.err")).unwrap();
    let p = l.pipeline_json();
    let refused = &p["collector"]["refused_by_kind"];
    for kind in ["status", "detections", "images", "metrics"] {
        assert!(refused[kind].as_u64().unwrap() > 0, "{kind}: {refused}");
    }
    for kind in ["image", "metrics"] {
        assert!(
            log.contains(&format!("foreign {kind} skipped")),
            "{kind}:\n{log}"
        );
    }
    (forger, l, log)
}

fn forged_status_and_results_neither_abort_a_run_nor_displace_real_results() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (forger, l, log) = run_against_forger(d, &["--malformed-images", "--forge-plans"]);
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
    // its plan under a wrong id was published, and taken on by nobody (the echo and the
    // processor take on only the missions asked for)
    for role in ["echo", "processor"] {
        let child = l.log(role);
        assert!(
            !child.contains("mission=5eed5eed5eed5eed"),
            "{role}:\n{child}"
        );
    }
    assert!(!log.contains("gave up the mission"), "{log}");
}

/// A forger alive as the echo, whose forgeries claim its own (echo) instance: its images,
/// metrics, detections and processor statuses are refused as another role's, and the run ends
/// with the reference outputs.
fn forged_images_and_metrics_from_another_role_are_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let (forger, _l, log) = run_against_forger(
        dir.path(),
        &["--announce-as", "echo", "--instance", "intruder-echo"],
    );
    assert!(
        log.contains(r#"from processor "intruder-echo", which never announced itself"#),
        "{log}"
    );
    let report = forger.log_text();
    assert!(report.contains("forging for mission"), "{report}");
}

/// Why [`another_user_cannot_join_the_private_mesh`] cannot run here (`None`: it can): it
/// needs root, to start a process as `nobody`, and `setpriv` to do it.
fn another_user_unavailable() -> Option<String> {
    use std::os::unix::fs::MetadataExt;
    let me = std::fs::metadata("/proc/self").map(|m| m.uid()).ok();
    if me != Some(0) {
        Some(format!("not root (uid {me:?})"))
    } else if !std::path::Path::new(SETPRIV).exists() {
        Some(format!("no {SETPRIV}"))
    } else {
        None
    }
}

/// What starts a process as another user.
const SETPRIV: &str = "/usr/bin/setpriv";

/// The launcher's own mesh (no Zenoh flag) is private to the user who started the run: every
/// process listens only on a Unix socket in a per-run directory of mode 0700, owned by that
/// user. A process of another user (`nobody`, by `setpriv`) cannot connect to any of the
/// sockets (permission denied), while the same forger as this user joins and sees the mission;
/// the directory is removed when the run ends.
fn another_user_cannot_join_the_private_mesh() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let me = std::fs::metadata("/proc/self").unwrap().uid();
    assert_eq!(another_user_unavailable(), None);
    const H: f64 = 30.0;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // without a processor the run waits (for --timeout-s), its mesh up
    let mut l = Launch::start(d, H, &["--external", "processor"]);
    let net = l.event("network", Duration::from_secs(60));
    let listen: Vec<String> = serde_json::from_value(net["launcher"].clone()).unwrap();
    let hub = listen
        .iter()
        .find_map(|a| a.strip_prefix("unixsock-stream/"))
        .unwrap_or_else(|| panic!("the launcher listens on no Unix socket: {listen:?}"))
        .to_string();
    assert!(!listen.iter().any(|a| a.starts_with("tcp/")), "{listen:?}");
    l.event("planned", Duration::from_secs(120));
    let mesh = std::path::Path::new(&hub).parent().unwrap().to_path_buf();
    let meta = std::fs::metadata(&mesh).unwrap();
    assert_eq!(
        meta.permissions().mode() & 0o777,
        0o700,
        "{}",
        mesh.display()
    );
    assert_eq!(meta.uid(), me);
    let sockets: Vec<String> = std::fs::read_dir(&mesh)
        .unwrap()
        .flatten()
        .map(|e| e.path().display().to_string())
        .filter(|p| p.ends_with(".sock"))
        .collect();
    // the launcher's, the planner's and the echo's
    assert!(sockets.len() >= 3, "{sockets:?}");
    let forge = |as_nobody: bool, socket: &str| {
        let mut cmd = std::process::Command::new("timeout");
        cmd.arg("60");
        if as_nobody {
            cmd.args([SETPRIV, "--reuid=65534", "--regid=65534", "--clear-groups"]);
        }
        cmd.arg(harness::bin("cellsar-bridge-bench"))
            .args(["forge", "--duration-s", "2", "-m", "client", "-e"])
            .arg(format!("unixsock-stream/{socket}"))
            .arg("--no-multicast-scouting")
            .env("RUST_LOG", "warn")
            .output()
            .unwrap()
    };
    for s in &sockets {
        let o = forge(true, s);
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!o.status.success(), "nobody joined at {s}:\n{text}");
        assert!(text.contains("Permission denied"), "{s}:\n{text}");
        assert!(!text.contains("forging for mission"), "{s}:\n{text}");
    }
    // the control: this user's forger joins and sees the mission
    let o = forge(false, &hub);
    let text = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && text.contains("forging for mission"),
        "{o:?}"
    );
    harness::signal(l.child.id(), nix::sys::signal::Signal::SIGINT);
    let st = l.finish(Duration::from_secs(60));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    assert!(!mesh.exists(), "{} left behind", mesh.display());
}

/// Waits (at most `timeout`) until `text()` contains `needle`; panics with the text otherwise.
fn wait_for_text(what: &str, needle: &str, timeout: Duration, text: impl Fn() -> String) {
    let deadline = std::time::Instant::now() + timeout;
    loop {
        let t = text();
        if t.contains(needle) {
            return;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "{what}: no {needle:?} within {timeout:?}:\n{t}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A forger on the private mesh answers the lookups of the run's plan (`cellsar/<run id>/plan`)
/// with a plan whose content is changed (the mission renamed) but whose mission id is the
/// run's. The test plays the planner (`--external planner`) so that, until the forgery has been
/// refused, the forger is the only holder the echo and the processor can ask: the echo, asked
/// for an aperture of the mission, looks the plan up, gets only the forgery, skips it and
/// refuses the request; the processor, asked for the mission's results by the launcher, does
/// the same. Then the planner's real plan is held too and the run ends with the closed loop's
/// outputs, both services counting the forgery (`plans_inconsistent` in their final counters)
/// and logging it, the forger answering every lookup all along.
fn a_plan_looked_up_whose_id_is_not_its_contents_is_skipped() {
    use bridge::net::{QueryOptions, SubscribeOptions};
    use bridge::{ZenohArgs, ZenohNode};
    use pipeline::protocol::{keys, ApertureRequest, PlanRequest, RequestAck};
    use pipeline::services::plan::{plan_request, PlanCache};
    use std::sync::Arc;

    const SKIPPED: &str = "plan skipped: its mission id is not its content's";
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut l = Launch::start(d, H, &["--external", "planner"]);
    let net = l.event("network", Duration::from_secs(60));
    let listen: Vec<String> = serde_json::from_value(net["launcher"].clone()).unwrap();
    let hub = listen
        .iter()
        .find(|a| a.starts_with("unixsock-stream/"))
        .unwrap_or_else(|| panic!("the launcher listens on no Unix socket: {listen:?}"))
        .clone();
    let open = |role: &str, instance: &str| {
        let z = ZenohArgs::isolated(&[], std::slice::from_ref(&hub));
        ZenohNode::open(z.to_config().unwrap(), role, instance).unwrap()
    };
    let planner = open("planner", "real");
    let forger = open("forge", "intruder");
    let requests = planner
        .queryable::<PlanRequest>(keys::PLAN, SubscribeOptions::default())
        .unwrap();
    let started = std::time::Instant::now();
    let q = loop {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no plan request\n{}",
            l.stderr_tail()
        );
        if let Some(q) = requests.recv_timeout(Duration::from_millis(200)) {
            break q;
        }
    };
    let plan = plan_request(&q.request, "real", &mut planner::NoObserver).unwrap();
    let id = plan.mission_id;
    let mut forged = plan.clone();
    forged.mission.name = Some("forged".into());
    assert!(forged.id_problem().is_some());
    let forgeries = PlanCache::new(&forger, None).unwrap();
    forgeries.insert(Arc::new(forged)).unwrap();
    // the echo, asked for an aperture of the mission, finds only the forgery
    wait_for_text("the echo", "echo ready", Duration::from_secs(60), || {
        l.log("echo")
    });
    let ask = ApertureRequest {
        mission_id: id,
        aperture: 0,
        look: None,
        frame_pulses: 1,
        scene_digest: 0,
        requester: "roles-test".into(),
    };
    let opts = QueryOptions {
        timeout: Duration::from_secs(10),
        ..QueryOptions::default()
    };
    let key = keys::echo_request(id).unwrap();
    match forger.query_one::<ApertureRequest, RequestAck>(&key, &ask, &opts) {
        Err(bridge::NetError::Refused { refusal, .. }) => {
            assert!(refusal.message.contains(&id.to_string()), "{refusal:?}")
        }
        other => panic!("the echo took a forged plan: {other:?}"),
    }
    wait_for_text("the echo", SKIPPED, Duration::from_secs(10), || {
        l.log("echo")
    });
    // the launcher gets the real plan and asks the processor for the results: it finds only
    // the forgery
    let meta = bridge::Meta {
        mission_id: id,
        ..bridge::Meta::default()
    };
    q.reply(&plan, meta).unwrap();
    wait_for_text("the processor", SKIPPED, Duration::from_secs(60), || {
        l.log("processor")
    });
    // now the planner holds the real plan too: the run ends exact
    let holds = PlanCache::new(&planner, None).unwrap();
    holds.insert(Arc::new(plan)).unwrap();
    let st = l.finish(Duration::from_secs(240));
    assert!(st.success(), "{st:?}\n{}", l.stderr_tail());
    assert_same_as_reference(&l.out, &reference);
    for (role, marker) in [
        ("echo", "echo stopping"),
        ("processor", "processor stopping"),
    ] {
        let log = l.log(role);
        let n = counter(&log, marker, "plans_inconsistent");
        assert!(n.is_some_and(|n| n >= 1), "{role}: {n:?}\n{log}");
        assert!(
            log.contains(SKIPPED) && log.contains(&format!("mission={id}")),
            "{role}:\n{log}"
        );
    }
    drop((forgeries, holds));
    forger.close().unwrap();
    planner.close().unwrap();
}

/// Runs the tests as libtest would (filters, `--list`, `--ignored`, `--test-threads`):
/// [`another_user_cannot_join_the_private_mesh`] shows as ignored (`test [root] NAME ...
/// ignored`, the reason printed once above) where the machine cannot run it.
fn main() {
    use libtest_mimic::{Arguments, Trial};
    let args = Arguments::from_args();
    let why_not = another_user_unavailable();
    if let Some(why) = &why_not {
        println!("the [root] tests are ignored on this machine: {why}");
    }
    let trial = |name: &str, run: fn()| {
        Trial::test(name, move || {
            run();
            Ok(())
        })
    };
    let trials = vec![
        trial(
            "forged_status_and_results_neither_abort_a_run_nor_displace_real_results",
            forged_status_and_results_neither_abort_a_run_nor_displace_real_results,
        ),
        trial(
            "forged_images_and_metrics_from_another_role_are_skipped",
            forged_images_and_metrics_from_another_role_are_skipped,
        ),
        trial(
            "a_plan_looked_up_whose_id_is_not_its_contents_is_skipped",
            a_plan_looked_up_whose_id_is_not_its_contents_is_skipped,
        ),
        trial(
            "another_user_cannot_join_the_private_mesh",
            another_user_cannot_join_the_private_mesh,
        )
        .with_kind("root")
        .with_ignored_flag(why_not.is_some()),
    ];
    libtest_mimic::run(&args, trials).exit()
}
