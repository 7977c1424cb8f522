//! `cellsar-radar-sim echo`: synthesises the frames of the apertures that processors ask for
//! and publishes them on the iceoryx2 frame service `cellsar/<mission>/echo`. It takes on a
//! mission only when a processor asks for one of its apertures (looking its plan up,
//! `cellsar/<m>/plan`), not every plan that is published: plans made for others (a peer
//! flooding the planner with requests) cannot crowd out the missions being processed.

use std::collections::{HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::plan::{PlanCache, StatusBoard};
use crate::protocol::keys as pkeys;
use crate::protocol::Plan;
use bridge::iox::FramePublisherOptions;
use bridge::net::{IncomingQuery, PublishOptions, SubscribeOptions, TypedPublisher};
use bridge::zenoh::qos::CongestionControl;
use bridge::{
    FrameMeta, FrameNode, FramePublisher, FrameServiceSpec, IoxArgs, MissionId, Refusal,
    RefusalKind, ZenohArgs, ZenohNode,
};
use serde::{Deserialize, Serialize};

use crate::args::IqLimitArgs;
use bridge::flags::Seconds;
use radar_sim::clutter::GroundClutter;
use radar_sim::config::SceneFile;
use radar_sim::limits::IqLimits;
use radar_sim::scene::SceneObject;
use radar_sim::synth::{Components, Synthesizer};
use radar_sim::track::PulseMeta;

use super::admission::{admit, Admission, Droppable, DEFAULT_MAX_MISSIONS};
use super::process::MissionContext;
use super::radar::{ServiceError, ServiceResult, DEFAULT_MAX_FRAME_BYTES};
use crate::protocol::{ApertureRequest, FrameInfo, FrameSlot, RequestAck, Role, ServiceState};

/// Flags of `cellsar-radar-sim echo`.
#[derive(clap::Args, Debug, Clone)]
pub struct EchoArgs {
    /// Instance name (liveliness token `cellsar/alive/echo/<instance>`).
    #[arg(long, default_value = "echo")]
    pub instance: String,
    /// Scene file (TOML): the objects, the radar and the processing settings.
    #[arg(long)]
    pub scene: PathBuf,
    /// Largest frame payload in bytes; sizes the iceoryx2 service and the frames (every process
    /// of the service, the bridge included, must use the same value).
    #[arg(long, default_value_t = DEFAULT_MAX_FRAME_BYTES)]
    pub max_frame_bytes: usize,
    /// Seconds between status publications.
    #[arg(long, default_value = "1", value_parser = bridge::flags::parse_seconds)]
    pub status_interval_s: Seconds,
    /// Requests the echo queues at most (more are refused as busy).
    #[arg(long, default_value_t = 64)]
    pub max_queue: usize,
    /// Missions held at once (each taken on when a processor first asks for it): at the cap, a
    /// new one replaces the mission least recently asked for that has no request queued (it
    /// is taken up again if a processor asks for it), and is refused while every held mission
    /// has requests queued.
    #[arg(long, default_value_t = DEFAULT_MAX_MISSIONS, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=4096))]
    pub max_missions: usize,
    /// Limits on a mission's IQ and on one aperture's memory (a plan above them is refused).
    #[command(flatten)]
    pub limits: IqLimitArgs,
    /// Zenoh flags.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// iceoryx2 flags.
    #[command(flatten)]
    pub iox: IoxArgs,
}

/// What the echo did, at exit.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EchoReport {
    /// Requests accepted.
    pub requests: u64,
    /// Requests refused (unknown mission, bad aperture, layout mismatch, busy).
    pub refused: u64,
    /// Requests already queued (not added again).
    pub merged: u64,
    /// Frames sent.
    pub frames: u64,
    /// Deliveries skipped because a subscriber's buffer was full (a slow or frozen reader).
    pub skipped_full: u64,
    /// Frame sends that failed.
    pub send_errors: u64,
    /// Jobs (apertures or looks) finished.
    pub jobs: u64,
    /// Payload bytes sent.
    pub bytes: u64,
    /// Plans refused because `--max-missions` missions had requests queued.
    pub plans_refused: u64,
    /// Plans skipped because their mission id is not the one their content gives.
    pub plans_inconsistent: u64,
    /// Missions let go to make room for new ones (`--max-missions`).
    pub evicted: u64,
}

