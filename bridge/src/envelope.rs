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

use std::fmt;
use std::time::{SystemTime, UNIX_EPOCH};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

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

/// Identifier of a mission (64 bits); shown and used in key expressions as 16 lower-case hex
/// digits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MissionId(pub u64);

impl MissionId {
    /// A stable id derived from a mission name (FNV-1a, 64 bit), so that every process that
    /// reads the same mission file agrees on the id without coordination.
    pub fn from_name(name: &str) -> Self {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in name.as_bytes() {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        MissionId(h)
    }

    /// Parses the 16-hex-digit form written by `Display`.
    pub fn parse_hex(s: &str) -> Result<Self, CodecError> {
        if s.is_empty() || s.len() > 16 || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(CodecError::Field {
                field: "mission_id",
                reason: format!("expected up to 16 hex digits, got {s:?}"),
            });
        }
        u64::from_str_radix(s, 16)
            .map(MissionId)
            .map_err(|e| CodecError::Field {
                field: "mission_id",
                reason: format!("{s:?}: {e}"),
            })
    }
}

impl fmt::Display for MissionId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

impl Serialize for MissionId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            s.serialize_str(&self.to_string())
        } else {
            s.serialize_u64(self.0)
        }
    }
}

impl<'de> Deserialize<'de> for MissionId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        if d.is_human_readable() {
            let s = String::deserialize(d)?;
            MissionId::parse_hex(&s).map_err(serde::de::Error::custom)
        } else {
            u64::deserialize(d).map(MissionId)
        }
    }
}

/// How the body after the header is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BodyFormat {
    /// bincode 2 (serde) with [`bincode_config`].
    Bincode,
    /// A raw frame: frame descriptor + little-endian samples (see [`crate::frame`]).
    RawFrame,
}

impl BodyFormat {
    fn to_u8(self) -> u8 {
        match self {
            BodyFormat::Bincode => 0,
            BodyFormat::RawFrame => 1,
        }
    }

    fn from_u8(v: u8) -> Result<Self, CodecError> {
        match v {
            0 => Ok(BodyFormat::Bincode),
            1 => Ok(BodyFormat::RawFrame),
            other => Err(CodecError::Field {
                field: "body_format",
                reason: format!("unknown body format {other} (known: 0 = bincode, 1 = raw frame)"),
            }),
        }
    }
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

/// Errors of the envelope codec. Each names what was wrong.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
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

/// The decoded header of an envelope.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Body format.
    pub body_format: BodyFormat,
    /// Message kind.
    pub kind: u16,
    /// Schema version of the body.
    pub schema_version: u16,
    /// Header flags ([`FLAG_CRC`]).
    pub flags: u16,
    /// CRC-32 of the body (valid when `flags & FLAG_CRC != 0`).
    pub body_crc32: u32,
    /// Mission id.
    pub mission_id: MissionId,
    /// Sequence number.
    pub seq: u64,
    /// Creation time, ns since the Unix epoch.
    pub time_unix_ns: u64,
    /// Body length in bytes.
    pub body_len: u64,
}

