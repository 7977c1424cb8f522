//! `forge`: a hostile peer of the pipeline. It learns the mission ids from the keys it may
//! see (plans, statuses) and, for each, keeps publishing a forged processor status
//! `{role: "processor", state: "failed"}` and forged detections of every aperture (one
//! detection far off the scene at `FORGED_X_M`), under an instance name of its own.
//!
//! - `--malformed-images`: also an image of aperture 0 (which every mission has) whose pixel
//!   count is not `nx × ny`, claiming the live processor's instance (liveliness tokens are
//!   public on a plain mesh, so it passes the sender check and meets the consistency check);
//! - `--forge-plans`: it answers every plan request at once with a plan of another mission
//!   (planned when it starts), and publishes that plan under a mission id its content does not
//!   give (`FORGED_PLAN_ID`); it learns the requested mission's id too (a peer that may answer
//!   plan requests but see no plan);
//! - `--forge-results`: well-formed images of every aperture (`FORGED_IMAGE_PX` square, one
//!   marker) under its own instance name and, with `--metrics-template` (the `metrics.json` of
//!   the same mission, say the closed loop's), those metrics claiming `pd` = `FORGED_PD`: they
//!   agree with the real detections (same per-aperture verdicts and counts), so only the
//!   sender check tells them from the real ones;
//! - `--announce-as <role>`: its liveliness token is `cellsar/alive/<role>/<--instance>`, so
//!   the forged messages claim an instance that is alive, in another role;
//! - `--flood-plan-requests N` and the other floods: see `flood.rs`;
//! - `--forge-iq`: wrong IQ frames on the echo keys (what the bridge's certificate may put):
//!   see `iq.rs`;
//! - `--ask-echo`, `--answer-echo`, `--read-frames`: it asks the echo for an aperture (whose
//!   answer carries the mission's frame key), answers aperture requests with a frame key of its
//!   own, and subscribes to the IQ frames: see `echo.rs`;
//! - `--answer-plan-lookups`: it answers every plan lookup (`cellsar/*/plan`) with a forged
//!   plan claiming the mission looked up: see `lookups.rs`;
//! - `--mission <id>`: it forges for this mission from the start, without having to see it (a
//!   peer that the router lets see nothing).
//!
//! Besides the keys it sees, it looks up the plans any process holds at start (a mission
//! planned before it joined).
//!
//! It logs its session's Zenoh id (`forge zid <zid>`, so that a test can pick its lines out of
//! a router's log) and, every [`PROGRESS_EVERY`], what it did and received so far (`forge
//! progress <json>`, the report's fields): the samples its subscribers got and the processors
//! it saw alive tell what a router let reach it.

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::Result;
use bridge::net::{PublishOptions, TypedPublisher};
use bridge::zenoh::sample::Sample;
use bridge::zenoh::Wait;
use bridge::{MissionId, ZenohArgs};
use pipeline::protocol::{
    keys, mission_id, ApertureDetections, ApertureImage, Detection, MissionMetrics, Plan,
    PlanRequest, ServiceStatus,
};
use serde::Serialize;

use super::{ready, report, tools::z_node};

mod echo;
mod flood;
mod iq;
mod lookups;

/// The mission id the published forged plan claims (its content gives another).
pub(super) const FORGED_PLAN_ID: MissionId = MissionId(0x5eed_5eed_5eed_5eed);

/// x of the forged detection, m: far from any scene's landmarks.
pub(super) const FORGED_X_M: f64 = 987_654.0;

/// The liveliness keys of processors, up to the instance.
const PROCESSOR_ALIVE: &str = "cellsar/alive/processor/";

/// Side of a forged well-formed image, pixels.
pub(super) const FORGED_IMAGE_PX: u32 = 8;

/// The detection probability forged metrics claim.
pub(super) const FORGED_PD: f64 = 0.123_456;

/// How often the forger logs its progress.
const PROGRESS_EVERY: Duration = Duration::from_secs(2);

