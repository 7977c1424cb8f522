//! Times receding-horizon re-plans of the default mission (a landmark moved by (40, 20) m in the
//! middle of a window), with and without warm start from the rest of the current plan.
//!
//! ```text
//! cargo run --release -p fmu --example replan-bench
//! ```

use anyhow::{Context, Result};
use planner::{Mission, MissionFile};

fn main() -> Result<()> {
    planner::init_logging("error");
    let mission = Mission::from_file_struct(
        &MissionFile::from_toml_str(fmu::core::DEFAULT_MISSION_TOML).map_err(anyhow::Error::msg)?,
    )?;
    let full = fmu::planning::plan(&mission, None).map_err(anyhow::Error::msg)?;
    println!("initial plan: {}", full.summary);
    println!("| move at t [s] | slots re-planned | warm [s] | warm, 5 it [s] | cold [s] | cold, 5 it [s] |");
    println!("|---|---|---|---|---|---|");
    let times: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let times = if times.is_empty() {
        vec![5.0, 65.0, 125.0, 185.0, 245.0, 295.0]
    } else {
        times
    };
    for t_move in times {
        let from = (t_move / 0.5_f64).round() as usize;
        let window = mission.schedule().slot_landmark[from].context("no landmark in that slot")?;
        let w = mission.schedule().landmarks[window];
        let moved = [w.x_m + 40.0, w.y_m + 20.0];
        let mut times = Vec::new();
        use fmu::planning::WarmStart::*;
        for (warm_start, max_iterations, tolerance) in [
            (Always, 200, 1e-4),
            (Always, 5, 1e-3),
            (Never, 200, 1e-4),
            (Never, 5, 1e-3),
        ] {
            let o = fmu::planning::ReplanOptions {
                warm_start,
                max_iterations,
                tolerance,
            };
            let r = fmu::planning::replan(&mission, &full.trajectory, from, window, moved, &o);
            times.push(match r {
                Ok(re) => format!(
                    "{:.3} ({} J, excess {:.1} m, {})",
                    re.solve_s,
                    planner::evaluate(&re.mission, &re.trajectory)
                        .energy_j
                        .round(),
                    re.start_excess_m,
                    if re.warm { "warm" } else { "cold" }
                ),
                Err(e) => format!("failed: {e:?}"),
            });
        }
        println!(
            "| {t_move} | {} | {} |",
            mission.slots() - from,
            times.join(" | ")
        );
    }
    Ok(())
}
