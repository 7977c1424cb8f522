//! Why planning failed: [`PlanError`].

use crate::init::Infeasibility;
use crate::socp::SolveError;

/// Why planning failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// The mission cannot be flown (found before or during phase I).
    #[error(transparent)]
    Infeasible(#[from] Infeasibility),
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