struct EchoMission {
    ctx: Arc<MissionContext>,
    synth: Synthesizer,
    /// The scene's objects (each aperture's clutter synthesiser holds them too).
    objects: Vec<SceneObject>,
    /// The scene's ground clutter (`[clutter]`), `None` when off.
    clutter: Option<GroundClutter>,
    publisher: Option<FramePublisher>,
    info: TypedPublisher<FrameInfo>,
    /// The mission's frame key: every frame sent is tagged with it, and every processor that
    /// asks for apertures is given it (in the [`RequestAck`]).
    frame_key: bridge::frame::FrameKey,
    /// When a processor last asked for it (or when its plan arrived).
    last_used: Instant,
}

struct Job {
    mission: MissionId,
    aperture: usize,
    look: Option<usize>,
    slots: Vec<(u64, FrameSlot)>,
    pulses: Vec<PulseMeta>,
    /// The aperture's objects and its patch of ground clutter, when the scene has clutter.
    cluttered: Option<Synthesizer>,
    next: usize,
}

/// Runs the echo service until `stop` is set. A stop while the Zenoh session still opens (a
/// client waiting for its router) ends it at once with an empty report.
pub fn run_echo(args: &EchoArgs, stop: &AtomicBool) -> ServiceResult<EchoReport> {
    let limits = args.limits.limits()?;
    let scene = SceneFile::from_path(&args.scene)?;
    let env = args.iox.env()?;
    let config = args.zenoh.to_config()?;
    let Some(node) = ZenohNode::open_until(config, Role::Echo.as_str(), &args.instance, stop)?
    else {
        return Ok(EchoReport::default());
    };
    let r = Echo::new(args, scene, limits, &node, &env).and_then(|mut e| e.run(stop));
    if let Err(e) = node.close() {
        tracing::warn!(error = %e, "closing the Zenoh session");
    }
    r
}

struct Echo<'a> {
    args: &'a EchoArgs,
    scene: SceneFile,
    /// `--max-iq-gib` / `--max-aperture-gib`, parsed once at start.
    limits: IqLimits,
    node: &'a ZenohNode,
    frames: FrameNode,
    cache: PlanCache,
    board: StatusBoard,
    missions: HashMap<MissionId, EchoMission>,
    queue: VecDeque<Job>,
    report: EchoReport,
}

impl<'a> Echo<'a> {
    fn new(
        args: &'a EchoArgs,
        scene: SceneFile,
        limits: IqLimits,
        node: &'a ZenohNode,
        env: &bridge::IoxEnv,
    ) -> ServiceResult<Self> {
        let node_name = format!("echo-{}", args.instance);
        let (frames, cleanup) = FrameNode::new(env, &node_name)?;
        if cleanup.cleaned > 0 {
            tracing::info!(
                cleaned = cleanup.cleaned,
                "stale iceoryx2 resources of dead processes removed"
            );
        }
        Ok(Echo {
            args,
            scene,
            limits,
            node,
            frames,
            cache: PlanCache::new(node, None)?,
            board: StatusBoard::new(Role::Echo, &args.instance),
            missions: HashMap::new(),
            queue: VecDeque::new(),
            report: EchoReport::default(),
        })
    }

    fn run(&mut self, stop: &AtomicBool) -> ServiceResult<EchoReport> {
        let plans = PlanCache::subscribe_plans(self.node)?;
        let requests = self.node.queryable::<ApertureRequest>(
            pkeys::ALL_ECHO_REQUESTS,
            SubscribeOptions {
                capacity: 256,
                ..SubscribeOptions::default()
            },
        )?;
        let plan_wait = format!(
            "a plan ({}) of a mission that a processor asks apertures of ({}): no other is \
             taken on",
            pkeys::ALL_PLANS,
            pkeys::ALL_ECHO_REQUESTS
        );
        let mut waits = super::wait::WaitLog::default();
        waits.waiting_for(self.node, Some(&plan_wait));
        tracing::info!(instance = %self.args.instance, "echo ready");
        let interval = self.args.status_interval_s.duration();
        let mut last_status = Instant::now();
        // a status goes out at once for every newly known mission (then every `interval`), so
        // that a watcher sees the echo's status even when a short mission ends within the
        // first interval
        let mut known_missions = 0;
        while !stop.load(Ordering::Relaxed) {
            let waiting = self.missions.is_empty().then_some(plan_wait.as_str());
            waits.waiting_for(self.node, waiting);
            // published plans are not taken on (a processor's request is, handle_request);
            // the subscription only counts the malformed ones
            while plans.try_recv().is_some() {}
            let status_due = self.missions.len() != known_missions;
            known_missions = self.missions.len();
            let wait = if self.queue.is_empty() {
                Duration::from_millis(50)
            } else {
                Duration::ZERO
            };
            let first = if wait.is_zero() {
                requests.recv_timeout(Duration::ZERO)
            } else {
                requests.recv_timeout(wait)
            };
            if let Some(q) = first {
                self.handle_request(q);
                while let Some(q) = requests.recv_timeout(Duration::ZERO) {
                    self.handle_request(q);
                }
            }
            if let Err(e) = self.send_next() {
                tracing::warn!(error = %e, "sending a frame failed");
                self.report.send_errors += 1;
                self.queue.pop_front();
            }
            if status_due || last_status.elapsed() >= interval {
                last_status = Instant::now();
                let bad = plans.counters().snapshot().malformed
                    + requests.counters().snapshot().malformed
                    + self.cache.malformed();
                self.publish_status(ServiceState::Running, bad);
            }
        }
        let bad = plans.counters().snapshot().malformed
            + requests.counters().snapshot().malformed
            + self.cache.malformed();
        self.publish_status(ServiceState::Stopping, bad);
        let c = plans.counters().snapshot();
        let q = requests.counters().snapshot();
        tracing::info!(
            final_counters = true,
            requests = self.report.requests,
            refused = self.report.refused,
            merged = self.report.merged,
            frames = self.report.frames,
            skipped_full = self.report.skipped_full,
            send_errors = self.report.send_errors,
            jobs = self.report.jobs,
            plans_refused = self.report.plans_refused,
            plans_inconsistent = self.report.plans_inconsistent,
            evicted = self.report.evicted,
            plans_malformed = c.malformed,
            requests_malformed = q.malformed,
            lookups_malformed = self.cache.malformed(),
            "echo stopping"
        );
        Ok(self.report.clone())
    }

