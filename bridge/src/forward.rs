//! The iceoryx2 <-> Zenoh forwarder behind `cellsar-bridge`.
//!
//! For every configured route (an iceoryx2 frame service and a Zenoh data key):
//!
//! - **to Zenoh**: a subscriber on the local service; each frame is sent on the data key as
//!   envelope header + frame descriptor + raw payload ([`crate::frame`]);
//! - **from Zenoh**: a subscriber on the data key; each frame is checked (header, size,
//!   optional CRC) and re-published on the local service, with [`FLAG_BRIDGED`] set;
//! - a liveliness token `cellsar/bridged/<instance>/<data key>` while the route is up.
//!
//! Nothing loops: the Zenoh publisher and subscriber use `Locality::Remote` (a bridge never
//! hears itself), and frames carrying [`FLAG_BRIDGED`] are never sent back to Zenoh, so a
//! frame crosses at most one Zenoh hop even with several bridges per host (Zenoh's own routing
//! covers multi-hop). The forwarder is payload-agnostic: it never looks past the frame header.
//!
//! The direction to Zenoh runs on its own thread, waiting on the local services' events. The
//! direction from Zenoh queues each frame for a thread of its own that re-publishes it or,
//! with [`ForwarderConfig::inbound_queue`] `== 0`, re-publishes it in the Zenoh callback.
//! Each direction has its own iceoryx2 node. Every frame is counted once per direction
//! ([`RouteStats`]).

use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use serde::{Deserialize, Serialize};
use zenoh::qos::CongestionControl;
use zenoh::sample::{Locality, Sample, SampleKind};
use zenoh::Wait;

use crate::counters::BadPayloadLog;
use crate::envelope::CodecError;
use crate::iox::{
    Backpressure, FrameNode, FramePublisher, FramePublisherOptions, FrameServiceSpec, IoxEnv,
    IoxError,
};
use crate::keys;
use crate::net::{split_frame_payload, NetError, ZenohFramePublisher, ZenohNode};
use crate::stats::BridgeStats;

pub use crate::frame::FLAG_BRIDGED;

/// Which way a route forwards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
pub enum Direction {
    /// Both ways.
    Both,
    /// Local iceoryx2 service -> Zenoh only.
    Out,
    /// Zenoh -> local iceoryx2 service only.
    In,
}

impl Direction {
    fn outbound(self) -> bool {
        matches!(self, Direction::Both | Direction::Out)
    }
    fn inbound(self) -> bool {
        matches!(self, Direction::Both | Direction::In)
    }
}

/// One forwarded service.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Route {
    /// The iceoryx2 frame service (sizes included).
    pub service: FrameServiceSpec,
    /// The Zenoh data key.
    pub key: String,
    /// Which way.
    pub direction: Direction,
}

impl Route {
    /// Parses `NAME[=KEY][@DIRECTION]` (KEY defaults to NAME, DIRECTION to both) with the
    /// given payload limit.
    pub fn parse(spec: &str, max_payload_bytes: usize) -> Result<Route, ForwardError> {
        let bad = |reason: String| ForwardError::Route {
            route: spec.to_string(),
            reason,
        };
        let (rest, direction) = match spec.rsplit_once('@') {
            Some((r, d)) => {
                let dir = match d {
                    "both" => Direction::Both,
                    "out" => Direction::Out,
                    "in" => Direction::In,
                    other => {
                        return Err(bad(format!("unknown direction {other:?} (both, out, in)")))
                    }
                };
                (r, dir)
            }
            None => (spec, Direction::Both),
        };
        let (name, key) = match rest.split_once('=') {
            Some((n, k)) => (n, k),
            None => (rest, rest),
        };
        keys::literal_key("data key", key).map_err(|e| bad(e.to_string()))?;
        let service = FrameServiceSpec::new(name, max_payload_bytes);
        service.validate().map_err(|e| bad(e.to_string()))?;
        Ok(Route {
            service,
            key: key.to_string(),
            direction,
        })
    }
}