impl Header {
    /// Writes the 48-byte binary header.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        b[0..4].copy_from_slice(&MAGIC);
        b[4] = HEADER_VERSION;
        b[5] = self.body_format.to_u8();
        b[6..8].copy_from_slice(&self.kind.to_le_bytes());
        b[8..10].copy_from_slice(&self.schema_version.to_le_bytes());
        b[10..12].copy_from_slice(&self.flags.to_le_bytes());
        b[12..16].copy_from_slice(&self.body_crc32.to_le_bytes());
        b[16..24].copy_from_slice(&self.mission_id.0.to_le_bytes());
        b[24..32].copy_from_slice(&self.seq.to_le_bytes());
        b[32..40].copy_from_slice(&self.time_unix_ns.to_le_bytes());
        b[40..48].copy_from_slice(&self.body_len.to_le_bytes());
        b
    }

    /// Parses the header at the start of `payload` (the body is not looked at).
    pub fn parse(payload: &[u8]) -> Result<Header, CodecError> {
        let Some(h) = payload.get(..HEADER_LEN) else {
            return Err(CodecError::TooShort { len: payload.len() });
        };
        let mut magic = [0u8; 4];
        magic.copy_from_slice(&h[0..4]);
        if magic != MAGIC {
            return Err(CodecError::BadMagic { found: magic });
        }
        if h[4] != HEADER_VERSION {
            return Err(CodecError::HeaderVersion { found: h[4] });
        }
        let body_format = BodyFormat::from_u8(h[5])?;
        let flags = le_u16(&h[10..12]);
        if flags & !FLAG_CRC != 0 {
            return Err(CodecError::Field {
                field: "flags",
                reason: format!("unknown flag bits {:#06x}", flags & !FLAG_CRC),
            });
        }
        Ok(Header {
            body_format,
            kind: le_u16(&h[6..8]),
            schema_version: le_u16(&h[8..10]),
            flags,
            body_crc32: le_u32(&h[12..16]),
            mission_id: MissionId(le_u64(&h[16..24])),
            seq: le_u64(&h[24..32]),
            time_unix_ns: le_u64(&h[32..40]),
            body_len: le_u64(&h[40..48]),
        })
    }

    /// Checks kind and schema version against the message type `M`.
    pub fn expect<M: Message>(&self) -> Result<(), CodecError> {
        if self.kind != M::KIND {
            return Err(CodecError::WrongKind {
                expected: M::KIND,
                expected_name: M::NAME,
                found: self.kind,
            });
        }
        if self.schema_version != M::SCHEMA_VERSION {
            return Err(CodecError::SchemaVersion {
                name: M::NAME,
                expected: M::SCHEMA_VERSION,
                found: self.schema_version,
            });
        }
        Ok(())
    }

    /// Whether the header carries a body CRC.
    pub fn has_crc(&self) -> bool {
        self.flags & FLAG_CRC != 0
    }
}

pub(crate) fn le_u16(b: &[u8]) -> u16 {
    let mut a = [0u8; 2];
    a.copy_from_slice(&b[..2]);
    u16::from_le_bytes(a)
}
pub(crate) fn le_u32(b: &[u8]) -> u32 {
    let mut a = [0u8; 4];
    a.copy_from_slice(&b[..4]);
    u32::from_le_bytes(a)
}
pub(crate) fn le_u64(b: &[u8]) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[..8]);
    u64::from_le_bytes(a)
}

/// Nanoseconds since the Unix epoch (0 if the clock is before 1970).
pub fn now_unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
        .unwrap_or(0)
}

/// Per-message metadata chosen by the sender.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Meta {
    /// Mission the message belongs to.
    pub mission_id: MissionId,
    /// Sequence number.
    pub seq: u64,
    /// Creation time (ns since the Unix epoch); 0 means "now" when encoding.
    pub time_unix_ns: u64,
}

/// Limits applied while decoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeLimits {
    /// Largest accepted body (bytes); at most [`MAX_BODY_BYTES`].
    pub max_body_bytes: usize,
    /// Whether a present CRC is verified.
    pub verify_crc: bool,
}

impl Default for DecodeLimits {
    fn default() -> Self {
        DecodeLimits {
            max_body_bytes: DEFAULT_MAX_MESSAGE_BYTES,
            verify_crc: true,
        }
    }
}

impl DecodeLimits {
    /// The effective limit (never above [`MAX_BODY_BYTES`]).
    pub fn effective_max(&self) -> usize {
        self.max_body_bytes.min(MAX_BODY_BYTES)
    }
}

/// A decoded message with its header.
#[derive(Clone, Debug, PartialEq)]
pub struct Envelope<M> {
    /// The header as received.
    pub header: Header,
    /// The body.
    pub message: M,
}

