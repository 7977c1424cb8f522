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

/// A landmark move in a free plan is not re-planned (re-plans fly one altitude): the plan and
/// its altitudes are kept, the outputs report the moved landmark, and a warning says why.
#[test]
fn a_move_in_a_free_plan_keeps_the_plan_and_says_why() {
    let (mut core, _dir, r) = planned(ONLY_LOWER, paper);
    r.unwrap();
    let before = run(&core).clone();
    set_input(&mut core, 40.0, 250.0);
    let log = Collect::default();
    let report = core.step(60.0, 0.5, &log).unwrap();
    let warning = report.warning.expect("a kept plan must warn");
    assert!(
        warning.contains("not re-planned") && warning.contains("altitude = \"free\""),
        "{warning}"
    );
    let after = run(&core);
    assert_eq!(after.traj, before.traj);
    assert_eq!(after.altitudes_m, before.altitudes_m);
    assert_eq!(after.replans, 0);
    assert_eq!(core.get_int(var(PLANNER_VARS, "replan_count")).unwrap(), 0);
    assert_eq!(
        core.get_real(var(PLANNER_VARS, "landmark_x_m"), 0, 60.0)
            .unwrap(),
        40.0
    );
    // the evaluation is at the plan's altitudes, against the moved landmark
    let want = evaluate_at(&after.mission, &after.traj, after.altitudes_m.as_deref()).unwrap();
    assert_eq!(after.eval, want);
    assert_eq!(
        core.get_real(var(PLANNER_VARS, "z_m"), 0, 60.0).unwrap(),
        before.altitudes_m.as_ref().unwrap()[119]
    );
}