/// The flags of `forge`.
#[derive(clap::Args, Debug, Clone)]
pub(super) struct ForgeArgs {
    /// The instance name the forged messages claim.
    #[arg(long, default_value = "intruder")]
    instance: String,
    /// Apertures to forge detections for (0..N).
    #[arg(long, default_value_t = 16)]
    apertures: u32,
    /// Keep forging for this many seconds.
    #[arg(long, default_value = "30", value_parser = bridge::flags::parse_seconds)]
    duration_s: bridge::flags::Seconds,
    /// Pause between two rounds, ms.
    #[arg(long, default_value_t = 200)]
    interval_ms: u64,
    /// Also publish an image of aperture 0 whose pixel count differs from nx × ny.
    #[arg(long)]
    malformed_images: bool,
    /// Also answer every plan request (cellsar/plan) at once with a plan of another mission.
    #[arg(long)]
    forge_plans: bool,
    /// Also publish well-formed images of every aperture (and metrics, with
    /// --metrics-template) under the forged instance name.
    #[arg(long)]
    forge_results: bool,
    /// metrics.json of the same mission to forge metrics from (pd replaced); with
    /// --forge-results.
    #[arg(long)]
    metrics_template: Option<std::path::PathBuf>,
    /// Announce the forger alive as this role with the forged instance name (default: role
    /// "forge", instance "forge-PID").
    #[arg(long)]
    announce_as: Option<String>,
    /// Forge for this mission (16 hexadecimal digits) from the start, besides those it sees.
    #[arg(long, value_parser = parse_mission)]
    mission: Option<MissionId>,
    /// Forge at least this many rounds for the missions it knows, past --duration-s if need
    /// be (on a loaded machine the flood of plans before the first round can take all of it),
    /// for at most --max-extra-s more.
    #[arg(long, default_value_t = 0)]
    min_rounds: u64,
    /// The longest it forges past --duration-s to complete --min-rounds, s.
    #[arg(long, default_value = "600", value_parser = bridge::flags::parse_seconds)]
    max_extra_s: bridge::flags::Seconds,
    #[command(flatten)]
    flood: flood::FloodArgs,
    #[command(flatten)]
    iq: iq::IqArgs,
    #[command(flatten)]
    echo: echo::EchoArgs,
    #[command(flatten)]
    lookups: lookups::LookupArgs,
    #[command(flatten)]
    zenoh: ZenohArgs,
}

#[derive(Debug, Default, Serialize)]
struct ForgeReport {
    missions: usize,
    /// Rounds of forgeries for at least one mission.
    rounds: u64,
    statuses: u64,
    detections: u64,
    images: u64,
    metrics: u64,
    plans: u64,
    errors: u64,
    /// Samples its subscribers (plans, statuses) received about missions other than its own
    /// (those of its forged and flooded plans and `--mission`, which it publishes itself: a
    /// session receives its own publications).
    received: u64,
    /// The most processors other than itself it saw alive at once (liveliness).
    processors_seen: usize,
    flood: flood::Flooded,
    iq: iq::IqForged,
    echo: echo::EchoTried,
    lookups: lookups::LookupsAnswered,
}

fn parse_mission(s: &str) -> Result<MissionId, String> {
    MissionId::parse_hex(s).map_err(|e| e.to_string())
}

/// A plan request of a mission of its own ("forged"), small and well-formed.
fn forged_request() -> Result<PlanRequest> {
    let mission = planner::MissionFile::from_toml_str(
        "name = \"forged\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{ x_m = 0.0, \
         y_m = 0.0, from_s = 0.0, to_s = 10.0 }, { x_m = 0.0, y_m = 30.0, from_s = 10.0, to_s = \
         20.0 }]\n",
    )
    .map_err(|e| anyhow::anyhow!("the forged mission: {e}"))?;
    Ok(PlanRequest {
        mission,
        options: Default::default(),
    })
}

/// A plan of a mission of its own ("forged"), for answering plan requests.
fn forged_plan() -> Result<Plan> {
    Ok(pipeline::services::plan::plan_request(
        &forged_request()?,
        "intruder",
        &mut planner::NoObserver,
    )?)
}

fn mission_of(key: &str) -> Option<MissionId> {
    let m = key.split('/').nth(1)?;
    (m.len() == 16)
        .then(|| u64::from_str_radix(m, 16).ok())
        .flatten()
        .map(MissionId)
}

struct Forger {
    status: TypedPublisher<ServiceStatus>,
    detections: TypedPublisher<ApertureDetections>,
    /// (aperture, publisher, image).
    images: Vec<(u32, TypedPublisher<ApertureImage>, ApertureImage)>,
    metrics: Option<TypedPublisher<MissionMetrics>>,
}