/// Encodes `msg` as a binary envelope (header + bincode body, with CRC).
pub fn encode<M: Message>(msg: &M, meta: Meta) -> Result<Vec<u8>, CodecError> {
    let mut out = vec![0u8; HEADER_LEN];
    bincode::serde::encode_into_std_write(msg, &mut out, bincode_config()).map_err(|e| {
        CodecError::Encode {
            name: M::NAME,
            reason: e.to_string(),
        }
    })?;
    let body_len = out.len() - HEADER_LEN;
    if body_len > MAX_BODY_BYTES {
        return Err(CodecError::TooLarge {
            what: "encoded body",
            len: body_len as u64,
            limit: MAX_BODY_BYTES as u64,
        });
    }
    let header = Header {
        body_format: BodyFormat::Bincode,
        kind: M::KIND,
        schema_version: M::SCHEMA_VERSION,
        flags: FLAG_CRC,
        body_crc32: crc32fast::hash(&out[HEADER_LEN..]),
        mission_id: meta.mission_id,
        seq: meta.seq,
        time_unix_ns: if meta.time_unix_ns == 0 {
            now_unix_ns()
        } else {
            meta.time_unix_ns
        },
        body_len: body_len as u64,
    };
    out[..HEADER_LEN].copy_from_slice(&header.to_bytes());
    Ok(out)
}

/// Splits a binary envelope into its checked header and body (length, size limit and CRC are
/// verified; kind and version are not).
pub fn split<'a>(
    payload: &'a [u8],
    limits: &DecodeLimits,
) -> Result<(Header, &'a [u8]), CodecError> {
    let header = Header::parse(payload)?;
    let body = &payload[HEADER_LEN..];
    let limit = limits.effective_max() as u64;
    if header.body_len > limit {
        return Err(CodecError::TooLarge {
            what: "declared body_len",
            len: header.body_len,
            limit,
        });
    }
    if header.body_len != body.len() as u64 {
        return Err(CodecError::LengthMismatch {
            declared: header.body_len,
            actual: body.len() as u64,
        });
    }
    if header.body_format == BodyFormat::Bincode && !header.has_crc() {
        return Err(CodecError::Field {
            field: "flags",
            reason: "a bincode envelope must carry a body CRC (flag bit 0)".into(),
        });
    }
    if limits.verify_crc && header.has_crc() && header.body_format == BodyFormat::Bincode {
        let actual = crc32fast::hash(body);
        if actual != header.body_crc32 {
            return Err(CodecError::Checksum {
                expected: header.body_crc32,
                actual,
            });
        }
    }
    Ok((header, body))
}

/// Decodes a binary envelope holding an `M`.
pub fn decode<M: Message>(
    payload: &[u8],
    limits: &DecodeLimits,
) -> Result<Envelope<M>, CodecError> {
    let (header, body) = split(payload, limits)?;
    header.expect::<M>()?;
    if header.body_format != BodyFormat::Bincode {
        return Err(CodecError::WrongFormat {
            name: M::NAME,
            expected: BodyFormat::Bincode,
            found: header.body_format,
        });
    }
    let (message, used) = bincode::serde::decode_from_slice::<M, _>(body, bincode_config())
        .map_err(|e| CodecError::Body {
            name: M::NAME,
            reason: e.to_string(),
        })?;
    if used != body.len() {
        return Err(CodecError::TrailingBytes {
            name: M::NAME,
            extra: body.len() - used,
        });
    }
    Ok(Envelope { header, message })
}

/// The JSON form of an envelope (see the module documentation).
#[derive(Serialize, Deserialize)]
struct JsonEnvelope<B> {
    kind: u16,
    /// Informative only (optional when decoding).
    #[serde(default)]
    kind_name: String,
    schema_version: u16,
    mission_id: MissionId,
    seq: u64,
    time_unix_ns: u64,
    body: B,
}

/// Encodes `msg` in the JSON form (for Zenoh encoding `application/json`).
pub fn encode_json<M: Message>(msg: &M, meta: Meta) -> Result<Vec<u8>, CodecError> {
    let env = JsonEnvelope {
        kind: M::KIND,
        kind_name: M::NAME.to_string(),
        schema_version: M::SCHEMA_VERSION,
        mission_id: meta.mission_id,
        seq: meta.seq,
        time_unix_ns: if meta.time_unix_ns == 0 {
            now_unix_ns()
        } else {
            meta.time_unix_ns
        },
        body: msg,
    };
    serde_json::to_vec(&env).map_err(|e| CodecError::Encode {
        name: M::NAME,
        reason: e.to_string(),
    })
}

