//! Refusals are proven, a plan not found says so with the best plan it has, and every plan
//! carries its energy bound.

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

/// The L-shaped mission starts at rest 2.2 km away: phase I cannot repair the coarse start under
/// the strict general cell, but another start of the planner's it can, so the strict plan
/// exists and is found (it was refused, exit 3, when phase I had one start).
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
