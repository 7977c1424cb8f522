//! `cellsar run`: the whole pipeline as supervised child processes.
//!
//! 1. Checks the inputs before anything starts: every option a child would refuse, the Zenoh
//!    and iceoryx2 flags, the mission and the scene (bad input: [`FailureKind::BadInput`],
//!    exit code 2), and the mission's necessary conditions of feasibility
//!    ([`FailureKind::Infeasible`], exit code 3). (The seconds options were checked when
//!    parsed, into [`Seconds`].)
//! 2. Chooses the Zenoh network ([`network`]): by default the private mesh (module `private`): the
//!    launcher and every child peers on Unix sockets in a per-run directory of mode 0700, so
//!    only the user who started the run can connect (no TCP, no multicast, no router); with
//!    `--router` a router child on such a socket and every process its client; with Zenoh flags, the
//!    launcher's flags, and children that connect to the launcher (or, for a client launcher,
//!    to the same routers). Opening the launcher's session and waiting for the children are
//!    bounded by `--peer-timeout-s`, and what it waits for is logged.
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
//!    Shared memory: only what this run made is removed (module `shm`).

mod imaging;
mod mode;
mod net;
mod outputs;
mod plan;
mod private;
mod session;
pub(crate) mod shm;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use bridge::flags::{self, Seconds};
use bridge::{FrameServiceSpec, IoxArgs, Message, NetError, Refusal, RefusalKind, ZenohArgs};
use radar_sim::config::SceneFile;

