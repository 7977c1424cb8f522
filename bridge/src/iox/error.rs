//! The errors of the iceoryx2 layer ([`IoxError`]).

use crate::envelope::CodecError;

/// Errors of the iceoryx2 layer; each names the service and the step that failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IoxError {
    /// An iceoryx2 call failed.
    #[error("iceoryx2: {step} for {service:?} failed: {reason}")]
    Iceoryx {
        /// What was being done.
        step: &'static str,
        /// Service (or node) name.
        service: String,
        /// iceoryx2's error.
        reason: String,
    },
    /// A specification value is invalid.
    #[error("invalid frame service spec for {service:?}: {field} {reason}")]
    Spec {
        /// Service name.
        service: String,
        /// Field name.
        field: &'static str,
        /// Why.
        reason: String,
    },
    /// A frame is inconsistent.
    #[error("frame on {service:?}: {error}")]
    Frame {
        /// Service name.
        service: String,
        /// What was wrong (printed in this message, not returned as `source()`).
        error: CodecError,
    },
}

pub(super) fn ierr(step: &'static str, service: &str, e: impl std::fmt::Debug) -> IoxError {
    IoxError::Iceoryx {
        step,
        service: service.to_string(),
        reason: format!("{e:?}"),
    }
}
