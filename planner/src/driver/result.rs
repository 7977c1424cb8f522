//! What a planning run returns: [`PlanResult`] and [`TerminationReason`].

use serde::{Deserialize, Serialize};

use crate::bound::EnergyBound;
use crate::evaluate::{Dynamics, Evaluation, ResolutionMode};
use crate::shortfall::ResolutionShortfall;
use crate::Trajectory;

use super::{IterationRecord, Scheme};

/// Why the iterations stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "reason", content = "detail")]
pub enum TerminationReason {
    /// The relative change of the objective fell below the tolerance.
    Converged,
    /// The iteration limit was reached.
    MaxIterations,
    /// A subproblem failed even after backing off; the last accepted iterate is returned.
    SubproblemFailed(String),
    /// Steps kept being rejected by the exact-geometry check; the last accepted iterate is returned.
    NoProgress,
    /// [`PlanOptions::time_limit_s`](super::PlanOptions::time_limit_s) passed; the last accepted
    /// iterate is returned.
    TimeLimit,
}

impl TerminationReason {
    /// Its name in `summary.json` (`termination.reason`): `converged`, `max_iterations`,
    /// `subproblem_failed`, `no_progress` or `time_limit`.
    pub fn name(&self) -> &'static str {
        match self {
            TerminationReason::Converged => "converged",
            TerminationReason::MaxIterations => "max_iterations",
            TerminationReason::SubproblemFailed(_) => "subproblem_failed",
            TerminationReason::NoProgress => "no_progress",
            TerminationReason::TimeLimit => "time_limit",
        }
    }
}

/// The name of `summary.json` ([`TerminationReason::name`]), with the detail of
/// `subproblem_failed` in parentheses.
impl std::fmt::Display for TerminationReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())?;
        if let TerminationReason::SubproblemFailed(detail) = self {
            write!(f, " ({detail})")?;
        }
        Ok(())
    }
}

/// The result of a planning run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanResult {
    /// The scheme that produced it.
    pub scheme: Scheme,
    /// The planned trajectory.
    pub trajectory: Trajectory,
    /// Its exact-geometry evaluation (true energy, violations, per-slot values).
    pub evaluation: Evaluation,
    /// The optimiser's own final objective (J for energy schemes, m for distance schemes).
    pub objective: f64,
    /// The optimiser's objective after each accepted iteration.
    pub objective_history: Vec<f64>,
    /// True energy after each accepted iteration, J.
    pub true_energy_history: Vec<f64>,
    /// All iterations (accepted and rejected).
    pub records: Vec<IterationRecord>,
    /// Number of iterations run.
    pub iterations: usize,
    /// True when stopped by the tolerance.
    pub converged: bool,
    /// Why it stopped.
    pub termination: TerminationReason,
    /// Wall time of the whole run (start, repair and iterations), s.
    pub solve_seconds: f64,
    /// True energy of the start trajectory, J.
    pub start_energy_j: f64,
    /// Phase-I iterations spent repairing the start.
    pub repair_iterations: usize,
    /// Cone programs solved.
    pub cone_programs: usize,
    /// The resolution requirement the plan was made for.
    pub resolution: ResolutionMode,
    /// Why a given start (`PlanOptions::init`) was not used: it could not be repaired (made
    /// feasible) and the plan starts from the built-in start instead. `None` when the given
    /// start was used or none was given.
    pub init_replaced: Option<String>,
    /// A best-effort plan under the general resolution ([`PlanOptions::strict_resolution`]
    /// off): the least-energy plan it was measured against. `None` for every other plan.
    ///
    /// [`PlanOptions::strict_resolution`]: super::PlanOptions::strict_resolution
    #[serde(default)]
    pub best_effort: Option<BestEffort>,
    /// The vehicle model the plan was made for (under [`Dynamics::Vehicle`] it meets the
    /// acceleration limit in every slot).
    #[serde(default)]
    pub dynamics: Dynamics,
    /// The altitude H_t of every slot, m, for a mission with `altitude = "free"` planned with
    /// [`PlanOptions::altitude_profile`](super::PlanOptions::altitude_profile) (`evaluation`
    /// is then at these altitudes); `None` for a plan at the mission's fixed altitude.
    #[serde(default)]
    pub altitudes_m: Option<Vec<f64>>,
    /// A lower bound on the energy of every trajectory that meets the mission's constraints
    /// under the plan's vehicle model ([`crate::bound`]); the plan's energy is at most
    /// [`EnergyBound::gap_pct`] above the least any such trajectory can have. `None` only in a
    /// result not made by the planner.
    #[serde(default)]
    pub bound: Option<EnergyBound>,
}

impl PlanResult {
    /// Whether the plan meets what it was planned for on the exact geometry: every constraint
    /// of (p2), and the general resolution in every landmark slot when it was planned for it
    /// strictly (a best-effort plan reports its shortfall instead), and the acceleration limit in
    /// every slot when it was made for [`Dynamics::Vehicle`].
    pub fn is_feasible(&self) -> bool {
        let constraints = match self.best_effort {
            Some(_) => self.evaluation.is_feasible(),
            None => self.evaluation.is_feasible_for(self.resolution),
        };
        constraints && self.evaluation.meets(self.dynamics)
    }
}

/// What a best-effort plan was measured against.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BestEffort {
    /// True energy of the least-energy plan (the `paper` resolution plan of the same mission), J.
    pub least_energy_j: f64,
    /// That plan's resolution shortfall on the exact geometry.
    pub least_energy_shortfall: ResolutionShortfall,
    /// The energy cap it was planned under, % above `least_energy_j` (`None`: none).
    pub max_extra_energy_pct: Option<f64>,
    /// Why this plan is not a strict general one: the first landmark slot it leaves with a
    /// cell wider than d_min (`None`: it resolves every slot). The best effort makes no strict
    /// attempt of its own (`PlanOptions::strict_resolution` does).
    pub strict_refusal: Option<String>,
}