/// An image of aperture `k`: with `malformed`, 8 × 8 pixels announced and 63 sent; otherwise
/// a consistent [`FORGED_IMAGE_PX`]-square image with one marker.
fn forged_image(id: MissionId, k: u32, malformed: bool, instance: &str) -> ApertureImage {
    let n = FORGED_IMAGE_PX;
    let pixels = (n * n) as usize - usize::from(malformed);
    ApertureImage {
        mission_id: id,
        aperture: k,
        nx: n,
        ny: n,
        centre_m: [FORGED_X_M, 0.0],
        spacing_m: 1.0,
        multilook: vec![1.0e3; pixels],
        markers: if malformed { Vec::new() } else { vec![(1, 1)] },
        processor: instance.to_string(),
    }
}

/// The metrics of `template` (a `metrics.json` of the same mission, so its per-aperture
/// summaries agree with the real detections) for mission `id`, claiming [`FORGED_PD`].
fn forged_metrics(
    template: &radar_sim::run::Metrics,
    id: MissionId,
    instance: &str,
) -> MissionMetrics {
    MissionMetrics {
        mission_id: id,
        apertures: template.apertures.len() as u32,
        metrics: radar_sim::run::Metrics {
            pd: FORGED_PD,
            ..template.clone()
        },
        processor: instance.to_string(),
    }
}

