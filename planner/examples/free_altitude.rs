//! Fixed against free altitude: plans a mission at its fixed altitude and with
//! `altitude = "free"` between two bounds (the `exact` scheme, jointly,
//! [`PlanOptions::altitude_profile`]), and prints each plan's true energy, wall time, altitude
//! range, feasibility, slots out of view and unresolved (worst width, the cell's longest chord,
//! over d_min), cone programs, iterations and alternations, with the floor T min_V P(V) that no
//! plan at any altitudes goes below. With `paper` it also plans the scheme `paper` at the fixed
//! altitude and by the paper's alternation (altitude step, then Algorithm 1), in the same run.
//! The landmarks' SNR of such plans, from the radar's link budget, is the radar simulator's
//! (`cargo run --release -p radar-sim --example landmark_snr`).
//!
//! `cargo run --release -p planner --example free_altitude -- MISSION.toml MIN_M MAX_M [paper] [records]`
//! (`paper`: the least-energy plans, the paper's resolution; default: the default options, the
//! general resolution as a best effort, which the scheme `paper` does not plan; `records`: the
//! joint plan's iterations).

use std::path::Path;
use std::time::Instant;

use planner::driver::ALTERNATION_PHASE;
use planner::evaluate::ResolutionMode;
use planner::{
    plan_with_observer, AltitudeMode, IterationRecord, Mission, Observer, PlanOptions, PlanResult,
    Scheme,
};

/// Counts the alternations of a plan by the scheme `paper`.
#[derive(Default)]
struct Alternations(usize);
impl Observer for Alternations {
    fn on_phase(&mut self, phase: &str) {
        if phase == ALTERNATION_PHASE {
            self.0 += 1;
        }
    }
    fn on_iteration(&mut self, _record: &IterationRecord) {}
}

/// Plans `mission` with `options`, timed, counting alternations.
fn timed(mission: &Mission, options: &PlanOptions) -> Result<(PlanResult, f64, usize), String> {
    let mut count = Alternations::default();
    let started = Instant::now();
    let r = plan_with_observer(mission, options, &mut count).map_err(|e| e.to_string())?;
    Ok((r, started.elapsed().as_secs_f64(), count.0))
}

fn row(label: &str, r: &PlanResult, seconds: f64, alternations: usize) {
    let (lo, hi) = match &r.altitudes_m {
        Some(z) => z
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            }),
        None => (r.evaluation.start_altitude_m, r.evaluation.start_altitude_m),
    };
    println!(
        "{label:<7} {:>10.1} {:>8.2} {:>6.0}-{:<6.0} {:>8} {:>11} {:>10} {:>8} {:>10} {:>12}",
        r.evaluation.energy_j,
        seconds,
        lo,
        hi,
        r.is_feasible(),
        r.evaluation.slots_out_of_view,
        r.evaluation.slots_unresolved,
        r.cone_programs,
        r.iterations,
        alternations
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
    println!(
        "plan      energy_j   time_s  altitude_m  feasible out_of_view unresolved programs iterations alternations"
    );
    let paper = rest.iter().any(|a| a == "paper");
    let (fixed, seconds, _) = timed(&mission, &options)?;
    row("fixed", &fixed, seconds, 0);
    let mut free = p.clone();
    free.altitude = AltitudeMode::Free;
    free.min_altitude_m = Some(lo.parse()?);
    free.max_altitude_m = Some(hi.parse()?);
    let free_mission = mission.with_params(free)?;
    options.altitude_profile = true;
    let (joint, seconds, _) = timed(&free_mission, &options)?;
    row("joint", &joint, seconds, 0);
    if paper {
        let paper_options = PlanOptions::for_scheme(Scheme::Paper);
        let (r, seconds, _) = timed(&mission, &paper_options)?;
        row("paper", &r, seconds, 0);
        let paper_free = PlanOptions {
            altitude_profile: true,
            ..paper_options
        };
        let (alt, seconds, alternations) = timed(&free_mission, &paper_free)?;
        row("altern", &alt, seconds, alternations);
        // what each alternation's 2-D step reached, accepted or not
        for rec in alt.records[r.records.len()..]
            .iter()
            .filter(|x| !x.accepted)
        {
            println!(
                "  rejected alternation ends at iteration {}: true energy {:.1} J, largest sensing violation {:.1} m",
                rec.iteration, rec.true_energy_j, rec.sensing_violation_m
            );
        }
        println!("  alternation: {}", alt.termination);
    }
    if rest.iter().any(|a| a == "records") {
        for r in &joint.records[fixed.records.len()..] {
            println!(
                "  iteration {:>3} objective {:>10.2} true energy {:>10.2} accepted {}",
                r.iteration, r.objective, r.true_energy_j, r.accepted
            );
        }
    }
    Ok(())
}
