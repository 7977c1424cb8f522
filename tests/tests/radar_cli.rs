//! End-to-end: the real binary on a shortened default mission (closed loop), and the
//! simulate → process path with clear errors for bad input.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

use harness::root;

fn bin() -> Command {
    Command::new(harness::bin("cellsar-radar-sim"))
}

#[test]
fn closed_loop_on_shortened_default_mission() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loop");
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(&out)
        .args(["--horizon-s", "20"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{text}");
    assert!(
        text.contains("every landmark in view detected: yes"),
        "{text}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for r in rows {
        assert!(r["in_view_fraction"].as_f64().unwrap() >= 0.5);
        assert_eq!(r["detected"], true);
    }
    // the files others read
    for f in [
        "recording/truth.csv",
        "recording/meta.json",
        "recording/pulses.csv",
        "recording/iq/aperture_000.npy",
        "processed/detections.csv",
        "processed/detections.json",
        "processed/metrics.json",
        "processed/images/aperture_000.png",
        "processed/images/aperture_000.npy",
        "plan/mission.toml",
        "plan/trajectory.csv",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let truth = std::fs::read_to_string(out.join("recording/truth.csv")).unwrap();
    assert!(truth.starts_with("id,x_m,y_m,rcs_m2"));
    let det = std::fs::read_to_string(out.join("processed/detections.csv")).unwrap();
    assert!(det.starts_with("aperture,x_m,y_m,snr_db"));
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("processed/metrics.json")).unwrap())
            .unwrap();
    for k in [
        "pd",
        "pd_distinct",
        "false_alarms",
        "design_false_alarms",
        "mean_position_error_m",
        "dp_suppression_db",
        "residual_over_floor_db",
        "range_resolution_m",
        "azimuth_resolution_m",
    ] {
        assert!(!m[k].is_null(), "metrics.json lacks {k}");
    }
    // Pd counts object-aperture pairs (the two landmarks are in both images), and distinct objects
    let (pairs, distinct) = (
        m["strong_objects"].as_u64().unwrap(),
        m["strong_distinct_objects"].as_u64().unwrap(),
    );
    assert!(
        distinct < pairs,
        "{distinct} distinct objects, {pairs} pairs"
    );
    assert!(
        text.contains(&format!("{pairs} object-aperture pairs")),
        "{text}"
    );
    // the canceller's line: its own suppression, the residual on the predicted floor
    assert!(text.contains("direct-path suppression"), "{text}");
    assert!(
        m["residual_over_floor_db"].as_f64().unwrap().abs() < 0.1,
        "{m}"
    );
    // every resolution pair uses one definition: −3 dB widths (× the main-lobe factor) against
    // −3 dB widths, cells against cells
    for k in ["range_resolution_m", "azimuth_resolution_m"] {
        let r = &m[k];
        let f = |n: &str| r[n].as_f64().unwrap();
        assert!((f("mainlobe_factor") - 1.44).abs() < 1e-3, "{r}"); // Hann in the scene
        assert!((f("paper_mainlobe_m") / f("paper_cell_m") - f("mainlobe_factor")).abs() < 1e-9);
        assert!(
            (f("predicted_general_m") / f("general_cell_m") - f("mainlobe_factor")).abs() < 1e-9
        );
        assert!(
            (f("measured_m") / f("predicted_general_m") - 1.0).abs() < 0.15,
            "{r}"
        );
    }
    for a in m["apertures"].as_array().unwrap() {
        let w = a["worst_width_m"].as_f64().unwrap();
        assert!((a["worst_width_mainlobe_m"].as_f64().unwrap() / w - 1.44).abs() < 1e-3);
    }

    // process again from the recording: same detections (deterministic)
    let again = dir.path().join("again");
    let o = bin()
        .arg("process")
        .arg("--in")
        .arg(out.join("recording"))
        .arg("--out")
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(again.join("detections.csv")).unwrap(),
        det
    );

    // an aperture (10 s: 31 MiB of IQ) above --max-aperture-gib is refused before reading
    let small = dir.path().join("small");
    let o = bin()
        .arg("process")
        .arg("--in")
        .arg(out.join("recording"))
        .arg("--out")
        .arg(&small)
        .args(["--max-aperture-gib", "0.01"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("aperture 0") && e.contains("--max-aperture-gib"),
        "{e}"
    );
    assert!(!small.join("images").exists());
}

