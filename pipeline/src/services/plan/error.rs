//! The error of the plan service and of the status board, plan cache and state files that
//! every service shares.

use std::path::Path;

use bridge::{Refusal, RefusalKind};
use planner::driver::PlanError;

use crate::protocol::BadRequest;

/// Errors of the planner service; each names what failed. A variant whose message includes
/// its cause does not also return it from `source()` (each cause is printed once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServiceError {
    /// Zenoh failed.
    #[error(transparent)]
    Net(#[from] bridge::NetError),
    /// The Zenoh flags or configuration file are invalid.
    #[error(transparent)]
    Config(#[from] bridge::zconfig::ConfigError),
    /// A key could not be built.
    #[error(transparent)]
    Key(#[from] bridge::keys::KeyError),
    /// A file of the state directory could not be read or written.
    #[error("{path}: {error}")]
    Io {
        /// The file or directory.
        path: String,
        /// The I/O error (in the message).
        error: std::io::Error,
    },
    /// A message could not be encoded.
    #[error("{what}: {error}")]
    Codec {
        /// What was being encoded.
        what: String,
        /// The codec error (in the message).
        error: bridge::CodecError,
    },
    /// The signal handlers could not be installed.
    #[error("installing the handler of signal {signal}: {error}")]
    Signal {
        /// Signal number.
        signal: i32,
        /// The OS error (in the message).
        error: std::io::Error,
    },
    /// A request was invalid (the message names the field).
    #[error("{0}")]
    BadRequest(String),
    /// Planning a valid mission failed: it cannot be flown, the start trajectory does not
    /// fit, or the solver failed ([`PlanError`] says which).
    #[error("planning {mission:?}: {error}")]
    Plan {
        /// The mission's name.
        mission: String,
        /// The planner's error.
        error: PlanError,
    },
    /// A worker thread failed.
    #[error("{0}")]
    Internal(String),
    /// A thread the service depends on ended while the service ran
    /// ([`crate::services::threads`]).
    #[error("the {thread} thread stopped: {cause}")]
    ThreadStopped {
        /// The thread, in words.
        thread: String,
        /// Its error, its panic's message, or that it returned.
        cause: String,
    },
    /// Planning did not end within the service's work budget (`--plan-budget-s`); the
    /// planning was stopped and the service went on to the next request.
    #[error(
        "planning {mission:?} did not end within the planner's work budget of {budget_s} s \
         (--plan-budget-s): the request is refused and the planner serves the next one"
    )]
    OverBudget {
        /// The mission's name.
        mission: String,
        /// The budget, s.
        budget_s: f64,
    },
    /// The plan worker refused the request (its refusal, kind and message, as it is).
    #[error("{}", .0.message)]
    Refused(Refusal),
}

impl From<BadRequest> for ServiceError {
    fn from(e: BadRequest) -> Self {
        ServiceError::BadRequest(e.0)
    }
}

impl ServiceError {
    /// Whether the service could not start because of its flags or configuration (the
    /// binaries' exit code 2), rather than failing at run time.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, ServiceError::Config(_))
    }

    /// The typed refusal a plan request is answered with: a request that names a bad field
    /// (or a start trajectory that does not fit) is `bad_request`, a mission proven impossible
    /// `infeasible`, a plan not found `not_found`, the rest (a solver or worker failure, a plan
    /// over the work budget) `internal`; the message is this error's (a worker's refusal is
    /// answered as it is).
    pub fn refusal(&self) -> Refusal {
        if let ServiceError::Refused(r) = self {
            return r.clone();
        }
        let kind = match self {
            ServiceError::BadRequest(_)
            | ServiceError::Plan {
                error:
                    PlanError::InvalidInit(_)
                    | PlanError::InvalidOption { .. }
                    | PlanError::OptionConflict(_)
                    | PlanError::AltitudeConflict { .. },
                ..
            } => RefusalKind::BadRequest,
            ServiceError::Plan {
                error: PlanError::Infeasible(_),
                ..
            } => RefusalKind::Infeasible,
            ServiceError::Plan {
                error: PlanError::NotFound(_),
                ..
            } => RefusalKind::NotFound,
            _ => RefusalKind::Internal,
        };
        Refusal::new(kind, self.to_string())
    }
}

impl From<ServiceError> for cellsar_error::exit::Failure {
    /// Bad flags or configuration exit 2 ([`ServiceError::is_bad_input`]), the rest 1.
    fn from(e: ServiceError) -> Self {
        Self::bad_input_or_runtime(e.is_bad_input(), e)
    }
}

impl ServiceError {
    /// An [`ServiceError::Io`] naming `path`.
    pub(crate) fn io(path: &Path, error: std::io::Error) -> Self {
        ServiceError::Io {
            path: path.display().to_string(),
            error,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error as _;

    /// A cause in the message is not returned again from `source()`, so the printed chain
    /// names it once; a transparent variant forwards both to its inner error.
    #[test]
    fn each_cause_is_printed_once() {
        let io = || std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = ServiceError::io(Path::new("/state/a.plan"), io());
        assert_eq!(e.to_string(), "/state/a.plan: no such file");
        assert!(e.source().is_none());
        assert_eq!(cellsar_error::error_chain(&e), e.to_string());
        let e = ServiceError::Signal {
            signal: 2,
            error: io(),
        };
        assert!(e.source().is_none() && e.to_string().ends_with(": no such file"));
        let e = crate::services::radar::ServiceError::Io {
            path: "/state/metrics.bin".into(),
            error: io(),
        };
        assert!(e.source().is_none());
        assert_eq!(
            cellsar_error::error_chain(&e),
            "/state/metrics.bin: no such file"
        );
        let e = crate::services::radar::ServiceError::from(ServiceError::io(
            Path::new("/state/a.plan"),
            io(),
        ));
        assert!(e.source().is_none());
        assert_eq!(
            cellsar_error::error_chain(&e),
            "/state/a.plan: no such file"
        );
    }
}