/// Decodes the JSON form of an envelope holding an `M` (bounded by `limits.max_body_bytes`).
pub fn decode_json<M: Message>(
    payload: &[u8],
    limits: &DecodeLimits,
) -> Result<Envelope<M>, CodecError> {
    let limit = limits.effective_max();
    if payload.len() > limit {
        return Err(CodecError::TooLarge {
            what: "JSON message",
            len: payload.len() as u64,
            limit: limit as u64,
        });
    }
    // First the envelope fields with an opaque body, so that a wrong kind or version is
    // reported as such and not as a body parse error.
    let env: JsonEnvelope<&serde_json::value::RawValue> =
        serde_json::from_slice(payload).map_err(|e| CodecError::Json(e.to_string()))?;
    let header = Header {
        body_format: BodyFormat::Bincode,
        kind: env.kind,
        schema_version: env.schema_version,
        flags: 0,
        body_crc32: 0,
        mission_id: env.mission_id,
        seq: env.seq,
        time_unix_ns: env.time_unix_ns,
        body_len: env.body.get().len() as u64,
    };
    header.expect::<M>()?;
    let message: M = serde_json::from_str(env.body.get())
        .map_err(|e| CodecError::Json(format!("body of {}: {e}", M::NAME)))?;
    Ok(Envelope { header, message })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize, Deserialize, Debug, PartialEq, Clone)]
    struct Ping {
        n: u32,
        text: String,
        v: Vec<f64>,
    }
    impl Message for Ping {
        const KIND: u16 = 7;
        const NAME: &'static str = "test.ping";
        const SCHEMA_VERSION: u16 = 2;
    }

    #[derive(Serialize, Deserialize, Debug, PartialEq)]
    struct Pong {
        n: u32,
    }
    impl Message for Pong {
        const KIND: u16 = 8;
        const NAME: &'static str = "test.pong";
        const SCHEMA_VERSION: u16 = 1;
    }

    fn ping() -> Ping {
        Ping {
            n: 42,
            text: "hello".into(),
            v: vec![1.0, -2.5],
        }
    }

    fn meta() -> Meta {
        Meta {
            mission_id: MissionId(0xabc),
            seq: 9,
            time_unix_ns: 123,
        }
    }

    #[test]
    fn header_layout_is_fixed() {
        let bytes = encode(&ping(), meta()).unwrap();
        assert_eq!(&bytes[0..4], b"CSAR");
        assert_eq!(bytes[4], 1);
        assert_eq!(bytes[5], 0);
        assert_eq!(&bytes[6..8], &7u16.to_le_bytes());
        assert_eq!(&bytes[8..10], &2u16.to_le_bytes());
        assert_eq!(&bytes[16..24], &0xabcu64.to_le_bytes());
        assert_eq!(&bytes[24..32], &9u64.to_le_bytes());
        assert_eq!(&bytes[32..40], &123u64.to_le_bytes());
        assert_eq!(le_u64(&bytes[40..48]) as usize, bytes.len() - HEADER_LEN);
        assert_eq!(
            le_u32(&bytes[12..16]),
            crc32fast::hash(&bytes[HEADER_LEN..])
        );
    }

    #[test]
    fn roundtrip_binary_and_json() {
        let bytes = encode(&ping(), meta()).unwrap();
        let env = decode::<Ping>(&bytes, &DecodeLimits::default()).unwrap();
        assert_eq!(env.message, ping());
        assert_eq!(env.header.seq, 9);
        assert_eq!(env.header.mission_id, MissionId(0xabc));

        let json = encode_json(&ping(), meta()).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!(v["kind_name"], "test.ping");
        assert_eq!(v["mission_id"], "0000000000000abc");
        assert_eq!(v["body"]["text"], "hello");
        let env = decode_json::<Ping>(&json, &DecodeLimits::default()).unwrap();
        assert_eq!(env.message, ping());
        assert_eq!(env.header.time_unix_ns, 123);
    }

    #[test]
    fn wrong_kind_and_version_are_named() {
        let bytes = encode(&ping(), meta()).unwrap();
        let err = decode::<Pong>(&bytes, &DecodeLimits::default()).unwrap_err();
        assert_eq!(
            err,
            CodecError::WrongKind {
                expected: 8,
                expected_name: "test.pong",
                found: 7
            }
        );
        assert!(err.to_string().contains("test.pong"));

        let mut b = bytes.clone();
        b[8..10].copy_from_slice(&3u16.to_le_bytes());
        let err = decode::<Ping>(&b, &DecodeLimits::default()).unwrap_err();
        assert_eq!(
            err,
            CodecError::SchemaVersion {
                name: "test.ping",
                expected: 2,
                found: 3
            }
        );

        let json = encode_json(&ping(), meta()).unwrap();
        let err = decode_json::<Pong>(&json, &DecodeLimits::default()).unwrap_err();
        assert!(matches!(err, CodecError::WrongKind { found: 7, .. }));
    }

    #[test]
    fn corrupt_payloads_fail_loudly() {
        let bytes = encode(&ping(), meta()).unwrap();
        let l = DecodeLimits::default();
        assert_eq!(
            decode::<Ping>(&bytes[..10], &l).unwrap_err(),
            CodecError::TooShort { len: 10 }
        );
        let mut b = bytes.clone();
        b[0] = b'X';
        assert!(matches!(
            decode::<Ping>(&b, &l),
            Err(CodecError::BadMagic { .. })
        ));
        let mut b = bytes.clone();
        b[4] = 2;
        assert_eq!(
            decode::<Ping>(&b, &l).unwrap_err(),
            CodecError::HeaderVersion { found: 2 }
        );
        let mut b = bytes.clone();
        let last = b.len() - 1;
        b[last] ^= 0xff;
        assert!(matches!(
            decode::<Ping>(&b, &l),
            Err(CodecError::Checksum { .. })
        ));
        let mut b = bytes.clone();
        b.push(0);
        assert!(matches!(
            decode::<Ping>(&b, &l),
            Err(CodecError::LengthMismatch { .. })
        ));
        let tight = DecodeLimits {
            max_body_bytes: 4,
            verify_crc: true,
        };
        assert!(matches!(
            decode::<Ping>(&bytes, &tight),
            Err(CodecError::TooLarge { .. })
        ));
    }

    #[test]
    fn forged_inner_length_is_bounded() {
        // A string whose length prefix claims 2^60 bytes: must fail, not allocate or panic.
        let mut body = Vec::new();
        body.push(42u8); // n = 42 (varint)
        body.push(253); // u64 varint marker
        body.extend_from_slice(&(1u64 << 60).to_le_bytes());
        body.extend_from_slice(b"abc");
        let header = Header {
            body_format: BodyFormat::Bincode,
            kind: Ping::KIND,
            schema_version: Ping::SCHEMA_VERSION,
            flags: FLAG_CRC,
            body_crc32: crc32fast::hash(&body),
            mission_id: MissionId(1),
            seq: 0,
            time_unix_ns: 0,
            body_len: body.len() as u64,
        };
        let mut b = header.to_bytes().to_vec();
        b.extend_from_slice(&body);
        let err = decode::<Ping>(&b, &DecodeLimits::default()).unwrap_err();
        assert!(matches!(err, CodecError::Body { .. }), "{err}");
    }

    use proptest::prelude::*;

    fn arb_ping() -> impl Strategy<Value = Ping> {
        (
            any::<u32>(),
            ".{0,40}",
            proptest::collection::vec(-1e12f64..1e12, 0..20),
        )
            .prop_map(|(n, text, v)| Ping { n, text, v })
    }

    fn arb_meta() -> impl Strategy<Value = Meta> {
        (any::<u64>(), any::<u64>(), 1..u64::MAX).prop_map(|(m, seq, t)| Meta {
            mission_id: MissionId(m),
            seq,
            time_unix_ns: t,
        })
    }

    proptest! {
        /// encode -> decode is the identity, in both forms, and keeps the header fields.
        #[test]
        fn roundtrip_any_message(p in arb_ping(), meta in arb_meta()) {
            let l = DecodeLimits::default();
            let b = encode(&p, meta).unwrap();
            let env = decode::<Ping>(&b, &l).unwrap();
            prop_assert_eq!(&env.message, &p);
            prop_assert_eq!(env.header.mission_id, meta.mission_id);
            prop_assert_eq!(env.header.seq, meta.seq);
            prop_assert_eq!(env.header.time_unix_ns, meta.time_unix_ns);
            let j = encode_json(&p, meta).unwrap();
            let env = decode_json::<Ping>(&j, &l).unwrap();
            prop_assert_eq!(&env.message, &p);
            prop_assert_eq!(env.header.seq, meta.seq);
            prop_assert_eq!(env.header.mission_id, meta.mission_id);
        }

        /// Any bytes: decoding returns (Ok or Err) without panicking; an accepted payload is
        /// canonical (re-encoding gives the same bytes).
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let l = DecodeLimits::default();
            if let Ok(env) = decode::<Ping>(&bytes, &l) {
                let meta = Meta { mission_id: env.header.mission_id, seq: env.header.seq, time_unix_ns: env.header.time_unix_ns };
                prop_assert_eq!(encode(&env.message, meta).unwrap(), bytes.clone());
            }
            let _ = decode_json::<Ping>(&bytes, &l);
            let _ = Header::parse(&bytes);
        }

        /// Flipping any bit of a valid envelope is detected (header check, length, CRC or
        /// decoder), except in the fields the decoder does not constrain (mission id, seq,
        /// time), which then decode to the flipped value.
        #[test]
        fn single_bit_flips_are_caught(p in arb_ping(), meta in arb_meta(), bit in any::<prop::sample::Index>()) {
            let b = encode(&p, meta).unwrap();
            let i = bit.index(b.len() * 8);
            let mut m = b.clone();
            m[i / 8] ^= 1 << (i % 8);
            let r = decode::<Ping>(&m, &DecodeLimits::default());
            let free = (16..40).contains(&(i / 8));
            prop_assert_eq!(r.is_ok(), free, "bit {} -> {:?}", i, r.err());
        }
    }

    /// 10,000 random and mutated payloads: every one is rejected or decoded, none panics,
    /// and each is counted exactly once.
    #[test]
    fn fuzz_10k_payloads() {
        let l = DecodeLimits::default();
        let valid = encode(&ping(), meta()).unwrap();
        let valid_json = encode_json(&ping(), meta()).unwrap();
        let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move || {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            state.wrapping_mul(0x2545_f491_4f6c_dd1d)
        };
        let (mut ok, mut rejected) = (0u32, 0u32);
        let mut kinds = std::collections::BTreeMap::new();
        for i in 0..10_000u32 {
            let payload: Vec<u8> = match i % 4 {
                0 => (0..next() % 256).map(|_| next() as u8).collect(),
                1 => {
                    let mut v = valid.clone();
                    for _ in 0..1 + next() % 8 {
                        let p = (next() as usize) % v.len();
                        v[p] = next() as u8;
                    }
                    v
                }
                2 => {
                    let mut v = valid_json.clone();
                    let p = (next() as usize) % v.len();
                    v[p] = next() as u8;
                    v
                }
                _ => {
                    let mut v = valid.clone();
                    v.truncate((next() as usize) % v.len());
                    v
                }
            };
            let r = if i % 4 == 2 {
                decode_json::<Ping>(&payload, &l).map(|_| ())
            } else {
                decode::<Ping>(&payload, &l).map(|_| ())
            };
            match r {
                Ok(()) => ok += 1,
                Err(e) => {
                    rejected += 1;
                    let name = format!("{e:?}");
                    let name = name.split([' ', '(', '{']).next().unwrap_or("").to_string();
                    *kinds.entry(name).or_insert(0u32) += 1;
                }
            }
        }
        assert_eq!(ok + rejected, 10_000);
        assert!(rejected >= 9_500, "only {rejected} rejected: {kinds:?}");
        assert!(kinds.len() >= 6, "too few error kinds exercised: {kinds:?}");
    }

    #[test]
    fn mission_id_forms() {
        let id = MissionId::from_name("default");
        assert_eq!(MissionId::parse_hex(&id.to_string()).unwrap(), id);
        assert_ne!(MissionId::from_name("a"), MissionId::from_name("b"));
        assert!(MissionId::parse_hex("xyz").is_err());
        assert!(MissionId::parse_hex("00000000000000000").is_err());
    }
}
