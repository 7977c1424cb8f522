//! The columns of `trajectory.csv` (`planner::summary::TRAJECTORY_COLUMNS`) as vectors: one
//! row for the start at t = 0, then one per slot, the same values as the CLI's file.

use planner::evaluate::SlotEval;
use planner::Evaluation;

/// The value of column `name` in one slot's row, or `None` for a column this module does not
/// know (the pytest suite compares every column of the CLI's file, so a new one fails there).
fn slot_value(name: &str, e: &SlotEval) -> Option<f64> {
    let landmark = |i: usize| e.landmark_m.map_or(f64::NAN, |l| l[i]);
    Some(match name {
        "t_s" => e.t_s,
        "x_m" => e.pos_m[0],
        "y_m" => e.pos_m[1],
        "speed_mps" => e.speed_mps,
        "heading_rad" => e.heading_rad,
        "xc_m" => e.centre_m[0],
        "yc_m" => e.centre_m[1],
        "landmark_x_m" => landmark(0),
        "landmark_y_m" => landmark(1),
        "in_view" => f64::from(u8::from(e.in_view)),
        "centre_error_m" => e.centre_error_m.unwrap_or(f64::NAN),
        "power_w" => e.power_w,
        "energy_j" => e.energy_j,
        "range_resolution_paper_m" => e.range_resolution_paper_m,
        "range_resolution_general_m" => e.range_resolution_general_m,
        "azimuth_resolution_m" => e.azimuth_resolution_paper_m,
        "bistatic_angle_deg" => e.bistatic_angle_rad.to_degrees(),
        "grad_norm" => e.grad_norm,
        "psi_rad" => e.psi_rad,
        "along_track_width_m" => e.along_track_width_m,
        "cross_track_width_m" => e.cross_track_width_m,
        "worst_width_m" => e.worst_width_m,
        "accel_mps2" => e.accel_mps2,
        "z_m" => e.z_m,
        "climb_mps" => e.climb_mps,
        "jerk_mps3" => e.jerk_mps3,
        _ => return None,
    })
}

/// The value of column `name` in the start row (t = 0): the start position, zero time and
/// energy, `nan` elsewhere.
fn start_value(name: &str, start_m: [f64; 2]) -> f64 {
    match name {
        "t_s" | "energy_j" => 0.0,
        "x_m" => start_m[0],
        "y_m" => start_m[1],
        _ => f64::NAN,
    }
}

/// The names of the columns, in the file's order.
pub fn names() -> impl Iterator<Item = &'static str> {
    planner::summary::TRAJECTORY_COLUMNS.split(',')
}

/// Column `name` of an evaluated trajectory that starts at `start_m`, or `None` when there is
/// no such column.
pub fn column(name: &str, ev: &Evaluation, start_m: [f64; 2]) -> Option<Vec<f64>> {
    if !names().any(|n| n == name) {
        return None;
    }
    let mut v = Vec::with_capacity(ev.slots.len() + 1);
    v.push(match name {
        "z_m" => ev.start_altitude_m,
        _ => start_value(name, start_m),
    });
    for e in &ev.slots {
        v.push(slot_value(name, e)?);
    }
    Some(v)
}
