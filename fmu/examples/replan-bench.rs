//! Times receding-horizon re-plans of the default mission (a landmark moved by (40, 20) m in the
//! middle of a window), with and without warm start from the rest of the current plan, and with
//! the warm start repaired on a coarse grid first or on the mission's own slots. Each cell lists
//! the re-plan's time, the spliced plan's true energy, the warm start's sensing excess, the start
//! used, the transition slots and every planner call with its time. `--dynamics` plans the initial
//! plan and every re-plan under that vehicle model (default: the library's,
//! `planner::DEFAULT_DYNAMICS`), as the FMU's parameter `dynamics` does; `--resolution` is the
//! initial plan's (default: the library's; the re-plans are for the paper's, as in the FMU).
//!
//! ```text
//! cargo run --release -p fmu --example replan-bench [-- [T ...] [--offset DX,DY] [--dynamics vehicle|paper] [--resolution general|paper]]
//! ```

use anyhow::{Context, Result};
use planner::{Mission, MissionFile};

fn main() -> Result<()> {
    cellsar_error::init_logging("error");
    let mission = Mission::from_file_struct(
        &MissionFile::from_toml_str(fmu::core::DEFAULT_MISSION_TOML).map_err(anyhow::Error::msg)?,
    )?;
    // arguments: move times in s (default: the six below), `--offset DX,DY` in m (default 40,20)
    // and `--dynamics NAME`
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut offset = [40.0, 20.0];
    let mut dynamics = planner::DEFAULT_DYNAMICS;
    let mut resolution = planner::DEFAULT_RESOLUTION;
    let mut times: Vec<f64> = Vec::new();
    let mut i = 0;
    while i < args.len() {
        if args[i] == "--dynamics" {
            let v = args
                .get(i + 1)
                .context("--dynamics needs vehicle or paper")?;
            dynamics = v
                .parse()
                .with_context(|| format!("--dynamics {v}: vehicle or paper"))?;
            i += 2;
        } else if args[i] == "--resolution" {
            let v = args
                .get(i + 1)
                .context("--resolution needs general or paper")?;
            resolution = v
                .parse()
                .with_context(|| format!("--resolution {v}: general or paper"))?;
            i += 2;
        } else if args[i] == "--offset" {
            let v = args.get(i + 1).context("--offset needs DX,DY")?;
            let (dx, dy) = v.split_once(',').context("--offset DX,DY")?;
            offset = [dx.parse()?, dy.parse()?];
            i += 2;
        } else {
            times.push(args[i].parse().context("a move time in s")?);
            i += 1;
        }
    }
    let options = planner::PlanOptions {
        dynamics,
        resolution,
        ..Default::default()
    };
    let full = fmu::planning::plan_with(&mission, None, &options).map_err(anyhow::Error::msg)?;
    println!(
        "initial plan (resolution {resolution}, {dynamics} dynamics): {}",
        full.summary
    );
    println!("| move at t [s] | slots re-planned | warm [s] | warm, 5 it [s] | warm, 5 it, fine repair [s] | cold [s] | cold, 5 it [s] |");
    println!("|---|---|---|---|---|---|---|");
    let times = if times.is_empty() {
        vec![5.0, 65.0, 125.0, 185.0, 245.0, 295.0]
    } else {
        times
    };
    for t_move in times {
        let from = (t_move / 0.5_f64).round() as usize;
        let window = mission.schedule().slot_landmark[from].context("no landmark in that slot")?;
        let w = mission.schedule().landmarks[window];
        let moved = [w.x_m + offset[0], w.y_m + offset[1]];
        let mut times = Vec::new();
        use fmu::planning::WarmStart::*;
        for (warm_start, max_iterations, tolerance, coarse) in [
            (Always, 200, 1e-4, true),
            (Always, 5, 1e-3, true),
            (Always, 5, 1e-3, false),
            (Never, 200, 1e-4, true),
            (Never, 5, 1e-3, true),
        ] {
            let o = fmu::planning::ReplanOptions {
                warm_start,
                max_iterations,
                tolerance,
                coarse,
                dynamics,
            };
            let r = fmu::planning::replan(&mission, &full.trajectory, from, window, moved, &o);
            times.push(match r {
                Ok(re) => format!(
                    "{:.3} ({} J, excess {:.1} m, {}, {} transition slot(s), calls: {})",
                    re.solve_s,
                    planner::evaluate(&re.mission, &re.trajectory)
                        .energy_j
                        .round(),
                    re.start_excess_m,
                    if re.warm { "warm" } else { "cold" },
                    re.transition_slots,
                    fmu::planning::describe_attempts(&re.attempts)
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
