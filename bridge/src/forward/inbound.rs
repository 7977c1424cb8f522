//! The direction from Zenoh: each frame heard on a route's data key is checked (header, size,
//! optional CRC) and re-published on the local iceoryx2 service with [`FLAG_BRIDGED`] set,
//! either in the Zenoh callback or from a queue on a thread of its own.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;

use zenoh::sample::{Locality, Sample, SampleKind};
use zenoh::Wait;

use super::forwarder::wait_ready;
use super::stats::{DirectionCounters, RouteCounters};
use super::{ForwardError, Forwarder, ForwarderConfig, Route, FLAG_BRIDGED};
use crate::counters::BadPayloadLog;
use crate::envelope::CodecError;
use crate::iox::{Backpressure, FrameNode, FramePublisher, FramePublisherOptions, IoxEnv};
use crate::net::{split_frame_payload, NetError, ZenohNode};

/// A frame queued for the inbound thread: the index of its route and the Zenoh sample.
type Inbound = (usize, Sample);

/// A publisher of the direction from Zenoh: route index, route, publisher.
type InboundPublisher = (usize, Route, FramePublisher);

/// Sets up the direction from Zenoh for every inbound route of `config`: re-published in the
/// Zenoh callbacks (`inbound_queue == 0`) or queued for the inbound thread.
pub(super) fn start(
    fwd: &mut Forwarder,
    node: &ZenohNode,
    env: &IoxEnv,
    config: &ForwarderConfig,
) -> Result<(), ForwardError> {
    let routes: Vec<(usize, Route)> = config
        .routes
        .iter()
        .enumerate()
        .filter(|(_, r)| r.direction.inbound())
        .map(|(i, r)| (i, r.clone()))
        .collect();
    if routes.is_empty() {
        Ok(())
    } else if config.inbound_queue == 0 {
        start_inline(fwd, node, env, config, &routes)
    } else {
        start_queued(fwd, node, env, config, routes)
    }
}

/// Inline: each Zenoh callback copies its frame into shared memory and publishes it (no
/// hand-off to another thread, so no extra wake-up on the way).
fn start_inline(
    fwd: &mut Forwarder,
    node: &ZenohNode,
    env: &IoxEnv,
    config: &ForwarderConfig,
    routes: &[(usize, Route)],
) -> Result<(), ForwardError> {
    let (inode, pubs) =
        inbound_publishers(env, &config.instance, routes, config.inbound_backpressure)?;
    let inode = Arc::new(inode);
    for (index, route, publisher) in pubs {
        let key = route.key.clone();
        let sink = InlineInbound {
            publisher,
            route,
            counters: fwd.counters.clone(),
            index,
            verify_checksum: config.verify_checksum,
            log: BadPayloadLog::default(),
            _node: inode.clone(),
        };
        fwd.subscribers
            .push(remote_subscriber(node, &key, move |sample| {
                sink.on_sample(&sample)
            })?);
    }
    Ok(())
}

/// Queued: the Zenoh callbacks queue each frame for the inbound thread, which re-publishes it.
fn start_queued(
    fwd: &mut Forwarder,
    node: &ZenohNode,
    env: &IoxEnv,
    config: &ForwarderConfig,
    routes: Vec<(usize, Route)>,
) -> Result<(), ForwardError> {
    let (tx, rx) = mpsc::sync_channel::<Inbound>(config.inbound_queue);
    let (ready_tx, ready_rx) = mpsc::channel();
    let keys: Vec<(usize, String)> = routes.iter().map(|(i, r)| (*i, r.key.clone())).collect();
    let thread = InboundThread {
        env: env.clone(),
        instance: config.instance.clone(),
        routes,
        verify_checksum: config.verify_checksum,
        backpressure: config.inbound_backpressure,
        rx,
        counters: fwd.counters.clone(),
        stop: fwd.stop.clone(),
    };
    let h = std::thread::Builder::new()
        .name("bridge-inbound".into())
        .spawn(move || thread.run(&ready_tx))
        .map_err(|e| ForwardError::Thread {
            thread: "inbound",
            reason: e.to_string(),
        })?;
    fwd.threads.push(("inbound", h));
    wait_ready(&ready_rx, "inbound")?;
    for (i, key) in keys {
        let tx = tx.clone();
        // Blocks when the queue is full: back-pressure to the sender rather than loss (the
        // inbound thread never blocks on iceoryx2).
        fwd.subscribers
            .push(remote_subscriber(node, &key, move |sample| {
                let _ = tx.send((i, sample));
            })?);
    }
    Ok(())
}

/// The thread that re-publishes queued frames from Zenoh, with what it needs.
struct InboundThread {
    env: IoxEnv,
    instance: String,
    routes: Vec<(usize, Route)>,
    verify_checksum: bool,
    backpressure: Backpressure,
    rx: Receiver<Inbound>,
    counters: Arc<Vec<RouteCounters>>,
    stop: Arc<AtomicBool>,
}

