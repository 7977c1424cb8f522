//! The JSON form of an envelope ([`encode_json`], [`decode_json`]), for tools without Rust.

use serde::{Deserialize, Serialize};

use super::{
    now_unix_ns, BodyFormat, CodecError, DecodeLimits, Envelope, Header, Message, Meta, MissionId,
};

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
