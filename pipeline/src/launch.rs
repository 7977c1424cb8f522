//! `cellsar run`: the whole pipeline as supervised child processes.
//!
//! 1. Checks the inputs before anything starts: every option a child would refuse, the Zenoh
//!    and iceoryx2 flags, the mission and the scene (bad input: [`FailureKind::BadInput`],
//!    exit code 2), and the mission's necessary conditions of feasibility
//!    ([`FailureKind::Infeasible`], exit code 3). (The seconds options were checked when
//!    parsed, into [`Seconds`].)
//! 2. Chooses the Zenoh network: by default an isolated mesh on loopback (the launcher listens on
//!    a free port, every child connects to it; no multicast, no router); with `--router` a
//!    router child and every process its client; with Zenoh flags, those flags for everyone.
//! 3. Starts the planner, echo and processor (and the bridge for `--transport zenoh` or
//!    `--bridge`), watches their liveliness tokens, restarts a child that dies (at most
//!    `--max-restarts` times each).
//! 4. Asks the planner for the plan (waiting for the planner to appear and for its answer
//!    together at most `--plan-timeout-s`), writes `plan/`, collects every aperture's detections and
//!    image and the metrics (asking the processor again for what it missed), and writes the
//!    same files as `cellsar-radar-sim closed-loop`, plus `pipeline.json` and `report.md`.
//!    A planner that refuses the mission answers with a typed refusal ([`Refusal`]), whose
//!    kind picks the exit code ([`PlanRefused::failure_kind`]: infeasible 3, bad request 2,
//!    internal 1); an error reply that is no refusal is a failure at run time naming the key.
//! 5. Stops every child (SIGTERM, then SIGKILL after a grace period) at the end, on SIGINT or
//!    SIGTERM, or when a child keeps failing: one clean-up path for every ending, and an
//!    `interrupted` event for every interrupted run (also while the Zenoh session opens).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use bridge::envelope::DecodeLimits;
use bridge::flags::{self, Seconds};
use bridge::net::{QueryOptions, SubscribeOptions, WireFormat};
use bridge::zconfig::Mode;
use bridge::{
    keys, FrameServiceSpec, IoxArgs, Message, NetError, Refusal, RefusalKind, ZenohArgs, ZenohNode,
};
use indicatif::{ProgressBar, ProgressStyle};
use radar_sim::config::SceneFile;

use crate::protocol::{
    self, ApertureDetections, ApertureImage, FrameLayout, MissionMetrics, Plan, PlanRequest,
    PlanRequestOptions, ResultAck, ResultRequest, ServiceStatus, MAX_PLAN_BYTES,
};
use crate::services::process::MissionContext;
use serde_json::{json, Value};

use crate::collect::{Added, Collector};
use crate::events::Events;
use crate::exit::{Failure, FailureKind};
use crate::supervise::{stop_all, ChildSpec, Supervised};

/// How IQ frames reach the processor.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transport {
    /// iceoryx2 shared memory (echo and processor on this host).
    Iox,
    /// Zenoh: the bridge forwards the echo's iceoryx2 frames, the processor subscribes on Zenoh
    /// (what a processor on another host does).
    Zenoh,
}

/// Flags of `cellsar run`.
///
/// Exit codes: 0 done; 1 failure at run time; 2 bad input (an option, the mission or the scene
/// file; the message names it; nothing was started); 3 the mission cannot be flown; 4 done
/// with `--strict` but a landmark in view was not detected; 130 interrupted (SIGINT/SIGTERM;
/// every child stopped).
#[derive(clap::Args, Debug, Clone)]
pub struct RunArgs {
    /// Mission file (TOML or JSON).
    pub mission: PathBuf,
    /// Scene file (TOML).
    #[arg(long)]
    pub scene: PathBuf,
    /// Output directory (plan/, images/, detections.csv, metrics.json, report.json, report.md,
    /// pipeline.json, logs/).
    #[arg(long)]
    pub out: PathBuf,
    /// Keep only the landmark windows that end within this horizon, s.
    #[arg(long, value_parser = flags::parse_seconds)]
    pub horizon_s: Option<Seconds>,
    /// The plan's resolution requirement: `paper` (the paper's δ_r, δ_a ≤ d_min) or `general`
    /// (the worst width of the true bistatic cell ≤ d_min in every landmark slot; top-level
    /// README, "Resolution"). Sent with the plan request; `cellsar-radar-sim closed-loop
    /// --resolution` gives the same results.
    #[arg(long, default_value = "paper", value_parser = planner::evaluate::ResolutionMode::parse)]
    pub resolution: planner::evaluate::ResolutionMode,
    /// How IQ frames reach the processor.
    #[arg(long, value_enum, default_value_t = Transport::Iox)]
    pub transport: Transport,
    /// Start the bridge (iceoryx2 -> Zenoh) even with `--transport iox`.
    #[arg(long)]
    pub bridge: bool,
    /// Start a Zenoh router child; every process is its client.
    #[arg(long)]
    pub router: bool,
    /// Do not start this role (planner, echo, processor, bridge): it runs elsewhere (another
    /// host, a container) and is found on the Zenoh network. Repeatable.
    #[arg(long = "external", value_name = "ROLE", value_parser = ["planner", "echo", "processor", "bridge"])]
    pub external: Vec<String>,
    /// Restarts allowed per child before the run is given up.
    #[arg(long, default_value_t = 5)]
    pub max_restarts: u32,
    /// Largest IQ frame payload, bytes (sizes the iceoryx2 service and the frames; at least
    /// one pulse of the scene).
    #[arg(long, default_value_t = bridge::frame::SERVICE_MAX_FRAME_BYTES)]
    pub max_frame_bytes: usize,
    /// Apertures the processor asks for at once (at least 1).
    #[arg(long, default_value_t = 2)]
    pub window: usize,
    /// The processor asks again for an aperture after this many seconds without frames.
    #[arg(long, default_value = "10", value_parser = flags::parse_seconds)]
    pub resend_after_s: Seconds,
    /// Exit with code 4 when a landmark in view was not detected (default: report it in
    /// `report.md`/`report.json` and on stdout, exit 0 once the run completed).
    #[arg(long)]
    pub strict: bool,
    /// Give up after this many seconds (default: no limit).
    #[arg(long, value_parser = flags::parse_seconds)]
    pub timeout_s: Option<Seconds>,
    /// Longest wait for the plan, s: waiting for a planner to appear (a local one starting,
    /// or an `--external planner`) and for its answer together; then the run fails (exit 1).
    #[arg(long, default_value = "900", value_parser = flags::parse_seconds)]
    pub plan_timeout_s: Seconds,
    /// Print events (children started/exited, liveliness, apertures) as JSON lines on stdout.
    #[arg(long)]
    pub events_json: bool,
    /// Keep the services' state directory (`.state/`) after a successful run.
    #[arg(long)]
    pub keep_state: bool,
    /// `RUST_LOG` of the children (their logs go to `<out>/logs/`); a valid filter.
    #[arg(long, default_value = "info")]
    pub child_log: String,
    /// Zenoh flags (used by the launcher and passed to every child).
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// iceoryx2 flags (default: an isolated environment under `<out>/.state/iox`).
    #[command(flatten)]
    pub iox: IoxArgs,
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Complete; every landmark in view detected.
    Complete,
    /// Complete, but a landmark in view was not detected (as `closed-loop` reports) and
    /// `--strict` was given.
    MissedLandmark,
    /// Stopped by SIGINT/SIGTERM.
    Interrupted,
}

