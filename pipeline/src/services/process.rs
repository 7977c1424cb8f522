//! `cellsar-radar-sim process-service`: pulls the apertures of each planned mission from the
//! echo, processes them one at a time (cancellation, compression, backprojection, CFAR,
//! scoring) and publishes detections, images and, at the end, the mission's metrics; the same
//! numbers as `cellsar-radar-sim process` on the recording of the same mission.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::plan::{write_atomic, PlanCache, StatusBoard};
use crate::protocol::keys::{self as pkeys, ALL_PLANS};
use crate::protocol::{Plan, MAX_PLAN_BYTES};
use bridge::envelope::{self, DecodeLimits, Meta};
use bridge::flags::Seconds;
use bridge::net::{
    FrameSubscribeOptions, PublishOptions, QueryOptions, SubscribeOptions, TypedPublisher,
};
use bridge::{
    Complex32, FrameNode, FrameServiceSpec, IoxArgs, Message, MissionId, ZenohArgs, ZenohNode,
};
use serde::{Deserialize, Serialize};

use crate::args::IqLimitArgs;
use radar_sim::config::SceneFile;
use radar_sim::limits::{IqBudget, IqLimits};
use radar_sim::pipeline::{Processor, RadarSetup};
use radar_sim::run::{MeasuredResolution, Metrics};
use radar_sim::scene::SceneObject;
use radar_sim::tally::{self, ApertureTally};
use radar_sim::track::{Aperture, PlannedTrack, PulseMeta};

use super::radar::{ServiceError, ServiceResult, DEFAULT_MAX_FRAME_BYTES};
use crate::protocol::{
    ApertureDetections, ApertureImage, ApertureRequest, Detection, FrameLayout, MissionMetrics,
    RequestAck, ResultAck, ResultRequest,
};

/// What every radar service derives from a plan and a scene.
#[derive(Debug)]
pub struct MissionContext {
    /// Mission id.
    pub mission_id: MissionId,
    /// The plan.
    pub plan: Arc<Plan>,
    /// The validated mission.
    pub mission: planner::Mission,
    /// Radar setup (mission parameters + scene).
    pub setup: RadarSetup,
    /// One aperture per landmark window.
    pub apertures: Vec<Aperture>,
    /// Which frame carries which pulses.
    pub layout: FrameLayout,
    /// The planned track at the mission altitude.
    pub track: PlannedTrack,
}

impl MissionContext {
    /// Resolves a plan against a scene under the default [`IqLimits`]; errors name the
    /// mission.
    pub fn new(plan: &Arc<Plan>, scene: &SceneFile, max_frame_bytes: usize) -> ServiceResult<Self> {
        Self::with_limits(plan, scene, max_frame_bytes, &IqLimits::default())
    }

    /// Resolves a plan against a scene; a mission whose IQ or largest aperture exceeds
    /// `limits` is refused ([`radar_sim::limits::IqBudget`]); errors name the mission.
    pub fn with_limits(
        plan: &Arc<Plan>,
        scene: &SceneFile,
        max_frame_bytes: usize,
        limits: &IqLimits,
    ) -> ServiceResult<Self> {
        let mission = plan.mission().map_err(|e| ServiceError::Mission {
            mission: plan.mission_id,
            reason: e.to_string(),
        })?;
        let setup = RadarSetup::new(mission.params(), scene)?;
        let apertures = setup.apertures(&mission)?;
        IqBudget::new(&setup, &apertures).check(&setup, limits)?;
        let spp = setup.scene.radar.samples_per_pulse();
        let layout = FrameLayout::new(&apertures, spp, max_frame_bytes)?;
        let track = PlannedTrack::new(plan.result.trajectory.clone(), mission.params().altitude_m);
        Ok(MissionContext {
            mission_id: plan.mission_id,
            plan: plan.clone(),
            mission,
            setup,
            apertures,
            layout,
            track,
        })
    }
}

/// Where the processor takes frames from.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameSource {
    /// The iceoryx2 service `cellsar/<mission>/echo` on this host (zero copy).
    Iox,
    /// The Zenoh key `cellsar/<mission>/echo` (frames from another host via cellsar-bridge).
    Zenoh,
}

