//! Typed publishers ([`ZenohNode::publisher`], [`TypedPublisher`]).

use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use zenoh::bytes::ZBytes;

use super::sender::{Sender, SenderOptions};
use super::{NetError, PublishOptions, WireFormat, ZenohNode};
use crate::counters::Counters;
use crate::envelope::{Message, Meta, MissionId};

impl ZenohNode {
    /// Declares a typed publisher on `key`.
    pub fn publisher<M: Message>(
        &self,
        key: &str,
        opts: PublishOptions,
    ) -> Result<TypedPublisher<M>, NetError> {
        let sender = Sender::declare(
            self,
            key,
            SenderOptions {
                encoding: opts.format.encoding::<M>(),
                congestion_control: opts.congestion_control,
                priority: opts.priority,
                allowed_destination: opts.allowed_destination,
            },
        )?;
        Ok(TypedPublisher {
            sender,
            format: opts.format,
            mission_id: opts.mission_id,
            next_seq: AtomicU64::new(opts.first_seq),
            _m: PhantomData,
        })
    }
}

/// A publisher of `M` with an automatic sequence number.
pub struct TypedPublisher<M> {
    sender: Sender,
    format: WireFormat,
    mission_id: MissionId,
    next_seq: AtomicU64,
    _m: PhantomData<fn(&M)>,
}

impl<M: Message> TypedPublisher<M> {
    /// Publishes `msg` with the next sequence number; returns that number.
    pub fn put(&self, msg: &M) -> Result<u64, NetError> {
        let seq = self.next_seq.fetch_add(1, Ordering::Relaxed);
        self.put_with(
            msg,
            Meta {
                mission_id: self.mission_id,
                seq,
                time_unix_ns: 0,
            },
        )?;
        Ok(seq)
    }

    /// Publishes `msg` with explicit header fields (e.g. to re-send with its original
    /// sequence number).
    pub fn put_with(&self, msg: &M, meta: Meta) -> Result<(), NetError> {
        let bytes = self
            .format
            .encode(msg, meta)
            .map_err(|e| NetError::codec(self.sender.key(), e))?;
        let len = bytes.len();
        self.sender.send(ZBytes::from(bytes), len)
    }

    /// Whether a subscriber that this publisher may deliver to matches its key now.
    pub fn has_subscribers(&self) -> bool {
        self.sender.matching().unwrap_or(false)
    }

    /// Waits up to `timeout` for a matching subscriber; returns whether one appeared.
    pub fn wait_for_subscribers(&self, timeout: Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        while !self.has_subscribers() {
            if std::time::Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        true
    }

    /// Counters of this publisher.
    pub fn counters(&self) -> &Counters {
        self.sender.counters()
    }

    /// The key it publishes on.
    pub fn key(&self) -> &str {
        self.sender.key()
    }
}
