//! The first slot under the vehicle dynamics: the start velocity v₀ is an instant's (a mission's
//! start) or the average of the slot flown before (a re-plan's splice), and the first slot's
//! average velocity may differ from it by a_max δ/2 or a_max δ. Checked on the plan's positions,
//! not on the evaluator: from v₀ at constant acceleration a, q₁ = q₀ + v₀ δ + a δ²/2.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use planner::evaluate::ResolutionMode;
use planner::{evaluate, Dynamics, Mission, MissionFile, PlanOptions, StartVelocityKind};

/// A mission from rest whose only landmark comes late (the least-energy plan accelerates at once
/// towards the least-power speed), its start velocity of `kind`.
fn from_rest(kind: StartVelocityKind) -> Mission {
    let text = "name = \"from rest\"\n[params]\nhorizon_s = 30\nstart_m = [-600.0, 0.0]\n\
                start_velocity_mps = [0.0, 0.0]\n\
                [landmarks]\npoints = [{ x_m = 0.0, y_m = 300.0, from_s = 25.0, to_s = 30.0 }]\n";
    let m = Mission::from_file_struct(&MissionFile::from_toml_str(text).unwrap()).unwrap();
    assert_eq!(m.params().start_velocity_kind, StartVelocityKind::Instant);
    let mut p = m.params().clone();
    p.start_velocity_kind = kind;
    m.with_params(p).unwrap()
}

/// ‖q₁ − q₀ − v₀ δ‖ of `mission`'s vehicle plan, and the mission's a_max δ².
fn first_slot_deviation_m(mission: &Mission) -> (f64, f64) {
    let options = PlanOptions {
        resolution: ResolutionMode::Paper,
        dynamics: Dynamics::Vehicle,
        ..Default::default()
    };
    let plan = planner::plan(mission, &options).unwrap();
    assert!(
        plan.evaluation.is_feasible(),
        "{:?}",
        plan.evaluation.violations
    );
    let p = mission.params();
    let (q0, q1) = (plan.trajectory.start_m, plan.trajectory.q(1));
    let v0 = mission.start_velocity_mps();
    let d = [
        q1[0] - q0[0] - v0[0] * p.slot_s,
        q1[1] - q0[1] - v0[1] * p.slot_s,
    ];
    // the evaluator's first-slot acceleration is the same quantity over its window
    let ev = evaluate(mission, &plan.trajectory);
    let window = planner::evaluate::accel_window_s(p, 1);
    let from_positions = d[0].hypot(d[1]) / (p.slot_s * window);
    assert!(
        (ev.slots[0].accel_mps2 - from_positions).abs() <= 1e-9 * from_positions.max(1.0),
        "{} against {from_positions}",
        ev.slots[0].accel_mps2
    );
    (d[0].hypot(d[1]), p.max_accel_mps2 * p.slot_s * p.slot_s)
}

#[test]
fn from_an_instant_the_first_slot_moves_at_most_half_a_max_delta_squared() {
    let (dev, a_dd) = first_slot_deviation_m(&from_rest(StartVelocityKind::Instant));
    // at most a_max δ²/2 (the planner keeps 1e-6 inside), and the plan uses that room
    assert!(dev <= 0.5 * a_dd * (1.0 + 1e-6), "{dev} > {}", 0.5 * a_dd);
    assert!(
        dev >= 0.45 * a_dd,
        "{dev}: the plan does not accelerate at once"
    );
}

#[test]
fn from_a_previous_slots_average_the_first_slot_moves_up_to_a_max_delta_squared() {
    let (dev, a_dd) = first_slot_deviation_m(&from_rest(StartVelocityKind::PreviousSlot));
    assert!(dev <= a_dd * (1.0 + 1e-6), "{dev} > {a_dd}");
    // more than an instant's start allows: the kind is what sets the room
    assert!(dev > 0.75 * a_dd, "{dev}");
}
