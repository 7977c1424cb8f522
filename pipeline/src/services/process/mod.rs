//! `cellsar-radar-sim process-service`: pulls the apertures of each mission that a client
//! asks results of (a launcher collecting them) from the echo, processes them one at a time (cancellation, compression, backprojection, CFAR,
//! scoring) and publishes detections, images and, at the end, the mission's metrics; the same
//! numbers as `cellsar-radar-sim process` on the recording of the same mission.
//!
//! - `context.rs`: what the processor derives from a plan and a scene, and an aperture's
//!   outcome;
//! - `receive.rs`: the frame receiver thread (iceoryx2 or Zenoh);
//! - `work.rs`: the worker and requester threads;
//! - `assembly.rs`, `proc.rs`: the service loop and its state (missions, assemblies);
//! - `publish.rs`: what it publishes (detections, images, metrics, status);
//! - `store.rs`: the state directory;
//! - `wanted.rs`: which missions it takes on (those a client asks results of).

mod assembly;
mod context;
mod frame_key;
mod proc;
mod publish;
mod receive;
mod store;
mod wanted;
mod work;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;

use bridge::flags::Seconds;
use bridge::net::FrameSubscribeOptions;
use bridge::{IoxArgs, MissionId, ZenohArgs, ZenohNode};
use radar_sim::config::SceneFile;
use radar_sim::limits::IqLimits;
use serde::{Deserialize, Serialize};

use crate::args::IqLimitArgs;
use crate::protocol::keys as pkeys;
use crate::protocol::Role;
use crate::services::admission::DEFAULT_MAX_MISSIONS;
use crate::services::plan::{PlanCache, StatusBoard};
use crate::services::radar::{ServiceError, ServiceResult, DEFAULT_MAX_FRAME_BYTES};
use crate::services::threads::{report_exit, thread_exits};
use proc::{Inbox, Proc};
use publish::Publishers;
use receive::{
    receive_iox, receive_zenoh, FrameLoss, FrameOutlet, IoxControl, RawFrame, ReceiverCmd,
};
use work::{requester, worker, Job, JobResult, RequestDone, RequestJob};

pub use context::{
    detections_message, fold_metrics, object_as_recorded, pulse_as_recorded, ApertureOutcome,
    MissionContext, ProcContext, StoredOutcome,
};

/// The frame receiver thread, in the processor's errors.
const FRAME_RECEIVER: &str = "frame receiver";
/// The requester thread, in the processor's errors.
const REQUESTER: &str = "aperture requester";

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
    /// Ask again for an aperture when no frame of its mission arrived for this long, s (after
    /// 1 s, if shorter, once frames were lost in transport since the request).
    #[arg(long, default_value = "10", value_parser = bridge::flags::parse_seconds)]
    pub resend_after_s: Seconds,
    /// Store finished apertures here; after a restart, resume with the next one.
    #[arg(long, value_name = "DIR")]
    pub state_dir: Option<PathBuf>,
    /// Seconds between status publications.
    #[arg(long, default_value = "1", value_parser = bridge::flags::parse_seconds)]
    pub status_interval_s: Seconds,
    /// Missions held at once: at the cap, a new plan replaces the oldest finished (or given
    /// up) mission, else the oldest one without progress (no plan or frame) for 60 s and no
    /// work queued, and is refused while every held mission is still in progress.
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
    /// Frames that fit the layout but whose tag is missing or does not verify under the
    /// mission's frame key (not the echo's), dropped.
    #[serde(default)]
    pub forged: u64,
    /// Frames dropped because the receive queue was full.
    pub dropped: u64,
    /// Frames the transport lost: sequence gaps (iceoryx2) or a full subscriber queue (Zenoh).
    /// Never a frame that arrived: those that fail to decode are `frames_malformed`.
    pub transport_lost: u64,
    /// Frames that arrived but failed to decode or validate (a header inconsistent with the
    /// payload, a bad checksum, a payload that is not complex f32), dropped.
    #[serde(default)]
    pub frames_malformed: u64,
    /// Requests sent to the echo (first requests and re-requests).
    pub requests: u64,
    /// Re-requests.
    pub resends: u64,
    /// Requests that failed (no echo, refused).
    pub request_errors: u64,
    /// Results published again on request or after a restart.
    pub republished: u64,
    /// Plans refused because `--max-missions` missions were in progress.
    pub plans_refused: u64,
    /// Plans skipped because their mission id is not the one their content gives.
    pub plans_inconsistent: u64,
    /// Missions let go to make room for new ones (`--max-missions`).
    pub evicted: u64,
    /// Outcomes or metrics that could not be saved to the state directory (still published).
    pub state_errors: u64,
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
    let Some(node) = ZenohNode::open_until(config, Role::Processor.as_str(), &args.instance, stop)?
    else {
        return Ok(ProcessReport::default());
    };
    let r = serve(args, limits, &scene, &node, &env, stop);
    if let Err(e) = node.close() {
        tracing::warn!(error = %e, "closing the Zenoh session");
    }
    r
}

/// Starts the worker, the frame receiver and the requester and runs the service loop until
/// `stop` is set; then stops the receiver and the requester (the worker is left to finish
/// its job: it holds no borrowed state).
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
    let (exit_tx, threads) = thread_exits();
    let inbox = Inbox {
        frames: frame_rx,
        watching: watch_rx,
        requests_done: done_rx,
        results: res_rx,
        threads,
    };
    let loss = FrameLoss::default();

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
        let out = FrameOutlet {
            tx: frame_tx,
            stop: &recv_stop,
            loss: &loss,
        };
        let control = IoxControl {
            cmds: cmd_rx,
            watching: watch_tx,
        };
        // each reports its end to the service loop, which then fails naming it
        let receiver_exit = exit_tx.clone();
        let receiver = std::thread::Builder::new()
            .name("frames".into())
            .spawn_scoped(scope, move || {
                report_exit(FRAME_RECEIVER, &receiver_exit, || match zenoh_frames {
                    Some(sub) => receive_zenoh(sub, out),
                    None => receive_iox(env, args, control, out),
                })
            })
            .map_err(|e| ServiceError::Internal(format!("starting the frame receiver: {e}")))?;
        let requester = std::thread::Builder::new()
            .name("requests".into())
            .spawn_scoped(scope, move || {
                report_exit(REQUESTER, &exit_tx, || {
                    requester(node, &args.instance, req_rx, done_tx);
                    Ok::<(), ServiceError>(())
                })
            })
            .map_err(|e| ServiceError::Internal(format!("starting the requester: {e}")))?;
        let mut p = Proc {
            args,
            limits,
            scene,
            node,
            cache: PlanCache::new(node, None)?,
            board: StatusBoard::new(Role::Processor, &args.instance),
            runs: Vec::new(),
            publishers: Publishers::default(),
            report: ProcessReport::default(),
            cmd_tx,
            req_tx,
            job_tx,
            worker_busy: false,
            malformed: 0,
            echo_unanswered: None,
            waits: Default::default(),
            wanted: Default::default(),
            frames_over_zenoh: args.frames == FrameSource::Zenoh,
        };
        let result = p.run(stop, &inbox, &loss);
        recv_stop.store(true, Ordering::Relaxed);
        drop(p);
        // their errors and panics were reported (and caught) in the threads
        let _ = receiver.join();
        let _ = requester.join();
        result
    })
}
