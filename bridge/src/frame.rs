//! Frames: bulk sample blocks (IQ pulses) with a fixed `#[repr(C)]` header.
//!
//! The same [`FrameHeader`] is the iceoryx2 user header of every frame service (zero copy on
//! one host) and, serialised field by field in little endian, the start of a frame on Zenoh:
//!
//! ```text
//! envelope header (48 bytes, body_format = RawFrame, body_crc32 = checksum of the samples)
//! frame descriptor (64 bytes):
//!     0  u16 element_size   bytes per element (8 for complex f32)
//!     2  u16 frame flags    bit 0: the frame carries a tag; other bits 0
//!     4  u32 rows           e.g. pulses (slow time)
//!     8  u32 cols           e.g. fast-time samples per pulse
//!    12  u32 reserved (0)
//!    16  i64 mission_time_ns   mission time of the first row
//!    24  [u8; 32] tag       keyed BLAKE3 of the frame (all zero without a tag)
//!    56  u64 scene_digest   digest of the scene the samples were made with (0: none)
//! samples (rows * cols * element_size bytes, raw little endian; complex f32 = re, im)
//! ```
//!
//! Samples start 112 bytes into the payload, a multiple of 8, so a contiguous receive buffer
//! can be viewed as `[Complex32]` without copying. Decoding checks every field and never
//! panics.
//!
//! The scene digest (`radar_sim::config::SceneFile::digest` for IQ frames) lets a receiver
//! refuse, by name, samples made from another scene than its own, whatever their shape
//! (schema version 2 of the IQ frame; version 1 had no digest).
//!
//! # Tags
//!
//! A frame may carry a tag: the keyed BLAKE3 hash ([`FrameKey::tag`]) under a secret
//! [`FrameKey`] of its kind, schema version, element size, mission id, sequence number, shape,
//! mission time, scene digest and samples. The echo draws a key per mission and gives it to the processors
//! that ask it for apertures; a processor that holds a mission's key takes only frames whose
//! tag it verifies ([`FrameHeader::verify_tag`]), so a peer that may put frames on the
//! mission's key (the bridge) but was never given the key cannot make one the processor
//! takes. Frames without a tag (tools, benchmarks) stay valid wherever no key is required.

use iceoryx2::prelude::ZeroCopySend;
use num_complex::Complex32;

use crate::envelope::{
    le_u16, le_u32, le_u64, now_unix_ns, BodyFormat, CodecError, Header, MissionId, FLAG_CRC,
    HEADER_LEN, MAX_BODY_BYTES,
};

#[cfg(target_endian = "big")]
compile_error!(
    "cellsar frames are little-endian on the wire and in shared memory; big-endian targets \
     would need a byte swap in bridge::frame"
);

/// Message kind of IQ frames (complex f32 samples, rows = pulses, cols = fast-time samples).
pub const IQ_FRAME_KIND: u16 = 0x0200;
/// Schema version of IQ frames (2: the scene digest).
pub const IQ_FRAME_SCHEMA_VERSION: u16 = 2;
/// Size of one complex f32 sample in bytes.
pub const COMPLEX32_BYTES: u16 = 8;
/// Length of the frame descriptor that follows the envelope header on Zenoh.
pub const DESCRIPTOR_LEN: usize = 64;
/// Length of a frame key and of a frame tag in bytes.
pub const FRAME_KEY_LEN: usize = 32;
/// Offset of the first sample in a frame's Zenoh payload.
pub const WIRE_PREFIX_LEN: usize = HEADER_LEN + DESCRIPTOR_LEN;
/// Frame header flag: the frame came in from Zenoh through a bridge and is never sent back
/// out (see [`crate::forward`]). Only used in shared memory; never on the wire.
pub const FLAG_BRIDGED: u16 = 2;
/// Frame header flag: `tag` is valid (the frame is tagged). On the wire, bit 0 of the frame
/// descriptor's flags.
pub const FLAG_TAGGED: u16 = 4;
/// The descriptor's frame-flags bit of a tagged frame.
const DESCRIPTOR_TAGGED: u16 = 1;
/// Default largest frame payload (64 MiB).
pub const DEFAULT_MAX_FRAME_BYTES: usize = 64 << 20;
/// The default `--max-frame-bytes` of the IQ frame services (4 MiB: 100 pulses of 4096
/// samples fit): `cellsar-bridge`, `cellsar bridge`, `cellsar run`, `cellsar echo` and
/// `cellsar process` all default to it, as every process of a mission must use the same value
/// (`radar_sim::service::DEFAULT_MAX_FRAME_BYTES` must equal it).
pub const SERVICE_MAX_FRAME_BYTES: usize = 4 << 20;

