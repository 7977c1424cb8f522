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

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::envelope::Message;

/// Why a request was refused.
///
/// New kinds are a schema change of [`Refusal`] (bump its `SCHEMA_VERSION`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RefusalKind {
    /// The request is invalid (a field out of range, a mission that does not validate); the
    /// message names the field. The binaries' exit code 2.
    BadRequest,
    /// The request is valid but cannot be fulfilled (a mission that cannot be flown); the
    /// message says why. The binaries' exit code 3.
    Infeasible,
    /// The service failed while handling a valid request (a solver or worker failure). The
    /// binaries' exit code 1.
    Internal,
}

impl RefusalKind {
    /// The name used in the JSON form and in messages (`bad_request`, `infeasible`,
    /// `internal`).
    pub fn as_str(self) -> &'static str {
        match self {
            RefusalKind::BadRequest => "bad_request",
            RefusalKind::Infeasible => "infeasible",
            RefusalKind::Internal => "internal",
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
}

impl Message for Refusal {
    const KIND: u16 = 0x1002;
    const NAME: &'static str = "bridge.refusal";
    const SCHEMA_VERSION: u16 = 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::envelope::{self, DecodeLimits, Meta};
    use crate::net::WireFormat;

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
        for k in [
            RefusalKind::BadRequest,
            RefusalKind::Infeasible,
            RefusalKind::Internal,
        ] {
            let v = serde_json::to_value(k).unwrap();
            assert_eq!(v, k.as_str());
            assert_eq!(k.to_string(), k.as_str());
        }
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
