//! Typed Zenoh endpoints: a session with its liveliness token, publishers, subscribers,
//! queryables and queries of [`Message`]s, frames over Zenoh, and liveliness watching.
//!
//! All calls are synchronous (zenoh's `Wait`), so the binaries need no async runtime of their
//! own. Receive paths decode in the Zenoh callback, count every payload
//! ([`Counters`]) and hand good messages to a bounded queue; a full queue either drops (and
//! counts) or blocks the Zenoh receive path, as chosen in [`SubscribeOptions`].

use std::collections::BTreeSet;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use zenoh::bytes::{Encoding, ZBytes};
use zenoh::handlers::FifoChannelHandler;
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::query::{ConsolidationMode, Query, QueryTarget, Reply};
use zenoh::sample::{Locality, Sample, SampleKind};
use zenoh::{Config, Session, Wait};

use crate::counters::{BadPayloadLog, Counters};
use crate::envelope::{self, CodecError, DecodeLimits, Envelope, Header, Message, Meta, MissionId};
use crate::frame::{self, FrameHeader, WIRE_PREFIX_LEN};
use crate::keys::{self, KeyError};
use crate::refusal::{Refusal, RefusalKind};
use crate::zconfig;

/// Errors of the Zenoh layer. Each names the key and the operation.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// Zenoh refused an operation.
    #[error("zenoh {op} on {key:?} failed: {reason}")]
    Zenoh {
        /// Operation (declare publisher, put, close, ...).
        op: &'static str,
        /// Key expression concerned (the liveliness token's key for the session itself).
        key: String,
        /// Zenoh's message.
        reason: String,
    },
    /// The Zenoh session could not be opened (a listen endpoint taken, a configuration that
    /// Zenoh refuses, no router or peer reachable within the configured connect timeout).
    #[error("opening the Zenoh session ({session}) failed: {reason}")]
    Open {
        /// What was being opened: the mode and the endpoints ([`zconfig::describe`]).
        session: String,
        /// Zenoh's message, on one line.
        reason: String,
    },
    /// A key was invalid.
    #[error(transparent)]
    Key(#[from] KeyError),
    /// A message could not be encoded or a reply decoded.
    #[error("{key}: {source}")]
    Codec {
        /// Key expression.
        key: String,
        /// Codec error.
        source: CodecError,
    },
    /// A queryable answered with an error that is not a typed [`Refusal`] (a plain text from
    /// an older or foreign queryable).
    #[error("query {key:?} answered with an error: {message}")]
    Remote {
        /// Key expression.
        key: String,
        /// The error text of the reply.
        message: String,
    },
    /// A queryable refused the request with a typed [`Refusal`] ([`IncomingQuery::refuse`]).
    #[error("query {key:?} refused ({}): {}", refusal.kind, refusal.message)]
    Refused {
        /// Key expression.
        key: String,
        /// The refusal: its kind and message.
        refusal: Refusal,
    },
    /// A query got no (good) reply before its timeout.
    #[error("query {key:?}: no reply within {timeout:?}")]
    NoReply {
        /// Key expression.
        key: String,
        /// The timeout.
        timeout: Duration,
    },
}

fn zerr(op: &'static str, key: &str, e: impl std::fmt::Display) -> NetError {
    NetError::Zenoh {
        op,
        key: key.to_string(),
        reason: e.to_string(),
    }
}

