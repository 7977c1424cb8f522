//! The processor's two helper threads: the worker, which processes one aperture (or measures
//! one look's resolution) at a time off the service loop, and the requester, which asks the
//! echo for apertures without blocking it.

use std::sync::mpsc::{Receiver, Sender};
use std::sync::Arc;
use std::time::Duration;

use bridge::envelope::Meta;
use bridge::net::QueryOptions;
use bridge::{Complex32, MissionId, ZenohNode};
use radar_sim::run::MeasuredResolution;

use super::context::{ApertureOutcome, ProcContext};
use crate::protocol::keys as pkeys;
use crate::protocol::{ApertureRequest, RequestAck};
use crate::services::radar::ServiceResult;

/// Work for the worker thread.
pub(super) enum Job {
    /// Process aperture `k` from its IQ.
    Aperture {
        /// The mission.
        ctx: Arc<ProcContext>,
        /// Aperture index.
        k: usize,
        /// Its IQ (`pulses × samples`).
        iq: Vec<Complex32>,
    },
    /// Measure the resolution on one look of aperture `k`.
    Resolution {
        /// The mission.
        ctx: Arc<ProcContext>,
        /// Aperture index.
        k: usize,
        /// Look index.
        look: usize,
        /// The look's IQ.
        iq: Vec<Complex32>,
    },
}

/// What the worker made of a [`Job`].
pub(super) enum JobResult {
    /// An aperture's outcome (or why it failed).
    Aperture(MissionId, Box<ServiceResult<ApertureOutcome>>),
    /// A resolution measurement, with the (aperture, look) it was made on.
    Resolution(
        MissionId,
        ServiceResult<Option<(MeasuredResolution, MeasuredResolution)>>,
        (usize, usize),
    ),
}

/// A request for the requester thread: ask the echo for an aperture (or one look).
pub(super) struct RequestJob {
    /// Mission.
    pub(super) mission: MissionId,
    /// Aperture index.
    pub(super) aperture: usize,
    /// One look only, or the whole aperture.
    pub(super) look: Option<usize>,
    /// Pulses per frame.
    pub(super) frame_pulses: usize,
}

/// The echo's answer to a [`RequestJob`].
pub(super) struct RequestDone {
    /// Mission.
    pub(super) mission: MissionId,
    /// Aperture index.
    pub(super) aperture: usize,
    /// One look only, or the whole aperture.
    pub(super) look: Option<usize>,
    /// The echo's acknowledgement, or why the request failed.
    pub(super) result: Result<RequestAck, String>,
}

/// The worker thread: runs jobs until either channel closes.
pub(super) fn worker(jobs: Receiver<Job>, results: Sender<JobResult>) {
    while let Ok(job) = jobs.recv() {
        let r = match job {
            Job::Aperture { ctx, k, iq } => {
                JobResult::Aperture(ctx.base.mission_id, Box::new(ctx.process(k, &iq)))
            }
            Job::Resolution { ctx, k, look, iq } => {
                JobResult::Resolution(ctx.base.mission_id, ctx.resolution(k, look, &iq), (k, look))
            }
        };
        if results.send(r).is_err() {
            break;
        }
    }
}

/// The requester thread: sends each request as a Zenoh query (5 s timeout) and reports the
/// answer, until either channel closes.
pub(super) fn requester(
    node: &ZenohNode,
    instance: &str,
    jobs: Receiver<RequestJob>,
    done: Sender<RequestDone>,
) {
    while let Ok(j) = jobs.recv() {
        let result = pkeys::echo_request(j.mission)
            .map_err(|e| e.to_string())
            .and_then(|key| {
                let req = ApertureRequest {
                    mission_id: j.mission,
                    aperture: j.aperture as u32,
                    look: j.look.map(|l| l as u32),
                    frame_pulses: j.frame_pulses as u32,
                    requester: instance.to_string(),
                };
                node.query_one::<ApertureRequest, RequestAck>(
                    &key,
                    &req,
                    &QueryOptions {
                        timeout: Duration::from_secs(5),
                        meta: Meta {
                            mission_id: j.mission,
                            ..Meta::default()
                        },
                        ..QueryOptions::default()
                    },
                )
                .map(|r| r.message)
                .map_err(|e| e.to_string())
            });
        let d = RequestDone {
            mission: j.mission,
            aperture: j.aperture,
            look: j.look,
            result,
        };
        if done.send(d).is_err() {
            break;
        }
    }
}