/// Forwarder settings.
#[derive(Clone, Debug)]
pub struct ForwarderConfig {
    /// Instance name (liveliness and stats keys).
    pub instance: String,
    /// The routes.
    pub routes: Vec<Route>,
    /// Verify the CRC of frames coming from Zenoh.
    pub verify_checksum: bool,
    /// Congestion control of the Zenoh publishers (block: lossless, back-pressure; drop: never
    /// stall on a slow network, count nothing lost locally).
    pub congestion_control: CongestionControl,
    /// Frames queued between the Zenoh callbacks and an inbound thread that re-publishes them;
    /// `0` re-publishes in the Zenoh callback itself, so a frame reaches the local subscribers
    /// without waking another thread first (Zenoh's receive path then waits for the copy into
    /// shared memory and, with [`Backpressure::Block`], for a full local subscriber). A queue
    /// (the binary's default is 4) decouples the two.
    pub inbound_queue: usize,
    /// What re-publishing a remote frame does when a local subscriber's buffer is full:
    /// `Discard` (default: skip and count, a frozen local consumer never stalls the bridge) or
    /// `Block` (lossless: wait, back-pressuring Zenoh and the remote sender).
    pub inbound_backpressure: Backpressure,
}

impl ForwarderConfig {
    /// Checks the configuration.
    pub fn validate(&self) -> Result<(), ForwardError> {
        keys::chunk("instance", &self.instance).map_err(|e| ForwardError::Route {
            route: "--instance".into(),
            reason: e.to_string(),
        })?;
        if self.routes.is_empty() {
            return Err(ForwardError::Route {
                route: "--service".into(),
                reason: "no route configured".into(),
            });
        }
        let mut keys_seen = HashSet::new();
        let mut names_seen = HashSet::new();
        for r in &self.routes {
            if !keys_seen.insert(&r.key) || !names_seen.insert(&r.service.name) {
                return Err(ForwardError::Route {
                    route: format!("{}={}", r.service.name, r.key),
                    reason: "service or key configured twice".into(),
                });
            }
            r.service.validate().map_err(ForwardError::Iox)?;
        }
        Ok(())
    }
}

/// Errors of the forwarder.
#[derive(Debug, thiserror::Error)]
pub enum ForwardError {
    /// A route specification is invalid.
    #[error("invalid route {route:?}: {reason}")]
    Route {
        /// The route as given.
        route: String,
        /// Why.
        reason: String,
    },
    /// iceoryx2 failed.
    #[error(transparent)]
    Iox(#[from] IoxError),
    /// Zenoh failed.
    #[error(transparent)]
    Net(#[from] NetError),
    /// A forwarding thread failed or panicked.
    #[error("forwarder thread {thread} failed: {reason}")]
    Thread {
        /// Which thread.
        thread: &'static str,
        /// Why.
        reason: String,
    },
}

/// Live counters of one direction of one route.
#[derive(Debug, Default)]
pub struct DirectionCounters {
    received: AtomicU64,
    forwarded: AtomicU64,
    malformed: AtomicU64,
    missed: AtomicU64,
    dropped: AtomicU64,
    unmatched: AtomicU64,
    send_errors: AtomicU64,
    bytes: AtomicU64,
}

/// Counters of one direction of one route.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct DirectionStats {
    /// Frames that arrived at the bridge on this side.
    pub received: u64,
    /// Frames forwarded to the other side.
    pub forwarded: u64,
    /// Frames rejected (bad header, size or checksum).
    pub malformed: u64,
    /// Frames the bridge never saw (gaps in sequence numbers; to-Zenoh side only).
    pub missed: u64,
    /// Local deliveries skipped because a subscriber's buffer was full (from-Zenoh side).
    pub dropped: u64,
    /// Frames not sent because no remote subscriber matched (to-Zenoh side).
    pub unmatched: u64,
    /// Sends that failed.
    pub send_errors: u64,
    /// Payload bytes forwarded.
    pub bytes: u64,
}

impl DirectionCounters {
    fn snapshot(&self) -> DirectionStats {
        let l = |a: &AtomicU64| a.load(Ordering::Relaxed);
        DirectionStats {
            received: l(&self.received),
            forwarded: l(&self.forwarded),
            malformed: l(&self.malformed),
            missed: l(&self.missed),
            dropped: l(&self.dropped),
            unmatched: l(&self.unmatched),
            send_errors: l(&self.send_errors),
            bytes: l(&self.bytes),
        }
    }
    fn add(a: &AtomicU64, n: u64) {
        a.fetch_add(n, Ordering::Relaxed);
    }
}

/// Counters of one route.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RouteStats {
    /// iceoryx2 service name.
    pub service: String,
    /// Zenoh data key.
    pub key: String,
    /// Whether a remote subscriber (another bridge, a Zenoh frame subscriber) matches the data
    /// key, as last seen by the to-Zenoh side (refreshed at least every 100 ms; always false
    /// for in-only routes).
    pub remote_subscribers: bool,
    /// Local service -> Zenoh.
    pub to_zenoh: DirectionStats,
    /// Zenoh -> local service.
    pub from_zenoh: DirectionStats,
}