fn decode_reply<Rep: Message>(
    key: &str,
    reply: &Reply,
    limits: &DecodeLimits,
) -> Result<Received<Rep>, NetError> {
    match reply.result() {
        Ok(sample) => {
            let bytes = sample.payload().to_bytes();
            let format = WireFormat::of(sample.encoding());
            format
                .decode::<Rep>(&bytes, limits)
                .map(|env| Received {
                    key: sample.key_expr().as_str().to_string(),
                    header: env.header,
                    format,
                    message: env.message,
                })
                .map_err(|source| NetError::Codec {
                    key: key.to_string(),
                    source,
                })
        }
        Err(err) => Err(decode_error_reply(
            key,
            &err.payload().to_bytes(),
            WireFormat::of(err.encoding()),
            limits,
        )),
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

/// How a message body is encoded on Zenoh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum WireFormat {
    /// Binary envelope + bincode 2 (encoding `application/octet-stream;cellsar/<name>/v<n>`).
    #[default]
    Bincode,
    /// JSON envelope (encoding `application/json;cellsar/<name>/v<n>`), readable from Python.
    Json,
}

impl WireFormat {
    /// The Zenoh encoding for message type `M` in this format.
    pub fn encoding<M: Message>(self) -> Encoding {
        let schema = format!("cellsar/{}/v{}", M::NAME, M::SCHEMA_VERSION);
        match self {
            WireFormat::Bincode => Encoding::APPLICATION_OCTET_STREAM.with_schema(schema),
            WireFormat::Json => Encoding::APPLICATION_JSON.with_schema(schema),
        }
    }

    /// The format announced by a Zenoh encoding (JSON if it is `application/json[;...]`).
    pub fn of(encoding: &Encoding) -> WireFormat {
        let s = std::borrow::Cow::<str>::from(encoding);
        let is_json = s
            .strip_prefix("application/json")
            .is_some_and(|rest| rest.is_empty() || rest.starts_with(';'));
        if is_json {
            WireFormat::Json
        } else {
            WireFormat::Bincode
        }
    }

    /// Encodes `msg`.
    pub fn encode<M: Message>(self, msg: &M, meta: Meta) -> Result<Vec<u8>, CodecError> {
        match self {
            WireFormat::Bincode => envelope::encode(msg, meta),
            WireFormat::Json => envelope::encode_json(msg, meta),
        }
    }

    /// Decodes a payload holding an `M`.
    pub fn decode<M: Message>(
        self,
        payload: &[u8],
        limits: &DecodeLimits,
    ) -> Result<Envelope<M>, CodecError> {
        match self {
            WireFormat::Bincode => envelope::decode(payload, limits),
            WireFormat::Json => envelope::decode_json(payload, limits),
        }
    }
}

/// A received message with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Received<M> {
    /// The key it was published on.
    pub key: String,
    /// Its header.
    pub header: Header,
    /// How it was encoded.
    pub format: WireFormat,
    /// The message.
    pub message: M,
}

/// A Zenoh session of one cellsar process, announced by the liveliness token
/// `cellsar/alive/<role>/<instance>` for as long as it is open.
pub struct ZenohNode {
    session: Session,
    role: String,
    instance: String,
    _token: LivelinessToken,
}

impl std::fmt::Debug for ZenohNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohNode")
            .field("role", &self.role)
            .field("instance", &self.instance)
            .field("zid", &self.session.zid().to_string())
            .finish()
    }
}

/// How long [`ZenohNode::open_until`] waits before it says that it is still waiting.
const OPEN_NOTICE_AFTER: Duration = Duration::from_secs(2);
/// How often it says so again.
const OPEN_NOTICE_EVERY: Duration = Duration::from_secs(30);
/// How often it looks at its stop flag.
const OPEN_POLL: Duration = Duration::from_millis(20);

impl ZenohNode {
    /// Opens a session and declares its liveliness token.
    ///
    /// This blocks until Zenoh has opened the session: with `connect.timeout_ms: -1` (a
    /// client that waits for its router, `pipeline/deploy/client.json5`) for as long as no
    /// router is reachable. A process that must stay stoppable meanwhile uses
    /// [`ZenohNode::open_until`].
    pub fn open(config: Config, role: &str, instance: &str) -> Result<Self, NetError> {
        let alive = keys::alive(role, instance)?;
        let described = zconfig::describe(&config);
        let session = zenoh::open(config)
            .wait()
            // a configuration error comes back as Debug text with source paths: clean it
            // here, where users see it (not on the per-frame put path)
            .map_err(|e| NetError::Open {
                session: described,
                reason: zconfig::clean_zenoh_message(&e.to_string()),
            })?;
        let token = session
            .liveliness()
            .declare_token(alive.clone())
            .wait()
            .map_err(|e| zerr("declare liveliness token", &alive, e))?;
        tracing::info!(%alive, zid = %session.zid(), "zenoh session open");
        Ok(ZenohNode {
            session,
            role: role.to_string(),
            instance: instance.to_string(),
            _token: token,
        })
    }

