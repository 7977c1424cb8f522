//! What a plan is, as data: its summary (`summary.json`, also the plan messages' summary) and
//! its trajectory table (`trajectory.csv`, which [`crate::Trajectory::from_csv_path`] reads
//! back).

use serde::{Deserialize, Serialize};

use crate::altitude::AltitudeMode;
use crate::driver::{BestEffort, PlanResult, Scheme, TerminationReason};
use crate::evaluate::SlotEval;
use crate::margins::LimitRoom;
use crate::power::PowerModel;
use crate::schemes::exact::ExactObjective;
use crate::shortfall::ResolutionShortfall;
use crate::Mission;

/// The contents of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Scheme name.
    pub scheme: Scheme,
    /// Mission name.
    pub mission: String,
    /// Number of slots.
    pub slots: usize,
    /// True propulsion energy on the exact geometry, J.
    pub energy_j: f64,
    /// The optimiser's own final objective for energy schemes, J; null for distance schemes.
    /// For a plan that is not a best effort it is the energy of the model the last cone program
    /// solved (Σ P̃_t δ, the surrogate of P(V), near `energy_j`). For a best-effort plan
    /// (`best_effort` set) it adds the penalty on the resolution deficit,
    /// `PlanOptions::resolution_weight_j_per_m` (100 J/m by default) × the cell slack of that
    /// program (near `resolution_shortfall.total_deficit_m`), so it exceeds `energy_j` by
    /// about that penalty: it is the quantity minimised, not an energy.
    pub objective_j: Option<f64>,
    /// The optimiser's own final objective for distance schemes, m; null for energy schemes.
    pub objective_m: Option<f64>,
    /// True energy of the start trajectory, J.
    pub start_energy_j: f64,
    /// T · P(V*) with V* the least-power speed within the speed limits, J.
    pub floor_energy_j: f64,
    /// energy_j / floor_energy_j − 1.
    pub energy_over_floor: f64,
    /// A lower bound on the true energy of every trajectory that meets the mission's
    /// constraints under the plan's vehicle model, J ([`crate::bound`]: the per-slot power
    /// floor under the speed range each slot must keep, and the distances the UAV must fly
    /// between the start and the landmarks); null where the result carries none.
    #[serde(default)]
    pub lower_bound_j: Option<f64>,
    /// How far `energy_j` lies above `lower_bound_j`, % of `energy_j`: no trajectory meeting the
    /// constraints uses less than `energy_j` × (1 − this / 100).
    #[serde(default)]
    pub bound_gap_pct: Option<f64>,
    /// Iterations run.
    pub iterations: usize,
    /// Stopped by the tolerance.
    pub converged: bool,
    /// Why it stopped.
    pub termination: TerminationReason,
    /// Wall time, s.
    pub solve_seconds: f64,
    /// The optimiser's objective after each accepted iteration.
    pub objective_history: Vec<f64>,
    /// True energy after each accepted iteration, J.
    pub true_energy_history: Vec<f64>,
    /// Largest (‖q_g − q_c‖ − r_s)⁺ over landmark slots on the exact geometry, m.
    pub max_sensing_violation_m: f64,
    /// Largest (V_min − V)⁺ over landmark slots (azimuth requirement), m/s.
    pub max_azimuth_speed_violation_mps: f64,
    /// Largest (V − V_m)⁺, m/s.
    pub max_speed_limit_violation_mps: f64,
    /// Largest (δ_r − d_min)⁺ with the paper's δ_r, m.
    pub max_range_violation_m: f64,
    /// Least true speed, m/s.
    pub min_speed_mps: f64,
    /// Largest true speed, m/s.
    pub max_speed_mps: f64,
    /// Path length, m.
    pub length_m: f64,
    /// Landmark slots with the landmark outside the true sensing disc.
    pub slots_out_of_view: usize,
    /// Landmark slots whose general resolution cell is wider than d_min (erratum 12 (docs/paper-notes.md)).
    pub slots_unresolved_general: usize,
    /// Landmark slots in blind geometry: ψ < 5° ([`crate::evaluate::BLIND_PSI_RAD`]), resolved
    /// or not (the cell's cross-track extent is then more than 11 times its range width). Not
    /// `resolution_shortfall.infinite_width_slots`, the slots whose cell is unbounded.
    pub slots_blind: usize,
    /// Largest worst width of the resolution cell over landmark slots, m.
    pub max_worst_width_m: f64,
    /// The resolution requirement the plan was made for.
    pub resolution: crate::evaluate::ResolutionMode,
    /// Largest general range resolution over landmark slots, m.
    pub max_range_resolution_general_m: f64,
    /// Largest paper range resolution over landmark slots, m.
    pub max_range_resolution_paper_m: f64,
    /// All constraints of (p2) hold on the exact geometry, and, for a plan made for the general
    /// resolution that is not a best effort, the cell's worst width ≤ d_min in every landmark
    /// slot (a best-effort plan reports its shortfall in `resolution_shortfall`).
    pub feasible: bool,
    /// Cone programs solved.
    pub cone_programs: usize,
    /// Phase-I iterations spent on the start.
    pub repair_iterations: usize,
    /// The resolution cell per landmark window and the unresolved slots and windows, on the
    /// exact geometry (whatever the plan was made for).
    #[serde(default)]
    pub resolution_shortfall: Option<ResolutionShortfall>,
    /// A best-effort plan: the least-energy plan it is measured against and the energy cap.
    #[serde(default)]
    pub best_effort: Option<BestEffort>,
    /// A best-effort plan: its energy above the least-energy plan's, %.
    #[serde(default)]
    pub extra_energy_pct: Option<f64>,
    /// The vehicle model the plan was made for (`vehicle`: within `accel_limit_mps2` in every
    /// slot, part of `feasible`; `paper`: the velocity may jump).
    #[serde(default)]
    pub dynamics: crate::evaluate::Dynamics,
    /// Largest acceleration between consecutive slots, ‖v_t − v_{t−1}‖/δ (the first slot from
    /// `start_velocity_mps`), on the exact geometry, m/s².
    #[serde(default)]
    pub max_accel_mps2: f64,
    /// The vehicle's acceleration limit (`max_accel_mps2` of the mission), m/s².
    #[serde(default)]
    pub accel_limit_mps2: f64,
    /// Largest (acceleration − limit)⁺ over the slots, m/s² (reported whatever the dynamics).
    #[serde(default)]
    pub max_accel_violation_mps2: f64,
    /// Slots whose acceleration exceeds the limit (to its relative tolerance 1e-7).
    #[serde(default)]
    pub slots_over_accel_limit: usize,
    /// The velocity at the start the accelerations are measured from, (v_x, v_y) m/s (the
    /// mission's `start_velocity_mps`, or its rule's value when the mission states none).
    #[serde(default)]
    pub start_velocity_mps: [f64; 2],
    /// The planned altitudes of a free-altitude plan (a mission with `altitude = "free"`,
    /// planned with [`crate::PlanOptions::altitude_profile`]); absent for a plan at the
    /// mission's one altitude `altitude_m`, whose summary it leaves unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub altitude: Option<AltitudeSummary>,
    /// The jerk of a plan of a mission with a jerk limit (`max_jerk_mps3`); absent without one,
    /// which leaves the summary unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jerk: Option<JerkSummary>,
    /// The least room the plan keeps inside each of the mission's limits, for a mission with
    /// margins (`resolution_margin_pct`, `accel_margin_pct`, `jerk_margin_pct`); absent without
    /// them, which leaves the summary unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub margins: Option<LimitRoom>,
}

