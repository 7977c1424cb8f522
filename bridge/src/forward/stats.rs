//! The forwarder's counters: live per direction ([`DirectionCounters`]), as snapshots
//! ([`DirectionStats`], [`RouteStats`]), and readable from any thread ([`StatsSource`]).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::stats::BridgeStats;

/// Live counters of one direction of one route.
#[derive(Debug, Default)]
pub struct DirectionCounters {
    pub(super) received: AtomicU64,
    pub(super) forwarded: AtomicU64,
    pub(super) malformed: AtomicU64,
    pub(super) missed: AtomicU64,
    pub(super) dropped: AtomicU64,
    pub(super) unmatched: AtomicU64,
    pub(super) send_errors: AtomicU64,
    pub(super) bytes: AtomicU64,
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
    pub(super) fn snapshot(&self) -> DirectionStats {
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
    pub(super) fn add(a: &AtomicU64, n: u64) {
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
pub(super) struct RouteCounters {
    pub(super) out: DirectionCounters,
    pub(super) inb: DirectionCounters,
    pub(super) remote_subscribers: AtomicBool,
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
    pub(super) fn new(
        instance: &str,
        started: Instant,
        routes: Vec<(String, String)>,
        counters: Arc<Vec<RouteCounters>>,
    ) -> Self {
        StatsSource {
            instance: instance.to_string(),
            started,
            routes,
            counters,
        }
    }

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
