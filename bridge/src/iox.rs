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
//! and counted ([`Counters::snapshot`]`.dropped` of the publisher), and the subscriber sees
//! the gap in the sequence numbers (`missed`).
//!
//! Stale resources of dead processes are removed when a [`FrameNode`] is created (and again
//! whenever a service is opened). [`IoxEnv::isolated`] gives tests their own root directory
//! and shared-memory prefix so they can run in parallel.

use std::cell::{Cell, RefCell};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::BackpressureAction;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::service::port_factory::event as event_factory;
use iceoryx2::service::port_factory::publish_subscribe as ps_factory;
use num_complex::Complex32;

use crate::counters::{BadPayloadLog, Counters};
use crate::envelope::CodecError;
use crate::frame::{self, FrameHeader, FrameMeta};
use crate::seq::{SeqObservation, SeqTracker};

/// Errors of the iceoryx2 layer; each names the service and the step that failed.
#[derive(Debug, thiserror::Error)]
pub enum IoxError {
    /// An iceoryx2 call failed.
    #[error("iceoryx2: {step} for {service:?} failed: {reason}")]
    Iceoryx {
        /// What was being done.
        step: &'static str,
        /// Service (or node) name.
        service: String,
        /// iceoryx2's error.
        reason: String,
    },
    /// A specification value is invalid.
    #[error("invalid frame service spec for {service:?}: {field} {reason}")]
    Spec {
        /// Service name.
        service: String,
        /// Field name.
        field: &'static str,
        /// Why.
        reason: String,
    },
    /// A frame is inconsistent.
    #[error("frame on {service:?}: {source}")]
    Frame {
        /// Service name.
        service: String,
        /// What was wrong.
        source: CodecError,
    },
}

fn ierr(step: &'static str, service: &str, e: impl std::fmt::Debug) -> IoxError {
    IoxError::Iceoryx {
        step,
        service: service.to_string(),
        reason: format!("{e:?}"),
    }
}

/// Command-line flags selecting the iceoryx2 environment (flatten into a clap parser).
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct IoxArgs {
    /// Root directory of iceoryx2's files (default: iceoryx2's own, /tmp/iceoryx2).
    #[arg(id = "iox_root", long = "iox-root", value_name = "DIR")]
    pub root: Option<PathBuf>,
    /// Prefix of every iceoryx2 resource name (default: "iox2_"); processes only see each
    /// other with the same root and prefix.
    #[arg(id = "iox_prefix", long = "iox-prefix", value_name = "PREFIX")]
    pub prefix: Option<String>,
    /// An iceoryx2 configuration file (TOML); default: iceoryx2's built-in defaults.
    #[arg(id = "iox_config", long = "iox-config", value_name = "FILE")]
    pub config: Option<PathBuf>,
}

impl IoxArgs {
    /// The flags as command-line arguments (to pass them on to a child process).
    pub fn to_cli_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(c) = &self.config {
            v.push("--iox-config".into());
            v.push(c.display().to_string());
        }
        if let Some(r) = &self.root {
            v.push("--iox-root".into());
            v.push(r.display().to_string());
        }
        if let Some(p) = &self.prefix {
            v.push("--iox-prefix".into());
            v.push(p.clone());
        }
        v
    }

    /// The environment these flags select.
    pub fn env(&self) -> Result<IoxEnv, IoxError> {
        let mut config = match &self.config {
            Some(file) => {
                let s = file.display().to_string();
                let path = FilePath::new(s.as_bytes())
                    .map_err(|e| ierr("config path (--iox-config)", &s, e))?;
                Config::from_file(&path).map_err(|e| ierr("read config (--iox-config)", &s, e))?
            }
            None => Config::default(),
        };
        if let Some(p) = &self.prefix {
            config.global.prefix =
                FileName::new(p.as_bytes()).map_err(|e| ierr("set prefix (--iox-prefix)", p, e))?;
        }
        if let Some(r) = &self.root {
            std::fs::create_dir_all(r)
                .map_err(|e| ierr("create root (--iox-root)", &r.display().to_string(), e))?;
            let s = r.display().to_string();
            let path = iceoryx2::prelude::Path::new(s.as_bytes())
                .map_err(|e| ierr("set root (--iox-root)", &s, e))?;
            config.global.set_root_path(&path);
        }
        Ok(IoxEnv { config })
    }
}