impl InboundThread {
    /// Creates the publishers, says on `ready` whether that worked, then re-publishes queued
    /// frames until the stop flag is set or every sender is gone.
    fn run(self, ready: &mpsc::Sender<Result<(), ForwardError>>) -> Result<(), ForwardError> {
        let (_node, pubs) =
            match inbound_publishers(&self.env, &self.instance, &self.routes, self.backpressure) {
                Ok(v) => {
                    let _ = ready.send(Ok(()));
                    v
                }
                Err(e) => {
                    let msg = e.to_string();
                    let _ = ready.send(Err(e));
                    return Err(ForwardError::Thread {
                        thread: "inbound",
                        reason: msg,
                    });
                }
            };
        let log = BadPayloadLog::default();
        while !self.stop.load(Ordering::Relaxed) {
            let (i, sample) = match self.rx.recv_timeout(Duration::from_millis(100)) {
                Ok(v) => v,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => break,
            };
            let Some((_, route, publisher)) = pubs.iter().find(|(j, _, _)| *j == i) else {
                continue;
            };
            let Some(c) = self.counters.get(i) else {
                continue;
            };
            deliver_inbound(
                &sample,
                route,
                publisher,
                &c.inb,
                self.verify_checksum,
                &log,
            );
        }
        Ok(())
    }
}

/// The iceoryx2 node of the direction from Zenoh and a publisher per inbound route.
fn inbound_publishers(
    env: &IoxEnv,
    instance: &str,
    routes: &[(usize, Route)],
    backpressure: Backpressure,
) -> Result<(FrameNode, Vec<InboundPublisher>), ForwardError> {
    let (node, _) = FrameNode::new(env, &format!("bridge-{instance}-in"))?;
    let mut pubs = Vec::with_capacity(routes.len());
    for (i, r) in routes {
        let p = node.publisher(
            &r.service,
            FramePublisherOptions {
                checksum: false,
                backpressure,
            },
        )?;
        pubs.push((*i, r.clone(), p));
    }
    Ok((node, pubs))
}

/// A Zenoh subscriber on `key` that hears only other sessions (so nothing this bridge sends
/// loops back) and calls `on_put` for each put.
fn remote_subscriber(
    node: &ZenohNode,
    key: &str,
    on_put: impl Fn(Sample) + Send + Sync + 'static,
) -> Result<zenoh::pubsub::Subscriber<()>, ForwardError> {
    node.session()
        .declare_subscriber(key.to_owned())
        .callback(move |sample: Sample| {
            if sample.kind() == SampleKind::Put {
                on_put(sample);
            }
        })
        .allowed_origin(Locality::Remote)
        .wait()
        .map_err(|e| ForwardError::from(NetError::zenoh("declare subscriber", key, e)))
}

/// One inbound route delivered in the Zenoh callback (`inbound_queue == 0`). The publisher is
/// declared before the node so that it is dropped first.
struct InlineInbound {
    publisher: FramePublisher,
    route: Route,
    counters: Arc<Vec<RouteCounters>>,
    index: usize,
    verify_checksum: bool,
    log: BadPayloadLog,
    _node: Arc<FrameNode>,
}

impl InlineInbound {
    fn on_sample(&self, sample: &Sample) {
        if let Some(c) = self.counters.get(self.index) {
            deliver_inbound(
                sample,
                &self.route,
                &self.publisher,
                &c.inb,
                self.verify_checksum,
                &self.log,
            );
        }
    }
}

/// Checks one frame from Zenoh (header, size, optional CRC) and re-publishes it on the local
/// service with [`FLAG_BRIDGED`] set: one copy, from Zenoh's buffers into a loaned sample.
fn deliver_inbound(
    sample: &Sample,
    route: &Route,
    publisher: &FramePublisher,
    c: &DirectionCounters,
    verify_checksum: bool,
    log: &BadPayloadLog,
) {
    DirectionCounters::add(&c.received, 1);
    let payload = sample.payload();
    let checked =
        split_frame_payload(payload, route.service.max_payload_bytes).and_then(|(h, chunks)| {
            if verify_checksum && h.has_checksum() {
                let mut hasher = crc32fast::Hasher::new();
                for ch in &chunks {
                    hasher.update(ch);
                }
                let actual = hasher.finalize();
                if actual != h.checksum {
                    return Err(CodecError::Checksum {
                        expected: h.checksum,
                        actual,
                    });
                }
            }
            Ok((h, chunks))
        });
    let (mut header, chunks) = match checked {
        Ok(v) => v,
        Err(e) => {
            DirectionCounters::add(&c.malformed, 1);
            log.log(&route.key, payload.len(), &e);
            return;
        }
    };
    header.flags |= FLAG_BRIDGED;
    match publisher.send_chunks(&header, chunks.iter().copied()) {
        Ok(report) => {
            DirectionCounters::add(&c.forwarded, 1);
            DirectionCounters::add(&c.bytes, header.payload_len);
            DirectionCounters::add(&c.dropped, report.skipped_full);
        }
        Err(e) => {
            DirectionCounters::add(&c.send_errors, 1);
            tracing::warn!(service = %route.service.name, error = %e, "re-publishing a remote frame failed");
        }
    }
}
