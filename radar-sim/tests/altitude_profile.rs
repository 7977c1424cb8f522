//! Flying a mission with `altitude = "free"` at its planned altitudes H_t.
//!
//! - the closed loop of a small free mission (planned with the altitude profile, the `exact`
//!   scheme) images every landmark the plan keeps in view and detects it, with the plan's
//!   altitude varying;
//! - every recorded pulse is at the plan's altitude interpolated linearly between slots, and its
//!   direct-path delay (the receiver's window delay) is that of the 3-D geometry at H_t, closed
//!   form, where the mission's fixed altitude gives another;
//! - a free mission without its profile, a fixed one with a profile, and a profile outside the
//!   bounds are refused, naming the field;
//! - a fixed mission flies as before: the recording of a constant profile is the fixed one's.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use radar_sim::config::SceneFile;
use radar_sim::limits::IqLimits;
use radar_sim::run;
use radar_sim::track::{dist3, Track};
use radar_sim::waveform::C_MPS;

/// `missions/default-30m-free-altitude.toml` (the paper's default mission, free within
/// 600–1200 m) cut to its windows within `horizon_s`.
fn free_mission(horizon_s: f64) -> planner::Mission {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../missions/default-30m-free-altitude.toml");
    let m = planner::Mission::from_path(&path).unwrap();
    assert_eq!(m.params().altitude, planner::AltitudeMode::Free);
    run::shorten(&m, horizon_s).unwrap()
}

fn plan_free(m: &planner::Mission) -> planner::PlanResult {
    let opts = planner::PlanOptions {
        altitude_profile: true,
        ..Default::default()
    };
    planner::plan(m, &opts).unwrap()
}

/// H at `t_s` from the start altitude and the per-slot ones, linear between slot ends.
fn altitude_closed_form(h0: f64, hs: &[f64], slot_s: f64, t_s: f64) -> f64 {
    let at = |k: usize| if k == 0 { h0 } else { hs[k - 1] };
    let x = (t_s / slot_s).clamp(0.0, hs.len() as f64);
    let k = (x.floor() as usize).min(hs.len() - 1);
    let f = x - k as f64;
    at(k) * (1.0 - f) + at(k + 1) * f
}

#[test]
fn a_free_mission_flies_its_planned_altitudes_and_detects_every_landmark_in_view() {
    let m = free_mission(25.0);
    let plan = plan_free(&m);
    assert!(plan.is_feasible());
    let hs = plan.altitudes_m.clone().expect("a free plan has altitudes");
    let p = m.params();
    let (lo, hi) = hs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), h| (a.min(*h), b.max(*h)));
    eprintln!(
        "planned altitudes {lo:.1}..{hi:.1} m over {} slots",
        hs.len()
    );
    // a best effort's altitude steps are capped at the fixed plan's energy, so the profile
    // varies by metres here: enough for the pulse-by-pulse checks below, which compare z with
    // the closed form at 1e-3 m and require most pulses more than 1 cm off the fixed altitude
    assert!(hi - lo > 1.0, "the plan varies in altitude: {lo}..{hi} m");

    let scene = SceneFile::default();
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("recording");
    let meta = run::simulate_profile_limited(
        &m,
        &plan.trajectory,
        Some(&hs),
        &scene,
        &rec,
        &IqLimits::default(),
        &mut |_, _| {},
    )
    .unwrap();
    assert!(meta.warnings.is_empty(), "{:?}", meta.warnings);

    // every pulse at H_t, its direct-path delay that of the 3-D geometry there
    let setup = radar_sim::pipeline::RadarSetup::new(p, &scene).unwrap();
    let fs = setup.num.sample_rate_hz();
    let pulses = run::read_pulses(&rec.join("pulses.csv")).unwrap();
    let mut differs = 0;
    for q in &pulses {
        let h = altitude_closed_form(p.altitude_m, &hs, p.slot_s, q.t_s);
        let xy = plan.trajectory.position_at(q.t_s);
        assert!(
            (q.pos_m[2] - h).abs() < 1e-3,
            "t {}: z {} vs {h}",
            q.t_s,
            q.pos_m[2]
        );
        let rd = dist3([xy[0], xy[1], h], setup.bs_m);
        let expect = (rd * fs / C_MPS).floor() as i64;
        assert!(
            (q.window_delay_samples - expect).abs() <= 1,
            "t {}: delay {} vs {expect}",
            q.t_s,
            q.window_delay_samples
        );
        // the z check above tells the profile from the fixed altitude at this pulse
        if (h - p.altitude_m).abs() > 1e-2 {
            differs += 1;
        }
    }
    assert!(
        differs > pulses.len() / 2,
        "{differs} of {} pulses",
        pulses.len()
    );

    let metrics = run::process_limited(
        &rec,
        &dir.path().join("processed"),
        &IqLimits::default(),
        &mut |_, _| {},
        &mut run::no_image_views,
    )
    .unwrap();
    let report = run::loop_report(&m, &plan.evaluation, metrics);
    for r in &report.rows {
        eprintln!(
            "aperture {} landmark {:?} in view {:.2} detected {:?} snr {:?}",
            r.aperture, r.landmark, r.in_view_fraction, r.detected, r.snr_db
        );
        assert!(r.in_view_fraction >= run::IN_VIEW_MIN_FRACTION, "{r:?}");
        assert_eq!(r.detected, Some(true), "{r:?}");
    }
    assert_eq!(report.landmarks_scored, m.schedule().landmarks.len());
    assert!(report.all_in_view_detected);
}