/// The iceoryx2 configuration processes share (root directory + resource prefix).
#[derive(Clone, Debug)]
pub struct IoxEnv {
    config: Config,
}

impl IoxEnv {
    /// iceoryx2's built-in defaults (root `/tmp/iceoryx2`, prefix `iox2_`).
    pub fn default_env() -> Self {
        IoxEnv {
            config: Config::default(),
        }
    }

    /// An isolated environment: files under `root`, shared memory named `<prefix>...`.
    /// Use a unique prefix per test (e.g. `t<pid>_<n>_`).
    pub fn isolated(root: &Path, prefix: &str) -> Result<Self, IoxError> {
        IoxArgs {
            root: Some(root.to_path_buf()),
            prefix: Some(prefix.to_string()),
            config: None,
        }
        .env()
    }

    /// The iceoryx2 configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }
}

/// Sets iceoryx2's own log level (its messages go to `tracing`): `IOX2_LOG_LEVEL` if set,
/// else WARN.
pub fn init_iceoryx_logging() {
    set_log_level_from_env_or(LogLevel::Warn);
}

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

/// The iceoryx2 service type of every cellsar port: the IPC service with mutex-protected
/// ports, so nodes, publishers, subscribers and received frames are `Send` (usable from worker
/// threads, and a received frame can be handed to Zenoh without a copy). It uses the same
/// shared-memory resources as `ipc::Service` and interoperates with it.
pub type IoxService = ipc_threadsafe::Service;

type FrameService = ps_factory::PortFactory<IoxService, [u8], FrameHeader>;
type EventService = event_factory::PortFactory<IoxService>;

/// An iceoryx2 node of this process.
pub struct FrameNode {
    node: Node<IoxService>,
    name: String,
}

impl std::fmt::Debug for FrameNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameNode")
            .field("name", &self.name)
            .finish()
    }
}

/// What the start-up cleanup of dead processes' resources did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// Dead nodes whose resources were removed.
    pub cleaned: u64,
    /// Dead nodes that could not be cleaned (permissions or in use).
    pub failed: u64,
}

