//! The bridge's own message: its counters, published as JSON on
//! `cellsar/bridge/<instance>/stats` and answered to queries on the same key.

use serde::{Deserialize, Serialize};

use crate::envelope::Message;
use crate::forward::RouteStats;

/// Counters of a running bridge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BridgeStats {
    /// Instance name.
    pub instance: String,
    /// Seconds since the forwarder started.
    pub uptime_s: f64,
    /// One entry per route.
    pub routes: Vec<RouteStats>,
}

impl Message for BridgeStats {
    const KIND: u16 = 0x1001;
    const NAME: &'static str = "bridge.stats";
    const SCHEMA_VERSION: u16 = 1;
}
