//! What altitude does to a fixed-altitude plan: plans a mission at its fixed altitude (the
//! default `exact` scheme), then evaluates the same 2-D track under altitude profiles that
//! descend from `altitude_m` at the mission's descent limit to a floor and hold it
//! ([`planner::evaluate::evaluate_with_altitudes`]). Descent costs no energy in the power model
//! ([`planner::PowerModel::climb_w`]), so each profile's energy is the plan's; the table shows
//! what the lower altitude does to the constraints along the unchanged track. The first line
//! gives the floor T min_V P(V) that no plan at any altitudes goes below (the climb power is
//! never negative), which bounds what free altitude can save.
//!
//! `cargo run --release -p planner --example altitude_profiles -- MISSION.toml [FLOOR_M ...]`
//! (floors default to 900 800 700 600 m; the mission is evaluated with `altitude = "free"`
//! between the lowest floor and `altitude_m`).

use std::path::Path;
use std::time::Instant;

use planner::evaluate::evaluate_with_altitudes;
use planner::{plan, Mission, PlanOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or("usage: altitude_profiles MISSION.toml [FLOOR_M ...]")?;
    let mission = Mission::from_path(Path::new(&path))?;
    let mut floors: Vec<f64> = args.map(|a| a.parse()).collect::<Result<_, _>>()?;
    if floors.is_empty() {
        floors = vec![900.0, 800.0, 700.0, 600.0];
    }
    let started = Instant::now();
    let result = plan(&mission, &PlanOptions::least_energy())?;
    // no plan, at any altitudes, costs less than T min_V P(V): P(V, v_z) ≥ P(V)
    let model = planner::PowerModel::new(mission.params());
    let floor_j = mission.slots() as f64
        * mission.params().slot_s
        * model.min_power(mission.params().max_speed_mps).1;
    println!(
        "{}: fixed-altitude plan in {:.2} s, {:.1} J; floor of any 3-D plan T min P(V) = {:.1} J",
        mission.name(),
        started.elapsed().as_secs_f64(),
        result.evaluation.energy_j,
        floor_j
    );
    // the same mission with its altitude free down to the lowest floor (the bounds checked)
    let mut free = mission.params().clone();
    free.altitude = planner::AltitudeMode::Free;
    free.min_altitude_m = Some(floors.iter().copied().fold(free.altitude_m, f64::min));
    free.max_altitude_m = Some(free.altitude_m);
    let mission = mission.with_params(free)?;
    let p = mission.params();
    println!("floor_m  energy_j  feasible  out_of_view  unresolved_general  sensing_violation_m");
    let mut rows = vec![p.altitude_m];
    rows.extend(floors);
    for floor in rows {
        let step = p.max_descent_mps * p.slot_s;
        let profile: Vec<f64> = (1..=mission.slots())
            .map(|t| (p.altitude_m - step * t as f64).max(floor))
            .collect();
        let ev = evaluate_with_altitudes(&mission, &result.trajectory, &profile)?;
        println!(
            "{floor:>7.0}  {:>8.1}  {:>8}  {:>11}  {:>18}  {:>19.2}",
            ev.energy_j,
            ev.is_feasible(),
            ev.slots_out_of_view,
            ev.slots_unresolved,
            ev.violations.sensing_m
        );
    }
    Ok(())
}