struct Net {
    launcher: ZenohArgs,
    child: ZenohArgs,
}

fn free_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").context("finding a free port")?;
    Ok(l.local_addr().context("finding a free port")?.port())
}

fn user_gave_zenoh(z: &ZenohArgs) -> bool {
    z.config.is_some() || z.mode.is_some() || !z.connect.is_empty() || !z.listen.is_empty()
}

/// The Zenoh flags of the children when the user gave the launcher's: the same flags, except
/// that the launcher's own listen endpoints become endpoints every child connects to (on
/// loopback when the launcher listens on every address), and a child that connects to the
/// launcher listens on a free loopback port of its own so that the children find each other
/// (gossip) without multicast scouting. A client launcher cannot listen, and a listen port 0
/// cannot be told to the children: both are refused naming `--listen`.
pub fn children_zenoh(user: &ZenohArgs) -> std::result::Result<ZenohArgs, String> {
    let mut child = user.clone();
    child.listen.clear();
    if user.listen.is_empty() {
        return Ok(child);
    }
    if user.mode == Some(Mode::Client) {
        return Err(format!(
            "--listen {}: a client (-m client) cannot listen; give the router with -e instead",
            user.listen[0]
        ));
    }
    for ep in &user.listen {
        child.connect.push(reachable_endpoint(ep)?);
    }
    // children are peers of the launcher (a router launcher routes for them)
    child.mode = Some(Mode::Peer);
    child.listen.push("tcp/127.0.0.1:0".to_string());
    Ok(child)
}

/// The endpoint a child on this host connects to for a listen endpoint: an unspecified address
/// (`0.0.0.0`, `[::]`) becomes loopback; port 0 is refused (the port is not known in advance).
fn reachable_endpoint(listen: &str) -> std::result::Result<String, String> {
    let (proto, rest) = listen.split_once('/').ok_or_else(|| {
        format!("--listen {listen}: expected PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447")
    })?;
    if proto == "unixsock-stream" {
        return Ok(listen.to_string());
    }
    let (addr, meta) = match rest.split_once(['?', '#']) {
        Some((a, _)) => (a, &rest[a.len()..]),
        None => (rest, ""),
    };
    let (host, port) = addr
        .rsplit_once(':')
        .ok_or_else(|| format!("--listen {listen}: no port"))?;
    if port == "0" {
        return Err(format!(
            "--listen {listen}: port 0 cannot be passed on to the children; give a port"
        ));
    }
    let host = match host {
        "0.0.0.0" => "127.0.0.1",
        "[::]" => "[::1]",
        h => h,
    };
    Ok(format!("{proto}/{host}:{port}{meta}"))
}

fn absolute(p: &Path) -> Result<PathBuf> {
    if p.is_absolute() {
        Ok(p.to_path_buf())
    } else {
        Ok(std::env::current_dir()
            .context("current directory")?
            .join(p))
    }
}

/// The planner refused the plan request with a typed refusal ([`Refusal`], on the wire as
/// `bridge.refusal`): its kind picks the exit code ([`PlanRefused::failure_kind`]).
#[derive(Debug, thiserror::Error)]
#[error("the planner on {key:?} refused the mission ({}): {}", refusal.kind, refusal.message)]
pub struct PlanRefused {
    /// The key the plan request went to.
    pub key: String,
    /// The planner's refusal: its kind and message.
    pub refusal: Refusal,
}

impl PlanRefused {
    /// What kind of failure the refusal is: a mission that cannot be flown exits 3, a request
    /// the planner found invalid 2, a planner that failed 1, a planner that stayed busy (its
    /// request queue full each time it was asked) 1.
    pub fn failure_kind(&self) -> FailureKind {
        match self.refusal.kind {
            RefusalKind::Infeasible => FailureKind::Infeasible,
            RefusalKind::BadRequest => FailureKind::BadInput,
            RefusalKind::Internal | RefusalKind::Busy => FailureKind::Runtime,
        }
    }
}

