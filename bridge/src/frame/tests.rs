//! Tests of the frame format: layout, wire round trips, bounded decoding and tags.

use super::*;

fn iq(rows: u32, cols: u32) -> (FrameHeader, Vec<Complex32>) {
    let n = (rows * cols) as usize;
    let samples: Vec<Complex32> = (0..n)
        .map(|i| Complex32::new(i as f32, -(i as f32) * 0.5))
        .collect();
    let c = checksum(samples_as_bytes(&samples));
    let h = FrameMeta::iq(MissionId(5), 3, 1_000, rows, cols)
        .header(Some(c))
        .unwrap();
    (h, samples)
}

#[test]
fn header_is_104_bytes_and_c_layout() {
    assert_eq!(std::mem::size_of::<FrameHeader>(), 104);
    assert_eq!(std::mem::align_of::<FrameHeader>(), 8);
}

#[test]
fn wire_roundtrip_and_le_samples() {
    let (h, s) = iq(3, 4);
    let wire = encode_wire(&h, samples_as_bytes(&s)).unwrap();
    assert_eq!(wire.len(), WIRE_PREFIX_LEN + 96);
    // first sample (0, -0) little endian right after the prefix; second = (1, -0.5)
    assert_eq!(
        &wire[WIRE_PREFIX_LEN + 8..WIRE_PREFIX_LEN + 12],
        &1.0f32.to_le_bytes()
    );
    assert_eq!(
        &wire[WIRE_PREFIX_LEN + 12..WIRE_PREFIX_LEN + 16],
        &(-0.5f32).to_le_bytes()
    );
    let (h2, p) = decode_wire(&wire, DEFAULT_MAX_FRAME_BYTES, true).unwrap();
    assert_eq!(h2, h);
    assert_eq!(samples_from_bytes(p).unwrap(), s);
}

#[test]
fn bad_frames_are_named() {
    let (h, s) = iq(2, 2);
    let wire = encode_wire(&h, samples_as_bytes(&s)).unwrap();
    let mut w = wire.clone();
    w.pop();
    let e = decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, true).unwrap_err();
    assert!(e.to_string().contains("payload_len"), "{e}");
    let mut w = wire.clone();
    *w.last_mut().unwrap() ^= 1;
    assert!(matches!(
        decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, true),
        Err(CodecError::Checksum { .. })
    ));
    assert!(decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, false).is_ok());
    let mut w = wire.clone();
    w[HEADER_LEN + 4] = 3; // rows 2 -> 3: shape no longer matches
    let e = decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, false).unwrap_err();
    assert!(e.to_string().contains("shape"), "{e}");
    assert!(matches!(
        decode_wire(&wire, 16, false),
        Err(CodecError::TooLarge { .. })
    ));
    let mut w = wire.clone();
    w[5] = 0; // bincode body format
    let e = decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, false).unwrap_err();
    assert!(e.to_string().contains("body_format"), "{e}");
}

fn key(b: u8) -> FrameKey {
    FrameKey::from_bytes([b; FRAME_KEY_LEN])
}

/// A tagged frame survives the wire and verifies; the tag sits in the descriptor.
#[test]
fn tagged_frame_roundtrip() {
    let (h, s) = iq(3, 4);
    let payload = samples_as_bytes(&s);
    let k = key(7);
    let h = h
        .meta()
        .tagged(&k, payload)
        .header(h.has_checksum().then_some(h.checksum))
        .unwrap();
    assert!(h.has_tag());
    assert_eq!(h.tag, k.tag(&h.meta(), payload));
    assert_ne!(h.tag, [0; FRAME_KEY_LEN]);
    let wire = encode_wire(&h, payload).unwrap();
    assert_eq!(WIRE_PREFIX_LEN, 112);
    assert_eq!(&wire[HEADER_LEN + 2..HEADER_LEN + 4], &1u16.to_le_bytes());
    assert_eq!(&wire[HEADER_LEN + 24..HEADER_LEN + 56], &h.tag);
    let (h2, p) = decode_wire(&wire, DEFAULT_MAX_FRAME_BYTES, true).unwrap();
    assert_eq!(h2, h);
    h2.verify_tag(&k, p).unwrap();
    // the tag is the keyed BLAKE3 of the documented fields and the samples
    let mut msg = b"cellsar frame tag 2\0".to_vec();
    for part in [
        &IQ_FRAME_KIND.to_le_bytes()[..],
        &IQ_FRAME_SCHEMA_VERSION.to_le_bytes(),
        &COMPLEX32_BYTES.to_le_bytes(),
        &5u64.to_le_bytes(),
        &3u64.to_le_bytes(),
        &3u32.to_le_bytes(),
        &4u32.to_le_bytes(),
        &1_000i64.to_le_bytes(),
        &0u64.to_le_bytes(),
        &96u64.to_le_bytes(),
        payload,
    ] {
        msg.extend_from_slice(part);
    }
    assert_eq!(h.tag, *blake3::keyed_hash(k.as_bytes(), &msg).as_bytes());
}

