//! Raw frames in from Zenoh ([`ZenohNode::frame_subscriber`], [`ZenohFrameSubscriber`]): the
//! header checked in the Zenoh callback, the payload read in the consumer's thread
//! ([`ZenohFrame`], [`OwnedFrame`]).

use std::sync::mpsc::{self, Receiver};
use std::sync::Arc;
use std::time::Duration;

use zenoh::bytes::ZBytes;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Wait;

use super::{FrameSubscribeOptions, NetError, OnFull, ZenohNode};
use crate::counters::{BadPayloadLog, Counters};
use crate::envelope::CodecError;
use crate::frame::{self, FrameHeader, WIRE_PREFIX_LEN};

impl ZenohNode {
    /// Declares a subscriber of raw frames on `key`. The Zenoh callback only checks the frame
    /// header (112 bytes) and queues the sample; the payload is read (copied or verified) in the
    /// consumer's thread, so a slow consumer never holds up Zenoh's receive path.
    pub fn frame_subscriber(
        &self,
        key: &str,
        opts: FrameSubscribeOptions,
    ) -> Result<ZenohFrameSubscriber, NetError> {
        let (tx, rx) = mpsc::sync_channel::<ZenohFrame>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let log = Arc::new(BadPayloadLog::default());
        let c = counters.clone();
        let cb_log = log.clone();
        let block = opts.on_full == OnFull::Block;
        let subscriber = self
            .session()
            .declare_subscriber(key.to_string())
            .callback(move |sample: Sample| {
                if sample.kind() != SampleKind::Put {
                    return;
                }
                let len = sample.payload().len();
                c.on_received(len);
                match split_frame_payload(sample.payload(), opts.max_payload_bytes) {
                    Ok((header, _)) => {
                        let f = ZenohFrame { header, sample };
                        let sent = if block {
                            tx.send(f).is_ok()
                        } else {
                            tx.try_send(f).is_ok()
                        };
                        if !sent {
                            c.on_dropped(1);
                        }
                    }
                    Err(e) => {
                        c.on_malformed();
                        cb_log.log(sample.key_expr().as_str(), len, &e);
                    }
                }
            })
            .allowed_origin(opts.allowed_origin)
            .wait()
            .map_err(|e| NetError::zenoh("declare subscriber", key, e))?;
        Ok(ZenohFrameSubscriber {
            _subscriber: subscriber,
            rx,
            counters,
            log,
            verify_checksum: opts.verify_checksum,
            key: key.to_string(),
        })
    }
}

/// A frame received over Zenoh, copied into an 8-byte-aligned buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedFrame {
    /// Its header.
    pub header: FrameHeader,
    words: Vec<u64>,
}

impl OwnedFrame {
    /// A frame from a header and payload bytes (checked for consistency).
    pub fn new(header: FrameHeader, payload: &[u8]) -> Result<Self, CodecError> {
        header.validate(payload.len(), frame::MAX_FRAME_HARD_LIMIT)?;
        let mut words = vec![0u64; payload.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..payload.len()].copy_from_slice(payload);
        Ok(OwnedFrame { header, words })
    }

    /// The payload bytes.
    pub fn payload(&self) -> &[u8] {
        let len = usize::try_from(self.header.payload_len).unwrap_or(usize::MAX);
        let all = bytemuck::cast_slice::<u64, u8>(&self.words);
        &all[..len.min(all.len())]
    }

    /// The payload as complex f32 samples (element size must be 8).
    pub fn samples(&self) -> Result<&[num_complex::Complex32], CodecError> {
        frame::bytes_as_samples(self.payload())
    }
}

/// A subscriber of raw frames on Zenoh.
pub struct ZenohFrameSubscriber {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    rx: Receiver<ZenohFrame>,
    counters: Arc<Counters>,
    log: Arc<BadPayloadLog>,
    verify_checksum: bool,
    key: String,
}

impl ZenohFrameSubscriber {
    /// Waits up to `timeout` for the next good frame, without copying its payload (the
    /// checksum, if enabled, is verified slice by slice).
    pub fn recv_frame_timeout(&self, timeout: Duration) -> Option<ZenohFrame> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            let f = self.rx.recv_timeout(left).ok()?;
            if self.verify_checksum {
                if let Err(e) = f.verify_checksum() {
                    self.counters.on_malformed();
                    self.log.log(&self.key, f.sample.payload().len(), &e);
                    continue;
                }
            }
            self.counters.on_delivered();
            return Some(f);
        }
    }

    /// Waits up to `timeout` for the next good frame, copied once into an aligned buffer.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<OwnedFrame> {
        let f = self.recv_frame_timeout(timeout)?;
        match f.to_owned_frame() {
            Ok(o) => Some(o),
            Err(e) => {
                // cannot happen for a frame whose header was checked; counted if it does
                self.counters.on_malformed();
                self.log.log(&self.key, f.sample.payload().len(), &e);
                None
            }
        }
    }

    /// Counters of this subscriber (`delivered` counts frames handed out, `malformed`
    /// includes checksum failures found when they are taken).
    pub fn counters(&self) -> &Counters {
        &self.counters
    }
}