    /// Opens a session as [`ZenohNode::open`] does, but gives up as soon as `stop` is set
    /// (the flag SIGINT/SIGTERM set): `Ok(None)` then, `Ok(Some(node))` once the session is
    /// open. Zenoh opens it on a thread of its own, which is left behind when `stop` is set
    /// first (the process is about to exit). While no router or peer answers (a client
    /// started before its router waits for it), it logs every 30 s, from 2 s on, what it
    /// waits for; a stop is logged too.
    pub fn open_until(
        config: Config,
        role: &str,
        instance: &str,
        stop: &AtomicBool,
    ) -> Result<Option<Self>, NetError> {
        keys::alive(role, instance)?;
        let session = zconfig::describe(&config);
        let (tx, rx) = mpsc::sync_channel(1);
        let (r, i) = (role.to_string(), instance.to_string());
        std::thread::Builder::new()
            .name("zenoh-open".into())
            .spawn(move || {
                let _ = tx.send(ZenohNode::open(config, &r, &i));
            })
            .map_err(|e| NetError::Open {
                session: session.clone(),
                reason: format!("starting the thread that opens it: {e}"),
            })?;
        let started = Instant::now();
        let mut notice_at = started + OPEN_NOTICE_AFTER;
        loop {
            if stop.load(Ordering::Relaxed) {
                tracing::warn!(
                    %session,
                    waited_s = started.elapsed().as_secs(),
                    "stopped before the Zenoh session opened"
                );
                return Ok(None);
            }
            match rx.recv_timeout(OPEN_POLL) {
                Ok(opened) => return opened.map(Some),
                Err(RecvTimeoutError::Timeout) => {
                    if Instant::now() >= notice_at {
                        notice_at += OPEN_NOTICE_EVERY;
                        tracing::warn!(
                            %session,
                            waited_s = started.elapsed().as_secs(),
                            "waiting for the Zenoh session to open: no router or peer \
                             reachable yet (SIGINT/SIGTERM stops)"
                        );
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(NetError::Open {
                        session,
                        reason: "the thread that opened it ended without an answer".into(),
                    })
                }
            }
        }
    }

    /// The underlying session (for anything this wrapper does not cover).
    pub fn session(&self) -> &Session {
        &self.session
    }

    /// Role of this process.
    pub fn role(&self) -> &str {
        &self.role
    }

    /// Instance name of this process.
    pub fn instance(&self) -> &str {
        &self.instance
    }

    /// Declares an additional liveliness token (alive while the returned token lives).
    pub fn declare_token(&self, key: &str) -> Result<LivelinessToken, NetError> {
        self.session
            .liveliness()
            .declare_token(key.to_string())
            .wait()
            .map_err(|e| zerr("declare liveliness token", key, e))
    }

    /// Declares a typed publisher on `key`.
    pub fn publisher<M: Message>(
        &self,
        key: &str,
        opts: PublishOptions,
    ) -> Result<TypedPublisher<M>, NetError> {
        let publisher = self
            .session
            .declare_publisher(key.to_string())
            .encoding(opts.format.encoding::<M>())
            .congestion_control(opts.congestion_control)
            .priority(opts.priority)
            .allowed_destination(opts.allowed_destination)
            .wait()
            .map_err(|e| zerr("declare publisher", key, e))?;
        Ok(TypedPublisher {
            publisher,
            key: key.to_string(),
            format: opts.format,
            mission_id: opts.mission_id,
            next_seq: AtomicU64::new(opts.first_seq),
            counters: Arc::new(Counters::default()),
            _m: PhantomData,
        })
    }

    /// Declares a typed subscriber on `key` (a key expression; wildcards allowed).
    pub fn subscriber<M: Message + Send + 'static>(
        &self,
        key: &str,
        opts: SubscribeOptions,
    ) -> Result<TypedSubscriber<M>, NetError> {
        let (tx, rx) = mpsc::sync_channel::<Received<M>>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let log = Arc::new(BadPayloadLog::default());
        let c = counters.clone();
        let limits = opts.limits;
        let block = opts.on_full == OnFull::Block;
        let subscriber = self
            .session
            .declare_subscriber(key.to_string())
            .callback(move |sample: Sample| {
                if sample.kind() != SampleKind::Put {
                    return;
                }
                let payload = sample.payload();
                c.on_received(payload.len());
                let bytes = payload.to_bytes();
                let format = WireFormat::of(sample.encoding());
                match format.decode::<M>(&bytes, &limits) {
                    Ok(env) => {
                        let msg = Received {
                            key: sample.key_expr().as_str().to_string(),
                            header: env.header,
                            format,
                            message: env.message,
                        };
                        deliver(&tx, msg, block, &c);
                    }
                    Err(e) => {
                        c.on_malformed();
                        log.log(sample.key_expr().as_str(), bytes.len(), &e);
                    }
                }
            })
            .allowed_origin(opts.allowed_origin)
            .wait()
            .map_err(|e| zerr("declare subscriber", key, e))?;
        Ok(TypedSubscriber {
            _subscriber: subscriber,
            rx,
            counters,
            key: key.to_string(),
        })
    }

