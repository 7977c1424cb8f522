//! Mission ids ([`MissionId`]): 64 bits, 16 hex digits in keys and JSON.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::CodecError;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mission_id_forms() {
        let id = MissionId::from_name("default");
        assert_eq!(MissionId::parse_hex(&id.to_string()).unwrap(), id);
        assert_ne!(MissionId::from_name("a"), MissionId::from_name("b"));
        assert!(MissionId::parse_hex("xyz").is_err());
        assert!(MissionId::parse_hex("00000000000000000").is_err());
    }
}
