//! Typed errors of the radar library. Each names the field, file, pulse or aperture at fault.

/// Everything that can go wrong in the radar library. A variant whose message includes its
/// cause does not also return it from `source()` (each cause is printed once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RadarError {
    /// A configuration value is invalid; `field` is its dotted name in the scene file.
    #[error("{field}: {reason}")]
    Config {
        /// Dotted name, e.g. `radar.prf_hz`.
        field: String,
        /// What the value must satisfy.
        reason: String,
    },
    /// The plan and the scene do not fit (e.g. no landmark in the beam, an empty aperture).
    #[error("plan/scene mismatch: {0}")]
    Mismatch(String),
    /// A numerical step failed (e.g. a singular canceller Gram matrix).
    #[error("numerical failure in {stage}: {reason}")]
    Numerical {
        /// Processing stage, e.g. `cancel` (pulse 17).
        stage: String,
        /// What happened.
        reason: String,
    },
    /// An input array has the wrong shape.
    #[error("{what}: expected {expected}, found {found}")]
    Shape {
        /// Which array.
        what: String,
        /// Expected size or shape.
        expected: String,
        /// Actual size or shape.
        found: String,
    },
    /// An input file could not be read (missing, unreadable, truncated).
    #[error("{path}: {error}")]
    Read {
        /// The file.
        path: String,
        /// The OS error (in the message, so not also a `source()`).
        error: std::io::Error,
    },
    /// An output file could not be written (or a directory created).
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The OS error (in the message, so not also a `source()`).
        error: std::io::Error,
    },
    /// A file has bad content; `location` names the line, field or header entry.
    #[error("{path}, {location}: {reason}")]
    Format {
        /// The file.
        path: String,
        /// Where in the file.
        location: String,
        /// What is wrong.
        reason: String,
    },
}

impl RadarError {
    /// Shorthand for [`RadarError::Config`].
    pub fn config(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Self::Config {
            field: field.into(),
            reason: reason.into(),
        }
    }

    /// Shorthand for [`RadarError::Format`].
    pub fn format(
        path: impl Into<String>,
        location: impl Into<String>,
        reason: impl Into<String>,
    ) -> Self {
        Self::Format {
            path: path.into(),
            location: location.into(),
            reason: reason.into(),
        }
    }

    /// Shorthand for [`RadarError::Io`] (an output could not be written).
    pub fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.display().to_string(),
            error: source,
        }
    }

    /// Shorthand for [`RadarError::Read`] (an input could not be read).
    pub fn read(path: &std::path::Path, source: std::io::Error) -> Self {
        Self::Read {
            path: path.display().to_string(),
            error: source,
        }
    }

    /// Whether the error is the caller's input: an invalid scene value or option, a missing
    /// or malformed input file, a plan that does not fit the scene ([`RadarError::Config`],
    /// [`RadarError::Read`], [`RadarError::Format`], [`RadarError::Mismatch`]). The others
    /// (a failed write, a numerical failure, an inconsistent array) are runtime failures.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            Self::Config { .. } | Self::Read { .. } | Self::Format { .. } | Self::Mismatch(_)
        )
    }
}

/// Result alias of the radar library.
pub type Result<T> = std::result::Result<T, RadarError>;
