//! The 48-byte binary header ([`Header`]) and its body format ([`BodyFormat`]).

use serde::{Deserialize, Serialize};

use super::{CodecError, Message, MissionId, FLAG_CRC, HEADER_LEN, HEADER_VERSION, MAGIC};

/// How the body after the header is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BodyFormat {
    /// bincode 2 (serde) with [`super::bincode_config`].
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
