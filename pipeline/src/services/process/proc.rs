//! The processor's service loop ([`Proc`]): plans in, frames into assemblies, complete
//! apertures to the worker, requests to the echo, the worker's results into outcomes and
//! metrics. What it publishes is in `publish.rs`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bridge::envelope::Meta;
use bridge::net::SubscribeOptions;
use bridge::{MissionId, ZenohNode};
use radar_sim::config::SceneFile;
use radar_sim::limits::IqLimits;

use super::assembly::{Assembly, Run};
use super::context::{fold_metrics, ApertureOutcome, MissionContext, ProcContext};
use super::frame_key::Admit;
use super::publish::Publishers;
use super::receive::{FrameLoss, RawFrame, ReceiverCmd};
use super::store::{restore, store, store_metrics};
use super::wanted::Wanted;
use super::work::{Job, JobResult, RequestDone, RequestJob};
use super::{ProcessArgs, ProcessReport};
use crate::protocol::keys as pkeys;
use crate::protocol::{MissionMetrics, Plan, ResultRequest};
use crate::services::admission::{admit, Admission};
use crate::services::plan::{PlanCache, StatusBoard};
use crate::services::radar::{ServiceError, ServiceResult};
use crate::services::wait::WaitLog;

/// What the service loop receives from its threads.
pub(super) struct Inbox {
    /// Frames from the receiver thread.
    pub(super) frames: Receiver<RawFrame>,
    /// Missions whose frames the receiver thread now takes.
    pub(super) watching: Receiver<MissionId>,
    /// Requests answered (or failed), from the requester thread.
    pub(super) requests_done: Receiver<RequestDone>,
    /// The worker's results.
    pub(super) results: Receiver<JobResult>,
    /// How the frame receiver and the requester ended: either one ending stops the service.
    pub(super) threads: crate::services::threads::ThreadExits,
}

/// The processor's state: the missions, the publishers, the counters and the channels to its
/// threads.
pub(super) struct Proc<'a> {
    /// The flags.
    pub(super) args: &'a ProcessArgs,
    /// `args.limits`, parsed once at start.
    pub(super) limits: IqLimits,
    /// The scene.
    pub(super) scene: &'a SceneFile,
    /// The Zenoh session.
    pub(super) node: &'a ZenohNode,
    /// The plans held (answered to lookups).
    pub(super) cache: PlanCache,
    /// The status publishers.
    pub(super) board: StatusBoard,
    /// The missions, in the order their plans arrived.
    pub(super) runs: Vec<Run>,
    /// The detections, image and metrics publishers.
    pub(super) publishers: Publishers,
    /// The counters.
    pub(super) report: ProcessReport,
    /// To the frame receiver.
    pub(super) cmd_tx: Sender<ReceiverCmd>,
    /// To the requester.
    pub(super) req_tx: Sender<RequestJob>,
    /// To the worker.
    pub(super) job_tx: Sender<Job>,
    /// A job is in the worker.
    pub(super) worker_busy: bool,
    /// Malformed plans, result requests and plan lookups.
    pub(super) malformed: u64,
    /// The mission whose last request to the echo failed (none answers yet), if any.
    pub(super) echo_unanswered: Option<MissionId>,
    /// Says what the service waits for.
    pub(super) waits: WaitLog,
    /// The missions asked for whose plan is not held yet.
    pub(super) wanted: Wanted,
    /// Frames come over Zenoh (every mission's frames arrive without subscribing).
    pub(super) frames_over_zenoh: bool,
}