impl FrameNode {
    /// Creates a node named `name` in `env` and removes the resources of dead nodes (processes
    /// that crashed or were killed) so that their services, publishers and shared memory do
    /// not block this one.
    pub fn new(env: &IoxEnv, name: &str) -> Result<(Self, CleanupReport), IoxError> {
        let node_name = NodeName::new(name).map_err(|e| ierr("node name", name, e))?;
        // Clean up explicitly (below) rather than silently inside the builder, to report it.
        let mut config = env.config().clone();
        config.global.node.cleanup_dead_nodes_on_creation = false;
        let node = NodeBuilder::new()
            .name(&node_name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<IoxService>()
            .map_err(|e| ierr("create node", name, e))?;
        let state = node.try_cleanup_dead_nodes();
        let report = CleanupReport {
            cleaned: state.cleanups,
            failed: state.failed_cleanups,
        };
        if report.cleaned > 0 || report.failed > 0 {
            tracing::info!(
                node = name,
                cleaned = report.cleaned,
                failed = report.failed,
                "removed stale iceoryx2 resources of dead processes"
            );
        }
        Ok((
            FrameNode {
                node,
                name: name.to_string(),
            },
            report,
        ))
    }

    /// Node name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The underlying iceoryx2 node.
    pub fn node(&self) -> &Node<IoxService> {
        &self.node
    }

    fn services(&self, spec: &FrameServiceSpec) -> Result<(FrameService, EventService), IoxError> {
        spec.validate()?;
        let name = ServiceName::new(&spec.name).map_err(|e| ierr("service name", &spec.name, e))?;
        let align = Alignment::new(8).ok_or_else(|| ierr("alignment", &spec.name, "8"))?;
        let ps = self
            .node
            .service_builder(&name)
            .publish_subscribe::<[u8]>()
            .user_header::<FrameHeader>()
            .payload_alignment(align)
            .max_publishers(spec.max_publishers)
            .max_subscribers(spec.max_subscribers)
            .max_nodes(spec.max_nodes)
            .history_size(spec.history)
            .subscriber_max_buffer_size(spec.subscriber_buffer)
            .subscriber_max_borrowed_samples(spec.subscriber_max_borrowed)
            .enable_safe_overflow(false)
            .open_or_create()
            .map_err(|e| ierr("open or create publish-subscribe service", &spec.name, e))?;
        let ev = self
            .node
            .service_builder(&name)
            .event()
            .max_notifiers(spec.max_publishers)
            .max_listeners(spec.max_subscribers)
            .max_nodes(spec.max_nodes)
            .open_or_create()
            .map_err(|e| ierr("open or create event service", &spec.name, e))?;
        Ok((ps, ev))
    }

    /// Creates a publisher on the frame service `spec` (creating the service if needed).
    pub fn publisher(
        &self,
        spec: &FrameServiceSpec,
        opts: FramePublisherOptions,
    ) -> Result<FramePublisher, IoxError> {
        let (service, event) = self.services(spec)?;
        let counters = Arc::new(Counters::default());
        let full = Arc::new(AtomicU64::new(0));
        let f = full.clone();
        let builder = service
            .publisher_builder()
            .initial_max_slice_len(spec.max_payload_bytes)
            .allocation_strategy(AllocationStrategy::Static)
            .max_loaned_samples(spec.publisher_max_loaned);
        let builder = match opts.backpressure {
            Backpressure::Discard => builder
                .backpressure_strategy(BackpressureStrategy::DiscardData)
                .set_backpressure_handler(move |_info: &iceoryx2::port::BackpressureInfo| {
                    f.fetch_add(1, Ordering::Relaxed);
                    BackpressureAction::DiscardData
                }),
            Backpressure::Block => {
                builder.backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
            }
        };
        let publisher = builder
            .create()
            .map_err(|e| ierr("create publisher", &spec.name, e))?;
        let notifier = event
            .notifier_builder()
            .create()
            .map_err(|e| ierr("create notifier", &spec.name, e))?;
        Ok(FramePublisher {
            service,
            _event: event,
            publisher,
            notifier,
            counters,
            full,
            spec: spec.clone(),
            opts,
        })
    }

    /// Creates a subscriber (and its listener) on the frame service `spec`.
    pub fn subscriber(&self, spec: &FrameServiceSpec) -> Result<FrameSubscriber, IoxError> {
        let (service, event) = self.services(spec)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(spec.subscriber_buffer)
            .create()
            .map_err(|e| ierr("create subscriber", &spec.name, e))?;
        let listener = event
            .listener_builder()
            .create()
            .map_err(|e| ierr("create listener", &spec.name, e))?;
        Ok(FrameSubscriber {
            _service: service,
            _event: event,
            subscriber,
            listener,
            counters: Counters::default(),
            log: BadPayloadLog::default(),
            seq: RefCell::new(SeqTracker::new()),
            missed: Cell::new(0),
            spec: spec.clone(),
            ignore_origin: Cell::new(None),
        })
    }
}

/// What a publisher does when a subscriber's buffer is full.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Backpressure {
    /// Skip that subscriber for this frame and count it (never stalls; the default).
    #[default]
    Discard,
    /// Wait until the subscriber takes a frame (lossless, but a frozen subscriber stalls the
    /// publisher: only for benchmarks and strictly paired pipelines).
    Block,
}

/// Options of a frame publisher.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FramePublisherOptions {
    /// Compute the CRC-32 of every payload into the header.
    pub checksum: bool,
    /// Behaviour on full subscriber buffers.
    pub backpressure: Backpressure,
}

impl Default for FramePublisherOptions {
    fn default() -> Self {
        FramePublisherOptions {
            checksum: true,
            backpressure: Backpressure::Discard,
        }
    }
}

/// Outcome of one send.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SendReport {
    /// Subscribers the frame was delivered to.
    pub delivered: usize,
    /// Subscribers skipped because their buffer was full.
    pub skipped_full: u64,
}

