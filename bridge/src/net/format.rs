//! How a message travels on Zenoh: the binary or JSON envelope ([`WireFormat`]) with its
//! Zenoh encoding, and a received message with its key and header ([`Received`]).

use zenoh::bytes::Encoding;

use crate::envelope::{self, CodecError, DecodeLimits, Envelope, Header, Message, Meta};

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