/// The jerk of a plan (`jerk` in `summary.json`), on the exact geometry: the change of the
/// acceleration between consecutive slots over its window
/// ([`crate::evaluate::jerk_window_s`]), from the second slot on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JerkSummary {
    /// Largest jerk over the slots, m/s³.
    pub max_jerk_mps3: f64,
    /// The mission's jerk limit (`max_jerk_mps3`), m/s³.
    pub jerk_limit_mps3: f64,
    /// Largest (jerk − limit)⁺ over the slots, m/s³ (reported whatever the dynamics).
    pub max_jerk_violation_mps3: f64,
    /// Slots whose jerk exceeds the limit (to its relative tolerance 1e-7).
    pub slots_over_jerk_limit: usize,
}

impl JerkSummary {
    /// The jerk of the plan evaluated as `ev` against `mission`'s limit; `None` without one.
    fn new(mission: &Mission, ev: &crate::Evaluation) -> Option<Self> {
        let p = mission.params();
        Some(Self {
            max_jerk_mps3: ev.max_jerk_mps3,
            jerk_limit_mps3: p.max_jerk_mps3?,
            max_jerk_violation_mps3: ev.violations.jerk_mps3,
            slots_over_jerk_limit: ev
                .slots
                .iter()
                .filter(|s| crate::evaluate::over_jerk_limit(p, s.jerk_mps3))
                .count(),
        })
    }
}