use crate::events::{Event, Events};
use crate::exit::{Failure, FailureKind};
use crate::protocol::{self, FrameLayout, Role};
use crate::services::process::MissionContext;
use crate::supervise::{stop_all, ChildSpec, Supervised};
pub use mode::OutputMode;
use net::{free_port, open_with_retry};
pub use net::{network, Hub, Net};
use outputs::Planned;
pub use private::PrivateDir;
use session::{Session, Setup};
pub use shm::node_counter_name as iox_node_counter_name;

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
    /// The plan's resolution requirement: `general` (the default: the worst width of the true
    /// bistatic cell ≤ d_min in every landmark slot, or the best effort where the geometry
    /// does not allow it) or `paper` (the paper's δ_r, δ_a ≤ d_min, the least-energy plan);
    /// top-level docs/user-guide.md, "Resolution". Sent with the plan request;
    /// `cellsar-radar-sim closed-loop --resolution` gives the same results.
    #[arg(long, default_value_t = planner::DEFAULT_RESOLUTION, value_parser = crate::args::enum_parser::<planner::evaluate::ResolutionMode>())]
    pub resolution: planner::evaluate::ResolutionMode,
    /// Under `general`: refuse a mission whose cell cannot be held within d_min in every
    /// landmark slot (the planner's refusal, exit 3) instead of planning the best effort.
    #[arg(long)]
    pub strict_resolution: bool,
    /// The plan's vehicle model: `vehicle` (the default: the velocity changes by at most the
    /// mission's `max_accel_mps2` × δ from slot to slot, and by half that from its
    /// `start_velocity_mps` into the first slot) or
    /// `paper` (the velocity may jump, as in the paper); top-level docs/user-guide.md,
    /// "Vehicle limits". Sent with the plan request.
    #[arg(long, default_value_t = planner::Scheme::Exact.default_dynamics(), value_parser = crate::args::enum_parser::<planner::Dynamics>())]
    pub dynamics: planner::Dynamics,
    /// How IQ frames reach the processor.
    #[arg(long, value_enum, default_value_t = Transport::Iox)]
    pub transport: Transport,
    /// Start the bridge (iceoryx2 -> Zenoh) even with `--transport iox`.
    #[arg(long)]
    pub bridge: bool,
    /// Start a Zenoh router child; every process is its client (refused with `-m`, `-e`, `-l`
    /// or `-c`, which it would not use).
    #[arg(long)]
    pub router: bool,
    /// Do not start this role (planner, echo, processor, bridge): it runs elsewhere (another
    /// host, a container) and is found on the Zenoh network. Repeatable.
    #[arg(long = "external", value_name = "ROLE", value_parser = crate::args::role_parser(&Role::CHILDREN))]
    pub external: Vec<Role>,
    /// The Zenoh configuration file of the children of one role, instead of the launcher's
    /// `-c` (`ROLE=FILE`, ROLE one of planner, echo, processor, bridge): a deployment with a
    /// certificate per role (`pipeline/deploy/tls/`). Repeatable.
    #[arg(long = "child-config", value_name = "ROLE=FILE", value_parser = net::parse_child_config)]
    pub child_config: Vec<(Role, PathBuf)>,
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
    /// The processor asks again for an aperture after this many seconds without frames (after
    /// 1 s, if shorter, once frames were lost in transport since the request).
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
    /// Longest wait for a peer, s: for the launcher's Zenoh session to open (a router or peer
    /// to answer), and, while imaging, for the echo and the processor (and the bridge with
    /// `--transport zenoh`) to announce themselves when none is up; then the run fails, exit
    /// code 1, naming what it waited for and the session's endpoints. What it waits for is
    /// logged from 2 s on.
    #[arg(long, default_value = "60", value_parser = flags::parse_seconds)]
    pub peer_timeout_s: Seconds,
    /// Print events (children started/exited, liveliness, apertures) as JSON lines on stdout.
    #[arg(long)]
    pub events_json: bool,
    /// Keep the services' state directory (`.state/`) after a successful run.
    #[arg(long)]
    pub keep_state: bool,
    /// Who may read what the run writes (outputs, logs, state): `private`, the user who
    /// started it only (directories 0700, files 0600: umask 077 for the launcher and its
    /// children), or `umask`, as the caller's umask says. An output directory that exists
    /// already keeps its mode.
    #[arg(long, value_enum, default_value_t = OutputMode::Private)]
    pub output_mode: OutputMode,
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
    /// What kind of failure the refusal is: a mission that cannot be flown exits 3, a plan not
    /// found 5, a request the planner found invalid 2, a planner that failed 1, a planner that stayed busy (its
    /// request queue full each time it was asked) 1.
    pub fn failure_kind(&self) -> FailureKind {
        match self.refusal.kind {
            RefusalKind::Infeasible => FailureKind::Infeasible,
            RefusalKind::BadRequest => FailureKind::BadInput,
            RefusalKind::NotFound => FailureKind::PlanNotFound,
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
    crate::args::check_best_effort_flags(&planner::PlanOptions {
        resolution: args.resolution,
        strict_resolution: args.strict_resolution,
        ..Default::default()
    })
    .map_err(Failure::bad_input)?;
    if args.window == 0 {
        return Err(Failure::bad_input(anyhow!(
            "--window 0: must be at least 1 (apertures the processor asks for at once)"
        )));
    }
    tracing_subscriber::EnvFilter::try_new(&args.child_log)
        .map_err(|e| Failure::bad_input(anyhow!("--child-log {:?}: {e}", args.child_log)))?;
    args.zenoh.to_config().map_err(Failure::bad_input)?;
    // every process's flags as the run would give them (any free port and directory stand
    // for the hub's)
    let hub = Hub {
        tcp_port: 7447,
        private_dir: std::env::temp_dir().join("cellsar-mesh"),
    };
    let net =
        network(args.router, &args.zenoh, &hub).map_err(|e| Failure::bad_input(anyhow!(e)))?;
    for z in [Some(&net.launcher), Some(&net.child), net.router.as_ref()]
        .into_iter()
        .flatten()
    {
        z.to_config().map_err(Failure::bad_input)?;
    }
    // with TLS or access control, each child the launcher starts has a configuration of its own
    let started: Vec<Role> = Role::CHILDREN
        .into_iter()
        .filter(|r| !args.external.contains(r))
        .filter(|r| *r != Role::Bridge || args.transport == Transport::Zenoh || args.bridge)
        .collect();
    net::check_secure_children(&args.zenoh, &net.child, &started, &args.child_config)
        .map_err(|e| Failure::bad_input(anyhow!(e)))?;
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
    planner::init::precheck_with(&mission, args.dynamics)
        .with_context(|| format!("mission {}", args.mission.display()))
        .map_err(Failure::infeasible)?;
    Ok(mission)
}

/// The error of a plan query the planner answered with an error reply: a typed refusal is a
/// [`PlanRefused`] (its kind picks the exit code, [`classify`]); an error reply that is no
/// refusal (an older or foreign planner) a failure at run time, naming the key.
pub(crate) fn plan_refusal(e: NetError) -> anyhow::Error {
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
    // before anything is created: the children inherit it
    mode::apply(args.output_mode);
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
    let own_iox = args.iox.root.is_none() && args.iox.prefix.is_none() && args.iox.config.is_none();
    let iox = if own_iox {
        shm::clean_dead_runs();
        let prefix = shm::own_prefix();
        // before any iceoryx2 node: iceoryx2 would make it writable by every user
        shm::claim_node_counter(&prefix).with_context(|| {
            format!("creating the run's iceoryx2 node counter (prefix {prefix})")
        })?;
        IoxArgs {
            root: Some(state.join("iox")),
            prefix: Some(prefix),
            config: None,
        }
    } else {
        args.iox.clone()
    };
    let mut children: Vec<Supervised> = Vec::new();
    let spec = |role: Role, a: Vec<String>| ChildSpec {
        role,
        exe: exe.clone(),
        args: a,
        log: logs.join(format!("{role}.log")),
        rust_log: Some(args.child_log.clone()),
    };
    // the private mesh's sockets, removed with their directory when the run ends
    let private_dir = PrivateDir::create()?;
    let hub = Hub {
        tcp_port: free_port()?,
        private_dir: private_dir.path().to_path_buf(),
    };
    let net = network(args.router, &args.zenoh, &hub).map_err(|e| anyhow!(e))?;
    if let Some(router) = &net.router {
        let mut ra = vec!["router".to_string(), "--instance".into(), "router".into()];
        ra.extend(router.to_cli_args());
        children.push(Supervised::start(spec(Role::Router, ra), &events)?);
    }
    events.emit(&Event::Network {
        launcher: net.launcher.to_cli_args(),
        children: net.child.to_cli_args(),
        iox: iox.to_cli_args(),
    });
    // 3.-5. the run on the launcher's Zenoh session; then one clean-up, however it ended
    // (SIGINT/SIGTERM while the session opens included)
    let (node, result) = match open_with_retry(&net.launcher, &stop, args.peer_timeout_s.duration())
    {
        Ok(Some(node)) => {
            let setup = Setup {
                args,
                out: &out,
                state: &state,
                scene: &scene_path,
                net: &net,
                iox: &iox,
                events: &events,
                stop: &stop,
                spec: &spec,
                wall,
            };
            let result =
                Session::open(setup, &node, &mut children).and_then(|s| run_on(s, mission));
            (Some(node), result)
        }
        Ok(None) => (None, Ok(Outcome::Interrupted)),
        Err(_) if stop.load(Ordering::Relaxed) => (None, Ok(Outcome::Interrupted)),
        Err(e) => (None, Err(e)),
    };
    if matches!(result, Ok(Outcome::Interrupted)) {
        events.emit(&Event::Interrupted);
    }
    stop_all(&mut children, Duration::from_secs(10), &events);
    if let Some(node) = node {
        if let Err(e) = node.close() {
            tracing::debug!(error = %e, "closing the launcher's session");
        }
    }
    shm::clean_after(&iox, own_iox);
    if let Ok(o) = &result {
        if *o != Outcome::Interrupted && !args.keep_state {
            let _ = std::fs::remove_dir_all(&state);
        }
    }
    result
}

/// The run on the launcher's session: the children, the plan, the collection, the outputs.
fn run_on(mut s: Session<'_>, mission: &planner::Mission) -> Result<Outcome> {
    s.start_children()?;
    let plan_started = Instant::now();
    let Some(plan) = s.request_plan(mission)? else {
        return Ok(Outcome::Interrupted);
    };
    let plan_s = plan_started.elapsed().as_secs_f64();
    let id = plan.mission_id;
    let resolved = plan.mission()?;
    let plan_dir = s.setup.out.join("plan");
    crate::report::write_plan_dir(&plan_dir, &resolved, &plan.result)
        .with_context(|| format!("writing {}", plan_dir.display()))?;
    let scene = SceneFile::from_path(s.setup.scene)?;
    let ctx = MissionContext::new(&Arc::new(plan.clone()), &scene, s.args().max_frame_bytes)?;
    let n = ctx.apertures.len();
    s.say(&format!(
        "planned {} slots in {plan_s:.1} s: energy {:.0} J, feasible {}; mission {id}, {n} apertures, {} frames of {} pulses",
        resolved.slots(),
        plan.summary.energy_j,
        plan.summary.feasible,
        ctx.layout.total_frames(),
        ctx.layout.frame_pulses()
    ));
    s.setup.events.emit(&Event::Planned {
        mission_id: id.to_string(),
        apertures: n,
        frames: ctx.layout.total_frames(),
        frame_pulses: ctx.layout.frame_pulses(),
        plan_s,
    });
    s.start_bridge(id)?;
    let collected = s.collect(id, n)?;
    if collected.interrupted {
        collected.col.write()?;
        return Ok(Outcome::Interrupted);
    }
    let planned = Planned {
        plan: &plan,
        mission: &resolved,
        ctx: &ctx,
        plan_s,
    };
    s.finish(&planned, &collected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bridge::envelope::DecodeLimits;

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
            (RefusalKind::NotFound, FailureKind::PlanNotFound),
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
