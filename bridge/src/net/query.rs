//! Typed queries ([`ZenohNode::query`], [`ZenohNode::start_query`],
//! [`ZenohNode::query_one`], [`PendingQuery`]) and what their replies mean
//! ([`decode_error_reply`]).

use std::marker::PhantomData;
use std::time::Duration;

use zenoh::handlers::FifoChannelHandler;
use zenoh::query::{ConsolidationMode, Reply};
use zenoh::Wait;

use super::{NetError, QueryOptions, Received, WireFormat, ZenohNode};
use crate::envelope::{DecodeLimits, Message};
use crate::refusal::Refusal;

fn decode_reply<Rep: Message>(
    key: &str,
    reply: &Reply,
    limits: &DecodeLimits,
) -> Result<Received<Rep>, NetError> {
    match reply.result() {
        Ok(sample) => {
            let format = WireFormat::of(sample.encoding());
            format
                .decode_zbytes::<Rep>(sample.payload(), limits)
                .map(|env| Received {
                    key: sample.key_expr().as_str().to_string(),
                    header: env.header,
                    format,
                    message: env.message,
                })
                .map_err(|e| NetError::codec(key, e))
        }
        Err(err) => {
            let payload = err.payload();
            let format = WireFormat::of(err.encoding());
            if let Err(e) = format.check_len(payload.len(), limits) {
                return Err(NetError::Remote {
                    key: key.to_string(),
                    message: format!("an error reply that is not read: {e}"),
                });
            }
            Err(decode_error_reply(key, &payload.to_bytes(), format, limits))
        }
    }
}

/// What an error reply of a query means: a typed [`Refusal`] in the envelope (in `format`,
/// the reply's encoding; any schema version this build reads, [`Refusal::decode`]) is
/// [`NetError::Refused`]; anything else is [`NetError::Remote`] with the reply's text (a
/// payload that is not UTF-8 is described, with why it is no refusal). Both name `key`.
/// Queries call it on each error reply; public for tests and raw Zenoh clients.
pub fn decode_error_reply(
    key: &str,
    payload: &[u8],
    format: WireFormat,
    limits: &DecodeLimits,
) -> NetError {
    match Refusal::decode(payload, format, limits) {
        Ok(env) => NetError::Refused {
            key: key.to_string(),
            refusal: env.message,
        },
        Err(codec) => NetError::Remote {
            key: key.to_string(),
            message: match std::str::from_utf8(payload) {
                Ok(text) => text.to_string(),
                Err(_) => format!(
                    "{} bytes of non-UTF-8 that are no {}: {codec}",
                    payload.len(),
                    Refusal::NAME
                ),
            },
        },
    }
}

/// A query in flight ([`ZenohNode::start_query`]); dropping it abandons the query.
pub struct PendingQuery<Rep> {
    key: String,
    replies: FifoChannelHandler<Reply>,
    limits: DecodeLimits,
    timeout: Duration,
    first_err: Option<NetError>,
    _rep: PhantomData<fn() -> Rep>,
}

impl<Rep> std::fmt::Debug for PendingQuery<Rep> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PendingQuery")
            .field("key", &self.key)
            .field("timeout", &self.timeout)
            .finish()
    }
}

impl<Rep: Message> PendingQuery<Rep> {
    /// Waits at most `wait` for the answer: `None` while it is still open; `Some(Ok)` with the
    /// first good reply; `Some(Err)` once every reply came in (or the query's timeout passed)
    /// without a good one: the first remote error or bad reply, else [`NetError::NoReply`].
    /// Call it again after `Some` and it says `NoReply`.
    pub fn poll(&mut self, wait: Duration) -> Option<Result<Received<Rep>, NetError>> {
        let mut wait = wait;
        loop {
            match self.replies.recv_timeout(wait) {
                Ok(Some(reply)) => match decode_reply::<Rep>(&self.key, &reply, &self.limits) {
                    Ok(r) => return Some(Ok(r)),
                    Err(e) => {
                        self.first_err.get_or_insert(e);
                        wait = Duration::ZERO;
                    }
                },
                Ok(None) => return None,
                Err(_) => {
                    return Some(Err(self.first_err.take().unwrap_or(NetError::NoReply {
                        key: self.key.clone(),
                        timeout: self.timeout,
                    })))
                }
            }
        }
    }
}

impl ZenohNode {
    /// Sends a typed query and collects every reply until `opts.timeout` (or until all
    /// queryables answered). Each reply is `Ok` (decoded) or `Err` (a typed refusal
    /// [`NetError::Refused`], another remote error [`NetError::Remote`], or a bad reply).
    pub fn query<Req: Message, Rep: Message>(
        &self,
        key: &str,
        request: &Req,
        opts: &QueryOptions,
    ) -> Result<Vec<Result<Received<Rep>, NetError>>, NetError> {
        let replies = self.send_query(key, request, opts, ConsolidationMode::Auto)?;
        let mut out = Vec::new();
        while let Ok(reply) = replies.recv() {
            out.push(decode_reply::<Rep>(key, &reply, &opts.limits));
        }
        Ok(out)
    }

    fn send_query<Req: Message>(
        &self,
        key: &str,
        request: &Req,
        opts: &QueryOptions,
        consolidation: ConsolidationMode,
    ) -> Result<FifoChannelHandler<Reply>, NetError> {
        let payload = opts
            .format
            .encode(request, opts.meta)
            .map_err(|e| NetError::codec(key, e))?;
        self.session()
            .get(key.to_string())
            .payload(payload)
            .encoding(opts.format.encoding::<Req>())
            .target(opts.target)
            .consolidation(consolidation)
            .timeout(opts.timeout)
            .wait()
            .map_err(|e| NetError::zenoh("get", key, e))
    }

    /// Sends a typed query and returns at once: [`PendingQuery::poll`] then waits for its
    /// first good reply a little at a time, so that the caller can give up (drop it) at any
    /// moment, on a signal for instance. Replies are not consolidated (Zenoh's default would
    /// hold every reply back until the last queryable answered), so the first good reply is
    /// seen as soon as it arrives.
    pub fn start_query<Req: Message, Rep: Message>(
        &self,
        key: &str,
        request: &Req,
        opts: &QueryOptions,
    ) -> Result<PendingQuery<Rep>, NetError> {
        Ok(PendingQuery {
            key: key.to_string(),
            replies: self.send_query(key, request, opts, ConsolidationMode::None)?,
            limits: opts.limits,
            timeout: opts.timeout,
            first_err: None,
            _rep: PhantomData,
        })
    }

    /// Sends a typed query and waits for the first good reply (returning as soon as it
    /// arrives, without waiting for the other queryables): as [`PendingQuery::poll`], a typed
    /// refusal is returned as [`NetError::Refused`], another remote error as
    /// [`NetError::Remote`], no reply at all as [`NetError::NoReply`].
    pub fn query_one<Req: Message, Rep: Message>(
        &self,
        key: &str,
        request: &Req,
        opts: &QueryOptions,
    ) -> Result<Received<Rep>, NetError> {
        let mut pending = self.start_query::<Req, Rep>(key, request, opts)?;
        loop {
            // Zenoh ends the query (closes the channel) at its timeout at the latest; the
            // bounded wait only keeps `Instant + wait` from overflowing
            if let Some(r) = pending.poll(Duration::from_secs(1)) {
                return r;
            }
        }
    }
}