    /// Declares a typed queryable on `key`; requests are decoded in the Zenoh callback and
    /// queued, and the owner answers them with [`IncomingQuery::reply`] from any thread.
    pub fn queryable<Req: Message + Send + 'static>(
        &self,
        key: &str,
        opts: SubscribeOptions,
    ) -> Result<TypedQueryable<Req>, NetError> {
        let (tx, rx) = mpsc::sync_channel::<IncomingQuery<Req>>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let log = Arc::new(BadPayloadLog::default());
        let c = counters.clone();
        let limits = opts.limits;
        let block = opts.on_full == OnFull::Block;
        let queryable = self
            .session
            .declare_queryable(key.to_string())
            .callback(move |query: Query| {
                let key = query.key_expr().as_str().to_string();
                let format = query.encoding().map(WireFormat::of).unwrap_or_default();
                let Some(payload) = query.payload() else {
                    c.on_received(0);
                    c.on_malformed();
                    let e = format!("empty request: expected a {} message", Req::NAME);
                    log.log(&key, 0, &e);
                    let _ = refuse_query(
                        &query,
                        &key,
                        format,
                        &Refusal::new(RefusalKind::BadRequest, e),
                    );
                    return;
                };
                c.on_received(payload.len());
                let bytes = payload.to_bytes();
                match format.decode::<Req>(&bytes, &limits) {
                    Ok(env) => {
                        let q = IncomingQuery {
                            query,
                            key,
                            header: env.header,
                            format,
                            request: env.message,
                        };
                        if block {
                            if tx.send(q).is_ok() {
                                c.on_delivered();
                            } else {
                                c.on_dropped(1);
                            }
                        } else {
                            match tx.try_send(q) {
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
                    Err(e) => {
                        c.on_malformed();
                        log.log(&key, bytes.len(), &e);
                        let _ = refuse_query(
                            &query,
                            &key,
                            format,
                            &Refusal::new(RefusalKind::BadRequest, format!("bad request: {e}")),
                        );
                    }
                }
            })
            .wait()
            .map_err(|e| zerr("declare queryable", key, e))?;
        Ok(TypedQueryable {
            _queryable: queryable,
            rx,
            counters,
            key: key.to_string(),
        })
    }

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
            .map_err(|source| NetError::Codec {
                key: key.to_string(),
                source,
            })?;
        self.session
            .get(key.to_string())
            .payload(payload)
            .encoding(opts.format.encoding::<Req>())
            .target(opts.target)
            .consolidation(consolidation)
            .timeout(opts.timeout)
            .wait()
            .map_err(|e| zerr("get", key, e))
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

    /// Watches liveliness tokens matching `selector` (e.g. [`keys::ALIVE_ALL`]), including
    /// the ones that exist already.
    pub fn watch_liveliness(&self, selector: &str) -> Result<LivelinessWatcher, NetError> {
        let alive = Arc::new(Mutex::new(BTreeSet::new()));
        let (tx, rx) = mpsc::channel();
        let a = alive.clone();
        let subscriber = self
            .session
            .liveliness()
            .declare_subscriber(selector.to_string())
            .history(true)
            .callback(move |sample: Sample| {
                let key = sample.key_expr().as_str().to_string();
                let is_alive = sample.kind() == SampleKind::Put;
                if let Ok(mut set) = a.lock() {
                    if is_alive {
                        set.insert(key.clone());
                    } else {
                        set.remove(&key);
                    }
                }
                let _ = tx.send(AliveEvent {
                    key,
                    alive: is_alive,
                });
            })
            .wait()
            .map_err(|e| zerr("declare liveliness subscriber", selector, e))?;
        Ok(LivelinessWatcher {
            _subscriber: subscriber,
            alive,
            events: rx,
        })
    }

    /// The liveliness tokens matching `selector` right now (a liveliness query).
    pub fn alive_now(&self, selector: &str, timeout: Duration) -> Result<Vec<String>, NetError> {
        let replies = self
            .session
            .liveliness()
            .get(selector.to_string())
            .timeout(timeout)
            .wait()
            .map_err(|e| zerr("liveliness get", selector, e))?;
        let mut out = BTreeSet::new();
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                out.insert(sample.key_expr().as_str().to_string());
            }
        }
        Ok(out.into_iter().collect())
    }

    /// Declares a publisher of raw frames on `key` (see [`crate::frame`] for the layout).
    pub fn frame_publisher(
        &self,
        key: &str,
        congestion_control: CongestionControl,
        allowed_destination: Locality,
    ) -> Result<ZenohFramePublisher, NetError> {
        let publisher = self
            .session
            .declare_publisher(key.to_string())
            .encoding(Encoding::APPLICATION_OCTET_STREAM.with_schema("cellsar/frame/v1"))
            .congestion_control(congestion_control)
            .priority(Priority::DataLow)
            .allowed_destination(allowed_destination)
            .wait()
            .map_err(|e| zerr("declare publisher", key, e))?;
        Ok(ZenohFramePublisher {
            publisher,
            key: key.to_string(),
            counters: Arc::new(Counters::default()),
            pool: BufPool::default(),
        })
    }

    /// Declares a subscriber of raw frames on `key`. The Zenoh callback only checks the frame
    /// header (72 bytes) and queues the sample; the payload is read (copied or verified) in the
    /// consumer's thread, so a slow consumer never holds up Zenoh's receive path.
    pub fn frame_subscriber(
        &self,
        key: &str,
        opts: FrameSubscribeOptions,
    ) -> Result<ZenohFrameSubscriber, NetError> {
        let (tx, rx) = mpsc::sync_channel::<ZenohFrame>(opts.capacity.max(1));
        let counters = Arc::new(Counters::default());
        let log = Arc::new(BadPayloadLog::default());
        let c = counters.clone();
        let cb_log = log.clone();
        let block = opts.on_full == OnFull::Block;
        let subscriber = self
            .session
            .declare_subscriber(key.to_string())
            .callback(move |sample: Sample| {
                if sample.kind() != SampleKind::Put {
                    return;
                }
                let len = sample.payload().len();
                c.on_received(len);
                match split_frame_payload(sample.payload(), opts.max_payload_bytes) {
                    Ok((header, _)) => {
                        let f = ZenohFrame { header, sample };
                        let sent = if block {
                            tx.send(f).is_ok()
                        } else {
                            tx.try_send(f).is_ok()
                        };
                        if !sent {
                            c.on_dropped(1);
                        }
                    }
                    Err(e) => {
                        c.on_malformed();
                        cb_log.log(sample.key_expr().as_str(), len, &e);
                    }
                }
            })
            .allowed_origin(opts.allowed_origin)
            .wait()
            .map_err(|e| zerr("declare subscriber", key, e))?;
        Ok(ZenohFrameSubscriber {
            _subscriber: subscriber,
            rx,
            counters,
            log,
            verify_checksum: opts.verify_checksum,
            key: key.to_string(),
        })
    }

    /// Closes the session (undeclaring everything, liveliness token included).
    pub fn close(self) -> Result<(), NetError> {
        let alive = keys::alive(&self.role, &self.instance).unwrap_or_default();
        self.session
            .close()
            .wait()
            .map_err(|e| zerr("close session", &alive, e))
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
    let (bytes, encoding) =
        refusal
            .encode(format, Meta::default())
            .map_err(|source| NetError::Codec {
                key: key.to_string(),
                source,
            })?;
    query
        .reply_err(bytes)
        .encoding(encoding)
        .wait()
        .map_err(|e| zerr("reply_err", key, e))
}

fn deliver<T>(tx: &SyncSender<T>, item: T, block: bool, c: &Counters) {
    if block {
        match tx.send(item) {
            Ok(()) => c.on_delivered(),
            Err(_) => c.on_dropped(1),
        }
    } else {
        match tx.try_send(item) {
            Ok(()) => c.on_delivered(),
            Err(_) => c.on_dropped(1),
        }
    }
}

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
}