/// The header of a frame (iceoryx2 user header; see the module documentation for its wire
/// form).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[repr(C)]
#[type_name("cellsar::FrameHeader/3")]
pub struct FrameHeader {
    /// Message kind of the frame (e.g. [`IQ_FRAME_KIND`]).
    pub kind: u16,
    /// Schema version of the frame kind.
    pub schema_version: u16,
    /// Bytes per element (8 for complex f32).
    pub element_size: u16,
    /// Flags ([`FLAG_CRC`]: `checksum` is valid; [`FLAG_BRIDGED`]; [`FLAG_TAGGED`]: `tag` is
    /// valid).
    pub flags: u16,
    /// CRC-32 (IEEE) of the payload bytes.
    pub checksum: u32,
    /// Reserved, 0.
    pub reserved: u32,
    /// Mission id ([`MissionId`]).
    pub mission_id: u64,
    /// Sequence number of the frame on its service.
    pub seq: u64,
    /// Time the frame was published, ns since the Unix epoch.
    pub time_unix_ns: u64,
    /// Mission time of the first row, ns.
    pub mission_time_ns: i64,
    /// Shape: `[rows, cols]`.
    pub shape: [u32; 2],
    /// Payload length in bytes (= rows * cols * element_size).
    pub payload_len: u64,
    /// Digest of the scene the samples were made with (0: no scene named).
    pub scene_digest: u64,
    /// Keyed BLAKE3 tag of the frame ([`FrameKey::tag`]) when [`FLAG_TAGGED`] is set, else 0.
    pub tag: [u8; FRAME_KEY_LEN],
}

/// A secret key that tags frames (32 bytes, from the operating system's random source). Its
/// `Debug` form does not show it.
#[derive(Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FrameKey([u8; FRAME_KEY_LEN]);

impl std::fmt::Debug for FrameKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("FrameKey(..)")
    }
}

impl FrameKey {
    /// A new key drawn from the operating system's random source.
    pub fn random() -> Result<Self, CodecError> {
        let mut key = [0u8; FRAME_KEY_LEN];
        getrandom::fill(&mut key).map_err(|e| CodecError::Field {
            field: "frame key",
            reason: format!("the operating system's random source failed: {e}"),
        })?;
        Ok(FrameKey(key))
    }

    /// A key of the given bytes.
    pub fn from_bytes(bytes: [u8; FRAME_KEY_LEN]) -> Self {
        FrameKey(bytes)
    }

    /// The key's bytes.
    pub fn as_bytes(&self) -> &[u8; FRAME_KEY_LEN] {
        &self.0
    }

    /// The tag of a frame of `meta` whose payload is `payload`: keyed BLAKE3 of a domain
    /// string, the kind, schema version, element size, mission id, sequence number, rows,
    /// cols, mission time, scene digest and payload length (little endian), then the payload.
    pub fn tag(&self, meta: &FrameMeta, payload: &[u8]) -> [u8; FRAME_KEY_LEN] {
        self.tag_hash(meta, payload).into()
    }

    fn tag_hash(&self, meta: &FrameMeta, payload: &[u8]) -> blake3::Hash {
        let mut h = blake3::Hasher::new_keyed(&self.0);
        h.update(b"cellsar frame tag 2\0");
        h.update(&meta.kind.to_le_bytes());
        h.update(&meta.schema_version.to_le_bytes());
        h.update(&meta.element_size.to_le_bytes());
        h.update(&meta.mission_id.0.to_le_bytes());
        h.update(&meta.seq.to_le_bytes());
        h.update(&meta.shape[0].to_le_bytes());
        h.update(&meta.shape[1].to_le_bytes());
        h.update(&meta.mission_time_ns.to_le_bytes());
        h.update(&meta.scene_digest.to_le_bytes());
        h.update(&(payload.len() as u64).to_le_bytes());
        h.update(payload);
        h.finalize()
    }
}