/// The altitudes of a free-altitude plan (`altitude` in `summary.json`), on the exact geometry
/// ([`crate::evaluate::evaluate_with_altitudes`]): the altitude H_t at the end of every slot
/// and the vertical rate (H_t − H_{t−1})/δ of every slot, from H_0 = `altitude_m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AltitudeSummary {
    /// The mission's altitude mode (`free`).
    pub mode: AltitudeMode,
    /// The altitude at the start H_0 (the mission's `altitude_m`), m.
    pub start_altitude_m: f64,
    /// The mission's bounds `[min_altitude_m, max_altitude_m]`, m.
    pub bounds_m: [f64; 2],
    /// Lowest planned altitude over the slots, m.
    pub min_altitude_m: f64,
    /// Highest planned altitude over the slots, m.
    pub max_altitude_m: f64,
    /// Mean planned altitude over the slots, m.
    pub mean_altitude_m: f64,
    /// Largest climb rate of a slot, m/s (0 when the plan never climbs).
    pub max_climb_mps: f64,
    /// Largest descent rate of a slot, m/s, positive (0 when the plan never descends).
    pub max_descent_mps: f64,
    /// The mission's climb-rate limit (its `max_climb_mps`), m/s.
    pub climb_limit_mps: f64,
    /// The mission's descent-rate limit (its `max_descent_mps`), m/s.
    pub descent_limit_mps: f64,
    /// Energy spent climbing, Σ W max(v_z, 0) δ ([`PowerModel::climb_w`]: descent earns no
    /// credit), J; part of `energy_j`.
    pub climb_energy_j: f64,
    /// `climb_energy_j / energy_j`, the share of the energy spent climbing (0 to 1).
    pub climb_energy_share: f64,
}

impl AltitudeSummary {
    /// The altitudes of the plan evaluated as `ev` with the altitude profile `altitudes_m` of
    /// `mission`; `None` for an empty profile.
    fn new(mission: &Mission, ev: &crate::Evaluation, altitudes_m: &[f64]) -> Option<Self> {
        if altitudes_m.is_empty() || ev.slots.is_empty() {
            return None;
        }
        let p = mission.params();
        let model = PowerModel::new(p);
        let (lo, hi) = crate::altitude::bounds_m(p);
        let climbs = || ev.slots.iter().map(|s| s.climb_mps);
        let climb_energy_j: f64 = climbs().map(|v| model.climb_w(v) * p.slot_s).sum();
        Some(Self {
            mode: p.altitude,
            start_altitude_m: ev.start_altitude_m,
            bounds_m: [lo, hi],
            min_altitude_m: altitudes_m.iter().copied().fold(f64::INFINITY, f64::min),
            max_altitude_m: altitudes_m
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max),
            mean_altitude_m: altitudes_m.iter().sum::<f64>() / altitudes_m.len() as f64,
            max_climb_mps: climbs().fold(0.0, f64::max),
            max_descent_mps: climbs().map(|v| -v).fold(0.0, f64::max),
            climb_limit_mps: p.max_climb_mps,
            descent_limit_mps: p.max_descent_mps,
            climb_energy_j,
            climb_energy_share: if ev.energy_j > 0.0 {
                climb_energy_j / ev.energy_j
            } else {
                0.0
            },
        })
    }
}

