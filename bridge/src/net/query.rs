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

/// The payload length of a reply, good or error.
fn reply_len(reply: &Reply) -> usize {
    match reply.result() {
        Ok(sample) => sample.payload().len(),
        Err(err) => err.payload().len(),
    }
}

/// Whether `reply` is the error Zenoh itself delivers when a query's timeout passes before
/// every queryable answered (the text `Timeout`, Zenoh's string encoding, no replier): the end
/// of the query, not a peer's answer. A peer that sends the same is taken at its word: as no
/// reply.
fn is_query_timeout(reply: &Reply) -> bool {
    match reply.result() {
        Err(e) => {
            *e.encoding() == zenoh::bytes::Encoding::ZENOH_STRING
                && e.payload().len() == QUERY_TIMEOUT_TEXT.len()
                && e.payload().to_bytes().as_ref() == QUERY_TIMEOUT_TEXT
        }
        Ok(_) => false,
    }
}

/// What Zenoh's own error reply at a query's timeout says.
const QUERY_TIMEOUT_TEXT: &[u8] = b"Timeout";

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

/// Longest error text of a peer kept in a [`NetError::Remote`] or [`NetError::Refused`]
/// (bytes): a longer one is cut (at a character boundary) and says how long it was.
pub const MAX_ERROR_TEXT_BYTES: usize = 4096;

/// `text`, cut to at most [`MAX_ERROR_TEXT_BYTES`] (plus a note of its length).
fn bounded_text(text: &str) -> String {
    if text.len() <= MAX_ERROR_TEXT_BYTES {
        return text.to_string();
    }
    let mut end = MAX_ERROR_TEXT_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}... ({} bytes in all)", &text[..end], text.len())
}

