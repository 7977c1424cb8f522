//! Output files of a plan: `mission.toml`, `trajectory.csv`, `summary.json`, `trajectory.svg`,
//! `energy.svg`, `convergence.svg`, and `altitude.svg` for a free-altitude plan; and reading a
//! plan directory back.

pub mod image_svg;
pub mod plot;
pub mod reproduce;
pub mod resolution;
pub mod tradeoff;

use std::path::{Path, PathBuf};

use crate::services::os::write_file_atomic;
use planner::driver::{PlanResult, Scheme};
use planner::summary::{trajectory_csv, Summary};
use planner::{Mission, MissionError, Trajectory, TrajectoryError};
use plot::{altitude_plot, line_plot, trajectory_plot, Series, TrackStyle};

/// Writing or reading report files failed. A variant whose message includes its cause does
/// not also return it from `source()` (each cause is printed once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// File system error, with the path.
    #[error("{path}: {error}")]
    Io {
        /// The file or directory.
        path: String,
        /// The I/O error (in the message).
        error: std::io::Error,
    },
    /// A plot could not be drawn.
    #[error("plot {path}: {message}")]
    Plot {
        /// The output file.
        path: String,
        /// The plotting library's message.
        message: String,
    },
    /// Serialisation failed.
    #[error("{path}: {message}")]
    Encode {
        /// The output file.
        path: String,
        /// The encoder's message.
        message: String,
    },
    /// The mission file of a plan directory is invalid.
    #[error(transparent)]
    Mission(#[from] MissionError),
    /// The trajectory file of a plan directory is invalid.
    #[error(transparent)]
    Trajectory(#[from] TrajectoryError),
}

/// The plan's jerk against the mission's jerk limit and the room it keeps inside each limit
/// under the mission's margins, as one line for the command line and `report.md`; `None` for
/// a mission with neither (whose output stays as it was).
pub fn vehicle_limits_line(s: &Summary) -> Option<String> {
    let mut parts = Vec::new();
    if let Some(j) = &s.jerk {
        parts.push(format!(
            "peak jerk {:.2} m/s³ between slot accelerations, {} slots above the {:.2} m/s³ \
             limit (max_jerk_mps3)",
            j.max_jerk_mps3, j.slots_over_jerk_limit, j.jerk_limit_mps3
        ));
    }
    if let Some(m) = &s.margins {
        let pct = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.1} %"));
        let [r, a, j] = m.requested_pct;
        parts.push(format!(
            "planned with margins of {r} % (resolution), {a} % (acceleration), {j} % (jerk); \
             least room kept inside the limits: cell {} (resolved slots; {} of them short of \
             the margin), azimuth {}, acceleration {:.1} %, jerk {}",
            pct(m.cell_room_pct),
            m.slots_short_of_margin,
            pct(m.azimuth_room_pct),
            m.accel_room_pct,
            pct(m.jerk_room_pct)
        ));
    }
    (!parts.is_empty()).then(|| parts.join("; "))
}

/// A best effort's least-energy plan is measured against the d_min the plans were made for:
/// with a resolution margin, d_min less the margin. This note says so (" (against the planned
/// d_min = 19 m)"), empty without a margin.
pub fn least_energy_basis_note(s: &Summary) -> String {
    match (&s.best_effort, &s.resolution_shortfall) {
        (Some(b), Some(r)) if b.least_energy_shortfall.d_min_m != r.d_min_m => format!(
            " (against the planned d_min = {} m)",
            b.least_energy_shortfall.d_min_m
        ),
        _ => String::new(),
    }
}

/// Writes `text` to `path` atomically ([`write_file_atomic`]: a reader never sees a part of
/// it), naming the path on error.
pub fn write_file(path: &Path, text: &str) -> Result<(), ReportError> {
    write_file_atomic(path, text.as_bytes()).map_err(|e| ReportError::Io {
        path: e.path.display().to_string(),
        error: e.error,
    })
}

/// Creates a directory (and parents).
pub fn create_dir(dir: &Path) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(|error| ReportError::Io {
        path: dir.display().to_string(),
        error,
    })
}

/// Slots whose sensing circles are drawn: a few spread over the mission.
pub fn circle_slots(slots: usize, count: usize) -> Vec<usize> {
    if slots == 0 || count == 0 {
        return Vec::new();
    }
    (0..count)
        .map(|k| 1 + (k * (slots - 1)) / count.max(1))
        .collect()
}

