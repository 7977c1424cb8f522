//! Typed queryables ([`ZenohNode::queryable`], [`TypedQueryable`], [`IncomingQuery`]) and
//! typed refusals of a query ([`refuse_query`]).

use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::Duration;

use zenoh::query::Query;
use zenoh::Wait;

use super::{NetError, OnFull, SubscribeOptions, WireFormat, ZenohNode};
use crate::counters::{BadPayloadLog, Counters};
use crate::envelope::{DecodeLimits, Header, Message, Meta};
use crate::refusal::{Refusal, RefusalKind};

impl ZenohNode {
    /// Declares a typed queryable on `key`; requests are decoded in the Zenoh callback and
    /// queued, and the owner answers them with [`IncomingQuery::reply`] from any thread.
    pub fn queryable<Req: Message + Send + 'static>(
        &self,
        key: &str,
        opts: SubscribeOptions,
    ) -> Result<TypedQueryable<Req>, NetError> {
        let (tx, rx) = mpsc::sync_channel::<IncomingQuery<Req>>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let handler = RequestHandler {
            tx,
            counters: counters.clone(),
            log: BadPayloadLog::default(),
            limits: opts.limits,
            block: opts.on_full == OnFull::Block,
        };
        let queryable = self
            .session()
            .declare_queryable(key.to_string())
            .callback(move |query: Query| handler.on_query(query))
            .wait()
            .map_err(|e| NetError::zenoh("declare queryable", key, e))?;
        Ok(TypedQueryable {
            _queryable: queryable,
            rx,
            counters,
            key: key.to_string(),
        })
    }
}

/// What a typed queryable does with each query, in the Zenoh callback: decode the request
/// (its length checked first), refuse a bad one, and queue a good one for the owner.
struct RequestHandler<Req> {
    tx: SyncSender<IncomingQuery<Req>>,
    counters: Arc<Counters>,
    log: BadPayloadLog,
    limits: DecodeLimits,
    block: bool,
}

impl<Req: Message> RequestHandler<Req> {
    fn on_query(&self, query: Query) {
        let c = &self.counters;
        let key = query.key_expr().as_str().to_string();
        let format = query.encoding().map(WireFormat::of).unwrap_or_default();
        let Some(payload) = query.payload() else {
            c.on_received(0);
            c.on_malformed();
            let e = format!("empty request: expected a {} message", Req::NAME);
            self.log.log(&key, 0, &e);
            let _ = refuse_query(
                &query,
                &key,
                format,
                &Refusal::new(RefusalKind::BadRequest, e),
            );
            return;
        };
        let len = payload.len();
        c.on_received(len);
        match format.decode_zbytes::<Req>(payload, &self.limits) {
            Ok(env) => self.queue(IncomingQuery {
                query,
                key,
                header: env.header,
                format,
                request: env.message,
            }),
            Err(e) => {
                c.on_malformed();
                self.log.log(&key, len, &e);
                let _ = refuse_query(
                    &query,
                    &key,
                    format,
                    &Refusal::new(RefusalKind::BadRequest, format!("bad request: {e}")),
                );
            }
        }
    }

    /// Queues a decoded request; without room (and not blocking), refuses it as busy.
    fn queue(&self, q: IncomingQuery<Req>) {
        let c = &self.counters;
        if self.block {
            if self.tx.send(q).is_ok() {
                c.on_delivered();
            } else {
                c.on_dropped(1);
            }
            return;
        }
        match self.tx.try_send(q) {
            Ok(()) => c.on_delivered(),
            Err(TrySendError::Full(q)) => {
                c.on_dropped(1);
                let _ = q.refuse(&Refusal::new(
                    RefusalKind::Busy,
                    "server busy: request queue full",
                ));
            }
            Err(TrySendError::Disconnected(q)) => {
                c.on_dropped(1);
                let _ = q.refuse(&Refusal::new(
                    RefusalKind::Busy,
                    "server stopping: request not taken",
                ));
            }
        }
    }
}

/// Answers `query` (to `key`) with a typed refusal in `format` ([`Refusal::encode`]: the
/// lowest schema version that has its kind). For queryables declared on the raw session
/// (plan lookups, bridge stats) as well as typed ones ([`IncomingQuery::refuse`]).
pub fn refuse_query(
    query: &Query,
    key: &str,
    format: WireFormat,
    refusal: &Refusal,
) -> Result<(), NetError> {
    let (bytes, encoding) = refusal
        .encode(format, Meta::default())
        .map_err(|e| NetError::codec(key, e))?;
    query
        .reply_err(bytes)
        .encoding(encoding)
        .wait()
        .map_err(|e| NetError::zenoh("reply_err", key, e))
}

/// A decoded request waiting for its reply. The query is finalised (the querier stops waiting
/// for this queryable) when this value is dropped.
pub struct IncomingQuery<Req> {
    query: Query,
    key: String,
    /// Header of the request.
    pub header: Header,
    /// Format of the request (replies use the same).
    pub format: WireFormat,
    /// The request.
    pub request: Req,
}

impl<Req> IncomingQuery<Req> {
    /// The key expression the query was sent to.
    pub fn key(&self) -> &str {
        &self.key
    }

    /// The value of parameter `name` of the query's selector (`key?name=value;...`), as the
    /// querier wrote it (nothing vouches for it).
    pub fn parameter(&self, name: &str) -> Option<&str> {
        self.query.parameters().get(name)
    }

    /// Sends a reply (in the request's format).
    pub fn reply<Rep: Message>(&self, reply: &Rep, meta: Meta) -> Result<(), NetError> {
        let bytes = self
            .format
            .encode(reply, meta)
            .map_err(|e| NetError::codec(&self.key, e))?;
        self.query
            .reply(self.query.key_expr().clone(), bytes)
            .encoding(self.format.encoding::<Rep>())
            .wait()
            .map_err(|e| NetError::zenoh("reply", &self.key, e))
    }

    /// Refuses the request with a typed [`Refusal`] (in the request's format), which the
    /// querier receives as [`NetError::Refused`].
    pub fn refuse(&self, refusal: &Refusal) -> Result<(), NetError> {
        refuse_query(&self.query, &self.key, self.format, refusal)
    }

    /// Sends an untyped error reply with a message for the querier (received as
    /// [`NetError::Remote`]; prefer [`IncomingQuery::refuse`]).
    pub fn reply_err(&self, message: &str) -> Result<(), NetError> {
        self.query
            .reply_err(message.to_string())
            .wait()
            .map_err(|e| NetError::zenoh("reply_err", &self.key, e))
    }
}

/// A queryable of `Req` requests (undeclared when dropped).
pub struct TypedQueryable<Req> {
    _queryable: zenoh::query::Queryable<()>,
    rx: Receiver<IncomingQuery<Req>>,
    counters: Arc<Counters>,
    key: String,
}

impl<Req> TypedQueryable<Req> {
    /// Waits up to `timeout` for the next request.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<IncomingQuery<Req>> {
        self.rx.recv_timeout(timeout).ok()
    }

    /// Counters of this queryable.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The key expression it answers.
    pub fn key(&self) -> &str {
        &self.key
    }
}
