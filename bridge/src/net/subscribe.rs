//! Typed subscribers ([`ZenohNode::subscriber`], [`TypedSubscriber`]): payloads decoded in
//! the Zenoh callback, counted, and queued for the consumer.

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
        let (tx, rx) = mpsc::sync_channel::<Received<M>>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let log = Arc::new(BadPayloadLog::default());
        let c = counters.clone();
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
                c.on_received(payload.len());
                let format = WireFormat::of(sample.encoding());
                match format.decode_zbytes::<M>(payload, &limits) {
                    Ok(env) => {
                        let msg = Received {
                            key: sample.key_expr().as_str().to_string(),
                            header: env.header,
                            format,
                            message: env.message,
                        };
                        deliver(&tx, msg, block, &c);
                    }
                    Err(e) => {
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
        })
    }
}

pub(super) fn deliver<T>(tx: &SyncSender<T>, item: T, block: bool, c: &Counters) {
    if block {
        match tx.send(item) {
            Ok(()) => c.on_delivered(),
            Err(_) => c.on_dropped(1),
        }
    } else {
        match tx.try_send(item) {
            Ok(()) => c.on_delivered(),
            Err(_) => c.on_dropped(1),
        }
    }
}

/// A subscriber of `M` (undeclared when dropped).
pub struct TypedSubscriber<M> {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    rx: Receiver<Received<M>>,
    counters: Arc<Counters>,
    key: String,
}

impl<M> TypedSubscriber<M> {
    /// Waits up to `timeout` for the next message.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<Received<M>> {
        match self.rx.recv_timeout(timeout) {
            Ok(m) => Some(m),
            Err(RecvTimeoutError::Timeout) | Err(RecvTimeoutError::Disconnected) => None,
        }
    }

    /// The next message if one is queued.
    pub fn try_recv(&self) -> Option<Received<M>> {
        self.rx.try_recv().ok()
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