/// What a sender chooses for a frame; the rest of [`FrameHeader`] is filled in on send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameMeta {
    /// Message kind.
    pub kind: u16,
    /// Schema version.
    pub schema_version: u16,
    /// Bytes per element.
    pub element_size: u16,
    /// Mission id.
    pub mission_id: MissionId,
    /// Sequence number.
    pub seq: u64,
    /// Mission time of the first row, ns.
    pub mission_time_ns: i64,
    /// `[rows, cols]`.
    pub shape: [u32; 2],
    /// Digest of the scene the samples were made with (0: none).
    pub scene_digest: u64,
    /// The frame's tag ([`FrameKey::tag`]), if it carries one.
    pub tag: Option<[u8; FRAME_KEY_LEN]>,
}

impl FrameMeta {
    /// Metadata of an IQ frame of `rows` pulses x `cols` complex f32 samples.
    pub fn iq(mission_id: MissionId, seq: u64, mission_time_ns: i64, rows: u32, cols: u32) -> Self {
        FrameMeta {
            kind: IQ_FRAME_KIND,
            schema_version: IQ_FRAME_SCHEMA_VERSION,
            element_size: COMPLEX32_BYTES,
            mission_id,
            seq,
            mission_time_ns,
            shape: [rows, cols],
            scene_digest: 0,
            tag: None,
        }
    }

    /// This metadata naming the scene its samples were made with (set before the tag).
    pub fn with_scene(mut self, scene_digest: u64) -> Self {
        self.scene_digest = scene_digest;
        self
    }

    /// This metadata with the tag of `payload` under `key` ([`FrameKey::tag`]).
    pub fn tagged(mut self, key: &FrameKey, payload: &[u8]) -> Self {
        self.tag = Some(key.tag(&self, payload));
        self
    }

    /// Metadata of an opaque byte frame of `len` bytes (shape `[1, len]`).
    pub fn bytes(
        kind: u16,
        mission_id: MissionId,
        seq: u64,
        len: usize,
    ) -> Result<Self, CodecError> {
        let cols = u32::try_from(len).map_err(|_| CodecError::TooLarge {
            what: "byte frame",
            len: len as u64,
            limit: u64::from(u32::MAX),
        })?;
        Ok(FrameMeta {
            kind,
            schema_version: 1,
            element_size: 1,
            mission_id,
            seq,
            mission_time_ns: 0,
            shape: [1, cols],
            scene_digest: 0,
            tag: None,
        })
    }

    /// Payload length implied by shape and element size.
    pub fn payload_len(&self) -> Result<usize, CodecError> {
        payload_len_of(self.shape, self.element_size)
    }

    /// The full header for a payload of `payload` bytes; `checksum` = `None` leaves the CRC
    /// flag clear.
    pub fn header(&self, checksum: Option<u32>) -> Result<FrameHeader, CodecError> {
        let payload_len = self.payload_len()?;
        Ok(FrameHeader {
            kind: self.kind,
            schema_version: self.schema_version,
            element_size: self.element_size,
            flags: if checksum.is_some() { FLAG_CRC } else { 0 }
                | if self.tag.is_some() { FLAG_TAGGED } else { 0 },
            checksum: checksum.unwrap_or(0),
            reserved: 0,
            mission_id: self.mission_id.0,
            seq: self.seq,
            time_unix_ns: now_unix_ns(),
            mission_time_ns: self.mission_time_ns,
            shape: self.shape,
            payload_len: payload_len as u64,
            scene_digest: self.scene_digest,
            tag: self.tag.unwrap_or_default(),
        })
    }
}

fn payload_len_of(shape: [u32; 2], element_size: u16) -> Result<usize, CodecError> {
    if element_size == 0 {
        return Err(CodecError::Field {
            field: "element_size",
            reason: "must be at least 1 byte".into(),
        });
    }
    u64::from(shape[0])
        .checked_mul(u64::from(shape[1]))
        .and_then(|n| n.checked_mul(u64::from(element_size)))
        .and_then(|n| usize::try_from(n).ok())
        .ok_or_else(|| CodecError::Field {
            field: "shape",
            reason: format!(
                "{} x {} x {element_size} bytes overflows",
                shape[0], shape[1]
            ),
        })
}

