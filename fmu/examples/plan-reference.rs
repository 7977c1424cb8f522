//! Reference plans for the fmpy tests, with the same command line as `cellsar-planner plan`:
//!
//! ```text
//! cargo run --release -p fmu --example plan-reference -- plan MISSION --out DIR
//! ```
//!
//! Reads the mission file, plans it with `planner::plan` and the default options, and writes the
//! plan directory (`trajectory.csv`, `mission.toml`, `summary.json`, plots) with
//! `planner::report::write_plan_dir`. The FMU must reproduce `trajectory.csv`.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mission, out) = match args.as_slice() {
        [cmd, mission, flag, out] if cmd == "plan" && flag == "--out" => {
            (PathBuf::from(mission), PathBuf::from(out))
        }
        _ => bail!("usage: plan-reference plan MISSION --out DIR"),
    };
    let m = planner::Mission::from_path(&mission)
        .with_context(|| format!("reading {}", mission.display()))?;
    let result = planner::plan(&m, &planner::PlanOptions::default())
        .with_context(|| format!("planning {}", mission.display()))?;
    planner::report::write_plan_dir(&out, &m, &result)
        .with_context(|| format!("writing {}", out.display()))?;
    println!(
        "{}: true energy {:.3} J, {} iterations, {:.3} s",
        m.name(),
        result.evaluation.energy_j,
        result.iterations,
        result.solve_seconds
    );
    Ok(())
}
