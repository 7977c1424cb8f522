//! Unit tests of free-altitude missions (`altitude = "free"`) through the FMU: the plan with an
//! altitude per slot (the exact scheme's, as `cellsar-planner plan` makes it), the outputs
//! `z_m` and `climb_mps`, and a landmark move, which keeps the plan and its altitudes.

use super::tests::{planned, set_input, var, Collect};
use super::*;

/// A mission the fixed altitude (1000 m) cannot fly: with the altitude free down to 800 m it
/// can (the planner's test `a_mission_only_a_lower_altitude_can_fly_gets_a_plan`).
const ONLY_LOWER: &str = include_str!("../../../missions/only-a-lower-altitude.toml");

fn run(core: &Core) -> &Run {
    let Core::Planner(c) = core else {
        panic!("not a planner")
    };
    c.run.as_ref().unwrap()
}

fn paper(c: &mut Core) {
    c.set_string(var(PLANNER_VARS, "resolution"), "paper")
        .unwrap();
}

#[test]
fn a_free_mission_outputs_its_altitude_and_climb_rate() {
    let (core, _dir, r) = planned(ONLY_LOWER, paper);
    r.unwrap();
    let mission =
        Mission::from_file_struct(&MissionFile::from_toml_str(ONLY_LOWER).unwrap()).unwrap();
    let options = planner::PlanOptions {
        resolution: planner::evaluate::ResolutionMode::Paper,
        altitude_profile: true,
        ..Default::default()
    };
    let want = planning::plan_with(&mission, None, &options).unwrap();
    let z = want.altitudes_m.clone().expect("a free plan has altitudes");
    assert_eq!(run(&core).altitudes_m.as_ref(), Some(&z));
    assert_eq!(run(&core).traj, want.trajectory);
    let p = mission.params();
    let (slot_s, h0) = (p.slot_s, p.altitude_m);
    let get = |name, tau_s| core.get_real(var(PLANNER_VARS, name), 0, tau_s).unwrap();
    assert_eq!(get("z_m", 0.0), h0);
    let mut prev = h0;
    for (i, &h) in z.iter().enumerate() {
        let t_s = (i + 1) as f64 * slot_s;
        assert!((800.0..=1000.0).contains(&h), "slot {}: {h} m", i + 1);
        let climb = get("climb_mps", t_s - 0.5 * slot_s);
        assert!(
            (climb - (h - prev) / slot_s).abs() <= 1e-9,
            "slot {}",
            i + 1
        );
        assert!(climb <= p.max_climb_mps + 1e-9 && -climb <= p.max_descent_mps + 1e-9);
        // at the slot end the plan's altitude, linear within the slot
        assert!((get("z_m", t_s) - h).abs() <= 1e-9, "slot {}", i + 1);
        let mid = get("z_m", t_s - 0.5 * slot_s);
        assert!((mid - 0.5 * (prev + h)).abs() <= 1e-9, "slot {}", i + 1);
        prev = h;
    }
    // the mission is flown lower than its start altitude: the fixed one cannot fly it
    assert!(z.iter().any(|&h| h < 900.0), "{z:?}");
    assert_eq!(run(&core).eval.slots_out_of_view, 0);
}

#[test]
fn a_fixed_mission_outputs_its_one_altitude() {
    let (core, _dir, r) = planned(crate::planning::tests::SHORT, |_| {});
    r.unwrap();
    assert!(run(&core).altitudes_m.is_none());
    let h = run(&core).mission.params().altitude_m;
    for tau_s in [0.0, 0.25, 3.0, 20.0] {
        assert_eq!(
            core.get_real(var(PLANNER_VARS, "z_m"), 0, tau_s).unwrap(),
            h
        );
        assert_eq!(
            core.get_real(var(PLANNER_VARS, "climb_mps"), 0, tau_s)
                .unwrap(),
            0.0
        );
    }
}

