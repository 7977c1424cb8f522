#![allow(clippy::unwrap_used, clippy::expect_used)]
//! Missions with `altitude = "free"`: read, validated, round-tripped, and refused by every
//! scheme (none plans per-slot altitudes) with an error naming `altitude`, not planned at the
//! fixed altitude.

use planner::{
    plan, tradeoff::tradeoff, AltitudeMode, Mission, MissionFile, PlanError, PlanOptions, Scheme,
};

const FREE: &str = r#"
name = "free altitude"
[params]
horizon_s = 20
altitude = "free"
min_altitude_m = 600
max_altitude_m = 1200
max_climb_mps = 2.5
[landmarks]
preset = "default"
"#;

fn free_mission() -> Mission {
    Mission::from_file_struct(&MissionFile::from_toml_str(FREE).unwrap()).unwrap()
}

#[test]
fn a_free_mission_reads_and_round_trips() {
    let m = free_mission();
    let p = m.params();
    assert_eq!(p.altitude, AltitudeMode::Free);
    assert_eq!(
        (p.min_altitude_m, p.max_altitude_m),
        (Some(600.0), Some(1200.0))
    );
    // the climb rate as given, the descent rate PX4's default
    assert_eq!((p.max_climb_mps, p.max_descent_mps), (2.5, 1.0));
    let toml = m.to_file_struct().to_toml_string().unwrap();
    let back = Mission::from_file_struct(&MissionFile::from_toml_str(&toml).unwrap()).unwrap();
    assert_eq!(back.params(), p);
    let json = serde_json::to_string(&m.to_file_struct()).unwrap();
    let back = Mission::from_file_struct(&MissionFile::from_json_str(&json).unwrap()).unwrap();
    assert_eq!(back.params(), p);
    // a fixed mission's file does not gain the altitude fields
    let fixed = Mission::preset(planner::Preset::Default, 30.0).unwrap();
    let toml = fixed.to_file_struct().to_toml_string().unwrap();
    assert!(!toml.contains("altitude"), "{toml}");
}

#[test]
fn bad_altitude_settings_name_their_field() {
    for (edit, field) in [
        (("min_altitude_m = 600\n", ""), "min_altitude_m"),
        (("altitude = \"free\"", "altitude = \"flying\""), "altitude"),
        (
            ("max_climb_mps = 2.5", "max_climb_mps = 0"),
            "max_climb_mps",
        ),
        (
            ("max_altitude_m = 1200", "max_altitude_m = 900"),
            "max_altitude_m",
        ),
    ] {
        let text = FREE.replace(edit.0, edit.1);
        let msg = match MissionFile::from_toml_str(&text) {
            Err(e) => e,
            Ok(f) => Mission::from_file_struct(&f).unwrap_err().to_string(),
        };
        assert!(msg.contains(field), "{field}: {msg}");
    }
}

#[test]
fn every_scheme_refuses_free_altitude_naming_it() {
    let m = free_mission();
    for scheme in [
        Scheme::Exact,
        Scheme::Paper,
        Scheme::Baseline,
        Scheme::BaselineExact,
    ] {
        let e = plan(&m, &PlanOptions::for_scheme(scheme)).unwrap_err();
        assert_eq!(e, PlanError::AltitudeConflict { scheme });
        let msg = e.to_string();
        assert!(msg.contains("`altitude` = \"free\""), "{msg}");
    }
    let e = tradeoff(&m, &PlanOptions::least_energy(), &[5.0]).unwrap_err();
    assert!(matches!(e, PlanError::AltitudeConflict { .. }), "{e}");
}
