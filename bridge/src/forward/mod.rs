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
//!
//! One job per module: the routes and settings (`config`), the running forwarder
//! (`forwarder`), the direction from Zenoh (`inbound`) and to Zenoh (`outbound`), the counters
//! (`stats`) and the errors (`error`).

mod config;
mod error;
mod forwarder;
mod inbound;
mod outbound;
mod stats;

pub use config::{Direction, ForwarderConfig, Route};
pub use error::ForwardError;
pub use forwarder::Forwarder;
pub use stats::{DirectionCounters, DirectionStats, RouteStats, StatsSource};

pub use crate::frame::FLAG_BRIDGED;
