//! What to forward: routes ([`Route`], parsed from `NAME[=KEY][@DIRECTION]`), their
//! [`Direction`], and the forwarder's settings ([`ForwarderConfig`]).

use std::collections::HashSet;

use serde::{Deserialize, Serialize};
use zenoh::qos::CongestionControl;

use super::ForwardError;
use crate::iox::{Backpressure, FrameServiceSpec};
use crate::keys;

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
    pub(super) fn outbound(self) -> bool {
        matches!(self, Direction::Both | Direction::Out)
    }
    pub(super) fn inbound(self) -> bool {
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
                let dir = <Direction as clap::ValueEnum>::from_str(d, false)
                    .map_err(|_| bad(format!("unknown direction {d:?} (both, out, in)")))?;
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
}