    fn add_plan(&mut self, plan: Plan) {
        let id = plan.mission_id;
        if self.missions.contains_key(&id) {
            return;
        }
        if !super::plan::id_consistent(&plan, &mut self.report.plans_inconsistent) {
            return;
        }
        if !self.make_room(id) {
            return;
        }
        match self.open_mission(plan) {
            Ok(m) => {
                tracing::info!(
                    mission = %id,
                    apertures = m.ctx.apertures.len(),
                    frames = m.ctx.layout.total_frames(),
                    frame_pulses = m.ctx.layout.frame_pulses(),
                    "plan received"
                );
                self.missions.insert(id, m);
            }
            Err(e) => tracing::warn!(mission = %id, error = %e, "plan not usable"),
        }
    }

    /// Makes room for mission `id` under `--max-missions`; false when it must be refused.
    fn make_room(&mut self, id: MissionId) -> bool {
        let mut held: Vec<(Instant, MissionId)> = self
            .missions
            .iter()
            .map(|(k, m)| (m.last_used, *k))
            .collect();
        held.sort();
        let queued = |m: &MissionId| self.queue.iter().any(|j| j.mission == *m);
        // a mission without requests queued may go (the least recently used first): the
        // echo cannot tell a finished one from one that a processor will ask more of
        let droppable = |m: &MissionId| {
            if queued(m) {
                Droppable::No
            } else {
                Droppable::Idle
            }
        };
        match admit(
            held.iter().map(|(_, m)| droppable(m)),
            self.args.max_missions,
        ) {
            Admission::Admit => true,
            Admission::Evict(i) => {
                let (_, old) = held[i];
                self.missions.remove(&old);
                self.cache.remove(old);
                self.report.evicted += 1;
                tracing::info!(mission = %old, "mission let go to make room (--max-missions)");
                true
            }
            Admission::Refuse => {
                self.report.plans_refused += 1;
                tracing::warn!(mission = %id, max_missions = self.args.max_missions,
                    "plan refused: every held mission has requests queued (--max-missions)");
                false
            }
        }
    }

    fn open_mission(&mut self, plan: Plan) -> ServiceResult<EchoMission> {
        let plan = Arc::new(plan);
        let ctx = Arc::new(MissionContext::with_limits(
            &plan,
            &self.scene,
            self.args.max_frame_bytes,
            &self.limits,
        )?);
        let objects = ctx.setup.objects(&ctx.mission)?;
        let synth = ctx.setup.synthesizer(objects.clone())?;
        // ground clutter (`[clutter]`): synthesised with the objects, as `cellsar-radar-sim simulate`
        let clutter = GroundClutter::for_run(&ctx.setup, &ctx.track, &ctx.apertures)?;
        let info = self.node.publisher::<FrameInfo>(
            &pkeys::frames(ctx.mission_id)?,
            PublishOptions {
                mission_id: ctx.mission_id,
                congestion_control: CongestionControl::Drop,
                ..PublishOptions::default()
            },
        )?;
        self.cache.insert(plan)?;
        // the publisher exists from the plan on, so processors are connected before they ask
        let spec = FrameServiceSpec::new(&pkeys::echo(ctx.mission_id)?, self.args.max_frame_bytes);
        let publisher = self
            .frames
            .publisher(&spec, FramePublisherOptions::default())?;
        let frame_key = bridge::frame::FrameKey::random().map_err(|error| ServiceError::Codec {
            what: format!("mission {}: drawing its frame key", ctx.mission_id),
            error,
        })?;
        Ok(EchoMission {
            ctx,
            synth,
            objects,
            clutter,
            publisher: Some(publisher),
            info,
            frame_key,
            last_used: Instant::now(),
        })
    }

