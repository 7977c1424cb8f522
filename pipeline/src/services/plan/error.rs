//! The error of the plan service and of the status board, plan cache and state files that
//! every service shares.

use std::path::Path;

use bridge::{Refusal, RefusalKind};
use planner::driver::PlanError;

use crate::protocol::BadRequest;

/// Errors of the planner service; each names what failed.
#[derive(Debug, thiserror::Error)]
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
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A message could not be encoded.
    #[error("{what}: {source}")]
    Codec {
        /// What was being encoded.
        what: String,
        /// The codec error.
        source: bridge::CodecError,
    },
    /// The signal handlers could not be installed.
    #[error("installing the handler of signal {signal}: {source}")]
    Signal {
        /// Signal number.
        signal: i32,
        /// The OS error.
        #[source]
        source: std::io::Error,
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
    /// (or a start trajectory that does not fit) is `bad_request`, a mission that cannot be
    /// flown `infeasible`, the rest (a solver or worker failure) `internal`; the message is
    /// this error's.
    pub fn refusal(&self) -> Refusal {
        let kind = match self {
            ServiceError::BadRequest(_)
            | ServiceError::Plan {
                error: PlanError::InvalidInit(_) | PlanError::InvalidOption { .. },
                ..
            } => RefusalKind::BadRequest,
            ServiceError::Plan {
                error: PlanError::Infeasible(_),
                ..
            } => RefusalKind::Infeasible,
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
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        ServiceError::Io {
            path: path.display().to_string(),
            source,
        }
    }
}