/// A landmark move in a free plan is re-planned as in a fixed one, with an altitude per slot:
/// the slots flown or committed keep their positions and altitudes, the re-plan starts at the
/// altitude flown at the splice (at the mission's 1000 m the mission cannot be flown at all,
/// and a profile restarted there would break the climb rate at the splice), the whole spliced
/// profile keeps the bounds and rates, and the run is the planner call's result, evaluated at
/// its altitudes against the moved landmark.
#[test]
fn a_move_in_a_free_plan_is_replanned_with_its_altitudes() {
    let (mut core, _dir, r) = planned(ONLY_LOWER, paper);
    r.unwrap();
    let before = run(&core).clone();
    let z0 = before.altitudes_m.clone().unwrap();
    let p = before.mission.params().clone();
    let n = before.mission.slots();
    // t = 60 s: slots up to 120 are flown or committed, the window (50, 100] s goes on
    let from = 120;
    assert!(z0[from - 1] < 900.0, "flown low: {} m", z0[from - 1]);
    // 120 m east: out of the old track's view (at 40 m the old track, circling slowly at the
    // least power, still sees it and the re-plan keeps it)
    set_input(&mut core, 120.0, 250.0);
    let log = Collect::default();
    let report = core.step(60.0, 0.5, &log).unwrap();
    if let Some(w) = &report.warning {
        assert!(!w.contains("not re-planned"), "{w}");
    }
    let after = run(&core).clone();
    assert_eq!(after.replans, 1);
    assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 1);
    let z = after
        .altitudes_m
        .clone()
        .expect("the re-plan has altitudes");
    assert_eq!(z.len(), n);
    // the committed slots are kept, position and altitude
    assert_eq!(after.traj.pos_m[..from], before.traj.pos_m[..from]);
    assert_eq!(z[..from], z0[..from]);
    // the rest is the planner call's plan
    let want = planning::replan_with_altitudes(
        &before.mission,
        &before.traj,
        Some(&z0),
        from,
        0,
        [120.0, 250.0],
        &planning::ReplanOptions {
            dynamics: before.dynamics,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(after.traj, want.trajectory);
    assert_eq!(after.altitudes_m, want.altitudes_m);
    assert_ne!(after.traj.pos_m[from..], before.traj.pos_m[from..]);
    // bounds and rates in every slot, the splice included
    let mut prev = p.altitude_m;
    for (i, &h) in z.iter().enumerate() {
        assert!(
            (800.0 - 1e-9..=1000.0 + 1e-9).contains(&h),
            "slot {}: {h} m",
            i + 1
        );
        let rate = (h - prev) / p.slot_s;
        assert!(
            rate <= p.max_climb_mps + 1e-9 && -rate <= p.max_descent_mps + 1e-9,
            "slot {}: {rate} m/s",
            i + 1
        );
        prev = h;
    }
    let ev = evaluate_at(&after.mission, &after.traj, Some(&z)).unwrap();
    assert_eq!(after.eval, ev);
    assert!(ev.violations.altitude_ok(1e-6), "{:?}", ev.violations);
    assert_eq!(
        after.mission.schedule().landmarks[0].pos_m(),
        [120.0, 250.0]
    );
    let get = |name, tau_s| core.get_real(var(PLANNER_VARS, name), 0, tau_s).unwrap();
    assert_eq!(get("landmark_x_m", 60.0), 120.0);
    assert_eq!(get("z_m", 60.0), z0[from - 1]);
    assert!((get("z_m", 90.0) - z[179]).abs() <= 1e-9);
    eprintln!(
        "re-planned from {:.1} m: {:.1}..{:.1} m after the splice, {} slot(s) out of view; {}",
        z0[from - 1],
        z[from..].iter().copied().fold(f64::MAX, f64::min),
        z[from..].iter().copied().fold(f64::MIN, f64::max),
        ev.slots_out_of_view,
        want.summary
    );
}