#[derive(Debug, Default)]
struct RouteCounters {
    out: DirectionCounters,
    inb: DirectionCounters,
    remote_subscribers: AtomicBool,
}

/// Reads a forwarder's counters from any thread.
#[derive(Clone, Debug)]
pub struct StatsSource {
    instance: String,
    started: Instant,
    routes: Vec<(String, String)>,
    counters: Arc<Vec<RouteCounters>>,
}

impl StatsSource {
    /// Current counters of every route.
    pub fn snapshot(&self) -> BridgeStats {
        BridgeStats {
            instance: self.instance.clone(),
            uptime_s: self.started.elapsed().as_secs_f64(),
            routes: self
                .routes
                .iter()
                .zip(self.counters.iter())
                .map(|((service, key), c)| RouteStats {
                    service: service.clone(),
                    key: key.clone(),
                    remote_subscribers: c.remote_subscribers.load(Ordering::Relaxed),
                    to_zenoh: c.out.snapshot(),
                    from_zenoh: c.inb.snapshot(),
                })
                .collect(),
        }
    }
}

/// A running forwarder. Stop it with [`Forwarder::stop`] (also done on drop).
pub struct Forwarder {
    stop: Arc<AtomicBool>,
    threads: Vec<(&'static str, JoinHandle<Result<(), ForwardError>>)>,
    counters: Arc<Vec<RouteCounters>>,
    routes: Vec<Route>,
    instance: String,
    started: Instant,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

type Inbound = (usize, Sample);

impl Forwarder {
    /// Starts forwarding `config.routes` between the iceoryx2 environment `env` and the
    /// Zenoh session of `node`. Returns once both directions are set up.
    pub fn start(
        node: &ZenohNode,
        env: &IoxEnv,
        config: &ForwarderConfig,
    ) -> Result<Forwarder, ForwardError> {
        config.validate()?;
        let stop = Arc::new(AtomicBool::new(false));
        let counters: Arc<Vec<RouteCounters>> = Arc::new(
            config
                .routes
                .iter()
                .map(|_| RouteCounters::default())
                .collect(),
        );
        let mut threads = Vec::new();
        let mut subscribers = Vec::new();
        let mut tokens = Vec::new();

        // From Zenoh: re-published in the callbacks (inline) or queued for the inbound thread.
        let (ready_tx, ready_rx) = mpsc::channel::<Result<(), ForwardError>>();
        let inbound_routes: Vec<(usize, Route)> = config
            .routes
            .iter()
            .enumerate()
            .filter(|(_, r)| r.direction.inbound())
            .map(|(i, r)| (i, r.clone()))
            .collect();
        if !inbound_routes.is_empty() && config.inbound_queue == 0 {
            // Inline: each Zenoh callback copies its frame into shared memory and publishes it
            // (no hand-off to another thread, so no extra wake-up on the way).
            let (inode, pubs) = inbound_publishers(
                env,
                &config.instance,
                &inbound_routes,
                config.inbound_backpressure,
            )?;
            let inode = Arc::new(inode);
            for (index, route, publisher) in pubs {
                let key = route.key.clone();
                let sink = InlineInbound {
                    publisher,
                    route,
                    counters: counters.clone(),
                    index,
                    verify_checksum: config.verify_checksum,
                    log: BadPayloadLog::default(),
                    _node: inode.clone(),
                };
                subscribers.push(remote_subscriber(node, &key, move |sample| {
                    sink.on_sample(&sample)
                })?);
            }
        } else if !inbound_routes.is_empty() {
            let (tx, rx) = mpsc::sync_channel::<Inbound>(config.inbound_queue);
            let env_in = env.clone();
            let c = counters.clone();
            let s = stop.clone();
            let instance = config.instance.clone();
            let verify = (config.verify_checksum, config.inbound_backpressure);
            let routes = inbound_routes.clone();
            let ready = ready_tx.clone();
            let h = std::thread::Builder::new()
                .name("bridge-inbound".into())
                .spawn(move || {
                    inbound_thread(&env_in, &instance, &routes, verify, rx, &c, &s, ready)
                })
                .map_err(|e| ForwardError::Thread {
                    thread: "inbound",
                    reason: e.to_string(),
                })?;
            threads.push(("inbound", h));
            wait_ready(&ready_rx, "inbound")?;
            for (i, r) in &inbound_routes {
                let tx = tx.clone();
                let i = *i;
                // Blocks when the queue is full: back-pressure to the sender rather than loss
                // (the inbound thread never blocks on iceoryx2).
                subscribers.push(remote_subscriber(node, &r.key, move |sample| {
                    let _ = tx.send((i, sample));
                })?);
            }
        }

        // To Zenoh.
        let outbound: Vec<(usize, Route, ZenohFramePublisher)> = config
            .routes
            .iter()
            .enumerate()
            .filter(|(_, r)| r.direction.outbound())
            .map(|(i, r)| {
                node.frame_publisher(&r.key, config.congestion_control, Locality::Remote)
                    .map(|p| (i, r.clone(), p))
            })
            .collect::<Result<_, _>>()?;
        if !outbound.is_empty() {
            let env_out = env.clone();
            let c = counters.clone();
            let s = stop.clone();
            let instance = config.instance.clone();
            let ready = ready_tx.clone();
            let h = std::thread::Builder::new()
                .name("bridge-outbound".into())
                .spawn(move || outbound_thread(&env_out, &instance, outbound, &c, &s, ready))
                .map_err(|e| ForwardError::Thread {
                    thread: "outbound",
                    reason: e.to_string(),
                })?;
            threads.push(("outbound", h));
            wait_ready(&ready_rx, "outbound")?;
        }

        for r in &config.routes {
            let key = keys::bridged(&config.instance, &r.key).map_err(NetError::from)?;
            tokens.push(node.declare_token(&key)?);
            tracing::info!(
                service = %r.service.name,
                key = %r.key,
                direction = ?r.direction,
                max_payload_bytes = r.service.max_payload_bytes,
                shm_bytes_per_publisher = r.service.shm_bytes_per_publisher(),
                "route up"
            );
        }

        Ok(Forwarder {
            stop,
            threads,
            counters,
            routes: config.routes.clone(),
            instance: config.instance.clone(),
            started: Instant::now(),
            _subscribers: subscribers,
            _tokens: tokens,
        })
    }

    /// Current counters of every route.
    pub fn stats(&self) -> BridgeStats {
        self.stats_source().snapshot()
    }

    /// A cheap, `Send + Sync` handle that reads the counters (e.g. from a Zenoh queryable
    /// callback).
    pub fn stats_source(&self) -> StatsSource {
        StatsSource {
            instance: self.instance.clone(),
            started: self.started,
            routes: self
                .routes
                .iter()
                .map(|r| (r.service.name.clone(), r.key.clone()))
                .collect(),
            counters: self.counters.clone(),
        }
    }

    /// Whether every forwarding thread is still running.
    pub fn is_running(&self) -> bool {
        self.threads.iter().all(|(_, h)| !h.is_finished())
    }

    /// Stops both directions, waits for the threads and returns the final counters.
    pub fn stop(mut self) -> Result<BridgeStats, ForwardError> {
        self.stop_threads()?;
        Ok(self.stats())
    }

    fn stop_threads(&mut self) -> Result<(), ForwardError> {
        self.stop.store(true, Ordering::SeqCst);
        // Undeclare the Zenoh subscribers first so no callback waits on a dead queue.
        self._subscribers.clear();
        let mut first_err = None;
        for (name, h) in self.threads.drain(..) {
            let r = match h.join() {
                Ok(r) => r,
                Err(_) => Err(ForwardError::Thread {
                    thread: name,
                    reason: "panicked".into(),
                }),
            };
            if let Err(e) = r {
                tracing::error!(thread = name, error = %e, "forwarder thread failed");
                first_err.get_or_insert(e);
            }
        }
        first_err.map_or(Ok(()), Err)
    }
}

impl Drop for Forwarder {
    fn drop(&mut self) {
        let _ = self.stop_threads();
    }
}

fn wait_ready(
    rx: &Receiver<Result<(), ForwardError>>,
    thread: &'static str,
) -> Result<(), ForwardError> {
    match rx.recv_timeout(Duration::from_secs(30)) {
        Ok(r) => r,
        Err(_) => Err(ForwardError::Thread {
            thread,
            reason: "did not start within 30 s".into(),
        }),
    }
}

#[allow(clippy::too_many_arguments)]
fn inbound_thread(
    env: &IoxEnv,
    instance: &str,
    routes: &[(usize, Route)],
    (verify_checksum, backpressure): (bool, Backpressure),
    rx: Receiver<Inbound>,
    counters: &[RouteCounters],
    stop: &AtomicBool,
    ready: mpsc::Sender<Result<(), ForwardError>>,
) -> Result<(), ForwardError> {
    let (_node, pubs) = match inbound_publishers(env, instance, routes, backpressure) {
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
    while !stop.load(Ordering::Relaxed) {
        let (i, sample) = match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(v) => v,
            Err(RecvTimeoutError::Timeout) => continue,
            Err(RecvTimeoutError::Disconnected) => break,
        };
        let Some((_, route, publisher)) = pubs.iter().find(|(j, _, _)| *j == i) else {
            continue;
        };
        deliver_inbound(
            &sample,
            route,
            publisher,
            &counters[i].inb,
            verify_checksum,
            &log,
        );
    }
    Ok(())
}

/// A publisher of the direction from Zenoh: route index, route, publisher.
type InboundPublisher = (usize, Route, FramePublisher);

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
        .map_err(|e| {
            ForwardError::from(NetError::Zenoh {
                op: "declare subscriber",
                key: key.to_owned(),
                reason: e.to_string(),
            })
        })
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

fn outbound_thread(
    env: &IoxEnv,
    instance: &str,
    routes: Vec<(usize, Route, ZenohFramePublisher)>,
    counters: &[RouteCounters],
    stop: &AtomicBool,
    ready: mpsc::Sender<Result<(), ForwardError>>,
) -> Result<(), ForwardError> {
    let setup = || -> Result<_, ForwardError> {
        let (node, _) = FrameNode::new(env, &format!("bridge-{instance}-out"))?;
        let mut subs = Vec::new();
        for (i, r, p) in routes {
            let s = node.subscriber(&r.service)?;
            subs.push((i, r, p, s));
        }
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<crate::iox::IoxService>()
            .map_err(|e| IoxError::Iceoryx {
                step: "create waitset",
                service: instance.to_string(),
                reason: format!("{e:?}"),
            })?;
        Ok((node, subs, waitset))
    };
    let (_node, subs, waitset) = match setup() {
        Ok(v) => v,
        Err(e) => {
            let msg = e.to_string();
            let _ = ready.send(Err(e));
            return Err(ForwardError::Thread {
                thread: "outbound",
                reason: msg,
            });
        }
    };
    let mut guards = Vec::new();
    for (_, r, _, s) in &subs {
        match waitset.attach_notification(s.listener()) {
            Ok(g) => guards.push(g),
            Err(e) => {
                let err = ForwardError::Iox(IoxError::Iceoryx {
                    step: "attach listener to waitset",
                    service: r.service.name.clone(),
                    reason: format!("{e:?}"),
                });
                let msg = err.to_string();
                let _ = ready.send(Err(err));
                return Err(ForwardError::Thread {
                    thread: "outbound",
                    reason: msg,
                });
            }
        }
    }
    let _ = ready.send(Ok(()));
    let log = BadPayloadLog::default();
    let mut missed_seen = vec![0u64; subs.len()];
    let mut malformed_seen = vec![0u64; subs.len()];
    while !stop.load(Ordering::Relaxed) {
        if let Err(e) = waitset.wait_and_process_once_with_timeout(
            |_| CallbackProgression::Continue,
            Duration::from_millis(100),
        ) {
            tracing::warn!(error = ?e, "waitset wait failed");
            std::thread::sleep(Duration::from_millis(10));
        }
        for (k, (i, route, zpub, sub)) in subs.iter().enumerate() {
            let c = &counters[*i].out;
            counters[*i]
                .remote_subscribers
                .store(zpub.has_remote_subscribers(), Ordering::Relaxed);
            if let Err(e) = sub.clear_notifications() {
                tracing::warn!(service = %route.service.name, error = %e, "clearing notifications failed");
            }
            loop {
                let frame = match sub.receive() {
                    Ok(Some(f)) => f,
                    Ok(None) => break,
                    Err(e) => {
                        tracing::warn!(service = %route.service.name, error = %e, "receive failed");
                        break;
                    }
                };
                let header = *frame.header();
                if header.flags & FLAG_BRIDGED != 0 {
                    continue; // came from Zenoh: never send it back
                }
                DirectionCounters::add(&c.received, 1);
                if !zpub.has_remote_subscribers() {
                    DirectionCounters::add(&c.unmatched, 1);
                    continue;
                }
                let len = frame.payload().len();
                // zero copy: Zenoh reads the payload straight from shared memory while it
                // fragments it; the sample goes back to the producer when `put` returns
                match zpub.put_owned(&header, frame) {
                    Ok(()) => {
                        DirectionCounters::add(&c.forwarded, 1);
                        DirectionCounters::add(&c.bytes, header.payload_len);
                    }
                    Err(e) => {
                        DirectionCounters::add(&c.send_errors, 1);
                        log.log(&route.key, len, &e);
                    }
                }
            }
            // Malformed local frames and sequence gaps are counted by the subscriber.
            let m = sub.counters().snapshot().malformed;
            DirectionCounters::add(&c.malformed, m - malformed_seen[k]);
            malformed_seen[k] = m;
            let missed = sub.missed();
            DirectionCounters::add(&c.missed, missed - missed_seen[k]);
            missed_seen[k] = missed;
        }
    }
    drop(guards);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_routes() {
        let r = Route::parse("cellsar/m/echo", 1024).unwrap();
        assert_eq!(r.key, "cellsar/m/echo");
        assert_eq!(r.direction, Direction::Both);
        let r = Route::parse("svc=cellsar/x@out", 1024).unwrap();
        assert_eq!(r.service.name, "svc");
        assert_eq!(r.key, "cellsar/x");
        assert_eq!(r.direction, Direction::Out);
        assert!(Route::parse("svc=a/*", 1024).is_err());
        assert!(Route::parse("svc@sideways", 1024)
            .unwrap_err()
            .to_string()
            .contains("sideways"));
        assert!(Route::parse("svc", 0).is_err());
    }

    #[test]
    fn config_rejects_duplicates() {
        let r = Route::parse("a=k", 16).unwrap();
        let c = ForwarderConfig {
            instance: "b".into(),
            routes: vec![r.clone(), r],
            verify_checksum: true,
            congestion_control: CongestionControl::Block,
            inbound_queue: 4,
            inbound_backpressure: Backpressure::Discard,
        };
        assert!(c.validate().unwrap_err().to_string().contains("twice"));
    }

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
