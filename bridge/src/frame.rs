//! Frames: bulk sample blocks (IQ pulses) with a fixed `#[repr(C)]` header.
//!
//! The same [`FrameHeader`] is the iceoryx2 user header of every frame service (zero copy on
//! one host) and, serialised field by field in little endian, the start of a frame on Zenoh:
//!
//! ```text
//! envelope header (48 bytes, body_format = RawFrame, body_crc32 = checksum of the samples)
//! frame descriptor (24 bytes):
//!     0  u16 element_size   bytes per element (8 for complex f32)
//!     2  u16 reserved (0)
//!     4  u32 rows           e.g. pulses (slow time)
//!     8  u32 cols           e.g. fast-time samples per pulse
//!    12  u32 reserved (0)
//!    16  i64 mission_time_ns   mission time of the first row
//! samples (rows * cols * element_size bytes, raw little endian; complex f32 = re, im)
//! ```
//!
//! Samples start 72 bytes into the payload, a multiple of 8, so a contiguous receive buffer
//! can be viewed as `[Complex32]` without copying. Decoding checks every field and never
//! panics.

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
/// Schema version of IQ frames.
pub const IQ_FRAME_SCHEMA_VERSION: u16 = 1;
/// Size of one complex f32 sample in bytes.
pub const COMPLEX32_BYTES: u16 = 8;
/// Length of the frame descriptor that follows the envelope header on Zenoh.
pub const DESCRIPTOR_LEN: usize = 24;
/// Offset of the first sample in a frame's Zenoh payload.
pub const WIRE_PREFIX_LEN: usize = HEADER_LEN + DESCRIPTOR_LEN;
/// Frame header flag: the frame came in from Zenoh through a bridge and is never sent back
/// out (see [`crate::forward`]). Only used in shared memory; never on the wire.
pub const FLAG_BRIDGED: u16 = 2;
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
#[type_name("cellsar::FrameHeader/1")]
pub struct FrameHeader {
    /// Message kind of the frame (e.g. [`IQ_FRAME_KIND`]).
    pub kind: u16,
    /// Schema version of the frame kind.
    pub schema_version: u16,
    /// Bytes per element (8 for complex f32).
    pub element_size: u16,
    /// Flags ([`FLAG_CRC`]: `checksum` is valid; [`FLAG_BRIDGED`]).
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
        }
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
            flags: if checksum.is_some() { FLAG_CRC } else { 0 },
            checksum: checksum.unwrap_or(0),
            reserved: 0,
            mission_id: self.mission_id.0,
            seq: self.seq,
            time_unix_ns: now_unix_ns(),
            mission_time_ns: self.mission_time_ns,
            shape: self.shape,
            payload_len: payload_len as u64,
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

    /// Checks the header's internal consistency against the payload length actually present
    /// and the size limit.
    pub fn validate(
        &self,
        actual_payload_len: usize,
        max_payload: usize,
    ) -> Result<(), CodecError> {
        if self.flags & !(FLAG_CRC | FLAG_BRIDGED) != 0 {
            return Err(CodecError::Field {
                field: "flags",
                reason: format!(
                    "unknown flag bits {:#06x}",
                    self.flags & !(FLAG_CRC | FLAG_BRIDGED)
                ),
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

    /// The 72-byte Zenoh prefix (envelope header + frame descriptor) of this frame.
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
        d[4..8].copy_from_slice(&self.shape[0].to_le_bytes());
        d[8..12].copy_from_slice(&self.shape[1].to_le_bytes());
        d[16..24].copy_from_slice(&self.mission_time_ns.to_le_bytes());
        out
    }

    /// Parses and checks the 72-byte Zenoh prefix of a frame whose whole payload (prefix +
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
        if le_u16(&d[2..4]) != 0 || le_u32(&d[12..16]) != 0 {
            return Err(CodecError::Field {
                field: "frame descriptor reserved",
                reason: "reserved bytes must be 0".into(),
            });
        }
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
            flags: header.flags,
            checksum: header.body_crc32,
            reserved: 0,
            mission_id: header.mission_id.0,
            seq: header.seq,
            time_unix_ns: header.time_unix_ns,
            mission_time_ns: le_u64(&d[16..24]) as i64,
            shape: [le_u32(&d[4..8]), le_u32(&d[8..12])],
            payload_len,
        };
        let actual = total_len.saturating_sub(WIRE_PREFIX_LEN);
        if total_len < WIRE_PREFIX_LEN {
            return Err(CodecError::TooShort { len: total_len });
        }
        fh.validate(actual, max_payload.min(MAX_FRAME_HARD_LIMIT))?;
        Ok(fh)
    }
}

/// Absolute upper bound on a frame payload (1 GiB), whatever the configured limit.
pub const MAX_FRAME_HARD_LIMIT: usize = 1 << 30;

// The frame descriptor keeps samples 8-byte aligned after the envelope header.
const _: () = assert!(WIRE_PREFIX_LEN.is_multiple_of(8));
const _: () = assert!(std::mem::size_of::<FrameHeader>() == 64);
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
mod tests {
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
    fn header_is_64_bytes_and_c_layout() {
        assert_eq!(std::mem::size_of::<FrameHeader>(), 64);
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
                            seq in any::<u64>(), mt in any::<i64>(), t in any::<u64>()) {
            let m = FrameMeta { kind, schema_version: ver, element_size: elem, mission_id: MissionId(mission), seq, mission_time_ns: mt, shape: [rows, cols] };
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
}
