//! The sizes of a frame service ([`FrameServiceSpec`]), checked before anything is created.

use iceoryx2::prelude::ServiceName;

use super::IoxError;
use crate::frame;

/// Sizes of one frame service. All processes that open the service must use the same spec
/// (the creator's values are binding; openers are checked against them).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct FrameServiceSpec {
    /// Service name (also the event service name), e.g. `cellsar/<mission>/echo`.
    pub name: String,
    /// Largest frame payload in bytes (the slice length every sample is allocated with).
    pub max_payload_bytes: usize,
    /// Frames kept for late subscribers.
    pub history: usize,
    /// Frames a subscriber can have queued (received, not yet taken).
    pub subscriber_buffer: usize,
    /// Frames a subscriber can hold at once (taken, not yet dropped).
    pub subscriber_max_borrowed: usize,
    /// Frames a publisher can have loaned at once.
    pub publisher_max_loaned: usize,
    /// Subscribers the service admits.
    pub max_subscribers: usize,
    /// Publishers the service admits.
    pub max_publishers: usize,
    /// Nodes (processes or threads with a node) that may open the service.
    pub max_nodes: usize,
}

impl FrameServiceSpec {
    /// A spec with cellsar's defaults: no history, buffer 2, 1 borrowed, 1 loaned,
    /// 4 subscribers, 2 publishers (producer + bridge), 8 nodes.
    pub fn new(name: &str, max_payload_bytes: usize) -> Self {
        FrameServiceSpec {
            name: name.to_string(),
            max_payload_bytes,
            history: 0,
            subscriber_buffer: 2,
            subscriber_max_borrowed: 1,
            publisher_max_loaned: 1,
            max_subscribers: 4,
            max_publishers: 2,
            max_nodes: 8,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), IoxError> {
        let err = |field, reason: String| IoxError::Spec {
            service: self.name.clone(),
            field,
            reason,
        };
        ServiceName::new(&self.name)
            .map_err(|e| err("name", format!("is not a valid service name: {e:?}")))?;
        if self.max_payload_bytes == 0 || self.max_payload_bytes > frame::MAX_FRAME_HARD_LIMIT {
            return Err(err(
                "max_payload_bytes",
                format!(
                    "= {} must be in 1..={}",
                    self.max_payload_bytes,
                    frame::MAX_FRAME_HARD_LIMIT
                ),
            ));
        }
        for (field, v) in [
            ("subscriber_buffer", self.subscriber_buffer),
            ("subscriber_max_borrowed", self.subscriber_max_borrowed),
            ("publisher_max_loaned", self.publisher_max_loaned),
            ("max_subscribers", self.max_subscribers),
            ("max_publishers", self.max_publishers),
            ("max_nodes", self.max_nodes),
        ] {
            if v == 0 || v > 1024 {
                return Err(err(field, format!("= {v} must be in 1..=1024")));
            }
        }
        if self.history > self.subscriber_buffer {
            return Err(err(
                "history",
                format!(
                    "= {} must not exceed subscriber_buffer = {}",
                    self.history, self.subscriber_buffer
                ),
            ));
        }
        Ok(())
    }

    /// Samples each publisher pre-allocates.
    pub fn samples_per_publisher(&self) -> usize {
        self.max_subscribers * (self.subscriber_buffer + self.subscriber_max_borrowed)
            + self.history
            + self.publisher_max_loaned
    }

    /// Approximate shared memory each publisher maps (payload only; the headers add 64 bytes
    /// plus iceoryx2's bookkeeping per sample).
    pub fn shm_bytes_per_publisher(&self) -> usize {
        self.samples_per_publisher()
            .saturating_mul(self.max_payload_bytes.saturating_add(128))
    }
}