impl Summary {
    /// The summary of a plan.
    pub fn new(mission: &Mission, result: &PlanResult) -> Self {
        let p = mission.params();
        let model = PowerModel::new(p);
        let (_, p_star) = model.min_power_in(0.0, p.max_speed_mps);
        let floor = p.horizon_s * p_star;
        let ev = &result.evaluation;
        let energy_scheme = result.scheme.spec().objective == ExactObjective::Energy;
        let landmark_slots = || ev.slots.iter().filter(|s| s.landmark_m.is_some());
        Self {
            scheme: result.scheme,
            mission: mission.name().to_string(),
            slots: mission.slots(),
            energy_j: ev.energy_j,
            objective_j: energy_scheme.then_some(result.objective),
            objective_m: (!energy_scheme).then_some(result.objective),
            start_energy_j: result.start_energy_j,
            floor_energy_j: floor,
            energy_over_floor: ev.energy_j / floor - 1.0,
            lower_bound_j: result.bound.map(|b| b.energy_j),
            bound_gap_pct: result.bound.map(|b| b.gap_pct(ev.energy_j)),
            iterations: result.iterations,
            converged: result.converged,
            termination: result.termination.clone(),
            solve_seconds: result.solve_seconds,
            objective_history: result.objective_history.clone(),
            true_energy_history: result.true_energy_history.clone(),
            max_sensing_violation_m: ev.violations.sensing_m,
            max_azimuth_speed_violation_mps: ev.violations.min_speed_mps,
            max_speed_limit_violation_mps: ev.violations.max_speed_mps,
            max_range_violation_m: ev.violations.range_paper_m,
            min_speed_mps: ev.min_speed_mps,
            max_speed_mps: ev.max_speed_mps,
            length_m: ev.length_m,
            slots_out_of_view: ev.slots_out_of_view,
            slots_unresolved_general: ev.slots_unresolved,
            slots_blind: ev.slots_blind,
            max_worst_width_m: landmark_slots()
                .map(|s| s.worst_width_m)
                .fold(0.0, f64::max),
            resolution: result.resolution,
            max_range_resolution_general_m: landmark_slots()
                .map(|s| s.range_resolution_general_m)
                .fold(0.0, f64::max),
            max_range_resolution_paper_m: landmark_slots()
                .map(|s| s.range_resolution_paper_m)
                .fold(0.0, f64::max),
            feasible: result.is_feasible(),
            cone_programs: result.cone_programs,
            repair_iterations: result.repair_iterations,
            resolution_shortfall: Some(ResolutionShortfall::new(mission, ev)),
            best_effort: result.best_effort.clone(),
            extra_energy_pct: result
                .best_effort
                .as_ref()
                .map(|b| 100.0 * (ev.energy_j / b.least_energy_j - 1.0)),
            dynamics: result.dynamics,
            max_accel_mps2: ev.max_accel_mps2,
            accel_limit_mps2: p.max_accel_mps2,
            max_accel_violation_mps2: ev.violations.accel_mps2,
            slots_over_accel_limit: ev
                .slots
                .iter()
                .filter(|s| {
                    s.accel_mps2 > p.max_accel_mps2 * (1.0 + crate::evaluate::ACCEL_TOL_REL)
                })
                .count(),
            start_velocity_mps: mission.start_velocity_mps(),
            altitude: result
                .altitudes_m
                .as_deref()
                .and_then(|z| AltitudeSummary::new(mission, ev, z)),
            jerk: JerkSummary::new(mission, ev),
            margins: p
                .has_margins()
                .then(|| crate::margins::LimitRoom::new(mission, ev)),
        }
    }
}

/// The columns of `trajectory.csv`.
pub const TRAJECTORY_COLUMNS: &str = "t_s,x_m,y_m,speed_mps,heading_rad,xc_m,yc_m,landmark_x_m,landmark_y_m,in_view,centre_error_m,power_w,energy_j,range_resolution_paper_m,range_resolution_general_m,azimuth_resolution_m,bistatic_angle_deg,grad_norm,psi_rad,along_track_width_m,cross_track_width_m,worst_width_m,accel_mps2,z_m,climb_mps,jerk_mps3";