    fn handle_request(&mut self, q: IncomingQuery<ApertureRequest>) {
        let r = q.request.clone();
        if !self.missions.contains_key(&r.mission_id) {
            // a mission is taken on when a processor first asks for it (or asks again after
            // this echo restarted or let it go)
            if let Some(p) = PlanCache::lookup_consistent(
                self.node,
                r.mission_id,
                Duration::from_millis(1500),
                &mut self.report.plans_inconsistent,
            ) {
                self.add_plan(p);
            }
        }
        match self.accept(&r) {
            Ok(ack) => {
                if ack.queued {
                    self.report.requests += 1;
                } else {
                    self.report.merged += 1;
                }
                tracing::debug!(mission = %r.mission_id, aperture = r.aperture, look = ?r.look,
                    requester = %r.requester, queued = ack.queued, "request");
                if let Err(e) = q.reply(
                    &ack,
                    bridge::Meta {
                        mission_id: r.mission_id,
                        ..bridge::Meta::default()
                    },
                ) {
                    tracing::warn!(error = %e, "request reply failed");
                }
            }
            Err(refusal) => {
                self.report.refused += 1;
                tracing::warn!(mission = %r.mission_id, aperture = r.aperture, requester = %r.requester,
                    kind = %refusal.kind, "request refused: {}", refusal.message);
                if let Err(e) = q.refuse(&refusal) {
                    tracing::warn!(error = %e, "error reply failed");
                }
            }
        }
    }

    /// Queues the request, or says why not: a typed refusal, `busy` when the queue is full
    /// (ask again later), `bad_request` naming what does not fit this echo.
    fn accept(&mut self, r: &ApertureRequest) -> Result<RequestAck, Refusal> {
        let bad = |message: String| Refusal::new(RefusalKind::BadRequest, message);
        let Some(m) = self.missions.get_mut(&r.mission_id) else {
            return Err(bad(format!(
                "unknown mission {}: this echo has no plan for it (is a planner running?)",
                r.mission_id
            )));
        };
        m.last_used = Instant::now();
        let ctx = &m.ctx;
        let ap = r.aperture as usize;
        let Some(aperture) = ctx.apertures.get(ap) else {
            return Err(bad(format!(
                "aperture {ap} does not exist: mission {} has {} apertures",
                r.mission_id,
                ctx.apertures.len()
            )));
        };
        let look = r.look.map(|l| l as usize);
        if let Some(l) = look {
            if l >= aperture.looks {
                return Err(bad(format!(
                    "look {l} of aperture {ap} does not exist: it has {} looks",
                    aperture.looks
                )));
            }
        }
        if r.frame_pulses as usize != ctx.layout.frame_pulses() {
            return Err(bad(format!(
                "frame layout mismatch: the requester expects {} pulses per frame, this echo sends {} (give both the same --max-frame-bytes)",
                r.frame_pulses,
                ctx.layout.frame_pulses()
            )));
        }
        if r.scene_digest != ctx.scene_digest {
            return Err(bad(bridge::frame::scene_mismatch(
                r.scene_digest,
                ctx.scene_digest,
            )));
        }
        let slots = ctx.layout.slots(ap, look);
        let seqs: Vec<u64> = slots.iter().map(|(s, _)| *s).collect();
        let dup = self.queue.iter().any(|j| {
            j.mission == r.mission_id && j.aperture == ap && j.look == look && j.next == 0
        });
        let queued_before = self.queue.len() as u32;
        if !dup {
            if self.queue.len() >= self.args.max_queue {
                return Err(Refusal::new(
                    RefusalKind::Busy,
                    format!("busy: {} requests queued (--max-queue)", self.queue.len()),
                ));
            }
            self.queue.push_back(Job {
                mission: r.mission_id,
                aperture: ap,
                look,
                slots,
                pulses: Vec::new(),
                cluttered: None,
                next: 0,
            });
        }
        Ok(RequestAck {
            mission_id: r.mission_id,
            aperture: r.aperture,
            look: r.look,
            seqs,
            queued_before,
            queued: !dup,
            frame_key: Some(m.frame_key.clone()),
        })
    }

