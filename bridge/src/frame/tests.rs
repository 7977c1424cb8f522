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

/// A tagged frame survives the wire and verifies; the tag and the scene digest sit in the
/// descriptor.
#[test]
fn tagged_frame_roundtrip() {
    let (h, s) = iq(3, 4);
    let payload = samples_as_bytes(&s);
    let k = key(7);
    let digest = 0x0102_0304_0506_0708u64;
    let h = h
        .meta()
        .with_scene(digest)
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
    assert_eq!(
        &wire[HEADER_LEN + 56..HEADER_LEN + 64],
        &digest.to_le_bytes()
    );
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
        &digest.to_le_bytes(),
        &96u64.to_le_bytes(),
        payload,
    ] {
        msg.extend_from_slice(part);
    }
    assert_eq!(h.tag, *blake3::keyed_hash(k.as_bytes(), &msg).as_bytes());
}

/// Changing a sample, the sequence number, the mission time, the shape, the mission, the
/// scene digest or the key makes the tag fail; so does a frame without a tag.
#[test]
fn tag_mismatch_is_refused() {
    let (h, s) = iq(2, 4);
    let payload = samples_as_bytes(&s).to_vec();
    let k = key(9);
    let h = h
        .meta()
        .with_scene(0x00ff_00ff_00ff_00ff)
        .tagged(&k, &payload)
        .header(None)
        .unwrap();
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
    h2.scene_digest ^= 1 << 63;
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
    // so is a scene digest relabelled on the wire, whichever of its bytes is flipped
    for i in 56..64 {
        let mut wire = encode_wire(&h, &payload).unwrap();
        wire[HEADER_LEN + i] ^= 0x10;
        let (h3, p3) = decode_wire(&wire, DEFAULT_MAX_FRAME_BYTES, true).unwrap();
        assert_ne!(h3.scene_digest, h.scene_digest);
        refused(&h3, &k, p3);
    }
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
                        tag in any::<Option<[u8; 32]>>(), digest in any::<u64>()) {
        let tag = tag.filter(|t| *t != [0; 32]);
        let m = FrameMeta { kind, schema_version: ver, element_size: elem, mission_id: MissionId(mission), seq, mission_time_ns: mt, shape: [rows, cols], scene_digest: digest, tag };
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

/// The scene digest travels at bytes 56..64 of the descriptor, little endian, and round trips;
/// a frame written with one digest and read expecting another is refused, naming the field
/// and both digests; a frame of no scene (digest 0) is refused by a receiver that has one.
#[test]
fn a_frame_of_another_scene_is_refused_naming_both_digests() {
    let k = key(9);
    let s = vec![Complex32::new(1.0, -1.0); 6];
    let payload = samples_as_bytes(&s);
    let (written, expected) = (0x1234_5678_9abc_def0u64, 0x0fed_cba9_8765_4321u64);
    let h = FrameMeta::iq(MissionId(5), 3, 1_000, 2, 3)
        .with_scene(written)
        .tagged(&k, payload)
        .header(Some(checksum(payload)))
        .unwrap();
    let wire = encode_wire(&h, payload).unwrap();
    assert_eq!(
        &wire[HEADER_LEN + 56..HEADER_LEN + 64],
        &written.to_le_bytes()
    );
    let (back, p) = decode_wire(&wire, DEFAULT_MAX_FRAME_BYTES, true).unwrap();
    assert_eq!(back.scene_digest, written);
    back.verify_tag(&k, p).unwrap();
    back.check_scene(written).unwrap();
    let e = back.check_scene(expected).unwrap_err().to_string();
    assert!(
        e.contains("scene_digest")
            && e.contains(
                "scene digest 123456789abcdef0, where this service's scene has 0fedcba987654321"
            )
            && e.contains("--scene"),
        "{e}"
    );
    let none = FrameMeta::iq(MissionId(5), 3, 1_000, 2, 3)
        .header(None)
        .unwrap();
    assert_eq!(none.scene_digest, 0);
    let e = none.check_scene(written).unwrap_err().to_string();
    assert!(e.contains("scene digest 0000000000000000"), "{e}");
}

/// Every length the prefix declares (body length, shape, element size) is checked against the
/// limit and against the bytes present before a payload is looked at or copied: a prefix that
/// declares more than the limit is refused given the prefix alone.
#[test]
fn declared_lengths_are_bounded_before_the_payload() {
    let (h, s) = iq(2, 2);
    let wire = encode_wire(&h, samples_as_bytes(&s)).unwrap();
    let prefix = &wire[..WIRE_PREFIX_LEN];
    let set_body_len = |len: u64| {
        let mut p = prefix.to_vec();
        p[40..48].copy_from_slice(&len.to_le_bytes());
        p
    };
    // a huge body, the prefix alone present
    for len in [
        u64::MAX,
        (MAX_FRAME_HARD_LIMIT as u64) + DESCRIPTOR_LEN as u64 + 8,
    ] {
        let e = FrameHeader::from_wire_prefix(&set_body_len(len), WIRE_PREFIX_LEN, usize::MAX)
            .unwrap_err();
        assert!(matches!(e, CodecError::TooLarge { .. }), "{e}");
    }
    // a body shorter than the descriptor (56: the descriptor of frame schema 1)
    for len in [0, 56, DESCRIPTOR_LEN as u64 - 1] {
        let e = FrameHeader::from_wire_prefix(&set_body_len(len), wire.len(), 1 << 20).unwrap_err();
        assert!(e.to_string().contains("body_len"), "{len}: {e}");
    }
    // a shape of more samples than the limit, whatever the body length says
    let mut p = prefix.to_vec();
    p[HEADER_LEN + 4..HEADER_LEN + 12].copy_from_slice(&[0xff; 8]);
    let e = FrameHeader::from_wire_prefix(&p, wire.len(), 1 << 20).unwrap_err();
    assert!(e.to_string().contains("shape"), "{e}");
    // a body that claims more bytes than are present
    let e = FrameHeader::from_wire_prefix(prefix, WIRE_PREFIX_LEN + 8, 1 << 20).unwrap_err();
    assert!(e.to_string().contains("payload_len"), "{e}");
    // a frame of schema 1 (a 56-byte descriptor, no digest) does not decode
    let mut old = wire.clone();
    old.drain(HEADER_LEN + 56..HEADER_LEN + 64);
    old[8..10].copy_from_slice(&1u16.to_le_bytes());
    let body_len = (old.len() - HEADER_LEN) as u64;
    old[40..48].copy_from_slice(&body_len.to_le_bytes());
    assert!(decode_wire(&old, DEFAULT_MAX_FRAME_BYTES, false).is_err());
}
