//! The core that every publisher shares ([`Sender`]): a Zenoh publisher declared on one key,
//! a put that counts what it sends and fails naming the key, and the matching status.

use std::sync::Arc;

use zenoh::bytes::{Encoding, ZBytes};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::Locality;
use zenoh::Wait;

use super::{NetError, ZenohNode};
use crate::counters::Counters;

/// How a [`Sender`] is declared.
pub(super) struct SenderOptions {
    /// The payloads' encoding.
    pub encoding: Encoding,
    /// Congestion control of the puts.
    pub congestion_control: CongestionControl,
    /// Priority of the puts.
    pub priority: Priority,
    /// Which subscribers the puts may reach.
    pub allowed_destination: Locality,
}

/// A publisher on one key with its counters.
pub(super) struct Sender {
    publisher: zenoh::pubsub::Publisher<'static>,
    key: String,
    counters: Arc<Counters>,
}

impl Sender {
    /// Declares the publisher on `key` in `node`'s session.
    pub(super) fn declare(
        node: &ZenohNode,
        key: &str,
        opts: SenderOptions,
    ) -> Result<Self, NetError> {
        let publisher = node
            .session()
            .declare_publisher(key.to_string())
            .encoding(opts.encoding)
            .congestion_control(opts.congestion_control)
            .priority(opts.priority)
            .allowed_destination(opts.allowed_destination)
            .wait()
            .map_err(|e| NetError::zenoh("declare publisher", key, e))?;
        Ok(Self {
            publisher,
            key: key.to_string(),
            counters: Arc::new(Counters::default()),
        })
    }

    /// Puts `payload` (`len` bytes on the wire), counting it as sent or as a send error.
    pub(super) fn send(&self, payload: ZBytes, len: usize) -> Result<(), NetError> {
        match self.publisher.put(payload).wait() {
            Ok(()) => {
                self.counters.on_sent(len);
                Ok(())
            }
            Err(e) => {
                self.counters.on_send_error();
                Err(NetError::zenoh("put", &self.key, e))
            }
        }
    }

    /// Whether a subscriber this publisher may deliver to matches its key now; `None` when
    /// Zenoh cannot tell.
    pub(super) fn matching(&self) -> Option<bool> {
        self.publisher
            .matching_status()
            .wait()
            .ok()
            .map(|m| m.matching())
    }

    /// The key it publishes on.
    pub(super) fn key(&self) -> &str {
        &self.key
    }

    /// Its counters.
    pub(super) fn counters(&self) -> &Counters {
        &self.counters
    }
}