/// Checks every input of `cellsar run` before anything starts, as the children would: the
/// numbers, `--window`, `--child-log`, `--max-frame-bytes` against the scene's pulses, the
/// Zenoh and iceoryx2 flags, the mission (with `--horizon-s`) and the scene and the IQ they
/// need ([`FailureKind::BadInput`]), then the mission's necessary conditions of feasibility
/// ([`FailureKind::Infeasible`]). Returns the mission to plan.
pub fn check_inputs(args: &RunArgs) -> Result<planner::Mission, Failure> {
    // the seconds flags were checked when parsed (bridge::flags::Seconds)
    if args.window == 0 {
        return Err(Failure::bad_input(anyhow!(
            "--window 0: must be at least 1 (apertures the processor asks for at once)"
        )));
    }
    tracing_subscriber::EnvFilter::try_new(&args.child_log)
        .map_err(|e| Failure::bad_input(anyhow!("--child-log {:?}: {e}", args.child_log)))?;
    args.zenoh.to_config().map_err(Failure::bad_input)?;
    if !args.router && user_gave_zenoh(&args.zenoh) {
        children_zenoh(&args.zenoh)
            .map_err(|e| Failure::bad_input(anyhow!(e)))?
            .to_config()
            .map_err(Failure::bad_input)?;
    }
    // the iceoryx2 configuration file and prefix as every child reads them (the root is
    // created by the children)
    IoxArgs {
        root: None,
        ..args.iox.clone()
    }
    .env()
    .map_err(Failure::bad_input)?;
    if let Some(r) = args.iox.root.as_ref().filter(|r| r.exists() && !r.is_dir()) {
        return Err(Failure::bad_input(anyhow!(
            "--iox-root {}: not a directory",
            r.display()
        )));
    }
    let mut mission = planner::Mission::from_path(&args.mission)
        .with_context(|| format!("mission {}", args.mission.display()))
        .map_err(Failure::bad_input)?;
    if let Some(h) = args.horizon_s {
        mission = radar_sim::run::shorten(&mission, h.as_secs_f64())
            .with_context(|| format!("--horizon-s {h}"))
            .map_err(Failure::bad_input)?;
    }
    let scene = SceneFile::from_path(&args.scene).map_err(Failure::bad_input)?;
    let context = || {
        format!(
            "scene {} with mission {}",
            args.scene.display(),
            args.mission.display()
        )
    };
    let setup = radar_sim::pipeline::RadarSetup::new(mission.params(), &scene)
        .with_context(context)
        .map_err(Failure::bad_input)?;
    radar_sim::limits::check_mission(&setup, &mission, &radar_sim::limits::IqLimits::default())
        .with_context(context)
        .map_err(Failure::bad_input)?;
    // the frame service every process opens, and the frames of one pulse at least
    let mfb = args.max_frame_bytes;
    FrameServiceSpec::new(
        &protocol::keys::echo(bridge::MissionId(0)).unwrap_or_default(),
        mfb,
    )
    .validate()
    .map_err(|e| Failure::bad_input(anyhow!("--max-frame-bytes {mfb}: {e}")))?;
    FrameLayout::new(&[], setup.scene.radar.samples_per_pulse(), mfb)
        .with_context(|| format!("scene {}", args.scene.display()))
        .map_err(Failure::bad_input)?;
    planner::init::precheck(&mission)
        .with_context(|| format!("mission {}", args.mission.display()))
        .map_err(Failure::infeasible)?;
    Ok(mission)
}

/// The error of a plan query the planner answered with an error reply: a typed refusal is a
/// [`PlanRefused`] (its kind picks the exit code, [`classify`]); an error reply that is no
/// refusal (an older or foreign planner) a failure at run time, naming the key.
fn plan_refusal(e: NetError) -> anyhow::Error {
    match e {
        NetError::Refused { key, refusal } => PlanRefused { key, refusal }.into(),
        e => anyhow::Error::new(e).context(format!(
            "the planner answered with an error that is no typed refusal ({} v{}; an older or \
             foreign planner?)",
            Refusal::NAME,
            Refusal::SCHEMA_VERSION
        )),
    }
}

fn classify(e: anyhow::Error) -> Failure {
    let kind = e
        .downcast_ref::<PlanRefused>()
        .map_or(FailureKind::Runtime, PlanRefused::failure_kind);
    Failure { kind, error: e }
}

/// Runs the pipeline; returns how it ended, or the failure (its kind picks the exit code).
pub fn run(args: &RunArgs, stop: Arc<AtomicBool>) -> Result<Outcome, Failure> {
    let wall = Instant::now();
    // 1. inputs, checked before anything starts
    let mission = check_inputs(args)?;
    launch(args, &mission, stop, wall).map_err(classify)
}

