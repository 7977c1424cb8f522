//! Tests of the envelope codec: the fixed layout, both forms' round trips, named errors, and
//! bounded, panic-free decoding of anything.

use serde::{Deserialize, Serialize};

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