/// What an error reply of a query means: a typed [`Refusal`] in the envelope (in `format`,
/// the reply's encoding; any schema version this build reads, [`Refusal::decode`]) is
/// [`NetError::Refused`]; anything else is [`NetError::Remote`] with the reply's text (a
/// payload that is not UTF-8 is described, with why it is no refusal). Both name `key`; a
/// peer's text is kept up to [`MAX_ERROR_TEXT_BYTES`].
/// Queries call it on each error reply; public for tests and raw Zenoh clients.
pub fn decode_error_reply(
    key: &str,
    payload: &[u8],
    format: WireFormat,
    limits: &DecodeLimits,
) -> NetError {
    match Refusal::decode(payload, format, limits) {
        Ok(env) => {
            let mut refusal = env.message;
            if refusal.message.len() > MAX_ERROR_TEXT_BYTES {
                refusal.message = bounded_text(&refusal.message);
            }
            NetError::Refused {
                key: key.to_string(),
                refusal,
            }
        }
        Err(codec) => NetError::Remote {
            key: key.to_string(),
            message: match std::str::from_utf8(payload) {
                Ok(text) => bounded_text(text),
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
                // the query's own end at its timeout: what came before decides
                Ok(Some(reply)) if is_query_timeout(&reply) => wait = Duration::ZERO,
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
    /// At most `opts.max_replies` replies and `opts.max_reply_bytes` payload bytes are
    /// collected; past either, the last entry is [`NetError::TooManyReplies`] and the rest
    /// are not read.
    pub fn query<Req: Message, Rep: Message>(
        &self,
        key: &str,
        request: &Req,
        opts: &QueryOptions,
    ) -> Result<Vec<Result<Received<Rep>, NetError>>, NetError> {
        let replies = self.send_query(key, request, opts, ConsolidationMode::Auto)?;
        let mut out = Vec::new();
        let mut bytes = 0usize;
        while let Ok(reply) = replies.recv() {
            if is_query_timeout(&reply) {
                continue;
            }
            bytes = bytes.saturating_add(reply_len(&reply));
            let past = if out.len() >= opts.max_replies {
                Some(("replies", opts.max_replies))
            } else if bytes > opts.max_reply_bytes {
                Some(("bytes", opts.max_reply_bytes))
            } else {
                None
            };
            if let Some((what, limit)) = past {
                out.push(Err(NetError::TooManyReplies {
                    key: key.to_string(),
                    what,
                    limit: limit as u64,
                }));
                break;
            }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refusal::RefusalKind;

    /// A peer's error text is kept up to MAX_ERROR_TEXT_BYTES, cut at a character boundary,
    /// and says how long it was; a refusal's message likewise.
    #[test]
    fn error_texts_of_peers_are_bounded() {
        let limits = DecodeLimits::default();
        let short = decode_error_reply("k", b"no", WireFormat::Bincode, &limits);
        assert!(matches!(&short, NetError::Remote { message, .. } if message == "no"));
        let long = "\u{e9}".repeat(MAX_ERROR_TEXT_BYTES); // 2 bytes each
        let e = decode_error_reply("k", long.as_bytes(), WireFormat::Bincode, &limits);
        let NetError::Remote { message, .. } = &e else {
            panic!("{e:?}");
        };
        assert!(
            message.len() <= MAX_ERROR_TEXT_BYTES + 40,
            "{}",
            message.len()
        );
        assert!(message.ends_with(&format!("({} bytes in all)", long.len())));
        let refusal = Refusal::new(RefusalKind::Internal, "x".repeat(100_000));
        let (bytes, _) = refusal
            .encode(WireFormat::Bincode, crate::Meta::default())
            .unwrap();
        let e = decode_error_reply("k", &bytes, WireFormat::Bincode, &limits);
        let NetError::Refused { refusal, .. } = &e else {
            panic!("{e:?}");
        };
        assert_eq!(refusal.kind, RefusalKind::Internal);
        assert!(refusal.message.len() <= MAX_ERROR_TEXT_BYTES + 40);
        assert!(e.to_string().len() < MAX_ERROR_TEXT_BYTES + 200);
    }

    /// A queryable that answers one query with many replies: the querier collects at most
    /// `max_replies` of them, or `max_reply_bytes`, and says so in a last entry.
    #[test]
    fn collected_replies_are_bounded_by_count_and_bytes() {
        use crate::envelope::encode;
        use crate::zconfig::ZenohArgs;
        let config = ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[])
            .to_config()
            .unwrap();
        let node = ZenohNode::open(config, "test", "many-replies").unwrap();
        let reply = Refusal::new(RefusalKind::Busy, "r");
        let bytes = encode(&reply, crate::Meta::default()).unwrap();
        let len = bytes.len();
        let _queryable = node
            .session()
            .declare_queryable("cellsar/test/many/**")
            .callback(move |q| {
                for i in 0..10 {
                    let _ = q
                        .reply(format!("cellsar/test/many/{i}"), bytes.clone())
                        .encoding(WireFormat::Bincode.encoding::<Refusal>())
                        .wait();
                }
            })
            .wait()
            .unwrap();
        let ask = |opts: &QueryOptions| {
            node.query::<Refusal, Refusal>("cellsar/test/many/**", &reply, opts)
                .unwrap()
        };
        let all = ask(&QueryOptions::default());
        assert_eq!(all.len(), 10);
        assert!(all.iter().all(Result::is_ok));
        let by_count = ask(&QueryOptions {
            max_replies: 3,
            ..QueryOptions::default()
        });
        assert_eq!(by_count.len(), 4);
        assert!(by_count[..3].iter().all(Result::is_ok));
        assert!(matches!(
            &by_count[3],
            Err(NetError::TooManyReplies {
                what: "replies",
                limit: 3,
                ..
            })
        ));
        let by_bytes = ask(&QueryOptions {
            max_reply_bytes: 2 * len + 1,
            ..QueryOptions::default()
        });
        assert_eq!(by_bytes.len(), 3);
        assert!(matches!(
            &by_bytes[2],
            Err(NetError::TooManyReplies { what: "bytes", .. })
        ));
        node.close().unwrap();
    }

    /// A queryable that holds its queries past their timeout: Zenoh ends the query with an
    /// error reply of its own, which is no reply, not a peer's error.
    #[test]
    fn a_query_that_times_out_has_no_reply() {
        use crate::zconfig::ZenohArgs;
        let config = ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[])
            .to_config()
            .unwrap();
        let node = ZenohNode::open(config, "test", "silent").unwrap();
        let held = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let keep = held.clone();
        let _queryable = node
            .session()
            .declare_queryable("cellsar/test/silent")
            .callback(move |q| keep.lock().unwrap().push(q))
            .wait()
            .unwrap();
        let request = Refusal::new(RefusalKind::Busy, "r");
        let opts = QueryOptions {
            timeout: Duration::from_millis(300),
            ..QueryOptions::default()
        };
        let one = node.query_one::<Refusal, Refusal>("cellsar/test/silent", &request, &opts);
        assert!(matches!(one, Err(NetError::NoReply { .. })), "{one:?}");
        let all = node
            .query::<Refusal, Refusal>("cellsar/test/silent", &request, &opts)
            .unwrap();
        assert!(all.is_empty(), "{all:?}");
        // the queryable got both and answered neither
        assert_eq!(held.lock().unwrap().len(), 2);
        held.lock().unwrap().clear();
        node.close().unwrap();
    }
}