pub(super) fn forge(a: &ForgeArgs) -> Result<()> {
    let node = match &a.announce_as {
        Some(role) => bridge::ZenohNode::open(a.zenoh.to_config()?, role, &a.instance)?,
        None => z_node(&a.zenoh, "forge")?,
    };
    // shared with the flood of plan requests' thread
    let node = Arc::new(node);
    let template: Option<radar_sim::run::Metrics> = match &a.metrics_template {
        Some(p) => Some(serde_json::from_str(&std::fs::read_to_string(p).map_err(
            |e| anyhow::anyhow!("--metrics-template {}: {e}", p.display()),
        )?)?),
        None => None,
    };
    let base_plan = if a.forge_plans || a.flood.flood_plans > 0 || a.lookups.answer_plan_lookups {
        Some(forged_plan()?)
    } else {
        None
    };
    let flood_plans = base_plan
        .as_ref()
        .map(|p| flood::plans(p, &a.flood))
        .unwrap_or_default();
    // not the missions of its own plans
    let own: Arc<BTreeSet<MissionId>> = Arc::new(
        flood_plans
            .iter()
            .map(|p| p.mission_id)
            .chain([FORGED_PLAN_ID])
            .collect(),
    );
    // nor, for what it received, the mission it was given
    let published: BTreeSet<MissionId> = own.iter().copied().chain(a.mission).collect();
    eprintln!("forge zid {}", node.session().zid());
    let seen: Arc<Mutex<BTreeSet<MissionId>>> =
        Arc::new(Mutex::new(a.mission.into_iter().collect()));
    let received = Arc::new(std::sync::atomic::AtomicU64::new(0));
    // whatever the router lets through: plans (the echo's certificate may read them) or
    // statuses (anyone on a plain mesh)
    let mut subs = Vec::new();
    for sel in [keys::ALL_PLANS, keys::ALL_STATUS] {
        let s = seen.clone();
        let own = own.clone();
        let received = received.clone();
        let published = published.clone();
        subs.push(
            node.session()
                .declare_subscriber(sel)
                .callback(move |sample: Sample| {
                    let m = mission_of(sample.key_expr().as_str());
                    if m.is_none_or(|m| !published.contains(&m)) {
                        received.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    }
                    let id = m.filter(|id| !own.contains(id));
                    if let (Some(id), Ok(mut s)) = (id, s.lock()) {
                        s.insert(id);
                    }
                })
                .wait()
                .map_err(|e| anyhow::anyhow!("subscribing to {sel}: {e}"))?,
        );
    }
    // and the plans any process holds (a mission planned before it joined, which no service
    // announces until a processor or a client asks for it); its replies are not counted in
    // `received`
    let lookup = {
        let (node, s, own) = (node.clone(), seen.clone(), own.clone());
        std::thread::spawn(move || learn_held_plans(&node, &s, &own))
    };
    let lookups = match (a.lookups.answer_plan_lookups, &base_plan) {
        (true, Some(plan)) => Some((lookups::Lookups::declare(&node)?, plan.clone())),
        _ => None,
    };
    let plans = if let (true, Some(plan)) = (a.forge_plans, base_plan) {
        let q =
            node.queryable::<PlanRequest>(keys::PLAN, bridge::net::SubscribeOptions::default())?;
        let wrong_id = Plan {
            mission_id: FORGED_PLAN_ID,
            ..plan.clone()
        };
        let publisher = node.publisher::<Plan>(
            &keys::plan(FORGED_PLAN_ID)?,
            PublishOptions {
                mission_id: FORGED_PLAN_ID,
                ..PublishOptions::default()
            },
        )?;
        Some((q, plan, publisher, wrong_id))
    } else {
        None
    };
    let alive = node.watch_liveliness(&format!("{PROCESSOR_ALIVE}*"))?;
    ready();
    let mut r = ForgeReport::default();
    let end = Instant::now() + a.duration_s.duration();
    let requests = if a.flood.flood_plan_requests > 0 {
        let (node, base, flood) = (node.clone(), forged_request()?, a.flood.clone());
        Some(std::thread::spawn(move || {
            flood::plan_requests(&node, &base, &flood, end)
        }))
    } else {
        None
    };
    flood::publish_plans(&node, &flood_plans, &mut r.flood)?;
    drop(flood_plans);
    let mut forgers: Vec<(MissionId, Forger)> = Vec::new();
    let mut echo = echo::Echo::default();
    let mut progress = Instant::now();
    let hard_end = end + a.max_extra_s.duration();
    while Instant::now() < end || (r.rounds < a.min_rounds && Instant::now() < hard_end) {
        if let Some((l, plan)) = &lookups {
            l.answer(plan, &mut r.lookups);
        }
        if let Some((q, plan, publisher, wrong_id)) = &plans {
            match publisher.put(wrong_id) {
                Ok(_) => r.plans += 1,
                Err(_) => r.errors += 1,
            }
            while let Some(request) = q.recv_timeout(Duration::ZERO) {
                let asked = mission_id(&request.request.mission, &request.request.options);
                if let Ok(mut s) = seen.lock() {
                    s.insert(asked);
                }
                match request.reply(plan, bridge::Meta::default()) {
                    Ok(()) => {
                        r.plans += 1;
                        eprintln!("answered a plan request with a forged plan");
                    }
                    Err(_) => r.errors += 1,
                }
            }
        }
        let ids: Vec<MissionId> = seen
            .lock()
            .map(|s| s.iter().copied().collect())
            .unwrap_or_default();
        for id in ids {
            if !forgers.iter().any(|(i, _)| *i == id) {
                eprintln!("forging for mission {id}");
                let opts = PublishOptions {
                    mission_id: id,
                    ..PublishOptions::json()
                };
                let bin = PublishOptions {
                    mission_id: id,
                    ..PublishOptions::default()
                };
                let mut images = Vec::new();
                if a.malformed_images {
                    let img = forged_image(id, 0, true, &a.instance);
                    images.push((0, node.publisher(&keys::image(id, 0)?, bin)?, img));
                }
                if a.forge_results {
                    for k in 0..a.apertures {
                        let img = forged_image(id, k, false, &a.instance);
                        let key = keys::image(id, k as usize)?;
                        images.push((k, node.publisher(&key, bin)?, img));
                    }
                }
                let metrics = if a.forge_results && template.is_some() {
                    Some(node.publisher(&keys::metrics(id)?, bin)?)
                } else {
                    None
                };
                forgers.push((
                    id,
                    Forger {
                        status: node.publisher(
                            &keys::status(id, pipeline::protocol::Role::Processor)?,
                            opts,
                        )?,
                        detections: node.publisher(&keys::detections(id)?, opts)?,
                        images,
                        metrics,
                    },
                ));
            }
        }
        // the malformed images (each forger's first) claim a live processor's instance
        // not itself, announced as a processor
        let live: Vec<String> = alive
            .alive()
            .into_iter()
            .filter(|k| k.strip_prefix(PROCESSOR_ALIVE) != Some(a.instance.as_str()))
            .collect();
        r.processors_seen = r.processors_seen.max(live.len());
        let live = live.iter().find_map(|k| k.strip_prefix(PROCESSOR_ALIVE));
        if let (Some(p), true) = (live, a.malformed_images) {
            for (_, f) in forgers.iter_mut() {
                if let Some((_, _, img)) = f.images.first_mut() {
                    img.processor = p.to_string();
                }
            }
        }
        for (id, f) in &forgers {
            forge_round(*id, f, a, template.as_ref(), &mut r);
            flood::flood_queries(&node, *id, &a.flood, &mut r.flood);
            iq::forge_round(&node, *id, &a.instance, &a.iq, &mut r.iq);
            echo.round(&node, *id, &a.instance, (&a.echo, &a.iq), &mut r.echo);
        }
        if !forgers.is_empty() {
            r.rounds += 1;
        }
        r.missions = forgers.len();
        r.received = received.load(std::sync::atomic::Ordering::Relaxed);
        if progress.elapsed() >= PROGRESS_EVERY {
            eprintln!("forge progress {}", serde_json::to_string(&r)?);
            progress = Instant::now();
        }
        std::thread::sleep(Duration::from_millis(a.interval_ms));
    }
    r.missions = forgers.len();
    r.received = received.load(std::sync::atomic::Ordering::Relaxed);
    if let Some(h) = requests {
        r.flood.plan_requests = h
            .join()
            .map_err(|_| anyhow::anyhow!("the flood of plan requests panicked"))?;
    }
    drop(subs);
    drop(echo);
    drop(lookups);
    lookup
        .join()
        .map_err(|_| anyhow::anyhow!("the plan lookup panicked"))?;
    report(&r)?;
    Arc::try_unwrap(node)
        .map_err(|_| anyhow::anyhow!("the Zenoh session is still shared at the end"))?
        .close()?;
    Ok(())
}