/// A number of a CSV table as Rust's `{}` prints it (shortest round trip, `1` for 1.0), NaN as
/// `nan`: the csv crate's own float format (ryu: `1.0`, `1e20`) would change the published
/// tables, and NumPy and pandas read `nan`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsvNum(pub f64);

impl std::fmt::Display for CsvNum {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_nan() {
            f.write_str("nan")
        } else {
            std::fmt::Display::fmt(&self.0, f)
        }
    }
}

impl Serialize for CsvNum {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// One row of `trajectory.csv` (field names are the columns, [`TRAJECTORY_COLUMNS`]).
#[derive(Debug, Clone, Serialize)]
struct TrajectoryRow {
    t_s: CsvNum,
    x_m: CsvNum,
    y_m: CsvNum,
    speed_mps: CsvNum,
    heading_rad: CsvNum,
    xc_m: CsvNum,
    yc_m: CsvNum,
    landmark_x_m: CsvNum,
    landmark_y_m: CsvNum,
    in_view: CsvNum,
    centre_error_m: CsvNum,
    power_w: CsvNum,
    energy_j: CsvNum,
    range_resolution_paper_m: CsvNum,
    range_resolution_general_m: CsvNum,
    azimuth_resolution_m: CsvNum,
    bistatic_angle_deg: CsvNum,
    grad_norm: CsvNum,
    psi_rad: CsvNum,
    along_track_width_m: CsvNum,
    cross_track_width_m: CsvNum,
    worst_width_m: CsvNum,
    accel_mps2: CsvNum,
    z_m: CsvNum,
    climb_mps: CsvNum,
    jerk_mps3: CsvNum,
}

impl TrajectoryRow {
    /// The start at t = 0: position, altitude and zero energy, the rest undefined.
    fn start(start_m: [f64; 2], start_altitude_m: f64) -> Self {
        let nan = CsvNum(f64::NAN);
        TrajectoryRow {
            t_s: CsvNum(0.0),
            x_m: CsvNum(start_m[0]),
            y_m: CsvNum(start_m[1]),
            speed_mps: nan,
            heading_rad: nan,
            xc_m: nan,
            yc_m: nan,
            landmark_x_m: nan,
            landmark_y_m: nan,
            in_view: nan,
            centre_error_m: nan,
            power_w: nan,
            energy_j: CsvNum(0.0),
            range_resolution_paper_m: nan,
            range_resolution_general_m: nan,
            azimuth_resolution_m: nan,
            bistatic_angle_deg: nan,
            grad_norm: nan,
            psi_rad: nan,
            along_track_width_m: nan,
            cross_track_width_m: nan,
            worst_width_m: nan,
            accel_mps2: nan,
            z_m: CsvNum(start_altitude_m),
            climb_mps: nan,
            jerk_mps3: nan,
        }
    }