/// A plan directory whose 10-s track runs far from its one landmark.
fn far_plan(dir: &Path) -> std::path::PathBuf {
    let plan = dir.join("plan");
    std::fs::create_dir_all(&plan).unwrap();
    std::fs::write(
        plan.join("mission.toml"),
        "name = \"far\"\n[params]\nhorizon_s = 10.0\n[landmarks]\npoints = [{ x_m = 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }]\n",
    )
    .unwrap();
    let mut csv = String::from("t_s,x_m,y_m\n0,5000,5000\n");
    for t in 1..=20 {
        csv += &format!("{},{},5000\n", t as f64 * 0.5, 5000.0 + 10.0 * t as f64);
    }
    std::fs::write(plan.join("trajectory.csv"), csv).unwrap();
    plan
}

/// `closed-loop` of the default mission's first 10 s with `scene`, writing to `dir/loop`.
fn short_closed_loop(dir: &Path, scene: &Path) -> Command {
    let mut c = bin();
    c.arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .arg("--scene")
        .arg(scene)
        .arg("--out")
        .arg(dir.join("loop"))
        .args(["--horizon-s", "10"]);
    c
}

/// The default scene with `key = value` set in its table.
fn scene_with(dir: &Path, name: &str, key: &str, value: &str) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("radar-sim/scenes/default.toml")).unwrap();
    let mut found = false;
    let out: Vec<String> = text
        .lines()
        .map(|l| {
            if l.split('=').next().map(str::trim) == Some(key) {
                found = true;
                format!("{key} = {value}")
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(found, "{key} not in the default scene");
    let p = dir.join(name);
    std::fs::write(&p, out.join("\n")).unwrap();
    p
}

#[test]
fn bad_inputs_get_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    // a scene with a bad field
    let scene = dir.path().join("bad.toml");
    std::fs::write(&scene, "[radar]\nprf_hz = -5\n").unwrap();
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .arg("--scene")
        .arg(&scene)
        .arg("--out")
        .arg(dir.path().join("x"))
        .args(["--horizon-s", "10"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("radar.prf_hz"), "{e}");
    // a missing plan directory
    let o = bin()
        .arg("simulate")
        .args(["--plan", "/nonexistent/plan"])
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(dir.path().join("y"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/plan"));
    // process on a directory that is no recording
    let o = bin()
        .arg("process")
        .arg("--in")
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("z"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("meta.json"));
    // a missing scene file
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .args(["--scene", "/nonexistent/scene.toml"])
        .arg("--out")
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/scene.toml"));
    // a bad option value (clap's usage errors exit 2 too)
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(dir.path().join("x"))
        .args(["--horizon-s", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--horizon-s"));
    let o = bin()
        .arg("simulate")
        .arg("--plan")
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--scene"));
    // a plan that looks elsewhere: a trajectory far from the landmarks
    let plan = far_plan(dir.path());
    let o = bin()
        .arg("simulate")
        .arg("--plan")
        .arg(&plan)
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(dir.path().join("w"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("no landmark is in the receive beam"), "{e}");
}

#[test]
fn scenes_beyond_the_signal_model_or_the_iq_limits_are_refused_before_simulating() {
    let dir = tempfile::tempdir().unwrap();
    let plan = far_plan(dir.path());
    let simulate = |scene: &Path, out: &Path, extra: &[&str]| {
        bin()
            .arg("simulate")
            .arg("--plan")
            .arg(&plan)
            .arg("--scene")
            .arg(scene)
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .unwrap()
    };
    // a PRF above the BS's symbol rate (48 kHz): the signal model cannot produce it
    for prf in ["1e5", "1e7"] {
        let scene = scene_with(dir.path(), "prf.toml", "prf_hz", prf);
        let out = dir.path().join("prf");
        let o = simulate(&scene, &out, &[]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains("radar.prf_hz") && e.contains("48000 Hz"), "{e}");
        assert!(!out.exists());
    }
    // 40 kHz is possible, but 10 s of it is 12 GiB of IQ
    let scene = scene_with(dir.path(), "fast.toml", "prf_hz", "40000");
    let out = dir.path().join("fast");
    let o = simulate(&scene, &out, &["--max-iq-gib", "1"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("radar.prf_hz") && e.contains("12.2 GiB of IQ") && e.contains("--max-iq-gib"),
        "{e}"
    );
    assert!(!out.exists());
    // under the default total limit (16 GiB), the one aperture is above its own (2 GiB)
    let o = simulate(&scene, &out, &[]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--max-aperture-gib"), "{e}");
    assert!(!out.exists());
    // a bad limit names the flag
    let o = simulate(&scene, &out, &["--max-iq-gib=nan"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--max-iq-gib"), "{e}");
    // a grid that would not fit in memory
    let scene = scene_with(dir.path(), "grid.toml", "grid_half_m", "1e6");
    let o = simulate(&scene, &out, &[]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("processing.grid_half_m"), "{e}");
}

#[test]
fn an_infeasible_mission_exits_3_and_a_failed_write_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    // the second landmark is 100 km away, 0.5 s after the first window
    let mission = dir.path().join("far.toml");
    std::fs::write(
        &mission,
        "name = \"far\"\n[params]\nhorizon_s = 60\nstart_m = [-1000.0, 0.0]\n[landmarks]\npoints = [{ x_m = 0.0, y_m = 0.0, from_s = 0.0, to_s = 20.0 }, { x_m = 100000.0, y_m = 0.0, from_s = 20.0, to_s = 40.0 }]\n",
    )
    .unwrap();
    let o = bin()
        .arg("closed-loop")
        .arg(&mission)
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("cannot be flown"), "{e}");
    // valid inputs, but the output cannot be written (a file where a directory must go)
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, "x").unwrap();
    let o = bin()
        .arg("simulate")
        .arg("--plan")
        .arg(far_plan(dir.path()))
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(blocker.join("rec"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("file/rec"), "{e}");
}

#[test]
fn a_missed_landmark_exits_4_and_redirected_logs_have_no_colour() {
    let dir = tempfile::tempdir().unwrap();
    // a landmark too faint to be detected, in view of the plan
    let scene = scene_with(dir.path(), "faint.toml", "landmark_rcs_m2", "1e-9");
    let o = short_closed_loop(dir.path(), &scene)
        .env("RUST_LOG", "planner=debug")
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{out}\n{e}");
    assert!(out.contains("every landmark in view detected: NO"), "{out}");
    assert!(e.contains("DEBUG"), "{e}");
    assert!(
        !e.contains('\u{1b}'),
        "ANSI codes in redirected stderr: {e}"
    );
}

/// A scene without landmark objects (`include_landmarks = false`): the landmarks are not
/// scored, so none is missed (exit 0, not 4).
#[test]
fn landmarks_that_are_no_objects_are_not_scored() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with(dir.path(), "nolm.toml", "include_landmarks", "false");
    let o = short_closed_loop(dir.path(), &scene).output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{out}\n{e}");
    assert!(
        out.contains("every landmark in view detected: not scored"),
        "{out}"
    );
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("loop/report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(report["landmarks_scored"], 0);
    assert_eq!(report["all_in_view_detected"], true);
    let rows = report["rows"].as_array().unwrap();
    assert!(!rows.is_empty());
    for r in rows {
        assert!(r["in_view_fraction"].as_f64().unwrap() >= 0.5);
        assert!(r["detected"].is_null(), "{r}");
    }
}

#[test]
fn help_documents_the_exit_codes_and_the_required_scene() {
    let o = bin().arg("--help").output().unwrap();
    let h = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    for code in [
        "0 success",
        "2 bad input",
        "3 the mission cannot be flown",
        "4 closed-loop",
        "1 runtime failure",
    ] {
        assert!(h.contains(code), "{code}: {h}");
    }
    for cmd in ["simulate", "closed-loop"] {
        let o = bin().args([cmd, "--help"]).output().unwrap();
        let h = String::from_utf8_lossy(&o.stdout);
        assert!(
            h.contains("--scene <SCENE>") && h.contains("--max-iq-gib"),
            "{h}"
        );
        assert!(!h.contains("--scene <SCENE>  [default"), "{h}");
    }
}

#[test]
fn service_seconds_beyond_a_duration_exit_2_naming_the_flag() {
    // 1e300 s passed the old "> 0 and finite" check and panicked converting to a Duration.
    let scene = root().join("radar-sim/scenes/default.toml");
    for (cmd, flag) in [
        ("echo", "--status-interval-s"),
        ("process-service", "--status-interval-s"),
        ("process-service", "--resend-after-s"),
    ] {
        let o = bin()
            .args([cmd, "--no-multicast-scouting", flag, "1e300", "--scene"])
            .arg(&scene)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{cmd} {flag}: {err}");
        assert!(err.contains(flag) && !err.contains("panicked"), "{err}");
    }
}

#[test]
fn closed_loop_plans_for_the_general_resolution_cell() {
    // The default mission started where a general-resolution plan exists (docs/user-guide.md,
    // "Resolution: paper or general"), first two windows: every landmark slot resolved under the general cell.
    let dir = tempfile::tempdir().unwrap();
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default-30m-far-start.toml"))
        .arg("--scene")
        .arg(root().join("radar-sim/scenes/default.toml"))
        .arg("--out")
        .arg(dir.path())
        .args(["--horizon-s", "20", "--resolution", "general"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 4)), "{err}");
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("plan/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(s["resolution"], "general");
    assert_eq!(s["feasible"], true);
    assert_eq!(s["slots_unresolved_general"], 0);
}

/// `closed-loop` of the default mission's first 20 s under the NR scene of `reference`: every
/// landmark in view detected, the report and metrics written; returns the metrics.
fn nr_closed_loop(reference: &str) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loop");
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .arg("--scene")
        .arg(root().join(format!("radar-sim/scenes/nr-{reference}.toml")))
        .arg("--out")
        .arg(&out)
        .args(["--horizon-s", "20"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{reference}: {text}");
    assert!(
        text.contains("every landmark in view detected: yes"),
        "{reference}: {text}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for r in report["rows"].as_array().unwrap() {
        assert_eq!(r["detected"], true, "{reference}: {r}");
    }
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("processed/metrics.json")).unwrap())
            .unwrap();
    assert_eq!(m["pd"].as_f64().unwrap(), 1.0, "{reference}: {m}");
    // the recording keeps the scene: processing it again gives the same detections
    let again = dir.path().join("again");
    let o = bin()
        .arg("process")
        .arg("--in")
        .arg(out.join("recording"))
        .arg("--out")
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(again.join("detections.csv")).unwrap(),
        std::fs::read_to_string(out.join("processed/detections.csv")).unwrap()
    );
    m
}

#[test]
fn nr_cell_closed_loop_with_the_ideal_reference() {
    nr_closed_loop("ideal");
}

#[test]
fn nr_cell_closed_loop_with_the_pilots_alone() {
    nr_closed_loop("pilots");
}

#[test]
fn nr_cell_closed_loop_with_the_reconstructed_reference() {
    nr_closed_loop("reconstructed");
}

#[test]
fn nr_scene_errors_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    for (name, key, value, append, field) in [
        (
            "pilots-plain.toml",
            "direct_path",
            "true\nreference = \"pilots\"",
            "",
            "radar.reference",
        ),
        (
            "nr-comb.toml",
            "direct_path",
            "true",
            "[radar.nr]\nprs_comb = 5",
            "radar.nr.prs_comb",
        ),
        (
            "nr-uplink.toml",
            "direct_path",
            "true",
            "[radar.nr]\npulse_slot = 4\npulse_period_slots = 5",
            "radar.nr.pulse_slot",
        ),
        // the PRF follows from the cell: another value is refused
        (
            "nr-prf.toml",
            "prf_hz",
            "250.0",
            "[radar.nr]",
            "radar.prf_hz",
        ),
    ] {
        let scene = scene_with(dir.path(), name, key, value);
        let text = std::fs::read_to_string(&scene).unwrap();
        std::fs::write(&scene, format!("{text}\n{append}\n")).unwrap();
        let o = short_closed_loop(dir.path(), &scene).output().unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(e.contains(field), "{name}: {e}");
    }
}