impl FrameHeader {
    /// Mission id as a typed value.
    pub fn mission(&self) -> MissionId {
        MissionId(self.mission_id)
    }

    /// Whether `checksum` is valid.
    pub fn has_checksum(&self) -> bool {
        self.flags & FLAG_CRC != 0
    }

    /// Whether the frame carries a tag.
    pub fn has_tag(&self) -> bool {
        self.flags & FLAG_TAGGED != 0
    }

    /// The metadata this header was made of (its tag included).
    pub fn meta(&self) -> FrameMeta {
        FrameMeta {
            kind: self.kind,
            schema_version: self.schema_version,
            element_size: self.element_size,
            mission_id: MissionId(self.mission_id),
            seq: self.seq,
            mission_time_ns: self.mission_time_ns,
            shape: self.shape,
            scene_digest: self.scene_digest,
            tag: self.has_tag().then_some(self.tag),
        }
    }

    /// Checks that the frame was made from the scene whose digest is `ours` (the receiver's):
    /// an error names the field, both digests and what to do ([`scene_mismatch`]). The digest
    /// is authentic only once the tag verifies ([`FrameHeader::verify_tag`] covers it).
    pub fn check_scene(&self, ours: u64) -> Result<(), CodecError> {
        if self.scene_digest == ours {
            return Ok(());
        }
        Err(CodecError::Field {
            field: "scene_digest",
            reason: scene_mismatch(self.scene_digest, ours),
        })
    }

    /// Checks the frame's tag against `payload` under `key`: an error names a frame without
    /// a tag or one whose tag does not match (a different key, or any tagged field or sample
    /// changed). The comparison takes the same time wherever the tags differ.
    pub fn verify_tag(&self, key: &FrameKey, payload: &[u8]) -> Result<(), CodecError> {
        if !self.has_tag() {
            return Err(CodecError::Field {
                field: "tag",
                reason: "the frame carries no tag, and its mission requires one".into(),
            });
        }
        // `blake3::Hash` compares in constant time
        if key.tag_hash(&self.meta(), payload) != blake3::Hash::from(self.tag) {
            return Err(CodecError::Field {
                field: "tag",
                reason: "the frame's tag does not match its contents under the mission's key"
                    .into(),
            });
        }
        Ok(())
    }

    /// Checks the header's internal consistency against the payload length actually present
    /// and the size limit.
    pub fn validate(
        &self,
        actual_payload_len: usize,
        max_payload: usize,
    ) -> Result<(), CodecError> {
        let known = FLAG_CRC | FLAG_BRIDGED | FLAG_TAGGED;
        if self.flags & !known != 0 {
            return Err(CodecError::Field {
                field: "flags",
                reason: format!("unknown flag bits {:#06x}", self.flags & !known),
            });
        }
        if self.has_tag() == (self.tag == [0; FRAME_KEY_LEN]) {
            return Err(CodecError::Field {
                field: "tag",
                reason: if self.has_tag() {
                    "a tagged frame's tag is never all zero".into()
                } else {
                    "a frame without the tagged flag must have an all-zero tag".into()
                },
            });
        }
        if self.payload_len > max_payload as u64 {
            return Err(CodecError::TooLarge {
                what: "frame payload_len",
                len: self.payload_len,
                limit: max_payload as u64,
            });
        }
        let implied = payload_len_of(self.shape, self.element_size)?;
        if implied as u64 != self.payload_len {
            return Err(CodecError::Field {
                field: "shape",
                reason: format!(
                    "{} x {} x {} bytes = {implied} bytes, but payload_len is {}",
                    self.shape[0], self.shape[1], self.element_size, self.payload_len
                ),
            });
        }
        if self.payload_len != actual_payload_len as u64 {
            return Err(CodecError::Field {
                field: "payload_len",
                reason: format!(
                    "the frame header says {} bytes but {actual_payload_len} bytes are present",
                    self.payload_len
                ),
            });
        }
        Ok(())
    }

    /// Verifies the checksum (if present) of `payload`.
    pub fn verify_checksum(&self, payload: &[u8]) -> Result<(), CodecError> {
        if self.has_checksum() {
            let actual = crc32fast::hash(payload);
            if actual != self.checksum {
                return Err(CodecError::Checksum {
                    expected: self.checksum,
                    actual,
                });
            }
        }
        Ok(())
    }