fn launch(
    args: &RunArgs,
    mission: &planner::Mission,
    stop: Arc<AtomicBool>,
    wall: Instant,
) -> Result<Outcome> {
    let out = absolute(&args.out)?;
    let state = out.join(".state");
    let logs = out.join("logs");
    for d in [&out, &state, &logs] {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    let scene_path = absolute(&args.scene)?;
    let events = Arc::new(Events::new(args.events_json));
    let exe = std::env::current_exe().context("locating the cellsar executable")?;

    // 2. iceoryx2 environment and Zenoh network
    let iox = if args.iox.root.is_none() && args.iox.prefix.is_none() && args.iox.config.is_none() {
        IoxArgs {
            root: Some(state.join("iox")),
            prefix: Some(format!("cs{}_", std::process::id())),
            config: None,
        }
    } else {
        args.iox.clone()
    };
    let mut children: Vec<Supervised> = Vec::new();
    let spec = |role: &str, a: Vec<String>| ChildSpec {
        role: role.to_string(),
        exe: exe.clone(),
        args: a,
        log: logs.join(format!("{role}.log")),
        rust_log: Some(args.child_log.clone()),
    };
    let net = if args.router {
        let port = free_port()?;
        let ep = format!("tcp/127.0.0.1:{port}");
        let router = ZenohArgs::isolated(std::slice::from_ref(&ep), &[]);
        let mut ra = vec!["router".to_string(), "--instance".into(), "router".into()];
        ra.extend(router.to_cli_args());
        children.push(Supervised::start(spec("router", ra), &events)?);
        let client = ZenohArgs {
            config: None,
            mode: Some(Mode::Client),
            connect: vec![ep],
            listen: Vec::new(),
            no_multicast_scouting: true,
            max_message_bytes: None,
        };
        Net {
            launcher: client.clone(),
            child: client,
        }
    } else if user_gave_zenoh(&args.zenoh) {
        Net {
            launcher: args.zenoh.clone(),
            child: children_zenoh(&args.zenoh).map_err(|e| anyhow!(e))?,
        }
    } else {
        let hub = format!("tcp/127.0.0.1:{}", free_port()?);
        Net {
            launcher: ZenohArgs::isolated(std::slice::from_ref(&hub), &[]),
            child: ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[hub]),
        }
    };
    events.emit(
        "network",
        &[
            ("launcher", json!(net.launcher.to_cli_args())),
            ("children", json!(net.child.to_cli_args())),
            ("iox", json!(iox.to_cli_args())),
        ],
    );
    // 3.-5. the run on the launcher's Zenoh session; then one clean-up, however it ended
    // (SIGINT/SIGTERM while the session opens included)
    let (node, result) = match open_with_retry(&net.launcher, &stop) {
        Ok(Some(node)) => {
            let result = run_on(
                args,
                mission,
                &scene_path,
                &out,
                &state,
                &node,
                &net,
                &iox,
                &events,
                &stop,
                &mut children,
                &spec,
                wall,
            );
            (Some(node), result)
        }
        Ok(None) => (None, Ok(Outcome::Interrupted)),
        Err(_) if stop.load(Ordering::Relaxed) => (None, Ok(Outcome::Interrupted)),
        Err(e) => (None, Err(e)),
    };
    if matches!(result, Ok(Outcome::Interrupted)) {
        events.emit("interrupted", &[]);
    }
    stop_all(&mut children, Duration::from_secs(10), &events);
    if let Some(node) = node {
        if let Err(e) = node.close() {
            tracing::debug!(error = %e, "closing the launcher's session");
        }
    }
    remove_shm(&iox);
    if let Ok(o) = &result {
        if *o != Outcome::Interrupted && !args.keep_state {
            let _ = std::fs::remove_dir_all(&state);
        }
    }
    result
}

/// Opens the launcher's session: an open that fails (a listen endpoint still taken, say) is
/// tried again for 15 s; one that waits (a client whose router is not up yet) waits for as
/// long as it takes. `None` once `stop` is set (SIGINT/SIGTERM), also in the middle of an
/// open ([`ZenohNode::open_until`]).
fn open_with_retry(z: &ZenohArgs, stop: &AtomicBool) -> Result<Option<ZenohNode>> {
    let config = z.to_config()?;
    let instance = format!("launcher-{}", std::process::id());
    let deadline = Instant::now() + Duration::from_secs(15);
    loop {
        match ZenohNode::open_until(config.clone(), "launcher", &instance, stop) {
            Ok(n) => return Ok(n),
            Err(_) if stop.load(Ordering::Relaxed) => return Ok(None),
            Err(e) if Instant::now() < deadline => {
                tracing::debug!(error = %e, "opening the Zenoh session; retrying");
                std::thread::sleep(Duration::from_millis(200));
            }
            Err(e) => return Err(e).context("opening the launcher's Zenoh session"),
        }
    }
}

