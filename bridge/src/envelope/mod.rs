//! The versioned envelope and the codec of every cellsar message.
//!
//! # Wire layout (binary form)
//!
//! A message is a fixed 48-byte header followed by the body. All integers are little endian.
//!
//! | offset | size | field            | meaning                                                  |
//! |-------:|-----:|------------------|----------------------------------------------------------|
//! |      0 |    4 | `magic`          | `b"CSAR"`                                                |
//! |      4 |    1 | `header_version` | [`HEADER_VERSION`] (1)                                   |
//! |      5 |    1 | `body_format`    | [`BodyFormat`]: 0 = bincode 2 (serde), 1 = raw frame     |
//! |      6 |    2 | `kind`           | message kind ([`Message::KIND`])                         |
//! |      8 |    2 | `schema_version` | version of the body's schema ([`Message::SCHEMA_VERSION`]) |
//! |     10 |    2 | `flags`          | bit 0: `body_crc32` is valid ([`FLAG_CRC`])              |
//! |     12 |    4 | `body_crc32`     | CRC-32 (IEEE) of the body (of the samples for raw frames) |
//! |     16 |    8 | `mission_id`     | [`MissionId`]                                            |
//! |     24 |    8 | `seq`            | sequence number, per publisher                           |
//! |     32 |    8 | `time_unix_ns`   | creation time, ns since the Unix epoch                   |
//! |     40 |    8 | `body_len`       | length of the body in bytes                              |
//!
//! Bodies are bincode 2 with the standard configuration (varint integers, little endian) and a
//! hard size limit ([`MAX_BODY_BYTES`]); IQ frames carry raw little-endian samples instead
//! (see [`crate::frame`]).
//!
//! # JSON form
//!
//! Control-plane messages can also travel as JSON (Zenoh encoding `application/json`) so that
//! tools without Rust (a Python `eclipse-zenoh` client) can read them:
//!
//! ```json
//! {"kind": 4097, "kind_name": "bridge.stats", "schema_version": 1,
//!  "mission_id": "0000000000000000", "seq": 3, "time_unix_ns": 1700000000000000000,
//!  "body": { ... }}
//! ```
//!
//! Decoding is bounded and never panics: every failure is a [`CodecError`] that names the field
//! (or the expected/actual kind and version) that was wrong.

use serde::de::DeserializeOwned;
use serde::Serialize;

mod codec;
mod error;
mod header;
mod json;
mod mission;

pub use codec::{decode, encode, now_unix_ns, split, DecodeLimits, Envelope, Meta};
pub use error::CodecError;
pub(crate) use header::{le_u16, le_u32, le_u64};
pub use header::{BodyFormat, Header};
pub use json::{decode_json, encode_json};
pub use mission::MissionId;

/// Magic bytes at the start of every binary envelope.
pub const MAGIC: [u8; 4] = *b"CSAR";
/// Version of the header layout described in the module documentation.
pub const HEADER_VERSION: u8 = 1;
/// Size of the binary header in bytes.
pub const HEADER_LEN: usize = 48;
/// Header flag: `body_crc32` holds the CRC-32 of the body.
pub const FLAG_CRC: u16 = 1;
/// Hard upper bound on any body this codec accepts (64 MiB). It is also the bincode size
/// limit, so a forged length prefix inside a body can never make the decoder allocate more.
pub const MAX_BODY_BYTES: usize = 64 << 20;
/// Default bound for control-plane message bodies (16 MiB); see [`DecodeLimits`].
pub const DEFAULT_MAX_MESSAGE_BYTES: usize = 16 << 20;

/// The bincode configuration of every body: standard (varint, little endian) with the hard
/// [`MAX_BODY_BYTES`] limit.
pub fn bincode_config() -> bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Varint,
    bincode::config::Limit<MAX_BODY_BYTES>,
> {
    bincode::config::standard().with_limit::<MAX_BODY_BYTES>()
}

/// A typed message: a serde type with a fixed kind and schema version.
///
/// Kinds are assigned by the crate that defines the message; `0x1000..=0x10ff` are reserved
/// for the bridge itself ([`crate::stats::BridgeStats`]), raw frames use
/// [`crate::frame::IQ_FRAME_KIND`]. Bump `SCHEMA_VERSION` on any change of the serde layout:
/// a receiver with another version rejects the message with [`CodecError::SchemaVersion`].
pub trait Message: Serialize + DeserializeOwned {
    /// Message kind written into the header.
    const KIND: u16;
    /// Human-readable name of the kind (logs, errors, the JSON form).
    const NAME: &'static str;
    /// Version of the body's schema.
    const SCHEMA_VERSION: u16;
}

#[cfg(test)]
mod tests;