impl Default for SubscribeOptions {
    fn default() -> Self {
        SubscribeOptions {
            capacity: 256,
            on_full: OnFull::Drop,
            limits: DecodeLimits::default(),
            allowed_origin: Locality::Any,
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
}

impl Default for QueryOptions {
    fn default() -> Self {
        QueryOptions {
            format: WireFormat::Bincode,
            meta: Meta::default(),
            timeout: Duration::from_secs(10),
            target: QueryTarget::BestMatching,
            limits: DecodeLimits::default(),
        }
    }
}

/// A publisher of `M` with an automatic sequence number.
pub struct TypedPublisher<M> {
    publisher: zenoh::pubsub::Publisher<'static>,
    key: String,
    format: WireFormat,
    mission_id: MissionId,
    next_seq: AtomicU64,
    counters: Arc<Counters>,
    _m: PhantomData<fn(&M)>,
}

impl<M: Message> TypedPublisher<M> {
    /// Publishes `msg` with the next sequence number; returns that number.
    pub fn put(&self, msg: &M) -> Result<u64, NetError> {
        let seq = self.next_seq.fetch_add(1, Ordering::Relaxed);
        self.put_with(
            msg,
            Meta {
                mission_id: self.mission_id,
                seq,
                time_unix_ns: 0,
            },
        )?;
        Ok(seq)
    }

    /// Publishes `msg` with explicit header fields (e.g. to re-send with its original
    /// sequence number).
    pub fn put_with(&self, msg: &M, meta: Meta) -> Result<(), NetError> {
        let bytes = self
            .format
            .encode(msg, meta)
            .map_err(|source| NetError::Codec {
                key: self.key.clone(),
                source,
            })?;
        let len = bytes.len();
        match self.publisher.put(ZBytes::from(bytes)).wait() {
            Ok(()) => {
                self.counters.on_sent(len);
                Ok(())
            }
            Err(e) => {
                self.counters.on_send_error();
                Err(zerr("put", &self.key, e))
            }
        }
    }

    /// Whether a subscriber that this publisher may deliver to matches its key now.
    pub fn has_subscribers(&self) -> bool {
        self.publisher
            .matching_status()
            .wait()
            .map(|m| m.matching())
            .unwrap_or(false)
    }

    /// Waits up to `timeout` for a matching subscriber; returns whether one appeared.
    pub fn wait_for_subscribers(&self, timeout: Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        while !self.has_subscribers() {
            if std::time::Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        true
    }

    /// Counters of this publisher.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The key it publishes on.
    pub fn key(&self) -> &str {
        &self.key
    }
}

/// A subscriber of `M` (undeclared when dropped).
pub struct TypedSubscriber<M> {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    rx: Receiver<Received<M>>,
    counters: Arc<Counters>,
    key: String,
}

impl<M> TypedSubscriber<M> {
    /// Waits up to `timeout` for the next message.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<Received<M>> {
        match self.rx.recv_timeout(timeout) {
            Ok(m) => Some(m),
            Err(RecvTimeoutError::Timeout) | Err(RecvTimeoutError::Disconnected) => None,
        }
    }

    /// The next message if one is queued.
    pub fn try_recv(&self) -> Option<Received<M>> {
        self.rx.try_recv().ok()
    }

    /// Counters of this subscriber.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The key expression it listens on.
    pub fn key(&self) -> &str {
        &self.key
    }
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

    /// Sends a reply (in the request's format).
    pub fn reply<Rep: Message>(&self, reply: &Rep, meta: Meta) -> Result<(), NetError> {
        let bytes = self
            .format
            .encode(reply, meta)
            .map_err(|source| NetError::Codec {
                key: self.key.clone(),
                source,
            })?;
        self.query
            .reply(self.query.key_expr().clone(), bytes)
            .encoding(self.format.encoding::<Rep>())
            .wait()
            .map_err(|e| zerr("reply", &self.key, e))
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
            .map_err(|e| zerr("reply_err", &self.key, e))
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

/// A liveliness change.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AliveEvent {
    /// The token's key, e.g. `cellsar/alive/planner/p1`.
    pub key: String,
    /// `true` when it appeared, `false` when it went away.
    pub alive: bool,
}

/// Tracks liveliness tokens matching a selector.
pub struct LivelinessWatcher {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    alive: Arc<Mutex<BTreeSet<String>>>,
    events: Receiver<AliveEvent>,
}

impl LivelinessWatcher {
    /// The keys alive now.
    pub fn alive(&self) -> BTreeSet<String> {
        self.alive.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// Whether `key` is alive now.
    pub fn is_alive(&self, key: &str) -> bool {
        self.alive.lock().map(|s| s.contains(key)).unwrap_or(false)
    }

    /// Waits up to `timeout` for the next change.
    pub fn next_event(&self, timeout: Duration) -> Option<AliveEvent> {
        self.events.recv_timeout(timeout).ok()
    }

    /// Waits until `key`'s state is `alive` (or `timeout`); returns whether it got there.
    pub fn wait_for(&self, key: &str, alive: bool, timeout: Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if self.is_alive(key) == alive {
                return true;
            }
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return false;
            }
            let _ = self
                .events
                .recv_timeout(left.min(Duration::from_millis(50)));
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

/// A frame received over Zenoh, copied into an 8-byte-aligned buffer.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedFrame {
    /// Its header.
    pub header: FrameHeader,
    words: Vec<u64>,
}

impl OwnedFrame {
    /// A frame from a header and payload bytes (checked for consistency).
    pub fn new(header: FrameHeader, payload: &[u8]) -> Result<Self, CodecError> {
        header.validate(payload.len(), frame::MAX_FRAME_HARD_LIMIT)?;
        let mut words = vec![0u64; payload.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..payload.len()].copy_from_slice(payload);
        Ok(OwnedFrame { header, words })
    }

    /// The payload bytes.
    pub fn payload(&self) -> &[u8] {
        let len = usize::try_from(self.header.payload_len).unwrap_or(usize::MAX);
        let all = bytemuck::cast_slice::<u64, u8>(&self.words);
        &all[..len.min(all.len())]
    }

    /// The payload as complex f32 samples (element size must be 8).
    pub fn samples(&self) -> Result<&[num_complex::Complex32], CodecError> {
        frame::bytes_as_samples(self.payload())
    }
}

/// Reused send buffers: frames of 32 MiB and more are above glibc's largest mmap threshold,
/// so a fresh buffer per frame would be mmap'ed, page-faulted and zeroed every time (this
/// halved the throughput at 32 MiB). A buffer returns here when Zenoh is done with it.
#[derive(Clone, Debug, Default)]
struct BufPool(Arc<Mutex<Vec<Vec<u8>>>>);

const POOLED_BUFFERS: usize = 4;

impl BufPool {
    fn take(&self, capacity: usize) -> Vec<u8> {
        let mut v = self
            .0
            .lock()
            .ok()
            .and_then(|mut p| p.pop())
            .unwrap_or_default();
        v.clear();
        v.reserve(capacity);
        v
    }
}

/// A pooled buffer handed to Zenoh (as `bytes::Bytes`) without a copy.
struct PooledBuf {
    buf: Vec<u8>,
    pool: BufPool,
}

impl AsRef<[u8]> for PooledBuf {
    fn as_ref(&self) -> &[u8] {
        &self.buf
    }
}

impl Drop for PooledBuf {
    fn drop(&mut self) {
        let buf = std::mem::take(&mut self.buf);
        if let Ok(mut p) = self.pool.0.lock() {
            if p.len() < POOLED_BUFFERS {
                p.push(buf);
            }
        }
    }
}

/// A publisher of raw frames on Zenoh.
pub struct ZenohFramePublisher {
    publisher: zenoh::pubsub::Publisher<'static>,
    key: String,
    counters: Arc<Counters>,
    pool: BufPool,
}

impl ZenohFramePublisher {
    /// Publishes a frame (one copy: prefix + payload into a reused buffer).
    pub fn put(&self, header: &FrameHeader, payload: &[u8]) -> Result<(), NetError> {
        header
            .validate(payload.len(), frame::MAX_FRAME_HARD_LIMIT)
            .map_err(|source| NetError::Codec {
                key: self.key.clone(),
                source,
            })?;
        let mut buf = self.pool.take(WIRE_PREFIX_LEN + payload.len());
        buf.extend_from_slice(&header.to_wire_prefix());
        buf.extend_from_slice(payload);
        let len = buf.len();
        let bytes = bytes::Bytes::from_owner(PooledBuf {
            buf,
            pool: self.pool.clone(),
        });
        match self.publisher.put(ZBytes::from(bytes)).wait() {
            Ok(()) => {
                self.counters.on_sent(len);
                Ok(())
            }
            Err(e) => {
                self.counters.on_send_error();
                Err(zerr("put", &self.key, e))
            }
        }
    }

    /// Publishes a frame whose payload is owned by `owner` (e.g. an iceoryx2
    /// [`crate::iox::Frame`]) without copying it: Zenoh reads the payload in place while it
    /// sends it, and `owner` is dropped when Zenoh no longer needs it.
    pub fn put_owned<O>(&self, header: &FrameHeader, owner: O) -> Result<(), NetError>
    where
        O: AsRef<[u8]> + Send + 'static,
    {
        let payload_len = owner.as_ref().len();
        header
            .validate(payload_len, frame::MAX_FRAME_HARD_LIMIT)
            .map_err(|source| NetError::Codec {
                key: self.key.clone(),
                source,
            })?;
        let mut writer = ZBytes::writer();
        writer.append(ZBytes::from(header.to_wire_prefix().to_vec()));
        writer.append(ZBytes::from(bytes::Bytes::from_owner(owner)));
        let len = WIRE_PREFIX_LEN + payload_len;
        match self.publisher.put(writer.finish()).wait() {
            Ok(()) => {
                self.counters.on_sent(len);
                Ok(())
            }
            Err(e) => {
                self.counters.on_send_error();
                Err(zerr("put", &self.key, e))
            }
        }
    }

    /// Whether a subscriber this publisher may deliver to currently matches its key (with
    /// `Locality::Remote`: a subscriber of another session).
    pub fn has_remote_subscribers(&self) -> bool {
        self.publisher
            .matching_status()
            .wait()
            .map(|m| m.matching())
            .unwrap_or(true)
    }

    /// Publishes an already encoded payload as is (also used to inject malformed payloads in
    /// tests).
    pub fn put_raw(&self, bytes: Vec<u8>) -> Result<(), NetError> {
        let len = bytes.len();
        match self.publisher.put(ZBytes::from(bytes)).wait() {
            Ok(()) => {
                self.counters.on_sent(len);
                Ok(())
            }
            Err(e) => {
                self.counters.on_send_error();
                Err(zerr("put", &self.key, e))
            }
        }
    }

    /// Counters of this publisher.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }
}

/// A subscriber of raw frames on Zenoh.
pub struct ZenohFrameSubscriber {
    _subscriber: zenoh::pubsub::Subscriber<()>,
    rx: Receiver<ZenohFrame>,
    counters: Arc<Counters>,
    log: Arc<BadPayloadLog>,
    verify_checksum: bool,
    key: String,
}

impl ZenohFrameSubscriber {
    /// Waits up to `timeout` for the next good frame, without copying its payload (the
    /// checksum, if enabled, is verified slice by slice).
    pub fn recv_frame_timeout(&self, timeout: Duration) -> Option<ZenohFrame> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            let f = self.rx.recv_timeout(left).ok()?;
            if self.verify_checksum {
                if let Err(e) = f.verify_checksum() {
                    self.counters.on_malformed();
                    self.log.log(&self.key, f.sample.payload().len(), &e);
                    continue;
                }
            }
            self.counters.on_delivered();
            return Some(f);
        }
    }

    /// Waits up to `timeout` for the next good frame, copied once into an aligned buffer.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<OwnedFrame> {
        let f = self.recv_frame_timeout(timeout)?;
        match f.to_owned_frame() {
            Ok(o) => Some(o),
            Err(e) => {
                // cannot happen for a frame whose header was checked; counted if it does
                self.counters.on_malformed();
                self.log.log(&self.key, f.sample.payload().len(), &e);
                None
            }
        }
    }

    /// Counters of this subscriber (`delivered` counts frames handed out, `malformed`
    /// includes checksum failures found when they are taken).
    pub fn counters(&self) -> &Counters {
        &self.counters
    }
}

/// A frame received over Zenoh, still in Zenoh's buffers (possibly many slices).
pub struct ZenohFrame {
    /// The checked header.
    pub header: FrameHeader,
    sample: Sample,
}

impl ZenohFrame {
    /// The payload as consecutive slices (no copy).
    pub fn payload_chunks(&self) -> Vec<&[u8]> {
        split_frame_payload(self.sample.payload(), usize::MAX)
            .map(|(_, c)| c)
            .unwrap_or_default()
    }