fn remove_shm(iox: &IoxArgs) {
    let Some(prefix) = &iox.prefix else { return };
    if let Ok(rd) = std::fs::read_dir("/dev/shm") {
        for e in rd.flatten() {
            if e.file_name().to_string_lossy().starts_with(prefix.as_str()) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn run_on(
    args: &RunArgs,
    mission: &planner::Mission,
    scene_path: &Path,
    out: &Path,
    state: &Path,
    node: &ZenohNode,
    net: &Net,
    iox: &IoxArgs,
    events: &Arc<Events>,
    stop: &AtomicBool,
    children: &mut Vec<Supervised>,
    spec: &dyn Fn(&str, Vec<String>) -> ChildSpec,
    wall: Instant,
) -> Result<Outcome> {
    let alive = node.watch_liveliness(keys::ALIVE_ALL)?;
    let limits = DecodeLimits::default();
    let detections = node.subscriber::<ApertureDetections>(
        protocol::keys::ALL_DETECTIONS,
        SubscribeOptions {
            capacity: 1024,
            ..SubscribeOptions::default()
        },
    )?;
    let images = node.subscriber::<ApertureImage>(
        protocol::keys::ALL_IMAGES,
        SubscribeOptions {
            capacity: 256,
            limits,
            ..SubscribeOptions::default()
        },
    )?;
    let metrics = node
        .subscriber::<MissionMetrics>(protocol::keys::ALL_METRICS, SubscribeOptions::default())?;
    let statuses = node.subscriber::<ServiceStatus>(
        protocol::keys::ALL_STATUS,
        SubscribeOptions {
            capacity: 1024,
            ..SubscribeOptions::default()
        },
    )?;

    // 3. children
    let zc = net.child.to_cli_args();
    let frames = args.max_frame_bytes.to_string();
    let mut pa = vec![
        "planner".to_string(),
        "--state-dir".into(),
        state.join("planner").display().to_string(),
    ];
    pa.extend(zc.clone());
    let local = |role: &str| !args.external.iter().any(|r| r == role);
    if local("planner") {
        children.push(Supervised::start(spec("planner", pa), events)?);
    }
    let mut ea = vec![
        "echo".to_string(),
        "--scene".into(),
        scene_path.display().to_string(),
        "--max-frame-bytes".into(),
        frames.clone(),
    ];
    ea.extend(zc.clone());
    ea.extend(iox.to_cli_args());
    if local("echo") {
        children.push(Supervised::start(spec("echo", ea), events)?);
    }
    let mut xa = vec![
        "process".to_string(),
        "--scene".into(),
        scene_path.display().to_string(),
        "--max-frame-bytes".into(),
        frames.clone(),
        "--frames".into(),
        match args.transport {
            Transport::Iox => "iox".into(),
            Transport::Zenoh => "zenoh".into(),
        },
        "--window".into(),
        args.window.to_string(),
        "--resend-after-s".into(),
        args.resend_after_s.to_string(),
        "--state-dir".into(),
        state.join("processor").display().to_string(),
    ];
    xa.extend(zc.clone());
    xa.extend(iox.to_cli_args());
    if local("processor") {
        children.push(Supervised::start(spec("processor", xa), events)?);
    }

    // a deadline past what an Instant can hold means "no limit" rather than a panic
    let deadline = args.timeout_s.and_then(|t| wall.checked_add(t.duration()));
    let backoff = Duration::from_millis(500);
    let supervise = |children: &mut Vec<Supervised>| -> Result<()> {
        for c in children.iter_mut() {
            c.poll(events, args.max_restarts, backoff)?;
        }
        Ok(())
    };
    let alive_log = |events: &Events| {
        while let Some(e) = alive.next_event(Duration::ZERO) {
            if let Some((role, instance)) = keys::parse_alive(&e.key) {
                if !e.alive {
                    tracing::warn!(role, instance, "liveliness lost");
                }
                events.emit(
                    "alive",
                    &[
                        ("role", role.into()),
                        ("instance", instance.into()),
                        ("alive", e.alive.into()),
                    ],
                );
            }
        }
    };
    let check_time = |what: &str| -> Result<()> {
        if let Some(d) = deadline {
            if Instant::now() >= d {
                bail!(
                    "timed out after {:.0} s while {what}",
                    wall.elapsed().as_secs_f64()
                );
            }
        }
        Ok(())
    };

    // 4a. the plan: waiting for a planner and for its answer, together at most
    // --plan-timeout-s; SIGINT/SIGTERM at any moment ends the run as interrupted
    let spinner = ProgressBar::new_spinner();
    if let Ok(s) = ProgressStyle::with_template("{spinner} {prefix:>9} {msg} [{elapsed}]") {
        spinner.set_style(s);
    }
    spinner.set_prefix("planning");
    spinner.enable_steady_tick(Duration::from_millis(200));
    let request = PlanRequest {
        mission: mission.to_file_struct(),
        options: PlanRequestOptions {
            resolution: Some(args.resolution),
            ..PlanRequestOptions::default()
        },
    };
    let plan_started = Instant::now();
    let plan_timeout = args.plan_timeout_s.duration();
    let plan_deadline = plan_started.checked_add(plan_timeout);
    let plan_left = || {
        plan_deadline.map_or(plan_timeout, |d| {
            d.saturating_duration_since(Instant::now())
        })
    };
    let planner_alive = || {
        alive
            .alive()
            .iter()
            .any(|k| keys::parse_alive(k).is_some_and(|(role, _)| role == "planner"))
    };
    let no_plan = |what: &str| {
        anyhow!(
            "no plan within --plan-timeout-s {} s: {what}",
            args.plan_timeout_s
        )
    };
    let mut get_plan = || -> Result<Option<Plan>> {
        let mut attempt = 0u32;
        loop {
            attempt += 1;
            // wait for the planner's token
            while !planner_alive() {
                if stop.load(Ordering::Relaxed) {
                    return Ok(None);
                }
                check_time("waiting for the planner")?;
                if plan_left().is_zero() {
                    return Err(no_plan(if local("planner") {
                        "the planner did not announce itself (see logs/planner.log)"
                    } else {
                        "no planner announced itself (cellsar/alive/planner/*): start \
                         `cellsar-planner serve` with the same Zenoh flags"
                    }));
                }
                supervise(children)?;
                alive_log(events);
                std::thread::sleep(Duration::from_millis(20));
            }
            let mut query = node.start_query::<PlanRequest, Plan>(
                protocol::keys::PLAN,
                &request,
                &QueryOptions {
                    timeout: plan_left(),
                    format: WireFormat::Bincode,
                    limits: DecodeLimits {
                        max_body_bytes: MAX_PLAN_BYTES,
                        verify_crc: true,
                    },
                    ..QueryOptions::default()
                },
            )?;
            let answer = loop {
                if stop.load(Ordering::Relaxed) {
                    return Ok(None);
                }
                check_time("planning")?;
                supervise(children)?;
                alive_log(events);
                while let Some(s) = statuses.try_recv() {
                    if s.message.role == "planner" {
                        spinner.set_message(s.message.message.clone());
                    }
                }
                if let Some(a) = query.poll(Duration::from_millis(20)) {
                    break a;
                }
            };
            match answer {
                Ok(r) => return Ok(Some(r.message)),
                // a busy planner (its request queue full) is asked again, as one that did not
                // answer
                Err(NetError::Refused { refusal, .. })
                    if refusal.kind == RefusalKind::Busy
                        && !plan_left().is_zero()
                        && attempt < 1 + args.max_restarts =>
                {
                    tracing::warn!(message = %refusal.message, attempt, "the planner is busy; asking again");
                    events.emit(
                        "plan_retry",
                        &[
                            ("attempt", attempt.into()),
                            ("error", refusal.message.clone().into()),
                        ],
                    );
                    std::thread::sleep(Duration::from_millis(500));
                }
                Err(e @ (NetError::Refused { .. } | NetError::Remote { .. })) => {
                    return Err(plan_refusal(e))
                }
                Err(e) if plan_left().is_zero() => {
                    return Err(anyhow::Error::new(e).context(no_plan("the planner did not answer")))
                }
                Err(e) if attempt < 1 + args.max_restarts => {
                    tracing::warn!(error = %e, attempt, "no plan; asking again");
                    events.emit(
                        "plan_retry",
                        &[("attempt", attempt.into()), ("error", e.to_string().into())],
                    );
                    std::thread::sleep(Duration::from_millis(200));
                }
                Err(e) => return Err(e).context("asking the planner for the plan"),
            }
        }
    };
    let plan = get_plan();
    spinner.finish_and_clear();
    let Some(plan) = plan? else {
        return Ok(Outcome::Interrupted);
    };
    let plan_s = plan_started.elapsed().as_secs_f64();
    let id = plan.mission_id;
    let resolved = plan.mission()?;
    let plan_dir = out.join("plan");
    crate::report::write_plan_dir(&plan_dir, &resolved, &plan.result)
        .with_context(|| format!("writing {}", plan_dir.display()))?;
    let scene = SceneFile::from_path(scene_path)?;
    let ctx = MissionContext::new(&Arc::new(plan.clone()), &scene, args.max_frame_bytes)?;
    let n = ctx.apertures.len();
    println_human(args, &format!(
        "planned {} slots in {plan_s:.1} s: energy {:.0} J, feasible {}; mission {id}, {n} apertures, {} frames of {} pulses",
        resolved.slots(),
        plan.summary.energy_j,
        plan.summary.feasible,
        ctx.layout.total_frames(),
        ctx.layout.frame_pulses()
    ));
    events.emit(
        "planned",
        &[
            ("mission_id", id.to_string().into()),
            ("apertures", n.into()),
            ("frames", ctx.layout.total_frames().into()),
            ("frame_pulses", ctx.layout.frame_pulses().into()),
            ("plan_s", plan_s.into()),
        ],
    );
    if (args.transport == Transport::Zenoh || args.bridge) && local("bridge") {
        let mut ba = vec![
            "bridge".to_string(),
            "--service".into(),
            protocol::keys::echo_route_out(id)?,
            "--max-frame-bytes".into(),
            frames,
        ];
        ba.extend(zc);
        ba.extend(iox.to_cli_args());
        children.push(Supervised::start(spec("bridge", ba), events)?);
    }

    // 4b. collect
    let mut col = Collector::new(id, n, out)?;
    let bar = ProgressBar::new(n as u64);
    if let Ok(s) = ProgressStyle::with_template(
        "{prefix:>9} [{bar:40}] {pos}/{len} apertures ({elapsed}, eta {eta}) {msg}",
    ) {
        bar.set_style(s.progress_chars("=> "));
    }
    bar.set_prefix("imaging");
    let started = Instant::now();
    let mut last_status: BTreeMap<String, ServiceStatus> = BTreeMap::new();
    let mut last_resend = Instant::now();
    let mut resend_requests = 0u64;
    let mut first_seen_done: BTreeMap<u32, Instant> = BTreeMap::new();
    let mut aperture_times: Vec<f64> = Vec::new();
    let interrupted = loop {
        if stop.load(Ordering::Relaxed) {
            break true;
        }
        check_time("collecting results")?;
        supervise(children)?;
        alive_log(events);
        let mut progressed = false;
        while let Some(d) = detections.try_recv() {
            let k = d.message.aperture;
            if col.add_detections(d.message) == Added::New {
                progressed = true;
                if let Some(dm) = col.detections(k) {
                    bar.set_message(format!(
                        "aperture {k}: {} detections, landmark {}",
                        dm.detections.len(),
                        match dm.landmark_detected {
                            Some(true) => "detected",
                            Some(false) => "missed",
                            None => "-",
                        }
                    ));
                    events.emit(
                        "detections",
                        &[
                            ("aperture", k.into()),
                            ("count", dm.detections.len().into()),
                        ],
                    );
                }
            }
        }
        while let Some(img) = images.try_recv() {
            if col.add_image(&img.message)? == Added::New {
                progressed = true;
            }
        }
        while let Some(m) = metrics.try_recv() {
            if col.add_metrics(m.message) == Added::New {
                events.emit("metrics", &[]);
            }
        }
        while let Some(s) = statuses.try_recv() {
            if s.message.mission_id != id {
                continue;
            }
            if s.message.role == "processor" && s.message.state == "failed" {
                bail!("the processor gave up the mission: {}", s.message.message);
            }
            events.emit(
                "status",
                &[
                    ("role", s.message.role.clone().into()),
                    ("state", s.message.state.clone().into()),
                    ("done", s.message.done.into()),
                    ("counters", json!(s.message.counters)),
                ],
            );
            if s.message.role == "processor" {
                for k in &s.message.done_items {
                    first_seen_done
                        .entry(*k as u32)
                        .or_insert_with(Instant::now);
                }
            }
            last_status.insert(s.message.role.clone(), s.message);
        }
        if progressed {
            let done = col.done();
            if done as u64 > bar.position() {
                aperture_times.push(started.elapsed().as_secs_f64());
                events.emit("aperture", &[("done", done.into()), ("total", n.into())]);
            }
            bar.set_position(done as u64);
        }
        if col.complete() {
            break false;
        }
        // ask the processor again for results it has but that did not arrive here
        if last_resend.elapsed() >= Duration::from_secs(2) {
            last_resend = Instant::now();
            let stale: Vec<u32> = col
                .missing()
                .into_iter()
                .filter(|k| {
                    first_seen_done
                        .get(k)
                        .is_some_and(|t| t.elapsed() >= Duration::from_secs(2))
                })
                .collect();
            let want_metrics = !col.has_metrics()
                && col.done() == n
                && last_status
                    .get("processor")
                    .is_some_and(|s| s.state == "done");
            if !stale.is_empty() || want_metrics {
                resend_requests += 1;
                events.emit(
                    "resend_request",
                    &[
                        ("apertures", json!(stale)),
                        ("metrics", want_metrics.into()),
                    ],
                );
                let req = ResultRequest {
                    mission_id: id,
                    apertures: stale,
                    metrics: want_metrics,
                };
                match node.query_one::<ResultRequest, ResultAck>(
                    &protocol::keys::results(id)?,
                    &req,
                    &QueryOptions {
                        timeout: Duration::from_secs(2),
                        ..QueryOptions::default()
                    },
                ) {
                    Ok(a) => {
                        tracing::info!(republished = ?a.message.republished, missing = ?a.message.missing, "results asked again")
                    }
                    Err(e) => tracing::debug!(error = %e, "asking for results again"),
                }
            }
        }
        if !progressed {
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    bar.finish_and_clear();
    if interrupted {
        col.write()?;
        return Ok(Outcome::Interrupted);
    }

    // 5. outputs
    col.write()?;
    let m = col
        .metrics()
        .cloned()
        .ok_or_else(|| anyhow!("no metrics"))?;
    let report = radar_sim::run::loop_report(&resolved, &plan.result.evaluation, m);
    radar_sim::io::write_json(&out.join("report.json"), &report)?;
    let wall_s = wall.elapsed().as_secs_f64();
    let restarts: BTreeMap<String, u32> = children
        .iter()
        .map(|c| (c.spec.role.clone(), c.restarts))
        .collect();
    let pipeline = json!({
        "mission": resolved.name(),
        "mission_id": id.to_string(),
        "apertures": n,
        "frames": ctx.layout.total_frames(),
        "frame_pulses": ctx.layout.frame_pulses(),
        "transport": format!("{:?}", args.transport).to_lowercase(),
        "router": args.router,
        "wall_s": wall_s,
        "plan_s": plan_s,
        "imaging_s": started.elapsed().as_secs_f64(),
        "aperture_done_s": aperture_times,
        "restarts": restarts,
        "collector": {"duplicates": col.duplicates, "foreign": col.foreign, "resend_requests": resend_requests,
            "detections": detections.counters().snapshot(),
            "images": images.counters().snapshot(),
            "metrics": metrics.counters().snapshot(),
            "status": statuses.counters().snapshot()},
        "services": last_status,
        "events": events.all(),
    });
    std::fs::write(
        out.join("pipeline.json"),
        serde_json::to_string_pretty(&pipeline)?,
    )
    .with_context(|| format!("writing {}", out.join("pipeline.json").display()))?;
    let widths = window_worst_widths_m(&resolved, &plan.result.evaluation);
    write_report_md(out, &resolved, &plan, &report, &widths, &pipeline, n)?;
    println_human(args, "aperture landmark  in-view  detected  SNR/dB");
    for r in &report.rows {
        println_human(
            args,
            &format!(
                "{:>8} {:>8} {:>8.2} {:>9} {:>7.1}",
                r.aperture,
                r.landmark.map(|l| l.to_string()).unwrap_or_default(),
                r.in_view_fraction,
                r.detected_label(),
                r.snr_db.unwrap_or(f64::NAN)
            ),
        );
    }
    println_human(
        args,
        &format!(
            "every landmark in view detected: {}",
            if report.all_in_view_detected {
                "yes"
            } else {
                "NO"
            }
        ),
    );
    println_human(
        args,
        &format!("wall time {wall_s:.1} s; outputs in {}", out.display()),
    );
    events.emit(
        "done",
        &[
            ("wall_s", wall_s.into()),
            ("all_in_view_detected", report.all_in_view_detected.into()),
        ],
    );
    if !report.all_in_view_detected {
        println_human(args, &missed_landmarks(&resolved, &widths, &report));
    }
    Ok(if report.all_in_view_detected || !args.strict {
        Outcome::Complete
    } else {
        Outcome::MissedLandmark
    })
}

/// Median of the plan's worst resolution-cell width (general cell, SPEC.md §4 item 12) over the
/// slots of each landmark window, m (NaN for a landmark without slots).
fn window_worst_widths_m(mission: &planner::Mission, eval: &planner::Evaluation) -> Vec<f64> {
    let n = mission.schedule().landmarks.len();
    let mut widths: Vec<Vec<f64>> = vec![Vec::new(); n];
    for (s, lm) in eval.slots.iter().zip(&mission.schedule().slot_landmark) {
        if let Some(w) = lm.and_then(|l| widths.get_mut(l)) {
            w.push(s.worst_width_m);
        }
    }
    widths
        .into_iter()
        .map(|mut w| {
            if w.is_empty() {
                return f64::NAN;
            }
            w.sort_by(f64::total_cmp);
            w[w.len() / 2]
        })
        .collect()
}

/// One line naming the in-view landmarks that were not detected and whether the plan's
/// resolution cell explains it.
fn missed_landmarks(
    mission: &planner::Mission,
    widths: &[f64],
    report: &radar_sim::run::LoopReport,
) -> String {
    let d_min = mission.params().d_min_m;
    let mut wide = 0;
    let missed: Vec<String> = report
        .rows
        .iter()
        .filter(|r| r.missed_in_view())
        .map(|r| match r.landmark.and_then(|l| widths.get(l)) {
            Some(w) if *w > d_min => {
                wide += 1;
                format!("{} (cell {w:.0} m)", r.aperture)
            }
            _ => r.aperture.to_string(),
        })
        .collect();
    let why = if wide > 0 {
        format!(
            "; a cell wider than d_min = {d_min} m (near-blind bistatic geometry, which the \
             paper's resolution criterion allows) can merge neighbouring objects"
        )
    } else {
        String::new()
    };
    format!(
        "not detected although in view: aperture(s) {}{why}; see report.md",
        missed.join(", ")
    )
}

fn println_human(args: &RunArgs, line: &str) {
    if args.events_json {
        tracing::info!("{line}");
    } else {
        println!("{line}");
    }
}

fn write_report_md(
    out: &Path,
    mission: &planner::Mission,
    plan: &Plan,
    report: &radar_sim::run::LoopReport,
    widths: &[f64],
    pipeline: &Value,
    n: usize,
) -> Result<()> {
    use std::fmt::Write as _;
    let m = &report.metrics;
    let mut s = String::new();
    let _ = writeln!(s, "# cellsar run: {}\n", mission.name());
    let _ = writeln!(
        s,
        "- plan: {} slots, energy {:.0} J (feasible {}), planned in {:.1} s",
        mission.slots(),
        plan.summary.energy_j,
        plan.summary.feasible,
        pipeline["plan_s"].as_f64().unwrap_or(f64::NAN)
    );
    let _ = writeln!(
        s,
        "- imaging: {n} apertures in {:.1} s; wall time {:.1} s",
        pipeline["imaging_s"].as_f64().unwrap_or(f64::NAN),
        pipeline["wall_s"].as_f64().unwrap_or(f64::NAN)
    );
    let _ = writeln!(s, "- detection: {}", m.detection_summary());
    let _ = writeln!(s, "- canceller: {}", m.canceller_summary());
    let _ = writeln!(
        s,
        "- every landmark in view detected: {}",
        if report.all_in_view_detected {
            "yes"
        } else {
            "NO"
        }
    );
    let _ = writeln!(s, "- restarts: {}", pipeline["restarts"]);
    let d_min = mission.params().d_min_m;
    let _ = writeln!(
        s,
        "\n\"cell\" is the median over the window's slots of the worst width of the plan's \
         resolution cell (general bistatic cell, SPEC.md §4 item 12); above d_min = {d_min} m \
         the geometry is near blind: objects d_min apart along the cell's long side fall into \
         one cell although the paper's δ_r, δ_a ≤ d_min hold (`--resolution general` plans \
         avoid this where the mission allows it)."
    );
    let _ = writeln!(
        s,
        "\n| aperture | landmark | in view | detected | SNR/dB | cell/m |\n|---:|---:|---:|:---:|---:|---:|"
    );
    for r in &report.rows {
        let w = r
            .landmark
            .and_then(|l| widths.get(l).copied())
            .unwrap_or(f64::NAN);
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | {:.1} | {:.1}{} |",
            r.aperture,
            r.landmark.map(|l| l.to_string()).unwrap_or_default(),
            r.in_view_fraction,
            match r.detected {
                Some(true) => "yes",
                Some(false) => "no",
                None => "not scored",
            },
            r.snr_db.unwrap_or(f64::NAN),
            w,
            if w > d_min { " (> d_min)" } else { "" }
        );
    }
    let _ = writeln!(s, "\nFiles: plan/, images/aperture_NNN.{{npy,png}}, detections.csv, detections.json, metrics.json, report.json, pipeline.json (timings, counters, events), logs/.");
    std::fs::write(out.join("report.md"), s)
        .with_context(|| format!("writing {}", out.join("report.md").display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plan service refuses with a typed refusal (bridge.refusal): the launcher decodes
    /// it and maps its kind to the exit code — a mission that cannot be flown 3, a bad
    /// request 2, a planner that failed 1 — whatever the message says. An error reply that
    /// is no refusal (an older or foreign planner) is a failure at run time naming the key.
    #[test]
    fn refusals_are_decoded_and_classified_by_kind() {
        use bridge::net::{decode_error_reply, WireFormat};
        let limits = DecodeLimits::default();
        let answer = |e: NetError| classify(plan_refusal(e));
        for (kind, want) in [
            (RefusalKind::Infeasible, FailureKind::Infeasible),
            (RefusalKind::BadRequest, FailureKind::BadInput),
            (RefusalKind::Internal, FailureKind::Runtime),
            (RefusalKind::Busy, FailureKind::Runtime),
        ] {
            // the text no longer decides: an internal failure that mentions infeasibility
            // stays a failure at run time
            let r = Refusal::new(kind, "planning \"m\": mission cannot be flown: slot 23");
            for format in [WireFormat::Bincode, WireFormat::Json] {
                // as a planner sends it (the lowest schema version of its kind) and in the
                // current schema version: both are decoded
                let (sent, _) = r.encode(format, Default::default()).unwrap();
                let current = format.encode(&r, Default::default()).unwrap();
                for bytes in [sent, current] {
                    let e = decode_error_reply(protocol::keys::PLAN, &bytes, format, &limits);
                    let f = answer(e);
                    assert_eq!(f.kind, want, "{kind:?} {format:?}");
                    assert_eq!(f.exit_code(), want.exit_code());
                    let text = f.to_string();
                    assert!(
                        text.contains(protocol::keys::PLAN)
                            && text.contains(kind.as_str())
                            && text.contains("slot 23"),
                        "{text}"
                    );
                }
            }
        }
        // an old planner's plain-text error: exit 1, naming the key
        let e = decode_error_reply(
            protocol::keys::PLAN,
            b"planning \"m\": mission cannot be flown: slot 23",
            WireFormat::Bincode,
            &limits,
        );
        assert!(matches!(e, NetError::Remote { .. }), "{e:?}");
        let f = answer(e);
        assert_eq!(f.kind, FailureKind::Runtime);
        assert!(f.to_string().contains(protocol::keys::PLAN), "{f}");
        // and bytes that are neither
        let e = decode_error_reply(
            protocol::keys::PLAN,
            &[0xff, 0xfe, 0x00],
            WireFormat::Bincode,
            &limits,
        );
        assert!(e.to_string().contains(protocol::keys::PLAN), "{e}");
        assert_eq!(classify(anyhow!("other")).kind, FailureKind::Runtime);
    }
}