/// Flags of `cellsar-radar-sim process-service`.
#[derive(clap::Args, Debug, Clone)]
pub struct ProcessArgs {
    /// Instance name (liveliness token `cellsar/alive/processor/<instance>`).
    #[arg(long, default_value = "processor")]
    pub instance: String,
    /// Scene file (TOML): the processing settings and the truth used for scoring.
    #[arg(long)]
    pub scene: PathBuf,
    /// Largest frame payload in bytes (as given to the echo and the bridge).
    #[arg(long, default_value_t = DEFAULT_MAX_FRAME_BYTES)]
    pub max_frame_bytes: usize,
    /// Where frames come from.
    #[arg(long, value_enum, default_value_t = FrameSource::Iox)]
    pub frames: FrameSource,
    /// Apertures asked for at once.
    #[arg(long, default_value_t = 2)]
    pub window: usize,
    /// Ask again for an aperture when no frame of its mission arrived for this long, s.
    #[arg(long, default_value = "10", value_parser = bridge::flags::parse_seconds)]
    pub resend_after_s: Seconds,
    /// Store finished apertures here; after a restart, resume with the next one.
    #[arg(long, value_name = "DIR")]
    pub state_dir: Option<PathBuf>,
    /// Seconds between status publications.
    #[arg(long, default_value = "1", value_parser = bridge::flags::parse_seconds)]
    pub status_interval_s: Seconds,
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

/// What the processor did, at exit.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ProcessReport {
    /// Apertures processed in this run.
    pub apertures: u64,
    /// Apertures restored from the state directory.
    pub restored: u64,
    /// Missions finished (metrics published).
    pub missions: u64,
    /// Frames received.
    pub frames: u64,
    /// Frames used.
    pub used: u64,
    /// Frames already held (re-sent copies), dropped.
    pub duplicates: u64,
    /// Frames no aperture was waiting for, dropped.
    pub unsolicited: u64,
    /// Frames inconsistent with the mission's layout, dropped.
    pub bad: u64,
    /// Frames dropped because the receive queue was full.
    pub dropped: u64,
    /// Frames the transport reported as missed (sequence gaps) or malformed.
    pub transport_lost: u64,
    /// Requests sent to the echo (first requests and re-requests).
    pub requests: u64,
    /// Re-requests.
    pub resends: u64,
    /// Requests that failed (no echo, refused).
    pub request_errors: u64,
    /// Results published again on request or after a restart.
    pub republished: u64,
}

/// One processed aperture: everything `cellsar-radar-sim process` derives from it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ApertureOutcome {
    /// Its detections and what it adds to the mission's metrics.
    pub tally: ApertureTally,
    /// The image.
    pub image: ApertureImage,
    /// Processing time, s.
    pub process_s: f64,
}

impl ApertureOutcome {
    /// Aperture index.
    pub fn aperture(&self) -> usize {
        self.tally.summary.aperture
    }
}

/// A per-aperture outcome as the processor stores it in `--state-dir`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StoredOutcome {
    /// The outcome.
    pub outcome: ApertureOutcome,
}

impl Message for StoredOutcome {
    const KIND: u16 = 0x0309;
    const NAME: &'static str = "radar.stored_outcome";
    /// 2: the outcome nests its tally and no longer repeats the aperture index (a version-1
    /// file in a state directory is ignored, and that aperture processed again). 3: the tally
    /// carries the physics review's metrics (an older file is ignored the same way).
    const SCHEMA_VERSION: u16 = 3;
}

/// The pulse as `cellsar-radar-sim simulate` writes it to `pulses.csv` and `process` reads it
/// back (same number formats), so that both processors see identical inputs.
pub fn pulse_as_recorded(p: &PulseMeta) -> PulseMeta {
    let r = |s: String| s.parse::<f64>().unwrap_or(f64::NAN);
    PulseMeta {
        index: p.index,
        aperture: p.aperture,
        look: p.look,
        t_s: r(format!("{:.9}", p.t_s)),
        symbol: p.symbol,
        pos_m: [
            r(format!("{:.6}", p.pos_m[0])),
            r(format!("{:.6}", p.pos_m[1])),
            r(format!("{:.6}", p.pos_m[2])),
        ],
        vel_mps: [
            r(format!("{:.6}", p.vel_mps[0])),
            r(format!("{:.6}", p.vel_mps[1])),
            r(format!("{:.6}", p.vel_mps[2])),
        ],
        heading: [
            r(format!("{:.12}", p.heading[0])),
            r(format!("{:.12}", p.heading[1])),
        ],
        window_delay_samples: p.window_delay_samples,
    }
}

/// The object as written to `truth.csv` and read back (same number formats).
pub fn object_as_recorded(o: &SceneObject) -> SceneObject {
    let r = |s: String| s.parse::<f64>().unwrap_or(f64::NAN);
    SceneObject {
        id: o.id,
        x_m: r(format!("{:.6}", o.x_m)),
        y_m: r(format!("{:.6}", o.y_m)),
        rcs_m2: r(format!("{:.6e}", o.rcs_m2)),
        phase_rad: r(format!("{:.9}", o.phase_rad)),
        landmark: o.landmark,
    }
}

/// The processor's view of a mission: the shared context, the processor, the pulses and the
/// truth as recorded.
pub struct ProcContext {
    /// The shared context.
    pub base: Arc<MissionContext>,
    /// The processor.
    pub proc: Processor,
    /// Pulses per aperture.
    pub pulses: Vec<Vec<PulseMeta>>,
    /// Truth objects (for scoring).
    pub truth: Vec<SceneObject>,
    /// Noise power per complex sample, W.
    pub noise_power_w: f64,
}

