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
    /// The worker panicked on a job (named, with the panic's message) and stopped: the
    /// process must fail so that its supervisor restarts it.
    Panicked(String),
}

impl Job {
    /// The job, in words (for a panic's report).
    fn describe(&self) -> String {
        match self {
            Job::Aperture { ctx, k, .. } => format!("mission {} aperture {k}", ctx.base.mission_id),
            Job::Resolution { ctx, k, look, .. } => {
                format!("mission {} aperture {k} look {look}", ctx.base.mission_id)
            }
        }
    }

    /// Runs the job.
    fn run(self) -> JobResult {
        match self {
            Job::Aperture { ctx, k, iq } => {
                JobResult::Aperture(ctx.base.mission_id, Box::new(ctx.process(k, &iq)))
            }
            Job::Resolution { ctx, k, look, iq } => {
                JobResult::Resolution(ctx.base.mission_id, ctx.resolution(k, look, &iq), (k, look))
            }
        }
    }
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
    /// The processor's scene digest.
    pub(super) scene_digest: u64,
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

/// The worker thread: runs jobs until either channel closes, or until a job panics (then it
/// reports [`JobResult::Panicked`] and stops).
pub(super) fn worker(jobs: Receiver<Job>, results: Sender<JobResult>) {
    run_jobs(jobs, results, Job::describe, Job::run, JobResult::Panicked)
}

/// Runs `run` on each job until either channel closes; a panic in `run` is caught, reported
/// as `panicked("<job>: <message>")` and ends the loop (state a panic left behind is not
/// trusted).
fn run_jobs<J, R>(
    jobs: Receiver<J>,
    results: Sender<R>,
    describe: impl Fn(&J) -> String,
    run: impl Fn(J) -> R,
    panicked: impl Fn(String) -> R,
) {
    while let Ok(job) = jobs.recv() {
        let what = describe(&job);
        let r = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(job))) {
            Ok(r) => r,
            Err(payload) => {
                let msg = payload
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "a panic without a message".into());
                let _ = results.send(panicked(format!("{what}: {msg}")));
                return;
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
                    scene_digest: j.scene_digest,
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

#[cfg(test)]
mod tests {
    use super::run_jobs;
    use std::sync::mpsc;

    #[derive(Debug, PartialEq)]
    enum Out {
        Done(u32),
        Panicked(String),
    }

    #[test]
    fn a_panicking_job_is_reported_by_name_and_stops_the_worker() {
        let (job_tx, job_rx) = mpsc::channel::<u32>();
        let (res_tx, res_rx) = mpsc::channel::<Out>();
        for j in [1, 2, 3, 4] {
            job_tx.send(j).unwrap();
        }
        let h = std::thread::spawn(move || {
            run_jobs(
                job_rx,
                res_tx,
                |j| format!("job {j}"),
                |j| {
                    assert!(j != 3, "job three is broken");
                    Out::Done(j * 10)
                },
                Out::Panicked,
            )
        });
        // the worker ends by itself after the panic (the channel to it is still open)
        h.join().expect("the worker thread itself does not panic");
        let got: Vec<Out> = res_rx.try_iter().collect();
        assert_eq!(got.len(), 3, "{got:?}");
        assert_eq!(got[0], Out::Done(10));
        assert_eq!(got[1], Out::Done(20));
        match &got[2] {
            Out::Panicked(m) => {
                assert!(m.starts_with("job 3: "), "{m}");
                assert!(m.contains("job three is broken"), "{m}");
            }
            other => panic!("expected a panic report, got {other:?}"),
        }
        drop(job_tx);
    }

    #[test]
    fn the_worker_ends_when_its_jobs_end() {
        let (job_tx, job_rx) = mpsc::channel::<u32>();
        let (res_tx, res_rx) = mpsc::channel::<Out>();
        job_tx.send(7).unwrap();
        drop(job_tx);
        run_jobs(job_rx, res_tx, |j| j.to_string(), Out::Done, Out::Panicked);
        assert_eq!(res_rx.try_iter().collect::<Vec<_>>(), vec![Out::Done(7)]);
    }
}
