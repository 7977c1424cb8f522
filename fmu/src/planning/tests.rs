//! Unit tests of the planner calls, and the short mission the crate's tests share.

use super::*;
use planner::geometry::{Point2, RIGHT_TURN};

/// A 20 s mission of two landmark windows, for the tests of this crate.
pub(crate) const SHORT: &str = r#"name = "short"
[params]
horizon_s = 20
[landmarks]
points = [
  { x_m = 0, y_m = 0, from_s = 0, to_s = 10 },
  { x_m = 0, y_m = 30, from_s = 10, to_s = 20 },
]
"#;

/// [`SHORT`] as a mission.
pub(crate) fn short_mission() -> Mission {
    Mission::from_file_struct(&planner::MissionFile::from_toml_str(SHORT).unwrap()).unwrap()
}

#[test]
fn replan_skips_delays_the_reach_bound_rules_out() {
    let mission = short_mission();
    let current = plan(&mission, None).unwrap().trajectory;
    let p = mission.params();
    let from = 5;
    // out of reach of the next two slots, within reach of the third
    let q = current.q(from);
    let hop = (p.max_speed_mps * p.slot_s).hypot(p.centre_offset_m());
    let d = hop + p.sensing_radius_m + 1.5 * p.max_speed_mps * p.slot_s;
    let g = current.q(from + 1);
    let u = (Point2::from(g) - Point2::from(q)).normalize();
    // to the right of the track, where the centre is
    let moved = (Point2::from(q) + RIGHT_TURN * u * d).into();
    let re = replan(
        &mission,
        &current,
        from,
        0,
        moved,
        &ReplanOptions::default(),
    )
    .unwrap();
    assert_eq!(
        re.attempts[0].window,
        WindowPlan::Delayed(2),
        "{}",
        re.summary
    );
    assert!(
        re.summary.contains("delays below 2 skipped"),
        "{}",
        re.summary
    );
    assert!(re.transition_slots >= 2);
    assert!(re.summary.contains(&describe_attempts(&re.attempts)));
}

#[test]
fn the_sub_mission_starts_with_the_velocity_flown() {
    let mission = short_mission();
    let current = plan(&mission, None).unwrap().trajectory;
    let p = mission.params();
    let rest = remainder(&mission, &current, None, 5, 0);
    let v = rest.sub_params.start_velocity_mps.unwrap();
    let (a, b) = (current.q(4), current.q(5));
    for i in 0..2 {
        assert!((v[i] - (b[i] - a[i]) / p.slot_s).abs() < 1e-9, "{v:?}");
    }
    assert_eq!(rest.sub_params.start_m, b);
    // from the start, the mission's own start rule
    let rest = remainder(&mission, &current, None, 0, 0);
    assert_eq!(rest.sub_params.start_velocity_mps, p.start_velocity_mps);
}

#[test]
fn replan_leaves_an_unreachable_window_out() {
    let mission = short_mission();
    let current = plan(&mission, None).unwrap().trajectory;
    let re = replan(
        &mission,
        &current,
        5,
        0,
        [9e4, 0.0],
        &ReplanOptions::default(),
    )
    .unwrap();
    assert!(re.window_dropped);
    assert_eq!(re.transition_slots, 15);
    // no planner call for a delay: the window is out of reach in all its slots
    assert_eq!(re.attempts.len(), 1);
    assert_eq!(re.attempts[0].window, WindowPlan::Dropped);
    let eval = planner::evaluate(&re.mission, &re.trajectory);
    assert_eq!(eval.slots_out_of_view, 20);
}

#[test]
fn attempts_are_described_with_their_times() {
    let a = [
        Attempt {
            window: WindowPlan::Delayed(0),
            solve_s: 9.5124,
            error: Some("infeasible".into()),
        },
        Attempt {
            window: WindowPlan::Delayed(1),
            solve_s: 0.21,
            error: None,
        },
    ];
    assert_eq!(
        describe_attempts(&a),
        "delay 0: failed after 9.512 s (infeasible); delay 1: 0.210 s"
    );
}
