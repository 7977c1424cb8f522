//! Typed subscribers ([`ZenohNode::subscriber`], [`TypedSubscriber`]): payloads decoded in
//! the Zenoh callback, counted, and queued for the consumer.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender};
use std::sync::Arc;
use std::time::Duration;

use zenoh::sample::{Sample, SampleKind};
use zenoh::Wait;

use super::{NetError, OnFull, Received, SubscribeOptions, WireFormat, ZenohNode};
use crate::counters::{BadPayloadLog, Counters};
use crate::envelope::Message;

impl ZenohNode {
    /// Declares a typed subscriber on `key` (a key expression; wildcards allowed).
    pub fn subscriber<M: Message + Send + 'static>(
        &self,
        key: &str,
        opts: SubscribeOptions,
    ) -> Result<TypedSubscriber<M>, NetError> {
        let (tx, rx) = mpsc::sync_channel::<(Received<M>, usize)>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let log = Arc::new(BadPayloadLog::default());
        let c = counters.clone();
        let queued = Arc::new(AtomicUsize::new(0));
        let q = queued.clone();
        let max_queued = opts.max_queued_bytes;
        let limits = opts.limits;
        let block = opts.on_full == OnFull::Block;
        let subscriber = self
            .session()
            .declare_subscriber(key.to_string())
            .callback(move |sample: Sample| {
                if sample.kind() != SampleKind::Put {
                    return;
                }
                let payload = sample.payload();
                let bytes = payload.len();
                c.on_received(bytes);
                // the byte budget is taken before decoding (nothing is allocated for a message
                // that would not fit) and given back when the consumer takes it
                // (a blocking subscriber is bounded by its capacity: the sender waits)
                let admitted = if block {
                    q.fetch_add(bytes, Ordering::AcqRel);
                    true
                } else {
                    q.fetch_update(Ordering::AcqRel, Ordering::Acquire, |held| {
                        held.checked_add(bytes).filter(|&n| n <= max_queued)
                    })
                    .is_ok()
                };
                if !admitted {
                    c.on_dropped(1);
                    return;
                }
                let format = WireFormat::of(sample.encoding());
                match format.decode_zbytes::<M>(payload, &limits) {
                    Ok(env) => {
                        let msg = Received {
                            key: sample.key_expr().as_str().to_string(),
                            header: env.header,
                            format,
                            message: env.message,
                        };
                        if !deliver(&tx, (msg, bytes), block, &c) {
                            q.fetch_sub(bytes, Ordering::AcqRel);
                        }
                    }
                    Err(e) => {
                        q.fetch_sub(bytes, Ordering::AcqRel);
                        c.on_malformed();
                        log.log(sample.key_expr().as_str(), payload.len(), &e);
                    }
                }
            })
            .allowed_origin(opts.allowed_origin)
            .wait()
            .map_err(|e| NetError::zenoh("declare subscriber", key, e))?;
        Ok(TypedSubscriber {
            _subscriber: subscriber,
            rx,
            counters,
            key: key.to_string(),
            queued,
        })
    }
}

/// Queues `item` (blocking or not); false when it was dropped (counted).
pub(super) fn deliver<T>(tx: &SyncSender<T>, item: T, block: bool, c: &Counters) -> bool {
    let sent = if block {
        tx.send(item).is_ok()
    } else {
        tx.try_send(item).is_ok()
    };
    if sent {
        c.on_delivered();
    } else {
        c.on_dropped(1);
    }
    sent
}

/// A subscriber of `M` (undeclared when dropped).
pub struct TypedSubscriber<M> {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    rx: Receiver<(Received<M>, usize)>,
    counters: Arc<Counters>,
    key: String,
    /// Wire bytes of the queued messages.
    queued: Arc<AtomicUsize>,
}

impl<M> TypedSubscriber<M> {
    /// Waits up to `timeout` for the next message.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<Received<M>> {
        match self.rx.recv_timeout(timeout) {
            Ok(m) => Some(self.taken(m)),
            Err(RecvTimeoutError::Timeout) | Err(RecvTimeoutError::Disconnected) => None,
        }
    }

    /// The next message if one is queued.
    pub fn try_recv(&self) -> Option<Received<M>> {
        self.rx.try_recv().ok().map(|m| self.taken(m))
    }

    /// Wire bytes of the messages queued now.
    pub fn queued_bytes(&self) -> usize {
        self.queued.load(Ordering::Acquire)
    }

    fn taken(&self, (m, bytes): (Received<M>, usize)) -> Received<M> {
        self.queued.fetch_sub(bytes, Ordering::AcqRel);
        m
    }

    /// Counters of this subscriber.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The key expression it listens on.
    pub fn key(&self) -> &str {
        &self.key
    }
}
