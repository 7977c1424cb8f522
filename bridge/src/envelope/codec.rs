//! The binary envelope: header + bincode 2 body with CRC ([`encode`], [`split`], [`decode`])
//! and its limits ([`DecodeLimits`]).

use std::time::{SystemTime, UNIX_EPOCH};

use super::DEFAULT_MAX_MESSAGE_BYTES;
use super::{
    bincode_config, BodyFormat, CodecError, Header, Message, MissionId, FLAG_CRC, HEADER_LEN,
    MAX_BODY_BYTES,
};

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
