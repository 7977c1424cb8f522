//! The errors of the Zenoh layer ([`NetError`]).

use std::time::Duration;

use crate::envelope::CodecError;
use crate::keys::KeyError;
use crate::refusal::Refusal;
use crate::zenoh_error::ZenohError;

/// Errors of the Zenoh layer. Each names the key and the operation, and prints its cause in
/// its own message (none is returned as `source()`, so a chain printer shows each once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NetError {
    /// Zenoh refused an operation.
    #[error("zenoh {op} on {key:?} failed: {error}")]
    Zenoh {
        /// Operation (declare publisher, put, close, ...).
        op: &'static str,
        /// Key expression concerned (the liveliness token's key for the session itself).
        key: String,
        /// Zenoh's error (printed on one line, without Zenoh's source locations).
        error: ZenohError,
    },
    /// The Zenoh session could not be opened (a listen endpoint taken, a configuration that
    /// Zenoh refuses, no router or peer reachable within the configured connect timeout).
    #[error("opening the Zenoh session ({session}) failed: {error}")]
    Open {
        /// What was being opened: the mode and the endpoints ([`crate::zconfig::describe`]).
        session: String,
        /// Zenoh's error (printed on one line, without Zenoh's source locations).
        error: ZenohError,
    },
    /// The thread that opens the Zenoh session ([`super::ZenohNode::open_until`]) could not
    /// be started or ended without an answer.
    #[error("opening the Zenoh session ({session}) failed: {reason}")]
    OpenThread {
        /// What was being opened: the mode and the endpoints ([`crate::zconfig::describe`]).
        session: String,
        /// What happened to the thread.
        reason: String,
    },
    /// No router or peer made the Zenoh session open within the time given
    /// ([`super::ZenohNode::open_within`]).
    #[error(
        "no Zenoh router or peer reachable within {} s: the session ({session}) did not open",
        waited.as_secs_f64()
    )]
    OpenTimeout {
        /// What was being opened: the mode and the endpoints ([`crate::zconfig::describe`]).
        session: String,
        /// How long it waited.
        waited: Duration,
    },
    /// A key was invalid.
    #[error(transparent)]
    Key(#[from] KeyError),
    /// A message could not be encoded or a reply decoded.
    #[error("{key}: {error}")]
    Codec {
        /// Key expression.
        key: String,
        /// Codec error.
        error: CodecError,
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
    /// A queryable refused the request with a typed [`Refusal`] ([`IncomingQuery::refuse`](crate::net::queryable::IncomingQuery::refuse)).
    #[error("query {key:?} refused ({}): {}", refusal.kind, refusal.message)]
    Refused {
        /// Key expression.
        key: String,
        /// The refusal: its kind and message.
        refusal: Refusal,
    },
    /// A query's replies went past a bound of its options ([`super::QueryOptions`]: a
    /// number of replies or of bytes); the replies past it were not read.
    #[error("query {key:?}: the replies went past {limit} {what}; the rest were not read")]
    TooManyReplies {
        /// Key expression.
        key: String,
        /// The bound: `replies` or `bytes`.
        what: &'static str,
        /// Its value.
        limit: u64,
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

impl NetError {
    /// A failed Zenoh operation `op` on `key`, with Zenoh's error (also for code that calls
    /// Zenoh directly, a queryable declared on the raw session for one).
    pub fn zenoh(op: &'static str, key: &str, error: impl Into<zenoh::Error>) -> Self {
        NetError::Zenoh {
            op,
            key: key.to_string(),
            error: ZenohError::new(error),
        }
    }

    /// A message for `key` that could not be encoded, or a reply that could not be decoded.
    pub fn codec(key: &str, error: CodecError) -> Self {
        NetError::Codec {
            key: key.to_string(),
            error,
        }
    }
}
