//! The errors of the forwarder ([`ForwardError`]).

use crate::iox::IoxError;
use crate::net::NetError;

/// Errors of the forwarder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ForwardError {
    /// A route specification is invalid.
    #[error("invalid route {route:?}: {reason}")]
    Route {
        /// The route as given.
        route: String,
        /// Why.
        reason: String,
    },
    /// iceoryx2 failed.
    #[error(transparent)]
    Iox(#[from] IoxError),
    /// Zenoh failed.
    #[error(transparent)]
    Net(#[from] NetError),
    /// A forwarding thread failed or panicked.
    #[error("forwarder thread {thread} failed: {reason}")]
    Thread {
        /// Which thread.
        thread: &'static str,
        /// Why.
        reason: String,
    },
}
