//! Why planning failed: [`PlanError`].

use crate::init::Infeasibility;
use crate::socp::SolveError;

/// No plan meets every constraint, and none is proven impossible ([`PlanError::NotFound`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "no plan found that meets every constraint, from {starts} starts (not proven impossible): \
     slot {slot} (t = {t_s} s): {reason}"
)]
pub struct NotFound {
    /// The first slot (1-based) that the best plan found violates.
    pub slot: usize,
    /// End time of that slot, s.
    pub t_s: f64,
    /// What that plan violates there and overall.
    pub reason: String,
    /// How many starts phase I tried.
    pub starts: usize,
    /// The best plan found: the iterate of least total violation (infeasible; its evaluation
    /// names what it violates). `None` when no start got as far as an iterate.
    pub best: Option<super::PlanResult>,
}

/// Why planning failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// The mission cannot be flown, proven: a closed-form bound (the speed limits, the reach of
    /// the UAV from the start and between landmarks, V_min above V_m; [`crate::init::precheck`],
    /// [`crate::bound::energy_bound`]) rules out every trajectory. Only this is a refusal.
    #[error(transparent)]
    Infeasible(#[from] Infeasibility),
    /// The planner found no trajectory that meets every constraint, from any of its starts, but
    /// has no proof that none exists. It carries the best plan it found (least violation),
    /// which is infeasible.
    #[error(transparent)]
    NotFound(Box<NotFound>),
    /// The given start trajectory does not fit the mission.
    #[error("start trajectory: {0}")]
    InvalidInit(String),
    /// The first subproblem could not be solved.
    ///
    /// The solver's error is part of the message (not a separate `source`), so that printing
    /// the error chain names it once.
    #[error("iteration {iteration}: {error}")]
    Solver {
        /// Iteration (0 = phase I).
        iteration: usize,
        /// The solver's error.
        error: SolveError,
    },
    /// [`PlanOptions::time_limit_s`](super::PlanOptions::time_limit_s) passed before a feasible
    /// start was found.
    #[error(
        "time limit of {limit_s} s reached after {iterations} phase I iterations without a \
         feasible start (largest sensing violation {sensing_violation_m:.2} m)"
    )]
    TimeLimit {
        /// The limit, s.
        limit_s: f64,
        /// Phase I iterations run on the mission's own grid.
        iterations: usize,
        /// Largest sensing violation of the last accepted repair iterate, m.
        sensing_violation_m: f64,
    },
    /// Best-effort options given to a plan that would ignore them
    /// ([`PlanOptions::check_best_effort`](super::PlanOptions::check_best_effort)).
    #[error(transparent)]
    OptionConflict(#[from] super::OptionConflict),
    /// A vehicle model the scheme cannot plan with (`paper` and `baseline` have the paper's
    /// model only).
    #[error(
        "dynamics {dynamics} applies to the exact-geometry schemes (exact, baseline-exact) only, \
         not to {scheme}"
    )]
    DynamicsConflict {
        /// The scheme.
        scheme: super::Scheme,
        /// The vehicle model asked for.
        dynamics: crate::evaluate::Dynamics,
    },
    /// A mission with `altitude = "free"` given to a scheme that plans at one altitude (every
    /// scheme but `exact` and `paper`), or to those by a caller that flies one altitude (without
    /// [`PlanOptions::altitude_profile`](super::PlanOptions::altitude_profile)): refused rather
    /// than planned at the fixed altitude `altitude_m`.
    #[error(
        "mission parameter `altitude` = \"free\": the scheme {scheme} plans at the fixed \
         altitude `altitude_m` only here, not per-slot altitudes (only the schemes exact and paper \
         plan them, for a caller that flies the profile: the user guide's section Altitude lists \
         which; or set altitude = \"fixed\")"
    )]
    AltitudeConflict {
        /// The scheme.
        scheme: super::Scheme,
    },
    /// An option is out of range.
    #[error("option `{field}` = {value}: {reason}")]
    InvalidOption {
        /// The option's name (its field of [`PlanOptions`](super::PlanOptions)).
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        reason: &'static str,
    },
}
