//! Typed Zenoh endpoints: a session with its liveliness token, publishers, subscribers,
//! queryables and queries of [`Message`](crate::Message)s, frames over Zenoh, and liveliness
//! watching.
//!
//! All calls are synchronous (zenoh's `Wait`), so the binaries need no async runtime of their
//! own. Receive paths decode in the Zenoh callback, count every payload
//! ([`Counters`](crate::Counters)) and hand good messages to a bounded queue; a full queue
//! either drops (and counts) or blocks the Zenoh receive path, as chosen in
//! [`SubscribeOptions`].
//!
//! One job per module: [`ZenohNode`] opens and closes the session (`node`); typed publishers
//! (`publish`), subscribers (`subscribe`), queryables (`queryable`) and queries (`query`);
//! liveliness (`liveliness`); raw frames out (`frame_publish`) and in (`frame_subscribe`); the
//! publish core both kinds of publisher share (`sender`); the
//! options of all of them (`options`), the wire format of messages (`format`) and the errors
//! (`error`).

mod error;
mod format;
mod frame_publish;
mod frame_subscribe;
mod liveliness;
mod node;
mod options;
mod publish;
mod query;
mod queryable;
mod sender;
mod subscribe;

pub use error::NetError;
pub use format::{Received, WireFormat};
pub use frame_publish::ZenohFramePublisher;
pub use frame_subscribe::{split_frame_payload, OwnedFrame, ZenohFrame, ZenohFrameSubscriber};
pub use liveliness::{
    AliveEvent, LivelinessWatcher, MAX_ALIVE_KEYS, MAX_ALIVE_KEY_BYTES, MAX_QUEUED_EVENTS,
};
pub use node::ZenohNode;
pub use options::{
    FrameSubscribeOptions, OnFull, PublishOptions, QueryOptions, SubscribeOptions,
    DEFAULT_MAX_REPLIES, DEFAULT_MAX_REPLY_BYTES,
};
pub use publish::TypedPublisher;
pub use query::{decode_error_reply, PendingQuery, MAX_ERROR_TEXT_BYTES};
pub use queryable::{refuse_query, IncomingQuery, TypedQueryable};
pub use subscribe::TypedSubscriber;