/// Publishes frames on one frame service and notifies its listeners.
pub struct FramePublisher {
    service: FrameService,
    _event: EventService,
    publisher: Publisher<IoxService, [u8], FrameHeader>,
    notifier: Notifier<IoxService>,
    counters: Arc<Counters>,
    full: Arc<AtomicU64>,
    spec: FrameServiceSpec,
    opts: FramePublisherOptions,
}

impl FramePublisher {
    /// Sends a copy of `payload` (one copy into shared memory).
    pub fn send_bytes(&self, meta: &FrameMeta, payload: &[u8]) -> Result<SendReport, IoxError> {
        let checksum = self.opts.checksum.then(|| frame::checksum(payload));
        let header = self.header(meta, payload.len(), checksum)?;
        let sample = self
            .publisher
            .loan_slice_uninit(payload.len())
            .map_err(|e| ierr("loan", &self.spec.name, e))?;
        let mut sample = sample.write_from_slice(payload);
        *sample.user_header_mut() = header;
        self.finish(sample, true)
    }

    /// Sends a copy of complex samples.
    pub fn send_samples(
        &self,
        meta: &FrameMeta,
        samples: &[Complex32],
    ) -> Result<SendReport, IoxError> {
        self.send_bytes(meta, frame::samples_as_bytes(samples))
    }

    /// Loans a zero-initialised frame of `meta`'s size, lets `fill` write it in place, and
    /// sends it (no copy besides the zeroing).
    pub fn send_with<F: FnOnce(&mut [u8])>(
        &self,
        meta: &FrameMeta,
        fill: F,
    ) -> Result<SendReport, IoxError> {
        let len = meta.payload_len().map_err(|source| IoxError::Frame {
            service: self.spec.name.clone(),
            source,
        })?;
        self.check_len(len)?;
        let sample = self
            .publisher
            .loan_slice_uninit(len)
            .map_err(|e| ierr("loan", &self.spec.name, e))?;
        let mut sample = sample.write_from_fn(|_| 0u8);
        fill(sample.payload_mut());
        let checksum = self
            .opts
            .checksum
            .then(|| frame::checksum(sample.payload()));
        let header = self.header(meta, len, checksum)?;
        *sample.user_header_mut() = header;
        self.finish(sample, true)
    }

