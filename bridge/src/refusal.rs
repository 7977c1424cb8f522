//! A typed refusal: what a cellsar queryable sends as its error reply when it will not answer
//! a request, so that the querier learns *why* without reading the text.
//!
//! The refusal travels as the payload of a Zenoh error reply, in the envelope of
//! [`crate::envelope`] and in the request's format (bincode, or JSON for a JSON request:
//! `{"kind": 4098, "kind_name": "bridge.refusal", ..., "body": {"kind": "infeasible",
//! "message": "..."}}`). [`crate::IncomingQuery::refuse`] sends one;
//! [`crate::PendingQuery::poll`] and [`crate::ZenohNode::query_one`] decode it into
//! [`crate::NetError::Refused`]. An error reply that is not a refusal (a plain text from an
//! older or foreign queryable) stays a [`crate::NetError::Remote`] naming the key.
//!
//! Schema versions: 1 has the kinds `bad_request`, `infeasible`, `internal`; 2 adds `busy`
//! (the queryable's request queue is full, or it is stopping: ask again later); 3 adds
//! `not_found` (no plan meets every constraint, none proven impossible). A refusal is sent with
//! the lowest version that has its kind ([`Refusal::schema_version`]: so a querier built before
//! a kind was added still reads every refusal of the kinds it knows), and read in any version
//! ([`Refusal::decode`]).

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::envelope::{CodecError, DecodeLimits, Envelope, Message, Meta};
use crate::net::WireFormat;

/// Why a request was refused.
///
/// New kinds are a schema change of [`Refusal`] (bump its `SCHEMA_VERSION`, append the kind
/// at the end so that the older versions' kinds keep their bincode index, and teach
/// [`Refusal::schema_version`] which version introduced it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RefusalKind {
    /// The request is invalid (a field out of range, a mission that does not validate); the
    /// message names the field. The binaries' exit code 2.
    BadRequest,
    /// The request is valid but cannot be fulfilled (a mission that cannot be flown, proven);
    /// the message says why. The binaries' exit code 3.
    Infeasible,
    /// The service failed while handling a valid request (a solver or worker failure). The
    /// binaries' exit code 1.
    Internal,
    /// The service cannot take the request now (its request queue is full, or it is
    /// stopping); the same request may succeed later. Since schema version 2.
    Busy,
    /// The planner found no plan that meets every constraint, and none is proven impossible;
    /// the message names the first slot the best plan found violates. The binaries' exit
    /// code 5. Since schema version 3.
    NotFound,
}

impl RefusalKind {
    /// Every kind, in wire order.
    pub const ALL: [RefusalKind; 5] = [
        RefusalKind::BadRequest,
        RefusalKind::Infeasible,
        RefusalKind::Internal,
        RefusalKind::Busy,
        RefusalKind::NotFound,
    ];

    /// The name used in the JSON form and in messages (`bad_request`, `infeasible`,
    /// `internal`, `busy`, `not_found`).
    pub fn as_str(self) -> &'static str {
        match self {
            RefusalKind::BadRequest => "bad_request",
            RefusalKind::Infeasible => "infeasible",
            RefusalKind::Internal => "internal",
            RefusalKind::Busy => "busy",
            RefusalKind::NotFound => "not_found",
        }
    }

    /// The first schema version of [`Refusal`] that has this kind.
    pub fn since_schema_version(self) -> u16 {
        match self {
            RefusalKind::BadRequest | RefusalKind::Infeasible | RefusalKind::Internal => 1,
            RefusalKind::Busy => 2,
            RefusalKind::NotFound => 3,
        }
    }
}

impl fmt::Display for RefusalKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The body of a typed error reply: a [`RefusalKind`] and a message for people.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Refusal {
    /// Why the request was refused.
    pub kind: RefusalKind,
    /// What was wrong, naming the field, the slot or the step that failed.
    pub message: String,
}

impl Refusal {
    /// A refusal of `kind` with `message`.
    pub fn new(kind: RefusalKind, message: impl Into<String>) -> Self {
        Refusal {
            kind,
            message: message.into(),
        }
    }

    /// The schema version this refusal is sent with: the lowest that has its kind (1 for the
    /// first three kinds, 2 for `busy`, 3 for `not_found`), so that queriers built before a
    /// kind was added still read the refusals they know.
    pub fn schema_version(&self) -> u16 {
        self.kind.since_schema_version()
    }

    /// Encodes the refusal in `format` with [`Refusal::schema_version`]; also returns the
    /// Zenoh encoding that names that version (`...;cellsar/bridge.refusal/v1`).
    pub fn encode(
        &self,
        format: WireFormat,
        meta: Meta,
    ) -> Result<(Vec<u8>, zenoh::bytes::Encoding), CodecError> {
        match self.schema_version() {
            RefusalV1::SCHEMA_VERSION => {
                let v1 = RefusalV1(self.clone());
                Ok((format.encode(&v1, meta)?, format.encoding::<RefusalV1>()))
            }
            RefusalV2::SCHEMA_VERSION => {
                let v2 = RefusalV2(self.clone());
                Ok((format.encode(&v2, meta)?, format.encoding::<RefusalV2>()))
            }
            _ => Ok((format.encode(self, meta)?, format.encoding::<Refusal>())),
        }
    }

    /// Decodes a refusal of any schema version this build reads (1 to 3) from a payload in
    /// `format`.
    pub fn decode(
        payload: &[u8],
        format: WireFormat,
        limits: &DecodeLimits,
    ) -> Result<Envelope<Refusal>, CodecError> {
        match format.decode::<Refusal>(payload, limits) {
            Err(CodecError::SchemaVersion { found: 1, .. }) => {
                let env = format.decode::<RefusalV1>(payload, limits)?;
                Ok(Envelope {
                    header: env.header,
                    message: env.message.0,
                })
            }
            Err(CodecError::SchemaVersion { found: 2, .. }) => {
                let env = format.decode::<RefusalV2>(payload, limits)?;
                Ok(Envelope {
                    header: env.header,
                    message: env.message.0,
                })
            }
            other => other,
        }
    }
}

