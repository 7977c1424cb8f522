//! The errors of the Zenoh layer ([`NetError`]).

use std::time::Duration;

use crate::envelope::CodecError;
use crate::keys::KeyError;
use crate::refusal::Refusal;

/// Errors of the Zenoh layer. Each names the key and the operation.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// Zenoh refused an operation.
    #[error("zenoh {op} on {key:?} failed: {reason}")]
    Zenoh {
        /// Operation (declare publisher, put, close, ...).
        op: &'static str,
        /// Key expression concerned (the liveliness token's key for the session itself).
        key: String,
        /// Zenoh's message.
        reason: String,
    },
    /// The Zenoh session could not be opened (a listen endpoint taken, a configuration that
    /// Zenoh refuses, no router or peer reachable within the configured connect timeout).
    #[error("opening the Zenoh session ({session}) failed: {reason}")]
    Open {
        /// What was being opened: the mode and the endpoints ([`zconfig::describe`]).
        session: String,
        /// Zenoh's message, on one line.
        reason: String,
    },
    /// A key was invalid.
    #[error(transparent)]
    Key(#[from] KeyError),
    /// A message could not be encoded or a reply decoded.
    #[error("{key}: {source}")]
    Codec {
        /// Key expression.
        key: String,
        /// Codec error.
        source: CodecError,
    },
    /// A queryable answered with an error that is not a typed [`Refusal`] (a plain text from
    /// an older or foreign queryable).
    #[error("query {key:?} answered with an error: {message}")]
    Remote {
        /// Key expression.
        key: String,
        /// The error text of the reply.
        message: String,
    },
    /// A queryable refused the request with a typed [`Refusal`] ([`IncomingQuery::refuse`]).
    #[error("query {key:?} refused ({}): {}", refusal.kind, refusal.message)]
    Refused {
        /// Key expression.
        key: String,
        /// The refusal: its kind and message.
        refusal: Refusal,
    },
    /// A query got no (good) reply before its timeout.
    #[error("query {key:?}: no reply within {timeout:?}")]
    NoReply {
        /// Key expression.
        key: String,
        /// The timeout.
        timeout: Duration,
    },
}

pub(super) fn zerr(op: &'static str, key: &str, e: impl std::fmt::Display) -> NetError {
    NetError::Zenoh {
        op,
        key: key.to_string(),
        reason: e.to_string(),
    }
}
