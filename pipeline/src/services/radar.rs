//! The radar as services: `cellsar-radar-sim echo` (UAV side: synthesises the IQ of the
//! apertures a processor asks for, publishes them as frames on iceoryx2) and
//! `cellsar-radar-sim process-service` (BS side: pulls apertures, cancels, images, detects,
//! publishes detections and images on Zenoh).
//!
//! The keys they use are listed in [`crate::protocol::keys`].
//!
//! # Delivery: pull, at least once, de-duplicated
//! The processor drives: it asks the echo for at most `--window` apertures at a time
//! (`ApertureRequest`, a Zenoh query; the reply says which frame sequence numbers will come),
//! and asks again for an aperture whose frames stop arriving for `--resend-after-s` (frames
//! lost to a full buffer, a frozen or restarted process, a dead bridge or router). Frame
//! sequence numbers are a pure function of the mission ([`crate::protocol::FrameLayout`]): a re-sent frame has
//! its original number, so the processor keeps the first copy of each and drops the rest. The
//! echo keeps no state beyond its queue. The processor stores each finished aperture in
//! `--state-dir` before publishing it, so after a restart it resumes with the next one and
//! re-publishes the stored results (consumers de-duplicate by mission and aperture). Frames
//! never cross looks, so a single look can be asked for again (the resolution measurement at
//! the end of a mission does that).
//!
//! Their messages are in [`crate::protocol::radar`]; this module holds their common error.

use std::path::PathBuf;

/// Default largest frame payload, bytes (4 MiB: 100 pulses of 4096 samples fit; an iceoryx2
/// publisher then maps 13 × 4 MiB of shared memory).
/// The same value as `cellsar-bridge` and `cellsar run` use ([`bridge::frame::SERVICE_MAX_FRAME_BYTES`]):
/// the services and the bridge must agree on it.
pub const DEFAULT_MAX_FRAME_BYTES: usize = bridge::frame::SERVICE_MAX_FRAME_BYTES;

/// Errors of the radar services; each names what failed. A variant whose message includes its
/// cause does not also return it from `source()` (each cause is printed once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServiceError {
    /// The radar library failed.
    #[error(transparent)]
    Radar(#[from] radar_sim::RadarError),
    /// The planner service layer failed.
    #[error(transparent)]
    Planner(#[from] super::plan::ServiceError),
    /// Zenoh failed.
    #[error(transparent)]
    Net(#[from] bridge::NetError),
    /// iceoryx2 failed.
    #[error(transparent)]
    Iox(#[from] bridge::iox::IoxError),
    /// The Zenoh flags or file are invalid.
    #[error(transparent)]
    Config(#[from] bridge::zconfig::ConfigError),
    /// A key could not be built.
    #[error(transparent)]
    Key(#[from] bridge::keys::KeyError),
    /// A mission of a plan is invalid.
    #[error("mission {mission}: {reason}")]
    Mission {
        /// Mission id.
        mission: bridge::MissionId,
        /// Why.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error (in the message).
        error: std::io::Error,
    },
    /// A stored or received message could not be encoded or decoded.
    #[error("{what}: {error}")]
    Codec {
        /// What.
        what: String,
        /// The codec error (in the message).
        error: bridge::CodecError,
    },
    /// The frames of a mission cannot be laid out (the message names the flag).
    #[error(transparent)]
    Layout(#[from] crate::protocol::layout::LayoutError),
    /// A flag is invalid (the message names it).
    #[error("{0}")]
    Flag(String),
    /// A worker thread stopped unexpectedly.
    #[error("{0}")]
    Internal(String),
}

impl From<ServiceError> for cellsar_error::exit::Failure {
    /// Bad input (exit 2): the flags, the Zenoh configuration, a radar input that is bad
    /// ([`radar_sim::RadarError::is_bad_input`]) and the planner layer's bad input; the rest is a
    /// failure at run time (exit 1).
    fn from(e: ServiceError) -> Self {
        let bad = match &e {
            ServiceError::Radar(r) => r.is_bad_input(),
            ServiceError::Config(_) | ServiceError::Flag(_) | ServiceError::Layout(_) => true,
            ServiceError::Planner(p) => p.is_bad_input(),
            _ => false,
        };
        Self::bad_input_or_runtime(bad, e)
    }
}

/// Result of the services.
pub type ServiceResult<T> = std::result::Result<T, ServiceError>;