    /// The 112-byte Zenoh prefix (envelope header + frame descriptor) of this frame.
    pub fn to_wire_prefix(&self) -> [u8; WIRE_PREFIX_LEN] {
        let header = Header {
            body_format: BodyFormat::RawFrame,
            kind: self.kind,
            schema_version: self.schema_version,
            flags: self.flags & FLAG_CRC,
            body_crc32: self.checksum,
            mission_id: MissionId(self.mission_id),
            seq: self.seq,
            time_unix_ns: self.time_unix_ns,
            body_len: (DESCRIPTOR_LEN as u64).saturating_add(self.payload_len),
        };
        let mut out = [0u8; WIRE_PREFIX_LEN];
        out[..HEADER_LEN].copy_from_slice(&header.to_bytes());
        let d = &mut out[HEADER_LEN..];
        d[0..2].copy_from_slice(&self.element_size.to_le_bytes());
        if self.has_tag() {
            d[2..4].copy_from_slice(&DESCRIPTOR_TAGGED.to_le_bytes());
        }
        d[4..8].copy_from_slice(&self.shape[0].to_le_bytes());
        d[8..12].copy_from_slice(&self.shape[1].to_le_bytes());
        d[16..24].copy_from_slice(&self.mission_time_ns.to_le_bytes());
        d[24..56].copy_from_slice(&self.tag);
        d[56..64].copy_from_slice(&self.scene_digest.to_le_bytes());
        out
    }

    /// Parses and checks the 112-byte Zenoh prefix of a frame whose whole payload (prefix +
    /// samples) is `total_len` bytes long.
    pub fn from_wire_prefix(
        prefix: &[u8],
        total_len: usize,
        max_payload: usize,
    ) -> Result<FrameHeader, CodecError> {
        let header = Header::parse(prefix)?;
        if header.body_format != BodyFormat::RawFrame {
            return Err(CodecError::Field {
                field: "body_format",
                reason: format!(
                    "expected RawFrame for a frame, got {:?}",
                    header.body_format
                ),
            });
        }
        let Some(d) = prefix.get(HEADER_LEN..WIRE_PREFIX_LEN) else {
            return Err(CodecError::TooShort { len: prefix.len() });
        };
        if le_u32(&d[12..16]) != 0 {
            return Err(CodecError::Field {
                field: "frame descriptor reserved",
                reason: "reserved bytes must be 0".into(),
            });
        }
        let frame_flags = le_u16(&d[2..4]);
        if frame_flags & !DESCRIPTOR_TAGGED != 0 {
            return Err(CodecError::Field {
                field: "frame descriptor flags",
                reason: format!(
                    "unknown flag bits {:#06x}",
                    frame_flags & !DESCRIPTOR_TAGGED
                ),
            });
        }
        let mut tag = [0u8; FRAME_KEY_LEN];
        tag.copy_from_slice(&d[24..56]);
        let Some(payload_len) = header.body_len.checked_sub(DESCRIPTOR_LEN as u64) else {
            return Err(CodecError::Field {
                field: "body_len",
                reason: format!(
                    "{} is shorter than the {DESCRIPTOR_LEN}-byte frame descriptor",
                    header.body_len
                ),
            });
        };
        let fh = FrameHeader {
            kind: header.kind,
            schema_version: header.schema_version,
            element_size: le_u16(&d[0..2]),
            flags: header.flags
                | if frame_flags & DESCRIPTOR_TAGGED != 0 {
                    FLAG_TAGGED
                } else {
                    0
                },
            checksum: header.body_crc32,
            reserved: 0,
            mission_id: header.mission_id.0,
            seq: header.seq,
            time_unix_ns: header.time_unix_ns,
            mission_time_ns: le_u64(&d[16..24]) as i64,
            shape: [le_u32(&d[4..8]), le_u32(&d[8..12])],
            payload_len,
            scene_digest: le_u64(&d[56..64]),
            tag,
        };
        let actual = total_len.saturating_sub(WIRE_PREFIX_LEN);
        if total_len < WIRE_PREFIX_LEN {
            return Err(CodecError::TooShort { len: total_len });
        }
        fh.validate(actual, max_payload.min(MAX_FRAME_HARD_LIMIT))?;
        Ok(fh)
    }
}

