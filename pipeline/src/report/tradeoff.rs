//! Output files of the energy–resolution trade-off (`cellsar-planner tradeoff`): `tradeoff.csv`,
//! `tradeoff.svg` and the plan directory of every point.

use std::path::{Path, PathBuf};

use planner::tradeoff::TradeoffPoint;
use planner::Mission;

use super::plot::{line_plot, Series};
use super::{create_dir, write_file, write_plan_dir, ReportError};

/// The columns of `tradeoff.csv`.
pub const TRADEOFF_COLUMNS: [&str; 10] = [
    "point",
    "cap_pct",
    "energy_j",
    "extra_energy_pct",
    "unresolved_windows",
    "unresolved_slots",
    "total_excess_width_m",
    "total_deficit_m",
    "solve_s",
    "plan_dir",
];

/// The folder of point `i` inside the trade-off directory.
pub fn point_dir_name(i: usize) -> String {
    format!("point_{i:02}")
}

/// Writes `tradeoff.csv`, `tradeoff.svg` and `point_NN/` (a plan directory each) into `dir`.
/// Returns the files written (the plan directories' files not listed one by one).
pub fn write_tradeoff_dir(
    dir: &Path,
    mission: &Mission,
    points: &[TradeoffPoint],
) -> Result<Vec<PathBuf>, ReportError> {
    create_dir(dir)?;
    let mut written = Vec::new();
    for (i, p) in points.iter().enumerate() {
        let sub = dir.join(point_dir_name(i));
        write_plan_dir(&sub, mission, &p.plan)?;
        written.push(sub);
    }
    let path = dir.join("tradeoff.csv");
    write_file(&path, &tradeoff_csv(points, &path)?)?;
    written.push(path);

    let path = dir.join("tradeoff.svg");
    let series = |name: &str, y: fn(&TradeoffPoint) -> f64| Series {
        markers: true,
        ..Series::line(
            name,
            points.iter().map(|p| (p.extra_energy_pct, y(p))).collect(),
        )
    };
    line_plot(
        &path,
        &planner::tradeoff::plot_title(mission.name(), points),
        &planner::tradeoff::energy_axis_label(points),
        "landmark windows (slots / 20) with a cell wider than d_min",
        &[
            series("unresolved windows", |p| {
                p.shortfall.unresolved_windows as f64
            }),
            series("unresolved slots / 20", |p| {
                p.shortfall.unresolved_slots as f64 / 20.0
            }),
        ],
    )?;
    written.push(path);
    Ok(written)
}

/// The text of `tradeoff.csv` (`path` only names the file in errors).
fn tradeoff_csv(points: &[TradeoffPoint], path: &Path) -> Result<String, ReportError> {
    let encode = |message: String| ReportError::Encode {
        path: path.display().to_string(),
        message,
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(TRADEOFF_COLUMNS)
        .map_err(|e| encode(e.to_string()))?;
    for (i, p) in points.iter().enumerate() {
        let s = &p.shortfall;
        w.write_record([
            i.to_string(),
            p.cap_pct.map_or("none".to_string(), |c| c.to_string()),
            p.plan.evaluation.energy_j.to_string(),
            p.extra_energy_pct.to_string(),
            s.unresolved_windows.to_string(),
            s.unresolved_slots.to_string(),
            s.total_excess_width_m.to_string(),
            s.total_deficit_m.to_string(),
            p.plan.solve_seconds.to_string(),
            point_dir_name(i),
        ])
        .map_err(|e| encode(e.to_string()))?;
    }
    let bytes = w.into_inner().map_err(|e| encode(e.to_string()))?;
    String::from_utf8(bytes).map_err(|e| encode(e.to_string()))
}
