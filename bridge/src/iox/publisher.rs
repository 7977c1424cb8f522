//! Frame publishers ([`FrameNode::publisher`], [`FramePublisher`]): a loaned shared-memory
//! sample filled by copy, in place or from chunks, then sent and notified.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::BackpressureAction;
use iceoryx2::prelude::*;
use num_complex::Complex32;

use super::error::ierr;
use super::{EventService, FrameNode, FrameService, FrameServiceSpec, IoxError, IoxService};
use crate::counters::Counters;
use crate::envelope::CodecError;
use crate::frame::{self, FrameHeader, FrameMeta};

impl FrameNode {
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
            error: source,
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
                error: source,
            })?;
        let mut sample = self
            .publisher
            .loan_slice_uninit(len)
            .map_err(|e| ierr("loan", &self.spec.name, e))?;
        let dst = sample.payload_mut();
        let mut written = 0usize;
        for chunk in chunks {
            let end = written.saturating_add(chunk.len());
            let Some(d) = dst.get_mut(written..end) else {
                return Err(IoxError::Frame {
                    service: self.spec.name.clone(),
                    error: CodecError::LengthMismatch {
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
                error: CodecError::LengthMismatch {
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
                error: CodecError::TooLarge {
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
            error: source,
        })?;
        header
            .validate(len, self.spec.max_payload_bytes)
            .map_err(|source| IoxError::Frame {
                service: self.spec.name.clone(),
                error: source,
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
        let skipped_full = self.full.load(Ordering::Relaxed).wrapping_sub(before);
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