    /// Verifies the CRC (if present) over the slices.
    pub fn verify_checksum(&self) -> Result<(), CodecError> {
        if !self.header.has_checksum() {
            return Ok(());
        }
        let mut h = crc32fast::Hasher::new();
        for c in self.payload_chunks() {
            h.update(c);
        }
        let actual = h.finalize();
        if actual != self.header.checksum {
            return Err(CodecError::Checksum {
                expected: self.header.checksum,
                actual,
            });
        }
        Ok(())
    }

    /// Copies the payload into an 8-byte-aligned [`OwnedFrame`].
    pub fn to_owned_frame(&self) -> Result<OwnedFrame, CodecError> {
        let len = usize::try_from(self.header.payload_len).unwrap_or(usize::MAX);
        let mut words = vec![0u64; len.div_ceil(8)];
        let dst = bytemuck::cast_slice_mut::<u64, u8>(&mut words);
        let mut written = 0usize;
        for c in self.payload_chunks() {
            let end = written + c.len();
            let Some(d) = dst.get_mut(written..end) else {
                return Err(CodecError::LengthMismatch {
                    declared: len as u64,
                    actual: end as u64,
                });
            };
            d.copy_from_slice(c);
            written = end;
        }
        if written != len {
            return Err(CodecError::LengthMismatch {
                declared: len as u64,
                actual: written as u64,
            });
        }
        Ok(OwnedFrame {
            header: self.header,
            words,
        })
    }
}

/// Splits a Zenoh frame payload into its checked header and the payload slices (no copy).
pub fn split_frame_payload(
    payload: &ZBytes,
    max_payload: usize,
) -> Result<(FrameHeader, Vec<&[u8]>), CodecError> {
    let total = payload.len();
    if total > WIRE_PREFIX_LEN.saturating_add(max_payload) {
        return Err(CodecError::TooLarge {
            what: "frame",
            len: total as u64,
            limit: WIRE_PREFIX_LEN.saturating_add(max_payload) as u64,
        });
    }
    let mut prefix = [0u8; WIRE_PREFIX_LEN];
    let mut filled = 0usize;
    let mut chunks = Vec::new();
    for slice in payload.slices() {
        let mut s = slice;
        if filled < WIRE_PREFIX_LEN {
            let take = (WIRE_PREFIX_LEN - filled).min(s.len());
            prefix[filled..filled + take].copy_from_slice(&s[..take]);
            filled += take;
            s = &s[take..];
        }
        if !s.is_empty() {
            chunks.push(s);
        }
    }
    if filled < WIRE_PREFIX_LEN {
        return Err(CodecError::TooShort { len: total });
    }
    let header = FrameHeader::from_wire_prefix(&prefix, total, max_payload)?;
    Ok((header, chunks))
}