/// What a receiver says of a frame or aperture request made from the scene of digest `theirs`
/// when its own scene's is `ours`: both digests (16 hex digits) and what to do.
pub fn scene_mismatch(theirs: u64, ours: u64) -> String {
    format!(
        "scene mismatch: scene digest {theirs:016x}, where this service's scene has \
         {ours:016x} (every process of a mission must read the same scene: give each the same \
         --scene file)"
    )
}

/// Absolute upper bound on a frame payload (1 GiB), whatever the configured limit.
pub const MAX_FRAME_HARD_LIMIT: usize = 1 << 30;

// The frame descriptor keeps samples 8-byte aligned after the envelope header.
const _: () = assert!(WIRE_PREFIX_LEN.is_multiple_of(8));
const _: () = assert!(std::mem::size_of::<FrameHeader>() == 104);
const _: () = assert!(MAX_BODY_BYTES <= MAX_FRAME_HARD_LIMIT);

/// Encodes a frame for Zenoh: prefix + payload in one buffer.
pub fn encode_wire(header: &FrameHeader, payload: &[u8]) -> Result<Vec<u8>, CodecError> {
    header.validate(payload.len(), MAX_FRAME_HARD_LIMIT)?;
    let mut out = Vec::with_capacity(WIRE_PREFIX_LEN + payload.len());
    out.extend_from_slice(&header.to_wire_prefix());
    out.extend_from_slice(payload);
    Ok(out)
}

/// Decodes a contiguous Zenoh frame payload into its header and sample bytes; the checksum is
/// verified when `verify_checksum` is set.
pub fn decode_wire(
    bytes: &[u8],
    max_payload: usize,
    verify_checksum: bool,
) -> Result<(FrameHeader, &[u8]), CodecError> {
    let prefix = bytes
        .get(..WIRE_PREFIX_LEN)
        .ok_or(CodecError::TooShort { len: bytes.len() })?;
    let header = FrameHeader::from_wire_prefix(prefix, bytes.len(), max_payload)?;
    let payload = &bytes[WIRE_PREFIX_LEN..];
    if verify_checksum {
        header.verify_checksum(payload)?;
    }
    Ok((header, payload))
}

/// CRC-32 (IEEE) of a payload, as stored in [`FrameHeader::checksum`].
pub fn checksum(payload: &[u8]) -> u32 {
    crc32fast::hash(payload)
}

/// Views complex samples as their little-endian bytes (no copy).
pub fn samples_as_bytes(samples: &[Complex32]) -> &[u8] {
    bytemuck::cast_slice(samples)
}

/// Views bytes as complex samples (no copy); fails if the length is not a multiple of 8 or
/// the buffer is not 4-byte aligned.
pub fn bytes_as_samples(bytes: &[u8]) -> Result<&[Complex32], CodecError> {
    bytemuck::try_cast_slice(bytes).map_err(|e| CodecError::Field {
        field: "samples",
        reason: format!(
            "{} bytes cannot be viewed as complex f32: {e:?}",
            bytes.len()
        ),
    })
}

/// Mutable view of bytes as complex samples (no copy).
pub fn bytes_as_samples_mut(bytes: &mut [u8]) -> Result<&mut [Complex32], CodecError> {
    let len = bytes.len();
    bytemuck::try_cast_slice_mut(bytes).map_err(|e| CodecError::Field {
        field: "samples",
        reason: format!("{len} bytes cannot be viewed as complex f32: {e:?}"),
    })
}

/// Copies bytes into a new vector of complex samples (for unaligned buffers).
pub fn samples_from_bytes(bytes: &[u8]) -> Result<Vec<Complex32>, CodecError> {
    if !bytes.len().is_multiple_of(usize::from(COMPLEX32_BYTES)) {
        return Err(CodecError::Field {
            field: "samples",
            reason: format!("{} bytes is not a multiple of 8", bytes.len()),
        });
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|c| {
            Complex32::new(
                f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                f32::from_le_bytes([c[4], c[5], c[6], c[7]]),
            )
        })
        .collect())
}

#[cfg(test)]
mod tests;