impl ProcContext {
    /// Builds the processor's context of a mission.
    pub fn new(base: Arc<MissionContext>) -> ServiceResult<Self> {
        let setup = &base.setup;
        let proc = Processor::new(setup.clone())?;
        let pulses = base
            .apertures
            .iter()
            .map(|ap| {
                setup
                    .pulses(&base.track, ap)
                    .iter()
                    .map(pulse_as_recorded)
                    .collect()
            })
            .collect();
        let truth = setup
            .objects(&base.mission)?
            .iter()
            .map(object_as_recorded)
            .collect();
        let noise_power_w = setup.synthesizer(Vec::new())?.noise_power_w();
        Ok(ProcContext {
            base,
            proc,
            pulses,
            truth,
            noise_power_w,
        })
    }

    /// Processes aperture `k` from its IQ (`pulses × samples`).
    pub fn process(&self, k: usize, iq: &[Complex32]) -> ServiceResult<ApertureOutcome> {
        let t0 = Instant::now();
        let ap =
            self.base.apertures.get(k).ok_or_else(|| {
                ServiceError::Internal(format!("aperture {k} is not in the mission"))
            })?;
        let pulses = &self.pulses[k];
        let r = self.proc.process_aperture(ap, pulses, iq, &self.truth)?;
        let markers = tally::detection_pixels(&r)
            .into_iter()
            .map(|(x, y)| (x as u32, y as u32))
            .collect();
        Ok(ApertureOutcome {
            tally: ApertureTally::new(ap, &r, self.noise_power_w),
            image: ApertureImage {
                mission_id: self.base.mission_id,
                aperture: ap.index as u32,
                nx: r.grid.nx as u32,
                ny: r.grid.ny as u32,
                centre_m: r.grid.centre_m,
                spacing_m: r.grid.spacing_m,
                multilook: r.multilook,
                markers,
            },
            process_s: t0.elapsed().as_secs_f64(),
        })
    }

    /// Measures the resolution on one look of aperture `k` (as `process` does on the
    /// strongest landmark); None when the measurement fails, as there.
    pub fn resolution(
        &self,
        k: usize,
        look: usize,
        iq: &[Complex32],
    ) -> ServiceResult<Option<(MeasuredResolution, MeasuredResolution)>> {
        let ap =
            self.base.apertures.get(k).ok_or_else(|| {
                ServiceError::Internal(format!("aperture {k} is not in the mission"))
            })?;
        let pulses: Vec<PulseMeta> = self.pulses[k]
            .iter()
            .filter(|p| p.look == look)
            .copied()
            .collect();
        Ok(tally::measure_look(&self.proc, ap, &pulses, iq)?)
    }
}

/// Folds per-aperture outcomes (in aperture order) into the mission's metrics, as `process`
/// does; returns them with the (aperture, look) of the resolution measurement, if any.
pub fn fold_metrics(
    outcomes: &[&ApertureOutcome],
    noise_power_w: f64,
) -> (Metrics, Option<(usize, usize)>) {
    tally::fold(outcomes.iter().map(|o| &o.tally), noise_power_w)
}

/// The detections message of an outcome.
pub fn detections_message(
    id: MissionId,
    o: &ApertureOutcome,
    apertures: usize,
    processor: &str,
) -> ApertureDetections {
    ApertureDetections {
        mission_id: id,
        aperture: o.aperture() as u32,
        apertures: apertures as u32,
        landmark: o.tally.summary.landmark,
        landmark_detected: o.tally.summary.landmark_detected,
        landmark_snr_db: o.tally.summary.landmark_snr_db.filter(|v| v.is_finite()),
        detections: o.tally.rows.iter().map(Detection::from).collect(),
        false_alarms: o.tally.false_alarms,
        process_s: o.process_s,
        processor: processor.to_string(),
    }
}

// ---------------------------------------------------------------------------------------------
// The service

/// A frame copied out of the transport.
struct RawFrame {
    mission: MissionId,
    seq: u64,
    mission_time_ns: i64,
    rows: usize,
    cols: usize,
    samples: Vec<Complex32>,
}

enum ReceiverCmd {
    Watch(MissionId),
}

enum Job {
    Aperture {
        ctx: Arc<ProcContext>,
        k: usize,
        iq: Vec<Complex32>,
    },
    Resolution {
        ctx: Arc<ProcContext>,
        k: usize,
        look: usize,
        iq: Vec<Complex32>,
    },
}

enum JobResult {
    Aperture(MissionId, Box<ServiceResult<ApertureOutcome>>),
    Resolution(
        MissionId,
        ServiceResult<Option<(MeasuredResolution, MeasuredResolution)>>,
        (usize, usize),
    ),
}

struct RequestJob {
    mission: MissionId,
    aperture: usize,
    look: Option<usize>,
    frame_pulses: usize,
}

struct RequestDone {
    mission: MissionId,
    aperture: usize,
    look: Option<usize>,
    result: Result<RequestAck, String>,
}

