#![allow(clippy::unwrap_used, clippy::expect_used)]
//! Missions with `altitude = "free"`: read, validated, round-tripped, and refused by every
//! scheme for a caller that flies one altitude (without `PlanOptions::altitude_profile`; the
//! plans with it are in `altitude_plan.rs`) with an error naming `altitude`, not planned at the
//! fixed altitude.

use planner::evaluate::evaluate_with_altitudes;
use planner::{
    evaluate, plan, tradeoff::tradeoff, AltitudeMode, Mission, MissionFile, PlanError, PlanOptions,
    Scheme,
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

/// A straight track north at 20 m/s for 10 s, the landmark broadside of its middle.
fn straight(altitude: &str) -> (Mission, planner::Trajectory) {
    let text = format!(
        "[params]\nhorizon_s = 10\nstart_m = [-1000.0, 0.0]\n{altitude}\n[landmarks]\n\
         points = [{{ x_m = 0.0, y_m = 100.0, from_s = 0.0, to_s = 10.0 }}]\n"
    );
    let m = Mission::from_file_struct(&MissionFile::from_toml_str(&text).unwrap()).unwrap();
    let traj = planner::Trajectory {
        slot_s: 0.5,
        start_m: [-1000.0, 0.0],
        pos_m: (1..=20).map(|t| [-1000.0, 10.0 * t as f64]).collect(),
    };
    (m, traj)
}

const FREE_BOUNDS: &str =
    "altitude = \"free\"\nmin_altitude_m = 600\nmax_altitude_m = 1200\nstart_velocity_mps = [0, 20]";

#[test]
fn a_profile_at_the_mission_altitude_is_the_fixed_evaluation() {
    let (m, traj) = straight("");
    let fixed = evaluate(&m, &traj);
    let same = evaluate_with_altitudes(&m, &traj, &[1000.0; 20]).unwrap();
    assert_eq!(fixed, same);
    assert!(fixed
        .slots
        .iter()
        .all(|s| s.z_m == 1000.0 && s.climb_mps == 0.0));
    assert_eq!(fixed.start_altitude_m, 1000.0);
    let e = evaluate_with_altitudes(&m, &traj, &[1000.0; 3]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "altitude profile: 3 altitudes for a trajectory of 20 slots"
    );
}

/// A climb at 2 m/s from 1000 m: closed forms of the centre, the sensing radius, V_min, the
/// paper's azimuth resolution and the energy at H_t; and every slot equals the fixed-altitude
/// evaluation of a mission at H_t (with the same antenna's radius) but for the climb power.
#[test]
fn a_climbing_profile_follows_h_t_in_every_slot() {
    let (m, traj) = straight(FREE_BOUNDS);
    let p = m.params().clone();
    let z: Vec<f64> = (1..=20).map(|t| 1000.0 + t as f64).collect();
    let ev = evaluate_with_altitudes(&m, &traj, &z).unwrap();
    let model = planner::PowerModel::new(&p);
    let w = 2.0 * 9.80665;
    let want_j = 10.0 * (model.power_w(20.0) + 2.0 * w);
    assert!(
        (ev.energy_j - want_j).abs() < 1e-9 * want_j,
        "{}",
        ev.energy_j
    );
    assert!(ev.is_feasible(), "{:?}", ev.violations);
    let tan = p.observation_angle_rad.tan();
    let cos = p.observation_angle_rad.cos();
    for (s, &h) in ev.slots.iter().zip(&z) {
        assert!((s.climb_mps - 2.0).abs() < 1e-9);
        assert_eq!(s.z_m, h);
        // heading north: the centre lies H_t tan η to the east
        assert!((s.centre_m[0] - (-1000.0 + h * tan)).abs() < 1e-9);
        let az = p.wavelength_m * h / (20.0 * p.integration_time_s * cos);
        assert!(
            (s.azimuth_resolution_paper_m - az).abs() < 1e-9 * az,
            "{}",
            s.t
        );
        // the same slot of a fixed mission at H_t whose antenna gives r_s H_t / H
        let mut at = p.clone();
        at.altitude = AltitudeMode::Fixed;
        at.min_altitude_m = None;
        at.max_altitude_m = None;
        at.altitude_m = h;
        at.sensing_radius_m = p.sensing_radius_m * h / 1000.0;
        let fixed = evaluate(&m.with_params(at).unwrap(), &traj);
        let f = &fixed.slots[s.t - 1];
        assert_eq!(
            (
                s.centre_m,
                s.in_view,
                s.worst_width_m,
                s.range_resolution_general_m
            ),
            (
                f.centre_m,
                f.in_view,
                f.worst_width_m,
                f.range_resolution_general_m
            )
        );
        assert_eq!(
            (s.psi_rad, s.bistatic_angle_rad),
            (f.psi_rad, f.bistatic_angle_rad)
        );
        assert!((s.power_w - (f.power_w + 2.0 * w)).abs() < 1e-9);
    }
    // the sensing radius scales with H_t: at 1500 m the centre is 500 m east of the track and
    // the radius 300 m, so the farthest slot (t = 20, 100 m past the landmark) misses by
    // hypot(500, 100) − 300 m (by 100 m more with the radius of 1000 m)
    let high = evaluate_with_altitudes(&m, &traj, &[1500.0; 20]).unwrap();
    let want = 500f64.hypot(100.0) - 300.0;
    assert!(
        (high.violations.sensing_m - want).abs() < 1e-9,
        "{}",
        high.violations.sensing_m
    );
    assert_eq!(high.slots_out_of_view, 20);
}

#[test]
fn altitude_bounds_and_rates_are_checked_in_every_slot() {
    let (m, traj) = straight(FREE_BOUNDS);
    // 3.5 m/s up in slot 1 (0.5 above the limit), 1.5 m/s down in slot 2 (0.5 above), then
    // above 1200 m by 10 m
    let mut z = vec![1001.75, 1001.0];
    z.extend((3..=20).map(|_| 1210.0));
    let ev = evaluate_with_altitudes(&m, &traj, &z).unwrap();
    assert!(!ev.is_feasible());
    assert!((ev.violations.altitude_m - 10.0).abs() < 1e-9);
    // slot 3 climbs 209 m in 0.5 s
    assert!((ev.violations.climb_mps - (418.0 - 3.0)).abs() < 1e-9);
    let mut z = vec![1001.75, 1001.0];
    z.extend((3..=20).map(|_| 1001.0));
    let v = evaluate_with_altitudes(&m, &traj, &z).unwrap().violations;
    assert!((v.climb_mps - 0.5).abs() < 1e-9, "{v:?}");
    assert_eq!(v.altitude_m, 0.0);
    // a fixed mission: any altitude other than altitude_m is out of its bounds
    let (fixed, traj) = straight("");
    let v = evaluate_with_altitudes(&fixed, &traj, &[1000.5; 20])
        .unwrap()
        .violations;
    assert!((v.altitude_m - 0.5).abs() < 1e-12 && (v.climb_mps - 0.0).abs() < 1e-12);
}