    /// Synthesises and sends the next frame of the first job.
    fn send_next(&mut self) -> ServiceResult<()> {
        let Some(job) = self.queue.front_mut() else {
            return Ok(());
        };
        let Some(m) = self.missions.get_mut(&job.mission) else {
            self.queue.pop_front();
            return Ok(());
        };
        let ctx = &m.ctx;
        if job.pulses.is_empty() {
            let ap = &ctx.apertures[job.aperture];
            job.pulses = ctx.setup.pulses(&ctx.track, ap);
            job.cluttered = match &m.clutter {
                Some(c) => Some(c.synthesizer(&ctx.setup, &m.objects, ap, &job.pulses)?),
                None => None,
            };
        }
        let Some(&(seq, slot)) = job.slots.get(job.next) else {
            self.queue.pop_front();
            return Ok(());
        };
        let chunk = job
            .pulses
            .get(slot.first_pulse..slot.first_pulse + slot.pulses)
            .ok_or_else(|| {
                ServiceError::Internal(format!(
                    "frame {seq}: pulses {}..{} outside aperture {}",
                    slot.first_pulse,
                    slot.first_pulse + slot.pulses,
                    job.aperture
                ))
            })?;
        let synth = job.cluttered.as_ref().unwrap_or(&m.synth);
        let iq = synth.synthesize_frame(chunk, Components::ALL)?;
        if m.publisher.is_none() {
            let spec =
                FrameServiceSpec::new(&pkeys::echo(ctx.mission_id)?, self.args.max_frame_bytes);
            m.publisher = Some(
                self.frames
                    .publisher(&spec, FramePublisherOptions::default())?,
            );
        }
        let Some(publisher) = m.publisher.as_ref() else {
            return Ok(());
        };
        let t_first_s = chunk.first().map_or(0.0, |p| p.t_s);
        let spp = ctx.layout.samples_per_pulse();
        let meta = FrameMeta::iq(
            ctx.mission_id,
            seq,
            (t_first_s * 1e9).round() as i64,
            slot.pulses as u32,
            spp as u32,
        )
        .with_scene(ctx.scene_digest);
        let bytes = bridge::frame::samples_as_bytes(&iq);
        // the tag lets a processor tell the echo's frames from a peer's that fit the layout
        let meta = meta.tagged(&m.frame_key, bytes);
        let sent = publisher.send_bytes(&meta, bytes)?;
        self.report.frames += 1;
        self.report.bytes += bytes.len() as u64;
        self.report.skipped_full += sent.skipped_full;
        let info = FrameInfo {
            mission_id: ctx.mission_id,
            seq,
            aperture: job.aperture as u32,
            look: slot.look as u32,
            first_pulse: (ctx.apertures[job.aperture].first_pulse + slot.first_pulse) as u64,
            pulses: slot.pulses as u32,
            samples_per_pulse: spp as u32,
            t_first_s,
            checksum: bridge::frame::checksum(bytes),
            delivered: sent.delivered as u32,
            skipped_full: sent.skipped_full as u32,
        };
        if let Err(e) = m.info.put_with(
            &info,
            bridge::Meta {
                mission_id: ctx.mission_id,
                seq,
                time_unix_ns: 0,
            },
        ) {
            tracing::debug!(error = %e, "frame info not published");
        }
        job.next += 1;
        if job.next >= job.slots.len() {
            self.report.jobs += 1;
            tracing::debug!(mission = %job.mission, aperture = job.aperture, look = ?job.look, "job done");
            self.queue.pop_front();
        }
        Ok(())
    }

    fn publish_status(&self, state: ServiceState, malformed: u64) {
        for (id, m) in &self.missions {
            let mut s = self.board.status(*id, state);
            s.total = m.ctx.layout.total_frames();
            s.done = self.report.frames;
            for (k, v) in [
                ("requests", self.report.requests),
                ("refused", self.report.refused),
                ("merged", self.report.merged),
                ("frames", self.report.frames),
                ("skipped_full", self.report.skipped_full),
                ("send_errors", self.report.send_errors),
                ("jobs", self.report.jobs),
                ("queued", self.queue.len() as u64),
                ("bytes", self.report.bytes),
                ("malformed", malformed),
            ] {
                s.counters.insert(k.to_string(), v);
            }
            s.message = format!(
                "{} frames sent, {} deliveries skipped (full buffers), {} jobs queued",
                self.report.frames,
                self.report.skipped_full,
                self.queue.len()
            );
            self.board.publish(self.node, &s);
        }
    }
}