/// An aperture (or one look) being filled from frames.
struct Assembly {
    look: Option<usize>,
    /// Sample offset of the first pulse held (the look's first pulse for a look).
    first_pulse: usize,
    buf: Vec<Complex32>,
    want: BTreeMap<u64, (usize, usize)>, // seq -> (first pulse within the aperture, pulses)
    have: usize,
    requested: Option<Instant>,
    retry_at: Option<Instant>,
    request_pending: bool,
    attempts: u32,
}

impl Assembly {
    fn new(ctx: &ProcContext, k: usize, look: Option<usize>) -> Assembly {
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

    fn complete(&self) -> bool {
        self.want.is_empty()
    }
}

struct Run {
    ctx: Arc<ProcContext>,
    dir: Option<PathBuf>,
    outcomes: BTreeMap<usize, ApertureOutcome>,
    assembling: BTreeMap<usize, Assembly>,
    look: Option<(usize, Assembly)>,
    ready: VecDeque<Job>,
    in_worker: Option<usize>,
    metrics: Option<MissionMetrics>,
    failures: HashMap<usize, u32>,
    failed: Option<String>,
    subscribed: bool,
    resolving: bool,
    last_frame: Instant,
    started: Instant,
}

/// Runs the processor service until `stop` is set. A stop while the Zenoh session still
/// opens (a client waiting for its router) ends it at once with an empty report.
pub fn run_processor(args: &ProcessArgs, stop: &AtomicBool) -> ServiceResult<ProcessReport> {
    if args.window == 0 {
        return Err(ServiceError::Flag("--window must be at least 1".into()));
    }
    let limits = args.limits.limits()?;
    let scene = SceneFile::from_path(&args.scene)?;
    let env = args.iox.env()?;
    let config = args.zenoh.to_config()?;
    let Some(node) = ZenohNode::open_until(config, "processor", &args.instance, stop)? else {
        return Ok(ProcessReport::default());
    };
    let r = serve(args, limits, &scene, &node, &env, stop);
    if let Err(e) = node.close() {
        tracing::warn!(error = %e, "closing the Zenoh session");
    }
    r
}

fn serve(
    args: &ProcessArgs,
    limits: IqLimits,
    scene: &SceneFile,
    node: &ZenohNode,
    env: &bridge::IoxEnv,
    stop: &AtomicBool,
) -> ServiceResult<ProcessReport> {
    let (frame_tx, frame_rx) = mpsc::sync_channel::<RawFrame>(16);
    let (cmd_tx, cmd_rx) = mpsc::channel::<ReceiverCmd>();
    let (watch_tx, watch_rx) = mpsc::channel::<MissionId>();
    let (req_tx, req_rx) = mpsc::channel::<RequestJob>();
    let (done_tx, done_rx) = mpsc::channel::<RequestDone>();
    let (job_tx, job_rx) = mpsc::channel::<Job>();
    let (res_tx, res_rx) = mpsc::channel::<JobResult>();
    let lost = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let dropped = Arc::new(std::sync::atomic::AtomicU64::new(0));

    // the worker owns no borrowed state, so a stop never waits for an aperture in progress
    std::thread::Builder::new()
        .name("process-worker".into())
        .spawn(move || worker(job_rx, res_tx))
        .map_err(|e| ServiceError::Internal(format!("starting the worker: {e}")))?;

    let zenoh_frames = match args.frames {
        FrameSource::Zenoh => Some(node.frame_subscriber(
            pkeys::ALL_ECHO,
            FrameSubscribeOptions {
                capacity: 16,
                max_payload_bytes: args.max_frame_bytes,
                ..FrameSubscribeOptions::default()
            },
        )?),
        FrameSource::Iox => None,
    };
    let recv_stop = AtomicBool::new(false);
    std::thread::scope(|scope| -> ServiceResult<ProcessReport> {
        let (l2, d2) = (lost.clone(), dropped.clone());
        let recv_stop_ref = &recv_stop;
        let receiver = std::thread::Builder::new()
            .name("frames".into())
            .spawn_scoped(scope, move || match zenoh_frames {
                Some(sub) => receive_zenoh(sub, frame_tx, recv_stop_ref, &l2, &d2),
                None => receive_iox(
                    env,
                    args,
                    cmd_rx,
                    watch_tx,
                    frame_tx,
                    recv_stop_ref,
                    &l2,
                    &d2,
                ),
            })
            .map_err(|e| ServiceError::Internal(format!("starting the frame receiver: {e}")))?;
        let requester = std::thread::Builder::new()
            .name("requests".into())
            .spawn_scoped(scope, move || {
                requester(node, &args.instance, req_rx, done_tx)
            })
            .map_err(|e| ServiceError::Internal(format!("starting the requester: {e}")))?;
        let mut p = Proc {
            args,
            limits,
            scene,
            node,
            cache: PlanCache::new(node, None)?,
            board: StatusBoard::new("processor", &args.instance),
            runs: Vec::new(),
            detections: HashMap::new(),
            images: HashMap::new(),
            metrics_pubs: HashMap::new(),
            report: ProcessReport::default(),
            cmd_tx,
            req_tx,
            job_tx,
            worker_busy: false,
            malformed: 0,
            frames_over_zenoh: args.frames == FrameSource::Zenoh,
        };
        let result = p.run(
            stop, &frame_rx, &watch_rx, &done_rx, &res_rx, &lost, &dropped,
        );
        recv_stop.store(true, Ordering::Relaxed);
        drop(p);
        let r1 = receiver
            .join()
            .map_err(|_| ServiceError::Internal("the frame receiver panicked".into()))?;
        let _ = requester.join();
        r1?;
        result
    })
}

fn worker(jobs: Receiver<Job>, results: Sender<JobResult>) {
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

fn requester(
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

fn forward(tx: &SyncSender<RawFrame>, f: RawFrame, dropped: &std::sync::atomic::AtomicU64) -> bool {
    match tx.try_send(f) {
        Ok(()) => true,
        Err(TrySendError::Full(_)) => {
            dropped.fetch_add(1, Ordering::Relaxed);
            true
        }
        Err(TrySendError::Disconnected(_)) => false,
    }
}

fn receive_zenoh(
    sub: bridge::net::ZenohFrameSubscriber,
    tx: SyncSender<RawFrame>,
    stop: &AtomicBool,
    lost: &std::sync::atomic::AtomicU64,
    dropped: &std::sync::atomic::AtomicU64,
) -> ServiceResult<()> {
    let mut last_bad = 0;
    while !stop.load(Ordering::Relaxed) {
        let c = sub.counters().snapshot();
        let bad = c.malformed + c.dropped;
        if bad > last_bad {
            lost.fetch_add(bad - last_bad, Ordering::Relaxed);
            last_bad = bad;
        }
        let Some(f) = sub.recv_timeout(Duration::from_millis(50)) else {
            continue;
        };
        let samples = match f.samples() {
            Ok(s) => s.to_vec(),
            Err(e) => {
                tracing::warn!(error = %e, "frame with a payload that is not complex f32");
                lost.fetch_add(1, Ordering::Relaxed);
                continue;
            }
        };
        let h = f.header;
        let raw = RawFrame {
            mission: h.mission(),
            seq: h.seq,
            mission_time_ns: h.mission_time_ns,
            rows: h.shape[0] as usize,
            cols: h.shape[1] as usize,
            samples,
        };
        if !forward(&tx, raw, dropped) {
            break;
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn receive_iox(
    env: &bridge::IoxEnv,
    args: &ProcessArgs,
    cmds: Receiver<ReceiverCmd>,
    watching: Sender<MissionId>,
    tx: SyncSender<RawFrame>,
    stop: &AtomicBool,
    lost: &std::sync::atomic::AtomicU64,
    dropped: &std::sync::atomic::AtomicU64,
) -> ServiceResult<()> {
    let (frames, cleanup) = FrameNode::new(env, &format!("processor-{}", args.instance))?;
    if cleanup.cleaned > 0 {
        tracing::info!(
            cleaned = cleanup.cleaned,
            "stale iceoryx2 resources of dead processes removed"
        );
    }
    let mut subs: Vec<(MissionId, bridge::FrameSubscriber, u64)> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        while let Ok(ReceiverCmd::Watch(id)) = cmds.try_recv() {
            if subs.iter().any(|(m, _, _)| *m == id) {
                continue;
            }
            let spec = FrameServiceSpec::new(&pkeys::echo(id)?, args.max_frame_bytes);
            subs.push((id, frames.subscriber(&spec)?, 0));
            tracing::info!(mission = %id, service = %spec.name, "subscribed to frames");
            let _ = watching.send(id);
        }
        let mut got = false;
        for (_, s, seen_lost) in &mut subs {
            while let Some(f) = s.receive()? {
                got = true;
                let h = *f.header();
                if let Err(e) = f.verify_checksum() {
                    tracing::warn!(seq = h.seq, error = %e, "frame checksum");
                    lost.fetch_add(1, Ordering::Relaxed);
                    continue;
                }
                let samples = match f.samples() {
                    Ok(s) => s.to_vec(),
                    Err(e) => {
                        tracing::warn!(seq = h.seq, error = %e, "frame payload is not complex f32");
                        lost.fetch_add(1, Ordering::Relaxed);
                        continue;
                    }
                };
                drop(f);
                let raw = RawFrame {
                    mission: h.mission(),
                    seq: h.seq,
                    mission_time_ns: h.mission_time_ns,
                    rows: h.shape[0] as usize,
                    cols: h.shape[1] as usize,
                    samples,
                };
                if !forward(&tx, raw, dropped) {
                    return Ok(());
                }
            }
            let now_lost = s.missed() + s.counters().snapshot().malformed;
            if now_lost > *seen_lost {
                lost.fetch_add(now_lost - *seen_lost, Ordering::Relaxed);
                *seen_lost = now_lost;
            }
        }
        if !got {
            match subs.last() {
                Some((_, s, _)) => {
                    s.wait(Duration::from_millis(20))?;
                }
                None => std::thread::sleep(Duration::from_millis(20)),
            }
        }
    }
    Ok(())
}

struct Proc<'a> {
    args: &'a ProcessArgs,
    /// `args.limits`, parsed once at start.
    limits: IqLimits,
    scene: &'a SceneFile,
    node: &'a ZenohNode,
    cache: PlanCache,
    board: StatusBoard,
    runs: Vec<Run>,
    detections: HashMap<MissionId, TypedPublisher<ApertureDetections>>,
    images: HashMap<(MissionId, usize), TypedPublisher<ApertureImage>>,
    metrics_pubs: HashMap<MissionId, TypedPublisher<MissionMetrics>>,
    report: ProcessReport,
    cmd_tx: Sender<ReceiverCmd>,
    req_tx: Sender<RequestJob>,
    job_tx: Sender<Job>,
    worker_busy: bool,
    malformed: u64,
    frames_over_zenoh: bool,
}

impl Proc<'_> {
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        stop: &AtomicBool,
        frames: &Receiver<RawFrame>,
        watching: &Receiver<MissionId>,
        requests_done: &Receiver<RequestDone>,
        results: &Receiver<JobResult>,
        lost: &std::sync::atomic::AtomicU64,
        dropped: &std::sync::atomic::AtomicU64,
    ) -> ServiceResult<ProcessReport> {
        let plans = self.node.subscriber::<Plan>(
            ALL_PLANS,
            SubscribeOptions {
                capacity: 16,
                limits: DecodeLimits {
                    max_body_bytes: MAX_PLAN_BYTES,
                    verify_crc: true,
                },
                ..SubscribeOptions::default()
            },
        )?;
        let result_requests = self.node.queryable::<ResultRequest>(
            pkeys::ALL_RESULTS,
            SubscribeOptions {
                capacity: 64,
                ..SubscribeOptions::default()
            },
        )?;
        let mut last_lookup = Instant::now();
        match PlanCache::lookup(self.node, ALL_PLANS, Duration::from_secs(2)) {
            Ok(found) => {
                for p in found {
                    self.add_plan(p);
                }
            }
            Err(e) => tracing::warn!(error = %e, "plan lookup at start failed"),
        }
        tracing::info!(instance = %self.args.instance, frames = ?self.args.frames, "processor ready");
        let interval = self.args.status_interval_s.duration();
        let mut last_status = Instant::now();
        while !stop.load(Ordering::Relaxed) {
            while let Some(p) = plans.try_recv() {
                self.add_plan(p.message);
            }
            if self.runs.iter().all(|r| r.metrics.is_some())
                && last_lookup.elapsed() > Duration::from_secs(5)
            {
                // a plan published while this process was down: ask for it
                last_lookup = Instant::now();
                if let Ok(found) = PlanCache::lookup(self.node, ALL_PLANS, Duration::from_secs(1)) {
                    for p in found {
                        self.add_plan(p);
                    }
                }
            }
            while let Ok(id) = watching.try_recv() {
                if let Some(i) = self.run_index(id) {
                    self.runs[i].subscribed = true;
                }
            }
            let mut idle = true;
            while let Ok(f) = frames.try_recv() {
                idle = false;
                self.on_frame(f);
            }
            while let Ok(d) = requests_done.try_recv() {
                idle = false;
                self.on_request_done(d);
            }
            while let Ok(r) = results.try_recv() {
                idle = false;
                self.worker_busy = false;
                self.on_result(r)?;
            }
            while let Some(q) = result_requests.recv_timeout(Duration::ZERO) {
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
            self.report.transport_lost = lost.load(Ordering::Relaxed);
            self.report.dropped = dropped.load(Ordering::Relaxed);
            self.malformed = plans.counters().snapshot().malformed
                + result_requests.counters().snapshot().malformed
                + self.cache.malformed();
            if last_status.elapsed() >= interval {
                last_status = Instant::now();
                self.publish_status();
            }
            if idle {
                if let Ok(f) = frames.recv_timeout(Duration::from_millis(10)) {
                    self.on_frame(f);
                }
            }
        }
        self.publish_status();
        let r = &self.report;
        tracing::info!(
            final_counters = true,
            apertures = r.apertures,
            restored = r.restored,
            missions = r.missions,
            frames = r.frames,
            used = r.used,
            duplicates = r.duplicates,
            unsolicited = r.unsolicited,
            bad = r.bad,
            dropped = r.dropped,
            transport_lost = r.transport_lost,
            requests = r.requests,
            resends = r.resends,
            request_errors = r.request_errors,
            republished = r.republished,
            plans_malformed = plans.counters().snapshot().malformed,
            result_requests_malformed = result_requests.counters().snapshot().malformed,
            lookups_malformed = self.cache.malformed(),
            "processor stopping"
        );
        Ok(self.report.clone())
    }

    fn add_plan(&mut self, plan: Plan) {
        let id = plan.mission_id;
        if self.runs.iter().any(|r| r.ctx.base.mission_id == id) {
            return;
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
        let mut run = Run {
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
            subscribed: self.frames_over_zenoh,
            resolving: false,
            last_frame: Instant::now(),
            started: Instant::now(),
        };
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

    fn run_index(&self, id: MissionId) -> Option<usize> {
        self.runs.iter().position(|r| r.ctx.base.mission_id == id)
    }

    fn on_frame(&mut self, f: RawFrame) {
        self.report.frames += 1;
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
        run.last_frame = Instant::now();
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
        let now = Instant::now();
        let idle = run.last_frame.elapsed() >= resend;
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
            let due = match (a.requested, a.retry_at) {
                (None, _) => true,
                (Some(_), Some(t)) => now >= t,
                (Some(t), None) => idle && t.elapsed() >= resend,
            };
            if due {
                if a.requested.is_some() {
                    self.report.resends += 1;
                    tracing::info!(mission = %id, aperture = k, look = ?a.look, missing = a.want.len(), "asking again");
                }
                a.requested = Some(now);
                a.retry_at = None;
                a.request_pending = true;
                a.attempts += 1;
                sent.push(RequestJob {
                    mission: id,
                    aperture: k,
                    look: a.look,
                    frame_pulses: fp,
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

    fn on_request_done(&mut self, d: RequestDone) {
        let Some(i) = self.run_index(d.mission) else {
            return;
        };
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
                let expected: Vec<u64> = run.ctx.base.layout.seqs(d.aperture, d.look);
                if ack.seqs != expected {
                    tracing::warn!(mission = %d.mission, aperture = d.aperture, "the echo announced other frames than expected");
                }
            }
            Err(e) => {
                self.report.request_errors += 1;
                tracing::warn!(mission = %d.mission, aperture = d.aperture, attempt = a.attempts, "request failed: {e}");
                // retry soon, whether frames flow or not
                a.retry_at = Some(Instant::now() + Duration::from_secs(1));
            }
        }
    }

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
                            store(d, &o)?;
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
                };
                if let Some(d) = &run.dir {
                    store_metrics(d, &mm)?;
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

    fn publish_outcome(&mut self, i: usize, k: usize) {
        let run = &self.runs[i];
        let id = run.ctx.base.mission_id;
        let Some(o) = run.outcomes.get(&k) else {
            return;
        };
        let n = run.ctx.base.apertures.len();
        let msg = detections_message(id, o, n, &self.args.instance);
        let meta = Meta {
            mission_id: id,
            seq: k as u64,
            time_unix_ns: 0,
        };
        if !self.detections.contains_key(&id) {
            let made = pkeys::detections(id)
                .map_err(ServiceError::from)
                .and_then(|key| {
                    Ok(self.node.publisher::<ApertureDetections>(
                        &key,
                        PublishOptions {
                            mission_id: id,
                            ..PublishOptions::json()
                        },
                    )?)
                });
            match made {
                Ok(p) => {
                    self.detections.insert(id, p);
                }
                Err(e) => tracing::warn!(error = %e, "detections publisher"),
            }
        }
        if let Some(p) = self.detections.get(&id) {
            if let Err(e) = p.put_with(&msg, meta) {
                tracing::warn!(error = %e, "detections not published");
            }
        }
        if !self.images.contains_key(&(id, k)) {
            let made = pkeys::image(id, k)
                .map_err(ServiceError::from)
                .and_then(|key| {
                    Ok(self.node.publisher::<ApertureImage>(
                        &key,
                        PublishOptions {
                            mission_id: id,
                            ..PublishOptions::default()
                        },
                    )?)
                });
            match made {
                Ok(p) => {
                    self.images.insert((id, k), p);
                }
                Err(e) => tracing::warn!(error = %e, "image publisher"),
            }
        }
        if let Some(p) = self.images.get(&(id, k)) {
            if let Err(e) = p.put_with(&o.image, meta) {
                tracing::warn!(error = %e, "image not published");
            }
        }
    }

    fn publish_metrics(&mut self, i: usize) {
        let run = &self.runs[i];
        let id = run.ctx.base.mission_id;
        let Some(m) = &run.metrics else { return };
        if !self.metrics_pubs.contains_key(&id) {
            let made = pkeys::metrics(id)
                .map_err(ServiceError::from)
                .and_then(|key| {
                    Ok(self.node.publisher::<MissionMetrics>(
                        &key,
                        PublishOptions {
                            mission_id: id,
                            ..PublishOptions::default()
                        },
                    )?)
                });
            match made {
                Ok(p) => {
                    self.metrics_pubs.insert(id, p);
                }
                Err(e) => tracing::warn!(error = %e, "metrics publisher"),
            }
        }
        if let Some(p) = self.metrics_pubs.get(&id) {
            if let Err(e) = p.put_with(
                m,
                Meta {
                    mission_id: id,
                    ..Meta::default()
                },
            ) {
                tracing::warn!(error = %e, "metrics not published");
            }
        }
    }

    fn republish(&mut self, req: &ResultRequest) -> ResultAck {
        let mut ack = ResultAck {
            republished: Vec::new(),
            missing: Vec::new(),
            metrics: false,
        };
        let Some(i) = self.run_index(req.mission_id) else {
            ack.missing = req.apertures.clone();
            return ack;
        };
        for &k in &req.apertures {
            if self.runs[i].outcomes.contains_key(&(k as usize)) {
                self.publish_outcome(i, k as usize);
                self.report.republished += 1;
                ack.republished.push(k);
            } else {
                ack.missing.push(k);
            }
        }
        if req.metrics && self.runs[i].metrics.is_some() {
            self.publish_metrics(i);
            ack.metrics = true;
        }
        ack
    }

    fn publish_status(&self) {
        for run in &self.runs {
            let id = run.ctx.base.mission_id;
            let state = if run.metrics.is_some() {
                "done"
            } else if run.failed.is_some() {
                "failed"
            } else {
                "running"
            };
            let mut s = self.board.status(id, state);
            s.total = run.ctx.base.apertures.len() as u64;
            s.done = run.outcomes.len() as u64;
            s.done_items = run.outcomes.keys().map(|k| *k as u64).collect();
            let r = &self.report;
            for (k, v) in [
                ("apertures", r.apertures),
                ("restored", r.restored),
                ("frames", r.frames),
                ("used", r.used),
                ("duplicates", r.duplicates),
                ("unsolicited", r.unsolicited),
                ("bad", r.bad),
                ("dropped", r.dropped),
                ("transport_lost", r.transport_lost),
                ("requests", r.requests),
                ("resends", r.resends),
                ("request_errors", r.request_errors),
                ("republished", r.republished),
                ("metrics", u64::from(run.metrics.is_some())),
                ("malformed", self.malformed + r.transport_lost),
            ] {
                s.counters.insert(k.to_string(), v);
            }
            if let Some(f) = &run.failed {
                s.message = format!("failed: {f}");
                self.board.publish(self.node, &s);
                continue;
            }
            s.message = format!(
                "{}/{} apertures, assembling {:?}, {} frames ({} duplicates, {} lost in transport)",
                s.done,
                s.total,
                run.assembling.keys().collect::<Vec<_>>(),
                r.frames,
                r.duplicates,
                r.transport_lost
            );
            self.board.publish(self.node, &s);
        }
    }
}

fn outcome_path(dir: &Path, k: usize) -> PathBuf {
    dir.join(format!("aperture_{k:03}.outcome"))
}

fn store(dir: &Path, o: &ApertureOutcome) -> ServiceResult<()> {
    std::fs::create_dir_all(dir).map_err(|source| ServiceError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let bytes = envelope::encode(&StoredOutcome { outcome: o.clone() }, Meta::default()).map_err(
        |source| ServiceError::Codec {
            what: format!("aperture {}", o.aperture()),
            source,
        },
    )?;
    write_atomic(&outcome_path(dir, o.aperture()), &bytes)?;
    Ok(())
}

fn store_metrics(dir: &Path, m: &MissionMetrics) -> ServiceResult<()> {
    std::fs::create_dir_all(dir).map_err(|source| ServiceError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let bytes = envelope::encode(m, Meta::default()).map_err(|source| ServiceError::Codec {
        what: "metrics".into(),
        source,
    })?;
    write_atomic(&dir.join("metrics.bin"), &bytes)?;
    Ok(())
}

type Restored = (BTreeMap<usize, ApertureOutcome>, Option<MissionMetrics>);

fn restore(dir: &Path, apertures: usize) -> ServiceResult<Restored> {
    let limits = DecodeLimits {
        max_body_bytes: 64 << 20,
        verify_crc: true,
    };
    let mut out = BTreeMap::new();
    if !dir.exists() {
        return Ok((out, None));
    }
    for k in 0..apertures {
        let p = outcome_path(dir, k);
        if !p.exists() {
            continue;
        }
        let bytes = std::fs::read(&p).map_err(|source| ServiceError::Io {
            path: p.clone(),
            source,
        })?;
        match envelope::decode::<StoredOutcome>(&bytes, &limits) {
            Ok(e) if e.message.outcome.aperture() == k => {
                out.insert(k, e.message.outcome);
            }
            Ok(_) => {
                tracing::warn!(file = %p.display(), "stored outcome of another aperture, ignored")
            }
            Err(e) => {
                tracing::warn!(file = %p.display(), error = %e, "stored outcome unreadable, ignored")
            }
        }
    }
    let mp = dir.join("metrics.bin");
    let metrics = if out.len() == apertures && mp.exists() {
        let bytes = std::fs::read(&mp).map_err(|source| ServiceError::Io {
            path: mp.clone(),
            source,
        })?;
        envelope::decode::<MissionMetrics>(&bytes, &limits)
            .map(|e| e.message)
            .map_err(
                |e| tracing::warn!(file = %mp.display(), error = %e, "stored metrics unreadable"),
            )
            .ok()
    } else {
        None
    };
    Ok((out, metrics))
}
