//! The processor's state of one mission ([`Run`]) and of each aperture (or look) being filled
//! from frames ([`Assembly`]).

use super::frame_key::KeyGate;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use bridge::Complex32;

use super::context::{ApertureOutcome, ProcContext};
use super::work::Job;
use crate::protocol::MissionMetrics;

/// An aperture (or one look) being filled from frames.
pub(super) struct Assembly {
    /// The look, when only one is asked for.
    pub(super) look: Option<usize>,
    /// Sample offset of the first pulse held (the look's first pulse for a look).
    pub(super) first_pulse: usize,
    /// The IQ, `pulses × samples`.
    pub(super) buf: Vec<Complex32>,
    /// Frames still missing: seq -> (first pulse within the aperture, pulses).
    pub(super) want: BTreeMap<u64, (usize, usize)>,
    /// Frames held.
    pub(super) have: usize,
    /// When it was last asked for.
    pub(super) requested: Option<Instant>,
    /// When to ask again after a failed request.
    pub(super) retry_at: Option<Instant>,
    /// A request is on its way.
    pub(super) request_pending: bool,
    /// Requests sent.
    pub(super) attempts: u32,
}

impl Assembly {
    /// An empty assembly of aperture `k` (or of one look of it).
    pub(super) fn new(ctx: &ProcContext, k: usize, look: Option<usize>) -> Assembly {
        let layout = &ctx.base.layout;
        let spp = layout.samples_per_pulse();
        let ap = &ctx.base.apertures[k];
        let (first_pulse, pulses) = match look {
            Some(l) => (l * ap.pulses_per_look, ap.pulses_per_look),
            None => (0, ap.pulses()),
        };
        let want = layout
            .slots(k, look)
            .into_iter()
            .map(|(s, slot)| (s, (slot.first_pulse, slot.pulses)))
            .collect();
        Assembly {
            look,
            first_pulse,
            buf: vec![Complex32::new(0.0, 0.0); pulses * spp],
            want,
            have: 0,
            requested: None,
            retry_at: None,
            request_pending: false,
            attempts: 0,
        }
    }

    /// Whether every frame is held.
    pub(super) fn complete(&self) -> bool {
        self.want.is_empty()
    }
}

/// One mission being processed.
pub(super) struct Run {
    /// The mission.
    pub(super) ctx: Arc<ProcContext>,
    /// Its state directory, if any.
    pub(super) dir: Option<PathBuf>,
    /// Finished apertures.
    pub(super) outcomes: BTreeMap<usize, ApertureOutcome>,
    /// Apertures being filled from frames.
    pub(super) assembling: BTreeMap<usize, Assembly>,
    /// The look asked for again to measure the resolution, once every aperture is done.
    pub(super) look: Option<(usize, Assembly)>,
    /// Complete assemblies waiting for the worker.
    pub(super) ready: VecDeque<Job>,
    /// The aperture the worker is processing.
    pub(super) in_worker: Option<usize>,
    /// The mission's metrics, once done.
    pub(super) metrics: Option<MissionMetrics>,
    /// Failed processing attempts per aperture.
    pub(super) failures: HashMap<usize, u32>,
    /// Why the mission was given up.
    pub(super) failed: Option<String>,
    /// Whether this process receives the mission's frames (apertures are asked for only then).
    pub(super) subscribed: bool,
    /// The resolution measurement is queued or in the worker.
    pub(super) resolving: bool,
    /// When a frame of the mission last arrived (or a request was last sent).
    pub(super) last_frame: Instant,
    /// When the plan arrived.
    pub(super) started: Instant,
    /// When the mission last made progress: its plan or a frame of it arrived.
    pub(super) last_progress: Instant,
    /// The mission's frame key from the echo, and the frames waiting for it.
    pub(super) key_gate: KeyGate,
}

impl Run {
    /// A mission with nothing done yet.
    pub(super) fn new(ctx: Arc<ProcContext>, dir: Option<PathBuf>, subscribed: bool) -> Run {
        Run {
            ctx,
            dir,
            outcomes: BTreeMap::new(),
            assembling: BTreeMap::new(),
            look: None,
            ready: VecDeque::new(),
            in_worker: None,
            metrics: None,
            failures: HashMap::new(),
            failed: None,
            subscribed,
            resolving: false,
            last_frame: Instant::now(),
            started: Instant::now(),
            last_progress: Instant::now(),
            key_gate: KeyGate::default(),
        }
    }

    /// Whether the mission may be dropped to make room for another
    /// ([`droppable`](crate::services::admission::droppable)): finished, given up, or held
    /// without progress for [`MISSION_IDLE_TIMEOUT`](crate::services::admission::MISSION_IDLE_TIMEOUT)
    /// with nothing queued or in the worker (the finished or given-up first).
    pub(super) fn droppable(&self) -> crate::services::admission::Droppable {
        crate::services::admission::droppable(
            self.metrics.is_some() || self.failed.is_some(),
            self.last_progress.elapsed(),
            !self.ready.is_empty() || self.in_worker.is_some(),
        )
    }
}