impl Proc<'_> {
    /// The service loop, until `stop` is set: takes plans, frames, answered requests, the
    /// worker's results and result requests; hands complete apertures to the worker; asks
    /// for apertures; publishes the status every `--status-interval-s`.
    pub(super) fn run(
        &mut self,
        stop: &AtomicBool,
        inbox: &Inbox,
        loss: &FrameLoss,
    ) -> ServiceResult<ProcessReport> {
        let plans = PlanCache::subscribe_plans(self.node)?;
        let result_requests = self.node.queryable::<ResultRequest>(
            pkeys::ALL_RESULTS,
            SubscribeOptions {
                capacity: 64,
                ..SubscribeOptions::default()
            },
        )?;
        let plan_wait = format!(
            "a plan ({}) of a mission that a client asks results of ({}): no other is taken on",
            pkeys::ALL_PLANS,
            pkeys::ALL_RESULTS
        );
        self.waits.waiting_for(self.node, Some(&plan_wait));
        tracing::info!(instance = %self.args.instance, frames = ?self.args.frames, "processor ready");
        let interval = self.args.status_interval_s.duration();
        let mut last_status = Instant::now();
        while !stop.load(Ordering::Relaxed) {
            // a thread the service depends on is gone: fail now, naming it
            inbox.threads.check()?;
            // a mission is taken on only when asked for (wanted.rs): the plans published for
            // others are not
            while let Some(p) = plans.try_recv() {
                let bytes = usize::try_from(p.header.body_len).unwrap_or(usize::MAX);
                if let Some(plan) = self.wanted.published(p.message, bytes) {
                    self.take_on(plan);
                }
            }
            for p in self.wanted.found(&mut self.report.plans_inconsistent) {
                self.take_on(p);
            }
            while let Ok(id) = inbox.watching.try_recv() {
                if let Some(i) = self.run_index(id) {
                    self.runs[i].subscribed = true;
                }
            }
            let mut idle = true;
            while let Ok(f) = inbox.frames.try_recv() {
                idle = false;
                self.on_frame(f);
            }
            while let Ok(d) = inbox.requests_done.try_recv() {
                idle = false;
                self.on_request_done(d);
            }
            while let Ok(r) = inbox.results.try_recv() {
                idle = false;
                self.worker_busy = false;
                self.on_result(r)?;
            }
            while let Some(q) = result_requests.recv_timeout(Duration::ZERO) {
                if self.run_index(q.request.mission_id).is_none() {
                    if let Some(plan) = self.wanted.ask(self.node, q.request.mission_id) {
                        self.take_on(plan);
                    }
                }
                let ack = self.republish(&q.request);
                if let Err(e) = q.reply(
                    &ack,
                    Meta {
                        mission_id: q.request.mission_id,
                        ..Meta::default()
                    },
                ) {
                    tracing::warn!(error = %e, "result request reply failed");
                }
            }
            self.dispatch();
            self.drive_requests();
            self.report.transport_lost = loss.lost.load(Ordering::Relaxed);
            self.report.frames_malformed = loss.malformed.load(Ordering::Relaxed);
            self.report.dropped = loss.dropped.load(Ordering::Relaxed);
            self.malformed = plans.counters().snapshot().malformed
                + result_requests.counters().snapshot().malformed
                + self.cache.malformed();
            if last_status.elapsed() >= interval {
                last_status = Instant::now();
                self.publish_status();
            }
            let echo_wait;
            let waiting = if self.runs.iter().all(|r| r.metrics.is_some()) {
                Some(plan_wait.as_str())
            } else if let Some(m) = self.echo_unanswered {
                echo_wait = format!(
                    "an echo to answer the requests of mission {m} (cellsar/{m}/echo/request)"
                );
                Some(echo_wait.as_str())
            } else {
                None
            };
            self.waits.waiting_for(self.node, waiting);
            if idle {
                if let Ok(f) = inbox.frames.recv_timeout(Duration::from_millis(10)) {
                    self.on_frame(f);
                }
            }
        }
        self.publish_status();
        self.log_final_counters(
            plans.counters().snapshot().malformed,
            result_requests.counters().snapshot().malformed,
        );
        Ok(self.report.clone())
    }

    /// Takes on the mission of `plan`, which was asked for.
    fn take_on(&mut self, plan: Plan) {
        self.wanted.forget(plan.mission_id);
        self.add_plan(plan);
    }

    /// Starts a mission for a new plan (a plan already held, or one that does not resolve
    /// against the scene, is skipped); restores and republishes what its state directory
    /// holds.
    fn add_plan(&mut self, plan: Plan) {
        let id = plan.mission_id;
        if self.runs.iter().any(|r| r.ctx.base.mission_id == id) {
            return;
        }
        if !crate::services::plan::id_consistent(&plan, &mut self.report.plans_inconsistent) {
            return;
        }
        let droppable = self.runs.iter().map(|r| r.droppable());
        match admit(droppable, self.args.max_missions) {
            Admission::Admit => {}
            Admission::Evict(i) => self.let_go(i),
            Admission::Refuse => {
                self.report.plans_refused += 1;
                tracing::warn!(mission = %id, max_missions = self.args.max_missions,
                    "plan refused: --max-missions missions are in progress");
                return;
            }
        }
        let plan = Arc::new(plan);
        let made =
            MissionContext::with_limits(&plan, self.scene, self.args.max_frame_bytes, &self.limits)
                .map(Arc::new)
                .and_then(ProcContext::new);
        let ctx = match made {
            Ok(c) => Arc::new(c),
            Err(e) => {
                tracing::warn!(mission = %id, error = %e, "plan not usable");
                return;
            }
        };
        if let Err(e) = self.cache.insert(plan) {
            tracing::warn!(mission = %id, error = %e, "plan not cached");
        }
        let dir = self.args.state_dir.as_ref().map(|d| d.join(id.to_string()));
        let mut run = Run::new(ctx, dir, self.frames_over_zenoh);
        if let Some(d) = &run.dir {
            match restore(d, run.ctx.base.apertures.len()) {
                Ok((outcomes, metrics)) => {
                    self.report.restored += outcomes.len() as u64;
                    if !outcomes.is_empty() {
                        tracing::info!(mission = %id, apertures = outcomes.len(), "resuming from the state directory");
                    }
                    run.outcomes = outcomes;
                    run.metrics = metrics;
                }
                Err(e) => tracing::warn!(mission = %id, error = %e, "state not restored"),
            }
        }
        tracing::info!(
            mission = %id,
            apertures = run.ctx.base.apertures.len(),
            done = run.outcomes.len(),
            frame_pulses = run.ctx.base.layout.frame_pulses(),
            "plan received"
        );
        let _ = self.cmd_tx.send(ReceiverCmd::Watch(id));
        self.runs.push(run);
        // at least once: what was finished before a restart is published again
        let idx = self.runs.len() - 1;
        let restored: Vec<usize> = self.runs[idx].outcomes.keys().copied().collect();
        for k in restored {
            self.publish_outcome(idx, k);
            self.report.republished += 1;
        }
        if self.runs[idx].metrics.is_some() {
            self.publish_metrics(idx);
        }
    }

    /// Lets go of mission `i` (finished or given up) to make room: its plan, publishers and
    /// frame subscription; what its state directory holds stays.
    fn let_go(&mut self, i: usize) {
        let run = self.runs.remove(i);
        let id = run.ctx.base.mission_id;
        self.cache.remove(id);
        self.publishers.detections.remove(&id);
        self.publishers.metrics.remove(&id);
        self.publishers.images.retain(|(m, _), _| *m != id);
        let _ = self.cmd_tx.send(ReceiverCmd::Unwatch(id));
        self.report.evicted += 1;
        tracing::info!(mission = %id, "mission let go to make room (--max-missions)");
    }

    /// The index of mission `id` in `runs`.
    pub(super) fn run_index(&self, id: MissionId) -> Option<usize> {
        self.runs.iter().position(|r| r.ctx.base.mission_id == id)
    }

    /// Counts a frame received and files it.
    fn on_frame(&mut self, f: RawFrame) {
        self.report.frames += 1;
        self.file_frame(f);
    }

    /// Files a frame into the assembly waiting for it once its tag verifies; complete
    /// assemblies are queued for the worker.
    fn file_frame(&mut self, f: RawFrame) {
        let Some(i) = self.run_index(f.mission) else {
            self.report.unsolicited += 1;
            return;
        };
        let run = &mut self.runs[i];
        let layout = &run.ctx.base.layout;
        let Some(slot) = layout.locate(f.seq) else {
            self.report.bad += 1;
            tracing::warn!(mission = %f.mission, seq = f.seq, "frame number outside the mission");
            return;
        };
        let spp = layout.samples_per_pulse();
        let pulses = &run.ctx.pulses[slot.aperture];
        let t_expected = pulses
            .get(slot.first_pulse)
            .map_or(0, |p| (p.t_s * 1e9).round() as i64);
        if f.rows != slot.pulses
            || f.cols != spp
            || f.samples.len() != f.rows * f.cols
            || (f.mission_time_ns - t_expected).abs() > 1_000
        {
            self.report.bad += 1;
            tracing::warn!(
                mission = %f.mission,
                seq = f.seq,
                shape = ?(f.rows, f.cols),
                expected = ?(slot.pulses, spp),
                "frame does not fit the mission's layout (same scene and --max-frame-bytes everywhere?)"
            );
            return;
        }
        // only the echo's frames (tagged with the mission's key) take a slot
        let (mission, seq) = (f.mission, f.seq);
        let f = match run.key_gate.admit(f) {
            Admit::Take(f) => f,
            Admit::Parked => return,
            Admit::Overflow => {
                self.report.dropped += 1;
                return;
            }
            Admit::Forged(e) => {
                self.report.forged += 1;
                run.key_gate.log_forged(mission, seq, &e);
                return;
            }
        };
        // after the tag, which covers the digest: only the echo's own frames are named so
        if let Err(e) = f.header.check_scene(run.ctx.base.scene_digest) {
            self.report.bad += 1;
            tracing::warn!(%mission, seq, "frame skipped: {e}");
            return;
        }
        run.last_frame = Instant::now();
        run.last_progress = run.last_frame;
        let target = match run.assembling.get_mut(&slot.aperture) {
            Some(a) => Some(a),
            None => match run.look.as_mut() {
                Some((k, a)) if *k == slot.aperture => Some(a),
                _ => None,
            },
        };
        let Some(a) = target else {
            let held = run.outcomes.contains_key(&slot.aperture)
                || run.in_worker == Some(slot.aperture)
                || run
                    .ready
                    .iter()
                    .any(|j| matches!(j, Job::Aperture { k, .. } if *k == slot.aperture));
            if held {
                self.report.duplicates += 1;
            } else {
                self.report.unsolicited += 1;
                tracing::debug!(mission = %f.mission, seq = f.seq, aperture = slot.aperture, "frame of an aperture not asked for");
            }
            return;
        };
        let Some((first, n)) = a.want.remove(&f.seq) else {
            self.report.duplicates += 1;
            return;
        };
        let off = (first - a.first_pulse) * spp;
        if let Some(dst) = a.buf.get_mut(off..off + n * spp) {
            dst.copy_from_slice(&f.samples);
            a.have += 1;
            self.report.used += 1;
        } else {
            self.report.bad += 1;
        }
        // hand complete assemblies to the worker queue
        if let Some(a) = run.assembling.get(&slot.aperture) {
            if a.complete() {
                if let Some(a) = run.assembling.remove(&slot.aperture) {
                    run.ready.push_back(Job::Aperture {
                        ctx: run.ctx.clone(),
                        k: slot.aperture,
                        iq: a.buf,
                    });
                }
            }
        }
        if let Some((k, a)) = &run.look {
            if *k == slot.aperture && a.complete() {
                if let Some((k, a)) = run.look.take() {
                    run.resolving = true;
                    run.ready.push_back(Job::Resolution {
                        ctx: run.ctx.clone(),
                        k,
                        look: a.look.unwrap_or(0),
                        iq: a.buf,
                    });
                }
            }
        }
    }

    /// Hands the next queued job to the worker, when it is idle.
    fn dispatch(&mut self) {
        if self.worker_busy {
            return;
        }
        for run in &mut self.runs {
            if let Some(job) = run.ready.pop_front() {
                if let Job::Aperture { k, .. } = &job {
                    run.in_worker = Some(*k);
                }
                if self.job_tx.send(job).is_ok() {
                    self.worker_busy = true;
                }
                return;
            }
        }
    }

    /// Opens assemblies up to the window for the first unfinished mission and (re)sends
    /// requests.
    fn drive_requests(&mut self) {
        let window = self.args.window;
        let resend = self.args.resend_after_s.duration();
        let Some(i) = self
            .runs
            .iter()
            .position(|r| r.metrics.is_none() && r.failed.is_none())
        else {
            return;
        };
        if !self.runs[i].subscribed {
            // ask for frames only once this process can receive them
            return;
        }
        let mut immediate = None;
        {
            let run = &mut self.runs[i];
            let n = run.ctx.base.apertures.len();
            let queued = run.ready.len() + usize::from(run.in_worker.is_some());
            if run.outcomes.len() < n {
                let mut k = 0;
                while run.assembling.len() + queued < window + 1
                    && run.assembling.len() < window
                    && k < n
                {
                    let busy = run.outcomes.contains_key(&k)
                        || run.assembling.contains_key(&k)
                        || run.in_worker == Some(k)
                        || run
                            .ready
                            .iter()
                            .any(|j| matches!(j, Job::Aperture { k: jk, .. } if *jk == k));
                    if !busy {
                        let a = Assembly::new(&run.ctx, k, None);
                        run.assembling.insert(k, a);
                    }
                    k += 1;
                }
            } else if run.look.is_none()
                && !run.resolving
                && run.ready.is_empty()
                && run.in_worker.is_none()
            {
                // every aperture done: the metrics, with one look asked for again to measure
                // the resolution (as `process` does on the strongest landmark)
                let outcomes: Vec<&ApertureOutcome> = run.outcomes.values().collect();
                match fold_metrics(&outcomes, run.ctx.noise_power_w).1 {
                    Some((k, look)) => {
                        run.look = Some((k, Assembly::new(&run.ctx, k, Some(look))));
                    }
                    None => {
                        immediate = Some(JobResult::Resolution(
                            run.ctx.base.mission_id,
                            Ok(None),
                            (0, 0),
                        ));
                    }
                }
            }
        }
        if let Some(r) = immediate {
            if let Err(e) = self.on_result(r) {
                tracing::warn!(error = %e, "finishing the metrics failed");
            }
            return;
        }
        let run = &mut self.runs[i];
        let id = run.ctx.base.mission_id;
        let fp = run.ctx.base.layout.frame_pulses();
        let scene_digest = run.ctx.base.scene_digest;
        let now = Instant::now();
        let quiet_since = run.last_frame;
        // a frame that arrived malformed will not come either: both make a request due sooner
        let lost_now = self
            .report
            .transport_lost
            .saturating_add(self.report.frames_malformed);
        let mut sent = Vec::new();
        let look_entry = run.look.as_mut().map(|la| (la.0, &mut la.1));
        let asm = run
            .assembling
            .iter_mut()
            .map(|(k, a)| (*k, a))
            .chain(look_entry);
        for (k, a) in asm {
            if a.request_pending {
                continue;
            }
            if a.due(now, quiet_since, resend, lost_now) {
                if a.requested.is_some() {
                    self.report.resends += 1;
                    tracing::info!(mission = %id, aperture = k, look = ?a.look, missing = a.want.len(), "asking again");
                }
                a.requested = Some(now);
                a.lost_at_request = lost_now;
                a.retry_at = None;
                a.request_pending = true;
                a.attempts += 1;
                sent.push(RequestJob {
                    mission: id,
                    aperture: k,
                    look: a.look,
                    frame_pulses: fp,
                    scene_digest,
                });
            }
        }
        if !sent.is_empty() {
            run.last_frame = now;
        }
        for j in sent {
            self.report.requests += 1;
            let _ = self.req_tx.send(j);
        }
    }

    /// Notes the echo's answer to a request (a failed one is retried in 1 s).
    fn on_request_done(&mut self, d: RequestDone) {
        let Some(i) = self.run_index(d.mission) else {
            return;
        };
        // the answer brings the mission's frame key: file the frames that waited for it
        let parked = match &d.result {
            Ok(ack) => self.runs[i].key_gate.on_ack(ack.frame_key.clone()),
            Err(_) => Vec::new(),
        };
        self.note_request_done(i, d);
        for f in parked {
            self.file_frame(f);
        }
    }

    /// The rest of [`Self::on_request_done`] for mission `i`.
    fn note_request_done(&mut self, i: usize, d: RequestDone) {
        let run = &mut self.runs[i];
        let a = match d.look {
            None => run.assembling.get_mut(&d.aperture),
            Some(_) => run
                .look
                .as_mut()
                .filter(|la| la.0 == d.aperture)
                .map(|la| &mut la.1),
        };
        let Some(a) = a else { return };
        a.request_pending = false;
        match d.result {
            Ok(ack) => {
                self.echo_unanswered = None;
                let expected: Vec<u64> = run.ctx.base.layout.seqs(d.aperture, d.look);
                if ack.seqs != expected {
                    tracing::warn!(mission = %d.mission, aperture = d.aperture, "the echo announced other frames than expected");
                }
            }
            Err(e) => {
                self.echo_unanswered = Some(d.mission);
                self.report.request_errors += 1;
                tracing::warn!(mission = %d.mission, aperture = d.aperture, attempt = a.attempts, "request failed: {e}");
                // retry soon, whether frames flow or not
                a.retry_at = Some(Instant::now() + Duration::from_secs(1));
            }
        }
    }

    /// Takes the worker's result: stores and publishes an aperture's outcome (a second failure
    /// gives the mission up), or finishes the mission's metrics.
    fn on_result(&mut self, r: JobResult) -> ServiceResult<()> {
        match r {
            JobResult::Aperture(id, outcome) => {
                let Some(i) = self.run_index(id) else {
                    return Ok(());
                };
                let run = &mut self.runs[i];
                let k = run.in_worker.take();
                match *outcome {
                    Ok(o) => {
                        let k = o.aperture();
                        if let Some(d) = &run.dir {
                            if let Err(e) = store(d, &o) {
                                // still published; after a restart it is processed again
                                self.report.state_errors += 1;
                                tracing::error!(mission = %id, aperture = k, error = %e,
                                    "aperture not saved to the state directory; serving it from memory");
                            }
                        }
                        tracing::info!(mission = %id, aperture = k, detections = o.tally.rows.len(),
                            seconds = format!("{:.2}", o.process_s), "aperture done");
                        run.outcomes.insert(k, o);
                        self.report.apertures += 1;
                        self.publish_outcome(i, k);
                    }
                    Err(e) => {
                        // ask again once (a frame may have been corrupted in a way the CRC
                        // missed); a second failure is a bad scene or a bug: give up the mission
                        let k = k.unwrap_or(usize::MAX);
                        let n = run.failures.entry(k).or_insert(0);
                        *n += 1;
                        tracing::error!(mission = %id, aperture = k, attempt = *n, error = %e, "processing failed");
                        if *n >= 2 {
                            run.failed = Some(format!("aperture {k}: {e}"));
                            self.publish_status();
                        }
                    }
                }
            }
            JobResult::Panicked(what) => {
                // the worker is gone: fail, so that the supervisor restarts this process (it
                // resumes from its state directory)
                tracing::error!("the processing worker panicked on {what}; exiting for a restart");
                return Err(ServiceError::Internal(format!(
                    "the processing worker panicked on {what}"
                )));
            }
            JobResult::Resolution(id, res, (k, look)) => {
                let Some(i) = self.run_index(id) else {
                    return Ok(());
                };
                let run = &mut self.runs[i];
                let outcomes: Vec<&ApertureOutcome> = run.outcomes.values().collect();
                let (mut metrics, best) = fold_metrics(&outcomes, run.ctx.noise_power_w);
                match res {
                    Ok(Some((rr, ra))) if best == Some((k, look)) => {
                        metrics.range_resolution_m = Some(rr);
                        metrics.azimuth_resolution_m = Some(ra);
                        metrics.resolution_from = Some((k, look));
                    }
                    Ok(_) => {}
                    Err(e) => {
                        tracing::warn!(mission = %id, error = %e, "resolution measurement failed")
                    }
                }
                let mm = MissionMetrics {
                    mission_id: id,
                    apertures: run.outcomes.len() as u32,
                    metrics,
                    processor: self.args.instance.clone(),
                };
                if let Some(d) = &run.dir {
                    if let Err(e) = store_metrics(d, &mm) {
                        self.report.state_errors += 1;
                        tracing::error!(mission = %id, error = %e,
                            "metrics not saved to the state directory; serving them from memory");
                    }
                }
                tracing::info!(mission = %id, pd = mm.metrics.pd, false_alarms = mm.metrics.false_alarms,
                    seconds = format!("{:.1}", run.started.elapsed().as_secs_f64()), "mission done");
                run.metrics = Some(mm);
                self.report.missions += 1;
                self.publish_metrics(i);
                self.publish_status();
            }
        }
        Ok(())
    }
}
