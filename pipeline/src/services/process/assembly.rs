//! The processor's state of one mission ([`Run`]) and of each aperture (or look) being filled
//! from frames ([`Assembly`]).

use super::frame_key::KeyGate;
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

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
    /// The process's count of frames lost in transport or arrived malformed when it was last
    /// asked for.
    pub(super) lost_at_request: u64,
}

/// How long a mission's frames must have paused before an aperture is asked for again when
/// frames were lost in transport since its request (the transport's sequence gaps, a full
/// iceoryx2 buffer on a loaded machine): the gap is known, so waiting the whole
/// `--resend-after-s` for the echo to fall silent would only delay the run. The pause still
/// lets the echo finish what it is sending; the count is the process's, so a loss on another
/// mission's frames shortens the wait too (at worst an aperture is sent twice).
pub(super) const LOST_QUIET: Duration = Duration::from_secs(1);

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
            lost_at_request: 0,
        }
    }

    /// Whether to ask for it (again) at `now`: never asked; a failed request's retry time
    /// reached; or the mission's frames paused since `quiet_since` and the request as long
    /// ago as `resend`, or [`LOST_QUIET`] (if shorter) once the process's count of frames
    /// lost in transport or arrived malformed, `lost_now`, has grown since the request.
    pub(super) fn due(
        &self,
        now: Instant,
        quiet_since: Instant,
        resend: Duration,
        lost_now: u64,
    ) -> bool {
        match (self.requested, self.retry_at) {
            (None, _) => true,
            (Some(_), Some(t)) => now >= t,
            (Some(t), None) => {
                let wait = if lost_now > self.lost_at_request {
                    resend.min(LOST_QUIET)
                } else {
                    resend
                };
                now.saturating_duration_since(quiet_since) >= wait
                    && now.saturating_duration_since(t) >= wait
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn asked(at: Instant, lost_at_request: u64) -> Assembly {
        Assembly {
            look: None,
            first_pulse: 0,
            buf: Vec::new(),
            want: BTreeMap::new(),
            have: 0,
            requested: Some(at),
            retry_at: None,
            request_pending: false,
            attempts: 1,
            lost_at_request,
        }
    }

    #[test]
    fn an_aperture_is_asked_for_again_after_resend_or_sooner_once_frames_were_lost() {
        let t0 = Instant::now();
        let s = |x: f64| t0 + Duration::from_secs_f64(x);
        let resend = Duration::from_secs(10);
        let a = asked(t0, 3);
        // nothing lost since the request: the whole resend of quiet
        assert!(!a.due(s(9.9), t0, resend, 3));
        assert!(a.due(s(10.0), t0, resend, 3));
        // frames keep coming: not yet, however long ago the request was
        assert!(!a.due(s(30.0), s(25.0), resend, 3));
        // a frame lost since the request: LOST_QUIET of quiet is enough
        assert!(!a.due(s(0.9), t0, resend, 4));
        assert!(a.due(s(1.0), t0, resend, 4));
        // ... but only once the mission's frames paused that long
        assert!(!a.due(s(5.0), s(4.5), resend, 4));
        assert!(a.due(s(5.5), s(4.5), resend, 4));
        // and never sooner than the request plus that pause
        let b = asked(s(5.0), 3);
        assert!(!b.due(s(5.5), t0, resend, 4));
        assert!(b.due(s(6.0), t0, resend, 4));
        // a resend shorter than LOST_QUIET stays the shorter
        let short = Duration::from_millis(300);
        assert!(a.due(s(0.3), t0, short, 4));
    }

    #[test]
    fn never_asked_or_a_failed_request_follow_their_own_rules() {
        let t0 = Instant::now();
        let resend = Duration::from_secs(10);
        let mut a = asked(t0, 0);
        a.requested = None;
        assert!(a.due(t0, t0, resend, 0), "never asked: at once");
        let mut b = asked(t0, 0);
        b.retry_at = Some(t0 + Duration::from_secs(1));
        assert!(!b.due(t0 + Duration::from_millis(999), t0, resend, 5));
        assert!(b.due(t0 + Duration::from_secs(1), t0, resend, 0));
    }
}