    /// Sends a frame whose header was made elsewhere (the bridge re-publishing a remote
    /// frame), writing the payload from consecutive chunks (e.g. the slices of a Zenoh
    /// payload). The header is checked against the total length.
    pub fn send_chunks<'a, I>(
        &self,
        header: &FrameHeader,
        chunks: I,
    ) -> Result<SendReport, IoxError>
    where
        I: IntoIterator<Item = &'a [u8]>,
    {
        let len = usize::try_from(header.payload_len).unwrap_or(usize::MAX);
        header
            .validate(len, self.spec.max_payload_bytes)
            .map_err(|source| IoxError::Frame {
                service: self.spec.name.clone(),
                source,
            })?;
        let mut sample = self
            .publisher
            .loan_slice_uninit(len)
            .map_err(|e| ierr("loan", &self.spec.name, e))?;
        let dst = sample.payload_mut();
        let mut written = 0usize;
        for chunk in chunks {
            let end = written + chunk.len();
            let Some(d) = dst.get_mut(written..end) else {
                return Err(IoxError::Frame {
                    service: self.spec.name.clone(),
                    source: CodecError::LengthMismatch {
                        declared: len as u64,
                        actual: end as u64,
                    },
                });
            };
            // SAFETY: `d` is exactly `chunk.len()` elements long (the range above);
            // `MaybeUninit<u8>` has the layout of `u8`; the source (a Zenoh buffer) and the
            // destination (this publisher's loaned shared-memory sample) do not overlap.
            unsafe {
                std::ptr::copy_nonoverlapping(
                    chunk.as_ptr(),
                    d.as_mut_ptr().cast::<u8>(),
                    chunk.len(),
                );
            }
            written = end;
        }
        if written != len {
            return Err(IoxError::Frame {
                service: self.spec.name.clone(),
                source: CodecError::LengthMismatch {
                    declared: len as u64,
                    actual: written as u64,
                },
            });
        }
        // SAFETY: every one of the `len` bytes of the loaned slice was written by the loop
        // above (the chunks cover 0..len exactly, checked by `written == len`).
        let mut sample = unsafe { sample.assume_init() };
        *sample.user_header_mut() = *header;
        self.finish(sample, false)
    }

    fn check_len(&self, len: usize) -> Result<(), IoxError> {
        if len > self.spec.max_payload_bytes {
            return Err(IoxError::Frame {
                service: self.spec.name.clone(),
                source: CodecError::TooLarge {
                    what: "frame payload",
                    len: len as u64,
                    limit: self.spec.max_payload_bytes as u64,
                },
            });
        }
        Ok(())
    }

    fn header(
        &self,
        meta: &FrameMeta,
        len: usize,
        checksum: Option<u32>,
    ) -> Result<FrameHeader, IoxError> {
        self.check_len(len)?;
        let header = meta.header(checksum).map_err(|source| IoxError::Frame {
            service: self.spec.name.clone(),
            source,
        })?;
        header
            .validate(len, self.spec.max_payload_bytes)
            .map_err(|source| IoxError::Frame {
                service: self.spec.name.clone(),
                source,
            })?;
        Ok(header)
    }

    /// Sends; `stamp` sets `time_unix_ns` to "now" just before the hand-off (so a receiver
    /// measures the hand-off, not the filling).
    fn finish(
        &self,
        mut sample: iceoryx2::sample_mut::SampleMut<IoxService, [u8], FrameHeader>,
        stamp: bool,
    ) -> Result<SendReport, IoxError> {
        let len = sample.payload().len();
        if stamp {
            sample.user_header_mut().time_unix_ns = crate::envelope::now_unix_ns();
        }
        let before = self.full.load(Ordering::Relaxed);
        let delivered = match sample.send() {
            Ok(n) => n,
            Err(e) => {
                self.counters.on_send_error();
                return Err(ierr("send", &self.spec.name, e));
            }
        };
        let skipped_full = self.full.load(Ordering::Relaxed) - before;
        self.counters.on_sent(len);
        if skipped_full > 0 {
            self.counters.on_dropped(skipped_full);
        }
        if let Err(e) = self.notifier.notify() {
            tracing::warn!(service = %self.spec.name, error = ?e, "notify failed");
        }
        Ok(SendReport {
            delivered,
            skipped_full,
        })
    }

    /// The unique id of this publisher (as carried by the samples it sends).
    pub fn id(&self) -> u128 {
        self.publisher.id().value()
    }

    /// Subscribers currently registered with the service.
    pub fn subscriber_count(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }

    /// Waits up to `timeout` until at least `n` subscribers are registered, then `settle`
    /// more: a subscriber connects to a new publisher on its next receive or wake-up, and
    /// frames sent before that (with no history) never reach it. Returns whether `n` were
    /// reached.
    pub fn wait_for_subscribers(&self, n: usize, timeout: Duration, settle: Duration) -> bool {
        let deadline = std::time::Instant::now() + timeout;
        while self.subscriber_count() < n {
            if std::time::Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(settle);
        true
    }

    /// Counters: `sent`, `bytes_out`, `dropped` (= deliveries skipped because a subscriber's
    /// buffer was full), `send_errors`.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The spec of the service.
    pub fn spec(&self) -> &FrameServiceSpec {
        &self.spec
    }
}

/// A frame taken from a subscriber; the shared-memory sample is returned when it is dropped.
pub struct Frame {
    sample: Sample<IoxService, [u8], FrameHeader>,
}

impl std::fmt::Debug for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Frame")
            .field("header", self.header())
            .finish_non_exhaustive()
    }
}

impl Frame {
    /// The frame header.
    pub fn header(&self) -> &FrameHeader {
        self.sample.user_header()
    }

    /// The payload bytes (in shared memory, no copy).
    pub fn payload(&self) -> &[u8] {
        self.sample.payload()
    }

    /// The payload as complex f32 samples (no copy).
    pub fn samples(&self) -> Result<&[Complex32], CodecError> {
        frame::bytes_as_samples(self.payload())
    }

