//! # cellsar bridge: the transport layer
//!
//! - [`envelope`]: the versioned 48-byte header + bincode 2 body of every message, its JSON
//!   form, and the [`Message`] trait (kind + schema version per type). Decoding is bounded and
//!   never panics.
//! - [`frame`]: bulk frames (IQ pulses) with the `#[repr(C)]` [`FrameHeader`]; raw
//!   little-endian complex f32 samples after the header.
//! - [`net`]: typed Zenoh publishers, subscribers, queryables and queries, frames over Zenoh,
//!   liveliness tokens `cellsar/alive/<role>/<instance>` and liveliness watching.
//! - [`zconfig`]: the `-m/-e/-l/-c/--no-multicast-scouting/--zenoh-max-message-bytes` flags
//!   ([`ZenohArgs`]), with the bound on the messages Zenoh reassembles.
//! - [`zenoh_error`]: Zenoh's errors kept whole as causes ([`ZenohError`]), printed for people.
//! - [`iox`]: zero-copy frame services over iceoryx2 (explicit sizing, event wake-ups,
//!   stale-resource cleanup, isolated roots for tests).
//! - [`forward`]: the iceoryx2 <-> Zenoh forwarder behind the `cellsar-bridge` binary.
//! - [`refusal`]: the typed error reply of a queryable ([`Refusal`]: bad request, infeasible,
//!   internal, busy), decoded by queries into [`NetError::Refused`].
//! - [`counters`], [`seq`]: what every endpoint counts; sequence gaps and duplicates.
//! - [`flags`]: numeric flags (seconds, rates) shared by the binaries, checked once when parsed
//!   ([`flags::Seconds`]).
//!
//! This crate knows no domain type: the pipeline's protocol (`pipeline::protocol`) defines the
//! messages and implements [`Message`] for them.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod counters;
pub mod envelope;
pub mod flags;
pub mod forward;
pub mod frame;
pub mod iox;
pub mod keys;
pub mod net;
pub mod refusal;
pub mod seq;
pub mod stats;
pub mod zconfig;
pub mod zenoh_error;

pub use counters::{CounterSnapshot, Counters};
pub use envelope::{CodecError, DecodeLimits, Envelope, Header, Message, Meta, MissionId};
pub use frame::{FrameHeader, FrameMeta};
pub use iox::{
    Frame, FrameNode, FramePublisher, FramePublisherOptions, FrameServiceSpec, FrameSubscriber,
    IoxArgs, IoxEnv, IoxError,
};
pub use net::{
    FrameSubscribeOptions, IncomingQuery, NetError, OwnedFrame, PendingQuery, PublishOptions,
    QueryOptions, Received, SubscribeOptions, WireFormat, ZenohFrame, ZenohNode,
};
pub use refusal::{Refusal, RefusalKind};
pub use seq::{SeqObservation, SeqTracker};
pub use zconfig::ZenohArgs;
pub use zenoh_error::ZenohError;

/// Re-export of the complex sample type of IQ frames.
pub use num_complex::Complex32;
/// Re-export of the zenoh crate (same version as this crate uses).
pub use zenoh;
