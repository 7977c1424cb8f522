//! Fixed against free altitude: plans a mission at its fixed altitude and with
//! `altitude = "free"` between two bounds (the `exact` scheme, [`PlanOptions::altitude_profile`]),
//! and prints each plan's energy, wall time, altitude range, feasibility and unresolved slots,
//! with the floor T min_V P(V) that no plan at any altitudes goes below.
//!
//! `cargo run --release -p planner --example free_altitude -- MISSION.toml MIN_M MAX_M [paper] [records]`
//! (`paper`: the least-energy plans, the paper's resolution; default: the default options, the
//! general resolution as a best effort; `records`: the free plan's iterations).

use std::path::Path;
use std::time::Instant;

use planner::evaluate::ResolutionMode;
use planner::{plan, AltitudeMode, Mission, PlanOptions, PlanResult};

fn row(label: &str, r: &PlanResult, seconds: f64) {
    let (lo, hi) = match &r.altitudes_m {
        Some(z) => z
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            }),
        None => (r.evaluation.start_altitude_m, r.evaluation.start_altitude_m),
    };
    println!(
        "{label:<6} {:>10.1} {:>8.2} {:>6.0}-{:<6.0} {:>8} {:>10} {:>8}",
        r.evaluation.energy_j,
        seconds,
        lo,
        hi,
        r.is_feasible(),
        r.evaluation.slots_unresolved,
        r.cone_programs
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [path, lo, hi, rest @ ..] = args.as_slice() else {
        return Err("usage: free_altitude MISSION.toml MIN_M MAX_M [paper] [records]".into());
    };
    let mission = Mission::from_path(Path::new(path))?;
    let mut options = PlanOptions::default();
    if rest.iter().any(|a| a == "paper") {
        options.resolution = ResolutionMode::Paper;
    }
    let model = planner::PowerModel::new(mission.params());
    let p = mission.params();
    let floor_j = mission.slots() as f64 * p.slot_s * model.min_power(p.max_speed_mps).1;
    println!(
        "{} ({} resolution), floor T min P(V) = {floor_j:.1} J",
        mission.name(),
        options.resolution
    );
    println!("plan     energy_j   time_s  altitude_m  feasible unresolved programs");
    let started = Instant::now();
    let fixed = plan(&mission, &options)?;
    row("fixed", &fixed, started.elapsed().as_secs_f64());
    let mut free = p.clone();
    free.altitude = AltitudeMode::Free;
    free.min_altitude_m = Some(lo.parse()?);
    free.max_altitude_m = Some(hi.parse()?);
    let mission = mission.with_params(free)?;
    options.altitude_profile = true;
    let started = Instant::now();
    let result = plan(&mission, &options)?;
    row("free", &result, started.elapsed().as_secs_f64());
    if rest.iter().any(|a| a == "records") {
        for r in &result.records[fixed.records.len()..] {
            println!(
                "  iteration {:>3} objective {:>10.2} true energy {:>10.2} accepted {}",
                r.iteration, r.objective, r.true_energy_j, r.accepted
            );
        }
    }
    Ok(())
}