/// A frame received over Zenoh, still in Zenoh's buffers (possibly many slices).
pub struct ZenohFrame {
    /// The checked header.
    pub header: FrameHeader,
    sample: Sample,
}

impl ZenohFrame {
    /// The payload as consecutive slices (no copy).
    pub fn payload_chunks(&self) -> Vec<&[u8]> {
        split_frame_payload(self.sample.payload(), usize::MAX)
            .map(|(_, c)| c)
            .unwrap_or_default()
    }

    /// Verifies the CRC (if present) over the slices.
    pub fn verify_checksum(&self) -> Result<(), CodecError> {
        if !self.header.has_checksum() {
            return Ok(());
        }
        let mut h = crc32fast::Hasher::new();
        for c in self.payload_chunks() {
            h.update(c);
        }
        let actual = h.finalize();
        if actual != self.header.checksum {
            return Err(CodecError::Checksum {
                expected: self.header.checksum,
                actual,
            });
        }
        Ok(())
    }

    /// Copies the payload into an 8-byte-aligned [`OwnedFrame`].
    pub fn to_owned_frame(&self) -> Result<OwnedFrame, CodecError> {
        let len = usize::try_from(self.header.payload_len).unwrap_or(usize::MAX);
        let mut words = vec![0u64; len.div_ceil(8)];
        let dst = bytemuck::cast_slice_mut::<u64, u8>(&mut words);
        let mut written = 0usize;
        for c in self.payload_chunks() {
            let end = written.saturating_add(c.len());
            let Some(d) = dst.get_mut(written..end) else {
                return Err(CodecError::LengthMismatch {
                    declared: len as u64,
                    actual: end as u64,
                });
            };
            d.copy_from_slice(c);
            written = end;
        }
        if written != len {
            return Err(CodecError::LengthMismatch {
                declared: len as u64,
                actual: written as u64,
            });
        }
        Ok(OwnedFrame {
            header: self.header,
            words,
        })
    }
}

/// Splits a Zenoh frame payload into its checked header and the payload slices (no copy).
pub fn split_frame_payload(
    payload: &ZBytes,
    max_payload: usize,
) -> Result<(FrameHeader, Vec<&[u8]>), CodecError> {
    let total = payload.len();
    if total > WIRE_PREFIX_LEN.saturating_add(max_payload) {
        return Err(CodecError::TooLarge {
            what: "frame",
            len: total as u64,
            limit: WIRE_PREFIX_LEN.saturating_add(max_payload) as u64,
        });
    }
    let mut prefix = [0u8; WIRE_PREFIX_LEN];
    let mut filled = 0usize;
    let mut chunks = Vec::new();
    for slice in payload.slices() {
        let mut s = slice;
        if filled < WIRE_PREFIX_LEN {
            let take = (WIRE_PREFIX_LEN - filled).min(s.len());
            prefix[filled..filled + take].copy_from_slice(&s[..take]);
            filled += take;
            s = &s[take..];
        }
        if !s.is_empty() {
            chunks.push(s);
        }
    }
    if filled < WIRE_PREFIX_LEN {
        return Err(CodecError::TooShort { len: total });
    }
    let header = FrameHeader::from_wire_prefix(&prefix, total, max_payload)?;
    Ok((header, chunks))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_frame_handles_any_slicing() {
        use crate::frame::{encode_wire, FrameMeta};
        use crate::MissionId;
        use zenoh::bytes::ZBytes;
        let payload: Vec<u8> = (0..200u32).map(|i| i as u8).collect();
        let h = FrameMeta::bytes(9, MissionId(1), 4, payload.len())
            .unwrap()
            .header(Some(crate::frame::checksum(&payload)))
            .unwrap();
        let wire = encode_wire(&h, &payload).unwrap();
        let z = ZBytes::from(wire.clone());
        let (h2, chunks) = split_frame_payload(&z, 1000).unwrap();
        assert_eq!(h2, h);
        assert_eq!(chunks.concat(), payload);
        assert!(split_frame_payload(&z, 100).is_err());
        let short = ZBytes::from(wire[..50].to_vec());
        assert!(matches!(
            split_frame_payload(&short, 1000),
            Err(CodecError::TooShort { .. })
        ));
    }
}
