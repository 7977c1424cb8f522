//! The errors of the envelope codec ([`CodecError`]).

use super::{BodyFormat, HEADER_LEN, HEADER_VERSION};

/// Errors of the envelope codec. Each names what was wrong.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum CodecError {
    /// The payload is shorter than a header.
    #[error("payload of {len} bytes is shorter than the {HEADER_LEN}-byte envelope header")]
    TooShort {
        /// Length of the payload.
        len: usize,
    },
    /// The magic bytes are wrong.
    #[error("bad magic {found:02x?}: not a cellsar envelope (expected \"CSAR\")")]
    BadMagic {
        /// The four bytes found.
        found: [u8; 4],
    },
    /// Unsupported header layout version.
    #[error(
        "unsupported envelope header version {found} (this build reads version {HEADER_VERSION})"
    )]
    HeaderVersion {
        /// Version found.
        found: u8,
    },
    /// A message of another kind than expected.
    #[error("wrong message kind: expected {expected} ({expected_name}), got {found}")]
    WrongKind {
        /// Kind expected by the receiver.
        expected: u16,
        /// Name of the expected kind.
        expected_name: &'static str,
        /// Kind found in the header.
        found: u16,
    },
    /// The schema version of the body differs from the receiver's.
    #[error("wrong schema version for {name}: expected {expected}, got {found}")]
    SchemaVersion {
        /// Name of the kind.
        name: &'static str,
        /// Version the receiver understands.
        expected: u16,
        /// Version found in the header.
        found: u16,
    },
    /// The body format is not the one expected.
    #[error("wrong body format for {name}: expected {expected:?}, got {found:?}")]
    WrongFormat {
        /// Name of the kind.
        name: &'static str,
        /// Expected format.
        expected: BodyFormat,
        /// Format found.
        found: BodyFormat,
    },
    /// The body is larger than allowed.
    #[error("{what} of {len} bytes exceeds the limit of {limit} bytes")]
    TooLarge {
        /// What was too large.
        what: &'static str,
        /// Its length.
        len: u64,
        /// The limit.
        limit: u64,
    },
    /// `body_len` disagrees with the payload.
    #[error("body_len field says {declared} bytes but {actual} bytes follow the header")]
    LengthMismatch {
        /// Declared by the header.
        declared: u64,
        /// Actually present.
        actual: u64,
    },
    /// The body's CRC does not match.
    #[error("body checksum mismatch: header says {expected:#010x}, body has {actual:#010x}")]
    Checksum {
        /// From the header.
        expected: u32,
        /// Computed.
        actual: u32,
    },
    /// bincode could not decode the body.
    #[error("cannot decode {name} body (bincode): {reason}")]
    Body {
        /// Name of the kind.
        name: &'static str,
        /// bincode's message.
        reason: String,
    },
    /// bincode did not consume the whole body.
    #[error("{name} body has {extra} trailing bytes after the decoded value")]
    TrailingBytes {
        /// Name of the kind.
        name: &'static str,
        /// Unconsumed bytes.
        extra: usize,
    },
    /// A field has an invalid value.
    #[error("invalid field {field}: {reason}")]
    Field {
        /// Field name.
        field: &'static str,
        /// Why.
        reason: String,
    },
    /// JSON form could not be parsed.
    #[error("cannot decode JSON message: {0}")]
    Json(String),
    /// Encoding failed (a serde type that bincode cannot represent, or too large).
    #[error("cannot encode {name}: {reason}")]
    Encode {
        /// Name of the kind.
        name: &'static str,
        /// Why.
        reason: String,
    },
}
