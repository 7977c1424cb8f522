//! Frame subscribers ([`FrameNode::subscriber`], [`FrameSubscriber`]) and the frames they
//! hand out ([`Frame`], in shared memory until dropped).

use std::cell::{Cell, RefCell};
use std::time::Duration;

use iceoryx2::port::listener::Listener;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::sample::Sample;
use num_complex::Complex32;

use super::error::ierr;
use super::{EventService, FrameNode, FrameService, FrameServiceSpec, IoxError, IoxService};
use crate::counters::{BadPayloadLog, Counters};
use crate::envelope::CodecError;
use crate::frame::{self, FrameHeader};
use crate::seq::{SeqObservation, SeqTracker};

impl FrameNode {
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
                SeqObservation::Gap { missing } => {
                    // a peer chooses the numbers: the total saturates, never overflows
                    self.missed.set(self.missed.get().saturating_add(missing))
                }
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

#[cfg(test)]
mod tests {
    use super::super::{FrameNode, FramePublisherOptions, FrameServiceSpec, IoxEnv};
    use crate::frame::FrameMeta;
    use crate::MissionId;
    use std::time::Duration;

    /// Sequence numbers chosen by a publisher (a peer) at the extremes: 0, u64::MAX, a wrap
    /// around to 0, and gaps that would overflow a plain sum: nothing panics, every frame is
    /// delivered, and the missed count saturates.
    /// Removes the shared-memory files under a prefix when dropped: iceoryx2 leaves its global
    /// management segment (`/dev/shm/<prefix>…global_mgmt`) behind after its last node.
    struct ShmCleanup(String);

    impl Drop for ShmCleanup {
        fn drop(&mut self) {
            let Ok(entries) = std::fs::read_dir("/dev/shm") else {
                return;
            };
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().starts_with(&self.0) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
    }

    #[test]
    fn extreme_sequence_numbers_saturate_the_missed_count() {
        let dir = tempfile::tempdir().unwrap();
        let prefix = format!("bt{}_", std::process::id());
        // declared first, so dropped after every iceoryx2 object of the test
        let _cleanup = ShmCleanup(prefix.clone());
        let env = IoxEnv::isolated(dir.path(), &prefix).unwrap();
        let (node, _) = FrameNode::new(&env, "seq-extremes").unwrap();
        let spec = FrameServiceSpec {
            subscriber_buffer: 8,
            ..FrameServiceSpec::new("cellsar/test/seq-extremes", 64)
        };
        let sub = node.subscriber(&spec).unwrap();
        let publisher = node
            .publisher(&spec, FramePublisherOptions::default())
            .unwrap();
        assert!(publisher.wait_for_subscribers(
            1,
            Duration::from_secs(5),
            Duration::from_millis(50)
        ));
        // the subscriber connects to the new publisher on its next receive
        assert!(sub.receive().unwrap().is_none());
        let mut got = Vec::new();
        for seq in [0, u64::MAX, 0, 1, u64::MAX - 1, u64::MAX] {
            let meta = FrameMeta::bytes(9, MissionId(1), seq, 8).unwrap();
            publisher.send_bytes(&meta, &[7u8; 8]).unwrap();
            let f = sub
                .receive_timeout(Duration::from_secs(5))
                .unwrap()
                .expect("a frame");
            got.push(f.header().seq);
        }
        assert_eq!(got, [0, u64::MAX, 0, 1, u64::MAX - 1, u64::MAX]);
        // 0 -> MAX misses MAX - 1; MAX -> 0 is in order (the counter wrapped); 1 -> MAX - 1
        // misses MAX - 3: the sum saturates
        assert_eq!(sub.missed(), u64::MAX);
        assert_eq!(sub.duplicates(), 0);
        assert_eq!(sub.counters().snapshot().delivered, 6);
    }
}