/// Writes a plan directory: `mission.toml`, `trajectory.csv`, `summary.json`, `trajectory.svg`,
/// `energy.svg`, `convergence.svg`, and for a plan with altitudes per slot
/// ([`PlanResult::altitudes_m`]) `altitude.svg` (no side view for a fixed mission: its one
/// altitude is a flat line). Returns the files written.
pub fn write_plan_dir(
    dir: &Path,
    mission: &Mission,
    result: &PlanResult,
) -> Result<Vec<PathBuf>, ReportError> {
    create_dir(dir)?;
    let mut written = Vec::new();
    let path = dir.join("mission.toml");
    let toml = mission
        .to_file_struct()
        .to_toml_string()
        .map_err(|message| ReportError::Encode {
            path: path.display().to_string(),
            message,
        })?;
    write_file(&path, &toml)?;
    written.push(path);

    let path = dir.join("trajectory.csv");
    let csv = trajectory_csv(result).map_err(|e| ReportError::Encode {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    write_file(&path, &csv)?;
    written.push(path);

    let path = dir.join("summary.json");
    let encode_error = |e: serde_json::Error| ReportError::Encode {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    let mut value = serde_json::to_value(Summary::new(mission, result)).map_err(encode_error)?;
    // Only in the file (the summary is also a wire message, whose layout stays fixed): why a
    // given `--init` path was replaced by the built-in start.
    if let (Some(reason), Some(map)) = (&result.init_replaced, value.as_object_mut()) {
        map.insert(
            "init_replaced".to_string(),
            serde_json::Value::String(reason.clone()),
        );
    }
    let json = serde_json::to_string_pretty(&value).map_err(encode_error)?;
    write_file(&path, &json)?;
    written.push(path);

    let path = dir.join("trajectory.svg");
    let circles = circle_slots(mission.slots(), 6);
    trajectory_plot(
        &path,
        &format!("{} — scheme {}", mission.name(), result.scheme),
        mission,
        &[TrackStyle {
            name: result.scheme.name(),
            traj: &result.trajectory,
            circle_slots: &circles,
            dashed: false,
        }],
    )?;
    written.push(path);

    let path = dir.join("energy.svg");
    let ev = &result.evaluation;
    line_plot(
        &path,
        &format!(
            "energy per slot — {} (total {:.0} J)",
            result.scheme, ev.energy_j
        ),
        "t (s)",
        "energy per slot (J)",
        &[Series::line(
            result.scheme.name(),
            ev.slots.iter().map(|s| (s.t_s, s.slot_energy_j)).collect(),
        )],
    )?;
    written.push(path);

    let path = dir.join("convergence.svg");
    let mut series = vec![Series {
        name: "optimiser objective".into(),
        points: result
            .objective_history
            .iter()
            .enumerate()
            .map(|(i, v)| ((i + 1) as f64, *v))
            .collect(),
        markers: true,
        dashed: false,
        colour: None,
    }];
    if matches!(result.scheme, Scheme::Exact | Scheme::Paper) {
        series.push(Series {
            name: "true energy".into(),
            points: result
                .true_energy_history
                .iter()
                .enumerate()
                .map(|(i, v)| ((i + 1) as f64, *v))
                .collect(),
            markers: true,
            dashed: true,
            colour: None,
        });
    }
    line_plot(
        &path,
        &format!("convergence — {}", result.scheme),
        "iteration",
        if matches!(result.scheme, Scheme::Exact | Scheme::Paper) {
            "J"
        } else {
            "m"
        },
        &series,
    )?;
    written.push(path);

    // a free-altitude plan's side view; a fixed mission flies one altitude (in mission.toml)
    if let Some(altitudes_m) = &result.altitudes_m {
        let path = dir.join("altitude.svg");
        let slot_s = mission.params().slot_s;
        let profile_m: Vec<(f64, f64)> = std::iter::once((0.0, mission.params().altitude_m))
            .chain(
                altitudes_m
                    .iter()
                    .enumerate()
                    .map(|(i, z)| ((i + 1) as f64 * slot_s, *z)),
            )
            .collect();
        altitude_plot(
            &path,
            &format!("altitude — {}", mission.name()),
            mission,
            &profile_m,
        )?;
        written.push(path);
    }
    Ok(written)
}

/// Reads a plan directory written by [`write_plan_dir`]: the mission and the trajectory.
pub fn read_plan_dir(dir: &Path) -> Result<(Mission, Trajectory), ReportError> {
    let mission = Mission::from_path(&dir.join("mission.toml"))?;
    let p = mission.params();
    let traj = Trajectory::from_csv_path(
        &dir.join("trajectory.csv"),
        p.slot_s,
        mission.slots(),
        p.start_m,
        p.altitude_m,
    )?;
    Ok((mission, traj))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn report_files_are_replaced_whole_and_a_failed_write_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("RESULTS.md");
        write_file(&path, "first, longer").unwrap();
        write_file(&path, "second").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "second");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["RESULTS.md"]);
        let missing = dir.path().join("missing").join("plot.svg");
        let e = write_file(&missing, "x").unwrap_err();
        assert!(matches!(e, ReportError::Io { .. }), "{e:?}");
        assert!(
            e.to_string().starts_with(&missing.display().to_string()),
            "{e}"
        );
        // a plot is written the same way
        let e = plot::line_plot(&missing, "t", "x", "y", &[]).unwrap_err();
        assert!(e.to_string().contains("plot.svg"), "{e}");
    }

    /// The `vehicle limits:` line: absent for a mission without a jerk limit or margins (its
    /// output as before), the peak jerk against the limit and the room kept with them.
    #[test]
    fn the_vehicle_limits_line_names_the_jerk_limit_and_the_margins_kept() {
        let mission = |extra: &str| {
            let text = format!(
                "[params]\nhorizon_s = 30\nstart_m = [-600.0, 0.0]\n\
                 start_velocity_mps = [0.0, 0.0]\n{extra}\n[landmarks]\n\
                 points = [{{ x_m = 0.0, y_m = 300.0, from_s = 25.0, to_s = 30.0 }}]\n"
            );
            Mission::from_file_struct(&planner::MissionFile::from_toml_str(&text).unwrap()).unwrap()
        };
        let line = |m: &Mission| {
            let plan = planner::plan(m, &planner::PlanOptions::least_energy()).unwrap();
            vehicle_limits_line(&Summary::new(m, &plan))
        };
        assert_eq!(line(&mission("")), None);
        // a best effort with a resolution margin says what its least-energy plan is measured
        // against
        let m = mission("resolution_margin_pct = 5");
        let plan = planner::plan(&m, &planner::PlanOptions::default()).unwrap();
        assert_eq!(
            least_energy_basis_note(&Summary::new(&m, &plan)),
            " (against the planned d_min = 19 m)"
        );
        let text = line(&mission("max_jerk_mps3 = 4\naccel_margin_pct = 10")).unwrap();
        assert!(
            text.starts_with("peak jerk 4.00 m/s³")
                && text.contains("0 slots above the 4.00 m/s³ limit (max_jerk_mps3)")
                && text.contains("margins of 0 % (resolution), 10 % (acceleration)")
                && text.contains("acceleration 10.0 %"),
            "{text}"
        );
    }

    /// A free-altitude plan's directory has `altitude.svg` (listed among the files written)
    /// with its bounds and rates; the same plan without altitudes (a fixed one) has none.
    #[test]
    fn a_free_plan_directory_has_its_altitude_side_view() {
        let text = include_str!("../../../missions/only-a-lower-altitude.toml");
        let m =
            Mission::from_file_struct(&planner::MissionFile::from_toml_str(text).unwrap()).unwrap();
        let options = planner::PlanOptions {
            altitude_profile: true,
            ..planner::PlanOptions::least_energy()
        };
        let r = planner::plan(&m, &options).unwrap();
        assert!(r.altitudes_m.is_some());
        let dir = tempfile::tempdir().unwrap();
        let written = write_plan_dir(dir.path(), &m, &r).unwrap();
        let path = dir.path().join("altitude.svg");
        assert!(written.contains(&path), "{written:?}");
        let svg = std::fs::read_to_string(&path).unwrap();
        for text in [
            "min_altitude_m = 800 m",
            "max_altitude_m = 1000 m",
            "descent ≤ 5.0 m/s",
            "altitude z_m",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        let fixed = PlanResult {
            altitudes_m: None,
            ..r
        };
        let dir = tempfile::tempdir().unwrap();
        let written = write_plan_dir(dir.path(), &m, &fixed).unwrap();
        assert!(!dir.path().join("altitude.svg").exists(), "{written:?}");
        assert_eq!(written.len(), 6);
    }
}
