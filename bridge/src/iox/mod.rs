//! Zero-copy frames over iceoryx2 0.10 on one host.
//!
//! A *frame service* is an iceoryx2 publish-subscribe service of `[u8]` slices with the
//! `#[repr(C)]` [`FrameHeader`] as user header, plus an event service of the same name that
//! publishers notify after each send, so subscribers sleep instead of polling.
//!
//! Every service is sized explicitly by a [`FrameServiceSpec`]. iceoryx2 pre-allocates, per
//! publisher, `max_subscribers * (buffer + max_borrowed) + history + max_loaned` samples of
//! `max_payload_bytes`; the defaults (8 subscribers, buffer 2, 2 borrowed, 2 loaned) would pin
//! 34 samples, about 1.1 GB of `/dev/shm` per publisher at 32 MB frames. The default spec here
//! needs 4 * (2 + 1) + 0 + 1 = 13 samples (416 MB at 32 MB); size it to the real fan-out.
//!
//! A full subscriber buffer never blocks a publisher: delivery to that subscriber is skipped
//! and counted ([`Counters::snapshot`](crate::counters::Counters::snapshot)`.dropped` of the publisher), and the subscriber sees
//! the gap in the sequence numbers (`missed`).
//!
//! Stale resources of dead processes are removed when a [`FrameNode`] is created (and again
//! whenever a service is opened). [`IoxEnv::isolated`] gives tests their own root directory
//! and shared-memory prefix so they can run in parallel.

use iceoryx2::prelude::ipc_threadsafe;
use iceoryx2::service::port_factory::event as event_factory;
use iceoryx2::service::port_factory::publish_subscribe as ps_factory;

use crate::frame::FrameHeader;

mod env;
mod error;
mod node;
mod publisher;
mod spec;
mod subscriber;

pub use env::{init_iceoryx_logging, IoxArgs, IoxEnv};
pub use error::IoxError;
pub use node::{CleanupReport, FrameNode};
pub use publisher::{Backpressure, FramePublisher, FramePublisherOptions, SendReport};
pub use spec::FrameServiceSpec;
pub use subscriber::{Frame, FrameSubscriber};

/// The iceoryx2 service type of every cellsar port: the IPC service with mutex-protected
/// ports, so nodes, publishers, subscribers and received frames are `Send` (usable from worker
/// threads, and a received frame can be handed to Zenoh without a copy). It uses the same
/// shared-memory resources as `ipc::Service` and interoperates with it.
pub type IoxService = ipc_threadsafe::Service;

type FrameService = ps_factory::PortFactory<IoxService, [u8], FrameHeader>;
type EventService = event_factory::PortFactory<IoxService>;