/// Changing a sample, the sequence number, the mission time, the shape, the mission or
/// the key makes the tag fail; so does a frame without a tag.
#[test]
fn tag_mismatch_is_refused() {
    let (h, s) = iq(2, 4);
    let payload = samples_as_bytes(&s).to_vec();
    let k = key(9);
    let h = h.meta().tagged(&k, &payload).header(None).unwrap();
    h.verify_tag(&k, &payload).unwrap();
    let refused = |h: &FrameHeader, k: &FrameKey, p: &[u8]| {
        let e = h.verify_tag(k, p).unwrap_err();
        assert!(e.to_string().contains("tag"), "{e}");
    };
    let mut p = payload.clone();
    p[13] ^= 1;
    refused(&h, &k, &p);
    refused(&h, &key(8), &payload);
    let mut h2 = h;
    h2.seq += 1;
    refused(&h2, &k, &payload);
    let mut h2 = h;
    h2.mission_time_ns += 1;
    refused(&h2, &k, &payload);
    let mut h2 = h;
    h2.shape = [4, 2];
    refused(&h2, &k, &payload);
    let mut h2 = h;
    h2.mission_id ^= 1;
    refused(&h2, &k, &payload);
    let mut h2 = h;
    h2.tag[31] ^= 0x80;
    refused(&h2, &k, &payload);
    let untagged = FrameMeta::iq(MissionId(5), 3, 1_000, 2, 4)
        .header(None)
        .unwrap();
    refused(&untagged, &k, &payload);
    // a tag flipped on the wire is refused after decoding too
    let mut wire = encode_wire(&h, &payload).unwrap();
    wire[HEADER_LEN + 30] ^= 4;
    let (h3, p3) = decode_wire(&wire, DEFAULT_MAX_FRAME_BYTES, false).unwrap();
    refused(&h3, &k, p3);
}

/// Unknown descriptor flags and a tag without the flag are refused by name.
#[test]
fn descriptor_flags_are_checked() {
    let (h, s) = iq(1, 2);
    let wire = encode_wire(&h, samples_as_bytes(&s)).unwrap();
    let mut w = wire.clone();
    w[HEADER_LEN + 2] = 2;
    let e = decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, false).unwrap_err();
    assert!(e.to_string().contains("frame descriptor flags"), "{e}");
    let mut w = wire.clone();
    w[HEADER_LEN + 40] = 1; // a tag byte, the tagged flag clear
    let e = decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, false).unwrap_err();
    assert!(e.to_string().contains("tag"), "{e}");
    let mut w = wire.clone();
    w[HEADER_LEN + 2] = 1; // the tagged flag, the tag all zero
    let e = decode_wire(&w, DEFAULT_MAX_FRAME_BYTES, false).unwrap_err();
    assert!(e.to_string().contains("never all zero"), "{e}");
}

#[test]
fn random_keys_differ() {
    let (a, b) = (FrameKey::random().unwrap(), FrameKey::random().unwrap());
    assert_ne!(a, b);
    assert_eq!(format!("{a:?}"), "FrameKey(..)");
}

#[test]
fn shape_overflow_is_an_error() {
    let m = FrameMeta::iq(MissionId(0), 0, 0, u32::MAX, u32::MAX);
    if usize::BITS == 64 {
        // 2^64 * 8 overflows u64
        assert!(m.payload_len().is_err());
    }
}

use proptest::prelude::*;

proptest! {
    /// Any consistent header survives the wire prefix unchanged; any bytes decode
    /// without panicking.
    #[test]
    fn prefix_roundtrip(kind in any::<u16>(), ver in any::<u16>(), rows in 0u32..64, cols in 0u32..64,
                        elem in 1u16..17, crc in any::<Option<u32>>(), mission in any::<u64>(),
                        seq in any::<u64>(), mt in any::<i64>(), t in any::<u64>(),
                        tag in any::<Option<[u8; 32]>>()) {
        let tag = tag.filter(|t| *t != [0; 32]);
        let m = FrameMeta { kind, schema_version: ver, element_size: elem, mission_id: MissionId(mission), seq, mission_time_ns: mt, shape: [rows, cols], scene_digest: mission ^ seq, tag };
        let mut h = m.header(crc).unwrap();
        h.time_unix_ns = t;
        let len = h.payload_len as usize;
        let prefix = h.to_wire_prefix();
        let back = FrameHeader::from_wire_prefix(&prefix, WIRE_PREFIX_LEN + len, 1 << 20).unwrap();
        prop_assert_eq!(back, h);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200), max in 0usize..1000) {
        let _ = decode_wire(&bytes, max, true);
        let _ = bytes_as_samples(&bytes);
    }
}

#[test]
fn sample_views() {
    let s = vec![Complex32::new(1.0, 2.0); 3];
    let b = samples_as_bytes(&s);
    assert_eq!(b.len(), 24);
    assert_eq!(bytes_as_samples(b).unwrap(), &s[..]);
    assert!(bytes_as_samples(&b[..7]).is_err());
    assert!(samples_from_bytes(&b[..7]).is_err());
}

/// The scene digest travels at bytes 56..64 of the descriptor, little endian, round trips, and
/// is covered by the tag: a frame relabelled with another scene fails its tag.
#[test]
fn the_scene_digest_travels_in_the_descriptor_under_the_tag() {
    let k = FrameKey::from_bytes([9; FRAME_KEY_LEN]);
    let s = vec![Complex32::new(1.0, -1.0); 6];
    let payload = samples_as_bytes(&s);
    let h = FrameMeta::iq(MissionId(5), 3, 1_000, 2, 3)
        .with_scene(0x1234_5678_9abc_def0)
        .tagged(&k, payload)
        .header(Some(checksum(payload)))
        .unwrap();
    let wire = encode_wire(&h, payload).unwrap();
    assert_eq!(
        &wire[HEADER_LEN + 56..HEADER_LEN + 64],
        &0x1234_5678_9abc_def0u64.to_le_bytes()
    );
    let (back, p) = decode_wire(&wire, DEFAULT_MAX_FRAME_BYTES, true).unwrap();
    assert_eq!(back.scene_digest, 0x1234_5678_9abc_def0);
    back.verify_tag(&k, p).unwrap();
    let mut other = back;
    other.scene_digest ^= 1;
    assert!(other.verify_tag(&k, p).is_err());
}
