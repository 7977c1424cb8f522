//! Refusals are proven, a plan not found says so with the best plan it has, and every plan
//! carries its energy bound; the start obeys the acceleration limit from the instantaneous
//! start velocity (a_max δ/2 into the first slot).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use planner::evaluate::ResolutionMode;
use planner::{
    evaluate, plan, Dynamics, LandmarkWindow, LandmarksSpec, Mission, Params, PlanError,
    PlanOptions,
};

fn mission_file(name: &str) -> Mission {
    Mission::from_path(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../missions")
            .join(format!("{name}.toml")),
    )
    .unwrap()
}

fn strict() -> PlanOptions {
    PlanOptions {
        resolution: ResolutionMode::General,
        strict_resolution: true,
        ..PlanOptions::default()
    }
}

/// The L-shaped mission starts at rest 2.2 km away: phase I from the coarse start stalls on the
/// acceleration limit, but the best effort's plan resolves every slot, so the strict plan
/// exists and is found from it.
#[test]
fn the_l_shaped_mission_plans_under_strict_resolution() {
    let m = mission_file("l-shaped");
    let r = plan(&m, &strict()).unwrap();
    assert!(r.is_feasible(), "{:?}", r.evaluation.violations);
    let ev = evaluate(&m, &r.trajectory);
    assert!(ev.is_feasible_with(ResolutionMode::General, Dynamics::Vehicle));
    let b = r.bound.expect("every plan carries its bound");
    assert!(b.energy_j <= ev.energy_j, "{b:?} vs {}", ev.energy_j);
    // the transit from the start is counted
    assert!(b.energy_j > b.slot_floor_j, "{b:?}");
}

/// A landmark beyond reach is refused with the bound's certificate (exit code 3), under either
/// vehicle model, naming its slot: from the first landmark's last slot (t = 10 s) the UAV must
/// fly 3000 − 2 × 1200 = 600 m by slot 41 (t = 20.5 s), and 21 slots at 50 m/s cover 525 m.
#[test]
fn a_refusal_carries_its_certificate() {
    let mut p = Params::default();
    p.horizon_s = 30.0;
    p.start_m = [-1000.0, 0.0];
    let spec = LandmarksSpec {
        points: Some(vec![
            LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: 10.0,
            },
            LandmarkWindow {
                x_m: 3000.0,
                y_m: 0.0,
                from_s: 20.0,
                to_s: 30.0,
            },
        ]),
        ..Default::default()
    };
    let m = Mission::new("too far", p, &spec).unwrap();
    for options in [PlanOptions::least_energy(), PlanOptions::default()] {
        match plan(&m, &options) {
            Err(PlanError::Infeasible(i)) => {
                assert_eq!(i.slot, 41, "{i}");
                assert!(i.reason.contains("cannot be in view"), "{i}");
            }
            other => panic!("expected a refusal, got {other:?}"),
        }
    }
}

/// From rest, the first slot's average velocity is at most a_max δ/2 (constant acceleration
/// from v₀ = 0 covers a_max δ²/2 in δ): every plan of a mission that starts at rest keeps it,
/// and the evaluation counts the first slot's change over δ/2.
#[test]
fn the_first_slot_obeys_the_acceleration_limit_from_the_start_velocity() {
    let m = mission_file("l-shaped");
    let p = m.params();
    assert_eq!(m.start_velocity_mps(), [0.0, 0.0]);
    let r = plan(&m, &PlanOptions::least_energy()).unwrap();
    let v1 = r.trajectory.velocity_mps(1);
    let change = v1[0].hypot(v1[1]);
    assert!(
        change <= p.max_accel_mps2 * p.slot_s / 2.0 * (1.0 + 1e-6),
        "{change} m/s in the first slot, at most {} possible",
        p.max_accel_mps2 * p.slot_s / 2.0
    );
    let ev = evaluate(&m, &r.trajectory);
    assert!((ev.slots[0].accel_mps2 - change / (p.slot_s / 2.0)).abs() < 1e-9);
    assert!(ev.is_flyable());
}
