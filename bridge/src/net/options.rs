//! Options of the typed endpoints and frame subscribers, with their defaults.

use std::time::Duration;

use zenoh::qos::{CongestionControl, Priority};
use zenoh::query::QueryTarget;
use zenoh::sample::Locality;

use super::WireFormat;
use crate::envelope::{DecodeLimits, Meta, MissionId};
use crate::frame;

/// What a receive queue does when it is full.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OnFull {
    /// Drop the new message and count it (the Zenoh session never waits on the consumer).
    #[default]
    Drop,
    /// Block the Zenoh receive path until there is room (back-pressure to the sender; use
    /// only where losing a message is worse than stalling this session's reception).
    Block,
}

/// Options of a typed publisher.
#[derive(Clone, Copy, Debug)]
pub struct PublishOptions {
    /// Body encoding.
    pub format: WireFormat,
    /// Mission id written into every header.
    pub mission_id: MissionId,
    /// Sequence number of the first message (then +1 per message).
    pub first_seq: u64,
    /// Zenoh congestion control (default: block, i.e. reliable).
    pub congestion_control: CongestionControl,
    /// Zenoh priority.
    pub priority: Priority,
    /// Who may receive (default: any).
    pub allowed_destination: Locality,
}

impl Default for PublishOptions {
    fn default() -> Self {
        PublishOptions {
            format: WireFormat::Bincode,
            mission_id: MissionId::default(),
            first_seq: 0,
            congestion_control: CongestionControl::Block,
            priority: Priority::Data,
            allowed_destination: Locality::Any,
        }
    }
}

impl PublishOptions {
    /// Default options in JSON format.
    pub fn json() -> Self {
        PublishOptions {
            format: WireFormat::Json,
            ..Default::default()
        }
    }
}

/// Options of a typed subscriber or queryable.
#[derive(Clone, Copy, Debug)]
pub struct SubscribeOptions {
    /// Queue length between the Zenoh callback and the consumer.
    pub capacity: usize,
    /// What a full queue does.
    pub on_full: OnFull,
    /// Decoding limits.
    pub limits: DecodeLimits,
    /// Which publishers are heard (default: any).
    pub allowed_origin: Locality,
    /// Wire bytes the queue holds at most (of a typed subscriber; counted as received
    /// payload bytes): a message that would go over is dropped as if the queue were full, so
    /// that `capacity` messages of the largest decodable size cannot pile up unread.
    pub max_queued_bytes: usize,
}

/// The default [`SubscribeOptions::max_queued_bytes`]: 256 MiB.
pub const DEFAULT_MAX_QUEUED_BYTES: usize = 256 << 20;

impl Default for SubscribeOptions {
    fn default() -> Self {
        SubscribeOptions {
            capacity: 256,
            on_full: OnFull::Drop,
            limits: DecodeLimits::default(),
            allowed_origin: Locality::Any,
            max_queued_bytes: DEFAULT_MAX_QUEUED_BYTES,
        }
    }
}

/// Options of a query.
#[derive(Clone, Copy, Debug)]
pub struct QueryOptions {
    /// Request encoding (replies come in the same format from cellsar queryables).
    pub format: WireFormat,
    /// Header fields of the request.
    pub meta: Meta,
    /// How long to wait for replies.
    pub timeout: Duration,
    /// Which queryables are asked.
    pub target: QueryTarget,
    /// Limits for decoding replies.
    pub limits: DecodeLimits,
    /// Most replies [`ZenohNode::query`](super::ZenohNode::query) collects (good or not);
    /// the replies past it are not read.
    pub max_replies: usize,
    /// Most payload bytes [`ZenohNode::query`](super::ZenohNode::query) collects, all
    /// replies together; the reply that would go past it and those after it are not read.
    pub max_reply_bytes: usize,
}

/// Default of [`QueryOptions::max_replies`].
pub const DEFAULT_MAX_REPLIES: usize = 1024;

/// Default of [`QueryOptions::max_reply_bytes`] (256 MiB: four replies of the largest body).
pub const DEFAULT_MAX_REPLY_BYTES: usize = 256 << 20;

impl Default for QueryOptions {
    fn default() -> Self {
        QueryOptions {
            format: WireFormat::Bincode,
            meta: Meta::default(),
            timeout: Duration::from_secs(10),
            target: QueryTarget::BestMatching,
            limits: DecodeLimits::default(),
            max_replies: DEFAULT_MAX_REPLIES,
            max_reply_bytes: DEFAULT_MAX_REPLY_BYTES,
        }
    }
}

/// Options of a frame subscriber.
#[derive(Clone, Copy, Debug)]
pub struct FrameSubscribeOptions {
    /// Queue length (frames).
    pub capacity: usize,
    /// What a full queue does.
    pub on_full: OnFull,
    /// Largest accepted payload (samples) in bytes.
    pub max_payload_bytes: usize,
    /// Verify the CRC of each frame.
    pub verify_checksum: bool,
    /// Which publishers are heard.
    pub allowed_origin: Locality,
}

impl Default for FrameSubscribeOptions {
    fn default() -> Self {
        FrameSubscribeOptions {
            capacity: 8,
            on_full: OnFull::Drop,
            max_payload_bytes: frame::DEFAULT_MAX_FRAME_BYTES,
            verify_checksum: true,
            allowed_origin: Locality::Any,
        }
    }
}