    /// Verifies the payload's CRC (if the publisher computed one).
    pub fn verify_checksum(&self) -> Result<(), CodecError> {
        self.header().verify_checksum(self.payload())
    }

    /// Id of the publisher that sent it.
    pub fn origin(&self) -> u128 {
        self.sample.origin().value()
    }
}

impl AsRef<[u8]> for Frame {
    fn as_ref(&self) -> &[u8] {
        self.payload()
    }
}

/// Receives frames from one frame service.
pub struct FrameSubscriber {
    _service: FrameService,
    _event: EventService,
    subscriber: Subscriber<IoxService, [u8], FrameHeader>,
    listener: Listener<IoxService>,
    counters: Counters,
    log: BadPayloadLog,
    seq: RefCell<SeqTracker>,
    missed: Cell<u64>,
    spec: FrameServiceSpec,
    ignore_origin: Cell<Option<u128>>,
}

impl FrameSubscriber {
    /// Silently skips frames sent by the publisher with this id (the bridge uses it so it
    /// never forwards what it published itself).
    pub fn ignore_origin(&self, publisher_id: u128) {
        self.ignore_origin.set(Some(publisher_id));
    }

    /// Takes the next good frame, if any. Malformed frames (inconsistent header) are counted,
    /// logged and skipped; sequence gaps are counted in [`FrameSubscriber::missed`].
    pub fn receive(&self) -> Result<Option<Frame>, IoxError> {
        loop {
            let Some(sample) = self
                .subscriber
                .receive()
                .map_err(|e| ierr("receive", &self.spec.name, e))?
            else {
                return Ok(None);
            };
            let origin = sample.origin().value();
            if Some(origin) == self.ignore_origin.get() {
                continue;
            }
            let f = Frame { sample };
            self.counters.on_received(f.payload().len());
            if let Err(e) = f
                .header()
                .validate(f.payload().len(), self.spec.max_payload_bytes)
            {
                self.counters.on_malformed();
                self.log.log(&self.spec.name, f.payload().len(), &e);
                continue;
            }
            let observed = self.seq.borrow_mut().observe(origin, f.header().seq);
            match observed {
                SeqObservation::Gap { missing } => self.missed.set(self.missed.get() + missing),
                SeqObservation::Duplicate | SeqObservation::First | SeqObservation::InOrder => {}
            }
            self.counters.on_delivered();
            return Ok(Some(f));
        }
    }

    /// Waits up to `timeout` for a notification from a publisher (returns at once if one is
    /// pending). Returns whether one arrived.
    /// A signal interrupting the wait (e.g. SIGSTOP/SIGCONT) counts as "nothing arrived".
    pub fn wait(&self, timeout: Duration) -> Result<bool, IoxError> {
        match self.listener.timed_wait(|_| {}, timeout) {
            Ok(n) => Ok(n > 0),
            Err(iceoryx2::port::listener::ListenerWaitError::InterruptSignal) => Ok(false),
            Err(e) => Err(ierr("wait", &self.spec.name, e)),
        }
    }

    /// The next frame, waiting up to `timeout` for one.
    pub fn receive_timeout(&self, timeout: Duration) -> Result<Option<Frame>, IoxError> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if let Some(f) = self.receive()? {
                return Ok(Some(f));
            }
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.wait(left)?;
        }
    }

    /// Clears pending notifications without waiting.
    pub fn clear_notifications(&self) -> Result<(), IoxError> {
        self.listener
            .try_wait(|_| {})
            .map(|_| ())
            .map_err(|e| ierr("try_wait", &self.spec.name, e))
    }

    /// The listener (to attach to an iceoryx2 `WaitSet`).
    pub fn listener(&self) -> &Listener<IoxService> {
        &self.listener
    }

    /// Frames that never arrived here, from gaps in the publishers' sequence numbers.
    pub fn missed(&self) -> u64 {
        self.missed.get()
    }

    /// Duplicate sequence numbers seen.
    pub fn duplicates(&self) -> u64 {
        self.seq.borrow().duplicates()
    }

    /// Counters (`received`, `delivered`, `malformed`).
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The spec of the service.
    pub fn spec(&self) -> &FrameServiceSpec {
        &self.spec
    }
}