    /// The end of one slot.
    fn slot(e: &SlotEval) -> Self {
        let (lx, ly) = e.landmark_m.map_or((f64::NAN, f64::NAN), |l| (l[0], l[1]));
        TrajectoryRow {
            t_s: CsvNum(e.t_s),
            x_m: CsvNum(e.pos_m[0]),
            y_m: CsvNum(e.pos_m[1]),
            speed_mps: CsvNum(e.speed_mps),
            heading_rad: CsvNum(e.heading_rad),
            xc_m: CsvNum(e.centre_m[0]),
            yc_m: CsvNum(e.centre_m[1]),
            landmark_x_m: CsvNum(lx),
            landmark_y_m: CsvNum(ly),
            in_view: CsvNum(f64::from(u8::from(e.in_view))),
            centre_error_m: CsvNum(e.centre_error_m.unwrap_or(f64::NAN)),
            power_w: CsvNum(e.power_w),
            energy_j: CsvNum(e.energy_j),
            range_resolution_paper_m: CsvNum(e.range_resolution_paper_m),
            range_resolution_general_m: CsvNum(e.range_resolution_general_m),
            azimuth_resolution_m: CsvNum(e.azimuth_resolution_paper_m),
            bistatic_angle_deg: CsvNum(e.bistatic_angle_rad.to_degrees()),
            grad_norm: CsvNum(e.grad_norm),
            psi_rad: CsvNum(e.psi_rad),
            along_track_width_m: CsvNum(e.along_track_width_m),
            cross_track_width_m: CsvNum(e.cross_track_width_m),
            worst_width_m: CsvNum(e.worst_width_m),
            accel_mps2: CsvNum(e.accel_mps2),
            z_m: CsvNum(e.z_m),
            climb_mps: CsvNum(e.climb_mps),
            jerk_mps3: CsvNum(e.jerk_mps3),
        }
    }
}

/// `trajectory.csv`: one row per slot plus the start at t = 0 (undefined values are `nan`).
pub fn trajectory_csv(result: &PlanResult) -> Result<String, csv::Error> {
    let mut w = csv::Writer::from_writer(Vec::with_capacity(
        200 * (result.evaluation.slots.len() + 2),
    ));
    w.serialize(TrajectoryRow::start(
        result.trajectory.start_m,
        result.evaluation.start_altitude_m,
    ))?;
    for e in &result.evaluation.slots {
        w.serialize(TrajectoryRow::slot(e))?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| csv::Error::from(e.into_error()))?;
    // every field is ASCII, so nothing is replaced
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_as_rust_prints_them_and_nan_as_nan() {
        let cells: Vec<String> = [1.0, -0.0, 0.1 + 0.2, 1e20, 2.5e-7, f64::NAN, -f64::NAN]
            .map(|v| CsvNum(v).to_string())
            .into();
        assert_eq!(
            cells,
            [
                "1",
                "-0",
                "0.30000000000000004",
                "100000000000000000000",
                "0.00000025",
                "nan",
                "nan"
            ]
        );
    }

    #[test]
    fn the_header_is_the_documented_columns_and_the_start_row_is_unchanged() {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(TrajectoryRow::start([-12.5, 3.0], 1000.0))
            .unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        // the columns before z_m as they were; the start altitude, no climb rate and no jerk
        let start = "-12.5,3,nan,nan,nan,nan,nan,nan,nan,nan,nan,0,nan,nan,nan,nan,nan,nan,nan,\
                     nan,nan,nan,1000,nan,nan";
        assert_eq!(text, format!("{TRAJECTORY_COLUMNS}\n0,{start}\n"));
    }

    /// A straight track north at 20 m/s for 10 s (20 slots), the landmark broadside of its
    /// middle; `altitude` adds to `[params]`.
    fn straight(altitude: &str) -> (Mission, crate::Trajectory) {
        let text = format!(
            "[params]\nhorizon_s = 10\nstart_m = [-1000.0, 0.0]\nstart_velocity_mps = [0, 20]\n\
             {altitude}\n[landmarks]\n\
             points = [{{ x_m = 0.0, y_m = 100.0, from_s = 0.0, to_s = 10.0 }}]\n"
        );
        let m =
            Mission::from_file_struct(&crate::MissionFile::from_toml_str(&text).unwrap()).unwrap();
        let traj = crate::Trajectory {
            slot_s: 0.5,
            start_m: [-1000.0, 0.0],
            pos_m: (1..=20).map(|t| [-1000.0, 10.0 * t as f64]).collect(),
        };
        (m, traj)
    }

    /// The plan result of `traj` flown at `altitudes_m` (the mission's altitude: `None`).
    fn result(m: &Mission, traj: &crate::Trajectory, altitudes_m: Option<Vec<f64>>) -> PlanResult {
        let evaluation = match &altitudes_m {
            Some(z) => crate::evaluate::evaluate_with_altitudes(m, traj, z).unwrap(),
            None => crate::evaluate(m, traj),
        };
        PlanResult {
            scheme: Scheme::Exact,
            trajectory: traj.clone(),
            objective: evaluation.energy_j,
            objective_history: vec![evaluation.energy_j],
            true_energy_history: vec![evaluation.energy_j],
            evaluation,
            records: Vec::new(),
            iterations: 1,
            converged: true,
            termination: TerminationReason::Converged,
            solve_seconds: 0.0,
            start_energy_j: 0.0,
            repair_iterations: 0,
            cone_programs: 1,
            resolution: crate::evaluate::ResolutionMode::Paper,
            init_replaced: None,
            best_effort: None,
            dynamics: crate::Dynamics::Vehicle,
            altitudes_m,
            bound: None,
        }
    }

    /// A free plan's `altitude`: closed forms of a profile that climbs 4 m at 2 m/s, holds,
    /// descends 2 m at 1 m/s and holds (the climb energy W · 4 m, descent without credit).
    #[test]
    fn a_free_plan_summarises_its_altitudes_in_closed_form() {
        let (m, traj) = straight(
            "altitude = \"free\"\nmin_altitude_m = 600\nmax_altitude_m = 1200\n\
             max_climb_mps = 2.5\nmax_descent_mps = 1.5",
        );
        let mut z: Vec<f64> = (1..=4).map(|t| 1000.0 + f64::from(t)).collect();
        z.extend([1004.0; 6]);
        z.extend((1..=4).map(|t| 1004.0 - 0.5 * f64::from(t)));
        z.extend([1002.0; 6]);
        let r = result(&m, &traj, Some(z.clone()));
        let s = Summary::new(&m, &r);
        let a = s.altitude.clone().expect("a free plan has its altitudes");
        assert_eq!(a.mode, AltitudeMode::Free);
        assert_eq!((a.start_altitude_m, a.bounds_m), (1000.0, [600.0, 1200.0]));
        assert_eq!((a.min_altitude_m, a.max_altitude_m), (1001.0, 1004.0));
        let mean = (1001.0 + 1002.0 + 1003.0 + 1004.0 + 6.0 * 1004.0)
            + (1003.5 + 1003.0 + 1002.5 + 1002.0 + 6.0 * 1002.0);
        assert!((a.mean_altitude_m - mean / 20.0).abs() < 1e-9, "{a:?}");
        assert!((a.max_climb_mps - 2.0).abs() < 1e-9, "{a:?}");
        assert!((a.max_descent_mps - 1.0).abs() < 1e-9, "{a:?}");
        assert_eq!((a.climb_limit_mps, a.descent_limit_mps), (2.5, 1.5));
        // 2 kg climbing 4 m; the level power P(20 m/s) for 10 s besides
        let climb_j = 2.0 * 9.80665 * 4.0;
        assert!((a.climb_energy_j - climb_j).abs() < 1e-9, "{a:?}");
        let level_j = 10.0 * PowerModel::new(m.params()).power_w(20.0);
        assert!((s.energy_j - (level_j + climb_j)).abs() < 1e-9 * s.energy_j);
        assert!((a.climb_energy_share - climb_j / s.energy_j).abs() < 1e-12);
        // summary.json carries it and reads back
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["altitude"]["mode"], "free");
        assert_eq!(json["altitude"]["max_altitude_m"], 1004.0);
        let back: Summary = serde_json::from_value(json).unwrap();
        assert_eq!(back, s);
    }

    /// A plan at the mission's one altitude has no `altitude` in its summary: summary.json is
    /// the same as before the field, and a summary without it reads back.
    #[test]
    fn a_fixed_plan_has_no_altitude_summary() {
        let (m, traj) = straight("");
        let s = Summary::new(&m, &result(&m, &traj, None));
        assert!(s.altitude.is_none());
        let json = serde_json::to_value(&s).unwrap();
        assert!(json.get("altitude").is_none(), "{json}");
        let back: Summary = serde_json::from_value(json).unwrap();
        assert_eq!(back, s);
    }

    #[test]
    fn termination_prints_with_its_summary_name() {
        use crate::TerminationReason as T;
        for t in [
            T::Converged,
            T::MaxIterations,
            T::SubproblemFailed("numerical error".into()),
            T::NoProgress,
            T::TimeLimit,
        ] {
            let json = serde_json::to_value(&t).unwrap();
            assert_eq!(json["reason"], t.name());
            assert!(t.to_string().starts_with(t.name()), "{t}");
        }
        assert_eq!(T::NoProgress.to_string(), "no_progress");
        assert_eq!(
            T::SubproblemFailed("numerical error".into()).to_string(),
            "subproblem_failed (numerical error)"
        );
    }
}
