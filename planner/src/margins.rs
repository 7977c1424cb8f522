//! Planning with margins: a mission's `resolution_margin_pct`, `accel_margin_pct` and
//! `jerk_margin_pct` ([`crate::Params`]) make the planner plan against tightened limits
//! ([`crate::Mission::planned`]) while the plan is judged against the mission's own, so that a
//! flown plan keeps that room for a flight controller's tracking error.
//!
//! [`within`] runs a planner on the planned mission and judges what comes back on the mission:
//! the plan's evaluation (and that of the best plan a [`PlanError::NotFound`] carries) is the
//! mission's, and a refusal or a plan not found says that it was planned with the margins. The
//! energy bound of a plan made with margins is that of the tightened limits, the problem it
//! solved. [`LimitRoom`] is the room a plan keeps inside each limit.

use serde::{Deserialize, Serialize};

use crate::driver::{PlanError, PlanResult};
use crate::evaluate::{evaluate, evaluate_with_altitudes, Evaluation, FEASIBILITY_TOL};
use crate::Mission;

/// Runs `plan` on the mission planned with `mission`'s margins ([`Mission::planned`]; the
/// mission itself when it sets none, and then the result as it comes) and judges the result on
/// `mission`: its evaluation, and the best plan of a [`PlanError::NotFound`], are re-evaluated
/// there, and the reason of a refusal or of a plan not found names the margins.
pub fn within(
    mission: &Mission,
    plan: impl FnOnce(&Mission) -> Result<PlanResult, PlanError>,
) -> Result<PlanResult, PlanError> {
    if !mission.params().has_margins() {
        return plan(mission);
    }
    match plan(&mission.planned()) {
        Ok(mut out) => {
            judge(mission, &mut out);
            Ok(out)
        }
        Err(e) => Err(judge_error(mission, e)),
    }
}

/// A planning error of the mission planned with `mission`'s margins, judged on `mission`: the
/// best plan a [`PlanError::NotFound`] carries re-evaluated there, and the reason of a refusal
/// or of a plan not found naming the margins. Other errors, and every error of a mission
/// without margins, as they are.
pub fn judge_error(mission: &Mission, error: PlanError) -> PlanError {
    if !mission.params().has_margins() {
        return error;
    }
    match error {
        PlanError::NotFound(mut not_found) => {
            if let Some(best) = not_found.best.as_mut() {
                judge(mission, best);
            }
            not_found.reason.push_str(&planned_with(mission));
            PlanError::NotFound(not_found)
        }
        PlanError::Infeasible(mut why) => {
            why.reason.push_str(&planned_with(mission));
            PlanError::Infeasible(why)
        }
        e => e,
    }
}

/// Re-evaluates `result` on `mission` (at its planned altitudes, where it has them), so that its
/// evaluation judges the mission's own limits.
pub fn judge(mission: &Mission, result: &mut PlanResult) {
    let judged = match &result.altitudes_m {
        Some(z) => evaluate_with_altitudes(mission, &result.trajectory, z).ok(),
        None => Some(evaluate(mission, &result.trajectory)),
    };
    if let Some(ev) = judged {
        result.evaluation = ev;
    }
}

/// The note a refusal or a plan not found gets when the mission sets margins: which, and the
/// limits they made.
fn planned_with(mission: &Mission) -> String {
    let p = mission.params();
    let t = p.planning_limits();
    let mut parts = Vec::new();
    if p.resolution_margin_pct > 0.0 {
        parts.push(format!(
            "resolution_margin_pct = {} (d_min {:.4} m)",
            p.resolution_margin_pct, t.d_min_m
        ));
    }
    if p.accel_margin_pct > 0.0 {
        parts.push(format!(
            "accel_margin_pct = {} (a_max {:.4} m/s²)",
            p.accel_margin_pct, t.max_accel_mps2
        ));
    }
    if let (true, Some(j)) = (p.jerk_margin_pct > 0.0, t.max_jerk_mps3) {
        parts.push(format!(
            "jerk_margin_pct = {} (j_max {:.4} m/s³)",
            p.jerk_margin_pct, j
        ));
    }
    format!(" (planned with the margins {})", parts.join(", "))
}

/// The least room a plan leaves inside each of the mission's limits, % of the limit
/// (`margins` in `summary.json`): what a flight controller's tracking error may use before the
/// flown track breaks the limit. Negative where the plan is over the limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LimitRoom {
    /// The mission's `resolution_margin_pct`, `accel_margin_pct` and `jerk_margin_pct` (0 for
    /// a margin not set), %.
    pub requested_pct: [f64; 3],
    /// 100 (1 − largest worst cell width / d_min) over the landmark slots the general cell
    /// resolves (worst width ≤ d_min); `None` when it resolves none.
    pub cell_room_pct: Option<f64>,
    /// Landmark slots the general cell resolves (worst width ≤ d_min) with less room than the
    /// resolution margin asks (wider than d_min (1 − `resolution_margin_pct`/100), to
    /// [`crate::evaluate::FEASIBILITY_TOL`]): where a best effort could not keep the margin, a
    /// tracking error may widen the cell beyond d_min. 0 without a resolution margin.
    pub slots_short_of_margin: usize,
    /// 100 (1 − largest paper azimuth resolution δ_a / d_min) over the landmark slots (the
    /// azimuth requirement, V ≥ V_min); `None` without landmark slots.
    pub azimuth_room_pct: Option<f64>,
    /// 100 (1 − largest acceleration / a_max) over the slots.
    pub accel_room_pct: f64,
    /// 100 (1 − largest jerk / j_max) over the slots; `None` without a jerk limit.
    pub jerk_room_pct: Option<f64>,
}

impl LimitRoom {
    /// The room the plan evaluated as `ev` keeps inside `mission`'s limits.
    pub fn new(mission: &Mission, ev: &Evaluation) -> Self {
        let p = mission.params();
        let room = |largest: f64, limit: f64| 100.0 * (1.0 - largest / limit);
        let landmark = || ev.slots.iter().filter(|s| s.landmark_m.is_some());
        let widest_resolved = landmark()
            .map(|s| s.worst_width_m)
            .filter(|w| *w <= p.d_min_m)
            .reduce(f64::max);
        let planned_d_min_m = p.planning_limits().d_min_m;
        let widest_azimuth = landmark()
            .map(|s| s.azimuth_resolution_paper_m)
            .reduce(f64::max);
        Self {
            requested_pct: [
                p.resolution_margin_pct,
                p.accel_margin_pct,
                p.jerk_margin_pct,
            ],
            cell_room_pct: widest_resolved.map(|w| room(w, p.d_min_m)),
            slots_short_of_margin: landmark()
                .map(|s| s.worst_width_m)
                .filter(|w| *w <= p.d_min_m && *w > planned_d_min_m + FEASIBILITY_TOL)
                .count(),
            azimuth_room_pct: widest_azimuth.map(|w| room(w, p.d_min_m)),
            accel_room_pct: room(ev.max_accel_mps2, p.max_accel_mps2),
            jerk_room_pct: p.max_jerk_mps3.map(|j| room(ev.max_jerk_mps3, j)),
        }
    }
}