/// Adds to `seen` the missions (not `own`) of the plans any process holds (`PlanLookup` on
/// every mission's plan key), as a late joiner would look them up; a lookup that fails (a
/// router that does not let it through) adds none.
fn learn_held_plans(
    node: &bridge::ZenohNode,
    seen: &Mutex<BTreeSet<MissionId>>,
    own: &BTreeSet<MissionId>,
) {
    let opts = bridge::net::QueryOptions {
        timeout: Duration::from_secs(2),
        target: bridge::zenoh::query::QueryTarget::All,
        limits: bridge::envelope::DecodeLimits {
            max_body_bytes: pipeline::protocol::MAX_PLAN_BYTES,
            verify_crc: true,
        },
        ..bridge::net::QueryOptions::default()
    };
    let Ok(replies) = node.query::<pipeline::protocol::PlanLookup, Plan>(
        keys::ALL_PLANS,
        &pipeline::protocol::PlanLookup {},
        &opts,
    ) else {
        return;
    };
    for r in replies.into_iter().flatten() {
        let id = r.message.mission_id;
        if let (false, Ok(mut s)) = (own.contains(&id), seen.lock()) {
            s.insert(id);
        }
    }
}

/// One round of forgeries for mission `id`: a failed processor status, detections of every
/// aperture, the images and the metrics that `f` forges.
fn forge_round(
    id: MissionId,
    f: &Forger,
    a: &ForgeArgs,
    template: Option<&radar_sim::run::Metrics>,
    r: &mut ForgeReport,
) {
    let status = ServiceStatus {
        role: pipeline::protocol::Role::Processor,
        instance: a.instance.clone(),
        mission_id: id,
        state: pipeline::protocol::ServiceState::Failed,
        message: "forged".into(),
        ..ServiceStatus::default()
    };
    match f.status.put(&status) {
        Ok(_) => r.statuses += 1,
        Err(_) => r.errors += 1,
    }
    for k in 0..a.apertures {
        let d = ApertureDetections {
            mission_id: id,
            aperture: k,
            apertures: a.apertures,
            landmark: None,
            landmark_detected: Some(true),
            landmark_snr_db: None,
            detections: vec![Detection {
                aperture: k as usize,
                x_m: FORGED_X_M,
                y_m: 0.0,
                snr_db: 99.0,
                pixels: 1,
                truth_id: None,
                error_m: None,
            }],
            false_alarms: 0,
            process_s: 0.0,
            processor: a.instance.clone(),
        };
        match f.detections.put(&d) {
            Ok(_) => r.detections += 1,
            Err(_) => r.errors += 1,
        }
    }
    for (_, p, img) in &f.images {
        match p.put(img) {
            Ok(_) => r.images += 1,
            Err(_) => r.errors += 1,
        }
    }
    if let (Some(p), Some(t)) = (&f.metrics, template) {
        match p.put(&forged_metrics(t, id, &a.instance)) {
            Ok(_) => r.metrics += 1,
            Err(_) => r.errors += 1,
        }
    }
}
