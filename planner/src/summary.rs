//! What a plan is, as data: its summary (`summary.json`, also the plan messages' summary) and
//! its trajectory table (`trajectory.csv`, which [`crate::Trajectory::from_csv_path`] reads
//! back).

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::driver::{BestEffort, PlanResult, Scheme, TerminationReason};
use crate::power::PowerModel;
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
    /// The optimiser's own final objective for energy schemes (Σ P̃_t δ), J; null for distance schemes.
    pub objective_j: Option<f64>,
    /// The optimiser's own final objective for distance schemes, m; null for energy schemes.
    pub objective_m: Option<f64>,
    /// True energy of the start trajectory, J.
    pub start_energy_j: f64,
    /// T · P(V*) with V* the least-power speed within the speed limits, J.
    pub floor_energy_j: f64,
    /// energy_j / floor_energy_j − 1.
    pub energy_over_floor: f64,
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
    /// Landmark slots in blind geometry (ψ < 5°).
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
}

impl Summary {
    /// The summary of a plan.
    pub fn new(mission: &Mission, result: &PlanResult) -> Self {
        let p = mission.params();
        let model = PowerModel::new(p);
        let (_, p_star) = model.min_power_in(0.0, p.max_speed_mps);
        let floor = p.horizon_s * p_star;
        let ev = &result.evaluation;
        let energy_scheme = matches!(result.scheme, Scheme::Exact | Scheme::Paper);
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
        }
    }
}

/// The columns of `trajectory.csv`.
pub const TRAJECTORY_COLUMNS: &str = "t_s,x_m,y_m,speed_mps,heading_rad,xc_m,yc_m,landmark_x_m,landmark_y_m,in_view,centre_error_m,power_w,energy_j,range_resolution_paper_m,range_resolution_general_m,azimuth_resolution_m,bistatic_angle_deg,grad_norm,psi_rad,along_track_width_m,cross_track_width_m,worst_width_m";

/// `trajectory.csv`: one row per slot plus the start at t = 0 (undefined values are `nan`).
pub fn trajectory_csv(result: &PlanResult) -> String {
    let mut s = String::with_capacity(200 * (result.evaluation.slots.len() + 2));
    s.push_str(TRAJECTORY_COLUMNS);
    s.push('\n');
    let st = result.trajectory.start_m;
    let _ = writeln!(
        s,
        "0,{},{},nan,nan,nan,nan,nan,nan,nan,nan,nan,0,nan,nan,nan,nan,nan,nan,nan,nan,nan",
        st[0], st[1]
    );
    for e in &result.evaluation.slots {
        let (lx, ly) = e.landmark_m.map_or((f64::NAN, f64::NAN), |l| (l[0], l[1]));
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            e.t_s,
            e.pos_m[0],
            e.pos_m[1],
            e.speed_mps,
            e.heading_rad,
            e.centre_m[0],
            e.centre_m[1],
            lx,
            ly,
            u8::from(e.in_view),
            e.centre_error_m.unwrap_or(f64::NAN),
            e.power_w,
            e.energy_j,
            e.range_resolution_paper_m,
            e.range_resolution_general_m,
            e.azimuth_resolution_paper_m,
            e.bistatic_angle_rad.to_degrees(),
            e.grad_norm,
            e.psi_rad,
            e.along_track_width_m,
            e.cross_track_width_m,
            e.worst_width_m
        );
    }
    // Rust prints NaN as "NaN": NumPy and pandas read both, keep one spelling
    s.replace("NaN", "nan")
}