#[test]
fn the_altitude_profile_is_refused_where_it_does_not_fit_the_mission() {
    let m = free_mission(25.0);
    let traj = planner::Trajectory {
        slot_s: m.params().slot_s,
        start_m: m.params().start_m,
        pos_m: vec![m.params().start_m; m.slots()],
    };
    let e = run::planned_track(&m, &traj, None).unwrap_err();
    assert!(
        e.is_bad_input() && e.to_string().contains("altitude"),
        "{e}"
    );
    assert!(e.to_string().contains("free"), "{e}");
    let mut hs = vec![1000.0; m.slots()];
    hs[3] = 1300.0;
    let e = run::planned_track(&m, &traj, Some(&hs)).unwrap_err();
    assert!(
        e.to_string().contains("altitudes_m") && e.to_string().contains("slot 4"),
        "{e}"
    );
    let e = run::planned_track(&m, &traj, Some(&hs[1..])).unwrap_err();
    assert!(e.to_string().contains("altitudes_m"), "{e}");
    let fixed = run::shorten(
        &planner::Mission::preset(planner::Preset::Default, 30.0).unwrap(),
        25.0,
    )
    .unwrap();
    let e = run::planned_track(&fixed, &traj, Some(&vec![1000.0; fixed.slots()])).unwrap_err();
    assert!(e.to_string().contains("altitudes_m"), "{e}");
    // the simulation refuses before writing anything
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec");
    let e = run::simulate(&m, &traj, &SceneFile::default(), &out, &mut |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("altitude"), "{e}");
    assert!(!out.exists());
}

#[test]
fn a_constant_profile_flies_the_fixed_track() {
    let m = free_mission(25.0);
    let p = m.params();
    let traj = planner::Trajectory {
        slot_s: p.slot_s,
        start_m: p.start_m,
        pos_m: (1..=m.slots())
            .map(|t| [p.start_m[0] + 20.0 * t as f64 * p.slot_s, p.start_m[1]])
            .collect(),
    };
    let flat = run::planned_track(&m, &traj, Some(&vec![p.altitude_m; m.slots()])).unwrap();
    let fixed = radar_sim::track::PlannedTrack::new(traj.clone(), p.altitude_m);
    for i in 0..=1000 {
        let t = i as f64 * 0.025;
        assert_eq!(flat.position_m(t), fixed.position_m(t));
        assert_eq!(flat.velocity_mps(t), fixed.velocity_mps(t));
    }
}
