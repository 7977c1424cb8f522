//! End-to-end: the real binary on a shortened default mission (closed loop), and the
//! simulate → process path with clear errors for bad input.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cellsar-radar-sim"))
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn closed_loop_on_shortened_default_mission() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loop");
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default.toml"))
        .arg("--scene")
        .arg(root().join("scenes/default.toml"))
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
        "false_alarms",
        "mean_position_error_m",
        "dpi_reduction_db",
        "range_resolution_m",
        "azimuth_resolution_m",
    ] {
        assert!(!m[k].is_null(), "metrics.json lacks {k}");
    }
    let r = &m["range_resolution_m"];
    let rel = r["measured_m"].as_f64().unwrap() / r["predicted_general_m"].as_f64().unwrap() - 1.0;
    assert!(rel.abs() < 0.15, "{r}");

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
}

#[test]
fn bad_inputs_get_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    // a scene with a bad field
    let scene = dir.path().join("bad.toml");
    std::fs::write(&scene, "[radar]\nprf_hz = -5\n").unwrap();
    let o = bin()
        .arg("closed-loop")
        .arg(root().join("missions/default.toml"))
        .arg("--scene")
        .arg(&scene)
        .arg("--out")
        .arg(dir.path().join("x"))
        .args(["--horizon-s", "10"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("radar.prf_hz"), "{e}");
    // a missing plan directory
    let o = bin()
        .arg("simulate")
        .args(["--plan", "/nonexistent/plan"])
        .arg("--scene")
        .arg(root().join("scenes/default.toml"))
        .arg("--out")
        .arg(dir.path().join("y"))
        .output()
        .unwrap();
    assert!(!o.status.success());
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
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("meta.json"));
    // a plan that looks elsewhere: a trajectory far from the landmarks
    let plan = dir.path().join("plan");
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
    let o = bin()
        .arg("simulate")
        .arg("--plan")
        .arg(&plan)
        .arg("--scene")
        .arg(root().join("scenes/default.toml"))
        .arg("--out")
        .arg(dir.path().join("w"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("no landmark is in the receive beam"), "{e}");
}
