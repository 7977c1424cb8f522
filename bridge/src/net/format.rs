//! How a message travels on Zenoh: the binary or JSON envelope ([`WireFormat`]) with its
//! Zenoh encoding, and a received message with its key and header ([`Received`]).

use zenoh::bytes::{Encoding, ZBytes};

use crate::envelope::{
    self, CodecError, DecodeLimits, Envelope, Header, Message, Meta, HEADER_LEN,
};

/// How a message body is encoded on Zenoh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum WireFormat {
    /// Binary envelope + bincode 2 (encoding `application/octet-stream;cellsar/<name>/v<n>`).
    #[default]
    Bincode,
    /// JSON envelope (encoding `application/json;cellsar/<name>/v<n>`), readable from Python.
    Json,
}

impl WireFormat {
    /// The Zenoh encoding for message type `M` in this format.
    pub fn encoding<M: Message>(self) -> Encoding {
        let schema = format!("cellsar/{}/v{}", M::NAME, M::SCHEMA_VERSION);
        match self {
            WireFormat::Bincode => Encoding::APPLICATION_OCTET_STREAM.with_schema(schema),
            WireFormat::Json => Encoding::APPLICATION_JSON.with_schema(schema),
        }
    }

    /// The format announced by a Zenoh encoding (JSON if it is `application/json[;...]`).
    pub fn of(encoding: &Encoding) -> WireFormat {
        let s = std::borrow::Cow::<str>::from(encoding);
        let is_json = s
            .strip_prefix("application/json")
            .is_some_and(|rest| rest.is_empty() || rest.starts_with(';'));
        if is_json {
            WireFormat::Json
        } else {
            WireFormat::Bincode
        }
    }

    /// Encodes `msg`.
    pub fn encode<M: Message>(self, msg: &M, meta: Meta) -> Result<Vec<u8>, CodecError> {
        match self {
            WireFormat::Bincode => envelope::encode(msg, meta),
            WireFormat::Json => envelope::encode_json(msg, meta),
        }
    }

    /// The longest payload in this format that `limits` can accept: the header and the
    /// largest body of a binary envelope, the whole text of a JSON one.
    pub fn max_payload_len(self, limits: &DecodeLimits) -> usize {
        match self {
            WireFormat::Bincode => HEADER_LEN.saturating_add(limits.effective_max()),
            WireFormat::Json => limits.effective_max(),
        }
    }

    /// Checks the length of a received payload against `limits` before anything reads it:
    /// Zenoh hands a large message over in fragments, and gathering them into one buffer
    /// ([`ZBytes::to_bytes`]) copies it.
    pub fn check_len(self, len: usize, limits: &DecodeLimits) -> Result<(), CodecError> {
        let limit = self.max_payload_len(limits);
        if len > limit {
            return Err(CodecError::TooLarge {
                what: "payload",
                len: len as u64,
                limit: limit as u64,
            });
        }
        Ok(())
    }

    /// Decodes a Zenoh payload holding an `M`, its length checked first
    /// ([`WireFormat::check_len`]).
    pub fn decode_zbytes<M: Message>(
        self,
        payload: &ZBytes,
        limits: &DecodeLimits,
    ) -> Result<Envelope<M>, CodecError> {
        self.check_len(payload.len(), limits)?;
        self.decode(&payload.to_bytes(), limits)
    }

    /// Decodes a payload holding an `M`.
    pub fn decode<M: Message>(
        self,
        payload: &[u8],
        limits: &DecodeLimits,
    ) -> Result<Envelope<M>, CodecError> {
        match self {
            WireFormat::Bincode => envelope::decode(payload, limits),
            WireFormat::Json => envelope::decode_json(payload, limits),
        }
    }
}

/// A received message with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Received<M> {
    /// The key it was published on.
    pub key: String,
    /// Its header.
    pub header: Header,
    /// How it was encoded.
    pub format: WireFormat,
    /// The message.
    pub message: M,
}