impl Message for Refusal {
    const KIND: u16 = 0x1002;
    const NAME: &'static str = "bridge.refusal";
    const SCHEMA_VERSION: u16 = 3;
}

/// A [`Refusal`] in schema version 2: the same layout (its kinds are the first four of
/// version 3, at the same places), under the version-2 header.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
struct RefusalV2(Refusal);

impl Message for RefusalV2 {
    const KIND: u16 = Refusal::KIND;
    const NAME: &'static str = Refusal::NAME;
    const SCHEMA_VERSION: u16 = 2;
}

/// A [`Refusal`] in schema version 1: the same layout (its kinds are the first three of
/// version 3, at the same places), under the version-1 header.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
struct RefusalV1(Refusal);

impl Message for RefusalV1 {
    const KIND: u16 = Refusal::KIND;
    const NAME: &'static str = Refusal::NAME;
    const SCHEMA_VERSION: u16 = 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::envelope;

    #[test]
    fn refusals_round_trip_in_both_forms() {
        let r = Refusal::new(RefusalKind::Infeasible, "mission cannot be flown: slot 23");
        for format in [WireFormat::Bincode, WireFormat::Json] {
            let bytes = format.encode(&r, Meta::default()).unwrap();
            let back = format
                .decode::<Refusal>(&bytes, &DecodeLimits::default())
                .unwrap();
            assert_eq!(back.message, r, "{format:?}");
        }
        // the JSON form names the kind in words (what a Python client reads)
        let json = envelope::encode_json(&r, Meta::default()).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!(v["kind"], 0x1002);
        assert_eq!(v["kind_name"], "bridge.refusal");
        assert_eq!(v["body"]["kind"], "infeasible");
        assert_eq!(v["body"]["message"], "mission cannot be flown: slot 23");
        for k in RefusalKind::ALL {
            let v = serde_json::to_value(k).unwrap();
            assert_eq!(v, k.as_str());
            assert_eq!(k.to_string(), k.as_str());
        }
    }

    /// Schema version 2 added `busy`, 3 `not_found`: the first three kinds are still sent as
    /// version 1 (what a querier built before version 2 reads), `busy` as version 2,
    /// `not_found` as version 3, and every version is read back, in both forms — also a
    /// version-1 refusal as an older service wrote it.
    #[test]
    fn refusals_are_sent_with_the_lowest_version_and_read_in_both() {
        let l = DecodeLimits::default();
        for kind in RefusalKind::ALL {
            let r = Refusal::new(kind, format!("{kind} happened"));
            let want = kind.since_schema_version();
            assert_eq!(r.schema_version(), want);
            for format in [WireFormat::Bincode, WireFormat::Json] {
                let (bytes, encoding) = r.encode(format, Meta::default()).unwrap();
                assert!(
                    encoding
                        .to_string()
                        .ends_with(&format!("cellsar/bridge.refusal/v{want}")),
                    "{encoding}"
                );
                let back = Refusal::decode(&bytes, format, &l).unwrap();
                assert_eq!(back.header.schema_version, want);
                assert_eq!(back.message, r, "{format:?}");
                // what a querier of version 1 decodes
                let old = format.decode::<RefusalV1>(&bytes, &l);
                if want == 1 {
                    assert_eq!(old.unwrap().message.0, r);
                } else {
                    assert!(
                        matches!(old, Err(CodecError::SchemaVersion { found, .. }) if found == want),
                        "{old:?}"
                    );
                }
                // what a querier of version 2 decodes
                let v2 = format.decode::<RefusalV2>(&bytes, &l);
                if want == 3 {
                    assert!(
                        matches!(v2, Err(CodecError::SchemaVersion { found: 3, .. })),
                        "{v2:?}"
                    );
                } else if want == 2 {
                    assert_eq!(v2.unwrap().message.0, r);
                }
            }
            // the plain encoding of the current version is read too
            let v2 = WireFormat::Bincode.encode(&r, Meta::default()).unwrap();
            assert_eq!(
                Refusal::decode(&v2, WireFormat::Bincode, &l)
                    .unwrap()
                    .message,
                r
            );
        }
        // a version-1 JSON refusal, as a planner of version 1 sent it
        let old = br#"{"kind": 4098, "kind_name": "bridge.refusal", "schema_version": 1,
            "mission_id": "0000000000000000", "seq": 0, "time_unix_ns": 1,
            "body": {"kind": "infeasible", "message": "slot 23"}}"#;
        let r = Refusal::decode(old, WireFormat::Json, &l).unwrap().message;
        assert_eq!(r, Refusal::new(RefusalKind::Infeasible, "slot 23"));
        // a version this build does not know stays an error naming both versions
        let future =
            String::from_utf8_lossy(old).replace("\"schema_version\": 1", "\"schema_version\": 4");
        let e = Refusal::decode(future.as_bytes(), WireFormat::Json, &l).unwrap_err();
        assert!(
            matches!(e, CodecError::SchemaVersion { found: 4, .. }),
            "{e:?}"
        );
    }

    #[test]
    fn plain_text_is_not_a_refusal() {
        let l = DecodeLimits::default();
        for text in ["mission cannot be flown: slot 3", "", "{\"kind\": 1}"] {
            assert!(WireFormat::Bincode
                .decode::<Refusal>(text.as_bytes(), &l)
                .is_err());
            assert!(WireFormat::Json
                .decode::<Refusal>(text.as_bytes(), &l)
                .is_err());
        }
    }
}
