//! A running forwarder ([`Forwarder`]): starts both directions and the routes' liveliness
//! tokens, reads the counters, and stops its threads (on [`Forwarder::stop`] or drop).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::stats::RouteCounters;
use super::{inbound, outbound, ForwardError, ForwarderConfig, Route, StatsSource};
use crate::iox::IoxEnv;
use crate::keys;
use crate::net::{NetError, ZenohNode};
use crate::stats::BridgeStats;

/// How long a forwarding thread may take to set itself up.
const THREAD_READY_TIMEOUT: Duration = Duration::from_secs(30);

/// A forwarding thread: its name and handle.
pub(super) type Thread = (&'static str, JoinHandle<Result<(), ForwardError>>);

/// A running forwarder. Stop it with [`Forwarder::stop`] (also done on drop).
pub struct Forwarder {
    pub(super) stop: Arc<AtomicBool>,
    pub(super) threads: Vec<Thread>,
    pub(super) counters: Arc<Vec<RouteCounters>>,
    routes: Vec<Route>,
    instance: String,
    started: Instant,
    pub(super) subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

impl Forwarder {
    /// Starts forwarding `config.routes` between the iceoryx2 environment `env` and the
    /// Zenoh session of `node`. Returns once both directions are set up; if one cannot be,
    /// whatever was started is stopped again before the error is returned.
    pub fn start(
        node: &ZenohNode,
        env: &IoxEnv,
        config: &ForwarderConfig,
    ) -> Result<Forwarder, ForwardError> {
        config.validate()?;
        let mut forwarder = Forwarder {
            stop: Arc::new(AtomicBool::new(false)),
            threads: Vec::new(),
            counters: Arc::new(
                config
                    .routes
                    .iter()
                    .map(|_| RouteCounters::default())
                    .collect(),
            ),
            routes: config.routes.clone(),
            instance: config.instance.clone(),
            started: Instant::now(),
            subscribers: Vec::new(),
            tokens: Vec::new(),
        };
        if let Err(e) = forwarder.start_routes(node, env, config) {
            // what was started stops again; the error is returned, not also logged
            forwarder.abandon();
            return Err(e);
        }
        forwarder.started = Instant::now();
        Ok(forwarder)
    }

    /// Starts both directions, then declares each route's liveliness token.
    fn start_routes(
        &mut self,
        node: &ZenohNode,
        env: &IoxEnv,
        config: &ForwarderConfig,
    ) -> Result<(), ForwardError> {
        inbound::start(self, node, env, config)?;
        outbound::start(self, node, env, config)?;
        for r in &config.routes {
            let key = keys::bridged(&config.instance, &r.key).map_err(NetError::from)?;
            self.tokens.push(node.declare_token(&key)?);
            tracing::info!(
                service = %r.service.name,
                key = %r.key,
                direction = ?r.direction,
                max_payload_bytes = r.service.max_payload_bytes,
                shm_bytes_per_publisher = r.service.shm_bytes_per_publisher(),
                "route up"
            );
        }
        Ok(())
    }

    /// Stops and joins the threads started so far without reporting how they ended (after
    /// a failed start, whose error is reported instead).
    fn abandon(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        self.subscribers.clear();
        for (_, h) in self.threads.drain(..) {
            let _ = h.join();
        }
    }

    /// Current counters of every route.
    pub fn stats(&self) -> BridgeStats {
        self.stats_source().snapshot()
    }

    /// A cheap, `Send + Sync` handle that reads the counters (e.g. from a Zenoh queryable
    /// callback).
    pub fn stats_source(&self) -> StatsSource {
        StatsSource::new(
            &self.instance,
            self.started,
            self.routes
                .iter()
                .map(|r| (r.service.name.clone(), r.key.clone()))
                .collect(),
            self.counters.clone(),
        )
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
        self.subscribers.clear();
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

/// Waits for a forwarding thread to report that it is set up (or why it is not).
pub(super) fn wait_ready(
    rx: &Receiver<Result<(), ForwardError>>,
    thread: &'static str,
) -> Result<(), ForwardError> {
    match rx.recv_timeout(THREAD_READY_TIMEOUT) {
        Ok(r) => r,
        Err(_) => Err(ForwardError::Thread {
            thread,
            reason: format!("did not start within {} s", THREAD_READY_TIMEOUT.as_secs()),
        }),
    }
}
