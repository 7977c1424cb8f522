//! Why a subproblem did not give a usable solution: [`SolveError`].

use clarabel::solver::SolverStatus;

/// Why a subproblem did not give a usable solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SolveError {
    /// Clarabel rejected the problem data (a bug in the assembly; names the cause).
    #[error("solver setup failed: {0}")]
    Setup(String),
    /// Clarabel proved the subproblem infeasible.
    #[error("subproblem is infeasible (solver status {0:?})")]
    Infeasible(SolverStatus),
    /// Clarabel proved the subproblem unbounded.
    #[error("subproblem is unbounded (solver status {0:?})")]
    Unbounded(SolverStatus),
    /// Clarabel stopped without a solution of the required accuracy.
    #[error("solver stopped with status {status:?} (cone violation {violation:.3e})")]
    Inaccurate {
        /// Clarabel's status.
        status: SolverStatus,
        /// Our residual check: largest cone violation of the returned point.
        violation: f64,
    },
}

impl SolveError {
    /// Whether a more accurate linear algebra could change the outcome (everything but a setup
    /// error: an inaccurate stop, or an infeasibility or unboundedness certificate).
    pub fn may_be_numerical(&self) -> bool {
        !matches!(self, SolveError::Setup(_))
    }
}
