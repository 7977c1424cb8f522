//! Raw frames out to Zenoh ([`ZenohNode::frame_publisher`], [`ZenohFramePublisher`]): one
//! copy into a reused buffer, or none for a payload owned elsewhere.

use std::sync::{Arc, Mutex};

use zenoh::bytes::{Encoding, ZBytes};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::Locality;

use super::sender::{Sender, SenderOptions};
use super::{NetError, ZenohNode};
use crate::counters::Counters;
use crate::frame::{self, FrameHeader, WIRE_PREFIX_LEN};

impl ZenohNode {
    /// Declares a publisher of raw frames on `key` (see [`crate::frame`] for the layout).
    pub fn frame_publisher(
        &self,
        key: &str,
        congestion_control: CongestionControl,
        allowed_destination: Locality,
    ) -> Result<ZenohFramePublisher, NetError> {
        let sender = Sender::declare(
            self,
            key,
            SenderOptions {
                encoding: Encoding::APPLICATION_OCTET_STREAM.with_schema("cellsar/frame/v1"),
                congestion_control,
                priority: Priority::DataLow,
                allowed_destination,
            },
        )?;
        Ok(ZenohFramePublisher {
            sender,
            pool: BufPool::default(),
        })
    }
}

/// Reused send buffers: frames of 32 MiB and more are above glibc's largest mmap threshold,
/// so a fresh buffer per frame would be mmap'ed, page-faulted and zeroed every time (this
/// halved the throughput at 32 MiB). A buffer returns here when Zenoh is done with it.
#[derive(Clone, Debug, Default)]
struct BufPool(Arc<Mutex<Vec<Vec<u8>>>>);

const POOLED_BUFFERS: usize = 4;

impl BufPool {
    fn take(&self, capacity: usize) -> Vec<u8> {
        let mut v = self
            .0
            .lock()
            .ok()
            .and_then(|mut p| p.pop())
            .unwrap_or_default();
        v.clear();
        v.reserve(capacity);
        v
    }
}

/// A pooled buffer handed to Zenoh (as `bytes::Bytes`) without a copy.
struct PooledBuf {
    buf: Vec<u8>,
    pool: BufPool,
}

impl AsRef<[u8]> for PooledBuf {
    fn as_ref(&self) -> &[u8] {
        &self.buf
    }
}

impl Drop for PooledBuf {
    fn drop(&mut self) {
        let buf = std::mem::take(&mut self.buf);
        if let Ok(mut p) = self.pool.0.lock() {
            if p.len() < POOLED_BUFFERS {
                p.push(buf);
            }
        }
    }
}

/// A publisher of raw frames on Zenoh.
pub struct ZenohFramePublisher {
    sender: Sender,
    pool: BufPool,
}

impl ZenohFramePublisher {
    /// Publishes a frame (one copy: prefix + payload into a reused buffer).
    pub fn put(&self, header: &FrameHeader, payload: &[u8]) -> Result<(), NetError> {
        header
            .validate(payload.len(), frame::MAX_FRAME_HARD_LIMIT)
            .map_err(|e| NetError::codec(self.sender.key(), e))?;
        let mut buf = self.pool.take(WIRE_PREFIX_LEN + payload.len());
        buf.extend_from_slice(&header.to_wire_prefix());
        buf.extend_from_slice(payload);
        let len = buf.len();
        let bytes = bytes::Bytes::from_owner(PooledBuf {
            buf,
            pool: self.pool.clone(),
        });
        self.sender.send(ZBytes::from(bytes), len)
    }

    /// Publishes a frame whose payload is owned by `owner` (e.g. an iceoryx2
    /// [`crate::iox::Frame`]) without copying it: Zenoh reads the payload in place while it
    /// sends it, and `owner` is dropped when Zenoh no longer needs it.
    pub fn put_owned<O>(&self, header: &FrameHeader, owner: O) -> Result<(), NetError>
    where
        O: AsRef<[u8]> + Send + 'static,
    {
        let payload_len = owner.as_ref().len();
        header
            .validate(payload_len, frame::MAX_FRAME_HARD_LIMIT)
            .map_err(|e| NetError::codec(self.sender.key(), e))?;
        let mut writer = ZBytes::writer();
        writer.append(ZBytes::from(header.to_wire_prefix().to_vec()));
        writer.append(ZBytes::from(bytes::Bytes::from_owner(owner)));
        let len = WIRE_PREFIX_LEN + payload_len;
        self.sender.send(writer.finish(), len)
    }

    /// Whether a subscriber this publisher may deliver to currently matches its key (with
    /// `Locality::Remote`: a subscriber of another session).
    pub fn has_remote_subscribers(&self) -> bool {
        self.sender.matching().unwrap_or(true)
    }

    /// Publishes an already encoded payload as is (also used to inject malformed payloads in
    /// tests).
    pub fn put_raw(&self, bytes: Vec<u8>) -> Result<(), NetError> {
        let len = bytes.len();
        self.sender.send(ZBytes::from(bytes), len)
    }

    /// Counters of this publisher.
    pub fn counters(&self) -> &Counters {
        self.sender.counters()
    }
}
